"""ucope.stages.revolute: a thin revolute child turned about its joint onto its points, and a part showing few points
seated back on its hinge."""

import numpy as np
import pytest
from stages_support import door_priors

from ucope.errors import InputError
from ucope.geometry.kinematics import joint_state_from_poses
from ucope.geometry.transforms import rotation_about_axis, rotation_angle_deg
from ucope.priors import CategoryPriors, JointPrior
from ucope.stages.revolute import seat_weak_parts, turn_thin_children


def _open_door_scene(seed=0, state=0.6, voted_off=0.35, n=400):
    """A cabinet seen from the front (2.5 m away) with its door open by ``state`` rad, the door's front face
    sampled (``n`` points, 1 mm noise), and the door voted ``voted_off`` rad further open about its hinge."""
    pri = door_priors()
    rng = np.random.default_rng(seed)
    S = np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.05]])
    R0 = rotation_about_axis(np.array([0.0, 1.0, 0.0]), np.pi + 0.3) @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), 0.4)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[0, :3, :3], T[0, :3, 3] = R0, [0.05, 0.3, 2.5]
    hinge = T[0, :3, 3] + R0 @ (np.array([0.0, -0.4, 0.3]))  # the body's front bottom edge
    axis = R0[:, 0]

    def door(q):
        D = np.eye(4)
        D[:3, :3] = R0 @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), q)
        D[:3, 3] = hinge - D[:3, :3] @ np.array([0.0, -0.35, -0.025])
        return D

    T[1] = door(state)
    face = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.35, 0.35, n), np.full(n, 0.025)])
    pts = face @ T[1, :3, :3].T + T[1, :3, 3] + rng.normal(0.0, 0.001, (n, 3))
    voted = T.copy()
    voted[1] = door(state + voted_off)
    return pri, T, voted, S, axis, pts, np.ones(n, dtype=np.int64)


def test_a_door_voted_too_far_open_turns_back_onto_its_points():
    """A door voted 20 degrees further open (or closed) than its points say turns back to within a degree, its
    front face on its points; the body stays, and so does a door voted right."""

    for off in (0.35, -0.35):
        pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=off)
        got, turned = turn_thin_children(voted, S, axis[None], pts, lab, pri)
        assert rotation_angle_deg(got[1, :3, :3], T[1, :3, :3]) < 1.0
        assert abs(np.degrees(joint_state_from_poses(got[0], got[1], axis, "revolute")) - np.degrees(0.6)) < 1.0
        assert abs(np.degrees(turned[1]) + np.degrees(off)) < 1.0 and turned[0] == 0.0
        normal = got[1, :3, :3][:, 2]
        assert abs(np.median((pts - got[1, :3, 3]) @ normal) - 0.025) < 1e-3  # the front face on the points
        # turned about its points, not the voted hinge: the centre lands within 5 % of the door's diagonal
        assert np.linalg.norm(got[1, :3, 3] - T[1, :3, 3]) < min(
            0.05 * np.linalg.norm(S[1]), np.linalg.norm(voted[1, :3, 3] - T[1, :3, 3])
        )
        np.testing.assert_array_equal(got[0], voted[0])
    pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=0.01)  # under the smallest turn (min_turn_deg)
    got, turned = turn_thin_children(voted, S, axis[None], pts, lab, pri)
    assert not turned.any() and np.array_equal(got, voted)


def test_turning_leaves_few_short_or_round_point_sets_thick_children_and_slides_alone():
    pri, T, voted, S, axis, pts, lab = _open_door_scene()
    cases = {
        "few points": (pts[:40], lab[:40], S, pri),
        "a short strip": (pts[np.abs((pts - T[1, :3, 3]) @ T[1, :3, 1]) < 0.05], None, S, pri),
        "a thick child": (pts, lab, np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.4]]), pri),
        "a blade, thin along its hinge": (pts, lab, np.array([[0.6, 0.8, 0.6], [0.02, 0.7, 0.05]]), pri),
        "a slide": (pts, lab, S, door_priors().__class__(**{**door_priors().__dict__, "joints": (
            door_priors().joints[0].__class__("prismatic", 0, 1, (0, 0, 1)),)})),
    }  # fmt: skip
    for name, (p, lb, size, priors) in cases.items():
        lb = np.ones(len(p), dtype=np.int64) if lb is None else lb
        got, turned = turn_thin_children(voted, size, axis[None], p, lb, priors)
        assert not turned.any() and np.array_equal(got, voted), name
    for lb in (np.zeros(len(pts), dtype=np.int64), np.full(len(pts), -1)):  # no point of the door
        got, turned = turn_thin_children(voted, S, axis[None], pts, lb, pri)
        assert not turned.any() and np.array_equal(got, voted)
    # points seen edge-on along the hinge form a blob, not a line: a door seen from straight above
    rng = np.random.default_rng(1)
    blob = T[1, :3, 3] + rng.normal(0.0, 0.05, (300, 3))
    got, turned = turn_thin_children(voted, S, axis[None], blob, np.ones(300, dtype=np.int64), pri)
    assert not turned.any()


def test_a_turn_that_moves_the_points_out_of_the_box_is_undone():
    """A strip of the body's bottom mislabelled as the door, joined to it at the hinge and longer than it, draws
    the line: the turn that follows it leaves most of the points outside the box, and is undone."""

    pri, T, voted, S, axis, pts, lab = _open_door_scene(voted_off=0.0)
    rng = np.random.default_rng(2)
    bottom = np.column_stack([rng.uniform(-0.3, 0.3, 300), np.full(300, -0.4), rng.uniform(-0.5, 0.3, 300)])
    strip = bottom @ T[0, :3, :3].T + T[0, :3, 3]
    both = np.concatenate([pts, strip])
    labels = np.ones(len(both), dtype=np.int64)
    free, turned_free = turn_thin_children(voted, S, axis[None], both, labels, pri, check_tol=1e9)
    assert abs(turned_free[1]) > np.radians(10.0)  # without the check the strip turns the door
    got, turned = turn_thin_children(voted, S, axis[None], both, labels, pri)
    assert not turned.any() and np.array_equal(got, voted)


def test_turning_names_bad_input():
    pri, T, voted, S, axis, pts, lab = _open_door_scene()
    with pytest.raises(InputError, match="joint_axis"):
        turn_thin_children(voted, S, np.zeros((2, 3)), pts, lab, pri)
    with pytest.raises(InputError, match="zero-length"):
        turn_thin_children(voted, S, np.zeros((1, 3)), pts, lab, pri)
    with pytest.raises(InputError, match="camera"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, camera=[0.0, np.nan, 0.0])
    with pytest.raises(InputError, match="thin_ratio"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, thin_ratio=0.0)
    with pytest.raises(InputError, match="min_elongation"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, min_elongation=0.5)
    with pytest.raises(InputError, match="check_tol"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, check_tol=-1.0)
    with pytest.raises(InputError, match="confidence"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, confidence=np.ones(3))
    with pytest.raises(InputError, match="min_confidence"):
        turn_thin_children(voted, S, axis[None], pts, lab, pri, min_confidence=1.5)
    with pytest.raises(InputError, match="finite"):
        turn_thin_children(voted, S, axis[None], np.full_like(pts, np.nan), lab, pri)


def _seat_scene(door_points, body_points=3000, q=0.6):
    """A body and a door open by ``q`` rad hinged at the body's front bottom edge (``_door_priors``), the door
    voted 0.3 m along its hinge and 0.2 m out in front; labels: so many points of each."""
    rng = np.random.default_rng(3)
    R0 = rotation_about_axis(rng.normal(size=3), 0.8)
    S = np.array([[0.6, 0.8, 0.6], [0.6, 0.7, 0.05]])
    T = np.tile(np.eye(4), (2, 1, 1))
    T[0, :3, :3], T[0, :3, 3] = R0, [0.1, -0.2, 2.4]
    T[1, :3, :3] = R0 @ rotation_about_axis(np.array([1.0, 0.0, 0.0]), q)
    hinge = R0 @ (np.array([0.0, -0.5, 0.5]) * S[0]) + T[0, :3, 3]
    T[1, :3, 3] = hinge - T[1, :3, :3] @ (np.array([0.0, -0.5, -0.5]) * S[1])
    voted = T.copy()
    voted[1, :3, 3] += R0 @ np.array([0.3, 0.0, 0.2])
    labels = np.repeat([0, 1, -1], [body_points, door_points, 50])
    return T, voted, S, labels, hinge


def test_a_door_showing_few_points_is_seated_back_on_its_hinge():
    """A door with 2 % of the points, voted off along its hinge and in front of the body: its centre goes where
    its hinge point meets the body's (a plain reference from the pivot places), the joint's pivot to that point;
    its rotation, the body and the sizes stay. A door with half the points, or one voted less than ``min_gap`` of
    its diagonal off, keeps its voted centre."""

    pri = door_priors()
    T, voted, S, labels, hinge = _seat_scene(door_points=60)
    piv = np.array([[9.0, 9.0, 9.0]])
    got, got_piv, seated = seat_weak_parts(voted, S, piv, labels, pri)
    assert seated.tolist() == [False, True]
    np.testing.assert_allclose(got[1], T[1], atol=1e-12)  # the scene's door sits exactly at the pivot places
    np.testing.assert_allclose(got_piv[0], hinge, atol=1e-12)
    np.testing.assert_array_equal(got[0], voted[0])
    np.testing.assert_array_equal(got[1, :3, :3], voted[1, :3, :3])
    assert np.array_equal(piv, [[9.0, 9.0, 9.0]])  # the input is not changed
    _, voted_strong, _, strong_labels, _ = _seat_scene(door_points=3000)
    same, same_piv, seated = seat_weak_parts(voted_strong, S, piv, strong_labels, pri)
    assert not seated.any() and np.array_equal(same, voted_strong) and np.array_equal(same_piv, piv)
    near = T.copy()  # 5 cm off, under 0.2 of the door's 0.92 m diagonal: the vote stands
    near[1, :3, 3] += T[0, :3, :3] @ np.array([0.05, 0.0, 0.0])
    same, _, seated = seat_weak_parts(near, S, piv, labels, pri)
    assert not seated.any() and np.array_equal(same, near)
    _, seated = seat_weak_parts(near, S, piv, labels, pri, min_gap=0.0)[1:]
    assert seated.tolist() == [False, True]


def test_seating_takes_a_weak_root_from_its_child_and_leaves_shared_views_prismatic_and_pivotless_joints_alone():
    pri = door_priors()
    T, _, S, _, hinge = _seat_scene(door_points=60)
    voted = T.copy()
    voted[0, :3, 3] += [0.2, -0.1, 0.3]  # the body (the root of two parts) voted off, the door seen well
    got, got_piv, seated = seat_weak_parts(voted, S, np.zeros((1, 3)), np.repeat([0, 1], [40, 3000]), pri)
    assert seated.tolist() == [True, False]
    np.testing.assert_allclose(got[0], T[0], atol=1e-12)
    np.testing.assert_allclose(got_piv[0], hinge, atol=1e-12)
    shared = np.repeat([0, 1, -1], [2400, 600, 3000])  # 80 / 20 % of the object: neither weak
    for kind, pivots in (("revolute", True), ("prismatic", True), ("revolute", False)):
        kw = {"pivot_in_parent": (0.0, -0.5, 0.5), "pivot_in_child": (0.0, -0.5, -0.5)} if pivots else {}
        other = CategoryPriors(
            category="cabinet_door",
            parts=pri.parts,
            joints=(JointPrior(kind, 0, 1, (1, 0, 0), limits=(0.0, 1.0), **kw),),
        )
        labels = shared if (kind, pivots) == ("revolute", True) else np.repeat([0, 1], [3000, 60])
        same, _, seated = seat_weak_parts(voted, S, np.zeros((1, 3)), labels, other)
        assert not seated.any() and np.array_equal(same, voted)


def test_seating_names_bad_input():
    pri = door_priors()
    T, voted, S, labels, _ = _seat_scene(door_points=60)
    piv = np.zeros((1, 3))
    with pytest.raises(InputError, match="shapes"):
        seat_weak_parts(voted[:1], S, piv, labels, pri)
    with pytest.raises(InputError, match="integers"):
        seat_weak_parts(voted, S, piv, labels.astype(float), pri)
    with pytest.raises(InputError, match="finite"):
        seat_weak_parts(voted, S, np.full((1, 3), np.nan), labels, pri)
    with pytest.raises(InputError, match="positive"):
        seat_weak_parts(voted, -S, piv, labels, pri)
    with pytest.raises(InputError, match="lie in"):
        seat_weak_parts(voted, S, piv, labels, pri, weak_share=1.5)
    with pytest.raises(InputError, match="min_gap"):
        seat_weak_parts(voted, S, piv, labels, pri, min_gap=-0.1)
