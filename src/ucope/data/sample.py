"""One training / test sample: a partial point cloud of an object with its ground truth.

A sample is a plain ``dict``; the fields and their meaning:

=================  ==============  =============================================================
name               shape / type    meaning
=================  ==============  =============================================================
``points``         (P, 3) float32  partial point cloud, camera frame (OpenCV axes), metres
``normals``        (P, 3) float32  unit normals (kNN PCA), oriented towards the camera
``part_labels``    (P,) int64      part index of each point, in ``[0, K)``
``cam_from_part``  (K, 4, 4) f64   every part's pose: part canonical frame -> camera frame
``size_m``         (K, 3) f64      amodal box extents of every part (in its own frame), metres
``joint_type``     (K-1,) int64    index into ``ucope.objects.articulation.JOINT_TYPES``
``joint_pivot``    (K-1, 3) f64    a point on each joint axis, camera frame, metres
``joint_axis``     (K-1, 3) f64    unit joint axis, camera frame
``joint_state``    (K-1,) f64      radians (revolute) or metres (prismatic)
``cam_from_object`` (4, 4) f64     the object (root part) frame -> camera frame
``intrinsics``     (4,) f64        fx, fy, cx, cy of the camera (pixels)
``category``       str             category name
``instance_id``    str             ``category/split/seed/index`` of the object instance
``index``          int             sample index in its data set
``source``         str             the model file the instance was built from (categories of your
                                   own objects only: relative to the spec's ``base_dir``)
``bg_points``      (M, 3) float32  background points just outside the object's silhouette (floor,
                                   distractor objects), nearest first, at the cloud's density
``bg_rank``        (M,) float32    their pixel distance to the silhouette (ascending)
``bg_clutter``     (M,) bool       True for a distractor object's point, False for the floor
=================  ==============  =============================================================

``source`` is absent for the procedural categories. The three ``bg_`` fields are optional (data sets
generated with ``background=False`` lack them); they feed the floor and mask-bleed corruptions of
:mod:`ucope.data.corrupt` (training augmentation).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..geometry.normals import estimate_normals
from ..geometry.sampling import random_subset
from ..objects.articulation import ArticulatedObject
from ..render.camera import PinholeCamera
from ..render.views import RenderedView
from ..vocab import JointType

__all__ = [
    "SAMPLE_ARRAY_FIELDS",
    "BACKGROUND_FIELDS",
    "sample_from_view",
    "check_sample",
    "background_fields",
    "scale_sample",
    "roll_sample",
]

BACKGROUND_FIELDS = ("bg_points", "bg_rank", "bg_clutter")
"""The optional per-sample background pool (see the module table)."""

BACKGROUND_BAND = 1.25
"""The stored pool covers the band of background pixels nearest the silhouette as large as this many
times the object's pixels (enough for a floor of 100 % of the object's points)."""

SAMPLE_ARRAY_FIELDS = (
    "points",
    "normals",
    "part_labels",
    "cam_from_part",
    "size_m",
    "joint_type",
    "joint_pivot",
    "joint_axis",
    "joint_state",
    "cam_from_object",
    "intrinsics",
)


def sample_from_view(
    obj: ArticulatedObject,
    view: RenderedView,
    camera: PinholeCamera,
    rng: np.random.Generator,
    index: int,
    max_points: int = 4096,
    normal_k: int = 16,
) -> dict:
    """Back-project the object pixels of a view into a sample (see the module table).

    The cloud is subsampled (uniformly, from ``rng``) to at most ``max_points`` before the normals are
    estimated. Raises :class:`InputError` if the view holds fewer than 3 object points.
    """
    K = obj.num_parts
    on_object = view.mask < K
    pts, pix = camera.backproject(view.depth_mm.astype(np.float64) / 1000.0, on_object)
    if len(pts) < 3:
        raise InputError(f"view {index} of {obj.instance_id} shows only {len(pts)} object points")
    labels = view.mask[pix[:, 0], pix[:, 1]].astype(np.int64)
    if len(pts) > max_points:
        keep = random_subset(len(pts), max_points, rng)
        pts, labels = pts[keep], labels[keep]
    normals = estimate_normals(pts, k=normal_k)
    source = obj.params.get("source") if isinstance(obj.params, dict) else None
    return {
        **({"source": source} if isinstance(source, str) and source else {}),
        "points": pts.astype(np.float32),
        "normals": normals,
        "part_labels": labels,
        "cam_from_part": view.cam_from_part,
        "size_m": obj.size_m,
        "joint_type": np.array([j.type_code for j in obj.joints], dtype=np.int64),
        "joint_pivot": view.joint_pivot.reshape(-1, 3),
        "joint_axis": view.joint_axis.reshape(-1, 3),
        "joint_state": view.joint_state.reshape(-1),
        "cam_from_object": view.cam_from_object,
        "intrinsics": np.array([camera.fx, camera.fy, camera.cx, camera.cy]),
        "category": obj.category,
        "instance_id": obj.instance_id,
        "index": int(index),
    }


def background_fields(view: RenderedView, camera: PinholeCamera, num_points: int, rng: np.random.Generator) -> dict:
    """The ``bg_`` fields of a sample: the background pool of ``view`` (:func:`ucope.data.corrupt.background_pool`)
    cut to the band of :data:`BACKGROUND_BAND` times the object's pixels nearest the silhouette and thinned
    at random (from ``rng``) to the density of the sample's ``num_points``-point cloud."""
    from .corrupt import background_pool

    pool = background_pool(view, camera, cloud_points=num_points)
    n_obj = int(np.count_nonzero((view.mask < len(view.cam_from_part)) & (view.depth_mm > 0)))
    band = min(len(pool.rank), int(round(BACKGROUND_BAND * n_obj)))
    keep = np.flatnonzero(rng.random(band) < 1.0 / pool.pixels_per_point)
    return {
        "bg_points": pool.points[keep].astype(np.float32),
        "bg_rank": pool.rank[keep].astype(np.float32),
        "bg_clutter": np.asarray(pool.clutter[keep], dtype=bool),
    }


def check_sample(sample: dict) -> None:
    """Raise :class:`InputError` naming the first field of ``sample`` with a wrong shape."""
    for k in SAMPLE_ARRAY_FIELDS + ("category", "instance_id"):
        if k not in sample:
            raise InputError(f"sample lacks field {k!r}")
    P = len(sample["points"])
    K = len(sample["size_m"])
    want = {
        "points": (P, 3),
        "normals": (P, 3),
        "part_labels": (P,),
        "cam_from_part": (K, 4, 4),
        "size_m": (K, 3),
        "joint_type": (K - 1,),
        "joint_pivot": (K - 1, 3),
        "joint_axis": (K - 1, 3),
        "joint_state": (K - 1,),
        "cam_from_object": (4, 4),
        "intrinsics": (4,),
    }
    if "bg_points" in sample:
        M = len(sample["bg_points"])
        want.update({"bg_points": (M, 3), "bg_rank": (M,), "bg_clutter": (M,)})
    for k, shape in want.items():
        if np.shape(sample.get(k)) != shape:
            raise InputError(f"sample field {k!r} has shape {np.shape(sample.get(k))}, expected {shape}")


def scale_sample(sample: dict, factor: float, centre=None) -> dict:
    """The sample of the same view of the object scaled uniformly by ``factor`` about ``centre``.

    ``centre`` ``(3,)`` camera frame, metres; default: the mean of the parts' box centres. Points, the
    background pool, part and object translations and joint pivots move to ``centre + factor * (x -
    centre)``; sizes and prismatic states are multiplied by ``factor``; rotations, normals, joint axes,
    revolute states and labels are kept. (The perspective is the original's: this is the object grown in
    place, not a new rendering.) Returns a new dict; ``sample`` is not changed.

    Raises:
        InputError: a ``factor`` that is not a positive finite number, or a ``centre`` not of shape (3,).
    """
    f = float(factor) if isinstance(factor, int | float | np.floating | np.integer) else float("nan")
    if not np.isfinite(f) or f <= 0.0:
        raise InputError(f"scale factor must be a positive finite number, got {factor!r}")
    T = np.asarray(sample["cam_from_part"], np.float64)
    c = T[:, :3, 3].mean(axis=0) if centre is None else np.asarray(centre, np.float64)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise InputError(f"centre must be a finite (3,) point, got shape {np.shape(centre)}")

    def move(x, dtype=np.float64):
        return (c + f * (np.asarray(x, np.float64) - c)).astype(dtype)

    out = dict(sample)
    out["points"] = move(sample["points"], np.float32)
    Tn = T.copy()
    Tn[:, :3, 3] = move(T[:, :3, 3])
    out["cam_from_part"] = Tn
    out["size_m"] = np.asarray(sample["size_m"], np.float64) * f
    To = np.array(sample["cam_from_object"], np.float64)
    To[:3, 3] = move(To[:3, 3])
    out["cam_from_object"] = To
    jt = np.asarray(sample["joint_type"])
    if len(jt):
        out["joint_pivot"] = move(sample["joint_pivot"])
        state = np.array(sample["joint_state"], np.float64)
        out["joint_state"] = np.where(jt == int(JointType.PRISMATIC), f * state, state)
    if "bg_points" in sample:
        out["bg_points"] = move(sample["bg_points"], np.float32)
    return out


def roll_sample(sample: dict, angle_rad: float) -> dict:
    """The sample of the same view seen by the camera rolled by ``-angle_rad`` about its optical axis:
    every camera-frame quantity turned by ``Rz = Rot(z, angle_rad)`` (points, normals, the background
    pool, part and object poses, joint pivots and axes); sizes, states and labels are kept. (A depth
    image turned in its plane, about the principal point.) Returns a new dict; ``sample`` is not changed.

    Raises:
        InputError: an angle that is not a finite number.
    """
    a = float(angle_rad) if isinstance(angle_rad, int | float | np.floating | np.integer) else float("nan")
    if not np.isfinite(a):
        raise InputError(f"roll angle must be a finite number of radians, got {angle_rad!r}")
    c, s_ = np.cos(a), np.sin(a)
    R = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    out = dict(sample)
    for key in ("points", "normals", "bg_points"):
        if key in sample:
            out[key] = (np.asarray(sample[key], np.float64) @ R.T).astype(np.asarray(sample[key]).dtype)
    T = np.array(sample["cam_from_part"], np.float64)
    T[:, :3, :] = np.einsum("ij,kjl->kil", R, T[:, :3, :])
    out["cam_from_part"] = T
    To = np.array(sample["cam_from_object"], np.float64)
    To[:3, :] = R @ To[:3, :]
    out["cam_from_object"] = To
    if len(np.asarray(sample["joint_type"])):
        out["joint_pivot"] = np.asarray(sample["joint_pivot"], np.float64) @ R.T
        out["joint_axis"] = np.asarray(sample["joint_axis"], np.float64) @ R.T
    return out
