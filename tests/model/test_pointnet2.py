"""Tests of the pure-torch PointNet++ encoder (ucope.model.pointnet2)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from ucope.errors import InputError
from ucope.geometry.sampling import farthest_point_sampling
from ucope.model.pointnet2 import (
    FeaturePropagation,
    PointNet2Config,
    PointNet2Encoder,
    SetAbstraction,
    _LinearMaxPool,
    ball_query,
    farthest_point_sample_torch,
    gather_points,
    numpy_fps_indices,
    square_distance,
    three_nn_interpolate,
)

TINY = PointNet2Config(
    in_channels=3,
    npoints=(64, 16),
    radii=(0.2, 0.4),
    nsamples=(16, 8),
    sa_mlps=((16, 16, 32), (32, 32, 64)),
    global_mlp=(64, 128),
    fp_mlps=((64, 64), (64, 32), (32, 32)),
)


def _cloud(B: int, N: int, seed: int = 0, dtype=torch.float32) -> torch.Tensor:
    """Points on a noisy sphere of radius 0.5 (about unit size), ``(B, N, 3)``."""
    g = torch.Generator().manual_seed(seed)
    x = torch.randn(B, N, 3, generator=g, dtype=torch.float64)
    x = 0.5 * x / x.norm(dim=-1, keepdim=True) + 0.02 * torch.randn(B, N, 3, generator=g, dtype=torch.float64)
    return x.to(dtype)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)


# --------------------------------------------------------------------------------------- functional ops


def test_square_distance_and_gather():
    a, b = torch.rand(2, 5, 3, dtype=torch.float64), torch.rand(2, 7, 3, dtype=torch.float64)
    ref = ((a[:, :, None] - b[:, None]) ** 2).sum(-1)
    assert torch.allclose(square_distance(a, b), ref, atol=1e-12)
    idx = torch.randint(0, 7, (2, 4, 3))
    g = gather_points(b, idx)
    assert g.shape == (2, 4, 3, 3)
    for i in range(2):
        assert torch.equal(g[i], b[i][idx[i]])


def _ball_query_reference(xyz: np.ndarray, centres: np.ndarray, radius: float, nsample: int) -> np.ndarray:
    B, M = centres.shape[:2]
    out = np.zeros((B, M, nsample), dtype=np.int64)
    for b in range(B):
        for m in range(M):
            d2 = ((xyz[b] - centres[b, m]) ** 2).sum(-1)
            order = np.argsort(d2, kind="stable")
            nearest = order[0]
            chosen = [int(j) for j in order if d2[j] < radius**2][:nsample]
            out[b, m] = chosen + [nearest] * (nsample - len(chosen))
    return out


@pytest.mark.parametrize("n", [60, 6])
def test_ball_query_matches_loop_reference(n):
    xyz = torch.rand(2, n, 3, dtype=torch.float64)
    centres = torch.cat([xyz[:, :4], torch.rand(2, 3, 3, dtype=torch.float64)], dim=1)
    centres[:, -1] = 5.0  # far away: no point within the radius, every slot is the nearest
    idx = ball_query(xyz, centres, radius=0.3, nsample=8)
    assert idx.shape == (2, 7, 8) and idx.dtype == torch.long
    ref = _ball_query_reference(xyz.numpy(), centres.numpy(), 0.3, 8)
    np.testing.assert_array_equal(idx.numpy(), ref)
    # centres taken from xyz are their own nearest neighbour, so always a member
    assert torch.equal(idx[:, :4, 0], torch.arange(4).expand(2, 4))


def test_ball_query_float32_sets():
    xyz = torch.rand(1, 200, 3)
    centres = xyz[:, :20]
    idx = ball_query(xyz, centres, radius=0.2, nsample=16)
    ref = _ball_query_reference(xyz.double().numpy(), centres.double().numpy(), 0.2, 16)
    for m in range(20):
        assert set(idx[0, m].tolist()) == set(ref[0, m].tolist())


def _three_nn_reference(dst: np.ndarray, src: np.ndarray, f: np.ndarray, eps: float = 1e-8) -> np.ndarray:
    out = np.zeros((dst.shape[0], dst.shape[1], f.shape[-1]))
    for b in range(dst.shape[0]):
        for i in range(dst.shape[1]):
            d2 = ((src[b] - dst[b, i]) ** 2).sum(-1)
            nn = np.argsort(d2)[: min(3, src.shape[1])]
            w = 1.0 / (d2[nn] + eps)
            out[b, i] = (w[:, None] * f[b, nn]).sum(0) / w.sum()
    return out


@pytest.mark.parametrize("m", [20, 2, 1])
def test_three_nn_interpolate(m):
    src = torch.rand(2, m, 3, dtype=torch.float64)
    dst = torch.rand(2, 30, 3, dtype=torch.float64)
    f = torch.randn(2, m, 5, dtype=torch.float64)
    out = three_nn_interpolate(dst, src, f)
    assert out.shape == (2, 30, 5)
    np.testing.assert_allclose(out.numpy(), _three_nn_reference(dst.numpy(), src.numpy(), f.numpy()), rtol=1e-10, atol=1e-12)
    # a constant feature is reproduced
    const = torch.full((2, m, 4), 2.5)
    assert torch.allclose(three_nn_interpolate(dst.float(), src.float(), const), torch.full((2, 30, 4), 2.5), atol=1e-6)


def test_three_nn_interpolate_exact_at_sources():
    src = torch.rand(2, 40, 3)
    f = torch.randn(2, 40, 6)
    perm = torch.randperm(40)[:25]
    dst = torch.cat([src[:, perm], torch.rand(2, 5, 3)], dim=1)
    out = three_nn_interpolate(dst, src, f)
    assert torch.equal(out[:, :25], f[:, perm])


def test_fps_torch_equals_numpy():
    xyz = torch.rand(3, 500, 3)
    np.testing.assert_array_equal(farthest_point_sample_torch(xyz, 100).numpy(), farthest_point_sampling(xyz.numpy(), 100))
    # ties: points on a coarse grid have many equal distances; both take the first maximum
    grid = (torch.rand(2, 300, 3) * 5).floor() / 5
    np.testing.assert_array_equal(farthest_point_sample_torch(grid, 60).numpy(), farthest_point_sampling(grid.numpy(), 60))
    with pytest.raises(InputError):
        farthest_point_sample_torch(xyz, 501)


def test_numpy_fps_indices_levels():
    xyz = _cloud(2, 256).numpy()
    idx = numpy_fps_indices(xyz, (64, 16))
    assert [i.shape for i in idx] == [(2, 64), (2, 16)]
    np.testing.assert_array_equal(idx[1], farthest_point_sampling(np.take_along_axis(xyz, idx[0][..., None], 1), 16))
    single = numpy_fps_indices(xyz[1], (64, 16))
    assert [s.shape for s in single] == [(64,), (16,)]
    for a, b in zip(single, idx, strict=False):
        np.testing.assert_array_equal(a, b[1])


def test_linear_max_pool_gradient_with_ties():
    x = torch.randn(6, 5, 4, dtype=torch.float64)
    x[:, 3:] = x[:, :1]  # duplicated rows, as ball_query's padding makes
    x.requires_grad_(True)
    w = torch.randn(3, 4, dtype=torch.float64, requires_grad=True)
    y = _LinearMaxPool.apply(x, w)
    g = torch.randn_like(y)
    got = torch.autograd.grad(y, (x, w), g)
    y_ref = F.linear(x, w).amax(1)
    ref = torch.autograd.grad(y_ref, (x, w), g)
    assert torch.equal(y, y_ref)
    for a, b in zip(got, ref, strict=False):
        assert torch.allclose(a, b)
    assert torch.autograd.gradcheck(_LinearMaxPool.apply, (torch.randn(4, 3, 4, dtype=torch.float64, requires_grad=True), w))


# --------------------------------------------------------------------------------------- modules


def test_set_abstraction_matches_naive():
    """The fused implementation (first layer before grouping, bias/ReLU after pooling) equals the textbook one."""
    sa = SetAbstraction(16, 0.3, 8, 4, (8, 8, 12)).double()
    xyz = _cloud(2, 64, dtype=torch.float64)
    feats = torch.randn(2, 64, 4, dtype=torch.float64, requires_grad=True)
    new_xyz, out = sa(xyz, feats)
    fps = farthest_point_sample_torch(xyz, 16)
    assert torch.equal(new_xyz, gather_points(xyz, fps))
    idx = ball_query(xyz, new_xyz, 0.3, 8)
    h = torch.cat([(gather_points(xyz, idx) - new_xyz[:, :, None]) / 0.3, gather_points(feats, idx)], dim=-1)
    for layer in sa.mlp.layers:
        h = F.relu(layer(h))
    ref = h.max(2).values
    assert torch.allclose(out, ref, atol=1e-12)
    g = torch.randn_like(out)
    params = [feats, *sa.parameters()]
    got = torch.autograd.grad(out, params, g)
    exp = torch.autograd.grad(ref, params, g)
    for a, b in zip(got, exp, strict=False):
        assert torch.allclose(a, b, atol=1e-10)
    # group all: one global feature from [xyz, feats]
    sg = SetAbstraction(None, None, None, 4, (8, 16)).double()
    gx, gf = sg(xyz, feats)
    assert gx.shape == (2, 1, 3) and not gx.any()
    assert torch.allclose(gf[:, 0], sg.mlp(torch.cat([xyz, feats], -1)).max(1).values, atol=1e-12)


def test_feature_propagation_matches_naive():
    fp = FeaturePropagation(6 + 2, (8, 5), skip_channels=2, last_relu=False).double()
    src, dst = torch.rand(2, 10, 3, dtype=torch.float64), torch.rand(2, 30, 3, dtype=torch.float64)
    fs, fd = torch.randn(2, 10, 6, dtype=torch.float64), torch.randn(2, 30, 2, dtype=torch.float64)
    out = fp(dst, src, fd, fs)
    ref = fp.mlp(torch.cat([three_nn_interpolate(dst, src, fs), fd], -1))
    assert out.shape == (2, 30, 5)
    assert torch.allclose(out, ref, atol=1e-12)
    assert (out < 0).any()  # plain Linear last


@pytest.mark.parametrize("in_channels", [3, 0])
def test_encoder_shapes(in_channels):
    cfg = PointNet2Config(**{**TINY.__dict__, "in_channels": in_channels})
    enc = PointNet2Encoder(cfg)
    xyz = _cloud(2, 256)
    feats = torch.randn(2, 256, 3) if in_channels else None
    out = enc(xyz, feats)
    assert out.shape == (2, 256, enc.out_channels) == (2, 256, 32)
    assert out.dtype == torch.float32 and torch.isfinite(out).all()
    with pytest.raises(InputError):
        enc(xyz, feats, [torch.zeros(2, 64, dtype=torch.long)])  # one level missing
    if in_channels:
        with pytest.raises(InputError):
            enc(xyz, None)


def test_config_width_and_validation():
    assert PointNet2Config().out_channels == 128
    assert PointNet2Encoder(PointNet2Config()).out_channels == 128
    slim = PointNet2Config(width=0.5, npoints=(256, 64))
    assert slim.out_channels == 64 and slim.channels((64, 10)) == (32, 8)
    enc = PointNet2Encoder(slim)
    assert enc.sa[0].mlp.layers[0].in_features == 3 + 3  # in_channels is not scaled
    assert enc.sa[0].out_channels == 64 and enc.global_sa.out_channels == 256
    with pytest.raises(InputError):
        PointNet2Config(radii=(0.1,))
    with pytest.raises(InputError):
        PointNet2Config(fp_mlps=((8,),))


def test_encoder_numpy_indices_equal_torch_fallback():
    enc = PointNet2Encoder(TINY)
    xyz, feats = _cloud(2, 256), torch.randn(2, 256, 3)
    idx = [torch.from_numpy(i) for i in numpy_fps_indices(xyz.numpy(), TINY.npoints)]
    assert torch.equal(enc(xyz, feats, idx), enc(xyz, feats))


def test_encoder_permutation_equivariance():
    enc = PointNet2Encoder(TINY).double()
    xyz, feats = _cloud(2, 256, dtype=torch.float64), torch.randn(2, 256, 3, dtype=torch.float64)
    idx = [torch.from_numpy(i) for i in numpy_fps_indices(xyz.numpy(), TINY.npoints)]
    out = enc(xyz, feats, idx)
    perm = torch.randperm(256)
    inv = torch.argsort(perm)
    idx_p = [inv[idx[0]], idx[1]]  # level 0 indices move with the points; level 1 indexes level 0 samples
    out_p = enc(xyz[:, perm], feats[:, perm], idx_p)
    assert torch.allclose(out_p, out[:, perm], atol=1e-10)


def test_encoder_gradients_reach_all_parameters():
    enc = PointNet2Encoder(TINY)
    xyz, feats = _cloud(2, 256), torch.randn(2, 256, 3)
    enc(xyz, feats).square().mean().backward()
    for name, p in enc.named_parameters():
        assert p.grad is not None and p.grad.abs().sum() > 0, name
