"""Revolute children.

:func:`turn_thin_children` turns a thin child hinged along an edge (a door, a lid, a temple) about its joint's
axis to the direction its own points take seen along that axis, its face put on them. :func:`seat_weak_parts`
puts the centre of a part that shows few points and stands off its hinge where its joint's axis meets its
well-seen neighbour's box. Camera frame, metres, radians.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..geometry.transforms import rotation_about_axis
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .support import (
    GROW_CONNECT_FACTOR,
    _checked_camera,
    _checked_cloud,
    _hinged_centre,
    _median_outside,
    joined_to_box,
    weak_neighbours,
)

SEAT_WEAK_SHARE = 0.125
"""A part is seated on its hinge (:func:`seat_weak_parts`) only where fewer than this share of the points segmented
as the object are its own ..."""


SEAT_STRONG_SHARE = 0.25
"""... and at least this share are its neighbour's across the joint (as :mod:`ucope.stages.freespace`) ..."""


SEAT_MIN_GAP = 0.2
"""... and only where its hinge point stands more than this share of its box diagonal from its neighbour's: the
part came loose from its hinge."""


def seat_weak_parts(
    cam_from_part,
    size_m,
    joint_pivot,
    labels,
    priors: CategoryPriors,
    weak_share: float = SEAT_WEAK_SHARE,
    strong_share: float = SEAT_STRONG_SHARE,
    min_gap: float = SEAT_MIN_GAP,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A part the camera barely sees, its centre put back where its hinge meets its well-seen neighbour's.

    The centre of a part that shows few points (a closed dishwasher door seen from behind, which shows a strip
    of its top edge; a laptop base behind its lid) is voted from little evidence: on the shipped dishwasher's
    back views such a door stood 0.3-0.4 m off its body, slid along its hinge or in front of the body, with its
    rotation right within 5 degrees. A revolute joint fixes the centre from the neighbour: the joint's axis passes
    through one point of each part's unit box (``JointPrior.pivot_in_parent`` / ``pivot_in_child``, the training
    objects' mean, times the extents), so for each revolute joint (in the priors' order) whose child is a leaf, or
    either of whose parts is the root of a two-part object, a part with fewer than ``weak_share`` of the object's
    labelled points next to one with at least ``strong_share``, whose voted centre stands more than ``min_gap`` of
    its box diagonal from the centre that puts its point on its neighbour's (:func:`carry_upright`'s placement),
    takes that centre, and the joint's pivot becomes that point. At the true poses and sizes of the test views that
    placement is 0.1 % of the part's box diagonal off the true centre (median) for the laptop's base and lid, 2.5 %
    (90th percentile 5.4 %) for the dishwasher's door; but it follows the neighbour's voted box, and seated without
    the gap the shipped dishwasher lost 8 of 200 test views (docs/results.md). Rotations, sizes, joint axes and
    revolute states are kept. Camera frame, metres.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses; size_m: ``(K, 3)`` box extents (> 0).
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


TURN_THIN_RATIO = 0.5
"""A revolute child is thin (:func:`turn_thin_children`) where one of its two box extents across the joint's axis is
at most this times each of its other two: a dishwasher door (0.2), a laptop lid, a spectacle temple. A scissor blade
is thin along its hinge and is left alone: turned, its box would be moved across its own width."""


TURN_MIN_POINTS = 50
"""A thin child with fewer confident points than this, in the piece joined to its box, keeps its pose."""


TURN_MIN_ELONGATION = 4.0
"""... and so does one whose points, seen along the joint's axis, do not lie along a line: the larger variance of
their projection at least this times the smaller (a door seen edge-on from above is a short blob)."""


TURN_MIN_COVER = 0.3
"""... or whose points span less than this fraction of its long extent along that line."""


TURN_MIN_DEG = 2.0
"""Turns smaller than this (degrees) are left alone."""


TURN_MIN_CONFIDENCE = 0.5
"""Points whose probability of being the object is below this do not count (the slide's, ``FRONT_MIN_CONFIDENCE``)."""


TURN_JOIN_MARGIN = 1.0
"""The points that count lie in a piece joined to the child's box grown by this many of its thicknesses on every
side (a door voted a thickness off its own points still finds them)."""


TURN_CHECK_TOL = 0.25
"""A turn is undone where it moves the points out of the box: their median distance outside it rises by more
than this many of the child's thicknesses (a mislabelled strip of the parent that drew the line)."""


def turn_thin_children(
    cam_from_part,
    size_m,
    joint_axis,
    points,
    labels,
    priors: CategoryPriors,
    confidence=None,
    camera=(0.0, 0.0, 0.0),
    thin_ratio: float = TURN_THIN_RATIO,
    min_points: int = TURN_MIN_POINTS,
    min_elongation: float = TURN_MIN_ELONGATION,
    min_cover: float = TURN_MIN_COVER,
    min_turn_deg: float = TURN_MIN_DEG,
    join_margin: float = TURN_JOIN_MARGIN,
    check_tol: float = TURN_CHECK_TOL,
    connect_factor: float = GROW_CONNECT_FACTOR,
    min_confidence: float = TURN_MIN_CONFIDENCE,
) -> tuple[np.ndarray, np.ndarray]:
    """Turn each thin revolute child about its joint's axis until its box lies along its own points.

    A dishwasher door is a slab hinged at its bottom edge. Seen from the side or the front, its points lie on a
    plane, and seen along the hinge they form a line whose direction is the door's angle. Voting gets that angle
    from pair votes, which strayed on the dishwasher's OOD machines: in 13 of the 31 OOD views it failed, the door
    was 11-89 degrees off while the body was right, 9 of them with 347-830 door points in view.

    For each revolute joint whose axis is one of its child's box axes, and whose child is a slab whose plane holds
    that axis (its smaller extent across the axis at most ``thin_ratio`` times each of its other two: a door, a
    lid, a spectacle temple; not a scissor blade, which is thin along its hinge):

    1. The child's points: labelled as it, ``confidence`` at least ``min_confidence``, in one connected piece
       (:func:`ucope.stages.support.joined_to_box`) with a point inside its box grown by ``join_margin``
       thicknesses. At least ``min_points`` of them.
    2. They are projected along the voted joint axis. Their principal direction is the child's long axis when
       the larger variance is at least ``min_elongation`` times the smaller, and they span at least
       ``min_cover`` of the child's long extent along it.
    3. The child is turned about the joint axis, through its points' mean, by the signed angle from its long
       axis to that direction (of the two senses, the nearer; skipped under ``min_turn_deg``).
    4. Its box is moved along its thin axis until the face towards ``camera`` lies at the points' median
       there.
    5. The turn is undone where the points' median distance outside the box rose by more than ``check_tol``
       thicknesses.

    Parents, sizes and the joint's axis and pivot are left as they are; the joint's state follows from the
    turned box (:func:`settle_joint_states`).

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        joint_axis: ``(J, 3)`` the voted joint axes (camera frame; any length > 0, any sign).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (joint tree, types, canonical axes).
        confidence: optional ``(P,)`` per point, the probability that it is the object.
        camera: ``(3,)`` the camera's centre in the same frame (the origin of a camera frame).
        thin_ratio: in ``(0, 1]``; min_points: >= 3; min_elongation: >= 1; min_cover, min_turn_deg,
            join_margin, check_tol: >= 0; connect_factor: > 0; min_confidence: in ``[0, 1]``.

    Returns:
        ``(cam_from_part, turned)``: a new ``(K, 4, 4)`` float64 array and ``(K,)`` the angle each part was
        turned by (radians about its joint's axis as given; 0 for parts left alone).

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes, axes, points or camera, a
            non-positive size or a zero axis, labels that are not integers, confidences that are not one
            finite value per point, or a setting out of its range.
    """
    T, S, pts, lab = _checked_cloud(
        cam_from_part, size_m, points, labels, priors, 0.0, connect_factor, confidence, min_confidence
    )
    J = priors.num_joints
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
    if not (min_cover >= 0.0 and min_turn_deg >= 0.0 and join_margin >= 0.0 and check_tol >= 0.0):
        raise InputError(
            "min_cover, min_turn_deg, join_margin and check_tol must be >= 0, got "
            f"{min_cover!r}, {min_turn_deg!r}, {join_margin!r}, {check_tol!r}"
        )
    turned = np.zeros(priors.num_parts)
    for j, jp in enumerate(priors.joints):  # a handful of joints; the point work is vectorised
        hinge = np.abs(np.asarray(jp.axis))
        if jp.type != JointType.REVOLUTE or not np.isclose(hinge.max(), 1.0, atol=1e-6):
            continue
        c = jp.child
        along = int(np.argmax(hinge))
        thin, long_ = sorted((i for i in range(3) if i != along), key=lambda i: S[c, i])
        if S[c, thin] > thin_ratio * min(S[c, long_], S[c, along]):  # a slab whose plane holds the hinge
            continue
        own = pts[lab == c]
        local = (own - T[c, :3, 3]) @ T[c, :3, :3]
        own = own[joined_to_box(local, 0.5 * S[c] + join_margin * S[c, thin], connect_factor)]
        if len(own) < max(int(min_points), 3):
            continue
        u = u_all[j] / length[j]
        mean = own.mean(0)
        flat = own - mean
        flat -= np.outer(flat @ u, u)  # seen along the axis
        var, vec = np.linalg.eigh(flat.T @ flat / len(flat))  # ascending; the smallest is along u
        if var[2] < min_elongation * max(var[1], 1e-18):
            continue
        line = vec[:, 2]
        if np.ptp(flat @ line) < min_cover * S[c, long_]:
            continue
        long_axis = T[c, :3, :3][:, long_] - (T[c, :3, :3][:, long_] @ u) * u
        line = line if long_axis @ line >= 0.0 else -line
        angle = float(np.arctan2(np.cross(long_axis, line) @ u, long_axis @ line))
        if abs(angle) < np.radians(min_turn_deg):
            continue
        before = T[c].copy()
        R = rotation_about_axis(u, angle)
        T[c, :3, :3] = R @ T[c, :3, :3]
        T[c, :3, 3] = mean + R @ (T[c, :3, 3] - mean)
        normal = T[c, :3, :3][:, thin]
        normal = normal if normal @ (cam - T[c, :3, 3]) >= 0.0 else -normal  # towards the camera
        T[c, :3, 3] += (np.median(own @ normal) - 0.5 * S[c, thin] - T[c, :3, 3] @ normal) * normal
        if _median_outside(own, T[c], S[c]) > _median_outside(own, before, S[c]) + check_tol * S[c, thin]:
            T[c] = before
            continue
        turned[c] = angle
    return T, turned


@stage("turn_children", kind="geometry", applies=lambda priors: priors.num_joints > 0)
def _turn_children(state: PoseState, params) -> None:
    """A thin revolute child (a door, a lid) turned about its joint's axis until its box lies along its points."""
    state.cam_from_part, _ = turn_thin_children(
        state.cam_from_part,
        state.size_m,
        state.joint_axis,
        state.points,
        state.part_labels,
        state.priors,
        confidence=state.confidence,
        camera=state.camera,
    )


@stage(
    "seat_parts",
    kind="learned-prior",
    reads=("joints.pivot_in_parent", "joints.pivot_in_child"),
    applies=lambda priors: priors.num_joints > 0,
)
def _seat_parts(state: PoseState, params) -> None:
    """A part that shows few points and stands off its hinge, put where its joint's axis meets its neighbour's box."""
    state.cam_from_part, state.joint_pivot, seated = seat_weak_parts(
        state.cam_from_part, state.size_m, state.joint_pivot, state.part_labels, state.priors
    )
    for k in np.flatnonzero(seated):
        state.warnings.append(
            f"part {state.part_name(k)!r}: it showed few points and its voted centre stood off its hinge; it was put "
            "where its hinge meets its neighbour's"
        )
