"""docs/results.md is exactly what scripts/make_results.py makes of the committed reports (docs/reports)
and the benchmarks' results, so every figure on the page is one that a report holds."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_results_page_is_regenerated_from_the_reports(tmp_path):
    out = tmp_path / "results.md"
    r = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_results.py"), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert out.read_text() == (ROOT / "docs" / "results.md").read_text()


def test_the_page_shows_every_category_and_the_report_figures():
    page = (ROOT / "docs" / "results.md").read_text()
    reports = ROOT / "docs" / "reports"
    for cat in (
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
    ):
        rep = json.loads((reports / f"{cat}.json").read_text())
        rot = ", ".join(f"{v:.1f}" for v in rep["parts"]["rotation_deg"]["mean"])
        assert f"| U-COPE (ours) | {rot} |" in page or f"| {cat} | U-COPE (ours) | {rot} |" in page, cat
        assert rep["data"]["split"] == "test"


def _make_results_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_results", ROOT / "scripts" / "make_results.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_a_fine_tuned_model_lists_every_training_stage(tmp_path):
    mr = _make_results_module()
    hw = {"device": "cpu", "torch_threads": 1}
    base = {"steps": 4000, "batch_size": 8, "train_time_s": 600.0, "hardware": hw}
    (tmp_path / "stage0").mkdir()
    (tmp_path / "stage0" / "model_card.json").write_text(json.dumps(base))
    stage1 = {
        **base,
        "steps": 5000,
        "train_time_s": 1200.0,
        "initialised_from": {"model": str(tmp_path / "stage0"), "steps": 4000, "train_time_s": 600.0},
    }
    (tmp_path / "stage1").mkdir()
    (tmp_path / "stage1" / "model_card.json").write_text(json.dumps(stage1))
    final = {
        **base,
        "steps": 6000,
        "train_time_s": 1800.0,
        "initialised_from": {"model": str(tmp_path / "stage1"), "steps": 5000, "train_time_s": 1200.0},
    }
    info = mr.training_info(final)
    assert [s["steps"] for s in info["stages"]] == [4000, 5000, 6000]
    line = mr.training_line({"training": info})
    assert line.startswith("4000 + 5000 + 6000 steps of batch 8 (a training, then 2 fine-tunings") and "60.0 min" in line
    # Without the run folders, the chain the cards recorded still gives every stage.
    gone = {
        **final,
        "initialised_from": {
            "model": str(tmp_path / "nowhere"),
            "steps": 5000,
            "train_time_s": 1200.0,
            "initialised_from": {"model": "laptop", "steps": 4000, "train_time_s": 600.0},
        },
    }
    assert [s["steps"] for s in mr.training_info(gone)["stages"]] == [4000, 5000, 6000]
    assert "stages" not in mr.training_info(base) and mr.training_line({"training": mr.training_info(base)}).startswith(
        "4000 steps"
    )
