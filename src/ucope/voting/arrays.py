"""Array helpers shared by the voting ops.

* input checks (:func:`tensor`, :func:`as_tensor`, :func:`check_shape`, :func:`check_finite`) raising
  :class:`ucope.errors.InputError` that names the argument;
* :func:`strided`: deterministic, evenly strided subsets of index vectors;
* small float64 numpy helpers of the iterative refinements (:func:`np64`, :func:`median`,
  :func:`cross3`) and the coordinate-major row-wise dot and cross products of the torch stages
  (:func:`dot3`, :func:`cross_rows`). "Coordinate-major" means ``(3, M)`` arrays: on the CPU, torch
  reductions over a trailing axis of size 3 are several times slower than three fused multiply-adds.
"""

from __future__ import annotations

import numpy as np
import torch

from ..errors import InputError

__all__ = ["as_tensor", "check_shape", "check_finite", "strided", "tensor", "np64", "median", "cross3", "dot3", "cross_rows"]


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
    if t.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, t.shape, strict=False)):
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


def np64(x) -> np.ndarray:
    """A float64 numpy copy of a tensor (any device) or array: the iterative refinements run on it."""
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    return np.asarray(x, dtype=np.float64)


def median(x: np.ndarray) -> float:
    """``np.median`` of a non-empty 1D array, without its per-call overhead (one partition)."""
    n = len(x)
    k = n // 2
    part = np.partition(x, k)
    return float(part[k]) if n % 2 else 0.5 * float(part[:k].max() + part[k])


def cross3(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (``np.cross`` costs tens of microseconds per call)."""
    return np.array([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])


def dot3(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Row-wise dot of ``(3, M)`` coordinate-major arrays -> ``(M,)``."""
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


def cross_rows(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Cross products of ``(3, M)`` coordinate-major arrays -> ``(3, M)``."""
    return torch.stack([x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]])
