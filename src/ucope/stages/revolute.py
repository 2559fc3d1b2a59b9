"""Revolute children: the ``turn_children`` and ``seat_parts`` stages.

:func:`turn_thin_children` turns a thin child hinged along an edge (a door, a lid, a temple) about its joint's
axis to the direction its own points take seen along that axis, its face put on them. :func:`seat_weak_parts`
puts the centre of a part that shows few points and stands off its hinge where its joint's axis meets its
well-seen neighbour's box. Camera frame, metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.transforms import rotation_about_axis
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .support import (
    FRONT_MIN_CONFIDENCE,
    GROW_CONNECT_FACTOR,
    _checked_camera,
    _checked_cloud,
    _hinged_centre,
    _median_outside,
    joined_to_box,
    weak_neighbours,
)


@dataclass(frozen=True)
class SeatPartsParams:
    """Attributes:
    weak_share / strong_share: a part is seated on its hinge only where fewer than ``weak_share`` of the object's
        labelled points are its own and at least ``strong_share`` its neighbour's across the joint.
    min_gap: ... and only where its hinge point stands more than this share of its box diagonal from its
        neighbour's (the part came loose from its hinge).
    """

    weak_share: float = 0.125
    strong_share: float = 0.25
    min_gap: float = 0.2


@dataclass(frozen=True)
class TurnChildrenParams:
    """Attributes:
    thin_ratio: a revolute child is thin where one of its two box extents across the joint's axis is at most this
        times each of its other two (a door, a lid, a temple; not a blade that is thin along its hinge).
    min_points: a thin child with fewer confident points joined to its box keeps its pose; join_margin: those points
        lie in a piece joined to the child's box grown by this many of its thicknesses on every side.
    min_elongation: ... and so does one whose points, seen along the joint's axis, do not lie along a line (the
        larger variance of their projection at least this times the smaller); min_cover: or span less than this
        fraction of its long extent along that line.
    min_turn_deg: smaller turns (degrees) are left alone.
    check_tol: a turn is undone where the points' median distance outside the box rises by more than this many of
        the child's thicknesses.
    min_confidence: points less likely to be the object do not count; connect_factor: the longest step between
        joined points (median nearest-neighbour distances).
    """

    thin_ratio: float = 0.5
    min_points: int = 50
    min_elongation: float = 4.0
    min_cover: float = 0.3
    min_turn_deg: float = 2.0
    join_margin: float = 1.0
    check_tol: float = 0.25
    min_confidence: float = FRONT_MIN_CONFIDENCE
    connect_factor: float = GROW_CONNECT_FACTOR


_SEAT = SeatPartsParams()
_TURN = TurnChildrenParams()


def seat_weak_parts(
    cam_from_part,
    size_m,
    joint_pivot,
    labels,
    priors: CategoryPriors,
    weak_share: float = _SEAT.weak_share,
    strong_share: float = _SEAT.strong_share,
    min_gap: float = _SEAT.min_gap,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A part the camera barely sees, its centre put back where its hinge meets its well-seen neighbour's.

    A revolute joint fixes a part's centre from its neighbour's box: the joint's axis passes through one point of each
    part's unit box (``JointPrior.pivot_in_parent`` / ``pivot_in_child``, the training objects' mean, times the
    extents). For each part ``w`` next to a neighbour ``o`` across a revolute joint
    (:func:`ucope.stages.support.weak_neighbours` with ``weak_share`` and ``strong_share``) whose voted centre stands
    more than ``min_gap`` of its box diagonal from the centre that puts its point on its neighbour's, the part takes
    that centre and the joint's pivot becomes that point. Rotations, sizes, joint axes and revolute states are kept.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres); size_m: ``(K, 3)`` box extents (> 0).
        joint_pivot: ``(J, 3)`` the joints' pivots.
        labels: ``(P,)`` integer part of each point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (tree, joint types, pivot places).
        weak_share, strong_share: as above, in ``[0, 1]``; min_gap: as above (>= 0).

    Returns:
        ``(cam_from_part, joint_pivot, seated)``: float64 copies and ``(K,)`` bool, the parts moved.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes or pivots, a size that is not
            positive, labels that are not integers, shares outside ``[0, 1]``, a negative ``min_gap``.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    piv = np.array(joint_pivot, dtype=np.float64)
    lab = np.asarray(labels)
    K, J = priors.num_parts, priors.num_joints
    if T.shape != (K, 4, 4) or S.shape != (K, 3) or piv.shape != (J, 3) or lab.ndim != 1:
        raise InputError(
            f"cam_from_part, size_m, joint_pivot and labels must have shapes ({K}, 4, 4), ({K}, 3), ({J}, 3) and (P,), "
            f"got {T.shape}, {S.shape}, {piv.shape}, {lab.shape}"
        )
    if not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be integers, got {lab.dtype}")
    if not (np.isfinite(T).all() and np.isfinite(S).all() and np.isfinite(piv).all()) or (S <= 0).any():
        raise InputError("cam_from_part and joint_pivot must be finite and size_m finite and positive")
    if not (0.0 <= weak_share <= 1.0 and 0.0 <= strong_share <= 1.0):
        raise InputError(f"weak_share and strong_share must lie in [0, 1], got {weak_share!r}, {strong_share!r}")
    if not min_gap >= 0.0:
        raise InputError(f"min_gap must be >= 0, got {min_gap!r}")
    seated = np.zeros(K, dtype=bool)
    for j, w, o in weak_neighbours(lab, priors, weak_share, strong_share):
        jp = priors.joints[j]
        if jp.pivot_in_parent is None or jp.pivot_in_child is None or seated[w] or seated[o]:
            continue
        centre, foot = _hinged_centre(T[o], S[o], T[w, :3, :3], S[w], jp, w == jp.parent)
        if np.linalg.norm(centre - T[w, :3, 3]) <= min_gap * np.linalg.norm(S[w]):
            continue
        T[w, :3, 3], piv[j] = centre, foot
        seated[w] = True
    return T, piv, seated


def _checked_turn(joint_axis, J: int, camera, thin_ratio, min_points, min_elongation, min_confidence, others):
    """``(axes (J, 3), lengths (J,), camera (3,))`` after :func:`turn_thin_children`'s checks of its axes, camera and
    settings (``others``: ``min_cover, min_turn_deg, join_margin, check_tol``, each ``>= 0``)."""
    u_all = np.asarray(joint_axis, dtype=np.float64)
    if u_all.shape != (J, 3) or not np.isfinite(u_all).all():
        raise InputError(f"joint_axis must be a finite ({J}, 3) array, got shape {u_all.shape}")
    length = np.linalg.norm(u_all, axis=1)
    if np.any(length <= 0.0):
        raise InputError("joint_axis must not hold a zero-length axis")
    cam = _checked_camera(camera)
    if not 0.0 < thin_ratio <= 1.0:
        raise InputError(f"thin_ratio must lie in (0, 1], got {thin_ratio!r}")
    if int(min_points) < 3 or not min_elongation >= 1.0:
        raise InputError(f"min_points must be >= 3 and min_elongation >= 1, got {min_points!r} and {min_elongation!r}")
    if not 0.0 <= min_confidence <= 1.0:
        raise InputError(f"min_confidence must lie in [0, 1], got {min_confidence!r}")
    if not all(x >= 0.0 for x in others):
        raise InputError("min_cover, min_turn_deg, join_margin and check_tol must be >= 0, got " + ", ".join(map(repr, others)))
    return u_all, length, cam


def _slab_axes(size: np.ndarray, axis, thin_ratio: float) -> tuple[int, int] | None:
    """``(thin, long)``: the box axes (of extents ``size``) across the canonical joint ``axis``, thinner first, where
    ``axis`` is a box axis and the box a slab whose plane holds it (its thin extent at most ``thin_ratio`` times each
    of its other two); ``None`` otherwise."""
    hinge = np.abs(np.asarray(axis))
    if not np.isclose(hinge.max(), 1.0, atol=1e-6):
        return None
    along = int(np.argmax(hinge))
    thin, long_ = sorted((i for i in range(3) if i != along), key=lambda i: size[i])
    return None if size[thin] > thin_ratio * min(size[long_], size[along]) else (thin, long_)


def _line_turn(own: np.ndarray, u: np.ndarray, long_axis: np.ndarray, long_extent: float, min_elongation, min_cover):
    """``(angle, mean)``: the signed angle (radians about the unit ``u``) from ``long_axis`` (a box axis, camera
    frame) to the line the points ``own`` ``(N, 3)`` take seen along ``u``, of the two senses the nearer, and their
    mean; ``None`` where they do not lie along a line (variances within ``min_elongation``) or span less than
    ``min_cover`` of ``long_extent`` along it."""
    mean = own.mean(0)
    flat = own - mean
    flat -= np.outer(flat @ u, u)  # seen along the axis
    var, vec = np.linalg.eigh(flat.T @ flat / len(flat))  # ascending; the smallest is along u
    if var[2] < min_elongation * max(var[1], 1e-18):
        return None
    line = vec[:, 2]
    if np.ptp(flat @ line) < min_cover * long_extent:
        return None
    long_axis = long_axis - (long_axis @ u) * u
    line = line if long_axis @ line >= 0.0 else -line
    return float(np.arctan2(np.cross(long_axis, line) @ u, long_axis @ line)), mean


def _turned_onto(cam_from_box, size, thin: int, u, angle: float, mean, own, cam) -> np.ndarray:
    """The box pose ``cam_from_box`` turned by ``angle`` about ``u`` through ``mean``, then moved along its ``thin``
    axis until its face towards ``cam`` lies at the median of the points ``own`` there."""
    X = np.array(cam_from_box, dtype=np.float64)
    R = rotation_about_axis(u, angle)
    X[:3, :3] = R @ X[:3, :3]
    X[:3, 3] = mean + R @ (X[:3, 3] - mean)
    normal = X[:3, :3][:, thin]
    normal = normal if normal @ (cam - X[:3, 3]) >= 0.0 else -normal  # towards the camera
    X[:3, 3] += (np.median(own @ normal) - 0.5 * size[thin] - X[:3, 3] @ normal) * normal
    return X


def turn_thin_children(
    cam_from_part,
    size_m,
    joint_axis,
    points,
    labels,
    priors: CategoryPriors,
    confidence=None,
    camera=(0.0, 0.0, 0.0),
    thin_ratio: float = _TURN.thin_ratio,
    min_points: int = _TURN.min_points,
    min_elongation: float = _TURN.min_elongation,
    min_cover: float = _TURN.min_cover,
    min_turn_deg: float = _TURN.min_turn_deg,
    join_margin: float = _TURN.join_margin,
    check_tol: float = _TURN.check_tol,
    connect_factor: float = _TURN.connect_factor,
    min_confidence: float = _TURN.min_confidence,
) -> tuple[np.ndarray, np.ndarray]:
    """Turn each thin revolute child about its joint's axis until its box lies along its own points.

    For each revolute joint whose axis is one of its child's box axes, and whose child is a slab whose plane holds
    that axis (its smaller extent across the axis at most ``thin_ratio`` times each of its other two): the child's
    points (labelled as it, ``confidence`` at least ``min_confidence``, joined to its box grown by ``join_margin``
    thicknesses, :func:`ucope.stages.support.joined_to_box`; at least ``min_points``), seen along the voted joint
    axis, give its long axis's direction (:func:`_line_turn`: ``min_elongation``, ``min_cover``). The child is
    turned about the joint axis through its points' mean by the signed angle from its long axis to that direction
    (skipped under ``min_turn_deg``) and moved along its thin axis until its face towards ``camera`` lies at the
    points' median there; the turn is undone where the points' median distance outside the box rose by more than
    ``check_tol`` thicknesses. Parents, sizes and the joint's axis and pivot are kept; the joint's state follows
    from the turned box (:func:`ucope.stages.states.settle_joint_states`).

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres); size_m: ``(K, 3)`` box extents (> 0).
        joint_axis: ``(J, 3)`` the voted joint axes (camera frame; any length > 0, any sign).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (joint tree, types, canonical axes).
        confidence: optional ``(P,)`` the probability that each point is the object; camera: ``(3,)`` its centre.
        thin_ratio: in ``(0, 1]``; min_points: >= 3; min_elongation: >= 1; min_cover, min_turn_deg,
            join_margin, check_tol: >= 0; connect_factor: > 0; min_confidence: in ``[0, 1]``.

    Returns:
        ``(cam_from_part, turned)``: a new ``(K, 4, 4)`` float64 array and ``(K,)`` the angle each part was
        turned by (radians about its joint's axis as given; 0 for parts left alone).

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes, axes, points or camera, a size
            <= 0 or a zero axis, labels that are not integers, bad confidences, or a setting out of its range.
    """
    T, S, pts, lab = _checked_cloud(
        cam_from_part, size_m, points, labels, priors, 0.0, connect_factor, confidence, min_confidence
    )
    others = (min_cover, min_turn_deg, join_margin, check_tol)
    u_all, length, cam = _checked_turn(
        joint_axis, priors.num_joints, camera, thin_ratio, min_points, min_elongation, min_confidence, others
    )
    turned = np.zeros(priors.num_parts)
    for j, jp in enumerate(priors.joints):  # a handful of joints; the point work is vectorised
        c = jp.child
        if jp.type != JointType.REVOLUTE or (axes := _slab_axes(S[c], jp.axis, thin_ratio)) is None:
            continue
        thin, long_ = axes
        own = pts[lab == c]
        local = (own - T[c, :3, 3]) @ T[c, :3, :3]
        own = own[joined_to_box(local, 0.5 * S[c] + join_margin * S[c, thin], connect_factor)]
        if len(own) < max(int(min_points), 3):
            continue
        u = u_all[j] / length[j]
        if (line := _line_turn(own, u, T[c, :3, long_], S[c, long_], min_elongation, min_cover)) is None:
            continue
        angle, mean = line
        if abs(angle) < np.radians(min_turn_deg):
            continue
        X = _turned_onto(T[c], S[c], thin, u, angle, mean, own, cam)
        if _median_outside(own, X, S[c]) > _median_outside(own, T[c], S[c]) + check_tol * S[c, thin]:
            continue
        T[c] = X
        turned[c] = angle
    return T, turned


@stage("turn_children", kind="geometry", params=TurnChildrenParams, applies=lambda priors: priors.num_joints > 0)
def _turn_children(state: PoseState, params: TurnChildrenParams) -> None:
    """A thin revolute child (a door, a lid) turned about its joint's axis until its box lies along its points."""
    p = params
    line = dict(thin_ratio=p.thin_ratio, min_points=p.min_points, min_elongation=p.min_elongation, min_cover=p.min_cover)
    check = dict(min_turn_deg=p.min_turn_deg, join_margin=p.join_margin, check_tol=p.check_tol)
    state.cam_from_part, _ = turn_thin_children(
        state.cam_from_part,
        state.size_m,
        state.joint_axis,
        state.points,
        state.part_labels,
        state.priors,
        confidence=state.confidence,
        camera=state.camera,
        connect_factor=p.connect_factor,
        min_confidence=p.min_confidence,
        **line,
        **check,
    )


@stage(
    "seat_parts",
    kind="learned-prior",
    params=SeatPartsParams,
    reads=("joints.pivot_in_parent", "joints.pivot_in_child"),
    applies=lambda priors: priors.num_joints > 0,
)
def _seat_parts(state: PoseState, params: SeatPartsParams) -> None:
    """A part that shows few points and stands off its hinge, put where its joint's axis meets its neighbour's box."""
    state.cam_from_part, state.joint_pivot, seated = seat_weak_parts(
        state.cam_from_part,
        state.size_m,
        state.joint_pivot,
        state.part_labels,
        state.priors,
        params.weak_share,
        params.strong_share,
        params.min_gap,
    )
    for k in np.flatnonzero(seated):
        state.warnings.append(
            f"part {state.part_name(k)!r}: it showed few points and its voted centre stood off its hinge; it was put "
            "where its hinge meets its neighbour's"
        )
