"""Training items: fixed-size clouds with precomputed FPS indices and per-part point pairs.

Everything random here is drawn from a generator keyed by ``(seed, epoch, sample index)``, so an
item is the same in any data-loader worker, on any machine and after a resume.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch.utils.data import Dataset

from ..data.augment import augment_sample
from ..errors import InputError
from ..geometry.normals import estimate_normals
from ..geometry.sampling import random_subset
from .config import ModelConfig
from .pointnet2 import numpy_fps_indices

__all__ = ["TrainingItems", "collate_items", "batch_to", "sample_pairs"]

NORMAL_K = 16
"""Neighbours of the normals estimated for corrupted items (as the estimator and the generator use)."""

_FLOAT_FIELDS = ("cam_from_part", "size_m", "joint_pivot", "joint_axis", "joint_state")


def sample_pairs(
    labels: np.ndarray, num_parts: int, pairs_per_part: int, rng: np.random.Generator, p_same: float = 0.5
) -> np.ndarray:
    """Point pairs for each part's voting heads.

    For part ``k`` the first point is drawn from the points labelled ``k`` (from all points if part
    ``k`` is not visible), the second from part ``k`` with probability ``p_same`` and from the whole
    cloud otherwise, so the part-score head sees both same-part and mixed pairs.

    Args:
        labels: ``(N,)`` part labels.

    Returns:
        ``(K, M, 2)`` int64 indices into the cloud.
    """
    N = len(labels)
    M = int(pairs_per_part)
    out = np.empty((num_parts, M, 2), dtype=np.int64)
    for k in range(num_parts):  # a handful of parts
        own = np.flatnonzero(labels == k)
        pool = own if len(own) > 0 else np.arange(N)
        out[k, :, 0] = pool[rng.integers(0, len(pool), M)]
        same = rng.random(M) < p_same
        out[k, :, 1] = np.where(same, pool[rng.integers(0, len(pool), M)], rng.integers(0, N, M))
    return out


class TrainingItems(Dataset):
    """Items for :meth:`ucope.model.network.UCOPENet.compute_loss`, from a sequence of sample dicts.

    Each item holds ``num_points`` points (drawn without replacement where the cloud allows), their
    normals and labels, the ground-truth fields as float32 tensors, the FPS indices of every encoder
    level, and ``(K, pairs_per_part, 2)`` pair indices (:func:`sample_pairs`).

    With ``augment`` each sample's cloud is first corrupted (:func:`ucope.data.augment.augment_sample`:
    occlusion, floor and neighbour points, outliers, noise, fewer points), the points it adds labelled
    ``K`` (the model's background class, required), and the normals of a corrupted item estimated anew
    (kNN PCA, k = 16, facing the camera) for the points the network sees, as the estimator does.

    Args:
        samples: an indexable sequence of sample dicts (:func:`ucope.data.load_dataset`, or generated
            on the fly).
        cfg: the model configuration (number of points, pairs, encoder levels).
        seed: seed of every draw.
        augment: an :class:`ucope.data.augment.AugmentConfig`, or ``None`` (no augmentation).
    """

    def __init__(self, samples: Sequence[dict], cfg: ModelConfig, seed: int = 0, augment=None):
        if augment is not None and not cfg.background_class:
            raise InputError("augmentation adds points that are not the object: the model needs background_class=True")
        self.samples = samples
        self.cfg = cfg
        self.seed = int(seed)
        self.augment = augment
        self.epoch = 0

    def set_epoch(self, epoch: int) -> None:
        """Draw other points and pairs (and, for a generated stream, other samples) in epoch ``epoch``."""
        self.epoch = int(epoch)
        if hasattr(self.samples, "set_epoch"):
            self.samples.set_epoch(self.epoch)

    def __len__(self) -> int:
        return len(self.samples)

    def __getitem__(self, i: int) -> dict:
        s = self.samples[i]
        cfg = self.cfg
        K = cfg.num_parts
        if len(s["size_m"]) != K:
            raise InputError(f"sample {i} ({s.get('category')}) has {len(s['size_m'])} parts, the model {K} ({cfg.category})")
        rng = np.random.default_rng(np.random.SeedSequence(entropy=self.seed, spawn_key=(self.epoch, int(i))))
        all_pts, all_labels, normals = s["points"], np.asarray(s["part_labels"]), s["normals"]
        corrupted = False
        if self.augment is not None:
            all_pts, all_labels, corrupted = augment_sample(s, np.random.default_rng(rng.integers(1 << 63)), self.augment)
            all_labels = np.where(all_labels < 0, K, all_labels)  # added points: the background class
        idx = random_subset(len(all_pts), cfg.num_points, rng)
        pts = np.ascontiguousarray(all_pts[idx], dtype=np.float32)
        labels = np.asarray(all_labels)[idx].astype(np.int64)
        nrm = estimate_normals(all_pts, k=NORMAL_K, rows=idx) if corrupted else np.asarray(normals)[idx]
        fps = numpy_fps_indices(pts, cfg.encoder.npoints)
        out = {
            "points": torch.from_numpy(pts),
            "normals": torch.from_numpy(np.ascontiguousarray(nrm, dtype=np.float32)),
            "part_labels": torch.from_numpy(labels),
            "joint_type": torch.from_numpy(np.asarray(s["joint_type"], dtype=np.int64).reshape(-1)),
            "fps_idx": [torch.from_numpy(f) for f in fps],
            "pair_idx": torch.from_numpy(sample_pairs(labels, K, cfg.pairs_per_part, rng)),
            "index": torch.tensor(int(i)),
        }
        for k in _FLOAT_FIELDS:
            out[k] = torch.from_numpy(np.asarray(s[k], dtype=np.float32))
        return out


def collate_items(items: list[dict]) -> dict:
    """Stack items into a batch: every tensor gains a leading ``B``; ``fps_idx`` stays a list (one
    ``(B, m_l)`` tensor per encoder level)."""
    if not items:
        raise InputError("cannot collate an empty list of items")
    batch = {k: torch.stack([it[k] for it in items]) for k in items[0] if k != "fps_idx"}
    batch["fps_idx"] = [torch.stack([it["fps_idx"][lev] for it in items]) for lev in range(len(items[0]["fps_idx"]))]
    return batch


def batch_to(batch: dict, device: torch.device | str) -> dict:
    """A copy of ``batch`` with every tensor (and the ``fps_idx`` list) on ``device``."""
    out = {}
    for k, v in batch.items():
        if isinstance(v, torch.Tensor):
            out[k] = v.to(device, non_blocking=True)
        elif isinstance(v, list):
            out[k] = [t.to(device, non_blocking=True) if isinstance(t, torch.Tensor) else t for t in v]
        else:
            out[k] = v
    return out
