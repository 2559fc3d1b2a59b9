"""docs/pipeline.md is exactly what scripts/make_pipeline_doc.py makes of the stage registry, the shipped model cards
and the validation reports; each card's search is the one its report chose."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REPORTS = ROOT / "docs" / "reports"


def test_pipeline_page_is_regenerated_from_the_cards_and_reports():
    r = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_pipeline_doc.py"), "--check"], capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr


def test_each_cards_search_is_what_its_validation_report_chose():
    from ucope.estimation.search import SearchPolicy
    from ucope.model.checkpoint import list_pretrained, pretrained_dir

    defaults = SearchPolicy().to_dict()

    checked = 0
    for name in list_pretrained():
        report = REPORTS / f"{name}_val_pipeline.json"
        chosen = json.loads(report.read_text()).get("search", {}).get("chosen") if report.is_file() else None
        if chosen is None:
            continue
        search = json.loads((pretrained_dir() / f"{name}.json").read_text())["info"]["pipeline"]["search"]
        for key in ("scale_factors", "scale_below", "restart_below", "restarts"):
            assert search.get(key, defaults[key]) == chosen[key], (name, key)
        checked += 1
    assert checked >= 10
