"""The sizes a cloud is estimated at: the rescaling into a model's training sizes, and the checks of a cloud's
size against them.

Frames and units: camera frame, metres.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..priors import CategoryPriors, cloud_radius

__all__ = ["input_scale", "extent_warnings", "EXTENT_WARN", "EXTENT_REFUSE", "RESCALE_CORE_FACTOR"]

EXTENT_WARN = 1.5
"""A cloud whose size (:func:`ucope.priors.cloud_radius`) is more than this factor outside the model's training
range gets a warning ..."""

EXTENT_REFUSE = 20.0
"""... and more than this factor outside it is refused (another unit, or not this kind of object)."""

RESCALE_CORE_FACTOR = 1.4
"""The rescaling measures a cloud by its 90th-percentile radius, but at most this factor times twice its median
radius (its core), so that a floor seen far behind the object or stray points do not make it look large."""


def input_scale(
    priors: CategoryPriors, points: np.ndarray, normalise: float | None = None, rescale: bool = True
) -> tuple[float, np.ndarray]:
    """``(s, c)``: the factor a pass scales ``points`` ``(N, 3)`` by about their median point ``c`` ``(3,)``
    (camera frame, metres). 1 unless ``rescale`` and the cloud's radius ``r`` (:func:`ucope.priors.cloud_radius`,
    at most :data:`RESCALE_CORE_FACTOR` x twice its median radius) lies below the radii the model saw often
    (``lo``, ``priors.radius_typical_m``) or above the largest it saw (``priors.radius_range_m``); then
    ``sqrt(lo hi) / r`` with ``[lo, hi]`` the typical radii. ``normalise``: a factor ``f`` (> 0) gives
    ``f sqrt(lo hi) / r`` whatever ``r`` (the scale search).

    Raises:
        InputError: ``normalise`` not a positive finite number or None."""
    if normalise is not None and not (
        isinstance(normalise, float | int) and not isinstance(normalise, bool) and 0.0 < normalise < np.inf
    ):
        raise InputError(f"normalise must be a positive factor or None, got {normalise!r}")
    pts = np.asarray(points, np.float64)
    full = priors.radius_range_m
    centre = np.median(pts, axis=0)
    if not rescale or full is None:
        return 1.0, centre
    typ = priors.radius_typical_m or full
    core = 2.0 * float(np.median(np.linalg.norm(pts - centre, axis=1)))
    r = min(cloud_radius(pts), RESCALE_CORE_FACTOR * core)
    lo, hi = float(typ[0]), float(typ[1])
    if r <= 0.0 or (normalise is None and lo <= r <= float(full[1])):
        return 1.0, centre
    return float((1.0 if normalise is None else normalise) * np.sqrt(lo * hi) / r), centre


def extent_warnings(priors: CategoryPriors, pts: np.ndarray, units: str) -> list[str]:
    """Refuse a cloud far outside the sizes the model was trained on (with a hint at its units: an InputError);
    warn about one outside them, and about one that only far stray points make look far too big."""
    rng = priors.radius_range_m
    if rng is None:
        return []
    category = priors.category
    r = cloud_radius(pts)
    lo, hi = rng
    if r > hi * EXTENT_REFUSE:  # a few far points (a floor seen to the horizon) raise the radius alone: warned
        core = 2.0 * float(np.median(np.linalg.norm(pts - np.median(pts, axis=0), axis=1)))
        if core <= hi * EXTENT_REFUSE:
            return [
                f"the cloud's size ({r:.3g} m, 90th-percentile radius) is far outside the {lo:.3g}-{hi:.3g} m the "
                f"{category} model was trained on, but half of its points lie within {core / 2:.3g} m: far "
                "points that are not the object (a floor or background in the mask?) make it look big"
            ]
    if lo / EXTENT_REFUSE <= r <= hi * EXTENT_REFUSE:
        if lo / EXTENT_WARN <= r <= hi * EXTENT_WARN:
            return []
        return [
            f"the cloud's size ({r:.3g} m, 90th-percentile radius) is outside the {lo:.3g}-{hi:.3g} m the "
            f"{category} model was trained on: poses and boxes may be off"
        ]
    hint = ""
    for unit, factor in (("mm", 1000.0), ("cm", 100.0)):
        if units == "m" and lo / 3 <= r / factor <= hi * 3:
            hint = f"; it looks like {unit}: pass units='{unit}' (ucope predict --units {unit})"
            break
    else:
        if units != "m" and lo / 3 <= r * {"mm": 1000.0, "cm": 100.0}[units] <= hi * 3:
            hint = "; it looks like metres already: leave units at 'm'"
    raise InputError(
        f"the cloud's size ({r:.3g} m, 90th-percentile radius) is far outside the {lo:.3g}-{hi:.3g} m the "
        f"{category} model was trained on{hint}"
    )
