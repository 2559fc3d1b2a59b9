"""Shared pieces of the data-set readers: checked file and image reads (regular files only, references kept
inside the data set's folder), checked numbers, and building a sample from labelled pixels."""

from __future__ import annotations

import os
import stat
import zlib
from pathlib import Path, PurePosixPath, PureWindowsPath

import numpy as np

from ...errors import DataError, InputError
from ...geometry.normals import estimate_normals
from ...geometry.sampling import random_subset

__all__ = [
    "regular_file",
    "inside_root",
    "read_data_json",
    "finite_array",
    "read_image",
    "read_depth",
    "read_label_image",
    "sample_from_pixels",
    "MIN_OBJECT_POINTS",
]

MIN_OBJECT_POINTS = 32
"""Objects with fewer measured pixels than this are skipped (the estimator needs 32 points)."""


def regular_file(path: str | Path, what: str) -> Path:
    """``path`` if it is a regular file (following links); :class:`DataError` naming it and ``what`` it
    should be when it is missing, a folder, or a FIFO, socket or device (reading those could block)."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise DataError(f"{path}: no such file (the {what})") from None
    except OSError as e:
        raise DataError(f"{path}: cannot read the {what} ({e.strerror or e})") from None
    if not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a FIFO, socket or device)"
        raise DataError(f"{path}: {kind}, expected the {what}")
    return path


def inside_root(root: str | Path, reference, what: str, where: str, subdirs: tuple[str, ...] = ("",)) -> Path:
    """The file a data set's annotation refers to, kept inside the data set: ``reference`` must be a
    relative path without ``..`` that, joined to ``root / subdir`` (the first of ``subdirs`` where it
    exists), resolves (links followed) inside ``root``.

    Raises :class:`DataError` naming ``where`` (the annotation and field) for an absolute path, a ``..``
    component, a reference that leaves ``root`` through a link, or one that is not a string."""
    if not isinstance(reference, str) or not reference:
        raise DataError(f"{where}: must be a relative file path (a string), got {reference!r}")
    parts = PurePosixPath(reference.replace("\\", "/")).parts
    if PurePosixPath(reference).is_absolute() or PureWindowsPath(reference).is_absolute() or PureWindowsPath(reference).drive:
        raise DataError(f"{where}: {reference!r} is an absolute path; data-set references must stay inside {root}")
    if ".." in parts:
        raise DataError(f"{where}: {reference!r} climbs out with '..'; data-set references must stay inside {root}")
    root = Path(root)
    cands = [root / sub / reference for sub in subdirs]
    path = next((c for c in cands if c.exists()), cands[0])
    real_root = root.resolve()
    real = path.resolve()
    if real != real_root and real_root not in real.parents:
        raise DataError(f"{where}: {reference!r} leads to {real}, outside the data set's folder {real_root} (through a link)")
    return path


def read_data_json(path: str | Path, what: str):
    """A data set's JSON file, read through :func:`ucope.fileio.read_json` after checking that it is a
    regular file (:class:`DataError` naming it otherwise)."""
    from ...fileio import read_json

    return read_json(regular_file(path, what))


def finite_array(value, shape: tuple, where: str, what: str = "numbers") -> np.ndarray:
    """``value`` as a float64 array of ``shape`` (``-1`` = any length) with every entry finite;
    :class:`DataError` naming ``where`` for a ragged or non-numeric value, another shape, NaN or Inf."""
    if isinstance(value, bool | str | bytes | dict) or value is None:
        raise DataError(f"{where}: expected {what} of shape {shape}, got {type(value).__name__} {str(value)[:60]!r}")
    try:
        arr = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{where}: expected {what} of shape {shape} (a ragged or non-numeric list)") from None
    if arr.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, arr.shape, strict=True)):
        raise DataError(f"{where}: expected {what} of shape {shape}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise DataError(f"{where}: {what} must be finite, got NaN or Inf")
    return arr


def read_image(path: str | Path, what: str) -> np.ndarray:
    """A PNG / JPEG image as an array (``(H, W)`` or ``(H, W, C)``, its own dtype; 16-bit kept).

    Raises :class:`DataError` naming the file and ``what`` it should be, if missing, not a regular file
    or unreadable."""
    path = regular_file(path, what)
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
