"""Reading user point clouds and depth images: ``.npy``, ``.npz``, ``.ply``, ``.pcd``, ``.xyz``/``.txt``, PNG depth.

Every reader returns float64 ``(N, 3)`` points (and ``(N, 3)`` normals when the file has them, else
``None``), in the file's own frame and units (metres expected). Bad files raise
:class:`ucope.errors.DataError` naming the file and the problem.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError

__all__ = ["read_point_cloud", "read_depth_png", "read_intrinsics", "read_mask_png", "POINT_CLOUD_SUFFIXES"]

POINT_CLOUD_SUFFIXES = (".npy", ".npz", ".ply", ".pcd", ".xyz", ".txt", ".pts")


def _split_columns(path: Path, arr: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    arr = np.asarray(arr)
    if arr.ndim != 2 or arr.shape[1] not in (3, 6):
        raise DataError(f"{path}: expected an (N, 3) array of points or (N, 6) of points and normals, got shape {arr.shape}")
    try:
        arr = arr.astype(np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{path}: point array is not numeric (dtype {arr.dtype})") from None
    return arr[:, :3], (arr[:, 3:6] if arr.shape[1] == 6 else None)


def read_point_cloud(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Points and (optional) normals of a point cloud file.

    Formats: ``.npy`` ((N, 3) or (N, 6) array), ``.npz`` (``points`` and optional ``normals``),
    ``.xyz``/``.txt``/``.pts`` (whitespace or comma separated, 3 or 6 columns, ``#`` comments),
    ``.ply`` (ASCII or binary; ``x y z`` and optional ``nx ny nz`` vertex properties) and ``.pcd``
    (ASCII or binary; fields ``x y z`` and optional ``normal_x normal_y normal_z``).

    Returns:
        ``points (N, 3)`` float64 and ``normals (N, 3)`` float64 or ``None``.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            return _split_columns(path, np.load(path, allow_pickle=False))
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                if "points" not in z:
                    raise DataError(f"{path}: an .npz point cloud needs a 'points' array (found {sorted(z.files)})")
                pts, _ = _split_columns(path, z["points"])
                nrm = _split_columns(path, z["normals"])[0] if "normals" in z else None
                return pts, nrm
        if suffix in (".xyz", ".txt", ".pts"):
            text = path.read_text(encoding="utf-8", errors="strict").replace(",", " ")
            rows = [ln.split("#")[0].split() for ln in text.splitlines()]
            rows = [r for r in rows if r]
            if not rows:
                raise DataError(f"{path}: the file holds no points")
            widths = {len(r) for r in rows}
            if len(widths) != 1:
                raise DataError(f"{path}: rows have different numbers of columns ({sorted(widths)})")
            return _split_columns(path, np.array(rows, dtype=np.float64))
        if suffix == ".ply":
            return _read_ply(path)
        if suffix == ".pcd":
            return _read_pcd(path)
    except DataError:
        raise
    except (OSError, ValueError, UnicodeDecodeError, EOFError, KeyError) as e:
        raise DataError(f"{path}: cannot read the point cloud ({type(e).__name__}: {e})") from None
    raise InputError(f"{path}: unsupported point cloud format {suffix!r}; use one of {', '.join(POINT_CLOUD_SUFFIXES)}")


def _read_ply(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    import trimesh

    try:
        geom = trimesh.load(path, process=False)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise DataError(f"{path}: not a readable PLY file ({type(e).__name__}: {e})") from None
    verts = np.asarray(getattr(geom, "vertices", np.zeros((0, 3))), dtype=np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3 or len(verts) == 0:
        raise DataError(f"{path}: the PLY file holds no vertices")
    nrm = None
    attrs = getattr(geom, "metadata", {}).get("_ply_raw", {}).get("vertex", {}).get("data")
    if attrs is not None and all(k in attrs.dtype.names for k in ("nx", "ny", "nz")):
        nrm = np.stack([attrs["nx"], attrs["ny"], attrs["nz"]], axis=1).astype(np.float64).reshape(-1, 3)
        if len(nrm) != len(verts):
            nrm = None
    return verts, nrm


_PCD_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4", ("I", 8): "i8",
              ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}


def _read_pcd(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    raw = path.read_bytes()
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
            break
    try:
        fields = header["FIELDS"]
        sizes = [int(s) for s in header["SIZE"]]
        types = header["TYPE"]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
        n = int(header["POINTS"][0]) if "POINTS" in header else int(header["WIDTH"][0]) * int(header["HEIGHT"][0])
    except (KeyError, ValueError, IndexError):
        raise DataError(f"{path}: PCD header lacks FIELDS/SIZE/TYPE/POINTS") from None
    if not ("x" in fields and "y" in fields and "z" in fields):
        raise DataError(f"{path}: PCD file has no x y z fields (fields: {fields})")
    kind = header["DATA"][0].lower()
    dtype = []
    for f, s, t, c in zip(fields, sizes, types, counts):
        code = _PCD_TYPES.get((t.upper(), s))
        if code is None:
            raise DataError(f"{path}: unsupported PCD field type {t}{s}")
        dtype.append((f if f != "_" else f"_pad{len(dtype)}", "<" + code, (c,)) if c > 1 else (f if f != "_" else f"_pad{len(dtype)}", "<" + code))
    dt = np.dtype(dtype)
    if kind == "ascii":
        vals = np.loadtxt(raw[pos:].decode("ascii").splitlines(), dtype=np.float64, ndmin=2)
        if vals.shape[0] != n:
            raise DataError(f"{path}: header says {n} points, found {vals.shape[0]} rows")
        cols = {}
        i = 0
        for f, c in zip(fields, counts):
            cols[f] = vals[:, i]
            i += c
        get = cols.__getitem__
    elif kind == "binary":
        if len(raw) - pos < n * dt.itemsize:
            raise DataError(f"{path}: truncated PCD data ({len(raw) - pos} bytes for {n} points of {dt.itemsize})")
        arr = np.frombuffer(raw, dtype=dt, count=n, offset=pos)
        get = lambda f: arr[f].astype(np.float64)  # noqa: E731
    else:
        raise DataError(f"{path}: PCD DATA {kind!r} is not supported (use ascii or binary)")
    pts = np.stack([get("x"), get("y"), get("z")], axis=1)
    nrm = None
    if all(f in fields for f in ("normal_x", "normal_y", "normal_z")):
        nrm = np.stack([get("normal_x"), get("normal_y"), get("normal_z")], axis=1)
    return pts, nrm


def read_depth_png(path: str | Path) -> np.ndarray:
    """A 16-bit (or 8-bit) single-channel depth PNG as an ``(H, W)`` uint16/uint8 array (raw units)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        from PIL import Image
    except ImportError:
        raise InputError("reading PNG depth needs Pillow: pip install 'ucope[images]'") from None
    try:
        with Image.open(path) as im:
            arr = np.array(im)
    except Exception as e:
        raise DataError(f"{path}: not a readable image ({type(e).__name__}: {e})") from None
    if arr.ndim != 2:
        raise DataError(f"{path}: a depth image must have one channel, got shape {arr.shape}")
    return arr


def read_mask_png(path: str | Path) -> np.ndarray:
    """A mask PNG as a boolean ``(H, W)`` array (non-zero = object)."""
    arr = read_depth_png(path)
    return arr != 0


def read_intrinsics(path: str | Path) -> np.ndarray:
    """Camera intrinsics ``(fx, fy, cx, cy)`` from a JSON file.

    Accepted layouts: ``{"fx":..,"fy":..,"cx":..,"cy":..}``; ``{"K": [[fx,0,cx],[0,fy,cy],[0,0,1]]}`` or
    its row-wise flat form (BOP's ``cam_K``), also nested under ``"camera"``; a BOP
    ``scene_camera.json`` (``{"<image id>": {"cam_K": ...}}``) whose images all share one camera.
    """
    path = Path(path)
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    except (OSError, ValueError) as e:
        raise DataError(f"{path}: not valid JSON ({e})") from None
    if isinstance(d, dict) and "camera" in d and isinstance(d["camera"], dict):
        d = d["camera"]
    if isinstance(d, dict) and d and all(isinstance(v, dict) and "cam_K" in v for v in d.values()):  # BOP scene_camera
        Ks = {json.dumps(v["cam_K"]) for v in d.values()}
        if len(Ks) > 1:
            raise DataError(f"{path}: a BOP scene_camera.json with {len(Ks)} different cameras; write the one you need to its own JSON")
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
