"""Fit each model's score calibration on validation views, clean and corrupted, and store it in the model.

    python scripts/calibrate_scores.py --models laptop mug          # shipped models (src/ucope/pretrained)
    python scripts/calibrate_scores.py --models runs/laptop --num 400

For every model: ``--num`` unseen views of the category's ``val`` split (one per instance, the default
sensor noise, their background pools), each left clean with chance 1/4 or else corrupted by one kind of
:data:`ucope.data.corrupt.KINDS` at one of its benchmark levels (drawn from ``--seed``); the model's raw
estimate of each; the per-part features of :mod:`ucope.stages.confidence` and whether the part
succeeded (< 10 degrees and < 10 % of its box diagonal; the y axis alone for parts symmetric about y and
for a mug whose handle the corrupted cloud hides, judged as the robustness benchmark judges it). A
:class:`~ucope.stages.confidence.Calibration` is fitted on them, its threshold set where the object
score separates successful from failed views best (Youden's J), and written into the model JSON's
``info.calibration`` with the fitting figures (views, success rate, AUROC on the fitting views).
The test-split AUROC comes from the robustness benchmark.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))

from ucope.data.augment import sample_context  # noqa: E402
from ucope.data.corrupt import KINDS, corrupt  # noqa: E402
from ucope.data.generate import config_of_model, make_sample  # noqa: E402
from ucope.estimation import Estimator  # noqa: E402
from ucope.eval.evaluate import mug_handle_kept  # noqa: E402
from ucope.eval.metrics import part_errors  # noqa: E402
from ucope.fileio import atomic_write_json, read_json  # noqa: E402
from ucope.model.checkpoint import find_model, load_model  # noqa: E402
from ucope.stages.confidence import SUCCESS_ROT_DEG, SUCCESS_TRANS_REL, Calibration, auroc  # noqa: E402

NEEDS_BACKGROUND = ("floor", "bleed")
"""Kinds that add points from the view's background pool; a view without one (nothing but the object
rendered around it) is not given them."""


def view_spec(rng: np.random.Generator, has_background: bool = True) -> str:
    """``""`` (clean) with chance 1/4, else one corruption kind at one of its non-clean benchmark levels
    (not :data:`NEEDS_BACKGROUND` where the view has no background pool)."""
    if rng.random() < 0.25:
        return ""
    names = sorted(k for k in KINDS if k != "shuffle" and (has_background or k not in NEEDS_BACKGROUND))
    kind = KINDS[names[int(rng.integers(len(names)))]]
    levels = [lv for lv in kind.levels if lv != kind.identity]
    return f"{kind.name}={levels[int(rng.integers(len(levels)))]:g}"


def part_success(result, sample: dict, src: np.ndarray) -> np.ndarray:
    """``(K,)`` bool: every part < 10 degrees and < 10 % of its box diagonal (see the module docstring).

    ``src`` ``(M,)``: for each point of the corrupted cloud, the clean point it came from (``-1``: added).
    A mug's handle is judged as the robustness benchmark judges it (:func:`ucope.eval.evaluate.mug_handle_kept`).
    """
    out = []
    handle = sample["category"] != "mug" or mug_handle_kept(sample, src)
    for k, p in enumerate(result.parts):
        sym = p.symmetry if handle else "y"
        e = part_errors(p.cam_from_part, p.size_m, sample["cam_from_part"][k], sample["size_m"][k], sym)
        diag = float(np.linalg.norm(sample["size_m"][k]))
        out.append(e["rotation_deg"] < SUCCESS_ROT_DEG and e["translation_m"] < SUCCESS_TRANS_REL * diag)
    return np.array(out, dtype=bool)


def calibrate(model: str, num: int, seed: int, pairs: int) -> dict:
    loaded = Estimator.load(model, overrides={"vote_parts.num_pairs": pairs})
    est = Estimator(loaded.model, dataclasses.replace(loaded.pipeline, calibration=None))  # raw scores: no search
    cat = est.category
    info = load_model(find_model(model))[1].get("info")
    cfg = config_of_model(cat, info, split="val", num=num, seed=seed, views_per_instance=1)
    feats, succ, part_idx, obj_rows = [], [], [], []
    t0 = time.perf_counter()
    for i in range(num):
        s = make_sample(cfg, i)
        rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(zlib.crc32(cat.encode()), i)))
        ctx = sample_context(s)
        spec = view_spec(rng, ctx.background is not None)
        pts, lab = s["points"], np.asarray(s["part_labels"])
        src = np.where(lab >= 0, np.arange(len(lab)), -1)  # provenance: the corruption carries it as labels
        if spec:
            pts, src = corrupt(pts, src, spec, rng, ctx)
        r = est.predict(pts)
        ok = part_success(r, s, src)
        obj_rows.append((len(feats), len(r.parts), bool(ok.all())))
        feats.extend(r.features)
        succ.extend(ok)
        part_idx.extend(range(len(r.parts)))
    F, y, k = np.asarray(feats), np.asarray(succ, float), np.asarray(part_idx)
    cal = Calibration.fit(F, y, k, est.cfg.num_parts, l2=1.0)
    # scores of the fitting views: per part, and per object (the smallest part score)
    part_scores = np.concatenate([cal.part_scores(F[a : a + n]) for a, n, _ in obj_rows])
    obj_scores = np.array([part_scores[a : a + n].min() for a, n, _ in obj_rows])
    obj_ok = np.array([o for *_, o in obj_rows], dtype=bool)
    cand = np.unique(obj_scores)
    j = [
        (np.mean(obj_scores[obj_ok] >= t) - np.mean(obj_scores[~obj_ok] >= t)) if obj_ok.any() and (~obj_ok).any() else 0.0
        for t in cand
    ]
    threshold = float(cand[int(np.argmax(j))]) if len(cand) else 0.5
    info = {
        "split": "val",
        "seed": seed,
        "views": num,
        "pairs": pairs,
        "clean_fraction": 0.25,
        "kinds": sorted(KINDS),
        "object_success_rate": float(obj_ok.mean()),
        "part_success_rate": float(y.mean()),
        "auroc_object_fit": auroc(obj_scores, obj_ok),
        "auroc_part_fit": auroc(part_scores, y.astype(bool)),
        "auroc_object_vote_score": auroc(np.array([F[a : a + n, 0].min() for a, n, _ in obj_rows]), obj_ok),
        "seconds": round(time.perf_counter() - t0, 1),
    }
    return dataclasses.replace(cal, threshold=threshold, info=info).to_dict()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", required=True, help="shipped model names, run folders or model JSONs")
    ap.add_argument("--num", type=int, default=300, help="validation views per model (default 300)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    for m in args.models:
        path = find_model(m)
        cal = calibrate(m, args.num, args.seed, args.pairs)
        meta = read_json(path)
        meta.setdefault("info", {})["calibration"] = cal
        atomic_write_json(path, meta)
        i = cal["info"]

        def auc(v):  # None when every view succeeded or every view failed
            return "n/a" if v is None else f"{v:.3f}"

        print(
            f"{m}: {i['views']} views, object success {i['object_success_rate']:.2f}, AUROC object {auc(i['auroc_object_fit'])} "
            f"(vote score alone {auc(i['auroc_object_vote_score'])}), threshold {cal['threshold']:.3f}, {i['seconds']:.0f} s -> "
            f"{path}"
        )
        print(json.dumps({k: cal[k] for k in ("coef", "part_bias", "threshold")}))


if __name__ == "__main__":
    main()
