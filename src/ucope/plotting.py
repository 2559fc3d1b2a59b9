"""Shared matplotlib plumbing for every picture ucope draws (matplotlib is an optional extra).

* :func:`pyplot`: ``matplotlib.pyplot`` on the non-interactive Agg backend, or a clear error;
* :func:`save_figure`: write a figure to a PNG atomically and close it;
* :data:`PART_COLOURS` and :func:`to_plot_axes`: the part colours and the camera-frame -> plot-axes map
  used by every 3D panel (seen roughly from the camera: x right, depth into the picture, up = -y).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .errors import InputError
from .fileio import atomic_write_bytes

__all__ = ["PART_COLOURS", "pyplot", "save_figure", "to_plot_axes"]

PART_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]


def pyplot():
    """``matplotlib.pyplot`` with the Agg backend; :class:`InputError` naming the extra if it is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - depends on the environment
        raise InputError('pictures need matplotlib: pip install "ucope[viz]"') from None
    return plt


def save_figure(fig, out: str | Path, dpi: float | None = None) -> Path:
    """Render ``fig`` to a PNG at ``out`` (folders created, written atomically), close it, return the path."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    pyplot().close(fig)
    atomic_write_bytes(out, buf.getvalue())
    return out


def to_plot_axes(p) -> np.ndarray:
    """Camera frame ``(..., 3)`` (x right, y down, z forward) -> plot axes (x right, z forward as depth, y up)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)
