"""Joint states from part poses (the inverse of the forward kinematics of ucope.objects.articulation).

Convention (docs/conventions.md, :mod:`ucope.objects.articulation`): a joint's state ``q`` moves the
child relative to its parent, ``parent_from_child(q) = motion(axis, pivot, q) @ parent_from_child_zero``,
and the part axes are the object axes at state 0, so the **rotation** of ``parent_from_child_zero`` is
the identity for every category. Hence:

* **Revolute**: ``R_rel = R_p^T R_c`` is the rotation by ``q`` about ``u = R_p^T axis_cam`` (the axis in
  the parent frame). ``q`` is the angle of the rotation about ``u`` closest to ``R_rel`` (maximum of
  ``trace(rot(u, q)^T R_rel)``): ``q = atan2(vee(R_rel - R_rel^T) . u, trace(R_rel) - u^T R_rel u)``.
  For an exact rotation about ``u`` this equals ``atan2(vee(R_rel - R_rel^T)/2 . u, (trace - 1)/2)``;
  for noisy poses it is the least-squares projection. ``q`` is in ``(-pi, pi]``.
* **Prismatic**: the translation at state 0 depends on the instance (drawer depth, front thickness), so
  ``q`` comes from the boxes' extents along the axis: ``q = support(child, u) - support(parent, u) -
  zero_offset_m`` with ``support(box, u) = t . u + 0.5 sum_i size_i |R_i . u|`` (how far the box reaches
  along ``u``; ``R_i`` the box axes) and ``zero_offset_m`` a per-joint category constant: the mean of
  ``support gap - q`` over training data at the ground-truth poses (:func:`prismatic_zero_offset`).

All functions are numpy (float64) and broadcast over leading batch dimensions; angles in radians,
lengths in metres, every pose and axis in one frame (the camera frame).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..vocab import JointType

__all__ = ["box_support", "revolute_angle", "joint_state_from_poses", "prismatic_zero_offset", "joint_type_code"]


def joint_type_code(joint_type) -> np.ndarray:
    """Joint type(s) as :class:`ucope.vocab.JointType` integer codes (revolute or prismatic); accepts
    codes, words or enum members, scalar or array."""
    arr = np.asarray(joint_type, dtype=object)
    codes = np.array([int(JointType.parse(t)) for t in arr.reshape(-1)], dtype=np.int64).reshape(arr.shape)
    if np.any(codes == int(JointType.FIXED)):
        raise InputError("a fixed joint has no state")
    return codes


def _poses(T, name: str) -> np.ndarray:
    T = np.asarray(T, dtype=np.float64)
    if T.shape[-2:] != (4, 4):
        raise InputError(f"{name} must have shape (..., 4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name} holds NaN or infinite values")
    return T


def _unit(u, name: str) -> np.ndarray:
    u = np.asarray(u, dtype=np.float64)
    if u.shape[-1:] != (3,) or not np.all(np.isfinite(u)):
        raise InputError(f"{name} must be finite with shape (..., 3), got {u.shape}")
    n = np.linalg.norm(u, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise InputError(f"{name} must be non-zero")
    return u / n


def box_support(cam_from_box, size_m, u) -> np.ndarray:
    """How far boxes reach along unit directions: ``t . u + 0.5 sum_i size_i |R_i . u|``.

    Args:
        cam_from_box: ``(..., 4, 4)`` box poses; size_m: ``(..., 3)`` full extents; u: ``(..., 3)``.

    Returns:
        ``(...)`` metres.
    """
    T = _poses(cam_from_box, "cam_from_box")
    s = np.asarray(size_m, dtype=np.float64)
    if s.shape[-1:] != (3,) or not np.all(np.isfinite(s)) or np.any(s < 0):
        raise InputError(f"size_m must be non-negative with shape (..., 3), got {s.shape}")
    u = _unit(u, "u")
    proj = np.einsum("...ji,...j->...i", T[..., :3, :3], u)  # R_i . u for each box axis i
    return np.einsum("...i,...i->...", T[..., :3, 3], u) + 0.5 * np.sum(s * np.abs(proj), axis=-1)


def revolute_angle(R_rel, u) -> np.ndarray:
    """Angle (radians, ``(-pi, pi]``) of the rotation about unit ``u`` closest to ``R_rel`` (see the
    module docstring). ``R_rel`` ``(..., 3, 3)``, ``u`` ``(..., 3)`` in the same frame."""
    R = np.asarray(R_rel, dtype=np.float64)
    u = _unit(u, "u")
    vee = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    s = np.einsum("...i,...i->...", vee, u)
    c = np.trace(R, axis1=-2, axis2=-1) - np.einsum("...i,...ij,...j->...", u, R, u)
    return np.arctan2(s, c)


def joint_state_from_poses(
    cam_from_parent,
    cam_from_child,
    axis_cam,
    joint_type,
    size_parent=None,
    size_child=None,
    zero_offset_m=0.0,
):
    """Joint state(s) from the parent's and child's poses (see the module docstring).

    Args:
        cam_from_parent, cam_from_child: ``(..., 4, 4)`` part poses.
        axis_cam: ``(..., 3)`` joint axis in the same frame (its sign sets the sign of ``q``).
        joint_type: 0 / ``"revolute"`` or 1 / ``"prismatic"`` (scalar or ``(...)``).
        size_parent, size_child: ``(..., 3)`` box extents (needed by prismatic joints).
        zero_offset_m: prismatic: the support gap at state 0 (scalar or ``(...)``).

    Returns:
        ``q``: radians (revolute, ``(-pi, pi]``) or metres (prismatic), a Python ``float`` for unbatched
        inputs, else an ``(...)`` array.
    """
    Tp = _poses(cam_from_parent, "cam_from_parent")
    Tc = _poses(cam_from_child, "cam_from_child")
    u = _unit(axis_cam, "axis_cam")
    jt = joint_type_code(joint_type)
    batch = np.broadcast_shapes(Tp.shape[:-2], Tc.shape[:-2], u.shape[:-1], jt.shape)
    Rp = Tp[..., :3, :3]
    R_rel = np.einsum("...ji,...jk->...ik", Rp, Tc[..., :3, :3])
    u_p = np.einsum("...ji,...j->...i", Rp, u)
    q = np.broadcast_to(revolute_angle(R_rel, u_p), batch).copy()
    prism = np.broadcast_to(jt == int(JointType.PRISMATIC), batch)
    if np.any(prism):
        if size_parent is None or size_child is None:
            raise InputError("prismatic joints need size_parent and size_child")
        gap = box_support(Tc, size_child, u) - box_support(Tp, size_parent, u)
        z = np.asarray(zero_offset_m, dtype=np.float64)
        q = np.where(prism, np.broadcast_to(gap - z, batch), q)
    return float(q) if q.ndim == 0 else q


def prismatic_zero_offset(cam_from_parent, cam_from_child, axis_cam, size_parent, size_child, joint_state) -> float:
    """The support gap at state 0 of a prismatic joint: ``mean(support gap - q)`` over samples.

    Args:
        cam_from_parent, cam_from_child: ``(S, 4, 4)`` ground-truth poses; axis_cam: ``(S, 3)``;
        size_parent, size_child: ``(S, 3)``; joint_state: ``(S,)`` metres.

    Returns:
        metres (a Python float).
    """
    gap = box_support(cam_from_child, size_child, axis_cam) - box_support(cam_from_parent, size_parent, axis_cam)
    q = np.asarray(joint_state, dtype=np.float64)
    d = np.asarray(gap - q, dtype=np.float64).reshape(-1)
    if d.size == 0 or not np.all(np.isfinite(d)):
        raise InputError("prismatic_zero_offset needs at least one finite sample")
    return float(d.mean())
