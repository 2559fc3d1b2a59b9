import json

import numpy as np
import pytest

from ucope.data.io import read_intrinsics, read_point_cloud
from ucope.errors import DataError, InputError


@pytest.fixture
def cloud(rng):
    pts = rng.normal(size=(50, 3))
    nrm = rng.normal(size=(50, 3))
    return pts, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def test_npy_npz_xyz(tmp_path, cloud):
    pts, nrm = cloud
    np.save(tmp_path / "a.npy", pts)
    p, n = read_point_cloud(tmp_path / "a.npy")
    assert np.array_equal(p, pts) and n is None
    np.save(tmp_path / "b.npy", np.hstack([pts, nrm]).astype(np.float32))
    p, n = read_point_cloud(tmp_path / "b.npy")
    np.testing.assert_allclose(n, nrm, atol=1e-6)
    np.savez(tmp_path / "c.npz", points=pts, normals=nrm)
    p, n = read_point_cloud(tmp_path / "c.npz")
    assert np.array_equal(n, nrm)
    np.savetxt(tmp_path / "d.xyz", np.hstack([pts, nrm]), header="x y z nx ny nz")
    p, n = read_point_cloud(tmp_path / "d.xyz")
    np.testing.assert_allclose(p, pts)
    np.testing.assert_allclose(n, nrm)


def test_ply(tmp_path, cloud):
    import trimesh

    pts, _ = cloud
    trimesh.PointCloud(pts).export(tmp_path / "a.ply")
    p, _ = read_point_cloud(tmp_path / "a.ply")
    np.testing.assert_allclose(p, pts, atol=1e-6)
    (tmp_path / "bad.ply").write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nend_header\n\x00"
    )
    with pytest.raises(DataError, match="bad.ply"):
        read_point_cloud(tmp_path / "bad.ply")


def _pcd_header(n, data):
    return (
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n"
        f"COUNT 1 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    )


def test_pcd_ascii_binary_truncated(tmp_path, cloud):
    pts, nrm = cloud
    arr = np.hstack([pts, nrm]).astype(np.float32)
    body = "\n".join(" ".join(f"{v:.8g}" for v in row) for row in arr)
    (tmp_path / "a.pcd").write_text(_pcd_header(50, "ascii") + body + "\n")
    p, n = read_point_cloud(tmp_path / "a.pcd")
    np.testing.assert_allclose(p, pts, atol=1e-6)
    np.testing.assert_allclose(n, nrm, atol=1e-6)
    (tmp_path / "b.pcd").write_bytes(_pcd_header(50, "binary").encode() + arr.astype("<f4").tobytes())
    p, n = read_point_cloud(tmp_path / "b.pcd")
    np.testing.assert_allclose(p, pts, atol=1e-6)
    (tmp_path / "c.pcd").write_bytes(_pcd_header(50, "binary").encode() + arr.astype("<f4").tobytes()[:100])
    with pytest.raises(DataError, match="c.pcd.*truncated"):
        read_point_cloud(tmp_path / "c.pcd")


def test_bad_files(tmp_path):
    np.save(tmp_path / "w.npy", np.zeros((5, 4)))
    with pytest.raises(DataError, match=r"w.npy.*\(5, 4\)"):
        read_point_cloud(tmp_path / "w.npy")
    with pytest.raises(DataError, match="no such file"):
        read_point_cloud(tmp_path / "missing.ply")
    (tmp_path / "x.obj").write_text("v 0 0 0\n")
    with pytest.raises(InputError, match="unsupported"):
        read_point_cloud(tmp_path / "x.obj")
    (tmp_path / "r.xyz").write_text("1 2 3\n4 5\n")
    with pytest.raises(DataError, match="columns"):
        read_point_cloud(tmp_path / "r.xyz")
    (tmp_path / "t.npy").write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(DataError, match="t.npy"):
        read_point_cloud(tmp_path / "t.npy")


def test_intrinsics(tmp_path):
    (tmp_path / "a.json").write_text(json.dumps({"fx": 500, "fy": 501, "cx": 320, "cy": 240}))
    assert read_intrinsics(tmp_path / "a.json").tolist() == [500, 501, 320, 240]
    (tmp_path / "b.json").write_text(json.dumps({"cam_K": [500, 0, 320, 0, 501, 240, 0, 0, 1]}))
    assert read_intrinsics(tmp_path / "b.json").tolist() == [500, 501, 320, 240]
    (tmp_path / "c.json").write_text(json.dumps({"camera": {"K": [[500, 0, 320], [0, 501, 240], [0, 0, 1]]}}))
    assert read_intrinsics(tmp_path / "c.json").tolist() == [500, 501, 320, 240]
    (tmp_path / "d.json").write_text("{not json")
    with pytest.raises(DataError, match="d.json"):
        read_intrinsics(tmp_path / "d.json")
    (tmp_path / "e.json").write_text(json.dumps({"fx": -1, "fy": 1, "cx": 0, "cy": 0}))
    with pytest.raises(DataError, match="positive"):
        read_intrinsics(tmp_path / "e.json")


def test_intrinsics_from_a_bop_scene_camera(tmp_path):
    K = [500, 0, 320, 0, 501, 240, 0, 0, 1]
    (tmp_path / "s.json").write_text(json.dumps({"0": {"cam_K": K, "depth_scale": 1.0}, "1": {"cam_K": K, "depth_scale": 1.0}}))
    assert read_intrinsics(tmp_path / "s.json").tolist() == [500, 501, 320, 240]
    (tmp_path / "t.json").write_text(json.dumps({"0": {"cam_K": K}, "1": {"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1]}}))
    with pytest.raises(DataError, match="2 different cameras"):
        read_intrinsics(tmp_path / "t.json")
