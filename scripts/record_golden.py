"""Record the golden results of the shipped models: the estimator's output on fixed generated views.

    python scripts/record_golden.py                       # every shipped model, 50 test + 50 ood views each
    python scripts/record_golden.py --models drawer --num 10

For each model it generates ``--num`` views of the ``test`` and of the ``ood`` split (seed
:data:`tests/golden_support.GOLDEN_SEED`, one view per object), runs ``Estimator.load(model)`` with its
default pipeline, and writes ``tests/golden/MODEL.npz``: every part pose and size, every joint's axis, pivot and
state, the scores and a digest of the per-point labels. ``tests/estimation/test_golden.py`` compares the
estimator against these files; re-record them only when a change of results is intended, and say in the
commit which views changed and why.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402
from golden_support import GOLDEN_DIR, differences, flatten, golden_views, load, predict_views  # noqa: E402

from ucope.model.checkpoint import list_pretrained  # noqa: E402
from ucope.objects.categories import CATEGORY_NAMES  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=None, help="shipped models (default: those of built-in categories)")
    ap.add_argument("--num", type=int, default=50, help="views per split (default 50)")
    ap.add_argument("--out", default=str(GOLDEN_DIR), help="folder of the golden files")
    args = ap.parse_args()
    models = args.models or [m for m in list_pretrained() if m in CATEGORY_NAMES]  # the others' views need their files
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in models:
        t0 = time.perf_counter()
        views = golden_views(name, args.num)
        path = out / f"{name}.npz"
        arrays = flatten(predict_views(name, views))
        if path.is_file():  # say which views change, against the file being replaced
            old = load(name) if out == GOLDEN_DIR else dict(np.load(path))
            rows = np.arange(len(views))
            diff = differences(old, arrays, rows) if len(old["split"]) == len(views) else ["(another number of views)"]
            print(f"{name}: {len(diff)} of {len(views)} views change", *diff, sep="\n  ", flush=True)
        np.savez_compressed(
            path, split=np.array([v[0] for v in views]), index=np.array([v[1] for v in views], np.int64), **arrays
        )
        print(f"{name}: {len(views)} views -> {path} ({time.perf_counter() - t0:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
