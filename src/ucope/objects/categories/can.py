"""Can (NOCS-like, rigid): a drink can or a food tin, one revolved solid.

Frame (NOCS): y up along the can's axis (the lid at +y), x right, z towards the front; metres; the
amodal box is centred on the origin. Solid of revolution about y: symmetry ``"y"`` (no pull tab).

Geometry: one open profile revolved about y, from the bottom centre to the lid centre:

* ``style = 0`` (drink can): a domed-in bottom on a standing ring, a chamfered heel, a straight body,
  a tapered neck (to ``neck_ratio`` of the radius) and a rolled lip around a lid inset by a few mm.
* ``style = 1`` (food tin): seamed rims (small lips) top and bottom at the full radius, a body slightly
  thinner than the rims with a few circumferential ribs, and lids inset at both ends.

Shape families (outer diameter D, height H; metres):

========= ============== ============== ==========================================================
family    D              H              products
========= ============== ============== ==========================================================
standard  0.065-0.068    0.115-0.135    drink can, 330 ml (115 x 66 mm), 355 ml (122 mm), 440 ml (135 mm)
slim      0.053-0.058    0.088-0.146    slim / sleek drink cans: 150 ml mini, 250 ml slim (134 x 53), 330 ml sleek (146 x 58)
tall      0.065-0.068    0.155-0.170    tall drink / energy cans, 473-568 ml (500 ml: 168 x 66 mm)
food      0.065-0.101    0.070-0.120    food tins (ribbed or plain), 200-800 g
squat     0.065-0.100    0.035-0.055    squat tins (tuna, pet food, 85 x 40 mm); held out
========= ============== ============== ==========================================================

Drink cans (standard, slim, tall) have the drink-can profile (``style`` 0), the others the food-tin one
(``style`` 1).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, revolve_profile
from . import CategorySpec, ShapeFamily
from .helpers import rigid_object, uniform

SECTIONS = 48


def _drink_can(R: float, H: float, rng: np.random.Generator, p: dict) -> np.ndarray:
    neck_ratio = p["neck_ratio"] = uniform(rng, 0.82, 0.93)
    neck_h = p["neck_height"] = uniform(rng, 0.06, 0.12) * H
    dome = p["dome_depth"] = uniform(rng, 0.08, 0.2) * R
    inset = p["lid_inset"] = uniform(rng, 0.002, 0.005)
    heel_h = p["heel_height"] = uniform(rng, 0.05, 0.1) * H
    lip = p["lip"] = uniform(rng, 0.0008, 0.0016)
    Rn = neck_ratio * R
    ring_r = 0.78 * R
    # bottom: dome (from the centre, up inside) -> standing ring -> heel chamfer -> body
    rr = np.linspace(0.0, ring_r - 0.002, 7)
    dome_pts = np.stack([rr, dome * (1.0 - (rr / (ring_r - 0.002)) ** 2)], -1)
    ring = arc((ring_r, 0.002), 0.002, np.pi, 2 * np.pi, 5)[1:]
    u = np.linspace(0.0, 1.0, 6)[1:]
    heel = np.stack(
        [ring_r + 0.002 + (R - ring_r - 0.002) * np.sin(u * np.pi / 2), 0.002 + heel_h * (1 - np.cos(u * np.pi / 2))], -1
    )
    body_top = H - neck_h
    body = np.array([[R, body_top]])
    w = np.linspace(0.0, 1.0, 9)[1:]
    y_lip = H - 2 * lip
    neck = np.stack([Rn + (R - Rn) * 0.5 * (1 + np.cos(np.pi * w)), body_top + w * (y_lip - body_top)], -1)
    # rolled lip: a small circle on top of the neck, then down into the lid recess
    roll = arc((Rn, H - lip), lip, -np.pi / 2 + 0.3, np.pi, 7)
    recess = np.array([[Rn - lip - 0.0005, H - inset], [0.0, H - inset]])
    return np.concatenate([dome_pts, ring, heel, body, neck, roll, recess])


def _food_tin(R: float, H: float, rng: np.random.Generator, p: dict) -> np.ndarray:
    rim_h = p["rim_height"] = uniform(rng, 0.002, 0.004)
    step = p["body_step"] = uniform(rng, 0.0008, 0.0018)
    inset = p["lid_inset"] = uniform(rng, 0.002, 0.004)
    n_ribs = p["n_ribs"] = min(int(rng.integers(0, 11)), max(0, int((H - 0.012) / 0.008)))
    rib_depth = p["rib_depth"] = uniform(rng, 0.0004, 0.001)
    Rbody = R - step
    r_lid = R - rim_h - 0.0005
    bottom = np.array([[0.0, inset], [r_lid, inset], [r_lid + 0.0004, 0.0004], [r_lid + 0.001, 0.0]])
    rim_lo = arc((R - rim_h / 2, rim_h / 2), rim_h / 2, -np.pi / 2, np.pi / 2, 7)
    y0, y1 = rim_h + 0.002, H - rim_h - 0.002
    ys = np.linspace(y0, y1, 90)
    gap = (y1 - y0) / (n_ribs + 1)
    centres = y0 + gap * np.arange(1, n_ribs + 1)
    rib = np.exp(-(((ys[:, None] - centres[None, :]) / (0.22 * min(gap, 0.012))) ** 2)).sum(1)
    body = np.stack([Rbody - rib_depth * rib, ys], -1)
    body = np.concatenate([[[Rbody, rim_h]], body, [[Rbody, H - rim_h]]])
    rim_hi = arc((R - rim_h / 2, H - rim_h / 2), rim_h / 2, -np.pi / 2, np.pi / 2, 7)
    top = np.array([[r_lid + 0.001, H], [r_lid + 0.0004, H - 0.0004], [r_lid, H - inset], [0.0, H - inset]])
    return np.concatenate([bottom, rim_lo, body, rim_hi, top])


FAMILIES = (
    ShapeFamily("standard", "drink can, 330-440 ml"),
    ShapeFamily("slim", "slim / sleek drink cans, 150-330 ml"),
    ShapeFamily("tall", "tall drink / energy cans, 473-568 ml"),
    ShapeFamily("food", "food tins, 200-800 g"),
    ShapeFamily("squat", "squat tins: tuna, pet food", held_out=True),
)

# per family: (lo, hi) of diameter and height (m), and the profile style (0 drink can, 1 food tin)
RANGES = {
    "standard": dict(diameter=(0.065, 0.068), height=(0.115, 0.135), style=0),
    "slim": dict(diameter=(0.053, 0.058), height=(0.088, 0.146), style=0),
    "tall": dict(diameter=(0.065, 0.068), height=(0.155, 0.170), style=0),
    "food": dict(diameter=(0.065, 0.101), height=(0.070, 0.120), style=1),
    "squat": dict(diameter=(0.065, 0.100), height=(0.035, 0.055), style=1),
}


def build(rng: np.random.Generator, instance_id: str, family: str = "standard") -> ArticulatedObject:
    """A random can of shape ``family``; see the module docstring for the frame and the ranges."""
    rg = RANGES[family]
    R = uniform(rng, *rg["diameter"]) / 2
    H = uniform(rng, *rg["height"])
    style = rg["style"]
    params: dict = dict(radius=R, height=H, style=style)
    prof = _food_tin(R, H, rng, params) if style else _drink_can(R, H, rng, params)
    mesh = revolve_profile(prof, SECTIONS, closed=False)
    return rigid_object("can", instance_id, [mesh], "y", params, family)


SPEC = CategorySpec(
    name="can",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("y",),
    distance_range_m=(0.3, 0.8),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description=(
        "revolved drink can (standard, slim, tall: domed bottom, neck, rolled lip) "
        "or food tin (food, squat: seamed rims, ribs)"
    ),
)
