"""Voting layer: 9D part poses and joints from the network's per-pair and per-point outputs.

Pure geometry (no network code, no Python loops over pairs or points): the stages over every pair
(decoding, grid votes, inlier tests) in float32 torch on the device of the inputs, the iterative
refinements on their subsets of at most ~1000 pairs in float64 numpy (dozens of small operations per
iteration, where numpy's per-call cost is a fraction of torch's). See docs/voting.md for the algorithms, defaults and measured accuracy.

* :func:`decode_bins`: binned logits -> values (expectation around the argmax).
* :func:`vote_centre`: centre from the pairs' ``(mu, nu)`` circles (grid vote + Gauss-Newton).
* :func:`vote_axis`, :func:`choose_axis_sign`: an axis from the pairs' directed cones.
* :func:`rotation_from_axes`, :func:`refine_rotation`: rotation from voted axes.
* :func:`vote_part`, :func:`vote_parts`: one part / every part of an object.
* :func:`joint_from_points`, :func:`vote_joints`: joint pivot and axis from the joint heads.
* :func:`vote_object`: parts + joints + joint states, optionally :func:`kinematic_refine`.
"""

from __future__ import annotations

from .axis import choose_axis_sign, fibonacci_sphere, vote_axis
from .bins import decode_bins
from .centre import circle_distance, vote_centre
from .rotation import perpendicular_axis, refine_rotation, rotation_from_axes
from .part import PartVote, VotingOptions, vote_part, vote_parts
from .joints import JointVote, joint_from_points, vote_joints
from .kinematic import kinematic_refine, resolve_joint_flips, resolve_shape_flips
from .object import vote_object

__all__ = [
    "decode_bins",
    "vote_centre",
    "circle_distance",
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
    "kinematic_refine",
    "resolve_joint_flips",
    "resolve_shape_flips",
    "vote_object",
]
