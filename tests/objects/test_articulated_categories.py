"""Quality checks of the five articulated (ArtImage-like) category generators.

The modules are imported directly (not through the registry) so that these tests do not depend on the
rigid categories.
"""

from __future__ import annotations

import importlib
import time

import numpy as np
import pytest
import trimesh

NAMES = ("laptop", "eyeglasses", "dishwasher", "scissors", "drawer")
N_INSTANCES = 30
N_PHYSICS = 6  # instances checked for interpenetration (winding numbers are the slow part)

# Plausible amodal part sizes (x, y, z) in metres: lower and upper bounds per part.
SIZE_RANGES = {
    "laptop": {
        "base": ((0.27, 0.011, 0.18), (0.41, 0.027, 0.28)),
        "lid": ((0.27, 0.003, 0.18), (0.41, 0.011, 0.28)),
    },
    "eyeglasses": {
        "frame": ((0.115, 0.025, 0.006), (0.155, 0.065, 0.02)),
        "left_temple": ((0.0015, 0.006, 0.10), (0.006, 0.04, 0.155)),
        "right_temple": ((0.0015, 0.006, 0.10), (0.006, 0.04, 0.155)),
    },
    "dishwasher": {
        "body": ((0.44, 0.79, 0.49), (0.63, 0.89, 0.66)),
        "door": ((0.44, 0.66, 0.04), (0.63, 0.81, 0.16)),
    },
    "scissors": {
        "blade_a": ((0.02, 0.003, 0.12), (0.08, 0.012, 0.26)),
        "blade_b": ((0.02, 0.003, 0.12), (0.08, 0.012, 0.26)),
    },
    "drawer": {
        "cabinet": ((0.39, 0.49, 0.34), (0.96, 1.11, 0.66)),
        "drawer_top": ((0.35, 0.09, 0.28), (0.90, 0.36, 0.63)),
        "drawer_middle": ((0.35, 0.09, 0.28), (0.90, 0.36, 0.63)),
        "drawer_bottom": ((0.35, 0.09, 0.28), (0.90, 0.36, 0.63)),
    },
}


def _module(name):
    return importlib.import_module(f"ucope.objects.categories.{name}")


def _build(name, seed):
    return _module(name).SPEC.build(np.random.default_rng(seed), f"{name}/test/{seed:06d}")


_CACHE: dict = {}


def _instances(name):
    if name not in _CACHE:
        objs, times = [], []
        for seed in range(N_INSTANCES):
            t0 = time.perf_counter()
            objs.append(_build(name, seed))
            times.append(time.perf_counter() - t0)
        _CACHE[name] = (objs, np.array(times))
    return _CACHE[name]


def _centres(obj, state):
    """Amodal box centre of every part in the object frame (part frames sit at the box centres)."""
    return obj.object_from_part(state)[:, :3, 3]


def _part_vertices(obj, state):
    """Vertices of every part in the object frame at ``state``: a list of ``(V_k, 3)`` arrays."""
    return [np.asarray(m.vertices) for m in obj.posed_meshes(state)]


def _winding_numbers(points: np.ndarray, mesh: trimesh.Trimesh, chunk: int = 400_000) -> np.ndarray:
    """Generalised winding number of ``points`` w.r.t. ``mesh`` (Van Oosterom-Strackee solid angles).

    Parts are unions of closed, outward-oriented pieces that may overlap or touch; the winding number
    counts the pieces containing a point, so it is robust where ray-parity inside tests are not.
    """
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]  # (F, 3, 3)
    out = np.zeros(len(points))
    step = max(1, chunk // len(tri))
    for i in range(0, len(points), step):
        d = tri[None] - points[i : i + step, None, None, :]  # (P, F, 3, 3)
        a, b, c = d[..., 0, :], d[..., 1, :], d[..., 2, :]
        la, lb, lc = (np.sqrt((x * x).sum(-1)) for x in (a, b, c))
        det = (a * np.cross(b, c)).sum(-1)
        den = la * lb * lc + (a * b).sum(-1) * lc + (a * c).sum(-1) * lb + (b * c).sum(-1) * la
        out[i : i + step] = np.arctan2(det, den).sum(1) / (2 * np.pi)
    return out


def _inside_fraction(points: np.ndarray, mesh: trimesh.Trimesh, n_max: int = 200) -> float:
    """Fraction of (a fixed subsample of) ``points`` strictly inside ``mesh`` (winding number > 0.75)."""
    points = np.asarray(points)
    if len(points) > n_max:
        points = points[np.random.default_rng(0).choice(len(points), n_max, replace=False)]
    lo, hi = mesh.bounds
    near = np.all((points > lo - 1e-6) & (points < hi + 1e-6), axis=1)  # outside the bounds: outside
    inside = np.zeros(len(points), bool)
    if near.any():
        inside[near] = _winding_numbers(points[near], mesh) > 0.75
    return float(inside.mean()) if len(points) else 0.0


def _check_states(obj):
    lim = obj.limits
    states = [lim[:, 0], lim[:, 1], obj.rest_state]
    if np.all((lim[:, 0] <= 0) & (lim[:, 1] >= 0)):
        states.append(np.zeros(len(lim)))
    return states


@pytest.mark.parametrize("name", NAMES)
def test_spec_fields(name):
    spec = _module(name).SPEC
    assert spec.name == name
    assert spec.family == "artimage"
    assert len(spec.symmetry) == spec.num_parts == len(spec.joint_types) + 1
    assert 0 < spec.distance_range_m[0] < spec.distance_range_m[1]
    assert 0 <= spec.elevation_range_deg[0] < spec.elevation_range_deg[1] <= 90
    assert spec.description


@pytest.mark.parametrize("name", NAMES)
def test_instances_build_and_match_spec(name):
    spec = _module(name).SPEC
    objs, _ = _instances(name)
    seen = set()
    for obj in objs:
        assert obj.category == name
        assert obj.num_parts == spec.num_parts
        assert tuple(p.name for p in obj.parts) == spec.part_names
        assert obj.joint_types == spec.joint_types
        assert tuple(p.symmetry for p in obj.parts) == spec.symmetry
        sizes = obj.size_m
        assert np.all(sizes > 0)
        for k, part in enumerate(obj.parts):
            lo, hi = (np.array(b) for b in SIZE_RANGES[name][part.name])
            assert np.all(sizes[k] >= lo) and np.all(sizes[k] <= hi), (part.name, sizes[k])
            assert len(part.mesh.faces) > 100
        n_faces = sum(len(p.mesh.faces) for p in obj.parts)
        assert n_faces < 20000
        lim = obj.limits
        assert np.all(lim[:, 0] <= obj.rest_state) and np.all(obj.rest_state <= lim[:, 1])
        assert obj.params and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in obj.params.values())
        key = tuple(sorted(obj.params.items()))
        assert key not in seen, "two instances drew identical parameters"
        seen.add(key)


@pytest.mark.parametrize("name", NAMES)
def test_deterministic(name):
    for seed in (0, 7):
        a, b = _build(name, seed), _build(name, seed)
        assert a.params == b.params
        for pa, pb in zip(a.parts, b.parts):
            np.testing.assert_array_equal(pa.mesh.vertices, pb.mesh.vertices)
            np.testing.assert_array_equal(pa.mesh.faces, pb.mesh.faces)
        np.testing.assert_array_equal(a.object_from_part(), b.object_from_part())
    v0, v1 = _build(name, 0).parts[0].mesh.vertices, _build(name, 1).parts[0].mesh.vertices
    assert v0.shape != v1.shape or not np.allclose(v0, v1)


@pytest.mark.parametrize("name", NAMES)
def test_no_gross_interpenetration(name):
    """At the limits, the rest state and state 0: < 5 % of a child's vertices lie inside its parent."""
    objs, _ = _instances(name)
    for obj in objs[:N_PHYSICS]:
        for q in _check_states(obj):
            meshes = obj.posed_meshes(q)
            for j in obj.joints:
                frac = _inside_fraction(np.asarray(meshes[j.child].vertices), meshes[j.parent])
                assert frac < 0.05, (obj.instance_id, q, obj.parts[j.child].name, frac)
            if name == "drawer":  # drawers must not hit each other either
                for a in range(1, 4):
                    for b in range(1, 4):
                        if a != b:
                            assert _inside_fraction(np.asarray(meshes[a].vertices), meshes[b]) < 0.01


def test_laptop_opens_upwards():
    for obj in _instances("laptop")[0][:10]:
        D = obj.params["depth"]
        base_top = obj.size_m[0, 1] / 2  # the base box is centred on the object origin
        c_rest = _centres(obj, [1.57])[1]
        assert c_rest[1] > base_top + 0.35 * D  # standing up
        assert c_rest[2] < -0.4 * D  # behind the base centre, near the hinge at z = -D/2
        c_lo, c_hi = _centres(obj, [0.35])[1], _centres(obj, [2.6])[1]
        assert c_lo[1] > base_top and c_lo[2] > c_rest[2]  # barely open: lid over the base
        assert c_hi[2] < -D / 2  # leaning back past the hinge
        assert _part_vertices(obj, [0.35])[1][:, 1].min() > base_top - 1e-6  # the lid stays above the base top


def test_dishwasher_door_opens_forward_and_down():
    for obj in _instances("dishwasher")[0][:10]:
        c0, c1 = _centres(obj, [0.0])[1], _centres(obj, [1.57])[1]
        H = obj.params["height"]
        assert c1[2] - c0[2] > 0.25 * H
        assert c0[1] - c1[1] > 0.25 * H
        door_y = _part_vertices(obj, [1.57])[1][:, 1]
        # horizontal door: thin along y, above the floor
        assert door_y.min() > -obj.size_m[0, 1] / 2 - 1e-6
        assert door_y.max() - door_y.min() < 0.2


def test_drawer_moves_exactly_along_z():
    for obj in _instances("drawer")[0][:10]:
        lim = obj.limits
        assert np.allclose(lim[:, 0], 0.0)
        assert np.allclose(lim[:, 1], 0.75 * obj.params["drawer_depth"])
        zero = obj.object_from_part(np.zeros(3))
        for k in range(3):
            q = np.zeros(3)
            q[k] = lim[k, 1]
            poses = obj.object_from_part(q)
            d = poses[k + 1, :3, 3] - zero[k + 1, :3, 3]
            np.testing.assert_allclose(d, [0.0, 0.0, q[k]], atol=1e-12)
            others = [i for i in range(4) if i != k + 1]
            np.testing.assert_allclose(poses[others], zero[others], atol=1e-12)
        # closed: fronts flush against the cabinet front, the top drawer is the highest
        c = _centres(obj, np.zeros(3))
        assert c[1, 1] > c[2, 1] > c[3, 1]


def test_scissors_tips_and_loops_separate():
    for obj in _instances("scissors")[0][:10]:
        Lb = obj.params["blade_length"]
        v0, v1 = _part_vertices(obj, [0.0]), _part_vertices(obj, [1.0])
        tips = [int(np.argmin(v0[k][:, 2])) for k in (0, 1)]  # tip vertex of each blade (closed)
        gap0 = np.linalg.norm(v0[0][tips[0]] - v0[1][tips[1]])
        assert gap0 < 0.25 * Lb  # closed: the tips are together
        gap1 = np.linalg.norm(v1[0][tips[0]] - v1[1][tips[1]])
        assert gap1 > 0.7 * Lb  # open by 1 rad: chord ~ 0.96 Lb
        assert v1[1][tips[1], 0] < v0[1][tips[1], 0] - 0.5 * Lb  # blade_b's tip swings to -x
        z_loop = 0.5 * max(v0[0][:, 2].max(), v0[1][:, 2].max())
        loops0 = [v0[k][v0[k][:, 2] > z_loop].mean(0) for k in (0, 1)]
        loops1 = [v1[k][v0[k][:, 2] > z_loop].mean(0) for k in (0, 1)]
        assert np.linalg.norm(loops1[1] - loops1[0]) > np.linalg.norm(loops0[1] - loops0[0]) + 0.3 * Lb
        c0, c1 = _centres(obj, [0.0]), _centres(obj, [1.0])
        np.testing.assert_allclose(c0[0], c1[0])  # blade_a is the root
        assert v0[0][:, 1].mean() > v0[1][:, 1].mean()  # blade_a on top


def test_eyeglasses_temples_fold_inwards():
    for obj in _instances("eyeglasses")[0][:10]:
        L = obj.params["temple_length"]
        c0 = _centres(obj, [0.0, 0.0])
        c1 = _centres(obj, [1.45, 1.45])
        left, right = 1, 2
        assert c0[right, 0] > 0 > c0[left, 0]
        assert c0[right, 2] < -0.3 * L and c0[left, 2] < -0.3 * L  # open: pointing backwards
        assert c1[right, 0] < c0[right, 0] - 0.3 * L  # folded inwards...
        assert c1[left, 0] > c0[left, 0] + 0.3 * L
        assert c1[right, 2] > c0[right, 2] + 0.3 * L  # ... and towards the frame
        assert c1[left, 2] > c0[left, 2] + 0.3 * L
        # folding one temple only moves that temple
        c_half = _centres(obj, [0.0, 1.0])
        np.testing.assert_allclose(c_half[left], c0[left])


def test_eyeglasses_folded_temples_overlap_slightly():
    for obj in _instances("eyeglasses")[0][:N_PHYSICS]:
        meshes = obj.posed_meshes([1.45, 1.45])
        # the two temples cross behind the front (same height, not yet parallel at 1.45 rad): only the
        # few millimetres around the crossing may overlap (measured: <= 4 % of the right temple)
        frac = _inside_fraction(np.asarray(meshes[2].vertices), meshes[1], n_max=1000)
        assert frac < 0.08, (obj.instance_id, frac)


@pytest.mark.parametrize("name", NAMES)
def test_build_time(name):
    objs, times = _instances(name)
    faces = np.mean([sum(len(p.mesh.faces) for p in o.parts) for o in objs])
    print(f"{name}: mean build {times.mean() * 1e3:.2f} ms, max {times.max() * 1e3:.2f} ms, {faces:.0f} faces")
    assert times.mean() < 0.1
