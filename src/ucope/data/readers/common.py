"""Shared pieces of the data-set readers: checked image reads and building a sample from labelled pixels."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from ...errors import DataError, InputError
from ...geometry.normals import estimate_normals
from ...geometry.sampling import random_subset

__all__ = ["read_image", "read_depth", "read_label_image", "sample_from_pixels", "MIN_OBJECT_POINTS"]

MIN_OBJECT_POINTS = 32
"""Objects with fewer measured pixels than this are skipped (the estimator needs 32 points)."""


def read_image(path: str | Path, what: str) -> np.ndarray:
    """A PNG / JPEG image as an array (``(H, W)`` or ``(H, W, C)``, its own dtype; 16-bit kept).

    Raises :class:`DataError` naming the file and ``what`` it should be, if missing or unreadable."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file (the {what})")
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - depends on the environment
        raise InputError('reading images needs Pillow: pip install "ucope[images]"') from None
    try:
        with Image.open(path) as im:
            arr = np.array(im)
    except Exception as e:  # PIL raises many types for corrupt files
        raise DataError(f"{path}: not a readable image, expected the {what} ({type(e).__name__}: {e})") from None
    if arr.dtype == np.int32:  # 16-bit PNGs may come back as mode "I"
        arr = arr.astype(np.uint16)
    return arr


def read_depth(path: str | Path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """A single-channel 16-bit depth PNG (raw units). Raises :class:`DataError` for more channels or a
    size other than ``shape`` ``(H, W)``."""
    d = read_image(path, "depth image (16-bit, one channel)")
    if d.ndim != 2:
        raise DataError(f"{path}: a depth image must have one channel, got shape {d.shape}")
    if shape is not None and d.shape != tuple(shape):
        raise DataError(f"{path}: the depth image is {d.shape[1]}x{d.shape[0]}, expected {shape[1]}x{shape[0]}")
    return d


def read_label_image(path: str | Path, what: str, shape: tuple[int, int] | None = None, channel: int = 0) -> np.ndarray:
    """An integer label image; a colour PNG gives its ``channel`` (NOCS's masks hold the id in red)."""
    m = read_image(path, what)
    if m.ndim == 3:
        m = m[..., channel]
    if m.ndim != 2 or not np.issubdtype(m.dtype, np.integer):
        raise DataError(f"{path}: the {what} must be an integer image, got shape {m.shape} dtype {m.dtype}")
    if shape is not None and m.shape != tuple(shape):
        raise DataError(f"{path}: the {what} is {m.shape[1]}x{m.shape[0]}, the depth image {shape[1]}x{shape[0]}")
    return m


def sample_from_pixels(
    depth_m: np.ndarray,
    intrinsics,
    labels: np.ndarray,
    gt: dict,
    category: str,
    instance_id: str,
    index: int,
    max_points: int = 4096,
    normal_k: int = 16,
) -> dict:
    """A sample (:mod:`ucope.data.sample` fields) from the labelled pixels of one object.

    Args:
        depth_m: ``(H, W)`` depth in metres (0 / NaN = none).
        intrinsics: ``(fx, fy, cx, cy)``.
        labels: ``(H, W)`` int: the part index of each object pixel, -1 elsewhere.
        gt: ``cam_from_part (K, 4, 4)``, ``size_m (K, 3)``, ``joint_type (J,)``, ``joint_pivot (J, 3)``,
            ``joint_axis (J, 3)``, ``joint_state (J,)`` (NaN where unknown); extra keys are copied.
        instance_id: a name unique in the data set (seeds the subsampling: the same file gives the
            same sample).

    Returns:
        the sample dict, or ``None`` when fewer than :data:`MIN_OBJECT_POINTS` pixels have depth.
    """
    fx, fy, cx, cy = (float(v) for v in intrinsics)
    d = np.asarray(depth_m, np.float64)
    ok = (labels >= 0) & np.isfinite(d) & (d > 0)
    rows, cols = np.nonzero(ok)
    if len(rows) < MIN_OBJECT_POINTS:
        return None
    z = d[rows, cols]
    pts = np.stack([(cols - cx) / fx * z, (rows - cy) / fy * z, z], axis=1)
    lab = labels[rows, cols].astype(np.int64)
    if len(pts) > max_points:
        rng = np.random.default_rng(zlib.crc32(instance_id.encode("utf-8")))
        keep = np.sort(random_subset(len(pts), max_points, rng))
        pts, lab = pts[keep], lab[keep]
    pts = pts.astype(np.float32)
    cam_from_part = np.asarray(gt["cam_from_part"], np.float64)
    out = {
        "points": pts,
        "normals": estimate_normals(pts, k=normal_k),
        "part_labels": lab,
        "cam_from_part": cam_from_part,
        "size_m": np.asarray(gt["size_m"], np.float64),
        "joint_type": np.asarray(gt.get("joint_type", np.zeros(0)), np.int64).reshape(-1),
        "joint_pivot": np.asarray(gt.get("joint_pivot", np.zeros((0, 3))), np.float64).reshape(-1, 3),
        "joint_axis": np.asarray(gt.get("joint_axis", np.zeros((0, 3))), np.float64).reshape(-1, 3),
        "joint_state": np.asarray(gt.get("joint_state", np.zeros(0)), np.float64).reshape(-1),
        "cam_from_object": cam_from_part[0],
        "intrinsics": np.array([fx, fy, cx, cy]),
        "category": category,
        "instance_id": instance_id,
        "index": int(index),
    }
    for k, v in gt.items():
        out.setdefault(k, v)
    return out
