"""The result of a pose estimate, and its stable JSON form.

JSON form (``format: "ucope-result/2"``, JSON Schema: :func:`result_schema`, docs/formats.md; every
length in metres, angles in radians, camera frame = OpenCV: +x right, +y down, +z forward)::

    {
      "format": "ucope-result/2",
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
      "estimates": 1,                         # estimates the search made (timings_ms sums them all)
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
from .result_check import validate

__all__ = ["RESULT_FORMAT", "PartEstimate", "JointEstimate", "PoseResult", "result_schema", "validate", "SCHEMA_FILE"]

SCHEMA_FILE = Path(__file__).with_name("result.schema.json")
"""The JSON Schema (draft 2020-12) of ``ucope-result/2`` and ``ucope-results/1``, shipped in the package."""


def result_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a result file: one object's ``ucope-result/2`` or one frame's
    ``ucope-results/1`` (``$defs/result`` and ``$defs/results``). Validate with any JSON Schema library,
    e.g. ``jsonschema.validate(json.load(f), result_schema())``; docs/formats.md describes every field."""
    return read_json(SCHEMA_FILE)


def _floats(a, ndigits: int = 7) -> Any:
    return np.round(np.asarray(a, dtype=np.float64), ndigits).tolist()


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
    estimates: int = 1
    """How many estimates the search made (:mod:`ucope.estimation.search`: sizes, restarts; >= 1); ``timings_ms``
    sums them all, ``stages`` is the one that stands."""

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
            "estimates": int(self.estimates),
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
                estimates=int(d["estimates"]),
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
        "joint_state": sensor_msgs/JointState}`` (:func:`ucope.estimation.robot_export.to_ros`)."""
        from .robot_export import to_ros

        return to_ros(self, frame_id=frame_id, stamp=stamp, prefix=prefix)

    def to_urdf(self, path: str | os.PathLike, name: str | None = None, limits=None, root: str = "camera") -> Path:
        """Write the estimated object as a URDF (parts as boxes, joints with the estimated axis, pivot,
        limits; :func:`ucope.estimation.robot_export.write_urdf`)."""
        from .robot_export import write_urdf

        return write_urdf(self, path, name=name, limits=limits, root=root)

    def to_mesh(self, path: str | os.PathLike, points=None) -> Path:
        """Write the boxes (and joint axes, and ``points``) as a GLB / PLY / OBJ file
        (:func:`ucope.estimation.robot_export.write_geometry`)."""
        from .robot_export import write_geometry

        return write_geometry([self], path, [points])

    def to_rrd(self, path: str | os.PathLike, points=None) -> Path:
        """Write a rerun recording (``.rrd``; needs ``pip install rerun-sdk``;
        :func:`ucope.estimation.robot_export.write_rrd`)."""
        from .robot_export import write_rrd

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
