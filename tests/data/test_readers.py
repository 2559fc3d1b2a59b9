"""The NOCS, ArtImage and BOP readers on small fixtures written by the tests in the documented layouts
(frames rendered by ucope, so the ground truth is known)."""

import json
import pickle
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
from ucope.data.readers.nocs import CAMERA_INTRINSICS, REAL275_INTRINSICS, read_nocs_meta
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


def test_nocs_intrinsics_come_from_the_data_root_down(tmp_path, nocs_root):
    _, frames = nocs_root
    # CAMERA frames below a folder named like a RealSense capture: the folders above the root never count
    prefix = tmp_path / "realsense_captures" / "CAMERA" / "val" / "00000" / "0000"
    write_nocs_frame(prefix, frames["CAMERA"], [6, 2, 5], three_channel=True)
    for root in (tmp_path / "realsense_captures" / "CAMERA", tmp_path / "realsense_captures"):
        assert tuple(read_nocs(root, "mug")[0]["intrinsics"]) == CAMERA_INTRINSICS
    plain = tmp_path / "frames" / "0000"
    write_nocs_frame(plain, frames["Real"], [6, 2, 5], three_channel=False)
    with pytest.raises(DataError, match=r"say neither REAL275 nor CAMERA25; give the data set \(--dataset real\|camera"):
        read_nocs(tmp_path / "frames")
    assert tuple(read_nocs(tmp_path / "frames", "mug", dataset="real")[0]["intrinsics"]) == REAL275_INTRINSICS
    with pytest.raises(InputError, match="dataset must be 'real'"):
        read_nocs(tmp_path / "frames", dataset="REAL275")


def _gts_pickle(frame, classes) -> bytes:
    """A NOCS gts pickle of a rendered frame (protocol 2, as NOCS's Python 3 code wrote them): gt_RTs =
    [s R | t] from the centred NOCS space (s = the box diagonal), gt_scales = the box in NOCS units."""
    RTs, scales = [], []
    for o in frame["objects"]:
        T, size = o["cam_from_part"][0], o["size_m"][0]
        s = float(np.linalg.norm(size))
        RT = np.eye(4)
        RT[:3, :3], RT[:3, 3] = s * T[:3, :3], T[:3, 3]
        RTs.append(RT)
        scales.append(size / s)
    doc = {
        "image_path": "data/real/test/scene_1/0003",
        "gt_class_ids": np.array(classes, np.int32),
        "gt_RTs": np.stack(RTs),
        "gt_scales": np.stack(scales),
        "gt_handle_visibility": np.ones(len(classes), np.int32),
    }
    return pickle.dumps(doc, protocol=2)


def test_nocs_official_gts_poses_and_model_boxes(tmp_path, nocs_root):
    root, frames = nocs_root
    gts = tmp_path / "gts" / "real_test"
    gts.mkdir(parents=True)
    (gts / "results_real_test_scene_1_0003.pkl").write_bytes(_gts_pickle(frames["Real"], [6, 2, 5]))
    fitted = read_nocs(root / "Real", "mug")[0]
    official = read_nocs(root / "Real", "mug", gts=tmp_path / "gts")[0]
    truth = frames["Real"]["objects"][0]
    assert fitted["gt_source"] == "coord" and official["gt_source"] == "gts"
    np.testing.assert_allclose(official["size_m"][0], truth["size_m"][0], atol=1e-9)  # the model's box, not the visible one
    np.testing.assert_allclose(official["cam_from_part"][0], truth["cam_from_part"][0], atol=1e-9)
    assert np.abs(fitted["size_m"][0] - truth["size_m"][0]).max() > 1e-4
    # a gts entry that is another instance's pose is refused
    bad = _gts_pickle(frames["Real"], [6, 2, 5])
    doc = pickle.loads(bad)
    doc["gt_RTs"][0, 0, 3] += 0.3
    (gts / "results_real_test_scene_1_0003.pkl").write_bytes(pickle.dumps(doc, protocol=2))
    with pytest.raises(DataError, match=r"scene_1_0003\.pkl: entry 0 \(class 6\) lies 30\.0 cm from instance 1"):
        read_nocs(root / "Real", "mug", gts=tmp_path / "gts")


class _Evil:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        import os

        return (os.system, (f"touch {self.marker}",))


def test_nocs_gts_unpickler_refuses_anything_but_arrays(tmp_path):
    from ucope.data.readers.nocs import read_nocs_gts

    marker = tmp_path / "pwned"
    path = tmp_path / "results_val_00000_0000.pkl"
    path.write_bytes(pickle.dumps({"gt_class_ids": _Evil(marker)}, protocol=2))
    with pytest.raises(DataError, match=r"results_val_00000_0000\.pkl: refused to unpickle (posix|os|nt)\.system"):
        read_nocs_gts(path)
    assert not marker.exists()
    path.write_bytes(pickle.dumps({"gt_class_ids": np.zeros(1)}, protocol=4))
    with pytest.raises(DataError, match="a dict with gt_class_ids, gt_RTs and gt_scales"):
        read_nocs_gts(path)
    path.write_bytes(b"\x80\x02garbage")
    with pytest.raises(DataError, match="not a readable NOCS gts pickle"):
        read_nocs_gts(path)


def test_nocs_fifo_meta_is_refused_not_read(tmp_path, nocs_root):
    import os

    _, frames = nocs_root
    prefix = tmp_path / "camera" / "0000"
    write_nocs_frame(prefix, frames["CAMERA"], [6, 2, 5], three_channel=False)
    meta = tmp_path / "camera" / "0000_meta.txt"
    meta.unlink()
    os.mkfifo(meta)  # reading it would block forever
    with pytest.raises(DataError, match=r"0000_meta\.txt: not a regular file \(a FIFO, socket or device\)"):
        read_nocs(tmp_path)


def test_nocs_random_coordinate_map_is_warned_about(tmp_path, nocs_root):
    _, frames = nocs_root
    prefix = tmp_path / "camera" / "0000"
    write_nocs_frame(prefix, frames["CAMERA"], [6, 2, 5], three_channel=False)
    rng = np.random.default_rng(0)
    save_png(tmp_path / "camera" / "0000_coord.png", rng.integers(0, 256, (480, 640, 3), dtype=np.uint8))
    with pytest.warns(UserWarning, match=r"coordinate map fits the depth poorly .*0000_coord\.png, instance 1: RMS"):
        samples = read_nocs(tmp_path, "mug")
    assert samples[0]["gt_fit_poor"]


@pytest.fixture(scope="module")
def artimage_roots(tmp_path_factory):
    """Frames in the authors' layout: laptops (compressed RLE, 1-based link ids, one frame with two laptops,
    states away from the rest state) and drawers (polygons, 0-based ids, a scale)."""
    from ucope.objects.categories import make_instance

    out = {}
    for cat, scale, seg, base in (("laptop", 1.0, "rle", 1), ("drawer", 1.25, "polygons", 0)):
        lim = make_instance(cat, "test", 0).limits
        state = lim[:, 0] + 0.3 * (lim[:, 1] - lim[:, 0])
        frames = [render_frame([(cat, i, posed(1.2 if cat == "drawer" else 0.8, 20 + 40 * i, 30), state)]) for i in range(2)]
        if cat == "laptop":
            frames.append(
                render_frame(
                    [(cat, 0, posed(0.9, 30, 30, (-0.2, 0.0, 0.0)), None), (cat, 1, posed(0.9, -40, 30, (0.2, 0.0, 0.1)), None)]
                )
            )
        root = tmp_path_factory.mktemp(f"artimage_{cat}")
        write_artimage(root, frames, scale=scale, segmentation=seg, link_base=base)
        out[cat] = (root, frames)
    return out


@pytest.mark.parametrize("category", ["laptop", "drawer"])
def test_artimage_published_layout_in_our_conventions(artimage_roots, category):
    root, frames = artimage_roots[category]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        samples = read_artimage(root, category)
    truths = [o for fr in frames for o in fr["objects"]]
    assert len(samples) == len(truths) == (4 if category == "laptop" else 2)  # two laptops in the third frame
    for s, truth in zip(samples, truths, strict=True):
        check_sample(s)
        for key in ("cam_from_part", "size_m", "joint_pivot", "joint_axis", "joint_state"):
            np.testing.assert_allclose(s[key], truth[key], atol=1e-9, err_msg=key)  # states measured from the poses
        assert s["joint_fit_residual"].max() < 1e-6
        K = len(truth["size_m"])
        assert set(np.unique(s["part_labels"])) <= set(range(K)) and len(np.unique(s["part_labels"])) >= 2
    if category == "laptop":  # RLE masks give exactly the rendered part labels, instance by instance
        assert [s["instance_id"] for s in samples[2:]] == ["scene_0/000002/0", "scene_0/000002/1"]
        lab = frames[0]["parts"]
        assert np.bincount(samples[0]["part_labels"], minlength=2).sum() == min(4096, int((lab >= 0).sum()))


def test_artimage_rle_decoding_matches_coco():
    from frame_fixtures import coco_rle

    from ucope.data.readers.artimage import rle_mask

    m = np.random.default_rng(0).random((13, 17)) > 0.4
    m[0, 0] = True  # a first run of foreground: COCO starts with an empty background run
    for compressed in (True, False):
        np.testing.assert_array_equal(rle_mask(coco_rle(m, compressed), m.shape, "x"), m)
    with pytest.raises(DataError, match=r"x: segmentation.size must be the image size \[17, 13\], got \[13, 17\]"):
        rle_mask(coco_rle(m), (17, 13), "x")


def _copy(src, dst):
    import shutil

    shutil.copytree(src, dst)
    ann = dst / "annotations" / "scene_0" / "000001.json"
    return ann, json.loads(ann.read_text())


def test_artimage_strict_errors_name_file_and_field(tmp_path, artimage_roots):
    src, _ = artimage_roots["laptop"]
    with pytest.raises(DataError, match=r"a drawer has 4 links with link_category_id 1..4"):
        read_artimage(src, "drawer")
    with pytest.raises(InputError, match="unknown category 'teapot'"):
        read_artimage(src, "teapot")
    cases = {  # a wrong value in an annotation -> the message names the file and the field
        "instance 5": (lambda d: d["instances"].__setitem__(0, 5), r"000001\.json: instances\[0\]: must be an object, got int 5"),
        "link id abc": (
            lambda d: d["instances"][0]["links"][0].update(link_category_id="abc"),
            r"000001\.json: instances\[0\]\.links\[0\]\.link_category_id: must be an integer, got 'abc'",
        ),
        "urdf_id x": (lambda d: d["instances"][0].update(urdf_id="x"), r"instances\[0\]\.urdf_id: must be an integer, got 'x'"),
        "scaled link": (
            lambda d: d["instances"][0]["links"][1]["transformation"][0].__setitem__(0, 3.0),
            r"000001\.json: instances\[0\]\.links\[1\] \(link 1\): transformation is not a rotation times a uniform scale",
        ),
        "NaN pose": (
            lambda d: d["instances"][0]["links"][0]["transformation"][0].__setitem__(3, float("nan")),
            r"links\[0\] \(link 2\): transformation: a 4x4 matrix of numbers must be finite",
        ),
        "absolute depth": (lambda d: d.update(depth_path="/etc/passwd"), r"json: depth_path: '/etc/passwd' is an absolute"),
        "climbing depth": (lambda d: d.update(depth_path="../../x.png"), r"depth_path: '../../x.png' climbs out with '..'"),
        "polygon": (
            lambda d: d["instances"][0]["links"][0].update(segmentation=[[1, 2, 3]]),
            r"links\[0\] \(link 2\)\.segmentation: segmentation\[0\] has an odd number of coordinates",
        ),
    }
    for name, (mutate, message) in cases.items():
        root = tmp_path / name.replace(" ", "_")
        ann, d = _copy(src, root)
        mutate(d)
        ann.write_text(json.dumps(d))
        with pytest.raises(DataError, match=message):
            read_artimage(root, "laptop")
    # urdf_metas.json: ragged or NaN corners, a missing joint field, a missing file
    root = tmp_path / "metas"
    _copy(src, root)
    meta = json.loads((root / "urdf_metas.json").read_text())
    good = json.loads(json.dumps(meta))
    meta["urdf_metas"][1]["corner_pts"][1] = [[[0, 0]], [[1, 1, 1]]]
    save_json(root / "urdf_metas.json", meta)
    with pytest.raises(DataError, match=r"urdf_metas\.json \(urdf 101\): corner_pts must be a \(3, 2, 1, 3\) array"):
        read_artimage(root, "laptop")
    meta = json.loads(json.dumps(good))
    meta["urdf_metas"][1]["corner_pts"][2][0][0][1] = float("nan")
    save_json(root / "urdf_metas.json", meta)
    with pytest.raises(DataError, match=r"\(urdf 101\): corner_pts must be finite"):
        read_artimage(root, "laptop")
    meta = json.loads(json.dumps(good))
    del meta["urdf_metas"][1]["joint_rpy"]
    save_json(root / "urdf_metas.json", meta)
    with pytest.raises(DataError, match=r"\(urdf 101\): needs joint_types.*\(missing joint_rpy\)"):
        read_artimage(root, "laptop")
    (root / "camera_intrinsic.json").unlink()
    with pytest.raises(DataError, match=r"camera_intrinsic\.json: no such file"):
        read_artimage(root, "laptop")


def test_artimage_depth_link_leading_out_is_refused(tmp_path, artimage_roots):
    src, _ = artimage_roots["laptop"]
    root = tmp_path / "a"
    _copy(src, root)
    outside = tmp_path / "outside.png"
    (root / "depth" / "scene_0" / "000001.png").rename(outside)
    (root / "depth" / "scene_0" / "000001.png").symlink_to(outside)
    with pytest.raises(DataError, match=r"depth_path: 'scene_0/000001.png' leads to .*outside the data set's folder"):
        read_artimage(root, "laptop")


def test_artimage_other_objects_are_skipped_with_a_warning(tmp_path, artimage_roots):
    src, _ = artimage_roots["laptop"]
    root = tmp_path / "a"
    ann, d = _copy(src, root)
    d["instances"][0]["urdf_id"] = 999
    ann.write_text(json.dumps(d))
    with pytest.warns(UserWarning, match=r"skipped 1 instance\(s\) whose urdf_id is not in .*urdf_metas\.json"):
        assert len(read_artimage(root, "laptop")) == 3


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
    with pytest.raises(DataError, match=r"image 7: a laptop is one entry of each of obj_ids \[1, 2\].*2 of obj_id 1, 1 of"):
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


def test_bop_two_articulated_instances_in_one_image(tmp_path):
    frame = render_frame(
        [
            ("laptop", 0, posed(0.9, -30, 35, (-0.25, 0.05, 0.3)), None),
            ("laptop", 0, posed(0.9, 40, 35, (0.25, 0.05, 0.3)), None),  # one model: one models_info box
        ],
        SMALL,
    )
    # entries base 0, lid 1, base 1, lid 0: pairing by order would join the wrong lids; the parts are joined by position
    write_bop_scene(tmp_path / "000002", frame, [[2, 3], [2, 3]], im_id=3)
    gt_path = tmp_path / "000002" / "scene_gt.json"
    gt = json.loads(gt_path.read_text())
    order = [0, 3, 2, 1]
    gt["3"] = [gt["3"][i] for i in order]
    save_json(gt_path, gt)
    for old, new in zip(order, range(4), strict=True):
        (tmp_path / "000002" / "mask_visib" / f"000003_{old:06d}.png").rename(tmp_path / "000002" / "mask_visib" / f"x_{new}.png")
    for new in range(4):
        (tmp_path / "000002" / "mask_visib" / f"x_{new}.png").rename(tmp_path / "000002" / "mask_visib" / f"000003_{new:06d}.png")
    samples = read_bop(tmp_path / "000002", "laptop", obj_id=2)
    assert len(samples) == 2
    for s in samples:
        truth = min(frame["objects"], key=lambda o: np.linalg.norm(o["cam_from_part"][0, :3, 3] - s["cam_from_part"][0, :3, 3]))
        np.testing.assert_allclose(s["cam_from_part"], truth["cam_from_part"], atol=1e-6)
        assert set(np.unique(s["part_labels"])) == {0, 1}


def test_bop_wrong_types_and_non_finite_values_name_file_and_field(tmp_path, bop_root):
    import shutil

    root, _ = bop_root
    scene = tmp_path / "b" / "test" / "000001"
    shutil.copytree(root, tmp_path / "b")
    gt = json.loads((scene / "scene_gt.json").read_text())
    cam = json.loads((scene / "scene_camera.json").read_text())
    info = json.loads((tmp_path / "b" / "test" / "models" / "models_info.json").read_text())
    cases = [
        ("scene_gt.json", list(gt.values()), r"scene_gt\.json: expected an object keyed by image id"),
        ("scene_gt.json", {"abc": gt["7"]}, r"scene_gt\.json: key 'abc' is not a non-negative integer image id"),
        ("scene_gt.json", {"7": {"obj_id": 1}}, r"scene_gt\.json, image 7: expected a list of ground-truth entries"),
        ("scene_camera.json", list(cam.values()), r"scene_camera\.json: expected an object keyed by image id"),
        ("scene_camera.json", {"7": {**cam["7"], "cam_K": [float("nan")] * 9}}, r"camera\.json, image 7: cam_K: numbers must be"),
        ("scene_camera.json", {"7": {**cam["7"], "cam_K": [0] * 9}}, r"image 7: cam_K needs positive focal lengths"),
        ("scene_camera.json", {"7": {**cam["7"], "depth_scale": -1}}, r"image 7: depth_scale must be a finite number > 0"),
        (
            "scene_gt.json",
            {"7": [{**gt["7"][0], "cam_t_m2c": [float("nan"), 0, 1]}] + gt["7"][1:]},
            r"image 7, gt_id 0: cam_t_m2c: numbers must be finite",
        ),
    ]
    for name, doc, message in cases:
        save_json(scene / name, doc)
        with pytest.raises(DataError, match=message):
            read_bop(tmp_path / "b" / "test", "mug")
        save_json(scene / "scene_gt.json", gt)
        save_json(scene / "scene_camera.json", cam)
    info["1"]["size_x"] = float("nan")
    save_json(tmp_path / "b" / "test" / "models" / "models_info.json", info)
    with pytest.raises(DataError, match=r"models_info\.json: obj_id 1: size_x, size_y, size_z: numbers must be finite"):
        read_bop(tmp_path / "b" / "test", "mug")


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


def test_segmented_clouds_npz_and_ply(tmp_path):
    from ucope.data.readers.clouds import read_instance_ids, read_segmented_cloud

    pts = np.random.default_rng(0).normal(size=(50, 3))
    ids = np.repeat([0, 1, 2, 7, 7], 10)
    np.savez(tmp_path / "a.npz", points=pts, instance=ids.astype(np.uint16))
    p, n, i = read_segmented_cloud(tmp_path / "a.npz")
    np.testing.assert_array_equal(i, ids)
    np.testing.assert_allclose(p, pts)
    assert n is None
    plyfile = pytest.importorskip("plyfile")
    v = np.zeros(50, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("instance", "f4")])
    v["x"], v["y"], v["z"], v["instance"] = pts[:, 0], pts[:, 1], pts[:, 2], ids
    plyfile.PlyData([plyfile.PlyElement.describe(v, "vertex")]).write(str(tmp_path / "a.ply"))
    np.testing.assert_array_equal(read_segmented_cloud(tmp_path / "a.ply")[2], ids)
    np.savez(tmp_path / "none.npz", points=pts)
    assert read_instance_ids(tmp_path / "none.npz") is None and read_instance_ids(tmp_path / "a.xyz") is None
    with pytest.raises(DataError, match=r"none\.npz: holds no per-point instance ids \(looked for an \.npz array named instance"):
        read_segmented_cloud(tmp_path / "none.npz")
    for bad, message in (
        (ids[:10], r"'instance' has shape \(10,\), the points \(50,\)"),
        (ids - 3, "non-negative instance ids"),
        (ids + 0.5, "whole numbers"),
    ):
        np.savez(tmp_path / "b.npz", points=pts, instance=bad)
        with pytest.raises(DataError, match=message):
            read_segmented_cloud(tmp_path / "b.npz")
