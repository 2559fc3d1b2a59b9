"""Test fixtures: frames with several rendered objects, and writers of the data-set layouts the readers
read (NOCS, ArtImage, BOP), built from ucope's own objects and renderer so that the ground truth is known."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ucope.geometry.transforms import invert_transform, look_at_rotation, make_transform
from ucope.model.checkpoint import list_pretrained
from ucope.objects.categories import make_instance
from ucope.render.camera import PinholeCamera
from ucope.render.noise import DepthNoise
from ucope.render.views import ViewConfig, render_view

CAMERA640 = PinholeCamera(fx=577.5, fy=577.5, cx=319.5, cy=239.5, width=640, height=480)
SMALL = PinholeCamera(fx=288.75, fy=288.75, cx=159.75, cy=119.75, width=320, height=240)

needs_models = pytest.mark.skipif(
    not {"laptop", "mug"} <= set(list_pretrained()), reason="needs the shipped laptop and mug models"
)


def posed(distance: float, yaw_deg: float, elev_deg: float, shift=(0.0, 0.0, 0.0)) -> np.ndarray:
    """``cam_from_object``: the object seen from ``(yaw, elevation, distance)``, then moved by ``shift``
    (camera frame, metres) so that several objects stand side by side."""
    yaw, elev = np.radians(yaw_deg), np.radians(elev_deg)
    eye = distance * np.array([np.cos(elev) * np.sin(yaw), np.sin(elev), np.cos(elev) * np.cos(yaw)])
    T = invert_transform(make_transform(look_at_rotation(eye, np.zeros(3)), eye))
    T[:3, 3] += np.asarray(shift, np.float64)
    return T


def render_frame(objects, camera: PinholeCamera = SMALL) -> dict:
    """Render ``[(category, instance index, cam_from_object, state or None), ...]`` into one frame.

    Returns ``{"depth_mm" (H, W) uint16, "instance" (H, W) uint8 (object i -> i + 1, 0 = none),
    "parts" (H, W) int (part index, -1 = none), "objects": [{"obj", "cam_from_part", "size_m",
    "joint_pivot", "joint_axis", "joint_state", "state"}]}``; clean depth, no floor, no distractors."""
    cfg = ViewConfig(camera=camera, noise=DepthNoise(enabled=False), floor=False, num_distractors=0)
    H, W = camera.height, camera.width
    depth = np.zeros((H, W), np.uint16)
    instance = np.zeros((H, W), np.uint8)
    parts = np.full((H, W), -1, np.int64)
    out = []
    for i, (cat, idx, T, state) in enumerate(objects):
        obj = make_instance(cat, "test", idx)
        st = obj.rest_state if state is None else np.asarray(state, np.float64)
        v = render_view(obj, cfg, np.random.default_rng(i), state=st, cam_from_object=T)
        hit = (v.mask < obj.num_parts) & (v.depth_mm > 0) & ((depth == 0) | (v.depth_mm < depth))
        depth[hit] = v.depth_mm[hit]
        instance[hit] = i + 1
        parts[hit] = v.mask[hit]
        out.append(
            {
                "obj": obj,
                "cam_from_part": v.cam_from_part,
                "size_m": obj.size_m,
                "joint_pivot": v.joint_pivot,
                "joint_axis": v.joint_axis,
                "joint_state": v.joint_state,
                "state": st,
            }
        )
    return {"depth_mm": depth, "instance": instance, "parts": parts, "objects": out, "camera": camera}


def save_png(path: Path, arr: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    a = np.asarray(arr)
    Image.fromarray(a.astype("<u2") if a.dtype == np.uint16 else a).save(path)


def save_json(path: Path, obj) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(obj))


def backproject(depth_mm: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """``(H, W, 3)`` camera-frame points of every pixel (metres)."""
    rows, cols = np.mgrid[0 : camera.height, 0 : camera.width]
    z = depth_mm.astype(np.float64) / 1000.0
    return np.stack([(cols - camera.cx) / camera.fx * z, (rows - camera.cy) / camera.fy * z, z], axis=-1)


def write_nocs_frame(prefix: Path, frame: dict, classes: list[int], three_channel: bool, extra_meta: list[str] = ()) -> None:
    """Write a frame in NOCS's layout: ``prefix_depth.png``, ``_mask.png``, ``_coord.png``, ``_meta.txt``
    (instance ``i + 1`` of class ``classes[i]``; CAMERA-style 3-channel depth and mask if ``three_channel``)."""
    cam = frame["camera"]
    H, W = cam.height, cam.width
    mask = np.full((H, W), 255, np.uint8)
    coord = np.zeros((H, W, 3), np.uint8)
    P = backproject(frame["depth_mm"], cam)
    for i, o in enumerate(frame["objects"]):
        sel = frame["instance"] == i + 1
        mask[sel] = i + 1
        T = o["cam_from_part"][0]
        local = (P[sel] - T[:3, 3]) @ T[:3, :3]  # object (box-centred) frame
        c = local / np.linalg.norm(o["size_m"][0]) + 0.5
        c[:, 2] = 1.0 - c[:, 2]  # NOCS stores z flipped
        coord[sel] = np.clip(np.round(255.0 * c), 0, 255).astype(np.uint8)
    d = frame["depth_mm"]
    if three_channel:  # NOCS's CAMERA encoding: depth = 256 * green + red (RGB order)
        save_png(
            prefix.with_name(prefix.name + "_depth.png"),
            np.stack([d % 256, d // 256, np.zeros_like(d)], axis=-1).astype(np.uint8),
        )
        save_png(prefix.with_name(prefix.name + "_mask.png"), np.stack([mask, mask, mask], axis=-1))
    else:
        save_png(prefix.with_name(prefix.name + "_depth.png"), d)
        save_png(prefix.with_name(prefix.name + "_mask.png"), mask)
    save_png(prefix.with_name(prefix.name + "_coord.png"), coord)
    lines = [f"{i + 1} {c} model_{i}" for i, c in enumerate(classes)] + list(extra_meta)
    prefix.with_name(prefix.name + "_meta.txt").write_text("\n".join(lines) + "\n")


def coco_rle(mask: np.ndarray, compressed: bool = True) -> dict:
    """COCO's RLE of a bool mask (column-major runs starting with background), its counts as COCO's
    compressed string (``rleToString``) or as a list (written here from COCO's definition, for fixtures)."""
    flat = np.asarray(mask, bool).T.reshape(-1)
    change = np.flatnonzero(np.diff(flat.astype(np.int8))) + 1
    bounds = np.r_[0, change, flat.size]
    counts = np.diff(bounds).tolist()
    if flat.size and flat[0]:
        counts = [0] + counts
    size = [int(mask.shape[0]), int(mask.shape[1])]
    if not compressed:
        return {"size": size, "counts": counts}
    out = []
    for i, c in enumerate(counts):
        x = c - counts[i - 2] if i > 2 else c
        more = True
        while more:
            ch = x & 0x1F
            x >>= 5
            more = x != -1 if ch & 0x10 else x != 0
            if more:
                ch |= 0x20
            out.append(chr(ch + 48))
    return {"size": size, "counts": "".join(out)}


def urdf_order(v) -> list:
    """A rest-frame vector ``(x, y, z)`` in the URDF axis order ReArt's files store (``[z, x, y]``: their
    loader reads a stored ``[a, b, c]`` as ``(b, c, a)``)."""
    v = np.asarray(v, np.float64)
    return [float(v[2]), float(v[0]), float(v[1])]


def write_artimage(root: Path, frames: list[dict], scale: float = 1.0, segmentation: str = "rle", link_base: int = 1) -> None:
    """Write frames in the ReArt / ArtImage annotation layout, with the field names of the authors'
    loaders: every object of a frame is an instance with its own urdf (``urdf_metas.json``: ``corner_pts``
    ``(K + 1, 2, 1, 3)`` with the whole object first, ``joint_xyz`` / ``joint_rpy`` in URDF axis order,
    link ids from ``link_base``), its links listed in reverse id order with ``link_category_id``,
    ``transformation`` (the object's rest frame -> camera, a uniform ``scale``) and ``segmentation``
    (``"rle"``: COCO compressed RLE; ``"rle-list"``: uncompressed; ``"polygons"``: the bounding quad of each
    part's pixels, coarse), and no link ``state`` (the reader measures it from the poses)."""
    cam = frames[0]["camera"]
    save_json(
        root / "camera_intrinsic.json",
        {"width": cam.width, "height": cam.height, "intrinsic_matrix": [cam.fx, 0, 0, 0, cam.fy, 0, cam.cx, cam.cy, 1]},
    )
    metas = []
    for f, fr in enumerate(frames):
        instances = []
        for i, o in enumerate(fr["objects"]):
            obj = o["obj"]
            u = 100 + len(metas)
            K = obj.num_parts
            zero = np.stack([np.eye(4)] * K)  # link frames: the object frame at state 0 (may be outside the limits)
            for j in obj.joints:
                zero[j.child] = zero[j.parent] @ j.parent_from_child_zero
            lo = (zero[:, :3, 3] - obj.size_m / 2) / scale
            hi = (zero[:, :3, 3] + obj.size_m / 2) / scale
            boxes = np.stack([lo, hi], axis=1)  # (K, 2, 3)
            whole = np.stack([lo.min(axis=0), hi.max(axis=0)])
            corners = np.concatenate([whole[None], boxes])[:, :, None, :]  # (K + 1, 2, 1, 3)
            metas.append(
                {
                    "id": u,
                    "norm_factors": [float(1.0 / np.linalg.norm(c[1, 0] - c[0, 0])) for c in corners],
                    "corner_pts": corners.tolist(),
                    "joint_types": [j.type for j in obj.joints],
                    "joint_parents": [j.parent + link_base for j in obj.joints],
                    "joint_children": [j.child + link_base for j in obj.joints],
                    "joint_xyz": [
                        urdf_order((zero[j.parent, :3, :3] @ j.pivot + zero[j.parent, :3, 3]) / scale) for j in obj.joints
                    ],
                    "joint_rpy": [urdf_order(zero[j.parent, :3, :3] @ j.axis) for j in obj.joints],
                }
            )
            links = []
            for k in reversed(range(K)):
                M = o["cam_from_part"][k] @ invert_transform(zero[k])  # camera <- link (metres)
                M[:3, :3] *= scale  # the link frame in model units
                link = {"link_category_id": k + link_base, "transformation": M.tolist()}
                sel = (fr["instance"] == i + 1) & (fr["parts"] == k)
                if segmentation == "polygons":
                    rows, cols = np.nonzero(sel)
                    x0, x1, y0, y1 = int(cols.min()), int(cols.max()), int(rows.min()), int(rows.max())
                    link["segmentation"] = [[x0, y0, x1, y0, x1, y1, x0, y1]]
                else:
                    link["segmentation"] = coco_rle(sel, compressed=segmentation == "rle")
                links.append(link)
            rows, cols = np.nonzero(fr["instance"] == i + 1)
            instances.append(
                {
                    "id": i,
                    "urdf_id": u,
                    "category_id": 1,
                    "bbox": [int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1],
                    "links": links,
                }
            )
        name = f"scene_0/{f:06d}"
        save_png(root / "depth" / f"{name}.png", fr["depth_mm"])
        save_json(
            root / "annotations" / f"{name}.json",
            {
                "color_path": f"{name}.jpg",
                "depth_path": f"{name}.png",
                "width": cam.width,
                "height": cam.height,
                "instances": instances,
            },
        )
    save_json(root / "urdf_metas.json", {"urdf_metas": metas})


def write_bop_scene(scene: Path, frame: dict, obj_ids: list[list[int]], im_id: int = 0) -> None:
    """Write a frame as BOP scene ``scene`` (``scene_camera``, ``scene_gt``, ``depth``, ``mask_visib``) and
    a ``models_info.json`` beside it: object ``i``'s part ``k`` is model ``obj_ids[i][k]``, whose frame
    has the part's box at ``[0, size]`` (not centred, as BOP models often are)."""
    cam = frame["camera"]
    gts, info = [], {}
    for i, (o, ids) in enumerate(zip(frame["objects"], obj_ids, strict=False)):
        for k, oid in enumerate(ids):
            T = o["cam_from_part"][k]
            half = o["size_m"][k] / 2
            t = T[:3, 3] - T[:3, :3] @ half
            gts.append({"obj_id": oid, "cam_R_m2c": T[:3, :3].reshape(-1).tolist(), "cam_t_m2c": (1000 * t).tolist()})
            info[str(oid)] = {
                "min_x": 0.0,
                "min_y": 0.0,
                "min_z": 0.0,
                "size_x": 1000 * o["size_m"][k][0],
                "size_y": 1000 * o["size_m"][k][1],
                "size_z": 1000 * o["size_m"][k][2],
                "diameter": 1000 * 2 * float(np.linalg.norm(half)),
            }
            sel = (frame["instance"] == i + 1) & (frame["parts"] == k)
            save_png(scene / "mask_visib" / f"{im_id:06d}_{len(gts) - 1:06d}.png", (255 * sel).astype(np.uint8))
    save_json(
        scene / "scene_camera.json", {str(im_id): {"cam_K": [cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1], "depth_scale": 0.1}}
    )
    save_json(scene / "scene_gt.json", {str(im_id): gts})
    save_png(scene / "depth" / f"{im_id:06d}.png", (frame["depth_mm"].astype(np.float64) * 10).astype(np.uint16))  # 0.1 mm units
    save_json(scene.parent / "models" / "models_info.json", info)


def rgb_of(frame) -> np.ndarray:
    """A colour image of a rendered frame (objects shaded by instance and depth over a grey background)."""
    inst = frame["instance"]
    img = np.full(inst.shape + (3,), 200, np.uint8)
    z = frame["depth_mm"].astype(np.float64)
    shade = np.clip(1.4 - z / max(1.0, z.max()), 0.4, 1.0)
    for i, colour in ((1, (180, 60, 40)), (2, (60, 90, 170))):
        sel = inst == i
        img[sel] = (np.array(colour) * shade[sel, None]).astype(np.uint8)
    return img
