"""Eyeglasses (ArtImage-like, articulated): parts ``("frame", "left_temple", "right_temple")``, two revolute joints.

Object frame (y up, x right, z towards the viewer, i.e. the direction the glasses face; metres; origin at
the frame's amodal box centre):

* ``frame``: the front, in the x-y plane facing +z: two lens rims (closed tubes along the lens outline,
  slightly tilted; a half-rim frame has a thick brow bar over the top and a thin wire below), thin
  lenses, an arched bridge (sometimes with a second, top bar), nose pads on pad arms behind the rims,
  and an end piece at each outer end that bends backwards to the hinge.
* ``right_temple`` (at +x) and ``left_temple`` (at -x): thin flattened bars from the hinge backwards
  along -z, bent down by 15-35 degrees over the last 25-35 % (the ear bend), with a hinge barrel at the
  front and a thicker ear tip.
* Joints ``frame -> left_temple`` and ``frame -> right_temple`` (revolute): vertical axes through the
  hinge points (the back ends of the end pieces). State 0 is OPEN (temples perpendicular to the front,
  pointing -z). ``right_temple`` axis ``(0, +1, 0)``, ``left_temple`` axis ``(0, -1, 0)``, so a positive
  angle folds each temple inwards behind the front. Limits ``(0, 1.45)`` rad, rest 0. At the upper limit
  the two folded temples cross each other behind the front over a few millimetres (a slight overlap).

Shape families (lens width and height of one lens, bridge = distance between the lenses, total width of
the front, temple length; metres; in the boxing system of ISO 8624 a frame marked 52-18-140 has 52 mm
lenses, an 18 mm bridge and 140 mm temples):

============ ============== ============== ============== ============== ========================================
family       lens width     lens height    bridge         temple         shape
============ ============== ============== ============== ============== ========================================
rectangular  0.048-0.058    0.55-0.75 x w  0.015-0.021    0.135-0.150    rounded rectangles, thin metal to medium rims
round        0.042-0.052    0.85-1.00 x w  0.018-0.024    0.135-0.150    circles / pantos, thin metal rims
wayfarer     0.048-0.056    0.70-0.85 x w  0.016-0.022    0.140-0.150    trapezoids wider at the top, thick acetate rims
browline     0.048-0.055    0.70-0.82 x w  0.016-0.021    0.135-0.150    half rim: thick brow bar, thin wire below
kids         0.038-0.046    0.70-0.90 x w  0.012-0.016    0.115-0.130    small rounded lenses
aviator      0.055-0.062    0.80-0.90 x w  0.016-0.020    0.135-0.150    teardrops, thin metal, double bridge (held out)
============ ============== ============== ============== ============== ========================================

The front is 8-26 mm wider than the two lenses and the bridge (end pieces): 0.105-0.16 m in all.
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine, convex_outline, curve_x_at, disc, extrude, rod, superellipse, sweep_planar
from . import CategorySpec, ShapeFamily

__all__ = ["SPEC", "build"]

LIMITS = (0.0, 1.45)
REST = 0.0


def _temple_path(pivot: np.ndarray, length: float, bend_start: float, bend_deg: float, n: int = 40) -> np.ndarray:
    """Centre line of a temple from ``pivot`` backwards (-z), bent down after ``bend_start`` (fraction)."""
    s = np.linspace(0.0, length, n)
    s0 = bend_start * length
    ramp = 0.12 * length
    u = np.clip((s - s0) / ramp, 0.0, 1.0)
    theta = np.radians(bend_deg) * u * u * (3 - 2 * u)  # smoothstep from straight to the bend angle
    ds = np.diff(s)
    th_mid = 0.5 * (theta[1:] + theta[:-1])
    dz = np.concatenate([[0.0], np.cumsum(-np.cos(th_mid) * ds)])
    dy = np.concatenate([[0.0], np.cumsum(-np.sin(th_mid) * ds)])
    return pivot[None, :] + np.stack([np.zeros(n), dy, dz], -1)


FAMILIES = (
    ShapeFamily("rectangular", "rectangular lenses, metal or medium acetate rims"),
    ShapeFamily("round", "round / panto lenses, thin metal rims"),
    ShapeFamily("wayfarer", "trapezoid lenses wider at the top, thick acetate rims and temples"),
    ShapeFamily("browline", "half-rim: thick brow bar over the lenses, thin wire below"),
    ShapeFamily("kids", "children's frames: small lenses, short temples"),
    ShapeFamily("aviator", "teardrop lenses, thin metal rims, double bridge", held_out=True),
)

# per family: (lo, hi) of lens width, lens height / width, superellipse exponent, bridge, rim half-width and
# half-depth, temple length and width, end piece height; "trapezoid", "teardrop": the lens outline's deformation
RANGES = {
    "rectangular": dict(
        lens_w=(0.048, 0.058),
        h_ratio=(0.55, 0.75),
        p=(3.0, 4.5),
        bridge=(0.015, 0.021),
        rim_w=(0.0008, 0.0025),
        rim_d=(0.0008, 0.0020),
        temple=(0.135, 0.150),
        temple_w=(0.0010, 0.0022),
        end_h=(0.0030, 0.0060),
    ),
    "round": dict(
        lens_w=(0.042, 0.052),
        h_ratio=(0.85, 1.00),
        p=(2.0, 2.4),
        bridge=(0.018, 0.024),
        rim_w=(0.0006, 0.0012),
        rim_d=(0.0007, 0.0012),
        temple=(0.135, 0.150),
        temple_w=(0.0009, 0.0014),
        end_h=(0.0025, 0.0040),
    ),
    "wayfarer": dict(
        lens_w=(0.048, 0.056),
        h_ratio=(0.70, 0.85),
        p=(2.6, 3.6),
        bridge=(0.016, 0.022),
        rim_w=(0.0025, 0.0045),
        rim_d=(0.0022, 0.0032),
        temple=(0.140, 0.150),
        temple_w=(0.0025, 0.0038),
        end_h=(0.0070, 0.0100),
        trapezoid=(0.08, 0.18),
    ),
    "browline": dict(
        lens_w=(0.048, 0.055),
        h_ratio=(0.70, 0.82),
        p=(2.5, 3.5),
        bridge=(0.016, 0.021),
        rim_w=(0.0025, 0.0040),
        rim_d=(0.0020, 0.0030),
        temple=(0.135, 0.150),
        temple_w=(0.0012, 0.0022),
        end_h=(0.0050, 0.0080),
    ),
    "kids": dict(
        lens_w=(0.038, 0.046),
        h_ratio=(0.70, 0.90),
        p=(2.2, 3.2),
        bridge=(0.012, 0.016),
        rim_w=(0.0012, 0.0025),
        rim_d=(0.0010, 0.0020),
        temple=(0.115, 0.130),
        temple_w=(0.0012, 0.0022),
        end_h=(0.0035, 0.0060),
    ),
    "aviator": dict(
        lens_w=(0.055, 0.062),
        h_ratio=(0.80, 0.90),
        p=(2.0, 2.6),
        bridge=(0.016, 0.020),
        rim_w=(0.0007, 0.0012),
        rim_d=(0.0007, 0.0012),
        temple=(0.135, 0.150),
        temple_w=(0.0009, 0.0014),
        end_h=(0.0025, 0.0040),
        teardrop=(0.30, 0.55),
    ),
}


def _lens_outline(a: float, b: float, p: float, trapezoid: float, teardrop: float, n: int) -> np.ndarray:
    """Convex counter-clockwise ``(n, 2)`` outline of the RIGHT lens (the nose at -x), centred on its box
    centre: a superellipse of half-axes ``a``, ``b``, made wider at the top (``trapezoid``) or drooping
    towards the nose at the bottom (``teardrop``), then replaced by its convex hull."""
    pts = superellipse(a, b, p, n=4 * n)
    if trapezoid == 0.0 and teardrop == 0.0:
        return superellipse(a, b, p, n=n)
    x, y = pts[:, 0], pts[:, 1]
    x = x * (1.0 + trapezoid * y / b)
    low = np.clip(-y / b, 0.0, 1.0)  # 0 at mid height, 1 at the bottom
    y = np.where(y < 0, y * (1.0 + teardrop * (1.0 - x / a) / 2.0), y)  # the nose side droops more
    x = x - teardrop * 0.35 * a * low**2
    out = convex_outline(np.stack([x, y], -1), n)
    lo, hi = out.min(0), out.max(0)
    return (out - 0.5 * (lo + hi)) * np.array([2 * a, 2 * b]) / (hi - lo)


def build(rng: np.random.Generator, instance_id: str, family: str = "rectangular") -> ArticulatedObject:
    """A random pair of glasses of shape ``family``; see the module docstring for the frame and joint conventions."""
    rg = RANGES[family]
    Lw = rng.uniform(*rg["lens_w"])  # lens width
    Lh = Lw * rng.uniform(*rg["h_ratio"])  # lens height
    p_shape = rng.uniform(*rg["p"])  # superellipse exponent: oval (2) to rounded rectangle
    trapezoid = rng.uniform(*rg.get("trapezoid", (0.0, 0.0)))
    teardrop = rng.uniform(*rg.get("teardrop", (0.0, 0.0)))
    tilt = np.radians(rng.uniform(-4.0, 6.0))
    bridge = rng.uniform(*rg["bridge"])  # distance between the lenses at centre height
    rw = rng.uniform(*rg["rim_w"])  # rim half-width in the plane
    rd = rng.uniform(*rg["rim_d"])  # rim half-depth along z
    base_w = 2 * Lw + bridge + 2 * rw
    Wt = base_w + rng.uniform(0.008, 0.026)  # total width
    lens_t = rng.uniform(0.0010, 0.0020)
    bridge_u = rng.uniform(0.15, 0.45)  # bridge height as a fraction of the lens half height
    arch = rng.uniform(0.0008, 0.0040)
    bridge_r = rng.uniform(0.0007, 0.0014) if family != "wayfarer" else rng.uniform(0.0018, 0.0026)
    double_bridge = int(family == "aviator" or (family in ("rectangular", "round") and rng.random() < 0.25))
    end_u = rng.uniform(0.15, 0.55)  # end piece height (fraction of lens half height)
    end_depth = rng.uniform(0.006, 0.011)  # how far behind the front the hinge is
    eh = rng.uniform(*rg["end_h"])  # end piece / temple front height
    ew = rng.uniform(0.0016, 0.0026) if family != "wayfarer" else rng.uniform(0.0035, 0.0050)  # end piece width
    L = rng.uniform(*rg["temple"])  # temple length
    bend_frac = rng.uniform(0.25, 0.35)
    bend_deg = rng.uniform(15.0, 35.0)
    tw = rng.uniform(*rg["temple_w"])  # temple width (x)
    pad_r = rng.uniform(0.0035, 0.0055)
    brow_cut = rng.uniform(-0.1, 0.25)  # browline: the brow bar covers the outline above this fraction of b

    a, b = Lw / 2, Lh / 2
    xc = bridge / 2 + rw + a  # lens centres at +-xc (rim centre line at the lens boundary + rw)
    frame_parts = []
    rims = {}
    rim_right = _lens_outline(a + rw, b + rw, p_shape, trapezoid, teardrop, 56)
    lens_grow = rw - 0.0004 if family == "browline" else 0.3 * rw  # a half-rim's lens reaches its thin wire
    lens_right = _lens_outline(a + lens_grow, b + lens_grow, p_shape, trapezoid, teardrop, 40)
    c, s = np.cos(tilt), np.sin(tilt)
    rot = np.array([[c, s], [-s, c]])
    for side in (-1, 1):
        mirror = np.array([side, 1.0])
        curve = (rim_right @ rot + np.array([xc, 0.0])) * mirror
        rims[side] = curve
        path = np.c_[curve, np.zeros(len(curve))]
        if family == "browline":  # thick brow bar over the top, a thin wire (the nylon thread) below
            k = np.clip((rim_right[:, 1] / (b + rw) - brow_cut) / 0.25, 0.0, 1.0)
            frame_parts.append(
                sweep_planar(path, (0, 0, 1), 0.0005 + (rd - 0.0005) * k, 0.0005 + (rw - 0.0005) * k, sections=8, closed=True)
            )
        else:
            frame_parts.append(sweep_planar(path, (0, 0, 1), rd, rw, sections=8, closed=True))
        lens = (lens_right @ rot + np.array([xc, 0.0])) * mirror
        frame_parts.append(extrude(lens, lens_t, plane="xy", offset=0.0))

    # bridge: an arch between the inner sides of the rims (and optionally a straight top bar)
    yb = bridge_u * b
    xin = curve_x_at(rims[1], yb, xc, -1)
    t = np.linspace(-1.0, 1.0, 17)
    arch_path = np.stack([t * xin, yb + arch * (1 - t**2), np.zeros_like(t)], -1)
    frame_parts.append(sweep_planar(arch_path, (0, 0, 1), bridge_r * 1.2, bridge_r, sections=8))
    if double_bridge:
        yt = 0.8 * b
        xt = curve_x_at(rims[1], yt, xc, -1)
        frame_parts.append(rod((-xt, yt, 0.0), (xt, yt, 0.0), 0.8 * bridge_r, 8))

    # nose pads on arms, behind the rims near the bridge
    for side in (-1, 1):
        y_arm = -0.15 * b
        x_arm = curve_x_at(rims[side], y_arm, side * xc, -side)
        pad_c = np.array([side * (bridge / 2 + 0.0025), -0.45 * b, -0.006])
        frame_parts.append(rod((x_arm, y_arm, -rd * 0.5), pad_c + np.array([side * 0.0012, 0.0, 0.0]), 0.0004, 6))
        pad = superellipse(pad_r, 0.6 * pad_r, 2.0, 12)  # (y, z) oval
        m = extrude(pad, 0.0012, plane="yz", offset=0.0)
        # tilt the pad so it faces the nose (inwards and a little backwards)
        ang = side * np.radians(25.0)
        R = np.array([[np.cos(ang), 0.0, np.sin(ang)], [0.0, 1.0, 0.0], [-np.sin(ang), 0.0, np.cos(ang)]])
        m.vertices = m.vertices @ R.T + pad_c
        frame_parts.append(m)

    # end pieces: from the rim's outer side outwards, bending back to the hinge
    ye = end_u * b
    pivots = {}
    x_outer = Wt / 2 - ew / 2  # centre line of the outermost part of the end piece
    r_bend = min(0.6 * end_depth, 0.004)
    for side in (-1, 1):
        x_rim = abs(curve_x_at(rims[side], ye, side * xc, side)) - 0.5 * rw
        straight = np.linspace(x_rim, x_outer - r_bend, 5)[:-1]
        ang = np.linspace(0.0, 0.5 * np.pi, 7)
        bend_x = x_outer - r_bend + r_bend * np.sin(ang)
        bend_z = -r_bend + r_bend * np.cos(ang)
        tail_z = np.linspace(-r_bend, -end_depth, 4)[1:]
        px = np.concatenate([straight, bend_x, np.full(3, x_outer)])
        pz = np.concatenate([np.zeros(4), bend_z, tail_z])
        path = np.stack([side * px, np.full(len(px), ye), pz], -1)
        frame_parts.append(sweep_planar(path, (0, 1, 0), eh / 2, ew / 2, sections=8))
        pivots[side] = np.array([side * x_outer, ye, -end_depth])

    temples = {}
    for side in (-1, 1):
        piv = pivots[side]
        path = _temple_path(piv + np.array([0.0, 0.0, -0.0005]), L - 0.0005, 1.0 - bend_frac, bend_deg)
        u = np.linspace(0.0, 1.0, len(path))
        # flattened section: tall at the hinge, slimmer along the side, a thicker ear tip
        h = eh / 2 * (1.0 - 0.45 * np.clip(u / 0.3, 0, 1)) + 0.0006 * np.clip((u - 0.6) / 0.3, 0, 1)
        w = tw / 2 * (1.0 + 0.5 * np.clip((u - 0.6) / 0.3, 0, 1))
        parts = [sweep_planar(path, (1, 0, 0), w, h, sections=10)]
        parts.append(disc(max(ew, tw) / 2 + 0.0003, eh * 0.9, piv, "y", 12))  # hinge barrel, on the axis
        temples[side] = combine(parts)

    frame, T_frame = make_part("frame", combine(frame_parts))
    left, T_left = make_part("left_temple", temples[-1])
    right, T_right = make_part("right_temple", temples[1])
    params = dict(
        total_width=Wt,
        lens_width=Lw,
        lens_height=Lh,
        lens_shape_exponent=p_shape,
        lens_tilt_rad=float(tilt),
        bridge_width=bridge,
        rim_half_width=rw,
        rim_half_depth=rd,
        lens_thickness=lens_t,
        bridge_height_frac=bridge_u,
        bridge_arch=arch,
        bridge_radius=bridge_r,
        double_bridge=double_bridge,
        end_piece_height_frac=end_u,
        hinge_depth=end_depth,
        end_piece_height=eh,
        end_piece_width=ew,
        temple_length=L,
        bend_fraction=bend_frac,
        bend_deg=bend_deg,
        temple_width=tw,
        nose_pad_radius=pad_r,
        trapezoid=trapezoid,
        teardrop=teardrop,
        brow_cut=brow_cut if family == "browline" else 0.0,
    )
    joints = [
        dict(type="revolute", parent=0, child=1, pivot=pivots[-1], axis=(0.0, -1.0, 0.0), limits=LIMITS, rest=REST),
        dict(type="revolute", parent=0, child=2, pivot=pivots[1], axis=(0.0, 1.0, 0.0), limits=LIMITS, rest=REST),
    ]
    return build_object(
        "eyeglasses",
        instance_id,
        [(frame, T_frame), (left, T_left), (right, T_right)],
        joints=joints,
        params=params,
        shape_family=family,
    )


SPEC = CategorySpec(
    name="eyeglasses",
    family="artimage",
    part_names=("frame", "left_temple", "right_temple"),
    joint_types=("revolute", "revolute"),
    symmetry=("none", "none", "none"),
    distance_range_m=(0.28, 0.55),
    elevation_range_deg=(10.0, 60.0),
    shape_families=FAMILIES,
    build=build,
    description="eyeglasses: front frame + two temples on vertical revolute hinges (fold inwards)",
)
