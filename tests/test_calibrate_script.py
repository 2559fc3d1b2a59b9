"""scripts/calibrate_scores.py's draw of corruptions for its fitting views."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from calibrate_scores import NEEDS_BACKGROUND, part_success, view_spec  # noqa: E402

from ucope.data.corrupt import corrupt  # noqa: E402
from ucope.estimation.result import PartEstimate, PoseResult  # noqa: E402
from ucope.eval.evaluate import mug_handle_kept  # noqa: E402


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


def _mug_turned_about_y(sample: dict, angle_deg: float) -> PoseResult:
    from scipy.spatial.transform import Rotation

    T = np.array(sample["cam_from_part"][0], np.float64)
    T[:3, :3] = T[:3, :3] @ Rotation.from_euler("y", angle_deg, degrees=True).as_matrix()
    part = PartEstimate(index=0, label="body", cam_from_part=T, size_m=np.array(sample["size_m"][0]), score=0.9)
    return PoseResult(category="mug", parts=[part], joints=[], part_labels=np.zeros(len(sample["points"]), np.int64))


def test_calibration_labels_judge_a_mugs_handle_as_the_robustness_benchmark_does():
    """The fitting labels and the benchmark's must agree: a mug cut to a few points that still include a
    handle point is not symmetric (the 20-point threshold scales with the share kept), one whose
    corruption kept no handle point is; points the corruption added never count."""
    from ucope.data.generate import GenerateConfig, make_sample

    cfg = GenerateConfig(category="mug", split="test", num=12, max_points=800, views_per_instance=1)
    mugs = [make_sample(cfg, i) for i in range(12)]
    s = next(m for m in mugs if mug_handle_kept(m, np.arange(len(m["points"]))))
    turned = _mug_turned_about_y(s, 30.0)
    n = len(s["points"])
    assert not part_success(turned, s, np.arange(n)).any()  # handle shown: 30 degrees about y is a failure
    T, (sx, _, sz) = np.asarray(s["cam_from_part"][0]), s["size_m"][0]
    body = np.flatnonzero(((np.asarray(s["points"]) - T[:3, 3]) @ T[:3, :3])[:, 0] <= -0.5 * sx + sz)
    assert part_success(turned, s, np.r_[body, -np.ones(300, np.int64)]).all()  # no handle point kept
    # a 100-point resample: judged with the kept clean points and the scaled threshold
    for seed in range(5):
        _, src = corrupt(s["points"], np.arange(n), "points=100", np.random.default_rng(seed))
        assert part_success(turned, s, src)[0] == (not mug_handle_kept(s, src))
    assert part_success(_mug_turned_about_y(s, 0.0), s, np.arange(n)).all()
