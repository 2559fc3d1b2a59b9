"""Rotations from voted axes: orthonormalisation and a joint least-squares refinement.

Convention (docs/conventions.md): ``cam_from_part`` rotation ``R = [x | y | z]`` (columns: right, up,
front), right-handed, ``z = x x y``.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..errors import InputError
from ..geometry.transforms import closest_rotation
from .arrays import median, np64, tensor

__all__ = ["rotation_from_axes", "perpendicular_axis", "refine_rotation", "rotation_from_cones"]


def perpendicular_axis(up: torch.Tensor) -> torch.Tensor:
    """A deterministic unit ``x`` perpendicular to unit ``up`` ``(3,)`` (for parts symmetric about y).

    ``x`` is the camera axis least aligned with ``up`` (the first on ties) with its component along
    ``up`` removed, so it is a continuous function of ``up`` except where that choice switches.
    """
    ref = torch.zeros_like(up)
    ref[int(up.abs().argmin())] = 1.0
    x = ref - (ref @ up) * up
    return x / x.norm()


def rotation_from_axes(up, right=None) -> torch.Tensor:
    """``(3, 3)`` rotation ``[x | y | z]`` from a voted up axis ``y`` and right axis ``x``.

    Method: the SVD-based closest rotation (Frobenius norm) to ``[x, y, x x y]`` with ``x, y``
    normalised: with independent ``x`` and ``y`` votes this splits their non-orthogonality evenly
    between the two instead of trusting one (Gram-Schmidt would keep ``y`` exact). The determinant is
    forced to +1. ``right=None`` (a part symmetric about ``y``): ``y`` is kept exactly and ``x`` is
    :func:`perpendicular_axis`.

    Args:
        up: ``(3,)`` up axis (any non-zero length); right: ``(3,)`` right axis or ``None``.

    Returns:
        float tensor ``(3, 3)`` on the device of ``up``.
    """
    y = tensor(up, "up", (3,))
    ny = y.norm()
    if float(ny) < 1e-12:
        raise InputError("up must be a non-zero vector")
    y = y / ny
    if right is None:
        x = perpendicular_axis(y)
        return torch.stack([x, y, torch.linalg.cross(x, y)], dim=1)
    x = tensor(right, "right", (3,), device=y.device)
    nx = x.norm()
    if float(nx) < 1e-12:
        raise InputError("right must be a non-zero vector")
    x = x / nx
    if float(torch.linalg.cross(x, y).norm()) < 1e-6:
        raise InputError("up and right are parallel: no rotation")
    xn, yn = np64(x), np64(y)
    R = closest_rotation(np.stack([xn, yn, np.cross(xn, yn)], axis=1))  # a 3x3: numpy is cheaper
    return torch.as_tensor(R, dtype=y.dtype, device=y.device)


def refine_rotation(
    R,
    e_up,
    alpha,
    w_up,
    e_right=None,
    beta=None,
    w_right=None,
    *,
    iters: int = 4,
    tol_deg: float = 5.0,
    min_tol_deg: float = 0.2,
) -> torch.Tensor:
    """Joint robust Gauss-Newton refinement of a rotation on the pair constraints of both axes.

    Minimises ``sum_i w_i rho(e_i . R y - cos alpha_i) + sum_j w_j rho(e_j . R x - cos beta_j)`` over
    rotations ``exp([d]_x) R`` (3x3 solves): the best rotation for both sets of cones at once, so
    neither axis is favoured by the orthonormalisation. ``rho`` is iteratively reweighted least squares
    with Tukey weights on the angle residual ``|acos(e . axis) - angle|``, whose scale starts at
    ``tol_deg`` and shrinks to ``3 x`` the median inlier residual (at least ``min_tol_deg``), as in
    :func:`ucope.voting.axis.vote_axis`. With only the up terms (symmetric parts) the rotation about
    ``y`` is left unchanged (damped null direction).

    Args:
        R: ``(3, 3)`` initial rotation (columns x, y, z), e.g. :func:`rotation_from_axes`.
        e_up: ``(M, 3)`` unit pair directions, alpha: ``(M,)`` radians, w_up: ``(M,)`` pair weights.
        e_right, beta, w_right: the same for the right axis (optional).

    Returns:
        ``(3, 3)`` rotation (float32, on the device of ``R``).
    """
    R = tensor(R, "R", (3, 3))
    dev = R.device
    terms = [(1, tensor(e_up, "e_up", (None, 3), device=dev), alpha, w_up)]
    if e_right is not None:
        terms.append((0, tensor(e_right, "e_right", (None, 3), device=dev), beta, w_right))
    prepared = []
    for col, e, ang, w in terms:
        M = e.shape[0]
        ang = tensor(ang, "angle", (M,), device=dev)
        w = tensor(w, "weights", (M,), device=dev)
        prepared.append((col, e.T.contiguous(), ang, w))
    return rotation_from_cones(R, prepared, int(iters), float(tol_deg), float(min_tol_deg))


def _so3_exp(w: np.ndarray) -> np.ndarray:
    """``(3, 3)`` rotation ``exp([w]_x)`` (Rodrigues) of a rotation vector ``w`` ``(3,)``, float64 numpy."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-8:
        return np.eye(3) + K
    return np.eye(3) + math.sin(th) / th * K + (1.0 - math.cos(th)) / th**2 * (K @ K)


def rotation_from_cones(R: torch.Tensor, terms: list, iters: int, tol_deg: float, min_tol_deg: float) -> torch.Tensor:
    """The work of :func:`refine_rotation` on inputs it has checked: ``terms = [(column, e (3, M)
    coordinate-major, angle (M,), w (M,))]`` (column 1: up, 0: right).

    Runs in float64 numpy on the CPU (a few dozen small operations per iteration: numpy's per-call
    cost is a fraction of torch's); returns a rotation of ``R``'s dtype and device."""
    dtype, dev = R.dtype, R.device
    prepared = []
    for col, et, ang, w in terms:
        ang = np64(ang)
        prepared.append([col, np64(et), ang, np.cos(ang), np64(w), math.radians(tol_deg)])
    tol_min = math.radians(min_tol_deg)
    Rn = np64(R)
    eye = np.eye(3)
    for _ in range(iters):
        H = np.zeros((3, 3))
        g = np.zeros(3)
        for term in prepared:
            col, et, ang, c, w, tol = term
            a = Rn[:, col]
            x = a @ et
            r_ang = np.abs(np.arccos(np.clip(x, -1.0, 1.0)) - ang)
            inl = (r_ang < tol) & (w > 0)
            if not inl.any():
                continue
            t = np.minimum(r_ang / tol, 1.0)
            t = 1.0 - t * t
            wi = np.where(inl, w * t * t, 0.0)
            # d/dd of e . (a + d x a) = (a x e) . d
            J = np.stack([a[1] * et[2] - a[2] * et[1], a[2] * et[0] - a[0] * et[2], a[0] * et[1] - a[1] * et[0]])
            Jw = J * wi
            H += Jw @ J.T
            g += Jw @ (x - c)
            term[5] = min(tol, max(tol_min, 3.0 * median(r_ang[inl])))
        tr = float(np.trace(H))
        if tr <= 0:
            break
        try:
            d = np.linalg.solve(H + (1e-6 * tr) * eye, -g)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(d)):
            break
        Rn = _so3_exp(d) @ Rn
        if float(np.linalg.norm(d)) < 1e-3 * tol_min and all(t[5] <= tol_min for t in prepared):  # converged
            break
    return torch.as_tensor(closest_rotation(Rn), dtype=dtype, device=dev)  # re-orthonormalised
