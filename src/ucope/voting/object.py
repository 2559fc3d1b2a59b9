"""One call from the network's outputs to every part pose, joint and joint state of one object."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..geometry.kinematics import joint_state_from_poses
from ..geometry.transforms import rotation_angle_deg
from ..priors import CategoryPriors
from ..vocab import JointType
from .faces import align_parts_to_faces, face_normals
from .joints import vote_joints
from .kinematic import (
    UPRIGHT_MARGIN_DEG,
    ShapeIndex,
    carry_upright,
    clamp_joint_states,
    kinematic_refine,
    resolve_joint_flips,
    resolve_shape_flips,
    turn_upright,
)
from .part import VotingOptions, vote_parts
from .revolution import refine_revolution

__all__ = ["vote_object", "regressed_object", "regression_scores", "part_fit"]


def vote_object(
    points,
    normals,
    pair_idx,
    outputs: Mapping[str, Any],
    priors: CategoryPriors,
    awareness: bool = True,
    refine: bool = False,
    options: VotingOptions | None = None,
    resolve_flips: bool = True,
    shape_flips: bool = True,
    axis_heads=None,
    shapes: ShapeIndex | None = None,
    score_filter: bool | None = None,
    upright: bool = True,
    align_faces: bool = False,
    carry_margin_deg: float = UPRIGHT_MARGIN_DEG,
) -> dict[str, Any]:
    """:func:`ucope.voting.part.vote_parts` + :func:`ucope.voting.joints.vote_joints` + joint states.

    With ``align_faces`` the voted rotations are first turned so that each part's box axes meet the
    normals of its points' flat faces (:func:`ucope.voting.faces.align_parts_to_faces`: the points of a
    part are those its pairs were drawn from, their normals estimated among ``points`` by
    :func:`ucope.voting.faces.face_normals`, not taken from ``normals``; a part joined to its
    parent by a prismatic joint takes its parent's turn; parts symmetric about y are left alone).

    With ``resolve_flips`` (default) a rigid object (``K = 1``) whose voted rotation is a half turn away
    from the pose its points fit best is turned back (``shape_flips``,
    :func:`ucope.voting.kinematic.resolve_shape_flips`), and a part of an articulated object whose
    rotation is a half turn away from what its revolute joint allows is turned back
    (:func:`ucope.voting.kinematic.resolve_joint_flips`; the shape check applies to rigid objects
    only, docs/voting.md says why). With ``upright`` (default) a part voted far off the upright the
    training views kept it in (more than ``carry_margin_deg`` beyond their cone) is re-placed from a
    neighbour through their joint (:func:`ucope.voting.kinematic.carry_upright`), or, in an object without
    joints, turned over by a half turn (:func:`ucope.voting.kinematic.turn_upright`).
    Joint states come from the voted poses (:func:`ucope.geometry.kinematics.joint_state_from_poses`)
    about the voted joint axis (revolute), or from the box supports minus the joint's
    ``zero_offset_m`` (prismatic). With
    ``refine=True`` the poses, axes and states are then made consistent by
    :func:`ucope.voting.kinematic.kinematic_refine` (part scores as weights).

    Args: as :func:`ucope.voting.part.vote_parts` (``outputs`` also holding the joint heads for
        ``K >= 2``; ``axis_heads`` computes the axis heads lazily); ``awareness``: the joint awareness
        (and, unless ``score_filter`` says otherwise, the part-score filter); ``shape_flips=False``
        turns the shape check off alone; ``shapes``: the priors' :class:`ShapeIndex` (built per call
        when ``None``: build it once per model).

    Returns:
        the dict of :func:`vote_parts` updated with that of :func:`vote_joints` and ``joint_state``
        ``(J,)``; ``flipped`` ``(K,)`` bool marks the parts turned back by the joint checks and
        ``shape_turned`` ``(K,)`` those turned by the shape check; ``revolved`` ``(K,)`` the parts whose box
        and centre came from their points' surface-of-revolution fit (``options.revolution_factor``,
        objects without joints); ``carried`` ``(K,)`` those re-placed
        from a neighbour and ``upright_turned`` ``(K,)`` those turned over (``upright``); ``joint_clamped`` ``(J,)`` the joints
        whose state was brought back into its limits; ``face_aligned`` ``(K,)`` the parts whose rotation
        ``align_faces`` turned; ``refined`` tells whether the kinematic refinement ran.
    """
    score_filter = awareness if score_filter is None else score_filter
    out = vote_parts(
        points, normals, pair_idx, outputs, priors, score_filter=score_filter, options=options, axis_heads=axis_heads
    )
    K = priors.num_parts
    out["shape_turned"] = np.zeros(K, dtype=bool)
    out["revolved"] = np.zeros(K, dtype=bool)
    out["face_aligned"] = np.zeros(K, dtype=bool)
    if align_faces or priors.num_joints == 0:  # the points each part's pairs were drawn from
        idx = np.asarray(pair_idx.cpu() if hasattr(pair_idx, "cpu") else pair_idx).reshape(K, -1)
        part_points = [np.unique(i) for i in idx]
        pts = np.asarray(points.cpu() if hasattr(points, "cpu") else points, dtype=np.float64)
    if align_faces:
        nrm = face_normals(pts.reshape(-1, 3))
        follow = [(j.child, j.parent) for j in priors.joints if j.type == JointType.PRISMATIC]
        out["cam_from_part"], out["face_aligned"] = align_parts_to_faces(
            out["cam_from_part"], nrm, part_points, [p.symmetry for p in priors.parts], follow
        )
        faces = (nrm, part_points, np.array(out["cam_from_part"][0, :3, :3], np.float64))
    else:
        faces = None
    out["upright_turned"] = np.zeros(K, dtype=bool)
    if priors.num_joints == 0:
        if resolve_flips and shape_flips:
            out["cam_from_part"], out["shape_turned"] = resolve_shape_flips(
                out["cam_from_part"], out["size_m"], pts, part_points, priors, shapes
            )
        if upright:  # no neighbour to carry a part from: an upside-down one is turned over
            out["cam_from_part"], out["upright_turned"] = turn_upright(
                out["cam_from_part"], out["size_m"], pts, part_points, priors, shapes
            )
        factor = (options or VotingOptions()).revolution_factor
        for k in np.flatnonzero(priors.symmetric) if factor is not None else ():  # a part or two
            T, S, out["revolved"][k] = refine_revolution(out["cam_from_part"][k], out["size_m"][k], pts[part_points[k]], factor)
            out["cam_from_part"][k], out["size_m"][k] = T, S
    return _with_joints(
        out,
        points,
        outputs,
        priors,
        awareness,
        refine,
        resolve_flips,
        upright=upright,
        faces=faces,
        carry_margin_deg=carry_margin_deg,
    )


BOX_FIT_MARGIN = 0.55
"""A point fits its part's box when each of its coordinates in the part frame lies within this fraction
of the box's size (a half plus 10 % of slack for depth noise), plus 1 mm."""


def part_fit(
    points: np.ndarray, labels: np.ndarray, seg_prob: np.ndarray | None, cam_from_part: np.ndarray, size_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How sure the segmentation is of each part and how well each part's box holds its points.

    Args:
        points: ``(P, 3)`` the network's points (camera frame, metres).
        labels: ``(P,)`` their segmentation (values ``>= K``: background).
        seg_prob: ``(P, C)`` class probabilities, ``C >= K``, or ``None`` (no segmentation).
        cam_from_part: ``(K, 4, 4)`` part poses; size_m: ``(K, 3)`` their box sizes (metres).

    Returns:
        ``(confidence (K,), fit (K,))``: the mean probability of class ``k`` over the points labelled
        ``k`` (1 without ``seg_prob`` or without such points), and the fraction of those points inside
        part ``k``'s box (:data:`BOX_FIT_MARGIN`; 0 without such points).
    """
    T = np.asarray(cam_from_part, np.float64)
    S = np.asarray(size_m, np.float64)
    pts = np.asarray(points, np.float64)
    labels = np.asarray(labels)
    K = len(T)
    conf, fit = np.ones(K), np.zeros(K)
    for k in range(K):  # a handful of parts; vectorised over points
        mine = labels == k
        if not mine.any():
            continue
        if seg_prob is not None:
            conf[k] = float(seg_prob[mine, k].mean())
        local = (pts[mine] - T[k, :3, 3]) @ T[k, :3, :3]  # the points in the part frame
        fit[k] = float(np.mean(np.all(np.abs(local) <= BOX_FIT_MARGIN * S[k] + 1e-3, axis=1)))
    return conf, fit


def regression_scores(
    points: np.ndarray, seg_prob: np.ndarray | None, cam_from_part: np.ndarray, size_m: np.ndarray
) -> np.ndarray:
    """``(K,)`` scores in ``[0, 1]`` of regressed part poses: the mean segmentation probability of the
    points segmented as part ``k`` times the fraction of those points that lie inside part ``k``'s
    regressed box (:func:`part_fit`). A part with no points scores 0.

    This is what a direct regression can say about itself without votes: whether the network is sure
    which points are the part, and whether its box agrees with them. A rotation about an axis the box
    is nearly symmetric about (the mug's handle side) is not seen by the second factor.

    Args:
        points: ``(P, 3)`` the network's points (camera frame, metres).
        seg_prob: ``(P, C)`` class probabilities, ``C >= K`` (a background class last), or ``None``
            (one part without segmentation: every point is the part's, probability 1).
        cam_from_part: ``(K, 4, 4)`` regressed poses.
        size_m: ``(K, 3)`` regressed box sizes.
    """
    labels = np.zeros(len(points), np.int64) if seg_prob is None else np.asarray(seg_prob).argmax(-1)
    conf, fit = part_fit(points, labels, seg_prob, cam_from_part, size_m)
    return conf * fit


def regressed_object(
    points,
    outputs: Mapping[str, Any],
    priors: CategoryPriors,
    awareness: bool = True,
    refine: bool = False,
    resolve_flips: bool = True,
    upright: bool = True,
    carry_margin_deg: float = UPRIGHT_MARGIN_DEG,
) -> dict[str, Any]:
    """The same dict as :func:`vote_object` for the direct-regression baseline
    (:class:`ucope.model.regression.RegressionNet`): part poses and sizes from its ``rotation``
    ``(1, K, 3, 3)``, ``centre_m`` ``(1, K, 3)`` and ``gamma`` ``(1, K, 3)`` outputs (no pairs),
    joints and joint states exactly as for U-COPE. The part scores are :func:`regression_scores`
    (the baseline has no votes to count)."""
    K = priors.num_parts
    R = outputs["rotation"].reshape(K, 3, 3).double().cpu().numpy()
    t = outputs["centre_m"].reshape(K, 3).double().cpu().numpy()
    gamma = outputs["gamma"].reshape(K, 3).double().cpu().numpy()
    T = np.tile(np.eye(4), (K, 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    size = np.exp(gamma) * priors.mean_size_m
    seg = outputs.get("seg_logits")
    prob = seg.reshape(-1, seg.shape[-1]).double().softmax(-1).cpu().numpy() if seg is not None else None
    out = {
        "cam_from_part": T,
        "size_m": size,
        "score": regression_scores(np.asarray(points, np.float64), prob, T, size),
        "num_pairs": np.zeros(K, dtype=np.int64),
    }
    return _with_joints(
        out, points, outputs, priors, awareness, refine, resolve_flips, upright=upright, carry_margin_deg=carry_margin_deg
    )


def _with_joints(
    out: dict,
    points,
    outputs,
    priors: CategoryPriors,
    awareness: bool,
    refine: bool,
    resolve_flips: bool = True,
    clamp_states: bool = True,
    upright: bool = True,
    faces: tuple | None = None,
    carry_margin_deg: float = UPRIGHT_MARGIN_DEG,
) -> dict[str, Any]:
    """Add the joints (:func:`vote_joints`), undo half-turn flips that contradict them
    (:func:`resolve_joint_flips`), re-place parts voted far off their upright (:func:`carry_upright`,
    with ``upright``, beyond ``carry_margin_deg`` outside their cone), then the joint states, clamped into the limits
    (:func:`clamp_joint_states`, the joint score halved where clamped), and the optional refinement.

    ``faces`` (``(normals (P, 3), K part point index arrays, the root's aligned rotation (3, 3))``, from
    ``align_faces``): the refinement weighs the joint heads' own axes and the other parts' voted
    rotations, and so pulls the aligned root off its faces again (on 12 of the drawer's test views the
    cabinet's median error was 3.8 degrees voted and 4.9 aligned, then refined; 1.2 turned back);
    afterwards the whole tree is turned so that its root is back on its faces
    (:func:`_root_back_to_faces`), joint axes included: states and the tree's consistency are kept."""
    out.update(vote_joints(points, outputs, priors, awareness=awareness))
    J = priors.num_joints
    out["flipped"] = np.zeros(priors.num_parts, dtype=bool)
    if resolve_flips and J > 0:
        out["cam_from_part"], out["flipped"] = resolve_joint_flips(out["cam_from_part"], out["joint_axis"], priors, out["size_m"])
    out["carried"] = np.zeros(priors.num_parts, dtype=bool)
    if upright and J > 0:
        out["cam_from_part"], out["carried"] = carry_upright(out["cam_from_part"], out["size_m"], priors, carry_margin_deg)
    T, S = out["cam_from_part"], out["size_m"]
    state = np.zeros(J)
    for j, jp in enumerate(priors.joints):  # a handful of joints
        p, c = jp.parent, jp.child
        state[j] = joint_state_from_poses(T[p], T[c], out["joint_axis"][j], jp.type, S[p], S[c], jp.zero_offset_m)
    out["joint_state"] = state
    out["joint_clamped"] = np.zeros(J, dtype=bool)
    if clamp_states and J > 0:
        out["cam_from_part"], out["joint_state"], out["joint_clamped"] = clamp_joint_states(
            T, out["joint_axis"], out["joint_pivot"], state, priors
        )
        out["joint_score"] = np.where(out["joint_clamped"], 0.5 * out["joint_score"], out["joint_score"])
        T = out["cam_from_part"]
    out["refined"] = False
    if refine and J > 0:
        r = kinematic_refine(T, S, out, priors, part_weights=np.maximum(out["score"], 1e-3))
        out.update(cam_from_part=r["cam_from_part"], joint_axis=r["joint_axis"], joint_state=r["joint_state"], refined=True)
        if faces is not None:
            out["cam_from_part"], out["joint_axis"], turned = _root_back_to_faces(
                out["cam_from_part"], out["joint_axis"], faces, priors
            )
            out["face_aligned"] = out["face_aligned"] | turned
    return out


FACE_RESET_MAX_DEG = 30.0
"""After the kinematic refinement, an aligned root within this angle of its aligned rotation is turned back
onto it (the refinement moved it); farther (a flip or an upright carry turned it) it is aligned afresh."""


def _root_back_to_faces(T: np.ndarray, joint_axis: np.ndarray, faces: tuple, priors: CategoryPriors):
    """The refined tree turned as one so that its root is on its faces again: back onto the root's rotation
    aligned before the joints (``faces[2]``) when the refinement left it within :data:`FACE_RESET_MAX_DEG`,
    else aligned afresh from where the refinement put it (every other part follows through the tree, the
    joint axes too, so states and consistency are kept). Aligning afresh from the refined rotation instead
    let the cabinet lock onto normals that lean off its faces (a far side panel's, quantised in depth:
    :data:`ucope.voting.faces.FACE_NORMAL_K`) on some drawer views: the refinement had moved it 5-10
    degrees, enough to bring them inside the matching cone."""
    T = np.array(T, np.float64)
    R_ref, R_aligned = T[0, :3, :3].copy(), faces[2]
    if rotation_angle_deg(R_aligned, R_ref) <= FACE_RESET_MAX_DEG:
        turn = R_aligned @ R_ref.T
    else:
        tree = [(jp.child, jp.parent) for jp in priors.joints]
        T2, _ = align_parts_to_faces(T, faces[0], faces[1], [p.symmetry for p in priors.parts], tree)
        turn = T2[0, :3, :3] @ R_ref.T
    T[:, :3, :3] = np.einsum("ij,kjl->kil", turn, T[:, :3, :3])
    turned = np.full(len(T), not np.allclose(turn, np.eye(3)))
    return T, np.asarray(joint_axis, np.float64) @ turn.T, turned
