"""Mug (NOCS-like, rigid): a hollow revolved cup with a bottom and a handle on the +x side.

Frame (NOCS): y up along the cup's axis (the opening at +y), x right, z towards the front; the handle
lies in the x-y plane on the +x side; metres; the amodal box is centred on the origin (so the cup's
axis sits at x = -(handle reach) / 2, not at x = 0). Symmetry ``"none"``: the handle breaks the
rotational symmetry of the cup.

Geometry: one closed cross-section loop revolved about y: outer bottom (with a shallow recess inside
a standing ring), rounded heel, outer wall (straight, tapered or barrel-shaped), a rounded rim, the
inner wall (the outer one offset by the wall thickness, 3-7 mm), a filleted inner bottom. The handle
is a tube (elliptic cross-section, wider along z than thick in the x-y plane) swept along a C/ear
shaped curve whose ends are buried in the wall.

Parameter ranges: radius 0.035-0.055 m (the cup's widest outer radius), height 0.07-0.12 m, wall
3-7 mm, handle reach 0.022-0.04 m beyond the wall.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..articulation import ArticulatedObject
from ..shapes import arc, offset_curve, revolve_profile, tube_along_path
from . import CategorySpec
from .helpers import rigid_object, uniform

SECTIONS = 48


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    R = uniform(rng, 0.035, 0.055)
    H = uniform(rng, 0.07, 0.12)
    t = uniform(rng, 0.003, 0.007)
    t_bottom = t * uniform(rng, 1.2, 2.0)
    taper = uniform(rng, -0.12, 0.12)  # top radius = bottom radius * (1 + taper) (before the belly)
    belly = uniform(rng, 0.0, 0.08) if rng.random() < 0.35 else 0.0
    heel = uniform(rng, 0.003, 0.01)
    recess = uniform(rng, 0.0, 0.003)
    reach = uniform(rng, 0.022, 0.04)  # handle's outer extent beyond the wall
    h_top = uniform(rng, 0.72, 0.9)  # handle attachments (fractions of the height)
    h_bot = uniform(rng, 0.12, 0.35)
    squareness = uniform(rng, 0.4, 1.0)  # handle curve: 1 round C, < 1 boxier "D"
    ear = uniform(rng, -0.25, 0.25)  # handle bulges more at the top (> 0) or the bottom (< 0)
    hw = uniform(rng, 0.005, 0.009)  # handle half-width (along z)
    ht = uniform(rng, 0.003, 0.0055)  # handle half-thickness (in the x-y plane)

    y_rim = H - t / 2
    # outer wall: r(s) for s in [0, 1] from the heel to the rim; the largest radius is R
    s = np.linspace(0.0, 1.0, 24)
    shape = 1.0 + taper * s + belly * np.sin(np.pi * s)
    r_wall = R * shape / shape.max()
    y_wall = heel + s * (y_rim - heel)
    wall = np.stack([r_wall, y_wall], -1)
    r0 = r_wall[0]
    ring = max(r0 - heel - 0.004, 0.3 * r0)
    base = np.array([[0.0, recess], [ring - 0.002, recess], [ring, 0.0]])
    heel_pts = arc((r0 - heel, heel), heel, -np.pi / 2, 0.0, 6)
    outer = np.concatenate([base, heel_pts, wall[1:]])
    # inner side: the wall offset inwards, down to an inner bottom at y = t_bottom with a fillet
    inner_wall = offset_curve(wall, t)
    fil = min(0.006, 0.5 * (y_rim - t_bottom))
    ri0 = float(np.interp(t_bottom + fil, inner_wall[:, 1], inner_wall[:, 0]))
    inner_wall = inner_wall[inner_wall[:, 1] > t_bottom + fil + 1e-4]
    inner_fillet = arc((ri0 - fil, t_bottom + fil), fil, 0.0, -np.pi / 2, 6)
    tang = wall[-1] - wall[-2]
    tang /= np.linalg.norm(tang)
    n_out = np.array([tang[1], -tang[0]])
    mid = wall[-1] - n_out * t / 2
    a = np.linspace(0.0, np.pi, 9)[1:-1, None]
    rim = mid + (t / 2) * (np.cos(a) * n_out + np.sin(a) * tang)
    inner = np.concatenate([inner_wall[::-1], inner_fillet, [[0.0, t_bottom]]])
    loop = np.concatenate([outer, rim, inner])
    loop[:, 1] *= H / loop[:, 1].max()  # a leaning rim tops out a hair below H: stretch to exactly H
    cup = revolve_profile(loop, SECTIONS, closed=True)

    # handle: a C curve in the x-y plane from the upper to the lower attachment, ends inside the wall
    yt, yb = h_top * H, h_bot * H
    yc, hh = 0.5 * (yt + yb), 0.5 * (yt - yb)
    r_at = lambda y: float(np.interp(y, y_wall, r_wall))  # noqa: E731
    x_out = R + reach - ht  # the tube's centre line at its farthest
    th = np.linspace(np.pi / 2, -np.pi / 2, 33)
    c = np.cos(th)
    bulge = (np.abs(c) ** squareness) * (1.0 + ear * np.sin(th))
    bulge /= bulge.max()
    y = yc + hh * np.sin(th)
    x_in = np.interp(y, y_wall, r_wall) - 0.2 * t  # the curve leaves the wall just under its surface
    x = x_in + (x_out - x_in) * bulge
    path = np.concatenate([[[r_at(yt) - 0.55 * t, yt]], np.stack([x, y], -1), [[r_at(yb) - 0.55 * t, yb]]])
    path3 = np.c_[path, np.zeros(len(path))]
    handle = tube_along_path(path3, (hw, ht), sections=12)
    handle = trimesh.Trimesh(vertices=handle.vertices, faces=np.asarray(handle.faces)[:, ::-1], process=False)  # outward

    params = dict(
        radius=R, height=H, wall=t, bottom=t_bottom, taper=taper, belly=belly, heel=heel, recess=recess,
        handle_reach=reach, handle_top=h_top, handle_bottom=h_bot, handle_squareness=squareness,
        handle_ear=ear, handle_half_width=hw, handle_half_thickness=ht,
    )
    return rigid_object("mug", instance_id, [cup, handle], "none", params)


SPEC = CategorySpec(
    name="mug",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("none",),
    distance_range_m=(0.35, 0.8),
    elevation_range_deg=(10.0, 60.0),
    build=build,
    description="hollow revolved mug (rounded rim, inner bottom) with a C/ear handle on the +x side",
)
