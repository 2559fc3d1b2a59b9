"""NOCS's CAMERA25 and REAL275 frames -> ucope samples (a cloud per object, its ground truth in our frames).

Layout read (NOCS's own, any folder depth below the root): per image, ``NNNN_depth.png``,
``NNNN_mask.png``, ``NNNN_coord.png``, ``NNNN_meta.txt`` (and ``NNNN_color.png``, not needed):

* ``_depth.png``: depth in millimetres, 16-bit one channel (REAL275), or NOCS's 3-channel encoding
  of CAMERA (``depth = 256 * green + red``, in RGB channel order; NOCS's loader reads
  ``d[:, :, 1] * 256 + d[:, :, 2]`` in OpenCV's BGR order). CAMERA's ``_depth.png`` holds the rendered
  objects only; the composed depth (objects over a real background, NOCS's ``camera_full_depths``)
  may sit beside it as ``NNNN_composed.png`` and is then read instead. Only object pixels are used.
* ``_mask.png``: instance ids, 255 = background (a colour mask: its red channel, as NOCS reads it).
* ``_coord.png``: the NOCS map, 8-bit RGB = x, y, z in ``[0, 1]`` with ``z`` stored flipped
  (``z = 1 - blue / 255``, as NOCS's loader does).
* ``_meta.txt``: one line per instance, ``inst_id class_id model_name`` (REAL275) or
  ``inst_id class_id synset model_id`` (CAMERA); class ids 1..6 = bottle, bowl, camera, can, laptop,
  mug; class 0 (CAMERA's background objects) is skipped.

Intrinsics: CAMERA fx = fy = 577.5, cx = 319.5, cy = 239.5; REAL275 fx = 591.0125, fy = 590.16775,
cx = 322.525, cy = 244.11084 (chosen by the path: a folder named ``real*`` means REAL275), or given.

Ground truth: NOCS space is the object normalised to a unit-diagonal tight box centred at 0.5, so
the instance's pose is the similarity ``p_cam = s R (c - 0.5) + t`` between its coordinate-map values
``c`` and its back-projected pixels, fitted by Umeyama with outlier rejection
(:func:`ucope.geometry.similarity.robust_umeyama`). Our rigid NOCS-like categories use NOCS's canonical
axes (docs/conventions.md: y up), so ``cam_from_part = [R, t]`` with no axis change (``laptop`` is our
``laptop_rigid``); the box is NOCS's own estimate of ``utils.align``: extents ``2 max |c - 0.5|`` per axis
over the visible pixels, times ``s``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError, InputError
from ...geometry.similarity import robust_umeyama
from .common import read_image, read_label_image, sample_from_pixels

__all__ = [
    "NOCS_CLASSES",
    "NOCS_TO_UCOPE",
    "CAMERA_INTRINSICS",
    "REAL275_INTRINSICS",
    "nocs_frames",
    "read_nocs_meta",
    "nocs_pose",
    "read_nocs",
    "read_nocs_depth",
]

NOCS_CLASSES = {1: "bottle", 2: "bowl", 3: "camera", 4: "can", 5: "laptop", 6: "mug"}
"""NOCS class ids (``_meta.txt``'s second column)."""

NOCS_TO_UCOPE = {"bottle": "bottle", "bowl": "bowl", "camera": "camera", "can": "can", "laptop": "laptop_rigid", "mug": "mug"}
"""Our category of each NOCS class."""

CAMERA_INTRINSICS = (577.5, 577.5, 319.5, 239.5)
REAL275_INTRINSICS = (591.0125, 590.16775, 322.525, 244.11084)

BACKGROUND_ID = 255


def nocs_frames(root: str | Path) -> list[Path]:
    """The frame prefixes (``.../NNNN``) under ``root``: every ``NNNN_meta.txt``, sorted.

    Raises :class:`DataError` if ``root`` is not a folder or holds no ``_meta.txt``."""
    root = Path(root)
    if not root.is_dir():
        raise DataError(
            f"{root} is not a folder (expected NOCS CAMERA / REAL275 frames: "
            "NNNN_depth.png, NNNN_mask.png, NNNN_coord.png, NNNN_meta.txt)"
        )
    metas = sorted(root.rglob("*_meta.txt"))
    if not metas:
        raise DataError(f"{root} holds no NOCS frames (no NNNN_meta.txt below it)")
    return [m.with_name(m.name[: -len("_meta.txt")]) for m in metas]


def read_nocs_meta(path: str | Path) -> list[tuple[int, int, str]]:
    """``(inst_id, class_id, model_name)`` of every line of a ``_meta.txt``; a bad line raises
    :class:`DataError` naming the file and line."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise DataError(f"{path}: no such file (the instance list)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read {path}: {e}") from None
    out = []
    for n, line in enumerate(lines, start=1):
        words = line.split()
        if not words:
            continue
        try:
            if len(words) < 3:
                raise ValueError("expected 'inst_id class_id model_name'")
            iid, cls = int(words[0]), int(words[1])
        except ValueError as e:
            raise DataError(f"{path}, line {n}: {e} (got {line.strip()!r})") from None
        if cls != 0 and cls not in NOCS_CLASSES:
            raise DataError(f"{path}, line {n}: unknown NOCS class id {cls} (1..6 = {', '.join(NOCS_CLASSES.values())})")
        out.append((iid, cls, " ".join(words[2:])))
    return out


def read_nocs_depth(prefix: Path) -> np.ndarray:
    """A frame's depth in millimetres (uint16 ``(H, W)``): ``_composed.png`` if present, else ``_depth.png``
    (16-bit one channel, or NOCS's 3-channel encoding, see the module docstring)."""
    path = prefix.with_name(prefix.name + "_composed.png")
    if not path.is_file():
        path = prefix.with_name(prefix.name + "_depth.png")
    d = read_image(path, "depth image")
    if d.ndim == 3 and d.shape[2] >= 3 and d.dtype == np.uint8:
        return d[..., 1].astype(np.uint16) * 256 + d[..., 0].astype(np.uint16)
    if d.ndim != 2:
        raise DataError(f"{path}: a NOCS depth image is 16-bit one channel or 8-bit 3 channels, got shape {d.shape} {d.dtype}")
    return d.astype(np.uint16)


def _intrinsics_for(prefix: Path) -> tuple[float, float, float, float]:
    return REAL275_INTRINSICS if any(p.lower().startswith("real") for p in prefix.parts[:-1]) else CAMERA_INTRINSICS


def nocs_pose(coords: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The ground truth of one instance from its pixels' NOCS coordinates and camera points.

    Args:
        coords: ``(N, 3)`` NOCS coordinates in ``[0, 1]`` (z already un-flipped).
        points: ``(N, 3)`` the same pixels back-projected, camera frame, metres.

    Returns:
        ``(cam_from_part (4, 4), size_m (3,), scale, rmse_m)``: the pose of the box-centred NOCS frame,
        the box extents (NOCS's visible-extent estimate times the scale), the similarity's scale (metres
        per NOCS unit) and the inliers' RMS residual.
    """
    c = np.asarray(coords, np.float64) - 0.5
    s, R, t, inl = robust_umeyama(c, points)
    r = np.linalg.norm(points[inl] - (s * c[inl] @ R.T + t), axis=1)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    size = s * 2.0 * np.max(np.abs(c[inl]), axis=0)
    return T, size, float(s), float(np.sqrt(np.mean(r * r)))


def read_nocs(root: str | Path, category: str | None = None, intrinsics=None, max_points: int = 4096) -> list[dict]:
    """Every object of the NOCS frames under ``root`` as a ucope sample (rigid, K = 1).

    Args:
        root: a folder of NOCS frames (searched recursively; see the module docstring for the layout).
        category: keep only this ucope category (``mug``, ``laptop_rigid``...); ``None``: all six.
        intrinsics: ``(fx, fy, cx, cy)``; default CAMERA's or REAL275's by the path.
        max_points: clouds are subsampled (deterministically) to this many points.

    Returns:
        samples (:mod:`ucope.data.sample` fields; ``joint_*`` empty) in frame and instance order, with
        ``nocs_class``, ``nocs_model``, ``frame`` and ``gt_fit_rmse_m`` (the alignment's residual).
        Instances with fewer than 32 measured pixels are skipped with a warning.

    Raises:
        DataError: a missing or corrupt file (named), images of different sizes, a bad meta line.
        InputError: an unknown category.
    """
    if category is not None and category not in NOCS_TO_UCOPE.values():
        raise InputError(f"NOCS holds {', '.join(sorted(set(NOCS_TO_UCOPE.values())))}; no {category!r} objects")
    samples, skipped = [], []
    for prefix in nocs_frames(root):
        meta = read_nocs_meta(prefix.with_name(prefix.name + "_meta.txt"))
        wanted = [
            (i, c, m)
            for i, c, m in meta
            if c in NOCS_CLASSES and (category is None or NOCS_TO_UCOPE[NOCS_CLASSES[c]] == category)
        ]
        if not wanted:
            continue
        depth = read_nocs_depth(prefix)
        shape = depth.shape
        mask = read_label_image(prefix.with_name(prefix.name + "_mask.png"), "instance mask (255 = background)", shape)
        coord_path = prefix.with_name(prefix.name + "_coord.png")
        coord = read_image(coord_path, "NOCS coordinate map (8-bit RGB)")
        if coord.ndim != 3 or coord.shape[2] < 3 or coord.shape[:2] != shape:
            raise DataError(
                f"{coord_path}: the coordinate map must be an RGB image of the depth's size "
                f"{shape[1]}x{shape[0]}, got {coord.shape}"
            )
        coord = coord[..., :3].astype(np.float64) / (65535.0 if coord.dtype == np.uint16 else 255.0)
        coord[..., 2] = 1.0 - coord[..., 2]
        K = tuple(float(v) for v in (intrinsics if intrinsics is not None else _intrinsics_for(prefix)))
        depth_m = depth.astype(np.float64) / 1000.0
        rel = str(prefix.relative_to(root)) if Path(root) in prefix.parents else str(prefix)
        for iid, cls, model in wanted:
            sel = (mask == iid) & (depth > 0)
            name = f"{rel}/{iid}"
            if np.count_nonzero(sel) < 32:
                skipped.append(name)
                continue
            rows, cols = np.nonzero(sel)
            z = depth_m[rows, cols]
            pts = np.stack([(cols - K[2]) / K[0] * z, (rows - K[3]) / K[1] * z, z], axis=1)
            try:
                T, size, scale, rmse = nocs_pose(coord[rows, cols], pts)
            except InputError as e:
                raise DataError(f"{coord_path}: instance {iid}'s coordinates give no pose ({e})") from None
            labels = np.where(sel, 0, -1)
            cat = NOCS_TO_UCOPE[NOCS_CLASSES[cls]]
            s = sample_from_pixels(
                depth_m,
                K,
                labels,
                {
                    "cam_from_part": T[None],
                    "size_m": size[None],
                    "nocs_class": NOCS_CLASSES[cls],
                    "nocs_model": model,
                    "frame": rel,
                    "gt_fit_rmse_m": rmse,
                    "nocs_scale": scale,
                },
                cat,
                name,
                len(samples),
                max_points,
            )
            samples.append(s)
    if skipped:
        warnings.warn(
            f"skipped {len(skipped)} NOCS instance(s) with fewer than 32 measured pixels (first: {skipped[0]})", stacklevel=2
        )
    return samples
