"""The :class:`Estimator`: a trained network plus the voting, from a point cloud (or RGB-D frame) to a
:class:`ucope.estimation.result.PoseResult`.

Pipeline of :meth:`Estimator.predict` (timed stage by stage in ``result.timings_ms``):

1. **preprocess**: rows with NaN / Inf are dropped (with a warning); a cloud larger than
   ``max_input_points`` (4096, the density the models were trained on) is subsampled uniformly; normals
   are estimated (kNN PCA, k = 16) unless given; ``num_points`` points (the model's) are drawn for the
   network, with their farthest-point-sampling indices.
2. **encoder**: PointNet++ features, part masks and segmentation, joint heads.
3. **pair_encoder**: ``num_pairs`` point pairs (default 20,000, as the paper), split evenly over the
   parts; with part awareness the pairs of part ``k`` are drawn from the points segmented as ``k``.
   Every pair gets the centre, size and part-score heads; the widest heads, the axis angles and sign
   bits, are left for the next stage to compute on the pairs that vote the axes (at most
   ``VotingOptions.max_axis_pairs`` per part, usually a tenth of them), with identical results.
   (For the direct-regression baseline, ``ModelConfig.head == "regression"``, this stage is its pose
   regression head instead, and the next one reads the regressed poses.)
4. **voting**: per part, centre, axes (with their heads, above) and size by voting (:mod:`ucope.voting`); per joint, pivot and
   axis from the joint heads; joint states from the part poses; optionally the kinematic refinement.

Stages 2-4 run twice where the first run segments part of the cloud as not the object or finds it outside
the model's sizes: the second run sees the object's points only (``Estimator(recrop=True)``, the
default; the timings are the sums). Right after voting, in every run, a parent whose prismatic
children's points say its front is its back (a cabinet seen from behind, turned round) is turned round
with them (``flip_fronts``). Where the result's calibrated score is below :data:`SCALE_SEARCH_BELOW`,
the whole is repeated on the cloud normalised to the model's typical size (``scale_search``; at 0.8, 1 and
1.25x it with ``wide_scale_search``) and the highest-scored estimate stands (by its lowest part score, or, with
``pick_seen_parts``, the lowest over the parts given points). In every run, after the part
scores, boxes are widened to their points (``grow_boxes``), the axes that views like this one see whole are
set from the points (``fit_extents``), the root part's faces that the camera faces are put where its points
are (``anchor_faces``), a parent's box is widened across its prismatic children's slides to hold their points
(``hold_children``), each prismatic child is given the depth its parent says it has, its front kept
(``carry_depths``), put where its parent always held it across the joint's axis (``place_children``), slid
along it to where its points end (``slide_fronts``), and, where a view hides it, stacked against a seen sibling
(``stack_children``) and slid back to the nearest state the view leaves room for (``free_slides``); each thin
revolute child is turned about its joint's axis to lie along its own points (``turn_children``). Last, every
joint state is read off the final boxes and clamped into the category's limits (the child moved with it, the
joint's score halved where clamped): a reported state always agrees with the reported part poses and lies
inside the limits; then a part that shows few points and came loose from its hinge
is seated back on it (``seat_parts``; a revolute state does not depend on where the centre stands). The upright
carry in voting acts beyond the training cone plus a margin, or at the cone itself (``carry_in_cone``).

Every random draw comes from ``seed`` (default 0): the same input gives the same result.
"""

from __future__ import annotations

import hashlib
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from ..errors import InputError
from ..geometry.denoise import smooth_points, surface_noise
from ..geometry.normals import estimate_normals
from ..geometry.sampling import random_subset
from ..model.checkpoint import find_model, load_model
from ..model.network import UCOPENet
from ..model.pointnet2 import numpy_fps_indices
from ..priors import cloud_radius
from ..vocab import AXIS_HEADS, VOTE_HEADS, JointType
from ..voting import (
    UPRIGHT_MARGIN_DEG,
    ShapeIndex,
    VotingOptions,
    anchor_faced_faces,
    carry_child_sizes,
    carry_prismatic_depths,
    fit_seen_extents,
    grow_to_points,
    hold_prismatic_children,
    place_prismatic_children,
    place_weak_parts,
    regressed_object,
    resolve_front_flips,
    seat_weak_parts,
    settle_joint_states,
    slide_to_fronts,
    slide_weak_children,
    stack_hidden_children,
    turn_thin_children,
    vote_object,
)
from .confidence import Calibration, part_features
from .inputs import (
    MIN_POINTS,
    NORMAL_K,
    SupportPlane,
    find_support_plane,
    label_points,
    prepare_points,
    rgbd_points,
    roll_to_up,
)
from .result import JointEstimate, PartEstimate, PoseResult

__all__ = [
    "Estimator",
    "MAX_PAIRS",
    "EXTENT_REFUSE",
    "EXTENT_WARN",
    "DENOISE_K",
    "DENOISE_MIN_POINTS",
    "RECROP_MIN_FRACTION",
    "RESCALE_CORE_FACTOR",
    "SCALE_SEARCH_BELOW",
]

MAX_PAIRS = 1_000_000
"""The most point pairs per object (the pair encoder holds ``num_pairs x hidden`` floats)."""

EXTENT_WARN = 1.5
"""A cloud whose size (:func:`ucope.priors.cloud_radius`) is more than this factor outside the model's
training range gets a warning."""

EXTENT_REFUSE = 20.0
"""... and more than this factor outside it is refused (another unit, or not this kind of object)."""

DENOISE_K = 48
"""Neighbours of the local planes the estimator's smoothing projects onto (two steps,
:func:`ucope.geometry.denoise.smooth_points`)."""

DENOISE_MIN_POINTS = 1000
"""Clouds with fewer points are never smoothed: their neighbourhoods are too wide, and their surface
noise (:func:`ucope.geometry.denoise.surface_noise`) measures curvature more than noise."""


RESCALE_CORE_FACTOR = 1.4
"""The rescaling measures a cloud by its 90th-percentile radius, but at most this factor times twice its
median radius (its core): on clean views of the shipped categories the 90th-percentile radius is at most
1.4-1.7x the core, while a floor seen far behind the object or other stray points raise it alone (to
2-15x), and the rescaling would then shrink the object."""

RECROP_MIN_FRACTION = 0.03
"""With ``Estimator(recrop=True)``, a first pass that segments at least this share of the cloud (and at
least :data:`ucope.estimation.inputs.MIN_POINTS` points) as not the object (the background class or a
support plane) is followed by a second pass on the rest. (A few stray labels in a sparse cloud are not
worth it: the second pass would only see fewer points.)"""


FIT_EXTENTS_BELOW = 0.9
"""With ``fit_extents``, only parts whose calibrated score is below this get axes set from their points; parts the
calibration is sure of keep their voted boxes (a model without a calibration fits every part). The shipped
dishwasher, 200 test and 100 OOD views, with the rule's first version (docs/results.md): every part 80 / 58 %
success, parts below 0.9 82 / 57 %, below 0.8 82 / 51 %, fit off 82.5 / 48 %."""

FIT_EXTENTS_MIN_INPUT = 1000
"""With ``fit_extents``, a cloud of fewer points than this keeps its voted boxes: the seen ratios were measured on
clouds of a few thousand points, and a sparse cloud's extremes fall short of its faces (the shipped dishwasher's
robustness benchmark at 200 points: 45 % success without fitting, 38 % fitting every cloud)."""

ANCHOR_MIN_INPUT = 600
"""With ``anchor_faces``, a cloud of fewer points than this keeps its voted centres (the shipped eyeglasses'
robustness benchmark at 500 points: 90 % success without anchoring, 82 % anchoring every cloud; their test clouds
hold 1,170 points median, 470 at the 10th percentile)."""

ANCHOR_MAX_NOISE_M = 1.5e-3
"""With ``anchor_faces``, a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`, metres) is
above this keeps its voted centres: noise moves the extreme points the faces are put at. The shipped eyeglasses'
validation views measure 0.7 mm median, 1.27 mm at most; with 5 mm of added noise 1.6-2.0 mm."""

SCALE_SEARCH_BELOW = 0.9
"""With ``Estimator(scale_search=True)``, the further estimates (on the normalised cloud) run only where the
first's object score (a calibrated success probability) is below this. Measured on 20 test views per
model at 0.7, 1, 1.5 and 2x (benchmarks/bench_scale.py's views, 8 models): the success of always searching
in every cell but one (eyeglasses at 0.7x: 55 instead of 60 %), while at 1x the second estimate is skipped
on 70-95 % of the views of laptop, laptop_rigid, mug and scissors, 20-45 % of eyeglasses, dishwasher and
camera, and none of the drawer's (whose scores stay low)."""

WIDE_SCALE_SEARCH = (0.8, 1.0, 1.25)
"""With ``Estimator(wide_scale_search=True)``, the scale search estimates on the cloud normalised to these
factors of the middle of the model's typical radii (:meth:`Estimator.input_scale`), not to the middle
alone: a cloud's radius says only roughly how large its object is (a view of a pair of glasses from the
front spans more than one from the side), and normalised to the one radius such objects come out too large
or too small by 10-20 % with their box centres moved along. The calibrated object score picks among the
estimates. Measured on benchmarks/bench_scale.py's views, the scale curve at 0.5 / 0.7 / 1 / 1.5 / 2x
(30 views each, success %): eyeglasses 73 / 80 / 93 / 73 / 77 -> 83 / 87 / 93 / 90 / 93, laptop 77 / 80 / 90 /
87 / 83 -> 87 / 90 / 90 / 90 / 90; seven factors from 0.7 to 1.4 did no better (88 and 89 % mean against 89
and 89). docs/results.md has the OOD split and the models it is on for."""


RESTART_BELOW = 0.8
"""With ``Estimator(restarts=N)``, a further estimate from another draw of the network's points and of the pairs
runs while the best object score so far (a calibrated success probability) is below this, up to ``N`` more.
Measured by benchmarks/bench_restarts.py on 100 drawer test views, each estimated with five estimator seeds,
the rule simulated on every order of the draws (success %, estimates per view): one draw 44.4, 1; at most 3 / 5
draws below 0.5: 47.4, 1.76 / 49.1, 2.44; below 0.8: 49.3, 2.50 / 52.6, 3.91; always all five: 53.0, 5.
docs/results.md has the models it is on for."""

MAX_RESTARTS = 16
"""The most further estimates ``Estimator(restarts=...)`` takes."""


COMPACT_FACTOR = 1.8
"""A cloud is compact (:func:`compact`) when its 90th-percentile radius is at most this factor times twice
its median radius: above the 1.4-1.7 of every clean view of the shipped categories, below the 2-15 of
views with a floor seen far behind the object."""


def _radii(pts: np.ndarray) -> tuple[np.ndarray, float, float]:
    """``(centre (3,), outer, core)`` of a cloud ``(N, 3)``: its median point, its 90th-percentile radius
    about it (:func:`ucope.priors.cloud_radius`) and twice its median radius (metres)."""
    centre = np.median(pts, axis=0)
    return centre, cloud_radius(pts), 2.0 * float(np.median(np.linalg.norm(pts - centre, axis=1)))


def compact(pts: np.ndarray) -> bool:
    """Whether the cloud ``pts`` ``(N, 3)`` looks like one object alone: its 90th-percentile radius about
    its median point (:func:`ucope.priors.cloud_radius`) at most :data:`COMPACT_FACTOR` x twice its
    median radius. A floor or stray points far from the object fail it."""
    _, outer, core = _radii(pts)
    return outer <= COMPACT_FACTOR * core


def _object_score(p: _Pass) -> float:
    """The object score of a pass: its smallest part score (:attr:`PoseResult.score`)."""
    return min(pe.score for pe in p.parts)


def _seen_score(p: _Pass) -> float:
    """The smallest score of the parts of a pass that were given at least one point (all parts where none was):
    a part no point was segmented as has no evidence for either estimate (``Estimator(pick_seen_parts=True)``)."""
    count = np.bincount(p.labels[p.labels >= 0], minlength=len(p.parts))
    seen = [pe.score for pe, n in zip(p.parts, count, strict=False) if n > 0]
    return min(seen) if seen else _object_score(p)


@dataclass
class _Estimate:
    """One or two passes of :meth:`Estimator.predict` (:meth:`Estimator._estimate`): the one that stands,
    the labels of the prepared cloud's points, the support planes left out, summed timings, warnings."""

    final: _Pass
    labels: np.ndarray
    planes: list
    timings: dict
    warnings: list[str]
    normalise: float | None = None  # the scale it was made at (:meth:`Estimator.input_scale`)


@dataclass
class _Pass:
    """One estimate of :meth:`Estimator.predict` on a prepared cloud of ``P`` points."""

    parts: list[PartEstimate]
    joints: list[JointEstimate]
    labels: np.ndarray  # (P,) part index per point, -1: support plane or background class
    plane: SupportPlane | None
    features: np.ndarray
    warnings: list[str]  # about this estimate
    input_warnings: list[str]  # about the cloud (a plane left out, mostly background): kept from a first pass
    timings: dict[str, float]


def _device(device) -> torch.device:
    """``device`` as a usable torch device, or an InputError naming the problem."""
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError) as e:
        raise InputError(f"device {device!r} is not a torch device ({e})") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"device {device!r}: no CUDA device is available here")
    if dev.type not in ("cpu", "cuda", "mps"):
        raise InputError(f"device {device!r}: use cpu, cuda or mps")
    return dev


class Estimator:
    """Estimates the 9D part poses, joints and segmentation of objects of one category.

    Everything it needs about the category comes from the model (``model.cfg.priors``): it never
    imports the generators.

    Args:
        model: a trained :class:`ucope.model.network.UCOPENet` (or the regression baseline).
        name: the model's name (shown in results).
        num_pairs: point pairs per object (split over the parts); the paper uses 20,000.
        awareness: the paper's joint and part awareness (section 4.5): only pairs whose part score
            passes 0.5 vote for a part, part ``k``'s pairs are drawn from the points segmented as
            ``k``, and only points whose joint score and heatmap pass 0.5 locate a joint. ``False``
            turns all three off (the ablation of Table 3).
        score_filter, segment_pairs: override the first two mechanisms separately (``None``: follow
            ``awareness``), to measure each on its own.
        refine: the kinematic refinement (off here; :meth:`load` takes the model's default, see
            docs/results.md for its measured effect).
        resolve_flips: turn back parts whose rotation is a half turn away from what their revolute
            joint allows (:func:`ucope.voting.resolve_joint_flips`) and rigid objects whose rotation is
            a half turn away from what their shape fits (:func:`ucope.voting.resolve_shape_flips`); on
            by default, measured in docs/voting.md.
        seed: seed of the subsampling and pair draws (an integer >= 0).
        device: torch device of the network (``"cpu"``, ``"cuda"``, ``"cuda:1"``...).
        max_input_points: clouds above this many points are subsampled uniformly first (4096: the
            density the models were trained on; at least :data:`ucope.estimation.inputs.MIN_POINTS`).
        options: :class:`ucope.voting.VotingOptions`.
        calibration: the model's score calibration (:class:`ucope.estimation.confidence.Calibration`;
            :meth:`load` reads it from the model file): part scores become success probabilities and
            an object below its threshold gets a warning. ``None``: scores are the raw vote scores.
        rescale: bring a cloud whose size (:func:`ucope.priors.cloud_radius`) lies outside the range the
            model was trained on (``priors.radius_range_m``) to the middle of that range, scaling it
            about its median point, estimate there, and scale the poses, sizes, pivots and prismatic
            states back (:meth:`predict`). Clouds inside the range are untouched. On by default; measured
            in docs/results.md (objects at 0.5-2x the training sizes).
        remove_plane: look for a floor or table plane under the object that the segmentation let in
            (:func:`ucope.estimation.inputs.find_support_plane`) and leave it out (its points get the label
            -1). Off here; :meth:`load` takes the model's default (on where it measured better:
            docs/robustness.md).
        upright: re-place a part that voting tilted far off the upright the training views kept it in
            (a laptop base hidden behind its lid) from a neighbour through their joint
            (:func:`ucope.voting.kinematic.carry_upright`); its score is halved and a warning says so. A
            part of an object without joints voted upside down is turned over by a half turn
            (:func:`ucope.voting.kinematic.turn_upright`, with a warning). It assumes an upright camera
            looking from the training elevations: pass ``False`` for a rolled camera or one below the object.
            On by default; measured in docs/results.md.
        denoise_above_m: smooth a cloud whose surface noise (:func:`ucope.geometry.denoise.surface_noise`,
            metres) is above this (:func:`ucope.geometry.denoise.smooth_points`, with a warning); clouds
            under :data:`DENOISE_MIN_POINTS` points never are. ``None`` (here): never; :meth:`load`
            takes the model's default (set where it measured better: docs/robustness.md).
        recrop: estimate in two passes where needed (:meth:`predict`): a first one, rescaled only where
            the cloud is :func:`compact`, segments the cloud; when it leaves at least
            :data:`RECROP_MIN_FRACTION` of the points out as not the object (the background class of
            models trained with one, a support plane) or the
            object's points need the rescaling, a second one estimates on the object's points alone. On
            by default; measured in docs/robustness.md.
        scale_search: with ``rescale``, estimate twice, on the cloud at the scale the rescaling gives it
            and on the cloud normalised to the middle of the model's typical radii whatever its size
            (:meth:`input_scale` with ``normalise=1.0``), where the first's object score is below
            :data:`SCALE_SEARCH_BELOW`, and return the estimate with the higher object score
            (:attr:`PoseResult.score`; ties: the first). An object 1.5x larger than the
            model's sizes still lies inside the radii it saw and is not rescaled, but its boxes come out
            too small; normalised it is estimated where the model knows it, while a view the first
            estimate gets right keeps its higher score. Only for a model with a ``calibration`` (its
            scores predict success; raw vote scores do not). Costs a second estimate; on by default,
            measured in docs/results.md.
        wide_scale_search: the scale search tries the cloud normalised to each factor of
            :data:`WIDE_SCALE_SEARCH` of the middle of the typical radii, not to the middle alone (two more
            estimates where it runs; an estimate identical to one already made is not made again). Off
            here; :meth:`load` takes the model's default (on where it measured better: docs/results.md).
        carry_in_cone: the upright carry (:func:`ucope.voting.carry_upright`, with ``upright``) re-places a part as
            soon as its upright axis leaves the cone its training views held it in, not only beyond
            :data:`ucope.voting.UPRIGHT_MARGIN_DEG` more: a laptop base seen from behind voted 33-39 degrees off
            its upright while no test view held it more than 29 degrees off. Off here; :meth:`load` takes the
            model's default (on for the shipped laptop and scissors, measured in docs/results.md).
        pick_seen_parts: the scale search and the restarts keep the estimate whose smallest score over the parts
            given at least one point is highest, not the smallest over all parts: the score of a part no point was
            segmented as (a closed door seen from behind) compares nothing. Off here; :meth:`load` takes the
            model's default (on for the shipped dishwasher, measured in docs/results.md).
        grow_boxes: widen every part's box to hold the points segmented as that part
            (:func:`ucope.voting.grow_to_points`: never shrunk, thin axes and parts symmetric about y
            kept; only points joined to the box that the segmentation is sure are not background), after
            the part scores are computed: objects whose shape family the model never saw
            get boxes of their own proportions rather than the training objects'. Off here;
            :meth:`load` takes the model's default (on where it measured better: docs/results.md,
            docs/robustness.md).
        fit_extents: set the box axes that views like this one see whole from the points segmented as their
            part, larger or smaller than voted (:func:`ucope.voting.fit_seen_extents`, with the model's
            ``PartPrior.seen_extent``; parts another part hides are left alone), after the box growth: objects
            of proportions the training never had are measured rather than pulled to the training sizes; a
            child's extents then follow its parent's measured ones where their ratio never varies
            (:func:`ucope.voting.carry_child_sizes`: a dishwasher door as wide as its body). Off
            here; :meth:`load` takes the model's default (on where it measured better: docs/results.md).
            Only parts whose calibrated score is below :data:`FIT_EXTENTS_BELOW` (every part without a
            calibration).
        anchor_faces: move the root part's box (part 0) along each axis whose face the camera faces so that
            the face sits where the part's points put it (:func:`ucope.voting.anchor_faced_faces`, with the
            model's ``PartPrior.faced_gap``; axes set by ``fit_extents`` kept), after it: a spectacle frame
            seen from behind gets its depth from its visible back. The root only: a child's points end where
            the segmentation puts its seam with its parent (the eyeglasses' temples: success 95 -> 83 %). Off
            here; :meth:`load` takes the model's default (on where it measured better: docs/results.md).
        align_faces: turn each voted part rotation so that its box axes meet the normals of the part's
            flat faces (:func:`ucope.voting.align_parts_to_faces`; a drawer takes its cabinet's turn,
            parts symmetric about y are left alone), before the joint checks and the part scores. Off
            here; :meth:`load` takes the model's default (on for box-like parts where it measured better:
            docs/results.md).
        free_space: turn a part that shows few points (below ``WEAK_SHARE`` of the object's; a laptop base
            behind its lid) about its revolute joint to where its box hides none of the other parts' points
            from the camera and its own points lie on it (:func:`ucope.voting.place_weak_parts`), after the
            box steps, before the joint states are read off the boxes. Off here; :meth:`load` takes the
            model's default (on where it measured better: docs/results.md).
        hold_children: widen a parent's box (a cabinet) across its prismatic children's slides until it holds their
            points as well as its own (:func:`ucope.voting.hold_prismatic_children`), after the box fits and
            before ``carry_depths``; on by default, measured in docs/results.md.
        carry_depths: give each prismatic child (a drawer) the extent along its joint's axis that its parent's box
            and the training views' size ratio say it has, its leading face kept
            (:func:`ucope.voting.carry_prismatic_depths`), after the box fits and before ``place_children``. Acts
            only where that ratio varied little (``DEPTH_MAX_SPREAD``); on by default, measured in docs/results.md.
        place_children: put each prismatic child (a drawer) where the training views always had it across
            its joint's axis (left-right in its cabinet: :func:`ucope.voting.place_prismatic_children`),
            after the part scores and the box growth. Acts only on models whose priors measured that
            spread (``JointPrior.child_in_parent_spread``); on by default, measured in docs/results.md.
        slide_fronts: slide each prismatic child (a drawer) whose leading face stands more than
            ``FRONT_MIN_SHIFT`` of its diagonal from where its points end along its joint's axis until it meets
            them (:func:`ucope.voting.slide_to_fronts`), after ``place_children``; on by default, measured in
            docs/results.md.
        stack_children: put each child of a stack (:class:`ucope.priors.StackPrior`: the drawers of a chest) that
            shows fewer than ``STACK_MIN_POINTS`` points against its nearest seen sibling, or under its parent's
            face (:func:`ucope.voting.stack_hidden_children`), after ``slide_fronts``. Acts only on models whose
            priors hold stacks; on by default, measured in docs/results.md.
        turn_children: turn each thin revolute child (a dishwasher door, a laptop lid) about its joint's axis until
            its box lies along its own points, seen along that axis (:func:`ucope.voting.turn_thin_children`),
            after the other box steps and before the joint states are read off the boxes; on by default, measured
            in docs/results.md.
        flip_fronts: turn a parent and its prismatic children (a cabinet and its drawers) round about the parent's
            upright axis where the children's points lie behind its centre, or where its front faces the camera
            and they show almost no points (:func:`ucope.voting.resolve_front_flips`), right after voting; on by
            default, measured in docs/results.md.
        free_slides: slide each prismatic child that shows fewer than ``SLIDE_MIN_POINTS`` points (a hidden drawer)
            back to the nearest state where the camera would not have seen its box (:func:`ucope.voting.
            slide_weak_children`), after ``stack_children``; where the view hides every state, it keeps its voted
            one. Off here; :meth:`load` takes the model's default (on for the shipped drawer, measured in
            docs/results.md).
        seat_parts: put the centre of a part that shows few points (a closed door seen from behind) and stands off
            its hinge where its revolute joint's axis meets its well-seen neighbour's box
            (:func:`ucope.voting.seat_weak_parts`), after the joint states are read off the boxes. Off here;
            :meth:`load` takes the model's default (on for the shipped dishwasher, measured in docs/results.md).
        restarts: up to this many further estimates, each from another draw of the network's points and of
            the pairs (at the scale the estimate so far was made at), while the best object score so far is
            below :data:`RESTART_BELOW`; the highest-scored estimate stands (ties: the earlier). One draw of
            1,024 points decides much of an estimate: on 100 drawer test views five draws succeeded on 40-49 %
            each and at least one of them on 61 %. Only for a model with a ``calibration``; each further
            estimate costs about one more. 0 here; :meth:`load` takes the model's default (``info.defaults.
            restarts``, set where it measured better: docs/results.md).

    Raises:
        InputError: a setting out of range (``num_pairs`` outside 10..:data:`MAX_PAIRS`, a negative
            seed, an unknown or unavailable device...), naming it.
    """

    def __init__(
        self,
        model: UCOPENet,
        name: str = "",
        num_pairs: int = 20000,
        awareness: bool = True,
        refine: bool = False,
        seed: int = 0,
        device: str | torch.device = "cpu",
        max_input_points: int = 4096,
        resolve_flips: bool = True,
        score_filter: bool | None = None,
        segment_pairs: bool | None = None,
        options: VotingOptions | None = None,
        calibration: Calibration | None = None,
        rescale: bool = True,
        remove_plane: bool = False,
        upright: bool = True,
        denoise_above_m: float | None = None,
        recrop: bool = True,
        scale_search: bool = True,
        wide_scale_search: bool = False,
        pick_seen_parts: bool = False,
        carry_in_cone: bool = False,
        grow_boxes: bool = False,
        fit_extents: bool = False,
        anchor_faces: bool = False,
        align_faces: bool = False,
        free_space: bool = False,
        hold_children: bool = True,
        carry_depths: bool = True,
        place_children: bool = True,
        slide_fronts: bool = True,
        stack_children: bool = True,
        turn_children: bool = True,
        flip_fronts: bool = True,
        seat_parts: bool = False,
        free_slides: bool = False,
        restarts: int = 0,
    ):
        if not isinstance(model, UCOPENet):
            raise InputError(f"model must be a ucope network (Estimator.load reads one from a file), got {type(model).__name__}")
        if not (isinstance(num_pairs, int | np.integer) and 10 <= num_pairs <= MAX_PAIRS):
            raise InputError(f"num_pairs must be an integer from 10 to {MAX_PAIRS}, got {num_pairs!r}")
        if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0):
            raise InputError(f"seed must be an integer >= 0, got {seed!r}")
        if not (isinstance(restarts, int | np.integer) and not isinstance(restarts, bool) and 0 <= restarts <= MAX_RESTARTS):
            raise InputError(f"restarts must be an integer from 0 to {MAX_RESTARTS}, got {restarts!r}")
        if not (isinstance(max_input_points, int | np.integer) and max_input_points >= MIN_POINTS):
            raise InputError(f"max_input_points must be an integer >= {MIN_POINTS}, got {max_input_points!r}")
        metres = isinstance(denoise_above_m, float | int) and not isinstance(denoise_above_m, bool)
        if denoise_above_m is not None and not (metres and 0.0 <= denoise_above_m < 1.0):
            raise InputError(f"denoise_above_m must be a surface noise in metres in [0, 1) or None, got {denoise_above_m!r}")
        device = _device(device)
        self.model = model.to(device).eval()
        self.cfg = model.cfg
        self.priors = model.cfg.priors
        self.name = name or self.cfg.category
        self.num_pairs = int(num_pairs)
        self.awareness = bool(awareness)
        self.score_filter = self.awareness if score_filter is None else bool(score_filter)
        self.segment_pairs = self.awareness if segment_pairs is None else bool(segment_pairs)
        self.refine = bool(refine)
        self.resolve_flips = bool(resolve_flips)
        self.seed = int(seed)
        self.device = torch.device(device)
        self.max_input_points = int(max_input_points)
        self.options = options or VotingOptions()
        self.shapes = ShapeIndex.from_priors(self.priors)
        self.seen_extent = self.priors.seen_extent  # (K, 3, SEEN_PATTERNS, 3) or None: fit_extents needs it
        self.faced_gap = self.priors.faced_gap  # (K, 3, 2, 3) or None: anchor_faces needs it
        if calibration is not None and len(calibration.part_bias) != self.cfg.num_parts:
            raise InputError(f"the calibration is for {len(calibration.part_bias)} parts, the model has {self.cfg.num_parts}")
        self.calibration = calibration
        self.rescale = bool(rescale)
        self.remove_plane = bool(remove_plane)
        self.upright = bool(upright)
        self.denoise_above_m = None if denoise_above_m is None else float(denoise_above_m)
        self.recrop = bool(recrop)
        self.scale_search = bool(scale_search)
        self.wide_scale_search = bool(wide_scale_search)
        self.pick_seen_parts = bool(pick_seen_parts)
        self.carry_in_cone = bool(carry_in_cone)
        self.grow_boxes = bool(grow_boxes)
        self.fit_extents = bool(fit_extents)
        self.anchor_faces = bool(anchor_faces)
        self.align_faces = bool(align_faces)
        self.free_space = bool(free_space)
        self.hold_children = bool(hold_children)
        self.carry_depths = bool(carry_depths)
        self.place_children = bool(place_children)
        self.slide_fronts = bool(slide_fronts)
        self.stack_children = bool(stack_children)
        self.turn_children = bool(turn_children)
        self.flip_fronts = bool(flip_fronts)
        self.seat_parts = bool(seat_parts)
        self.free_slides = bool(free_slides)
        self.restarts = int(restarts)

    # ------------------------------------------------------------------------------------- loading
    @classmethod
    def load(
        cls,
        model: str | os.PathLike,
        refine: bool | None = None,
        remove_plane: bool | None = None,
        denoise_above_m: float | None | str = "model",
        grow_boxes: bool | None = None,
        fit_extents: bool | None = None,
        anchor_faces: bool | None = None,
        align_faces: bool | None = None,
        free_space: bool | None = None,
        seat_parts: bool | None = None,
        free_slides: bool | None = None,
        wide_scale_search: bool | None = None,
        pick_seen_parts: bool | None = None,
        carry_in_cone: bool | None = None,
        restarts: int | None = None,
        **kwargs,
    ) -> Estimator:
        """An estimator from a run folder / model JSON path, or the name of a shipped model
        (``Estimator.load("laptop")``; :func:`ucope.model.checkpoint.list_pretrained` lists them).

        ``refine=None`` / ``remove_plane=None`` / ``denoise_above_m="model"`` / ``grow_boxes=None`` /
        ``fit_extents=None`` / ``anchor_faces=None`` / ``align_faces=None`` / ``free_space=None`` /
        ``seat_parts=None`` / ``free_slides=None`` / ``wide_scale_search=None`` / ``pick_seen_parts=None`` /
        ``carry_in_cone=None`` / ``restarts=None`` take the model's own defaults (``info.defaults`` of its JSON, set
        when it was packaged where they measured better). Other keyword arguments: as the constructor."""
        if not isinstance(model, str | os.PathLike) or not str(model):
            raise InputError(f"model must be a shipped model's name or a path, got {model!r}")
        path = find_model(model)
        net, meta = load_model(path)
        info = meta.get("info") or {}
        defaults = info.get("defaults") or {}
        switches = dict(
            refine=refine,
            remove_plane=remove_plane,
            grow_boxes=grow_boxes,
            fit_extents=fit_extents,
            anchor_faces=anchor_faces,
            align_faces=align_faces,
            free_space=free_space,
            seat_parts=seat_parts,
            free_slides=free_slides,
            wide_scale_search=wide_scale_search,
            pick_seen_parts=pick_seen_parts,
            carry_in_cone=carry_in_cone,
        )
        for key, value in switches.items():  # None: the model's own default (off where it has none)
            switches[key] = bool(defaults.get(key, False)) if value is None else value
        if isinstance(denoise_above_m, str):
            if denoise_above_m != "model":
                raise InputError(f'denoise_above_m must be metres, None or "model", got {denoise_above_m!r}')
            denoise_above_m = defaults.get("denoise_above_m")
        restarts = int(defaults.get("restarts", 0)) if restarts is None else restarts
        if "calibration" not in kwargs and info.get("calibration"):
            kwargs["calibration"] = Calibration.from_dict(info["calibration"])
        kwargs.update(switches, denoise_above_m=denoise_above_m, restarts=restarts)
        return cls(net, name=str(Path(model)), **kwargs)

    @property
    def category(self) -> str:
        return self.cfg.category

    # ---------------------------------------------------------------------------------- prediction
    def predict(self, points, normals=None, units: str = "m", up=None) -> PoseResult:
        """Estimate the pose of the object whose (segmented) cloud ``points`` is.

        With ``recrop`` (on by default) it takes two passes where it needs them. A first pass segments the
        cloud (rescaled only where it is :func:`compact`: no floor or far stray points); when it leaves
        at least :data:`RECROP_MIN_FRACTION` of the points out as not the object (the background class, a
        support plane), or when the object's points lie
        outside the model's training sizes, a second pass estimates on the object's points alone (and
        rescales them if ``rescale``), and its result is returned: a floor or a bleeding mask then no
        longer widens the cloud, shifts its features or triggers the rescaling (a warning says what was
        left out).

        Args:
            points: ``(N, 3)`` or organised ``(H, W, 3)`` (NaN = no measurement): the object's points in
                the camera frame (OpenCV axes: x right, y down, z forward), in ``units``.
            normals: optional normals of the points' shape (any sign and length: normalised and turned
                to face the camera); estimated when ``None``.
            units: ``"m"`` (default), ``"cm"`` or ``"mm"``; results are always in metres.
            up: optional ``(3,)`` the world's up direction in the camera frame (from an IMU, the robot's
                kinematics or a known mounting). The models were trained on upright cameras (3 degrees
                of roll); with ``up`` the cloud is first turned about the optical axis to take out the
                camera's roll (:func:`ucope.estimation.inputs.roll_to_up`), and the result turned back.

        Returns:
            a :class:`PoseResult`: ``part_labels`` has one entry per input point (an organised cloud
            flattened row by row), -1 for dropped ones and for those segmented as not the object;
            ``warnings`` lists what looked wrong.

        Raises:
            InputError: a cloud that cannot be one object in the camera frame (see
                :func:`ucope.estimation.inputs.prepare_points`), or whose size is more than
                :data:`EXTENT_REFUSE` times outside the model's training range (with a hint at the units).
        """
        t0 = time.perf_counter()
        roll = None if up is None else roll_to_up(up)
        prep = prepare_points(points, normals, self.max_input_points, self.seed, estimate=False, units=units, rotation=roll)
        pts, nrm, raw, finite = prep.points, prep.normals, prep.raw, prep.finite
        warnings = list(prep.warnings)
        turned_deg = 0.0 if roll is None else float(np.degrees(np.arctan2(roll[1, 0], roll[0, 0])))
        if abs(turned_deg) > 1.0:
            warnings.append(
                f"the cloud was turned {turned_deg:.0f} degrees about the optical axis "
                "to put the given up direction at image up for the estimate; the result is turned back"
            )
        t_prep = time.perf_counter() - t0
        memo: dict = {}  # passes already made, by their input and scale (the searches repeat some)
        est = self._estimate(pts, nrm, units, roll, len(raw), normalise=None, memo=memo)
        timings = dict(est.timings)  # of every estimate made, whichever stands

        def better(kept: _Estimate, alt: _Estimate) -> _Estimate:
            """The higher-scored of two estimates (ties: the one kept so far), ``alt``'s time counted."""
            nonlocal timings
            timings = {key: timings[key] + alt.timings[key] for key in timings}
            score = _seen_score if self.pick_seen_parts else _object_score
            return alt if score(alt.final) > score(kept.final) else kept

        if self.rescale and self.scale_search and self.calibration is not None and _object_score(est.final) < SCALE_SEARCH_BELOW:
            for factor in WIDE_SCALE_SEARCH if self.wide_scale_search else (1.0,):
                est = better(est, self._estimate(pts, nrm, units, roll, len(raw), normalise=factor, memo=memo))
        if self.calibration is not None:
            draw = 0
            while draw < self.restarts and _object_score(est.final) < RESTART_BELOW:
                draw += 1
                est = better(est, self._estimate(pts, nrm, units, roll, len(raw), normalise=est.normalise, memo=memo, draw=draw))
        final, labels, planes = est.final, est.labels, est.planes
        warnings += est.warnings
        warnings += final.input_warnings + final.warnings
        warnings = list(dict.fromkeys(warnings))  # a warning both passes gave, once
        t4 = time.perf_counter()
        usable = finite.copy()
        for plane in planes:
            if plane is not None:
                usable &= ~plane.removes(np.nan_to_num(raw))
        all_labels = label_points(raw, usable, pts, labels)
        timings["preprocess"] += 1e3 * (t_prep + time.perf_counter() - t4)
        timings["total"] = 1e3 * (time.perf_counter() - t0)
        return PoseResult(
            category=self.cfg.category,
            parts=final.parts,
            joints=final.joints,
            part_labels=all_labels,
            timings_ms=timings,
            model=self.name,
            num_points=len(raw),
            warnings=warnings,
            features=final.features,
        )

    def _estimate(
        self,
        pts: np.ndarray,
        nrm: np.ndarray | None,
        units: str,
        roll: np.ndarray | None,
        num_input: int,
        normalise: float | None,
        memo: dict | None = None,
        draw: int = 0,
    ) -> _Estimate:
        """One or two passes (:meth:`predict`) on the prepared cloud ``pts`` ``(P, 3)``, rescaled by
        :meth:`input_scale` (``normalise``: to that factor of the middle of the typical radii whatever its
        size). ``memo``: passes already made in this prediction, reused (with zero timings) where the same
        cloud would be estimated at the same scale again. ``draw``: which draw of the network's points and
        pairs (0: the first; ``restarts`` take others)."""
        warnings: list[str] = []
        # With recrop, the first pass rescales only a compact cloud (:func:`compact`): a floor or stray
        # points widen the cloud and would trigger the rescaling (the network was trained on such clouds
        # at their own scale); the second pass decides it on the points the first segmented as the object.
        # (Never rescaling the first pass lost objects at 2x: unscaled, the network segments much of
        # them as background, and their remaining points no longer look too large.)
        first = self._pass(
            pts,
            nrm,
            units,
            roll,
            num_input,
            rescale=self.rescale and (not self.recrop or compact(pts)),
            normalise=normalise,
            memo=memo,
            draw=draw,
        )
        final, labels, planes, timings = first, first.labels, [first.plane], dict(first.timings)
        obj = first.labels >= 0
        left_out = float(np.mean(~obj))
        if self.recrop and np.count_nonzero(obj) >= MIN_POINTS:
            again = left_out >= RECROP_MIN_FRACTION and np.count_nonzero(~obj) >= MIN_POINTS
            if not again:
                obj[:] = True  # a few stray labels: the second pass (if any) sees the whole cloud
            if again or (self.rescale and self.input_scale(pts[obj], normalise)[0] != 1.0):
                try:
                    n_obj = round(num_input * float(np.mean(obj)))  # the input's object points, as the calibration counts them
                    second = self._pass(
                        pts[obj],
                        None if nrm is None else nrm[obj],
                        units,
                        roll,
                        n_obj,
                        rescale=self.rescale,
                        normalise=normalise,
                        memo=memo,
                        draw=draw,
                    )
                except InputError as e:  # the object's points alone look like no object of the category
                    warnings.append(
                        f"the second pass on the {np.count_nonzero(obj)} object points failed ({e}); the first stands"
                    )
                else:
                    if again:
                        warnings += first.input_warnings
                        what = "a support plane and the background" if first.plane is not None else "the background"
                        warnings.append(
                            f"{100 * left_out:.0f} % of the points were segmented as not the object ({what}) "
                            "and left out; the pose was estimated again on the rest"
                        )
                    final, planes = second, planes + [second.plane]
                    labels = np.full(len(pts), -1, dtype=np.int64)
                    labels[obj] = second.labels
                    timings = {key: timings[key] + second.timings[key] for key in timings}
        return _Estimate(final, labels, planes, timings, warnings, normalise)

    @staticmethod
    def _noise_m(pts: np.ndarray, scale: float, memo: dict | None, key) -> float:
        """Surface noise (metres of the input) of a pass's cloud ``pts`` (scaled by ``scale``), kept in ``memo``
        under ``key``: the passes of one prediction on the same points share it."""
        if memo is not None and key in memo:
            return memo[key]
        noise = surface_noise(pts) / scale
        if memo is not None:
            memo[key] = noise
        return noise

    def _pass(
        self,
        pts: np.ndarray,
        nrm: np.ndarray | None,
        units: str,
        roll: np.ndarray | None,
        num_input: int,
        rescale: bool,
        normalise: float | None = None,
        memo: dict | None = None,
        draw: int = 0,
    ) -> _Pass:
        """One estimate on a prepared cloud ``pts`` ``(P, 3)`` float32 (camera frame, metres, turned by
        ``roll`` when given; canonical order) with optional normals ``(P, 3)``, standing for ``num_input``
        points of the user's cloud (a calibration feature): smoothing, support plane,
        extent checks, rescaling (:meth:`input_scale` with ``normalise``), network, voting, scores, back to
        the input's frame. Its ``labels`` ``(P,)`` give every point of ``pts`` its part, -1 for the support
        plane and the background class. ``memo``: a dict of the passes made so far in one prediction; a pass
        on the same points at the same scale and draw is returned from it with zero timings (the result would
        be the same: every draw is seeded). ``draw``: 0 for the first draw of the network's points and pairs,
        ``d > 0`` for the ``d``-th further one (:attr:`restarts`)."""
        t0 = time.perf_counter()
        pts_in = pts
        warnings, input_warnings = [], []
        if self.denoise_above_m is not None and len(pts) >= DENOISE_MIN_POINTS:
            noise = surface_noise(pts)
            if noise > self.denoise_above_m:
                pts = smooth_points(pts, k=DENOISE_K, iterations=2).astype(np.float32)
                warnings.append(
                    f"the cloud's surface noise ({1e3 * noise:.1f} mm) is above the {1e3 * self.denoise_above_m:.1f} mm "
                    f"the model handles; it was smoothed before the estimate"
                )
        plane = find_support_plane(pts, seed=self.seed) if self.remove_plane else None
        on_object = np.ones(len(pts), dtype=bool)
        if plane is not None and np.count_nonzero(keep := ~plane.removes(pts)) >= MIN_POINTS:
            on_object = keep
            pts, nrm = pts[keep], (None if nrm is None else nrm[keep])
            input_warnings.append(
                f"a plane under the object ({100 * plane.fraction:.0f} % of the points) was left out as floor or table"
            )
        else:
            plane = None
        input_warnings += self._extent_warnings(pts, units)  # about the cloud: kept from a first pass
        scale, centre = self.input_scale(pts, normalise) if rescale else (1.0, np.zeros(3))
        key = noise_key = None
        if memo is not None:
            digest = hashlib.blake2b(np.ascontiguousarray(pts_in).tobytes(), digest_size=16)
            if nrm is not None:
                digest.update(np.ascontiguousarray(nrm).tobytes())
            key = (digest.hexdigest(), num_input, scale, centre.tobytes(), draw)
            noise_key = ("surface_noise", digest.hexdigest())  # the same points before scaling, whatever the scale
            if key in memo:
                return replace(memo[key], timings=dict.fromkeys(memo[key].timings, 0.0))
        if scale != 1.0:
            pts = (centre + scale * (pts - centre)).astype(np.float32)
            warnings.append(
                f"the cloud was scaled by {scale:.3g} into the {self.category} model's training sizes for the estimate; "
                "its poses and sizes are scaled back"
            )
        cfg = self.cfg
        rng = np.random.default_rng(np.random.SeedSequence(entropy=self.seed, spawn_key=(2,) if draw == 0 else (2, draw)))
        sub = random_subset(len(pts), cfg.num_points, rng)
        p_net = pts[sub]
        # Missing normals: only the network's points need them (neighbours still from the whole cloud).
        n_net = estimate_normals(pts, k=NORMAL_K, rows=sub) if nrm is None else nrm[sub]
        fps = [torch.from_numpy(f)[None].to(self.device) for f in numpy_fps_indices(p_net, cfg.encoder.npoints)]
        P = torch.from_numpy(p_net)[None].to(self.device)
        Nn = torch.from_numpy(n_net)[None].to(self.device)
        t1 = time.perf_counter()
        with torch.no_grad():
            enc = self.model.encode(P, Nn, fps)
            out = dict(enc)
            if cfg.num_joints > 0:
                out.update(self.model.joint_heads(enc))
            labels = enc["seg_logits"][0].argmax(-1).cpu().numpy() if "seg_logits" in enc else np.zeros(len(p_net), np.int64)
            t2 = time.perf_counter()
            if cfg.head == "regression":  # the baseline: no pairs, no voting
                out.update(self.model.regress(enc, P))
            else:
                pair_idx = self._sample_pairs(labels, rng)
                # The axis heads are computed later, for the pairs that vote the axes only.
                out.update(
                    self.model.pair_heads(
                        enc, P, Nn, torch.from_numpy(pair_idx)[None].to(self.device), heads=VOTE_HEADS, return_hidden=True
                    )
                )
                hidden = out.pop("pair_hidden")[0]  # (K, M, H)
        t3 = time.perf_counter()
        carry_margin = 0.0 if self.carry_in_cone else UPRIGHT_MARGIN_DEG
        camera = centre * (1.0 - scale)  # the cloud was scaled about centre (the roll turns about the camera)
        if cfg.head == "regression":
            v = regressed_object(
                p_net,
                out,
                self.priors,
                awareness=self.awareness,
                refine=self.refine,
                resolve_flips=self.resolve_flips,
                upright=self.upright,
                carry_margin_deg=carry_margin,
            )
        else:

            def axis_heads(k: int, rows: torch.Tensor) -> dict:
                with torch.no_grad():
                    return self.model.pair_outputs(hidden[k].index_select(0, rows.to(hidden.device)), AXIS_HEADS, part=k)

            v = vote_object(
                p_net,
                n_net,
                pair_idx,
                out,
                self.priors,
                awareness=self.awareness,
                refine=self.refine,
                options=self.options,
                resolve_flips=self.resolve_flips,
                upright=self.upright,
                carry_margin_deg=carry_margin,
                axis_heads=axis_heads,
                shapes=self.shapes,
                score_filter=self.score_filter,
                align_faces=self.align_faces,
            )
        K = cfg.num_parts
        seg_prob = enc["seg_logits"][0].softmax(-1).cpu().numpy() if "seg_logits" in enc else None
        # the object, not the background, as the segmentation sees it (models with a background class)
        object_conf = 1.0 - seg_prob[:, K] if seg_prob is not None and seg_prob.shape[1] > K else None
        part_labels = np.where(labels < K, labels, -1)  # the background class (models with one) as no part
        if self.flip_fronts and any(j.type == JointType.PRISMATIC for j in self.priors.joints):  # before the scores
            v = dict(v)
            v["cam_from_part"], v["joint_axis"], v["joint_pivot"], _ = resolve_front_flips(
                v["cam_from_part"],
                v["joint_axis"],
                v["joint_pivot"],
                p_net,
                part_labels,
                self.priors,
                confidence=object_conf,
                camera=camera,
            )
        feats = part_features(
            v, labels, seg_prob, p_net, num_input, [j.parent for j in self.priors.joints], [j.child for j in self.priors.joints]
        )
        scores = self.calibration.part_scores(feats) if self.calibration is not None else np.asarray(v["score"], np.float64)
        if self.grow_boxes:  # after the scores: the calibration's box-fit features see the voted boxes
            v = dict(v)
            v["cam_from_part"], v["size_m"], _ = grow_to_points(
                v["cam_from_part"], v["size_m"], p_net, labels, [p.symmetry for p in self.priors.parts], confidence=object_conf
            )
        fitted = np.zeros((K, 3), dtype=bool)
        if self.fit_extents and self.seen_extent is not None and num_input >= FIT_EXTENTS_MIN_INPUT:  # after growth
            v = dict(v)
            # parts the calibration is sure of keep their boxes
            unsure = np.flatnonzero(scores < FIT_EXTENTS_BELOW) if self.calibration is not None else None
            v["cam_from_part"], v["size_m"], fitted = fit_seen_extents(
                v["cam_from_part"],
                v["size_m"],
                p_net,
                labels,
                self.seen_extent,
                [p.symmetry for p in self.priors.parts],
                parts=unsure,
                confidence=object_conf,
            )
            if fitted.any():  # a hidden child's extents follow its measured parent's
                v["cam_from_part"], v["size_m"], _ = carry_child_sizes(v["cam_from_part"], v["size_m"], fitted, self.priors)
        if (
            self.anchor_faces
            and self.faced_gap is not None
            and num_input >= ANCHOR_MIN_INPUT
            and self._noise_m(pts, scale, memo, noise_key) <= ANCHOR_MAX_NOISE_M
        ):  # the root only: a child's points end at a seam
            v = dict(v)
            v["cam_from_part"], _ = anchor_faced_faces(
                v["cam_from_part"], v["size_m"], p_net, labels, self.faced_gap, parts=(0,), keep=fitted, confidence=object_conf
            )
        if self.hold_children and self.priors.num_joints > 0:  # after the fits, which may have narrowed the parent
            v = dict(v)
            v["cam_from_part"], v["size_m"], _ = hold_prismatic_children(
                v["cam_from_part"], v["size_m"], p_net, part_labels, self.priors, confidence=object_conf
            )
        if self.carry_depths and self.priors.num_joints > 0:  # after the fits: the parent's extents as they stand
            v = dict(v)
            v["cam_from_part"], v["size_m"], _ = carry_prismatic_depths(v["cam_from_part"], v["size_m"], self.priors, fitted)
        if self.place_children:  # after growth, which may have moved a drawer's centre sideways
            v = dict(v)
            v["cam_from_part"], _ = place_prismatic_children(v["cam_from_part"], v["size_m"], self.priors)
        if self.slide_fronts and self.priors.num_joints > 0:
            v = dict(v)
            v["cam_from_part"], _ = slide_to_fronts(
                v["cam_from_part"],
                v["size_m"],
                p_net,
                part_labels,
                self.priors,
                confidence=object_conf,
            )
        if self.stack_children and self.priors.stacks:
            v = dict(v)
            v["cam_from_part"], v["size_m"], _ = stack_hidden_children(
                v["cam_from_part"], v["size_m"], part_labels, self.priors, confidence=object_conf
            )
        if self.free_slides and self.priors.num_joints > 0:  # after the stack: a hidden drawer's height as it stands
            v = dict(v)
            v["cam_from_part"], slid = slide_weak_children(
                v["cam_from_part"],
                v["size_m"],
                v["joint_axis"],
                p_net,
                part_labels,
                self.priors,
                camera=camera,
                confidence=object_conf,
            )
            v["slid_m"] = slid / scale  # metres of the cloud as given
        if self.free_space and self.priors.num_joints > 0:  # after the box steps: the boxes as they stand
            v = dict(v)
            v["cam_from_part"], v["free_space_turned"] = place_weak_parts(
                v["cam_from_part"],
                v["size_m"],
                v["joint_axis"],
                v["joint_pivot"],
                p_net,
                part_labels,
                self.priors,
                camera=camera,
                upright_margin_deg=UPRIGHT_MARGIN_DEG if self.upright else None,
            )
        if self.turn_children and self.priors.num_joints > 0:  # after the box steps: the boxes as they stand
            v = dict(v)
            v["cam_from_part"], _ = turn_thin_children(
                v["cam_from_part"],
                v["size_m"],
                v["joint_axis"],
                p_net,
                part_labels,
                self.priors,
                confidence=object_conf,
                camera=camera,
            )
        if self.priors.num_joints > 0:  # the states of the boxes as they now stand, inside the limits
            v = dict(v)
            before = np.asarray(v["joint_clamped"], dtype=bool)  # clamped by voting (vote_object, regressed_object)
            v["cam_from_part"], v["joint_state"], clamped = settle_joint_states(
                v["cam_from_part"], v["size_m"], v["joint_axis"], v["joint_pivot"], self.priors
            )
            v["joint_score"] = np.where(clamped & ~before, 0.5 * np.asarray(v["joint_score"]), v["joint_score"])
            v["joint_clamped"] = before | clamped
            if self.seat_parts:  # after the states: a revolute state is the same wherever the centre stands
                v["cam_from_part"], v["joint_pivot"], v["seated"] = seat_weak_parts(
                    v["cam_from_part"], v["size_m"], v["joint_pivot"], part_labels, self.priors
                )
        carried = np.asarray(v.get("carried", np.zeros(K, dtype=bool)), dtype=bool)
        scores = np.where(carried, 0.5 * scores, scores)
        if scale != 1.0:
            v = self._scale_back(v, scale, centre)
            p_net = (centre + (p_net - centre) / scale).astype(np.float32)
        if roll is not None:  # the labels below are carried over in the turned frame: p_net and pts stay in it
            v = self._turn_back(v, roll)
        parts, joints = self._estimates(v, scores)
        for k in np.flatnonzero(carried):
            warnings.append(
                f"part {parts[k].label!r}: its voted pose was tilted far off the upright this model was trained on; "
                "it was placed from its neighbour through their joint, its score halved (upright=False if the camera is "
                "rolled or below the object)"
            )
        for k in np.flatnonzero(v.get("free_space_turned", [])):
            warnings.append(
                f"part {parts[k].label!r}: it showed few points; it was turned by {np.degrees(v['free_space_turned'][k]):.0f} "
                "degrees about its joint to where its box hides none of the points the camera sees and its own points "
                "lie on it"
            )
        for k in np.flatnonzero(v.get("slid_m", [])):
            warnings.append(
                f"part {parts[k].label!r}: it showed no points and was voted where the camera would have seen it; it was "
                f"slid {v['slid_m'][k]:+.3f} m along its joint to the nearest state the view leaves room for"
            )
        for k in np.flatnonzero(v.get("seated", [])):
            warnings.append(
                f"part {parts[k].label!r}: it showed few points and its voted centre stood off its hinge; it was put "
                "where its hinge meets its neighbour's"
            )
        for k in np.flatnonzero(v.get("upright_turned", [])):
            warnings.append(
                f"part {parts[k].label!r}: its voted pose was upside down against the upright this model was trained on; "
                "it was turned over by a half turn (upright=False if the camera is rolled or below the object)"
            )
        for j in np.flatnonzero(v.get("joint_clamped", [])):
            warnings.append(
                f"joint {joints[j].parent}->{joints[j].child}: the voted state lay outside the category's limits; "
                "it was clamped onto them (and the child moved), its score halved"
            )
        if self.calibration is not None and float(scores.min()) < self.calibration.threshold:
            worst = int(np.argmin(scores))
            warnings.append(
                f"low confidence: part {parts[worst].label!r} is likely wrong (score {scores[worst]:.2f} below "
                f"the model's threshold {self.calibration.threshold:.2f})"
            )
        t4 = time.perf_counter()
        background = float(np.mean(part_labels < 0))  # the share segmented as the background class
        if background > 0.5:
            input_warnings.append(
                f"{100 * background:.0f} % of the points were segmented as not the object: " "is the cloud one segmented object?"
            )
        for k, pe in enumerate(parts):
            if np.count_nonzero(labels == k) < 3:
                warnings.append(f"part {pe.label!r}: fewer than 3 points were segmented as it; its pose is a guess")
        point_labels = label_points(pts_in, on_object, p_net, part_labels)
        t5 = time.perf_counter()
        timings = {
            "preprocess": 1e3 * (t1 - t0 + t5 - t4),
            "encoder": 1e3 * (t2 - t1),
            "pair_encoder": 1e3 * (t3 - t2),
            "voting": 1e3 * (t4 - t3),
            "total": 1e3 * (t5 - t0),
        }
        made = _Pass(parts, joints, point_labels, plane, feats, warnings, input_warnings, timings)
        if key is not None:
            memo[key] = made
        return made

    def input_scale(self, points: np.ndarray, normalise: float | None = None) -> tuple[float, np.ndarray]:
        """``(s, c)``: the factor :meth:`predict` scales ``points`` ``(N, 3)`` by about their median point
        ``c`` ``(3,)`` (camera frame, metres): 1 unless ``rescale`` is on and the cloud's radius ``r``
        (:func:`ucope.priors.cloud_radius`, at most :data:`RESCALE_CORE_FACTOR` x twice its median radius,
        so that far stray points do not make it look big) lies below the radii the model saw often (``lo``: the 2nd
        percentile, ``priors.radius_typical_m``) or above the largest it saw (``priors.radius_range_m``);
        then ``sqrt(lo hi) / r`` with ``[lo, hi]`` the typical radii: the middle of the sizes the model
        knows, where sizes come out right. The upper trigger is the largest radius, not the 98th
        percentile, because a floor, a bleeding mask or outliers also widen a cloud (measured: the 98th
        percentile cost the eyeglasses 14-20 points of success under them). A model without typical radii
        uses ``radius_range_m`` for both. ``normalise``: a factor ``f`` (> 0) gives ``f sqrt(lo hi) / r``
        whatever ``r`` (the further estimates of ``scale_search``). docs/results.md has the measured effect.

        Raises:
            InputError: ``normalise`` not a positive finite number or None."""
        if normalise is not None and not (
            isinstance(normalise, float | int) and not isinstance(normalise, bool) and 0.0 < normalise < np.inf
        ):
            raise InputError(f"normalise must be a positive factor or None, got {normalise!r}")
        pts = np.asarray(points, np.float64)
        full = self.priors.radius_range_m
        if not self.rescale or full is None:
            return 1.0, np.median(pts, axis=0)
        typ = self.priors.radius_typical_m or full
        centre, outer, core = _radii(pts)
        r = min(outer, RESCALE_CORE_FACTOR * core)
        lo, hi = float(typ[0]), float(typ[1])
        if r <= 0.0 or (normalise is None and lo <= r <= float(full[1])):
            return 1.0, centre
        return float((1.0 if normalise is None else normalise) * np.sqrt(lo * hi) / r), centre

    def _scale_back(self, v: dict, scale: float, centre: np.ndarray) -> dict:
        """The estimate ``v`` made on the cloud scaled by ``scale`` about ``centre``, for the cloud itself:
        translations and pivots move back towards ``centre``, sizes and prismatic states (displacements of
        an object of another size: the zero offset scales with it) are divided by ``scale``, rotations,
        axes and revolute states are kept."""
        v = dict(v)
        T = np.array(v["cam_from_part"], np.float64)
        T[:, :3, 3] = centre + (T[:, :3, 3] - centre) / scale
        S = np.asarray(v["size_m"], np.float64) / scale
        v["cam_from_part"], v["size_m"] = T, S
        if len(self.priors.joints):
            v["joint_pivot"] = centre + (np.asarray(v["joint_pivot"], np.float64) - centre) / scale
            prismatic = np.array([jp.type == JointType.PRISMATIC for jp in self.priors.joints])
            state = np.where(prismatic, np.asarray(v["joint_state"], np.float64) / scale, v["joint_state"])
            v["joint_state"] = state
        return v

    @staticmethod
    def _turn_back(v: dict, roll: np.ndarray) -> dict:
        """The estimate ``v`` made on the cloud turned by ``roll`` (``p R^T``), for the cloud itself: poses,
        pivots and axes turned by ``R^T``; sizes and states are kept."""
        v = dict(v)
        T = np.array(v["cam_from_part"], np.float64)
        T[:, :3, :] = np.einsum("ji,kjl->kil", roll, T[:, :3, :])
        v["cam_from_part"] = T
        for key in ("joint_pivot", "joint_axis"):
            if key in v and len(v[key]):
                v[key] = np.asarray(v[key], np.float64) @ roll
        return v

    def _extent_warnings(self, pts: np.ndarray, units: str) -> list[str]:
        """Refuse a cloud far outside the sizes the model was trained on (with a hint at its units); warn
        about one outside them, and about one that only far stray points make look far too big."""
        rng = self.priors.radius_range_m
        if rng is None:
            return []
        r = cloud_radius(pts)
        lo, hi = rng
        # A cloud in other units is scaled as a whole: its half-way radius grows with it. A few far points
        # (a floor seen to the horizon) raise the 90th-percentile radius alone: warned, not refused.
        if r > hi * EXTENT_REFUSE:  # the half-way radius only where it decides
            core = 2.0 * float(np.median(np.linalg.norm(pts - np.median(pts, axis=0), axis=1)))
            if core <= hi * EXTENT_REFUSE:
                return [
                    f"the cloud's size ({r:.3g} m, 90th-percentile radius) is far outside the {lo:.3g}-{hi:.3g} m the "
                    f"{self.category} model was trained on, but half of its points lie within {core / 2:.3g} m: far "
                    "points that are not the object (a floor or background in the mask?) make it look big"
                ]
        if lo / EXTENT_REFUSE <= r <= hi * EXTENT_REFUSE:
            if lo / EXTENT_WARN <= r <= hi * EXTENT_WARN:
                return []
            return [
                f"the cloud's size ({r:.3g} m, 90th-percentile radius) is outside the {lo:.3g}-{hi:.3g} m the "
                f"{self.category} model was trained on: poses and boxes may be off"
            ]
        hint = ""
        for unit, factor in (("mm", 1000.0), ("cm", 100.0)):
            if units == "m" and lo / 3 <= r / factor <= hi * 3:
                hint = f"; it looks like {unit}: pass units='{unit}' (ucope predict --units {unit})"
                break
        else:
            if units != "m" and lo / 3 <= r * {"mm": 1000.0, "cm": 100.0}[units] <= hi * 3:
                hint = "; it looks like metres already: leave units at 'm'"
        raise InputError(
            f"the cloud's size ({r:.3g} m, 90th-percentile radius) is far outside the {lo:.3g}-{hi:.3g} m the "
            f"{self.category} model was trained on{hint}"
        )

    def _sample_pairs(self, labels: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``(K, M, 2)`` pair indices, ``M = num_pairs // K``: with ``segment_pairs``, both points of part
        ``k``'s pairs come from the points segmented as ``k`` (all points if fewer than 3 are)."""
        K = self.cfg.num_parts
        M = max(1, self.num_pairs // K)
        N = len(labels)
        out = np.empty((K, M, 2), dtype=np.int64)
        for k in range(K):  # a handful of parts
            own = np.flatnonzero(labels == k) if self.segment_pairs else np.arange(N)
            pool = own if len(own) >= 3 else np.arange(N)
            out[k] = pool[rng.integers(0, len(pool), size=(M, 2))]
        return out

    def _estimates(self, v: dict, scores: np.ndarray) -> tuple[list[PartEstimate], list[JointEstimate]]:
        """The result's parts and joints from the dict of :func:`vote_object` / :func:`regressed_object`
        and the parts' ``(K,)`` scores."""
        pri = self.priors
        parts = [
            PartEstimate(
                index=k,
                label=pp.name,
                cam_from_part=np.asarray(v["cam_from_part"][k], np.float64),
                size_m=np.asarray(v["size_m"][k], np.float64),
                score=float(scores[k]),
                symmetry=pp.symmetry,
                num_votes=int(v["num_pairs"][k]),
                vote_score=float(v["score"][k]),
            )
            for k, pp in enumerate(pri.parts)
        ]
        joints = []
        for j, jp in enumerate(pri.joints):
            piv = np.asarray(v["joint_pivot"][j], np.float64)
            revolute = jp.type == JointType.REVOLUTE
            joints.append(
                JointEstimate(
                    type=jp.type.label,
                    parent=jp.parent,
                    child=jp.child,
                    pivot_m=piv if revolute and np.all(np.isfinite(piv)) else None,
                    axis=np.asarray(v["joint_axis"][j], np.float64),
                    state=float(v["joint_state"][j]),
                    score=float(v["joint_score"][j]),
                )
            )
        return parts, joints

    def predict_rgbd(self, depth, intrinsics, mask=None, box=None, depth_scale: float = 1000.0, mask_label=None) -> PoseResult:
        """Estimate the pose from a depth image of the object: :func:`rgbd_points` then :meth:`predict`
        (arguments as :func:`rgbd_points`)."""
        return self.predict(rgbd_points(depth, intrinsics, mask, box, depth_scale, mask_label))

    def predict_sample(self, sample: dict) -> PoseResult:
        """Estimate on a data-set sample (its points and normals; the ground truth is not used)."""
        return self.predict(sample["points"], sample["normals"])
