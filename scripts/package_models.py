"""Copy trained models into the package (src/ucope/pretrained/<category>.json + .safetensors).

    python scripts/package_models.py --runs work/runs --reports work/reports [--categories laptop mug ...]

Each model is stored in half precision (float16) after checking that it predicts as well as its float32
original: both are evaluated on the same test views (the first ``--check-num`` of the report's data
set) and the largest change of any part's mean rotation (deg), translation (m) and IoU is recorded in
the model's JSON (``info.fp16_check``); if it exceeds ``--max-change-deg`` / ``--max-change-m`` the
model is stored in float32 instead. The JSON's ``info`` also carries the model card and the test-split
figures of its ``ucope eval`` report (``info.test``), which ``ucope models`` prints.

    python scripts/package_models.py --figures-only --reports work/reports [--categories ...]

only refreshes the shipped models' ``info.test`` from new reports of those same models (e.g. after a
change to the voting), leaving their weights alone.

    python scripts/package_models.py --set-defaults --runs work/runs --reports work/reports --categories eyeglasses

writes only that default (and ``--remove-plane``'s and ``--grow-boxes``', when given) into the runs' own ``model.json`` (so that
what is measured on a run before it is packaged, its score calibration above all, sees the run as it will
ship).

Every mode also sets the model's default for the kinematic refinement (``info.defaults.refine``, which
``Estimator.load`` and the command line take unless told otherwise) from the reports
``<cat>_norefine.json`` and ``<cat>_refine.json`` (``ucope eval --no-refine`` / ``--refine``) when
both exist: on when it lowers the summed mean rotation error, does not lower the success fraction
(every part under 10 degrees and 10 % of its box diagonal; every part's 10deg10cm fraction for reports
without one) and costs no part more than one point of mean 3D IoU (:func:`refine_default`).
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
from ucope.eval.evaluate import evaluate  # noqa: E402
from ucope.model.checkpoint import (  # noqa: E402
    load_model,
    pretrained_dir,  # noqa: E402
    save_model,
)
from ucope.objects.categories import CATEGORY_NAMES  # noqa: E402


def test_figures(rep: dict) -> dict:
    """The compact test-split figures stored with a shipped model."""
    p = rep["parts"]
    out = {
        "num_samples": rep["data"]["num_samples"],
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


def refine_default(off: dict, on: dict, max_iou_loss: float = 0.01) -> bool:
    """Whether the kinematic refinement should be on by default, from two reports of one model on the
    same views (refinement off / on): see the module docstring."""
    po, pn = off["parts"], on["parts"]
    better_rot = sum(pn["rotation_deg"]["mean"]) < sum(po["rotation_deg"]["mean"])
    if "success" in off and "success" in on:  # the object's success, as every other page measures it
        keeps_success = on["success"]["fraction"] >= off["success"]["fraction"]
    else:  # reports from before the success fraction: every part's 10deg10cm fraction
        keeps_success = all(b >= a for a, b in zip(po["fraction"]["10deg10cm"], pn["fraction"]["10deg10cm"], strict=False))
    keeps_iou = all(b >= a - max_iou_loss for a, b in zip(po["iou"]["mean"], pn["iou"]["mean"], strict=False))
    return bool(better_rot and keeps_success and keeps_iou)


SWITCHES = {
    "remove_plane": ("leave a support plane out", "docs/robustness.md"),
    "grow_boxes": ("grow their boxes to hold their points", "docs/results.md"),
    "align_faces": ("align their part rotations to the normals of flat faces", "docs/results.md"),
    "wide_scale_search": ("let the scale search also try 0.8x and 1.25x the typical size", "docs/results.md"),
    "fit_extents": ("set the box axes a view sees whole from their points", "docs/results.md"),
    "anchor_faces": ("anchor the root part's faced faces to its points", "docs/results.md"),
    "free_space": ("turn parts they barely see about their joint to where the points say they can be", "docs/results.md"),
    "seat_parts": ("put parts they barely see that stand off their hinge back on it", "docs/results.md"),
    "free_slides": ("slide hidden prismatic children back to where the camera would not have seen them", "docs/results.md"),
    "pick_seen_parts": ("compare their estimates by the parts given points only", "docs/results.md"),
    "carry_in_cone": ("carry a part from its neighbour as soon as it leaves its training upright cone", "docs/results.md"),
}
"""The model switches packaging sets per category (``info.defaults.<key>``): what each does, where it was
measured. ``--<key with dashes> CAT...`` names the categories that get it on."""


RESTARTS_ON = 4
"""``info.defaults.restarts`` of the models ``--restarts CAT...`` names (``Estimator(restarts=...)``: up to this
many further estimates while the object score is low; docs/results.md has the measurements); others get 0."""


def set_defaults(info: dict, reports: Path, cat: str, restarts: list[str] | None = None, **lists: list[str] | None) -> None:
    """``info["defaults"]["refine"]`` from the refine-off / refine-on reports of ``cat``, if both exist, each
    switch of :data:`SWITCHES` given a list (``key=[categories]``) set to ``cat in`` that list, and
    ``restarts`` (given a list) :data:`RESTARTS_ON` for the categories in it, 0 for the others; the other
    defaults (``denoise_above_m``) are kept. Raises ``TypeError`` on a key that is not a switch."""
    unknown = sorted(set(lists) - set(SWITCHES))
    if unknown:
        raise TypeError(f"set_defaults: not model switches: {unknown}")
    off, on = reports / f"{cat}_norefine.json", reports / f"{cat}_refine.json"
    if off.is_file() and on.is_file():
        info.setdefault("defaults", {}).update(
            refine=refine_default(json.loads(off.read_text()), json.loads(on.read_text())), decided_from=[off.name, on.name]
        )
    for key, cats in lists.items():
        if cats is not None:
            info.setdefault("defaults", {})[key] = cat in cats
    if restarts is not None:
        info.setdefault("defaults", {})["restarts"] = RESTARTS_ON if cat in restarts else 0


def refresh_figures(dest: Path, reports: Path, cats: list[str], **lists) -> int:
    """``--figures-only``: rewrite ``info.test`` of the shipped models ``cats`` from ``reports/<cat>.json``
    (and the defaults: :func:`set_defaults` with ``lists``, the switches of :data:`SWITCHES`)."""
    from ucope.fileio import atomic_write_json

    for cat in cats:
        rep = json.loads((reports / f"{cat}.json").read_text())
        meta_path = dest / f"{cat}.json"
        meta = json.loads(meta_path.read_text())
        if rep.get("category") != meta["config"]["priors"]["category"]:
            raise SystemExit(f"{reports / (cat + '.json')} is a report on {rep.get('category')!r}, not {cat!r}")
        meta["info"]["test"] = test_figures(rep)
        set_defaults(meta["info"], reports, cat, **lists)
        atomic_write_json(meta_path, meta)
        print(f"{cat}: test figures refreshed from {reports / (cat + '.json')}; defaults {meta['info'].get('defaults')}")
    return 0


def set_run_defaults(runs: Path, reports: Path, cats: list[str], **lists) -> int:
    """``--set-defaults``: :func:`set_defaults` (and the switches of :data:`SWITCHES`, when given) into
    ``runs/<cat>/model.json``."""
    from ucope.fileio import atomic_write_json

    for cat in cats:
        path = runs / cat / "model.json"
        meta = json.loads(path.read_text())
        set_defaults(meta.setdefault("info", {}), reports, cat, **lists)
        atomic_write_json(path, meta)
        print(f"{cat}: defaults {meta['info'].get('defaults')} in {path}")
    return 0


def summary(rep: dict) -> tuple[list, list, list]:
    p = rep["parts"]
    return p["rotation_deg"]["mean"], p["translation_m"]["mean"], p["iou"]["mean"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=None)
    ap.add_argument("--figures-only", action="store_true", help="only refresh the shipped models' test figures from --reports")
    ap.add_argument(
        "--set-defaults", action="store_true", help="only write the refinement default into the runs' model.json (--runs)"
    )
    ap.add_argument("--reports", type=Path, required=True)
    ap.add_argument("--categories", nargs="+", default=None)
    ap.add_argument("--check-num", type=int, default=60)
    ap.add_argument("--max-change-deg", type=float, default=0.5)
    ap.add_argument("--max-change-m", type=float, default=0.002)
    for key, (what, where) in SWITCHES.items():
        ap.add_argument(
            "--" + key.replace("_", "-"),
            nargs="*",
            default=None,
            metavar="CAT",
            help=f"the categories whose models {what} by default (info.defaults.{key}; {where} has the measurements); "
            "others get it off; omitted: left as it is",
        )
    ap.add_argument(
        "--restarts",
        nargs="*",
        default=None,
        metavar="CAT",
        help=f"the categories whose models take up to {RESTARTS_ON} further estimates while their score is low "
        "(info.defaults.restarts; docs/results.md has the measurements); others get 0; omitted: left as it is",
    )
    args = ap.parse_args()
    lists = {key: getattr(args, key) for key in SWITCHES}
    lists["restarts"] = args.restarts
    dest = pretrained_dir()
    if args.figures_only:
        return refresh_figures(dest, args.reports, args.categories or [p.stem for p in sorted(dest.glob("*.json"))], **lists)
    if args.runs is None:
        ap.error("--runs is required (unless --figures-only)")
    if args.set_defaults:
        cats = args.categories or [p.parent.name for p in args.runs.glob("*/model.json")]
        return set_run_defaults(args.runs, args.reports, cats, **lists)
    dest.mkdir(parents=True, exist_ok=True)
    cats = args.categories or [c for c in CATEGORY_NAMES if (args.runs / c / "model.json").is_file()]
    for cat in cats:
        run, rep_path = args.runs / cat, args.reports / f"{cat}.json"
        rep = json.loads(rep_path.read_text())
        model, meta = load_model(run)
        ds = load_dataset(rep["data"]["path"])
        n = min(args.check_num, len(ds))
        check = ds[:n]
        ref = evaluate(Estimator(model, name=cat), check, progress=False, keep_samples=False)
        with tempfile.TemporaryDirectory() as tmp:
            half_json = save_model(model, Path(tmp) / "half.json", dtype="float16")
            half, _ = load_model(half_json)
            got = evaluate(Estimator(half, name=cat), check, progress=False, keep_samples=False)
        change = [max(abs(a - b) for a, b in zip(x, y, strict=False)) for x, y in zip(summary(ref), summary(got), strict=False)]
        fp16_ok = change[0] <= args.max_change_deg and change[1] <= args.max_change_m
        info = dict(meta.get("info", {}))
        info["test"] = test_figures(rep)
        set_defaults(info, args.reports, cat, **lists)
        info["fp16_check"] = {
            "num_samples": n,
            "max_change_rotation_deg": change[0],
            "max_change_translation_m": change[1],
            "max_change_iou": change[2],
            "stored_as": "float16" if fp16_ok else "float32",
        }
        out = save_model(model, dest / f"{cat}.json", info=info, dtype="float16" if fp16_ok else "float32")
        size = out.with_suffix(".safetensors").stat().st_size
        print(
            f"{cat}: {'float16' if fp16_ok else 'float32'} ({size / 1e6:.2f} MB); fp16 change rot {change[0]:.3f} deg, "
            f"trans {change[1] * 1000:.2f} mm, IoU {change[2]:.4f} on {n} views -> {out}"
        )
    total = sum(f.stat().st_size for f in dest.iterdir())
    print(f"{dest}: {total / 1e6:.1f} MB in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
