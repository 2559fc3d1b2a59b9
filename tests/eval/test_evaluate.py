"""ucope.eval.evaluate: per-sample errors, reports and their tables, on oracle estimators with known errors."""

import functools
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import InputError
from ucope.eval.evaluate import EVAL_FORMAT, evaluate, format_report, mug_handle_visible, sample_errors
from ucope.model.config import ModelConfig
from ucope.vocab import JointType
from tests_support import measured_priors
from ucope.estimation.result import JointEstimate, PartEstimate, PoseResult


@functools.lru_cache(maxsize=None)
def samples(category: str, n: int = 6) -> tuple:
    cfg = GenerateConfig(category=category, split="test", num=n, max_points=800, views_per_instance=1)
    return tuple(make_sample(cfg, i) for i in range(n))


class Oracle:
    """An estimator that answers the ground truth, rotated by ``angle_deg`` about each part's own z
    axis and shifted by ``shift_m`` along the camera x axis."""

    def __init__(self, category, angle_deg=0.0, shift_m=0.0):
        self.cfg = ModelConfig.default(measured_priors(category, samples(category)), size="full")
        self.name, self.num_pairs, self.awareness, self.refine, self.seed = "oracle", 100, True, False, 0
        self.R = Rotation.from_euler("z", angle_deg, degrees=True).as_matrix()
        self.shift = np.array([shift_m, 0.0, 0.0])

    def predict_sample(self, s):
        parts = []
        for k in range(self.cfg.num_parts):
            T = np.array(s["cam_from_part"][k], np.float64)
            T[:3, :3] = T[:3, :3] @ self.R
            T[:3, 3] += self.shift
            parts.append(PartEstimate(index=k, label=self.cfg.part_names[k], cam_from_part=T, size_m=np.array(s["size_m"][k]),
                                      score=0.9, symmetry=self.cfg.priors.parts[k].symmetry))
        joints = [JointEstimate(type=jp.type.label, parent=jp.parent, child=jp.child,
                                pivot_m=np.array(s["joint_pivot"][j]) if jp.type == JointType.REVOLUTE else None,
                                axis=np.array(s["joint_axis"][j]), state=float(s["joint_state"][j]))
                  for j, jp in enumerate(self.cfg.priors.joints)]
        return PoseResult(category=self.cfg.category, parts=parts, joints=joints, part_labels=np.asarray(s["part_labels"]),
                          timings_ms={"total": 12.0, "voting": 5.0})


@pytest.mark.parametrize("category", ["laptop", "drawer", "mug"])
def test_a_perfect_estimator_has_zero_error(category):
    rep = evaluate(Oracle(category), samples(category), progress=False)
    K = rep["parts"]["num_parts"]
    assert rep["format"] == EVAL_FORMAT and rep["data"]["num_samples"] == 6
    np.testing.assert_allclose(rep["parts"]["rotation_deg"]["mean"], 0.0, atol=1e-3)
    np.testing.assert_allclose(rep["parts"]["translation_m"]["mean"], 0.0, atol=1e-9)
    np.testing.assert_allclose(rep["parts"]["iou"]["mean"], 1.0, atol=1e-6)
    assert rep["parts"]["fraction"]["5deg5cm"] == [1.0] * K
    if K > 1:
        np.testing.assert_allclose(rep["joints"]["axis_deg"]["mean"], 0.0, atol=1e-3)
        np.testing.assert_allclose(rep["joints"]["state_error"]["mean"], 0.0, atol=1e-6)
        assert rep["segmentation"]["accuracy"] == 1.0 and rep["segmentation"]["iou"] == [1.0] * K
        assert rep["map"] is None
    else:
        assert rep["map"]["mean"] == {m: 1.0 for m in rep["map"]["metrics"]}
    assert rep["time_ms"]["mean"]["total"] == 12.0
    json.dumps(rep)  # JSON-friendly


def test_known_rotation_and_translation_errors():
    rep = evaluate(Oracle("laptop", angle_deg=9.0, shift_m=0.03), samples("laptop"), progress=False)
    np.testing.assert_allclose(rep["parts"]["rotation_deg"]["mean"], [9.0, 9.0], atol=1e-6)
    np.testing.assert_allclose(rep["parts"]["translation_m"]["median"], [0.03, 0.03], atol=1e-9)
    assert rep["parts"]["fraction"]["5deg5cm"] == [0.0, 0.0]
    assert rep["parts"]["fraction"]["10deg10cm"] == [1.0, 1.0]
    assert all(0.0 < v < 1.0 for v in rep["parts"]["iou"]["mean"])
    text = format_report(rep)
    assert "rotation error (deg)    9.0, 9.0" in text and "translation error (m)   0.030, 0.030" in text


def test_rigid_map_counts_a_20_degree_error_as_a_pose_miss():
    rep = evaluate(Oracle("camera", angle_deg=20.0), samples("camera"), progress=False)
    m = rep["map"]["mean"]
    assert m["5deg2cm"] == m["10deg5cm"] == 0.0
    assert rep["map_records"][0]["gt"][0]["class"] == "camera"
    assert "mAP (%)" in format_report(rep)


def test_mug_handle_visibility_follows_the_points():
    s = dict(samples("mug")[0])
    T, (sx, _, sz) = np.asarray(s["cam_from_part"][0]), s["size_m"][0]
    local = (np.asarray(s["points"]) - T[:3, 3]) @ T[:3, :3]
    body = local[:, 0] <= -0.5 * sx + sz
    assert mug_handle_visible(s) == (np.count_nonzero(~body & (local[:, 0] > -0.5 * sx + sz + 0.002)) >= 20)
    s["points"] = np.asarray(s["points"])[body]
    assert not mug_handle_visible(s)


def test_category_mismatch_is_named():
    with pytest.raises(InputError, match="mug"):
        evaluate(Oracle("laptop"), samples("mug"), progress=False)
    with pytest.raises(InputError, match="empty"):
        evaluate(Oracle("laptop"), [], progress=False)
    r = Oracle("laptop").predict_sample(samples("laptop")[0])
    with pytest.raises(InputError, match="different categories"):
        sample_errors(r, samples("drawer")[0])


@pytest.mark.parametrize("head", ["voting", "regression"])
def test_cli_eval_writes_a_report_and_prints_the_table(tmp_path, capsys, head):
    """`ucope eval` end to end on an untrained tiny model (plumbing, not accuracy), both heads."""
    import torch

    from ucope.cli.main import main
    from ucope.model.checkpoint import save_model
    from ucope.model.factory import build_model
    from ucope.model.pointnet2 import PointNet2Config

    cfg = ModelConfig.default(measured_priors("laptop", samples("laptop")), size="full", head=head,
                                   encoder=PointNet2Config(width=0.25, npoints=(64, 16), radii=(0.15, 0.3), nsamples=(8, 8)),
                                   num_points=256, hidden=16)
    torch.manual_seed(0)
    save_model(build_model(cfg), tmp_path / "run")
    assert main(["generate", "--category", "laptop", "--split", "test", "--num", "3", "--out", str(tmp_path / "data"), "--quiet"]) == 0
    rc = main(["eval", "--model", str(tmp_path / "run"), "--data", str(tmp_path / "data"), "--out", str(tmp_path / "r.json"),
               "--num", "2", "--pairs", "500", "--quiet"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "rotation error (deg)" in out and "joint axis error (deg)" in out
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["head"] == head and rep["data"]["num_samples"] == 2 and rep["settings"]["num_pairs"] == 500
    assert rep["command"].startswith("ucope eval --model") and len(rep["samples"]) == 2
    assert main(["eval", "--model", str(tmp_path / "run"), "--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "x.json")]) == 2
