"""Bowl (NOCS-like, rigid): a revolved bowl with a rounded rim, standing on a foot ring, a flat base or a
pedestal.

Frame (NOCS): y up along the bowl's axis (the opening at +y, the foot at -y), x right, z towards the
front; metres; the amodal box is centred on the origin. The bowl is a solid of revolution about y:
symmetry ``"y"``.

Geometry: one closed cross-section loop revolved about y. The outer wall is a curve from the bottom
centre to the rim: a cubic Bezier for the round, shallow and serving families (its control points give
anything from flat-bottomed dishes to deep hemispherical or flared bowls), a flat bottom with a small
fillet and a straight (slightly drafted) wall for ramekins. The inner wall is the outer one offset by the
wall thickness, joined to it by a rounded rim. A trapezoidal foot ring stands under the bottom (no ring
on a ramekin: it stands on its flat base); a footed bowl stands on a revolved pedestal (a disc foot and a
stem) instead.

Shape families (rim diameter D, overall height H, metres):

========== ============ ============ ======================================================================
family     D            H            shape
========== ============ ============ ======================================================================
round      0.105-0.200  0.045-0.095  rice, cereal and soup bowls: deep rounded wall, foot ring (H/D 0.35-0.55)
ramekin    0.075-0.110  0.038-0.060  straight wall (0-6 deg draft), flat bottom, thick wall, no foot ring
shallow    0.180-0.300  0.030-0.060  pasta / coupe dishes: wide flat bottom, low flared wall, foot ring
serving    0.200-0.300  0.080-0.130  salad / mixing bowls: deep flared wall, foot ring or flat base
footed     0.100-0.180  0.065-0.130  dessert / compote bowl on a pedestal foot (held out)
========== ============ ============ ======================================================================

Walls 3-8 mm (ramekins 4-7 mm).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, offset_curve, revolve_profile
from . import CategorySpec, ShapeFamily
from .helpers import rigid_object, uniform

SECTIONS = 64

FAMILIES = (
    ShapeFamily("round", "rice, cereal and soup bowls: deep rounded wall on a foot ring"),
    ShapeFamily("ramekin", "ramekin / souffle dish: straight wall, flat bottom"),
    ShapeFamily("shallow", "pasta / coupe dish: wide, low, flared"),
    ShapeFamily("serving", "large salad / mixing bowl"),
    ShapeFamily("footed", "dessert / compote bowl on a pedestal foot", held_out=True),
)

# per family: (lo, hi) of rim diameter D, height H (bowl only for footed), wall, and the Bezier shape controls
RANGES = {
    "round": dict(
        diameter=(0.105, 0.200), h_ratio=(0.35, 0.55), wall=(0.003, 0.007), flat=(0.2, 0.6), bulge=(0.2, 0.6), flare=(0.0, 0.10)
    ),
    "ramekin": dict(diameter=(0.075, 0.110), h_ratio=(0.42, 0.62), wall=(0.004, 0.007)),
    "shallow": dict(
        diameter=(0.180, 0.300),
        h_ratio=(0.12, 0.22),
        wall=(0.003, 0.008),
        flat=(0.55, 0.85),
        bulge=(0.0, 0.4),
        flare=(0.05, 0.25),
    ),
    "serving": dict(
        diameter=(0.200, 0.300), h_ratio=(0.32, 0.48), wall=(0.004, 0.008), flat=(0.25, 0.6), bulge=(0.1, 0.5), flare=(0.02, 0.15)
    ),
    "footed": dict(
        diameter=(0.100, 0.180), h_ratio=(0.30, 0.45), wall=(0.003, 0.006), flat=(0.15, 0.5), bulge=(0.2, 0.6), flare=(0.0, 0.12)
    ),
}
HEIGHT_LIMITS = {
    "round": (0.045, 0.095),
    "ramekin": (0.038, 0.060),
    "shallow": (0.030, 0.060),
    "serving": (0.080, 0.130),
    "footed": (0.040, 0.080),
}


def _bezier(p: np.ndarray, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - s) ** 3 * p[0] + 3 * (1 - s) ** 2 * s * p[1] + 3 * (1 - s) * s**2 * p[2] + s**3 * p[3]


def build(rng: np.random.Generator, instance_id: str, family: str = "round") -> ArticulatedObject:
    """A random bowl of shape ``family``; see the module docstring for the frame and the ranges."""
    rg = RANGES[family]
    R = uniform(rng, *rg["diameter"]) / 2
    H = float(np.clip(2 * R * uniform(rng, *rg["h_ratio"]), *HEIGHT_LIMITS[family]))  # the bowl (pedestal excluded)
    t = uniform(rng, *rg["wall"])
    foot_h = uniform(rng, 0.003, 0.010)
    foot_frac = uniform(rng, 0.3, 0.55)  # foot ring radius / rim radius
    foot_w = uniform(rng, 0.003, 0.008)
    flat = uniform(rng, *rg.get("flat", (0.0, 0.0)))  # bottom flatness (first control point, fraction of R)
    wall_c = uniform(rng, *rg.get("bulge", (0.0, 0.0)))  # how far up the wall bulges out (second control point height)
    flare = uniform(rng, *rg.get("flare", (0.0, 0.0)))  # the rim tangent leans outwards by this fraction of R
    draft = np.radians(uniform(rng, 0.0, 6.0))  # ramekin wall draft
    fillet = uniform(rng, 0.003, 0.008)  # ramekin bottom fillet
    has_ring = int(family not in ("ramekin", "footed") and (family != "serving" or rng.random() < 0.6))
    ped_h = uniform(rng, 0.025, 0.050)  # footed: pedestal height (foot disc + stem)
    ped_r = uniform(rng, 0.30, 0.45) * R  # footed: foot disc radius
    stem_r = uniform(rng, 0.08, 0.16) * R
    if family != "footed":
        ped_h = 0.0

    y0 = foot_h if has_ring else 0.0  # the outer bottom's height at the centre (the bowl's own frame)
    y_top = H - t / 2  # the rim's half circle adds t/2
    if family == "ramekin":
        r_bot = R - (y_top - fillet) * np.tan(draft)  # straight wall leaning out by the draft angle
        n_b, n_w = 8, 10
        bottom = np.stack([np.linspace(0.0, r_bot - fillet, n_b), np.zeros(n_b)], -1)
        fil = arc((r_bot - fillet, fillet), fillet, -np.pi / 2, -draft, 6)[1:]
        w = np.linspace(0.0, 1.0, n_w)[1:, None]
        curve = np.concatenate([bottom, fil, fil[-1] + w * (np.array([R, y_top]) - fil[-1])])
    else:
        ctrl = np.array([[0.0, y0], [flat * R, y0], [R * (1.0 - flare), y0 + wall_c * (y_top - y0)], [R, y_top]])
        curve = _bezier(ctrl, 40)
    # the inner wall: the whole outer curve offset inwards by the wall thickness
    inner = offset_curve(curve, t)
    inner[0, 0] = 0.0
    # rounded rim: half circle from the outer to the inner rim point, over the top
    tang = curve[-1] - curve[-2]
    tang /= np.linalg.norm(tang)
    n_out = np.array([tang[1], -tang[0]])
    mid = curve[-1] - n_out * t / 2
    a = np.linspace(0.0, np.pi, 9)[1:-1, None]
    rim = mid + (t / 2) * (np.cos(a) * n_out + np.sin(a) * tang)

    outer = curve
    if has_ring:  # the foot ring replaces the outer curve where it stands: r in [Rf - foot_w, Rf]
        Rf = foot_frac * R
        r_c = curve[:, 0]
        r0, r1 = Rf - foot_w, Rf
        y_at = lambda r: float(np.interp(r, r_c, curve[:, 1]))  # noqa: E731 - r_c is monotonic
        ch = 0.25 * foot_w
        foot = np.array([[r0, y_at(r0)], [r0 + ch, 0.0], [r1 - ch, 0.0], [r1, y_at(r1)]])
        outer = np.concatenate([curve[r_c < r0 - 1e-6], foot, curve[r_c > r1 + 1e-6]])
    loop = np.concatenate([outer, rim, inner[::-1]])
    loop[:, 1] += ped_h
    meshes = [revolve_profile(loop, SECTIONS, closed=True)]
    if family == "footed":  # pedestal: foot disc with a rounded edge, a stem flaring into the bowl's bottom
        td = min(0.006, 0.3 * ped_h)
        r_in = np.linspace(2.0 * stem_r, 0.0, 6)  # the stem's top runs inside the bowl's bottom (half a wall up)
        top = np.stack([r_in, ped_h + np.interp(r_in, curve[:, 0], curve[:, 1]) + 0.5 * t], -1)
        ped = np.concatenate(
            [
                [[0.0, 0.0], [ped_r - td / 2, 0.0]],
                arc((ped_r - td / 2, td / 2), td / 2, -np.pi / 2, np.pi / 2, 5)[1:],
                [[stem_r * 1.6, td + 0.003], [stem_r, td + 0.35 * (ped_h - td)], [stem_r, ped_h - 0.004]],
                top,
            ]
        )
        meshes.append(revolve_profile(ped, SECTIONS, closed=False))

    params = dict(
        radius=R,
        height=H + ped_h,
        wall=t,
        foot_height=foot_h if has_ring else 0.0,
        foot_radius=foot_frac * R if has_ring else 0.0,
        foot_width=foot_w if has_ring else 0.0,
        bottom_flatness=flat,
        wall_bulge=wall_c,
        flare=flare,
        draft_rad=float(draft) if family == "ramekin" else 0.0,
        pedestal_height=ped_h,
        pedestal_radius=ped_r if ped_h else 0.0,
        stem_radius=stem_r if ped_h else 0.0,
    )
    return rigid_object("bowl", instance_id, meshes, "y", params, family)


SPEC = CategorySpec(
    name="bowl",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("y",),
    distance_range_m=(0.3, 0.9),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="revolved bowl: round, ramekin, shallow dish, serving, footed (pedestal)",
)
