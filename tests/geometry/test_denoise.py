"""ucope.geometry.denoise against plain per-point references and known surfaces."""

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.denoise import smooth_points, surface_noise


def plane(rng, n=3000, sigma=0.0):
    p = np.stack([rng.uniform(-0.1, 0.1, n), rng.uniform(-0.1, 0.1, n), np.zeros(n)], axis=1)
    return p + np.array([0, 0, 1.0]) * rng.normal(scale=sigma, size=(n, 1)) if sigma else p


def reference_smooth(points, k, iterations):
    """One point at a time: neighbours by sorting distances, the plane by numpy's eigh."""
    pts = np.asarray(points, np.float64)
    for _ in range(iterations):
        new = pts.copy()
        for i, p in enumerate(pts):
            nb = pts[np.argsort(np.linalg.norm(pts - p, axis=1), kind="stable")[:k]]
            c = nb.mean(0)
            n = np.linalg.eigh((nb - c).T @ (nb - c))[1][:, 0]
            new[i] = p - ((p - c) @ n) * n
        pts = new
    return pts


def reference_noise(points, k):
    pts = np.asarray(points, np.float64)
    rms = []
    for p in pts:
        nb = pts[np.argsort(np.linalg.norm(pts - p, axis=1), kind="stable")[:k]]
        c = nb.mean(0)
        n = np.linalg.eigh((nb - c).T @ (nb - c))[1][:, 0]
        rms.append(np.sqrt(np.mean(((nb - c) @ n) ** 2)))
    return float(np.median(rms))


def test_smoothing_matches_the_per_point_reference():
    rng = np.random.default_rng(0)
    pts = plane(rng, n=300, sigma=0.002)
    np.testing.assert_allclose(smooth_points(pts, k=16, iterations=2), reference_smooth(pts, 16, 2), atol=1e-9)


def test_noise_measure_matches_the_per_point_reference():
    rng = np.random.default_rng(1)
    pts = plane(rng, n=300, sigma=0.003)
    assert surface_noise(pts, k=16, max_points=300) == pytest.approx(reference_noise(pts, 16), rel=1e-9)


def test_noise_measure_grows_with_the_noise_and_is_near_zero_on_a_clean_surface():
    rng = np.random.default_rng(2)
    levels = [surface_noise(plane(rng, sigma=s)) for s in (0.0, 0.001, 0.002, 0.005)]
    assert levels[0] < 1e-9
    assert levels[1] < levels[2] < levels[3]
    assert 0.3 * 0.005 < levels[3] < 0.005


def test_smoothing_takes_noise_off_a_surface_and_keeps_its_shape_and_order():
    rng = np.random.default_rng(3)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[d[:, 2] < 0]  # the half of a 5 cm sphere facing a camera at the origin
    clean = 0.05 * d + [0, 0, 0.6]
    noisy = clean + rng.normal(scale=0.003, size=clean.shape)
    out = smooth_points(noisy, k=32, iterations=2)
    radial = lambda p: np.linalg.norm(p - [0, 0, 0.6], axis=1) - 0.05  # noqa: E731
    assert np.sqrt(np.mean(radial(out) ** 2)) < 0.4 * np.sqrt(np.mean(radial(noisy) ** 2))
    assert abs(np.mean(radial(out))) < 0.001  # hardly any shrinking
    assert np.median(np.linalg.norm(out - clean, axis=1)) < np.median(np.linalg.norm(noisy - clean, axis=1))
    assert out.shape == noisy.shape


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: smooth_points(np.zeros((10, 2))), "shape"),
        (lambda: smooth_points(np.zeros((3, 3))), "at least 4"),
        (lambda: smooth_points(np.full((10, 3), np.nan)), "NaN"),
        (lambda: smooth_points(np.zeros((10, 3)), k=2), "k >= 4"),
        (lambda: smooth_points(np.zeros((10, 3)), iterations=0), "iterations"),
        (lambda: surface_noise(np.zeros((2, 3))), "at least 4"),
    ],
)
def test_bad_input_is_named(call, match):
    with pytest.raises(InputError, match=match):
        call()
