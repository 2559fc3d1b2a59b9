"""Similarity transforms between point sets (Umeyama), with a robust variant.

Used to recover a ground-truth pose from a NOCS coordinate map and its depth: the map gives each
pixel's point in the object's normalised space, the depth gives it in the camera frame, and
``dst ≈ s R src + t`` holds for the pixels of one object.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["umeyama", "robust_umeyama"]


def umeyama(src, dst, weights=None, with_scale: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity ``dst ≈ s R src + t`` (Umeyama 1991).

    Args:
        src, dst: ``(N, 3)`` corresponding points (``N >= 3``, not all on one line).
        weights: optional ``(N,)`` non-negative weights.
        with_scale: estimate ``s`` (else ``s = 1``).

    Returns:
        ``(s, R (3, 3), t (3,))`` with ``R`` a proper rotation (det +1).

    Raises:
        InputError: mismatched shapes, fewer than 3 points, or degenerate points (all on a line).
    """
    a = np.asarray(src, np.float64)
    b = np.asarray(dst, np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape != b.shape:
        raise InputError(f"src and dst must both be (N, 3), got {a.shape} and {b.shape}")
    if len(a) < 3:
        raise InputError(f"a similarity needs at least 3 point pairs, got {len(a)}")
    w = np.ones(len(a)) if weights is None else np.asarray(weights, np.float64).reshape(-1)
    if w.shape != (len(a),) or np.any(w < 0) or w.sum() <= 0:
        raise InputError("weights must be (N,) non-negative with a positive sum")
    w = w / w.sum()
    ma, mb = w @ a, w @ b
    A, B = a - ma, b - mb
    cov = (B * w[:, None]).T @ A  # (3, 3)
    var_a = float(w @ np.sum(A * A, axis=1))
    U, S, Vt = np.linalg.svd(cov)
    if var_a <= 1e-18 or S[1] <= 1e-12 * max(S[0], 1e-300):
        raise InputError("the points are degenerate (coincident or on one line): no unique rotation")
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0])
    R = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / var_a) if with_scale else 1.0
    t = mb - s * R @ ma
    return s, R, t


def robust_umeyama(
    src, dst, iterations: int = 3, k: float = 3.0, min_inlier_m: float = 0.005
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`umeyama` refitted on inliers: pairs whose residual is below ``max(k x median residual,
    min_inlier_m)`` (depth outliers at object edges, mask bleeding).

    Returns:
        ``(s, R, t, inliers (N,) bool)``.
    """
    a = np.asarray(src, np.float64)
    b = np.asarray(dst, np.float64)
    inl = np.ones(len(a), bool)
    s, R, t = umeyama(a, b)
    for _ in range(int(iterations)):
        r = np.linalg.norm(b - (s * a @ R.T + t), axis=1)
        new = r <= max(k * float(np.median(r)), min_inlier_m)
        if new.sum() < 3 or np.array_equal(new, inl):
            break
        inl = new
        s, R, t = umeyama(a[inl], b[inl])
    return s, R, t, inl
