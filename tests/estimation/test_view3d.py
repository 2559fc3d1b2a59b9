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
    blue, orange = (31, 119, 180), (255, 127, 14)  # the base's and the lid's colours

    def drawn(img):
        return _colour_pixels(img, blue) > 300 and _colour_pixels(img, orange) > 300

    img = screenshot(html.as_uri(), drawn)
    from PIL import Image

    Image.fromarray(img).save(tmp_path / "shot.png")
    # the points and boxes of both parts are drawn in their colours
    assert drawn(img), (_colour_pixels(img, blue), _colour_pixels(img, orange))


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
