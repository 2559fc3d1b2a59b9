"""Pictures of estimates: the image with the estimate drawn over it, and a 3D panel.

A picture has one row per :class:`Scene` (one frame, or one cloud): the depth image, the RGB image
when there is one, and a 3D panel. Over each image every part's box is projected (solid: estimate,
dashed: ground truth; dotted and faded with its score beside it: an estimated part whose score is
below :data:`LOW_SCORE`), with the part frame's axis triad at its origin (x red, y green, z blue) and
every joint axis (black arrow through the pivot, or from the child part for a prismatic joint; dashed
grey: ground truth). Part colours come from :data:`PART_PALETTE`, which holds no red, green or blue, so
that a part never looks like a triad axis. Arrows and boxes are clipped to the visible window (an arrow
whose head lies outside it is drawn up to the window's edge, never dropped). The legend lists each part
in its colour with its score (and its rotation / translation / IoU errors when the ground truth is
known), each joint with its state (and errors), and the result's warnings.

Without a depth image (a point cloud given alone) the image panel shows the cloud's own depth, splatted
through the sample's intrinsics or through a virtual camera fitted to the cloud (:func:`fit_camera`).

Frames and units: camera frame (OpenCV: x right, y down, z forward), metres; pixels ``(u, v)`` =
(column, row). The 3D panels use :func:`ucope.plotting.to_plot_axes` (x right, depth into the picture,
up = -y).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..errors import InputError
from ..geometry.boxes import BOX_EDGES, box_corners
from ..plotting import pyplot, save_figure, to_plot_axes


class PoseResult(Protocol):
    """What the drawing reads of a :class:`ucope.estimation.result.PoseResult` (named here, not imported:
    ``PoseResult.plot`` draws through this module, so this module must not import that one back)."""

    category: str
    model: str
    parts: Sequence[Any]
    joints: Sequence[Any]
    part_labels: Any
    timings_ms: dict


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

AXIS_COLOURS = ("#e41a1c", "#2ca02c", "#1f3fff")
"""Triad colours of a part frame's x, y and z axes (red, green, blue)."""

PART_PALETTE = ("#ff8c00", "#9467bd", "#e377c2", "#17becf", "#bcbd22", "#8c6d31", "#7f7f7f", "#637939")
"""Part colours (orange, purple, pink, cyan, olive, ochre, grey, moss): every hue at least 25 degrees from
red, green and blue, the triad's colours."""

LOW_SCORE = 0.5
"""Estimated parts scoring below this are drawn dotted and faded, with their score beside them."""


@dataclass
class DrawnObject:
    """One object to draw: its estimate, optionally its cloud (camera frame, metres), its ground-truth
    sample (:mod:`ucope.data.sample` fields ``cam_from_part``, ``size_m``, ``joint_pivot``, ``joint_axis``)
    and its errors (:func:`ucope.eval.evaluate.sample_errors`, printed in the legend). ``truth``: the
    result is itself a ground truth (drawn without scores)."""

    result: PoseResult
    points: np.ndarray | None = None
    sample: dict | None = None
    errors: dict | None = None
    name: str = ""
    truth: bool = False  # the result is a ground truth itself (ucope show): no scores in its labels


@dataclass
class Scene:
    """One row of a picture: the objects of one frame (or one cloud) and what to draw them over.

    ``depth_m``: ``(H, W)`` depth in metres (0 / NaN = none); ``rgb``: ``(H, W, 3)`` uint8 image of the
    same camera; ``intrinsics``: ``(fx, fy, cx, cy)`` of that camera. Without ``depth_m`` the objects'
    clouds are splatted into a depth image (through ``intrinsics``, a sample's, or a fitted camera)."""

    objects: list[DrawnObject]
    title: str = ""
    depth_m: np.ndarray | None = None
    rgb: np.ndarray | None = None
    intrinsics: Sequence[float] | None = None


# --------------------------------------------------------------------------------------------------
# Cameras and projection
# --------------------------------------------------------------------------------------------------


def _intrinsics(K) -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    if K.shape == (3, 3):
        K = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    if K.shape != (4,) or not np.all(np.isfinite(K)) or K[0] <= 0 or K[1] <= 0:
        raise InputError(
            f"intrinsics must be (fx, fy, cx, cy) or a 3x3 K with positive focal lengths, got {np.asarray(K).tolist()}"
        )
    return K


def project(points, intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates of camera-frame points.

    Args:
        points: ``(..., 3)`` camera frame, metres.
        intrinsics: ``(fx, fy, cx, cy)`` or a 3x3 K.

    Returns:
        ``uv (..., 2)`` (column, row) and ``in_front (...)`` (z > 1 mm; ``uv`` is meaningless elsewhere).
    """
    fx, fy, cx, cy = _intrinsics(intrinsics)
    p = np.asarray(points, dtype=np.float64)
    z = p[..., 2]
    ok = z > 1e-3
    zs = np.where(ok, z, 1.0)
    return np.stack([fx * p[..., 0] / zs + cx, fy * p[..., 1] / zs + cy], axis=-1), ok


def fit_camera(points, width: int = 480, height: int = 360, fill: float = 0.7) -> np.ndarray:
    """A virtual pinhole camera at the camera-frame origin that frames ``points``: ``(fx, fy, cx, cy)``
    with ``fx = fy`` chosen so that the cloud spans ``fill`` of the ``width x height`` image, centred.

    Raises :class:`InputError` if no point lies in front of the camera (z > 1 mm)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1) & (p[:, 2] > 1e-3)]
    if len(p) == 0:
        raise InputError("no point lies in front of the camera (z > 0): nothing to project")
    xy = p[:, :2] / p[:, 2:3]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, 1e-6)
    f = float(fill * min(width / span[0], height / span[1]))
    mid = 0.5 * (lo + hi)
    return np.array([f, f, 0.5 * (width - 1) - f * mid[0], 0.5 * (height - 1) - f * mid[1]])


def splat_depth(points, intrinsics, shape: tuple[int, int], radius: int = 1) -> np.ndarray:
    """A depth image (metres, NaN where empty) of ``points`` seen through ``intrinsics``.

    Args:
        points: ``(N, 3)`` camera frame, metres.
        intrinsics: ``(fx, fy, cx, cy)`` or a 3x3 K.
        shape: ``(H, W)`` of the image.
        radius: each point covers a ``(2 radius + 1)`` pixel square (the nearest point wins).
    """
    from scipy.ndimage import grey_erosion

    H, W = int(shape[0]), int(shape[1])
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    uv, ok = project(p, intrinsics)
    col, row = np.round(uv[:, 0]).astype(np.int64), np.round(uv[:, 1]).astype(np.int64)
    ok &= (col >= 0) & (col < W) & (row >= 0) & (row < H)
    depth = np.full((H, W), np.inf)
    np.minimum.at(depth, (row[ok], col[ok]), p[ok, 2])
    if radius > 0:
        depth = grey_erosion(depth, size=(2 * radius + 1, 2 * radius + 1), mode="constant", cval=np.inf)
    depth[~np.isfinite(depth)] = np.nan
    return depth


def part_colours(scene_objects: Sequence[DrawnObject]) -> list[list[str]]:
    """The colour of every part of every object: part ``k`` of the first object is ``PART_PALETTE[k]``;
    later objects continue the sequence, so that the parts of one frame all differ (up to 8)."""
    out, offset = [], 0
    for o in scene_objects:
        K = len(o.result.parts)
        out.append([PART_PALETTE[(offset + k) % len(PART_PALETTE)] for k in range(K)])
        offset += K
    return out


def _low(obj: DrawnObject, k: int) -> bool:
    """Whether part ``k`` of an estimate scores below :data:`LOW_SCORE` (a ground truth never does)."""
    return not obj.truth and float(obj.result.parts[k].score) < LOW_SCORE


def clip_segment(a, b, box: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray] | None:
    """The part of the 2D segment ``a -> b`` inside ``box = (x0, x1, y0, y1)`` (Liang-Barsky), its
    direction kept, or ``None`` when it misses the box."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    d = b - a
    x0, x1, y0, y1 = min(box[0], box[1]), max(box[0], box[1]), min(box[2], box[3]), max(box[2], box[3])
    t0, t1 = 0.0, 1.0
    for p, q in ((-d[0], a[0] - x0), (d[0], x1 - a[0]), (-d[1], a[1] - y0), (d[1], y1 - a[1])):
        if p == 0:
            if q < 0:
                return None
            continue
        t = q / p
        if p < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return None
    return a + t0 * d, a + t1 * d


def _image_segment(p0, p1, K, box, near: float = 0.01) -> tuple[np.ndarray, np.ndarray] | None:
    """The pixel segment of the camera-frame segment ``p0 -> p1``: cut to the part in front of the
    camera (``z >= near``), projected, and clipped to the window ``box``; ``None`` if nothing is visible."""
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    z0, z1 = p0[2], p1[2]
    if z0 < near and z1 < near:
        return None
    if z0 < near or z1 < near:
        cut = p0 + (near - z0) / (z1 - z0) * (p1 - p0)
        p0, p1 = (cut, p1) if z0 < near else (p0, cut)
    uv, _ = project(np.stack([p0, p1]), K)
    return clip_segment(uv[0], uv[1], box)


# --------------------------------------------------------------------------------------------------
# Text
# --------------------------------------------------------------------------------------------------


def _joint_state_text(jtype: str, state: float) -> str:
    return f"{np.degrees(state):.1f} deg" if jtype == "revolute" else f"{100 * state:.1f} cm"


def legend_lines(obj: DrawnObject) -> tuple[list[str], list[str]]:
    """The legend's text for one object: one line per part (label, score, and errors when known) and
    one per joint (type, state, and errors when known). A part scoring below :data:`LOW_SCORE` is marked
    ``(low)``."""
    r, e = obj.result, obj.errors
    prefix = f"{obj.name}: " if obj.name else ""
    parts = []
    for k, p in enumerate(r.parts):
        line = f"{prefix}{p.label}  " + ("(ground truth)" if obj.truth else f"score {p.score:.2f}")
        if _low(obj, k):
            line += " (low)"
        if e is not None and k < len(e.get("parts", [])):
            pe = e["parts"][k]
            line += f"  | err {pe['rotation_deg']:.1f} deg, {100 * pe['translation_m']:.1f} cm, IoU {pe['iou']:.2f}"
        parts.append(line)
    joints = []
    for i, j in enumerate(r.joints):
        line = (
            f"{prefix}joint {r.parts[j.parent].label}->{r.parts[j.child].label} ({j.type}) {_joint_state_text(j.type, j.state)}"
        )
        je = (e.get("joints") or [None] * len(r.joints))[i] if e is not None else None
        if je is not None:
            st = f"{je['state_error']:.1f} deg" if je["state_unit"] == "deg" else f"{100 * je['state_error']:.1f} cm"
            piv = f", pivot {100 * je['pivot_m']:.1f} cm" if je.get("pivot_m") is not None else ""
            line += f"  | err axis {je['axis_deg']:.1f} deg{piv}, state {st}"
        joints.append(line)
    return parts, joints


# --------------------------------------------------------------------------------------------------
# Image panels
# --------------------------------------------------------------------------------------------------


def _box_segments(cam_from_part, size_m, intrinsics) -> list[np.ndarray]:
    """Per part, the ``(E, 2, 2)`` pixel segments of its box edges with both ends in front of the camera."""
    corners = box_corners(np.asarray(cam_from_part, np.float64).reshape(-1, 4, 4), np.asarray(size_m, np.float64).reshape(-1, 3))
    uv, ok = project(corners, intrinsics)  # (K, 8, 2), (K, 8)
    seg = uv[:, BOX_EDGES]  # (K, 12, 2, 2)
    keep = ok[:, BOX_EDGES].all(axis=-1)  # (K, 12)
    return [s[m] for s, m in zip(seg, keep, strict=False)]


def _joint_segment(pivot, axis, length: float):
    piv = np.asarray(pivot, np.float64)
    u = np.asarray(axis, np.float64)
    u = u / (np.linalg.norm(u) + 1e-12)
    return np.stack([piv - 0.5 * length * u, piv + 0.5 * length * u])


def _object_diag(obj: DrawnObject) -> float:
    corners = box_corners(obj.result.cam_from_part, obj.result.size_m).reshape(-1, 3)
    return float(np.linalg.norm(np.ptp(corners, axis=0))) if len(corners) else 0.1


def _joint_pivot(result: PoseResult, j) -> np.ndarray:
    """A point on a joint's axis: its pivot, or the child part's origin for a prismatic joint."""
    return np.asarray(j.pivot_m if j.pivot_m is not None else result.parts[j.child].cam_from_part[:3, 3], np.float64)


def draw_overlay(ax, scene: Scene, intrinsics, image=None, kind: str = "depth", legend: bool = True, zoom: bool = True) -> None:
    """Draw a scene's objects over an image on a matplotlib 2D axis.

    Args:
        scene: the objects (their ``result``, ``sample`` and ``errors``).
        intrinsics: ``(fx, fy, cx, cy)`` of the image's camera.
        image: ``(H, W)`` depth in metres (``kind="depth"``: grey, near = light, with a colour bar) or
            ``(H, W, 3)`` uint8 RGB (``kind="rgb"``).
        legend: add the legend (parts with scores and errors, joints, axis colours) below the image.
        zoom: when the objects cover less than a fifth of the image, show the window around them
            (with a margin, the image's aspect ratio kept) instead of the whole image.
    """
    import matplotlib.patheffects as pe
    from matplotlib.collections import LineCollection

    K = _intrinsics(intrinsics)
    img = np.asarray(image)
    H, W = img.shape[:2]
    if kind == "depth":
        d = np.where(np.isfinite(img) & (img > 0), img, np.nan)
        cmap = pyplot().get_cmap("Greys").with_extremes(bad="#f4f1ea")
        good = d[np.isfinite(d)]
        lo, hi = (float(np.percentile(good, 1)), float(np.percentile(good, 99))) if good.size else (0.0, 1.0)
        hi = max(hi, lo + 1e-3)
        # near = light grey, far = dark; no measurement = the pale background (never white on white)
        im = ax.imshow(np.ma.masked_invalid(d), cmap=cmap, vmin=lo - 0.4 * (hi - lo), vmax=hi, interpolation="nearest")
        cb = ax.figure.colorbar(im, ax=ax, fraction=0.035, pad=0.02)
        cb.set_label("depth (m)", fontsize=7)
        cb.ax.tick_params(labelsize=6)
    else:
        ax.imshow(img, interpolation="nearest")
    halo = [pe.Stroke(linewidth=3.2, foreground="white"), pe.Normal()]
    window = _view_window(scene, K, W, H) if zoom else (-0.5, W - 0.5, -0.5, H - 0.5)
    x0, x1, y0, y1 = window
    colours = part_colours(scene.objects)

    def arrow(p0, p1, colour: str, lw: float, scale: float, effects=None) -> None:
        seg = _image_segment(p0, p1, K, window)
        if seg is None:
            return
        props = dict(arrowstyle="-|>", color=colour, lw=lw, mutation_scale=scale, shrinkA=0, shrinkB=0)
        if effects is not None:
            props["path_effects"] = effects
        ax.annotate("", xy=seg[1], xytext=seg[0], arrowprops=props, annotation_clip=False)

    for obj, cols in zip(scene.objects, colours, strict=False):
        r = obj.result
        diag = _object_diag(obj)
        if obj.points is not None:  # the object's points, tinted by predicted part (the segmentation)
            pts = np.asarray(obj.points, np.float64).reshape(-1, 3)
            labels = np.asarray(r.part_labels) if len(r.part_labels) == len(pts) else np.zeros(len(pts), np.int64)
            keep = np.flatnonzero(labels >= 0)
            keep = keep[np.linspace(0, len(keep) - 1, min(len(keep), 4000)).astype(np.int64)] if len(keep) else keep
            uv, ok = project(pts[keep], K)
            ax.scatter(
                uv[ok, 0],
                uv[ok, 1],
                s=1.2,
                c=np.array(cols)[np.clip(labels[keep][ok], 0, len(cols) - 1)],
                alpha=0.45,
                linewidths=0,
                rasterized=True,
            )
        if obj.sample is not None:
            for segs, c in zip(_box_segments(obj.sample["cam_from_part"], obj.sample["size_m"], K), cols, strict=False):
                ax.add_collection(LineCollection(segs, colors=c, linewidths=1.1, linestyles=(0, (4, 3)), alpha=0.9))
        for k, (segs, c) in enumerate(zip(_box_segments(r.cam_from_part, r.size_m, K), cols, strict=False)):
            if _low(obj, k):  # a doubtful part: dotted, faded, its score written beside it
                ax.add_collection(LineCollection(segs, colors=c, linewidths=1.4, linestyles=(0, (1, 1.6)), alpha=0.55))
                inside = [s for s in segs.reshape(-1, 2) if x0 <= s[0] <= x1 and min(y0, y1) <= s[1] <= max(y0, y1)]
                if inside:
                    top = min(inside, key=lambda q: q[1])
                    ax.text(
                        top[0],
                        top[1],
                        f"{r.parts[k].label} {r.parts[k].score:.2f}",
                        color=c,
                        fontsize=6,
                        ha="center",
                        va="bottom",
                        alpha=0.9,
                        path_effects=halo,
                        clip_on=True,
                    )
            else:
                ax.add_collection(LineCollection(segs, colors=c, linewidths=1.6, path_effects=halo))
        for p in r.parts:  # axis triads: x red, y green, z blue
            T = p.cam_from_part
            L = 0.3 * float(np.max(p.size_m))
            for a in range(3):
                arrow(T[:3, 3], T[:3, 3] + L * T[:3, a], AXIS_COLOURS[a], 1.6, 9)
        for j in r.joints:
            seg = _joint_segment(_joint_pivot(r, j), j.axis, 0.6 * diag)
            arrow(seg[0], seg[1], "k", 2.0, 11, halo)
        if obj.sample is not None:
            piv = np.asarray(obj.sample.get("joint_pivot", np.zeros((0, 3))), np.float64).reshape(-1, 3)
            axes = np.asarray(obj.sample.get("joint_axis", np.zeros((0, 3))), np.float64).reshape(-1, 3)
            for p0, u in zip(piv, axes, strict=False):
                if np.all(np.isfinite(p0)) and np.all(np.isfinite(u)):
                    seg = _joint_segment(p0, u, 0.5 * diag)
                    vis = _image_segment(seg[0], seg[1], K, window)
                    if vis is not None:
                        ax.plot([vis[0][0], vis[1][0]], [vis[0][1], vis[1][1]], color="0.45", lw=1.4, ls=(0, (3, 2)))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y1, y0)
    ax.set_xlabel("u (px)", fontsize=7)
    ax.set_ylabel("v (px)", fontsize=7)
    ax.tick_params(labelsize=6)
    if legend:
        ax.legend(
            handles=legend_handles(scene),
            loc="upper center",
            bbox_to_anchor=(0.5, -0.13),
            fontsize=6,
            frameon=False,
            handlelength=1.8,
        )


def _view_window(scene: Scene, K, W: int, H: int) -> tuple[float, float, float, float]:
    """``(u0, u1, v0, v1)``: the whole image, or a window around the objects' projected boxes."""
    corners = [box_corners(o.result.cam_from_part, o.result.size_m).reshape(-1, 3) for o in scene.objects]
    uv, ok = project(np.concatenate(corners), K)
    full = (-0.5, W - 0.5, -0.5, H - 0.5)
    if not ok.any():
        return full
    lo, hi = np.clip(uv[ok].min(axis=0), 0, [W, H]), np.clip(uv[ok].max(axis=0), 0, [W, H])
    size = hi - lo
    if size[0] * size[1] >= 0.2 * W * H:
        return full
    half = 0.5 * np.maximum(1.5 * size, [0.3 * W, 0.3 * H])
    half = np.maximum(half, half[::-1] * [W / H, H / W])  # keep the image's aspect ratio
    half = np.minimum(half, [W / 2, H / 2])
    c = np.clip(0.5 * (lo + hi), half - 0.5, [W, H] - half - 0.5)
    return float(c[0] - half[0]), float(c[0] + half[0]), float(c[1] - half[1]), float(c[1] + half[1])


def warning_lines(scene: Scene, width: int = 120) -> list[str]:
    """The legend's warning lines of a scene: each result's warnings (prefixed by the object's name when
    the scene holds several), cut to ``width`` characters."""
    out = []
    for obj in scene.objects:
        for w in getattr(obj.result, "warnings", None) or []:
            text = f"warning{f' ({obj.name})' if obj.name else ''}: {w}"
            out.append(text if len(text) <= width else text[: width - 3] + "...")
    return out


def legend_handles(scene: Scene) -> list:
    """The legend entries of a scene: every part in its colour with its score (and errors; a low score
    dotted), every joint, the axis colours of the triads, the ground-truth line style when there is one,
    and every warning of the results."""
    from matplotlib.lines import Line2D

    handles = []
    for obj, cols in zip(scene.objects, part_colours(scene.objects), strict=False):
        part_text, joint_text = legend_lines(obj)
        handles += [
            Line2D(
                [], [], color=c, lw=2.2, label=t, ls=(0, (1, 1.2)) if _low(obj, k) else "-", alpha=0.6 if _low(obj, k) else 1.0
            )
            for k, (c, t) in enumerate(zip(cols, part_text, strict=False))
        ]
        handles += [Line2D([], [], color="k", lw=2.0, marker=">", markersize=4, label=t) for t in joint_text]
    handles += [Line2D([], [], color=c, lw=1.6, label=f"part frame {n} axis") for c, n in zip(AXIS_COLOURS, "xyz", strict=False)]
    if any(o.sample is not None for o in scene.objects):
        handles.append(Line2D([], [], color="0.3", lw=1.1, ls=(0, (4, 3)), label="ground truth (dashed boxes, grey joint axes)"))
    if any(_low(o, k) for o in scene.objects for k in range(len(o.result.parts))):
        handles.append(
            Line2D([], [], color="0.4", lw=1.4, ls=(0, (1, 1.2)), alpha=0.6, label=f"dotted, faded: score < {LOW_SCORE}")
        )
    handles += [Line2D([], [], ls="none", marker="$!$", markersize=6, color="#b00020", label=t) for t in warning_lines(scene)]
    return handles


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
