"""How many estimates one view gets and which one stands: the recrop, the scale search, the restarts.

One *pass* runs the network and the stages once on a cloud at one scale and one draw of the network's points.
An *estimate* is one or two passes (the recrop: a second pass on the points the first took as the object). The
search makes further estimates where the best calibrated score so far is low, on the cloud normalised to other
sizes and on other draws of its points, and keeps the highest-scored one (:class:`SearchPolicy`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..priors import cloud_radius
from ..vocab import MIN_POINTS
from .result import JointEstimate, PartEstimate

__all__ = ["SearchPolicy", "Pass", "Estimate", "recrop", "search", "compact", "PICKS", "FAST"]

PICKS = ("all", "seen")

FAST = {"search.recrop": False, "search.scale_factors": [], "search.restarts": 0}
"""Overrides of the fast setting (``ucope predict --fast``): one estimate of one pass, whatever the score."""


@dataclass(frozen=True)
class SearchPolicy:
    """Attributes:
    rescale: bring a cloud outside the model's training sizes to the middle of them for the estimate (the poses,
        sizes and prismatic states are scaled back).
    recrop: a second pass on the object's points alone where the first leaves at least ``recrop_min_fraction`` of
        the cloud out as not the object (the background class, a support plane) or where they need rescaling.
    scale_factors: where the first estimate's object score is below ``scale_below``, one more estimate per factor,
        on the cloud normalised to that factor of the middle of the model's typical sizes (``()``: none).
    restarts: up to this many further estimates from other draws of the network's points and pairs while the best
        object score so far is below ``restart_below``.
    pick: which estimate stands: ``"all"``, the highest object score (its lowest part score); ``"seen"``, the
        highest lowest score over the parts given at least one point.
    compact_factor: with ``recrop``, the first pass rescales only a compact cloud (its 90th-percentile radius at
        most this factor times twice its median radius): a floor or stray points would make it look large.
    roll_from_plane: where no ``up`` is given and the cloud holds a support plane (a floor or table the mask let
        in: :func:`ucope.geometry.planes.find_support_plane`), the plane's normal is taken as the world's up and a
        camera roll of more than ``roll_min_deg`` it shows is taken out for the estimate (as with ``up``).
    The scale search and the restarts need a calibrated model (their rules compare scores).
    """

    rescale: bool = True
    recrop: bool = True
    recrop_min_fraction: float = 0.03
    scale_factors: tuple[float, ...] = (1.0,)
    scale_below: float = 0.9
    restarts: int = 0
    restart_below: float = 0.8
    pick: str = "all"
    compact_factor: float = 1.8
    roll_from_plane: bool = False
    roll_min_deg: float = 5.0

    def __post_init__(self) -> None:
        if self.pick not in PICKS:
            raise InputError(f"search.pick must be one of {PICKS}, got {self.pick!r}")
        if not (isinstance(self.restarts, int) and 0 <= self.restarts <= 16):
            raise InputError(f"search.restarts must be an integer from 0 to 16, got {self.restarts!r}")
        if any(not (isinstance(f, float | int) and 0.0 < f < np.inf) for f in self.scale_factors):
            raise InputError(f"search.scale_factors must be positive numbers, got {self.scale_factors!r}")
        if not 0.0 <= self.recrop_min_fraction <= 1.0:
            raise InputError(f"search.recrop_min_fraction must be in [0, 1], got {self.recrop_min_fraction!r}")

    def to_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in self.__dict__.items()}


@dataclass
class Pass:
    """One pass on a prepared cloud of ``P`` points: its parts and joints (in the input's frame), ``labels``
    ``(P,)`` (-1: left out as a support plane or the background class), the plane left out, the calibration's
    features, warnings about the estimate and about the cloud, timings (ms) and the stages' records."""

    parts: list[PartEstimate]
    joints: list[JointEstimate]
    labels: np.ndarray
    plane: object
    features: np.ndarray | None
    warnings: list[str]
    input_warnings: list[str]
    timings: dict[str, float]
    stages: list = field(default_factory=list)

    @property
    def score(self) -> float:
        """The object score: the smallest part score."""
        return min(pe.score for pe in self.parts)

    @property
    def seen_score(self) -> float:
        """The smallest score of the parts given at least one point (all parts where none was)."""
        count = np.bincount(self.labels[self.labels >= 0], minlength=len(self.parts))
        seen = [pe.score for pe, n in zip(self.parts, count, strict=False) if n > 0]
        return min(seen) if seen else self.score


@dataclass
class Estimate:
    """One or two passes: the one that stands, the labels of the prepared cloud's points, the planes left out,
    summed timings, warnings, and the scale factor it was made at (``None``: the rescaling's own)."""

    final: Pass
    labels: np.ndarray
    planes: list
    timings: dict
    warnings: list[str]
    normalise: float | None = None


def compact(points: np.ndarray, factor: float) -> bool:
    """Whether ``points`` ``(N, 3)`` look like one object alone: 90th-percentile radius about the median point
    (:func:`ucope.priors.cloud_radius`) at most ``factor`` x twice the median radius."""
    centre = np.median(points, axis=0)
    return cloud_radius(points) <= factor * 2.0 * float(np.median(np.linalg.norm(points - centre, axis=1)))


def _sum(a: dict, b: dict) -> dict:
    return {key: a[key] + b[key] for key in a}


def recrop(policy: SearchPolicy, run_pass: Callable, needs_rescale: Callable, pts, nrm, num_input: int, **kw) -> Estimate:
    """One estimate: ``run_pass(pts, nrm, num_input, rescale=..., **kw)`` and, with ``policy.recrop``, a second pass
    on the points the first took as the object where it left enough out or they need rescaling
    (``needs_rescale(points)``). A second pass that fails (its points look like no object) leaves the first."""
    first = run_pass(
        pts, nrm, num_input, rescale=policy.rescale and (not policy.recrop or compact(pts, policy.compact_factor)), **kw
    )
    final, labels, planes, timings, warnings = first, first.labels, [first.plane], dict(first.timings), []
    obj = first.labels >= 0
    left_out = float(np.mean(~obj))
    if policy.recrop and np.count_nonzero(obj) >= MIN_POINTS:
        again = left_out >= policy.recrop_min_fraction and np.count_nonzero(~obj) >= MIN_POINTS
        if not again:
            obj[:] = True  # a few stray labels: a second pass (if any) sees the whole cloud
        if again or (policy.rescale and needs_rescale(pts[obj])):
            try:
                n_obj = round(num_input * float(np.mean(obj)))  # the input's object points, as the calibration counts them
                second = run_pass(pts[obj], None if nrm is None else nrm[obj], n_obj, rescale=policy.rescale, **kw)
            except InputError as e:  # the object's points alone look like no object of the category
                warnings.append(f"the second pass on the {np.count_nonzero(obj)} object points failed ({e}); the first stands")
            else:
                if again:
                    warnings += first.input_warnings
                    what = "a support plane and the background" if first.plane is not None else "the background"
                    warnings.append(
                        f"{100 * left_out:.0f} % of the points were segmented as not the object ({what}) "
                        "and left out; the pose was estimated again on the rest"
                    )
                final, planes = second, planes + [second.plane]
                labels = np.full(len(pts), -1, dtype=np.int64)
                labels[obj] = second.labels
                timings = _sum(timings, second.timings)
    return Estimate(final, labels, planes, timings, warnings, kw.get("normalise"))


def search(policy: SearchPolicy, estimate: Callable[..., Estimate], calibrated: bool) -> tuple[Estimate, dict, int]:
    """The estimate that stands, the summed timings of all estimates made and how many were made.

    ``estimate(normalise=None | factor, draw=d)`` makes one estimate. Where the first one's object score is below
    ``policy.scale_below`` (and the model is ``calibrated``), one more per ``policy.scale_factors``; then, while the
    best object score is below ``policy.restart_below``, up to ``policy.restarts`` more from other draws at the
    best one's scale. Ties keep the earlier estimate."""
    best = estimate(normalise=None, draw=0)
    timings, made = dict(best.timings), 1

    def better(kept: Estimate, alt: Estimate) -> Estimate:
        nonlocal timings, made
        timings, made = _sum(timings, alt.timings), made + 1
        key = (lambda e: e.final.seen_score) if policy.pick == "seen" else (lambda e: e.final.score)
        return alt if key(alt) > key(kept) else kept

    if not calibrated:
        return best, timings, made
    if policy.rescale and best.final.score < policy.scale_below:
        for factor in policy.scale_factors:
            best = better(best, estimate(normalise=factor, draw=0))
    draw = 0
    while draw < policy.restarts and best.final.score < policy.restart_below:
        draw += 1
        best = better(best, estimate(normalise=best.normalise, draw=draw))
    return best, timings, made
