"""The direct-regression baseline: same encoder, masks and joint heads as U-COPE, poses regressed."""

import math

import pytest
import torch
from test_network import overfit, tiny_batch, tiny_config

from ucope.errors import InputError
from ucope.model.checkpoint import load_model, save_model
from ucope.model.factory import build_model
from ucope.model.network import UCOPENet
from ucope.model.regression import RegressionNet, rotation_from_6d


def test_rotation_from_6d_is_a_rotation_and_keeps_the_first_column():
    g = torch.Generator().manual_seed(0)
    x = torch.randn(50, 6, generator=g)
    R = rotation_from_6d(x)
    torch.testing.assert_close(R.transpose(-1, -2) @ R, torch.eye(3).expand(50, 3, 3), atol=1e-5, rtol=0)
    torch.testing.assert_close(torch.linalg.det(R), torch.ones(50), atol=1e-5, rtol=0)
    torch.testing.assert_close(R[..., 0], x[:, :3] / x[:, :3].norm(dim=-1, keepdim=True))
    # A rotation's own first two columns give it back.
    Rg = rotation_from_6d(torch.randn(5, 6, generator=g))
    torch.testing.assert_close(rotation_from_6d(torch.cat([Rg[..., 0], Rg[..., 1]], -1)), Rg, atol=1e-6, rtol=0)


@pytest.mark.parametrize("category, K", [("mug", 1), ("laptop", 2), ("drawer", 4)])
def test_shapes_and_shared_parts_with_ucope(category, K):
    torch.manual_seed(0)
    cfg = tiny_config(category, head="regression")
    net = build_model(cfg)
    assert isinstance(net, RegressionNet)
    b = tiny_batch(cfg, n=3)
    out = net(b["points"], b["normals"], b["pair_idx"], b["fps_idx"])
    assert out["rotation"].shape == (3, K, 3, 3)
    assert out["centre_m"].shape == out["gamma"].shape == (3, K, 3)
    assert "mu_logits" not in out
    # Everything but the pose branch has the same parameters as U-COPE's network.
    ours = {k: v.shape for k, v in UCOPENet(tiny_config(category)).state_dict().items() if not k.startswith("pair_")}
    base = {k: v.shape for k, v in net.state_dict().items() if not k.startswith("reg_")}
    assert ours == base


@pytest.mark.parametrize("category", ["bottle", "laptop"])
def test_gradients_reach_every_parameter_and_the_loss_falls(category):
    torch.manual_seed(0)
    cfg = tiny_config(category, head="regression")
    net = build_model(cfg)
    b = tiny_batch(cfg, n=4)
    loss, logs = net.compute_loss(b)
    loss.backward()
    for name, p in net.named_parameters():
        assert p.grad is not None and p.grad.abs().sum() > 0, name
    assert {"rot", "trans", "gamma", "rot_err_deg", "trans_err_m"} <= set(logs)
    first, logs = overfit(net, b, 150)
    assert logs["loss"] < 0.5 * first["loss"], (first["loss"], logs["loss"])
    assert logs["rot_err_deg"] < first["rot_err_deg"]


def test_symmetric_part_loss_ignores_rotation_about_y():
    torch.manual_seed(0)
    cfg = tiny_config("bottle", head="regression")
    net = build_model(cfg)
    b = tiny_batch(cfg, n=2)
    out = net(b["points"], b["normals"])
    T = b["cam_from_part"].clone()
    c, s = math.cos(1.0), math.sin(1.0)
    about_y = torch.tensor([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    out_a = dict(out, rotation=T[..., :3, :3].clone())
    out_b = dict(out, rotation=T[..., :3, :3] @ about_y)
    la = net._pose_loss(out_a, b, {})
    lb = net._pose_loss(out_b, b, {})
    torch.testing.assert_close(la, lb)


def test_save_load_round_trip(tmp_path):
    torch.manual_seed(0)
    cfg = tiny_config("laptop", head="regression")
    net = build_model(cfg).eval()
    save_model(net, tmp_path)
    back, meta = load_model(tmp_path)
    assert isinstance(back, RegressionNet) and meta["config"]["head"] == "regression"
    b = tiny_batch(cfg, n=2)
    with torch.no_grad():
        torch.testing.assert_close(back(b["points"], b["normals"])["rotation"], net(b["points"], b["normals"])["rotation"])


def test_unknown_head_is_refused():
    with pytest.raises(InputError, match="head"):
        tiny_config("laptop", head="mlp")
