"""Accuracy and speed of the voting alone, on exact synthetic network outputs (no network).

    python benchmarks/bench_voting.py [--trials 20] [--threads 2] [--out benchmarks/results_voting.json]

For random part poses and sizes (0.04-0.4 m, ~1 m from the camera), pairs on the part's box surface get
their exact voting parameters as peaked bin logits (tests/voting/voting_support.py), optionally with a
fraction of outlier pairs carrying random parameters. Reported per setting: centre error (mm and in grid
cells), up / right axis error (degrees), relative size error, and the voting time per part. The axis vote
is compared with CPPF's: the best of a 480-direction sphere (about 9 degrees apart) with no refinement.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "voting"))
from voting_support import angle_deg, random_part, synthetic_heads  # noqa: E402

from ucope.voting import AxisOptions, VotingOptions, vote_axis, vote_part  # noqa: E402

# The synthetic pairs cover every face of the box, not one view's visible side: no thin-part snap.
OPTIONS = VotingOptions(thin_snap_ratio=0.0)

HEADS = ("mu_logits", "nu_logits", "alpha_logits", "beta_logits", "sign_logits", "gamma", "part_score")


def run(pairs: int, outliers: float, trials: int, noise_frac: float, noise_deg: float, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(trials):
        T, size = random_part(rng)
        V = 1.1 * 0.5 * float(np.linalg.norm(size))
        a, b, n, h, V = synthetic_heads(
            rng, T, size, size, pairs, outlier_frac=outliers, V=V, noise=(noise_frac * V, np.radians(noise_deg))
        )
        vote_part(
            a[:64], b[:64], n[:64], *(h[k][:64] for k in HEADS), vote_range_m=V, mean_size_m=size, options=OPTIONS
        )  # warm caches
        t0 = time.perf_counter()
        r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size, options=OPTIONS)
        dt = time.perf_counter() - t0
        R = r.cam_from_part[:3, :3]
        e = torch.nn.functional.normalize(a - b, dim=-1)
        alpha = torch.arccos((e.double() @ torch.tensor(T[:3, 1])).clamp(-1, 1)).float()
        u_cppf, _ = vote_axis(
            e, alpha, options=AxisOptions(method="fibonacci", num_directions=480, refine_iters=0, max_coarse_pairs=pairs)
        )
        u_cppf = u_cppf.double().numpy()
        rows.append(
            {
                "centre_mm": 1000 * float(np.linalg.norm(r.cam_from_part[:3, 3] - T[:3, 3])),
                "centre_cells": float(np.linalg.norm(r.cam_from_part[:3, 3] - T[:3, 3]) / (V / 20)),
                "up_deg": angle_deg(R[:, 1], T[:3, 1]),
                "right_deg": angle_deg(R[:, 0], T[:3, 0]),
                "up_deg_cppf_480": min(angle_deg(u_cppf, T[:3, 1]), angle_deg(-u_cppf, T[:3, 1])),
                "size_rel": float(np.abs(r.size_m / size - 1).max()),
                "ms": 1000 * dt,
            }
        )
    keys = rows[0].keys()
    return {
        "pairs": pairs,
        "outlier_fraction": outliers,
        "noise_fraction_of_V": noise_frac,
        "noise_deg": noise_deg,
        "trials": trials,
        "median": {k: statistics.median(r[k] for r in rows) for k in keys},
        "max": {k: max(r[k] for r in rows) for k in keys},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_voting.json"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    results = []
    settings = [(p, o, 0.0, 0.0) for p in (2500, 10000) for o in (0.0, 0.3)]
    settings += [(p, 0.3, 0.03, 3.0) for p in (2500, 5000, 10000, 20000)]
    for pairs, outliers, nf, nd in settings:
        r = run(pairs, outliers, args.trials, nf, nd)
        results.append(r)
        m, x = r["median"], r["max"]
        print(
            f"{pairs:6d} pairs, {int(100 * outliers):2d}% outliers, noise {nf:.2f} V / {nd:.0f} deg: centre "
            f"{m['centre_mm']:.2f} mm ({m['centre_cells']:.3f} cells, max "
            f"{x['centre_cells']:.3f}), up {m['up_deg']:.3f} deg (max {x['up_deg']:.3f}; CPPF-style 480-direction sphere "
            f"{m['up_deg_cppf_480']:.2f}, max {x['up_deg_cppf_480']:.2f}), right {m['right_deg']:.3f} deg, size "
            f"{100 * m['size_rel']:.2f}%, "
            f"{m['ms']:.1f} ms per part",
            flush=True,
        )
    args.out.write_text(
        json.dumps(
            {"threads": args.threads, "torch": torch.__version__, "platform": platform.platform(), "results": results}, indent=2
        )
        + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
