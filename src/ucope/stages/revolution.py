"""Boxes of parts symmetric about y measured from their own points: a surface-of-revolution fit.

A part symmetric about its y axis (bottle, bowl, can) is a surface of revolution: once its axis direction is
voted, its points in the voted frame lie on circles about one axis line, one radius per height.
:func:`fit_revolution` fits that line and the radii; :func:`refine_revolution` turns the fit into the part's
amodal box and centre, and replaces the voted ones where the two disagree by more than a factor (the votes are
kept where they agree). Camera frame, metres; part frame with y the symmetry axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .base import PoseState, stage


@dataclass(frozen=True)
class RevolutionFitParams:
    """Attributes: factor: the fitted box replaces the voted one where their sizes differ by more than this factor
    on some axis; max_spread: ... and where the fit is good (:attr:`RevolutionFit.spread` at most this)."""

    factor: float = 1.2
    max_spread: float = 0.08

    def __post_init__(self) -> None:
        if not (self.factor > 1.0 and self.max_spread >= 0.0):
            raise InputError(f"factor must be > 1 and max_spread >= 0, got {self.factor}, {self.max_spread}")


_P = RevolutionFitParams()


@dataclass(frozen=True)
class RevolutionFit:
    """A surface of revolution about an axis parallel to y, fitted to points in a part frame.

    Attributes:
        axis_xz: ``(2,)`` where the axis line crosses the x-z plane (part frame, metres).
        radii_m: ``(S,)`` the radius of each height slice with enough points, bottom to top.
        y_range_m: ``(2,)`` the lowest and highest inlier height (0.5th / 99.5th percentiles).
        spread: the median absolute radial residual over the largest radius (0: points exactly on circles).
        num_inliers: points within three robust sigmas of their slice's circle.
    """

    axis_xz: np.ndarray
    radii_m: np.ndarray
    y_range_m: np.ndarray
    spread: float
    num_inliers: int

    @property
    def size_m(self) -> np.ndarray:
        """``(3,)`` the box of the fitted surface: twice the largest radius across, the inlier height along y."""
        d = 2.0 * float(self.radii_m.max())
        return np.array([d, float(self.y_range_m[1] - self.y_range_m[0]), d])

    @property
    def centre_m(self) -> np.ndarray:
        """``(3,)`` the box centre in the part frame."""
        return np.array([self.axis_xz[0], 0.5 * float(self.y_range_m.sum()), self.axis_xz[1]])


def fit_revolution(local, slices: int = 8, min_points: int = 8, iterations: int = 3) -> RevolutionFit | None:
    """Fit circles about one axis line parallel to y, one radius per height slice, to ``local`` points.

    The points' heights (0.5th-99.5th percentiles) are cut into ``slices`` equal slices; slices with at
    least ``min_points`` points take part. Each point ``q = (x, z)`` on its slice's circle satisfies
    ``|q|^2 = 2 q . c + d_s`` with ``c`` the axis and ``d_s = r_s^2 - |c|^2``: linear least squares in
    ``(c, d_1..d_S)`` (the Kasa fit with a shared centre), reweighted ``iterations`` times with Huber
    weights on the radial residuals so that stray points count less. Only the visible side of the
    surface is needed (an arc of a quarter turn or more per slice fits well).

    Args:
        local: ``(N, 3)`` points in the part frame (y the symmetry axis), metres.
        slices, min_points, iterations: as above (``slices >= 1``, ``min_points >= 3``, ``iterations >= 1``).

    Returns:
        a :class:`RevolutionFit`, or ``None`` when no slice has enough points or the fit is degenerate
        (a negative squared radius: the points do not bend about any axis).

    Raises:
        InputError: a wrong shape or non-finite points, or settings out of range.
    """
    q3 = np.asarray(local, dtype=np.float64)
    if q3.ndim != 2 or q3.shape[1] != 3 or not np.all(np.isfinite(q3)):
        raise InputError(f"local points must be a finite (N, 3) array, got shape {q3.shape}")
    if int(slices) < 1 or int(min_points) < 3 or int(iterations) < 1:
        raise InputError(f"need slices >= 1, min_points >= 3, iterations >= 1; got {slices}, {min_points}, {iterations}")
    if len(q3) < min_points:
        return None
    y = q3[:, 1]
    lo, hi = np.percentile(y, [0.5, 99.5])
    slot = np.clip(((y - lo) / max(hi - lo, 1e-12) * slices).astype(np.int64), 0, slices - 1)
    full = np.bincount(slot, minlength=slices) >= min_points
    if not full.any():
        return None
    use = full[slot]
    q, y = q3[use][:, [0, 2]], y[use]
    col = (np.cumsum(full) - 1)[slot[use]]  # the slice's column among the full ones
    S = int(full.sum())
    A = np.zeros((len(q), 2 + S))
    A[:, :2] = 2.0 * q
    A[np.arange(len(q)), 2 + col] = 1.0
    b = (q * q).sum(axis=1)
    w = np.ones(len(q))
    for _ in range(int(iterations)):
        sol = np.linalg.lstsq(A * w[:, None], b * w, rcond=None)[0]
        c, r2 = sol[:2], sol[2:] + sol[:2] @ sol[:2]
        if np.any(r2 <= 0.0):
            return None
        r = np.sqrt(r2)
        res = np.linalg.norm(q - c, axis=1) - r[col]
        sigma = 1.4826 * float(np.median(np.abs(res))) + 1e-5
        w = 1.0 / np.maximum(1.0, np.abs(res) / (2.0 * sigma))
    inl = np.abs(res) < 3.0 * sigma
    y_range = np.percentile(y[inl], [0.5, 99.5]) if inl.sum() >= min_points else np.array([lo, hi])
    return RevolutionFit(
        axis_xz=c,
        radii_m=r,
        y_range_m=np.asarray(y_range, np.float64),
        spread=float(np.median(np.abs(res)) / r.max()),
        num_inliers=int(inl.sum()),
    )


def looks_cut(y_range_m, height_m: float, overhang: float = 0.1, balance: float = 0.3) -> bool:
    """Whether the points' height range ``(2,)`` looks cut off at one end of the voted box of height
    ``height_m`` (centred at 0 in the part frame): the box reaches more than ``overhang`` x its height past
    the points at one end and less than ``balance`` x that at the other. An occluder (or the image border)
    that hides the top or bottom of the part does this; a part that is really shorter or taller than the
    vote leaves the box about evenly past (or short of) both ends."""
    below = float(y_range_m[0]) + 0.5 * height_m  # how far the box reaches below the lowest point
    above = 0.5 * height_m - float(y_range_m[1])
    big, small = max(below, above), min(below, above)
    return big > overhang * height_m and small < balance * big


def refine_revolution(
    cam_from_part, size_m, points, factor: float = _P.factor, max_spread: float = _P.max_spread
) -> tuple[np.ndarray, np.ndarray, bool]:
    """A y-symmetric part's box and centre from its own points, where they disagree with the vote.

    The points are brought into the voted part frame (its y axis is trusted; its centre and size are not)
    and :func:`fit_revolution` measures the surface: the box is twice the largest radius across and the
    inlier height along y, centred on the axis line at mid-height. The fit replaces the voted box and
    centre when it is good (``spread <= max_spread``, a size within 1/3-3x of the vote on every axis) and
    differs from the vote by more than ``factor`` on some axis, unless the points look cut off at one
    end of the voted box (:func:`looks_cut`: then their height and widest slice say little about the
    whole part); otherwise the vote stands.

    Args:
        cam_from_part: ``(4, 4)`` the voted pose; size_m: ``(3,)`` the voted size (metres).
        points: ``(N, 3)`` the part's points, camera frame, metres.
        factor: the disagreement (> 1) above which the fit wins; max_spread: see :class:`RevolutionFit`.

    Returns:
        ``(cam_from_part, size_m, replaced)``: the pose (rotation unchanged) and size, copies, and whether
        the fit replaced the vote.

    Raises:
        InputError: ``factor <= 1`` or a wrong shape.
    """
    if not float(factor) > 1.0:
        raise InputError(f"factor must be > 1, got {factor}")
    T = np.array(cam_from_part, dtype=np.float64, copy=True)
    S = np.array(size_m, dtype=np.float64, copy=True)
    if T.shape != (4, 4) or S.shape != (3,):
        raise InputError(f"need a (4, 4) pose and a (3,) size, got {T.shape} and {S.shape}")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    fit = fit_revolution((pts - T[:3, 3]) @ T[:3, :3])
    if fit is None or fit.spread > max_spread or not np.all(S > 0):
        return T, S, False
    ratio = fit.size_m / S
    if not np.all((ratio > 1.0 / 3.0) & (ratio < 3.0)) or np.all(np.abs(np.log(ratio)) <= np.log(factor)):
        return T, S, False
    if looks_cut(fit.y_range_m, S[1]):
        return T, S, False
    T[:3, 3] = T[:3, 3] + T[:3, :3] @ fit.centre_m
    return T, fit.size_m, True


@stage(
    "revolution_fit",
    kind="geometry",
    params=RevolutionFitParams,
    applies=lambda priors: priors.num_joints == 0 and bool(np.any(priors.symmetric)),
)
def _revolution_fit(state: PoseState, params: RevolutionFitParams) -> None:
    """The box and centre of a part symmetric about y from a surface-of-revolution fit to its points."""
    pts = np.asarray(state.points, np.float64)
    T, S = np.array(state.cam_from_part), np.array(state.size_m)
    for k in np.flatnonzero(state.priors.symmetric):  # a part or two
        T[k], S[k], _ = refine_revolution(T[k], S[k], pts[state.part_points[k]], params.factor, params.max_spread)
    state.cam_from_part, state.size_m = T, S
