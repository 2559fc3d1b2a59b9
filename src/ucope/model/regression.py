"""The direct-regression baseline: U-COPE's encoder, masks and joint heads, with poses regressed.

It answers "does the voting help?" on equal terms: the same PointNet++ encoder, the same part masks
and re-modulated features ``F2_k = F1 * m_k``, the same segmentation and joint heads and losses, the
same data, steps and budget (``ModelConfig.head = "regression"``). Only the pose branch differs:

* per part ``k``, ``F2_k`` is pooled over the points (max and mask-weighted mean, ``(B, K, 2C)``) and
  a per-part MLP regresses
  - the rotation ``cam_from_part[:3, :3]`` as the 6D representation of Zhou et al. (CVPR 2019): the
    first two columns (x, y), made orthonormal by Gram-Schmidt, ``z = x cross y``;
  - the box centre as an offset from the cloud centroid in units of ``priors.norm_scale_m``;
  - ``gamma = log(size_m) - log(mean_size_m)`` (3 values), as U-COPE's scale head.
* Pose loss per part: L1 (summed over entries) between the predicted and ground-truth rotation
  matrices (for a part symmetric about y, between the y columns only), smooth L1 on the normalised centre offset, MSE on
  ``gamma``; summed over parts and weighted by ``lambda_pose`` in equation (7) as U-COPE's.

Frames and units: camera frame (OpenCV axes), metres, as everywhere.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from .network import PerGroupLinear, UCOPENet

__all__ = ["RegressionNet", "rotation_from_6d"]


def rotation_from_6d(x: torch.Tensor) -> torch.Tensor:
    """Rotation matrices from the 6D representation.

    Args:
        x: ``(..., 6)``: two 3-vectors ``(a, b)``, the raw first and second columns.

    Returns:
        ``(..., 3, 3)`` rotations with columns ``x = a / |a|``, ``y = `` ``b`` made orthogonal to ``x``
        and normalised, ``z = x cross y``.
    """
    a, b = x[..., :3], x[..., 3:]
    c0 = F.normalize(a, dim=-1, eps=1e-8)
    c1 = F.normalize(b - (c0 * b).sum(-1, keepdim=True) * c0, dim=-1, eps=1e-8)
    c2 = torch.cross(c0, c1, dim=-1)
    return torch.stack([c0, c1, c2], dim=-1)


class RegressionNet(UCOPENet):
    """The direct-regression baseline (see the module docstring). Outputs of :meth:`forward`: those of
    :meth:`UCOPENet.encode` and :meth:`UCOPENet.joint_heads`, plus ``rotation`` ``(B, K, 3, 3)``,
    ``centre_m`` ``(B, K, 3)`` (camera frame, metres) and ``gamma`` ``(B, K, 3)``."""

    def _build_pose_heads(self, C: int, K: int, H: int) -> None:
        self.reg_mlp = nn.Sequential(nn.Linear(2 * C, 2 * H), nn.ReLU(inplace=True), nn.Linear(2 * H, H), nn.ReLU(inplace=True))
        self.reg_out = PerGroupLinear(K, H, 12)  # 6D rotation, centre offset, gamma

    def regress(self, enc: dict, points: torch.Tensor) -> dict[str, torch.Tensor]:
        """Per-part poses from the encoder output ``enc`` and the ``(B, N, 3)`` input points."""
        f1, masks = enc["feats"], enc["masks"]  # (B, N, C), (B, N, K)
        f2 = f1.unsqueeze(1) * masks.permute(0, 2, 1).unsqueeze(-1)  # (B, K, N, C)
        w = masks.permute(0, 2, 1).unsqueeze(-1)  # (B, K, N, 1)
        mean = f2.sum(2) / w.sum(2).clamp_min(1e-6)
        pooled = torch.cat([f2.amax(2), mean], dim=-1)  # (B, K, 2C)
        y = self.reg_out(self.reg_mlp(pooled).unsqueeze(2)).squeeze(2)  # (B, K, 12)
        centroid = points.mean(dim=1, keepdim=True)  # (B, 1, 3)
        # Start the 6D head near the identity so early rotations are well conditioned.
        six = y[..., :6] + y.new_tensor([1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
        return {
            "rotation": rotation_from_6d(six),
            "centre_m": centroid + y[..., 6:9] * self.norm_scale,
            "gamma": y[..., 9:12],
        }

    def forward(self, points, normals, pair_idx=None, fps_idx=None) -> dict[str, torch.Tensor]:
        """All outputs (``pair_idx`` is accepted for the trainer's sake and ignored)."""
        enc = self.encode(points, normals, fps_idx)
        out = dict(enc)
        if self.cfg.num_joints > 0:
            out.update(self.joint_heads(enc))
        out.update(self.regress(enc, points))
        return out

    def _pose_loss(self, out, batch, logs) -> torch.Tensor:
        T = batch["cam_from_part"]  # (B, K, 4, 4)
        R_gt, t_gt = T[..., :3, :3], T[..., :3, 3]
        R = out["rotation"]
        sym = self.symmetric.view(1, -1)  # (1, K)
        full = (R - R_gt).abs().sum((-1, -2))
        y_only = (R[..., 1] - R_gt[..., 1]).abs().sum(-1)
        l_rot = torch.where(sym, y_only, full).mean(0)  # (K,)
        l_t = (
            F.smooth_l1_loss(out["centre_m"] / self.norm_scale, t_gt / self.norm_scale, reduction="none", beta=0.05)
            .sum(-1)
            .mean(0)
        )
        g_gt = torch.log(batch["size_m"]) - torch.log(self.mean_size.unsqueeze(0))
        l_g = (out["gamma"] - g_gt).pow(2).mean(-1).mean(0)
        with torch.no_grad():
            cos_y = (R[..., 1] * R_gt[..., 1]).sum(-1).clamp(-1, 1)
            tr = ((R * R_gt).sum((-1, -2)) - 1.0).mul(0.5).clamp(-1, 1)
            ang = torch.where(sym, torch.arccos(cos_y), torch.arccos(tr))
            logs.update(
                rot=float(l_rot.mean()),
                trans=float(l_t.mean()),
                gamma=float(l_g.mean()),
                rot_err_deg=float(torch.rad2deg(ang).mean()),
                trans_err_m=float((out["centre_m"] - t_gt).norm(dim=-1).mean()),
            )
        return (l_rot + l_t + l_g).sum()
