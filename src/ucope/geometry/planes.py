"""The floor or table a segmented object stands on, when the mask let it in.

Frames and units: camera frame, metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["SupportPlane", "find_support_plane"]


@dataclass(frozen=True)
class SupportPlane:
    """A plane that a cloud's object stands on (:func:`find_support_plane`).

    Attributes:
        normal: ``(3,)`` unit normal, camera frame, pointing towards the object.
        offset_m: the plane is ``{x : normal . x = offset_m}`` (metres).
        threshold_m: points within this distance of the plane, or behind it, belong to it.
        fraction: the fraction of the searched cloud within ``threshold_m`` of the plane.
    """

    normal: np.ndarray
    offset_m: float
    threshold_m: float
    fraction: float

    def removes(self, points: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: the points ``(N, 3)`` on the plane or behind it (not the object's)."""
        return np.asarray(points, np.float64) @ self.normal - self.offset_m <= self.threshold_m


def find_support_plane(
    points: np.ndarray,
    seed: int = 0,
    iterations: int = 256,
    min_fraction: float = 0.1,
    threshold_rel: float = 0.02,
    one_side: float = 0.95,
    beyond: float = 0.3,
) -> SupportPlane | None:
    """The floor or table under a segmented object, if the cloud holds one; ``None`` otherwise.

    RANSAC over ``iterations`` planes through 3 points drawn from a generator seeded by ``seed`` (all
    planes scored at once); the plane with the most points within ``max(2 mm, threshold_rel x`` the
    cloud's 90th-percentile radius ``)`` is a support plane when (1) it holds at least ``min_fraction`` of
    the points, (2) at least ``one_side`` of the other points lie on one side of it (the object stands on
    it), and (3) at least ``beyond`` of its points lie outside the object's footprint on it (farther from
    the other points' in-plane median than 1.05 x their 95th-percentile in-plane radius): a floor reaches
    beyond the object, a flat face or a tangent plane of a convex object does not. A laptop's base is
    such a plane for its lid, so the estimator removes planes only for models whose default says so
    (docs/robustness.md has the measurements).

    Args:
        points: ``(N, 3)`` camera frame, metres, ``N >= 3`` (e.g. :attr:`PreparedCloud.points`, whose
            canonical order makes the result independent of the input's order).

    Returns:
        a :class:`SupportPlane` with its normal towards the object, or ``None``.
    """
    p = np.asarray(points, np.float64)
    n = len(p)
    if p.ndim != 2 or p.shape[1:] != (3,) or n < 3:
        raise InputError(f"points must have shape (N, 3) with N >= 3, got {p.shape}")
    centre = np.median(p, axis=0)
    radius = float(np.percentile(np.linalg.norm(p - centre, axis=1), 90.0))
    thr = max(0.002, threshold_rel * radius)
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=(7,)))
    idx = rng.integers(0, n, size=(int(iterations), 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    nrm = np.cross(b - a, c - a)
    length = np.linalg.norm(nrm, axis=1)
    good = length > 1e-12
    if not np.any(good):
        return None
    nrm, a = nrm[good] / length[good, None], a[good]
    dist = p @ nrm.T - np.sum(nrm * a, axis=1)  # (N, I) signed distances
    inliers = np.abs(dist) < thr
    best = int(np.argmax(inliers.sum(axis=0)))
    on = inliers[:, best]
    if on.sum() < min_fraction * n or (~on).sum() < 3:
        return None
    d = dist[:, best]
    side = 1.0 if np.median(d[~on]) > 0 else -1.0
    if np.mean(d[~on] * side > 0) < one_side:
        return None
    normal = side * nrm[best]
    offset = float(side * (a[best] @ nrm[best]))
    flat = p - np.outer(p @ normal, normal)  # projections onto the plane's direction space
    mid = np.median(flat[~on], axis=0)
    foot = float(np.percentile(np.linalg.norm(flat[~on] - mid, axis=1), 95.0))
    if np.mean(np.linalg.norm(flat[on] - mid, axis=1) > 1.05 * foot) < beyond:
        return None
    return SupportPlane(normal=normal, offset_m=offset, threshold_m=thr, fraction=float(on.mean()))
