"""ucope.stages.cloud: the ``clean_cloud`` stage on a mug standing on a floor (the plane left out, the noise
smoothed) and the estimator that runs it from the model card's stage list."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.estimation.estimator import Estimator
from ucope.geometry.denoise import surface_noise
from ucope.stages import CloudState, run, stage_params


@pytest.fixture(scope="module")
def mug_on_the_floor():
    from ucope.data.generate import GenerateConfig, make_sample

    s = make_sample(GenerateConfig(category="mug", split="test", num=1, views_per_instance=1, seed=2), 0)
    obj = s["points"].astype(np.float64)
    # a floor under it: the plane through the lowest object points, perpendicular to the mug's up axis
    up = -s["cam_from_part"][0][:3, 1]  # the object's +y is up in its frame; the floor is below it
    low = np.min(obj @ up)
    rng = np.random.default_rng(3)
    e1 = np.cross(up, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    c = s["cam_from_part"][0][:3, 3]
    rad, ang = rng.uniform(0.06, 0.12, 1500), rng.uniform(0, 2 * np.pi, 1500)
    floor = c + up * (low - c @ up) + np.outer(rad * np.cos(ang), e1) + np.outer(rad * np.sin(ang), e2)
    floor = floor[floor[:, 2] < c[2]]  # the camera's side
    return obj, floor


def _cleaned(points, overrides=None):
    cloud = CloudState(np.asarray(points, np.float32), None, seed=0)
    records = run(["clean_cloud", "vote_parts"], cloud, stage_params(["clean_cloud"], overrides), phase="cloud")
    return cloud, records


def test_the_stage_leaves_the_floor_out_and_only_with_its_plane_setting(mug_on_the_floor):
    obj, floor = mug_on_the_floor
    cloud, records = _cleaned(np.r_[obj, floor])
    assert [r.name for r in records] == ["clean_cloud"] and records[0].changed == {}  # pose stages wait for the network
    assert cloud.plane is not None and any("left out as floor" in w for w in cloud.input_warnings)
    assert (~cloud.keep[len(obj) :]).mean() > 0.95 and cloud.keep[: len(obj)].mean() > 0.9
    np.testing.assert_array_equal(cloud.keep, ~cloud.plane.removes(cloud.points))
    kept, _ = _cleaned(np.r_[obj, floor], {"clean_cloud.plane": False})
    assert kept.plane is None and kept.keep.all() and not kept.input_warnings


def test_the_stage_smooths_a_cloud_noisier_than_the_model_knows(mug_on_the_floor):
    """3 mm of noise on the mug, above the 1.5 mm default: smoothed (the noise goes down) with a warning; not with
    ``noise_above_m`` null, nor in a cloud under ``smooth_min_points``."""
    obj, _ = mug_on_the_floor
    noisy = (obj + np.random.default_rng(0).normal(0.0, 0.003, obj.shape)).astype(np.float32)
    assert len(noisy) >= 1000 and surface_noise(noisy) > 1.5e-3
    cloud, _ = _cleaned(noisy, {"clean_cloud.plane": False})
    assert surface_noise(cloud.points) < 0.7 * surface_noise(noisy)
    assert any("surface noise" in w for w in cloud.warnings)
    for overrides in ({"clean_cloud.noise_above_m": "null"}, {"clean_cloud.smooth_min_points": len(noisy) + 1}):
        same, _ = _cleaned(noisy, {"clean_cloud.plane": False, **overrides})
        np.testing.assert_array_equal(same.points, noisy)
        assert not same.warnings


def test_the_estimator_leaves_the_floor_out_labels_it_minus_one_and_says_so(mug_on_the_floor):
    obj, floor = mug_on_the_floor
    cloud = np.r_[obj, floor].astype(np.float32)
    on = Estimator.load("mug", overrides={"vote_parts.num_pairs": 4000})
    assert "clean_cloud" in on.pipeline.stages  # the mug's card runs it
    r = on.predict(cloud)
    assert any("left out as floor" in w for w in r.warnings)
    assert (r.part_labels[len(obj) :] == -1).mean() > 0.95
    assert (r.part_labels[: len(obj)] == 0).mean() > 0.9
    for off in (
        Estimator.load("mug", overrides={"vote_parts.num_pairs": 4000, "clean_cloud.plane": False}),
        Estimator.load("mug", overrides={"vote_parts.num_pairs": 4000}, drop=["clean_cloud"]),
    ):
        assert not any("left out as floor" in w for w in off.predict(cloud).warnings)
    # the same cloud in another order gives the same plane and the same result
    perm = np.random.default_rng(0).permutation(len(cloud))
    again = on.predict(cloud[perm])
    np.testing.assert_array_equal(again.parts[0].cam_from_part, r.parts[0].cam_from_part)
    np.testing.assert_array_equal(again.part_labels, r.part_labels[perm])
