"""docs/results.md is exactly what scripts/make_results.py makes of the committed reports (docs/reports), and every
figure on it can be recomputed from the reports' per-view records."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
REPORTS = ROOT / "docs" / "reports"


def _module():
    spec = importlib.util.spec_from_file_location("make_results", ROOT / "scripts" / "make_results.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_results_page_is_regenerated_from_the_reports():
    r = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_results.py"), "--check"], capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr


def test_the_results_page_stays_short():
    assert len((ROOT / "docs" / "results.md").read_bytes()) <= 40_000


def test_every_success_figure_is_its_reports_per_view_records():
    mr = _module()
    page = (ROOT / "docs" / "results.md").read_text()
    reports = sorted(REPORTS.glob("*_test.json")) + sorted(REPORTS.glob("*_ood.json"))
    assert reports, "no test / ood reports"
    for path in reports:
        rep = json.loads(path.read_text())
        ok, objects, _ = mr.outcomes(rep)
        assert len(ok) == rep["data"]["num_samples"] and rep["success"]["fraction"] == np.mean(ok)
        assert mr.success_cell(rep) in page, path.name


def test_the_interval_resamples_objects():
    from ucope.eval.evaluate import object_interval

    # 10 objects of 10 views each, all right or all wrong together: the interval is wide, unlike one over 100 views
    ok = np.repeat([True] * 5 + [False] * 5, 10)
    lo, hi = object_interval(ok, np.repeat([f"o{i}" for i in range(10)], 10))
    assert lo < 0.25 and hi > 0.75
    lo1, hi1 = object_interval(ok, [f"v{i}" for i in range(100)])
    assert hi1 - lo1 < 0.25


@pytest.mark.parametrize("model", ["mug", "laptop"])
def test_a_report_reproduces_its_first_views(model, tmp_path):
    """The per-view records of a committed report are what the shipped model gives on the same generated views
    today: the data set is re-made from its settings (sample i depends only on the category, split, seed and i) and
    stored as ``ucope generate`` stores it (normals in float16); the report's number of torch threads."""
    import torch

    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.data.shards import read_shard, write_shard
    from ucope.estimation import Estimator
    from ucope.eval.evaluate import sample_errors, view_record, view_success

    rep = json.loads((REPORTS / f"{model}_test.json").read_text())
    data = rep["data"]
    cfg = GenerateConfig(category=model, split="test", seed=data["seed"], num=data["num_samples"], views_per_instance=1)
    est = Estimator.load(model)
    threads = torch.get_num_threads()
    torch.set_num_threads(rep["hardware"]["torch_threads"])
    try:
        for v in rep["views"][:2]:
            write_shard(tmp_path / "shard.npz", [make_sample(cfg, v["index"])])
            (s,) = read_shard(tmp_path / "shard.npz")
            e = sample_errors(est.predict_sample(s), s)
            assert view_record(v["index"], v["object"], e, view_success(e["parts"])) == v
    finally:
        torch.set_num_threads(threads)


def test_the_microwave_report_reproduces_its_first_views():
    """The shipped microwave (a model of public model files, whose views need those files) on the first two views of
    its test report, stored as ``ucope generate`` stored them (tests/golden/microwave_test_views.npz)."""
    import torch

    from ucope.data.shards import read_shard
    from ucope.estimation import Estimator
    from ucope.eval.evaluate import sample_errors, view_record, view_success

    rep = json.loads((REPORTS / "microwave_test.json").read_text())
    samples = read_shard(ROOT / "tests" / "golden" / "microwave_test_views.npz")
    est = Estimator.load("microwave")
    threads = torch.get_num_threads()
    torch.set_num_threads(rep["hardware"]["torch_threads"])
    try:
        for v, s in zip(rep["views"][:2], samples, strict=True):
            e = sample_errors(est.predict_sample(s), s)
            assert view_record(v["index"], v["object"], e, view_success(e["parts"])) == v
    finally:
        torch.set_num_threads(threads)
