"""scripts/reproduce_models.sh chooses every model's pipeline on validation views and measures test and ood once."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = (ROOT / "scripts" / "reproduce_models.sh").read_text()


def test_no_per_model_switch_lists_remain():
    """What runs for a model is its card's pipeline, chosen on val views: no list of categories per stage."""
    for old in ("PLANE_CATS", "GROW_CATS", "ALIGN_CATS", "WIDE_CATS", "FIT_CATS", "RESTART_CATS", "DENOISE_CATS"):
        assert old not in SCRIPT
    assert not re.search(r"--(remove-plane|grow-boxes|align-faces|refine|no-refine|restarts)\b", SCRIPT)


def test_every_final_run_is_finished_on_validation_views():
    body = SCRIPT[SCRIPT.index("finish_run() {") :]
    body = body[: body.index("\n}\n")]
    order = [body.index(s) for s in ("set_denoise_default.py", "calibrate_scores.py", "choose_pipeline.py")]
    assert order == sorted(order) and body.count("calibrate_scores.py") == 2
    assert "_val" in body and "_test" not in body and "_ood" not in body


def test_test_and_ood_are_measured_once_on_fresh_objects():
    assert re.search(r"--split test --num \"\$TEST_NUM\" --seed 2026 --views-per-instance 1", SCRIPT)
    assert re.search(r"--split ood --num \"\$OOD_NUM\" --seed 2026 --views-per-instance 1", SCRIPT)
    assert "--check-data" in SCRIPT  # the fp16 check reads validation views
