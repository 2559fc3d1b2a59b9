"""Boxes grown to hold the points segmented as their part.

The voted size of a part (``exp(gamma) x`` the category's mean size, :mod:`ucope.voting.part`) is pulled
towards the sizes and aspect ratios of the training objects. An object of another shape family (a
countertop dishwasher wider than it is tall, a cabinet shallower than any the generator made) then gets
a box narrower than the points that the network itself segmented as that part: the box cannot be right,
since a part's amodal box holds all of its surface. :func:`grow_to_points` widens every box, axis by
axis in the part's voted frame, until it holds the part's points (a robust range: the ``quantile`` and
``1 - quantile`` quantiles, so that a few mislabelled points do not stretch it), and moves its centre to
the middle of the widened range. Only points joined to the box count: the part's points that lie in
one connected piece (a chain of steps no longer than ``connect_factor`` times the median distance from
a part point to its nearest neighbour) with a point inside the voted box. Outliers, and a neighbour or
background patch that the segmentation gave to the part across a gap, stay out (measured on the robustness
benchmark's views: without this test 10 % outliers took the dishwasher from 67 to 37 % success and 25 %
mask bleed from 63 to 30 %), and so do points the segmentation may take for background (``confidence``
below ``min_confidence``: outliers next to a part's surface). It never shrinks a box (the points of a
partial view need not reach the far faces) and never touches:

* a thin axis (an extent below ``thin_ratio`` times the part's median extent: the thickness of a lid, a
  door or a blade), which sensor noise alone would widen;
* a part symmetric about y (its x and z axes are arbitrary);
* a part with fewer than ``min_points`` points.

Measured on the OOD split (docs/results.md) and the robustness benchmark (docs/robustness.md); the
estimator applies it after the part scores are computed, where a model's ``grow_boxes`` default says so.

Growth never shrinks. :func:`fit_seen_extents` sets the axes that views with this face pattern saw whole in the
training (``PartPrior.seen_extent``) from the points, larger or smaller than voted, and
:func:`anchor_faced_faces` puts the faces the camera faces where the points are (``PartPrior.faced_gap``); both
leave parts another part's box hides alone (:func:`ucope.geometry.boxes.occluded_fraction`).

Frames and units: points and poses in the camera frame, metres; ``cam_from_part`` ``(K, 4, 4)`` as in
docs/conventions.md (the box is centred on the part frame's origin, aligned with its axes).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..geometry.boxes import SEEN_PATTERNS, occluded_fraction, seen_pattern
from ..priors import SEEN_MAX_OCCLUDED, SEEN_QUANTILE

__all__ = [
    "grow_to_points",
    "joined_to_box",
    "connected_pieces",
    "GROW_QUANTILE",
    "GROW_THIN_RATIO",
    "GROW_MIN_POINTS",
    "GROW_CONNECT_FACTOR",
    "GROW_MIN_CONFIDENCE",
    "fit_seen_extents",
    "FIT_MIN_RATIO",
    "FIT_MAX_RATIO",
    "FIT_MIN_SEEN",
    "FIT_MIN_CONFIDENCE",
    "anchor_faced_faces",
    "ANCHOR_MAX_SPREAD",
]

GROW_QUANTILE = 0.01
"""Lower quantile of a part's points along each box axis that the grown box holds (and ``1 -`` it):
1 % measured best against 2 % and 5 % on the dishwasher's and drawer's OOD views (docs/results.md)."""

GROW_THIN_RATIO = 0.25
"""An axis whose voted extent is below this times the part's median extent is thin and never grown."""

GROW_MIN_POINTS = 30
"""A part with fewer points than this keeps its voted box."""

GROW_MIN_CONFIDENCE = 0.9
"""Points whose confidence is below this do not count. The estimator passes the probability that a point is
the object, not the background (models with a background class). On the dishwasher (shipped model, 40
benchmark views, 100 OOD views), 10 % / 20 % outliers and OOD success: every point counted 60 / 52 / 46 %;
this 65 / 62 / 46 %; without growing 70 / 65 / 23 %. The largest class probability instead (which also doubts
a point between two look-alike parts) at 0.8 / 0.9 / 0.97: 62 / 60 / 44, 68 / 65 / 39, 70 / 65 / 28 %, and it
took the drawer's OOD gain from 6 -> 16 % to 6 -> 10 %."""

GROW_CONNECT_FACTOR = 8.0
"""Longest step between joined points, in median nearest-neighbour distances of the part's points: 8 kept
the dishwasher's OOD gain (23 -> 46 % against 47 % with every point) and its outlier and bleed figures
(67 and 60 % against 67 and 63 % without growing, 30 benchmark views); 3 lost most of the gain (31 %)."""


def _checked(cam_from_part, size_m, points, labels) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(T, S, points, labels)`` as float64 copies / arrays after the checks every function here shares:
    ``(K, 4, 4)`` poses, ``(K, 3)`` positive sizes, ``(P, 3)`` points, ``(P,)`` integer labels, all finite."""
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.array(size_m, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    lab = np.asarray(labels)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"cam_from_part must have shape (K, 4, 4), got {T.shape}")
    K = len(T)
    if S.shape != (K, 3):
        raise InputError(f"size_m must have shape ({K}, 3) for {K} parts, got {S.shape}")
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (P, 3), got {pts.shape}")
    if lab.shape != (len(pts),) or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be {len(pts)} integers (one per point), got {lab.dtype} of shape {lab.shape}")
    if not (np.isfinite(T).all() and np.isfinite(S).all() and np.isfinite(pts).all()):
        raise InputError("cam_from_part, size_m and points must be finite")
    if (S <= 0).any():
        raise InputError(f"size_m must be positive, got {S.tolist()}")
    return T, S, pts, lab


def _part_mask(parts, K: int) -> np.ndarray:
    """``(K,)`` bool of the part indices ``parts`` (``None``: all), or :class:`InputError` on one outside ``[0, K)``."""
    if parts is None:
        return np.ones(K, dtype=bool)
    idx = np.asarray(list(parts), dtype=np.int64).reshape(-1)
    if ((idx < 0) | (idx >= K)).any():
        raise InputError(f"parts must name parts in [0, {K}), got {idx.tolist()}")
    mask = np.zeros(K, dtype=bool)
    mask[idx] = True
    return mask


def _checked_confidence(confidence, n: int) -> np.ndarray:
    """``(n,)`` float64 confidences, or :class:`InputError` naming the wrong shape or a non-finite value."""
    conf = np.asarray(confidence, dtype=np.float64)
    if conf.shape != (n,) or not np.isfinite(conf).all():
        raise InputError(f"confidence must be {n} finite values (one per point), got shape {conf.shape}")
    return conf


def connected_pieces(points: np.ndarray, factor: float) -> np.ndarray:
    """``(P,)`` int: the connected piece of every point of ``points`` ``(P, 3)``; two points are joined when
    they are at most ``factor`` times the median nearest-neighbour distance apart (components of that radius
    graph, :mod:`scipy.sparse.csgraph`). Fewer than two points: each its own piece."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(points)
    if n < 2:
        return np.arange(n)
    tree = cKDTree(points)
    nn = tree.query(points, k=2)[0][:, 1]
    radius = factor * float(np.median(nn))
    if radius <= 0.0:  # more than half of the points are duplicates: join only equal points
        radius = float(np.finfo(np.float64).eps)
    pairs = tree.query_pairs(radius, output_type="ndarray")  # the edges alone: 1.8x faster than a distance matrix
    graph = coo_matrix((np.ones(len(pairs), np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def joined_to_box(local: np.ndarray, half: np.ndarray, factor: float) -> np.ndarray:
    """``(P,)`` bool: which points ``local`` ``(P, 3)`` (a part's frame) lie in a connected piece
    (:func:`connected_pieces`) with a point inside the box ``[-half, half]``."""
    piece = connected_pieces(local, factor)
    inside = np.all(np.abs(local) <= half, axis=1)
    return np.isin(piece, np.unique(piece[inside]))


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
