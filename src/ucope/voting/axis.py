"""Axis (orientation) voting: every point pair constrains a part axis to a cone about its direction.

For a pair with unit direction ``e`` and decoded angle ``alpha = angle(e, u)`` in ``[0, pi]``
(:func:`ucope.model.targets.pair_vote_targets`: ``alpha`` for the up axis ``y``, ``beta`` for the right
axis ``x``), the axis satisfies ``e . u = cos(alpha)``: ``u`` lies on the cone of half-angle ``alpha``
about ``e``. The cone is *directed* (``-u`` satisfies ``e . (-u) = -cos(alpha)``), so the vote already
tells ``u`` from ``-u`` unless every ``alpha`` is near 90 degrees. :func:`vote_axis`:

1. **Coarse vote** on a Fibonacci sphere of ``num_directions`` directions (default 4000, about 3.2
   degrees apart; CPPF scores only 480 directions, about 9 degrees apart, and keeps that quantisation).
   The score of direction ``d`` is the weighted count of pairs with ``|acos(e . d) - alpha| < tol``,
   tested as ``cos(alpha + tol) <= e . d <= cos(alpha - tol)`` (no ``acos`` on the big matrix), with
   chunked ``(D, S)`` matrix products over at most ``max_coarse_pairs`` pairs (an evenly strided
   subset), never a loop over pairs.
2. **Refinement** well below the sphere spacing: iteratively reweighted Gauss-Newton on the sphere
   minimising ``sum_i w_i (e_i . u - cos alpha_i)^2`` over the pairs (2x2 solves in the tangent plane),
   with Tukey weights on the angle residual ``|acos(e_i . u) - alpha_i|`` whose scale starts at ``tol``
   and shrinks to ``3 x`` the median inlier residual (never below ``min_tol_deg``). The residual in
   cosine naturally down-weights pairs with ``alpha`` near 0 or pi, whose cone barely constrains ``u``
   and whose decoded angle is clipped to the first / last bin centre. Measured on exact synthetic votes
   (tests/voting, docs/voting.md) the error is a few hundredths of a degree.

:func:`choose_axis_sign` then picks ``s u`` with ``s = +-1`` from the directed residuals and the
predicted sign bits (the one ambiguity the directed cone leaves: ``alpha`` near 90 degrees for all
pairs, e.g. the normal of a flat part).

Frames: everything in one frame (the camera frame). Tensors are float32 torch tensors on any device
(the refinement runs in float64 numpy on its at most ``max_refine_pairs`` pairs).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import torch

from ..errors import InputError
from .arrays import cross3, dot3, median, np64, strided, tensor
from .centre import circle_basis, perpendicular_basis

__all__ = [
    "AxisOptions",
    "fibonacci_sphere",
    "vote_axis",
    "axis_from_cones",
    "coarse_axes",
    "choose_axis_sign",
    "signed_axis",
    "axis_residual",
    "cube_cell",
    "cube_cell_centre",
    "AXIS_METHODS",
]

_CHUNK = 1 << 20  # elements of one (D, S) score chunk

AXIS_METHODS = ("cubemap", "fibonacci")
"""Coarse stages of :func:`vote_axis`."""


@dataclass(frozen=True)
class AxisOptions:
    """Settings of an axis vote (defaults measured in tests/voting and benchmarks/bench_voting.py).

    Attributes:
        method: coarse stage, ``"cubemap"`` (cone candidates binned on a cube map) or ``"fibonacci"``
            (every pair scored against every direction of a Fibonacci sphere).
        num_angles, grid: cubemap: candidates per cone, cells per cube face side (32: about 2.8 degrees).
        num_directions: fibonacci: directions of the sphere.
        tol_deg: the inlier tolerance of the result, the initial Tukey scale of the refinement and the
            fibonacci score tolerance (degrees; 5 = the angle bin width for 36 bins).
        min_tol_deg: smallest Tukey scale of the refinement (degrees).
        refine_iters: Gauss-Newton iterations (0: the coarse direction).
        max_coarse_pairs: most pairs in the coarse vote; max_refine_pairs: most pairs in the
            refinement (evenly strided subsets of the voting pairs; the inlier test uses all).
    """

    method: str = "cubemap"
    num_angles: int = 24
    grid: int = 32
    num_directions: int = 4000
    tol_deg: float = 5.0
    min_tol_deg: float = 0.2
    refine_iters: int = 6
    max_coarse_pairs: int = 1024
    max_refine_pairs: int = 4096

    def __post_init__(self) -> None:
        if self.method not in AXIS_METHODS:
            raise InputError(f"method must be one of {AXIS_METHODS}, got {self.method!r}")
        if not (self.tol_deg > 0 and self.min_tol_deg > 0):
            raise InputError("tol_deg and min_tol_deg must be positive")
        if (
            min(
                int(self.num_angles),
                int(self.grid),
                int(self.num_directions),
                int(self.max_coarse_pairs),
                int(self.max_refine_pairs),
            )
            < 1
        ):
            raise InputError("num_angles, grid, num_directions, max_coarse_pairs and max_refine_pairs must be positive")


@functools.lru_cache(maxsize=8)
def _fibonacci_np(n: int) -> np.ndarray:
    i = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / n
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * (math.pi * (3.0 - math.sqrt(5.0)))  # golden angle
    out = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)
    out.setflags(write=False)
    return out


def fibonacci_sphere(n: int, device=None, dtype=torch.float32) -> torch.Tensor:
    """``(n, 3)`` nearly uniform unit directions (Fibonacci lattice); neighbours are about
    ``sqrt(4 pi / n)`` radians apart (``n = 4000``: 3.2 degrees). Deterministic."""
    n = int(n)
    if n < 2:
        raise InputError(f"a Fibonacci sphere needs at least 2 directions, got {n}")
    return torch.tensor(_fibonacci_np(n), dtype=dtype, device=device)


def axis_residual(u: torch.Tensor, e: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """``(M,)`` directed angle residual ``|acos(e_i . u) - angle_i|`` (radians) of axis ``u`` ``(3,)``
    for pair directions ``e`` ``(3, M)`` (coordinate-major) and angles ``(M,)``."""
    x = (u @ e).clamp(-1.0, 1.0)
    return (torch.arccos(x) - angle).abs()


def _tangent_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal ``b1, b2`` spanning the plane normal to unit ``u`` ``(3,)`` (float64 numpy)."""
    ref = np.zeros(3)
    ref[int(np.abs(u).argmin())] = 1.0
    b1 = cross3(u, ref)
    b1 /= math.sqrt(float(b1 @ b1))
    return b1, cross3(u, b1)


def cube_cell(u: torch.Tensor, G: int) -> torch.Tensor:
    """Cell index in ``[0, 6 G^2)`` of unit directions ``u`` ``(3, ...)`` on an equi-angular cube map
    (``G x G`` cells per face, cell side ``90 / G`` degrees at the face centre). Face ``2 m + neg`` has
    major axis ``m`` and sign ``neg``; its minor axes are (y, z) for x, (x, z) for y, (x, y) for z."""
    x, y, z = u[0], u[1], u[2]
    ax, ay, az = x.abs(), y.abs(), z.abs()
    is_x = (ax >= ay) & (ax >= az)
    is_z = ~is_x & (az > ay)
    is_y = ~is_x & ~is_z
    m = torch.where(is_x, x, torch.where(is_y, y, z))
    inv = 1.0 / m.abs().clamp_min(1e-12)
    s = torch.where(is_x, y, x) * inv
    t = torch.where(is_z, y, z) * inv
    face = is_y.to(torch.int64) * 2 + is_z.to(torch.int64) * 4 + (m < 0).to(torch.int64)
    k = G * (2.0 / math.pi)  # equi-angular warp: atan(s) in [-pi/4, pi/4] -> [0, G)
    cs = ((torch.atan(s) + math.pi / 4) * k).to(torch.int64).clamp_(0, G - 1)
    ct = ((torch.atan(t) + math.pi / 4) * k).to(torch.int64).clamp_(0, G - 1)
    return (face * G + cs) * G + ct


def cube_cell_centre(idx: int, G: int, device=None, dtype=torch.float32) -> torch.Tensor:
    """Unit direction ``(3,)`` at the centre of cube-map cell ``idx`` (inverse of :func:`cube_cell`)."""
    face, rem = divmod(int(idx), G * G)
    cs, ct = divmod(rem, G)
    major, neg = divmod(face, 2)
    s = math.tan((cs + 0.5) / G * (math.pi / 2) - math.pi / 4)
    t = math.tan((ct + 0.5) / G * (math.pi / 2) - math.pi / 4)
    i1 = 1 if major == 0 else 0
    i2 = 1 if major == 2 else 2
    v = [0.0, 0.0, 0.0]
    v[major] = -1.0 if neg else 1.0
    v[i1], v[i2] = s, t
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return torch.tensor([v[0] / n, v[1] / n, v[2] / n], device=device, dtype=dtype)


def coarse_axes(e: torch.Tensor, angle: torch.Tensor, w: torch.Tensor, num_angles: int, grid: int) -> torch.Tensor:
    """The coarse cube-map vote of one or several axes (inputs unchecked). Peak of the cones' candidates binned on a cube map.
    ``e`` ``(3, S)``, ``angle`` ``(S,)`` (or
    ``(n, S)``: ``n`` axes voted by the same pairs at once, e.g. up and right), ``w`` ``(S,)``.
    Returns ``(3,)`` (or ``(n, 3)``).

    Each cone gets ``num_angles`` candidates ``cos(a) e + sin(a) (cos t p + sin t q)``; a candidate
    weighs ``w * max(2 pi sin(a) / (T cell), 1 / T)`` (the arc it stands for, in cells), so each cone
    adds about ``w`` to every cell it crosses.
    """
    single = angle.ndim == 1
    ang = angle.view(1, -1) if single else angle
    n, S = ang.shape
    p, q = perpendicular_basis(e)
    sa, ca = torch.sin(ang), torch.cos(ang)  # (n, S)
    basis = circle_basis(num_angles, e.device, e.dtype)  # (3, T)
    A = torch.stack([p[:, None] * sa, q[:, None] * sa, e[:, None] * ca], dim=-1)  # (3, n, S, 3)
    cand = (A.reshape(3 * n * S, 3) @ basis).view(3, n, S, num_angles)
    cell = (math.pi / 2) / grid
    cells = 6 * grid * grid
    cw = w * torch.clamp(sa * (2.0 * math.pi / (num_angles * cell)), min=1.0 / num_angles)  # (n, S)
    idx = cube_cell(cand, grid) + (torch.arange(n, device=e.device) * cells).view(n, 1, 1)
    votes = torch.bincount(idx.reshape(-1), weights=cw.unsqueeze(-1).expand(-1, -1, num_angles).reshape(-1), minlength=n * cells)
    peaks = votes.view(n, cells).argmax(1).tolist()
    out = torch.stack([cube_cell_centre(k, grid, device=e.device, dtype=e.dtype) for k in peaks])  # a handful
    return out[0] if single else out


def _sphere_axis(e: torch.Tensor, angle: torch.Tensor, w: torch.Tensor, dirs: torch.Tensor, tol: float) -> torch.Tensor:
    """Direction of ``dirs`` ``(D, 3)`` with the largest weighted count of pairs within ``tol`` of their
    cone (``cos(angle + tol) <= e . d <= cos(angle - tol)``), in chunked ``(D, s)`` matrix products."""
    lo = torch.cos((angle + tol).clamp(max=math.pi))  # (S,)
    hi = torch.cos((angle - tol).clamp(min=0.0))
    D, S = dirs.shape[0], e.shape[1]
    score = torch.zeros(D, device=e.device, dtype=e.dtype)
    step = max(1, _CHUNK // max(D, 1))
    for s0 in range(0, S, step):  # chunks of pairs: memory stays O(D * step)
        X = dirs @ e[:, s0 : s0 + step]  # (D, s)
        hit = (X >= lo[s0 : s0 + step]) & (X <= hi[s0 : s0 + step])
        score += hit.to(e.dtype) @ w[s0 : s0 + step]
    return dirs[int(score.argmax())]


def _refine_axis(
    u: np.ndarray, e: np.ndarray, angle: np.ndarray, w: np.ndarray, tol0: float, tol_min: float, iters: int, tol_start: float
) -> np.ndarray:
    """Iteratively reweighted Gauss-Newton on the sphere (module docstring, step 2), on float64 numpy
    ``u`` ``(3,)``, ``e`` ``(3, M)``, ``angle, w`` ``(M,)`` (small arrays: numpy's per-call cost is a
    fraction of torch's)."""
    c = np.cos(angle)
    tol = tol_start
    eye = np.eye(2)
    for _ in range(iters):
        x = u @ e
        r_ang = np.abs(np.arccos(np.clip(x, -1.0, 1.0)) - angle)
        inl = r_ang < tol
        t = np.minimum(r_ang / tol, 1.0)
        t = 1.0 - t * t
        wi = np.where(inl, w * t * t, 0.0)
        if float(wi.sum()) <= 0:
            break
        b1, b2 = _tangent_basis(u)
        J = np.stack((b1, b2)) @ e  # (2, M)
        Jw = J * wi
        H = Jw @ J.T
        g = Jw @ (x - c)
        H += (1e-6 * float(np.trace(H)) + 1e-12) * eye
        try:
            d = np.linalg.solve(H, -g)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(d)):
            break
        u = u + d[0] * b1 + d[1] * b2
        u = u / np.linalg.norm(u)
        new_tol = min(tol0, max(tol_min, 3.0 * median(r_ang[inl])))
        if new_tol == tol and float(np.linalg.norm(d)) < 1e-3 * tol_min:  # converged
            break
        tol = new_tol
    return u


def vote_axis(e, angle, weights=None, *, options: AxisOptions | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Vote a (directed) unit axis ``u`` with ``e_i . u = cos(angle_i)`` (see the module docstring).

    Args:
        e: ``(M, 3)`` unit pair directions ``(a - b) / |a - b|``.
        angle: ``(M,)`` decoded angles between ``e`` and the axis, radians in ``[0, pi]``.
        weights: ``(M,)`` non-negative pair weights (default 1); weight-0 pairs do not vote.
        options: :class:`AxisOptions` (default: its defaults).

    Returns:
        ``u`` ``(3,)`` unit axis and ``inliers`` ``(M,)`` bool (weight > 0 and directed residual
        ``< options.tol_deg``), on the device of ``e``.

    Raises:
        InputError: mismatched shapes, NaN / inf, negative weights, or no pair with positive weight.
    """
    opt = options or AxisOptions()
    e = tensor(e, "e", (None, 3))
    M = e.shape[0]
    dev = e.device
    angle = tensor(angle, "angle", (M,), device=dev)
    w = torch.ones(M, device=dev) if weights is None else tensor(weights, "weights", (M,), device=dev)
    if bool((w < 0).any()):
        raise InputError("weights must be non-negative")
    if M == 0 or not bool((w > 0).any()):
        raise InputError("vote_axis needs at least one pair with a positive weight")
    et = e.T.contiguous()
    et = et / torch.sqrt(dot3(et, et)).clamp_min(1e-12)
    return axis_from_cones(et, angle, w, opt)


def axis_from_cones(
    et: torch.Tensor,
    angle: torch.Tensor,
    w: torch.Tensor,
    options: AxisOptions,
    coarse: torch.Tensor | None = None,
    with_inliers: bool = True,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """The work of :func:`vote_axis` on inputs it has checked: coordinate-major unit directions ``et``
    ``(3, M)``, ``angle, w`` ``(M,)``. ``coarse``: the coarse direction ``(3,)`` if already voted
    (:func:`coarse_axes` of several axes at once); ``with_inliers=False`` returns ``None`` for them."""
    dev = et.device
    tol = math.radians(options.tol_deg)
    tol_min = min(math.radians(options.min_tol_deg), tol)
    sel = torch.nonzero(w > 0).squeeze(-1)
    cs = strided(sel, options.max_coarse_pairs)
    if coarse is not None:
        u = coarse
    elif options.method == "cubemap":
        u = coarse_axes(et[:, cs], angle[cs], w[cs], int(options.num_angles), int(options.grid))
    else:
        u = _sphere_axis(et[:, cs], angle[cs], w[cs], fibonacci_sphere(options.num_directions, device=dev, dtype=et.dtype), tol)
    rs = strided(sel, options.max_refine_pairs)
    u64 = _refine_axis(np64(u), np64(et[:, rs]), np64(angle[rs]), np64(w[rs]), tol, tol_min, int(options.refine_iters), tol)
    u = torch.as_tensor(u64, dtype=et.dtype, device=dev)
    if not with_inliers:
        return u, None
    return u, (axis_residual(u, et, angle) < tol) & (w > 0)


def choose_axis_sign(
    u,
    e,
    angle,
    normals,
    sign_logits,
    inliers=None,
    *,
    tol_deg: float = 5.0,
    margin: float = 0.05,
    use_sign_bits: bool = True,
) -> tuple[torch.Tensor, int]:
    """Choose ``s u``, ``s = +-1``, from the directed angle residuals and the predicted sign bits.

    ``score(s) = #{inliers i : |acos(e_i . s u) - angle_i| < tol}
    + #{inliers i : |n_i . u| > margin and [sign_logit_i > 0] == [n_i . s u > 0]}``, with ``n_i`` the
    normal at the pair's first point flipped so that ``n_i . e_i >= 0`` (as in the targets); pairs whose
    normal is within ``margin`` of perpendicular to ``u`` carry no sign information and are skipped.
    Ties keep ``s = +1``. The first term is what the directed cones say (decisive unless every angle is
    near 90 degrees); the second breaks the remaining tie (e.g. the normal axis of a flat part).

    Args:
        u: ``(3,)`` unit axis; e: ``(M, 3)`` unit pair directions; angle: ``(M,)`` radians.
        normals: ``(M, 3)`` unit normals at the pairs' first points (any sign).
        sign_logits: ``(M,)`` logits of the sign bit of this axis (``[n . axis > 0]``).
        inliers: ``(M,)`` bool, the pairs that count (default all).
        use_sign_bits: ``False`` drops the second term.

    Returns:
        ``(s u, s)`` with ``s`` a Python int.
    """
    u = tensor(u, "u", (3,))
    dev = u.device
    e = tensor(e, "e", (None, 3), device=dev)
    M = e.shape[0]
    angle = tensor(angle, "angle", (M,), device=dev)
    n = tensor(normals, "normals", (M, 3), device=dev)
    lg = tensor(sign_logits, "sign_logits", (M,), device=dev)
    inl = (
        torch.ones(M, dtype=torch.bool, device=dev)
        if inliers is None
        else tensor(inliers, "inliers", (M,), dtype=torch.bool, device=dev)
    )
    return signed_axis(u, e.T.contiguous(), angle, n.T.contiguous(), lg, inl, float(tol_deg), float(margin), use_sign_bits)


def signed_axis(
    u: torch.Tensor,
    et: torch.Tensor,
    angle: torch.Tensor,
    nt: torch.Tensor,
    lg: torch.Tensor,
    inl: torch.Tensor,
    tol_deg: float,
    margin: float,
    use_sign_bits: bool,
) -> tuple[torch.Tensor, int]:
    """The work of :func:`choose_axis_sign` on inputs it has checked: coordinate-major ``et, nt`` ``(3, M)``."""
    nt = torch.where(dot3(nt, et) < 0, -nt, nt)
    x = (u @ et).clamp(-1.0, 1.0)
    tol = math.radians(tol_deg)
    a_plus = torch.arccos(x)
    score_p = ((a_plus - angle).abs() < tol) & inl
    score_m = ((math.pi - a_plus - angle).abs() < tol) & inl
    sp, sm = int(score_p.sum()), int(score_m.sum())
    if use_sign_bits:
        nu_ = u @ nt
        informative = inl & (nu_.abs() > margin)
        bit = lg > 0
        sp += int((informative & (bit == (nu_ > 0))).sum())
        sm += int((informative & (bit == (nu_ < 0))).sum())
    s = -1 if sm > sp else 1
    return u * s, s
