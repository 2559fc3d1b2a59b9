"""Oriented 3D boxes: corners, volume and exact 3D IoU.

Conventions (see also :mod:`ucope.geometry.transforms`):

* A box is described by a rigid transform ``cam_from_box`` of shape ``(..., 4, 4)`` and a size
  ``size_m`` of shape ``(..., 3)``.  The box centre is the origin of the box frame and the box edges
  are parallel to the box-frame axes.  ``size_m`` holds the *full* extents (not half extents) along
  the box's own x, y and z axes, in metres.  The box therefore occupies
  ``{p_box : |p_box[k]| <= size_m[k] / 2, k = 0, 1, 2}`` in its own frame.
* "Outer frame" means the frame ``cam_from_box`` maps into (usually the camera frame, but any frame
  works as long as both boxes of a comparison use the same one).
* Corner order (used by :func:`box_corners` and :data:`BOX_EDGES`): corner ``i`` (``0 <= i < 8``)
  has box-frame coordinates ``(sx * size_x, sy * size_y, sz * size_z) / 2`` with signs taken from the
  bits of ``i``: ``sx = +1`` if bit 2 of ``i`` is set else ``-1``, ``sy`` from bit 1, ``sz`` from
  bit 0.  Hence corner 0 is ``(-, -, -)``, 1 is ``(-, -, +)``, 2 is ``(-, +, -)``, 3 is ``(-, +, +)``,
  4 is ``(+, -, -)``, 5 is ``(+, -, +)``, 6 is ``(+, +, -)`` and 7 is ``(+, +, +)``.

All functions use numpy (float64) and raise :class:`ucope.errors.InputError` on bad input.
"""

from __future__ import annotations

import heapq

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial import ConvexHull, QhullError

from ..errors import InputError
from .transforms import apply_transform, invert_transform

__all__ = [
    "BOX_CORNER_SIGNS",
    "BOX_EDGES",
    "box_corners",
    "box_volume",
    "box_iou_3d",
    "box_iou_3d_batch",
    "box_iou_3d_symmetric_y",
    "SEEN_PATTERNS",
    "seen_pattern",
    "occluded_fraction",
]

#: ``(8, 3)`` float array: the sign of each coordinate of corner ``i`` in the box frame
#: (x sign from bit 2 of ``i``, y sign from bit 1, z sign from bit 0; ``-1`` where the bit is clear).
BOX_CORNER_SIGNS: np.ndarray = np.array([[1.0 if (i >> b) & 1 else -1.0 for b in (2, 1, 0)] for i in range(8)], dtype=np.float64)
BOX_CORNER_SIGNS.setflags(write=False)

#: ``(12, 2)`` int array of corner index pairs (see :func:`box_corners` for the corner order), one row
#: per box edge: rows 0-3 are the edges parallel to the box x axis, rows 4-7 parallel to y and
#: rows 8-11 parallel to z.  The first index of each pair is the corner on the negative side.
BOX_EDGES: np.ndarray = np.array(
    [
        [0, 4],
        [1, 5],
        [2, 6],
        [3, 7],  # along x (bit 2 flips)
        [0, 2],
        [1, 3],
        [4, 6],
        [5, 7],  # along y (bit 1 flips)
        [0, 1],
        [2, 3],
        [4, 5],
        [6, 7],
    ],  # along z (bit 0 flips)
    dtype=np.int64,
)
BOX_EDGES.setflags(write=False)

# The 6 face planes of a box, in its own frame: face j is {p : p[_FACE_AXES[j]] = _FACE_SIGNS[j] * h}.
_FACE_AXES = np.array([0, 0, 1, 1, 2, 2], dtype=np.int64)
_FACE_SIGNS = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])

# Relative tolerance (times the largest box extent) for inside tests, de-duplication and flatness.
_REL_TOL = 1e-9
# Tolerance used to decide whether a matrix is a rigid transform.
_RIGID_TOL = 1e-5


# --------------------------------------------------------------------------------------------------
# Input validation
# --------------------------------------------------------------------------------------------------


def _as_float_array(x, name: str) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a numeric array, got {type(x).__name__}") from exc
    return arr


def _check_transform(T, name: str, batch_shape: tuple | None = None) -> np.ndarray:
    """Return ``T`` as float64 after checking it is a finite rigid ``(..., 4, 4)`` transform."""
    T = _as_float_array(T, name)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise InputError(f"{name} must have shape (..., 4, 4), got {T.shape}")
    if batch_shape is not None and T.shape[:-2] != batch_shape:
        raise InputError(f"{name} must have shape {batch_shape + (4, 4)}, got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name} contains non-finite values (NaN or inf)")
    if np.any(np.abs(T[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])) > _RIGID_TOL):
        raise InputError(f"{name} must be a rigid transform: its last row must be [0, 0, 0, 1]")
    R = T[..., :3, :3]
    RtR = np.einsum("...ji,...jk->...ik", R, R)
    if np.any(np.abs(RtR - np.eye(3)) > _RIGID_TOL) or np.any(np.linalg.det(R) <= 0.0):
        raise InputError(f"{name} must be a rigid transform: its 3x3 block must be a rotation")
    return T


def _check_size(size, name: str, batch_shape: tuple | None = None, strict: bool = True) -> np.ndarray:
    """Return ``size`` as float64 after checking shape ``(..., 3)``, finiteness and sign."""
    size = _as_float_array(size, name)
    if size.ndim < 1 or size.shape[-1] != 3:
        raise InputError(f"{name} must have shape (..., 3), got {size.shape}")
    if batch_shape is not None and size.shape[:-1] != batch_shape:
        raise InputError(f"{name} must have shape {batch_shape + (3,)}, got {size.shape}")
    if not np.all(np.isfinite(size)):
        raise InputError(f"{name} contains non-finite values (NaN or inf)")
    if strict and np.any(size <= 0.0):
        raise InputError(f"{name} must be strictly positive (box extents in metres), got {size.tolist()}")
    if not strict and np.any(size < 0.0):
        raise InputError(f"{name} must be non-negative (box extents in metres), got {size.tolist()}")
    return size


# --------------------------------------------------------------------------------------------------
# Corners and volume
# --------------------------------------------------------------------------------------------------


def box_corners(cam_from_box: np.ndarray, size_m: np.ndarray) -> np.ndarray:
    """Corners of oriented boxes, in the outer frame.

    Args:
        cam_from_box: ``(..., 4, 4)`` rigid transforms mapping box-frame points to the outer
            (e.g. camera) frame.  The box centre is the box-frame origin.
        size_m: ``(..., 3)`` full box extents along the box's own x, y, z axes, in metres
            (non-negative; zero gives a flat box).  Leading dimensions broadcast with those of
            ``cam_from_box``.

    Returns:
        ``(..., 8, 3)`` corner positions in the outer frame, in metres, where ``...`` is the broadcast
        of the two batch shapes.  Corner ``i`` is
        ``cam_from_box @ (sx * size_x / 2, sy * size_y / 2, sz * size_z / 2)`` with
        ``sx = +1`` iff bit 2 of ``i`` is set (else ``-1``), ``sy`` from bit 1 and ``sz`` from bit 0:
        ``0: (-,-,-)``, ``1: (-,-,+)``, ``2: (-,+,-)``, ``3: (-,+,+)``, ``4: (+,-,-)``,
        ``5: (+,-,+)``, ``6: (+,+,-)``, ``7: (+,+,+)``.  See :data:`BOX_EDGES` for the edges.

    Raises:
        InputError: on wrong shapes, non-finite values, negative sizes or a non-rigid transform.

    Example:
        >>> import numpy as np
        >>> box_corners(np.eye(4), np.array([2.0, 2.0, 2.0]))[[0, 7]]
        array([[-1., -1., -1.],
               [ 1.,  1.,  1.]])
    """
    T = _check_transform(cam_from_box, "cam_from_box")
    size = _check_size(size_m, "size_m", strict=False)
    try:
        batch = np.broadcast_shapes(T.shape[:-2], size.shape[:-1])
    except ValueError as exc:
        raise InputError(f"batch shapes of cam_from_box {T.shape} and size_m {size.shape} do not broadcast") from exc
    local = BOX_CORNER_SIGNS * (0.5 * size[..., None, :])  # (..., 8, 3) in the box frame
    T = np.broadcast_to(T, batch + (4, 4))
    local = np.broadcast_to(local, batch + (8, 3))
    return apply_transform(T, local)


def box_volume(size_m: np.ndarray) -> np.ndarray | float:
    """Volume of boxes.

    Args:
        size_m: ``(..., 3)`` full box extents in metres (non-negative).

    Returns:
        ``(...)`` volumes in cubic metres (a Python ``float`` for a single ``(3,)`` size).

    Raises:
        InputError: on a wrong shape, non-finite values or negative sizes.
    """
    size = _check_size(size_m, "size_m", strict=False)
    vol = np.prod(size, axis=-1)
    return float(vol) if vol.ndim == 0 else vol


# --------------------------------------------------------------------------------------------------
# Exact IoU of two oriented boxes
# --------------------------------------------------------------------------------------------------


def _inside(points: np.ndarray, half: np.ndarray, tol: float) -> np.ndarray:
    """``(N,)`` mask of ``(N, 3)`` points (box frame) inside the box with half extents ``half``."""
    return np.all(np.abs(points) <= half + tol, axis=-1)


def _edge_face_points(corners_in_q: np.ndarray, half_q: np.ndarray, tol: float) -> np.ndarray:
    """Intersections of the 12 edges of box P with the 6 face planes of box Q, kept if inside Q.

    ``corners_in_q`` is the ``(8, 3)`` corners of P written in Q's frame; ``half_q`` the ``(3,)`` half
    extents of Q.  Returns ``(M, 3)`` points in Q's frame.  Vectorised over (12 edges x 6 planes).
    """
    p0 = corners_in_q[BOX_EDGES[:, 0]]  # (12, 3)
    d = corners_in_q[BOX_EDGES[:, 1]] - p0  # (12, 3)
    offsets = _FACE_SIGNS * half_q[_FACE_AXES]  # (6,)
    num = offsets[None, :] - p0[:, _FACE_AXES]  # (12, 6)
    den = d[:, _FACE_AXES]  # (12, 6)
    edge_len = np.linalg.norm(d, axis=-1, keepdims=True)  # (12, 1)
    ok = np.abs(den) > 1e-12 * edge_len  # edge not parallel to the plane
    t = np.divide(num, den, out=np.full(num.shape, np.nan), where=ok)
    t_tol = tol / np.maximum(edge_len, tol)
    ok &= (t >= -t_tol) & (t <= 1.0 + t_tol)
    t = np.clip(np.where(ok, t, 0.0), 0.0, 1.0)
    pts = p0[:, None, :] + t[..., None] * d[:, None, :]  # (12, 6, 3)
    pts[:, np.arange(6), _FACE_AXES] = offsets  # snap exactly onto the plane
    pts = pts[ok]
    return pts[_inside(pts, half_q, tol)]


def _hull_volume(points: np.ndarray, scale: float) -> float:
    """Volume of the convex hull of ``(N, 3)`` points; 0 for fewer than 4 points or a flat set."""
    tol = _REL_TOL * scale
    if len(points) < 4:
        return 0.0
    # De-duplicate near-identical points (they are all valid, the hull just does not need copies).
    keys = np.round(points / tol).astype(np.int64)
    _, idx = np.unique(keys, axis=0, return_index=True)
    points = points[np.sort(idx)]
    if len(points) < 4:
        return 0.0
    # Flat (or nearly flat) point sets, e.g. boxes touching along a face: zero volume.
    centred = points - points.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[-1] <= tol * np.sqrt(len(points)):
        return 0.0
    try:
        return float(ConvexHull(points).volume)
    except QhullError:
        try:  # joggled input as a last resort for badly conditioned sets
            return float(ConvexHull(points, qhull_options="QJ").volume)
        except QhullError:
            return 0.0


def _iou_validated(Ta: np.ndarray, size_a: np.ndarray, Tb: np.ndarray, size_b: np.ndarray) -> float:
    """IoU of two single, already validated boxes (``(4, 4)``, ``(3,)`` each)."""
    ha = 0.5 * size_a
    hb = 0.5 * size_b
    scale = float(max(size_a.max(), size_b.max()))
    tol = _REL_TOL * scale
    vol_a = float(np.prod(size_a))
    vol_b = float(np.prod(size_b))

    # Quick rejection: centre distance larger than the sum of the circumscribed radii.
    if np.linalg.norm(Ta[:3, 3] - Tb[:3, 3]) > np.linalg.norm(ha) + np.linalg.norm(hb) + tol:
        return 0.0

    # Work in A's frame: A is the axis-aligned box [-ha, ha].
    a_from_b = invert_transform(Ta) @ Tb
    b_from_a = invert_transform(a_from_b)
    corners_a = BOX_CORNER_SIGNS * ha  # (8, 3) in A
    corners_b = BOX_CORNER_SIGNS * hb  # (8, 3) in B
    corners_a_in_b = apply_transform(b_from_a, corners_a)
    corners_b_in_a = apply_transform(a_from_b, corners_b)

    candidates = [
        corners_a[_inside(corners_a_in_b, hb, tol)],  # corners of A inside B
        corners_b_in_a[_inside(corners_b_in_a, ha, tol)],  # corners of B inside A
        apply_transform(a_from_b, _edge_face_points(corners_a_in_b, hb, tol)),  # A's edges x B's faces
        _edge_face_points(corners_b_in_a, ha, tol),  # B's edges x A's faces
    ]
    points = np.concatenate(candidates, axis=0)
    inter = _hull_volume(points, scale)
    inter = min(inter, vol_a, vol_b)
    if inter <= 0.0:
        return 0.0
    iou = inter / (vol_a + vol_b - inter)
    return float(min(max(iou, 0.0), 1.0))


def box_iou_3d(
    cam_from_box_a: np.ndarray,
    size_a: np.ndarray,
    cam_from_box_b: np.ndarray,
    size_b: np.ndarray,
) -> float:
    """Exact intersection-over-union of two oriented 3D boxes.

    The intersection of two boxes is a convex polyhedron whose vertices are (a) corners of A inside
    B, (b) corners of B inside A, and (c) intersections of the edges of one box with the face planes
    of the other that fall within the face.  These candidates are computed in A's frame, vectorised
    over the 12 edges x 6 planes, de-duplicated (at ``1e-9`` times the largest box extent) and their
    convex hull volume (:class:`scipy.spatial.ConvexHull`) is the intersection volume.  The result
    is exact up to floating point round-off (about ``1e-12``); boxes need not be axis aligned.

    Degenerate cases: disjoint boxes, boxes that only touch (shared face, edge or corner) and any
    flat intersection give ``0.0``; identical boxes give ``1.0``; a box nested inside another gives
    ``vol_small / vol_big``.

    Args:
        cam_from_box_a: ``(4, 4)`` rigid transform, box A frame -> outer frame.  Box A's centre is
            its frame origin and its edges are parallel to its frame axes.
        size_a: ``(3,)`` full extents of box A along its own x, y, z axes, in metres (> 0).
        cam_from_box_b: ``(4, 4)`` rigid transform, box B frame -> the same outer frame.
        size_b: ``(3,)`` full extents of box B in metres (> 0).

    Returns:
        IoU in ``[0, 1]`` (dimensionless), as a Python ``float``.

    Raises:
        InputError: on wrong shapes (use :func:`box_iou_3d_batch` for batches), non-finite values,
            non-positive sizes or non-rigid transforms; the message names the argument.

    Example:
        >>> import numpy as np
        >>> T_b = np.eye(4); T_b[0, 3] = 0.5          # B shifted by half its length along x
        >>> round(box_iou_3d(np.eye(4), [1, 1, 1], T_b, [1, 1, 1]), 12)
        0.333333333333
    """
    Ta = _check_transform(cam_from_box_a, "cam_from_box_a", batch_shape=())
    sa = _check_size(size_a, "size_a", batch_shape=())
    Tb = _check_transform(cam_from_box_b, "cam_from_box_b", batch_shape=())
    sb = _check_size(size_b, "size_b", batch_shape=())
    return _iou_validated(Ta, sa, Tb, sb)


def box_iou_3d_batch(
    cam_from_box_a: np.ndarray,
    size_a: np.ndarray,
    cam_from_box_b: np.ndarray,
    size_b: np.ndarray,
) -> np.ndarray:
    """Exact 3D IoU of pairs of oriented boxes (pair ``n`` = ``(a[n], b[n])``).

    Each pair needs its own convex hull, so this is a Python loop over pairs calling the same code
    as :func:`box_iou_3d` (about 0.1-0.3 ms per overlapping pair); inputs are validated once.

    Args:
        cam_from_box_a: ``(N, 4, 4)`` rigid transforms, box A frames -> outer frame.
        size_a: ``(N, 3)`` full extents of boxes A in metres (> 0).
        cam_from_box_b: ``(N, 4, 4)`` rigid transforms, box B frames -> the same outer frame.
        size_b: ``(N, 3)`` full extents of boxes B in metres (> 0).
        (More generally any batch shape ``(...)`` is accepted, as long as all four agree after
        broadcasting the leading dimensions.)

    Returns:
        ``(N,)`` float64 IoUs in ``[0, 1]`` (shape ``(...)`` for general batch shapes).

    Raises:
        InputError: on wrong or incompatible shapes, non-finite values, non-positive sizes or
            non-rigid transforms.
    """
    Ta = _check_transform(cam_from_box_a, "cam_from_box_a")
    sa = _check_size(size_a, "size_a")
    Tb = _check_transform(cam_from_box_b, "cam_from_box_b")
    sb = _check_size(size_b, "size_b")
    try:
        batch = np.broadcast_shapes(Ta.shape[:-2], sa.shape[:-1], Tb.shape[:-2], sb.shape[:-1])
    except ValueError as exc:
        raise InputError(
            "batch shapes do not match: cam_from_box_a "
            f"{Ta.shape}, size_a {sa.shape}, cam_from_box_b {Tb.shape}, size_b {sb.shape}"
        ) from exc
    n = int(np.prod(batch, dtype=np.int64))
    Ta = np.broadcast_to(Ta, batch + (4, 4)).reshape(n, 4, 4)
    sa = np.broadcast_to(sa, batch + (3,)).reshape(n, 3)
    Tb = np.broadcast_to(Tb, batch + (4, 4)).reshape(n, 4, 4)
    sb = np.broadcast_to(sb, batch + (3,)).reshape(n, 3)
    out = np.array([_iou_validated(Ta[i], sa[i], Tb[i], sb[i]) for i in range(n)], dtype=np.float64)
    return out.reshape(batch)


def _rot_y_transform(angle_rad: float) -> np.ndarray:
    """``(4, 4)`` rotation by ``angle_rad`` (right hand) about the y axis."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    T = np.eye(4)
    T[0, 0], T[0, 2], T[2, 0], T[2, 2] = c, s, -s, c
    return T


def _volume_in_y_slab(corners: np.ndarray, half_height: float, scale: float) -> float:
    """Volume of the part of a box (its ``(8, 3)`` corners, in a frame F) with ``|y_F| <= half_height``.

    The clipped box is convex: its vertices are the corners inside the slab and the crossings of the
    box edges with the planes ``y_F = +-half_height``.
    """
    tol = _REL_TOL * scale
    y = corners[:, 1]
    points = [corners[np.abs(y) <= half_height + tol]]
    p0, p1 = corners[BOX_EDGES[:, 0]], corners[BOX_EDGES[:, 1]]
    dy = p1[:, 1] - p0[:, 1]
    crossing = np.abs(dy) > 1e-15 * scale
    for plane in (-half_height, half_height):
        t = np.divide(plane - p0[:, 1], dy, out=np.full(len(dy), -1.0), where=crossing)
        ok = (t >= 0.0) & (t <= 1.0)
        q = p0[ok] + t[ok, None] * (p1[ok] - p0[ok])
        q[:, 1] = plane
        points.append(q)
    return _hull_volume(np.concatenate(points, axis=0), scale)


def _y_turn_volume_bound(Ta: np.ndarray, size_a: np.ndarray, Tb: np.ndarray, size_b: np.ndarray) -> float:
    """An upper bound, valid for every angle, of ``vol(A & B turned about its own y axis)``.

    The smallest of: the two volumes; the volume of A inside B's y slab (B turns inside that slab,
    whatever the angle); and B's xz cross-section area times the length of B's y range that can lie in
    A's y slab (B turns inside the cylinder of radius ``|(size_x, size_z)| / 2`` about its axis, so
    only points of that cylinder whose B-height lies in a range computable from A's slab can be in A).
    The last two make the bound tight where the IoU is flat in the angle (a box whose cross-section
    fits inside the other's turns freely), which the Lipschitz search alone would have to sample densely.
    """
    scale = float(max(size_a.max(), size_b.max()))
    vol_a, vol_b = float(np.prod(size_a)), float(np.prod(size_b))
    b_from_a = invert_transform(Tb) @ Ta
    a_in_b_slab = _volume_in_y_slab(apply_transform(b_from_a, BOX_CORNER_SIGNS * (0.5 * size_a)), 0.5 * size_b[1], scale)
    # B's height t along its axis y_B for points of the cylinder that can be in A's slab |(p - c_A) . y_A| <= h_A:
    # (c_B - c_A) . y_A + t k + rho . y_A, with k = y_A . y_B and |rho . y_A| <= r sqrt(1 - k^2).
    k = float(Ta[:3, 1] @ Tb[:3, 1])
    bound = min(vol_a, vol_b, a_in_b_slab)
    if abs(k) > 1e-9:
        h_a, r = 0.5 * size_a[1], 0.5 * float(np.hypot(size_b[0], size_b[2]))
        d = float((Tb[:3, 3] - Ta[:3, 3]) @ Ta[:3, 1])
        spread = r * np.sqrt(max(0.0, 1.0 - k * k))
        lo, hi = sorted(((-h_a - d - spread) / k, (h_a - d + spread) / k))
        length = max(0.0, min(hi, 0.5 * size_b[1]) - max(lo, -0.5 * size_b[1]))
        bound = min(bound, float(size_b[0] * size_b[2]) * length)
    return bound


def box_iou_3d_symmetric_y(
    cam_from_box_a: np.ndarray,
    size_a: np.ndarray,
    cam_from_box_b: np.ndarray,
    size_b: np.ndarray,
    num_angles: int = 36,
    return_angle: bool = False,
    tol: float = 1e-3,
) -> float | tuple[float, float]:
    """Best 3D IoU over rotations of box B about its own y axis (for y-symmetric parts): the global maximum.

    For parts with a rotational symmetry about their y axis (bottle, bowl, can...) the rotation
    about y is arbitrary, so the IoU is ``max_theta IoU(theta)`` with
    ``IoU(theta) = box_iou_3d(A, cam_from_box_b @ Ry(theta), size_b)``; a box is mapped onto itself by
    a half turn about its y axis, so ``theta`` covers ``[0, pi)``.  ``IoU(theta)`` is piecewise smooth
    and often has two or four near-equal peaks (a quarter turn apart for square cross-sections), so a
    local search from the best of a coarse sweep can end on the lower one.  The search here is global:

    1. **Lipschitz bound.** Turning B by ``d theta`` moves its x and z faces; the intersection volume
       ``V`` changes by at most half the flux of the boundary velocity through B's surface,
       ``|dV/dtheta| <= size_y (size_x^2 + size_z^2) / 4`` (B's sizes; the y faces slide in their own
       planes and the total flux is 0), and ``IoU = V / (vol_a + vol_b - V)`` changes by at most
       ``(vol_a + vol_b) / (vol_a + vol_b - V_max)^2`` per unit of ``V``.  Their product ``L`` bounds
       ``|dIoU/dtheta|``.  ``V_max`` (:func:`_y_turn_volume_bound`) also caps the IoU at every angle.
    2. **Piyavskii-Shubert search.** Starting from ``num_angles`` equally spaced angles, the interval
       whose bound ``min(cap, (f1 + f2) / 2 + L (theta2 - theta1) / 2)`` is highest is split at the
       bound's peak, until no interval can hold an IoU more than ``tol`` above the best sampled one.
    3. **Refinement.** Around every remaining candidate peak (each sampled local maximum in an interval
       that could still beat the best sample) a bounded Brent search
       (:func:`scipy.optimize.minimize_scalar`) between its neighbouring samples refines the angle.

    Guarantee: no angle gives an IoU more than ``tol`` above the returned one (by the bound, whatever
    the boxes); in practice the refinement makes it the maximum to about ``1e-7`` (compared with a
    dense search in the tests).  Cost: about 60-200 exact IoUs (a few to tens of milliseconds).

    Args:
        cam_from_box_a: ``(4, 4)`` rigid transform, box A frame -> outer frame.
        size_a: ``(3,)`` full extents of box A along its own axes, in metres (> 0).
        cam_from_box_b: ``(4, 4)`` rigid transform, box B frame -> the same outer frame; B is the box
            rotated about its own y axis (the line through its centre along its frame's y axis).
        size_b: ``(3,)`` full extents of box B, in metres (> 0).
        num_angles: number of starting angles in ``[0, pi)`` (>= 1).
        return_angle: if true, also return the best angle.
        tol: the certified tolerance of the maximum (IoU units, > 0).

    Returns:
        The best IoU in ``[0, 1]`` as a Python ``float``; with ``return_angle=True`` a tuple
        ``(iou, theta_rad)`` where ``theta_rad`` in ``[0, pi)`` is the right-handed rotation about
        B's y axis that achieves it (``cam_from_box_b @ Ry(theta_rad)`` is the best-aligned B).

    Raises:
        InputError: on bad boxes (see :func:`box_iou_3d`), ``num_angles < 1`` or a ``tol`` that is not
            a positive number.
    """
    Ta = _check_transform(cam_from_box_a, "cam_from_box_a", batch_shape=())
    sa = _check_size(size_a, "size_a", batch_shape=())
    Tb = _check_transform(cam_from_box_b, "cam_from_box_b", batch_shape=())
    sb = _check_size(size_b, "size_b", batch_shape=())
    if isinstance(num_angles, bool) or not isinstance(num_angles, int | np.integer) or num_angles < 1:
        raise InputError(f"num_angles must be an integer >= 1, got {num_angles!r}")
    if isinstance(tol, bool) or not isinstance(tol, int | float | np.integer | np.floating) or not 0.0 < tol < np.inf:
        raise InputError(f"tol must be a positive number, got {tol!r}")
    best_iou, best_theta = _max_iou_about_y(Ta, sa, Tb, sb, int(num_angles), float(tol))
    best_theta = float(np.mod(best_theta, np.pi))
    if best_theta >= np.pi:  # mod can round up to pi
        best_theta = 0.0
    return (best_iou, best_theta) if return_angle else best_iou


def _max_iou_about_y(
    Ta: np.ndarray, sa: np.ndarray, Tb: np.ndarray, sb: np.ndarray, num_angles: int, tol: float
) -> tuple[float, float]:
    """The search of :func:`box_iou_3d_symmetric_y` on validated boxes: ``(best IoU, its angle)``."""
    vol_a, vol_b = float(np.prod(sa)), float(np.prod(sb))
    # B turns about an axis through its centre: its circumscribed sphere does not move.
    if np.linalg.norm(Ta[:3, 3] - Tb[:3, 3]) >= 0.5 * (np.linalg.norm(sa) + np.linalg.norm(sb)):
        return 0.0, 0.0
    v_max = _y_turn_volume_bound(Ta, sa, Tb, sb)
    cap = v_max / (vol_a + vol_b - v_max)
    lipschitz = 0.25 * sb[1] * (sb[0] ** 2 + sb[2] ** 2) * (vol_a + vol_b) / (vol_a + vol_b - v_max) ** 2

    def iou_at(theta: float) -> float:
        return _iou_validated(Ta, sa, Tb @ _rot_y_transform(theta), sb)

    def bound(x1: float, f1: float, x2: float, f2: float) -> float:
        return min(cap, 0.5 * (f1 + f2) + 0.5 * lipschitz * (x2 - x1))

    xs = list(np.arange(num_angles) * (np.pi / num_angles))
    fs = [iou_at(x) for x in xs]
    best = max(fs)
    heap = []  # intervals [x1, x2] between neighbouring samples (the last one wraps round to pi), by bound
    for i in range(num_angles):
        x2, f2 = (xs[i + 1], fs[i + 1]) if i + 1 < num_angles else (np.pi, fs[0])
        heapq.heappush(heap, (-bound(xs[i], fs[i], x2, f2), xs[i], fs[i], x2, f2))
    while -heap[0][0] > best + tol:
        _, x1, f1, x2, f2 = heapq.heappop(heap)
        xm = min(max(0.5 * (x1 + x2) + (f2 - f1) / (2.0 * lipschitz), x1), x2)  # the peak of the bound
        fm = iou_at(xm)
        xs.append(xm)
        fs.append(fm)
        best = max(best, fm)
        heapq.heappush(heap, (-bound(x1, f1, xm, fm), x1, f1, xm, fm))
        heapq.heappush(heap, (-bound(xm, fm, x2, f2), xm, fm, x2, f2))

    order = np.argsort(xs, kind="stable")
    x, f = np.asarray(xs)[order], np.asarray(fs)[order]
    k = int(np.argmax(f))
    best_iou, best_theta = float(f[k]), float(x[k])
    if best_iou <= 0.0:
        return 0.0, 0.0
    # Refine every candidate peak: a sampled local maximum next to an interval that may beat the best sample.
    x_prev, f_prev = np.roll(x, 1), np.roll(f, 1)
    x_prev[0] -= np.pi
    x_next, f_next = np.roll(x, -1), np.roll(f, -1)
    x_next[-1] += np.pi
    may_beat = (
        np.maximum(
            np.minimum(cap, 0.5 * (f_prev + f) + 0.5 * lipschitz * (x - x_prev)),
            np.minimum(cap, 0.5 * (f + f_next) + 0.5 * lipschitz * (x_next - x)),
        )
        > best_iou
    )
    peak = (f > f_prev + 1e-9) & (f > f_next + 1e-9)
    peak[k] = True  # the best sample, even on a plateau
    for i in np.nonzero(may_beat & peak & (f > 0.0))[0]:
        # Brent on the offset from the sample: its tolerance is partly relative to |x|, so a small
        # variable gives a tighter absolute angle tolerance.
        res = minimize_scalar(
            lambda dt, x0=x[i]: -iou_at(x0 + dt),
            bounds=(x_prev[i] - x[i], x_next[i] - x[i]),
            method="bounded",
            options={"xatol": 1e-10},
        )
        if res.success and -res.fun > best_iou:
            best_iou, best_theta = float(-res.fun), float(x[i] + res.x)
    return best_iou, best_theta


SEEN_PATTERNS = 9
"""How many face patterns :func:`seen_pattern` tells apart per box axis."""

_OTHER_AXES = np.array([[1, 2], [0, 2], [0, 1]])


def seen_pattern(cam_from_box, size_m) -> np.ndarray:
    """Which faces across each axis of each box the camera faces.

    The camera sits at the origin of the outer frame. Along a box axis ``b`` it faces the + face when it lies
    beyond it (box-frame coordinate ``> size_b / 2``), the - face when below ``-size_b / 2``, neither when
    within the slab: code 1, 2 or 0 (perspective, not the viewing direction alone: a tall cabinet's top is not
    faced from a camera below it). An axis ``a``'s extent shows on the faces across it, normal to the two other
    axes ``b < c``; its pattern is ``3 * code_b + code_c``.

    Args:
        cam_from_box: ``(K, 4, 4)`` rigid transforms.
        size_m: ``(K, 3)`` full extents (metres, > 0).

    Returns:
        ``(K, 3)`` int64 in ``[0, SEEN_PATTERNS)``.

    Raises:
        InputError: malformed shapes or values.
    """
    T = _check_transform(cam_from_box, "cam_from_box")
    if T.ndim != 3:
        raise InputError(f"cam_from_box must have shape (K, 4, 4), got {T.shape}")
    S = _check_size(size_m, "size_m", batch_shape=T.shape[:1])
    cam = -np.einsum("kji,kj->ki", T[:, :3, :3], T[:, :3, 3])  # the camera in each box's frame
    half = 0.5 * S
    code = np.where(cam > half, 1, np.where(cam < -half, 2, 0))
    return (3 * code[:, _OTHER_AXES[:, 0]] + code[:, _OTHER_AXES[:, 1]]).astype(np.int64)


def _faced_points(cam: np.ndarray, half: np.ndarray) -> np.ndarray:
    """``(N, 3)`` sample points (box frame) on the faces of a box of half extents ``half`` that a camera at
    ``cam`` (box frame) faces: per face a 3 x 3 grid at -0.95, 0 and 0.95 of the half extents."""
    g = np.array([-0.95, 0.0, 0.95])
    uv = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    out = []
    for a in range(3):  # three axes
        side = np.sign(cam[a]) if abs(cam[a]) > half[a] else 0.0
        if side:
            q = np.zeros((len(uv), 3))
            q[:, a] = side * half[a]
            q[:, _OTHER_AXES[a]] = uv * half[_OTHER_AXES[a]]
            out.append(q)
    return np.concatenate(out) if out else np.zeros((0, 3))


def occluded_fraction(cam_from_box, size_m) -> np.ndarray:
    """Per box, the fraction of its faced sample points that another box hides from the camera.

    The camera sits at the origin of the outer frame. A box's sample points are a 3 x 3 grid (centre, edge
    midpoints, corners pulled 5 % in) on every face it turns to the camera (:func:`seen_pattern`); a point is
    hidden when the segment from the camera to it crosses another box (slab test). A part's points need not
    span its box where a neighbour hides it (a closed door seen from behind its cabinet).

    Args:
        cam_from_box: ``(K, 4, 4)`` rigid transforms.
        size_m: ``(K, 3)`` full extents (metres, > 0).

    Returns:
        ``(K,)`` float64 in ``[0, 1]``; 0 for a single box and for a box with no faced face (camera inside).

    Raises:
        InputError: malformed shapes or values.
    """
    T = _check_transform(cam_from_box, "cam_from_box")
    if T.ndim != 3:
        raise InputError(f"cam_from_box must have shape (K, 4, 4), got {T.shape}")
    K = len(T)
    half = 0.5 * _check_size(size_m, "size_m", batch_shape=(K,))
    out = np.zeros(K)
    if K < 2:
        return out
    R, t = T[:, :3, :3], T[:, :3, 3]
    cam = -np.einsum("kji,kj->ki", R, t)
    for k in range(K):  # a handful of boxes; the segment tests are vectorised over points and boxes
        local = _faced_points(cam[k], half[k])
        if not len(local):
            continue
        world = local @ R[k].T + t[k]  # (N, 3) in the outer frame
        others = np.array([j for j in range(K) if j != k])
        o = cam[others][:, None, :]  # (J, 1, 3): the segment 0 -> world in box j's frame is o + s * d, s in [0, 1]
        d = np.einsum("nc,jca->jna", world, R[others])  # (J, N, 3)
        h = half[others][:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            s1, s2 = (-h - o) / d, (h - o) / d
        inside = np.abs(o) <= h
        lo = np.where(d == 0, np.where(inside, -np.inf, np.inf), np.minimum(s1, s2)).max(-1)
        hi = np.where(d == 0, np.where(inside, np.inf, -np.inf), np.maximum(s1, s2)).min(-1)
        hidden = ((lo < hi) & (hi > 0.0) & (lo < 0.999)).any(0)
        out[k] = float(hidden.mean())
    return out
