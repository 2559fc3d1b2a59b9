"""ucope.stages.prismatic: drawers placed in their cabinet: held by its box, as deep as it says, placed across the
slide as in training, slid to their fronts' points, hidden ones stacked against seen siblings."""

import numpy as np
import pytest
from stages_support import chest, chest_scene, labels_of

from ucope.errors import InputError
from ucope.geometry.kinematics import joint_state_from_poses
from ucope.geometry.transforms import rotation_about_axis
from ucope.priors import CategoryPriors, JointPrior, PartPrior
from ucope.stages.prismatic import (
    carry_prismatic_depths,
    hold_prismatic_children,
    place_prismatic_children,
    slide_to_fronts,
    stack_hidden_children,
)


def _cabinet_priors(spread=(0.0, 0.05, 0.1), axis=(0, 0, 1)):
    parts = (PartPrior("cabinet", "none", 0.6, (0.6, 0.8, 0.5)), PartPrior("drawer", "none", 0.4, (0.55, 0.2, 0.45)))
    joint = JointPrior("prismatic", 0, 1, axis, limits=(0.0, 0.3), child_in_parent=(0.0, 0.2, 0.1), child_in_parent_spread=spread)
    return CategoryPriors("toy", parts, (joint,), norm_scale_m=0.5)


def _placed_reference(T, S, pri, max_spread):
    """Plain per-axis reference: the child's centre in the parent frame, each parent axis across the joint
    axis with a small spread set to the training mean (in parent diagonals), back to the camera frame."""
    out = T.copy()
    for jp in pri.joints:
        Rp, tp = T[jp.parent, :3, :3], T[jp.parent, :3, 3]
        local = [float(Rp[:, i] @ (T[jp.child, :3, 3] - tp)) for i in range(3)]
        for i in range(3):
            if abs(jp.axis_in_parent[i]) < 1e-6 and jp.child_in_parent_spread[i] < max_spread:
                local[i] = jp.child_in_parent[i] * float(np.sqrt(sum(x * x for x in S[jp.parent])))
        out[jp.child, :3, 3] = tp + sum(local[i] * Rp[:, i] for i in range(3))
    return out


def test_a_prismatic_child_is_placed_where_its_parent_always_held_it_against_a_plain_reference():
    pri = _cabinet_priors()
    rng = np.random.default_rng(3)
    for _ in range(5):
        T = np.tile(np.eye(4), (2, 1, 1))
        R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
        T[:, :3, :3] = R
        T[0, :3, 3] = rng.normal(size=3)
        T[1, :3, 3] = T[0, :3, 3] + R @ np.array([0.07, 0.15, 0.2])  # 7 cm off to the side
        S = np.array([[0.6, 0.8, 0.5], [0.5, 0.2, 0.45]])
        got, moved = place_prismatic_children(T, S, pri)
        np.testing.assert_allclose(got, _placed_reference(T, S, pri, 0.01), atol=1e-12)
        local = R.T @ (got[1, :3, 3] - got[0, :3, 3])
        np.testing.assert_allclose(local, [0.0, 0.15, 0.2], atol=1e-12)  # only x, whose spread is 0, moved
        assert moved[0] == pytest.approx(0.07) and np.array_equal(got[1, :3, :3], T[1, :3, :3])
        u = R @ np.array([0.0, 0.0, 1.0])
        q = [joint_state_from_poses(X[0], X[1], u, "prismatic", S[0], S[1]) for X in (T, got)]
        assert q[1] == pytest.approx(q[0])  # the state, along the axis, is kept
    # a wide spread, the joint's own axis, a revolute joint or priors without the spread: nothing moves
    for other in (_cabinet_priors(spread=(0.02, 0.05, 0.1)), _cabinet_priors(axis=(1, 0, 0)), _cabinet_priors(spread=None)):
        same, moved = place_prismatic_children(T, S, other)
        assert np.array_equal(same, T) and not moved.any()


def test_placing_names_bad_input():
    pri = _cabinet_priors()
    with pytest.raises(InputError, match="cam_from_part"):
        place_prismatic_children(np.eye(4)[None], np.ones((1, 3)), pri)
    with pytest.raises(InputError, match="max_spread"):
        place_prismatic_children(np.tile(np.eye(4), (2, 1, 1)), np.ones((2, 3)), pri, max_spread=-1.0)
    with pytest.raises(InputError, match="child_in_parent_spread"):
        JointPrior("prismatic", 0, 1, (0, 0, 1), child_in_parent_spread=(0.0, -0.1, 0.0))
    assert JointPrior.__dataclass_fields__["child_in_parent_spread"].default is None


def _drawer_front_scene(rng, pulled=0.12, voted_offset=0.5):
    """A cabinet and a drawer pulled out by ``pulled`` (both turned by one random rotation); the drawer's front
    panel sampled (the face at +z of its box, as a camera in front sees it), and the voted drawer box moved
    ``voted_offset`` further out along the slide, the panel now inside it."""
    R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
    T = np.tile(np.eye(4), (2, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = rng.normal(size=3) + [0, 0, 3]
    S = np.array([[0.6, 0.8, 0.5], [0.55, 0.2, 0.45]])
    true_local = np.array([0.0, 0.2, 0.025 + pulled])  # the drawer's centre in the cabinet's frame
    T[1, :3, 3] = T[0, :3, 3] + R @ true_local
    panel = np.c_[rng.uniform(-0.27, 0.27, 300), rng.uniform(-0.1, 0.1, 300), np.full(300, 0.225)]
    pts = T[1, :3, 3] + panel @ R.T
    voted = T.copy()
    voted[1, :3, 3] += voted_offset * (R @ [0.0, 0.0, 1.0])
    return T, voted, S, pts


def test_a_drawer_voted_out_in_front_of_its_panel_slides_back_to_it():
    """The voted box stands 0.5 m out, its back at the front panel: the drawer slides back along the cabinet's z
    until its front face meets the panel's points (their 98th percentile: the panel itself here); rotation and
    size stay, the cabinet stays, and the move is reported along the axis."""

    pri = _cabinet_priors()
    rng = np.random.default_rng(4)
    for _ in range(5):
        T, voted, S, pts = _drawer_front_scene(rng)
        lab = np.ones(len(pts), dtype=np.int64)
        got, moved = slide_to_fronts(voted, S, pts, lab, pri)
        np.testing.assert_allclose(got[1, :3, 3], T[1, :3, 3], atol=1e-9)
        np.testing.assert_array_equal(got[1, :3, :3], voted[1, :3, :3])
        np.testing.assert_array_equal(got[0], voted[0])
        assert moved[0] == pytest.approx(-0.5)
        # a drawer voted too deep into the cabinet comes out to the panel the same way
        deep = T.copy()
        deep[1, :3, 3] -= 0.2 * (T[0, :3, :3] @ [0.0, 0.0, 1.0])
        got, moved = slide_to_fronts(deep, S, pts, lab, pri)
        np.testing.assert_allclose(got[1, :3, 3], T[1, :3, 3], atol=1e-9)
        assert moved[0] == pytest.approx(0.2)


def test_a_drawer_whose_front_is_near_its_points_keeps_its_voted_centre():
    """A box voted 6 cm too deep (0.06 m / 0.65 m diagonal, under ``min_shift``'s 10 %) keeps its centre: moving
    its front onto the panel would carry the voted depth's error into the centre; at ``min_shift=0`` it moves."""

    pri = _cabinet_priors()
    T, voted, S, pts = _drawer_front_scene(np.random.default_rng(8), voted_offset=0.06)
    lab = np.ones(len(pts), dtype=np.int64)
    got, moved = slide_to_fronts(voted, S, pts, lab, pri)
    np.testing.assert_array_equal(got, voted)
    assert not moved.any()
    got, moved = slide_to_fronts(voted, S, pts, lab, pri, min_shift=0.0)
    np.testing.assert_allclose(got[1, :3, 3], T[1, :3, 3], atol=1e-9)
    assert moved[0] == pytest.approx(-0.06)


def test_a_drawer_slides_to_the_quantile_of_its_points_not_a_stray_one():
    """One stray point 0.4 m out in front does not carry the front with it (the 98th percentile of 301 points);
    points of other parts, and points below the confidence, do not count."""

    pri = _cabinet_priors()
    T, voted, S, pts = _drawer_front_scene(np.random.default_rng(5))
    out = T[1, :3, 3] + T[1, :3, :3] @ [0.0, 0.0, 0.625]
    lab = np.ones(len(pts) + 2, dtype=np.int64)
    lab[-1] = 0  # a cabinet point further out still
    cloud = np.vstack([pts, out, T[1, :3, 3] + T[1, :3, :3] @ [0.0, 0.0, 0.9]])
    got, _ = slide_to_fronts(voted, S, cloud, lab, pri)
    np.testing.assert_allclose(got[1, :3, 3], T[1, :3, 3], atol=1e-9)
    unsure = np.ones(len(cloud))
    unsure[: len(pts)] = 0.2  # only the stray points are sure: fewer than min_points, the drawer stays
    got, moved = slide_to_fronts(voted, S, cloud, lab, pri, confidence=unsure)
    np.testing.assert_array_equal(got, voted)
    assert not moved.any()


def test_stray_points_out_in_front_of_a_drawer_do_not_carry_its_front():
    """30 stray points labelled as the drawer (10 % of its panel's), scattered 0.18-0.43 m in front of it (beyond 8
    times the panel's point spacing): their 98th percentile would put the front over 0.2 m out; only the panel,
    the largest connected piece, counts. With one piece per point (a tiny ``connect_factor``) the largest is a
    single point: too few, the drawer stays."""

    pri = _cabinet_priors()
    rng = np.random.default_rng(9)
    T, voted, S, pts = _drawer_front_scene(rng)
    local = np.c_[rng.uniform(-0.27, 0.27, 30), rng.uniform(-0.1, 0.1, 30), rng.uniform(0.4, 0.65, 30)]
    cloud = np.vstack([pts, T[1, :3, 3] + local @ T[1, :3, :3].T])
    lab = np.ones(len(cloud), dtype=np.int64)
    a = T[1, :3, :3][:, 2]  # the slide axis in the camera frame
    assert np.quantile((cloud - T[1, :3, 3]) @ a, 0.98) > 0.225 + 0.2  # the plain quantile lies far out
    got, _ = slide_to_fronts(voted, S, cloud, lab, pri)
    np.testing.assert_allclose(got[1, :3, 3], T[1, :3, 3], atol=1e-9)
    same, moved = slide_to_fronts(voted, S, cloud, lab, pri, connect_factor=1e-6)
    np.testing.assert_array_equal(same, voted)
    assert not moved.any()


def test_sliding_leaves_drawers_with_few_points_and_revolute_joints_alone():
    pri = _cabinet_priors()
    T, voted, S, pts = _drawer_front_scene(np.random.default_rng(6))
    few = pts[:9]
    got, moved = slide_to_fronts(voted, S, few, np.ones(len(few), dtype=np.int64), pri)
    assert np.array_equal(got, voted) and not moved.any()
    got, _ = slide_to_fronts(voted, S, few, np.ones(len(few), dtype=np.int64), pri, min_points=5)
    assert not np.array_equal(got, voted)
    hinge = CategoryPriors("toy", pri.parts, (JointPrior("revolute", 0, 1, (1, 0, 0), limits=(0.0, 1.5)),), norm_scale_m=0.5)
    got, moved = slide_to_fronts(voted, S, pts, np.ones(len(pts), dtype=np.int64), hinge)
    assert np.array_equal(got, voted) and not moved.any()


def test_sliding_names_bad_input():
    pri = _cabinet_priors()
    T, voted, S, pts = _drawer_front_scene(np.random.default_rng(7))
    lab = np.ones(len(pts), dtype=np.int64)
    with pytest.raises(InputError, match="cam_from_part"):
        slide_to_fronts(voted[:1], S[:1], pts, lab, pri)
    with pytest.raises(InputError, match="labels"):
        slide_to_fronts(voted, S, pts, lab[:-1], pri)
    with pytest.raises(InputError, match="finite"):
        slide_to_fronts(voted, S, np.where(np.arange(len(pts))[:, None] == 3, np.nan, pts), lab, pri)
    with pytest.raises(InputError, match="positive"):
        slide_to_fronts(voted, S * [[1, 1, 1], [1, 0, 1]], pts, lab, pri)
    with pytest.raises(InputError, match="quantile"):
        slide_to_fronts(voted, S, pts, lab, pri, quantile=0.5)
    with pytest.raises(InputError, match="min_shift"):
        slide_to_fronts(voted, S, pts, lab, pri, min_shift=-0.1)
    with pytest.raises(InputError, match="connect_factor"):
        slide_to_fronts(voted, S, pts, lab, pri, connect_factor=0.0)
    with pytest.raises(InputError, match="confidence"):
        slide_to_fronts(voted, S, pts, lab, pri, confidence=np.ones(3))


def _sized_cabinet_priors(ratio=(0.97, 0.27, 0.95), spread=(0.05, 0.18, 0.047), axis=(0, 0, 1), kind="prismatic"):
    """A cabinet and one drawer (or door) whose box is ``ratio`` times the cabinet's, varying by ``spread``."""

    parts = (PartPrior("cabinet", "none", 0.6, (0.6, 0.8, 0.5)), PartPrior("drawer", "none", 0.4, (0.55, 0.2, 0.45)))
    joint = JointPrior(kind, 0, 1, axis, limits=(0.0, 0.3), child_size_ratio=ratio, child_size_spread=spread)
    return CategoryPriors("toy", parts, (joint,), norm_scale_m=0.5)


def _deep_drawer_scene(seed):
    """A cabinet 0.5 m deep and its drawer voted 0.6 m deep (0.95 x 0.5 = 0.475 is right), one random rotation."""
    rng = np.random.default_rng(seed)
    R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
    T = np.tile(np.eye(4), (2, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = rng.normal(size=3) + [0, 0, 3]
    T[1, :3, 3] = T[0, :3, 3] + R @ np.array([0.0, 0.2, 0.05])
    S = np.array([[0.6, 0.8, 0.5], [0.55, 0.2, 0.6]])
    return T, S, R


def _narrow_chest_scene(seed, n=400):
    """A chest 1.2 m wide, 1.0 m tall, 0.5 m deep whose cabinet box was voted 0.7 m wide, 0.8 m tall (centred
    0.1 m off to the right); the camera sees the cabinet's top board and two drawer fronts spanning its width."""
    rng = np.random.default_rng(seed)
    R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
    t = rng.normal(size=3) + [0, 0, 3]
    top = np.c_[rng.uniform(-0.6, 0.6, n), np.full(n, 0.45), rng.uniform(-0.25, 0.25, n)]
    fronts = np.c_[rng.uniform(-0.6, 0.6, 2 * n), rng.uniform(-0.48, 0.45, 2 * n), np.full(2 * n, 0.25)]
    pts = np.r_[top, fronts] @ R.T + t
    labels = np.r_[np.zeros(n, int), np.where(fronts[:, 1] > 0, 1, 2)]
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = t + R @ [0.1, 0.05, 0.0]
    T[1, :3, 3] = t + R @ [0.1, 0.25, 0.0]
    T[2, :3, 3] = t + R @ [0.1, -0.25, 0.0]
    S = np.array([[0.7, 0.8, 0.5], [0.65, 0.45, 0.45], [0.65, 0.45, 0.45]])
    return T, S, pts, labels, R, t


def _two_drawer_priors(ratio=(0.97, 0.45, 0.95), kind="prismatic"):
    parts = tuple(PartPrior(n, "none", 0.8, (0.6, 0.5, 0.5)) for n in ("cabinet", "upper", "lower"))
    joints = tuple(
        JointPrior(kind, 0, k, (0, 0, 1), limits=(0.0, 0.3), child_size_ratio=ratio, child_size_spread=(0.05, 0.1, 0.05))
        for k in (1, 2)
    )
    return CategoryPriors("chest2", parts, joints, norm_scale_m=0.5)


def test_a_cabinet_voted_narrow_is_widened_to_hold_its_drawers_fronts():
    """The cabinet's box widens left-right and up-down (across the slide) to the 1-99 % range of its own and its
    drawers' points, its centre to that range's middle; along the slide (z) and in rotation it stays, and so do
    the drawers. Checked against a plain per-axis reference."""

    pri = _two_drawer_priors()
    for seed in range(3):
        T, S, pts, lab, R, t = _narrow_chest_scene(seed)
        got_T, got_S, grown = hold_prismatic_children(T, S, pts, lab, pri)
        local = (pts - T[0, :3, 3]) @ R  # every point is the cabinet's or a drawer's, all joined
        lo = np.minimum(np.quantile(local, 0.01, axis=0), -0.5 * S[0])
        hi = np.maximum(np.quantile(local, 0.99, axis=0), 0.5 * S[0])
        assert grown.tolist() == [[True, True, False], [False] * 3, [False] * 3]
        np.testing.assert_allclose(got_S[0], [hi[0] - lo[0], hi[1] - lo[1], 0.5])
        np.testing.assert_allclose(got_T[0, :3, 3], T[0, :3, 3] + R @ [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.0])
        assert 1.15 < got_S[0, 0] < 1.2 and abs(R[:, 0] @ (got_T[0, :3, 3] - t)) < 0.02  # about the true 1.2 m, centred
        np.testing.assert_array_equal(got_T[1:], T[1:])
        np.testing.assert_array_equal(got_S[1:], S[1:])
        np.testing.assert_array_equal(got_T[0, :3, :3], T[0, :3, :3])


def test_holding_leaves_what_it_should_alone():
    """Nothing moves for: a box that already holds the points, revolute children, children larger than the parent
    along an axis (that axis), stray points out of reach, points the segmentation doubts."""

    T, S, pts, lab, R, t = _narrow_chest_scene(0)
    wide = S.copy()
    wide[0] = [1.5, 1.2, 0.5]
    wide_T = T.copy()
    wide_T[0, :3, 3] = t
    for T2, S2, pri in ((wide_T, wide, _two_drawer_priors()), (T, S, _two_drawer_priors(kind="revolute"))):
        got_T, got_S, grown = hold_prismatic_children(T2, S2, pts, lab, pri)
        assert not grown.any() and np.array_equal(got_S, S2) and np.array_equal(got_T, T2)
    _, got_S, grown = hold_prismatic_children(T, S, pts, lab, _two_drawer_priors(ratio=(1.02, 0.45, 0.95)))
    assert grown[0].tolist() == [False, True, False] and got_S[0, 0] == S[0, 0]  # drawers wider: x is not the cabinet's
    # 30 stray points 2 m to the side, labelled as a drawer: out of reach of the box's piece
    stray = t + R @ [2.5, 0.0, 0.0] + np.random.default_rng(1).normal(scale=0.01, size=(30, 3))
    _, with_stray, _ = hold_prismatic_children(T, S, np.r_[pts, stray], np.r_[lab, np.ones(30, int)], _two_drawer_priors())
    _, plain, _ = hold_prismatic_children(T, S, pts, lab, _two_drawer_priors())
    np.testing.assert_allclose(with_stray, plain, atol=0.02)
    doubted = np.where(lab > 0, 0.3, 0.99)  # the fronts doubted: only the top board counts, 1.2 m wide
    _, got_S, grown = hold_prismatic_children(T, S, pts, lab, _two_drawer_priors(), confidence=doubted)
    assert grown[0].tolist() == [True, False, False] and got_S[0, 1] == S[0, 1]


def test_holding_names_bad_input():
    pri = _two_drawer_priors()
    T, S, pts, lab, _, _ = _narrow_chest_scene(0)
    with pytest.raises(InputError, match="parts of the priors"):
        hold_prismatic_children(T[:2], S[:2], pts, lab, pri)
    with pytest.raises(InputError, match="finite"):
        hold_prismatic_children(T, S, np.full_like(pts, np.nan), lab, pri)
    with pytest.raises(InputError, match="labels"):
        hold_prismatic_children(T, S, pts, lab[:5], pri)
    with pytest.raises(InputError, match="quantile"):
        hold_prismatic_children(T, S, pts, lab, pri, quantile=0.5)
    with pytest.raises(InputError, match="connect_factor"):
        hold_prismatic_children(T, S, pts, lab, pri, connect_factor=0.0)
    with pytest.raises(InputError, match="confidence"):
        hold_prismatic_children(T, S, pts, lab, pri, confidence=np.ones(3))


def test_a_drawer_voted_too_deep_takes_its_cabinets_depth_and_keeps_its_front():
    """The drawer's depth becomes 0.95 x the cabinet's 0.5 m; its front face (at +z, where it is pulled out)
    stays where voting put it, so its centre moves 6.25 cm out; rotation, width, height and the cabinet stay.
    Checked against a plain per-corner reference: the front face's four corners do not move."""

    pri = _sized_cabinet_priors()
    for seed in range(4):
        T, S, R = _deep_drawer_scene(seed)
        got_T, got_S, carried = carry_prismatic_depths(T, S, pri)
        assert carried.tolist() == [True]
        np.testing.assert_allclose(got_S[1], [0.55, 0.2, 0.95 * 0.5])
        np.testing.assert_array_equal(got_S[0], S[0])
        np.testing.assert_array_equal(got_T[0], T[0])
        np.testing.assert_array_equal(got_T[1, :3, :3], T[1, :3, :3])
        np.testing.assert_allclose(got_T[1, :3, 3], T[1, :3, 3] + R @ [0.0, 0.0, 0.5 * (0.6 - 0.475)], atol=1e-12)
        corners = np.array([[x, y, 0.5] for x in (-0.5, 0.5) for y in (-0.5, 0.5)])  # the front face, unit box
        before = (corners * S[1]) @ T[1, :3, :3].T + T[1, :3, 3]
        after = (corners * got_S[1]) @ got_T[1, :3, :3].T + got_T[1, :3, 3]
        np.testing.assert_allclose(after, before, atol=1e-12)
    # pulled out along -z instead: the face at -z stays
    pri = _sized_cabinet_priors(axis=(0, 0, -1))
    got_T, got_S, _ = carry_prismatic_depths(T, S, pri)
    np.testing.assert_allclose(got_T[1, :3, 3], T[1, :3, 3] - R @ [0.0, 0.0, 0.5 * (0.6 - 0.475)], atol=1e-12)


def test_a_drawer_keeps_its_depth_where_nothing_says_otherwise():
    """Left alone: a depth within 10 % of the carried one, a depth measured from the points, a ratio that varied
    by more than 10 %, a revolute joint, a slide across the box axes, priors without size ratios."""

    T, S, _ = _deep_drawer_scene(0)
    pri = _sized_cabinet_priors()
    near = S.copy()
    near[1, 2] = 0.5  # 0.475 is within 10 %
    measured = np.zeros((2, 3), bool)
    measured[1, 2] = True
    bare = CategoryPriors("toy", pri.parts, (JointPrior("prismatic", 0, 1, (0, 0, 1), limits=(0.0, 0.3)),), norm_scale_m=0.5)
    cases = [
        (near, pri, None),
        (S, pri, measured),
        (S, _sized_cabinet_priors(spread=(0.05, 0.18, 0.15)), None),
        (S, _sized_cabinet_priors(kind="revolute"), None),
        (S, _sized_cabinet_priors(axis=(0, 1, 1)), None),
        (S, bare, None),
    ]
    for S2, p, m in cases:
        got_T, got_S, carried = carry_prismatic_depths(T, S2, p, m)
        assert not carried.any() and np.array_equal(got_S, S2) and np.array_equal(got_T, T)


def test_carrying_depths_names_bad_input():
    pri = _sized_cabinet_priors()
    T, S, _ = _deep_drawer_scene(0)
    with pytest.raises(InputError, match="shapes"):
        carry_prismatic_depths(T[:1], S, pri)
    with pytest.raises(InputError, match="measured"):
        carry_prismatic_depths(T, S, pri, np.zeros((3, 3), bool))
    with pytest.raises(InputError, match="positive"):
        carry_prismatic_depths(T, -S, pri)
    with pytest.raises(InputError, match="finite"):
        carry_prismatic_depths(np.full_like(T, np.nan), S, pri)
    with pytest.raises(InputError, match="max_spread"):
        carry_prismatic_depths(T, S, pri, max_spread=-0.1)


def _local_y(T, R):
    return [float(R[:, 1] @ (T[k, :3, 3] - T[0, :3, 3])) for k in range(4)]


def test_hidden_drawers_are_stacked_under_a_seen_one_above_them():
    """The top drawer is seen (kept where voted, 0.55 m up); the middle and bottom ones, hidden, hang under it
    0.005 x 1 m apart: each one's top face 5 mm under the bottom face of the one above. Only their heights
    change; the slide (z), left-right (x), rotations and sizes stay."""

    pri = chest()
    for seed in range(3):
        T, S, R = chest_scene(seed)
        got, S2, moved = stack_hidden_children(T, S, labels_of([500, 200, 3, 0]), pri)
        np.testing.assert_array_equal(S2, S)  # the chest's priors hold no size ratios
        y = _local_y(got, R)
        assert y[1] == pytest.approx(0.55)
        assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125)
        assert y[3] == pytest.approx(y[2] - 0.125 - 0.005 - 0.15)
        for k in range(4):
            np.testing.assert_allclose(R.T @ (got[k, :3, 3] - T[k, :3, 3]), [0.0, y[k] - _local_y(T, R)[k], 0.0], atol=1e-12)
            np.testing.assert_array_equal(got[k, :3, :3], T[k, :3, :3])
        np.testing.assert_allclose(moved, np.array(y) - _local_y(T, R), atol=1e-12)


def test_hidden_drawers_go_on_a_seen_one_below_or_under_the_cabinets_top():
    """Only the bottom drawer seen: the middle one sits on it, the top one on the middle one. None seen: the top
    drawer's top face 0.03 x 1 m under the cabinet's, the others under it. All seen: nothing moves."""

    pri = chest()
    T, S, R = chest_scene(0)
    y = _local_y(stack_hidden_children(T, S, labels_of([500, 0, 0, 50]), pri)[0], R)
    assert y[3] == pytest.approx(0.0, abs=1e-12)
    assert y[2] == pytest.approx(0.15 + 0.005 + 0.125) and y[1] == pytest.approx(y[2] + 0.125 + 0.005 + 0.1)
    y = _local_y(stack_hidden_children(T, S, labels_of([500, 0, 0, 0]), pri)[0], R)
    assert y[1] == pytest.approx(0.5 - 0.03 - 0.1)
    assert y[2] == pytest.approx(y[1] - 0.1 - 0.005 - 0.125) and y[3] == pytest.approx(y[2] - 0.125 - 0.005 - 0.15)
    # the middle one hidden between two seen ones hangs under the top one
    y = _local_y(stack_hidden_children(T, S, labels_of([500, 40, 0, 40]), pri)[0], R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125) and y[3] == pytest.approx(0.0, abs=1e-12)
    same, _, moved = stack_hidden_children(T, S, labels_of([500, 40, 40, 40]), pri)
    assert np.array_equal(same, T) and not moved.any()


def test_stacking_leaves_loose_stacks_doubted_points_and_stackless_priors_alone():
    T, S, R = chest_scene(1)
    lab = labels_of([500, 0, 0, 0])
    for pri in (chest(first_gap_spread=0.2), chest(gap_spread=0.15), _cabinet_priors()):
        if pri.num_parts != 4:  # a category without stacks
            T2, S2 = T[:2], S[:2]
            same, _, moved = stack_hidden_children(T2, S2, np.zeros(10, int), pri)
            assert np.array_equal(same, T2) and not moved.any()
            continue
        same, _, moved = stack_hidden_children(T, S, lab, pri)
        assert np.array_equal(same, T) and not moved.any()
    # the middle drawer's 40 points doubted by the segmentation (confidence 0.3): it counts as hidden
    lab = labels_of([500, 40, 40, 40])
    conf = np.where(lab == 2, 0.3, 0.99)
    y = _local_y(stack_hidden_children(T, S, lab, chest(), confidence=conf)[0], R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125)


def _sized_chest():
    """:func:`_chest` with size ratios: each drawer 0.95 of the cabinet's width, 0.25 of its height, 0.9 of its depth."""
    from dataclasses import replace

    pri = chest()
    joints = tuple(replace(jp, child_size_ratio=(0.95, 0.25, 0.9), child_size_spread=(0.05, 0.15, 0.05)) for jp in pri.joints)
    return replace(pri, joints=joints)


def test_hidden_drawers_take_their_width_and_height_from_the_cabinet_before_they_are_stacked():
    """With size ratios in the priors, the hidden middle and bottom drawers become 0.95 x 0.6 m wide and 0.25 x 1 m
    tall (their depth, along the slide, stays), then hang under the seen top drawer by those heights; the seen one
    keeps its size. Without ``size_from_parent`` the voted sizes stay."""

    pri = _sized_chest()
    T, S, R = chest_scene(2)
    got, S2, _ = stack_hidden_children(T, S, labels_of([500, 200, 3, 0]), pri)
    np.testing.assert_array_equal(S2[:2], S[:2])
    np.testing.assert_allclose(S2[2:], [[0.57, 0.25, 0.45], [0.57, 0.25, 0.45]])
    y = _local_y(got, R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125)
    assert y[3] == pytest.approx(y[2] - 0.125 - 0.005 - 0.125)
    _, S3, _ = stack_hidden_children(T, S, labels_of([500, 200, 3, 0]), pri, size_from_parent=False)
    np.testing.assert_array_equal(S3, S)


def test_stacking_names_bad_input():
    pri = chest()
    T, S, _ = chest_scene(0)
    lab = labels_of([10, 10, 10, 10])
    with pytest.raises(InputError, match="cam_from_part"):
        stack_hidden_children(T[:3], S, lab, pri)
    with pytest.raises(InputError, match="positive"):
        stack_hidden_children(T, -S, lab, pri)
    with pytest.raises(InputError, match="labels"):
        stack_hidden_children(T, S, lab.astype(float), pri)
    with pytest.raises(InputError, match="confidence"):
        stack_hidden_children(T, S, lab, pri, confidence=np.ones(3))
    with pytest.raises(InputError, match="max_spread"):
        stack_hidden_children(T, S, lab, pri, max_spread=-1.0)
