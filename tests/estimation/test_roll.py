"""A known up direction takes out the camera's roll: roll_to_up and Estimator.predict(up=...)."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import InputError
from ucope.estimation.estimator import Estimator
from ucope.estimation.inputs import roll_to_up
from ucope.geometry.transforms import rotation_about_axis

Z = np.array([0.0, 0.0, 1.0])


@pytest.mark.parametrize("roll_deg", [0.0, 30.0, -75.0, 180.0])
def test_roll_to_up_turns_the_up_direction_to_image_up_about_the_optical_axis(roll_deg):
    up = np.array([0.0, -0.8, -0.6])  # image up, tilted by a 37-degree elevation
    tilted = rotation_about_axis(Z, np.radians(roll_deg)) @ up * 3.0  # any length
    R = roll_to_up(tilted)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(R @ Z, Z, atol=1e-12)  # about the optical axis only
    np.testing.assert_allclose(R @ (tilted / 3.0), up, atol=1e-12)


@pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [0.0, 0.05, -1.0], [1.0, 2.0]])
def test_roll_to_up_refuses_what_has_no_roll(bad):
    with pytest.raises(InputError, match="up"):
        roll_to_up(bad)


def test_a_rolled_cloud_with_its_up_gives_the_rolled_result():
    """Predicting a cloud seen by a camera rolled 60 degrees, with the up direction that camera measured,
    gives the upright camera's result turned by the roll (poses, pivots, axes); sizes, states and labels
    are unchanged, and a warning says the cloud was turned."""
    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1), 3)
    up = np.asarray(s["cam_from_object"], np.float64)[:3, 1]  # the object stands upright in the world
    est = Estimator.load("laptop", overrides={"vote_parts.num_pairs": 4000})
    base = est.predict(s["points"], s["normals"], up=up)
    Rz = rotation_about_axis(Z, np.radians(60.0))
    rolled = est.predict(np.asarray(s["points"], np.float64) @ Rz.T, np.asarray(s["normals"], np.float64) @ Rz.T, up=Rz @ up)
    assert any("turned" in w and "optical axis" in w for w in rolled.warnings)
    for a, b in zip(base.parts, rolled.parts, strict=True):
        np.testing.assert_allclose(b.cam_from_part[:3, :3], Rz @ a.cam_from_part[:3, :3], atol=1e-4)
        np.testing.assert_allclose(b.cam_from_part[:3, 3], Rz @ a.cam_from_part[:3, 3], atol=1e-4)
        np.testing.assert_allclose(b.size_m, a.size_m, atol=1e-5)
    for a, b in zip(base.joints, rolled.joints, strict=True):
        np.testing.assert_allclose(b.axis, Rz @ a.axis, atol=1e-4)
        np.testing.assert_allclose(b.pivot_m, Rz @ a.pivot_m, atol=1e-4)
        assert b.state == pytest.approx(a.state, abs=1e-4)
    np.testing.assert_array_equal(rolled.part_labels, base.part_labels)


def test_roll_sample_turns_every_camera_frame_quantity_about_the_optical_axis():
    from ucope.data.sample import roll_sample

    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1), 0)
    r = roll_sample(s, np.radians(40.0))
    Rz = rotation_about_axis(Z, np.radians(40.0))
    np.testing.assert_allclose(r["points"], np.asarray(s["points"], np.float64) @ Rz.T, atol=1e-6)
    assert r["points"].dtype == np.asarray(s["points"]).dtype
    np.testing.assert_allclose(r["normals"], np.asarray(s["normals"], np.float64) @ Rz.T, atol=1e-6)
    for k in range(len(s["size_m"])):  # each part's points stay where they were in the part
        T0, T1 = np.asarray(s["cam_from_part"][k]), r["cam_from_part"][k]
        np.testing.assert_allclose(T1, np.vstack([Rz @ T0[:3], [0, 0, 0, 1]]), atol=1e-12)
    np.testing.assert_allclose(r["joint_axis"], np.asarray(s["joint_axis"]) @ Rz.T, atol=1e-12)
    np.testing.assert_allclose(r["joint_pivot"], np.asarray(s["joint_pivot"]) @ Rz.T, atol=1e-12)
    np.testing.assert_array_equal(r["size_m"], s["size_m"])
    np.testing.assert_array_equal(r["joint_state"], s["joint_state"])
    back = roll_sample(r, -np.radians(40.0))
    np.testing.assert_allclose(back["cam_from_object"], s["cam_from_object"], atol=1e-12)
    with pytest.raises(InputError, match="finite"):
        roll_sample(s, float("nan"))
