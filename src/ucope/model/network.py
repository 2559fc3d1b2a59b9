"""The U-COPE network: PointNet++ features, part masks, the pair ("PPF") encoder and joint heads.

Data flow (paper section 4.2-4.5), all channels-last:

* points ``(B, N, 3)`` (camera frame, metres) are centred at their centroid and divided by the
  category's ``norm_scale_m``; the encoder (:class:`PointNet2Encoder`, normals as point features)
  gives ``F1`` ``(B, N, C)``.
* K >= 2: a mask decoder gives per-point part logits ``(B, N, K)`` (segmentation, cross-entropy) and
  masks ``m = softmax(logits)``; the re-modulated features are ``F2_k = F1 * m_k`` (Hadamard). K = 1:
  ``F2_0 = F1`` and there is no segmentation branch. With ``cfg.background_class`` (beyond the paper)
  the decoder has a ``K + 1``-th class, "not the object" (floor, outliers, a neighbour's points), for any
  K (a rigid object too): ``m = softmax(logits)[..., :K]``, so background points are masked out of every
  part's features and, segmented as background, never drawn into a part's pairs.
* Pair encoder: for part ``k`` and a pair ``(i, j)``, ``[F2_k[i], F2_k[j], PPF(i, j), onehot(k)]`` ->
  an MLP -> a per-part output layer giving the bin logits of ``mu``, ``nu``, ``alpha``, ``beta``, two
  axis sign-bit logits, ``gamma`` (3) and the part-score logit (both points on part ``k``). The first
  layer is applied to the N points before gathering the pairs (it is linear), so pairs only cost the
  hidden layers.
* Joint heads (K >= 2): for joint ``j`` between parts ``p`` and ``c``, ``F1 * (m_p + m_c)`` -> an MLP ->
  per point a heatmap logit, an offset to the axis (metres), a direction, and a joint-score logit.

The voting-parameter definitions are in :mod:`ucope.model.targets`.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from ..errors import InputError
from ..vocab import JointType
from .config import ModelConfig
from .pointnet2 import PointNet2Encoder
from .targets import bin_centres, joint_point_targets, pair_features, pair_vote_targets, two_hot_kl

__all__ = ["UCOPENet", "PerGroupLinear", "per_group_linear"]

REVOLUTE = int(JointType.REVOLUTE)


class PerGroupLinear(nn.Module):
    """``G`` independent linear layers applied to the matching group of a ``(B, G, ..., I)`` tensor."""

    def __init__(self, groups: int, in_features: int, out_features: int):
        super().__init__()
        bound = 1.0 / math.sqrt(in_features)
        self.weight = nn.Parameter(torch.empty(groups, in_features, out_features).uniform_(-bound, bound))
        self.bias = nn.Parameter(torch.zeros(groups, out_features))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``x``: ``(B, G, *, I)`` -> ``(B, G, *, O)``."""
        return per_group_linear(x, self.weight, self.bias)


def per_group_linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    """:class:`PerGroupLinear` with the given ``weight`` ``(G, I, O)`` and ``bias`` ``(G, O)`` (e.g. a
    subset of its output columns): ``(B, G, *, I)`` -> ``(B, G, *, O)``."""
    B, G = x.shape[:2]
    c_in = x.shape[-1]
    flat = x.reshape(B, G, -1, c_in).transpose(0, 1).reshape(G, -1, c_in)  # (G, B n, I); a view when B = 1
    y = torch.baddbmm(bias.unsqueeze(1), flat, weight)  # (G, B n, O)
    return y.reshape(G, B, -1, y.shape[-1]).transpose(0, 1).reshape(*x.shape[:-1], -1)


def _mlp(c_in: int, hidden: int, layers: int = 2) -> nn.Sequential:
    mods: list[nn.Module] = []
    for _ in range(layers):
        mods += [nn.Linear(c_in, hidden), nn.ReLU(inplace=True)]
        c_in = hidden
    return nn.Sequential(*mods)


class UCOPENet(nn.Module):
    """U-COPE for one category (see the module docstring).

    Args:
        cfg: :class:`ModelConfig`.
    """

    def __init__(self, cfg: ModelConfig):
        super().__init__()
        self.cfg = cfg
        K, J, H = cfg.num_parts, cfg.num_joints, cfg.hidden
        self.encoder = PointNet2Encoder(cfg.encoder)
        C = self.encoder.out_channels
        self.num_classes = K + 1 if cfg.background_class else K  # segmentation classes (the last is "background")
        self.mask_head = (
            nn.Sequential(nn.Linear(C, H), nn.ReLU(inplace=True), nn.Linear(H, self.num_classes))
            if self.num_classes > 1
            else None
        )
        self._build_pose_heads(C, K, H)
        if J > 0:
            self.joint_mlp = _mlp(C, H, 2)
            self.joint_out = PerGroupLinear(J, H, 8)
        pri = cfg.priors
        self.register_buffer("vote_range", torch.tensor(pri.vote_range_m, dtype=torch.float32), persistent=False)
        self.register_buffer("mean_size", torch.tensor(pri.mean_size_m, dtype=torch.float32), persistent=False)
        self.register_buffer("joint_parent_idx", torch.tensor([j.parent for j in pri.joints], dtype=torch.long), persistent=False)
        self.register_buffer("joint_child_idx", torch.tensor([j.child for j in pri.joints], dtype=torch.long), persistent=False)
        self.register_buffer("symmetric", torch.tensor(pri.symmetric, dtype=torch.bool), persistent=False)
        self.norm_scale = float(pri.norm_scale_m)

    def _build_pose_heads(self, C: int, K: int, H: int) -> None:
        """The pair ("PPF") encoder: per pair and part, the voting parameters and the part score."""
        self.out_sizes = {
            "mu_logits": self.cfg.mu_bins,
            "nu_logits": self.cfg.nu_bins,
            "alpha_logits": self.cfg.angle_bins,
            "beta_logits": self.cfg.angle_bins,
            "sign_logits": 2,
            "gamma": 3,
            "part_score": 1,
        }
        self.pair_point = nn.Linear(C, 2 * H, bias=False)  # [W_a F_i ; W_b F_j], applied per point
        self.pair_geo = nn.Linear(4 + K, H)  # PPF + part one-hot, with the first layer's bias
        self.pair_mlp = nn.Sequential(
            nn.ReLU(inplace=True), nn.Linear(H, H), nn.ReLU(inplace=True), nn.Linear(H, H), nn.ReLU(inplace=True)
        )
        self.pair_out = PerGroupLinear(K, H, sum(self.out_sizes.values()))

    # ------------------------------------------------------------------------------------------ forward
    def encode(self, points: torch.Tensor, normals: torch.Tensor, fps_idx=None) -> dict[str, torch.Tensor]:
        """Point features and part masks.

        Args:
            points: ``(B, N, 3)`` camera frame, metres; normals: ``(B, N, 3)`` unit (any sign).
            fps_idx: optional precomputed FPS indices (see :class:`PointNet2Encoder`).

        Returns:
            ``feats`` ``(B, N, C)`` (F1), ``masks`` ``(B, N, K)``, and, with a segmentation branch (K >= 2
            or a background class), ``seg_logits`` ``(B, N, K)`` (``(B, N, K + 1)`` with the background class).
        """
        if points.ndim != 3 or points.shape[-1] != 3 or normals.shape != points.shape:
            raise InputError(f"points and normals must both be (B, N, 3), got {tuple(points.shape)} and {tuple(normals.shape)}")
        centroid = points.mean(dim=1, keepdim=True)
        x = (points - centroid) / self.norm_scale
        f1 = self.encoder(x, normals, fps_idx)
        out = {"feats": f1}
        if self.mask_head is not None:
            logits = self.mask_head(f1)
            out["seg_logits"] = logits
            out["masks"] = logits.softmax(-1)[..., : self.cfg.num_parts]
        else:
            out["masks"] = f1.new_ones(*f1.shape[:2], 1)
        return out

    def pair_heads(
        self,
        enc: dict,
        points: torch.Tensor,
        normals: torch.Tensor,
        pair_idx: torch.Tensor,
        heads=None,
        return_hidden: bool = False,
    ) -> dict[str, torch.Tensor]:
        """Per-pair voting outputs for every part.

        Args:
            enc: the output of :meth:`encode`.
            pair_idx: ``(B, K, M, 2)`` int64 indices of pair points for each part's heads.
            heads: the output names to compute (default: all). Inference computes ``mu``, ``nu``,
                ``gamma`` and ``part_score`` for every pair and the axis heads (:data:`AXIS_HEADS`) later,
                with :meth:`pair_outputs`, for the few hundred pairs that vote the axes.
            return_hidden: also return ``pair_hidden`` ``(B, K, M, H)``, the input of the output layer.

        Returns:
            ``mu_logits``, ``nu_logits`` ``(B, K, M, bins)``, ``alpha_logits``, ``beta_logits``
            ``(B, K, M, angle_bins)``, ``sign_logits`` ``(B, K, M, 2)`` (up, right), ``gamma``
            ``(B, K, M, 3)``, ``part_score`` ``(B, K, M)`` logit (those in ``heads``).
        """
        K, H = self.cfg.num_parts, self.cfg.hidden
        B, N = points.shape[:2]
        if pair_idx.ndim != 4 or pair_idx.shape[:2] != (B, K) or pair_idx.shape[-1] != 2:
            raise InputError(f"pair_idx must be (B={B}, K={K}, M, 2), got {tuple(pair_idx.shape)}")
        M = pair_idx.shape[2]
        f1, masks = enc["feats"], enc["masks"]
        # The first layer is linear: (F1 * m_k) W = m_k (F1 W), so it is applied once per point (proj), and
        # part k's pair (i, j) takes m_k[i] proj_a[i] + m_k[j] proj_b[j]. pair_geo of [PPF, part one-hot] =
        # PPF W_g^T + (W_onehot[:, k] + bias): a constant per part.
        proj = self.pair_point(f1)  # (B, N, 2H)
        W = self.pair_geo.weight  # (H, 4 + K)
        part_const = (W[:, 4:].T + self.pair_geo.bias).view(1, K, 1, H)
        flat = pair_idx.reshape(B, K * M * 2)
        bidx = torch.arange(B, device=points.device)[:, None]
        if M < N:  # training (hundreds of pairs a part): gather the pairs' rows, then weight them by their part's mask
            b3, kk = bidx.view(B, 1, 1), torch.arange(K, device=points.device).view(1, K, 1)
            ia, ib = pair_idx[..., 0], pair_idx[..., 1]  # (B, K, M)
            h = (masks[b3, ia, kk].unsqueeze(-1) * proj[..., :H][b3, ia] + part_const).reshape(B * K * M, H)
            h += (masks[b3, ib, kk].unsqueeze(-1) * proj[..., H:][b3, ib]).reshape(B * K * M, H)
        else:  # inference (thousands of pairs a part): weight every point once per part, then gather the pairs' rows
            mk = masks.permute(0, 2, 1).unsqueeze(-1)  # (B, K, N, 1)
            pa = (mk * proj[:, None, :, :H] + part_const).reshape(B * K * N, H)
            pb = (mk * proj[:, None, :, H:]).reshape(B * K * N, H)
            offs = (torch.arange(B * K, device=points.device) * N).view(B, K, 1)  # row of (b, k, point 0)
            h = pa.index_select(0, (pair_idx[..., 0] + offs).reshape(-1))  # (B K M, H), in place from here
            h += pb.index_select(0, (pair_idx[..., 1] + offs).reshape(-1))
        pts = points[bidx, flat].reshape(B, K, M, 2, 3)
        nrm = normals[bidx, flat].reshape(B, K, M, 2, 3)
        geo = pair_features(pts[..., 0, :], pts[..., 1, :], nrm[..., 0, :], nrm[..., 1, :], self.norm_scale)
        h.addmm_(geo.reshape(-1, 4), W[:, :4].T)
        h = self.pair_mlp(h.view(B, K, M, H))
        out = self.pair_outputs(h, heads)
        if return_hidden:
            out["pair_hidden"] = h
        return out

    def pair_outputs(self, hidden: torch.Tensor, heads=None, part: int | None = None) -> dict[str, torch.Tensor]:
        """The output layer of the pair encoder, for some of its heads.

        Args:
            hidden: ``(B, K, M, H)`` (``pair_hidden`` of :meth:`pair_heads`), or with ``part`` given,
                ``(M', H)`` hidden features of that part's pairs.
            heads: output names (default: all, see :meth:`pair_heads`).
            part: the part index whose output layer applies to ``(M', H)`` rows.

        Returns:
            the named outputs, shaped as in :meth:`pair_heads` (or ``(M', ...)`` for one part).
        """
        names = list(self.out_sizes) if heads is None else [n for n in self.out_sizes if n in heads]
        unknown = set(heads or ()) - set(self.out_sizes)
        if unknown:
            raise InputError(f"unknown pair heads {sorted(unknown)} (known: {list(self.out_sizes)})")
        starts, start = {}, 0  # each head's first column in the full output layer
        for name, n in self.out_sizes.items():
            starts[name] = start
            start += n
        if part is None and len(names) == len(self.out_sizes):
            y = self.pair_out(hidden)
        else:
            idx = torch.cat([torch.arange(starts[n], starts[n] + self.out_sizes[n]) for n in names]).to(hidden.device)
            w, b = self.pair_out.weight.index_select(-1, idx), self.pair_out.bias.index_select(-1, idx)
            y = per_group_linear(hidden, w, b) if part is None else torch.addmm(b[part], hidden, w[part])
            start = 0  # the selected heads' columns, packed in order
            for n in names:
                starts[n] = start
                start += self.out_sizes[n]
        out = {n: y[..., starts[n] : starts[n] + self.out_sizes[n]] for n in names}
        if "part_score" in out:
            out["part_score"] = out["part_score"].squeeze(-1)
        return out

    def joint_heads(self, enc: dict) -> dict[str, torch.Tensor]:
        """Per-point joint outputs (K >= 2): ``joint_heat``, ``joint_score`` logits ``(B, J, N)``,
        ``joint_offset`` ``(B, J, N, 3)`` metres, ``joint_dir`` ``(B, J, N, 3)`` unit."""
        f1, masks = enc["feats"], enc["masks"]
        m = masks[..., self.joint_parent_idx] + masks[..., self.joint_child_idx]  # (B, N, J)
        h = self.joint_mlp(f1.unsqueeze(1) * m.permute(0, 2, 1).unsqueeze(-1))  # (B, J, N, H)
        y = self.joint_out(h)
        return {
            "joint_heat": y[..., 0],
            "joint_offset": y[..., 1:4] * self.norm_scale,
            "joint_dir": F.normalize(y[..., 4:7], dim=-1, eps=1e-8),
            "joint_score": y[..., 7],
        }

    def forward(
        self, points: torch.Tensor, normals: torch.Tensor, pair_idx: torch.Tensor | None = None, fps_idx=None
    ) -> dict[str, torch.Tensor]:
        """All outputs: those of :meth:`encode`, :meth:`joint_heads` (K >= 2) and, given ``pair_idx``,
        :meth:`pair_heads`."""
        enc = self.encode(points, normals, fps_idx)
        out = dict(enc)
        if self.cfg.num_joints > 0:
            out.update(self.joint_heads(enc))
        if pair_idx is not None:
            out.update(self.pair_heads(enc, points, normals, pair_idx))
        return out

    # --------------------------------------------------------------------------------------------- loss
    def compute_loss(self, batch: dict) -> tuple[torch.Tensor, dict[str, float]]:
        """Equation (7): ``(1/K) (l_joint sum_j L_joint + l_seg sum_k L_seg + l_pose sum_k L_pose)``.

        ``batch`` is a collated batch of :class:`ucope.model.batch.TrainingItems`. Returns the scalar
        loss and a dict of float logs (the loss terms, and interpretable errors such as the mean
        absolute error of the decoded ``mu`` in metres).
        """
        out = self(batch["points"], batch["normals"], batch["pair_idx"], batch.get("fps_idx"))
        return self.loss_from_outputs(out, batch)

    def loss_from_outputs(self, out: dict, batch: dict) -> tuple[torch.Tensor, dict[str, float]]:
        cfg = self.cfg
        K, J = cfg.num_parts, cfg.num_joints
        logs: dict[str, float] = {}
        seg = self._seg_loss(out, batch, logs) if self.mask_head is not None else out["feats"].new_zeros(())
        pose = self._pose_loss(out, batch, logs)
        joint = self._joint_loss(out, batch, logs) if J > 0 else out["feats"].new_zeros(())
        total = (cfg.lambda_joint * joint + cfg.lambda_seg * seg + cfg.lambda_pose * pose) / K
        logs.update(loss=float(total.detach()), pose=float(pose.detach()), seg=float(seg.detach()), joint=float(joint.detach()))
        return total, logs

    def _seg_loss(self, out, batch, logs) -> torch.Tensor:
        """``cfg.seg_weighting``: ``"balanced"``, the sum over classes (the parts, and the background class
        when the model has one) of the mean cross-entropy of that class's points; ``"points"``, the number of
        classes x the mean cross-entropy over all points (the same scale)."""
        C = self.num_classes
        logits, labels = out["seg_logits"], batch["part_labels"]
        ce = F.cross_entropy(logits.reshape(-1, C), labels.reshape(-1), reduction="none")
        if self.cfg.seg_weighting == "points":
            per_part = ce.mean().expand(C)
        else:
            onehot = F.one_hot(labels.reshape(-1), C).to(ce.dtype)  # (BN, C)
            per_part = (onehot * ce[:, None]).sum(0) / onehot.sum(0).clamp_min(1.0)
        with torch.no_grad():
            logs["seg_acc"] = float((logits.argmax(-1) == labels).float().mean())
        return per_part.sum()

    def _pose_loss(self, out, batch, logs) -> torch.Tensor:
        cfg = self.cfg
        K = cfg.num_parts
        pts, nrm, labels, pair_idx = batch["points"], batch["normals"], batch["part_labels"], batch["pair_idx"]
        B, _, M, _ = pair_idx.shape
        bidx = torch.arange(B, device=pts.device)[:, None]
        flat = pair_idx.reshape(B, -1)
        p = pts[bidx, flat].reshape(B, K, M, 2, 3)
        lab = labels[bidx, flat].reshape(B, K, M, 2)
        n_a = nrm[bidx, flat].reshape(B, K, M, 2, 3)[..., 0, :]
        t = pair_vote_targets(
            p[..., 0, :], p[..., 1, :], n_a, batch["cam_from_part"], batch["size_m"], self.mean_size.unsqueeze(0)
        )
        kk = torch.arange(K, device=pts.device).view(1, K, 1)
        same = (lab[..., 0] == kk) & (lab[..., 1] == kk)
        valid = (same & (t["dist"] > 1e-4)).to(pts.dtype)  # (B, K, M)
        V = self.vote_range.view(1, K, 1)
        nonsym = (~self.symmetric).to(pts.dtype).view(1, K, 1)

        def masked_mean(x, w):  # per part mean over the batch's valid pairs -> (K,)
            return (x * w).sum((0, 2)) / w.sum((0, 2)).clamp_min(1.0)

        # KL of the two-hot bin targets, without materialising them (two_hot_kl): B K M rows of up to 36 bins
        l_mu = masked_mean(two_hot_kl(out["mu_logits"], t["mu"], -V, V), valid)
        l_nu = masked_mean(two_hot_kl(out["nu_logits"], t["nu"], 0.0, V), valid)
        l_alpha = masked_mean(two_hot_kl(out["alpha_logits"], t["alpha"], 0.0, math.pi), valid)
        l_beta = masked_mean(two_hot_kl(out["beta_logits"], t["beta"], 0.0, math.pi), valid * nonsym)
        sign_bce = F.binary_cross_entropy_with_logits(out["sign_logits"], t["sign"], reduction="none")
        l_sign = masked_mean(sign_bce[..., 0], valid) + masked_mean(sign_bce[..., 1], valid * nonsym)
        g_err = (out["gamma"] - t["gamma"].unsqueeze(2)).pow(2).mean(-1)
        l_gamma = masked_mean(g_err, valid)
        l_score = F.binary_cross_entropy_with_logits(out["part_score"], same.to(pts.dtype), reduction="none").mean((0, 2))
        per_part = l_mu + l_nu + l_alpha + l_beta + l_sign + l_gamma + l_score
        with torch.no_grad():
            centres_mu = bin_centres(-1.0, 1.0, cfg.mu_bins, device=pts.device)
            mu_hat = (out["mu_logits"].softmax(-1) * centres_mu).sum(-1) * V
            centres_a = bin_centres(0.0, math.pi, cfg.angle_bins, device=pts.device)
            a_hat = (out["alpha_logits"].softmax(-1) * centres_a).sum(-1)
            w = valid
            den = float(w.sum().clamp_min(1.0))
            logs.update(
                mu=float(l_mu.mean()),
                nu=float(l_nu.mean()),
                alpha=float(l_alpha.mean()),
                beta=float(l_beta.mean()),
                sign=float(l_sign.mean()),
                gamma=float(l_gamma.mean()),
                part_score=float(l_score.mean()),
                mu_err_m=float(((mu_hat - t["mu"]).abs() * w).sum() / den),
                alpha_err_deg=float(((a_hat - t["alpha"]).abs() * w).sum() / den * 180.0 / math.pi),
                part_score_acc=float(((out["part_score"] > 0) == same).float().mean()),
            )
        return per_part.sum()

    def _joint_loss(self, out, batch, logs) -> torch.Tensor:
        """Equations (1)-(3) on the heat-weighted pivot and the score-weighted direction, plus the
        per-point heatmap, offset, direction and joint-score (equation (9)) terms."""
        pts, labels = batch["points"], batch["part_labels"]
        pivot, axis, jtype = batch["joint_pivot"], batch["joint_axis"], batch["joint_type"]
        s = self.norm_scale
        t = joint_point_targets(
            pts, labels, pivot, axis, jtype, self.joint_parent_idx, self.joint_child_idx, self.cfg.heat_radius * s
        )
        if self.cfg.background_class:  # background points are nobody's hinge
            t["heat"] = t["heat"] * (labels < self.cfg.num_parts).to(pts.dtype).unsqueeze(1)
        heat_l, score_l = out["joint_heat"], out["joint_score"]
        l_heat = F.binary_cross_entropy_with_logits(heat_l, t["heat"], reduction="none").mean(-1)  # (B, J)
        l_score = F.binary_cross_entropy_with_logits(score_l, t["score"], reduction="none").mean(-1)
        near = (t["heat"] > 0).to(pts.dtype) * (jtype == REVOLUTE).to(pts.dtype).unsqueeze(-1)
        off_err = F.smooth_l1_loss(out["joint_offset"] / s, t["offset"] / s, reduction="none", beta=0.05).sum(-1)
        l_off = (off_err * near).sum(-1) / near.sum(-1).clamp_min(1.0)
        u = axis.unsqueeze(2)  # (B, J, 1, 3)
        on = t["score"]
        dir_err = (out["joint_dir"] - u).norm(dim=-1)
        l_dir_pt = (dir_err * on).sum(-1) / on.sum(-1).clamp_min(1.0)
        # Equation (1): heat-weighted pivot; equation (3) on it and on the mean direction.
        H = torch.sigmoid(heat_l)
        p_hat = (H.unsqueeze(-1) * (pts.unsqueeze(1) + out["joint_offset"])).sum(2) / H.sum(-1, keepdim=True).clamp_min(1e-6)
        l_pvt = torch.cross(p_hat - pivot, axis, dim=-1).norm(dim=-1) / s * (jtype == REVOLUTE).to(pts.dtype)
        w = torch.sigmoid(score_l)
        u_hat = F.normalize((w.unsqueeze(-1) * out["joint_dir"]).sum(2), dim=-1, eps=1e-8)
        l_dir = (u_hat - axis).norm(dim=-1)
        per_joint = (l_pvt + l_dir + l_heat + l_score + l_off + l_dir_pt).mean(0)  # (J,)
        with torch.no_grad():
            cosang = (u_hat * axis).sum(-1).clamp(-1, 1)
            rev = (jtype == REVOLUTE).to(pts.dtype)
            logs.update(
                joint_heat=float(l_heat.mean()),
                joint_score=float(l_score.mean()),
                joint_offset=float(l_off.mean()),
                joint_pivot=float(l_pvt.mean()),
                joint_dir=float(l_dir.mean()),
                axis_err_deg=float(torch.rad2deg(torch.arccos(cosang)).mean()),
                pivot_err_m=float((l_pvt * s).sum() / rev.sum().clamp_min(1.0)),
            )
        return per_joint.sum()
