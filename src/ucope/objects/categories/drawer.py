"""Drawer cabinet (ArtImage-like, articulated): parts ``("cabinet", "drawer_top", "drawer_middle",
"drawer_bottom")``, three prismatic joints.

Object frame (y up, x right, z towards the viewer / the cabinet front; metres; origin at the cabinet's
amodal box centre):

* ``cabinet``: a carcass open at the front (+z) with two shelves dividing it into three equal slots, a
  recessed plinth below and a top board overhanging the front and the sides. Width 0.40-0.90 m, height
  0.50-1.10 m, depth 0.35-0.60 m (carcass; the top board and the drawer fronts add a few centimetres).
* ``drawer_top`` / ``drawer_middle`` / ``drawer_bottom``: an open-top box (sides, back, bottom, inner
  front) in its slot with a few millimetres of clearance, a front panel slightly larger than the slot
  opening (it overlaps the walls and shelves, leaving ~3 mm gaps between fronts), and a handle (one style
  per cabinet: a bar on stand-offs, one or two knobs, or a lip along the top edge).
* Joints ``cabinet -> drawer_*`` (prismatic, parent 0): axis ``(0, 0, +1)``; the state is how far the
  drawer is pulled out, in metres. State 0 is CLOSED (the back of the front panel against the cabinet's
  front edge). Limits ``(0, 0.75 * drawer box depth)``, rest 0.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import boxes, combine, disc, extrude, open_box, rounded_rect, sweep_planar
from . import CategorySpec

__all__ = ["SPEC", "build"]

DRAWERS = ("drawer_top", "drawer_middle", "drawer_bottom")


def _bar_handle(x_half: float, y: float, z0: float, off: float, r: float) -> trimesh.Trimesh:
    r_c = min(0.5 * off, 0.012)
    ang = np.linspace(0.0, 0.5 * np.pi, 5)
    xa = x_half - r_c + r_c * np.sin(ang)
    za = z0 + off - r_c + r_c * np.cos(ang)
    xs = np.concatenate([[-x_half], -xa[::-1][:-1], np.linspace(-xa[0], xa[0], 3), xa[1:], [x_half]])
    zs = np.concatenate([[z0 - 0.002], za[::-1][:-1], np.full(3, z0 + off), za[1:], [z0 - 0.002]])
    return sweep_planar(np.stack([xs, np.full(len(xs), y), zs], -1), (0, 1, 0), r, r, sections=8)


def _knob(x: float, y: float, z0: float, r: float, length: float) -> list:
    return [disc(0.45 * r, length, (x, y, z0 + length / 2), "z", 10), disc(r, 0.35 * length, (x, y, z0 + length), "z", 16)]


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    """A random three-drawer cabinet; see the module docstring for the frame and joint conventions."""
    W = rng.uniform(0.40, 0.90)
    H = rng.uniform(0.50, 1.10)
    D = rng.uniform(0.35, 0.60)
    wt = rng.uniform(0.015, 0.024)  # carcass wall / shelf thickness
    plinth_h = rng.uniform(0.03, 0.10)
    plinth_in = rng.uniform(0.01, 0.04)
    top_t = rng.uniform(0.015, 0.03)
    top_ov = rng.uniform(0.0, 0.025)  # top board overhang beyond the sides and the fronts
    tf = rng.uniform(0.015, 0.022)  # front panel thickness
    clr = rng.uniform(0.003, 0.008)  # side clearance of a drawer box in its slot
    top_clr = rng.uniform(0.012, 0.035)  # drawer box sides are lower than the slot
    dwt = rng.uniform(0.008, 0.014)  # drawer box wall thickness
    back_clr = rng.uniform(0.01, 0.04)
    handle_type = int(rng.integers(0, 3))  # 0: bar, 1: knob(s), 2: lip along the top edge
    handle_w = rng.uniform(0.25, 0.5)  # bar / lip length as a fraction of the panel width
    handle_r = rng.uniform(0.005, 0.009)
    handle_off = rng.uniform(0.02, 0.035)
    handle_y = rng.uniform(0.45, 0.7)  # handle height as a fraction of the panel height
    two_knobs = int(rng.random() < 0.6 and W > 0.6)  # (always draws, so the stream does not depend on W)

    Hc = H - plinth_h - top_t  # carcass height
    hs = (Hc - 4 * wt) / 3  # slot height
    y_slot = plinth_h + wt + np.arange(3) * (hs + wt)  # slot bottoms, bottom slot first
    shelves = [plinth_h + wt + k * hs + (k - 0.5) * wt - (plinth_h + Hc / 2) for k in (1, 2)]
    zf = D / 2  # carcass front plane
    cab = [open_box((W, Hc, D), wt, center=(0.0, plinth_h + Hc / 2, 0.0), open_side="+z", shelves_y=shelves)]
    cab.append(boxes([[0.0, plinth_h / 2, -plinth_in / 2]], [[W - 2 * plinth_in, plinth_h, D - plinth_in]]))
    z_top_front = zf + tf + 0.001 + top_ov
    top = rounded_rect(W + 2 * top_ov, z_top_front + D / 2, 0.004, 3, center=(0.0, 0.5 * (z_top_front - D / 2)))
    cab.append(extrude(top, top_t, plane="xz", offset=H - top_t / 2))
    cab_mesh = combine(cab)

    m_side = wt - 0.002  # how far a front panel overlaps the side walls
    m_vert = wt / 2 - 0.0015  # ... and the shelves (3 mm gap between fronts)
    bw = W - 2 * wt - 2 * clr
    bh = hs - top_clr - 0.003
    bd = D - wt - back_clr
    parts, joints = [], []
    for k, name in enumerate(DRAWERS):
        ys = y_slot[2 - k]  # drawer_top is in the top slot
        geo = [open_box((bw, bh, bd + 0.001), dwt, center=(0.0, ys + 0.003 + bh / 2, zf + 0.001 - (bd + 0.001) / 2), open_side="+y")]
        pw = W - 2 * wt + 2 * m_side
        ph = hs + 2 * m_vert
        yc = ys + hs / 2
        z0 = zf + 0.001 + tf  # panel front face
        geo.append(extrude(rounded_rect(pw, ph, 0.003, 3, center=(0.0, yc)), tf, plane="xy", offset=zf + 0.001 + tf / 2))
        yh = yc - ph / 2 + handle_y * ph
        if handle_type == 0:
            geo.append(_bar_handle(0.5 * handle_w * pw, yh, z0, handle_off, handle_r))
        elif handle_type == 1:
            xs = (-0.25 * pw, 0.25 * pw) if two_knobs else (0.0,)
            for x in xs:
                geo += _knob(x, yh, z0, 2.2 * handle_r, handle_off)
        else:
            ylip = yc + ph / 2 - 0.006
            geo.append(boxes([[0.0, ylip, z0 + 0.008], [0.0, ylip - 0.008, z0 + 0.0145]],
                             [[handle_w * pw, 0.012, 0.016], [handle_w * pw, 0.022, 0.003]]))
        part = make_part(name, combine(geo))
        parts.append(part)
        joints.append(dict(type="prismatic", parent=0, child=k + 1, pivot=(0.0, yc, zf), axis=(0.0, 0.0, 1.0),
                           limits=(0.0, 0.75 * bd), rest=0.0))

    cabinet = make_part("cabinet", cab_mesh)
    params = dict(
        width=W, height=H, depth=D, wall_thickness=wt, plinth_height=plinth_h, plinth_inset=plinth_in,
        top_thickness=top_t, top_overhang=top_ov, front_thickness=tf, side_clearance=clr, top_clearance=top_clr,
        drawer_wall=dwt, back_clearance=back_clr, handle_type=handle_type, handle_width_frac=handle_w,
        handle_radius=handle_r, handle_offset=handle_off, handle_height_frac=handle_y, two_knobs=two_knobs,
        slot_height=hs, drawer_depth=bd,
    )
    return build_object("drawer", instance_id, [cabinet] + parts, joints=joints, params=params)


SPEC = CategorySpec(
    name="drawer",
    family="artimage",
    part_names=("cabinet",) + DRAWERS,
    joint_types=("prismatic", "prismatic", "prismatic"),
    symmetry=("none", "none", "none", "none"),
    distance_range_m=(1.3, 2.6),
    elevation_range_deg=(10.0, 55.0),
    build=build,
    description="drawer: cabinet with three drawers on prismatic slides (pull out up to 3/4 of their depth)",
)
