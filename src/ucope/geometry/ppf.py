"""Point pair features (Drost et al. 2010), batched.

For a pair of oriented points ``(a, n_a)``, ``(b, n_b)`` with ``d = b - a``:

``F(a, b) = (|d|, angle(n_a, d), angle(n_b, d), angle(n_a, n_b))``

Normals estimated from a single depth view are only defined up to sign; with ``sign_invariant=True``
(the default) every angle is folded into ``[0, pi/2]`` by taking absolute cosines, so flipping either
normal leaves the feature unchanged.
"""

from __future__ import annotations

import numpy as np

__all__ = ["point_pair_features"]


def point_pair_features(
    a: np.ndarray, n_a: np.ndarray, b: np.ndarray, n_b: np.ndarray, sign_invariant: bool = True, eps: float = 1e-12
) -> np.ndarray:
    """Point pair features of ``(..., 3)`` points and unit normals.

    Returns:
        ``(..., 4)`` float array: distance in metres, then three angles in radians
        (``[0, pi]``, or ``[0, pi/2]`` when ``sign_invariant``). A zero-length pair gets angles of
        ``pi/2`` for the two point-to-direction terms.
    """
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    n_a, n_b = np.asarray(n_a, np.float64), np.asarray(n_b, np.float64)
    d = b - a
    dist = np.linalg.norm(d, axis=-1)
    e = d / np.maximum(dist, eps)[..., None]
    cos = np.stack([(n_a * e).sum(-1), (n_b * e).sum(-1), (n_a * n_b).sum(-1)], axis=-1)
    if sign_invariant:
        cos = np.abs(cos)
    return np.concatenate([dist[..., None], np.arccos(np.clip(cos, -1.0, 1.0))], axis=-1)
