"""Exporting results for other tools: the BOP toolkit's results CSV here; ROS 2 messages, a URDF, geometry
(GLB / PLY / OBJ) and rerun recordings in :mod:`ucope.estimation.robot_export`, re-exported here.

* :func:`bop_rows`, :func:`frame_bop_rows`, :func:`write_bop_csv`, :func:`read_bop_csv`: the results CSV of
  ``bop_toolkit`` (``scripts/eval_bop*.py``), with the obj_id of every (object, part) written beside it;
* :func:`to_ros`, :func:`write_urdf`, :func:`urdf_names`, :func:`write_geometry`, :func:`write_rrd`: for a
  robot stack (:mod:`ucope.estimation.robot_export`).

BOP results CSV: one row per estimated part::

    scene_id,im_id,obj_id,score,R,t,time
    0,3,1,0.912,0.99 0.01 ... (9 values),12.5 -80.1 1204.3,0.041

* ``R``: the part's rotation ``cam_from_part[:3, :3]``, 9 values row-wise, separated by spaces;
* ``t``: ``cam_from_part[:3, 3]`` in **millimetres**, separated by spaces;
* ``score``: the part's score; ``time``: seconds for the whole image (the sum over its objects, the
  same on every row of one image, as the toolkit requires; -1 if unknown).

**obj_id of a part**: ``obj_id = base + k`` for part ``k`` of an object whose base id is ``base``
(default 1): a rigid object is ``base`` itself, a laptop's base and lid are ``base`` and ``base + 1``.
``ucope generate --images`` writes its ground truth (``scene_gt.json``) with the same rule and
``base = 1``. With several objects in one image (``--instances``) the objects are numbered on from the
base in instance order, so that every (object, part) of the image has its own obj_id (a mug after a
laptop at base 1 is 3); :func:`write_bop_csv` writes the obj_id of every (object, part) to
``<csv stem>.obj_ids.json`` beside the CSV. The "model" frame of every row is the ucope part frame
(its amodal box centred on the origin, the category's canonical axes; docs/conventions.md), as in the
ground truth ucope writes; a BOP data set whose model frames differ needs that offset applied.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError
from ..fileio import atomic_write_json, atomic_write_text
from .result import PoseResult
from .robot_export import to_ros, urdf_names, write_geometry, write_rrd, write_urdf

__all__ = [
    "BOP_CSV_HEADER",
    "BopRow",
    "bop_rows",
    "frame_bop_rows",
    "write_bop_csv",
    "read_bop_csv",
    "obj_id_map_path",
    "to_ros",
    "write_urdf",
    "urdf_names",
    "write_geometry",
    "write_rrd",
]

BOP_CSV_HEADER = ("scene_id", "im_id", "obj_id", "score", "R", "t", "time")


@dataclass
class BopRow:
    """One row of a BOP results CSV: ``R`` ``(3, 3)``, ``t_mm`` ``(3,)`` millimetres, ``time_s`` seconds (-1: unknown)."""

    scene_id: int
    im_id: int
    obj_id: int
    score: float
    R: np.ndarray
    t_mm: np.ndarray
    time_s: float = -1.0
    object: str = ""
    """What the obj_id stands for (written to the obj_id map beside the CSV): the object's name..."""
    part: str = ""
    """...and the part's label."""


def bop_rows(
    result: PoseResult, scene_id: int, im_id: int, obj_id: int = 1, time_s: float | None = None, name: str = ""
) -> list[BopRow]:
    """The rows of one object's result: part ``k`` gets ``obj_id + k``.

    Args:
        result: the object's estimate.
        scene_id, im_id: the image's BOP ids (non-negative integers).
        obj_id: the object's base id (>= 1); part ``k`` is written as ``obj_id + k``.
        time_s: seconds for the whole image; default the result's ``timings_ms["total"] / 1000``
            (-1 when it has none). Pass the image's total when it holds several objects.
        name: the object's name in the obj_id map (default its model or category).
    """
    for field_name, v in (("scene_id", scene_id), ("im_id", im_id)):
        if int(v) != v or int(v) < 0:
            raise InputError(f"BOP {field_name} must be a non-negative integer, got {v!r}")
    if int(obj_id) != obj_id or int(obj_id) < 1:
        raise InputError(f"BOP obj_id must be a positive integer, got {obj_id!r}")
    if time_s is None:
        t = result.timings_ms.get("total")
        time_s = -1.0 if t is None else float(t) / 1000.0
    return [
        BopRow(
            int(scene_id),
            int(im_id),
            int(obj_id) + k,
            float(p.score),
            np.asarray(p.cam_from_part, np.float64)[:3, :3],
            1000.0 * np.asarray(p.cam_from_part, np.float64)[:3, 3],
            float(time_s),
            name or result.model or result.category,
            p.label,
        )
        for k, p in enumerate(result.parts)
    ]


def _fmt(values) -> str:
    return " ".join(f"{float(v):.6f}" for v in np.asarray(values, np.float64).reshape(-1))


def obj_id_map_path(csv_path: str | os.PathLike) -> Path:
    """Where :func:`write_bop_csv` writes the obj_id map of a CSV: ``<stem>.obj_ids.json`` beside it."""
    p = Path(csv_path)
    return p.with_name(p.stem + ".obj_ids.json")


def write_bop_csv(path: str | os.PathLike, rows: Iterable[BopRow], obj_id_map: bool = True) -> Path:
    """Write rows as a BOP results CSV (header line, then one line per row), atomically, and (with
    ``obj_id_map``) the obj_id of every (object, part) to :func:`obj_id_map_path`::

        {"format": "ucope-bop-obj-ids/1", "csv": "results.csv",
         "obj_ids": [{"scene_id": 0, "im_id": 42, "obj_id": 1, "object": "1: laptop", "part": "base"}, ...]}

    Raises :class:`InputError` when the rows of one image have different times (the toolkit needs one
    time per image) or when one obj_id stands for two different (object, part) in one image."""
    rows = list(rows)
    times: dict[tuple[int, int], float] = {}
    owner: dict[tuple[int, int, int], tuple[str, str]] = {}
    for r in rows:
        key = (r.scene_id, r.im_id)
        if times.setdefault(key, r.time_s) != r.time_s:
            raise InputError(
                f"scene {r.scene_id} image {r.im_id} has rows with different times ({times[key]} and {r.time_s} s); "
                "BOP needs one time per image (the sum over its objects)"
            )
        what = (r.object, r.part)
        if r.object and owner.setdefault((r.scene_id, r.im_id, r.obj_id), what) != what:
            first = owner[(r.scene_id, r.im_id, r.obj_id)]
            raise InputError(
                f"scene {r.scene_id} image {r.im_id}: obj_id {r.obj_id} would stand for both {first[0]} {first[1]!r} and "
                f"{r.object} {r.part!r}; give each object its own --bop-obj-id range"
            )
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(BOP_CSV_HEADER)
    for r in rows:
        w.writerow([r.scene_id, r.im_id, r.obj_id, f"{r.score:.6f}", _fmt(r.R), _fmt(r.t_mm), f"{r.time_s:.6f}"])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, buf.getvalue())
    if obj_id_map:
        entries = sorted({(r.scene_id, r.im_id, r.obj_id, r.object, r.part) for r in rows}, key=lambda e: (e[0], e[1], e[2]))
        atomic_write_json(
            obj_id_map_path(path),
            {
                "format": "ucope-bop-obj-ids/1",
                "csv": path.name,
                "obj_ids": [{"scene_id": a, "im_id": b, "obj_id": c, "object": o, "part": p} for a, b, c, o, p in entries],
            },
        )
    return path


def read_bop_csv(path: str | os.PathLike) -> list[BopRow]:
    """Read a BOP results CSV (as :func:`write_bop_csv` writes it, or the toolkit's own files).

    Raises :class:`DataError` naming the file and line for a missing file, a wrong header or a bad row."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataError(f"{path} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read {path}: {e}") from None
    lines = list(csv.reader(io.StringIO(text)))
    if not lines or tuple(c.strip() for c in lines[0]) != BOP_CSV_HEADER:
        raise DataError(f"{path}: the first line must be the header {','.join(BOP_CSV_HEADER)}")
    out = []
    for n, row in enumerate(lines[1:], start=2):
        if not row:
            continue
        try:
            if len(row) != 7:
                raise ValueError(f"{len(row)} fields instead of 7")
            R = np.array(row[4].split(), np.float64)
            t = np.array(row[5].split(), np.float64)
            if R.shape != (9,) or t.shape != (3,):
                raise ValueError(f"R needs 9 values and t 3, got {R.size} and {t.size}")
            out.append(BopRow(int(row[0]), int(row[1]), int(row[2]), float(row[3]), R.reshape(3, 3), t, float(row[6])))
        except ValueError as e:
            raise DataError(f"{path}, line {n}: {e}") from None
    return out


def frame_bop_rows(
    results: Sequence[tuple], scene_id: int, im_id: int, time_s: float | None = None, base: int | None = None
) -> list[BopRow]:
    """The rows of every object of one image.

    Args:
        results: ``(result, base obj_id)`` or ``(result, base obj_id, name)`` per object; with ``base``
            given, the objects' own bases are ignored and the objects are numbered on from ``base`` in
            list order (object ``i`` starts after the parts of objects ``0 .. i-1``), so that every
            (object, part) of the image has its own obj_id.
        time_s: the image's time; default the sum of the objects' times (-1 if one is unknown).
    """
    if time_s is None:
        ts = [item[0].timings_ms.get("total") for item in results]
        time_s = -1.0 if any(t is None for t in ts) else sum(float(t) for t in ts) / 1000.0
    rows: list[BopRow] = []
    next_id = base
    for item in results:
        r, own = item[0], item[1]
        name = item[2] if len(item) > 2 else ""
        start = own if next_id is None else next_id
        rows += bop_rows(r, scene_id, im_id, start, time_s, name)
        if next_id is not None:
            next_id += len(r.parts)
    return rows
