"""The :class:`Estimator`: a trained network and its pipeline, from a point cloud (or RGB-D frame) to a
:class:`ucope.estimation.result.PoseResult`. :meth:`Estimator.predict` prepares the cloud (checks, units, the roll
to a given ``up``, a canonical order and subset), then the search policy (:mod:`ucope.estimation.search`) makes one
or more estimates. Each pass of an estimate runs the cloud stages, rescales the cloud into the model's training
sizes where needed, runs the network on ``num_points`` of its points (one draw: part masks, segmentation, joint
heads, the pair heads on ``num_pairs`` pairs) and then the pose stages of the model's pipeline
(:mod:`ucope.stages`), and scales and turns the result back. ``result.stages`` says what each stage of the estimate
that stands did; ``result.timings_ms`` sums every estimate made. Every random draw comes from ``seed``.
"""

from __future__ import annotations

import hashlib
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from ..errors import InputError
from ..geometry.denoise import surface_noise
from ..geometry.normals import estimate_normals
from ..geometry.planes import find_support_plane
from ..geometry.sampling import random_subset
from ..model.checkpoint import find_model, load_model
from ..model.network import UCOPENet
from ..model.pointnet2 import numpy_fps_indices
from ..stages import CloudState, PoseState, run, stage_params
from ..stages.flips import ShapeIndex
from ..threads import one_blas_thread
from ..vocab import AXIS_HEADS, VOTE_HEADS, JointType
from .inputs import NORMAL_K, label_points, prepare_points, rgbd_points, roll_to_up
from .pipeline import Pipeline
from .result import JointEstimate, PartEstimate, PoseResult
from .scales import extent_warnings, input_scale
from .search import Estimate, Pass, recrop, search

__all__ = ["Estimator", "MAX_INPUT_POINTS"]

MAX_INPUT_POINTS = 4096
"""Clouds above this many points are subsampled uniformly first (the density of the training views)."""
_TIMINGS = ("preprocess", "encoder", "pair_encoder", "voting", "total")


def _device(device) -> torch.device:
    """``device`` as a usable torch device, or an InputError naming the problem."""
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError) as e:
        raise InputError(f"device {device!r} is not a torch device ({e})") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"device {device!r}: no CUDA device is available here")
    if dev.type not in ("cpu", "cuda", "mps"):
        raise InputError(f"device {device!r}: use cpu, cuda or mps")
    return dev


class Estimator:
    """Estimates the 9D part poses, joints and segmentation of objects of one category.

    Everything it needs about the category comes from the model (``model.cfg.priors``) and its pipeline: it
    never imports the generators.

    Args:
        model: a trained :class:`ucope.model.network.UCOPENet` (or the regression baseline).
        pipeline: the model's :class:`ucope.estimation.pipeline.Pipeline` (:meth:`load` reads it from the model
            card); ``None``: the default stages for the model's structure, no calibration.
        stages: replaces the pipeline's stage list (names of :data:`ucope.stages.REGISTRY`, in order).
        overrides: ``{"stage.param": value}`` stage parameters and ``{"search.field": value}`` search settings,
            e.g. ``{"vote_parts.num_pairs": 5000, "search.restarts": 0}``.
        seed: seed of the subsampling and pair draws (an integer >= 0).
        device: torch device of the network (``"cpu"``, ``"cuda"``, ``"cuda:1"``...).

    Raises:
        InputError: an unknown stage or parameter, a value of the wrong type, a negative seed, an unknown or
            unavailable device, naming it.
    """

    def __init__(
        self, model: UCOPENet, pipeline: Pipeline | None = None, stages=None, overrides=None, seed: int = 0, device="cpu"
    ):
        if not isinstance(model, UCOPENet):
            raise InputError(f"model must be a ucope network (Estimator.load reads one from a file), got {type(model).__name__}")
        if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0):
            raise InputError(f"seed must be an integer >= 0, got {seed!r}")
        self.cfg, self.priors = model.cfg, model.cfg.priors
        base = pipeline if pipeline is not None else Pipeline.from_info(None, self.priors, self.cfg.head)
        self.pipeline = base.changed(stages=stages, overrides=overrides)
        if self.pipeline.calibration is not None and len(self.pipeline.calibration.part_bias) != self.cfg.num_parts:
            raise InputError(
                f"the calibration is for {len(self.pipeline.calibration.part_bias)} parts, the model has {self.cfg.num_parts}"
            )
        self.params = stage_params([*self.pipeline.stages, "vote_parts"], self.pipeline.params)
        self.device = _device(device)
        self.model = model.to(self.device).eval()
        self.seed = int(seed)
        self.shapes = ShapeIndex.from_priors(self.priors)
        self.name = self.cfg.category

    @classmethod
    def load(cls, model: str | os.PathLike, stages=None, overrides=None, seed: int = 0, device="cpu", drop=()) -> Estimator:
        """An estimator from a run folder / model JSON path, or the name of a shipped model (``Estimator.load("laptop")``;
        :func:`ucope.model.checkpoint.list_pretrained` lists them), with the model card's pipeline (``stages``,
        ``overrides``: as the constructor; ``drop``: stage names to leave out of the list)."""
        if not isinstance(model, str | os.PathLike) or not str(model):
            raise InputError(f"model must be a shipped model's name or a path, got {model!r}")
        net, meta = load_model(find_model(model))
        pipeline = Pipeline.from_info(meta.get("info"), net.cfg.priors, net.cfg.head).changed(stages=stages, drop=drop)
        est = cls(net, pipeline, None, overrides, seed, device)
        est.name = str(Path(model))
        return est

    @property
    def category(self) -> str:
        return self.cfg.category

    @property
    def calibration(self):
        return self.pipeline.calibration

    def predict(self, points, normals=None, units: str = "m", up=None) -> PoseResult:
        """Estimate the pose of the object whose (segmented) cloud ``points`` is.

        Args:
            points: ``(N, 3)`` or organised ``(H, W, 3)`` (NaN = no measurement): the object's points in the camera
                frame (OpenCV axes: x right, y down, z forward), in ``units``.
            normals: optional normals of the points' shape (any sign and length); estimated when ``None``.
            units: ``"m"`` (default), ``"cm"`` or ``"mm"``; results are always in metres.
            up: optional ``(3,)`` the world's up direction in the camera frame: the cloud is turned about the optical
                axis to an upright camera for the estimate (:func:`ucope.estimation.inputs.roll_to_up`), and the
                result turned back.

        Returns:
            a :class:`PoseResult`: ``part_labels`` has one entry per input point (an organised cloud flattened row
            by row), -1 for dropped ones and for those segmented as not the object.

        Raises:
            InputError: a cloud that cannot be one object in the camera frame
                (:func:`ucope.estimation.inputs.prepare_points`), or far outside the model's training sizes
                (:func:`ucope.estimation.scales.extent_warnings`, with a hint at the units).
        """
        with one_blas_thread():
            return self._predict(points, normals, units, up)

    def _predict(self, points, normals, units: str, up) -> PoseResult:
        """:meth:`predict` inside :func:`ucope.threads.one_blas_thread`."""
        t0 = time.perf_counter()
        roll = None if up is None else roll_to_up(up)
        prep = prepare_points(points, normals, MAX_INPUT_POINTS, self.seed, estimate=False, units=units, rotation=roll)
        given = "given"
        if up is None and self.pipeline.search.roll_from_plane:
            roll = self._roll_from_plane(prep.points)
            if roll is not None:
                prep = prepare_points(points, normals, MAX_INPUT_POINTS, self.seed, estimate=False, units=units, rotation=roll)
                given = "estimated from the support plane in view"
        pts, nrm, raw = prep.points, prep.normals, prep.raw
        warnings = list(prep.warnings)
        turned_deg = 0.0 if roll is None else float(np.degrees(np.arctan2(roll[1, 0], roll[0, 0])))
        if abs(turned_deg) > 1.0:
            warnings.append(
                f"the cloud was turned {turned_deg:.0f} degrees about the optical axis "
                f"to put the {given} up direction at image up for the estimate; the result is turned back"
            )
        t_prep = time.perf_counter() - t0
        memo: dict = {}  # passes already made, by their input and scale (the searches repeat some)

        def estimate(normalise, draw):
            return self._estimate(pts, nrm, units, roll, len(raw), normalise=normalise, memo=memo, draw=draw)

        est, timings, made = search(self.pipeline.search, estimate, self.calibration is not None)
        final = est.final
        warnings = list(dict.fromkeys(warnings + est.warnings + final.input_warnings + final.warnings))
        t4 = time.perf_counter()
        usable = prep.finite.copy()
        for plane in est.planes:
            if plane is not None:
                usable &= ~plane.removes(np.nan_to_num(raw))
        all_labels = label_points(raw, usable, pts, est.labels)
        timings["preprocess"] += 1e3 * (t_prep + time.perf_counter() - t4)
        timings["total"] = 1e3 * (time.perf_counter() - t0)
        return PoseResult(
            category=self.cfg.category,
            parts=final.parts,
            joints=final.joints,
            part_labels=all_labels,
            timings_ms=timings,
            model=self.name,
            num_points=len(raw),
            warnings=warnings,
            features=final.features,
            stages=[r.to_dict() for r in final.stages],
            estimates=made,
        )

    def _roll_from_plane(self, pts: np.ndarray) -> np.ndarray | None:
        """The roll to take out (:func:`roll_to_up`) where ``pts`` hold a support plane whose normal shows a camera
        roll above ``search.roll_min_deg``; ``None`` otherwise."""
        plane = find_support_plane(pts, seed=self.seed)
        if plane is None:
            return None
        try:
            roll = roll_to_up(plane.normal)
        except InputError:  # the camera looks straight down at the plane: no roll to read
            return None
        return roll if abs(np.degrees(np.arctan2(roll[1, 0], roll[0, 0]))) > self.pipeline.search.roll_min_deg else None

    def predict_rgbd(self, depth, intrinsics, mask=None, box=None, depth_scale: float = 1000.0, mask_label=None) -> PoseResult:
        """Estimate the pose from a depth image of the object: :func:`rgbd_points` then :meth:`predict`."""
        return self.predict(rgbd_points(depth, intrinsics, mask, box, depth_scale, mask_label))

    def predict_sample(self, sample: dict) -> PoseResult:
        """Estimate on a data-set sample (its points and normals; the ground truth is not used)."""
        return self.predict(sample["points"], sample["normals"])

    def _estimate(self, pts, nrm, units, roll, num_input: int, normalise=None, memo=None, draw: int = 0) -> Estimate:
        """One estimate of the prepared cloud ``pts`` (one or two passes: :func:`ucope.estimation.search.recrop`) at the
        scale ``normalise`` gives (:meth:`input_scale`) and on draw ``draw`` of the network's points."""

        def run_pass(p, n, k, rescale, **kw):
            return self._pass(p, n, units, roll, k, rescale, normalise=normalise, memo=memo, draw=draw)

        rescaled = lambda p: self.input_scale(p, normalise)[0] != 1.0  # noqa: E731
        return recrop(self.pipeline.search, run_pass, rescaled, pts, nrm, num_input, normalise=normalise)

    def _pass(self, pts, nrm, units, roll, num_input: int, rescale: bool, normalise=None, memo=None, draw: int = 0) -> Pass:
        """One pass on a prepared cloud ``pts`` ``(P, 3)`` float32 (camera frame, metres, turned by ``roll``) standing
        for ``num_input`` points of the user's cloud: cloud stages, extent checks, rescaling (:meth:`input_scale`
        with ``normalise``), network on draw ``draw``, pose stages, back to the input's frame. A pass already in
        ``memo`` (same points, scale and draw) is returned from it with zero timings; the cloud stages run once per
        points in ``memo`` (their records repeat with zero time)."""
        t0 = time.perf_counter()
        digest = hashlib.blake2b(np.ascontiguousarray(pts).tobytes(), digest_size=16)
        if nrm is not None:
            digest.update(np.ascontiguousarray(nrm).tobytes())
        cloud_key = ("cloud", digest.hexdigest())  # the cloud stages depend on the points and the seed alone
        if memo is not None and cloud_key in memo:
            cloud, cloud_records = memo[cloud_key]
            records = [replace(r, ms=0.0) for r in cloud_records]
        else:
            cloud = CloudState(pts, nrm, seed=self.seed)
            records = run(self.pipeline.stages, cloud, self.params, phase="cloud")
            if memo is not None:
                memo[cloud_key] = (cloud, records)
        keep = cloud.keep
        pts_c = cloud.points[keep]
        nrm_c = None if nrm is None else nrm[keep]
        input_warnings = cloud.input_warnings + extent_warnings(self.priors, pts_c, units)
        scale, centre = self.input_scale(pts_c, normalise) if rescale else (1.0, np.zeros(3))
        key = (digest.hexdigest(), num_input, scale, centre.tobytes(), draw)
        if memo is not None and key in memo:
            return replace(memo[key], timings=dict.fromkeys(memo[key].timings, 0.0))
        warnings = list(cloud.warnings)
        if scale != 1.0:
            pts_c = (centre + scale * (pts_c - centre)).astype(np.float32)
            warnings.append(
                f"the cloud was scaled by {scale:.3g} into the {self.category} model's training sizes for the estimate; "
                "its poses and sizes are scaled back"
            )
        noise_key = ("surface_noise", digest.hexdigest())

        def noise_m() -> float:  # metres of the input; the passes of one prediction on the same points share it
            if memo is None or noise_key not in memo:
                value = surface_noise(pts_c) / scale
                if memo is None:
                    return value
                memo[noise_key] = value
            return memo[noise_key]

        t1 = time.perf_counter()
        state, t_enc = self._network(pts_c, nrm_c, draw)
        t3 = time.perf_counter()
        state.num_input, state.camera, state.scale, state.noise_m = num_input, centre * (1.0 - scale), scale, noise_m
        state.calibration, state.shapes = self.calibration, self.shapes
        state.warnings = warnings
        records += run(self.pipeline.stages, state, self.params)
        made = self._finish(state, centre, roll, pts, keep, input_warnings, records)
        made.plane = cloud.plane
        t5 = time.perf_counter()
        made.timings = {
            "preprocess": 1e3 * (t1 - t0) + made.timings["preprocess"],
            "encoder": 1e3 * (t_enc - t1),
            "pair_encoder": 1e3 * (t3 - t_enc),
            "voting": 1e3 * (t5 - t3) - made.timings["preprocess"],
            "total": 1e3 * (t5 - t0),
        }
        if memo is not None:
            memo[key] = made
        return made

    def _network(self, pts: np.ndarray, nrm, draw: int) -> tuple[PoseState, float]:
        """The network on one draw of ``num_points`` of ``pts`` (seeded by ``seed`` and ``draw``): a :class:`PoseState`
        with its outputs, pairs and segmentation, and the time the encoder finished."""
        cfg = self.cfg
        rng = np.random.default_rng(np.random.SeedSequence(entropy=self.seed, spawn_key=(2,) if draw == 0 else (2, draw)))
        sub = random_subset(len(pts), cfg.num_points, rng)
        p_net = pts[sub]
        n_net = estimate_normals(pts, k=NORMAL_K, rows=sub) if nrm is None else nrm[sub]  # neighbours from the whole cloud
        fps = [torch.from_numpy(f)[None].to(self.device) for f in numpy_fps_indices(p_net, cfg.encoder.npoints)]
        P = torch.from_numpy(p_net)[None].to(self.device)
        Nn = torch.from_numpy(n_net)[None].to(self.device)
        pair_idx = axis_heads = None
        with torch.no_grad():
            enc = self.model.encode(P, Nn, fps)
            out = dict(enc)
            if cfg.num_joints > 0:
                out.update(self.model.joint_heads(enc))
            labels = enc["seg_logits"][0].argmax(-1).cpu().numpy() if "seg_logits" in enc else np.zeros(len(p_net), np.int64)
            t_enc = time.perf_counter()
            if cfg.head == "regression":  # the baseline: no pairs, no voting
                out.update(self.model.regress(enc, P))
            else:
                pair_idx = self._sample_pairs(labels, rng)
                out.update(
                    self.model.pair_heads(
                        enc, P, Nn, torch.from_numpy(pair_idx)[None].to(self.device), heads=VOTE_HEADS, return_hidden=True
                    )
                )
                hidden = out.pop("pair_hidden")[0]  # (K, M, H): the axis heads run later, on the pairs that vote the axes

                def axis_heads(k: int, rows: torch.Tensor) -> dict:
                    with torch.no_grad():
                        return self.model.pair_outputs(hidden[k].index_select(0, rows.to(hidden.device)), AXIS_HEADS, part=k)

        seg_prob = enc["seg_logits"][0].softmax(-1).cpu().numpy() if "seg_logits" in enc else None
        state = PoseState(self.priors, p_net, n_net, labels, seg_prob, outputs=out, pair_idx=pair_idx, axis_heads=axis_heads)
        return state, t_enc

    def _sample_pairs(self, labels: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``(K, M, 2)`` pair indices, ``M = num_pairs // K``: with ``vote_parts.segment_pairs``, both points of part
        ``k``'s pairs come from the points segmented as ``k`` (all points if fewer than 3 are)."""
        K = self.cfg.num_parts
        opts = self.params["vote_parts"]
        M = max(1, opts.num_pairs // K)
        out = np.empty((K, M, 2), dtype=np.int64)
        for k in range(K):  # a handful of parts
            own = np.flatnonzero(labels == k) if opts.segment_pairs else np.arange(len(labels))
            pool = own if len(own) >= 3 else np.arange(len(labels))
            out[k] = pool[rng.integers(0, len(pool), size=(M, 2))]
        return out

    def _finish(self, state: PoseState, centre, roll, pts_in, keep, input_warnings, records) -> Pass:
        """The pass's result in the input's frame: scores (carried parts halved), poses scaled and turned back,
        warnings, per-point labels of ``pts_in``."""
        t0 = time.perf_counter()
        pri, scale = self.priors, state.scale
        scores = np.asarray(state.votes["score"], np.float64) if state.score is None else state.score
        scores = np.where(state.carried, 0.5 * scores, scores)
        T = np.array(state.cam_from_part, np.float64)
        S = np.asarray(state.size_m, np.float64) / scale
        T[:, :3, 3] = centre + (T[:, :3, 3] - centre) / scale
        pivot = centre + (np.asarray(state.joint_pivot, np.float64) - centre) / scale
        prismatic = np.array([jp.type == JointType.PRISMATIC for jp in pri.joints], dtype=bool)
        q = np.where(prismatic, np.asarray(state.joint_state, np.float64) / scale, state.joint_state)
        axis = np.asarray(state.joint_axis, np.float64)
        p_net = (centre + (state.points - centre) / scale).astype(np.float32)
        if roll is not None:  # the labels below are carried over in the turned frame: p_net and pts stay in it
            T[:, :3, :] = np.einsum("ji,kjl->kil", roll, T[:, :3, :])
            pivot, axis = pivot @ roll, axis @ roll
        parts = [
            PartEstimate(
                k,
                pp.name,
                T[k],
                S[k],
                float(scores[k]),
                pp.symmetry,
                int(state.votes["num_pairs"][k]),
                float(state.votes["score"][k]),
            )
            for k, pp in enumerate(pri.parts)
        ]
        joints = [
            JointEstimate(
                jp.type.label,
                jp.parent,
                jp.child,
                pivot[j] if jp.type == JointType.REVOLUTE and np.all(np.isfinite(pivot[j])) else None,
                axis[j],
                float(q[j]),
                float(state.joint_score[j]),
            )
            for j, jp in enumerate(pri.joints)
        ]
        warnings = list(state.warnings)
        for j in np.flatnonzero(state.joint_clamped):
            warnings.append(
                f"joint {joints[j].parent}->{joints[j].child}: the voted state lay outside the category's limits; "
                "it was clamped onto them (and the child moved), its score halved"
            )
        cal = self.calibration
        if cal is not None and float(scores.min()) < cal.threshold:
            worst = int(np.argmin(scores))
            warnings.append(
                f"low confidence: part {parts[worst].label!r} is likely wrong (score {scores[worst]:.2f} below "
                f"the model's threshold {cal.threshold:.2f})"
            )
        background = float(np.mean(state.part_labels < 0))
        if background > 0.5:
            input_warnings.append(
                f"{100 * background:.0f} % of the points were segmented as not the object: is the cloud one segmented object?"
            )
        for k, pe in enumerate(parts):
            if np.count_nonzero(state.seg_labels == k) < 3:
                warnings.append(f"part {pe.label!r}: fewer than 3 points were segmented as it; its pose is a guess")
        labels = label_points(pts_in, keep, p_net, state.part_labels)
        ms = 1e3 * (time.perf_counter() - t0)
        timings = dict.fromkeys(_TIMINGS, 0.0) | {"preprocess": ms}
        return Pass(parts, joints, labels, None, state.features, warnings, input_warnings, timings, records)

    def input_scale(self, points: np.ndarray, normalise: float | None = None) -> tuple[float, np.ndarray]:
        """:func:`ucope.estimation.scales.input_scale` of ``points`` ``(N, 3)`` with this model's priors (1 when the
        pipeline does not rescale)."""
        return input_scale(self.priors, points, normalise, self.pipeline.search.rescale)
