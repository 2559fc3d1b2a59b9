"""Box extents from the points a part shows.

The voted size of a part (``exp(gamma)`` times the category's mean size) is pulled towards the training
objects' proportions. A part's amodal box holds all of its surface, so:

* :func:`grow_to_points` widens each box, axis by axis in the part's voted frame, until it holds the part's
  points (a robust range: the ``quantile`` and ``1 - quantile`` quantiles), and moves its centre to the middle
  of that range. Only points joined to the box count (one connected piece, steps no longer than
  ``connect_factor`` times the median nearest-neighbour distance, with a point inside the voted box) and only
  those the segmentation is sure are not background (``confidence >= min_confidence``). It never shrinks a
  box and never touches a thin axis (below ``thin_ratio`` of the part's median extent), a part symmetric about
  y, or a part with fewer than ``min_points`` points.
* :func:`fit_seen_extents` sets the axes that views with this face pattern saw whole in training
  (``PartPrior.seen_extent``) from the points, larger or smaller than voted.
* :func:`anchor_faced_faces` moves a box so that the faces the camera faces sit where the points put them
  (``PartPrior.faced_gap``).
* :func:`carry_child_sizes` gives a child the extents its measured parent says it has, where their ratio
  never varied over the training views.

Parts another part's box hides are left alone (:func:`ucope.geometry.boxes.occluded_fraction`). Frames and
units: camera frame, metres; ``cam_from_part`` ``(K, 4, 4)`` as in docs/conventions.md (each box centred on
its part frame's origin, aligned with its axes).
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
    GROW_THIN_RATIO,
    _checked,
    _checked_confidence,
    _hinged_centre,
    _part_mask,
    joined_to_box,
)


def grow_to_points(
    cam_from_part,
    size_m,
    points,
    labels,
    symmetry: Sequence[str] | None = None,
    quantile: float = GROW_QUANTILE,
    thin_ratio: float = GROW_THIN_RATIO,
    min_points: int = GROW_MIN_POINTS,
    connect_factor: float | None = GROW_CONNECT_FACTOR,
    confidence=None,
    min_confidence: float = GROW_MIN_CONFIDENCE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every part's box widened to hold the robust range of the points labelled as it (module docstring).

    Args:
        cam_from_part: ``(K, 4, 4)`` the parts' voted poses (camera frame, metres).
        size_m: ``(K, 3)`` their box extents along the part's x, y, z (metres, > 0).
        points: ``(P, 3)`` the cloud the labels belong to (camera frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` (-1, the background
            class ``K``) belong to no part.
        symmetry: ``K`` part symmetries (``"none"``, ``"y"``...); parts other than ``"none"`` are kept.
            ``None``: every part ``"none"``.
        quantile: the robust range along each axis is ``[q, 1 - q]`` of the part's coordinates, ``q`` in
            ``[0, 0.5)``.
        thin_ratio: axes whose extent is below ``thin_ratio`` times the part's median extent are kept.
        min_points: parts with fewer points (or fewer joined to their box) keep their box.
        connect_factor: only points joined to the box count (:func:`joined_to_box` with this factor);
            ``None``: every point of the part.
        confidence: ``(P,)`` how sure the segmentation is that each point belongs to the object (the
            estimator: one minus its background probability); points below ``min_confidence`` do not
            count. ``None``: every point counts.

    Returns:
        ``(cam_from_part, size_m, grown)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays (rotations
        unchanged, translations moved by the centre shift) and ``(K,)`` bool, which parts changed.

    Raises:
        InputError: shapes that do not match, a non-finite pose, size or point, a non-positive size,
            ``quantile`` outside ``[0, 0.5)``, a ``connect_factor`` that is not positive.
    """
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    K = len(T)
    if not 0.0 <= quantile < 0.5:
        raise InputError(f"quantile must lie in [0, 0.5), got {quantile!r}")
    if connect_factor is not None and not connect_factor > 0:
        raise InputError(f"connect_factor must be positive or None, got {connect_factor!r}")
    if confidence is not None:
        conf = _checked_confidence(confidence, len(pts))
        lab = np.where(conf >= min_confidence, lab, -1)
    sym = ["none"] * K if symmetry is None else list(symmetry)
    if len(sym) != K:
        raise InputError(f"symmetry must name {K} parts, got {len(sym)}")
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


FIT_MIN_RATIO = 0.85
"""An axis is set from its part's points only where at least 90 % of the training views with the same face
pattern saw at least this fraction of its extent (the 10th percentile of the seen ratio,
:attr:`ucope.priors.PartPrior.seen_extent`)."""


FIT_MAX_RATIO = 1.05
"""... and at most 10 % saw more than this fraction (the 90th percentile: sensor noise, a part that reaches past
its box)."""


FIT_MIN_CONFIDENCE = 0.5
"""Points whose confidence (the probability that they are the object, not the background) is below this do not
count: lower than growth's :data:`GROW_MIN_CONFIDENCE`, since leaving a part's real points out shrinks a fitted
box where it only keeps a grown one. The bottle's OOD views (shipped model, 100 views; the rule's first version,
the plausible points alone): 93 % success without fitting, 81 % fitting with 0.9, 96 % with 0.5. The points at
:data:`GROW_MIN_CONFIDENCE` or above bound the extent from below (``sure_confidence``)."""


FIT_MIN_SEEN = 0.5
"""An axis whose fitted extent would fall below this times its voted extent keeps the voted one: the points
span far less of it than views like this one do (a segmentation that gave much of the part to a neighbour)."""


def fit_seen_extents(
    cam_from_part,
    size_m,
    points,
    labels,
    seen_extent,
    symmetry: Sequence[str] | None = None,
    parts: Sequence[int] | None = None,
    quantile: float = SEEN_QUANTILE,
    min_points: int = GROW_MIN_POINTS,
    connect_factor: float | None = GROW_CONNECT_FACTOR,
    confidence=None,
    min_confidence: float = FIT_MIN_CONFIDENCE,
    sure_confidence: float = GROW_MIN_CONFIDENCE,
    min_ratio: float = FIT_MIN_RATIO,
    max_ratio: float = FIT_MAX_RATIO,
    min_seen: float = FIT_MIN_SEEN,
    max_occluded: float = SEEN_MAX_OCCLUDED,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Box axes that views like this one see whole, set from the points segmented as their part.

    A box seen from outside shows its extent along an axis wherever the camera faces one of the faces across
    that axis and nothing hides them, and the training views measure how reliably: per part, axis and face
    pattern (:func:`ucope.geometry.boxes.seen_pattern`) the percentiles of the seen ratio (the robust range
    of the part's points along the axis over the box's extent, :attr:`ucope.priors.PartPrior.seen_extent`).
    Where this view's pattern (from the voted pose and size) saw at least ``min_ratio`` in 90 % of the
    training views and at most ``max_ratio`` in 90 %, the axis's extent is held between what the points sure to
    be the object span and what the plausible ones span (each robust range, ``quantile`` to ``1 - quantile``,
    over the median ratio): a voted extent outside that interval is set to its nearer end, and the box centre
    moves to the middle of the range that set it. Larger or smaller than voted, then; outliers next to the
    object (doubted by the segmentation) cannot widen a box, nor real points it doubts narrow one. An object
    whose proportions the training never had (a countertop dishwasher half as tall as it is wide) is measured
    rather than pulled to the training sizes.
    Left alone: parts a neighbour's box hides (more than ``max_occluded`` of their faced points,
    :func:`ucope.geometry.boxes.occluded_fraction`), the x and z axes of parts symmetric about y, parts with
    fewer than ``min_points`` points (or joined to their box, :func:`joined_to_box`), and axes whose new
    extent would be below ``min_seen`` times the voted one.

    Args:
        cam_from_part: ``(K, 4, 4)`` the parts' voted poses (camera frame, metres).
        size_m: ``(K, 3)`` their box extents (metres, > 0).
        points: ``(P, 3)`` the cloud the labels belong to (camera frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        seen_extent: ``(K, 3, SEEN_PATTERNS, 3)`` per part, axis and face pattern the 10th, 50th and 90th
            percentiles of the seen ratio, NaN where not measured
            (:attr:`ucope.priors.CategoryPriors.seen_extent`).
        symmetry, min_points, connect_factor: as :func:`grow_to_points`.
        parts: the parts that may be fitted (``None``: all).
        confidence: ``(P,)`` the probability that each point is the object, not the background (``None``:
            every labelled point is sure). Points at ``sure_confidence`` or above are sure, points at
            ``min_confidence`` or above plausible; the others do not count.

    Returns:
        ``(cam_from_part, size_m, fitted)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays (rotations
        unchanged) and ``(K, 3)`` bool, which axes were set.

    Raises:
        InputError: shapes that do not match, non-finite poses, sizes or points, a non-positive size, a
            negative or non-finite table entry, a part index outside ``[0, K)``, ``quantile`` outside
            ``[0, 0.5)``, ratios that are not positive.
    """
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    K = len(T)
    table = np.asarray(seen_extent, dtype=np.float64)
    if table.shape != (K, 3, SEEN_PATTERNS, 3):
        raise InputError(f"seen_extent must have shape ({K}, 3, {SEEN_PATTERNS}, 3), got {table.shape}")
    if np.isinf(table).any() or (table < 0).any():
        raise InputError("seen_extent must hold ratios >= 0 (NaN where not measured)")
    if not 0.0 <= quantile < 0.5:
        raise InputError(f"quantile must lie in [0, 0.5), got {quantile!r}")
    if not (min_ratio > 0 and max_ratio > 0 and min_seen > 0):
        raise InputError(f"min_ratio, max_ratio and min_seen must be positive, got {min_ratio!r}, {max_ratio!r}, {min_seen!r}")
    if connect_factor is not None and not connect_factor > 0:
        raise InputError(f"connect_factor must be positive or None, got {connect_factor!r}")
    sure = lab
    if confidence is not None:
        conf = _checked_confidence(confidence, len(pts))
        sure = np.where(conf >= sure_confidence, lab, -1)
        lab = np.where(conf >= min_confidence, lab, -1)
    sym = ["none"] * K if symmetry is None else list(symmetry)
    if len(sym) != K:
        raise InputError(f"symmetry must name {K} parts, got {len(sym)}")
    stats = table[np.arange(K)[:, None], np.arange(3)[None, :], seen_pattern(T, S)]  # (K, 3, 3) for this view
    with np.errstate(invalid="ignore"):  # NaN (not measured) compares False
        fit = (stats[..., 0] >= min_ratio) & (stats[..., 2] <= max_ratio) & (stats[..., 1] > 0)
    fit[np.array([k for k in range(K) if sym[k] != "none"], dtype=np.int64), 0::2] = False  # x, z of a y-symmetric part
    fit &= _part_mask(parts, K)[:, None]
    fitted = np.zeros((K, 3), dtype=bool)
    if not fit.any():
        return T, S, fitted
    fit &= (occluded_fraction(T, S) <= max_occluded)[:, None]
    for k in np.flatnonzero(fit.any(1)):  # a handful of parts; the point work is vectorised
        R, t = T[k, :3, :3], T[k, :3, 3]
        ranges = []
        for chosen in (sure, lab):  # the sure points (the least extent), the plausible ones (the most)
            sel = chosen == k
            q = (pts[sel] - t) @ R  # the part's points in its voted frame
            if connect_factor is not None and len(q):
                q = q[joined_to_box(q, 0.5 * S[k], connect_factor)]
            ranges.append(np.quantile(q, [quantile, 1.0 - quantile], axis=0) if len(q) >= min_points else None)
        if ranges[1] is None:
            continue
        if ranges[0] is None:
            ranges[0] = ranges[1]
        med = np.where(fit[k], stats[k, :, 1], 1.0)
        least, most = (np.diff(r, axis=0)[0] / med for r in ranges)
        least = np.minimum(least, most)
        new = np.clip(S[k], least, most)
        mid = np.where(S[k] > most, ranges[1].mean(0), np.where(S[k] < least, ranges[0].mean(0), 0.0))
        a = fit[k] & (new >= min_seen * S[k]) & (new != S[k])
        S[k] = np.where(a, new, S[k])
        T[k, :3, 3] = t + R @ np.where(a, mid, 0.0)
        fitted[k] = a
    return T, S, fitted


ANCHOR_MAX_SPREAD = 0.03
"""A faced face is anchored to the points only where the training views' gap between it and the points varied
by at most this (the 10th to 90th percentile, in part box diagonals)."""


def anchor_faced_faces(
    cam_from_part,
    size_m,
    points,
    labels,
    faced_gap,
    parts: Sequence[int] | None = None,
    keep=None,
    quantile: float = SEEN_QUANTILE,
    min_points: int = GROW_MIN_POINTS,
    connect_factor: float | None = GROW_CONNECT_FACTOR,
    confidence=None,
    min_confidence: float = FIT_MIN_CONFIDENCE,
    max_spread: float = ANCHOR_MAX_SPREAD,
    max_occluded: float = SEEN_MAX_OCCLUDED,
) -> tuple[np.ndarray, np.ndarray]:
    """Box centres moved so that the faces the camera faces sit where the part's points put them.

    A part's voted centre can sit off along an axis it is not seen whole along (the depth of a spectacle frame
    seen from behind: its points show only its back), while the face turned to the camera is in plain view.
    Along every axis where the camera lies beyond a face of the voted box (its box-frame coordinate beyond half
    the extent), and where the training views' gap between that face and the points (``faced_gap``:
    :attr:`ucope.priors.PartPrior.faced_gap`) varied by at most ``max_spread`` part diagonals, the face is put
    at the points' extreme towards the camera (their ``1 - quantile`` quantile) plus the median gap, and the
    centre half the voted extent behind it. Sizes and rotations are kept.
    Left alone: parts not in ``parts``, axes marked in ``keep``, parts a neighbour's box hides (more than
    ``max_occluded``, :func:`ucope.geometry.boxes.occluded_fraction`), parts with fewer than ``min_points``
    points (or joined to their box, :func:`joined_to_box`).

    Args:
        cam_from_part: ``(K, 4, 4)`` the parts' poses (camera frame, metres).
        size_m: ``(K, 3)`` their box extents (metres, > 0).
        points: ``(P, 3)`` the cloud the labels belong to (camera frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        faced_gap: ``(K, 3, 2, 3)`` per part, axis and faced side (-, +) the 10th, 50th and 90th percentiles
            of the gap, NaN where not measured (:attr:`ucope.priors.CategoryPriors.faced_gap`).
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
    table = np.asarray(faced_gap, dtype=np.float64)
    if table.shape != (K, 3, 2, 3) or np.isinf(table).any():
        raise InputError(f"faced_gap must have shape ({K}, 3, 2, 3) with finite entries (NaN: not measured), got {table.shape}")
    movable = _part_mask(parts, K)
    hold = np.zeros((K, 3), dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    if hold.shape != (K, 3):
        raise InputError(f"keep must have shape ({K}, 3), got {hold.shape}")
    if not 0.0 <= quantile < 0.5:
        raise InputError(f"quantile must lie in [0, 0.5), got {quantile!r}")
    if not max_spread >= 0:
        raise InputError(f"max_spread must be >= 0, got {max_spread!r}")
    if connect_factor is not None and not connect_factor > 0:
        raise InputError(f"connect_factor must be positive or None, got {connect_factor!r}")
    if confidence is not None:
        conf = _checked_confidence(confidence, len(pts))
        lab = np.where(conf >= min_confidence, lab, -1)
    cam = -np.einsum("kji,kj->ki", T[:, :3, :3], T[:, :3, 3])  # the camera in each part's frame
    plus = (cam > 0).astype(np.int64)
    stats = table[np.arange(K)[:, None], np.arange(3)[None, :], plus]  # (K, 3, 3): the faced side's gaps
    with np.errstate(invalid="ignore"):  # NaN (not measured) compares False
        move = (np.abs(cam) > 0.5 * S) & (stats[..., 2] - stats[..., 0] <= max_spread) & movable[:, None] & ~hold
    anchored = np.zeros((K, 3), dtype=bool)
    if not move.any():
        return T, anchored
    move &= (occluded_fraction(T, S) <= max_occluded)[:, None]
    for k in np.flatnonzero(move.any(1)):  # a handful of parts; the point work is vectorised
        sel = lab == k
        if np.count_nonzero(sel) < min_points:
            continue
        R, t = T[k, :3, :3], T[k, :3, 3]
        q = (pts[sel] - t) @ R
        if connect_factor is not None:
            q = q[joined_to_box(q, 0.5 * S[k], connect_factor)]
            if len(q) < min_points:
                continue
        lo, hi = np.quantile(q, [quantile, 1.0 - quantile], axis=0)
        sign = np.where(plus[k] == 1, 1.0, -1.0)
        face = np.where(plus[k] == 1, hi, lo) + sign * stats[k, :, 1] * np.linalg.norm(S[k])
        shift = np.where(move[k], face - sign * 0.5 * S[k], 0.0)
        T[k, :3, 3] = t + R @ shift
        anchored[k] = move[k]
    return T, anchored


SIZE_MAX_SPREAD = 0.03
"""A child's extent follows its parent's only along axes where the training views' size ratio varied by at most
this (standard deviation over the mean, ``JointPrior.child_size_spread``)."""


SIZE_MIN_CHANGE = 0.15
"""... and only where the parent's measured extent puts the child's more than this fraction away from its voted
one (a child voted plausibly keeps its own extent). The shipped dishwasher (fitted extents on), 200 test and 100
OOD views: 81 / 60 % success at 0, 82.5 / 61 % at 0.15, 82 / 57 % without carrying."""


def _checked_sizes(
    cam_from_part, size_m, measured, priors: CategoryPriors, max_spread: float = 0.0, min_change: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(T, S, measured)`` as float64 / bool copies after the checks the size carries and the stack share:
    ``(K, 4, 4)`` finite poses, ``(K, 3)`` finite positive sizes and ``(K, 3)`` flags (``None``: none measured)
    for the priors' ``K`` parts, ``max_spread`` and ``min_change`` ``>= 0``."""
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.array(size_m, dtype=np.float64)
    K = priors.num_parts
    done = np.zeros((K, 3), dtype=bool) if measured is None else np.array(measured, dtype=bool)
    if T.shape != (K, 4, 4) or S.shape != (K, 3):
        raise InputError(f"cam_from_part and size_m must have shapes ({K}, 4, 4) and ({K}, 3), got {T.shape} and {S.shape}")
    if done.shape != (K, 3):
        raise InputError(f"measured must have shape ({K}, 3), got {done.shape}")
    if not (np.isfinite(T).all() and np.isfinite(S).all()) or (S <= 0).any():
        raise InputError("cam_from_part must be finite and size_m finite and positive")
    if not (max_spread >= 0 and min_change >= 0):
        raise InputError(f"max_spread and min_change must be >= 0, got {max_spread!r}, {min_change!r}")
    return T, S, done


def carry_child_sizes(
    cam_from_part,
    size_m,
    measured,
    priors: CategoryPriors,
    max_spread: float = SIZE_MAX_SPREAD,
    min_change: float = SIZE_MIN_CHANGE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Children's extents carried from their parents' measured ones through the joints.

    A dishwasher door is as wide as its body and 0.86 of its height in every training view; where the body's
    extents were measured from its points (``measured``: :func:`ucope.stages.extents.fit_seen_extents`) and the door
    was hidden from fitting, the door's voted extents can stay those of the training doors. For each joint and
    each axis whose size ratio child / parent varied by at most ``max_spread`` (relative, ``JointPrior.
    child_size_spread``), measured on the parent and not on the child, the child's extent becomes the ratio
    (``child_size_ratio``) times the parent's where that differs from the voted one by more than ``min_change``
    (relative). A revolute child whose extents changed is then placed through the joint from its parent: its
    centre where the joint axis passes in both unit boxes (``pivot_in_parent`` / ``pivot_in_child``), its
    rotation kept. Parents are handled before children (the joints' order), so a carried child carries on.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        measured: ``(K, 3)`` bool, which extents were measured from the points.
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


@dataclass(frozen=True)
class FitBoxesParams:
    """Attributes:
    grow: widen boxes to hold their points (:func:`grow_to_points`).
    fit: set the axes views like this one see whole from the points (:func:`fit_seen_extents`), then carry a
        child's extents from its measured parent (:func:`carry_child_sizes`); only parts whose calibrated score
        is below ``fit_below`` (every part without a calibration), only clouds of ``fit_min_input`` points or more.
    anchor: put the root part's faces that the camera faces where its points are (:func:`anchor_faced_faces`),
        only for clouds of ``anchor_min_input`` points or more whose surface noise is at most ``anchor_max_noise_m``.
    """

    grow: bool = True
    fit: bool = True
    anchor: bool = True
    fit_below: float = 0.9
    fit_min_input: int = 1000
    anchor_min_input: int = 600
    anchor_max_noise_m: float = 1.5e-3

    def __post_init__(self) -> None:
        if not (0.0 <= self.fit_below <= 1.0 and self.anchor_max_noise_m >= 0.0):
            raise InputError(
                f"fit_below must be in [0, 1] and anchor_max_noise_m >= 0, got {self.fit_below}, {self.anchor_max_noise_m}"
            )


@stage(
    "fit_boxes",
    kind="learned-prior",
    params=FitBoxesParams,
    reads=("parts.seen_extent", "parts.faced_gap", "joints.child_size_ratio"),
)
def _fit_boxes(state: PoseState, params: FitBoxesParams) -> None:
    """Boxes measured from the points: widened to hold them, the axes a view sees whole set from them, the root's
    faced faces put on them."""
    T, S, pri = state.cam_from_part, state.size_m, state.priors
    pts, labels, conf = state.points, state.seg_labels, state.confidence
    if params.grow:
        T, S, _ = grow_to_points(T, S, pts, labels, state.symmetry, confidence=conf)
    if params.fit and pri.seen_extent is not None and state.num_input >= params.fit_min_input:
        unsure = (
            np.flatnonzero(state.score < params.fit_below) if state.calibration is not None and state.score is not None else None
        )
        T, S, state.fitted = fit_seen_extents(T, S, pts, labels, pri.seen_extent, state.symmetry, parts=unsure, confidence=conf)
        if state.fitted.any():
            T, S, _ = carry_child_sizes(T, S, state.fitted, pri)
    if (
        params.anchor
        and pri.faced_gap is not None
        and state.num_input >= params.anchor_min_input
        and (state.noise_m is None or state.noise_m() <= params.anchor_max_noise_m)
    ):  # the root only: a child's points end at a seam
        T, _ = anchor_faced_faces(T, S, pts, labels, pri.faced_gap, parts=(0,), keep=state.fitted, confidence=conf)
    state.cam_from_part, state.size_m = T, S
