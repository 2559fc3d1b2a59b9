"""Category-building helpers that are not mesh primitives (those are in :mod:`ucope.objects.shapes`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine

__all__ = ["uniform", "rigid_object"]


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
