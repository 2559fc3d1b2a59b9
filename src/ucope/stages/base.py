"""The pipeline's building blocks: the typed states that stages pass on, the :class:`Stage` record, the
registry, parameter overrides and :func:`run`.

A stage is a function ``fn(state, params) -> None`` that updates a state in place, registered under a
name with :func:`stage`. Its ``params`` is a frozen dataclass holding every constant it uses; a model card
lists the stages a model runs (in order) and may override parameters (``"fit_boxes.grow": false``); users
do the same with ``Estimator(stages=..., overrides=...)`` or ``ucope predict --stages / --drop-stage / --set``.

Two phases: ``"cloud"`` stages clean the prepared cloud before the network (:class:`CloudState`), ``"pose"``
stages turn the network's outputs into part poses and joints (:class:`PoseState`). :func:`run` times each
stage and records what it changed (:class:`StageRecord`).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..errors import InputError
from ..geometry.transforms import rotation_angle_deg
from ..priors import CategoryPriors

__all__ = [
    "KINDS",
    "PHASES",
    "CloudState",
    "PoseState",
    "Stage",
    "StageRecord",
    "NoParams",
    "REGISTRY",
    "stage",
    "get_stage",
    "stage_params",
    "parse_overrides",
    "coerced",
    "replace_field",
    "run",
]

KINDS = ("paper", "geometry", "learned-prior", "calibration")
"""What a stage rests on: the paper's method, plain geometry of the points, statistics the model measured
on its training views (``CategoryPriors``), or the model's fitted score calibration."""

PHASES = ("cloud", "pose")


@dataclass(frozen=True)
class NoParams:
    """The parameters of a stage that has none."""


@dataclass
class CloudState:
    """The cloud of one pass before the network, as the cloud stages pass it on.

    Attributes:
        points: ``(N, 3)`` float32, camera frame (turned by the roll when ``up`` was given), metres.
        normals: ``(N, 3)`` or ``None`` (estimated later).
        keep: ``(N,)`` bool, the points still taken as the object (a stage that leaves points out clears them).
        seed: the estimator's seed (stages that draw take their stream from it).
        plane: the support plane left out, if a stage found one (:class:`ucope.geometry.planes.SupportPlane`).
        warnings: what the stages did to the estimate; input_warnings: what they found about the cloud.
    """

    points: np.ndarray
    normals: np.ndarray | None
    seed: int = 0
    keep: np.ndarray | None = None
    plane: Any = None
    warnings: list[str] = field(default_factory=list)
    input_warnings: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.keep is None:
            self.keep = np.ones(len(self.points), dtype=bool)


@dataclass
class PoseState:
    """The estimate of one pass as the pose stages pass it on, from the network's outputs to the final boxes.

    Fixed inputs (validated once here):
        priors: the model's :class:`ucope.priors.CategoryPriors` (``K`` parts, ``J`` joints).
        points: ``(P, 3)`` the network's points, camera frame, metres of the pass (the cloud may be rescaled by
            ``scale``); normals: ``(P, 3)``.
        seg_labels: ``(P,)`` the network's class of each point (values ``>= K``: the background class).
        seg_prob: ``(P, C)`` class probabilities (``C >= K``) or ``None`` (one part, no segmentation).
        num_input: points of the user's cloud this pass stands for (a calibration feature).
        camera: ``(3,)`` the camera centre in the pass's frame (the origin moves when the cloud is rescaled).
        scale: the factor the pass's cloud was scaled by (metres of the input = metres here / ``scale``).
        outputs: the network's outputs (heads named in :mod:`ucope.vocab`); pair_idx: ``(K, M, 2)`` or ``None``.
        axis_heads: computes the axis heads of part ``k``'s pairs lazily (``None``: they are in ``outputs``).
        calibration: the model's :class:`ucope.stages.confidence.Calibration` or ``None``.
        shapes: the model's :class:`ucope.stages.flips.ShapeIndex` (built once per model) or ``None``.
        noise_m: returns the surface noise of the pass's cloud, metres of the input (computed once, on demand).

    The estimate (stages change these):
        cam_from_part ``(K, 4, 4)``, size_m ``(K, 3)``; votes: per-part vote statistics of ``vote_parts``
        (``score``, ``num_pairs``, ``num_inliers``, ``mean_prob``, ``fallback``, ``up_agreement``,
        ``right_agreement``, ``(K,)`` each); joint_axis / joint_pivot ``(J, 3)``, joint_state / joint_score
        ``(J,)``, joint_clamped ``(J,)`` bool; score ``(K,)`` (the calibrated part scores once ``score`` ran;
        ``None`` before); features ``(K, F)`` the calibration's inputs; carried ``(K,)`` the parts re-placed
        from a neighbour (their scores are halved at the end); fitted ``(K, 3)`` the box axes set from points;
        face_frame: what ``align_faces`` measured, for stages that turn parts back onto their faces; warnings.
    """

    priors: CategoryPriors
    points: np.ndarray
    normals: np.ndarray
    seg_labels: np.ndarray
    seg_prob: np.ndarray | None = None
    num_input: int = 0
    camera: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: float = 1.0
    outputs: Mapping[str, Any] = field(default_factory=dict)
    pair_idx: np.ndarray | None = None
    axis_heads: Callable | None = None
    calibration: Any = None
    shapes: Any = None
    noise_m: Callable[[], float] | None = None
    cam_from_part: np.ndarray | None = None
    size_m: np.ndarray | None = None
    votes: dict[str, np.ndarray] = field(default_factory=dict)
    joint_axis: np.ndarray | None = None
    joint_pivot: np.ndarray | None = None
    joint_state: np.ndarray | None = None
    joint_score: np.ndarray | None = None
    joint_clamped: np.ndarray | None = None
    score: np.ndarray | None = None
    features: np.ndarray | None = None
    carried: np.ndarray | None = None
    fitted: np.ndarray | None = None
    face_frame: tuple | None = None
    warnings: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        K, J = self.priors.num_parts, self.priors.num_joints
        P = len(self.points)
        if np.shape(self.points) != (P, 3) or np.shape(self.normals) != (P, 3) or np.shape(self.seg_labels) != (P,):
            raise InputError(
                f"points, normals and seg_labels must be (P, 3), (P, 3), (P,), got {np.shape(self.points)}, "
                f"{np.shape(self.normals)}, {np.shape(self.seg_labels)}"
            )
        if self.seg_prob is not None and (
            np.ndim(self.seg_prob) != 2 or len(self.seg_prob) != P or np.shape(self.seg_prob)[1] < K
        ):
            raise InputError(f"seg_prob must be (P={P}, C >= {K}), got {np.shape(self.seg_prob)}")
        if np.shape(self.camera) != (3,):
            raise InputError(f"camera must be a (3,) point, got shape {np.shape(self.camera)}")
        self.camera = np.asarray(self.camera, np.float64)
        self.joint_axis = np.zeros((J, 3)) if self.joint_axis is None else self.joint_axis
        self.joint_pivot = np.zeros((J, 3)) if self.joint_pivot is None else self.joint_pivot
        self.joint_state = np.zeros(J) if self.joint_state is None else self.joint_state
        self.joint_score = np.zeros(J) if self.joint_score is None else self.joint_score
        self.joint_clamped = np.zeros(J, dtype=bool) if self.joint_clamped is None else self.joint_clamped
        self.carried = np.zeros(K, dtype=bool) if self.carried is None else self.carried
        self.fitted = np.zeros((K, 3), dtype=bool) if self.fitted is None else self.fitted

    @property
    def K(self) -> int:
        return self.priors.num_parts

    @property
    def J(self) -> int:
        return self.priors.num_joints

    @cached_property
    def part_labels(self) -> np.ndarray:
        """``(P,)`` the part of each point, -1 for the background class."""
        return np.where(self.seg_labels < self.K, self.seg_labels, -1)

    @cached_property
    def confidence(self) -> np.ndarray | None:
        """``(P,)`` the probability that each point is the object, not the background (models with a
        background class; ``None`` otherwise)."""
        if self.seg_prob is None or self.seg_prob.shape[1] <= self.K:
            return None
        return 1.0 - self.seg_prob[:, self.K]

    @cached_property
    def part_points(self) -> list[np.ndarray]:
        """The indices of the points part ``k``'s pairs were drawn from (sorted, unique), per part."""
        idx = np.asarray(self.pair_idx).reshape(self.K, -1)
        return [np.unique(i) for i in idx]

    @property
    def symmetry(self) -> list[str]:
        return [p.symmetry for p in self.priors.parts]

    def part_name(self, k: int) -> str:
        return self.priors.parts[k].name

    def joint_name(self, j: int) -> str:
        jp = self.priors.joints[j]
        return f"{jp.parent}->{jp.child}"


@dataclass(frozen=True)
class Stage:
    """A registered stage: ``fn(state, params)`` updates a :class:`CloudState` (phase ``"cloud"``) or a
    :class:`PoseState` (phase ``"pose"``) in place. ``reads``: the ``CategoryPriors`` fields it uses;
    ``applies(priors)``: whether it can act on a model at all (a prismatic step on a laptop cannot)."""

    name: str
    kind: str
    phase: str
    fn: Callable[[Any, Any], None]
    params: type = NoParams
    reads: tuple[str, ...] = ()
    applies: Callable[[CategoryPriors], bool] | None = None

    @property
    def purpose(self) -> str:
        """The first paragraph of the stage function's docstring, as one line."""
        return " ".join((self.fn.__doc__ or "").strip().split("\n\n")[0].split())

    @property
    def module(self) -> str:
        return self.fn.__module__


REGISTRY: dict[str, Stage] = {}
"""Every stage by name, in the order of registration."""


def stage(
    name: str,
    kind: str,
    params: type = NoParams,
    phase: str = "pose",
    reads: Iterable[str] = (),
    applies: Callable[[CategoryPriors], bool] | None = None,
):
    """Register the decorated function as the stage ``name`` (see :class:`Stage`)."""
    if kind not in KINDS or phase not in PHASES:
        raise ValueError(f"stage {name}: kind must be one of {KINDS} and phase one of {PHASES}")

    def register(fn):
        if name in REGISTRY:
            raise ValueError(f"stage {name!r} is registered twice")
        REGISTRY[name] = Stage(name, kind, phase, fn, params, tuple(reads), applies)
        return fn

    return register


def get_stage(name: str) -> Stage:
    """The registered stage ``name``; an InputError naming the known stages otherwise."""
    if not isinstance(name, str) or name not in REGISTRY:
        raise InputError(f"unknown stage {name!r}; the stages are: {', '.join(REGISTRY)}")
    return REGISTRY[name]


def _coerce(value: Any, current: Any, where: str) -> Any:
    """``value`` (a JSON value, or a string from the command line) as the type of ``current``."""
    if isinstance(value, str) and not isinstance(current, str):
        try:
            value = json.loads(value)
        except json.JSONDecodeError:
            if current is not None:
                raise InputError(f"{where}: {value!r} is not a value of type {type(current).__name__}") from None
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise InputError(f"{where}: must be true or false, got {value!r}")
        return value
    if isinstance(current, int) and not isinstance(current, bool):
        if isinstance(value, bool) or not isinstance(value, int | float) or not float(value).is_integer():
            raise InputError(f"{where}: must be a whole number, got {value!r}")
        return int(value)
    if isinstance(current, int | float) and not isinstance(current, bool):
        if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
            raise InputError(f"{where}: must be a finite number, got {value!r}")
        return type(current)(value) if isinstance(current, float) else value
    if isinstance(current, tuple):
        if not isinstance(value, list | tuple):
            raise InputError(f"{where}: must be a list, got {value!r}")
        return tuple(value)
    return value


def _optional(params: Any, name: str) -> bool:
    """Whether the dataclass field ``name`` of ``params`` may be ``None`` (its annotation says so)."""
    f = next(f for f in dataclasses.fields(params) if f.name == name)
    return "None" in str(f.type)


def replace_field(params: Any, path: Sequence[str], value: Any, where: str) -> Any:
    """``params`` (a dataclass) with its (nested) field ``path`` set to ``value`` (coerced to the field's type;
    an InputError naming ``where`` otherwise)."""
    names = {f.name for f in dataclasses.fields(params)}
    if path[0] not in names:
        raise InputError(f"{where}: no parameter {path[0]!r} (it has: {', '.join(sorted(names)) or 'none'})")
    current = getattr(params, path[0])
    if len(path) > 1:
        if not dataclasses.is_dataclass(current):
            raise InputError(f"{where}: {path[0]!r} has no parameters of its own")
        new = replace_field(current, path[1:], value, where)
    else:
        if dataclasses.is_dataclass(current):
            raise InputError(f"{where}: {path[0]!r} is a group of parameters; set one of them")
        new = None if value in (None, "null") and _optional(params, path[0]) else _coerce(value, current, where)
    try:
        return dataclasses.replace(params, **{path[0]: new})
    except InputError as e:
        raise InputError(f"{where}: {e}") from None


def coerced(key: str, value: Any) -> Any:
    """The override ``{key: value}`` (``"stage.param[.sub]"``) with ``value`` as the parameter's own type (a string
    from the command line becomes a number, a bool or null); an InputError as :func:`stage_params` raises."""
    name, _, path = str(key).partition(".")
    if not path:
        raise InputError(f"override {key!r}: write STAGE.PARAM")
    obj = replace_field(get_stage(name).params(), path.split("."), value, f"override {key}")
    for part in path.split("."):
        obj = getattr(obj, part)
    return list(obj) if isinstance(obj, tuple) else obj


def parse_overrides(items: Iterable[str]) -> dict[str, str]:
    """``["stage.param=value", ...]`` (the command line's ``--set``) as a dict."""
    out = {}
    for item in items:
        key, eq, value = str(item).partition("=")
        if not eq or "." not in key:
            raise InputError(f"--set takes STAGE.PARAM=VALUE, got {item!r}")
        out[key.strip()] = value.strip()
    return out


def stage_params(names: Iterable[str], overrides: Mapping[str, Any] | None = None) -> dict:
    """``{stage: params}`` of the stages ``names`` with ``overrides`` (``{"stage.param[.sub]": value}``, JSON values or
    strings from the command line) applied; an override of a stage not in ``names`` is checked and kept.

    Raises:
        InputError: an unknown stage or parameter, or a value of the wrong type, naming it."""
    params = {n: get_stage(n).params() for n in dict.fromkeys(names)}
    for key, value in (overrides or {}).items():
        name, _, path = str(key).partition(".")
        if not path:
            raise InputError(f"override {key!r}: write STAGE.PARAM")
        if name not in params:
            params[name] = get_stage(name).params()
        params[name] = replace_field(params[name], path.split("."), value, f"override {key}")
    return params


@dataclass
class StageRecord:
    """What one stage did in one pass: its time and, for pose stages, what it changed (the largest rotation
    in degrees, translation and size change in metres of the input, over the parts it moved; the largest
    joint-state change), empty when it changed nothing."""

    name: str
    ms: float
    changed: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"name": self.name, "ms": round(self.ms, 3), "changed": self.changed}


def _copy(a) -> np.ndarray | None:
    return None if a is None else np.array(a, np.float64, copy=True)


def _snapshot(state: PoseState) -> tuple:
    return _copy(state.cam_from_part), _copy(state.size_m), _copy(state.joint_state)


_MOVED_DEG, _MOVED_M = 1e-4, 1e-7
"""Below these a part counts as unmoved in a stage's record (degrees; metres of the input)."""


def _changes(before: tuple, state: PoseState) -> dict:
    T0, S0, q0 = before
    T1, S1, q1 = _snapshot(state)
    out: dict[str, Any] = {}
    if T1 is not None and (T0 is None or T0.shape != T1.shape):
        return {"parts": [state.part_name(k) for k in range(len(T1))]}
    if T1 is not None:
        rot = np.array([rotation_angle_deg(a[:3, :3], b[:3, :3]) for a, b in zip(T0, T1, strict=True)])  # K parts
        trans = np.linalg.norm(T1[:, :3, 3] - T0[:, :3, 3], axis=1) / state.scale
        size = np.abs(S1 - S0).max(axis=1) / state.scale if S0 is not None and S1 is not None else np.zeros(len(T1))
        moved = (rot > _MOVED_DEG) | (trans > _MOVED_M) | (size > _MOVED_M)  # not float round-off
        if moved.any():
            out.update(
                parts=[state.part_name(k) for k in np.flatnonzero(moved)],
                rotation_deg=round(float(rot.max()), 4),
                translation_m=round(float(trans.max()), 6),
                size_m=round(float(size.max()), 6),
            )
    if q1 is not None and q0 is not None and q0.shape == q1.shape and len(q1) and np.abs(q1 - q0).max() > 1e-9:
        out["joint_state"] = round(float(np.abs(q1 - q0).max()), 6)
    return out


def run(names: Sequence[str], state, params: Mapping[str, Any], phase: str = "pose") -> list[StageRecord]:
    """Run the stages ``names`` of ``phase`` on ``state`` in order (each with ``params[name]``), skipping
    those that do not apply to the model; return one :class:`StageRecord` per stage run."""
    records = []
    for name in names:
        st = get_stage(name)
        if st.phase != phase:
            continue
        priors = getattr(state, "priors", None)
        if st.applies is not None and priors is not None and not st.applies(priors):
            continue
        before = _snapshot(state) if phase == "pose" else None
        t0 = time.perf_counter()
        st.fn(state, params[name] if name in params else st.params())
        ms = 1e3 * (time.perf_counter() - t0)
        records.append(StageRecord(name, ms, _changes(before, state) if phase == "pose" else {}))
    return records
