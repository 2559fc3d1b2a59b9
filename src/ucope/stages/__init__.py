"""The estimator's stages: everything between the network's outputs and the result, one named step each.

A model card lists the stages its model runs, in order; :func:`ucope.stages.base.run` runs them on a typed
:class:`PoseState` (or, before the network, a :class:`CloudState`) and records each one's time and what it
changed. ``ucope pipeline --model M`` prints a model's list; docs/pipeline.md describes every stage.

Layer: below :mod:`ucope.estimation`, above :mod:`ucope.voting` (the paper's maths, which the ``paper`` stages
call) and :mod:`ucope.priors` (what the ``learned-prior`` stages read). Modules by topic:

* :mod:`.cloud`: ``clean_cloud`` (before the network);
* :mod:`.paper`: ``vote_parts`` (or ``regress_parts``), ``vote_joints``, ``joint_states``;
* :mod:`.faces`: ``align_faces``; :mod:`.flips`: ``flips``; :mod:`.upright`: ``upright``;
* :mod:`.revolution`: ``revolution_fit``;
* :mod:`.states`: ``kinematic_refine``; :mod:`.confidence`: ``score``;
* :mod:`.extents`: ``fit_boxes``; :mod:`.prismatic`: ``prismatic``;
* :mod:`.exposure`: ``free_space`` (its parameters and its turn of hinged parts in :mod:`.freespace`);
* :mod:`.revolute`: ``turn_children``, ``seat_parts``;
* :mod:`.support`: what several stages share (argument checks, joined points, shared defaults).

Every constant a stage uses is a field of its parameter dataclass (``STAGE.PARAM`` overrides it); the defaults
several stages share are named once in :mod:`.support`.
"""

from __future__ import annotations

from . import cloud, confidence, exposure, extents, faces, flips, paper, prismatic, revolute, revolution, states, upright
from .base import KINDS, REGISTRY, CloudState, PoseState, Stage, StageRecord, get_stage, parse_overrides, run, stage_params

__all__ = [
    "KINDS",
    "REGISTRY",
    "CloudState",
    "PoseState",
    "Stage",
    "StageRecord",
    "get_stage",
    "parse_overrides",
    "run",
    "stage_params",
    "cloud",
    "confidence",
    "exposure",
    "extents",
    "faces",
    "flips",
    "paper",
    "prismatic",
    "revolute",
    "revolution",
    "states",
    "upright",
]
