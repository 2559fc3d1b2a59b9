"""Point subsampling: farthest point sampling (batched numpy) and seeded random subsets."""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["farthest_point_sampling", "random_subset"]


def farthest_point_sampling(points: np.ndarray, m: int, start: int | np.ndarray = 0) -> np.ndarray:
    """Indices of ``m`` farthest-point samples of ``(N, 3)`` or ``(B, N, 3)`` points.

    Iterates over the ``m`` samples only; every iteration updates the distances of all points of all
    batch items at once. Returns ``(m,)`` or ``(B, m)`` int64 indices; ``m <= N`` is required.

    Args:
        start: index of the first sample (per batch item, or one for all).
    """
    pts = np.asarray(points, dtype=np.float32)
    single = pts.ndim == 2
    if single:
        pts = pts[None]
    if pts.ndim != 3 or pts.shape[-1] != 3:
        raise InputError(f"points must have shape (N, 3) or (B, N, 3), got {np.shape(points)}")
    B, N, _ = pts.shape
    if not 0 < m <= N:
        raise InputError(f"cannot take {m} farthest-point samples of {N} points")
    # Coordinate-major planes and in-place updates: about 2x (one cloud) to 6x (a batch) faster than
    # ((pts - p) ** 2).sum(-1), with the same summation order ((dx^2 + dy^2) + dz^2), so the same result.
    x, y, z = np.ascontiguousarray(np.moveaxis(pts, -1, 0))
    if single:
        return _fps_one(x[0], y[0], z[0], m, int(np.asarray(start).reshape(-1)[0]))
    out = np.empty((B, m), dtype=np.int64)
    cur = np.broadcast_to(np.asarray(start, dtype=np.int64), (B,)).copy()
    dist = np.full((B, N), np.inf, dtype=np.float32)
    d = np.empty((B, N), dtype=np.float32)
    t = np.empty((B, N), dtype=np.float32)
    rows = np.arange(B)
    for i in range(m):
        out[:, i] = cur
        np.subtract(x, x[rows, cur][:, None], out=d)
        np.multiply(d, d, out=d)
        for c in (y, z):
            np.subtract(c, c[rows, cur][:, None], out=t)
            np.multiply(t, t, out=t)
            d += t
        np.minimum(dist, d, out=dist)
        cur = dist.argmax(axis=1)
    return out[0] if single else out


def _fps_one(x: np.ndarray, y: np.ndarray, z: np.ndarray, m: int, start: int) -> np.ndarray:
    """:func:`farthest_point_sampling` of one cloud given as coordinate planes ``(N,)``: the same
    arithmetic with scalar instead of fancy indexing (half the time of the batched loop)."""
    N = len(x)
    out = np.empty(m, dtype=np.int64)
    dist = np.full(N, np.inf, dtype=np.float32)
    d = np.empty(N, dtype=np.float32)
    t = np.empty(N, dtype=np.float32)
    cur = start
    for i in range(m):
        out[i] = cur
        np.subtract(x, x[cur], out=d)
        np.multiply(d, d, out=d)
        for c in (y, z):
            np.subtract(c, c[cur], out=t)
            np.multiply(t, t, out=t)
            d += t
        np.minimum(dist, d, out=dist)
        cur = int(dist.argmax())
    return out


def random_subset(n: int, m: int, rng: np.random.Generator) -> np.ndarray:
    """``m`` indices into ``n`` items drawn from ``rng``: without replacement when ``m <= n``, else all
    ``n`` once plus ``m - n`` repeats (so every item is used). Sorted, int64."""
    if n <= 0:
        raise InputError("cannot sample from an empty set")
    if m <= n:
        idx = rng.choice(n, size=m, replace=False)
    else:
        idx = np.concatenate([np.arange(n), rng.integers(0, n, size=m - n)])
    return np.sort(idx).astype(np.int64)
