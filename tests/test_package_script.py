"""scripts/package_models.py: the figures a shipped model card stores from its test and ood reports."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from package_models import card_figures, refresh_figures  # noqa: E402


def _report(category="mug", success=0.9):
    return {
        "category": category,
        "data": {"num_samples": 150, "split": "test"},
        "parts": {
            "rotation_deg": {"mean": [3.0]},
            "translation_m": {"mean": [0.01]},
            "iou": {"mean": [0.8]},
            "fraction": {"10deg10cm": [0.95]},
        },
        "success": {"fraction": success, "num_objects": 150, "interval_95_objects": [success - 0.05, success + 0.04]},
        "time_ms": {"mean": {"total": 120.0}},
    }


def test_figures_keep_success_and_its_interval_over_objects():
    f = card_figures(_report())
    assert (
        f["success"] == 0.9
        and f["num_objects"] == 150
        and f["success_interval_95_objects"] == _report()["success"]["interval_95_objects"]
    )
    assert f["rotation_deg_mean"] == [3.0] and f["time_s_mean"] == 0.12


def test_refresh_writes_test_and_ood_figures_and_refuses_another_category(tmp_path):
    dest, reports = tmp_path / "pretrained", tmp_path / "reports"
    dest.mkdir()
    reports.mkdir()
    (dest / "mug.json").write_text(json.dumps({"config": {"priors": {"category": "mug"}}, "info": {"pipeline": {"stages": []}}}))
    (reports / "mug_test.json").write_text(json.dumps(_report(success=0.9)))
    (reports / "mug_ood.json").write_text(json.dumps(_report(success=0.7)))
    assert refresh_figures(dest, reports, ["mug"]) == 0
    info = json.loads((dest / "mug.json").read_text())["info"]
    assert info["test"]["success"] == 0.9 and info["ood"]["success"] == 0.7 and info["pipeline"] == {"stages": []}
    (reports / "mug_test.json").write_text(json.dumps(_report(category="bowl")))
    try:
        refresh_figures(dest, reports, ["mug"])
    except SystemExit as e:
        assert "not 'mug'" in str(e)
    else:
        raise AssertionError("a report on another category was taken")
