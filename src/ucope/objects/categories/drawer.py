"""Drawer cabinet (ArtImage-like, articulated): parts ``("cabinet", "drawer_top", "drawer_middle",
"drawer_bottom")``, three prismatic joints.

Object frame (y up, x right, z towards the viewer / the cabinet front; metres; origin at the cabinet's
amodal box centre):

* ``cabinet``: a carcass open at the front (+z) with two shelves dividing it into three slots (equal, or
  graduated: taller towards the bottom), standing on a recessed plinth, on four legs, or directly on the
  floor, with a top board overhanging the front and the sides on furniture-style cabinets.
* ``drawer_top`` / ``drawer_middle`` / ``drawer_bottom``: an open-top box (sides, back, bottom, inner
  front) in its slot with a few millimetres of clearance, a front panel, and a handle (one style per
  cabinet: a bar on stand-offs, one or two knobs, a lip along the top edge, a recessed finger slot, or a
  cup pull with a label holder). Front panels are partial overlay (slightly larger than the slot opening:
  they overlap the walls and shelves, leaving ~3 mm gaps between fronts), full overlay (covering the
  carcass front and overhanging its sides by up to 8 mm) or inset (inside the opening, flush with the
  carcass front).
* Joints ``cabinet -> drawer_*`` (prismatic, parent 0): axis ``(0, 0, +1)``; the state is how far the
  drawer is pulled out, in metres. State 0 is CLOSED (an overlay front's back against the cabinet's front
  edge, an inset front flush with it). Limits ``(0, 0.75 * drawer box depth)``, rest 0.

Shape families (width W, height H, depth D of the carcass; metres):

=========== ============ ============ ============ =====================================================
family      W            H            D            look
=========== ============ ============ ============ =====================================================
tabletop    0.25-0.42    0.20-0.38    0.25-0.40    desktop drawer unit: thin walls, no plinth, knobs / slots / lips
nightstand  0.38-0.60    0.45-0.80    0.35-0.50    bedside chest: plinth or (35 %) legs, top board, any handle
dresser     0.70-1.80    0.70-1.05    0.40-0.55    chest of drawers: plinth or (35 %) legs, overhanging top, bars / knobs / lips
filing      0.38-0.50    0.95-1.35    0.55-0.70    filing cabinet: full-overlay fronts, cup pulls or slots
legged      0.80-2.00    0.60-0.95    0.40-0.50    sideboard on four tapered legs (15-30 cm), bars / knobs (held out)
=========== ============ ============ ============ =====================================================
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import boxes, combine, disc, extrude, open_box, rounded_rect, sweep_planar
from . import CategorySpec, ShapeFamily
from .helpers import build_with_variant

__all__ = ["SPEC", "build"]

DRAWERS = ("drawer_top", "drawer_middle", "drawer_bottom")
HANDLES = ("bar", "knob", "lip", "recessed", "cup")
FRONTS = ("partial", "full", "inset")

FAMILIES = (
    ShapeFamily("tabletop", "desktop / tabletop drawer unit, 25-42 cm wide"),
    ShapeFamily("nightstand", "bedside table / small chest with three drawers"),
    ShapeFamily("dresser", "chest of drawers / dresser, 0.7-1.8 m wide"),
    ShapeFamily("filing", "three-drawer filing cabinet"),
    ShapeFamily("legged", "sideboard / mid-century chest on four legs", held_out=True),
)

# per family: (lo, hi) of width, height, depth, wall thickness, plinth (or leg) height, top board thickness and
# overhang (0: no top board), front thickness; the handle and front styles it draws from; the probability of
# graduated slots
RANGES = {
    "tabletop": dict(
        width=(0.25, 0.42),
        height=(0.20, 0.38),
        depth=(0.25, 0.40),
        wall=(0.006, 0.012),
        plinth=(0.0, 0.0),
        top=(0.0, 0.0),
        overhang=(0.0, 0.0),
        front=(0.006, 0.012),
        handles=("knob", "lip", "recessed"),
        fronts=("partial", "full", "inset"),
        p_graduated=0.3,
    ),
    "nightstand": dict(
        width=(0.38, 0.60),
        height=(0.45, 0.80),
        depth=(0.35, 0.50),
        wall=(0.015, 0.022),
        plinth=(0.03, 0.10),
        top=(0.015, 0.030),
        overhang=(0.0, 0.025),
        front=(0.015, 0.022),
        handles=("bar", "knob", "lip", "recessed"),
        fronts=("partial", "full", "inset"),
        p_graduated=0.4,
    ),
    "dresser": dict(
        width=(0.70, 1.80),
        height=(0.70, 1.05),
        depth=(0.40, 0.55),
        wall=(0.016, 0.024),
        plinth=(0.04, 0.12),
        top=(0.018, 0.035),
        overhang=(0.0, 0.030),
        front=(0.016, 0.024),
        handles=("bar", "knob", "lip"),
        fronts=("partial", "full", "inset"),
        p_graduated=0.5,
    ),
    "filing": dict(
        width=(0.38, 0.50),
        height=(0.95, 1.35),
        depth=(0.55, 0.70),
        wall=(0.010, 0.016),
        plinth=(0.01, 0.03),
        top=(0.0, 0.0),
        overhang=(0.0, 0.0),
        front=(0.015, 0.025),
        handles=("cup", "recessed"),
        fronts=("full",),
        p_graduated=0.0,
    ),
    "legged": dict(
        width=(0.80, 2.00),
        height=(0.60, 0.95),
        depth=(0.40, 0.50),
        wall=(0.016, 0.022),
        plinth=(0.15, 0.30),
        top=(0.018, 0.030),
        overhang=(0.0, 0.020),
        front=(0.016, 0.022),
        handles=("bar", "knob"),
        fronts=("partial", "full"),
        p_graduated=0.3,
    ),
}


def _bar_handle(x_half: float, y: float, z0: float, off: float, r: float, xc: float = 0.0) -> trimesh.Trimesh:
    r_c = min(0.5 * off, 0.012)
    ang = np.linspace(0.0, 0.5 * np.pi, 5)
    xa = x_half - r_c + r_c * np.sin(ang)
    za = z0 + off - r_c + r_c * np.cos(ang)
    xs = np.concatenate([[-x_half], -xa[::-1][:-1], np.linspace(-xa[0], xa[0], 3), xa[1:], [x_half]]) + xc
    zs = np.concatenate([[z0 - 0.002], za[::-1][:-1], np.full(3, z0 + off), za[1:], [z0 - 0.002]])
    return sweep_planar(np.stack([xs, np.full(len(xs), y), zs], -1), (0, 1, 0), r, r, sections=8)


def _knob(x: float, y: float, z0: float, r: float, length: float) -> list:
    return [disc(0.45 * r, length, (x, y, z0 + length / 2), "z", 10), disc(r, 0.35 * length, (x, y, z0 + length), "z", 16)]


def _front_with_slot(pw: float, ph: float, yc: float, z_back: float, tf: float, sw: float, sh: float, y_slot: float) -> list:
    """A ``pw x ph`` front panel (thickness ``tf`` from ``z_back`` forwards) with a ``sw x sh`` finger slot
    centred at height ``y_slot``, as four boxes, plus the slot's back plate recessed into the panel."""
    y0, y1 = yc - ph / 2, yc + ph / 2
    s0, s1 = y_slot - sh / 2, y_slot + sh / 2
    zc = z_back + tf / 2
    c = [
        [0.0, 0.5 * (y0 + s0), zc],
        [0.0, 0.5 * (s1 + y1), zc],
        [-(pw + sw) / 4, y_slot, zc],
        [(pw + sw) / 4, y_slot, zc],
        [0.0, y_slot, z_back + 0.25 * tf],
    ]
    e = [[pw, s0 - y0, tf], [pw, y1 - s1, tf], [(pw - sw) / 2, sh, tf], [(pw - sw) / 2, sh, tf], [sw, sh, 0.5 * tf]]
    return [boxes(np.array(c), np.array(e))]


# Nightstands and dressers on legs (revision 2): mid-century bedside chests and chests of drawers (IKEA Tarva /
# Hemnes-style legged chests, West Elm Mid-Century, Habitat) stand on four 10-22 cm legs in place of the plinth;
# the total height stays the family's, so the carcass is lower. The held-out sideboard family is longer and lower
# (0.8-2 m wide, 15-30 cm legs).
LEGS = dict(leg_height=(0.10, 0.22))
LEG_MAX_FRAC = 0.3  # at most this fraction of the cabinet's height, so a low nightstand keeps usable drawers
P_LEGS = 0.35
LEG_FAMILIES = ("nightstand", "dresser")


def build(rng: np.random.Generator, instance_id: str, family: str = "nightstand") -> ArticulatedObject:
    """A random three-drawer cabinet of shape ``family``; see the module docstring for the frame and joint conventions.

    A nightstand or a dresser stands on four legs (:data:`LEGS`, at most :data:`LEG_MAX_FRAC` of its height)
    with chance :data:`P_LEGS`, decided by a draw after all of the cabinet's own
    (:func:`~ucope.objects.categories.helpers.build_with_variant`): every other instance is the cabinet it was
    before this variant existed."""
    if family not in LEG_FAMILIES:
        return _build(rng, instance_id, family, None)
    return build_with_variant(rng, lambda r, legs: _build(r, instance_id, family, legs), P_LEGS, LEGS)


def _build(rng: np.random.Generator, instance_id: str, family: str, legs: dict | None) -> ArticulatedObject:
    """:func:`build`'s cabinet; ``legs``: the leg height of a nightstand or dresser on legs, which replaces the
    drawn plinth (the draws are made all the same)."""
    rg = RANGES[family]
    W = rng.uniform(*rg["width"])
    H = rng.uniform(*rg["height"])
    D = rng.uniform(*rg["depth"])
    wt = rng.uniform(*rg["wall"])  # carcass wall / shelf thickness
    plinth_h = rng.uniform(*rg["plinth"])  # plinth height, or leg height for the legged family
    plinth_in = rng.uniform(0.01, 0.04)
    top_t = rng.uniform(*rg["top"])
    top_ov = rng.uniform(*rg["overhang"])  # top board overhang beyond the sides and the fronts
    tf = rng.uniform(*rg["front"])  # front panel thickness
    clr = rng.uniform(0.002, 0.004) if family == "tabletop" else rng.uniform(0.003, 0.008)  # side clearance of a drawer box
    top_clr = rng.uniform(0.012, 0.035) * min(1.0, H / 0.5)  # drawer box sides are lower than the slot
    dwt = rng.uniform(0.004, 0.008) if family == "tabletop" else rng.uniform(0.008, 0.014)  # drawer box wall thickness
    back_clr = rng.uniform(0.01, 0.04) * min(1.0, D / 0.4)
    handle = rg["handles"][int(rng.integers(len(rg["handles"])))]
    front_style = rg["fronts"][int(rng.integers(len(rg["fronts"])))]
    handle_w = rng.uniform(0.25, 0.5)  # bar / lip / slot length as a fraction of the panel width
    small = family == "tabletop"  # small handles on small units
    handle_r = rng.uniform(0.003, 0.005) if small else rng.uniform(0.005, 0.009)
    handle_off = rng.uniform(0.010, 0.018) if small else rng.uniform(0.02, 0.035)
    handle_y = rng.uniform(0.45, 0.7)  # handle height as a fraction of the panel height
    two_handles = int(rng.random() < 0.6 and W > 0.6)  # (always draws, so the stream does not depend on W)
    graduation = rng.uniform(0.1, 0.35) if rng.random() < rg["p_graduated"] else 0.0
    full_ov = rng.uniform(0.0, 0.008)  # full overlay: how far the fronts overhang the carcass sides
    leg_in = rng.uniform(0.03, 0.07)  # legged: leg inset from the carcass corners
    leg_r = rng.uniform(0.012, 0.02)
    legged = family == "legged"
    if legs is not None:
        plinth_h, legged = min(legs["leg_height"], LEG_MAX_FRAC * H), True
    has_top = top_t > 0.0
    if not has_top:
        top_t = top_ov = 0.0

    Hc = H - plinth_h - top_t  # carcass height
    # slot heights bottom to top (graduated: the bottom one is the tallest)
    weights = np.array([1.0 + 2.0 * graduation, 1.0 + graduation, 1.0])
    hs_all = (Hc - 4 * wt) * weights / weights.sum()
    y_slot = plinth_h + wt + np.concatenate([[0.0], np.cumsum(hs_all[:2] + wt)])  # slot bottoms, bottom slot first
    shelves = [y_slot[k] - wt / 2 - (plinth_h + Hc / 2) for k in (1, 2)]
    zf = D / 2  # carcass front plane
    cab = [open_box((W, Hc, D), wt, center=(0.0, plinth_h + Hc / 2, 0.0), open_side="+z", shelves_y=shelves)]
    if legged:  # four tapered legs, splayed a little outwards
        for sx in (-1, 1):
            for sz in (-1, 1):
                top = np.array([sx * (W / 2 - leg_in), plinth_h + 0.5 * wt, sz * (D / 2 - leg_in)])
                foot = top + np.array([sx * 0.15 * plinth_h, -plinth_h - 0.5 * wt, sz * 0.1 * plinth_h])
                cab.append(
                    sweep_planar(
                        np.stack([top, foot]),
                        (sz, 0.0, -sx),
                        np.array([leg_r, 0.5 * leg_r]),
                        np.array([leg_r, 0.5 * leg_r]),
                        sections=10,
                    )
                )
    elif plinth_h > 0.0:
        cab.append(boxes([[0.0, plinth_h / 2, -plinth_in / 2]], [[W - 2 * plinth_in, plinth_h, D - plinth_in]]))
    if has_top:
        z_top_front = zf + tf + 0.001 + top_ov
        top = rounded_rect(W + 2 * top_ov, z_top_front + D / 2, 0.004, 3, center=(0.0, 0.5 * (z_top_front - D / 2)))
        cab.append(extrude(top, top_t, plane="xz", offset=H - top_t / 2))
    cab_mesh = combine(cab)

    m_side = wt - 0.002  # how far a partial-overlay front overlaps the side walls
    m_vert = wt / 2 - 0.0015  # ... and the shelves (3 mm gap between fronts)
    bw = W - 2 * wt - 2 * clr
    bd = D - wt - back_clr
    parts, joints = [], []
    for k, name in enumerate(DRAWERS):
        slot = 2 - k  # drawer_top is in the top slot
        ys, hs = y_slot[slot], hs_all[slot]
        bh = hs - top_clr - 0.003
        yc = ys + hs / 2
        if front_style == "inset":  # inside the opening, 2.5 mm gaps, front face flush with the carcass
            pw, ph = W - 2 * wt - 0.005, hs - 0.005
            z_back = zf - tf
            box_front = z_back
        else:
            if front_style == "full":  # covers the carcass front (outer walls included), 3 mm gaps
                pw = W + 2 * full_ov
                lo = plinth_h if slot == 0 else ys - wt / 2 + 0.0015
                hi = (plinth_h + Hc - 0.0015) if slot == 2 else ys + hs + wt / 2 - 0.0015
                ph, yc = hi - lo, 0.5 * (lo + hi)
            else:
                pw, ph = W - 2 * wt + 2 * m_side, hs + 2 * m_vert
            z_back = zf + 0.001
            box_front = zf + 0.001
        bdk = bd + (box_front - zf)  # the box runs from the back clearance to the front panel
        geo = [open_box((bw, bh, bdk), dwt, center=(0.0, ys + 0.003 + bh / 2, box_front - bdk / 2), open_side="+y")]
        z0 = z_back + tf  # panel front face
        slot_w, slot_h = handle_w * pw, min(0.025, 0.3 * ph)
        yh = yc - ph / 2 + handle_y * ph
        if handle == "recessed":
            geo += _front_with_slot(pw, ph, yc, z_back, tf, slot_w, slot_h, yc + ph / 2 - 0.6 * slot_h - 0.012)
        else:
            geo.append(extrude(rounded_rect(pw, ph, 0.003, 3, center=(0.0, yc)), tf, plane="xy", offset=z_back + tf / 2))
        xs = (-0.25 * pw, 0.25 * pw) if two_handles else (0.0,)
        if handle == "bar":
            for x in xs:
                geo.append(_bar_handle(0.5 * handle_w * pw / len(xs), yh, z0, handle_off, handle_r, x))
        elif handle == "knob":
            for x in xs:
                geo += _knob(x, yh, z0, 2.2 * handle_r, handle_off)
        elif handle == "lip":
            ylip = yc + ph / 2 - 0.006
            geo.append(
                boxes(
                    [[0.0, ylip, z0 + 0.008], [0.0, ylip - 0.008, z0 + 0.0145]],
                    [[handle_w * pw, 0.012, 0.016], [handle_w * pw, 0.022, 0.003]],
                )
            )
        elif handle == "cup":  # a label holder above a cup pull (a shallow curved shell as a box frame)
            cw = min(0.12, 0.4 * pw)
            geo.append(
                boxes(
                    [[0.0, yh + 0.035, z0 + 0.001], [0.0, yh, z0 + 0.006], [0.0, yh - 0.012, z0 + 0.011]],
                    [[0.08, 0.03, 0.002], [cw, 0.006, 0.012], [cw, 0.025, 0.004]],
                )
            )
        parts.append(make_part(name, combine(geo)))
        joints.append(
            dict(
                type="prismatic",
                parent=0,
                child=k + 1,
                pivot=(0.0, yc, zf),
                axis=(0.0, 0.0, 1.0),
                limits=(0.0, 0.75 * bd),
                rest=0.0,
            )
        )

    cabinet = make_part("cabinet", cab_mesh)
    params = dict(
        width=W,
        height=H,
        depth=D,
        wall_thickness=wt,
        plinth_height=plinth_h if not legged else 0.0,
        leg_height=plinth_h if legged else 0.0,
        on_legs=int(legs is not None),
        plinth_inset=plinth_in,
        top_thickness=top_t,
        top_overhang=top_ov,
        front_thickness=tf,
        side_clearance=clr,
        top_clearance=top_clr,
        drawer_wall=dwt,
        back_clearance=back_clr,
        handle_type=HANDLES.index(handle),
        front_style=FRONTS.index(front_style),
        handle_width_frac=handle_w,
        handle_radius=handle_r,
        handle_offset=handle_off,
        handle_height_frac=handle_y,
        two_handles=two_handles,
        graduation=graduation,
        full_overlay_overhang=full_ov if front_style == "full" else 0.0,
        slot_height_top=float(hs_all[2]),
        slot_height_bottom=float(hs_all[0]),
        drawer_depth=bd,
    )
    return build_object("drawer", instance_id, [cabinet] + parts, joints=joints, params=params, shape_family=family)


SPEC = CategorySpec(
    name="drawer",
    family="artimage",
    part_names=("cabinet",) + DRAWERS,
    joint_types=("prismatic", "prismatic", "prismatic"),
    symmetry=("none", "none", "none", "none"),
    distance_range_m=(1.0, 3.0),
    elevation_range_deg=(10.0, 55.0),
    shape_families=FAMILIES,
    build=build,
    revision=2,  # 2: 35 % of the nightstands and dressers on legs (10-22 cm)
    description=(
        "drawer: cabinet with three drawers on prismatic slides " "(tabletop units to dressers, filing cabinets, sideboards)"
    ),
)
