"""docs/robustness.md holds exactly what benchmarks/bench_robustness.py makes of the committed results JSON."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results_robustness.json"
PAGE = ROOT / "docs" / "robustness.md"


@pytest.mark.skipif(not RESULTS.exists(), reason="no committed robustness results")
def test_robustness_page_is_regenerated_from_the_results(tmp_path):
    page = tmp_path / "docs" / "robustness.md"
    page.parent.mkdir()
    shutil.copy(PAGE, page)
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_robustness.py"),
            "--page-only",
            "--out",
            str(RESULTS),
            "--page",
            str(page),
            "--figure",
            str(tmp_path / "docs" / "images" / "robustness.png"),
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert page.read_text() == PAGE.read_text()
    assert (tmp_path / "docs" / "images" / "robustness.png").stat().st_size > 10_000


@pytest.mark.skipif(not RESULTS.exists(), reason="no committed robustness results")
def test_the_results_cover_every_shipped_model_kind_and_level():
    res = json.loads(RESULTS.read_text())
    from ucope.data.corrupt import KINDS

    assert res["settings"]["num"] == 40 and res["settings"]["split"] == "test"
    models = (
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
    assert set(res["models"]) == set(models)
    for m in models:
        levels = res["models"][m]["levels"]
        for kind in KINDS.values():
            for lv in kind.levels:
                spec = "clean" if lv == kind.identity else f"{kind.name}={lv:g}"
                assert spec in levels, (m, spec)
                assert len(levels[spec]["views"]["success"]) == 40


def test_a_run_with_other_stages_never_merges_into_the_cards_results(tmp_path):
    out = tmp_path / "r.json"
    shutil.copy(RESULTS, out)

    def run(*args: str) -> subprocess.CompletedProcess:
        script = str(ROOT / "benchmarks" / "bench_robustness.py")
        return subprocess.run(
            [sys.executable, script, "--out", str(out), "--no-page", *args],
            check=False,
            capture_output=True,
            text=True,
            timeout=120,
        )

    r = run("--models", "camera", "--set", "clean_cloud.plane=false")
    assert r.returncode != 0 and "other settings" in r.stderr
    r = run("--models", "camera", "mug", "--stages", "vote_parts")
    assert r.returncode != 0 and "one model" in r.stderr
    assert out.read_bytes() == RESULTS.read_bytes()


@pytest.mark.parametrize("name", ["camera_smoothing", "camera_clean_cloud"])
def test_the_camera_runs_with_smoothing_record_their_pipeline(name):
    res = json.loads((ROOT / "benchmarks" / f"results_robustness_{name}.json").read_text())
    assert res["settings"]["stages"][0] == "clean_cloud"
    assert res["settings"].get("set", []) == (["clean_cloud.plane=false"] if name.endswith("smoothing") else [])
    assert {k: v for k, v in res["settings"].items() if k not in ("stages", "set")} == json.loads(RESULTS.read_text())["settings"]
