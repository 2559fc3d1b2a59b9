"""Input checks shared by the voting ops (shapes, finiteness), raising :class:`ucope.errors.InputError`."""

from __future__ import annotations

import numpy as np
import torch

from ..errors import InputError


def as_tensor(x, name: str, dtype: torch.dtype | None = torch.float32, device=None) -> torch.Tensor:
    """``x`` as a torch tensor (numpy arrays and sequences are converted; tensors keep their device).

    Floating inputs are cast to ``dtype`` (float32 by default: the voting ops run in float32).
    """
    if isinstance(x, torch.Tensor):
        t = x.detach()
    else:
        try:
            t = torch.as_tensor(np.asarray(x))
        except (TypeError, ValueError) as e:
            raise InputError(f"{name}: cannot convert to an array ({e})") from None
    if device is not None:
        t = t.to(device)
    if dtype is not None and t.dtype != dtype:
        t = t.to(dtype)
    return t


def check_shape(t: torch.Tensor, name: str, shape: tuple) -> torch.Tensor:
    """Check ``t.shape`` against ``shape`` (``None`` entries match any size)."""
    if t.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, t.shape)):
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise InputError(f"{name} must have shape {want}, got {tuple(t.shape)}")
    return t


def check_finite(t: torch.Tensor, name: str) -> torch.Tensor:
    """Raise :class:`InputError` if a float tensor holds NaN / inf (fast path: NaN and inf propagate
    through a sum; only a non-finite sum pays for the element-wise test, which also rules out overflow)."""
    if t.is_floating_point() and t.numel() and not bool(torch.isfinite(t.sum())):
        if not bool(torch.isfinite(t).all()):
            raise InputError(f"{name} holds NaN or infinite values")
    return t


def strided(idx: torch.Tensor, n: int) -> torch.Tensor:
    """At most ``n`` entries of the 1D ``idx``, evenly strided (deterministic subsampling)."""
    n = int(n)
    if len(idx) <= n:
        return idx
    return idx[torch.linspace(0, len(idx) - 1, n, device=idx.device).long()]


def tensor(x, name: str, shape: tuple, dtype: torch.dtype | None = torch.float32, device=None) -> torch.Tensor:
    """Convert, check the shape and (for floats) finiteness in one go."""
    return check_finite(check_shape(as_tensor(x, name, dtype, device), name, shape), name)
