"""The articulated object model: a tree of K rigid parts joined by K-1 joints.

A rigid object is the same model with ``K = 1`` and no joints.

Frames
------
* Every part has a *canonical part frame*: metres, its amodal box is centred on the frame origin and
  aligned with the frame axes, so a part's 9D pose is ``(cam_from_part, size_m)``.
* The *object frame* is the root part's frame (part 0). ``object_from_part(state)`` gives every part's
  pose in it by forward kinematics.
* A joint is written in its parent's part frame: a ``pivot`` point and a unit ``axis``. Its state ``q``
  (``angle_rad`` for a revolute joint, metres for a prismatic one) moves the child relative to the
  parent::

      parent_from_child(q) = motion(axis, pivot, q) @ parent_from_child_zero

  where ``motion`` is the right-handed rotation by ``q`` about the axis line through ``pivot``
  (revolute), the translation ``q * axis`` (prismatic) or the identity (fixed).

This can hold any URDF tree of fixed, revolute and prismatic links.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import trimesh

from ..errors import InputError
from ..geometry.transforms import (
    apply_transform,
    axis_angle_transform,
    invert_transform,
    make_transform,
    translation_transform,
)
from ..vocab import JOINT_TYPES, SYMMETRIES, JointType

__all__ = ["Part", "Joint", "ArticulatedObject", "make_part", "build_object"]


@dataclass(frozen=True, eq=False)
class Part:
    """A rigid part: a mesh in its canonical frame, with its amodal box centred on the origin.

    Attributes:
        name: part name, unique within an object (``"base"``, ``"lid"``...).
        mesh: triangle mesh in the part frame, metres. Its axis-aligned bounds are centred on the
            origin (checked), so its extents are the amodal box size.
        symmetry: ``"none"`` or ``"y"`` (continuous rotational symmetry about the part's y axis).
    """

    name: str
    mesh: trimesh.Trimesh
    symmetry: str = "none"

    def __post_init__(self) -> None:
        if self.symmetry not in SYMMETRIES:
            raise InputError(f"part {self.name!r}: symmetry must be one of {SYMMETRIES}, got {self.symmetry!r}")
        if len(self.mesh.faces) == 0:
            raise InputError(f"part {self.name!r}: mesh has no faces")
        lo, hi = self.mesh.bounds
        if np.abs(lo + hi).max() > 1e-6 * max(1.0, float(np.abs(hi - lo).max())):
            raise InputError(f"part {self.name!r}: mesh bounds are not centred on the part frame origin")

    @property
    def size_m(self) -> np.ndarray:
        """``(3,)`` amodal box extents along the part's x, y, z axes, metres."""
        lo, hi = self.mesh.bounds
        return (hi - lo).astype(np.float64)


@dataclass(frozen=True, eq=False)
class Joint:
    """A joint between a parent and a child part.

    Attributes:
        type: ``"revolute"``, ``"prismatic"`` or ``"fixed"``.
        parent, child: part indices.
        pivot: ``(3,)`` a point on the joint axis, in the parent's part frame, metres.
        axis: ``(3,)`` unit axis direction in the parent's part frame.
        limits: ``(lower, upper)`` joint state limits (radians or metres); data generation samples
            states uniformly within them.
        rest: the rest state, within the limits.
        parent_from_child_zero: ``(4, 4)`` child pose in the parent frame at state 0.
    """

    type: str
    parent: int
    child: int
    pivot: np.ndarray
    axis: np.ndarray
    limits: tuple[float, float]
    rest: float
    parent_from_child_zero: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        if self.type not in JOINT_TYPES:
            raise InputError(f"joint type must be one of {JOINT_TYPES}, got {self.type!r}")
        axis = np.asarray(self.axis, dtype=np.float64).reshape(3)
        n = np.linalg.norm(axis)
        if not np.isfinite(n) or n < 1e-9:
            raise InputError(f"joint {self.parent}->{self.child}: axis must be a non-zero finite vector")
        object.__setattr__(self, "axis", axis / n)
        object.__setattr__(self, "pivot", np.asarray(self.pivot, dtype=np.float64).reshape(3))
        object.__setattr__(
            self, "parent_from_child_zero", np.asarray(self.parent_from_child_zero, dtype=np.float64).reshape(4, 4)
        )
        lo, hi = (float(v) for v in self.limits)
        if not lo <= hi:
            raise InputError(f"joint {self.parent}->{self.child}: limits must satisfy lower <= upper, got {self.limits}")
        object.__setattr__(self, "limits", (lo, hi))
        if not lo - 1e-9 <= float(self.rest) <= hi + 1e-9:
            raise InputError(f"joint {self.parent}->{self.child}: rest state {self.rest} is outside the limits {self.limits}")

    @property
    def type_code(self) -> int:
        """Integer code of the joint type (:class:`ucope.vocab.JointType`), as stored in data sets."""
        return int(JointType.parse(self.type))

    def motion(self, state: float) -> np.ndarray:
        """``(4, 4)`` motion of the child in the parent frame at ``state`` (relative to state 0)."""
        if self.type == "revolute":
            return axis_angle_transform(self.axis, self.pivot, float(state))
        if self.type == "prismatic":
            return translation_transform(self.axis * float(state))
        return np.eye(4)

    def parent_from_child(self, state: float) -> np.ndarray:
        """``(4, 4)`` child pose in the parent frame at ``state``."""
        return self.motion(state) @ self.parent_from_child_zero


@dataclass(frozen=True, eq=False)
class ArticulatedObject:
    """K parts joined by K-1 joints into a tree rooted at part 0.

    Attributes:
        category: category name (``"laptop"``...).
        instance_id: a name unique to this instance (``"laptop/train/000042"``).
        parts: the K parts; part 0 is the root and its frame is the object frame.
        joints: the K-1 joints; every part but the root is the child of exactly one joint.
        params: the shape parameters the instance was generated from (for bookkeeping; lengths in metres
            BEFORE scaling by ``scale``).
        shape_family: the category's shape family the instance was drawn from (``""`` if none).
        scale: the uniform scale factor applied to the generated shape (1: as generated);
            see :meth:`scaled`.
        stretch: ``(3,)`` the factors along the object frame's x, y, z applied to the generated shape
            (``(1, 1, 1)``: as generated); see :meth:`stretched`.
    """

    category: str
    instance_id: str
    parts: tuple[Part, ...]
    joints: tuple[Joint, ...] = ()
    params: dict = field(default_factory=dict)
    shape_family: str = ""
    scale: float = 1.0
    stretch: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "parts", tuple(self.parts))
        object.__setattr__(self, "stretch", tuple(float(v) for v in self.stretch))
        object.__setattr__(self, "joints", tuple(self.joints))
        K = len(self.parts)
        if K == 0:
            raise InputError("an object needs at least one part")
        if len(self.joints) != K - 1:
            raise InputError(f"an object with {K} parts needs {K - 1} joints, got {len(self.joints)}")
        names = [p.name for p in self.parts]
        if len(set(names)) != K:
            raise InputError(f"part names must be unique, got {names}")
        children = [j.child for j in self.joints]
        if sorted(children) != list(range(1, K)):
            raise InputError(f"every part but the root (0) must be the child of exactly one joint, got children {children}")
        for j in self.joints:
            if not 0 <= j.parent < K:
                raise InputError(f"joint parent {j.parent} is not a part index")
        # topological order: parents before children (also rejects cycles)
        order, placed = [], {0}
        pending = list(range(K - 1))
        while pending:
            ready = [i for i in pending if self.joints[i].parent in placed]
            if not ready:
                raise InputError("the joints do not form a tree rooted at part 0")
            for i in ready:
                order.append(i)
                placed.add(self.joints[i].child)
                pending.remove(i)
        object.__setattr__(self, "_fk_order", tuple(order))

    # ----------------------------------------------------------------------------------------
    @property
    def num_parts(self) -> int:
        """K, the number of parts."""
        return len(self.parts)

    @property
    def is_rigid(self) -> bool:
        return len(self.parts) == 1

    @property
    def joint_types(self) -> tuple[str, ...]:
        return tuple(j.type for j in self.joints)

    @property
    def size_m(self) -> np.ndarray:
        """``(K, 3)`` amodal box extents of every part, metres."""
        return np.stack([p.size_m for p in self.parts]) if self.parts else np.zeros((0, 3))

    @property
    def rest_state(self) -> np.ndarray:
        """``(K-1,)`` rest state of every joint."""
        return np.array([j.rest for j in self.joints], dtype=np.float64)

    @property
    def limits(self) -> np.ndarray:
        """``(K-1, 2)`` joint limits (lower, upper)."""
        return np.array([j.limits for j in self.joints], dtype=np.float64).reshape(-1, 2)

    def check_state(self, state: Sequence[float] | np.ndarray | None, tol: float = 1e-6) -> np.ndarray:
        """``state`` as a checked ``(K-1,)`` float64 array (``None``: the rest state); raises
        :class:`InputError` naming a joint whose state is outside its limits."""
        if state is None:
            return self.rest_state
        q = np.asarray(state, dtype=np.float64).reshape(-1)
        if q.shape != (len(self.joints),):
            raise InputError(f"joint state must have {len(self.joints)} values, got shape {np.shape(state)}")
        if not np.all(np.isfinite(q)):
            raise InputError("joint state contains NaN or Inf")
        lim = self.limits
        bad = (q < lim[:, 0] - tol) | (q > lim[:, 1] + tol)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"joint {i} state {q[i]:.4g} is outside its limits {tuple(lim[i])}")
        return q

    def object_from_part(self, state: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """Forward kinematics: ``(K, 4, 4)`` pose of every part in the object frame at ``state``.

        Args:
            state: ``(K-1,)`` joint states (radians / metres), ``None`` for the rest state.
        """
        q = self.check_state(state)
        out = np.empty((self.num_parts, 4, 4))
        out[0] = np.eye(4)
        for i in self._fk_order:
            j = self.joints[i]
            out[j.child] = out[j.parent] @ j.parent_from_child(q[i])
        return out

    def joints_in_object(self, state: Sequence[float] | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Joint pivots and axes in the object frame at ``state``: ``(K-1, 3)`` each."""
        poses = self.object_from_part(state)
        if not self.joints:
            return np.zeros((0, 3)), np.zeros((0, 3))
        piv = np.stack([poses[j.parent, :3, :3] @ j.pivot + poses[j.parent, :3, 3] for j in self.joints])
        ax = np.stack([poses[j.parent, :3, :3] @ j.axis for j in self.joints])
        return piv, ax

    def posed_meshes(self, state: Sequence[float] | np.ndarray | None = None) -> list[trimesh.Trimesh]:
        """Every part mesh moved into the object frame at ``state`` (new mesh objects)."""
        poses = self.object_from_part(state)
        return [p.mesh.copy().apply_transform(T) for p, T in zip(self.parts, poses, strict=False)]

    def posed_geometry(self, state: Sequence[float] | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All parts in the object frame as one triangle soup.

        Returns:
            vertices ``(V, 3)`` float64, faces ``(F, 3)`` int64, part index of each face ``(F,)`` int64.
        """
        poses = self.object_from_part(state)
        verts, faces, labels, offset = [], [], [], 0
        for k, (p, T) in enumerate(zip(self.parts, poses, strict=False)):
            verts.append(apply_transform(T, p.mesh.vertices))
            faces.append(np.asarray(p.mesh.faces, dtype=np.int64) + offset)
            labels.append(np.full(len(p.mesh.faces), k, dtype=np.int64))
            offset += len(p.mesh.vertices)
        return np.concatenate(verts), np.concatenate(faces), np.concatenate(labels)

    def structure(self) -> dict:
        """The declared structure (JSON-safe): ``parts`` ``[{name, symmetry}]`` and ``joints``
        ``[{type, parent, child, axis_in_parent, limits}]``, the form of a data set's ``meta.json`` that
        :func:`ucope.priors.structure_from_dict` reads. Fixed joints cannot be declared (merge such parts)."""
        for j in self.joints:
            if JointType.parse(j.type) == JointType.FIXED:
                raise InputError(
                    f"{self.instance_id}: joint {j.parent}->{j.child} is fixed; a category's joints are revolute or prismatic"
                )
        return {
            "parts": [{"name": p.name, "symmetry": p.symmetry} for p in self.parts],
            "joints": [
                {
                    "type": j.type,
                    "parent": int(j.parent),
                    "child": int(j.child),
                    "axis_in_parent": [float(x) for x in j.axis],
                    "limits": [float(j.limits[0]), float(j.limits[1])],
                }
                for j in self.joints
            ],
        }

    def scaled(self, factor: float) -> ArticulatedObject:
        """The same object scaled uniformly by ``factor`` about the object frame's origin.

        Every length scales: part meshes (so box sizes), the parts' placements, joint pivots, and the
        limits and rest states of prismatic joints (metres). Rotations, joint axes, revolute limits (radians)
        and the canonical frames are unchanged, so ``object_from_part(state)`` of the scaled object at a
        revolute state ``q`` (or a prismatic state ``factor * q``) is the original's with its translation
        times ``factor``. ``scale`` of the result is ``self.scale * factor``; ``params`` are kept as they were.
        """
        f = float(factor)
        if not np.isfinite(f) or f <= 0:
            raise InputError(f"scale factor must be a positive finite number, got {factor!r}")
        parts = tuple(
            Part(
                name=p.name,
                symmetry=p.symmetry,
                mesh=trimesh.Trimesh(vertices=np.asarray(p.mesh.vertices) * f, faces=np.asarray(p.mesh.faces), process=False),
            )
            for p in self.parts
        )
        joints = []
        for j in self.joints:
            T = j.parent_from_child_zero.copy()
            T[:3, 3] *= f
            prismatic = JointType.parse(j.type) == JointType.PRISMATIC
            k = f if prismatic else 1.0
            joints.append(
                Joint(
                    type=j.type,
                    parent=j.parent,
                    child=j.child,
                    pivot=j.pivot * f,
                    axis=j.axis,
                    limits=(j.limits[0] * k, j.limits[1] * k),
                    rest=j.rest * k,
                    parent_from_child_zero=T,
                )
            )
        return dataclasses.replace(self, parts=parts, joints=tuple(joints), scale=self.scale * f)

    def placements_at_zero(self) -> np.ndarray:
        """``(K, 4, 4)`` every part's pose in the object frame with every joint at state 0, which may lie
        outside the joints' limits (:meth:`object_from_part` refuses such states): the frame the
        generators build parts in."""
        out = np.empty((self.num_parts, 4, 4))
        out[0] = np.eye(4)
        for i in self._fk_order:
            j = self.joints[i]
            out[j.child] = out[j.parent] @ j.parent_from_child_zero
        return out

    def stretched(self, factors: Sequence[float] | np.ndarray) -> ArticulatedObject:
        """The same object stretched about the object frame's origin by ``factors`` along the object
        frame's x, y, z axes, applied at joint state 0 (every part at its state-0 placement).

        Each part's mesh is stretched along its own axes by the factors its state-0 orientation maps onto
        them, so every amodal box stays a box: the parts' state-0 orientations in the object frame must be
        signed permutations of the axes. Placements and pivots are stretched; a joint axis ``a`` becomes
        ``normalise(factors * a)``, and a prismatic joint's limits and rest state are multiplied by
        ``|factors * a|`` (the stretched length of a unit move). Revolute limits are unchanged. A part
        symmetric about its y axis must get the same factor along its x and z axes. ``stretch`` of the
        result is ``self.stretch * factors``; ``scale`` and ``params`` are kept.

        Args:
            factors: ``(3,)`` positive finite factors along the object frame's x, y, z.

        Raises:
            InputError: non-positive or non-finite factors, a part not axis-aligned at state 0, or a
                y-symmetric part stretched unequally across its axis.
        """
        try:
            f = np.asarray(factors, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise InputError(f"stretch factors must be 3 positive finite numbers, got {factors!r}") from None
        if f.shape != (3,) or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise InputError(f"stretch factors must be 3 positive finite numbers, got {factors!r}")
        zero = self.placements_at_zero()
        R = zero[:, :3, :3]
        tilted = np.flatnonzero((np.abs(np.abs(R) - np.abs(R).round()) > 1e-6).any(axis=(1, 2)))
        if len(tilted):
            k = int(tilted[0])
            raise InputError(f"part {self.parts[k].name!r} is not aligned with the object axes at state 0: cannot stretch it")
        in_part = np.abs(R).round().transpose(0, 2, 1) @ f  # (K, 3) factor along each part axis
        parts = []
        for p, s in zip(self.parts, in_part, strict=True):
            if p.symmetry == "y" and not np.isclose(s[0], s[2]):
                raise InputError(f"part {p.name!r} is symmetric about its y axis: its x and z stretch must be equal, got {s}")
            verts = np.asarray(p.mesh.vertices) * s
            mesh = trimesh.Trimesh(vertices=verts, faces=np.asarray(p.mesh.faces), process=False)
            parts.append(Part(name=p.name, symmetry=p.symmetry, mesh=mesh))
        placed = zero.copy()
        placed[:, :3, 3] *= f
        joints = []
        for j in self.joints:
            parent = zero[j.parent]
            pivot_obj = f * (parent[:3, :3] @ j.pivot + parent[:3, 3])
            axis_obj = f * (parent[:3, :3] @ j.axis)
            length = float(np.linalg.norm(axis_obj))
            k = length if JointType.parse(j.type) == JointType.PRISMATIC else 1.0
            inv = invert_transform(placed[j.parent])
            joints.append(
                Joint(
                    type=j.type,
                    parent=j.parent,
                    child=j.child,
                    pivot=apply_transform(inv, pivot_obj[None])[0],
                    axis=inv[:3, :3] @ (axis_obj / length),
                    limits=(j.limits[0] * k, j.limits[1] * k),
                    rest=j.rest * k,
                    parent_from_child_zero=inv @ placed[j.child],
                )
            )
        stretch = tuple(float(a * b) for a, b in zip(self.stretch, f, strict=True))
        return dataclasses.replace(self, parts=tuple(parts), joints=tuple(joints), stretch=stretch)

    def bounds(self, state: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """``(2, 3)`` axis-aligned bounds of the whole object in the object frame at ``state``."""
        v, _, _ = self.posed_geometry(state)
        return np.stack([v.min(0), v.max(0)])


def make_part(
    name: str,
    mesh_in_object: trimesh.Trimesh | Sequence[trimesh.Trimesh],
    rotation_object_from_part: np.ndarray | None = None,
    symmetry: str = "none",
) -> tuple[Part, np.ndarray]:
    """Make a :class:`Part` from geometry written in the object frame.

    Generators build every part in one common object frame (the root's orientation, at joint state 0).
    This finds the part's amodal box (the tight box along the axes of ``rotation_object_from_part``,
    default: the object axes), puts the part frame at the box centre, and returns the part with its
    mesh in that frame, and ``object_from_part`` ``(4, 4)`` (the part's pose at state 0).
    """
    if not isinstance(mesh_in_object, trimesh.Trimesh):
        mesh_in_object = trimesh.util.concatenate(list(mesh_in_object))
    R = np.eye(3) if rotation_object_from_part is None else np.asarray(rotation_object_from_part, dtype=np.float64)
    v_rot = mesh_in_object.vertices @ R  # coordinates along the part axes (origin at object origin)
    centre_rot = 0.5 * (v_rot.min(0) + v_rot.max(0))
    object_from_part = make_transform(R, R @ centre_rot)
    mesh = trimesh.Trimesh(vertices=v_rot - centre_rot, faces=np.asarray(mesh_in_object.faces), process=False)
    return Part(name=name, mesh=mesh, symmetry=symmetry), object_from_part


def build_object(
    category: str,
    instance_id: str,
    parts: Sequence[tuple[Part, np.ndarray]],
    joints: Sequence[dict] = (),
    params: dict | None = None,
    shape_family: str = "",
) -> ArticulatedObject:
    """Assemble an object from parts and joints written in the object frame at state 0.

    Args:
        parts: ``(part, object_from_part_zero)`` pairs as returned by :func:`make_part`; the first
            is the root. The object frame is re-anchored on the root part frame.
        joints: dicts with keys ``type, parent, child, pivot, axis, limits, rest``; ``pivot`` and
            ``axis`` are in the object frame (at state 0).
        shape_family: the category's shape family the instance belongs to.
    """
    poses = np.stack([T for _, T in parts])
    root_inv = invert_transform(poses[0])
    poses = root_inv @ poses  # object frame := root part frame
    built = []
    for spec in joints:
        p, c = int(spec["parent"]), int(spec["child"])
        parent_inv = invert_transform(poses[p])
        pivot = parent_inv[:3, :3] @ (root_inv[:3, :3] @ np.asarray(spec["pivot"], float) + root_inv[:3, 3]) + parent_inv[:3, 3]
        axis = parent_inv[:3, :3] @ (root_inv[:3, :3] @ np.asarray(spec["axis"], float))
        built.append(
            Joint(
                type=spec["type"],
                parent=p,
                child=c,
                pivot=pivot,
                axis=axis,
                limits=tuple(spec["limits"]),
                rest=float(spec.get("rest", spec["limits"][0])),
                parent_from_child_zero=parent_inv @ poses[c],
            )
        )
    return ArticulatedObject(
        category=category,
        instance_id=instance_id,
        parts=tuple(p for p, _ in parts),
        joints=tuple(built),
        params=dict(params or {}),
        shape_family=shape_family,
    )
