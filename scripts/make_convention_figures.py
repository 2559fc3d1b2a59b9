"""Regenerate the per-category pictures of docs/conventions.md (docs/images/conventions_<name>.png).

Usage: python scripts/make_convention_figures.py
Each picture shows train instance 0 of the category at a mid joint state, with part boxes, part frames
(x red, y green, z blue) and joint axes (black, arrow head = positive direction).
"""

from pathlib import Path

import numpy as np

from ucope.data.visualize import plot_object
from ucope.objects.categories import CATEGORY_NAMES, make_instance

out_dir = Path(__file__).resolve().parents[1] / "docs" / "images"
for name in CATEGORY_NAMES:
    obj = make_instance(name, "train", 0)
    state = obj.limits.mean(axis=1) if obj.joints else None
    label = f"{name}: state {np.round(state, 2).tolist()}" if state is not None else f"{name} (rigid)"
    print(plot_object(obj, out_dir / f"conventions_{name}.png", state=state, title=label))
