"""What the stages share: the defaults several stages use, argument checks, a part's points joined to its box, the
subtree of a joint.

Frames and units: points and poses in the camera frame of the pass, metres.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..priors import CategoryPriors
from ..vocab import JointType

GROW_QUANTILE = 0.01
"""Lower quantile of a part's points along each box axis that a grown box holds (``1 -`` it above)."""


GROW_MIN_POINTS = 30
"""A part with fewer (confident, joined) points than this keeps its voted box."""


GROW_MIN_CONFIDENCE = 0.9
"""Points whose probability of being the object (not the background) is below this are not sure enough to
widen a box."""


GROW_CONNECT_FACTOR = 8.0
"""Longest step between joined points (:func:`connected_pieces`), in median nearest-neighbour distances of the
points."""


FRONT_MIN_CONFIDENCE = 0.5
"""Points whose probability of being the object (not the background) is below this do not count as their
part's when a stage places a part from its points (drawer fronts, stacks, slides, turned doors)."""


UPRIGHT_MARGIN_DEG = 10.0
"""How far (degrees) beyond its training cone (``PartPrior.upright_cone_deg``) a part's upright axis may tilt:
beyond it the ``upright`` stage re-places the part; ``free_space`` never turns a part further."""


SHAPE_CLIP = 0.25
"""Point-to-template distances (unit-box sizes) are clipped here before averaging: a few stray points do not
decide a shape fit (``flips``, ``upright``)."""


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


def _confident(labels: np.ndarray, confidence, min_confidence: float) -> np.ndarray:
    """``labels`` with those of points whose ``confidence`` is below ``min_confidence`` set to -1 (``confidence``
    ``None``: unchanged); :class:`InputError` unless there is one finite confidence per label."""
    if confidence is None:
        return labels
    return np.where(_checked_confidence(confidence, len(labels)) >= min_confidence, labels, -1)


def _symmetries(symmetry, K: int) -> list[str]:
    """The ``K`` part symmetries ``symmetry`` as a list (``None``: ``"none"`` each); :class:`InputError` on another count."""
    sym = ["none"] * K if symmetry is None else list(symmetry)
    if len(sym) != K:
        raise InputError(f"symmetry must name {K} parts, got {len(sym)}")
    return sym


def _check_range_settings(quantile: float, connect_factor: float | None) -> None:
    """:class:`InputError` unless ``quantile`` lies in ``[0, 0.5)`` and ``connect_factor`` is positive or ``None``."""
    if not 0.0 <= quantile < 0.5:
        raise InputError(f"quantile must lie in [0, 0.5), got {quantile!r}")
    if connect_factor is not None and not connect_factor > 0:
        raise InputError(f"connect_factor must be positive or None, got {connect_factor!r}")


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


_HALF_TURNS = np.stack([np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])])


def _checked_cloud(
    cam_from_part, size_m, points, labels, priors: CategoryPriors, quantile, connect_factor, confidence, min_confidence
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(T, S, points, labels)`` after the checks the slide and the hold share (:func:`ucope.stages.support._checked`,
    the priors' part count, ``quantile`` in ``[0, 0.5)``, a positive ``connect_factor``, one confidence per point),
    the labels of points below ``min_confidence`` set to -1."""
    T, S, pts, lab = _checked(cam_from_part, size_m, points, labels)
    if len(T) != priors.num_parts:
        raise InputError(f"cam_from_part must hold the {priors.num_parts} parts of the priors, got {len(T)}")
    if not 0.0 <= quantile < 0.5:
        raise InputError(f"quantile must lie in [0, 0.5), got {quantile!r}")
    if not connect_factor > 0.0:
        raise InputError(f"connect_factor must be positive, got {connect_factor!r}")
    return T, S, pts, _confident(lab, confidence, min_confidence)


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


def _checked_camera(camera) -> np.ndarray:
    """``camera`` as a finite ``(3,)`` float64 point; InputError otherwise (the turn's and the flip's check)."""
    cam = np.asarray(camera, dtype=np.float64)
    if cam.shape != (3,) or not np.isfinite(cam).all():
        raise InputError(f"camera must be a finite (3,) point, got shape {cam.shape}")
    return cam


def _subtree(priors: CategoryPriors, p: int) -> list[int]:
    """``p`` and every part below it in the joint tree, ``p`` first."""
    out = [p]
    for jp in priors.joints:  # parents before children
        if jp.parent in out and jp.child not in out:
            out.append(jp.child)
    return out


def _median_outside(points: np.ndarray, cam_from_box: np.ndarray, size: np.ndarray) -> float:
    """The median distance of ``points`` ``(N, 3)`` outside the box of extents ``size`` at ``cam_from_box`` (0 inside)."""
    local = np.abs((points - cam_from_box[:3, 3]) @ cam_from_box[:3, :3]) - 0.5 * size
    return float(np.median(np.linalg.norm(np.maximum(local, 0.0), axis=1)))


def weak_neighbours(labels, priors: CategoryPriors, weak_share: float, strong_share: float) -> list[tuple[int, int, int]]:
    """``[(j, w, o)]``: for each revolute joint ``j`` (in the priors' order) whose child is a leaf, or either of
    whose parts is the root of a two-part object, a part ``w`` (the child first) with fewer than ``weak_share``
    of the object's labelled points next to its neighbour ``o`` across the joint with at least ``strong_share``
    (``labels``: ``(P,)`` integers, values outside ``[0, K)`` belong to no part). The parts that
    :func:`seat_weak_parts` and :func:`ucope.stages.freespace.place_weak_parts` may move."""
    K = priors.num_parts
    lab = np.asarray(labels)
    count = np.bincount(lab[(lab >= 0) & (lab < K)].astype(np.int64), minlength=K)
    total = max(int(count.sum()), 1)
    parents = {jp.parent for jp in priors.joints}
    out = []
    for j, jp in enumerate(priors.joints):  # a handful of joints
        if jp.type != JointType.REVOLUTE:
            continue
        options = ([(jp.child, jp.parent)] if jp.child not in parents else []) + ([(jp.parent, jp.child)] if K == 2 else [])
        out += [(j, w, o) for w, o in options if count[w] < weak_share * total and count[o] >= strong_share * total]
    return out


def _hinged_centre(To: np.ndarray, So: np.ndarray, Rk: np.ndarray, Sk: np.ndarray, jp, k_is_parent: bool) -> tuple:
    """``(centre (3,), foot (3,))``: where part ``k`` (rotation ``Rk``, extents ``Sk``) has its centre when the
    point of joint ``jp``'s axis in its unit box (``pivot_in_parent`` / ``pivot_in_child`` times the extents)
    meets that point of its neighbour ``o`` (pose ``To``, extents ``So``), and that meeting point (``foot``)."""
    f_o, f_k = (jp.pivot_in_child, jp.pivot_in_parent) if k_is_parent else (jp.pivot_in_parent, jp.pivot_in_child)
    foot = To[:3, :3] @ (np.asarray(f_o) * So) + To[:3, 3]
    return foot - Rk @ (np.asarray(f_k) * Sk), foot


def box_surface_distance(cam_from_box, size_m, points) -> np.ndarray:
    """``(B, P)`` the distance (metres) of each point to each box's surface, inside or out.

    Args:
        cam_from_box: ``(B, 4, 4)`` rigid box poses; size_m: ``(B, 3)`` or ``(3,)`` full extents;
        points: ``(P, 3)``, all in one frame."""
    T = np.asarray(cam_from_box, np.float64)
    half = np.broadcast_to(0.5 * np.asarray(size_m, np.float64), (len(T), 3))[:, None, :]
    q = np.abs(np.einsum("bji,bpj->bpi", T[:, :3, :3], np.asarray(points, np.float64)[None] - T[:, None, :3, 3])) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    return outside + np.abs(np.minimum(q.max(-1), 0.0))


def _checked_scene(cam_from_part, size_m, joint_axis, points, labels, priors: CategoryPriors, camera, joint_pivot=None):
    """The inputs shared by :func:`place_weak_parts` and :func:`slide_weak_children` as float64 arrays (the poses a
    copy), checked: ``(T, S, u, pivots or None, points, labels, camera)``. Pivots may hold NaN (a joint without one)."""
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    u = np.asarray(joint_axis, dtype=np.float64)
    piv = None if joint_pivot is None else np.asarray(joint_pivot, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    lab = np.asarray(labels)
    K, J = priors.num_parts, priors.num_joints
    if T.shape != (K, 4, 4) or S.shape != (K, 3) or u.shape != (J, 3) or (piv is not None and piv.shape != (J, 3)):
        names, want = "cam_from_part, size_m, joint_axis", f"({K}, 4, 4), ({K}, 3), ({J}, 3)"
        got = f"{T.shape}, {S.shape}, {u.shape}" + ("" if piv is None else f", {piv.shape}")
        if piv is not None:
            names, want = names + " and joint_pivot", want + f", ({J}, 3)"
        raise InputError(f"{names} must have shapes {want}, got {got}")
    if pts.ndim != 2 or pts.shape[1] != 3 or lab.shape != (len(pts),) or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"points must have shape (P, 3) and labels (P,) integers, got {pts.shape} and {lab.shape} {lab.dtype}")
    if not (np.isfinite(T).all() and np.isfinite(S).all() and np.isfinite(u).all() and np.isfinite(pts).all()):
        raise InputError("cam_from_part, size_m, joint_axis and points must be finite")
    cam = np.zeros(3) if camera is None else _checked_camera(camera)
    if (S <= 0).any():
        raise InputError(f"size_m must be positive, got {S.tolist()}")
    return T, S, u, piv, pts, lab, cam
