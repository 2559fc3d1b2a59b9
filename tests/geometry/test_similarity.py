import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.similarity import robust_umeyama, umeyama
from ucope.geometry.transforms import random_rotation


def test_umeyama_recovers_a_similarity(rng):
    R = random_rotation(rng)
    src = rng.uniform(-0.5, 0.5, (200, 3))
    dst = 0.37 * src @ R.T + [0.1, -0.2, 1.3]
    s, R2, t = umeyama(src, dst)
    assert s == pytest.approx(0.37, rel=1e-9)
    np.testing.assert_allclose(R2, R, atol=1e-9)
    np.testing.assert_allclose(t, [0.1, -0.2, 1.3], atol=1e-9)
    assert np.linalg.det(R2) == pytest.approx(1.0)


def test_robust_umeyama_ignores_outliers(rng):
    R = random_rotation(rng)
    src = rng.uniform(-0.5, 0.5, (300, 3))
    dst = 0.2 * src @ R.T + [0.0, 0.0, 1.0] + rng.normal(0, 1e-4, (300, 3))
    dst[:20] += rng.uniform(0.2, 0.5, (20, 3))  # mask bleeding onto the background
    s, R2, t, inl = robust_umeyama(src, dst)
    assert s == pytest.approx(0.2, rel=1e-3) and np.abs(R2 - R).max() < 2e-3
    assert not inl[:20].any() and inl[20:].mean() > 0.95


def test_degenerate_or_mismatched_points_raise():
    line = np.outer(np.linspace(0, 1, 10), [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="degenerate"):
        umeyama(line, line)
    with pytest.raises(InputError, match="at least 3"):
        umeyama(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        umeyama(np.zeros((5, 3)), np.zeros((4, 3)))
