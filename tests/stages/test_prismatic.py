import numpy as np
import pytest
import torch
from tests_support import measured_priors
from voting_support import angle_deg, peaked_logits

from ucope.data.generate import GenerateConfig, make_sample
from ucope.geometry.transforms import rotation_about_axis, rotation_angle_deg
from ucope.model.config import ModelConfig
from ucope.model.targets import joint_point_targets, pair_vote_targets
from ucope.vocab import JointType
from ucope.voting import VotingOptions, kinematic_refine, vote_object


def _samples(category, split, n):
    cfg = GenerateConfig(category=category, split=split, num=n, seed=0, views_per_instance=1)
    return [make_sample(cfg, i) for i in range(n)]


def _exact_outputs(s, cfg, rng, M=1500):
    """Network-shaped outputs equal to the ground truth of sample ``s`` (pairs within each part)."""
    K, J = cfg.num_parts, cfg.num_joints
    pts = torch.tensor(s["points"], dtype=torch.float32)
    nrm = torch.tensor(s["normals"], dtype=torch.float32)
    labels = np.asarray(s["part_labels"])
    pair_idx = np.stack([rng.choice(np.flatnonzero(labels == k), (M, 2)) for k in range(K)])
    out = {k: [] for k in ("mu_logits", "nu_logits", "alpha_logits", "beta_logits", "sign_logits", "gamma", "part_score")}
    for k in range(K):
        V = cfg.priors.vote_range_m[k]
        a, b, na = pts[pair_idx[k, :, 0]], pts[pair_idx[k, :, 1]], nrm[pair_idx[k, :, 0]]
        t = pair_vote_targets(
            a,
            b,
            na,
            torch.tensor(s["cam_from_part"][k], dtype=torch.float32),
            torch.tensor(s["size_m"][k], dtype=torch.float32),
            torch.tensor(cfg.priors.mean_size_m[k], dtype=torch.float32),
        )
        out["mu_logits"].append(peaked_logits(t["mu"], -V, V, cfg.mu_bins))
        out["nu_logits"].append(peaked_logits(t["nu"], 0.0, V, cfg.nu_bins))
        out["alpha_logits"].append(peaked_logits(t["alpha"], 0.0, np.pi, cfg.angle_bins))
        out["beta_logits"].append(peaked_logits(t["beta"], 0.0, np.pi, cfg.angle_bins))
        out["sign_logits"].append(t["sign"] * 8 - 4)
        out["gamma"].append(t["gamma"].expand(M, 3))
        out["part_score"].append(torch.full((M,), 4.0))
    outputs = {k: torch.stack(v)[None] for k, v in out.items()}
    jt = joint_point_targets(
        pts[None],
        torch.tensor(labels)[None],
        torch.tensor(s["joint_pivot"], dtype=torch.float32)[None],
        torch.tensor(s["joint_axis"], dtype=torch.float32)[None],
        torch.tensor(s["joint_type"])[None],
        torch.tensor([j.parent for j in cfg.priors.joints]),
        torch.tensor([j.child for j in cfg.priors.joints]),
        0.05,
    )
    outputs["joint_heat"] = jt["heat"] * 8 - 4
    outputs["joint_score"] = jt["score"] * 8 - 4
    outputs["joint_offset"] = jt["offset"]
    outputs["joint_dir"] = torch.tensor(s["joint_axis"], dtype=torch.float32)[None, :, None, :].expand(1, J, len(pts), 3)
    return pts, nrm, pair_idx, outputs


@pytest.mark.parametrize("category", ["laptop", "eyeglasses", "drawer"])
def test_vote_object_on_exact_heads_of_real_samples(category, rng):
    cfg = ModelConfig.default(measured_priors(category, _samples(category, "train", 20)), size="full")
    for s in _samples(category, "val", int(__import__("os").environ.get("UCOPE_TEST_SAMPLES", 2))):
        pts, nrm, pair_idx, outputs = _exact_outputs(s, cfg, rng)
        # With exact heads the voting inverts the targets; the thin-part surface snap (on by default)
        # then trades that exactness for the median of real, noisy surface points: a few millimetres.
        snapped = vote_object(pts, nrm, pair_idx, outputs, cfg.priors)
        for k in range(cfg.num_parts):
            assert np.linalg.norm(snapped["cam_from_part"][k][:3, 3] - s["cam_from_part"][k][:3, 3]) < 0.003
        for refine in (False, True):
            res = vote_object(pts, nrm, pair_idx, outputs, cfg.priors, refine=refine, options=VotingOptions(thin_snap_ratio=0.0))
            assert res["refined"] == refine
            for k in range(cfg.num_parts):
                T, Tg = res["cam_from_part"][k], s["cam_from_part"][k]
                cell = cfg.priors.vote_range_m[k] / 20
                assert np.linalg.norm(T[:3, 3] - Tg[:3, 3]) < 0.25 * cell
                assert rotation_angle_deg(T[:3, :3], Tg[:3, :3]) < 0.5
                np.testing.assert_allclose(res["size_m"][k], s["size_m"][k], rtol=0.01)
            for j in range(cfg.num_joints):
                assert angle_deg(res["joint_axis"][j], s["joint_axis"][j]) < 0.5
                if cfg.priors.joints[j].type == JointType.REVOLUTE:
                    d = np.cross(res["joint_pivot"][j] - s["joint_pivot"][j], s["joint_axis"][j])
                    assert np.linalg.norm(d) < 1e-3
                    assert abs(res["joint_state"][j] - s["joint_state"][j]) < np.radians(0.5)
                else:  # box supports: instance geometry the boxes cannot see (tests/geometry)
                    assert abs(res["joint_state"][j] - s["joint_state"][j]) < 0.04


def test_kinematic_refine_keeps_consistent_poses_and_reduces_noise(rng):
    S = _samples("eyeglasses", "train", 6)
    cfg = ModelConfig.default(measured_priors("eyeglasses", S), size="full")
    before, after = [], []
    for s in S:
        r = kinematic_refine(s["cam_from_part"], s["size_m"], {"joint_axis": s["joint_axis"]}, cfg.priors)
        assert rotation_angle_deg(r["cam_from_part"][:, :3, :3], s["cam_from_part"][:, :3, :3]).max() < 1e-4
        np.testing.assert_allclose(r["joint_state"], s["joint_state"], atol=1e-6)
        np.testing.assert_allclose(r["joint_axis"], s["joint_axis"], atol=1e-6)
        T = s["cam_from_part"].copy()
        for k in range(len(T)):
            T[k, :3, :3] = rotation_about_axis(rng.normal(size=3), np.radians(3.0)) @ T[k, :3, :3]
        axis = -(s["joint_axis"] + rng.normal(size=s["joint_axis"].shape) * 0.05)  # flipped sign too
        r = kinematic_refine(T, s["size_m"], {"joint_axis": axis, "joint_pivot": s["joint_pivot"]}, cfg.priors)
        before.append(rotation_angle_deg(T[:, :3, :3], s["cam_from_part"][:, :3, :3]).mean())
        after.append(rotation_angle_deg(r["cam_from_part"][:, :3, :3], s["cam_from_part"][:, :3, :3]).mean())
        # The result is exactly consistent: child = parent turned about the canonical axis.
        R = r["cam_from_part"][:, :3, :3]
        for j in range(cfg.num_joints):
            p, c = cfg.priors.joints[j].parent, cfg.priors.joints[j].child
            a = cfg.priors.joint_axes[j]
            np.testing.assert_allclose(R[c], R[p] @ rotation_about_axis(a, r["joint_state"][j]), atol=1e-9)
            assert r["joint_axis"][j] @ s["joint_axis"][j] > 0.99
        np.testing.assert_allclose(r["joint_pivot"], s["joint_pivot"])
    assert np.mean(after) < 0.9 * np.mean(before)  # measured: 3.0 -> ~2.4 degrees


@pytest.mark.parametrize("flip_axis", [(0.0, 1.0, 0.0), (0.0, 0.0, 1.0)])
def test_half_turn_flips_that_contradict_a_revolute_joint_are_undone(rng, flip_axis):
    from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis
    from ucope.voting import resolve_joint_flips

    cfg = ModelConfig.default(measured_priors("laptop", _samples("laptop", "train", 4)), size="full")
    a = cfg.priors.joint_axes[0]
    Rp = random_rotation(rng)
    Rc = Rp @ rotation_about_axis(a, 1.2)
    T = np.stack([make_transform(Rp, [0, 0, 1.0]), make_transform(Rc, [0, 0.1, 1.0])])
    u = Rp @ a  # the joint heads' axis
    flipped = T.copy()
    flipped[1, :3, :3] = Rc @ rotation_about_axis(np.array(flip_axis), np.pi)
    fixed, which = resolve_joint_flips(flipped, u[None], cfg.priors)
    assert which.tolist() == [False, True]
    np.testing.assert_allclose(fixed[1, :3, :3], Rc, atol=1e-9)
    np.testing.assert_allclose(fixed[1, :3, 3], T[1, :3, 3])
    # Consistent poses, or both parts against the joint heads' axis, are left alone.
    same, which = resolve_joint_flips(T, u[None], cfg.priors)
    assert not which.any() and np.array_equal(same, T)
    _, which = resolve_joint_flips(T, -u[None], cfg.priors)
    assert not which.any()
    # The parent is the flipped one: it is turned back, the child stays.
    bad_parent = T.copy()
    bad_parent[0, :3, :3] = Rp @ rotation_about_axis(np.array(flip_axis), np.pi)
    fixed, which = resolve_joint_flips(bad_parent, u[None], cfg.priors)
    assert which.tolist() == [True, False]
    np.testing.assert_allclose(fixed[0, :3, :3], Rp, atol=1e-9)
    # A half turn of the child about the hinge itself puts the angle outside the limits: undone too.
    about_hinge = T.copy()
    about_hinge[1, :3, :3] = Rc @ rotation_about_axis(a, np.pi)
    fixed, which = resolve_joint_flips(about_hinge, u[None], cfg.priors)
    assert which.tolist() == [False, True]
    np.testing.assert_allclose(fixed[1, :3, :3], Rc, atol=1e-9)


def test_a_front_turned_about_its_hinge_axis_is_turned_back_by_the_temples_placement(rng):
    """Eyeglasses: a front rotated half a turn about y (the hinge axis: its box maps onto itself) has
    the temples in front of it; the placement check turns it back, and leaves correct poses alone."""
    from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis
    from ucope.objects.categories import make_instance
    from ucope.voting import resolve_joint_flips

    cfg = ModelConfig.default(measured_priors("eyeglasses", _samples("eyeglasses", "train", 4)), size="full")
    obj = make_instance("eyeglasses", "test", 3)
    cam_from_object = make_transform(random_rotation(rng), [0.0, 0.0, 0.6])
    T = cam_from_object @ obj.object_from_part(obj.rest_state)
    axis = T[0, :3, :3] @ cfg.priors.joint_axes[:, :, None]  # (J, 3, 1)
    u = axis[..., 0]
    same, which = resolve_joint_flips(T, u, cfg.priors, obj.size_m)
    assert not which.any()
    np.testing.assert_allclose(same, T)
    bad = T.copy()
    bad[0, :3, :3] = T[0, :3, :3] @ rotation_about_axis(np.array([0.0, 1.0, 0.0]), np.pi)
    fixed, which = resolve_joint_flips(bad, u, cfg.priors, obj.size_m)
    assert which.tolist() == [True, False, False]
    np.testing.assert_allclose(fixed[0, :3, :3], T[0, :3, :3], atol=1e-9)


@pytest.mark.parametrize("half_turn", [0, 1, 2])
def test_a_rigid_part_turned_half_a_turn_is_turned_back_by_its_shape(half_turn):
    """laptop_rigid (an L-shaped body): each half turn of the ground-truth pose about one of the part's
    axes is turned back by the shape check. The ground-truth pose is left alone there and on a mug
    (whose half turns a hidden handle can leave undecided), and a y-symmetric bottle is never turned."""
    from ucope.geometry.transforms import rotation_about_axis
    from ucope.voting import resolve_shape_flips

    axis = np.eye(3)[half_turn]
    for category in ("laptop_rigid", "mug", "bottle"):
        cfg = ModelConfig.default(measured_priors(category, _samples(category, "train", 2)), size="full")
        for s in _samples(category, "test", 6):
            T, S = s["cam_from_part"], s["size_m"]
            idx = [np.arange(len(s["points"]))]
            same, which = resolve_shape_flips(T, S, s["points"], idx, cfg.priors)
            assert not which.any() and np.allclose(same, T)
            bad = T.copy()
            bad[0, :3, :3] = T[0, :3, :3] @ rotation_about_axis(axis, np.pi)
            fixed, which = resolve_shape_flips(bad, S, s["points"], idx, cfg.priors)
            if category == "laptop_rigid":
                assert which[0] and rotation_angle_deg(fixed[0, :3, :3], T[0, :3, :3]) < 1e-4
                np.testing.assert_allclose(fixed[0, :3, 3], T[0, :3, 3])
            elif category == "bottle":
                assert not which.any() and np.allclose(fixed, bad)


def test_states_outside_the_limits_are_clamped_and_the_child_moves_with_them():
    from ucope.geometry.kinematics import joint_state_from_poses
    from ucope.priors import CategoryPriors, JointPrior, PartPrior
    from ucope.voting.kinematic import clamp_joint_states

    parts = (PartPrior("base", "none", 0.3, (0.3, 0.1, 0.3)), PartPrior("drawer", "none", 0.3, (0.2, 0.1, 0.25)))
    pri = CategoryPriors("toy", parts, (JointPrior("prismatic", 0, 1, (0, 0, 1), limits=(0.0, 0.2)),), norm_scale_m=0.3)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[1, :3, 3] = [0.0, 0.0, 0.35]
    u = np.array([[0.0, 0.0, 1.0]])
    q = joint_state_from_poses(T[0], T[1], u[0], "prismatic", parts[0].mean_size_m, parts[1].mean_size_m)
    T2, q2, clamped = clamp_joint_states(T, u, np.full((1, 3), np.nan), np.array([q]), pri)
    assert clamped[0] and q2[0] == pytest.approx(0.2)
    assert joint_state_from_poses(T2[0], T2[1], u[0], "prismatic", parts[0].mean_size_m, parts[1].mean_size_m) == pytest.approx(
        0.2
    )
    # a revolute joint voted about the reversed axis: its state is clamped in the canonical sense, the child turned
    rev = CategoryPriors("toy", parts, (JointPrior("revolute", 0, 1, (1, 0, 0), limits=(0.0, 1.0)),), norm_scale_m=0.3)
    from ucope.geometry.transforms import rotation_about_axis

    T = np.tile(np.eye(4), (2, 1, 1))
    T[1, :3, :3] = rotation_about_axis(np.array([1.0, 0, 0]), 1.4)
    T2, q2, clamped = clamp_joint_states(T, -np.eye(3)[:1], np.zeros((1, 3)), np.array([-1.4]), rev)
    assert clamped[0] and q2[0] == pytest.approx(-1.0)
    np.testing.assert_allclose(T2[1, :3, :3], rotation_about_axis(np.array([1.0, 0, 0]), 1.0), atol=1e-9)
    same, q3, clamped = clamp_joint_states(T2, np.eye(3)[:1], np.zeros((1, 3)), np.array([1.0]), rev)
    assert not clamped[0] and np.array_equal(same, T2)


def test_settled_states_are_read_off_the_boxes_and_clamped_into_the_limits():
    """A drawer box moved and resized after voting: its state is its support gap now, not the voted one;
    one pulled out past the upper limit (or pushed in past 0) is brought onto it and moves with it; a
    revolute state is the angle about the voted axis; bad shapes are named."""
    from ucope.errors import InputError
    from ucope.geometry.kinematics import joint_state_from_poses
    from ucope.priors import CategoryPriors, JointPrior, PartPrior
    from ucope.voting import settle_joint_states

    parts = (PartPrior("base", "none", 0.3, (0.3, 0.1, 0.3)), PartPrior("drawer", "none", 0.3, (0.2, 0.1, 0.25)))
    pri = CategoryPriors(
        "toy", parts, (JointPrior("prismatic", 0, 1, (0, 0, 1), limits=(0.0, 0.2), zero_offset_m=0.01),), norm_scale_m=0.3
    )
    R = rotation_about_axis(np.array([0.0, 1.0, 0.0]), 0.7)  # turned about the camera's y: the axis is R e_z
    u = (R @ np.array([0.0, 0.0, 1.0]))[None]
    S = np.array([[0.3, 0.1, 0.3], [0.2, 0.1, 0.27]])
    for local_z, want in ((0.1, None), (0.3, 0.2), (-0.2, 0.0)):
        T = np.tile(np.eye(4), (2, 1, 1))
        T[:, :3, :3] = R
        T[:, :3, 3] = [0.1, -0.2, 1.0]
        T[1, :3, 3] += R @ np.array([0.0, 0.05, local_z])
        plain = 0.5 * 0.27 + local_z - 0.5 * 0.3 - 0.01  # support gap along the axis less the zero offset
        T2, q, clamped = settle_joint_states(T, S, u, np.zeros((1, 3)), pri)
        if want is None:
            assert not clamped[0] and q[0] == pytest.approx(plain) and np.array_equal(T2, T)
        else:
            assert clamped[0] and q[0] == pytest.approx(want)
            np.testing.assert_allclose(T2[1, :3, 3] - T[1, :3, 3], (want - plain) * u[0], atol=1e-12)
            assert joint_state_from_poses(T2[0], T2[1], u[0], "prismatic", S[0], S[1], 0.01) == pytest.approx(want)
    rev = CategoryPriors("toy", parts, (JointPrior("revolute", 0, 1, (1, 0, 0), limits=(0.0, 1.0)),), norm_scale_m=0.3)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[1, :3, :3] = rotation_about_axis(np.array([1.0, 0, 0]), 0.6)
    _, q, clamped = settle_joint_states(T, S, np.eye(3)[:1], np.zeros((1, 3)), rev)
    assert not clamped[0] and q[0] == pytest.approx(0.6)
    with pytest.raises(InputError, match="joint_axis"):
        settle_joint_states(T, S, np.eye(3)[:2], np.zeros((1, 3)), rev)
    with pytest.raises(InputError, match="finite"):
        settle_joint_states(T, np.full((2, 3), np.nan), np.eye(3)[:1], np.zeros((1, 3)), rev)


def test_a_part_tilted_off_its_upright_is_carried_from_its_neighbour_through_the_joint():
    """Laptop: a base voted on end (turned 70 degrees about the hinge line) is re-placed from the lid:
    consistent with it through the joint, within the limits, its hinge where the lid's is, nearer the
    truth; true poses are left alone."""
    from ucope.geometry.kinematics import revolute_angle
    from ucope.voting import carry_upright, upright_angles_deg

    S = _samples("laptop", "train", 12)
    pri = measured_priors("laptop", S)
    jp = pri.joints[0]
    a = jp.axis
    moved = 0
    for s in S:
        T, size = s["cam_from_part"], s["size_m"]
        same, carried = carry_upright(T, size, pri)
        assert not carried.any() and np.array_equal(same, T)  # the training views are inside the cone
        u = T[0, :3, :3] @ a
        turn = rotation_about_axis(u, np.radians(70.0))
        bad = T.copy()
        bad[0, :3, :3] = turn @ T[0, :3, :3]
        bad[0, :3, 3] = turn @ (T[0, :3, 3] - s["joint_pivot"][0]) + s["joint_pivot"][0]
        if not upright_angles_deg(bad, pri)[0] > pri.parts[0].upright_cone_deg + 10.0:
            continue  # turned within the cone: nothing to do
        moved += 1
        fixed, carried = carry_upright(bad, size, pri)
        assert carried.tolist() == [True, False]
        np.testing.assert_array_equal(fixed[1], bad[1])  # the lid is kept
        q = revolute_angle(fixed[0, :3, :3].T @ fixed[1, :3, :3], a)
        np.testing.assert_allclose(fixed[1, :3, :3], fixed[0, :3, :3] @ rotation_about_axis(a, q), atol=1e-9)
        assert jp.limits[0] - 1e-9 <= q <= jp.limits[1] + 1e-9
        assert upright_angles_deg(fixed, pri)[0] <= pri.parts[0].upright_cone_deg + 10.0
        offsets = (jp.pivot_in_parent, jp.pivot_in_child)
        feet = [fixed[k, :3, :3] @ (np.asarray(f) * size[k]) + fixed[k, :3, 3] for k, f in enumerate(offsets)]
        np.testing.assert_allclose(feet[0], feet[1], atol=1e-9)
        err_bad = rotation_angle_deg(bad[0, :3, :3], T[0, :3, :3])
        err_fixed = rotation_angle_deg(fixed[0, :3, :3], T[0, :3, :3])
        assert err_fixed < 0.6 * err_bad
        assert np.linalg.norm(fixed[0, :3, 3] - T[0, :3, 3]) < np.linalg.norm(bad[0, :3, 3] - T[0, :3, 3])
    assert moved >= 6


def test_carrying_needs_a_plausible_neighbour_and_is_off_for_rigid_objects(rng):
    from ucope.geometry.transforms import make_transform
    from ucope.voting import carry_upright

    S = _samples("drawer", "train", 2)
    pri = measured_priors("drawer", S)
    s = S[0]
    T = s["cam_from_part"].copy()
    flip = rotation_about_axis(np.array([1.0, 0.0, 0.0]), np.pi)  # everything upside down
    T[:, :3, :3] = flip @ T[:, :3, :3]
    fixed, carried = carry_upright(T, s["size_m"], pri)
    assert not carried.any() and np.array_equal(fixed, T)  # no plausible neighbour to carry from
    # one drawer upside down: carried from the cabinet (prismatic: same rotation, its voted centre kept)
    T = s["cam_from_part"].copy()
    T[2, :3, :3] = flip @ T[2, :3, :3]
    fixed, carried = carry_upright(T, s["size_m"], pri)
    assert carried.tolist() == [False, False, True, False]
    np.testing.assert_allclose(fixed[2, :3, :3], s["cam_from_part"][0, :3, :3], atol=1e-12)
    np.testing.assert_array_equal(fixed[2, :3, 3], T[2, :3, 3])
    rigid = measured_priors("mug", _samples("mug", "train", 3))
    one = make_transform(flip, np.array([0.0, 0.0, 0.5]))[None]
    out, carried = carry_upright(one, np.ones((1, 3)), rigid)
    assert not carried.any() and np.array_equal(out, one)


def test_a_part_turning_about_its_upright_axis_keeps_the_state_nearest_its_vote():
    """Eyeglasses: a temple's hinge is its upright axis, so every state is equally upright; a temple
    voted tipped over (100 degrees about its z) comes back at the state nearest its voted rotation."""
    from ucope.geometry.kinematics import revolute_angle
    from ucope.voting import carry_upright

    S = _samples("eyeglasses", "train", 8)
    pri = measured_priors("eyeglasses", S)
    jp = pri.joints[0]
    assert pri.parts[jp.child].upright_axis == 1 and abs(jp.axis[1]) > 0.99  # hinge along y
    s = S[0]
    T = s["cam_from_part"].copy()
    q0 = revolute_angle(T[0, :3, :3].T @ T[jp.child, :3, :3], jp.axis)
    T[jp.child, :3, :3] = T[jp.child, :3, :3] @ rotation_about_axis(np.array([0.0, 0.0, 1.0]), np.radians(100.0))
    fixed, carried = carry_upright(T, s["size_m"], pri)
    assert carried.tolist() == [False, True, False]
    q = revolute_angle(fixed[0, :3, :3].T @ fixed[jp.child, :3, :3], jp.axis)
    step = (jp.limits[1] - jp.limits[0]) / 180
    assert abs(q - np.clip(q0, *jp.limits)) <= step


def _cabinet_priors(spread=(0.0, 0.05, 0.1), axis=(0, 0, 1)):
    from ucope.priors import CategoryPriors, JointPrior, PartPrior

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
    from ucope.geometry.kinematics import joint_state_from_poses
    from ucope.voting import place_prismatic_children

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
    from ucope.errors import InputError
    from ucope.priors import JointPrior
    from ucope.voting import place_prismatic_children

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
    from ucope.voting import slide_to_fronts

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
    from ucope.voting import slide_to_fronts

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
    from ucope.voting import slide_to_fronts

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
    from ucope.voting import slide_to_fronts

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
    from ucope.priors import CategoryPriors, JointPrior
    from ucope.voting import slide_to_fronts

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
    from ucope.errors import InputError
    from ucope.voting import slide_to_fronts

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


def _door_priors(ratio=(1.0, 0.86, 0.2), spread=(0.004, 0.02, 0.2)):
    """A body and a door hinged along x at the body's front bottom edge (the door's bottom edge)."""
    from ucope.priors import CategoryPriors, JointPrior, PartPrior

    return CategoryPriors(
        category="cabinet_door",
        parts=(PartPrior("body", "none", 1.0, (0.6, 0.8, 0.6)), PartPrior("door", "none", 1.0, (0.6, 0.7, 0.1))),
        joints=(
            JointPrior(
                "revolute",
                0,
                1,
                (1, 0, 0),
                limits=(0.0, 1.57),
                child_size_ratio=ratio,
                child_size_spread=spread,
                pivot_in_parent=(0.0, -0.5, 0.5),
                pivot_in_child=(0.0, -0.5, -0.5),
            ),
        ),
    )


def test_a_hidden_door_takes_its_width_and_height_from_its_measured_body():
    """The body's extents were measured (a countertop cabinet, 0.5 m tall); the door, voted 0.8 m tall, gets
    0.86 x the body's height and its width, and hangs from the hinge where the body puts it; its depth (a
    ratio that varies) and its rotation stay. A plausible door (within 15 %) keeps its extents."""
    from ucope.voting import carry_child_sizes

    pri = _door_priors()
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
    from ucope.errors import InputError
    from ucope.priors import JointPrior
    from ucope.voting import carry_child_sizes

    pri = _door_priors()
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


def _sized_cabinet_priors(ratio=(0.97, 0.27, 0.95), spread=(0.05, 0.18, 0.047), axis=(0, 0, 1), kind="prismatic"):
    """A cabinet and one drawer (or door) whose box is ``ratio`` times the cabinet's, varying by ``spread``."""
    from ucope.priors import CategoryPriors, JointPrior, PartPrior

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
    from ucope.priors import CategoryPriors, JointPrior, PartPrior

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
    from ucope.voting import hold_prismatic_children

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
    from ucope.voting import hold_prismatic_children

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
    from ucope.errors import InputError
    from ucope.voting import hold_prismatic_children

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
    from ucope.voting import carry_prismatic_depths

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
    from ucope.priors import CategoryPriors, JointPrior
    from ucope.voting import carry_prismatic_depths

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
    from ucope.errors import InputError
    from ucope.voting import carry_prismatic_depths

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


def _chest(first_gap_spread=0.06, gap_spread=0.04):
    """A cabinet (part 0, 0.6 x 1.0 x 0.5) with three drawers stacked top down (parts 1-3) along its y."""
    from ucope.priors import CategoryPriors, JointPrior, PartPrior, StackPrior

    parts = (PartPrior("cabinet", "none", 0.8, (0.6, 1.0, 0.5)),) + tuple(
        PartPrior(f"drawer{k}", "none", 0.4, (0.55, 0.25, 0.45)) for k in (1, 2, 3)
    )
    joints = tuple(JointPrior("prismatic", 0, k, (0, 0, 1), limits=(0.0, 0.3)) for k in (1, 2, 3))
    stack = StackPrior(0, 1, (1, 2, 3), first_gap=0.03, gap=0.005, first_gap_spread=first_gap_spread, gap_spread=gap_spread)
    return CategoryPriors("chest", parts, joints, norm_scale_m=0.5, stacks=(stack,))


def _chest_scene(seed):
    """Voted poses: the drawers (0.2 / 0.25 / 0.3 m tall) at 0.55 / 0.3 / 0 m up the cabinet's y, pulled out
    0.1 / 0.02 / 0.2 m, under one random rotation."""
    rng = np.random.default_rng(seed)
    R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, :3] = R
    T[0, :3, 3] = rng.normal(size=3) + [0, 0, 3]
    local = np.array([[0, 0, 0], [0.0, 0.55, 0.1], [0.0, 0.3, 0.02], [0.0, 0.0, 0.2]])
    T[1:, :3, 3] = T[0, :3, 3] + local[1:] @ R.T
    S = np.array([[0.6, 1.0, 0.5], [0.55, 0.2, 0.45], [0.55, 0.25, 0.45], [0.55, 0.3, 0.45]])
    return T, S, R


def _labels(counts):
    return np.repeat(np.arange(len(counts)), counts)


def _local_y(T, R):
    return [float(R[:, 1] @ (T[k, :3, 3] - T[0, :3, 3])) for k in range(4)]


def test_hidden_drawers_are_stacked_under_a_seen_one_above_them():
    """The top drawer is seen (kept where voted, 0.55 m up); the middle and bottom ones, hidden, hang under it
    0.005 x 1 m apart: each one's top face 5 mm under the bottom face of the one above. Only their heights
    change; the slide (z), left-right (x), rotations and sizes stay."""
    from ucope.voting import stack_hidden_children

    pri = _chest()
    for seed in range(3):
        T, S, R = _chest_scene(seed)
        got, S2, moved = stack_hidden_children(T, S, _labels([500, 200, 3, 0]), pri)
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
    from ucope.voting import stack_hidden_children

    pri = _chest()
    T, S, R = _chest_scene(0)
    y = _local_y(stack_hidden_children(T, S, _labels([500, 0, 0, 50]), pri)[0], R)
    assert y[3] == pytest.approx(0.0, abs=1e-12)
    assert y[2] == pytest.approx(0.15 + 0.005 + 0.125) and y[1] == pytest.approx(y[2] + 0.125 + 0.005 + 0.1)
    y = _local_y(stack_hidden_children(T, S, _labels([500, 0, 0, 0]), pri)[0], R)
    assert y[1] == pytest.approx(0.5 - 0.03 - 0.1)
    assert y[2] == pytest.approx(y[1] - 0.1 - 0.005 - 0.125) and y[3] == pytest.approx(y[2] - 0.125 - 0.005 - 0.15)
    # the middle one hidden between two seen ones hangs under the top one
    y = _local_y(stack_hidden_children(T, S, _labels([500, 40, 0, 40]), pri)[0], R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125) and y[3] == pytest.approx(0.0, abs=1e-12)
    same, _, moved = stack_hidden_children(T, S, _labels([500, 40, 40, 40]), pri)
    assert np.array_equal(same, T) and not moved.any()


def test_stacking_leaves_loose_stacks_doubted_points_and_stackless_priors_alone():
    from ucope.voting import stack_hidden_children

    T, S, R = _chest_scene(1)
    lab = _labels([500, 0, 0, 0])
    for pri in (_chest(first_gap_spread=0.2), _chest(gap_spread=0.15), _cabinet_priors()):
        if pri.num_parts != 4:  # a category without stacks
            T2, S2 = T[:2], S[:2]
            same, _, moved = stack_hidden_children(T2, S2, np.zeros(10, int), pri)
            assert np.array_equal(same, T2) and not moved.any()
            continue
        same, _, moved = stack_hidden_children(T, S, lab, pri)
        assert np.array_equal(same, T) and not moved.any()
    # the middle drawer's 40 points doubted by the segmentation (confidence 0.3): it counts as hidden
    lab = _labels([500, 40, 40, 40])
    conf = np.where(lab == 2, 0.3, 0.99)
    y = _local_y(stack_hidden_children(T, S, lab, _chest(), confidence=conf)[0], R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125)


def _sized_chest():
    """:func:`_chest` with size ratios: each drawer 0.95 of the cabinet's width, 0.25 of its height, 0.9 of its depth."""
    from dataclasses import replace

    pri = _chest()
    joints = tuple(replace(jp, child_size_ratio=(0.95, 0.25, 0.9), child_size_spread=(0.05, 0.15, 0.05)) for jp in pri.joints)
    return replace(pri, joints=joints)


def test_hidden_drawers_take_their_width_and_height_from_the_cabinet_before_they_are_stacked():
    """With size ratios in the priors, the hidden middle and bottom drawers become 0.95 x 0.6 m wide and 0.25 x 1 m
    tall (their depth, along the slide, stays), then hang under the seen top drawer by those heights; the seen one
    keeps its size. Without ``size_from_parent`` the voted sizes stay."""
    from ucope.voting import stack_hidden_children

    pri = _sized_chest()
    T, S, R = _chest_scene(2)
    got, S2, _ = stack_hidden_children(T, S, _labels([500, 200, 3, 0]), pri)
    np.testing.assert_array_equal(S2[:2], S[:2])
    np.testing.assert_allclose(S2[2:], [[0.57, 0.25, 0.45], [0.57, 0.25, 0.45]])
    y = _local_y(got, R)
    assert y[2] == pytest.approx(0.55 - 0.1 - 0.005 - 0.125)
    assert y[3] == pytest.approx(y[2] - 0.125 - 0.005 - 0.125)
    _, S3, _ = stack_hidden_children(T, S, _labels([500, 200, 3, 0]), pri, size_from_parent=False)
    np.testing.assert_array_equal(S3, S)


def test_stacking_names_bad_input():
    from ucope.errors import InputError
    from ucope.voting import stack_hidden_children

    pri = _chest()
    T, S, _ = _chest_scene(0)
    lab = _labels([10, 10, 10, 10])
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


def test_an_upside_down_rigid_part_is_turned_over_and_placed_from_its_points():
    """laptop_rigid: true poses are left alone; a pose turned upside down (a half turn about the body's x or
    z) with its centre voted off is turned back onto its upright and its centre placed from its points: the
    half turn is undone exactly (the shape fit picks it) and the centre moves nearer the truth. A negative
    margin is named."""
    from ucope.errors import InputError
    from ucope.voting import turn_upright

    S = _samples("laptop_rigid", "train", 12)
    pri = measured_priors("laptop_rigid", S)
    exact = tried = 0
    for s in S:
        T, size, pts = s["cam_from_part"], s["size_m"], np.asarray(s["points"], np.float64)
        idx = [np.flatnonzero(np.asarray(s["part_labels"]) == 0)]
        same, turned = turn_upright(T, size, pts, idx, pri)
        assert not turned.any() and np.array_equal(same, T)
        for flip in (np.diag([-1.0, -1.0, 1.0]), np.diag([1.0, -1.0, -1.0])):
            bad = T.copy()
            bad[0, :3, :3] = T[0, :3, :3] @ flip
            bad[0, :3, 3] = T[0, :3, 3] + 0.4 * np.linalg.norm(size[0]) * bad[0, :3, 1]  # voted off along its own up
            fixed, turned = turn_upright(bad, size, pts, idx, pri)
            tried += 1
            assert turned.tolist() == [True]
            assert upright_angle_deg(fixed[0], pri) <= pri.parts[0].upright_cone_deg + 10.0
            exact += rotation_angle_deg(fixed[0, :3, :3], T[0, :3, :3]) < 1e-3
            moved = np.linalg.norm(fixed[0, :3, 3] - T[0, :3, 3])
            assert moved < 0.5 * np.linalg.norm(bad[0, :3, 3] - T[0, :3, 3])
    assert exact == tried
    s0 = S[0]
    with pytest.raises(InputError, match="margin_deg"):
        turn_upright(s0["cam_from_part"], s0["size_m"], s0["points"], [np.arange(10)], pri, margin_deg=-1.0)
    with pytest.raises(InputError, match=r"\(1, 4, 4\)"):
        turn_upright(s0["cam_from_part"][0], s0["size_m"], s0["points"], [np.arange(10)], pri)
    nan_points = np.array(s0["points"], np.float64)
    nan_points[3] = np.nan
    with pytest.raises(InputError, match="finite"):
        turn_upright(s0["cam_from_part"], s0["size_m"], nan_points, [np.arange(10)], pri)
    with pytest.raises(InputError, match="positive"):
        turn_upright(s0["cam_from_part"], np.zeros_like(s0["size_m"]), s0["points"], [np.arange(10)], pri)


def upright_angle_deg(T, pri):
    p = pri.parts[0]
    return float(np.degrees(np.arccos(np.clip(T[:3, p.upright_axis] @ np.asarray(p.upright_in_cam), -1.0, 1.0))))


def _open_door_scene(seed=0, state=0.6, voted_off=0.35, n=400):
    """A cabinet seen from the front (2.5 m away) with its door open by ``state`` rad, the door's front face
    sampled (``n`` points, 1 mm noise), and the door voted ``voted_off`` rad further open about its hinge."""
    pri = _door_priors()
    rng = np.random.default_rng(seed)
    S = np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.05]])
    R0 = rotation_about_axis(np.array([0.0, 1.0, 0.0]), np.pi + 0.3) @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), 0.4)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[0, :3, :3], T[0, :3, 3] = R0, [0.05, 0.3, 2.5]
    hinge = T[0, :3, 3] + R0 @ (np.array([0.0, -0.4, 0.3]))  # the body's front bottom edge
    axis = R0[:, 0]

    def door(q):
        D = np.eye(4)
        D[:3, :3] = R0 @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), q)
        D[:3, 3] = hinge - D[:3, :3] @ np.array([0.0, -0.35, -0.025])
        return D

    T[1] = door(state)
    face = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.35, 0.35, n), np.full(n, 0.025)])
    pts = face @ T[1, :3, :3].T + T[1, :3, 3] + rng.normal(0.0, 0.001, (n, 3))
    voted = T.copy()
    voted[1] = door(state + voted_off)
    return pri, T, voted, S, axis, pts, np.ones(n, dtype=np.int64)


def test_a_door_voted_too_far_open_turns_back_onto_its_points():
    """A door voted 20 degrees further open (or closed) than its points say turns back to within a degree, its
    front face on its points; the body stays, and so does a door voted right."""
    from ucope.geometry.kinematics import joint_state_from_poses
    from ucope.voting import turn_thin_children

    for off in (0.35, -0.35):
        pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=off)
        got, turned = turn_thin_children(voted, S, axis[None], pts, lab, pri)
        assert rotation_angle_deg(got[1, :3, :3], T[1, :3, :3]) < 1.0
        assert abs(np.degrees(joint_state_from_poses(got[0], got[1], axis, "revolute")) - np.degrees(0.6)) < 1.0
        assert abs(np.degrees(turned[1]) + np.degrees(off)) < 1.0 and turned[0] == 0.0
        normal = got[1, :3, :3][:, 2]
        assert abs(np.median((pts - got[1, :3, 3]) @ normal) - 0.025) < 1e-3  # the front face on the points
        # turned about its points, not the voted hinge: the centre lands within 5 % of the door's diagonal
        assert np.linalg.norm(got[1, :3, 3] - T[1, :3, 3]) < min(
            0.05 * np.linalg.norm(S[1]), np.linalg.norm(voted[1, :3, 3] - T[1, :3, 3])
        )
        np.testing.assert_array_equal(got[0], voted[0])
    pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=0.01)  # under TURN_MIN_DEG
    got, turned = turn_thin_children(voted, S, axis[None], pts, lab, pri)
    assert not turned.any() and np.array_equal(got, voted)


def test_turning_leaves_few_short_or_round_point_sets_thick_children_and_slides_alone():
    from ucope.voting import turn_thin_children

    pri, T, voted, S, axis, pts, lab = _open_door_scene()
    cases = {
        "few points": (pts[:40], lab[:40], S, pri),
        "a short strip": (pts[np.abs((pts - T[1, :3, 3]) @ T[1, :3, 1]) < 0.05], None, S, pri),
        "a thick child": (pts, lab, np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.4]]), pri),
        "a blade, thin along its hinge": (pts, lab, np.array([[0.6, 0.8, 0.6], [0.02, 0.7, 0.05]]), pri),
        "a slide": (pts, lab, S, _door_priors().__class__(**{**_door_priors().__dict__, "joints": (
            _door_priors().joints[0].__class__("prismatic", 0, 1, (0, 0, 1)),)})),
    }  # fmt: skip
    for name, (p, lb, size, priors) in cases.items():
        lb = np.ones(len(p), dtype=np.int64) if lb is None else lb
        got, turned = turn_thin_children(voted, size, axis[None], p, lb, priors)
        assert not turned.any() and np.array_equal(got, voted), name
    for lb in (np.zeros(len(pts), dtype=np.int64), np.full(len(pts), -1)):  # no point of the door
        got, turned = turn_thin_children(voted, S, axis[None], pts, lb, pri)
        assert not turned.any() and np.array_equal(got, voted)
    # points seen edge-on along the hinge form a blob, not a line: a door seen from straight above
    rng = np.random.default_rng(1)
    blob = T[1, :3, 3] + rng.normal(0.0, 0.05, (300, 3))
    got, turned = turn_thin_children(voted, S, axis[None], blob, np.ones(300, dtype=np.int64), pri)
    assert not turned.any()


def test_a_turn_that_moves_the_points_out_of_the_box_is_undone():
    """A strip of the body's bottom mislabelled as the door, joined to it at the hinge and longer than it, draws
    the line: the turn that follows it leaves most of the points outside the box, and is undone."""
    from ucope.voting import turn_thin_children

    pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=0.0)
    rng = np.random.default_rng(2)
    bottom = np.column_stack([rng.uniform(-0.3, 0.3, 300), np.full(300, -0.4), rng.uniform(-0.5, 0.3, 300)])
    strip = bottom @ T[0, :3, :3].T + T[0, :3, 3]
    both = np.concatenate([pts, strip])
    labels = np.ones(len(both), dtype=np.int64)
    free, turned_free = turn_thin_children(voted, S, axis[None], both, labels, pri, check_tol=1e9)
    assert abs(turned_free[1]) > np.radians(10.0)  # without the check the strip turns the door
    got, turned = turn_thin_children(voted, S, axis[None], both, labels, pri)
    assert not turned.any() and np.array_equal(got, voted)


def test_turning_names_bad_input():
    from ucope.errors import InputError
    from ucope.voting import turn_thin_children

    pri, T, voted, S, axis, pts, lab = _open_door_scene()
    with pytest.raises(InputError, match="joint_axis"):
        turn_thin_children(voted, S, np.zeros((2, 3)), pts, lab, pri)
    with pytest.raises(InputError, match="zero-length"):
        turn_thin_children(voted, S, np.zeros((1, 3)), pts, lab, pri)
    with pytest.raises(InputError, match="camera"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, camera=[0.0, np.nan, 0.0])
    with pytest.raises(InputError, match="thin_ratio"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, thin_ratio=0.0)
    with pytest.raises(InputError, match="min_elongation"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, min_elongation=0.5)
    with pytest.raises(InputError, match="check_tol"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, check_tol=-1.0)
    with pytest.raises(InputError, match="confidence"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, confidence=np.ones(3))
    with pytest.raises(InputError, match="min_confidence"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, min_confidence=1.5)
    with pytest.raises(InputError, match="finite"):
        turn_thin_children(voted, S, axis[None], np.full_like(pts, np.nan), lab, pri)


def _turned_round(T, u, piv, b):
    """The whole object turned by a half turn about the cabinet's box axis ``b`` through its centre."""
    Rf = rotation_about_axis(T[0, :3, b], np.pi)
    c = T[0, :3, 3]
    T2 = T.copy()
    T2[:, :3, :3] = Rf @ T[:, :3, :3]
    T2[:, :3, 3] = c + (T[:, :3, 3] - c) @ Rf.T
    return T2, u @ Rf.T, c + (piv - c) @ Rf.T


def test_a_cabinet_turned_round_is_turned_back_by_its_drawers():
    """Real drawer views at their true poses and labels, the camera at the origin: nothing is turned. The whole
    object turned round about the cabinet's upright axis is turned back exactly wherever the drawers decide it:
    their points behind the cabinet's centre (views that show them), or a front facing the camera with no drawer
    on it (views from behind that hide them). Both kinds occur among the views."""
    from ucope.voting import resolve_front_flips

    S = _samples("drawer", "test", 16)
    pri = measured_priors("drawer", S)
    assert pri.parts[0].upright_axis == 1
    kinds = {"shown": 0, "hidden": 0}
    for s in S:
        T, pts, lab = np.asarray(s["cam_from_part"]), np.asarray(s["points"], np.float64), np.asarray(s["part_labels"])
        u, piv = np.asarray(s["joint_axis"]), np.asarray(s["joint_pivot"])
        same, u2, piv2, flipped = resolve_front_flips(T, u, piv, pts, lab, pri)
        assert not flipped.any()
        np.testing.assert_array_equal(same, T)
        np.testing.assert_array_equal(u2, u)
        bad, ub, pb = _turned_round(T, u, piv, 1)
        fixed, uf, pf, flipped = resolve_front_flips(bad, ub, pb, pts, lab, pri)
        drawers = int(np.isin(lab, [1, 2, 3]).sum())
        if drawers >= 30:
            kinds["shown"] += 1
        cam = T[0, :3, :3].T @ -T[0, :3, 3]  # the camera in the true cabinet frame: behind it, within 45 degrees
        if drawers < 0.02 * len(lab) and -cam[2] > abs(cam[0]):
            kinds["hidden"] += 1
        elif drawers < 30:
            continue  # neither rule decides: a side view with the drawers hidden
        assert flipped.all()
        np.testing.assert_allclose(fixed, T, atol=1e-9)
        np.testing.assert_allclose(uf, u, atol=1e-9)
        np.testing.assert_allclose(pf, piv, atol=1e-9)
    assert kinds["shown"] >= 5 and kinds["hidden"] >= 1, kinds


def test_turning_round_leaves_side_views_doubted_points_and_revolute_joints_alone():
    """A chest (no upright prior: it turns about its stack's axis) seen from the front with its drawers' points
    on it is left alone; the same drawers behind its centre turn it round about y, and their joint axes and
    pivots with it. Drawers doubted by the segmentation do not count; a front seen from the side (60 degrees off
    its normal) is not taken as bare; a model with revolute joints only is never turned."""
    from ucope.voting import resolve_front_flips

    pri = _chest()
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, 3] = [0.0, 0.0, 3.0]  # the camera 3 m in front... of the cabinet's -z face: R turns it round
    T[:, :3, :3] = np.diag([-1.0, 1.0, -1.0])  # the cabinet's +z (its front) towards the camera
    u, piv = np.tile([0.0, 0.0, -1.0], (3, 1)), np.zeros((3, 3))
    rng = np.random.default_rng(0)
    front = np.column_stack([rng.uniform(-0.3, 0.3, 300), rng.uniform(-0.5, 0.5, 300), np.full(300, 2.75)])
    body = np.column_stack([rng.uniform(-0.3, 0.3, 300), np.full(300, 0.5), rng.uniform(2.75, 3.25, 300)])
    lab = np.r_[np.zeros(300, int), rng.integers(1, 4, 300)]
    pts = np.r_[body, front]
    same, _, _, flipped = resolve_front_flips(T, u, piv, pts, lab, pri)
    assert not flipped.any() and np.array_equal(same, T)
    back = front.copy()
    back[:, 2] = 3.25  # the drawers' points behind the cabinet's centre
    out, u2, piv2, flipped = resolve_front_flips(T, u, piv + [0.0, 0.0, 3.1], np.r_[body, back], lab, pri)
    assert flipped.all()
    np.testing.assert_allclose(out[0, :3, :3], np.eye(3), atol=1e-12)  # turned about y
    np.testing.assert_allclose(u2, np.tile([0.0, 0.0, 1.0], (3, 1)), atol=1e-12)
    np.testing.assert_allclose(piv2, np.tile([0.0, 0.0, 2.9], (3, 1)), atol=1e-12)
    conf = np.r_[np.ones(300), np.full(300, 0.2)]  # the drawers' points doubted: the front looks bare
    assert resolve_front_flips(T, u, piv, np.r_[body, back], lab, pri, confidence=conf)[3].all()
    side = T.copy()
    side[:, :3, :3] = rotation_about_axis([0.0, 1.0, 0.0], np.radians(120.0))  # the front 60 degrees off the camera
    assert not resolve_front_flips(side, u, piv, body, np.zeros(300, int), pri)[3].any()
    assert resolve_front_flips(T, u, piv, body, np.zeros(300, int), pri)[3].all()  # faced and bare
    door = _door_priors()
    Td = np.tile(np.eye(4), (2, 1, 1))
    Td[:, 2, 3] = 2.0
    out, *_, flipped = resolve_front_flips(Td, np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 3)), body, np.ones(300, int), door)
    assert not flipped.any() and np.array_equal(out, Td)


def test_turning_round_names_bad_input():
    from ucope.errors import InputError
    from ucope.voting import resolve_front_flips

    pri = _chest()
    T, S, _ = _chest_scene(0)
    u, piv = np.tile([0.0, 0.0, 1.0], (3, 1)), np.zeros((3, 3))
    pts, lab = np.zeros((40, 3)), _labels([10, 10, 10, 10])
    with pytest.raises(InputError, match="cam_from_part"):
        resolve_front_flips(T[:3], u, piv, pts, lab, pri)
    with pytest.raises(InputError, match="finite"):
        resolve_front_flips(T, u * np.nan, piv, pts, lab, pri)
    with pytest.raises(InputError, match="points"):
        resolve_front_flips(T, u, piv, pts[:, :2], lab, pri)
    with pytest.raises(InputError, match="labels"):
        resolve_front_flips(T, u, piv, pts, lab.astype(float), pri)
    with pytest.raises(InputError, match="camera"):
        resolve_front_flips(T, u, piv, pts, lab, pri, camera=(0.0, np.inf, 0.0))
    with pytest.raises(InputError, match="confidence"):
        resolve_front_flips(T, u, piv, pts, lab, pri, confidence=np.ones(3))
    with pytest.raises(InputError, match="min_share"):
        resolve_front_flips(T, u, piv, pts, lab, pri, min_share=1.5)
    with pytest.raises(InputError, match="max_deg"):
        resolve_front_flips(T, u, piv, pts, lab, pri, max_deg=120.0)
    with pytest.raises(InputError, match="min_confidence"):
        resolve_front_flips(T, u, piv, pts, lab, pri, min_confidence=2.0)


def _seat_scene(door_points, body_points=3000, q=0.6):
    """A body and a door open by ``q`` rad hinged at the body's front bottom edge (``_door_priors``), the door
    voted 0.3 m along its hinge and 0.2 m out in front; labels: so many points of each."""
    rng = np.random.default_rng(3)
    R0 = rotation_about_axis(rng.normal(size=3), 0.8)
    S = np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.05]])
    T = np.tile(np.eye(4), (2, 1, 1))
    T[0, :3, :3], T[0, :3, 3] = R0, [0.1, -0.2, 2.4]
    T[1, :3, :3] = R0 @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), q)
    hinge = R0 @ (np.array([0.0, -0.5, 0.5]) * S[0]) + T[0, :3, 3]
    T[1, :3, 3] = hinge - T[1, :3, :3] @ (np.array([0.0, -0.5, -0.5]) * S[1])
    voted = T.copy()
    voted[1, :3, 3] += R0 @ np.array([0.3, 0.0, 0.2])
    labels = np.repeat([0, 1, -1], [body_points, door_points, 50])
    return T, voted, S, labels, hinge


def test_a_door_showing_few_points_is_seated_back_on_its_hinge():
    """A door with 2 % of the points, voted off along its hinge and in front of the body: its centre goes where
    its hinge point meets the body's (a plain reference from the pivot places), the joint's pivot to that point;
    its rotation, the body and the sizes stay. A door with half the points, or one voted less than ``min_gap`` of
    its diagonal off, keeps its voted centre."""
    from ucope.voting import seat_weak_parts

    pri = _door_priors()
    T, voted, S, labels, hinge = _seat_scene(door_points=60)
    piv = np.array([[9.0, 9.0, 9.0]])
    got, got_piv, seated = seat_weak_parts(voted, S, piv, labels, pri)
    assert seated.tolist() == [False, True]
    np.testing.assert_allclose(got[1], T[1], atol=1e-12)  # the scene's door sits exactly at the pivot places
    np.testing.assert_allclose(got_piv[0], hinge, atol=1e-12)
    np.testing.assert_array_equal(got[0], voted[0])
    np.testing.assert_array_equal(got[1, :3, :3], voted[1, :3, :3])
    assert np.array_equal(piv, [[9.0, 9.0, 9.0]])  # the input is not changed
    _, voted_strong, _, strong_labels, _ = _seat_scene(door_points=3000)
    same, same_piv, seated = seat_weak_parts(voted_strong, S, piv, strong_labels, pri)
    assert not seated.any() and np.array_equal(same, voted_strong) and np.array_equal(same_piv, piv)
    near = T.copy()  # 5 cm off, under 0.2 of the door's 0.92 m diagonal: the vote stands
    near[1, :3, 3] += T[0, :3, :3] @ np.array([0.05, 0.0, 0.0])
    same, _, seated = seat_weak_parts(near, S, piv, labels, pri)
    assert not seated.any() and np.array_equal(same, near)
    _, seated = seat_weak_parts(near, S, piv, labels, pri, min_gap=0.0)[1:]
    assert seated.tolist() == [False, True]


def test_seating_takes_a_weak_root_from_its_child_and_leaves_shared_views_prismatic_and_pivotless_joints_alone():
    from ucope.priors import CategoryPriors, JointPrior
    from ucope.voting import seat_weak_parts

    pri = _door_priors()
    T, _, S, _, hinge = _seat_scene(door_points=60)
    voted = T.copy()
    voted[0, :3, 3] += [0.2, -0.1, 0.3]  # the body (the root of two parts) voted off, the door seen well
    got, got_piv, seated = seat_weak_parts(voted, S, np.zeros((1, 3)), np.repeat([0, 1], [40, 3000]), pri)
    assert seated.tolist() == [True, False]
    np.testing.assert_allclose(got[0], T[0], atol=1e-12)
    np.testing.assert_allclose(got_piv[0], hinge, atol=1e-12)
    shared = np.repeat([0, 1, -1], [2400, 600, 3000])  # 80 / 20 % of the object: neither weak
    for kind, pivots in (("revolute", True), ("prismatic", True), ("revolute", False)):
        kw = {"pivot_in_parent": (0.0, -0.5, 0.5), "pivot_in_child": (0.0, -0.5, -0.5)} if pivots else {}
        other = CategoryPriors(
            category="cabinet_door",
            parts=pri.parts,
            joints=(JointPrior(kind, 0, 1, (1, 0, 0), limits=(0.0, 1.0), **kw),),
        )
        labels = shared if (kind, pivots) == ("revolute", True) else np.repeat([0, 1], [3000, 60])
        same, _, seated = seat_weak_parts(voted, S, np.zeros((1, 3)), labels, other)
        assert not seated.any() and np.array_equal(same, voted)


def test_seating_names_bad_input():
    from ucope.errors import InputError
    from ucope.voting import seat_weak_parts

    pri = _door_priors()
    T, voted, S, labels, _ = _seat_scene(door_points=60)
    piv = np.zeros((1, 3))
    with pytest.raises(InputError, match="shapes"):
        seat_weak_parts(voted[:1], S, piv, labels, pri)
    with pytest.raises(InputError, match="integers"):
        seat_weak_parts(voted, S, piv, labels.astype(float), pri)
    with pytest.raises(InputError, match="finite"):
        seat_weak_parts(voted, S, np.full((1, 3), np.nan), labels, pri)
    with pytest.raises(InputError, match="positive"):
        seat_weak_parts(voted, -S, piv, labels, pri)
    with pytest.raises(InputError, match="lie in"):
        seat_weak_parts(voted, S, piv, labels, pri, weak_share=1.5)
    with pytest.raises(InputError, match="min_gap"):
        seat_weak_parts(voted, S, piv, labels, pri, min_gap=-0.1)


def test_a_part_just_outside_its_upright_cone_is_carried_only_without_the_margin():
    """Laptop: a base turned about the hinge to 5 degrees beyond its training cone is kept with the default
    margin (10 degrees) and carried back inside the cone with ``margin_deg=0``."""
    from ucope.voting import carry_upright, upright_angles_deg

    S = _samples("laptop", "train", 12)
    pri = measured_priors("laptop", S)
    cone = pri.parts[0].upright_cone_deg
    tried = 0
    for s in S:
        T, size = s["cam_from_part"], s["size_m"]
        u = T[0, :3, :3] @ pri.joints[0].axis
        for deg in np.arange(0.0, 90.0, 0.5):  # the smallest turn that takes the base 5 degrees outside the cone
            turn = rotation_about_axis(u, np.radians(deg))
            bad = T.copy()
            bad[0, :3, :3] = turn @ T[0, :3, :3]
            if upright_angles_deg(bad, pri)[0] >= cone + 5.0:
                break
        else:
            continue
        tried += 1
        kept, carried = carry_upright(bad, size, pri)
        assert not carried.any() and np.array_equal(kept, bad)
        fixed, carried = carry_upright(bad, size, pri, margin_deg=0.0)
        assert carried.tolist() == [True, False]
        assert upright_angles_deg(fixed, pri)[0] <= cone
    assert tried >= 6


def test_weak_neighbours_names_the_barely_seen_side_of_each_revolute_joint():
    """The parts seat_weak_parts and place_weak_parts may move: the weak side of a revolute joint next to a strong
    one (a leaf child, or the root of a two-part object); background labels do not count; prismatic joints never."""
    from ucope.priors import CategoryPriors, JointPrior
    from ucope.voting.kinematic import weak_neighbours

    pri = _door_priors()
    assert weak_neighbours(np.repeat([0, 1, -1], [3000, 60, 9000]), pri, 0.125, 0.25) == [(0, 1, 0)]
    assert weak_neighbours(np.repeat([0, 1], [40, 3000]), pri, 0.125, 0.25) == [(0, 0, 1)]
    assert weak_neighbours(np.repeat([0, 1], [2400, 600]), pri, 0.125, 0.25) == []
    slide = CategoryPriors(category="slide", parts=pri.parts, joints=(JointPrior("prismatic", 0, 1, (0, 0, 1)),))
    assert weak_neighbours(np.repeat([0, 1], [3000, 60]), slide, 0.125, 0.25) == []
