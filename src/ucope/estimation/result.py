"""The result of a pose estimate, and its stable JSON form.

JSON form (``format: "ucope-result/1"``, JSON Schema: :func:`result_schema`, docs/formats.md; every
length in metres, angles in radians, camera frame = OpenCV: +x right, +y down, +z forward)::

    {
      "format": "ucope-result/1",
      "category": "laptop",
      "score": 0.83,                          # the object's confidence: its smallest part score
      "warnings": ["..."],                    # what looked wrong with the input or the estimate
      "parts": [{"index": 0, "label": "base", "symmetry": "none",
                 "cam_from_part": [[...4 floats...] x 4], "size_m": [x, y, z],
                 "score": 0.83, "vote_score": 0.91, "num_votes": 9400}, ...],
      "joints": [{"type": "revolute", "parent": 0, "child": 1,
                  "pivot_m": [x, y, z] | null, "axis": [x, y, z],
                  "state": 1.21, "state_unit": "rad", "score": 0.9}, ...],
      "part_labels": [0, 0, 1, -1, ...],      # one per input point; -1: not the object (NaN / Inf, background)
      "num_points": 12345,                    # input points
      "timings_ms": {"preprocess": ..., "encoder": ..., "pair_encoder": ..., "voting": ..., "total": ...},
      "stages": [{"name": "vote_parts", "ms": 8.1, "changed": {"parts": ["base", "lid"], ...}}, ...],
      "model": "laptop", "ucope_version": "0.2.0", "conventions_version": "1",
      "errors": {...}                         # optional: errors against a known ground truth
    }

``cam_from_part`` maps part-frame points to the camera frame (the part's amodal box is centred on the
part frame's origin and aligned with its axes: docs/conventions.md); ``size_m`` are the box extents
along the part's x, y, z. A part with ``symmetry: "y"`` has a meaningful y axis only. A prismatic
joint has no pivot (``null``). ``state`` is in the data sets' ``joint_state`` convention.

:func:`validate` checks a JSON form beyond what its JSON Schema can say (index ranges, a rigid last row,
orthonormal rotations, unit axes, finite numbers, a pivot for every revolute joint); :meth:`PoseResult.from_dict`
and :meth:`PoseResult.load` call it, so a result that loads can be drawn and exported.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError
from ..fileio import atomic_write_json, parse_json, read_json
from ..versions import CONVENTIONS_VERSION, RESULT_FORMAT, __version__

__all__ = ["RESULT_FORMAT", "PartEstimate", "JointEstimate", "PoseResult", "result_schema", "validate", "SCHEMA_FILE"]

SCHEMA_FILE = Path(__file__).with_name("result.schema.json")
"""The JSON Schema (draft 2020-12) of ``ucope-result/1`` and ``ucope-results/1``, shipped in the package."""


def result_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a result file: one object's ``ucope-result/1`` or one frame's
    ``ucope-results/1`` (``$defs/result`` and ``$defs/results``). Validate with any JSON Schema library,
    e.g. ``jsonschema.validate(json.load(f), result_schema())``; docs/formats.md describes every field."""
    return read_json(SCHEMA_FILE)


def _floats(a, ndigits: int = 7) -> Any:
    return np.round(np.asarray(a, dtype=np.float64), ndigits).tolist()


# --------------------------------------------------------------------------------------------------
# Validation of the JSON form
# --------------------------------------------------------------------------------------------------

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


def _check_errors(e, K: int, J: int) -> None:
    _keys(e, _ERROR_KEYS, {"parts", "joints"}, "errors")
    if not isinstance(e["parts"], list) or len(e["parts"]) != K:
        raise _bad("errors.parts", f"must be a list of {K} (one per part)")
    for k, pe in enumerate(e["parts"]):
        if pe is None:
            continue
        w = f"errors.parts[{k}]"
        _keys(pe, _PART_ERROR_KEYS, set(), w)
        for key, v in pe.items():
            _number(v, f"{w}.{key}", 0.0, 1.0 if key == "iou" else None)
    if not isinstance(e["joints"], list) or len(e["joints"]) != J:
        raise _bad("errors.joints", f"must be a list of {J} (one per joint)")
    for i, je in enumerate(e["joints"]):
        if je is None:
            continue
        w = f"errors.joints[{i}]"
        _keys(je, _JOINT_ERROR_KEYS, set(), w)
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


def validate(d: Any) -> dict:
    """Check a ``ucope-result/1`` JSON form (a dict as :meth:`PoseResult.to_dict` writes it).

    Beyond the JSON Schema (:func:`result_schema`): part ``index`` ``k`` at position ``k``; rigid
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
    joints = d["joints"]
    if not isinstance(joints, list):
        raise _bad("joints", "must be a list")
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
    for child in parent_of:  # the joints form a forest: following parents never comes back
        seen, k = {child}, child
        while k in parent_of:
            k = parent_of[k]
            if k in seen:
                raise _bad("joints", f"the joints form a cycle through part {k}")
            seen.add(k)
    labels = d["part_labels"]
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
    if _integer(d["num_points"], "num_points", 0) != len(labels):
        raise _bad("num_points", f"is {d['num_points']} but part_labels holds {len(labels)} labels (one per input point)")
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
    for key in ("model", "ucope_version", "conventions_version"):
        _string(d[key], key)
    if "errors" in d:
        _check_errors(d["errors"], K, len(joints))
    if "stages" in d:
        _check_stages(d["stages"])
    return d


@dataclass
class PartEstimate:
    """One part's 9D pose: ``cam_from_part`` ``(4, 4)``, ``size_m`` ``(3,)``, a confidence ``score`` in
    ``[0, 1]`` (the calibrated probability that the part is right, within 10 degrees and 10 % of its box
    diagonal, for a model with a calibration; else the vote score), the raw ``vote_score`` (the fraction
    of its votes that agree x their mean part-score probability) and the number of pairs that voted."""

    index: int
    label: str
    cam_from_part: np.ndarray
    size_m: np.ndarray
    score: float
    symmetry: str = "none"
    num_votes: int = 0
    vote_score: float | None = None

    def to_dict(self) -> dict:
        d = {
            "index": int(self.index),
            "label": self.label,
            "symmetry": self.symmetry,
            "cam_from_part": _floats(self.cam_from_part),
            "size_m": _floats(self.size_m),
            "score": round(float(self.score), 5),
            "num_votes": int(self.num_votes),
        }
        if self.vote_score is not None:
            d["vote_score"] = round(float(self.vote_score), 5)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> PartEstimate:
        return cls(
            index=int(d["index"]),
            label=str(d["label"]),
            cam_from_part=np.asarray(d["cam_from_part"], np.float64).reshape(4, 4),
            size_m=np.asarray(d["size_m"], np.float64).reshape(3),
            score=float(d["score"]),
            symmetry=str(d.get("symmetry", "none")),
            num_votes=int(d.get("num_votes", 0)),
            vote_score=None if d.get("vote_score") is None else float(d["vote_score"]),
        )


@dataclass
class JointEstimate:
    """One joint: ``type`` (``"revolute"``/``"prismatic"``), the ``parent``/``child`` part indices,
    ``pivot_m`` ``(3,)`` (a point on the axis; ``None`` for prismatic joints), unit ``axis`` ``(3,)``,
    ``state`` (radians or metres, see ``state_unit``) and a confidence ``score``."""

    type: str
    parent: int
    child: int
    pivot_m: np.ndarray | None
    axis: np.ndarray
    state: float
    score: float = 0.0

    @property
    def state_unit(self) -> str:
        return "rad" if self.type == "revolute" else "m"

    def to_dict(self) -> dict:
        return {
            "type": self.type,
            "parent": int(self.parent),
            "child": int(self.child),
            "pivot_m": None if self.pivot_m is None else _floats(self.pivot_m),
            "axis": _floats(self.axis),
            "state": round(float(self.state), 7),
            "state_unit": self.state_unit,
            "score": round(float(self.score), 5),
        }

    @classmethod
    def from_dict(cls, d: dict) -> JointEstimate:
        return cls(
            type=str(d["type"]),
            parent=int(d["parent"]),
            child=int(d["child"]),
            pivot_m=None if d.get("pivot_m") is None else np.asarray(d["pivot_m"], np.float64).reshape(3),
            axis=np.asarray(d["axis"], np.float64).reshape(3),
            state=float(d["state"]),
            score=float(d.get("score", 0.0)),
        )


@dataclass
class PoseResult:
    """Everything :meth:`ucope.Estimator.predict` estimates for one object (see the module docstring)."""

    category: str
    parts: list[PartEstimate]
    joints: list[JointEstimate]
    part_labels: np.ndarray
    timings_ms: dict[str, float] = field(default_factory=dict)
    model: str = ""
    num_points: int = 0
    warnings: list[str] = field(default_factory=list)
    errors: dict | None = None
    """Errors against a known ground truth (:func:`ucope.eval.evaluate.sample_errors`), saved with the result."""
    features: np.ndarray | None = field(default=None, repr=False, compare=False)
    """``(K, len(FEATURES))`` the inputs of the score calibration (:mod:`ucope.stages.confidence`);
    not part of the JSON form."""
    stages: list[dict] = field(default_factory=list, compare=False)
    """What each stage of the pipeline did in the estimate that stands: ``{"name", "ms", "changed"}`` per stage,
    in order (:class:`ucope.stages.base.StageRecord`)."""

    @property
    def cam_from_part(self) -> np.ndarray:
        """``(K, 4, 4)`` every part's pose."""
        return np.stack([p.cam_from_part for p in self.parts])

    @property
    def size_m(self) -> np.ndarray:
        """``(K, 3)`` every part's box extents."""
        return np.stack([p.size_m for p in self.parts])

    @property
    def score(self) -> float:
        """The object's confidence: the smallest of its parts' scores (every part must be right)."""
        return float(min((p.score for p in self.parts), default=0.0))

    @property
    def joint_state(self) -> np.ndarray:
        return np.array([j.state for j in self.joints], dtype=np.float64)

    def to_dict(self) -> dict:
        d = {
            "format": RESULT_FORMAT,
            "category": self.category,
            "score": round(self.score, 5),
            "warnings": [str(w) for w in self.warnings],
            "parts": [p.to_dict() for p in self.parts],
            "joints": [j.to_dict() for j in self.joints],
            "part_labels": np.asarray(self.part_labels, dtype=np.int64).tolist(),
            "num_points": int(self.num_points),
            "timings_ms": {k: round(float(v), 3) for k, v in self.timings_ms.items()},
            "stages": [dict(s) for s in self.stages],
            "model": self.model,
            "ucope_version": __version__,
            "conventions_version": CONVENTIONS_VERSION,
        }
        if self.errors is not None:
            d["errors"] = self.errors
        return d

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, d: dict) -> PoseResult:
        """The result of a JSON form, checked by :func:`validate` first (:class:`DataError` naming the
        first bad field)."""
        validate(d)
        try:
            return cls(
                category=str(d["category"]),
                parts=[PartEstimate.from_dict(p) for p in d["parts"]],
                joints=[JointEstimate.from_dict(j) for j in d["joints"]],
                part_labels=np.asarray(d["part_labels"], dtype=np.int64),
                timings_ms=dict(d.get("timings_ms", {})),
                model=str(d.get("model", "")),
                num_points=int(d.get("num_points", 0)),
                warnings=[str(w) for w in d.get("warnings", [])],
                stages=[dict(s) for s in d.get("stages", [])],
                errors=d.get("errors"),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise DataError(f"malformed ucope result: {e}") from None

    @classmethod
    def from_json(cls, text: str) -> PoseResult:
        return cls.from_dict(parse_json(text, "the result text"))

    def save(self, path: str | os.PathLike) -> Path:
        """Write the JSON form to ``path`` atomically."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, self.to_dict())
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> PoseResult:
        """Read and :func:`validate` a result JSON (:class:`DataError` naming the file and the bad field)."""
        d = read_json(path)
        try:
            return cls.from_dict(d)
        except DataError as e:
            raise DataError(f"{path}: {e}") from None

    def to_ros(self, frame_id: str = "camera", stamp: float | None = None, prefix: str = "") -> dict:
        """The result as plain dicts in the field layout of ROS 2 messages (no ROS needed):
        ``{"detections": vision_msgs/Detection3DArray, "transforms": tf2_msgs/TFMessage,
        "joint_state": sensor_msgs/JointState}`` (:func:`ucope.estimation.export.to_ros`)."""
        from .export import to_ros

        return to_ros(self, frame_id=frame_id, stamp=stamp, prefix=prefix)

    def to_urdf(self, path: str | os.PathLike, name: str | None = None, limits=None, root: str = "camera") -> Path:
        """Write the estimated object as a URDF (parts as boxes, joints with the estimated axis, pivot,
        limits; :func:`ucope.estimation.export.write_urdf`)."""
        from .export import write_urdf

        return write_urdf(self, path, name=name, limits=limits, root=root)

    def to_mesh(self, path: str | os.PathLike, points=None) -> Path:
        """Write the boxes (and joint axes, and ``points``) as a GLB / PLY / OBJ file
        (:func:`ucope.estimation.export.write_geometry`)."""
        from .export import write_geometry

        return write_geometry([self], path, [points])

    def to_rrd(self, path: str | os.PathLike, points=None) -> Path:
        """Write a rerun recording (``.rrd``; needs ``pip install rerun-sdk``;
        :func:`ucope.estimation.export.write_rrd`)."""
        from .export import write_rrd

        return write_rrd([self], path, [points])

    def plot(
        self,
        points=None,
        depth=None,
        rgb=None,
        intrinsics=None,
        sample: dict | None = None,
        errors: dict | None = None,
        depth_scale: float = 1000.0,
        title: str = "",
        out: str | os.PathLike | None = None,
    ) -> np.ndarray:
        """A picture of this estimate, as ``ultralytics``' ``results.plot()``: an ``(H, W, 3)`` uint8 RGB array.

        The depth image (and the RGB image when given) with every part's box, axis triad (x red, y
        green, z blue) and joint axes projected over it, a legend with part colours and scores (and
        errors), and a 3D panel (:mod:`ucope.estimation.draw`). Needs matplotlib (``ucope[viz]``).

        Args:
            points: ``(N, 3)`` the cloud the estimate was made from (camera frame, metres); coloured by
                ``part_labels`` in the 3D panel, and splatted into a depth image when ``depth`` is not given.
            depth: ``(H, W)`` depth image in raw units (``depth / depth_scale`` = metres, 0 = none).
            rgb: ``(H, W, 3)`` uint8 colour image of the same camera.
            intrinsics: ``(fx, fy, cx, cy)`` or a 3x3 K; needed with ``depth`` / ``rgb``; without one
                (and without a ``sample``) a virtual camera is fitted to the cloud.
            sample: the ground truth (a data-set sample dict: ``cam_from_part``, ``size_m``,
                ``joint_pivot``, ``joint_axis``; dashed in the picture).
            errors: :func:`ucope.eval.evaluate.sample_errors` of this result against ``sample`` (listed
                in the legend).
            out: also write the picture to this PNG (atomically).

        Raises:
            InputError: ``depth`` without intrinsics, images of different sizes, nothing to draw.
        """
        from ..errors import InputError
        from .draw import DrawnObject, Scene, render_scenes

        depth_m = None
        if depth is not None:
            depth_m = np.asarray(depth, dtype=np.float64) / float(depth_scale)
            if depth_m.ndim != 2:
                raise InputError(f"depth must be an (H, W) image, got shape {depth_m.shape}")
        if rgb is not None:
            rgb = np.asarray(rgb)
            if rgb.ndim != 3 or rgb.shape[2] not in (3, 4):
                raise InputError(f"rgb must be an (H, W, 3) image, got shape {rgb.shape}")
            rgb = rgb[..., :3]
            if depth_m is not None and rgb.shape[:2] != depth_m.shape:
                raise InputError(f"rgb is {rgb.shape[:2]}, depth {depth_m.shape}: they must be images of one camera")
            if depth_m is None:  # an RGB image alone: draw over it, with the cloud's depth beside it
                if intrinsics is None:
                    raise InputError("an RGB image needs its camera's intrinsics to draw the estimate over it")
        scene = Scene(
            [DrawnObject(self, points, sample, errors)],
            title=title or (self.model or self.category),
            depth_m=depth_m,
            rgb=rgb,
            intrinsics=intrinsics,
        )
        img = render_scenes([scene], out=out)
        return img
