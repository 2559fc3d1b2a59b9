"""Regenerate docs/results.md from the evaluation reports (``ucope eval`` JSON files).

    python scripts/make_results.py                      # docs/reports/*.json -> docs/results.md
    python scripts/make_results.py --reports work/reports --runs work/runs --save-reports docs/reports

    python scripts/make_results.py --refresh-rigid      # recompute the rigid reports' metrics, then build

The second form (what scripts/reproduce_models.sh runs) first copies the fresh reports of a run of the
whole pipeline into docs/reports, without their per-sample records and with each model's training
figures (steps, time, hardware, from its run folder's model card) added, then builds the page from
them: the committed reports are what the page is made from, and tests/test_results_page.py checks
that the page is exactly what this script makes of them. ``--refresh-rigid`` rewrites the rigid
categories' reports (and their baselines') in place with their per-part summary and both mAPs recomputed
from the per-view records they store (``ucope.eval.evaluate.rigid_figures``), for when a metric changes
and the predictions do not; the report then lists what was recomputed under ``refreshed``.

Every figure on the page is read from a report; nothing is typed in by hand except the paper's own
numbers (Tables 1-3 of ../shared/reference/u-cope-paper.txt, quoted for comparison) and the notes in
scripts/results_notes.md, which are appended as they are. Report names: ``<category>.json`` (U-COPE),
``<category>_regression.json`` (the direct-regression baseline) and ``<category>_voting.json`` (U-COPE
measured beside it, when ``<category>.json`` is on other test views), ``eyeglasses_t3_*.json`` (the ablation,
every row on one test set: ``pairs<N>``, ``pairs<N>_nocaps``, ``no_score_filter``, ``pairs_from_cloud``,
``no_awareness``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

ARTICULATED = ("laptop", "eyeglasses", "dishwasher", "scissors", "drawer")
RIGID = ("bottle", "bowl", "camera", "can", "laptop_rigid", "mug")
CATEGORY_ORDER = ARTICULATED + RIGID

# The paper's U-COPE rows (Table 2: rotation deg, translation m, 3D IoU %, time s; ArtImage).
PAPER_TABLE2 = {
    "laptop": ([4.8, 4.1], [0.029, 0.030], [74.6, 49.2], 1.8),
    "eyeglasses": ([3.9, 5.3, 5.6], [0.043, 0.088, 0.088], [65.4, 60.9, 61.4], 2.1),
    "dishwasher": ([3.8, 4.5], [0.062, 0.066], [87.7, 72.8], 1.4),
    "scissors": ([2.4, 2.5], [0.033, 0.023], [46.9, 45.9], 1.9),
    "drawer": ([2.7, 3.2, 3.4, 2.9], [0.042, 0.101, 0.122, 0.094], [86.1, 81.8, 79.1, 80.3], 1.7),
}
# Table 1 (CAMERA25 mAP %, U-COPE row): the metrics we compute.
PAPER_TABLE1 = {"3D50": 93.4, "3D75": 86.3, "5deg2cm": 65.3, "5deg5cm": 71.6, "10deg2cm": 78.6, "10deg5cm": 86.0}
# Table 3 (eyeglasses): pairs -> (rotation, translation, IoU, time), and awareness off / on.
PAPER_TABLE3 = {
    5000: ([4.9, 7.4, 7.6], [0.062, 0.103, 0.112], [59.3, 54.2, 55.5], 1.8),
    10000: ([4.3, 5.8, 6.4], [0.051, 0.097, 0.099], [63.4, 57.8, 58.6], 2.0),
    20000: ([3.9, 5.3, 5.6], [0.043, 0.088, 0.088], [65.4, 60.9, 61.4], 2.1),
    40000: ([3.7, 5.0, 5.2], [0.039, 0.084, 0.086], [66.7, 62.4, 62.9], 2.6),
    "off": ([4.2, 5.8, 6.7], [0.058, 0.092, 0.105], [62.9, 58.8, 56.1], 2.0),
}


def load(reports: Path, name: str) -> dict | None:
    p = reports / f"{name}.json"
    return json.loads(p.read_text()) if p.is_file() else None


def cells(values, fmt: str, scale: float = 1.0) -> str:
    return ", ".join("-" if v is None else fmt.format(v * scale) for v in values)


def part_row(rep: dict, label: str, stat: str = "mean") -> str:
    """A Table-2 row of means (``stat="median"``: medians; the 10deg10cm fraction is not a statistic, "-")."""
    p = rep["parts"]
    frac = cells(p["fraction"]["10deg10cm"], "{:.0f}", 100) if stat == "mean" else "-"
    return (
        f"| {label} | {cells(p['rotation_deg'][stat], '{:.1f}')} | {cells(p['translation_m'][stat], '{:.3f}')} "
        f"| {cells(p['iou'][stat], '{:.1f}', 100)} | {frac} | {rep['time_ms'][stat]['total'] / 1000:.3f} |"
    )


def state_cells(j: dict, stat: str) -> str:
    return ", ".join(
        "-" if v is None else (f"{v:.1f} deg" if u == "deg" else f"{v:.3f} m")
        for v, u in zip(j["state_error"][stat], j["state_unit"], strict=False)
    )


def refresh_rigid(reports: Path) -> list[str]:
    """Recompute, in place, the per-part summary and both mAPs of every rigid report in ``reports`` from its
    ``map_records`` (nothing is predicted again); returns the names rewritten."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))
    from ucope.eval.evaluate import rigid_figures

    done = []
    for name in [c for c in RIGID] + [f"{c}_regression" for c in RIGID]:
        path = reports / f"{name}.json"
        if not path.is_file():
            continue
        rep = json.loads(path.read_text())
        if not rep.get("map_records"):
            continue
        rep.update(rigid_figures(rep["map_records"], rep["part_symmetry"][0]))
        rep["refreshed"] = (
            "parts, map and map_nocs recomputed from map_records by scripts/make_results.py --refresh-rigid "
            "with the metric code of ucope " + _version() + "; the predictions are those of the run above"
        )
        tmp = path.with_name(f".{path.name}.tmp")
        tmp.write_text(json.dumps(rep, indent=1, sort_keys=True) + "\n")
        tmp.replace(path)
        done.append(name)
    return done


def _version() -> str:
    from ucope import __version__

    return __version__


def translation_against_paper(reports: Path) -> str:
    """Which parts' mean translation errors (metres) are above the paper's Table 2 figures, read from the reports."""
    higher, total = [], 0
    for cat in ARTICULATED:
        rep = load(reports, cat)
        if rep is None:
            continue
        for name, ours, paper in zip(
            rep["part_names"], rep["parts"]["translation_m"]["mean"], PAPER_TABLE2[cat][1], strict=False
        ):
            total += 1
            if ours is not None and ours > paper:
                higher.append(f"{cat} {name} ({ours:.3f} m against {paper:.3f} m)")
    if not total:
        return ""
    lower = total - len(higher)
    return (
        f"Translation against the paper's Table 2, in metres: our mean error is lower for {lower} of {total} parts"
        + (
            f" and higher for: {' and '.join([', '.join(higher[:-1]), higher[-1]] if len(higher) > 1 else higher)}"
            if higher
            else ""
        )
        + ". The units may differ as well: the paper's metric section says its translation errors are normalised, "
        "its table prints metres; ours are metres (the reports also hold them divided by each part's box diagonal)."
    )


def pool_maps(reports: list, key: str) -> dict:
    """The per-class figures of several reports' ``key`` mAP (``"map"`` or ``"map_nocs"``; each report a
    different class) and their means over the classes.

    Every class's figures are computed from that class's views alone, so pooling the reports' per-class
    figures is the same as evaluating all their records at once (the mean is over the classes with
    ground truth, as in ``compute_map``).  Returns ``{"metrics", "classes", "num_pred": {cls},
    "ap" / "fraction" / "tie_range": {cls: {metric}}, "mean" / "mean_fraction": {metric},
    "mean_tie_range": {metric: [low, high]}}``.
    """
    pooled = {"metrics": None, "classes": [], "num_pred": {}, "ap": {}, "fraction": {}, "tie_range": {}}
    for rep in reports:
        m = rep[key]
        pooled["metrics"] = pooled["metrics"] or m["metrics"]
        for cls in m["classes_with_gt"]:
            pooled["classes"].append(cls)
            pooled["num_pred"][cls] = m["num_pred"][cls]
            pooled["ap"][cls] = m["per_class"][cls]
            pooled["fraction"][cls] = m["fraction"]["per_class"][cls]
            pooled["tie_range"][cls] = m["tie_range"]["per_class"][cls]
    names, classes = pooled["metrics"], pooled["classes"]
    pooled["mean"] = {n: mean_of(pooled, classes, "ap", n) for n in names}
    pooled["mean_fraction"] = {n: mean_of(pooled, classes, "fraction", n) for n in names}
    pooled["mean_tie_range"] = {
        n: [sum(pooled["tie_range"][c][n][k] for c in classes) / len(classes) for k in (0, 1)] for n in names
    }
    return pooled


def mean_of(pooled: dict, classes: list, what: str, metric: str) -> float:
    return sum(pooled[what][c][metric] for c in classes) / len(classes)


def map_cells(ap: dict, fraction: dict, names: list) -> str:
    return " | ".join(f"{100 * ap[n]:.1f} ({100 * fraction[n]:.1f})" for n in names)


def map_rows(pooled: dict, names: list, mean_label: str = "**mean (ours)**") -> list:
    rows = [f"| {c} | " + map_cells(pooled["ap"][c], pooled["fraction"][c], names) + " |" for c in pooled["classes"]]
    rows.append(
        f"| {mean_label} | "
        + " | ".join(f"**{100 * pooled['mean'][n]:.1f}** ({100 * pooled['mean_fraction'][n]:.1f})" for n in names)
        + " |"
    )
    return rows


def paper_row(row: tuple, label: str = "U-COPE, paper (ArtImage, GPU)", blanks: int = 1) -> str:
    """A row of the paper's figures; ``blanks`` columns it does not report (``-``) before the time."""
    rot, tr, iou, t = row
    return f"| {label} | {cells(rot, '{:.1f}')} | {cells(tr, '{:.3f}')} | {cells(iou, '{:.1f}')} | {'- | ' * blanks}{t:.1f} |"


def training_info(card: dict) -> dict:
    """What the page says about a model's training, from its model card. A fine-tuned model (``ucope
    train --init``) also lists the stages it was made in, oldest first (``stages``: steps and minutes
    each), followed through the run folders its card names (else the chain the card records)."""
    info = {
        k: card.get(k)
        for k in ("steps", "batch_size", "train_time_s", "world_size", "model_size", "head", "hardware", "stopped_early")
    }
    stages = [{"steps": card.get("steps"), "train_time_s": card.get("train_time_s")}]
    init = card.get("initialised_from")
    seen: set = set()
    while init and len(stages) < 32:
        parent = Path(init["model"]) / "model_card.json"
        pcard = json.loads(parent.read_text()) if parent.is_file() and parent.resolve() not in seen else None
        seen.add(parent.resolve())
        if pcard is not None and pcard.get("steps") == init.get("steps"):
            stages.append({"steps": pcard.get("steps"), "train_time_s": pcard.get("train_time_s")})
            init = pcard.get("initialised_from")
        else:
            stages.append({"steps": init.get("steps"), "train_time_s": init.get("train_time_s")})
            init = init.get("initialised_from")
    if len(stages) > 1:
        info["stages"] = stages[::-1]
    return info


def save_reports(src: Path, dest: Path, runs: Path | None) -> None:
    """Slim copies of the reports in ``src`` (no per-sample records), with the training figures of the
    run each was made from (``runs/<name without _pairsN / _no_awareness / _refine / _norefine>/model_card.json``,
    else the model card inside the shipped model of that name). A report that carries its own ``training``
    (one measured with an earlier model than that run, e.g. the voting side of a baseline comparison) keeps it."""
    import re

    from ucope.eval.evaluate import parts_in_view, view_bin, view_success

    dest.mkdir(parents=True, exist_ok=True)
    for p in sorted(src.glob("*.json")):
        rep = json.loads(p.read_text())
        if "success" not in rep and rep.get("samples"):  # a report from before the field: from its per-view records
            ok = [view_success(v["parts"]) for v in rep["samples"]]
            rep["success"] = {"definition": "every part < 10 deg and < 10 % of its box diagonal", "fraction": sum(ok) / len(ok)}
        recs = rep.get("samples") or []
        if "in_view_fraction" not in rep.get("success", {}) and recs and all("visible_points" in v for v in recs):
            # a report from before the success over the parts in view: from its per-view records, as evaluate counts it
            ok = [view_success(v["parts"], parts_in_view(v["visible_points"])) for v in recs]
            rep["success"]["in_view_fraction"] = sum(ok) / len(ok)
            for name, vb in (rep.get("view_bins") or {}).items():
                mine = [o for o, v in zip(ok, recs, strict=True) if view_bin(v["view_yaw_deg"]) == name]
                vb["success_in_view"] = sum(mine) / len(mine)
        rep.pop("samples", None)
        run = re.sub(r"_(t3_.*|pairs\d+|no_awareness|refine|norefine|voting|upright|noupright)$", "", p.stem)
        card = runs / run / "model_card.json" if runs is not None else None
        shipped = Path(__file__).resolve().parent.parent / "src" / "ucope" / "pretrained" / f"{run}.json"
        if "training" not in rep:
            if card is not None and card.is_file():
                rep["training"] = training_info(json.loads(card.read_text()))
            elif shipped.is_file():  # a shipped model's JSON holds its model card
                rep["training"] = training_info(json.loads(shipped.read_text()).get("info", {}))
        tmp = dest / f".{p.name}.tmp"
        tmp.write_text(json.dumps(rep, indent=1, sort_keys=True) + "\n")
        tmp.replace(dest / p.name)


def training_line(rep: dict | None) -> str:
    c = (rep or {}).get("training")
    if not c:
        return ""
    hw = c.get("hardware") or {}
    dev = hw.get("device", "?")
    n = hw.get("torch_threads", "?")
    where = f"{n} CPU thread{'' if n == 1 else 's'}" if dev == "cpu" else dev
    early = f" (stopped early: {c['stopped_early']})" if c.get("stopped_early") else ""
    stages = c.get("stages")
    if stages:
        steps = " + ".join(str(s["steps"]) for s in stages)
        minutes = sum(float(s["train_time_s"] or 0.0) for s in stages) / 60
        n = len(stages) - 1
        return (
            f"{steps} steps of batch {c['batch_size']} (a training, then {n} fine-tuning{'s' if n > 1 else ''} "
            f"with `--init` on fresh views) in {minutes:.1f} min on {where}{early}"
        )
    return f"{c['steps']} steps of batch {c['batch_size']} in {c['train_time_s'] / 60:.1f} min on {where}{early}"


def in_category_order(models: dict) -> list:
    """``(name, value)`` of a benchmark's per-model results, the shipped categories in the page's order
    first (a results file keeps them in whatever order its runs wrote them), any other model after."""
    rank = {c: i for i, c in enumerate(CATEGORY_ORDER)}
    return sorted(models.items(), key=lambda kv: (rank.get(kv[0], len(rank)), kv[0]))


def success_cell(rep: dict | None) -> str:
    """The report's success fraction (``success.fraction``) in percent with its view count, or ``-``."""
    if not rep or not rep.get("success"):
        return "-"
    return f"{100 * rep['success']['fraction']:.0f} % ({rep['data']['num_samples']})"


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a success fraction ``k / n`` (95 % for ``z`` 1.96), as fractions in [0, 1]."""
    if n <= 0:
        return 0.0, 1.0
    p = k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, mid - half), min(1.0, mid + half)


def success_interval_cell(rep: dict | None) -> str:
    """As :func:`success_cell`, with the 95 % Wilson interval over the views: ``"48 % (200; 41-54)"``."""
    if not rep or not rep.get("success"):
        return "-"
    n = int(rep["data"]["num_samples"])
    lo, hi = wilson_interval(round(rep["success"]["fraction"] * n), n)
    return f"{100 * rep['success']['fraction']:.0f} % ({n}; {100 * lo:.0f}-{100 * hi:.0f})"


def in_view_cell(rep: dict | None) -> str:
    """The success counting only the parts each view shows (``success.in_view_fraction``), ``"63 %"``; ``-`` for
    a rigid category (its one part is always in view) or a report without it."""
    frac = ((rep or {}).get("success") or {}).get("in_view_fraction")
    if frac is None or len((rep or {}).get("part_names") or []) < 2:
        return "-"
    return f"{100 * frac:.0f} %"


def seen_ratios(view_bins: dict) -> str:
    """Per part, ``"<rotation>x; <translation>x (n)"``: the back views' mean errors over the front views', both over
    the views that show the part (``seen_parts``), ``n`` the back views that hide it; ``-`` for a report without
    them (older reports) or a part no front or back view shows."""
    f, b = (view_bins.get(x, {}).get("seen_parts") for x in ("front", "back"))
    if not f or not b:
        return "-"
    out = []
    for k in range(len(f["rotation_deg"]["mean"])):
        rf, rb = f["rotation_deg"]["mean"][k], b["rotation_deg"]["mean"][k]
        tf, tb = f["translation_norm"]["mean"][k], b["translation_norm"]["mean"][k]
        if None in (rf, rb, tf, tb) or rf <= 0 or tf <= 0:
            out.append("-")
            continue
        out.append(f"{rb / rf:.2f}x; {tb / tf:.2f}x ({b['num_missing'][k]})")
    return ", ".join(out)


def command(rep: dict) -> str:
    return rep.get("command") or "(command not recorded)"


# Table 3 rows: (report name, label); every report on one eyeglasses test set (see table3_section).
TABLE3_PAIRS = (5000, 10000, 20000, 40000)
TABLE3_MECHANISMS = (
    ("eyeglasses_t3_pairs20000", "pairs from the predicted segment, score filter on (U-COPE, the default)"),
    ("eyeglasses_t3_no_score_filter", "pairs from the predicted segment, score filter off"),
    ("eyeglasses_t3_pairs_from_cloud", "pairs from the whole cloud, score filter on"),
    ("eyeglasses_t3_no_awareness", "awareness off: pairs from the whole cloud, no score filter, no joint awareness"),
)


def generator_label(data: dict) -> str:
    """A report's generator, e.g. ``"2"``, or ``"2, category revision 2"`` when its category's generator is past
    its first revision (``data.category_revision``; reports without it: 1)."""
    rev = data.get("category_revision", 1)
    return f"{data.get('generator_version', '?')}" + (f", category revision {rev}" if rev != 1 else "")


def same_test_set(a: dict, b: dict) -> bool:
    """Whether two reports were measured on the same test views: the same category, generator (and category
    revision), split, seed and count (sample i of a generated data set is the same wherever and into whichever
    folder it was generated)."""
    da, db = a.get("data", {}), b.get("data", {})
    keys = ("generator_version", "split", "seed", "num_samples")
    same_rev = da.get("category_revision", 1) == db.get("category_revision", 1)
    return all(da.get(k) == db.get(k) for k in keys) and same_rev and a.get("category") == b.get("category")


def ablation_row(rep: dict, label: str) -> str:
    """Table 3 row: means (medians of the rotation in brackets), 10deg10cm, success, time."""
    p = rep["parts"]
    rot = ", ".join(f"{m:.1f} ({d:.1f})" for m, d in zip(p["rotation_deg"]["mean"], p["rotation_deg"]["median"], strict=True))
    return (
        f"| {label} | {rot} | {cells(p['translation_m']['mean'], '{:.3f}')} | {cells(p['iou']['mean'], '{:.1f}', 100)} "
        f"| {cells(p['fraction']['10deg10cm'], '{:.0f}', 100)} | {success_cell(rep)} "
        f"| {rep['time_ms']['mean']['total'] / 1000:.3f} |"
    )


def table3_section(R: Path) -> list[str]:
    """The ablation of the paper's Table 3 on eyeglasses, every row on one test set: the number of pairs
    with the voting's pair caps (default) and without them, then the two mechanisms that part awareness
    couples (the score filter of eq. (10) and pair sampling from the predicted segment), one at a time."""
    reps = {n: load(R, f"eyeglasses_t3_pairs{n}") for n in TABLE3_PAIRS}
    free = {n: load(R, f"eyeglasses_t3_pairs{n}_nocaps") for n in TABLE3_PAIRS}
    mech = [(load(R, name), label) for name, label in TABLE3_MECHANISMS]
    every = [r for r in list(reps.values()) + list(free.values()) + [r for r, _ in mech] if r is not None]
    if not every:
        return []
    first = every[0]
    if not all(same_test_set(first, r) for r in every):
        raise SystemExit("the eyeglasses_t3_* reports are not all on one test set")
    d = first["data"]
    head = [
        "| setting | rotation error (deg), mean (median) | translation error (m) | 3D IoU (%) | 10deg10cm (%) | success | "
        "time (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    out = [
        "## Ablation on eyeglasses (Table 3 shape)",
        "",
        f"Every row: the shipped eyeglasses model on the same {d['num_samples']} test views (generator "
        f"{generator_label(d)}, seed {d.get('seed')}), parts {', '.join(first['part_names'])}; means, with the "
        "rotation's median in brackets; success: views whose every part is under 10 degrees and 10 % of its box diagonal. "
        "The paper's rows are its Table 3 (ArtImage, GPU).",
        "",
        "### Pairs per object",
        "",
        "The voting casts every pair's centre-inlier test and size, but decodes the axes from an evenly strided subset "
        "of at most 1,024 centre inliers per part and fills the centre grid from at most 4,096 pairs (its refinement "
        "1,024): these caps make it fast and, by construction, flatten a pairs ablation. The rows *without caps* "
        "(`--no-vote-caps`) let every pair cast every vote.",
        "",
    ] + head
    for n in TABLE3_PAIRS:
        if reps[n] is not None:
            out.append(ablation_row(reps[n], f"{n:,} pairs (ours, caps)"))
        if free[n] is not None:
            out.append(ablation_row(free[n], f"{n:,} pairs (ours, no caps)"))
        out.append(paper_row(PAPER_TABLE3[n], f"{n:,} pairs (paper)", blanks=2))
    out += [
        "",
        "### What part awareness does",
        "",
        "The paper's awareness ablation turns off two things at once: the score filter of its eq. (10) (a pair votes for "
        "a part only when its part score passes 0.5) and, in our implementation, drawing each part's pairs from the "
        "points segmented as that part. The rows below separate them (20,000 pairs; `--no-score-filter`, "
        "`--pairs-from-cloud`, `--no-awareness`).",
        "",
    ] + head
    for r, label in mech:
        if r is not None:
            out.append(ablation_row(r, label))
    out.append(paper_row(PAPER_TABLE3[20000], "awareness on (paper)", blanks=2))
    out.append(paper_row(PAPER_TABLE3["off"], "awareness off (paper)", blanks=2))
    cmds = list(dict.fromkeys(command(r) for r in every))
    if cmds:
        out += ["", "Commands: " + "; ".join(f"`{c}`" for c in cmds)]
    return out + [""]


# Voting against direct regression: the categories and the table's columns.
VERSUS = ("laptop", "drawer", "camera", "mug")


def versus_cells(rep: dict, stat: str) -> str:
    p = rep["parts"]
    fr = p["fraction"]
    five = cells(fr["5deg"], "{:.0f}", 100) if "5deg" in fr and stat == "mean" else "-"
    ten = cells(fr["10deg"], "{:.0f}", 100) if "10deg" in fr and stat == "mean" else "-"
    return (
        f"{cells(p['rotation_deg'][stat], '{:.1f}')} | {cells(p['translation_m'][stat], '{:.3f}')} | "
        f"{cells(p['iou'][stat], '{:.1f}', 100)} | {five} | {ten}"
    )


def joint_cells(rep: dict, stat: str) -> str:
    j = rep.get("joints")
    if not j:
        return "- | -"
    return f"{cells(j['axis_deg'][stat], '{:.1f}')} | {state_cells(j, stat)}"


def voting_vs_regression_section(R: Path) -> list[str]:
    """U-COPE's voting against the direct-regression baseline, per category, on the same test views: the
    voting report is whichever of ``<c>_voting`` (measured beside the baseline) and ``<c>`` is on the
    baseline's test set (``<c>_voting`` first)."""
    rows, cmds, notes = [], [], []
    for c in VERSUS:
        base = load(R, f"{c}_regression")
        if base is None:
            continue
        vote = next((r for r in (load(R, f"{c}_voting"), load(R, c)) if r is not None and same_test_set(r, base)), None)
        if vote is None:
            notes.append(f"{c}: no voting report on the baseline's test views")
            continue
        n = vote["data"]["num_samples"]
        for label, r in (("voting (U-COPE)", vote), ("regression", base)):
            for stat in ("mean", "median"):
                rows.append(
                    f"| {c} ({n}) | {label}{'' if stat == 'mean' else ', *median*'} | {versus_cells(r, stat)} | "
                    f"{joint_cells(r, stat)} | {success_cell(r) if stat == 'mean' else '-'} | "
                    f"{r['time_ms'][stat]['total'] / 1000:.3f} |"
                )
        cmds += [command(vote), command(base)]
    if not rows and not notes:
        return []
    out = [
        "## Voting against direct regression",
        "",
        "The direct-regression baseline (`ucope train --head regression`): the same PointNet++ encoder, part masks, "
        "segmentation and joint heads as U-COPE, with each part's 6D rotation, centre offset and log-size regressed from "
        "its mask-pooled features instead of voted from point pairs. Each baseline starts from the shipped voting model "
        "(`--init <model> --head regression`: its encoder, segmentation and joint heads are copied, the pose heads start "
        "fresh) and trains 3,000 steps of batch 8 on that model's last training data, with its augmentation and learning "
        "rate (the drawer: on generator-2 views, where the voting drawer's were generator-1 ones): it gets the voting "
        "model's whole training budget and 3,000 steps more. Its part score is the mean segmentation probability "
        "of the part's points times the fraction of them inside its regressed box (`ucope.stages.paper.regression_scores`). "
        "Both rows of a category are on the same test views (their count in brackets) with the same plane removal, "
        "rescaling and refinement settings, evaluated in the same session (so the times compare). Per part: rotation "
        "(deg), translation (m), 3D IoU (%), fractions of views under 5 and 10 degrees of rotation (%); per joint: axis "
        "error (deg) and state error; success: every part under 10 degrees and 10 % of its box diagonal.",
    ]
    if rows:
        out += [
            "",
            "| category (views) | method | rotation error (deg) | translation error (m) | 3D IoU (%) | 5 deg (%) | 10 deg (%) "
            "| joint axis error (deg) | joint state error | success | time (s) |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ] + rows
    if notes:
        out += ["", "Not compared: " + "; ".join(notes) + "."]
    if cmds:
        out += ["", "Commands: " + "; ".join(f"`{c}`" for c in cmds)]
    return out + [""]


def upright_section(R: Path) -> list[str]:
    """Every articulated shipped model with and without the upright carry (``<c>_upright`` /
    ``<c>_noupright``: ``ucope eval`` without / with ``--no-upright``, on the same test views)."""
    rows, cmds = [], []
    for c in ARTICULATED:
        on, off = load(R, f"{c}_upright"), load(R, f"{c}_noupright")
        if on is None or off is None or not same_test_set(on, off):
            continue
        vb_on, vb_off = on.get("view_bins", {}), off.get("view_bins", {})
        n = on["data"]["num_samples"]

        def bins(vb, key):
            return " / ".join(
                (f"{100 * vb[b]['success']:.0f}" if key == "success" else cells(vb[b]["parts"]["rotation_deg"]["mean"], "{:.1f}"))
                if b in vb
                else "-"
                for b in ("front", "side", "back")
            )

        for label, r, vb in (("off", off, vb_off), ("on", on, vb_on)):
            rows.append(
                f"| {c} ({n}, back {vb.get('back', {}).get('num_samples', 0)}) | {label} | "
                f"{success_cell(r)} | {bins(vb, 'success')} | "
                f"{bins(vb, 'rotation')} | {cells(r['parts']['translation_norm']['mean'], '{:.3f}')} |"
            )
        cmds += [command(off), command(on)]
    if not rows:
        return []
    return [
        "## Parts seen badly: the upright carry",
        "",
        "A part that voting tilted far outside the upright its training views kept it in (more than 10 degrees beyond "
        "the cone of its upright axis over the training views: a laptop base hidden behind its lid, whose few visible "
        "points voted it on end) is re-placed from a neighbour through their joint: the state within the limits that "
        "brings it nearest its upright, its centre from where the joint axis passes in both parts' boxes "
        "(`ucope.stages.upright.carry_upright`, docs/voting.md; `Estimator(upright=False)` / `--no-upright` turn it off). It "
        "assumes the training views' camera: upright, looking from above. Shipped models (their stored weights, "
        "half precision where the packaging check allowed), generator-2 test views, shipped defaults; each pair of "
        "rows on the same views. Success % and mean rotation error per part (deg) per camera-yaw bin (front / side / "
        "back), and the mean translation error per part (fraction of the box diagonal).",
        "",
        "| category (views) | carry | success | success front / side / back (%) | rotation front / side / back (deg) "
        "| translation (diag.) |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        "Commands: " + "; ".join(f"`{c}`" for c in cmds),
        "",
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    root = Path(__file__).resolve().parent.parent
    ap.add_argument("--reports", type=Path, default=root / "docs" / "reports")
    ap.add_argument("--runs", type=Path, default=None, help="run folders (training figures for --save-reports)")
    ap.add_argument("--save-reports", type=Path, default=None, help="copy the reports here (slim) and build from the copies")
    ap.add_argument("--out", type=Path, default=root / "docs" / "results.md")
    ap.add_argument("--notes", type=Path, default=Path(__file__).with_name("results_notes.md"))
    ap.add_argument(
        "--refresh-rigid",
        action="store_true",
        help="recompute the rigid reports' per-part summary and mAPs from their per-view records, in place",
    )
    ap.add_argument("--bench", type=Path, default=root / "benchmarks", help="folder of the benchmarks' results_*.json")
    args = ap.parse_args()
    R = args.reports
    if args.refresh_rigid:
        print("refreshed " + ", ".join(refresh_rigid(R)))
    if args.save_reports is not None:
        save_reports(args.reports, args.save_reports, args.runs)
        R = args.save_reports
    out = [
        "# Results",
        "",
        "Generated by `python scripts/make_results.py` from the `ucope eval` reports in [reports/](reports/); "
        "`scripts/reproduce_models.sh` retrains every model, re-evaluates it and rebuilds both from nothing. "
        "Every figure below is read from those reports; the paper's rows are quoted from its Tables 1-3 for comparison "
        "(its numbers are on ArtImage / CAMERA25 with a GPU; ours are on our procedural data sets, see "
        "[conventions.md](conventions.md), with CPU-trained models, so the comparison is of shape, not a like-for-like "
        "benchmark).",
        "",
        "Conventions: errors over the test split (unseen instances), means in the rows so labelled and medians in the "
        "rows marked *median* (a few flipped views pull a mean far from the typical view); rotation in degrees (y-symmetric "
        "parts, and mugs whose handle is not visible: angle between the y axes), translation in metres (box centre distance), "
        "3D IoU of the amodal boxes in percent computed **exactly** for oriented boxes (not what NOCS's evaluation code "
        "computes, see [metrics.md](metrics.md)); `10deg10cm` is the percentage of test views with rotation <= 10 deg and "
        "translation <= 10 cm; time is the wall time of `Estimator.predict` per object, in seconds. The refinement "
        "table shows means, the ablation table means with the rotation's median in brackets.",
        "",
    ]

    # ------------------------------------------------------------------------- Table 2 (articulated)
    out += ["## Articulated objects (Table 2 shape)", ""]
    for cat in ARTICULATED:
        rep = load(R, cat)
        if rep is None:
            continue
        base = load(R, f"{cat}_regression")
        if base is not None and not same_test_set(rep, base):  # compared in "Voting against direct regression"
            base = None
        out += [
            f"### {cat}",
            "",
            f"Parts: {', '.join(rep['part_names'])}; {rep['data']['num_samples']} test views "
            f"(generator {generator_label(rep['data'])}). "
            f"U-COPE trained with {training_line(rep) or 'see its model card'}.",
            "",
            "| method | rotation error (deg) | translation error (m) | 3D IoU (%) | 10deg10cm (%) | time (s) |",
            "|---|---|---|---|---|---|",
            part_row(rep, "U-COPE (ours)"),
            part_row(rep, "U-COPE (ours), *median*", "median"),
        ]
        if base is not None:
            out.append(part_row(base, "direct regression (baseline, same encoder / data / steps)"))
            out.append(part_row(base, "direct regression, *median*", "median"))
        out.append(paper_row(PAPER_TABLE2[cat]))
        out += ["", "| joint | method | axis error (deg) | pivot error (m) | state error |", "|---|---|---|---|---|"]
        for name, r in (("U-COPE (ours)", rep), ("direct regression", base)):
            if r is None or not r.get("joints"):
                continue
            j = r["joints"]
            for i in range(j["num_joints"]):
                for stat, label in (("mean", name), ("median", f"{name}, *median*")):
                    unit = j["state_unit"][i]
                    st = j["state_error"][stat][i]
                    st_s = "-" if st is None else (f"{st:.1f} deg" if unit == "deg" else f"{st:.3f} m")
                    piv = j["pivot_m"][stat][i]
                    out.append(
                        f"| {i} ({j['joint_type'][i]}) | {label} | {j['axis_deg'][stat][i]:.1f} | "
                        f"{'-' if piv is None else f'{piv:.3f}'} | {st_s} |"
                    )
        seg = rep.get("segmentation")
        if seg:
            out += [
                "",
                f"Segmentation (U-COPE): per-part IoU {cells(seg['iou'], '{:.1f}', 100)} %, accuracy "
                f"{100 * seg['accuracy']:.1f} %.",
            ]
        out += ["", f"Command: `{command(rep)}`" + (f"; baseline: `{command(base)}`" if base else ""), ""]

    sentence = translation_against_paper(R)
    if sentence:
        out += [sentence, ""]
    rerun = sorted(
        p.stem for p in R.glob("*.json") if (rep := load(R, p.stem) or {}).get("category") in ARTICULATED and rep.get("refreshed")
    )
    if rerun:
        out += [
            f"The joint state errors of the reports {', '.join(rerun)} were recomputed after the metric changed (a state is "
            "now compared about the axis sign that the axis error chose): their commands were re-run on the regenerated test "
            "splits, "
            "reproduced every other figure, and only the state errors were replaced (the reports' `refreshed` field).",
            "",
        ]

    # ---------------------------------------------------------------------------- Table 1 (rigid)
    rigid = {c: load(R, c) for c in RIGID}
    rigid = {c: r for c, r in rigid.items() if r is not None}
    if rigid:
        base = {c: load(R, f"{c}_regression") for c in rigid}
        base = {c: b for c, b in base.items() if b is not None and same_test_set(rigid[c], b)}
        exact, nocs = pool_maps(list(rigid.values()), "map"), pool_maps(list(rigid.values()), "map_nocs")
        names = exact["metrics"]
        out += [
            "## Rigid objects (Table 1 shape): NOCS-style mAP",
            "",
            f"Per class and mean over {len(exact['classes'])} classes, one object per view, so the AP of a class is the "
            "precision-recall area of its views ranked by our part score. Bottle, bowl, can and mugs whose handle is not "
            "visible are evaluated as symmetric about y (NOCS rules, anchors.md section 3). Each cell: the AP, and in "
            "brackets the **score-free fraction**: the percentage of views whose pose passes the threshold, i.e. the recall "
            "a "
            "perfect ranking would reach, which does not depend on the scores. Two protocols ([metrics.md](metrics.md)): "
            "ours, with the exact IoU and tied scores counted as one operating point (no figure depends on the order of the "
            "records), and the NOCS reference code's, as it runs, which the paper's Table 1 was computed with: its IoU is "
            "not "
            "an IoU (a max taken over the wrong array axis) and its pose columns count only the views matched at that IoU > "
            "0.1. Only the second is "
            "comparable with the paper's row; neither is a like-for-like benchmark (different data).",
            "",
            "### Our protocol (exact IoU)",
            "",
            "| class | " + " | ".join(names) + " |",
            "|---|" + "---|" * len(names),
        ]
        out += map_rows(exact, names)
        if base:
            bex = pool_maps(list(base.values()), "map")
            sub = {
                "mean": {n: mean_of(exact, bex["classes"], "ap", n) for n in names},
                "mean_fraction": {n: mean_of(exact, bex["classes"], "fraction", n) for n in names},
            }
            out.append(
                f"| direct regression ({', '.join(bex['classes'])}) | "
                + map_cells(bex["mean"], bex["mean_fraction"], names)
                + " |"
            )
            out.append("| U-COPE (ours) on the same classes | " + map_cells(sub["mean"], sub["mean_fraction"], names) + " |")
        out += [
            "",
            "### NOCS's reference protocol (the paper's)",
            "",
            "| class | " + " | ".join(names) + " |",
            "|---|" + "---|" * len(names),
        ]
        out += map_rows(nocs, names, "**mean (ours, NOCS protocol)**")
        out.append("| U-COPE, paper (CAMERA25) | " + " | ".join(f"{PAPER_TABLE1[n]:.1f}" for n in names) + " |")
        ties, bex = [], pool_maps(list(base.values()), "map") if base else None
        if base:
            bno = pool_maps(list(base.values()), "map_nocs")
            out.append(
                f"| direct regression ({', '.join(bno['classes'])}) | "
                + map_cells(bno["mean"], bno["mean_fraction"], names)
                + " |"
            )
            ties = [
                f"{n} {100 * bno['mean_tie_range'][n][0]:.1f}-{100 * bno['mean_tie_range'][n][1]:.1f}"
                for n in names
                if bno["mean_tie_range"][n][1] - bno["mean_tie_range"][n][0] > 5e-4
            ]
        tied = sum(v for m in rigid.values() for v in m["map_nocs"].get("num_tied", {}).values())
        spread = max(hi - lo for lo, hi in nocs["mean_tie_range"].values())
        out += [
            "",
            "Under the NOCS protocol, tied scores are ranked in reverse record order, so an AP with ties depends on the "
            "order of the records"
            + (
                f" ({tied} of our {sum(exact['num_pred'].values())} predictions share their score with another; "
                f"over all their orders the means above move by at most {100 * spread:.2f} points)"
                if tied
                else ""
            )
            + "."
            + (
                " The direct-regression baseline gives every view the score 1.0, so its NOCS row is one of many: over all "
                f"orders of its records it spans {', '.join(ties)}. Under our protocol a tie is one operating point, which "
                "gives the lowest "
                "AP over the orders (a ranking that orders nothing earns nothing for its order: "
                + ", ".join(
                    f"{n} {100 * bex['mean'][n]:.1f} of {100 * bex['mean_tie_range'][n][0]:.1f}-"
                    f"{100 * bex['mean_tie_range'][n][1]:.1f}"
                    for n in names
                    if bex["mean_tie_range"][n][1] - bex["mean_tie_range"][n][0] > 5e-4
                )
                + "), and its fractions say how good its poses are."
                if ties
                else ""
            ),
            "",
        ]
        out += [
            "Per-category errors (means, then medians):",
            "",
            "| category | method | rotation error (deg) | translation error (m) | 3D IoU (%) | 10deg10cm (%) | time (s) |",
            "|---|---|---|---|---|---|---|",
        ]
        for c, r in rigid.items():
            out.append(part_row(r, f"{c} | U-COPE (ours)"))
            out.append(part_row(r, f"{c} | U-COPE (ours), *median*", "median"))
            if c in base:
                out.append(part_row(base[c], f"{c} | direct regression"))
                out.append(part_row(base[c], f"{c} | direct regression, *median*", "median"))
        out += ["", "Commands: " + "; ".join(f"`{command(r)}`" for r in rigid.values()), ""]
        refreshed = [c for c in list(rigid) + [f"{c}_regression" for c in base] if (load(R, c) or {}).get("refreshed")]
        if refreshed:
            out += [
                f"The figures of {', '.join(refreshed)} were recomputed from the per-view records their reports store, "
                "after the metrics changed (the reports' `refreshed` field); the predictions and times are those of the "
                "commands.",
                "",
            ]
        gens = {c: generator_label(r["data"]) for c, r in rigid.items()}
        out += [
            "Test views: "
            + "; ".join(f"generator {g}: {', '.join(c for c in rigid if gens[c] == g)}" for g in sorted(set(gens.values())))
            + " (the data sets' `generator_version`; the mAP tables pool every class's views).",
            "",
        ]
        lines = [training_line(r) for r in rigid.values()]
        if any(lines):
            out += ["Training: " + "; ".join(f"{c}: {line}" for c, line in zip(rigid, lines, strict=False) if line) + ".", ""]

    # ----------------------------------------------------------------------------- Table 3 (ablation)
    out += table3_section(R)
    out += voting_vs_regression_section(R)
    out += upright_section(R)

    # ------------------------------------------------------------------------- kinematic refinement
    pairs = [(c, load(R, f"{c}_norefine") or load(R, c), load(R, f"{c}_refine")) for c in ARTICULATED]
    pairs = [(c, a, b) for c, a, b in pairs if a is not None and b is not None]
    if pairs:
        on_by_default = [c for c, _, _ in pairs if (load(R, c) or {}).get("settings", {}).get("refine")]
        out += [
            "## The kinematic refinement (`--refine` / `--no-refine`)",
            "",
            "Part rotations, joint axes and joint states made mutually consistent after the voting "
            "([voting.md](voting.md)). Same models and test views, refinement off / on. A model is packaged "
            "with it on by default where it lowers the rotation errors, does not lower the success fraction and "
            "costs no part more than one point of 3D IoU (`scripts/package_models.py`): "
            + (", ".join(on_by_default) if on_by_default else "none")
            + ". The tables above use each model's default.",
            "",
            "| category | refine | rotation error (deg) | translation error (m) | 3D IoU (%) | joint axis error (deg) | joint "
            "state error | success |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for c, a, b in pairs:
            for flag, r in (("off", a), ("on", b)):
                p, j = r["parts"], r["joints"]
                st = ", ".join(
                    "-" if v is None else (f"{v:.1f} deg" if u == "deg" else f"{v:.3f} m")
                    for v, u in zip(j["state_error"]["mean"], j["state_unit"], strict=False)
                )
                out.append(
                    f"| {c} | {flag} | {cells(p['rotation_deg']['mean'], '{:.1f}')} | "
                    f"{cells(p['translation_m']['mean'], '{:.3f}')} "
                    f"| {cells(p['iou']['mean'], '{:.1f}', 100)} | {cells(j['axis_deg']['mean'], '{:.1f}')} | {st} "
                    f"| {success_cell(r)} |"
                )
        out.append("")

    # ----------------------------------------------------------------------------- training curves
    curves = [c for c in ("laptop", "mug") if (root / "docs" / "images" / f"training_{c}.png").is_file()]
    if curves:
        out += [
            "## Training curves",
            "",
            "Training (thin) and held-out validation (markers) losses and errors of the shipped laptop and mug models, "
            "drawn by `python scripts/plot_training.py RUN --out PNG` from the runs' `metrics.jsonl`:",
            "",
        ]
        out += [f"![{c} training](images/training_{c}.png)" for c in curves] + [""]

    # ------------------------------------------------------------------- out of distribution, view bins
    ood = {c: load(R, f"{c}_ood") for c in CATEGORY_ORDER}
    binned = {c: load(R, c) for c in CATEGORY_ORDER}
    binned = {c: r for c, r in binned.items() if r and r.get("view_bins")}
    if binned or any(ood.values()):
        out += [
            "## Unseen shape families, other sizes and views from behind",
            "",
            "Success = every part < 10 deg and < 10 % of its ground-truth box diagonal, per view, with the number of views and "
            "the 95 % Wilson interval over them in brackets (the views are not the only spread: another draw of the "
            "network's points moved the drawer's success by up to 9 points on 100 views). *test*: the test split above "
            "(unseen instances of the training families and sizes); *ood*: `ucope generate --split ood` (shape families held "
            "out of training, sizes scaled by log-uniform 0.5-2x, [conventions.md](conventions.md)), 100 views, evaluated "
            "with the model's shipped defaults (rescaling, plane removal, refinement, box growth, face alignment, "
            "the three-size scale search, the fitted extents and anchored faces, the laptop's and dishwasher's free "
            "space (inside the upright cone), the drawer's front flips, placement, slide and stack, the door, lid and "
            "temple turn, the settled joint states, the dishwasher's hinge seat and its pick by the parts given points, "
            "the laptop's and scissors' upright carry inside the cone, "
            "the drawer's restarts and its hidden drawers' check against the view; its stored weights, "
            "half precision where the packaging check allowed); front / side / "
            "back: the test views by the camera's yaw about the object (front "
            "|yaw| < 45 deg, back > 135 deg), their count in brackets, and the mean rotation error and mean translation "
            "error (% of the part's box diagonal) per part. *back / front, seen*: per part, the mean rotation and "
            "translation errors of the back views over those of the front views, both counted only where the view shows "
            "the part (at least 30 of its points, the report's `seen_parts`; a closed dishwasher door or a drawer seen "
            "from behind is hidden, its pose a guess no point can check), the number of back views that hide it in "
            "brackets. *in view*: the success counting in each view only the parts it shows (at least 30 of their "
            "points): what the hidden parts cost.",
            "",
            "| category | test | ood | in view: test / ood | front | side | back | rotation front / side / back (deg) | "
            "translation front / side / back (% of diagonal) | back / front, seen: rotation; translation |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for c in CATEGORY_ORDER:
            r, o = binned.get(c), ood.get(c)
            if not r and not o:
                continue
            vb = (r or {}).get("view_bins", {})
            cell_ = [
                f"{100 * vb[b]['success']:.0f} % ({vb[b]['num_samples']})" if b in vb else "-" for b in ("front", "side", "back")
            ]
            rot = " / ".join(
                cells(vb[b]["parts"]["rotation_deg"]["mean"], "{:.1f}") if b in vb else "-" for b in ("front", "side", "back")
            )
            trans = " / ".join(
                cells([100 * t for t in vb[b]["parts"]["translation_norm"]["mean"]], "{:.1f}") if b in vb else "-"
                for b in ("front", "side", "back")
            )
            row = f"| {c} | {success_interval_cell(r)} | {success_interval_cell(o)} | {in_view_cell(r)} / {in_view_cell(o)} | "
            row += " | ".join(cell_)
            out.append(row + f" | {rot} | {trans} | {seen_ratios(vb)} |")
        out.append("")

    # ------------------------------------------------------------------------------ other sizes
    bs = args.bench / "results_scale.json"
    if bs.is_file():
        b = json.loads(bs.read_text())
        st = b["settings"]
        facs = [f"{f:g}" for f in st["factors"]]
        wide = [
            n for n, _ in in_category_order(b["models"]) if ((load(R, n) or {}).get("settings") or {}).get("wide_scale_search")
        ]
        out += [
            "## Objects of other sizes",
            "",
            f"`python benchmarks/bench_scale.py`: {st['num']} unseen test views per model (seed {st['seed']}, "
            f"{st['pairs']:,} pairs), each scaled about the object's centre by the factor (points, poses, sizes, "
            "pivots, prismatic states); success = "
            f"{b['success']}. Each cell: success % / median box size ratio (cube root of predicted over true "
            "volume), first as the model sees the cloud (`--no-rescale`), then with the estimator's defaults: "
            "the rescaling into the training sizes (`Estimator(rescale=True)`) and, where the first estimate's "
            "score is below 0.9, the scale search (a second estimate on the cloud normalised to the model's "
            "typical radii, the higher-scored one standing; `--no-scale-search`; at 0.8, 1 and 1.25x those radii for "
            f"the models whose default `wide_scale_search` is on: {', '.join(wide) or 'none'}).",
            "",
            "| model | " + " | ".join(f"x{f} as is" for f in facs) + " | " + " | ".join(f"x{f} rescaled" for f in facs) + " |",
            "|---|" + "---|" * (2 * len(facs)),
        ]
        for name, m in in_category_order(b["models"]):
            cells_ = [m["factors"][f][k] for k in ("as_is", "rescale") for f in facs]
            out.append(
                f"| {name} | " + " | ".join(f"{100 * c['success']:.0f} / {c['median_size_ratio']:.2f}" for c in cells_) + " |"
            )
        out.append("")

    # ------------------------------------------------------------------------------- camera roll
    br = args.bench / "results_roll.json"
    if br.is_file():
        b = json.loads(br.read_text())
        st = b["settings"]
        rolls = [f"{r:g}" for r in st["rolls_deg"]]
        out += [
            "## Cameras that are not upright",
            "",
            f"`python benchmarks/bench_roll.py`: {st['num']} unseen test views per model (seed {st['seed']}, "
            f"{st['pairs']:,} pairs), the camera rolled about its optical axis by each angle "
            "(`ucope.data.sample.roll_sample`). The models were trained on upright cameras (3 degrees of roll). Each "
            "cell: success % without the upright carry and turn (`upright=False`) / with the defaults / with the world's up "
            "direction given (`predict(points, up=...)`, `--up X Y Z`: the cloud is turned back to an upright camera "
            f"first); success = {b['success']}.",
            "",
            "| model | " + " | ".join(f"roll {r} deg" for r in rolls) + " |",
            "|---|" + "---|" * len(rolls),
        ]
        for name, m in in_category_order(b["models"]):
            keys = ("no_carry", "default", "up_given")
            row = [" / ".join(f"{100 * m['rolls'][r][k]['success']:.0f}" for k in keys) for r in rolls]
            out.append(f"| {name} | " + " | ".join(row) + " |")
        out.append("")

    # --------------------------------------------------------------------------------------- speed
    bp, bt = args.bench / "results_predict.json", args.bench / "results_train.json"
    if bp.is_file() or bt.is_file():
        out += ["## Speed", ""]
    if bp.is_file():
        b = json.loads(bp.read_text())
        out += [
            f"`python benchmarks/bench_predict.py` ({b['threads']} CPU threads, torch {b['torch']}; median over "
            f"{b['results'][0]['repeats']} unseen test views; target {b['target_total_ms']:.0f} ms in total):",
            "",
            "| model | K | pairs | normals | preprocess | encoder | pair encoder | voting | total (ms) |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in b["results"]:
            m = r["median_ms"]
            switches = (("refine", r.get("refine")), (f"restarts {r.get('restarts')}", r.get("restarts")))
            how = ", ".join(w for w, on in switches if on)
            label = f"{r['category']} ({how})" if how else r["category"]
            out.append(
                f"| {label} | {r['num_parts']} | {r['pairs']:,} | "
                f"{'given' if r['normals_given'] else 'estimated'} | "
                f"{m['preprocess']:.1f} | {m['encoder']:.1f} | {m['pair_encoder']:.1f} | {m['voting']:.1f} | "
                f"**{m['total']:.1f}** |"
            )
        out.append("")
    if bt.is_file():
        b = json.loads(bt.read_text())
        out += [
            f"`python benchmarks/bench_train.py` ({b['threads']} CPU threads): training step at batch 8 (forward, loss, "
            "backward, Adam) "
            "and the preparation of its 8 items (point subset, FPS, pairs), forward pass for one object:",
            "",
            "| category | size | points | parameters | step (s) | items (s) | forward, 1 object (ms) |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in b["results"]:
            out.append(
                f"| {r['category']} | {r['size']} | {r['num_points']} | {r['parameters'] / 1e6:.2f} M | "
                f"{r['step_s_median']:.3f} | "
                f"{r.get('items_s_median', float('nan')):.3f} | {r['forward_1_ms_median']:.1f} |"
            )
        out.append("")

    if args.notes.is_file():
        out += [args.notes.read_text().rstrip(), ""]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".md.tmp")
    tmp.write_text("\n".join(out))
    tmp.replace(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
