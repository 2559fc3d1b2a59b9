"""The on-disk format of a data set: ``meta.json`` plus shards ``shard_NNNNN.npz``.

A shard holds ``n`` consecutive samples. Per-point arrays are concatenated with an ``offsets``
``(n + 1,)`` index; per-sample arrays are stacked. Normals are stored as float16. Files are written
atomically (temporary file + rename), so a shard either exists whole or not at all, and loading never
unpickles anything (``allow_pickle=False``).
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DataError
from ..fileio import atomic_write_bytes, open_regular
from ..versions import DATA_FORMAT_VERSION as FORMAT_VERSION

__all__ = ["FORMAT_VERSION", "write_shard", "read_shard", "shard_name"]

_POINT_FIELDS = ("points", "normals", "part_labels")
_STACK_FIELDS = (
    "cam_from_part",
    "size_m",
    "joint_type",
    "joint_pivot",
    "joint_axis",
    "joint_state",
    "cam_from_object",
    "intrinsics",
)


def shard_name(shard: int) -> str:
    return f"shard_{shard:05d}.npz"


def write_shard(path: str | os.PathLike, samples: list[dict]) -> None:
    """Write samples (dicts as made by :func:`ucope.data.sample.sample_from_view`) as one shard."""
    import io

    arrays: dict[str, np.ndarray] = {"format_version": np.array(FORMAT_VERSION)}
    counts = np.array([len(s["points"]) for s in samples], dtype=np.int64)
    arrays["offsets"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    arrays["points"] = np.concatenate([s["points"] for s in samples]).astype(np.float32)
    arrays["normals"] = np.concatenate([s["normals"] for s in samples]).astype(np.float16)
    arrays["part_labels"] = np.concatenate([s["part_labels"] for s in samples]).astype(np.uint8)
    for k in _STACK_FIELDS:
        arrays[k] = np.stack([np.asarray(s[k]) for s in samples])
    arrays["index"] = np.array([s["index"] for s in samples], dtype=np.int64)
    arrays["instance_id"] = np.array([s["instance_id"] for s in samples])
    arrays["category"] = np.array([s["category"] for s in samples])
    if all("source" in s for s in samples):  # the instance's model file (categories of your own objects)
        arrays["source"] = np.array([str(s["source"]) for s in samples])
    if all("bg_points" in s for s in samples):
        bg = np.array([len(s["bg_points"]) for s in samples], dtype=np.int64)
        arrays["bg_offsets"] = np.concatenate([[0], np.cumsum(bg)]).astype(np.int64)
        arrays["bg_points"] = np.concatenate([np.asarray(s["bg_points"], np.float32).reshape(-1, 3) for s in samples])
        arrays["bg_rank"] = np.concatenate([np.asarray(s["bg_rank"], np.float32).reshape(-1) for s in samples]).astype(np.float16)
        arrays["bg_clutter"] = np.concatenate([np.asarray(s["bg_clutter"], bool).reshape(-1) for s in samples])
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def read_shard(path: str | os.PathLike, num_parts: int | None = None, category: str | None = None) -> list[dict]:
    """Read a shard back into a list of sample dicts.

    Args:
        num_parts, category: what ``meta.json`` says (checked when given).

    Raises:
        DataError: naming the file: missing, not a regular file (a FIFO...), truncated or corrupt,
            another format version, inconsistent offsets or array lengths, labels outside
            ``[0, num_parts)``, non-finite points, poses or sizes, samples of another category.
    """
    path = Path(path)
    if not path.exists():
        raise DataError(f"shard {path} does not exist (was the data set generated completely?)")
    try:
        with open_regular(path, "shard") as f, np.load(f, allow_pickle=False) as z:  # a FIFO is refused, not waited on
            data = {k: z[k] for k in z.files}
    except DataError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError, zipfile.LargeZipFile) as e:
        raise DataError(
            f"shard {path} is truncated or corrupt ({type(e).__name__}: {e}); delete it and re-run `ucope generate` to rebuild it"
        ) from None
    try:
        if int(data["format_version"]) != FORMAT_VERSION:
            raise DataError(f"shard {path} has format version {int(data['format_version'])}, this ucope reads {FORMAT_VERSION}")
        off = data["offsets"]
        n = len(off) - 1
        _check_shard(path, data, n, num_parts, category)
        out = []
        for i in range(n):
            a, b = int(off[i]), int(off[i + 1])
            s = {
                "points": data["points"][a:b],
                "normals": data["normals"][a:b].astype(np.float32),
                "part_labels": data["part_labels"][a:b].astype(np.int64),
            }
            for k in _STACK_FIELDS:
                s[k] = data[k][i]
            s["joint_type"] = s["joint_type"].astype(np.int64)
            if "bg_offsets" in data:
                c, d = int(data["bg_offsets"][i]), int(data["bg_offsets"][i + 1])
                s["bg_points"] = data["bg_points"][c:d]
                s["bg_rank"] = data["bg_rank"][c:d].astype(np.float32)
                s["bg_clutter"] = data["bg_clutter"][c:d]
            s["category"] = str(data["category"][i])
            s["instance_id"] = str(data["instance_id"][i])
            if "source" in data:
                s["source"] = str(data["source"][i])
            s["index"] = int(data["index"][i])
            out.append(s)
        return out
    except KeyError as e:
        raise DataError(f"shard {path} lacks array {e}; it is corrupt or not a ucope shard") from None
    except (IndexError, ValueError, TypeError) as e:
        raise DataError(f"shard {path} is inconsistent ({e}); it is corrupt or not a ucope shard") from None


def _check_shard(path, data: dict, n: int, num_parts: int | None, category: str | None) -> None:
    """The structural checks of :func:`read_shard` (vectorised over the shard)."""
    off = data["offsets"]
    P = len(data["points"])
    if n < 1 or off.ndim != 1 or off[0] != 0 or off[-1] != P or np.any(np.diff(off) < 0):
        raise DataError(
            f"shard {path} has inconsistent offsets (first {off[:1].tolist()}, last {off[-1:].tolist()}, {P} points); it is "
            "corrupt"
        )
    for k in ("normals", "part_labels"):
        if len(data[k]) != P:
            raise DataError(f"shard {path}: {k} has {len(data[k])} rows for {P} points; it is corrupt")
    for k in _STACK_FIELDS + ("index", "instance_id", "category") + (("source",) if "source" in data else ()):
        if len(data[k]) != n:
            raise DataError(f"shard {path}: {k} has {len(data[k])} entries for {n} samples; it is corrupt")
    if not np.all(np.isfinite(data["points"])):
        raise DataError(f"shard {path} holds non-finite points; it is corrupt")
    for k in ("cam_from_part", "size_m", "joint_axis", "joint_state", "cam_from_object"):
        if not np.all(np.isfinite(data[k])):
            raise DataError(f"shard {path} holds non-finite {k}; it is corrupt")
    if np.any(data["size_m"] <= 0):
        raise DataError(f"shard {path} holds non-positive part sizes; it is corrupt")
    K = data["size_m"].shape[1] if data["size_m"].ndim == 3 else None
    if num_parts is not None and K != num_parts:
        raise DataError(f"shard {path} holds samples of {K} parts, meta.json says {num_parts}")
    labels = data["part_labels"]
    if K is not None and len(labels) and (int(labels.min()) < 0 or int(labels.max()) >= K):
        raise DataError(
            f"shard {path} holds part labels {int(labels.min())}..{int(labels.max())}, outside 0..{K - 1}; it is corrupt"
        )
    if "bg_offsets" in data:
        bo, M = data["bg_offsets"], len(data["bg_points"])
        if (
            len(bo) != n + 1
            or bo[0] != 0
            or bo[-1] != M
            or np.any(np.diff(bo) < 0)
            or len(data["bg_rank"]) != M
            or len(data["bg_clutter"]) != M
        ):
            raise DataError(f"shard {path} has inconsistent background offsets; it is corrupt")
        if not np.all(np.isfinite(data["bg_points"])):
            raise DataError(f"shard {path} holds non-finite background points; it is corrupt")
    if category is not None and np.any(data["category"] != category):
        raise DataError(f"shard {path} holds {sorted(set(map(str, data['category'])))} samples, meta.json says {category!r}")
