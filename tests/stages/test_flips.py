"""ucope.stages.flips: half turns undone by a revolute joint's limits and its neighbours' placements, by a rigid part's
shape, and a cabinet turned round by where its drawers' points lie."""

import numpy as np
import pytest
from stages_support import chest, chest_scene, door_priors, labels_of, samples
from tests_support import measured_priors

from ucope.errors import InputError
from ucope.geometry.transforms import make_transform, random_rotation, rotation_about_axis, rotation_angle_deg
from ucope.model.config import ModelConfig
from ucope.objects.categories import make_instance
from ucope.stages.flips import resolve_front_flips, resolve_joint_flips, resolve_shape_flips


@pytest.mark.parametrize("flip_axis", [(0.0, 1.0, 0.0), (0.0, 0.0, 1.0)])
def test_half_turn_flips_that_contradict_a_revolute_joint_are_undone(rng, flip_axis):
    cfg = ModelConfig.default(measured_priors("laptop", samples("laptop", "train", 4)), size="full")
    a = cfg.priors.joint_axes[0]
    Rp = random_rotation(rng)
    Rc = Rp @ rotation_about_axis(a, 1.2)
    T = np.stack([make_transform(Rp, [0, 0, 1.0]), make_transform(Rc, [0, 0.1, 1.0])])
    u = Rp @ a  # the joint heads' axis
    flipped = T.copy()
    flipped[1, :3, :3] = Rc @ rotation_about_axis(np.array(flip_axis), np.pi)
    fixed, which = resolve_joint_flips(flipped, u[None], cfg.priors)
    assert which.tolist() == [False, True]
    np.testing.assert_allclose(fixed[1, :3, :3], Rc, atol=1e-9)
    np.testing.assert_allclose(fixed[1, :3, 3], T[1, :3, 3])
    # Consistent poses, or both parts against the joint heads' axis, are left alone.
    same, which = resolve_joint_flips(T, u[None], cfg.priors)
    assert not which.any() and np.array_equal(same, T)
    _, which = resolve_joint_flips(T, -u[None], cfg.priors)
    assert not which.any()
    # The parent is the flipped one: it is turned back, the child stays.
    bad_parent = T.copy()
    bad_parent[0, :3, :3] = Rp @ rotation_about_axis(np.array(flip_axis), np.pi)
    fixed, which = resolve_joint_flips(bad_parent, u[None], cfg.priors)
    assert which.tolist() == [True, False]
    np.testing.assert_allclose(fixed[0, :3, :3], Rp, atol=1e-9)
    # A half turn of the child about the hinge itself puts the angle outside the limits: undone too.
    about_hinge = T.copy()
    about_hinge[1, :3, :3] = Rc @ rotation_about_axis(a, np.pi)
    fixed, which = resolve_joint_flips(about_hinge, u[None], cfg.priors)
    assert which.tolist() == [False, True]
    np.testing.assert_allclose(fixed[1, :3, :3], Rc, atol=1e-9)


def test_a_front_turned_about_its_hinge_axis_is_turned_back_by_the_temples_placement(rng):
    """Eyeglasses: a front rotated half a turn about y (the hinge axis: its box maps onto itself) has
    the temples in front of it; the placement check turns it back, and leaves correct poses alone."""

    cfg = ModelConfig.default(measured_priors("eyeglasses", samples("eyeglasses", "train", 4)), size="full")
    obj = make_instance("eyeglasses", "test", 3)
    cam_from_object = make_transform(random_rotation(rng), [0.0, 0.0, 0.6])
    T = cam_from_object @ obj.object_from_part(obj.rest_state)
    axis = T[0, :3, :3] @ cfg.priors.joint_axes[:, :, None]  # (J, 3, 1)
    u = axis[..., 0]
    same, which = resolve_joint_flips(T, u, cfg.priors, obj.size_m)
    assert not which.any()
    np.testing.assert_allclose(same, T)
    bad = T.copy()
    bad[0, :3, :3] = T[0, :3, :3] @ rotation_about_axis(np.array([0.0, 1.0, 0.0]), np.pi)
    fixed, which = resolve_joint_flips(bad, u, cfg.priors, obj.size_m)
    assert which.tolist() == [True, False, False]
    np.testing.assert_allclose(fixed[0, :3, :3], T[0, :3, :3], atol=1e-9)


@pytest.mark.parametrize("half_turn", [0, 1, 2])
def test_a_rigid_part_turned_half_a_turn_is_turned_back_by_its_shape(half_turn):
    """laptop_rigid (an L-shaped body): each half turn of the ground-truth pose about one of the part's
    axes is turned back by the shape check. The ground-truth pose is left alone there and on a mug
    (whose half turns a hidden handle can leave undecided), and a y-symmetric bottle is never turned."""

    axis = np.eye(3)[half_turn]
    for category in ("laptop_rigid", "mug", "bottle"):
        cfg = ModelConfig.default(measured_priors(category, samples(category, "train", 2)), size="full")
        for s in samples(category, "test", 6):
            T, S = s["cam_from_part"], s["size_m"]
            idx = [np.arange(len(s["points"]))]
            same, which = resolve_shape_flips(T, S, s["points"], idx, cfg.priors)
            assert not which.any() and np.allclose(same, T)
            bad = T.copy()
            bad[0, :3, :3] = T[0, :3, :3] @ rotation_about_axis(axis, np.pi)
            fixed, which = resolve_shape_flips(bad, S, s["points"], idx, cfg.priors)
            if category == "laptop_rigid":
                assert which[0] and rotation_angle_deg(fixed[0, :3, :3], T[0, :3, :3]) < 1e-4
                np.testing.assert_allclose(fixed[0, :3, 3], T[0, :3, 3])
            elif category == "bottle":
                assert not which.any() and np.allclose(fixed, bad)


def _turned_round(T, u, piv, b):
    """The whole object turned by a half turn about the cabinet's box axis ``b`` through its centre."""
    Rf = rotation_about_axis(T[0, :3, b], np.pi)
    c = T[0, :3, 3]
    T2 = T.copy()
    T2[:, :3, :3] = Rf @ T[:, :3, :3]
    T2[:, :3, 3] = c + (T[:, :3, 3] - c) @ Rf.T
    return T2, u @ Rf.T, c + (piv - c) @ Rf.T


def test_a_cabinet_turned_round_is_turned_back_by_its_drawers():
    """Real drawer views at their true poses and labels, the camera at the origin: nothing is turned. The whole
    object turned round about the cabinet's upright axis is turned back exactly wherever the drawers decide it:
    their points behind the cabinet's centre (views that show them), or a front facing the camera with no drawer
    on it (views from behind that hide them). Both kinds occur among the views."""

    S = samples("drawer", "test", 16)
    pri = measured_priors("drawer", S)
    assert pri.parts[0].upright_axis == 1
    kinds = {"shown": 0, "hidden": 0}
    for s in S:
        T, pts, lab = np.asarray(s["cam_from_part"]), np.asarray(s["points"], np.float64), np.asarray(s["part_labels"])
        u, piv = np.asarray(s["joint_axis"]), np.asarray(s["joint_pivot"])
        same, u2, piv2, flipped = resolve_front_flips(T, u, piv, pts, lab, pri)
        assert not flipped.any()
        np.testing.assert_array_equal(same, T)
        np.testing.assert_array_equal(u2, u)
        bad, ub, pb = _turned_round(T, u, piv, 1)
        fixed, uf, pf, flipped = resolve_front_flips(bad, ub, pb, pts, lab, pri)
        drawers = int(np.isin(lab, [1, 2, 3]).sum())
        if drawers >= 30:
            kinds["shown"] += 1
        cam = T[0, :3, :3].T @ -T[0, :3, 3]  # the camera in the true cabinet frame: behind it, within 45 degrees
        if drawers < 0.02 * len(lab) and -cam[2] > abs(cam[0]):
            kinds["hidden"] += 1
        elif drawers < 30:
            continue  # neither rule decides: a side view with the drawers hidden
        assert flipped.all()
        np.testing.assert_allclose(fixed, T, atol=1e-9)
        np.testing.assert_allclose(uf, u, atol=1e-9)
        np.testing.assert_allclose(pf, piv, atol=1e-9)
    assert kinds["shown"] >= 5 and kinds["hidden"] >= 1, kinds


def test_turning_round_leaves_side_views_doubted_points_and_revolute_joints_alone():
    """A chest (no upright prior: it turns about its stack's axis) seen from the front with its drawers' points
    on it is left alone; the same drawers behind its centre turn it round about y, and their joint axes and
    pivots with it. Drawers doubted by the segmentation do not count; a front seen from the side (60 degrees off
    its normal) is not taken as bare; a model with revolute joints only is never turned."""

    pri = chest()
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, 3] = [0.0, 0.0, 3.0]  # the camera 3 m in front... of the cabinet's -z face: R turns it round
    T[:, :3, :3] = np.diag([-1.0, 1.0, -1.0])  # the cabinet's +z (its front) towards the camera
    u, piv = np.tile([0.0, 0.0, -1.0], (3, 1)), np.zeros((3, 3))
    rng = np.random.default_rng(0)
    front = np.column_stack([rng.uniform(-0.3, 0.3, 300), rng.uniform(-0.5, 0.5, 300), np.full(300, 2.75)])
    body = np.column_stack([rng.uniform(-0.3, 0.3, 300), np.full(300, 0.5), rng.uniform(2.75, 3.25, 300)])
    lab = np.r_[np.zeros(300, int), rng.integers(1, 4, 300)]
    pts = np.r_[body, front]
    same, _, _, flipped = resolve_front_flips(T, u, piv, pts, lab, pri)
    assert not flipped.any() and np.array_equal(same, T)
    back = front.copy()
    back[:, 2] = 3.25  # the drawers' points behind the cabinet's centre
    out, u2, piv2, flipped = resolve_front_flips(T, u, piv + [0.0, 0.0, 3.1], np.r_[body, back], lab, pri)
    assert flipped.all()
    np.testing.assert_allclose(out[0, :3, :3], np.eye(3), atol=1e-12)  # turned about y
    np.testing.assert_allclose(u2, np.tile([0.0, 0.0, 1.0], (3, 1)), atol=1e-12)
    np.testing.assert_allclose(piv2, np.tile([0.0, 0.0, 2.9], (3, 1)), atol=1e-12)
    conf = np.r_[np.ones(300), np.full(300, 0.2)]  # the drawers' points doubted: the front looks bare
    assert resolve_front_flips(T, u, piv, np.r_[body, back], lab, pri, confidence=conf)[3].all()
    side = T.copy()
    side[:, :3, :3] = rotation_about_axis([0.0, 1.0, 0.0], np.radians(120.0))  # the front 60 degrees off the camera
    assert not resolve_front_flips(side, u, piv, body, np.zeros(300, int), pri)[3].any()
    assert resolve_front_flips(T, u, piv, body, np.zeros(300, int), pri)[3].all()  # faced and bare
    door = door_priors()
    Td = np.tile(np.eye(4), (2, 1, 1))
    Td[:, 2, 3] = 2.0
    out, *_, flipped = resolve_front_flips(Td, np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 3)), body, np.ones(300, int), door)
    assert not flipped.any() and np.array_equal(out, Td)


def test_turning_round_names_bad_input():
    pri = chest()
    T, S, _ = chest_scene(0)
    u, piv = np.tile([0.0, 0.0, 1.0], (3, 1)), np.zeros((3, 3))
    pts, lab = np.zeros((40, 3)), labels_of([10, 10, 10, 10])
    with pytest.raises(InputError, match="cam_from_part"):
        resolve_front_flips(T[:3], u, piv, pts, lab, pri)
    with pytest.raises(InputError, match="finite"):
        resolve_front_flips(T, u * np.nan, piv, pts, lab, pri)
    with pytest.raises(InputError, match="points"):
        resolve_front_flips(T, u, piv, pts[:, :2], lab, pri)
    with pytest.raises(InputError, match="labels"):
        resolve_front_flips(T, u, piv, pts, lab.astype(float), pri)
    with pytest.raises(InputError, match="camera"):
        resolve_front_flips(T, u, piv, pts, lab, pri, camera=(0.0, np.inf, 0.0))
    with pytest.raises(InputError, match="confidence"):
        resolve_front_flips(T, u, piv, pts, lab, pri, confidence=np.ones(3))
    with pytest.raises(InputError, match="min_share"):
        resolve_front_flips(T, u, piv, pts, lab, pri, min_share=1.5)
    with pytest.raises(InputError, match="max_deg"):
        resolve_front_flips(T, u, piv, pts, lab, pri, max_deg=120.0)
    with pytest.raises(InputError, match="min_confidence"):
        resolve_front_flips(T, u, piv, pts, lab, pri, min_confidence=2.0)
