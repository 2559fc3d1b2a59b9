"""Centre (translation) voting: every point pair constrains the part centre to a circle.

For a pair ``(a, b)`` with ``e = (a - b) / |a - b|`` and decoded ``(mu, nu)``
(:func:`ucope.model.targets.pair_vote_targets`), the centre ``c`` lies on the circle of radius ``nu``
about the foot ``f = a - mu e``, in the plane through ``f`` normal to ``e``. :func:`vote_centre`
finds the point most circles pass through:

1. **Grid vote** (paper section 4.4, CPPF): ``num_angles`` candidates evenly spaced on every circle
   of (at most ``max_grid_pairs``, an evenly strided subset of) the pairs (one ``(M, 3, T)`` tensor
   from one matrix product, no Python loop over pairs) are accumulated into a 3D grid of cubic cells
   of side ``cell_m`` with one ``bincount`` over flattened cell indices. The grid spans the candidates'
   robust extent (1st-99th percentile per axis, on a strided subset of at most 4096 candidates, plus
   2 cells), so a few wild votes cannot blow it up; candidates outside it are dropped. Each candidate
   weighs ``w_pair * max(2 pi nu / (T cell), 1 / T)``: the arc length it stands for, in cells, so
   that a circle adds about ``w_pair`` to each cell it crosses whatever its radius (a circle smaller
   than a cell adds ``w_pair`` to its cell in total). The peak cell centre is the coarse centre.
2. **Refinement** well below the cell size: iteratively reweighted Gauss-Newton on
   ``sum_i w_i d_i(c)^2`` with ``d_i(c) = sqrt((|(c - f_i)_perp| - nu_i)^2 + ((c - f_i) . e_i)^2)`` the
   distance of ``c`` to circle ``i`` (the Jacobian rows are the unit radial direction and ``e_i``;
   each step is a 3x3 solve). The weights are Tukey's biweight of ``d_i / tol`` where ``tol`` starts at
   ``inlier_tol_cells`` cells and shrinks to ``3 x`` the median inlier distance (never below
   ``min_tol_cells`` cells), so circles from outliers or from clipped bins drop out.
3. **Mirror check**: when the pair points are (nearly) coplanar (a thin part, one visible face), every
   circle is symmetric about their plane and the centre's mirror image fits equally well (the
   parameters cannot tell the two apart). The mirror image is refined too; if its inlier weight is at
   least ``mirror_ratio`` of the other's, the centre farther behind the surface as seen from
   ``viewpoint`` (the camera) is kept, since a visible face has its box behind it. Otherwise the
   better-supported one wins.

Defaults (:class:`CentreOptions`, relative to the vote range ``V`` of the part, :class:`ucope.priors.PartPrior`):
``cell_m = V / 20`` (the ``mu`` bins are ``V / 16`` wide, so a cell is a little under a bin),
``num_angles = 36`` candidates per circle (CPPF: up to 72), inliers within ``2`` cells (CPPF: 3 cells
of its voxel size). Measured on exact synthetic votes (tests/voting, docs/voting.md) the refined centre
is within a few hundredths of a cell, with 20% outlier pairs.

Frames: everything in one frame (the camera frame), metres. Tensors are float32 torch tensors on any
device (numpy arrays are converted); the refinement (step 2, 3) runs in float64 numpy on its at most
``max_refine_pairs`` pairs.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import torch

from ..errors import InputError
from .arrays import cross_rows, dot3, median, np64, strided, tensor

__all__ = [
    "CentreOptions",
    "vote_centre",
    "centre_from_circles",
    "circle_candidates",
    "circle_distance",
    "pair_frames",
    "perpendicular_basis",
    "DEFAULT_CELL_FRACTION",
]

DEFAULT_CELL_FRACTION = 1.0 / 20.0
"""Default grid cell as a fraction of the part's vote range ``V``."""

_MAX_EXTENT_SAMPLES = 4096


@dataclass(frozen=True)
class CentreOptions:
    """Settings of the centre vote (defaults measured in tests/voting and benchmarks/bench_voting.py).

    Attributes:
        cell_fraction: grid cell side as a fraction of the part's vote range ``V``.
        num_angles: candidates per circle ``T``.
        inlier_tol_cells: a pair is an inlier if its circle passes within this many cells of the
            centre (also the initial Tukey scale of the refinement).
        min_tol_cells: the smallest Tukey scale of the refinement, in cells.
        refine_iters: Gauss-Newton iterations (0: the peak cell centre).
        max_cells: most cells per grid axis (the cell grows if the extent needs more).
        max_grid_pairs: most pairs (an evenly strided subset of the voting pairs) casting grid votes;
            max_refine_pairs: most pairs the refinement runs on. The inlier test uses every pair.
        mirror_ratio: the mirror image of the centre (coplanar pairs, step 3) counts as "as good"
            when its inlier weight is at least this fraction of the other's.
    """

    cell_fraction: float = DEFAULT_CELL_FRACTION
    num_angles: int = 36
    inlier_tol_cells: float = 2.0
    min_tol_cells: float = 0.1
    refine_iters: int = 8
    max_cells: int = 96
    max_grid_pairs: int = 4096
    max_refine_pairs: int = 4096
    mirror_ratio: float = 0.8

    def __post_init__(self) -> None:
        if int(self.num_angles) < 3:
            raise InputError(f"num_angles must be >= 3, got {self.num_angles}")
        if not (self.cell_fraction > 0 and self.inlier_tol_cells > 0 and self.min_tol_cells > 0):
            raise InputError("cell_fraction, inlier_tol_cells and min_tol_cells must be positive")
        if min(int(self.max_cells), int(self.max_grid_pairs), int(self.max_refine_pairs)) < 1 or int(self.refine_iters) < 0:
            raise InputError("max_cells, max_grid_pairs and max_refine_pairs must be positive, refine_iters >= 0")


def pair_frames(
    a: torch.Tensor, b: torch.Tensor, mu: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per pair: the unit direction ``e``, the foot ``f = a - mu e`` and an orthonormal basis ``p, q``
    of the plane normal to ``e`` (``e x p = q``), plus a validity mask (``|a - b| > 1e-9``).

    Shapes (**coordinate-major**, the internal layout of the voting ops): ``a, b`` ``(3, M)``, ``mu``
    ``(M,)`` -> ``e, f, p, q`` ``(3, M)``, ``valid`` ``(M,)`` bool.
    """
    d = a - b
    dist = torch.sqrt(dot3(d, d))
    valid = dist > 1e-9
    e = d / dist.clamp_min(1e-9)
    f = a - mu * e
    p, q = perpendicular_basis(e)
    return e, f, p, q, valid


def perpendicular_basis(e: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per unit direction, an orthonormal basis ``p, q`` of the plane normal to it (``e x p = q``):
    ``p = e x ref`` normalised, with ``ref = x`` unless ``e`` is close to ``x``, then ``y``
    (deterministic). Shapes: ``e`` ``(3, M)`` coordinate-major -> ``p, q`` ``(3, M)``."""
    use_y = e[0].abs() > 0.9
    zero = torch.zeros_like(e[0])
    p = torch.stack([torch.where(use_y, -e[2], zero), torch.where(use_y, zero, e[2]), torch.where(use_y, e[0], -e[1])])
    p = p / torch.sqrt(dot3(p, p)).clamp_min(1e-12)
    return p, cross_rows(e, p)


@functools.lru_cache(maxsize=16)
def circle_basis(num_angles: int, device, dtype) -> torch.Tensor:
    """``(3, T)`` rows ``cos t_j``, ``sin t_j``, ``1`` at ``t_j = 2 pi j / T`` (cached: read-only)."""
    t = torch.arange(num_angles, dtype=torch.float64) * (2.0 * math.pi / num_angles)
    return torch.stack([t.cos(), t.sin(), torch.ones_like(t)], dim=0).to(device=device, dtype=dtype)


def circle_candidates(f: torch.Tensor, p: torch.Tensor, q: torch.Tensor, nu: torch.Tensor, num_angles: int) -> torch.Tensor:
    """Points ``f + nu (cos t_j p + sin t_j q)`` at ``t_j = 2 pi j / T`` on every circle.

    Shapes: ``f, p, q`` ``(3, M)`` coordinate-major, ``nu`` ``(M,)`` -> ``(3, M, T)`` (one matrix
    product).
    """
    M = f.shape[1]
    basis = circle_basis(num_angles, f.device, f.dtype)  # (3 terms, T)
    A = torch.stack([p * nu, q * nu, f], dim=-1)  # (3 coords, M, 3 terms)
    return (A.reshape(3 * M, 3) @ basis).view(3, M, num_angles)


def circle_distance(c: torch.Tensor, f: torch.Tensor, e: torch.Tensor, nu: torch.Tensor) -> torch.Tensor:
    """``(M,)`` distance (metres) of point ``c`` ``(3,)`` to each circle (centre ``f`` ``(3, M)``,
    unit normal ``e`` ``(3, M)``, both coordinate-major, radius ``nu`` ``(M,)``):
    ``sqrt((|(c - f)_perp| - nu)^2 + ((c - f) . e)^2)``."""
    d = c.view(3, 1) - f
    h = dot3(d, e)
    rho = torch.sqrt((dot3(d, d) - h * h).clamp_min(0.0))
    return torch.sqrt((rho - nu).square() + h.square())


def _robust_extent(cand: torch.Tensor, lo_q: float = 0.01, hi_q: float = 0.99) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-axis ``lo_q`` / ``hi_q`` quantiles of ``(3, M, T)`` candidates, on a strided subset."""
    flat = cand.reshape(3, -1)
    n = flat.shape[1]
    sub = flat[:, :: max(1, n // _MAX_EXTENT_SAMPLES)]
    m = sub.shape[1]
    lo = sub.kthvalue(max(1, int(lo_q * m)), dim=1).values
    hi = sub.kthvalue(max(1, min(m, int(math.ceil(hi_q * m)))), dim=1).values
    return lo, hi


def grid_peak(cand: torch.Tensor, w: torch.Tensor, cell: float, max_cells: int) -> torch.Tensor:
    """Centre ``(3,)`` of the heaviest cell of a grid over the candidates' robust extent.

    ``cand`` ``(3, M, T)`` candidates, ``w`` ``(M, T)`` their weights, ``cell`` metres.
    """
    lo, hi = _robust_extent(cand)
    lo = lo - 2.0 * cell
    hi = hi + 2.0 * cell
    cell = max(cell, float((hi - lo).max()) / max_cells)  # never more than max_cells per axis
    dims = torch.clamp(torch.ceil((hi - lo) / cell), 1, max_cells).long()
    dx, dy, dz = (int(v) for v in dims)
    # Cell indices; "+1 then truncate then -1" is floor for x >= -1 (and < 0 for any x < 0), and is
    # several times faster than torch.floor on CPU.
    # (In-place ops: every fresh temporary of this size costs page faults.)
    x = cand - lo.view(3, 1, 1)
    x.mul_(1.0 / cell).add_(1.0)
    ijk = x.to(torch.int32).sub_(1)  # (3, M, T)
    del x
    ix, iy, iz = ijk[0], ijk[1], ijk[2]
    outside = (ix < 0) | (ix >= dx)
    outside |= iy < 0
    outside |= iy >= dy
    outside |= iz < 0
    outside |= iz >= dz
    total = dx * dy * dz
    flat = ix.mul(dy).add_(iy).mul_(dz).add_(iz)
    flat.masked_fill_(outside, total)  # one trash bin past the grid
    votes = torch.bincount(flat.reshape(-1), weights=w.reshape(-1), minlength=total + 1)[:total]
    k = int(votes.argmax())
    idx = torch.tensor([k // (dy * dz), (k // dz) % dy, k % dz], device=cand.device, dtype=cand.dtype)
    return lo + (idx + 0.5) * cell


def _refine_centre(
    c: np.ndarray,
    f: np.ndarray,
    e: np.ndarray,
    p: np.ndarray,
    nu: np.ndarray,
    w: np.ndarray,
    tol0: float,
    tol_min: float,
    iters: int,
    tol_start: float,
) -> np.ndarray:
    """Iteratively reweighted Gauss-Newton on the circle distances (module docstring, step 2).
    ``c`` ``(3,)``; ``f, e, p`` ``(3, M)``; ``nu, w`` ``(M,)``, all float64 numpy (a few dozen small
    operations per iteration on at most ``max_refine_pairs`` pairs: numpy's per-call cost is a
    fraction of torch's); Tukey scale from ``tol_start``, kept in ``[tol_min, tol0]``."""
    tol = tol_start
    eye = np.eye(3)
    for _ in range(iters):
        d = c[:, None] - f
        h = d[0] * e[0] + d[1] * e[1] + d[2] * e[2]
        dp = d - h * e  # radial part
        rho = np.sqrt(dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2])
        ph = np.where(rho > 1e-12, dp / np.maximum(rho, 1e-12), p)
        dr = rho - nu
        r = np.sqrt(dr * dr + h * h)
        inl = r < tol
        x = np.minimum(r / tol, 1.0)
        x = 1.0 - x * x
        wi = np.where(inl, w * x * x, 0.0)
        W = float(wi.sum())
        if W <= 0:
            break
        # Normal equations: sum w (ph ph^T + e e^T) dc = -sum w (closest-point residual d - nu ph).
        A = (ph * wi) @ ph.T + (e * wi) @ e.T
        g = (d - nu * ph) @ wi
        try:
            step = np.linalg.solve(A + (1e-6 * W) * eye, g)
        except np.linalg.LinAlgError:  # degenerate geometry: keep c
            break
        if not np.all(np.isfinite(step)):
            break
        c = c - step
        new_tol = min(tol0, max(tol_min, 3.0 * median(r[inl])))
        if new_tol == tol and float(np.linalg.norm(step)) < 1e-3 * tol_min:  # converged
            break
        tol = new_tol
    return c


def vote_centre(
    a,
    b,
    mu,
    nu,
    weights=None,
    *,
    cell_m: float | None = None,
    vote_range_m: float | None = None,
    options: CentreOptions | None = None,
    viewpoint=(0.0, 0.0, 0.0),
) -> tuple[torch.Tensor, torch.Tensor]:
    """Vote the part centre from point pairs (see the module docstring for the algorithm).

    Args:
        a, b: ``(M, 3)`` pair points (metres, camera frame); ``e = (a - b) / |a - b|``.
        mu: ``(M,)`` signed ``(a - c) . e`` (metres); nu: ``(M,)`` circle radii (metres, >= 0).
        weights: ``(M,)`` non-negative pair weights (default 1); weight-0 pairs do not vote.
        cell_m: grid cell side (metres). Default ``options.cell_fraction x vote_range_m``; if neither
            is given, ``V`` is taken as the largest ``|mu|``, ``nu``.
        vote_range_m: the part's vote range ``V`` (sets the default cell).
        options: :class:`CentreOptions` (default: its defaults).
        viewpoint: ``(3,)`` the camera centre in the frame of the points (the origin in the camera
            frame), used to resolve the mirror ambiguity of coplanar pairs (step 3); ``None`` keeps the
            refined grid peak.

    Returns:
        ``centre`` ``(3,)`` metres and ``inliers`` ``(M,)`` bool (weight > 0 and circle distance
        < ``inlier_tol_cells * cell_m``), on the device of ``a``.

    Raises:
        InputError: on mismatched shapes, NaN / inf, negative weights or no pair with positive weight.
    """
    opt = options or CentreOptions()
    a = tensor(a, "a", (None, 3))
    M = a.shape[0]
    dev = a.device
    b = tensor(b, "b", (M, 3), device=dev)
    mu = tensor(mu, "mu", (M,), device=dev)
    nu = tensor(nu, "nu", (M,), device=dev).clamp_min(0.0)
    w = torch.ones(M, device=dev) if weights is None else tensor(weights, "weights", (M,), device=dev)
    if bool((w < 0).any()):
        raise InputError("weights must be non-negative")
    if M == 0:
        raise InputError("vote_centre needs at least one pair")
    if cell_m is None:
        V = float(vote_range_m) if vote_range_m is not None else float(torch.maximum(mu.abs(), nu).max())
        cell_m = max(V, 1e-6) * opt.cell_fraction
    cell = float(cell_m)
    if not (math.isfinite(cell) and cell > 0):
        raise InputError(f"cell_m must be a positive number, got {cell_m}")
    c, inliers, _ = centre_from_circles(a.T.contiguous(), b.T.contiguous(), mu, nu, w, cell, opt, viewpoint)
    return c, inliers


def centre_from_circles(
    at: torch.Tensor,
    bt: torch.Tensor,
    mu: torch.Tensor,
    nu: torch.Tensor,
    w: torch.Tensor,
    cell: float,
    options: CentreOptions,
    viewpoint=(0.0, 0.0, 0.0),
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The work of :func:`vote_centre` on inputs it has checked: coordinate-major pair points ``at, bt``
    ``(3, M)``, ``mu, nu, w`` ``(M,)``, the grid cell ``cell`` (metres). Returns ``(centre (3,),
    inliers (M,), e (3, M))`` with ``e`` the unit pair directions (the axis votes reuse them)."""
    dev = at.device
    num_angles, refine_iters = int(options.num_angles), int(options.refine_iters)
    inlier_tol_cells, min_tol_cells, mirror_ratio = options.inlier_tol_cells, options.min_tol_cells, options.mirror_ratio
    e, f, p, q, valid = pair_frames(at, bt, mu)
    w = w * valid.to(w.dtype)
    voting = torch.nonzero(w > 0).squeeze(-1)
    if len(voting) == 0:
        raise InputError("vote_centre needs at least one pair with a positive weight and a, b distinct")

    # 1. Grid vote over (a subset of) the voting pairs.
    sel = strided(voting, options.max_grid_pairs)
    cand = circle_candidates(f[:, sel], p[:, sel], q[:, sel], nu[sel], num_angles)  # (3, S, T)
    cw = w[sel] * torch.clamp(nu[sel] * (2.0 * math.pi / (num_angles * cell)), min=1.0 / num_angles)
    c = grid_peak(cand, cw.unsqueeze(-1).expand(-1, num_angles), cell, int(options.max_cells))
    del cand

    # 2. Iteratively reweighted Gauss-Newton on the distances to the circles, on (a subset of) them.
    tol0 = inlier_tol_cells * cell
    tol_min = min(min_tol_cells * cell, tol0)
    rs = strided(voting, options.max_refine_pairs)
    fr, er, pr, nur, wr = (np64(x) for x in (f[:, rs], e[:, rs], p[:, rs], nu[rs], w[rs]))
    c64 = _refine_centre(np64(c), fr, er, pr, nur, wr, tol0, tol_min, refine_iters, tol0)
    c = torch.as_tensor(c64, dtype=at.dtype, device=dev)

    # 3. Mirror ambiguity: if the pair points are (nearly) coplanar, every circle is symmetric about
    # their plane and the centre's mirror image fits as well. Try it; if it fits about as well, keep
    # the one behind the surface as seen from the viewpoint (a visible face has the box behind it).
    near = None  # circles within tol0 of the returned centre, when already computed
    if viewpoint is not None and refine_iters > 0:
        pts = np64(at[:, rs])
        m = pts.mean(1)
        evals, evecs = np.linalg.eigh((pts - m[:, None]) @ (pts - m[:, None]).T)
        n = evecs[:, 0]
        h = float((c64 - m) @ n)
        if abs(h) > tol_min:
            c2_64 = _refine_centre(c64 - 2.0 * h * n, fr, er, pr, nur, wr, tol0, tol_min, refine_iters, tol0)
            c2 = torch.as_tensor(c2_64, dtype=at.dtype, device=dev)
            near1 = circle_distance(c, f, e, nu) < tol0
            near2 = circle_distance(c2, f, e, nu) < tol0
            s1 = float((w * near1).sum())  # support among all voting pairs
            s2 = float((w * near2).sum())
            near = near1
            if s2 > s1 / mirror_ratio:
                c, near = c2, near2
            elif s2 >= mirror_ratio * s1:  # ambiguous: the candidate farther behind the surface
                toward_view = np.asarray(viewpoint, dtype=np.float64) - m
                if float((c2_64 - c64) @ toward_view) < 0:
                    c, near = c2, near2
    if near is None:
        near = circle_distance(c, f, e, nu) < tol0
    return c, near & (w > 0), e
