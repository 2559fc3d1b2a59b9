import math

import pytest
import torch

from ucope.errors import InputError
from ucope.model.targets import bin_centres, two_hot
from ucope.voting import decode_bins


def test_two_hot_targets_decode_to_their_values():
    g = torch.Generator().manual_seed(0)
    n, lo, hi = 32, -0.3, 0.3
    c = bin_centres(lo, hi, n, dtype=torch.float64)
    x = c[0] + torch.rand(1000, generator=g, dtype=torch.float64) * (c[-1] - c[0])  # inside the centres' span
    logits = torch.log(two_hot(x, lo, hi, n) + 1e-12)
    torch.testing.assert_close(decode_bins(logits.float(), lo, hi).double(), x, atol=1e-5, rtol=0)
    # Beyond the first / last centre: clipped to that centre.
    ends = decode_bins(torch.log(two_hot(torch.tensor([-1.0, 1.0]), lo, hi, n) + 1e-12), lo, hi)
    torch.testing.assert_close(ends, c[[0, -1]].float())


def test_window_zero_is_the_argmax_centre_and_decoding_is_deterministic():
    logits = torch.randn(7, 5, 36)
    a = decode_bins(logits, 0.0, math.pi, window=0)
    torch.testing.assert_close(a, bin_centres(0.0, math.pi, 36)[logits.argmax(-1)])
    torch.testing.assert_close(decode_bins(logits, 0.0, math.pi), decode_bins(logits, 0.0, math.pi), rtol=0, atol=0)


def test_window_expectation_matches_a_plain_reference():
    logits = torch.randn(50, 12, dtype=torch.float64)
    out = decode_bins(logits, -1.0, 2.0, window=2)
    c = bin_centres(-1.0, 2.0, 12, dtype=torch.float64)
    for i in range(50):  # plain loop reference
        k = int(logits[i].argmax())
        js = [j for j in range(k - 2, k + 3) if 0 <= j < 12]
        p = torch.softmax(logits[i, js], 0)
        assert abs(float((p * c[js]).sum()) - float(out[i])) < 1e-6


def test_per_part_ranges_broadcast():
    V = torch.tensor([0.1, 0.5, 1.0])
    x = torch.stack([torch.full((4,), 0.3) * v for v in V])  # (K=3, M=4)
    logits = torch.log(two_hot(x, -V[:, None], V[:, None], 32) + 1e-12)
    torch.testing.assert_close(decode_bins(logits, -V[:, None], V[:, None]), x, atol=1e-5, rtol=0)


def test_bad_inputs():
    with pytest.raises(InputError):
        decode_bins(torch.tensor([[0.0, float("nan"), 1.0]]), 0.0, 1.0)
    with pytest.raises(InputError):
        decode_bins(torch.zeros(3, 4), torch.zeros(2), torch.ones(2))
    with pytest.raises(InputError):
        decode_bins(torch.zeros(3, 4), 0.0, 1.0, window=-1)
