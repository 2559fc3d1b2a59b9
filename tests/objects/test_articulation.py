import numpy as np
import pytest
from tests_support import make_toy_object  # noqa: E402

from ucope.errors import InputError
from ucope.geometry.transforms import axis_angle_transform
from ucope.objects.articulation import ArticulatedObject, Joint, Part, build_object, make_part
from ucope.objects.shapes import box


def test_make_part_centres_the_box():
    part, T = make_part("p", box([0.2, 0.4, 0.6], [1.0, 2.0, 3.0]))
    np.testing.assert_allclose(part.size_m, [0.2, 0.4, 0.6])
    np.testing.assert_allclose(T[:3, 3], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(part.mesh.bounds.sum(0), 0.0, atol=1e-12)


def test_rest_and_fk_of_a_revolute_joint():
    obj = make_toy_object()
    assert obj.num_parts == 2 and obj.joint_types == ("revolute",)
    poses0 = obj.object_from_part([0.0])
    np.testing.assert_allclose(poses0[0], np.eye(4), atol=1e-12)
    # at 90 degrees the lid stands up behind the hinge
    poses = obj.object_from_part([np.pi / 2])
    piv, ax = obj.joints_in_object([np.pi / 2])
    np.testing.assert_allclose(ax[0], [-1.0, 0.0, 0.0], atol=1e-12)
    lid_centre = poses[1, :3, 3]
    assert lid_centre[1] > poses0[1, 1, 3] + 0.1  # moved up
    # the child's motion is exactly a rotation about the joint axis through the pivot
    M = axis_angle_transform(ax[0], piv[0], np.pi / 2)
    np.testing.assert_allclose(poses[1], M @ poses0[1], atol=1e-12)


def test_prismatic_moves_along_axis():
    obj = make_toy_object("prismatic")
    p0, p1 = obj.object_from_part([0.0]), obj.object_from_part([0.2])
    np.testing.assert_allclose(p1[1, :3, 3] - p0[1, :3, 3], [0.0, 0.0, 0.2], atol=1e-12)


def test_state_validation():
    obj = make_toy_object()
    with pytest.raises(InputError, match="outside its limits"):
        obj.object_from_part([3.0])
    with pytest.raises(InputError, match="1 values"):
        obj.object_from_part([0.1, 0.2])
    with pytest.raises(InputError, match="NaN"):
        obj.object_from_part([np.nan])


def test_tree_validation():
    part, _ = make_part("a", box([0.1, 0.1, 0.1]))
    part2, _ = make_part("b", box([0.1, 0.1, 0.1]))
    with pytest.raises(InputError, match="needs 1 joints"):
        ArticulatedObject("c", "i", (part, part2), ())
    j = Joint("revolute", 1, 1, [0, 0, 0], [0, 1, 0], (0, 1), 0)
    with pytest.raises(InputError):
        ArticulatedObject("c", "i", (part, part2), (j,))
    with pytest.raises(InputError, match="unique"):
        ArticulatedObject("c", "i", (part, part), (Joint("revolute", 0, 1, [0, 0, 0], [0, 1, 0], (0, 1), 0),))
    with pytest.raises(InputError, match="type"):
        Joint("ball", 0, 1, [0, 0, 0], [0, 1, 0], (0, 1), 0)
    with pytest.raises(InputError, match="axis"):
        Joint("revolute", 0, 1, [0, 0, 0], [0, 0, 0], (0, 1), 0)
    with pytest.raises(InputError, match="centred"):
        Part("x", box([0.1, 0.1, 0.1], [1.0, 0.0, 0.0]))


def test_chain_of_three_parts():
    # a URDF-like chain: root -> 1 (revolute about y) -> 2 (prismatic along x of part 1)
    parts = [make_part(n, box([0.1, 0.1, 0.1], c)) for n, c in (("a", [0, 0, 0]), ("b", [0.2, 0, 0]), ("c", [0.4, 0, 0]))]
    joints = [
        dict(type="revolute", parent=0, child=1, pivot=[0.1, 0, 0], axis=[0, 1, 0], limits=(-3, 3)),
        dict(type="prismatic", parent=1, child=2, pivot=[0.3, 0, 0], axis=[1, 0, 0], limits=(0, 0.5)),
    ]
    obj = build_object("chain", "c/0", parts, joints)
    P = obj.object_from_part([np.pi / 2, 0.1])
    # part 1 rotated by 90 degrees about y through (0.1, 0, 0): centre (0.2,0,0) -> (0.1, 0, -0.1)
    np.testing.assert_allclose(P[1, :3, 3], [0.1, 0.0, -0.1], atol=1e-12)
    # part 2 at (0.4 + 0.1) along the rotated x axis -> (0.1, 0, -0.4)
    np.testing.assert_allclose(P[2, :3, 3], [0.1, 0.0, -0.4], atol=1e-12)
    v, f, lab = obj.posed_geometry([np.pi / 2, 0.1])
    assert set(lab.tolist()) == {0, 1, 2} and len(f) == 36


def test_scaled_object_scales_every_length_and_keeps_the_frames():
    obj = make_toy_object()
    s = 1.7
    big = obj.scaled(s)
    assert big.scale == pytest.approx(s) and obj.scale == 1.0 and big.params == obj.params
    np.testing.assert_allclose(big.size_m, s * obj.size_m)
    j, jb = obj.joints[0], big.joints[0]
    np.testing.assert_allclose(jb.pivot, s * j.pivot)
    np.testing.assert_array_equal(jb.axis, j.axis)
    assert jb.limits == j.limits  # revolute: radians
    q = [0.3]
    A, B = big.object_from_part(q), obj.object_from_part(q)
    np.testing.assert_allclose(A[:, :3, :3], B[:, :3, :3], atol=1e-12)
    np.testing.assert_allclose(A[:, :3, 3], s * B[:, :3, 3], atol=1e-12)
    for bad in (0.0, -1.0, float("inf")):
        with pytest.raises(InputError):
            obj.scaled(bad)


def test_scaled_prismatic_joint_scales_its_limits():
    base, T0 = make_part("base", box([0.4, 0.1, 0.4]))
    slide, T1 = make_part("slide", box([0.2, 0.05, 0.2], [0.0, 0.1, 0.0]))
    obj = build_object(
        "toy",
        "toy/0",
        [(base, T0), (slide, T1)],
        joints=[dict(type="prismatic", parent=0, child=1, pivot=(0, 0.1, 0), axis=(0, 0, 1), limits=(0.0, 0.3), rest=0.1)],
    )
    half = obj.scaled(0.5)
    assert half.joints[0].limits == pytest.approx((0.0, 0.15)) and half.joints[0].rest == pytest.approx(0.05)
    np.testing.assert_allclose(half.object_from_part([0.15])[1, :3, 3], 0.5 * obj.object_from_part([0.3])[1, :3, 3])


def _state_zero_geometry(obj):
    """Every part's vertices in the object frame at joint state 0 (outside the limits allowed)."""
    T = obj.placements_at_zero()
    return [np.asarray(p.mesh.vertices) @ t[:3, :3].T + t[:3, 3] for p, t in zip(obj.parts, T, strict=True)]


def test_stretched_object_is_the_state_zero_geometry_stretched_and_moves_like_it():
    obj = make_toy_object()
    np.testing.assert_allclose(obj.placements_at_zero(), obj.object_from_part([0.0]), atol=1e-15)
    f = np.array([0.6, 1.8, 1.1])
    st = obj.stretched(f)
    assert st.stretch == pytest.approx(tuple(f)) and obj.stretch == (1.0, 1.0, 1.0) and st.scale == obj.scale
    for a, b in zip(_state_zero_geometry(st), _state_zero_geometry(obj), strict=True):
        np.testing.assert_allclose(a, b * f, atol=1e-12)
    np.testing.assert_allclose(st.size_m, obj.size_m * f, atol=1e-12)  # parts aligned with the object axes
    # the revolute joint (axis -x): the same axis and limits, its pivot line stretched
    j, js = obj.joints[0], st.joints[0]
    np.testing.assert_allclose(js.axis, j.axis, atol=1e-12)
    assert js.limits == j.limits and js.rest == j.rest
    piv, ax = obj.joints_in_object([0.0])
    piv_s, ax_s = st.joints_in_object([0.0])
    np.testing.assert_allclose(piv_s, piv * f, atol=1e-12)
    # at any state the child turns about the stretched hinge line exactly
    q = 0.9
    M = axis_angle_transform(ax_s[0], piv_s[0], q)
    np.testing.assert_allclose(st.object_from_part([q])[1], M @ st.object_from_part([0.0])[1], atol=1e-12)
    # stretching twice multiplies the factors
    assert st.stretched([2.0, 0.5, 1.0]).stretch == pytest.approx((1.2, 0.9, 1.1))


def test_stretched_prismatic_joint_scales_its_limits_by_the_stretched_axis():
    base, T0 = make_part("base", box([0.4, 0.1, 0.4]))
    slide, T1 = make_part("slide", box([0.2, 0.05, 0.2], [0.0, 0.1, 0.0]))
    axis = np.array([0.0, 0.6, 0.8])
    obj = build_object(
        "toy",
        "toy/0",
        [(base, T0), (slide, T1)],
        joints=[dict(type="prismatic", parent=0, child=1, pivot=(0, 0.1, 0), axis=axis, limits=(0.0, 0.3), rest=0.1)],
    )
    f = np.array([1.0, 2.0, 0.5])
    st = obj.stretched(f)
    k = np.linalg.norm(f * axis)  # sqrt(1.44 + 0.16)
    assert st.joints[0].limits == pytest.approx((0.0, 0.3 * k)) and st.joints[0].rest == pytest.approx(0.1 * k)
    np.testing.assert_allclose(st.joints[0].axis, f * axis / k, atol=1e-12)
    # a full move of the stretched slide is the original's full move, stretched
    d = st.object_from_part([0.3 * k])[1, :3, 3] - st.object_from_part([0.0])[1, :3, 3]
    d0 = obj.object_from_part([0.3])[1, :3, 3] - obj.object_from_part([0.0])[1, :3, 3]
    np.testing.assert_allclose(d, d0 * f, atol=1e-12)


def test_stretched_refuses_bad_factors_tilted_parts_and_unequal_stretch_of_a_symmetric_part():
    obj = make_toy_object()
    for bad in ([1.0, 1.0], [1.0, 0.0, 1.0], [1.0, -2.0, 1.0], [1.0, np.nan, 1.0], "abc"):
        with pytest.raises(InputError, match="stretch factors"):
            obj.stretched(bad)
    turn = axis_angle_transform([0, 1, 0], [0, 0, 0], 0.3)[:3, :3]
    tilted, T = make_part("tilted", box([0.2, 0.2, 0.2]), rotation_object_from_part=turn)
    one = build_object("toy", "toy/1", [(tilted, np.eye(4))], joints=[])
    one.stretched([1.0, 1.0, 1.0])  # the root is the object frame: always aligned
    root, T0 = make_part("root", box([0.4, 0.1, 0.4]))
    two = build_object(
        "toy",
        "toy/2",
        [(root, T0), (tilted, T)],
        joints=[dict(type="revolute", parent=0, child=1, pivot=(0, 0, 0), axis=(0, 1, 0), limits=(0.0, 1.0), rest=0.0)],
    )
    with pytest.raises(InputError, match="'tilted' is not aligned"):
        two.stretched([1.0, 2.0, 1.0])
    cyl = ArticulatedObject("toy", "toy/3", (Part("cyl", box([0.1, 0.3, 0.1]), symmetry="y"),))
    cyl.stretched([1.5, 0.5, 1.5])
    with pytest.raises(InputError, match="symmetric about its y axis"):
        cyl.stretched([1.5, 0.5, 1.0])
