"""Scissors (ArtImage-like, articulated): parts ``("blade_a", "blade_b")``, one revolute joint.

Object frame (y up, x right, z towards the viewer; metres; origin at blade_a's amodal box centre):
the scissors lie flat in the x-z plane (thin along y) with the blades pointing to -z and the finger
loops towards +z. The pivot screw sits at the construction origin; ``y = 0`` is the contact plane of
the two blades (each layer keeps 0.05 mm of clearance from it).

* ``blade_a`` (upper layer, ``y`` in ``[0, t_a]``): a tapered convex blade (cutting edge on its -x
  side, curved spine on +x), a pivot hub with the screw head, a shank and its finger loop at -x.
* ``blade_b`` (lower layer, ``y`` in ``[-t_b, 0]``): the mirror blade (cutting edge on +x), the nut,
  a shank and its finger loop at +x. Blade length 0.06-0.12 m, blade thickness 1.5-3 mm, overall
  length 0.13-0.25 m. The finger loops are thicker (4-8 mm, plastic) and centred on ``y = 0``.
* Joint ``blade_a -> blade_b`` (revolute): axis ``(0, 1, 0)`` through the pivot screw. State 0 is
  CLOSED (blades aligned); a positive angle rotates blade_b about +y, which moves its tip to -x and its
  loop to +x: the tips and the loops separate (the scissors open). Limits ``(0, 1.0)`` rad, rest 0.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine, disc, extrude, sweep_planar
from . import CategorySpec

__all__ = ["SPEC", "build"]

LIMITS = (0.0, 1.0)
REST = 0.0
GAP = 0.00005  # half the clearance between the two blades (they slide on each other)


def _blade_poly(length: float, hw_spine: float, hw_edge: float, p_spine: float, blunt: float, heel: float, side: int) -> np.ndarray:
    """Convex outline (x, z) of a blade pointing to -z; the spine is on ``side`` (+1: +x), the edge opposite."""
    u = np.linspace(0.0, 1.0 - blunt, 14)
    z = -u * length
    xs = side * hw_spine * (1.0 - u) ** p_spine
    xe = -side * hw_edge * (1.0 - u)
    spine = np.stack([xs, z], -1)
    edge = np.stack([xe, z], -1)[::-1]
    heel_pts = np.array([[-side * hw_edge, heel], [side * hw_spine, heel]])  # behind the pivot
    return np.concatenate([spine, edge, heel_pts])


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


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    """A random pair of scissors; see the module docstring for the frame and joint conventions."""
    total = rng.uniform(0.13, 0.25)
    Lb = float(np.clip(total * rng.uniform(0.45, 0.56), 0.06, 0.12))  # blade length (pivot to tip)
    ta = rng.uniform(0.0015, 0.003)
    tb = rng.uniform(0.0015, 0.003)
    hw = Lb * rng.uniform(0.07, 0.11)  # spine half-width at the pivot
    hw_e = hw * rng.uniform(0.35, 0.65)
    p_spine = rng.uniform(0.5, 0.9)
    blunt = rng.uniform(0.0, 0.07)
    r_hub = hw * rng.uniform(0.9, 1.2)
    loop_w = rng.uniform(0.004, 0.008)  # loop band width (in plane)
    loop_t = rng.uniform(0.004, 0.008)  # loop band thickness (y)
    sep = rng.uniform(0.002, 0.008)  # half gap between the loops
    # handle length = total - blade length, shared by the shank and the loop
    handle = total - Lb
    lb_a = rng.uniform(0.18, 0.27) * handle  # loop half-lengths along z
    lb_b = lb_a * rng.uniform(1.0, 1.3)
    la_a = rng.uniform(0.010, 0.014)  # loop half-widths along x
    la_b = la_a * rng.uniform(1.0, 1.4)
    tilt_a, tilt_b = rng.uniform(-0.25, 0.05), rng.uniform(-0.05, 0.25)
    sw = rng.uniform(0.7, 1.0) * hw  # shank half-width at the pivot

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
        geo = [extrude(_blade_poly(Lb, hw, hw_e, p_spine, blunt, 0.6 * r_hub, side), th, plane="xz", offset=yc)]
        geo.append(disc(r_hub, th, (0.0, yc, 0.0), "y", 18))
        attach = np.array([cx - loop_side * 0.3 * la, cz - lb * 0.9])
        geo.append(extrude(_shank_poly(attach, sw, 0.6 * loop_w + 0.001), th, plane="xz", offset=yc))
        geo.append(_loop(cx, cz, la, lb, loop_t / 2, loop_w / 2, tilt))
        if name == "blade_a":
            geo.append(disc(0.55 * r_hub, 0.0008, (0.0, t_hi + 0.0004, 0.0), "y", 14))  # screw head
        else:
            geo.append(disc(0.45 * r_hub, 0.0008, (0.0, t_lo - 0.0004, 0.0), "y", 6))  # hex nut
        parts[name] = make_part(name, combine(geo))

    params = dict(
        total_length=total, blade_length=Lb, thickness_a=ta, thickness_b=tb, blade_half_width=hw,
        edge_half_width=hw_e, spine_exponent=p_spine, tip_blunt=blunt, hub_radius=r_hub, loop_band_width=loop_w,
        loop_band_thickness=loop_t, loop_gap=sep, loop_a_half_length=lb_a, loop_b_half_length=lb_b,
        loop_a_half_width=la_a, loop_b_half_width=la_b, loop_a_tilt=tilt_a, loop_b_tilt=tilt_b, shank_half_width=sw,
    )
    return build_object(
        "scissors", instance_id, [parts["blade_a"], parts["blade_b"]],
        joints=[dict(type="revolute", parent=0, child=1, pivot=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0),
                     limits=LIMITS, rest=REST)],
        params=params,
    )


SPEC = CategorySpec(
    name="scissors",
    family="artimage",
    part_names=("blade_a", "blade_b"),
    joint_types=("revolute",),
    symmetry=("none", "none"),
    distance_range_m=(0.30, 0.60),
    elevation_range_deg=(25.0, 80.0),
    build=build,
    description="scissors: two blades with finger loops on a revolute pivot screw (open up to 57 degrees)",
)
