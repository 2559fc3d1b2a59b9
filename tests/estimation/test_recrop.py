"""The estimator's second pass on the points its first pass segmented as the object (``search.recrop``)."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.data.generate import GenerateConfig, make_sample
from ucope.data.sample import scale_sample
from ucope.estimation.estimator import Estimator
from ucope.estimation.search import SearchPolicy
from ucope.eval.metrics import rotation_error_deg


@pytest.fixture(scope="module")
def mug():
    s = make_sample(GenerateConfig(category="mug", split="test", num=1, views_per_instance=1, seed=2), 0)
    return s, Estimator.load("mug", overrides={"clean_cloud.plane": False, "vote_parts.num_pairs": 4000})


def _floor_under(s, rng, n=1500, reach=(0.06, 0.25)):
    """Floor points around the object's lowest point, perpendicular to its up axis, on the camera's side."""
    up = -s["cam_from_part"][0][:3, 1]
    c = s["cam_from_part"][0][:3, 3]
    low = np.min(s["points"] @ up)
    e1 = np.cross(up, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    rad, ang = rng.uniform(*reach, n), rng.uniform(0, 2 * np.pi, n)
    floor = c + up * (low - c @ up) + np.outer(rad * np.cos(ang), e1) + np.outer(rad * np.sin(ang), e2)
    return floor[floor[:, 2] < c[2]]


def test_a_clean_cloud_in_the_training_sizes_takes_one_pass(mug):
    s, est = mug
    one = Estimator.load(
        "mug", overrides={"clean_cloud.plane": False, "vote_parts.num_pairs": 4000, "search.recrop": False}
    ).predict(s["points"])
    assert np.mean(one.part_labels < 0) < SearchPolicy().recrop_min_fraction  # the precondition: nothing to leave out
    two = est.predict(s["points"])
    assert not any("estimated again" in w for w in two.warnings)
    np.testing.assert_array_equal(two.parts[0].cam_from_part, one.parts[0].cam_from_part)
    np.testing.assert_array_equal(two.part_labels, one.part_labels)


def test_a_floor_left_in_the_mask_is_left_out_and_the_pose_estimated_again(mug):
    s, est = mug
    floor = _floor_under(s, np.random.default_rng(3))
    cloud = np.r_[s["points"], floor].astype(np.float32)
    r = est.predict(cloud)
    assert any("left out; the pose was estimated again" in w for w in r.warnings)
    assert r.part_labels.shape == (len(cloud),)
    assert (r.part_labels[len(s["points"]) :] == -1).mean() > 0.8  # the floor
    assert (r.part_labels[: len(s["points"])] == 0).mean() > 0.9  # the mug
    T, Tg = r.parts[0].cam_from_part, s["cam_from_part"][0]
    assert rotation_error_deg(T[:3, :3], Tg[:3, :3], "y") < 10.0
    assert np.linalg.norm(T[:3, 3] - Tg[:3, 3]) < 0.1 * np.linalg.norm(s["size_m"][0])
    # timings add up over both passes
    assert r.timings_ms["total"] >= r.timings_ms["encoder"] + r.timings_ms["voting"]
    # the same cloud in another order: the same result
    perm = np.random.default_rng(0).permutation(len(cloud))
    again = est.predict(cloud[perm])
    np.testing.assert_array_equal(again.parts[0].cam_from_part, T)
    np.testing.assert_array_equal(again.part_labels, r.part_labels[perm])
    # one pass: no such warning, and every point labelled by the one estimate
    one = Estimator.load(
        "mug", overrides={"clean_cloud.plane": False, "vote_parts.num_pairs": 4000, "search.recrop": False}
    ).predict(cloud)
    assert not any("estimated again" in w for w in one.warnings)


def test_the_second_pass_decides_the_rescaling_on_the_object_points():
    """A drawer (its model has no background class) at 0.3x: the first pass leaves nothing out and does not
    rescale; the second rescales the whole cloud, so the result is the one-pass rescaled estimate."""
    s = make_sample(GenerateConfig(category="drawer", split="test", num=1, views_per_instance=1, seed=3), 0)
    small = scale_sample(s, 0.3)["points"]
    two = Estimator.load("drawer", drop=["kinematic_refine"], overrides={"vote_parts.num_pairs": 2000}).predict(small)
    one = Estimator.load(
        "drawer", drop=["kinematic_refine"], overrides={"vote_parts.num_pairs": 2000, "search.recrop": False}
    ).predict(small)
    assert any("scaled by" in w for w in two.warnings) and any("scaled by" in w for w in one.warnings)
    for a, b in zip(two.parts, one.parts, strict=True):
        np.testing.assert_array_equal(a.cam_from_part, b.cam_from_part)
        np.testing.assert_array_equal(a.size_m, b.size_m)


def test_compact_tells_a_lone_object_from_one_with_a_far_floor(mug):
    from ucope.estimation.search import SearchPolicy, compact

    s, _ = mug
    factor = SearchPolicy().compact_factor
    assert compact(s["points"], factor)
    assert compact(scale_sample(s, 2.0)["points"], factor)  # a size does not change it
    far = _floor_under(s, np.random.default_rng(0), n=800, reach=(0.3, 1.5))  # ~25 % of the points
    assert not compact(np.concatenate([s["points"], far]), factor)


def test_a_compact_cloud_far_above_the_training_sizes_is_rescaled_in_the_first_pass(mug):
    s, est = mug
    big = scale_sample(s, 3.0)
    assert est.input_scale(big["points"])[0] < 1.0  # the precondition: too large for the model
    one = Estimator.load(
        "mug", overrides={"clean_cloud.plane": False, "vote_parts.num_pairs": 4000, "search.recrop": False}
    ).predict(big["points"])
    two = est.predict(big["points"])
    assert any("was scaled by" in w for w in one.warnings) and any("was scaled by" in w for w in two.warnings)
    assert rotation_error_deg(two.parts[0].cam_from_part[:3, :3], big["cam_from_part"][0][:3, :3]) < 15.0
    ratio = np.cbrt(np.prod(two.parts[0].size_m) / np.prod(big["size_m"][0]))
    assert 0.8 < ratio < 1.25
