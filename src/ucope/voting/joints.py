"""Joint pivot and axis from the per-point joint heads (paper section 4.5, joint awareness).

The network predicts for every point ``p_i`` and joint ``j`` a heat logit (``H``: closeness to the
axis line, revolute; on the child part, prismatic), a joint-score logit (``C^JT``: the point belongs to
the joint's parent or child part, equation (9)), an offset ``o_i`` from the point to its foot on the
axis line (metres; 0 for prismatic joints) and a unit axis direction ``d_i`` (signed: supervised to
equal the joint axis). :func:`joint_from_points`:

* **Awareness on** (the paper): the points with ``sigmoid(score) > threshold`` and
  ``sigmoid(heat) > threshold`` vote with weight 1. If none pass, the fallback takes the top
  ``max(fallback_min_points, fallback_fraction N)`` points by ``sigmoid(heat) * sigmoid(score)``, with
  those products as weights, and flags ``fallback``.
* **Awareness off** (ablation): every point votes, weighted by ``sigmoid(heat)``.
* pivot = weighted mean of ``p_i + o_i``; axis = the principal direction of the weighted ``d_i``
  (largest eigenvector of ``sum w d d^T``, robust to a few reversed or stray directions), oriented to
  agree with the weighted majority (``sum w (d . axis) >= 0``).
* Prismatic joints have no pivot; the same formula then gives the weighted centroid of the voting
  points (the child's visible points, offsets ~0): a finite point on a line along the axis through
  the moving part, fine for drawing but not a location (the metrics ignore it).

Frames and units: camera frame, metres. Float32 torch on the device of the inputs.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from ..errors import InputError
from ..priors import CategoryPriors
from .arrays import tensor
from .part import as_points

__all__ = ["JointVote", "joint_from_points", "vote_joints"]


@dataclass
class JointVote:
    """One voted joint: ``pivot`` ``(3,)`` and unit ``axis`` ``(3,)`` (numpy float64, camera frame,
    metres), the number of voting points, whether the fallback was used, and a score in ``[0, 1]``
    (mean ``sigmoid(heat) * sigmoid(score)`` of the voting points)."""

    pivot: np.ndarray
    axis: np.ndarray
    num_points: int
    fallback: bool
    score: float


def joint_from_points(
    points,
    heat_logits,
    offset,
    direction,
    score_logits,
    awareness: bool = True,
    threshold: float = 0.5,
    *,
    fallback_fraction: float = 0.1,
    fallback_min_points: int = 16,
) -> JointVote:
    """Pivot and axis of one joint from its per-point heads (see the module docstring).

    Args:
        points: ``(N, 3)`` cloud (camera frame, metres).
        heat_logits, score_logits: ``(N,)`` logits of this joint's heat and joint score.
        offset: ``(N, 3)`` predicted point-to-axis offsets (metres).
        direction: ``(N, 3)`` predicted axis directions (normalised here; zero rows carry no vote).
        awareness: joint awareness on (paper) or off (every point, weighted by heat).
        threshold: probability threshold of both heads.
        fallback_fraction, fallback_min_points: size of the fallback set when no point passes.

    Returns:
        :class:`JointVote`.
    """
    p = tensor(points, "points", (None, 3))
    N = p.shape[0]
    if N == 0:
        raise InputError("joint_from_points needs at least one point")
    dev = p.device
    heat = torch.sigmoid(tensor(heat_logits, "heat_logits", (N,), device=dev))
    sc = torch.sigmoid(tensor(score_logits, "score_logits", (N,), device=dev))
    off = tensor(offset, "offset", (N, 3), device=dev)
    d = tensor(direction, "direction", (N, 3), device=dev)
    d = d / d.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    fallback = False
    if awareness:
        w = ((heat > threshold) & (sc > threshold)).to(p.dtype)
        if not bool((w > 0).any()):
            fallback = True
            conf = heat * sc
            k = min(N, max(int(fallback_min_points), int(round(float(fallback_fraction) * N))))
            top = torch.topk(conf, k).indices
            w = torch.zeros_like(conf)
            w[top] = conf[top].clamp_min(1e-6)
    else:
        w = heat.clamp_min(1e-6)
    W = w.sum()
    pivot = ((p + off) * w.unsqueeze(-1)).sum(0) / W
    C = (d * w.unsqueeze(-1)).T @ d
    _, vecs = torch.linalg.eigh(C.double())
    axis = vecs[:, -1].to(p.dtype)
    if float(((d @ axis) * w).sum()) < 0:
        axis = -axis
    used = w > 0
    return JointVote(
        pivot=pivot.double().cpu().numpy(),
        axis=axis.double().cpu().numpy(),
        num_points=int(used.sum()),
        fallback=fallback,
        score=float((heat * sc)[used].mean()),
    )


def vote_joints(
    points, outputs: Mapping[str, Any], priors: CategoryPriors, awareness: bool = True, threshold: float = 0.5
) -> dict[str, np.ndarray]:
    """Every joint of one object (batch size 1) from the network's joint heads.

    Args:
        points: ``(N, 3)`` or ``(1, N, 3)`` the network's input cloud.
        outputs: :meth:`ucope.model.network.UCOPENet.forward` outputs with ``joint_heat``,
            ``joint_score`` ``(1, J, N)``, ``joint_offset``, ``joint_dir`` ``(1, J, N, 3)``.
        priors: the category's :class:`ucope.priors.CategoryPriors` (``J = priors.num_joints``).
        awareness: joint awareness on (paper) or off (ablation), see :func:`joint_from_points`.
        threshold: probability threshold of the heat and joint-score heads.

    Returns:
        dict of numpy arrays: ``joint_pivot``, ``joint_axis`` ``(J, 3)``, ``joint_type`` ``(J,)``
        (:class:`ucope.vocab.JointType` codes), ``joint_num_points`` ``(J,)``, ``joint_fallback`` ``(J,)`` bool,
        ``joint_score`` ``(J,)``. Empty ``(0, ...)`` arrays for a rigid object.
    """
    J = priors.num_joints
    pts = as_points(points, "points")
    N = pts.shape[0]
    out = dict(
        joint_pivot=np.zeros((J, 3)),
        joint_axis=np.zeros((J, 3)),
        joint_type=np.array([int(j.type) for j in priors.joints], dtype=np.int64),
        joint_num_points=np.zeros(J, dtype=np.int64),
        joint_fallback=np.zeros(J, dtype=bool),
        joint_score=np.zeros(J),
    )
    if J == 0:
        return out
    heads = {}
    for name, tail in (("joint_heat", ()), ("joint_score", ()), ("joint_offset", (3,)), ("joint_dir", (3,))):
        if name not in outputs:
            raise InputError(f"outputs lack {name!r}")
        x = outputs[name]
        shape = (1, J, N) + tail
        if tuple(x.shape) != shape and tuple(x.shape) != shape[1:]:
            raise InputError(f"outputs[{name!r}] must be {shape}, got {tuple(x.shape)}")
        heads[name] = tensor(x, name, tuple(x.shape), device=pts.device).reshape(shape[1:])
    for j in range(J):  # a handful of joints; everything inside is vectorised over points
        v = joint_from_points(
            pts,
            heads["joint_heat"][j],
            heads["joint_offset"][j],
            heads["joint_dir"][j],
            heads["joint_score"][j],
            awareness=awareness,
            threshold=threshold,
        )
        out["joint_pivot"][j] = v.pivot
        out["joint_axis"][j] = v.axis
        out["joint_num_points"][j] = v.num_points
        out["joint_fallback"][j] = v.fallback
        out["joint_score"][j] = v.score
    return out
