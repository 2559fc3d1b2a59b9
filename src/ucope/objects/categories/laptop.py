"""Laptop (ArtImage-like, articulated): parts ``("base", "lid")``, one revolute joint.

Object frame (y up, x right, z towards the viewer / the laptop's front; metres; origin at the base's
amodal box centre):

* ``base``: the keyboard slab lying in the x-z plane (width along x, depth along z towards the user),
  with a recessed key well holding a grid of keys, a touchpad on the palm rest, rubber feet underneath
  and a rounded outline; a wedge base is thick at the hinge and thin at the front (flat top).
* ``lid``: the screen slab (same width and depth) with a bezel, a screen panel on its inner face, a
  camera dot and a logo on its back.
* Joint ``base -> lid`` (revolute): hinge line along x at the back top edge of the base
  (``z = -depth/2``, ``y`` = top of the base). State 0 is CLOSED (lid lying on the base, screen down).
  Axis ``(-1, 0, 0)``, so a positive angle opens the lid (its front edge goes up); at ``pi/2`` the lid
  stands vertical behind the hinge. Limits ``(0.35, 2.6)`` rad (about 20 to 150 degrees), rest 1.57.

Shape families (shared with ``laptop_rigid``; width W along x, depth D along z, base thickness T (feet
included), lid thickness; metres; W = 0.27-0.41 spans 11.6 to 18 inch screens):

=========== ============ ============ ============== ============== ================================
family      W            D / W        base T         lid            look
=========== ============ ============ ============== ============== ================================
ultrabook   0.280-0.360  0.66-0.72    0.008-0.014    0.0035-0.006   thin, narrow bezels
mainstream  0.270-0.380  0.64-0.72    0.016-0.024    0.005-0.009    classic consumer / business laptop
gaming      0.350-0.410  0.68-0.78    0.022-0.034    0.007-0.012    thick base, large
rugged      0.280-0.350  0.72-0.90    0.030-0.045    0.014-0.028    thick base and lid, big corner radii and bezels
wedge       0.280-0.340  0.66-0.72    0.013-0.018    0.004-0.006    base tapering to 3-6 mm at the front (held out)
=========== ============ ============ ============== ============== ================================
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import boxes, clip_convex, combine, disc, extrude, rounded_rect
from . import CategorySpec, ShapeFamily

__all__ = ["SPEC", "build"]

LIMITS = (0.35, 2.6)
REST = 1.57

FAMILIES = (
    ShapeFamily("ultrabook", "thin and light 13-16 inch laptop: thin base and lid"),
    ShapeFamily("mainstream", "classic 11.6-16 inch consumer / business laptop"),
    ShapeFamily("gaming", "15.6-18 inch gaming / workstation laptop: thick base"),
    ShapeFamily("rugged", "rugged / semi-rugged laptop: thick base and lid, large corner radii and bezels"),
    ShapeFamily("wedge", "wedge-shaped base thick at the hinge, thin at the front", held_out=True),
)

# per family: (lo, hi) of width W, depth / W, base thickness (at the hinge), lid thickness, corner radius, bezel (m)
RANGES = {
    "ultrabook": dict(
        width=(0.280, 0.360),
        depth_ratio=(0.66, 0.72),
        base=(0.008, 0.014),
        lid=(0.0035, 0.006),
        corner=(0.006, 0.014),
        bezel=(0.004, 0.008),
    ),
    "mainstream": dict(
        width=(0.270, 0.380),
        depth_ratio=(0.64, 0.72),
        base=(0.016, 0.024),
        lid=(0.005, 0.009),
        corner=(0.004, 0.012),
        bezel=(0.006, 0.014),
    ),
    "gaming": dict(
        width=(0.350, 0.410),
        depth_ratio=(0.68, 0.78),
        base=(0.022, 0.034),
        lid=(0.007, 0.012),
        corner=(0.003, 0.010),
        bezel=(0.006, 0.014),
    ),
    "rugged": dict(
        width=(0.280, 0.350),
        depth_ratio=(0.72, 0.90),
        base=(0.030, 0.045),
        lid=(0.014, 0.028),
        corner=(0.015, 0.030),
        bezel=(0.015, 0.030),
    ),
    "wedge": dict(
        width=(0.280, 0.340),
        depth_ratio=(0.66, 0.72),
        base=(0.013, 0.018),
        lid=(0.004, 0.006),
        corner=(0.006, 0.012),
        bezel=(0.005, 0.010),
    ),
}
WEDGE_FRONT = (0.003, 0.006)
"""Thickness of a wedge base at its front edge (feet excluded), metres."""


def draw_dimensions(rng: np.random.Generator, family: str) -> dict:
    """The main dimensions of a laptop of ``family`` (metres; shared with ``laptop_rigid``): ``width``,
    ``depth``, ``base`` (thickness at the hinge, feet included), ``front`` (thickness at the front edge:
    ``base`` except for a wedge), ``lid``, ``corner`` (radius of the outline's corners) and ``bezel``."""
    rg = RANGES[family]
    W = float(rng.uniform(*rg["width"]))
    D = W * float(rng.uniform(*rg["depth_ratio"]))
    T = float(rng.uniform(*rg["base"]))
    front = float(rng.uniform(*WEDGE_FRONT))
    return dict(
        width=W,
        depth=D,
        base=T,
        front=front if family == "wedge" else T,
        lid=float(rng.uniform(*rg["lid"])),
        corner=float(rng.uniform(*rg["corner"])),
        bezel=float(rng.uniform(*rg["bezel"])),
    )


def build(rng: np.random.Generator, instance_id: str, family: str = "mainstream") -> ArticulatedObject:
    """A random laptop of shape ``family``; see the module docstring for the frame and joint conventions."""
    dims = draw_dimensions(rng, family)
    W, D, T, t_lid, corner, bezel = (dims[k] for k in ("width", "depth", "base", "lid", "corner", "bezel"))
    foot_h = rng.uniform(0.0012, 0.0025)
    gap = rng.uniform(0.0005, 0.0012)  # lid bottom above base top when closed
    well = rng.uniform(0.0008, 0.0016)  # key-well depth
    kb_w = W * rng.uniform(0.80, 0.90)  # keyboard area
    kb_d = D * rng.uniform(0.38, 0.46)
    kb_back = D * rng.uniform(0.06, 0.11)  # margin from the back edge to the keyboard
    n_cols = int(rng.integers(13, 16))
    n_rows = int(rng.integers(5, 7))
    key_gap = rng.uniform(0.12, 0.22)  # fraction of the key pitch
    tp_w = min(W * rng.uniform(0.28, 0.42), kb_w * 0.6)
    tp_d_frac = rng.uniform(0.55, 0.75)
    bezel_top = bezel + rng.uniform(0.0, 0.008)
    wedge = family == "wedge"

    parts_base = []
    y_body_lo = foot_h
    outline = rounded_rect(W, D, corner, 5)
    # body below the key-well floor, and the deck (a frame around the key well) up to the top
    y_front = T - dims["front"]  # the body's bottom at the front edge (= foot_h unless a wedge)
    if wedge:  # trapezoid cross-section in the y-z plane, extruded along x: bottom rising towards the front
        section = np.array([[y_body_lo, -D / 2], [y_front, D / 2], [T - well, D / 2], [T - well, -D / 2]])
        parts_base.append(extrude(section, W, plane="yz"))
    else:
        parts_base.append(extrude(outline, T - foot_h - well, plane="xz", offset=0.5 * (y_body_lo + T - well)))
    kb_z0 = -D / 2 + kb_back  # back edge of the keyboard area
    kb_z1 = kb_z0 + kb_d
    # the deck: the outline minus the key well, as four convex pieces (back, front, left, right)
    yc = T - well / 2
    mid = clip_convex(clip_convex(outline, 1, kb_z0, "above"), 1, kb_z1, "below")
    for piece in (
        clip_convex(outline, 1, kb_z0, "below"),
        clip_convex(outline, 1, kb_z1, "above"),
        clip_convex(mid, 0, -kb_w / 2, "below"),
        clip_convex(mid, 0, kb_w / 2, "above"),
    ):
        parts_base.append(extrude(piece, well, plane="xz", offset=yc))
    # keys: a grid, function row slimmer, space bar wide
    pitch_x = kb_w / n_cols
    pitch_z = kb_d / n_rows
    cols, rows = np.meshgrid(np.arange(n_cols), np.arange(n_rows))
    kx = -kb_w / 2 + (cols + 0.5) * pitch_x
    kz = kb_z0 + (rows + 0.5) * pitch_z
    ex = np.full(kx.shape, pitch_x * (1 - key_gap))
    ez = np.full(kx.shape, pitch_z * (1 - key_gap))
    ez[0] *= 0.6  # function row
    keep = np.ones(kx.shape, bool)
    space_lo, space_hi = int(n_cols * 0.3), int(n_cols * 0.7)
    keep[-1, space_lo:space_hi] = False
    key_c = np.c_[kx[keep], np.zeros(keep.sum()), kz[keep]]
    key_e = np.c_[ex[keep], np.zeros(keep.sum()), ez[keep]]
    space_c = [[0.5 * (kx[-1, space_lo] + kx[-1, space_hi - 1]), 0.0, kz[-1, 0]]]
    space_e = [[(space_hi - space_lo) * pitch_x - key_gap * pitch_x, 0.0, pitch_z * (1 - key_gap)]]
    key_c = np.concatenate([key_c, space_c])
    key_e = np.concatenate([key_e, space_e])
    key_h = well * rng.uniform(0.6, 0.85)
    key_c[:, 1] = T - well + key_h / 2
    key_e[:, 1] = key_h
    parts_base.append(boxes(key_c, key_e))
    # touchpad: a thin plate on the palm rest, centred left-right
    palm_d = D / 2 - kb_z1
    tp_d = palm_d * tp_d_frac
    tp_z = kb_z1 + 0.5 * palm_d
    # (0.3 mm thick, 0.2 mm proud of the deck: below the closed lid, which floats `gap` >= 0.5 mm above)
    parts_base.append(extrude(rounded_rect(tp_w, tp_d, 0.003, 3, center=(0.0, tp_z)), 0.0003, plane="xz", offset=T + 0.00005))
    fx = W / 2 - max(corner, 0.012) - 0.008
    fz = D / 2 - max(corner, 0.012) - 0.006
    # rubber feet (under a wedge, the front ones are taller: they reach up to the sloping bottom)
    foot_top = lambda z: foot_h + (y_front - foot_h) * (z + D / 2) / D + 0.0003 if wedge else foot_h  # noqa: E731
    feet = [
        disc(0.005, foot_top(sz * fz), (sx * fx, foot_top(sz * fz) / 2, sz * fz), "y", 12) for sx in (-1, 1) for sz in (-1, 1)
    ]
    parts_base.extend(feet)
    base_mesh = combine(parts_base)

    # lid (state 0: closed, screen facing down)
    y0 = T + gap
    screen_t = 0.0003
    lid_parts = [extrude(outline, t_lid - screen_t, plane="xz", offset=y0 + screen_t + 0.5 * (t_lid - screen_t))]
    scr_w = W - 2 * bezel
    scr_d = D - bezel - bezel_top
    scr_z = -D / 2 + bezel + scr_d / 2  # the lid's back (hinge) edge has the thin bezel
    lid_parts.append(boxes([[0.0, y0 + screen_t / 2 + 1e-5, scr_z]], [[scr_w, screen_t, scr_d]]))
    lid_parts.append(disc(0.0012, screen_t, (0.0, y0 + screen_t / 2, D / 2 - bezel_top / 2), "y", 10))
    logo_r = rng.uniform(0.010, 0.018)
    lid_parts.append(disc(logo_r, 0.0002, (0.0, y0 + t_lid + 0.0001, 0.0), "y", 20))
    lid_mesh = combine(lid_parts)

    base, T_base = make_part("base", base_mesh)
    lid, T_lid = make_part("lid", lid_mesh)
    params = dict(
        width=W,
        depth=D,
        base_thickness=T,
        base_front_thickness=dims["front"],
        lid_thickness=t_lid,
        corner_radius=corner,
        foot_height=foot_h,
        closed_gap=gap,
        key_well_depth=well,
        keyboard_width=kb_w,
        keyboard_depth=kb_d,
        keyboard_back_margin=kb_back,
        key_columns=n_cols,
        key_rows=n_rows,
        key_gap_fraction=key_gap,
        touchpad_width=tp_w,
        touchpad_depth=tp_d,
        bezel=bezel,
        bezel_top=bezel_top,
        logo_radius=logo_r,
    )
    return build_object(
        "laptop",
        instance_id,
        [(base, T_base), (lid, T_lid)],
        joints=[
            dict(type="revolute", parent=0, child=1, pivot=(0.0, T, -D / 2), axis=(-1.0, 0.0, 0.0), limits=LIMITS, rest=REST)
        ],
        params=params,
        shape_family=family,
    )


SPEC = CategorySpec(
    name="laptop",
    family="artimage",
    part_names=("base", "lid"),
    joint_types=("revolute",),
    symmetry=("none", "none"),
    distance_range_m=(0.55, 1.3),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="laptop: keyboard base + screen lid on a revolute hinge (opens 20-150 degrees)",
)
