"""Exporting results for other tools: the BOP toolkit's results CSV, ROS 2 messages as plain dicts, a URDF
of the estimated object, its geometry (GLB / PLY) and a rerun recording (``.rrd``).

* :func:`bop_rows`, :func:`frame_bop_rows`, :func:`write_bop_csv`, :func:`read_bop_csv`: the results CSV of
  ``bop_toolkit`` (``scripts/eval_bop*.py``), with the obj_id of every (object, part) written beside it;
* :func:`to_ros`: ``vision_msgs/Detection3DArray``, ``tf2_msgs/TFMessage`` and ``sensor_msgs/JointState``
  as dicts with the messages' field names (no ROS needed; fill the messages with them);
* :func:`write_urdf`: the object as a URDF (parts as boxes, joints with the estimated axis, pivot and
  limits) for a planner or a simulator;
* :func:`write_geometry`: boxes, joint axes and points as a GLB (or PLY) file, through trimesh;
* :func:`write_rrd`: a rerun recording, with ``pip install rerun-sdk``.

BOP results CSV: one row per estimated part::

    scene_id,im_id,obj_id,score,R,t,time
    0,3,1,0.912,0.99 0.01 ... (9 values),12.5 -80.1 1204.3,0.041

* ``R``: the part's rotation ``cam_from_part[:3, :3]``, 9 values row-wise, separated by spaces;
* ``t``: ``cam_from_part[:3, 3]`` in **millimetres**, separated by spaces;
* ``score``: the part's score; ``time``: seconds for the whole image (the sum over its objects, the
  same on every row of one image, as the toolkit requires; -1 if unknown).

**obj_id of a part**: ``obj_id = base + k`` for part ``k`` of an object whose base id is ``base``
(default 1): a rigid object is ``base`` itself, a laptop's base and lid are ``base`` and ``base + 1``.
``ucope generate --images`` writes its ground truth (``scene_gt.json``) with the same rule and
``base = 1``. With several objects in one image (``--instances``) the objects are numbered on from the
base in instance order, so that every (object, part) of the image has its own obj_id (a mug after a
laptop at base 1 is 3); :func:`write_bop_csv` writes the obj_id of every (object, part) to
``<csv stem>.obj_ids.json`` beside the CSV. The "model" frame of every row is the ucope part frame
(its amodal box centred on the origin, the category's canonical axes; docs/conventions.md), as in the
ground truth ucope writes; a BOP data set whose model frames differ needs that offset applied.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import DataError, InputError
from ..fileio import atomic_write_bytes, atomic_write_json, atomic_write_text
from ..geometry.transforms import axis_angle_transform, invert_transform
from ..versions import __version__
from .result import PoseResult

__all__ = [
    "BOP_CSV_HEADER",
    "BopRow",
    "bop_rows",
    "frame_bop_rows",
    "write_bop_csv",
    "read_bop_csv",
    "obj_id_map_path",
    "to_ros",
    "write_urdf",
    "urdf_names",
    "write_geometry",
    "write_rrd",
]

BOP_CSV_HEADER = ("scene_id", "im_id", "obj_id", "score", "R", "t", "time")


@dataclass
class BopRow:
    """One row of a BOP results CSV: ``R`` ``(3, 3)``, ``t_mm`` ``(3,)`` millimetres, ``time_s`` seconds (-1: unknown)."""

    scene_id: int
    im_id: int
    obj_id: int
    score: float
    R: np.ndarray
    t_mm: np.ndarray
    time_s: float = -1.0
    object: str = ""
    """What the obj_id stands for (written to the obj_id map beside the CSV): the object's name..."""
    part: str = ""
    """...and the part's label."""


def bop_rows(
    result: PoseResult, scene_id: int, im_id: int, obj_id: int = 1, time_s: float | None = None, name: str = ""
) -> list[BopRow]:
    """The rows of one object's result: part ``k`` gets ``obj_id + k``.

    Args:
        result: the object's estimate.
        scene_id, im_id: the image's BOP ids (non-negative integers).
        obj_id: the object's base id (>= 1); part ``k`` is written as ``obj_id + k``.
        time_s: seconds for the whole image; default the result's ``timings_ms["total"] / 1000``
            (-1 when it has none). Pass the image's total when it holds several objects.
        name: the object's name in the obj_id map (default its model or category).
    """
    for field_name, v in (("scene_id", scene_id), ("im_id", im_id)):
        if int(v) != v or int(v) < 0:
            raise InputError(f"BOP {field_name} must be a non-negative integer, got {v!r}")
    if int(obj_id) != obj_id or int(obj_id) < 1:
        raise InputError(f"BOP obj_id must be a positive integer, got {obj_id!r}")
    if time_s is None:
        t = result.timings_ms.get("total")
        time_s = -1.0 if t is None else float(t) / 1000.0
    return [
        BopRow(
            int(scene_id),
            int(im_id),
            int(obj_id) + k,
            float(p.score),
            np.asarray(p.cam_from_part, np.float64)[:3, :3],
            1000.0 * np.asarray(p.cam_from_part, np.float64)[:3, 3],
            float(time_s),
            name or result.model or result.category,
            p.label,
        )
        for k, p in enumerate(result.parts)
    ]


def _fmt(values) -> str:
    return " ".join(f"{float(v):.6f}" for v in np.asarray(values, np.float64).reshape(-1))


def obj_id_map_path(csv_path: str | os.PathLike) -> Path:
    """Where :func:`write_bop_csv` writes the obj_id map of a CSV: ``<stem>.obj_ids.json`` beside it."""
    p = Path(csv_path)
    return p.with_name(p.stem + ".obj_ids.json")


def write_bop_csv(path: str | os.PathLike, rows: Iterable[BopRow], obj_id_map: bool = True) -> Path:
    """Write rows as a BOP results CSV (header line, then one line per row), atomically, and (with
    ``obj_id_map``) the obj_id of every (object, part) to :func:`obj_id_map_path`::

        {"format": "ucope-bop-obj-ids/1", "csv": "results.csv",
         "obj_ids": [{"scene_id": 0, "im_id": 42, "obj_id": 1, "object": "1: laptop", "part": "base"}, ...]}

    Raises :class:`InputError` when the rows of one image have different times (the toolkit needs one
    time per image) or when one obj_id stands for two different (object, part) in one image."""
    rows = list(rows)
    times: dict[tuple[int, int], float] = {}
    owner: dict[tuple[int, int, int], tuple[str, str]] = {}
    for r in rows:
        key = (r.scene_id, r.im_id)
        if times.setdefault(key, r.time_s) != r.time_s:
            raise InputError(
                f"scene {r.scene_id} image {r.im_id} has rows with different times ({times[key]} and {r.time_s} s); "
                "BOP needs one time per image (the sum over its objects)"
            )
        what = (r.object, r.part)
        if r.object and owner.setdefault((r.scene_id, r.im_id, r.obj_id), what) != what:
            first = owner[(r.scene_id, r.im_id, r.obj_id)]
            raise InputError(
                f"scene {r.scene_id} image {r.im_id}: obj_id {r.obj_id} would stand for both {first[0]} {first[1]!r} and "
                f"{r.object} {r.part!r}; give each object its own --bop-obj-id range"
            )
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(BOP_CSV_HEADER)
    for r in rows:
        w.writerow([r.scene_id, r.im_id, r.obj_id, f"{r.score:.6f}", _fmt(r.R), _fmt(r.t_mm), f"{r.time_s:.6f}"])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, buf.getvalue())
    if obj_id_map:
        entries = sorted({(r.scene_id, r.im_id, r.obj_id, r.object, r.part) for r in rows}, key=lambda e: (e[0], e[1], e[2]))
        atomic_write_json(
            obj_id_map_path(path),
            {
                "format": "ucope-bop-obj-ids/1",
                "csv": path.name,
                "obj_ids": [{"scene_id": a, "im_id": b, "obj_id": c, "object": o, "part": p} for a, b, c, o, p in entries],
            },
        )
    return path


def read_bop_csv(path: str | os.PathLike) -> list[BopRow]:
    """Read a BOP results CSV (as :func:`write_bop_csv` writes it, or the toolkit's own files).

    Raises :class:`DataError` naming the file and line for a missing file, a wrong header or a bad row."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataError(f"{path} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read {path}: {e}") from None
    lines = list(csv.reader(io.StringIO(text)))
    if not lines or tuple(c.strip() for c in lines[0]) != BOP_CSV_HEADER:
        raise DataError(f"{path}: the first line must be the header {','.join(BOP_CSV_HEADER)}")
    out = []
    for n, row in enumerate(lines[1:], start=2):
        if not row:
            continue
        try:
            if len(row) != 7:
                raise ValueError(f"{len(row)} fields instead of 7")
            R = np.array(row[4].split(), np.float64)
            t = np.array(row[5].split(), np.float64)
            if R.shape != (9,) or t.shape != (3,):
                raise ValueError(f"R needs 9 values and t 3, got {R.size} and {t.size}")
            out.append(BopRow(int(row[0]), int(row[1]), int(row[2]), float(row[3]), R.reshape(3, 3), t, float(row[6])))
        except ValueError as e:
            raise DataError(f"{path}, line {n}: {e}") from None
    return out


def frame_bop_rows(
    results: Sequence[tuple], scene_id: int, im_id: int, time_s: float | None = None, base: int | None = None
) -> list[BopRow]:
    """The rows of every object of one image.

    Args:
        results: ``(result, base obj_id)`` or ``(result, base obj_id, name)`` per object; with ``base``
            given, the objects' own bases are ignored and the objects are numbered on from ``base`` in
            list order (object ``i`` starts after the parts of objects ``0 .. i-1``), so that every
            (object, part) of the image has its own obj_id.
        time_s: the image's time; default the sum of the objects' times (-1 if one is unknown).
    """
    if time_s is None:
        ts = [item[0].timings_ms.get("total") for item in results]
        time_s = -1.0 if any(t is None for t in ts) else sum(float(t) for t in ts) / 1000.0
    rows: list[BopRow] = []
    next_id = base
    for item in results:
        r, own = item[0], item[1]
        name = item[2] if len(item) > 2 else ""
        start = own if next_id is None else next_id
        rows += bop_rows(r, scene_id, im_id, start, time_s, name)
        if next_id is not None:
            next_id += len(r.parts)
    return rows


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
    robot = name or f"{result.category}_estimate"
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- the object estimated by ucope {__version__} (model {result.model or result.category}, score "
        f"{result.score:.3f}); joint states at the estimate: "
        + ", ".join(
            f"{n} = {j.state:.6g} {'rad' if j.type == 'revolute' else 'm'}" for n, j in zip(jnames, result.joints, strict=True)
        )
        + " -->",
        f"<robot name={quoteattr(robot)}>",
    ]

    def link(name: str, size=None) -> None:
        if size is None:
            lines.append(f"  <link name={quoteattr(name)}/>")
            return
        sx, sy, sz = (max(float(v), 1e-6) for v in size)
        mass = max(1e-3, 500.0 * sx * sy * sz)
        ixx, iyy, izz = (mass / 12.0 * (b * b + c * c) for b, c in ((sy, sz), (sx, sz), (sx, sy)))
        box = f'<geometry><box size="{sx:.9g} {sy:.9g} {sz:.9g}"/></geometry>'
        lines.extend(
            (
                f"  <link name={quoteattr(name)}>",
                f'    <inertial><mass value="{mass:.6g}"/><inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" '
                f'izz="{izz:.6g}"/></inertial>',
                f"    <visual>{box}</visual>",
                f"    <collision>{box}</collision>",
                "  </link>",
            )
        )

    def fixed(name: str, parent: str, child: str, M: np.ndarray) -> None:
        lines.extend(
            (
                f'  <joint name={quoteattr(name)} type="fixed">',
                f"    <parent link={quoteattr(parent)}/><child link={quoteattr(child)}/>{_xyz_rpy(M)}",
                "  </joint>",
            )
        )

    if root == "camera":
        link("camera")
        fixed(f"camera_to_{links[0]}", "camera", links[0], T[0])
    for k, lk in enumerate(links):
        link(lk, result.parts[k].size_m)
    for j, jn, (lo, hi) in zip(result.joints, jnames, lim, strict=True):
        q = float(j.state)
        lo, hi = min(lo, q), max(hi, q)
        Tc0 = invert_transform(_joint_motion(j, q)) @ T[j.child]  # the child at state 0 (camera frame)
        a = np.asarray(j.axis, np.float64) / np.linalg.norm(j.axis)
        J0 = Tc0.copy()
        if j.type == "revolute":
            J0[:3, 3] = np.asarray(j.pivot_m, np.float64)  # the joint frame: the child's axes, on the hinge
        axis_local = Tc0[:3, :3].T @ a
        target = links[j.child] if j.type == "prismatic" else f"{links[j.child]}_hinge"
        if j.type == "revolute":
            link(target)
        lines += [
            f'  <joint name={quoteattr(jn)} type="{j.type}">',
            f"    <parent link={quoteattr(links[j.parent])}/><child link={quoteattr(target)}/>"
            f"{_xyz_rpy(invert_transform(T[j.parent]) @ J0)}",
            f'    <axis xyz="{axis_local[0]:.12g} {axis_local[1]:.12g} {axis_local[2]:.12g}"/>',
            f'    <limit lower="{lo:.9g}" upper="{hi:.9g}" effort="10" velocity="1"/>',
            "  </joint>",
        ]
        if j.type == "revolute":
            fixed(f"{links[j.child]}_hinge_to_{links[j.child]}", target, links[j.child], invert_transform(J0) @ Tc0)
    lines.append("</robot>")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


# --------------------------------------------------------------------------------------------------
# Geometry (GLB / PLY) and rerun recordings
# --------------------------------------------------------------------------------------------------


def _rgba(hex_colour: str, alpha: int = 255) -> list[int]:
    h = hex_colour.lstrip("#")
    return [int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16), alpha]


def _object_colours(results: Sequence[PoseResult]) -> list[list[str]]:
    from .draw import PART_PALETTE

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
            P = np.asarray(pts, np.float64).reshape(-1, 3)
            lab = np.asarray(r.part_labels)
            lab = lab if len(lab) == len(P) else np.zeros(len(P), np.int64)
            ok = np.isfinite(P).all(axis=1) & (lab >= 0)
            palette = np.array([_rgba(c) for c in cols], np.uint8)
            clouds.append(trimesh.PointCloud(P[ok], colors=palette[np.clip(lab[ok], 0, len(cols) - 1)]))
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
                P = np.asarray(pts, np.float64).reshape(-1, 3)
                lab = np.asarray(r.part_labels)
                lab = lab if len(lab) == len(P) else np.zeros(len(P), np.int64)
                ok = np.isfinite(P).all(axis=1) & (lab >= 0)
                palette = np.array([_rgba(c) for c in cols], np.uint8)
                rec.log(f"{base}/points", rr.Points3D(P[ok], colors=palette[np.clip(lab[ok], 0, len(cols) - 1)]))
        rec.flush()
        rec.disconnect()
        atomic_write_bytes(path, Path(tmp).read_bytes())
    return path
