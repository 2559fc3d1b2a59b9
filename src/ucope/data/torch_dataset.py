"""A torch ``Dataset`` over a generated data set, with a fixed number of points per item."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from torch.utils.data import Dataset

from ..errors import InputError
from ..geometry.sampling import random_subset
from .dataset import SyntheticDataset, load_dataset

__all__ = ["PointCloudDataset"]

_FLOAT_FIELDS = ("cam_from_part", "size_m", "joint_pivot", "joint_axis", "joint_state", "cam_from_object", "intrinsics")


class PointCloudDataset(Dataset):
    """Items with exactly ``num_points`` points drawn from each sample's cloud.

    The draw uses a generator keyed by ``(seed, epoch, index)``, so an item is the same in any worker
    process and on any machine; call :meth:`set_epoch` to draw other points each epoch. Clouds with
    fewer points repeat some. Items are dicts of tensors: ``points``/``normals`` ``(N, 3)`` float32,
    ``part_labels`` ``(N,)`` int64, the ground-truth fields of :mod:`ucope.data.sample` as float32
    (``joint_type`` int64), plus ``index`` (int), ``category`` and ``instance_id`` (str).
    """

    def __init__(self, data: SyntheticDataset | str | Path, num_points: int = 2048, seed: int = 0):
        self.data = data if isinstance(data, SyntheticDataset) else load_dataset(data)
        if int(num_points) <= 0:
            raise InputError(f"num_points must be positive, got {num_points}")
        self.num_points = int(num_points)
        self.seed = int(seed)
        self.epoch = 0

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def __len__(self) -> int:
        return len(self.data)

    def __getitem__(self, i: int) -> dict:
        s = self.data[i]
        rng = np.random.default_rng(np.random.SeedSequence(entropy=self.seed, spawn_key=(self.epoch, int(s["index"]))))
        idx = random_subset(len(s["points"]), self.num_points, rng)
        out: dict = {
            "points": torch.from_numpy(np.ascontiguousarray(s["points"][idx], dtype=np.float32)),
            "normals": torch.from_numpy(np.ascontiguousarray(s["normals"][idx], dtype=np.float32)),
            "part_labels": torch.from_numpy(s["part_labels"][idx].astype(np.int64)),
            "joint_type": torch.from_numpy(np.asarray(s["joint_type"], dtype=np.int64)),
        }
        for k in _FLOAT_FIELDS:
            out[k] = torch.from_numpy(np.asarray(s[k], dtype=np.float32))
        out["index"] = int(s["index"])
        out["category"] = s["category"]
        out["instance_id"] = s["instance_id"]
        return out
