import numpy as np
import pytest
from frame_fixtures import SMALL, needs_models, rgb_of

from ucope.errors import InputError
from ucope.estimation.draw import (
    AXIS_COLOURS,
    PART_PALETTE,
    DrawnObject,
    Scene,
    clip_segment,
    draw_overlay,
    fit_camera,
    legend_handles,
    legend_lines,
    plot_scenes,
    project,
    splat_depth,
)
from ucope.estimation.result import JointEstimate, PartEstimate, PoseResult

pytest.importorskip("matplotlib")
K = (SMALL.fx, SMALL.fy, SMALL.cx, SMALL.cy)


def _count_colour(img: np.ndarray, hex_colour: str, tol: int = 30) -> int:
    rgb = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(img.astype(int) - rgb).max(axis=-1) < tol).sum())


def test_projection_fitted_camera_and_splatting():
    uv, ok = project(np.array([[0.1, -0.05, 1.0], [0.0, 0.0, -1.0]]), K)
    np.testing.assert_allclose(uv[0], [SMALL.fx * 0.1 + SMALL.cx, -SMALL.fy * 0.05 + SMALL.cy])
    assert ok.tolist() == [True, False]
    pts = np.random.default_rng(0).uniform([-0.2, -0.1, 1.0], [0.2, 0.1, 1.3], (500, 3))
    Kv = fit_camera(pts, 480, 360)
    uv, _ = project(pts, Kv)
    assert uv.min() >= 0 and uv[:, 0].max() < 480 and uv[:, 1].max() < 360
    d = splat_depth(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]), K, (240, 320), radius=1)
    r, c = int(round(SMALL.cy)), int(round(SMALL.cx))
    assert d[r, c] == 1.0 and d[r + 1, c + 1] == 1.0 and np.isnan(d[0, 0])  # the nearest point wins, 3x3 splat
    with pytest.raises(InputError, match="in front of the camera"):
        fit_camera(np.array([[0.0, 0.0, -1.0]]))


def test_legend_lines_carry_scores_states_and_errors():
    parts = [PartEstimate(0, "base", np.eye(4), np.ones(3), 0.81), PartEstimate(1, "lid", np.eye(4), np.ones(3), 0.7)]
    r = PoseResult(
        "laptop", parts, [JointEstimate("revolute", 0, 1, np.zeros(3), np.array([1.0, 0, 0]), np.pi / 2)], np.zeros(3, np.int64)
    )
    err = {
        "parts": [{"rotation_deg": 2.5, "translation_m": 0.012, "translation_norm": 0.1, "iou": 0.8}] * 2,
        "joints": [{"joint_type": "revolute", "axis_deg": 1.0, "pivot_m": 0.02, "state_error": 4.0, "state_unit": "deg"}],
    }
    p, j = legend_lines(DrawnObject(r, errors=err))
    assert p[0] == "base  score 0.81  | err 2.5 deg, 1.2 cm, IoU 0.80"
    assert j[0] == "joint base->lid (revolute) 90.0 deg  | err axis 1.0 deg, pivot 2.0 cm, state 4.0 deg"
    p, j = legend_lines(DrawnObject(r, truth=True))
    assert p[0] == "base  (ground truth)" and "err" not in j[0]


@needs_models
def test_plot_over_depth_and_rgb_with_legend(tmp_path, laptop_and_mug_frame):
    frame, fr = laptop_and_mug_frame
    mug = fr.objects[0]
    img = mug.result.plot(points=mug.points, depth=frame["depth_mm"], rgb=rgb_of(frame), intrinsics=K, out=tmp_path / "mug.png")
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8 and img.shape[1] > 1200  # depth, RGB and 3D panels
    assert (tmp_path / "mug.png").stat().st_size > 20_000
    assert _count_colour(img, PART_PALETTE[0]) > 200  # the mug's part colour: box edges, points, legend
    assert _count_colour(img, "#e41a1c", 40) > 20 and _count_colour(img, "#2ca02c", 40) > 20  # x and y triad arrows


@needs_models
def test_plot_of_a_cloud_with_its_ground_truth(tmp_path, laptop_sample_result):
    s, r, err = laptop_sample_result
    img = r.plot(points=s["points"], sample=s, errors=err, title="laptop", out=tmp_path / "laptop.png")
    assert img.shape[1] < 1200  # no RGB panel: depth (splatted through the sample's camera) and 3D
    assert _count_colour(img, "#ff7f0e") > 200


def test_bad_picture_inputs():
    r = PoseResult(
        "mug", [PartEstimate(0, "mug", np.eye(4) + np.diag([0, 0, 0, 0]), np.ones(3) * 0.1, 0.5)], [], np.zeros(0, np.int64)
    )
    r.parts[0].cam_from_part[2, 3] = 1.0
    with pytest.raises(InputError, match="intrinsics"):
        r.plot(depth=np.ones((10, 10)))
    with pytest.raises(InputError, match="one camera"):
        r.plot(depth=np.ones((10, 10)), rgb=np.zeros((5, 5, 3), np.uint8), intrinsics=K)
    with pytest.raises(InputError, match="nothing to plot"):
        plot_scenes([], "x.png")


def _hsv(hex_colour: str) -> tuple[float, float, float]:
    import colorsys

    r, g, b = (int(hex_colour[i : i + 2], 16) / 255 for i in (1, 3, 5))
    h, s, v = colorsys.rgb_to_hsv(r, g, b)
    return 360.0 * h, s, v


def _hue(hex_colour: str) -> float:
    return _hsv(hex_colour)[0]


def test_part_colours_cannot_be_taken_for_triad_axes():
    for c in PART_PALETTE:
        if _hsv(c)[1] < 0.1:  # a grey has no hue
            continue
        for axis in AXIS_COLOURS:
            d = abs(_hue(c) - _hue(axis)) % 360
            assert min(d, 360 - d) >= 25, (c, axis)  # no part is red, green or blue


def test_clip_segment_keeps_direction_and_cuts_at_the_box():
    a, b = clip_segment([10, 10], [30, 10], (0, 20, 0, 20))
    np.testing.assert_allclose(a, [10, 10])
    np.testing.assert_allclose(b, [20, 10])  # the head cut back to the box edge
    assert clip_segment([-5, 30], [30, 30], (0, 20, 0, 20)) is None
    a, b = clip_segment([-10, 5], [10, 5], (0, 20, 0, 20))
    np.testing.assert_allclose(a, [0, 5])


def _two_part(score_lid: float, warnings=()) -> PoseResult:
    base, lid = np.eye(4), np.eye(4)
    base[:3, 3] = [0.0, 0.05, 0.6]
    lid[:3, 3] = [0.0, -0.03, 0.65]
    parts = [
        PartEstimate(0, "base", base, np.array([0.2, 0.02, 0.15]), 0.9),
        PartEstimate(1, "lid", lid, np.array([0.2, 0.15, 0.02]), score_lid),
    ]
    # a joint axis far longer than the image is wide: its head falls outside the picture
    joint = JointEstimate("revolute", 0, 1, np.array([0.0, 0.04, 0.66]), np.array([1.0, 0.0, 0.0]), 1.2)
    return PoseResult("laptop", parts, [joint], np.zeros(0, np.int64), warnings=list(warnings))


def test_arrow_with_its_head_outside_the_image_is_drawn_to_the_edge():
    import matplotlib.pyplot as plt
    from matplotlib.text import Annotation

    r = _two_part(0.9)
    for p in r.parts:  # the object at the image's right edge: the joint axis (+x) leaves the picture
        p.cam_from_part[0, 3] += 0.28
    r.joints[0].pivot_m = r.joints[0].pivot_m + [0.28, 0.0, 0.0]
    fig, ax = plt.subplots()
    depth = np.full((240, 320), 0.6)
    draw_overlay(ax, Scene([DrawnObject(r)]), K, depth, "depth", legend=False, zoom=False)
    fig.canvas.draw()
    arrows = [c for c in ax.get_children() if isinstance(c, Annotation) and c.arrow_patch is not None]
    black = [a for a in arrows if tuple(a.arrow_patch.get_edgecolor()[:3]) == (0.0, 0.0, 0.0)]
    assert len(black) == 1, len(arrows)
    head, tail = np.array(black[0].xy), np.array(black[0].xyann)
    full_head = project(r.joints[0].pivot_m + [0.09, 0.0, 0.0], K)[0][0]
    assert full_head > 320  # the head lies outside the image...
    assert head[0] == pytest.approx(319.5) and 200 < tail[0] < 300  # ...so the arrow is drawn up to its edge
    plt.close(fig)


def test_low_scores_dotted_with_their_score_and_warnings_in_the_legend():
    import matplotlib.pyplot as plt

    r = _two_part(0.29, warnings=["the cloud holds 40 points"])
    p, _ = legend_lines(DrawnObject(r))
    assert p[1] == "lid  score 0.29 (low)" and p[0] == "base  score 0.90"
    labels = [h.get_label() for h in legend_handles(Scene([DrawnObject(r)]))]
    assert "warning: the cloud holds 40 points" in labels and any("score < 0.5" in t for t in labels)
    fig, ax = plt.subplots()
    depth = np.full((240, 320), 0.6)
    draw_overlay(ax, Scene([DrawnObject(r)]), K, depth, "depth", legend=False, zoom=False)
    texts = [t.get_text() for t in ax.texts]
    assert "lid 0.29" in texts and "base 0.90" not in texts  # only the doubtful part carries its score in the image
    plt.close(fig)
