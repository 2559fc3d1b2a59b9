"""Regenerate the pictures of docs/formats.md: docs/images/vis_frame.png (``--vis`` of a mug and a laptop
in one rendered frame, estimated by the shipped models with their ground truth) and docs/images/view3d.png
(the ``--view-html`` page of the same frame, screenshotted by a headless Chromium when one is installed).

Usage: python scripts/make_format_figures.py
"""

import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(root / "tests"))

import numpy as np  # noqa: E402
from frame_fixtures import SMALL, posed, render_frame  # noqa: E402

from ucope.estimation.draw import DrawnObject, Scene, plot_scenes, project  # noqa: E402
from ucope.estimation.frame import predict_frame  # noqa: E402
from ucope.eval.evaluate import sample_errors  # noqa: E402

out_dir = root / "docs" / "images"
K = (SMALL.fx, SMALL.fy, SMALL.cx, SMALL.cy)
frame = render_frame(
    [("mug", 0, posed(0.7, 30, 30, (-0.16, 0.0, 0.0)), None), ("laptop", 3, posed(0.9, -30, 35, (0.12, 0.05, 0.4)), None)]
)
predict_frame(frame["depth_mm"], K, frame["instance"], {1: "mug", 2: "laptop"})  # warm-up: the timings shown are steady ones
fr = predict_frame(frame["depth_mm"], K, frame["instance"], {1: "mug", 2: "laptop"})
objects = []
for o, truth in zip(fr.objects, frame["objects"], strict=False):
    gt = {
        "cam_from_part": truth["cam_from_part"],
        "size_m": truth["size_m"],
        "joint_pivot": truth["joint_pivot"],
        "joint_axis": truth["joint_axis"],
        "joint_state": truth["joint_state"],
        "joint_type": [{"revolute": 0, "prismatic": 1}[j.type] for j in truth["obj"].joints],
        "part_labels": frame["parts"][tuple(np.round(project(o.points, K)[0][:, ::-1]).astype(int).T)],
    }
    err = sample_errors(o.result, gt)
    objects.append(DrawnObject(o.result, o.points, gt, err, name=f"{o.instance_id}: {o.model}"))
scene = Scene(
    objects, title="a rendered frame: mug (instance 1), laptop (instance 2)", depth_m=frame["depth_mm"] / 1000.0, intrinsics=K
)
print(plot_scenes([scene], out_dir / "vis_frame.png"))

from browser_shot import chromium, screenshot  # noqa: E402

if chromium() is not None:
    from PIL import Image

    from ucope.estimation.view3d import write_html

    with tempfile.TemporaryDirectory() as tmp:
        html = write_html([scene], Path(tmp) / "view.html")
        blue = np.array([31, 119, 180])
        img = screenshot(
            html.as_uri(), lambda im: int((np.abs(im.astype(int) - blue).max(axis=-1) < 40).sum()) > 300, size=(900, 600)
        )
    Image.fromarray(img).save(out_dir / "view3d.png")
    print(out_dir / "view3d.png")
