"""benchmarks/bench_restarts.py's summaries against plain per-view loops over the same recorded draws."""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_restarts import best_of, restart_rule  # noqa: E402


def _draws(seed: int = 3, views: int = 12, draws: int = 4):
    rng = np.random.default_rng(seed)
    return rng.random((views, draws)) < 0.5, rng.random((views, draws))


def test_best_of_k_is_the_highest_scored_draw_over_every_choice():
    ok, score = _draws()
    for k in range(1, 5):
        fractions = []
        for choice in itertools.combinations(range(4), k):
            hits = 0
            for v in range(len(ok)):
                best = max(choice, key=lambda d: score[v, d])
                hits += ok[v, best]
            fractions.append(hits / len(ok))
        assert best_of(ok, score, k) == pytest.approx(np.mean(fractions))
    assert best_of(ok, score, 1) == pytest.approx(ok.mean())


def test_the_restart_rule_matches_the_estimators_loop_on_every_order():
    ok, score = _draws()
    for below, most in ((0.5, 3), (0.8, 4), (1.01, 2)):
        fractions, used = [], []
        for order in itertools.permutations(range(4), most):
            hits = count = 0
            for v in range(len(ok)):  # Estimator.predict: draw on while the best so far is low
                best, n = order[0], 1
                for d in order[1:]:
                    if score[v, best] >= below:
                        break
                    n += 1
                    if score[v, d] > score[v, best]:
                        best = d
                hits += ok[v, best]
                count += n
            fractions.append(hits / len(ok))
            used.append(count / len(ok))
        got = restart_rule(ok, score, below, most)
        assert got == pytest.approx((np.mean(fractions), np.mean(used)))
