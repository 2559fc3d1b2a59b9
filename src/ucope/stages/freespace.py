"""Free space: a part the camera barely sees, turned about its joint to where the points say it can be; and the
parameters of the ``free_space`` stage (:mod:`ucope.stages.exposure` runs it).

Every seen point of the other parts lies on a ray from the camera that nothing crossed before it, so a part's
box cannot stand on that ray in front of the point; and the part's own few points lie on its surface.
:func:`place_weak_parts` turns a part that shows few points (a laptop base behind its lid) about its joint
(the voted axis through the voted pivot, the neighbour fixed) over a grid of angles inside the limits and keeps
the angle of least

    hidden(box) + misfit(box) + turn_cost * |angle|

``hidden``: the share of the other parts' points whose segment from the camera (to ``stop`` of the way) passes
through the box shrunk by ``shrink``; ``misfit``: the median distance of the part's own points to its box's
surface over the box diagonal. A part with an upright prior is never turned further than
``upright_margin_deg`` beyond its training cone. Camera frame (the camera at the origin), metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses
from ..geometry.transforms import axis_angle_transform
from ..priors import CategoryPriors
from .support import (
    FRONT_MIN_CONFIDENCE,
    UPRIGHT_MARGIN_DEG,
    _checked_scene,
    box_surface_distance,
    weak_neighbours,
)


@dataclass(frozen=True)
class FreeSpaceParams:
    """Attributes:
    upright_margin_deg: a turned part never leaves its training upright cone by more than this (``None``: no limit,
        for a camera that is not upright).
    weak_share / strong_share: a part is turned (:func:`place_weak_parts`) only where fewer than ``weak_share`` of the
        object's labelled points are its own and at least ``strong_share`` its neighbour's across the joint.
    turn_cost: cost per radian of turn away from the voted angle (the other terms are fractions of points);
        max_turn_deg / step_deg: the angles tried, up to this far either way in steps of this (degrees).
    turn_shrink: the box a segment must pass through to count as hidden is the part's shrunk to this share of its
        extents; turn_stop: segments run from the camera to this share of the way to their points.
    slide_min_points: a prismatic child with fewer confident points is hidden and its slide checked against the
        view (:func:`ucope.stages.exposure.slide_weak_children`): ``slide_steps`` states evenly over its range; those
        whose cost is at most ``slide_slack`` above the least are open; the box checked is the child's shrunk to
        ``slide_shrink`` of its extents; without a measured ``JointPrior.max_state_over_extent`` a child slides out
        at most ``slide_extent_share`` of its own extent along the slide.
    min_confidence: points less likely to be the object do not count as a part's for the slide.
    face_grid: samples per side of each box face (:func:`ucope.stages.exposure.exposed_surface_share`); a sample's
        ray is compared with those of up to ``ray_neighbours`` cloud points within ``ray_radius`` times the cloud's
        median nearest-neighbour spacing in the image plane; it is in free space where the nearest surface seen
        lies more than ``depth_tol`` of the box diagonal beyond it.
    """

    upright_margin_deg: float | None = UPRIGHT_MARGIN_DEG
    weak_share: float = 0.125
    strong_share: float = 0.25
    turn_cost: float = 0.02
    max_turn_deg: float = 60.0
    step_deg: float = 2.0
    turn_shrink: float = 0.9
    turn_stop: float = 0.97
    slide_min_points: int = 10
    slide_steps: int = 33
    slide_slack: float = 0.02
    slide_shrink: float = 0.92
    slide_extent_share: float = 0.75
    min_confidence: float = FRONT_MIN_CONFIDENCE
    face_grid: int = 7
    ray_neighbours: int = 8
    ray_radius: float = 2.5
    depth_tol: float = 0.03


_P = FreeSpaceParams()


def segments_through_box(cam_from_box, size_m, points, stop: float = _P.turn_stop, camera=None) -> np.ndarray:
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


def _turns_allowed(cand: np.ndarray, q: np.ndarray, jp, pp, upright_margin_deg: float | None) -> np.ndarray:
    """``(A,)`` bool: which candidate poses ``cand`` ``(A, 4, 4)`` of a part (joint states ``q``) keep the joint ``jp``
    inside its limits and the part's upright axis (part prior ``pp``) within its cone plus ``upright_margin_deg``
    (``None``: no bound). The voted pose (the first) is always allowed: the caller clamps its state."""
    lo, hi = jp.limits
    ok = np.ones(len(q), dtype=bool)
    if lo is not None:
        ok &= q >= lo - 1e-9
    if hi is not None:
        ok &= q <= hi + 1e-9
    if upright_margin_deg is not None and pp.upright_axis is not None and pp.upright_cone_deg is not None:
        tilt = np.degrees(np.arccos(np.clip(cand[:, :3, pp.upright_axis] @ np.asarray(pp.upright_in_cam), -1.0, 1.0)))
        ok &= tilt <= pp.upright_cone_deg + upright_margin_deg
    ok[0] = True
    return ok


def _check_turn_settings(weak_share, strong_share, turn_cost, max_turn_deg, step_deg, upright_margin_deg) -> None:
    """:class:`InputError` unless the shares lie in ``[0, 1]``, ``turn_cost`` and ``max_turn_deg`` are ``>= 0``,
    ``step_deg > 0`` and ``upright_margin_deg`` is finite or ``None``."""
    if not (0.0 <= weak_share <= 1.0 and 0.0 <= strong_share <= 1.0):
        raise InputError(f"weak_share and strong_share must lie in [0, 1], got {weak_share!r}, {strong_share!r}")
    if not (turn_cost >= 0.0 and step_deg > 0.0 and max_turn_deg >= 0.0):
        raise InputError(
            f"turn_cost and max_turn_deg must be >= 0 and step_deg > 0, got {turn_cost!r}, {max_turn_deg!r}, {step_deg!r}"
        )
    if upright_margin_deg is not None and not np.isfinite(upright_margin_deg):
        raise InputError(f"upright_margin_deg must be finite or None, got {upright_margin_deg!r}")


def place_weak_parts(
    cam_from_part,
    size_m,
    joint_axis,
    joint_pivot,
    points,
    labels,
    priors: CategoryPriors,
    weak_share: float = _P.weak_share,
    strong_share: float = _P.strong_share,
    turn_cost: float = _P.turn_cost,
    max_turn_deg: float = _P.max_turn_deg,
    step_deg: float = _P.step_deg,
    camera=None,
    upright_margin_deg: float | None = _P.upright_margin_deg,
    shrink: float = _P.turn_shrink,
    stop: float = _P.turn_stop,
) -> tuple[np.ndarray, np.ndarray]:
    """Parts the camera barely sees, turned about their revolute joint to where the points say they can be.

    For each part ``w`` next to a neighbour across a revolute joint (:func:`ucope.stages.support.weak_neighbours`
    with ``weak_share`` and ``strong_share``), the part is turned about the joint's axis (``joint_axis`` through
    ``joint_pivot``) by the angle of least cost (module docstring) among ``0, +-step_deg, ...`` up to
    ``max_turn_deg``, whose joint state (:func:`ucope.geometry.kinematics.joint_state_from_poses`) stays inside the
    category's limits and, for a part with an upright prior, whose upright axis stays within ``upright_cone_deg +
    upright_margin_deg`` of ``upright_in_cam``. Each part turns at most once; sizes are kept; the caller re-reads
    the joint states from the new poses.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame, metres; or any frame ``camera`` is given in).
        size_m: ``(K, 3)`` box extents (metres, > 0).
        joint_axis, joint_pivot: ``(J, 3)`` the joints' unit axes and pivots (same frame).
        points: ``(P, 3)`` the cloud (same frame, metres).
        labels: ``(P,)`` integer part of every point; values outside ``[0, K)`` belong to no part.
        priors: the category's priors (tree, joint types and limits).
        weak_share, strong_share, turn_cost, max_turn_deg, step_deg, shrink, stop: as above.
        camera: ``(3,)`` the camera centre in that frame (``None``: the origin; a cloud scaled about a centre
            ``c`` by ``s`` has it at ``c (1 - s)``).
        upright_margin_deg: degrees beyond each part's upright cone that a turn may take it (``None``: no bound).

    Returns:
        ``(cam_from_part, turned_rad)``: a ``(K, 4, 4)`` float64 copy and ``(K,)`` the angle each part was
        turned by about its joint's axis (0: kept).

    Raises:
        InputError: shapes that do not match the priors, non-finite or non-positive values, a camera that is not a
            finite ``(3,)`` position, or a setting out of its range (:func:`_check_turn_settings`).
    """
    T, S, u, piv, pts, lab, cam = _checked_scene(cam_from_part, size_m, joint_axis, points, labels, priors, camera, joint_pivot)
    K = priors.num_parts
    _check_turn_settings(weak_share, strong_share, turn_cost, max_turn_deg, step_deg, upright_margin_deg)
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
        ok = _turns_allowed(cand, q, jp, priors.parts[w], upright_margin_deg)
        others = pts[on_part & (lab != w)]
        own = pts[lab == w]
        hidden, misfit = np.zeros(len(angles)), np.zeros(len(angles))
        if len(others):
            hidden = segments_through_box(cand, shrink * S[w], others, stop, camera=cam).mean(1)
        if len(own):
            misfit = np.median(box_surface_distance(cand, S[w], own), axis=1) / np.linalg.norm(S[w])
        cost = np.where(ok, hidden + misfit + turn_cost * np.abs(angles), np.inf)
        best = int(np.argmin(cost))
        if best != 0:
            T[w] = cand[best]
            turned[w] = angles[best]
    return T, turned
