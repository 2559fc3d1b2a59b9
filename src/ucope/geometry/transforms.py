"""Rigid transforms and rotation helpers.

Conventions (used everywhere in ucope):

* A rigid transform is a ``(..., 4, 4)`` homogeneous matrix named ``<to>_from_<from>``, e.g.
  ``cam_from_part`` maps a point written in the part frame to the camera frame:
  ``p_cam = cam_from_part[:3, :3] @ p_part + cam_from_part[:3, 3]``.
* Points are row vectors stacked as ``(..., N, 3)`` arrays in metres.
* Rotations are right-handed, active, and converted with :mod:`scipy.spatial.transform`.
* Angles are radians unless a name says ``_deg``.

All functions accept numpy arrays and broadcast over leading batch dimensions.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError

__all__ = [
    "make_transform",
    "invert_transform",
    "apply_transform",
    "transform_directions",
    "rotation_about_axis",
    "axis_angle_transform",
    "translation_transform",
    "random_rotation",
    "look_at_rotation",
    "normalize",
    "rotation_angle_deg",
    "closest_rotation",
]


def normalize(v: np.ndarray, axis: int = -1, eps: float = 1e-12) -> np.ndarray:
    """Unit vectors along ``axis``. Raises :class:`InputError` on a (near) zero vector."""
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v, axis=axis, keepdims=True)
    if np.any(n < eps):
        raise InputError("cannot normalise a zero-length vector")
    return v / n


def make_transform(rotation: np.ndarray | None = None, translation: np.ndarray | None = None) -> np.ndarray:
    """Build ``(..., 4, 4)`` transforms from ``(..., 3, 3)`` rotations and ``(..., 3)`` translations."""
    if rotation is None and translation is None:
        return np.eye(4)
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    translation = np.zeros(3) if translation is None else np.asarray(translation, dtype=np.float64)
    batch = np.broadcast_shapes(rotation.shape[:-2], translation.shape[:-1])
    out = np.zeros(batch + (4, 4))
    out[..., :3, :3] = rotation
    out[..., :3, 3] = translation
    out[..., 3, 3] = 1.0
    return out


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid ``(..., 4, 4)`` transforms (``a_from_b`` -> ``b_from_a``), exact for rotations."""
    T = np.asarray(T, dtype=np.float64)
    R = T[..., :3, :3]
    Rt = np.swapaxes(R, -1, -2)
    t = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    return make_transform(Rt, t)


def apply_transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map ``(..., N, 3)`` points by ``(..., 4, 4)`` transforms; returns ``(..., N, 3)``."""
    T = np.asarray(T)
    points = np.asarray(points)
    return np.einsum("...ij,...nj->...ni", T[..., :3, :3], points) + T[..., None, :3, 3]


def transform_directions(T: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Rotate ``(..., N, 3)`` directions by the rotation part of ``(..., 4, 4)`` transforms."""
    T = np.asarray(T)
    return np.einsum("...ij,...nj->...ni", T[..., :3, :3], np.asarray(dirs))


def rotation_about_axis(axis: np.ndarray, angle_rad: np.ndarray | float) -> np.ndarray:
    """``(..., 3, 3)`` rotation by ``angle_rad`` (right hand) about unit ``axis`` ``(..., 3)``."""
    axis = normalize(axis)
    angle = np.asarray(angle_rad, dtype=np.float64)
    rotvec = axis * angle[..., None]
    flat = rotvec.reshape(-1, 3)
    return Rotation.from_rotvec(flat).as_matrix().reshape(rotvec.shape[:-1] + (3, 3))


def axis_angle_transform(axis: np.ndarray, pivot: np.ndarray, angle_rad: np.ndarray | float) -> np.ndarray:
    """``(..., 4, 4)`` rotation by ``angle_rad`` ``(...)`` about the line through ``pivot`` ``(3,)`` along ``axis``
    ``(3,)`` (right hand)."""
    R = rotation_about_axis(axis, angle_rad)
    pivot = np.asarray(pivot, dtype=np.float64)
    return make_transform(R, pivot - R @ pivot)


def translation_transform(t: np.ndarray) -> np.ndarray:
    """``(..., 4, 4)`` pure translation."""
    return make_transform(None, np.asarray(t, dtype=np.float64))


def random_rotation(rng: np.random.Generator, n: int | None = None) -> np.ndarray:
    """Uniform random rotation(s) drawn from ``rng``: ``(3, 3)`` or ``(n, 3, 3)``."""
    return Rotation.random(n, random_state=rng).as_matrix()


def look_at_rotation(eye: np.ndarray, target: np.ndarray, up: np.ndarray = (0.0, 1.0, 0.0)) -> np.ndarray:
    """``world_from_cam`` rotation of an OpenCV camera at ``eye`` looking at ``target``.

    OpenCV camera axes: +z forward (viewing direction), +x right, +y down in the image.
    ``up`` is the world direction that should appear upwards in the image.
    """
    eye = np.asarray(eye, dtype=np.float64)
    z = normalize(np.asarray(target, dtype=np.float64) - eye)
    up = np.asarray(up, dtype=np.float64)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:  # looking straight along up: pick any perpendicular
        x = np.cross(z, np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 0.0, 1.0]))
    x = normalize(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def rotation_angle_deg(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """Geodesic angle in degrees between ``(..., 3, 3)`` rotations."""
    R = np.einsum("...ji,...jk->...ik", R_a, R_b)
    cos = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def closest_rotation(M: np.ndarray) -> np.ndarray:
    """The rotation(s) closest to ``(..., 3, 3)`` matrices in the Frobenius norm (orthogonal Procrustes:
    ``U diag(1, 1, det(U V^T)) V^T`` from the SVD ``M = U S V^T``, so the determinant is +1)."""
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=np.float64))
    s = np.where(np.linalg.det(U @ Vt) < 0, -1.0, 1.0)
    U[..., :, 2] *= s[..., None]
    return U @ Vt
