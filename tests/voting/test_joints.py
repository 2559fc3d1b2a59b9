import numpy as np
import pytest
import torch
from voting_support import angle_deg

from ucope.errors import InputError
from ucope.voting import joint_from_points


def _heads(rng, N=2000, pivot=(0.1, -0.05, 0.8), axis=(0.3, 0.9, -0.2), outliers=0.3):
    pivot = np.asarray(pivot)
    axis = np.asarray(axis) / np.linalg.norm(axis)
    p = rng.normal(size=(N, 3)) * 0.1 + pivot
    v = p - pivot
    foot = pivot + (v @ axis)[:, None] * axis
    offset = foot - p
    d = np.tile(axis, (N, 1))
    heat = np.full(N, 4.0)
    score = np.full(N, 4.0)
    bad = rng.random(N) < outliers
    offset[bad] = rng.normal(size=(bad.sum(), 3))  # wild heads, but the network is unsure of them
    d[bad] = rng.normal(size=(bad.sum(), 3))
    score[bad] = -4.0
    t = lambda x: torch.tensor(x, dtype=torch.float32)  # noqa: E731
    return t(p), t(heat), t(offset), t(d), t(score), pivot, axis, bad


def _line_dist(p, u, q):
    return float(np.linalg.norm(np.cross(np.asarray(p) - q, u)))


def test_exact_heads_give_the_pivot_and_axis(rng):
    p, heat, off, d, sc, pivot, axis, bad = _heads(rng)
    v = joint_from_points(p, heat, off, d, sc)
    assert _line_dist(v.pivot, axis, pivot) < 1e-5
    assert angle_deg(v.axis, axis) < 1e-3
    assert v.num_points == int((~bad).sum()) and not v.fallback and v.score > 0.9
    # A minority of reversed directions: the majority sets the sign, the principal axis is unchanged.
    d2 = d.clone()
    d2[: len(d) // 4] *= -1
    v2 = joint_from_points(p, heat, off, d2, sc)
    assert angle_deg(v2.axis, axis) < 1e-3


def test_without_awareness_outliers_hurt(rng):
    p, heat, off, d, sc, pivot, axis, _ = _heads(rng)
    v = joint_from_points(p, heat, off, d, sc, awareness=False)
    assert v.num_points == len(p)
    assert _line_dist(v.pivot, axis, pivot) > 1e-3 or angle_deg(v.axis, axis) > 1.0


def test_fallback_when_no_point_passes(rng):
    p, heat, off, d, sc, pivot, axis, bad = _heads(rng, outliers=0.0)
    sc = torch.full_like(sc, -1.0)  # everything below the threshold, but still ordered by confidence
    v = joint_from_points(p, heat, off, d, sc)
    assert v.fallback and v.num_points == 200  # 10% of 2000
    assert _line_dist(v.pivot, axis, pivot) < 1e-5 and angle_deg(v.axis, axis) < 1e-3


def test_prismatic_pivot_is_the_voting_points_centroid(rng):
    N = 500
    p = torch.tensor(rng.normal(size=(N, 3)), dtype=torch.float32)
    d = torch.tensor(np.tile([0.0, 0.0, 1.0], (N, 1)), dtype=torch.float32)
    heat = torch.where(torch.arange(N) < 200, 5.0, -5.0)  # heat = on the child part
    v = joint_from_points(p, heat, torch.zeros(N, 3), d, torch.full((N,), 5.0))
    np.testing.assert_allclose(v.pivot, p[:200].double().mean(0).numpy(), atol=1e-5)
    np.testing.assert_allclose(v.axis, [0.0, 0.0, 1.0], atol=1e-6)


def test_joint_errors(rng):
    p, heat, off, d, sc, *_ = _heads(rng, N=10)
    with pytest.raises(InputError):
        joint_from_points(p, heat[:5], off, d, sc)
    with pytest.raises(InputError):
        joint_from_points(p, heat, off[:, :2], d, sc)
    off[0, 0] = float("nan")
    with pytest.raises(InputError):
        joint_from_points(p, heat, off, d, sc)
