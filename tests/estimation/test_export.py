import numpy as np
import pytest

from ucope.errors import DataError, InputError
from ucope.estimation.export import BOP_CSV_HEADER, BopRow, bop_rows, frame_bop_rows, read_bop_csv, write_bop_csv
from ucope.estimation.result import JointEstimate, PartEstimate, PoseResult
from ucope.geometry.transforms import random_rotation


def _result(rng, K=2, total_ms=40.0) -> PoseResult:
    parts = []
    for k in range(K):
        T = np.eye(4)
        T[:3, :3] = random_rotation(rng)
        T[:3, 3] = [0.1 * k, -0.05, 1.2]
        parts.append(PartEstimate(k, f"p{k}", T, np.array([0.3, 0.02, 0.2]), 0.9 - 0.1 * k))
    joints = [JointEstimate("revolute", 0, k, np.zeros(3), np.array([1.0, 0, 0]), 0.5) for k in range(1, K)]
    return PoseResult("x", parts, joints, np.zeros(5, np.int64), timings_ms={"total": total_ms})


def test_rows_map_part_k_to_base_plus_k_in_millimetres(rng, tmp_path):
    r = _result(rng)
    rows = bop_rows(r, scene_id=3, im_id=12, obj_id=5)
    assert [row.obj_id for row in rows] == [5, 6]
    np.testing.assert_allclose(rows[1].t_mm, [100.0, -50.0, 1200.0])
    assert rows[0].time_s == pytest.approx(0.04) and rows[0].score == pytest.approx(0.9)
    path = write_bop_csv(tmp_path / "sub" / "res.csv", rows)
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(BOP_CSV_HEADER)
    fields = lines[1].split(",")
    assert fields[:3] == ["3", "12", "5"] and len(fields[4].split()) == 9 and len(fields[5].split()) == 3
    back = read_bop_csv(path)
    np.testing.assert_allclose(back[0].R, r.parts[0].cam_from_part[:3, :3], atol=1e-6)  # row-wise
    np.testing.assert_allclose(back[1].t_mm, rows[1].t_mm, atol=1e-6)


def test_one_time_per_image_the_sum_of_its_objects(rng, tmp_path):
    a, b = _result(rng, 1, 30.0), _result(rng, 2, 45.0)
    rows = frame_bop_rows([(a, 1), (b, 2)], scene_id=0, im_id=4)
    assert [r.obj_id for r in rows] == [1, 2, 3] and [r.time_s for r in rows] == pytest.approx([0.075] * 3)
    with pytest.raises(InputError, match="one time per image"):
        write_bop_csv(tmp_path / "x.csv", bop_rows(a, 0, 4) + bop_rows(b, 0, 4))
    assert bop_rows(PoseResult("x", a.parts, [], np.zeros(1)), 0, 0)[0].time_s == -1.0


def test_bad_ids_and_files(rng, tmp_path):
    r = _result(rng)
    with pytest.raises(InputError, match="obj_id must be a positive integer"):
        bop_rows(r, 0, 0, obj_id=0)
    with pytest.raises(InputError, match="im_id must be a non-negative integer"):
        bop_rows(r, 0, -1)
    with pytest.raises(DataError, match="does not exist"):
        read_bop_csv(tmp_path / "none.csv")
    (tmp_path / "bad.csv").write_text("a,b\n")
    with pytest.raises(DataError, match="header"):
        read_bop_csv(tmp_path / "bad.csv")
    write_bop_csv(tmp_path / "ok.csv", [BopRow(0, 0, 1, 0.5, np.eye(3), np.zeros(3))])
    text = (tmp_path / "ok.csv").read_text().replace("0.000000 0.000000 0.000000,", "0 0,")
    (tmp_path / "short.csv").write_text(text)
    with pytest.raises(DataError, match=r"short\.csv, line 2: R needs 9 values and t 3"):
        read_bop_csv(tmp_path / "short.csv")


# --------------------------------------------------------------------------------------------------
# obj_id map, ROS messages, URDF, geometry, rerun
# --------------------------------------------------------------------------------------------------


def test_several_objects_get_their_own_obj_ids_and_a_map(rng, tmp_path):
    import json

    from ucope.estimation.export import obj_id_map_path

    laptop, mug = _result(rng, 2), _result(rng, 1)
    rows = frame_bop_rows([(laptop, 1, "1: laptop"), (mug, 2, "2: mug")], scene_id=0, im_id=42, base=1)
    assert [(r.obj_id, r.object, r.part) for r in rows] == [(1, "1: laptop", "p0"), (2, "1: laptop", "p1"), (3, "2: mug", "p0")]
    path = write_bop_csv(tmp_path / "res.csv", rows)
    doc = json.loads(obj_id_map_path(path).read_text())
    assert obj_id_map_path(path).name == "res.obj_ids.json" and doc["csv"] == "res.csv"
    assert [(e["obj_id"], e["object"], e["part"]) for e in doc["obj_ids"]] == [
        (1, "1: laptop", "p0"),
        (2, "1: laptop", "p1"),
        (3, "2: mug", "p0"),
    ]
    # the old rule (part k = the object's own base + k) made the laptop's lid and the mug share obj_id 2: refused
    clash = frame_bop_rows([(laptop, 1, "1: laptop"), (mug, 2, "2: mug")], scene_id=0, im_id=42)
    with pytest.raises(InputError, match=r"obj_id 2 would stand for both 1: laptop 'p1' and 2: mug 'p0'"):
        write_bop_csv(tmp_path / "clash.csv", clash)


# Field lists of the ROS 2 message definitions (vision_msgs 4.1 ros2 branch: Detection3DArray.msg, Detection3D.msg,
# ObjectHypothesisWithPose.msg, ObjectHypothesis.msg, BoundingBox3D.msg; common_interfaces rolling: std_msgs/Header,
# geometry_msgs/Pose, Point, Quaternion, Vector3, PoseWithCovariance, Transform, TransformStamped,
# sensor_msgs/JointState; tf2_msgs/TFMessage; builtin_interfaces/Time), written out here from those files.
MSG = {
    "vision_msgs/Detection3DArray": {"header": "std_msgs/Header", "detections": "vision_msgs/Detection3D[]"},
    "vision_msgs/Detection3D": {
        "header": "std_msgs/Header",
        "results": "vision_msgs/ObjectHypothesisWithPose[]",
        "bbox": "vision_msgs/BoundingBox3D",
        "id": "string",
    },
    "vision_msgs/ObjectHypothesisWithPose": {
        "hypothesis": "vision_msgs/ObjectHypothesis",
        "pose": "geometry_msgs/PoseWithCovariance",
    },
    "vision_msgs/ObjectHypothesis": {"class_id": "string", "score": "float64"},
    "vision_msgs/BoundingBox3D": {"center": "geometry_msgs/Pose", "size": "geometry_msgs/Vector3"},
    "std_msgs/Header": {"stamp": "builtin_interfaces/Time", "frame_id": "string"},
    "builtin_interfaces/Time": {"sec": "int32", "nanosec": "uint32"},
    "geometry_msgs/PoseWithCovariance": {"pose": "geometry_msgs/Pose", "covariance": "float64[36]"},
    "geometry_msgs/Pose": {"position": "geometry_msgs/Point", "orientation": "geometry_msgs/Quaternion"},
    "geometry_msgs/Point": {"x": "float64", "y": "float64", "z": "float64"},
    "geometry_msgs/Vector3": {"x": "float64", "y": "float64", "z": "float64"},
    "geometry_msgs/Quaternion": {"x": "float64", "y": "float64", "z": "float64", "w": "float64"},
    "tf2_msgs/TFMessage": {"transforms": "geometry_msgs/TransformStamped[]"},
    "geometry_msgs/TransformStamped": {
        "header": "std_msgs/Header",
        "child_frame_id": "string",
        "transform": "geometry_msgs/Transform",
    },
    "geometry_msgs/Transform": {"translation": "geometry_msgs/Vector3", "rotation": "geometry_msgs/Quaternion"},
    "sensor_msgs/JointState": {
        "header": "std_msgs/Header",
        "name": "string[]",
        "position": "float64[]",
        "velocity": "float64[]",
        "effort": "float64[]",
    },
}


def _check_msg(value, msg_type: str, where: str) -> None:
    """``value`` has exactly the fields of ``msg_type``, recursively, with values of the fields' types."""
    import re

    base, array = re.fullmatch(r"([\w/]+)(\[(\d*)\])?", msg_type).group(1, 2)
    if array:
        assert isinstance(value, list), where
        n = re.fullmatch(r"\[(\d*)\]", array).group(1)
        assert not n or len(value) == int(n), (where, len(value))
        for i, v in enumerate(value):
            _check_msg(v, base, f"{where}[{i}]")
        return
    if base in MSG:
        assert isinstance(value, dict) and set(value) == set(MSG[base]), (where, sorted(value), sorted(MSG[base]))
        for k, t in MSG[base].items():
            _check_msg(value[k], t, f"{where}.{k}")
    elif base == "string":
        assert isinstance(value, str), where
    elif base in ("int32", "uint32"):
        assert isinstance(value, int) and not isinstance(value, bool) and (base == "int32" or value >= 0), where
    else:
        assert isinstance(value, float) and np.isfinite(value), where


def test_to_ros_has_the_message_fields_and_the_parts_poses(rng):
    from scipy.spatial.transform import Rotation

    r = _result(rng, 2)
    msgs = r.to_ros(frame_id="camera_color_optical_frame", stamp=12.25, prefix="laptop/")
    _check_msg(msgs["detections"], "vision_msgs/Detection3DArray", "detections")
    _check_msg(msgs["transforms"], "tf2_msgs/TFMessage", "transforms")
    _check_msg(msgs["joint_state"], "sensor_msgs/JointState", "joint_state")
    det = msgs["detections"]["detections"][1]
    assert det["header"] == {"stamp": {"sec": 12, "nanosec": 250_000_000}, "frame_id": "camera_color_optical_frame"}
    assert det["results"][0]["hypothesis"] == {"class_id": "x/p1", "score": pytest.approx(0.8)}
    c = det["bbox"]["center"]
    q = [c["orientation"][k] for k in "xyzw"]
    np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), r.parts[1].cam_from_part[:3, :3], atol=1e-12)
    np.testing.assert_allclose([c["position"][k] for k in "xyz"], r.parts[1].cam_from_part[:3, 3])
    assert [det["bbox"]["size"][k] for k in "xyz"] == pytest.approx([0.3, 0.02, 0.2])
    assert msgs["transforms"]["transforms"][1]["child_frame_id"] == "laptop/p1"
    assert msgs["joint_state"]["name"] == ["laptop/p0_to_p1"] and msgs["joint_state"]["position"] == [0.5]


def _articulated(kind: str) -> PoseResult:
    """A drawer-like (prismatic) or laptop-like (revolute, pivot off the child's centre) estimate, posed
    at a state away from 0."""
    from ucope.geometry.transforms import axis_angle_transform

    rng = np.random.default_rng(3)
    base = np.eye(4)
    base[:3, :3] = random_rotation(rng)
    base[:3, 3] = [0.05, 0.1, 0.9]
    axis = base[:3, :3] @ np.array([1.0, 0.0, 0.0])
    child0 = base.copy()
    child0[:3, 3] += base[:3, :3] @ np.array([0.0, 0.05, -0.1])
    if kind == "revolute":
        pivot = base[:3, 3] + base[:3, :3] @ np.array([0.0, 0.01, -0.15])
        state = 1.1
        child = axis_angle_transform(axis, pivot, state) @ child0
    else:
        pivot, state = None, 0.12
        child = child0.copy()
        child[:3, 3] += state * axis
    return PoseResult(
        "laptop" if kind == "revolute" else "thing",
        [
            PartEstimate(0, "base", base, np.array([0.3, 0.02, 0.2]), 0.9),
            PartEstimate(1, "lid", child, np.array([0.3, 0.2, 0.01]), 0.8),
        ],
        [JointEstimate(kind, 0, 1, pivot, axis, state, 0.9)],
        np.zeros(3, np.int64),
    )


@pytest.mark.parametrize("kind", ["revolute", "prismatic"])
@pytest.mark.parametrize("root", ["camera", "object"])
def test_urdf_loads_back_to_the_part_poses_at_the_estimated_state(tmp_path, kind, root):
    yourdfpy = pytest.importorskip("yourdfpy")
    from ucope.geometry.transforms import invert_transform

    r = _articulated(kind)
    path = r.to_urdf(tmp_path / f"{kind}.urdf", root=root)
    urdf = yourdfpy.URDF.load(str(path))
    joint = urdf.joint_map["base_to_lid"]
    assert joint.type == kind and joint.limit.lower <= r.joints[0].state <= joint.limit.upper
    urdf.update_cfg({"base_to_lid": r.joints[0].state})
    frame = "camera" if root == "camera" else "base"
    ref = np.eye(4) if root == "camera" else invert_transform(r.parts[0].cam_from_part)
    for p in r.parts:
        T = urdf.get_transform(frame_to=p.label, frame_from=frame)
        np.testing.assert_allclose(T, ref @ p.cam_from_part, atol=1e-6)
    boxes = {name: link.visuals[0].geometry.box.size for name, link in urdf.link_map.items() if link.visuals}
    np.testing.assert_allclose(boxes["lid"], r.parts[1].size_m)
    # at state 0 the child sits where the estimate's motion started: turned / slid back
    urdf.update_cfg({"base_to_lid": 0.0})
    moved = urdf.get_transform(frame_to="lid", frame_from=frame)
    assert np.abs(moved - ref @ r.parts[1].cam_from_part).max() > 0.05
    with pytest.raises(InputError, match="limits must be 1 finite"):
        r.to_urdf(tmp_path / "x.urdf", limits=[(1.0, 0.0)])


def test_geometry_glb_and_ply(tmp_path):
    import trimesh

    r = _articulated("revolute")
    pts = np.random.default_rng(0).normal([0.05, 0.1, 0.9], 0.05, (3, 3))
    scene = trimesh.load(r.to_mesh(tmp_path / "r.glb", points=pts))
    assert len(scene.geometry) == 4  # two boxes, one joint axis, the cloud
    mesh = trimesh.load(r.to_mesh(tmp_path / "r.ply"))
    assert len(mesh.faces) > 24 and mesh.visual.kind in ("face", "vertex")
    with pytest.raises(InputError, match=r"\.glb, \.ply or \.obj"):
        r.to_mesh(tmp_path / "r.stl")


def test_rerun_recording_or_a_clear_message(tmp_path, monkeypatch):
    import importlib.util
    import sys

    r = _articulated("revolute")
    if importlib.util.find_spec("rerun") is None:
        with pytest.raises(InputError, match="pip install rerun-sdk"):
            r.to_rrd(tmp_path / "r.rrd")
        return
    from rerun.chunk import RrdReader

    path = r.to_rrd(tmp_path / "r.rrd", points=np.zeros((4, 3)) + [0, 0, 1])
    assert path.read_bytes()[:4] == b"RRF2"
    entities = {c.entity_path for c in RrdReader(path).stream()}
    assert {"/camera/object_0/boxes", "/camera/object_0/joints", "/camera/object_0/points"} <= entities
    monkeypatch.setitem(sys.modules, "rerun", None)
    with pytest.raises(InputError, match="pip install rerun-sdk"):
        r.to_rrd(tmp_path / "x.rrd")
