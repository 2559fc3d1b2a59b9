"""Normal estimation for point clouds: k-nearest-neighbour PCA, oriented towards a viewpoint."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError

__all__ = ["estimate_normals", "smallest_eigenvectors_sym3"]


def smallest_eigenvectors_sym3(cov: np.ndarray) -> np.ndarray:
    """Unit eigenvectors of the smallest eigenvalue of a batch of symmetric 3x3 matrices.

    Closed form (trigonometric eigenvalues, then the longest cross product of two rows of
    ``cov - lambda_min I``), about 8x faster than :func:`numpy.linalg.eigh` on large batches. Rows where
    the smallest eigenvalue is (nearly) repeated, so the eigenvector is not unique, fall back to ``eigh``.

    Args:
        cov: ``(N, 3, 3)`` symmetric matrices (float64 recommended).

    Returns:
        ``(N, 3)`` unit vectors, sign arbitrary.
    """
    a = np.asarray(cov, dtype=np.float64)
    scale = np.abs(a).max(axis=(1, 2))
    scale = np.where(scale > 0, scale, 1.0)
    a = a / scale[:, None, None]
    q = np.trace(a, axis1=1, axis2=2) / 3.0
    b = a - q[:, None, None] * np.eye(3)
    p = np.sqrt(np.maximum((b * b).sum(axis=(1, 2)) / 6.0, 1e-300))
    det = np.linalg.det(b / p[:, None, None]) / 2.0
    phi = np.arccos(np.clip(det, -1.0, 1.0)) / 3.0
    lam_min = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    m = a - lam_min[:, None, None] * np.eye(3)
    r0, r1, r2 = m[:, 0], m[:, 1], m[:, 2]
    cands = np.stack([np.cross(r0, r1), np.cross(r0, r2), np.cross(r1, r2)], axis=1)  # (N, 3, 3)
    norms = np.linalg.norm(cands, axis=-1)
    best = norms.argmax(axis=1)
    rows = np.arange(len(a))
    vec = cands[rows, best]
    n = norms[rows, best]
    # The cross product is reliable when two rows of m are well independent, i.e. the other two
    # eigenvalues are well separated from lambda_min (n ~ gap1 * gap2 on a unit-scaled matrix).
    bad = n < 1e-6
    out = vec / np.where(bad, 1.0, n)[:, None]
    if bad.any():
        out[bad] = np.linalg.eigh(a[bad])[1][:, :, 0]
    return out


def estimate_normals(
    points: np.ndarray, k: int = 16, viewpoint: np.ndarray | None = (0.0, 0.0, 0.0), workers: int = 1, rows=None
) -> np.ndarray:
    """Unit normals of a ``(N, 3)`` cloud by PCA over each point's ``k`` nearest neighbours.

    The normal is the eigenvector of the neighbourhood covariance with the smallest eigenvalue. With a
    ``viewpoint`` (default: the camera centre, for clouds in the camera frame) every normal is flipped
    to face it, ``n . (viewpoint - p) >= 0``; with ``None`` the sign is arbitrary.

    Args:
        points: ``(N, 3)`` metres, N >= 3.
        k: neighbourhood size (clipped to N).
        workers: threads for the KD-tree query.
        rows: optional indices of the points whose normals are wanted (their neighbours are still
            searched in the whole cloud, so each is the same as in the full result).

    Returns:
        ``(N, 3)`` float32 unit normals (``(len(rows), 3)`` with ``rows``).
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    if len(pts) < 3:
        raise InputError(f"normal estimation needs at least 3 points, got {len(pts)}")
    if not np.all(np.isfinite(pts)):
        raise InputError("points contain NaN or Inf")
    k = int(min(max(k, 3), len(pts)))
    query = pts if rows is None else pts[np.asarray(rows, dtype=np.int64)]
    _, idx = cKDTree(pts).query(query, k=k, workers=workers)
    nb = pts[idx]  # (N, k, 3)
    nb = nb - nb.mean(axis=1, keepdims=True)
    cov = nb.transpose(0, 2, 1) @ nb  # (N, 3, 3)
    normals = smallest_eigenvectors_sym3(cov)
    if viewpoint is not None:
        flip = ((np.asarray(viewpoint, np.float64) - query) * normals).sum(-1) < 0
        normals[flip] *= -1.0
    return normals.astype(np.float32)
