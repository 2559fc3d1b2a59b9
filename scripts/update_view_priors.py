"""Measure a model's view priors on training views and write them into its JSON.

    python scripts/update_view_priors.py --model src/ucope/pretrained/laptop.json --data DATA [--num 2000]
    python scripts/update_view_priors.py --model ... --data DATA --extent-only
    python scripts/update_view_priors.py --model ... --data DATA --stacks-only
    python scripts/update_view_priors.py --model ... --data DATA --slides-only

``ucope train`` measures these priors (``PartPrior.upright_*`` and ``seen_extent``,
``JointPrior.pivot_in_parent`` / ``pivot_in_child``; with ``--radius`` also ``radius_typical_m``:
:func:`ucope.priors.measure_priors`) with all the others. This script adds them to a model trained before
they existed, leaving every other prior, the weights and the model card alone, so that its predictions
change only where :func:`ucope.stages.upright.carry_upright` re-places a part (or, with the seen extents,
where ``fit_extents`` / ``anchor_faces`` are on). ``--extent-only`` writes the seen extents, faced gaps and
child size ratios alone and records them in ``info.seen_extent_from``; ``--stacks-only`` writes the stacks of
prismatic children alone (``CategoryPriors.stacks``, :func:`ucope.priors.stack_statistics`: the drawers of a
chest) and records them in ``info.stacks_from``; without either flag the stacks are written with the rest.
``--slides-only`` writes how far each prismatic child slides for its size alone
(``JointPrior.max_state_over_extent``, :func:`ucope.priors.max_state_over_extent`) and records them in
``info.slides_from``.
``DATA`` is a data set of the model's category made by ``ucope generate`` (training split). The JSON is
rewritten atomically; ``info.view_priors_from`` records the data set and how many views were used.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.data.dataset import load_dataset  # noqa: E402
from ucope.fileio import atomic_write_json, read_json  # noqa: E402
from ucope.priors import CategoryPriors, max_state_over_extent, measure_priors, stack_statistics  # noqa: E402

PART_FIELDS = ("upright_axis", "upright_in_cam", "upright_cone_deg", "seen_extent", "faced_gap")
JOINT_FIELDS = ("pivot_in_parent", "pivot_in_child", "child_size_ratio", "child_size_spread", "max_state_over_extent")
EXTENT_JOINT_FIELDS = ("child_size_ratio", "child_size_spread")


def _picked_views(ds, num: int) -> tuple[list, np.ndarray, np.ndarray]:
    """Up to ``num`` evenly spaced views of ``ds``, their true part poses ``(V, K, 4, 4)`` and box extents ``(V, K, 3)``."""
    picked = [ds[int(i)] for i in np.unique(np.linspace(0, len(ds) - 1, min(len(ds), num)).round().astype(np.int64))]
    T = np.stack([np.asarray(s["cam_from_part"], np.float64) for s in picked])
    S = np.stack([np.asarray(s["size_m"], np.float64) for s in picked])
    return picked, T, S


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="the model's JSON file")
    ap.add_argument("--data", required=True, help="training views of the model's category (ucope generate)")
    ap.add_argument("--num", type=int, default=2000, help="at most this many views, evenly spaced")
    ap.add_argument("--radius", action="store_true", help="also the typical cloud radii (radius_typical_m, for rescaling)")
    ap.add_argument(
        "--extent-only",
        action="store_true",
        help="write only the seen-extent and faced-gap tables and the child size ratios (PartPrior.seen_extent, "
        "faced_gap, JointPrior.child_size_ratio / child_size_spread)",
    )
    ap.add_argument(
        "--stacks-only",
        action="store_true",
        help="write only the stacks of prismatic children (CategoryPriors.stacks: drawers one above the other)",
    )
    ap.add_argument(
        "--slides-only",
        action="store_true",
        help="write only how far prismatic children slide for their size (JointPrior.max_state_over_extent)",
    )
    args = ap.parse_args(argv)
    if args.extent_only + args.stacks_only + args.slides_only > 1:
        print("error: --extent-only, --stacks-only and --slides-only exclude each other", file=sys.stderr)
        return 2
    meta = read_json(args.model)
    pri = meta["config"]["priors"]
    ds = load_dataset(args.data)
    if ds.meta.get("category") != pri["category"]:
        have = ds.meta.get("category")
        print(f"error: {args.data} holds {have!r} views, the model is a {pri['category']!r} model", file=sys.stderr)
        return 2
    made = {k: ds.meta.get(k) for k in ("split", "seed", "num", "generator_version")}  # how to make the views again
    if args.slides_only:
        picked, T, S = _picked_views(ds, args.num)
        J = len(pri["joints"])
        U = np.stack([np.asarray(s["joint_axis"], np.float64).reshape(J, 3) for s in picked])
        Q = np.stack([np.asarray(s["joint_state"], np.float64).reshape(J) for s in picked])
        for j, jd in enumerate(pri["joints"]):
            ratio = None
            if jd["type"] == "prismatic":
                ratio = max_state_over_extent(T[:, jd["child"]], S[:, jd["child"]], U[:, j], Q[:, j])
            jd["max_state_over_extent"] = ratio
            print(f"joint {jd['parent']}->{jd['child']} ({jd['type']}): max state over extent {ratio}")
        CategoryPriors.from_dict(pri)  # refuse to write priors that do not load
        meta.setdefault("info", {})["slides_from"] = {"data": Path(args.data).name, **made, "num_samples": len(picked)}
        atomic_write_json(args.model, meta)
        return 0
    if args.stacks_only:
        picked, T, S = _picked_views(ds, args.num)
        pri["stacks"] = [st.to_dict() for st in stack_statistics(T, S, CategoryPriors.from_dict(pri).joints)]
        meta.setdefault("info", {})["stacks_from"] = {"data": Path(args.data).name, **made, "num_samples": len(picked)}
        atomic_write_json(args.model, meta)
        for st in pri["stacks"]:
            print(
                f"stack {st['children']} in part {st['parent']} along {'xyz'[st['axis']]}: gap under its face "
                f"{st['first_gap']:.3f}, between children {st['gap']:.3f} (of the parent's extent)"
            )
        if not pri["stacks"]:
            print("no stacks")
        return 0
    new = measure_priors(ds, pri["category"], ds.meta["structure"], max_samples=args.num, template_samples=1).to_dict()
    part_fields = ("seen_extent", "faced_gap") if args.extent_only else PART_FIELDS
    for old, fresh in zip(pri["parts"], new["parts"], strict=True):
        old.update({k: fresh[k] for k in part_fields})
    for old, fresh in zip(pri["joints"], new["joints"], strict=True):
        old.update({k: fresh[k] for k in (EXTENT_JOINT_FIELDS if args.extent_only else JOINT_FIELDS)})
    if args.radius:
        pri["radius_typical_m"] = new["radius_typical_m"]
    if not args.extent_only:
        pri["stacks"] = new["stacks"]
    key = "seen_extent_from" if args.extent_only else "view_priors_from"
    meta.setdefault("info", {})[key] = {"data": Path(args.data).name, **made, "num_samples": new["num_samples"]}
    atomic_write_json(args.model, meta)
    for p in pri["parts"]:
        cells = sum(row[0] is not None for ax in p["seen_extent"] for row in ax)
        print(f"{p['name']}: seen extents measured in {cells} of {3 * len(p['seen_extent'][0])} axis patterns")
        if args.extent_only:
            continue
        if p["upright_axis"] is None:
            print(f"{p['name']}: no upright axis")
        else:
            print(f"{p['name']}: axis {'xyz'[p['upright_axis']]} upright, cone {p['upright_cone_deg']:.1f} deg")
    for j in pri["joints"]:
        if j["pivot_in_parent"] is not None:
            print(f"joint {j['parent']}->{j['child']}: pivot in parent {[round(v, 3) for v in j['pivot_in_parent']]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
