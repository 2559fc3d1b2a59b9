"""Training step time (batch 8) of the slim and full networks, and forward latency for one object.

    python benchmarks/bench_train.py [--threads 2] [--steps 10] [--out benchmarks/results_train.json]

Targets on 2 CPU cores (issue 3): a training step at batch 8 at most 0.7 s (slim) and 1.4 s (full).
The step is what ``ucope train`` does per batch (forward, loss, backward, Adam), on real generated
laptop (K = 2) and mug (K = 1) samples. Preparing the batch's items (point subset, FPS indices, pairs:
``TrainingItems``) is timed separately (``items_s_median``): with ``--workers 0`` (the default) it adds to
the step, with data-loader workers it runs beside it.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import torch

from ucope.data.generate import GenerateConfig, make_sample
from ucope.model.batch import TrainingItems, collate_items
from ucope.model.config import ModelConfig
from ucope.model.factory import build_model
from ucope.objects.categories import make_instance
from ucope.priors import measure_priors

TARGET_S = {"slim": 0.7, "full": 1.4}


def bench(category: str, size: str, steps: int, samples: list[dict]) -> dict:
    cfg = ModelConfig.default(measure_priors(samples, category, make_instance(category, "train", 0).structure()), size=size)
    torch.manual_seed(0)
    net = build_model(cfg)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    items = TrainingItems(samples, cfg)
    prep = []
    for _ in range(5):
        t0 = time.perf_counter()
        batch = collate_items([items[i] for i in range(8)])
        prep.append(time.perf_counter() - t0)
    times = []
    for i in range(steps + 2):  # two warm-up steps
        t0 = time.perf_counter()
        loss, _ = net.compute_loss(batch)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        if i >= 2:
            times.append(time.perf_counter() - t0)
    net.eval()
    one = collate_items([items[0]])
    fwd = []
    with torch.no_grad():
        for i in range(steps + 2):
            t0 = time.perf_counter()
            net(one["points"], one["normals"], None, one["fps_idx"])
            if i >= 2:
                fwd.append(time.perf_counter() - t0)
    return {
        "category": category,
        "size": size,
        "num_points": cfg.num_points,
        "parameters": sum(p.numel() for p in net.parameters()),
        "step_s_median": statistics.median(times),
        "step_s_min": min(times),
        "items_s_median": statistics.median(prep),
        "forward_1_ms_median": 1000 * statistics.median(fwd),
        "target_step_s": TARGET_S[size],
        "meets_target": statistics.median(times) <= TARGET_S[size],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_train.json"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rows = []
    for category in ("laptop", "mug"):
        gen = GenerateConfig(category=category, split="train", num=16, views_per_instance=2)
        samples = [make_sample(gen, i) for i in range(16)]
        for size in ("slim", "full"):
            r = bench(category, size, args.steps, samples)
            rows.append(r)
            print(
                f"{category:7s} {size:4s} ({r['num_points']} pts, {r['parameters'] / 1e6:.2f} M params): "
                f"step (batch 8) {r['step_s_median']:.3f} s [target {r['target_step_s']} s] + items {r['items_s_median']:.3f} s, "
                f"forward (1 object) {r['forward_1_ms_median']:.1f} ms",
                flush=True,
            )
    result = {
        "threads": args.threads,
        "torch": torch.__version__,
        "platform": platform.platform(),
        "processor": platform.processor(),
        "results": rows,
    }
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
