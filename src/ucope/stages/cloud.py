"""Cloud stages: what a pass does to the cloud before the network sees it.

Both read and write a :class:`ucope.stages.base.CloudState` (camera frame, metres).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.denoise import smooth_points, surface_noise
from ..geometry.planes import find_support_plane
from ..vocab import MIN_POINTS
from .base import CloudState, stage

__all__ = ["DenoiseParams", "RemovePlaneParams"]


@dataclass(frozen=True)
class DenoiseParams:
    """Attributes:
    above_m: a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`, metres) is above this is
        smoothed; each model's card stores the noise it measured on its own validation views.
    k: neighbours of the local planes the points are projected onto; iterations: projection rounds.
    min_points: sparser clouds are never smoothed (their neighbourhoods are too wide: their "noise" is curvature).
    """

    above_m: float = 1.5e-3
    k: int = 48
    iterations: int = 2
    min_points: int = 1000


@stage("denoise", kind="learned-prior", params=DenoiseParams, phase="cloud")
def _denoise(cloud: CloudState, params: DenoiseParams) -> None:
    """The cloud smoothed onto local planes where its surface noise is above what the model's views had."""
    if len(cloud.points) < params.min_points:
        return
    noise = surface_noise(cloud.points)
    if noise > params.above_m:
        cloud.points = smooth_points(cloud.points, k=params.k, iterations=params.iterations).astype(np.float32)
        cloud.warnings.append(
            f"the cloud's surface noise ({1e3 * noise:.1f} mm) is above the {1e3 * params.above_m:.1f} mm "
            f"the model handles; it was smoothed before the estimate"
        )


@dataclass(frozen=True)
class RemovePlaneParams:
    """Attributes: as :func:`ucope.geometry.planes.find_support_plane`."""

    iterations: int = 256
    min_fraction: float = 0.1
    threshold_rel: float = 0.02
    one_side: float = 0.95
    beyond: float = 0.3


@stage("remove_plane", kind="geometry", params=RemovePlaneParams, phase="cloud")
def _remove_plane(cloud: CloudState, params: RemovePlaneParams) -> None:
    """A floor or table under the object that reaches beyond its footprint, left out (its points get the label -1)."""
    plane = find_support_plane(
        cloud.points,
        seed=cloud.seed,
        iterations=params.iterations,
        min_fraction=params.min_fraction,
        threshold_rel=params.threshold_rel,
        one_side=params.one_side,
        beyond=params.beyond,
    )
    if plane is None:
        return
    keep = ~plane.removes(cloud.points)
    if np.count_nonzero(keep & cloud.keep) < MIN_POINTS:
        return
    cloud.keep &= keep
    cloud.plane = plane
    cloud.input_warnings.append(
        f"a plane under the object ({100 * plane.fraction:.0f} % of the points) was left out as floor or table"
    )
