"""The six NOCS-like rigid category generators (bottle, bowl, camera, can, laptop_rigid, mug).

The modules are imported directly (not through the registry) so these tests run on their own.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from ucope.objects.categories import CategorySpec, bottle, bowl, camera, can, laptop_rigid, mug

MODULES = {"bottle": bottle, "bowl": bowl, "camera": camera, "can": can, "laptop_rigid": laptop_rigid, "mug": mug}
SYMMETRIC = ("bottle", "bowl", "can")
N = 30
_CACHE: dict = {}


def _instances(name):
    """(objects, build seconds) of seeds 0..N-1, built once per category."""
    if name not in _CACHE:
        objs, times = [], []
        for seed in range(N):
            rng = np.random.default_rng(seed)
            t0 = time.perf_counter()
            objs.append(MODULES[name].SPEC.build(rng, f"{name}/{seed}"))
            times.append(time.perf_counter() - t0)
        _CACHE[name] = (objs, np.array(times))
    return _CACHE[name]


def _expected_size_ranges(name, p):
    """(lo, hi) (3,) bounds on size_m (x, y, z) derived from the parameter ranges (and the instance)."""
    if name == "bottle":
        lo, hi = [0.05, 0.15, 0.05], [0.10, 0.32, 0.10]
    elif name == "bowl":
        lo, hi = [0.12, 0.04, 0.12], [0.26 + 0.008, 0.10 + 0.004, 0.26 + 0.008]
    elif name == "can":
        lo, hi = [0.05, 0.06, 0.05], [0.09, 0.16, 0.09]
    elif name == "mug":
        lo = [0.07 + 0.022, 0.07, 0.07]
        hi = [0.11 + 0.04, 0.12, 0.11]
    elif name == "camera":
        lo = [0.09, 0.06, 0.03 + 0.02]
        hi = [0.15, 0.10 + 0.03, 0.07 + 0.09 + 0.012]
    else:  # laptop_rigid: lid 0.94-1.0 x depth, opened 70-130 degrees
        th = np.deg2rad(p["opening_deg"])
        lo = [0.28, 0.94 * p["depth"] * np.sin(th), p["depth"]]
        hi = [0.40, 0.022 + 0.012 + p["lid_length"], p["depth"] + p["lid_length"] * max(0.0, -np.cos(th)) + 0.02]
    return np.array(lo) - 1e-6, np.array(hi) + 1e-6


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


@pytest.mark.parametrize("name", list(MODULES))
def test_instances_build_rigid_and_in_range(name):
    objs, _ = _instances(name)
    for obj in objs:
        assert obj.category == name and obj.num_parts == 1 and obj.joints == () and obj.is_rigid
        part = obj.parts[0]
        assert part.name == "body" and part.symmetry == MODULES[name].SPEC.symmetry[0]
        v, f = np.asarray(part.mesh.vertices), np.asarray(part.mesh.faces)
        assert np.all(np.isfinite(v)) and f.min() >= 0 and f.max() < len(v)
        assert len(f) < 20000
        lo_b, hi_b = part.mesh.bounds
        np.testing.assert_allclose(lo_b + hi_b, 0.0, atol=1e-9)  # the box is centred on the origin
        lo, hi = _expected_size_ranges(name, obj.params)
        size = obj.size_m[0]
        assert np.all(size >= lo) and np.all(size <= hi), (obj.instance_id, size, lo, hi)
        assert all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in obj.params.values())


@pytest.mark.parametrize("name", list(MODULES))
def test_params_distinct_and_deterministic(name):
    objs, _ = _instances(name)
    keys = {tuple(sorted(o.params.items())) for o in objs}
    assert len(keys) == N
    again = MODULES[name].SPEC.build(np.random.default_rng(7), "again")
    np.testing.assert_array_equal(again.parts[0].mesh.vertices, objs[7].parts[0].mesh.vertices)
    np.testing.assert_array_equal(again.parts[0].mesh.faces, objs[7].parts[0].mesh.faces)
    assert again.params == objs[7].params


@pytest.mark.parametrize("name", list(MODULES))
def test_build_time(name):
    _, times = _instances(name)
    print(f"{name}: mean build {1e3 * times.mean():.2f} ms, max {1e3 * times.max():.2f} ms")
    assert times.mean() < 0.1


@pytest.mark.parametrize("name", SYMMETRIC)
def test_symmetric_about_y(name):
    objs, _ = _instances(name)
    for obj in objs:
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
    objs, _ = _instances("mug")
    for obj in objs:
        v = obj.parts[0].mesh.vertices
        sx, sy, sz = obj.size_m[0]
        p = obj.params
        assert sx > sz + 0.02  # the handle sticks out along x only
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
    objs, _ = _instances("camera")
    for obj in objs:
        v = obj.parts[0].mesh.vertices
        p = obj.params
        front = v[v[:, 2] > v[:, 2].max() - 0.002]
        ex, ey = np.ptp(front[:, 0]), np.ptp(front[:, 1])
        assert abs(ex - ey) <= 0.05 * ex  # the extreme-z face is round (the lens front ring)
        assert 1.6 * p["lens_radius"] <= ex <= 2.3 * p["lens_radius"]
        # the lens sticks out in front of the body by about its length
        assert obj.size_m[0, 2] >= p["depth"] + p["lens_length"] - 1e-6


def test_laptop_lid_above_hinge_at_back():
    objs, _ = _instances("laptop_rigid")
    for obj in objs:
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
