"""BOP-format scenes -> ucope samples (a cloud per object, its parts' poses; no joints in BOP).

Layout read (the BOP toolkit's): a scene folder, or a folder of scene folders (``000001/``...),
each with ``scene_camera.json``, ``scene_gt.json``, ``depth/{im_id:06d}.png`` and the masks, plus the
object models' ``models_info.json`` (the scene folder, its parent, or ``models/`` beside or above them):

* ``scene_camera.json``: per image id, ``cam_K`` (9 values, row-wise) and ``depth_scale``
  (depth PNG value x ``depth_scale`` = millimetres);
* ``scene_gt.json``: per image id, a list of ``{"obj_id", "cam_R_m2c" (9 values, row-wise),
  "cam_t_m2c" (millimetres)}``; an entry's position in the list is its ``gt_id``;
* masks: ``mask_visib/{im_id:06d}_{gt_id:06d}.png`` (BOP's visible masks, non-zero = object),
  else ``mask/{im_id:06d}_{gt_id:06d}.png``, else one label image ``mask/{im_id:06d}.png`` whose value is the
  ``gt_id`` (255 background, 254 distractors: what ``ucope generate --images`` writes);
* ``models_info.json``: per ``obj_id``, ``min_x, min_y, min_z, size_x, size_y, size_z`` in millimetres
  (the model's bounding box in its own frame).

Objects and parts: part ``k`` of an object is the model ``obj_id = base + k`` (``--bop-obj-id`` sets
``base``, default 1; the rule of ucope's BOP CSV export and of ``ucope generate --images``). A rigid
model gives one sample per ground-truth entry of ``base``; an articulated one needs the K entries
``base .. base + K - 1`` once each in an image. The part frame is the model frame moved to its box
centre (its axes are taken to be the category's canonical axes); ``size_m`` is the box's size. BOP
has no joints: the samples' joint fields are NaN and joint errors are not measured.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError
from ...fileio import read_json
from .common import read_depth, read_label_image, sample_from_pixels

__all__ = ["bop_scenes", "read_models_info", "read_bop"]


def bop_scenes(root: str | Path) -> list[Path]:
    """The scene folders of ``root``: itself if it holds ``scene_gt.json``, else its sub-folders that do
    (also ``root/images`` of a ``ucope generate --images`` data set)."""
    root = Path(root)
    if not root.is_dir():
        raise DataError(
            f"{root} is not a folder (expected a BOP scene with scene_camera.json, scene_gt.json, depth/, mask_visib/)"
        )
    if (root / "scene_gt.json").is_file():
        return [root]
    scenes = sorted(p for p in root.iterdir() if p.is_dir() and (p / "scene_gt.json").is_file())
    if not scenes:
        raise DataError(f"{root} holds no BOP scene (no scene_gt.json in it or in its sub-folders)")
    return scenes


def read_models_info(scene: Path, path: str | Path | None = None) -> tuple[Path, dict[int, tuple[np.ndarray, np.ndarray]]]:
    """``(path, {obj_id: (box centre (3,), box size (3,)) in metres})`` from ``models_info.json``
    (``path``, or searched in the scene folder, its parent and their ``models/`` folders)."""
    if path is None:
        cands = [
            d / n for d in (scene, scene.parent, scene.parent.parent) for n in ("models_info.json", "models/models_info.json")
        ]
        path = next((c for c in cands if c.is_file()), None)
        if path is None:
            raise DataError(
                f"no models_info.json for {scene} (looked in {', '.join(str(c) for c in cands[:4])}, ...): "
                "the object boxes (min_x.., size_x.. in mm) come from it"
            )
    path = Path(path)
    d = read_json(path)
    out = {}
    try:
        for k, v in d.items():
            lo = np.array([v["min_x"], v["min_y"], v["min_z"]], np.float64) / 1000.0
            size = np.array([v["size_x"], v["size_y"], v["size_z"]], np.float64) / 1000.0
            out[int(k)] = (lo + 0.5 * size, size)
    except (AttributeError, KeyError, TypeError, ValueError) as e:
        raise DataError(
            f"{path}: every object needs min_x, min_y, min_z, size_x, size_y, size_z (mm) ({type(e).__name__}: {e})"
        ) from None
    return path, out


def _mask(scene: Path, im: int, gt_id: int, shape, cache: dict) -> np.ndarray:
    for sub in ("mask_visib", "mask"):
        p = scene / sub / f"{im:06d}_{gt_id:06d}.png"
        if p.is_file():
            return read_label_image(p, "object mask (non-zero = object)", shape) > 0
    p = scene / "mask" / f"{im:06d}.png"
    if not p.is_file():
        raise DataError(
            f"{scene}: no mask for image {im}, object {gt_id} (looked for mask_visib/{im:06d}_{gt_id:06d}.png, "
            f"mask/{im:06d}_{gt_id:06d}.png and mask/{im:06d}.png)"
        )
    if p not in cache:
        cache.clear()
        cache[p] = read_label_image(p, "label mask (value = gt_id, 255 = background)", shape)
    return cache[p] == gt_id


def read_bop(
    root: str | Path, category: str, obj_id: int = 1, models_info: str | Path | None = None, max_points: int = 4096
) -> list[dict]:
    """Every object of ``category`` in the BOP scenes under ``root`` as a ucope sample.

    Args:
        root: a BOP scene folder or a folder of them (see the module docstring).
        category: the ucope category of the objects (its part count K sets the obj_ids read).
        obj_id: the base obj_id: part ``k`` is ``obj_id + k``.
        models_info: path of ``models_info.json`` (default: searched, see :func:`read_models_info`).
        max_points: clouds are subsampled (deterministically) to this many points.

    Returns:
        samples (:mod:`ucope.data.sample` fields, joints NaN) with ``scene_id``, ``im_id``, ``gt_ids``
        and ``obj_ids``. Objects with fewer than 32 measured pixels are skipped with a warning.

    Raises:
        DataError: a missing or corrupt file or field (named), an articulated object with a part
            missing or given twice in an image, an obj_id absent from ``models_info.json``.
    """
    from ...objects.categories import get_category, make_instance

    spec = get_category(category)
    K = spec.num_parts
    jtypes = np.array(
        [{"revolute": 0, "prismatic": 1}.get(j.type, 2) for j in make_instance(category, "test", 0).joints], np.int64
    )
    ids = list(range(int(obj_id), int(obj_id) + K))
    samples, skipped = [], []
    for scene in bop_scenes(root):
        cams = read_json(scene / "scene_camera.json")
        gts = read_json(scene / "scene_gt.json")
        info_path, boxes = read_models_info(scene, models_info)
        for oid in ids:
            if oid not in boxes:
                raise DataError(f"{info_path}: no obj_id {oid} (part {oid - obj_id} of {category} with --bop-obj-id {obj_id})")
        try:
            scene_id = int(scene.name)
        except ValueError:
            scene_id = 0
        mask_cache: dict = {}
        for im_key in sorted(gts, key=lambda k: int(k)):
            im = int(im_key)
            entries = gts[im_key]
            where = f"{scene / 'scene_gt.json'}, image {im}"
            try:
                found = [(g, int(e["obj_id"])) for g, e in enumerate(entries) if int(e["obj_id"]) in ids]
            except (KeyError, TypeError, ValueError):
                raise DataError(f"{where}: every entry needs an integer obj_id") from None
            if not found:
                continue
            if K == 1:
                groups = [[g] for g, _ in found]
            else:
                got = [o for _, o in found]
                if sorted(got) != ids:
                    raise DataError(
                        f"{where}: a {category} needs obj_ids {ids} once each (part k = {obj_id} + k), got {sorted(got)}"
                    )
                groups = [[g for k in ids for g, o in found if o == k]]
            cam = cams.get(im_key)
            if cam is None:
                raise DataError(f"{scene / 'scene_camera.json'}: no entry for image {im}")
            try:
                Km = np.asarray(cam["cam_K"], np.float64).reshape(3, 3)
                depth_scale = float(cam.get("depth_scale", 1.0))
            except (KeyError, TypeError, ValueError):
                raise DataError(f"{scene / 'scene_camera.json'}, image {im}: needs cam_K (9 values) and depth_scale") from None
            intr = (Km[0, 0], Km[1, 1], Km[0, 2], Km[1, 2])
            depth_path = scene / "depth" / f"{im:06d}.png"
            depth = read_depth(depth_path).astype(np.float64) * depth_scale / 1000.0
            for group in groups:
                labels = np.full(depth.shape, -1, np.int64)
                cam_from_part, size = np.zeros((K, 4, 4)), np.zeros((K, 3))
                for k, g in enumerate(group):
                    e = entries[g]
                    try:
                        R = np.asarray(e["cam_R_m2c"], np.float64).reshape(3, 3)
                        t = np.asarray(e["cam_t_m2c"], np.float64).reshape(3) / 1000.0
                    except (KeyError, TypeError, ValueError):
                        raise DataError(f"{where}, gt_id {g}: needs cam_R_m2c (9 values) and cam_t_m2c (3 values, mm)") from None
                    if np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
                        raise DataError(f"{where}, gt_id {g}: cam_R_m2c is not a rotation")
                    centre, sz = boxes[ids[k]]
                    cam_from_part[k] = np.eye(4)
                    cam_from_part[k, :3, :3] = R
                    cam_from_part[k, :3, 3] = R @ centre + t
                    size[k] = sz
                    labels[_mask(scene, im, g, depth.shape, mask_cache)] = k
                gt = {
                    "cam_from_part": cam_from_part,
                    "size_m": size,
                    "joint_type": jtypes,
                    "joint_pivot": np.full((K - 1, 3), np.nan),
                    "joint_axis": np.full((K - 1, 3), np.nan),
                    "joint_state": np.full(K - 1, np.nan),
                    "scene_id": scene_id,
                    "im_id": im,
                    "gt_ids": list(group),
                    "obj_ids": ids,
                }
                name = f"{scene.name}/{im:06d}/{group[0]}"
                s = sample_from_pixels(depth, intr, labels, gt, category, name, len(samples), max_points)
                if s is None:
                    skipped.append(name)
                else:
                    samples.append(s)
    if skipped:
        warnings.warn(
            f"skipped {len(skipped)} BOP object(s) with fewer than 32 measured pixels (first: {skipped[0]})", stacklevel=2
        )
    return samples
