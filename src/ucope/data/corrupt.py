"""Seeded corruptions of a partial point cloud: the robustness benchmark's and the training augmentation's.

Every corruption is a plain, vectorised numpy function of the same shape::

    new_points, new_labels = kind(points, labels, level, rng, context=None)

* ``points``: ``(N, 3)`` float, the cloud in the **camera frame** (OpenCV axes: +x right, +y down,
  +z forward; the camera centre is the origin), **metres**. The output keeps a floating input's dtype.
* ``labels``: ``(N,)`` int carried along with the points (normally the part index of each point; any
  non-negative integers work, e.g. ``np.arange(N)`` to track where every output point came from).
  Points a corruption **adds** get the label ``-1`` ("not the object"). Fractions of "the object's
  point count" count the points with ``labels >= 0``.
* ``rng``: an explicit :class:`numpy.random.Generator`, the only source of randomness: the same
  generator state gives the same output.
* ``context``: a :class:`CorruptionContext` holding what some corruptions need besides the cloud (the
  ground-truth part boxes, the background pixels around the object, the depth sensor model).

Inputs are never modified; the outputs are new arrays. Added points are appended after the input
points; points a corruption keeps stay in their input order (only :func:`shuffle` reorders).

:func:`corrupt` applies a spec string (``"noise=0.005"``, ``"outliers=0.1,shuffle=1"``) and
:data:`KINDS` lists every kind with its benchmark levels. docs/robustness.md describes each kind and the
benchmark that uses them (benchmarks/bench_robustness.py).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..render.camera import PinholeCamera
from ..render.noise import DepthNoise
from ..render.raycast import BACKGROUND_LABEL, CLUTTER_LABEL

__all__ = [  # noqa: RUF022 - grouped: the types, the corruptions, the helpers
    "BackgroundPool",
    "CorruptionContext",
    "CorruptionKind",
    "KINDS",
    "isotropic_noise",
    "axial_noise",
    "add_outliers",
    "add_floor",
    "mask_bleed",
    "occlude",
    "resample",
    "shuffle",
    "corrupt",
    "parse_spec",
    "object_box",
    "occluder_normal",
    "background_pool",
]

OCCLUDER_MAX_TILT_DEG = 20.0
"""The occluding plane's normal leans at most this far out of the image plane (see :func:`occluder_normal`)."""


# --------------------------------------------------------------------------------------------------
# What some corruptions need besides the cloud
# --------------------------------------------------------------------------------------------------


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class BackgroundPool:
    """Candidate background points around an object, nearest to its silhouette first.

    Attributes:
        points: ``(M, 3)`` camera frame, metres: one point per background pixel (floor or distractor
            object) with a depth return. Stored sorted by ``rank`` (stable), as float64.
        rank: ``(M,)`` how far each point lies from the object: the pixel distance from its pixel to the
            nearest object pixel (:func:`background_pool`), ascending after construction.
        clutter: ``(M,)`` bool: ``True`` for a pixel of a distractor object, ``False`` for the floor.
        pixels_per_point: object pixels per point of the object's cloud (``>= 1``; 1 when the cloud holds
            every object pixel). :func:`add_floor` and :func:`mask_bleed` thin the background the same
            way, so that the added points have the object's density.
    """

    points: np.ndarray
    rank: np.ndarray
    clutter: np.ndarray
    pixels_per_point: float = 1.0

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise InputError(f"BackgroundPool.points must have shape (M, 3), got {pts.shape}")
        rank = np.asarray(self.rank, np.float64)
        clutter = np.asarray(self.clutter)
        if rank.shape != (len(pts),) or clutter.shape != (len(pts),):
            raise InputError(
                f"BackgroundPool.rank and .clutter must have shape ({len(pts)},), got {rank.shape} and {clutter.shape}"
            )
        if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(rank))):
            raise InputError("BackgroundPool.points and .rank must be finite")
        ppp = float(self.pixels_per_point)
        if not math.isfinite(ppp) or ppp < 1.0:
            raise InputError(f"BackgroundPool.pixels_per_point must be >= 1, got {self.pixels_per_point!r}")
        order = np.argsort(rank, kind="stable")
        object.__setattr__(self, "points", _readonly(pts[order]))
        object.__setattr__(self, "rank", _readonly(rank[order]))
        object.__setattr__(self, "clutter", _readonly(clutter[order].astype(bool)))
        object.__setattr__(self, "pixels_per_point", ppp)

    def select(self, clutter: bool | None = None) -> BackgroundPool:
        """The floor points only (``clutter=False``), the distractor points only (``True``), or all (``None``).

        The subsets are made once and kept (the pool is immutable)."""
        if clutter is None:
            return self
        cache = self.__dict__.setdefault("_subsets", {})
        if bool(clutter) not in cache:
            keep = self.clutter == bool(clutter)
            cache[bool(clutter)] = BackgroundPool(self.points[keep], self.rank[keep], self.clutter[keep], self.pixels_per_point)
        return cache[bool(clutter)]


@dataclass(frozen=True, eq=False)
class CorruptionContext:
    """What some corruptions need besides the cloud; every field is optional.

    Attributes:
        cam_from_part: ``(K, 4, 4)`` ground-truth part poses (part frame -> camera frame).
        size_m: ``(K, 3)`` ground-truth amodal box extents of the parts, metres. With ``cam_from_part``
            they give the object's box (:func:`object_box`) that :func:`add_outliers` fills.
        background: the background around the object (:func:`background_pool`), for :func:`add_floor`
            and :func:`mask_bleed`.
        depth_noise: the sensor model whose ``sigma(z)`` :func:`axial_noise` scales.
    """

    cam_from_part: np.ndarray | None = None
    size_m: np.ndarray | None = None
    background: BackgroundPool | None = None
    depth_noise: DepthNoise = field(default_factory=DepthNoise)

    def __post_init__(self) -> None:
        if (self.cam_from_part is None) != (self.size_m is None):
            raise InputError("CorruptionContext needs both cam_from_part and size_m, or neither")
        if self.cam_from_part is not None:
            T = np.asarray(self.cam_from_part, np.float64)
            s = np.asarray(self.size_m, np.float64)
            if T.ndim != 3 or T.shape[1:] != (4, 4) or len(T) == 0:
                raise InputError(f"CorruptionContext.cam_from_part must have shape (K, 4, 4), got {T.shape}")
            if s.shape != (len(T), 3):
                raise InputError(f"CorruptionContext.size_m must have shape ({len(T)}, 3), got {s.shape}")
            if not (np.all(np.isfinite(T)) and np.all(np.isfinite(s))) or np.any(s <= 0):
                raise InputError("CorruptionContext.cam_from_part must be finite and size_m finite and positive")
            object.__setattr__(self, "cam_from_part", _readonly(T.copy()))
            object.__setattr__(self, "size_m", _readonly(s.copy()))
        if self.background is not None and not isinstance(self.background, BackgroundPool):
            raise InputError(f"CorruptionContext.background must be a BackgroundPool, got {type(self.background).__name__}")
        if not isinstance(self.depth_noise, DepthNoise):
            raise InputError(f"CorruptionContext.depth_noise must be a DepthNoise, got {type(self.depth_noise).__name__}")


# --------------------------------------------------------------------------------------------------
# Checks and helpers
# --------------------------------------------------------------------------------------------------


def _check(points, labels, rng) -> tuple[np.ndarray, np.ndarray, np.dtype]:
    """``(points as float64 (N, 3), labels as int64 (N,), output dtype)``; the inputs are not copied."""
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] != 3 or not np.issubdtype(p.dtype, np.number):
        raise InputError(f"points must be a numeric (N, 3) array, got shape {p.shape} and dtype {p.dtype}")
    if len(p) == 0:
        raise InputError("points is empty: there is nothing to corrupt")
    dtype = p.dtype if np.issubdtype(p.dtype, np.floating) else np.dtype(np.float64)
    p = p.astype(np.float64, copy=False)
    if not np.all(np.isfinite(p)):
        raise InputError("points contains non-finite values (NaN or inf)")
    lab = np.asarray(labels)
    if lab.shape != (len(p),) or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be an integer array of shape ({len(p)},), got shape {lab.shape} and dtype {lab.dtype}")
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {type(rng).__name__}")
    return p, lab.astype(np.int64, copy=False), dtype


def _level(x, name: str, lo: float = 0.0, hi: float = math.inf, lo_open: bool = False) -> float:
    if isinstance(x, bool | np.bool_):
        raise InputError(f"{name} must be a number, got {x!r}")
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {x!r}") from None
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo):
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise InputError(f"{name} must lie in {interval}, got {x!r}")
    return v


def _context(context) -> CorruptionContext:
    if context is None:
        return CorruptionContext()
    if not isinstance(context, CorruptionContext):
        raise InputError(f"context must be a CorruptionContext or None, got {type(context).__name__}")
    return context


def _count(fraction: float, labels: np.ndarray) -> int:
    """``round(fraction * number of object points)`` (object points: ``labels >= 0``)."""
    return round(float(fraction) * int(np.count_nonzero(labels >= 0)))


def _out(points: np.ndarray, labels: np.ndarray, dtype) -> tuple[np.ndarray, np.ndarray]:
    """New arrays (always copies): points in ``dtype``, labels int64."""
    return points.astype(dtype), labels.astype(np.int64)


def _append(p, lab, added, dtype) -> tuple[np.ndarray, np.ndarray]:
    pts = np.concatenate([p, np.asarray(added, np.float64).reshape(-1, 3)]).astype(dtype, copy=False)
    return pts, np.concatenate([lab, np.full(len(pts) - len(p), -1, np.int64)])


def object_box(cam_from_part: np.ndarray, size_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The object's box: the smallest box aligned with the root part's frame that holds every part's box.

    Args:
        cam_from_part: ``(K, 4, 4)`` part poses; part 0 is the root (its frame is the object frame).
        size_m: ``(K, 3)`` amodal box extents of the parts, metres.

    Returns:
        ``(cam_from_box (4, 4), centre_in_root (3,), size (3,))``: the box's frame (the root part's axes,
        origin at the box centre) in the camera frame, its centre in the root part's frame, and its
        extents along the root part's x, y, z in metres.
    """
    T = np.asarray(cam_from_part, np.float64)
    s = np.asarray(size_m, np.float64)
    signs = np.array([[(i >> 2) & 1, (i >> 1) & 1, i & 1] for i in range(8)], np.float64) * 2.0 - 1.0  # (8, 3)
    corners_part = 0.5 * signs[None] * s[:, None, :]  # (K, 8, 3)
    root_from_part = np.linalg.inv(T[0])[None] @ T  # (K, 4, 4)
    c = np.einsum("kij,knj->kni", root_from_part[:, :3, :3], corners_part) + root_from_part[:, None, :3, 3]
    lo, hi = c.reshape(-1, 3).min(0), c.reshape(-1, 3).max(0)
    centre = 0.5 * (lo + hi)
    cam_from_box = T[0].copy()
    cam_from_box[:3, 3] = T[0, :3, :3] @ centre + T[0, :3, 3]
    return cam_from_box, centre, hi - lo


def occluder_normal(view_dir: np.ndarray, rng: np.random.Generator, max_tilt_deg: float = OCCLUDER_MAX_TILT_DEG) -> np.ndarray:
    """A random unit normal roughly perpendicular to a viewing direction (the occluder of :func:`occlude`).

    ``n = cos(t) (cos(phi) e1 + sin(phi) e2) + sin(t) d`` with ``d`` the unit ``view_dir``, ``e1, e2`` a fixed
    orthonormal basis of the plane perpendicular to ``d``, ``phi ~ U(0, 2 pi)`` (the side the occluder
    comes from, in the image) and ``t ~ U(-max_tilt_deg, max_tilt_deg)`` (its lean out of the image plane).
    Draws ``phi`` then ``t`` from ``rng``. Returns ``(3,)``.
    """
    d = np.asarray(view_dir, np.float64)
    d = d / np.linalg.norm(d)
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(d, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    t = np.radians(rng.uniform(-max_tilt_deg, max_tilt_deg))
    return np.cos(t) * (np.cos(phi) * e1 + np.sin(phi) * e2) + np.sin(t) * d


def _nearest(pool: BackgroundPool, n_add: int, rng: np.random.Generator) -> np.ndarray:
    """Indices (ascending) of ``n_add`` pool points: a random ``n_add`` of the ``n_add * pixels_per_point``
    pool points nearest the object (ties of rank at the band's edge broken at random)."""
    M = len(pool.rank)
    if n_add <= 0 or M == 0:
        return np.zeros(0, np.int64)
    n_band = min(M, max(n_add, round(n_add * float(pool.pixels_per_point))))
    edge = pool.rank[n_band - 1]
    lo = int(np.searchsorted(pool.rank, edge, side="left"))
    hi = int(np.searchsorted(pool.rank, edge, side="right"))
    band = np.concatenate([np.arange(lo), lo + rng.choice(hi - lo, size=n_band - lo, replace=False)])
    take = band[rng.choice(n_band, size=min(n_add, n_band), replace=False)]
    return np.sort(take)


# --------------------------------------------------------------------------------------------------
# The corruptions
# --------------------------------------------------------------------------------------------------


def isotropic_noise(points, labels, sigma_m: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian noise on every coordinate: ``p' = p + e``, ``e ~ N(0, sigma_m^2 I_3)`` per point.

    Args:
        points: ``(N, 3)`` camera frame, metres. labels: ``(N,)`` int (unchanged).
        sigma_m: the standard deviation per axis, metres (>= 0).
        rng: draws one ``(N, 3)`` standard normal array.

    Returns:
        ``(points' (N, 3), labels (N,))``.
    """
    p, lab, dtype = _check(points, labels, rng)
    sigma = _level(sigma_m, "sigma_m")
    return _out(p + sigma * rng.standard_normal(p.shape), lab, dtype)


def axial_noise(points, labels, factor: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Depth noise along each point's viewing ray: the sensor model's axial noise, ``factor`` times.

    The depth ``z`` (camera z, metres) of each point becomes ``z' = z + factor * sigma(z) * g``,
    ``g ~ N(0, 1)``, with ``sigma(z) = sigma_0_m + sigma_2 (z - 0.4)^2`` of the context's
    :class:`~ucope.render.noise.DepthNoise` (default: 1.2 mm + 1.9 mm/m^2 (z - 0.4 m)^2); the point moves
    along its ray through the camera centre: ``p' = p z' / z`` (its pixel is unchanged). ``z' / z`` is
    clipped at 0.001 so that no point crosses the camera.

    Args:
        points: ``(N, 3)`` camera frame, metres, every ``z > 0``. labels: ``(N,)`` int (unchanged).
        factor: the multiple of the sensor's sigma (>= 0).
        rng: draws one ``(N,)`` standard normal array.
        context: its ``depth_noise`` gives ``sigma_0_m`` and ``sigma_2`` (other fields are not used).
    """
    p, lab, dtype = _check(points, labels, rng)
    k = _level(factor, "factor")
    dn = _context(context).depth_noise
    z = p[:, 2]
    if np.any(z <= 0):
        raise InputError("axial noise needs every point in front of the camera (z > 0); is the cloud in the camera frame?")
    sigma = dn.sigma_0_m + dn.sigma_2 * (z - 0.4) ** 2
    scale = np.maximum(1.0 + k * sigma * rng.standard_normal(len(z)) / z, 1e-3)
    return _out(p * scale[:, None], lab, dtype)


def add_outliers(points, labels, fraction: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Add ``round(fraction * n_obj)`` points uniform in the object's box scaled 1.5x about its centre.

    ``n_obj`` is the number of object points (``labels >= 0``). The box is :func:`object_box` of the
    context's ground-truth parts (aligned with the root part's frame); without them, the axis-aligned
    (camera axes) bounding box of the object points. A point is ``centre + R (u * 1.5 * size / 2)``,
    ``u ~ U(-1, 1)^3``.

    Args:
        points: ``(N, 3)`` camera frame, metres. labels: ``(N,)`` int.
        fraction: added points per object point (>= 0); 0.1 adds 10 % of the object's count.
        rng: draws one ``(n_add, 3)`` uniform array.

    Returns:
        ``(N + n_add, 3)`` points (the input's first) and their labels (``-1`` for the added ones).
    """
    p, lab, dtype = _check(points, labels, rng)
    f = _level(fraction, "fraction")
    ctx = _context(context)
    n_add = _count(f, lab)
    if ctx.cam_from_part is not None:
        cam_from_box, _, size = object_box(ctx.cam_from_part, ctx.size_m)
    else:
        obj = p[lab >= 0] if np.any(lab >= 0) else p
        cam_from_box = np.eye(4)
        lo, hi = obj.min(0), obj.max(0)
        cam_from_box[:3, 3] = 0.5 * (lo + hi)
        size = hi - lo
    u = rng.uniform(-1.0, 1.0, (n_add, 3)) * (0.75 * size)
    return _append(p, lab, u @ cam_from_box[:3, :3].T + cam_from_box[:3, 3], dtype)


def _from_pool(p, lab, dtype, fraction, rng, context, clutter, what: str):
    f = _level(fraction, "fraction")
    ctx = _context(context)
    if ctx.background is None:
        raise InputError(
            f"{what} needs context.background, the background pixels around the object "
            "(ucope.data.corrupt.background_pool(view, camera))"
        )
    pool = ctx.background.select(clutter)
    return _append(p, lab, pool.points[_nearest(pool, _count(f, lab), rng)], dtype)


def add_floor(points, labels, fraction: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Add floor points next to the object, ``round(fraction * n_obj)`` of them (``n_obj``: ``labels >= 0``).

    From the context's background pool, floor pixels only (not distractors): the
    ``n_add * pixels_per_point`` floor points nearest the object's silhouette (a band around it covering
    ``fraction`` of the object's area in the image; ties at its edge broken at random), thinned at random
    to ``n_add`` so that they have the object's point density. If the pool holds fewer floor points, all
    of them are added.

    Args:
        points: ``(N, 3)`` camera frame, metres. labels: ``(N,)`` int.
        fraction: floor points per object point (>= 0).
        rng: breaks the ties and draws the thinning.
        context: needs ``background`` (:func:`background_pool`).

    Returns:
        the input points followed by the added ones, labels ``-1`` for the added ones.
    """
    p, lab, dtype = _check(points, labels, rng)
    return _from_pool(p, lab, dtype, fraction, rng, context, False, "add_floor")


def mask_bleed(points, labels, fraction: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """A segmentation mask that bleeds over the silhouette: add ``round(fraction * n_obj)`` background points.

    As :func:`add_floor`, but from every background pixel with a depth return, floor **and** distractor
    objects: the points of the pixels just outside the object's silhouette, nearest first (a band
    covering ``fraction`` of the object's image area, thinned to the object's point density).

    Args:
        points: ``(N, 3)`` camera frame, metres. labels: ``(N,)`` int.
        fraction: added points per object point (>= 0).
        rng: breaks the ties and draws the thinning.
        context: needs ``background`` (:func:`background_pool`).
    """
    p, lab, dtype = _check(points, labels, rng)
    return _from_pool(p, lab, dtype, fraction, rng, context, None, "mask_bleed")


def occlude(points, labels, keep: float, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Cut the cloud with a random plane (an occluder entering from one side), keeping ``keep`` of its points.

    The plane's normal ``n`` is :func:`occluder_normal` of the viewing direction to the cloud's centroid
    (camera at the origin): nearly perpendicular to it, from a random side. With ``s_i = p_i . n``, the
    ``round(keep * N)`` points (at least 1) of smallest ``s`` are kept (the plane sits between the kept and
    the removed ones), in their input order. Every point counts, added ones included.

    Args:
        points: ``(N, 3)`` camera frame, metres. labels: ``(N,)`` int.
        keep: the fraction of points kept, in ``(0, 1]`` (1 changes nothing).
        rng: draws the normal (``phi``, then the tilt).
    """
    p, lab, dtype = _check(points, labels, rng)
    k = _level(keep, "keep", 0.0, 1.0, lo_open=True)
    c = p.mean(0)
    n = occluder_normal(c if np.linalg.norm(c) > 1e-9 else np.array([0.0, 0.0, 1.0]), rng)
    m = max(1, round(k * len(p)))
    if m >= len(p):
        return _out(p, lab, dtype)
    idx = np.sort(np.argpartition(p @ n, m - 1)[:m])
    return _out(p[idx], lab[idx], dtype)


def resample(points, labels, num: int, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """Resample the cloud to exactly ``num`` points, in input order.

    ``num <= N``: a uniform random subset without replacement. ``num > N``: every point once plus
    ``num - N`` repeats drawn uniformly with replacement (no point is lost). The chosen rows are sorted, so
    the output keeps the input's order.

    Args:
        points: ``(N, 3)``. labels: ``(N,)`` int.
        num: the number of output points (a positive integer).
    """
    p, lab, dtype = _check(points, labels, rng)
    v = _level(num, "num", 1.0)
    if v != int(v):
        raise InputError(f"num must be a positive integer, got {num!r}")
    m, n = int(v), len(p)
    if m <= n:
        idx = rng.choice(n, size=m, replace=False)
    else:
        idx = np.concatenate([np.arange(n), rng.integers(0, n, size=m - n)])
    idx = np.sort(idx)
    return _out(p[idx], lab[idx], dtype)


def shuffle(points, labels, on: int, rng: np.random.Generator, context=None) -> tuple[np.ndarray, np.ndarray]:
    """A random permutation of the points (and their labels): ``on=1`` shuffles, ``on=0`` changes nothing.

    Args:
        points: ``(N, 3)``. labels: ``(N,)`` int.
        on: 0 or 1.
        rng: draws one permutation of ``N``.
    """
    p, lab, dtype = _check(points, labels, rng)
    v = _level(on, "on", 0.0, 1.0)
    if v not in (0.0, 1.0):
        raise InputError(f"shuffle takes 0 or 1, got {on!r}")
    if v == 0.0:
        return _out(p, lab, dtype)
    perm = rng.permutation(len(p))
    return _out(p[perm], lab[perm], dtype)


# --------------------------------------------------------------------------------------------------
# Registry and dispatcher
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CorruptionKind:
    """One kind of corruption: its spec name, function, benchmark levels and what they mean.

    ``levels[0]`` is the uncorrupted reference (``identity``) except for ``points``, whose first level
    (4096, the clouds' maximum size) resamples clouds smaller than that.
    """

    name: str
    function: Callable
    levels: tuple
    identity: float | None
    unit: str
    description: str
    integer: bool = False


KINDS: dict[str, CorruptionKind] = {
    k.name: k
    for k in (
        CorruptionKind(
            "noise", isotropic_noise, (0.0, 0.002, 0.005, 0.01), 0.0, "m", "isotropic Gaussian noise, sigma per axis in metres"
        ),
        CorruptionKind(
            "axial",
            axial_noise,
            (0.0, 1.0, 3.0, 5.0),
            0.0,
            "x sigma(z)",
            "depth noise along the viewing rays, a multiple of the sensor model's sigma(z)",
        ),
        CorruptionKind(
            "outliers",
            add_outliers,
            (0.0, 0.05, 0.10, 0.20),
            0.0,
            "x object points",
            "points added uniformly in the object's box scaled 1.5x",
        ),
        CorruptionKind(
            "floor", add_floor, (0.0, 0.25, 0.50, 1.00), 0.0, "x object points", "floor points nearest the silhouette added"
        ),
        CorruptionKind(
            "bleed",
            mask_bleed,
            (0.0, 0.10, 0.25),
            0.0,
            "x object points",
            "floor and distractor points just outside the silhouette added",
        ),
        CorruptionKind(
            "occlude", occlude, (1.0, 0.8, 0.6, 0.4), 1.0, "fraction kept", "a random plane cuts away one side of the cloud"
        ),
        CorruptionKind(
            "points", resample, (4096, 1000, 500, 200, 100), None, "points", "resampled to this many points", integer=True
        ),
        CorruptionKind("shuffle", shuffle, (0, 1), 0.0, "on/off", "the points in a random order", integer=True),
    )
}
"""Every corruption kind by spec name, in the benchmark's order."""

_SPEC = re.compile(r"^\s*([A-Za-z_]+)\s*=\s*([^=,\s]+)\s*$")


def parse_spec(spec: str) -> list[tuple[str, float]]:
    """``"noise=0.005"`` or ``"outliers=0.1,shuffle=1"`` -> ``[(kind, level), ...]``, levels checked.

    Raises:
        InputError: naming the bad part (not ``kind=level``, an unknown kind, a level that is not a
            number or is out of the kind's range).
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(f"a corruption spec is a string like 'noise=0.005', got {spec!r}")
    out = []
    for part in spec.split(","):
        m = _SPEC.match(part)
        if m is None:
            raise InputError(
                f"corruption spec {part.strip()!r} is not of the form KIND=LEVEL (e.g. 'noise=0.005'); "
                f"kinds: {', '.join(KINDS)}"
            )
        name, raw = m.group(1), m.group(2)
        if name not in KINDS:
            raise InputError(f"unknown corruption kind {name!r} in {spec!r}; kinds: {', '.join(KINDS)}")
        try:
            level = float(raw)
        except ValueError:
            raise InputError(f"the level of {name!r} must be a number, got {raw!r}") from None
        kind = KINDS[name]
        if kind.integer:
            if not level.is_integer():
                raise InputError(f"the level of {name!r} must be an integer, got {raw!r}")
            level = int(level)
        _check_level(kind, level)
        out.append((name, level))
    return out


def _check_level(kind: CorruptionKind, level) -> None:
    if kind.name == "occlude":
        _level(level, "the level of 'occlude' (fraction kept)", 0.0, 1.0, lo_open=True)
    elif kind.name == "points":
        _level(level, "the level of 'points'", 1.0)
    elif kind.name == "shuffle":
        if level not in (0, 1):
            raise InputError(f"the level of 'shuffle' must be 0 or 1, got {level!r}")
    else:
        _level(level, f"the level of {kind.name!r}")


def corrupt(
    points, labels, spec: str, rng: np.random.Generator, context: CorruptionContext | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Apply the corruption(s) of ``spec`` (``"KIND=LEVEL"``, several joined by commas, applied in order).

    Kinds (:data:`KINDS`): ``noise`` (sigma, m), ``axial`` (x sensor sigma), ``outliers``, ``floor``,
    ``bleed`` (fractions of the object's point count), ``occlude`` (fraction kept), ``points`` (count),
    ``shuffle`` (0 / 1). Arguments and results as the kinds' functions; all draws come from ``rng``.

    Raises:
        InputError: a bad spec (see :func:`parse_spec`), bad points / labels / rng, or a kind whose
            context is missing.
    """
    for name, level in parse_spec(spec):
        points, labels = KINDS[name].function(points, labels, level, rng, context)
    return points, labels


# --------------------------------------------------------------------------------------------------
# The background around an object in a rendered view
# --------------------------------------------------------------------------------------------------


def background_pool(view, camera: PinholeCamera, cloud_points: int | None = None) -> BackgroundPool:
    """The background points around the object of a :class:`~ucope.render.views.RenderedView`.

    Every pixel that is not the object (``mask`` = :data:`~ucope.render.raycast.BACKGROUND_LABEL`, the
    floor, or :data:`~ucope.render.raycast.CLUTTER_LABEL`, a distractor) and has a depth return is
    back-projected (``depth_mm / 1000``, camera frame, metres). Its rank is the Euclidean pixel distance
    from its pixel centre to the nearest object pixel's (``scipy.ndimage.distance_transform_edt``: 1 for a
    pixel next to the silhouette).

    Args:
        view: has ``depth_mm (H, W)`` uint16, ``mask (H, W)`` (part index ``0..K-1`` on the object) and
            ``cam_from_part (K, 4, 4)`` (gives K).
        camera: the view's intrinsics.
        cloud_points: how many points the object's cloud holds (e.g. 4096 after the data set's
            subsampling); gives ``pixels_per_point`` = object pixels with a depth return / ``cloud_points``
            (at least 1). ``None``: 1.

    Raises:
        InputError: if the view shows no object pixel.
    """
    from scipy.ndimage import distance_transform_edt

    depth = np.asarray(view.depth_mm)
    mask = np.asarray(view.mask)
    K = len(view.cam_from_part)
    if depth.shape != (camera.height, camera.width) or mask.shape != depth.shape:
        raise InputError(
            f"depth {depth.shape} and mask {mask.shape} must have the camera's shape {(camera.height, camera.width)}"
        )
    on_object = mask < K
    if not np.any(on_object):
        raise InputError("the view shows no object pixel: there is no silhouette to rank the background by")
    rank_img = distance_transform_edt(~on_object)
    bg = (mask == BACKGROUND_LABEL) | (mask == CLUTTER_LABEL)
    pts, pix = camera.backproject(depth.astype(np.float64) / 1000.0, bg)
    r, c = pix[:, 0], pix[:, 1]
    ppp = 1.0
    if cloud_points is not None:
        n_obj = int(np.count_nonzero(on_object & (depth > 0)))
        ppp = max(1.0, n_obj / max(1, int(cloud_points)))
    return BackgroundPool(pts.astype(np.float64), rank_img[r, c], mask[r, c] == CLUTTER_LABEL, ppp)
