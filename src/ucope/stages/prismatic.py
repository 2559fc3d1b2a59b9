"""Prismatic children (drawers) placed in their parent (a cabinet): the ``prismatic`` stage.

* :func:`hold_prismatic_children` widens the parent's box across its children's slides until it holds their
  points as well as its own;
* :func:`carry_prismatic_depths` gives each child the extent along its slide that the parent's box and the
  training views' size ratio say it has (its leading face kept);
* :func:`place_prismatic_children` puts each child where the training views always held it across the slide;
* :func:`slide_to_fronts` slides each child along its slide until its leading face meets its points;
* :func:`stack_hidden_children` puts a child of a stack that shows too few points against its
  nearest seen sibling, or under the parent's face.

Each acts only where the model's priors measured what it needs. Camera frame (or any other), metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .support import (
    FRONT_MIN_CONFIDENCE,
    GROW_CONNECT_FACTOR,
    GROW_MIN_CONFIDENCE,
    GROW_MIN_POINTS,
    GROW_QUANTILE,
    _checked_cloud,
    _checked_sizes,
    _confident,
    connected_pieces,
    joined_to_box,
)


@dataclass(frozen=True)
class PrismaticParams:
    """Attributes:
    hold_quantile / hold_min_points / hold_min_confidence: the parent's box holds the ``hold_quantile`` to
        ``1 - hold_quantile`` range of its and its children's points at least ``hold_min_confidence`` likely to be
        the object, where there are ``hold_min_points`` of them or more (:func:`hold_prismatic_children`).
    depth_max_spread / depth_min_change: a child's extent along its slide follows its parent's where their ratio
        varied by at most ``depth_max_spread`` over the training views (standard deviation over the mean) and where
        that changes it by more than ``depth_min_change`` (relative; :func:`carry_prismatic_depths`).
    place_max_spread: a child is put at its training place along the parent axes across its slide where that
        place varied by less than this (standard deviation, parent box diagonals; :func:`place_prismatic_children`).
    front_quantile / front_min_points / front_min_shift: a child with ``front_min_points`` points or more slides
        until its leading face meets the ``1 - front_quantile`` quantile of its points along the slide, where they
        stand more than ``front_min_shift`` of its box diagonal apart (:func:`slide_to_fronts`).
    stack_min_points / stack_max_spread / stack_size_from_parent: a child of a stack with fewer points than
        ``stack_min_points`` is placed against its siblings, in stacks whose gaps varied by at most
        ``stack_max_spread`` (10th to 90th percentile, parent extents), sized from its parent first
        (:func:`stack_hidden_children`).
    min_confidence: points less likely to be the object do not count for the slide and the stack.
    connect_factor: the longest step between joined points (median nearest-neighbour distances).
    """

    hold_quantile: float = GROW_QUANTILE
    hold_min_points: int = GROW_MIN_POINTS
    hold_min_confidence: float = GROW_MIN_CONFIDENCE
    depth_max_spread: float = 0.1
    depth_min_change: float = 0.1
    place_max_spread: float = 0.01
    front_quantile: float = 0.02
    front_min_points: int = 10
    front_min_shift: float = 0.1
    stack_min_points: int = 10
    stack_max_spread: float = 0.1
    stack_size_from_parent: bool = True
    min_confidence: float = FRONT_MIN_CONFIDENCE
    connect_factor: float = GROW_CONNECT_FACTOR


_P = PrismaticParams()


def place_prismatic_children(
    cam_from_part: np.ndarray, size_m: np.ndarray, priors: CategoryPriors, max_spread: float = _P.place_max_spread
) -> tuple[np.ndarray, np.ndarray]:
    """Put each prismatic child where the training views always had it across its joint's axis.

    For each prismatic joint (parents first) and each parent axis ``e_i`` across the joint's axis
    (``|e_i . a| < 1e-6``) whose placement spread (``JointPrior.child_in_parent_spread``) is below ``max_spread``,
    the child's centre is set, along ``R_p e_i``, to the training mean ``child_in_parent[i] x |size_p|``; the other
    coordinates, the rotation and the size are kept, and so are the joint states (measured along the axis). A moved
    child carries nothing along. Joints without a measured spread are left alone.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres); size_m: ``(K, 3)`` box extents.
        priors: the category's priors.
        max_spread: the largest spread (standard deviation in parent box diagonals) that is placed.

    Returns:
        ``(cam_from_part, moved)``: a copy with the children moved, and ``(J,)`` the distance (metres) each
        joint's child moved.

    Raises:
        InputError: shapes that do not match the priors' parts, or a negative ``max_spread``.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    K = len(priors.parts)
    if T.shape != (K, 4, 4) or S.shape != (K, 3):
        raise InputError(f"cam_from_part must be ({K}, 4, 4) and size_m ({K}, 3), got {T.shape} and {S.shape}")
    if not max_spread >= 0.0:
        raise InputError(f"max_spread must be >= 0, got {max_spread!r}")
    moved = np.zeros(len(priors.joints))
    for j, jp in enumerate(priors.joints):
        if jp.type != JointType.PRISMATIC or jp.child_in_parent_spread is None:
            continue
        fixed = (np.abs(jp.axis) < 1e-6) & (np.asarray(jp.child_in_parent_spread) < max_spread)
        if not fixed.any():
            continue
        R, t = T[jp.parent, :3, :3], T[jp.parent, :3, 3]
        local = R.T @ (T[jp.child, :3, 3] - t)
        target = np.where(fixed, np.asarray(jp.child_in_parent) * np.linalg.norm(S[jp.parent]), local)
        T[jp.child, :3, 3] = t + R @ target
        moved[j] = float(np.linalg.norm(target - local))
    return T, moved


def slide_to_fronts(
    cam_from_part,
    size_m,
    points,
    labels,
    priors: CategoryPriors,
    quantile: float = _P.front_quantile,
    min_points: int = _P.front_min_points,
    min_shift: float = _P.front_min_shift,
    connect_factor: float = _P.connect_factor,
    confidence=None,
    min_confidence: float = _P.min_confidence,
) -> tuple[np.ndarray, np.ndarray]:
    """Slide each prismatic child along its joint's axis until its leading face meets its points.

    Nothing of a drawer lies beyond its front along the direction it is pulled out (``+a``, the joint's axis), and
    whatever part of it the camera sees reaches to that front. For each prismatic joint whose child has at least
    ``min_points`` (confident) points in its largest connected piece (:func:`ucope.stages.support.connected_pieces`;
    stray points out in front of it do not count), the child's box face along ``a`` is compared with the
    ``1 - quantile`` quantile of those points along ``a``; where they lie more than ``min_shift`` of the child's box
    diagonal apart, the child moves along ``a`` until they meet. Rotation and size are kept; the joint state changes
    by the move (the caller reads the states off the boxes). A moved child carries nothing along.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (metres); size_m: ``(K, 3)`` box extents (metres, > 0).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (joint tree, types, canonical axes in the parent frame).
        quantile: in ``[0, 0.5)``; min_points: children with fewer (confident) points stay.
        min_shift: ``>= 0``, in the child's box diagonals; connect_factor: ``> 0``, as above.
        confidence: optional ``(P,)`` per point, the probability that it is the object; points below
            ``min_confidence`` do not count.

    Returns:
        ``(cam_from_part, moved_m)``: a ``(K, 4, 4)`` float64 copy, and ``(J,)`` the signed distance each
        joint's child moved along its axis (metres; 0 where it stayed).

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes or points, a non-positive
            size, ``quantile`` outside ``[0, 0.5)``, a negative ``min_shift``, a ``connect_factor`` that is not
            positive, or confidences that are not one finite value per point.
    """
    if not min_shift >= 0.0:
        raise InputError(f"min_shift must be >= 0, got {min_shift!r}")
    T, S, pts, lab = _checked_cloud(
        cam_from_part, size_m, points, labels, priors, quantile, connect_factor, confidence, min_confidence
    )
    moved = np.zeros(len(priors.joints))
    for j, jp in enumerate(priors.joints):  # a handful of joints; the point work is vectorised
        if jp.type != JointType.PRISMATIC:
            continue
        c = jp.child
        own = pts[lab == c]
        if len(own) < max(int(min_points), 1):
            continue
        pieces = connected_pieces(own, connect_factor)
        own = own[pieces == np.bincount(pieces).argmax()]  # the largest piece
        if len(own) < max(int(min_points), 1):
            continue
        R, t = T[c, :3, :3], T[c, :3, 3]
        a = R.T @ (T[jp.parent, :3, :3] @ jp.axis)  # the slide direction in the child's box frame
        a /= np.linalg.norm(a)
        reach = 0.5 * float(np.abs(a) @ S[c])  # the box's half extent along a
        shift = float(np.quantile((own - t) @ R @ a, 1.0 - quantile)) - reach
        if abs(shift) <= min_shift * float(np.linalg.norm(S[c])):
            continue
        moved[j] = shift
        T[c, :3, 3] = t + shift * (R @ a)
    return T, moved


def hold_prismatic_children(
    cam_from_part,
    size_m,
    points,
    labels,
    priors: CategoryPriors,
    confidence=None,
    quantile: float = _P.hold_quantile,
    min_points: int = _P.hold_min_points,
    connect_factor: float = _P.connect_factor,
    min_confidence: float = _P.hold_min_confidence,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Widen a parent's box across its prismatic children's slides until it holds their points as well as its own.

    A drawer stays inside its cabinet across its slide (every training drawer was at most as wide and as tall as its
    cabinet: ``JointPrior.child_size_ratio`` at most 1 along those axes), while the segmentation may give the
    drawer fronts points the cabinet's own do not span. For each parent with prismatic children, along each of its
    box axes across every such child's slide where each child's size ratio is at most 1, the box is widened (never
    narrowed) until it holds the ``quantile`` to ``1 - quantile`` range of the points segmented as the parent or one
    of those children (``confidence`` at least ``min_confidence``, joined to the parent's box,
    :func:`ucope.stages.support.joined_to_box`), its centre moved to the middle of the widened range. Rotations and
    the children are left as they are (:func:`place_prismatic_children` puts the children back in their place).

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (metres); size_m: ``(K, 3)`` box extents (metres, > 0).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (joint tree, types, canonical axes, size ratios).
        confidence: optional ``(P,)`` per point, the probability that it is the object.
        quantile: in ``[0, 0.5)``; min_points: parents with fewer such points stay; connect_factor: ``> 0``.

    Returns:
        ``(cam_from_part, size_m, grown)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays and ``(K, 3)`` bool,
        which extents were widened.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes or points, a non-positive size,
            ``quantile`` outside ``[0, 0.5)``, a ``connect_factor`` that is not positive, or confidences that are
            not one finite value per point.
    """
    T, S, pts, lab = _checked_cloud(
        cam_from_part, size_m, points, labels, priors, quantile, connect_factor, confidence, min_confidence
    )
    K = priors.num_parts
    grown = np.zeros((K, 3), dtype=bool)
    for p in range(K):  # a handful of parts; the point work is vectorised
        kids = [jp for jp in priors.joints if jp.parent == p and jp.type == JointType.PRISMATIC]
        if not kids or any(jp.child_size_ratio is None for jp in kids):
            continue
        axes = np.ones(3, dtype=bool)
        for jp in kids:  # across every slide, where no child was ever larger than its parent
            axes &= (np.abs(jp.axis) < 1e-6) & (np.asarray(jp.child_size_ratio) <= 1.0)
        if not axes.any():
            continue
        own = np.isin(lab, [p] + [jp.child for jp in kids])
        if np.count_nonzero(own) < max(int(min_points), 1):
            continue
        R, t = T[p, :3, :3], T[p, :3, 3]
        q = (pts[own] - t) @ R  # the points in the parent's frame
        q = q[joined_to_box(q, 0.5 * S[p], connect_factor)]
        if len(q) < max(int(min_points), 1):
            continue
        lo, hi = np.quantile(q, [quantile, 1.0 - quantile], axis=0)
        lo, hi = np.minimum(lo, -0.5 * S[p]), np.maximum(hi, 0.5 * S[p])
        wider = axes & (hi - lo > S[p] * (1.0 + 1e-9))
        if not wider.any():
            continue
        S[p] = np.where(wider, hi - lo, S[p])
        T[p, :3, 3] = t + R @ np.where(wider, 0.5 * (lo + hi), 0.0)
        grown[p] = wider
    return T, S, grown


def carry_prismatic_depths(
    cam_from_part,
    size_m,
    priors: CategoryPriors,
    measured=None,
    max_spread: float = _P.depth_max_spread,
    min_change: float = _P.depth_min_change,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Give each prismatic child the depth its parent's box says it has, keeping its leading face.

    A drawer's points say where its front is, rarely how deep it reaches into the cabinet, whose box holds that
    depth. For each prismatic joint whose axis lies along one of the parent's box axes, where the child's extent
    along it over the parent's (``JointPrior.child_size_ratio``) varied by at most ``max_spread`` (relative,
    ``child_size_spread``), and unless that extent of the child was ``measured`` from its points, the child's extent
    along the axis becomes the ratio times the parent's, where that differs from the voted one by more than
    ``min_change`` (relative). The child's leading face (along ``+a``, the direction it is pulled out) stays: the
    centre moves by half the change along the axis. Rotations, the other extents and the joint states are kept.
    Parents are handled before children; revolute joints, joints without size ratios and axes across the box axes
    are left alone.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (metres); size_m: ``(K, 3)`` box extents (metres, > 0).
        priors: the category's priors (joint tree, types, canonical axes, size ratios).
        measured: optional ``(K, 3)`` bool, extents measured from the points
            (:func:`ucope.stages.extents.fit_seen_extents`), which stay.
        max_spread, min_change: ``>= 0``, as above.

    Returns:
        ``(cam_from_part, size_m, carried)``: new ``(K, 4, 4)`` and ``(K, 3)`` float64 arrays and ``(J,)`` bool,
        which joints' children changed.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses or sizes, a non-positive size,
            a negative ``max_spread`` or ``min_change``.
    """
    T, S, done = _checked_sizes(cam_from_part, size_m, measured, priors, max_spread, min_change)
    carried = np.zeros(len(priors.joints), dtype=bool)
    for j, jp in enumerate(priors.joints):  # parents before children; a handful of joints
        if jp.type != JointType.PRISMATIC or jp.child_size_ratio is None:
            continue
        i = int(np.argmax(np.abs(jp.axis)))
        if abs(jp.axis[i]) < 1.0 - 1e-6 or jp.child_size_spread[i] > max_spread:
            continue  # an axis across the box axes, or a ratio the training views did not hold
        p, c = jp.parent, jp.child
        new = jp.child_size_ratio[i] * S[p, i]
        if done[c, i] or abs(new / S[c, i] - 1.0) <= min_change:
            continue
        # the leading face stays: the child's axis i is the parent's at state 0 (prismatic: same rotation)
        lead = np.sign(jp.axis[i]) * T[c, :3, i]
        T[c, :3, 3] += 0.5 * (S[c, i] - new) * lead
        S[c, i] = new
        carried[j] = True
    return T, S, carried


def _sized_from_parent(S: np.ndarray, hidden, parent: int, priors: CategoryPriors) -> None:
    """Set (in place) the extents across its slide of each child in ``hidden`` to its size ratio times ``parent``'s
    (``JointPrior.child_size_ratio``, where measured; a prismatic child's axes are its parent's)."""
    for c in hidden:  # a handful of children
        jp = next(jp for jp in priors.joints if jp.child == c)
        if jp.child_size_ratio is not None:
            across = np.abs(np.asarray(jp.axis)) < 1e-6  # the parent's axes across the slide
            S[c] = np.where(across, np.asarray(jp.child_size_ratio) * S[parent], S[c])


def _stacked_places(y: np.ndarray, h: np.ndarray, seen: np.ndarray, st, H: float) -> np.ndarray:
    """``(n,)`` the places along a stack's axis of its children (top first; ``y`` their places, ``h`` their extents
    along it, ``H`` the parent's): seen ones stay, hidden ones chained at the stack's gap below a placed child
    above, or above one below, or (none seen) the first under the parent's face at ``first_gap``."""
    gap = st.gap * H
    new, placed = y.copy(), seen.copy()
    for m in range(len(y)):  # down: from a placed child above, or the first from the parent's face
        if placed[m]:
            continue
        if m > 0 and placed[m - 1]:
            new[m] = new[m - 1] - 0.5 * h[m - 1] - gap - 0.5 * h[m]
            placed[m] = True
        elif m == 0 and not seen.any():
            new[0] = 0.5 * H - st.first_gap * H - 0.5 * h[0]
            placed[0] = True
    for m in range(len(y) - 2, -1, -1):  # up: from a placed child below
        if not placed[m] and placed[m + 1]:
            new[m] = new[m + 1] + 0.5 * h[m + 1] + gap + 0.5 * h[m]
            placed[m] = True
    return new


def stack_hidden_children(
    cam_from_part,
    size_m,
    labels,
    priors: CategoryPriors,
    confidence=None,
    min_points: int = _P.stack_min_points,
    min_confidence: float = _P.min_confidence,
    max_spread: float = _P.stack_max_spread,
    size_from_parent: bool = _P.stack_size_from_parent,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Size the hidden children of a stack from their parent and put them next to a seen one, or under their parent's face.

    The children of a stack (:class:`ucope.priors.StackPrior`: drawers one above the other, in one order, face to
    face in every training view) that show fewer than ``min_points`` (confident) points are hidden. For each stack
    whose gaps varied by at most ``max_spread``, each hidden child is moved along the stack's axis ``e`` (the
    parent's box axis) to lie against its nearest seen sibling above it at the stack's median gap (times the
    parent's extent along ``e``), hidden siblings in between chained the same way; without a seen sibling above,
    against the nearest seen one below; with none seen, the first under the parent's ``+e`` face at ``first_gap``
    and the rest chained below it. A child's extent along ``e`` is its box's (``|R_c^T e| . size_c``). Only the
    coordinate along ``e`` changes. Before it is placed, with ``size_from_parent``, a hidden child's extents across
    its slide become its size ratio to the parent times the parent's (``JointPrior.child_size_ratio``).

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (metres); size_m: ``(K, 3)`` box extents (metres, > 0).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (``CategoryPriors.stacks``; without stacks nothing moves).
        confidence: optional ``(P,)`` per point, the probability that it is the object; points below
            ``min_confidence`` do not count.
        min_points, max_spread (``>= 0``), size_from_parent: as above.

    Returns:
        ``(cam_from_part, size_m, moved_m)``: ``(K, 4, 4)`` and ``(K, 3)`` float64 copies, and ``(K,)`` the signed
        distance each part moved along its stack's axis (metres; 0 for parts that stayed).

    Raises:
        InputError: shapes that do not match the priors, non-finite poses or sizes, a non-positive size,
            labels that are not one integer per point, confidences that are not one finite value per label,
            a negative ``max_spread``.
    """
    K = priors.num_parts
    T, S, _ = _checked_sizes(cam_from_part, size_m, None, priors, max_spread=max_spread)
    lab = np.asarray(labels)
    if lab.ndim != 1 or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be one integer per point, got {lab.dtype} of shape {lab.shape}")
    lab = _confident(lab, confidence, min_confidence)
    counts = np.bincount(lab[(lab >= 0) & (lab < K)], minlength=K)
    moved = np.zeros(K)
    for st in priors.stacks:  # a stack or two; a handful of children each
        if st.first_gap_spread > max_spread or st.gap_spread > max_spread:
            continue
        ch = np.asarray(st.children)
        seen = counts[ch] >= max(int(min_points), 1)
        if seen.all():
            continue
        if size_from_parent:
            _sized_from_parent(S, ch[~seen], st.parent, priors)
        e = T[st.parent, :3, st.axis]
        y = (T[ch, :3, 3] - T[st.parent, :3, 3]) @ e  # (n,) places along e
        h = np.einsum("ni,ni->n", np.abs(np.einsum("nji,j->ni", T[ch, :3, :3], e)), S[ch])  # (n,) extents along e
        new = _stacked_places(y, h, seen, st, float(S[st.parent, st.axis]))
        T[ch, :3, 3] += (new - y)[:, None] * e
        moved[ch] = new - y
    return T, S, moved


@stage(
    "prismatic",
    kind="learned-prior",
    params=PrismaticParams,
    reads=("joints.child_in_parent_spread", "joints.child_size_ratio", "stacks"),
    applies=lambda priors: any(jp.type == JointType.PRISMATIC for jp in priors.joints),
)
def _prismatic(state: PoseState, params: PrismaticParams) -> None:
    """Drawers placed in their cabinet: the cabinet's box holds their points, each drawer as deep as the cabinet
    says, placed across its slide as in training, slid to where its points end, hidden ones stacked against seen
    siblings."""
    T, S, pri, pts, lab, conf = state.cam_from_part, state.size_m, state.priors, state.points, state.part_labels, state.confidence
    p = params
    hold = dict(quantile=p.hold_quantile, min_points=p.hold_min_points, min_confidence=p.hold_min_confidence)
    T, S, _ = hold_prismatic_children(T, S, pts, lab, pri, conf, connect_factor=p.connect_factor, **hold)
    T, S, _ = carry_prismatic_depths(T, S, pri, state.fitted, p.depth_max_spread, p.depth_min_change)
    T, _ = place_prismatic_children(T, S, pri, p.place_max_spread)
    front = dict(quantile=p.front_quantile, min_points=p.front_min_points, min_shift=p.front_min_shift)
    T, _ = slide_to_fronts(
        T, S, pts, lab, pri, connect_factor=p.connect_factor, confidence=conf, min_confidence=p.min_confidence, **front
    )
    if pri.stacks:
        stack = dict(min_points=p.stack_min_points, max_spread=p.stack_max_spread, size_from_parent=p.stack_size_from_parent)
        T, S, _ = stack_hidden_children(T, S, lab, pri, conf, min_confidence=p.min_confidence, **stack)
    state.cam_from_part, state.size_m = T, S
