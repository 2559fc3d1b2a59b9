"""Restarts: how much one draw of the network's points decides, and what keeping the best-scored draw buys.

    python benchmarks/bench_restarts.py                                  # the drawer, 100 test views, 5 draws
    python benchmarks/bench_restarts.py --models camera --split ood --num 100 --out /tmp/r.json

For every model, ``--num`` views of its category's ``--split`` (``GenerateConfig(split, num=200, seed=0)``:
the views ``ucope generate --split test --num 200`` writes and docs/results.md evaluates) are each estimated
``--draws`` times with estimator seeds 0, 1, ... (other draws of the network's points and pairs; every other
setting the model's default, restarts off). A view succeeds when every part is within 10 degrees and 10 % of
its ground-truth box diagonal (:func:`ucope.eval.evaluate.view_success`, as ``ucope eval`` counts it).

Reported per model: the success of each draw; the best of ``k`` draws kept by the highest object score (the
mean over every choice of ``k`` draws); the success if any draw succeeds; and the restart rule of
``search.restarts=N`` simulated on the recorded draws (a further draw while the best score so far is below
a threshold, up to ``m`` draws; the highest-scored stands), averaged over every order of the draws, with the
draws it takes per view. Writes ``benchmarks/results_restarts.json``. Each model's restarts and bars are chosen on
validation views by ``scripts/choose_search.py``, never on these.
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

from ucope import __version__
from ucope.data.generate import GenerateConfig, make_sample
from ucope.estimation import Estimator
from ucope.eval.evaluate import sample_errors, view_success
from ucope.fileio import atomic_write_json

THRESHOLDS = (0.5, 0.8, 1.01)
"""Restart thresholds simulated (1.01: always restart)."""


def draws_of(model: str, samples: list[dict], draws: int) -> tuple[np.ndarray, np.ndarray]:
    """``(ok, score)``, both ``(views, draws)``: success and object score of each view's estimate per seed."""
    ok = np.zeros((len(samples), draws), dtype=bool)
    score = np.zeros((len(samples), draws))
    for d in range(draws):
        est = Estimator.load(model, seed=d, overrides={"search.restarts": 0})
        for i, s in enumerate(samples):
            res = est.predict_sample(s)  # its points and normals, as ucope eval
            ok[i, d] = view_success(sample_errors(res, s)["parts"])
            score[i, d] = res.score
    return ok, score


def best_of(ok: np.ndarray, score: np.ndarray, k: int) -> float:
    """Success of the highest-scored of ``k`` draws, the mean over every choice of ``k`` of the draws."""
    rows = np.arange(len(ok))
    fractions = [
        ok[rows, np.asarray(c)[score[:, c].argmax(1)]].mean() for c in map(list, itertools.combinations(range(ok.shape[1]), k))
    ]
    return float(np.mean(fractions))


def restart_rule(ok: np.ndarray, score: np.ndarray, below: float, most: int) -> tuple[float, float]:
    """The rule of ``search.restarts=most - 1`` with ``search.restart_below = below`` on the recorded draws:
    ``(success, draws per view)``, the mean over every order of ``most`` of the draws."""
    n, rows = len(ok), np.arange(len(ok))
    success, used = [], []
    for order in itertools.permutations(range(ok.shape[1]), most):
        s, o = score[:, order], ok[:, order]
        best, count = np.zeros(n, dtype=np.int64), np.ones(n)
        for j in range(1, most):
            go = s[rows, best] < below
            count += go
            best = np.where(go & (s[:, j] > s[rows, best]), j, best)
        success.append(o[rows, best].mean())
        used.append(count.mean())
    return float(np.mean(success)), float(np.mean(used))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["drawer"], help="shipped model names (default: drawer)")
    ap.add_argument("--split", default="test", choices=["test", "ood"])
    ap.add_argument("--num", type=int, default=100, help="views per model (default 100)")
    ap.add_argument("--draws", type=int, default=5, help="estimates per view, seeds 0.. (default 5)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_restarts.json"))
    args = ap.parse_args()
    if args.num < 1 or not 2 <= args.draws <= 6:
        ap.error("--num must be >= 1 and --draws 2 to 6 (the rule is averaged over every order of the draws)")
    torch.set_num_threads(args.threads)
    out = {
        "ucope_version": __version__,
        "date": datetime.date.today().isoformat(),
        "settings": {"split": args.split, "num": args.num, "draws": args.draws, "data_seed": 0},
        "hardware": {"cpu_count": torch.get_num_threads(), "platform": platform.platform(), "torch": torch.__version__},
        "models": {},
    }
    for m in args.models:
        t0 = time.perf_counter()
        category = Estimator.load(m).category
        gen = GenerateConfig(category=category, split=args.split, num=200, seed=0)
        samples = [make_sample(gen, i) for i in range(min(args.num, 200))]
        ok, score = draws_of(m, samples, args.draws)
        rules = {
            f"below {t:g}, at most {k}": dict(zip(("success", "draws_per_view"), restart_rule(ok, score, t, k), strict=True))
            for t in THRESHOLDS
            for k in sorted({3, args.draws})
            if k <= args.draws
        }
        out["models"][m] = {
            "views": len(samples),
            "per_draw": ok.mean(0).tolist(),
            "best_of_k": [best_of(ok, score, k) for k in range(1, args.draws + 1)],
            "any_draw": float(ok.any(1).mean()),
            "restart_rule": rules,
            "time_s": time.perf_counter() - t0,
        }
        r = out["models"][m]
        print(
            f"{m} ({args.split}, {len(samples)} views): per draw {', '.join(f'{100 * x:.0f}' for x in r['per_draw'])} %; "
            f"best-scored of k = 1..{args.draws}: {' / '.join(f'{100 * x:.1f}' for x in r['best_of_k'])} %; "
            f"any draw {100 * r['any_draw']:.0f} %",
            flush=True,
        )
        for name, v in rules.items():
            print(f"  {name}: {100 * v['success']:.1f} %, {v['draws_per_view']:.2f} draws per view", flush=True)
    atomic_write_json(args.out, out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
