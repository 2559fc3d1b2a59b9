"""Voting: 9D part poses and joints from the network's per-pair and per-point outputs.

Pure maths: it needs a model's stored :class:`ucope.priors.CategoryPriors` and the outputs named in
:mod:`ucope.vocab` (``VOTE_HEADS``, ``AXIS_HEADS``, the joint heads), never the network code nor the
generators. No Python loops over pairs or points: the stages over every pair (decoding, grid votes,
inlier tests) run in float32 torch on the device of the inputs, the iterative refinements on their
subsets of at most ~1000 pairs in float64 numpy (dozens of small operations per iteration, where
numpy's per-call cost is a fraction of torch's). See docs/voting.md for the algorithms, defaults and
measured accuracy.

* :func:`decode_bins`: binned logits -> values (expectation around the argmax).
* :func:`vote_centre` (:class:`CentreOptions`): centre from the pairs' ``(mu, nu)`` circles.
* :func:`vote_axis` (:class:`AxisOptions`), :func:`choose_axis_sign`: an axis from the pairs' cones.
* :func:`rotation_from_axes`, :func:`refine_rotation`: rotation from voted axes.
* :func:`vote_part`, :func:`vote_parts` (:class:`VotingOptions`): one part / every part of an object.
* :func:`joint_from_points`, :func:`vote_joints`: joint pivot and axis from the joint heads.
* :func:`resolve_joint_flips`, :func:`resolve_shape_flips` (:class:`ShapeIndex`), :func:`kinematic_refine`.
* :func:`carry_upright`, :func:`upright_angles_deg`: a part voted far off its upright, re-placed from a neighbour.
* :func:`turn_upright`: a part of a rigid object voted upside down, turned over by the half turn its points fit
  best, its centre placed from its points.
* :func:`carry_child_sizes`: a child's extents carried from its parent's measured ones where their ratio is fixed.
* :func:`hold_prismatic_children`: a cabinet's box widened across the slides to hold its drawers' points too.
* :func:`carry_prismatic_depths`: a drawer as deep as its cabinet says, its front kept.
* :func:`place_prismatic_children`: a drawer put where its cabinet always holds it across its slide.
* :func:`slide_to_fronts`: a drawer slid along its slide until its front meets its points.
* :func:`stack_hidden_children`: a hidden drawer put against a seen one in its stack (or under its cabinet's top).
* :func:`turn_thin_children`: a thin revolute child (a door, a lid) turned about its joint to lie along its points.
* :func:`resolve_front_flips`: a cabinet turned round, its drawers with it, where its drawers' points say its front
  is its back.
* :func:`slide_weak_children` (:func:`exposed_surface_share`): a hidden drawer voted pulled out where the camera would
  have seen it, slid back to the nearest state the view allows.
* :func:`settle_joint_states`: joint states read off the final boxes and clamped into the limits.
* :func:`vote_object`: parts + joints + joint states (+ the flip checks, the optional refinement).
* :func:`grow_to_points`: boxes widened to hold the points segmented as their part (objects of unseen shapes).
* :func:`fit_seen_extents`: box axes that views like this one see whole, set from the part's points (larger or
  smaller than voted), by the seen-extent percentiles the training views measured.
* :func:`anchor_faced_faces`: box centres moved so that the faces the camera faces sit where the points put
  them (the face-to-points gaps the training views measured).
* :func:`align_to_faces`, :func:`align_parts_to_faces`: rotations turned so that box axes meet the normals of flat faces.
* :func:`place_weak_parts`: a part the camera barely sees, turned about its joint to where its box hides none of the
  points the camera sees and its own points lie on it (free space).
"""

from __future__ import annotations

from .axis import AxisOptions, choose_axis_sign, fibonacci_sphere, vote_axis
from .bins import decode_bins
from .centre import CentreOptions, circle_distance, vote_centre
from .extent import anchor_faced_faces, fit_seen_extents, grow_to_points
from .faces import align_parts_to_faces, align_to_faces
from .freespace import exposed_surface_share, place_weak_parts, slide_weak_children
from .joints import JointVote, joint_from_points, vote_joints
from .kinematic import (
    UPRIGHT_MARGIN_DEG,
    ShapeIndex,
    carry_child_sizes,
    carry_prismatic_depths,
    carry_upright,
    hold_prismatic_children,
    kinematic_refine,
    place_prismatic_children,
    resolve_front_flips,
    resolve_joint_flips,
    resolve_shape_flips,
    seat_weak_parts,
    settle_joint_states,
    slide_to_fronts,
    stack_hidden_children,
    turn_thin_children,
    turn_upright,
    upright_angles_deg,
)
from .object import part_fit, regressed_object, regression_scores, vote_object
from .part import PartVote, VotingOptions, vote_part, vote_parts
from .rotation import perpendicular_axis, refine_rotation, rotation_from_axes

__all__ = [
    "decode_bins",
    "CentreOptions",
    "vote_centre",
    "circle_distance",
    "AxisOptions",
    "fibonacci_sphere",
    "vote_axis",
    "choose_axis_sign",
    "rotation_from_axes",
    "perpendicular_axis",
    "refine_rotation",
    "VotingOptions",
    "PartVote",
    "vote_part",
    "vote_parts",
    "JointVote",
    "joint_from_points",
    "vote_joints",
    "ShapeIndex",
    "kinematic_refine",
    "resolve_joint_flips",
    "resolve_front_flips",
    "resolve_shape_flips",
    "carry_upright",
    "turn_upright",
    "carry_child_sizes",
    "carry_prismatic_depths",
    "hold_prismatic_children",
    "upright_angles_deg",
    "place_prismatic_children",
    "slide_to_fronts",
    "stack_hidden_children",
    "turn_thin_children",
    "seat_weak_parts",
    "settle_joint_states",
    "vote_object",
    "part_fit",
    "regressed_object",
    "regression_scores",
    "grow_to_points",
    "fit_seen_extents",
    "anchor_faced_faces",
    "align_to_faces",
    "align_parts_to_faces",
    "place_weak_parts",
    "slide_weak_children",
    "exposed_surface_share",
    "UPRIGHT_MARGIN_DEG",
]
