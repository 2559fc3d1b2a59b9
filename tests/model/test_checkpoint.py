import json

import pytest
import torch
from test_network import tiny_batch, tiny_config

from ucope.errors import DataError
from ucope.model.checkpoint import load_checkpoint, load_model, save_checkpoint, save_model
from ucope.model.network import UCOPENet


@pytest.fixture(scope="module")
def laptop_net():
    torch.manual_seed(3)
    return UCOPENet(tiny_config("laptop"))


def _outputs(net, cfg):
    b = tiny_batch(cfg, n=2)
    with torch.no_grad():
        return net.eval()(b["points"], b["normals"], b["pair_idx"], b["fps_idx"])


def test_model_round_trip_gives_identical_outputs(laptop_net, tmp_path):
    path = save_model(laptop_net, tmp_path / "run", info={"note": "x"})
    assert path == tmp_path / "run" / "model.json"
    net, meta = load_model(tmp_path / "run")
    assert meta["info"] == {"note": "x"} and meta["config"] == laptop_net.cfg.to_dict()
    a, b = _outputs(laptop_net, laptop_net.cfg), _outputs(net, net.cfg)
    for k in a:
        torch.testing.assert_close(a[k], b[k], rtol=0, atol=0)
    # the same model is found from its .json and its .safetensors path
    load_model(tmp_path / "run" / "model.json")
    load_model(tmp_path / "run" / "model.safetensors")


def test_half_precision_storage_is_half_the_size_and_close(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path / "f32")
    save_model(laptop_net, tmp_path / "f16", dtype="float16")
    s32 = (tmp_path / "f32" / "model.safetensors").stat().st_size
    s16 = (tmp_path / "f16" / "model.safetensors").stat().st_size
    assert s16 < 0.55 * s32
    net16, meta = load_model(tmp_path / "f16")
    assert meta["weights"]["dtype"] == "float16"
    assert all(p.dtype == torch.float32 for p in net16.parameters())
    a, b = _outputs(laptop_net, laptop_net.cfg), _outputs(net16, net16.cfg)
    torch.testing.assert_close(a["mu_logits"], b["mu_logits"], rtol=0, atol=2e-2)


def test_tampered_weights_are_refused(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path)
    w = tmp_path / "model.safetensors"
    data = bytearray(w.read_bytes())
    data[-100] ^= 0xFF  # one flipped byte inside a tensor: still a valid safetensors file
    w.write_bytes(bytes(data))
    with pytest.raises(DataError, match="SHA-256.*modified"):
        load_model(tmp_path)


def test_truncated_weights_are_refused(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path)
    w = tmp_path / "model.safetensors"
    w.write_bytes(w.read_bytes()[: w.stat().st_size // 2])
    with pytest.raises(DataError, match="truncated"):
        load_model(tmp_path)


def test_truncated_or_foreign_json_is_refused(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path)
    j = tmp_path / "model.json"
    text = j.read_text()
    j.write_text(text[: len(text) // 2])
    with pytest.raises(DataError, match="not valid JSON"):
        load_model(tmp_path)
    j.write_text(json.dumps({"hello": 1}))
    with pytest.raises(DataError, match="not a model this ucope"):
        load_model(tmp_path)


def test_models_of_another_format_or_conventions_version_are_refused_naming_both(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path)
    j = tmp_path / "model.json"
    meta = json.loads(j.read_text())
    j.write_text(json.dumps({**meta, "format": "ucope-model/1"}))
    with pytest.raises(DataError, match="'ucope-model/1', expected 'ucope-model/2'"):
        load_model(tmp_path)
    j.write_text(json.dumps({**meta, "conventions_version": "0"}))
    with pytest.raises(DataError, match="conventions version 0, this ucope uses version 1"):
        load_model(tmp_path)


def test_missing_model_gives_clear_errors(laptop_net, tmp_path):
    with pytest.raises(DataError, match="holds no model.json"):
        load_model(tmp_path)
    with pytest.raises(DataError, match="does not exist"):
        load_model(tmp_path / "nope.json")
    save_model(laptop_net, tmp_path)
    (tmp_path / "model.safetensors").unlink()
    with pytest.raises(DataError, match="does not exist"):
        load_model(tmp_path)


def test_weights_of_another_config_are_refused(laptop_net, tmp_path):
    save_model(laptop_net, tmp_path)
    meta = json.loads((tmp_path / "model.json").read_text())
    meta["config"]["hidden"] = 48  # same file, different architecture
    (tmp_path / "model.json").write_text(json.dumps(meta))
    with pytest.raises(DataError, match="shape|fit"):
        load_model(tmp_path)


def test_checkpoint_round_trip_restores_optimizer(laptop_net, tmp_path):
    cfg = laptop_net.cfg
    torch.manual_seed(0)
    net = UCOPENet(cfg)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    loss, _ = net.compute_loss(tiny_batch(cfg, n=2))
    loss.backward()
    opt.step()
    save_checkpoint(tmp_path, net, opt, {"step": 1, "epoch": 0})
    net2 = UCOPENet(cfg)
    opt2 = torch.optim.Adam(net2.parameters(), lr=1e-3)
    meta = load_checkpoint(tmp_path, net2, opt2)
    assert meta["state"]["step"] == 1
    for p, q in zip(net.parameters(), net2.parameters(), strict=False):
        torch.testing.assert_close(p, q, rtol=0, atol=0)
    s1, s2 = opt.state_dict(), opt2.state_dict()
    for pid in s1["state"]:
        for k, v in s1["state"][pid].items():
            torch.testing.assert_close(torch.as_tensor(v), torch.as_tensor(s2["state"][pid][k]), rtol=0, atol=0)
    # a newer checkpoint replaces the older weights file
    save_checkpoint(tmp_path, net, opt, {"step": 2, "epoch": 0})
    assert sorted(p.name for p in tmp_path.glob("checkpoint-*.safetensors")) == ["checkpoint-00000002.safetensors"]
    ck = tmp_path / "checkpoint-00000002.safetensors"
    ck.write_bytes(ck.read_bytes()[:-10])
    with pytest.raises(DataError, match="truncated"):
        load_checkpoint(tmp_path, net2, opt2)
