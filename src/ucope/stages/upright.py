"""The upright the training views kept each part in (``PartPrior.upright_*``).

:func:`carry_upright` re-places a part that voting tilted far outside its training cone (a laptop base hidden
behind its lid, voted on end from a few points) from a neighbour through their revolute joint: the state
within the limits that brings the part nearest its upright, its centre from the joint axis's place in both
parts' unit boxes (``JointPrior.pivot_in_parent`` / ``pivot_in_child``). :func:`turn_upright` turns a part of
a rigid object voted upside down over by the half turn its points fit best. Both assume the camera is upright
(no roll) and looks from the training elevations. Camera frame, metres, degrees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.transforms import rotation_about_axis
from ..priors import CategoryPriors
from ..vocab import JointType
from .base import PoseState, stage
from .flips import ShapeIndex, _shape_misfit
from .support import (
    _HALF_TURNS,
    SHAPE_CLIP,
    UPRIGHT_MARGIN_DEG,
    _hinged_centre,
)


@dataclass(frozen=True)
class UprightParams:
    """Attributes:
    margin_deg: how far beyond its training cone (``PartPrior.upright_cone_deg``) a part's upright axis may tilt
        before it is re-placed or turned over (0: as soon as it leaves the cone).
    clip: the template distance cap of a rigid part's fit (unit-box sizes).
    """

    margin_deg: float = UPRIGHT_MARGIN_DEG
    clip: float = SHAPE_CLIP

    def __post_init__(self) -> None:
        if not (0.0 <= self.margin_deg <= 180.0 and self.clip > 0.0):
            raise InputError(f"margin_deg must be in [0, 180] and clip > 0, got {self.margin_deg}, {self.clip}")


_P = UprightParams()

_CARRY_STEPS = 181
"""Joint states tried per revolute joint by :func:`carry_upright` (evenly over the limits)."""


_TIE_DEG = 1.0
"""States whose upright angle is within this of the best count as equally upright (:func:`carry_upright`
then keeps the one nearest the voted rotation)."""


def upright_angles_deg(cam_from_part: np.ndarray, priors: CategoryPriors) -> np.ndarray:
    """``(K,)`` angle (degrees) between each part's upright axis and the camera-frame direction the
    training views held it in (``PartPrior.upright_axis`` / ``upright_in_cam``); NaN for a part without one.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses (camera frame).
    """
    T = np.asarray(cam_from_part, dtype=np.float64)
    out = np.full(priors.num_parts, np.nan)
    for k, pp in enumerate(priors.parts):
        if pp.upright_axis is not None:
            c = float(T[k, :3, pp.upright_axis] @ np.asarray(pp.upright_in_cam))
            out[k] = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
    return out


def turn_upright(
    cam_from_part: np.ndarray,
    size_m: np.ndarray,
    points: np.ndarray,
    part_points: list,
    priors: CategoryPriors,
    shapes: ShapeIndex | None = None,
    margin_deg: float = _P.margin_deg,
    clip: float = _P.clip,
) -> tuple[np.ndarray, np.ndarray]:
    """Turn a part voted upside down back onto its upright by the half turn its points fit best.

    For an object without joints (no neighbour to carry a part from, :func:`carry_upright`): a part with an
    upright prior (``PartPrior.upright_*``) whose upright axis lies more than ``upright_cone_deg + margin_deg``
    from the training views' direction is turned by a half turn about one of its two other axes that brings it
    within that cone, its centre placed from its points under the turn (:func:`_centre_from_points`). Where both
    turns qualify (they differ by a half turn about the upright axis itself), the one whose placed box puts the
    points nearest the category's shape template stands (mean distance clipped at ``clip``, as
    :func:`ucope.stages.flips.resolve_shape_flips`; a part symmetric about y, or without a template, takes the
    first). Sizes are kept; a part within its cone plus the margin is not touched.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses (camera frame, metres); size_m: ``(K, 3)`` box extents.
        points: ``(N, 3)`` camera frame; part_points: per part, indices into ``points``.
        priors: the category's priors (upright priors, shape templates); shapes: their :class:`ShapeIndex`
            (built here when ``None`` and needed).
        margin_deg: tolerance beyond the training cone, degrees (>= 0); clip: unit-box sizes (> 0).

    Returns:
        ``(cam_from_part, turned)``: a copy with the turned parts, and ``(K,)`` bool.

    Raises:
        InputError: shapes that do not match the priors, non-finite poses or points, a non-positive size, a
            negative margin.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    P = np.asarray(points, dtype=np.float64)
    K = priors.num_parts
    if T.shape != (K, 4, 4) or S.shape != (K, 3) or len(part_points) != K or P.ndim != 2 or P.shape[-1] != 3:
        raise InputError(
            f"cam_from_part, size_m, part_points and points must be ({K}, 4, 4), ({K}, 3), {K} index arrays and (N, 3), "
            f"got {T.shape}, {S.shape}, {len(part_points)}, {P.shape}"
        )
    if not (np.isfinite(T).all() and np.isfinite(P).all() and np.isfinite(S).all()) or (S <= 0).any():
        raise InputError("cam_from_part and points must be finite and size_m finite and positive")
    if not margin_deg >= 0:
        raise InputError(f"margin_deg must be >= 0, got {margin_deg!r}")
    turned = np.zeros(K, dtype=bool)
    trees = None
    for k, part in enumerate(priors.parts):  # a handful of parts
        if part.upright_axis is None:
            continue
        a, up = int(part.upright_axis), np.asarray(part.upright_in_cam, np.float64)
        limit = np.cos(np.radians(part.upright_cone_deg + float(margin_deg)))
        if T[k, :3, a] @ up >= limit:
            continue
        # the half turns about the part's other axes (diagonal, flipping two axes) that bring it within the cone
        options = [D for D in _HALF_TURNS[1:] if D[a, a] < 0 and (T[k, :3, :3] @ D)[:, a] @ up >= limit]
        if not options:
            continue
        idx = np.asarray(part_points[k], dtype=np.int64)
        poses = []
        for D in options:  # one or two: the rotation turned, the centre placed from the points under it
            X = T[k].copy()
            X[:3, :3] = X[:3, :3] @ D
            if len(idx) >= 3:  # the votes that saw it upside down put its centre off too
                X[:3, 3] = _centre_from_points(X, S[k], P[idx])
            poses.append(X)
        if len(poses) > 1 and not priors.symmetric[k] and len(idx):
            trees = trees or (shapes or ShapeIndex.from_priors(priors)).trees
            if trees[k] is not None:
                cost = [_shape_misfit(trees[k], P[idx], X, S[k], clip) for X in poses]  # two turns
                poses = [poses[int(np.argmin(cost))]]
        T[k] = poses[0]
        turned[k] = True
    return T, turned


def _centre_from_points(T: np.ndarray, size: np.ndarray, points: np.ndarray) -> np.ndarray:
    """A box centre (camera frame) from the points' 1-99 % range in the box frame ``T``: along each axis the
    face the camera lies beyond is put at the points' extreme on its side, the centre half the extent behind
    it; where the camera lies within the range, or the range is wider than the box, the centre is its middle."""
    R, t = T[:3, :3], T[:3, 3]
    local = (points - t) @ R
    lo, hi = np.quantile(local, [0.01, 0.99], axis=0)
    cam = -(R.T @ t)
    mid = 0.5 * (lo + hi)
    centre = np.where(cam > hi, hi - 0.5 * size, np.where(cam < lo, lo + 0.5 * size, mid))
    centre = np.where(hi - lo >= size, mid, centre)
    return t + R @ centre


def carry_upright(
    cam_from_part: np.ndarray, size_m: np.ndarray, priors: CategoryPriors, margin_deg: float = _P.margin_deg
) -> tuple[np.ndarray, np.ndarray]:
    """Re-place, from a neighbour through their joint, each part voted far off its upright.

    A part ``k`` with an upright prior whose axis lies more than ``upright_cone_deg + margin_deg`` from
    ``upright_in_cam`` (:func:`upright_angles_deg`) is implausible for the views the model was trained
    on. For each joint linking it to a neighbour ``o`` that is not itself implausible, the part is
    turned with ``o`` through the joint: revolute joints try :data:`_CARRY_STEPS` states over the
    limits (``R_k = R_o Rot(a, q)^T`` for a parent, ``R_o Rot(a, q)`` for a child, ``a`` the canonical
    axis) and keep the one nearest the upright (of equally upright ones, as when the joint turns about
    the upright axis itself, the one nearest the voted rotation); prismatic joints give ``R_k = R_o``. The neighbour
    whose best state brings the part nearest its upright wins, when that is inside the cone plus the
    margin. The part's centre then follows from where the joint axis passes in both unit boxes
    (``pivot_in_parent`` / ``pivot_in_child`` times the box extents); without those (prismatic joints,
    priors that lack them) it keeps its voted centre. Sizes are kept.

    This assumes what the training views show: an upright camera (little roll) looking from the
    category's elevations; drop the stage ``upright`` for other cameras.

    Args:
        cam_from_part: ``(K, 4, 4)`` voted poses; size_m: ``(K, 3)`` voted box extents (metres).
        priors: the category's priors.
        margin_deg: tolerance beyond the training cone, degrees.

    Returns:
        ``(cam_from_part, carried)``: a copy with the re-placed parts, and ``(K,)`` bool.
    """
    T = np.array(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    K = priors.num_parts
    carried = np.zeros(K, dtype=bool)
    if priors.num_joints == 0:
        return T, carried
    limit = np.array([np.nan if p.upright_cone_deg is None else p.upright_cone_deg + float(margin_deg) for p in priors.parts])
    bad = upright_angles_deg(T, priors) > limit  # NaN compares False: parts without a prior are never bad
    for k in np.flatnonzero(bad):  # a handful of parts
        pp = priors.parts[k]
        up = np.asarray(pp.upright_in_cam)
        best = (np.inf, None, None)
        for jp in priors.joints:
            if k not in (jp.parent, jp.child):
                continue
            o = jp.child if k == jp.parent else jp.parent
            if bad[o] and not carried[o]:
                continue
            Ro = T[o, :3, :3]
            if jp.type == JointType.REVOLUTE:
                lo, hi = jp.limits
                q = np.linspace(-np.pi if lo is None else lo, np.pi if hi is None else hi, _CARRY_STEPS)
                G = rotation_about_axis(jp.axis, q)  # (Q, 3, 3)
                Rk = Ro @ G.transpose(0, 2, 1) if k == jp.parent else Ro @ G
            else:
                Rk = Ro[None]
            ang = np.degrees(np.arccos(np.clip(Rk[:, :, pp.upright_axis] @ up, -1.0, 1.0)))
            # Among the states within _TIE_DEG of the best (all of them when the joint turns about the
            # upright axis itself), the one nearest the voted rotation.
            near = np.flatnonzero(ang <= ang.min() + _TIE_DEG)
            i = int(near[np.argmax(np.einsum("qij,ij->q", Rk[near], T[k, :3, :3]))])
            if ang[i] < best[0]:
                best = (float(ang[i]), Rk[i], jp)
        err, Rk, jp = best
        if jp is None or not err <= limit[k]:
            continue
        o = jp.child if k == jp.parent else jp.parent
        t = T[k, :3, 3].copy()
        if jp.pivot_in_parent is not None:
            t = _hinged_centre(T[o], S[o], Rk, S[k], jp, k == jp.parent)[0]
        T[k, :3, :3] = Rk
        T[k, :3, 3] = t
        carried[k] = True
    return T, carried


@stage(
    "upright",
    kind="learned-prior",
    params=UprightParams,
    reads=(
        "parts.upright_in_cam",
        "parts.upright_cone_deg",
        "joints.pivot_in_parent",
        "joints.pivot_in_child",
        "shape_templates",
    ),
)
def _upright(state: PoseState, params: UprightParams) -> None:
    """A part voted far off the upright its training views kept it in: re-placed from a neighbour through their joint
    (its score halved), or, in a rigid object, turned over by the half turn its points fit best. Assumes an upright
    camera."""
    if state.J > 0:
        state.cam_from_part, carried = carry_upright(state.cam_from_part, state.size_m, state.priors, params.margin_deg)
        state.carried = state.carried | carried
        what = "it was placed from its neighbour through their joint, its score halved"
        moved = carried
    else:
        state.cam_from_part, moved = turn_upright(
            state.cam_from_part,
            state.size_m,
            np.asarray(state.points, np.float64),
            state.part_points,
            state.priors,
            state.shapes,
            margin_deg=params.margin_deg,
            clip=params.clip,
        )
        what = "it was turned over by a half turn"
    for k in np.flatnonzero(moved):
        state.warnings.append(
            f"part {state.part_name(k)!r}: its voted pose was "
            f"{'tilted far off' if state.J > 0 else 'upside down against'} the upright this model was trained on; "
            f"{what} (drop the stage upright if the camera is rolled or below the object)"
        )
