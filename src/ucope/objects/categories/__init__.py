"""The procedural categories: a registry of :class:`CategorySpec`, one module per category.

Each category is a generator: ``spec.build(rng, instance_id) -> ArticulatedObject`` draws a new,
plausible instance from shape-parameter ranges. :func:`make_instance` derives the random stream from
``(category, split, index, seed)`` with :class:`numpy.random.SeedSequence`, so train and test instances
come from disjoint streams by construction, and instance ``i`` is the same on every machine.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...errors import InputError, UnknownCategoryError
from ..articulation import ArticulatedObject

__all__ = ["CategorySpec", "CATEGORY_NAMES", "SPLITS", "get_category", "list_categories", "make_instance", "instance_rng"]

SPLITS = ("train", "val", "test")
"""Instance splits. Each split draws its instances from its own random stream."""


@dataclass(frozen=True)
class CategorySpec:
    """Static description of a category and its generator.

    Attributes:
        name: registry name (``"laptop"``, ``"laptop_rigid"``...).
        family: ``"artimage"`` (articulated, ArtImage-like) or ``"nocs"`` (rigid, NOCS-like).
        part_names: the K part names, root first.
        joint_types: the K-1 joint types.
        symmetry: per part ``"none"`` or ``"y"``.
        distance_range_m: camera distance range (to the object centre) for rendering, metres.
        elevation_range_deg: camera elevation range above the object's x-z plane, degrees.
        build: ``(rng, instance_id) -> ArticulatedObject``.
        description: one line for ``ucope categories``.
    """

    name: str
    family: str
    part_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    symmetry: tuple[str, ...]
    distance_range_m: tuple[float, float]
    elevation_range_deg: tuple[float, float]
    build: Callable[[np.random.Generator, str], ArticulatedObject]
    description: str = ""

    @property
    def num_parts(self) -> int:
        return len(self.part_names)


def _load() -> dict[str, CategorySpec]:
    from . import (  # noqa: PLC0415 - one module per category
        bottle,
        bowl,
        camera,
        can,
        dishwasher,
        drawer,
        eyeglasses,
        laptop,
        laptop_rigid,
        mug,
        scissors,
    )

    mods = [laptop, eyeglasses, dishwasher, scissors, drawer, bottle, bowl, camera, can, laptop_rigid, mug]
    return {m.SPEC.name: m.SPEC for m in mods}


_REGISTRY: dict[str, CategorySpec] | None = None


def _registry() -> dict[str, CategorySpec]:
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = _load()
    return _REGISTRY


CATEGORY_NAMES = (
    "laptop", "eyeglasses", "dishwasher", "scissors", "drawer",
    "bottle", "bowl", "camera", "can", "laptop_rigid", "mug",
)
"""All registered category names: the ArtImage five, then the NOCS six (``laptop_rigid`` is NOCS's laptop)."""


def list_categories() -> list[CategorySpec]:
    """Every category spec, ArtImage five first, then the NOCS six."""
    reg = _registry()
    return [reg[n] for n in CATEGORY_NAMES]


def get_category(name: str) -> CategorySpec:
    """The spec of category ``name``; raises :class:`UnknownCategoryError` listing the valid names."""
    reg = _registry()
    if name not in reg:
        raise UnknownCategoryError(f"unknown category {name!r}; valid categories: {', '.join(CATEGORY_NAMES)}")
    return reg[name]


def _key(text: str) -> int:
    return zlib.crc32(text.encode("utf-8"))


def instance_rng(category: str, split: str, index: int, seed: int = 0) -> np.random.Generator:
    """The random stream of instance ``index`` of ``category`` in ``split`` (independent of any other)."""
    if split not in SPLITS:
        raise InputError(f"unknown split {split!r}; valid splits: {', '.join(SPLITS)}")
    if index < 0:
        raise InputError(f"instance index must be >= 0, got {index}")
    ss = np.random.SeedSequence(entropy=int(seed), spawn_key=(_key(category), _key("instance"), _key(split), int(index)))
    return np.random.default_rng(ss)


def make_instance(category: str, split: str, index: int, seed: int = 0) -> ArticulatedObject:
    """Build instance ``index`` of ``category`` for ``split`` (``"train"``, ``"val"`` or ``"test"``)."""
    spec = get_category(category)
    rng = instance_rng(category, split, index, seed)
    obj = spec.build(rng, f"{category}/{split}/{seed}/{index:06d}")
    return obj
