"""docs/results.md is exactly what scripts/make_results.py makes of the committed reports (docs/reports)
and the benchmarks' results, so every figure on the page is one that a report holds."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

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


def _fake_report(rot, data_path="d/eyeglasses_test", generator="2", parts=("frame",), **extra):
    k = len(parts)
    stat = {"mean": [rot] * k, "median": [rot / 2] * k}
    rep = {
        "part_names": list(parts),
        "data": {"generator_version": generator, "split": "test", "seed": 0, "num_samples": 10, "path": data_path},
        "parts": {
            "rotation_deg": stat,
            "translation_m": {"mean": [0.01] * k, "median": [0.005] * k},
            "iou": {"mean": [0.5] * k, "median": [0.6] * k},
            "fraction": {"10deg10cm": [0.9] * k, "5deg": [0.7] * k, "10deg": [0.95] * k},
        },
        "time_ms": {"mean": {"total": 50.0}, "median": {"total": 40.0}},
        "success": {"fraction": 0.8},
        "joints": None,
        "command": f"ucope eval --rot {rot}",
    }
    rep.update(extra)
    return rep


def test_table3_rows_must_share_one_test_set_and_list_each_command_once(tmp_path):
    mr = _make_results_module()
    for name in ("eyeglasses_t3_pairs20000", "eyeglasses_t3_pairs20000_nocaps", "eyeglasses_t3_no_score_filter"):
        (tmp_path / f"{name}.json").write_text(json.dumps(_fake_report(len(name))))
    lines = mr.table3_section(tmp_path)
    text = "\n".join(lines)
    assert "20,000 pairs (ours, caps)" in text and "20,000 pairs (ours, no caps)" in text
    assert "pairs from the predicted segment, score filter off" in text
    cmds = [ln for ln in lines if ln.startswith("Commands:")][0]
    assert cmds.count("ucope eval --rot 24") == 1  # pairs20000 is in both tables, its command once
    (tmp_path / "eyeglasses_t3_no_awareness.json").write_text(json.dumps(_fake_report(9.0, generator="1")))
    with pytest.raises(SystemExit, match="one test set"):
        mr.table3_section(tmp_path)


def test_voting_is_compared_with_regression_only_on_the_same_views(tmp_path):
    mr = _make_results_module()
    (tmp_path / "mug.json").write_text(json.dumps(_fake_report(4.0, data_path="g1/mug_test", generator="1")))
    (tmp_path / "mug_regression.json").write_text(json.dumps(_fake_report(5.0, data_path="g2/mug_test")))
    assert any(ln.startswith("Not compared: mug") for ln in mr.voting_vs_regression_section(tmp_path))
    (tmp_path / "mug_voting.json").write_text(json.dumps(_fake_report(3.0, data_path="g2/mug_test")))
    text = "\n".join(mr.voting_vs_regression_section(tmp_path))
    assert "| mug (10) | voting (U-COPE) | 3.0 |" in text and "| mug (10) | regression | 5.0 |" in text
    assert "| mug (10) | regression, *median* | 2.5 |" in text
    # a baseline re-measured on the new views: a _voting report left on the old ones gives way to the model's own
    (tmp_path / "mug_voting.json").write_text(json.dumps(_fake_report(3.0, data_path="g1/mug_test", generator="1")))
    (tmp_path / "mug.json").write_text(json.dumps(_fake_report(4.0, data_path="g2/mug_test")))
    text = "\n".join(mr.voting_vs_regression_section(tmp_path))
    assert "| mug (10) | voting (U-COPE) | 4.0 |" in text and "Not compared" not in text


def test_a_category_generator_revision_makes_another_test_set():
    mr = _make_results_module()
    old, new = _fake_report(4.0), _fake_report(4.0)
    new["data"]["category_revision"] = 2
    assert mr.same_test_set(old, _fake_report(5.0)) and not mr.same_test_set(old, new)
    assert mr.same_test_set(old, {**new, "data": {**new["data"], "category_revision": 1}})  # absent means 1
    assert mr.generator_label(old["data"]) == "2" and mr.generator_label(new["data"]) == "2, category revision 2"


def test_seen_ratios_divide_back_by_front_over_the_views_that_show_each_part():
    mr = _make_results_module()

    def seen(rot, trans, missing):
        return {"seen_parts": {"rotation_deg": {"mean": rot}, "translation_norm": {"mean": trans}, "num_missing": missing}}

    bins = {"front": seen([2.0, 4.0], [0.02, 0.05], [0, 0]), "back": seen([3.0, None], [0.01, None], [0, 7])}
    assert mr.seen_ratios(bins) == "1.50x; 0.50x (0), -"
    assert mr.seen_ratios({"front": {"parts": {}}, "back": {"parts": {}}}) == "-"  # a report from before seen_parts


def test_success_intervals_are_wilson_score_intervals():
    """The OOD table's intervals: the Wilson score interval, checked against its closed form at known points
    (45 of 100 and 90 of 200 views: 35.6-54.8 % and 38.3-51.9 %) and at the ends (0 and n successes)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from make_results import success_interval_cell, wilson_interval

    assert wilson_interval(45, 100) == pytest.approx((0.3562, 0.5476), abs=1e-4)
    assert wilson_interval(90, 200) == pytest.approx((0.3826, 0.5192), abs=1e-4)
    lo, hi = wilson_interval(0, 100)
    assert lo == 0.0 and hi == pytest.approx(0.0370, abs=1e-4)
    lo, hi = wilson_interval(100, 100)
    assert hi == pytest.approx(1.0) and lo == pytest.approx(0.9630, abs=1e-4)
    rep = {"success": {"fraction": 0.475}, "data": {"num_samples": 200}}
    assert success_interval_cell(rep) == "48 % (200; 41-54)" and success_interval_cell(None) == "-"


def test_saved_reports_get_the_success_over_the_parts_in_view_from_their_records(tmp_path):
    """A full report from before the field: the slim copy counts, per view, only the parts with at least
    SEEN_MIN_POINTS points (the eval's rule), overall and per view bin; the page's cell shows it for
    articulated categories only."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from make_results import in_view_cell, save_reports

    from ucope.eval.evaluate import SEEN_MIN_POINTS

    good, bad = {"rotation_deg": 1.0, "translation_norm": 0.01}, {"rotation_deg": 40.0, "translation_norm": 0.3}
    recs = [
        {"parts": [good, bad], "visible_points": [900, 0], "view_yaw_deg": 170.0},  # back, lid hidden: in view right
        {"parts": [good, bad], "visible_points": [900, SEEN_MIN_POINTS], "view_yaw_deg": -175.0},  # back, lid shown
        {"parts": [good, good], "visible_points": [900, 400], "view_yaw_deg": 10.0},  # front
        {"parts": [bad, good], "visible_points": [900, 5], "view_yaw_deg": 20.0},  # front, base wrong and shown
    ]
    rep = {
        "part_names": ["base", "lid"],
        "success": {"definition": "every part < 10 deg and < 10 % of its box diagonal", "fraction": 0.25},
        "view_bins": {"back": {"success": 0.0}, "front": {"success": 0.5}},
        "samples": recs,
    }
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "oddname_ood.json").write_text(json.dumps(rep))
    save_reports(tmp_path / "src", tmp_path / "dest", None)
    slim = json.loads((tmp_path / "dest" / "oddname_ood.json").read_text())
    assert "samples" not in slim
    assert slim["success"]["in_view_fraction"] == pytest.approx(0.5)
    assert slim["view_bins"]["back"]["success_in_view"] == pytest.approx(0.5)
    assert slim["view_bins"]["front"]["success_in_view"] == pytest.approx(0.5)
    assert in_view_cell(slim) == "50 %"
    assert in_view_cell(dict(slim, part_names=["body"])) == "-" and in_view_cell(None) == "-"
