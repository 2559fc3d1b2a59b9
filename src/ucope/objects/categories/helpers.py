"""Category-building helpers that are not mesh primitives (those are in :mod:`ucope.objects.shapes`)."""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine

__all__ = ["uniform", "rigid_object", "build_with_variant"]


def uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """One float drawn uniformly in ``[lo, hi)`` (a plain Python float, for the params dict)."""
    return float(rng.uniform(lo, hi))


def rigid_object(
    category: str, instance_id: str, meshes: Sequence[trimesh.Trimesh], symmetry: str, params: dict, shape_family: str = ""
) -> ArticulatedObject:
    """A one-part object (part ``"body"``) of ``shape_family`` from ``meshes`` written in the object frame;
    the part frame is put at the centre of their amodal box (:func:`ucope.objects.articulation.make_part`)."""
    mesh = combine(list(meshes)) if len(meshes) > 1 else meshes[0]
    part, T = make_part("body", mesh, symmetry=symmetry)
    return build_object(category, instance_id, [(part, T)], joints=[], params=params, shape_family=shape_family)


def build_with_variant(
    rng: np.random.Generator,
    build: Callable[[np.random.Generator, dict | None], ArticulatedObject],
    p: float,
    ranges: Mapping[str, tuple[float, float]],
) -> ArticulatedObject:
    """An instance that takes a variant with chance ``p``, decided without changing any other instance.

    ``build(rng, None)`` builds the instance as it was before the variant existed; one more draw from ``rng``
    then decides. With chance ``p`` the variant's values are drawn, each uniformly in its ``(lo, hi)`` of
    ``ranges`` in their order, and the instance is built again, ``build(replay, variant)``, from a copy of
    ``rng``'s state before the first build: ``build`` must make the same draws either way and only use the
    variant's values in place of some of them. So an instance that does not take the variant is byte for byte
    the one built before, one that takes it shares all of its other draws, and ``rng`` ends after the decision
    (and the variant's draws) either way.

    Args:
        rng: the instance's stream.
        build: ``build(rng, variant)`` -> the instance; ``variant`` is ``None`` or ``{name: value}`` of ``ranges``.
        p: the chance of the variant, in ``[0, 1]``.
        ranges: ``{name: (lo, hi)}`` of the variant's values.
    """
    start = copy.deepcopy(rng.bit_generator.state)
    obj = build(rng, None)
    if rng.random() >= p:
        return obj
    variant = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in ranges.items()}
    replay = np.random.Generator(type(rng.bit_generator)(0))  # its state is replaced by the saved one
    replay.bit_generator.state = start
    return build(replay, variant)
