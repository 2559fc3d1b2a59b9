"""ucope: universal 9D category-level pose estimation of rigid and articulated objects.

Layers, each importing only from the ones before it::

    geometry -> objects -> render -> data -> (model -> voting -> eval) -> cli
"""

from __future__ import annotations

__version__ = "0.1.0"

CONVENTIONS_VERSION = "1"
"""Version of the frames / units / per-category canonical frames documented in docs/conventions.md."""

GENERATOR_VERSION = "1"
"""Version of the procedural generators and renderer; data sets record it in meta.json."""

__all__ = ["__version__", "CONVENTIONS_VERSION", "GENERATOR_VERSION", "Estimator", "PoseResult"]


def __getattr__(name: str):
    """``ucope.Estimator`` and ``ucope.PoseResult``, imported on first use (``import ucope`` stays light)."""
    if name == "Estimator":
        from .voting.estimator import Estimator

        return Estimator
    if name == "PoseResult":
        from .voting.result import PoseResult

        return PoseResult
    raise AttributeError(f"module 'ucope' has no attribute {name!r}")
