"""ucope.stages.support: the helpers the stages share: connected pieces of a cloud against a plain flood fill, and
the weak side of each revolute joint."""

import numpy as np
from stages_support import door_priors

from ucope.priors import CategoryPriors, JointPrior
from ucope.stages.support import connected_pieces, weak_neighbours


def _plain_pieces(points, factor):
    """Plain reference: the full distance matrix, the median nearest-neighbour distance, and a flood fill."""
    d = np.linalg.norm(points[:, None] - points[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    radius = factor * np.median(d.min(1))
    joined = d <= radius
    piece = np.full(len(points), -1)
    for start in range(len(points)):
        if piece[start] >= 0:
            continue
        piece[start] = start
        todo = [start]
        while todo:
            i = todo.pop()
            for j in np.flatnonzero(joined[i] & (piece < 0)):
                piece[j] = start
                todo.append(j)
    return piece


def test_connected_pieces_match_a_plain_flood_fill():
    """Clusters of points at random gaps, some closer than the radius, some further: the same partition as a
    flood fill over the full distance matrix; duplicates and single points too."""
    rng = np.random.default_rng(0)
    for _ in range(5):
        centres = rng.uniform(-1, 1, size=(6, 3))
        pts = np.concatenate([c + rng.normal(scale=0.03, size=(rng.integers(5, 60), 3)) for c in centres])
        for factor in (2.0, 8.0):
            got, ref = connected_pieces(pts, factor), _plain_pieces(pts, factor)
            pairs = got[:, None] == got[None]
            np.testing.assert_array_equal(pairs, ref[:, None] == ref[None])
    assert connected_pieces(np.zeros((1, 3)), 8.0).tolist() == [0]
    assert len(set(connected_pieces(np.zeros((5, 3)), 8.0).tolist())) == 1  # duplicates are one piece


def test_weak_neighbours_names_the_barely_seen_side_of_each_revolute_joint():
    """The parts seat_weak_parts and place_weak_parts may move: the weak side of a revolute joint next to a strong
    one (a leaf child, or the root of a two-part object); background labels do not count; prismatic joints never."""

    pri = door_priors()
    assert weak_neighbours(np.repeat([0, 1, -1], [3000, 60, 9000]), pri, 0.125, 0.25) == [(0, 1, 0)]
    assert weak_neighbours(np.repeat([0, 1], [40, 3000]), pri, 0.125, 0.25) == [(0, 0, 1)]
    assert weak_neighbours(np.repeat([0, 1], [2400, 600]), pri, 0.125, 0.25) == []
    slide = CategoryPriors(category="slide", parts=pri.parts, joints=(JointPrior("prismatic", 0, 1, (0, 0, 1)),))
    assert weak_neighbours(np.repeat([0, 1], [3000, 60]), slide, 0.125, 0.25) == []
