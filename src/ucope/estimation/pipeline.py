"""A model's pipeline: its ordered stage list, parameter overrides, search policy and score calibration, as its
model card (``info.pipeline`` and ``info.calibration`` of the model JSON) stores them.

    "pipeline": {"stages": ["vote_parts", "vote_joints", ...], "params": {"denoise.above_m": 0.0013},
                 "search": {"scale_factors": [0.8, 1.0, 1.25], "restarts": 4}, "chosen_on": "..."}

A model without one (a fresh ``ucope train`` run) gets :func:`default_stages` for its structure.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError
from ..priors import CategoryPriors
from ..stages import REGISTRY, get_stage, stage_params
from ..stages.base import coerced, replace_field
from ..stages.confidence import Calibration
from ..vocab import JointType
from .search import SearchPolicy

__all__ = ["Pipeline", "default_stages", "describe"]


def default_stages(priors: CategoryPriors, head: str = "voting") -> tuple[str, ...]:
    """The stages of a model whose card names none: the paper's, the flip and upright checks, the calibrated score
    and, for articulated objects, joint states read off the final boxes (plus the drawer steps where there are
    prismatic joints)."""
    first = "regress_parts" if head == "regression" else "vote_parts"
    if priors.num_joints == 0:
        return (first, "score") if head == "regression" else (first, "flips", "upright", "revolution_fit", "score")
    prismatic = any(jp.type == JointType.PRISMATIC for jp in priors.joints)
    return (
        first,
        "vote_joints",
        "flips",
        "upright",
        "joint_states",
        "score",
        *(("prismatic",) if prismatic else ()),
        "turn_children",
        "joint_states",
    )


@dataclass(frozen=True)
class Pipeline:
    """Attributes:
    stages: the stage names, in order (a name may repeat: ``joint_states`` runs twice in most lists).
    params: overrides ``{"stage.param": value}`` of the stages' parameter defaults.
    search: the :class:`ucope.estimation.search.SearchPolicy`.
    calibration: the model's :class:`ucope.stages.confidence.Calibration`, or ``None`` (raw vote scores).
    chosen_on: which views chose the list and its parameters (free text, for the model card).
    """

    stages: tuple[str, ...]
    params: Mapping[str, Any] = field(default_factory=dict)
    search: SearchPolicy = field(default_factory=SearchPolicy)
    calibration: Calibration | None = None
    chosen_on: str = ""

    def __post_init__(self) -> None:
        for name in self.stages:
            get_stage(name)
        stage_params(self.stages, self.params)  # checks every override

    @classmethod
    def from_info(cls, info: Mapping[str, Any] | None, priors: CategoryPriors, head: str = "voting") -> Pipeline:
        """The pipeline of a model card (``info`` of the model JSON; the default for its structure without one)."""
        info = info or {}
        cal = Calibration.from_dict(info["calibration"]) if info.get("calibration") else None
        doc = info.get("pipeline")
        if doc is None:
            return cls(default_stages(priors, head), calibration=cal)
        if not isinstance(doc, Mapping) or not isinstance(doc.get("stages", []), list | None):
            raise InputError("the model card's pipeline must be an object with a list of stages (or none: the default)")
        stages = default_stages(priors, head) if doc.get("stages") is None else tuple(doc["stages"])
        search = SearchPolicy()
        for key, value in (doc.get("search") or {}).items():
            search = replace_field(search, [key], value, f"pipeline.search.{key}")
        return cls(stages, dict(doc.get("params") or {}), search, cal, str(doc.get("chosen_on", "")))

    def to_dict(self) -> dict:
        """The card's ``pipeline`` entry (the calibration is stored beside it; parameters of stages not in the list
        are left out)."""
        default = SearchPolicy().to_dict()
        search = {k: v for k, v in self.search.to_dict().items() if v != default[k]}
        params = {k: v for k, v in self.params.items() if k.partition(".")[0] in self.stages}
        return {"stages": list(self.stages), "params": params, "search": search, "chosen_on": self.chosen_on}

    def changed(
        self, stages: Iterable[str] | None = None, drop: Iterable[str] = (), overrides: Mapping[str, Any] | None = None
    ) -> Pipeline:
        """This pipeline with another stage list (``stages``), without the stages ``drop`` and with ``overrides``
        (``{"stage.param": value}``; ``search.*`` keys set the search policy)."""
        names = tuple(self.stages if stages is None else stages)
        drop = set(drop)
        for name in drop:
            get_stage(name)
        names = tuple(n for n in names if n not in drop)
        params, search = dict(self.params), self.search
        for key, value in (overrides or {}).items():
            group, _, path = str(key).partition(".")
            if group == "search":
                search = replace_field(search, path.split("."), value, f"override {key}")
            else:
                params[key] = coerced(key, value)
        return dataclasses.replace(self, stages=names, params=params, search=search)


def describe(pipeline: Pipeline) -> str:
    """One line per stage of ``pipeline``: its name, kind and purpose; then the search policy."""
    lines = []
    for i, name in enumerate(pipeline.stages, 1):
        st = REGISTRY[name]
        lines.append(f"{i:2d}. {name:<16} {st.kind:<13} {st.purpose}")
    for key, value in pipeline.params.items():
        lines.append(f"    {key} = {value}")
    s = pipeline.search
    lines.append(
        f"search: rescale {s.rescale}, recrop {s.recrop}, scale factors {list(s.scale_factors)} below {s.scale_below}, "
        f"restarts {s.restarts} below {s.restart_below}, pick {s.pick}"
    )
    if pipeline.chosen_on:
        lines.append(f"chosen on: {pipeline.chosen_on}")
    return "\n".join(lines)
