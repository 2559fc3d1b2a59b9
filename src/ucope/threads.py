"""Thread pools of the libraries ucope calls: one BLAS thread while a prediction runs.

numpy and scipy each load an OpenBLAS whose worker threads, once a large enough product or solve has woken them,
keep spinning on the CPU for a while after it returns; the network's torch threads then share the cores with
them. The small products of ucope's geometry and voting gain nothing from several BLAS threads, so
:func:`one_blas_thread` holds every loaded BLAS at one thread while it is open (``threadpoolctl``) and gives the
caller's settings back when it closes. torch's own threads (``torch.set_num_threads``) are left as they are.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterator

__all__ = ["one_blas_thread"]


@functools.lru_cache(maxsize=1)
def _controller():
    """The thread pools of the libraries loaded when first asked; numpy's and scipy's BLAS are loaded first, so
    that both are among them whatever the caller had imported."""
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """numpy's and scipy's BLAS (and any other loaded before the first call) at one thread inside the block, as
    they were after it (re-entrant)."""
    with _controller().limit(limits=1, user_api="blas"):
        yield
