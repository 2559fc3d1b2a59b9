"""Mug (NOCS-like, rigid): a hollow revolved cup with a bottom and a handle on the +x side.

Frame (NOCS): y up along the cup's axis (the opening at +y), x right, z towards the front; the handle
lies in the x-y plane on the +x side; metres; the amodal box is centred on the origin (so the cup's
axis sits at x = -(handle reach) / 2, not at x = 0). Symmetry ``"none"``: the handle breaks the
rotational symmetry of the cup.

Geometry: one closed cross-section loop revolved about y: outer bottom (with a shallow recess inside
a standing ring), rounded heel, outer wall (straight, tapered, flared or barrel-shaped: the radius goes
from the bottom to the rim as ``r0 + (r1 - r0) s^curve`` plus a ``belly`` bulge), a rounded rim, the
inner wall (the outer one offset by the wall thickness), a filleted inner bottom. The handle is a tube
(elliptic cross-section, wider along z than thick in the x-y plane) swept along a C/ear shaped curve
whose ends are buried in the wall.

Shape families (overall height H including the rim, widest outer diameter D of the cup, handle reach
beyond the wall; metres):

============ ============== ============== ============================================== ==============
family       H              D              wall shape (top radius / bottom radius)         handle reach
============ ============== ============== ============================================== ==============
straight     0.085-0.120    0.072-0.092    straight, 0.94-1.06                              0.024-0.040
conical      0.075-0.120    0.075-0.100    flared, 1.15-1.45                                0.022-0.038
espresso     0.050-0.068    0.055-0.072    straight to tulip, 0.95-1.20                     0.014-0.024
cappuccino   0.060-0.080    0.085-0.105    flared bowl, 1.15-1.40 (curved lower wall)       0.018-0.030
tall         0.120-0.150    0.075-0.095    straight, 0.95-1.12                              0.026-0.042
barrel       0.085-0.125    0.080-0.100    bulging (+8-18 % at mid height); held out        0.024-0.040
============ ============== ============== ============================================== ==============

Walls 3-6 mm (espresso and cappuccino cups 3-5 mm, thick bottoms).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, offset_curve, revolve_profile, sweep_planar
from . import CategorySpec, ShapeFamily
from .helpers import rigid_object, uniform

SECTIONS = 48

FAMILIES = (
    ShapeFamily("straight", "standard 11-15 oz mug, straight wall"),
    ShapeFamily("conical", "tapered mug, wider at the rim"),
    ShapeFamily("espresso", "espresso / demitasse cup, 60-90 ml"),
    ShapeFamily("cappuccino", "wide, low cappuccino / tea cup with a curved lower wall"),
    ShapeFamily("tall", "tall latte mug, 12-16 oz"),
    ShapeFamily("barrel", "barrel mug, wall bulging at mid height", held_out=True),
)

# per family: (lo, hi) of height H, diameter D, top/bottom radius ratio, wall curve exponent, belly, wall, handle reach
RANGES = {
    "straight": dict(
        height=(0.085, 0.120),
        diameter=(0.072, 0.092),
        ratio=(0.94, 1.06),
        curve=(1.0, 1.0),
        belly=(0.0, 0.0),
        wall=(0.003, 0.006),
        reach=(0.024, 0.040),
    ),
    "conical": dict(
        height=(0.075, 0.120),
        diameter=(0.075, 0.100),
        ratio=(1.15, 1.45),
        curve=(0.8, 1.2),
        belly=(0.0, 0.0),
        wall=(0.003, 0.006),
        reach=(0.022, 0.038),
    ),
    "espresso": dict(
        height=(0.050, 0.068),
        diameter=(0.055, 0.072),
        ratio=(0.95, 1.20),
        curve=(0.5, 1.0),
        belly=(0.0, 0.0),
        wall=(0.003, 0.005),
        reach=(0.014, 0.024),
    ),
    "cappuccino": dict(
        height=(0.060, 0.080),
        diameter=(0.085, 0.105),
        ratio=(1.15, 1.40),
        curve=(0.35, 0.6),
        belly=(0.0, 0.0),
        wall=(0.003, 0.005),
        reach=(0.018, 0.030),
    ),
    "tall": dict(
        height=(0.120, 0.150),
        diameter=(0.075, 0.095),
        ratio=(0.95, 1.12),
        curve=(1.0, 1.0),
        belly=(0.0, 0.0),
        wall=(0.003, 0.006),
        reach=(0.026, 0.042),
    ),
    "barrel": dict(
        height=(0.085, 0.125),
        diameter=(0.080, 0.100),
        ratio=(0.95, 1.05),
        curve=(1.0, 1.0),
        belly=(0.08, 0.18),
        wall=(0.003, 0.006),
        reach=(0.024, 0.040),
    ),
}


def build(rng: np.random.Generator, instance_id: str, family: str = "straight") -> ArticulatedObject:
    """A random mug of shape ``family``; see the module docstring for the frame and the ranges."""
    rg = RANGES[family]
    small = family in ("espresso", "cappuccino")
    H = uniform(rng, *rg["height"])
    R = uniform(rng, *rg["diameter"]) / 2
    ratio = uniform(rng, *rg["ratio"])
    curve = uniform(rng, *rg["curve"])
    belly = uniform(rng, *rg["belly"])
    t = uniform(rng, *rg["wall"])
    t_bottom = t * uniform(rng, 1.2, 2.0)
    heel = uniform(rng, 0.003, 0.008 if small else 0.01)
    recess = uniform(rng, 0.0, 0.003)
    reach = uniform(rng, *rg["reach"])  # handle's outer extent beyond the wall
    h_top = uniform(rng, 0.65, 0.85) if small else uniform(rng, 0.72, 0.9)  # handle attachments (fractions of H)
    h_bot = uniform(rng, 0.25, 0.45) if small else uniform(rng, 0.12, 0.35)
    squareness = uniform(rng, 0.4, 1.0)  # handle curve: 1 round C, < 1 boxier "D"
    ear = uniform(rng, -0.25, 0.25)  # handle bulges more at the top (> 0) or the bottom (< 0)
    hw = uniform(rng, 0.003, 0.005) if small else uniform(rng, 0.005, 0.009)  # handle half-width (along z)
    ht = uniform(rng, 0.0025, 0.0035) if small else uniform(rng, 0.003, 0.0055)  # handle half-thickness (x-y plane)

    y_rim = H - t / 2
    # outer wall: r(s) for s in [0, 1] from the heel to the rim, scaled so that the largest radius is R
    s = np.linspace(0.0, 1.0, 24)
    shape = 1.0 + (ratio - 1.0) * s**curve + belly * np.sin(np.pi * s)
    r_wall = R * shape / shape.max()
    heel = min(heel, 0.3 * r_wall[0])
    y_wall = heel + s * (y_rim - heel)
    wall = np.stack([r_wall, y_wall], -1)
    r0 = r_wall[0]
    ring = max(r0 - heel - 0.004, 0.3 * r0)
    base = np.array([[0.0, recess], [ring - 0.002, recess], [ring, 0.0]])
    heel_pts = arc((r0 - heel, heel), heel, -np.pi / 2, 0.0, 6)
    outer = np.concatenate([base, heel_pts, wall[1:]])
    # inner side: the wall offset inwards, down to an inner bottom at y = t_bottom with a fillet
    inner_wall = offset_curve(wall, t)
    fil = min(0.006, 0.5 * (y_rim - t_bottom), 0.3 * float(inner_wall[0, 0]))
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
    handle = sweep_planar(np.c_[path, np.zeros(len(path))], (0.0, 0.0, 1.0), hw, ht, sections=12)

    params = dict(
        radius=R,
        height=H,
        wall=t,
        bottom=t_bottom,
        top_bottom_ratio=ratio,
        wall_curve=curve,
        belly=belly,
        heel=heel,
        recess=recess,
        handle_reach=reach,
        handle_top=h_top,
        handle_bottom=h_bot,
        handle_squareness=squareness,
        handle_ear=ear,
        handle_half_width=hw,
        handle_half_thickness=ht,
    )
    return rigid_object("mug", instance_id, [cup, handle], "none", params, family)


SPEC = CategorySpec(
    name="mug",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("none",),
    distance_range_m=(0.3, 0.8),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="hollow revolved mug or cup (straight, conical, espresso, cappuccino, tall, barrel) with a handle on +x",
)
