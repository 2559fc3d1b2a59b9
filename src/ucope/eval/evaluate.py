"""Evaluating an estimator on a data set: per-sample errors, Table-2 / Table-1 shaped summaries.

:func:`evaluate` runs :meth:`ucope.Estimator.predict` on every sample of a (test) data set, measures
every metric of :mod:`ucope.eval.metrics` against the ground truth and summarises them in a report
(a JSON-friendly dict, ``format: "ucope-eval/1"``)::

    {"format": "ucope-eval/1", "model": ..., "head": "voting" | "regression", "category": ...,
     "part_names": [K], "part_symmetry": [K], "settings": {"seed", "pipeline"},
     "data": {"path", "split", "num_samples", "generator_version", "category_revision"},
     "parts": summarize_parts(...),          # per part mean / median errors and success fractions
     "joints": summarize_joints(...) | None,
     "segmentation": {"iou": [K], "accuracy"} | None,     # means over samples (K >= 2)
     "time_ms": {"mean": {stage: ms}, "median": {stage: ms}},
     "map": compute_map(...) | None,         # rigid (K = 1) categories: NOCS-style mAP, our exact protocol
     "map_nocs": compute_map(..., protocol="nocs") | None,   # the same under NOCS's reference protocol
     "map_records": [...] | None,            # their inputs (one GT, one prediction per view)
     "success": {"definition", "fraction",   # views with every part < 10 deg and < 10 % of its box diagonal
                 "in_view_fraction",         # ... every part the view shows (parts_in_view)
                 "num_objects", "interval_95_objects"},   # a cluster bootstrap over objects (object_interval)
     "view_bins": {"front" | "side" | "back": {"num_samples", "success", "success_in_view",
                                               "parts": summarize_parts(...),
                                               "seen_parts": summarize_parts(...)}},   # parts seen only
     "iou_method": ..., "hardware": {...}, "ucope_version": ...,
     "views": [view_record(...)],           # compact per-view records, always kept
     "samples": [{"index", "instance_id", "view_yaw_deg", "visible_points": [K], "parts": [part_errors],
                  "joints": [joint_errors], "segmentation_iou": [K], "time_ms"}]}

``seen_parts`` summarises, per view bin, each part over the views that show it: at least
:data:`SEEN_MIN_POINTS` of the view's points are the part's (``visible_points``, the ground-truth labels);
a part hidden in a view (a closed dishwasher door seen from behind, a drawer behind its cabinet) counts
there as missing (``num_missing``). Its pose is a guess that the points cannot check, so the errors of the
seen parts say how the estimate holds up from behind apart from what no view from there shows; likewise
``in_view_fraction`` / ``success_in_view`` count a view as a success when every part it shows is right.

:func:`format_report` prints it as the paper's tables print (rotation in degrees, translation in
metres, IoU in percent, time in seconds), means with medians beside them. :func:`rigid_figures`
recomputes a rigid category's per-part summary and both mAPs from its ``map_records`` alone (how the
committed reports' figures are refreshed when a metric changes). A mug whose handle is not visible is
evaluated as symmetric about y in its per-part errors as in its mAP (NOCS's rule). Frames and units as in
:mod:`ucope.eval.metrics`.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from ..versions import __version__
from .mean_ap import compute_map
from .metrics import (
    IOU_METHOD,
    joint_errors,
    part_errors,
    segmentation_accuracy,
    segmentation_iou,
    summarize_joints,
    summarize_parts,
)

__all__ = [
    "EVAL_FORMAT",
    "evaluate",
    "format_map_table",
    "format_report",
    "map_record_part_errors",
    "map_records_of",
    "mug_handle_visible",
    "mug_handle_kept",
    "nocs_class",
    "rigid_figures",
    "sample_errors",
    "SEEN_MIN_POINTS",
    "VIEW_BINS",
    "SUCCESS_ROT_DEG",
    "SUCCESS_TRANS_REL",
    "view_success",
    "object_interval",
    "view_record",
    "parts_in_view",
    "view_bin",
    "view_yaw_deg",
    "visible_points",
]

EVAL_FORMAT = "ucope-eval/1"

_STAGES = ("preprocess", "encoder", "pair_encoder", "voting", "total")


def nocs_class(category: str) -> str:
    """The NOCS class name of a rigid category (``laptop_rigid`` is NOCS's ``laptop``)."""
    return "laptop" if category == "laptop_rigid" else category


def mug_handle_visible(sample: Mapping, min_points: int = 20, margin_m: float = 0.002) -> bool:
    """Whether a mug sample's cloud shows its handle (NOCS evaluates a mug without a visible handle
    as symmetric about y).

    In the mug's frame (docs/conventions.md) the cup's body spans ``x in [-sx/2, -sx/2 + sz]`` (its
    diameter is the box's z extent) and the handle lies beyond it on the +x side; the handle is
    visible if at least ``min_points`` points of the cloud lie more than ``margin_m`` beyond the body.
    """
    T = np.asarray(sample["cam_from_part"], np.float64)[0]
    sx, _, sz = np.asarray(sample["size_m"], np.float64)[0]
    pts = np.asarray(sample["points"], np.float64)
    local = (pts - T[:3, 3]) @ T[:3, :3]
    return int(np.count_nonzero(local[:, 0] > -0.5 * sx + sz + margin_m)) >= int(min_points)


def mug_handle_kept(sample: Mapping, src: np.ndarray, min_points: int = 20) -> bool:
    """Whether a corrupted mug cloud still shows its handle (:func:`mug_handle_visible`).

    Judged on the clean positions of the object points the corruption kept, so that noise does not
    move points onto or off the handle, with the ``min_points`` threshold scaled by the fraction of the
    clean cloud kept (at least 1): a mug cut to 100 of its 2,000 points shows its handle with 1 of them.

    Args:
        sample: the clean sample: ``cam_from_part`` ``(1, 4, 4)``, ``size_m`` ``(1, 3)`` (metres) and
            ``points`` ``(N, 3)`` (camera frame, metres).
        src: ``(M,)`` int, for each point of the corrupted cloud the index of the clean point it came
            from, ``-1`` for an added one (:func:`ucope.data.corrupt.corrupt` applied to ``arange(N)``).

    Raises:
        InputError: ``src`` not a 1-D integer array, or an index outside ``[-1, N)``.
    """
    src = np.asarray(src)
    n = len(sample["points"])
    if src.ndim != 1 or (src.size and not np.issubdtype(src.dtype, np.integer)):
        raise InputError(f"src must be a 1-D integer array of clean-point indices, got shape {src.shape} and dtype {src.dtype}")
    if src.size and (src.min() < -1 or src.max() >= n):
        raise InputError(f"src indices must lie in [-1, {n}) (-1: an added point), got {src.min()}..{src.max()}")
    kept = np.unique(src[src >= 0])
    need = max(1, round(int(min_points) * len(kept) / max(n, 1)))
    clean = {"cam_from_part": sample["cam_from_part"], "size_m": sample["size_m"], "points": np.asarray(sample["points"])[kept]}
    return mug_handle_visible(clean, min_points=need)


def part_symmetry(category: str, symmetry: str, handle_visible: bool = True) -> str:
    """The symmetry a rigid part is evaluated with: its own, or ``"y"`` for a mug whose handle is not
    visible (NOCS's rule, the same in the per-part errors as in the mAP)."""
    return "y" if nocs_class(category) == "mug" and not handle_visible else symmetry


VIEW_BINS = {"front": (0.0, 45.0), "side": (45.0, 135.0), "back": (135.0, 180.0)}
"""View bins by the camera's absolute yaw about the object's y axis (degrees; 0 = in front, on +z)."""


SUCCESS_ROT_DEG, SUCCESS_TRANS_REL = 10.0, 0.10
"""A view succeeds when every part is within this rotation (deg) and translation (fraction of its
ground-truth box diagonal) of the truth (the success of issues #13 / #14 and of the calibrated scores)."""

SEEN_MIN_POINTS = 30
"""A part is *seen* in a view when at least this many of the view's points are its own (ground-truth labels;
about 1 % of a 4,096-point view): the view bins' ``seen_parts`` summaries."""


def visible_points(sample: Mapping, num_parts: int) -> list[int]:
    """``[K]`` how many of a data-set sample's points belong to each part (its ground-truth ``part_labels``;
    labels outside ``0..K-1`` are not counted)."""
    labels = np.asarray(sample["part_labels"]).reshape(-1)
    labels = labels[(labels >= 0) & (labels < num_parts)].astype(np.int64)
    return [int(n) for n in np.bincount(labels, minlength=num_parts)]


def view_success(part_errs: Sequence[Mapping], shown: Sequence[bool] | None = None) -> bool:
    """Whether every part of one view (its :func:`ucope.eval.metrics.part_errors`) is within
    :data:`SUCCESS_ROT_DEG` and :data:`SUCCESS_TRANS_REL`; with ``shown`` (one flag per part), every part
    flagged (those the view shows, :func:`parts_in_view`): the others' poses are guesses no point can check.

    Raises:
        InputError: ``shown`` of another length than ``part_errs``."""
    if shown is None:
        shown = [True] * len(part_errs)
    if len(shown) != len(part_errs):
        raise InputError(f"shown must flag each of the {len(part_errs)} parts, got {len(shown)} flags")
    return all(
        e["rotation_deg"] < SUCCESS_ROT_DEG and e["translation_norm"] < SUCCESS_TRANS_REL
        for e, s in zip(part_errs, shown, strict=True)
        if s
    )


def parts_in_view(visible: Sequence[int]) -> list[bool]:
    """Per part, whether a view shows it: at least :data:`SEEN_MIN_POINTS` of the view's points are its own
    (``visible``: the count per part, :func:`visible_points`)."""
    return [int(n) >= SEEN_MIN_POINTS for n in visible]


def object_interval(ok: Sequence[bool], objects: Sequence[str], level: float = 0.95, resamples: int = 2000) -> list[float]:
    """A ``level`` interval of the success fraction of views ``ok`` that resamples whole objects, not views
    (a cluster bootstrap over ``objects``, the instance of each view): views of one object succeed or fail
    together far more often than views of different ones. Deterministic (a fixed seed).

    Returns:
        ``[low, high]`` fractions (both the fraction itself with a single object)."""
    ok = np.asarray(ok, np.float64)
    names, inverse = np.unique(np.asarray(objects, dtype=str), return_inverse=True)
    hits = np.bincount(inverse, weights=ok, minlength=len(names))
    views = np.bincount(inverse, minlength=len(names)).astype(np.float64)
    if len(names) < 2:
        return [float(ok.mean()), float(ok.mean())]
    rng = np.random.default_rng(0)
    pick = rng.integers(0, len(names), size=(resamples, len(names)))
    frac = hits[pick].sum(axis=1) / views[pick].sum(axis=1)
    lo, hi = np.quantile(frac, [(1.0 - level) / 2.0, (1.0 + level) / 2.0])
    return [float(lo), float(hi)]


def view_record(index: int, instance: str, errors: Mapping, ok: bool) -> dict:
    """The compact per-view record every report keeps (``views``): the view's index, its object, its success, and
    per part ``[rotation_deg, translation_norm, iou]``, per joint ``[axis_deg, state_error]`` (rounded)."""

    def r(x, n=4):
        return None if x is None else round(float(x), n)

    return {
        "index": int(index),
        "object": str(instance),
        "success": bool(ok),
        "parts": [[r(e["rotation_deg"], 3), r(e["translation_norm"]), r(e["iou"])] for e in errors["parts"]],
        "joints": [None if j is None else [r(j["axis_deg"], 3), r(j["state_error"])] for j in errors["joints"]],
    }


def view_yaw_deg(sample: Mapping) -> float:
    """The camera's azimuth about the object's y axis, degrees in ``(-180, 180]``: 0 when the camera sits
    in front of the object (on its +z side, docs/conventions.md), +-180 behind it; from the sample's
    ``cam_from_object`` (the camera centre in the object frame)."""
    T = np.asarray(sample["cam_from_object"], np.float64)
    eye = -T[:3, :3].T @ T[:3, 3]
    return float(np.degrees(np.arctan2(eye[0], eye[2])))


def view_bin(yaw_deg: float) -> str:
    """``"front"``, ``"side"`` or ``"back"`` (:data:`VIEW_BINS`) of a yaw from :func:`view_yaw_deg`."""
    a = abs(float(yaw_deg))
    return "front" if a < 45.0 else "side" if a < 135.0 else "back"


def sample_errors(result, sample: Mapping) -> dict:
    """Every metric of one prediction against one data-set sample.

    Args:
        result: a :class:`ucope.estimation.result.PoseResult` of the sample's cloud (``part_labels`` one
            per sample point).
        sample: the sample dict (:mod:`ucope.data.sample`).

    Returns:
        ``{"parts": [K part_errors], "joints": [J joint_errors], "segmentation_iou": [K] | None,
        "segmentation_accuracy": float | None}`` (IoU ``None`` for a part absent from both).  A mug whose
        handle is not visible (:func:`mug_handle_visible`) gets the symmetric errors (angle between the y
        axes, best IoU over turns about y), as in its mAP.
    """
    K = len(sample["size_m"])
    if len(result.parts) != K or len(result.joints) != len(sample["joint_type"]):
        raise InputError(
            f"the result has {len(result.parts)} parts / {len(result.joints)} joints, the sample "
            f"{K} / {len(sample['joint_type'])}: model and data set are of different categories"
        )
    category = str(sample.get("category", ""))
    visible = mug_handle_visible(sample) if K == 1 and nocs_class(category) == "mug" else True
    parts = [
        part_errors(
            p.cam_from_part,
            p.size_m,
            sample["cam_from_part"][k],
            sample["size_m"][k],
            part_symmetry(category, p.symmetry, visible) if K == 1 else p.symmetry,
        )
        for k, p in enumerate(result.parts)
    ]
    # A joint whose ground-truth axis is unknown (NaN: BOP scenes have no joints) is not measured (None).
    joints = [
        joint_errors(
            j.axis, j.pivot_m, j.state, sample["joint_axis"][i], sample["joint_pivot"][i], sample["joint_state"][i], j.type
        )
        if np.all(np.isfinite(sample["joint_axis"][i]))
        else None
        for i, j in enumerate(result.joints)
    ]
    seg_iou = seg_acc = None
    if K > 1:
        labels = np.asarray(result.part_labels)
        iou = segmentation_iou(labels, sample["part_labels"], K)
        seg_iou = [None if np.isnan(v) else float(v) for v in iou]
        seg_acc = segmentation_accuracy(labels, sample["part_labels"])
    return {"parts": parts, "joints": joints, "segmentation_iou": seg_iou, "segmentation_accuracy": seg_acc}


def map_records_of(results: Sequence, samples: Sequence[Mapping]) -> list[dict]:
    """:func:`ucope.eval.metrics.compute_map` records (one GT and one prediction per view) of a rigid
    category's predictions; the prediction's score is its part score."""
    out = []
    for r, s in zip(results, samples, strict=False):
        cls = nocs_class(str(s["category"]))
        gt = {
            "class": cls,
            "cam_from_object": np.asarray(s["cam_from_part"][0], np.float64).tolist(),
            "size_m": np.asarray(s["size_m"][0], np.float64).tolist(),
        }
        if cls == "mug":
            gt["handle_visible"] = mug_handle_visible(s)
        p = r.parts[0]
        out.append(
            {
                "gt": [gt],
                "pred": [
                    {
                        "class": cls,
                        "cam_from_object": np.asarray(p.cam_from_part).tolist(),
                        "size_m": np.asarray(p.size_m).tolist(),
                        "score": float(p.score),
                    }
                ],
            }
        )
    return out


def map_record_part_errors(record: Mapping, symmetry: str) -> dict:
    """:func:`ucope.eval.metrics.part_errors` of a rigid view from its :func:`map_records_of` record.

    Args:
        record: ``{"gt": [one object], "pred": [one object]}`` as :func:`map_records_of` writes it.
        symmetry: the part's own symmetry (the report's ``part_symmetry[0]``); a mug whose ground truth
            says ``handle_visible: False`` is evaluated as ``"y"`` (:func:`part_symmetry`).

    Returns:
        The part_errors dict (rotation degrees, translation metres and normalised, exact IoU).
    """
    if len(record.get("gt", ())) != 1 or len(record.get("pred", ())) != 1:
        raise InputError("a rigid view's record must hold exactly one ground truth and one prediction")
    gt, pred = record["gt"][0], record["pred"][0]
    sym = part_symmetry(gt["class"], symmetry, bool(gt.get("handle_visible", True)))
    return part_errors(pred["cam_from_object"], pred["size_m"], gt["cam_from_object"], gt["size_m"], sym)


def rigid_figures(map_records: Sequence[Mapping], symmetry: str) -> dict:
    """A rigid category's per-part summary and mAPs, from its per-view records alone.

    Args:
        map_records: one record per view (:func:`map_records_of`), e.g. a report's ``map_records``.
        symmetry: the part's own symmetry (``"none"`` or ``"y"``).

    Returns:
        ``{"parts": summarize_parts(...), "map": compute_map(records), "map_nocs": compute_map(records,
        protocol="nocs")}``: what :func:`evaluate` writes under those keys for a rigid category (the
        report's per-view errors are exactly these, so a report can be refreshed without predicting again).
    """
    parts = [[map_record_part_errors(r, symmetry)] for r in map_records]
    return {
        "parts": summarize_parts(parts),
        "map": compute_map(map_records),
        "map_nocs": compute_map(map_records, protocol="nocs"),
    }


def evaluate(
    estimator, samples: Sequence[Mapping], progress: bool = True, data_info: Mapping | None = None, keep_samples: bool = True
) -> dict:
    """Predict on every sample and measure every metric (see the module docstring for the report).

    Args:
        estimator: a :class:`ucope.Estimator` (U-COPE or the regression baseline).
        samples: an indexable sequence of sample dicts of the estimator's category (e.g.
            ``load_dataset("data/laptop_test")``).
        progress: show a progress bar (tqdm, when installed).
        data_info: what to record about the data (path, split...), stored under ``"data"``.
        keep_samples: keep the per-sample records in the report.

    Returns:
        the report dict.
    """
    n = len(samples)
    if n == 0:
        raise InputError("cannot evaluate on an empty data set")
    cfg = estimator.cfg
    first = samples[0]
    if str(first.get("category")) != cfg.category:
        raise InputError(f"the data set holds {first.get('category')!r} samples, the model is a {cfg.category!r} model")
    bar = None
    if progress:
        try:
            from tqdm.auto import tqdm

            bar = tqdm(total=n, desc=f"eval {cfg.category}", unit="sample", dynamic_ncols=True)
        except ImportError:  # pragma: no cover - tqdm is an optional extra
            bar = None
    results, records, kept, bins, seen, instances = [], [], [], [], [], []
    for i in range(n):
        s = samples[i]
        r = estimator.predict_sample(s)
        e = sample_errors(r, s)
        yaw = view_yaw_deg(s)
        bins.append(view_bin(yaw))
        vis = visible_points(s, cfg.num_parts)
        seen.append(parts_in_view(vis))
        records.append(e)
        results.append(r)
        instances.append(str(s.get("instance_id", i)))
        if cfg.num_parts == 1:
            kept.append(s)
        if bar is not None:
            bar.update(1)
        if keep_samples:
            e["index"] = int(s.get("index", i))
            e["instance_id"] = str(s.get("instance_id", ""))
            e["view_yaw_deg"] = round(yaw, 3)
            e["visible_points"] = vis
            e["time_ms"] = {k: round(float(v), 3) for k, v in r.timings_ms.items()}
    if bar is not None:
        bar.close()
    times = {k: [float(r.timings_ms.get(k, 0.0)) for r in results] for k in _STAGES}
    seg = None
    if cfg.num_parts > 1:
        ious = np.array([[np.nan if v is None else v for v in e["segmentation_iou"]] for e in records], np.float64)
        seg = {
            "iou": [None if np.all(np.isnan(c)) else float(np.nanmean(c)) for c in ious.T],
            "accuracy": float(np.mean([e["segmentation_accuracy"] for e in records])),
        }
    rigid = cfg.num_parts == 1
    map_records = map_records_of(results, kept) if rigid else None
    ok = np.array([view_success(e["parts"]) for e in records])
    ok_in_view = np.array([view_success(e["parts"], shown) for e, shown in zip(records, seen, strict=True)])
    in_bin = {b: np.flatnonzero(np.array(bins) == b) for b in VIEW_BINS if b in bins}  # the views of each bin, in order
    report: dict[str, Any] = {
        "format": EVAL_FORMAT,
        "model": estimator.name,
        "head": cfg.head,
        "category": cfg.category,
        "part_names": list(cfg.part_names),
        "part_symmetry": [p.symmetry for p in cfg.priors.parts],
        "settings": {"seed": estimator.seed, "pipeline": estimator.pipeline.to_dict()},
        "data": dict(data_info or {}, num_samples=n),
        "parts": summarize_parts([e["parts"] for e in records]),
        "joints": summarize_joints([e["joints"] for e in records]) if cfg.num_joints else None,
        "segmentation": seg,
        "time_ms": {
            "mean": {k: float(np.mean(v)) for k, v in times.items()},
            "median": {k: float(np.median(v)) for k, v in times.items()},
        },
        "map": compute_map(map_records) if rigid else None,
        "map_nocs": compute_map(map_records, protocol="nocs") if rigid else None,
        "map_records": map_records,
        "success": {
            "definition": f"every part < {SUCCESS_ROT_DEG:g} deg and < {100 * SUCCESS_TRANS_REL:g} % of its box diagonal",
            "fraction": float(np.mean(ok)),
            "in_view_fraction": float(np.mean(ok_in_view)),
            "num_objects": len(set(instances)),
            "interval_95_objects": object_interval(ok, instances),
        },
        "view_bins": {
            b: {
                "num_samples": len(idx),
                "success": float(np.mean(ok[idx])),
                "success_in_view": float(np.mean(ok_in_view[idx])),
                "parts": summarize_parts([records[i]["parts"] for i in idx]),
                "seen_parts": summarize_parts(
                    [[p if shown else None for p, shown in zip(records[i]["parts"], seen[i], strict=True)] for i in idx]
                ),
            }
            for b, idx in in_bin.items()
        },
        "iou_method": IOU_METHOD,
        "ucope_version": __version__,
        "hardware": {"platform": platform.platform(), "cpu_count": os.cpu_count(), "torch_threads": _threads()},
        "views": [view_record(int(samples[i].get("index", i)), instances[i], records[i], bool(ok[i])) for i in range(n)],
        "samples": records if keep_samples else None,
    }
    return report


def _threads() -> int:
    import torch

    return int(torch.get_num_threads())


def _cells(values: Sequence, fmt: str, scale: float = 1.0) -> str:
    return ", ".join("-" if v is None else fmt.format(v * scale) for v in values)


def _stat_cells(stats: Mapping, fmt: str, scale: float = 1.0, unit: Sequence[str] | None = None) -> str:
    """``"mean cells (median cells)"`` of a ``{"mean": [...], "median": [...]}`` summary."""

    def cells(values):
        if unit is None:
            return _cells(values, fmt, scale)
        return ", ".join(
            "-" if v is None else (f"{v:.1f} deg" if u == "deg" else f"{v:.3f} m") for v, u in zip(values, unit, strict=False)
        )

    return f"{cells(stats['mean'])}  (median {cells(stats['median'])})"


def format_report(report: Mapping) -> str:
    """A Table-2 shaped text table of a report, means with medians beside them (and both mAP tables of a
    rigid category, Table-1 shaped).

    Args:
        report: an :func:`evaluate` report.

    Returns:
        The text; each error row reads ``means  (median medians)``, one value per part or joint.
    """
    p = report["parts"]
    head = report.get("head", "voting")
    name = "U-COPE (ours)" if head == "voting" else "direct regression (baseline)"
    lines = [
        f"{report['category']} ({report['data'].get('num_samples')} samples, {name}, "
        f"{len(report['settings']['pipeline']['stages'])} stages); means (medians)",
        f"  parts: {', '.join(report['part_names'])}",
        f"  rotation error (deg)    {_stat_cells(p['rotation_deg'], '{:.1f}')}",
        f"  translation error (m)   {_stat_cells(p['translation_m'], '{:.3f}')}",
        f"  3D IoU (%)              {_stat_cells(p['iou'], '{:.1f}', 100.0)}",
        f"  5deg5cm (%)             {_cells(p['fraction']['5deg5cm'], '{:.1f}', 100.0)}",
        f"  inference time (s)      {report['time_ms']['mean']['total'] / 1000.0:.3f}  "
        f"(median {report['time_ms']['median']['total'] / 1000.0:.3f})",
    ]
    j = report.get("joints")
    if j:
        lines.append(f"  joint axis error (deg)  {_stat_cells(j['axis_deg'], '{:.1f}')}")
        if any(t == "revolute" for t in j["joint_type"]):
            lines.append(f"  joint pivot error (m)   {_stat_cells(j['pivot_m'], '{:.3f}')}")
        lines.append(f"  joint state error       {_stat_cells(j['state_error'], '', unit=j['state_unit'])}")
    seg = report.get("segmentation")
    if seg:
        lines.append(f"  segmentation IoU (%)    {_cells(seg['iou'], '{:.1f}', 100.0)}; accuracy {100 * seg['accuracy']:.1f}%")
    succ = report.get("success")
    if succ:
        line = f"  success (%)             {100 * succ['fraction']:.1f}"
        if succ.get("in_view_fraction") is not None and len(report["part_names"]) > 1:  # a rigid object's one part is in view
            line += f"  (every part in view right: {100 * succ['in_view_fraction']:.1f})"
        lines.append(line)
    for b, vb in (report.get("view_bins") or {}).items():
        line = (
            f"  {b + ' views':12s} ({vb['num_samples']:3d}) rotation {_stat_cells(vb['parts']['rotation_deg'], '{:.1f}')}; "
            f"success {100 * vb['success']:.0f} %"
        )
        if vb.get("success_in_view") is not None and vb["success_in_view"] != vb["success"]:
            line += f" ({100 * vb['success_in_view']:.0f} % counting the parts in view)"
        seen = vb.get("seen_parts")
        if seen and any(seen["num_missing"]):  # parts some views of the bin do not show
            line += (
                f"; views hiding each part {', '.join(str(n) for n in seen['num_missing'])}, rotation where shown "
                f"{_cells(seen['rotation_deg']['mean'], '{:.1f}')}"
            )
        lines.append(line)
    if report.get("map"):
        lines.append(format_map_table(report["map"], indent="  "))
    if report.get("map_nocs"):
        lines.append(format_map_table(report["map_nocs"], indent="  "))
    return "\n".join(lines)


def format_map_table(m: Mapping, indent: str = "") -> str:
    """The figures of :func:`ucope.eval.mean_ap.compute_map` in percent, as the paper's Table 1: per class
    and metric the AP, then in brackets the score-free fraction (the best recall any ranking reaches)."""
    names = list(m["metrics"])
    protocol = m.get("protocol")  # None: a report from before the protocols had names
    title = {"exact": "mAP (%), exact protocol", "nocs": "mAP (%), NOCS reference protocol"}.get(protocol, "mAP (%)")
    rows = [indent + f"{title}: AP (score-free fraction)", indent + " " * 9 + "  ".join(f"{n:>13s}" for n in names)]

    fraction = m.get("fraction") or {"mean": {}, "per_class": {}}  # (absent from reports older than the fractions)

    def row(label, ap, frac):
        return (
            indent
            + f"{label:8s} "
            + "  ".join(
                f"{100 * ap[n]:5.1f} ({100 * frac[n]:5.1f})" if n in frac else f"{100 * ap[n]:5.1f}        " for n in names
            )
        )

    for cls in m["classes_with_gt"]:
        rows.append(row(cls, m["per_class"][cls], fraction["per_class"].get(cls, {})))
    if len(m["classes_with_gt"]) > 1:
        rows.append(row("mean", m["mean"], fraction["mean"]))
    tied = sum(m.get("num_tied", {}).values())
    if protocol is None:
        note = "(computed by an older ucope: see the report's iou_method and matching"
    elif protocol == "exact":
        note = "(IoU: exact oriented boxes; tied scores count as one operating point"
    else:
        note = (
            "(IoU: the NOCS code's, not an IoU; pose metrics over the views matched at IoU > 0.1; "
            "tied scores ranked last record first"
        )
    rows.append(indent + note + (f"; {tied} predictions share a score" if tied else "") + ")")
    return "\n".join(rows)
