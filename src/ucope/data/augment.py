"""Training augmentation: the robustness benchmark's corruptions (:mod:`ucope.data.corrupt`), drawn at random.

A real depth camera and a real segmentation hand the estimator noisy, sparse, partly occluded clouds
with floor, outlier and neighbouring-object points in them. :func:`augment_sample` turns a clean
training view into such a cloud: with probability :attr:`AugmentConfig.probability` it applies each
corruption below independently with its own probability, at a level drawn from its range, in this
order (removals first, additions next, noise last, the point count at the very end):

======================  ===========  =====================================================
corruption              probability  level
======================  ===========  =====================================================
occlusion by a plane    0.30         keep 40-95 % of the points
mask bleed              0.30         5-35 % of the object's points (floor and distractors)
floor points            0.35         5-100 % of the object's points
outliers                0.30         2-25 % uniform in the 1.5x box of the object
isotropic noise         0.35         sigma 0.5-7 mm
axial (sensor) noise    0.20         1-5 x the sensor model's sigma(z)
resampling              0.30         100-4096 points, log-uniform
======================  ===========  =====================================================

Every draw comes from the ``rng`` passed in (the training items key it by seed, epoch and sample), so
an augmented item is the same on any machine and after a resume. Added points carry the label ``-1``
("not the object"); the floor and bleed corruptions need the sample's background pool (``bg_`` fields,
:func:`ucope.data.sample.background_fields`) and are skipped without it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .corrupt import (
    BackgroundPool,
    CorruptionContext,
    add_floor,
    add_outliers,
    axial_noise,
    isotropic_noise,
    mask_bleed,
    occlude,
    resample,
)

__all__ = ["AugmentConfig", "augment_sample", "sample_context"]


@dataclass(frozen=True)
class AugmentConfig:
    """Probabilities and level ranges of :func:`augment_sample` (defaults: the module table).

    Attributes:
        probability: chance that an item is corrupted at all (the rest stay as rendered).
        p_*: each corruption's chance on a corrupted item; *_range: its level range.
    """

    probability: float = 0.7
    p_occlude: float = 0.30
    occlude_keep: tuple[float, float] = (0.40, 0.95)
    p_bleed: float = 0.30
    bleed_range: tuple[float, float] = (0.05, 0.35)
    p_floor: float = 0.35
    floor_range: tuple[float, float] = (0.05, 1.0)
    p_outliers: float = 0.30
    outlier_range: tuple[float, float] = (0.02, 0.25)
    p_noise: float = 0.35
    noise_m: tuple[float, float] = (0.0005, 0.007)
    p_axial: float = 0.20
    axial_factor: tuple[float, float] = (1.0, 5.0)
    p_resample: float = 0.30
    resample_points: tuple[int, int] = (100, 4096)

    def __post_init__(self) -> None:
        for name in ("probability", "p_occlude", "p_bleed", "p_floor", "p_outliers", "p_noise", "p_axial", "p_resample"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise InputError(f"augmentation {name} must be a probability in [0, 1], got {v}")
        for name in ("occlude_keep", "bleed_range", "floor_range", "outlier_range", "noise_m", "axial_factor", "resample_points"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
                raise InputError(f"augmentation {name} must be a range 0 <= lo <= hi, got {(lo, hi)}")

    @classmethod
    def from_settings(cls, probability: float, settings: dict | None = None) -> AugmentConfig:
        """The configuration with chance ``probability`` and the fields in ``settings`` changed.

        Args:
            probability: :attr:`probability`.
            settings: ``{field: value}`` for any other field: a probability for a ``p_*`` field, a pair
                ``[lo, hi]`` for a range (``noise_m`` in metres, ``resample_points`` point counts). JSON
                lists are taken as pairs, so a model card's ``train_config`` round-trips.

        Raises:
            InputError: an unknown field (the known ones are named), a range that is not two numbers,
                or a value out of its bounds.
        """
        settings = dict(settings or {})
        known = [f.name for f in dataclasses.fields(cls) if f.name != "probability"]
        unknown = sorted(set(settings) - set(known))
        if unknown:
            raise InputError(f"unknown augmentation setting(s) {', '.join(unknown)}; known: {', '.join(known)}")
        kw: dict = {}
        for k, v in settings.items():
            if k.startswith("p_"):
                try:
                    kw[k] = float(v)
                except (TypeError, ValueError):
                    raise InputError(f"augmentation {k} must be a probability, got {v!r}") from None
                continue
            try:
                lo, hi = (float(x) for x in v)
            except (TypeError, ValueError):
                raise InputError(f"augmentation {k} must be a range of two numbers [lo, hi], got {v!r}") from None
            kw[k] = (int(round(lo)), int(round(hi))) if k == "resample_points" else (lo, hi)
        return cls(probability=float(probability), **kw)


MIN_DEPTH_M = 0.05
"""Background points nearer the camera than this are left out of the pool (no depth sensor returns them;
generator-2 pools hold a few at 1 mm, the noise model's quantisation floor, which further noise can push
behind the camera), and so are any points of the corrupted cloud before the axial noise (the outliers of
a large object seen from near by fill a box that reaches behind the camera)."""


def sample_context(sample: dict) -> CorruptionContext:
    """The :class:`CorruptionContext` of a training sample: its true part boxes and, when the sample has
    one, its background pool (stored thinned to the cloud's density: ``pixels_per_point = 1``) without
    points nearer than :data:`MIN_DEPTH_M`."""
    pool = None
    if "bg_points" in sample and len(sample["bg_points"]):
        bg = np.asarray(sample["bg_points"], np.float64)
        keep = bg[:, 2] >= MIN_DEPTH_M
        pool = BackgroundPool(
            bg[keep],
            np.asarray(sample["bg_rank"], np.float64)[keep],
            np.asarray(sample["bg_clutter"], bool)[keep],
            1.0,
        )
    return CorruptionContext(
        cam_from_part=np.asarray(sample["cam_from_part"], np.float64),
        size_m=np.asarray(sample["size_m"], np.float64),
        background=pool,
    )


def augment_sample(
    sample: dict, rng: np.random.Generator, config: AugmentConfig | None = None
) -> tuple[np.ndarray, np.ndarray, bool]:
    """A corrupted copy of a training sample's cloud (see the module docstring).

    Args:
        sample: a sample dict (``points`` ``(N, 3)`` camera frame, metres; ``part_labels`` ``(N,)``;
            ``cam_from_part``, ``size_m``; optionally the ``bg_`` pool).
        rng: the only source of randomness.
        config: :class:`AugmentConfig`.

    Returns:
        ``(points (N', 3) float32, labels (N',) int64, corrupted)``: labels ``-1`` mark added points;
        ``corrupted`` tells whether anything was applied (when not, the arrays are the sample's).
    """
    c = config or AugmentConfig()
    pts = np.asarray(sample["points"])
    lab = np.asarray(sample["part_labels"], dtype=np.int64)
    if rng.random() >= c.probability:
        return pts.astype(np.float32, copy=False), lab, False
    ctx = sample_context(sample)
    u = rng.random(7)  # one draw per corruption, whatever is applied: the stream does not depend on the choices
    if u[0] < c.p_occlude:
        q, m = occlude(pts, lab, rng.uniform(*c.occlude_keep), rng, ctx)
        if np.count_nonzero(m >= 0) >= 32:  # keep enough of the object to learn from
            pts, lab = q, m
    has_pool = ctx.background is not None
    if has_pool and u[1] < c.p_bleed:
        pts, lab = mask_bleed(pts, lab, rng.uniform(*c.bleed_range), rng, ctx)
    if has_pool and u[2] < c.p_floor:
        pts, lab = add_floor(pts, lab, rng.uniform(*c.floor_range), rng, ctx)
    if u[3] < c.p_outliers:
        pts, lab = add_outliers(pts, lab, rng.uniform(*c.outlier_range), rng, ctx)
    if u[4] < c.p_noise:
        pts, lab = isotropic_noise(pts, lab, rng.uniform(*c.noise_m), rng, ctx)
    near = np.asarray(pts)[:, 2] < MIN_DEPTH_M  # no sensor returns these; outliers of a big, near object can lie there
    if near.any():
        pts, lab = np.asarray(pts)[~near], np.asarray(lab)[~near]
    if u[5] < c.p_axial:
        pts, lab = axial_noise(pts, lab, rng.uniform(*c.axial_factor), rng, ctx)
    if u[6] < c.p_resample:
        lo, hi = c.resample_points
        n = int(round(math.exp(rng.uniform(math.log(max(lo, 1)), math.log(max(hi, 1))))))
        if n < len(pts):  # fewer points only (more would only repeat them)
            pts, lab = resample(pts, lab, n, rng, ctx)
    return np.asarray(pts, np.float32), np.asarray(lab, np.int64), True
