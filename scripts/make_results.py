"""Write docs/results.md from the evaluation reports in docs/reports: every figure on the page is read from a
report that holds its per-view records, so anyone can recompute it.

    python scripts/make_results.py                    # rewrite docs/results.md from docs/reports
    python scripts/make_results.py --out /tmp/r.md    # somewhere else
    python scripts/make_results.py --check            # exit 1 if docs/results.md is not what it would write

Reports (``ucope eval``, format ``ucope-eval/1``): ``MODEL_test.json`` and ``MODEL_ood.json`` (the shipped
models on fresh views, one per object), ``before/MODEL_test.json`` / ``before/MODEL_ood.json`` (the code before the
one-pipeline refactor on the same views, when present), ``MODEL_t3_*.json`` (Table 3's ablation). A view succeeds
when every part is within 10 degrees and 10 % of its ground-truth box diagonal; intervals are 95 % cluster
bootstraps over objects (``ucope.eval.evaluate.object_interval``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.eval.evaluate import object_interval, view_success  # noqa: E402

REPORTS = ROOT / "docs" / "reports"
PAGE = ROOT / "docs" / "results.md"
MODELS = ("laptop", "eyeglasses", "dishwasher", "scissors", "drawer", "bottle", "bowl", "camera", "can", "laptop_rigid", "mug")
OWN = ("robot_arm", "microwave")
"""Models of public model files (docs/own_objects.md)."""


def load(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def outcomes(rep: dict) -> tuple[np.ndarray, list[str], list[int]]:
    """Per view of a report: success, object and index (from ``views``, or the older ``samples``)."""
    if rep.get("views"):
        v = rep["views"]
        return np.array([x["success"] for x in v], bool), [x["object"] for x in v], [x["index"] for x in v]
    s = rep["samples"]
    return (
        np.array([view_success(x["parts"]) for x in s], bool),
        [x.get("instance_id", str(i)) for i, x in enumerate(s)],
        [x.get("index", i) for i, x in enumerate(s)],
    )


def slim(path: Path) -> None:
    """Rewrite a report compactly for the repository: its per-view records (``views``, built from ``samples`` for a
    report without them) and summaries kept, the full ``samples`` left out."""
    from ucope.eval.evaluate import view_record

    rep = json.loads(path.read_text())
    if not rep.get("views") and rep.get("samples"):
        rep["views"] = [
            view_record(x.get("index", i), x.get("instance_id", str(i)), x, view_success(x["parts"]))
            for i, x in enumerate(rep["samples"])
        ]
    rep.pop("samples", None)
    path.write_text(json.dumps(rep, sort_keys=True, separators=(",", ":")) + "\n")


def success_cell(rep: dict | None) -> str:
    if rep is None:
        return "-"
    ok, objects, _ = outcomes(rep)
    lo, hi = object_interval(ok, objects)
    return f"{100 * ok.mean():.0f} % ({100 * lo:.0f}-{100 * hi:.0f}; {len(set(objects))} obj.)"


def cells(values, fmt: str, scale: float = 1.0) -> str:
    return ", ".join("-" if v is None else fmt.format(v * scale) for v in values)


def state_cells(joints: dict, stat: str) -> str:
    """Each joint's state error with its unit: degrees for a revolute joint, centimetres for a prismatic one."""
    units = joints["state_unit"]
    units = [units] * len(joints["state_error"][stat]) if isinstance(units, str) else units
    return ", ".join(
        "-" if v is None else f"{v:.1f} deg" if u == "deg" else f"{100.0 * v:.1f} cm"
        for v, u in zip(joints["state_error"][stat], units, strict=True)
    )


def headline(reports: Path, models) -> list[str]:
    out = [
        "| model | parts | test success | ood success | rotation (deg) | translation (% diag.) | 3D IoU (%) "
        "| joints: axis (deg), state | time (ms, median) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for m in models:
        test, ood = load(reports / f"{m}_test.json"), load(reports / f"{m}_ood.json")
        if test is None:
            continue
        p, j = test["parts"], test.get("joints")
        joints = "-"
        if j:
            joints = f"{cells(j['axis_deg']['mean'], '{:.1f}')}; {state_cells(j, 'mean')}"
        out.append(
            f"| {m} | {len(test['part_names'])} | {success_cell(test)} | {success_cell(ood)} | "
            f"{cells(p['rotation_deg']['mean'], '{:.1f}')} | {cells(p['translation_norm']['mean'], '{:.1f}', 100.0)} | "
            f"{cells(p['iou']['mean'], '{:.0f}', 100.0)} | {joints} | {test['time_ms']['median']['total']:.0f} |"
        )
    return out


def before_after(reports: Path, models) -> list[str]:
    out = [
        "| model | split | views | before | now | right only before | right only now |",
        "|---|---|---|---|---|---|---|",
    ]
    any_row = False
    for m in models:
        for split in ("test", "ood"):
            now, before = load(reports / f"{m}_{split}.json"), load(reports / "before" / f"{m}_{split}.json")
            if now is None or before is None:
                continue
            a, _, ia = outcomes(before)
            b, _, ib = outcomes(now)
            if ia != ib:
                raise SystemExit(f"{m} {split}: the reports before and now are on different views")
            any_row = True
            out.append(f"| {m} | {split} | {len(a)} | {a.sum()} | {b.sum()} | {int(np.sum(a & ~b))} | {int(np.sum(b & ~a))} |")
    return out if any_row else []


def rigid_maps(reports: Path) -> list[str]:
    keys = ("3D50", "3D75", "5deg2cm", "5deg5cm", "10deg2cm", "10deg5cm")
    out = ["| model | protocol | " + " | ".join(keys) + " |", "|---|---|" + "---|" * len(keys)]
    for m in MODELS:
        rep = load(reports / f"{m}_test.json")
        for field, protocol in (("map", "exact boxes"), ("map_nocs", "NOCS reference")):
            if rep is None or not rep.get(field):
                continue
            mp = rep[field]["mean"]
            out.append(
                f"| {m} | {protocol} | " + " | ".join("-" if mp.get(k) is None else f"{100 * mp[k]:.1f}" for k in keys) + " |"
            )
    return out if len(out) > 2 else []


def own_models(reports: Path) -> list[str]:
    out = []
    for m in OWN:
        for split, what in (("test", "unseen views of the training files"), ("ood", "the held-out file")):
            rep = load(reports / f"{m}_{split}.json")
            if rep is None:
                continue
            p, j = rep["parts"], rep.get("joints")
            out += [
                f"**{m}, {split}** ({what}; {rep['data']['num_samples']} views, success {success_cell(rep)}):",
                "",
                "| part | " + " | ".join(rep["part_names"]) + " |",
                "|---|" + "---|" * len(rep["part_names"]),
                "| rotation (deg, median) | " + cells(p["rotation_deg"]["median"], "{:.1f}").replace(", ", " | ") + " |",
                "| translation (% diag., median) | "
                + cells(p["translation_norm"]["median"], "{:.1f}", 100.0).replace(", ", " | ")
                + " |",
                "| 3D IoU (%, mean) | " + cells(p["iou"]["mean"], "{:.0f}", 100.0).replace(", ", " | ") + " |",
            ]
            if j:
                out += [
                    "",
                    "| joint | " + " | ".join(str(i + 1) for i in range(len(j["axis_deg"]["median"]))) + " |",
                    "|---|" + "---|" * len(j["axis_deg"]["median"]),
                    "| axis (deg, median) | " + cells(j["axis_deg"]["median"], "{:.1f}").replace(", ", " | ") + " |",
                    "| pivot (m, median) | " + cells(j["pivot_m"]["median"], "{:.3f}").replace(", ", " | ") + " |",
                    "| state (median) | " + state_cells(j, "median").replace(", ", " | ") + " |",
                ]
            out.append("")
    return out


def table3(reports: Path, cat: str = "eyeglasses") -> list[str]:
    rows = [
        ("shipped pipeline (20,000 pairs)", f"{cat}_test.json"),
        ("part-score filter off", f"{cat}_t3_no_score_filter.json"),
        ("pairs drawn from the whole cloud", f"{cat}_t3_pairs_from_cloud.json"),
        ("awareness off (both, and the joints')", f"{cat}_t3_no_awareness.json"),
    ] + [
        (f"{n:,} pairs{suffix}", f"{cat}_t3_pairs{n}{tag}.json")
        for n in (5000, 10000, 20000, 40000)
        for suffix, tag in (("", ""), (", no vote caps", "_nocaps"))
    ]
    out = ["| setting | success | rotation (deg) | translation (% diag.) | time (ms, median) |", "|---|---|---|---|---|"]
    for label, name in rows:
        rep = load(reports / name)
        if rep is None:
            continue
        p = rep["parts"]
        out.append(
            f"| {label} | {success_cell(rep)} | {cells(p['rotation_deg']['mean'], '{:.1f}')} | "
            f"{cells(p['translation_norm']['mean'], '{:.1f}', 100.0)} | {rep['time_ms']['median']['total']:.0f} |"
        )
    return out if len(out) > 3 else []


def data_line(reports: Path) -> str:
    rep = next((load(reports / f"{m}_test.json") for m in MODELS if (reports / f"{m}_test.json").is_file()), None)
    if rep is None:
        return ""
    hw = rep.get("hardware", {})
    return (
        f"Measured with ucope {rep.get('ucope_version')} on {hw.get('cpu_count')} CPU cores "
        f"({hw.get('torch_threads')} torch threads); data: `ucope generate --split test|ood --seed "
        f"{rep['data'].get('seed')} --views-per-instance 1`."
    )


README = ROOT / "README.md"
BEGIN, END = "<!-- models:begin (written by scripts/make_results.py) -->", "<!-- models:end -->"


def readme_table(reports: Path) -> str:
    """The README's table of models: one row per model with a test report."""
    rows = ["| model | parts | test success | ood success |", "|---|---|---|---|"]
    for m in (*MODELS, *OWN):
        test = load(reports / f"{m}_test.json")
        if test is not None:
            rows.append(
                f"| {m} | {len(test['part_names'])} | {success_cell(test)} | {success_cell(load(reports / f'{m}_ood.json'))} |"
            )
    return "\n".join(rows)


def with_readme_table(text: str, reports: Path) -> str:
    a, b = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text[:a] + "\n" + readme_table(reports) + "\n" + text[b:]


def page(reports: Path) -> str:
    lines = [
        "# Results",
        "",
        "Every figure here is written by `scripts/make_results.py` from the reports in `docs/reports`, each of which",
        "holds its per-view records (`views`: per view its object, success and per-part errors). A view **succeeds**",
        "when every part is within 10 degrees and 10 % of its ground-truth box diagonal; success is given with a 95 %",
        "interval that resamples whole objects (views of one object succeed or fail together). Each model's pipeline",
        "was chosen on validation views ([pipeline.md](pipeline.md)); test and ood were measured once afterwards, on",
        "fresh views of objects no choice saw (one view per object). **test**: unseen instances of the training",
        "shape families at training sizes; **ood**: held-out shape families at 0.5-2x the training sizes.",
        "",
        data_line(reports),
        "",
        "## The shipped models",
        "",
        "Means over views, per part (in the order of the model's parts) and per joint; time: the median per view as",
        "the evaluation ran, with other evaluations beside it (`benchmarks/bench_predict.py` measures speed).",
        "",
        *headline(reports, MODELS),
        "",
    ]
    ba = before_after(reports, MODELS)
    if ba:
        lines += [
            "## Before and after the one-pipeline refactor",
            "",
            "The same views, the code before the refactor (its switch defaults) against today's (the pipelines chosen",
            "on validation views): successes, and the views only one of them got right.",
            "",
            *ba,
            "",
        ]
    maps = rigid_maps(reports)
    if maps:
        lines += [
            "## Rigid models: mAP (%, NOCS metrics, test)",
            "",
            "Two protocols ([metrics.md](metrics.md)): **exact boxes** matches on the IoU of the oriented boxes; **NOCS",
            "reference** does what the NOCS evaluation code does (its own box IoU, pose metrics over the views matched at",
            "IoU > 0.1).",
            "",
            *maps,
            "",
        ]
    own = own_models(reports)
    if own:
        lines += [
            "## Models of public model files",
            "",
            "Models trained on public model files ([own_objects.md](own_objects.md)), per part and joint, medians over",
            "views. The microwave is one file: its test views are new sizes (x0.8-1.25), door angles and views of that",
            "microwave, two views per drawn size and angle (an object in the interval).",
            "",
            *own,
        ]
    t3 = table3(reports)
    if t3:
        lines += [
            "## Table 3: awareness and pairs (the shipped eyeglasses model, test views)",
            "",
            "The shipped model and its pipeline on the eyeglasses test views, one setting changed per row. The rows were",
            "evaluated one after another on one machine that ran other evaluations beside them: compare times within",
            "the table only roughly (`benchmarks/bench_predict.py` measures speed).",
            "",
            *t3,
            "",
        ]
    lines += [
        "## Elsewhere",
        "",
        "- Sensor noise, outliers, floor points, mask bleed, occlusion and sparse clouds: [robustness.md](robustness.md)",
        "  (`benchmarks/bench_robustness.py`); rolled cameras: `benchmarks/results_roll.json`; objects at 0.5-2x the",
        "  training sizes: `benchmarks/results_scale.json`; time per stage: `benchmarks/results_predict.json` (each",
        "  written by the benchmark script of the same name).",
        "- What each stage adds on validation views, per model: [pipeline.md](pipeline.md).",
        "",
    ]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reports", type=Path, default=REPORTS)
    ap.add_argument("--out", type=Path, default=PAGE)
    ap.add_argument("--check", action="store_true", help="exit 1 if --out is not what this would write")
    ap.add_argument("--slim", nargs="+", type=Path, default=None, help="rewrite these reports compactly first (see slim)")
    args = ap.parse_args()
    for path in args.slim or []:
        slim(path)
    text = page(args.reports)
    readme = with_readme_table(README.read_text(), args.reports)
    if args.check:
        if not args.out.is_file() or args.out.read_text() != text or README.read_text() != readme:
            print(f"{args.out} or {README} is out of date: run python scripts/make_results.py", file=sys.stderr)
            return 1
        return 0
    args.out.write_text(text)
    if args.out == PAGE:
        README.write_text(readme)
    print(f"wrote {args.out} ({len(text.encode())} bytes) and the README's table of models")
    return 0


if __name__ == "__main__":
    sys.exit(main())
