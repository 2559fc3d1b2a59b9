"""align_to_faces / align_parts_to_faces: against a plain reference (per-normal loops, weighted Kabsch by
SVD), and the contract (a box's faces bring a turned rotation back, one face fixes two angles, too few
normals, symmetric parts, prismatic followers, bad input)."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.transforms import make_transform, random_rotation
from ucope.stages.faces import align_parts_to_faces, align_to_faces, face_normals


def reference(R, normals, tol_deg, iterations, prior_weight, min_points):
    """Each normal matched to its nearest signed axis by a loop; the rotation by the SVD of the weighted
    cross-covariance (Kabsch), the last round's axes as three extra pairs."""
    R0 = np.array(R, float)
    R = R0.copy()
    for _ in range(iterations):
        pairs = []
        for n in normals:
            n = n / np.linalg.norm(n)
            local = R.T @ n
            a = int(np.argmax(np.abs(local)))
            if abs(local[a]) >= np.cos(np.radians(tol_deg)):
                e = np.zeros(3)
                e[a] = np.sign(local[a])
                pairs.append((n, e))
        if len(pairs) < min_points:
            return R0, len(pairs)
        H = sum(np.outer(n, e) for n, e in pairs) + prior_weight * len(pairs) * sum(
            np.outer(R[:, i], np.eye(3)[i]) for i in range(3)
        )
        U, _, Vt = np.linalg.svd(H)
        R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    return R, len(pairs)


def _turn(deg, axis):
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(np.radians(deg) * np.asarray(axis, float) / np.linalg.norm(axis)).as_matrix()


def _box_normals(R, rng, faces=(0, 1, 2), n=300, noise_deg=3.0, clutter=True):
    """Normals of ``faces`` (axis indices, the +side of each) of a box turned by ``R``, with noise, plus
    (``clutter``) a quarter of random ones (a lens, a handle, outliers)."""
    out = []
    for a in faces:
        e = np.zeros(3)
        e[a] = 1.0
        out.append(np.tile(e, (n, 1)) + rng.normal(size=(n, 3)) * np.radians(noise_deg))
    rand = rng.normal(size=(len(faces) * n // 4 if clutter else 0, 3))
    nrm = np.concatenate(out + [rand]) @ R.T
    return nrm * rng.choice([-1.0, 1.0], size=(len(nrm), 1))  # any sign


@pytest.mark.parametrize("seed", range(4))
def test_matches_the_plain_reference(seed):
    rng = np.random.default_rng(seed)
    R_true = random_rotation(rng)
    R_voted = _turn(rng.uniform(5, 15), rng.normal(size=3)) @ R_true
    nrm = _box_normals(R_true, rng, n=60) * rng.uniform(0.5, 2.0, (1, 1))  # any length
    for tol, it, w, m in [(20.0, 5, 0.1, 30), (10.0, 2, 0.0, 10), (30.0, 3, 1.0, 5), (20.0, 5, 0.1, 10_000)]:
        got, matched = align_to_faces(R_voted, nrm, tol, it, w, m)
        ref, ref_matched = reference(R_voted, nrm, tol, it, w, m)
        np.testing.assert_allclose(got, ref, atol=1e-9)
        assert matched == ref_matched


def test_a_turned_box_comes_back_to_its_faces():
    rng = np.random.default_rng(5)
    for _ in range(5):
        R_true = random_rotation(rng)
        R_voted = _turn(15.0, rng.normal(size=3)) @ R_true
        got, matched = align_to_faces(R_voted, _box_normals(R_true, rng))
        err = np.degrees(np.arccos(np.clip((np.trace(got.T @ R_true) - 1) / 2, -1, 1)))
        assert err < 1.5 and matched > 800


def test_one_face_fixes_two_angles_and_the_prior_keeps_the_third():
    """Normals of the +z face only: a tilt of z comes back; a turn about z (which no normal sees) stays."""
    rng = np.random.default_rng(6)
    R_true = random_rotation(rng)
    about_z = R_true @ _turn(12.0, [0, 0, 1]) @ R_true.T  # camera-frame turn about the part's z axis
    tilt = R_true @ _turn(8.0, [1, 0, 0]) @ R_true.T
    R_voted = tilt @ about_z @ R_true
    got, _ = align_to_faces(R_voted, _box_normals(R_true, rng, faces=(2,), noise_deg=1.0, clutter=False))
    np.testing.assert_allclose(got[:, 2], R_true[:, 2], atol=0.01)  # the face normal is right
    twist = np.degrees(np.arccos(np.clip(got[:, 0] @ R_true[:, 0], -1, 1)))
    assert 11.0 < twist < 13.0  # the turn about it is the voted one


def test_too_few_matching_normals_keep_the_voted_rotation():
    rng = np.random.default_rng(7)
    R = random_rotation(rng)
    nrm = _box_normals(R, rng, n=5)
    got, matched = align_to_faces(_turn(10, [1, 2, 3]) @ R, nrm, min_points=30)
    np.testing.assert_array_equal(got, _turn(10, [1, 2, 3]) @ R)
    assert matched < 30
    np.testing.assert_array_equal(align_to_faces(R, np.zeros((0, 3)))[0], R)


def test_parts_symmetric_parts_and_followers():
    rng = np.random.default_rng(8)
    R_true = [random_rotation(rng) for _ in range(3)]
    R_voted = [_turn(10.0, rng.normal(size=3)) @ r for r in R_true]
    T = np.stack([make_transform(r, rng.normal(size=3)) for r in R_voted])
    nrm = np.concatenate([_box_normals(r, rng, n=100) for r in R_true])
    part_points = np.array_split(np.arange(len(nrm)), 3)
    got, turned = align_parts_to_faces(T, nrm, part_points, ["none", "y", "none"], follow=[(2, 0)])
    assert turned.tolist() == [True, False, True]
    np.testing.assert_array_equal(got[:, :3, 3], T[:, :3, 3])  # translations kept
    np.testing.assert_array_equal(got[1], T[1])  # symmetric about y: left alone
    alone, _ = align_to_faces(T[0, :3, :3], nrm[part_points[0]])
    np.testing.assert_allclose(got[0, :3, :3], alone)
    # the follower took part 0's turn, not one of its own: their relative rotation is the voted one
    np.testing.assert_allclose(got[0, :3, :3].T @ got[2, :3, :3], T[0, :3, :3].T @ T[2, :3, :3], atol=1e-12)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(cam_from_part_rot=np.eye(3)[:2]),
        dict(cam_from_part_rot=2 * np.eye(3)),
        dict(cam_from_part_rot=np.diag([1.0, 1.0, -1.0])),
        dict(normals=np.ones((4, 2))),
        dict(normals=np.full((4, 3), np.nan)),
        dict(tolerance_deg=0.0),
        dict(tolerance_deg=60.0),
        dict(iterations=0),
        dict(min_points=0),
        dict(prior_weight=-1.0),
    ],
)
def test_bad_input_is_named(kwargs):
    args = dict(cam_from_part_rot=np.eye(3), normals=np.ones((4, 3)))
    args.update(kwargs)
    with pytest.raises(InputError):
        align_to_faces(**args)


def test_bad_part_input_is_named():
    T = np.stack([np.eye(4)] * 2)
    nrm = np.ones((4, 3))
    with pytest.raises(InputError, match="K, 4, 4"):
        align_parts_to_faces(T[0], nrm, [[0], [1]], ["none", "none"])
    with pytest.raises(InputError, match="one entry per part"):
        align_parts_to_faces(T, nrm, [[0]], ["none", "none"])
    for follow in ([(1, 1)], [(2, 0)], [(1, 0), (1, 0)]):
        with pytest.raises(InputError, match="follow"):
            align_parts_to_faces(T, nrm, [[0], [1]], ["none", "none"], follow=follow)


def test_a_chain_of_followers_turns_as_one():
    """Every part following its parent (the tree after the refinement): the whole object takes the root's
    turn, so every relative rotation is kept."""
    rng = np.random.default_rng(9)
    R_true = random_rotation(rng)
    T = np.stack([make_transform(_turn(8.0, rng.normal(size=3)) @ R_true, rng.normal(size=3)) for _ in range(3)])
    T[1:, :3, :3] = [random_rotation(rng) for _ in range(2)]
    nrm = _box_normals(R_true, rng, n=100)
    got, turned = align_parts_to_faces(T, nrm, [np.arange(len(nrm)), [], []], ["none"] * 3, follow=[(1, 0), (2, 1)])
    assert turned.all()
    for k in (1, 2):
        np.testing.assert_allclose(got[k - 1, :3, :3].T @ got[k, :3, :3], T[k - 1, :3, :3].T @ T[k, :3, :3], atol=1e-12)


def test_face_normals_count_each_point_once():
    """A sparse cloud repeated up to the network's count gets the normals of its distinct points (a
    neighbourhood of copies has none), over the same share of them (16 of 1,024 -> at least 6), and a
    plane's normals are its normal."""
    rng = np.random.default_rng(10)
    R = random_rotation(rng)
    plane = np.c_[rng.uniform(-0.1, 0.1, (100, 2)), rng.normal(0.0, 1e-4, 100)] @ R.T + [0, 0, 1.0]
    idx = np.concatenate([np.arange(100), rng.integers(0, 100, 924)])
    got = face_normals(plane[idx])
    np.testing.assert_allclose(got, face_normals(plane, k=6)[idx], atol=1e-12)
    np.testing.assert_allclose(np.abs(got @ R[:, 2]), 1.0, atol=0.01)
    with pytest.raises(InputError):
        face_normals(np.ones((5, 2)))
