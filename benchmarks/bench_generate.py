"""Generation speed: views per second for every category, with 2 worker processes.

Usage: python benchmarks/bench_generate.py [--num 200] [--workers 2] [--categories ...]

Each category generates --num views (320x240, noise, floor and distractors on, as `ucope generate`
does by default) into a temporary folder; the time includes process start-up, instance building,
ray casting, noise, normals and writing the shards. Target: >= 40 views/s on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

from ucope.data.generate import GenerateConfig, generate_dataset
from ucope.objects.categories import CATEGORY_NAMES


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--categories", nargs="+", default=list(CATEGORY_NAMES))
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()
    rows, total_n, total_t = {}, 0, 0.0
    print(f"{'category':<14}{'views':>7}{'seconds':>10}{'views/s':>10}   (workers={args.workers}, cpus={os.cpu_count()})")
    for cat in args.categories:
        with tempfile.TemporaryDirectory() as d:
            cfg = GenerateConfig(category=cat, split="train", num=args.num, shard_size=max(1, args.num // (2 * args.workers)))
            t0 = time.perf_counter()
            generate_dataset(d, cfg, workers=args.workers, progress=False)
            dt = time.perf_counter() - t0
        rows[cat] = {"views": args.num, "seconds": dt, "views_per_s": args.num / dt}
        total_n += args.num
        total_t += dt
        print(f"{cat:<14}{args.num:>7}{dt:>10.2f}{args.num / dt:>10.1f}")
    print(f"{'all':<14}{total_n:>7}{total_t:>10.2f}{total_n / total_t:>10.1f}   target >= 40 views/s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"workers": args.workers, "per_category": rows, "overall_views_per_s": total_n / total_t}, f, indent=2)


if __name__ == "__main__":
    main()
