"""ArtImage frames -> ucope samples (a cloud per articulated object, its parts' and joints' ground truth).

ArtImage (laptop, eyeglasses, dishwasher, scissors, drawer; PartNet-Mobility models re-aligned so that
each category shares a rest state) is not distributed with a documented file format. This reader
expects the layout below, modelled on the annotation files its authors published for the related
ReArt data (per-image JSON with ``instances`` -> ``links`` -> 4x4 ``transformation``, and a
``urdf_metas.json`` with per-link ``corner_pts`` and the joints); convert other copies to it.
Every deviation raises :class:`~ucope.errors.DataError` naming the file and the field::

    DIR/                                   one category (one split)
      camera_intrinsic.json                {"width": W, "height": H, "intrinsic_matrix": [9 values]}
                                           (Open3D's layout: column-major, fx, 0, 0, 0, fy, 0, cx, cy, 1)
      urdf_metas.json                      {"urdf_metas": [{"id": U,
                                              "corner_pts": [[[x, y, z], [x, y, z]] per link],   min / max corner, link frame
                                              "joint_types": ["revolute" | "prismatic", ...],
                                              "joint_parents": [link ids], "joint_children": [link ids],
                                              "joint_xyz": [[x, y, z], ...],           a point on the axis, parent link frame
                                              "joint_axis": [[x, y, z], ...]}]}                  axis direction, parent link frame
      depth/<scene>/<NNNNNN>.png           uint16 depth, millimetres (0 = none)
      mask/<scene>/<NNNNNN>.png            uint8 part mask: link id 0..K-1, 255 = background
      annotations/<scene>/<NNNNNN>.json    {"depth_path": "<scene>/NNNNNN.png", "mask_path": "<scene>/NNNNNN.png",
                                            "width": W, "height": H,
                                            "instances": [{"id": 0, "urdf_id": U, "links": [
                                               {"id": k, "transformation": 4x4 rows (link frame -> camera, metres;
                                                                            may include a uniform scale),
                                                "state": joint state of the joint whose child is link k
                                                         (degrees if revolute, metres if prismatic; the root has none),
                                                "segmentation": optional COCO polygons [[x0, y0, x1, y1, ...], ...]}]}]}

* One object instance per image (ArtImage renders one); link ``k`` is ucope part ``k`` (so the links
  follow the category's part order: laptop base, lid; eyeglasses frame, left temple, right temple;
  drawer cabinet, top, middle, bottom drawer...).
* A link's pixels are those of the part mask holding its id, or its ``segmentation`` polygons when
  the annotation has them (then ``mask_path`` may be absent).
* Link frames are the object's rest frame with ArtImage's canonical axes, which this reader takes to be
  ours (docs/conventions.md: y up, x right, z towards the front); ``transformation`` maps a link's
  points to the camera (OpenCV axes) at the image's joint states. The part's box is the link's
  ``corner_pts`` box: ``cam_from_part = transformation @ [I | box centre]`` (the scale taken out of the
  rotation) and ``size_m = scale * (max - min)``.
* Joints: pivot ``transformation_parent @ joint_xyz`` and axis ``R_parent @ joint_axis`` in the camera;
  the state is the child link's ``state`` (degrees -> radians; prismatic metres times the scale), with
  ArtImage's rest state as 0 and the same sign convention as ours (a right-handed turn about the axis).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError
from ...fileio import read_json
from .common import read_depth, read_label_image, sample_from_pixels

__all__ = ["read_artimage", "read_open3d_intrinsics", "decompose_similarity", "polygon_mask"]

JOINT_CODES = {"revolute": 0, "prismatic": 1}


def read_open3d_intrinsics(path: str | Path) -> tuple[tuple[float, float, float, float], tuple[int, int]]:
    """``((fx, fy, cx, cy), (H, W))`` from an Open3D ``PinholeCameraIntrinsic`` JSON."""
    d = read_json(path)
    try:
        m = np.asarray(d["intrinsic_matrix"], np.float64).reshape(3, 3).T  # column-major on disk
        W, H = int(d["width"]), int(d["height"])
    except (KeyError, TypeError, ValueError) as e:
        raise DataError(f"{path}: expected {{'width', 'height', 'intrinsic_matrix': [9 values, column-major]}} ({e})") from None
    K = (float(m[0, 0]), float(m[1, 1]), float(m[0, 2]), float(m[1, 2]))
    if not (np.all(np.isfinite(K)) and K[0] > 0 and K[1] > 0 and W > 0 and H > 0):
        raise DataError(f"{path}: intrinsics must be finite with positive focal lengths and image size, got {K} {W}x{H}")
    return K, (H, W)


def decompose_similarity(M, where: str) -> tuple[float, np.ndarray, np.ndarray]:
    """``(s, R, t)`` of a 4x4 similarity ``[s R | t]``; :class:`DataError` naming ``where`` otherwise."""
    try:
        M = np.asarray(M, np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{where}: transformation must be a 4x4 matrix of numbers") from None
    if M.shape != (4, 4) or not np.all(np.isfinite(M)):
        raise DataError(f"{where}: transformation must be a finite 4x4 matrix, got shape {M.shape}")
    A = M[:3, :3]
    det = float(np.linalg.det(A))
    if det <= 0:
        raise DataError(f"{where}: transformation's rotation part has determinant {det:.3g} (a reflection or degenerate)")
    s = det ** (1.0 / 3.0)
    R = A / s
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-3:
        raise DataError(f"{where}: transformation is not a rotation times a uniform scale")
    U, _, Vt = np.linalg.svd(R)
    return s, U @ Vt, M[:3, 3].copy()


def polygon_mask(polygons, shape: tuple[int, int], where: str) -> np.ndarray:
    """``(H, W)`` bool mask of COCO polygons (``[[x0, y0, x1, y1, ...], ...]``, pixel coordinates)."""
    from PIL import Image, ImageDraw

    H, W = shape
    img = Image.new("1", (W, H), 0)
    draw = ImageDraw.Draw(img)
    try:
        for poly in polygons:
            xy = np.asarray(poly, np.float64).reshape(-1, 2)
            if len(xy) >= 3:
                draw.polygon([tuple(p) for p in xy.tolist()], fill=1, outline=1)
    except (TypeError, ValueError):
        raise DataError(f"{where}: segmentation must be a list of [x0, y0, x1, y1, ...] polygons") from None
    return np.array(img, dtype=bool)


def _urdf_metas(root: Path) -> dict[int, dict]:
    path = root / "urdf_metas.json"
    d = read_json(path)
    if not isinstance(d, dict) or not isinstance(d.get("urdf_metas"), list):
        raise DataError(f"{path}: expected {{'urdf_metas': [...]}}")
    out = {}
    for i, m in enumerate(d["urdf_metas"]):
        try:
            out[int(m["id"])] = m
        except (KeyError, TypeError, ValueError):
            raise DataError(f"{path}: urdf_metas[{i}] has no integer 'id'") from None
    return out


def _joint_table(meta: dict, K: int, where: str, spec_joints: list[tuple[int, int, str]]) -> list[dict]:
    """The urdf's joints in ucope's joint order (matched by child link)."""
    try:
        types, parents, children = (
            list(meta["joint_types"]),
            [int(v) for v in meta["joint_parents"]],
            [int(v) for v in meta["joint_children"]],
        )
        xyz = np.asarray(meta["joint_xyz"], np.float64).reshape(-1, 3)
        axis = np.asarray(meta["joint_axis"], np.float64).reshape(-1, 3)
    except (KeyError, TypeError, ValueError) as e:
        raise DataError(
            f"{where}: needs joint_types, joint_parents, joint_children, joint_xyz and joint_axis ({type(e).__name__}: {e})"
        ) from None
    if not (len(types) == len(parents) == len(children) == len(xyz) == len(axis) == K - 1):
        raise DataError(
            f"{where}: a {K}-part object needs {K - 1} joints in every joint_* list, got "
            f"{[len(types), len(parents), len(children), len(xyz), len(axis)]}"
        )
    by_child = {c: i for i, c in enumerate(children)}
    out = []
    for parent, child, jtype in spec_joints:
        i = by_child.get(child)
        if i is None or parents[i] != parent:
            raise DataError(
                f"{where}: no joint from link {parent} to link {child} (joint_parents {parents}, joint_children {children})"
            )
        if types[i] != jtype:
            raise DataError(f"{where}: the joint of link {child} is {types[i]!r}; this category's is {jtype!r}")
        if not np.linalg.norm(axis[i]) > 1e-9:
            raise DataError(f"{where}: joint_axis of link {child} is zero")
        out.append({"type": jtype, "parent": parent, "child": child, "xyz": xyz[i], "axis": axis[i] / np.linalg.norm(axis[i])})
    return out


def read_artimage(root: str | Path, category: str, max_points: int = 4096) -> list[dict]:
    """Every annotated object under ``root`` (the layout of the module docstring) as a ucope sample.

    Args:
        root: the category's folder (``camera_intrinsic.json``, ``urdf_metas.json``, ``annotations/``...).
        category: the ucope category (laptop, eyeglasses, dishwasher, scissors, drawer): its part count
            and joints are checked against each file.
        max_points: clouds are subsampled (deterministically) to this many points.

    Returns:
        samples (:mod:`ucope.data.sample` fields) in file order, with ``frame`` (the annotation's path
        below ``annotations/``) and ``urdf_id``. Objects with fewer than 32 measured pixels are skipped
        with a warning.

    Raises:
        DataError: a missing or corrupt file, a missing field, a transformation that is not a
            similarity, a link or joint count other than the category's (each naming the file).
        InputError: an unknown category.
    """
    from ...objects.categories import get_category, make_instance

    root = Path(root)
    spec = get_category(category)
    K = spec.num_parts
    proto = make_instance(category, "test", 0)
    spec_joints = [(j.parent, j.child, j.type) for j in proto.joints]
    if not root.is_dir():
        raise DataError(
            f"{root} is not a folder (expected an ArtImage category folder with annotations/, depth/, mask/, urdf_metas.json)"
        )
    ann_dir = root / "annotations"
    files = sorted(ann_dir.rglob("*.json")) if ann_dir.is_dir() else []
    if not files:
        raise DataError(f"{ann_dir} holds no annotation JSON files (annotations/<scene>/<NNNNNN>.json)")
    K_cam, shape = read_open3d_intrinsics(root / "camera_intrinsic.json")
    metas = _urdf_metas(root)
    samples, skipped = [], []
    for f in files:
        a = read_json(f)
        rel = f.relative_to(ann_dir).with_suffix("").as_posix()
        try:
            W, H = int(a["width"]), int(a["height"])
            instances = list(a["instances"])
            depth_rel = str(a["depth_path"])
        except (KeyError, TypeError, ValueError) as e:
            raise DataError(f"{f}: needs width, height, depth_path and instances ({type(e).__name__}: {e})") from None
        if (H, W) != shape:
            raise DataError(f"{f}: the image is {W}x{H}, camera_intrinsic.json says {shape[1]}x{shape[0]}")
        if len(instances) != 1:
            raise DataError(f"{f}: holds {len(instances)} instances; ArtImage images hold one object")
        inst = instances[0]
        try:
            links = sorted(inst["links"], key=lambda ln: int(ln["id"]))
            meta = metas[int(inst["urdf_id"])]
        except KeyError as e:
            raise DataError(f"{f}: instance 0 lacks {e} (or its urdf_id is not in urdf_metas.json)") from None
        if [int(ln["id"]) for ln in links] != list(range(K)):
            raise DataError(f"{f}: a {category} has {K} links with ids 0..{K - 1}, got ids {[ln['id'] for ln in links]}")
        depth = read_depth(root / "depth" / depth_rel, shape).astype(np.float64) / 1000.0
        labels = np.full(shape, -1, np.int64)
        if all("segmentation" in ln for ln in links):
            for k, ln in enumerate(links):
                labels[polygon_mask(ln["segmentation"], shape, f"{f}: link {k}")] = k
        else:
            if "mask_path" not in a:
                raise DataError(f"{f}: needs mask_path (or a segmentation for every link)")
            m = read_label_image(root / "mask" / str(a["mask_path"]), "part mask (link id, 255 = background)", shape)
            labels = np.where(m < K, m.astype(np.int64), -1)
        corners = np.asarray(meta.get("corner_pts"), np.float64) if meta.get("corner_pts") is not None else None
        if corners is None or corners.shape != (K, 2, 3):
            raise DataError(
                f"{root / 'urdf_metas.json'}: urdf {inst['urdf_id']} needs corner_pts of shape ({K}, 2, 3) "
                "(min and max corner per link)"
            )
        joints = _joint_table(meta, K, f"{root / 'urdf_metas.json'} (urdf {inst['urdf_id']})", spec_joints)
        cam_from_part, size, sims = np.zeros((K, 4, 4)), np.zeros((K, 3)), []
        for k, ln in enumerate(links):
            s, R, t = decompose_similarity(ln.get("transformation"), f"{f}: link {k}")
            lo, hi = corners[k]
            if np.any(hi < lo):
                raise DataError(f"{root / 'urdf_metas.json'}: corner_pts of link {k} has max < min")
            cam_from_part[k] = np.eye(4)
            cam_from_part[k, :3, :3] = R
            cam_from_part[k, :3, 3] = s * R @ (0.5 * (lo + hi)) + t
            size[k] = s * (hi - lo)
            sims.append((s, R, t))
        piv, ax, state = np.zeros((K - 1, 3)), np.zeros((K - 1, 3)), np.zeros(K - 1)
        for i, j in enumerate(joints):
            s, R, t = sims[j["parent"]]
            piv[i] = s * R @ j["xyz"] + t
            ax[i] = R @ j["axis"]
            try:
                q = float(links[j["child"]]["state"])
            except (KeyError, TypeError, ValueError):
                raise DataError(f"{f}: link {j['child']} needs a numeric 'state' (its joint's state)") from None
            state[i] = np.radians(q) if j["type"] == "revolute" else sims[j["child"]][0] * q
        gt = {
            "cam_from_part": cam_from_part,
            "size_m": size,
            "joint_type": np.array([JOINT_CODES[j["type"]] for j in joints], np.int64),
            "joint_pivot": piv,
            "joint_axis": ax,
            "joint_state": state,
            "frame": rel,
            "urdf_id": int(inst["urdf_id"]),
        }
        sample = sample_from_pixels(
            depth, K_cam, labels, gt, category, f"{rel}/{int(inst.get('id', 0))}", len(samples), max_points
        )
        if sample is None:
            skipped.append(rel)
            continue
        samples.append(sample)
    if skipped:
        warnings.warn(
            f"skipped {len(skipped)} ArtImage object(s) with fewer than 32 measured pixels (first: {skipped[0]})", stacklevel=2
        )
    if not samples:
        raise DataError(f"{root}: no object with enough measured pixels")
    return samples
