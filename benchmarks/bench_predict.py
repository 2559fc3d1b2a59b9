"""Time ``Estimator.predict`` for one object: the whole, the network, and every stage of the model's pipeline.

    python benchmarks/bench_predict.py                                  # every shipped model, 20 views each
    python benchmarks/bench_predict.py --model drawer laptop --repeats 10 --threads 2

Target (issue 52): median <= 100 ms and 95th percentile <= 250 ms per object for every shipped model with its own
pipeline, on 2 CPU cores, 20,000 pairs, normals estimated by ucope. Measured on unseen test views of each model's
category (one per object, seed 2027) in one process, each model with its default pipeline and with the fast
setting (``ucope.estimation.FAST``: one estimate, one pass), so that their ratio compares within one run. Per stage:
the median time over the views of the estimate that stands (``result.stages``); per model, the estimates its search
made per view (mean and most).

``--free-blas`` leaves numpy's and scipy's BLAS threads as they are during ``predict`` (``ucope.threads`` holds them
at one): run it as a separate process beside a plain run to see what the hold saves (threads still spinning from
one arm would slow the other, so the two cannot alternate in one process).

    python benchmarks/bench_predict.py --model bottle mug laptop --out /tmp/held.json
    python benchmarks/bench_predict.py --model bottle mug laptop --free-blas --out /tmp/free.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
from pathlib import Path

import numpy as np
import torch

import ucope
from ucope.data.generate import GenerateConfig, make_sample
from ucope.estimation import FAST, Estimator
from ucope.fileio import atomic_write_text
from ucope.model.checkpoint import list_pretrained
from ucope.objects.categories import CATEGORY_NAMES

TIMINGS = ("preprocess", "encoder", "pair_encoder", "voting", "total")


def bench(model: str, repeats: int, fast: bool) -> dict:
    est = Estimator.load(model, overrides=FAST if fast else None)
    gen = GenerateConfig(category=est.category, split="test", seed=2027, num=repeats, views_per_instance=1)
    samples = [make_sample(gen, i) for i in range(repeats)]
    est.predict(samples[0]["points"])  # warm-up
    rows, stages, estimates = [], {}, []
    for s in samples:
        r = est.predict(s["points"])
        estimates.append(r.estimates)
        rows.append(r.timings_ms)
        for rec in r.stages:
            stages.setdefault(rec["name"], []).append(rec["ms"])
    totals = np.array([r["total"] for r in rows])
    return {
        "model": model,
        "fast": fast,
        "num_parts": est.cfg.num_parts,
        "stages": list(est.pipeline.stages),
        "median_ms": {k: statistics.median(r[k] for r in rows) for k in TIMINGS},
        "p95_total_ms": float(np.percentile(totals, 95)),
        "max_total_ms": float(totals.max()),
        "stage_median_ms": {k: statistics.median(v) for k, v in stages.items()},
        "estimates_mean": float(np.mean(estimates)),
        "estimates_max": int(max(estimates)),
        "repeats": repeats,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--model",
        nargs="+",
        default=None,
        help="shipped model names or run folders (default: every shipped model of a built-in category)",
    )
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_predict.json"))
    ap.add_argument("--free-blas", action="store_true", help="leave the BLAS threads alone during predict (see above)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    if args.free_blas:
        import contextlib

        import ucope.estimation.estimator as estimator_module

        estimator_module.one_blas_thread = contextlib.nullcontext
    results = []
    for m in args.model or [m for m in list_pretrained() if m in CATEGORY_NAMES]:  # the others' views need their files
        pair = [bench(m, args.repeats, fast) for fast in (False, True)]
        results += pair
        d, f = pair
        slow = sorted(d["stage_median_ms"].items(), key=lambda kv: -kv[1])[:3]
        t, tf = d["median_ms"], f["median_ms"]
        print(
            f"{m:12s} median {t['total']:7.1f} ms (p95 {d['p95_total_ms']:7.1f}), fast {tf['total']:6.1f} ms "
            f"({t['total'] / tf['total']:.2f}x); network {t['encoder'] + t['pair_encoder']:.1f} ms; slowest stages: "
            + ", ".join(f"{k} {v:.1f}" for k, v in slow),
            flush=True,
        )
    atomic_write_text(
        args.out,
        json.dumps(
            {
                "ucope_version": ucope.__version__,
                "threads": args.threads,
                "blas_held_at_one_thread": not args.free_blas,
                "torch": torch.__version__,
                "platform": platform.platform(),
                "cpu_count": os.cpu_count(),
                "target_median_ms": 100.0,
                "target_p95_ms": 250.0,
                "results": results,
            },
            indent=2,
        )
        + "\n",
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
