"""Model configuration, JSON-safe and saved with every model.

:class:`ModelConfig` holds everything needed to rebuild a :class:`ucope.model.network.UCOPENet`: the
category's :class:`ucope.priors.CategoryPriors` (structure and the statistics the voting parameters are
scaled by, measured on the training data), the encoder's hyper-parameters, the bin layout, the pair
sampling and the loss weights.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError
from ..priors import CategoryPriors
from .pointnet2 import PointNet2Config

__all__ = ["ModelConfig", "MODEL_CONFIG_VERSION", "HEADS", "SEG_WEIGHTINGS", "MODEL_SIZES"]

MODEL_CONFIG_VERSION = 2

HEADS = ("voting", "regression")
"""Pose branches: U-COPE's voting, or the direct-regression baseline."""

SEG_WEIGHTINGS = ("balanced", "points")
"""Segmentation cross-entropy weightings (see :attr:`ModelConfig.seg_weighting`)."""

MODEL_SIZES = ("slim", "full")
"""Encoder sizes of :meth:`ModelConfig.default`."""


_SLIM = dict(width=0.5, npoints=(256, 64))
_SLIM_HIDDEN = 64  # head MLP width of the slim model (the pair MLP runs on 20,000 pairs at inference)


@dataclass(frozen=True)
class ModelConfig:
    """Everything that defines a U-COPE network (saved next to its weights).

    Attributes:
        priors: the category's :class:`ucope.priors.CategoryPriors` (parts, joints, statistics).
        encoder: the PointNet++ hyper-parameters (``in_channels = 3``: the normals are point features).
        num_points: points per input cloud (the encoder's ``N``).
        pairs_per_part: point pairs sampled per part per training item.
        hidden: width of the head MLPs.
        mu_bins, nu_bins, angle_bins: bin counts (centre on ``[-V, V]`` / ``[0, V]``; angles on ``[0, pi]``).
        heat_radius: joint heatmap radius as a fraction of ``priors.norm_scale_m``: ``H = max(0, 1 - d/r)``
            with ``d`` the distance of a point to the joint axis line.
        lambda_joint, lambda_seg, lambda_pose: the loss weights of equation (7).
        seg_weighting: the segmentation cross-entropy: ``"balanced"`` (each part's points weigh as
            much as any other part's) or ``"points"`` (every point alike).
        head: ``"voting"`` (U-COPE: the pair encoder and voting) or ``"regression"`` (the baseline
            of :mod:`ucope.model.regression`: the same network with poses regressed directly).
        background_class: the segmentation has a ``K + 1``-th class for points that are not the object
            (floor, outliers, other objects: beyond the paper, see :mod:`ucope.model.network`); training
            items label such points ``K``.
    """

    priors: CategoryPriors
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
    head: str = "voting"
    seg_weighting: str = "balanced"
    background_class: bool = False
    version: int = MODEL_CONFIG_VERSION

    def __post_init__(self) -> None:
        if not isinstance(self.priors, CategoryPriors):
            raise InputError(f"priors must be CategoryPriors, got {type(self.priors).__name__}")
        if self.seg_weighting not in SEG_WEIGHTINGS:
            raise InputError(f"seg_weighting must be one of {SEG_WEIGHTINGS}, got {self.seg_weighting!r}")
        if self.head not in HEADS:
            raise InputError(f"head must be one of {HEADS}, got {self.head!r}")
        if self.encoder.in_channels != 3:
            raise InputError("the encoder takes the normals as point features: in_channels must be 3")
        if self.num_points < self.encoder.npoints[0]:
            raise InputError(f"num_points ({self.num_points}) < the encoder's first level ({self.encoder.npoints[0]})")
        for name in ("pairs_per_part", "hidden", "mu_bins", "nu_bins", "angle_bins"):
            if int(getattr(self, name)) < 1:
                raise InputError(f"{name} must be positive")

    @property
    def category(self) -> str:
        return self.priors.category

    @property
    def num_parts(self) -> int:
        return self.priors.num_parts

    @property
    def num_joints(self) -> int:
        return self.priors.num_joints

    @property
    def part_names(self) -> tuple[str, ...]:
        return self.priors.part_names

    @classmethod
    def default(cls, priors: CategoryPriors, size: str = "slim", **overrides) -> ModelConfig:
        """The default configuration for a category: ``size="full"`` (2048 points, the paper's, head
        MLPs 128 wide) or ``"slim"`` (1024 points, half encoder widths, head MLPs 64 wide: about three
        times as fast to train, and its pair encoder is what makes 20,000 pairs cheap at inference)."""
        if size == "full":
            enc, npts, hidden = PointNet2Config(), 2048, 128
        elif size == "slim":
            enc, npts, hidden = PointNet2Config(**_SLIM), 1024, _SLIM_HIDDEN
        else:
            raise InputError(f"model size must be one of {MODEL_SIZES}, got {size!r}")
        kw: dict[str, Any] = dict(priors=priors, encoder=enc, num_points=npts, hidden=hidden)
        kw.update(overrides)
        return cls(**kw)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (the priors' shape templates travel beside the weights: ``priors.tensors()``)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in ("priors", "encoder")}
        d["priors"] = self.priors.to_dict()
        d["encoder"] = dataclasses.asdict(self.encoder)
        return {k: _jsonable(v) for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], tensors: Mapping[str, Any] | None = None) -> ModelConfig:
        """Inverse of :meth:`to_dict`; ``tensors`` holds the priors' shape templates. Raises
        :class:`InputError` naming the problem (another version, unknown or malformed fields)."""
        try:
            d = dict(d)
            version = int(d.get("version", -1))
            if version != MODEL_CONFIG_VERSION:
                raise InputError(f"model config version {version}; this ucope reads version {MODEL_CONFIG_VERSION}")
            d["priors"] = CategoryPriors.from_dict(d["priors"], tensors)
            d["encoder"] = PointNet2Config(**{k: _tuplify(v) for k, v in d["encoder"].items()})
            names = {f.name for f in dataclasses.fields(cls)}
            unknown = set(d) - names
            if unknown:
                raise InputError(f"unknown model config fields: {sorted(unknown)}")
            return cls(**{k: (_tuplify(v) if k not in ("priors", "encoder") else v) for k, v in d.items()})
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"malformed model config: {type(e).__name__}: {e}") from None


def _jsonable(v: Any) -> Any:
    """``v`` with tuples as lists, recursively (what a JSON round trip gives back); non-finite floats refused."""
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        raise InputError("model config values must be finite")
    return v


def _tuplify(v: Any) -> Any:
    return tuple(_tuplify(x) for x in v) if isinstance(v, list) else v
