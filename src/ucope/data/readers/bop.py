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
model gives one sample per ground-truth entry of ``base``. An articulated object is one entry of each of
``base .. base + K - 1``; an image may hold several: then every obj_id must occur equally often, and each
entry of ``base`` (the root part) is joined with the entries of the other parts whose box centres lie
nearest to its own (a minimum-total-distance assignment, per part). The part frame is the model frame
moved to its box centre (its axes are taken to be the category's canonical axes); ``size_m`` is the
box's size. BOP has no joints: the samples' joint fields are NaN and joint errors are not measured.

Every field is checked: ``scene_gt.json`` / ``scene_camera.json`` are objects keyed by integer image
ids, ``cam_K`` finite with positive focal lengths, ``depth_scale`` finite and positive, poses and box
sizes finite; a bad one raises :class:`~ucope.errors.DataError` naming the file, image and field.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError
from .common import finite_array, read_data_json, read_depth, read_label_image, sample_from_pixels

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
    d = read_data_json(path, "BOP models_info.json")
    if not isinstance(d, dict):
        raise DataError(f"{path}: expected an object keyed by obj_id, got {type(d).__name__}")
    out = {}
    for k, v in d.items():
        oid = _image_key(k, path, "obj_id")
        if not isinstance(v, dict) or not all(f in v for f in ("min_x", "min_y", "min_z", "size_x", "size_y", "size_z")):
            raise DataError(f"{path}: obj_id {k} needs min_x, min_y, min_z, size_x, size_y, size_z (mm)")
        lo = finite_array([v["min_x"], v["min_y"], v["min_z"]], (3,), f"{path}: obj_id {k}: min_x, min_y, min_z") / 1000.0
        size = finite_array([v["size_x"], v["size_y"], v["size_z"]], (3,), f"{path}: obj_id {k}: size_x, size_y, size_z") / 1000.0
        if (size < 0).any():
            raise DataError(f"{path}: obj_id {k}: size_x, size_y, size_z must be >= 0, got {(1000 * size).tolist()}")
        out[oid] = (lo + 0.5 * size, size)
    return path, out


def _image_key(key, path: Path, what: str = "image id") -> int:
    """A key of a BOP JSON object as an integer (digits only); :class:`DataError` naming the file otherwise."""
    if not isinstance(key, str) or not key.strip().isdigit():
        raise DataError(f"{path}: key {key!r} is not a non-negative integer {what}")
    return int(key)


def _scene_json(path: Path, what: str) -> dict[int, object]:
    d = read_data_json(path, what)
    if not isinstance(d, dict):
        raise DataError(f"{path}: expected an object keyed by image id (BOP's {path.name}), got {type(d).__name__}")
    return {_image_key(k, path): v for k, v in d.items()}


def _camera(cams: dict, im: int, path: Path) -> tuple[tuple[float, float, float, float], float]:
    """``((fx, fy, cx, cy), depth_scale)`` of image ``im`` from ``scene_camera.json``, checked."""
    cam = cams.get(im)
    if cam is None:
        raise DataError(f"{path}: no entry for image {im}")
    if not isinstance(cam, dict) or "cam_K" not in cam:
        raise DataError(f"{path}, image {im}: needs cam_K (9 values, row-wise) and depth_scale")
    Km = finite_array(cam["cam_K"], (9,), f"{path}, image {im}: cam_K").reshape(3, 3)
    if not (Km[0, 0] > 0 and Km[1, 1] > 0):
        raise DataError(f"{path}, image {im}: cam_K needs positive focal lengths, got fx {Km[0, 0]}, fy {Km[1, 1]}")
    scale = cam.get("depth_scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not (np.isfinite(scale) and scale > 0):
        raise DataError(
            f"{path}, image {im}: depth_scale must be a finite number > 0 (depth value x depth_scale = mm), got {scale!r}"
        )
    return (float(Km[0, 0]), float(Km[1, 1]), float(Km[0, 2]), float(Km[1, 2])), float(scale)


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


def _group_parts(found, poses, ids, where: str, category: str, base: int) -> list[list[int]]:
    """The ``gt_id`` s of every articulated instance of one image, in its parts' order: each entry of the
    root part's obj_id joined with the entries of every other part whose box centres lie nearest (one
    minimum-total-distance assignment per part)."""
    from scipy.optimize import linear_sum_assignment

    by_id = {o: [g for g, oo in found if oo == o] for o in ids}
    counts = {o: len(v) for o, v in by_id.items()}
    if len(set(counts.values())) != 1 or not by_id[ids[0]]:
        raise DataError(
            f"{where}: a {category} is one entry of each of obj_ids {ids} (part k = {base} + k); the image holds "
            f"{', '.join(f'{n} of obj_id {o}' for o, n in counts.items())}: every part must occur as often as the others"
        )
    roots = by_id[ids[0]]
    groups = [[g] for g in roots]
    centres = np.stack([poses[g][:3, 3] for g in roots])
    for o in ids[1:]:
        parts = by_id[o]
        cost = np.linalg.norm(centres[:, None] - np.stack([poses[g][:3, 3] for g in parts])[None], axis=-1)
        rows, cols = linear_sum_assignment(cost)
        for r, c in zip(rows, cols, strict=True):
            groups[r].append(parts[c])
    return groups


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
        DataError: a missing or corrupt file or field (named, with its image), a wrong type (a list
            where an object is due, a key that is not an image id), NaN or Inf, a ``cam_K`` without
            positive focal lengths, a ``depth_scale`` not > 0, an image whose articulated parts do not all
            occur equally often, an obj_id absent from ``models_info.json``.
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
        cam_path, gt_path = scene / "scene_camera.json", scene / "scene_gt.json"
        cams = _scene_json(cam_path, "BOP scene_camera.json")
        gts = _scene_json(gt_path, "BOP scene_gt.json")
        info_path, boxes = read_models_info(scene, models_info)
        for oid in ids:
            if oid not in boxes:
                raise DataError(f"{info_path}: no obj_id {oid} (part {oid - obj_id} of {category} with --bop-obj-id {obj_id})")
        try:
            scene_id = int(scene.name)
        except ValueError:
            scene_id = 0
        mask_cache: dict = {}
        for im in sorted(gts):
            entries = gts[im]
            where = f"{gt_path}, image {im}"
            if not isinstance(entries, list):
                raise DataError(f"{where}: expected a list of ground-truth entries, got {type(entries).__name__}")
            poses: dict[int, np.ndarray] = {}
            found: list[tuple[int, int]] = []
            for g, e in enumerate(entries):
                if not isinstance(e, dict) or "obj_id" not in e:
                    raise DataError(f"{where}, gt_id {g}: needs obj_id, cam_R_m2c (9 values) and cam_t_m2c (3 values, mm)")
                o = e["obj_id"]
                if isinstance(o, bool) or not isinstance(o, int):
                    raise DataError(f"{where}, gt_id {g}: obj_id must be an integer, got {o!r}")
                if o not in ids:
                    continue
                if "cam_R_m2c" not in e or "cam_t_m2c" not in e:
                    raise DataError(f"{where}, gt_id {g}: needs cam_R_m2c (9 values) and cam_t_m2c (3 values, mm)")
                R = finite_array(e["cam_R_m2c"], (9,), f"{where}, gt_id {g}: cam_R_m2c").reshape(3, 3)
                t = finite_array(e["cam_t_m2c"], (3,), f"{where}, gt_id {g}: cam_t_m2c") / 1000.0
                if np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
                    raise DataError(f"{where}, gt_id {g}: cam_R_m2c is not a rotation")
                centre, _ = boxes[o]
                T = np.eye(4)
                T[:3, :3], T[:3, 3] = R, R @ centre + t
                poses[g] = T
                found.append((g, o))
            if not found:
                continue
            if K == 1:
                groups = [[g] for g, _ in found]
            else:
                groups = _group_parts(found, poses, ids, where, category, obj_id)
            intr, depth_scale = _camera(cams, im, cam_path)
            depth_path = scene / "depth" / f"{im:06d}.png"
            depth = read_depth(depth_path).astype(np.float64) * depth_scale / 1000.0
            for group in groups:
                labels = np.full(depth.shape, -1, np.int64)
                cam_from_part, size = np.zeros((K, 4, 4)), np.zeros((K, 3))
                for k, g in enumerate(group):
                    cam_from_part[k] = poses[g]
                    size[k] = boxes[ids[k]][1]
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
