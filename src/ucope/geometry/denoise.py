"""Point-cloud noise: how much a cloud has off its surface, and taking it out.

* :func:`surface_noise`: a robust estimate of the spread of a cloud's points off its surface
  (the median, over points, of the RMS distance of each neighbourhood from its best plane).
* :func:`smooth_points`: local-plane projection (a first-order moving-least-squares step): every point
  moves along the normal of its neighbourhood's best plane onto it; repeated ``iterations`` times.

Units: whatever the points are in (metres for the estimator). Everything is vectorised over points.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .normals import smallest_eigenvectors_sym3

__all__ = ["surface_noise", "smooth_points"]


def _check(points) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    if len(pts) < 4:
        raise InputError(f"a surface needs at least 4 points, got {len(pts)}")
    if not np.all(np.isfinite(pts)):
        raise InputError("points contain NaN or Inf")
    return pts


def _planes(pts: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid ``(N, 3)``, unit normal ``(N, 3)`` and off-plane variance ``(N,)`` of each neighbourhood
    ``pts[idx[i]]``."""
    nb = pts[idx]  # (N, k, 3)
    c = nb.mean(axis=1)
    d = nb - c[:, None, :]
    cov = d.transpose(0, 2, 1) @ d / idx.shape[1]
    n = smallest_eigenvectors_sym3(cov)
    var = np.einsum("nkj,nj->nk", d, n) ** 2
    return c, n, var.mean(axis=1)


def surface_noise(points, k: int = 16, max_points: int = 1024) -> float:
    """The typical distance of a cloud's points from its surface, in the points' units.

    For each point, the ``k`` nearest neighbours' best plane (PCA); the result is the median over points of
    the RMS distance of the neighbours from it. A clean scan of a smooth surface gives a small fraction of
    the point spacing (curvature and the sensor's own noise); isotropic noise of standard deviation
    ``sigma`` gives roughly ``0.6 sigma`` at ``k = 16`` (the plane also fits some of the noise).

    Args:
        points: ``(N, 3)`` finite, N >= 4.
        k: neighbourhood size (clipped to N).
        max_points: the median runs over at most this many points, evenly strided (their neighbours are
            still searched in the whole cloud).

    Raises:
        InputError: a wrong shape, too few points, NaN or Inf.
    """
    pts = _check(points)
    k = int(min(max(k, 4), len(pts)))
    rows = np.linspace(0, len(pts) - 1, min(len(pts), max(int(max_points), 1))).astype(np.int64)
    _, idx = cKDTree(pts).query(pts[rows], k=k)
    return float(np.median(np.sqrt(_planes(pts, idx)[2])))


def smooth_points(points, k: int = 64, iterations: int = 2) -> np.ndarray:
    """The cloud with each point projected onto its neighbourhood's best plane, ``iterations`` times.

    Each step: for every point, the ``k`` nearest neighbours (in the current cloud), their centroid ``c``
    and PCA normal ``n``; the point moves to ``p - ((p - c) . n) n``. Points move only across the local
    surface, so the cloud keeps its extent and density; noise off the surface shrinks with every step,
    while a curved surface of radius ``R`` is flattened by about ``r^2 / 8R`` for neighbourhoods of radius
    ``r``. The order of the points is kept.

    Args:
        points: ``(N, 3)`` finite, N >= 4.
        k: neighbourhood size (clipped to N); wider takes out more noise and more detail.
        iterations: projection steps (>= 1).

    Returns:
        ``(N, 3)`` float64.

    Raises:
        InputError: a wrong shape, too few points, NaN or Inf, or ``k < 4`` / ``iterations < 1``.
    """
    pts = _check(points)
    if int(k) < 4 or int(iterations) < 1:
        raise InputError(f"smoothing needs k >= 4 and iterations >= 1, got k={k}, iterations={iterations}")
    k = int(min(k, len(pts)))
    for _ in range(int(iterations)):
        _, idx = cKDTree(pts).query(pts, k=k)
        c, n, _ = _planes(pts, idx)
        pts = pts - np.einsum("ij,ij->i", pts - c, n)[:, None] * n
    return pts
