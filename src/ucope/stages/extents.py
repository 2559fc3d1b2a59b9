"""Box extents from the points a part shows (the ``fit_boxes`` stage).

The voted size of a part (``exp(gamma)`` times the category's mean size) leans towards the training objects'
proportions, while a part's amodal box holds all of its surface:

* :func:`grow_to_points` widens each box, axis by axis in the part's voted frame, until it holds the robust range
  of the part's sure points (``quantile`` to ``1 - quantile``), its centre moved to the middle of that range. It
  never shrinks a box, nor touches a thin axis, a part symmetric about y or a part with too few points.
* :func:`fit_seen_extents` sets the axes that views with this face pattern saw whole in training
  (``PartPrior.seen_extent``) from the points, larger or smaller than voted.
* :func:`anchor_faced_faces` moves a box so that the faces the camera faces sit where the points put them
  (``PartPrior.faced_gap``).
* :func:`carry_child_sizes` gives a child the extents its measured parent says it has, where their ratio
  (``JointPrior.child_size_ratio``) held over the training views.

Only confident points joined to the box count (:func:`ucope.stages.support.joined_to_box`); parts another
part's box hides are left alone (:func:`ucope.geometry.boxes.occluded_fraction`). Camera frame, metres;
``cam_from_part`` ``(K, 4, 4)`` as in docs/conventions.md (boxes centred on their part frames, axis-aligned).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.boxes import SEEN_PATTERNS, occluded_fraction, seen_pattern
from ..priors import SEEN_MAX_OCCLUDED, SEEN_QUANTILE, CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .support import (
    GROW_CONNECT_FACTOR,
    GROW_MIN_CONFIDENCE,
    GROW_MIN_POINTS,
    GROW_QUANTILE,
    _check_range_settings,
    _checked,
    _checked_sizes,
    _confident,
    _hinged_centre,
    _part_mask,
    _symmetries,
    joined_to_box,
)


@dataclass(frozen=True)
class FitBoxesParams:
    """Attributes:
    grow: widen boxes to hold their points (:func:`grow_to_points`), by ``grow_quantile`` (the range held) and
        ``grow_thin_ratio`` (axes below it times the part's median extent are never grown).
    fit: set the axes views like this one see whole from the points (:func:`fit_seen_extents`), then carry a
        child's extents from its measured parent (:func:`carry_child_sizes`); only parts whose calibrated score
        is below ``fit_below`` (every part without a calibration), only clouds of ``fit_min_input`` points or more.
        An axis is fitted where the 10th percentile of its seen ratio for this face pattern is ``fit_min_ratio`` or
        more and the 90th ``fit_max_ratio`` or less; a fitted extent below ``fit_min_seen`` times the voted one is refused.
    anchor: put the root part's faces that the camera faces where its points are (:func:`anchor_faced_faces`),
        only for clouds of ``anchor_min_input`` points or more whose surface noise is at most ``anchor_max_noise_m``,
        and only along axes whose training gap between face and points varied by at most ``anchor_max_spread``
        (10th to 90th percentile, part box diagonals).
    carry_max_spread / carry_min_change: a child's extent follows its measured parent's only along axes whose
        size ratio varied by at most this (standard deviation over the mean) and where it moves the extent by more
        than this fraction.
    sure_confidence: points at least this likely to be the object grow a box and bound a fitted extent from
        below; plausible_confidence: points at least this likely bound a fitted extent from above and anchor
        faces (lower, since leaving a part's real points out shrinks a fitted box).
    min_points: parts with fewer such points keep their box; connect_factor: the longest step between joined points
        (median nearest-neighbour distances).
    """

    grow: bool = True
    fit: bool = True
    anchor: bool = True
    fit_below: float = 0.9
    fit_min_input: int = 1000
    anchor_min_input: int = 600
    anchor_max_noise_m: float = 1.5e-3
    grow_quantile: float = GROW_QUANTILE
    grow_thin_ratio: float = 0.25
    fit_min_ratio: float = 0.85
    fit_max_ratio: float = 1.05
    fit_min_seen: float = 0.5
    anchor_max_spread: float = 0.03
    carry_max_spread: float = 0.03
    carry_min_change: float = 0.15
    sure_confidence: float = GROW_MIN_CONFIDENCE
    plausible_confidence: float = 0.5
    min_points: int = GROW_MIN_POINTS
    connect_factor: float = GROW_CONNECT_FACTOR

    def __post_init__(self) -> None:
        if not (0.0 <= self.fit_below <= 1.0 and self.anchor_max_noise_m >= 0.0):
            raise InputError(
                f"fit_below must be in [0, 1] and anchor_max_noise_m >= 0, got {self.fit_below}, {self.anchor_max_noise_m}"
            )


_P = FitBoxesParams()


def grow_to_points(
    cam_from_part,
    size_m,
    points,
    labels,
    symmetry: Sequence[str] | None = None,
    quantile: float = _P.grow_quantile,
    thin_ratio: float = _P.grow_thin_ratio,
    min_points: int = _P.min_points,
    connect_factor: float | None = _P.connect_factor,
    confidence=None,
    min_confidence: float = _P.sure_confidence,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every part's box widened to hold the robust range of the points labelled as it (module docstring).

    Args:
        cam_from_part: ``(K, 4, 4)`` the parts' voted poses (camera frame, metres).
        size_m: ``(K, 3)`` their box extents along the part's x, y, z (metres, > 0).
        points: ``(P, 3)`` the cloud the labels belong to (camera frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        symmetry: ``K`` part symmetries (``"none"``, ``"y"``...); parts other than ``"none"`` are kept.
            ``None``: every part ``"none"``.
        quantile: in ``[0, 0.5)``; the range along each axis is ``[q, 1 - q]`` of the part's coordinates.
        thin_ratio: axes whose extent is below ``thin_ratio`` times the part's median extent are kept.
        min_points: parts with fewer points (or fewer joined to their box) keep their box.
        connect_factor: only points joined to the box count (:func:`joined_to_box` with this factor);
            ``None``: every point of the part.
        confidence: ``(P,)`` the probability that each point is the object; points below ``min_confidence``
            do not count. ``None``: every point counts.

    Returns:
        ``(cam_from_part, size_m, grown)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays (rotations
        unchanged, translations moved by the centre shift) and ``(K,)`` bool, which parts changed.

    Raises:
        InputError: shapes that do not match, a non-finite pose, size or point, a non-positive size,
            ``quantile`` outside ``[0, 0.5)``, a ``connect_factor`` that is not positive.
    """
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    K = len(T)
    _check_range_settings(quantile, connect_factor)
    lab = _confident(lab, confidence, min_confidence)
    sym = _symmetries(symmetry, K)
    grown = np.zeros(K, dtype=bool)
    for k in range(K):  # a handful of parts; every point operation below is vectorised
        sel = lab == k
        if sym[k] != "none" or np.count_nonzero(sel) < min_points:
            continue
        R, t = T[k, :3, :3], T[k, :3, 3]
        q = (pts[sel] - t) @ R  # the part's points in its voted frame
        half = 0.5 * S[k]
        free = S[k] >= thin_ratio * np.median(S[k])
        if np.all(np.abs(q[:, free]) <= half[free]):  # nothing beyond the box where it may grow: no graph to build
            continue
        if connect_factor is not None:
            q = q[joined_to_box(q, half, connect_factor)]
            if len(q) < min_points:
                continue
        lo, hi = np.quantile(q, [quantile, 1.0 - quantile], axis=0)
        new_lo = np.where(free, np.minimum(-half, lo), -half)
        new_hi = np.where(free, np.maximum(half, hi), half)
        if np.array_equal(new_lo, -half) and np.array_equal(new_hi, half):
            continue
        S[k] = new_hi - new_lo
        T[k, :3, 3] = t + R @ (0.5 * (new_lo + new_hi))
        grown[k] = True
    return T, S, grown


def _checked_table(table, shape: tuple, name: str, negative: bool) -> np.ndarray:
    """``table`` as float64 after checking its shape and that it holds no infinity (NaN: not measured) and, unless
    ``negative``, no negative entry."""
    out = np.asarray(table, dtype=np.float64)
    if out.shape != shape or np.isinf(out).any() or (not negative and (out < 0).any()):
        what = "finite entries" if negative else "finite ratios >= 0"
        raise InputError(f"{name} must have shape {shape} with {what} (NaN: not measured), got {out.shape}")
    return out


def _robust_range(pts, sel, cam_from_box, half, quantile, connect_factor, min_points) -> np.ndarray | None:
    """``(2, 3)``: the ``quantile`` and ``1 - quantile`` quantiles of the points ``pts[sel]`` in the box frame
    ``cam_from_box`` (only those joined to the box ``[-half, half]`` when ``connect_factor`` is given); ``None`` with
    fewer than ``min_points`` of them."""
    q = (pts[sel] - cam_from_box[:3, 3]) @ cam_from_box[:3, :3]  # the part's points in its voted frame
    if connect_factor is not None and len(q):
        q = q[joined_to_box(q, half, connect_factor)]
    return np.quantile(q, [quantile, 1.0 - quantile], axis=0) if len(q) >= min_points else None


def _seen_axes(table, T, S, sym, movable, min_ratio, max_ratio) -> tuple[np.ndarray, np.ndarray]:
    """``(stats (K, 3, 3), fit (K, 3) bool)``: the seen-ratio percentiles of this view's face pattern per part and axis,
    and the axes they say are seen whole (not the x and z axes of a y-symmetric part, only parts in ``movable``)."""
    K = len(T)
    stats = table[np.arange(K)[:, None], np.arange(3)[None, :], seen_pattern(T, S)]  # (K, 3, 3) for this view
    with np.errstate(invalid="ignore"):  # NaN (not measured) compares False
        fit = (stats[..., 0] >= min_ratio) & (stats[..., 2] <= max_ratio) & (stats[..., 1] > 0)
    fit[np.array([k for k in range(K) if sym[k] != "none"], dtype=np.int64), 0::2] = False  # x, z of a y-symmetric part
    return stats, fit & movable[:, None]


def fit_seen_extents(
    cam_from_part,
    size_m,
    points,
    labels,
    seen_extent,
    symmetry: Sequence[str] | None = None,
    parts: Sequence[int] | None = None,
    quantile: float = SEEN_QUANTILE,
    min_points: int = _P.min_points,
    connect_factor: float | None = _P.connect_factor,
    confidence=None,
    min_confidence: float = _P.plausible_confidence,
    sure_confidence: float = _P.sure_confidence,
    min_ratio: float = _P.fit_min_ratio,
    max_ratio: float = _P.fit_max_ratio,
    min_seen: float = _P.fit_min_seen,
    max_occluded: float = SEEN_MAX_OCCLUDED,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Box axes that views like this one see whole, set from the points segmented as their part.

    Per part, axis and face pattern (:func:`ucope.geometry.boxes.seen_pattern` of the voted box) the training views
    measured the seen ratio: the robust range of the part's points along the axis over the box's extent
    (``seen_extent``). Where this view's pattern saw at least ``min_ratio`` at the 10th percentile and at most
    ``max_ratio`` at the 90th, the axis's extent is held between the range of the sure points (``confidence >=
    sure_confidence``) and that of the plausible ones (``>= min_confidence``), each over the median ratio: a voted
    extent outside that interval is set to its nearer end and the centre moves to the middle of the range that set
    it. Left alone: parts not in ``parts`` or hidden by a neighbour's box (more than ``max_occluded``), the x and z
    axes of y-symmetric parts, parts with under ``min_points`` points, and extents that would fall below ``min_seen``
    times the voted ones.

    Args:
        cam_from_part, size_m, points, labels: as :func:`grow_to_points`.
        seen_extent: ``(K, 3, SEEN_PATTERNS, 3)`` per part, axis and face pattern the 10th, 50th and 90th
            percentiles of the seen ratio, NaN where not measured (:attr:`ucope.priors.CategoryPriors.seen_extent`).
        symmetry, min_points, connect_factor: as :func:`grow_to_points`; parts: the parts to fit (``None``: all).
        confidence: ``(P,)`` the probability that each point is the object (``None``: every labelled point is sure).

    Returns:
        ``(cam_from_part, size_m, fitted)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays (rotations
        unchanged) and ``(K, 3)`` bool, which axes were set.

    Raises:
        InputError: shapes that do not match, non-finite poses, sizes or points, a non-positive size, a negative
            or infinite table entry, a part outside ``[0, K)``, ``quantile`` outside ``[0, 0.5)``, a ratio <= 0.
    """
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    K = len(T)
    table = _checked_table(seen_extent, (K, 3, SEEN_PATTERNS, 3), "seen_extent", negative=False)
    _check_range_settings(quantile, connect_factor)
    if not (min_ratio > 0 and max_ratio > 0 and min_seen > 0):
        raise InputError(f"min_ratio, max_ratio and min_seen must be positive, got {min_ratio!r}, {max_ratio!r}, {min_seen!r}")
    sure = _confident(lab, confidence, sure_confidence)
    lab = _confident(lab, confidence, min_confidence)
    stats, fit = _seen_axes(table, T, S, _symmetries(symmetry, K), _part_mask(parts, K), min_ratio, max_ratio)
    fitted = np.zeros((K, 3), dtype=bool)
    if not fit.any():
        return T, S, fitted
    fit &= (occluded_fraction(T, S) <= max_occluded)[:, None]
    for k in np.flatnonzero(fit.any(1)):  # a handful of parts; the point work is vectorised
        R, t = T[k, :3, :3], T[k, :3, 3]
        # the sure points bound the extent from below, the plausible ones from above
        least_r, most_r = (
            _robust_range(pts, c == k, T[k], 0.5 * S[k], quantile, connect_factor, min_points) for c in (sure, lab)
        )
        if most_r is None:
            continue
        least_r = most_r if least_r is None else least_r
        med = np.where(fit[k], stats[k, :, 1], 1.0)
        least, most = (np.diff(r, axis=0)[0] / med for r in (least_r, most_r))
        least = np.minimum(least, most)
        new = np.clip(S[k], least, most)
        mid = np.where(S[k] > most, most_r.mean(0), np.where(S[k] < least, least_r.mean(0), 0.0))
        a = fit[k] & (new >= min_seen * S[k]) & (new != S[k])
        S[k] = np.where(a, new, S[k])
        T[k, :3, 3] = t + R @ np.where(a, mid, 0.0)
        fitted[k] = a
    return T, S, fitted


def anchor_faced_faces(
    cam_from_part,
    size_m,
    points,
    labels,
    faced_gap,
    parts: Sequence[int] | None = None,
    keep=None,
    quantile: float = SEEN_QUANTILE,
    min_points: int = _P.min_points,
    connect_factor: float | None = _P.connect_factor,
    confidence=None,
    min_confidence: float = _P.plausible_confidence,
    max_spread: float = _P.anchor_max_spread,
    max_occluded: float = SEEN_MAX_OCCLUDED,
) -> tuple[np.ndarray, np.ndarray]:
    """Box centres moved so that the faces the camera faces sit where the part's points put them.

    Along every axis where the camera lies beyond a face of the voted box (its box-frame coordinate beyond half the
    extent), and where the training views' gap between that face and the points (``faced_gap``) varied by at most
    ``max_spread`` part diagonals, the face is put at the points' extreme towards the camera (their ``1 - quantile``
    quantile) plus the median gap, and the centre half the voted extent behind it. Sizes and rotations are kept.
    Left alone: parts not in ``parts``, axes marked in ``keep``, parts a neighbour's box hides (more than
    ``max_occluded``), parts with fewer than ``min_points`` points joined to their box.

    Args:
        cam_from_part, size_m, points, labels: as :func:`grow_to_points`.
        faced_gap: ``(K, 3, 2, 3)`` per part, axis and faced side (-, +) the 10th, 50th and 90th percentiles
            of the gap (part box diagonals), NaN where not measured (:attr:`ucope.priors.CategoryPriors.faced_gap`).
        parts: the parts that may move (``None``: all).
        keep: ``(K, 3)`` bool, axes to leave alone (those :func:`fit_seen_extents` set); ``None``: none.
        confidence, min_confidence, connect_factor: as :func:`fit_seen_extents`.

    Returns:
        ``(cam_from_part, anchored)``: new ``(K, 4, 4)`` float64 poses and ``(K, 3)`` bool, which axes moved.

    Raises:
        InputError: shapes that do not match, non-finite poses, sizes, points or table entries (other than
            NaN), a non-positive size, a part index outside ``[0, K)``, ``quantile`` outside ``[0, 0.5)``,
            a negative ``max_spread``.
    """
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    K = len(T)
    table = _checked_table(faced_gap, (K, 3, 2, 3), "faced_gap", negative=True)
    hold = np.zeros((K, 3), dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    if hold.shape != (K, 3):
        raise InputError(f"keep must have shape ({K}, 3), got {hold.shape}")
    _check_range_settings(quantile, connect_factor)
    if not max_spread >= 0:
        raise InputError(f"max_spread must be >= 0, got {max_spread!r}")
    lab = _confident(lab, confidence, min_confidence)
    cam = -np.einsum("kji,kj->ki", T[:, :3, :3], T[:, :3, 3])  # the camera in each part's frame
    plus = (cam > 0).astype(np.int64)
    stats = table[np.arange(K)[:, None], np.arange(3)[None, :], plus]  # (K, 3, 3): the faced side's gaps
    with np.errstate(invalid="ignore"):  # NaN (not measured) compares False
        move = (np.abs(cam) > 0.5 * S) & (stats[..., 2] - stats[..., 0] <= max_spread) & _part_mask(parts, K)[:, None] & ~hold
    anchored = np.zeros((K, 3), dtype=bool)
    if not move.any():
        return T, anchored
    move &= (occluded_fraction(T, S) <= max_occluded)[:, None]
    for k in np.flatnonzero(move.any(1)):  # a handful of parts; the point work is vectorised
        sel = lab == k
        if np.count_nonzero(sel) < min_points:
            continue
        rng = _robust_range(pts, sel, T[k], 0.5 * S[k], quantile, connect_factor, min_points)
        if rng is None:
            continue
        sign = np.where(plus[k] == 1, 1.0, -1.0)
        face = np.where(plus[k] == 1, rng[1], rng[0]) + sign * stats[k, :, 1] * np.linalg.norm(S[k])
        shift = np.where(move[k], face - sign * 0.5 * S[k], 0.0)
        T[k, :3, 3] = T[k, :3, 3] + T[k, :3, :3] @ shift
        anchored[k] = move[k]
    return T, anchored


def carry_child_sizes(
    cam_from_part,
    size_m,
    measured,
    priors: CategoryPriors,
    max_spread: float = _P.carry_max_spread,
    min_change: float = _P.carry_min_change,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Children's extents carried from their parents' measured ones through the joints.

    For each joint and each axis whose size ratio child / parent varied by at most ``max_spread`` over the training
    views (standard deviation over the mean, ``JointPrior.child_size_spread``), measured on the parent and not on the
    child, the child's extent becomes the ratio (``child_size_ratio``) times the parent's where that differs from the
    voted one by more than ``min_change`` (relative). A revolute child whose extents changed is then placed through
    the joint from its parent: its centre where the joint axis passes in both unit boxes (``pivot_in_parent`` /
    ``pivot_in_child``), its rotation kept. Parents are handled before children, so a carried child carries on.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        measured: ``(K, 3)`` bool, which extents were measured from the points (:func:`fit_seen_extents`).
        priors: the category's priors; joints without ``child_size_ratio`` are skipped.

    Returns:
        ``(cam_from_part, size_m, carried)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays and ``(K, 3)``
        bool, which extents were carried.

    Raises:
        InputError: shapes that do not match the priors, a non-positive or non-finite size, negative
            ``max_spread`` or ``min_change``.
    """
    T, S, done = _checked_sizes(cam_from_part, size_m, measured, priors, max_spread, min_change)
    K = priors.num_parts
    carried = np.zeros((K, 3), dtype=bool)
    for jp in priors.joints:  # parents before children; a handful of joints
        if jp.child_size_ratio is None:
            continue
        p, c = jp.parent, jp.child
        new = np.asarray(jp.child_size_ratio) * S[p]
        move = (np.asarray(jp.child_size_spread) <= max_spread) & done[p] & ~done[c] & (np.abs(new / S[c] - 1.0) > min_change)
        if not move.any():
            continue
        S[c] = np.where(move, new, S[c])
        carried[c] = move
        done[c] |= move
        if jp.type == JointType.REVOLUTE and jp.pivot_in_parent is not None:
            T[c, :3, 3] = _hinged_centre(T[p], S[p], T[c, :3, :3], S[c], jp, False)[0]
    return T, S, carried


@stage(
    "fit_boxes",
    kind="learned-prior",
    params=FitBoxesParams,
    reads=("parts.seen_extent", "parts.faced_gap", "joints.child_size_ratio"),
)
def _fit_boxes(state: PoseState, params: FitBoxesParams) -> None:
    """Boxes measured from the points: widened to hold them, the axes a view sees whole set from them, the root's
    faced faces put on them."""
    T, S, pri, p = state.cam_from_part, state.size_m, state.priors, params
    pts, labels, sym = state.points, state.seg_labels, state.symmetry
    near = dict(min_points=p.min_points, connect_factor=p.connect_factor, confidence=state.confidence)
    if p.grow:
        T, S, _ = grow_to_points(
            T, S, pts, labels, sym, p.grow_quantile, p.grow_thin_ratio, min_confidence=p.sure_confidence, **near
        )
    if p.fit and pri.seen_extent is not None and state.num_input >= p.fit_min_input:
        unsure = np.flatnonzero(state.score < p.fit_below) if state.calibration is not None and state.score is not None else None
        ratios = dict(
            min_ratio=p.fit_min_ratio, max_ratio=p.fit_max_ratio, min_seen=p.fit_min_seen, sure_confidence=p.sure_confidence
        )
        T, S, state.fitted = fit_seen_extents(
            T, S, pts, labels, pri.seen_extent, sym, unsure, min_confidence=p.plausible_confidence, **ratios, **near
        )
        if state.fitted.any():
            T, S, _ = carry_child_sizes(T, S, state.fitted, pri, p.carry_max_spread, p.carry_min_change)
    if (
        p.anchor
        and pri.faced_gap is not None
        and state.num_input >= p.anchor_min_input
        and (state.noise_m is None or state.noise_m() <= p.anchor_max_noise_m)
    ):  # the root only: a child's points end at a seam
        faces = dict(min_confidence=p.plausible_confidence, max_spread=p.anchor_max_spread)
        T, _ = anchor_faced_faces(T, S, pts, labels, pri.faced_gap, (0,), state.fitted, **faces, **near)
    state.cam_from_part, state.size_m = T, S
