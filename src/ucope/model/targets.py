"""Training targets of U-COPE from ground truth: pair voting parameters, joint point targets, bins.

Everything is batched torch in the camera frame (metres, OpenCV axes), differentiable-free (targets).
The voting parameters of a point pair ``(a, b)`` for part ``k`` with box centre ``c``, up axis ``y_k``
and right axis ``x_k`` (columns 1 and 0 of the part's rotation) are (as in CPPF, Wang et al. 2022):

* ``e = (a - b) / |a - b|``;
* ``mu = (a - c) . e`` (signed): the foot of the perpendicular from ``c`` to the pair's line is
  ``a - mu e``;
* ``nu = |a - c - mu e|``: ``c`` lies on the circle of radius ``nu`` about that foot, normal to ``e``;
* ``alpha = angle(e, y_k)``, ``beta = angle(e, x_k)`` in ``[0, pi]``;
* sign bits: with the normal at ``a`` flipped so that ``n . e >= 0`` (normals are unoriented),
  ``[n . y_k > 0]`` and ``[n . x_k > 0]``;
* ``gamma = log(size_m) - log(mean_size_m)``.

These functions are the single definition of the parameters: the voting (``ucope.voting``) inverts
exactly these.
"""

from __future__ import annotations

import torch

from ..vocab import JointType

__all__ = [
    "pair_vote_targets",
    "joint_point_targets",
    "two_hot",
    "two_hot_kl",
    "bin_centres",
    "canonical_pair_normals",
    "pair_features",
]


def canonical_pair_normals(e: torch.Tensor, n_a: torch.Tensor, n_b: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Flip each normal so that it points along the pair direction: ``n . e >= 0``.

    Normals from kNN PCA are defined up to sign; after this flip every feature built from them is
    invariant to the input normals' signs. Shapes ``(..., 3)``.
    """
    s_a = torch.where((n_a * e).sum(-1, keepdim=True) < 0, -1.0, 1.0).to(n_a.dtype)
    s_b = torch.where((n_b * e).sum(-1, keepdim=True) < 0, -1.0, 1.0).to(n_b.dtype)
    return n_a * s_a, n_b * s_b


def pair_features(
    a: torch.Tensor, b: torch.Tensor, n_a: torch.Tensor, n_b: torch.Tensor, scale: torch.Tensor | float
) -> torch.Tensor:
    """Sign-invariant point pair features ``[|a-b| / scale, n_a.e, n_b.e, n_a.n_b]`` (Drost et al.).

    Args:
        a, b: ``(..., 3)`` points; n_a, n_b: ``(..., 3)`` unit normals (any sign).
        scale: the length unit of the distance feature (broadcastable to ``(...)``).

    Returns:
        ``(..., 4)``; rotation- and translation-invariant, invariant to the normals' signs.
    """
    # Equal to canonical_pair_normals followed by the dot products, with three dot products only:
    # flipping n so that n . e >= 0 turns n . e into |n . e| and n_a . n_b into s_a s_b n_a . n_b.
    d = a - b
    dist = d.norm(dim=-1)
    inv = 1.0 / dist.clamp_min(1e-9)
    da = (n_a * d).sum(-1)
    db = (n_b * d).sum(-1)
    flip = (da < 0) != (db < 0)
    nab = (n_a * n_b).sum(-1)
    return torch.stack([dist / scale, da.abs() * inv, db.abs() * inv, torch.where(flip, -nab, nab)], dim=-1)


def pair_vote_targets(
    a: torch.Tensor,
    b: torch.Tensor,
    n_a: torch.Tensor,
    cam_from_part: torch.Tensor,
    size_m: torch.Tensor,
    mean_size_m: torch.Tensor,
) -> dict[str, torch.Tensor]:
    """The voting parameters of point pairs for one part each (see the module docstring).

    Args:
        a, b: ``(..., M, 3)`` pair points, camera frame, metres.
        n_a: ``(..., M, 3)`` unit normals at ``a`` (any sign).
        cam_from_part: ``(..., 4, 4)`` the part's pose (box centre = its translation).
        size_m: ``(..., 3)`` the part's box extents; mean_size_m: ``(..., 3)`` the category mean.

    Returns:
        dict of ``mu``, ``nu``, ``alpha``, ``beta``, ``dist`` ``(..., M)`` (metres / radians),
        ``sign`` ``(..., M, 2)`` float 0/1 (up, right), ``gamma`` ``(..., 3)``.
    """
    R = cam_from_part[..., :3, :3]
    c = cam_from_part[..., :3, 3].unsqueeze(-2)  # (..., 1, 3)
    up = R[..., :, 1].unsqueeze(-2)
    right = R[..., :, 0].unsqueeze(-2)
    d = a - b
    dist = d.norm(dim=-1)
    e = d / dist.clamp_min(1e-9).unsqueeze(-1)
    ac = a - c
    mu = (ac * e).sum(-1)
    nu = (ac - mu.unsqueeze(-1) * e).norm(dim=-1)
    alpha = torch.arccos((e * up).sum(-1).clamp(-1.0, 1.0))
    beta = torch.arccos((e * right).sum(-1).clamp(-1.0, 1.0))
    n = torch.where((n_a * e).sum(-1, keepdim=True) < 0, -n_a, n_a)
    sign = torch.stack([(n * up).sum(-1) > 0, (n * right).sum(-1) > 0], dim=-1).to(a.dtype)
    gamma = torch.log(size_m) - torch.log(mean_size_m)
    return {"mu": mu, "nu": nu, "alpha": alpha, "beta": beta, "dist": dist, "sign": sign, "gamma": gamma}


def joint_point_targets(
    points: torch.Tensor,
    labels: torch.Tensor,
    pivot: torch.Tensor,
    axis: torch.Tensor,
    joint_type: torch.Tensor,
    parents: torch.Tensor,
    children: torch.Tensor,
    heat_radius_m: torch.Tensor | float,
) -> dict[str, torch.Tensor]:
    """Per-point, per-joint targets of the joint heads (paper equations (1)-(3), (9)).

    * ``heat``: revolute: ``max(0, 1 - d / r)`` with ``d`` the point's distance to the joint axis line
      and ``r = heat_radius_m``; prismatic (whose axis has no location): 1 on the child part, else 0.
    * ``offset``: from the point to its foot on the axis line (revolute; 0 for prismatic).
    * ``score``: 1 if the point belongs to the joint's parent or child part (equation (9)).

    Args:
        points: ``(B, N, 3)``; labels: ``(B, N)`` part indices.
        pivot, axis: ``(B, J, 3)`` camera frame (axis unit); joint_type: ``(B, J)`` (0 revolute,
            1 prismatic); parents, children: ``(J,)`` part indices.
        heat_radius_m: scalar or ``(B,)``.

    Returns:
        dict with ``heat``, ``score`` ``(B, J, N)`` and ``offset`` ``(B, J, N, 3)`` (metres).
    """
    v = points.unsqueeze(1) - pivot.unsqueeze(2)  # (B, J, N, 3)
    u = axis.unsqueeze(2)
    perp = v - (v * u).sum(-1, keepdim=True) * u
    d = perp.norm(dim=-1)
    r = torch.as_tensor(heat_radius_m, dtype=points.dtype, device=points.device)
    r = r.reshape(-1, 1, 1) if r.ndim == 1 else r
    revolute = (joint_type == int(JointType.REVOLUTE)).unsqueeze(-1)  # (B, J, 1)
    lab = labels.unsqueeze(1)  # (B, 1, N)
    on_child = lab == children.view(1, -1, 1)
    on_parent = lab == parents.view(1, -1, 1)
    heat = torch.where(revolute, (1.0 - d / r).clamp_min(0.0), on_child.to(points.dtype))
    offset = torch.where(revolute.unsqueeze(-1), -perp, torch.zeros_like(perp))
    score = (on_child | on_parent).to(points.dtype)
    return {"heat": heat, "offset": offset, "score": score}


def bin_centres(lo: float, hi: float, n: int, device=None, dtype=torch.float32) -> torch.Tensor:
    """The ``n`` bin centres of ``[lo, hi]`` split into equal bins: ``lo + (i + 0.5) (hi - lo) / n``."""
    return lo + (torch.arange(n, device=device, dtype=dtype) + 0.5) * ((hi - lo) / n)


def two_hot(x: torch.Tensor, lo: torch.Tensor | float, hi: torch.Tensor | float, n: int) -> torch.Tensor:
    """Soft two-hot targets: ``x`` split linearly between its two nearest bin centres.

    Values beyond the first / last centre go entirely to the end bin. ``lo`` / ``hi`` broadcast
    against ``x`` (e.g. a per-part vote range). Returns ``(*x.shape, n)``; each row sums to 1 and its
    expectation over the centres equals ``x`` (inside the centres' span).
    """
    lo = torch.as_tensor(lo, dtype=x.dtype, device=x.device)
    hi = torch.as_tensor(hi, dtype=x.dtype, device=x.device)
    pos = ((x - lo) / (hi - lo) * n - 0.5).clamp(0.0, n - 1.0)  # continuous bin coordinate
    i0 = pos.floor().clamp(max=n - 2).long() if n > 1 else torch.zeros_like(pos, dtype=torch.long)
    w1 = (pos - i0.to(pos.dtype)).clamp(0.0, 1.0)
    out = torch.zeros(*x.shape, n, dtype=x.dtype, device=x.device)
    out.scatter_(-1, i0.unsqueeze(-1), (1.0 - w1).unsqueeze(-1))
    if n > 1:
        out.scatter_add_(-1, (i0 + 1).unsqueeze(-1), w1.unsqueeze(-1))
    return out


def two_hot_kl(logits: torch.Tensor, x: torch.Tensor, lo: torch.Tensor | float, hi: torch.Tensor | float) -> torch.Tensor:
    """``KL(two_hot(x, lo, hi, n) || softmax(logits))`` over the last axis (``n = logits.shape[-1]``), per row.

    Equal to ``F.kl_div(logits.log_softmax(-1), two_hot(x, lo, hi, n), reduction="none").sum(-1)`` (to float
    rounding), without materialising the ``(..., n)`` target or log-probabilities: a two-hot target has two
    non-zero entries, so the divergence is ``sum_i t_i (log t_i - logits_i + logsumexp(logits))`` over them.

    Args:
        logits: ``(..., n)`` bin logits; x: ``(...)`` values; lo, hi: as in :func:`two_hot`.

    Returns:
        ``(...)`` divergences (differentiable in ``logits``).
    """
    n = logits.shape[-1]
    lo = torch.as_tensor(lo, dtype=x.dtype, device=x.device)
    hi = torch.as_tensor(hi, dtype=x.dtype, device=x.device)
    pos = ((x - lo) / (hi - lo) * n - 0.5).clamp(0.0, n - 1.0)
    if n > 1:
        i0 = pos.floor().clamp(max=n - 2).long()
        w1 = (pos - i0.to(pos.dtype)).clamp(0.0, 1.0)
        idx = torch.stack([i0, i0 + 1], dim=-1)
        w = torch.stack([1.0 - w1, w1], dim=-1)
    else:
        idx = torch.zeros((*pos.shape, 1), dtype=torch.long, device=x.device)
        w = torch.ones((*pos.shape, 1), dtype=x.dtype, device=x.device)
    log_p = logits.gather(-1, idx) - logits.logsumexp(-1, keepdim=True)
    return (torch.xlogy(w, w) - w * log_p).sum(-1)
