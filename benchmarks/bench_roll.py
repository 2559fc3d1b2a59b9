"""Camera roll: the shipped models on views from a camera turned about its optical axis.

    python benchmarks/bench_roll.py                                    # laptop, scissors, drawer, camera, mug; 40 views
    python benchmarks/bench_roll.py --models laptop --num 10 --out /tmp/r.json
    python benchmarks/bench_roll.py --models camera --model-dir runs/candidates   # <category>.json models of a folder

The models were trained on upright cameras (3 degrees of roll). For every model, ``--num`` unseen test views
of its category (generator defaults, one view per instance, seed ``--seed``) are rolled by each angle of
``--rolls`` (:func:`ucope.data.sample.roll_sample`: the same view, the camera turned about its optical axis)
and estimated five ways: without the ``upright`` stage (``carried_views`` counts the views where it acted), with
the defaults, with the world's up direction given (``predict(points, up=...)``, the object's y axis, which the
generators stand upright: what an IMU would report), which turns the cloud back to an upright camera first, and,
with rendered floor points next to the object added to the cloud (half as many as the object's: :func:`with_floor`),
with the defaults and with the roll read from that support plane (``search.roll_from_plane``). A view succeeds
when every part is within 10 degrees and 10 % of its ground-truth box diagonal
(:func:`ucope.eval.evaluate.sample_errors`).

Writes ``benchmarks/results_roll.json`` (docs/results.md points to it).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import torch

from ucope.data.augment import sample_context
from ucope.data.corrupt import add_floor
from ucope.data.generate import GenerateConfig, make_sample
from ucope.data.sample import roll_sample
from ucope.estimation import Estimator
from ucope.eval.evaluate import sample_errors, view_success

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_scale import write_results  # noqa: E402

MODELS = ("laptop", "scissors", "drawer", "camera", "mug")
ROLLS_DEG = (0.0, 20.0, 45.0, 90.0, 180.0)
SETTINGS = ("no_carry", "default", "up_given", "floor_default", "floor_plane")


def with_floor(sample: dict, rng: np.random.Generator, share: float = 0.5) -> np.ndarray:
    """The sample's points and rendered floor points next to it, ``share`` times as many as the object's: the floor
    pixels of its background pool nearest its silhouette (:func:`ucope.data.corrupt.add_floor`, the robustness
    benchmark's and the training augmentation's floor), so only floor the camera sees, with the sensor's noise."""
    points, _ = add_floor(sample["points"], sample["part_labels"], share, rng, sample_context(sample))
    return points.astype(np.float32)


def view_record(est: Estimator, sample: dict, up, points=None) -> dict:
    """One estimate of ``sample`` (or of ``points``: its points with floor points after them) scored against it."""
    res = est.predict(sample["points"] if points is None else points, up=up)
    n = len(sample["points"])  # the object's points come first: the floor's have no ground-truth label
    err = sample_errors(dataclasses.replace(res, part_labels=res.part_labels[:n]), sample)["parts"]
    return {
        "rot_deg": [e["rotation_deg"] for e in err],
        "success": bool(view_success(err)),
        "carried": any("placed from its neighbour" in w or "turned over" in w for w in res.warnings),
    }


def summarize(records: list[dict]) -> dict:
    rot = np.array([r["rot_deg"] for r in records], np.float64)
    return {
        "views": len(records),
        "success": float(np.mean([r["success"] for r in records])),
        "mean_rot_deg": rot.mean(axis=0).tolist(),
        "carried_views": int(sum(r["carried"] for r in records)),
    }


def run_model(name: str, num: int, seed: int, rolls, pairs: int, model_dir: Path | None = None) -> dict:
    src = str(model_dir / f"{name}.json") if model_dir else name
    ests = {
        "no_carry": Estimator.load(src, drop=["upright"], overrides={"vote_parts.num_pairs": pairs}),
        "default": Estimator.load(src, overrides={"vote_parts.num_pairs": pairs}),
        "up_given": Estimator.load(src, overrides={"vote_parts.num_pairs": pairs}),
        "floor_default": Estimator.load(src, overrides={"vote_parts.num_pairs": pairs}),
        "floor_plane": Estimator.load(src, overrides={"vote_parts.num_pairs": pairs, "search.roll_from_plane": True}),
    }
    cat = ests["default"].category
    gen = GenerateConfig(category=cat, split="test", num=num, seed=seed, views_per_instance=1)
    samples = [make_sample(gen, i) for i in range(num)]
    out = {"category": cat, "rolls": {}}
    for deg in rolls:
        rolled = [roll_sample(s, np.radians(deg)) for s in samples]
        row = {}
        floors = [with_floor(s, np.random.default_rng([seed, i])) for i, s in enumerate(rolled)]
        for key, est in ests.items():
            recs = [
                view_record(
                    est,
                    s,
                    np.asarray(s["cam_from_object"])[:3, 1] if key == "up_given" else None,
                    floors[i] if key.startswith("floor") else None,
                )
                for i, s in enumerate(rolled)
            ]
            row[key] = summarize(recs)
        out["rolls"][f"{deg:g}"] = row
        cells = " / ".join(f"{100 * row[k]['success']:.0f}" for k in SETTINGS)
        print(f"{name} roll {deg:g}: success {cells} % ({', '.join(SETTINGS)})", flush=True)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=list(MODELS))
    ap.add_argument("--num", type=int, default=40, help="test views per model")
    ap.add_argument("--seed", type=int, default=11, help="seed of the test views")
    ap.add_argument("--model-dir", type=Path, default=None, help="folder of <category>.json models (default: the shipped ones)")
    ap.add_argument("--rolls", type=float, nargs="+", default=list(ROLLS_DEG), help="camera roll angles, degrees")
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results_roll.json")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    t0 = time.perf_counter()
    models = {m: run_model(m, args.num, args.seed, args.rolls, args.pairs, args.model_dir) for m in args.models}
    settings = {"num": args.num, "seed": args.seed, "rolls_deg": args.rolls, "pairs": args.pairs}
    write_results(args.out, "ucope-roll/2", settings, models, t0, args.threads)


if __name__ == "__main__":
    sys.exit(main())
