"""What a picture of estimates shows, whatever draws it: the objects of a :class:`Scene`, their part
colours, the legend's text, and the points that place a joint's axis.

Part colours come from :data:`PART_PALETTE`, which holds no red, green or blue, so that a part never looks
like a part frame's axis triad (:data:`AXIS_COLOURS`: x red, y green, z blue). A part scoring below
:data:`LOW_SCORE` is drawn dotted and faded. Frames and units: camera frame (OpenCV: x right, y down,
z forward), metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..geometry.boxes import box_corners

__all__ = [
    "DrawnObject",
    "Scene",
    "part_colours",
    "legend_lines",
    "warning_lines",
    "PART_PALETTE",
    "AXIS_COLOURS",
    "LOW_SCORE",
]


AXIS_COLOURS = ("#e41a1c", "#2ca02c", "#1f3fff")
"""Triad colours of a part frame's x, y and z axes (red, green, blue)."""


PART_PALETTE = ("#ff8c00", "#9467bd", "#e377c2", "#17becf", "#bcbd22", "#8c6d31", "#7f7f7f", "#637939")
"""Part colours (orange, purple, pink, cyan, olive, ochre, grey, moss): every hue at least 25 degrees from
red, green and blue, the triad's colours."""


LOW_SCORE = 0.5
"""Estimated parts scoring below this are drawn dotted and faded, with their score beside them."""


class PoseResult(Protocol):
    """What the drawing reads of a :class:`ucope.estimation.result.PoseResult` (named here, not imported:
    ``PoseResult.plot`` draws through these modules, so they must not import that one back)."""

    category: str
    model: str
    parts: Sequence[Any]
    joints: Sequence[Any]
    part_labels: Any
    timings_ms: dict


@dataclass
class DrawnObject:
    """One object to draw: its estimate, optionally its cloud (camera frame, metres), its ground-truth
    sample (:mod:`ucope.data.sample` fields ``cam_from_part``, ``size_m``, ``joint_pivot``, ``joint_axis``)
    and its errors (:func:`ucope.eval.evaluate.sample_errors`, printed in the legend). ``truth``: the
    result is itself a ground truth (drawn without scores)."""

    result: PoseResult
    points: np.ndarray | None = None
    sample: dict | None = None
    errors: dict | None = None
    name: str = ""
    truth: bool = False  # the result is a ground truth itself (ucope show): no scores in its labels


@dataclass
class Scene:
    """One row of a picture: the objects of one frame (or one cloud) and what to draw them over.

    ``depth_m``: ``(H, W)`` depth in metres (0 / NaN = none); ``rgb``: ``(H, W, 3)`` uint8 image of the
    same camera; ``intrinsics``: ``(fx, fy, cx, cy)`` of that camera. Without ``depth_m`` the objects'
    clouds are splatted into a depth image (through ``intrinsics``, a sample's, or a fitted camera)."""

    objects: list[DrawnObject]
    title: str = ""
    depth_m: np.ndarray | None = None
    rgb: np.ndarray | None = None
    intrinsics: Sequence[float] | None = None


def part_colours(scene_objects: Sequence[DrawnObject]) -> list[list[str]]:
    """The colour of every part of every object: part ``k`` of the first object is ``PART_PALETTE[k]``;
    later objects continue the sequence, so that the parts of one frame all differ (up to 8)."""
    out, offset = [], 0
    for o in scene_objects:
        K = len(o.result.parts)
        out.append([PART_PALETTE[(offset + k) % len(PART_PALETTE)] for k in range(K)])
        offset += K
    return out


def _low(obj: DrawnObject, k: int) -> bool:
    """Whether part ``k`` of an estimate scores below :data:`LOW_SCORE` (a ground truth never does)."""
    return not obj.truth and float(obj.result.parts[k].score) < LOW_SCORE


def _joint_state_text(jtype: str, state: float) -> str:
    return f"{np.degrees(state):.1f} deg" if jtype == "revolute" else f"{100 * state:.1f} cm"


def legend_lines(obj: DrawnObject) -> tuple[list[str], list[str]]:
    """The legend's text for one object: one line per part (label, score, and errors when known) and
    one per joint (type, state, and errors when known). A part scoring below :data:`LOW_SCORE` is marked
    ``(low)``."""
    r, e = obj.result, obj.errors
    prefix = f"{obj.name}: " if obj.name else ""
    parts = []
    for k, p in enumerate(r.parts):
        line = f"{prefix}{p.label}  " + ("(ground truth)" if obj.truth else f"score {p.score:.2f}")
        if _low(obj, k):
            line += " (low)"
        if e is not None and k < len(e.get("parts", [])):
            pe = e["parts"][k]
            line += f"  | err {pe['rotation_deg']:.1f} deg, {100 * pe['translation_m']:.1f} cm, IoU {pe['iou']:.2f}"
        parts.append(line)
    joints = []
    for i, j in enumerate(r.joints):
        line = (
            f"{prefix}joint {r.parts[j.parent].label}->{r.parts[j.child].label} ({j.type}) {_joint_state_text(j.type, j.state)}"
        )
        je = (e.get("joints") or [None] * len(r.joints))[i] if e is not None else None
        if je is not None:
            st = f"{je['state_error']:.1f} deg" if je["state_unit"] == "deg" else f"{100 * je['state_error']:.1f} cm"
            piv = f", pivot {100 * je['pivot_m']:.1f} cm" if je.get("pivot_m") is not None else ""
            line += f"  | err axis {je['axis_deg']:.1f} deg{piv}, state {st}"
        joints.append(line)
    return parts, joints


def warning_lines(scene: Scene, width: int = 120) -> list[str]:
    """The legend's warning lines of a scene: each result's warnings (prefixed by the object's name when
    the scene holds several), cut to ``width`` characters."""
    out = []
    for obj in scene.objects:
        for w in getattr(obj.result, "warnings", None) or []:
            text = f"warning{f' ({obj.name})' if obj.name else ''}: {w}"
            out.append(text if len(text) <= width else text[: width - 3] + "...")
    return out


def _joint_segment(pivot, axis, length: float) -> np.ndarray:
    """``(2, 3)`` the ends of a segment of ``length`` metres along ``axis``, centred on ``pivot``."""
    piv = np.asarray(pivot, np.float64)
    u = np.asarray(axis, np.float64)
    u = u / (np.linalg.norm(u) + 1e-12)
    return np.stack([piv - 0.5 * length * u, piv + 0.5 * length * u])


def _joint_pivot(result: PoseResult, j) -> np.ndarray:
    """A point on a joint's axis: its pivot, or the child part's origin for a prismatic joint."""
    return np.asarray(j.pivot_m if j.pivot_m is not None else result.parts[j.child].cam_from_part[:3, 3], np.float64)


def _object_diag(obj: DrawnObject) -> float:
    """The diagonal (metres) of the bounding box of an object's estimated boxes."""
    corners = box_corners(obj.result.cam_from_part, obj.result.size_m).reshape(-1, 3)
    return float(np.linalg.norm(np.ptp(corners, axis=0))) if len(corners) else 0.1
