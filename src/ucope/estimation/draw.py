"""Pictures of estimates: points coloured by predicted part, predicted boxes (solid) and joint axes
(black), and, when a data-set sample is given, its ground-truth boxes (dashed) and axes (grey)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import PART_COLOURS, pyplot, save_figure, to_plot_axes
from ..errors import InputError
from ..geometry.boxes import BOX_EDGES, box_corners
from .result import PoseResult

__all__ = ["plot_results", "draw_result"]


def _draw_boxes(ax, cam_from_part, size_m, style: str, lw: float) -> np.ndarray:
    corners = to_plot_axes(box_corners(np.asarray(cam_from_part), np.asarray(size_m)))
    for k, c in enumerate(corners):
        for a, b in BOX_EDGES:
            ax.plot(*zip(c[a], c[b]), style, color=PART_COLOURS[k % len(PART_COLOURS)], lw=lw)
    return corners.reshape(-1, 3)


def _draw_axes(ax, pivots, axes, length: float, colour: str) -> None:
    for piv, u in zip(pivots, axes):
        seg = to_plot_axes(np.stack([piv - length * u, piv + length * u]))
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=colour, lw=2.0)
        ax.scatter(*to_plot_axes(piv), color=colour, s=12)


def draw_result(ax, points: np.ndarray, result: PoseResult, sample: dict | None = None, title: str | None = None, max_points: int = 3000) -> None:
    """Draw one estimate on a matplotlib 3D axis (see the module docstring)."""
    pts = np.asarray(points, dtype=np.float64)
    labels = np.asarray(result.part_labels)
    ok = labels >= 0
    pts, labels = pts[ok], labels[ok]
    if len(pts) > max_points:
        sel = np.linspace(0, len(pts) - 1, max_points).astype(int)
        pts, labels = pts[sel], labels[sel]
    P = to_plot_axes(pts)
    ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=np.array(PART_COLOURS)[labels % len(PART_COLOURS)], s=1.5, depthshade=False)
    allp = [P, _draw_boxes(ax, result.cam_from_part, result.size_m, "-", 1.2)]
    diag = float(np.linalg.norm(np.ptp(pts, axis=0))) if len(pts) else 0.1
    if result.joints:
        piv = [j.pivot_m if j.pivot_m is not None else result.parts[j.child].cam_from_part[:3, 3] for j in result.joints]
        _draw_axes(ax, piv, [j.axis for j in result.joints], 0.35 * diag, "k")
    if sample is not None:
        allp.append(_draw_boxes(ax, sample["cam_from_part"], sample["size_m"], "--", 0.8))
        piv = np.asarray(sample["joint_pivot"]).reshape(-1, 3)
        if len(piv):
            _draw_axes(ax, piv, np.asarray(sample["joint_axis"]).reshape(-1, 3), 0.3 * diag, "0.55")
    allp = np.concatenate(allp)
    centre = 0.5 * (allp.min(0) + allp.max(0))
    r = 0.5 * float(np.max(np.ptp(allp, axis=0)))
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[1] - r, centre[1] + r)
    ax.set_zlim(centre[2] - r, centre[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-75)
    ax.tick_params(labelsize=6)
    if title:
        ax.set_title(title, fontsize=8)


def plot_results(items: list[tuple[np.ndarray, PoseResult, dict | None, str]], out: str | Path, cols: int = 3) -> Path:
    """Draw ``(points, result, sample_or_None, title)`` items side by side into a PNG; returns its path
    (written atomically)."""
    if not items:
        raise InputError("nothing to plot")
    plt = pyplot()
    n = len(items)
    cols = min(cols, n)
    rows = -(-n // cols)
    fig = plt.figure(figsize=(4.2 * cols, 4.0 * rows), dpi=110)
    for i, (pts, res, sample, title) in enumerate(items):
        draw_result(fig.add_subplot(rows, cols, i + 1, projection="3d"), pts, res, sample, title)
    fig.tight_layout()
    return save_figure(fig, out)
