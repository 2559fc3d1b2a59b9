"""Evaluation: per-part pose, joint and segmentation metrics (:mod:`ucope.eval.metrics`) and NOCS-style
mAP under our exact protocol or NOCS's (:mod:`ucope.eval.mean_ap`).

Imports only from :mod:`ucope.geometry` (and :mod:`ucope.errors`).
"""

from __future__ import annotations

from .mean_ap import (
    NOCS_IOU_METHOD,
    PROTOCOLS,
    average_precision,
    compute_map,
    nocs_average_precision,
    nocs_reference_iou,
    tie_range,
)
from .metrics import (
    IOU_METHOD,
    NOCS_SYMMETRIC_CLASSES,
    SYMMETRIES,
    axis_angle_error_deg,
    box_iou,
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
    "NOCS_IOU_METHOD",
    "NOCS_SYMMETRIC_CLASSES",
    "PROTOCOLS",
    "SYMMETRIES",
    "average_precision",
    "axis_angle_error_deg",
    "box_iou",
    "compute_map",
    "joint_errors",
    "line_distance_m",
    "nocs_average_precision",
    "nocs_reference_iou",
    "normalized_translation_error",
    "part_errors",
    "rotation_error_deg",
    "segmentation_accuracy",
    "segmentation_iou",
    "state_error",
    "summarize_joints",
    "summarize_parts",
    "tie_range",
    "translation_error_m",
]
