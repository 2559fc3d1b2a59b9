"""scripts/calibrate_scores.py's draw of corruptions for its fitting views."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from calibrate_scores import NEEDS_BACKGROUND, view_spec  # noqa: E402


def test_views_without_a_background_pool_never_get_floor_or_bleed_and_the_draw_is_seeded():
    """A validation view rendered with nothing around the object has no pool for the floor and bleed
    corruptions (they would raise); the other kinds are drawn for it, the same ones for the same seed."""
    without = [view_spec(np.random.default_rng(i), has_background=False) for i in range(400)]
    assert not any(s.split("=")[0] in NEEDS_BACKGROUND for s in without)
    assert {s.split("=")[0] for s in without if s} >= {"noise", "axial", "outliers", "occlude", "points"}
    with_pool = [view_spec(np.random.default_rng(i)) for i in range(400)]
    assert {s.split("=")[0] for s in with_pool if s} >= set(NEEDS_BACKGROUND)
    assert 0.15 < sum(s == "" for s in with_pool) / 400 < 0.35  # a quarter stay clean
    assert with_pool == [view_spec(np.random.default_rng(i)) for i in range(400)]
