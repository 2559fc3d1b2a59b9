"""Depth and part-id images by ray casting (Embree through trimesh when ``embreex`` is installed).

Only the pixels inside the projected bounding box of the meshes are cast; a floor plane is
intersected analytically, so a full-image floor costs no ray casting.
"""

from __future__ import annotations

import numpy as np
import trimesh

from .camera import PinholeCamera

__all__ = ["raycast_depth", "BACKGROUND_LABEL", "CLUTTER_LABEL"]

BACKGROUND_LABEL = 255
"""Label of pixels that see nothing, or the floor."""
CLUTTER_LABEL = 254
"""Label of pixels that see a distractor object."""


def _intersector(mesh: trimesh.Trimesh):
    try:
        from trimesh.ray.ray_pyembree import RayMeshIntersector  # needs embreex

        return RayMeshIntersector(mesh)
    except Exception:  # embreex missing or failing: trimesh's pure numpy/rtree fallback
        return trimesh.ray.ray_triangle.RayMeshIntersector(mesh)


def raycast_depth(
    vertices_cam: np.ndarray,
    faces: np.ndarray,
    face_labels: np.ndarray,
    camera: PinholeCamera,
    floor_cam: tuple[np.ndarray, np.ndarray] | None = None,
    near_m: float = 0.05,
) -> tuple[np.ndarray, np.ndarray]:
    """Render a triangle soup given in the camera frame.

    Args:
        vertices_cam: ``(V, 3)`` vertices in the camera frame, metres.
        faces: ``(F, 3)`` vertex indices.
        face_labels: ``(F,)`` label of each face, written into the label image (0..253).
        floor_cam: optional floor plane as ``(point (3,), normal (3,))`` in the camera frame; it is
            rendered with :data:`BACKGROUND_LABEL`.

    Returns:
        depth ``(H, W)`` float64 metres (0 = no return), labels ``(H, W)`` uint8.
    """
    H, W = camera.height, camera.width
    depth = np.zeros((H, W), dtype=np.float64)
    labels = np.full((H, W), BACKGROUND_LABEL, dtype=np.uint8)

    if floor_cam is not None:
        p0, n = (np.asarray(a, np.float64) for a in floor_cam)
        rows, cols = np.mgrid[0:H, 0:W]
        d = camera.pixel_rays(rows.ravel(), cols.ravel())  # z = 1, so t is the depth
        denom = d @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (p0 @ n) / denom
        t[~np.isfinite(t) | (t < near_m)] = 0.0
        depth = t.reshape(H, W)

    v = np.asarray(vertices_cam, np.float64)
    front = v[:, 2] > near_m
    if len(faces) == 0 or not np.any(front):
        return depth, labels
    uv = camera.project(v[front])
    u0, v0 = np.floor(uv.min(0)).astype(int)
    u1, v1 = np.ceil(uv.max(0)).astype(int)
    u0, u1 = max(u0, 0), min(u1, W - 1)
    v0, v1 = max(v0, 0), min(v1, H - 1)
    if u0 > u1 or v0 > v1:
        return depth, labels
    rows, cols = np.mgrid[v0 : v1 + 1, u0 : u1 + 1]
    rows, cols = rows.ravel(), cols.ravel()
    dirs = camera.pixel_rays(rows, cols)
    dirs_unit = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    mesh = trimesh.Trimesh(vertices=v, faces=faces, process=False)
    locs, ray_idx, tri_idx = _intersector(mesh).intersects_location(np.zeros_like(dirs_unit), dirs_unit, multiple_hits=False)
    if len(ray_idx) == 0:
        return depth, labels
    z = locs[:, 2]
    keep = z > near_m
    ray_idx, tri_idx, z = ray_idx[keep], tri_idx[keep], z[keep]
    r, c = rows[ray_idx], cols[ray_idx]
    cur = depth[r, c]
    closer = (cur <= 0) | (z < cur)
    r, c = r[closer], c[closer]
    depth[r, c] = z[closer]
    labels[r, c] = np.asarray(face_labels)[tri_idx[closer]].astype(np.uint8)
    return depth, labels
