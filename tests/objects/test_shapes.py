"""The mesh kit (ucope.objects.shapes): extents, closedness and outward orientation of every primitive."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from ucope.objects import shapes


def _closed_outward(m: trimesh.Trimesh) -> tuple[bool, float]:
    """(every edge shared by exactly two faces in opposite directions, signed volume), with vertices at
    the same position merged (revolved profiles repeat their points on the axis)."""
    uniq, ids = np.unique(np.round(np.asarray(m.vertices), 9), axis=0, return_inverse=True)
    f = ids.reshape(-1)[np.asarray(m.faces)]
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    fwd = {tuple(x) for x in e.tolist()}
    ok = len(fwd) == len(e) and all((b, a) in fwd for a, b in fwd)
    v = uniq[f]
    vol = float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)
    return ok, vol


PRIMITIVES = {
    "box": lambda: shapes.box((0.1, 0.2, 0.3), (1.0, 0.0, 0.0)),
    "boxes": lambda: shapes.boxes([[0, 0, 0], [1, 0, 0]], [0.1, 0.2, 0.3]),
    "cylinder": lambda: shapes.cylinder(0.05, 0.2, axis=(1.0, 1.0, 0.0)),
    "disc": lambda: shapes.disc(0.05, 0.02, (0.0, 0.1, 0.0), "x"),
    "extrude_xz": lambda: shapes.extrude(shapes.rounded_rect(0.2, 0.1, 0.02), 0.01, plane="xz"),
    "extrude_cw": lambda: shapes.extrude(shapes.rounded_rect(0.2, 0.1, 0.02)[::-1], 0.01, plane="yz"),
    "rounded_slab_y": lambda: shapes.rounded_slab((0.3, 0.02, 0.2), 0.01, axis="y"),
    "revolve_closed": lambda: shapes.revolve_profile(np.array([[0.05, 0.0], [0.06, 0.0], [0.06, 0.1], [0.05, 0.1]]), 32),
    "revolve_open": lambda: shapes.revolve_profile(
        np.array([[0.0, 0.0], [0.05, 0.0], [0.05, 0.1], [0.0, 0.1]]), 32, closed=False
    ),
    "rod": lambda: shapes.rod((0, 0, 0), (0.1, 0.2, 0.0), 0.01),
    "sweep_open": lambda: shapes.sweep_planar(np.c_[np.linspace(0, 0.1, 9), np.zeros(9), np.zeros(9)], (0, 1, 0), 0.004, 0.002),
    "sweep_ring": lambda: shapes.sweep_planar(
        np.c_[shapes.superellipse(0.05, 0.03, 2.0, 40), np.zeros(40)], (0, 0, 1), 0.002, 0.003, closed=True
    ),
}


@pytest.mark.parametrize("name", list(PRIMITIVES))
def test_primitives_are_closed_and_outward(name):
    m = PRIMITIVES[name]()
    ok, vol = _closed_outward(m)
    assert ok, name
    assert vol > 0, (name, vol)


def test_box_extents_and_layout():
    m = shapes.boxes([[0.0, 1.0, 2.0]], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(m.bounds, [[-0.05, 0.9, 1.85], [0.05, 1.1, 2.15]])
    one = shapes.box((0.1, 0.2, 0.3), (0.0, 1.0, 2.0))
    np.testing.assert_allclose(one.bounds, m.bounds)
    np.testing.assert_allclose(_closed_outward(m)[1], 0.1 * 0.2 * 0.3)


def test_open_box_leaves_one_side_open():
    m = shapes.open_box((0.4, 0.3, 0.2), 0.01, open_side="+z", shelves_y=(0.0,))
    np.testing.assert_allclose(m.extents, [0.4, 0.3, 0.2])
    assert len(m.faces) == 12 * 6  # five walls and one shelf


def test_revolve_profile_sections_keep_x_and_z_extents_equal():
    m = shapes.revolve_profile(np.array([[0.0, 0.0], [0.05, 0.0], [0.05, 0.1], [0.0, 0.1]]), 48, closed=False)
    np.testing.assert_allclose(m.extents, [0.1, 0.1, 0.1])
    area2 = np.linalg.norm(
        np.cross(
            *(np.asarray(m.vertices)[np.asarray(m.faces)][:, 1:] - np.asarray(m.vertices)[np.asarray(m.faces)][:, :1]).transpose(
                1, 0, 2
            )
        ),
        axis=1,
    )
    assert area2.min() > 1e-14  # the degenerate triangles at the axis are dropped


def test_outlines():
    rr = shapes.rounded_rect(0.2, 0.1, 0.02, 5, center=(1.0, 2.0))
    assert rr.shape == (20, 2)
    np.testing.assert_allclose([rr[:, 0].min(), rr[:, 0].max(), rr[:, 1].min(), rr[:, 1].max()], [0.9, 1.1, 1.95, 2.05])
    area2 = np.sum(rr[:, 0] * np.roll(rr[:, 1], -1) - np.roll(rr[:, 0], -1) * rr[:, 1])
    assert area2 > 0  # counter-clockwise
    se = shapes.superellipse(0.03, 0.02, 2.0, 64)
    np.testing.assert_allclose((se[:, 0] / 0.03) ** 2 + (se[:, 1] / 0.02) ** 2, 1.0)
    half = shapes.clip_convex(rr, 0, 1.0, "below")
    assert half[:, 0].max() <= 1.0 + 1e-12 and half[:, 0].min() == pytest.approx(0.9)
    line = np.array([[0.0, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(shapes.offset_curve(line, 0.1), [[-0.1, 0.0], [-0.1, 1.0]])  # to the left
    np.testing.assert_allclose(shapes.curve_x_at(se, 0.0, 0.0, +1), 0.03)
    hull = shapes.convex_outline(np.concatenate([se, se * 0.5 + [0.0, -0.03]]), 40)
    assert hull.shape == (40, 2) and hull[:, 1].min() == pytest.approx(-0.04, abs=1e-3)
    d = np.diff(np.concatenate([hull, hull[:1]]), axis=0)
    assert np.all(d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1) >= -1e-12)  # convex, counter-clockwise
    a = shapes.arc((0.0, 0.0), 1.0, 0.0, np.pi / 2, 3)
    np.testing.assert_allclose(a, [[1, 0], [np.sqrt(0.5), np.sqrt(0.5)], [0, 1]], atol=1e-12)
