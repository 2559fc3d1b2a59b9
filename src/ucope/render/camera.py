"""Pinhole camera: intrinsics, pixel rays, projection and back-projection.

OpenCV convention: the camera frame has +x right, +y down, +z forward (into the scene); pixel ``(u, v)``
= (column, row) with pixel centres at integer coordinates; depth is the z coordinate in metres (not
the range along the ray).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError

__all__ = ["PinholeCamera", "DEFAULT_CAMERA"]


@dataclass(frozen=True)
class PinholeCamera:
    """Intrinsics ``fx, fy, cx, cy`` (pixels) and image ``width x height``."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        vals = np.array([self.fx, self.fy, self.cx, self.cy], dtype=np.float64)
        if not np.all(np.isfinite(vals)) or self.fx <= 0 or self.fy <= 0:
            raise InputError(f"camera intrinsics must be finite with fx, fy > 0, got {vals.tolist()}")
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise InputError(f"image size must be positive, got {self.width}x{self.height}")
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))

    @property
    def K(self) -> np.ndarray:
        """``(3, 3)`` intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> PinholeCamera:
        try:
            return cls(**{k: d[k] for k in ("fx", "fy", "cx", "cy", "width", "height")})
        except (KeyError, TypeError) as e:
            raise InputError(f"camera dict needs fx, fy, cx, cy, width, height: {e}") from None

    def pixel_rays(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """``(N, 3)`` ray directions with z = 1 through pixel centres ``(rows, cols)``."""
        x = (np.asarray(cols, np.float64) - self.cx) / self.fx
        y = (np.asarray(rows, np.float64) - self.cy) / self.fy
        return np.stack([x, y, np.ones_like(x)], axis=-1)

    def project(self, points: np.ndarray) -> np.ndarray:
        """``(N, 2)`` pixel coordinates ``(u, v)`` of ``(N, 3)`` camera-frame points (z > 0)."""
        p = np.asarray(points, np.float64)
        z = p[..., 2]
        return np.stack([self.fx * p[..., 0] / z + self.cx, self.fy * p[..., 1] / z + self.cy], axis=-1)

    def backproject(self, depth_m: np.ndarray, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Points of the valid pixels (depth > 0, and ``mask`` where given) of a ``(H, W)`` depth map.

        Returns:
            points ``(N, 3)`` float32 in the camera frame (metres), and ``(N, 2)`` int (row, col).
        """
        depth = np.asarray(depth_m)
        if depth.shape != (self.height, self.width):
            raise InputError(f"depth has shape {depth.shape}, camera expects {(self.height, self.width)}")
        valid = np.isfinite(depth) & (depth > 0)
        if mask is not None:
            valid &= np.asarray(mask, bool)
        rows, cols = np.nonzero(valid)
        z = depth[rows, cols].astype(np.float64)
        pts = self.pixel_rays(rows, cols) * z[:, None]
        return pts.astype(np.float32), np.stack([rows, cols], axis=-1)


DEFAULT_CAMERA = PinholeCamera(fx=288.75, fy=288.75, cx=159.75, cy=119.75, width=320, height=240)
"""320x240 camera: NOCS's CAMERA intrinsics (fx = fy = 577.5 at 640x480) halved; ~58 degree horizontal FOV."""
