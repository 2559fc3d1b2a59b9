"""benchmarks/bench_scale.py's results writer (shared with bench_roll.py) and bench_roll.py's floor."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_roll import with_floor  # noqa: E402
from bench_scale import write_results  # noqa: E402

from ucope.data.generate import GenerateConfig, make_sample  # noqa: E402
from ucope.data.sample import roll_sample  # noqa: E402


def test_a_run_of_some_models_merges_into_the_results_and_other_settings_are_refused(tmp_path):
    out = tmp_path / "results_scale.json"
    settings = {"num": 3, "seed": 11, "factors": [0.5, 2.0], "pairs": 1000}
    write_results(out, "ucope-scale/1", settings, {"mug": {"v": 1}, "laptop": {"v": 2}}, time.perf_counter(), 1)
    write_results(out, "ucope-scale/1", settings, {"laptop": {"v": 3}}, time.perf_counter(), 1)
    res = json.loads(out.read_text())
    assert res["models"] == {"mug": {"v": 1}, "laptop": {"v": 3}}  # the re-measured model replaced, the other kept
    assert [r["models"] for r in res["runs"]] == [["mug", "laptop"], ["laptop"]]
    assert all(r["time_s"] >= 0 and r["date"] and r["hardware"]["threads"] == 1 for r in res["runs"])
    with pytest.raises(SystemExit, match="other settings"):
        write_results(out, "ucope-scale/1", {**settings, "num": 4}, {"mug": {"v": 5}}, time.perf_counter(), 1)
    with pytest.raises(SystemExit, match="other settings or format"):
        write_results(out, "ucope-roll/1", settings, {"mug": {"v": 5}}, time.perf_counter(), 1)
    assert json.loads(out.read_text())["models"]["mug"] == {"v": 1}  # a refused run leaves the file as it was


def test_the_roll_benchmarks_floor_is_rendered_floor_from_the_views_background_pool():
    s = roll_sample(make_sample(GenerateConfig(category="mug", split="test", seed=11, num=1, views_per_instance=1), 0), 0.4)
    pts = with_floor(s, np.random.default_rng(0))
    n = len(s["points"])
    np.testing.assert_array_equal(pts[:n], s["points"])  # the object's points first, unchanged
    floor = pts[n:]
    assert len(floor) == round(0.5 * n)
    pool = np.asarray(s["bg_points"])[~np.asarray(s["bg_clutter"])]  # the rolled view's floor pixels, no distractor
    gap = np.min(np.linalg.norm(floor[:, None, :] - pool[None, :, :], axis=-1), axis=1)
    assert gap.max() < 1e-6
