"""Does running a view's hypotheses through the network as one batch pay? One batch of ``n`` against ``n`` batches of one.

    python benchmarks/bench_batching.py                          # every shipped model, 3 hypotheses, 10 views
    python benchmarks/bench_batching.py --model drawer mug --hypotheses 3 4 --threads 2

A view's search makes up to one estimate per size and per restart (``ucope.estimation.search``); each runs the
network (point encoder, joint heads, pair encoder on ``vote_parts.num_pairs`` pairs) on its own draw of the
cloud's points. This benchmark times exactly that network work both ways on unseen test views of each model's
category (seed 2027): the ``n`` hypotheses of a view (draws ``0 .. n-1`` of ``num_points`` points, their normals,
farthest-point samples and pairs, all prepared outside the clock) one at a time, and stacked as one batch. It
reports, per model and ``n``, the median over views of both (ms) and their ratio (sequential / batched: above 1,
batching pays). Both arms run alternately in one process, so the ratio compares within one run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np
import torch

import ucope
from ucope.data.generate import GenerateConfig, make_sample
from ucope.estimation import Estimator
from ucope.estimation.inputs import NORMAL_K
from ucope.fileio import atomic_write_text
from ucope.geometry.normals import estimate_normals
from ucope.geometry.sampling import random_subset
from ucope.model.checkpoint import list_pretrained
from ucope.model.pointnet2 import numpy_fps_indices
from ucope.objects.categories import CATEGORY_NAMES
from ucope.vocab import VOTE_HEADS


def hypotheses(est: Estimator, points: np.ndarray, n: int) -> list[tuple[torch.Tensor, ...]]:
    """The network inputs of ``n`` draws of ``points`` ``(N, 3)``: ``(P, normals, fps, pair_idx)``, batch size 1 each,
    pairs drawn as the estimator draws them (its segmentation of the draw decides each part's pool)."""
    cfg, out = est.cfg, []
    for draw in range(n):
        rng = np.random.default_rng(np.random.SeedSequence(entropy=0, spawn_key=(2, draw)))
        sub = random_subset(len(points), cfg.num_points, rng)
        p = points[sub]
        P = torch.from_numpy(p)[None]
        N = torch.from_numpy(estimate_normals(points, k=NORMAL_K, rows=sub))[None]
        fps = [torch.from_numpy(f)[None] for f in numpy_fps_indices(p, cfg.encoder.npoints)]
        with torch.no_grad():
            enc = est.model.encode(P, N, fps)
        labels = enc["seg_logits"][0].argmax(-1).numpy() if "seg_logits" in enc else np.zeros(len(p), np.int64)
        out.append((P, N, fps, torch.from_numpy(est._sample_pairs(labels, rng))[None]))
    return out


def network(est: Estimator, P, N, fps, pair_idx) -> dict[str, torch.Tensor]:
    """The network work of one pass of :meth:`ucope.estimation.Estimator.predict` on a batch: its outputs."""
    model = est.model
    out = model.encode(P, N, fps)
    if est.cfg.num_joints > 0:
        out |= model.joint_heads(out)
    return out | model.pair_heads(out, P, N, pair_idx, heads=VOTE_HEADS, return_hidden=True)


def stack(hyps: list[tuple]) -> tuple:
    """One batch of the hypotheses ``hyps`` (each of batch size 1)."""
    P, N, fps, idx = zip(*hyps, strict=True)
    return torch.cat(P), torch.cat(N), [torch.cat(level) for level in zip(*fps, strict=True)], torch.cat(idx)


def bench(model: str, views: int, n: int) -> dict:
    est = Estimator.load(model)
    gen = GenerateConfig(category=est.category, split="test", seed=2027, num=views, views_per_instance=1)
    seq, bat = [], []
    with torch.no_grad():
        for i in range(views):
            hyps = hypotheses(est, make_sample(gen, i)["points"].astype(np.float32), n)
            batch = stack(hyps)
            network(est, *batch)  # warm-up of this batch shape
            t0 = time.perf_counter()
            for h in hyps:
                network(est, *h)
            t1 = time.perf_counter()
            network(est, *batch)
            t2 = time.perf_counter()
            seq.append(1e3 * (t1 - t0))
            bat.append(1e3 * (t2 - t1))
    s, b = statistics.median(seq), statistics.median(bat)
    return {"model": model, "hypotheses": n, "views": views, "sequential_ms": s, "batched_ms": b, "ratio": s / b}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", nargs="+", default=None, help="shipped model names (default: every built-in one)")
    ap.add_argument("--hypotheses", type=int, nargs="+", default=[3], help="hypotheses per view (default 3)")
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_batching.json"))
    args = ap.parse_args()
    if min(args.hypotheses) < 1 or args.views < 1:
        raise SystemExit("--hypotheses and --views must be positive")
    torch.set_num_threads(args.threads)
    results = []
    for m in args.model or [m for m in list_pretrained() if m in CATEGORY_NAMES]:
        for n in args.hypotheses:
            r = bench(m, args.views, n)
            results.append(r)
            print(
                f"{m:12s} {n} hypotheses: one at a time {r['sequential_ms']:6.1f} ms, one batch {r['batched_ms']:6.1f} ms "
                f"(ratio {r['ratio']:.2f})",
                flush=True,
            )
    meta = {"ucope_version": ucope.__version__, "threads": args.threads, "torch": torch.__version__}
    meta |= {"platform": platform.platform(), "cpu_count": os.cpu_count(), "results": results}
    atomic_write_text(args.out, json.dumps(meta, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
