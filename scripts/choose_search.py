"""Choose how much a model searches on validation views: the score bars below which it tries other sizes and other
draws, and how many draws, losing none of the views its card's policy gets right.

    python scripts/choose_search.py --model drawer             # measure, choose, write the card's search policy
    python scripts/choose_search.py --model drawer --rechoose  # choose again from the stored table (no measuring)

Each further estimate of the search (:func:`ucope.estimation.search.search`) costs a whole estimate's time, so the
slowest views of a model are those whose first estimate scores below ``scale_below`` (three more sizes) and, with
restarts, below ``restart_below``. Both bars are model settings, chosen here on two sets of validation views: the
views ``scripts/choose_pipeline.py`` chose the model's stages on (its report gives their number and seed: objects at
their training sizes), and as many other validation objects, each built at a size drawn in the ``ood`` split's
range (:data:`ucope.objects.categories.OOD_SCALE_RANGE`): the size search is made for those.

1. every estimate the card's policy could make on a view is made once and stored: each size of the search at the
   first draw, each restart draw at each size (its calibrated object score, its ``seen`` score, and whether every
   part is right);
2. every policy of the grid (each subset of the card's sizes, each bar in :data:`BARS` at or below the card's, fewer
   restarts) is played out on those
   tables by the search itself (:func:`ucope.estimation.search.search` on the stored estimates), so a policy's
   successes and estimates per view are exact, not modelled;
3. of the policies that lose none of the views the card's policy gets right (on either set), the one with the fewest
   estimates per view is taken (ties: more successes, then more sizes and the higher bars). Losing none, rather than
   keeping the count, matters: a model whose estimates depend much on the draw (the drawer) has, among thousands of
   policies, cheap ones that trade a few views for a few others on these views and lose on fresh ones.

The tables and every policy's outcome go into the model's validation report under ``search``, so the choice can be
recomputed (``--rechoose``); the card's ``pipeline.chosen_on`` names the bars taken.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "scripts"))

from choose_pipeline import val_views, view_ok, write_card  # noqa: E402

import ucope.estimation.estimator as estimator_module  # noqa: E402
from ucope.errors import DataError  # noqa: E402
from ucope.estimation import Estimator  # noqa: E402
from ucope.estimation.pipeline import Pipeline  # noqa: E402
from ucope.estimation.search import SearchPolicy, search  # noqa: E402
from ucope.fileio import atomic_write_json, read_json  # noqa: E402
from ucope.model.checkpoint import find_model, load_model  # noqa: E402
from ucope.objects.categories import OOD_SCALE_RANGE  # noqa: E402

BARS = (0.95, 0.9, 0.85, 0.8, 0.75, 0.7, 0.65, 0.6, 0.55, 0.5, 0.4, 0.3, 0.2, 0.0)
"""The bars tried for ``scale_below`` and ``restart_below`` (each at or below the card's own)."""


def hypotheses(policy: SearchPolicy) -> list[tuple[float | None, int]]:
    """Every ``(normalise, draw)`` estimate ``policy`` can make on one view: the first, each size at draw 0, each
    restart draw at each size."""
    sizes = [None, *policy.scale_factors]
    first = [(None, 0)] + [(f, 0) for f in policy.scale_factors]
    return first + [(n, d) for d in range(1, policy.restarts + 1) for n in sizes]


def forced_estimate(est: Estimator, view: dict, normalise, draw: int) -> tuple[float, float, bool]:
    """The object score, the ``seen`` score and the success of the one estimate ``(normalise, draw)`` of ``view``:
    :meth:`Estimator.predict` with its search replaced by that estimate alone."""
    made = {}

    def one(policy, estimate, calibrated):
        e = estimate(normalise=normalise, draw=draw)
        made["score"], made["seen"] = float(e.final.score), float(e.final.seen_score)
        return e, dict(e.timings), 1

    saved = estimator_module.search
    estimator_module.search = one
    try:
        r = est.predict(view["points"], view.get("normals"))
    finally:
        estimator_module.search = saved
    return made["score"], made["seen"], view_ok(r, view)


def measure_table(est: Estimator, views: list[dict]) -> dict:
    """Every estimate of :func:`hypotheses` on every view (see the module docstring, step 1)."""
    hyps = hypotheses(est.pipeline.search)
    score, seen, ok = (np.zeros((len(views), len(hyps))) for _ in range(3))
    for i, view in enumerate(views):
        for j, (n, d) in enumerate(hyps):
            score[i, j], seen[i, j], ok[i, j] = forced_estimate(est, view, n, d)
    return {
        "hypotheses": [[n, d] for n, d in hyps],
        "score": np.round(score, 6).tolist(),
        "seen": np.round(seen, 6).tolist(),
        "ok": ok.astype(int).tolist(),
    }


def play(policy: SearchPolicy, table: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per view of ``table``, whether ``policy``'s search ends on a right estimate and how many estimates it makes:
    :func:`ucope.estimation.search.search` itself on the stored estimates."""
    index = {(None if n is None else float(n), int(d)): j for j, (n, d) in enumerate(table["hypotheses"])}
    ok, made = [], []
    for score, seen, right in zip(table["score"], table["seen"], table["ok"], strict=True):

        def estimate(normalise, draw, score=score, seen=seen, right=right):
            j = index[(None if normalise is None else float(normalise), int(draw))]
            final = SimpleNamespace(score=score[j], seen_score=seen[j])
            return SimpleNamespace(final=final, timings={"estimates": 1.0}, normalise=normalise, right=right[j])

        best, _, count = search(policy, estimate, calibrated=True)
        ok.append(bool(best.right))
        made.append(count)
    return np.array(ok), np.array(made)


def _outcome(policy: SearchPolicy, tables: dict[str, dict]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """:func:`play` of ``policy`` on every table."""
    return {name: play(policy, table) for name, table in tables.items()}


def choose(card: SearchPolicy, tables: dict[str, dict]) -> tuple[SearchPolicy, dict]:
    """The cheapest policy of the grid that loses no view ``card`` gets right on any table of ``tables`` (module
    docstring, steps 2 and 3), and a summary: the card's and the chosen policy's outcomes, the policies tried."""
    base = _outcome(card, tables)
    scale_bars = [b for b in BARS if b <= card.scale_below] if card.scale_factors else [card.scale_below]
    restart_bars = [b for b in BARS if b <= card.restart_below] if card.restarts else [card.restart_below]
    f = card.scale_factors
    sizes = [c for n in range(len(f), 0, -1) for c in itertools.combinations(f, n)] or [()]
    tried, best, best_key = 0, card, None
    for fs, sb, rb, k in itertools.product(sizes, scale_bars, restart_bars, range(card.restarts + 1)):
        policy = dataclasses.replace(card, scale_factors=fs, scale_below=sb, restart_below=rb, restarts=k)
        res = _outcome(policy, tables)
        made = np.concatenate([m for _, m in res.values()])
        success = {name: int(ok.sum()) for name, (ok, _) in res.items()}
        tried += 1
        if any((base[name][0] & ~ok).any() for name, (ok, _) in res.items()):
            continue  # a view the card gets right is lost
        key = (float(made.mean()), -sum(success.values()), -len(fs), -sb, -rb, -k)
        if best_key is None or key < best_key:
            best, best_key = policy, key

    def summary(policy: SearchPolicy) -> dict:
        res = _outcome(policy, tables)
        made = np.concatenate([m for _, m in res.values()])
        out = {"scale_factors": list(policy.scale_factors), "scale_below": policy.scale_below}
        out |= {"restart_below": policy.restart_below, "restarts": policy.restarts}
        return out | {
            "success": {name: int(ok.sum()) for name, (ok, _) in res.items()},
            "estimates": float(made.mean()),
            "p95_estimates": float(np.percentile(made, 95)),
            "gained": {name: np.flatnonzero(ok & ~base[name][0]).tolist() for name, (ok, _) in res.items()},
            "lost": {name: np.flatnonzero(base[name][0] & ~ok).tolist() for name, (ok, _) in res.items()},
        }

    return best, {"card": summary(card), "chosen": summary(best), "policies_tried": tried}


def sizes_seed(seed: int) -> int:
    """The seed of the validation objects at other sizes, beside the report's views of seed ``seed``."""
    return seed + 1


def main() -> int:
    try:
        return _main()
    except DataError as e:  # a corrupt report, a model whose validation views cannot be made here
        raise SystemExit(f"choose_search: {e}") from None


def _main() -> int:
    import torch

    torch.set_num_threads(1)  # one process per core when several models are chosen at once
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True, help="a shipped model name or a run folder / model .json")
    ap.add_argument(
        "--report", type=Path, default=None, help="the model's validation report (default docs/reports/MODEL_val_pipeline.json)"
    )
    ap.add_argument("--rechoose", action="store_true", help="choose again from the report's stored table")
    ap.add_argument("--no-write", action="store_true", help="measure and report only; leave the model card alone")
    args = ap.parse_args()
    name = Path(args.model).stem if not Path(args.model).is_dir() else Path(args.model).name
    report = args.report or ROOT / "docs" / "reports" / f"{name}_val_pipeline.json"
    if not report.is_file():
        raise SystemExit(f"{report}: no validation report (run scripts/choose_pipeline.py --model {args.model} first)")
    rep = read_json(report, "validation report")
    net, meta = load_model(find_model(args.model))
    pipe = Pipeline.from_info(meta.get("info"), net.cfg.priors, net.cfg.head)
    if pipe.calibration is None:
        raise SystemExit(f"{args.model}: no calibration, so no search to choose")
    stored = rep.get("search", {})
    card = pipe.search
    if args.rechoose and "measured_with" in stored:  # the policy the table was measured with, not the one it chose
        mw = stored["measured_with"]
        card = dataclasses.replace(card, **(mw | {"scale_factors": tuple(mw["scale_factors"])}))
    if card.restarts == 0 and len(card.scale_factors) == 0:
        raise SystemExit(f"{args.model}: its search makes one estimate; nothing to choose")
    if args.rechoose:
        if "tables" not in stored:
            raise SystemExit(f"{report}: no stored tables (run without --rechoose first)")
        tables = stored["tables"]
    else:
        t0 = time.perf_counter()
        est = Estimator(net, pipe)
        cat, num, seed, info = net.cfg.category, rep["num"], rep["seed"], meta.get("info")
        tables = {
            "val": measure_table(est, val_views(cat, num, seed, info)),
            "val_sizes": measure_table(est, val_views(cat, num, sizes_seed(seed), info, scale_range=OOD_SCALE_RANGE)),
        }
        hyps = len(tables["val"]["hypotheses"])
        print(f"{args.model}: {hyps} estimates x {num} + {num} views in {time.perf_counter() - t0:.0f} s", flush=True)
    chosen, summary = choose(card, tables)
    keys = ("scale_factors", "scale_below", "restart_below", "restarts")
    measured_with = {k: list(v) if k == "scale_factors" else v for k, v in card.to_dict().items() if k in keys}
    rep["search"] = {"measured_with": measured_with, "sizes_seed": sizes_seed(rep["seed"]), **summary, "tables": tables}
    atomic_write_json(report, rep)
    a, c = summary["card"], summary["chosen"]
    what = f"sizes {c['scale_factors']} below {c['scale_below']}, restarts {c['restarts']} below {c['restart_below']}"
    print(
        f"{args.model}: card {a['success']} at {a['estimates']:.2f} estimates a view; chosen {what}: {c['success']} at "
        f"{c['estimates']:.2f} (gained {c['gained']}, lost {c['lost']})",
        flush=True,
    )
    if not args.no_write:
        note = f"; search chosen by scripts/choose_search.py (fewest estimates, no view lost): {what}"
        base = pipe.chosen_on.split("; search")[0]
        policy = {k: tuple(c[k]) if k == "scale_factors" else c[k] for k in keys}
        new = dataclasses.replace(pipe, search=dataclasses.replace(pipe.search, **policy), chosen_on=base + note)
        write_card(find_model(args.model), new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
