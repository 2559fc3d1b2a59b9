"""Bottle (NOCS-like, rigid): a hollow revolved bottle with a shoulder, a neck, a lip, maybe a cap.

Frame (NOCS): y up along the bottle's axis (the cap / mouth at +y, the base at -y), x right, z towards
the front; metres; the amodal box is centred on the origin. The bottle is a solid of revolution about
y, so its symmetry tag is ``"y"`` (any rotation about y gives the same shape; x and z carry no meaning).

Geometry: one closed cross-section loop revolved about y (wall thickness 1-2.5 mm): the outer side
runs from the base centre (a shallow punt) over a rounded heel, up the body (radius ``body_radius``,
with an optional grip waist), over the shoulder (from conical/S-shaped to dome-like, drawn by
``shoulder_roundness``), up the (slightly tapered) neck to the mouth, and back down the inner side.
A bead ring forms the lip; some instances (``has_cap``) carry a screw cap with a tamper ring below.

Shape families (overall height H with the cap, body diameter D, outer neck radius at the mouth;
metres):

======= ============ ============== ================ ==========================================================
family  H            D              neck radius      shape
======= ============ ============== ================ ==========================================================
wine    0.28-0.35    0.068-0.085    0.0140-0.0155    shoulder 8-25 % of H, neck 22-30 %, punt 3-9 % of H, foil capsule (60 %)
water   0.18-0.33    0.055-0.092    0.0125-0.0140    rounded shoulder, short neck, screw cap, grip waist (40 %)
slim    0.19-0.30    0.045-0.062    0.0105-0.0135    long neck (15-32 % of H), crown or screw cap (70 %)
flask   0.17-0.28    0.060-0.080    0.62-0.85 x D/2  no shoulder: a short dome (2-6 % of H), wide mouth, tall cap
squat   0.09-0.16    0.060-0.100    0.45-0.75 x D/2  jar-like: wide neck, short shoulder, wide cap (held out)
======= ============ ============== ================ ==========================================================
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, offset_curve, revolve_profile
from . import CategorySpec, ShapeFamily
from .helpers import rigid_object, uniform

SECTIONS = 48


FAMILIES = (
    ShapeFamily("wine", "75 cl wine bottle (Bordeaux, Burgundy, flute): long neck, punt, foil capsule or bare"),
    ShapeFamily("water", "PET water / soft-drink bottle, 0.33-1.5 l: short neck, screw cap, some with a grip waist"),
    ShapeFamily("slim", "narrow glass bottle: longneck beer, oil, sauce, 25 cl water"),
    ShapeFamily("flask", "sports / aluminium bottle without a shoulder: straight body, wide mouth, tall cap"),
    ShapeFamily("squat", "squat jar-like bottle: wide neck, short shoulder, wide cap", held_out=True),
)

# per family: (lo, hi) of height H, body diameter D, neck radius (m, or ``neck_rel``: fraction of the body
# radius), wall, shoulder and neck lengths (fractions of H), shoulder roundness, punt (fraction of H),
# probability of a cap and the cap's height and radial overhang
RANGES = {
    "wine": dict(
        height=(0.28, 0.35),
        diameter=(0.068, 0.085),
        neck=(0.0140, 0.0155),
        wall=(0.003, 0.005),
        shoulder=(0.08, 0.25),
        neck_len=(0.22, 0.30),
        roundness=(0.0, 0.8),
        punt=(0.03, 0.09),
        p_cap=0.6,
        cap_h=(0.035, 0.060),
        cap_extra=(0.0012, 0.002),
        p_waist=0.0,
    ),
    "water": dict(
        height=(0.18, 0.33),
        diameter=(0.055, 0.092),
        neck=(0.0125, 0.0140),
        wall=(0.001, 0.0015),
        shoulder=(0.12, 0.25),
        neck_len=(0.04, 0.08),
        roundness=(0.3, 1.0),
        punt=(0.0, 0.02),
        p_cap=1.0,
        cap_h=(0.012, 0.020),
        cap_extra=(0.0015, 0.003),
        p_waist=0.4,
    ),
    "slim": dict(
        height=(0.19, 0.30),
        diameter=(0.045, 0.062),
        neck=(0.0105, 0.0135),
        wall=(0.002, 0.004),
        shoulder=(0.10, 0.25),
        neck_len=(0.15, 0.32),
        roundness=(0.0, 1.0),
        punt=(0.0, 0.03),
        p_cap=0.7,
        cap_h=(0.006, 0.020),
        cap_extra=(0.0015, 0.0025),
        p_waist=0.0,
    ),
    "flask": dict(
        height=(0.17, 0.28),
        diameter=(0.060, 0.080),
        neck_rel=(0.62, 0.85),
        wall=(0.001, 0.002),
        shoulder=(0.02, 0.06),
        neck_len=(0.03, 0.06),
        roundness=(0.8, 1.0),
        punt=(0.0, 0.015),
        p_cap=1.0,
        cap_h=(0.020, 0.045),
        cap_extra=(0.001, 0.003),
        p_waist=0.0,
    ),
    "squat": dict(
        height=(0.09, 0.16),
        diameter=(0.060, 0.100),
        neck_rel=(0.45, 0.75),
        wall=(0.002, 0.004),
        shoulder=(0.06, 0.15),
        neck_len=(0.05, 0.12),
        roundness=(0.5, 1.0),
        punt=(0.0, 0.02),
        p_cap=1.0,
        cap_h=(0.012, 0.020),
        cap_extra=(0.0015, 0.003),
        p_waist=0.0,
    ),
}


def build(rng: np.random.Generator, instance_id: str, family: str = "wine") -> ArticulatedObject:
    """A random bottle of shape ``family``; see the module docstring for the frame and the ranges."""
    rg = RANGES[family]
    H = uniform(rng, *rg["height"])
    Rb = uniform(rng, *rg["diameter"]) / 2
    Rn = uniform(rng, *rg["neck"]) if "neck" in rg else Rb * uniform(rng, *rg["neck_rel"])
    t = uniform(rng, *rg["wall"])
    shoulder_frac = uniform(rng, *rg["shoulder"])  # of the height
    neck_frac = uniform(rng, *rg["neck_len"])
    roundness = uniform(rng, *rg["roundness"])  # 0: S-shaped / conical shoulder, 1: dome
    waist_depth = uniform(rng, 0.03, 0.08) if rng.random() < rg["p_waist"] else 0.0  # grip waist, fraction of Rb
    waist_pos = uniform(rng, 0.35, 0.65)
    neck_taper = uniform(rng, 0.0, 0.2) if family in ("wine", "slim") else uniform(rng, 0.0, 0.06)
    heel = uniform(rng, 0.12, 0.3) * Rb  # rounded heel radius
    punt = uniform(rng, *rg["punt"]) * H
    lip_w = uniform(rng, 0.0012, 0.003)
    lip_h = uniform(rng, 0.003, 0.010)
    has_cap = int(rng.random() < rg["p_cap"])
    cap_h = uniform(rng, *rg["cap_h"])
    cap_extra = uniform(rng, *rg["cap_extra"])
    Rn = min(Rn, Rb - cap_extra - 0.001) if has_cap else Rn
    neck_taper = min(neck_taper, (Rb - 0.0005) / Rn - 1.0)
    if has_cap:  # the cap sits on the neck, above the shoulder
        neck_frac = max(neck_frac, (cap_h + 0.006) / H)

    top = H - (0.0015 if has_cap else t / 2)  # mouth height (inside the cap's top plate when capped)
    y_neck = top - neck_frac * H
    y_shoulder = y_neck - shoulder_frac * H
    y_heel = heel

    # outer side, from the base centre outwards and upwards
    n_base = 6
    r_base = np.linspace(0.0, Rb - heel, n_base)
    base = np.stack([r_base, punt * (1 - (r_base / (Rb - heel)) ** 2) ** 2], -1)
    heel_pts = arc((Rb - heel, heel), heel, -np.pi / 2, 0.0, 7)[1:]
    s = np.linspace(0.0, 1.0, 18)[1:]
    body_y = y_heel + s * (y_shoulder - y_heel)
    waist = 1.0 - waist_depth * np.exp(-(((s - waist_pos) / 0.16) ** 2))
    body = np.stack([Rb * waist, body_y], -1)
    u = np.linspace(0.0, 1.0, 16)[1:]
    g = (1.0 - roundness) * 0.5 * (1.0 + np.cos(np.pi * u)) + roundness * np.sqrt(np.clip(1.0 - u**2, 0.0, 1.0))
    r_neck_base = Rn * (1.0 + neck_taper)
    shoulder = np.stack([r_neck_base + (Rb - r_neck_base) * g, y_shoulder + u * (y_neck - y_shoulder)], -1)
    v = np.linspace(0.0, 1.0, 6)[1:]
    neck = np.stack([r_neck_base + (Rn - r_neck_base) * v, y_neck + v * (top - y_neck)], -1)
    outer = np.concatenate([base, heel_pts, body, shoulder, neck])
    inner = offset_curve(outer, t)
    inner[0, 0] = 0.0
    inner[-1, 1] = top
    # round the mouth: a half circle over the wall from the outer to the inner side
    mouth = arc((Rn - t / 2, top), t / 2, 0.0, np.pi, 7)[1:-1]
    loop = np.concatenate([outer, mouth, inner[::-1]])
    meshes = [revolve_profile(loop, SECTIONS, closed=True)]

    # lip bead ring at the mouth
    lip_top = top - (0.0 if not has_cap else 0.004)
    if has_cap:  # keep the bead inside the cap
        lip_w = min(lip_w, cap_extra - 0.0005)
    bead = np.concatenate(
        [
            arc((Rn + lip_w - lip_w / 2, lip_top - lip_w / 2), lip_w / 2, 0.0, np.pi / 2, 4),
            [[Rn - 0.3 * t, lip_top], [Rn - 0.3 * t, lip_top - lip_h]],
            arc((Rn + lip_w - lip_w / 2, lip_top - lip_h + lip_w / 2), lip_w / 2, -np.pi / 2, 0.0, 4),
        ]
    )
    meshes.append(revolve_profile(bead, SECTIONS, closed=True))

    if has_cap:
        Rc = Rn + cap_extra
        f = min(0.0015, 0.3 * cap_h)
        y0 = H - cap_h
        cap = np.concatenate(
            [
                [[0.0, y0 + 0.001], [Rc - 0.0005, y0]],
                [[Rc, y0 + 0.0008], [Rc, H - f]],
                arc((Rc - f, H - f), f, 0.0, np.pi / 2, 4),
                [[0.0, H]],
            ]
        )
        meshes.append(revolve_profile(cap, SECTIONS, closed=False))
        # tamper-evident ring just below the cap
        ring = np.array([[Rn, y0 - 0.004], [Rc - 0.0004, y0 - 0.004], [Rc - 0.0004, y0 - 0.0005], [Rn, y0 - 0.0005]])
        meshes.append(revolve_profile(ring, SECTIONS, closed=True))

    params = dict(
        height=H,
        body_radius=Rb,
        neck_radius=Rn,
        wall=t,
        shoulder_frac=shoulder_frac,
        neck_frac=neck_frac,
        shoulder_roundness=roundness,
        waist_depth=waist_depth,
        waist_pos=waist_pos,
        neck_taper=neck_taper,
        heel_radius=heel,
        punt=punt,
        lip_width=lip_w,
        lip_height=lip_h,
        has_cap=has_cap,
        cap_height=cap_h,
        cap_extra=cap_extra,
    )
    return rigid_object("bottle", instance_id, meshes, "y", params, family)


SPEC = CategorySpec(
    name="bottle",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("y",),
    distance_range_m=(0.35, 0.9),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="hollow revolved bottle: wine, water, slim, flask (no shoulder), squat jar; some with a cap",
)
