"""ucope.stages.revolution: the surface-of-revolution fit against known surfaces and a plain geometric fit, and the
``revolution_fit`` stage on a pose state."""

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ucope.errors import InputError
from ucope.priors import CategoryPriors, PartPrior
from ucope.stages import PoseState, run, stage_params
from ucope.stages.revolution import fit_revolution, looks_cut, refine_revolution


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


def _bottle_scene(seed=3):
    """A bottle's points in the camera frame, its true pose, and a vote pulled 2.2 cm off its axis."""
    rng = np.random.default_rng(seed)
    local, _ = bottle_points(rng, centre=(0.0, 0.0), noise=0.0005)
    R = Rotation.from_euler("xyz", [150, 20, 5], degrees=True).as_matrix()
    t = np.array([0.05, 0.02, 0.6])
    cam = local @ R.T + t
    truth = np.eye(4)
    truth[:3, :3], truth[:3, 3] = R, t
    wrong = truth.copy()
    wrong[:3, 3] += R @ np.array([0.02, 0.0, -0.01])  # a vote pulled off the axis, its box towards another shape
    return cam, truth, wrong, R, t


def test_a_box_far_off_the_points_is_replaced_and_a_close_one_kept():
    cam, truth, wrong, R, t = _bottle_scene()
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
    cam, _, wrong, _, _ = _bottle_scene()
    state = _bottle_state(cam, wrong)
    with pytest.raises(InputError, match="factor"):
        run(["revolution_fit"], state, stage_params(["revolution_fit"], {"revolution_fit.factor": 0.9}))


def _bottle_state(cam, voted, symmetry="y", size=(0.05, 0.26, 0.05)):
    """A one-part pose state: ``cam`` ``(P, 3)`` all the part's points (and its pairs' points), ``voted`` its pose."""
    priors = CategoryPriors("bottle", (PartPrior("body", symmetry, 0.2, (0.09, 0.2, 0.09)),), ())
    P = len(cam)
    state = PoseState(priors, cam, np.zeros((P, 3)), np.zeros(P, np.int64), pair_idx=np.arange(P).reshape(1, -1, 1))
    state.cam_from_part, state.size_m = voted[None].copy(), np.array([size], np.float64)
    return state


def test_the_stage_replaces_the_box_of_a_y_symmetric_part_from_its_pairs_points():
    """The ``revolution_fit`` stage on the scene above: the box and centre of the y-symmetric part come from its
    points (as refine_revolution gives them), the rotation stays, and the record names the part and the move.
    A model whose part is not symmetric does not run it; a close box is kept (an empty record)."""
    cam, truth, wrong, R, t = _bottle_scene()
    state = _bottle_state(cam, wrong)
    records = run(["revolution_fit"], state, stage_params(["revolution_fit"]))
    want_T, want_S, _ = refine_revolution(wrong, np.array([0.05, 0.26, 0.05]), cam)
    np.testing.assert_allclose(state.cam_from_part[0], want_T)
    np.testing.assert_allclose(state.size_m[0], want_S)
    np.testing.assert_allclose(state.cam_from_part[0, :3, 3], t, atol=3e-3)
    assert [r.name for r in records] == ["revolution_fit"]
    assert records[0].changed["parts"] == ["body"] and records[0].changed["rotation_deg"] == pytest.approx(0.0, abs=1e-4)
    assert records[0].changed["translation_m"] == pytest.approx(np.linalg.norm(want_T[:3, 3] - wrong[:3, 3]), abs=1e-6)
    plain = _bottle_state(cam, wrong, symmetry="none")
    assert run(["revolution_fit"], plain, {}) == []
    np.testing.assert_array_equal(plain.cam_from_part[0], wrong)
    close = _bottle_state(cam, truth, size=(0.085, 0.21, 0.085))
    records = run(["revolution_fit"], close, {})
    assert records[0].changed == {}
    np.testing.assert_array_equal(close.cam_from_part[0], truth)
