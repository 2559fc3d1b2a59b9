"""A structured-light / time-of-flight depth sensor noise model, applied to clean depth maps.

Effects, each switchable:

* axial Gaussian noise growing with depth: ``sigma(z) = sigma_0_m + sigma_2 * (z - 0.4)^2``
  (the form measured for Kinect-class sensors by Nguyen et al., 2012);
* disparity quantisation: depth is snapped to the nearest representable disparity
  ``d = focal_baseline / z`` in steps of ``disparity_step_px``, so the step in depth grows as ``z^2``;
* missing pixels at depth edges (a large jump to a neighbour), with probability ``edge_dropout``,
  plus uniform random dropout ``random_dropout``;
* a few outliers: a fraction ``outlier_fraction`` of the remaining pixels gets a depth error of up to
  ``outlier_scale * z``.

The result is what a sensor writes: millimetres in ``uint16`` (0 = no return).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["DepthNoise", "apply_depth_noise", "depth_to_mm"]


@dataclass(frozen=True)
class DepthNoise:
    """Parameters of :func:`apply_depth_noise`. ``DepthNoise(enabled=False)`` gives clean depth."""

    enabled: bool = True
    sigma_0_m: float = 0.0012
    sigma_2: float = 0.0019
    focal_baseline_px_m: float = 288.75 * 0.075
    disparity_step_px: float = 1.0 / 8.0
    edge_jump_rel: float = 0.03
    edge_dropout: float = 0.5
    random_dropout: float = 0.005
    outlier_fraction: float = 0.002
    outlier_scale: float = 0.1

    def to_dict(self) -> dict:
        return asdict(self)


def depth_to_mm(depth_m: np.ndarray) -> np.ndarray:
    """Metres -> ``uint16`` millimetres, rounded; 0 and non-finite stay 0; clipped to 65.535 m."""
    d = np.where(np.isfinite(depth_m) & (depth_m > 0), depth_m, 0.0)
    return np.clip(np.rint(d * 1000.0), 0, 65535).astype(np.uint16)


def apply_depth_noise(depth_m: np.ndarray, noise: DepthNoise, rng: np.random.Generator) -> np.ndarray:
    """Noisy copy of a ``(H, W)`` clean depth map in metres (0 = no return); returns metres."""
    d = np.array(depth_m, dtype=np.float64, copy=True)
    if not noise.enabled:
        return d
    valid = d > 0
    H, W = d.shape
    # missing pixels at depth edges: compare with the 4-neighbours (missing neighbours count as jumps)
    pad = np.pad(d, 1, mode="edge")
    neigh = np.stack([pad[:-2, 1:-1], pad[2:, 1:-1], pad[1:-1, :-2], pad[1:-1, 2:]])
    jump = np.abs(neigh - d[None]).max(axis=0) > noise.edge_jump_rel * np.maximum(d, 1e-6)
    u = rng.random((2, H, W))
    drop = valid & ((jump & (u[0] < noise.edge_dropout)) | (u[1] < noise.random_dropout))
    # axial noise
    z = d[valid]
    sigma = noise.sigma_0_m + noise.sigma_2 * (z - 0.4) ** 2
    z = z + rng.standard_normal(z.shape) * sigma
    # outliers
    out = rng.random(z.shape) < noise.outlier_fraction
    z[out] += rng.uniform(-1.0, 1.0, int(out.sum())) * noise.outlier_scale * z[out]
    # disparity quantisation
    if noise.disparity_step_px > 0:
        disp = noise.focal_baseline_px_m / np.maximum(z, 1e-3)
        disp = np.maximum(np.rint(disp / noise.disparity_step_px), 1.0) * noise.disparity_step_px
        z = noise.focal_baseline_px_m / disp
    d[valid] = np.maximum(z, 0.0)
    d[drop] = 0.0
    return d
