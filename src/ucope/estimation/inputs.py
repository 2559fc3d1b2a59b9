"""Turning what users hold into the estimator's input: a checked, cleaned cloud.

* :func:`prepare_points`: validate an ``(N, 3)`` cloud (and optional normals), drop non-finite rows,
  subsample huge clouds, estimate normals;
* :func:`rgbd_points`: back-project a depth image (with a mask and / or a box) into the object's cloud;
* :func:`label_points`: carry the labels of the network's points over to every input point.

Frames and units: camera frame (OpenCV axes: x right, y down, z forward), metres.
"""

from __future__ import annotations

import warnings

import numpy as np
import torch

from ..errors import InputError
from ..geometry.normals import estimate_normals
from ..geometry.sampling import random_subset

__all__ = ["MIN_POINTS", "NORMAL_K", "prepare_points", "rgbd_points", "label_points"]

MIN_POINTS = 32
"""The fewest finite points :meth:`ucope.estimation.Estimator.predict` accepts."""

NORMAL_K = 16
"""Neighbours of the kNN-PCA normals estimated for clouds given without normals."""


def prepare_points(points, normals=None, max_points: int = 4096, seed: int = 0, normal_k: int = NORMAL_K,
                   estimate: bool = True) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """Validate and clean a cloud for the network.

    Args:
        points: ``(N, 3)`` camera frame, metres (any float dtype, numpy / torch / sequence).
        normals: optional ``(N, 3)`` (any sign; re-normalised); estimated when ``None``.
        max_points: clouds above this are subsampled uniformly (from ``seed``) before anything else.
        estimate: ``False`` leaves missing normals to the caller (``nrm`` is then ``None``; the
            estimator estimates them for the network's subset only).

    Returns:
        ``(pts, nrm, raw, finite)``: float32 ``(P, 3)`` points and unit normals (``P <= max_points``),
        the input as an ``(N, 3)`` array (not copied) and the ``(N,)`` mask of its usable rows.
    """
    if isinstance(points, torch.Tensor):
        points = points.detach().cpu().numpy()
    pts = np.asarray(points)
    if pts.dtype == object or not np.issubdtype(pts.dtype, np.number):
        raise InputError(f"points must be a numeric (N, 3) array, got dtype {pts.dtype}")
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    n_in = len(pts)
    if n_in == 0:
        raise InputError("the point cloud is empty")
    nrm = None
    if normals is not None:
        if isinstance(normals, torch.Tensor):
            normals = normals.detach().cpu().numpy()
        nrm = np.asarray(normals)
        if nrm.shape != pts.shape:
            raise InputError(f"normals must have the points' shape {pts.shape}, got {nrm.shape}")
    finite = np.isfinite(pts).all(axis=1)
    if nrm is not None:
        finite &= np.isfinite(nrm).all(axis=1) & (np.abs(nrm).sum(axis=1) > 0)
    kept = np.flatnonzero(finite)
    if len(kept) < n_in:
        if len(kept) < MIN_POINTS:
            raise InputError(f"only {len(kept)} of {n_in} points are finite (NaN / Inf / zero normals dropped); at least {MIN_POINTS} are needed")
        warnings.warn(f"dropped {n_in - len(kept)} of {n_in} points with NaN / Inf coordinates or normals", stacklevel=3)
    if len(kept) < MIN_POINTS:
        raise InputError(f"the cloud has {len(kept)} points; at least {MIN_POINTS} are needed")
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=(1,)))
    if len(kept) > max_points:
        kept = kept[random_subset(len(kept), max_points, rng)]
    p = pts[kept].astype(np.float32)
    if float(np.ptp(p, axis=0).max()) < 1e-6:
        raise InputError("all points coincide: the cloud has no extent")
    if nrm is None:
        n = estimate_normals(p, k=normal_k) if estimate else None
    else:
        n = nrm[kept].astype(np.float32)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
    return p, n, pts, finite


def label_points(raw: np.ndarray, finite: np.ndarray, ref: np.ndarray, ref_labels: np.ndarray, chunk: int = 1 << 18) -> np.ndarray:
    """The label of the nearest ``ref`` point for every usable row of ``raw`` (``-1`` elsewhere),
    in chunks so that a cloud of millions of points needs little extra memory."""
    from scipy.spatial import cKDTree

    tree = cKDTree(ref)
    out = np.full(len(raw), -1, dtype=np.int64)
    for lo in range(0, len(raw), chunk):
        f = np.flatnonzero(finite[lo : lo + chunk])
        if len(f):
            out[lo + f] = ref_labels[tree.query(raw[lo + f].astype(np.float32), k=1)[1]]
    return out


def rgbd_points(depth, intrinsics, mask=None, box=None, depth_scale: float = 1000.0, mask_label=None) -> np.ndarray:
    """The object's points (camera frame, metres) from a depth image, back-projected and cleaned.

    Args:
        depth: ``(H, W)`` depth (z, not range); ``depth / depth_scale`` is metres (default 1000:
            millimetres, as 16-bit PNGs hold them); 0, NaN or Inf = no measurement.
        intrinsics: ``(fx, fy, cx, cy)`` in pixels or a ``(3, 3)`` matrix K.
        mask: optional ``(H, W)`` object mask: boolean / 0-1, or a label image with ``mask_label``
            (one value or several) selecting the object's values.
        box: optional ``(x_min, y_min, x_max, y_max)`` pixel box (columns, rows; max exclusive) to
            crop to (e.g. a detector's box), combined with ``mask``.

    Points far from the bulk of the object (mask bleeding onto the background) are removed:
    those more than 3x the median distance from the median point, and at least 0.05 m away.
    """
    from ..render.camera import PinholeCamera

    d = np.asarray(depth)
    if d.ndim != 2 or d.size == 0:
        raise InputError(f"depth must be a non-empty (H, W) image, got shape {d.shape}")
    if not np.issubdtype(d.dtype, np.number):
        raise InputError(f"depth must be numeric, got dtype {d.dtype}")
    if not (np.isfinite(depth_scale) and depth_scale > 0):
        raise InputError(f"depth_scale must be positive, got {depth_scale}")
    H, W = d.shape
    K = np.asarray(intrinsics, dtype=np.float64)
    if K.shape == (3, 3):
        K = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    if K.shape != (4,) or not np.all(np.isfinite(K)) or K[0] <= 0 or K[1] <= 0:
        raise InputError(f"intrinsics must be (fx, fy, cx, cy) or a 3x3 K with positive focal lengths, got {np.asarray(intrinsics).tolist()}")
    valid = np.ones((H, W), bool)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape != (H, W):
            raise InputError(f"mask has shape {m.shape}, the depth image {d.shape}")
        valid &= np.isin(m, np.atleast_1d(mask_label)) if mask_label is not None else m.astype(bool)
    if box is not None:
        x0, y0, x1, y1 = (int(round(float(v))) for v in box)
        if not (0 <= x0 < x1 <= W and 0 <= y0 < y1 <= H):
            raise InputError(f"box {tuple(box)} is not inside the {W}x{H} image (x_min < x_max <= W, y_min < y_max <= H)")
        crop = np.zeros_like(valid)
        crop[y0:y1, x0:x1] = True
        valid &= crop
    cam = PinholeCamera(fx=K[0], fy=K[1], cx=K[2], cy=K[3], width=W, height=H)
    pts, _ = cam.backproject(d.astype(np.float64) / depth_scale, valid)
    if len(pts) == 0:
        raise InputError("no valid depth pixels inside the mask / box")
    med = np.median(pts, axis=0)
    r = np.linalg.norm(pts - med, axis=1)
    keep = r <= max(3.0 * float(np.median(r)), 0.05)
    return pts[keep]
