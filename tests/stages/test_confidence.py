"""ucope.stages.confidence: the logistic fit, the AUROC against a plain reference, part features, and calibrated
scores in predictions (the ``score`` stage)."""

import dataclasses
import json

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.estimation import Estimator
from ucope.stages.confidence import FEATURES, Calibration, auroc, fit_logistic, part_features


def test_auroc_matches_the_pairwise_definition(rng):
    s = np.round(rng.normal(size=300), 1)  # many ties
    y = rng.random(300) < 0.4
    pos, neg = s[y], s[~y]
    ref = np.mean([(a > b) + 0.5 * (a == b) for a in pos for b in neg])
    assert auroc(s, y) == pytest.approx(ref)
    assert auroc(s, np.ones(300)) is None


def test_fit_recovers_a_known_logistic_model(rng):
    n, d = 20000, len(FEATURES)
    X = rng.normal(size=(n, d)) * 2.0 + 1.0
    part = rng.integers(0, 3, n)
    z = 1.2 * X[:, 0] - 0.8 * X[:, 5] + np.array([0.0, 1.5, -1.0])[part] + 0.3
    y = (rng.random(n) < 1 / (1 + np.exp(-z))).astype(float)
    cal = Calibration.fit(X, y, part, 3, l2=1e-4)
    F = np.tile(X[:50, None, :], (1, 3, 1))  # every sample as each of the 3 parts
    got = np.stack([cal.part_scores(f) for f in F])
    want = 1 / (1 + np.exp(-(1.2 * X[:50, 0, None] - 0.8 * X[:50, 5, None] + np.array([0.0, 1.5, -1.0]) + 0.3)))
    assert np.abs(got - want).max() < 0.06
    back = Calibration.from_dict(json.loads(json.dumps(cal.to_dict())))
    np.testing.assert_allclose(back.part_scores(F[0]), cal.part_scores(F[0]))
    coef, b, mean, std = fit_logistic(X[:, :2], (X[:, 0] > 1.0).astype(float), l2=1.0)
    assert coef[0] > 3 * abs(coef[1])
    with pytest.raises(InputError, match="features"):
        Calibration.from_dict({**cal.to_dict(), "features": ["x"]})
    with pytest.raises(InputError):
        cal.part_scores(np.zeros((2, d)))


def test_an_estimator_with_a_calibration_reports_probabilities_and_warns_below_its_threshold():
    from ucope.data.generate import GenerateConfig, make_sample

    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, seed=4), 0)
    shipped = Estimator.load("laptop", overrides={"vote_parts.num_pairs": 4000})
    assert shipped.pipeline.calibration is not None and shipped.calibration is shipped.pipeline.calibration
    raw = Estimator(shipped.model, dataclasses.replace(shipped.pipeline, calibration=None))
    r = raw.predict(s["points"])
    assert r.features.shape == (2, len(FEATURES)) and all(p.score == p.vote_score for p in r.parts)
    d = len(FEATURES)
    always = Calibration(coef=(0.0,) * d, intercept=-2.0, mean=(0.0,) * d, std=(1.0,) * d, part_bias=(0.0, 0.0), threshold=0.5)
    cal = Estimator(raw.model, dataclasses.replace(raw.pipeline, calibration=always)).predict(s["points"])
    assert [p.score for p in cal.parts] == pytest.approx([1 / (1 + np.exp(2.0))] * 2)
    assert cal.score == pytest.approx(min(p.score for p in cal.parts))
    assert any("low confidence" in w for w in cal.warnings)
    at_zero = dataclasses.replace(raw.pipeline, calibration=dataclasses.replace(always, threshold=0.0))
    ok = Estimator(raw.model, at_zero).predict(s["points"])
    assert not any("low confidence" in w for w in ok.warnings)
    with pytest.raises(InputError, match="parts"):
        Estimator(raw.model, dataclasses.replace(raw.pipeline, calibration=dataclasses.replace(always, part_bias=(0.0,))))


def test_part_features_carry_the_axis_agreements_and_zero_them_without_votes(rng):
    T = np.repeat(np.eye(4)[None], 2, axis=0)
    T[1, :3, 3] = [0.3, 0.0, 0.0]
    pts = np.concatenate([rng.uniform(-0.05, 0.05, (50, 3)), rng.uniform(-0.05, 0.05, (50, 3)) + [0.3, 0, 0]])
    labels = np.repeat([0, 1], 50)
    votes = dict(
        cam_from_part=T,
        size_m=np.full((2, 3), 0.1),
        score=np.array([0.9, 0.8]),
        num_pairs=np.array([100, 100]),
        num_inliers=np.array([90, 80]),
        mean_prob=np.array([0.9, 0.9]),
        fallback=np.array([False, False]),
        joint_score=np.array([0.7]),
        up_agreement=np.array([0.95, 0.4]),
        right_agreement=np.array([0.9, 0.2]),
    )
    F = part_features(votes, labels, None, pts, 100, [0], [1])
    i, j = FEATURES.index("up_agreement"), FEATURES.index("right_agreement")
    np.testing.assert_allclose(F[:, i], [0.95, 0.4])
    np.testing.assert_allclose(F[:, j], [0.9, 0.2])
    np.testing.assert_allclose(F[:, FEATURES.index("joint_score")], [0.7, 0.7])
    regressed = {k: v for k, v in votes.items() if k not in ("up_agreement", "right_agreement", "num_inliers")}
    F = part_features(regressed, labels, None, pts, 100, [0], [1])
    assert np.all(F[:, [i, j]] == 0.0)


def test_the_score_stage_sets_the_calibrated_scores_or_the_raw_vote_scores(rng):
    """``score`` computes the part features of the state and scores them with the model's calibration; without one
    the scores are the vote scores. It moves nothing (an empty record)."""
    from ucope.priors import CategoryPriors, JointPrior, PartPrior
    from ucope.stages import PoseState, run

    parts = (PartPrior("base", "none", 0.2, (0.1, 0.1, 0.1)), PartPrior("lid", "none", 0.2, (0.1, 0.1, 0.1)))
    pri = CategoryPriors("toy", parts, (JointPrior("revolute", 0, 1, (1, 0, 0), limits=(0.0, 1.0)),))
    pts = np.concatenate([rng.uniform(-0.05, 0.05, (50, 3)), rng.uniform(-0.05, 0.05, (50, 3)) + [0.3, 0, 0]])
    labels = np.repeat([0, 1], 50)
    votes = dict(
        score=np.array([0.9, 0.3]),
        num_pairs=np.array([100, 100]),
        num_inliers=np.array([90, 30]),
        mean_prob=np.array([0.9, 0.9]),
        fallback=np.array([False, False]),
        up_agreement=np.array([0.95, 0.4]),
        right_agreement=np.array([0.9, 0.2]),
    )
    T = np.repeat(np.eye(4)[None], 2, axis=0)
    T[1, :3, 3] = [0.3, 0.0, 0.0]
    d = len(FEATURES)
    always = Calibration(coef=(0.0,) * d, intercept=-2.0, mean=(0.0,) * d, std=(1.0,) * d, part_bias=(0.0, 1.0), threshold=0.5)
    for cal in (None, always):
        state = PoseState(pri, pts, np.zeros_like(pts), labels, num_input=100, calibration=cal)
        state.cam_from_part, state.size_m, state.votes = T.copy(), np.full((2, 3), 0.1), dict(votes)
        state.joint_score = np.array([0.7])
        records = run(["score"], state, {})
        assert records[0].changed == {}
        full = {**votes, "cam_from_part": T, "size_m": state.size_m, "joint_score": [0.7]}
        want = part_features(full, labels, None, pts, 100, [0], [1])
        np.testing.assert_allclose(state.features, want)
        if cal is None:
            np.testing.assert_array_equal(state.score, votes["score"])
        else:
            np.testing.assert_allclose(state.score, 1 / (1 + np.exp([2.0, 1.0])))
