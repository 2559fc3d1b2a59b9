import numpy as np
import pytest
from tests_support import make_toy_object

from ucope.errors import InputError
from ucope.geometry.transforms import apply_transform, invert_transform, look_at_rotation, make_transform
from ucope.render.camera import DEFAULT_CAMERA, PinholeCamera
from ucope.render.noise import DepthNoise, apply_depth_noise, depth_to_mm
from ucope.render.raycast import BACKGROUND_LABEL, raycast_depth
from ucope.render.views import ViewConfig, render_view


def _top_down_pose(height=1.0):
    eye = np.array([0.0, height, 0.0])
    R = look_at_rotation(eye, [0.0, 0.0, 0.0], up=(0.0, 0.0, -1.0))
    return invert_transform(make_transform(R, eye))


def test_backproject_project_round_trip(rng):
    cam = DEFAULT_CAMERA
    depth = rng.uniform(0.5, 2.0, size=(cam.height, cam.width))
    pts, pix = cam.backproject(depth)
    uv = cam.project(pts)
    np.testing.assert_allclose(uv, pix[:, ::-1], atol=1e-3)
    with pytest.raises(InputError):
        cam.backproject(depth[:10])
    with pytest.raises(InputError):
        PinholeCamera(-1, 1, 0, 0, 10, 10)


def test_raycast_depth_of_a_plate_seen_from_above():
    obj = make_toy_object()
    cam_from_obj = _top_down_pose(1.0)
    v, f, lab = obj.posed_geometry([0.0])  # closed; object frame = base box centre, lid top at y = 0.07
    depth, labels = raycast_depth(apply_transform(cam_from_obj, v), f, lab, DEFAULT_CAMERA)
    c = (DEFAULT_CAMERA.height // 2, DEFAULT_CAMERA.width // 2)
    assert labels[c] == 1
    assert depth[c] == pytest.approx(1.0 - 0.07, abs=1e-9)
    assert labels[0, 0] == BACKGROUND_LABEL and depth[0, 0] == 0.0
    # the plate covers a 0.4 x 0.3 m rectangle at 0.93 m: its pixel area is predictable
    area = (labels == 1).sum()
    expect = (0.4 * DEFAULT_CAMERA.fx / 0.93) * (0.3 * DEFAULT_CAMERA.fy / 0.93)
    assert area == pytest.approx(expect, rel=0.03)


def test_floor_is_analytic():
    cam_from_obj = _top_down_pose(1.0)
    floor = (apply_transform(cam_from_obj, np.zeros((1, 3)))[0], cam_from_obj[:3, 1])
    depth, labels = raycast_depth(np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0, int), DEFAULT_CAMERA, floor_cam=floor)
    np.testing.assert_allclose(depth, 1.0, atol=1e-9)  # looking straight down: depth = height everywhere
    assert np.all(labels == BACKGROUND_LABEL)


def test_noise_model(rng):
    d = np.full((60, 80), 1.5)
    d[:, :40] = 0.8
    d[:5, :5] = 0
    clean = apply_depth_noise(d, DepthNoise(enabled=False), rng)
    np.testing.assert_array_equal(clean, d)
    noisy = apply_depth_noise(d, DepthNoise(), rng)
    assert np.all(noisy[:5, :5] == 0)
    valid = noisy > 0
    err = np.abs(noisy - d)[valid & (np.abs(noisy - d) < 0.05)]
    assert 0.0005 < err.mean() < 0.02  # noise of the right order of magnitude
    far, near = np.abs(noisy - d)[:, 45:][valid[:, 45:]], np.abs(noisy - d)[:, :35][valid[:, :35]]
    assert np.median(far) > np.median(near)  # grows with depth
    assert (~valid[:, 39:41]).mean() > 0.2  # pixels go missing at the depth edge
    assert depth_to_mm(np.array([[1.2344, np.nan, -1.0]])).tolist() == [[1234, 0, 0]]


def test_render_view_is_deterministic_and_consistent():
    obj = make_toy_object()
    cfg = ViewConfig(distance_range_m=(0.8, 1.2), elevation_range_deg=(30, 60))
    a = render_view(obj, cfg, np.random.default_rng(5))
    b = render_view(obj, cfg, np.random.default_rng(5))
    np.testing.assert_array_equal(a.depth_mm, b.depth_mm)
    np.testing.assert_array_equal(a.mask, b.mask)
    assert a.depth_mm.dtype == np.uint16 and a.mask.dtype == np.uint8
    assert set(np.unique(a.mask).tolist()) <= {0, 1, 254, 255}
    assert (a.mask < 2).sum() > 500
    np.testing.assert_allclose(a.cam_from_part, a.cam_from_object @ obj.object_from_part(a.joint_state))
