"""Eyeglasses (ArtImage-like, articulated): parts ``("frame", "left_temple", "right_temple")``, two revolute joints.

Object frame (y up, x right, z towards the viewer, i.e. the direction the glasses face; metres; origin at
the frame's amodal box centre):

* ``frame``: the front, in the x-y plane facing +z: two lens rims (closed tubes along superellipse
  paths, slightly tilted), thin lenses, an arched bridge (sometimes with a second, top bar), nose pads on
  pad arms behind the rims, and an end piece at each outer end that bends backwards to the hinge.
  Total width 0.12-0.15 m, lens width 0.045-0.058 m, lens height 0.028-0.045 m.
* ``right_temple`` (at +x) and ``left_temple`` (at -x): thin flattened bars from the hinge backwards
  along -z, length 0.12-0.15 m, bent down by 15-35 degrees over the last 25-35 % (the ear bend), with a
  hinge barrel at the front and a thicker ear tip.
* Joints ``frame -> left_temple`` and ``frame -> right_temple`` (revolute): vertical axes through the
  hinge points (the back ends of the end pieces). State 0 is OPEN (temples perpendicular to the front,
  pointing -z). ``right_temple`` axis ``(0, +1, 0)``, ``left_temple`` axis ``(0, -1, 0)``, so a positive
  angle folds each temple inwards behind the front. Limits ``(0, 1.45)`` rad, rest 0. At the upper limit
  the two folded temples cross each other behind the front over a few millimetres (a slight overlap).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject, build_object, make_part
from ..shapes import combine, curve_x_at, disc, extrude, rod, superellipse, sweep_planar
from . import CategorySpec

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


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    """A random pair of glasses; see the module docstring for the frame and joint conventions."""
    Lw = rng.uniform(0.045, 0.058)  # lens width
    Lh = float(np.clip(Lw * rng.uniform(0.55, 0.85), 0.028, 0.045))  # lens height
    p_shape = rng.uniform(2.0, 3.6)  # superellipse exponent: oval (2) to rounded rectangle
    tilt = np.radians(rng.uniform(-4.0, 6.0))
    bridge = rng.uniform(0.014, 0.019)  # distance between the lenses at centre height
    rw = rng.uniform(0.0008, 0.0020)  # rim half-width in the plane
    rd = rng.uniform(0.0008, 0.0016)  # rim half-depth along z
    base_w = 2 * Lw + bridge + 2 * rw
    Wt = rng.uniform(max(0.12, base_w + 0.008), min(0.15, base_w + 0.026))  # total width
    lens_t = rng.uniform(0.0010, 0.0020)
    bridge_u = rng.uniform(0.15, 0.45)  # bridge height as a fraction of the lens half height
    arch = rng.uniform(0.0008, 0.0040)
    bridge_r = rng.uniform(0.0007, 0.0014)
    double_bridge = int(rng.random() < 0.3)
    end_u = rng.uniform(0.15, 0.55)  # end piece height (fraction of lens half height)
    end_depth = rng.uniform(0.006, 0.011)  # how far behind the front the hinge is
    eh = rng.uniform(0.0030, 0.0055)  # end piece / temple front height
    ew = rng.uniform(0.0016, 0.0026)  # end piece width
    L = rng.uniform(0.12, 0.15)  # temple length
    bend_frac = rng.uniform(0.25, 0.35)
    bend_deg = rng.uniform(15.0, 35.0)
    tw = rng.uniform(0.0010, 0.0018)  # temple width (x)
    pad_r = rng.uniform(0.0035, 0.0055)

    a, b = Lw / 2, Lh / 2
    xc = bridge / 2 + rw + a  # lens centres at +-xc (rim centre line at the lens boundary + rw)
    frame_parts = []
    rims = {}
    for side in (-1, 1):
        curve = superellipse(a + rw, b + rw, p_shape, n=56)
        c, s = np.cos(side * tilt), np.sin(side * tilt)
        curve = curve @ np.array([[c, s], [-s, c]]) + np.array([side * xc, 0.0])
        rims[side] = curve
        path = np.c_[curve, np.zeros(len(curve))]
        frame_parts.append(sweep_planar(path, (0, 0, 1), rd, rw, sections=8, closed=True))
        lens = superellipse(a + 0.3 * rw, b + 0.3 * rw, p_shape, n=40) @ np.array([[c, s], [-s, c]])
        frame_parts.append(extrude(lens + np.array([side * xc, 0.0]), lens_t, plane="xy", offset=0.0))

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
        total_width=Wt, lens_width=Lw, lens_height=Lh, lens_shape_exponent=p_shape, lens_tilt_rad=float(tilt),
        bridge_width=bridge, rim_half_width=rw, rim_half_depth=rd, lens_thickness=lens_t, bridge_height_frac=bridge_u,
        bridge_arch=arch, bridge_radius=bridge_r, double_bridge=double_bridge, end_piece_height_frac=end_u,
        hinge_depth=end_depth, end_piece_height=eh, end_piece_width=ew, temple_length=L, bend_fraction=bend_frac,
        bend_deg=bend_deg, temple_width=tw, nose_pad_radius=pad_r,
    )
    joints = [
        dict(type="revolute", parent=0, child=1, pivot=pivots[-1], axis=(0.0, -1.0, 0.0), limits=LIMITS, rest=REST),
        dict(type="revolute", parent=0, child=2, pivot=pivots[1], axis=(0.0, 1.0, 0.0), limits=LIMITS, rest=REST),
    ]
    return build_object(
        "eyeglasses", instance_id, [(frame, T_frame), (left, T_left), (right, T_right)], joints=joints, params=params
    )


SPEC = CategorySpec(
    name="eyeglasses",
    family="artimage",
    part_names=("frame", "left_temple", "right_temple"),
    joint_types=("revolute", "revolute"),
    symmetry=("none", "none", "none"),
    distance_range_m=(0.28, 0.55),
    elevation_range_deg=(10.0, 60.0),
    build=build,
    description="eyeglasses: front frame + two temples on vertical revolute hinges (fold inwards)",
)
