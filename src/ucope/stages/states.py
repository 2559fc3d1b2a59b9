"""Joint states inside the category's limits, and the kinematic refinement.

Voting estimates every part and joint independently, so a voted child rotation is in general not its parent's
rotation turned about the joint axis. The articulation model (docs/conventions.md) says, for joint ``j`` with
parent ``p``, child ``c`` and canonical axis ``a_j`` in the parent frame (``JointPrior.axis_in_parent``):

    R_c = R_p Rot(a_j, q_j)   (revolute)        R_c = R_p   (prismatic)
    axis_cam_j = R_p a_j

:func:`kinematic_refine` finds the root rotation ``R_0`` and revolute states ``q`` minimising

    sum_k w_k ||R_k(R_0, q) - R^_k||_F^2  +  w_axis sum_j ||R_p(j) a_j - u^_j||^2

(``R^_k`` the voted rotations, ``u^_j`` the voted joint axes, sign-aligned with ``R^_p a_j``) by block
coordinate descent, each block in closed form: given ``q``, ``R_0`` is the orthogonal Procrustes solution of
``sum_k w_k R^_k G_k^T + w_axis sum_j u^_j (G_p(j) a_j)^T`` (``G_k`` the chain of joint rotations from the root
to part ``k``); given the rotations, each ``q_j`` is the angle about ``a_j`` closest to
``sum_{k in subtree(c)} w_k R_p^T R^_k H_k^T``. Translations, sizes and pivots are kept; prismatic states are
recomputed from the refined poses.

:func:`clamp_joint_states` brings states outside the limits onto them, moving the child;
:func:`settle_joint_states` reads every state off the final boxes and clamps it. Camera frame, metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses, revolute_angle
from ..geometry.transforms import closest_rotation, rotation_about_axis, rotation_angle_deg
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .faces import align_parts_to_faces


@dataclass(frozen=True)
class KinematicRefineParams:
    """Attributes:
    axis_weight: the weight of the voted joint axes against the part rotations (weighted by their vote scores).
    iters: block coordinate descent rounds.
    face_reset_max_deg: a root aligned to its faces (``align_faces``) and left within this angle of that rotation by
        the refinement is turned back onto it; farther (a flip or an upright carry turned it) it is aligned afresh
        (:func:`root_back_to_faces`).
    """

    axis_weight: float = 1.0
    iters: int = 10
    face_reset_max_deg: float = 30.0


_P = KinematicRefineParams()


def _checked_refine(poses, sizes, joints: dict, priors: CategoryPriors, part_weights) -> tuple:
    """``(T, S, U_hat, pivot, w)`` as float64 arrays after :func:`kinematic_refine`'s checks of its inputs."""
    K, J = priors.num_parts, priors.num_joints
    T = np.asarray(poses, dtype=np.float64)
    S = np.asarray(sizes, dtype=np.float64)
    if T.shape != (K, 4, 4) or S.shape != (K, 3) or not (np.all(np.isfinite(T)) and np.all(np.isfinite(S))):
        raise InputError(f"poses must be finite (K={K}, 4, 4) and sizes (K, 3), got {T.shape}, {S.shape}")
    U_hat = np.asarray(joints.get("joint_axis", np.zeros((0, 3))), dtype=np.float64).reshape(-1, 3)
    if U_hat.shape != (J, 3) or not np.all(np.isfinite(U_hat)):
        raise InputError(f"joints['joint_axis'] must be finite ({J}, 3), got {U_hat.shape}")
    pivot = np.asarray(joints.get("joint_pivot", np.full((J, 3), np.nan)), dtype=np.float64).reshape(J, 3)
    w = np.ones(K) if part_weights is None else np.asarray(part_weights, dtype=np.float64).reshape(K)
    if np.any(w < 0) or not np.all(np.isfinite(w)):
        raise InputError("part_weights must be non-negative and finite")
    return T, S, U_hat, pivot, w


def _tree(parent: np.ndarray, child: np.ndarray, K: int) -> tuple[list[int], dict[int, int], dict[int, list[int]]]:
    """``(order, joint_of, subtree)``: the parts parents first from the root 0, the joint above each part and each
    part's subtree (itself first); :class:`InputError` where the joints do not form a tree rooted at part 0."""
    J = len(parent)
    joint_of = {int(c): j for j, c in enumerate(child)}
    order, seen = [0], {0}
    while len(order) < K:
        grew = False
        for j in range(J):
            if int(parent[j]) in seen and int(child[j]) not in seen:
                order.append(int(child[j]))
                seen.add(int(child[j]))
                grew = True
        if not grew:
            raise InputError("the joints do not form a tree rooted at part 0")
    subtree = {k: [k] for k in range(K)}
    for k in reversed(order[1:]):
        subtree[int(parent[joint_of[k]])] += subtree[k]
    return order, joint_of, subtree


def _chains(q: np.ndarray, a: np.ndarray, parent: np.ndarray, revolute: np.ndarray, order, joint_of) -> np.ndarray:
    """``(K, 3, 3)`` the chain of joint rotations from the root to each part at the revolute states ``q``."""
    G = np.zeros((len(order), 3, 3))
    G[0] = np.eye(3)
    for k in order[1:]:
        j = joint_of[k]
        rot = rotation_about_axis(a[j], q[j]) if revolute[j] else np.eye(3)
        G[k] = G[parent[j]] @ rot
    return G


def kinematic_refine(
    poses,
    sizes,
    joints: dict,
    priors: CategoryPriors,
    part_weights=None,
    axis_weight: float = _P.axis_weight,
    iters: int = _P.iters,
) -> dict[str, np.ndarray]:
    """Consistent part rotations, joint axes and states (see the module docstring).

    Args:
        poses: ``(K, 4, 4)`` voted ``cam_from_part``; sizes: ``(K, 3)`` voted sizes.
        joints: dict with ``joint_axis`` ``(J, 3)`` (voted, camera frame) and optionally
            ``joint_pivot`` ``(J, 3)`` (kept).
        priors: the category's priors (tree, joint types, canonical axes, prismatic zero offsets).
        part_weights: ``(K,)`` non-negative weights of the voted rotations (default 1 each).
        axis_weight: weight of each voted joint axis (same units as a part weight).
        iters: block coordinate descent sweeps.

    Returns:
        dict: ``cam_from_part`` ``(K, 4, 4)`` (rotations refined, translations as voted),
        ``joint_axis`` ``(J, 3)`` (``R_parent a_j``), ``joint_pivot`` ``(J, 3)`` (as given, or NaN),
        ``joint_state`` ``(J,)`` (radians / metres).

    Raises:
        InputError: shapes that do not match the priors, non-finite values, negative weights, joints that do not
            form a tree rooted at part 0.
    """
    K, J = priors.num_parts, priors.num_joints
    T, S, U_hat, pivot, w = _checked_refine(poses, sizes, joints, priors, part_weights)
    out_T = T.copy()
    if J == 0:
        return dict(cam_from_part=out_T, joint_axis=np.zeros((0, 3)), joint_pivot=np.zeros((0, 3)), joint_state=np.zeros(0))
    a = priors.joint_axes
    parent = np.array([jp.parent for jp in priors.joints])
    child = np.array([jp.child for jp in priors.joints])
    revolute = np.array([jp.type == JointType.REVOLUTE for jp in priors.joints])
    R_hat = T[:, :3, :3]
    U_hat = U_hat / np.linalg.norm(U_hat, axis=-1, keepdims=True).clip(1e-12)
    for j in range(J):  # the joint heads' axis sign may disagree with the canonical axis: align it
        if U_hat[j] @ (R_hat[parent[j]] @ a[j]) < 0:
            U_hat[j] = -U_hat[j]
    order, joint_of, subtree = _tree(parent, child, K)
    q = np.zeros(J)
    for j in range(J):
        if revolute[j]:
            q[j] = revolute_angle(R_hat[parent[j]].T @ R_hat[child[j]], a[j])
    R0 = R_hat[0]
    for _ in range(int(iters)):
        G = _chains(q, a, parent, revolute, order, joint_of)
        M = np.einsum("k,kij,klj->il", w, R_hat, G) + axis_weight * sum(np.outer(U_hat[j], G[parent[j]] @ a[j]) for j in range(J))
        R0 = closest_rotation(M)
        R = R0 @ G
        for j in range(J):
            if not revolute[j]:
                continue
            Rp = R[parent[j]]
            N = np.zeros((3, 3))
            for k in subtree[int(child[j])]:
                H = R[child[j]].T @ R[k]  # the chain below the child (fixed while q_j changes)
                N += w[k] * Rp.T @ R_hat[k] @ H.T
            q[j] = revolute_angle(N, a[j]) if np.any(N) else q[j]
            R = R0 @ _chains(q, a, parent, revolute, order, joint_of)
    R = R0 @ _chains(q, a, parent, revolute, order, joint_of)
    out_T[:, :3, :3] = R
    axis = np.stack([R[parent[j]] @ a[j] for j in range(J)])
    state = q.copy()
    for j, jp in enumerate(priors.joints):
        if jp.type == JointType.PRISMATIC:
            state[j] = joint_state_from_poses(
                out_T[parent[j]], out_T[child[j]], axis[j], JointType.PRISMATIC, S[parent[j]], S[child[j]], jp.zero_offset_m
            )
    return dict(cam_from_part=out_T, joint_axis=axis, joint_pivot=pivot, joint_state=state)


def clamp_joint_states(
    cam_from_part: np.ndarray, joint_axis: np.ndarray, joint_pivot: np.ndarray, joint_state: np.ndarray, priors: CategoryPriors
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bring joint states that voting put outside the category's limits back onto them, moving the child.

    A state is measured about the voted joint axis ``u``; the limits about the canonical one ``R_p a``
    (``JointPrior.axis_in_parent``). A state outside its limits (a hidden drawer pulled out further than
    any drawer opens) is set to the nearest limit and the child moves with it: along ``u`` (prismatic) or
    about the axis line through the voted pivot (revolute). Prismatic joints whose voted axis points
    against the canonical one are left alone (their support gap is not the state then).

    Args:
        cam_from_part: ``(K, 4, 4)``; joint_axis, joint_pivot: ``(J, 3)`` camera frame; joint_state: ``(J,)``.
        priors: the category's priors (limits, canonical axes).

    Returns:
        ``(cam_from_part, joint_state, clamped)``: copies, and ``(J,)`` bool, the joints clamped.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    q = np.array(joint_state, dtype=np.float64)
    clamped = np.zeros(len(q), dtype=bool)
    for j, jp in enumerate(priors.joints):  # parents first: a moved child carries nothing else along here
        lo, hi = jp.limits
        u = np.asarray(joint_axis[j], dtype=np.float64)
        canon = T[jp.parent, :3, :3] @ jp.axis
        sign = 1.0 if float(u @ canon) >= 0 else -1.0
        if jp.type == JointType.PRISMATIC and sign < 0:
            continue
        qc = sign * q[j]
        target = min(max(qc, -np.inf if lo is None else lo), np.inf if hi is None else hi)
        if abs(target - qc) < 1e-9:
            continue
        delta = sign * (target - qc)  # the change of the state about u
        if jp.type == JointType.PRISMATIC:
            T[jp.child, :3, 3] += delta * u / np.linalg.norm(u)
        else:
            piv = np.asarray(joint_pivot[j], dtype=np.float64)
            if not np.all(np.isfinite(piv)):
                piv = T[jp.parent, :3, 3]
            R = rotation_about_axis(u, delta)
            T[jp.child, :3, :3] = R @ T[jp.child, :3, :3]
            T[jp.child, :3, 3] = R @ (T[jp.child, :3, 3] - piv) + piv
        q[j] += delta
        clamped[j] = True
    return T, q, clamped


def settle_joint_states(
    cam_from_part, size_m, joint_axis, joint_pivot, priors: CategoryPriors
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint states read off the final part poses and boxes, then clamped into the category's limits.

    The states voting reports are measured before the stages that move boxes afterwards, and the refinement may take
    a clamped state back outside the limits. Here each state is measured again from ``cam_from_part`` and ``size_m``
    about the voted axis (:func:`ucope.geometry.kinematics.joint_state_from_poses`: a revolute angle about
    ``joint_axis``, a prismatic support gap less ``zero_offset_m``), then :func:`clamp_joint_states` brings those
    outside the limits onto them and moves the child with them.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres); size_m: ``(K, 3)`` box extents.
        joint_axis, joint_pivot: ``(J, 3)`` the voted axes (unit, camera frame) and pivots (metres).
        priors: the category's priors (tree, types, limits, canonical axes, prismatic zero offsets).

    Returns:
        ``(cam_from_part, joint_state, clamped)``: a ``(K, 4, 4)`` copy with clamped children moved, ``(J,)``
        states (radians or metres), ``(J,)`` bool, the joints clamped.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses, sizes or axes.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    u = np.asarray(joint_axis, dtype=np.float64)
    piv = np.asarray(joint_pivot, dtype=np.float64)
    K, J = priors.num_parts, priors.num_joints
    if T.shape != (K, 4, 4) or S.shape != (K, 3) or u.shape != (J, 3) or piv.shape != (J, 3):
        raise InputError(
            f"cam_from_part, size_m, joint_axis and joint_pivot must have shapes ({K}, 4, 4), ({K}, 3), ({J}, 3), "
            f"({J}, 3), got {T.shape}, {S.shape}, {u.shape}, {piv.shape}"
        )
    if not (np.isfinite(T).all() and np.isfinite(S).all() and np.isfinite(u).all()):
        raise InputError("cam_from_part, size_m and joint_axis must be finite")
    q = np.array(
        [
            joint_state_from_poses(T[jp.parent], T[jp.child], u[j], jp.type, S[jp.parent], S[jp.child], jp.zero_offset_m)
            for j, jp in enumerate(priors.joints)  # a handful of joints
        ],
        dtype=np.float64,
    )
    return clamp_joint_states(T, u, piv, q, priors)


def root_back_to_faces(
    T: np.ndarray, joint_axis: np.ndarray, faces: tuple, priors: CategoryPriors, max_deg: float = _P.face_reset_max_deg
):
    """The refined tree turned as one so that its root is on its faces again: back onto the root's rotation aligned
    before the joints when the refinement left it within ``max_deg`` of it, else aligned afresh
    (:func:`ucope.stages.faces.align_parts_to_faces`) from where the refinement put it. Every other part follows
    through the tree, the joint axes too, so states and consistency are kept.

    Args:
        T: ``(K, 4, 4)`` refined part poses (camera frame); joint_axis: ``(J, 3)``.
        faces: ``(normals (P, 3), part_points, aligned root rotation (3, 3))``, what ``align_faces`` measured
            (``PoseState.face_frame``).
        priors: the category's priors (tree, symmetries).

    Returns:
        ``(cam_from_part, joint_axis, turned)``: float64 copies and ``(K,)`` bool (every part or none).
    """
    T = np.array(T, np.float64)
    R_ref, R_aligned = T[0, :3, :3].copy(), faces[2]
    if rotation_angle_deg(R_aligned, R_ref) <= max_deg:
        turn = R_aligned @ R_ref.T
    else:
        tree = [(jp.child, jp.parent) for jp in priors.joints]
        T2, _ = align_parts_to_faces(T, faces[0], faces[1], [p.symmetry for p in priors.parts], tree)
        turn = T2[0, :3, :3] @ R_ref.T
    T[:, :3, :3] = np.einsum("ij,kjl->kil", turn, T[:, :3, :3])
    turned = np.full(len(T), not np.allclose(turn, np.eye(3)))
    return T, np.asarray(joint_axis, np.float64) @ turn.T, turned


@stage("kinematic_refine", kind="geometry", params=KinematicRefineParams, applies=lambda priors: priors.num_joints > 0)
def _kinematic_refine(state: PoseState, params: KinematicRefineParams) -> None:
    """Rotations, joint axes and revolute states made consistent along the tree (a weighted least-squares fit to
    the voted rotations and axes); a root aligned to its faces is put back on them."""
    joints = {"joint_axis": state.joint_axis, "joint_pivot": state.joint_pivot, "joint_state": state.joint_state}
    weights = np.maximum(state.votes["score"], 1e-3)
    r = kinematic_refine(
        state.cam_from_part,
        state.size_m,
        joints,
        state.priors,
        part_weights=weights,
        axis_weight=params.axis_weight,
        iters=params.iters,
    )
    state.cam_from_part, state.joint_axis, state.joint_state = r["cam_from_part"], r["joint_axis"], r["joint_state"]
    if state.face_frame is not None:
        state.cam_from_part, state.joint_axis, _ = root_back_to_faces(
            state.cam_from_part, state.joint_axis, state.face_frame, state.priors, params.face_reset_max_deg
        )
