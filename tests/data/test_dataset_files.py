"""Data sets on disk: round trip, determinism across workers and machines, resume, bad input."""

import json

import numpy as np
import pytest
from scipy.spatial import cKDTree

from ucope.data import GenerateConfig, PointCloudDataset, generate_dataset, load_dataset, make_sample
from ucope.data.images import read_png
from ucope.data.shards import read_shard, shard_name, write_shard
from ucope.errors import DataError, InputError, UnknownCategoryError

FIELDS = (
    "points",
    "normals",
    "part_labels",
    "cam_from_part",
    "size_m",
    "joint_type",
    "joint_pivot",
    "joint_axis",
    "joint_state",
    "cam_from_object",
    "intrinsics",
)


def _assert_same(a, b, normal_atol=0.0):
    for k in FIELDS:
        np.testing.assert_allclose(a[k], b[k], atol=normal_atol if k == "normals" else 0.0, err_msg=k)
    assert a["instance_id"] == b["instance_id"] and a["category"] == b["category"] and a["index"] == b["index"]


def test_shard_round_trip(tmp_path):
    cfg = GenerateConfig(category="drawer", split="test")
    samples = [make_sample(cfg, i) for i in range(3)]
    write_shard(tmp_path / "s.npz", samples)
    back = read_shard(tmp_path / "s.npz")
    for a, b in zip(samples, back, strict=False):
        _assert_same(a, b, normal_atol=1e-3)  # normals are stored as float16
        assert b["points"].dtype == np.float32 and b["part_labels"].dtype == np.int64


def test_same_files_for_any_worker_count_and_shard_split(tmp_path):
    cfg = GenerateConfig(category="scissors", split="train", num=7, shard_size=2, views_per_instance=3)
    one = load_dataset(generate_dataset(tmp_path / "w1", cfg, workers=1, progress=False))
    two = load_dataset(generate_dataset(tmp_path / "w2", cfg, workers=2, progress=False))
    # two "machines", each making a range of the shards into the same folder
    generate_dataset(tmp_path / "split", cfg, shards=range(0, 1), progress=False)
    generate_dataset(tmp_path / "split", cfg, shards=range(1, 4), progress=False)
    split = load_dataset(tmp_path / "split")
    assert len(one) == len(two) == len(split) == 7
    for i in range(7):
        _assert_same(one[i], two[i])
        _assert_same(one[i], split[i])
    assert one[-1]["index"] == 6
    assert [s["index"] for s in one[2:4]] == [2, 3]
    with pytest.raises(IndexError):
        one[7]


def test_resume_rebuilds_only_missing_shards(tmp_path):
    cfg = GenerateConfig(category="can", split="val", num=6, shard_size=2)
    out = generate_dataset(tmp_path / "d", cfg, progress=False)
    before = {s: (out / shard_name(s)).stat().st_mtime_ns for s in range(3)}
    ref = load_dataset(out)[3]
    (out / shard_name(1)).unlink()
    with pytest.raises(DataError, match="incomplete.*shard_00001.npz"):
        load_dataset(out)
    generate_dataset(out, cfg, progress=False)
    assert (out / shard_name(0)).stat().st_mtime_ns == before[0]
    assert (out / shard_name(2)).stat().st_mtime_ns == before[2]
    _assert_same(load_dataset(out)[3], ref)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["category"] == "can" and meta["num_parts"] == 1 and meta["seed"] == 0
    assert {"generator_version", "conventions_version", "view", "joint_types"} <= set(meta)
    with pytest.raises(DataError, match="other settings.*num"):
        generate_dataset(out, GenerateConfig(category="can", split="val", num=8, shard_size=2), progress=False)


def test_corrupt_and_truncated_shards_are_named(tmp_path):
    cfg = GenerateConfig(category="bowl", split="test", num=4, shard_size=2)
    out = generate_dataset(tmp_path / "d", cfg, progress=False)
    p0, p1 = out / shard_name(0), out / shard_name(1)
    data = p0.read_bytes()
    p0.write_bytes(data[: len(data) // 2])
    p1.write_bytes(b"not a shard at all" * 10)
    ds = load_dataset(out)
    with pytest.raises(DataError, match="shard_00000.npz.*truncated or corrupt"):
        ds[0]
    with pytest.raises(DataError, match="shard_00001.npz"):
        ds[3]
    (out / "meta.json").write_text("{ broken")
    with pytest.raises(DataError, match="meta.json"):
        load_dataset(out)
    with pytest.raises(DataError, match="does not exist"):
        load_dataset(tmp_path / "nowhere")


def test_bad_generation_requests(tmp_path):
    with pytest.raises(UnknownCategoryError, match="valid categories: laptop, eyeglasses"):
        generate_dataset(tmp_path / "x", GenerateConfig(category="teapot"), progress=False)
    for bad in (0, -3):
        with pytest.raises(InputError, match="num must be a positive integer"):
            generate_dataset(tmp_path / "x", GenerateConfig(category="mug", num=bad), progress=False)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(DataError, match="cannot write to output folder"):
        generate_dataset(blocker / "out", GenerateConfig(category="mug", num=2), progress=False)
    with pytest.raises(InputError, match="workers"):
        generate_dataset(tmp_path / "y", GenerateConfig(category="mug", num=2), workers=0, progress=False)


def test_images_and_bop_files(tmp_path):
    cfg = GenerateConfig(category="laptop", split="test", num=3, shard_size=2, images=True)
    out = generate_dataset(tmp_path / "d", cfg, progress=False)
    ds = load_dataset(out)
    depth = read_png(out / "images" / "depth" / "000002.png")
    mask = read_png(out / "images" / "mask" / "000002.png")
    assert depth.dtype == np.uint16 and depth.shape == (240, 320) and mask.dtype == np.uint8
    s = ds[2]
    # the stored cloud is the back-projection of the PNG's object pixels
    fx, fy, cx, cy = s["intrinsics"]
    rows, cols = np.nonzero((mask < 2) & (depth > 0))
    z = depth[rows, cols] / 1000.0
    cloud = np.c_[(cols - cx) / fx * z, (rows - cy) / fy * z, z]
    assert len(cloud) >= len(s["points"])
    dist, _ = cKDTree(cloud).query(s["points"])
    assert dist.max() < 1e-5  # every stored point is one of the PNG's object pixels
    cams = json.loads((out / "images" / "scene_camera.json").read_text())
    gts = json.loads((out / "images" / "scene_gt.json").read_text())
    assert sorted(cams, key=int) == ["0", "1", "2"]
    np.testing.assert_allclose(np.array(cams["2"]["cam_K"]).reshape(3, 3)[0, 0], fx)
    g = gts["2"][1]
    assert g["obj_id"] == 2
    np.testing.assert_allclose(np.array(g["cam_R_m2c"]).reshape(3, 3), s["cam_from_part"][1, :3, :3], atol=1e-9)
    np.testing.assert_allclose(np.array(g["cam_t_m2c"]) / 1000.0, s["cam_from_part"][1, :3, 3], atol=1e-9)


def test_torch_dataset_fixed_size_and_seeded(tmp_path):
    out = generate_dataset(tmp_path / "d", GenerateConfig(category="mug", split="train", num=3, max_points=500), progress=False)
    ds = PointCloudDataset(out, num_points=700, seed=1)
    a, b = ds[1], ds[1]
    assert a["points"].shape == (700, 3) and a["part_labels"].shape == (700,)
    assert a["cam_from_part"].shape == (1, 4, 4) and a["joint_state"].shape == (0,)
    assert (a["points"] == b["points"]).all()
    ds.set_epoch(1)
    small = PointCloudDataset(out, num_points=100, seed=1)
    assert small[0]["points"].shape == (100, 3)
    with pytest.raises(InputError):
        PointCloudDataset(out, num_points=0)


def test_stretched_data_set_records_its_range_and_shows_the_stretched_objects(tmp_path, capsys):
    from ucope.cli.main import main
    from ucope.objects.categories import make_instance

    out = tmp_path / "st"
    argv = ["generate", "--category", "dishwasher", "--num", "2", "--seed", "2", "--out", str(out), "--quiet"]
    assert main([*argv, "--stretch", "0.5,2"]) == 0
    meta = json.loads((out / "meta.json").read_text())
    assert meta["stretch"] == [0.5, 2.0] and meta["stretch_share"] == 1.0
    cfg = GenerateConfig(category="dishwasher", num=2, seed=2, stretch=(0.5, 2.0))
    obj = make_instance("dishwasher", "train", 0, 2, stretch_range=(0.5, 2.0))
    s = load_dataset(out)[0]
    np.testing.assert_allclose(s["size_m"], obj.size_m, rtol=1e-6)
    _assert_same(s, make_sample(cfg, 0), normal_atol=2e-3)
    # the unstretched data set has the same shapes at their generated proportions, and no stretch key
    plain = make_sample(GenerateConfig(category="dishwasher", num=2, seed=2), 0)
    np.testing.assert_allclose(plain["size_m"] * np.asarray(obj.stretch), s["size_m"], rtol=1e-6)
    assert "stretch" not in GenerateConfig(category="dishwasher").settings()
    # a different range is a different data set: resuming with it is refused, naming the setting
    capsys.readouterr()
    assert main([*argv, "--stretch", "0.7,1.5"]) != 0
    assert "other settings (stretch differ)" in capsys.readouterr().err
    with pytest.raises(InputError, match="stretch range must satisfy"):
        GenerateConfig(category="dishwasher", stretch=(1.2, 2.0)).validate()
    with pytest.raises(InputError, match="stretch share must be a fraction"):
        GenerateConfig(category="dishwasher", stretch=(0.5, 2.0), stretch_share=-0.1).validate()
    with pytest.raises(InputError, match="a stretch share needs a stretch range"):
        GenerateConfig(category="dishwasher", stretch_share=0.5).validate()
    with pytest.raises(SystemExit):
        main([*argv, "--stretch", "0.5"])
    assert "expected two numbers LOW,HIGH" in capsys.readouterr().err
