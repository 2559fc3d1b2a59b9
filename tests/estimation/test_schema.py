"""The JSON Schema of ``ucope-result/2`` / ``ucope-results/1`` shipped in the package, checked with the
reference validator (``jsonschema``, a test dependency) against real results of shipped models."""

import copy
import json

import numpy as np
import pytest
from frame_fixtures import needs_models

from ucope.errors import DataError
from ucope.estimation.result import SCHEMA_FILE, JointEstimate, PartEstimate, PoseResult, result_schema, validate

jsonschema = pytest.importorskip("jsonschema")


@pytest.fixture(scope="module")
def validator():
    schema = result_schema()
    jsonschema.Draft202012Validator.check_schema(schema)  # the schema itself is valid draft 2020-12
    return jsonschema.Draft202012Validator(schema)


def _errors(validator, doc) -> list[str]:
    return [e.message for e in validator.iter_errors(doc)]


def test_the_schema_ships_inside_the_package():
    assert SCHEMA_FILE.is_file() and SCHEMA_FILE.parent.name == "estimation"
    s = result_schema()
    assert s["$defs"]["result"]["properties"]["format"]["const"] == "ucope-result/2"
    assert s["$defs"]["results"]["properties"]["format"]["const"] == "ucope-results/1"


@needs_models
def test_real_results_validate(validator, laptop_sample_result, laptop_and_mug_frame):
    _, res, err = laptop_sample_result
    d = json.loads(res.to_json())
    assert _errors(validator, d) == []
    d["errors"] = err  # as `ucope predict --data` and `ucope demo` write it
    assert _errors(validator, json.loads(json.dumps(d))) == []
    _, frame_result = laptop_and_mug_frame
    assert _errors(validator, json.loads(json.dumps(frame_result.to_dict()))) == []


def test_prismatic_joints_and_failed_objects_validate(validator):
    r = PoseResult(
        "drawer",
        [PartEstimate(0, "cabinet", np.eye(4), np.ones(3), 0.5), PartEstimate(1, "drawer_top", np.eye(4), np.ones(3), 0.0)],
        [JointEstimate("prismatic", 0, 1, None, np.array([0, 0, 1.0]), 0.12, 0.4)],
        np.array([0, 1, -1]),
    )
    assert _errors(validator, r.to_dict()) == []
    frame = {
        "format": "ucope-results/1",
        "ucope_version": "0",
        "objects": [{"instance_id": 3, "model": "mug", "result": None, "error": "too few"}],
    }
    assert _errors(validator, frame) == []


@needs_models
def test_broken_results_are_rejected(validator, laptop_sample_result):
    _, res, _ = laptop_sample_result
    good = res.to_dict()
    cases = {
        "format": lambda d: d.update(format="ucope-result/1"),
        "no estimates": lambda d: d.pop("estimates"),
        "no estimate made": lambda d: d.update(estimates=0),
        "missing size": lambda d: d["parts"][0].pop("size_m"),
        "3x4 pose": lambda d: d["parts"][0]["cam_from_part"].pop(),
        "score > 1": lambda d: d["parts"][1].update(score=1.5),
        "unit": lambda d: d["joints"][0].update(state_unit="deg"),
        "extra field": lambda d: d.update(colour="red"),
        "label < -1": lambda d: d["part_labels"].__setitem__(0, -2),
        "symmetry": lambda d: d["parts"][0].update(symmetry="z"),
        "last row": lambda d: d["parts"][0]["cam_from_part"].__setitem__(3, [0, 0, 1, 1]),
        "rotation entry > 1": lambda d: d["parts"][0]["cam_from_part"][0].__setitem__(0, 1.5),
        "revolute without pivot": lambda d: d["joints"][0].update(pivot_m=None),
        "junk in errors": lambda d: d.update(errors={"parts": [None, None], "joints": [None], "junk": 1}),
        "junk in part errors": lambda d: d.update(errors={"parts": [{"iou": 0.5, "colour": 1}, None], "joints": [None]}),
        "no parts": lambda d: d.update(parts=[]),
    }
    for name, mutate in cases.items():
        d = copy.deepcopy(good)
        mutate(d)
        assert _errors(validator, d), name
        with pytest.raises(DataError):  # the package's own validator refuses what the schema refuses
            validate(d)
