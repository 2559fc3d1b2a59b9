"""The procedural categories: a registry of :class:`CategorySpec`, one module per category (categories of
your own objects, from a spec, are registered at run time: :mod:`ucope.objects.spec`).

Each category is a generator: ``spec.build(rng, instance_id, shape_family) -> ArticulatedObject`` draws a
new, plausible instance of one of the category's :class:`ShapeFamily` from its shape-parameter ranges
(real-world dimensions, documented in docs/conventions.md). :func:`make_instance` derives the random
stream from ``(category, split, index, seed)`` with :class:`numpy.random.SeedSequence`, so the splits'
instances come from disjoint streams by construction, and instance ``i`` is the same on every machine.

Splits (:data:`SPLITS`):

* ``train``, ``val``, ``test``: the category's families that are not held out, drawn uniformly, at the
  generated size (scale 1).
* ``ood`` (out of distribution): only the held-out families (drawn uniformly), each instance scaled
  uniformly (:meth:`ArticulatedObject.scaled`) by a factor drawn log-uniformly in :data:`OOD_SCALE_RANGE`.

:func:`make_instance` can also build any split's instance at an explicit ``scale`` (the same shape, scaled:
for scale curves) or of an explicit ``family`` (for pictures and tests), and stretch it along the object
axes by factors drawn in a ``stretch_range`` (an augmentation of proportions for training data: the factors
come from a stream of their own, so the shapes are those of the unstretched data set).
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...errors import InputError, UnknownCategoryError
from ..articulation import ArticulatedObject

__all__ = [
    "CategorySpec",
    "ShapeFamily",
    "CATEGORY_NAMES",
    "SPLITS",
    "IN_DISTRIBUTION_SPLITS",
    "OOD_SCALE_RANGE",
    "get_category",
    "list_categories",
    "make_instance",
    "instance_rng",
    "instance_family_and_scale",
    "instance_stretch",
    "check_stretch_range",
    "register_category",
    "registered_doc",
]

SPLITS = ("train", "val", "test", "ood")
"""Instance splits. Each split draws its instances from its own random stream; ``ood`` draws only the
held-out shape families, scaled by a factor in :data:`OOD_SCALE_RANGE`."""

IN_DISTRIBUTION_SPLITS = ("train", "val", "test")
"""The splits that draw the families that are not held out, at scale 1."""

OOD_SCALE_RANGE = (0.5, 2.0)
"""The ``ood`` split's scale factors are drawn log-uniformly in this range."""


@dataclass(frozen=True)
class ShapeFamily:
    """A kind of product within a category (e.g. a mug's ``"espresso"`` cup), with its own shape and size
    ranges (the category module's docstring gives them).

    Attributes:
        name: short identifier, unique within the category.
        description: one line (the real products it stands for).
        held_out: ``True``: only the ``ood`` split draws it; train, val and test never do.
    """

    name: str
    description: str
    held_out: bool = False


@dataclass(frozen=True)
class CategorySpec:
    """Static description of a category and its generator.

    Attributes:
        name: registry name (``"laptop"``, ``"laptop_rigid"``...).
        family: ``"artimage"`` (articulated, ArtImage-like), ``"nocs"`` (rigid, NOCS-like) or ``"own"`` (from a
            category spec of your own objects, :mod:`ucope.objects.spec`).
        part_names: the K part names, root first.
        joint_types: the K-1 joint types.
        symmetry: per part ``"none"`` or ``"y"``.
        distance_range_m: camera distance range (to the object centre) for rendering, metres.
        elevation_range_deg: camera elevation range above the object's x-z plane, degrees.
        shape_families: the category's shape families (1-2 of them held out for the ``ood`` split).
        build: ``(rng, instance_id, shape_family) -> ArticulatedObject``: an instance of that family.
        description: one line for ``ucope categories``.
        procedural: ``True`` for the built-in generators (they must hold some, not all, families out);
            ``False`` for a category from a spec (:mod:`ucope.objects.spec`), whose held-out files are optional.
        revision: the revision of this category's generator (>= 1) under
            :data:`ucope.versions.GENERATOR_VERSION`: raised when ``build`` makes something else for some
            instance. Data sets record it (``category_revision`` in ``meta.json``, 1 when absent) and
            readers refuse one made at another revision (:func:`ucope.data.check_versions`).
    """

    name: str
    family: str
    part_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    symmetry: tuple[str, ...]
    distance_range_m: tuple[float, float]
    elevation_range_deg: tuple[float, float]
    shape_families: tuple[ShapeFamily, ...]
    build: Callable[[np.random.Generator, str, str], ArticulatedObject]
    description: str = ""
    procedural: bool = True
    revision: int = 1

    def __post_init__(self) -> None:
        names = [f.name for f in self.shape_families]
        if len(set(names)) != len(names) or not names:
            raise ValueError(f"{self.name}: shape family names must be unique and non-empty, got {names}")
        if isinstance(self.revision, bool) or not isinstance(self.revision, int) or self.revision < 1:
            raise ValueError(f"{self.name}: revision must be an integer >= 1, got {self.revision!r}")
        if self.procedural and (not any(f.held_out for f in self.shape_families) or all(f.held_out for f in self.shape_families)):
            raise ValueError(f"{self.name}: some shape families, not all, must be held out")

    @property
    def num_parts(self) -> int:
        return len(self.part_names)

    @property
    def family_names(self) -> tuple[str, ...]:
        """Every shape family's name, in declaration order."""
        return tuple(f.name for f in self.shape_families)

    @property
    def held_out_families(self) -> tuple[str, ...]:
        """The families only the ``ood`` split draws."""
        return tuple(f.name for f in self.shape_families if f.held_out)

    def families_for_split(self, split: str) -> tuple[str, ...]:
        """The families ``split`` draws from: the held-out ones for ``"ood"``, the others otherwise."""
        if split not in SPLITS:
            raise InputError(f"unknown split {split!r}; valid splits: {', '.join(SPLITS)}")
        ood = split == "ood"
        fams = tuple(f.name for f in self.shape_families if f.held_out == ood)
        if not fams:
            which = "held out (ood)" if ood else "not held out"
            raise InputError(f"category {self.name!r} has no shape families {which}: it has no {split!r} split")
        return fams


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
    "laptop",
    "eyeglasses",
    "dishwasher",
    "scissors",
    "drawer",
    "bottle",
    "bowl",
    "camera",
    "can",
    "laptop_rigid",
    "mug",
)
"""All registered category names: the ArtImage five, then the NOCS six (``laptop_rigid`` is NOCS's laptop)."""


def list_categories() -> list[CategorySpec]:
    """Every category spec, ArtImage five first, then the NOCS six."""
    reg = _registry()
    return [reg[n] for n in CATEGORY_NAMES]


def get_category(name: str) -> CategorySpec:
    """The spec of category ``name`` (built in, or registered in this process by :func:`register_category`);
    raises :class:`UnknownCategoryError` listing the valid names."""
    reg = _registry()
    if name not in reg:
        own = [n for n in reg if n not in CATEGORY_NAMES]
        extra = f"; registered from specs: {', '.join(own)}" if own else ""
        raise UnknownCategoryError(
            f"unknown category {name!r}; valid categories: {', '.join(CATEGORY_NAMES)}{extra} "
            "(a category of your own comes from a spec: ucope generate --spec FILE)"
        )
    return reg[name]


_DOCS: dict[str, dict] = {}


def register_category(spec: CategorySpec, doc: dict | None = None) -> None:
    """Add a non-procedural category (from :func:`ucope.objects.spec.load_spec`) to this process's registry,
    replacing an earlier one of the same name; ``doc``: the spec document it came from
    (:func:`registered_doc`). A built-in name raises :class:`InputError`."""
    if spec.name in CATEGORY_NAMES or spec.procedural:
        raise InputError(f"cannot register {spec.name!r}: built-in names and procedural categories are fixed")
    _registry()[spec.name] = spec
    if doc is not None:
        _DOCS[spec.name] = doc


def registered_doc(name: str) -> dict | None:
    """The spec document a registered category came from (``None`` for a built-in or unknown one)."""
    return _DOCS.get(name)


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


def _draw_family_and_scale(spec: CategorySpec, split: str, rng: np.random.Generator) -> tuple[str, float]:
    """The first draws of an instance's stream: its shape family, then (ood only) its scale factor."""
    choices = spec.families_for_split(split)
    family = choices[int(rng.integers(len(choices)))]
    factor = float(np.exp(rng.uniform(np.log(OOD_SCALE_RANGE[0]), np.log(OOD_SCALE_RANGE[1])))) if split == "ood" else 1.0
    return family, factor


def instance_family_and_scale(category: str, split: str, index: int, seed: int = 0) -> tuple[str, float]:
    """The shape family and the scale factor of instance ``index`` of ``split`` (what :func:`make_instance`
    builds by default), without building it."""
    return _draw_family_and_scale(get_category(category), split, instance_rng(category, split, index, seed))


def check_stretch_range(stretch_range) -> tuple[float, float]:
    """``stretch_range`` as a checked ``(low, high)`` pair with ``0 < low <= 1 <= high``; raises
    :class:`InputError` naming what is wrong."""
    try:
        lo, hi = (float(v) for v in stretch_range)
    except (TypeError, ValueError):
        raise InputError(f"stretch range must be two numbers (low, high), got {stretch_range!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= 1.0 <= hi):
        raise InputError(f"stretch range must satisfy 0 < low <= 1 <= high, got ({lo}, {hi})")
    return lo, hi


def instance_stretch(
    obj: ArticulatedObject, split: str, index: int, seed: int, stretch_range: tuple[float, float], share: float = 1.0
) -> np.ndarray:
    """``(3,)`` the stretch factors along the object's x, y, z for instance ``index``: each drawn
    log-uniformly in ``stretch_range`` from a stream of its own (keyed by category, split, seed and index;
    independent of the instance's shape stream), then one more draw from it leaves the instance unstretched
    (all ones) unless it falls below ``share`` (in [0, 1]; 1: every instance stretched). A part symmetric
    about its y axis gets the geometric mean of the two factors across that axis on both (so it stays
    symmetric)."""
    lo, hi = check_stretch_range(stretch_range)
    if not 0.0 <= float(share) <= 1.0:
        raise InputError(f"stretch share must be a fraction in [0, 1], got {share!r}")
    ss = np.random.SeedSequence(entropy=int(seed), spawn_key=(_key(obj.category), _key("stretch"), _key(split), int(index)))
    rng = np.random.default_rng(ss)
    f = np.exp(rng.uniform(np.log(lo), np.log(hi), size=3))
    if rng.random() >= float(share):
        return np.ones(3)
    for p, T in zip(obj.parts, obj.placements_at_zero(), strict=True):
        if p.symmetry == "y":  # the object axes the part's x and z lie along (signed permutation)
            a, b = (int(np.argmax(np.abs(T[:3, c]))) for c in (0, 2))
            f[a] = f[b] = float(np.sqrt(f[a] * f[b]))
    return f


def make_instance(
    category: str,
    split: str,
    index: int,
    seed: int = 0,
    *,
    scale: float | None = None,
    family: str | None = None,
    stretch_range: tuple[float, float] | None = None,
    stretch_share: float = 1.0,
) -> ArticulatedObject:
    """Build instance ``index`` of ``category`` for ``split`` (one of :data:`SPLITS`).

    The instance's stream first draws its shape family (uniformly among
    :meth:`CategorySpec.families_for_split`), then, for ``"ood"`` only, its scale factor (log-uniform in
    :data:`OOD_SCALE_RANGE`), then the shape. So:

    Args:
        scale: build the same instance scaled by this factor instead of the split's own (1 for train,
            val and test; the drawn factor for ood): the shape does not depend on it, so instance ``i`` at
            scales 0.5, 1 and 2 is one shape at three sizes (:meth:`ArticulatedObject.scaled`).
        family: build a shape of this family instead of the drawn one (the rest of the stream is the same);
            any family of the category, held out or not, for pictures and tests. Data sets never set it.
        stretch_range: ``(low, high)``, ``0 < low <= 1 <= high``: stretch the built object along its x, y
            and z axes by factors drawn log-uniformly in it (:func:`instance_stretch`,
            :meth:`ArticulatedObject.stretched`), after any scaling; ``None`` (default): no stretch.
        stretch_share: the share of instances stretched (the others keep their proportions; drawn from
            the stretch stream, :func:`instance_stretch`).

    Returns:
        The object; its ``shape_family`` and ``scale`` say what was built.
    """
    spec = get_category(category)
    rng = instance_rng(category, split, index, seed)
    drawn, factor = _draw_family_and_scale(spec, split, rng)
    if family is not None:
        if family not in spec.family_names:
            raise InputError(f"{category} has no shape family {family!r}; its families: {', '.join(spec.family_names)}")
        drawn = family
    if scale is not None:
        if (
            isinstance(scale, bool)
            or not isinstance(scale, int | float | np.integer | np.floating)
            or not np.isfinite(scale)
            or scale <= 0
        ):
            raise InputError(f"scale must be a positive finite number, got {scale!r}")
        factor = float(scale)
    obj = spec.build(rng, f"{category}/{split}/{seed}/{index:06d}", drawn)
    obj = obj.scaled(factor) if factor != 1.0 else obj
    if stretch_range is not None:
        f = instance_stretch(obj, split, index, seed, stretch_range, stretch_share)
        obj = obj.stretched(f) if np.any(f != 1.0) else obj
    return obj
