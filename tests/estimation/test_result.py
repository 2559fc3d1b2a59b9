import json

import numpy as np
import pytest

from ucope.errors import DataError
from ucope.estimation.result import RESULT_FORMAT, JointEstimate, PartEstimate, PoseResult


def _result() -> PoseResult:
    T = np.eye(4)
    T[:3, 3] = [0.1, -0.2, 1.5]
    return PoseResult(
        category="laptop",
        parts=[
            PartEstimate(0, "base", T, np.array([0.3, 0.02, 0.2]), 0.8, "none", 900),
            PartEstimate(1, "lid", T.copy(), np.array([0.3, 0.01, 0.2]), 0.7, "none", 800),
        ],
        joints=[JointEstimate("revolute", 0, 1, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), 1.2, 0.9)],
        part_labels=np.array([0, 1, -1, 1]),
        timings_ms={"total": 12.5},
        model="laptop",
        num_points=4,
    )


def test_json_round_trip_is_lossless_to_1e_7():
    r = _result()
    text = r.to_json()
    d = json.loads(text)
    assert d["format"] == RESULT_FORMAT
    assert d["joints"][0]["state_unit"] == "rad" and d["part_labels"] == [0, 1, -1, 1]
    back = PoseResult.from_json(text)
    np.testing.assert_allclose(back.cam_from_part, r.cam_from_part, atol=1e-7)
    np.testing.assert_allclose(back.size_m, r.size_m, atol=1e-7)
    np.testing.assert_array_equal(back.part_labels, r.part_labels)
    assert back.joints[0].type == "revolute" and back.joints[0].state == pytest.approx(1.2)
    assert back.to_dict() == r.to_dict()


def test_prismatic_joint_has_no_pivot_and_metres():
    j = JointEstimate("prismatic", 0, 1, None, np.array([0.0, 0.0, 1.0]), 0.12)
    d = j.to_dict()
    assert d["pivot_m"] is None and d["state_unit"] == "m"
    assert JointEstimate.from_dict(d).pivot_m is None


def test_save_and_load(tmp_path):
    r = _result()
    path = r.save(tmp_path / "sub" / "r.json")
    assert PoseResult.load(path).to_dict() == r.to_dict()


def test_foreign_or_broken_json_is_refused(tmp_path):
    with pytest.raises(DataError, match="not a ucope result"):
        PoseResult.from_dict({"parts": []})
    with pytest.raises(DataError, match="not valid JSON"):
        PoseResult.from_json("{")
    d = _result().to_dict()
    del d["parts"][0]["size_m"]
    with pytest.raises(DataError, match="malformed"):
        PoseResult.from_dict(d)
