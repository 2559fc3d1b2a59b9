"""Scene dressing of rendered views: a distractor object standing right next to the object in the image.

A real segmentation mask bleeds onto whatever touches the object's silhouette: the floor, and often a
neighbouring object. :func:`add_adjacent_distractor` puts such a neighbour into a rendered view (the
robustness benchmark's mask-bleed corruption and the training data's background pools both use it).
Frames: the object frame is y up with the floor at the lowest point of the parts' boxes; the view's
``cam_from_object`` maps it to the camera frame (OpenCV axes), metres.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..render.noise import depth_to_mm
from ..render.raycast import CLUTTER_LABEL, raycast_depth

__all__ = ["add_adjacent_distractor", "object_bounds", "LATERAL_STEPS", "BEHIND_STEPS"]


def object_bounds(view, size_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners, in the object frame, of the box around every part's amodal box."""
    object_from_part = np.linalg.inv(view.cam_from_object)[None] @ view.cam_from_part
    signs = np.array([[(i >> 2) & 1, (i >> 1) & 1, i & 1] for i in range(8)], np.float64) * 2.0 - 1.0
    corners = 0.5 * signs[None] * np.asarray(size_m)[:, None, :]
    c = np.einsum("kij,knj->kni", object_from_part[:, :3, :3], corners) + object_from_part[:, None, :3, 3]
    return c.reshape(-1, 3).min(0), c.reshape(-1, 3).max(0)


LATERAL_STEPS = (1.0, 0.8, 0.6, 0.4, 0.2, 0.0)
BEHIND_STEPS = (1.0, 0.75, 0.5, 0.25, 0.0)


def _distractor_placements(rng, centre, lo, ext, right, back, side, points_obj):
    """One draw of the distractor (object frame) behind the object's ``side``: its meshes at the
    placements of add_adjacent_distractor, in the order tried, skipping those whose footprint holds an
    object point."""
    import trimesh

    radius = 0.5 * float(np.hypot(ext[0], ext[2]))
    w = radius * rng.uniform(0.3, 0.6)
    h = max(ext[1], radius) * rng.uniform(0.6, 1.2)
    yaw = rng.uniform(0.0, np.pi)
    is_box = bool(rng.random() < 0.5)
    gap = radius * rng.uniform(0.0, 0.1)
    along = rng.uniform(0.0, 0.8)
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    def half_obj(u):  # the object's box half-extent along the floor direction u
        return 0.5 * float(ext[0] * abs(u[0]) + ext[2] * abs(u[2]))

    def half_dis(u):
        return w if not is_box else w * float(abs(R[:, 0] @ u) + abs(R[:, 2] @ u))

    lateral = half_obj(right) + half_dis(right) * along
    for b in BEHIND_STEPS:
        behind = b * half_obj(back) + half_dis(back) + gap
        for t in LATERAL_STEPS:
            pos = centre + side * t * lateral * right + behind * back
            pos[1] = lo[1] + 0.5 * h
            local = (points_obj - pos) @ R  # the distractor's axes
            margin = 0.002 + w
            if is_box:
                inside = (np.abs(local[:, 0]) < margin) & (np.abs(local[:, 2]) < margin)
            else:
                inside = np.hypot(local[:, 0], local[:, 2]) < margin
            if b < 1.0 and np.any(inside):  # the first row never reaches the object's box
                continue
            T = np.eye(4)
            T[:3, 3] = pos
            if is_box:
                T[:3, :3] = R
                yield trimesh.creation.box(extents=(2 * w, h, 2 * w), transform=T), "box", t, b
            else:
                T[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]  # the cylinder's z axis along y
                yield trimesh.creation.cylinder(radius=w, height=h, sections=24, transform=T), "cylinder", t, b


def add_adjacent_distractor(view, size_m: np.ndarray, points: np.ndarray, camera, rng: np.random.Generator, tries: int = 3):
    """A copy of ``view`` with one more distractor (a box or a cylinder) standing on the floor just behind
    the object, to one side, so that in the image it touches the object's silhouette (partly hidden by
    it): a bleeding mask reaches it first.

    Object frame (y up, the floor at the lowest point of the parts' boxes), directions on the floor:
    ``back`` (the camera's viewing direction) and ``right`` (the camera's x axis). A draw: footprint
    half-width ``w`` = 30-60 % of the object's footprint radius, height 60-120 % of the object's height (at
    least that radius), a box at a random yaw or a cylinder, the left or the right side. Its centre lies
    ``b`` times the object box's half-extent along ``back`` plus its own plus a gap (0-10 % of the radius)
    behind the object's centre, and ``t`` times (the object box's half-width plus 0-80 % of its own) to the
    side. Placements are tried in turn, ``b`` = 1, 0.75, ..., 0 (outer loop; ``b = 1`` never meets the
    object's box; below 1 a placement whose footprint, widened by 2 mm, holds a point of the object's
    cloud is skipped) and ``t`` = 1, 0.8, ..., 0 (inner loop), until the distractor's visible pixels touch
    the silhouette (8-neighbourhood). Each is ray cast alone and composited by depth into the non-object
    pixels (object pixels are kept; ``overlap_px`` counts those where it would have been in front). Up to
    ``tries`` draws; the last placement is kept in any case (``touching`` says whether it touches).

    Args:
        view: the rendered view; size_m: ``(K, 3)`` the parts' box extents; points: ``(N, 3)`` the object's
            cloud, camera frame.

    Returns:
        ``(new view, info dict)``.
    """
    from scipy.ndimage import binary_dilation

    K = len(view.cam_from_part)
    lo, hi = object_bounds(view, size_m)
    centre, ext = 0.5 * (lo + hi), hi - lo
    object_from_cam = np.linalg.inv(view.cam_from_object)
    back = object_from_cam[:3, :3] @ np.array([0.0, 0.0, 1.0])
    back = np.array([back[0], 0.0, back[2]])
    back = back / np.linalg.norm(back) if np.linalg.norm(back) > 1e-6 else np.array([0.0, 0.0, -1.0])
    right = np.cross(np.array([0.0, 1.0, 0.0]), back)  # perpendicular to back, on the floor
    right /= np.linalg.norm(right)
    if right @ (object_from_cam[:3, :3] @ np.array([1.0, 0.0, 0.0])) < 0:
        right = -right
    points_obj = np.asarray(points, np.float64) @ object_from_cam[:3, :3].T + object_from_cam[:3, 3]
    cur = view.depth_mm.astype(np.float64) / 1000.0
    obj = view.mask < K
    near_obj = binary_dilation(obj, structure=np.ones((3, 3), bool))
    touching, last = False, None
    for attempt in range(1, tries + 1):  # noqa: B007 (read after the loop)
        side = 1.0 if rng.random() < 0.5 else -1.0
        for mesh, shape, t, b in _distractor_placements(rng, centre, lo, ext, right, back, side, points_obj):
            v_cam = np.asarray(mesh.vertices) @ view.cam_from_object[:3, :3].T + view.cam_from_object[:3, 3]
            depth_d, _ = raycast_depth(v_cam, np.asarray(mesh.faces), np.zeros(len(mesh.faces), np.int64), camera)
            front = (depth_d > 0) & ((cur <= 0) | (depth_d < cur))
            write = front & ~obj
            touching = bool(np.any(write & near_obj))
            last = (depth_d, front, write, shape, t, b, side)
            if touching:
                break
        if touching:
            break
    depth_d, front, write, shape, t, b, side = last
    depth_mm = view.depth_mm.copy()
    depth_mm[write] = depth_to_mm(depth_d)[write]
    mask = view.mask.copy()
    mask[write] = CLUTTER_LABEL
    info = {
        "shape": shape,
        "side": "right" if side > 0 else "left",
        "lateral": t,
        "behind": b,
        "pixels": int(write.sum()),
        "touching": touching,
        "tries": attempt,
        "overlap_px": int((front & obj).sum()),
    }
    return dataclasses.replace(view, depth_mm=depth_mm, mask=mask), info
