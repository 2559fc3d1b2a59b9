"""benchmarks/bench_scale.py's results writer (shared with bench_roll.py): runs merge, other settings refuse."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_scale import write_results  # noqa: E402


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
