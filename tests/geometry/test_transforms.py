import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ucope.errors import InputError
from ucope.geometry.transforms import (
    apply_transform,
    axis_angle_transform,
    invert_transform,
    look_at_rotation,
    make_transform,
    random_rotation,
    rotation_about_axis,
    rotation_angle_deg,
)


def test_invert_and_apply_round_trip(rng):
    T = make_transform(random_rotation(rng, 5), rng.normal(size=(5, 3)))
    p = rng.normal(size=(5, 7, 3))
    back = apply_transform(invert_transform(T), apply_transform(T, p))
    np.testing.assert_allclose(back, p, atol=1e-12)
    np.testing.assert_allclose(invert_transform(T) @ T, np.broadcast_to(np.eye(4), (5, 4, 4)), atol=1e-12)


def test_rotation_about_axis_matches_scipy(rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R = rotation_about_axis(axis, 0.7)
    np.testing.assert_allclose(R, Rotation.from_rotvec(axis * 0.7).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(R @ axis, axis, atol=1e-12)


def test_axis_angle_transform_fixes_the_pivot_line():
    T = axis_angle_transform([0, 0, 1], [1.0, 2.0, 0.0], np.pi / 2)
    np.testing.assert_allclose(apply_transform(T, np.array([[1.0, 2.0, 5.0]])), [[1.0, 2.0, 5.0]], atol=1e-12)
    np.testing.assert_allclose(apply_transform(T, np.array([[2.0, 2.0, 0.0]])), [[1.0, 3.0, 0.0]], atol=1e-12)


def test_look_at_points_z_at_target_and_keeps_up():
    R = look_at_rotation([0.0, 1.0, 2.0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) > 0
    z = R[:, 2]
    np.testing.assert_allclose(z, -np.array([0.0, 1.0, 2.0]) / np.sqrt(5), atol=1e-12)
    assert R[:, 1] @ np.array([0.0, 1.0, 0.0]) < 0  # image y (down) points against world up


def test_rotation_angle_deg(rng):
    R = random_rotation(rng)
    assert rotation_angle_deg(R, R @ rotation_about_axis([1, 0, 0], np.radians(30))) == pytest.approx(30.0)


def test_zero_axis_is_rejected():
    with pytest.raises(InputError):
        rotation_about_axis([0.0, 0.0, 0.0], 1.0)
