import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.normals import estimate_normals
from ucope.geometry.sampling import farthest_point_sampling, random_subset


def _naive_fps(points, m, start=0):
    idx = [start]
    d = np.full(len(points), np.inf)
    for _ in range(m - 1):
        d = np.minimum(d, ((points - points[idx[-1]]) ** 2).sum(1))
        idx.append(int(d.argmax()))
    return np.array(idx)


def test_fps_matches_plain_reference_and_batches(rng):
    pts = rng.normal(size=(3, 500, 3)).astype(np.float32)
    out = farthest_point_sampling(pts, 40, start=np.array([0, 5, 9]))
    assert out.shape == (3, 40)
    for b, s in enumerate([0, 5, 9]):
        np.testing.assert_array_equal(out[b], _naive_fps(pts[b], 40, s))
    assert len(np.unique(out[0])) == 40
    # One cloud takes its own (scalar-indexed) path: the same samples as in the batch.
    for b, s in enumerate([0, 5, 9]):
        np.testing.assert_array_equal(farthest_point_sampling(pts[b], 40, start=s), out[b])


def test_fps_spreads_points(rng):
    pts = rng.uniform(size=(2000, 3))
    fps = pts[farthest_point_sampling(pts, 64)]
    rnd = pts[:64]

    def min_gap(p):
        d = np.linalg.norm(p[:, None] - p[None], axis=-1) + np.eye(len(p)) * 9
        return d.min()

    assert min_gap(fps) > 2 * min_gap(rnd)


def test_fps_bad_input():
    with pytest.raises(InputError):
        farthest_point_sampling(np.zeros((10, 2)), 3)
    with pytest.raises(InputError):
        farthest_point_sampling(np.zeros((10, 3)), 11)


def test_random_subset_pads_and_is_seeded():
    a = random_subset(10, 25, np.random.default_rng(0))
    assert len(a) == 25 and set(a.tolist()) == set(range(10))
    np.testing.assert_array_equal(
        random_subset(100, 10, np.random.default_rng(3)), random_subset(100, 10, np.random.default_rng(3))
    )


def test_normals_of_a_plane_face_the_camera(rng):
    xy = rng.uniform(-0.2, 0.2, size=(800, 2))
    n_true = np.array([0.3, -0.2, -1.0])
    n_true /= np.linalg.norm(n_true)
    # plane through (0, 0, 1) with normal n_true, seen from the origin
    z = 1.0 - (n_true[0] * xy[:, 0] + n_true[1] * xy[:, 1]) / n_true[2]
    pts = np.c_[xy, z]
    n = estimate_normals(pts, k=12)
    assert np.all(n @ n_true > 0.999)
    assert np.all((n * (-pts)).sum(1) > 0)  # oriented towards the camera at the origin
    rows = rng.choice(len(pts), 100, replace=False)  # some rows only: the same normals as in the full result
    np.testing.assert_array_equal(estimate_normals(pts, k=12, rows=rows), n[rows])


def test_normals_of_a_sphere(rng):
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pts = d * 0.1 + [0, 0, 1.0]
    n = estimate_normals(pts, k=16, viewpoint=None)
    assert np.median(np.abs((n * d).sum(1))) > 0.995


def test_normals_bad_input():
    with pytest.raises(InputError, match="at least 3"):
        estimate_normals(np.zeros((2, 3)))
    with pytest.raises(InputError, match="NaN"):
        estimate_normals(np.array([[0, 0, np.nan]] * 5))
    with pytest.raises(InputError, match="shape"):
        estimate_normals(np.zeros((5, 2)))


def test_smallest_eigenvectors_sym3_matches_eigh(rng):
    from ucope.geometry.normals import smallest_eigenvectors_sym3

    x = rng.normal(size=(3000, 16, 3)) * rng.uniform(1e-3, 1.0, size=(3000, 1, 3))
    x = x @ np.linalg.qr(rng.normal(size=(3000, 3, 3)))[0]
    cov = x.transpose(0, 2, 1) @ x
    # Degenerate batches: collinear points (two zero eigenvalues), isotropic, all-zero.
    line = np.outer(np.linspace(-1, 1, 16), [0.3, -0.5, 0.8])
    cov = np.concatenate([cov, (line.T @ line)[None], np.eye(3)[None], np.zeros((1, 3, 3))])
    vec = smallest_eigenvectors_sym3(cov)
    np.testing.assert_allclose(np.linalg.norm(vec, axis=1), 1.0, atol=1e-9)
    # Each result is an eigenvector of the smallest eigenvalue (the residual measures that even where
    # the eigenvector is not unique).
    lam = np.linalg.eigvalsh(cov)[:, 0]
    resid = np.linalg.norm(np.einsum("nij,nj->ni", cov, vec) - lam[:, None] * vec, axis=1)
    assert resid.max() < 1e-8 * max(1.0, np.abs(cov).max())
    ref = np.linalg.eigh(cov[:3000])[1][:, :, 0]
    assert (1 - np.abs((vec[:3000] * ref).sum(1))).max() < 1e-9
