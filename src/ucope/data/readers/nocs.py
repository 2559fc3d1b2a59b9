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
cx = 322.525, cy = 244.11084. Which one: ``intrinsics`` when given, else ``dataset`` (``"real"`` /
``"camera"``), else the names of the folders from the data root down to the frame (the root's own name
included, the folders above it never): one of :data:`REAL_FOLDERS` means REAL275, one of
:data:`CAMERA_FOLDERS` CAMERA25; neither or both is an error asking for ``dataset``.

Ground truth: NOCS space is the object normalised to a unit-diagonal tight box centred at 0.5, so
the instance's pose is the similarity ``p_cam = s R (c - 0.5) + t`` between its coordinate-map values
``c`` and its back-projected pixels, fitted by Umeyama with outlier rejection
(:func:`ucope.geometry.similarity.robust_umeyama`). Our rigid NOCS-like categories use NOCS's canonical
axes (docs/conventions.md: y up), so ``cam_from_part = [R, t]`` with no axis change (``laptop`` is our
``laptop_rigid``); the box is NOCS's own estimate of ``utils.align``: extents ``2 max |c - 0.5|`` per axis
over the visible pixels, times ``s``. A fit whose RMS residual exceeds :data:`POOR_FIT_FRACTION` of the
fitted box's diagonal (a coordinate map that does not belong to the depth) is warned about, naming the
file and the instance.

Official ground truth: NOCS's ``gts`` files (``gts/val/results_val_00000_0000.pkl``,
``gts/real_test/results_real_test_scene_1_0000.pkl``: ``gt_class_ids`` ``(n,)``, ``gt_RTs`` ``(n, 4, 4)``
``[s R | t]`` from the centred NOCS space to the camera in metres, ``gt_scales`` ``(n, 3)`` the model's box
in NOCS units) replace the fit when given (``gts``, or a ``gts`` folder in the data root): pose ``[R | t]``
and box ``s * gt_scales``. A frame's file is ``*_<scene folder>_<frame>.pkl``; its entries are matched to
the ``_meta.txt`` instances of the same class in order, and each match is checked against the
coordinate-map fit (:data:`GTS_MATCH_M`). The pickles are read by :func:`read_nocs_gts`, which builds
only dicts, lists, numbers, strings and numpy arrays and refuses any other object.
"""

from __future__ import annotations

import importlib
import io
import pickle
import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError, InputError
from ...geometry.similarity import robust_umeyama
from .common import read_image, read_label_image, regular_file, sample_from_pixels

__all__ = [
    "NOCS_CLASSES",
    "NOCS_TO_UCOPE",
    "CAMERA_INTRINSICS",
    "REAL275_INTRINSICS",
    "REAL_FOLDERS",
    "CAMERA_FOLDERS",
    "POOR_FIT_FRACTION",
    "GTS_MATCH_M",
    "nocs_frames",
    "nocs_dataset",
    "read_nocs_meta",
    "read_nocs_gts",
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

REAL_FOLDERS = frozenset({"real", "real275", "real_test", "real_train", "real_val"})
"""Folder names (any case) that mark REAL275 frames: NOCS's ``data/real``, its zips ``real_test`` /
``real_train``."""

CAMERA_FOLDERS = frozenset({"camera", "camera25", "camera_val", "camera_val25k", "camera_train", "camera_full_depths", "val25k"})
"""Folder names (any case) that mark CAMERA25 frames: NOCS's ``data/camera``, its zips ``camera_val25K`` /
``camera_train``, ``camera_full_depths``."""

POOR_FIT_FRACTION = 0.1
"""A coordinate-map fit whose RMS residual exceeds this fraction of the fitted box's diagonal is warned
about (the map does not explain the depth)."""

GTS_MATCH_M = 0.05
"""Largest distance (metres) between a ``gts`` pose's centre and the coordinate-map fit's, for a good fit,
before the match is refused as belonging to another instance."""

MAX_GTS_BYTES = 64 * 2**20
"""Largest ``gts`` pickle read (NOCS's are a few kB)."""

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
    :class:`DataError` naming the file and line (also a file that is not a regular file: a FIFO would
    block the read)."""
    path = regular_file(path, "instance list")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
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


def nocs_dataset(root: str | Path, prefix: Path) -> str:
    """``"real"`` or ``"camera"`` for a frame ``prefix`` below ``root``, from the names of the folders from
    the root (its own name included) down to the frame: see :data:`REAL_FOLDERS`, :data:`CAMERA_FOLDERS`.

    Raises :class:`DataError` when the names say neither or both (then give ``dataset`` or intrinsics)."""
    root = Path(root).resolve()
    try:
        below = prefix.resolve().relative_to(root).parts[:-1]
    except ValueError:
        below = ()
    names = [n.lower() for n in (root.name, *below)]
    kinds = {"real" for n in names if n in REAL_FOLDERS} | {"camera" for n in names if n in CAMERA_FOLDERS}
    if len(kinds) != 1:
        said = "both REAL275 and CAMERA25" if kinds else "neither REAL275 nor CAMERA25"
        raise DataError(
            f"{prefix}: the folder names from the data root down ({'/'.join(names)}) say {said}; give the data set "
            "(--dataset real|camera, read_nocs(dataset=...)) or the camera (--intrinsics K.json)"
        )
    return kinds.pop()


_PICKLE_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"),
    ("numpy._core.numeric", "_frombuffer"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("collections", "OrderedDict"),
}


class _ArraysOnlyUnpickler(pickle.Unpickler):
    """An unpickler that builds dicts, lists, tuples, numbers, strings and numpy arrays / scalars only:
    ``find_class`` admits numpy's array and dtype reconstruction, ``OrderedDict`` and protocol 2's
    latin-1 bytes (``_codecs.encode`` of a string, nothing else) and refuses every other global, so a
    pickle cannot call ``os.system`` or build an object of its choosing."""

    def __init__(self, file, path: Path):
        super().__init__(file, encoding="latin1")
        self.path = path

    def find_class(self, module: str, name: str):
        if (module, name) == ("_codecs", "encode"):  # protocol 2 stores bytes (an array's data) as latin-1 text
            return self._latin1_bytes
        if (module, name) not in _PICKLE_GLOBALS:
            raise DataError(
                f"{self.path}: refused to unpickle {module}.{name}: a NOCS gts file holds only dicts, lists, numbers, "
                "strings and numpy arrays"
            )
        if module.startswith("numpy.core") and hasattr(np, "_core"):  # numpy 2 moved numpy.core to numpy._core
            module = "numpy._core" + module[len("numpy.core") :]
        return getattr(importlib.import_module(module), name)

    def _latin1_bytes(self, text, encoding="utf-8"):
        if not isinstance(text, str) or str(encoding).lower().replace("-", "") != "latin1":
            raise DataError(f"{self.path}: refused _codecs.encode({type(text).__name__}, {encoding!r}) in the pickle")
        return text.encode("latin-1")

    def persistent_load(self, pid):
        raise DataError(f"{self.path}: refused a persistent reference in the pickle")


def read_nocs_gts(path: str | Path) -> dict:
    """The ground truth of one frame from NOCS's ``gts`` pickle (see the module docstring), read by an
    unpickler that builds only dicts, lists, numbers, strings and numpy arrays.

    Returns ``{"class_ids": (n,) int, "RTs": (n, 4, 4), "scales": (n, 3)}`` (finite, checked).

    Raises :class:`DataError` naming the file: not a regular file, larger than 64 MB, any other global in
    the pickle (``os.system``, a class...), a corrupt pickle, missing keys or wrong shapes."""
    path = regular_file(path, "NOCS gts pickle")
    if path.stat().st_size > MAX_GTS_BYTES:
        raise DataError(f"{path}: {path.stat().st_size} bytes, more than a NOCS gts pickle ({MAX_GTS_BYTES} at most)")
    try:
        with open(path, "rb") as f:
            d = _ArraysOnlyUnpickler(io.BytesIO(f.read()), path).load()
    except DataError:
        raise
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError, MemoryError) as e:
        raise DataError(f"{path}: not a readable NOCS gts pickle ({type(e).__name__}: {e})") from None
    if not isinstance(d, dict) or not {"gt_class_ids", "gt_RTs", "gt_scales"} <= set(d):
        keys = sorted(map(str, d)) if isinstance(d, dict) else type(d).__name__
        raise DataError(f"{path}: a NOCS gts pickle is a dict with gt_class_ids, gt_RTs and gt_scales, got {keys}")
    try:
        cls = np.asarray(d["gt_class_ids"]).astype(np.int64).reshape(-1)
        RTs = np.asarray(d["gt_RTs"], np.float64).reshape(-1, 4, 4)
        scales = np.asarray(d["gt_scales"], np.float64).reshape(-1, 3)
    except (TypeError, ValueError):
        raise DataError(f"{path}: gt_class_ids (n,), gt_RTs (n, 4, 4) and gt_scales (n, 3) must be numeric arrays") from None
    if not (len(cls) == len(RTs) == len(scales)):
        raise DataError(f"{path}: gt_class_ids, gt_RTs and gt_scales have {len(cls)}, {len(RTs)} and {len(scales)} entries")
    if not (np.all(np.isfinite(RTs)) and np.all(np.isfinite(scales))):
        raise DataError(f"{path}: gt_RTs and gt_scales must be finite, got NaN or Inf")
    return {"class_ids": cls, "RTs": RTs, "scales": scales}


def _gts_files(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        raise DataError(f"{folder} is not a folder (expected NOCS's gts folder of results_*.pkl files)")
    return {p.name: p for p in folder.rglob("*.pkl")}


def _gts_for(files: dict[str, Path], prefix: Path) -> Path | None:
    suffix = f"_{prefix.parent.name}_{prefix.name}.pkl"
    hits = sorted(n for n in files if n.endswith(suffix))
    if len(hits) > 1:
        raise DataError(f"{prefix}: several gts files end with {suffix!r}: {', '.join(hits[:3])}; give the split's gts folder")
    return files[hits[0]] if hits else None


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


def read_nocs(
    root: str | Path,
    category: str | None = None,
    intrinsics=None,
    max_points: int = 4096,
    dataset: str | None = None,
    gts: str | Path | None = None,
) -> list[dict]:
    """Every object of the NOCS frames under ``root`` as a ucope sample (rigid, K = 1).

    Args:
        root: a folder of NOCS frames (searched recursively; see the module docstring for the layout).
        category: keep only this ucope category (``mug``, ``laptop_rigid``...); ``None``: all six.
        intrinsics: ``(fx, fy, cx, cy)``; default by ``dataset``.
        max_points: clouds are subsampled (deterministically) to this many points.
        dataset: ``"real"`` (REAL275's camera) or ``"camera"`` (CAMERA25's); default told by the folder
            names below the root (:func:`nocs_dataset`).
        gts: NOCS's ``gts`` folder (or one split of it); default ``root/gts`` when it exists. Frames with a
            file there take its poses and model boxes (module docstring).

    Returns:
        samples (:mod:`ucope.data.sample` fields; ``joint_*`` empty) in frame and instance order, with
        ``nocs_class``, ``nocs_model``, ``frame``, ``gt_fit_rmse_m`` (the coordinate-map fit's residual)
        and ``gt_source`` (``"gts"`` or ``"coord"``). Instances with fewer than 32 measured pixels are
        skipped with a warning; a poor coordinate-map fit is warned about.

    Raises:
        DataError: a missing or corrupt file (named), a FIFO or other non-regular file, images of
            different sizes, a bad meta line, frames whose data set cannot be told, a gts pickle that is
            refused or does not match.
        InputError: an unknown category or ``dataset``.
    """
    if category is not None and category not in NOCS_TO_UCOPE.values():
        raise InputError(f"NOCS holds {', '.join(sorted(set(NOCS_TO_UCOPE.values())))}; no {category!r} objects")
    if dataset is not None and dataset not in ("real", "camera"):
        raise InputError(f"dataset must be 'real' (REAL275) or 'camera' (CAMERA25), got {dataset!r}")
    if gts is None and (Path(root) / "gts").is_dir():
        gts = Path(root) / "gts"
    gts_files = _gts_files(Path(gts)) if gts is not None else {}
    samples, skipped, poor, unmatched = [], [], [], []
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
        if intrinsics is not None:
            K = tuple(float(v) for v in intrinsics)
        else:
            K = REAL275_INTRINSICS if (dataset or nocs_dataset(root, prefix)) == "real" else CAMERA_INTRINSICS
        depth_m = depth.astype(np.float64) / 1000.0
        rel = str(prefix.relative_to(root)) if Path(root) in prefix.parents else str(prefix)
        gt_path = _gts_for(gts_files, prefix) if gts_files else None
        official = read_nocs_gts(gt_path) if gt_path is not None else None
        used: set[int] = set()
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
            diag = float(np.linalg.norm(size))
            fit_poor = not rmse <= POOR_FIT_FRACTION * diag
            if fit_poor:
                poor.append(
                    f"{coord_path}, instance {iid}: RMS {100 * rmse:.1f} cm against a fitted box diagonal of "
                    f"{100 * diag:.1f} cm"
                )
            source = "coord"
            if official is not None:
                cand = [n for n in np.flatnonzero(official["class_ids"] == cls) if int(n) not in used]
                if cand:
                    n = int(cand[0])
                    used.add(n)
                    RT = official["RTs"][n]
                    s_off = float(np.cbrt(np.linalg.det(RT[:3, :3])))
                    if not s_off > 0:
                        raise DataError(f"{gt_path}: gt_RTs[{n}] has a rotation part of determinant <= 0")
                    if not fit_poor and np.linalg.norm(RT[:3, 3] - T[:3, 3]) > max(GTS_MATCH_M, 0.5 * diag):
                        raise DataError(
                            f"{gt_path}: entry {n} (class {cls}) lies {100 * np.linalg.norm(RT[:3, 3] - T[:3, 3]):.1f} cm "
                            f"from instance {iid} of {prefix.name}_meta.txt as its coordinate map places it; the entries do "
                            "not follow the meta file's instances"
                        )
                    T = np.eye(4)
                    U, _, Vt = np.linalg.svd(RT[:3, :3] / s_off)
                    T[:3, :3], T[:3, 3] = U @ Vt, RT[:3, 3]
                    size, scale, source = s_off * official["scales"][n], s_off, "gts"
                else:
                    unmatched.append(f"{gt_path}: no entry of class {cls} left for instance {iid}")
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
                    "gt_fit_poor": fit_poor,
                    "gt_source": source,
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
    if poor:
        warnings.warn(
            f"{len(poor)} NOCS instance(s) whose coordinate map fits the depth poorly (RMS residual above "
            f"{POOR_FIT_FRACTION:.0%} of the fitted box's diagonal; the ground truth is doubtful), first: {poor[0]}",
            stacklevel=2,
        )
    if unmatched:
        warnings.warn(
            f"{len(unmatched)} NOCS instance(s) without a gts entry kept the coordinate-map fit (first: {unmatched[0]})",
            stacklevel=2,
        )
    return samples
