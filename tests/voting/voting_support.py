"""Exact synthetic network outputs for the voting tests: ground-truth parameters as peaked logits."""

from __future__ import annotations

import math

import numpy as np
import torch

from ucope.geometry.transforms import make_transform, random_rotation
from ucope.model.targets import pair_vote_targets, two_hot


def peaked_logits(x: torch.Tensor, lo, hi, n: int, eps: float = 1e-4) -> torch.Tensor:
    """``log(two_hot + eps)``: the softmax is the two-hot target (up to eps)."""
    return torch.log(two_hot(x, lo, hi, n) + eps)


def random_part(rng, sym: bool = False):
    """A random part pose (camera frame, ~1 m away) and size (0.04-0.4 m)."""
    R = random_rotation(rng)
    t = rng.normal(size=3) * 0.2 + np.array([0.0, 0.0, 1.0])
    size = rng.uniform(0.04, 0.4, 3)
    if sym:
        size[2] = size[0]
    return make_transform(R, t), size


def box_surface_points(rng, T, size, n):
    """``n`` points on the faces of the box ``(T, size)``."""
    p = rng.uniform(-0.5, 0.5, (n, 3)) * size
    face = rng.integers(0, 3, n)
    sign = rng.choice([-0.5, 0.5], n)
    p[np.arange(n), face] = sign * size[face]
    return p @ T[:3, :3].T + T[:3, 3]


def synthetic_heads(rng, T, size, mean_size, M, outlier_frac=0.0, bins=(32, 32, 36), V=None, points=None, noise=(0.0, 0.0)):
    """Pairs on the box and exact heads for them (float32 torch), with a fraction of outlier pairs
    whose parameters (and sign bits) are random, and Gaussian noise ``noise = (sigma_m, sigma_rad)`` on
    every inlier's ``mu, nu`` (metres) and ``alpha, beta`` (radians), like a network's errors.

    Returns ``(a, b, n_a, heads, V)``; ``heads`` holds the 7 per-pair outputs of one part.
    """
    mu_bins, nu_bins, angle_bins = bins
    V = 1.1 * 0.5 * float(np.linalg.norm(size)) if V is None else V
    pts = box_surface_points(rng, T, size, 2 * M) if points is None else points
    a = torch.tensor(pts[:M], dtype=torch.float32)
    b = torch.tensor(pts[M : 2 * M], dtype=torch.float32)
    n = torch.nn.functional.normalize(torch.tensor(rng.normal(size=(M, 3)), dtype=torch.float32), dim=-1)
    t = pair_vote_targets(
        a,
        b,
        n,
        torch.tensor(T, dtype=torch.float32),
        torch.tensor(size, dtype=torch.float32),
        torch.tensor(mean_size, dtype=torch.float32),
    )
    out = torch.from_numpy(rng.random(M) < outlier_frac)
    if noise[0] > 0 or noise[1] > 0:
        for k, sd in (("mu", noise[0]), ("nu", noise[0]), ("alpha", noise[1]), ("beta", noise[1])):
            t[k] = t[k] + torch.tensor(rng.normal(0.0, sd, M), dtype=torch.float32)
        t["nu"] = t["nu"].clamp(0.0, V)
        t["alpha"], t["beta"] = t["alpha"].clamp(0.0, math.pi), t["beta"].clamp(0.0, math.pi)
    ranges = {"mu": (-V, V), "nu": (0.0, V), "alpha": (0.0, math.pi), "beta": (0.0, math.pi)}
    for k, (lo, hi) in ranges.items():
        t[k] = torch.where(out, torch.tensor(rng.uniform(lo, hi, M), dtype=torch.float32), t[k])
    sign = torch.where(out.unsqueeze(-1), torch.tensor(rng.random((M, 2)) < 0.5, dtype=torch.float32), t["sign"])
    heads = dict(
        mu_logits=peaked_logits(t["mu"], -V, V, mu_bins),
        nu_logits=peaked_logits(t["nu"], 0.0, V, nu_bins),
        alpha_logits=peaked_logits(t["alpha"], 0.0, math.pi, angle_bins),
        beta_logits=peaked_logits(t["beta"], 0.0, math.pi, angle_bins),
        sign_logits=(sign * 2.0 - 1.0) * 4.0,
        gamma=t["gamma"].expand(M, 3).clone(),
        part_score=torch.full((M,), 4.0),
    )
    return a, b, n, heads, V


def angle_deg(u, v) -> float:
    u, v = np.asarray(u, float), np.asarray(v, float)
    return float(np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1.0, 1.0))))
