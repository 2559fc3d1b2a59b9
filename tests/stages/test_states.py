"""ucope.stages.states: the kinematic refinement against the ground truth of real samples, joint states clamped into
the limits and settled onto the final boxes."""

import numpy as np
import pytest
from stages_support import samples
from tests_support import measured_priors

from ucope.errors import InputError
from ucope.geometry.kinematics import joint_state_from_poses
from ucope.geometry.transforms import rotation_about_axis, rotation_angle_deg
from ucope.model.config import ModelConfig
from ucope.priors import CategoryPriors, JointPrior, PartPrior
from ucope.stages.states import clamp_joint_states, kinematic_refine, settle_joint_states


def test_kinematic_refine_keeps_consistent_poses_and_reduces_noise(rng):
    S = samples("eyeglasses", "train", 6)
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


def test_states_outside_the_limits_are_clamped_and_the_child_moves_with_them():
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
