"""benchmarks/bench_batching.py: a batch of a view's hypotheses gives each hypothesis the network outputs it gets alone."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_batching import hypotheses, network, stack  # noqa: E402

from ucope.data.generate import GenerateConfig, make_sample  # noqa: E402
from ucope.estimation import Estimator  # noqa: E402


def test_a_stacked_batch_matches_its_hypotheses_one_at_a_time():
    est = Estimator.load("scissors")  # two parts and a joint: every head the benchmark times
    gen = GenerateConfig(category=est.category, split="test", seed=2027, num=1, views_per_instance=1)
    hyps = hypotheses(est, make_sample(gen, 0)["points"].astype(np.float32), 3)
    assert len({h[0].numpy().tobytes() for h in hyps}) == 3  # three different draws of the cloud
    with torch.no_grad():
        alone = [network(est, *h) for h in hyps]
        batch = network(est, *stack(hyps))
    keys = ("masks", "joint_heat", "mu_logits", "nu_logits", "gamma", "part_score")
    for b, one in enumerate(alone):
        for key in keys:
            assert batch[key].shape[1:] == one[key].shape[1:], key
            torch.testing.assert_close(batch[key][b], one[key][0], atol=2e-4, rtol=1e-4, msg=key)
