"""The cloud stage: what a pass does to the cloud before the network sees it.

It reads and writes a :class:`ucope.stages.base.CloudState` (camera frame, metres).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry.denoise import smooth_points, surface_noise
from ..geometry.planes import find_support_plane
from ..vocab import MIN_POINTS
from .base import CloudState, stage

__all__ = ["CleanCloudParams"]


@dataclass(frozen=True)
class CleanCloudParams:
    """Attributes:
    noise_above_m: a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`, metres) is above this
        is smoothed onto local planes (``smooth_k`` neighbours, ``smooth_iterations`` rounds; never a cloud of fewer
        than ``smooth_min_points`` points, whose "noise" is curvature); ``None``: never. Each model's card stores
        the noise measured on its own validation views.
    plane: look for a support plane (:func:`ucope.geometry.planes.find_support_plane`, with the ``plane_*``
        settings) and leave it out.
    """

    noise_above_m: float | None = 1.5e-3
    smooth_k: int = 48
    smooth_iterations: int = 2
    smooth_min_points: int = 1000
    plane: bool = True
    plane_iterations: int = 256
    plane_min_fraction: float = 0.1
    plane_threshold_rel: float = 0.02
    plane_one_side: float = 0.95
    plane_beyond: float = 0.3

    def __post_init__(self) -> None:
        if self.noise_above_m is not None and not 0.0 <= self.noise_above_m < 1.0:
            raise InputError(f"noise_above_m must be metres in [0, 1) or null, got {self.noise_above_m}")
        if self.smooth_k < 3 or self.smooth_iterations < 0 or self.plane_iterations < 1:
            raise InputError("smooth_k must be >= 3, smooth_iterations >= 0 and plane_iterations >= 1")


@stage("clean_cloud", kind="learned-prior", params=CleanCloudParams, phase="cloud")
def _clean_cloud(cloud: CloudState, params: CleanCloudParams) -> None:
    """What is not the object's surface as the model knows it taken out: sensor noise beyond its training views
    smoothed away, a floor or table that reaches beyond the object's footprint left out (its points get the label -1)."""
    if params.noise_above_m is not None and len(cloud.points) >= params.smooth_min_points:
        noise = surface_noise(cloud.points)
        if noise > params.noise_above_m:
            cloud.points = smooth_points(cloud.points, k=params.smooth_k, iterations=params.smooth_iterations).astype(np.float32)
            cloud.warnings.append(
                f"the cloud's surface noise ({1e3 * noise:.1f} mm) is above the {1e3 * params.noise_above_m:.1f} mm "
                f"the model handles; it was smoothed before the estimate"
            )
    if not params.plane:
        return
    plane = find_support_plane(
        cloud.points,
        seed=cloud.seed,
        iterations=params.plane_iterations,
        min_fraction=params.plane_min_fraction,
        threshold_rel=params.plane_threshold_rel,
        one_side=params.plane_one_side,
        beyond=params.plane_beyond,
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
