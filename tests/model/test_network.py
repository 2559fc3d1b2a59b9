import functools

import numpy as np
import pytest
import torch
from tests_support import measured_priors

from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import InputError
from ucope.model.batch import TrainingItems, batch_to, collate_items, sample_pairs
from ucope.model.config import ModelConfig
from ucope.model.network import UCOPENet
from ucope.model.pointnet2 import PointNet2Config
from ucope.vocab import AXIS_HEADS

TINY_ENCODER = PointNet2Config(width=0.25, npoints=(64, 16), radii=(0.15, 0.3), nsamples=(8, 8))


@functools.cache
def tiny_samples(category: str, n: int = 8) -> tuple:
    cfg = GenerateConfig(category=category, split="train", num=n, max_points=600, views_per_instance=2)
    return tuple(make_sample(cfg, i) for i in range(n))


def tiny_config(category: str, **kw) -> ModelConfig:
    base = dict(encoder=TINY_ENCODER, num_points=256, pairs_per_part=48, hidden=32)
    base.update(kw)
    return ModelConfig.default(measured_priors(category, tiny_samples(category)), size="full", **base)


def tiny_batch(cfg: ModelConfig, n: int = 4, seed: int = 0) -> dict:
    items = TrainingItems(list(tiny_samples(cfg.category)), cfg, seed=seed)
    return collate_items([items[i] for i in range(n)])


def overfit(net, batch: dict, steps: int, lr: float = 3e-3) -> tuple[dict, dict]:
    """Adam on one batch for ``steps`` steps; the logs of the first and the last step."""
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    first = None
    for _ in range(steps):
        loss, logs = net.compute_loss(batch)
        opt.zero_grad()
        loss.backward()
        opt.step()
        first = logs if first is None else first
    return first, logs


@pytest.mark.parametrize("category, K", [("mug", 1), ("laptop", 2), ("eyeglasses", 3), ("drawer", 4)])
def test_output_shapes(category, K):
    torch.manual_seed(0)
    cfg = tiny_config(category)
    assert cfg.num_parts == K
    net = UCOPENet(cfg)
    b = tiny_batch(cfg, n=3)
    out = net(b["points"], b["normals"], b["pair_idx"], b["fps_idx"])
    B, N, M, J = 3, cfg.num_points, cfg.pairs_per_part, K - 1
    assert out["feats"].shape == (B, N, net.encoder.out_channels)
    assert out["masks"].shape == (B, N, K)
    torch.testing.assert_close(out["masks"].sum(-1), torch.ones(B, N))
    assert ("seg_logits" in out) == (K > 1)
    assert out["mu_logits"].shape == (B, K, M, cfg.mu_bins)
    assert out["nu_logits"].shape == (B, K, M, cfg.nu_bins)
    assert out["alpha_logits"].shape == out["beta_logits"].shape == (B, K, M, cfg.angle_bins)
    assert out["sign_logits"].shape == (B, K, M, 2)
    assert out["gamma"].shape == (B, K, M, 3)
    assert out["part_score"].shape == (B, K, M)
    if J:
        assert out["joint_heat"].shape == out["joint_score"].shape == (B, J, N)
        assert out["joint_offset"].shape == out["joint_dir"].shape == (B, J, N, 3)
        torch.testing.assert_close(out["joint_dir"].norm(dim=-1), torch.ones(B, J, N))
    else:
        assert "joint_heat" not in out
    # The encoder's own FPS gives the same result as the precomputed indices.
    out2 = net(b["points"], b["normals"], b["pair_idx"])
    torch.testing.assert_close(out2["mu_logits"], out["mu_logits"])


def test_pair_outputs_do_not_depend_on_other_pairs():
    """Pairs are independent: a pair's outputs do not change when other pairs are added."""
    torch.manual_seed(0)
    cfg = tiny_config("laptop")
    net = UCOPENet(cfg).eval()
    b = tiny_batch(cfg, n=2)
    with torch.no_grad():
        full = net(b["points"], b["normals"], b["pair_idx"], b["fps_idx"])
        part = net(b["points"], b["normals"], b["pair_idx"][:, :, :5], b["fps_idx"])
    torch.testing.assert_close(part["alpha_logits"], full["alpha_logits"][:, :, :5])


@pytest.mark.parametrize("category", ["mug", "drawer"])
def test_lazy_pair_outputs_equal_the_full_heads(category):
    """Some heads for every pair, the rest later for a few rows of one part: the same numbers."""
    torch.manual_seed(0)
    cfg = tiny_config(category)
    net = UCOPENet(cfg).eval()
    b = tiny_batch(cfg, n=1)
    with torch.no_grad():
        enc = net.encode(b["points"], b["normals"], b["fps_idx"])
        full = net.pair_heads(enc, b["points"], b["normals"], b["pair_idx"])
        some = net.pair_heads(
            enc, b["points"], b["normals"], b["pair_idx"], heads=("mu_logits", "part_score"), return_hidden=True
        )
        assert set(some) == {"mu_logits", "part_score", "pair_hidden"}
        torch.testing.assert_close(some["mu_logits"], full["mu_logits"])
        torch.testing.assert_close(some["part_score"], full["part_score"])
        rows = torch.tensor([3, 0, 7])
        k = cfg.num_parts - 1
        late = net.pair_outputs(some["pair_hidden"][0, k, rows], AXIS_HEADS, part=k)
        assert set(late) == set(AXIS_HEADS)
        for name in AXIS_HEADS:
            torch.testing.assert_close(late[name], full[name][0, k, rows])
        with pytest.raises(InputError, match="unknown pair heads"):
            net.pair_outputs(some["pair_hidden"], ("theta_logits",))


@pytest.mark.parametrize("category", ["mug", "bottle", "laptop", "drawer"])
def test_gradients_reach_every_head(category):
    torch.manual_seed(0)
    cfg = tiny_config(category)
    net = UCOPENet(cfg)
    loss, logs = net.compute_loss(tiny_batch(cfg))
    assert torch.isfinite(loss) and loss.item() > 0
    loss.backward()
    for name, p in net.named_parameters():
        assert p.grad is not None, name
        assert torch.isfinite(p.grad).all(), name
        if name.startswith("pair_out") and cfg.priors.parts[0].symmetry == "y" and cfg.num_parts == 1:
            continue  # the beta bins of a symmetric part get no gradient (checked below)
        assert p.grad.abs().sum() > 0, name
    assert set(logs) >= {"loss", "pose", "mu", "nu", "alpha", "beta", "gamma", "sign", "part_score"}
    if cfg.num_parts > 1:
        assert {"seg", "seg_acc", "joint_pivot", "joint_dir", "axis_err_deg"} <= set(logs)


def test_symmetric_part_trains_no_right_axis():
    """A y-symmetric part (bottle) gets no gradient on its beta bins or its right-axis sign bit."""
    torch.manual_seed(0)
    cfg = tiny_config("bottle")
    assert cfg.priors.symmetric == (True,)
    net = UCOPENet(cfg)
    loss, _ = net.compute_loss(tiny_batch(cfg))
    loss.backward()
    g = net.pair_out.weight.grad[0]  # (H, O)
    s = net.out_sizes
    o_beta = s["mu_logits"] + s["nu_logits"] + s["alpha_logits"]
    o_sign = o_beta + s["beta_logits"]
    assert g[:, o_beta : o_beta + s["beta_logits"]].abs().max() == 0
    assert g[:, o_sign + 1].abs().max() == 0  # right-axis sign bit
    assert g[:, o_sign].abs().max() > 0  # up-axis sign bit trains
    assert g[:, s["mu_logits"] + s["nu_logits"] :][:, : s["alpha_logits"]].abs().max() > 0


@pytest.mark.parametrize("category", ["laptop", "mug"])
def test_tiny_model_overfits_tiny_data(category):
    torch.manual_seed(0)
    cfg = tiny_config(category)
    net = UCOPENet(cfg)
    b = tiny_batch(cfg, n=4)
    first, logs = overfit(net, b, 200)
    assert logs["loss"] < 0.6 * first["loss"], (first["loss"], logs["loss"])
    assert logs["mu"] < 0.7 * first["mu"]
    assert logs["mu_err_m"] < first["mu_err_m"]
    if cfg.num_parts > 1:
        assert logs["seg_acc"] > 0.9
        assert logs["axis_err_deg"] < first["axis_err_deg"]


def test_batch_items_are_deterministic_and_epoch_dependent():
    cfg = tiny_config("laptop")
    items = TrainingItems(list(tiny_samples("laptop")), cfg, seed=3)
    a, b = items[2], items[2]
    for k in ("points", "pair_idx", "part_labels"):
        assert torch.equal(a[k], b[k])
    assert all(torch.equal(x, y) for x, y in zip(a["fps_idx"], b["fps_idx"], strict=False))
    items.set_epoch(1)
    assert not torch.equal(items[2]["pair_idx"], a["pair_idx"])
    assert a["points"].shape == (cfg.num_points, 3)
    assert a["pair_idx"].shape == (cfg.num_parts, cfg.pairs_per_part, 2)
    batch = batch_to(collate_items([a, b]), "cpu")
    assert batch["points"].shape == (2, cfg.num_points, 3)
    assert [t.shape for t in batch["fps_idx"]] == [(2, 64), (2, 16)]


def test_sample_pairs_first_point_on_its_part(rng):
    labels = np.array([0] * 50 + [1] * 5 + [2] * 0)
    pairs = sample_pairs(labels, 3, 400, rng)
    assert pairs.shape == (3, 400, 2)
    assert np.all(labels[pairs[0, :, 0]] == 0) and np.all(labels[pairs[1, :, 0]] == 1)
    same = labels[pairs[1, :, 1]] == 1
    assert 0.4 < same.mean() < 0.7  # half drawn from the part, plus the few random hits
    assert pairs[2].min() >= 0 and pairs[2].max() < len(labels)  # invisible part: anywhere


def test_config_round_trip_and_errors():
    cfg = tiny_config("eyeglasses")
    d = cfg.to_dict()
    import json

    back = ModelConfig.from_dict(json.loads(json.dumps(d)), cfg.priors.tensors())
    assert back == cfg and all(
        np.array_equal(a, b) for a, b in zip(back.priors.shape_templates, cfg.priors.shape_templates, strict=False)
    )
    assert [(j.parent, j.child, j.type.label) for j in cfg.priors.joints] == [(0, 1, "revolute"), (0, 2, "revolute")]
    with pytest.raises(InputError, match="unknown model config fields"):
        ModelConfig.from_dict({**d, "bogus": 1})
    with pytest.raises(InputError, match="malformed"):
        ModelConfig.from_dict({k: v for k, v in d.items() if k != "priors"})
    with pytest.raises(InputError, match="version"):
        ModelConfig.from_dict({**d, "version": 1})
    with pytest.raises(InputError, match="size"):
        ModelConfig.default(cfg.priors, size="huge")


def test_bad_input_shapes():
    cfg = tiny_config("mug")
    net = UCOPENet(cfg)
    pts = torch.zeros(1, 300, 3)
    with pytest.raises(InputError, match="points and normals"):
        net(pts, torch.zeros(1, 300, 2))
    with pytest.raises(InputError, match="pair_idx"):
        net(torch.randn(1, 300, 3), torch.randn(1, 300, 3), torch.zeros(1, 2, 5, 2, dtype=torch.long))


def test_segmentation_weighting_over_points_is_k_times_the_mean_cross_entropy():
    torch.manual_seed(0)
    cfg = tiny_config("drawer", seg_weighting="points")
    net = UCOPENet(cfg)
    b = tiny_batch(cfg, n=2)
    out = net(b["points"], b["normals"], b["pair_idx"], b["fps_idx"])
    seg = net._seg_loss(out, b, {})
    ce = torch.nn.functional.cross_entropy(out["seg_logits"].reshape(-1, 4), b["part_labels"].reshape(-1))
    torch.testing.assert_close(seg, 4 * ce)
    balanced = UCOPENet(tiny_config("drawer"))._seg_loss(out, b, {})
    assert not torch.isclose(balanced, seg)  # a different weighting of the same logits
    with pytest.raises(InputError, match="seg_weighting"):
        tiny_config("drawer", seg_weighting="parts")


# ---------------------------------------------------------------- batched heads = per-part computation
def _per_part_pair_outputs(net: UCOPENet, enc: dict, points, normals, pair_idx) -> dict[str, torch.Tensor]:
    """The pair encoder as the paper writes it, one part at a time: for part k and pair (i, j),
    ``[F1 m_k][i], [F1 m_k][j], PPF(i, j), onehot(k)`` -> the first layer (the concatenation's weights),
    the hidden layers, and part k's own output layer."""
    from ucope.model.targets import pair_features

    K, H = net.cfg.num_parts, net.cfg.hidden
    f1, masks = enc["feats"], enc["masks"]
    W_point = net.pair_point.weight  # (2H, C): [W_a; W_b]
    W_first = torch.cat([W_point[:H], W_point[H:], net.pair_geo.weight], dim=1)  # (H, 2C + 4 + K)
    outs = []
    for b in range(points.shape[0]):
        per_part = []
        for k in range(K):
            f2 = f1[b] * masks[b, :, k : k + 1]  # (N, C): the re-modulated features of part k
            i, j = pair_idx[b, k, :, 0], pair_idx[b, k, :, 1]
            ppf = pair_features(points[b, i], points[b, j], normals[b, i], normals[b, j], net.norm_scale)
            onehot = torch.nn.functional.one_hot(torch.full_like(i, k), K).to(f2.dtype)
            x = torch.cat([f2[i], f2[j], ppf, onehot], dim=1)
            hidden = net.pair_mlp(x @ W_first.T + net.pair_geo.bias)
            per_part.append(hidden @ net.pair_out.weight[k] + net.pair_out.bias[k])  # (M, outputs)
        outs.append(torch.stack(per_part))
    y = torch.stack(outs)  # (B, K, M, outputs)
    start, out = 0, {}
    for name, n in net.out_sizes.items():
        out[name] = y[..., start : start + n]
        start += n
    out["part_score"] = out["part_score"].squeeze(-1)
    return out


@pytest.mark.parametrize("pairs", [40, 300])  # fewer pairs than points (training's branch) and more (inference's)
def test_batched_pair_encoder_equals_the_per_part_computation(pairs):
    """The pair encoder runs every part at once (the first layer once per point, the pairs' rows gathered,
    one batched output layer); it must equal the per-part loop to 1e-5 on a small random network, on either
    branch (gathering the pairs' rows when there are fewer pairs than points, weighting every point first
    otherwise)."""
    torch.manual_seed(3)
    cfg = tiny_config("drawer", num_points=256, pairs_per_part=pairs, hidden=16)
    net = UCOPENet(cfg).eval()
    b = tiny_batch(cfg, n=2)
    with torch.no_grad():
        enc = net.encode(b["points"], b["normals"], b["fps_idx"])
        got = net.pair_heads(enc, b["points"], b["normals"], b["pair_idx"])
        want = _per_part_pair_outputs(net, enc, b["points"], b["normals"], b["pair_idx"])
    assert cfg.num_parts == 4 and b["pair_idx"].shape[2] == pairs
    for name in net.out_sizes:
        torch.testing.assert_close(got[name], want[name], rtol=1e-5, atol=1e-5, msg=name)


def test_both_pair_encoder_branches_give_the_same_bits():
    """The training branch (pairs' rows gathered, then weighted) and the inference branch (points weighted,
    then gathered) do the same float operations in the same order: the same pairs give the same outputs."""
    torch.manual_seed(4)
    cfg = tiny_config("drawer", num_points=256, pairs_per_part=40, hidden=16)
    net = UCOPENet(cfg).eval()
    b = tiny_batch(cfg, n=2)
    few = b["pair_idx"]
    many = torch.cat([few, few[:, :, :1].expand(-1, -1, 300, -1)], dim=2)  # 340 pairs > 256 points
    with torch.no_grad():
        enc = net.encode(b["points"], b["normals"], b["fps_idx"])
        a = net.pair_heads(enc, b["points"], b["normals"], few, return_hidden=True)
        c = net.pair_heads(enc, b["points"], b["normals"], many, return_hidden=True)
    torch.testing.assert_close(a["pair_hidden"], c["pair_hidden"][:, :, :40], rtol=1e-6, atol=1e-6)


def test_the_loss_of_the_two_hot_bins_equals_the_kl_of_the_materialised_target():
    from ucope.model.targets import two_hot, two_hot_kl

    g = torch.Generator().manual_seed(0)
    logits = (3 * torch.randn(2, 3, 50, 32, generator=g)).requires_grad_(True)
    V = torch.tensor([0.1, 0.2, 0.3]).view(1, 3, 1)
    x = (torch.rand(2, 3, 50, generator=g) * 2.4 - 1.2) * V  # some beyond the range: the end bins take them
    ref = torch.nn.functional.kl_div(logits.log_softmax(-1), two_hot(x, -V, V, 32), reduction="none").sum(-1)
    got = two_hot_kl(logits, x, -V, V)
    torch.testing.assert_close(got, ref, rtol=1e-5, atol=1e-6)
    (g_ref,) = torch.autograd.grad(ref.sum(), logits)
    (g_got,) = torch.autograd.grad(got.sum(), logits)
    torch.testing.assert_close(g_got, g_ref, rtol=1e-5, atol=1e-6)
    one = torch.randn(4, 1)  # a single bin: the target is that bin, the divergence 0
    torch.testing.assert_close(two_hot_kl(one, torch.rand(4), 0.0, 1.0), torch.zeros(4))


@pytest.mark.parametrize("model", ["drawer", "laptop"])
def test_shipped_weights_load_and_the_batched_heads_equal_the_per_part_computation(model):
    """The state-dict layout is unchanged (the shipped weights load strictly) and their pair encoder gives the
    per-part computation's outputs on a real cloud (to float32 rounding: 2e-6 of the outputs' range, whose
    logits reach about 170)."""
    from ucope.model.checkpoint import find_model, load_model

    net, _ = load_model(find_model(model))
    net.eval()
    cat = net.cfg.category
    items = TrainingItems([make_sample(GenerateConfig(category=cat, split="test", num=1, views_per_instance=1), 0)], net.cfg)
    b = collate_items([items[0]])
    pair_idx = b["pair_idx"][:, :, :64]
    with torch.no_grad():
        enc = net.encode(b["points"], b["normals"], b["fps_idx"])
        got = net.pair_heads(enc, b["points"], b["normals"], pair_idx)
        want = _per_part_pair_outputs(net, enc, b["points"], b["normals"], pair_idx)
    for name in net.out_sizes:
        scale = float(want[name].abs().max())
        assert float((got[name] - want[name]).abs().max()) <= 2e-6 * scale + 1e-6, name
