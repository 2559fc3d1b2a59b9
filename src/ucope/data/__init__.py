"""Synthetic data sets: generation (sharded, resumable, deterministic) and loading.

``load_dataset(DIR)`` gives an indexable sequence of sample dicts (fields in :mod:`ucope.data.sample`);
``GeneratedSamples`` streams new samples on the fly; ``PointCloudDataset`` (a torch ``Dataset``, imported
lazily) gives fixed-size point sets.
"""

from __future__ import annotations

from .dataset import SyntheticDataset, check_versions, load_dataset
from .generate import GenerateConfig, generate_dataset, make_sample
from .stream import GeneratedSamples

__all__ = [
    "SyntheticDataset",
    "load_dataset",
    "check_versions",
    "GenerateConfig",
    "generate_dataset",
    "make_sample",
    "GeneratedSamples",
    "PointCloudDataset",
]


def __getattr__(name: str):
    if name == "PointCloudDataset":  # keeps `import ucope.data` free of torch
        from .torch_dataset import PointCloudDataset

        return PointCloudDataset
    raise AttributeError(f"module 'ucope.data' has no attribute {name!r}")
