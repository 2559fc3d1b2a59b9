"""Laptop, rigid (NOCS-like): NOCS's laptop category, an opened laptop as ONE rigid part.

Frame (NOCS): y up, x right (the laptop's width), z towards the front (towards the user). The base
lies in the x-z plane; the hinge runs along x at the back of the base (z = -depth/2); the lid rises
from the hinge towards +y, opened by ``opening_deg`` (70-130 degrees from closed: 90 = vertical,
above 90 it leans back towards -z), with its screen facing +z (the user). Metres; the amodal box of
the whole laptop is centred on the origin. Symmetry ``"none"``.

Geometry (one mesh): a base slab with rounded corners (a wedge base: a trapezoid thick at the hinge,
thin at the front, on two front feet), a grid of raised keys with a space bar, a thin touchpad plate in
front of the keyboard, a hinge barrel along x, and the lid (length 0.94-1.0 x depth) with a raised bezel
frame around an inset screen on its inner face.

Shape families: those of the articulated ``laptop`` (ultrabook, mainstream, gaming, rugged; wedge held
out), with the same width, depth, base and lid thickness ranges (:data:`ucope.objects.categories.laptop.RANGES`).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import boxes, cylinder, extrude, rounded_slab, transformed
from . import CategorySpec
from .helpers import rigid_object, uniform
from .laptop import FAMILIES, draw_dimensions


def build(rng: np.random.Generator, instance_id: str, family: str = "mainstream") -> ArticulatedObject:
    """A random opened laptop of shape ``family``; see the module docstring for the frame."""
    dims = draw_dimensions(rng, family)
    W, Dp, tb, tl, corner = (dims[k] for k in ("width", "depth", "base", "lid", "corner"))
    lid_len = uniform(rng, 0.94, 1.0) * Dp
    theta_deg = uniform(rng, 70.0, 130.0)
    kb_w = uniform(rng, 0.8, 0.9) * W
    kb_d = uniform(rng, 0.34, 0.42) * Dp
    kb_back = uniform(rng, 0.05, 0.12) * Dp  # keyboard's distance from the back edge
    n_cols = int(rng.integers(13, 16))
    n_rows = int(rng.integers(5, 7))
    key_h = uniform(rng, 0.0005, 0.0012)
    key_fill = uniform(rng, 0.78, 0.88)
    tp_w = uniform(rng, 0.28, 0.42) * W
    tp_d = uniform(rng, 0.45, 0.75)  # fraction of the room in front of the keyboard
    bez_side = dims["bezel"]
    bez_top = bez_side + uniform(rng, 0.0, 0.006)
    bez_chin = bez_side + uniform(rng, 0.005, 0.015)

    if family == "wedge":  # trapezoid cross-section in the y-z plane: the bottom rises towards the front, on two front feet
        y_front = tb - dims["front"]
        meshes = [extrude(np.array([[0.0, -Dp / 2], [y_front, Dp / 2], [tb, Dp / 2], [tb, -Dp / 2]]), W, plane="yz")]
        fz = Dp / 2 - 0.02
        meshes.append(
            boxes(np.array([[sx * (W / 2 - 0.03), y_front / 2 + 0.0005, fz] for sx in (-1, 1)]), [0.012, y_front + 0.001, 0.01])
        )
    else:
        meshes = [rounded_slab((W, tb, Dp), corner, axis="y", center=(0.0, tb / 2, 0.0))]

    # keys: an n_rows x n_cols grid, the front row's middle keys merged into a space bar
    px, pz = kb_w / n_cols, kb_d / n_rows
    z0 = -Dp / 2 + kb_back
    cx = -kb_w / 2 + px * (np.arange(n_cols) + 0.5)
    cz = z0 + pz * (np.arange(n_rows) + 0.5)
    gx, gz = np.meshgrid(cx, cz)
    row = np.broadcast_to(np.arange(n_rows)[:, None], gx.shape)
    col = np.broadcast_to(np.arange(n_cols)[None, :], gx.shape)
    s0, s1 = n_cols // 2 - 3, n_cols // 2 + 3
    keep = ~((row == n_rows - 1) & (col >= s0) & (col < s1))
    centers = np.stack([gx[keep], np.full(keep.sum(), tb + key_h / 2), gz[keep]], -1)
    ext = np.array([key_fill * px, key_h, key_fill * pz])
    space_c = [0.5 * (cx[s0] + cx[s1 - 1]), tb + key_h / 2, cz[-1]]
    space_e = [(s1 - s0 - 1) * px + key_fill * px, key_h, key_fill * pz]
    meshes.append(boxes(np.concatenate([centers, [space_c]]), np.concatenate([np.broadcast_to(ext, centers.shape), [space_e]])))

    # touchpad: a thin plate centred in the room between the keyboard and the front edge
    room = Dp / 2 - (z0 + kb_d)
    tp_dd = tp_d * room
    meshes.append(rounded_slab((tp_w, 0.0004, tp_dd), 0.004, axis="y", center=(0.0, tb + 0.0002, z0 + kb_d + room / 2)))

    # hinge barrel and lid: the lid is built closed (lying over the base, screen down), then opened
    gap = key_h + 0.0008
    pivot = np.array([0.0, tb + gap + tl / 2, -Dp / 2 + tl / 2 + 0.001])
    meshes.append(cylinder(tl / 2 + 0.0015, 0.7 * W, center=pivot, axis=(1.0, 0.0, 0.0), sections=16))
    e = 0.001  # the lid starts just behind the hinge line
    lid = [rounded_slab((W, tl, lid_len), corner, axis="y", center=(0.0, 0.0, lid_len / 2 - e))]
    # bezel frame, protruding 0.6 mm from the inner (-y) face around the inset screen
    bt = 0.0006
    zc0, zc1 = -e, lid_len - e
    sx = W - 2 * bez_side
    lid.append(
        boxes(
            np.array(
                [
                    [0.0, -tl / 2 - bt / 2, zc0 + bez_chin / 2],
                    [0.0, -tl / 2 - bt / 2, zc1 - bez_top / 2],
                    [-W / 2 + bez_side / 2 + 0.0005, -tl / 2 - bt / 2, (zc0 + zc1) / 2],
                    [W / 2 - bez_side / 2 - 0.0005, -tl / 2 - bt / 2, (zc0 + zc1) / 2],
                ]
            ),
            np.array(
                [
                    [sx, bt, bez_chin],
                    [sx, bt, bez_top],
                    [bez_side - 0.001, bt, lid_len - 2 * corner],
                    [bez_side - 0.001, bt, lid_len - 2 * corner],
                ]
            ),
        )
    )
    th = np.deg2rad(theta_deg)
    R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(th), np.sin(th)], [0.0, -np.sin(th), np.cos(th)]])  # about x by -theta
    meshes += [transformed(m, R, pivot) for m in lid]

    params = dict(
        width=W,
        depth=Dp,
        base_thickness=tb,
        base_front_thickness=dims["front"],
        lid_thickness=tl,
        lid_length=lid_len,
        opening_deg=theta_deg,
        corner_radius=corner,
        keyboard_width=kb_w,
        keyboard_depth=kb_d,
        keyboard_back=kb_back,
        n_cols=n_cols,
        n_rows=n_rows,
        key_height=key_h,
        key_fill=key_fill,
        touchpad_width=tp_w,
        touchpad_depth=tp_dd,
        bezel_side=bez_side,
        bezel_top=bez_top,
        bezel_chin=bez_chin,
    )
    return rigid_object("laptop_rigid", instance_id, meshes, "none", params, family)


SPEC = CategorySpec(
    name="laptop_rigid",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("none",),
    distance_range_m=(0.6, 1.3),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="opened laptop as one rigid part (NOCS): base with keys and touchpad, lid at 70-130 deg",
)
