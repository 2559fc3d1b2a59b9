"""Dishwasher (ArtImage-like, articulated): parts ``("body", "door")``, one revolute joint.

Object frame (y up, x right, z towards the viewer / the front of the machine; metres; origin at the
body's amodal box centre):

* ``body``: the cabinet and tub, an open box (open at the front, +z) with side, top, back walls, a tub
  floor above the kick zone, a recessed kick plate (feet on a countertop machine), one to three wire racks
  (rim loops, bottom grid, posts, plate tines on the lower rack; the third one a flat cutlery tray) on side
  rails, and spray arms; a freestanding machine carries a worktop lid.
* ``door``: the front slab above the kick plate (under the worktop), with a control panel strip (buttons,
  display) and a handle (a bar on stand-offs, or a pull lip under the panel) on its front, or, fully
  integrated, a plain furniture front with the controls on its top edge and a bar handle or none; an
  inner liner and a detergent dispenser on its back.
* Joint ``body -> door`` (revolute): hinge line along x at the bottom front edge of the door (``y`` =
  top of the kick zone, ``z`` = front face of the door). State 0 is CLOSED. Axis ``(+1, 0, 0)``, so a
  positive angle opens the door downwards / forwards (its top edge moves to +z); at ``pi/2`` it lies
  horizontal in front of the tub. Limits ``(0, 1.57)`` rad, rest 0.

Shape families (width W, height H, depth D with the door, metres; typical dimensions of European
built-under dishwashers, which fill the 60 or 45 cm wide, 82-87 cm high kitchen-module niches of the
co-ordinating sizes of EN 1116, and of 24 inch US machines):

============== ======================== ============== ============== ==============================================
family         W                        H              D              look
============== ======================== ============== ============== ==============================================
freestanding   0.595-0.610              0.815-0.890    0.570-0.630    60 cm EU / 24 inch US; worktop lid, door panel
slim           0.445-0.450              0.815-0.860    0.550-0.630    45 cm; worktop lid (50 %), door panel
integrated     0.446-0.450, 0.594-0.598 0.815-0.870    0.550-0.575    furniture front, controls on the door's top edge
countertop     0.540-0.560              0.430-0.500    0.480-0.520    on short feet, one rack (held out)
============== ======================== ============== ============== ==============================================

Full-size machines have two racks and, half of them, a third cutlery tray at the top. Half of the integrated
machines are compact built-ins (:data:`COMPACT_BUILT_IN`: 0.594-0.598 wide, 0.445-0.460 high, 0.550-0.575 deep,
a 20-35 mm base instead of the plinth, two racks), the 45 cm high machines for a niche in a tall unit.
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import boxes, combine, disc, extrude, open_box, rounded_rect, sweep_planar
from . import CategorySpec, ShapeFamily
from .helpers import build_with_variant

__all__ = ["SPEC", "build"]

LIMITS = (0.0, 1.57)
REST = 0.0


def _rack(rng: np.random.Generator, w: float, d: float, h: float, y0: float, zc: float, tines: bool, rod: float):
    """A wire rack (bottom loop, top loop, posts, bottom grid, optional plate tines) centred at (0, y0, zc)."""
    parts = []
    loop = rounded_rect(w, d, 0.02, 4)
    for y in (y0, y0 + h):
        path = np.stack([loop[:, 0], np.full(len(loop), y), loop[:, 1] + zc], -1)
        parts.append(sweep_planar(path, (0, 1, 0), rod, rod, sections=6, closed=True))
    n_z = int(rng.integers(9, 15))  # grid wires running front-back
    xs = np.linspace(-w / 2, w / 2, n_z + 2)[1:-1]
    n_x = int(rng.integers(3, 6))
    zs = np.linspace(zc - d / 2, zc + d / 2, n_x + 2)[1:-1]
    c = [np.c_[xs, np.full(n_z, y0), np.full(n_z, zc)], np.c_[np.zeros(n_x), np.full(n_x, y0), zs]]
    e = [np.tile([2 * rod, 2 * rod, d], (n_z, 1)), np.tile([w, 2 * rod, 2 * rod], (n_x, 1))]
    # posts: corners and side midpoints
    px = np.array([-1, 1, -1, 1, -1, 1]) * (w / 2 - 0.01)
    pz = zc + np.array([-1, -1, 1, 1, 0, 0]) * (d / 2 - 0.01)
    c.append(np.c_[px, np.full(6, y0 + h / 2), pz])
    e.append(np.tile([2 * rod, h, 2 * rod], (6, 1)))
    if tines:
        n_t = int(rng.integers(8, 14))
        tx = np.linspace(-w / 2 + 0.04, w / 2 - 0.04, n_t)
        th = h * rng.uniform(1.2, 1.8)
        for zt in (zc - d / 6, zc + d / 6):
            c.append(np.c_[tx, np.full(n_t, y0 + th / 2), np.full(n_t, zt)])
            e.append(np.tile([1.6 * rod, th, 1.6 * rod], (n_t, 1)))
    parts.append(boxes(np.concatenate(c), np.concatenate(e)))
    return parts


def _spray_arm(length: float, width: float, y: float, zc: float, angle: float):
    """A flat spray arm (rotated bar) with a hub."""
    rect = np.array([[-length / 2, -width / 2], [length / 2, -width / 2], [length / 2, width / 2], [-length / 2, width / 2]])
    c, s = np.cos(angle), np.sin(angle)
    rect = rect @ np.array([[c, s], [-s, c]]) + np.array([0.0, zc])
    return [extrude(rect, 0.012, plane="xz", offset=y), disc(0.02, 0.03, (0.0, y - 0.015, zc), "y", 14)]


FAMILIES = (
    ShapeFamily("freestanding", "60 cm (24 inch) freestanding dishwasher with a worktop lid"),
    ShapeFamily("slim", "45 cm slimline dishwasher"),
    ShapeFamily("integrated", "fully integrated dishwasher: furniture front, controls on the door's top edge"),
    ShapeFamily("countertop", "countertop dishwasher, about 55 x 45 x 50 cm, one rack", held_out=True),
)

# per family: (lo, hi) of width, height, depth, door thickness, kick (plinth) height; probability of a worktop lid
RANGES = {
    "freestanding": dict(
        width=(0.595, 0.610), height=(0.815, 0.890), depth=(0.570, 0.630), door=(0.040, 0.070), kick=(0.08, 0.12), p_top=1.0
    ),
    "slim": dict(
        width=(0.445, 0.450), height=(0.815, 0.860), depth=(0.550, 0.630), door=(0.040, 0.070), kick=(0.08, 0.12), p_top=0.5
    ),
    "integrated": dict(
        width=(0.446, 0.598), height=(0.815, 0.870), depth=(0.550, 0.575), door=(0.050, 0.075), kick=(0.09, 0.15), p_top=0.0
    ),
    "countertop": dict(
        width=(0.540, 0.560), height=(0.430, 0.500), depth=(0.480, 0.520), door=(0.035, 0.050), kick=(0.045, 0.065), p_top=0.0
    ),
}


# the share of integrated machines built as compact built-ins (the 45 cm high machines for a 60 cm wide niche in a
# tall unit, e.g. Bosch / Siemens / Neff compact 45 cm, Miele G 4x "compact"): their ranges replace the integrated
# ones; two racks, no third tray, a low base instead of a plinth
COMPACT_BUILT_IN = dict(width=(0.594, 0.598), height=(0.445, 0.460), depth=(0.550, 0.575), kick=(0.020, 0.035))
P_COMPACT_BUILT_IN = 0.5


def build(rng: np.random.Generator, instance_id: str, family: str = "freestanding") -> ArticulatedObject:
    """A random dishwasher of shape ``family``; see the module docstring for the frame and joint conventions.

    An integrated machine is a compact built-in (:data:`COMPACT_BUILT_IN`) with chance
    :data:`P_COMPACT_BUILT_IN`, decided by a draw after all of the machine's own: the instance is then built again
    from the same stream with the compact sizes (drawn after that decision), so every other instance is the
    machine it was before this variant existed."""
    if family != "integrated":
        return _build(rng, instance_id, family, None)
    return build_with_variant(
        rng, lambda r, compact: _build(r, instance_id, family, compact), P_COMPACT_BUILT_IN, COMPACT_BUILT_IN
    )


def _build(rng: np.random.Generator, instance_id: str, family: str, compact: dict | None) -> ArticulatedObject:
    """:func:`build`'s machine; ``compact``: the compact built-in's width, height, depth and base height, which
    replace the drawn ones (the draws are made all the same)."""
    rg = RANGES[family]
    W = rng.uniform(*rg["width"])
    if family == "integrated":  # a 45 cm or a 60 cm niche
        W = (0.446 if rng.random() < 0.5 else 0.594) + rng.uniform(0.0, 0.004)
    H = rng.uniform(*rg["height"])
    D = rng.uniform(*rg["depth"])  # door included
    Td = rng.uniform(*rg["door"])
    wt = rng.uniform(0.012, 0.022)  # wall thickness
    kick_h = rng.uniform(*rg["kick"])
    if compact is not None:
        W, H, D, kick_h = compact["width"], compact["height"], compact["depth"], compact["kick"]
    kick_recess = rng.uniform(0.01, 0.05)
    panel_h = rng.uniform(0.06, 0.10) if family != "countertop" else rng.uniform(0.05, 0.07)
    panel_proud = rng.uniform(0.002, 0.006)
    handle_type = int(rng.integers(0, 2))  # 0: bar on stand-offs, 1: pull lip under the control panel (integrated: none)
    handle_len = W * rng.uniform(0.45, 0.85)
    handle_r = rng.uniform(0.008, 0.013)
    handle_off = rng.uniform(0.03, 0.05)  # bar distance from the door
    n_buttons = int(rng.integers(3, 8))
    rack_rod = rng.uniform(0.0018, 0.0028)
    lower_rack_h = rng.uniform(0.09, 0.14) if family != "countertop" else rng.uniform(0.07, 0.10)
    upper_rack_h = rng.uniform(0.07, 0.11)
    upper_frac = rng.uniform(0.50, 0.60)
    arm_angles = rng.uniform(0.0, np.pi, 2)
    has_top = int(rng.random() < rg["p_top"])
    top_t = rng.uniform(0.015, 0.025)  # worktop lid thickness
    top_ov = rng.uniform(0.0, 0.012)  # ... overhang over the door
    third_rack = int(family != "countertop" and rng.random() < 0.5 and compact is None)
    n_racks = 1 if family == "countertop" else 2 + third_rack
    integrated = family == "integrated"
    countertop = family == "countertop"

    H_body = H - top_t if has_top else H  # the tub carcass (the worktop sits on it)
    Db = D - Td - 0.0015  # body depth (the door and its 1.5 mm gap make up the rest)
    zb, zf = -D / 2, -D / 2 + Db  # body back and front planes
    body = []
    body.append(
        open_box(
            (W, H_body, Db), wt, center=(0.0, H_body / 2, zb + Db / 2), open_side="+z", shelves_y=(kick_h - wt / 2 - H_body / 2,)
        )
    )
    if countertop:  # four short feet under the base (the kick zone is the base under the door)
        fx, fz = W / 2 - 0.04, Db / 2 - 0.04
        body.append(
            boxes(np.array([[sx * fx, 0.006, zb + Db / 2 + sz * fz] for sx in (-1, 1) for sz in (-1, 1)]), [0.03, 0.012, 0.03])
        )
        body.append(
            boxes([[0.0, 0.012 + (kick_h - 0.012) / 2, zf + Td / 2]], [[W - 0.004, kick_h - 0.012, Td]])
        )  # base front under the door
    else:
        body.append(boxes([[0.0, kick_h / 2, zf + Td - kick_recess - 0.005]], [[W - 0.004, kick_h - 0.004, 0.01]]))  # kick plate
    if has_top:  # worktop lid over the body and the door
        body.append(boxes([[0.0, H - top_t / 2, zb + (D + top_ov) / 2]], [[W + 0.004, top_t, D + top_ov]]))
    # tub inner extents
    wi = W - 2 * wt
    y_floor = kick_h
    y_ceil = H_body - wt
    rack_w = wi - 0.03
    rack_d = Db - wt - 0.06
    rack_zc = zb + wt + 0.01 + rack_d / 2
    y_low = y_floor + rng.uniform(0.05, 0.08) if not countertop else y_floor + rng.uniform(0.04, 0.06)
    y_up = y_floor + upper_frac * (y_ceil - y_floor)
    y_third = y_ceil - rng.uniform(0.055, 0.07)
    if third_rack:  # the upper rack moves down a little to make room for the cutlery tray
        y_up = min(y_up, y_third - upper_rack_h - 0.03)
    racks_y = [y_low, y_up, y_third][:n_racks]
    body += _rack(rng, rack_w, rack_d, lower_rack_h, y_low, rack_zc, True, rack_rod)
    if n_racks > 1:
        body += _rack(rng, rack_w, rack_d, upper_rack_h, y_up, rack_zc, False, rack_rod)
    if n_racks > 2:
        body += _rack(rng, rack_w, rack_d, 0.03, y_third, rack_zc, False, rack_rod)
    # side rails carrying the racks
    rails_c, rails_e = [], []
    for y in racks_y:
        for sx in (-1, 1):
            rails_c.append([sx * (wi / 2 - 0.0075), y, rack_zc])
            rails_e.append([0.015, 0.012, rack_d + 0.02])
    body.append(boxes(np.array(rails_c), np.array(rails_e)))
    body += _spray_arm(rack_w * 0.8, 0.035, y_floor + 0.03, rack_zc, arm_angles[0])
    if n_racks > 1:
        body += _spray_arm(rack_w * 0.7, 0.03, y_up - 0.03, rack_zc, arm_angles[1])
    body.append(disc(0.05, 0.01, (0.0, y_floor + 0.005, rack_zc + rack_d * 0.25), "y", 18))  # filter
    body_mesh = combine(body)

    # door at state 0: y in [kick_h, H_door], z in [zf + gap, zf + gap + Td] (a 1.5 mm gap to the body)
    H_door = H_body - 0.002 if has_top else H
    Hd = H_door - kick_h
    gap = 0.0015
    door = [
        extrude(
            rounded_rect(W - 0.002, Hd - 0.002, 0.008, 3, center=(0.0, kick_h + Hd / 2)), Td, plane="xy", offset=zf + gap + Td / 2
        )
    ]
    zfront = zf + gap + Td
    if integrated:  # controls on the top edge of the door, a plain furniture front with a bar handle or none
        bx = np.linspace(-0.30 * W, 0.05 * W, n_buttons)
        door.append(
            boxes(
                np.c_[bx, np.full(n_buttons, H_door - 0.001 + 0.0015), np.full(n_buttons, zf + gap + 0.6 * Td)],
                np.tile([0.014, 0.003, 0.010], (n_buttons, 1)),
            )
        )
        door.append(boxes([[0.25 * W, H_door - 0.001 + 0.001, zf + gap + 0.6 * Td]], [[0.07, 0.002, 0.012]]))  # display
        y_panel = H_door - panel_h / 2
        handle_type = 0 if handle_type == 0 else 2  # 2: none (push to open)
    else:
        y_panel = H_door - 0.001 - panel_h / 2
        door.append(boxes([[0.0, y_panel, zfront + panel_proud / 2]], [[W - 0.01, panel_h - 0.004, panel_proud]]))
        bx = np.linspace(-0.35 * W, 0.10 * W, n_buttons)
        door.append(
            boxes(
                np.c_[bx, np.full(n_buttons, y_panel), np.full(n_buttons, zfront + panel_proud + 0.0015)],
                np.tile([0.016, 0.012, 0.003], (n_buttons, 1)),
            )
        )
        door.append(boxes([[0.25 * W, y_panel, zfront + panel_proud + 0.001]], [[0.09, 0.03, 0.002]]))  # display
    if handle_type == 0:
        yh = H_door - panel_h - rng.uniform(0.03, 0.06)
        r_c = min(0.5 * handle_off, 0.02)
        ang = np.linspace(0.0, 0.5 * np.pi, 6)
        x_arc = handle_len / 2 - r_c + r_c * np.sin(ang)
        z_arc = zfront + handle_off - r_c + r_c * np.cos(ang)
        xs = np.concatenate(
            [[-handle_len / 2], -x_arc[::-1][:-1], np.linspace(-x_arc[0], x_arc[0], 5), x_arc[1:], [handle_len / 2]]
        )
        zs = np.concatenate([[zfront - 0.002], z_arc[::-1][:-1], np.full(5, zfront + handle_off), z_arc[1:], [zfront - 0.002]])
        path = np.stack([xs, np.full(len(xs), yh), zs], -1)
        door.append(sweep_planar(path, (0, 1, 0), handle_r, handle_r, sections=10))
    elif handle_type == 1:
        yh = H_door - panel_h - 0.006
        door.append(boxes([[0.0, yh, zfront + 0.012]], [[handle_len, 0.012, 0.024]]))
        door.append(boxes([[0.0, yh - 0.012, zfront + 0.022]], [[handle_len, 0.02, 0.006]]))
    # inner liner and dispenser on the back of the door (they enter the tub opening when closed)
    liner_w = wi - 0.02
    liner_h = (y_ceil - y_floor) - 0.03
    door.append(boxes([[0.0, y_floor + 0.015 + liner_h / 2, zf + 0.5 * gap - 0.004]], [[liner_w, liner_h, 0.008 + gap]]))
    door.append(boxes([[0.1 * W, y_floor + 0.55 * liner_h, zf - 0.013]], [[0.14, 0.08, 0.012]]))
    door_mesh = combine(door)

    body_part, T_body = make_part("body", body_mesh)
    door_part, T_door = make_part("door", door_mesh)
    params = dict(
        width=W,
        height=H,
        depth=D,
        door_thickness=Td,
        wall_thickness=wt,
        kick_height=kick_h,
        kick_recess=kick_recess,
        panel_height=panel_h,
        panel_proud=panel_proud,
        handle_type=handle_type,
        handle_length=handle_len,
        handle_radius=handle_r,
        handle_offset=handle_off,
        n_buttons=n_buttons,
        rack_rod_radius=rack_rod,
        lower_rack_height=lower_rack_h,
        upper_rack_height=upper_rack_h,
        upper_rack_frac=upper_frac,
        spray_arm_angle_lower=float(arm_angles[0]),
        spray_arm_angle_upper=float(arm_angles[1]),
        worktop=has_top,
        worktop_thickness=top_t if has_top else 0.0,
        worktop_overhang=top_ov if has_top else 0.0,
        racks=n_racks,
        compact_built_in=int(compact is not None),
    )
    return build_object(
        "dishwasher",
        instance_id,
        [(body_part, T_body), (door_part, T_door)],
        joints=[
            dict(type="revolute", parent=0, child=1, pivot=(0.0, kick_h, zfront), axis=(1.0, 0.0, 0.0), limits=LIMITS, rest=REST)
        ],
        params=params,
        shape_family=family,
    )


SPEC = CategorySpec(
    name="dishwasher",
    family="artimage",
    part_names=("body", "door"),
    joint_types=("revolute",),
    symmetry=("none", "none"),
    distance_range_m=(1.5, 2.6),
    elevation_range_deg=(10.0, 55.0),
    shape_families=FAMILIES,
    build=build,
    description="dishwasher: cabinet with racks + front door on a bottom revolute hinge (opens down to 90 degrees)",
    revision=2,  # 2: half of the integrated machines compact built-ins (45 cm high)
)
