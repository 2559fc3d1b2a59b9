"""PointNet++ (Qi et al. 2017) segmentation-style encoder in pure PyTorch: per-point features.

No compiled extensions: every op is batched torch (CPU or GPU), with Python loops only over the
``m`` samples of farthest point sampling (and over layers). Functional ops first, thin
``nn.Module`` wrappers after, roma / kornia style.

Conventions:

* Tensors are channels-last: points ``(B, N, 3)``, features ``(B, N, C)``; index tensors are int64.
* Coordinates are in the caller's normalised object units (see :class:`PointNet2Encoder`): radii and
  distances are in the same units, squared distances in those units squared. The ops themselves have no
  preferred frame; everything is translation-covariant except the group-all layer, which sees
  coordinates relative to the origin of the input frame.
* Inputs are float32 (the dtype of the module parameters); the functional ops also accept float64.
* Shared MLPs are ``nn.Linear`` layers on channels-last tensors (measured faster than ``Conv1d`` /
  ``Conv2d`` on CPU), each followed by ReLU, with He (Kaiming) initialisation and no normalisation
  layers (so results do not depend on the batch composition or on train / eval mode). The encoder's very
  last layer is a plain ``Linear`` (no ReLU), so output features are signed.

Speed-ups, all exact in real arithmetic (equal to the textbook formulation up to float rounding):

* The first layer of a set-abstraction MLP is applied to the ``N`` input points *before* grouping
  (``W [(p_j - c) / r ; f_j] = W [p_j / r ; f_j] - W_xyz c / r``), so the ``(B, M, nsample, C)`` group
  tensor is only built with the first layer's width.
* The last layer's bias and ReLU are applied *after* the max-pool (both commute with ``max``).
* Feature propagation projects the coarse features with the first layer before interpolating
  (interpolation is linear), and adds the skip features' projection instead of concatenating.
* The last layer and the max-pool are one autograd Function (:class:`_LinearMaxPool`): ``amax`` forward,
  and a backward that builds the gradient in the forward product's buffer (large fresh CPU allocations
  page-fault, which costs more than the arithmetic here).
* In-place ReLUs only ever act on base tensors (2D ``addmm`` outputs), never on views (an in-place op on
  a view makes autograd copy the whole gradient in the backward pass).
* Neighbour searches use ``|a|^2 + |b|^2 - 2 a.b`` (one batched matmul) and ``topk``, without autograd,
  a few batch items at a time on CPU, then recompute the few selected distances exactly.

Step times of both sizes: benchmarks/bench_train.py (figures in docs/results.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from ..errors import InputError
from ..geometry.sampling import farthest_point_sampling

__all__ = [
    "square_distance",
    "gather_points",
    "ball_query",
    "three_nn_interpolate",
    "farthest_point_sample_torch",
    "numpy_fps_indices",
    "SharedMLP",
    "SetAbstraction",
    "FeaturePropagation",
    "PointNet2Config",
    "PointNet2Encoder",
]


# ----------------------------------------------------------------------------------------------------
# Functional ops
# ----------------------------------------------------------------------------------------------------


def _check_points(name: str, x: torch.Tensor) -> None:
    if x.ndim != 3 or x.shape[-1] != 3:
        raise InputError(f"{name} must have shape (B, N, 3), got {tuple(x.shape)}")


def square_distance(a: torch.Tensor, b: torch.Tensor, clamp: bool = True) -> torch.Tensor:
    """Pairwise squared Euclidean distances ``|a_i - b_j|^2`` of ``(B, M, 3)`` and ``(B, N, 3)`` points.

    Expanded as ``|a|^2 + |b|^2 - 2 a.b`` in one batched matmul of 5-vectors
    ``[-2a, 1, |a|^2] . [b, |b|^2, 1]`` (a single pass over the ``(B, M, N)`` output). The absolute error
    is about ``eps * (|a|^2 + |b|^2)`` (float32: ~1e-7 for unit-size coordinates), so use it to *rank*
    neighbours and recompute exact distances of the few selected ones.

    Args:
        clamp: clamp the (rounding-induced) negative values to 0; ranking does not need it.

    Returns:
        ``(B, M, N)`` tensor, in the input units squared.
    """
    aa = (a * a).sum(-1, keepdim=True)  # (B, M, 1)
    bb = (b * b).sum(-1, keepdim=True)  # (B, N, 1)
    a5 = torch.cat([a * -2.0, torch.ones_like(aa), aa], dim=-1)
    b5 = torch.cat([b, bb, torch.ones_like(bb)], dim=-1)
    d2 = torch.bmm(a5, b5.transpose(1, 2))
    return d2.clamp_min_(0.0) if clamp else d2


_KNN_CHUNK = 1 << 21  # elements of one (b, M, N) distance block on CPU: small blocks reuse heap memory


def _knn(query: torch.Tensor, ref: torch.Tensor, k: int, sorted: bool) -> torch.Tensor:
    """``(B, M, k)`` indices of the ``k`` points of ``ref`` ``(B, N, 3)`` nearest to each ``query``
    ``(B, M, 3)`` point, by expanded squared distances, without autograd. On CPU the ``(B, M, N)``
    distances are built a few batch items at a time (measured ~1.3-2x faster for 8 x 2048 x 512 blocks:
    large fresh allocations page-fault)."""
    B, M, _ = query.shape
    N = ref.shape[1]
    with torch.no_grad():
        query, ref = query.detach(), ref.detach()
        step = B if query.device.type != "cpu" else max(1, _KNN_CHUNK // max(1, M * N))
        out = [
            square_distance(query[i : i + step], ref[i : i + step], clamp=False)
            .topk(k, dim=-1, largest=False, sorted=sorted)
            .indices
            for i in range(0, B, step)
        ]
    return out[0] if len(out) == 1 else torch.cat(out, dim=0)


def gather_points(x: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """Gather rows of ``x`` ``(B, N, C)`` with int64 indices ``idx`` ``(B, ...)`` into ``[0, N)``.

    ``out[b, ...] = x[b, idx[b, ...]]``. Implemented as one ``index_select`` on the flattened
    ``(B * N, C)`` tensor with per-batch offsets (faster than advanced indexing or ``torch.gather``
    forward and backward on CPU). Differentiable in ``x``. Indices are not range-checked per batch item.

    Returns:
        ``(B, ..., C)`` tensor, contiguous.
    """
    B, N, C = x.shape
    if idx.shape[0] != B:
        raise InputError(f"idx batch size {idx.shape[0]} does not match x batch size {B}")
    offset = torch.arange(B, device=idx.device, dtype=idx.dtype).mul_(N).view((B,) + (1,) * (idx.ndim - 1))
    flat = (idx + offset).reshape(-1)
    return x.reshape(B * N, C).index_select(0, flat).view(*idx.shape, C)


def ball_query(xyz: torch.Tensor, centres: torch.Tensor, radius: float, nsample: int) -> torch.Tensor:
    """Indices of up to ``nsample`` points of ``xyz`` within ``radius`` of each centre.

    The candidates are the ``nsample`` points *nearest* to the centre (``torch.topk`` on squared
    distances, ``largest=False``, sorted nearest first); those whose exact distance is not strictly below
    ``radius`` are replaced by the index of the nearest point (slot 0). So every row holds the nearest
    in-radius points, padded by repeating the nearest one; when centres are a subset of ``xyz`` (as after
    farthest point sampling) the centre itself is the nearest point and always a member. A centre with
    no point within the radius gets its nearest point in every slot. If ``N < nsample`` all ``N``
    points are candidates and the remaining slots are padded the same way. (The CUDA PointNet++ kernel
    takes the *first* in-radius points in index order instead; nearest-first makes the result
    independent of the point order.) Not differentiable (returns indices; runs without autograd).

    Args:
        xyz: ``(B, N, 3)`` points.
        centres: ``(B, M, 3)`` query centres, same units and frame as ``xyz``.
        radius: ball radius, in the units of ``xyz``.
        nsample: number of neighbours per centre (``>= 1``).

    Returns:
        ``(B, M, nsample)`` int64 indices into ``[0, N)``.
    """
    _check_points("xyz", xyz)
    _check_points("centres", centres)
    if nsample < 1:
        raise InputError(f"nsample must be >= 1, got {nsample}")
    N = xyz.shape[1]
    k = min(nsample, N)
    with torch.no_grad():
        xyz, centres = xyz.detach(), centres.detach()
        idx = _knn(centres, xyz, k, sorted=True)  # (B, M, k), nearest first
        diff = gather_points(xyz, idx) - centres.unsqueeze(2)
        exact = diff.square_().sum(-1)  # (B, M, k)
        nearest = idx[..., :1]
        idx = torch.where(exact < radius * radius, idx, nearest)
        if k < nsample:
            idx = torch.cat([idx, nearest.expand(-1, -1, nsample - k)], dim=-1)
    return idx


def three_nn_interpolate(
    xyz_dst: torch.Tensor, xyz_src: torch.Tensor, feats_src: torch.Tensor, eps: float = 1e-8
) -> torch.Tensor:
    """Inverse-distance weighted interpolation of source features at destination points.

    For each destination point, the ``k = min(3, M)`` nearest sources ``i`` get weights
    ``w_i = 1 / (d_i^2 + eps)`` normalised to sum to 1 (inverse *squared* distance, ``p = 2`` in the
    PointNet++ paper). Sources closer than ``sqrt(eps)`` (``d_i^2 < eps``) count as coincident: if a
    destination has any, only those are averaged with equal weights, so a destination point equal to a
    source point gets that source's feature exactly. A constant feature is reproduced exactly up to
    rounding. Differentiable in ``feats_src`` (and through the weights in the coordinates); the neighbour
    search itself runs without autograd.

    Args:
        xyz_dst: ``(B, N, 3)`` destination points.
        xyz_src: ``(B, M, 3)`` source points (``M >= 1``), same units and frame.
        feats_src: ``(B, M, C)`` source features.
        eps: squared-distance regulariser and coincidence threshold, in units squared.

    Returns:
        ``(B, N, C)`` interpolated features.
    """
    _check_points("xyz_dst", xyz_dst)
    _check_points("xyz_src", xyz_src)
    B, M, _ = xyz_src.shape
    if feats_src.ndim != 3 or feats_src.shape[:2] != (B, M):
        raise InputError(f"feats_src must have shape (B, M, C) = ({B}, {M}, C), got {tuple(feats_src.shape)}")
    if M == 0:
        raise InputError("three_nn_interpolate needs at least one source point")
    k = min(3, M)
    idx = _knn(xyz_dst, xyz_src, k, sorted=False)  # (B, N, k)
    diff = gather_points(xyz_src, idx) - xyz_dst.unsqueeze(2)
    dist2 = diff.square().sum(-1)  # (B, N, k), exact
    coincident = dist2 < eps
    w = torch.where(coincident.any(-1, keepdim=True), coincident.to(dist2.dtype), 1.0 / (dist2 + eps))
    w = w / w.sum(-1, keepdim=True)
    if k == 1:
        return gather_points(feats_src, idx[..., 0]) * w
    g = gather_points(feats_src, idx)  # (B, N, k, C)
    return (g * w.unsqueeze(-1)).sum(2)


def farthest_point_sample_torch(xyz: torch.Tensor, m: int) -> torch.Tensor:
    """Farthest point sampling of ``(B, N, 3)`` points in torch, starting at index 0 of every item.

    Loops over the ``m`` samples only (batched over points and items, works on any device). Gives
    exactly the indices of :func:`ucope.geometry.sampling.farthest_point_sampling` (numpy) for the same
    float32 input and ``start=0``: same arithmetic order, first index on ties. Costs ~30 ms per batch
    of 8 x 2048 points (both default levels, 2 CPU threads) inside the training step; computing the
    indices with :func:`numpy_fps_indices` in data-loading workers moves that cost off the training
    process. Not differentiable.

    Returns:
        ``(B, m)`` int64 indices into ``[0, N)``; ``1 <= m <= N`` is required.
    """
    _check_points("xyz", xyz)
    B, N, _ = xyz.shape
    if not 0 < m <= N:
        raise InputError(f"cannot take {m} farthest-point samples of {N} points")
    with torch.no_grad():
        xyz = xyz.detach()
        out = torch.empty(B, m, dtype=torch.long, device=xyz.device)
        cur = torch.zeros(B, dtype=torch.long, device=xyz.device)
        dist = torch.full((B, N), float("inf"), dtype=xyz.dtype, device=xyz.device)
        rows = torch.arange(B, device=xyz.device)
        for i in range(m):
            out[:, i] = cur
            d = (xyz - xyz[rows, cur].unsqueeze(1)).square_()
            d = d[..., 0] + d[..., 1] + d[..., 2]  # numpy's summation order: (x + y) + z
            torch.minimum(dist, d, out=dist)
            cur = dist.argmax(1)
    return out


def numpy_fps_indices(xyz: np.ndarray, npoints: Sequence[int]) -> list[np.ndarray]:
    """Hierarchical farthest-point-sampling indices for :class:`PointNet2Encoder`, in numpy.

    Level ``l`` indices index into level ``l - 1``'s points (level ``-1`` being ``xyz``), each computed
    with :func:`ucope.geometry.sampling.farthest_point_sampling` starting at index 0: the encoder gives
    identical results with these as with its own torch fallback. Meant for data-loading workers, to take
    FPS out of the training step (~19 ms per 2048-point item for the default ``(512, 128)``, ~6 ms per
    1024-point item for ``(256, 64)``, one core).

    Args:
        xyz: ``(N, 3)`` or ``(B, N, 3)`` points (normalised units, cast to float32).
        npoints: samples per level, e.g. ``PointNet2Config.npoints``.

    Returns:
        list of ``(npoints[l],)`` or ``(B, npoints[l])`` int64 arrays.
    """
    pts = np.asarray(xyz, dtype=np.float32)
    if pts.ndim not in (2, 3) or pts.shape[-1] != 3:
        raise InputError(f"xyz must have shape (N, 3) or (B, N, 3), got {pts.shape}")
    out = []
    for m in npoints:
        idx = farthest_point_sampling(pts, int(m))
        out.append(idx)
        pts = np.take_along_axis(pts, idx[..., None], axis=-2)
    return out


# ----------------------------------------------------------------------------------------------------
# Modules
# ----------------------------------------------------------------------------------------------------


class _LinearMaxPool(torch.autograd.Function):
    """``y[r, c] = max_k x[r, k] . w[c]`` for ``x`` ``(R, K, C_in)``, ``w`` ``(C, C_in)``: ``(R, C)``.

    Same value and gradient as ``F.linear(x, w).amax(1)`` (ties share the gradient equally, so the
    duplicated padding slots of :func:`ball_query` pass exactly the gradient of one slot to their point),
    but faster on CPU: ``amax`` instead of ``max`` with indices, and the backward builds the
    ``(R, K, C)`` gradient in the forward product's buffer (kept alive for it) instead of a freshly
    allocated, page-faulting zero tensor. That keeps the ``(R, K, C)`` product alive from forward to
    backward (``max`` would keep only ``(R, C)`` indices): 64 MiB for the first level of the default
    config at batch 8. A second backward through the same graph recomputes the product.
    """

    @staticmethod
    def forward(ctx, x: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
        R, K, cin = x.shape
        prod = torch.mm(x.reshape(R * K, cin), w.t()).view(R, K, w.shape[0])
        y = prod.amax(1)
        ctx.save_for_backward(x, w, y)
        ctx.prod = prod
        return y

    @staticmethod
    def backward(ctx, g: torch.Tensor):
        x, w, y = ctx.saved_tensors
        prod = ctx.prod
        ctx.prod = None
        R, K, cin = x.shape
        if prod is None:  # backward twice (retain_graph): the buffer was consumed, recompute it
            prod = torch.mm(x.reshape(R * K, cin), w.t()).view(R, K, w.shape[0])
        mask = torch.eq(prod, y.unsqueeze(1), out=prod)  # 1.0 where the max is attained, in place
        count = mask.sum(1)
        grad = mask.mul_((g / count).unsqueeze(1)).view(R * K, -1)  # (R * K, C)
        gx = torch.mm(grad, w).view(R, K, cin) if ctx.needs_input_grad[0] else None
        gw = torch.mm(grad.t(), x.reshape(R * K, cin)) if ctx.needs_input_grad[1] else None
        return gx, gw


def _init_linear(layer: nn.Linear, relu: bool) -> None:
    nn.init.kaiming_normal_(layer.weight, nonlinearity="relu" if relu else "linear")
    nn.init.zeros_(layer.bias)


class SharedMLP(nn.Module):
    """Per-point MLP on channels-last tensors: ``(..., in_channels) -> (..., channels[-1])``.

    ``Linear -> ReLU`` per layer (He initialisation, zero bias); with ``last_relu=False`` the last layer
    is a plain ``Linear``. The layers are in ``self.layers`` (an ``nn.ModuleList`` of ``nn.Linear``).
    """

    def __init__(self, in_channels: int, channels: Sequence[int], last_relu: bool = True):
        super().__init__()
        if len(channels) == 0:
            raise InputError("an MLP needs at least one layer")
        dims = [int(in_channels), *map(int, channels)]
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:], strict=False))
        self.last_relu = last_relu
        for i, layer in enumerate(self.layers):
            _init_linear(layer, relu=last_relu or i < len(self.layers) - 1)

    @property
    def out_channels(self) -> int:
        return self.layers[-1].out_features

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        n = len(self.layers)
        for i, layer in enumerate(self.layers):
            x = layer(x)
            if i < n - 1 or self.last_relu:
                x = F.relu(x)
        return x


class SetAbstraction(nn.Module):
    """PointNet++ set abstraction (single scale grouping): sample, group, shared MLP, max-pool.

    ``npoint`` centres are picked by farthest point sampling; each groups ``nsample`` neighbours by
    :func:`ball_query`; the MLP input per neighbour is ``[(p_j - c) / radius, f_j]`` (relative
    coordinates in radius units, then the neighbour's features), and the MLP output is max-pooled over
    the neighbours. With ``npoint=None`` the layer groups all points into one (the global feature):
    the centre is the origin and the MLP input is ``[p_j, f_j]`` (coordinates not divided).

    Args:
        npoint: number of centres, or ``None`` for group-all.
        radius: ball radius in the coordinates' units (ignored for group-all).
        nsample: neighbours per centre (ignored for group-all).
        in_channels: feature channels ``C`` per input point (0 when there are none).
        mlp: output channels of each MLP layer, every layer ``Linear -> ReLU``.
    """

    def __init__(self, npoint: int | None, radius: float | None, nsample: int | None, in_channels: int, mlp: Sequence[int]):
        super().__init__()
        if npoint is not None and (radius is None or radius <= 0 or nsample is None or nsample < 1):
            raise InputError("a set abstraction with npoint needs radius > 0 and nsample >= 1")
        self.npoint = npoint
        self.radius = float(radius) if radius is not None else None
        self.nsample = int(nsample) if nsample is not None else None
        self.in_channels = int(in_channels)
        self.mlp = SharedMLP(3 + self.in_channels, mlp)

    @property
    def out_channels(self) -> int:
        return self.mlp.out_channels

    def extra_repr(self) -> str:
        return f"npoint={self.npoint}, radius={self.radius}, nsample={self.nsample}, in_channels={self.in_channels}"

    def _check(self, xyz: torch.Tensor, feats: torch.Tensor | None) -> None:
        _check_points("xyz", xyz)
        if self.in_channels > 0:
            if feats is None or feats.shape != (*xyz.shape[:2], self.in_channels):
                got = None if feats is None else tuple(feats.shape)
                raise InputError(f"feats must have shape (B, N, {self.in_channels}) for xyz {tuple(xyz.shape)}, got {got}")
        elif feats is not None and feats.shape[-1] != 0:
            raise InputError(f"this layer takes no features (in_channels=0), got feats {tuple(feats.shape)}")

    def _pool_last(self, h: torch.Tensor) -> torch.Tensor:
        """``(R, K, C)`` -> ``(R, C_out)``: last layer without bias, max over K, then bias and ReLU
        (both commute with max)."""
        last = self.mlp.layers[-1]
        h = _LinearMaxPool.apply(h, last.weight)
        return F.relu(h + last.bias)

    def forward(
        self, xyz: torch.Tensor, feats: torch.Tensor | None = None, fps_idx: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Abstract ``(B, N, 3)`` points with ``(B, N, C)`` features (or ``None`` when ``in_channels == 0``).

        Args:
            fps_idx: ``(B, npoint)`` int64 indices of the centres into ``xyz`` (e.g. from
                :func:`numpy_fps_indices`); ``None`` computes them with
                :func:`farthest_point_sample_torch`. Ignored for group-all.

        Returns:
            ``new_xyz`` ``(B, npoint, 3)`` (group-all: ``(B, 1, 3)`` zeros) and ``new_feats``
            ``(B, npoint, mlp[-1])`` (group-all: ``(B, 1, mlp[-1])``).
        """
        self._check(xyz, feats)
        if self.in_channels == 0:
            feats = None
        B, N, _ = xyz.shape
        layers = self.mlp.layers
        n = len(layers)

        if self.npoint is None:  # group all
            h = xyz if feats is None else torch.cat([xyz, feats], dim=-1)
            for layer in layers[:-1]:
                h = F.relu(layer(h))
            new_feats = self._pool_last(h).unsqueeze(1)
            return xyz.new_zeros(B, 1, 3), new_feats

        if fps_idx is None:
            fps_idx = farthest_point_sample_torch(xyz, self.npoint)
        else:
            fps_idx = torch.as_tensor(fps_idx, dtype=torch.long, device=xyz.device)
            if fps_idx.shape != (B, self.npoint):
                raise InputError(f"fps_idx must have shape ({B}, {self.npoint}), got {tuple(fps_idx.shape)}")
        new_xyz = gather_points(xyz, fps_idx)  # (B, M, 3)
        idx = ball_query(xyz, new_xyz, self.radius, self.nsample)  # (B, M, K)

        # First layer on the N input points, then grouped: W [(p - c)/r ; f] = W [p/r ; f] - W_xyz c/r.
        inv_r = 1.0 / self.radius
        first = layers[0]
        inp = xyz * inv_r if feats is None else torch.cat([xyz * inv_r, feats], dim=-1)
        if n == 1:  # the first layer is the last: bias and ReLU go after the pool
            p = F.linear(inp, first.weight)
        else:
            p = first(inp)  # (B, N, C1)
        neg_q = F.linear(new_xyz * -inv_r, first.weight[:, :3])  # (B, M, C1): -W_xyz c / r
        M, K = idx.shape[1:]
        c1 = p.shape[-1]
        # Kept 2D / 3D so that every in-place ReLU acts on a base tensor: F.linear on 2D input is a plain
        # addmm, whereas on 4D input its output is a view, and an in-place op on a view costs a full copy
        # (CopySlices) in the backward pass.
        # (adding -q rather than subtracting q: the backward of a broadcast sub negates the full tensor)
        h = gather_points(p, idx).view(B * M, K, c1) + neg_q.view(B * M, 1, c1)  # (B * M, K, C1)
        if n == 1:
            return new_xyz, F.relu(h.max(1).values + first.bias).view(B, M, -1)
        h = h.relu_().view(B * M * K, c1)
        for layer in layers[1:-1]:
            h = layer(h).relu_()
        return new_xyz, self._pool_last(h.view(B * M, K, -1)).view(B, M, -1)


class FeaturePropagation(nn.Module):
    """PointNet++ feature propagation: interpolate coarse features to finer points, add skip features, MLP.

    ``MLP([three_nn_interpolate(xyz_dst, xyz_src, feats_src), feats_dst])``; ``in_channels`` is
    ``C_src + C_dst``, ``skip_channels`` is ``C_dst`` (0 when there are no skip features).

    Args:
        in_channels: MLP input channels (interpolated plus skip).
        mlp: output channels of each MLP layer, ``Linear -> ReLU`` each.
        skip_channels: channels ``C_dst`` of the skip features among ``in_channels``.
        last_relu: ``False`` makes the last layer a plain ``Linear``.
    """

    def __init__(self, in_channels: int, mlp: Sequence[int], skip_channels: int = 0, last_relu: bool = True):
        super().__init__()
        if not 0 <= skip_channels < in_channels:
            raise InputError(f"skip_channels must be in [0, in_channels), got {skip_channels} of {in_channels}")
        self.in_channels = int(in_channels)
        self.skip_channels = int(skip_channels)
        self.mlp = SharedMLP(in_channels, mlp, last_relu=last_relu)

    @property
    def out_channels(self) -> int:
        return self.mlp.out_channels

    def forward(
        self,
        xyz_dst: torch.Tensor,
        xyz_src: torch.Tensor,
        feats_dst: torch.Tensor | None,
        feats_src: torch.Tensor,
    ) -> torch.Tensor:
        """Propagate ``(B, M, C_src)`` features at ``(B, M, 3)`` points to ``(B, N, 3)`` points.

        Args:
            feats_dst: ``(B, N, C_dst)`` skip features at the destination points, or ``None`` when
                ``skip_channels == 0``.

        Returns:
            ``(B, N, mlp[-1])`` features at the destination points.
        """
        c_src = self.in_channels - self.skip_channels
        if feats_src.ndim != 3 or feats_src.shape[-1] != c_src or feats_src.shape[:2] != xyz_src.shape[:2]:
            raise InputError(f"feats_src must have shape (B, M, {c_src}), got {tuple(feats_src.shape)}")
        if self.skip_channels:
            if feats_dst is None or feats_dst.shape != (*xyz_dst.shape[:2], self.skip_channels):
                got = None if feats_dst is None else tuple(feats_dst.shape)
                raise InputError(f"feats_dst must have shape (B, N, {self.skip_channels}), got {got}")
        layers = self.mlp.layers
        first = layers[0]
        # Interpolation is linear: project the M coarse features first, add the skip projection.
        p = F.linear(feats_src, first.weight[:, :c_src])  # (B, M, C1)
        h = three_nn_interpolate(xyz_dst, xyz_src, p)
        if self.skip_channels:
            h = h + F.linear(feats_dst, first.weight[:, c_src:], first.bias)
        else:
            h = h + first.bias
        n = len(layers)
        if n > 1 or self.mlp.last_relu:
            h = F.relu(h)
        for i, layer in enumerate(layers[1:], start=1):
            h = layer(h)
            if i < n - 1 or self.mlp.last_relu:
                h = F.relu(h)
        return h


def _scale(c: int, width: float) -> int:
    return max(8, int(round(c * width)))


@dataclass(frozen=True)
class PointNet2Config:
    """Hyper-parameters of :class:`PointNet2Encoder`.

    Attributes:
        in_channels: feature channels per input point besides xyz (0 for xyz only; 3 for normals).
        npoints: centres of each set-abstraction level (farthest point samples of the previous level).
        radii: ball-query radius of each level, in the encoder's normalised coordinate units.
        nsamples: neighbours per centre of each level.
        sa_mlps: MLP channels of each set-abstraction level.
        global_mlp: MLP channels of the group-all (global feature) layer.
        fp_mlps: MLP channels of the feature-propagation layers, coarsest first: global -> last level,
            ..., level 1 -> input points (``len(npoints) + 1`` of them). The last channel count is the
            encoder's output width.
        width: multiplier of every channel count (rounded, at least 8); ``in_channels`` is not scaled.
    """

    in_channels: int = 3
    npoints: tuple[int, ...] = (512, 128)
    radii: tuple[float, ...] = (0.1, 0.2)
    nsamples: tuple[int, ...] = (32, 32)
    sa_mlps: tuple[tuple[int, ...], ...] = ((64, 64, 128), (128, 128, 256))
    global_mlp: tuple[int, ...] = (256, 512)
    fp_mlps: tuple[tuple[int, ...], ...] = ((256, 256), (256, 128), (128, 128))
    width: float = 1.0

    def __post_init__(self) -> None:
        L = len(self.npoints)
        if L == 0 or not (len(self.radii) == len(self.nsamples) == len(self.sa_mlps) == L):
            raise InputError("npoints, radii, nsamples and sa_mlps must have the same (non-zero) length")
        if len(self.fp_mlps) != L + 1:
            raise InputError(f"fp_mlps needs len(npoints) + 1 = {L + 1} entries, got {len(self.fp_mlps)}")
        if any(m < 1 for m in self.npoints) or any(a < b for a, b in zip(self.npoints, self.npoints[1:], strict=False)):
            raise InputError(f"npoints must be positive and non-increasing, got {self.npoints}")
        if self.in_channels < 0 or self.width <= 0:
            raise InputError("in_channels must be >= 0 and width > 0")

    def channels(self, mlp: Sequence[int]) -> tuple[int, ...]:
        """``mlp`` scaled by ``width`` (rounded, at least 8)."""
        return tuple(_scale(c, self.width) for c in mlp)

    @property
    def out_channels(self) -> int:
        """Channels of the encoder's per-point output features."""
        return self.channels(self.fp_mlps[-1])[-1]


class PointNet2Encoder(nn.Module):
    """PointNet++ encoder with per-point output features (segmentation-style, single scale grouping).

    Architecture: set abstraction levels ``SA_1 .. SA_L`` (``L = len(npoints)``), a group-all layer
    giving one global feature, then feature propagation back through ``SA_L .. SA_1`` to the input
    points (global -> level L -> ... -> level 1 -> input), with skip features at every level; the skip at
    the input points is ``[xyz, feats]``. The last layer is a plain ``Linear``.

    Coordinates must be normalised by the caller: typically centred (e.g. at the bounding-box centre)
    and divided by an object scale so that the object spans about unit size; ``radii`` are in those
    units, and the group-all layer sees coordinates relative to the origin, so centre them. Inputs are
    float32.

    Args:
        cfg: hyper-parameters (defaults: ``PointNet2Config()``).
    """

    def __init__(self, cfg: PointNet2Config | None = None):
        super().__init__()
        cfg = PointNet2Config() if cfg is None else cfg
        self.cfg = cfg
        self.sa = nn.ModuleList()
        c_in = cfg.in_channels
        level_channels = [cfg.in_channels]
        for m, r, k, mlp in zip(cfg.npoints, cfg.radii, cfg.nsamples, cfg.sa_mlps, strict=False):
            sa = SetAbstraction(m, r, k, c_in, cfg.channels(mlp))
            self.sa.append(sa)
            c_in = sa.out_channels
            level_channels.append(c_in)
        self.global_sa = SetAbstraction(None, None, None, c_in, cfg.channels(cfg.global_mlp))
        c_in = self.global_sa.out_channels
        self.fp = nn.ModuleList()
        L = len(cfg.npoints)
        for j, mlp in enumerate(cfg.fp_mlps):
            level = L - j  # destination level: L, ..., 1, 0 (input points)
            skip = level_channels[level] + (3 if level == 0 else 0)
            fp = FeaturePropagation(c_in + skip, cfg.channels(mlp), skip_channels=skip, last_relu=level > 0)
            self.fp.append(fp)
            c_in = fp.out_channels

    @property
    def out_channels(self) -> int:
        """Channels of the per-point output features."""
        return self.fp[-1].out_channels

    def forward(
        self,
        xyz: torch.Tensor,
        feats: torch.Tensor | None = None,
        fps_idx: Sequence[torch.Tensor] | None = None,
    ) -> torch.Tensor:
        """Per-point features of ``(B, N, 3)`` normalised points.

        Args:
            xyz: ``(B, N, 3)`` float32 points in normalised object units (see the class docstring).
            feats: ``(B, N, in_channels)`` point features (e.g. unit normals in the same frame), or
                ``None`` when ``in_channels == 0``.
            fps_idx: one ``(B, npoints[l])`` int64 tensor (or array) per level, level ``l`` indexing
                level ``l - 1``'s points (level 0: ``xyz``), e.g. from :func:`numpy_fps_indices`;
                ``None`` computes them with :func:`farthest_point_sample_torch` (same result, slower).

        Returns:
            ``(B, N, out_channels)`` features, row ``i`` for point ``xyz[:, i]``.
        """
        _check_points("xyz", xyz)
        L = len(self.sa)
        if fps_idx is not None and len(fps_idx) != L:
            raise InputError(f"fps_idx needs one index tensor per level ({L}), got {len(fps_idx)}")
        if self.cfg.in_channels == 0:
            if feats is not None and feats.shape[-1] != 0:
                raise InputError(f"this encoder takes no point features (in_channels=0), got {tuple(feats.shape)}")
            feats = None
        xyzs, featss = [xyz], [feats]
        for level, sa in enumerate(self.sa):
            x, f = sa(xyzs[-1], featss[-1], None if fps_idx is None else fps_idx[level])
            xyzs.append(x)
            featss.append(f)
        g_xyz, h = self.global_sa(xyzs[-1], featss[-1])
        src_xyz = g_xyz
        for j, fp in enumerate(self.fp):
            level = L - j
            skip = featss[level]
            if level == 0:
                skip = xyz if feats is None else torch.cat([xyz, feats], dim=-1)
            h = fp(xyzs[level], src_xyz, skip, h)
            src_xyz = xyzs[level]
        return h
