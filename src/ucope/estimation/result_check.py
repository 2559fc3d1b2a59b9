"""The checks of a ``ucope-result/2`` JSON form beyond its JSON Schema (:func:`validate`).

:mod:`ucope.estimation.result` re-exports :func:`validate`; :meth:`~ucope.estimation.result.PoseResult.from_dict`
and :meth:`~ucope.estimation.result.PoseResult.load` call it, so a result that loads can be drawn and exported.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import DataError
from ..versions import RESULT_FORMAT

__all__ = ["validate", "ROTATION_TOL", "UNIT_TOL"]

ROTATION_TOL = 1e-4
"""Largest ``|R^T R - I|`` entry (and ``|det R - 1|``) a stored rotation may have (7 decimals are stored)."""

UNIT_TOL = 1e-4
"""Largest ``| |axis| - 1 |`` a stored joint axis may have."""

_RESULT_KEYS = {
    "format",
    "category",
    "score",
    "warnings",
    "parts",
    "joints",
    "part_labels",
    "num_points",
    "timings_ms",
    "estimates",
    "model",
    "ucope_version",
    "conventions_version",
    "errors",
    "stages",
}
_STAGE_KEYS = {"name", "ms", "changed"}
_CHANGED_KEYS = {"parts", "rotation_deg", "translation_m", "size_m", "joint_state"}
_PART_KEYS = {"index", "label", "symmetry", "cam_from_part", "size_m", "score", "vote_score", "num_votes"}
_JOINT_KEYS = {"type", "parent", "child", "pivot_m", "axis", "state", "state_unit", "score"}
_ERROR_KEYS = {"parts", "joints", "segmentation_iou", "segmentation_accuracy"}
_PART_ERROR_KEYS = {"rotation_deg", "translation_m", "translation_norm", "iou"}
_JOINT_ERROR_KEYS = {"joint_type", "axis_deg", "axis_line_deg", "pivot_m", "state_error", "state_unit", "axis_flipped"}


def validate(d: Any) -> dict:
    """Check a ``ucope-result/2`` JSON form (a dict as :meth:`~ucope.estimation.result.PoseResult.to_dict` writes it).

    Beyond the JSON Schema (:func:`~ucope.estimation.result.result_schema`): part ``index`` ``k`` at position ``k``; rigid
    ``cam_from_part`` (last row ``[0, 0, 0, 1]``, orthonormal rotation with determinant 1, within
    :data:`ROTATION_TOL`); joint ``parent`` / ``child`` in ``[0, K)``, different, each child once and no
    cycle; unit ``axis`` (within :data:`UNIT_TOL`); a ``pivot_m`` for every revolute joint and none for a
    prismatic one; ``part_labels`` in ``[-1, K)``; ``num_points == len(part_labels)``; every number
    finite (no NaN / Inf, no booleans); no unknown fields, ``errors`` included.

    Returns ``d``; raises :class:`~ucope.errors.DataError` naming the first bad field
    (``parts[1].cam_from_part: ...``).
    """
    if not isinstance(d, dict) or d.get("format") != RESULT_FORMAT:
        found = d.get("format") if isinstance(d, dict) else None
        raise DataError(f"not a ucope result (format {found!r}, expected {RESULT_FORMAT!r})")
    _keys(d, _RESULT_KEYS, _RESULT_KEYS - {"errors", "stages"}, "result")
    _string(d["category"], "category")
    parts = d["parts"]
    if not isinstance(parts, list) or not parts:
        raise _bad("parts", "must be a non-empty list")
    K = len(parts)
    for k, p in enumerate(parts):
        _check_part(p, k)
    joints = d["joints"]
    if not isinstance(joints, list):
        raise _bad("joints", "must be a list")
    _check_joints(joints, K)
    _check_labels(d["part_labels"], d["num_points"], K)
    _check_summary(d, parts)
    if "errors" in d:
        _check_errors(d["errors"], K, len(joints))
    if "stages" in d:
        _check_stages(d["stages"])
    return d


def _check_part(p, k: int) -> None:
    """Part ``k`` of ``parts``."""
    w = f"parts[{k}]"
    _keys(p, _PART_KEYS, _PART_KEYS - {"vote_score"}, w)
    if _integer(p["index"], f"{w}.index") != k:
        raise _bad(f"{w}.index", f"must be {k} (its position in the list), got {p['index']}")
    _string(p["label"], f"{w}.label")
    if p["symmetry"] not in ("none", "y"):
        raise _bad(f"{w}.symmetry", f"must be 'none' or 'y', got {p['symmetry']!r}")
    _check_transform(p["cam_from_part"], f"{w}.cam_from_part")
    size = _array(p["size_m"], (3,), f"{w}.size_m")
    if (size < 0).any():
        raise _bad(f"{w}.size_m", f"must be >= 0, got {size.tolist()}")
    _number(p["score"], f"{w}.score", 0.0, 1.0)
    if p.get("vote_score") is not None:
        _number(p["vote_score"], f"{w}.vote_score", 0.0, 1.0)
    _integer(p["num_votes"], f"{w}.num_votes", 0)


def _check_joints(joints: list, K: int) -> None:
    """Every joint of a result with ``K`` parts, then that the joints form a forest."""
    parent_of: dict[int, int] = {}
    for i, j in enumerate(joints):
        w = f"joints[{i}]"
        _keys(j, _JOINT_KEYS, _JOINT_KEYS, w)
        if j["type"] not in ("revolute", "prismatic"):
            raise _bad(f"{w}.type", f"must be 'revolute' or 'prismatic', got {j['type']!r}")
        parent = _integer(j["parent"], f"{w}.parent", 0, K - 1)
        child = _integer(j["child"], f"{w}.child", 0, K - 1)
        if parent == child:
            raise _bad(w, f"parent and child are both part {child}")
        if child in parent_of:
            raise _bad(f"{w}.child", f"part {child} is the child of two joints")
        parent_of[child] = parent
        _check_joint_geometry(j, w)
    for child in parent_of:  # the joints form a forest: following parents never comes back
        seen, k = {child}, child
        while k in parent_of:
            k = parent_of[k]
            if k in seen:
                raise _bad("joints", f"the joints form a cycle through part {k}")
            seen.add(k)


def _check_joint_geometry(j: dict, w: str) -> None:
    """A joint's unit axis, its pivot (revolute only), its state and unit, its score."""
    axis = _array(j["axis"], (3,), f"{w}.axis")
    if abs(float(np.linalg.norm(axis)) - 1.0) > UNIT_TOL:
        raise _bad(f"{w}.axis", f"must be a unit vector, got length {np.linalg.norm(axis):.6g}")
    if j["type"] == "revolute":
        if j.get("pivot_m") is None:
            raise _bad(f"{w}.pivot_m", "a revolute joint needs a pivot (a point on its axis), got null")
        _array(j["pivot_m"], (3,), f"{w}.pivot_m")
    elif j.get("pivot_m") is not None:
        raise _bad(f"{w}.pivot_m", "a prismatic joint has no pivot (null)")
    _number(j["state"], f"{w}.state")
    unit = {"revolute": "rad", "prismatic": "m"}[j["type"]]
    if j["state_unit"] != unit:
        raise _bad(f"{w}.state_unit", f"a {j['type']} joint's state is in {unit!r}, got {j['state_unit']!r}")
    _number(j["score"], f"{w}.score", 0.0, 1.0)


def _check_labels(labels, num_points, K: int) -> None:
    """``part_labels``: integers in ``[-1, K)``, as many as ``num_points``."""
    if not isinstance(labels, list):
        raise _bad("part_labels", "must be a list of integers")
    lab = np.asarray(labels, dtype=object)
    if lab.size and not all(isinstance(v, int) and not isinstance(v, bool) for v in labels):
        bad = next(v for v in labels if not (isinstance(v, int) and not isinstance(v, bool)))
        raise _bad("part_labels", f"must hold integers, got {bad!r}")
    if lab.size:
        arr = np.asarray(labels, np.int64)
        if arr.min() < -1 or arr.max() >= K:
            raise _bad("part_labels", f"must lie in [-1, {K - 1}] (K = {K}), got values in [{arr.min()}, {arr.max()}]")
    if _integer(num_points, "num_points", 0) != len(labels):
        raise _bad("num_points", f"is {num_points} but part_labels holds {len(labels)} labels (one per input point)")


def _check_summary(d: dict, parts: list) -> None:
    """The object's ``score`` (its smallest part score), ``warnings``, ``timings_ms``, ``estimates`` and version
    strings."""
    score = _number(d["score"], "score", 0.0, 1.0)
    lowest = min(float(p["score"]) for p in parts)
    if abs(score - lowest) > 1e-4:
        raise _bad("score", f"must be the smallest part score ({lowest:.5g}), got {score}")
    if not isinstance(d["warnings"], list):
        raise _bad("warnings", "must be a list of strings")
    for i, w in enumerate(d["warnings"]):
        _string(w, f"warnings[{i}]")
    if not isinstance(d["timings_ms"], dict):
        raise _bad("timings_ms", "must be an object of {stage: milliseconds}")
    for key, v in d["timings_ms"].items():
        _number(v, f"timings_ms.{key}", 0.0)
    _integer(d["estimates"], "estimates", 1)
    for key in ("model", "ucope_version", "conventions_version"):
        _string(d[key], key)


def _check_stages(stages) -> None:
    """The stage records of a result (:class:`ucope.stages.base.StageRecord`)."""
    if not isinstance(stages, list):
        raise _bad("stages", "must be a list of stage records")
    for i, st in enumerate(stages):
        w = f"stages[{i}]"
        _keys(st, _STAGE_KEYS, _STAGE_KEYS, w)
        _string(st["name"], f"{w}.name")
        _number(st["ms"], f"{w}.ms", 0.0)
        _keys(st["changed"], _CHANGED_KEYS, set(), f"{w}.changed")
        for key, v in st["changed"].items():
            if key == "parts":
                if not isinstance(v, list):
                    raise _bad(f"{w}.changed.parts", "must be a list of part names")
                for j, name in enumerate(v):
                    _string(name, f"{w}.changed.parts[{j}]")
            else:
                _number(v, f"{w}.changed.{key}", 0.0)


def _bad(where: str, problem: str):
    return DataError(f"invalid ucope result: {where}: {problem}")


def _keys(d, allowed: set[str], required: set[str], where: str) -> dict:
    if not isinstance(d, dict):
        raise _bad(where, f"must be an object, got {type(d).__name__}")
    missing = sorted(required - set(d))
    if missing:
        raise _bad(where, f"missing {', '.join(missing)}")
    extra = sorted(set(d) - allowed)
    if extra:
        raise _bad(where, f"unknown field(s) {', '.join(map(repr, extra))} (the format is strict)")
    return d


def _number(v, where: str, lo: float | None = None, hi: float | None = None) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise _bad(where, f"must be a number, got {v!r}")
    x = float(v)
    if not np.isfinite(x):
        raise _bad(where, f"must be finite, got {x}")
    if (lo is not None and x < lo) or (hi is not None and x > hi):
        rng = f"[{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]"
        raise _bad(where, f"must lie in {rng}, got {x}")
    return x


def _integer(v, where: str, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise _bad(where, f"must be an integer, got {v!r}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise _bad(where, f"must lie in [{lo}, {hi}], got {v}")
    return v


def _string(v, where: str) -> str:
    if not isinstance(v, str):
        raise _bad(where, f"must be a string, got {v!r}")
    return v


def _array(v, shape: tuple[int, ...], where: str) -> np.ndarray:
    """A nested list of numbers of exactly ``shape`` (no bools, no NaN / Inf)."""

    def walk(x, depth: int, path: str):
        if depth == len(shape):
            _number(x, where + path)
            return
        if not isinstance(x, list) or len(x) != shape[depth]:
            n = len(x) if isinstance(x, list) else type(x).__name__
            raise _bad(where + path, f"must be a list of {shape[depth]}, got {n}")
        for i, item in enumerate(x):
            walk(item, depth + 1, f"{path}[{i}]")

    walk(v, 0, "")
    return np.asarray(v, np.float64)


def _check_transform(v, where: str) -> None:
    T = _array(v, (4, 4), where)
    if np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max() > 1e-9:
        raise _bad(where, f"the last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    R = T[:3, :3]
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if err > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
        raise _bad(where, f"the rotation is not orthonormal with determinant 1 (|R^T R - I| = {err:.2g}, det = {det:.6g})")


def _error_entries(e: dict, field: str, n: int, allowed: set[str]):
    """``(where, entry)`` of the non-null entries of ``e[field]``, a list of ``n`` objects with keys in ``allowed``."""
    if not isinstance(e[field], list) or len(e[field]) != n:
        raise _bad(f"errors.{field}", f"must be a list of {n} (one per {field[:-1]})")
    for i, entry in enumerate(e[field]):
        if entry is not None:
            _keys(entry, allowed, set(), f"errors.{field}[{i}]")
            yield f"errors.{field}[{i}]", entry


def _check_errors(e, K: int, J: int) -> None:
    _keys(e, _ERROR_KEYS, {"parts", "joints"}, "errors")
    for w, pe in _error_entries(e, "parts", K, _PART_ERROR_KEYS):
        for key, v in pe.items():
            _number(v, f"{w}.{key}", 0.0, 1.0 if key == "iou" else None)
    for w, je in _error_entries(e, "joints", J, _JOINT_ERROR_KEYS):
        for key, v in je.items():
            if key == "joint_type":
                if v not in ("revolute", "prismatic"):
                    raise _bad(f"{w}.joint_type", f"must be 'revolute' or 'prismatic', got {v!r}")
            elif key == "state_unit":
                if v not in ("deg", "m"):
                    raise _bad(f"{w}.state_unit", f"must be 'deg' or 'm', got {v!r}")
            elif key == "axis_flipped":
                if not isinstance(v, bool):
                    raise _bad(f"{w}.axis_flipped", f"must be true or false, got {v!r}")
            elif not (key == "pivot_m" and v is None):
                _number(v, f"{w}.{key}", 0.0)
    seg = e.get("segmentation_iou")
    if seg is not None:
        if not isinstance(seg, list) or len(seg) != K:
            raise _bad("errors.segmentation_iou", f"must be null or a list of {K}")
        for k, v in enumerate(seg):
            if v is not None:
                _number(v, f"errors.segmentation_iou[{k}]", 0.0, 1.0)
    if e.get("segmentation_accuracy") is not None:
        _number(e["segmentation_accuracy"], "errors.segmentation_accuracy", 0.0, 1.0)
