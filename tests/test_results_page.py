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
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_results.py"), "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert out.read_text() == (ROOT / "docs" / "results.md").read_text()


def test_the_page_shows_every_category_and_the_report_figures():
    page = (ROOT / "docs" / "results.md").read_text()
    reports = ROOT / "docs" / "reports"
    for cat in ("laptop", "eyeglasses", "dishwasher", "scissors", "drawer", "bottle", "bowl", "camera", "can", "laptop_rigid", "mug"):
        rep = json.loads((reports / f"{cat}.json").read_text())
        rot = ", ".join(f"{v:.1f}" for v in rep["parts"]["rotation_deg"]["mean"])
        assert f"| U-COPE (ours) | {rot} |" in page or f"| {cat} | U-COPE (ours) | {rot} |" in page, cat
        assert rep["data"]["split"] == "test"
