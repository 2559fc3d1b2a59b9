"""ucope.stages.paper: the paper's stages end to end on exact synthetic network outputs (voting inverts the
targets of real samples; joints, flips and states on top), and the direct-regression baseline's part scores."""

import os

import numpy as np
import pytest
import torch
from stages_support import samples
from tests_support import measured_priors
from voting.voting_support import angle_deg, peaked_logits

from ucope.geometry.transforms import make_transform, rotation_angle_deg
from ucope.model.checkpoint import find_model, load_model
from ucope.model.config import ModelConfig
from ucope.model.targets import joint_point_targets, pair_vote_targets
from ucope.stages import PoseState, run, stage_params
from ucope.stages.paper import regression_scores
from ucope.vocab import JointType

ARTICULATED = ("vote_parts", "vote_joints", "flips", "upright", "joint_states")
"""The paper's stages of an articulated object with the flip and upright checks (what ``vote_object`` ran; ``flips``
now also turns a cabinet round by its drawers, which the true poses here never need)."""


def _exact_outputs(s, cfg, rng, M=1500):
    """Network-shaped outputs equal to the ground truth of sample ``s`` (pairs within each part)."""
    K, J = cfg.num_parts, cfg.num_joints
    pts = torch.tensor(s["points"], dtype=torch.float32)
    nrm = torch.tensor(s["normals"], dtype=torch.float32)
    labels = np.asarray(s["part_labels"])
    pair_idx = np.stack([rng.choice(np.flatnonzero(labels == k), (M, 2)) for k in range(K)])
    out = {k: [] for k in ("mu_logits", "nu_logits", "alpha_logits", "beta_logits", "sign_logits", "gamma", "part_score")}
    for k in range(K):
        V = cfg.priors.vote_range_m[k]
        a, b, na = pts[pair_idx[k, :, 0]], pts[pair_idx[k, :, 1]], nrm[pair_idx[k, :, 0]]
        t = pair_vote_targets(
            a,
            b,
            na,
            torch.tensor(s["cam_from_part"][k], dtype=torch.float32),
            torch.tensor(s["size_m"][k], dtype=torch.float32),
            torch.tensor(cfg.priors.mean_size_m[k], dtype=torch.float32),
        )
        out["mu_logits"].append(peaked_logits(t["mu"], -V, V, cfg.mu_bins))
        out["nu_logits"].append(peaked_logits(t["nu"], 0.0, V, cfg.nu_bins))
        out["alpha_logits"].append(peaked_logits(t["alpha"], 0.0, np.pi, cfg.angle_bins))
        out["beta_logits"].append(peaked_logits(t["beta"], 0.0, np.pi, cfg.angle_bins))
        out["sign_logits"].append(t["sign"] * 8 - 4)
        out["gamma"].append(t["gamma"].expand(M, 3))
        out["part_score"].append(torch.full((M,), 4.0))
    outputs = {k: torch.stack(v)[None] for k, v in out.items()}
    jt = joint_point_targets(
        pts[None],
        torch.tensor(labels)[None],
        torch.tensor(s["joint_pivot"], dtype=torch.float32)[None],
        torch.tensor(s["joint_axis"], dtype=torch.float32)[None],
        torch.tensor(s["joint_type"])[None],
        torch.tensor([j.parent for j in cfg.priors.joints]),
        torch.tensor([j.child for j in cfg.priors.joints]),
        0.05,
    )
    outputs["joint_heat"] = jt["heat"] * 8 - 4
    outputs["joint_score"] = jt["score"] * 8 - 4
    outputs["joint_offset"] = jt["offset"]
    outputs["joint_dir"] = torch.tensor(s["joint_axis"], dtype=torch.float32)[None, :, None, :].expand(1, J, len(pts), 3)
    return pts, nrm, pair_idx, outputs


def _voted(priors, pts, nrm, labels, pair_idx, outputs, stages, overrides=None):
    """A pose state of the network-shaped ``outputs`` after ``stages``, and the stages' records."""
    state = PoseState(priors, pts.numpy(), nrm.numpy(), labels, outputs=outputs, pair_idx=pair_idx)
    return state, run(stages, state, stage_params(stages, overrides))


@pytest.mark.parametrize("category", ["laptop", "eyeglasses", "drawer"])
def test_the_paper_stages_on_exact_heads_of_real_samples(category, rng):
    cfg = ModelConfig.default(measured_priors(category, samples(category, "train", 20)), size="full")
    for s in samples(category, "val", int(os.environ.get("UCOPE_TEST_SAMPLES", 2))):
        pts, nrm, pair_idx, outputs = _exact_outputs(s, cfg, rng)
        labels = np.asarray(s["part_labels"])
        # With exact heads the voting inverts the targets; the thin-part surface snap (on by default)
        # then trades that exactness for the median of real, noisy surface points: a few millimetres.
        snapped, _ = _voted(cfg.priors, pts, nrm, labels, pair_idx, outputs, ARTICULATED)
        for k in range(cfg.num_parts):
            assert np.linalg.norm(snapped.cam_from_part[k][:3, 3] - s["cam_from_part"][k][:3, 3]) < 0.003
        for refine in (False, True):
            stages = ARTICULATED + (("kinematic_refine",) if refine else ())
            res, records = _voted(
                cfg.priors, pts, nrm, labels, pair_idx, outputs, stages, {"vote_parts.options.thin_snap_ratio": 0.0}
            )
            assert [r.name for r in records] == list(stages)
            for k in range(cfg.num_parts):
                T, Tg = res.cam_from_part[k], s["cam_from_part"][k]
                cell = cfg.priors.vote_range_m[k] / 20
                assert np.linalg.norm(T[:3, 3] - Tg[:3, 3]) < 0.25 * cell
                assert rotation_angle_deg(T[:3, :3], Tg[:3, :3]) < 0.5
                np.testing.assert_allclose(res.size_m[k], s["size_m"][k], rtol=0.01)
            for j in range(cfg.num_joints):
                assert angle_deg(res.joint_axis[j], s["joint_axis"][j]) < 0.5
                if cfg.priors.joints[j].type == JointType.REVOLUTE:
                    d = np.cross(res.joint_pivot[j] - s["joint_pivot"][j], s["joint_axis"][j])
                    assert np.linalg.norm(d) < 1e-3
                    assert abs(res.joint_state[j] - s["joint_state"][j]) < np.radians(0.5)
                else:  # box supports: instance geometry the boxes cannot see (tests/geometry)
                    assert abs(res.joint_state[j] - s["joint_state"][j]) < 0.04


def _box_points(rng, size, n):
    """``n`` points on the surface of a box of ``size`` centred at the origin (its own frame)."""
    p = rng.uniform(-0.5, 0.5, (n, 3)) * size
    axis = rng.integers(0, 3, n)
    p[np.arange(n), axis] = np.sign(rng.uniform(-1, 1, n)) * 0.5 * size[axis]
    return p


def test_regression_scores_see_whether_the_box_fits_the_part_points():
    rng = np.random.default_rng(0)
    size = np.array([0.30, 0.05, 0.10])
    T = make_transform(np.eye(3), np.array([0.0, 0.0, 0.8]))
    pts = _box_points(rng, size, 400) + T[:3, 3]
    right = regression_scores(pts, None, T[None], size[None])
    assert right.shape == (1,) and right[0] == 1.0
    # the same box turned 90 degrees about z: the long side no longer covers the points
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    wrong = regression_scores(pts, None, make_transform(Rz, T[:3, 3])[None], size[None])
    assert wrong[0] < 0.5
    # a box shifted by half its length
    shifted = regression_scores(pts, None, make_transform(np.eye(3), T[:3, 3] + [0.15, 0, 0])[None], size[None])
    assert 0.3 < shifted[0] < 0.7


def test_regression_scores_weigh_by_segmentation_confidence_and_give_an_unseen_part_zero():
    rng = np.random.default_rng(1)
    size = np.array([0.2, 0.2, 0.2])
    T = np.stack([make_transform(np.eye(3), np.array([0.0, 0.0, 1.0])), make_transform(np.eye(3), np.array([1.0, 0.0, 1.0]))])
    pts = _box_points(rng, size, 300) + T[0, :3, 3]
    prob = np.tile([0.7, 0.1, 0.2], (300, 1))  # every point part 0 with probability 0.7; nothing is part 1
    s = regression_scores(pts, prob, T, np.stack([size, size]))
    np.testing.assert_allclose(s, [0.7, 0.0])


def _regressed(priors, pts, outputs):
    """A pose state of the regression baseline's ``outputs`` (no segmentation: one part) after ``regress_parts``."""
    P = len(pts)
    state = PoseState(priors, pts, np.zeros((P, 3)), np.zeros(P, np.int64), outputs=outputs)
    run(["regress_parts"], state, {})
    return state


def test_regressed_part_scores_are_not_all_one():
    """The baseline used to give every part the score 1.0, so its mAP depended on record order only."""
    rng = np.random.default_rng(2)
    priors = load_model(find_model("mug"))[0].cfg.priors
    size = np.asarray(priors.mean_size_m, np.float64).reshape(1, 3)
    pts = _box_points(rng, size[0], 256) + [0.0, 0.0, 0.7]
    R = torch.eye(3, dtype=torch.float64).reshape(1, 1, 3, 3)
    good = {"rotation": R, "centre_m": torch.tensor([[[0.0, 0.0, 0.7]]]), "gamma": torch.zeros(1, 1, 3)}
    far = dict(good, centre_m=torch.tensor([[[0.0, 0.0, 0.9]]]))
    s_good = _regressed(priors, pts, good).votes["score"]
    s_far = _regressed(priors, pts, far).votes["score"]
    assert s_good[0] > 0.9 and s_far[0] < 0.2
    state = _regressed(priors, pts, good)
    np.testing.assert_allclose(state.cam_from_part[0, :3, 3], [0.0, 0.0, 0.7])
    np.testing.assert_allclose(state.size_m[0], size[0])
