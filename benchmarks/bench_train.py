"""Training step time (batch 8) of the slim and full networks: built-in categories, and categories of your
own objects with K = 2, 4 and 8 parts; forward latency for one object; a profile of the K = 8 step.

    python benchmarks/bench_train.py [--threads 2] [--steps 10] [--what all|builtin|parts] [--parts 2,4,8]
                                     [--sizes slim,full] [--profile] [--out benchmarks/results_train.json]

Targets on 2 CPU cores (issue 3): a training step at batch 8 at most 0.7 s (slim) and 1.4 s (full).
The step is what ``ucope train`` does per batch (forward, loss, backward, Adam), on real generated samples:
laptop (K = 2) and mug (K = 1), and (``--what parts``) spec categories of K parts read from serial URDF
chains the script writes into a temporary folder (a base and K - 1 links, revolute joints about
alternating axes, like a robot arm: docs/own_objects.md). Each row splits the step into forward + loss,
backward and the optimiser step, and gives samples per second. Preparing the batch's items (point subset,
FPS indices, pairs: ``TrainingItems``) is timed separately (``items_s_median``): with ``--workers 0`` (the
default) it adds to the step, with data-loader workers it runs beside it. ``--profile`` runs the K = 8
slim step under ``torch.profiler`` and ``cProfile`` and stores the top entries.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import platform
import pstats
import statistics
import tempfile
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
RECIPE_STEPS = 8000
"""The steps of the 8,000-step batch-8 recipe (``scripts/make_own_category.sh``'s robot arm), for the wall times."""


def chain_urdf(k: int) -> str:
    """A z-up serial chain of ``k`` links (base + ``k - 1``): boxes standing on z, joints about z and y in turn."""
    links, joints = [], []
    for i in range(k):
        h, w = 0.12 + 0.02 * i, 0.1 - 0.006 * i
        links.append(
            f'<link name="link{i}"><visual><origin xyz="0.01 0 {h / 2}"/><geometry><box size="{w} {w * 0.8} {h}"/></geometry>'
            "</visual></link>"
        )
        if i:
            axis = "0 0 1" if i % 2 else "0 1 0"
            joints.append(
                f'<joint name="joint{i}" type="revolute"><parent link="link{i - 1}"/><child link="link{i}"/>'
                f'<origin xyz="0 0 {0.12 + 0.02 * (i - 1)}"/><axis xyz="{axis}"/>'
                '<limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>'
            )
    return f'<?xml version="1.0"?><robot name="chain{k}">{"".join(links)}{"".join(joints)}</robot>'


def chain_spec(folder: Path, k: int) -> dict:
    """The spec of :func:`chain_urdf` ``k`` written into ``folder``: one part per link, every joint a category joint."""
    (folder / f"chain{k}.urdf").write_text(chain_urdf(k))
    return {
        "ucope_category_spec": 1,
        "name": f"bench_chain{k}",
        "parts": [{"name": f"link{i}", "links": [f"link{i}"]} for i in range(k)],
        "joints": [{"joint": f"joint{i}", "range": [-1.0, 1.0] if i % 2 else [-0.8, 1.2]} for i in range(1, k)],
        "instances": [{"file": f"chain{k}.urdf"}],
        "size_range_m": [0.1, 3.0],
        "camera": {"distance_range_m": [0.8 + 0.15 * k, 1.2 + 0.2 * k], "elevation_range_deg": [10, 50]},
        "base_dir": str(folder),
    }


# ------------------------------------------------------------------ the step before the batching
def _before_two_hot_kl(logits, x, lo, hi):
    """The pose loss's bin term before: the two-hot target materialised, then ``kl_div`` over every bin."""
    import torch.nn.functional as F

    from ucope.model.targets import two_hot

    return F.kl_div(logits.log_softmax(-1), two_hot(x, lo, hi, logits.shape[-1]), reduction="none").sum(-1)


def _before_pair_heads(self, enc, points, normals, pair_idx, heads=None, return_hidden=False):
    """The pair encoder before: every point weighted by every part's mask (``(B, K, N, H)`` twice), then the
    pairs' rows gathered, for any number of pairs."""
    from ucope.model.targets import pair_features

    K, H = self.cfg.num_parts, self.cfg.hidden
    B, N = points.shape[:2]
    M = pair_idx.shape[2]
    f1, masks = enc["feats"], enc["masks"]
    proj = self.pair_point(f1)
    mk = masks.permute(0, 2, 1).unsqueeze(-1)
    W = self.pair_geo.weight
    part_const = (W[:, 4:].T + self.pair_geo.bias).view(1, K, 1, H)
    pa = (mk * proj[:, None, :, :H] + part_const).reshape(B * K * N, H)
    pb = (mk * proj[:, None, :, H:]).reshape(B * K * N, H)
    offs = (torch.arange(B * K, device=points.device) * N).view(B, K, 1)
    ia = (pair_idx[..., 0] + offs).reshape(-1)
    ib = (pair_idx[..., 1] + offs).reshape(-1)
    flat = pair_idx.reshape(B, K * M * 2)
    bidx = torch.arange(B, device=points.device)[:, None]
    pts = points[bidx, flat].reshape(B, K, M, 2, 3)
    nrm = normals[bidx, flat].reshape(B, K, M, 2, 3)
    geo = pair_features(pts[..., 0, :], pts[..., 1, :], nrm[..., 0, :], nrm[..., 1, :], self.norm_scale)
    h = pa.index_select(0, ia)
    h += pb.index_select(0, ib)
    h.addmm_(geo.reshape(-1, 4), W[:, :4].T)
    h = self.pair_mlp(h.view(B, K, M, H))
    out = self.pair_outputs(h, heads)
    if return_hidden:
        out["pair_hidden"] = h
    return out


class _Before:
    """Within this context the network computes the training step as it did before the batching."""

    def __enter__(self):
        import ucope.model.network as network

        self.saved = network.two_hot_kl, network.UCOPENet.pair_heads
        network.two_hot_kl, network.UCOPENet.pair_heads = _before_two_hot_kl, _before_pair_heads

    def __exit__(self, *exc):
        import ucope.model.network as network

        network.two_hot_kl, network.UCOPENet.pair_heads = self.saved


def _timed_step(net, opt, batch) -> tuple[float, float, float]:
    """Forward + loss, backward, optimiser: seconds of each."""
    t0 = time.perf_counter()
    loss, _ = net.compute_loss(batch)
    t1 = time.perf_counter()
    opt.zero_grad(set_to_none=True)
    loss.backward()
    t2 = time.perf_counter()
    opt.step()
    return t1 - t0, t2 - t1, time.perf_counter() - t2


def bench(
    category: str, size: str, steps: int, samples: list[dict], profile: bool = False, before: bool = False, warmup: int = 2
) -> dict:
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
    fwd, bwd, opt_t, times, before_t = [], [], [], [], []
    for i in range(steps + warmup):  # warm-up steps first; with ``before``, a step of each kind in turn
        if before:
            with _Before():
                b = _timed_step(net, opt, batch)
            if i >= warmup:
                before_t.append(b)
        f, bw, o = _timed_step(net, opt, batch)
        if i >= warmup:
            fwd.append(f)
            bwd.append(bw)
            opt_t.append(o)
            times.append(f + bw + o)
    net.eval()
    one = collate_items([items[0]])
    lat = []
    with torch.no_grad():
        for i in range(steps + warmup):
            t0 = time.perf_counter()
            net(one["points"], one["normals"], None, one["fps_idx"])
            if i >= warmup:
                lat.append(time.perf_counter() - t0)
    step = statistics.median(times)
    row = {
        "category": category,
        "num_parts": cfg.num_parts,
        "size": size,
        "num_points": cfg.num_points,
        "pairs_per_part": cfg.pairs_per_part,
        "parameters": sum(p.numel() for p in net.parameters()),
        "steps_timed": len(times),
        "step_s_median": step,
        "step_s_min": min(times),
        "forward_loss_s_median": statistics.median(fwd),
        "backward_s_median": statistics.median(bwd),
        "optimiser_s_median": statistics.median(opt_t),
        "samples_per_s": 8 / step,
        "items_s_median": statistics.median(prep),
        "recipe_8000_steps_h": RECIPE_STEPS * step / 3600,
        "forward_1_ms_median": 1000 * statistics.median(lat),
        "target_step_s": TARGET_S[size],
        "meets_target": step <= TARGET_S[size],
    }
    if before:
        b_step = statistics.median(sum(t) for t in before_t)
        row.update(
            before_step_s_median=b_step,
            before_forward_loss_s_median=statistics.median(t[0] for t in before_t),
            before_backward_s_median=statistics.median(t[1] for t in before_t),
            speedup_vs_before=b_step / step,
        )
    if profile:
        row["profile"] = profile_step(net, batch, opt)
    return row


def profile_step(net, batch: dict, opt) -> dict:
    """The top entries of one training step under ``torch.profiler`` (operators by self CPU time) and
    ``cProfile`` (Python functions by cumulative time), after a warm-up."""
    from torch.profiler import ProfilerActivity, profile

    net.train()

    def step():
        loss, _ = net.compute_loss(batch)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    step()
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(2):
            step()
    ops = sorted(prof.key_averages(), key=lambda e: e.self_cpu_time_total, reverse=True)
    total = sum(e.self_cpu_time_total for e in ops) or 1.0
    top_ops = [
        {"op": e.key, "calls": e.count, "self_cpu_ms": e.self_cpu_time_total / 1000 / 2, "share": e.self_cpu_time_total / total}
        for e in ops[:15]
    ]
    pr = cProfile.Profile()
    pr.enable()
    step()
    pr.disable()
    buf = io.StringIO()
    pstats.Stats(pr, stream=buf).sort_stats("cumulative").print_stats(25)
    return {"torch_ops_per_step": top_ops, "cprofile_cumulative": buf.getvalue().splitlines()[:60]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--what", choices=("all", "builtin", "parts"), default="all")
    ap.add_argument("--parts", default="2,4,8", help="part counts K of the spec categories (--what parts)")
    ap.add_argument("--sizes", default="slim,full")
    ap.add_argument("--profile", action="store_true", help="profile the largest-K slim step")
    ap.add_argument("--before", action="store_true", help="also time the step as computed before the batching, in turn")
    ap.add_argument("--warmup", type=int, default=2, help="untimed steps first")
    ap.add_argument("--note", default="", help="a line stored with the results (e.g. what else the machine ran)")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_train.json"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    sizes = [s for s in args.sizes.split(",") if s]
    old = json.loads(args.out.read_text()) if args.out.is_file() else {}
    result = {
        "threads": args.threads,
        "torch": torch.__version__,
        "platform": platform.platform(),
        "processor": platform.processor(),
        "results": old.get("results", []),
        "parts": old.get("parts", []),
    }
    t_start = time.perf_counter()

    def report(r):
        before = ""
        if "speedup_vs_before" in r:
            before = f"; before the batching {r['before_step_s_median']:.3f} s (x{r['speedup_vs_before']:.2f})"
        print(
            f"{r['category']:13s} K={r['num_parts']} {r['size']:4s} ({r['num_points']} pts, "
            f"{r['parameters'] / 1e6:.2f} M params): step (batch 8) {r['step_s_median']:.3f} s = forward+loss "
            f"{r['forward_loss_s_median']:.3f} + backward {r['backward_s_median']:.3f} + Adam {r['optimiser_s_median']:.3f}; "
            f"{r['samples_per_s']:.1f} samples/s; items {r['items_s_median']:.3f} s; forward (1 object) "
            f"{r['forward_1_ms_median']:.1f} ms{before}",
            flush=True,
        )

    if args.what in ("all", "builtin"):
        rows = []
        for category in ("laptop", "mug"):
            gen = GenerateConfig(category=category, split="train", num=16, views_per_instance=2)
            samples = [make_sample(gen, i) for i in range(16)]
            for size in sizes:
                rows.append(bench(category, size, args.steps, samples, warmup=args.warmup))
                report(rows[-1])
        result["results"] = rows
    if args.what in ("all", "parts"):
        from ucope.objects.spec import register_spec

        ks = [int(k) for k in args.parts.split(",")]
        rows = []
        with tempfile.TemporaryDirectory(prefix="ucope_bench_") as tmp:
            for k in ks:
                own = register_spec(chain_spec(Path(tmp), k), quiet=True)
                gen = GenerateConfig(category=own.name, spec=own.doc, split="train", num=16, views_per_instance=2)
                samples = [make_sample(gen, i) for i in range(16)]
                for size in sizes:
                    prof = args.profile and k == max(ks) and size == "slim"
                    rows.append(bench(own.name, size, args.steps, samples, profile=prof, before=args.before, warmup=args.warmup))
                    report(rows[-1])
        for r in rows:
            r.update(measured=time.strftime("%Y-%m-%d %H:%M"), note=args.note)
        new = {(r["num_parts"], r["size"]) for r in rows}  # rows of other sizes or K from an earlier run are kept
        rows = [r for r in result["parts"] if (r["num_parts"], r["size"]) not in new] + rows
        rows.sort(key=lambda r: (r["size"] != "slim", r["num_parts"]))
        for size in {r["size"] for r in rows}:  # per-sample cost against K: the ratio to the smallest K's, beside K's own
            same = [r for r in rows if r["size"] == size]
            base = min(same, key=lambda r: r["num_parts"])
            for r in same:
                r["step_ratio_to_smallest_k"] = r["step_s_median"] / base["step_s_median"]
                r["k_ratio_to_smallest_k"] = r["num_parts"] / base["num_parts"]
        result["parts"] = rows
    result["note"] = args.note
    result["wall_s"] = round(time.perf_counter() - t_start, 1)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out} ({result['wall_s']} s)")


if __name__ == "__main__":
    main()
