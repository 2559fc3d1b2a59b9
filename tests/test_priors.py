"""Category priors: validation, JSON round trip, measurement from samples."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import InputError
from ucope.geometry.boxes import SEEN_PATTERNS
from ucope.geometry.transforms import rotation_about_axis
from ucope.objects.categories import make_instance
from ucope.priors import (
    CategoryPriors,
    JointPrior,
    PartPrior,
    StackPrior,
    faced_gap_statistics,
    measure_priors,
    pivot_offsets,
    placement_offsets,
    seen_extent_statistics,
    stack_statistics,
    structure_from_dict,
    upright_statistics,
)
from ucope.vocab import JointType


def _samples(category, n=10, split="train"):
    cfg = GenerateConfig(category=category, split=split, num=n, max_points=800, views_per_instance=2)
    return [make_sample(cfg, i) for i in range(n)]


def _structure(category):
    return make_instance(category, "train", 0).structure()


def test_measured_priors_bound_the_vote_parameters_and_round_trip():
    samples = _samples("laptop")
    pri = measure_priors(samples, "laptop", _structure("laptop"))
    for s in samples:
        for k in range(2):
            pts = s["points"][s["part_labels"] == k]
            if len(pts):
                assert np.linalg.norm(pts - s["cam_from_part"][k][:3, 3], axis=1).max() <= pri.parts[k].vote_range_m
    assert 0.05 < pri.norm_scale_m < 0.5
    lo, hi = pri.radius_range_m
    assert lo <= pri.radius_typical_m[0] <= pri.radius_typical_m[1] <= hi
    assert math.isclose(pri.parts[0].mean_size_m[0], pri.parts[1].mean_size_m[0], rel_tol=1e-6)  # lid as wide as the base
    (j,) = pri.joints
    assert j.type == JointType.REVOLUTE and j.limits == (0.35, 2.6) and j.zero_offset_m == 0.0
    # the lid is as wide and as deep as the base in every view; its thickness ratio varies
    np.testing.assert_allclose([j.child_size_ratio[0], j.child_size_ratio[2]], [1.0, 1.0], rtol=1e-9)
    assert j.child_size_spread[0] < 1e-9 and j.child_size_spread[2] < 1e-9 and j.child_size_spread[1] > 0.01
    # the lid sits above the base (+y in the base frame), the base below the lid
    assert j.child_in_parent[1] > 0.1 and j.parent_in_child[1] < 0.0
    for t in pri.shape_templates:  # the templates fill the unit box
        assert t.dtype == np.float32 and len(t) > 100 and np.abs(t).max() <= 0.5 and np.ptp(t, axis=0).min() > 0.5
    back = CategoryPriors.from_dict(json.loads(json.dumps(pri.to_dict())), pri.tensors())
    assert back == pri and all(np.array_equal(a, b) for a, b in zip(back.shape_templates, pri.shape_templates, strict=False))


def test_prismatic_zero_offsets_and_limits_widened_to_the_states_seen():
    samples = _samples("drawer", 12)
    pri = measure_priors(samples, "drawer", _structure("drawer"))
    assert [j.type for j in pri.joints] == [JointType.PRISMATIC] * 3
    assert all(0.0 < j.zero_offset_m < 0.05 for j in pri.joints)
    assert all(j.axis_in_parent == (0.0, 0.0, 1.0) for j in pri.joints)
    top = max(float(np.max(s["joint_state"])) for s in samples)
    assert max(j.limits[1] for j in pri.joints) >= top - 1e-12  # instance 0's limits widened by what was seen
    # drawers are centred left-right in their cabinets: no spread along x; the slots and states spread y and z
    for j in pri.joints:
        assert j.child_in_parent_spread[0] < 1e-9 and j.child_in_parent_spread[2] > 0.01
    back = CategoryPriors.from_dict(pri.to_dict())
    assert [j.child_in_parent_spread for j in back.joints] == [j.child_in_parent_spread for j in pri.joints]
    # the drawers stand one above the other, top first, just under the cabinet's top
    (st,) = pri.stacks
    assert (st.parent, st.axis, st.children) == (0, 1, (1, 2, 3)) and back.stacks == pri.stacks
    assert 0.0 <= st.first_gap < 0.12 and 0.0 <= st.gap < 0.05
    rigid = measure_priors(_samples("mug", 3), "mug", _structure("mug"))
    assert rigid.joints == () and rigid.num_parts == 1


def test_placement_offsets_match_a_direct_computation(rng):
    from ucope.geometry.transforms import make_transform, random_rotation

    T = np.stack([np.stack([make_transform(random_rotation(rng), rng.normal(size=3)) for _ in range(2)]) for _ in range(5)])
    S = rng.uniform(0.1, 1.0, (5, 2, 3))
    cip, pic = placement_offsets(T, S, 0, 1)
    for s in range(5):
        np.testing.assert_allclose(cip[s], T[s, 0, :3, :3].T @ (T[s, 1, :3, 3] - T[s, 0, :3, 3]) / np.linalg.norm(S[s, 0]))
        np.testing.assert_allclose(pic[s], T[s, 1, :3, :3].T @ (T[s, 0, :3, 3] - T[s, 1, :3, 3]) / np.linalg.norm(S[s, 1]))


def test_pivot_offsets_describe_one_point_on_the_axis_in_both_parts(rng):
    from ucope.geometry.transforms import make_transform, random_rotation

    a = np.array([0.0, 0.6, 0.8])
    T = np.stack([np.stack([make_transform(random_rotation(rng), rng.normal(size=3)) for _ in range(2)]) for _ in range(4)])
    S = rng.uniform(0.1, 1.0, (4, 2, 3))
    pivot = rng.normal(size=(4, 3))
    pp, pc = pivot_offsets(T, S, pivot, a, 0, 1)
    for s in range(4):
        foot_p = T[s, 0, :3, :3] @ (pp[s] * S[s, 0]) + T[s, 0, :3, 3]
        foot_c = T[s, 1, :3, :3] @ (pc[s] * S[s, 1]) + T[s, 1, :3, 3]
        np.testing.assert_allclose(foot_p, foot_c, atol=1e-12)  # the same point, seen from both parts
        u = T[s, 0, :3, :3] @ a
        d = foot_p - pivot[s]
        np.testing.assert_allclose(np.linalg.norm(np.cross(d, u)), 0.0, atol=1e-12)  # on the axis line
        assert abs((foot_p - T[s, 0, :3, 3]) @ u) < 1e-12  # the foot from the parent's centre


def test_upright_statistics_find_the_axis_the_views_hold_and_its_cone(rng):
    from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis

    # part 0 tilts up to 20 degrees about random horizontal axes; part 1 turns freely
    t = rng.uniform(0, 2 * np.pi, 50)
    tilt = rotation_about_axis(np.stack([np.cos(t), 0 * t, np.sin(t)], -1), np.radians(np.linspace(0, 20, 50)))
    R0 = tilt @ rotation_about_axis(np.array([0.0, 1.0, 0.0]), rng.uniform(-np.pi, np.pi, 50))
    zero = np.zeros(3)
    T = np.stack([np.stack([make_transform(R0[s], zero), make_transform(random_rotation(rng), zero)]) for s in range(50)])
    (ax, mean, cone), free = upright_statistics(T)
    assert ax == 1 and free is None
    direct = T[:, 0, :3, 1].mean(0)
    np.testing.assert_allclose(mean, direct / np.linalg.norm(direct))
    assert cone == pytest.approx(np.degrees(np.arccos(np.clip(T[:, 0, :3, 1] @ np.array(mean), -1, 1))).max())
    assert 15.0 < cone < 25.0


def test_measured_priors_hold_the_upright_base_and_the_hinge(rng):
    samples = _samples("laptop", 16)
    pri = measure_priors(samples, "laptop", _structure("laptop"))
    base, lid = pri.parts
    assert base.upright_axis == 1 and 5.0 < base.upright_cone_deg < 60.0  # the base lies on the table, y up
    assert lid.upright_axis is None  # the lid turns with the joint
    (j,) = pri.joints
    # the hinge runs along the base's top back edge (docs/conventions.md: the lid rises at -z)
    assert j.pivot_in_parent[1] == pytest.approx(0.5, abs=0.05) and j.pivot_in_parent[2] == pytest.approx(-0.5, abs=0.05)
    drawers = measure_priors(_samples("drawer", 6), "drawer", _structure("drawer"))
    assert all(jp.pivot_in_parent is None for jp in drawers.joints)  # prismatic joints have no pivot


def test_bad_priors_and_structures_are_refused():
    part = PartPrior(name="a", symmetry="none", vote_range_m=0.2, mean_size_m=(0.1, 0.1, 0.1))
    with pytest.raises(InputError, match="symmetry"):
        PartPrior(name="a", symmetry="x", vote_range_m=0.2, mean_size_m=(0.1, 0.1, 0.1))
    with pytest.raises(InputError, match="positive"):
        PartPrior(name="a", symmetry="none", vote_range_m=0.2, mean_size_m=(0.1, 0.0, 0.1))
    with pytest.raises(InputError, match="joint type"):
        JointPrior(type="ball", parent=0, child=1, axis_in_parent=(1, 0, 0))
    with pytest.raises(InputError, match="fixed"):
        JointPrior(type="fixed", parent=0, child=1, axis_in_parent=(1, 0, 0))
    with pytest.raises(InputError, match="non-zero"):
        JointPrior(type="revolute", parent=0, child=1, axis_in_parent=(0, 0, 0))
    with pytest.raises(InputError, match="lower <= upper"):
        JointPrior(type="revolute", parent=0, child=1, axis_in_parent=(1, 0, 0), limits=(1.0, 0.0))
    with pytest.raises(InputError, match="go together"):
        PartPrior(name="a", symmetry="none", vote_range_m=0.2, mean_size_m=(0.1, 0.1, 0.1), upright_axis=1)
    with pytest.raises(InputError, match="0, 1 or 2"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), upright_axis=3, upright_in_cam=(0, 1, 0), upright_cone_deg=20.0)
    with pytest.raises(InputError, match=r"\[0, 180\]"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), upright_axis=1, upright_in_cam=(0, 1, 0), upright_cone_deg=-1.0)
    with pytest.raises(InputError, match="go together"):
        JointPrior(type="revolute", parent=0, child=1, axis_in_parent=(1, 0, 0), pivot_in_parent=(0, 0.5, -0.5))
    joint = JointPrior(type="revolute", parent=0, child=1, axis_in_parent=(0, 2, 0), limits=(None, None))
    assert joint.axis_in_parent == (0.0, 1.0, 0.0) and joint.limits == (None, None)
    with pytest.raises(InputError, match="1 joints"):
        CategoryPriors(category="c", parts=(part, PartPrior("b", "none", 0.2, (0.1, 0.1, 0.1))), joints=())
    with pytest.raises(InputError, match="unique"):
        CategoryPriors(category="c", parts=(part, part), joints=(joint,))
    with pytest.raises(InputError, match="tree"):
        CategoryPriors(
            category="c",
            parts=(part, PartPrior("b", "none", 0.2, (0.1, 0.1, 0.1))),
            joints=(JointPrior(type="revolute", parent=1, child=1, axis_in_parent=(1, 0, 0)),),
        )
    with pytest.raises(InputError, match="malformed category priors"):
        CategoryPriors.from_dict({"category": "c", "parts": []})
    with pytest.raises(InputError, match="malformed category structure"):
        structure_from_dict({"parts": [{"name": "a"}], "joints": []})
    with pytest.raises(InputError, match="needs 1"):
        structure_from_dict({"parts": [{"name": "a", "symmetry": "none"}, {"name": "b", "symmetry": "none"}], "joints": []})
    with pytest.raises(InputError, match="empty"):
        measure_priors([], "laptop", _structure("laptop"))
    with pytest.raises(InputError, match="3 parts"):
        measure_priors(_samples("eyeglasses", 2), "laptop", _structure("laptop"))


def test_seen_extents_are_ordered_percentiles_of_what_the_views_saw_and_round_trip():
    """The laptop's lid, seen from outside, shows nearly all of its width (x) in every view; the table's
    percentiles are ordered, patterns seen too rarely are NaN, and the JSON form (null for NaN) round-trips."""
    samples = _samples("laptop", 24)
    table = seen_extent_statistics(samples, 2, min_views=3)
    assert table.shape == (2, 3, SEEN_PATTERNS, 3)
    measured = ~np.isnan(table[..., 0])
    assert measured.any() and (~measured).any()
    t = table[measured]
    assert np.all(t[:, 0] <= t[:, 1]) and np.all(t[:, 1] <= t[:, 2]) and np.all(t >= 0)
    lid_x = table[1, 0][~np.isnan(table[1, 0, :, 1])]
    assert len(lid_x) and np.all(lid_x[:, 1] > 0.9)
    assert np.isnan(seen_extent_statistics(samples, 2, min_views=1000)).all()
    # measure_priors keeps it per part; JSON null <-> NaN
    pri = measure_priors(samples, "laptop", _structure("laptop"))
    assert pri.seen_extent.shape == (2, 3, SEEN_PATTERNS, 3)
    back = CategoryPriors.from_dict(json.loads(json.dumps(pri.to_dict())), pri.tensors())
    np.testing.assert_array_equal(back.seen_extent, pri.seen_extent)  # NaN where NaN
    no_table = replace(pri, parts=tuple(replace(p, seen_extent=None) for p in pri.parts))
    assert no_table.seen_extent is None
    with pytest.raises(InputError, match="seen_extent"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), seen_extent=[[[1.0, 1.0, 1.0]] * SEEN_PATTERNS] * 2)
    with pytest.raises(InputError, match="seen_extent"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), seen_extent=[[[-1.0, 1.0, 1.0]] * SEEN_PATTERNS] * 3)
    with pytest.raises(InputError, match="seen_extent"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), seen_extent=[[["x", 1.0, 1.0]] * SEEN_PATTERNS] * 3)


def test_faced_gaps_are_small_for_the_faces_the_camera_faces_and_round_trip():
    """The laptop base's top (its + y face, which the cameras above look down on) shows its points right at the
    face: a gap of a few millimetres per box diagonal; the base's bottom is never faced; the JSON form
    round-trips (null for NaN)."""
    samples = _samples("laptop", 24)
    gap = faced_gap_statistics(samples, 2, min_views=3)
    assert gap.shape == (2, 3, 2, 3)
    top = gap[0, 1, 1]
    assert np.all(np.isfinite(top)) and top[0] <= top[1] <= top[2] and abs(top[1]) < 0.03
    assert np.isnan(gap[0, 1, 0]).all()  # the bottom face: the camera is never below the base
    pri = measure_priors(samples, "laptop", _structure("laptop"))
    back = CategoryPriors.from_dict(json.loads(json.dumps(pri.to_dict())), pri.tensors())
    np.testing.assert_array_equal(back.faced_gap, pri.faced_gap)
    assert replace(pri, parts=tuple(replace(p, faced_gap=None) for p in pri.parts)).faced_gap is None
    with pytest.raises(InputError, match="faced_gap"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), faced_gap=[[[0.0, 0.0, 0.0]] * 3] * 3)
    with pytest.raises(InputError, match="faced_gap"):
        PartPrior("a", "none", 0.2, (0.1, 0.1, 0.1), faced_gap=[[[float("inf"), 0.0, 0.0]] * 2] * 3)


def _stacked_views(rng, n=30, overlap=0.0):
    """``n`` views of a cabinet (part 0, 0.6 x H x 0.5) with three drawers (parts 1-3, given bottom first) stacked
    top down from 0.02 H under its top with 5 mm between them (``overlap``: the middle one pushed up into the top
    one by that much of H), each view under a random rotation, the drawers pulled out at random."""
    T = np.tile(np.eye(4), (n, 4, 1, 1))
    S = np.zeros((n, 4, 3))
    for v in range(n):
        H = rng.uniform(0.4, 1.2)
        h = rng.uniform(0.15, 0.25, 3) * H
        S[v] = [[0.6, H, 0.5], [0.55, h[2], 0.45], [0.55, h[1], 0.45], [0.55, h[0], 0.45]]  # parts 1-3: bottom first
        R = rotation_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
        top = 0.5 * H - 0.02 * H
        y = []
        for k in range(3):  # top, middle, bottom
            y.append(top - 0.5 * h[k])
            top -= h[k] + 0.005
        y[1] += overlap * H
        T[v, :, :3, :3] = R
        T[v, 0, :3, 3] = rng.normal(size=3)
        for k, part in enumerate((3, 2, 1)):
            T[v, part, :3, 3] = T[v, 0, :3, 3] + R @ [0.0, y[k], rng.uniform(0.0, 0.3)]
    return T, S


def _prismatic(children, axis=(0, 0, 1)):
    return [JointPrior("prismatic", 0, c, axis) for c in children]


def test_stack_statistics_find_the_drawers_top_down_with_their_gaps():
    T, S = _stacked_views(np.random.default_rng(0))
    (st,) = stack_statistics(T, S, _prismatic((1, 2, 3)))
    assert (st.parent, st.axis, st.children) == (0, 1, (3, 2, 1))  # top first, whatever the joints' order
    assert st.first_gap == pytest.approx(0.02, abs=1e-9) and st.first_gap_spread == pytest.approx(0.0, abs=1e-9)
    gaps = 0.005 / S[:, 0, 1]
    assert st.gap == pytest.approx(np.median(np.r_[gaps, gaps])) and st.gap_spread > 0  # 5 mm over H
    back = StackPrior(**json.loads(json.dumps(st.to_dict())))
    assert back == st
    # drawers that overlap in a view, one drawer alone, revolute joints, a slide along y: no stack
    T2, S2 = _stacked_views(np.random.default_rng(1), overlap=0.05)
    assert stack_statistics(T2, S2, _prismatic((1, 2, 3))) == ()
    assert stack_statistics(T, S, _prismatic((1,))) == ()
    assert stack_statistics(T, S, [JointPrior("revolute", 0, c, (1, 0, 0)) for c in (1, 2, 3)]) == ()
    assert stack_statistics(T, S, _prismatic((1, 2, 3), axis=(0, 1, 0))) == ()  # sliding up: side by side across it
    with pytest.raises(InputError, match="size_m"):
        stack_statistics(T, S[:, :3], _prismatic((1, 2, 3)))
    with pytest.raises(InputError, match="positive"):
        stack_statistics(T, -S, _prismatic((1, 2, 3)))


def test_bad_stacks_are_refused():
    ok = dict(parent=0, axis=1, children=(1, 2), first_gap=0.03, gap=0.005, first_gap_spread=0.06, gap_spread=0.04)
    for bad, match in (
        (dict(children=(1,)), "two or more"),
        (dict(children=(1, 1)), "two or more"),
        (dict(children=(0, 1)), "two or more"),
        (dict(axis=3), "axis"),
        (dict(gap_spread=-0.1), "spreads"),
        (dict(gap=float("nan")), "gap"),
    ):
        with pytest.raises(InputError, match=match):
            StackPrior(**{**ok, **bad})
    parts = tuple(PartPrior(f"p{k}", "none", 0.5, (0.5, 0.5, 0.5)) for k in range(3))
    hinged = (JointPrior("prismatic", 0, 1, (0, 0, 1)), JointPrior("revolute", 0, 2, (1, 0, 0)))
    with pytest.raises(InputError, match="prismatic children"):
        CategoryPriors("toy", parts, hinged, stacks=(StackPrior(**ok),))
    # a model file whose stack entry is corrupt: a clear error, not a TypeError from deep inside
    form = CategoryPriors("toy", parts, hinged).to_dict()
    for entry in ({"parent": 0, "axis": 1}, {**ok, "colour": "red"}, {**ok, "children": [1]}):
        with pytest.raises(InputError, match="malformed category priors|two or more"):
            CategoryPriors.from_dict({**form, "stacks": [entry]})


def test_max_state_over_extent_is_the_largest_slide_for_the_drawer_depth_and_round_trips():
    """On drawer views the largest state over the drawer's depth (its box extent along the slide) is at most 0.75
    (three-quarter extension slides: the generator's upper limit) and close to it; a plain per-sample reference
    agrees; revolute joints get none; the value survives to_dict / from_dict, and a revolute joint or a
    non-positive value is refused by name."""
    samples = _samples("drawer")
    pri = measure_priors(samples, "drawer", _structure("drawer"))
    for j, jp in enumerate(pri.joints):
        want = max(
            s["joint_state"][j]
            / float(np.abs(s["cam_from_part"][jp.child][:3, :3].T @ s["joint_axis"][j]) @ s["size_m"][jp.child])
            for s in samples
        )
        assert jp.max_state_over_extent == pytest.approx(want, rel=1e-9)
        assert 0.4 < jp.max_state_over_extent <= 0.75 + 1e-9
    again = CategoryPriors.from_dict(pri.to_dict())
    assert [jp.max_state_over_extent for jp in again.joints] == [jp.max_state_over_extent for jp in pri.joints]
    assert all(
        jp.max_state_over_extent is None for jp in measure_priors(_samples("laptop"), "laptop", _structure("laptop")).joints
    )
    with pytest.raises(InputError, match="max_state_over_extent"):
        JointPrior(JointType.REVOLUTE, 0, 1, (1.0, 0.0, 0.0), max_state_over_extent=0.5)
    with pytest.raises(InputError, match="max_state_over_extent"):
        JointPrior(JointType.PRISMATIC, 0, 1, (0.0, 0.0, 1.0), max_state_over_extent=0.0)
