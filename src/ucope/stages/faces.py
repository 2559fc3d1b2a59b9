"""Part rotations aligned to the flat faces their points show.

Most parts are boxes or plates whose visible faces are parallel to the faces of their box: a surface normal
seen on a part lies close to one of its box axes ``+-x, +-y, +-z``. :func:`align_to_faces` matches each normal
to the nearest signed box axis (within ``tolerance_deg``), finds the rotation that best turns the matched axes
onto the normals (Wahba's problem, :meth:`scipy.spatial.transform.Rotation.align_vectors`) and repeats from it.
Each round is a damped step: the three axes of the last round count as pairs too, each weighing
``prior_weight`` times the number of matched normals, so that what the normals do not fix (the turn about a
single face's normal) stays where voting put it. Normals that match no axis drop out. The rotation turns about
the box centre; centre and size are kept. Parts symmetric about y and parts with fewer than ``min_points``
matched normals are left alone. Normals in the camera frame (any sign or length).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from ..geometry.normals import estimate_normals
from ..vocab import JointType
from .base import PoseState, stage


@dataclass(frozen=True)
class AlignFacesParams:
    """Attributes:
    tolerance_deg: a normal counts for the signed box axis nearest to it when within this angle of it.
    iterations: rounds of matching and solving (the matches change as the rotation moves).
    prior_weight: weight of each of the last round's axes in a round, per matched normal (0.1: ten matched normals
        weigh as much as one axis).
    min_points: a part with fewer matched normals keeps its voted rotation.
    normal_k: neighbours of a normal among the network's points (:func:`face_normals`), scaled to the share of
        distinct points, never fewer than ``sparse_min_k``.
    """

    tolerance_deg: float = 20.0
    iterations: int = 5
    prior_weight: float = 0.1
    min_points: int = 30
    normal_k: int = 16
    sparse_min_k: int = 6


_P = AlignFacesParams()


def face_normals(points: np.ndarray, k: int = _P.normal_k, min_k: int = _P.sparse_min_k) -> np.ndarray:
    """Normals for :func:`align_to_faces`: PCA over each point's nearest neighbours among ``points``, each
    distinct point counted once, and as many of them as ``k`` is of ``P`` (at least ``min_k``): a sparse cloud
    reaches the network's point count by repeating points, and a neighbourhood of copies of two or three points
    has no normal.

    Args:
        points: ``(P, 3)`` camera frame, metres, at least 3 distinct points; k: neighbours of a point in a
            cloud of distinct points (clipped to their number); min_k: the fewest neighbours.

    Returns:
        ``(P, 3)`` unit normals, any sign; repeated points share one.

    Raises:
        InputError: wrong shape, non-finite values, fewer than 3 distinct points.
    """
    pts = np.asarray(points, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (P, 3), got {pts.shape}")
    uniq, inverse = np.unique(pts, axis=0, return_inverse=True)
    k = max(int(min_k), round(int(k) * len(uniq) / len(pts)))  # the same share of the object's points
    return estimate_normals(uniq, k=min(k, len(uniq)), viewpoint=None)[inverse.reshape(-1)]


def align_to_faces(
    cam_from_part_rot: np.ndarray,
    normals: np.ndarray,
    tolerance_deg: float = _P.tolerance_deg,
    iterations: int = _P.iterations,
    prior_weight: float = _P.prior_weight,
    min_points: int = _P.min_points,
) -> tuple[np.ndarray, int]:
    """A part's rotation turned so that its box axes meet the surface normals of its points.

    Args:
        cam_from_part_rot: ``(3, 3)`` the voted rotation (columns: the part's x, y, z axes in the camera
            frame).
        normals: ``(N, 3)`` normals of the part's points, camera frame (the sign does not matter;
            zero-length rows are ignored).
        tolerance_deg: in ``(0, 45]``; a normal matches the nearest signed axis within this angle.
        iterations: rounds (>= 1).
        prior_weight: >= 0; each voted axis weighs this times the number of matched normals.
        min_points: the fewest matched normals that may move the rotation (>= 1).

    Returns:
        ``(rotation (3, 3), matched)``: the aligned rotation (the voted one when fewer than
        ``min_points`` normals match) and the number of normals matched in the last round.

    Raises:
        InputError: wrong shapes, non-finite values, a rotation that is not one, a setting out of range.
    """
    R = np.asarray(cam_from_part_rot, np.float64)
    n = np.asarray(normals, np.float64)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise InputError(f"cam_from_part_rot must be a finite (3, 3) rotation, got shape {R.shape}")
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-4) or np.linalg.det(R) < 0:
        raise InputError("cam_from_part_rot must be a rotation (orthonormal, determinant +1)")
    if n.ndim != 2 or n.shape[1] != 3:
        raise InputError(f"normals must have shape (N, 3), got {n.shape}")
    if not np.all(np.isfinite(n)):
        raise InputError("normals contain NaN or Inf")
    if not 0.0 < tolerance_deg <= 45.0:
        raise InputError(f"tolerance_deg must lie in (0, 45], got {tolerance_deg!r}")
    if int(iterations) < 1 or int(min_points) < 1 or not prior_weight >= 0.0:
        raise InputError(
            f"iterations and min_points must be >= 1 and prior_weight >= 0, got {iterations!r}, {min_points!r}, {prior_weight!r}"
        )
    length = np.linalg.norm(n, axis=1)
    n = n[length > 1e-9] / length[length > 1e-9, None]
    cos_tol = np.cos(np.radians(tolerance_deg))
    R_new, matched = R, 0
    for _ in range(int(iterations)):
        local = n @ R_new  # each normal in the part frame
        axis = np.abs(local).argmax(axis=1)
        comp = local[np.arange(len(local)), axis]
        keep = np.abs(comp) >= cos_tol
        matched = int(keep.sum())
        if matched < min_points:
            return R, matched
        target = np.zeros((matched, 3))
        target[np.arange(matched), axis[keep]] = np.sign(comp[keep])
        # R_new minimises sum w |a - R b|^2 over the matched (normal, signed axis) pairs and the prior's
        # (axis of the last round, axis) pairs: a damped step, so that what the normals fix converges to
        # them over the rounds while what they do not fix stays where voting put it
        a = np.concatenate([n[keep], R_new.T])
        b = np.concatenate([target, np.eye(3)])
        w = np.concatenate([np.ones(matched), np.full(3, prior_weight * matched)])
        R_new = Rotation.align_vectors(a, b, weights=w)[0].as_matrix()
    return R_new, matched


def align_parts_to_faces(
    cam_from_part: np.ndarray,
    normals: np.ndarray,
    part_points: Sequence[np.ndarray],
    symmetry: Sequence[str],
    follow: Sequence[tuple[int, int]] = (),
    **options,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`align_to_faces` for every part of an object, each with the normals of its own points.

    A part joined to its parent by a prismatic joint keeps its rotation relative to the parent (a drawer
    slides, it does not turn): listed in ``follow`` it takes the turn of its parent's alignment instead
    of one of its own.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted part poses (camera frame, metres).
        normals: ``(P, 3)`` normals of the points (camera frame, any sign).
        part_points: ``K`` index arrays into ``normals``: the points of each part.
        symmetry: ``K`` part symmetries (``"y"`` parts are left alone).
        follow: ``(child, parent)`` part index pairs, parents before their children (the order of
            ``CategoryPriors.joints``): the child takes the parent's turn.
        options: passed on to :func:`align_to_faces`.

    Returns:
        ``(cam_from_part (K, 4, 4), turned (K,) bool)``: the poses with aligned rotations (translations
        kept) and the parts whose rotation moved.

    Raises:
        InputError: as :func:`align_to_faces`, lengths that do not match, a ``follow`` pair that names no
            part or a child twice.
    """
    T = np.array(cam_from_part, np.float64)
    normals = np.asarray(normals, np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"cam_from_part must have shape (K, 4, 4), got {T.shape}")
    K = len(T)
    if len(symmetry) != K or len(part_points) != K:
        raise InputError(f"symmetry and part_points must have one entry per part ({K}), got {len(symmetry)}, {len(part_points)}")
    pairs = [(int(c), int(p)) for c, p in follow]
    children = [c for c, _ in pairs]
    if any(not (0 <= c < K and 0 <= p < K and c != p) for c, p in pairs) or len(set(children)) != len(children):
        raise InputError(
            f"follow must hold (child, parent) pairs of distinct part indices below {K}, each child once; got {pairs}"
        )
    old = T[:, :3, :3].copy()
    for k in sorted(set(range(K)) - set(children)):  # a handful of parts; vectorised over points
        if symmetry[k] != "y":
            T[k, :3, :3], _ = align_to_faces(old[k], normals[np.asarray(part_points[k], dtype=np.int64)], **options)
    for c, p in pairs:  # the parent's turn, camera frame: R_c <- (R_p,new R_p,old^T) R_c
        T[c, :3, :3] = T[p, :3, :3] @ old[p].T @ old[c]
    turned = np.array([not np.allclose(T[k, :3, :3], old[k]) for k in range(K)], dtype=bool)
    return T, turned


@stage("align_faces", kind="geometry", params=AlignFacesParams)
def _align_faces(state: PoseState, params: AlignFacesParams) -> None:
    """Each part's rotation turned so that its box axes meet the normals of its flat faces (a drawer takes its
    cabinet's turn)."""
    nrm = face_normals(np.asarray(state.points, np.float64).reshape(-1, 3), params.normal_k, params.sparse_min_k)
    follow = [(j.child, j.parent) for j in state.priors.joints if j.type == JointType.PRISMATIC]
    state.cam_from_part, _ = align_parts_to_faces(
        state.cam_from_part,
        nrm,
        state.part_points,
        state.symmetry,
        follow,
        tolerance_deg=params.tolerance_deg,
        iterations=params.iterations,
        prior_weight=params.prior_weight,
        min_points=params.min_points,
    )
    state.face_frame = (nrm, state.part_points, np.array(state.cam_from_part[0, :3, :3], np.float64))
