"""Scissors (ArtImage-like, articulated): parts ``("blade_a", "blade_b")``, one revolute joint.

Object frame (y up, x right, z towards the viewer; metres; origin at blade_a's amodal box centre):
the scissors lie flat in the x-z plane (thin along y) with the blades pointing to -z and the finger
loops towards +z. The pivot screw sits at the construction origin; ``y = 0`` is the contact plane of
the two blades (each layer keeps 0.05 mm of clearance from it).

* ``blade_a`` (upper layer, ``y`` in ``[0, t_a]``): a tapered convex blade (cutting edge on its -x
  side, curved spine on +x), a pivot hub with the screw head, a shank and its finger loop at -x.
* ``blade_b`` (lower layer, ``y`` in ``[-t_b, 0]``): the mirror blade (cutting edge on +x), the nut,
  a shank and its finger loop at +x. The finger loops are thicker than the blades (plastic bands, or
  thin metal rings) and centred on ``y = 0``; curved blades (nail scissors) bend towards +x, both the same
  way, so they stay together when closed.
* Joint ``blade_a -> blade_b`` (revolute): axis ``(0, 1, 0)`` through the pivot screw. State 0 is
  CLOSED (blades aligned); a positive angle rotates blade_b about +y, which moves its tip to -x and its
  loop to +x: the tips and the loops separate (the scissors open). Limits ``(0, 1.0)`` rad, rest 0.

Shape families (overall length from the blade tips to the far end of the loops, blade length from the
pivot to the tip, blade thickness, finger loops; metres):

============= ============ ============= =============== ===============================================
family        length       blade         thickness       loops
============= ============ ============= =============== ===============================================
office        0.170-0.220  0.45-0.56 x   0.0015-0.0025   plastic, oval, the finger loop 1-1.3x the thumb loop
kitchen       0.200-0.250  0.42-0.52 x   0.0022-0.0032   plastic, a large finger loop (1.3-1.7x), broad blades
craft         0.120-0.160  0.40-0.50 x   0.0012-0.0020   plastic, two equal round loops, blunt tips
nail          0.085-0.105  0.28-0.36 x   0.0012-0.0018   metal rings (2-3 mm bands), narrow curved blades
hairdressing  0.140-0.190  0.45-0.55 x   0.0018-0.0026   metal rings, slim blades, a finger rest (held out)
============= ============ ============= =============== ===============================================
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine, disc, extrude, rod, sweep_planar
from . import CategorySpec, ShapeFamily

__all__ = ["SPEC", "build"]

LIMITS = (0.0, 1.0)
REST = 0.0
GAP = 0.00005  # half the clearance between the two blades (they slide on each other)


def _blade_poly(
    length: float, hw_spine: float, hw_edge: float, p_spine: float, blunt: float, heel: float, side: int
) -> np.ndarray:
    """Convex outline (x, z) of a blade pointing to -z; the spine is on ``side`` (+1: +x), the edge opposite."""
    u = np.linspace(0.0, 1.0 - blunt, 14)
    z = -u * length
    xs = side * hw_spine * (1.0 - u) ** p_spine
    xe = -side * hw_edge * (1.0 - u)
    spine = np.stack([xs, z], -1)
    edge = np.stack([xe, z], -1)[::-1]
    heel_pts = np.array([[-side * hw_edge, heel], [side * hw_spine, heel]])  # behind the pivot
    return np.concatenate([spine, edge, heel_pts])


def _blade(
    length: float,
    hw_spine: float,
    hw_edge: float,
    p_spine: float,
    blunt: float,
    heel: float,
    side: int,
    bend: float,
    thickness: float,
    yc: float,
) -> list:
    """The blade as extruded convex pieces (thickness along y, centred on ``yc``). Straight: one convex
    polygon (:func:`_blade_poly`). Curved (``bend > 0``): the part in front of the pivot is bent towards +x
    (``x += bend * length * u^2``, u the fraction of the blade length) and cut into convex strips."""
    poly = _blade_poly(length, hw_spine, hw_edge, p_spine, blunt, heel, side)
    if bend <= 0.0:
        return [extrude(poly, thickness, plane="xz", offset=yc)]
    n = 14  # _blade_poly: 14 spine points, 14 edge points (reversed), 2 heel points
    spine, edge = poly[:n], poly[n : 2 * n][::-1]
    u = np.clip(-spine[:, 1] / length, 0.0, 1.0)
    shift = np.c_[bend * length * u**2, np.zeros(n)]
    spine, edge = spine + shift, edge + shift
    heel_poly = np.concatenate([spine[:1], edge[:1], poly[2 * n :]])
    out = [extrude(heel_poly, thickness, plane="xz", offset=yc)]
    for i in range(n - 1):
        out.append(extrude(np.stack([spine[i], spine[i + 1], edge[i + 1], edge[i]]), thickness, plane="xz", offset=yc))
    return out


def _shank_poly(p1: np.ndarray, w0: float, w1: float) -> np.ndarray:
    """Trapezoid (x, z) from the pivot (width ``2 w0``) to ``p1`` (width ``2 w1``)."""
    d = p1 / np.linalg.norm(p1)
    n = np.array([-d[1], d[0]])
    return np.stack([w0 * n, p1 + w1 * n, p1 - w1 * n, -w0 * n])


def _loop(cx: float, cz: float, a: float, b: float, half_t: float, half_w: float, tilt: float) -> trimesh.Trimesh:
    t = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
    x, z = a * np.cos(t), b * np.sin(t)
    c, s = np.cos(tilt), np.sin(tilt)
    path = np.stack([cx + c * x - s * z, np.zeros_like(t), cz + s * x + c * z], -1)
    return sweep_planar(path, (0, 1, 0), half_t, half_w, sections=8, closed=True)


FAMILIES = (
    ShapeFamily("office", "office / paper scissors, 17-22 cm, plastic loops"),
    ShapeFamily("kitchen", "kitchen shears: broad thick blades, a large finger loop"),
    ShapeFamily("craft", "small craft / children's scissors: equal round loops, blunt tips"),
    ShapeFamily("nail", "nail scissors: short narrow curved blades, metal ring loops"),
    ShapeFamily("hairdressing", "hairdressing scissors: long slim blades, ring loops, a finger rest", held_out=True),
)

# per family: (lo, hi) of total length, blade fraction, blade thickness, spine half-width (fraction of the
# blade length), edge / spine width, tip bluntness, curvature (tip offset / blade length), loop band width
# and thickness, loop half-length (fraction of the handle length), finger / thumb loop length ratio, loop
# half-width (m), finger / thumb loop width ratio
RANGES = {
    "office": dict(
        total=(0.17, 0.22),
        blade=(0.45, 0.56),
        thick=(0.0015, 0.0025),
        hw=(0.07, 0.11),
        edge=(0.35, 0.65),
        blunt=(0.0, 0.05),
        curve=(0.0, 0.0),
        band_w=(0.004, 0.008),
        band_t=(0.004, 0.008),
        loop_len=(0.18, 0.27),
        len_ratio=(1.0, 1.3),
        loop_w=(0.010, 0.014),
        w_ratio=(1.0, 1.4),
    ),
    "kitchen": dict(
        total=(0.20, 0.25),
        blade=(0.42, 0.52),
        thick=(0.0022, 0.0032),
        hw=(0.10, 0.14),
        edge=(0.45, 0.7),
        blunt=(0.0, 0.04),
        curve=(0.0, 0.0),
        band_w=(0.006, 0.009),
        band_t=(0.006, 0.009),
        loop_len=(0.20, 0.28),
        len_ratio=(1.3, 1.7),
        loop_w=(0.011, 0.014),
        w_ratio=(1.2, 1.6),
    ),
    "craft": dict(
        total=(0.12, 0.16),
        blade=(0.40, 0.50),
        thick=(0.0012, 0.0020),
        hw=(0.08, 0.12),
        edge=(0.4, 0.7),
        blunt=(0.05, 0.12),
        curve=(0.0, 0.0),
        band_w=(0.004, 0.007),
        band_t=(0.004, 0.007),
        loop_len=(0.22, 0.30),
        len_ratio=(1.0, 1.1),
        loop_w=(0.009, 0.012),
        w_ratio=(1.0, 1.1),
    ),
    "nail": dict(
        total=(0.085, 0.105),
        blade=(0.28, 0.36),
        thick=(0.0012, 0.0018),
        hw=(0.07, 0.10),
        edge=(0.4, 0.6),
        blunt=(0.0, 0.03),
        curve=(0.06, 0.14),
        band_w=(0.0022, 0.0032),
        band_t=(0.0022, 0.0032),
        loop_len=(0.13, 0.17),
        len_ratio=(1.0, 1.05),
        loop_w=(0.0075, 0.009),
        w_ratio=(1.0, 1.05),
    ),
    "hairdressing": dict(
        total=(0.14, 0.19),
        blade=(0.45, 0.55),
        thick=(0.0018, 0.0026),
        hw=(0.05, 0.07),
        edge=(0.5, 0.8),
        blunt=(0.0, 0.02),
        curve=(0.0, 0.0),
        band_w=(0.0028, 0.004),
        band_t=(0.003, 0.0045),
        loop_len=(0.12, 0.16),
        len_ratio=(1.0, 1.1),
        loop_w=(0.009, 0.011),
        w_ratio=(1.0, 1.1),
    ),
}


def build(rng: np.random.Generator, instance_id: str, family: str = "office") -> ArticulatedObject:
    """A random pair of scissors of shape ``family``; see the module docstring for the frame and joint conventions."""
    rg = RANGES[family]
    total = rng.uniform(*rg["total"])
    Lb = total * rng.uniform(*rg["blade"])  # blade length (pivot to tip)
    ta = rng.uniform(*rg["thick"])
    tb = rng.uniform(*rg["thick"])
    hw = Lb * rng.uniform(*rg["hw"])  # spine half-width at the pivot
    hw_e = hw * rng.uniform(*rg["edge"])
    p_spine = rng.uniform(0.5, 0.9)
    blunt = rng.uniform(*rg["blunt"])
    bend = rng.uniform(*rg["curve"])
    r_hub = hw * rng.uniform(0.9, 1.2)
    loop_w = rng.uniform(*rg["band_w"])  # loop band width (in plane)
    loop_t = rng.uniform(*rg["band_t"])  # loop band thickness (y)
    sep = rng.uniform(0.002, 0.008)  # half gap between the loops
    # handle length = total - blade length, shared by the shank and the loop
    handle = total - Lb
    lb_a = rng.uniform(*rg["loop_len"]) * handle  # loop half-lengths along z
    lb_b = lb_a * rng.uniform(*rg["len_ratio"])
    la_a = rng.uniform(*rg["loop_w"])  # loop half-widths along x
    la_b = la_a * rng.uniform(*rg["w_ratio"])
    tilt_a, tilt_b = rng.uniform(-0.25, 0.05), rng.uniform(-0.05, 0.25)
    sw = rng.uniform(0.7, 1.0) * hw  # shank half-width at the pivot
    if family in ("nail", "hairdressing"):  # round metal rings
        lb_a, lb_b = la_a * rng.uniform(0.95, 1.1), la_b * rng.uniform(0.95, 1.1)
        sw = max(sw, 0.5 * loop_w + 0.0005)
        tilt_a, tilt_b = 0.3 * tilt_a, 0.3 * tilt_b

    parts = {}
    for name, side, t_lo, t_hi, la, lb, tilt in (
        ("blade_a", +1, GAP, GAP + ta, la_a, lb_a, tilt_a),
        ("blade_b", -1, -GAP - tb, -GAP, la_b, lb_b, tilt_b),
    ):
        yc, th = 0.5 * (t_lo + t_hi), t_hi - t_lo
        loop_side = -side  # blade_a's loop is at -x, blade_b's at +x
        # the loop's far end is at z = total - Lb (minus half the band): the handle length
        cz = handle - lb - loop_w / 2
        cx = loop_side * (sep + la + loop_w / 2)
        geo = _blade(Lb, hw, hw_e, p_spine, blunt, 0.6 * r_hub, side, bend, th, yc)
        geo.append(disc(r_hub, th, (0.0, yc, 0.0), "y", 18))
        attach = np.array([cx - loop_side * 0.3 * la, cz - lb * 0.9])
        geo.append(extrude(_shank_poly(attach, sw, 0.6 * loop_w + 0.001), th, plane="xz", offset=yc))
        geo.append(_loop(cx, cz, la, lb, loop_t / 2, loop_w / 2, tilt))
        if family == "hairdressing" and name == "blade_b":  # finger rest: a spur off the ring, outwards and back
            p0 = np.array([cx + loop_side * la * 0.8, 0.0, cz - 0.5 * lb])
            geo.append(rod(p0, p0 + np.array([loop_side * 0.010, 0.0, 0.016]), 0.45 * loop_t, 8))
        if name == "blade_a":
            geo.append(disc(0.55 * r_hub, 0.0008, (0.0, t_hi + 0.0004, 0.0), "y", 14))  # screw head
        else:
            geo.append(disc(0.45 * r_hub, 0.0008, (0.0, t_lo - 0.0004, 0.0), "y", 6))  # hex nut
        parts[name] = make_part(name, combine(geo))

    params = dict(
        total_length=total,
        blade_length=Lb,
        thickness_a=ta,
        thickness_b=tb,
        blade_half_width=hw,
        edge_half_width=hw_e,
        spine_exponent=p_spine,
        tip_blunt=blunt,
        hub_radius=r_hub,
        loop_band_width=loop_w,
        loop_band_thickness=loop_t,
        loop_gap=sep,
        loop_a_half_length=lb_a,
        loop_b_half_length=lb_b,
        loop_a_half_width=la_a,
        loop_b_half_width=la_b,
        loop_a_tilt=tilt_a,
        loop_b_tilt=tilt_b,
        shank_half_width=sw,
        blade_curve=bend,
    )
    return build_object(
        "scissors",
        instance_id,
        [parts["blade_a"], parts["blade_b"]],
        joints=[dict(type="revolute", parent=0, child=1, pivot=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), limits=LIMITS, rest=REST)],
        params=params,
        shape_family=family,
    )


SPEC = CategorySpec(
    name="scissors",
    family="artimage",
    part_names=("blade_a", "blade_b"),
    joint_types=("revolute",),
    symmetry=("none", "none"),
    distance_range_m=(0.30, 0.60),
    elevation_range_deg=(25.0, 80.0),
    shape_families=FAMILIES,
    build=build,
    description="scissors: two blades with finger loops on a revolute pivot screw (open up to 57 degrees)",
)
