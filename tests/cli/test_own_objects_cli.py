"""Bring your own objects through the command line: categories --spec, generate --spec, train, predict, eval."""

from __future__ import annotations

import importlib.util
import json
import shutil

import pytest
from own_objects_support import two_link_spec, write_spec, write_two_link_urdf

from ucope.cli.main import main

pytest.importorskip("yourdfpy")


def test_categories_spec_checks_and_draws(tmp_path, capsys):
    src = tmp_path / "src"
    write_two_link_urdf(src)
    spec = write_spec(src / "spec.json", two_link_spec("two_link.urdf"))
    if importlib.util.find_spec("matplotlib") is not None:
        png = tmp_path / "pic" / "toy.png"
        assert main(["categories", "--spec", str(spec), "--picture", str(png)]) == 0
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["categories", "--spec", str(spec), "--no-picture"]) == 0
    out = capsys.readouterr().out
    assert "toy_box: valid spec, 1 instance file(s), K = 2" in out
    assert "joint 0 'hinge': revolute part 0 -> 1, states [0, 1.745] rad (spec: [0.0, 100.0] deg" in out
    write_spec(spec, {**two_link_spec("two_link.urdf"), "joints": [{"joint": "hinge", "range": [0, 3]}]})
    assert main(["categories", "--spec", str(spec), "--no-picture"]) == 2
    assert "two_link.urdf: category joint 0 ('hinge'): sampled range [0, 3] rad is outside" in capsys.readouterr().err
    # a bad spec stops generate before anything is written
    assert main(["generate", "--spec", str(spec), "--num", "4", "--out", str(tmp_path / "data"), "--quiet"]) == 2
    assert "sampled range [0, 3] rad is outside" in capsys.readouterr().err and not (tmp_path / "data").exists()


def test_generate_train_predict_eval_on_a_spec_without_its_files(tmp_path, capsys):
    """The whole flow on a category that is not built in; the model predicts after the source files are gone."""
    src = tmp_path / "src"
    write_two_link_urdf(src)
    spec = write_spec(src / "spec.json", two_link_spec("two_link.urdf", size_scale_range=[0.9, 1.1]))
    common = ["--spec", str(spec), "--shard-size", "8", "--views-per-instance", "4", "--max-points", "512", "--quiet"]
    train_dir, val_dir = tmp_path / "train", tmp_path / "val"
    assert main(["generate", *common, "--num", "16", "--out", str(train_dir)]) == 0
    assert main(["generate", *common, "--split", "test", "--num", "4", "--out", str(val_dir)]) == 0
    meta = json.loads((train_dir / "meta.json").read_text())
    assert meta["category"] == "toy_box" and meta["spec"]["name"] == "toy_box" and meta["family"] == "own"
    assert sorted(p.name for p in train_dir.glob("shard_*.npz")) == ["shard_00000.npz", "shard_00001.npz"]
    # resumable: the same settings find every shard done; another spec is refused, nothing is written
    before = {p.name: p.stat().st_mtime_ns for p in train_dir.iterdir()}
    assert main(["generate", *common, "--num", "16", "--out", str(train_dir)]) == 0
    assert {p.name: p.stat().st_mtime_ns for p in train_dir.iterdir()} == before
    write_spec(spec, two_link_spec("two_link.urdf", size_scale_range=[0.9, 1.2]))
    capsys.readouterr()
    assert main(["generate", *common, "--num", "16", "--out", str(train_dir)]) == 2
    assert "already holds a data set made with other settings (spec differ)" in capsys.readouterr().err
    assert {p.name: p.stat().st_mtime_ns for p in train_dir.iterdir()} == before

    run = tmp_path / "run"
    args = ["train", "--category", "toy_box", "--data", str(train_dir), "--out", str(run), "--steps", "20", "--batch-size", "4"]
    args += [
        "--val-samples",
        "2",
        "--val-every",
        "20",
        "--checkpoint-every",
        "20",
        "--threads",
        "1",
        "--device",
        "cpu",
        "--quiet",
    ]
    assert main(args) == 0  # its validation views come from the spec stored in the data's meta.json
    card = json.loads((run / "model_card.json").read_text())
    assert card["category"] == "toy_box" and card["steps"] == 20

    shutil.rmtree(src)  # the URDF, its mesh and the spec: prediction needs only the model
    capsys.readouterr()
    assert main(["predict", "--model", str(run), "--data", str(val_dir), "--index", "0", "--out", f"{tmp_path / 'pred'}/"]) == 0
    res = json.loads((tmp_path / "pred" / "toy_box_000000.json").read_text())
    assert [p["label"] for p in res["parts"]] == ["base", "lid"] and len(res["joints"]) == 1
    assert set(res["errors"]) >= {"parts", "joints"}
    assert main(["eval", "--model", str(run), str(val_dir), "--out", str(tmp_path / "eval.json"), "--quiet"]) == 0
    report = json.loads((tmp_path / "eval.json").read_text())
    assert report["category"] == "toy_box" and len(report["samples"]) == 4


def test_categories_spec_draws_every_instance_and_prints_the_files_limits(tmp_path, capsys):
    """Issue #48 defect 5: every instance in one picture (a grid), and per instance each joint's limits in
    the file and as category states, beside the range sampled (the doors: one turned round, states negated)."""
    from own_objects_support import door_spec, write_door_pair

    write_door_pair(tmp_path)
    spec = write_spec(tmp_path / "doors.json", door_spec(tmp_path))
    png = tmp_path / "doors.png"
    args = ["categories", "--spec", str(spec)] + (
        ["--picture", str(png)] if importlib.util.find_spec("matplotlib") else ["--no-picture"]
    )
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert err.startswith("warning: category spec: 001_right-door (right/door.urdf): the axis of category joint(s) [0] points")
    assert "instance 000_left-door: left/door.urdf" in out and "instance 001_right-door: right/door.urdf" in out
    assert "joint 0 'hinge': file limits [0, 2] rad = states [0, 2] rad; sampled [0, 1.571] rad" in out
    assert "joint 0 'hinge': file limits [0, 2] rad = states [-2, 0] rad; sampled [-1.571, 0] rad; axis turned round" in out
    if importlib.util.find_spec("matplotlib"):
        import matplotlib.image

        h, w = matplotlib.image.imread(str(png)).shape[:2]
        assert w > 1.8 * h and f"wrote {png} (2 instance(s))" in out  # two panels side by side


def test_train_without_val_data_and_without_the_sources_leaves_no_run_folder(tmp_path, capsys):
    """Issue #48 defect 8: the default validation views need the spec's files; with them gone the error says
    so (and how to do without), before the run folder is made."""
    src = tmp_path / "src"
    write_two_link_urdf(src)
    spec = write_spec(src / "spec.json", two_link_spec("two_link.urdf"))
    data = tmp_path / "train"
    common = ["--spec", str(spec), "--num", "8", "--views-per-instance", "4", "--max-points", "256", "--quiet"]
    assert main(["generate", *common, "--out", str(data)]) == 0
    shutil.rmtree(src)
    from ucope.objects import categories

    categories._registry().pop("toy_box", None)  # a new process: the spec is read from the data's meta.json
    categories._DOCS.pop("toy_box", None)
    run = tmp_path / "runs" / "toy"
    capsys.readouterr()
    args = ["train", "--category", "toy_box", "--data", str(data), "--out", str(run), "--steps", "2", "--batch-size", "2"]
    assert main([*args, "--threads", "1", "--device", "cpu", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "the validation views of 'toy_box' are generated from its spec's files" in err and "--val-data" in err
    assert "two_link.urdf" in err and not run.exists() and not run.parent.exists()
    (tmp_path / "afile").write_text("x")
    assert main([*args[:5], "--out", str(tmp_path / "afile"), *args[7:], "--device", "cpu", "--quiet"]) == 2
    assert "it exists and is not a folder" in capsys.readouterr().err
