"""ucope.stages.exposure: exposed_surface_share against a plain per-sample reference, and slide_weak_children's
contract on a cabinet seen from the side and from behind."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.kinematics import joint_state_from_poses
from ucope.geometry.transforms import make_transform, random_rotation
from ucope.priors import CategoryPriors, JointPrior, PartPrior
from ucope.stages.exposure import exposed_surface_share, slide_weak_children
from ucope.stages.freespace import FreeSpaceParams
from ucope.vocab import JointType

P = FreeSpaceParams()


def exposed_reference(T, S, pts, camera, grid=P.face_grid, ray_radius=P.ray_radius, depth_tol=P.depth_tol, k=P.ray_neighbours):
    """One box at a time, one face sample at a time: the plain version of exposed_surface_share."""
    rel = np.asarray(pts) - camera
    uv = rel[:, :2] / rel[:, 2:3]
    d = np.linalg.norm(uv[:, None] - uv[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    r = ray_radius * np.median(d.min(1))
    a = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
    bad = facing = 0
    for ax in range(3):
        o1, o2 = [i for i in range(3) if i != ax]
        for sgn in (-1.0, 1.0):
            normal = T[:3, :3] @ (np.eye(3)[ax] * sgn)
            for x in a:
                for y in a:
                    f = np.zeros(3)
                    f[ax], f[o1], f[o2] = sgn, x, y
                    q = T[:3, :3] @ (f * S / 2) + T[:3, 3]
                    if normal @ (camera - q) <= 0:
                        continue
                    facing += 1
                    v = q - camera
                    dd = np.linalg.norm(uv - v[:2] / v[2], axis=1)
                    near = np.argsort(dd)[:k]
                    near = near[dd[near] <= r]
                    seen = rel[near, 2].min() if len(near) else np.inf
                    bad += seen > v[2] + depth_tol * np.linalg.norm(S)
    return bad / max(facing, 1)


def test_exposed_surface_share_matches_the_plain_reference():
    rng = np.random.default_rng(4)
    pts = rng.uniform([-0.4, -0.3, 1.5], [0.4, 0.3, 2.5], (300, 3))  # a slab of seen surfaces
    cam = np.array([0.05, -0.02, 0.1])
    T = np.stack([make_transform(random_rotation(rng), rng.uniform([-0.5, -0.4, 1.2], [0.5, 0.4, 2.8])) for _ in range(6)])
    S = rng.uniform(0.1, 0.6, (6, 3))
    got = exposed_surface_share(T, S, pts, camera=cam)
    want = [exposed_reference(T[b], S[b], pts, cam) for b in range(6)]
    np.testing.assert_allclose(got, want, atol=1e-12)
    assert (got > 0).any() and (got < 1).any()
    # a box far outside the silhouette is all exposed; one behind the slab all hidden; one in front of it, in free space
    far = make_transform(np.eye(3), [3.0, 0.0, 2.0])
    behind = make_transform(np.eye(3), [0.0, 0.0, 3.5])
    before = make_transform(np.eye(3), [0.0, 0.0, 1.0])
    np.testing.assert_allclose(exposed_surface_share(np.stack([far, behind, before]), [0.1, 0.1, 0.1], pts), [1.0, 0.0, 1.0])


def _cabinet(view: str, n: int = 4000, seed: int = 0):
    """A cabinet (0.6 wide, 0.8 tall, 0.5 deep; its front +z, its up +y) 2 m ahead of the camera and 0.6 m below
    it, with one drawer (0.55 x 0.2 x 0.45, 0.05 m under its top) on a slide along the cabinet's +z, at state 0
    when its front is 5 mm behind the cabinet's. ``view``: "back" (its front faces away from the camera) or
    "side" (its front faces the camera's +x). The cloud: the cabinet's box as a depth camera sees it (rays on a
    regular pixel grid, ``n`` of the hits kept at random); the drawer shows none."""
    rng = np.random.default_rng(seed)
    if view == "back":
        R = np.diag([-1.0, -1.0, 1.0])
    else:
        R = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])  # columns: the cabinet's x, y, z in the camera
    t = np.array([0.0, 0.6, 2.0])
    Sc, Sd = np.array([0.6, 0.8, 0.5]), np.array([0.55, 0.2, 0.45])
    cab = make_transform(R, t)
    u, v = np.meshgrid(np.arange(-0.4, 0.4, 0.003), np.arange(-0.2, 0.8, 0.003))
    rays = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], 1) @ R  # in the cabinet's frame
    o = -t @ R
    with np.errstate(divide="ignore"):
        t1, t2 = (-Sc / 2 - o) / rays, (Sc / 2 - o) / rays
    near, far = np.minimum(t1, t2).max(1), np.maximum(t1, t2).min(1)
    hit = near < far
    pts = rays[hit] * near[hit, None] @ R.T
    pts = pts[rng.choice(len(pts), n, replace=False)]
    priors = CategoryPriors(
        category="chest",
        parts=(PartPrior("cabinet", "none", 0.6, tuple(Sc)), PartPrior("drawer", "none", 0.4, tuple(Sd))),
        joints=(
            JointPrior(
                JointType.PRISMATIC, 0, 1, (0.0, 0.0, 1.0), limits=(0.0, 0.6), zero_offset_m=-0.005, max_state_over_extent=0.75
            ),
        ),
    )
    axis = R[:, 2]

    def drawer_at(state):
        return make_transform(R, t + R @ np.array([0.0, 0.4 - 0.05 - 0.1, 0.25 - 0.005 - 0.225 + state]))

    return cab, drawer_at, np.stack([Sc, Sd]), axis, pts, priors


SLACK_M = 0.1
"""How far out of closed the side view's drawer may be left: the box checked is the drawer's shrunk to ``slide_shrink`` of
its 0.45 m depth (3.4 cm each side), a ray counts as seen within ``ray_radius`` point spacings of a seen one (about 3 cm at
2 m here), and the states are 1 cm apart."""


def _state(T, S, axis, priors):
    return joint_state_from_poses(T[0], T[1], axis, "prismatic", S[0], S[1], priors.joints[0].zero_offset_m)


def test_a_hidden_drawer_voted_where_the_camera_would_have_seen_it_is_slid_back():
    """Seen from the side, a drawer pulled out 0.3 m would stand beside the cabinet where the camera saw nothing:
    it is slid back to where the cabinet hides it: within :data:`SLACK_M` of closed. Voted closed, it stays."""
    cab, drawer_at, S, axis, pts, priors = _cabinet("side")
    labels = np.zeros(len(pts), dtype=np.int64)
    voted = np.stack([cab, drawer_at(0.3)])
    assert exposed_surface_share(voted[1:], P.slide_shrink * S[1], pts)[0] > 0.2  # the precondition
    out, moved = slide_weak_children(voted, S, axis[None], pts, labels, priors)
    q = _state(out, S, axis, priors)
    assert 0.0 <= q <= SLACK_M and moved[1] == pytest.approx(q - 0.3) and moved[0] == 0.0
    np.testing.assert_array_equal(out[0], voted[0])
    np.testing.assert_allclose(out[1, :3, :3], voted[1, :3, :3])
    closed = np.stack([cab, drawer_at(0.0)])
    out, moved = slide_weak_children(closed, S, axis[None], pts, labels, priors)
    assert not moved.any() and np.array_equal(out, closed)


def test_a_drawer_the_view_hides_at_every_state_keeps_its_voted_state():
    """From behind, the cabinet hides the drawer wherever it stands: the slide is not observed, nothing moves. A
    drawer that shows points (``min_points`` of them) is left alone, and so is a revolute joint."""
    cab, drawer_at, S, axis, pts, priors = _cabinet("back")
    labels = np.zeros(len(pts), dtype=np.int64)
    for state in (0.0, 0.2, 0.33):
        voted = np.stack([cab, drawer_at(state)])
        assert exposed_surface_share(voted[1:], P.slide_shrink * S[1], pts)[0] < 0.05  # a stray sample between rays
        out, moved = slide_weak_children(voted, S, axis[None], pts, labels, priors)
        assert not moved.any() and np.array_equal(out, voted)
    cab, drawer_at, S, axis, pts, priors = _cabinet("side")
    voted = np.stack([cab, drawer_at(0.3)])
    seen = np.zeros(len(pts), dtype=np.int64)
    seen[: P.slide_min_points] = 1  # ten points given to the drawer: it counts as seen
    _, moved = slide_weak_children(voted, S, axis[None], pts, seen, priors)
    assert not moved.any()
    rev = CategoryPriors(category="hinge", parts=priors.parts, joints=(JointPrior(JointType.REVOLUTE, 0, 1, (1.0, 0.0, 0.0)),))
    _, moved = slide_weak_children(voted, S, axis[None], pts, np.zeros(len(pts), dtype=np.int64), rev)
    assert not moved.any()


def test_the_slide_range_follows_the_measured_share_of_the_drawer_depth():
    """The states tried end at the least of the upper limit and the drawer's depth times max_state_over_extent
    (0.75 where it is not measured): with a share of 0.1 the side view's drawer can only come back to 0-0.045 m,
    and with an upper limit of 0.02 m to 0-0.02 m."""
    from dataclasses import replace

    cab, drawer_at, S, axis, pts, priors = _cabinet("side")
    labels = np.zeros(len(pts), dtype=np.int64)
    voted = np.stack([cab, drawer_at(0.3)])
    for jp, top in (
        (replace(priors.joints[0], max_state_over_extent=0.1), 0.045),
        (replace(priors.joints[0], limits=(0.0, 0.02)), 0.02),
    ):
        out, _ = slide_weak_children(voted, S, axis[None], pts, labels, replace(priors, joints=(jp,)))
        assert 0.0 <= _state(out, S, axis, priors) <= top + 1e-9
    # neither measured nor limited above: the range ends at ``slide_extent_share`` of the depth
    unmeasured = replace(priors, joints=(replace(priors.joints[0], max_state_over_extent=None, limits=(0.0, None)),))
    out, _ = slide_weak_children(voted, S, axis[None], pts, labels, unmeasured)
    assert 0.0 <= _state(out, S, axis, priors) <= SLACK_M


def test_slides_with_a_camera_off_the_origin_and_bad_input():
    cab, drawer_at, S, axis, pts, priors = _cabinet("side")
    labels = np.zeros(len(pts), dtype=np.int64)
    voted = np.stack([cab, drawer_at(0.3)])
    want, want_moved = slide_weak_children(voted, S, axis[None], pts, labels, priors)
    c = np.array([0.2, -0.1, 0.3])
    moved_scene = voted.copy()
    moved_scene[:, :3, 3] += c
    got, got_moved = slide_weak_children(moved_scene, S, axis[None], pts + c, labels, priors, camera=c)
    np.testing.assert_allclose(got_moved, want_moved, atol=1e-12)
    np.testing.assert_allclose(got[:, :3, 3] - c, want[:, :3, 3], atol=1e-9)
    args = (voted, S, axis[None], pts, labels, priors)
    with pytest.raises(InputError, match="shapes"):
        slide_weak_children(voted[:1], *args[1:])
    with pytest.raises(InputError, match="labels"):
        slide_weak_children(*args[:4], labels.astype(float), priors)
    with pytest.raises(InputError, match="finite"):
        slide_weak_children(voted, S, axis[None], np.full_like(pts, np.nan), labels, priors)
    with pytest.raises(InputError, match="positive"):
        slide_weak_children(voted, -S, axis[None], pts, labels, priors)
    with pytest.raises(InputError, match="shrink"):
        slide_weak_children(*args, shrink=0.0)
    with pytest.raises(InputError, match="steps"):
        slide_weak_children(*args, steps=1)
    with pytest.raises(InputError, match="camera"):
        slide_weak_children(*args, camera=[0.0, np.nan, 0.0])
    with pytest.raises(InputError, match="in front of the camera"):
        exposed_surface_share(voted, S, pts - [0.0, 0.0, 5.0])
    # points behind the camera (a cloud grown about its centre past it) hide nothing: ignored; none in front, no move
    behind = np.concatenate([pts, pts[:50] * [1.0, 1.0, -1.0]])
    np.testing.assert_array_equal(exposed_surface_share(voted, S, behind), exposed_surface_share(voted, S, pts))
    out, moved = slide_weak_children(voted, S, axis[None], pts - [0.0, 0.0, 5.0], labels, priors)
    assert not moved.any() and np.array_equal(out, voted)
    with pytest.raises(InputError, match="grid"):
        exposed_surface_share(voted, S, pts, grid=1)
