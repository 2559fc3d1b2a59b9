"""Private helpers shared by the NOCS-like rigid category generators (bottle, bowl, camera, can,
laptop_rigid, mug).

Profiles are ``(N, 2)`` arrays of ``(r, y)`` points for :func:`ucope.objects.shapes.revolve_profile`.
A profile loop that runs counter-clockwise in the (r, y) plane (up the outer side, down the inner
side) gives outward-facing triangles.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine, prism, revolve_profile

__all__ = [
    "uniform",
    "arc",
    "offset_curve",
    "lathe",
    "rounded_rect",
    "rounded_slab",
    "boxes",
    "transformed",
    "finish",
]


def uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """One float drawn uniformly in ``[lo, hi)`` (a plain Python float, for the params dict)."""
    return float(rng.uniform(lo, hi))


def arc(center: Sequence[float], radius: float | Sequence[float], a0: float, a1: float, n: int) -> np.ndarray:
    """``(n, 2)`` points of a circular (or elliptic, ``radius=(rx, ry)``) arc from angle ``a0`` to ``a1``."""
    rad = np.broadcast_to(np.asarray(radius, float), (2,))
    t = np.linspace(a0, a1, n)
    return np.stack([center[0] + rad[0] * np.cos(t), center[1] + rad[1] * np.sin(t)], -1)


def offset_curve(points: np.ndarray, distance: float, max_miter: float = 2.0) -> np.ndarray:
    """Offset an open ``(N, 2)`` polyline by ``distance`` to its LEFT (inwards for a profile that runs
    counter-clockwise, e.g. up an outer wall). Mitred vertex normals, clipped at ``max_miter``."""
    p = np.asarray(points, float)
    seg = np.diff(p, axis=0)
    seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    left = np.stack([-seg[:, 1], seg[:, 0]], -1)  # (N-1, 2) unit left normals of the segments
    n_prev = np.concatenate([left[:1], left])
    n_next = np.concatenate([left, left[-1:]])
    avg = n_prev + n_next
    avg /= np.maximum(np.linalg.norm(avg, axis=1, keepdims=True), 1e-12)
    cos_half = np.clip(np.sum(avg * n_next, axis=1, keepdims=True), 1.0 / max_miter, 1.0)
    return p + distance * avg / cos_half


def lathe(profile_ry: np.ndarray, sections: int = 48, closed: bool = True) -> trimesh.Trimesh:
    """:func:`revolve_profile`, minus the zero-area triangles that profile points on the axis
    (``r = 0``) produce. ``sections`` should be a multiple of 4 so the x and z extents agree."""
    prof = np.asarray(profile_ry, float)
    m = revolve_profile(prof, sections=sections, closed=closed)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    area2 = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    keep = area2 > 1e-14
    return trimesh.Trimesh(vertices=v, faces=f[keep], process=False)


def rounded_rect(width: float, height: float, radius: float, n_corner: int = 6) -> np.ndarray:
    """Counter-clockwise convex ``(4 * n_corner, 2)`` rounded rectangle centred on the origin."""
    r = float(np.clip(radius, 1e-5, 0.5 * min(width, height) - 1e-6))
    cx = np.array([width / 2 - r, -width / 2 + r, -width / 2 + r, width / 2 - r])
    cy = np.array([height / 2 - r, height / 2 - r, -height / 2 + r, -height / 2 + r])
    start = np.array([0.0, 0.5, 1.0, 1.5]) * np.pi
    t = start[:, None] + np.linspace(0.0, 0.5 * np.pi, n_corner)[None, :]
    x = cx[:, None] + r * np.cos(t)
    y = cy[:, None] + r * np.sin(t)
    return np.stack([x.ravel() + 0.0, y.ravel() + 0.0], -1)


# (x, y, z) coordinates of the prism frame -> object frame, per extrusion axis (proper rotations)
_PERM = {
    "z": np.eye(3),
    "y": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),  # polygon (a, b) in the x, -z plane
    "x": np.array([[0.0, 0, 1], [1, 0, 0], [0, 1, 0]]),  # polygon (a, b) in the y, z plane
}


def rounded_slab(
    size: Sequence[float],
    radius: float,
    axis: str = "z",
    center: Sequence[float] = (0.0, 0.0, 0.0),
    n_corner: int = 6,
) -> trimesh.Trimesh:
    """A box of extents ``size`` (x, y, z) whose 4 edges parallel to ``axis`` are rounded by ``radius``."""
    sx, sy, sz = (float(s) for s in size)
    if axis == "z":
        poly, thick = rounded_rect(sx, sy, radius, n_corner), sz
    elif axis == "y":
        poly, thick = rounded_rect(sx, sz, radius, n_corner), sy
    elif axis == "x":
        poly, thick = rounded_rect(sy, sz, radius, n_corner), sx
    else:
        raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
    m = prism(poly, thick)
    v = np.asarray(m.vertices) @ _PERM[axis].T + np.asarray(center, float)
    return trimesh.Trimesh(vertices=v, faces=np.asarray(m.faces), process=False)


# unit box corners and its 12 outward triangles (same layout for every box)
_BOX_CORNERS = np.array(
    [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float
) * 0.5
_BOX_FACES = np.array(
    [
        [0, 2, 1], [0, 3, 2],  # -z
        [4, 5, 6], [4, 6, 7],  # +z
        [0, 1, 5], [0, 5, 4],  # -y
        [3, 7, 6], [3, 6, 2],  # +y
        [0, 4, 7], [0, 7, 3],  # -x
        [1, 2, 6], [1, 6, 5],  # +x
    ],
    np.int64,
)


def boxes(centers: np.ndarray, extents: np.ndarray) -> trimesh.Trimesh:
    """Many axis-aligned boxes at once: ``centers`` ``(M, 3)``, ``extents`` ``(M, 3)`` or ``(3,)``."""
    c = np.atleast_2d(np.asarray(centers, float))
    e = np.broadcast_to(np.atleast_2d(np.asarray(extents, float)), c.shape)
    n = len(c)
    v = (c[:, None, :] + _BOX_CORNERS[None] * e[:, None, :]).reshape(-1, 3)
    f = (_BOX_FACES[None] + 8 * np.arange(n)[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def transformed(mesh: trimesh.Trimesh, rotation: np.ndarray | None = None, translation: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """A copy of ``mesh`` with vertices ``R @ v + t`` (R a proper rotation, so the winding is kept)."""
    v = np.asarray(mesh.vertices, float)
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return trimesh.Trimesh(vertices=v + np.asarray(translation, float), faces=np.asarray(mesh.faces), process=False)


def finish(category: str, instance_id: str, meshes: Sequence[trimesh.Trimesh], symmetry: str, params: dict) -> ArticulatedObject:
    """One rigid part ``"body"`` from ``meshes`` (object frame), centred by :func:`make_part`."""
    mesh = combine(list(meshes)) if len(meshes) > 1 else meshes[0]
    part, T = make_part("body", mesh, symmetry=symmetry)
    return build_object(category, instance_id, [(part, T)], joints=[], params=params)
