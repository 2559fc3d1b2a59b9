"""Results for a robot stack: ROS 2 messages as plain dicts, a URDF of the estimated object, its geometry
(GLB / PLY / OBJ) and a rerun recording (``.rrd``). :mod:`ucope.estimation.export` re-exports them.

* :func:`to_ros`: ``vision_msgs/Detection3DArray``, ``tf2_msgs/TFMessage`` and ``sensor_msgs/JointState``
  as dicts with the messages' field names (no ROS needed; fill the messages with them);
* :func:`write_urdf`: the object as a URDF (parts as boxes, joints with the estimated axis, pivot and
  limits) for a planner or a simulator; :func:`urdf_names` gives its link and joint names;
* :func:`write_geometry`: boxes, joint axes and points as a GLB (or PLY / OBJ) file, through trimesh;
* :func:`write_rrd`: a rerun recording, with ``pip install rerun-sdk``.

Frames and units: camera frame (OpenCV: x right, y down, z forward), metres, radians.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import InputError
from ..fileio import atomic_write_bytes, atomic_write_text
from ..geometry.transforms import axis_angle_transform, invert_transform
from ..versions import __version__
from .draw_scene import PART_PALETTE
from .result import PoseResult

__all__ = ["to_ros", "write_urdf", "urdf_names", "write_geometry", "write_rrd"]


# --------------------------------------------------------------------------------------------------
# ROS 2 messages as plain dicts
# --------------------------------------------------------------------------------------------------


def _quaternion_xyzw(R: np.ndarray) -> list[float]:
    from scipy.spatial.transform import Rotation

    return [float(v) for v in Rotation.from_matrix(np.asarray(R, np.float64)).as_quat()]


def _pose_msg(T: np.ndarray) -> dict:
    """``geometry_msgs/Pose`` of a 4x4 transform."""
    x, y, z = (float(v) for v in T[:3, 3])
    qx, qy, qz, qw = _quaternion_xyzw(T[:3, :3])
    return {"position": {"x": x, "y": y, "z": z}, "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}


def urdf_names(result: PoseResult) -> tuple[list[str], list[str]]:
    """``(link names, joint names)`` that :func:`write_urdf` and :func:`to_ros` give the parts and joints:
    the part labels (made unique and URDF-safe), and ``<parent>_to_<child>`` per joint."""
    links: list[str] = []
    for k, p in enumerate(result.parts):
        n = re.sub(r"[^A-Za-z0-9_]+", "_", str(p.label)).strip("_") or f"part_{k}"
        links.append(n if n not in links else f"{n}_{k}")
    joints = [f"{links[j.parent]}_to_{links[j.child]}" for j in result.joints]
    return links, joints


def to_ros(result: PoseResult, frame_id: str = "camera", stamp: float | None = None, prefix: str = "") -> dict:
    """The result as plain dicts with the field names of ROS 2 messages (no ROS dependency).

    Returns ``{"detections": <vision_msgs/Detection3DArray>, "transforms": <tf2_msgs/TFMessage>,
    "joint_state": <sensor_msgs/JointState>}``:

    * one ``Detection3D`` per part: ``bbox.center`` = the part's pose (its box is centred on it),
      ``bbox.size`` = ``size_m``; one ``ObjectHypothesisWithPose`` with ``class_id`` =
      ``"<category>/<part label>"``, ``score`` = the part's score and the same pose (covariance all zero:
      not estimated); ``id`` = the part's frame name;
    * one ``geometry_msgs/TransformStamped`` per part, ``frame_id`` -> ``<prefix><part link name>``;
    * one ``JointState`` entry per joint, named ``<prefix><parent>_to_<child>`` (the joint names of
      :func:`write_urdf`, so that the URDF and this state drive a ``robot_state_publisher``), position
      in radians / metres; ``velocity`` and ``effort`` empty.

    Every header has ``stamp`` (``{"sec", "nanosec"}`` of ``stamp`` seconds, default 0) and ``frame_id``
    (the camera's optical frame: x right, y down, z forward, as ucope's camera frame). Lengths in
    metres, quaternions ``(x, y, z, w)``.
    """
    t = 0.0 if stamp is None else float(stamp)
    if not np.isfinite(t) or t < 0:
        raise InputError(f"stamp must be a non-negative number of seconds, got {stamp!r}")
    sec = int(np.floor(t))
    header = {"stamp": {"sec": sec, "nanosec": int(round((t - sec) * 1e9)) % 1_000_000_000}, "frame_id": str(frame_id)}
    links, joints = urdf_names(result)
    detections, transforms = [], []
    for p, link in zip(result.parts, links, strict=True):
        T = np.asarray(p.cam_from_part, np.float64)
        pose = _pose_msg(T)
        sx, sy, sz = (float(v) for v in np.asarray(p.size_m, np.float64))
        detections.append(
            {
                "header": dict(header),
                "results": [
                    {
                        "hypothesis": {"class_id": f"{result.category}/{p.label}", "score": float(p.score)},
                        "pose": {"pose": pose, "covariance": [0.0] * 36},
                    }
                ],
                "bbox": {"center": pose, "size": {"x": sx, "y": sy, "z": sz}},
                "id": f"{prefix}{link}",
            }
        )
        transforms.append(
            {
                "header": dict(header),
                "child_frame_id": f"{prefix}{link}",
                "transform": {
                    "translation": dict(pose["position"]),
                    "rotation": dict(pose["orientation"]),
                },
            }
        )
    joint_state = {
        "header": dict(header),
        "name": [f"{prefix}{n}" for n in joints],
        "position": [float(j.state) for j in result.joints],
        "velocity": [],
        "effort": [],
    }
    return {
        "detections": {"header": dict(header), "detections": detections},
        "transforms": {"transforms": transforms},
        "joint_state": joint_state,
    }


# --------------------------------------------------------------------------------------------------
# URDF
# --------------------------------------------------------------------------------------------------


def _joint_motion(j, state: float) -> np.ndarray:
    """The camera-frame motion of a joint's child from state 0 to ``state``."""
    a = np.asarray(j.axis, np.float64)
    a = a / np.linalg.norm(a)
    if j.type == "revolute":
        return axis_angle_transform(a, np.asarray(j.pivot_m, np.float64), float(state))
    M = np.eye(4)
    M[:3, 3] = float(state) * a
    return M


def _default_limits(result: PoseResult) -> list[tuple[float, float]]:
    """The category's joint limits (its generator's first test instance), or +-pi / +-the object's size."""
    from ..errors import UcopeError

    try:
        from ..objects.categories import make_instance

        proto = make_instance(result.category, "test", 0)
        if proto.num_parts == len(result.parts) and len(proto.joints) == len(result.joints):
            return [tuple(float(v) for v in j.limits) for j in proto.joints]
    except (UcopeError, KeyError, ValueError):
        pass
    reach = 2.0 * float(np.linalg.norm(result.size_m, axis=1).max())
    return [(-np.pi, np.pi) if j.type == "revolute" else (-reach, reach) for j in result.joints]


def _xyz_rpy(T: np.ndarray) -> str:
    from scipy.spatial.transform import Rotation

    xyz = " ".join(f"{v:.12g}" for v in T[:3, 3])
    rpy = " ".join(f"{v:.12g}" for v in Rotation.from_matrix(T[:3, :3]).as_euler("xyz"))  # URDF: fixed-axis roll, pitch, yaw
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def write_urdf(result: PoseResult, path: str | os.PathLike, name: str | None = None, limits=None, root: str = "camera") -> Path:
    """Write the estimated object as a URDF file: every part a link with its box (visual, collision and
    a nominal inertia of 500 kg/m^3), every joint with the estimated type, axis, pivot and limits.

    Links are named after the parts (:func:`urdf_names`) and their frames are the part frames; joints are
    ``<parent>_to_<child>``. URDF joints are defined at state 0, so the file holds the object at the
    estimated configuration when its joints are set to ``result.joint_state`` (radians / metres): then
    every part link's pose is the result's ``cam_from_part`` (``root="camera"``: the root link
    ``camera`` is the camera frame and a fixed joint places part 0) or ``inv(cam_from_part[0]) @
    cam_from_part[k]`` (``root="object"``: part 0 is the root). A revolute joint turns about its
    pivot through a link ``<child>_hinge`` placed on the axis, fixed to the child's link.

    Args:
        limits: ``[(lower, upper)]`` per joint (radians / metres); default the category's limits when
            ucope knows the category, else +-pi (revolute) and +-twice the largest part diagonal
            (prismatic); widened to hold the estimated state.
        root: ``"camera"`` or ``"object"``.

    Raises :class:`InputError` for a bad ``root`` / ``limits`` or a joint tree not rooted at part 0.
    """
    if root not in ("camera", "object"):
        raise InputError(f"root must be 'camera' or 'object', got {root!r}")
    links, jnames = urdf_names(result)
    J = len(result.joints)
    lim = _default_limits(result) if limits is None else [tuple(float(v) for v in pair) for pair in limits]
    if len(lim) != J or any(len(p) != 2 or not (np.isfinite(p).all() and p[0] <= p[1]) for p in lim):
        raise InputError(f"limits must be {J} finite (lower, upper) pairs with lower <= upper, got {limits!r}")
    T = [np.asarray(p.cam_from_part, np.float64) for p in result.parts]
    children = {j.child for j in result.joints}
    if 0 in children or any(k not in children for k in range(1, len(T))):
        raise InputError("a URDF needs a joint tree rooted at part 0 with every other part the child of one joint")
    lines = _urdf_head(result, name or f"{result.category}_estimate", jnames)
    if root == "camera":
        lines += _urdf_link("camera")
        lines += _urdf_fixed(f"camera_to_{links[0]}", "camera", links[0], T[0])
    for k, lk in enumerate(links):
        lines += _urdf_link(lk, result.parts[k].size_m)
    for j, jn, (lo, hi) in zip(result.joints, jnames, lim, strict=True):
        lines += _urdf_joint(j, jn, lo, hi, links, T)
    lines.append("</robot>")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


def _urdf_head(result: PoseResult, robot: str, jnames: list[str]) -> list[str]:
    """The XML declaration, a comment naming the estimate and its joint states, and the ``<robot>`` tag."""
    return [
        '<?xml version="1.0"?>',
        f"<!-- the object estimated by ucope {__version__} (model {result.model or result.category}, score "
        f"{result.score:.3f}); joint states at the estimate: "
        + ", ".join(
            f"{n} = {j.state:.6g} {'rad' if j.type == 'revolute' else 'm'}" for n, j in zip(jnames, result.joints, strict=True)
        )
        + " -->",
        f"<robot name={quoteattr(robot)}>",
    ]


def _urdf_link(name: str, size=None) -> list[str]:
    """A link: empty, or a box of extents ``size`` (metres) with a nominal inertia of 500 kg/m^3."""
    if size is None:
        return [f"  <link name={quoteattr(name)}/>"]
    sx, sy, sz = (max(float(v), 1e-6) for v in size)
    mass = max(1e-3, 500.0 * sx * sy * sz)
    ixx, iyy, izz = (mass / 12.0 * (b * b + c * c) for b, c in ((sy, sz), (sx, sz), (sx, sy)))
    box = f'<geometry><box size="{sx:.9g} {sy:.9g} {sz:.9g}"/></geometry>'
    return [
        f"  <link name={quoteattr(name)}>",
        f'    <inertial><mass value="{mass:.6g}"/><inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" '
        f'izz="{izz:.6g}"/></inertial>',
        f"    <visual>{box}</visual>",
        f"    <collision>{box}</collision>",
        "  </link>",
    ]


def _urdf_fixed(name: str, parent: str, child: str, M: np.ndarray) -> list[str]:
    """A fixed joint placing ``child`` at ``M`` (4x4) in ``parent``'s frame."""
    return [
        f'  <joint name={quoteattr(name)} type="fixed">',
        f"    <parent link={quoteattr(parent)}/><child link={quoteattr(child)}/>{_xyz_rpy(M)}",
        "  </joint>",
    ]


def _urdf_joint(j, jname: str, lo: float, hi: float, links: list[str], T: list[np.ndarray]) -> list[str]:
    """The URDF of one estimated joint at state 0 (``T``: every part's ``cam_from_part``): a prismatic joint
    moves the child's link; a revolute one turns a ``<child>_hinge`` link on the axis, fixed to the child's."""
    q = float(j.state)
    lo, hi = min(lo, q), max(hi, q)
    Tc0 = invert_transform(_joint_motion(j, q)) @ T[j.child]  # the child at state 0 (camera frame)
    a = np.asarray(j.axis, np.float64) / np.linalg.norm(j.axis)
    J0 = Tc0.copy()
    if j.type == "revolute":
        J0[:3, 3] = np.asarray(j.pivot_m, np.float64)  # the joint frame: the child's axes, on the hinge
    axis_local = Tc0[:3, :3].T @ a
    target = links[j.child] if j.type == "prismatic" else f"{links[j.child]}_hinge"
    lines = _urdf_link(target) if j.type == "revolute" else []
    lines += [
        f'  <joint name={quoteattr(jname)} type="{j.type}">',
        f"    <parent link={quoteattr(links[j.parent])}/><child link={quoteattr(target)}/>"
        f"{_xyz_rpy(invert_transform(T[j.parent]) @ J0)}",
        f'    <axis xyz="{axis_local[0]:.12g} {axis_local[1]:.12g} {axis_local[2]:.12g}"/>',
        f'    <limit lower="{lo:.9g}" upper="{hi:.9g}" effort="10" velocity="1"/>',
        "  </joint>",
    ]
    if j.type == "revolute":
        lines += _urdf_fixed(f"{links[j.child]}_hinge_to_{links[j.child]}", target, links[j.child], invert_transform(J0) @ Tc0)
    return lines


# --------------------------------------------------------------------------------------------------
# Geometry (GLB / PLY) and rerun recordings
# --------------------------------------------------------------------------------------------------


def _rgba(hex_colour: str, alpha: int = 255) -> list[int]:
    h = hex_colour.lstrip("#")
    return [int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16), alpha]


def _object_colours(results: Sequence[PoseResult]) -> list[list[str]]:
    out, offset = [], 0
    for r in results:
        out.append([PART_PALETTE[(offset + k) % len(PART_PALETTE)] for k in range(len(r.parts))])
        offset += len(r.parts)
    return out


def _joint_segment(result: PoseResult, j) -> tuple[np.ndarray, np.ndarray]:
    """``(start, vector)`` of a joint's drawn axis: through the pivot (or the child's centre), 0.6 of the
    object's largest part diagonal long."""
    a = np.asarray(j.axis, np.float64) / np.linalg.norm(j.axis)
    p = np.asarray(j.pivot_m if j.pivot_m is not None else result.parts[j.child].cam_from_part[:3, 3], np.float64)
    L = 0.6 * float(np.linalg.norm(result.size_m, axis=1).max())
    return p - 0.5 * L * a, L * a


def _labelled_cloud(result: PoseResult, points, colours: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """``(P (M, 3), rgba (M, 4) uint8)``: the finite points of a result's cloud that are on a part, in their
    part's colour (every point as part 0 when ``part_labels`` belongs to another cloud)."""
    P = np.asarray(points, np.float64).reshape(-1, 3)
    lab = np.asarray(result.part_labels)
    lab = lab if len(lab) == len(P) else np.zeros(len(P), np.int64)
    ok = np.isfinite(P).all(axis=1) & (lab >= 0)
    palette = np.array([_rgba(c) for c in colours], np.uint8)
    return P[ok], palette[np.clip(lab[ok], 0, len(colours) - 1)]


def write_geometry(results: Sequence[PoseResult], path: str | os.PathLike, points: Sequence | None = None) -> Path:
    """Write the estimates' boxes (one per part, in its part colour), joint axes (thin dark cylinders) and
    optionally the clouds (``points[i]``: ``(N, 3)`` of result ``i``, coloured by its ``part_labels``) in
    the camera frame, metres, through trimesh: ``.glb`` (a scene, points included) or ``.ply`` / ``.obj``
    (one coloured mesh: boxes and axes; points are not written). Opens in Open3D, Blender, MeshLab.

    Raises :class:`InputError` for another suffix or no results."""
    import trimesh

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".glb", ".ply", ".obj"):
        raise InputError(f"{path}: geometry is written as .glb, .ply or .obj, not {suffix!r}")
    if not results:
        raise InputError("no results to write")
    points = list(points) if points is not None else [None] * len(results)
    meshes, clouds = [], []
    for r, cols, pts in zip(results, _object_colours(results), points, strict=False):
        for p, c in zip(r.parts, cols, strict=True):
            box = trimesh.creation.box(extents=np.maximum(np.asarray(p.size_m, np.float64), 1e-6), transform=p.cam_from_part)
            box.visual.face_colors = _rgba(c)
            meshes.append(box)
        radius = 0.01 * float(np.linalg.norm(r.size_m, axis=1).max())
        for j in r.joints:
            start, vec = _joint_segment(r, j)
            cyl = trimesh.creation.cylinder(radius=radius, segment=np.stack([start, start + vec]), sections=12)
            cyl.visual.face_colors = [30, 30, 30, 255]
            meshes.append(cyl)
        if pts is not None and suffix == ".glb":
            clouds.append(trimesh.PointCloud(*_labelled_cloud(r, pts, cols)))
    if suffix == ".glb":
        data = trimesh.Scene(meshes + clouds).export(file_type="glb")
    else:
        data = trimesh.util.concatenate(meshes).export(file_type=suffix[1:])
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, data if isinstance(data, bytes) else str(data).encode("utf-8"))
    return path


def write_rrd(
    results: Sequence[PoseResult], path: str | os.PathLike, points: Sequence | None = None, names: Sequence[str] | None = None
) -> Path:
    """Write the estimates as a rerun recording (``.rrd``; open it with ``rerun FILE.rrd``): under the
    entity ``camera`` (view coordinates right-down-forward, the camera frame), per object ``camera/<name>``
    its boxes (``Boxes3D``, labelled with part and score), joint axes (``Arrows3D``) and cloud
    (``Points3D`` coloured by part). Needs rerun-sdk: ``pip install rerun-sdk`` (about 700 MB with
    its dependencies); :class:`InputError` naming the extra otherwise."""
    try:
        import rerun as rr
    except ImportError:
        raise InputError("writing .rrd recordings needs rerun-sdk: pip install rerun-sdk") from None
    import tempfile

    path = Path(path)
    if not results:
        raise InputError("no results to write")
    points = list(points) if points is not None else [None] * len(results)
    names = list(names) if names is not None else [f"object_{i}" for i in range(len(results))]
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ucope-rrd-") as folder:
        tmp = str(Path(folder) / "recording.rrd")
        rec = rr.RecordingStream("ucope")
        rec.save(tmp)
        rec.log("camera", rr.ViewCoordinates.RDF, static=True)
        for r, cols, pts, name in zip(results, _object_colours(results), points, names, strict=False):
            base = "camera/" + re.sub(r"[^A-Za-z0-9_]+", "_", str(name))
            T = np.stack([np.asarray(p.cam_from_part, np.float64) for p in r.parts])
            rec.log(
                f"{base}/boxes",
                rr.Boxes3D(
                    centers=T[:, :3, 3],
                    half_sizes=0.5 * np.asarray(r.size_m, np.float64),
                    quaternions=[rr.Quaternion(xyzw=_quaternion_xyzw(M[:3, :3])) for M in T],
                    colors=[_rgba(c) for c in cols],
                    labels=[f"{p.label} {p.score:.2f}" for p in r.parts],
                ),
            )
            if r.joints:
                segs = [_joint_segment(r, j) for j in r.joints]
                rec.log(
                    f"{base}/joints",
                    rr.Arrows3D(
                        origins=[s for s, _ in segs],
                        vectors=[v for _, v in segs],
                        colors=[[30, 30, 30, 255]] * len(segs),
                        labels=[
                            f"{j.type} {np.degrees(j.state):.1f} deg"
                            if j.type == "revolute"
                            else f"{j.type} {100 * j.state:.1f} cm"
                            for j in r.joints
                        ],
                    ),
                )
            if pts is not None:
                P, colours = _labelled_cloud(r, pts, cols)
                rec.log(f"{base}/points", rr.Points3D(P, colors=colours))
        rec.flush()
        rec.disconnect()
        atomic_write_bytes(path, Path(tmp).read_bytes())
    return path
