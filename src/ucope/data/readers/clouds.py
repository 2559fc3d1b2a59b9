"""Segmented point clouds: a cloud whose points carry an instance id, one per object (``ucope predict --input
CLOUD --instances 1=laptop 2=mug``).

* ``.npz``: the ``points`` array (and optional ``normals``) of :func:`ucope.data.io.read_point_cloud`, plus an
  integer array named by one of :data:`INSTANCE_KEYS` (``instance``...) of one id per point (the shape of
  ``points`` without its last axis: ``(N,)``, or ``(H, W)`` for an organised cloud);
* ``.ply``: a ``vertex`` property named by one of :data:`INSTANCE_KEYS` (``property int instance``).

Ids are non-negative integers (a float property must hold whole numbers); points of ids that are not
asked for (background, 0 by convention) are left out.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from ...errors import DataError, InputError
from .common import regular_file

__all__ = ["INSTANCE_KEYS", "read_instance_ids", "read_segmented_cloud"]

INSTANCE_KEYS = ("instance", "instance_id", "instances", "instance_ids")
"""Names of the per-point instance id array (``.npz``) or vertex property (``.ply``), tried in order."""


def _ids(path: Path, raw, n_points: tuple[int, ...], where: str) -> np.ndarray:
    a = np.asarray(raw)
    if a.dtype.kind not in "iuf" or a.dtype == np.bool_:
        raise DataError(f"{path}: {where} must hold integer instance ids, got dtype {a.dtype}")
    if a.shape != n_points:
        raise DataError(f"{path}: {where} has shape {a.shape}, the points {n_points} (one id per point)")
    if a.dtype.kind == "f":
        if not np.all(np.isfinite(a)) or np.any(a != np.round(a)):
            raise DataError(f"{path}: {where} must hold whole numbers (instance ids), got NaN / Inf or fractions")
        a = a.astype(np.int64)
    a = a.astype(np.int64).reshape(-1)
    if a.size and a.min() < 0:
        raise DataError(f"{path}: {where} must hold non-negative instance ids, got {int(a.min())}")
    return a


def read_instance_ids(path: str | Path) -> np.ndarray | None:
    """The per-point instance ids of a cloud file (flattened, ``(N,)`` int64), or ``None`` when it has none
    (or is a format without them). Raises :class:`DataError` naming the file for ids of another length, not
    integers, or negative."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".npz", ".ply"):
        return None
    regular_file(path, "point cloud")
    try:
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                key = next((k for k in INSTANCE_KEYS if k in z.files), None)
                if key is None:
                    return None
                if "points" not in z.files:
                    raise DataError(f"{path}: an .npz point cloud needs a 'points' array (found {sorted(z.files)})")
                return _ids(path, z[key], tuple(z["points"].shape[:-1]), f"'{key}'")
        try:
            import plyfile
        except ImportError:  # pragma: no cover - depends on the environment
            raise InputError(f'{path}: reading .ply files needs plyfile: pip install "ucope[ply]"') from None
        ply = plyfile.PlyData.read(str(path))
        if "vertex" not in [el.name for el in ply.elements]:
            return None
        v = ply["vertex"].data
        key = next((k for k in INSTANCE_KEYS if k in (v.dtype.names or ())), None)
        return None if key is None else _ids(path, v[key], (len(v),), f"vertex property '{key}'")
    except (DataError, InputError):
        raise
    except (OSError, ValueError, EOFError, KeyError, IndexError, zipfile.BadZipFile) as e:
        raise DataError(f"{path}: cannot read the point cloud ({type(e).__name__}: {e})") from None


def read_segmented_cloud(path: str | Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """``(points (N, 3), normals (N, 3) or None, instance ids (N,))`` of a segmented cloud file (an
    organised one flattened row by row). Raises :class:`DataError` naming the file when it holds no
    instance ids (and which names were looked for)."""
    from ..io import read_point_cloud

    path = Path(path)
    pts, nrm = read_point_cloud(path)
    ids = read_instance_ids(path)
    if ids is None:
        where = "an .npz array" if path.suffix.lower() == ".npz" else "a PLY vertex property"
        raise DataError(
            f"{path}: holds no per-point instance ids (looked for {where} named {', '.join(INSTANCE_KEYS)}); "
            "with --instances a cloud needs them (.npz or .ply)"
        )
    pts = np.asarray(pts, np.float64).reshape(-1, 3)
    return pts, None if nrm is None else np.asarray(nrm, np.float64).reshape(-1, 3), ids
