"""Time ``Estimator.predict`` for one object, stage by stage (preprocess, encoder, pair encoder, voting).

    python benchmarks/bench_predict.py [--model NAME_OR_RUN ...] [--pairs 20000] [--threads 2]

Target (issue 4): 50 ms or less per object with 20,000 pairs on 2 CPU cores. Measured on unseen test
views of each model's category, with the views' normals given (as a depth pipeline has them) and, in a
second row, estimated by ucope (kNN PCA) inside the preprocess stage.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
from pathlib import Path

import torch

from ucope.data.generate import GenerateConfig, make_sample
from ucope.estimation import Estimator
from ucope.fileio import atomic_write_text

STAGES = ("preprocess", "encoder", "pair_encoder", "voting", "total")


def bench(model: str, pairs: int, repeats: int, normals: bool, refine: bool | None = None) -> dict:
    est = Estimator.load(model, num_pairs=pairs, refine=refine)  # None: the model's default
    gen = GenerateConfig(category=est.category, split="test", num=repeats, views_per_instance=1)
    samples = [make_sample(gen, i) for i in range(repeats)]
    est.predict(samples[0]["points"], samples[0]["normals"])  # warm-up
    rows = []
    for s in samples:
        r = est.predict(s["points"], s["normals"] if normals else None)
        rows.append(r.timings_ms)
    med = {k: statistics.median(r[k] for r in rows) for k in STAGES}
    return {
        "model": model,
        "category": est.category,
        "num_parts": est.cfg.num_parts,
        "num_points": est.cfg.num_points,
        "pairs": pairs,
        "normals_given": normals,
        "refine": est.refine,
        "restarts": est.restarts,
        "free_space": est.free_space,
        "median_ms": med,
        "max_total_ms": max(r["total"] for r in rows),
        "repeats": repeats,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--model", nargs="+", default=["laptop", "mug"], help="shipped model names or run folders (default laptop mug)"
    )
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_predict.json"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    results = []
    for m in args.model:
        for normals in (True, False):
            r = bench(m, args.pairs, args.repeats, normals)
            results.append(r)
            t = r["median_ms"]
            print(
                f"{r['category']:10s} K={r['num_parts']} pairs={args.pairs} normals {'given    ' if normals else 'estimated'}: "
                + "  ".join(f"{k} {t[k]:6.1f}" for k in STAGES)
                + " ms (median)",
                flush=True,
            )
    atomic_write_text(
        args.out,
        json.dumps(
            {
                "threads": args.threads,
                "torch": torch.__version__,
                "platform": platform.platform(),
                "target_total_ms": 50.0,
                "results": results,
            },
            indent=2,
        )
        + "\n",
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
