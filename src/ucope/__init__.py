"""ucope: universal 9D category-level pose estimation of rigid and articulated objects.

Layers, each importing only from the ones before it (docs/architecture.md)::

    errors, versions, vocab, fileio, plotting -> geometry -> priors
        -> objects -> render -> data -> model -> voting -> estimation -> eval -> cli

``ucope.Estimator``, ``ucope.PoseResult`` and the sub-packages (``ucope.data``, ``ucope.eval``...) are
imported on first use, so ``import ucope`` stays light and ``ucope.data.load_dataset`` works after a
plain ``import ucope``; ``dir(ucope)`` lists them all (tab completion sees them).
"""

from __future__ import annotations

from .versions import CONVENTIONS_VERSION, GENERATOR_VERSION, __version__

__all__ = ["__version__", "CONVENTIONS_VERSION", "GENERATOR_VERSION", "Estimator", "PoseResult"]


_SUBMODULES = (
    "cli",
    "data",
    "errors",
    "estimation",
    "eval",
    "fileio",
    "geometry",
    "model",
    "objects",
    "plotting",
    "priors",
    "render",
    "versions",
    "vocab",
    "voting",
)


def __getattr__(name: str):
    if name in _SUBMODULES:
        import importlib

        return importlib.import_module(f"{__name__}.{name}")
    if name == "Estimator":
        from .estimation.estimator import Estimator

        return Estimator
    if name == "PoseResult":
        from .estimation.result import PoseResult

        return PoseResult
    raise AttributeError(f"module 'ucope' has no attribute {name!r}")


def __dir__() -> list[str]:
    """What tab completion offers: the loaded names, ``Estimator``, ``PoseResult`` and the sub-packages
    (all imported on first use)."""
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))
