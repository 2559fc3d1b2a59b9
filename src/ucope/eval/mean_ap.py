"""NOCS-style mean average precision of rigid-object poses, under two protocols.

One plain function per step, in the spirit of the BOP toolkit (docs/metrics.md says the same in prose):

1. :func:`check_records` - the per-image records, checked;
2. :func:`pair_errors` - per image and class, the IoU, rotation and translation error of every
   (prediction, ground truth) pair;
3. ranking - :func:`exact_order` (ours: descending score, ties broken by the objects' own numbers) or
   :func:`nocs_order` (the reference code's ascending argsort read backwards);
4. matching - :func:`match_greedy` (ours) or :func:`nocs_match_iou` / :func:`nocs_match_pose` (the
   reference code's loops); :func:`max_matching_size` for the score-free fraction;
5. average precision - :func:`average_precision` (ours: tied scores form one operating point),
   :func:`nocs_average_precision` (the reference ranking) and :func:`tie_range` (the lowest and
   highest AP over the orders of tied detections);
6. :func:`compute_map` - the per-class loop and the mean, for ``protocol="exact"`` or ``"nocs"``.

The two protocols (``PROTOCOLS``):

* ``"exact"`` (the default, ours): the exact oriented-box IoU (global maximum over turns about y for
  symmetric classes), IoU >= t, no IoU gating of the pose metrics, an order-free treatment of tied
  scores.  Permuting the records, or the objects inside a record, cannot change any figure.
* ``"nocs"``: what the NOCS reference evaluation (``compute_independent_mAP`` with
  ``use_matches_for_pose=True, iou_pose_thres=0.1``), which published tables such as the U-COPE
  paper's Table 1 were computed with, actually computes (anchors.md section 3):
  :func:`nocs_reference_iou` (its IoU with the max/min over the wrong array axis, and 20 turns over the
  full circle for symmetric classes), stored in float32, IoU > t; pose errors only for the predictions
  and ground truths matched at IoU > 0.1; predictions ranked by an ascending argsort read backwards, so
  that tied scores are ranked in reverse record order (numpy's default sort leaves that order to the
  implementation; we use the stable sort, which is what the default does on small arrays).  It is
  there to compare with published rows, not as a measurement: its IoU is not an IoU.

Frames and units as in :mod:`ucope.eval.metrics`; pose thresholds in degrees and centimetres.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..geometry.boxes import box_corners
from .metrics import (
    IOU_METHOD,
    NOCS_SYMMETRIC_CLASSES,
    box_iou,
    check_scalar,
    check_size,
    check_transform,
    pose_metric_name,
    rotation_error_deg,
)

__all__ = [
    "NOCS_IOU_METHOD",
    "PROTOCOLS",
    "average_precision",
    "check_records",
    "compute_map",
    "exact_order",
    "match_greedy",
    "max_matching_size",
    "nocs_average_precision",
    "nocs_match_iou",
    "nocs_match_pose",
    "nocs_order",
    "nocs_reference_iou",
    "pair_errors",
    "tie_range",
]

#: The mAP protocols of :func:`compute_map`.
PROTOCOLS = ("exact", "nocs")

#: What ``protocol="nocs"`` uses as its IoU (written into :func:`compute_map`'s result).
NOCS_IOU_METHOD = (
    "the NOCS reference code's compute_3d_iou_new as it runs (nocs_reference_iou): min / max of the "
    "transformed box corners taken over the wrong array axis, best of 20 turns about y for symmetric "
    "classes; not an IoU, reproduced only to compare with tables computed by that code"
)

#: The pose-gating IoU of the NOCS protocol (``iou_pose_thres``; a match needs IoU > 0.1).
NOCS_POSE_IOU_GATE = 0.1

#: Turns of the prediction about its y axis tried by the NOCS reference IoU for symmetric classes.
NOCS_SYMMETRY_TURNS = 20


# --------------------------------------------------------------------------------------------------
# 1. Records
# --------------------------------------------------------------------------------------------------


def _check_object(obj, where: str, is_pred: bool) -> dict:
    if not isinstance(obj, Mapping):
        raise InputError(f"{where} must be a dict, got {type(obj).__name__}")
    keys = ("class", "cam_from_object", "size_m") + (("score",) if is_pred else ())
    for key in keys:
        if key not in obj:
            raise InputError(f"{where} is missing the key {key!r} (needs {keys})")
    if not isinstance(obj["class"], str):
        raise InputError(f"{where}['class'] must be a class name (str), got {obj['class']!r}")
    out = {
        "class": obj["class"],
        "T": check_transform(obj["cam_from_object"], f"{where}['cam_from_object']"),
        "size": check_size(obj["size_m"], f"{where}['size_m']"),
    }
    if is_pred:
        out["score"] = check_scalar(obj["score"], f"{where}['score']")
    else:
        hv = obj.get("handle_visible", True)
        if not isinstance(hv, bool | np.bool_):
            raise InputError(f"{where}['handle_visible'] must be a bool, got {hv!r}")
        out["handle_visible"] = bool(hv)
    return out


def check_records(records: Sequence[Mapping]) -> list[tuple[list[dict], list[dict]]]:
    """Check the per-image records of :func:`compute_map` and return them as ``(gts, preds)`` per image.

    Args:
        records: one dict per image, ``{"gt": [...], "pred": [...]}`` (see :func:`compute_map`).

    Returns:
        Per image a pair of lists of dicts ``{"class", "T" (4, 4) float64, "size" (3,) float64}``, plus
        ``"handle_visible"`` (bool, default ``True``) for a ground truth and ``"score"`` for a prediction.

    Raises:
        InputError: on a malformed record; the message gives its index and key.
    """
    if isinstance(records, str | bytes | Mapping) or not isinstance(records, Sequence):
        raise InputError(f"records must be a list of per-image dicts, got {type(records).__name__}")
    images = []
    for i, rec in enumerate(records):
        if not isinstance(rec, Mapping) or "gt" not in rec or "pred" not in rec:
            raise InputError(f"records[{i}] must be a dict with the keys 'gt' and 'pred'")
        for key in ("gt", "pred"):
            if isinstance(rec[key], str | bytes | Mapping) or not isinstance(rec[key], Sequence):
                raise InputError(f"records[{i}]['{key}'] must be a list of dicts")
        images.append(
            (
                [_check_object(o, f"records[{i}]['gt'][{j}]", False) for j, o in enumerate(rec["gt"])],
                [_check_object(o, f"records[{i}]['pred'][{j}]", True) for j, o in enumerate(rec["pred"])],
            )
        )
    return images


# --------------------------------------------------------------------------------------------------
# 2. Pair errors
# --------------------------------------------------------------------------------------------------


def nocs_reference_iou(cam_from_pred, size_pred, cam_from_gt, size_gt, symmetric: bool = False) -> float:
    """The "3D IoU" that the NOCS reference code (``compute_3d_iou_new``) returns, defect included.

    **Not an IoU.**  It reproduces the published protocol (anchors.md section 3) so that our figures can
    be set beside tables computed with that code.  The reference keeps each box's 8 transformed corners
    as a ``(3, 8)`` array and takes ``amax`` / ``amin`` over axis 0, i.e. over the three coordinates of
    each corner instead of over the corners.  What it then treats as the two boxes' extents are 8 numbers
    per box, corner ``i``'s largest coordinate minus its smallest; the "intersection" is the product over
    the 8 corners of the overlaps of those spans (0 if any is negative), the "volumes" are the products of
    the spans, and the result is intersection / (volume_1 + volume_2 - intersection).  It depends on the
    camera frame and is neither the exact IoU nor the intended axis-aligned one: on the non-symmetric
    views of our committed reports it is 0.05 above the exact IoU on average, from -0.61 (half-turn
    flips) to +0.30 (docs/metrics.md has a worked example).  Corners are paired by index, so the corner
    order does not matter as long as both boxes use the same one (:func:`ucope.geometry.boxes.box_corners`).

    Args:
        cam_from_pred: ``(4, 4)`` predicted pose (object frame -> camera frame, metres).
        size_pred: ``(3,)`` predicted box extents, metres (> 0).
        cam_from_gt: ``(4, 4)`` ground-truth pose, same frames.
        size_gt: ``(3,)`` ground-truth box extents, metres (> 0).
        symmetric: the reference's rule for bottle, bowl, can and a mug without a visible handle: the
            largest value over 20 turns of the prediction about its own y axis, ``2 pi i / 20``.

    Returns:
        The reference's value, a Python ``float`` (in ``[0, 1]``; float64 here, the reference stores
        it in float32, which :func:`compute_map` does too).

    Raises:
        InputError: on a malformed pose or size (the message names the argument).
    """
    Tp = check_transform(cam_from_pred, "cam_from_pred")
    sp = check_size(size_pred, "size_pred")
    Tg = check_transform(cam_from_gt, "cam_from_gt")
    sg = check_size(size_gt, "size_gt")
    turns = NOCS_SYMMETRY_TURNS if symmetric else 1
    best = 0.0
    for i in range(turns):
        a = 2.0 * np.pi * i / turns
        turn = np.array(
            [[np.cos(a), 0.0, np.sin(a), 0.0], [0.0, 1.0, 0.0, 0.0], [-np.sin(a), 0.0, np.cos(a), 0.0], [0.0, 0.0, 0.0, 1.0]]
        )
        best = max(best, _nocs_asymmetric_iou(Tp @ turn, sp, Tg, sg))
    return float(best)


def _nocs_asymmetric_iou(Ta: np.ndarray, size_a: np.ndarray, Tb: np.ndarray, size_b: np.ndarray) -> float:
    """The reference's ``asymmetric_3d_iou``: per-corner spans (max minus min over a corner's x, y, z)."""
    ca, cb = box_corners(Ta, size_a), box_corners(Tb, size_b)  # (8, 3): the reference's (3, 8) transposed
    a_max, a_min = ca.max(axis=1), ca.min(axis=1)  # its amax(axis=0) on (3, 8): one value per corner
    b_max, b_min = cb.max(axis=1), cb.min(axis=1)
    overlap = np.minimum(a_max, b_max) - np.maximum(a_min, b_min)
    inter = 0.0 if np.min(overlap) < 0 else float(np.prod(overlap))
    union = float(np.prod(a_max - a_min)) + float(np.prod(b_max - b_min)) - inter
    return inter / union


def _is_symmetric(cls: str, gt: Mapping, symmetric_classes) -> bool:
    return cls in symmetric_classes or (cls == "mug" and not gt["handle_visible"])


def pair_errors(
    gts: Sequence[Mapping],
    preds: Sequence[Mapping],
    protocol: str = "exact",
    symmetric_classes: Sequence[str] = NOCS_SYMMETRIC_CLASSES,
    num_angles: int = 36,
) -> dict:
    """IoU, rotation and translation error of every (prediction, ground truth) pair of one image and class.

    Args:
        gts, preds: checked objects of one class in one image (:func:`check_records`).
        protocol: ``"exact"`` (:func:`ucope.eval.metrics.box_iou`, exact; the global maximum over turns
            about y for symmetric objects) or ``"nocs"`` (:func:`nocs_reference_iou`, rounded to float32
            as the reference stores it).
        symmetric_classes: classes symmetric about their y axis; a ``"mug"`` whose ground truth has
            ``handle_visible`` false is symmetric too (NOCS's rule), for the IoU and the rotation error.
        num_angles: starting angles of the exact symmetric IoU search.

    Returns:
        ``{"iou", "rot_deg", "trans_cm"}``: ``(P, G)`` float64 arrays (``P`` predictions, ``G`` ground
        truths); rotation errors in degrees (:func:`ucope.eval.metrics.rotation_error_deg`, the angle
        between the y axes when symmetric), translation errors in centimetres.
    """
    _check_protocol(protocol)
    shape = (len(preds), len(gts))
    out = {"iou": np.zeros(shape), "rot_deg": np.zeros(shape), "trans_cm": np.zeros(shape)}
    for a, p in enumerate(preds):
        for b, g in enumerate(gts):
            sym = _is_symmetric(g["class"], g, symmetric_classes)
            if protocol == "exact":
                out["iou"][a, b] = box_iou(p["T"], p["size"], g["T"], g["size"], "y" if sym else "none", num_angles)
            else:
                out["iou"][a, b] = np.float32(nocs_reference_iou(p["T"], p["size"], g["T"], g["size"], sym))
            out["rot_deg"][a, b] = rotation_error_deg(p["T"][:3, :3], g["T"][:3, :3], "y" if sym else "none")
            out["trans_cm"][a, b] = 100.0 * np.linalg.norm(p["T"][:3, 3] - g["T"][:3, 3])
    return out


# --------------------------------------------------------------------------------------------------
# 3. Ranking
# --------------------------------------------------------------------------------------------------


def _content(obj: Mapping) -> np.ndarray:
    return np.concatenate([obj["T"].ravel(), obj["size"]])


def exact_order(objects: Sequence[Mapping], by_score: bool) -> np.ndarray:
    """The order in which the exact protocol visits the objects of one image and class: order-free.

    Args:
        objects: checked objects (:func:`check_records`).
        by_score: predictions: by descending score first.

    Returns:
        ``(N,)`` int indices.  Ties (equal scores, or any ground truths) are broken by the objects' own
        numbers (pose, then size, compared lexicographically), never by their position in the list, so
        the order of a set of objects does not depend on how the set was listed.  Objects that compare
        equal are identical, and swapping them changes nothing.
    """
    if not objects:
        return np.zeros(0, dtype=np.int64)
    content = np.stack([_content(o) for o in objects])
    keys = [content[:, j] for j in range(content.shape[1] - 1, -1, -1)]  # np.lexsort: the last key is primary
    if by_score:
        keys.append(-np.array([o["score"] for o in objects]))
    return np.lexsort(keys).astype(np.int64)


def nocs_order(scores) -> np.ndarray:
    """The reference code's ranking: ``np.argsort(scores)[::-1]`` (stable sort, so tied scores come out
    in reverse input order).  ``scores``: ``(N,)``; returns ``(N,)`` int indices."""
    return np.argsort(np.asarray(scores, dtype=np.float64), kind="stable")[::-1].astype(np.int64)


# --------------------------------------------------------------------------------------------------
# 4. Matching
# --------------------------------------------------------------------------------------------------


def match_greedy(passes, cost, pred_order, gt_order=None) -> tuple[np.ndarray, np.ndarray]:
    """Greedy one-to-one matching of one image's predictions to its ground truths (the exact protocol).

    The predictions are visited in ``pred_order``; each takes, among the still unmatched ground truths
    it passes, the one of lowest ``cost`` (the earliest in ``gt_order`` on equal costs).

    Args:
        passes: ``(P, G)`` bool, pair passes the threshold.
        cost: ``(P, G)`` float, lower is better (``-IoU``, or degrees + centimetres).
        pred_order: ``(P,)`` the visiting order (:func:`exact_order`).
        gt_order: ``(G,)`` the preference on equal costs (default: list order).

    Returns:
        ``(tp, gt_match)``: ``(P,)`` bool, the prediction was matched; ``(G,)`` int, the index of the
        prediction that took each ground truth, ``-1`` if none.
    """
    passes = np.asarray(passes, dtype=bool)
    cost = np.asarray(cost, dtype=np.float64)
    n_pred, n_gt = passes.shape
    rank = np.empty(n_gt, dtype=np.int64)
    rank[np.arange(n_gt) if gt_order is None else np.asarray(gt_order, dtype=np.int64)] = np.arange(n_gt)
    tp = np.zeros(n_pred, dtype=bool)
    gt_match = np.full(n_gt, -1, dtype=np.int64)
    for i in pred_order:
        free = np.nonzero(passes[i] & (gt_match < 0))[0]
        if free.size:
            j = free[np.lexsort((rank[free], cost[i, free]))[0]]
            gt_match[j] = i
            tp[i] = True
    return tp, gt_match


def nocs_match_iou(iou_sorted, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """The reference's ``compute_3d_matches`` loop for one IoU threshold, one image and class.

    Args:
        iou_sorted: ``(P, G)`` IoUs with the predictions already in rank order (:func:`nocs_order`).
        threshold: a match needs IoU **>** ``threshold``.

    Returns:
        ``(pred_match, gt_match)``: ``(P,)`` / ``(G,)`` int, the matched partner's index or ``-1``.  Each
        prediction walks the ground truths by descending IoU (``argsort(...)[::-1]``), skips matched ones,
        stops at the first IoU below the threshold and takes the first one above it.
    """
    iou_sorted = np.asarray(iou_sorted)
    n_pred, n_gt = iou_sorted.shape
    pred_match = np.full(n_pred, -1, dtype=np.int64)
    gt_match = np.full(n_gt, -1, dtype=np.int64)
    for i in range(n_pred):
        for j in np.argsort(iou_sorted[i], kind="stable")[::-1]:
            if gt_match[j] > -1:
                continue
            if iou_sorted[i, j] < threshold:
                break
            if iou_sorted[i, j] > threshold:
                gt_match[j], pred_match[i] = i, j
                break
    return pred_match, gt_match


def nocs_match_pose(rot_deg_sorted, trans_cm_sorted, degrees: float, cm: float) -> tuple[np.ndarray, np.ndarray]:
    """The reference's ``compute_RT_matches`` loop for one (degrees, cm) threshold, one image and class.

    Args:
        rot_deg_sorted, trans_cm_sorted: ``(P, G)`` errors with the predictions in rank order.
        degrees, cm: a match needs rotation error <= ``degrees`` and translation error <= ``cm``.

    Returns:
        ``(pred_match, gt_match)`` as :func:`nocs_match_iou`.  Each prediction walks the ground truths
        by ascending degrees + centimetres, skips matched and failing ones and takes the first that passes.
    """
    rot, trans = np.asarray(rot_deg_sorted), np.asarray(trans_cm_sorted)
    n_pred, n_gt = rot.shape
    pred_match = np.full(n_pred, -1, dtype=np.int64)
    gt_match = np.full(n_gt, -1, dtype=np.int64)
    for i in range(n_pred):
        for j in np.argsort(rot[i] + trans[i], kind="stable"):
            if gt_match[j] > -1 or rot[i, j] > degrees or trans[i, j] > cm:
                continue
            gt_match[j], pred_match[i] = i, j
            break
    return pred_match, gt_match


def max_matching_size(passes) -> int:
    """The largest number of disjoint (prediction, ground truth) pairs that pass, in one image.

    This is the recall numerator that the best possible ranking reaches: it does not depend on scores
    or on any order.  With one object and one prediction per view it is 1 if the prediction passes.
    Augmenting paths (Kuhn's algorithm), ``O(P G^2)``, for the handful of objects of an image.

    Args:
        passes: ``(P, G)`` bool.
    """
    passes = np.asarray(passes, dtype=bool)
    n_pred, n_gt = passes.shape
    owner = np.full(n_gt, -1, dtype=np.int64)

    def augment(i: int, seen: np.ndarray) -> bool:
        for j in np.nonzero(passes[i] & ~seen)[0]:
            seen[j] = True
            if owner[j] < 0 or augment(int(owner[j]), seen):
                owner[j] = i
                return True
        return False

    return sum(augment(i, np.zeros(n_gt, dtype=bool)) for i in range(n_pred))


# --------------------------------------------------------------------------------------------------
# 5. Average precision
# --------------------------------------------------------------------------------------------------


def _check_ap_inputs(tp, scores, num_gt) -> tuple[np.ndarray, np.ndarray]:
    tp = np.asarray(tp)
    if tp.ndim != 1 or not (tp.dtype == bool or np.issubdtype(tp.dtype, np.number)) or np.any((tp != 0) & (tp != 1)):
        raise InputError(f"tp must be a (D,) array of 0/1 or booleans, got shape {tp.shape}, dtype {tp.dtype}")
    scores = np.asarray(scores, dtype=np.float64) if np.size(scores) else np.zeros(0)
    if scores.shape != tp.shape or not np.all(np.isfinite(scores)):
        raise InputError(f"scores must be a finite array of shape {tp.shape}, got {scores.shape}")
    if isinstance(num_gt, bool | np.bool_) or not isinstance(num_gt, int | np.integer) or num_gt < 1:
        raise InputError(f"num_gt must be an integer >= 1 (AP is undefined without ground truth), got {num_gt!r}")
    if int(tp.sum()) > num_gt:
        raise InputError(f"{int(tp.sum())} true positives but only num_gt = {num_gt} ground-truth objects")
    return tp.astype(np.float64), scores


def _voc_all_point(precision: np.ndarray, recall: np.ndarray) -> float:
    """VOC all-point interpolation: the precision envelope (max precision at any recall >= r)
    integrated over the recall steps, with (0, 0) and (1, 0) added at the ends."""
    mrec = np.concatenate([[0.0], recall, [1.0]])
    mpre = np.concatenate([[0.0], precision, [0.0]])
    mpre = np.maximum.accumulate(mpre[::-1])[::-1]
    steps = np.nonzero(mrec[1:] != mrec[:-1])[0] + 1
    return float(np.sum((mrec[steps] - mrec[steps - 1]) * mpre[steps]))


def average_precision(tp, scores, num_gt: int) -> float:
    """Average precision with VOC all-point interpolation, tied scores counted as one operating point.

    A ranking says nothing about the order of detections with equal scores, so the precision-recall
    curve has a point only where the score threshold can stop: after the last detection of each
    distinct score (a score threshold takes all of a tie or none of it).  With precision ``P_k`` and
    recall ``R_k = (#TP with score >= s_k) / num_gt`` at the k-th distinct score ``s_k`` (descending),
    ``AP = sum_k (R_k - R_{k-1}) * max_{j >= k} P_j``, ``R_0 = 0``.  This is order-free (the result
    depends only on the multiset of (score, tp) pairs) and equals the **lowest** AP that any order of
    the tied detections would give (all false positives of a tie first; docs/metrics.md has the
    argument), so a detector earns nothing for an order it did not give.  Without ties it is the usual
    VOC all-point AP.  A class whose detections all tie gets ``precision * recall``.

    Args:
        tp: ``(D,)`` 1/0 (int, float or bool) per detection: matched to a ground-truth object or not.
        scores: ``(D,)`` finite detection scores (higher = more confident), in any order.
        num_gt: number of ground-truth objects (>= 1, and >= the number of true positives).

    Returns:
        AP in ``[0, 1]`` as a Python ``float`` (0.0 when there are no detections).

    Raises:
        InputError: on mismatched shapes, non-binary ``tp``, non-finite scores or a bad ``num_gt``.
    """
    tp, scores = _check_ap_inputs(tp, scores, num_gt)
    if tp.size == 0:
        return 0.0
    order = np.argsort(-scores, kind="stable")
    s, ctp = scores[order], np.cumsum(tp[order])
    ends = np.append(np.nonzero(s[1:] != s[:-1])[0], len(s) - 1)  # last detection of each distinct score
    return _voc_all_point(ctp[ends] / (ends + 1.0), ctp[ends] / num_gt)


def nocs_average_precision(tp, scores, num_gt: int) -> float:
    """The reference code's ``compute_ap_from_matches_scores``: rank by :func:`nocs_order` (ties in
    reverse input order), a precision-recall point after every detection, VOC all-point interpolation.
    Arguments, result and errors as :func:`average_precision`; the result depends on the input order
    when scores tie."""
    tp, scores = _check_ap_inputs(tp, scores, num_gt)
    if tp.size == 0:
        return 0.0
    ctp = np.cumsum(tp[nocs_order(scores)])
    return _voc_all_point(ctp / np.arange(1.0, len(ctp) + 1.0), ctp / num_gt)


def tie_range(tp, scores, num_gt: int) -> tuple[float, float]:
    """The lowest and highest VOC all-point AP over all orders of the tied detections.

    The lowest puts the false positives of every tie first and equals :func:`average_precision`; the
    highest puts the true positives first.  Equal when no two scores tie (or ties are all-TP / all-FP).
    Arguments and errors as :func:`average_precision`; returns ``(low, high)`` Python floats.
    """
    tp, scores = _check_ap_inputs(tp, scores, num_gt)
    if tp.size == 0:
        return 0.0, 0.0
    ctp = np.cumsum(tp[np.lexsort((-tp, -scores))])
    high = _voc_all_point(ctp / np.arange(1.0, len(ctp) + 1.0), ctp / num_gt)
    return average_precision(tp, scores, num_gt), high


# --------------------------------------------------------------------------------------------------
# 6. mAP
# --------------------------------------------------------------------------------------------------


def _check_protocol(protocol) -> str:
    if protocol not in PROTOCOLS:
        raise InputError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    return protocol


def iou_metric_name(thr: float) -> str:
    return f"3D{round(thr * 100):d}"


def _check_thresholds(iou_thresholds, pose_thresholds_deg_cm) -> tuple[list[float], list[tuple[float, float]], list[str]]:
    iou_thr = [check_scalar(t, "iou_thresholds") for t in iou_thresholds]
    if any(not 0.0 < t <= 1.0 for t in iou_thr):
        raise InputError(f"iou_thresholds must lie in (0, 1], got {iou_thr}")
    pose_thr = []
    for pair in pose_thresholds_deg_cm:
        if np.shape(pair) != (2,):
            raise InputError(f"pose_thresholds_deg_cm must hold (degrees, cm) pairs, got {pair!r}")
        deg, cm = check_scalar(pair[0], "pose threshold (deg)"), check_scalar(pair[1], "pose threshold (cm)")
        if deg < 0 or cm < 0:
            raise InputError(f"pose thresholds must be non-negative, got {pair!r}")
        pose_thr.append((deg, cm))
    names = [iou_metric_name(t) for t in iou_thr] + [pose_metric_name(d, c) for d, c in pose_thr]
    if len(set(names)) != len(names):
        raise InputError(f"duplicate thresholds give duplicate metric names: {names}")
    return iou_thr, pose_thr, names


def _class_images(images, cls: str, protocol: str, symmetric_classes, num_angles: int) -> list[dict]:
    """Per image: the class's ground truths and predictions (in the protocol's visiting order) and
    their pair errors (rows in that order)."""
    out = []
    for gts_all, preds_all in images:
        gts = [o for o in gts_all if o["class"] == cls]
        preds = [o for o in preds_all if o["class"] == cls]
        scores = np.array([p["score"] for p in preds], dtype=np.float64)
        if protocol == "exact":
            g_order, p_order = exact_order(gts, by_score=False), exact_order(preds, by_score=True)
        else:
            g_order, p_order = np.arange(len(gts)), nocs_order(scores)
        err = pair_errors([gts[j] for j in g_order], [preds[i] for i in p_order], protocol, symmetric_classes, num_angles)
        out.append({"scores": scores[p_order], **err})
    return out


def _ap_figures(tp: np.ndarray, scores: np.ndarray, num_gt: int, reachable: int, protocol: str) -> dict:
    """AP, score-free fraction and tie range of one metric of one class."""
    if num_gt == 0:
        return {"ap": 0.0, "fraction": 0.0, "tie_range": [0.0, 0.0]}
    ap = average_precision(tp, scores, num_gt) if protocol == "exact" else nocs_average_precision(tp, scores, num_gt)
    return {"ap": ap, "fraction": reachable / num_gt, "tie_range": list(tie_range(tp, scores, num_gt))}


def _evaluate_class_exact(per_image: list[dict], iou_thr, pose_thr, names, gate) -> dict:
    """Every metric of one class under the exact protocol (rows of ``per_image`` in visiting order)."""
    n_gt = sum(im["iou"].shape[1] for im in per_image)
    scores = np.concatenate([im["scores"] for im in per_image]) if per_image else np.zeros(0)
    figures = {}
    for t, name in zip(iou_thr, names, strict=False):
        tps, reach = [], 0
        for im in per_image:
            passes = im["iou"] >= t
            tps.append(match_greedy(passes, -im["iou"], np.arange(len(passes)))[0])
            reach += max_matching_size(passes)
        figures[name] = _ap_figures(np.concatenate(tps) if tps else np.zeros(0), scores, n_gt, reach, "exact")
    # Pose metrics: over everything, or (gate) over the pairs matched at IoU >= gate only.
    kept = []
    for im in per_image:
        p_keep, g_keep = np.ones(im["iou"].shape[0], bool), np.ones(im["iou"].shape[1], bool)
        if gate is not None:
            p_keep, g_match = match_greedy(im["iou"] >= gate, -im["iou"], np.arange(len(p_keep)))
            g_keep = g_match >= 0
        kept.append((im["rot_deg"][p_keep][:, g_keep], im["trans_cm"][p_keep][:, g_keep], im["scores"][p_keep]))
    pose_gt = sum(k[0].shape[1] for k in kept)
    pose_scores = np.concatenate([k[2] for k in kept]) if kept else np.zeros(0)
    for (deg, cm), name in zip(pose_thr, names[len(iou_thr) :], strict=False):
        tps, reach = [], 0
        for rot, trans, _ in kept:
            passes = (rot <= deg) & (trans <= cm)
            tps.append(match_greedy(passes, rot + trans, np.arange(len(passes)))[0])
            reach += max_matching_size(passes)
        figures[name] = _ap_figures(np.concatenate(tps) if tps else np.zeros(0), pose_scores, pose_gt, reach, "exact")
    return figures


def _evaluate_class_nocs(per_image: list[dict], iou_thr, pose_thr, names) -> dict:
    """Every metric of one class as the NOCS reference code computes it (rows in its rank order)."""
    n_gt = sum(im["iou"].shape[1] for im in per_image)
    scores = np.concatenate([im["scores"] for im in per_image]) if per_image else np.zeros(0)
    figures = {}
    for t, name in zip(iou_thr, names, strict=False):
        tps = [nocs_match_iou(im["iou"], t)[0] >= 0 for im in per_image]
        reach = sum(max_matching_size(im["iou"] > t) for im in per_image)
        figures[name] = _ap_figures(np.concatenate(tps) if tps else np.zeros(0), scores, n_gt, reach, "nocs")
    kept = []
    for im in per_image:  # use_matches_for_pose: only the pairs matched at IoU > 0.1
        p_match, g_match = nocs_match_iou(im["iou"], NOCS_POSE_IOU_GATE)
        p_keep, g_keep = p_match >= 0, g_match >= 0
        kept.append((im["rot_deg"][p_keep][:, g_keep], im["trans_cm"][p_keep][:, g_keep], im["scores"][p_keep]))
    pose_gt = sum(k[0].shape[1] for k in kept)
    pose_scores = np.concatenate([k[2] for k in kept]) if kept else np.zeros(0)
    for (deg, cm), name in zip(pose_thr, names[len(iou_thr) :], strict=False):
        tps = [nocs_match_pose(rot, trans, deg, cm)[0] >= 0 for rot, trans, _ in kept]
        reach = sum(max_matching_size((rot <= deg) & (trans <= cm)) for rot, trans, _ in kept)
        figures[name] = _ap_figures(np.concatenate(tps) if tps else np.zeros(0), pose_scores, pose_gt, reach, "nocs")
    return figures


def _num_tied(scores: np.ndarray) -> int:
    """How many of the scores are equal to another one."""
    _, counts = np.unique(scores, return_counts=True)
    return int(counts[counts > 1].sum())


def compute_map(
    records: Sequence[Mapping],
    classes: Sequence[str] | None = None,
    iou_thresholds: Sequence[float] = (0.5, 0.75),
    pose_thresholds_deg_cm: Sequence[tuple[float, float]] = ((5, 2), (5, 5), (10, 2), (10, 5)),
    symmetric_classes: Sequence[str] = NOCS_SYMMETRIC_CLASSES,
    num_angles: int = 36,
    pose_iou_gate: float | None = None,
    protocol: str = "exact",
) -> dict:
    """NOCS-style mean average precision for rigid categories, under our exact protocol or NOCS's.

    Record format: one dict per image (or per evaluated view)::

        {"gt":   [{"class": "mug", "cam_from_object": (4, 4), "size_m": (3,), "handle_visible": True}, ...],
         "pred": [{"class": "mug", "cam_from_object": (4, 4), "size_m": (3,), "score": 0.93}, ...]}

    ``cam_from_object`` maps the object frame (NOCS-like: y up; the amodal box centred on its origin and
    aligned with its axes) to the camera frame, metres; ``size_m`` is the box's full extents along the
    object's x, y, z in metres; ``score`` any finite confidence (higher is better).  ``handle_visible``
    (optional, default ``True``, only read for the class ``"mug"``) is NOCS's mug special case: a mug
    whose handle is not visible is evaluated as symmetric about y.  Either list may be empty.

    Rules common to both protocols (docs/metrics.md; anchors section 3): symmetric classes (and mugs
    with a hidden handle) use the angle between the y axes as rotation error and the best IoU over turns
    about y; translation error = centre distance in cm; per class, each prediction is matched at most
    once to a ground truth of its image that passes the threshold (IoU for ``3D{t}``, rotation <= d
    degrees and translation <= c cm for ``{d}deg{c}cm``), preferring the highest IoU, respectively the
    smallest degrees + cm; matched = true positive; AP by VOC all-point interpolation; a class with ground
    truth but no predictions has AP 0, one without ground truth AP ``None``; the mean is over the classes
    with ground truth.

    ``protocol="exact"`` (default): the exact oriented-box IoU, IoU >= t; predictions visited by
    descending score, ties broken by the objects' own numbers (:func:`exact_order`); tied scores form one
    precision-recall point (:func:`average_precision`).  Order-free: permuting the records or the objects
    within them cannot change any figure.  ``pose_iou_gate`` (default ``None``) optionally restricts the
    pose metrics to the predictions and ground truths matched at IoU >= gate (the unmatched are dropped,
    not counted as false positives or misses).

    ``protocol="nocs"``: the NOCS reference evaluation as it runs (module docstring):
    :func:`nocs_reference_iou`, IoU > t, pose metrics only over the pairs matched at IoU > 0.1, ranking
    by :func:`nocs_order` (tied scores in reverse record order).  Only to compare with published tables.

    Besides the AP, every metric gets its **score-free fraction**: the largest recall any ranking could
    reach (:func:`max_matching_size` summed over images, over the ground truths that AP counts); with one
    object and one prediction per view, the fraction of views whose prediction passes the threshold.  And
    its **tie range**: the lowest and highest AP over the orders of tied detections (:func:`tie_range`);
    under the exact protocol the AP is the lowest.

    Args:
        records: the per-image records described above.
        classes: the classes to evaluate (default: every class seen in the records, sorted).
            Predictions of other classes are ignored.
        iou_thresholds: IoU thresholds in ``(0, 1]``; metric names ``3D50``, ``3D75``.
        pose_thresholds_deg_cm: ``(degrees, centimetres)`` pairs; names ``5deg2cm`` etc.
        symmetric_classes: classes symmetric about their y axis.
        num_angles: starting angles of the exact symmetric IoU search (see
            :func:`ucope.eval.metrics.box_iou`).
        pose_iou_gate: ``None`` or an IoU in ``(0, 1]``; exact protocol only (the NOCS protocol's gate
            is fixed at IoU > 0.1).
        protocol: ``"exact"`` or ``"nocs"``.

    Returns:
        A JSON-friendly dict (APs and fractions in ``[0, 1]``; NOCS tables print percent)::

            {"protocol": "exact" | "nocs", "iou_method": str,
             "metrics": ["3D50", "3D75", "5deg2cm", "5deg5cm", "10deg2cm", "10deg5cm"],
             "mean": {metric: AP or None},              # over the classes with ground truth
             "per_class": {class: {metric: AP or None}},
             "fraction": {"mean": {metric: f or None}, "per_class": {class: {metric: f or None}}},
             "tie_range": {"mean": {metric: [low, high] or None}, "per_class": {class: {metric: [low, high] or None}}},
             "num_gt": {class: int}, "num_pred": {class: int}, "num_tied": {class: int},
             "classes_with_gt": [...], "symmetric_classes": [...],
             "matching": str, "ranking": str, "pose_iou_gate": float or None, "interpolation": str}

        ``num_tied``: predictions whose score equals another prediction's of the same class.

    Raises:
        InputError: on a malformed record (the message gives its index and key), bad thresholds, an
            unknown protocol or a gate given with the NOCS protocol.
    """
    _check_protocol(protocol)
    images = check_records(records)
    iou_thr, pose_thr, names = _check_thresholds(iou_thresholds, pose_thresholds_deg_cm)
    gate = None
    if pose_iou_gate is not None:
        if protocol == "nocs":
            raise InputError("pose_iou_gate applies to protocol='exact' only; the NOCS protocol gates at IoU > 0.1")
        gate = check_scalar(pose_iou_gate, "pose_iou_gate")
        if not 0.0 < gate <= 1.0:
            raise InputError(f"pose_iou_gate must be None or lie in (0, 1], got {gate}")
    if isinstance(symmetric_classes, str):
        raise InputError("symmetric_classes must be a list of class names, not a single string")
    sym_classes = set(symmetric_classes)
    if classes is None:
        classes = sorted({o["class"] for gts, preds in images for o in gts + preds})
    elif isinstance(classes, str):
        raise InputError("classes must be a list of class names, not a single string")
    classes = list(classes)

    per_class, fraction, ties, num_gt, num_pred, num_tied = {}, {}, {}, {}, {}, {}
    for cls in classes:
        per_image = _class_images(images, cls, protocol, sym_classes, num_angles)
        num_gt[cls] = sum(im["iou"].shape[1] for im in per_image)
        scores = np.concatenate([im["scores"] for im in per_image]) if per_image else np.zeros(0)
        num_pred[cls], num_tied[cls] = len(scores), _num_tied(scores)
        if num_gt[cls] == 0:
            per_class[cls] = dict.fromkeys(names)
            fraction[cls], ties[cls] = dict.fromkeys(names), dict.fromkeys(names)
            continue
        if protocol == "exact":
            figures = _evaluate_class_exact(per_image, iou_thr, pose_thr, names, gate)
        else:
            figures = _evaluate_class_nocs(per_image, iou_thr, pose_thr, names)
        per_class[cls] = {m: figures[m]["ap"] for m in names}
        fraction[cls] = {m: figures[m]["fraction"] for m in names}
        ties[cls] = {m: figures[m]["tie_range"] for m in names}

    with_gt = [c for c in classes if num_gt[c] > 0]

    def mean_of(table):
        return {m: (float(np.mean([table[c][m] for c in with_gt])) if with_gt else None) for m in names}

    def mean_range(table):
        return {m: ([float(np.mean([table[c][m][k] for c in with_gt])) for k in (0, 1)] if with_gt else None) for m in names}

    if protocol == "exact":
        matching = (
            "greedy per image and class in descending score order, equal scores in the order of the "
            "predictions' own numbers (pose, size); each takes the best unmatched passing GT (highest "
            "IoU, or smallest deg + cm; equal costs: by the GTs' own numbers); IoU >= t; "
            + (
                "no IoU gating of pose metrics"
                if gate is None
                else f"pose metrics only over the predictions and GT matched at IoU >= {gate:g}"
            )
        )
        ranking = "descending score; tied scores form one precision-recall point (the lowest AP over their orders)"
    else:
        matching = (
            "NOCS reference: per image in its rank order, each prediction takes the first unmatched GT by "
            "descending IoU with IoU > t (pose: by ascending deg + cm that passes); pose metrics only over "
            "the predictions and GT matched at IoU > 0.1"
        )
        ranking = "NOCS reference: ascending argsort read backwards (stable: tied scores in reverse record order)"
    return {
        "protocol": protocol,
        "iou_method": IOU_METHOD if protocol == "exact" else NOCS_IOU_METHOD,
        "metrics": names,
        "mean": mean_of(per_class),
        "per_class": per_class,
        "fraction": {"mean": mean_of(fraction), "per_class": fraction},
        "tie_range": {"mean": mean_range(ties), "per_class": ties},
        "num_gt": num_gt,
        "num_pred": num_pred,
        "num_tied": num_tied,
        "classes_with_gt": with_gt,
        "symmetric_classes": sorted(sym_classes),
        "matching": matching,
        "ranking": ranking,
        "pose_iou_gate": gate if protocol == "exact" else NOCS_POSE_IOU_GATE,
        "interpolation": "VOC all-point",
    }
