"""Write docs/pipeline.md from the stage registry, the shipped model cards and their validation choices.

    python scripts/make_pipeline_doc.py            # rewrite docs/pipeline.md
    python scripts/make_pipeline_doc.py --check    # exit 1 if docs/pipeline.md is not what it would write

Every line of the page comes from code or data: each stage's name, kind, module and purpose from
:data:`ucope.stages.REGISTRY`, its parameters from its params dataclass, which shipped models run it from their
cards (``info.pipeline``), and its measured effect on validation views from
``docs/reports/MODEL_val_pipeline.json`` (scripts/choose_pipeline.py): the successes lost (or won) when the stage
is left out of that model's list; the search's bars from the same reports (scripts/choose_search.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.estimation.pipeline import Pipeline  # noqa: E402
from ucope.model.checkpoint import list_pretrained, load_model, pretrained_dir  # noqa: E402
from ucope.stages import REGISTRY  # noqa: E402

PAGE = ROOT / "docs" / "pipeline.md"
ORDER = (
    "clean_cloud", "vote_parts", "regress_parts", "align_faces", "vote_joints", "flips", "upright", "joint_states",
    "revolution_fit", "kinematic_refine", "score", "fit_boxes", "prismatic", "free_space", "turn_children", "seat_parts",
)  # fmt: skip
"""The order stages are listed in: where they stand in the lists (others after them)."""
REPORTS = ROOT / "docs" / "reports"

INTRO = """# The pipeline

What the estimator does with a cloud, stage by stage. This page is written by `scripts/make_pipeline_doc.py` from
the stage registry (`ucope.stages`), the shipped model cards and the validation reports that chose each model's
list (`scripts/choose_pipeline.py`); do not edit it by hand.

A prediction prepares the cloud (checks, units, a given `up`, a canonical subset), then makes one or more
*estimates* (the search policy below). Each estimate is one or two *passes*: the cloud stages, the rescaling into
the model's training sizes, the network on one draw of its points (segmentation, part masks, joint heads, the pair
heads), then the pose stages, in the order of the model's list. `ucope pipeline --model M` prints a model's list;
`--stages`, `--drop-stage` and `--set STAGE.PARAM=VALUE` (or `Estimator(stages=..., overrides=...)`) change it for
one run. Every result records what each stage did (`result.stages`: time and the largest change it made).

Kinds: **paper** (U-COPE's own method), **geometry** (plain geometry of the points), **learned-prior** (statistics
the model measured on its training views, stored in its priors), **calibration** (the model's fitted score).
"""


def _cards() -> dict[str, Pipeline]:
    out = {}
    for name in list_pretrained():
        net, meta = load_model(pretrained_dir() / f"{name}.json")
        out[name] = Pipeline.from_info(meta.get("info"), net.cfg.priors, net.cfg.head)
    return out


def _choices() -> dict[str, dict]:
    out = {}
    for p in sorted(REPORTS.glob("*_val_pipeline.json")):
        out[p.name[: -len("_val_pipeline.json")]] = json.loads(p.read_text())
    return out


def _effect(stage: str, choices: dict[str, dict]) -> str:
    cells = []
    for model, rep in choices.items():
        cand = rep.get(f"drop {stage}")
        if cand is not None:
            cells.append(f"{model} {-cand['delta']:+d}/{rep['num']}")
    return ", ".join(cells) or "-"


def _params(cls) -> str:
    if not dataclasses.is_dataclass(cls) or not dataclasses.fields(cls):
        return "-"
    parts = []
    for f in dataclasses.fields(cls):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        parts.append(f"`{f.name}`" if dataclasses.is_dataclass(default) else f"`{f.name}={json.dumps(default)}`")
    return ", ".join(parts)


def page() -> str:
    cards, choices = _cards(), _choices()
    lines = [INTRO, "## Stages", ""]
    lines.append("| stage | kind | what it does | parameters | shipped models | effect on validation (successes it adds) |")
    lines.append("|---|---|---|---|---|---|")
    for name, st in sorted(REGISTRY.items(), key=lambda kv: ORDER.index(kv[0]) if kv[0] in ORDER else len(ORDER)):
        models = ", ".join(m for m, p in cards.items() if name in p.stages) or "-"
        module = st.module.replace("ucope.", "").replace(".", "/") + ".py"
        lines.append(
            f"| `{name}` ({st.phase}; {module}) | {st.kind} | {st.purpose} | {_params(st.params)} | {models} | "
            f"{_effect(name, choices)} |"
        )
    lines += ["", "## Each model's list", ""]
    lines.append("| model | stages, in order | parameters set by its card | search | chosen on |")
    lines.append("|---|---|---|---|---|")
    for model, p in cards.items():
        params = ", ".join(f"`{k}={json.dumps(v)}`" for k, v in p.params.items()) or "-"
        s = p.search
        sizes = f"sizes {list(s.scale_factors)} below {s.scale_below}" if s.scale_factors else "one size"
        restarts = f"restarts {s.restarts} below {s.restart_below}" if s.restarts else "restarts 0"
        search = f"{sizes}, {restarts}, pick {s.pick}"
        lines.append(f"| {model} | {', '.join(p.stages)} | {params} | {search} | {p.chosen_on or '-'} |")
    lines += [
        "",
        "## The search policy",
        "",
        "`search.*` settings (`ucope.estimation.search.SearchPolicy`): `rescale` (a cloud outside the training sizes",
        "is brought into them for the estimate and the result scaled back), `recrop` (a second pass on the points the",
        "first took as the object, where it left enough out or they need rescaling), `scale_factors` (where the first",
        "estimate's calibrated score is below `scale_below`, one more estimate per factor on the cloud normalised to",
        "that factor of the middle of the training sizes), `restarts` (further estimates from other draws of the",
        "network's points while the best score is below `restart_below`) and `pick` (`all`: the estimate whose lowest",
        "part score is highest stands; `seen`: the lowest over the parts given at least one point).",
        "",
    ]
    return "\n".join(lines + _search(choices) + _fast(choices))


def _succ(outcome: dict) -> str:
    """Successes of a policy on each set of views, ``"a + b"``."""
    return " + ".join(str(v) for v in outcome["success"].values())


def _bars(p: dict) -> str:
    """A search policy of a choice report, in words."""
    return f"sizes {p['scale_factors']} below {p['scale_below']}; restarts {p['restarts']} below {p['restart_below']}"


def _search(choices: dict[str, dict]) -> list[str]:
    """The bars of each card's search against the policy they were chosen from (``choose_search.py``)."""
    rows = [(m, c["search"], c["num"]) for m, c in choices.items() if "search" in c]
    if not rows:
        return []
    out = [
        "The bars `scale_below` and `restart_below` and the number of restarts are chosen by",
        "`scripts/choose_search.py` on the validation views that chose the list and on as many validation objects built",
        "at other sizes (drawn in the `ood` split's range, 0.5-2x): every estimate the search could make on a view is",
        "made once, every policy of a grid of lower bars and fewer restarts is played out on them by the search itself,",
        "and the one with the fewest estimates per view that loses none of the views the policy it started from gets",
        "right is taken. Successes are given as *at training sizes + at other sizes*; the views gained are in the",
        "model's report (`search.chosen`).",
        "",
        "| model | views | from | successes | estimates / view (p95) | chosen | successes | estimates / view (p95) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m, s, n in rows:
        w, a, c = s["measured_with"], s["card"], s["chosen"]
        out.append(
            f"| {m} | {n} + {n} | {_bars(w)} | {_succ(a)} | {a['estimates']:.2f} ({a['p95_estimates']:.0f}) | {_bars(c)} | "
            f"{_succ(c)} | {c['estimates']:.2f} ({c['p95_estimates']:.0f}) |"
        )
    return out + [""]


def _fast(choices: dict[str, dict]) -> list[str]:
    """The fast setting against each card's pipeline on its validation views (``choose_pipeline.py --fast``)."""
    rows = [(m, c["fast"], c["num"]) for m, c in choices.items() if "fast" in c]
    if not rows:
        return []
    out = [
        "## The fast setting",
        "",
        "`--fast` (`ucope.estimation.FAST`) makes one estimate of one pass whatever its score: no second pass, no",
        "other sizes, no restarts. Each model's pipeline and its fast setting on the same validation views, measured",
        "one after the other in one process (one torch thread; mean time per view):",
        "",
        "| model | views | successes | fast: successes | time (ms) | fast: time (ms) | faster |",
        "|---|---|---|---|---|---|---|",
    ]
    for m, f, n in rows:
        d, q = f["default"], f["fast"]
        out.append(f"| {m} | {n} | {d['success']} | {q['success']} | {d['ms']:.0f} | {q['ms']:.0f} | {d['ms'] / q['ms']:.1f}x |")
    return out + [""]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the page is out of date")
    args = ap.parse_args()
    text = page()
    if args.check:
        if not PAGE.is_file() or PAGE.read_text() != text:
            print(f"{PAGE} is out of date: run python scripts/make_pipeline_doc.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(text)
    print(f"wrote {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
