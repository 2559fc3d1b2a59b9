"""An independent implementation of the NOCS reference evaluation, for tests/eval/test_mean_ap.py.

Written from the published description of the NOCS evaluation code (``utils.py``: ``get_3d_bbox``,
``transform_coordinates_3d``, ``compute_3d_iou_new``, ``compute_3d_matches``,
``compute_RT_degree_cm_symmetry``, ``compute_RT_overlaps``, ``compute_RT_matches``,
``compute_ap_from_matches_scores``, ``compute_independent_mAP``) and anchors.md section 3, keeping its
array layouts and loop structure on purpose (``(3, 8)`` corner arrays, ``amax(axis=0)``, ascending
argsorts read backwards, float32 IoUs, ``arccos`` angles), and sharing no code with ``ucope.eval`` except
the exact IoU that ``iou="exact"`` swaps in.  It is slow and literal; it only computes the figures that
the regression test stores, once, and checks that they still come out.

``nocs_map(records, iou="nocs", use_matches_for_pose=True)`` is the published protocol;
``iou="exact", use_matches_for_pose=False`` is the same pipeline with the exact IoU and no gating, which
is our exact protocol on records without tied scores or IoUs equal to a threshold.
"""

from __future__ import annotations

import math

import numpy as np

CLASSES = ["bottle", "bowl", "camera", "can", "laptop", "mug"]
IOU_THRESHOLDS = [0.1, 0.5, 0.75]  # 0.1: the pose gate (iou_pose_thres)
DEGREE_THRESHOLDS = [5, 10]
SHIFT_THRESHOLDS_CM = [2, 5]


def get_3d_bbox(scale):
    """(3, 8): the corners of a box of full extents ``scale`` centred on the origin, one per column."""
    sx, sy, sz = (float(v) / 2 for v in scale)
    corners = np.array(
        [
            [+sx, +sy, +sz],
            [+sx, +sy, -sz],
            [-sx, +sy, +sz],
            [-sx, +sy, -sz],
            [+sx, -sy, +sz],
            [+sx, -sy, -sz],
            [-sx, -sy, +sz],
            [-sx, -sy, -sz],
        ]
    )
    return corners.transpose()


def transform_coordinates_3d(coordinates, RT):
    """(3, N) points through a 4x4 transform, homogeneous coordinates."""
    assert coordinates.shape[0] == 3
    homogeneous = np.vstack([coordinates, np.ones((1, coordinates.shape[1]), dtype=np.float32)])
    moved = RT @ homogeneous
    return moved[:3, :] / moved[3, :]


def y_rotation_matrix(theta):
    return np.array([[np.cos(theta), 0, np.sin(theta), 0], [0, 1, 0, 0], [-np.sin(theta), 0, np.cos(theta), 0], [0, 0, 0, 1]])


def compute_3d_iou_new(RT_1, RT_2, scales_1, scales_2, handle_visibility, class_name_1, class_name_2):
    """The reference "IoU", defect included: ``amax`` / ``amin`` over axis 0 of the (3, 8) corner arrays."""

    def asymmetric_3d_iou(RT_1, RT_2, scales_1, scales_2):
        bbox_3d_1 = transform_coordinates_3d(get_3d_bbox(scales_1), RT_1)
        bbox_3d_2 = transform_coordinates_3d(get_3d_bbox(scales_2), RT_2)
        bbox_1_max = np.amax(bbox_3d_1, axis=0)
        bbox_1_min = np.amin(bbox_3d_1, axis=0)
        bbox_2_max = np.amax(bbox_3d_2, axis=0)
        bbox_2_min = np.amin(bbox_3d_2, axis=0)
        overlap_min = np.maximum(bbox_1_min, bbox_2_min)
        overlap_max = np.minimum(bbox_1_max, bbox_2_max)
        if np.amin(overlap_max - overlap_min) < 0:
            intersections = 0
        else:
            intersections = np.prod(overlap_max - overlap_min)
        union = np.prod(bbox_1_max - bbox_1_min) + np.prod(bbox_2_max - bbox_2_min) - intersections
        return intersections / union

    symmetric = (class_name_1 in ["bottle", "bowl", "can"] and class_name_1 == class_name_2) or (
        class_name_1 == "mug" and class_name_1 == class_name_2 and handle_visibility == 0
    )
    if symmetric:
        n = 20
        max_iou = 0
        for i in range(n):
            rotated_RT_1 = RT_1 @ y_rotation_matrix(2 * math.pi * i / float(n))
            max_iou = max(max_iou, asymmetric_3d_iou(rotated_RT_1, RT_2, scales_1, scales_2))
        return max_iou
    return asymmetric_3d_iou(RT_1, RT_2, scales_1, scales_2)


def exact_3d_iou(RT_1, RT_2, scales_1, scales_2, handle_visibility, class_name_1, class_name_2):
    """The exact oriented-box IoU in the reference's calling convention (ucope's geometry)."""
    from ucope.geometry.boxes import box_iou_3d, box_iou_3d_symmetric_y

    symmetric = class_name_1 in ["bottle", "bowl", "can"] or (class_name_1 == "mug" and handle_visibility == 0)
    if symmetric:
        return box_iou_3d_symmetric_y(RT_2, scales_2, RT_1, scales_1)
    return box_iou_3d(RT_2, scales_2, RT_1, scales_1)


def compute_3d_matches(
    gt_class_ids,
    gt_RTs,
    gt_scales,
    gt_handle_visibility,
    pred_class_ids,
    pred_scores,
    pred_RTs,
    pred_scales,
    iou_3d_thresholds,
    iou_function,
):
    num_pred = len(pred_class_ids)
    num_gt = len(gt_class_ids)
    indices = np.zeros(0)
    if num_pred:
        indices = np.argsort(pred_scores, kind="stable")[::-1]
        pred_class_ids = pred_class_ids[indices].copy()
        pred_scores = pred_scores[indices].copy()
        pred_scales = pred_scales[indices].copy()
        pred_RTs = pred_RTs[indices].copy()
    overlaps = np.zeros((num_pred, num_gt), dtype=np.float32)
    for i in range(num_pred):
        for j in range(num_gt):
            overlaps[i, j] = iou_function(
                pred_RTs[i],
                gt_RTs[j],
                pred_scales[i, :],
                gt_scales[j],
                gt_handle_visibility[j],
                CLASSES[pred_class_ids[i]],
                CLASSES[gt_class_ids[j]],
            )
    pred_matches = -1 * np.ones([len(iou_3d_thresholds), num_pred])
    gt_matches = -1 * np.ones([len(iou_3d_thresholds), num_gt])
    for s, iou_thres in enumerate(iou_3d_thresholds):
        for i in range(num_pred):
            sorted_ixs = np.argsort(overlaps[i], kind="stable")[::-1]
            for j in sorted_ixs:
                if gt_matches[s, j] > -1:
                    continue
                iou = overlaps[i, j]
                if iou < iou_thres:
                    break
                if not pred_class_ids[i] == gt_class_ids[j]:
                    continue
                if iou > iou_thres:
                    gt_matches[s, j] = i
                    pred_matches[s, i] = j
                    break
    return gt_matches, pred_matches, overlaps, indices


def compute_RT_degree_cm_symmetry(RT_1, RT_2, class_id, handle_visibility):
    R1 = RT_1[:3, :3] / np.cbrt(np.linalg.det(RT_1[:3, :3]))
    T1 = RT_1[:3, 3]
    R2 = RT_2[:3, :3] / np.cbrt(np.linalg.det(RT_2[:3, :3]))
    T2 = RT_2[:3, 3]
    name = CLASSES[class_id]
    if name in ["bottle", "can", "bowl"] or (name == "mug" and handle_visibility == 0):
        y = np.array([0, 1, 0])
        y1 = R1 @ y
        y2 = R2 @ y
        theta = np.arccos(y1.dot(y2) / (np.linalg.norm(y1) * np.linalg.norm(y2)))
    else:
        R = R1 @ R2.transpose()
        theta = np.arccos((np.trace(R) - 1) / 2)
    theta *= 180 / np.pi
    shift = np.linalg.norm(T1 - T2) * 100
    return np.array([theta, shift])


def compute_RT_overlaps(gt_class_ids, gt_RTs, gt_handle_visibility, pred_class_ids, pred_RTs):
    num_pred = len(pred_class_ids)
    num_gt = len(gt_class_ids)
    overlaps = np.zeros((num_pred, num_gt, 2))
    for i in range(num_pred):
        for j in range(num_gt):
            overlaps[i, j, :] = compute_RT_degree_cm_symmetry(pred_RTs[i], gt_RTs[j], gt_class_ids[j], gt_handle_visibility[j])
    return overlaps


def compute_RT_matches(overlaps_RT, degree_thres_list, shift_thres_list):
    num_pred, num_gt = overlaps_RT.shape[0], overlaps_RT.shape[1]
    pred_matches = -1 * np.ones((len(degree_thres_list), len(shift_thres_list), num_pred))
    gt_matches = -1 * np.ones((len(degree_thres_list), len(shift_thres_list), num_gt))
    if num_pred == 0 or num_gt == 0:
        return gt_matches, pred_matches
    for d, degree_thres in enumerate(degree_thres_list):
        for s, shift_thres in enumerate(shift_thres_list):
            for i in range(num_pred):
                sum_degree_shift = np.sum(overlaps_RT[i, :, :], axis=-1)
                sorted_ixs = np.argsort(sum_degree_shift, kind="stable")
                for j in sorted_ixs:
                    if gt_matches[d, s, j] > -1:
                        continue
                    if overlaps_RT[i, j, 0] > degree_thres or overlaps_RT[i, j, 1] > shift_thres:
                        continue
                    gt_matches[d, s, j] = i
                    pred_matches[d, s, i] = j
                    break
    return gt_matches, pred_matches


def compute_ap_from_matches_scores(pred_match, pred_scores, gt_match):
    score_indices = np.argsort(pred_scores, kind="stable")[::-1]
    pred_match = pred_match[score_indices]
    precisions = np.cumsum(pred_match > -1) / (np.arange(len(pred_match)) + 1)
    recalls = np.cumsum(pred_match > -1).astype(np.float64) / len(gt_match)
    precisions = np.concatenate([[0], precisions, [0]])
    recalls = np.concatenate([[0], recalls, [1]])
    for i in range(len(precisions) - 2, -1, -1):
        precisions[i] = np.maximum(precisions[i], precisions[i + 1])
    indices = np.where(recalls[:-1] != recalls[1:])[0] + 1
    return float(np.sum((recalls[indices] - recalls[indices - 1]) * precisions[indices]))


def nocs_map(records, iou="nocs", use_matches_for_pose=True):
    """``{class: {metric: AP}}`` and the mean over the classes with ground truth, for our record format."""
    iou_function = compute_3d_iou_new if iou == "nocs" else exact_3d_iou
    n_iou, n_deg, n_shift = len(IOU_THRESHOLDS), len(DEGREE_THRESHOLDS), len(SHIFT_THRESHOLDS_CM)
    iou_pred_matches = {c: np.zeros((n_iou, 0)) for c in range(len(CLASSES))}
    iou_pred_scores = {c: np.zeros((n_iou, 0)) for c in range(len(CLASSES))}
    iou_gt_matches = {c: np.zeros((n_iou, 0)) for c in range(len(CLASSES))}
    pose_pred_matches = {c: np.zeros((n_deg, n_shift, 0)) for c in range(len(CLASSES))}
    pose_pred_scores = {c: np.zeros((n_deg, n_shift, 0)) for c in range(len(CLASSES))}
    pose_gt_matches = {c: np.zeros((n_deg, n_shift, 0)) for c in range(len(CLASSES))}
    for rec in records:
        gt_class_ids = np.array([CLASSES.index(o["class"]) for o in rec["gt"]], dtype=np.int64)
        gt_RTs = np.array([np.asarray(o["cam_from_object"], float) for o in rec["gt"]]).reshape(-1, 4, 4)
        gt_scales = np.array([np.asarray(o["size_m"], float) for o in rec["gt"]]).reshape(-1, 3)
        gt_handle = np.array([int(o.get("handle_visible", True)) for o in rec["gt"]], dtype=np.int64)
        pred_class_ids = np.array([CLASSES.index(o["class"]) for o in rec["pred"]], dtype=np.int64)
        pred_RTs = np.array([np.asarray(o["cam_from_object"], float) for o in rec["pred"]]).reshape(-1, 4, 4)
        pred_scales = np.array([np.asarray(o["size_m"], float) for o in rec["pred"]]).reshape(-1, 3)
        pred_scores = np.array([o["score"] for o in rec["pred"]], dtype=np.float64)
        for cls_id in range(len(CLASSES)):
            g, p = gt_class_ids == cls_id, pred_class_ids == cls_id
            cls_gt_ids, cls_gt_RTs, cls_gt_scales, cls_gt_handle = gt_class_ids[g], gt_RTs[g], gt_scales[g], gt_handle[g]
            cls_pred_ids, cls_pred_RTs, cls_pred_scales = pred_class_ids[p], pred_RTs[p], pred_scales[p]
            cls_pred_scores = pred_scores[p]
            iou_gt_match, iou_pred_match, _, indices = compute_3d_matches(
                cls_gt_ids,
                cls_gt_RTs,
                cls_gt_scales,
                cls_gt_handle,
                cls_pred_ids,
                cls_pred_scores,
                cls_pred_RTs,
                cls_pred_scales,
                IOU_THRESHOLDS,
                iou_function,
            )
            if len(indices):
                cls_pred_ids, cls_pred_RTs = cls_pred_ids[indices], cls_pred_RTs[indices]
                cls_pred_scores = cls_pred_scores[indices]
            iou_pred_matches[cls_id] = np.concatenate((iou_pred_matches[cls_id], iou_pred_match), axis=-1)
            iou_pred_scores[cls_id] = np.concatenate((iou_pred_scores[cls_id], np.tile(cls_pred_scores, (n_iou, 1))), axis=-1)
            iou_gt_matches[cls_id] = np.concatenate((iou_gt_matches[cls_id], iou_gt_match), axis=-1)
            if use_matches_for_pose:
                keep_pred = iou_pred_match[0, :] > -1
                keep_gt = iou_gt_match[0, :] > -1
                cls_pred_ids, cls_pred_RTs = cls_pred_ids[keep_pred], cls_pred_RTs[keep_pred]
                cls_pred_scores = cls_pred_scores[keep_pred]
                cls_gt_ids, cls_gt_RTs, cls_gt_handle = cls_gt_ids[keep_gt], cls_gt_RTs[keep_gt], cls_gt_handle[keep_gt]
            RT_overlaps = compute_RT_overlaps(cls_gt_ids, cls_gt_RTs, cls_gt_handle, cls_pred_ids, cls_pred_RTs)
            pose_gt_match, pose_pred_match = compute_RT_matches(RT_overlaps, DEGREE_THRESHOLDS, SHIFT_THRESHOLDS_CM)
            pose_pred_matches[cls_id] = np.concatenate((pose_pred_matches[cls_id], pose_pred_match), axis=-1)
            pose_pred_scores[cls_id] = np.concatenate(
                (pose_pred_scores[cls_id], np.tile(cls_pred_scores, (n_deg, n_shift, 1))), axis=-1
            )
            pose_gt_matches[cls_id] = np.concatenate((pose_gt_matches[cls_id], pose_gt_match), axis=-1)
    out = {}
    for cls_id, name in enumerate(CLASSES):
        if iou_gt_matches[cls_id].shape[1] == 0:
            continue
        row = {}
        for s, thr in enumerate(IOU_THRESHOLDS[1:], start=1):
            row[f"3D{round(thr * 100)}"] = compute_ap_from_matches_scores(
                iou_pred_matches[cls_id][s], iou_pred_scores[cls_id][s], iou_gt_matches[cls_id][s]
            )
        for d, deg in enumerate(DEGREE_THRESHOLDS):
            for s, cm in enumerate(SHIFT_THRESHOLDS_CM):
                gt = pose_gt_matches[cls_id][d, s]
                row[f"{deg}deg{cm}cm"] = (
                    compute_ap_from_matches_scores(pose_pred_matches[cls_id][d, s], pose_pred_scores[cls_id][d, s], gt)
                    if len(gt)
                    else 0.0
                )
        out[name] = row
    metrics = ["3D50", "3D75", "5deg2cm", "5deg5cm", "10deg2cm", "10deg5cm"]
    mean = {m: float(np.mean([out[c][m] for c in out])) for m in metrics}
    return out, mean
