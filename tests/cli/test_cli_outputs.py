"""The command line's pictures, viewer export, BOP CSV, several objects per frame and data-set formats."""

import json

import numpy as np
import pytest
from frame_fixtures import (
    SMALL,
    needs_models,
    posed,
    render_frame,
    rgb_of,
    save_json,
    save_png,
    write_artimage,
    write_bop_scene,
    write_nocs_frame,
)

from ucope.cli.main import main
from ucope.estimation.export import read_bop_csv
from ucope.estimation.result import result_schema

pytestmark = needs_models


@pytest.fixture(scope="module")
def frame_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("frame")
    frame = render_frame(
        [("mug", 0, posed(0.7, 30, 30, (-0.16, 0.0, 0.0)), None), ("laptop", 0, posed(0.9, -30, 35, (0.12, 0.05, 0.4)), None)]
    )
    save_png(d / "000042.png", frame["depth_mm"])
    save_png(d / "instances.png", frame["instance"])
    save_png(d / "rgb.png", rgb_of(frame))
    save_json(d / "K.json", {"fx": SMALL.fx, "fy": SMALL.fy, "cx": SMALL.cx, "cy": SMALL.cy})
    return d, frame


def test_predict_several_objects_in_one_frame(frame_files, tmp_path, capsys):
    d, _ = frame_files
    argv = [
        "predict",
        "--instances",
        "1=mug",
        "2=laptop",
        "--depth",
        str(d / "000042.png"),
        "--mask",
        str(d / "instances.png"),
        "--intrinsics",
        str(d / "K.json"),
        "--rgb",
        str(d / "rgb.png"),
        "--out",
        str(tmp_path / "frame.json"),
        "--vis",
        str(tmp_path / "frame.png"),
        "--bop-csv",
        str(tmp_path / "frame.csv"),
        "--bop-scene-id",
        "3",
        "--pairs",
        "4000",
    ]
    assert main(argv) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "instance 1 (mug)" in out and "instance 2 (laptop)" in out
    doc = json.loads((tmp_path / "frame.json").read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(doc, result_schema())
    assert [o["model"] for o in doc["objects"]] == ["mug", "laptop"] and doc["source"]["rgb"].endswith("rgb.png")
    rows = read_bop_csv(tmp_path / "frame.csv")
    # obj_id: the instance id for part 0, + k for part k; one time (the sum) for the image, im_id from the file name
    assert [(r.scene_id, r.im_id, r.obj_id) for r in rows] == [(3, 42, 1), (3, 42, 2), (3, 42, 3)]
    assert len({r.time_s for r in rows}) == 1 and rows[0].time_s > 0
    # one picture of the frame: the mug's part in blue, then the laptop's base and lid in the next colours
    from PIL import Image

    img = np.array(Image.open(tmp_path / "frame.png").convert("RGB")).astype(int)
    for colour in ((31, 119, 180), (255, 127, 14), (44, 160, 44)):
        assert int((np.abs(img - np.array(colour)).max(axis=-1) < 30).sum()) > 200, colour


def test_predict_data_samples_with_pictures_viewer_and_csv(tmp_path, capsys):
    data = tmp_path / "d"
    assert main(["generate", "--category", "laptop", "--split", "test", "--num", "3", "--out", str(data), "--quiet"]) == 0
    argv = [
        "predict",
        "--model",
        "laptop",
        "--data",
        str(data),
        "--index",
        "0",
        "2",
        "--out",
        str(tmp_path / "res"),
        "--pairs",
        "4000",
        "--vis",
        str(tmp_path / "v.png"),
        "--bop-csv",
        str(tmp_path / "r.csv"),
        "--view-html",
        str(tmp_path / "v.html"),
    ]
    if not _has("viser"):
        argv = argv[:-2]
    assert main(argv) == 0, capsys.readouterr().err
    rows = read_bop_csv(tmp_path / "r.csv")
    assert [(r.im_id, r.obj_id) for r in rows] == [(0, 1), (0, 2), (2, 1), (2, 2)]  # im_id = the sample index
    written = json.loads((tmp_path / "res" / "laptop_000002.json").read_text())
    assert "errors" in written and (tmp_path / "v.png").stat().st_size > 50_000
    if _has("viser"):
        assert (tmp_path / "v.html").stat().st_size > 100_000
        assert main(["show", str(data), "--index", "1", "--view-html", str(tmp_path / "s.html")]) == 0
        assert (tmp_path / "s.html").stat().st_size > 100_000


def _has(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


def test_eval_reads_nocs_artimage_and_bop(tmp_path, capsys):
    frame = render_frame(
        [("mug", 0, posed(0.7, 30, 30, (-0.15, 0.0, 0.0)), None), ("mug", 0, posed(0.7, 150, 35, (0.15, 0.05, 0.1)), None)]
    )
    write_nocs_frame(tmp_path / "nocs" / "0000", frame, [6, 6], three_channel=False)
    write_bop_scene(tmp_path / "bop" / "000000", frame, [[1], [1]])
    art = [render_frame([("laptop", 0, posed(0.8, 20, 30), None)])]
    write_artimage(tmp_path / "art", art)
    K = tmp_path / "K.json"
    save_json(K, {"fx": SMALL.fx, "fy": SMALL.fy, "cx": SMALL.cx, "cy": SMALL.cy})
    common = ["--pairs", "3000", "--quiet"]
    assert (
        main(
            [
                "eval",
                "--model",
                "mug",
                "--format",
                "nocs",
                str(tmp_path / "nocs"),
                "--intrinsics",
                str(K),
                "--out",
                str(tmp_path / "n.json"),
                *common,
            ]
        )
        == 0
    )
    rep = json.loads((tmp_path / "n.json").read_text())
    assert rep["data"]["num_samples"] == 2 and rep["data"]["format"] == "nocs" and rep["map"] is not None
    assert (
        rep["parts"]["rotation_deg"]["mean"][0] < 30
    )  # the shipped mug model on clean renders, against the NOCS-map ground truth
    assert (
        main(
            [
                "eval",
                "--model",
                "mug",
                "--format",
                "bop",
                "--data",
                str(tmp_path / "bop"),
                "--out",
                str(tmp_path / "b.json"),
                *common,
            ]
        )
        == 0
    )
    assert json.loads((tmp_path / "b.json").read_text())["data"]["num_samples"] == 2
    assert (
        main(
            [
                "eval",
                "--model",
                "laptop",
                "--format",
                "artimage",
                str(tmp_path / "art"),
                "--out",
                str(tmp_path / "a.json"),
                *common,
            ]
        )
        == 0
    )
    rep = json.loads((tmp_path / "a.json").read_text())
    assert rep["joints"]["axis_deg"]["mean"][0] is not None
    assert "rotation error" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["predict", "--instances", "1=mug", "--depth", "{d}/000042.png", "--intrinsics", "{d}/K.json", "--out", "{t}/x.json"],
            "--instances needs",
        ),
        (
            [
                "predict",
                "--instances",
                "1=mug",
                "7=mug",
                "--depth",
                "{d}/000042.png",
                "--mask",
                "{d}/instances.png",
                "--intrinsics",
                "{d}/K.json",
                "--out",
                "{t}/x.json",
            ],
            "instance id(s) [7] do not occur",
        ),
        (["predict", "--depth", "{d}/000042.png", "--out", "{t}/x.json"], "--model is required"),
        (
            [
                "predict",
                "--model",
                "mug",
                "--depth",
                "{d}/000042.png",
                "--intrinsics",
                "{d}/K.json",
                "--mask",
                "{d}/instances.png",
                "--mask-label",
                "1",
                "--rgb",
                "{d}/K.json",
                "--out",
                "{t}/x.json",
                "--vis",
                "{t}/x.png",
            ],
            "not a readable image",
        ),
        (["eval", "--model", "mug", "--format", "nocs", "{t}", "--out", "{t}/r.json"], "holds no NOCS frames"),
        (["eval", "--model", "mug", "--out", "{t}/r.json"], "give the data set"),
        (["show", "{t}"], "does not exist"),
    ],
)
def test_one_line_errors(frame_files, tmp_path, capsys, argv, message):
    d, _ = frame_files
    argv = [a.replace("{d}", str(d)).replace("{t}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1, err
