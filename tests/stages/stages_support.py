"""Scenes shared by the tests of several stage modules: real generated samples and small hand-made priors."""

from __future__ import annotations

import numpy as np

from ucope.data.generate import GenerateConfig, make_sample
from ucope.geometry.transforms import rotation_about_axis
from ucope.priors import CategoryPriors, JointPrior, PartPrior, StackPrior


def samples(category, split, n):
    """The first ``n`` views of ``category``'s ``split`` (seed 0, one view per instance)."""
    cfg = GenerateConfig(category=category, split=split, num=n, seed=0, views_per_instance=1)
    return [make_sample(cfg, i) for i in range(n)]


def door_priors(ratio=(1.0, 0.86, 0.2), spread=(0.004, 0.02, 0.2)):
    """A body and a door hinged along x at the body's front bottom edge (the door's bottom edge)."""
    return CategoryPriors(
        category="cabinet_door",
        parts=(PartPrior("body", "none", 1.0, (0.6, 0.8, 0.6)), PartPrior("door", "none", 1.0, (0.6, 0.7, 0.1))),
        joints=(
            JointPrior(
                "revolute",
                0,
                1,
                (1, 0, 0),
                limits=(0.0, 1.57),
                child_size_ratio=ratio,
                child_size_spread=spread,
                pivot_in_parent=(0.0, -0.5, 0.5),
                pivot_in_child=(0.0, -0.5, -0.5),
            ),
        ),
    )


def chest(first_gap_spread=0.06, gap_spread=0.04):
    """A cabinet (part 0, 0.6 x 1.0 x 0.5) with three drawers stacked top down (parts 1-3) along its y."""
    parts = (PartPrior("cabinet", "none", 0.8, (0.6, 1.0, 0.5)),) + tuple(
        PartPrior(f"drawer{k}", "none", 0.4, (0.55, 0.25, 0.45)) for k in (1, 2, 3)
    )
    joints = tuple(JointPrior("prismatic", 0, k, (0, 0, 1), limits=(0.0, 0.3)) for k in (1, 2, 3))
    stack = StackPrior(0, 1, (1, 2, 3), first_gap=0.03, gap=0.005, first_gap_spread=first_gap_spread, gap_spread=gap_spread)
    return CategoryPriors("chest", parts, joints, norm_scale_m=0.5, stacks=(stack,))


def chest_scene(seed):
    """Voted poses of :func:`chest`: the drawers (0.2 / 0.25 / 0.3 m tall) at 0.55 / 0.3 / 0 m up the cabinet's y,
    pulled out 0.1 / 0.02 / 0.2 m, under one random rotation. Returns ``(T (4, 4, 4), S (4, 3), R (3, 3))``."""
    rng = np.random.default_rng(seed)
    R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = rng.normal(size=3) + [0, 0, 3]
    local = np.array([[0, 0, 0], [0.0, 0.55, 0.1], [0.0, 0.3, 0.02], [0.0, 0.0, 0.2]])
    T[1:, :3, 3] = T[0, :3, 3] + local[1:] @ R.T
    S = np.array([[0.6, 1.0, 0.5], [0.55, 0.2, 0.45], [0.55, 0.25, 0.45], [0.55, 0.3, 0.45]])
    return T, S, R


def labels_of(counts):
    """Point labels: ``counts[k]`` points of part ``k``, in order."""
    return np.repeat(np.arange(len(counts)), counts)
