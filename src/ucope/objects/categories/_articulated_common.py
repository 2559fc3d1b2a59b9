"""Private mesh helpers shared by the articulated (ArtImage-like) categories.

Everything here is vectorised numpy: many boxes in one call, extrusions of convex polygons in any
axis plane, and sweeps of elliptic cross-sections along planar paths (the frame comes from the
plane normal, so there is no sequential frame transport). All meshes keep outward-facing windings.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import trimesh

__all__ = ["boxes", "rounded_rect", "superellipse", "clip_convex", "extrude", "sweep_planar", "rod", "disc", "curve_x_at"]

_AXES = {"x": 0, "y": 1, "z": 2}

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


def _mesh(v: np.ndarray, f: np.ndarray) -> trimesh.Trimesh:
    return trimesh.Trimesh(vertices=np.asarray(v, float), faces=np.asarray(f, np.int64), process=False)


def boxes(centers: np.ndarray, extents: np.ndarray) -> trimesh.Trimesh:
    """``N`` axis-aligned closed boxes in one mesh: ``centers`` and ``extents`` are ``(N, 3)`` (or broadcastable)."""
    c = np.atleast_2d(np.asarray(centers, float))
    e = np.broadcast_to(np.atleast_2d(np.asarray(extents, float)), c.shape)
    n = len(c)
    v = (c[:, None, :] + _BOX_CORNERS[None] * e[:, None, :]).reshape(-1, 3)
    f = (_BOX_FACES[None] + 8 * np.arange(n)[:, None, None]).reshape(-1, 3)
    return _mesh(v, f)


def superellipse(a: float, b: float, p: float = 2.0, n: int = 32, center: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """``(n, 2)`` counter-clockwise points of ``|x/a|^p + |y/b|^p = 1`` (convex for ``p >= 1``); starts at ``(a, 0)``."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    x = a * np.sign(c) * np.abs(c) ** (2.0 / p)
    y = b * np.sign(s) * np.abs(s) ** (2.0 / p)
    return np.stack([center[0] + x, center[1] + y], -1)


def rounded_rect(w: float, h: float, r: float, n_corner: int = 5, center: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """Counter-clockwise convex polygon of a ``w x h`` rectangle with corner radius ``r``."""
    r = float(np.clip(r, 1e-5, 0.5 * min(w, h) - 1e-6))
    cx = np.array([w / 2 - r, -w / 2 + r, -w / 2 + r, w / 2 - r])
    cy = np.array([h / 2 - r, h / 2 - r, -h / 2 + r, -h / 2 + r])
    start = np.array([0.0, 0.5, 1.0, 1.5]) * np.pi
    t = start[:, None] + np.linspace(0.0, 0.5 * np.pi, n_corner)[None, :]
    x = cx[:, None] + r * np.cos(t)
    y = cy[:, None] + r * np.sin(t)
    return np.stack([x.ravel() + center[0], y.ravel() + center[1]], -1)


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


def extrude(poly: np.ndarray, thickness: float, plane: str = "xz", offset: float = 0.0) -> trimesh.Trimesh:
    """Extrude a CONVEX polygon (any orientation) drawn in an axis ``plane``.

    ``plane`` names the two axes of the polygon coordinates (``"xz"``: points are ``(x, z)``); the
    extrusion runs along the third axis, centred on ``offset`` along it.
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


def sweep_planar(
    path: np.ndarray,
    plane_normal: Sequence[float],
    r_normal: float | np.ndarray,
    r_inplane: float | np.ndarray,
    sections: int = 8,
    closed: bool = False,
) -> trimesh.Trimesh:
    """Sweep an elliptic cross-section along a ``(N, 3)`` path lying in a plane.

    The section has half-axis ``r_normal`` along ``plane_normal`` and ``r_inplane`` in the plane,
    perpendicular to the path; both may vary along the path (``(N,)`` arrays). Open paths get capped.
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
    ring = (rn[:, None, None] * np.cos(phi)[None, :, None] * nrm[None, None, :]
            + rb[:, None, None] * np.sin(phi)[None, :, None] * bin_[:, None, :])
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
        faces.append(np.stack([np.full(sections, base), k, k1], -1))
        faces.append(np.stack([np.full(sections, base + 1), last + k1, last + k], -1))
    return _mesh(v, np.concatenate(faces))


def disc(radius: float, height: float, center: Sequence[float], axis: str = "y", n: int = 16) -> trimesh.Trimesh:
    """A closed cylinder along an object axis (cheaper than :func:`shapes.cylinder`)."""
    a = _AXES[axis]
    plane = {0: "yz", 1: "zx", 2: "xy"}[a]
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    poly = np.stack([radius * np.cos(t), radius * np.sin(t)], -1)
    m = extrude(poly, height, plane=plane, offset=0.0)
    m.vertices += np.asarray(center, float)
    return m


def rod(p0: Sequence[float], p1: Sequence[float], radius: float, sections: int = 8) -> trimesh.Trimesh:
    """A straight closed cylinder from ``p0`` to ``p1``."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    ref = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 * np.linalg.norm(d) else np.array([1.0, 0.0, 0.0])
    return sweep_planar(np.stack([p0, p1]), np.cross(d, ref), radius, radius, sections, closed=False)


def curve_x_at(curve: np.ndarray, y: float, centre_x: float, side: int) -> float:
    """x of a convex closed ``(N, 2)`` curve at height ``y`` on the side ``side`` (-1: x < centre_x, +1: x > centre_x)."""
    sel = curve[(curve[:, 0] - centre_x) * side > 0]
    order = np.argsort(sel[:, 1])
    return float(np.interp(y, sel[order, 1], sel[order, 0]))
