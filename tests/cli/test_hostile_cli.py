"""Hostile input, round three (issue #50): every failure of the command line is exit 2 and one line naming
the file or option and the problem, before any work is done; "internal error" stays for bugs.

The sweep runs ``ucope`` in this process (fast); only the concurrency test starts real processes. No
model is trained and the data sets hold a few views.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ucope.cli.main import main
from ucope.data.dataset import load_dataset
from ucope.data.generate import GenerateConfig, generate_dataset, make_sample
from ucope.data.images import write_png
from ucope.errors import DataError, InputError
from ucope.estimation.inputs import parse_intrinsics, prepare_points, rgbd_points, roll_to_up
from ucope.estimation.result import PoseResult
from ucope.fileio import MAX_JSON_DEPTH, parse_json, read_json
from ucope.model.checkpoint import list_pretrained

needs_mug = pytest.mark.skipif("mug" not in list_pretrained(), reason="needs the shipped mug model")
posix_only = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
DEEP = "[" * 100_000 + "]" * 100_000


@contextlib.contextmanager
def no_hang(seconds: float = 30.0):
    """Fail, instead of hanging the suite, when the body blocks (a FIFO read, a server thread)."""

    def _alarm(*_):
        raise TimeoutError(f"hung for more than {seconds} s")

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def refused(capsys, argv: list[str], *needles: str) -> str:
    """Run ``ucope ARGV``: exit 2, one line on stderr holding every needle, no traceback, no internal error."""
    capsys.readouterr()
    with no_hang():
        rc = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and "internal error" not in err, err
    for n in needles:
        assert n in err, err
    return err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A mug cloud, an RGB-D frame of it (depth, mask, K.json), a two-view data set, a file and a FIFO."""
    d = tmp_path_factory.mktemp("hostile")
    cfg = GenerateConfig(category="mug", split="test", num=1, views_per_instance=1, seed=3)
    s, view = make_sample(cfg, 0, return_view=True)
    np.save(d / "cloud.npy", s["points"].astype(np.float64))
    write_png(d / "depth.png", view.depth_mm)
    write_png(d / "mask.png", (view.mask == 0).astype(np.uint8))
    fx, fy, cx, cy = (float(v) for v in s["intrinsics"])
    (d / "K.json").write_text(json.dumps({"fx": fx, "fy": fy, "cx": cx, "cy": cy}))
    (d / "deep.json").write_text(DEEP)
    (d / "file").write_text("a file, not a folder")
    generate_dataset(
        d / "data", GenerateConfig(category="mug", split="test", num=2, shard_size=2, max_points=256), progress=False
    )
    if hasattr(os, "mkfifo"):
        os.mkfifo(d / "fifo.json")
    return d


# ------------------------------------------------------------------------ 1: outputs that cannot be written
@needs_mug
@pytest.mark.parametrize(
    "extra, option",
    [
        (["--out", "{d}/file/r.json"], "--out"),
        (["--out", "{t}/r.json", "--vis", "{d}/file/v.png"], "--vis"),
        (["--out", "{t}/r.json", "--bop-csv", "{d}/file/r.csv"], "--bop-csv"),
        (["--out", "{t}/new/" + "y" * 300 + "/r.json"], "too long"),
        (["--out", "{t}/r.json", "--view-html", "{d}/file/v.html"], "--view-html"),
        (["--out", "{t}/r.json", "--vis", "/dev/null"], "--vis"),
        (["--out", "{t}/r.json", "--vis", "{t}/r.json"], "same path"),
        (["--out", "{t}/r.json", "--vis", "{t}/" + "x" * 300 + ".png"], "too long"),
    ],
)
def test_predict_checks_every_output_before_writing_any(files, tmp_path, capsys, extra, option):
    if "--view-html" in extra:
        pytest.importorskip("viser")
    argv = ["predict", "--model", "mug", "--input", files / "cloud.npy", "--pairs", "500", "--quiet"]
    argv += [a.replace("{d}", str(files)).replace("{t}", str(tmp_path)) for a in extra]
    refused(capsys, argv, option)
    assert not (tmp_path / "r.json").exists()  # the result JSON is not written when a picture cannot be


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's read-only /proc")
def test_an_output_on_a_read_only_file_system_is_named(files, capsys):
    err = refused(capsys, ["eval", "--model", "mug", files / "data", "--out", "/proc/ucope_report.json"], "--out")
    assert "/proc/ucope_report.json" in err and "cannot write" in err


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["eval", "--model", "mug", "{d}/data", "--out", "{d}/file/r.json"], ("--out", "{d}/file is a file, not a folder")),
        (
            ["train", "--category", "mug", "--data", "{d}/data", "--out", "{d}/file", "--steps", "1"],
            ("--out {d}/file", "not a folder"),
        ),
        (["demo", "--out", "{d}/file", "--num", "1"], ("--out {d}/file", "not a folder")),
        (["show", "{d}/data", "--out", "{d}/file/s.png"], ("--out", "{d}/file is a file, not a folder")),
        (["show", "{d}/data", "--out", "{d}/data"], ("--out {d}/data is a folder",)),
        (
            ["generate", "--category", "mug", "--num", "2", "--out", "{d}/file/sub"],
            ("cannot write to output folder {d}/file/sub",),
        ),
        (
            [
                "predict",
                "--instances",
                "1=mug",
                "--depth",
                "{d}/depth.png",
                "--mask",
                "{d}/mask.png",
                "--intrinsics",
                "{d}/K.json",
                "--out",
                "{d}/file/f.json",
            ],
            ("--out", "{d}/file is a file, not a folder"),
        ),
    ],
)
def test_other_commands_refuse_unwritable_outputs_before_work(files, capsys, argv, needles):
    refused(capsys, [a.replace("{d}", str(files)) for a in argv], *(n.replace("{d}", str(files)) for n in needles))


def test_categories_picture_is_checked_before_drawing(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from own_objects_support import two_link_spec, write_spec, write_two_link_urdf

    write_two_link_urdf(tmp_path)
    spec = write_spec(tmp_path / "spec.json", two_link_spec("two_link.urdf"))
    (tmp_path / "file").write_text("x")
    refused(capsys, ["categories", "--spec", spec, "--picture", tmp_path / "file" / "p.png"], "--picture", "not a folder")
    refused(capsys, ["categories", "--spec", spec, "--picture", tmp_path / "p.png", "--no-picture"], "contradict")
    refused(capsys, ["categories", "--no-picture"], "add --spec")


# ----------------------------------------------------------------------------------- 2: the Python API
def test_absurd_magnitudes_and_intrinsics_dicts_in_the_api(files):
    P = np.load(files / "cloud.npy")
    with pytest.raises(InputError, match=r"beyond 1e\+06 m, up to \S+e\+(299|300) m"):
        prepare_points(P * 1e300)
    Q = P.copy()
    Q[0] = 1e300  # one corrupt row among good ones: dropped with a warning, like a NaN row
    prep = prepare_points(Q)
    assert len(prep.points) == len(P) - 1 and any("beyond 1e+06 m" in w for w in prep.warnings)
    huge = prepare_points(P, np.ones_like(P) * 1e308)  # normals of huge length are normalised without overflow
    assert np.allclose(np.linalg.norm(huge.normals, axis=1), 1.0)
    K = parse_intrinsics({"fx": 500, "fy": 501, "cx": 32, "cy": 24})
    assert K.tolist() == [500, 501, 32, 24]
    assert parse_intrinsics({"camera": {"K": [[500, 0, 32], [0, 501, 24], [0, 0, 1]]}}).tolist() == [500, 501, 32, 24]
    assert parse_intrinsics({"cam_K": [500, 0, 32, 0, 501, 24, 0, 0, 1]}).tolist() == [500, 501, 32, 24]
    depth = np.full((48, 64), 800, np.uint16)
    assert len(rgbd_points(depth, {"fx": 60, "fy": 60, "cx": 32, "cy": 24})) > 1000
    for bad, match in (({"f": 1}, r"dict with keys \['f'\]"), ("K.json", "got 'K.json'"), ([1, 2, 3], r"shape \(3,\)")):
        with pytest.raises(InputError, match=match):
            rgbd_points(depth, bad)
    with pytest.raises(InputError, match="positive focal lengths"):
        parse_intrinsics({"fx": float("nan"), "fy": 1, "cx": 0, "cy": 0})


def test_deep_json_is_a_data_error_everywhere(files, tmp_path):
    with pytest.raises(DataError, match=rf"deep.json nests arrays / objects more than {MAX_JSON_DEPTH} levels"):
        PoseResult.load(files / "deep.json")
    with pytest.raises(DataError, match="more than"):
        PoseResult.from_json(DEEP)
    ok = "[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH
    assert parse_json(ok) == parse_json(ok)  # the limit itself is accepted...
    with pytest.raises(DataError, match="more than"):
        parse_json("[" + ok + "]")  # ...one more level is not
    (tmp_path / "big.json").write_text('{"n": ' + "9" * 5000 + "}")  # beyond Python's digit limit: a ValueError before
    with pytest.raises(DataError, match="big.json is not valid JSON"):
        read_json(tmp_path / "big.json")


@posix_only
def test_json_readers_refuse_fifos_and_devices_without_waiting(files):
    with no_hang(10), pytest.raises(DataError, match="fifo.json is a FIFO"):
        read_json(files / "fifo.json")
    with no_hang(10), pytest.raises(DataError, match="/dev/zero is a device"):
        read_json("/dev/zero")


# -------------------------------------------------------------- 4, 8: deep JSON, FIFOs and viewer addresses
@posix_only
def test_fifos_in_place_of_files_are_refused(files, tmp_path, capsys):
    data = tmp_path / "data"
    generate_dataset(data, GenerateConfig(category="mug", split="test", num=2, shard_size=1, max_points=64), progress=False)
    (data / "shard_00001.npz").unlink()
    os.mkfifo(data / "shard_00001.npz")
    refused(capsys, ["show", data, "--index", "1", "--out", tmp_path / "s.png"], "shard_00001.npz is a FIFO")
    os.unlink(data / "meta.json")
    os.mkfifo(data / "meta.json")
    refused(capsys, ["show", data, "--out", tmp_path / "s.png"], "meta.json is a FIFO")
    argv = ["predict", "--model", "mug", "--depth", files / "depth.png", "--intrinsics", files / "fifo.json"]
    refused(capsys, [*argv, "--out", tmp_path / "r.json"], "camera intrinsics", "fifo.json is a FIFO")


@needs_mug
def test_deep_json_files_are_one_line_errors(files, tmp_path, capsys):
    deep = files / "deep.json"
    refused(capsys, ["categories", "--spec", deep, "--no-picture"], "category spec", "deep.json nests")
    argv = ["predict", "--model", "mug", "--depth", files / "depth.png", "--intrinsics", deep, "--out", tmp_path / "r.json"]
    refused(capsys, argv, "camera intrinsics", "deep.json nests")
    refused(capsys, ["predict", "--model", deep, "--input", files / "cloud.npy", "--out", tmp_path / "r.json"], "deep.json")
    data = tmp_path / "data"
    data.mkdir()
    (data / "meta.json").write_text(DEEP)
    refused(capsys, ["eval", "--model", "mug", data, "--out", tmp_path / "e.json"], "meta.json nests")
    (data / "meta.json").write_text(json.dumps({"num": "abc", "shard_size": [], "num_parts": None}))  # wrong types
    refused(capsys, ["show", data, "--out", tmp_path / "s.png"], "meta.json")
    (tmp_path / "K.json").write_text(json.dumps({"fx": "abc", "fy": 1, "cx": 0, "cy": 0}))
    argv = ["predict", "--model", "mug", "--depth", files / "depth.png", "--intrinsics", tmp_path / "K.json"]
    refused(capsys, [*argv, "--out", tmp_path / "r.json"], "K.json")
    assert not (tmp_path / "r.json").exists() and not (tmp_path / "e.json").exists()


@needs_mug
@pytest.mark.parametrize(
    "view, needles",
    [
        (["--view-port", "99999"], ("--view-port must be an integer from 0 to 65535", "99999")),
        (["--view-port", "70000"], ("--view-port", "70000")),
        (["--view-port", "-1"], ("--view-port", "-1")),
        (["--view-host", "no.such.host.invalid"], ("--view-host 'no.such.host.invalid' does not resolve",)),
        (["--view-host", "192.0.2.1"], ("no address of this machine",)),
    ],
)
def test_viewer_addresses_are_checked_before_any_work(files, tmp_path, capsys, view, needles):
    pytest.importorskip("viser")
    argv = ["predict", "--model", "mug", "--input", files / "cloud.npy", "--out", tmp_path / "r.json", "--view", *view]
    t0 = time.perf_counter()
    refused(capsys, argv, *needles)
    assert time.perf_counter() - t0 < 10 and not (tmp_path / "r.json").exists()


def test_the_viewer_warns_when_it_listens_beyond_this_machine():
    from ucope.estimation.view3d import check_address

    assert check_address("127.0.0.1", 0) == []
    (note,) = check_address("0.0.0.0", 0)
    assert "open to every machine" in note and "without authentication" in note
    with pytest.raises(InputError, match="port must be an integer from 0 to 65535"):
        check_address("127.0.0.1", 99999)


# ------------------------------------------------------------------------------- 9: ignored options
@pytest.mark.parametrize(
    "extra, needles",
    [
        (["--input", "{d}/cloud.npy", "--depth", "{d}/depth.png"], ("give one input", "--input and --depth")),
        (["--data", "{d}/data", "--depth", "{d}/depth.png"], ("--depth and --data",)),
        (["--input", "{d}/cloud.npy", "--mask", "{d}/mask.png"], ("--mask is for a --depth frame",)),
        (["--input", "{d}/cloud.npy", "--box", "0", "0", "5", "5"], ("--box is for a --depth frame",)),
        (["--input", "{d}/cloud.npy", "--rgb", "{d}/depth.png"], ("--rgb is for a --depth frame",)),
        (["--input", "{d}/cloud.npy", "--depth-scale", "1"], ("--depth-scale is for a --depth frame",)),
        (["--input", "{d}/cloud.npy", "--index", "0"], ("--index picks samples of a data set",)),
        (["--data", "{d}/data", "--units", "mm"], ("--units is the length unit of --input",)),
        (["--input", "{d}/cloud.npy", "--bop-scene-id", "3"], ("--bop-scene-id sets the rows of --bop-csv",)),
        (
            ["--depth", "{d}/depth.png", "--intrinsics", "{d}/K.json", "--mask", "{d}/mask.png", "--rgb", "{d}/depth.png"],
            ("--rgb is drawn under the estimates by --vis",),
        ),
        (["--depth", "{d}/depth.png", "--intrinsics", "{d}/K.json", "--mask-label", "1"], ("--mask-label picks values",)),
        (["--input", "{d}/cloud.npy", "--up", "nan", "0", "0"], ("--up: up must be a finite, non-zero 3-vector",)),
        (["--input", "{d}/cloud.npy", "--up", "0", "0", "0"], ("--up: up must be a finite, non-zero",)),
        (["--input", "{d}/cloud.npy", "--view-port", "8081"], ("--view-port is for the --view server",)),
    ],
)
def test_options_the_others_would_ignore_are_refused(files, tmp_path, capsys, extra, needles):
    argv = ["predict", "--model", "mug", "--out", str(tmp_path / "r.json")]
    refused(capsys, argv + [a.replace("{d}", str(files)) for a in extra], *needles)


def test_a_bad_rgb_with_instances_and_eval_options_of_another_format(files, tmp_path, capsys):
    frame = ["--depth", files / "depth.png", "--mask", files / "mask.png", "--intrinsics", files / "K.json"]
    bad_rgb = ["predict", "--instances", "1=mug", *frame, "--rgb", files / "K.json", "--out", tmp_path / "f.json"]
    refused(capsys, bad_rgb, "K.json", "not a readable image")
    assert not (tmp_path / "f.json").exists()  # said before the frame's JSON is written
    ev = ["eval", "--model", "mug", files / "data", "--out", tmp_path / "e.json"]
    refused(
        capsys,
        [*ev, "--format", "bop", "--intrinsics", files / "K.json"],
        "--intrinsics is an option of --format nocs and artimage",
    )
    refused(capsys, [*ev, "--models-info", files / "K.json"], "--models-info is for --format bop only")
    refused(capsys, [*ev, "--format", "nocs", "--bop-obj-id", "3"], "--bop-obj-id is for --format bop only")
    refused(capsys, [*ev, "--data", files / "data"], "give the data set once")
    refused(capsys, [*ev, "--num", "0"], "--num must be positive")


# ------------------------------------------------------------------ 11, 15: shard ranges, distractors, up
@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--shards", "1:0"], "--shards 1:0: START must be >= 0 and below STOP"),
        (["--shards", "0:0"], "--shards 0:0"),
        (["--shards=-1:1"], "--shards -1:1"),
        (["--shards", "0:5"], "shard range 0:5 is outside 0:1"),
        (["--distractors", "-1"], "distractors (the most distractor objects per view) must be an integer >= 0, got -1"),
    ],
)
def test_generate_refuses_empty_shard_ranges_and_negative_distractors(tmp_path, capsys, extra, needle):
    refused(capsys, ["generate", "--category", "mug", "--num", "2", "--out", tmp_path / "d", "--quiet", *extra], needle)
    assert not (tmp_path / "d").exists()  # refused before anything is written


def test_a_huge_up_vector_is_a_direction():
    np.testing.assert_allclose(roll_to_up((1e308, 1e308, 0)), roll_to_up((1, 1, 0)))
    np.testing.assert_allclose(roll_to_up((1e-320, 0, 0)), roll_to_up((1, 0, 0)))
    with pytest.raises(InputError, match="must be a finite"):
        roll_to_up((np.inf, 0, 0))


# ------------------------------------------------------------------------ 10: concurrent generate runs
def _generate(out: Path, seed: int, num: int = 12) -> subprocess.Popen:
    argv = ["generate", "--category", "mug", "--split", "test", "--num", str(num), "--shard-size", "1", "--max-points", "128"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen(
        [sys.executable, "-m", "ucope", *argv, "--seed", str(seed), "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def test_two_generate_runs_into_one_folder_never_interleave(tmp_path, capsys):
    # different seeds, started together: exactly one writes, the other is refused before writing anything
    out = tmp_path / "d"
    runs = [_generate(out, seed=0, num=4), _generate(out, seed=1, num=4)]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in runs]
    assert sorted(rc for rc, _ in results) == [0, 2], results
    (winner,) = [i for i, (rc, _) in enumerate(results) if rc == 0]
    loser_err = results[1 - winner][1]
    assert "already holds a data set made with other settings (seed differ)" in loser_err and "Traceback" not in loser_err
    ds = load_dataset(out)
    assert ds.meta["seed"] == winner
    want = make_sample(GenerateConfig(category="mug", split="test", num=4, shard_size=1, max_points=128, seed=winner), 3)
    np.testing.assert_array_equal(ds[3]["points"], want["points"])  # every shard is the winner's

    # the same settings while a run is live: refused, naming the run; after a kill -9, the next run resumes
    out = tmp_path / "e"
    first = _generate(out, seed=0, num=40)
    deadline = time.monotonic() + 120
    while not (out / "shard_00000.npz").exists() and first.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    first.send_signal(signal.SIGSTOP)  # holds its claim, makes no progress (and no longer the folder's start lock)
    assert first.poll() is None, first.stderr.read()
    err = refused(
        capsys,
        [
            "generate",
            "--category",
            "mug",
            "--split",
            "test",
            "--num",
            "40",
            "--shard-size",
            "1",
            "--max-points",
            "128",
            "--out",
            out,
            "--quiet",
        ],
        "another `ucope generate` is writing into",
    )
    assert f"pid {first.pid}" in err
    first.send_signal(signal.SIGKILL)
    first.wait(timeout=60)
    assert list(out.glob(".generate-run-*.json"))  # the killed run's claim is left behind...
    argv = ["generate", "--category", "mug", "--split", "test", "--num", "40", "--shard-size", "1", "--max-points", "128"]
    assert main([*argv, "--out", str(out), "--quiet"]) == 0  # ...and found unlocked: removed, the run resumes
    assert not list(out.glob(".generate-run-*.json")) and len(load_dataset(out)) == 40


def test_disjoint_shard_ranges_may_share_a_folder(tmp_path):
    cfg = GenerateConfig(category="mug", split="test", num=4, shard_size=1, max_points=64)
    generate_dataset(tmp_path / "d", cfg, shards=range(2, 4), progress=False)
    generate_dataset(tmp_path / "d", cfg, shards=range(0, 2), progress=False)
    assert len(load_dataset(tmp_path / "d")) == 4


# ------------------------------------------------------------------------------ the main() safety net
def test_an_os_error_naming_a_file_is_not_an_internal_error_but_a_bug_is(monkeypatch, tmp_path, capsys):
    import ucope.cli.main as cli

    def full_disk(args):
        raise OSError(28, "No space left on device", str(tmp_path / "x"))

    monkeypatch.setattr(cli, "cmd_models", full_disk)  # build_parser binds the module's function at each call
    refused(capsys, ["models"], "No space left on device", str(tmp_path / "x"))

    def bug(args):
        return 1 // 0

    monkeypatch.setattr(cli, "cmd_models", bug)
    assert main(["models"]) == 1
    assert "internal error: ZeroDivisionError" in capsys.readouterr().err
