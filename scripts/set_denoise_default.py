"""Measure the surface noise a model saw in training and write its smoothing threshold into its JSON.

    python scripts/set_denoise_default.py --model src/ucope/pretrained/mug.json --data DATA/mug_val
    python scripts/set_denoise_default.py --model src/ucope/pretrained/laptop.json --off

The ``clean_cloud`` stage smooths a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`) is
above its ``noise_above_m``, which a model card stores in ``info.pipeline.params``. This script measures the surface
noise of ``--num`` views of ``DATA`` (views of the model's category made by ``ucope generate``, with the depth
sensor's noise: the validation split), as the stage measures it (the same preparation, clouds of at least
``smooth_min_points`` points), and sets the threshold to ``--margin`` times its 99th percentile: a cloud is
smoothed only when it is noisier than nearly every view the model was trained on. ``--off`` removes the value
(the stage's default applies where the model lists it). The JSON is rewritten atomically;
``info.denoise_measured_on`` records the data, the views and the percentiles.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.data.dataset import load_dataset  # noqa: E402
from ucope.estimation.inputs import prepare_points  # noqa: E402
from ucope.fileio import atomic_write_json, read_json  # noqa: E402
from ucope.geometry.denoise import surface_noise  # noqa: E402
from ucope.stages.cloud import CleanCloudParams  # noqa: E402

MIN_POINTS = CleanCloudParams().smooth_min_points
KEY = "clean_cloud.noise_above_m"


def measure(data: str, num: int, max_points: int = 4096) -> np.ndarray:
    """Surface noise (metres) of up to ``num`` evenly spaced views of ``data`` with enough points."""
    ds = load_dataset(data)
    rows = np.unique(np.linspace(0, len(ds) - 1, min(num, len(ds))).astype(int))
    out = []
    for i in rows:
        pts = prepare_points(ds[int(i)]["points"], None, max_points, 0, estimate=False).points
        if len(pts) >= MIN_POINTS:
            out.append(surface_noise(pts))
    return np.asarray(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="the model's JSON file")
    ap.add_argument("--data", help="views of the model's category with sensor noise (its validation split)")
    ap.add_argument("--num", type=int, default=200, help="at most this many views, evenly spaced (default 200)")
    ap.add_argument("--margin", type=float, default=1.1, help="threshold = margin x the 99th percentile (default 1.1)")
    ap.add_argument("--off", action="store_true", help="remove the model's smoothing default")
    args = ap.parse_args(argv)
    meta = read_json(args.model)
    info = meta.setdefault("info", {})
    params = info.setdefault("pipeline", {"stages": None}).setdefault("params", {})
    if args.off:
        params.pop(KEY, None)
        info.pop("denoise_measured_on", None)
        atomic_write_json(args.model, meta)
        print(f"{args.model}: smoothing off by default")
        return 0
    if not args.data:
        ap.error("--data is required (unless --off)")
    ds_cat = load_dataset(args.data).meta.get("category")
    if ds_cat != meta["config"]["priors"]["category"]:
        model_cat = meta["config"]["priors"]["category"]
        print(f"error: {args.data} holds {ds_cat!r} views, the model is a {model_cat!r} model", file=sys.stderr)
        return 2
    noise = measure(args.data, args.num)
    if len(noise) < 20:
        print(f"error: only {len(noise)} views of {args.data} have {MIN_POINTS} points or more", file=sys.stderr)
        return 2
    p50, p99 = np.percentile(noise, [50, 99])
    params[KEY] = round(float(args.margin * p99), 6)
    info["denoise_measured_on"] = {
        "data": str(args.data),
        "num_views": int(len(noise)),
        "surface_noise_p50_m": round(float(p50), 6),
        "surface_noise_p99_m": round(float(p99), 6),
        "margin": args.margin,
    }
    atomic_write_json(args.model, meta)
    print(
        f"{args.model}: smooth above {1e3 * params[KEY]:.2f} mm "
        f"(views like the training ones: median {1e3 * p50:.2f} mm, 99th percentile {1e3 * p99:.2f} mm, {len(noise)} views)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
