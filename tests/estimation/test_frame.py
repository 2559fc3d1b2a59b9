import numpy as np
import pytest
from frame_fixtures import SMALL, needs_models

from ucope.errors import DataError, InputError
from ucope.estimation.frame import FrameResult, parse_instance_models, predict_frame
from ucope.geometry.transforms import rotation_angle_deg
from ucope.versions import RESULTS_FORMAT

K = (SMALL.fx, SMALL.fy, SMALL.cx, SMALL.cy)


@needs_models
def test_each_instance_estimated_by_its_model(laptop_and_mug_frame, tmp_path):
    frame, fr = laptop_and_mug_frame
    assert [(o.instance_id, o.model) for o in fr.objects] == [(1, "mug"), (2, "laptop")]
    mug, laptop = fr.results
    assert mug.category == "mug" and laptop.category == "laptop" and len(laptop.joints) == 1
    for res, truth in zip(fr.results, frame["objects"], strict=False):
        t_err = np.linalg.norm(res.cam_from_part[0, :3, 3] - truth["cam_from_part"][0, :3, 3])
        assert t_err < 0.05, t_err  # each object found where it is (not the other one)
    assert rotation_angle_deg(laptop.cam_from_part[0, :3, :3], frame["objects"][1]["cam_from_part"][0, :3, :3]) < 20
    assert fr.objects[0].num_pixels == int((frame["instance"] == 1).sum())
    d = fr.save(tmp_path / "f.json")
    back = FrameResult.load(d)
    assert back.to_dict()["objects"] == fr.to_dict()["objects"] and back.to_dict()["format"] == RESULTS_FORMAT
    assert back.source["image_size"] == [320, 240] and back.source["intrinsics"] == list(K)


@needs_models
def test_an_instance_without_enough_pixels_gets_an_error_not_a_crash():
    depth = np.full((60, 80), 1000, np.uint16)
    mask = np.zeros((60, 80), np.uint8)
    mask[10:40, 10:50] = 1
    mask[0, :5] = 2  # 5 pixels
    fr = predict_frame(depth, K, mask, {1: "mug", 2: "mug"}, estimator_options={"overrides": {"vote_parts.num_pairs": 500}})
    assert fr.objects[0].result is not None and fr.objects[1].result is None and "32" in fr.objects[1].error
    with pytest.raises(InputError, match="instance 2 \\(mug\\)"):
        predict_frame(depth, K, mask, {2: "mug"}, keep_going=False)


def test_bad_frames_and_instance_lists():
    depth = np.ones((4, 5), np.uint16)
    with pytest.raises(InputError, match=r"instance id\(s\) \[3\] do not occur in the instance mask \(it holds \[0, 1\]\)"):
        predict_frame(depth, K, np.eye(4, 5, dtype=np.uint8), {3: "mug"})
    with pytest.raises(InputError, match="the instance mask is"):
        predict_frame(depth, K, np.zeros((2, 2), np.uint8), {1: "mug"})
    with pytest.raises(InputError, match="integer ids"):
        predict_frame(depth, K, np.zeros((4, 5), np.float32), {1: "mug"})
    assert parse_instance_models(["1=mug", "7=runs/x"]) == {1: "mug", 7: "runs/x"}
    for bad in (["mug"], ["a=mug"], ["1="], ["-1=mug"]):
        with pytest.raises(InputError, match="ID=MODEL"):
            parse_instance_models(bad)
    with pytest.raises(InputError, match="given twice"):
        parse_instance_models(["1=mug", "1=bowl"])
    with pytest.raises(DataError, match="not a ucope frame result"):
        FrameResult.from_dict({"format": "ucope-result/2"})


def test_segmented_cloud_inputs_are_checked_before_any_model_loads():
    from ucope.estimation.frame import predict_cloud

    pts = np.random.default_rng(0).normal([0, 0, 1], 0.05, (20, 3))
    ids = np.repeat([1, 2], 10)
    with pytest.raises(InputError, match=r"\[3\] do not occur in the cloud's instance ids \(it holds \[1, 2\]\)"):
        predict_cloud(pts, ids, {3: "mug"})
    with pytest.raises(InputError, match=r"instance_ids must be \(20,\) integers"):
        predict_cloud(pts, ids[:5], {1: "mug"})
    with pytest.raises(InputError, match="units must be one of"):
        predict_cloud(pts, ids, {1: "mug"}, units="inch")


def test_frame_objects_of_a_cloud_carry_their_point_counts():
    from ucope.estimation.frame import FrameObject

    d = FrameResult([FrameObject(2, "mug", None, error="too few", num_points=12)], {"input": "seg.npz"}).to_dict()
    assert d["objects"][0]["num_points"] == 12 and "num_pixels" not in d["objects"][0]
    assert FrameResult.from_dict(d).objects[0].num_points == 12
