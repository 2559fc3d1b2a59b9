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
from ..fileio import atomic_write_bytes
from ..versions import DATA_FORMAT_VERSION as FORMAT_VERSION

__all__ = ["FORMAT_VERSION", "write_shard", "read_shard", "shard_name"]

_POINT_FIELDS = ("points", "normals", "part_labels")
_STACK_FIELDS = ("cam_from_part", "size_m", "joint_type", "joint_pivot", "joint_axis", "joint_state", "cam_from_object", "intrinsics")


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
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def read_shard(path: str | os.PathLike) -> list[dict]:
    """Read a shard back into a list of sample dicts; a truncated or corrupt file raises
    :class:`DataError` naming the file."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise DataError(f"shard {path} does not exist (was the data set generated completely?)") from None
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError, zipfile.LargeZipFile) as e:
        raise DataError(f"shard {path} is truncated or corrupt ({type(e).__name__}: {e}); delete it and re-run `ucope generate` to rebuild it") from None
    try:
        if int(data["format_version"]) != FORMAT_VERSION:
            raise DataError(f"shard {path} has format version {int(data['format_version'])}, this ucope reads {FORMAT_VERSION}")
        off = data["offsets"]
        n = len(off) - 1
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
            s["category"] = str(data["category"][i])
            s["instance_id"] = str(data["instance_id"][i])
            s["index"] = int(data["index"][i])
            out.append(s)
        return out
    except KeyError as e:
        raise DataError(f"shard {path} lacks array {e}; it is corrupt or not a ucope shard") from None
    except (IndexError, ValueError, TypeError) as e:
        raise DataError(f"shard {path} is inconsistent ({e}); it is corrupt or not a ucope shard") from None
