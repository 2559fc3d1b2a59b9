"""ucope.stages.extents: grow_to_points, fit_seen_extents and anchor_faced_faces against plain per-axis references,
and their contracts (growth never shrinks, thin axes, symmetric parts, few points, labels outside the parts, hidden
parts, bad input); carry_child_sizes on a door whose body was measured."""

from __future__ import annotations

import numpy as np
import pytest
from stages_support import door_priors
from tests_support import seen_pattern_reference

from ucope.errors import InputError
from ucope.geometry.boxes import SEEN_PATTERNS
from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis
from ucope.priors import JointPrior
from ucope.stages.extents import FitBoxesParams, anchor_faced_faces, carry_child_sizes, fit_seen_extents, grow_to_points

P = FitBoxesParams()


def joined_reference(local, half, factor):
    """Flood fill from the points inside the box over steps of at most ``factor`` median nearest-neighbour
    distances, with plain loops."""
    n = len(local)
    dist = [[float(np.linalg.norm(local[i] - local[j])) for j in range(n)] for i in range(n)]
    radius = factor * float(np.median([min(d for j, d in enumerate(row) if j != i) for i, row in enumerate(dist)]))
    joined = [bool(np.all(np.abs(p) <= half)) for p in local]
    todo = [i for i in range(n) if joined[i]]
    while todo:
        i = todo.pop()
        for j in range(n):
            if not joined[j] and dist[i][j] <= radius:
                joined[j] = True
                todo.append(j)
    return np.array(joined)


def reference(T, S, pts, labels, sym, q, thin, min_points, factor=None):
    """Plain loops over parts and axes, the contract written out."""
    T, S = np.array(T, float), np.array(S, float)
    for k in range(len(T)):
        own = [p for p, lab in zip(pts, labels, strict=True) if lab == k]
        if sym[k] != "none" or len(own) < min_points:
            continue
        R, t = T[k, :3, :3], T[k, :3, 3]
        local = np.array([R.T @ (p - t) for p in own])
        if factor is not None:
            local = local[joined_reference(local, S[k] / 2, factor)]
            if len(local) < min_points:
                continue
        shift, voted = np.zeros(3), S[k].copy()
        for a in range(3):
            if voted[a] < thin * np.median(voted):
                continue
            lo = min(-S[k, a] / 2, np.quantile(local[:, a], q))
            hi = max(S[k, a] / 2, np.quantile(local[:, a], 1 - q))
            shift[a] = (lo + hi) / 2
            S[k, a] = hi - lo
        T[k, :3, 3] = t + R @ shift
    return T, S


def _scene(rng, K=3, n=400):
    T = np.stack([make_transform(random_rotation(rng), rng.normal(size=3) * 0.2 + [0, 0, 1.0]) for _ in range(K)])
    S = rng.uniform(0.05, 0.4, (K, 3))
    labels = rng.integers(-1, K + 1, n)  # -1 and K: no part
    pts = rng.normal(size=(n, 3)) * 0.15 + [0, 0, 1.0]
    return T, S, pts, labels


@pytest.mark.parametrize("seed,factor", [(0, None), (1, None), (2, None), (3, 1.5), (4, 3.0), (5, 8.0)])
def test_matches_the_plain_reference(seed, factor):
    rng = np.random.default_rng(seed)
    T, S, pts, labels = _scene(rng)
    sym = ["none", "y", "none"]
    got_T, got_S, grown = grow_to_points(
        T, S, pts, labels, sym, quantile=0.02, thin_ratio=0.3, min_points=20, connect_factor=factor
    )
    ref_T, ref_S = reference(T, S, pts, labels, sym, 0.02, 0.3, 20, factor)
    np.testing.assert_allclose(got_T, ref_T, atol=1e-12)
    np.testing.assert_allclose(got_S, ref_S, atol=1e-12)
    np.testing.assert_array_equal(grown, ~np.isclose(got_S, S).all(axis=1) | ~np.isclose(got_T, T).all(axis=(1, 2)))
    np.testing.assert_array_equal(got_T[:, :3, :3], T[:, :3, :3])  # rotations kept


def test_a_too_narrow_box_grows_to_its_points_and_a_wide_one_is_kept():
    rng = np.random.default_rng(1)
    T = make_transform(random_rotation(rng), np.array([0.1, -0.05, 1.2]))
    true = np.array([0.6, 0.3, 0.5])
    local = rng.uniform(-0.5, 0.5, (3000, 3)) * true
    pts = local @ T[:3, :3].T + T[:3, 3]
    narrow = np.array([0.4, 0.3, 0.6])  # x too small, z too big
    T2, S2, grown = grow_to_points(T[None], narrow[None], pts, np.zeros(3000, int), quantile=0.0, connect_factor=None)
    assert grown[0]
    np.testing.assert_allclose(S2[0], [np.ptp(local[:, 0]), 0.3, 0.6], atol=1e-9)  # y, z held them already
    box_lo = T2[0, :3, :3].T @ (pts - T2[0, :3, 3]).T
    assert np.all(np.abs(box_lo.T) <= S2[0] / 2 + 1e-9)  # every point inside the grown box
    same_T, same_S, grown = grow_to_points(T[None], (true * 1.2)[None], pts, np.zeros(3000, int))
    assert not grown[0]
    np.testing.assert_array_equal(same_S[0], true * 1.2)
    np.testing.assert_array_equal(same_T[0], T)


def test_thin_axes_symmetric_parts_and_sparse_parts_are_kept():
    rng = np.random.default_rng(2)
    T = np.stack([np.eye(4)] * 3)
    T[:, 2, 3] = 1.0
    S = np.array([[0.5, 0.6, 0.01], [0.1, 0.1, 0.1], [0.1, 0.1, 0.1]])  # a plate; a symmetric part; a sparse one
    pts = np.concatenate(
        [rng.normal(size=(500, 3)) * [0.5, 0.5, 0.05], rng.normal(size=(500, 3)) * 0.3, rng.normal(size=(10, 3))]
    )
    pts[:, 2] += 1.0
    labels = np.repeat([0, 1, 2], [500, 500, 10])
    _, S2, grown = grow_to_points(T, S, pts, labels, ["none", "y", "none"])
    assert grown.tolist() == [True, False, False]
    assert S2[0, 2] == 0.01 and S2[0, 0] > 0.5 and S2[0, 1] > 0.6  # the plate's thickness is kept
    np.testing.assert_array_equal(S2[1:], S[1:])


def test_points_across_a_gap_do_not_grow_the_box():
    """A dense patch of the part's surface next to the box counts; a cluster of points beyond a gap (a
    neighbour the segmentation gave to the part) and scattered outliers do not, unless the test is off."""
    rng = np.random.default_rng(3)
    T = np.eye(4)
    T[2, 3] = 1.0
    size = np.array([0.4, 0.4, 0.4])
    face = np.c_[rng.uniform(-0.25, 0.25, (2000, 2)), np.full(2000, -0.2)]  # the front face, 5 cm wider each side
    far = np.c_[rng.uniform(0.6, 0.7, (200, 1)), rng.uniform(-0.2, 0.2, (200, 1)), np.full(200, -0.2)]  # 35 cm away
    outliers = rng.uniform(-0.6, 0.6, (20, 3))
    pts = np.concatenate([face, far, outliers]) + [0, 0, 1.0]
    labels = np.zeros(len(pts), int)
    _, S2, _ = grow_to_points(T[None], size[None], pts, labels, quantile=0.0)
    assert 0.49 < S2[0, 0] < 0.51 and 0.49 < S2[0, 1] < 0.51  # the face's 0.5 m, not the far cluster's 0.95 m
    _, S_all, _ = grow_to_points(T[None], size[None], pts, labels, quantile=0.0, connect_factor=None)
    assert S_all[0, 0] > 0.9


def test_points_the_segmentation_is_unsure_of_do_not_count():
    rng = np.random.default_rng(4)
    T = np.eye(4)
    T[2, 3] = 1.0
    local = rng.uniform(-0.3, 0.3, (1000, 3))
    labels = np.zeros(1000, int)
    conf = np.where(np.abs(local[:, 0]) > 0.2, 0.5, 0.99)  # the points beyond the 0.4 m box: unsure
    size = np.array([[0.4, 0.6, 0.6]])
    _, sure, grown = grow_to_points(T[None], size, local + [0, 0, 1.0], labels, confidence=conf, quantile=0.0)
    assert not grown[0] and sure[0, 0] == 0.4
    _, every, grown = grow_to_points(T[None], size, local + [0, 0, 1.0], labels, confidence=conf, min_confidence=0.0)
    assert grown[0] and every[0, 0] > 0.55


def test_bad_input_is_named():
    T, S = np.eye(4)[None], np.ones((1, 3))
    pts, lab = np.zeros((5, 3)), np.zeros(5, int)
    with pytest.raises(InputError, match="cam_from_part"):
        grow_to_points(np.eye(4), S, pts, lab)
    with pytest.raises(InputError, match="size_m"):
        grow_to_points(T, np.ones((2, 3)), pts, lab)
    with pytest.raises(InputError, match="size_m must be positive"):
        grow_to_points(T, -S, pts, lab)
    with pytest.raises(InputError, match="points"):
        grow_to_points(T, S, np.zeros((5, 2)), lab)
    with pytest.raises(InputError, match="labels"):
        grow_to_points(T, S, pts, np.zeros(4, int))
    with pytest.raises(InputError, match="labels"):
        grow_to_points(T, S, pts, np.zeros(5))
    with pytest.raises(InputError, match="finite"):
        grow_to_points(T, S, np.full((5, 3), np.nan), lab)
    with pytest.raises(InputError, match="quantile"):
        grow_to_points(T, S, pts, lab, quantile=0.5)
    with pytest.raises(InputError, match="confidence"):
        grow_to_points(T, S, pts, lab, confidence=np.ones(4))
    with pytest.raises(InputError, match="connect_factor"):
        grow_to_points(T, S, pts, lab, connect_factor=0.0)
    with pytest.raises(InputError, match="symmetry"):
        grow_to_points(T, S, pts, lab, ["none", "y"])


# ------------------------------------------------------------------------------------ fit_seen_extents
def fit_reference(T, S, pts, labels, table, sym, q, min_points, min_ratio, max_ratio, min_seen):
    """Plain loops over parts and axes, the contract written out (no joining test, no hiding neighbours)."""
    T, S = np.array(T, float), np.array(S, float)
    pattern = seen_pattern_reference(T, S)
    for k in range(len(T)):
        own = [p for p, lab in zip(pts, labels, strict=True) if lab == k]
        if len(own) < min_points:
            continue
        R, t = T[k, :3, :3], T[k, :3, 3]
        local = np.array([R.T @ (p - t) for p in own])
        shift = np.zeros(3)
        for a in range(3):
            lo10, mid, hi90 = table[k, a, pattern[k, a]]
            if sym[k] != "none" and a != 1:
                continue
            if not (lo10 >= min_ratio and hi90 <= max_ratio):  # NaN: not measured, never fitted
                continue
            lo, hi = np.quantile(local[:, a], q), np.quantile(local[:, a], 1 - q)
            if (hi - lo) / mid < min_seen * S[k, a]:
                continue
            S[k, a] = (hi - lo) / mid
            shift[a] = (lo + hi) / 2
        T[k, :3, 3] = t + R @ shift
    return T, S


def _face_points(T, S, rng, n=600):
    """``(n, 3)`` camera-frame points on the faces of the box ``T, S`` that the camera (origin) faces."""
    cam = T[:3, :3].T @ -T[:3, 3]
    faces = [a for a in range(3) if abs(cam[a]) > S[a] / 2]
    q = rng.uniform(-0.5, 0.5, (n, 3)) * S
    a = np.array(faces)[rng.integers(0, len(faces), n)]
    q[np.arange(n), a] = np.sign(cam[a]) * S[a] / 2
    return q @ T[:3, :3].T + T[:3, 3]


@pytest.mark.parametrize("seed", range(4))
def test_fit_matches_the_plain_reference(seed):
    rng = np.random.default_rng(seed)
    T, S, pts, labels = _scene(rng, K=3)
    table = np.sort(rng.uniform(0.8, 1.1, (3, 3, SEEN_PATTERNS, 3)), axis=-1)
    table[rng.uniform(size=table.shape[:3]) < 0.3] = np.nan  # patterns never measured
    sym = ["none", "y", "none"]
    got_T, got_S, fitted = fit_seen_extents(T, S, pts, labels, table, sym, connect_factor=None, max_occluded=1.0, min_points=20)
    ref_T, ref_S = fit_reference(T, S, pts, labels, table, sym, 0.01, 20, P.fit_min_ratio, P.fit_max_ratio, P.fit_min_seen)
    np.testing.assert_allclose(got_S, ref_S, rtol=1e-12)
    np.testing.assert_allclose(got_T, ref_T, rtol=1e-12, atol=1e-12)
    assert fitted.any() and not fitted[1, [0, 2]].any()
    np.testing.assert_array_equal(got_T[:, :3, :3], T[:, :3, :3])


def test_an_axis_seen_whole_is_set_from_the_points_larger_or_smaller():
    """A box seen from above-front-right: a voted box 1.6x too tall and 0.7x too wide gets the true extents
    back on the two axes its table marks as seen whole; the third (not measured) keeps its voted extent."""
    rng = np.random.default_rng(0)
    true = make_transform(random_rotation(rng) @ np.eye(3), [0.1, -0.2, 1.5])
    size = np.array([0.4, 0.3, 0.5])
    pts = _face_points(true, size, rng)
    voted = size * [0.7, 1.6, 1.0]
    table = np.full((1, 3, SEEN_PATTERNS, 3), np.nan)
    table[0, :2] = [0.95, 1.0, 1.02]  # x and y seen whole in every pattern; z never measured
    T, S, fitted = fit_seen_extents(true[None], voted[None], pts, np.zeros(len(pts), int), table, quantile=0.0)
    np.testing.assert_array_equal(fitted, [[True, True, False]])
    np.testing.assert_allclose(S[0], [size[0], size[1], voted[2]], rtol=2e-2)
    np.testing.assert_allclose(T[0, :3, 3], true[:3, 3], atol=0.02)


def test_hidden_symmetric_sparse_and_far_too_small_parts_keep_their_boxes():
    rng = np.random.default_rng(1)
    front = make_transform(np.eye(3), [0.0, 0.0, 1.0])
    back = make_transform(np.eye(3), [0.0, 0.0, 2.0])
    S = np.array([[1.0, 1.0, 0.2], [0.4, 0.4, 0.2]])
    pts = np.concatenate([_face_points(front, S[0] * 0.5, rng), _face_points(back, S[1] * 0.5, rng)])
    labels = np.repeat([0, 1], len(pts) // 2)
    table = np.full((2, 3, SEEN_PATTERNS, 3), np.nan)
    table[:, :] = [0.95, 1.0, 1.02]
    T2 = np.stack([front, back])
    # the back box is hidden behind the front one: kept; the front one is fitted
    _, S_out, fitted = fit_seen_extents(T2, S, pts, labels, table, min_seen=0.1)
    assert fitted[0, :2].all() and not fitted[1].any()
    np.testing.assert_array_equal(S_out[1], S[1])
    # far smaller than voted (below min_seen): kept
    _, _, fitted = fit_seen_extents(T2, S, pts, labels, table, min_seen=0.9, max_occluded=1.0)
    assert not fitted[:, :2].any()
    # symmetric about y: only y may be set; too few points: nothing
    _, _, fitted = fit_seen_extents(T2, S, pts, labels, table, ["y", "none"], min_seen=0.1, max_occluded=1.0)
    assert not fitted[0, [0, 2]].any()
    # only the parts named may be fitted
    _, _, fitted = fit_seen_extents(T2, S, pts, labels, table, parts=(1,), min_seen=0.1, max_occluded=1.0)
    assert not fitted[0].any()
    _, S_out, fitted = fit_seen_extents(T2, S, pts[:10], labels[:10], table)
    assert not fitted.any() and np.array_equal(S_out, S)


def test_fit_bad_input_is_named():
    T, S = np.eye(4)[None], np.ones((1, 3))
    pts, lab = np.zeros((5, 3)), np.zeros(5, int)
    table = np.full((1, 3, SEEN_PATTERNS, 3), 1.0)
    with pytest.raises(InputError, match="cam_from_part"):
        fit_seen_extents(np.eye(4), S, pts, lab, table)
    with pytest.raises(InputError, match="size_m"):
        fit_seen_extents(T, np.ones((2, 3)), pts, lab, table)
    with pytest.raises(InputError, match="seen_extent must have shape"):
        fit_seen_extents(T, S, pts, lab, table[:, :2])
    with pytest.raises(InputError, match="ratios >= 0"):
        fit_seen_extents(T, S, pts, lab, -table)
    with pytest.raises(InputError, match="ratios >= 0"):
        fit_seen_extents(T, S, pts, lab, np.full_like(table, np.inf))
    with pytest.raises(InputError, match="labels"):
        fit_seen_extents(T, S, pts, np.zeros(5), table)
    with pytest.raises(InputError, match="finite"):
        fit_seen_extents(T, S, np.full((5, 3), np.nan), lab, table)
    with pytest.raises(InputError, match="quantile"):
        fit_seen_extents(T, S, pts, lab, table, quantile=-0.1)
    with pytest.raises(InputError, match="min_seen"):
        fit_seen_extents(T, S, pts, lab, table, min_seen=0.0)
    with pytest.raises(InputError, match="confidence"):
        fit_seen_extents(T, S, pts, lab, table, confidence=np.ones(3))
    with pytest.raises(InputError, match="symmetry"):
        fit_seen_extents(T, S, pts, lab, table, ["none", "y"])
    with pytest.raises(InputError, match="parts"):
        fit_seen_extents(T, S, pts, lab, table, parts=(1,))


# ---------------------------------------------------------------------------------- anchor_faced_faces
def anchor_reference(T, S, pts, labels, table, parts, keep, q, min_points, max_spread):
    """Plain loops over parts and axes (no joining test, no hiding neighbours)."""
    T = np.array(T, float)
    for k in parts:
        own = [p for p, lab in zip(pts, labels, strict=True) if lab == k]
        if len(own) < min_points:
            continue
        R, t = T[k, :3, :3], T[k, :3, 3]
        local = np.array([R.T @ (p - t) for p in own])
        cam = R.T @ (np.zeros(3) - t)
        shift = np.zeros(3)
        for a in range(3):
            if keep[k, a] or abs(cam[a]) <= S[k, a] / 2:
                continue
            side = 1 if cam[a] > 0 else 0
            lo10, mid, hi90 = table[k, a, side]
            if not hi90 - lo10 <= max_spread:
                continue
            diag = float(np.sqrt(sum(x * x for x in S[k])))
            if side:
                face = np.quantile(local[:, a], 1 - q) + mid * diag
                shift[a] = face - S[k, a] / 2
            else:
                face = np.quantile(local[:, a], q) - mid * diag
                shift[a] = face + S[k, a] / 2
        T[k, :3, 3] = t + R @ shift
    return T


@pytest.mark.parametrize("seed", range(4))
def test_anchoring_matches_the_plain_reference(seed):
    rng = np.random.default_rng(seed)
    T, S, pts, labels = _scene(rng, K=3)
    table = np.sort(rng.uniform(-0.02, 0.04, (3, 3, 2, 3)), axis=-1)
    table[rng.uniform(size=(3, 3, 2)) < 0.2] = np.nan
    keep = rng.uniform(size=(3, 3)) < 0.2
    got, moved = anchor_faced_faces(
        T, S, pts, labels, table, parts=(0, 2), keep=keep, connect_factor=None, max_occluded=1.0, min_points=20
    )
    ref = anchor_reference(T, S, pts, labels, table, (0, 2), keep, 0.01, 20, P.anchor_max_spread)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)
    assert not moved[1].any() and not (moved & keep).any()
    np.testing.assert_array_equal(got[:, :3, :3], T[:, :3, :3])


def test_a_frame_seen_from_behind_gets_its_depth_from_its_back():
    """A thin box seen from behind and the side (the camera beyond its - z and - x faces) whose voted centre
    sits 1.5 cm too far along +z: anchored, its - z face goes where its points are, the centre half the extent
    behind it; x (not measured in the table) stays."""
    rng = np.random.default_rng(2)
    Rt = np.eye(3)  # the box's z runs away from the camera (origin), which lies beyond its - z face
    true = make_transform(Rt, [0.2, 0.02, 0.8])
    size = np.array([0.14, 0.05, 0.02])
    pts = _face_points(true, size, rng)
    voted = true.copy()
    voted[:3, 3] += Rt @ [0.0, 0.0, 0.015]
    table = np.full((1, 3, 2, 3), np.nan)
    table[0, 2, 0] = [0.0, 0.0, 0.01]  # the - z face: no gap between it and the points
    T, moved = anchor_faced_faces(voted[None], size[None], pts, np.zeros(len(pts), int), table, quantile=0.0)
    np.testing.assert_array_equal(moved, [[False, False, True]])
    np.testing.assert_allclose(T[0, :3, 3], true[:3, 3], atol=1e-9)
    # a spread above max_spread: left where voting put it
    table[0, 2, 0] = [0.0, 0.0, 0.05]
    T, moved = anchor_faced_faces(voted[None], size[None], pts, np.zeros(len(pts), int), table)
    assert not moved.any() and np.array_equal(T[0], voted)


def test_anchor_bad_input_is_named():
    T, S = np.eye(4)[None], np.ones((1, 3))
    pts, lab = np.zeros((5, 3)), np.zeros(5, int)
    table = np.zeros((1, 3, 2, 3))
    with pytest.raises(InputError, match="cam_from_part"):
        anchor_faced_faces(np.eye(4), S, pts, lab, table)
    with pytest.raises(InputError, match="size_m"):
        anchor_faced_faces(T, np.ones((2, 3)), pts, lab, table)
    with pytest.raises(InputError, match="faced_gap"):
        anchor_faced_faces(T, S, pts, lab, np.zeros((1, 3, 3, 3)))
    with pytest.raises(InputError, match="faced_gap"):
        anchor_faced_faces(T, S, pts, lab, np.full((1, 3, 2, 3), np.inf))
    with pytest.raises(InputError, match="parts"):
        anchor_faced_faces(T, S, pts, lab, table, parts=(1,))
    with pytest.raises(InputError, match="keep"):
        anchor_faced_faces(T, S, pts, lab, table, keep=np.zeros((2, 3), bool))
    with pytest.raises(InputError, match="max_spread"):
        anchor_faced_faces(T, S, pts, lab, table, max_spread=-1.0)
    with pytest.raises(InputError, match="labels"):
        anchor_faced_faces(T, S, pts, np.zeros(4, int), table)
    with pytest.raises(InputError, match="finite"):
        anchor_faced_faces(T, S, np.full((5, 3), np.nan), lab, table)
    with pytest.raises(InputError, match="confidence"):
        anchor_faced_faces(T, S, pts, lab, table, confidence=np.ones(2))


def test_a_hidden_door_takes_its_width_and_height_from_its_measured_body():
    """The body's extents were measured (a countertop cabinet, 0.5 m tall); the door, voted 0.8 m tall, gets
    0.86 x the body's height and its width, and hangs from the hinge where the body puts it; its depth (a
    ratio that varies) and its rotation stay. A plausible door (within 15 %) keeps its extents."""

    pri = door_priors()
    rng = np.random.default_rng(0)
    R = rotation_about_axis(rng.normal(size=3), 0.7)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = [0.1, 0.2, 2.0]
    S = np.array([[0.6, 0.5, 0.55], [0.6, 0.8, 0.1]])
    measured = np.array([[True, True, True], [False, False, False]])
    got_T, got_S, carried = carry_child_sizes(T, S, measured, pri)
    np.testing.assert_allclose(got_S[1], [0.6, 0.86 * 0.5, 0.1])  # the width was already right: 0.6 = 1.0 x 0.6
    np.testing.assert_array_equal(carried, [[False, False, False], [False, True, False]])
    hinge = R @ (np.array([0.0, -0.5, 0.5]) * S[0]) + T[0, :3, 3]
    np.testing.assert_allclose(got_T[1, :3, 3], hinge - R @ (np.array([0.0, -0.5, -0.5]) * got_S[1]), atol=1e-12)
    np.testing.assert_array_equal(got_T[1, :3, :3], R)
    np.testing.assert_array_equal(got_T[0], T[0])
    # a door voted within 15 % of 0.86 x the body, a body not measured, a door measured itself: nothing moves
    for S2, m in (
        (np.array([[0.6, 0.5, 0.55], [0.6, 0.46, 0.1]]), measured),
        (S, np.zeros((2, 3), bool)),
        (S, np.ones((2, 3), bool)),
    ):
        same_T, same_S, carried = carry_child_sizes(T, S2, m, pri)
        assert not carried.any() and np.array_equal(same_S, S2) and np.array_equal(same_T, T)


def test_carrying_sizes_names_bad_input():
    pri = door_priors()
    T, S, m = np.tile(np.eye(4), (2, 1, 1)), np.ones((2, 3)), np.zeros((2, 3), bool)
    with pytest.raises(InputError, match="shapes"):
        carry_child_sizes(T[:1], S, m, pri)
    with pytest.raises(InputError, match="positive"):
        carry_child_sizes(T, -S, m, pri)
    with pytest.raises(InputError, match="min_change"):
        carry_child_sizes(T, S, m, pri, min_change=-1.0)
    with pytest.raises(InputError, match="go together"):
        JointPrior("revolute", 0, 1, (1, 0, 0), child_size_ratio=(1.0, 1.0, 1.0))
    with pytest.raises(InputError, match="child_size_ratio"):
        JointPrior("revolute", 0, 1, (1, 0, 0), child_size_ratio=(1.0, 0.0, 1.0), child_size_spread=(0.0, 0.0, 0.0))
