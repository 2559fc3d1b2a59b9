"""The estimator's rescaling of clouds outside the model's training sizes (``search.rescale``)."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.data.generate import GenerateConfig, make_sample
from ucope.data.sample import scale_sample
from ucope.errors import InputError
from ucope.estimation.estimator import Estimator
from ucope.priors import cloud_radius


@pytest.fixture(scope="module")
def drawer():
    """A drawer test view (prismatic joints: their states must follow the scale) and the shipped model
    (one estimate per cloud: the scale search is tested in test_scale_search.py, the restarts in test_restarts.py)."""
    s = make_sample(GenerateConfig(category="drawer", split="test", num=1, views_per_instance=1, seed=3), 0)
    return s, Estimator.load(
        "drawer",
        drop=["kinematic_refine"],
        overrides={"vote_parts.num_pairs": 2000, "search.scale_factors": [], "search.restarts": 0},
    )


def test_a_cloud_inside_the_training_sizes_is_left_alone(drawer):
    s, est = drawer
    lo, hi = est.priors.radius_range_m
    assert lo <= cloud_radius(s["points"]) <= hi
    scale, _ = est.input_scale(s["points"])
    assert scale == 1.0
    a, b = (
        est.predict(s["points"]),
        Estimator(est.model, est.pipeline, overrides={"search.rescale": False}).predict(s["points"]),
    )
    for pa, pb in zip(a.parts, b.parts, strict=True):
        np.testing.assert_allclose(pa.cam_from_part, pb.cam_from_part, rtol=0, atol=1e-12)  # round-off only
    assert not any("scaled by" in w for w in a.warnings)


@pytest.mark.parametrize("factor", [0.3, 3.0])
def test_a_small_or_large_cloud_is_estimated_in_the_training_sizes_and_scaled_back(drawer, factor):
    s, est = drawer
    small = scale_sample(s, factor)["points"]
    scale, centre = est.input_scale(small)
    lo, hi = est.priors.radius_typical_m or est.priors.radius_range_m  # the middle of the typical radii
    assert scale != 1.0 and np.isclose(cloud_radius(centre + scale * (small - centre)), np.sqrt(lo * hi), rtol=1e-6)
    got = est.predict(small)
    assert any("scaled by" in w for w in got.warnings)
    # The same as estimating the scaled cloud as it is and mapping the result back by hand.
    plain = Estimator(est.model, est.pipeline, overrides={"search.rescale": False}).predict(
        (centre + scale * (small - centre)).astype(np.float32)
    )
    for pg, pp in zip(got.parts, plain.parts, strict=True):
        np.testing.assert_allclose(pg.size_m, pp.size_m / scale, rtol=1e-9)
        np.testing.assert_allclose(pg.cam_from_part[:3, :3], pp.cam_from_part[:3, :3], atol=1e-12)
        np.testing.assert_allclose(pg.cam_from_part[:3, 3], centre + (pp.cam_from_part[:3, 3] - centre) / scale, atol=1e-9)
    for jg, jp in zip(got.joints, plain.joints, strict=True):  # prismatic: displacements shrink with the object
        assert jg.type == "prismatic"
        np.testing.assert_allclose(jg.axis, jp.axis, atol=1e-12)
        assert jg.state == pytest.approx(jp.state / scale, rel=1e-9)
    np.testing.assert_array_equal(got.part_labels, plain.part_labels)


def test_rescaling_recovers_the_size_of_an_object_half_as_big_as_the_smallest_trained():
    """Measured, not constructed: a mug scaled so that its cloud is half the smallest the model was trained
    on keeps its box size ratio near 1 with the rescaling and is far too big without it
    (benchmarks/bench_scale.py has the full curve)."""
    s0 = make_sample(GenerateConfig(category="mug", split="test", num=1, views_per_instance=1, seed=5), 0)
    est = {on: Estimator.load("mug", overrides={"vote_parts.num_pairs": 4000, "search.rescale": on}) for on in (False, True)}
    lo = est[True].priors.radius_range_m[0]
    s = scale_sample(s0, 0.5 * lo / cloud_radius(s0["points"]))
    true = np.prod(s["size_m"][0])
    ratio = {on: float(np.cbrt(np.prod(e.predict(s["points"]).parts[0].size_m) / true)) for on, e in est.items()}
    assert ratio[False] > 1.4 and 0.8 < ratio[True] < 1.25, ratio


def test_scale_sample_keeps_every_point_where_it_was_in_its_part():
    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1), 0)
    t = scale_sample(s, 1.7)

    def local(x, k):
        T, m = x["cam_from_part"][k], s["part_labels"] == k
        return (x["points"][m].astype(np.float64) - T[:3, 3]) @ T[:3, :3] / x["size_m"][k]

    for k in range(2):
        np.testing.assert_allclose(local(t, k), local(s, k), atol=1e-5)
    np.testing.assert_allclose(t["size_m"], 1.7 * s["size_m"])
    np.testing.assert_allclose(t["joint_state"], s["joint_state"])  # revolute: unchanged
    assert np.array_equal(t["normals"], s["normals"]) and t is not s and s["size_m"] is not t["size_m"]
    with pytest.raises(InputError, match="positive finite"):
        scale_sample(s, 0.0)


def test_rescaling_triggers_below_the_typical_radii_and_above_the_largest(drawer):
    """``input_scale``: a cloud smaller than the radii the model saw often (``radius_typical_m``) or larger
    than any it saw (``radius_range_m``) goes to the middle of the typical radii; one between the typical
    and the largest radius (a floor or a bleeding mask widen a cloud too) is left alone."""
    import dataclasses

    s, est0 = drawer
    est = Estimator(est0.model, est0.pipeline)
    r = cloud_radius(s["points"])
    cases = [  # (typical, range, rescaled)
        ((1.2 * r, 2.0 * r), (0.5 * r, 3.0 * r), True),  # below the typical radii
        ((0.3 * r, 0.8 * r), (0.2 * r, 1.5 * r), False),  # above them, inside the range
        ((0.3 * r, 0.8 * r), (0.2 * r, 0.9 * r), True),  # above the largest
        (None, (0.5 * r, 3.0 * r), False),  # no typical radii: the range decides
    ]
    for typical, full, rescaled in cases:
        est.priors = dataclasses.replace(est0.priors, radius_typical_m=typical, radius_range_m=full)
        scale, _ = est.input_scale(s["points"])
        if rescaled:
            assert scale == pytest.approx(np.sqrt(typical[0] * typical[1]) / r)
        else:
            assert scale == 1.0
