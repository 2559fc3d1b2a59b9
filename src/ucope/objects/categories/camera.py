"""Camera (NOCS-like, rigid): a photo camera with a body, a grip, a lens barrel and top controls.

Frame (NOCS): y up, x right, z towards the front: the lens points along +z; the grip is on the -x
side (the photographer's right hand: seen from the front, the grip is on the viewer's left); the
viewfinder hump / controls are on top (+y); the screen is on the back (-z). Metres; the amodal box
(lens included) is centred on the origin. Symmetry ``"none"``.

Geometry: a body box with rounded front-view corners (width 0.09-0.15 m, height 0.06-0.10 m, depth
0.03-0.07 m); a grip block with rounded edges on the -x end, protruding forwards; a revolved lens
(radius 0.02-0.04 m, protruding 0.02-0.09 m from the body front; on compacts the radius is at most
0.34 x body height and the length at most 0.05 m), right of the grip: a mount ring, the barrel, a
ribbed focus ring, a front ring with a rounded lip and a recessed glass dome; on top a shutter button
(over the grip) and a mode dial (when the hump leaves room), plus, for ``style = 0`` (DSLR / mirrorless) a viewfinder hump with a hot
shoe over the lens and an eyepiece at the back, or for ``style = 1`` (compact) a flash window and a
viewfinder window on the front; a screen on the back.
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, box, boxes, cylinder, extrude, revolve_profile, rounded_slab, transformed
from . import CategorySpec
from .helpers import rigid_object, uniform

_Y_TO_Z = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # rotation about x by +90 deg: y -> z


def _lens_profile(rl: float, L: float, mount_len: float, front_len: float, n_ribs: int) -> np.ndarray:
    """Open (r, y) profile of the lens along its axis (y = 0 at the body front), axis to axis."""
    rm = 1.12 * rl
    y_focus0, y_focus1 = 0.4 * L, min(0.78 * L, L - front_len - 0.002)
    f = np.linspace(y_focus0, y_focus1, 2 * n_ribs + 1)
    focus_r = rl * (1.035 + 0.012 * (np.arange(len(f)) % 2))
    rf = 1.06 * rl
    lip = min(0.0015, 0.3 * front_len)
    glass_y = L - 0.4 * front_len
    return np.concatenate([
        [[0.0, -0.003], [rm, -0.003], [rm, mount_len], [rl, mount_len], [rl, y_focus0]],
        np.stack([focus_r, f], -1),
        [[rl, y_focus1], [0.98 * rl, y_focus1 + 0.001], [0.98 * rl, L - front_len], [rf, L - front_len], [rf, L - lip]],
        arc((rf - lip, L - lip), lip, 0.0, np.pi / 2, 4)[1:],
        [[0.88 * rl, L], [0.8 * rl, glass_y]],
        arc((0.0, glass_y), (0.8 * rl, 0.2 * front_len), 0.0, np.pi / 2, 6)[1:],
    ])


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    style = int(rng.random() < 0.4)  # 0: DSLR / mirrorless, 1: compact
    W = uniform(rng, 0.09, 0.15)
    Hb = uniform(rng, 0.06, 0.10)
    D = uniform(rng, 0.03, 0.07)
    corner = uniform(rng, 0.004, 0.015)
    rl = uniform(rng, 0.02, min(0.04, (0.42 if style == 0 else 0.34) * Hb, (W - 0.016) / 2.24))
    L = uniform(rng, 0.02, 0.09 if style == 0 else 0.05)  # compacts: shorter, slimmer lenses
    grip_w = uniform(rng, 0.18, 0.3) * W
    grip_d = uniform(rng, 0.1, 0.6) * L  # forwards from the body front
    grip_h = uniform(rng, 0.8, 1.0)
    mount_len = min(uniform(rng, 0.003, 0.008), 0.3 * L)
    front_len = uniform(rng, 0.15, 0.3) * L
    n_ribs = int(rng.integers(6, 14))
    hump_h = uniform(rng, 0.012, 0.025)
    hump_w = uniform(rng, 0.3, 0.45) * W
    button_r = uniform(rng, 0.0035, 0.006)
    dial_r = uniform(rng, 0.007, 0.012)
    screen_frac = uniform(rng, 0.5, 0.7)

    rm = 1.12 * rl
    # lens position: right of the grip (the grip narrows if needed), vertically inside the body when possible
    x_hi = W / 2 - rm - 0.002
    x_l = float(np.clip(uniform(rng, 0.0, 0.12) * W, rm + 0.014 - W / 2, x_hi))
    grip_w = float(np.clip(W / 2 + x_l - rm - 0.002, 0.012, grip_w))
    y_room = max(0.0, Hb / 2 - rm - 0.002)
    y_l = -uniform(rng, 0.0, 0.6) * y_room if style == 0 else uniform(rng, -0.3, 0.3) * y_room

    meshes = [rounded_slab((W, Hb, D), corner, axis="z")]
    gh = grip_h * Hb
    gsize = (grip_w, gh, D + grip_d)
    meshes.append(rounded_slab(gsize, 0.45 * min(grip_w, D + grip_d), axis="y", center=(-W / 2 + grip_w / 2, -Hb / 2 + gh / 2, grip_d / 2), n_corner=8))

    lens = revolve_profile(_lens_profile(rl, L, mount_len, front_len, n_ribs), 48, closed=False)
    meshes.append(transformed(lens, _Y_TO_Z, (x_l, y_l, D / 2)))

    top = Hb / 2
    x_btn = -W / 2 + grip_w / 2
    meshes.append(cylinder(button_r, 0.003, center=(x_btn, top + 0.0015, D / 2 - 0.012), sections=20))
    meshes.append(cylinder(button_r * 1.5, 0.0015, center=(x_btn, top + 0.00075, D / 2 - 0.012), sections=20))
    # mode dial at the back of the +x top; the viewfinder hump must leave room for it
    x_dial = W / 2 - dial_r - 0.006
    room = 2.0 * (x_dial - dial_r - 0.003 - x_l)
    has_dial = int(style == 1 or room >= 0.25 * W)
    if style == 0 and has_dial:
        hump_w = min(hump_w, room)
    if has_dial:
        meshes.append(cylinder(dial_r, 0.006, center=(x_dial, top + 0.003, -D / 2 + dial_r + 0.004), sections=24))
    if style == 0:  # viewfinder hump (trapezoid) over the lens, hot shoe, eyepiece
        hd = 0.75 * D
        tw = 0.45 * hump_w
        poly = np.array([[-hump_w / 2, 0.0], [hump_w / 2, 0.0], [tw / 2, hump_h], [-tw / 2, hump_h]])
        meshes.append(transformed(extrude(poly, hd, plane="xy"), None, (x_l, top - 0.001, -D / 2 + hd / 2)))
        meshes.append(box((0.6 * tw, 0.003, 0.6 * hd), (x_l, top - 0.001 + hump_h + 0.0015, -D / 2 + hd / 2)))
        meshes.append(rounded_slab((0.022, 0.016, 0.012), 0.004, axis="z", center=(x_l, top + 0.4 * hump_h, -D / 2 - 0.004)))
    else:  # compact: flash window and viewfinder window on the front face, top plate strip
        meshes.append(boxes(
            np.array([[W / 2 - 0.016, top - 0.012, D / 2 + 0.0006], [x_l - 0.5 * rl, top - 0.01, D / 2 + 0.0006]]),
            np.array([[0.018, 0.009, 0.0012], [0.01, 0.007, 0.0012]]),
        ))
    # screen on the back
    sw, sh = screen_frac * W, 0.62 * Hb
    meshes.append(box((sw, sh, 0.002), (W / 2 - sw / 2 - 0.08 * W, -0.05 * Hb, -D / 2 - 0.0008)))

    params = dict(
        style=style, width=W, height=Hb, depth=D, corner_radius=corner, lens_radius=rl, lens_length=L,
        lens_x=x_l, lens_y=y_l, grip_width=grip_w, grip_depth=grip_d, grip_height=grip_h, mount_length=mount_len,
        front_ring_length=front_len, n_ribs=n_ribs, hump_height=hump_h, hump_width=hump_w,
        button_radius=button_r, dial_radius=dial_r, has_dial=has_dial, screen_frac=screen_frac,
    )
    return rigid_object("camera", instance_id, meshes, "none", params)


SPEC = CategorySpec(
    name="camera",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("none",),
    distance_range_m=(0.35, 0.8),
    elevation_range_deg=(10.0, 60.0),
    build=build,
    description="photo camera: rounded body, -x grip, lens barrel along +z, top controls (DSLR or compact)",
)
