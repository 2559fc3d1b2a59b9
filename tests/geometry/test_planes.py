"""ucope.geometry.planes: the floor / table plane under a segmented object (find_support_plane); the estimator's use
of it: tests/stages/test_cloud.py."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.geometry.planes import find_support_plane


def _cylinder(rng, n=1500, r=0.04, h=0.1, centre=(0.0, 0.0, 0.6)):
    """The camera-facing half of an upright cylinder (y down in the camera frame: the floor at y = +h/2)."""
    a = rng.uniform(-np.pi / 2, np.pi / 2, n) + np.pi  # the half towards the camera (-z)
    y = rng.uniform(-h / 2, h / 2, n)
    return np.c_[r * np.sin(a), y, r * np.cos(a)] + centre


def _floor(rng, n=800, centre=(0.0, 0.0, 0.6), y=0.05):
    """Floor points in a ring around the cylinder's base, camera side, as a mask lets them in."""
    rad = rng.uniform(0.045, 0.09, n)
    a = rng.uniform(-np.pi / 2, np.pi / 2, n) + np.pi
    return np.c_[rad * np.sin(a), np.full(n, y), rad * np.cos(a)] + centre


def test_a_floor_ring_under_an_object_is_found_and_only_it_removed():
    rng = np.random.default_rng(0)
    obj, floor = _cylinder(rng), _floor(rng)
    plane = find_support_plane(np.r_[obj, floor], seed=0)
    assert plane is not None
    assert np.dot(plane.normal, [0.0, -1.0, 0.0]) > 0.99  # towards the object: up, camera y down
    assert plane.removes(floor).mean() > 0.99
    base = obj[:, 1] > 0.05 - 2 * plane.threshold_m  # the cylinder's lowest millimetres touch the floor
    assert plane.removes(obj[~base]).sum() == 0


@pytest.mark.parametrize("what", ["cylinder", "plate_and_box"])
def test_no_plane_is_taken_from_the_object_itself(what):
    rng = np.random.default_rng(1)
    if what == "cylinder":  # a tangent strip holds many points, but lies inside the object's footprint
        pts = _cylinder(rng, n=3000, r=0.2)
    else:  # a large flat face with a smaller block standing in its middle: the face is the object's
        plate = np.c_[rng.uniform(-0.1, 0.1, 2000), np.full(2000, 0.02), rng.uniform(0.5, 0.7, 2000)]
        block = np.c_[rng.uniform(-0.09, 0.09, 1500), rng.uniform(-0.1, 0.02, 1500), rng.uniform(0.51, 0.69, 1500)]
        pts = np.r_[plate, block]
    assert find_support_plane(pts, seed=0) is None


def test_too_few_points_are_named():
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        find_support_plane(np.zeros((2, 3)))
