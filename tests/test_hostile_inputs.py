"""What users actually feed us (issue #17): one case per reported problem, files written by other tools.

Each test names the failure it guards against. CLI cases check for a non-zero exit and a one-line error
without a traceback; API cases for a :mod:`ucope.errors` type whose message names the problem.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import ucope
from ucope.cli.main import main
from ucope.data.generate import GenerateConfig, generate_dataset, make_sample
from ucope.data.io import read_point_cloud
from ucope.errors import DataError, InputError
from ucope.estimation import Estimator
from ucope.estimation.inputs import label_points, prepare_points, rgbd_points
from ucope.render.noise import DepthNoise
from ucope.render.views import ViewConfig

CLEAN = ViewConfig(noise=DepthNoise(enabled=False), num_distractors=0)


@pytest.fixture(scope="module")
def mug_sample():
    return make_sample(GenerateConfig(category="mug", split="test", num=1, seed=11, view=CLEAN), 0)


@pytest.fixture(scope="module")
def mug():
    return Estimator.load("mug", overrides={"vote_parts.num_pairs": 4000})


def _cli(capsys, *argv) -> tuple[int, str]:
    rc = main(list(argv))
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return rc, err


# ------------------------------------------------------------------------------------------- files
def test_ascii_and_binary_ply_with_extra_properties_from_other_writers(tmp_path, mug_sample, mug):
    plyfile = pytest.importorskip("plyfile")
    pts = mug_sample["points"].astype(np.float64)
    nrm = mug_sample["normals"].astype(np.float32)
    v = np.empty(
        len(pts),
        dtype=[
            ("x", "f8"),
            ("y", "f8"),
            ("z", "f8"),
            ("nx", "f4"),
            ("ny", "f4"),
            ("nz", "f4"),
            ("red", "u1"),
            ("green", "u1"),
            ("blue", "u1"),
            ("intensity", "f4"),
        ],
    )
    for k, a in zip(("x", "y", "z"), pts.T, strict=False):
        v[k] = a
    for k, a in zip(("nx", "ny", "nz"), nrm.T, strict=False):
        v[k] = a
    v["red"], v["intensity"] = 200, 0.5
    faces = np.array([([0, 1, 2],)], dtype=[("vertex_indices", "i4", (3,))])
    for name, text, order in (("ascii", True, "="), ("le", False, "<"), ("be", False, ">")):  # ASCII crashed before
        el = [plyfile.PlyElement.describe(v, "vertex"), plyfile.PlyElement.describe(faces, "face")]
        path = tmp_path / f"cloud_{name}.ply"
        plyfile.PlyData(el, text=text, byte_order=order).write(str(path))
        got, got_n = read_point_cloud(path)
        np.testing.assert_allclose(got, pts, rtol=1e-6 if text else 0)
        np.testing.assert_allclose(got_n, nrm, rtol=1e-5)
    import trimesh  # another writer: trimesh's binary PLY of a point cloud

    trimesh.PointCloud(pts).export(tmp_path / "trimesh.ply")
    np.testing.assert_allclose(read_point_cloud(tmp_path / "trimesh.ply")[0], pts, rtol=1e-6)
    rc = main(
        [
            "predict",
            "--model",
            "mug",
            "--pairs",
            "2000",
            "--input",
            str(tmp_path / "cloud_ascii.ply"),
            "--out",
            str(tmp_path / "r.json"),
        ]
    )
    assert rc == 0 and json.loads((tmp_path / "r.json").read_text())["format"] == "ucope-result/2"


def test_pcd_variants_including_organised_binary_compressed(tmp_path, mug_sample):
    pypcd4 = pytest.importorskip("pypcd4")
    from pypcd4 import pypcd4 as impl

    pts = mug_sample["points"][:600].astype(np.float32)
    organised = np.full((20, 40, 3), np.nan, dtype=np.float32)
    organised.reshape(-1, 3)[::2][: len(pts) // 2] = pts[: len(pts) // 2]  # every other pixel measured
    for enc in (impl.Encoding.ASCII, impl.Encoding.BINARY, impl.Encoding.BINARY_COMPRESSED):
        pc = pypcd4.PointCloud.from_xyz_points(pts)
        pc.save(tmp_path / "a.pcd", encoding=enc)
        assert enc.value.encode() in (tmp_path / "a.pcd").read_bytes()[:300]
        got, _ = read_point_cloud(tmp_path / "a.pcd")
        np.testing.assert_allclose(got, pts, rtol=1e-6)
        opc = pypcd4.PointCloud.from_xyz_points(organised.reshape(-1, 3))
        opc.metadata.width, opc.metadata.height = 40, 20  # an organised cloud, as a depth camera driver writes it
        opc.save(tmp_path / "o.pcd", encoding=enc)
        got, _ = read_point_cloud(tmp_path / "o.pcd")
        assert got.shape == (20, 40, 3)
        np.testing.assert_allclose(got, organised, rtol=1e-6)  # NaN where nothing was measured
    with pytest.raises(DataError, match="corrupt PCD binary_compressed"):
        raw = (tmp_path / "o.pcd").read_bytes()
        (tmp_path / "bad.pcd").write_bytes(raw[:-40] + bytes(40))
        read_point_cloud(tmp_path / "bad.pcd")


def test_organised_cloud_with_nans_predicts_and_labels_every_pixel(mug_sample, mug):
    grid = np.full((64, 96, 3), np.nan)
    grid.reshape(-1, 3)[: len(mug_sample["points"])] = mug_sample["points"]
    res = mug.predict(grid)
    assert len(res.part_labels) == 64 * 96 and (res.part_labels[len(mug_sample["points"]) :] == -1).all()
    assert not any("NaN" in w for w in res.warnings)  # an organised cloud marks missing pixels with NaN: normal


def test_truncated_npz_is_a_data_error(tmp_path, capsys, mug_sample):
    np.savez(tmp_path / "c.npz", points=mug_sample["points"])
    raw = (tmp_path / "c.npz").read_bytes()
    (tmp_path / "c.npz").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(DataError, match="c.npz"):
        read_point_cloud(tmp_path / "c.npz")
    rc, err = _cli(capsys, "predict", "--model", "mug", "--input", str(tmp_path / "c.npz"), "--out", str(tmp_path / "r.json"))
    assert rc == 2 and "c.npz" in err


# ----------------------------------------------------------------------------- units and frames
def test_millimetres_are_refused_with_a_hint_and_accepted_with_units(mug_sample, mug):
    with pytest.raises(InputError, match="looks like mm"):
        mug.predict(mug_sample["points"] * 1000.0)
    a = mug.predict(mug_sample["points"])
    b = mug.predict(mug_sample["points"] * 1000.0, units="mm")
    np.testing.assert_allclose(a.cam_from_part, b.cam_from_part, atol=1e-5)


def test_far_stray_points_are_warned_about_not_mistaken_for_other_units(mug_sample, mug):
    """A mask that let in floor up to the horizon: 15 % of the points 4-6 m away make the 90th-percentile
    radius far too big, but half of the points still lie within the mug: a warning, not a refusal."""
    pts = np.asarray(mug_sample["points"], np.float64)
    rng = np.random.default_rng(0)
    far = pts[rng.integers(0, len(pts), int(0.15 * len(pts)))] + rng.uniform(4.0, 6.0, (int(0.15 * len(pts)), 1)) * [0, 0.3, 1]
    res = mug.predict(np.concatenate([pts, far]))
    assert any("far points that are not the object" in w for w in res.warnings)


def test_depth_in_the_wrong_scale_or_8_bit_is_refused():
    depth = np.full((40, 40), 800, dtype=np.uint16)  # 0.8 m in millimetres
    K = (50.0, 50.0, 20.0, 20.0)
    assert len(rgbd_points(depth, K)) == 1600
    with pytest.raises(InputError, match="depth_scale"):
        rgbd_points(depth, K, depth_scale=1.0)  # millimetres read as metres: 800 m away
    with pytest.raises(InputError, match="8-bit"):
        rgbd_points((depth // 4).astype(np.uint8), K)
    with pytest.raises(InputError, match="finite"):
        rgbd_points(depth, K, box=(float("nan"), 0, 10, 10))


def test_clouds_that_are_no_object_in_the_camera_frame(mug_sample, mug):
    line = np.stack([np.linspace(0, 1, 100), np.zeros(100), np.full(100, 1.0)], 1)
    with pytest.raises(InputError, match="line"):
        mug.predict(line)
    with pytest.raises(InputError, match="behind the camera"):
        mug.predict(mug_sample["points"] * [1, 1, -1])
    plane = np.random.default_rng(0).uniform(-0.05, 0.05, (500, 3))
    plane[:, 2] = 0.7
    assert any("one plane" in w for w in mug.predict(plane).warnings)


# --------------------------------------------------------------------------------- CLI arguments
def test_cli_arguments_that_used_to_raise(tmp_path, capsys, mug_sample):
    np.save(tmp_path / "c.npy", mug_sample["points"])
    base = ["predict", "--model", "mug", "--input", str(tmp_path / "c.npy")]
    assert _cli(capsys, *base, "--out", str(tmp_path / "r.json"), "--seed", "-1")[0] == 2
    rc, err = _cli(capsys, *base, "--out", str(tmp_path / "r.json"), "--pairs", "99999999999")
    assert rc == 2 and "num_pairs" in err
    rc, err = _cli(capsys, *base, "--out", "/proc/forbidden/r.json")
    assert rc == 2 and "cannot" in err
    (tmp_path / "folder").mkdir()
    assert _cli(capsys, *base, "--pairs", "2000", "--out", str(tmp_path / "folder"))[0] == 0
    assert (tmp_path / "folder" / "c.json").is_file()  # an existing folder: the result goes inside
    assert _cli(capsys, *base, "--pairs", "2000", "--out", str(tmp_path / "new") + "/")[0] == 0
    assert (tmp_path / "new" / "c.json").is_file()  # a trailing slash names a folder


def test_a_glob_with_one_bad_file_predicts_the_others_and_exits_non_zero(tmp_path, capsys, mug_sample):
    np.save(tmp_path / "a.npy", mug_sample["points"])
    np.save(tmp_path / "b.npy", np.zeros((4, 2)))
    np.save(tmp_path / "c.npy", mug_sample["points"][::-1])
    rc, err = _cli(
        capsys,
        "predict",
        "--model",
        "mug",
        "--pairs",
        "2000",
        "--quiet",
        "--input",
        str(tmp_path / "*.npy"),
        "--out",
        str(tmp_path / "out"),
    )
    assert rc == 2 and "b: error" in err and "1 of 3" in err
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.json", "c.json"]


def test_vis_without_matplotlib_fails_before_predicting(tmp_path, mug_sample):
    np.save(tmp_path / "c.npy", mug_sample["points"])
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'matplotlib':\n"
        "            raise ImportError('no matplotlib here')\n"
        "sys.meta_path.insert(0, Block())\n"
        "from ucope.cli.main import main\n"
        f"sys.exit(main(['predict', '--model', 'mug', '--input', {str(tmp_path / 'c.npy')!r}, '--out', "
        f"{str(tmp_path / 'r.json')!r},"
        f" '--vis', {str(tmp_path / 'r.png')!r}]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "matplotlib" in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "r.json").exists()  # nothing predicted, nothing written


# ---------------------------------------------------------------------------------- Python API
def test_api_inputs_give_ucope_errors(mug_sample, mug):
    with pytest.raises(InputError, match="different lengths|ragged"):
        mug.predict([[0.0, 0.0, 1.0], [0.0, 1.0]])
    with pytest.raises(InputError, match="real numbers"):
        mug.predict(mug_sample["points"], normals=np.full(mug_sample["points"].shape, "a"))
    with pytest.raises(InputError, match="unknown stage"):
        Estimator(mug.model, stages=["vote_parts", 3])
    with pytest.raises(InputError, match="model must be"):
        Estimator.load(None)
    with pytest.raises(InputError, match="device"):
        Estimator(mug.model, device="tpu")
    with pytest.raises(InputError, match="units"):
        mug.predict(mug_sample["points"], units="inch")


def test_file_normals_are_turned_towards_the_camera(mug_sample, mug):
    pts, nrm = mug_sample["points"], mug_sample["normals"]
    flip = np.where(np.random.default_rng(0).random(len(nrm)) < 0.5, -1.0, 1.0)[:, None]  # Open3D-like: unoriented
    a = mug.predict(pts, nrm)
    b = mug.predict(pts, nrm * flip * 3.0)  # and not unit length
    np.testing.assert_allclose(a.cam_from_part, b.cam_from_part, atol=1e-6)


def test_the_same_cloud_in_any_order_gives_the_same_result(mug_sample, mug):
    perm = np.random.default_rng(3).permutation(len(mug_sample["points"]))
    a = mug.predict(mug_sample["points"])
    b = mug.predict(mug_sample["points"][perm])
    np.testing.assert_array_equal(a.cam_from_part, b.cam_from_part)
    np.testing.assert_array_equal(a.part_labels[perm], b.part_labels)
    big = np.repeat(mug_sample["points"], 3, axis=0) + np.random.default_rng(1).normal(0, 1e-4, (3 * len(perm), 3))
    c = prepare_points(big, seed=5, estimate=False)
    d = prepare_points(big[np.random.default_rng(2).permutation(len(big))], seed=5, estimate=False)
    np.testing.assert_array_equal(c.points, d.points)  # the subset of a larger cloud does not depend on the order


def test_labels_of_a_huge_cloud_match_the_exact_nearest_network_point(mug_sample):
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(0)
    ref = mug_sample["points"][::4]
    ref_labels = (ref[:, 1] > np.median(ref[:, 1])).astype(np.int64)  # two spatially coherent parts
    raw = np.repeat(mug_sample["points"], 80, axis=0) + rng.normal(0, 2e-3, (80 * len(mug_sample["points"]), 3))
    raw[5] = np.nan
    finite = np.isfinite(raw).all(1)
    out = label_points(raw, finite, ref, ref_labels)  # > 2^18 points: the lattice path
    exact = ref_labels[cKDTree(ref).query(np.nan_to_num(raw))[1]]
    assert out[5] == -1 and np.mean(out[finite] == exact[finite]) > 0.98


def test_ucope_data_needs_no_explicit_import():
    out = subprocess.run(
        [sys.executable, "-c", "import ucope; print(ucope.data.load_dataset.__name__)"], capture_output=True, text=True
    )
    assert out.returncode == 0 and out.stdout.strip() == "load_dataset"


# ------------------------------------------------------------------------------------ data sets
def _tiny_set(tmp_path, name="d", **kw):
    cfg = GenerateConfig(category="mug", split="test", num=4, shard_size=2, max_points=300, **kw)
    return generate_dataset(tmp_path / name, cfg, progress=False)


def test_bad_meta_and_corrupt_shards_are_named(tmp_path):
    root = _tiny_set(tmp_path)
    meta = json.loads((root / "meta.json").read_text())
    for bad, match in (
        ({"shard_size": 0}, "must be positive"),
        ({"num": -5}, "must be positive"),
        ({"generator_version": "0"}, "generator version 0, this ucope uses"),
        ({"conventions_version": "9"}, "conventions version 9"),
        ({"category_revision": 7}, "mug generator revision 7, this ucope uses 1"),
    ):
        (root / "meta.json").write_text(json.dumps({**meta, **bad}))
        with pytest.raises(DataError, match=match):
            ucope.data.load_dataset(root)[0]
    (root / "meta.json").write_text(json.dumps(meta))
    with np.load(root / "shard_00000.npz") as z:
        arrays = {k: z[k] for k in z.files}
    for key, value, match in (("part_labels", 200, "labels"), ("points", np.nan, "non-finite points")):
        broken = dict(arrays)
        broken[key] = arrays[key].copy()
        broken[key][3] = value
        np.savez(root / "shard_00000.npz", **broken)
        with pytest.raises(DataError, match=match):
            ucope.data.load_dataset(root)[0]
    broken = dict(arrays)
    broken["offsets"] = arrays["offsets"].copy()
    broken["offsets"][1] -= 10
    broken["offsets"][2] -= 10  # the last sample truncated: loads "fine" without the check
    np.savez(root / "shard_00000.npz", **broken)
    with pytest.raises(DataError, match="offsets"):
        ucope.data.load_dataset(root)[0]


def test_a_data_set_from_an_older_category_generator_is_refused(tmp_path):
    root = _tiny_set(tmp_path)
    meta = json.loads((root / "meta.json").read_text())
    assert meta["category_revision"] == 1
    ucope.data.check_versions({k: v for k, v in meta.items() if k != "category_revision"}, "m")  # absent: 1
    # the camera's generator is at revision 2 (the ultra-compacts): a revision-1 camera set is refused by name
    with pytest.raises(DataError, match="camera generator revision 1, this ucope uses 2"):
        ucope.data.check_versions({**meta, "category": "camera", "category_revision": 1}, "m")
    ucope.data.check_versions({**meta, "category": "camera", "category_revision": 2}, "m")
    # a category of your own is checked by its recorded spec, not by a built-in revision
    ucope.data.check_versions({**meta, "category": "robot_arm", "spec": {"name": "robot_arm"}, "category_revision": 1}, "m")


def test_generate_into_a_folder_of_shards_without_meta_refuses(tmp_path, capsys):
    root = _tiny_set(tmp_path)
    (root / "meta.json").unlink()
    rc, err = _cli(
        capsys,
        "generate",
        "--category",
        "laptop",
        "--split",
        "test",
        "--num",
        "4",
        "--shard-size",
        "2",
        "--out",
        str(root),
        "--quiet",
    )
    assert rc == 2 and "no meta.json" in err


def test_files_follow_the_umask(tmp_path, mug_sample, mug):
    old = os.umask(0o022)
    try:
        path = mug.predict(mug_sample["points"]).save(tmp_path / "r.json")
        root = _tiny_set(tmp_path)
    finally:
        os.umask(old)
    for f in (path, root / "meta.json", root / "shard_00000.npz"):
        assert f.stat().st_mode & 0o777 == 0o644, f


def test_a_killed_generate_leaves_no_worker_behind(tmp_path):
    out = tmp_path / "big"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "ucope",
            "generate",
            "--category",
            "drawer",
            "--split",
            "train",
            "--num",
            "400",
            "--shard-size",
            "20",
            "--workers",
            "2",
            "--out",
            str(out),
            "--quiet",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=False,
    )
    deadline = time.time() + 60
    while time.time() < deadline and not list(out.glob("shard_*.npz")):
        time.sleep(0.2)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    time.sleep(2.0)
    before = sorted(p.name for p in out.glob("shard_*.npz"))
    time.sleep(4.0)
    assert sorted(p.name for p in out.glob("shard_*.npz")) == before  # no orphan went on writing
    assert len(before) < 20


# ------------------------------------------------------------------------------------- models
def test_a_model_json_that_disagrees_with_its_weights_is_refused(tmp_path):
    from ucope.model.checkpoint import load_model, pretrained_dir

    for suffix in (".json", ".safetensors"):
        (tmp_path / f"m{suffix}").write_bytes((pretrained_dir() / f"laptop{suffix}").read_bytes())
    meta = json.loads((tmp_path / "m.json").read_text())
    pri = meta["config"]["priors"]
    pri["parts"].append({**pri["parts"][1], "name": "extra"})
    pri["joints"].append({**pri["joints"][0], "child": 2})
    (tmp_path / "m.json").write_text(json.dumps(meta))
    with pytest.raises(DataError, match="weight|shape"):
        load_model(tmp_path / "m.json")


def test_safetensors_is_a_hard_dependency():
    from importlib.metadata import requires

    reqs = requires("ucope") or []
    assert any(r.startswith("safetensors") and "extra" not in r for r in reqs)


# ------------------------------------------------------------------------------------ training
def test_resume_refuses_changed_settings_and_keeps_the_metrics_curve(tmp_path):
    sys.path.insert(0, str(Path(__file__).parent / "model"))
    from test_train import _Crash, _train_rows, tiny_train_config

    from ucope.model.train import TrainingError, train

    train(tiny_train_config(tmp_path / "ref", log_every=3, checkpoint_every=2))

    def crash(step):
        if step == 5:
            raise _Crash()

    with pytest.raises(_Crash):  # checkpoint at step 4, in the middle of the metrics window 4..6
        train(tiny_train_config(tmp_path / "cut", log_every=3, checkpoint_every=2), on_step=crash)
    with pytest.raises(TrainingError, match="lr: 0.001 -> 0.01"):
        train(tiny_train_config(tmp_path / "cut", log_every=3, checkpoint_every=2, resume=True, lr=1e-2))
    train(tiny_train_config(tmp_path / "cut", log_every=3, checkpoint_every=2, resume=True))
    assert _train_rows(tmp_path / "cut") == _train_rows(tmp_path / "ref")
