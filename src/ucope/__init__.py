"""ucope: universal 9D category-level pose estimation of rigid and articulated objects.

Layers, each importing only from the ones before it (docs/architecture.md)::

    errors, versions, vocab, fileio, plotting -> geometry -> priors
        -> objects -> render -> data -> model -> voting -> estimation -> eval -> cli

``ucope.Estimator`` and ``ucope.PoseResult`` are imported on first use, so ``import ucope`` stays light.
"""

from __future__ import annotations

from .versions import CONVENTIONS_VERSION, GENERATOR_VERSION, __version__

__all__ = ["__version__", "CONVENTIONS_VERSION", "GENERATOR_VERSION", "Estimator", "PoseResult"]


def __getattr__(name: str):
    if name == "Estimator":
        from .estimation.estimator import Estimator

        return Estimator
    if name == "PoseResult":
        from .estimation.result import PoseResult

        return PoseResult
    raise AttributeError(f"module 'ucope' has no attribute {name!r}")
