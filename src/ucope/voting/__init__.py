"""Voting: the paper's 9D part poses and joints from the network's per-pair and per-point outputs.

Pure maths: it needs a model's stored :class:`ucope.priors.CategoryPriors` and the outputs named in
:mod:`ucope.vocab` (``VOTE_HEADS``, ``AXIS_HEADS``, the joint heads), never the network code nor the
generators. No Python loops over pairs or points: the stages over every pair (decoding, grid votes,
inlier tests) run in float32 torch on the device of the inputs, the iterative refinements on their
subsets of at most ~1000 pairs in float64 numpy. What the estimator does after voting (flips, upright,
boxes from points, joint states...) is in :mod:`ucope.stages`. See docs/voting.md for the algorithms.

* :func:`decode_bins`: binned logits -> values (expectation around the argmax).
* :func:`vote_centre` (:class:`CentreOptions`): centre from the pairs' ``(mu, nu)`` circles.
* :func:`vote_axis` (:class:`AxisOptions`), :func:`choose_axis_sign`: an axis from the pairs' cones.
* :func:`rotation_from_axes`, :func:`refine_rotation`: rotation from voted axes.
* :func:`vote_part`, :func:`vote_parts` (:class:`VotingOptions`): one part / every part of an object.
* :func:`joint_from_points`, :func:`vote_joints`: joint pivot and axis from the joint heads.
"""

from __future__ import annotations

from .axis import AxisOptions, choose_axis_sign, fibonacci_sphere, vote_axis
from .bins import decode_bins
from .centre import CentreOptions, circle_distance, vote_centre
from .joints import JointVote, joint_from_points, vote_joints
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
]
