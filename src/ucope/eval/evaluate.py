"""Evaluating an estimator on a data set: per-sample errors, Table-2 / Table-1 shaped summaries.

:func:`evaluate` runs :meth:`ucope.Estimator.predict` on every sample of a (test) data set, measures
every metric of :mod:`ucope.eval.metrics` against the ground truth and summarises them in a report
(a JSON-friendly dict, ``format: "ucope-eval/1"``)::

    {"format": "ucope-eval/1", "model": ..., "head": "voting" | "regression", "category": ...,
     "part_names": [K], "part_symmetry": [K], "settings": {"num_pairs", "awareness", "refine", "seed"},
     "data": {"path", "split", "num_samples", "generator_version"},
     "parts": summarize_parts(...),          # per part mean / median errors and success fractions
     "joints": summarize_joints(...) | None,
     "segmentation": {"iou": [K], "accuracy"} | None,     # means over samples (K >= 2)
     "time_ms": {"mean": {stage: ms}, "median": {stage: ms}},
     "map": compute_map(...) | None,         # rigid (K = 1) categories: NOCS-style mAP, exact IoU
     "map_records": [...] | None,            # its inputs, to pool several categories (Table 1)
     "iou_method": ..., "hardware": {...}, "ucope_version": ...,
     "samples": [{"index", "instance_id", "parts": [part_errors], "joints": [joint_errors],
                  "segmentation_iou": [K], "time_ms"}]}

:func:`format_report` prints it as the paper's tables print (rotation in degrees, translation in
metres, IoU in percent, time in seconds). Frames and units as in :mod:`ucope.eval.metrics`.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .. import __version__
from ..errors import InputError
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

__all__ = ["EVAL_FORMAT", "evaluate", "sample_errors", "mug_handle_visible", "nocs_class", "map_records_of",
           "format_report", "format_map_table"]

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


def sample_errors(result, sample: Mapping) -> dict:
    """Every metric of one prediction against one data-set sample.

    Args:
        result: a :class:`ucope.voting.result.PoseResult` of the sample's cloud (``part_labels`` one
            per sample point).
        sample: the sample dict (:mod:`ucope.data.sample`).

    Returns:
        ``{"parts": [K part_errors], "joints": [J joint_errors], "segmentation_iou": [K] | None,
        "segmentation_accuracy": float | None}`` (IoU ``None`` for a part absent from both).
    """
    K = len(sample["size_m"])
    if len(result.parts) != K or len(result.joints) != len(sample["joint_type"]):
        raise InputError(f"the result has {len(result.parts)} parts / {len(result.joints)} joints, the sample "
                         f"{K} / {len(sample['joint_type'])}: model and data set are of different categories")
    parts = [part_errors(p.cam_from_part, p.size_m, sample["cam_from_part"][k], sample["size_m"][k], p.symmetry)
             for k, p in enumerate(result.parts)]
    joints = [joint_errors(j.axis, j.pivot_m, j.state, sample["joint_axis"][i], sample["joint_pivot"][i],
                           sample["joint_state"][i], j.type)
              for i, j in enumerate(result.joints)]
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
    for r, s in zip(results, samples):
        cls = nocs_class(str(s["category"]))
        gt = {"class": cls, "cam_from_object": np.asarray(s["cam_from_part"][0], np.float64).tolist(),
              "size_m": np.asarray(s["size_m"][0], np.float64).tolist()}
        if cls == "mug":
            gt["handle_visible"] = mug_handle_visible(s)
        p = r.parts[0]
        out.append({"gt": [gt], "pred": [{"class": cls, "cam_from_object": np.asarray(p.cam_from_part).tolist(),
                                          "size_m": np.asarray(p.size_m).tolist(), "score": float(p.score)}]})
    return out


def evaluate(estimator, samples: Sequence[Mapping], progress: bool = True, data_info: Mapping | None = None,
             keep_samples: bool = True) -> dict:
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
    results, records, kept = [], [], []
    for i in range(n):
        s = samples[i]
        r = estimator.predict_sample(s)
        e = sample_errors(r, s)
        records.append(e)
        results.append(r)
        if cfg.num_parts == 1:
            kept.append(s)
        if bar is not None:
            bar.update(1)
        if keep_samples:
            e["index"] = int(s.get("index", i))
            e["instance_id"] = str(s.get("instance_id", ""))
            e["time_ms"] = {k: round(float(v), 3) for k, v in r.timings_ms.items()}
    if bar is not None:
        bar.close()
    times = {k: [float(r.timings_ms.get(k, 0.0)) for r in results] for k in _STAGES}
    seg = None
    if cfg.num_parts > 1:
        ious = np.array([[np.nan if v is None else v for v in e["segmentation_iou"]] for e in records], np.float64)
        seg = {"iou": [None if np.all(np.isnan(c)) else float(np.nanmean(c)) for c in ious.T],
               "accuracy": float(np.mean([e["segmentation_accuracy"] for e in records]))}
    rigid = cfg.num_parts == 1
    map_records = map_records_of(results, kept) if rigid else None
    report: dict[str, Any] = {
        "format": EVAL_FORMAT,
        "model": estimator.name,
        "head": cfg.head,
        "category": cfg.category,
        "part_names": list(cfg.part_names),
        "part_symmetry": list(cfg.part_symmetry),
        "settings": {"num_pairs": estimator.num_pairs, "awareness": estimator.awareness,
                     "refine": estimator.refine, "resolve_flips": getattr(estimator, "resolve_flips", False), "seed": estimator.seed},
        "data": dict(data_info or {}, num_samples=n),
        "parts": summarize_parts([e["parts"] for e in records]),
        "joints": summarize_joints([e["joints"] for e in records]) if cfg.num_joints else None,
        "segmentation": seg,
        "time_ms": {"mean": {k: float(np.mean(v)) for k, v in times.items()},
                    "median": {k: float(np.median(v)) for k, v in times.items()}},
        "map": compute_map(map_records) if rigid else None,
        "map_records": map_records,
        "iou_method": IOU_METHOD,
        "ucope_version": __version__,
        "hardware": {"platform": platform.platform(), "cpu_count": os.cpu_count(), "torch_threads": _threads()},
        "samples": records if keep_samples else None,
    }
    return report


def _threads() -> int:
    import torch

    return int(torch.get_num_threads())


def _cells(values: Sequence, fmt: str, scale: float = 1.0) -> str:
    return ", ".join("-" if v is None else fmt.format(v * scale) for v in values)


def format_report(report: Mapping, stat: str = "mean") -> str:
    """A Table-2 shaped text table of a report (and the mAP of a rigid category, Table-1 shaped).

    Args:
        report: an :func:`evaluate` report.
        stat: ``"mean"`` (the paper's) or ``"median"``.
    """
    p = report["parts"]
    head = report.get("head", "voting")
    name = "U-COPE (ours)" if head == "voting" else "direct regression (baseline)"
    lines = [
        f"{report['category']} ({report['data'].get('num_samples')} samples, {name}, "
        f"{report['settings']['num_pairs']} pairs, awareness {'on' if report['settings']['awareness'] else 'off'}); {stat}s",
        f"  parts: {', '.join(report['part_names'])}",
        f"  rotation error (deg)    {_cells(p['rotation_deg'][stat], '{:.1f}')}",
        f"  translation error (m)   {_cells(p['translation_m'][stat], '{:.3f}')}",
        f"  3D IoU (%)              {_cells(p['iou'][stat], '{:.1f}', 100.0)}",
        f"  5deg5cm (%)             {_cells(p['fraction']['5deg5cm'], '{:.1f}', 100.0)}",
        f"  inference time (s)      {report['time_ms'][stat]['total'] / 1000.0:.3f}",
    ]
    j = report.get("joints")
    if j:
        lines.append(f"  joint axis error (deg)  {_cells(j['axis_deg'][stat], '{:.1f}')}")
        if any(t == "revolute" for t in j["joint_type"]):
            lines.append(f"  joint pivot error (m)   {_cells(j['pivot_m'][stat], '{:.3f}')}")
        units = ["deg" if u == "deg" else "m" for u in j["state_unit"]]
        lines.append(f"  joint state error       " + ", ".join(
            "-" if v is None else (f"{v:.1f} deg" if u == "deg" else f"{v:.3f} m") for v, u in zip(j["state_error"][stat], units)))
    seg = report.get("segmentation")
    if seg:
        lines.append(f"  segmentation IoU (%)    {_cells(seg['iou'], '{:.1f}', 100.0)}; accuracy {100 * seg['accuracy']:.1f}%")
    if report.get("map"):
        lines.append(format_map_table(report["map"], indent="  "))
    return "\n".join(lines)


def format_map_table(m: Mapping, indent: str = "") -> str:
    """The mAP figures of :func:`ucope.eval.metrics.compute_map` in percent, as the paper's Table 1."""
    names = list(m["metrics"])
    rows = [indent + "mAP (%)  " + "  ".join(f"{n:>8s}" for n in names)]
    for cls in m["classes_with_gt"]:
        rows.append(indent + f"{cls:8s} " + "  ".join(f"{100 * m['per_class'][cls][n]:8.1f}" for n in names))
    if len(m["classes_with_gt"]) > 1:
        rows.append(indent + f"{'mean':8s} " + "  ".join(f"{100 * m['mean'][n]:8.1f}" for n in names))
    rows.append(indent + "(IoU: exact oriented boxes, not NOCS's axis-aligned approximation)")
    return "\n".join(rows)
