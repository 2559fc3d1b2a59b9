"""Copy trained models into the package (src/ucope/pretrained/<category>.json + .safetensors).

    python scripts/package_models.py --runs work/runs --reports work/reports --check-data work/data [--categories laptop mug ...]

Each model is stored in half precision (float16) after checking that it predicts as well as its float32
original: both are evaluated on the same validation views (the first ``--check-num`` of
``CHECK_DATA/<category>_val``) and the largest change of any part's mean rotation (deg), translation (m) and IoU
is recorded in the model's JSON (``info.fp16_check``); if it exceeds ``--max-change-deg`` / ``--max-change-m`` the
model is stored in float32 instead. The model card keeps the run's pipeline (``info.pipeline``, chosen on
validation views by scripts/choose_pipeline.py) and its calibration, and gains the test and ood figures of its
``ucope eval`` reports (``info.test``, ``info.ood``), which ``ucope models`` prints.

    python scripts/package_models.py --figures-only --reports work/reports [--categories ...]

only refreshes the shipped models' ``info.test`` / ``info.ood`` from reports of those same models, leaving their
weights and pipelines alone.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.data.dataset import load_dataset  # noqa: E402
from ucope.estimation import Estimator  # noqa: E402
from ucope.estimation.pipeline import Pipeline  # noqa: E402
from ucope.eval.evaluate import evaluate  # noqa: E402
from ucope.model.checkpoint import (  # noqa: E402
    load_model,
    pretrained_dir,  # noqa: E402
    save_model,
)
from ucope.objects.categories import CATEGORY_NAMES  # noqa: E402


def card_figures(rep: dict) -> dict:
    """The compact figures of one report (test or ood split) stored with a shipped model."""
    p = rep["parts"]
    succ = rep.get("success") or {}
    out = {
        "num_samples": rep["data"]["num_samples"],
        "num_objects": succ.get("num_objects"),
        "success": succ.get("fraction"),
        "success_interval_95_objects": succ.get("interval_95_objects"),
        "data_split": rep["data"].get("split"),
        "rotation_deg_mean": p["rotation_deg"]["mean"],
        "translation_m_mean": p["translation_m"]["mean"],
        "iou_mean": p["iou"]["mean"],
        "fraction_10deg10cm": p["fraction"]["10deg10cm"],
        "time_s_mean": rep["time_ms"]["mean"]["total"] / 1000.0,
    }
    if rep.get("joints"):
        out["joint_axis_deg_mean"] = rep["joints"]["axis_deg"]["mean"]
        out["joint_state_error_mean"] = rep["joints"]["state_error"]["mean"]
        out["joint_state_unit"] = rep["joints"]["state_unit"]
    if rep.get("map"):
        out["map"] = rep["map"]["mean"]
    return out


def refresh_figures(dest: Path, reports: Path, cats: list[str]) -> int:
    """``--figures-only``: rewrite ``info.test`` / ``info.ood`` of the shipped models ``cats`` from
    ``reports/<cat>_test.json`` and ``reports/<cat>_ood.json``."""
    from ucope.fileio import atomic_write_json

    for cat in cats:
        meta_path = dest / f"{cat}.json"
        meta = json.loads(meta_path.read_text())
        for split in ("test", "ood"):
            path = reports / f"{cat}_{split}.json"
            if not path.is_file():
                continue
            rep = json.loads(path.read_text())
            if rep.get("category") != meta["config"]["priors"]["category"]:
                raise SystemExit(f"{path} is a report on {rep.get('category')!r}, not {cat!r}")
            meta["info"][split] = card_figures(rep)
        atomic_write_json(meta_path, meta)
        print(f"{cat}: figures refreshed from {reports}")
    return 0


def summary(rep: dict) -> tuple[list, list, list]:
    p = rep["parts"]
    return p["rotation_deg"]["mean"], p["translation_m"]["mean"], p["iou"]["mean"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=None)
    ap.add_argument("--figures-only", action="store_true", help="only refresh the shipped models' figures from --reports")
    ap.add_argument("--reports", type=Path, required=True)
    ap.add_argument("--check-data", type=Path, default=None, help="folder of the CATEGORY_val data sets of the fp16 check")
    ap.add_argument("--categories", nargs="+", default=None)
    ap.add_argument("--check-num", type=int, default=60)
    ap.add_argument("--max-change-deg", type=float, default=0.5)
    ap.add_argument("--max-change-m", type=float, default=0.002)
    args = ap.parse_args()
    dest = pretrained_dir()
    if args.figures_only:
        return refresh_figures(dest, args.reports, args.categories or [p.stem for p in sorted(dest.glob("*.json"))])
    if args.runs is None or args.check_data is None:
        ap.error("--runs and --check-data are required (unless --figures-only)")
    dest.mkdir(parents=True, exist_ok=True)
    cats = args.categories or [c for c in CATEGORY_NAMES if (args.runs / c / "model.json").is_file()]
    for cat in cats:
        run = args.runs / cat
        model, meta = load_model(run)
        pipeline = Pipeline.from_info(meta.get("info"), model.cfg.priors, model.cfg.head)
        val = args.check_data / f"{cat}_val"
        ds = load_dataset(val if val.is_dir() else args.check_data / "val")  # reproduce_models.sh / make_own_category.sh
        n = min(args.check_num, len(ds))
        check = ds[:n]
        ref = evaluate(Estimator(model, pipeline), check, progress=False, keep_samples=False)
        with tempfile.TemporaryDirectory() as tmp:
            half_json = save_model(model, Path(tmp) / "half.json", dtype="float16")
            half, _ = load_model(half_json)
            got = evaluate(Estimator(half, pipeline), check, progress=False, keep_samples=False)
        change = [max(abs(a - b) for a, b in zip(x, y, strict=False)) for x, y in zip(summary(ref), summary(got), strict=False)]
        fp16_ok = change[0] <= args.max_change_deg and change[1] <= args.max_change_m
        info = dict(meta.get("info", {}))
        for split in ("test", "ood"):
            path = args.reports / f"{cat}_{split}.json"
            if path.is_file():
                info[split] = card_figures(json.loads(path.read_text()))
        info["fp16_check"] = {
            "num_samples": n,
            "data": f"{cat}_val",
            "max_change_rotation_deg": change[0],
            "max_change_translation_m": change[1],
            "max_change_iou": change[2],
            "stored_as": "float16" if fp16_ok else "float32",
        }
        out = save_model(model, dest / f"{cat}.json", info=info, dtype="float16" if fp16_ok else "float32")
        size = out.with_suffix(".safetensors").stat().st_size
        print(
            f"{cat}: {'float16' if fp16_ok else 'float32'} ({size / 1e6:.2f} MB); fp16 change rot {change[0]:.3f} deg, "
            f"trans {change[1] * 1000:.2f} mm, IoU {change[2]:.4f} on {n} validation views -> {out}"
        )
    total = sum(f.stat().st_size for f in dest.iterdir())
    print(f"{dest}: {total / 1e6:.1f} MB in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
