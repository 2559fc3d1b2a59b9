"""Choose a model's pipeline on validation views: which stages it keeps and how much it searches.

    python scripts/choose_pipeline.py --model drawer                      # a shipped model: its card is rewritten
    python scripts/choose_pipeline.py --model work/runs/arm --num 120 --report work/reports/arm_val.json

The validation views are drawn from the ``val`` split (seed ``--seed``, one view per object, never a view a
reported figure uses); every second view is corrupted with the training augmentation's mix (occlusion, floor
and neighbour points, outliers, noise, fewer points), so that the stages meant for real sensors are measured
where they act. Starting from the model card's pipeline P, each candidate change is measured on the same views:

* every optional stage of P left out (the paper's ``vote_parts`` / ``regress_parts``, ``vote_joints``,
  ``joint_states`` and ``score`` always stay);
* each sub-step of ``fit_boxes`` and ``clean_cloud`` turned off;
* the search: one size instead of three, three instead of one, no restarts instead of some, the other pick, no
  roll read from a support plane in view.

A change is taken when it gains at least :data:`MIN_GAIN` views (a stage stays unless leaving it out gains that
much): the validation views are views of the training shape families at training sizes, so a stage made for other
shapes and sizes shows nothing there, and a view or so either way is noise. Several changes taken are measured
together and kept together only if that does as well as the best of them alone. The report holds every candidate's
per-view outcomes, so the choice can be recomputed (``--rechoose REPORT``); the card's ``pipeline.chosen_on`` says
which views chose it.

    python scripts/choose_pipeline.py --model drawer --rechoose docs/reports/drawer_val_pipeline.json
    python scripts/choose_pipeline.py --model drawer --fast docs/reports/drawer_val_pipeline.json   # what --fast costs
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.data.augment import AugmentConfig, augment_sample  # noqa: E402
from ucope.data.generate import config_of_model, make_sample  # noqa: E402
from ucope.estimation import FAST, Estimator  # noqa: E402
from ucope.estimation.pipeline import Pipeline  # noqa: E402
from ucope.eval.evaluate import sample_errors, view_success  # noqa: E402
from ucope.fileio import atomic_write_json  # noqa: E402
from ucope.model.checkpoint import find_model, load_model  # noqa: E402

ALWAYS = ("vote_parts", "regress_parts", "vote_joints", "joint_states", "score")
"""Stages a choice never leaves out: the paper's, and the calibrated score the search reads."""

VAL_SEED = 4242
"""The default seed of the validation views (no reported figure uses it)."""


def val_views(category: str, num: int, seed: int, info: dict | None = None, scale_range=None) -> list[dict]:
    """``num`` validation views of ``category`` (one per object; a category of your own drawn from the spec of the
    model card ``info``'s training data); every second one corrupted, each by a random stream of its own. With
    ``scale_range`` ``(low, high)``, each object is built at a scale factor drawn log-uniformly in it (a stream of
    its own per view) instead of its training size."""
    cfg = config_of_model(category, info, split="val", seed=seed, num=num, views_per_instance=1, background=True)
    aug = AugmentConfig(probability=1.0)
    out = []
    for i in range(num):
        if scale_range is None:
            s = make_sample(cfg, i)
        else:
            rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(zlib.crc32(b"scale"), i)))
            factor = float(np.exp(rng.uniform(np.log(scale_range[0]), np.log(scale_range[1]))))
            s = make_sample(dataclasses.replace(cfg, scale=factor), i)
        if i % 2 == 1:
            rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(zlib.crc32(category.encode()), i)))
            pts, labels, _ = augment_sample(s, rng, aug)
            s = dict(s, points=pts, part_labels=labels, normals=None)
        out.append(s)
    return out


def view_ok(result, view: dict) -> bool:
    """Whether every part of ``result`` is right on the validation view ``view``."""
    # points a corruption added are no part (-1); the part errors are what counts here, not the segmentation
    truth = dict(view, part_labels=np.maximum(np.asarray(view["part_labels"]), 0)) if len(view["size_m"]) > 1 else view
    return bool(view_success(sample_errors(result, truth)["parts"]))


def measure(est: Estimator, views: list[dict]) -> tuple[np.ndarray, float]:
    """Per view, whether every part is right; and the mean time per view (ms)."""
    ok, ms = [], 0.0
    for s in views:
        r = est.predict(s["points"], s.get("normals"))
        ok.append(view_ok(r, s))
        ms += r.timings_ms["total"]
    return np.array(ok, dtype=bool), ms / len(views)


MIN_GAIN = 2
"""A change is taken when it gains at least this many views on the validation views: a view or so either way is
noise on a hundred views, and the stages made for shapes and sizes the validation views do not hold (held-out shape
families, objects at other sizes) would otherwise be left out for want of evidence."""


def candidates(p: Pipeline) -> list[tuple[str, Pipeline]]:
    """``(label, pipeline)`` of every candidate change of ``p`` (see the module docstring)."""
    out = []
    for name in dict.fromkeys(p.stages):
        if name not in ALWAYS:
            out.append((f"drop {name}", p.changed(drop=[name])))
    for stage, subs in (("fit_boxes", ("grow", "fit", "anchor")), ("clean_cloud", ("plane",))):
        if stage in p.stages:
            for sub in subs:
                if p.params.get(f"{stage}.{sub}", True):
                    out.append((f"{stage}.{sub} off", p.changed(overrides={f"{stage}.{sub}": False})))
    if p.search.roll_from_plane:
        out.append(("no roll from a plane", p.changed(overrides={"search.roll_from_plane": False})))
    if p.calibration is not None:
        s = p.search
        if len(s.scale_factors) > 1:
            out.append(("one size", p.changed(overrides={"search.scale_factors": [1.0]})))
        else:
            out.append(("three sizes", p.changed(overrides={"search.scale_factors": [0.8, 1.0, 1.25]})))
        if s.restarts:
            out.append(("no restarts", p.changed(overrides={"search.restarts": 0})))
        out.append(
            (
                f"pick {'all' if s.pick == 'seen' else 'seen'}",
                p.changed(overrides={"search.pick": "all" if s.pick == "seen" else "seen"}),
            )
        )
    return out


def combine(p: Pipeline, labels: list[str], cands: dict[str, Pipeline]) -> Pipeline:
    """``p`` with every change in ``labels`` applied."""
    out = p
    for label in labels:
        c = cands[label]
        dropped = [n for n in out.stages if n not in c.stages]
        overrides = {k: v for k, v in c.params.items() if p.params.get(k, object()) != v}
        search = {
            f.name: getattr(c.search, f.name)
            for f in dataclasses.fields(c.search)
            if getattr(c.search, f.name) != getattr(p.search, f.name)
        }
        out = out.changed(drop=dropped, overrides={**overrides, **{f"search.{k}": v for k, v in search.items()}})
    return out


def decide(record: dict) -> list[str]:
    """The changes a report's candidates justify: each that gains at least :data:`MIN_GAIN` views over P; of two
    changes of one setting (none here: each candidate is one change) the order of the report."""
    return [k for k, v in record.items() if isinstance(v, dict) and "delta" in v and v["delta"] >= MIN_GAIN]


def choose(model: str, num: int, seed: int, record: dict | None = None) -> tuple[Pipeline, dict]:
    """Measure P and every candidate on ``num`` validation views (or take them from a report's ``record``), then
    take the changes :func:`decide` justifies; several are measured together, and kept together only if that does
    as well as the best of them alone (else the best alone)."""
    net, meta = load_model(find_model(model))
    base = Pipeline.from_info(meta.get("info"), net.cfg.priors, net.cfg.head)
    cands = dict(candidates(base))
    views = None

    def run(pipe):
        nonlocal views
        if views is None:
            t0 = time.perf_counter()
            views = val_views(net.cfg.category, num, seed, meta.get("info"))
            print(f"{model}: {num} val views in {time.perf_counter() - t0:.0f} s", flush=True)
        return measure(Estimator(net, pipe), views)

    if record is None:
        record = {}
        ok_p, ms_p = run(base)
        record["P"] = {
            "stages": list(base.stages),
            "success": int(ok_p.sum()),
            "ms": round(ms_p, 1),
            "views": ok_p.astype(int).tolist(),
        }
        print(f"  P: {ok_p.sum()}/{num} ({ms_p:.0f} ms)", flush=True)
        for label, pipe in cands.items():
            ok, ms = run(pipe)
            delta = int(ok.sum()) - int(ok_p.sum())
            record[label] = {"success": int(ok.sum()), "delta": delta, "ms": round(ms, 1), "views": ok.astype(int).tolist()}
            print(f"  {label}: {ok.sum()}/{num} ({delta:+d}, {ms:.0f} ms)", flush=True)
    for key in ("combined", "fallback", "chosen"):
        record.pop(key, None)
    taken = decide(record)
    chosen = combine(base, taken, cands) if taken else base
    if len(taken) > 1:
        ok_c, ms_c = run(chosen)
        record["combined"] = {
            "changes": taken,
            "success": int(ok_c.sum()),
            "ms": round(ms_c, 1),
            "views": ok_c.astype(int).tolist(),
        }
        best = max(taken, key=lambda k: record[k]["success"])
        print(f"  combined {taken}: {ok_c.sum()}/{num} ({ms_c:.0f} ms)", flush=True)
        if ok_c.sum() < record[best]["success"]:
            taken = [best]
            chosen = combine(base, taken, cands)
            record["fallback"] = {"changes": taken}
    chosen = dataclasses.replace(
        chosen,
        chosen_on=f"val split, seed {seed}, {num} views of {num} objects, every second corrupted (scripts/choose_pipeline.py, "
        f"changes that gain at least {MIN_GAIN} views): {', '.join(taken) or 'no change'}",
    )
    record["chosen"] = chosen.to_dict()
    return chosen, record


def measure_fast(model: str, report: Path) -> dict:
    """The model card's pipeline and its fast setting (:data:`ucope.estimation.FAST`: one estimate of one pass) on a
    choice report's validation views, one after the other in one process: what ``--fast`` costs in successes and what
    it saves in time. Stored in the report as ``fast``; never taken into a card."""
    if not report.is_file():
        raise SystemExit(f"--fast {report}: no such choice report (run choose_pipeline.py --model {model} first)")
    rep = json.loads(report.read_text())
    net, meta = load_model(find_model(model))
    card = Pipeline.from_info(meta.get("info"), net.cfg.priors, net.cfg.head)
    views = val_views(net.cfg.category, rep["num"], rep["seed"], meta.get("info"))
    ok_d, ms_d = measure(Estimator(net, card), views)
    ok_f, ms_f = measure(Estimator(net, card.changed(overrides=FAST)), views)
    rep["fast"] = {
        "default": {"success": int(ok_d.sum()), "ms": round(ms_d, 1), "views": ok_d.astype(int).tolist()},
        "fast": {"success": int(ok_f.sum()), "ms": round(ms_f, 1), "views": ok_f.astype(int).tolist()},
    }
    atomic_write_json(report, rep)
    print(f"{model}: default {ok_d.sum()}/{len(views)} ({ms_d:.0f} ms), fast {ok_f.sum()}/{len(views)} ({ms_f:.0f} ms)")
    return rep["fast"]


def write_card(path: Path, pipeline: Pipeline) -> None:
    doc = json.loads(path.read_text())
    doc.setdefault("info", {})["pipeline"] = pipeline.to_dict()
    atomic_write_json(path, doc)


def main() -> int:
    import torch

    torch.set_num_threads(1)  # one process per core when several models are chosen at once
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True, help="a shipped model name or a run folder / model .json")
    ap.add_argument("--num", type=int, default=120, help="validation views (default 120)")
    ap.add_argument("--seed", type=int, default=VAL_SEED)
    ap.add_argument("--report", default=None, help="report JSON (default docs/reports/MODEL_val_pipeline.json)")
    ap.add_argument("--no-write", action="store_true", help="measure and report only; leave the model card alone")
    ap.add_argument("--apply", type=Path, default=None, help="write the pipeline a report chose into the card (no measuring)")
    ap.add_argument(
        "--rechoose", type=Path, default=None, help="decide again from a report's candidates (measuring a combination only)"
    )
    ap.add_argument("--fast", type=Path, default=None, help="measure the card's pipeline and --fast on a report's views")
    args = ap.parse_args()
    if args.fast is not None:
        measure_fast(args.model, args.fast)
        return 0
    if args.apply is not None:
        net, meta = load_model(find_model(args.model))
        rep = json.loads(args.apply.read_text())
        chosen = Pipeline.from_info({**meta.get("info", {}), "pipeline": rep["chosen"]}, net.cfg.priors, net.cfg.head)
        write_card(find_model(args.model), chosen)
        print(f"{args.model}: {list(chosen.stages)} from {args.apply}")
        return 0
    rechoose = args.rechoose is not None
    old = json.loads(args.rechoose.read_text()) if rechoose else None
    if rechoose:
        args.num, args.seed = old["num"], old["seed"]
    chosen, record = choose(
        args.model,
        args.num,
        args.seed,
        {k: v for k, v in old.items() if k not in ("format", "model", "num", "seed")} if rechoose else None,
    )
    path = find_model(args.model)
    name = Path(args.model).stem if not Path(args.model).is_dir() else Path(args.model).name
    report = Path(args.report or args.rechoose or ROOT / "docs" / "reports" / f"{name}_val_pipeline.json")
    report.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(
        report, {"format": "ucope-pipeline-choice/1", "model": args.model, "num": args.num, "seed": args.seed, **record}
    )
    if not args.no_write:
        write_card(path, chosen)
    print(f"{args.model}: {list(chosen.stages)} search {chosen.search.to_dict()} -> {report}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
