"""Decoding of binned network outputs into values (the inverse of :func:`ucope.model.targets.two_hot`)."""

from __future__ import annotations

import torch

from ..errors import InputError
from .arrays import as_tensor, check_finite

__all__ = ["decode_bins"]


def decode_bins(logits: torch.Tensor, lo, hi, window: int = 1) -> torch.Tensor:
    """Repeatable decoding of binned logits: the expectation over the bins around the argmax.

    Bin ``i`` of ``n`` has centre ``lo + (i + 0.5) (hi - lo) / n`` (:func:`ucope.model.targets.bin_centres`).
    The value is ``sum_j p_j centre_j`` over the ``2 window + 1`` bins ``j`` within ``window`` of the
    argmax, with ``p`` the softmax of the logits renormalised over those bins. There is no random
    sampling (CPPF draws a bin from a multinomial at test time), so the result is deterministic. A
    two-hot target (:func:`ucope.model.targets.two_hot`) decodes back to its value exactly, since its
    two non-zero bins are adjacent; a value beyond the first / last bin centre decodes to that centre.

    Args:
        logits: ``(..., n)`` unnormalised log-probabilities of ``n`` bins.
        lo, hi: the binned interval, scalars or tensors broadcastable against ``logits.shape[:-1]``
            (e.g. ``(K, 1)`` per-part vote ranges for ``(K, M, n)`` logits). Units of the result.
        window: half width of the window (``0``: the argmax bin centre).

    Returns:
        ``(...)`` decoded values, same dtype and device as ``logits``.
    """
    logits = as_tensor(logits, "logits")
    if logits.ndim < 1 or logits.shape[-1] < 1:
        raise InputError(f"logits must have a trailing bin dimension, got shape {tuple(logits.shape)}")
    window = int(window)
    if window < 0:
        raise InputError(f"window must be >= 0, got {window}")
    n = logits.shape[-1]
    lo = torch.as_tensor(lo, dtype=logits.dtype, device=logits.device)
    hi = torch.as_tensor(hi, dtype=logits.dtype, device=logits.device)
    idx = logits.argmax(-1, keepdim=True)
    j = idx + torch.arange(-window, window + 1, device=logits.device)
    g = logits.gather(-1, j.clamp(0, n - 1))
    # The argmax (column `window`) is the window's maximum: subtract it instead of a max-reduction.
    p = torch.exp(g - g[..., window : window + 1])
    p = torch.where((j >= 0) & (j < n), p, 0.0)
    pos = idx.squeeze(-1).to(logits.dtype) + (
        p * torch.arange(-window, window + 1, device=logits.device, dtype=logits.dtype)
    ).sum(-1) / p.sum(-1)
    try:
        out = lo + (pos + 0.5) * ((hi - lo) / n)
    except RuntimeError as e:
        raise InputError(f"lo / hi do not broadcast against logits.shape[:-1] = {tuple(logits.shape[:-1])}: {e}") from None
    # NaN / inf logits propagate to the values (argmax picks a NaN; exp(inf - inf) is NaN): check once,
    # on the small output rather than on every logit.
    return check_finite(out, "decoded values (the logits hold NaN or inf)")
