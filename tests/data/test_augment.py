"""Training augmentation (ucope.data.augment): seeded, label-keeping, and safe on what generated pools hold."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.data.augment import MIN_DEPTH_M, AugmentConfig, augment_sample, sample_context
from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import InputError

EVERYTHING = AugmentConfig(
    probability=1.0, p_occlude=1.0, p_bleed=1.0, p_floor=1.0, p_outliers=1.0, p_noise=1.0, p_axial=1.0, p_resample=0.0
)


@pytest.fixture(scope="module")
def sample():
    s = make_sample(GenerateConfig(category="laptop", split="train", num=1, views_per_instance=1, max_points=1500), 0)
    assert len(s["bg_points"]) > 100
    return s


def test_the_same_rng_gives_the_same_item_and_nothing_applied_gives_the_sample(sample):
    a = augment_sample(sample, np.random.default_rng(5), EVERYTHING)
    b = augment_sample(sample, np.random.default_rng(5), EVERYTHING)
    assert a[2] and np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    p, lab, done = augment_sample(sample, np.random.default_rng(5), AugmentConfig(probability=0.0))
    assert not done and np.array_equal(p, sample["points"]) and np.array_equal(lab, sample["part_labels"])


def test_added_points_are_labelled_not_the_object(sample):
    cfg = AugmentConfig(probability=1.0, p_occlude=0, p_bleed=0, p_floor=1.0, p_outliers=1.0, p_noise=0, p_axial=0, p_resample=0)
    p, lab, _ = augment_sample(sample, np.random.default_rng(1), cfg)
    obj = lab >= 0
    assert obj.sum() == len(sample["points"]) and (~obj).sum() > 0
    # the object's points are the sample's, in order (floor and outliers only add)
    np.testing.assert_array_equal(p[obj], sample["points"])
    np.testing.assert_array_equal(lab[obj], sample["part_labels"])


def test_pool_points_at_the_camera_are_left_out_and_never_crash_the_noise(sample):
    """Generator-2 pools hold a few points at z = 1 mm (the depth noise's quantisation floor); isotropic
    noise could push them behind the camera, where the axial noise refuses the cloud: a training run died
    on one at step 2,000-3,000 before they were left out."""
    bad = dict(sample)
    near = np.array([[0.0, 0.0, 0.001]] * 50, np.float32)
    bad["bg_points"] = np.concatenate([near, sample["bg_points"]])
    bad["bg_rank"] = np.concatenate([np.zeros(50, np.float32), sample["bg_rank"]])
    bad["bg_clutter"] = np.concatenate([np.zeros(50, bool), sample["bg_clutter"]])
    assert len(sample_context(bad).background.points) == len(sample["bg_points"])
    assert np.all(sample_context(bad).background.points[:, 2] >= MIN_DEPTH_M)
    cfg = AugmentConfig(
        probability=1.0, p_occlude=0, p_bleed=1.0, bleed_range=(0.35, 0.35), p_floor=1.0, floor_range=(1.0, 1.0),
        p_outliers=0, p_noise=1.0, noise_m=(0.007, 0.007), p_axial=1.0, p_resample=0,
    )  # fmt: skip
    for seed in range(20):
        p, _, _ = augment_sample(bad, np.random.default_rng(seed), cfg)
        assert np.all(p[:, 2] > 0.0)


def test_outliers_of_a_near_object_behind_the_camera_are_dropped_before_the_axial_noise(sample):
    """A drawer training run died at step 0-50: the 1.5x box of a large cabinet seen from near by reaches
    behind the camera, and the axial noise refuses a cloud with points at z <= 0."""
    near = dict(sample)
    shift = np.array([0.0, 0.0, 0.08 - float(np.min(sample["points"][:, 2]))])  # nearest object point at 8 cm
    near["points"] = (sample["points"] + shift).astype(np.float32)
    T = np.array(sample["cam_from_part"], np.float64)
    T[:, :3, 3] += shift
    near["cam_from_part"] = T
    near["size_m"] = np.asarray(sample["size_m"]) * 3.0  # a box far deeper than the visible points
    cfg = AugmentConfig(
        probability=1.0, p_occlude=0, p_bleed=0, p_floor=0, p_outliers=1.0, outlier_range=(0.2, 0.2),
        p_noise=0, p_axial=1.0, p_resample=0,
    )  # fmt: skip
    for seed in range(5):
        p, lab, done = augment_sample(near, np.random.default_rng(seed), cfg)
        assert done and np.all(p[:, 2] > 0.0) and len(p) == len(lab)
        assert np.count_nonzero(lab >= 0) == len(sample["points"])  # the object's own points are all kept


def test_bad_settings_are_named():
    with pytest.raises(InputError, match="p_floor"):
        AugmentConfig(p_floor=1.5)
    with pytest.raises(InputError, match="noise_m"):
        AugmentConfig(noise_m=(0.01, 0.001))


def test_settings_change_the_named_fields_and_round_trip_through_json_lists():
    cfg = AugmentConfig.from_settings(0.5, {"p_noise": 0.8, "noise_m": [0.002, 0.01], "resample_points": [150.0, 900.0]})
    assert cfg.probability == 0.5 and cfg.p_noise == 0.8
    assert cfg.noise_m == (0.002, 0.01) and cfg.resample_points == (150, 900)
    assert cfg.p_floor == AugmentConfig().p_floor  # the rest keep the table's values
    assert AugmentConfig.from_settings(0.7, None) == AugmentConfig()


def test_settings_that_are_unknown_or_malformed_are_named():
    with pytest.raises(InputError, match="unknown augmentation setting.*p_nois.*known: p_occlude"):
        AugmentConfig.from_settings(0.5, {"p_nois": 0.5})
    with pytest.raises(InputError, match="probability"):
        AugmentConfig.from_settings(0.5, {"probability": 0.5})  # that is the first argument, not a setting
    with pytest.raises(InputError, match="noise_m must be a range of two numbers"):
        AugmentConfig.from_settings(0.5, {"noise_m": 0.005})
    with pytest.raises(InputError, match="p_noise must be a probability"):
        AugmentConfig.from_settings(0.5, {"p_noise": "often"})
    with pytest.raises(InputError, match="p_noise must be a probability in"):
        AugmentConfig.from_settings(0.5, {"p_noise": 2.0})


def test_stronger_noise_settings_move_the_points_further(sample):
    """Only isotropic noise, always on: the settings' range is what the points see."""
    only_noise = dict(p_occlude=0.0, p_bleed=0.0, p_floor=0.0, p_outliers=0.0, p_axial=0.0, p_resample=0.0, p_noise=1.0)
    weak = AugmentConfig.from_settings(1.0, {**only_noise, "noise_m": [0.001, 0.001]})
    strong = AugmentConfig.from_settings(1.0, {**only_noise, "noise_m": [0.01, 0.01]})
    pw, _, _ = augment_sample(sample, np.random.default_rng(3), weak)
    ps, _, _ = augment_sample(sample, np.random.default_rng(3), strong)
    dw = np.linalg.norm(pw - sample["points"], axis=1).mean()
    ds = np.linalg.norm(ps - sample["points"], axis=1).mean()
    # the mean length of a 3D Gaussian step is 1.596 sigma
    assert dw == pytest.approx(1.596e-3, rel=0.1) and ds == pytest.approx(1.596e-2, rel=0.1)
