"""Exposure: how much of a box the camera would have seen, hidden drawers slid back to where it would not, and
the ``free_space`` stage (its parameters, :class:`ucope.stages.freespace.FreeSpaceParams`, and its turn of hinged
parts live in :mod:`ucope.stages.freespace`).

:func:`exposed_surface_share` counts the share of a box's camera-facing surface that the camera would have seen
where it saw nothing, or in front of a surface it saw; :func:`slide_weak_children` slides a prismatic child that
shows no points and was voted where the camera would have seen it back to the nearest state where it would not.
Camera frame (the camera at the origin), metres.
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .freespace import FreeSpaceParams, place_weak_parts
from .support import (
    _checked_camera,
    _checked_scene,
    _confident,
    box_surface_distance,
)

_P = FreeSpaceParams()


def exposed_surface_share(
    cam_from_box,
    size_m,
    points,
    camera=None,
    grid: int = _P.face_grid,
    ray_radius: float = _P.ray_radius,
    depth_tol: float = _P.depth_tol,
    neighbours: int = _P.ray_neighbours,
) -> np.ndarray:
    """The share of each box's camera-facing surface that the view says is not there.

    The faces of each box that face the camera are sampled at the centres of a ``grid x grid`` lattice. Rays
    are compared in the image plane (``x / z, y / z`` from the camera). A sample is contradicted where the
    camera saw nothing along its ray (no cloud point within ``ray_radius`` times the cloud's median
    nearest-neighbour spacing of it: the object's silhouette does not cover it), or where the nearest surface
    among the (up to ``neighbours``) cloud points nearest to it within that radius lies more than
    ``depth_tol`` times the box diagonal beyond the sample (free space). Samples behind a seen surface
    (occluded) and on it are not. The cloud is taken to be every surface the camera saw near the object (the
    object and any background points kept with it, which can only occlude more).

    Args:
        cam_from_box: ``(B, 4, 4)`` rigid box poses (camera frame, or the frame ``camera`` is given in; the
            camera looks along that frame's ``+z``).
        size_m: ``(B, 3)`` or ``(3,)`` box extents (metres, > 0).
        points: ``(P, 3)`` the cloud (same frame); at least two in front of the camera (the others are ignored).
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin).
        grid, ray_radius, depth_tol, neighbours: as above.

    Returns:
        ``(B,)`` shares in ``[0, 1]`` (0 for a box with no face towards the camera).

    Raises:
        InputError: shapes that do not match, non-finite values, non-positive sizes, fewer than two points in
            front of the camera, ``grid < 2``, a non-positive ``ray_radius`` or negative ``depth_tol``.
    """
    T = np.asarray(cam_from_box, np.float64)
    pts = np.asarray(points, np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"cam_from_box must have shape (B, 4, 4), got {T.shape}")
    S = np.broadcast_to(np.asarray(size_m, np.float64), (len(T), 3)) if np.ndim(size_m) < 2 else np.asarray(size_m, np.float64)
    if S.shape != (len(T), 3):
        raise InputError(f"size_m must have shape ({len(T)}, 3) or (3,), got {np.shape(size_m)}")
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (P, 3), got {pts.shape}")
    cam = np.zeros(3) if camera is None else _checked_camera(camera)
    if not (np.isfinite(T).all() and np.isfinite(S).all() and np.isfinite(pts).all()):
        raise InputError("cam_from_box, size_m and points must be finite")
    if (S <= 0).any():
        raise InputError(f"size_m must be positive, got {S.tolist()}")
    if int(grid) < 2 or not ray_radius > 0 or not depth_tol >= 0 or int(neighbours) < 1:
        raise InputError(
            f"grid must be >= 2, ray_radius > 0, depth_tol >= 0 and neighbours >= 1, got {grid!r}, {ray_radius!r}, "
            f"{depth_tol!r}, {neighbours!r}"
        )
    rays = _ray_index(pts, cam, ray_radius)
    if rays is None:
        raise InputError("at least two points must lie in front of the camera (positive z from it)")
    return _exposed_share(T, S, cam, rays, int(grid), depth_tol, int(neighbours))


def _ray_index(pts: np.ndarray, cam: np.ndarray, ray_radius: float):
    """The cloud's rays for :func:`_exposed_share`: ``(rel, tree, r)``, the points in front of the camera relative to
    it, a KD-tree of their image-plane coordinates and the search radius; ``None`` with fewer than two such points."""
    from scipy.spatial import cKDTree  # noqa: PLC0415 - scipy is a hard dependency; import where used

    rel = pts - cam
    rel = rel[rel[:, 2] > 0]  # a point behind the camera hides nothing from it
    if len(rel) < 2:
        return None
    uv = rel[:, :2] / rel[:, 2:3]
    tree = cKDTree(uv)
    spacing = float(np.median(tree.query(uv, k=2)[0][:, 1]))
    return rel, tree, ray_radius * max(spacing, 1e-9)


@functools.lru_cache(maxsize=8)
def _face_lattice(g: int) -> tuple[np.ndarray, np.ndarray]:
    """``(unit, normals)``, each ``(6 * g * g, 3)``, read-only: the centres of a ``g x g`` lattice on each face of the
    cube ``[-1, 1]^3`` (in units of a box's half extents) and each sample's face normal (made once per ``g``)."""
    a = (np.arange(g) + 0.5) / g * 2.0 - 1.0
    A, B = np.meshgrid(a, a, indexing="ij")
    faces, normals = [], []
    for ax in range(3):  # six faces
        o1, o2 = [k for k in range(3) if k != ax]
        for sgn in (-1.0, 1.0):
            f = np.zeros((g * g, 3))
            f[:, ax], f[:, o1], f[:, o2] = sgn, A.reshape(-1), B.reshape(-1)
            faces.append(f)
            normals.append(np.broadcast_to(np.eye(3)[ax] * sgn, (g * g, 3)))
    unit, nrm = np.concatenate(faces), np.concatenate(normals)
    unit.setflags(write=False)
    nrm.setflags(write=False)
    return unit, nrm


def _exposed_share(T: np.ndarray, S: np.ndarray, cam: np.ndarray, rays, g: int, depth_tol: float, neighbours: int) -> np.ndarray:
    """:func:`exposed_surface_share` on checked inputs and a prepared :func:`_ray_index`."""
    rel, tree, r = rays
    unit, nrm = _face_lattice(g)
    R, t = T[:, :3, :3], T[:, :3, 3]
    q = np.einsum("bij,bfj->bfi", R, unit[None] * (0.5 * S)[:, None, :]) + t[:, None, :]  # (B, F, 3)
    n = np.einsum("bij,fj->bfi", R, nrm)
    facing = np.einsum("bfi,bfi->bf", n, cam - q) > 0.0
    qr = q[facing] - cam  # (Q, 3) the faced samples only, from the camera
    box = np.nonzero(facing)[0]
    front = qr[:, 2] > 1e-9
    k = min(neighbours, len(rel))
    dist, idx = tree.query(qr[front, :2] / qr[front, 2:3], k=k, distance_upper_bound=r)
    dist, idx = dist.reshape(-1, k), idx.reshape(-1, k)
    seen_z = np.where(np.isfinite(dist), rel[np.minimum(idx, len(rel) - 1), 2], np.inf).min(1)  # the nearest surface seen
    tol = depth_tol * np.linalg.norm(S, axis=1)
    bad = ~front  # a faced sample behind the camera's plane is contradicted
    bad[front] = seen_z > qr[front, 2] + tol[box[front]]  # nothing seen along the ray, or a surface seen beyond it
    return np.bincount(box[bad], minlength=len(T)) / np.maximum(facing.sum(1), 1)


def _slide_states(T: np.ndarray, S: np.ndarray, jp, axis: np.ndarray, steps: int, extent_share: float):
    """``(states, q0)``: the voted state ``q0`` of joint ``jp``'s child (sliding along the unit ``axis``) followed by
    ``steps`` states evenly over its range (the lower limit, 0 without one, to the least of the upper limit and the
    child's extent along the slide times ``max_state_over_extent``, else ``extent_share``); ``None`` for an empty
    range."""
    c = jp.child
    ext = float(np.abs(T[c, :3, :3].T @ axis) @ S[c])  # the child's extent along the slide
    share = jp.max_state_over_extent if jp.max_state_over_extent is not None else extent_share
    lo = jp.limits[0] if jp.limits[0] is not None else 0.0
    hi = share * ext if jp.limits[1] is None else min(jp.limits[1], share * ext)
    if not hi > lo:
        return None
    q0 = float(joint_state_from_poses(T[jp.parent], T[c], axis, "prismatic", S[jp.parent], S[c], jp.zero_offset_m))
    return np.concatenate([[q0], np.linspace(lo, hi, steps)]), q0


def _nearest_open(states: np.ndarray, cost: np.ndarray, slack: float) -> float | None:
    """Where a hidden child slides to: ``None`` where the voted state (``states[0]``) is open (its cost at most
    ``slack`` above the least of the others), else the open state nearest to it."""
    least = cost[1:].min()
    if cost[0] <= least + slack:
        return None
    grid, open_ = states[1:], cost[1:] <= least + slack
    return float(grid[open_][np.argmin(np.abs(grid[open_] - states[0]))])


def slide_weak_children(
    cam_from_part,
    size_m,
    joint_axis,
    points,
    labels,
    priors: CategoryPriors,
    min_points: int = _P.slide_min_points,
    steps: int = _P.slide_steps,
    slack: float = _P.slide_slack,
    shrink: float = _P.slide_shrink,
    camera=None,
    confidence=None,
    extent_share: float = _P.slide_extent_share,
    min_confidence: float = _P.min_confidence,
    grid: int = _P.face_grid,
    ray_radius: float = _P.ray_radius,
    depth_tol: float = _P.depth_tol,
    neighbours: int = _P.ray_neighbours,
) -> tuple[np.ndarray, np.ndarray]:
    """Hidden prismatic children (drawers) voted where the camera would have seen them, slid back to the nearest
    state the view leaves room for.

    A box the camera would have seen where it saw nothing, or in front of a surface it saw, is not there. For each
    prismatic child with fewer than ``min_points`` (confident) points, ``steps`` states evenly spaced over its range
    (:func:`_slide_states`) are costed: :func:`exposed_surface_share` of the box shrunk to ``shrink`` of its extents,
    plus the median distance of the child's own points to the box over its diagonal. States at most ``slack`` above
    the least cost are open. The voted state stands where it is open, else the child takes the open state nearest to
    it; where the view hides every state, nothing moves. Only the child moves, along ``joint_axis``; the caller
    re-reads the states from the new poses.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (metres, the frame of ``camera``); size_m: ``(K, 3)`` extents (> 0).
        joint_axis: ``(J, 3)`` the joints' axes (same frame; a prismatic one points the way its child pulls out).
        points: ``(P, 3)`` the cloud (same frame; every point counts as a surface the camera saw).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (tree, joint types, limits, zero offsets, ``max_state_over_extent``).
        min_points, steps, slack, shrink, extent_share: as above (``steps >= 2``, ``slack >= 0``, ``0 < shrink <= 1``).
        camera: ``(3,)`` the camera centre (``None``: the origin); confidence: optional ``(P,)`` the probability
            that each point is the object (points below ``min_confidence`` are no part's).
        grid, ray_radius, depth_tol, neighbours: as :func:`exposed_surface_share`.

    Returns:
        ``(cam_from_part, moved_m)``: a ``(K, 4, 4)`` float64 copy and ``(K,)`` how far (metres) each part slid.

    Raises:
        InputError: shapes that do not match the priors, non-finite values, non-positive sizes, labels that are not
            integers, ``steps < 2``, ``slack < 0``, ``shrink`` outside ``(0, 1]``, a camera that is not a finite point.
    """
    T, S, u, _, pts, lab, cam = _checked_scene(cam_from_part, size_m, joint_axis, points, labels, priors, camera)
    K = priors.num_parts
    if int(steps) < 2 or not slack >= 0.0 or not 0.0 < shrink <= 1.0:
        raise InputError(f"steps must be >= 2, slack >= 0 and shrink in (0, 1], got {steps!r}, {slack!r}, {shrink!r}")
    moved = np.zeros(K)
    lab = _confident(lab, confidence, min_confidence)
    counts = np.bincount(lab[(lab >= 0) & (lab < K)], minlength=K)
    rays = None
    for j, jp in enumerate(priors.joints):  # a handful of joints; the work per joint is vectorised
        c = jp.child
        if jp.type != JointType.PRISMATIC or counts[c] >= max(int(min_points), 1) or not np.linalg.norm(u[j]) > 0:
            continue
        axis = u[j] / np.linalg.norm(u[j])
        if (tried := _slide_states(T, S, jp, axis, int(steps), extent_share)) is None:
            continue
        states, q0 = tried  # the voted state first
        cand = np.broadcast_to(T[c], (len(states), 4, 4)).copy()
        cand[:, :3, 3] += (states - q0)[:, None] * axis
        rays = _ray_index(pts, cam, ray_radius) if rays is None else rays  # once, for every hidden child
        if rays is None:  # fewer than two points in front of the camera: no view to check against
            break
        cost = _exposed_share(cand, np.broadcast_to(shrink * S[c], (len(cand), 3)), cam, rays, grid, depth_tol, neighbours)
        own = pts[lab == c]
        if len(own):
            cost = cost + np.median(box_surface_distance(cand, S[c], own), axis=1) / np.linalg.norm(S[c])
        q = _nearest_open(states, cost, slack)
        if q is None:
            continue
        T[c, :3, 3] += (q - q0) * axis
        moved[c] = q - q0
    return T, moved


@stage(
    "free_space",
    kind="geometry",
    params=FreeSpaceParams,
    reads=("parts.upright_cone_deg",),
    applies=lambda priors: priors.num_joints > 0,
)
def _free_space(state: PoseState, params: FreeSpaceParams) -> None:
    """Parts the camera barely sees moved to where the view leaves room for them: a hidden drawer slid back where
    the camera would not have seen it, a hidden lid or base turned about its hinge to where its box hides none of
    the seen points."""
    T, S, pri, lab, p = state.cam_from_part, state.size_m, state.priors, state.part_labels, params
    if any(jp.type == JointType.PRISMATIC for jp in pri.joints):
        slide = dict(min_points=p.slide_min_points, steps=p.slide_steps, slack=p.slide_slack, shrink=p.slide_shrink)
        view = dict(grid=p.face_grid, ray_radius=p.ray_radius, depth_tol=p.depth_tol, neighbours=p.ray_neighbours)
        T, slid = slide_weak_children(
            T,
            S,
            state.joint_axis,
            state.points,
            lab,
            pri,
            camera=state.camera,
            confidence=state.confidence,
            extent_share=p.slide_extent_share,
            min_confidence=p.min_confidence,
            **slide,
            **view,
        )
        for k in np.flatnonzero(slid):
            state.warnings.append(
                f"part {state.part_name(k)!r}: it showed no points and was voted where the camera would have seen it; "
                f"it was slid {slid[k] / state.scale:+.3f} m along its joint to the nearest state the view leaves room for"
            )
    if any(jp.type == JointType.REVOLUTE for jp in pri.joints):
        turn = dict(weak_share=p.weak_share, strong_share=p.strong_share, turn_cost=p.turn_cost, max_turn_deg=p.max_turn_deg)
        T, turned = place_weak_parts(
            T,
            S,
            state.joint_axis,
            state.joint_pivot,
            state.points,
            lab,
            pri,
            step_deg=p.step_deg,
            camera=state.camera,
            upright_margin_deg=p.upright_margin_deg,
            shrink=p.turn_shrink,
            stop=p.turn_stop,
            **turn,
        )
        for k in np.flatnonzero(turned):
            state.warnings.append(
                f"part {state.part_name(k)!r}: it showed few points; it was turned by {np.degrees(turned[k]):.0f} "
                "degrees about its joint to where its box hides none of the points the camera sees and its own points "
                "lie on it"
            )
    state.cam_from_part = T
