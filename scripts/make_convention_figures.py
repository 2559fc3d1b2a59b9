"""Regenerate every picture of docs/conventions.md.

Usage: python scripts/make_convention_figures.py [--categories laptop mug ...] [--per-family 4]

* ``docs/images/conventions_<name>.png``: train instance 0 of the category at a mid joint state, with part
  boxes, part frames (x red, y green, z blue) and joint axes (black, arrow head = positive direction).
* ``docs/images/families_<name>.png``: a gallery of the category's shape families, one row per family
  (held-out families marked), ``--per-family`` instances each (instances 0, 1, ... of the train stream
  built as that family, at scale 1, mid joint state), each titled with its rest-state object extents
  (x, y, z) in centimetres and drawn to fit its tile (the titles give the sizes).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ucope.data.visualize import plot_object
from ucope.geometry.transforms import apply_transform, invert_transform, look_at_rotation, make_transform
from ucope.objects.categories import CATEGORY_NAMES, get_category, make_instance
from ucope.plotting import PART_COLOURS, pyplot, save_figure
from ucope.render.camera import PinholeCamera
from ucope.render.raycast import raycast_depth

OUT_DIR = Path(__file__).resolve().parents[1] / "docs" / "images"


def shaded(obj, state, yaw_deg: float = 35.0, elevation_deg: float = 25.0, width: int = 220, height: int = 180) -> np.ndarray:
    """``(height, width, 3)`` picture of ``obj`` at ``state``: ray cast, shaded by part colour and normal."""
    import matplotlib.colors as mcolors

    v, f, lab = obj.posed_geometry(state)
    lo, hi = v.min(0), v.max(0)
    centre, diag = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    cam = PinholeCamera(fx=0.95 * width, fy=0.95 * width, cx=(width - 1) / 2, cy=(height - 1) / 2, width=width, height=height)
    yaw, elev = np.radians(yaw_deg), np.radians(elevation_deg)
    eye = centre + 1.25 * diag * np.array([np.cos(elev) * np.sin(yaw), np.sin(elev), np.cos(elev) * np.cos(yaw)])
    cam_from_obj = invert_transform(make_transform(look_at_rotation(eye, centre), eye))
    depth, labels = raycast_depth(apply_transform(cam_from_obj, v), f, lab, cam)
    pts = cam.pixel_rays(*np.mgrid[0:height, 0:width].reshape(2, -1)).reshape(height, width, 3) * depth[..., None]
    n = np.cross(np.gradient(pts, axis=1), np.gradient(pts, axis=0))
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    shade = 0.35 + 0.65 * np.abs(n[..., 2])
    img = np.ones((height, width, 3))
    for k in range(obj.num_parts):
        m = labels == k
        img[m] = np.clip(np.array(mcolors.to_rgb(PART_COLOURS[k % len(PART_COLOURS)])) * 0.5 + 0.5, 0, 1) * shade[m, None]
    return img


def mid_state(obj):
    return obj.limits.mean(axis=1) if obj.joints else None


def family_gallery(name: str, per_family: int, out: Path) -> Path:
    spec = get_category(name)
    fams = spec.shape_families
    plt = pyplot()
    fig, axes = plt.subplots(len(fams), per_family, figsize=(2.3 * per_family, 2.0 * len(fams)), dpi=100, squeeze=False)
    for r, fam in enumerate(fams):
        for c in range(per_family):
            obj = make_instance(name, "train", c, family=fam.name)
            lo, hi = obj.bounds(obj.rest_state if obj.joints else None)
            ext = 100 * (hi - lo)
            ax = axes[r, c]
            elev = float(np.clip(np.mean(spec.elevation_range_deg), 20.0, 55.0))
            ax.imshow(shaded(obj, mid_state(obj), yaw_deg=30.0 + 10.0 * c, elevation_deg=elev))
            ax.set_xticks([])
            ax.set_yticks([])
            for side in ax.spines.values():
                side.set_visible(False)
            ax.set_title(f"{ext[0]:.1f} x {ext[1]:.1f} x {ext[2]:.1f} cm", fontsize=7)
            if c == 0:
                label = fam.name + ("\n(held out: ood)" if fam.held_out else "")
                ax.set_ylabel(label, fontsize=9)
    fig.suptitle(f"{name}: shape families (rest-state extents x, y, z)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--categories", nargs="+", default=list(CATEGORY_NAMES))
    ap.add_argument("--per-family", type=int, default=4)
    ap.add_argument("--out", default=str(OUT_DIR))
    ap.add_argument("--galleries-only", action="store_true")
    args = ap.parse_args()
    out_dir = Path(args.out)
    for name in args.categories:
        if not args.galleries_only:
            obj = make_instance(name, "train", 0)
            state = mid_state(obj)
            label = (
                f"{name} ({obj.shape_family}): state {np.round(state, 2).tolist()}"
                if state is not None
                else f"{name} ({obj.shape_family}, rigid)"
            )
            print(plot_object(obj, out_dir / f"conventions_{name}.png", state=state, title=label))
        print(family_gallery(name, args.per_family, out_dir / f"families_{name}.png"))


if __name__ == "__main__":
    main()
