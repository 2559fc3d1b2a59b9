"""Bowl (NOCS-like, rigid): a revolved bowl with a rounded rim and a foot ring.

Frame (NOCS): y up along the bowl's axis (the opening at +y, the foot ring at -y), x right, z towards
the front; metres; the amodal box is centred on the origin. The bowl is a solid of revolution about y:
symmetry ``"y"``.

Geometry: one closed cross-section loop revolved about y. The outer wall is a cubic Bezier curve from
the bottom centre to the rim (its control points give anything from shallow flat-bottomed dishes to
deep hemispherical or flared bowls); a trapezoidal foot ring (radius ``foot_radius``) stands under the
bottom; the inner wall is the outer one offset by the wall thickness (3-8 mm), joined to it by a
rounded rim.

Parameter ranges: rim radius 0.06-0.13 m (the rim may overhang by up to half a wall), height
0.04-0.10 m (at most 0.95 rim radius), wall 3-8 mm.
"""

from __future__ import annotations

import numpy as np

from ..articulation import ArticulatedObject
from ..shapes import offset_curve, revolve_profile
from . import CategorySpec
from .helpers import rigid_object, uniform

SECTIONS = 64


def _bezier(p: np.ndarray, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - s) ** 3 * p[0] + 3 * (1 - s) ** 2 * s * p[1] + 3 * (1 - s) * s**2 * p[2] + s**3 * p[3]


def build(rng: np.random.Generator, instance_id: str) -> ArticulatedObject:
    R = uniform(rng, 0.06, 0.13)
    H = uniform(rng, 0.04, min(0.10, 0.95 * R))
    t = uniform(rng, 0.003, 0.008)
    foot_h = uniform(rng, 0.003, 0.012)
    foot_frac = uniform(rng, 0.3, 0.55)  # foot ring radius / rim radius
    foot_w = uniform(rng, 0.003, 0.008)
    flat = uniform(rng, 0.2, 0.7)  # bottom flatness (first control point, fraction of R)
    wall_c = uniform(rng, 0.0, 0.6)  # how far up the wall bulges out (second control point height)
    flare = uniform(rng, 0.0, 0.12)  # the rim tangent leans outwards by this fraction of R

    Rf = foot_frac * R
    y_top = H - t / 2  # the rim's half circle adds t/2
    ctrl = np.array([
        [0.0, foot_h],
        [flat * R, foot_h],
        [R * (1.0 - flare), foot_h + wall_c * (y_top - foot_h)],
        [R, y_top],
    ])
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

    # foot ring replaces the outer curve where it stands: r in [Rf - foot_w, Rf]
    r_c = curve[:, 0]
    r0, r1 = Rf - foot_w, Rf
    y_at = lambda r: float(np.interp(r, r_c, curve[:, 1]))  # noqa: E731 - r_c is monotonic
    ch = 0.25 * foot_w
    foot = np.array([[r0, y_at(r0)], [r0 + ch, 0.0], [r1 - ch, 0.0], [r1, y_at(r1)]])
    outer = np.concatenate([curve[r_c < r0 - 1e-6], foot, curve[r_c > r1 + 1e-6]])
    loop = np.concatenate([outer, rim, inner[::-1]])
    mesh = revolve_profile(loop, SECTIONS, closed=True)

    params = dict(
        radius=R, height=H, wall=t, foot_height=foot_h, foot_radius=Rf, foot_width=foot_w,
        bottom_flatness=flat, wall_bulge=wall_c, flare=flare,
    )
    return rigid_object("bowl", instance_id, [mesh], "y", params)


SPEC = CategorySpec(
    name="bowl",
    family="nocs",
    part_names=("body",),
    joint_types=(),
    symmetry=("y",),
    distance_range_m=(0.35, 0.8),
    elevation_range_deg=(10.0, 60.0),
    build=build,
    description="revolved bowl (Bezier wall, rounded rim, foot ring), shallow dishes to deep bowls",
)
