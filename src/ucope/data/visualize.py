"""Pictures of samples: points coloured by part, amodal boxes and joint axes (matplotlib, optional).

Plots are drawn in the camera frame seen roughly from the camera: x right, y down (flipped so the
picture is upright), z away from the viewer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.boxes import BOX_EDGES, box_corners
from ..plotting import PART_COLOURS, pyplot, save_figure, to_plot_axes

__all__ = ["plot_samples", "plot_object", "draw_sample"]


def draw_sample(ax, sample: dict, title: str | None = None, max_points: int = 3000, box_style: str = "-") -> None:
    """Draw one sample on a matplotlib 3D axis."""
    pts = np.asarray(sample["points"])
    labels = np.asarray(sample["part_labels"])
    if len(pts) > max_points:
        sel = np.linspace(0, len(pts) - 1, max_points).astype(int)
        pts, labels = pts[sel], labels[sel]
    P = to_plot_axes(pts)
    cols = np.array(PART_COLOURS)[labels % len(PART_COLOURS)]
    ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=cols, s=1.5, depthshade=False)
    corners = to_plot_axes(box_corners(np.asarray(sample["cam_from_part"]), np.asarray(sample["size_m"])))
    for k, c in enumerate(corners):
        for a, b in BOX_EDGES:
            ax.plot(*zip(c[a], c[b], strict=False), box_style, color=PART_COLOURS[k % len(PART_COLOURS)], lw=1.0)
        # part frame axes: x red, y green, z blue, a quarter of the box
        T = np.asarray(sample["cam_from_part"])[k]
        L = 0.25 * float(np.min(np.asarray(sample["size_m"])[k])) + 1e-3
        o = T[:3, 3]
        for d, colour in zip(T[:3, :3].T, ("r", "g", "b"), strict=False):
            seg = to_plot_axes(np.stack([o, o + L * d]))
            ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=colour, lw=1.5)
    diag = float(np.linalg.norm(np.ptp(pts, axis=0))) if len(pts) else 0.1
    for piv, axis in zip(
        np.asarray(sample["joint_pivot"]).reshape(-1, 3), np.asarray(sample["joint_axis"]).reshape(-1, 3), strict=False
    ):
        seg = to_plot_axes(np.stack([piv - 0.35 * diag * axis, piv + 0.35 * diag * axis]))
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color="k", lw=2.0)
        ax.scatter(*to_plot_axes(piv), color="k", s=12)
    allp = np.concatenate([P, corners.reshape(-1, 3)])
    centre = 0.5 * (allp.min(0) + allp.max(0))
    r = 0.5 * float(np.max(np.ptp(allp, axis=0)))
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[1] - r, centre[1] + r)
    ax.set_zlim(centre[2] - r, centre[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-75)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_zlabel("-y (m)")
    ax.tick_params(labelsize=6)
    if title:
        ax.set_title(title, fontsize=8)


def plot_samples(samples: list[dict], out: str | Path, titles: list[str] | None = None, cols: int = 3) -> Path:
    """Draw samples side by side into a PNG at ``out``; returns the path."""
    if not samples:
        raise InputError("nothing to plot: no samples given")
    plt = pyplot()
    n = len(samples)
    cols = min(cols, n)
    rows = -(-n // cols)
    fig = plt.figure(figsize=(4.2 * cols, 4.0 * rows), dpi=110)
    for i, s in enumerate(samples):
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d")
        title = titles[i] if titles else f"{s['category']} #{s['index']} ({s['instance_id']})"
        draw_sample(ax, s, title)
    fig.tight_layout()
    return save_figure(fig, out)


def plot_object(
    obj, out: str | Path, state=None, title: str | None = None, yaw_deg: float = 35.0, elevation_deg: float = 25.0
) -> Path:
    """Draw an :class:`~ucope.objects.articulation.ArticulatedObject` at ``state`` (default: rest).

    The object is ray cast from an oblique camera (so occlusion is exact) and shaded by part, with the
    amodal boxes, the part frames (x red, y green, z blue) and the joint axes (black, arrow head on the
    positive side) drawn over it. Used for the pictures in docs/conventions.md.
    """
    from ..geometry.transforms import apply_transform, invert_transform, look_at_rotation, make_transform
    from ..render.camera import PinholeCamera
    from ..render.raycast import raycast_depth

    plt = pyplot()
    import matplotlib.colors as mcolors

    poses = obj.object_from_part(state)
    v, f, lab = obj.posed_geometry(state)
    lo, hi = v.min(0), v.max(0)
    centre, diag = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    cam = PinholeCamera(fx=520.0, fy=520.0, cx=239.5, cy=199.5, width=480, height=400)
    yaw, elev = np.radians(yaw_deg), np.radians(elevation_deg)
    eye = centre + 1.6 * diag * np.array([np.cos(elev) * np.sin(yaw), np.sin(elev), np.cos(elev) * np.cos(yaw)])
    cam_from_obj = invert_transform(make_transform(look_at_rotation(eye, centre), eye))
    depth, labels = raycast_depth(apply_transform(cam_from_obj, v), f, lab, cam)
    pts = (
        cam.pixel_rays(*np.mgrid[0 : cam.height, 0 : cam.width].reshape(2, -1)).reshape(cam.height, cam.width, 3)
        * depth[..., None]
    )
    n = np.cross(np.gradient(pts, axis=1), np.gradient(pts, axis=0))
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    shade = 0.35 + 0.65 * np.abs(n[..., 2])
    img = np.ones((cam.height, cam.width, 3))
    for k in range(obj.num_parts):
        m = labels == k
        img[m] = np.clip(np.array(mcolors.to_rgb(PART_COLOURS[k % len(PART_COLOURS)])) * 0.5 + 0.5, 0, 1) * shade[m, None]

    fig, ax = plt.subplots(figsize=(4.8, 4.0), dpi=110)
    ax.imshow(img)
    uv = lambda p: cam.project(apply_transform(cam_from_obj, np.atleast_2d(p)))  # noqa: E731
    for k, (part, T) in enumerate(zip(obj.parts, poses, strict=False)):
        c = uv(box_corners(T, part.size_m))
        for a, b in BOX_EDGES:
            ax.plot(c[[a, b], 0], c[[a, b], 1], color=PART_COLOURS[k % len(PART_COLOURS)], lw=0.9)
        L = 0.3 * float(np.max(part.size_m))
        for d, colour in zip(T[:3, :3].T, ("r", "g", "b"), strict=False):
            seg = uv(np.stack([T[:3, 3], T[:3, 3] + L * d]))
            ax.plot(seg[:, 0], seg[:, 1], color=colour, lw=2.0)
    piv, axes = obj.joints_in_object(state)
    for p, a in zip(piv, axes, strict=False):
        seg = uv(np.stack([p - 0.25 * diag * a, p + 0.25 * diag * a]))
        ax.annotate("", xy=seg[1], xytext=seg[0], arrowprops=dict(arrowstyle="-|>", color="k", lw=1.8))
    ax.set_xlim(0, cam.width)
    ax.set_ylim(cam.height, 0)
    ax.axis("off")
    ax.set_title(title or obj.instance_id, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out)
