"""ucope.data.corrupt: every corruption against a plain (loop) reference, determinism, labels, fractions."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from ucope.data.corrupt import (
    KINDS,
    BackgroundPool,
    CorruptionContext,
    add_floor,
    add_outliers,
    axial_noise,
    background_pool,
    corrupt,
    isotropic_noise,
    mask_bleed,
    object_box,
    occlude,
    occluder_normal,
    parse_spec,
    resample,
    shuffle,
)
from ucope.errors import InputError
from ucope.geometry.transforms import make_transform, random_rotation
from ucope.render.camera import PinholeCamera
from ucope.render.noise import DepthNoise
from ucope.render.raycast import BACKGROUND_LABEL, CLUTTER_LABEL
from ucope.render.views import RenderedView


def _rot_y(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])


@pytest.fixture
def cloud(rng):
    """A 2-part cloud about 0.8 m in front of the camera (float32, as samples hold), labels 0 / 1."""
    pts = (rng.normal(size=(500, 3)) * [0.05, 0.04, 0.03] + [0.02, -0.01, 0.8]).astype(np.float32)
    labels = (pts[:, 0] > 0.02).astype(np.int64)
    return pts, labels


@pytest.fixture
def boxes(rng):
    """Two part boxes: a root part turned about its y axis and a child part above it."""
    R0 = random_rotation(rng)
    T0 = make_transform(R0, [0.0, 0.0, 0.8])
    T1 = T0 @ make_transform(_rot_y(30.0), [0.05, 0.06, 0.0])
    return np.stack([T0, T1]), np.array([[0.2, 0.05, 0.15], [0.1, 0.08, 0.05]])


@pytest.fixture
def pool(rng):
    M = 3000
    pts = rng.normal(size=(M, 3)) * 0.1 + [0.0, 0.1, 0.9]
    rank = rng.integers(1, 40, M).astype(np.float64)  # many ties, as pixel distances have
    clutter = rng.random(M) < 0.3
    return BackgroundPool(pts, rank, clutter, pixels_per_point=2.5)


@pytest.fixture
def context(boxes, pool):
    return CorruptionContext(boxes[0], boxes[1], pool)


SPECS = [
    "noise=0.005",
    "axial=3",
    "outliers=0.1",
    "floor=0.5",
    "bleed=0.25",
    "occlude=0.6",
    "points=200",
    "points=900",
    "shuffle=1",
    "noise=0.002,outliers=0.2,shuffle=1",
]


# ---------------------------------------------------------------------------------------------- references


def test_isotropic_noise_matches_a_loop(cloud):
    pts, lab = cloud
    out, lab2 = isotropic_noise(pts, lab, 0.005, np.random.default_rng(3))
    g = np.random.default_rng(3).standard_normal((len(pts), 3))
    for i in range(len(pts)):
        for a in range(3):
            assert out[i, a] == pytest.approx(float(pts[i, a]) + 0.005 * g[i, a], abs=1e-6)
    assert out.dtype == np.float32 and np.array_equal(lab2, lab)
    d = out.astype(np.float64) - pts
    assert abs(d.std() - 0.005) < 0.0005 and abs(d.mean()) < 0.0005


def test_axial_noise_moves_points_along_their_rays_by_the_sensor_sigma(cloud):
    pts, lab = cloud
    pts = pts.astype(np.float64)
    noise = DepthNoise(sigma_0_m=0.002, sigma_2=0.01)
    ctx = CorruptionContext(depth_noise=noise)
    out, lab2 = axial_noise(pts, lab, 3.0, np.random.default_rng(5), ctx)
    g = np.random.default_rng(5).standard_normal(len(pts))
    for i, p in enumerate(pts):
        z = p[2]
        sigma = 0.002 + 0.01 * (z - 0.4) ** 2
        r = math.sqrt(p[0] ** 2 + p[1] ** 2 + p[2] ** 2)
        dz = 3.0 * sigma * g[i]
        ref = p + (dz * r / z) * (p / r)  # along the unit ray by the range change of a depth change dz
        np.testing.assert_allclose(out[i], ref, atol=1e-12)
    assert np.allclose(np.cross(out, pts), 0.0, atol=1e-12)  # still on the ray through the camera centre
    assert np.array_equal(lab2, lab)
    with pytest.raises(InputError, match="z > 0"):
        axial_noise(pts * [1, 1, -1], lab, 1.0, np.random.default_rng(0))


def test_axial_noise_defaults_to_the_renderers_sensor_model(cloud):
    pts, lab = cloud
    a, _ = axial_noise(pts, lab, 1.0, np.random.default_rng(1))
    b, _ = axial_noise(pts, lab, 1.0, np.random.default_rng(1), CorruptionContext(depth_noise=DepthNoise()))
    assert np.array_equal(a, b)


def test_object_box_holds_every_part_box(boxes):
    T, size = boxes
    cam_from_box, _, ext = object_box(T, size)
    box_from_cam = np.linalg.inv(cam_from_box)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for k in range(len(T)):
        for sx, sy, sz in itertools.product((-1, 1), repeat=3):
            c = T[k] @ np.array([sx * size[k, 0] / 2, sy * size[k, 1] / 2, sz * size[k, 2] / 2, 1.0])
            q = box_from_cam @ c
            lo, hi = np.minimum(lo, q[:3]), np.maximum(hi, q[:3])
    np.testing.assert_allclose(hi - lo, ext, atol=1e-12)
    np.testing.assert_allclose(0.5 * (lo + hi), 0.0, atol=1e-12)  # the frame's origin is the box centre
    np.testing.assert_allclose(cam_from_box[:3, :3], T[0, :3, :3])  # aligned with the root part
    np.testing.assert_allclose(ext[:3] >= size[0] - 1e-12, True)


def test_outliers_are_uniform_in_the_1p5x_object_box(cloud, boxes):
    pts, lab = cloud
    T, size = boxes
    ctx = CorruptionContext(T, size)
    out, lab2 = add_outliers(pts, lab, 0.2, np.random.default_rng(7), ctx)
    n_add = round(0.2 * len(pts))
    assert len(out) == len(pts) + n_add and np.array_equal(out[: len(pts)], pts)
    assert np.array_equal(lab2[: len(pts)], lab) and np.all(lab2[len(pts) :] == -1)
    cam_from_box, _, ext = object_box(T, size)
    u = np.random.default_rng(7).uniform(-1.0, 1.0, (n_add, 3))
    for i in range(n_add):  # reference: centre + R (u * 1.5 * ext / 2)
        ref = cam_from_box[:3, 3] + cam_from_box[:3, :3] @ (u[i] * 1.5 * ext / 2)
        np.testing.assert_allclose(out[len(pts) + i], ref, atol=1e-6)
    local = (out[len(pts) :].astype(np.float64) - cam_from_box[:3, 3]) @ cam_from_box[:3, :3]
    assert np.all(np.abs(local) <= 0.75 * ext + 1e-6)
    assert np.all(local.max(0) > 0.6 * ext) and np.all(local.min(0) < -0.6 * ext)  # spread over the whole box


def test_outliers_count_the_object_points_only_and_fall_back_to_the_cloud_box(cloud):
    pts, lab = cloud
    lab = lab.copy()
    lab[:100] = -1  # e.g. points an earlier corruption added
    out, lab2 = add_outliers(pts, lab, 0.5, np.random.default_rng(0))
    assert len(out) - len(pts) == round(0.5 * 400)
    obj = pts[lab >= 0].astype(np.float64)
    c, half = 0.5 * (obj.min(0) + obj.max(0)), 0.5 * (obj.max(0) - obj.min(0))
    assert np.all(np.abs(out[len(pts) :] - c) <= 1.5 * half + 1e-6)
    assert np.count_nonzero(lab2 == -1) == 100 + 200


def _nearest_reference(pool: BackgroundPool, clutter, n_add: int):
    """Plain loops: the candidate ranks and the band edge rank (the n_band-th smallest)."""
    cand = [
        (float(pool.rank[i]), tuple(pool.points[i]))
        for i in range(len(pool.rank))
        if clutter is None or bool(pool.clutter[i]) == clutter
    ]
    cand.sort(key=lambda c: c[0])
    n_band = min(len(cand), max(n_add, round(n_add * pool.pixels_per_point)))
    return cand, n_band, cand[n_band - 1][0]


@pytest.mark.parametrize("fn,clutter", [(add_floor, False), (mask_bleed, None)])
@pytest.mark.parametrize("fraction", [0.0, 0.1, 0.25, 1.0])
def test_floor_and_bleed_take_the_points_nearest_the_silhouette(cloud, pool, fn, clutter, fraction):
    pts, lab = cloud
    ctx = CorruptionContext(background=pool)
    out, lab2 = fn(pts, lab, fraction, np.random.default_rng(11), ctx)
    n_add = round(fraction * len(pts))
    assert len(out) == len(pts) + n_add and np.array_equal(out[: len(pts)], pts)
    assert np.all(lab2[len(pts) :] == -1) and np.array_equal(lab2[: len(pts)], lab)
    if n_add == 0:
        return
    cand, _, edge = _nearest_reference(pool, clutter, n_add)
    where = {tuple(np.float32(c[1])): c[0] for c in cand}
    added = [tuple(p) for p in out[len(pts) :]]
    assert len(set(added)) == n_add  # drawn without replacement
    ranks = [where[p] for p in added]  # KeyError: a point from outside the allowed pool
    assert max(ranks) <= edge
    if clutter is False:
        assert not any(bool(c) for c, p in zip(pool.clutter, pool.points, strict=False) if tuple(np.float32(p)) in set(added))


def test_floor_thins_a_band_of_the_objects_image_area_to_the_objects_density(cloud, rng):
    pts, lab = cloud
    M = 20000
    p = rng.normal(size=(M, 3)) + [0, 0, 3]
    pool = BackgroundPool(p, np.arange(M, dtype=np.float64), np.zeros(M, bool), pixels_per_point=4.0)
    out, _ = add_floor(pts, lab, 0.5, np.random.default_rng(2), CorruptionContext(background=pool))
    idx = [int(np.flatnonzero((p.astype(np.float32) == q).all(1))[0]) for q in out[len(pts) :]]
    assert max(idx) < 4 * 250  # from the 1000 nearest
    assert min(idx) < 100 and max(idx) > 900  # spread over that band, not its 250 nearest


def test_an_exhausted_pool_adds_what_it_has(cloud):
    pts, lab = cloud
    pool = BackgroundPool(np.ones((30, 3)) * [0, 0, 1] + np.arange(30)[:, None] * 0.01, np.arange(30.0), np.zeros(30, bool))
    out, lab2 = add_floor(pts, lab, 1.0, np.random.default_rng(0), CorruptionContext(background=pool))
    assert len(out) == len(pts) + 30 and np.count_nonzero(lab2 == -1) == 30
    out, _ = add_floor(pts, lab, 1.0, np.random.default_rng(0), CorruptionContext(background=pool.select(True)))
    assert len(out) == len(pts)  # no distractor points at all


@pytest.mark.parametrize("keep", [1.0, 0.8, 0.6, 0.4, 0.01])
def test_occlusion_keeps_the_fraction_on_one_side_of_a_plane(cloud, keep):
    pts, lab = cloud
    out, lab2 = occlude(pts, lab, keep, np.random.default_rng(9))
    m = max(1, round(keep * len(pts)))
    assert len(out) == m
    # reference: the same normal, then the m smallest projections by a plain sort
    c = pts.astype(np.float64).mean(0)
    n = occluder_normal(c, np.random.default_rng(9))
    s = [float(np.dot(p.astype(np.float64), n)) for p in pts]
    kept = sorted(range(len(pts)), key=lambda i: s[i])[:m]
    kept.sort()
    assert np.array_equal(out, pts[kept]) and np.array_equal(lab2, lab[kept])
    # the normal is nearly perpendicular to the viewing direction
    assert abs(float(n @ c) / np.linalg.norm(c)) <= math.sin(math.radians(20.0)) + 1e-9
    assert np.linalg.norm(n) == pytest.approx(1.0)


def test_occluders_come_from_every_side(cloud):
    c = np.array([0.0, 0.0, 1.0])
    normals = np.array([occluder_normal(c, np.random.default_rng(s)) for s in range(200)])
    angles = np.degrees(np.arctan2(normals[:, 1], normals[:, 0]))
    assert np.histogram(angles, bins=4, range=(-180, 180))[0].min() > 25


@pytest.mark.parametrize("num", [1, 100, 499, 500, 501, 4096])
def test_resample_to_a_fixed_count(cloud, num):
    pts, lab = cloud
    lab = np.arange(len(pts))  # provenance
    out, src = resample(pts, lab, num, np.random.default_rng(4))
    assert len(out) == num and np.array_equal(out, pts[src])
    assert np.all(np.diff(src) >= 0)  # input order kept
    if num <= len(pts):
        assert len(np.unique(src)) == num
    else:
        assert set(src.tolist()) == set(range(len(pts)))  # every point once, plus repeats
        assert np.bincount(src).sum() == num


def test_shuffle_is_a_permutation_that_carries_the_labels(cloud):
    pts, lab = cloud
    out, lab2 = shuffle(pts, lab, 1, np.random.default_rng(8))
    perm = np.random.default_rng(8).permutation(len(pts))
    for i in range(len(pts)):
        assert np.array_equal(out[i], pts[perm[i]]) and lab2[i] == lab[perm[i]]
    assert not np.array_equal(out, pts)
    same, _ = shuffle(pts, lab, 0, np.random.default_rng(8))
    assert np.array_equal(same, pts)


# ------------------------------------------------------------------------------------------ common rules


@pytest.mark.parametrize("spec", SPECS)
def test_same_seed_same_output_other_seed_other_output(cloud, context, spec):
    pts, lab = cloud
    a = corrupt(pts, lab, spec, np.random.default_rng(21), context)
    b = corrupt(pts, lab, spec, np.random.default_rng(21), context)
    c = corrupt(pts, lab, spec, np.random.default_rng(22), context)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not (a[0].shape == c[0].shape and np.array_equal(a[0], c[0]))


@pytest.mark.parametrize("spec", SPECS)
def test_inputs_are_never_modified_and_outputs_are_new(cloud, context, spec):
    pts, lab = cloud
    p0, l0 = pts.copy(), lab.copy()
    pts.setflags(write=False)
    lab.setflags(write=False)
    out, lab2 = corrupt(pts, lab, spec, np.random.default_rng(0), context)
    assert np.array_equal(pts, p0) and np.array_equal(lab, l0)
    assert not np.shares_memory(out, pts) and not np.shares_memory(lab2, lab)
    assert out.dtype == np.float32 and lab2.dtype == np.int64 and out.shape == (len(lab2), 3)
    assert np.all(np.isfinite(out))


@pytest.mark.parametrize("kind", list(KINDS))
def test_identity_levels_change_nothing(cloud, context, kind):
    pts, lab = cloud
    k = KINDS[kind]
    if k.identity is None:
        return
    out, lab2 = corrupt(pts, lab, f"{kind}={k.identity:g}", np.random.default_rng(0), context)
    assert np.array_equal(out, pts) and np.array_equal(lab2, lab)


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_benchmark_level_runs_and_adds_the_stated_fraction(cloud, context, kind):
    pts, lab = cloud
    for level in KINDS[kind].levels:
        out, lab2 = corrupt(pts, lab, f"{kind}={level:g}", np.random.default_rng(1), context)
        added = int(np.count_nonzero(lab2 == -1))
        if kind in ("outliers", "floor", "bleed"):
            assert added == round(level * len(pts)) and len(out) == len(pts) + added
        elif kind == "occlude":
            assert len(out) == round(level * len(pts)) and added == 0
        elif kind == "points":
            assert len(out) == level
        else:
            assert len(out) == len(pts) and added == 0


def test_labels_of_kept_points_follow_their_points(cloud, context):
    pts, _ = cloud
    out, src = corrupt(pts, np.arange(len(pts)), "floor=0.25,occlude=0.5,shuffle=1", np.random.default_rng(3), context)
    obj = src >= 0
    assert np.array_equal(out[obj], pts[src[obj]])


# ------------------------------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "spec,match",
    [
        ("noise", "KIND=LEVEL"),
        ("noise=", "KIND=LEVEL"),
        ("blur=1", "unknown corruption kind 'blur'"),
        ("noise=abc", "must be a number"),
        ("noise=-0.1", r"\[0, inf\]"),
        ("noise=nan", r"\[0, inf\]"),
        ("occlude=0", r"\(0, 1\]"),
        ("occlude=1.5", r"\(0, 1\]"),
        ("points=0", "points"),
        ("points=10.5", "integer"),
        ("shuffle=2", "0 or 1"),
        ("", "spec"),
        ("noise=0.1,,shuffle=1", "KIND=LEVEL"),
    ],
)
def test_bad_specs_raise_input_errors_naming_the_problem(cloud, spec, match):
    pts, lab = cloud
    with pytest.raises(InputError, match=match):
        corrupt(pts, lab, spec, np.random.default_rng(0))


def test_bad_inputs_raise_input_errors(cloud, pool):
    pts, lab = cloud
    g = np.random.default_rng(0)
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        corrupt(pts[:, :2], lab, "noise=0.01", g)
    with pytest.raises(InputError, match="labels"):
        corrupt(pts, lab[:-1], "noise=0.01", g)
    with pytest.raises(InputError, match="labels"):
        corrupt(pts, lab.astype(float), "noise=0.01", g)
    with pytest.raises(InputError, match="Generator"):
        corrupt(pts, lab, "noise=0.01", 0)
    with pytest.raises(InputError, match="empty"):
        corrupt(pts[:0], lab[:0], "noise=0.01", g)
    bad = pts.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        corrupt(bad, lab, "noise=0.01", g)
    for spec in ("floor=0.1", "bleed=0.1"):
        with pytest.raises(InputError, match="context.background"):
            corrupt(pts, lab, spec, g)
    with pytest.raises(InputError, match="both"):
        CorruptionContext(cam_from_part=np.eye(4)[None])
    with pytest.raises(InputError, match="size_m"):
        CorruptionContext(np.eye(4)[None], np.ones((2, 3)))
    with pytest.raises(InputError, match="pixels_per_point"):
        BackgroundPool(pool.points, pool.rank, pool.clutter, 0.5)


def test_parse_spec_chains_kinds():
    assert parse_spec("noise=0.005, points=200") == [("noise", 0.005), ("points", 200)]
    assert isinstance(parse_spec("points=200")[0][1], int)


# ------------------------------------------------------------------------------------------ the pool


def _toy_view():
    """An 8 x 10 view: a 2-part object in the middle, a distractor column, one pixel with no return."""
    H, W = 8, 10
    mask = np.full((H, W), BACKGROUND_LABEL, np.uint8)
    mask[3:5, 3:5] = 0
    mask[3:5, 5:6] = 1
    mask[:, 8] = CLUTTER_LABEL
    depth = np.full((H, W), 1500, np.uint16)
    depth[mask < 2] = 1000
    depth[0, 0] = 0
    view = RenderedView(
        depth_mm=depth,
        mask=mask,
        cam_from_object=np.eye(4),
        cam_from_part=np.stack([np.eye(4)] * 2),
        joint_state=np.zeros(1),
        joint_pivot=np.zeros((1, 3)),
        joint_axis=np.zeros((1, 3)),
    )
    return view, PinholeCamera(10.0, 10.0, 4.5, 3.5, W, H)


def test_background_pool_ranks_pixels_by_their_distance_to_the_silhouette():
    view, cam = _toy_view()
    pool = background_pool(view, cam, cloud_points=3)
    H, W = view.mask.shape
    obj = [(r, c) for r in range(H) for c in range(W) if view.mask[r, c] < 2]
    want = {}
    for r in range(H):
        for c in range(W):
            if view.mask[r, c] >= 2 and view.depth_mm[r, c] > 0:
                d = min(math.hypot(r - a, c - b) for a, b in obj)
                z = view.depth_mm[r, c] / 1000.0
                p = ((c - cam.cx) / cam.fx * z, (r - cam.cy) / cam.fy * z, z)
                want[p] = (d, view.mask[r, c] == CLUTTER_LABEL)
    assert len(pool.rank) == len(want) == H * W - 6 - 1
    assert np.all(np.diff(pool.rank) >= 0)
    for p, r, cl in zip(pool.points, pool.rank, pool.clutter, strict=False):
        key = min(want, key=lambda q: np.linalg.norm(np.subtract(q, p)))
        assert np.allclose(key, p, atol=1e-6) and want[key] == (pytest.approx(r), cl)
    assert pool.pixels_per_point == pytest.approx(6 / 3)
    assert background_pool(view, cam).pixels_per_point == 1.0


def test_background_pool_of_a_rendered_view_lies_on_the_floor():
    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.render.views import ViewConfig

    cfg = GenerateConfig("mug", split="test", num=1, view=ViewConfig(noise=DepthNoise(enabled=False)))
    sample, view = make_sample(cfg, 0, return_view=True)
    pool = background_pool(view, cfg.view.camera, cloud_points=len(sample["points"]))
    floor = pool.points[~pool.clutter]
    # the floor plane: y = (lowest point of the object) in the object frame
    obj_from_cam = np.linalg.inv(view.cam_from_object)
    y = floor @ obj_from_cam[:3, :3].T[:, 1] + obj_from_cam[1, 3]
    assert np.ptp(y) < 0.01  # one plane, up to millimetre depth quantisation at a grazing angle
    ctx = CorruptionContext(sample["cam_from_part"], sample["size_m"], pool)
    out, lab = corrupt(sample["points"], sample["part_labels"], "floor=0.5", np.random.default_rng(0), ctx)
    assert np.count_nonzero(lab == -1) == round(0.5 * len(sample["points"])) and len(out) == len(lab)
