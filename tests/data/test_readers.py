"""The NOCS, ArtImage and BOP readers on small fixtures written by the tests in the documented layouts
(frames rendered by ucope, so the ground truth is known)."""

import json
import warnings

import numpy as np
import pytest
from frame_fixtures import (
    CAMERA640,
    SMALL,
    posed,
    render_frame,
    save_json,
    save_png,
    write_artimage,
    write_bop_scene,
    write_nocs_frame,
)

from ucope.data.readers import read_artimage, read_bop, read_nocs, read_samples
from ucope.data.readers.nocs import REAL275_INTRINSICS, read_nocs_meta
from ucope.data.sample import check_sample
from ucope.errors import DataError, InputError
from ucope.geometry.transforms import rotation_angle_deg
from ucope.render.camera import PinholeCamera

REAL640 = PinholeCamera(*REAL275_INTRINSICS, width=640, height=480)


def _nocs_frame(camera):
    return render_frame(
        [
            ("mug", 0, posed(0.6, 30, 30, (-0.12, 0.0, 0.2)), None),
            ("bowl", 1, posed(0.6, -20, 40, (0.12, 0.0, 0.3)), None),
            ("laptop_rigid", 0, posed(0.9, 10, 35, (0.0, 0.2, 0.9)), None),
        ],
        camera,
    )


@pytest.fixture(scope="module")
def nocs_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("nocs")
    cam, real = _nocs_frame(CAMERA640), _nocs_frame(REAL640)
    # CAMERA: 3-channel depth and mask, a class-0 background object in the meta; REAL275: 16-bit depth.
    write_nocs_frame(
        root / "CAMERA" / "val" / "00000" / "0000", cam, [6, 2, 5], three_channel=True, extra_meta=["9 0 02876657 bg"]
    )
    write_nocs_frame(root / "Real" / "test" / "scene_1" / "0003", real, [6, 2, 5], three_channel=False)
    return root, {"CAMERA": cam, "Real": real}


def _pose_errors(sample, truth):
    T, G = sample["cam_from_part"][0], truth["cam_from_part"][0]
    return float(rotation_angle_deg(T[:3, :3], G[:3, :3])), float(np.linalg.norm(T[:3, 3] - G[:3, 3]))


def test_nocs_ground_truth_is_recovered_from_the_coordinate_maps(nocs_root):
    root, frames = nocs_root
    samples = read_nocs(root)
    assert [s["category"] for s in samples] == ["mug", "bowl", "laptop_rigid"] * 2  # class 0 skipped, laptop -> laptop_rigid
    for s in samples:
        check_sample(s)
        which = "CAMERA" if s["instance_id"].startswith("CAMERA") else "Real"
        truth = frames[which]["objects"][["mug", "bowl", "laptop_rigid"].index(s["category"])]
        rot, trans = _pose_errors(s, truth)
        # 8-bit NOCS maps: about 1/255 of the box diagonal per coordinate
        assert rot < 1.5 and trans < 0.004, (s["instance_id"], rot, trans)
        np.testing.assert_allclose(s["size_m"][0], truth["size_m"][0], rtol=0.06)
        assert s["gt_fit_rmse_m"] < 0.003
        assert s["nocs_model"].startswith("model_") and len(s["points"]) >= 32
    assert tuple(samples[3]["intrinsics"]) == REAL275_INTRINSICS and samples[0]["intrinsics"][0] == 577.5


def test_nocs_category_filter_and_unknown_category(nocs_root):
    root, _ = nocs_root
    mugs = read_nocs(root, "mug")
    assert len(mugs) == 2 and {s["nocs_class"] for s in mugs} == {"mug"}
    assert read_samples("nocs", root, "bowl")[0]["category"] == "bowl"
    with pytest.raises(InputError, match="no 'laptop' objects"):
        read_nocs(root, "laptop")


def test_nocs_bad_files_name_the_file_and_element(tmp_path, nocs_root):
    root, frames = nocs_root
    prefix = tmp_path / "f" / "0000"
    write_nocs_frame(prefix, frames["CAMERA"], [6, 2, 5], three_channel=False)
    (tmp_path / "f" / "0000_coord.png").unlink()
    with pytest.raises(DataError, match=r"0000_coord\.png: no such file \(the NOCS coordinate map"):
        read_nocs(tmp_path)
    (tmp_path / "f" / "0000_meta.txt").write_text("1 6 m\n2 x bowl\n")
    with pytest.raises(DataError, match=r"0000_meta\.txt, line 2"):
        read_nocs_meta(tmp_path / "f" / "0000_meta.txt")
    (tmp_path / "f" / "0000_meta.txt").write_text("1 17 m\n")
    with pytest.raises(DataError, match="unknown NOCS class id 17"):
        read_nocs(tmp_path)
    (tmp_path / "f" / "0000_meta.txt").write_text("1 6 m\n")
    save_png(tmp_path / "f" / "0000_mask.png", np.zeros((10, 10), np.uint8))
    with pytest.raises(
        DataError, match=r"0000_mask\.png: the instance mask \(255 = background\) is 10x10, the depth image 640x480"
    ):
        read_nocs(tmp_path)
    (tmp_path / "f" / "0000_depth.png").write_bytes(b"not a png")
    with pytest.raises(DataError, match=r"0000_depth\.png: not a readable image"):
        read_nocs(tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match="holds no NOCS frames"):
        read_nocs(tmp_path / "empty")


@pytest.fixture(scope="module")
def artimage_roots(tmp_path_factory):
    out = {}
    for cat, scale, poly in (("laptop", 1.0, False), ("drawer", 1.25, True)):
        frames = [render_frame([(cat, i, posed(1.2 if cat == "drawer" else 0.8, 20 + 40 * i, 30), None)]) for i in range(2)]
        root = tmp_path_factory.mktemp(f"artimage_{cat}")
        write_artimage(root, frames, scale=scale, polygons=poly)
        out[cat] = (root, frames)
    return out


@pytest.mark.parametrize("category", ["laptop", "drawer"])
def test_artimage_parts_and_joints_in_our_conventions(artimage_roots, category):
    root, frames = artimage_roots[category]
    samples = read_artimage(root, category)
    assert len(samples) == 2
    for s, fr in zip(samples, frames, strict=False):
        check_sample(s)
        truth = fr["objects"][0]
        np.testing.assert_allclose(s["cam_from_part"], truth["cam_from_part"], atol=1e-9)
        np.testing.assert_allclose(s["size_m"], truth["size_m"], atol=1e-9)
        np.testing.assert_allclose(s["joint_pivot"], truth["joint_pivot"], atol=1e-9)
        np.testing.assert_allclose(s["joint_axis"], truth["joint_axis"], atol=1e-9)
        np.testing.assert_allclose(s["joint_state"], truth["joint_state"], atol=1e-9)
        K = len(truth["size_m"])
        assert set(np.unique(s["part_labels"])) <= set(range(K)) and len(np.unique(s["part_labels"])) >= 2
    if category == "laptop":  # the part mask gives exactly the rendered part labels
        lab = frames[0]["parts"]
        assert np.bincount(samples[0]["part_labels"], minlength=2).sum() == min(4096, int((lab >= 0).sum()))


def test_artimage_strict_errors(tmp_path, artimage_roots):
    import shutil

    src, _ = artimage_roots["laptop"]
    root = tmp_path / "a"
    shutil.copytree(src, root)
    with pytest.raises(DataError, match="a drawer has 4 links"):
        read_artimage(root, "drawer")
    ann = root / "annotations" / "scene_0" / "000001.json"
    d = json.loads(ann.read_text())
    d["instances"][0]["links"][1]["transformation"][0][0] *= 3.0
    ann.write_text(json.dumps(d))
    with pytest.raises(DataError, match=r"000001\.json: link 1: transformation is not a rotation times a uniform scale"):
        read_artimage(root, "laptop")
    del d["instances"][0]["links"][1]["state"]
    d["instances"][0]["links"][1]["transformation"][0][0] /= 3.0
    ann.write_text(json.dumps(d))
    with pytest.raises(DataError, match="link 1 needs a numeric 'state'"):
        read_artimage(root, "laptop")
    meta = json.loads((root / "urdf_metas.json").read_text())
    del meta["urdf_metas"][0]["joint_axis"]
    save_json(root / "urdf_metas.json", meta)
    with pytest.raises(DataError, match=r"urdf_metas\.json \(urdf 0\): needs joint_types.*joint_axis"):
        read_artimage(root, "laptop")
    (root / "camera_intrinsic.json").unlink()
    with pytest.raises(DataError, match=r"camera_intrinsic\.json does not exist"):
        read_artimage(root, "laptop")
    with pytest.raises(InputError, match="unknown category 'teapot'"):
        read_artimage(root, "teapot")


@pytest.fixture(scope="module")
def bop_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("bop")
    frame = render_frame(
        [
            ("mug", 0, posed(0.7, 30, 30, (-0.15, 0.0, 0.0)), None),
            ("mug", 0, posed(0.7, 150, 35, (0.15, 0.05, 0.1)), None),
            ("laptop", 0, posed(0.9, -30, 35, (0.0, 0.1, 0.6)), None),
        ],
        SMALL,
    )
    write_bop_scene(root / "test" / "000001", frame, [[1], [1], [2, 3]], im_id=7)
    return root, frame


def test_bop_scenes_rigid_and_articulated(bop_root):
    root, frame = bop_root
    mugs = read_bop(root / "test", "mug", obj_id=1)
    assert len(mugs) == 2
    for s, truth in zip(mugs, frame["objects"][:2], strict=False):
        check_sample(s)
        np.testing.assert_allclose(s["cam_from_part"], truth["cam_from_part"], atol=1e-6)  # mm JSON, box offset taken out
        np.testing.assert_allclose(s["size_m"], truth["size_m"], atol=1e-9)
        assert s["scene_id"] == 1 and s["im_id"] == 7
    (laptop,) = read_bop(root / "test" / "000001", "laptop", obj_id=2)
    np.testing.assert_allclose(laptop["cam_from_part"], frame["objects"][2]["cam_from_part"], atol=1e-6)
    assert np.isnan(laptop["joint_axis"]).all() and laptop["obj_ids"] == [2, 3]
    # the depth's 0.1 mm units (depth_scale) give the same points as the rendered millimetres
    assert np.abs(laptop["points"][:, 2]).max() < 2.0 and set(np.unique(laptop["part_labels"])) == {0, 1}


def test_bop_errors(tmp_path, bop_root):
    import shutil

    root, _ = bop_root
    copy = tmp_path / "b"
    shutil.copytree(root, copy)
    with pytest.raises(DataError, match=r"needs obj_ids \[1, 2\] once each"):
        read_bop(copy / "test", "laptop", obj_id=1)
    with pytest.raises(DataError, match=r"no obj_id 9"):
        read_bop(copy / "test", "mug", obj_id=9)
    (copy / "test" / "000001" / "mask_visib" / "000007_000001.png").unlink()
    with pytest.raises(DataError, match="no mask for image 7, object 1"):
        read_bop(copy / "test", "mug")
    (copy / "test" / "models" / "models_info.json").unlink()
    with pytest.raises(DataError, match="no models_info.json"):
        read_bop(copy / "test", "mug")
    with pytest.raises(DataError, match="holds no BOP scene"):
        read_bop(tmp_path, "mug")


def test_bop_reads_what_ucope_generate_images_writes(tmp_path):
    from ucope.data.dataset import load_dataset
    from ucope.data.generate import GenerateConfig, generate_dataset

    out = tmp_path / "gen"
    generate_dataset(out, GenerateConfig(category="laptop", split="test", num=2, images=True), progress=False)
    ds = load_dataset(out)
    # the generator's model frames are the part frames: boxes centred on them (per image sizes differ, use image 1's)
    s1 = ds[1]
    save_json(
        out / "images" / "models_info.json",
        {
            str(k + 1): {
                "min_x": -500 * s1["size_m"][k][0],
                "min_y": -500 * s1["size_m"][k][1],
                "min_z": -500 * s1["size_m"][k][2],
                "size_x": 1000 * s1["size_m"][k][0],
                "size_y": 1000 * s1["size_m"][k][1],
                "size_z": 1000 * s1["size_m"][k][2],
            }
            for k in range(2)
        },
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        samples = read_bop(out, "laptop")
    assert len(samples) == 2
    s = samples[1]
    np.testing.assert_allclose(s["cam_from_part"], s1["cam_from_part"], atol=1e-6)
    np.testing.assert_allclose(s["size_m"], s1["size_m"], atol=1e-9)
    # the label mask (value = gt_id = part index) gives the generated labels' proportions
    frac = np.bincount(s["part_labels"], minlength=2) / len(s["part_labels"])
    frac_gen = np.bincount(s1["part_labels"], minlength=2) / len(s1["part_labels"])
    np.testing.assert_allclose(frac, frac_gen, atol=0.05)
