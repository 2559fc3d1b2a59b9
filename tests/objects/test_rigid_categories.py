"""The six NOCS-like rigid category generators (bottle, bowl, camera, can, laptop_rigid, mug).

The modules are imported directly (not through the registry) so these tests run on their own.
"""

from __future__ import annotations

import numpy as np
import pytest

from ucope.objects.categories import CategorySpec, bottle, bowl, camera, can, laptop_rigid, mug

MODULES = {"bottle": bottle, "bowl": bowl, "camera": camera, "can": can, "laptop_rigid": laptop_rigid, "mug": mug}
SYMMETRIC = ("bottle", "bowl", "can")
N = 8  # instances per shape family
_CACHE: dict = {}

# The documented real-world ranges of every family (docs/conventions.md and the modules' docstrings), as
# extents of the body's box along an axis: {category: {family: {axis: (lo, hi)}}}, metres.
DIMS = {
    "bottle": {  # y: height with the cap, x: body diameter
        "wine": {"y": (0.28, 0.35), "x": (0.068, 0.085)},
        "water": {"y": (0.18, 0.33), "x": (0.055, 0.092)},
        "slim": {"y": (0.19, 0.30), "x": (0.045, 0.062)},
        "flask": {"y": (0.17, 0.28), "x": (0.060, 0.080)},
        "squat": {"y": (0.09, 0.16), "x": (0.060, 0.100)},
    },
    "bowl": {  # x: rim diameter, y: height
        "round": {"x": (0.105, 0.200), "y": (0.045, 0.095)},
        "ramekin": {"x": (0.075, 0.110), "y": (0.038, 0.060)},
        "shallow": {"x": (0.180, 0.300), "y": (0.030, 0.060)},
        "serving": {"x": (0.200, 0.300), "y": (0.080, 0.130)},
        "footed": {"x": (0.100, 0.180), "y": (0.065, 0.130)},
    },
    "can": {  # x: diameter, y: height
        "standard": {"x": (0.065, 0.068), "y": (0.115, 0.135)},
        "slim": {"x": (0.053, 0.058), "y": (0.088, 0.146)},
        "tall": {"x": (0.065, 0.068), "y": (0.155, 0.170)},
        "food": {"x": (0.065, 0.101), "y": (0.070, 0.120)},
        "squat": {"x": (0.065, 0.100), "y": (0.035, 0.055)},
    },
    "mug": {  # y: height, z: the cup's widest diameter (the handle sticks out along x only)
        "straight": {"y": (0.085, 0.120), "z": (0.072, 0.092)},
        "conical": {"y": (0.075, 0.120), "z": (0.075, 0.100)},
        "espresso": {"y": (0.050, 0.068), "z": (0.055, 0.072)},
        "cappuccino": {"y": (0.060, 0.080), "z": (0.085, 0.105)},
        "tall": {"y": (0.120, 0.150), "z": (0.075, 0.095)},
        "barrel": {"y": (0.085, 0.125), "z": (0.080, 0.100)},
    },
    "camera": {  # x: body width (grip, lens and controls inside it)
        "dslr": {"x": (0.125, 0.150)},
        "mirrorless": {"x": (0.110, 0.135)},
        "compact": {"x": (0.095, 0.115)},
        "action": {"x": (0.060, 0.075)},
    },
    "laptop_rigid": {  # x: width (11.6 to 18 inch)
        "ultrabook": {"x": (0.280, 0.360)},
        "mainstream": {"x": (0.270, 0.380)},
        "gaming": {"x": (0.350, 0.410)},
        "rugged": {"x": (0.280, 0.350)},
        "wedge": {"x": (0.280, 0.340)},
    },
}
CASES = [(name, fam) for name in MODULES for fam in MODULES[name].SPEC.family_names]


def _instances(name, family):
    """The objects of seeds 0..N-1 of ``family``, built once."""
    if (name, family) not in _CACHE:
        objs = []
        for seed in range(N):
            rng = np.random.default_rng(seed)
            objs.append(MODULES[name].SPEC.build(rng, f"{name}/{family}/{seed}", family))
        _CACHE[name, family] = objs
    return _CACHE[name, family]


def _all(name):
    return [o for fam in MODULES[name].SPEC.family_names for o in _instances(name, fam)]


def test_every_family_has_documented_ranges():
    for name, mod in MODULES.items():
        assert set(DIMS[name]) == set(mod.SPEC.family_names), name


@pytest.mark.parametrize("name,family", CASES)
def test_instances_build_rigid_and_in_range(name, family):
    objs = _instances(name, family)
    for obj in objs:
        assert obj.category == name and obj.num_parts == 1 and obj.joints == () and obj.is_rigid
        assert obj.shape_family == family and obj.scale == 1.0
        part = obj.parts[0]
        assert part.name == "body" and part.symmetry == MODULES[name].SPEC.symmetry[0]
        v, f = np.asarray(part.mesh.vertices), np.asarray(part.mesh.faces)
        assert np.all(np.isfinite(v)) and f.min() >= 0 and f.max() < len(v)
        assert len(f) < 20000
        lo_b, hi_b = part.mesh.bounds
        np.testing.assert_allclose(lo_b + hi_b, 0.0, atol=1e-9)  # the box is centred on the origin
        size = obj.size_m[0]
        for axis, (lo, hi) in DIMS[name][family].items():
            x = size["xyz".index(axis)]
            assert lo * 0.99 - 5e-4 <= x <= hi * 1.01 + 5e-4, (obj.instance_id, axis, x, lo, hi)
        assert all(isinstance(x, int | float) and not isinstance(x, bool) for x in obj.params.values())


@pytest.mark.parametrize("name", list(MODULES))
def test_spec(name):
    spec = MODULES[name].SPEC
    assert isinstance(spec, CategorySpec)
    assert spec.name == name and spec.family == "nocs"
    assert spec.part_names == ("body",) and spec.joint_types == () and spec.num_parts == 1
    assert spec.symmetry == (("y",) if name in SYMMETRIC else ("none",))
    assert 0 < spec.distance_range_m[0] < spec.distance_range_m[1]
    assert 0 <= spec.elevation_range_deg[0] < spec.elevation_range_deg[1] <= 90
    assert spec.description


@pytest.mark.parametrize("name,family", CASES)
def test_params_distinct_and_deterministic(name, family):
    objs = _instances(name, family)
    keys = {tuple(sorted(o.params.items())) for o in objs}
    assert len(keys) == N
    again = MODULES[name].SPEC.build(np.random.default_rng(7), "again", family)
    np.testing.assert_array_equal(again.parts[0].mesh.vertices, objs[7].parts[0].mesh.vertices)
    np.testing.assert_array_equal(again.parts[0].mesh.faces, objs[7].parts[0].mesh.faces)
    assert again.params == objs[7].params


@pytest.mark.parametrize("name", SYMMETRIC)
def test_symmetric_about_y(name):
    for obj in _all(name):
        v = obj.parts[0].mesh.vertices
        sx, sy, sz = obj.size_m[0]
        assert abs(sx - sz) <= 0.02 * sx
        # the radius distribution is the same in each quarter turn about y
        r = np.hypot(v[:, 0], v[:, 2])
        off = r > 1e-6
        q = np.floor((np.arctan2(v[off, 2], v[off, 0]) + np.pi + 0.01) / (np.pi / 2)).astype(int) % 4
        rs = [np.sort(r[off][q == k]) for k in range(4)]
        assert all(len(x) == len(rs[0]) for x in rs)
        for x in rs[1:]:
            np.testing.assert_allclose(x, rs[0], atol=1e-3 * sx)


def test_mug_handle_on_plus_x():
    for obj in _all("mug"):
        v = obj.parts[0].mesh.vertices
        sx, sy, sz = obj.size_m[0]
        p = obj.params
        assert sx > sz + 0.012  # the handle sticks out along x only
        np.testing.assert_allclose(sz, 2 * p["radius"], rtol=0.02)
        np.testing.assert_allclose(sx, 2 * p["radius"] + p["handle_reach"], rtol=0.02)
        # the rim (top 1 mm) is a circle whose centre, the cup's axis, is left of the box centre
        rim = v[v[:, 1] > sy / 2 - 0.001]
        axis_x = 0.5 * (rim[:, 0].min() + rim[:, 0].max())
        np.testing.assert_allclose(axis_x, -p["handle_reach"] / 2, atol=0.002)
        # vertices beyond the cup on the +x side exist (the handle), none on -x
        assert v[:, 0].max() > axis_x + p["radius"] + 0.01
        assert v[:, 0].min() >= axis_x - p["radius"] * 1.001


def test_camera_lens_points_plus_z():
    for obj in _all("camera"):
        v = obj.parts[0].mesh.vertices
        p = obj.params
        front = v[v[:, 2] > v[:, 2].max() - 0.002]
        ex, ey = np.ptp(front[:, 0]), np.ptp(front[:, 1])
        assert abs(ex - ey) <= 0.05 * ex  # the extreme-z face is round (the lens front ring)
        assert 1.6 * p["lens_radius"] <= ex <= 2.3 * p["lens_radius"]
        # the lens sticks out in front of the body by about its length
        assert obj.size_m[0, 2] >= p["depth"] + p["lens_length"] - 1e-6


def test_laptop_lid_above_hinge_at_back():
    for obj in _all("laptop_rigid"):
        v = obj.parts[0].mesh.vertices
        p = obj.params
        np.testing.assert_allclose(obj.size_m[0, 0], p["width"], atol=1e-6)
        ymin = v[:, 1].min()
        high = v[v[:, 1] > ymin + 0.5 * obj.size_m[0, 1]]  # the upper half is lid only
        base_front = v[:, 2].max()
        assert high[:, 2].max() < base_front - 0.5 * p["depth"]  # the lid rises at the back
        if p["opening_deg"] > 95:  # leaning back: the lid's top edge is behind the hinge
            top = v[v[:, 1] > v[:, 1].max() - 0.003]
            assert top[:, 2].mean() < base_front - p["depth"]


def test_camera_ultra_compacts_put_a_small_lens_in_the_top_corner():
    objs = [camera.SPEC.build(np.random.default_rng(s), f"camera/compact/{s}", "compact") for s in range(24)]
    ultra = [o for o in objs if o.params["ultra_compact"]]
    assert 6 <= len(ultra) <= 18  # half of the compacts, drawn per instance
    assert all(o.params["ultra_compact"] in (0, 1) for o in objs)
    for obj in ultra:
        p = obj.params
        assert camera.ULTRA_COMPACT["depth"][0] <= p["depth"] <= camera.ULTRA_COMPACT["depth"][1]
        assert camera.ULTRA_COMPACT["lens_r"][0] <= p["lens_radius"] <= camera.ULTRA_COMPACT["lens_r"][1]
        assert p["lens_length"] <= camera.ULTRA_COMPACT["lens_len_max"] + 1e-9
        assert p["grip_width"] == 0.0 and p["has_dial"] == 0
        # the lens (the front-most ring) sits in the +x top corner of the body, within 1 cm of both edges
        v = obj.parts[0].mesh.vertices
        front = v[v[:, 2] > v[:, 2].max() - 0.002]
        body_centre = v[:, :2].min(0) + [p["width"] / 2, p["height"] / 2]  # the box also holds the top button
        cx, cy = 0.5 * (front[:, :2].min(0) + front[:, :2].max(0)) - body_centre
        np.testing.assert_allclose([cx, cy], [p["lens_x"], p["lens_y"]], atol=0.001)
        r_mount = 1.15 * p["lens_radius"]
        assert 0.0 < p["width"] / 2 - (cx + r_mount) <= 0.01
        assert 0.0 < p["height"] / 2 - (cy + r_mount) <= 0.01


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2"])
def test_a_category_revision_must_be_an_integer_from_one(bad):
    import dataclasses

    with pytest.raises(ValueError, match="revision must be an integer >= 1"):
        dataclasses.replace(camera.SPEC, revision=bad)
    assert dataclasses.replace(camera.SPEC, revision=3).revision == 3
