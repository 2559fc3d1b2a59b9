"""Bottle (NOCS-like, rigid): a hollow revolved bottle with a shoulder, a neck, a lip, maybe a cap.

Frame (NOCS): y up along the bottle's axis (the cap / mouth at +y, the base at -y), x right, z towards
the front; metres; the amodal box is centred on the origin. The bottle is a solid of revolution about
y, so its symmetry tag is ``"y"`` (any rotation about y gives the same shape; x and z carry no meaning).

Geometry: one closed cross-section loop revolved about y (wall thickness 1-2.5 mm): the outer side
runs from the base centre (a shallow punt) over a rounded heel, up the body (radius ``body_radius``,
with an optional grip waist), over the shoulder (from conical/S-shaped to dome-like, drawn by
``shoulder_roundness``), up the (slightly tapered) neck to the mouth, and back down the inner side.
A bead ring forms the lip; some instances (``has_cap``) carry a screw cap with a tamper ring below.

Parameter ranges: height 0.15-0.32 m (cap included), body radius 0.025-0.05 m, neck radius
0.009-0.018 m (at most 0.65 body radius).
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import arc, offset_curve, revolve_profile
from . import CategorySpec
from .helpers import rigid_object, uniform

SECTIONS = 48


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    H = uniform(rng, 0.15, 0.32)
    Rb = uniform(rng, 0.025, 0.05)
    Rn = uniform(rng, 0.009, min(0.018, 0.65 * Rb))
    t = uniform(rng, 0.001, 0.0025)
    shoulder_frac = uniform(rng, 0.12, 0.32)  # of the height
    neck_frac = uniform(rng, 0.06, 0.28)
    roundness = uniform(rng, 0.0, 1.0)  # 0: S-shaped / conical shoulder, 1: dome
    waist_depth = uniform(rng, 0.0, 0.08) if rng.random() < 0.4 else 0.0  # grip waist, fraction of Rb
    waist_pos = uniform(rng, 0.35, 0.65)
    neck_taper = uniform(rng, 0.0, 0.2)
    heel = uniform(rng, 0.12, 0.3) * Rb  # rounded heel radius
    punt = uniform(rng, 0.0, 0.025) * H
    lip_w = uniform(rng, 0.0012, 0.003)
    lip_h = uniform(rng, 0.003, 0.008)
    has_cap = int(rng.random() < 0.5)
    cap_h = uniform(rng, 0.012, 0.025)
    cap_extra = uniform(rng, 0.0015, 0.0035)

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
    bead = np.concatenate([
        arc((Rn + lip_w - lip_w / 2, lip_top - lip_w / 2), lip_w / 2, 0.0, np.pi / 2, 4),
        [[Rn - 0.3 * t, lip_top], [Rn - 0.3 * t, lip_top - lip_h]],
        arc((Rn + lip_w - lip_w / 2, lip_top - lip_h + lip_w / 2), lip_w / 2, -np.pi / 2, 0.0, 4),
    ])
    meshes.append(revolve_profile(bead, SECTIONS, closed=True))

    if has_cap:
        Rc = Rn + cap_extra
        f = min(0.0015, 0.3 * cap_h)
        y0 = H - cap_h
        cap = np.concatenate([
            [[0.0, y0 + 0.001], [Rc - 0.0005, y0]],
            [[Rc, y0 + 0.0008], [Rc, H - f]],
            arc((Rc - f, H - f), f, 0.0, np.pi / 2, 4),
            [[0.0, H]],
        ])
        meshes.append(revolve_profile(cap, SECTIONS, closed=False))
        # tamper-evident ring just below the cap
        ring = np.array([[Rn, y0 - 0.004], [Rc - 0.0004, y0 - 0.004], [Rc - 0.0004, y0 - 0.0005], [Rn, y0 - 0.0005]])
        meshes.append(revolve_profile(ring, SECTIONS, closed=True))

    params = dict(
        height=H, body_radius=Rb, neck_radius=Rn, wall=t, shoulder_frac=shoulder_frac, neck_frac=neck_frac,
        shoulder_roundness=roundness, waist_depth=waist_depth, waist_pos=waist_pos, neck_taper=neck_taper,
        heel_radius=heel, punt=punt, lip_width=lip_w, lip_height=lip_h, has_cap=has_cap, cap_height=cap_h,
        cap_extra=cap_extra,
    )
    return rigid_object("bottle", instance_id, meshes, "y", params)


SPEC = CategorySpec(
    name="bottle",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("y",),
    distance_range_m=(0.35, 0.8),
    elevation_range_deg=(10.0, 60.0),
    build=build,
    description="hollow revolved bottle (body, sloped or rounded shoulder, neck, lip), some with a cap",
)
