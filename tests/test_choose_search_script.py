"""scripts/choose_search.py: the search played out on stored estimates against a plain per-view loop, and the choice
of the cheapest policy that loses none of the card's views against a brute-force search of the grid."""

from __future__ import annotations

import dataclasses
import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from choose_pipeline import val_views, view_ok  # noqa: E402
from choose_search import BARS, choose, hypotheses, measure_table, play  # noqa: E402

from ucope.estimation import Estimator  # noqa: E402
from ucope.estimation.search import SearchPolicy  # noqa: E402

CARD = SearchPolicy(scale_factors=(0.8, 1.0, 1.25), scale_below=0.9, restarts=2, restart_below=0.8)


def _table(policy: SearchPolicy, views: int = 40, seed: int = 5) -> dict:
    hyps = hypotheses(policy)
    rng = np.random.default_rng(seed)
    score = rng.random((views, len(hyps)))
    ok = (rng.random((views, len(hyps))) < score).astype(int)  # a higher score is more often right, as calibrated
    return {"hypotheses": [list(h) for h in hyps], "score": score.tolist(), "seen": score.tolist(), "ok": ok.tolist()}


def _plain(policy: SearchPolicy, table: dict, picks: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The search rule of ucope.estimation.search written out per view (pick "all"); the column of the estimate
    that stands is appended to ``picks``."""
    col = {(n, d): j for j, (n, d) in enumerate(table["hypotheses"])}
    oks, made = [], []
    for score, ok in zip(table["score"], table["ok"], strict=True):
        best, count = (None, 0), 1
        if score[col[best]] < policy.scale_below:
            for f in policy.scale_factors:
                count += 1
                if score[col[(f, 0)]] > score[col[best]]:
                    best = (f, 0)
        for d in range(1, policy.restarts + 1):
            if score[col[best]] >= policy.restart_below:
                break
            count += 1
            if score[col[(best[0], d)]] > score[col[best]]:
                best = (best[0], d)
        oks.append(bool(ok[col[best]]))
        made.append(count)
        if picks is not None:
            picks.append(col[best])
    return np.array(oks), np.array(made)


def test_the_table_holds_every_estimate_the_search_can_ask_for():
    hyps = hypotheses(CARD)
    assert len(hyps) == len(set(hyps)) == 1 + 3 + 2 * 4
    assert hyps[0] == (None, 0)
    assert hypotheses(SearchPolicy(scale_factors=(1.0,))) == [(None, 0), (1.0, 0)]


def test_playing_a_policy_on_the_table_matches_the_rule_written_out():
    table = _table(CARD)
    sizes = ((0.8, 1.0, 1.25), (0.8, 1.25), (1.0,))
    for fs, sb, rb, k in itertools.product(sizes, (0.9, 0.6, 0.0), (0.8, 0.5, 0.0), (0, 1, 2)):
        policy = dataclasses.replace(CARD, scale_factors=fs, scale_below=sb, restart_below=rb, restarts=k)
        ok, made = play(policy, table)
        ok_ref, made_ref = _plain(policy, table)
        np.testing.assert_array_equal(ok, ok_ref)
        np.testing.assert_array_equal(made, made_ref)
    _, made = play(dataclasses.replace(CARD, scale_below=0.0, restarts=0), table)
    assert (made == 1).all()


def test_the_choice_is_the_cheapest_policy_of_the_grid_that_loses_none_of_the_cards_views():
    tables = {"val": _table(CARD, views=60, seed=11), "val_sizes": _table(CARD, views=50, seed=12)}
    chosen, summary = choose(CARD, tables)
    base = {name: _plain(CARD, t) for name, t in tables.items()}
    feasible = []
    subsets = [c for n in (1, 2, 3) for c in itertools.combinations(CARD.scale_factors, n)]
    for fs, sb, rb, k in itertools.product(subsets, BARS, BARS, range(CARD.restarts + 1)):
        if sb > CARD.scale_below or rb > CARD.restart_below:
            continue
        policy = dataclasses.replace(CARD, scale_factors=fs, scale_below=sb, restart_below=rb, restarts=k)
        res = {name: _plain(policy, t) for name, t in tables.items()}
        if not any((base[name][0] & ~res[name][0]).any() for name in tables):  # no view of the card's lost
            made = np.concatenate([res[name][1] for name in tables])
            feasible.append((made.mean(), -sum(int(res[name][0].sum()) for name in tables)))
    c = summary["chosen"]
    assert summary["card"]["success"] == {name: int(ok.sum()) for name, (ok, _) in base.items()}
    assert (c["estimates"], -sum(c["success"].values())) == min(feasible)
    assert c["estimates"] <= summary["card"]["estimates"]
    for name, table in tables.items():
        ok, _ = _plain(chosen, table)
        assert c["success"][name] >= base[name][0].sum()
        assert c["gained"][name] == np.flatnonzero(ok & ~base[name][0]).tolist()
        assert c["lost"][name] == [] == np.flatnonzero(base[name][0] & ~ok).tolist()


def test_the_stored_estimates_played_out_are_what_predict_returns():
    """The table of one shipped model's estimates, played out with its card's policy, picks the estimate that
    ``predict`` (the real search) returns on every view: the same object score and the same success."""
    est = Estimator.load("camera")
    assert len(est.pipeline.search.scale_factors) == 3
    views = val_views("camera", 4, 4242)
    table = measure_table(est, views)
    picks: list[int] = []
    ok, made = _plain(est.pipeline.search, table, picks)
    assert made.max() == 4  # some view searched every size
    for i, view in enumerate(views):
        r = est.predict(view["points"], view.get("normals"))
        assert r.score == pytest.approx(table["score"][i][picks[i]], abs=1e-6)
        assert view_ok(r, view) == ok[i]
