"""Scores that say when a pose is wrong: calibrated success probabilities per part and per object.

A part succeeds when its rotation error is below :data:`SUCCESS_ROT_DEG` and its translation error below
:data:`SUCCESS_TRANS_REL` of its box diagonal (rotation about y ignored for parts symmetric about y); an object
succeeds when every part does. For each part the ``score`` stage measures :data:`FEATURES`
(:func:`part_features`): what the votes say, what the segmentation says, whether the part's points fit its box,
how many points there were and how sure the joint heads are. A logistic model per category
(:class:`Calibration`, fitted by ``scripts/calibrate_scores.py`` on validation views and stored in the model
file) maps them to ``P(success)``; the object's score is the smallest of its parts'.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from .base import PoseState, stage

BOX_FIT_MARGIN = 0.55
"""A point fits its part's box when each of its coordinates in the part frame lies within this fraction
of the box's size (a half plus 10 % of slack for depth noise), plus 1 mm."""


def part_fit(
    points: np.ndarray, labels: np.ndarray, seg_prob: np.ndarray | None, cam_from_part: np.ndarray, size_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How sure the segmentation is of each part and how well each part's box holds its points.

    Args:
        points: ``(P, 3)`` the network's points (camera frame, metres).
        labels: ``(P,)`` their segmentation (values ``>= K``: background).
        seg_prob: ``(P, C)`` class probabilities, ``C >= K``, or ``None`` (no segmentation).
        cam_from_part: ``(K, 4, 4)`` part poses; size_m: ``(K, 3)`` their box sizes (metres).

    Returns:
        ``(confidence (K,), fit (K,))``: the mean probability of class ``k`` over the points labelled
        ``k`` (1 without ``seg_prob`` or without such points), and the fraction of those points inside
        part ``k``'s box (:data:`BOX_FIT_MARGIN`; 0 without such points).
    """
    T = np.asarray(cam_from_part, np.float64)
    S = np.asarray(size_m, np.float64)
    pts = np.asarray(points, np.float64)
    labels = np.asarray(labels)
    K = len(T)
    conf, fit = np.ones(K), np.zeros(K)
    for k in range(K):  # a handful of parts; vectorised over points
        mine = labels == k
        if not mine.any():
            continue
        if seg_prob is not None:
            conf[k] = float(seg_prob[mine, k].mean())
        local = (pts[mine] - T[k, :3, 3]) @ T[k, :3, :3]  # the points in the part frame
        fit[k] = float(np.mean(np.all(np.abs(local) <= BOX_FIT_MARGIN * S[k] + 1e-3, axis=1)))
    return conf, fit


SUCCESS_ROT_DEG = 10.0
"""A part succeeds below this rotation error (degrees) ..."""


SUCCESS_TRANS_REL = 0.10
"""... and below this translation error, as a fraction of its ground-truth box diagonal."""


FEATURES = (
    "vote_score",
    "inlier_fraction",
    "mean_part_prob",
    "fallback",
    "seg_share",
    "seg_confidence",
    "background_share",
    "box_fit",
    "log_points",
    "joint_score",
    "up_agreement",
    "right_agreement",
)
"""Per-part inputs of the calibration, in order (:func:`part_features`)."""


def part_features(
    votes: Mapping[str, Any],
    labels: np.ndarray,
    seg_prob: np.ndarray | None,
    points: np.ndarray,
    num_input_points: int,
    joint_parents: Sequence[int],
    joint_children: Sequence[int],
) -> np.ndarray:
    """``(K, len(FEATURES))`` float64 features of every part of one estimate.

    Args:
        votes: the dict of :func:`ucope.voting.vote_object` (``score``, ``num_pairs``, ``num_inliers``,
            ``mean_prob``, ``fallback``, ``cam_from_part``, ``size_m``, ``joint_score``), or of
            :func:`ucope.voting.regressed_object` (no votes: the vote features are 0).
        labels: ``(P,)`` the network points' segmentation (``K``: background, models with one).
        seg_prob: ``(P, C)`` their class probabilities, or ``None`` (one part, no segmentation).
        points: ``(P, 3)`` the network's points (camera frame, metres).
        num_input_points: points of the input cloud.
        joint_parents, joint_children: the parts of each joint.
    """
    T = np.asarray(votes["cam_from_part"], np.float64)
    S = np.asarray(votes["size_m"], np.float64)
    K = len(T)
    labels = np.asarray(labels)
    obj = labels < K
    n_obj = max(int(obj.sum()), 1)
    pts = np.asarray(points, np.float64)
    out = np.zeros((K, len(FEATURES)))
    # the direct-regression baseline has no votes: those features are 0 for it
    pairs = np.maximum(np.asarray(votes.get("num_pairs", np.zeros(K)), np.float64), 1.0)
    out[:, 0] = votes["score"] if "num_inliers" in votes else 0.0
    out[:, 1] = np.asarray(votes.get("num_inliers", np.zeros(K)), np.float64) / pairs
    out[:, 2] = votes.get("mean_prob", np.zeros(K))
    out[:, 3] = np.asarray(votes.get("fallback", np.zeros(K)), np.float64)
    out[:, 6] = 1.0 - obj.mean()
    out[:, 8] = math.log(max(int(num_input_points), 1))
    js = np.asarray(votes.get("joint_score", np.zeros(0)), np.float64)
    out[:, 5], out[:, 7] = part_fit(pts, labels, seg_prob, T, S)
    for k in range(K):  # a handful of parts
        out[k, 4] = np.count_nonzero(labels == k) / n_obj
        near = [j for j in range(len(js)) if joint_parents[j] == k or joint_children[j] == k]
        out[k, 9] = min((js[j] for j in near), default=1.0)
    out[:, 10] = votes.get("up_agreement", np.zeros(K))
    out[:, 11] = votes.get("right_agreement", np.zeros(K))
    return out


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))


def fit_logistic(
    X: np.ndarray, y: np.ndarray, l2: float = 1.0, iters: int = 50
) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """L2-regularised logistic regression by Newton's method on standardised features.

    Args:
        X: ``(n, d)`` features; y: ``(n,)`` 0/1 outcomes; l2: ridge weight on the standardised
            coefficients (the intercept is free).

    Returns:
        ``(coef (d,), intercept, mean (d,), std (d,))``: ``P(y = 1) = sigmoid(((x - mean) / std) . coef + intercept)``.
    """
    X = np.asarray(X, np.float64)
    y = np.asarray(y, np.float64)
    if X.ndim != 2 or y.shape != (len(X),) or len(X) < 2:
        raise InputError(f"fit_logistic needs X (n, d) and y (n,) with n >= 2, got {X.shape} and {y.shape}")
    mean, std = X.mean(0), X.std(0)
    std = np.where(std > 1e-9, std, 1.0)
    Z = np.concatenate([(X - mean) / std, np.ones((len(X), 1))], axis=1)
    w = np.zeros(Z.shape[1])
    reg = np.full(Z.shape[1], float(l2))
    reg[-1] = 1e-6
    for _ in range(iters):
        p = _sigmoid(Z @ w)
        g = Z.T @ (p - y) + reg * w
        H = (Z * (p * (1 - p))[:, None]).T @ Z + np.diag(reg)
        step = np.linalg.solve(H, g)
        w -= step
        if float(np.abs(step).max()) < 1e-8:
            break
    return w[:-1], float(w[-1]), mean, std


@dataclass(frozen=True)
class Calibration:
    """A category's score calibration: ``P(part succeeds) = sigmoid(((f - mean) / std) . coef + intercept
    + part_bias[k])`` over :data:`FEATURES` ``f``.

    Attributes:
        coef, mean, std: ``(len(FEATURES),)``; intercept: float; part_bias: ``(K,)`` per-part offsets.
        threshold: object scores below it count as "probably wrong" (the estimator warns).
        info: how it was fitted and measured (views, AUROC...), free-form JSON.
    """

    coef: tuple[float, ...]
    intercept: float
    mean: tuple[float, ...]
    std: tuple[float, ...]
    part_bias: tuple[float, ...]
    threshold: float = 0.5
    info: dict | None = None

    def __post_init__(self) -> None:
        d = len(FEATURES)
        for name in ("coef", "mean", "std"):
            v = np.asarray(getattr(self, name), np.float64)
            if v.shape != (d,) or not np.all(np.isfinite(v)):
                raise InputError(f"calibration {name} must hold {d} finite numbers")
        if not (math.isfinite(self.intercept) and 0.0 <= self.threshold <= 1.0):
            raise InputError("calibration intercept must be finite and threshold in [0, 1]")
        if np.any(np.asarray(self.std, np.float64) <= 0):
            raise InputError("calibration std must be positive")

    def part_scores(self, features: np.ndarray) -> np.ndarray:
        """``(K,)`` success probabilities of the parts from their ``(K, d)`` features."""
        F = np.asarray(features, np.float64)
        bias = np.asarray(self.part_bias, np.float64)
        if F.shape != (len(bias), len(FEATURES)):
            raise InputError(f"features must be ({len(bias)}, {len(FEATURES)}), got {F.shape}")
        z = ((F - np.asarray(self.mean)) / np.asarray(self.std)) @ np.asarray(self.coef) + self.intercept + bias
        return _sigmoid(z)

    def to_dict(self) -> dict:
        return {
            "features": list(FEATURES),
            "coef": [float(x) for x in self.coef],
            "intercept": float(self.intercept),
            "mean": [float(x) for x in self.mean],
            "std": [float(x) for x in self.std],
            "part_bias": [float(x) for x in self.part_bias],
            "threshold": float(self.threshold),
            "info": self.info or {},
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Calibration:
        try:
            if list(d["features"]) != list(FEATURES):
                raise InputError(f"calibration features {d['features']} are not this ucope's {list(FEATURES)}")
            return cls(
                coef=tuple(d["coef"]),
                intercept=float(d["intercept"]),
                mean=tuple(d["mean"]),
                std=tuple(d["std"]),
                part_bias=tuple(d["part_bias"]),
                threshold=float(d.get("threshold", 0.5)),
                info=dict(d.get("info") or {}),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"malformed score calibration ({type(e).__name__}: {e})") from None

    @classmethod
    def fit(
        cls,
        features: np.ndarray,
        success: np.ndarray,
        part_index: np.ndarray,
        num_parts: int,
        l2: float = 1.0,
        info: dict | None = None,
    ) -> Calibration:
        """Fit on ``(n, d)`` part features, their ``(n,)`` 0/1 success and ``(n,)`` part indices (a one-hot of
        the part is fitted beside the features and folded into ``part_bias``). The threshold starts at 0.5;
        the fitting script sets it from the data (``dataclasses.replace``)."""
        X = np.asarray(features, np.float64)
        onehot = np.eye(num_parts)[np.asarray(part_index, np.int64)][:, 1:]  # part 0 is the reference
        coef, b, mean, std = fit_logistic(np.concatenate([X, onehot], axis=1), success, l2=l2)
        d = len(FEATURES)
        # the one-hot columns were standardised: fold them back into raw per-part offsets
        shift = -float(np.sum(mean[d:] / std[d:] * coef[d:]))
        pb = np.concatenate([[0.0], coef[d:] / std[d:]]) + shift
        return cls(
            coef=tuple(coef[:d]),
            intercept=b,
            mean=tuple(mean[:d]),
            std=tuple(std[:d]),
            part_bias=tuple(pb),
            threshold=0.5,
            info=info,
        )


def auroc(scores: np.ndarray, labels: np.ndarray) -> float | None:
    """Area under the ROC curve of ``scores`` for the 0/1 ``labels`` (the probability that a random
    positive scores above a random negative, ties counting half); ``None`` without both classes."""
    s = np.asarray(scores, np.float64)
    y = np.asarray(labels).astype(bool)
    n1, n0 = int(y.sum()), int((~y).sum())
    if n1 == 0 or n0 == 0:
        return None
    order = np.argsort(s, kind="mergesort")
    ranks = np.empty(len(s))
    sorted_s = s[order]
    # average ranks of ties (1-based)
    starts = np.flatnonzero(np.r_[True, sorted_s[1:] != sorted_s[:-1]])
    ends = np.r_[starts[1:], len(s)]
    avg = 0.5 * (starts + ends - 1) + 1.0
    ranks[order] = np.repeat(avg, ends - starts)
    return float((ranks[y].sum() - n1 * (n1 + 1) / 2.0) / (n1 * n0))


@stage("score", kind="calibration")
def _score(state: PoseState, params) -> None:
    """Each part's calibrated probability of being right, from what its votes, segmentation and box say (the raw
    vote score for a model without a calibration)."""
    votes = {**state.votes, "cam_from_part": state.cam_from_part, "size_m": state.size_m, "joint_score": state.joint_score}
    pri = state.priors
    state.features = part_features(
        votes,
        state.seg_labels,
        state.seg_prob,
        state.points,
        state.num_input,
        [j.parent for j in pri.joints],
        [j.child for j in pri.joints],
    )
    cal = state.calibration
    state.score = cal.part_scores(state.features) if cal is not None else np.asarray(state.votes["score"], np.float64)
