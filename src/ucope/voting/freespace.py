"""Free space: a part the camera barely sees, turned about its joint to where the points say it can be.

A part that shows few points (a laptop base behind its lid, seen from behind) is voted from little
evidence, while its neighbour across a revolute joint is seen well. What the camera saw still constrains
it: every seen point of the other parts lies on a ray from the camera that nothing crossed before it, so
the part's box cannot stand on that ray in front of the point (free space); and the part's own few points
lie on its surface. :func:`place_weak_parts` turns such a part about its joint (the voted axis through the
voted pivot, the neighbour fixed) over a grid of angles inside the joint limits, and keeps the angle of
least cost

    hidden(box) + misfit(box) + turn_cost * |angle|

``hidden``: the share of the other parts' points whose segment from the camera (to ``stop`` of the way)
passes through the box shrunk by ``shrink``; ``misfit``: the median distance of the part's own points to
its box's surface over the box diagonal; the last term keeps the voted angle where the points do not
decide. A part with an upright prior (``PartPrior.upright_*``) is never turned further than ``upright_margin_deg``
beyond the cone the training views held its upright axis in: a laptop base seen from behind shows a strip of
points along its hinge edge, which fits a face of the box turned 40-60 degrees as well as the truth, and the
turn had undone the upright carry (:func:`ucope.voting.kinematic.carry_upright`) that had brought it back within 1
degree of its upright. Camera frame (the camera at the origin), metres, radians. Measured in docs/results.md.

The same evidence keeps a hidden prismatic child (a drawer no point shows) where the view leaves room for it:
:func:`exposed_surface_share` counts the share of a box's camera-facing surface that the camera would have seen
where it saw nothing, or in front of a surface it saw, and :func:`slide_weak_children` slides a child voted
there back to the nearest state where it would not have been seen (docs/voting.md, row *hidden slide*).
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses
from ..geometry.transforms import axis_angle_transform
from ..priors import CategoryPriors
from ..vocab import JointType
from .extent import _checked_confidence
from .kinematic import FRONT_MIN_CONFIDENCE, UPRIGHT_MARGIN_DEG, _checked_camera, weak_neighbours

__all__ = [
    "place_weak_parts",
    "slide_weak_children",
    "exposed_surface_share",
    "segments_through_box",
    "box_surface_distance",
    "WEAK_SHARE",
    "STRONG_SHARE",
    "TURN_COST",
]

WEAK_SHARE = 0.125
"""A part is turned only where fewer than this share of the points segmented as the object are its own ..."""

STRONG_SHARE = 0.25
"""... and at least this share are its neighbour's across the joint."""

TURN_COST = 0.02
"""Cost per radian of turn away from the voted angle (the two other terms are fractions: 0.02 is a point of
hidden share per half radian). Measured on the shipped laptop's test views: 0 let parts with a few points
on an edge swing 30-60 degrees to where those points fit a face (success 32 -> 30 on 40 views), 0.02 kept
the voted angle unless the points disagree (32 -> 34)."""

MAX_TURN_DEG = 60.0
"""The angles tried: the voted one and up to this far either way ..."""

STEP_DEG = 2.0
"""... in steps of this."""

SHRINK = 0.9
"""The box a segment must pass through to count as hidden: the part's box shrunk to this share of its extents
(a point on the part's own surface or just beside it is not hidden by it)."""

STOP = 0.97
"""A segment runs from the camera to this share of the way to its point (the point's own surface excluded)."""


def segments_through_box(cam_from_box, size_m, points, stop: float = STOP, camera=None) -> np.ndarray:
    """Which segments from the camera to ``stop`` of the way to each point cross each box.

    Args:
        cam_from_box: ``(B, 4, 4)`` rigid box poses (camera frame, or any frame ``camera`` is given in).
        size_m: ``(B, 3)`` full extents (> 0) or ``(3,)`` for every box.
        points: ``(P, 3)`` points (same frame).
        stop: the share of the way to each point the segment runs (``(0, 1]``).
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin).

    Returns:
        ``(B, P)`` bool.
    """
    T = np.asarray(cam_from_box, np.float64)
    half = np.broadcast_to(0.5 * np.asarray(size_m, np.float64), (len(T), 3))[:, None, :]
    R, t = T[:, :3, :3], T[:, :3, 3]
    c = np.zeros(3) if camera is None else np.asarray(camera, np.float64)
    o = np.einsum("bji,bj->bi", R, c - t)[:, None, :]  # (B, 1, 3) the camera in each box's frame
    p = np.einsum("bji,bpj->bpi", R, np.asarray(points, np.float64)[None] - t[:, None, :])  # (B, P, 3)
    d = stop * (p - o)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o) / d, (half - o) / d
    flat = d == 0.0  # a segment parallel to a slab: inside it throughout or never
    inside = np.abs(o) <= half
    lo = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    hi = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    return np.maximum(lo.max(-1), 0.0) < np.minimum(hi.min(-1), 1.0)


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


def place_weak_parts(
    cam_from_part,
    size_m,
    joint_axis,
    joint_pivot,
    points,
    labels,
    priors: CategoryPriors,
    weak_share: float = WEAK_SHARE,
    strong_share: float = STRONG_SHARE,
    turn_cost: float = TURN_COST,
    max_turn_deg: float = MAX_TURN_DEG,
    step_deg: float = STEP_DEG,
    camera=None,
    upright_margin_deg: float | None = UPRIGHT_MARGIN_DEG,
) -> tuple[np.ndarray, np.ndarray]:
    """Parts the camera barely sees, turned about their revolute joint to where the points say they can be.

    For each revolute joint (in the priors' order) whose child is a leaf (no joint hangs from it), or
    either of whose parts is the root of a two-part object, a part with fewer than ``weak_share`` of the
    object's labelled points next to one with at least ``strong_share`` is turned about the joint's axis
    (``joint_axis`` through ``joint_pivot``) by the angle of least cost (module docstring) among
    ``0, +-step_deg, ...`` up to ``max_turn_deg``, whose joint state
    (:func:`ucope.geometry.kinematics.joint_state_from_poses`) stays inside the category's limits and, for a
    part with an upright prior, whose upright axis stays within ``upright_cone_deg + upright_margin_deg`` of
    ``upright_in_cam``. Each part turns at most once; sizes are kept; the caller re-reads the joint states from
    the new poses.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres; or any frame ``camera`` is given in).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        joint_axis, joint_pivot: ``(J, 3)`` the joints' unit axes and pivots (same frame).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (tree, joint types and limits).
        weak_share, strong_share, turn_cost, max_turn_deg, step_deg: as above.
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin; a cloud scaled about a centre
            ``c`` by ``s`` has it at ``c (1 - s)``).
        upright_margin_deg: degrees beyond each part's upright cone that a turn may take it (``None``: no bound,
            for cameras that are not upright; the estimator passes ``None`` with ``upright=False``).

    Returns:
        ``(cam_from_part, turned_rad)``: a ``(K, 4, 4)`` float64 copy and ``(K,)`` the angle each part was
        turned by about its joint's axis (0: kept).

    Raises:
        InputError: shapes that do not match the priors, non-finite or non-positive values, shares outside
            ``[0, 1]``, a negative ``turn_cost``, a step that is not positive, a camera that is not a finite
            ``(3,)`` position, an ``upright_margin_deg`` that is not finite.
    """
    T, S, u, piv, pts, lab, cam = _checked_scene(cam_from_part, size_m, joint_axis, points, labels, priors, camera, joint_pivot)
    K = priors.num_parts
    if not (0.0 <= weak_share <= 1.0 and 0.0 <= strong_share <= 1.0):
        raise InputError(f"weak_share and strong_share must lie in [0, 1], got {weak_share!r}, {strong_share!r}")
    if not (turn_cost >= 0.0 and step_deg > 0.0 and max_turn_deg >= 0.0):
        raise InputError(
            f"turn_cost and max_turn_deg must be >= 0 and step_deg > 0, got {turn_cost!r}, {max_turn_deg!r}, {step_deg!r}"
        )
    if upright_margin_deg is not None and not np.isfinite(upright_margin_deg):
        raise InputError(f"upright_margin_deg must be finite or None, got {upright_margin_deg!r}")
    turned = np.zeros(K)
    on_part = (lab >= 0) & (lab < K)
    steps = np.radians(np.arange(step_deg, max_turn_deg + 1e-9, step_deg))
    angles = np.concatenate([[0.0], np.stack([steps, -steps], 1).reshape(-1)])  # 0, +s, -s, +2s, ...: ties go to the smaller turn
    for j, w, _ in weak_neighbours(lab, priors, weak_share, strong_share):  # the work per joint is vectorised
        jp = priors.joints[j]
        if turned[w] != 0.0 or not np.isfinite(piv[j]).all():
            continue
        axis = u[j] / np.linalg.norm(u[j])
        cand = axis_angle_transform(axis, piv[j], angles) @ T[w]  # (A, 4, 4) the part turned about the joint line
        Tp = np.broadcast_to(T[jp.parent], cand.shape) if w == jp.child else cand
        Tc = cand if w == jp.child else np.broadcast_to(T[jp.child], cand.shape)
        q = np.asarray(joint_state_from_poses(Tp, Tc, np.broadcast_to(axis, (len(angles), 3)), "revolute"), np.float64)
        lo, hi = jp.limits
        ok = np.ones(len(angles), dtype=bool)
        if lo is not None:
            ok &= q >= lo - 1e-9
        if hi is not None:
            ok &= q <= hi + 1e-9
        pp = priors.parts[w]
        if upright_margin_deg is not None and pp.upright_axis is not None and pp.upright_cone_deg is not None:
            tilt = np.degrees(np.arccos(np.clip(cand[:, :3, pp.upright_axis] @ np.asarray(pp.upright_in_cam), -1.0, 1.0)))
            ok &= tilt <= pp.upright_cone_deg + upright_margin_deg
        ok[0] = True  # the voted angle stays a candidate (the caller clamps its state)
        others = pts[on_part & (lab != w)]
        own = pts[lab == w]
        hidden, misfit = np.zeros(len(angles)), np.zeros(len(angles))
        if len(others):
            hidden = segments_through_box(cand, SHRINK * S[w], others, camera=cam).mean(1)
        if len(own):
            misfit = np.median(box_surface_distance(cand, S[w], own), axis=1) / np.linalg.norm(S[w])
        cost = np.where(ok, hidden + misfit + turn_cost * np.abs(angles), np.inf)
        best = int(np.argmin(cost))
        if best != 0:
            T[w] = cand[best]
            turned[w] = angles[best]
    return T, turned


SLIDE_MIN_POINTS = 10
"""A prismatic child with fewer (confident) points than this is hidden: :func:`slide_weak_children` checks its slide
against the view. (Checking drawers with up to 5 % of the points too lost views: their few points voted the slide
better than the check, which a box voted 1.1-1.3x too large fools.)"""

SLIDE_STEPS = 33
"""States tried, evenly spaced over a hidden child's range."""

SLIDE_SLACK = 0.02
"""A state is open where its cost (the share of the box's faced surface the view contradicts, plus the misfit of the
child's own points) is at most this above the least cost over the range."""

SLIDE_SHRINK = 0.92
"""The box whose faced surface is checked: the child's shrunk to this share of its extents, so that a box voted a
little too large (the shipped drawer's hidden drawers: often 1.1-1.3x as deep as they are) does not poke through the
cabinet's seen back wall at its true state. Measured on the shipped drawer (test / OOD views it succeeds on, of 200 /
100): 1.0 133 / 47, 0.92 140 / 48, 0.85 134 / 44, against 131 / 45 without the check (docs/results.md)."""

SLIDE_EXTENT_SHARE = 0.75
"""Without a measured ``JointPrior.max_state_over_extent``, a child slides out at most this share of its own box extent
along the slide (a three-quarter extension slide)."""

FACE_GRID = 7
"""Samples per side of each box face in :func:`exposed_surface_share` (``7 x 7`` per face)."""

RAY_NEIGHBOURS = 8
"""A sample's ray is compared with the rays of up to this many cloud points nearest to it in the image plane ..."""

RAY_RADIUS = 2.5
"""... within this many times the cloud's median nearest-neighbour spacing there (``x / z, y / z`` from the camera)."""

DEPTH_TOL = 0.03
"""A sample is in free space where the nearest surface the camera saw along its ray lies more than this share of the
box diagonal beyond it."""


def exposed_surface_share(
    cam_from_box,
    size_m,
    points,
    camera=None,
    grid: int = FACE_GRID,
    ray_radius: float = RAY_RADIUS,
    depth_tol: float = DEPTH_TOL,
) -> np.ndarray:
    """The share of each box's camera-facing surface that the view says is not there.

    The faces of each box that face the camera are sampled at the centres of a ``grid x grid`` lattice. Rays
    are compared in the image plane (``x / z, y / z`` from the camera). A sample is contradicted where the
    camera saw nothing along its ray (no cloud point within ``ray_radius`` times the cloud's median
    nearest-neighbour spacing of it: the object's silhouette does not cover it), or where the nearest surface
    among the (up to ``RAY_NEIGHBOURS``) cloud points nearest to it within that radius lies more than
    ``depth_tol`` times the box diagonal beyond the sample (free space). Samples behind a seen surface
    (occluded) and on it are not. The cloud is taken to be every surface the camera saw near the object (the
    object and any background points kept with it, which can only occlude more).

    Args:
        cam_from_box: ``(B, 4, 4)`` rigid box poses (camera frame, or the frame ``camera`` is given in; the
            camera looks along that frame's ``+z``).
        size_m: ``(B, 3)`` or ``(3,)`` box extents (metres, > 0).
        points: ``(P, 3)`` the cloud (same frame); at least two in front of the camera (the others are ignored).
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin).
        grid, ray_radius, depth_tol: as above.

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
    if int(grid) < 2 or not ray_radius > 0 or not depth_tol >= 0:
        raise InputError(f"grid must be >= 2, ray_radius > 0 and depth_tol >= 0, got {grid!r}, {ray_radius!r}, {depth_tol!r}")
    rays = _ray_index(pts, cam, ray_radius)
    if rays is None:
        raise InputError("at least two points must lie in front of the camera (positive z from it)")
    return _exposed_share(T, S, cam, rays, int(grid), depth_tol)


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


def _exposed_share(T: np.ndarray, S: np.ndarray, cam: np.ndarray, rays, g: int, depth_tol: float) -> np.ndarray:
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
    k = min(RAY_NEIGHBOURS, len(rel))
    dist, idx = tree.query(qr[front, :2] / qr[front, 2:3], k=k, distance_upper_bound=r)
    dist, idx = dist.reshape(-1, k), idx.reshape(-1, k)
    seen_z = np.where(np.isfinite(dist), rel[np.minimum(idx, len(rel) - 1), 2], np.inf).min(1)  # the nearest surface seen
    tol = depth_tol * np.linalg.norm(S, axis=1)
    bad = ~front  # a faced sample behind the camera's plane is contradicted
    bad[front] = seen_z > qr[front, 2] + tol[box[front]]  # nothing seen along the ray, or a surface seen beyond it
    return np.bincount(box[bad], minlength=len(T)) / np.maximum(facing.sum(1), 1)


def slide_weak_children(
    cam_from_part,
    size_m,
    joint_axis,
    points,
    labels,
    priors: CategoryPriors,
    min_points: int = SLIDE_MIN_POINTS,
    steps: int = SLIDE_STEPS,
    slack: float = SLIDE_SLACK,
    shrink: float = SLIDE_SHRINK,
    camera=None,
    confidence=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Hidden prismatic children kept where the view leaves room for them: a drawer voted pulled out where the
    camera would have seen it is slid back to the nearest state the view allows.

    A drawer a view hides (under the open drawer above it, behind its cabinet) has no point to vote its slide
    from. The view still rules states out: a box the camera would have seen where it saw nothing (outside the
    object's silhouette), or in front of a surface it saw (free space), is not there
    (:func:`exposed_surface_share` of the box shrunk to ``shrink`` of its extents, plus the median distance of
    any of the child's own points to the box over its diagonal). For each prismatic child with fewer than
    ``min_points`` (confident) points, ``steps`` states evenly spaced over its range are costed; those at most
    ``slack`` above the least cost are open. The voted state stands where it is open, else the child takes the
    open state nearest to it. Where the view hides every state (from behind) nothing moves: the slide is not
    observed, and the voted state is kept: the drawers a back view hides are more often shut than a uniform draw over
    the range would make them, and the network votes them so (on the shipped drawer's back test views it put 24 of 50
    such drawers within the success bound, the middle of the range 17; docs/results.md). The range: the joint's lower
    limit (0 without one) to the least of its upper limit and the child's extent along the slide times
    ``JointPrior.max_state_over_extent`` (:data:`SLIDE_EXTENT_SHARE` where not measured). Only the child moves,
    along ``joint_axis``; rotations and sizes are kept; the caller re-reads the states from the new poses.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres; or any frame ``camera`` is given in).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        joint_axis: ``(J, 3)`` the joints' axes (same frame; a prismatic one points the way its child pulls out).
        points: ``(P, 3)`` the cloud (same frame; every point counts as a surface the camera saw).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (tree, joint types, limits, zero offsets, ``max_state_over_extent``).
        min_points, steps, slack, shrink: as above (``steps >= 2``, ``slack >= 0``, ``0 < shrink <= 1``).
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin).
        confidence: optional ``(P,)`` per point, the probability that it is the object; points below
            ``FRONT_MIN_CONFIDENCE`` do not count as a part's.

    Returns:
        ``(cam_from_part, moved_m)``: a ``(K, 4, 4)`` float64 copy and ``(K,)`` how far each child moved along its
        slide (metres; 0 for parts that stayed).

    Raises:
        InputError: shapes that do not match the priors, non-finite values, non-positive sizes, labels that are not
            integers, ``steps < 2``, a negative ``slack``, a ``shrink`` outside ``(0, 1]``, a camera that is not a
            finite ``(3,)`` position.
    """
    T, S, u, _, pts, lab, cam = _checked_scene(cam_from_part, size_m, joint_axis, points, labels, priors, camera)
    K = priors.num_parts
    if int(steps) < 2 or not slack >= 0.0 or not 0.0 < shrink <= 1.0:
        raise InputError(f"steps must be >= 2, slack >= 0 and shrink in (0, 1], got {steps!r}, {slack!r}, {shrink!r}")
    moved = np.zeros(K)
    if confidence is not None:
        lab = np.where(_checked_confidence(confidence, len(lab)) >= FRONT_MIN_CONFIDENCE, lab, -1)
    counts = np.bincount(lab[(lab >= 0) & (lab < K)], minlength=K)
    rays = None
    for j, jp in enumerate(priors.joints):  # a handful of joints; the work per joint is vectorised
        c = jp.child
        if jp.type != JointType.PRISMATIC or counts[c] >= max(int(min_points), 1) or not np.linalg.norm(u[j]) > 0:
            continue
        axis = u[j] / np.linalg.norm(u[j])
        ext = float(np.abs(T[c, :3, :3].T @ axis) @ S[c])  # the child's extent along the slide
        share = jp.max_state_over_extent if jp.max_state_over_extent is not None else SLIDE_EXTENT_SHARE
        lo = jp.limits[0] if jp.limits[0] is not None else 0.0
        hi = share * ext if jp.limits[1] is None else min(jp.limits[1], share * ext)
        if not hi > lo:
            continue
        q0 = float(joint_state_from_poses(T[jp.parent], T[c], axis, "prismatic", S[jp.parent], S[c], jp.zero_offset_m))
        states = np.concatenate([[q0], np.linspace(lo, hi, int(steps))])  # the voted state first
        cand = np.broadcast_to(T[c], (len(states), 4, 4)).copy()
        cand[:, :3, 3] += (states - q0)[:, None] * axis
        rays = _ray_index(pts, cam, RAY_RADIUS) if rays is None else rays  # once, for every hidden child
        if rays is None:  # fewer than two points in front of the camera: no view to check against
            break
        cost = _exposed_share(cand, np.broadcast_to(shrink * S[c], (len(cand), 3)), cam, rays, FACE_GRID, DEPTH_TOL)
        own = pts[lab == c]
        if len(own):
            cost = cost + np.median(box_surface_distance(cand, S[c], own), axis=1) / np.linalg.norm(S[c])
        least = cost[1:].min()
        if cost[0] <= least + slack:
            continue
        grid, open_ = states[1:], cost[1:] <= least + slack
        q = float(grid[open_][np.argmin(np.abs(grid[open_] - q0))])
        T[c, :3, 3] += (q - q0) * axis
        moved[c] = q - q0
    return T, moved
