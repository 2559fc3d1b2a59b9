"""The 3D viewer (viser): the scene it builds, and its standalone HTML rendered for real by a headless
Chromium (skipped where no Chromium is installed: ``apt-get install chromium``)."""

import sys

import numpy as np
import pytest
from browser_shot import chromium, screenshot

from ucope.errors import InputError
from ucope.estimation.draw import DrawnObject, Scene
from ucope.estimation.result import JointEstimate, PartEstimate, PoseResult


def _laptop_like() -> tuple[PoseResult, np.ndarray]:
    """A two-part result (a base slab and a lid standing up behind it) and points on both parts."""
    base, lid = np.eye(4), np.eye(4)
    base[:3, 3] = [0.0, 0.35, 0.8]  # below the camera: seen from above
    lid[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    lid[:3, 3] = [0.0, 0.25, 0.9]
    size = np.array([0.3, 0.02, 0.2])
    g = np.random.default_rng(0).uniform(-0.5, 0.5, (3000, 2))
    pts_base = np.c_[0.3 * g[:1500, 0], np.full(1500, 0.34), 0.8 + 0.2 * g[:1500, 1]]
    pts_lid = np.c_[0.3 * g[1500:, 0], 0.25 + 0.2 * g[1500:, 1], np.full(1500, 0.9)]
    r = PoseResult(
        "laptop",
        [PartEstimate(0, "base", base, size, 0.9), PartEstimate(1, "lid", lid, size, 0.8)],
        [JointEstimate("revolute", 0, 1, np.array([0.0, 0.34, 0.9]), np.array([-1.0, 0, 0]), 1.57, 0.9)],
        np.r_[np.zeros(1500, np.int64), np.ones(1500, np.int64)],
        model="laptop",
    )
    return r, np.r_[pts_base, pts_lid]


def test_missing_viser_names_the_extra(monkeypatch):
    from ucope.estimation import view3d

    monkeypatch.setitem(sys.modules, "viser", None)
    with pytest.raises(InputError, match=r'pip install "ucope\[view\]"'):
        view3d.viser_module()


def test_scene_holds_clouds_boxes_triads_and_joints():
    pytest.importorskip("viser")
    from ucope.estimation.view3d import _server, build_scene

    r, pts = _laptop_like()
    server = _server("127.0.0.1", 0, quiet=True)
    try:
        names = build_scene(server, [Scene([DrawnObject(r, pts)], title="a"), Scene([DrawnObject(r, None)], title="b")])
    finally:
        server.stop()
    for n in (
        "/scene_0/object_0/points",
        "/scene_0/object_0/boxes",
        "/scene_0/object_0/part_1",
        "/scene_0/object_0/joint_0",
        "/scene_0/object_0/label_0",
        "/scene_0/object_0/box_1",
        "/scene_1/object_0/boxes",
    ):
        assert n in names
    assert "/scene_1/object_0/points" not in names
    with pytest.raises(InputError, match="nothing to show"):
        build_scene(None, [])


def _colour_pixels(img: np.ndarray, rgb, tol: int = 40) -> int:
    return int((np.abs(img.astype(int) - np.array(rgb)).max(axis=-1) < tol).sum())


@pytest.mark.skipif(chromium() is None, reason="no Chromium to render the page")
def test_html_view_renders_in_a_headless_browser(tmp_path):
    pytest.importorskip("viser")
    from ucope.estimation.view3d import write_html

    r, pts = _laptop_like()
    html = write_html([Scene([DrawnObject(r, pts)], title="laptop")], tmp_path / "view.html")
    assert html.stat().st_size > 100_000 and b"__VISER_EMBED_DATA__" in html.read_bytes()
    orange, purple = (255, 140, 0), (148, 103, 189)  # the base's and the lid's colours

    def drawn(img):
        return _colour_pixels(img, orange) > 300 and _colour_pixels(img, purple) > 300

    img = screenshot(html.as_uri(), drawn)
    from PIL import Image

    Image.fromarray(img).save(tmp_path / "shot.png")
    # the points and boxes of both parts are drawn in their colours
    assert drawn(img), (_colour_pixels(img, orange), _colour_pixels(img, purple))


def test_live_viewer_serves_the_page():
    pytest.importorskip("viser")
    import urllib.request

    from ucope.estimation.view3d import show

    r, pts = _laptop_like()
    server = show([Scene([DrawnObject(r, pts)])], port=0, block=False)
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{server.get_port()}/", timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read(2000).lower()
    finally:
        server.stop()


def test_html_has_a_legend_and_instance_labels_and_the_view_frames_the_object(tmp_path):
    pytest.importorskip("viser")
    from ucope.estimation.view3d import VIEW_FILL, VIEW_FOV_DEG, _opening_view, _server, build_scene, write_html

    r, pts = _laptop_like()
    r.parts[1].score = 0.3
    r.warnings = ["few points on the lid"]
    scene = Scene([DrawnObject(r, pts, name="2: laptop")], title="frame 7")
    text = write_html([scene], tmp_path / "view.html").read_text()
    legend = text[text.index('<div id="ucope-legend"') :]
    for item in (
        "2: laptop: base  score 0.90",
        "2: laptop: lid  score 0.30 (low)",
        "few points on the lid",
        "frame 7",
        "#ff8c00",
    ):
        assert item in legend, item
    server = _server("127.0.0.1", 0, quiet=True)
    try:
        build_scene(server, [scene])
        eye, look = np.asarray(server.initial_camera.position), np.asarray(server.initial_camera.look_at)
        labels = {h.text for h in server.scene._handle_from_node_name.values() if hasattr(h, "text") and isinstance(h.text, str)}
    finally:
        server.stop()
    assert "2: laptop: lid 0.30 (low)" in labels
    # the opening view: along the line of sight, close enough for the object to span most of the view's height
    from ucope.geometry.boxes import box_corners

    corners = np.concatenate([box_corners(r.cam_from_part, r.size_m).reshape(-1, 3), pts])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    span = np.linalg.norm(hi - lo) / (2 * np.linalg.norm(eye - look) * np.tan(np.radians(VIEW_FOV_DEG) / 2))
    assert span == pytest.approx(VIEW_FILL, rel=1e-6) and np.allclose(_opening_view(lo, hi)[1], look)
