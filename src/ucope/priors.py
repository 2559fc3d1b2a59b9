"""What a trained model knows about its category: structure and measured statistics.

Prediction (:mod:`ucope.voting`, :mod:`ucope.estimation`) needs a category's joint tree, joint limits,
part symmetries, size statistics and the templates of its flip checks. All of it is measured when a
model is trained (:func:`measure_priors`, from the training samples and the data set's declared
structure) and stored in the model files, so a model predicts without the generator (or the meshes)
that made its data.

* :class:`PartPrior`: a part's name, symmetry, vote range and mean size, the part axis (if any) that
  the training views hold upright (its direction in the camera frame and the cone it stays in), and how
  much of each box axis the training views saw, per face pattern (:func:`seen_extent_statistics`), and how
  far its points stop short of the face the camera faces (:func:`faced_gap_statistics`);
* :class:`JointPrior`: a joint's type, parent and child, canonical axis in the parent frame, state
  limits, prismatic zero offset, where its two parts' centres sit relative to each other and where a
  revolute axis passes in each part's unit box;
* :class:`StackPrior`: prismatic children of one parent that the training views always held one above the
  other in one order, face to face (drawers in a chest), and the gaps between them (:func:`stack_statistics`);
* :class:`CategoryPriors`: the whole category, plus per-part shape templates (surface points in each
  part's unit box) and the input normalisation scale.

The declared structure of a data set (``meta.json["structure"]``, :func:`structure_from_dict`) holds
the part names and symmetries and, per joint, its type, parent, child, canonical axis and limits.

Frames and units: a part frame has its amodal box centred on its origin (docs/conventions.md); metres,
radians. JSON forms use plain lists; the shape templates travel as tensors beside the weights.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .errors import InputError
from .vocab import JointType, parse_symmetry

__all__ = [
    "PartPrior",
    "JointPrior",
    "StackPrior",
    "CategoryPriors",
    "structure_from_dict",
    "stack_statistics",
    "STACK_MAX_OVERLAP",
    "measure_priors",
    "max_state_over_extent",
    "placement_offsets",
    "pivot_offsets",
    "upright_statistics",
    "shape_template_points",
    "cloud_radius",
    "seen_extent_statistics",
    "faced_gap_statistics",
    "SEEN_QUANTILE",
    "SEEN_MAX_OCCLUDED",
    "SEEN_MIN_VIEWS",
]

STACK_MAX_OVERLAP = 0.01
"""Prismatic children of one parent are a stack (:func:`stack_statistics`) only where no training view had one
overlap the next, or reach beyond the parent's face, by more than this (in the parent's extent along the axis)."""

TEMPLATE_POINTS = 4096
"""Points per part kept in a shape template measured from training views."""

UPRIGHT_MIN_RESULTANT = 0.9
"""A part axis counts as held upright by the training views when the mean of its camera-frame
directions has at least this length (1 = always the same direction, about 0 = any direction)."""


SEEN_QUANTILE = 0.01
"""A part's seen extent along an axis is the range from this quantile to ``1 -`` it of its points' coordinates
(:func:`seen_extent_statistics`, :func:`ucope.stages.extents.fit_seen_extents`)."""

SEEN_MAX_OCCLUDED = 0.25
"""Views where another part's box hides more than this fraction of a part's faced box points
(:func:`ucope.geometry.boxes.occluded_fraction`) do not count towards its seen extents (and are not fitted)."""

SEEN_MIN_VIEWS = 20
"""A face pattern needs this many training views of a part to get seen-extent percentiles."""


def _finite(values, name: str, positive: bool = False) -> np.ndarray:
    arr = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or (positive and np.any(arr <= 0)):
        raise InputError(f"{name} must be {'positive ' if positive else ''}finite numbers, got {np.asarray(values).tolist()}")
    return arr


def _nan_table(values, shape: tuple[int, int, int], name: str, nonnegative: bool = False) -> tuple:
    """A nested tuple of floats of ``shape`` from nested sequences (``None`` or NaN: not measured), or
    :class:`InputError` naming ``name`` on another shape, an infinite or (``nonnegative``) a negative entry."""
    try:
        table = np.array([[[np.nan if v is None else v for v in row] for row in ax] for ax in values], np.float64)
    except (TypeError, ValueError):
        table = np.zeros(0)
    if table.shape != shape or np.isinf(table).any() or (nonnegative and (table < 0).any()):
        what = "ratios >= 0" if nonnegative else "finite numbers"
        raise InputError(f"{name} must be {' x '.join(map(str, shape))} {what} (NaN or null: not measured)")
    return tuple(tuple(tuple(float(v) for v in row) for row in ax) for ax in table)


def _nan_table_json(table: tuple | None) -> list | None:
    """The JSON form of a :func:`_nan_table` (``null`` for NaN), or ``None``."""
    return None if table is None else [[[None if math.isnan(v) else v for v in row] for row in ax] for ax in table]


@dataclass(frozen=True)
class PartPrior:
    """One part of a category.

    Attributes:
        name: the part's name (``"base"``, ``"lid"``...).
        symmetry: ``"none"`` or ``"y"`` (continuous symmetry about the part's y axis).
        vote_range_m: ``V``: an upper bound of the distance from any point of the part to its box
            centre (1.1 x the largest half box diagonal seen); ``mu`` is binned on ``[-V, V]``, ``nu``
            on ``[0, V]``.
        mean_size_m: ``(3,)`` the geometric mean of the part's box extents; ``gamma = log(size) -
            log(mean_size_m)``.
        upright_axis: the part axis (0 = x, 1 = y, 2 = z) whose direction in the camera frame the
            training views keep nearly fixed (a part resting on a support, seen by an upright camera
            from above), or ``None`` (:func:`upright_statistics`).
        upright_in_cam: ``(3,)`` that axis's mean direction in the camera frame (OpenCV axes), unit.
        upright_cone_deg: the largest angle between that axis and ``upright_in_cam`` over the training
            views.
        seen_extent: ``(3, SEEN_PATTERNS, 3)`` per part axis and face pattern
            (:func:`ucope.geometry.boxes.seen_pattern`) the 10th, 50th and 90th percentiles of the seen ratio
            over the training views (the :data:`SEEN_QUANTILE` range of the part's points along the axis over
            its box extent, :func:`seen_extent_statistics`); NaN (``null`` in JSON) where a pattern had fewer
            than :data:`SEEN_MIN_VIEWS` views; ``None`` when not measured. Used by
            :func:`ucope.stages.extents.fit_seen_extents`.
        faced_gap: ``(3, 2, 3)`` per part axis and faced side (- then +: the face the camera lies beyond) the
            10th, 50th and 90th percentiles over the training views of the gap between that face of the box
            and the part's points (their :data:`SEEN_QUANTILE` extreme towards the camera), in part box
            diagonals (:func:`faced_gap_statistics`); NaN (``null``) where fewer than :data:`SEEN_MIN_VIEWS`
            views; ``None`` when not measured. Used by :func:`ucope.stages.extents.anchor_faced_faces`.
    """

    name: str
    symmetry: str
    vote_range_m: float
    mean_size_m: tuple[float, float, float]
    upright_axis: int | None = None
    upright_in_cam: tuple[float, float, float] | None = None
    upright_cone_deg: float | None = None
    seen_extent: tuple | None = field(default=None, compare=False)
    faced_gap: tuple | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        parse_symmetry(self.symmetry)
        if self.seen_extent is not None:
            from .geometry.boxes import SEEN_PATTERNS

            table = _nan_table(self.seen_extent, (3, SEEN_PATTERNS, 3), f"part {self.name!r}: seen_extent", nonnegative=True)
            object.__setattr__(self, "seen_extent", table)
        if self.faced_gap is not None:
            object.__setattr__(self, "faced_gap", _nan_table(self.faced_gap, (3, 2, 3), f"part {self.name!r}: faced_gap"))
        object.__setattr__(self, "vote_range_m", float(_finite(self.vote_range_m, f"part {self.name!r} vote_range_m", True)))
        size = _finite(self.mean_size_m, f"part {self.name!r} mean_size_m", True).reshape(-1)
        if size.shape != (3,):
            raise InputError(f"part {self.name!r}: mean_size_m needs 3 values, got {size.shape}")
        object.__setattr__(self, "mean_size_m", tuple(float(x) for x in size))
        given = [self.upright_axis is None, self.upright_in_cam is None, self.upright_cone_deg is None]
        if any(given) and not all(given):
            raise InputError(f"part {self.name!r}: upright_axis, upright_in_cam and upright_cone_deg go together")
        if self.upright_axis is not None:
            if int(self.upright_axis) not in (0, 1, 2):
                raise InputError(f"part {self.name!r}: upright_axis must be 0, 1 or 2, got {self.upright_axis}")
            d = _finite(self.upright_in_cam, f"part {self.name!r} upright_in_cam").reshape(-1)
            if d.shape != (3,) or np.linalg.norm(d) < 1e-9:
                raise InputError(f"part {self.name!r}: upright_in_cam must be a non-zero 3-vector")
            cone = float(_finite(self.upright_cone_deg, f"part {self.name!r} upright_cone_deg"))
            if not 0.0 <= cone <= 180.0:
                raise InputError(f"part {self.name!r}: upright_cone_deg must lie in [0, 180], got {cone}")
            object.__setattr__(self, "upright_axis", int(self.upright_axis))
            object.__setattr__(self, "upright_in_cam", tuple(float(x) for x in d / np.linalg.norm(d)))
            object.__setattr__(self, "upright_cone_deg", cone)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "symmetry": self.symmetry,
            "vote_range_m": self.vote_range_m,
            "mean_size_m": list(self.mean_size_m),
            "upright_axis": self.upright_axis,
            "upright_in_cam": None if self.upright_in_cam is None else list(self.upright_in_cam),
            "upright_cone_deg": self.upright_cone_deg,
            "seen_extent": _nan_table_json(self.seen_extent),
            "faced_gap": _nan_table_json(self.faced_gap),
        }


@dataclass(frozen=True)
class JointPrior:
    """One joint of a category.

    Attributes:
        type: :class:`ucope.vocab.JointType` (revolute or prismatic).
        parent, child: part indices.
        axis_in_parent: ``(3,)`` the unit joint axis in the parent's part frame (the rotation of
            ``parent_from_child`` at state 0 is the identity in every category: docs/conventions.md).
        limits: ``(lower, upper)`` joint states (radians / metres) the category spans; ``None`` on a
            side that is unlimited (a continuous joint).
        zero_offset_m: prismatic: the gap between the child's and the parent's box supports along the
            axis minus the state, at the true poses (:func:`ucope.geometry.kinematics.prismatic_zero_offset`);
            0 for revolute joints.
        child_in_parent, parent_in_child: ``(3,)`` mean position of the child's box centre in the parent's
            frame divided by the parent's box diagonal, and of the parent's centre in the child's frame
            divided by the child's diagonal (over the category's instances and joint range): where each
            part's neighbour sits, used to undo half-turn flips (:func:`ucope.stages.flips.resolve_joint_flips`).
        child_in_parent_spread: prismatic joints: ``(3,)`` the standard deviation of ``child_in_parent``
            over the training views (same units); where it is below
            ``PrismaticParams.place_max_spread`` (:mod:`ucope.stages.prismatic`) on a parent axis across the joint's axis (a
            drawer always centred left-right in its cabinet), the child is placed at the mean there
            (:func:`ucope.stages.prismatic.place_prismatic_children`). ``None`` for revolute joints or
            when not measured.
        child_size_ratio, child_size_spread: ``(3,)`` the mean over the training views of the child's box
            extents over the parent's, axis by axis (the parts' axes agree at state 0), and its standard
            deviation over that mean (a dishwasher door as wide as its body: 0.99, spread 0.004); where the
            spread is small, a child's extent follows its parent's measured one
            (:func:`ucope.stages.extents.carry_child_sizes`). ``None`` when not measured.
        max_state_over_extent: prismatic joints: the largest state over the training views divided by the child's
            box extent along the joint's axis (a drawer on three-quarter extension slides: 0.75): how far a child
            the view hides can be pulled out (:func:`ucope.stages.exposure.slide_weak_children`). ``None`` for revolute
            joints or when not measured.
        pivot_in_parent, pivot_in_child: revolute joints: ``(3,)`` the foot of the perpendicular from the
            parent's box centre to the joint axis, in the parent's and in the child's frame, each divided
            elementwise by that part's box extents (mean over the training views, :func:`pivot_offsets`);
            ``None`` for prismatic joints or when not measured. They place a part from its neighbour
            through the joint (:func:`ucope.stages.upright.carry_upright`).
    """

    type: JointType
    parent: int
    child: int
    axis_in_parent: tuple[float, float, float]
    limits: tuple[float | None, float | None] = (None, None)
    zero_offset_m: float = 0.0
    child_in_parent: tuple[float, float, float] = (0.0, 0.0, 0.0)
    parent_in_child: tuple[float, float, float] = (0.0, 0.0, 0.0)
    child_in_parent_spread: tuple[float, float, float] | None = None
    child_size_ratio: tuple[float, float, float] | None = None
    child_size_spread: tuple[float, float, float] | None = None
    pivot_in_parent: tuple[float, float, float] | None = None
    pivot_in_child: tuple[float, float, float] | None = None
    max_state_over_extent: float | None = None

    def __post_init__(self) -> None:
        jt = JointType.parse(self.type)
        if jt == JointType.FIXED:
            raise InputError(
                f"joint {self.parent}->{self.child}: a category joint must be revolute or prismatic (fixed parts merge)"
            )
        object.__setattr__(self, "type", jt)
        ax = _finite(self.axis_in_parent, f"joint {self.parent}->{self.child} axis_in_parent").reshape(-1)
        if ax.shape != (3,) or np.linalg.norm(ax) < 1e-9:
            raise InputError(f"joint {self.parent}->{self.child}: axis_in_parent must be a non-zero 3-vector, got {ax.tolist()}")
        object.__setattr__(self, "axis_in_parent", tuple(float(x) for x in ax / np.linalg.norm(ax)))
        lo, hi = (None if v is None else float(v) for v in self.limits)
        if (lo is not None and not math.isfinite(lo)) or (hi is not None and not math.isfinite(hi)):
            raise InputError(f"joint {self.parent}->{self.child}: limits must be finite numbers or None, got {self.limits}")
        if lo is not None and hi is not None and lo > hi:
            raise InputError(f"joint {self.parent}->{self.child}: limits must satisfy lower <= upper, got {self.limits}")
        object.__setattr__(self, "limits", (lo, hi))
        object.__setattr__(self, "zero_offset_m", float(_finite(self.zero_offset_m, "zero_offset_m")))
        for name in ("child_in_parent", "parent_in_child"):
            v = _finite(getattr(self, name), name).reshape(-1)
            if v.shape != (3,):
                raise InputError(f"joint {self.parent}->{self.child}: {name} needs 3 values")
            object.__setattr__(self, name, tuple(float(x) for x in v))
        if self.child_in_parent_spread is not None:
            v = _finite(self.child_in_parent_spread, "child_in_parent_spread").reshape(-1)
            if v.shape != (3,) or np.any(v < 0):
                raise InputError(f"joint {self.parent}->{self.child}: child_in_parent_spread needs 3 values >= 0")
            object.__setattr__(self, "child_in_parent_spread", tuple(float(x) for x in v))
        if (self.child_size_ratio is None) != (self.child_size_spread is None):
            raise InputError(f"joint {self.parent}->{self.child}: child_size_ratio and child_size_spread go together")
        if self.child_size_ratio is not None:
            ratio = _finite(self.child_size_ratio, "child_size_ratio", positive=True).reshape(-1)
            spread = _finite(self.child_size_spread, "child_size_spread").reshape(-1)
            if ratio.shape != (3,) or spread.shape != (3,) or np.any(spread < 0):
                raise InputError(f"joint {self.parent}->{self.child}: child_size_ratio needs 3 values > 0, its spread 3 >= 0")
            object.__setattr__(self, "child_size_ratio", tuple(float(x) for x in ratio))
            object.__setattr__(self, "child_size_spread", tuple(float(x) for x in spread))
        if (self.pivot_in_parent is None) != (self.pivot_in_child is None):
            raise InputError(f"joint {self.parent}->{self.child}: pivot_in_parent and pivot_in_child go together")
        for name in ("pivot_in_parent", "pivot_in_child"):
            if getattr(self, name) is not None:
                v = _finite(getattr(self, name), name).reshape(-1)
                if v.shape != (3,):
                    raise InputError(f"joint {self.parent}->{self.child}: {name} needs 3 values")
                object.__setattr__(self, name, tuple(float(x) for x in v))
        if self.max_state_over_extent is not None:
            m = float(_finite(self.max_state_over_extent, "max_state_over_extent"))
            if jt != JointType.PRISMATIC or m <= 0:
                raise InputError(
                    f"joint {self.parent}->{self.child}: max_state_over_extent must be a positive number on a prismatic joint, "
                    f"got {self.max_state_over_extent!r} on a {jt.label} joint"
                )
            object.__setattr__(self, "max_state_over_extent", m)

    @property
    def axis(self) -> np.ndarray:
        """``(3,)`` float64 copy of :attr:`axis_in_parent`."""
        return np.array(self.axis_in_parent, dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type.label,
            "parent": int(self.parent),
            "child": int(self.child),
            "axis_in_parent": list(self.axis_in_parent),
            "limits": list(self.limits),
            "zero_offset_m": self.zero_offset_m,
            "child_in_parent": list(self.child_in_parent),
            "parent_in_child": list(self.parent_in_child),
            "child_in_parent_spread": None if self.child_in_parent_spread is None else list(self.child_in_parent_spread),
            "child_size_ratio": None if self.child_size_ratio is None else list(self.child_size_ratio),
            "child_size_spread": None if self.child_size_spread is None else list(self.child_size_spread),
            "pivot_in_parent": None if self.pivot_in_parent is None else list(self.pivot_in_parent),
            "pivot_in_child": None if self.pivot_in_child is None else list(self.pivot_in_child),
            "max_state_over_extent": self.max_state_over_extent,
        }


@dataclass(frozen=True)
class StackPrior:
    """Prismatic children of one parent that every training view held one above the other along a parent axis
    across their slides, in one order and face to face (the drawers of a chest): where a view hides some of
    them, :func:`ucope.stages.prismatic.stack_hidden_children` puts them next to a seen one (or under the parent's face).

    Attributes:
        parent: the parent part's index.
        axis: the parent box axis (0, 1 or 2) they are stacked along, across their joints' axis.
        children: their part indices, from the parent's ``+axis`` face towards its ``-axis`` face (the top
            drawer first); at least two.
        first_gap: the gap between the parent's ``+axis`` face and the first child's, over the parent's extent
            along ``axis`` (median over the training views).
        gap: the gap between each child's ``-axis`` face and the next child's ``+axis`` face, same units
            (median over the training views and neighbours).
        first_gap_spread, gap_spread: the 10th-90th percentile ranges of the two, same units.
    """

    parent: int
    axis: int
    children: tuple[int, ...]
    first_gap: float
    gap: float
    first_gap_spread: float
    gap_spread: float

    def __post_init__(self) -> None:
        children = tuple(int(c) for c in self.children)
        if len(children) < 2 or len(set(children)) != len(children) or self.parent in children:
            raise InputError(f"a stack needs two or more distinct children other than its parent, got {self.children}")
        if int(self.axis) not in (0, 1, 2):
            raise InputError(f"a stack's axis must be 0, 1 or 2, got {self.axis!r}")
        object.__setattr__(self, "children", children)
        object.__setattr__(self, "parent", int(self.parent))
        object.__setattr__(self, "axis", int(self.axis))
        for name in ("first_gap", "gap", "first_gap_spread", "gap_spread"):
            object.__setattr__(self, name, float(_finite(getattr(self, name), f"stack {name}")))
        if self.first_gap_spread < 0 or self.gap_spread < 0:
            raise InputError(f"a stack's spreads must be >= 0, got {self.first_gap_spread}, {self.gap_spread}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "parent": self.parent,
            "axis": self.axis,
            "children": list(self.children),
            "first_gap": self.first_gap,
            "gap": self.gap,
            "first_gap_spread": self.first_gap_spread,
            "gap_spread": self.gap_spread,
        }


@dataclass(frozen=True)
class CategoryPriors:
    """Everything prediction needs to know about a category (see the module docstring).

    Attributes:
        category: the category's name.
        parts: the K :class:`PartPrior`, root first.
        joints: the K-1 :class:`JointPrior`; they form a tree rooted at part 0, parents listed before
            their children.
        norm_scale_m: the length the encoder's input is divided by (mean cloud radius of the training
            views about their centroid).
        num_samples: how many training samples the statistics were measured on.
        radius_range_m: ``(smallest, largest)`` :func:`cloud_radius` of the training views: the sizes
            of cloud the model knows (a cloud far outside it is in other units, or another object);
            ``None`` when not measured.
        radius_typical_m: ``(2nd, 98th)`` percentiles of the same radii: the sizes of cloud the model saw
            often (the estimator rescales clouds below them, and into them,
            :meth:`ucope.Estimator.input_scale`); ``None`` when not measured (``radius_range_m`` serves).
        shape_templates: per part, ``(P_k, 3)`` float32 surface points in the part's unit box (part frame
            divided by the box extents), seen over the category's instances; ``()`` when not measured
            (the rigid shape-flip check is then skipped).
        stacks: the :class:`StackPrior` of the category (:func:`stack_statistics`); ``()`` where it has none
            or they were not measured.
    """

    category: str
    parts: tuple[PartPrior, ...]
    joints: tuple[JointPrior, ...] = ()
    norm_scale_m: float = 1.0
    num_samples: int = 0
    radius_range_m: tuple[float, float] | None = None
    radius_typical_m: tuple[float, float] | None = None
    shape_templates: tuple[np.ndarray, ...] = field(default=(), compare=False)
    stacks: tuple[StackPrior, ...] = ()

    def __post_init__(self) -> None:
        parts, joints = tuple(self.parts), tuple(self.joints)
        object.__setattr__(self, "parts", parts)
        object.__setattr__(self, "joints", joints)
        K = len(parts)
        if K == 0:
            raise InputError(f"category {self.category!r}: a category needs at least one part")
        if len({p.name for p in parts}) != K:
            raise InputError(f"category {self.category!r}: part names must be unique, got {[p.name for p in parts]}")
        if len(joints) != K - 1:
            raise InputError(f"category {self.category!r}: {K} parts need {K - 1} joints, got {len(joints)}")
        placed = {0}
        for j in joints:
            if not (0 <= j.parent < K and 0 < j.child < K):
                raise InputError(f"category {self.category!r}: joint {j.parent}->{j.child} names a part outside 0..{K - 1}")
            if j.parent not in placed or j.child in placed:
                raise InputError(
                    f"category {self.category!r}: the joints must form a tree rooted at part 0, parents before children"
                )
            placed.add(j.child)
        object.__setattr__(self, "norm_scale_m", float(_finite(self.norm_scale_m, "norm_scale_m", True)))
        if self.radius_range_m is not None:
            lo, hi = (float(v) for v in _finite(self.radius_range_m, "radius_range_m", True).reshape(2))
            if lo > hi:
                raise InputError(f"radius_range_m must be (smallest, largest), got {self.radius_range_m}")
            object.__setattr__(self, "radius_range_m", (lo, hi))
        if self.radius_typical_m is not None:
            lo, hi = (float(v) for v in _finite(self.radius_typical_m, "radius_typical_m", True).reshape(2))
            if lo > hi:
                raise InputError(f"radius_typical_m must be (low, high), got {self.radius_typical_m}")
            object.__setattr__(self, "radius_typical_m", (lo, hi))
        templates = tuple(np.ascontiguousarray(t, dtype=np.float32).reshape(-1, 3) for t in self.shape_templates)
        if templates and len(templates) != K:
            raise InputError(f"category {self.category!r}: {len(templates)} shape templates for {K} parts")
        if any(not np.all(np.isfinite(t)) for t in templates):
            raise InputError(f"category {self.category!r}: shape templates must be finite")
        object.__setattr__(self, "shape_templates", templates)
        stacks = tuple(self.stacks)
        prismatic = {(j.parent, j.child) for j in joints if j.type == JointType.PRISMATIC}
        for st in stacks:
            if any((st.parent, c) not in prismatic for c in st.children):
                raise InputError(
                    f"category {self.category!r}: stack {list(st.children)} must be prismatic children of part {st.parent}"
                )
        object.__setattr__(self, "stacks", stacks)

    # ------------------------------------------------------------------------------------ views
    @property
    def num_parts(self) -> int:
        return len(self.parts)

    @property
    def num_joints(self) -> int:
        return len(self.joints)

    @property
    def part_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parts)

    @property
    def symmetric(self) -> tuple[bool, ...]:
        """Per part, whether it is symmetric about its y axis."""
        return tuple(p.symmetry == "y" for p in self.parts)

    @property
    def vote_range_m(self) -> np.ndarray:
        """``(K,)`` float64."""
        return np.array([p.vote_range_m for p in self.parts], dtype=np.float64)

    @property
    def mean_size_m(self) -> np.ndarray:
        """``(K, 3)`` float64."""
        return np.array([p.mean_size_m for p in self.parts], dtype=np.float64)

    @property
    def seen_extent(self) -> np.ndarray | None:
        """``(K, 3, SEEN_PATTERNS, 3)`` float64 :attr:`PartPrior.seen_extent` of every part (NaN for a part
        without one), or ``None`` when no part has one."""
        if all(p.seen_extent is None for p in self.parts):
            return None
        from .geometry.boxes import SEEN_PATTERNS

        return np.stack(
            [np.full((3, SEEN_PATTERNS, 3), np.nan) if p.seen_extent is None else np.array(p.seen_extent) for p in self.parts]
        )

    @property
    def faced_gap(self) -> np.ndarray | None:
        """``(K, 3, 2, 3)`` float64 :attr:`PartPrior.faced_gap` of every part (NaN for a part without one), or
        ``None`` when no part has one."""
        if all(p.faced_gap is None for p in self.parts):
            return None
        return np.stack([np.full((3, 2, 3), np.nan) if p.faced_gap is None else np.array(p.faced_gap) for p in self.parts])

    @property
    def joint_axes(self) -> np.ndarray:
        """``(J, 3)`` float64 unit axes, each in its parent's frame."""
        return np.array([j.axis_in_parent for j in self.joints], dtype=np.float64).reshape(-1, 3)

    # ------------------------------------------------------------------------------ (de)serialise
    def to_dict(self) -> dict[str, Any]:
        """The JSON form (everything but the shape templates: :meth:`tensors`)."""
        return {
            "category": self.category,
            "parts": [p.to_dict() for p in self.parts],
            "joints": [j.to_dict() for j in self.joints],
            "norm_scale_m": self.norm_scale_m,
            "num_samples": int(self.num_samples),
            "radius_range_m": None if self.radius_range_m is None else list(self.radius_range_m),
            "radius_typical_m": None if self.radius_typical_m is None else list(self.radius_typical_m),
            "stacks": [st.to_dict() for st in self.stacks],
        }

    def tensors(self) -> dict[str, np.ndarray]:
        """The shape templates as named float32 arrays (``shape_template.<k>``), stored beside the weights."""
        return {f"shape_template.{k}": t for k, t in enumerate(self.shape_templates)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], tensors: Mapping[str, Any] | None = None) -> CategoryPriors:
        """Inverse of :meth:`to_dict` (+ :meth:`tensors`); :class:`InputError` on a malformed form."""
        try:
            parts = tuple(
                PartPrior(
                    name=str(p["name"]),
                    symmetry=str(p["symmetry"]),
                    vote_range_m=p["vote_range_m"],
                    mean_size_m=tuple(p["mean_size_m"]),
                    upright_axis=p.get("upright_axis"),
                    upright_in_cam=_tuple_or_none(p.get("upright_in_cam")),
                    upright_cone_deg=p.get("upright_cone_deg"),
                    seen_extent=p.get("seen_extent"),
                    faced_gap=p.get("faced_gap"),
                )
                for p in d["parts"]
            )
            joints = tuple(
                JointPrior(
                    type=j["type"],
                    parent=int(j["parent"]),
                    child=int(j["child"]),
                    axis_in_parent=tuple(j["axis_in_parent"]),
                    limits=tuple(j["limits"]),
                    zero_offset_m=j.get("zero_offset_m", 0.0),
                    child_in_parent=tuple(j["child_in_parent"]),
                    parent_in_child=tuple(j["parent_in_child"]),
                    child_in_parent_spread=_tuple_or_none(j.get("child_in_parent_spread")),
                    child_size_ratio=_tuple_or_none(j.get("child_size_ratio")),
                    child_size_spread=_tuple_or_none(j.get("child_size_spread")),
                    pivot_in_parent=_tuple_or_none(j.get("pivot_in_parent")),
                    pivot_in_child=_tuple_or_none(j.get("pivot_in_child")),
                    max_state_over_extent=j.get("max_state_over_extent"),
                )
                for j in d["joints"]
            )
            templates: tuple = ()
            if tensors:
                templates = tuple(np.asarray(tensors[f"shape_template.{k}"]) for k in range(len(parts)))
            rr = d.get("radius_range_m")
            return cls(
                category=str(d["category"]),
                parts=parts,
                joints=joints,
                norm_scale_m=d["norm_scale_m"],
                num_samples=int(d.get("num_samples", 0)),
                radius_range_m=None if rr is None else tuple(rr),
                radius_typical_m=_tuple_or_none(d.get("radius_typical_m")),
                shape_templates=templates,
                stacks=tuple(StackPrior(**st) for st in d.get("stacks") or ()),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"malformed category priors: {type(e).__name__}: {e}") from None

    def with_templates(self, shape_templates: Sequence[np.ndarray]) -> CategoryPriors:
        """A copy with other shape templates."""
        return replace(self, shape_templates=tuple(shape_templates))


def _tuple_or_none(v) -> tuple | None:
    return None if v is None else tuple(v)


# -------------------------------------------------------------------------------------- structure
def structure_from_dict(d: Mapping[str, Any]) -> tuple[list[tuple[str, str]], list[dict[str, Any]]]:
    """A data set's declared structure (``meta.json["structure"]``): ``(parts, joints)`` with parts as
    ``(name, symmetry)`` and joints as dicts of ``type`` (:class:`JointType`), ``parent``, ``child``,
    ``axis_in_parent`` ``(3,)`` and ``limits`` ``(lower | None, upper | None)``.

    Raises :class:`InputError` naming what is missing or malformed."""
    try:
        parts = [(str(p["name"]), parse_symmetry(p["symmetry"])) for p in d["parts"]]
        joints = [
            {
                "type": JointType.parse(j["type"]),
                "parent": int(j["parent"]),
                "child": int(j["child"]),
                "axis_in_parent": _finite(j["axis_in_parent"], "axis_in_parent").reshape(3),
                "limits": tuple(None if v is None else float(v) for v in j["limits"]),
            }
            for j in d["joints"]
        ]
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(
            f"malformed category structure ({type(e).__name__}: {e}): expected parts [{{name, symmetry}}] "
            "and joints [{type, parent, child, axis_in_parent, limits}]"
        ) from None
    if len(joints) != len(parts) - 1:
        raise InputError(f"the structure declares {len(parts)} parts and {len(joints)} joints; it needs {len(parts) - 1}")
    return parts, joints


def cloud_radius(points: np.ndarray) -> float:
    """A robust size of a cloud ``(N, 3)``: the 90th percentile of the points' distances to their
    median point (metres). Outliers and stray background points up to 10 % barely move it."""
    p = np.asarray(points, dtype=np.float64)
    return float(np.percentile(np.linalg.norm(p - np.median(p, axis=0), axis=1), 90.0))


def placement_offsets(cam_from_part: np.ndarray, size_m: np.ndarray, parent: int, child: int) -> tuple[np.ndarray, np.ndarray]:
    """Where each of a joint's two parts sits in the other's frame, in units of the other's box diagonal.

    Args:
        cam_from_part: ``(S, K, 4, 4)`` part poses of ``S`` views; size_m: ``(S, K, 3)`` box extents.

    Returns:
        ``(child_in_parent, parent_in_child)``, each ``(S, 3)``: ``R_p^T (t_c - t_p) / |size_p|`` and
        ``R_c^T (t_p - t_c) / |size_c|``.
    """
    T = np.asarray(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    d = T[:, child, :3, 3] - T[:, parent, :3, 3]
    cip = np.einsum("sji,sj->si", T[:, parent, :3, :3], d) / np.linalg.norm(S[:, parent], axis=-1, keepdims=True)
    pic = np.einsum("sji,sj->si", T[:, child, :3, :3], -d) / np.linalg.norm(S[:, child], axis=-1, keepdims=True)
    return cip, pic


def pivot_offsets(
    cam_from_part: np.ndarray, size_m: np.ndarray, pivot: np.ndarray, axis_in_parent: np.ndarray, parent: int, child: int
) -> tuple[np.ndarray, np.ndarray]:
    """Where a revolute joint's axis passes in each of its two parts, in their unit boxes.

    The point is the foot ``f`` of the perpendicular from the parent's box centre to the axis line (the
    line through ``pivot`` along ``R_p a``), so that both parts describe the same point.

    Args:
        cam_from_part: ``(S, K, 4, 4)`` part poses of ``S`` views; size_m: ``(S, K, 3)`` box extents.
        pivot: ``(S, 3)`` a point on the joint axis per view (camera frame); axis_in_parent: ``(3,)`` unit.

    Returns:
        ``(pivot_in_parent, pivot_in_child)``, each ``(S, 3)``: ``R_p^T (f - t_p) / size_p`` and
        ``R_c^T (f - t_c) / size_c`` (elementwise division).
    """
    T = np.asarray(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    a = np.asarray(axis_in_parent, dtype=np.float64)
    a = a / np.linalg.norm(a)
    x = np.einsum("sji,sj->si", T[:, parent, :3, :3], np.asarray(pivot, np.float64) - T[:, parent, :3, 3])
    x = x - (x @ a)[:, None] * a  # the foot from the parent's centre, parent frame
    foot = np.einsum("sij,sj->si", T[:, parent, :3, :3], x) + T[:, parent, :3, 3]
    xc = np.einsum("sji,sj->si", T[:, child, :3, :3], foot - T[:, child, :3, 3])
    return x / S[:, parent], xc / S[:, child]


def upright_statistics(cam_from_part: np.ndarray, min_resultant: float = UPRIGHT_MIN_RESULTANT) -> list[tuple | None]:
    """Per part, the axis that the views hold upright: ``(axis, mean direction (3,), cone_deg)`` or ``None``.

    The axis is the part axis whose camera-frame directions have the longest mean (of length at least
    ``min_resultant``); ``cone_deg`` is the largest angle between it and its mean direction over the views.

    Args:
        cam_from_part: ``(S, K, 4, 4)`` part poses of ``S`` views.
    """
    R = np.asarray(cam_from_part, dtype=np.float64)[..., :3, :3]  # (S, K, 3, 3): columns = part axes in camera
    mean = R.mean(axis=0)  # (K, 3, 3)
    length = np.linalg.norm(mean, axis=1)  # (K, 3) per axis (column)
    out: list[tuple | None] = []
    for k in range(R.shape[1]):  # a handful of parts
        ax = int(np.argmax(length[k]))
        if length[k, ax] < min_resultant:
            out.append(None)
            continue
        m = mean[k][:, ax] / length[k, ax]
        cone = float(np.degrees(np.arccos(np.clip(R[:, k, :, ax] @ m, -1.0, 1.0))).max())
        out.append((ax, tuple(float(v) for v in m), cone))
    return out


def _seen_part_ranges(samples, K: int, quantile: float, max_occluded: float, min_points: int):
    """For every sample and part with at least ``min_points`` labelled points that other parts' boxes hide at most
    ``max_occluded`` of (at the true poses): ``(k, lo, hi, size, pattern, cam)``, the ``quantile`` and ``1 -
    quantile`` quantiles of its points in its frame, its extents ``(3,)``, its face patterns ``(3,)``
    (:func:`ucope.geometry.boxes.seen_pattern`) and the camera in its frame ``(3,)``."""
    from .geometry.boxes import occluded_fraction, seen_pattern

    for s in samples:  # one pass per sample; its points are handled with array operations
        T = np.asarray(s["cam_from_part"], dtype=np.float64)
        S = np.asarray(s["size_m"], dtype=np.float64)
        pts = np.asarray(s["points"], dtype=np.float64)
        lab = np.asarray(s["part_labels"])
        pat = seen_pattern(T, S)
        occ = occluded_fraction(T, S)
        cam = -np.einsum("kji,kj->ki", T[:, :3, :3], T[:, :3, 3])
        for k in range(K):  # a handful of parts
            sel = lab == k
            if np.count_nonzero(sel) < min_points or occ[k] > max_occluded:
                continue
            q = (pts[sel] - T[k, :3, 3]) @ T[k, :3, :3]
            lo, hi = np.quantile(q, [quantile, 1.0 - quantile], axis=0)
            yield k, lo, hi, S[k], pat[k], cam[k]


def _cell_percentiles(values: np.ndarray, cells: np.ndarray, shape: tuple, min_views: int) -> np.ndarray:
    """``shape + (3,)``: the 10th, 50th and 90th percentiles of ``values`` per flat cell index ``cells`` (into
    ``shape``), NaN in cells with fewer than ``min_views`` values."""
    out = np.full((int(np.prod(shape)), 3), np.nan)
    for c in np.unique(cells):  # one per filled cell: a few dozen
        v = values[cells == c]
        if len(v) >= min_views:
            out[c] = np.percentile(v, [10.0, 50.0, 90.0])
    return out.reshape(*shape, 3)


def seen_extent_statistics(
    samples: Sequence[Mapping[str, Any]],
    num_parts: int,
    quantile: float = SEEN_QUANTILE,
    max_occluded: float = SEEN_MAX_OCCLUDED,
    min_views: int = SEEN_MIN_VIEWS,
    min_points: int = 30,
) -> np.ndarray:
    """``(K, 3, SEEN_PATTERNS, 3)`` how much of each part axis the views saw, per face pattern.

    For every sample and part with at least ``min_points`` labelled points that other parts' boxes do not
    hide (:func:`ucope.geometry.boxes.occluded_fraction` at most ``max_occluded``, at the true poses): the
    seen ratio along each axis (``quantile`` to ``1 - quantile`` range of the points in the part's frame over
    its box extent) is filed under the axis's face pattern (:func:`ucope.geometry.boxes.seen_pattern`).
    Returns the 10th, 50th and 90th percentiles per part, axis and pattern; NaN where fewer than
    ``min_views`` views."""
    from .geometry.boxes import SEEN_PATTERNS

    K = int(num_parts)
    ratios, pattern, part, axis = [], [], [], []
    for k, lo, hi, size, pat, _ in _seen_part_ranges(samples, K, quantile, max_occluded, min_points):
        ratios.append((hi - lo) / size)
        pattern.append(pat)
        part.append(np.full(3, k))
        axis.append(np.arange(3))
    if not ratios:
        return np.full((K, 3, SEEN_PATTERNS, 3), np.nan)
    r, p, k, a = (np.concatenate(x) for x in (ratios, pattern, part, axis))
    return _cell_percentiles(r, (k * 3 + a) * SEEN_PATTERNS + p, (K, 3, SEEN_PATTERNS), min_views)


def faced_gap_statistics(
    samples: Sequence[Mapping[str, Any]],
    num_parts: int,
    quantile: float = SEEN_QUANTILE,
    max_occluded: float = SEEN_MAX_OCCLUDED,
    min_views: int = SEEN_MIN_VIEWS,
    min_points: int = 30,
) -> np.ndarray:
    """``(K, 3, 2, 3)`` how far each part's points stop short of the box face the camera faces.

    For every sample and part with at least ``min_points`` labelled points that other parts' boxes do not
    hide (at the true poses, as :func:`seen_extent_statistics`), and every axis along which the camera lies
    beyond a face of the box (side 0: the - face, 1: the + face): the gap from that face to the ``1 -
    quantile`` extreme of the points towards it, over the part's box diagonal (negative where noise takes
    points past the face). Returns the 10th, 50th and 90th percentiles per part, axis and side; NaN where
    fewer than ``min_views`` views."""
    K = int(num_parts)
    gaps, cells = [], []
    for k, lo, hi, size, _, cam in _seen_part_ranges(samples, K, quantile, max_occluded, min_points):
        half = 0.5 * size
        plus = cam > 0
        gap = np.where(plus, half - hi, half + lo) / np.linalg.norm(size)
        a = np.flatnonzero(np.abs(cam) > half)  # the axes along which the camera faces a face
        gaps.append(gap[a])
        cells.append((k * 3 + a) * 2 + plus[a])
    if not gaps:
        return np.full((K, 3, 2, 3), np.nan)
    return _cell_percentiles(np.concatenate(gaps), np.concatenate(cells), (K, 3, 2), min_views)


def shape_template_points(samples: Sequence[Mapping[str, Any]], part: int, max_points: int = TEMPLATE_POINTS) -> np.ndarray:
    """``(P, 3)`` float32 points of ``part`` seen in ``samples``, in its unit box (part frame / extents).

    The part's labelled points of every sample are pooled (evenly strided down to ``max_points``).
    Sensor noise throws points of thin parts well outside their box in unit-box coordinates: points
    beyond 0.75 of the box on any axis are dropped as outliers, the rest clipped onto the box
    ``[-0.5, 0.5]^3``. ``(0, 3)`` when the part is never seen."""
    pooled = []
    for s in samples:  # one transform per sample; vectorised over its points
        pts = np.asarray(s["points"], dtype=np.float64)[np.asarray(s["part_labels"]) == part]
        if len(pts):
            T = np.asarray(s["cam_from_part"], dtype=np.float64)[part]
            size = np.asarray(s["size_m"], dtype=np.float64)[part]
            q = ((pts - T[:3, 3]) @ T[:3, :3]) / size
            pooled.append(np.clip(q[np.abs(q).max(1) <= 0.75], -0.5, 0.5))
    allp = np.concatenate(pooled) if pooled else np.zeros((0, 3))
    if len(allp) == 0:
        return np.zeros((0, 3), dtype=np.float32)
    if len(allp) > max_points:
        allp = allp[np.linspace(0, len(allp) - 1, max_points).round().astype(np.int64)]
    return allp.astype(np.float32)


def stack_statistics(cam_from_part, size_m, joints: Sequence[JointPrior]) -> tuple[StackPrior, ...]:
    """The stacks of prismatic children (:class:`StackPrior`) that training views at the true poses show.

    Prismatic children of one parent sliding along one axis are grouped; along the parent axis across the
    slide on which their mean places (over the parent's extent) differ most, they are ordered from the
    ``+`` face down. They form a stack only where, in every view, each child's box ends above the next one's
    and the first lies within the parent's ``+`` face (each overlap at most :data:`STACK_MAX_OVERLAP`).

    Args:
        cam_from_part: ``(S, K, 4, 4)`` true part poses of ``S`` views; size_m: ``(S, K, 3)`` box extents.
        joints: the category's joints (types, parents, children, canonical axes).

    Returns:
        the stacks found, in the order of their first joints.

    Raises:
        InputError: poses and sizes of other shapes, or non-positive sizes.
    """
    T = np.asarray(cam_from_part, dtype=np.float64)
    S = np.asarray(size_m, dtype=np.float64)
    if T.ndim != 4 or T.shape[2:] != (4, 4) or S.shape != T.shape[:2] + (3,):
        raise InputError(f"cam_from_part must be (S, K, 4, 4) and size_m (S, K, 3), got {T.shape} and {S.shape}")
    if not (S > 0).all():
        raise InputError("size_m must be positive")
    groups: dict[tuple, list[int]] = {}
    for jp in joints:
        if jp.type == JointType.PRISMATIC:
            groups.setdefault((jp.parent, tuple(np.round(jp.axis_in_parent, 6))), []).append(jp.child)
    stacks = []
    for (p, axis), children in groups.items():
        across = [i for i in range(3) if abs(axis[i]) < 1e-6]
        if len(children) < 2 or not across:
            continue
        c = np.asarray(children)
        local = np.einsum("sji,snj->sni", T[:, p, :3, :3], T[:, c][..., :3, 3] - T[:, p, None, :3, 3])  # (S, n, 3)
        H = S[:, p]  # (S, 3)
        place = (local / H[:, None, :]).mean(0)  # (n, 3) mean places over the parent's extents
        i = across[int(np.argmax([np.ptp(place[:, a]) for a in across]))]
        order = np.argsort(-place[:, i], kind="stable")
        top = (local[:, order, i] + 0.5 * S[:, c[order], i]) / H[:, i, None]  # (S, n) each child's + face
        bottom = (local[:, order, i] - 0.5 * S[:, c[order], i]) / H[:, i, None]
        first = 0.5 - top[:, 0]
        gaps = bottom[:, :-1] - top[:, 1:]
        if (first < -STACK_MAX_OVERLAP).any() or (gaps < -STACK_MAX_OVERLAP).any():
            continue
        q1, q2 = np.percentile(first, [10.0, 90.0]), np.percentile(gaps, [10.0, 90.0])
        stacks.append(
            StackPrior(
                parent=p,
                axis=i,
                children=tuple(int(k) for k in c[order]),
                first_gap=float(np.median(first)),
                gap=float(np.median(gaps)),
                first_gap_spread=float(q1[1] - q1[0]),
                gap_spread=float(q2[1] - q2[0]),
            )
        )
    return tuple(stacks)


def max_state_over_extent(cam_from_child, size_child, axis_cam, state) -> float | None:
    """The largest prismatic state over the child's box extent along the joint's axis, over samples.

    Args:
        cam_from_child: ``(S, 4, 4)`` the child's true poses; size_child: ``(S, 3)`` its box extents (metres);
        axis_cam: ``(S, 3)`` the joint's axis (same frame); state: ``(S,)`` the joint's states (metres).

    Returns:
        ``max(state / extent)`` over the samples whose ratio is positive and finite (``None`` where none is).
    """
    R = np.asarray(cam_from_child, np.float64)[:, :3, :3]
    u = np.asarray(axis_cam, np.float64)
    u = u / np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-12)
    ext = np.einsum("si,si->s", np.abs(np.einsum("sji,sj->si", R, u)), np.asarray(size_child, np.float64))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.asarray(state, np.float64) / ext
    r = r[np.isfinite(r) & (r > 0)]
    return float(r.max()) if len(r) else None


def measure_priors(
    samples: Sequence[Mapping[str, Any]],
    category: str,
    structure: Mapping[str, Any],
    max_samples: int = 2000,
    template_samples: int = 400,
) -> CategoryPriors:
    """Measure a category's :class:`CategoryPriors` on (up to ``max_samples`` evenly spaced) training samples.

    Args:
        samples: an indexable sequence of sample dicts (:mod:`ucope.data.sample` fields: ``points``,
            ``part_labels``, ``cam_from_part``, ``size_m``, ``joint_axis``, ``joint_pivot``, ``joint_state``).
        category: the category's name.
        structure: the data set's declared structure (:func:`structure_from_dict`).
        template_samples: samples (evenly spaced) whose points make the shape templates.

    The statistics: vote range 1.1 x the largest half box diagonal, mean size = geometric mean, input
    scale = mean cloud radius, the range of :func:`cloud_radius` and its 2nd-98th percentiles, prismatic
    zero offsets and part placements at the true poses (with their spread for prismatic joints), joint
    limits = the declared limits widened to every state seen, revolute pivots in the parts' unit boxes
    (:func:`pivot_offsets`), how far prismatic children slide for their size (:func:`max_state_over_extent`), the
    upright axes (:func:`upright_statistics`), the seen extents
    (:func:`seen_extent_statistics`), the faced gaps (:func:`faced_gap_statistics`) and the stacks of prismatic
    children (:func:`stack_statistics`).
    Raises :class:`InputError` on an empty data set or samples that disagree with the structure.
    """
    from .geometry.kinematics import prismatic_zero_offset

    part_decl, joint_decl = structure_from_dict(structure)
    K, J = len(part_decl), len(joint_decl)
    n = len(samples)
    if n == 0:
        raise InputError("cannot measure category priors on an empty data set")
    idx = np.unique(np.linspace(0, n - 1, min(n, int(max_samples))).round().astype(np.int64))
    picked = [samples[int(i)] for i in idx]
    size = np.stack([np.asarray(s["size_m"], np.float64) for s in picked])
    if size.shape[1:] != (K, 3):
        raise InputError(f"samples have {size.shape[1]} parts, the structure declares {K}")
    if np.any(size <= 0) or not np.all(np.isfinite(size)):
        raise InputError("training samples hold a non-positive or non-finite part size")
    clouds = [np.asarray(s["points"], np.float64) for s in picked]
    radii = [float(np.linalg.norm(p - p.mean(0), axis=1).max()) for p in clouds]
    robust = [cloud_radius(p) for p in clouds]
    vote = 1.1 * 0.5 * np.linalg.norm(size, axis=-1).max(0)
    mean = np.exp(np.log(size).mean(0))
    T = np.stack([np.asarray(s["cam_from_part"], np.float64) for s in picked])
    upright = upright_statistics(T)
    seen = seen_extent_statistics(picked, K)
    gaps = faced_gap_statistics(picked, K)
    parts = tuple(
        PartPrior(
            name=nm,
            symmetry=sym,
            vote_range_m=float(vote[k]),
            mean_size_m=tuple(mean[k]),
            seen_extent=seen[k],
            faced_gap=gaps[k],
            **(dict(zip(("upright_axis", "upright_in_cam", "upright_cone_deg"), upright[k], strict=True)) if upright[k] else {}),
        )
        for k, (nm, sym) in enumerate(part_decl)
    )
    joints = []
    if J:
        P = np.stack([np.asarray(s["joint_pivot"], np.float64).reshape(J, 3) for s in picked])
        U = np.stack([np.asarray(s["joint_axis"], np.float64).reshape(J, 3) for s in picked])
        Q = np.stack([np.asarray(s["joint_state"], np.float64).reshape(J) for s in picked])
        for j, jd in enumerate(joint_decl):  # a handful of joints; vectorised over samples
            p, c = jd["parent"], jd["child"]
            zero = 0.0
            if jd["type"] == JointType.PRISMATIC:
                zero = prismatic_zero_offset(T[:, p], T[:, c], U[:, j], size[:, p], size[:, c], Q[:, j])
            cip, pic = placement_offsets(T, size, p, c)
            ratio = size[:, c] / size[:, p]
            extra: dict[str, Any] = dict(
                child_size_ratio=tuple(ratio.mean(0)), child_size_spread=tuple(ratio.std(0) / ratio.mean(0))
            )
            if jd["type"] == JointType.PRISMATIC:
                extra["child_in_parent_spread"] = tuple(cip.std(0))
                extra["max_state_over_extent"] = max_state_over_extent(T[:, c], size[:, c], U[:, j], Q[:, j])
            if jd["type"] == JointType.REVOLUTE and np.all(np.isfinite(P[:, j])):
                pp, pc = pivot_offsets(T, size, P[:, j], jd["axis_in_parent"], p, c)
                extra.update(pivot_in_parent=tuple(pp.mean(0)), pivot_in_child=tuple(pc.mean(0)))
            lo, hi = jd["limits"]
            lo = None if lo is None else min(lo, float(Q[:, j].min()))
            hi = None if hi is None else max(hi, float(Q[:, j].max()))
            joints.append(
                JointPrior(
                    type=jd["type"],
                    parent=p,
                    child=c,
                    axis_in_parent=tuple(jd["axis_in_parent"]),
                    limits=(lo, hi),
                    zero_offset_m=zero,
                    child_in_parent=tuple(cip.mean(0)),
                    parent_in_child=tuple(pic.mean(0)),
                    **extra,
                )
            )
    stacks = stack_statistics(T, size, joints)
    t_idx = np.unique(np.linspace(0, n - 1, min(n, int(template_samples))).round().astype(np.int64))
    t_samples = [samples[int(i)] for i in t_idx]
    templates = tuple(shape_template_points(t_samples, k) for k in range(K))
    return CategoryPriors(
        category=category,
        parts=parts,
        joints=tuple(joints),
        norm_scale_m=float(np.mean(radii)),
        num_samples=len(idx),
        radius_range_m=(min(robust), max(robust)),
        radius_typical_m=tuple(float(v) for v in np.percentile(robust, [2.0, 98.0])),
        shape_templates=templates,
        stacks=stacks,
    )
