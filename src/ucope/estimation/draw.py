"""Pictures of estimates: the image with the estimate drawn over it, and a 3D panel.

A picture has one row per :class:`Scene` (one frame, or one cloud): the depth image, the RGB image
when there is one (both drawn by :func:`draw_overlay`, :mod:`ucope.estimation.draw_image`), a 3D panel
(:func:`draw_result`) and a legend. What a picture shows of each object (part colours, legend text) is
set in :mod:`ucope.estimation.draw_scene`; this module re-exports the public names of both.

Without a depth image (a point cloud given alone) the image panel shows the cloud's own depth, splatted
through the sample's intrinsics or through a virtual camera fitted to the cloud (:func:`fit_camera`).

Frames and units: camera frame (OpenCV: x right, y down, z forward), metres; pixels ``(u, v)`` =
(column, row). The 3D panels use :func:`ucope.plotting.to_plot_axes` (x right, depth into the picture,
up = -y).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.boxes import BOX_EDGES, box_corners
from ..plotting import pyplot, save_figure, to_plot_axes
from .draw_image import _intrinsics, clip_segment, draw_overlay, fit_camera, legend_handles, project, splat_depth
from .draw_scene import (
    AXIS_COLOURS,
    LOW_SCORE,
    PART_PALETTE,
    DrawnObject,
    PoseResult,
    Scene,
    _joint_pivot,
    _joint_segment,
    _low,
    legend_lines,
    part_colours,
    warning_lines,
)

__all__ = [
    "DrawnObject",
    "Scene",
    "plot_scenes",
    "plot_results",
    "draw_result",
    "draw_overlay",
    "render_scenes",
    "fit_camera",
    "splat_depth",
    "project",
    "part_colours",
    "legend_lines",
    "legend_handles",
    "warning_lines",
    "clip_segment",
    "PART_PALETTE",
    "AXIS_COLOURS",
    "LOW_SCORE",
]


# --------------------------------------------------------------------------------------------------
# 3D panel
# --------------------------------------------------------------------------------------------------


def _draw_boxes3d(ax, cam_from_part, size_m, colours, style: str, lw: float, faded=None) -> np.ndarray:
    """Draw boxes on a 3D axis; those flagged in ``faded`` dotted and half transparent."""
    corners = to_plot_axes(box_corners(np.asarray(cam_from_part).reshape(-1, 4, 4), np.asarray(size_m).reshape(-1, 3)))
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    faded = [False] * len(corners) if faded is None else list(faded)
    for c, colour, f in zip(corners, colours, faded, strict=False):
        ax.add_collection3d(
            Line3DCollection(
                c[BOX_EDGES], colors=colour, linewidths=lw, linestyles=(0, (1, 1.6)) if f else style, alpha=0.55 if f else 1.0
            )
        )
    return corners.reshape(-1, 3)


def draw_result(
    ax,
    points,
    result: PoseResult,
    sample: dict | None = None,
    title: str | None = None,
    max_points: int = 3000,
    colours: Sequence[str] | None = None,
    errors: dict | None = None,
    legend: bool = True,
    truth: bool = False,
) -> np.ndarray:
    """Draw one estimate on a matplotlib 3D axis: its points coloured by predicted part, its boxes
    (solid; dotted and faded below :data:`LOW_SCORE` unless ``truth``; ground truth dashed), part triads
    (x red, y green, z blue) and joint axes (black; ground truth grey). Returns the ``(M, 3)`` plot-axes
    points drawn (to frame the panel). ``points`` may be ``None`` (boxes only)."""
    drawn = DrawnObject(result, truth=truth)
    cols = list(colours) if colours is not None else [PART_PALETTE[k % len(PART_PALETTE)] for k in range(len(result.parts))]
    allp = []
    if points is not None:
        pts = np.asarray(points, dtype=np.float64)
        labels = np.asarray(result.part_labels)
        if len(labels) == len(pts):
            ok = labels >= 0
            pts, labels = pts[ok], labels[ok]
        else:  # labels of another cloud: colour everything as part 0
            labels = np.zeros(len(pts), np.int64)
        if len(pts) > max_points:
            sel = np.linspace(0, len(pts) - 1, max_points).astype(int)
            pts, labels = pts[sel], labels[sel]
        P = to_plot_axes(pts)
        ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=np.array(cols)[np.clip(labels, 0, len(cols) - 1)], s=1.5, depthshade=False)
        allp.append(P)
    faded = [_low(drawn, k) for k in range(len(result.parts))]
    allp.append(_draw_boxes3d(ax, result.cam_from_part, result.size_m, cols, "-", 1.3, faded))
    diag = float(np.linalg.norm(np.ptp(allp[-1], axis=0)))
    for p in result.parts:
        T = p.cam_from_part
        L = 0.3 * float(np.max(p.size_m))
        for a in range(3):
            seg = to_plot_axes(np.stack([T[:3, 3], T[:3, 3] + L * T[:3, a]]))
            ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=AXIS_COLOURS[a], lw=1.6)
    for j in result.joints:
        seg = to_plot_axes(_joint_segment(_joint_pivot(result, j), j.axis, 0.6 * diag))
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color="k", lw=2.0)
        ax.scatter(*seg[1], color="k", s=14, marker="^")
    if sample is not None:
        allp.append(_draw_boxes3d(ax, sample["cam_from_part"], sample["size_m"], cols, "--", 0.8))
        piv = np.asarray(sample.get("joint_pivot", np.zeros((0, 3))), np.float64).reshape(-1, 3)
        for p0, u in zip(piv, np.asarray(sample.get("joint_axis", np.zeros((0, 3))), np.float64).reshape(-1, 3), strict=False):
            if np.all(np.isfinite(p0)) and np.all(np.isfinite(u)):
                seg = to_plot_axes(_joint_segment(p0, u, 0.5 * diag))
                ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color="0.55", lw=1.5, ls="--")
    if title:
        ax.set_title(title, fontsize=8)
    if legend:
        from matplotlib.lines import Line2D

        part_text, _ = legend_lines(DrawnObject(result, errors=errors, truth=truth))
        ax.legend(
            handles=[Line2D([], [], color=c, lw=2, label=t.split("  |")[0]) for c, t in zip(cols, part_text, strict=False)],
            loc="upper left",
            fontsize=6,
            frameon=False,
        )
    _frame3d(ax, np.concatenate(allp))
    return np.concatenate(allp)


def _frame3d(ax, allp: np.ndarray) -> None:
    centre = 0.5 * (allp.min(0) + allp.max(0))
    r = 0.5 * float(np.max(np.ptp(allp, axis=0))) + 1e-6
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[1] - r, centre[1] + r)
    ax.set_zlim(centre[2] - r, centre[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-75)
    ax.set_xlabel("x (m)", fontsize=7, labelpad=-2)
    ax.set_ylabel("z (m)", fontsize=7, labelpad=-2)
    ax.set_zlabel("-y (m)", fontsize=7, labelpad=-2)
    ax.tick_params(labelsize=5, pad=-1)


# --------------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------------


def _scene_image(scene: Scene) -> tuple[np.ndarray, np.ndarray, str]:
    """``(depth_m, intrinsics, note)``: the scene's depth image, or its clouds splatted into one."""
    K = scene.intrinsics
    if K is None:
        K = next((o.sample["intrinsics"] for o in scene.objects if o.sample is not None and "intrinsics" in o.sample), None)
    if scene.depth_m is not None:
        if K is None:
            raise InputError("a depth image needs its camera's intrinsics to draw the estimates over it")
        return np.asarray(scene.depth_m, np.float64), _intrinsics(K), ""
    clouds = [np.asarray(o.points, np.float64).reshape(-1, 3) for o in scene.objects if o.points is not None]
    if not clouds:
        clouds = [box_corners(o.result.cam_from_part, o.result.size_m).reshape(-1, 3) for o in scene.objects]
    pts = np.concatenate(clouds)
    if K is not None:
        K = _intrinsics(K)
        shape = scene.rgb.shape[:2] if scene.rgb is not None else (int(round(2 * K[3] + 1)), int(round(2 * K[2] + 1)))
        note = "the cloud's depth, through its camera"
    else:
        K = fit_camera(pts)
        shape = (360, 480)
        note = "the cloud's depth, through a virtual camera at the origin"
    return splat_depth(pts, K, shape, radius=1 if shape[0] * shape[1] <= 320 * 240 else 2), K, note


def _draw_scene_row(fig, gs_row, legend_slot, scene: Scene, with_rgb: bool) -> None:
    depth, K, note = _scene_image(scene)
    col = 0
    ax = fig.add_subplot(gs_row[col])
    draw_overlay(ax, scene, K, depth, "depth", legend=False)
    ax.set_title((scene.title + "\n" if scene.title else "") + ("depth image" if not note else note), fontsize=8)
    col += 1
    if with_rgb:
        ax = fig.add_subplot(gs_row[col])
        if scene.rgb is not None:
            draw_overlay(ax, scene, K, scene.rgb, "rgb", legend=False)
            ax.set_title("RGB image", fontsize=8)
        else:
            ax.axis("off")
        col += 1
    ax3 = fig.add_subplot(gs_row[col], projection="3d")
    colours = part_colours(scene.objects)
    allp = [
        draw_result(ax3, o.points, o.result, o.sample, None, colours=c, errors=o.errors, legend=False, truth=o.truth)
        for o, c in zip(scene.objects, colours, strict=False)
    ]
    _frame3d(ax3, np.concatenate(allp))
    times = [o.result.timings_ms.get("total") for o in scene.objects if o.result.timings_ms.get("total") is not None]
    models = ", ".join(dict.fromkeys(o.result.model or o.result.category for o in scene.objects))
    ax3.set_title(f"3D, camera frame ({models}" + (f", {sum(times):.0f} ms" if times else "") + ")", fontsize=8)
    lax = fig.add_subplot(legend_slot)
    lax.axis("off")
    lax.legend(
        handles=legend_handles(scene),
        loc="upper left",
        ncol=_legend_cols(scene),
        fontsize=7,
        frameon=False,
        handlelength=2.0,
        columnspacing=2.5,
        borderaxespad=0.0,
    )


def _legend_cols(scene: Scene) -> int:
    return 1 if any(o.errors is not None for o in scene.objects) else 2


def _legend_rows(scene: Scene) -> int:
    n = (
        sum(len(o.result.parts) + len(o.result.joints) for o in scene.objects)
        + 4
        + 2 * len(warning_lines(scene))
        + any(o.sample is not None for o in scene.objects)
    )
    return -(-n // _legend_cols(scene))


def _figure(scenes: Sequence[Scene]):
    if not scenes:
        raise InputError("nothing to plot")
    for s in scenes:
        if not s.objects:
            raise InputError(f"scene {s.title!r} has no objects to draw")
    plt = pyplot()
    with_rgb = any(s.rgb is not None for s in scenes)
    ncols = 3 if with_rgb else 2
    panel_h = 4.0
    heights = [h for s in scenes for h in (panel_h, 0.25 + 0.16 * _legend_rows(s))]
    total = sum(heights) + 0.4 * len(scenes)
    fig = plt.figure(figsize=(5.3 * ncols, total), dpi=100)
    gs = fig.add_gridspec(
        2 * len(scenes),
        ncols,
        height_ratios=heights,
        width_ratios=[1.0] * (ncols - 1) + [0.9],
        hspace=0.4 * len(scenes) / total * 2,
        wspace=0.2,
        left=0.05,
        right=0.98,
        top=1 - 0.35 / total,
        bottom=0.01,
    )
    for i, s in enumerate(scenes):
        _draw_scene_row(fig, [gs[2 * i, c] for c in range(ncols)], gs[2 * i + 1, :], s, with_rgb)
    return fig


def plot_scenes(scenes: Sequence[Scene], out: str | Path) -> Path:
    """Draw scenes (one row each: depth image, RGB image if any scene has one, 3D panel) into a PNG,
    written atomically; returns its path. Raises :class:`InputError` on an empty list, a scene
    without objects or a depth image without intrinsics."""
    return save_figure(_figure(scenes), out)


def render_scenes(scenes: Sequence[Scene], out: str | Path | None = None) -> np.ndarray:
    """The picture of :func:`plot_scenes` as an ``(H, W, 3)`` uint8 RGB array (also written to the PNG
    ``out`` when given)."""
    fig = _figure(scenes)
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    if out is not None:
        save_figure(fig, out)
    else:
        pyplot().close(fig)
    return img


def plot_results(items: list, out: str | Path, cols: int = 3) -> Path:
    """Draw ``(points, result, sample_or_None, title)`` items (or :class:`Scene` s), one row each, into
    a PNG written atomically; returns its path. (``cols`` is accepted for compatibility, unused.)"""
    scenes = []
    for it in items:
        if isinstance(it, Scene):
            scenes.append(it)
            continue
        pts, res, sample, title = it[:4]
        errors = it[4] if len(it) > 4 else None
        scenes.append(Scene([DrawnObject(res, pts, sample, errors)], title=title))
    return plot_scenes(scenes, out)
