"""Scale generalisation: the shipped models on objects smaller and larger than any they were trained on.

    python benchmarks/bench_scale.py                                   # all 11 models, 30 views, both settings
    python benchmarks/bench_scale.py --models mug laptop --num 10 --out /tmp/s.json
    python benchmarks/bench_scale.py --model-dir /path/to/models       # <dir>/<category>.json instead

For every model, ``--num`` unseen test views of its category (generator defaults: sensor noise, one view
per instance, seed ``--seed``) are scaled about the object's centre by each factor of ``--factors``
(:func:`ucope.data.sample.scale_sample`: points, part poses, sizes, pivots and prismatic states; the view's
perspective is kept) and estimated twice: as they are (``rescale=False``) and with the estimator's
rescaling into the training sizes (``search.rescale``, :meth:`ucope.estimation.Estimator.input_scale`) and
the estimator's other defaults (its scale search among them).
A view succeeds when every part is within 10 degrees and 10 % of its ground-truth box diagonal
(:func:`ucope.eval.evaluate.sample_errors`: symmetric parts and a mug with a hidden handle by their y axis).
Reported per model, factor and setting: success fraction, median rotation error (deg, over parts and
views), median size ratio (cube root of predicted / true box volume) and median 3D IoU.

Writes ``benchmarks/results_scale.json`` (docs/results.md points to it).
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

from ucope import __version__
from ucope.data.generate import GenerateConfig, make_sample
from ucope.data.sample import scale_sample
from ucope.estimation import Estimator
from ucope.eval.evaluate import sample_errors
from ucope.fileio import atomic_write_json

MODELS = ("laptop", "eyeglasses", "dishwasher", "scissors", "drawer", "bottle", "bowl", "camera", "can", "laptop_rigid", "mug")
FACTORS = (0.5, 0.7, 1.0, 1.5, 2.0)
ROT_DEG, TRANS_REL = 10.0, 0.10


def view_record(est: Estimator, sample: dict) -> dict:
    """Errors of one view: per part rotation (deg), translation / diagonal, size ratio, IoU; success."""
    res = est.predict(sample["points"])
    err = sample_errors(res, sample)["parts"]
    diag = np.linalg.norm(np.asarray(sample["size_m"], np.float64), axis=1)
    rot = np.array([e["rotation_deg"] for e in err])
    trans = np.array([e["translation_m"] for e in err]) / diag
    vol = np.array([np.prod(p.size_m) for p in res.parts]) / np.prod(np.asarray(sample["size_m"], np.float64), axis=1)
    return {
        "rot_deg": rot.tolist(),
        "trans_rel": trans.tolist(),
        "size_ratio": np.cbrt(vol).tolist(),
        "iou": [e["iou"] for e in err],
        "success": bool(np.all((rot < ROT_DEG) & (trans < TRANS_REL))),
        "rescaled": any("was scaled by" in w for w in res.warnings),
    }


def summarize(records: list[dict]) -> dict:
    cat = {k: np.concatenate([np.asarray(r[k], np.float64) for r in records]) for k in ("rot_deg", "size_ratio", "iou")}
    return {
        "views": len(records),
        "success": float(np.mean([r["success"] for r in records])),
        "median_rot_deg": float(np.median(cat["rot_deg"])),
        "median_size_ratio": float(np.median(cat["size_ratio"])),
        "median_iou": float(np.median(cat["iou"])),
        "rescaled_views": int(sum(r["rescaled"] for r in records)),
    }


def run_model(name: str, num: int, seed: int, factors, pairs: int, model_dir: Path | None) -> dict:
    src = str(model_dir / f"{name}.json") if model_dir else name
    ests = {on: Estimator.load(src, overrides={"vote_parts.num_pairs": pairs, "search.rescale": on}) for on in (False, True)}
    cat = ests[True].category
    gen = GenerateConfig(category=cat, split="test", num=num, seed=seed, views_per_instance=1)
    samples = [make_sample(gen, i) for i in range(num)]
    out = {"category": cat, "radius_range_m": list(ests[True].priors.radius_range_m or []), "factors": {}}
    for f in factors:
        scaled = [scale_sample(s, f) for s in samples]
        out["factors"][f"{f:g}"] = {
            ("rescale" if on else "as_is"): summarize([view_record(est, s) for s in scaled]) for on, est in ests.items()
        }
        row = out["factors"][f"{f:g}"]
        print(
            f"{name} x{f:g}: success {100 * row['as_is']['success']:.0f} -> {100 * row['rescale']['success']:.0f} %, "
            f"size ratio {row['as_is']['median_size_ratio']:.2f} -> {row['rescale']['median_size_ratio']:.2f}",
            flush=True,
        )
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=list(MODELS))
    ap.add_argument("--model-dir", type=Path, default=None, help="folder of <category>.json models (default: the shipped ones)")
    ap.add_argument("--num", type=int, default=30, help="test views per model")
    ap.add_argument("--seed", type=int, default=11, help="seed of the test views")
    ap.add_argument("--factors", type=float, nargs="+", default=list(FACTORS))
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results_scale.json")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    t0 = time.perf_counter()
    models = {m: run_model(m, args.num, args.seed, args.factors, args.pairs, args.model_dir) for m in args.models}
    settings = {"num": args.num, "seed": args.seed, "factors": args.factors, "pairs": args.pairs}
    write_results(args.out, "ucope-scale/1", settings, models, t0, args.threads)


def write_results(out: Path, fmt: str, settings: dict, models: dict, t0: float, threads: int) -> dict:
    """Write a view benchmark's results (``benchmarks/bench_scale.py``, ``bench_roll.py``) atomically:
    format, version, settings, the success rule, per-model results and, per run, its date, models, wall
    time since ``t0`` (``time.perf_counter``) and machine.

    A run of some models merges into an existing file of the same format and settings (its other models
    are kept, so re-measuring a retrained model does not re-run the rest); a file with other settings is
    refused (``SystemExit``) rather than overwritten with a mix."""
    run = {
        "date": datetime.date.today().isoformat(),
        "models": list(models),
        "time_s": time.perf_counter() - t0,
        "hardware": {"platform": platform.platform(), "torch": torch.__version__, "threads": threads},
    }
    merged, runs = dict(models), [run]
    if out.is_file():
        old = json.loads(out.read_text())
        if old.get("format") != fmt or old.get("settings") != json.loads(json.dumps(settings)):
            raise SystemExit(f"{out} holds results of other settings or format; use another --out (or delete it)")
        merged = {**old.get("models", {}), **models}
        runs = old.get("runs", []) + [run]
    res = {
        "format": fmt,
        "ucope": __version__,
        "settings": settings,
        "success": f"every part < {ROT_DEG:g} deg and < {100 * TRANS_REL:g} % of its box diagonal",
        "models": merged,
        "runs": runs,
    }
    atomic_write_json(out, res)
    print(f"wrote {out} ({run['time_s'] / 60:.1f} min)")
    return res


if __name__ == "__main__":
    sys.exit(main())
