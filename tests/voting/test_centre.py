import math

import numpy as np
import pytest
import torch
from voting_support import random_part, synthetic_heads

from ucope.errors import InputError
from ucope.voting import CentreOptions, vote_centre
from ucope.voting.bins import decode_bins
from ucope.voting.centre import circle_candidates, grid_peak, pair_frames


@pytest.mark.parametrize("outliers", [0.0, 0.2])
def test_centre_from_exact_votes_within_a_small_fraction_of_a_cell(rng, outliers):
    for _ in range(4):
        T, size = random_part(rng)
        a, b, _, h, V = synthetic_heads(rng, T, size, size, 3000, outlier_frac=outliers)
        mu = decode_bins(h["mu_logits"], -V, V)
        nu = decode_bins(h["nu_logits"], 0.0, V)
        c, inl = vote_centre(a, b, mu, nu, vote_range_m=V)
        cell = V / 20
        err = float(np.linalg.norm(c.numpy() - T[:3, 3]))
        assert err < 0.05 * cell and err < 1e-3  # measured: ~1e-6 m
        frac = float(inl.float().mean())
        assert 0.95 * (1 - outliers) < frac < 1 - outliers + 0.1
        # Without refinement: the peak cell centre, within a cell.
        c0, _ = vote_centre(a, b, mu, nu, vote_range_m=V, options=CentreOptions(refine_iters=0))
        assert np.linalg.norm(c0.numpy() - T[:3, 3]) < 1.5 * cell


def _slow_grid_peak(cand, w, cell, max_cells):
    """Plain reference: per-axis percentiles, then a Python dict of cell votes."""
    pts = cand.permute(1, 2, 0).reshape(-1, 3).numpy().astype(np.float64)
    ws = w.reshape(-1).numpy()
    n = len(pts)
    srt = np.sort(pts, axis=0)
    lo = srt[max(0, int(0.01 * n) - 1)] - 2 * cell
    hi = srt[min(n, math.ceil(0.99 * n)) - 1] + 2 * cell
    cell = max(cell, float((hi - lo).max()) / max_cells)
    dims = np.clip(np.ceil((hi - lo) / cell), 1, max_cells).astype(int)
    votes = {}
    for p, wi in zip(pts, ws, strict=False):
        ijk = tuple(int(v) for v in np.floor((p - lo) / cell))
        if all(0 <= ijk[i] < dims[i] for i in range(3)):
            votes[ijk] = votes.get(ijk, 0.0) + wi
    best = max(sorted(votes), key=lambda k: votes[k])
    return lo + (np.array(best) + 0.5) * cell, votes[best]


def test_vectorised_grid_vote_matches_a_slow_reference(rng):
    M, Tn = 40, 12
    a = torch.tensor(rng.normal(size=(M, 3)), dtype=torch.float32)
    b = torch.tensor(rng.normal(size=(M, 3)), dtype=torch.float32)
    c_true = torch.tensor([0.1, -0.2, 0.3])
    e = (a - b) / (a - b).norm(dim=-1, keepdim=True)
    mu = ((a - c_true) * e).sum(-1)
    nu = ((a - c_true) - mu[:, None] * e).norm(dim=-1)
    ef, f, p, q, _ = pair_frames(a.T.contiguous(), b.T.contiguous(), mu)
    cand = circle_candidates(f, p, q, nu, Tn)
    # Every candidate lies on its circle.
    d = cand - f.unsqueeze(-1)
    torch.testing.assert_close((d * ef.unsqueeze(-1)).sum(0), torch.zeros(M, Tn), atol=1e-5, rtol=0)
    torch.testing.assert_close(d.norm(dim=0), nu[:, None].expand(M, Tn), atol=1e-5, rtol=0)
    w = torch.rand(M, Tn, generator=torch.Generator().manual_seed(0))
    for cell in (0.05, 0.2):
        fast = grid_peak(cand, w, cell, 64).numpy()
        slow, _ = _slow_grid_peak(cand, w, cell, 64)
        np.testing.assert_allclose(fast, slow, atol=1e-5)


def test_centre_errors():
    a = torch.zeros(5, 3)
    with pytest.raises(InputError):
        vote_centre(a, a, torch.zeros(5), torch.zeros(5), vote_range_m=1.0)  # a == b: no direction
    with pytest.raises(InputError):
        vote_centre(torch.zeros(5, 2), a, torch.zeros(5), torch.zeros(5))
    with pytest.raises(InputError):
        vote_centre(a, a + 1, torch.full((5,), float("nan")), torch.zeros(5))
    with pytest.raises(InputError):
        vote_centre(a, a + 1, torch.zeros(5), torch.zeros(5), weights=-torch.ones(5))
    with pytest.raises(InputError):
        vote_centre(torch.zeros(0, 3), torch.zeros(0, 3), torch.zeros(0), torch.zeros(0))
