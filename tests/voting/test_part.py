import math

import numpy as np
import pytest
import torch
from voting_support import angle_deg, box_surface_points, random_part, synthetic_heads

from ucope.errors import InputError
from ucope.priors import CategoryPriors, JointPrior, PartPrior
from ucope.voting import CentreOptions, VotingOptions, rotation_from_axes, vote_part, vote_parts
from ucope.voting.rotation import refine_rotation

HEADS = ("mu_logits", "nu_logits", "alpha_logits", "beta_logits", "sign_logits", "gamma", "part_score")


def _check_pose(r, T, size, V, sym):
    cell = V / 20
    assert np.linalg.norm(r.cam_from_part[:3, 3] - T[:3, 3]) < 0.25 * cell
    R = r.cam_from_part[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-6)
    assert np.linalg.det(R) > 0
    assert angle_deg(R[:, 1], T[:3, 1]) < 0.5
    if not sym:
        assert angle_deg(R[:, 0], T[:3, 0]) < 0.5
    assert np.all(np.abs(r.size_m / size - 1) < 0.01)


@pytest.mark.parametrize("outliers", [0.0, 0.2])
@pytest.mark.parametrize("sym", [False, True])
def test_vote_part_recovers_exact_poses(rng, outliers, sym):
    for _ in range(3):
        T, size = random_part(rng, sym)
        mean = size * rng.uniform(0.7, 1.3, 3)
        a, b, n, h, V = synthetic_heads(rng, T, size, mean, 4000, outlier_frac=outliers)
        r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=mean, symmetric=sym)
        _check_pose(r, T, size, V, sym)
        assert r.num_pairs == 4000 and not r.fallback
        assert abs(r.num_inliers / 4000 - (1 - outliers)) < 0.05
        assert 0.9 * (1 - outliers) < r.score <= 1.0
        assert set(r.timings_ms) == {"decode", "centre", "axes", "rotation", "size"}


def test_awareness_drops_pairs_across_parts_and_falls_back(rng):
    T, size = random_part(rng)
    # 60% of the pairs span two parts (random parameters); the part score knows them.
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 3000)
    bad = torch.tensor(rng.random(3000) < 0.6)
    for k in ("mu_logits", "nu_logits", "alpha_logits", "beta_logits"):
        h[k] = torch.where(bad[:, None], torch.randn(3000, h[k].shape[1]) * 3, h[k])
    h["part_score"] = torch.where(bad, -4.0, 4.0)
    r_on = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    r_off = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size, score_filter=False)
    assert r_on.num_pairs == int((~bad).sum()) and r_off.num_pairs == 3000
    _check_pose(r_on, T, size, V, False)
    assert r_on.score > r_off.score
    # No pair passes: every pair votes, flagged, with a lower score.
    h["part_score"] = torch.full((3000,), -3.0)
    r_fb = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    assert r_fb.fallback and r_fb.num_pairs == 3000 and r_fb.score < 0.1


def test_degenerate_inputs_do_not_crash(rng):
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 20, outlier_frac=1.0)  # nothing agrees
    r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    assert np.all(np.isfinite(r.cam_from_part)) and np.all(r.size_m > 0)
    r = vote_part(a[:1], b[:1], n[:1], *(h[k][:1] for k in HEADS), vote_range_m=V, mean_size_m=size)
    assert np.all(np.isfinite(r.cam_from_part)) and r.fallback


def test_pairs_of_one_point_twice_never_vote(rng):
    """Seen on a trained drawer model: a part with no segmented points whose only confident pairs were
    (i, i); that raised from inside the centre vote. Such pairs are left out of the awareness count,
    and a part with nothing else gets no estimate (score 0) instead of an error."""
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 400)
    a, b = a.clone(), b.clone()
    h = {k: v.clone() for k, v in h.items()}
    b[:10] = a[:10]
    h["part_score"][:] = -5.0
    h["part_score"][:10] = 5.0  # only the degenerate pairs pass the part score
    r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    assert r.fallback and r.num_pairs == 390 and np.all(np.isfinite(r.cam_from_part))
    r = vote_part(a, a, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    assert r.score == 0.0 and r.num_pairs == 0 and r.fallback
    np.testing.assert_allclose(r.cam_from_part[:3, :3], np.eye(3))
    np.testing.assert_allclose(r.cam_from_part[:3, 3], a.double().mean(0).numpy(), atol=1e-9)
    np.testing.assert_allclose(r.size_m, size)


def test_up_and_right_voted_onto_one_direction_still_give_a_rotation(rng):
    """Garbage votes can put both axes on one direction (seen on a trained eyeglasses model); the part
    keeps its up axis and gets a proper rotation instead of an error from deep inside."""
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 2000)
    h["beta_logits"] = h["alpha_logits"].clone()  # the right axis votes exactly like the up axis
    h["sign_logits"] = torch.stack([h["sign_logits"][:, 0]] * 2, -1)
    r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size)
    R = r.cam_from_part[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-6)
    assert np.linalg.det(R) > 0 and angle_deg(R[:, 1], T[:3, 1]) < 2.0


def test_bad_inputs_raise_input_errors(rng):
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 50)
    args = [a, b, n] + [h[k] for k in HEADS]
    bad = list(args)
    bad[3] = h["mu_logits"].clone()
    bad[3][0, 0] = float("nan")
    with pytest.raises(InputError, match="NaN"):
        vote_part(*bad, vote_range_m=V, mean_size_m=size)
    bad = list(args)
    bad[8] = h["gamma"][:, :2]
    with pytest.raises(InputError, match="gamma"):
        vote_part(*bad, vote_range_m=V, mean_size_m=size)
    with pytest.raises(InputError):
        vote_part(*args, vote_range_m=-1.0, mean_size_m=size)
    with pytest.raises(InputError):
        vote_part(*args, vote_range_m=V, mean_size_m=[1.0, 0.0, 1.0])


def _priors(K, sizes, V, sym=False):
    parts = tuple(
        PartPrior(name=f"p{k}", symmetry="y" if sym else "none", vote_range_m=V[k], mean_size_m=tuple(sizes[k])) for k in range(K)
    )
    joints = tuple(JointPrior(type="revolute", parent=0, child=k, axis_in_parent=(1.0, 0.0, 0.0)) for k in range(1, K))
    return CategoryPriors(category="toy", parts=parts, joints=joints, norm_scale_m=0.3)


@pytest.mark.parametrize("K", [1, 2, 3, 4])
def test_vote_parts_from_network_shaped_outputs(rng, K):
    poses, sizes, pts_all = [], [], []
    for k in range(K):
        T, s = random_part(rng)
        T[:3, 3] += np.array([0.5 * k, 0.0, 0.0])
        poses.append(T)
        sizes.append(s)
        pts_all.append(box_surface_points(rng, T, s, 600))
    points = np.concatenate(pts_all)
    normals = rng.normal(size=points.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    M = 800
    pair_idx = np.stack([600 * k + rng.integers(0, 600, (M, 2)) for k in range(K)])
    V = [1.1 * 0.5 * float(np.linalg.norm(s)) for s in sizes]
    outs = {n: [] for n in HEADS}
    for k in range(K):
        pk = points[pair_idx[k].reshape(-1)].reshape(M, 2, 3)
        a, b, n_, h, _ = synthetic_heads(
            rng, poses[k], sizes[k], sizes[k], M, V=V[k], points=np.concatenate([pk[:, 0], pk[:, 1]])
        )
        # The helper draws its own normals: recompute the sign bits for the cloud's normals.
        from ucope.model.targets import pair_vote_targets

        t = pair_vote_targets(
            a,
            b,
            torch.tensor(normals[pair_idx[k, :, 0]], dtype=torch.float32),
            torch.tensor(poses[k], dtype=torch.float32),
            torch.tensor(sizes[k], dtype=torch.float32),
            torch.tensor(sizes[k], dtype=torch.float32),
        )
        h["sign_logits"] = t["sign"] * 8 - 4
        for name in HEADS:
            outs[name].append(h[name])
    outputs = {name: torch.stack(v)[None] for name, v in outs.items()}
    cfg = _priors(K, sizes, V)
    full_surface = VotingOptions(thin_snap_ratio=0.0)  # points on every face: no visible side to snap to
    res = vote_parts(
        torch.tensor(points, dtype=torch.float32)[None],
        torch.tensor(normals, dtype=torch.float32)[None],
        torch.tensor(pair_idx)[None],
        outputs,
        cfg,
        options=full_surface,
    )
    assert res["cam_from_part"].shape == (K, 4, 4) and res["size_m"].shape == (K, 3) and len(res["timings_ms"]) == K
    for k in range(K):
        assert np.linalg.norm(res["cam_from_part"][k, :3, 3] - poses[k][:3, 3]) < 0.25 * V[k] / 20
        assert angle_deg(res["cam_from_part"][k, :3, 1], poses[k][:3, 1]) < 0.5
        assert angle_deg(res["cam_from_part"][k, :3, 0], poses[k][:3, 0]) < 0.5
        np.testing.assert_allclose(res["size_m"][k], sizes[k], rtol=0.01)
    # Unbatched inputs work too; wrong shapes are named.
    res2 = vote_parts(points, normals, pair_idx, {k: v[0] for k, v in outputs.items()}, cfg, options=full_surface)
    np.testing.assert_allclose(res2["cam_from_part"], res["cam_from_part"], atol=1e-6)
    # The axis heads computed lazily for the rows that vote the axes (as the estimator does): the same result.
    asked = []

    def axis_heads(k, rows):
        asked.append((k, len(rows)))
        return {n: outputs[n][0, k][rows] for n in ("alpha_logits", "beta_logits", "sign_logits")}

    lazy_outputs = {n: v for n, v in outputs.items() if n not in ("alpha_logits", "beta_logits", "sign_logits")}
    res3 = vote_parts(points, normals, pair_idx, lazy_outputs, cfg, options=full_surface, axis_heads=axis_heads)
    np.testing.assert_array_equal(res3["cam_from_part"], res2["cam_from_part"])
    assert [k for k, _ in asked] == list(range(K)) and all(0 < n <= VotingOptions().max_axis_pairs for _, n in asked)
    with pytest.raises(InputError, match="alpha_logits"):
        vote_parts(points, normals, pair_idx, lazy_outputs, cfg)
    with pytest.raises(InputError, match="beta_logits"):
        vote_parts(
            points,
            normals,
            pair_idx,
            lazy_outputs,
            cfg,
            axis_heads=lambda k, rows: {"alpha_logits": outputs["alpha_logits"][0, k][rows]},
        )
    with pytest.raises(InputError, match="mu_logits"):
        vote_parts(points, normals, pair_idx, {**outputs, "mu_logits": outputs["mu_logits"][:, :, :10]}, cfg)
    for name in ("mu_logits", "nu_logits", "gamma", "part_score"):
        bad = outputs[name].clone()
        bad[0, K - 1, 5] = float("nan")
        with pytest.raises(InputError, match="NaN"):
            vote_parts(points, normals, pair_idx, {**outputs, name: bad}, cfg)
    with pytest.raises(InputError, match="pair_idx"):
        vote_parts(points, normals, pair_idx + len(points), outputs, cfg)


def test_rotation_from_axes():
    g = torch.Generator().manual_seed(0)
    for _ in range(10):
        R0 = torch.linalg.qr(torch.randn(3, 3, generator=g))[0]
        R0 = R0 * torch.sign(torch.linalg.det(R0))
        x = R0[:, 0] + 0.02 * torch.randn(3, generator=g)
        y = R0[:, 1] + 0.02 * torch.randn(3, generator=g)
        R = rotation_from_axes(y, x)
        torch.testing.assert_close(R.T @ R, torch.eye(3), atol=1e-5, rtol=0)
        assert float(torch.linalg.det(R)) > 0
        assert angle_deg(R[:, 0], x) < 3 and angle_deg(R[:, 1], y) < 3
        Rs = rotation_from_axes(y)  # symmetric part: y exact, a deterministic x
        torch.testing.assert_close(Rs[:, 1], y / y.norm())
        torch.testing.assert_close(Rs, rotation_from_axes(y), rtol=0, atol=0)
        torch.testing.assert_close(Rs.T @ Rs, torch.eye(3), atol=1e-5, rtol=0)
    with pytest.raises(InputError):
        rotation_from_axes(torch.tensor([0.0, 1.0, 0.0]), torch.tensor([0.0, 2.0, 0.0]))
    with pytest.raises(InputError):
        rotation_from_axes(torch.zeros(3))


def test_refine_rotation_is_the_joint_optimum(rng):
    from ucope.geometry.transforms import random_rotation

    R = random_rotation(rng)
    e = rng.normal(size=(500, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    alpha, beta = np.arccos(e @ R[:, 1]), np.arccos(e @ R[:, 0])
    t = lambda x: torch.tensor(x, dtype=torch.float32)  # noqa: E731
    start = rotation_from_axes(t(R[:, 1] + 0.03), t(R[:, 0] - 0.03))
    out = refine_rotation(start, t(e), t(alpha), torch.ones(500), t(e), t(beta), torch.ones(500)).numpy()
    assert angle_deg(out[:, 0], R[:, 0]) < 0.05 and angle_deg(out[:, 1], R[:, 1]) < 0.05


def test_options_are_used(rng):
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 2000)
    r = vote_part(
        a,
        b,
        n,
        *(h[k] for k in HEADS),
        vote_range_m=V,
        mean_size_m=size,
        options=VotingOptions(
            refine_rotation=False,
            use_sign_bits=False,
            max_axis_pairs=500,
            centre=CentreOptions(num_angles=24, max_refine_pairs=1024),
        ),
    )
    _check_pose(r, T, size, V, False)
    assert math.isfinite(r.score)


def test_thin_parts_snap_to_their_visible_face(rng):
    """A plate seen from the camera side: a centre that is off along the plate's normal is moved so that
    the visible points lie on the face towards the camera; thick parts and the arbitrary axes of a
    y-symmetric part are left alone."""
    from ucope.voting.part import snap_to_visible_face

    R = torch.tensor(rotation_from_axes(torch.tensor([0.0, 0.6, -0.8]), torch.tensor([1.0, 0.0, 0.0])).numpy())
    size = np.array([0.30, 0.008, 0.20])  # thin along y
    centre = torch.tensor([0.05, -0.1, 0.9])
    n = R[:, 1]
    side = -1.0 if float(centre @ n) > 0 else 1.0
    uv = torch.tensor(rng.uniform(-0.5, 0.5, (500, 2)), dtype=torch.float32)
    face = centre + uv[:, :1] * 0.30 * R[:, 0] + uv[:, 1:] * 0.20 * R[:, 2] + side * 0.004 * n
    face = face + 0.0005 * torch.randn(500, 3, generator=torch.Generator().manual_seed(0))
    wrong = centre + 0.012 * n
    fixed = snap_to_visible_face(wrong, R, size, face, 0.25, False)
    assert float((fixed - centre).norm()) < 0.001
    assert torch.equal(snap_to_visible_face(wrong, R, np.array([0.3, 0.1, 0.2]), face, 0.25, False), wrong)  # not thin
    assert torch.equal(snap_to_visible_face(wrong, R, np.array([0.008, 0.3, 0.2]), face, 0.25, True), wrong)  # symmetric, thin x


def test_uncapped_options_let_every_pair_vote_and_still_recover_the_pose(rng):
    """``VotingOptions.uncapped()`` (the pairs ablation without caps): with 6,000 pairs, above every default
    cap, the pose is as exact as with the caps."""
    assert VotingOptions().capped and not VotingOptions.uncapped().capped
    assert VotingOptions.uncapped(score_threshold=0.3).score_threshold == 0.3
    T, size = random_part(rng)
    a, b, n, h, V = synthetic_heads(rng, T, size, size, 6000, outlier_frac=0.2)
    for opt in (VotingOptions(), VotingOptions.uncapped()):
        r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size, options=opt)
        _check_pose(r, T, size, V, False)
        assert r.num_pairs == 6000


def test_cone_agreement_matches_a_per_pair_reference(rng):
    from ucope.voting.part import _cone_agreement

    A = 500
    e = rng.normal(size=(3, A))
    e /= np.linalg.norm(e, axis=0)
    axis = rng.normal(size=3)
    angle = rng.uniform(0.0, math.pi, A)
    ref = 0
    for i in range(A):  # plain reference: the angle between the pair direction and the axis, one by one
        cos = float(np.dot(e[:, i], axis) / np.linalg.norm(axis))
        ref += abs(math.degrees(math.acos(max(-1.0, min(1.0, cos))) - angle[i])) < 20.0
    got = _cone_agreement(torch.from_numpy(axis), torch.from_numpy(e), torch.from_numpy(angle), 20.0)
    assert got == pytest.approx(ref / A)
    assert _cone_agreement(torch.from_numpy(axis), torch.zeros(3, 0, dtype=torch.float64), torch.zeros(0), 5.0) == 0.0


@pytest.mark.parametrize("sym", [False, True])
def test_axis_agreement_falls_when_the_axis_votes_disagree(rng, sym):
    T, size = random_part(rng, sym)
    agree = []
    for axis_noise in (0.0, 0.6):  # radians of noise on every pair's alpha and beta
        a, b, n, h, V = synthetic_heads(rng, T, size, size, 4000, noise=(0.0, axis_noise))
        r = vote_part(a, b, n, *(h[k] for k in HEADS), vote_range_m=V, mean_size_m=size, symmetric=sym)
        agree.append((r.up_agreement, r.right_agreement))
    assert agree[0][0] > 0.9 and agree[1][0] < 0.7 * agree[0][0]
    if sym:
        assert agree[0][1] == agree[1][1] == 1.0
    else:
        assert agree[0][1] > 0.9 and agree[1][1] < 0.7 * agree[0][1]
