"""Per-part 9D pose by voting (paper section 4.4, with the part awareness of section 4.5).

For part ``k`` (:func:`vote_part`):

1. **Part awareness**: the pairs whose predicted part score ``sigmoid(part_score) > 0.5`` vote (pairs
   across two parts carry wrong parameters). If fewer than ``min_pairs`` pass, every pair of the part
   votes instead (``fallback``), which also lowers the score (below). ``score_filter=False`` (ablation):
   every pair votes with weight 1. Pairs of one point twice never vote (no direction); a part whose
   pairs are all such gets no estimate: identity rotation at the points' mean, the mean size, score 0.
2. Decode ``mu, nu`` (on ``[-V_k, V_k]`` / ``[0, V_k]``) and ``alpha, beta`` (on ``[0, pi]``) with
   :func:`ucope.voting.bins.decode_bins` (expectation within +-1 bin of the argmax).
3. Centre: :func:`ucope.voting.centre.vote_centre`; its inliers (circle within 2 cells of the centre,
   the paper's pool ``P``) vote everything else.
4. Up axis: :func:`ucope.voting.axis.vote_axis` on ``alpha``, sign by
   :func:`ucope.voting.axis.choose_axis_sign` (up sign bit). Right axis likewise on ``beta`` (right sign
   bit), unless the part is symmetric about ``y``.
5. Rotation: :func:`ucope.voting.rotation.rotation_from_axes` then a joint robust refinement on both
   sets of cones (:func:`ucope.voting.rotation.refine_rotation`).
6. Size: ``exp(mean gamma over the centre inliers) * mean_size_m`` (equation (8)). Beyond the paper, a
   thin part (a plate: smallest extent below ``thin_snap_ratio`` of the middle one) then has its centre
   moved along its thin axis so that its visible points lie on the box face towards the camera: the
   pairs of a plate barely constrain the centre along its normal (docs/voting.md).
7. Score: ``inlier fraction x mean part-score probability`` of the voting pairs, in ``[0, 1]``: high
   when the pairs agree on a centre and the network is sure they belong to the part; a fallback part
   has a mean probability below the threshold, so it ranks below confident parts.

:func:`vote_parts` does this for every part of one object from the network's output dict.

Frames and units: points, centres, poses in the camera frame, metres; poses returned as numpy float64
``cam_from_part`` ``(4, 4)`` (convention of docs/conventions.md). The voting runs in float32 torch on
the device of the inputs, its Gauss-Newton refinements in float64 numpy (see :mod:`ucope.voting`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from ..errors import InputError
from ..priors import CategoryPriors
from ..vocab import AXIS_HEADS, VOTE_HEADS
from .arrays import as_tensor, strided, tensor
from .axis import AxisOptions, axis_from_cones, coarse_axes, signed_axis
from .bins import decode_bins
from .centre import CentreOptions, centre_from_circles
from .rotation import rotation_from_axes, rotation_from_cones

__all__ = ["VotingOptions", "PartVote", "vote_part", "vote_parts", "snap_to_visible_face", "as_points"]


@dataclass(frozen=True)
class VotingOptions:
    """Voting settings (defaults measured in tests/voting and benchmarks/bench_voting.py).

    Attributes:
        score_threshold: part-score probability above which a pair votes (paper: 0.5).
        min_pairs: fewest passing pairs before falling back to every pair of the part.
        window: decoding window, bins either side of the argmax.
        centre: :class:`ucope.voting.centre.CentreOptions` of the centre vote (here the refinement
            runs on at most 1024 pairs).
        axis: :class:`ucope.voting.axis.AxisOptions` of the up and right votes; its ``tol_deg`` and
            ``min_tol_deg`` also scale the sign choice and the rotation refinement.
        max_axis_pairs: most centre inliers voting the axes (an evenly strided subset; decoded, refined
            on and used for the signs and the rotation refinement). The centre inlier test, the size
            and the score use every voting pair.
        use_sign_bits: use the predicted sign bits to choose the axis signs.
        sign_margin: pairs whose normal is within this cosine of perpendicular to an axis carry no
            sign information.
        refine_rotation: jointly refine the rotation on both axes' cones; rotation_iters: its
            Gauss-Newton iterations.
        thin_snap_ratio: surface snap of thin parts (0: off; default 0.25, measured in
            docs/voting.md). A part whose smallest box extent is below this fraction of its middle one
            (a plate: laptop lid, scissor blade) has its centre moved along that thin axis so that its
            visible points lie on the box face towards the camera (the camera is the origin of the
            points' frame): the pair geometry hardly constrains the centre along the normal of a plate
            (``nu`` changes only to second order with it).
    """

    score_threshold: float = 0.5
    min_pairs: int = 8
    window: int = 1
    centre: CentreOptions = CentreOptions(max_refine_pairs=1024)
    axis: AxisOptions = AxisOptions()
    max_axis_pairs: int = 1024
    use_sign_bits: bool = True
    sign_margin: float = 0.05
    refine_rotation: bool = True
    rotation_iters: int = 4
    thin_snap_ratio: float = 0.25

    @classmethod
    def uncapped(cls, **kw) -> VotingOptions:
        """Options under which every voting pair casts every vote (ablation): no strided subsets for the
        axes (``max_axis_pairs``, the axis vote's ``max_coarse_pairs`` / ``max_refine_pairs``) or for the
        centre grid and refinement (``max_grid_pairs`` / ``max_refine_pairs``). Time grows about
        linearly with the pairs; the defaults cap them at 1,024 (axes) and 4,096 / 1,024 (centre)."""
        big = 2**31 - 1
        return cls(
            centre=CentreOptions(max_grid_pairs=big, max_refine_pairs=big),
            axis=AxisOptions(max_coarse_pairs=big, max_refine_pairs=big),
            max_axis_pairs=big,
            **kw,
        )

    @property
    def capped(self) -> bool:
        """Whether some vote runs on a strided subset of the pairs when there are many (the defaults)."""
        big = 2**31 - 1
        caps = (
            self.max_axis_pairs,
            self.centre.max_grid_pairs,
            self.centre.max_refine_pairs,
            self.axis.max_coarse_pairs,
            self.axis.max_refine_pairs,
        )
        return min(caps) < big

    def __post_init__(self) -> None:
        if not 0.0 <= self.score_threshold < 1.0:
            raise InputError(f"score_threshold must be in [0, 1), got {self.score_threshold}")
        if int(self.min_pairs) < 1 or int(self.max_axis_pairs) < 1 or int(self.window) < 0 or int(self.rotation_iters) < 0:
            raise InputError("min_pairs and max_axis_pairs must be positive, window and rotation_iters >= 0")


@dataclass
class PartVote:
    """The voted pose of one part.

    Attributes:
        cam_from_part: ``(4, 4)`` float64 pose (box centre = translation), camera frame, metres.
        size_m: ``(3,)`` float64 box extents along the part's x, y, z.
        score: confidence in ``[0, 1]`` (inlier fraction x mean part-score probability).
        num_pairs: pairs that voted; num_inliers: centre inliers among them.
        fallback: too few pairs passed the part score and every pair voted.
        mean_prob: the mean part-score probability of the voting pairs.
        up_agreement, right_agreement: the fractions of the axis-voting pairs whose cone (the angle
            ``alpha`` to y, ``beta`` to x between their direction and the axis) the voted rotation's y / x
            axis meets within ``VotingOptions.axis.tol_deg``; ``right_agreement`` is 1 for a part
            symmetric about y. A calibration feature: a low one says the pairs disagree on the axis
            (a mug whose handle direction is guessed).
        timings_ms: CPU wall time per stage (``decode``, ``centre``, ``axes``, ``rotation``, ``size``).
    """

    cam_from_part: np.ndarray
    size_m: np.ndarray
    score: float
    num_pairs: int
    num_inliers: int
    fallback: bool = False
    mean_prob: float = 0.0
    up_agreement: float = 0.0
    right_agreement: float = 0.0
    timings_ms: dict[str, float] = field(default_factory=dict)


def vote_part(
    a,
    b,
    normals_a,
    mu_logits,
    nu_logits,
    alpha_logits,
    beta_logits,
    sign_logits,
    gamma,
    part_score,
    *,
    vote_range_m: float,
    mean_size_m,
    symmetric: bool = False,
    score_filter: bool = True,
    options: VotingOptions | None = None,
) -> PartVote:
    """Vote the 9D pose of one part from its ``M`` pairs (see the module docstring).

    Args:
        a, b: ``(M, 3)`` pair points (camera frame, metres); normals_a: ``(M, 3)`` normals at ``a``.
        mu_logits, nu_logits: ``(M, mu_bins)`` / ``(M, nu_bins)``; alpha_logits, beta_logits:
            ``(M, angle_bins)``; sign_logits: ``(M, 2)`` (up, right); gamma: ``(M, 3)``; part_score:
            ``(M,)`` logits: this part's heads of :meth:`ucope.model.network.UCOPENet.pair_heads`.
        vote_range_m: ``V_k`` (metres); mean_size_m: ``(3,)`` the category mean size of the part.
        symmetric: the part is symmetric about ``y`` (only the up axis is voted).
        score_filter: only pairs whose part score passes ``options.score_threshold`` vote (the part
            awareness of the paper's equation (10); ``False``: every pair votes, an ablation).
        options: :class:`VotingOptions`.

    Returns:
        :class:`PartVote`.
    """
    opt = options or VotingOptions()
    t0 = time.perf_counter()
    a = tensor(a, "a", (None, 3))
    M = a.shape[0]
    if M == 0:
        raise InputError("vote_part needs at least one pair")
    dev = a.device
    b = tensor(b, "b", (M, 3), device=dev)
    n_a = tensor(normals_a, "normals_a", (M, 3), device=dev)
    mu_l = tensor(mu_logits, "mu_logits", (M, None), device=dev)
    nu_l = tensor(nu_logits, "nu_logits", (M, None), device=dev)
    al_l = tensor(alpha_logits, "alpha_logits", (M, None), device=dev)
    be_l = tensor(beta_logits, "beta_logits", (M, None), device=dev)
    sg_l = tensor(sign_logits, "sign_logits", (M, 2), device=dev)
    gam = tensor(gamma, "gamma", (M, 3), device=dev)
    ps = tensor(part_score, "part_score", (M,), device=dev)
    V = float(vote_range_m)
    if not (math.isfinite(V) and V > 0):
        raise InputError(f"vote_range_m must be a positive number, got {vote_range_m}")
    mean_size = np.asarray(mean_size_m, dtype=np.float64).reshape(-1)
    if mean_size.shape != (3,) or not np.all(np.isfinite(mean_size)) or np.any(mean_size <= 0):
        raise InputError(f"mean_size_m must be 3 positive numbers, got {mean_size_m}")

    mu = decode_bins(mu_l, -V, V, opt.window)
    nu = decode_bins(nu_l, 0.0, V, opt.window)
    return _vote_part(
        a,
        b,
        n_a,
        mu,
        nu,
        functools.partial(_rows, (al_l, be_l, sg_l)),
        gam,
        torch.sigmoid(ps),
        V,
        mean_size,
        symmetric,
        score_filter,
        opt,
        t0,
    )


def _vote_part(
    a,
    b,
    n_a,
    mu,
    nu,
    axis_logits,
    gam,
    prob,
    V: float,
    mean_size: np.ndarray,
    symmetric: bool,
    score_filter: bool,
    opt: VotingOptions,
    t0: float,
) -> PartVote:
    """:func:`vote_part` on checked inputs, with ``mu, nu`` ``(M,)`` already decoded (for every pair:
    decoding is row-wise, so :func:`vote_parts` decodes all parts at once), ``axis_logits(rows)`` the
    ``alpha``, ``beta`` and sign logits of the pairs ``rows`` ``(A,)`` (``(A, bins)``, ``(A, bins)``,
    ``(A, 2)``: computed lazily at inference), and ``prob`` ``(M,)`` the part-score probabilities;
    ``t0`` the start time of the decode stage."""
    dev = a.device
    a.shape[0]
    # 1. Part awareness, among the pairs of two distinct points (a pair (i, i) has no direction; the
    # network can still give it a high part score).
    fallback = False
    distinct = (a != b).any(-1)
    sel = torch.nonzero(distinct).squeeze(-1)
    if score_filter:
        passing = torch.nonzero(distinct & (prob > float(opt.score_threshold))).squeeze(-1)
        if len(passing) >= int(opt.min_pairs):
            sel = passing
        else:
            fallback = True
    S = len(sel)
    if S == 0:  # every pair is degenerate: no estimate (score 0) rather than an error
        T = np.eye(4)
        T[:3, 3] = a.double().mean(0).cpu().numpy()
        return PartVote(
            cam_from_part=T,
            size_m=mean_size.copy(),
            score=0.0,
            num_pairs=0,
            num_inliers=0,
            fallback=True,
            timings_ms=dict(decode=1000.0 * (time.perf_counter() - t0), centre=0.0, axes=0.0, rotation=0.0, size=0.0),
        )
    # 2. The voting pairs' decoded mu, nu (they all take part in the inlier test).
    mu, nu = mu[sel], nu[sel]
    t1 = time.perf_counter()
    # 3. Centre.
    at = a[sel].T.contiguous()
    bt = b[sel].T.contiguous()
    centre, inl, et = centre_from_circles(
        at, bt, mu, nu, torch.ones(S, device=dev), V * float(opt.centre.cell_fraction), opt.centre
    )
    n_inl = int(inl.sum())
    pool = torch.nonzero(inl).squeeze(-1) if n_inl > 0 else torch.arange(S, device=dev)
    t2 = time.perf_counter()
    # 4. Axes, voted by (an evenly strided subset of at most max_axis_pairs of) the centre inliers.
    ax = strided(pool, opt.max_axis_pairs)
    gi = sel[ax]  # indices into the part's M pairs
    e_ax = et[:, ax].contiguous()
    n_ax = n_a[gi].T.contiguous()
    ones = torch.ones(len(ax), device=dev)
    every = torch.ones(len(ax), dtype=torch.bool, device=dev)
    ao = opt.axis
    ao_all = dataclasses.replace(ao, max_refine_pairs=max(len(ax), 1))  # the axes refine on every axis pair
    al_l, be_l, sg_l = axis_logits(gi)
    alpha = decode_bins(al_l, 0.0, math.pi, opt.window)
    beta = None if symmetric else decode_bins(be_l, 0.0, math.pi, opt.window)
    # The coarse vote of both axes at once (the same pairs and cone bases; one cube-map histogram).
    cs = strided(torch.arange(len(ax), device=dev), int(ao.max_coarse_pairs))
    coarse = coarse_axes(
        e_ax[:, cs], alpha[cs] if symmetric else torch.stack([alpha[cs], beta[cs]]), ones[cs], int(ao.num_angles), int(ao.grid)
    )
    up, _ = axis_from_cones(e_ax, alpha, ones, ao_all, coarse=coarse if symmetric else coarse[0], with_inliers=False)
    up, _ = signed_axis(up, e_ax, alpha, n_ax, sg_l[:, 0], every, float(ao.tol_deg), float(opt.sign_margin), opt.use_sign_bits)
    right = None
    if not symmetric:
        right, _ = axis_from_cones(e_ax, beta, ones, ao_all, coarse=coarse[1], with_inliers=False)
        right, _ = signed_axis(
            right, e_ax, beta, n_ax, sg_l[:, 1], every, float(ao.tol_deg), float(opt.sign_margin), opt.use_sign_bits
        )
    t3 = time.perf_counter()
    # 5. Rotation. Both axes voted onto (nearly) one direction happens on garbage votes: take y alone
    # then (x any perpendicular) and let the refinement find x on the beta cones.
    if right is not None and float(torch.linalg.cross(up / up.norm(), right / right.norm()).norm()) < 1e-3:
        right = None
    R = rotation_from_axes(up, right)
    if opt.refine_rotation:
        terms = [(1, e_ax, alpha, ones)] + ([] if symmetric else [(0, e_ax, beta, ones)])
        R = rotation_from_cones(R, terms, int(opt.rotation_iters), float(ao.tol_deg), float(ao.min_tol_deg))
    up_agree = _cone_agreement(R[:, 1], e_ax, alpha, float(ao.tol_deg))
    right_agree = 1.0 if symmetric else _cone_agreement(R[:, 0], e_ax, beta, float(ao.tol_deg))
    t4 = time.perf_counter()
    # 6. Size and score.
    g = gam[sel[pool]].mean(0)
    size = np.exp(g.double().cpu().numpy()) * mean_size
    if opt.thin_snap_ratio > 0:
        centre = snap_to_visible_face(centre, R, size, a[sel[pool]], float(opt.thin_snap_ratio), symmetric)
    mean_prob = float(prob[sel].mean())
    score = (n_inl / S) * mean_prob
    T = np.eye(4)
    T[:3, :3] = R.double().cpu().numpy()
    T[:3, 3] = centre.double().cpu().numpy()
    t5 = time.perf_counter()
    ms = lambda x, y: 1000.0 * (y - x)  # noqa: E731
    return PartVote(
        cam_from_part=T,
        size_m=size,
        score=float(score),
        num_pairs=S,
        num_inliers=n_inl,
        fallback=fallback,
        mean_prob=mean_prob,
        up_agreement=up_agree,
        right_agreement=right_agree,
        timings_ms=dict(decode=ms(t0, t1), centre=ms(t1, t2), axes=ms(t2, t3), rotation=ms(t3, t4), size=ms(t4, t5)),
    )


def _cone_agreement(axis: torch.Tensor, e: torch.Tensor, angle: torch.Tensor, tol_deg: float) -> float:
    """The fraction of pairs whose cone about their unit direction ``e`` ``(3, A)`` with half-angle
    ``angle`` ``(A,)`` (radians) passes within ``tol_deg`` of the unit ``axis`` ``(3,)``."""
    if e.shape[1] == 0:
        return 0.0
    a = axis.to(e.dtype) / axis.norm()
    off = torch.acos((a @ e).clamp(-1.0, 1.0)) - angle
    return float((off.abs() < math.radians(tol_deg)).float().mean())


def snap_to_visible_face(
    centre: torch.Tensor, R: torch.Tensor, size: np.ndarray, pts: torch.Tensor, ratio: float, symmetric: bool
) -> torch.Tensor:
    """:attr:`VotingOptions.thin_snap_ratio`: ``centre`` moved along the thin axis of the box so that
    the median of the part's points ``pts`` ``(P, 3)`` lies on the box face towards the camera. A part
    symmetric about y is snapped only along y (its x and z axes are arbitrary)."""
    order = np.argsort(size)
    k = int(order[0])
    if not size[k] < ratio * size[order[1]] or len(pts) == 0 or (symmetric and k != 1):
        return centre
    n = R[:, k]
    side = -1.0 if float(centre @ n) > 0 else 1.0  # the face whose outward normal points to the camera
    offset = float(((pts - centre) @ n).median()) - side * 0.5 * float(size[k])
    return centre + offset * n


def _one(x: torch.Tensor, name: str) -> torch.Tensor:
    """Drop a leading batch dimension of size 1."""
    if x.ndim >= 1 and x.shape[0] == 1:
        return x[0]
    raise InputError(f"{name}: expected batch size 1, got shape {tuple(x.shape)}")


def vote_parts(
    points,
    normals,
    pair_idx,
    outputs: Mapping[str, Any],
    priors: CategoryPriors,
    score_filter: bool = True,
    options: VotingOptions | None = None,
    axis_heads: Callable[[int, torch.Tensor], Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """Vote every part of one object from the network's outputs (batch size 1).

    Args:
        points: ``(N, 3)`` or ``(1, N, 3)`` the network's input cloud (camera frame, metres).
        normals: ``(N, 3)`` or ``(1, N, 3)`` its normals.
        pair_idx: ``(K, M, 2)`` or ``(1, K, M, 2)`` the pair indices given to the network (first
            column = ``a``).
        outputs: the dict of :meth:`ucope.model.network.UCOPENet.forward` (``mu_logits``...,
            ``(1, K, M, ...)`` tensors).
        priors: the category's :class:`ucope.priors.CategoryPriors` (vote ranges, mean sizes, symmetry).
        score_filter: the part-score filter on (paper) or off (ablation), see :func:`vote_part`.
        axis_heads: optional ``axis_heads(k, rows)`` -> ``alpha_logits``, ``beta_logits``,
            ``sign_logits`` of part ``k``'s pairs ``rows`` ``(A,)`` (``(A, ...)`` tensors); then
            ``outputs`` may omit those heads. The estimator passes
            :meth:`ucope.model.network.UCOPENet.pair_outputs` here: the axes are voted by at most
            ``options.max_axis_pairs`` pairs per part, so the network evaluates its widest heads on
            those alone.

    Returns:
        dict of numpy arrays: ``cam_from_part`` ``(K, 4, 4)``, ``size_m`` ``(K, 3)``, ``score``
        ``(K,)``, ``num_pairs`` / ``num_inliers`` ``(K,)`` int, ``fallback`` ``(K,)`` bool, ``mean_prob``,
        ``up_agreement`` and ``right_agreement`` ``(K,)`` (:class:`PartVote`), and ``timings_ms`` (a list
        of per-part stage timings).
    """
    K = priors.num_parts
    pts = as_points(points, "points")
    nrm = as_points(normals, "normals", device=pts.device)
    if nrm.shape != pts.shape:
        raise InputError(f"normals must match points {tuple(pts.shape)}, got {tuple(nrm.shape)}")
    idx = tensor(pair_idx, "pair_idx", (None,) * (4 if np.ndim(pair_idx) == 4 else 3), dtype=torch.long, device=pts.device)
    if idx.ndim == 4:
        idx = _one(idx, "pair_idx")
    if idx.ndim != 3 or idx.shape[0] != K or idx.shape[2] != 2:
        raise InputError(f"pair_idx must be (K={K}, M, 2), got {tuple(idx.shape)}")
    N = pts.shape[0]
    if bool((idx < 0).any()) or bool((idx >= N).any()):
        raise InputError(f"pair_idx holds indices outside [0, {N})")
    heads = {}
    names = VOTE_HEADS + (() if axis_heads is not None else AXIS_HEADS)
    for name in names:
        if name not in outputs:
            raise InputError(f"outputs lack {name!r} (run the network with pair_idx)")
        if name in ("mu_logits", "nu_logits"):  # NaN / inf logits surface in decode_bins' check of its values
            x = as_tensor(outputs[name], name, device=pts.device)
        else:
            x = tensor(outputs[name], name, (None,) * np.ndim(outputs[name]), device=pts.device)
        want = 3 if name == "part_score" else 4
        if x.ndim == want:
            x = _one(x, name)
        if x.ndim != want - 1 or x.shape[:2] != (K, idx.shape[1]):
            raise InputError(f"outputs[{name!r}] must start with (1, K={K}, M={idx.shape[1]}), got {tuple(outputs[name].shape)}")
        heads[name] = x
    out = dict(
        cam_from_part=np.zeros((K, 4, 4)),
        size_m=np.zeros((K, 3)),
        score=np.zeros(K),
        num_pairs=np.zeros(K, dtype=np.int64),
        num_inliers=np.zeros(K, dtype=np.int64),
        fallback=np.zeros(K, dtype=bool),
        mean_prob=np.zeros(K),
        up_agreement=np.zeros(K),
        right_agreement=np.zeros(K),
        timings_ms=[],
    )
    opt = options or VotingOptions()
    t0 = time.perf_counter()
    V = torch.tensor(priors.vote_range_m, dtype=pts.dtype, device=pts.device).view(K, 1)
    mu_all = decode_bins(heads["mu_logits"], -V, V, opt.window)  # (K, M), every part at once
    nu_all = decode_bins(heads["nu_logits"], 0.0, V, opt.window)
    prob_all = torch.sigmoid(heads["part_score"])
    gamma_all = heads["gamma"].contiguous()  # a strided view of the output layer: rows gather faster
    mean_sizes = priors.mean_size_m
    vote_ranges = priors.vote_range_m
    for k in range(K):  # a handful of parts; everything inside is vectorised over pairs
        ia, ib = idx[k, :, 0], idx[k, :, 1]
        if axis_heads is None:
            axis_logits = functools.partial(_rows, tuple(heads[n][k] for n in AXIS_HEADS))
        else:
            axis_logits = functools.partial(_lazy_rows, axis_heads, k)
        r = _vote_part(
            pts[ia],
            pts[ib],
            nrm[ia],
            mu_all[k],
            nu_all[k],
            axis_logits,
            gamma_all[k],
            prob_all[k],
            float(vote_ranges[k]),
            mean_sizes[k],
            priors.symmetric[k],
            score_filter,
            opt,
            t0 if k == 0 else time.perf_counter(),
        )
        out["cam_from_part"][k] = r.cam_from_part
        out["size_m"][k] = r.size_m
        out["score"][k] = r.score
        out["mean_prob"][k] = r.mean_prob
        out["up_agreement"][k] = r.up_agreement
        out["right_agreement"][k] = r.right_agreement
        out["num_pairs"][k] = r.num_pairs
        out["num_inliers"][k] = r.num_inliers
        out["fallback"][k] = r.fallback
        out["timings_ms"].append(r.timings_ms)
    return out


def _rows(logits: tuple, rows: torch.Tensor) -> tuple:
    return tuple(x[rows] for x in logits)


def _lazy_rows(axis_heads: Callable, k: int, rows: torch.Tensor) -> tuple:
    """The axis heads of part ``k``'s pairs ``rows`` from ``axis_heads``, checked."""
    out = axis_heads(k, rows)
    A = len(rows)
    try:
        return tuple(tensor(out[n], n, (A, None), device=rows.device) for n in AXIS_HEADS)
    except KeyError as e:
        raise InputError(f"axis_heads returned no {e.args[0]!r}") from None


def as_points(x, name: str, device=None) -> torch.Tensor:
    """``(N, 3)`` float32 points from ``(N, 3)`` or ``(1, N, 3)``."""
    t = tensor(x, name, (None,) * np.ndim(x), device=device)
    if t.ndim == 3:
        t = _one(t, name)
    if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] == 0:
        raise InputError(f"{name} must be (N, 3) or (1, N, 3) with N > 0, got {tuple(t.shape)}")
    return t
