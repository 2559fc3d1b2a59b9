"""Evaluation metrics: per-part 9D pose errors, joint errors, segmentation and their summaries.

The NOCS-style mAP of rigid categories is in :mod:`ucope.eval.mean_ap`.

Plain numpy functions, one per metric, in the spirit of the BOP toolkit. Conventions (see also
docs/conventions.md and docs/metrics.md):

* Frames: every pose is a ``(4, 4)`` rigid transform ``cam_from_part`` (part frame -> camera frame,
  OpenCV camera axes); the part's amodal box is centred on the part-frame origin and aligned with its
  axes, with full extents ``size_m`` ``(3,)`` along the part's x, y, z.  Prediction and ground truth
  must be given in the same (camera) frame.
* Units: lengths in metres, angles in degrees for every returned error (names end in ``_deg`` / ``_m``);
  input joint states are in radians (revolute) or metres (prismatic), as in the data sets.  The mAP
  pose thresholds are in degrees and **centimetres**, as NOCS names them (``5deg2cm``).
* Symmetry: ``"none"`` or ``"y"``.  A ``"y"`` part (bottle, bowl, can) is continuously symmetric about
  its own y axis: its rotation error is the angle between the two y axes and its IoU is the best over
  rotations of the predicted box about its y axis.
* 3D IoU is the **exact** IoU of the two oriented boxes (:func:`ucope.geometry.boxes.box_iou_3d`,
  convex polyhedron intersection), not the axis-aligned-in-camera-frame shortcut of the NOCS reference
  code (which also has a known defect).  IoUs are fractions in ``[0, 1]`` (tables print percent).
* Results are plain Python ``float`` / ``int`` / ``list`` / ``dict`` (JSON-friendly); an undefined
  value in a dict is ``None``.  Low-level array results (:func:`segmentation_iou`) use ``NaN``.

Every function raises :class:`ucope.errors.InputError` on bad input (wrong shape, NaN, non-rigid
transform, unknown symmetry or joint type...), with a message naming the argument.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..geometry.boxes import box_iou_3d, box_iou_3d_symmetric_y
from ..vocab import JointType

__all__ = [
    "SYMMETRIES",
    "NOCS_SYMMETRIC_CLASSES",
    "IOU_METHOD",
    "rotation_error_deg",
    "translation_error_m",
    "normalized_translation_error",
    "box_iou",
    "part_errors",
    "axis_angle_error_deg",
    "line_distance_m",
    "state_error",
    "joint_errors",
    "segmentation_iou",
    "segmentation_accuracy",
    "summarize_parts",
    "summarize_joints",
]

#: Accepted part symmetries.
SYMMETRIES = ("none", "y")

#: NOCS classes treated as symmetric about y (a mug too when its handle is not visible).
NOCS_SYMMETRIC_CLASSES = ("bottle", "bowl", "can")

#: How every IoU in this module is computed (also written into :func:`ucope.eval.mean_ap.compute_map`'s result).
IOU_METHOD = (
    "exact oriented 3D box IoU (ucope.geometry.boxes.box_iou_3d, convex polyhedron intersection); "
    "not the NOCS reference code's axis-aligned-in-camera-frame approximation"
)

# A matrix is accepted as a rotation if |R^T R - I| and |det R - 1| are below this (float32 input is fine).
_ROT_TOL = 1e-5
_JOINT_TYPE_NAMES = {int(t): t.label for t in JointType}


# --------------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------------


def _array(x, name: str, shape: tuple) -> np.ndarray:
    """``x`` as a finite float64 array of exactly ``shape``."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a numeric array of shape {shape}, got {type(x).__name__}") from exc
    if arr.shape != shape:
        raise InputError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains non-finite values (NaN or inf)")
    return arr


def _rotation(R, name: str) -> np.ndarray:
    R = _array(R, name, (3, 3))
    if np.max(np.abs(R.T @ R - np.eye(3))) > _ROT_TOL or abs(np.linalg.det(R) - 1.0) > _ROT_TOL:
        raise InputError(f"{name} must be a rotation matrix (orthonormal, det +1)")
    return R


def check_transform(T, name: str) -> np.ndarray:
    T = _array(T, name, (4, 4))
    if np.max(np.abs(T[3] - np.array([0.0, 0.0, 0.0, 1.0]))) > _ROT_TOL:
        raise InputError(f"{name} must be a rigid transform: its last row must be [0, 0, 0, 1]")
    _rotation(T[:3, :3], f"{name}[:3, :3]")
    return T


def check_size(s, name: str) -> np.ndarray:
    s = _array(s, name, (3,))
    if np.any(s <= 0.0):
        raise InputError(f"{name} must be strictly positive box extents in metres, got {s.tolist()}")
    return s


def _unit(v, name: str) -> np.ndarray:
    v = _array(v, name, (3,))
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise InputError(f"{name} must be a non-zero direction vector")
    return v / n


def check_scalar(x, name: str) -> float:
    if isinstance(x, bool | np.bool_):
        raise InputError(f"{name} must be a finite number, got {x!r}")
    try:
        v = float(x)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a finite number, got {x!r}") from exc
    if not math.isfinite(v):
        raise InputError(f"{name} must be a finite number, got {v}")
    return v


def _symmetry(symmetry) -> str:
    if symmetry not in SYMMETRIES:
        raise InputError(f"symmetry must be one of {SYMMETRIES}, got {symmetry!r}")
    return symmetry


def _joint_type(joint_type) -> str:
    """``"revolute"`` or ``"prismatic"`` from a name or an integer code (0 revolute, 1 prismatic)."""
    if isinstance(joint_type, int | np.integer) and not isinstance(joint_type, bool | np.bool_):
        name = _JOINT_TYPE_NAMES.get(int(joint_type))
    else:
        name = joint_type if joint_type in _JOINT_TYPE_NAMES.values() else None
    if name is None:
        raise InputError(f"joint_type must be 'revolute' (0) or 'prismatic' (1), got {joint_type!r}")
    if name == "fixed":
        raise InputError("joint_type 'fixed' (2) has no axis or state to evaluate")
    return name


def _angle_between_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle in degrees, in [0, 180], between two non-zero 3-vectors (atan2: accurate near 0 and 180)."""
    return float(np.degrees(math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b)))))


# --------------------------------------------------------------------------------------------------
# Per part
# --------------------------------------------------------------------------------------------------


def rotation_error_deg(R_pred, R_gt, symmetry: str = "none") -> float:
    """Rotation error of a part, in degrees.

    Args:
        R_pred: ``(3, 3)`` predicted rotation (part frame -> camera frame).
        R_gt: ``(3, 3)`` ground-truth rotation, same frames.
        symmetry: ``"none"``: the geodesic angle of ``R_pred^T R_gt``, in ``[0, 180]``;
            ``"y"`` (part symmetric about its y axis): the angle between the two y axes (second
            columns), in ``[0, 180]`` (an upside-down prediction is 180 degrees off, as in NOCS).

    Returns:
        The error in degrees, a Python ``float``.

    Raises:
        InputError: on a wrong shape, NaN, a non-rotation matrix or an unknown symmetry.
    """
    Rp = _rotation(R_pred, "R_pred")
    Rg = _rotation(R_gt, "R_gt")
    if _symmetry(symmetry) == "y":
        return _angle_between_deg(Rp[:, 1], Rg[:, 1])
    D = Rp.T @ Rg
    # For a rotation by theta: trace = 1 + 2 cos(theta) and D - D^T = 2 sin(theta) [axis]_x.
    cos = 0.5 * (np.trace(D) - 1.0)
    sin = 0.5 * np.linalg.norm([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
    return float(np.degrees(math.atan2(sin, cos)))


def translation_error_m(t_pred, t_gt) -> float:
    """Euclidean distance in metres between the predicted and ground-truth ``(3,)`` part centres."""
    tp = _array(t_pred, "t_pred", (3,))
    tg = _array(t_gt, "t_gt", (3,))
    return float(np.linalg.norm(tp - tg))


def normalized_translation_error(t_pred, t_gt, size_gt) -> float:
    """Translation error divided by the diagonal of the ground-truth box (dimensionless).

    Args:
        t_pred: ``(3,)`` predicted part centre, metres.
        t_gt: ``(3,)`` ground-truth part centre, metres (same frame).
        size_gt: ``(3,)`` ground-truth box extents, metres (> 0); the diagonal is ``|size_gt|``.

    Returns:
        ``|t_pred - t_gt| / |size_gt|`` as a Python ``float``.
    """
    size = check_size(size_gt, "size_gt")
    return translation_error_m(t_pred, t_gt) / float(np.linalg.norm(size))


def box_iou(cam_from_part_pred, size_pred, cam_from_part_gt, size_gt, symmetry: str = "none", num_angles: int = 36) -> float:
    """Exact 3D IoU of the predicted and ground-truth amodal part boxes.

    Args:
        cam_from_part_pred: ``(4, 4)`` predicted pose (part frame -> camera frame); the box is centred
            on the part-frame origin and aligned with its axes.
        size_pred: ``(3,)`` predicted box extents along the part's x, y, z, metres (> 0).
        cam_from_part_gt: ``(4, 4)`` ground-truth pose, same frames.
        size_gt: ``(3,)`` ground-truth box extents, metres (> 0).
        symmetry: ``"none"``: the IoU of the two oriented boxes
            (:func:`ucope.geometry.boxes.box_iou_3d`); ``"y"``: the best IoU over rotations of the
            predicted box about its own y axis (:func:`ucope.geometry.boxes.box_iou_3d_symmetric_y`:
            the global maximum over the angle, certified to 1e-3 by a Lipschitz bound and refined to
            about 1e-7).
        num_angles: starting angles of that search for ``symmetry="y"`` (ignored otherwise).

    Returns:
        IoU in ``[0, 1]`` as a Python ``float``: exact (convex polyhedron intersection), not NOCS's
        axis-aligned approximation.

    Raises:
        InputError: on bad poses or sizes (the message names the argument) or an unknown symmetry.
    """
    Tp = check_transform(cam_from_part_pred, "cam_from_part_pred")
    sp = check_size(size_pred, "size_pred")
    Tg = check_transform(cam_from_part_gt, "cam_from_part_gt")
    sg = check_size(size_gt, "size_gt")
    if _symmetry(symmetry) == "y":
        return float(box_iou_3d_symmetric_y(Tg, sg, Tp, sp, num_angles=num_angles))
    return float(box_iou_3d(Tg, sg, Tp, sp))


def part_errors(cam_from_part_pred, size_pred, cam_from_part_gt, size_gt, symmetry: str = "none") -> dict:
    """All per-part pose errors of one part in one sample, as a JSON-friendly dict.

    Args: as :func:`box_iou`.

    Returns:
        ``{"rotation_deg", "translation_m", "translation_norm", "iou"}`` (Python floats): rotation
        error in degrees (:func:`rotation_error_deg`), centre distance in metres, the same divided by
        the ground-truth box diagonal, and the exact 3D IoU in ``[0, 1]``.
    """
    Tp = check_transform(cam_from_part_pred, "cam_from_part_pred")
    Tg = check_transform(cam_from_part_gt, "cam_from_part_gt")
    return {
        "rotation_deg": rotation_error_deg(Tp[:3, :3], Tg[:3, :3], symmetry),
        "translation_m": translation_error_m(Tp[:3, 3], Tg[:3, 3]),
        "translation_norm": normalized_translation_error(Tp[:3, 3], Tg[:3, 3], size_gt),
        "iou": box_iou(Tp, size_pred, Tg, size_gt, symmetry),
    }


# --------------------------------------------------------------------------------------------------
# Per joint
# --------------------------------------------------------------------------------------------------


def axis_angle_error_deg(u_pred, u_gt, signed: bool = False) -> float:
    """Angle between two joint axis directions.

    Args:
        u_pred, u_gt: ``(3,)`` non-zero axis directions (any length; normalised here), same frame.
        signed: ``False``: the angle between the axis lines, ``min(theta, 180 - theta)``, in ``[0, 90]``
            (opposite directions give 0); ``True``: the angle ``theta`` between the directions, in
            ``[0, 180]`` (opposite directions give 180).

    Returns:
        Degrees.
    """
    a = _unit(u_pred, "u_pred")
    b = _unit(u_gt, "u_gt")
    dot = float(np.dot(a, b))
    return float(np.degrees(math.atan2(np.linalg.norm(np.cross(a, b)), dot if signed else abs(dot))))


def line_distance_m(p1, u1, p2, u2, parallel_tol_rad: float = 1e-6) -> float:
    """Distance in metres between two infinite 3D lines ``p1 + s u1`` and ``p2 + s u2``.

    Used as the pivot (joint location) error of revolute joints: any point on each axis line will do.

    * Skew or intersecting lines: ``|(p2 - p1) . (u1 x u2)| / |u1 x u2|`` (0 if they intersect).
    * Parallel lines (the angle between the directions, or between one and the opposite of the other,
      is below ``parallel_tol_rad``): handled explicitly as the distance from ``p2`` to line 1,
      ``|(p2 - p1) x u1|`` with ``u1`` normalised, i.e. the lines' separation.

    Args:
        p1, p2: ``(3,)`` a point on each line, metres, same frame.
        u1, u2: ``(3,)`` non-zero line directions (normalised here).
        parallel_tol_rad: angle below which the lines count as parallel.

    Returns:
        The distance in metres, a Python ``float``.
    """
    p1 = _array(p1, "p1", (3,))
    p2 = _array(p2, "p2", (3,))
    u1 = _unit(u1, "u1")
    u2 = _unit(u2, "u2")
    d = p2 - p1
    n = np.cross(u1, u2)
    sin = float(np.linalg.norm(n))
    if sin < math.sin(check_scalar(parallel_tol_rad, "parallel_tol_rad")):
        return float(np.linalg.norm(np.cross(d, u1)))
    return float(abs(np.dot(d, n)) / sin)


def state_error(pred, gt, joint_type) -> float:
    """Joint state error: degrees for a revolute joint, metres for a prismatic one.

    Args:
        pred, gt: joint states as stored in the data sets: radians (revolute) or metres (prismatic).
        joint_type: ``"revolute"`` / ``0`` or ``"prismatic"`` / ``1`` (``"fixed"`` raises).

    Returns:
        Revolute: ``|pred - gt|`` wrapped to ``[0, 180]`` degrees (states differing by a full turn
        are the same configuration). Prismatic: ``|pred - gt|`` in metres.
        Both states are taken about their own axes; the caller must express them with the same axis sign.
    """
    p = check_scalar(pred, "pred")
    g = check_scalar(gt, "gt")
    if _joint_type(joint_type) == "prismatic":
        return abs(p - g)
    d = math.remainder(p - g, 2.0 * math.pi)  # in [-pi, pi]
    return float(np.degrees(abs(d)))


def joint_errors(axis_pred, pivot_pred, state_pred, axis_gt, pivot_gt, state_gt, joint_type) -> dict:
    """All errors of one joint in one sample, as a JSON-friendly dict.

    A joint state is signed by its axis (turning by ``q`` about ``u`` is turning by ``-q`` about ``-u``;
    sliding ``q`` along ``u`` is sliding ``-q`` along ``-u``), and a category's axis sign is part of its
    state convention (a door's positive state opens it). So the axis error is sign-aware: ``axis_deg`` is
    the angle between the two directions, in ``[0, 180]`` (a prediction about the opposite axis is 180
    degrees off), and the state error compares the two states as they are. A prediction that differs
    from the ground truth only by the sign of its axis and of its state (the same motion in the other
    convention) reads 180 degrees of axis error and the state error of ``|q_pred - q_gt|``;
    ``axis_line_deg`` (the angle between the axis lines, sign aside, in ``[0, 90]``) and ``axis_flipped``
    say so.

    Args:
        axis_pred, axis_gt: ``(3,)`` joint axis directions, camera frame (normalised here).
        pivot_pred, pivot_gt: ``(3,)`` a point on each axis, camera frame, metres (ignored for prismatic
            joints, may be ``None`` there).
        state_pred, state_gt: joint states about / along their own axes, radians (revolute) or metres
            (prismatic).
        joint_type: ``"revolute"`` / ``0`` or ``"prismatic"`` / ``1``.

    Returns:
        ``{"joint_type": "revolute" | "prismatic", "axis_deg": float, "axis_line_deg": float,
        "pivot_m": float | None, "state_error": float, "state_unit": "deg" | "m", "axis_flipped": bool}``;
        ``pivot_m`` (:func:`line_distance_m`) is ``None`` for prismatic joints, whose axis has no
        location; ``axis_flipped``: the predicted axis points away from the ground truth's
        (``axis_pred . axis_gt < 0``).

    Raises:
        InputError: on a zero or malformed axis, a non-finite state or pivot, or an unknown joint type.
    """
    jt = _joint_type(joint_type)
    flipped = bool(np.dot(_unit(axis_pred, "axis_pred"), _unit(axis_gt, "axis_gt")) < 0.0)
    out = {
        "joint_type": jt,
        "axis_deg": axis_angle_error_deg(axis_pred, axis_gt, signed=True),
        "axis_line_deg": axis_angle_error_deg(axis_pred, axis_gt),
        "pivot_m": None,
    }
    if jt == "revolute":
        out["pivot_m"] = line_distance_m(pivot_pred, axis_pred, pivot_gt, axis_gt)
    out["state_error"] = state_error(check_scalar(state_pred, "state_pred"), state_gt, jt)
    out["state_unit"] = "deg" if jt == "revolute" else "m"
    out["axis_flipped"] = flipped
    return out


# --------------------------------------------------------------------------------------------------
# Segmentation
# --------------------------------------------------------------------------------------------------


def _labels(x, name: str, low: int, num_parts: int) -> np.ndarray:
    arr = np.asarray(x)
    if arr.ndim != 1 or arr.size == 0:
        raise InputError(f"{name} must be a non-empty (N,) array of part indices, got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer):
        raise InputError(f"{name} must hold integers (part indices), got dtype {arr.dtype}")
    if num_parts is not None and (arr.min() < low or arr.max() >= num_parts):
        raise InputError(f"{name} must lie in [{low}, {num_parts}), got values in [{arr.min()}, {arr.max()}]")
    return arr.astype(np.int64)


def _num_parts(num_parts) -> int:
    if isinstance(num_parts, bool | np.bool_) or not isinstance(num_parts, int | np.integer) or num_parts < 1:
        raise InputError(f"num_parts must be an integer >= 1, got {num_parts!r}")
    return int(num_parts)


def segmentation_iou(pred_labels, gt_labels, num_parts: int) -> np.ndarray:
    """Per-part IoU of a point segmentation.

    ``IoU_k = |{pred = k} & {gt = k}| / |{pred = k} | {gt = k}|`` over the N points.

    Args:
        pred_labels: ``(N,)`` integer predicted part index per point, in ``[0, K)``, or ``-1`` for a
            point assigned to no part (it then only counts in the union of its ground-truth part).
        gt_labels: ``(N,)`` integer ground-truth part index per point, in ``[0, K)``.
        num_parts: K.

    Returns:
        ``(K,)`` float64 IoUs in ``[0, 1]``; **NaN** for a part absent from both the prediction and the
        ground truth (its IoU is undefined). Average with ``np.nanmean`` to exclude such parts.

    Raises:
        InputError: on shapes that differ, empty or non-integer labels, or labels out of range.
    """
    k = _num_parts(num_parts)
    pred = _labels(pred_labels, "pred_labels", -1, k)
    gt = _labels(gt_labels, "gt_labels", 0, k)
    if pred.shape != gt.shape:
        raise InputError(f"pred_labels {pred.shape} and gt_labels {gt.shape} must have the same shape")
    ious = np.full(k, np.nan)
    for part in range(k):
        p, g = pred == part, gt == part
        union = np.count_nonzero(p | g)
        if union > 0:
            ious[part] = np.count_nonzero(p & g) / union
    return ious


def segmentation_accuracy(pred_labels, gt_labels) -> float:
    """Fraction of points whose predicted part index equals the ground truth, in ``[0, 1]``.

    Args:
        pred_labels, gt_labels: ``(N,)`` integer part indices (``-1`` in the prediction is simply wrong).
    """
    pred = _labels(pred_labels, "pred_labels", -1, None)
    gt = _labels(gt_labels, "gt_labels", 0, None)
    if pred.shape != gt.shape:
        raise InputError(f"pred_labels {pred.shape} and gt_labels {gt.shape} must have the same shape")
    return float(np.mean(pred == gt))


# --------------------------------------------------------------------------------------------------
# Metric names (shared with ucope.eval.mean_ap)
# --------------------------------------------------------------------------------------------------


def pose_metric_name(deg: float, cm: float) -> str:
    return f"{round(deg, 6):g}deg{round(cm, 6):g}cm"


# --------------------------------------------------------------------------------------------------
# Summaries
# --------------------------------------------------------------------------------------------------


def _stats(values: list) -> dict:
    """``{"mean", "median"}`` of the non-None values (``None`` if there are none)."""
    vals = [v for v in values if v is not None]
    if not vals:
        return {"mean": None, "median": None}
    return {"mean": float(np.mean(vals)), "median": float(np.median(vals))}


def _check_table(samples, name: str) -> int:
    """Check a list (samples) of lists (parts / joints) of dicts or None; return the common length."""
    if isinstance(samples, str | bytes | Mapping) or not isinstance(samples, Sequence) or len(samples) == 0:
        raise InputError(f"{name} must be a non-empty list (one entry per sample) of lists of dicts")
    lengths = set()
    for i, row in enumerate(samples):
        if isinstance(row, str | bytes | Mapping) or not isinstance(row, Sequence):
            raise InputError(f"{name}[{i}] must be a list (one dict or None per part / joint)")
        lengths.add(len(row))
        for j, d in enumerate(row):
            if d is not None and not isinstance(d, Mapping):
                raise InputError(f"{name}[{i}][{j}] must be a dict or None, got {type(d).__name__}")
    if len(lengths) != 1:
        raise InputError(f"every sample of {name} must have the same number of entries, got {sorted(lengths)}")
    return lengths.pop()


def _value(d, key: str, where: str):
    if d is None or d.get(key) is None:
        return None
    return check_scalar(d[key], f"{where}['{key}']")


def summarize_parts(
    samples: Sequence[Sequence[Mapping | None]],
    pose_thresholds_deg_m: Sequence[tuple[float, float]] = ((5, 0.05), (10, 0.10)),
    iou_thresholds: Sequence[float] = (0.5, 0.75),
    rotation_thresholds_deg: Sequence[float] = (5, 10),
) -> dict:
    """Per-part mean / median errors and success fractions over samples (Table-2-shaped).

    Args:
        samples: one list per sample of K per-part dicts from :func:`part_errors`
            (``rotation_deg``, ``translation_m``, ``translation_norm``, ``iou``); every sample has the
            same K (one category).  A part whose prediction is missing may be ``None`` (or have ``None``
            values): it is left out of the means and medians and counts as a failure in the fractions.
        pose_thresholds_deg_m: ``(degrees, metres)`` pairs; a part passes if its rotation error is
            ``<= degrees`` and its translation error ``<= metres``.  Named ``5deg5cm``, ``10deg10cm``.
        iou_thresholds: a part passes if its IoU is ``>= t``; named ``iou50``, ``iou75``.
        rotation_thresholds_deg: a part passes if its rotation error is ``<= degrees`` (translation
            not looked at); named ``5deg``, ``10deg``.

    Returns:
        A JSON-friendly dict; every leaf list has one entry per part (like the paper's Table 2 cells)::

            {"num_samples": N, "num_parts": K, "num_missing": [K ints],
             "rotation_deg": {"mean": [K], "median": [K]}, "translation_m": {...},
             "translation_norm": {...}, "iou": {...},      # IoU as a fraction in [0, 1]
             "fraction": {"5deg5cm": [K], "10deg10cm": [K], "iou50": [K], "iou75": [K],
                          "5deg": [K], "10deg": [K]}}

        Means / medians are ``None`` for a part with no valid value.
    """
    k = _check_table(samples, "samples")
    keys = ("rotation_deg", "translation_m", "translation_norm", "iou")
    cols = {key: [[_value(row[j], key, f"samples[{i}][{j}]") for i, row in enumerate(samples)] for j in range(k)] for key in keys}
    n = len(samples)
    out = {
        "num_samples": n,
        "num_parts": k,
        "num_missing": [sum(1 for v in cols["rotation_deg"][j] if v is None) for j in range(k)],
    }
    for key in keys:
        stats = [_stats(cols[key][j]) for j in range(k)]
        out[key] = {"mean": [s["mean"] for s in stats], "median": [s["median"] for s in stats]}
    fraction = {}
    for pair in pose_thresholds_deg_m:
        if np.shape(pair) != (2,):
            raise InputError(f"pose_thresholds_deg_m must hold (degrees, metres) pairs, got {pair!r}")
        deg, m = check_scalar(pair[0], "pose threshold (deg)"), check_scalar(pair[1], "pose threshold (m)")
        name = pose_metric_name(deg, 100.0 * m)
        fraction[name] = [
            sum(
                1
                for r, t in zip(cols["rotation_deg"][j], cols["translation_m"][j], strict=False)
                if r is not None and t is not None and r <= deg and t <= m
            )
            / n
            for j in range(k)
        ]
    for t in iou_thresholds:
        t = check_scalar(t, "iou threshold")
        fraction[f"iou{round(t * 100):d}"] = [sum(1 for v in cols["iou"][j] if v is not None and v >= t) / n for j in range(k)]
    for deg in rotation_thresholds_deg:
        deg = check_scalar(deg, "rotation threshold (deg)")
        fraction[f"{deg:g}deg"] = [sum(1 for v in cols["rotation_deg"][j] if v is not None and v <= deg) / n for j in range(k)]
    out["fraction"] = fraction
    return out


def summarize_joints(samples: Sequence[Sequence[Mapping | None]]) -> dict:
    """Per-joint mean / median errors over samples.

    Args:
        samples: one list per sample of K-1 per-joint dicts from :func:`joint_errors` (same joint count
            in every sample; ``None`` for a missing prediction, left out of the statistics).

    Returns:
        ``{"num_samples": N, "num_joints": J, "joint_type": [J], "state_unit": [J],
        "axis_deg": {"mean": [J], "median": [J]}, "axis_line_deg": {...}, "pivot_m": {...}, "state_error": {...},
        "axis_flipped_fraction": [J]}``; ``pivot_m`` statistics are ``None`` for prismatic joints; the
        fraction of samples whose predicted axis pointed away from the ground truth's (``None`` without any).
    """
    j_count = _check_table(samples, "samples")
    out = {"num_samples": len(samples), "num_joints": j_count, "joint_type": [], "state_unit": []}
    for j in range(j_count):
        kinds = {row[j].get("joint_type") for row in samples if row[j] is not None}
        if len(kinds) > 1:
            raise InputError(f"joint {j} has different joint types across samples: {sorted(map(str, kinds))}")
        kind = kinds.pop() if kinds else None
        out["joint_type"].append(kind)
        out["state_unit"].append({"revolute": "deg", "prismatic": "m"}.get(kind))
    for key in ("axis_deg", "axis_line_deg", "pivot_m", "state_error"):
        stats = [_stats([_value(row[j], key, f"samples[{i}][{j}]") for i, row in enumerate(samples)]) for j in range(j_count)]
        out[key] = {"mean": [s["mean"] for s in stats], "median": [s["median"] for s in stats]}
    flips = [
        [bool(row[j]["axis_flipped"]) for row in samples if row[j] is not None and "axis_flipped" in row[j]]
        for j in range(j_count)
    ]
    out["axis_flipped_fraction"] = [sum(f) / len(f) if f else None for f in flips]
    return out
