"""Shared fixtures: a small hand-built articulated object that does not depend on the generators."""

from __future__ import annotations

import numpy as np

from ucope.objects.articulation import build_object, make_part
from ucope.objects.shapes import box


def make_toy_object(joint_type: str = "revolute"):
    """A 0.4 x 0.1 x 0.3 base with a 0.4 x 0.02 x 0.3 lid hinged along x at the back top edge."""
    base, T0 = make_part("base", box([0.4, 0.1, 0.3], [0.0, 0.05, 0.0]))
    lid, T1 = make_part("lid", box([0.4, 0.02, 0.3], [0.0, 0.11, 0.0]))
    if joint_type == "revolute":
        joint = dict(
            type="revolute", parent=0, child=1, pivot=[0.0, 0.1, -0.15], axis=[-1.0, 0.0, 0.0], limits=(0.0, 2.5), rest=1.0
        )
    else:
        joint = dict(
            type="prismatic", parent=0, child=1, pivot=[0.0, 0.1, 0.0], axis=[0.0, 0.0, 1.0], limits=(0.0, 0.25), rest=0.0
        )
    return build_object("toy", "toy/0", [(base, T0), (lid, T1)], [joint])


def measured_priors(category: str, samples):
    """The :class:`ucope.priors.CategoryPriors` a training run would measure on ``samples`` of a
    procedural category (its declared structure from the generator's instance 0)."""
    from ucope.objects.categories import make_instance
    from ucope.priors import measure_priors

    return measure_priors(samples, category, make_instance(category, "train", 0).structure())


def seen_pattern_reference(T, S):
    """Plain loops: the camera (origin) in each box's frame, each axis's two other axes coded by hand."""
    out = np.zeros((len(T), 3), dtype=int)
    for k in range(len(T)):
        cam = T[k, :3, :3].T @ (np.zeros(3) - T[k, :3, 3])
        codes = []
        for b in range(3):
            if cam[b] > S[k, b] / 2:
                codes.append(1)
            elif cam[b] < -S[k, b] / 2:
                codes.append(2)
            else:
                codes.append(0)
        for a in range(3):
            b, c = [i for i in range(3) if i != a]
            out[k, a] = 3 * codes[b] + codes[c]
    return out
