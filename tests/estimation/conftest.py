"""Real results of shipped models, shared by the picture, schema, frame and viewer tests (computed once)."""

from __future__ import annotations

import pytest
from frame_fixtures import SMALL, posed, render_frame


@pytest.fixture(scope="session")
def laptop_and_mug_frame():
    """A 320x240 frame with a mug (instance 1) and a laptop (instance 2), and its ``predict_frame`` result."""
    from ucope.estimation.frame import predict_frame

    frame = render_frame(
        [("mug", 0, posed(0.7, 30, 30, (-0.16, 0.0, 0.0)), None), ("laptop", 0, posed(0.9, -30, 35, (0.12, 0.05, 0.4)), None)],
        SMALL,
    )
    result = predict_frame(
        frame["depth_mm"],
        (SMALL.fx, SMALL.fy, SMALL.cx, SMALL.cy),
        frame["instance"],
        {1: "mug", 2: "laptop"},
        estimator_options={"overrides": {"vote_parts.num_pairs": 4000}},
    )
    return frame, result


@pytest.fixture(scope="session")
def laptop_sample_result():
    """A generated laptop test view, the shipped model's result on it and its errors."""
    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.estimation.estimator import Estimator
    from ucope.eval.evaluate import sample_errors

    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1), 0)
    r = Estimator.load("laptop", overrides={"vote_parts.num_pairs": 4000}).predict_sample(s)
    return s, r, sample_errors(r, s)
