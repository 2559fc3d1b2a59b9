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
from ..geometry.transforms import rotation_angle_deg
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage

FACE_TOLERANCE_DEG = 20.0
"""A normal counts for the box axis nearest to it when within this angle of it."""


FACE_ITERATIONS = 5
"""Rounds of matching and solving (the matches change as the rotation moves)."""


FACE_PRIOR_WEIGHT = 0.1
"""Weight of each of the last round's axes in a round, per matched normal (0.1: ten matched normals weigh
as much as one axis)."""


FACE_NORMAL_K = 16
"""Neighbours of the normals the alignment uses, which :func:`ucope.voting.vote_object` estimates among the
network's points (1,024), not in the input cloud (4,096: the normals the network is given). Quantised depth
lays a far, slanted face out in terraces of constant depth, and neighbourhoods of the dense cloud, each
within one terrace, lean towards the camera's axis: by about 20 degrees on the side panel of a cabinet
2.8 m away (depth steps of about 4.5 cm), where the alignment then locked onto them. Measured on 200
test views each (success %, median rotation of the first part in degrees), input-cloud normals / 16 / 32 /
64 neighbours among the network's points: drawer 37.5, 1.6 / 40.5, 1.9 / 39.5, 1.8 / 37, 2.2; camera 99,
1.2 / 99, 1.5 / 98, 2.1 / 96.5, 3.0; dishwasher 83.5, 1.1 / 83, 0.7 / 82.5, 0.7 / 82.5, 1.2."""


FACE_SPARSE_MIN_K = 6
"""Fewest neighbours of a normal in a sparse cloud (:func:`face_normals`)."""


FACE_MIN_POINTS = 30
"""A part with fewer matched normals than this keeps its voted rotation."""


def face_normals(points: np.ndarray, k: int = FACE_NORMAL_K) -> np.ndarray:
    """Normals for :func:`align_to_faces`: PCA over each point's nearest neighbours among ``points``, each
    distinct point counted once, and as many of them as ``k`` is of ``P`` (at least
    :data:`FACE_SPARSE_MIN_K`): a sparse cloud reaches the network's point count by repeating points, and a
    neighbourhood of copies of two or three points has no normal. On the robustness benchmark's 100-point
    level (40 views, success %), with repeats / distinct points and 16 neighbours / this: camera 28 / 42 /
    60, dishwasher 15 / 25 / 32; at 200 points 80 / 75 / 80 and 50 / 42 / 45.

    Args:
        points: ``(P, 3)`` camera frame, metres, at least 3 distinct points; k: neighbours of a point in a
            cloud of distinct points (clipped to their number).

    Returns:
        ``(P, 3)`` unit normals, any sign; repeated points share one.

    Raises:
        InputError: wrong shape, non-finite values, fewer than 3 distinct points.
    """
    pts = np.asarray(points, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (P, 3), got {pts.shape}")
    uniq, inverse = np.unique(pts, axis=0, return_inverse=True)
    k = max(FACE_SPARSE_MIN_K, round(int(k) * len(uniq) / len(pts)))  # the same share of the object's points
    return estimate_normals(uniq, k=min(k, len(uniq)), viewpoint=None)[inverse.reshape(-1)]


def align_to_faces(
    cam_from_part_rot: np.ndarray,
    normals: np.ndarray,
    tolerance_deg: float = FACE_TOLERANCE_DEG,
    iterations: int = FACE_ITERATIONS,
    prior_weight: float = FACE_PRIOR_WEIGHT,
    min_points: int = FACE_MIN_POINTS,
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
    of one of its own (a drawer's few front-plate normals fix it worse than the cabinet's do: on 100 test
    views of the drawer, aligned on their own the drawers were within 10 degrees in 73-78 % of the
    views against 82 % voted, while the cabinet went 82 -> 86 %).

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


FACE_RESET_MAX_DEG = 30.0
"""After the kinematic refinement, an aligned root within this angle of its aligned rotation is turned back
onto it (the refinement moved it); farther (a flip or an upright carry turned it) it is aligned afresh."""


def root_back_to_faces(T: np.ndarray, joint_axis: np.ndarray, faces: tuple, priors: CategoryPriors):
    """The refined tree turned as one so that its root is on its faces again: back onto the root's rotation
    aligned before the joints (``faces[2]``) when the refinement left it within :data:`FACE_RESET_MAX_DEG`,
    else aligned afresh from where the refinement put it (every other part follows through the tree, the
    joint axes too, so states and consistency are kept). Aligning afresh from the refined rotation instead
    let the cabinet lock onto normals that lean off its faces (a far side panel's, quantised in depth:
    :data:`ucope.stages.faces.FACE_NORMAL_K`) on some drawer views: the refinement had moved it 5-10
    degrees, enough to bring them inside the matching cone."""
    T = np.array(T, np.float64)
    R_ref, R_aligned = T[0, :3, :3].copy(), faces[2]
    if rotation_angle_deg(R_aligned, R_ref) <= FACE_RESET_MAX_DEG:
        turn = R_aligned @ R_ref.T
    else:
        tree = [(jp.child, jp.parent) for jp in priors.joints]
        T2, _ = align_parts_to_faces(T, faces[0], faces[1], [p.symmetry for p in priors.parts], tree)
        turn = T2[0, :3, :3] @ R_ref.T
    T[:, :3, :3] = np.einsum("ij,kjl->kil", turn, T[:, :3, :3])
    turned = np.full(len(T), not np.allclose(turn, np.eye(3)))
    return T, np.asarray(joint_axis, np.float64) @ turn.T, turned


@dataclass(frozen=True)
class AlignFacesParams:
    """Attributes: as :func:`align_to_faces`."""

    tolerance_deg: float = FACE_TOLERANCE_DEG
    iterations: int = FACE_ITERATIONS
    prior_weight: float = FACE_PRIOR_WEIGHT
    min_points: int = FACE_MIN_POINTS


@stage("align_faces", kind="geometry", params=AlignFacesParams)
def _align_faces(state: PoseState, params: AlignFacesParams) -> None:
    """Each part's rotation turned so that its box axes meet the normals of its flat faces (a drawer takes its
    cabinet's turn)."""
    nrm = face_normals(np.asarray(state.points, np.float64).reshape(-1, 3))
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
