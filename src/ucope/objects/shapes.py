"""The mesh kit of the procedural categories: every mesh primitive and 2D outline the generators use.

Conventions (all functions):

* Lengths in metres. Meshes are :class:`trimesh.Trimesh` built vectorised with ``process=False`` (no
  merging, no validation, so building is fast), written in the caller's frame: usually the object frame
  of a category (y up, x right, z towards the front).
* Closed primitives are outward-oriented (counter-clockwise seen from outside), so the union of
  overlapping primitives has a well-defined inside for ray casting and winding numbers; there is no
  boolean union (:func:`combine` concatenates).
* 2D outlines are ``(N, 2)`` float arrays. A profile for :func:`revolve_profile` is a polyline of
  ``(r, y)`` points (radius from the y axis, height); a loop that runs counter-clockwise in the
  ``(r, y)`` plane (up the outer side, down the inner side) gives outward-facing triangles.
* Axis names ``"x" "y" "z"`` are the frame's axes; a ``plane`` such as ``"xz"`` names the two axes of a
  polygon's ``(a, b)`` coordinates (``"xz"``: points are ``(x, z)``) and the third axis is the extrusion
  direction.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh

from ..geometry.transforms import make_transform, rotation_about_axis

__all__ = [
    # meshes
    "combine",
    "transformed",
    "box",
    "boxes",
    "open_box",
    "cylinder",
    "disc",
    "rod",
    "extrude",
    "rounded_slab",
    "revolve_profile",
    "sweep_planar",
    # 2D outlines
    "arc",
    "rounded_rect",
    "superellipse",
    "offset_curve",
    "clip_convex",
    "curve_x_at",
    "convex_outline",
]

_AXES = {"x": 0, "y": 1, "z": 2}


def _mesh(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    return trimesh.Trimesh(vertices=np.asarray(vertices, float), faces=np.asarray(faces, np.int64), process=False)


# ------------------------------------------------------------------------------------------------
# meshes


def combine(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate meshes into one (no boolean union: overlapping solids are fine for rendering)."""
    verts, faces, off = [], [], 0
    for m in meshes:
        verts.append(np.asarray(m.vertices))
        faces.append(np.asarray(m.faces) + off)
        off += len(m.vertices)
    return _mesh(np.concatenate(verts), np.concatenate(faces))


def transformed(
    mesh: trimesh.Trimesh, rotation: np.ndarray | None = None, translation: Sequence[float] = (0, 0, 0)
) -> trimesh.Trimesh:
    """A copy of ``mesh`` with vertices ``R @ v + t``.

    Args:
        rotation: ``(3, 3)`` proper rotation (so the winding is kept), or ``None`` for the identity.
        translation: ``(3,)`` metres.
    """
    v = np.asarray(mesh.vertices, float)
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return trimesh.Trimesh(vertices=v + np.asarray(translation, float), faces=np.asarray(mesh.faces), process=False)


def box(
    extents: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0), rotation: np.ndarray | None = None
) -> trimesh.Trimesh:
    """One closed box of ``extents`` ``(3,)`` (x, y, z) metres, centred at ``center`` ``(3,)``, optionally
    rotated by ``rotation`` ``(3, 3)`` about its centre. For many axis-aligned boxes use :func:`boxes`."""
    m = trimesh.creation.box(extents=np.asarray(extents, float))
    m.apply_transform(make_transform(rotation, np.asarray(center, float)))
    return _mesh(m.vertices, m.faces)


# unit box corners and its 12 outward triangles (same layout for every box)
_BOX_CORNERS = (
    np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float) * 0.5
)
_BOX_FACES = np.array(
    [
        [0, 2, 1],
        [0, 3, 2],  # -z
        [4, 5, 6],
        [4, 6, 7],  # +z
        [0, 1, 5],
        [0, 5, 4],  # -y
        [3, 7, 6],
        [3, 6, 2],  # +y
        [0, 4, 7],
        [0, 7, 3],  # -x
        [1, 2, 6],
        [1, 6, 5],  # +x
    ],
    np.int64,
)


def boxes(centers: np.ndarray, extents: np.ndarray) -> trimesh.Trimesh:
    """``M`` axis-aligned closed boxes in one mesh.

    Args:
        centers: ``(M, 3)`` (or ``(3,)`` for one box) box centres, metres.
        extents: ``(M, 3)`` or ``(3,)`` (shared) edge lengths along x, y, z, metres.

    Returns:
        A mesh of ``8 M`` vertices and ``12 M`` faces.
    """
    c = np.atleast_2d(np.asarray(centers, float))
    e = np.broadcast_to(np.atleast_2d(np.asarray(extents, float)), c.shape)
    n = len(c)
    v = (c[:, None, :] + _BOX_CORNERS[None] * e[:, None, :]).reshape(-1, 3)
    f = (_BOX_FACES[None] + 8 * np.arange(n)[:, None, None]).reshape(-1, 3)
    return _mesh(v, f)


def open_box(
    outer: Sequence[float],
    wall: float,
    center: Sequence[float] = (0.0, 0.0, 0.0),
    open_side: str = "+z",
    shelves_y: Sequence[float] = (),
) -> trimesh.Trimesh:
    """A box of outer extents ``outer`` ``(3,)`` made of walls of thickness ``wall`` (metres), one side open.

    Args:
        open_side: one of ``"+x" "-x" "+y" "-y" "+z" "-z"``, the side left out.
        shelves_y: heights (metres, relative to ``center``) of horizontal boards spanning the full inner
            width and depth.
    """
    ex = np.asarray(outer, float)
    c = np.asarray(center, float)
    centres, sizes = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            name = ("+" if sign > 0 else "-") + "xyz"[axis]
            if name == open_side:
                continue
            size = ex.copy()
            size[axis] = wall
            off = np.zeros(3)
            off[axis] = sign * (ex[axis] - wall) / 2
            centres.append(c + off)
            sizes.append(size)
    for y in shelves_y:
        centres.append(c + [0.0, y, 0.0])
        sizes.append([ex[0] - 2 * wall, wall, ex[2] - 2 * wall])
    return boxes(np.array(centres), np.array(sizes))


def cylinder(
    radius: float, height: float, center: Sequence[float] = (0, 0, 0), axis: Sequence[float] = (0, 1, 0), sections: int = 24
) -> trimesh.Trimesh:
    """A closed cylinder along any direction ``axis`` ``(3,)`` (default y), centred at ``center`` ``(3,)``.
    Along an axis of the frame, :func:`disc` is cheaper."""
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


def disc(radius: float, height: float, center: Sequence[float], axis: str = "y", n: int = 16) -> trimesh.Trimesh:
    """A closed cylinder (an ``n``-gon prism) of ``radius`` and ``height`` (metres) along the frame axis
    ``axis`` (``"x" "y" "z"``), centred at ``center`` ``(3,)``."""
    a = _AXES[axis]
    plane = {0: "yz", 1: "zx", 2: "xy"}[a]
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    poly = np.stack([radius * np.cos(t), radius * np.sin(t)], -1)
    m = extrude(poly, height, plane=plane, offset=0.0)
    m.vertices += np.asarray(center, float)
    return m


def rod(p0: Sequence[float], p1: Sequence[float], radius: float, sections: int = 8) -> trimesh.Trimesh:
    """A straight closed cylinder of ``radius`` from point ``p0`` ``(3,)`` to point ``p1`` ``(3,)``."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    ref = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 * np.linalg.norm(d) else np.array([1.0, 0.0, 0.0])
    return sweep_planar(np.stack([p0, p1]), np.cross(d, ref), radius, radius, sections, closed=False)


def extrude(poly: np.ndarray, thickness: float, plane: str = "xz", offset: float = 0.0) -> trimesh.Trimesh:
    """Extrude a CONVEX ``(N, 2)`` polygon (either orientation) drawn in an axis ``plane``.

    Args:
        poly: the polygon's ``(a, b)`` coordinates in the two axes named by ``plane``, metres.
        thickness: extent along the third axis, metres, centred on ``offset`` along it.

    Returns:
        A closed, outward-oriented prism (the caps are fans, hence the convexity requirement).
    """
    poly = np.asarray(poly, float)
    a0, a1 = _AXES[plane[0]], _AXES[plane[1]]
    a2 = 3 - a0 - a1
    n = len(poly)
    v = np.zeros((2 * n, 3))
    v[:n, a0] = v[n:, a0] = poly[:, 0]
    v[:n, a1] = v[n:, a1] = poly[:, 1]
    v[:n, a2] = offset - thickness / 2
    v[n:, a2] = offset + thickness / 2
    i = np.arange(n)
    i1 = (i + 1) % n
    fan = np.arange(1, n - 1)
    f = np.concatenate(
        [
            np.stack([i, i1, n + i1], -1),
            np.stack([i, n + i1, n + i], -1),
            np.stack([np.zeros(n - 2, int), fan + 1, fan], -1),
            np.stack([np.full(n - 2, n), n + fan, n + fan + 1], -1),
        ]
    )
    # orientation: prism faces are outward for a CCW polygon in a right-handed (a0, a1, a2) frame
    area2 = np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])
    perm = np.zeros((3, 3))
    perm[0, a0] = perm[1, a1] = perm[2, a2] = 1.0
    if (area2 > 0) != (np.linalg.det(perm) > 0):
        f = f[:, ::-1]
    return _mesh(v, f)


# (x, y, z) coordinates of the extrusion frame -> object frame, per extrusion axis (proper rotations)
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
    """A box of extents ``size`` ``(3,)`` (x, y, z, metres) whose 4 edges parallel to ``axis`` are rounded
    by ``radius`` (``n_corner`` points per rounded corner), centred at ``center`` ``(3,)``."""
    sx, sy, sz = (float(s) for s in size)
    if axis == "z":
        poly, thick = rounded_rect(sx, sy, radius, n_corner), sz
    elif axis == "y":
        poly, thick = rounded_rect(sx, sz, radius, n_corner), sy
    elif axis == "x":
        poly, thick = rounded_rect(sy, sz, radius, n_corner), sx
    else:
        raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
    m = extrude(poly, thick, plane="xy")
    v = np.asarray(m.vertices) @ _PERM[axis].T + np.asarray(center, float)
    return trimesh.Trimesh(vertices=v, faces=np.asarray(m.faces), process=False)


def revolve_profile(profile_ry: np.ndarray, sections: int = 48, closed: bool = True) -> trimesh.Trimesh:
    """Revolve a 2D profile about the y axis.

    Args:
        profile_ry: ``(N, 2)`` ``(r, y)`` points, metres. With ``closed=True`` the polyline is a closed
            loop (a cross-section with wall thickness); otherwise an open line whose end points on the
            axis (``r = 0``) close the surface.
        sections: number of angular steps; a multiple of 4 keeps the x and z extents equal.

    Returns:
        The surface of revolution, without the zero-area triangles that profile points on the axis make.
        The angle runs from +x towards -z (counter-clockwise seen from +y).
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
    v = np.asarray(verts, float)
    area2 = np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1)
    return _mesh(v, faces[area2 > 1e-14])


def sweep_planar(
    path: np.ndarray,
    plane_normal: Sequence[float],
    r_normal: float | np.ndarray,
    r_inplane: float | np.ndarray,
    sections: int = 8,
    closed: bool = False,
) -> trimesh.Trimesh:
    """Sweep an elliptic cross-section along a ``(N, 3)`` path lying in a plane (metres).

    The section has half-axis ``r_normal`` along ``plane_normal`` ``(3,)`` and ``r_inplane`` in the plane,
    perpendicular to the path; both may vary along the path (``(N,)`` arrays). The frame comes from the
    plane normal (no sequential transport). ``closed`` joins the last point to the first (a ring);
    open paths get capped.
    """
    path = np.asarray(path, float)
    n = len(path)
    nrm = np.asarray(plane_normal, float)
    nrm = nrm / np.linalg.norm(nrm)
    if closed:
        tang = np.roll(path, -1, 0) - np.roll(path, 1, 0)
    else:
        tang = np.gradient(path, axis=0)
    tang = tang - (tang @ nrm)[:, None] * nrm
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    bin_ = np.cross(tang, nrm)  # in-plane, perpendicular to the path; (nrm, bin, tang) right-handed
    rn = np.broadcast_to(np.asarray(r_normal, float), (n,))
    rb = np.broadcast_to(np.asarray(r_inplane, float), (n,))
    phi = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    ring = (
        rn[:, None, None] * np.cos(phi)[None, :, None] * nrm[None, None, :]
        + rb[:, None, None] * np.sin(phi)[None, :, None] * bin_[:, None, :]
    )
    v = (path[:, None, :] + ring).reshape(-1, 3)
    i = np.arange(n if closed else n - 1)[:, None]
    j = np.arange(sections)[None, :]
    i1, j1 = (i + 1) % n, (j + 1) % sections
    a, b, c, d = i * sections + j, i1 * sections + j, i1 * sections + j1, i * sections + j1
    faces = [np.stack([a, c, b], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    if not closed:
        base = len(v)
        v = np.concatenate([v, path[[0, -1]]])
        k = np.arange(sections)
        k1 = (k + 1) % sections
        last = (n - 1) * sections
        faces.append(np.stack([np.full(sections, base), k1, k], -1))
        faces.append(np.stack([np.full(sections, base + 1), last + k, last + k1], -1))
    return _mesh(v, np.concatenate(faces))


# ------------------------------------------------------------------------------------------------
# 2D outlines


def arc(center: Sequence[float], radius: float | Sequence[float], a0: float, a1: float, n: int) -> np.ndarray:
    """``(n, 2)`` points of a circular (or elliptic, ``radius=(rx, ry)``) arc from angle ``a0`` to ``a1``
    (radians, counter-clockwise from +a), both ends included."""
    rad = np.broadcast_to(np.asarray(radius, float), (2,))
    t = np.linspace(a0, a1, n)
    return np.stack([center[0] + rad[0] * np.cos(t), center[1] + rad[1] * np.sin(t)], -1)


def rounded_rect(
    width: float, height: float, radius: float, n_corner: int = 5, center: Sequence[float] = (0.0, 0.0)
) -> np.ndarray:
    """Counter-clockwise convex ``(4 n_corner, 2)`` outline of a ``width x height`` rectangle with corner
    ``radius`` (clipped to fit), centred at ``center``, ``n_corner`` points per corner; it starts at the
    top of the right edge (the (+, +) corner comes first)."""
    r = float(np.clip(radius, 1e-5, 0.5 * min(width, height) - 1e-6))
    cx = np.array([width / 2 - r, -width / 2 + r, -width / 2 + r, width / 2 - r])
    cy = np.array([height / 2 - r, height / 2 - r, -height / 2 + r, -height / 2 + r])
    start = np.array([0.0, 0.5, 1.0, 1.5]) * np.pi
    t = start[:, None] + np.linspace(0.0, 0.5 * np.pi, n_corner)[None, :]
    x = cx[:, None] + r * np.cos(t)
    y = cy[:, None] + r * np.sin(t)
    return np.stack([x.ravel() + center[0], y.ravel() + center[1]], -1)


def superellipse(a: float, b: float, p: float = 2.0, n: int = 32, center: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """``(n, 2)`` counter-clockwise points of ``|x/a|^p + |y/b|^p = 1`` (an ellipse for ``p = 2``, a rounded
    rectangle as ``p`` grows; convex for ``p >= 1``), centred at ``center``; starts at ``(a, 0)``."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    x = a * np.sign(c) * np.abs(c) ** (2.0 / p)
    y = b * np.sign(s) * np.abs(s) ** (2.0 / p)
    return np.stack([center[0] + x, center[1] + y], -1)


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


def clip_convex(poly: np.ndarray, coord: int, value: float, keep: str = "below") -> np.ndarray:
    """Clip a convex ``(N, 2)`` polygon by the half-plane ``poly[:, coord] <= value`` (``keep="below"``)
    or ``>= value`` (``"above"``); vectorised Sutherland-Hodgman with one line."""
    poly = np.asarray(poly, float)
    s = poly[:, coord] - value
    if keep == "above":
        s = -s
    inside = s <= 0
    nxt, sn = np.roll(poly, -1, 0), np.roll(s, -1)
    cross = inside != np.roll(inside, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(cross, s / (s - sn), 0.0)
    ipts = poly + t[:, None] * (nxt - poly)
    out = np.stack([poly, ipts], 1).reshape(-1, 2)
    mask = np.stack([inside, cross], 1).reshape(-1)
    return out[mask]


def convex_outline(points: np.ndarray, n: int = 48) -> np.ndarray:
    """The convex hull of ``(M, 2)`` points as ``n`` counter-clockwise points spaced evenly along its
    perimeter (for shapes made of several convex pieces: a teardrop from two ellipses)."""
    from scipy.spatial import ConvexHull  # noqa: PLC0415 - scipy is a hard dependency, imported on use

    p = np.asarray(points, float)
    hull = p[ConvexHull(p).vertices]  # counter-clockwise in 2D
    closed = np.concatenate([hull, hull[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])], -1)


def curve_x_at(curve: np.ndarray, y: float, centre_x: float, side: int) -> float:
    """x of a convex closed ``(N, 2)`` curve at height ``y`` on the side ``side`` (-1: x < centre_x,
    +1: x > centre_x), interpolated linearly."""
    sel = curve[(curve[:, 0] - centre_x) * side > 0]
    order = np.argsort(sel[:, 1])
    return float(np.interp(y, sel[order, 1], sel[order, 0]))
