import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import torch
from test_network import TINY_ENCODER

from ucope.cli.main import main
from ucope.errors import InputError
from ucope.model.checkpoint import load_model
from ucope.model.train import TrainConfig, TrainingError, parameter_digest, train

TINY = dict(encoder=TINY_ENCODER, num_points=256, pairs_per_part=32, hidden=32)


def tiny_train_config(out, **kw) -> TrainConfig:
    base = dict(
        category="laptop",
        out=str(out),
        on_the_fly=True,
        epoch_size=6,
        steps=7,
        batch_size=2,
        val_samples=2,
        model_overrides=dict(TINY),
        log_every=1,
        val_every=4,
        checkpoint_every=2,
        progress=False,
        threads=1,
    )
    base.update(kw)
    return TrainConfig(**base)


def _train_rows(run):
    rows = [json.loads(x) for x in (run / "metrics.jsonl").read_text().splitlines()]
    return {r["step"]: r["train/loss"] for r in rows if "train/loss" in r}


class _Crash(Exception):
    pass


def test_kill_and_resume_matches_an_uninterrupted_run(tmp_path):
    card = train(tiny_train_config(tmp_path / "ref"))
    assert card["steps"] == 7 and card["epochs"] == pytest.approx(7 / 3, abs=1e-3)  # crosses two epoch boundaries
    ref, _ = load_model(tmp_path / "ref")

    def crash(step):
        if step == 5:  # after the checkpoint at step 4, before the one at step 6: steps 5 is lost and redone
            raise _Crash()

    with pytest.raises(_Crash):
        train(tiny_train_config(tmp_path / "cut"), on_step=crash)
    assert json.loads((tmp_path / "cut" / "checkpoint.json").read_text())["state"]["step"] == 4
    with pytest.raises(TrainingError, match="--resume"):
        train(tiny_train_config(tmp_path / "cut"))
    train(tiny_train_config(tmp_path / "cut", resume=True))
    resumed, _ = load_model(tmp_path / "cut")
    assert parameter_digest(resumed) == parameter_digest(ref)
    assert _train_rows(tmp_path / "cut") == _train_rows(tmp_path / "ref")  # the same loss curve, step by step


def test_run_folder_holds_model_card_metrics_and_a_loadable_model(tmp_path):
    card = train(tiny_train_config(tmp_path, steps=4))
    on_disk = json.loads((tmp_path / "model_card.json").read_text())
    assert on_disk["category"] == "laptop" and on_disk["num_parts"] == 2
    assert on_disk["joints"] == [{"type": "revolute", "parent": 0, "child": 1}]
    assert on_disk["conventions_version"] and on_disk["generator_version"]
    assert on_disk["training_data"]["kind"] == "on-the-fly" and on_disk["steps"] == 4
    assert set(on_disk["final_validation"]) >= {"loss", "pose", "seg", "joint"}
    assert card["parameter_digests"] == on_disk["parameter_digests"]
    rows = [json.loads(x) for x in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert [r["step"] for r in rows if "val/loss" in r] == [4]
    assert all(r["samples_per_s"] > 0 for r in rows if "train/loss" in r)
    net, meta = load_model(tmp_path)
    assert meta["info"]["steps"] == 4 and net.cfg.num_points == 256


def test_learning_rate_steps_down_by_epoch(tmp_path):
    train(tiny_train_config(tmp_path, steps=7, lr=1e-3, lr_step_epochs=1, lr_gamma=0.5))
    rows = [json.loads(x) for x in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    lrs = {r["step"]: r["lr"] for r in rows if "lr" in r}
    # 3 steps per epoch; the lr logged at step s was used for step s (0-based step s - 1)
    assert lrs[1] == lrs[3] == pytest.approx(1e-3)
    assert lrs[4] == lrs[6] == pytest.approx(5e-4)
    assert lrs[7] == pytest.approx(2.5e-4)


def test_init_from_a_model_fine_tunes_its_weights(tmp_path):
    train(tiny_train_config(tmp_path / "base", steps=3))
    base, _ = load_model(tmp_path / "base")
    # one step at a negligible learning rate: the run starts from the base weights, not from random ones
    train(
        tiny_train_config(
            tmp_path / "tuned",
            steps=1,
            lr=1e-12,
            init_from=str(tmp_path / "base"),
            model_overrides=dict(TINY, lambda_seg=1.0, seg_weighting="points"),
        )
    )
    tuned, meta = load_model(tmp_path / "tuned")
    for (k, a), b in zip(base.state_dict().items(), tuned.state_dict().values(), strict=False):
        assert torch.allclose(a, b, atol=1e-6), k
    assert tuned.cfg.priors == base.cfg.priors  # the outputs stay relative to the base model's statistics
    assert tuned.cfg.lambda_seg == 1.0 and tuned.cfg.seg_weighting == "points"
    assert meta["info"]["initialised_from"] == {
        "model": str(tmp_path / "base"),
        "category": "laptop",
        "steps": 3,
        "train_time_s": json.loads((tmp_path / "base" / "model_card.json").read_text())["train_time_s"],
        "reinitialised": [],
    }
    with pytest.raises(InputError, match="cannot change"):
        train(tiny_train_config(tmp_path / "wide", init_from=str(tmp_path / "base"), model_overrides=dict(TINY, hidden=48)))
    with pytest.raises(InputError, match="'laptop' model cannot start a 'mug' run"):
        train(tiny_train_config(tmp_path / "mug", category="mug", init_from=str(tmp_path / "base")))


def test_bad_training_arguments_are_named(tmp_path):
    with pytest.raises(InputError, match="exactly one of steps and epochs"):
        train(tiny_train_config(tmp_path, epochs=1))
    with pytest.raises(InputError, match="--data DIR"):
        train(tiny_train_config(tmp_path, on_the_fly=False))
    with pytest.raises(InputError, match="unknown category|valid"):
        train(tiny_train_config(tmp_path, category="toaster"))
    with pytest.raises(TrainingError, match="no checkpoint"):
        train(tiny_train_config(tmp_path / "empty", resume=True))


def test_cli_train_errors_are_one_line(tmp_path, capsys):
    assert (
        main(["train", "--category", "laptop", "--data", str(tmp_path / "nope"), "--steps", "1", "--out", str(tmp_path / "r")])
        == 2
    )
    err = capsys.readouterr().err
    assert "ucope train: error:" in err and "does not exist" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("setting", "message"),
    [("p_noise", "write KEY=VALUE"), ("p_noise=often", "a number or LO,HI"), ("noise=0.5", "unknown augmentation setting")],
)
def test_cli_augment_settings_errors_are_one_line(tmp_path, capsys, setting, message):
    args = ["train", "--category", "laptop", "--on-the-fly", "--steps", "1", "--out", str(tmp_path / "r")]
    assert main([*args, "--augment", "0.5", "--augment-set", setting]) == 2
    err = capsys.readouterr().err
    assert "ucope train: error:" in err and message in err and "Traceback" not in err


def test_cli_train_on_a_data_set(tmp_path, capsys):
    assert (
        main(
            [
                "generate",
                "--category",
                "mug",
                "--num",
                "8",
                "--shard-size",
                "4",
                "--max-points",
                "1500",
                "--out",
                str(tmp_path / "d"),
                "--quiet",
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "train",
                "--category",
                "laptop",
                "--data",
                str(tmp_path / "d"),
                "--steps",
                "1",
                "--out",
                str(tmp_path / "r"),
                "--quiet",
            ]
        )
        == 2
    )
    assert "holds 'mug' samples" in capsys.readouterr().err
    assert (
        main(
            [
                "train",
                "--category",
                "mug",
                "--data",
                str(tmp_path / "d"),
                "--val-data",
                str(tmp_path / "d"),
                "--steps",
                "2",
                "--batch-size",
                "4",
                "--val-samples",
                "4",
                "--out",
                str(tmp_path / "r"),
                "--quiet",
                "--threads",
                "1",
            ]
        )
        == 0
    )
    card = json.loads((tmp_path / "r" / "model_card.json").read_text())
    assert card["steps"] == 2 and card["training_data"]["kind"] == "shards" and card["model_size"] == "slim"


def test_torchrun_ddp_two_processes_end_with_identical_parameters(tmp_path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [
        sys.executable,
        "-m",
        "torch.distributed.run",
        "--standalone",
        "--nproc_per_node=2",
        "-m",
        "ucope",
        "train",
        "--category",
        "mug",
        "--on-the-fly",
        "--epoch-size",
        "8",
        "--steps",
        "3",
        "--batch-size",
        "2",
        "--val-samples",
        "2",
        "--checkpoint-every",
        "2",
        "--out",
        str(tmp_path / "ddp"),
        "--quiet",
        "--device",
        "cpu",
    ]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    card = json.loads((tmp_path / "ddp" / "model_card.json").read_text())
    assert card["world_size"] == 2
    digests = card["parameter_digests"]
    assert len(digests) == 2 and digests[0] == digests[1]
    net, _ = load_model(tmp_path / "ddp")
    assert parameter_digest(net) == digests[0]
    assert card["epochs"] == pytest.approx(1.5)  # 8 samples / (2 per rank x 2 ranks) = 2 steps per epoch


def test_augmented_training_learns_a_background_class(tmp_path):
    """Corrupted items (floor, neighbour and outlier points labelled as the background class, noise,
    occlusion, fewer points) train without error; the model then segments K + 1 classes; resume is exact."""
    card = train(tiny_train_config(tmp_path / "aug", augment=1.0, steps=4, checkpoint_every=2))
    net, meta = load_model(tmp_path / "aug")
    assert net.cfg.background_class and net.num_classes == 3 and meta["config"]["background_class"]
    assert card["train_config"]["augment"] == 1.0
    out = net(
        torch.zeros(1, 256, 3).uniform_(-0.2, 0.2) + torch.tensor([0.0, 0.0, 0.8]),
        torch.nn.functional.normalize(torch.randn(1, 256, 3), dim=-1),
    )
    assert out["seg_logits"].shape == (1, 256, 3) and out["masks"].shape == (1, 256, 2)
    rows = [json.loads(x) for x in (tmp_path / "aug" / "metrics.jsonl").read_text().splitlines()]
    assert all(math.isfinite(r["train/loss"]) for r in rows if "train/loss" in r)


def test_augment_settings_are_checked_and_kept_in_the_model_card(tmp_path):
    with pytest.raises(InputError, match="need augmentation on"):
        tiny_train_config(tmp_path / "a", augment_settings={"p_noise": 0.5}).validate()
    with pytest.raises(InputError, match="unknown augmentation setting"):
        tiny_train_config(tmp_path / "a", augment=0.5, augment_settings={"noise": 0.5}).validate()
    card = train(tiny_train_config(tmp_path / "b", augment=1.0, steps=2, augment_settings={"noise_m": [0.002, 0.01]}))
    assert card["train_config"]["augment_settings"] == {"noise_m": [0.002, 0.01]}


def test_fine_tuning_adds_the_background_class_and_keeps_the_part_rows(tmp_path):
    train(tiny_train_config(tmp_path / "base", steps=2))
    base, _ = load_model(tmp_path / "base")
    card = train(tiny_train_config(tmp_path / "tuned", steps=2, init_from=str(tmp_path / "base"), augment=0.5, lr=1e-12))
    tuned, _ = load_model(tmp_path / "tuned")
    assert not base.cfg.background_class and tuned.cfg.background_class
    assert card["initialised_from"]["reinitialised"] == ["mask_head.2.weight", "mask_head.2.bias"]
    w0, w1 = base.state_dict()["mask_head.2.weight"], tuned.state_dict()["mask_head.2.weight"]
    assert w1.shape[0] == w0.shape[0] + 1 and torch.allclose(w1[:2], w0, atol=1e-6)  # the parts' rows kept (lr ~ 0)


def test_fine_tuning_with_new_priors_keeps_the_weights_and_measures_the_statistics_anew(tmp_path):
    train(tiny_train_config(tmp_path / "base", steps=2))
    base, _ = load_model(tmp_path / "base")
    train(
        tiny_train_config(tmp_path / "tuned", steps=1, lr=1e-12, init_from=str(tmp_path / "base"), new_priors=True, data_seed=7)
    )
    tuned, _ = load_model(tmp_path / "tuned")
    assert tuned.cfg.priors != base.cfg.priors and tuned.cfg.priors.num_samples > 0
    for (k, a), b in zip(base.state_dict().items(), tuned.state_dict().values(), strict=False):
        assert torch.allclose(a, b, atol=1e-6), k


def test_a_voting_model_starts_the_regression_baseline_with_its_encoder(tmp_path):
    """``--init MODEL --head regression``: the baseline gets the voting model's encoder, segmentation and
    joint heads (so the two heads are compared on one encoder and budget); only the pose heads start fresh."""
    train(tiny_train_config(tmp_path / "base", steps=2))
    base, _ = load_model(tmp_path / "base")
    card = train(
        tiny_train_config(
            tmp_path / "reg", steps=1, lr=1e-12, init_from=str(tmp_path / "base"), model_overrides=dict(TINY, head="regression")
        )
    )
    reg, _ = load_model(tmp_path / "reg")
    assert reg.cfg.head == "regression" and base.cfg.head == "voting"
    fresh = card["initialised_from"]["reinitialised"]
    assert fresh and all(k.startswith("reg_") for k in fresh)
    shared = {k: v for k, v in base.state_dict().items() if not k.startswith("pair_")}
    got = reg.state_dict()
    for k, v in shared.items():
        assert torch.allclose(got[k], v, atol=1e-6), k


def test_on_the_fly_training_stretches_its_stream_and_records_it(tmp_path):
    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.data.stream import GeneratedSamples

    # the stretched stream is exactly the stretched data set that `ucope generate --stretch` writes
    stream = GeneratedSamples("dishwasher", "train", 3, epoch_size=4, stretch=(0.5, 2.0), stretch_share=0.5)
    cfg = GenerateConfig(category="dishwasher", split="train", seed=3, num=4, stretch=(0.5, 2.0), stretch_share=0.5)
    for i in range(2):
        a, b = stream[i], make_sample(cfg, i)
        np.testing.assert_array_equal(a["points"], b["points"])
        np.testing.assert_array_equal(a["size_m"], b["size_m"])
    assert stream.meta["stretch"] == [0.5, 2.0] and stream.meta["stretch_share"] == 0.5
    with pytest.raises(InputError, match="not both"):
        GeneratedSamples("dishwasher", config=cfg, stretch=(0.5, 2.0))

    card = train(tiny_train_config(tmp_path / "run", steps=2, stretch=(0.7, 1.5), stretch_share=0.5))
    assert card["training_data"]["stretch"] == [0.7, 1.5] and card["training_data"]["stretch_share"] == 0.5
    assert json.loads((tmp_path / "run" / "model_card.json").read_text())["train_config"]["stretch"] == [0.7, 1.5]
    with pytest.raises(TrainingError, match="stretch"):  # resuming with another stretch trains another model
        train(tiny_train_config(tmp_path / "run", steps=3, stretch=(0.5, 2.0), resume=True))


def test_a_stretch_needs_generated_samples_and_a_valid_range(tmp_path, capsys):
    with pytest.raises(InputError, match="ucope generate --stretch"):
        train(tiny_train_config(tmp_path, on_the_fly=False, data=str(tmp_path), stretch=(0.5, 2.0)))
    with pytest.raises(InputError, match="stretch range must satisfy"):
        train(tiny_train_config(tmp_path, stretch=(1.2, 2.0)))
    with pytest.raises(InputError, match="a stretch share needs a stretch range"):
        train(tiny_train_config(tmp_path, stretch_share=0.5))
    args = ["train", "--category", "laptop", "--on-the-fly", "--steps", "1", "--out", str(tmp_path / "r")]
    assert main([*args, "--stretch", "0.5,2", "--stretch-share", "1.5"]) == 2
    err = capsys.readouterr().err
    assert "ucope train: error:" in err and "stretch share must be a fraction" in err and "Traceback" not in err
