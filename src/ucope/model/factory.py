"""Building the network a :class:`ucope.model.config.ModelConfig` describes."""

from __future__ import annotations

from .config import ModelConfig
from .network import UCOPENet
from .regression import RegressionNet

__all__ = ["build_model"]


def build_model(cfg: ModelConfig) -> UCOPENet:
    """:class:`ucope.model.network.UCOPENet` (``cfg.head == "voting"``) or the direct-regression
    baseline :class:`ucope.model.regression.RegressionNet` (``"regression"``), with fresh weights."""
    return RegressionNet(cfg) if cfg.head == "regression" else UCOPENet(cfg)
