"""ucope.threads: one BLAS thread while a prediction runs, the caller's settings back afterwards."""

from __future__ import annotations

import numpy as np
import scipy.linalg  # noqa: F401  (its BLAS loaded before the counts below, as in any ucope process)
from threadpoolctl import threadpool_info, threadpool_limits

from ucope.threads import one_blas_thread


def _blas_threads() -> list[int]:
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]


def test_every_blas_is_held_at_one_thread_inside_and_given_back_after():
    assert _blas_threads(), "numpy's BLAS is loaded: ucope imports numpy and scipy"
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        with one_blas_thread():
            assert _blas_threads() == [1] * len(before)
            with one_blas_thread():  # re-entrant
                assert _blas_threads() == [1] * len(before)
            assert _blas_threads() == [1] * len(before)
        assert _blas_threads() == before


def test_predict_runs_with_one_blas_thread(monkeypatch):
    """The estimator's BLAS calls see one thread; the caller's thread count is back once predict returns."""
    import ucope.estimation.estimator as estimator_module
    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.estimation import FAST, Estimator

    seen = []
    real = estimator_module.estimate_normals

    def spy(*args, **kwargs):
        seen.append(_blas_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(estimator_module, "estimate_normals", spy)
    s = make_sample(GenerateConfig(category="bottle", split="test", seed=3, num=1, views_per_instance=1), 0)
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        r = Estimator.load("bottle", overrides=FAST).predict(s["points"])
        assert _blas_threads() == before
    assert seen and all(t == [1] * len(before) for t in seen)
    assert np.isfinite(r.parts[0].cam_from_part).all()
