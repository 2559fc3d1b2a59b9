"""Whole-object voting entry points; here the direct-regression baseline's part scores."""

import numpy as np
import torch

from ucope.geometry.transforms import make_transform
from ucope.model.checkpoint import find_model, load_model
from ucope.voting import regressed_object, regression_scores


def _box_points(rng, size, n):
    """``n`` points on the surface of a box of ``size`` centred at the origin (its own frame)."""
    p = rng.uniform(-0.5, 0.5, (n, 3)) * size
    axis = rng.integers(0, 3, n)
    p[np.arange(n), axis] = np.sign(rng.uniform(-1, 1, n)) * 0.5 * size[axis]
    return p


def test_regression_scores_see_whether_the_box_fits_the_part_points():
    rng = np.random.default_rng(0)
    size = np.array([0.30, 0.05, 0.10])
    T = make_transform(np.eye(3), np.array([0.0, 0.0, 0.8]))
    pts = _box_points(rng, size, 400) + T[:3, 3]
    right = regression_scores(pts, None, T[None], size[None])
    assert right.shape == (1,) and right[0] == 1.0
    # the same box turned 90 degrees about z: the long side no longer covers the points
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    wrong = regression_scores(pts, None, make_transform(Rz, T[:3, 3])[None], size[None])
    assert wrong[0] < 0.5
    # a box shifted by half its length
    shifted = regression_scores(pts, None, make_transform(np.eye(3), T[:3, 3] + [0.15, 0, 0])[None], size[None])
    assert 0.3 < shifted[0] < 0.7


def test_regression_scores_weigh_by_segmentation_confidence_and_give_an_unseen_part_zero():
    rng = np.random.default_rng(1)
    size = np.array([0.2, 0.2, 0.2])
    T = np.stack([make_transform(np.eye(3), np.array([0.0, 0.0, 1.0])), make_transform(np.eye(3), np.array([1.0, 0.0, 1.0]))])
    pts = _box_points(rng, size, 300) + T[0, :3, 3]
    prob = np.tile([0.7, 0.1, 0.2], (300, 1))  # every point part 0 with probability 0.7; nothing is part 1
    s = regression_scores(pts, prob, T, np.stack([size, size]))
    np.testing.assert_allclose(s, [0.7, 0.0])


def test_regressed_object_scores_are_not_all_one():
    """The baseline used to give every part the score 1.0, so its mAP depended on record order only."""
    rng = np.random.default_rng(2)
    priors = load_model(find_model("mug"))[0].cfg.priors
    size = np.asarray(priors.mean_size_m, np.float64).reshape(1, 3)
    pts = _box_points(rng, size[0], 256) + [0.0, 0.0, 0.7]
    R = torch.eye(3, dtype=torch.float64).reshape(1, 1, 3, 3)
    good = {"rotation": R, "centre_m": torch.tensor([[[0.0, 0.0, 0.7]]]), "gamma": torch.zeros(1, 1, 3)}
    far = dict(good, centre_m=torch.tensor([[[0.0, 0.0, 0.9]]]))
    s_good = regressed_object(pts, good, priors)["score"]
    s_far = regressed_object(pts, far, priors)["score"]
    assert s_good[0] > 0.9 and s_far[0] < 0.2
