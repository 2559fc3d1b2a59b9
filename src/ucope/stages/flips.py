"""Half-turn ambiguities.

Voting fixes each axis up to sign from symmetric evidence, so a part can come out turned by a half turn.

* :func:`resolve_shape_flips`: a part of a rigid object is turned by the half turn about one of its axes that
  best fits its points to the category's shape templates (``CategoryPriors.shape_templates``, a
  :class:`ShapeIndex`), when that clearly fits better;
* :func:`resolve_joint_flips`: a part of an articulated object is turned back by a half turn where its
  revolute joint's limits and the category's placements of neighbouring parts say so;
* :func:`resolve_front_flips`: a parent and its prismatic children (a cabinet and its drawers) are turned
  round about the parent's upright axis where the children's points lie behind its centre.

Camera frame, metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..geometry.kinematics import revolute_angle
from ..geometry.transforms import rotation_about_axis
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .support import (
    _HALF_TURNS,
    FRONT_MIN_CONFIDENCE,
    SHAPE_CLIP,
    _checked_camera,
    _confident,
    _subtree,
)


@dataclass(frozen=True)
class FlipsParams:
    """Attributes:
    shape_margin: a rigid part's best half turn replaces its voted rotation where its template misfit is below this
        times the voted one's; shape_clip: the point-to-template distance cap (unit-box sizes); shape_max_points: the
        most points of a part compared (:func:`resolve_shape_flips`).
    front_min_share: a parent whose front faces the camera while its prismatic children show fewer than this share
        of the object's (confident) points is taken as seen from behind; front_min_points: one whose children show
        at least this many points, their median behind its centre along the slide, as turned round;
        front_max_deg: the front counts as faced only where the camera lies within this angle of its normal, seen
        along the parent's upright axis; front_min_confidence: points less likely to be the object do not count
        (:func:`resolve_front_flips`).
    """

    shape_margin: float = 0.75
    shape_clip: float = SHAPE_CLIP
    shape_max_points: int = 1024
    front_min_share: float = 0.02
    front_min_points: int = 30
    front_max_deg: float = 45.0
    front_min_confidence: float = FRONT_MIN_CONFIDENCE


_P = FlipsParams()


def _placement_flips(T: np.ndarray, size: np.ndarray, priors: CategoryPriors, flipped: np.ndarray) -> None:
    """Turn (in place) each part by the half turn about one of its axes that best puts its neighbours'
    voted centres where the category has them (``JointPrior.child_in_parent`` / ``parent_in_child``),
    when that at least halves the misfit and lowers it by 0.1 (box diagonals as units)."""
    E = np.array([[jp.child_in_parent, jp.parent_in_child] for jp in priors.joints], dtype=np.float64).reshape(-1, 2, 3)
    for k in range(T.shape[0]):  # a handful of parts
        links = [(j, 0, jp.child) for j, jp in enumerate(priors.joints) if jp.parent == k]
        links += [(j, 1, jp.parent) for j, jp in enumerate(priors.joints) if jp.child == k]
        if not links:
            continue
        cost = np.zeros(len(_HALF_TURNS))
        for j, side, o in links:
            v = T[k, :3, :3].T @ (T[o, :3, 3] - T[k, :3, 3]) / np.linalg.norm(size[k])
            cost += (((_HALF_TURNS @ v) - E[j, side]) ** 2).sum(-1)  # D^T v = D v for these D
        best = int(np.argmin(cost))
        if best != 0 and cost[best] < 0.5 * cost[0] and cost[0] - cost[best] > 0.1:
            T[k, :3, :3] = T[k, :3, :3] @ _HALF_TURNS[best]
            flipped[k] = True


def _shape_misfit(
    tree: cKDTree, points: np.ndarray, cam_from_box: np.ndarray, size_m: np.ndarray, clip: float = _P.shape_clip
) -> float:
    """Mean distance (unit-box sizes, each clipped at ``clip``) from ``points`` ``(N, 3)``, brought into the box
    ``cam_from_box`` ``(4, 4)`` of extents ``size_m`` ``(3,)``, to the nearest point of a shape template's k-d tree."""
    q = (np.asarray(points, np.float64) - cam_from_box[:3, 3]) @ cam_from_box[:3, :3] / np.maximum(size_m, 1e-6)
    return float(np.minimum(tree.query(q)[0], clip).mean())


@dataclass(frozen=True)
class ShapeIndex:
    """Per part, a k-d tree of the category's shape template (``CategoryPriors.shape_templates``:
    surface points in the part's unit box), for :func:`resolve_shape_flips`; ``None`` for a part
    without a template. Build it once per model (:meth:`from_priors`) and pass it to every call."""

    trees: tuple

    @classmethod
    def from_priors(cls, priors: CategoryPriors) -> ShapeIndex:
        templates = priors.shape_templates or (np.zeros((0, 3)),) * priors.num_parts
        return cls(tuple(cKDTree(np.asarray(t, dtype=np.float64)) if len(t) else None for t in templates))


def resolve_shape_flips(
    cam_from_part: np.ndarray,
    size_m: np.ndarray,
    points: np.ndarray,
    part_points: list,
    priors: CategoryPriors,
    shapes: ShapeIndex | None = None,
    margin: float = _P.shape_margin,
    clip: float = _P.shape_clip,
    max_points: int = _P.shape_max_points,
) -> tuple[np.ndarray, np.ndarray]:
    """Turn back parts whose voted rotation is a half turn (about one of the part's axes) away from
    the pose their own points fit best (beyond the paper).

    A box is unchanged by those half turns, and the votes cannot always tell them apart (a camera's
    lens side from its screen side). Each part's points are brought into its voted frame and unit
    box, turned by each half turn, and compared with the category's shape (its template in the priors,
    :class:`ShapeIndex`): mean distance to the nearest template point, clipped at
    ``clip`` box sizes. The best half turn replaces the voted one when its misfit is below
    ``margin`` times the voted one's. Parts symmetric about y, or without a template, are left alone. At most ``max_points``
    of a part's points (evenly strided) are compared, all half turns in one k-d tree query.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses; size_m: ``(K, 3)`` voted sizes.
        points: ``(N, 3)`` camera frame, metres; part_points: per part, indices into ``points``.
        priors: the category's priors; shapes: their :class:`ShapeIndex` (built here when ``None``).

    Returns:
        ``(cam_from_part, turned)``: new poses (a copy) and ``(K,)`` bool, the parts turned.
    """
    T = np.array(cam_from_part, dtype=np.float64, copy=True)
    turned = np.zeros(len(T), dtype=bool)
    trees = (shapes or ShapeIndex.from_priors(priors)).trees
    symmetric = priors.symmetric
    for k in range(len(T)):  # a handful of parts
        idx = np.asarray(part_points[k])
        if symmetric[k] or trees[k] is None or len(idx) < 16:
            continue
        if len(idx) > max_points:
            idx = idx[np.linspace(0, len(idx) - 1, max_points).astype(np.int64)]
        q = (points[idx] - T[k, :3, 3]) @ T[k, :3, :3] / np.maximum(size_m[k], 1e-6)
        turns = np.diagonal(_HALF_TURNS, axis1=1, axis2=2)  # (4, 3): the half turns are diagonal
        dist = trees[k].query((q[None] * turns[:, None, :]).reshape(-1, 3))[0]
        cost = np.minimum(dist, clip).reshape(len(turns), -1).mean(1)
        best = int(np.argmin(cost))
        if best != 0 and cost[best] < margin * cost[0]:
            T[k, :3, :3] = T[k, :3, :3] @ _HALF_TURNS[best]
            turned[k] = True
    return T, turned


def _range_distance(q: float, lo: float | None, hi: float | None) -> float:
    """How far the angle ``q`` (any turn) lies outside ``[lo, hi]`` (0 inside; an unlimited side never
    excludes), radians."""
    if lo is None or hi is None:
        return 0.0
    q = (q - lo) % (2 * np.pi) + lo  # into [lo, lo + 2 pi)
    return 0.0 if q <= hi else min(q - hi, lo + 2 * np.pi - q)


def resolve_joint_flips(
    cam_from_part: np.ndarray, joint_axis: np.ndarray, priors: CategoryPriors, size_m: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Undo half-turn flips of part rotations that contradict a revolute joint.

    A box is unchanged by a half turn about any of its own axes, so the votes of a plate-like part (a
    laptop lid, a temple) can land on such a flip of the truth. A revolute joint ``j`` (canonical axis
    ``a_j`` in the parent frame) tells two kinds apart:

    * a half turn about an axis perpendicular to ``a_j``: then ``R_p a_j . R_c a_j < 0`` (the joint
      turns the child about ``a_j``, so both are the joint axis). The joint heads give the signed axis
      ``u_j`` independently of the part votes; the part that disagrees with ``u_j`` while the other
      agrees is turned by a half turn about whichever of its canonical axes perpendicular to ``a_j``
      puts the joint angle inside the joint's limits (else the closer to them);
    * a half turn about ``a_j`` itself: the relative rotation is still about ``a_j`` but its angle is
      off by pi; if the angle lies outside the joint's limits and ``angle + pi`` is closer to them, the
      child is turned by a half turn about ``a_j``.

    Before both, with ``size_m`` given, each part connected by any joint may take the half turn about one
    of its own axes that best puts its neighbours' voted centres where the category has them (in the
    part's frame, in units of its box diagonal, averaged over the category's instances and joint
    range): the half turn of an eyeglasses front about its hinge axis puts the temples in front of it.

    The limits and placements are the priors'. Joints are visited parent first; prismatic joints are
    left alone by the two joint rules.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses; joint_axis: ``(J, 3)`` the joint heads' axes (camera).
        priors: the category's priors (joint tree, canonical axes, limits, placements).
        size_m: ``(K, 3)`` the voted box sizes (for the placement check; ``None`` skips it).

    Returns:
        ``(cam_from_part, flipped)``: corrected poses (a copy) and ``(K,)`` bool, the parts turned.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    K = T.shape[0]
    flipped = np.zeros(K, dtype=bool)
    axes = priors.joint_axes
    basis = np.eye(3)
    if size_m is not None and priors.num_joints > 0:
        _placement_flips(T, np.asarray(size_m, dtype=np.float64), priors, flipped)
    for j, jp in enumerate(priors.joints):  # a handful of joints, parents before children
        if jp.type != JointType.REVOLUTE:
            continue
        p, c, a = jp.parent, jp.child, axes[j]
        limits = jp.limits
        u = np.asarray(joint_axis[j], dtype=np.float64)
        if not np.all(np.isfinite(u)):
            u = np.zeros(3)
        sp, sc = float(T[p, :3, :3] @ a @ u), float(T[c, :3, :3] @ a @ u)
        if sp * sc < 0:
            k = c if sp > 0 else p
            best = None
            for b in basis[np.argsort(np.abs(basis @ a))[:2]]:  # the two canonical axes most perpendicular to a
                R = T[k, :3, :3] @ rotation_about_axis(b, np.pi)
                rel = T[p, :3, :3].T @ R if k == c else R.T @ T[c, :3, :3]
                q = float(revolute_angle(rel, a))
                key = (round(_range_distance(q, *limits), 6), float(np.linalg.norm(rel - rotation_about_axis(a, q))))
                if best is None or key < best[0]:
                    best = (key, R)
            T[k, :3, :3] = best[1]
            flipped[k] = True
        q = float(revolute_angle(T[p, :3, :3].T @ T[c, :3, :3], a))
        if _range_distance(q + np.pi, *limits) < _range_distance(q, *limits):
            T[c, :3, :3] = T[c, :3, :3] @ rotation_about_axis(a, np.pi)
            flipped[c] = True
    return T, flipped


def _checked_front(cam_from_part, joint_axis, joint_pivot, points, labels, priors, camera, settings) -> tuple:
    """``(T, u, piv, points, labels, camera)`` as float64 copies / arrays after :func:`resolve_front_flips`'s checks
    (``settings``: ``min_share, min_points, max_deg, min_confidence``)."""
    K, J = priors.num_parts, priors.num_joints
    T = np.array(cam_from_part, dtype=np.float64)
    u = np.array(joint_axis, dtype=np.float64)
    piv = np.array(joint_pivot, dtype=np.float64)
    if T.shape != (K, 4, 4) or u.shape != (J, 3) or piv.shape != (J, 3):
        raise InputError(
            f"cam_from_part, joint_axis and joint_pivot must have shapes ({K}, 4, 4), ({J}, 3), ({J}, 3), "
            f"got {T.shape}, {u.shape}, {piv.shape}"
        )
    if not (np.isfinite(T).all() and np.isfinite(u).all()):
        raise InputError("cam_from_part and joint_axis must be finite")
    pts = np.asarray(points, dtype=np.float64)
    lab = np.asarray(labels)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.isfinite(pts).all():
        raise InputError(f"points must be a finite (P, 3) array, got shape {pts.shape}")
    if lab.shape != (len(pts),) or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be one integer per point, got {lab.dtype} of shape {lab.shape}")
    cam = _checked_camera(camera)
    min_share, min_points, max_deg, min_confidence = settings
    if not (0.0 <= min_share <= 1.0 and int(min_points) >= 1 and 0.0 <= max_deg <= 90.0):
        raise InputError(
            f"min_share must lie in [0, 1], min_points be >= 1 and max_deg lie in [0, 90], got {min_share!r}, "
            f"{min_points!r}, {max_deg!r}"
        )
    if not 0.0 <= min_confidence <= 1.0:
        raise InputError(f"min_confidence must lie in [0, 1], got {min_confidence!r}")
    return T, u, piv, pts, lab, cam


def _front_turn_axis(T, p, kids, priors, pts, lab, n_object, cam, min_share, min_points, max_deg) -> int | None:
    """The box axis of parent ``p`` to turn it round about (its upright axis; else its stack's; else its first axis
    across the slide) where its prismatic children ``kids`` (all sliding along one of its box axes) say its front is
    where its back is (:func:`resolve_front_flips`); ``None`` otherwise."""
    axis = np.asarray(kids[0].axis, dtype=np.float64)
    i = int(np.argmax(np.abs(axis)))
    if abs(axis[i]) < 1.0 - 1e-6 or any(not np.allclose(jp.axis, axis, atol=1e-6) for jp in kids):
        return None  # children that do not all slide along one box axis
    sign = float(np.sign(axis[i]))
    R, t = T[p, :3, :3], T[p, :3, 3]
    own = np.isin(lab, [jp.child for jp in kids])
    n_kids = int(np.count_nonzero(own))
    stacked = [st.axis for st in priors.stacks if st.parent == p and st.axis != i]
    up = priors.parts[p].upright_axis
    b = up if up is not None and up != i else (stacked[0] if stacked else next(x for x in range(3) if x != i))
    behind = n_kids >= int(min_points) and sign * float(np.median((pts[own] - t) @ R[:, i])) < 0.0
    c = R.T @ (cam - t)  # the camera in the parent's frame
    side = 3 - i - b  # the third axis: across the front, seen from above
    ahead = sign * c[i]
    faces = ahead > 0.0 and np.degrees(np.arctan2(abs(c[side]), ahead)) <= max_deg
    bare = faces and n_kids < min_share * n_object
    return b if behind or bare else None


def resolve_front_flips(
    cam_from_part,
    joint_axis,
    joint_pivot,
    points,
    labels,
    priors: CategoryPriors,
    confidence=None,
    camera=(0.0, 0.0, 0.0),
    min_share: float = _P.front_min_share,
    min_points: int = _P.front_min_points,
    max_deg: float = _P.front_max_deg,
    min_confidence: float = _P.front_min_confidence,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Undo the half turn of a parent and its prismatic children that puts its front where its back is.

    A closed cabinet is nearly a box, and voting can turn it round with its drawers. The drawers decide it: they
    slide out of the front, so their points lie at or in front of it, and a camera facing the front sees them. For
    each parent whose prismatic children all slide along one of its box axes ``+a``:

    * where the children show at least ``min_points`` (confident) points and their median along ``a`` lies behind
      the parent's centre, or
    * where the camera lies ahead of the parent's centre along ``+a``, within ``max_deg`` of that direction seen
      along the parent's upright axis, and the children show under ``min_share`` of the object's (confident)
      labelled points,

    the parent and every part below it are turned by a half turn about the parent's upright axis
    (``PartPrior.upright_axis``; else the axis its children are stacked along, ``StackPrior.axis``; else its first
    box axis across ``a``) through the parent's box centre, and the axes and pivots of the joints below it with them.
    Joint states do not change (they are relative).

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres).
        joint_axis, joint_pivot: ``(J, 3)`` the joints' axes (unit) and pivots (metres), same frame; a pivot may be
            NaN (a prismatic joint has none) and stays NaN.
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (joint tree, types, canonical axes, upright axes).
        confidence: optional ``(P,)`` per point, the probability that it is the object; points below
            ``min_confidence`` do not count.
        camera: ``(3,)`` the camera's centre in the same frame.
        min_share: in ``[0, 1]``; min_points: ``>= 1``; max_deg: in ``[0, 90]``.

    Returns:
        ``(cam_from_part, joint_axis, joint_pivot, flipped)``: new float64 arrays, and ``(K,)`` bool, the parts
        turned.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, axes, points or camera, labels that are
            not integers, confidences that are not one finite value per point, or a setting out of its range.
    """
    K = priors.num_parts
    settings = (min_share, min_points, max_deg, min_confidence)
    T, u, piv, pts, lab, cam = _checked_front(cam_from_part, joint_axis, joint_pivot, points, labels, priors, camera, settings)
    lab = _confident(lab, confidence, min_confidence)
    n_object = int(np.count_nonzero((lab >= 0) & (lab < K)))
    flipped = np.zeros(K, dtype=bool)
    for p in range(K):  # a handful of parts; the point work is vectorised
        kids = [jp for jp in priors.joints if jp.parent == p and jp.type == JointType.PRISMATIC]
        if not kids:
            continue
        b = _front_turn_axis(T, p, kids, priors, pts, lab, n_object, cam, min_share, min_points, max_deg)
        if b is None:
            continue
        R, t = T[p, :3, :3], T[p, :3, 3]
        below = _subtree(priors, p)
        Rf = rotation_about_axis(R[:, b], np.pi)
        T[below, :3, :3] = Rf @ T[below, :3, :3]
        T[below, :3, 3] = t + (T[below, :3, 3] - t) @ Rf.T
        js = [j for j, jp in enumerate(priors.joints) if jp.child in below]
        u[js] = u[js] @ Rf.T
        piv[js] = t + (piv[js] - t) @ Rf.T
        flipped[below] = True
    return T, u, piv, flipped


@stage(
    "flips",
    kind="learned-prior",
    params=FlipsParams,
    reads=("shape_templates", "joints.limits", "joints.child_in_parent", "joints.parent_in_child"),
)
def _flips(state: PoseState, params: FlipsParams) -> None:
    """Half turns undone: a rigid part turned to the pose that fits its training shapes, a part turned back to what its
    joint's limits and its neighbours' placements allow, a cabinet turned round with its drawers where their points
    lie behind it."""
    if state.J == 0:
        state.cam_from_part, _ = resolve_shape_flips(
            state.cam_from_part,
            state.size_m,
            np.asarray(state.points, np.float64),
            state.part_points,
            state.priors,
            state.shapes,
            margin=params.shape_margin,
            clip=params.shape_clip,
            max_points=params.shape_max_points,
        )
        return
    state.cam_from_part, _ = resolve_joint_flips(state.cam_from_part, state.joint_axis, state.priors, state.size_m)
    if any(jp.type == JointType.PRISMATIC for jp in state.priors.joints):
        state.cam_from_part, state.joint_axis, state.joint_pivot, _ = resolve_front_flips(
            state.cam_from_part,
            state.joint_axis,
            state.joint_pivot,
            state.points,
            state.part_labels,
            state.priors,
            confidence=state.confidence,
            camera=state.camera,
            min_share=params.front_min_share,
            min_points=params.front_min_points,
            max_deg=params.front_max_deg,
            min_confidence=params.front_min_confidence,
        )
