"""ucope.voting.revolution: the surface-of-revolution fit against known surfaces and a plain geometric fit."""

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ucope.errors import InputError
from ucope.voting import VotingOptions
from ucope.voting.revolution import fit_revolution, looks_cut, refine_revolution


def bottle_points(rng, n=3000, centre=(0.01, -0.02), radius=0.045, neck=0.015, height=0.2, arc_deg=200.0, noise=0.0):
    """Points on the visible side of a bottle (a cylinder of ``radius`` for the lower 60 %, narrowing to a
    ``neck`` radius at the top), axis parallel to y through ``centre`` (x, z), heights ``[-h/2, h/2]``."""
    y = rng.uniform(-height / 2, height / 2, n)
    u = (y + height / 2) / height
    r = np.where(u < 0.6, radius, radius + (neck - radius) * np.clip((u - 0.6) / 0.25, 0, 1))
    a = np.radians(rng.uniform(-arc_deg / 2, arc_deg / 2, n)) - np.pi / 2  # facing -z: the camera side
    pts = np.stack([centre[0] + r * np.cos(a), y, centre[1] + r * np.sin(a)], axis=1)
    return pts + rng.normal(scale=noise, size=pts.shape), r


def reference_fit(local, slices=8):
    """A plain geometric fit: shared axis and one radius per slice minimising the radial distances."""
    y = local[:, 1]
    lo, hi = np.percentile(y, [0.5, 99.5])
    slot = np.clip(((y - lo) / (hi - lo) * slices).astype(int), 0, slices - 1)

    def residual(x):
        c, r = x[:2], x[2:]
        return np.hypot(local[:, 0] - c[0], local[:, 2] - c[1]) - r[slot]

    x0 = np.concatenate([local[:, [0, 2]].mean(0), np.full(slices, 0.03)])
    return least_squares(residual, x0).x


def test_the_fit_finds_the_axis_and_radii_of_a_bottle_seen_from_one_side():
    rng = np.random.default_rng(0)
    pts, _ = bottle_points(rng, noise=0.0005)
    fit = fit_revolution(pts)
    ref = reference_fit(pts)
    assert fit is not None and len(fit.radii_m) == 8
    np.testing.assert_allclose(fit.axis_xz, [0.01, -0.02], atol=1.5e-3)
    np.testing.assert_allclose(fit.axis_xz, ref[:2], atol=1e-3)
    np.testing.assert_allclose(fit.radii_m, ref[2:], atol=1.5e-3)
    assert abs(fit.radii_m.max() - 0.045) < 1.5e-3
    np.testing.assert_allclose(fit.size_m, [0.09, 0.2, 0.09], atol=4e-3)
    np.testing.assert_allclose(fit.centre_m, [0.01, 0.0, -0.02], atol=2e-3)
    assert fit.spread < 0.05


def test_stray_points_count_less_than_the_surface():
    rng = np.random.default_rng(1)
    pts, _ = bottle_points(rng, noise=0.0005)
    stray = rng.uniform([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1], size=(150, 3))  # 5 %
    fit = fit_revolution(np.concatenate([pts, stray]))
    np.testing.assert_allclose(fit.axis_xz, [0.01, -0.02], atol=3e-3)
    assert abs(fit.radii_m.max() - 0.045) < 3e-3
    assert abs(fit.size_m[1] - 0.2) < 0.01


def test_points_that_do_not_bend_about_an_axis_give_no_fit_or_a_poor_one():
    rng = np.random.default_rng(2)
    plane = np.stack([rng.uniform(-0.05, 0.05, 500), rng.uniform(-0.1, 0.1, 500), rng.normal(0, 1e-4, 500)], 1)
    fit = fit_revolution(plane)
    assert fit is None or fit.radii_m.max() > 0.5 or fit.spread > 0.08
    assert fit_revolution(plane[:5]) is None  # fewer points than one slice needs


def test_a_box_far_off_the_points_is_replaced_and_a_close_one_kept():
    rng = np.random.default_rng(3)
    local, _ = bottle_points(rng, centre=(0.0, 0.0), noise=0.0005)
    R = Rotation.from_euler("xyz", [150, 20, 5], degrees=True).as_matrix()
    t = np.array([0.05, 0.02, 0.6])
    cam = local @ R.T + t
    truth = np.eye(4)
    truth[:3, :3], truth[:3, 3] = R, t
    wrong = truth.copy()
    wrong[:3, 3] += R @ np.array([0.02, 0.0, -0.01])  # a vote pulled off the axis, its box towards another shape
    T, S, replaced = refine_revolution(wrong, np.array([0.05, 0.26, 0.05]), cam)
    assert replaced
    np.testing.assert_allclose(T[:3, :3], R)  # the rotation is the vote's
    np.testing.assert_allclose(T[:3, 3], t, atol=3e-3)
    np.testing.assert_allclose(S, [0.09, 0.2, 0.09], atol=5e-3)
    close = np.array([0.085, 0.21, 0.085])  # within 1.2x of the fit on every axis: the vote stands
    T2, S2, replaced2 = refine_revolution(truth, close, cam)
    assert not replaced2
    np.testing.assert_array_equal(S2, close)
    np.testing.assert_array_equal(T2, truth)


def test_points_cut_off_at_one_end_keep_the_vote():
    """An occluder hiding the lower part: the points end well inside the voted box at the bottom and at
    its top: their height says little about the whole part, so the (right) vote stands."""
    rng = np.random.default_rng(4)
    local, _ = bottle_points(rng, centre=(0.0, 0.0), noise=0.0005)
    top = local[local[:, 1] > -0.03]
    truth = np.eye(4)
    truth[:3, 3] = [0.0, 0.0, 0.6]
    T, S, replaced = refine_revolution(truth, np.array([0.09, 0.2, 0.09]) * [0.7, 1.0, 0.7], top + truth[:3, 3])
    assert looks_cut(np.percentile(top[:, 1], [0.5, 99.5]), 0.2)
    assert not replaced
    np.testing.assert_array_equal(T, truth)
    assert not looks_cut(np.array([-0.09, 0.09]), 0.2)  # about evenly short at both ends: not cut
    assert not looks_cut(np.array([-0.1, 0.1]), 0.2)


def test_bad_settings_are_named():
    with pytest.raises(InputError, match="factor"):
        refine_revolution(np.eye(4), np.ones(3), np.zeros((10, 3)), factor=1.0)
    with pytest.raises(InputError, match="shape"):
        fit_revolution(np.zeros((10, 2)))
    with pytest.raises(InputError, match="finite"):
        fit_revolution(np.full((10, 3), np.nan))
    with pytest.raises(InputError, match="revolution_factor"):
        VotingOptions(revolution_factor=0.9)
