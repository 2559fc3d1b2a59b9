"""Reading user point clouds, depth images and intrinsics.

Point clouds (:func:`read_point_cloud`): ``.npy``, ``.npz``, ``.ply`` (ASCII and binary, through the
maintained ``plyfile`` reader, extra ``ply``), ``.pcd`` (ascii, binary and binary_compressed, organised
or not), ``.xyz`` / ``.txt`` / ``.pts``. A reader returns the points as float64 ``(N, 3)``, or
``(H, W, 3)`` for an **organised** cloud (a PCD with ``HEIGHT > 1``, an ``(H, W, 3)`` array), where
NaN rows mark pixels without a measurement, and the normals in the same shape when the file has them
(else ``None``). Frame and units are the file's own (ucope expects the camera frame, metres: see
:mod:`ucope.estimation.inputs` for the unit and frame checks).

Depth images (:func:`read_depth_png`) and object masks (:func:`read_mask_png`) are single-channel PNGs;
intrinsics (:func:`read_intrinsics`) are JSON. Every problem with a file raises
:class:`ucope.errors.DataError` naming the file and what is wrong.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError
from ..fileio import read_json

__all__ = [
    "POINT_CLOUD_SUFFIXES",
    "read_point_cloud",
    "read_depth_png",
    "read_mask_png",
    "read_intrinsics",
    "lzf_decompress",
]

POINT_CLOUD_SUFFIXES = (".npy", ".npz", ".ply", ".pcd", ".xyz", ".txt", ".pts")


def _columns(path: Path, arr: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Points and optional normals from an ``(N, 3 | 6)`` or ``(H, W, 3 | 6)`` numeric array."""
    arr = np.asarray(arr)
    if arr.ndim not in (2, 3) or arr.shape[-1] not in (3, 6):
        raise DataError(
            f"{path}: expected an (N, 3) array of points, (N, 6) of points and normals, or an organised (H, W, 3) "
            f"cloud, got shape {arr.shape}"
        )
    if not np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.complexfloating):
        raise DataError(f"{path}: point array is not real-valued numbers (dtype {arr.dtype})")
    arr = arr.astype(np.float64)
    return arr[..., :3], (arr[..., 3:6] if arr.shape[-1] == 6 else None)


def _unit_rows(x: np.ndarray) -> bool:
    """Whether at least 90 % of the finite rows of ``x`` ``(N, 3)`` have a length within 10 % of 1."""
    n = np.linalg.norm(x, axis=-1)
    n = n[np.isfinite(n)]
    return bool(len(n)) and float(np.mean(np.abs(n - 1.0) < 0.1)) >= 0.9


def read_point_cloud(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Points and (optional) normals of a point cloud file.

    Formats:

    * ``.npy``: an ``(N, 3)`` / ``(N, 6)`` (points, normals) or organised ``(H, W, 3)`` / ``(H, W, 6)`` array;
    * ``.npz``: a ``points`` array (as for ``.npy``) and an optional ``normals`` array of its shape;
    * ``.xyz`` / ``.txt`` / ``.pts``: whitespace or comma separated rows, ``#`` comments; the first three
      columns are x y z; columns 4-6 are read as normals when they are unit vectors, else ignored (RGB...);
    * ``.ply``: the ``vertex`` element's ``x y z`` and optional ``nx ny nz`` (other properties and elements
      ignored), ASCII or binary, through ``plyfile`` (``pip install "ucope[ply]"``);
    * ``.pcd``: fields ``x y z`` and optional ``normal_x normal_y normal_z``, ``DATA ascii``, ``binary`` or
      ``binary_compressed``; organised clouds (``HEIGHT > 1``) come back as ``(H, W, 3)``.

    Returns:
        ``points`` float64 ``(N, 3)`` or ``(H, W, 3)`` (NaN rows allowed) and ``normals`` of the same shape
        or ``None``.

    Raises:
        DataError: a missing, truncated, corrupt or unsupported file (naming it and the problem).
        InputError: an unsupported suffix, or a missing optional reader (naming the extra).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file" + (" (it is a folder)" if path.is_dir() else ""))
    suffix = path.suffix.lower()
    if suffix not in POINT_CLOUD_SUFFIXES:
        raise InputError(f"{path}: unsupported point cloud format {suffix!r}; use one of {', '.join(POINT_CLOUD_SUFFIXES)}")
    try:
        if suffix == ".npy":
            return _columns(path, np.load(path, allow_pickle=False))
        if suffix == ".npz":
            return _read_npz(path)
        if suffix in (".xyz", ".txt", ".pts"):
            return _read_text(path)
        if suffix == ".ply":
            return _read_ply(path)
        return _read_pcd(path)
    except (DataError, InputError):
        raise
    except (OSError, ValueError, UnicodeDecodeError, EOFError, KeyError, IndexError, zipfile.BadZipFile) as e:
        raise DataError(f"{path}: cannot read the point cloud ({type(e).__name__}: {e})") from None


def _read_npz(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    with np.load(path, allow_pickle=False) as z:
        if "points" not in z.files:
            raise DataError(f"{path}: an .npz point cloud needs a 'points' array (found {sorted(z.files)})")
        pts, nrm = _columns(path, z["points"])
        if "normals" in z.files:
            nrm, _ = _columns(path, z["normals"])
            if nrm.shape != pts.shape:
                raise DataError(f"{path}: 'normals' has shape {nrm.shape}, 'points' {pts.shape}")
        return pts, nrm


def _read_text(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    text = path.read_text(encoding="utf-8", errors="strict").replace(",", " ")
    rows = [ln.split("#")[0].split() for ln in text.splitlines()]
    rows = [r for r in rows if r]
    if not rows:
        raise DataError(f"{path}: the file holds no points")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise DataError(f"{path}: rows have different numbers of columns ({sorted(widths)})")
    width = widths.pop()
    if width < 3:
        raise DataError(f"{path}: rows need at least 3 columns (x y z), got {width}")
    arr = np.array(rows, dtype=np.float64)
    nrm = arr[:, 3:6] if width >= 6 and _unit_rows(arr[:, 3:6]) else None
    return arr[:, :3], nrm


def _read_ply(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    try:
        import plyfile
    except ImportError:  # pragma: no cover - depends on the environment
        raise InputError(f'{path}: reading .ply files needs plyfile: pip install "ucope[ply]"') from None
    try:
        ply = plyfile.PlyData.read(str(path))
    except (plyfile.PlyParseError, plyfile.PlyHeaderParseError, ValueError, EOFError, IndexError, KeyError) as e:
        raise DataError(f"{path}: not a readable PLY file ({type(e).__name__}: {e})") from None
    names = [el.name for el in ply.elements]
    if "vertex" not in names:
        raise DataError(f"{path}: the PLY file has no 'vertex' element (elements: {names})")
    v = ply["vertex"].data
    props = v.dtype.names or ()
    if not all(k in props for k in ("x", "y", "z")):
        raise DataError(f"{path}: the PLY vertices have no x y z properties (properties: {list(props)})")
    if len(v) == 0:
        raise DataError(f"{path}: the PLY file holds no vertices")
    pts = np.stack([np.asarray(v[k], dtype=np.float64) for k in ("x", "y", "z")], axis=1)
    nrm = None
    if all(k in props for k in ("nx", "ny", "nz")):
        nrm = np.stack([np.asarray(v[k], dtype=np.float64) for k in ("nx", "ny", "nz")], axis=1)
    return pts, nrm


# ------------------------------------------------------------------------------------------ PCD
_PCD_TYPES = {
    ("F", 4): "f4",
    ("F", 8): "f8",
    ("I", 1): "i1",
    ("I", 2): "i2",
    ("I", 4): "i4",
    ("I", 8): "i8",
    ("U", 1): "u1",
    ("U", 2): "u2",
    ("U", 4): "u4",
    ("U", 8): "u8",
}


def lzf_decompress(data: bytes, size: int) -> bytes:
    """Decompress LZF data (liblzf's format, used by PCD's ``binary_compressed``) into ``size`` bytes.

    A token with control byte ``c < 32`` copies the next ``c + 1`` literal bytes; otherwise it copies
    ``(c >> 5) + 2`` bytes (plus an extra length byte when ``c >> 5 == 7``) from ``((c & 31) << 8) + next + 1``
    bytes back in the output (overlapping copies repeat the pattern). Raises :class:`DataError` on
    corrupt input. The loop runs over tokens, a few per run of bytes, not over points."""
    src = memoryview(data)
    out = bytearray(size)
    ip = op = 0
    n = len(src)
    try:
        while ip < n:
            ctrl = src[ip]
            ip += 1
            if ctrl < 32:
                length = ctrl + 1
                if op + length > size or ip + length > n:
                    raise DataError("literal run past the end")
                out[op : op + length] = src[ip : ip + length]
                ip += length
                op += length
                continue
            length = ctrl >> 5
            if length == 7:
                length += src[ip]
                ip += 1
            ref = op - ((ctrl & 0x1F) << 8) - src[ip] - 1
            ip += 1
            length += 2
            if ref < 0 or op + length > size:
                raise DataError("back reference outside the output")
            if op - ref >= length:
                out[op : op + length] = out[ref : ref + length]
            else:  # overlapping: the period op - ref repeats
                period = bytes(out[ref:op])
                reps = -(-length // len(period))
                out[op : op + length] = (period * reps)[:length]
            op += length
    except IndexError:
        raise DataError("LZF data ends inside a token") from None
    if op != size:
        raise DataError(f"LZF data decompressed to {op} bytes, the header says {size}")
    return bytes(out)


def _pcd_header(path: Path, raw: bytes) -> tuple[dict[str, list[str]], int]:
    header: dict[str, list[str]] = {}
    pos = 0
    while True:
        end = raw.find(b"\n", pos)
        if end < 0:
            raise DataError(f"{path}: PCD header has no DATA line")
        line = raw[pos:end].decode("ascii", errors="replace").strip()
        pos = end + 1
        if not line or line.startswith("#"):
            continue
        key, *vals = line.split()
        header[key.upper()] = vals
        if key.upper() == "DATA":
            return header, pos


def _read_pcd(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    raw = path.read_bytes()
    header, pos = _pcd_header(path, raw)
    try:
        fields = header["FIELDS"]
        sizes = [int(s) for s in header["SIZE"]]
        types = [t.upper() for t in header["TYPE"]]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
        width = int(header["WIDTH"][0])
        height = int(header.get("HEIGHT", ["1"])[0])
        n = int(header["POINTS"][0]) if "POINTS" in header else width * height
        kind = header["DATA"][0].lower()
    except (KeyError, ValueError, IndexError):
        raise DataError(f"{path}: PCD header lacks or has bad FIELDS / SIZE / TYPE / WIDTH / POINTS / DATA") from None
    if not (len(fields) == len(sizes) == len(types) == len(counts)):
        raise DataError(
            f"{path}: PCD header has {len(fields)} FIELDS but {len(sizes)} SIZE, {len(types)} TYPE, {len(counts)} COUNT"
        )
    if not all(f in fields for f in ("x", "y", "z")):
        raise DataError(f"{path}: PCD file has no x y z fields (fields: {fields})")
    if n < 0 or width * height != n:
        raise DataError(f"{path}: PCD header says POINTS {n} but WIDTH x HEIGHT = {width} x {height}")
    dtype = []
    for i, (f, s, t, c) in enumerate(zip(fields, sizes, types, counts, strict=False)):
        code = _PCD_TYPES.get((t, s))
        if code is None:
            raise DataError(f"{path}: unsupported PCD field type {t}{s} (field {f!r})")
        name = f if f != "_" and f not in [d[0] for d in dtype] else f"_pad{i}"
        dtype.append((name, "<" + code, (c,)) if c > 1 else (name, "<" + code))
    dt = np.dtype(dtype)
    if kind == "ascii":
        vals = np.loadtxt(raw[pos:].decode("ascii").splitlines(), dtype=np.float64, ndmin=2)
        if vals.shape != (n, sum(counts)):
            raise DataError(f"{path}: header says {n} points of {sum(counts)} values, the data has shape {vals.shape}")
        offsets = np.concatenate([[0], np.cumsum(counts)])
        cols = {f: vals[:, offsets[i]] for i, f in enumerate(fields)}
    elif kind == "binary":
        if len(raw) - pos < n * dt.itemsize:
            raise DataError(f"{path}: truncated PCD data ({len(raw) - pos} bytes for {n} points of {dt.itemsize} bytes)")
        arr = np.frombuffer(raw, dtype=dt, count=n, offset=pos)
        cols = {f: np.asarray(arr[dt.names[i]], dtype=np.float64).reshape(n, -1)[:, 0] for i, f in enumerate(fields)}
    elif kind == "binary_compressed":
        if len(raw) - pos < 8:
            raise DataError(f"{path}: truncated PCD binary_compressed data")
        csize, usize = (int(v) for v in np.frombuffer(raw, dtype="<u4", count=2, offset=pos))
        if usize != n * dt.itemsize or len(raw) - pos - 8 < csize:
            raise DataError(
                f"{path}: PCD binary_compressed sizes do not fit {n} points ({csize} compressed, {usize} uncompressed bytes)"
            )
        try:
            data = lzf_decompress(raw[pos + 8 : pos + 8 + csize], usize)
        except DataError as e:
            raise DataError(f"{path}: corrupt PCD binary_compressed data ({e})") from None
        cols, off = {}, 0  # fields are stored one after the other (structure of arrays)
        for f, s, t, c in zip(fields, sizes, types, counts, strict=False):
            block = np.frombuffer(data, dtype="<" + _PCD_TYPES[(t, s)], count=n * c, offset=off).reshape(n, c)
            cols[f] = block[:, 0].astype(np.float64)
            off += n * s * c
    else:
        raise DataError(f"{path}: PCD DATA {kind!r} is not supported (ascii, binary or binary_compressed)")
    shape = (height, width, 3) if height > 1 else (n, 3)
    pts = np.stack([cols["x"], cols["y"], cols["z"]], axis=1).reshape(shape)
    nrm = None
    if all(f in fields for f in ("normal_x", "normal_y", "normal_z")):
        nrm = np.stack([cols["normal_x"], cols["normal_y"], cols["normal_z"]], axis=1).reshape(shape)
    return pts, nrm


# ------------------------------------------------------------------------------ images, intrinsics
def read_depth_png(path: str | Path) -> np.ndarray:
    """A single-channel PNG as an ``(H, W)`` array of its raw values (uint8 or uint16).

    Raises :class:`DataError` for a missing or unreadable file or an image with colour channels."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - depends on the environment
        raise InputError('reading PNG images needs Pillow: pip install "ucope[images]"') from None
    try:
        with Image.open(path) as im:
            arr = np.array(im)
    except Exception as e:  # Pillow raises many types on corrupt files
        raise DataError(f"{path}: not a readable image ({type(e).__name__}: {e})") from None
    if arr.ndim != 2:
        raise DataError(f"{path}: a depth image or mask must have one channel, got shape {arr.shape}")
    return arr


def read_mask_png(path: str | Path) -> np.ndarray:
    """A mask PNG as an ``(H, W)`` array of its raw values (non-zero = object, or label values)."""
    return read_depth_png(path)


def read_intrinsics(path: str | Path) -> np.ndarray:
    """Camera intrinsics ``(fx, fy, cx, cy)`` from a JSON file.

    Accepted layouts: ``{"fx":..,"fy":..,"cx":..,"cy":..}``; ``{"K": [[fx,0,cx],[0,fy,cy],[0,0,1]]}`` or
    its row-wise flat form (BOP's ``cam_K``), also nested under ``"camera"``; a BOP
    ``scene_camera.json`` (``{"<image id>": {"cam_K": ...}}``) whose images all share one camera.
    """
    path = Path(path)
    d = read_json(path, "camera intrinsics")
    if isinstance(d, dict) and "camera" in d and isinstance(d["camera"], dict):
        d = d["camera"]
    if isinstance(d, dict) and d and all(isinstance(v, dict) and "cam_K" in v for v in d.values()):  # BOP scene_camera
        Ks = {json.dumps(v["cam_K"]) for v in d.values()}
        if len(Ks) > 1:
            raise DataError(
                f"{path}: a BOP scene_camera.json with {len(Ks)} different cameras; write the one you need to its own JSON"
            )
        d = next(iter(d.values()))
    try:
        if all(k in d for k in ("fx", "fy", "cx", "cy")):
            K = np.array([d["fx"], d["fy"], d["cx"], d["cy"]], dtype=np.float64)
        else:
            m = np.asarray(d.get("K", d.get("cam_K")), dtype=np.float64).reshape(3, 3)
            K = np.array([m[0, 0], m[1, 1], m[0, 2], m[1, 2]])
    except (TypeError, ValueError, AttributeError):
        raise DataError(f"{path}: expected fx, fy, cx, cy or a 3x3 K / cam_K matrix") from None
    if not np.all(np.isfinite(K)) or K[0] <= 0 or K[1] <= 0:
        raise DataError(f"{path}: intrinsics must be finite with positive focal lengths, got {K.tolist()}")
    return K
