"""One call from the network's outputs to every part pose, joint and joint state of one object."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ..geometry.kinematics import joint_state_from_poses
from ..model.config import ModelConfig
from .joints import vote_joints
from .kinematic import kinematic_refine
from .part import VotingOptions, vote_parts

__all__ = ["vote_object"]


def vote_object(
    points,
    normals,
    pair_idx,
    outputs: Mapping[str, Any],
    cfg: ModelConfig,
    awareness: bool = True,
    refine: bool = False,
    options: VotingOptions | None = None,
) -> dict[str, Any]:
    """:func:`ucope.voting.part.vote_parts` + :func:`ucope.voting.joints.vote_joints` + joint states.

    Joint states come from the voted poses (:func:`ucope.geometry.kinematics.joint_state_from_poses`)
    about the voted joint axis (revolute), or from the box supports minus
    ``cfg.stats.joint_zero_offset_m`` (prismatic; 0 when the statistics predate it). With
    ``refine=True`` the poses, axes and states are then made consistent by
    :func:`ucope.voting.kinematic.kinematic_refine` (part scores as weights).

    Args: as :func:`ucope.voting.part.vote_parts` (``outputs`` also holding the joint heads for
        ``K >= 2``).

    Returns:
        the dict of :func:`vote_parts` updated with that of :func:`vote_joints` and ``joint_state``
        ``(J,)``; ``refined`` tells whether the kinematic refinement ran.
    """
    out = vote_parts(points, normals, pair_idx, outputs, cfg, awareness=awareness, options=options)
    out.update(vote_joints(points, outputs, cfg, awareness=awareness))
    J = cfg.num_joints
    T, S = out["cam_from_part"], out["size_m"]
    zero = cfg.stats.joint_zero_offset_m or (0.0,) * J
    state = np.zeros(J)
    for j in range(J):  # a handful of joints
        p, c = cfg.joint_parents[j], cfg.joint_children[j]
        state[j] = joint_state_from_poses(T[p], T[c], out["joint_axis"][j], cfg.joint_types[j], S[p], S[c], zero[j])
    out["joint_state"] = state
    out["refined"] = False
    if refine and J > 0:
        r = kinematic_refine(T, S, out, cfg, part_weights=np.maximum(out["score"], 1e-3))
        out.update(cam_from_part=r["cam_from_part"], joint_axis=r["joint_axis"], joint_state=r["joint_state"], refined=True)
    return out
