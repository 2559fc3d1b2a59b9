"""Camera (NOCS-like, rigid): a photo camera with a body, a grip, a lens barrel and top controls.

Frame (NOCS): y up, x right, z towards the front: the lens points along +z; the grip is on the -x
side (the photographer's right hand: seen from the front, the grip is on the viewer's left); the
viewfinder hump / controls are on top (+y); the screen is on the back (-z). Metres; the amodal box
(lens included) is centred on the origin. Symmetry ``"none"``.

Geometry: a body box with rounded front-view corners; on the photo cameras a grip block with rounded
edges on the -x end, protruding forwards; a revolved lens right of the grip (a mount ring, the barrel,
a ribbed focus ring, a front ring with a rounded lip and a recessed glass dome; short lenses: a stepped
ring and the glass); on top a shutter button (over the grip) and a mode dial (when the hump leaves room);
a viewfinder hump with a hot shoe over the lens and an eyepiece at the back (DSLRs, most mirrorless), or
a flash window and a viewfinder window on the front (compacts); a screen on the back. The action camera
is a rounded box with a small lens near its +x top corner, a square front screen at -x, a shutter button
on top and a large back screen.

Shape families (body width W along x, body height H without the hump, body depth D without grip and
lens, lens radius and length; metres):

=========== ============ ============ ============ ============== ============== =========================
family      W            H            D            lens radius    lens length    other
=========== ============ ============ ============ ============== ============== =========================
dslr        0.125-0.150  0.075-0.095  0.045-0.065  0.030-0.040    0.045-0.110    hump 15-25 mm, grip 20-35 mm
mirrorless  0.110-0.135  0.062-0.085  0.032-0.050  0.026-0.034    0.020-0.090    hump 0-20 mm (30 % none)
compact     0.095-0.115  0.055-0.068  0.025-0.042  0.014-0.022    0.004-0.030    flash window, small grip
action      0.060-0.075  0.040-0.056  0.020-0.034  0.008-0.012    0.004-0.010    box, no grip (held out)
=========== ============ ============ ============ ============== ============== =========================

Half of the compacts take the ultra-compact layout (:data:`ULTRA_COMPACT`): depth 0.018-0.026, lens radius
0.010-0.015 and length at most 0.012, the lens in the top corner away from the grip, a flat front without a
grip block or mode dial, the flash window in the grip-side top corner, a back screen 65-80 % of the width.
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, box, boxes, cylinder, extrude, revolve_profile, rounded_slab, transformed
from . import CategorySpec, ShapeFamily
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
    return np.concatenate(
        [
            [[0.0, -0.003], [rm, -0.003], [rm, mount_len], [rl, mount_len], [rl, y_focus0]],
            np.stack([focus_r, f], -1),
            [[rl, y_focus1], [0.98 * rl, y_focus1 + 0.001], [0.98 * rl, L - front_len], [rf, L - front_len], [rf, L - lip]],
            arc((rf - lip, L - lip), lip, 0.0, np.pi / 2, 4)[1:],
            [[0.88 * rl, L], [0.8 * rl, glass_y]],
            arc((0.0, glass_y), (0.8 * rl, 0.2 * front_len), 0.0, np.pi / 2, 6)[1:],
        ]
    )


def _short_lens_profile(rl: float, L: float) -> np.ndarray:
    """Open (r, y) profile of a short lens (compacts, action cameras): a stepped ring and a glass dome."""
    rm = 1.15 * rl
    lip = min(0.001, 0.2 * L)
    return np.concatenate(
        [
            [[0.0, -0.003], [rm, -0.003], [rm, 0.45 * L], [rl, 0.45 * L], [rl, L - lip]],
            arc((rl - lip, L - lip), lip, 0.0, np.pi / 2, 4)[1:],
            [[0.82 * rl, L], [0.75 * rl, 0.75 * L]],
            arc((0.0, 0.75 * L), (0.75 * rl, 0.15 * L), 0.0, np.pi / 2, 6)[1:],
        ]
    )


FAMILIES = (
    ShapeFamily("dslr", "DSLR with a kit or zoom lens, viewfinder hump, deep grip"),
    ShapeFamily("mirrorless", "mirrorless system camera: slimmer body, pancake to zoom lens"),
    ShapeFamily("compact", "compact camera: small body, short retracting lens, flash window"),
    ShapeFamily("action", "action camera: a small rounded box with a small lens", held_out=True),
)

# the share of compacts built in the ultra-compact layout (Canon IXUS / ELPH, Sony Cyber-shot W, Nikon Coolpix S
# class): a slim flat-fronted body, a small lens in the top corner away from the grip (+x), no grip, no mode
# dial, a flash window in the other top corner, a larger back screen; its ranges replace the compact's
ULTRA_COMPACT = dict(lens_r=(0.010, 0.015), depth=(0.018, 0.026), lens_len_max=0.012, screen_frac=(0.65, 0.8))
P_ULTRA_COMPACT = 0.5

# per family: (lo, hi) of body width, height, depth, lens radius and length, grip protrusion, hump height (m)
RANGES = {
    "dslr": dict(
        width=(0.125, 0.150),
        height=(0.075, 0.095),
        depth=(0.045, 0.065),
        lens_r=(0.030, 0.040),
        lens_len=(0.045, 0.110),
        grip=(0.020, 0.035),
        hump=(0.015, 0.025),
        p_hump=1.0,
    ),
    "mirrorless": dict(
        width=(0.110, 0.135),
        height=(0.062, 0.085),
        depth=(0.032, 0.050),
        lens_r=(0.026, 0.034),
        lens_len=(0.020, 0.090),
        grip=(0.010, 0.025),
        hump=(0.010, 0.020),
        p_hump=0.7,
    ),
    "compact": dict(
        width=(0.095, 0.115),
        height=(0.055, 0.068),
        depth=(0.025, 0.042),
        lens_r=(0.014, 0.022),
        lens_len=(0.004, 0.030),
        grip=(0.002, 0.008),
        hump=(0.0, 0.0),
        p_hump=0.0,
    ),
    "action": dict(
        width=(0.060, 0.075),
        height=(0.040, 0.056),
        depth=(0.020, 0.034),
        lens_r=(0.008, 0.012),
        lens_len=(0.004, 0.010),
        grip=(0.0, 0.0),
        hump=(0.0, 0.0),
        p_hump=0.0,
    ),
}


def build(rng: np.random.Generator, instance_id: str, family: str = "dslr") -> ArticulatedObject:
    """A random camera of shape ``family``; see the module docstring for the frame and the ranges."""
    rg = RANGES[family]
    W = uniform(rng, *rg["width"])
    Hb = uniform(rng, *rg["height"])
    D = uniform(rng, *rg["depth"])
    corner = uniform(rng, 0.004, 0.012) if family != "action" else uniform(rng, 0.004, 0.009)
    rl = uniform(rng, *rg["lens_r"])
    L = uniform(rng, *rg["lens_len"])
    grip_w = uniform(rng, 0.18, 0.3) * W
    grip_d = uniform(rng, *rg["grip"])  # forwards from the body front
    grip_h = uniform(rng, 0.8, 1.0)
    has_hump = int(rng.random() < rg["p_hump"])
    hump_h = uniform(rng, *rg["hump"])
    hump_w = uniform(rng, 0.3, 0.45) * W
    mount_len = min(uniform(rng, 0.003, 0.008), 0.3 * L)
    front_len = uniform(rng, 0.15, 0.3) * L
    n_ribs = int(rng.integers(6, 14))
    button_r = uniform(rng, 0.0035, 0.006) if family != "action" else uniform(rng, 0.003, 0.0045)
    dial_r = uniform(rng, 0.007, 0.012)
    screen_frac = uniform(rng, 0.5, 0.7) if family != "action" else uniform(rng, 0.75, 0.85)
    lens_u = uniform(rng, 0.0, 1.0)  # lens placement within its allowed range
    lens_v = uniform(rng, 0.0, 1.0)
    front_screen = uniform(rng, 0.36, 0.45)  # action: front screen size, fraction of the height
    # compacts: the ultra-compact layout, drawn last so that every other draw of the stream is unchanged
    ultra = family == "compact" and bool(rng.random() < P_ULTRA_COMPACT)
    if ultra:
        rl = uniform(rng, *ULTRA_COMPACT["lens_r"])
        D = uniform(rng, *ULTRA_COMPACT["depth"])
        L = min(L, ULTRA_COMPACT["lens_len_max"])
        screen_frac = uniform(rng, *ULTRA_COMPACT["screen_frac"])
        grip_d = 0.0

    rl = min(rl, 0.45 * Hb, (W - 0.016) / 2.4)
    L = max(L, grip_d + 0.005)  # the lens is the front-most part
    rm = 1.12 * rl if L >= 0.015 else 1.15 * rl
    top = Hb / 2
    meshes = [rounded_slab((W, Hb, D), corner, axis="z")]
    if family == "action":
        # lens near the +x top corner, square front screen at -x, shutter button on top, big back screen
        x_l = W / 2 - rm - 0.003 - 0.004 * lens_u
        y_l = Hb / 2 - rm - 0.003 - 0.004 * lens_v
        grip_w = grip_d = 0.0
        lens = revolve_profile(_short_lens_profile(rl, L), 32, closed=False)
        meshes.append(transformed(lens, _Y_TO_Z, (x_l, y_l, D / 2)))
        fs = front_screen * Hb
        meshes.append(rounded_slab((fs, fs, 0.0016), 0.002, axis="z", center=(-W / 2 + fs / 2 + 0.005, 0.0, D / 2 + 0.0006)))
        x_btn = -W / 4
        meshes.append(cylinder(button_r, 0.003, center=(x_btn, top + 0.0012, 0.0), sections=16))
        has_dial = 0
    else:
        if ultra:  # lens in the top corner away from the grip, a flat front (no grip block)
            x_l = W / 2 - rm - 0.004 - 0.004 * lens_u
            y_l = Hb / 2 - rm - 0.004 - 0.004 * lens_v
            grip_w = 0.0
        else:
            x_l = float(np.clip((0.12 * lens_u) * W, rm + 0.014 - W / 2, W / 2 - rm - 0.002))
            grip_w = float(np.clip(W / 2 + x_l - rm - 0.002, 0.012, grip_w))
            y_room = max(0.0, Hb / 2 - rm - 0.002)
            y_l = -0.6 * lens_v * y_room if family == "dslr" else (lens_v - 0.5) * 0.6 * y_room
            gh = grip_h * Hb
            gsize = (grip_w, gh, D + grip_d)
            meshes.append(
                rounded_slab(
                    gsize,
                    0.45 * min(grip_w, D + grip_d),
                    axis="y",
                    center=(-W / 2 + grip_w / 2, -Hb / 2 + gh / 2, grip_d / 2),
                    n_corner=8,
                )
            )
        prof = _lens_profile(rl, L, mount_len, front_len, n_ribs) if L >= 0.015 else _short_lens_profile(rl, L)
        lens = revolve_profile(prof, 48, closed=False)
        meshes.append(transformed(lens, _Y_TO_Z, (x_l, y_l, D / 2)))
        x_btn = -W / 2 + grip_w / 2 if not ultra else -W / 4
        z_btn = D / 2 - 0.012 if not ultra else 0.0
        meshes.append(cylinder(button_r, 0.003, center=(x_btn, top + 0.0015, z_btn), sections=20))
        meshes.append(cylinder(button_r * 1.5, 0.0015, center=(x_btn, top + 0.00075, z_btn), sections=20))
        # mode dial at the back of the +x top; the viewfinder hump must leave room for it
        x_dial = W / 2 - dial_r - 0.006
        room = 2.0 * (x_dial - dial_r - 0.003 - x_l)
        has_dial = int(not ultra and (not has_hump or room >= 0.25 * W))
        if has_hump and has_dial:
            hump_w = min(hump_w, room)
        if has_dial:
            meshes.append(cylinder(dial_r, 0.006, center=(x_dial, top + 0.003, -D / 2 + dial_r + 0.004), sections=24))
        if has_hump:  # viewfinder hump (trapezoid) over the lens, hot shoe, eyepiece
            hd = 0.75 * D
            tw = 0.45 * hump_w
            poly = np.array([[-hump_w / 2, 0.0], [hump_w / 2, 0.0], [tw / 2, hump_h], [-tw / 2, hump_h]])
            meshes.append(transformed(extrude(poly, hd, plane="xy"), None, (x_l, top - 0.001, -D / 2 + hd / 2)))
            meshes.append(box((0.6 * tw, 0.003, 0.6 * hd), (x_l, top - 0.001 + hump_h + 0.0015, -D / 2 + hd / 2)))
            meshes.append(
                rounded_slab(
                    (0.022, min(0.016, 0.8 * hump_h + 0.006), 0.012),
                    0.004,
                    axis="z",
                    center=(x_l, top + 0.4 * hump_h, -D / 2 - 0.004),
                )
            )
        if ultra:  # flash window in the top corner on the grip side
            meshes.append(box((0.014, 0.007, 0.0012), (-W / 2 + 0.012, top - 0.008, D / 2 + 0.0006)))
        elif family == "compact":  # flash window and viewfinder window on the front face
            meshes.append(
                boxes(
                    np.array([[W / 2 - 0.016, top - 0.012, D / 2 + 0.0006], [x_l - 0.5 * rl, top - 0.01, D / 2 + 0.0006]]),
                    np.array([[0.018, 0.009, 0.0012], [0.01, 0.007, 0.0012]]),
                )
            )
    # screen on the back
    sw, sh = screen_frac * W, (0.62 if family != "action" else 0.8) * Hb
    x_screen = W / 2 - sw / 2 - 0.08 * W if family != "action" else 0.0
    meshes.append(box((sw, sh, 0.002), (x_screen, -0.05 * Hb if family != "action" else 0.0, -D / 2 - 0.0008)))

    params = dict(
        width=W,
        height=Hb,
        depth=D,
        corner_radius=corner,
        lens_radius=rl,
        lens_length=L,
        lens_x=x_l,
        lens_y=y_l,
        grip_width=grip_w,
        grip_depth=grip_d,
        grip_height=grip_h,
        mount_length=mount_len,
        front_ring_length=front_len,
        n_ribs=n_ribs,
        has_hump=has_hump,
        hump_height=hump_h if has_hump else 0.0,
        hump_width=hump_w if has_hump else 0.0,
        button_radius=button_r,
        dial_radius=dial_r,
        has_dial=has_dial,
        screen_frac=screen_frac,
        ultra_compact=int(ultra),
    )
    return rigid_object("camera", instance_id, meshes, "none", params, family)


SPEC = CategorySpec(
    name="camera",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("none",),
    distance_range_m=(0.3, 0.8),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="camera: rounded body, -x grip, lens along +z, top controls (DSLR, mirrorless, compact, action camera)",
    revision=2,  # 2: half of the compacts in the ultra-compact layout
)
