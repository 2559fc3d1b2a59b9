import json

import numpy as np
import pytest

from ucope.errors import DataError
from ucope.estimation.result import RESULT_FORMAT, JointEstimate, PartEstimate, PoseResult, validate


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
    with pytest.raises(DataError, match=r"invalid ucope result: parts\[0\]: missing size_m"):
        PoseResult.from_dict(d)


def _mutations() -> dict:
    """One broken field per case (the cases of issue #49, item 4) -> the start of the message naming it."""

    def setp(path, value):
        def f(d):
            node = d
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = value

        return f

    skew = np.eye(4)
    skew[0, 1] = 0.3
    return {
        "last row": (setp(["parts", 0, "cam_from_part", 3], [0, 0, 1, 1]), r"parts\[0\]\.cam_from_part: the last row must be"),
        "non-orthonormal": (
            setp(["parts", 1, "cam_from_part"], skew.tolist()),
            r"parts\[1\]\.cam_from_part: the rotation is not",
        ),
        "label >= K": (setp(["part_labels", 1], 2), r"part_labels: must lie in \[-1, 1\] \(K = 2\)"),
        "num_points": (setp(["num_points"], 7), r"num_points: is 7 but part_labels holds 4"),
        "child 9": (setp(["joints", 0, "child"], 9), r"joints\[0\]\.child: must lie in \[0, 1\], got 9"),
        "parent = child": (setp(["joints", 0, "child"], 0), r"joints\[0\]: parent and child are both part 0"),
        "no pivot": (setp(["joints", 0, "pivot_m"], None), r"joints\[0\]\.pivot_m: a revolute joint needs a pivot"),
        "NaN score": (setp(["parts", 0, "score"], float("nan")), r"parts\[0\]\.score: must be finite"),
        "NaN top score": (setp(["score"], float("nan")), r"score: must be finite"),
        "bool votes": (setp(["parts", 0, "num_votes"], True), r"parts\[0\]\.num_votes: must be an integer"),
        "axis length": (setp(["joints", 0, "axis"], [2.0, 0.0, 0.0]), r"joints\[0\]\.axis: must be a unit vector"),
        "junk in errors": (
            setp(["errors"], {"parts": [None, None], "joints": [None], "junk": 1}),
            r"errors: unknown field\(s\) 'junk'",
        ),
        "junk in part errors": (
            setp(["errors"], {"parts": [{"iou": 0.5, "colour": "red"}, None], "joints": [None]}),
            r"errors\.parts\[0\]: unknown field\(s\) 'colour'",
        ),
        "unknown field": (setp(["colour"], "red"), r"result: unknown field\(s\) 'colour'"),
        "index order": (setp(["parts", 1, "index"], 0), r"parts\[1\]\.index: must be 1"),
        "score not min": (setp(["score"], 0.8), r"score: must be the smallest part score"),
    }


@pytest.mark.parametrize("name", list(_mutations()))
def test_validate_names_the_bad_field(name):
    mutate, message = _mutations()[name]
    d = json.loads(_result().to_json())
    validate(d)  # the unbroken result is valid
    mutate(d)
    with pytest.raises(DataError, match=message):
        validate(d)
    with pytest.raises(DataError, match=message):  # from_dict validates: no IndexError later in plot()
        PoseResult.from_dict(d)


def test_errors_round_trip_through_save_and_load(tmp_path):
    r = _result()
    r.errors = {
        "parts": [{"rotation_deg": 2.5, "translation_m": 0.01, "translation_norm": 0.05, "iou": 0.8}, None],
        "joints": [{"joint_type": "revolute", "axis_deg": 1.0, "pivot_m": 0.02, "state_error": 3.0, "state_unit": "deg"}],
        "segmentation_iou": [0.9, None],
        "segmentation_accuracy": 0.95,
    }
    back = PoseResult.load(r.save(tmp_path / "r.json"))
    assert back.errors == r.errors and back.to_dict() == r.to_dict()
    d = json.loads((tmp_path / "r.json").read_text())
    d["joints"][0]["child"] = 9
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(DataError, match=r"bad\.json: invalid ucope result: joints\[0\]\.child"):
        PoseResult.load(tmp_path / "bad.json")
