"""Turning what users hold into the estimator's input: a checked, cleaned cloud in a canonical order.

* :func:`prepare_points`: validate a cloud (``(N, 3)`` or organised ``(H, W, 3)``, numpy / torch /
  nested sequences, optional normals), convert its units, drop rows without a measurement, check that it
  looks like one object in the camera frame, put it in a canonical order and subsample it;
* :func:`rgbd_points`: back-project a depth image (with a mask and / or a box) into the object's cloud
  (:func:`parse_intrinsics` reads the camera in the forms users hold it);
* :func:`roll_to_up`: the turn about the optical axis that brings a known up direction to image up;
* :func:`label_points`: carry the labels of the network's points over to every input point.

Frames and units: camera frame (OpenCV axes: x right, y down, z forward), metres after conversion.

**Order independence.** The points that go on are chosen and ordered by their own values, never by
their position in the input: a cloud of at most ``max_points`` points is sorted lexicographically; a
larger one keeps the ``max_points`` points whose seeded hash of their coordinates is smallest (a uniform
random subset whose choice does not depend on the order), then sorted. So the same cloud in any order
gives the same result.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import InputError
from ..geometry.normals import estimate_normals
from ..vocab import MIN_POINTS

__all__ = [
    "roll_to_up",
    "MIN_POINTS",
    "MAX_COORDINATE_M",
    "NORMAL_K",
    "parse_intrinsics",
    "UNITS",
    "PreparedCloud",
    "prepare_points",
    "rgbd_points",
    "label_points",
    "canonical_subset",
]

NORMAL_K = 16
"""Neighbours of the kNN-PCA normals estimated for clouds given without normals."""

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Length units a cloud may come in, and their size in metres."""

MAX_COORDINATE_M = 1e6
"""Coordinates farther than this from the camera (metres, after the unit conversion) are no measurement
of an object a camera sees: such rows are dropped like NaN rows (a corrupt file or wrong units)."""

_EXACT_LABELS = 1 << 18  # clouds up to this many points are labelled by an exact nearest-neighbour query


def _array(x, name: str) -> np.ndarray:
    """``x`` (numpy, torch or nested sequences) as a real-valued float64 array, or a clear InputError."""
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    try:
        arr = np.asarray(x)
    except ValueError as e:  # ragged nested sequences
        raise InputError(f"{name} must be a numeric array of shape (N, 3); it has rows of different lengths ({e})") from None
    if arr.dtype == object:
        raise InputError(f"{name} must be a numeric array of shape (N, 3); it holds non-numeric or ragged rows")
    if not np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.complexfloating) or arr.dtype == np.bool_:
        raise InputError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


@dataclass
class PreparedCloud:
    """A cloud ready for the network (:func:`prepare_points`).

    Attributes:
        points: ``(P, 3)`` float32, metres, canonical order, ``P <= max_points``.
        normals: ``(P, 3)`` float32 unit normals facing the camera, or ``None`` (to be estimated).
        raw: ``(N, 3)`` float64 the whole input in metres (an organised cloud flattened row by row).
        finite: ``(N,)`` bool, the rows that are usable measurements.
        shape: the input's leading shape: ``(N,)`` or ``(H, W)`` for an organised cloud.
        warnings: what looked wrong but was not fatal, one sentence each.
    """

    points: np.ndarray
    normals: np.ndarray | None
    raw: np.ndarray
    finite: np.ndarray
    shape: tuple
    warnings: list[str] = field(default_factory=list)


def canonical_subset(points: np.ndarray, m: int, seed: int = 0, normals: np.ndarray | None = None) -> np.ndarray:
    """Indices of at most ``m`` rows of ``points`` ``(N, 3)``, chosen and ordered by their values only.

    ``N <= m``: all rows, sorted lexicographically by (x, y, z) (then by the normals). ``N > m``: the
    ``m`` rows with the smallest seeded 64-bit hash of their coordinates (and normals), a uniform random
    subset that is the same whatever the order of the rows; then sorted. O(N) for large clouds.
    """
    P = np.ascontiguousarray(points, dtype=np.float64)
    cols = [P] if normals is None else [P, np.ascontiguousarray(normals, dtype=np.float64)]
    if len(P) > m:
        bits = np.concatenate(cols, axis=1).view(np.uint64)  # (N, 3 or 6)
        h = np.full(len(P), np.uint64((0x9E3779B97F4A7C15 * (int(seed) + 1)) % (1 << 64)))
        with np.errstate(over="ignore"):
            for c in range(bits.shape[1]):  # a splitmix64-style mix of each column into the hash
                h ^= bits[:, c]
                h *= np.uint64(0xBF58476D1CE4E5B9)
                h ^= h >> np.uint64(31)
                h *= np.uint64(0x94D049BB133111EB)
                h ^= h >> np.uint64(29)
        idx = np.argpartition(h, m - 1)[:m]
        idx = idx[np.lexsort((idx, h[idx]))]  # ties (identical rows) by index: they are interchangeable
    else:
        idx = np.arange(len(P))
    keys = [c[idx, j] for c in reversed(cols) for j in (2, 1, 0)]
    return idx[np.lexsort(keys)]


def roll_to_up(up) -> np.ndarray:
    """``(3, 3)`` rotation about the camera's optical axis (z) that turns the world's up direction ``up``
    (camera frame, any length) so that its image-plane part points to image up (``-y``, OpenCV axes):
    applied to a cloud (``p @ R.T``), it takes out the camera's roll, as an upright camera would have
    seen the scene. Only the direction counts (``(1e308, 1e308, 0)`` is ``(1, 1, 0)``). Raises
    :class:`InputError` for a non-finite or zero ``up``, or one within 10 degrees of the optical axis (a
    camera looking straight down or up has no roll to take out)."""
    try:
        u = np.asarray(up, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"up must be a finite, non-zero 3-vector in the camera frame, got {up!r}") from None
    if u.shape != (3,) or not np.all(np.isfinite(u)) or not np.any(u != 0):
        raise InputError(f"up must be a finite, non-zero 3-vector in the camera frame, got {u.tolist()}")
    # first to the largest component: the norm of huge or tiny components neither overflows nor underflows
    u = u / np.max(np.abs(u))
    u = u / np.linalg.norm(u)
    if np.hypot(u[0], u[1]) < np.sin(np.radians(10.0)):
        raise InputError(
            f"up {u.round(3).tolist()} lies within 10 degrees of the optical axis: the camera looks straight down or up, "
            "so it has no roll to take out"
        )
    phi = -np.pi / 2 - np.arctan2(u[1], u[0])
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def prepare_points(
    points,
    normals=None,
    max_points: int = 4096,
    seed: int = 0,
    normal_k: int = NORMAL_K,
    estimate: bool = True,
    units: str = "m",
    rotation=None,
) -> PreparedCloud:
    """Validate and clean a cloud for the network (see the module docstring).

    Args:
        points: ``(N, 3)`` or organised ``(H, W, 3)`` (NaN = no measurement), camera frame, in ``units``
            (numpy, torch or nested sequences of numbers).
        normals: optional, the points' shape (any length; re-normalised; flipped to face the camera, as
            the models were trained); estimated when ``None``.
        max_points: at most this many points go on (:func:`canonical_subset`), at least :data:`MIN_POINTS`.
        seed: seed of the subset of a larger cloud.
        estimate: ``False`` leaves missing normals to the caller (``normals`` is then ``None``).
        units: ``"m"`` (default), ``"cm"`` or ``"mm"``: the cloud is converted to metres.
        rotation: optional ``(3, 3)`` rotation applied to the points and normals after the unit
            conversion and before the canonical order (:func:`roll_to_up`); ``raw`` holds the turned cloud.

    Returns:
        :class:`PreparedCloud`.

    Raises:
        InputError: a wrong shape or dtype, ragged rows, normals of another shape, fewer than
            :data:`MIN_POINTS` usable points (rows with NaN / Inf or farther than :data:`MAX_COORDINATE_M`
            are not usable), coincident or collinear points, most points behind the camera (z <= 0: not
            the camera frame), an unknown unit. Each message names the problem.
    """
    pts, nrm, shape = _read_cloud(points, normals, max_points, units)
    n_in = len(pts)
    with np.errstate(invalid="ignore"):
        far = (np.abs(pts) > MAX_COORDINATE_M).any(axis=1) & np.isfinite(pts).all(axis=1)  # before a turn can overflow
    n_far = int(np.count_nonzero(far))
    top = float(np.max(np.abs(pts[far]))) if n_far else 0.0
    if rotation is not None:
        R = np.asarray(rotation, dtype=np.float64)
        with np.errstate(over="ignore", invalid="ignore"):  # rows that overflow are the far ones, dropped below
            pts = pts @ R.T
            nrm = None if nrm is None else nrm @ R.T
    finite = np.isfinite(pts).all(axis=1) & ~far
    if nrm is not None:
        finite &= np.isfinite(nrm).all(axis=1) & (nrm != 0).any(axis=1)
    notes = _dropped_notes(n_in, int(finite.sum()), n_far, top, organised=len(shape) != 1)
    kept = np.flatnonzero(finite)
    sub = kept[canonical_subset(pts[kept], int(max_points), seed, None if nrm is None else nrm[kept])]
    p = pts[sub]
    notes += _shape_notes(pts[kept, 2], p)
    n = None
    if nrm is not None:
        n = nrm[sub] / np.abs(nrm[sub]).max(axis=1, keepdims=True)  # no overflow of the norm of huge normals
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        n = np.where((n * p).sum(axis=1, keepdims=True) > 0, -n, n)  # face the camera (at the origin)
        n = n.astype(np.float32)
    elif estimate:
        n = estimate_normals(p, k=normal_k)
    return PreparedCloud(points=p.astype(np.float32), normals=n, raw=pts, finite=finite, shape=tuple(shape), warnings=notes)


def _read_cloud(points, normals, max_points: int, units: str) -> tuple[np.ndarray, np.ndarray | None, tuple]:
    """``(points (N, 3) metres, normals (N, 3) or None, leading shape)`` of a cloud, its options checked."""
    if units not in UNITS:
        raise InputError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
    if int(max_points) < MIN_POINTS:
        raise InputError(f"max_input_points must be at least {MIN_POINTS}, got {max_points}")
    pts = _array(points, "points")
    if pts.ndim not in (2, 3) or pts.shape[-1] != 3 or pts.size == 0 and pts.ndim != 2:
        raise InputError(f"points must have shape (N, 3) or (H, W, 3), got {pts.shape}")
    shape = pts.shape[:-1]
    pts = pts.reshape(-1, 3) * UNITS[units]
    if len(pts) == 0:
        raise InputError("the point cloud is empty")
    nrm = None
    if normals is not None:
        nrm = _array(normals, "normals")
        if nrm.shape[:-1] != shape or nrm.shape[-1:] != (3,):
            raise InputError(f"normals must have the points' shape {(*shape, 3)}, got {nrm.shape}")
        nrm = nrm.reshape(-1, 3)
    return pts, nrm, shape


def _dropped_notes(n_in: int, n_ok: int, n_far: int, top: float, organised: bool) -> list[str]:
    """Warnings about the ``n_in - n_ok`` dropped rows (``n_far`` of them beyond :data:`MAX_COORDINATE_M`,
    up to ``top`` metres; NaN rows of an ``organised`` cloud are missing pixels, not worth a warning).

    Raises :class:`InputError` when fewer than :data:`MIN_POINTS` rows are usable."""
    if n_ok < MIN_POINTS:
        why = "NaN / Inf coordinates or zero normals dropped"
        if n_far and n_ok + n_far >= MIN_POINTS:
            why = f"{n_far} have a coordinate beyond {MAX_COORDINATE_M:.0e} m, up to {top:.3g} m: wrong units or a corrupt file?"
        raise InputError(f"only {n_ok} of {n_in} points are usable ({why}); at least {MIN_POINTS} are needed")
    notes: list[str] = []
    if n_far:
        notes.append(
            f"dropped {n_far} of {n_in} points with a coordinate beyond {MAX_COORDINATE_M:.0e} m (up to {top:.3g} m): "
            "wrong units or a corrupt file?"
        )
    if n_ok + n_far < n_in and not organised:
        notes.append(f"dropped {n_in - n_ok - n_far} of {n_in} points with NaN / Inf coordinates or normals")
    return notes


def _shape_notes(z: np.ndarray, p: np.ndarray) -> list[str]:
    """Warnings about a cloud in front of the camera (``z`` ``(N,)`` of its usable rows) whose kept points
    ``p`` ``(P, 3)`` span a surface.

    Raises :class:`InputError` when most points lie behind the camera (not the camera frame), or all
    points coincide or lie on a line."""
    notes: list[str] = []
    behind = float(np.mean(z <= 0.0))
    if behind > 0.5:
        raise InputError(
            f"{100 * behind:.0f} % of the points lie behind the camera (z <= 0): the cloud must be in the camera "
            "frame (OpenCV axes: x right, y down, z forward from the camera), not in an object or world frame"
        )
    if behind > 0:
        notes.append(f"{100 * behind:.1f} % of the points lie behind the camera (z <= 0)")
    ev = np.sqrt(np.clip(np.linalg.eigvalsh(np.cov(p.T)), 0.0, None))[::-1]  # spreads along the principal axes, largest first
    if ev[0] < 1e-6:
        raise InputError("all points coincide: the cloud has no extent")
    if ev[1] < 1e-3 * ev[0]:
        raise InputError(
            f"the points lie on a line (spreads {ev[0]:.3g} / {ev[1]:.2g} / {ev[2]:.2g} m): not the surface of an object"
        )
    if ev[2] < 1e-4 * ev[1]:
        notes.append(f"the points lie in one plane (spreads {ev[0]:.3g} / {ev[1]:.3g} / {ev[2]:.2g} m)")
    return notes


def label_points(raw: np.ndarray, finite: np.ndarray, ref: np.ndarray, ref_labels: np.ndarray, grid: int = 64) -> np.ndarray:
    """The label of the nearest ``ref`` point for every usable row of ``raw`` (``-1`` elsewhere).

    Args:
        raw: ``(N, 3)`` points; finite: ``(N,)`` bool, the rows to label.
        ref: ``(R, 3)`` the labelled points (the network's); ref_labels: ``(R,)``.
        grid: cells per axis of the label lattice used for large clouds.

    Clouds of up to 2^18 usable points get an exact nearest-neighbour query. Larger ones look their
    label up in a ``grid^3`` lattice over ``ref``'s bounding box whose cells carry the label of the
    ``ref`` point nearest their centre (``grid=64``: cells of ~1.6 % of ``ref``'s extent); points outside
    the lattice get the exact query. O(N), no sort.
    """
    from scipy.spatial import cKDTree

    n_ok = int(np.count_nonzero(finite))
    out = np.full(len(raw), -1, dtype=np.int64)
    if n_ok == 0:
        return out
    tree = cKDTree(np.asarray(ref, dtype=np.float64))
    labels = np.asarray(ref_labels, dtype=np.int64)
    if n_ok <= _EXACT_LABELS:
        rows = np.flatnonzero(finite)
        out[rows] = labels[tree.query(raw[rows], k=1)[1]]
        return out
    lo = ref.min(0).astype(np.float64)
    cell = float(np.max(ref.max(0) - lo)) / (grid - 2) + 1e-9
    lo = lo - cell
    ax = lo[:, None] + (np.arange(grid) + 0.5) * cell  # (3, G) cell centres per axis
    centres = np.stack(np.meshgrid(ax[0], ax[1], ax[2], indexing="ij"), axis=-1).reshape(-1, 3)
    lut = labels[tree.query(centres, k=1, workers=-1)[1]]
    key = np.zeros(len(raw), dtype=np.int32)
    outside = ~finite
    with np.errstate(invalid="ignore"):  # non-finite rows are outside anyway
        for a in range(3):  # per axis, in place: "+1, truncate, -1" is floor above -1 and negative below 0
            i = ((raw[:, a] - lo[a]) * (1.0 / cell) + 1.0).astype(np.int32)
            i -= 1
            outside |= i.view(np.uint32) >= grid  # negatives wrap to huge
            key *= grid
            key += i
    np.take(lut, key, out=out, mode="clip")
    far = np.flatnonzero(outside & finite)
    if len(far):
        out[far] = labels[tree.query(raw[far], k=1, workers=-1)[1]]
    out[~finite] = -1
    return out


_INTRINSICS_FORMS = "(fx, fy, cx, cy), a 3x3 matrix K, or a dict with fx, fy, cx, cy or K / cam_K"


def parse_intrinsics(intrinsics) -> np.ndarray:
    """Pinhole intrinsics ``(fx, fy, cx, cy)`` (pixels, float64) from the forms users hold them in.

    Accepted: a sequence / array ``(fx, fy, cx, cy)``; a ``(3, 3)`` matrix K or its 9 values row by row
    (BOP's ``cam_K``); a mapping with keys ``fx, fy, cx, cy`` or ``K`` / ``cam_K`` (also nested under
    ``"camera"``); an object with attributes ``fx, fy, cx, cy`` (:class:`ucope.render.camera.PinholeCamera`).

    Raises :class:`InputError` naming the accepted forms: another form, non-numeric or non-finite values,
    focal lengths that are not positive."""
    src, vals = intrinsics, None
    if isinstance(src, torch.Tensor):
        src = src.detach().cpu().numpy()
    if isinstance(src, Mapping) and isinstance(src.get("camera"), Mapping):
        src = src["camera"]
    try:
        if isinstance(src, Mapping):
            if all(k in src for k in ("fx", "fy", "cx", "cy")):
                vals = [src[k] for k in ("fx", "fy", "cx", "cy")]
            elif "K" in src or "cam_K" in src:
                vals = src["K"] if "K" in src else src["cam_K"]
        elif all(hasattr(src, k) for k in ("fx", "fy", "cx", "cy")) and not isinstance(src, np.ndarray):
            vals = [getattr(src, k) for k in ("fx", "fy", "cx", "cy")]
        else:
            vals = src
        if vals is None or isinstance(vals, str | bytes):
            raise TypeError
        K = np.asarray(vals, dtype=np.float64)
    except (TypeError, ValueError):
        unknown_keys = isinstance(src, Mapping) and vals is None
        got = f"a dict with keys {sorted(map(str, src))}" if unknown_keys else _short(intrinsics)
        raise InputError(f"intrinsics must be {_INTRINSICS_FORMS}, got {got}") from None
    if K.shape in ((3, 3), (9,)):
        K = K.reshape(3, 3)
        K = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    if K.shape != (4,):
        raise InputError(f"intrinsics must be {_INTRINSICS_FORMS}, got an array of shape {K.shape}")
    if not np.all(np.isfinite(K)) or K[0] <= 0 or K[1] <= 0:
        raise InputError(f"intrinsics must be finite with positive focal lengths, got (fx, fy, cx, cy) = {K.tolist()}")
    return K


def _short(x, limit: int = 80) -> str:
    text = repr(x)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def rgbd_points(depth, intrinsics, mask=None, box=None, depth_scale: float = 1000.0, mask_label=None) -> np.ndarray:
    """The object's points (camera frame, metres) from a depth image, back-projected and cleaned.

    Args:
        depth: ``(H, W)`` depth (z, not range); ``depth / depth_scale`` is metres (default 1000:
            millimetres, as 16-bit PNGs hold them); 0, NaN or Inf = no measurement.
        intrinsics: pixels, in any form :func:`parse_intrinsics` reads: ``(fx, fy, cx, cy)``, a ``(3, 3)``
            matrix K, or a dict ``{"fx", "fy", "cx", "cy"}`` / ``{"K": ...}``.
        mask: optional ``(H, W)`` object mask: boolean / 0-1, or a label image with ``mask_label``
            (one value or several) selecting the object's values.
        box: optional ``(x_min, y_min, x_max, y_max)`` pixel box (columns, rows; max exclusive) to
            crop to (e.g. a detector's box), combined with ``mask``.

    Points far from the bulk of the object (mask bleeding onto the background) are removed:
    those more than 3x the median distance from the median point, and at least 0.05 m away.

    Raises:
        InputError: a wrong shape or dtype; an 8-bit depth image (it cannot hold millimetres: a
            visualisation or a mask?); a median depth outside 0.05-20 m after ``depth_scale`` (the
            scale is wrong); bad intrinsics; a mask of another shape; a box that is not finite or not
            inside the image; no valid pixel left.
    """
    from ..render.camera import PinholeCamera

    d = np.asarray(depth)
    if d.ndim != 2 or d.size == 0:
        raise InputError(f"depth must be a non-empty (H, W) image, got shape {d.shape}")
    if not np.issubdtype(d.dtype, np.number) or d.dtype == np.bool_:
        raise InputError(f"depth must be numeric, got dtype {d.dtype}")
    if d.dtype in (np.uint8, np.int8):
        raise InputError(
            "the depth image has 8-bit values, which cannot hold depth in millimetres (is it a visualisation "
            "or a mask?); give the 16-bit depth (millimetres) or float depth in metres with depth_scale=1"
        )
    try:
        scale_ok = bool(np.isfinite(float(depth_scale)) and float(depth_scale) > 0)
    except (TypeError, ValueError):
        scale_ok = False
    if not scale_ok:
        raise InputError(f"depth_scale must be a finite positive number, got {depth_scale!r}")
    depth_scale = float(depth_scale)
    H, W = d.shape
    K = parse_intrinsics(intrinsics)
    valid = np.ones((H, W), bool)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape != (H, W):
            raise InputError(f"mask has shape {m.shape}, the depth image {d.shape}")
        valid &= np.isin(m, np.atleast_1d(mask_label)) if mask_label is not None else m.astype(bool)
    if box is not None:
        b = np.asarray(box, dtype=np.float64).reshape(-1)
        if b.shape != (4,) or not np.all(np.isfinite(b)):
            raise InputError(f"box must be 4 finite numbers (x_min, y_min, x_max, y_max), got {box}")
        x0, y0, x1, y1 = (int(round(float(v))) for v in b)
        if not (0 <= x0 < x1 <= W and 0 <= y0 < y1 <= H):
            raise InputError(f"box {tuple(box)} is not inside the {W}x{H} image (x_min < x_max <= W, y_min < y_max <= H)")
        crop = np.zeros_like(valid)
        crop[y0:y1, x0:x1] = True
        valid &= crop
    cam = PinholeCamera(fx=K[0], fy=K[1], cx=K[2], cy=K[3], width=W, height=H)
    pts, _ = cam.backproject(d.astype(np.float64) / depth_scale, valid)
    if len(pts) == 0:
        raise InputError("no valid depth pixels inside the mask / box")
    z = float(np.median(pts[:, 2]))
    if not 0.05 <= z <= 20.0:
        raise InputError(
            f"the object's median depth is {z:.4g} m after dividing by depth_scale={depth_scale:g}: check the scale "
            "(depth_scale=1000 for millimetre PNGs, 1 for float depth in metres)"
        )
    med = np.median(pts, axis=0)
    r = np.linalg.norm(pts - med, axis=1)
    keep = r <= max(3.0 * float(np.median(r)), 0.05)
    return pts[keep]
