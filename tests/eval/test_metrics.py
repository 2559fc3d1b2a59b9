"""Tests for ucope.eval.metrics on hand-made cases with known answers."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.eval.metrics import (
    axis_angle_error_deg,
    box_iou,
    joint_errors,
    line_distance_m,
    normalized_translation_error,
    part_errors,
    rotation_error_deg,
    segmentation_accuracy,
    segmentation_iou,
    state_error,
    summarize_joints,
    summarize_parts,
    translation_error_m,
)
from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis

X, Y, Z = np.eye(3)


def rot(axis, deg: float) -> np.ndarray:
    return rotation_about_axis(np.asarray(axis, dtype=float), np.radians(deg))


def pose(R=None, t=(0.0, 0.0, 1.0)) -> np.ndarray:
    return make_transform(np.eye(3) if R is None else R, np.asarray(t, dtype=float))


# --------------------------------------------------------------------------------------------------
# per part
# --------------------------------------------------------------------------------------------------


def test_identical_boxes_iou_one(rng):
    T = pose(random_rotation(rng), (0.1, -0.2, 0.9))
    assert box_iou(T, [0.3, 0.1, 0.2], T, [0.3, 0.1, 0.2]) == pytest.approx(1.0, abs=1e-9)


def test_box_shifted_by_half_its_length_iou_one_third(rng):
    R = random_rotation(rng)
    size = np.array([0.4, 0.1, 0.2])
    T_gt = pose(R, (0.0, 0.0, 1.0))
    T_pred = pose(R, T_gt[:3, 3] + 0.5 * size[0] * R[:, 0])  # half a length along the box's own x
    # intersection = half the box, union = 1.5 boxes
    assert box_iou(T_pred, size, T_gt, size) == pytest.approx(1.0 / 3.0, abs=1e-9)
    assert box_iou(T_pred, size, T_gt, size, symmetry="none") == pytest.approx(1.0 / 3.0, abs=1e-9)


def test_rotation_error_known_angles(rng):
    R = random_rotation(rng)
    assert rotation_error_deg(R, R) == pytest.approx(0.0, abs=1e-6)
    assert rotation_error_deg(R @ rot(X, 90), R) == pytest.approx(90.0, abs=1e-9)
    assert rotation_error_deg(R, R @ rot([1, 2, 3], 90)) == pytest.approx(90.0, abs=1e-9)
    assert rotation_error_deg(R @ rot(Z, 180), R) == pytest.approx(180.0, abs=1e-9)
    # small angles are accurate (atan2, not arccos of a cosine near 1)
    assert rotation_error_deg(R @ rot(Y, 1e-4), R) == pytest.approx(1e-4, rel=1e-5)


def test_symmetric_part_rotated_about_y_has_zero_error_and_iou_one(rng):
    R = random_rotation(rng)
    size = np.array([0.1, 0.2, 0.06])  # x != z: a y rotation changes the box
    T_gt = pose(R, (0.05, 0.1, 0.8))
    T_pred = pose(R @ rot(Y, 40), T_gt[:3, 3])
    assert rotation_error_deg(T_pred[:3, :3], T_gt[:3, :3], symmetry="y") == pytest.approx(0.0, abs=1e-6)
    assert box_iou(T_pred, size, T_gt, size, symmetry="y") == pytest.approx(1.0, abs=1e-6)
    # without symmetry the same prediction is 40 degrees off and its box overlaps less
    assert rotation_error_deg(T_pred[:3, :3], T_gt[:3, :3]) == pytest.approx(40.0, abs=1e-9)
    assert box_iou(T_pred, size, T_gt, size) < 0.9
    # a tilt of the y axis is seen by the symmetric error
    assert rotation_error_deg(R @ rot(X, 10), R, symmetry="y") == pytest.approx(10.0, abs=1e-9)
    assert rotation_error_deg(R @ rot(X, 180), R, symmetry="y") == pytest.approx(180.0, abs=1e-9)


def test_translation_errors():
    assert translation_error_m([0.03, 0.04, 1.0], [0.0, 0.0, 1.0]) == pytest.approx(0.05)
    # GT diagonal = |(0.3, 0.4, 1.2)| = 1.3
    assert normalized_translation_error([0.03, 0.04, 1.0], [0.0, 0.0, 1.0], [0.3, 0.4, 1.2]) == pytest.approx(0.05 / 1.3)


def test_part_errors_dict_is_plain_floats():
    size = np.array([0.2, 0.2, 0.2])
    e = part_errors(pose(rot(Z, 90), (0.1, 0.0, 1.0)), size, pose(None, (0.0, 0.0, 1.0)), size)
    assert set(e) == {"rotation_deg", "translation_m", "translation_norm", "iou"}
    assert all(type(v) is float for v in e.values())
    assert e["rotation_deg"] == pytest.approx(90.0)
    assert e["translation_m"] == pytest.approx(0.1)
    assert e["translation_norm"] == pytest.approx(0.1 / math.sqrt(0.12))
    assert e["iou"] == pytest.approx(1.0 / 3.0)  # a cube turned 90 degrees is itself, shifted by half


# --------------------------------------------------------------------------------------------------
# per joint
# --------------------------------------------------------------------------------------------------


def test_axis_angle_error():
    assert axis_angle_error_deg([0, 0, 1], [0, 0, -2]) == pytest.approx(0.0, abs=1e-12)  # opposite: 0
    assert axis_angle_error_deg(X, Y) == pytest.approx(90.0)
    assert axis_angle_error_deg(rot(Z, 30) @ X, X) == pytest.approx(30.0)
    assert axis_angle_error_deg(rot(Z, 150) @ X, X) == pytest.approx(30.0)  # min(theta, 180 - theta)


def test_line_distance_parallel_lines_is_their_separation():
    assert line_distance_m([0, 0, 0], Z, [0.3, 0.4, 7.0], Z) == pytest.approx(0.5)
    assert line_distance_m([0, 0, 0], Z, [0.3, 0.4, -2.0], -Z) == pytest.approx(0.5)  # anti-parallel
    assert line_distance_m([0, 0, 0], Z, [0.3, 0.4, 0.0], Z + 1e-9 * X) == pytest.approx(0.5)  # within tolerance
    assert line_distance_m([1, 2, 3], X, [1, 2, 3], X) == 0.0  # the same line


def test_line_distance_intersecting_and_skew_lines():
    # x = 1 (along y) meets the diagonal through the origin at (1, 1, 0)
    assert line_distance_m([1, 0, 0], Y, [0, 0, 0], [1, 1, 0]) == pytest.approx(0.0, abs=1e-12)
    # the x axis and a line along y at z = 2: common perpendicular along z, length 2
    assert line_distance_m([0, 0, 0], X, [5, -3, 2], Y) == pytest.approx(2.0)
    # the x axis and the line through (0, 0, 2) along (0, 1, 1): n = (0, -1, 1), d.n / |n| = 2 / sqrt(2)
    assert line_distance_m([0, 0, 0], X, [0, 0, 2], [0, 1, 1]) == pytest.approx(math.sqrt(2.0))
    # skew at 45 degrees, in the planes z = 0 and z = 2: distance 2
    assert line_distance_m([0, 0, 0], X, [4, 1, 2], [1, 1, 0]) == pytest.approx(2.0)


def test_state_error():
    assert state_error(0.1, 0.3, "revolute") == pytest.approx(math.degrees(0.2))
    assert state_error(0.1, 0.3, 0) == pytest.approx(math.degrees(0.2))
    assert state_error(3.1, -3.1, "revolute") == pytest.approx(math.degrees(2 * math.pi - 6.2))  # wraps
    assert state_error(0.10, 0.25, "prismatic") == pytest.approx(0.15)
    assert state_error(0.10, 0.25, 1) == pytest.approx(0.15)
    with pytest.raises(InputError, match="fixed"):
        state_error(0.0, 0.0, 2)
    with pytest.raises(InputError, match="joint_type"):
        state_error(0.0, 0.0, "hinge")


def test_joint_errors_dicts():
    rev = joint_errors(X, [0, 0.1, 1], 0.5, X, [0, 0, 1], 0.4, "revolute")
    assert rev["joint_type"] == "revolute" and rev["state_unit"] == "deg" and rev["axis_flipped"] is False
    assert rev["axis_deg"] == pytest.approx(0.0, abs=1e-12)
    assert rev["pivot_m"] == pytest.approx(0.1)
    assert rev["state_error"] == pytest.approx(math.degrees(0.1))
    pri = joint_errors(Z, None, 0.2, Z, None, 0.25, 1)
    assert pri["pivot_m"] is None and pri["state_unit"] == "m"
    assert pri["state_error"] == pytest.approx(0.05)
    json.dumps([rev, pri], allow_nan=False)


def test_joint_axis_error_is_sign_aware_because_the_state_is():
    """A lid opened by 40 degrees about u: a prediction with perfect part poses whose axis came out as -u reads
    the state about -u, -40 degrees: the same motion in the other convention, which a user reading "lid at -40
    degrees" gets wrong. The axis error says so (180 degrees, flipped) and the state is compared as it is (80
    degrees off); the line angle (sign aside) stays 0.  The same for a drawer pulled 0.2 m along u, read as
    -0.2 m along -u."""
    from ucope.geometry.kinematics import joint_state_from_poses

    u, q = np.array([0.6, 0.0, 0.8]), math.radians(40.0)
    parent = pose(None, (0.0, 0.0, 1.0))
    child = pose(rotation_about_axis(u, q), (0.0, 0.0, 1.0))
    q_pred = joint_state_from_poses(parent, child, -u, "revolute")
    assert q_pred == pytest.approx(-q)
    rev = joint_errors(-u, [0, 0, 1], q_pred, u, [0, 0, 1], q, "revolute")
    assert rev["axis_deg"] == pytest.approx(180.0) and rev["axis_flipped"] is True
    assert rev["axis_line_deg"] == pytest.approx(0.0, abs=1e-9) and rev["pivot_m"] == pytest.approx(0.0, abs=1e-12)
    assert rev["state_error"] == pytest.approx(80.0)
    pri = joint_errors(-u, None, -0.2, u, None, 0.2, "prismatic")
    assert pri["state_error"] == pytest.approx(0.4) and pri["axis_flipped"] is True and pri["axis_deg"] == pytest.approx(180.0)
    # the right convention: no error at all
    same = joint_errors(u, [0, 0, 1], q, u, [0, 0, 1], q, "revolute")
    assert same["axis_deg"] == pytest.approx(0.0, abs=1e-6) and same["state_error"] == pytest.approx(0.0, abs=1e-9)
    # nearly perpendicular on the far side: 95 degrees signed, 85 as lines
    tilted = rotation_about_axis(Y, math.radians(95.0)) @ u
    e = joint_errors(tilted, [0, 0, 1], q, u, [0, 0, 1], q, 0)
    assert e["axis_deg"] == pytest.approx(95.0) and e["axis_line_deg"] == pytest.approx(85.0) and e["axis_flipped"] is True
    assert axis_angle_error_deg(-u, u) == pytest.approx(0.0, abs=1e-9)  # the line angle by default
    assert axis_angle_error_deg(-u, u, signed=True) == pytest.approx(180.0)
    table = summarize_joints([[rev], [same]])
    assert table["axis_deg"]["mean"] == [pytest.approx(90.0)] and table["axis_flipped_fraction"] == [0.5]
    assert table["axis_line_deg"]["median"][0] == pytest.approx(0.0, abs=1e-6)


# --------------------------------------------------------------------------------------------------
# segmentation
# --------------------------------------------------------------------------------------------------


def test_segmentation_iou_and_accuracy_hand_example():
    pred = np.array([0, 0, 1, 1, 1, 2, 2])
    gt = np.array([0, 0, 0, 1, 1, 2, 2])
    # part 0: pred {0,1}, gt {0,1,2} -> 2/3; part 1: pred {2,3,4}, gt {3,4} -> 2/3; part 2: {5,6} both -> 1;
    # part 3: absent from both -> NaN
    iou = segmentation_iou(pred, gt, 4)
    np.testing.assert_allclose(iou[:3], [2 / 3, 2 / 3, 1.0])
    assert np.isnan(iou[3])
    assert segmentation_accuracy(pred, gt) == pytest.approx(6 / 7)
    # an unassigned point (-1) only enlarges its GT part's union
    iou = segmentation_iou([0, -1, 1], [0, 0, 1], 2)
    np.testing.assert_allclose(iou, [0.5, 1.0])
    assert segmentation_accuracy([0, -1, 1], [0, 0, 1]) == pytest.approx(2 / 3)
    # a part predicted but absent from the GT has IoU 0
    np.testing.assert_allclose(segmentation_iou([1, 1], [0, 0], 2), [0.0, 0.0])


# --------------------------------------------------------------------------------------------------
# summaries
# --------------------------------------------------------------------------------------------------


def test_summarize_parts():
    def e(r, t, iou):
        return {"rotation_deg": r, "translation_m": t, "translation_norm": t / 2, "iou": iou}

    samples = [
        [e(2.0, 0.01, 0.9), e(4.0, 0.04, 0.6)],
        [e(6.0, 0.02, 0.8), e(20.0, 0.30, 0.1)],
        [e(1.0, 0.03, 0.7), None],  # part 1 not predicted: a failure, out of the means
    ]
    s = summarize_parts(samples)
    json.dumps(s, allow_nan=False)
    assert s["num_samples"] == 3 and s["num_parts"] == 2 and s["num_missing"] == [0, 1]
    assert s["rotation_deg"]["mean"] == pytest.approx([3.0, 12.0])
    assert s["rotation_deg"]["median"] == pytest.approx([2.0, 12.0])
    assert s["translation_m"]["mean"] == pytest.approx([0.02, 0.17])
    assert s["translation_norm"]["median"] == pytest.approx([0.01, 0.085])
    assert s["iou"]["mean"] == pytest.approx([0.8, 0.35])
    assert s["fraction"]["5deg5cm"] == pytest.approx([2 / 3, 1 / 3])
    assert s["fraction"]["10deg10cm"] == pytest.approx([1.0, 1 / 3])
    assert s["fraction"]["iou50"] == pytest.approx([1.0, 1 / 3])
    assert s["fraction"]["iou75"] == pytest.approx([2 / 3, 0.0])
    # rotation alone: 6 deg passes 10 deg though its 2 cm would not matter either way; part 1's 4 deg passes 5 deg
    assert s["fraction"]["5deg"] == pytest.approx([2 / 3, 1 / 3])
    assert s["fraction"]["10deg"] == pytest.approx([1.0, 1 / 3])
    far = summarize_parts([[e(3.0, 0.5, 0.1)]])  # right rotation, far centre: passes on rotation only
    assert far["fraction"]["5deg"] == [1.0] and far["fraction"]["5deg5cm"] == [0.0]
    with pytest.raises(InputError, match="same number"):
        summarize_parts([[e(1, 0.1, 0.5)], [e(1, 0.1, 0.5), e(1, 0.1, 0.5)]])


def test_summarize_joints():
    j1 = joint_errors(X, [0, 0, 1], 0.5, X, [0, 0.1, 1], 0.4, "revolute")
    j2 = joint_errors(X, [0, 0, 1], 0.5, X, [0, 0.3, 1], 0.5, "revolute")
    s = summarize_joints([[j1], [j2], [None]])
    json.dumps(s, allow_nan=False)
    assert s["joint_type"] == ["revolute"] and s["state_unit"] == ["deg"]
    assert s["pivot_m"]["mean"] == pytest.approx([0.2])
    assert s["state_error"]["median"] == pytest.approx([math.degrees(0.05)])


# --------------------------------------------------------------------------------------------------
# bad inputs
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: rotation_error_deg(np.eye(3) * 2, np.eye(3)), "R_pred"),
        (lambda: rotation_error_deg(np.eye(3), np.diag([1.0, 1.0, -1.0])), "R_gt"),
        (lambda: rotation_error_deg(np.eye(4), np.eye(3)), r"shape \(3, 3\)"),
        (lambda: rotation_error_deg(np.eye(3), np.eye(3), symmetry="z"), "symmetry"),
        (lambda: translation_error_m([0, 0, np.nan], [0, 0, 0]), "non-finite"),
        (lambda: normalized_translation_error([0, 0, 0], [0, 0, 0], [0.1, 0.0, 0.1]), "size_gt"),
        (lambda: box_iou(np.eye(4), [0.1, 0.1, -0.1], np.eye(4), [0.1] * 3), "size_pred"),
        (lambda: box_iou(np.eye(4), [0.1] * 3, np.ones((4, 4)), [0.1] * 3), "cam_from_part_gt"),
        (lambda: axis_angle_error_deg([0, 0, 0], Z), "u_pred"),
        (lambda: line_distance_m([0, 0], Z, [0, 0, 0], Z), "p1"),
        (lambda: state_error(float("inf"), 0.0, 0), "pred"),
        (lambda: segmentation_iou([0, 1], [0, 1, 1], 2), "same shape"),
        (lambda: segmentation_iou([0, 2], [0, 1], 2), "pred_labels"),
        (lambda: segmentation_iou([0.0, 1.0], [0, 1], 2), "integers"),
        (lambda: segmentation_iou([0, 1], [0, 1], 0), "num_parts"),
        (lambda: segmentation_accuracy([], []), "non-empty"),
        (lambda: summarize_parts([]), "non-empty"),
        (lambda: summarize_parts([[None]], pose_thresholds_deg_m=[5]), "pairs"),
    ],
)
def test_bad_inputs_raise_input_error(call, match):
    with pytest.raises(InputError, match=match):
        call()
