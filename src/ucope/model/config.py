"""Model configuration and per-category statistics, both JSON-safe and saved with every model.

:class:`CategoryStats` holds what the voting parameters are scaled by (vote ranges, mean part sizes,
the input normalisation scale), measured on the training data. :class:`ModelConfig` holds everything
needed to rebuild a :class:`ucope.model.network.UCOPENet`: the category's structure, the encoder's
hyper-parameters, the bin layout, the pair sampling and the loss weights.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..errors import InputError
from .pointnet2 import PointNet2Config

__all__ = ["CategoryStats", "ModelConfig", "compute_category_stats", "MODEL_CONFIG_VERSION", "HEADS"]

MODEL_CONFIG_VERSION = 1

HEADS = ("voting", "regression")
"""Pose branches: U-COPE's voting, or the direct-regression baseline."""


@dataclass(frozen=True)
class CategoryStats:
    """Per-category, per-part statistics from the training data (all in metres).

    Attributes:
        vote_range_m: ``(K,)`` ``V_k``: an upper bound of the distance from any point of part ``k`` to its
            box centre (1.1 x the largest half box diagonal seen). ``mu`` is binned on ``[-V_k, V_k]``,
            ``nu`` on ``[0, V_k]``.
        mean_size_m: ``(K, 3)`` geometric mean of the amodal box extents of part ``k`` (``exp`` of the mean
            log size); ``gamma = log(size_m) - log(mean_size_m)``.
        norm_scale_m: the object scale the encoder's input is divided by (mean cloud radius about the
            cloud centroid).
        num_samples: how many samples the statistics were measured on.
        joint_zero_offset_m: ``(J,)`` per joint, prismatic: the mean gap between the child's and the
            parent's box supports along the joint axis minus the joint state, at the ground-truth poses
            (:func:`ucope.geometry.kinematics.prismatic_zero_offset`), the constant that turns a support
            gap into a state; 0.0 for revolute joints. ``()`` when not measured (older statistics).
    """

    vote_range_m: tuple[float, ...]
    mean_size_m: tuple[tuple[float, float, float], ...]
    norm_scale_m: float
    num_samples: int = 0
    joint_zero_offset_m: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        K = len(self.vote_range_m)
        if K == 0 or len(self.mean_size_m) != K:
            raise InputError("CategoryStats: vote_range_m and mean_size_m need one entry per part")
        vals = np.array([*self.vote_range_m, *np.ravel(self.mean_size_m), self.norm_scale_m], dtype=np.float64)
        if not np.all(np.isfinite(vals)) or np.any(vals <= 0):
            raise InputError("CategoryStats: every range, size and scale must be a positive finite number")
        if not np.all(np.isfinite(np.asarray(self.joint_zero_offset_m, dtype=np.float64))):
            raise InputError("CategoryStats: joint_zero_offset_m must be finite")

    def to_dict(self) -> dict[str, Any]:
        return {
            "vote_range_m": [float(v) for v in self.vote_range_m],
            "mean_size_m": [[float(x) for x in s] for s in self.mean_size_m],
            "norm_scale_m": float(self.norm_scale_m),
            "num_samples": int(self.num_samples),
            "joint_zero_offset_m": [float(v) for v in self.joint_zero_offset_m],
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "CategoryStats":
        try:
            return cls(
                vote_range_m=tuple(float(v) for v in d["vote_range_m"]),
                mean_size_m=tuple(tuple(float(x) for x in s) for s in d["mean_size_m"]),
                norm_scale_m=float(d["norm_scale_m"]),
                num_samples=int(d.get("num_samples", 0)),
                joint_zero_offset_m=tuple(float(v) for v in d.get("joint_zero_offset_m", ())),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"malformed category statistics: {e}") from None


def compute_category_stats(samples: Sequence[dict], max_samples: int = 2000, joints: Sequence[tuple[int, int]] | None = None) -> CategoryStats:
    """Measure :class:`CategoryStats` on (up to ``max_samples`` evenly spaced) training samples.

    Args:
        samples: an indexable sequence of sample dicts (e.g. :func:`ucope.data.load_dataset`).
        joints: ``(parent, child)`` part indices of each joint; by default those of the category of the
            first sample (``sample["category"]``). Needed for ``joint_zero_offset_m``.
    """
    from ..geometry.kinematics import prismatic_zero_offset

    n = len(samples)
    if n == 0:
        raise InputError("cannot compute category statistics on an empty data set")
    idx = np.unique(np.linspace(0, n - 1, min(n, int(max_samples))).round().astype(int))
    sizes, radii, poses, axes, types, states = [], [], [], [], [], []
    for i in idx:
        s = samples[int(i)]
        sizes.append(np.asarray(s["size_m"], np.float64))
        pts = np.asarray(s["points"], np.float64)
        radii.append(np.linalg.norm(pts - pts.mean(0), axis=1).max())
        if "joint_type" in s and len(s["joint_type"]) > 0:
            poses.append(np.asarray(s["cam_from_part"], np.float64))
            axes.append(np.asarray(s["joint_axis"], np.float64))
            types.append(np.asarray(s["joint_type"], np.int64))
            states.append(np.asarray(s["joint_state"], np.float64))
    size = np.stack(sizes)  # (S, K, 3)
    if np.any(size <= 0):
        raise InputError("training samples hold a non-positive part size")
    vote = 1.1 * 0.5 * np.linalg.norm(size, axis=-1).max(0)
    mean = np.exp(np.log(size).mean(0))
    zero: tuple[float, ...] = ()
    if types:
        T, U, Q, JT = np.stack(poses), np.stack(axes), np.stack(states), np.stack(types)  # (S, K, 4, 4) ...
        if joints is None:
            from ..objects.categories import make_instance

            obj = make_instance(str(samples[int(idx[0])]["category"]), "train", 0)
            joints = [(int(j.parent), int(j.child)) for j in obj.joints]
        if len(joints) != JT.shape[1]:
            raise InputError(f"{len(joints)} (parent, child) pairs given for {JT.shape[1]} joints")
        offs = []
        for j, (p, c) in enumerate(joints):  # a handful of joints; vectorised over samples
            if np.all(JT[:, j] == 1):
                offs.append(prismatic_zero_offset(T[:, p], T[:, c], U[:, j], size[:, p], size[:, c], Q[:, j]))
            else:
                offs.append(0.0)
        zero = tuple(float(v) for v in offs)
    return CategoryStats(
        vote_range_m=tuple(float(v) for v in vote),
        mean_size_m=tuple(tuple(float(x) for x in m) for m in mean),
        norm_scale_m=float(np.mean(radii)),
        num_samples=len(idx),
        joint_zero_offset_m=zero,
    )


_SLIM = dict(width=0.5, npoints=(256, 64))
_SLIM_HIDDEN = 64  # head MLP width of the slim model (the pair MLP runs on 20,000 pairs at inference)


@dataclass(frozen=True)
class ModelConfig:
    """Everything that defines a U-COPE network (saved next to its weights).

    Attributes:
        category: category name; ``part_names``, ``part_symmetry`` (``"none"``/``"y"``), ``joint_types``
            (codes: 0 revolute, 1 prismatic), ``joint_parents`` / ``joint_children`` (part indices):
            the category's structure.
        stats: :class:`CategoryStats`.
        encoder: the PointNet++ hyper-parameters (``in_channels = 3``: the normals are point features).
        num_points: points per input cloud (the encoder's ``N``).
        pairs_per_part: point pairs sampled per part per training item.
        hidden: width of the head MLPs.
        mu_bins, nu_bins, angle_bins: bin counts (centre on ``[-V, V]`` / ``[0, V]``; angles on ``[0, pi]``).
        heat_radius: joint heatmap radius as a fraction of ``stats.norm_scale_m``: ``H = max(0, 1 - d/r)``
            with ``d`` the distance of a point to the joint axis line.
        joint_axes_in_parent: ``(J, 3)`` each joint's canonical unit axis in its parent's part frame
            (the category's, from :func:`ucope.objects.categories.make_instance`); used by the
            kinematic refinement. ``()`` for configurations saved before it existed.
        lambda_joint, lambda_seg, lambda_pose: the loss weights of equation (7).
        seg_weighting: the segmentation cross-entropy: ``"balanced"`` (each part's points weigh as
            much as any other part's) or ``"points"`` (every point alike).
        head: ``"voting"`` (U-COPE: the pair encoder and voting) or ``"regression"`` (the baseline
            of :mod:`ucope.model.regression`: the same network with poses regressed directly).
    """

    category: str
    part_names: tuple[str, ...]
    part_symmetry: tuple[str, ...]
    joint_types: tuple[int, ...]
    joint_parents: tuple[int, ...]
    joint_children: tuple[int, ...]
    stats: CategoryStats
    encoder: PointNet2Config = field(default_factory=PointNet2Config)
    num_points: int = 2048
    pairs_per_part: int = 512
    hidden: int = 128
    mu_bins: int = 32
    nu_bins: int = 32
    angle_bins: int = 36
    heat_radius: float = 0.15
    lambda_joint: float = 0.2
    lambda_seg: float = 0.2
    lambda_pose: float = 0.6
    joint_axes_in_parent: tuple = ()
    head: str = "voting"
    seg_weighting: str = "balanced"
    version: int = MODEL_CONFIG_VERSION

    def __post_init__(self) -> None:
        K = len(self.part_names)
        if K == 0:
            raise InputError("a model needs at least one part")
        if len(self.part_symmetry) != K or len(self.stats.vote_range_m) != K:
            raise InputError(f"part_symmetry and stats need {K} parts")
        J = len(self.joint_types)
        if not (len(self.joint_parents) == len(self.joint_children) == J == K - 1):
            raise InputError(f"a {K}-part model needs {K - 1} joints with a parent and a child each")
        if any(t not in (0, 1) for t in self.joint_types):
            raise InputError(f"joint types must be 0 (revolute) or 1 (prismatic), got {self.joint_types}")
        if self.seg_weighting not in ("balanced", "points"):
            raise InputError(f"seg_weighting must be 'balanced' or 'points', got {self.seg_weighting!r}")
        if self.head not in HEADS:
            raise InputError(f"head must be one of {HEADS}, got {self.head!r}")
        if any(s not in ("none", "y") for s in self.part_symmetry):
            raise InputError(f"part symmetry must be 'none' or 'y', got {self.part_symmetry}")
        if self.encoder.in_channels != 3:
            raise InputError("the encoder takes the normals as point features: in_channels must be 3")
        if self.num_points < self.encoder.npoints[0]:
            raise InputError(f"num_points ({self.num_points}) < the encoder's first level ({self.encoder.npoints[0]})")
        if self.joint_axes_in_parent:
            ax = np.asarray(self.joint_axes_in_parent, dtype=np.float64)
            if ax.shape != (J, 3) or not np.all(np.isfinite(ax)) or np.any(np.linalg.norm(ax, axis=-1) < 1e-9):
                raise InputError(f"joint_axes_in_parent must hold {J} non-zero finite 3-vectors, got {self.joint_axes_in_parent}")
        for name in ("pairs_per_part", "hidden", "mu_bins", "nu_bins", "angle_bins"):
            if int(getattr(self, name)) < 1:
                raise InputError(f"{name} must be positive")

    @property
    def num_parts(self) -> int:
        return len(self.part_names)

    @property
    def num_joints(self) -> int:
        return len(self.joint_types)

    @classmethod
    def for_category(cls, category: str, stats: CategoryStats, size: str = "full", **overrides) -> "ModelConfig":
        """The default configuration of ``category``: ``size="full"`` (2048 points, the paper's, head
        MLPs 128 wide) or ``"slim"`` (1024 points, half encoder widths, head MLPs 64 wide: about three
        times as fast to train, and its pair encoder is what makes 20,000 pairs cheap at inference)."""
        from ..objects.articulation import JOINT_TYPES
        from ..objects.categories import get_category, make_instance

        spec = get_category(category)
        obj = make_instance(category, "train", 0)
        if size == "full":
            enc, npts, hidden = PointNet2Config(), 2048, 128
        elif size == "slim":
            enc, npts, hidden = PointNet2Config(**_SLIM), 1024, _SLIM_HIDDEN
        else:
            raise InputError(f"model size must be 'full' or 'slim', got {size!r}")
        kw: dict[str, Any] = dict(
            category=category,
            part_names=tuple(spec.part_names),
            part_symmetry=tuple(spec.symmetry),
            joint_types=tuple(JOINT_TYPES.index(j.type) for j in obj.joints),
            joint_parents=tuple(int(j.parent) for j in obj.joints),
            joint_children=tuple(int(j.child) for j in obj.joints),
            joint_axes_in_parent=tuple(tuple(float(x) for x in j.axis) for j in obj.joints),
            stats=stats,
            encoder=enc,
            num_points=npts,
            hidden=hidden,
        )
        kw.update(overrides)
        return cls(**kw)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["stats"] = self.stats.to_dict()
        d["encoder"] = {k: _jsonable(v) for k, v in dataclasses.asdict(self.encoder).items()}
        return {k: _jsonable(v) for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "ModelConfig":
        try:
            d = dict(d)
            if int(d.get("version", MODEL_CONFIG_VERSION)) > MODEL_CONFIG_VERSION:
                raise InputError(f"model config version {d['version']} is newer than this ucope ({MODEL_CONFIG_VERSION})")
            d["stats"] = CategoryStats.from_dict(d["stats"])
            d["encoder"] = PointNet2Config(**{k: _tuplify(v) for k, v in d["encoder"].items()})
            names = {f.name for f in dataclasses.fields(cls)}
            unknown = set(d) - names
            if unknown:
                raise InputError(f"unknown model config fields: {sorted(unknown)}")
            return cls(**{k: (_tuplify(v) if k not in ("stats", "encoder") else v) for k, v in d.items()})
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"malformed model config: {e}") from None


def _jsonable(v: Any) -> Any:
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        raise InputError("model config values must be finite")
    return v


def _tuplify(v: Any) -> Any:
    return tuple(_tuplify(x) for x in v) if isinstance(v, list) else v
