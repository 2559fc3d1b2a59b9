"""Opt-in kinematic refinement: make part rotations, joint axes and joint states consistent.

Voting estimates every part and joint independently, so a voted child rotation is in general not its
parent's rotation turned about the joint axis, and the voted joint axis is not the parent's canonical
axis. The articulation model (docs/conventions.md) says, for joint ``j`` with parent ``p``, child ``c``
and canonical axis ``a_j`` in the parent frame (``ModelConfig.joint_axes_in_parent``; the rotation of
``parent_from_child_zero`` is the identity):

    R_c = R_p Rot(a_j, q_j)   (revolute)        R_c = R_p   (prismatic)
    axis_cam_j = R_p a_j

:func:`kinematic_refine` finds the root rotation ``R_0`` and revolute states ``q`` minimising

    sum_k w_k ||R_k(R_0, q) - R^_k||_F^2  +  w_axis sum_j ||R_p(j) a_j - u^_j||^2

(``R^_k`` the voted rotations, ``u^_j`` the voted joint axes, sign-aligned with ``R^_p a_j``; every
``R_k`` follows from ``R_0`` and ``q`` down the tree) by block coordinate descent, each block in
closed form: given ``q``, ``R_0`` is the orthogonal Procrustes solution (SVD) of
``sum_k w_k R^_k G_k^T + w_axis sum_j u^_j (G_p(j) a_j)^T`` (``G_k`` the chain of joint rotations from the
root to part ``k``); given the rotations, each ``q_j`` is the angle of the rotation about ``a_j`` closest
to ``sum_{k in subtree(c)} w_k R_p^T R^_k H_k^T`` (``H_k`` the chain below ``c``). So the revolute axis
becomes a weighted compromise between the voted parent rotation, the voted child rotation(s) and the
voted joint axis. Translations and sizes are left as voted; pivots are kept as voted (the axis line
keeps its voted point); prismatic states are recomputed from the refined poses
(:func:`ucope.geometry.kinematics.joint_state_from_poses`).

Off by default in the estimator: whether it helps depends on how good the joint heads are relative to
the part votes, and is measured on real predictions elsewhere (docs/voting.md).
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses, revolute_angle
from ..geometry.transforms import rotation_about_axis
from ..model.config import ModelConfig

__all__ = ["kinematic_refine", "canonical_joint_axes", "resolve_joint_flips", "resolve_shape_flips"]


def canonical_joint_axes(cfg: ModelConfig) -> np.ndarray:
    """``(J, 3)`` unit joint axes in their parents' frames: ``cfg.joint_axes_in_parent``, or (older
    configurations) those of the category's generator."""
    if cfg.joint_axes_in_parent:
        ax = np.asarray(cfg.joint_axes_in_parent, dtype=np.float64)
    else:
        from ..objects.categories import make_instance

        ax = np.stack([j.axis for j in make_instance(cfg.category, "train", 0).joints]) if cfg.num_joints else np.zeros((0, 3))
    if ax.shape != (cfg.num_joints, 3):
        raise InputError(f"the configuration has {cfg.num_joints} joints but {len(ax)} canonical axes")
    return ax / np.linalg.norm(ax, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=32)
def _generator_limits(category: str) -> tuple[tuple[float, float], ...]:
    from ..objects.categories import make_instance

    return tuple((float(j.limits[0]), float(j.limits[1])) for j in make_instance(category, "train", 0).joints)


_HALF_TURNS = np.stack([np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])])


@functools.lru_cache(maxsize=32)
def _placement_templates(category: str) -> np.ndarray:
    """``(J, 2, 3)``: for joint ``j``, the mean position of the child's box centre in the parent's frame
    divided by the parent's box diagonal (``[j, 0]``), and of the parent's centre in the child's frame
    divided by the child's box diagonal (``[j, 1]``), over 8 training instances of the category's generator at 5 joint states
    spread over their limits."""
    from ..objects.categories import make_instance

    objs = [make_instance(category, "train", i) for i in range(8)]
    J = len(objs[0].joints)
    acc = np.zeros((J, 2, 3))
    n = 0
    for obj in objs:
        lo, hi = obj.limits[:, 0], obj.limits[:, 1]
        for f in np.linspace(0.0, 1.0, 5):
            T = obj.object_from_part(lo + f * (hi - lo))
            S = obj.size_m
            for j, jt in enumerate(obj.joints):
                p, c = jt.parent, jt.child
                acc[j, 0] += T[p, :3, :3].T @ (T[c, :3, 3] - T[p, :3, 3]) / np.linalg.norm(S[p])
                acc[j, 1] += T[c, :3, :3].T @ (T[p, :3, 3] - T[c, :3, 3]) / np.linalg.norm(S[c])
            n += 1
    return acc / n


def _placement_flips(T: np.ndarray, size: np.ndarray, cfg: ModelConfig, flipped: np.ndarray) -> None:
    """Turn (in place) each part by the half turn about one of its axes that best puts its neighbours'
    voted centres where the category has them (:func:`_placement_templates`), when that at least halves
    the misfit and lowers it by 0.1 (box diagonals as units)."""
    E = _placement_templates(cfg.category)
    for k in range(T.shape[0]):  # a handful of parts
        links = [(j, 0, cfg.joint_children[j]) for j in range(cfg.num_joints) if cfg.joint_parents[j] == k]
        links += [(j, 1, cfg.joint_parents[j]) for j in range(cfg.num_joints) if cfg.joint_children[j] == k]
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


@functools.lru_cache(maxsize=32)
def _shape_templates(category: str, instances: int = 8, points: int = 512):
    """Per part, a k-d tree of surface points of ``instances`` training instances of the category's
    generator, in the part frame divided by the part's box size (so in the unit box)."""
    import trimesh
    from scipy.spatial import cKDTree

    from ..objects.categories import make_instance

    objs = [make_instance(category, "train", i) for i in range(instances)]
    out = []
    for k in range(objs[0].num_parts):
        pts = [np.asarray(trimesh.sample.sample_surface(o.parts[k].mesh, points, seed=i)[0]) / o.parts[k].size_m
               for i, o in enumerate(objs)]
        out.append(cKDTree(np.concatenate(pts)))
    return out


def resolve_shape_flips(cam_from_part: np.ndarray, size_m: np.ndarray, points: np.ndarray, part_points: list,
                        cfg: ModelConfig, margin: float = 0.75, clip: float = 0.25, max_points: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """Turn back parts whose voted rotation is a half turn (about one of the part's axes) away from
    the pose their own points fit best (beyond the paper).

    A box is unchanged by those half turns, and the votes cannot always tell them apart (a camera's
    lens side from its screen side). Each part's points are brought into its voted frame and unit
    box, turned by each half turn, and compared with the category's shape (surface points of training
    instances, :func:`_shape_templates`): mean distance to the nearest template point, clipped at
    ``clip`` box sizes. The best half turn replaces the voted one when its misfit is below
    ``margin`` times the voted one's. Parts symmetric about y are left alone. At most ``max_points``
    of a part's points (evenly strided) are compared, all half turns in one k-d tree query.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses; size_m: ``(K, 3)`` voted sizes.
        points: ``(N, 3)`` camera frame, metres; part_points: per part, indices into ``points``.

    Returns:
        ``(cam_from_part, turned)``: new poses (a copy) and ``(K,)`` bool, the parts turned.
    """
    T = np.array(cam_from_part, dtype=np.float64, copy=True)
    turned = np.zeros(len(T), dtype=bool)
    trees = _shape_templates(cfg.category)
    for k in range(len(T)):  # a handful of parts
        idx = np.asarray(part_points[k])
        if cfg.part_symmetry[k] == "y" or len(idx) < 16:
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


def _range_distance(q: float, lo: float, hi: float) -> float:
    """How far the angle ``q`` (any turn) lies outside ``[lo, hi]`` (0 inside), radians."""
    q = (q - lo) % (2 * np.pi) + lo  # into [lo, lo + 2 pi)
    return 0.0 if q <= hi else min(q - hi, lo + 2 * np.pi - q)


def resolve_joint_flips(cam_from_part: np.ndarray, joint_axis: np.ndarray, cfg: ModelConfig, size_m: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
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
    part's frame, in units of its box diagonal, averaged over the generator's instances and joint range): the
    half turn of an eyeglasses front about its hinge axis puts the temples in front of it.

    The limits and placements are the category generator's. Joints are visited parent first; prismatic
    joints are left alone by the two joint rules.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses; joint_axis: ``(J, 3)`` the joint heads' axes (camera).
        cfg: the model configuration (joint tree and canonical axes).
        size_m: ``(K, 3)`` the voted box sizes (for the placement check; ``None`` skips it).

    Returns:
        ``(cam_from_part, flipped)``: corrected poses (a copy) and ``(K,)`` bool, the parts turned.
    """
    from ..geometry.kinematics import revolute_angle

    T = np.array(cam_from_part, dtype=np.float64)
    K = T.shape[0]
    flipped = np.zeros(K, dtype=bool)
    axes = canonical_joint_axes(cfg)
    limits = _generator_limits(cfg.category)
    basis = np.eye(3)
    if size_m is not None and cfg.num_joints > 0:
        _placement_flips(T, np.asarray(size_m, dtype=np.float64), cfg, flipped)
    for j in range(cfg.num_joints):  # a handful of joints, parents before children in every category
        if cfg.joint_types[j] != 0:
            continue
        p, c, a = cfg.joint_parents[j], cfg.joint_children[j], axes[j]
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
                key = (round(_range_distance(q, *limits[j]), 6), float(np.linalg.norm(rel - rotation_about_axis(a, q))))
                if best is None or key < best[0]:
                    best = (key, R)
            T[k, :3, :3] = best[1]
            flipped[k] = True
        q = float(revolute_angle(T[p, :3, :3].T @ T[c, :3, :3], a))
        if _range_distance(q + np.pi, *limits[j]) < _range_distance(q, *limits[j]):
            T[c, :3, :3] = T[c, :3, :3] @ rotation_about_axis(a, np.pi)
            flipped[c] = True
    return T, flipped


def _procrustes(M: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    return U @ D @ Vt


def kinematic_refine(
    poses,
    sizes,
    joints: dict,
    cfg: ModelConfig,
    part_weights=None,
    axis_weight: float = 1.0,
    iters: int = 10,
) -> dict[str, np.ndarray]:
    """Consistent part rotations, joint axes and states (see the module docstring).

    Args:
        poses: ``(K, 4, 4)`` voted ``cam_from_part``; sizes: ``(K, 3)`` voted sizes.
        joints: dict with ``joint_axis`` ``(J, 3)`` (voted, camera frame) and optionally
            ``joint_pivot`` ``(J, 3)`` (kept).
        cfg: the model configuration (tree, joint types, canonical axes, prismatic zero offsets).
        part_weights: ``(K,)`` non-negative weights of the voted rotations (default 1 each).
        axis_weight: weight of each voted joint axis (same units as a part weight).
        iters: block coordinate descent sweeps.

    Returns:
        dict: ``cam_from_part`` ``(K, 4, 4)`` (rotations refined, translations as voted),
        ``joint_axis`` ``(J, 3)`` (``R_parent a_j``), ``joint_pivot`` ``(J, 3)`` (as given, or NaN),
        ``joint_state`` ``(J,)`` (radians / metres).
    """
    K, J = cfg.num_parts, cfg.num_joints
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
    out_T = T.copy()
    if J == 0:
        return dict(cam_from_part=out_T, joint_axis=np.zeros((0, 3)), joint_pivot=np.zeros((0, 3)), joint_state=np.zeros(0))
    a = canonical_joint_axes(cfg)
    parent = np.asarray(cfg.joint_parents)
    child = np.asarray(cfg.joint_children)
    jtype = np.asarray(cfg.joint_types)
    R_hat = T[:, :3, :3]
    U_hat = U_hat / np.linalg.norm(U_hat, axis=-1, keepdims=True).clip(1e-12)
    for j in range(J):  # the joint heads' axis sign may disagree with the canonical axis: align it
        if U_hat[j] @ (R_hat[parent[j]] @ a[j]) < 0:
            U_hat[j] = -U_hat[j]
    # Parts in tree order (parents first) and the joint above each part.
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
    q = np.zeros(J)
    for j in range(J):
        if jtype[j] == 0:
            q[j] = revolute_angle(R_hat[parent[j]].T @ R_hat[child[j]], a[j])

    def chains(q):
        G = np.zeros((K, 3, 3))
        G[0] = np.eye(3)
        for k in order[1:]:
            j = joint_of[k]
            rot = rotation_about_axis(a[j], q[j]) if jtype[j] == 0 else np.eye(3)
            G[k] = G[parent[j]] @ rot
        return G

    subtree = {k: [k] for k in range(K)}
    for k in reversed(order[1:]):
        subtree[int(parent[joint_of[k]])] += subtree[k]
    R0 = R_hat[0]
    for _ in range(int(iters)):
        G = chains(q)
        M = np.einsum("k,kij,klj->il", w, R_hat, G) + axis_weight * sum(np.outer(U_hat[j], G[parent[j]] @ a[j]) for j in range(J))
        R0 = _procrustes(M)
        R = R0 @ G
        for j in range(J):
            if jtype[j] != 0:
                continue
            Rp = R[parent[j]]
            N = np.zeros((3, 3))
            for k in subtree[int(child[j])]:
                H = R[child[j]].T @ R[k]  # the chain below the child (fixed while q_j changes)
                N += w[k] * Rp.T @ R_hat[k] @ H.T
            q[j] = revolute_angle(N, a[j]) if np.any(N) else q[j]
            R = R0 @ chains(q)
    R = R0 @ chains(q)
    out_T[:, :3, :3] = R
    axis = np.stack([R[parent[j]] @ a[j] for j in range(J)])
    state = q.copy()
    zero = cfg.stats.joint_zero_offset_m or (0.0,) * J
    for j in range(J):
        if jtype[j] == 1:
            state[j] = joint_state_from_poses(out_T[parent[j]], out_T[child[j]], axis[j], 1, S[parent[j]], S[child[j]], zero[j])
    return dict(cam_from_part=out_T, joint_axis=axis, joint_pivot=pivot, joint_state=state)
