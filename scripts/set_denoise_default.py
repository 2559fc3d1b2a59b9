"""Measure the surface noise a model saw in training and write its smoothing threshold into its JSON.

    python scripts/set_denoise_default.py --model src/ucope/pretrained/mug.json --data DATA/mug_val
    python scripts/set_denoise_default.py --model src/ucope/pretrained/laptop.json --off

The estimator smooths a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`) is above
``Estimator.denoise_above_m``; :meth:`ucope.estimation.Estimator.load` takes it from the model's
``info.defaults.denoise_above_m``. This script measures the surface noise of ``--num`` views of ``DATA``
(views of the model's category made by ``ucope generate``, with the depth sensor's noise: the validation
split), as the estimator measures it (the same preparation, clouds of at least
:data:`ucope.estimation.estimator.DENOISE_MIN_POINTS` points), and sets the threshold to ``--margin``
times its 99th percentile: a cloud is smoothed only when it is noisier than nearly every view the model
was trained on. ``--off`` removes the default. The JSON is rewritten atomically;
``info.denoise_measured_on`` records the data, the views and the percentiles. docs/robustness.md has the
measured effect and the categories where it is on.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from ucope.data.dataset import load_dataset  # noqa: E402
from ucope.estimation.estimator import DENOISE_MIN_POINTS  # noqa: E402
from ucope.estimation.inputs import prepare_points  # noqa: E402
from ucope.fileio import atomic_write_json, read_json  # noqa: E402
from ucope.geometry.denoise import surface_noise  # noqa: E402


def measure(data: str, num: int, max_points: int = 4096) -> np.ndarray:
    """Surface noise (metres) of up to ``num`` evenly spaced views of ``data`` with enough points."""
    ds = load_dataset(data)
    rows = np.unique(np.linspace(0, len(ds) - 1, min(num, len(ds))).astype(int))
    out = []
    for i in rows:
        pts = prepare_points(ds[int(i)]["points"], None, max_points, 0, estimate=False).points
        if len(pts) >= DENOISE_MIN_POINTS:
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
    defaults = info.setdefault("defaults", {})
    if args.off:
        defaults.pop("denoise_above_m", None)
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
        print(f"error: only {len(noise)} views of {args.data} have {DENOISE_MIN_POINTS} points or more", file=sys.stderr)
        return 2
    p50, p99 = np.percentile(noise, [50, 99])
    defaults["denoise_above_m"] = round(float(args.margin * p99), 6)
    info["denoise_measured_on"] = {
        "data": str(args.data),
        "num_views": int(len(noise)),
        "surface_noise_p50_m": round(float(p50), 6),
        "surface_noise_p99_m": round(float(p99), 6),
        "margin": args.margin,
    }
    atomic_write_json(args.model, meta)
    print(
        f"{args.model}: smooth above {1e3 * defaults['denoise_above_m']:.2f} mm "
        f"(views like the training ones: median {1e3 * p50:.2f} mm, 99th percentile {1e3 * p99:.2f} mm, {len(noise)} views)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
