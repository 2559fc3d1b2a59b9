"""Evaluation: per-part pose, joint and segmentation metrics and NOCS-style mAP (:mod:`ucope.eval.metrics`).

Imports only from :mod:`ucope.geometry` (and :mod:`ucope.errors`).
"""

from __future__ import annotations

from .metrics import (
    IOU_METHOD,
    NOCS_SYMMETRIC_CLASSES,
    SYMMETRIES,
    average_precision,
    axis_angle_error_deg,
    box_iou,
    compute_map,
    joint_errors,
    line_distance_m,
    normalized_translation_error,
    part_errors,
    rotation_error_deg,
    segmentation_accuracy,
    segmentation_iou,
    state_error,
    summarize_joints,
    summarize_parts,
    translation_error_m,
)

__all__ = [
    "IOU_METHOD",
    "NOCS_SYMMETRIC_CLASSES",
    "SYMMETRIES",
    "average_precision",
    "axis_angle_error_deg",
    "box_iou",
    "compute_map",
    "joint_errors",
    "line_distance_m",
    "normalized_translation_error",
    "part_errors",
    "rotation_error_deg",
    "segmentation_accuracy",
    "segmentation_iou",
    "state_error",
    "summarize_joints",
    "summarize_parts",
    "translation_error_m",
]
