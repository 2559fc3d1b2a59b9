"""Mesh building blocks for the procedural categories (numpy + trimesh, no optional dependency).

All functions return :class:`trimesh.Trimesh` in metres, in the frame of the caller (usually the
object frame: y up, x right, z towards the front). Meshes are built vectorised; none is processed or
merged, so building is fast.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import trimesh

from ..geometry.transforms import make_transform, rotation_about_axis

__all__ = [
    "box",
    "open_box",
    "cylinder",
    "revolve_profile",
    "tube_along_path",
    "prism",
    "ellipse",
    "combine",
]


def _mesh(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    return trimesh.Trimesh(vertices=np.asarray(vertices, float), faces=np.asarray(faces, np.int64), process=False)


def combine(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate meshes into one (no boolean union: overlapping solids are fine for rendering)."""
    verts, faces, off = [], [], 0
    for m in meshes:
        verts.append(np.asarray(m.vertices))
        faces.append(np.asarray(m.faces) + off)
        off += len(m.vertices)
    return _mesh(np.concatenate(verts), np.concatenate(faces))


def box(extents: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0), rotation: np.ndarray | None = None) -> trimesh.Trimesh:
    """A closed box with ``extents`` (x, y, z) metres, centred at ``center``, optionally rotated."""
    m = trimesh.creation.box(extents=np.asarray(extents, float))
    m.apply_transform(make_transform(rotation, np.asarray(center, float)))
    return _mesh(m.vertices, m.faces)


def open_box(
    outer: Sequence[float],
    wall: float,
    center: Sequence[float] = (0.0, 0.0, 0.0),
    open_side: str = "+z",
    shelves_y: Sequence[float] = (),
) -> trimesh.Trimesh:
    """A box of outer ``extents`` made of walls of thickness ``wall``, with one side open.

    ``open_side`` is one of ``"+x" "-x" "+y" "-y" "+z" "-z"``. ``shelves_y`` adds horizontal boards
    (full inner width and depth) at those heights relative to ``center``.
    """
    ex = np.asarray(outer, float)
    c = np.asarray(center, float)
    parts = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            name = ("+" if sign > 0 else "-") + "xyz"[axis]
            if name == open_side:
                continue
            size = ex.copy()
            size[axis] = wall
            off = np.zeros(3)
            off[axis] = sign * (ex[axis] - wall) / 2
            parts.append(box(size, c + off))
    for y in shelves_y:
        parts.append(box([ex[0] - 2 * wall, wall, ex[2] - 2 * wall], c + [0.0, y, 0.0]))
    return combine(parts)


def cylinder(radius: float, height: float, center: Sequence[float] = (0, 0, 0), axis: Sequence[float] = (0, 1, 0), sections: int = 24) -> trimesh.Trimesh:
    """A closed cylinder along ``axis`` (default y), centred at ``center``."""
    m = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)  # along z
    R = _rotation_z_to(np.asarray(axis, float))
    m.apply_transform(make_transform(R, np.asarray(center, float)))
    return _mesh(m.vertices, m.faces)


def _rotation_z_to(axis: np.ndarray) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ axis)
    if c > 1 - 1e-12:
        return np.eye(3)
    if c < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross(z, axis)
    return rotation_about_axis(v, np.arccos(c))


def revolve_profile(profile_ry: np.ndarray, sections: int = 32, closed: bool = True) -> trimesh.Trimesh:
    """Revolve a 2D profile about the y axis.

    Args:
        profile_ry: ``(N, 2)`` (radius, height) points. With ``closed=True`` the polyline is treated as a
            closed loop (a cross-section with wall thickness); otherwise as an open line whose end
            points on the axis (radius 0) close the surface.
        sections: number of angular steps.
    """
    prof = np.asarray(profile_ry, float)
    n = len(prof)
    theta = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    r, y = prof[:, 0], prof[:, 1]
    verts = np.stack(
        [r[None, :] * np.cos(theta)[:, None], np.broadcast_to(y, (sections, n)), -r[None, :] * np.sin(theta)[:, None]],
        axis=-1,
    ).reshape(-1, 3)
    i = np.arange(sections)[:, None]
    j = np.arange(n if closed else n - 1)[None, :]
    i1, j1 = (i + 1) % sections, (j + 1) % n
    a, b, c, d = i * n + j, i1 * n + j, i1 * n + j1, i * n + j1
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return _mesh(verts, faces)


def _path_frames(path: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal / binormal at each path point by parallel transport of an initial frame."""
    if closed:
        tang = np.roll(path, -1, 0) - np.roll(path, 1, 0)
    else:
        tang = np.gradient(path, axis=0)
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    ref = np.array([0.0, 1.0, 0.0]) if abs(tang[0, 1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    normals = np.empty_like(path)
    nrm = np.cross(tang[0], ref)
    nrm /= np.linalg.norm(nrm)
    # parallel transport is sequential by nature; paths have a few dozen points, not a hot loop
    for k in range(len(path)):
        nrm = nrm - (nrm @ tang[k]) * tang[k]
        nrm /= np.linalg.norm(nrm)
        normals[k] = nrm
    binormals = np.cross(tang, normals)
    return normals, binormals


def tube_along_path(path: np.ndarray, radius: float | Sequence[float], sections: int = 8, closed: bool = False) -> trimesh.Trimesh:
    """A tube of ``radius`` (scalar, or ``(2,)`` = half-widths along the path normal and binormal)
    swept along a ``(N, 3)`` polyline; ``closed`` joins the last point to the first (a ring)."""
    path = np.asarray(path, float)
    rad = np.broadcast_to(np.asarray(radius, float), (2,))
    normals, binormals = _path_frames(path, closed)
    phi = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    ring = rad[0] * np.cos(phi)[None, :, None] * normals[:, None, :] + rad[1] * np.sin(phi)[None, :, None] * binormals[:, None, :]
    verts = (path[:, None, :] + ring).reshape(-1, 3)
    n = len(path)
    i = np.arange(n if closed else n - 1)[:, None]
    j = np.arange(sections)[None, :]
    i1, j1 = (i + 1) % n, (j + 1) % sections
    a, b, c, d = i * sections + j, i1 * sections + j, i1 * sections + j1, i * sections + j1
    faces = [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    if not closed:  # cap the ends with fans around added centre vertices
        centres = np.stack([path[0], path[-1]])
        base = len(verts)
        verts = np.concatenate([verts, centres])
        k = np.arange(sections)
        k1 = (k + 1) % sections
        faces.append(np.stack([np.full(sections, base), k1, k], -1))
        last = (n - 1) * sections
        faces.append(np.stack([np.full(sections, base + 1), last + k, last + k1], -1))
    return _mesh(verts, np.concatenate(faces))


def prism(polygon_xy: np.ndarray, thickness: float, center_z: float = 0.0) -> trimesh.Trimesh:
    """Extrude a CONVEX ``(N, 2)`` polygon (counter-clockwise, in the x-y plane) along z by
    ``thickness``, centred on ``center_z``. Rotate the result to place it in another plane."""
    poly = np.asarray(polygon_xy, float)
    n = len(poly)
    z0, z1 = center_z - thickness / 2, center_z + thickness / 2
    verts = np.concatenate([np.c_[poly, np.full(n, z0)], np.c_[poly, np.full(n, z1)]])
    i = np.arange(n)
    i1 = (i + 1) % n
    sides = np.concatenate([np.stack([i, i1, n + i1], -1), np.stack([i, n + i1, n + i], -1)])
    fan = np.arange(1, n - 1)
    bottom = np.stack([np.zeros(n - 2, int), fan + 1, fan], -1)
    top = np.stack([np.full(n - 2, n), n + fan, n + fan + 1], -1)
    return _mesh(verts, np.concatenate([sides, bottom, top]))


def ellipse(a: float, b: float, n: int = 32, center: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """``(n, 2)`` counter-clockwise points of an ellipse with half-axes ``a`` (x) and ``b`` (y)."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([center[0] + a * np.cos(t), center[1] + b * np.sin(t)], -1)
