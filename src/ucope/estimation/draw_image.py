"""The image panel of a picture: camera-frame geometry projected to pixels, and a scene's estimates drawn
over its depth or RGB image.

Over the image every part's box is projected (solid: estimate, dashed: ground truth; dotted and faded
with its score beside it: an estimated part scoring below :data:`~ucope.estimation.draw_scene.LOW_SCORE`),
with the part frame's axis triad at its origin (x red, y green, z blue) and every joint axis (black arrow
through the pivot, or from the child part for a prismatic joint; dashed grey: ground truth). Arrows and
boxes are clipped to the visible window (an arrow whose head lies outside it is drawn up to the window's
edge, never dropped). The legend lists each part in its colour with its score (and its rotation /
translation / IoU errors when the ground truth is known), each joint with its state (and errors), and the
results' warnings.

Frames and units: camera frame (OpenCV: x right, y down, z forward), metres; pixels ``(u, v)`` =
(column, row).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..geometry.boxes import BOX_EDGES, box_corners
from ..plotting import pyplot
from .draw_scene import (
    AXIS_COLOURS,
    LOW_SCORE,
    DrawnObject,
    Scene,
    _joint_pivot,
    _joint_segment,
    _low,
    _object_diag,
    legend_lines,
    part_colours,
    warning_lines,
)

__all__ = ["project", "fit_camera", "splat_depth", "clip_segment", "draw_overlay", "legend_handles"]


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


def _box_segments(cam_from_part, size_m, intrinsics) -> list[np.ndarray]:
    """Per part, the ``(E, 2, 2)`` pixel segments of its box edges with both ends in front of the camera."""
    corners = box_corners(np.asarray(cam_from_part, np.float64).reshape(-1, 4, 4), np.asarray(size_m, np.float64).reshape(-1, 3))
    uv, ok = project(corners, intrinsics)  # (K, 8, 2), (K, 8)
    seg = uv[:, BOX_EDGES]  # (K, 12, 2, 2)
    keep = ok[:, BOX_EDGES].all(axis=-1)  # (K, 12)
    return [s[m] for s, m in zip(seg, keep, strict=False)]


# --------------------------------------------------------------------------------------------------
# Drawing over an image
# --------------------------------------------------------------------------------------------------


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

    K = _intrinsics(intrinsics)
    img = np.asarray(image)
    H, W = img.shape[:2]
    _draw_image(ax, img, kind)
    halo = [pe.Stroke(linewidth=3.2, foreground="white"), pe.Normal()]
    window = _view_window(scene, K, W, H) if zoom else (-0.5, W - 0.5, -0.5, H - 0.5)
    for obj, cols in zip(scene.objects, part_colours(scene.objects), strict=False):
        _draw_object(ax, obj, cols, K, window, halo)
    x0, x1, y0, y1 = window
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


def _draw_image(ax, img: np.ndarray, kind: str) -> None:
    """Show a depth image (metres; near = light grey, far = dark, no measurement = the pale background,
    with a colour bar) or an RGB image."""
    if kind != "depth":
        ax.imshow(img, interpolation="nearest")
        return
    d = np.where(np.isfinite(img) & (img > 0), img, np.nan)
    cmap = pyplot().get_cmap("Greys").with_extremes(bad="#f4f1ea")
    good = d[np.isfinite(d)]
    lo, hi = (float(np.percentile(good, 1)), float(np.percentile(good, 99))) if good.size else (0.0, 1.0)
    hi = max(hi, lo + 1e-3)
    im = ax.imshow(np.ma.masked_invalid(d), cmap=cmap, vmin=lo - 0.4 * (hi - lo), vmax=hi, interpolation="nearest")
    cb = ax.figure.colorbar(im, ax=ax, fraction=0.035, pad=0.02)
    cb.set_label("depth (m)", fontsize=7)
    cb.ax.tick_params(labelsize=6)


def _arrow(ax, p0, p1, K, window, colour: str, lw: float, scale: float, effects=None) -> None:
    """An arrow from camera-frame ``p0`` to ``p1``, cut to its visible part in ``window``."""
    seg = _image_segment(p0, p1, K, window)
    if seg is None:
        return
    props = dict(arrowstyle="-|>", color=colour, lw=lw, mutation_scale=scale, shrinkA=0, shrinkB=0)
    if effects is not None:
        props["path_effects"] = effects
    ax.annotate("", xy=seg[1], xytext=seg[0], arrowprops=props, annotation_clip=False)


def _draw_object(ax, obj: DrawnObject, cols: Sequence[str], K, window, halo) -> None:
    """One object over the image: its points tinted by predicted part, the ground truth's boxes, its own
    boxes, its part triads (x red, y green, z blue), its joint axes and the ground truth's joint axes."""
    from matplotlib.collections import LineCollection

    r = obj.result
    diag = _object_diag(obj)
    if obj.points is not None:
        _draw_points(ax, obj, cols, K)
    if obj.sample is not None:
        for segs, c in zip(_box_segments(obj.sample["cam_from_part"], obj.sample["size_m"], K), cols, strict=False):
            ax.add_collection(LineCollection(segs, colors=c, linewidths=1.1, linestyles=(0, (4, 3)), alpha=0.9))
    _draw_boxes(ax, obj, cols, K, window, halo)
    for p in r.parts:  # axis triads: x red, y green, z blue
        T = p.cam_from_part
        L = 0.3 * float(np.max(p.size_m))
        for a in range(3):
            _arrow(ax, T[:3, 3], T[:3, 3] + L * T[:3, a], K, window, AXIS_COLOURS[a], 1.6, 9)
    for j in r.joints:
        seg = _joint_segment(_joint_pivot(r, j), j.axis, 0.6 * diag)
        _arrow(ax, seg[0], seg[1], K, window, "k", 2.0, 11, halo)
    if obj.sample is not None:
        piv = np.asarray(obj.sample.get("joint_pivot", np.zeros((0, 3))), np.float64).reshape(-1, 3)
        axes = np.asarray(obj.sample.get("joint_axis", np.zeros((0, 3))), np.float64).reshape(-1, 3)
        for p0, u in zip(piv, axes, strict=False):
            if np.all(np.isfinite(p0)) and np.all(np.isfinite(u)):
                seg = _joint_segment(p0, u, 0.5 * diag)
                vis = _image_segment(seg[0], seg[1], K, window)
                if vis is not None:
                    ax.plot([vis[0][0], vis[1][0]], [vis[0][1], vis[1][1]], color="0.45", lw=1.4, ls=(0, (3, 2)))


def _draw_points(ax, obj: DrawnObject, cols: Sequence[str], K) -> None:
    """The object's points (at most 4000, evenly spread), tinted by predicted part (the segmentation)."""
    r = obj.result
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


def _draw_boxes(ax, obj: DrawnObject, cols: Sequence[str], K, window, halo) -> None:
    """The estimated boxes: solid, or dotted and faded with the score written beside a low-scoring part."""
    from matplotlib.collections import LineCollection

    r = obj.result
    x0, x1, y0, y1 = window
    for k, (segs, c) in enumerate(zip(_box_segments(r.cam_from_part, r.size_m, K), cols, strict=False)):
        if not _low(obj, k):
            ax.add_collection(LineCollection(segs, colors=c, linewidths=1.6, path_effects=halo))
            continue
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
