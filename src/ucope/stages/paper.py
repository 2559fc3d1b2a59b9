"""The paper's stages: part poses by voting (or the direct-regression baseline's), joints from the joint heads,
joint states read off the part poses.

Frames and units: the camera frame of the pass (OpenCV axes), metres; states in radians (revolute) or metres
(prismatic).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..geometry.kinematics import joint_state_from_poses
from ..priors import CategoryPriors
from ..voting import VotingOptions, vote_joints, vote_parts
from .base import NoParams, PoseState, stage
from .confidence import part_fit
from .states import clamp_joint_states

__all__ = ["VotePartsParams", "VoteJointsParams", "regression_scores"]


@dataclass(frozen=True)
class VotePartsParams:
    """Attributes:
    num_pairs: point pairs per object, split evenly over the parts (the paper: 20,000).
    segment_pairs: part ``k``'s pairs are drawn from the points segmented as ``k`` (the paper's part
        awareness; all points where fewer than 3 are).
    score_filter: only pairs whose part score passes ``options.score_threshold`` vote (part awareness).
    options: :class:`ucope.voting.VotingOptions` of the centre, axis and size votes.
    """

    num_pairs: int = 20000
    segment_pairs: bool = True
    score_filter: bool = True
    options: VotingOptions = field(default_factory=VotingOptions)

    def __post_init__(self) -> None:
        if not 10 <= self.num_pairs <= 1_000_000:
            raise InputError(f"num_pairs must be from 10 to 1000000, got {self.num_pairs}")


@stage("vote_parts", kind="paper", params=VotePartsParams, reads=("parts.vote_range_m", "parts.mean_size_m"))
def _vote_parts(state: PoseState, params: VotePartsParams) -> None:
    """Every part's centre, up / right axes and size by voting over its point pairs (section 4.4)."""
    out = vote_parts(
        state.points,
        state.normals,
        state.pair_idx,
        state.outputs,
        state.priors,
        score_filter=params.score_filter,
        options=params.options,
        axis_heads=state.axis_heads,
    )
    state.cam_from_part, state.size_m = out.pop("cam_from_part"), out.pop("size_m")
    out.pop("timings_ms", None)
    state.votes = out


def regression_scores(
    points: np.ndarray, seg_prob: np.ndarray | None, cam_from_part: np.ndarray, size_m: np.ndarray
) -> np.ndarray:
    """``(K,)`` scores in ``[0, 1]`` of regressed part poses: the mean segmentation probability of the points
    segmented as part ``k`` times the fraction of those points inside part ``k``'s regressed box
    (:func:`ucope.stages.confidence.part_fit`); a part without points scores 0.

    Args:
        points: ``(P, 3)`` camera frame, metres; seg_prob: ``(P, C)`` class probabilities or ``None`` (one part).
        cam_from_part: ``(K, 4, 4)``; size_m: ``(K, 3)`` the regressed boxes.
    """
    labels = np.zeros(len(points), np.int64) if seg_prob is None else np.asarray(seg_prob).argmax(-1)
    conf, fit = part_fit(points, labels, seg_prob, cam_from_part, size_m)
    return conf * fit


@stage("regress_parts", kind="paper", reads=("parts.mean_size_m",))
def _regress_parts(state: PoseState, params: NoParams) -> None:
    """Part poses and sizes from the direct-regression baseline's heads (no votes; the Table 2 baseline)."""
    K, out = state.K, state.outputs
    T = np.tile(np.eye(4), (K, 1, 1))
    T[:, :3, :3] = out["rotation"].reshape(K, 3, 3).double().cpu().numpy()
    T[:, :3, 3] = out["centre_m"].reshape(K, 3).double().cpu().numpy()
    size = np.exp(out["gamma"].reshape(K, 3).double().cpu().numpy()) * state.priors.mean_size_m
    state.cam_from_part, state.size_m = T, size
    state.votes = {
        "score": regression_scores(np.asarray(state.points, np.float64), state.seg_prob, T, size),
        "num_pairs": np.zeros(K, dtype=np.int64),
    }


@dataclass(frozen=True)
class VoteJointsParams:
    """Attributes:
    awareness: only points whose joint score and heatmap pass ``threshold`` locate a joint (section 4.5).
    threshold: probability threshold of the heatmap and joint-score heads.
    """

    awareness: bool = True
    threshold: float = 0.5


def _has_joints(priors: CategoryPriors) -> bool:
    return priors.num_joints > 0


@stage("vote_joints", kind="paper", params=VoteJointsParams, reads=("joints.type",), applies=_has_joints)
def _vote_joints(state: PoseState, params: VoteJointsParams) -> None:
    """Every joint's pivot and axis from the heatmap, offset and direction heads of its points (section 4.3)."""
    out = vote_joints(state.points, state.outputs, state.priors, awareness=params.awareness, threshold=params.threshold)
    state.joint_axis, state.joint_pivot, state.joint_score = out["joint_axis"], out["joint_pivot"], out["joint_score"]


@stage(
    "joint_states", kind="paper", reads=("joints.limits", "joints.axis_in_parent", "joints.zero_offset_m"), applies=_has_joints
)
def _joint_states(state: PoseState, params: NoParams) -> None:
    """Joint states read off the part boxes as they stand and clamped into the category's limits (the child
    moved with its joint, the joint's score halved where it was clamped)."""
    T, S, u, pri = state.cam_from_part, state.size_m, state.joint_axis, state.priors
    q = np.array(
        [
            joint_state_from_poses(T[jp.parent], T[jp.child], u[j], jp.type, S[jp.parent], S[jp.child], jp.zero_offset_m)
            for j, jp in enumerate(pri.joints)  # a handful of joints
        ],
        dtype=np.float64,
    )
    T, q, clamped = clamp_joint_states(T, u, state.joint_pivot, q, pri)
    state.cam_from_part, state.joint_state = T, q
    state.joint_score = np.where(clamped & ~state.joint_clamped, 0.5 * np.asarray(state.joint_score), state.joint_score)
    state.joint_clamped = state.joint_clamped | clamped
