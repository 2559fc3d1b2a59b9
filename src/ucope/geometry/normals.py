"""Normal estimation for point clouds: k-nearest-neighbour PCA, oriented towards a viewpoint."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError

__all__ = ["estimate_normals"]


def estimate_normals(
    points: np.ndarray, k: int = 16, viewpoint: np.ndarray | None = (0.0, 0.0, 0.0), workers: int = 1
) -> np.ndarray:
    """Unit normals of a ``(N, 3)`` cloud by PCA over each point's ``k`` nearest neighbours.

    The normal is the eigenvector of the neighbourhood covariance with the smallest eigenvalue. With a
    ``viewpoint`` (default: the camera centre, for clouds in the camera frame) every normal is flipped
    to face it, ``n . (viewpoint - p) >= 0``; with ``None`` the sign is arbitrary.

    Args:
        points: ``(N, 3)`` metres, N >= 3.
        k: neighbourhood size (clipped to N).
        workers: threads for the KD-tree query.

    Returns:
        ``(N, 3)`` float32 unit normals.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    if len(pts) < 3:
        raise InputError(f"normal estimation needs at least 3 points, got {len(pts)}")
    if not np.all(np.isfinite(pts)):
        raise InputError("points contain NaN or Inf")
    k = int(min(max(k, 3), len(pts)))
    _, idx = cKDTree(pts).query(pts, k=k, workers=workers)
    nb = pts[idx]  # (N, k, 3)
    nb = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb)
    _, vecs = np.linalg.eigh(cov)  # ascending eigenvalues
    normals = vecs[:, :, 0]
    if viewpoint is not None:
        flip = ((np.asarray(viewpoint, np.float64) - pts) * normals).sum(-1) < 0
        normals[flip] *= -1.0
    return normals.astype(np.float32)
