import torch

from ucope.geometry.transforms import make_transform, random_rotation
from ucope.model.targets import (
    bin_centres,
    joint_point_targets,
    pair_features,
    pair_vote_targets,
    two_hot,
)


def _random_pose(rng):
    return torch.from_numpy(make_transform(random_rotation(rng), rng.normal(size=3))).double()


def test_pair_targets_define_the_centre_circle_and_axes(rng):
    T = _random_pose(rng)
    size = torch.tensor([0.3, 0.1, 0.2], dtype=torch.float64)
    a = torch.from_numpy(rng.normal(size=(200, 3)))
    b = torch.from_numpy(rng.normal(size=(200, 3)))
    n = torch.nn.functional.normalize(torch.from_numpy(rng.normal(size=(200, 3))), dim=-1)
    t = pair_vote_targets(a, b, n, T, size, torch.tensor([0.2, 0.2, 0.2], dtype=torch.float64))
    e = (a - b) / (a - b).norm(dim=-1, keepdim=True)
    c = T[:3, 3]
    foot = a - t["mu"][:, None] * e
    # The centre lies on the circle about the foot, of radius nu, in the plane normal to e.
    torch.testing.assert_close((c - foot).norm(dim=-1), t["nu"])
    torch.testing.assert_close(((c - foot) * e).sum(-1), torch.zeros(200, dtype=torch.float64), atol=1e-12, rtol=0)
    torch.testing.assert_close(torch.cos(t["alpha"]), e @ T[:3, 1])
    torch.testing.assert_close(torch.cos(t["beta"]), e @ T[:3, 0])
    torch.testing.assert_close(t["gamma"], torch.log(size / 0.2))
    # Sign bits do not depend on the normals' signs.
    t2 = pair_vote_targets(a, b, -n, T, size, torch.full((3,), 0.2, dtype=torch.float64))
    assert torch.equal(t["sign"], t2["sign"])
    # Invariance: moving points and part together leaves every parameter unchanged.
    G = _random_pose(rng)
    Ga, Gb = a @ G[:3, :3].T + G[:3, 3], b @ G[:3, :3].T + G[:3, 3]
    t3 = pair_vote_targets(Ga, Gb, n @ G[:3, :3].T, G @ T, size, torch.full((3,), 0.2, dtype=torch.float64))
    for k in ("mu", "nu", "alpha", "beta", "sign"):
        torch.testing.assert_close(t3[k], t[k])


def test_pair_features_invariances(rng):
    a, b = torch.from_numpy(rng.normal(size=(50, 3))), torch.from_numpy(rng.normal(size=(50, 3)))
    na = torch.nn.functional.normalize(torch.from_numpy(rng.normal(size=(50, 3))), dim=-1)
    nb = torch.nn.functional.normalize(torch.from_numpy(rng.normal(size=(50, 3))), dim=-1)
    f = pair_features(a, b, na, nb, 2.0)
    assert f.shape == (50, 4)
    torch.testing.assert_close(f[:, 0], (a - b).norm(dim=-1) / 2.0)
    assert (f[:, 1:3] >= 0).all()  # normals flipped along the pair direction
    torch.testing.assert_close(pair_features(a, b, -na, nb, 2.0), f)
    torch.testing.assert_close(pair_features(a, b, na, -nb, 2.0), f)
    R = torch.from_numpy(random_rotation(rng))
    torch.testing.assert_close(pair_features(a @ R.T + 1, b @ R.T + 1, na @ R.T, nb @ R.T, 2.0), f)


def test_two_hot_expectation_and_ends():
    lo, hi, n = -0.5, 1.5, 32
    x = torch.linspace(lo, hi, 301, dtype=torch.float64)
    t = two_hot(x, lo, hi, n)
    c = bin_centres(lo, hi, n, dtype=torch.float64)
    torch.testing.assert_close(t.sum(-1), torch.ones_like(x))
    assert (t >= 0).all() and ((t > 0).sum(-1) <= 2).all()
    inside = (x >= c[0]) & (x <= c[-1])
    torch.testing.assert_close((t * c).sum(-1)[inside], x[inside])
    assert t[0, 0] == 1 and t[-1, -1] == 1
    # Per-element ranges broadcast (a vote range per part).
    V = torch.tensor([[0.1], [0.2]], dtype=torch.float64)
    t2 = two_hot(torch.tensor([[0.05], [0.05]], dtype=torch.float64), -V, V, 8)
    assert not torch.equal(t2[0], t2[1])


def test_joint_targets_point_at_the_axis(rng):
    B, N = 2, 100
    pts = torch.from_numpy(rng.normal(size=(B, N, 3)) * 0.2)
    labels = torch.from_numpy(rng.integers(0, 3, size=(B, N)))
    pivot = torch.from_numpy(rng.normal(size=(B, 2, 3)) * 0.1)
    axis = torch.nn.functional.normalize(torch.from_numpy(rng.normal(size=(B, 2, 3))), dim=-1)
    jtype = torch.tensor([[0, 1], [0, 1]])
    t = joint_point_targets(pts, labels, pivot, axis, jtype, torch.tensor([0, 0]), torch.tensor([1, 2]), 0.1)
    foot = pts.unsqueeze(1) + t["offset"]  # revolute: on the axis line
    rel = foot[:, 0] - pivot[:, 0:1]
    cross = torch.cross(rel, axis[:, 0:1].expand_as(rel), dim=-1).norm(dim=-1)
    assert cross.max() < 1e-12
    d = t["offset"][:, 0].norm(dim=-1)
    torch.testing.assert_close(t["heat"][:, 0], (1 - d / 0.1).clamp_min(0))
    assert torch.equal(t["offset"][:, 1], torch.zeros(B, N, 3, dtype=torch.float64))  # prismatic
    assert torch.equal(t["heat"][:, 1], (labels == 2).double())
    assert torch.equal(t["score"][:, 0], ((labels == 0) | (labels == 1)).double())
    assert torch.equal(t["score"][:, 1], ((labels == 0) | (labels == 2)).double())
