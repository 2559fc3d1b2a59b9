"""Plot the training and validation curves of one or more runs from their ``metrics.jsonl``.

    python scripts/plot_training.py RUN [RUN ...] --out curves.png [--keys loss mu alpha ...]

One panel per key; training values (thin) and validation values (markers) against the step.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

DEFAULT_KEYS = ("loss", "pose", "mu_err_m", "alpha_err_deg", "seg_acc", "axis_err_deg", "pivot_err_m")


def read_metrics(run: Path) -> list[dict]:
    path = run / "metrics.jsonl"
    if not path.is_file():
        raise SystemExit(f"{path}: no such file")
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--keys", nargs="+", default=list(DEFAULT_KEYS))
    args = ap.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = {r: read_metrics(r) for r in args.runs}
    keys = [k for k in args.keys if any(f"train/{k}" in row or f"val/{k}" in row for rows in runs.values() for row in rows)]
    if not keys:
        raise SystemExit("none of the keys appear in the metrics")
    cols = min(3, len(keys))
    rows_n = (len(keys) + cols - 1) // cols
    fig, axes = plt.subplots(rows_n, cols, figsize=(4.2 * cols, 3.2 * rows_n), squeeze=False)
    for ax, key in zip(axes.ravel(), keys, strict=False):
        for i, (run, rows) in enumerate(runs.items()):
            color = f"C{i}"
            tr = [(r["step"], r[f"train/{key}"]) for r in rows if f"train/{key}" in r]
            va = [(r["step"], r[f"val/{key}"]) for r in rows if f"val/{key}" in r]
            if tr:
                ax.plot(*zip(*tr, strict=False), color=color, alpha=0.35, lw=0.8, label=f"{run.name} train")
            if va:
                ax.plot(*zip(*va, strict=False), color=color, marker="o", ms=3, lw=1.5, label=f"{run.name} val")
        ax.set_title(key)
        ax.set_xlabel("step")
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(keys) :]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
