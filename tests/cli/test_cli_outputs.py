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
    # obj_ids numbered on over the objects (the mug 1, the laptop's base 2 and lid 3): every (object, part) its own;
    # one time (the sum) for the image, im_id from the file name
    assert [(r.scene_id, r.im_id, r.obj_id) for r in rows] == [(3, 42, 1), (3, 42, 2), (3, 42, 3)]
    assert len({r.time_s for r in rows}) == 1 and rows[0].time_s > 0
    ids = json.loads((tmp_path / "frame.obj_ids.json").read_text())["obj_ids"]
    assert [(e["obj_id"], e["object"], e["part"]) for e in ids] == [
        (1, "1: mug", "body"),
        (2, "2: laptop", "base"),
        (3, "2: laptop", "lid"),
    ]
    # one picture of the frame: the mug's part in orange, then the laptop's base and lid in the next colours
    from PIL import Image

    img = np.array(Image.open(tmp_path / "frame.png").convert("RGB")).astype(int)
    for colour in ((255, 140, 0), (148, 103, 189), (227, 119, 194)):
        assert int((np.abs(img - np.array(colour)).max(axis=-1) < 30).sum()) > 200, colour


def _segmented_cloud(frame) -> tuple[np.ndarray, np.ndarray]:
    """The frame's measured pixels as a cloud (metres) and their instance ids (0: background)."""
    from frame_fixtures import backproject

    ok = frame["depth_mm"] > 0
    return backproject(frame["depth_mm"], SMALL)[ok], frame["instance"][ok].astype(np.int32)


def test_predict_a_segmented_cloud_with_instance_ids(frame_files, tmp_path, capsys):
    _, frame = frame_files
    pts, ids = _segmented_cloud(frame)
    fmt = "npz"  # the PLY property is read by the same reader: tests/data/test_readers.py
    np.savez(tmp_path / "seg.npz", points=pts, instance=ids)
    argv = ["predict", "--input", str(tmp_path / f"seg.{fmt}"), "--instances", "1=mug", "2=laptop"]
    argv += ["--out", str(tmp_path / "f.json"), "--bop-csv", str(tmp_path / "f.csv"), "--pairs", "3000"]
    assert main(argv) == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "f.json").read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(doc, result_schema())
    objs = doc["objects"]
    assert [(o["instance_id"], o["model"], o["num_points"]) for o in objs] == [
        (1, "mug", int((ids == 1).sum())),
        (2, "laptop", int((ids == 2).sum())),
    ]
    for o, truth in zip(objs, frame["objects"], strict=True):  # each object found where it is
        t = np.asarray(o["result"]["parts"][0]["cam_from_part"])[:3, 3]
        assert np.linalg.norm(t - truth["cam_from_part"][0][:3, 3]) < 0.05
    assert doc["source"]["input"].endswith(f"seg.{fmt}") and len(read_bop_csv(tmp_path / "f.csv")) == 3
    # without --instances the cloud is one object, and the command says so
    one = ["predict", "--model", "mug", "--input", str(tmp_path / "seg.npz"), "--out", str(tmp_path / "one.json")]
    assert main([*one, "--pairs", "500", "--fast"]) == 0
    assert "carries per-point instance ids [1, 2]: estimated as one object" in capsys.readouterr().err


def test_instances_honour_box_and_refuse_mask_label(frame_files, tmp_path, capsys):
    d, frame = frame_files
    cols = np.nonzero(frame["instance"] == 1)[1]
    box = [0, 0, int(cols.max()) + 1, 240]  # the mug's side of the image only
    argv = ["predict", "--instances", "1=mug", "2=laptop", "--depth", str(d / "000042.png"), "--mask", str(d / "instances.png")]
    argv += ["--intrinsics", str(d / "K.json"), "--out", str(tmp_path / "b.json"), "--pairs", "2000"]
    assert main([*argv, "--box", *map(str, box)]) == 0, capsys.readouterr().err
    objs = json.loads((tmp_path / "b.json").read_text())["objects"]
    laptop_inside = int(((frame["instance"] == 2) & (frame["depth_mm"] > 0))[:, : box[2]].sum())
    assert objs[0]["result"] is not None and objs[0]["num_pixels"] == int(
        ((frame["instance"] == 1) & (frame["depth_mm"] > 0)).sum()
    )
    assert objs[1]["num_pixels"] == laptop_inside < int((frame["instance"] == 2).sum())  # cut to the box
    assert main([*argv, "--mask-label", "1"]) == 2
    assert "--mask-label picks one object's values" in capsys.readouterr().err


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
        (
            ["eval", "--model", "mug", "--format", "bop", "{t}", "--intrinsics", "{d}/K.json", "--out", "{t}/r.json"],
            "--intrinsics is an option of --format nocs and artimage",
        ),
        (
            ["eval", "--model", "mug", "--format", "bop", "{t}", "--dataset", "real", "--out", "{t}/r.json"],
            "--dataset is an option",
        ),
        (
            ["predict", "--instances", "1=mug", "--input", "{d}/x.npz", "--depth", "{d}/000042.png", "--out", "{t}/x.json"],
            "--depth",
        ),
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
