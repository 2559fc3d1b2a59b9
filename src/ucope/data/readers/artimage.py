"""ArtImage / ReArt annotation files -> ucope samples (a cloud per articulated object, its parts' and joints'
ground truth in ucope's frames).

The layout is the one the data sets' authors publish and their loaders read (ReArt's ``ArtiImgDataset``
and its pipelines, the OMAD / ArtImage loaders); the field names are theirs. Every deviation raises
:class:`~ucope.errors.DataError` naming the file and the field::

    DIR/                                   one category (one split)
      camera_intrinsic.json                Open3D's PinholeCameraIntrinsic: {"width": W, "height": H,
                                           "intrinsic_matrix": [fx, 0, 0, 0, fy, 0, cx, cy, 1]} (column-major)
      urdf_metas.json                      {"urdf_metas": [{"id": U,
                                              "norm_factors": [K + 1 numbers],                 (not needed)
                                              "corner_pts": (K + 1, 2, 1, 3): [0] the whole object, [i] the
                                                            i-th link (1-based); [min corner, max corner],
                                                            the object's rest frame,
                                              "joint_types": ["revolute" | "prismatic", ...],
                                              "joint_parents": [link ids], "joint_children": [link ids],
                                              "joint_xyz": [[a, b, c], ...],  a point on the axis  } both in URDF axis
                                              "joint_rpy": [[a, b, c], ...]}  the axis direction  } order, see below
                                           ]}
      depth/<scene>/<name>.png             uint16 depth in millimetres (0 = none)
      color/<scene>/<name>.jpg             (not read)
      annotations/<scene>/<name>.json      {"color_path": ..., "depth_path": "<scene>/<name>.png",
                                            "width": W, "height": H,
                                            "instances": [{"id": i, "urdf_id": U, "category_id": c, "bbox": [...],
                                              "links": [{"link_category_id": l,
                                                         "transformation": 4x4 rows,
                                                         "segmentation": COCO polygons or RLE,
                                                         "state": ...}, ...]}, ...]}

How it is read:

* **Several instances per image**: every instance whose ``urdf_id`` is in ``urdf_metas.json`` becomes a
  sample (others, such as objects of other categories, are skipped with a warning).
* **Link ids**: ``link_category_id`` is 1-based (``1 .. K``, ReArt); ``0 .. K - 1`` (ArtImage's renders)
  is accepted too, told apart per instance. Links in increasing id order are ucope's parts ``0 .. K - 1``
  (the category's part order: laptop base, lid; drawer cabinet, top, middle, bottom drawer...), and
  ``joint_parents`` / ``joint_children`` use the same ids.
* **Boxes**: ``corner_pts[i]`` (``(2, 1, 3)`` or ``(2, 3)``) is the i-th link's box in the object's rest
  frame, ``corner_pts[0]`` the whole object's.
* **Link frames**: every link's coordinates are the object's rest frame; ``transformation`` maps them to
  the camera (OpenCV axes, metres; a uniform scale is allowed) at the image's configuration. The rest
  frame's axes are taken to be the category's canonical axes (docs/conventions.md: y up, x right, z
  towards the front), the rest state ucope's state 0. Part ``k``:
  ``cam_from_part = transformation @ [I | box centre]`` (scale taken out), ``size_m = scale * (max - min)``.
* **Joints**: ``joint_xyz`` and ``joint_rpy`` (an axis direction, despite its name) are stored in URDF
  axis order; as the authors' loader reads them, a stored ``[a, b, c]`` is the rest-frame vector
  ``(b, c, a)``. Pivot ``transformation_parent @ xyz``, axis ``R_parent @ axis`` in the camera.
* **States** come from the joint values the link poses imply: the child's motion relative to its parent,
  ``inv(transformation_parent) @ transformation_child``, is a turn about the joint axis (its signed
  angle, radians) or a slide along it (its length times the scale, metres). A motion that is not one
  (more than :data:`JOINT_FIT_TOL_DEG` off the axis, or a slide that turns) is reported as a warning and
  its residual kept in the sample (``joint_fit_residual``). The links' own ``state`` field, where
  present, is not used.
* **Pixels**: a link's pixels are its ``segmentation``: COCO polygons ``[[x0, y0, x1, y1, ...], ...]`` or
  RLE (``{"size": [H, W], "counts": [...] | "compressed string"}``, column-major as COCO's). A link
  without one has no pixels.
* ``depth_path`` is relative to ``DIR/depth`` (or to ``DIR``) and must stay inside ``DIR``: an absolute
  path, ``..`` or a link leading out is refused.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import DataError
from .common import finite_array, inside_root, read_data_json, read_depth, sample_from_pixels

__all__ = [
    "read_artimage",
    "read_open3d_intrinsics",
    "decompose_similarity",
    "polygon_mask",
    "rle_mask",
    "urdf_vector",
    "JOINT_FIT_TOL_DEG",
]

JOINT_CODES = {"revolute": 0, "prismatic": 1}

JOINT_FIT_TOL_DEG = 2.0
"""Largest angle (degrees) a child's motion may turn off its joint's axis (or turn at all, for a slide)
before the reader warns that the link poses do not follow the joint."""


def urdf_vector(v) -> np.ndarray:
    """The rest-frame vector of a ``joint_xyz`` / ``joint_rpy`` entry ``[a, b, c]``: ``(b, c, a)`` (the
    authors' loader's reordering of URDF axes)."""
    a = np.asarray(v, np.float64)
    return a[..., [1, 2, 0]]


def _int(v, where: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int | np.integer):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        raise DataError(f"{where}: must be an integer, got {v!r}")
    return int(v)


def read_open3d_intrinsics(path: str | Path) -> tuple[tuple[float, float, float, float], tuple[int, int]]:
    """``((fx, fy, cx, cy), (H, W))`` from an Open3D ``PinholeCameraIntrinsic`` JSON."""
    d = read_data_json(path, "camera intrinsics (Open3D's camera_intrinsic.json)")
    if not isinstance(d, dict) or "intrinsic_matrix" not in d:
        raise DataError(f"{path}: expected {{'width', 'height', 'intrinsic_matrix': [9 values, column-major]}}")
    m = finite_array(d["intrinsic_matrix"], (9,), f"{path}: intrinsic_matrix").reshape(3, 3).T  # column-major on disk
    W, H = _int(d.get("width"), f"{path}: width"), _int(d.get("height"), f"{path}: height")
    K = (float(m[0, 0]), float(m[1, 1]), float(m[0, 2]), float(m[1, 2]))
    if not (K[0] > 0 and K[1] > 0 and W > 0 and H > 0):
        raise DataError(f"{path}: intrinsics need positive focal lengths and image size, got {K} {W}x{H}")
    return K, (H, W)


def decompose_similarity(M, where: str) -> tuple[float, np.ndarray, np.ndarray]:
    """``(s, R, t)`` of a 4x4 similarity ``[s R | t]``; :class:`DataError` naming ``where`` otherwise."""
    M = finite_array(M, (4, 4), f"{where}: transformation", "a 4x4 matrix of numbers")
    if np.abs(M[3] - [0.0, 0.0, 0.0, 1.0]).max() > 1e-6:
        raise DataError(f"{where}: transformation's last row must be [0, 0, 0, 1], got {M[3].tolist()}")
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
    if not isinstance(polygons, list):
        raise DataError(f"{where}: segmentation must be a list of [x0, y0, x1, y1, ...] polygons or an RLE object")
    for i, poly in enumerate(polygons):
        xy = finite_array(poly, (-1,), f"{where}: segmentation[{i}]", "polygon coordinates")
        if len(xy) % 2:
            raise DataError(f"{where}: segmentation[{i}] has an odd number of coordinates ({len(xy)})")
        if len(xy) >= 6:
            draw.polygon([tuple(p) for p in xy.reshape(-1, 2).tolist()], fill=1, outline=1)
    return np.array(img, dtype=bool)


def _coco_counts(text: str, where: str) -> np.ndarray:
    """The run lengths of COCO's compressed RLE string (``rleFrString``: 5 bits per character, a
    continuation bit, sign extension, counts after the second stored as differences)."""
    try:
        b = np.frombuffer(text.encode("ascii"), np.uint8).astype(np.int64) - 48
    except UnicodeEncodeError:
        raise DataError(f"{where}: the RLE counts string is not ASCII") from None
    if b.size == 0:
        return np.zeros(0, np.int64)
    if (b < 0).any() or (b > 63).any():
        raise DataError(f"{where}: the RLE counts string holds characters outside COCO's alphabet")
    more = (b & 0x20) != 0
    if more[-1]:
        raise DataError(f"{where}: the RLE counts string ends inside a number")
    ends = np.flatnonzero(~more)
    starts = np.r_[0, ends[:-1] + 1]
    group = np.repeat(np.arange(len(ends)), ends - starts + 1)
    pos = np.arange(len(b)) - starts[group]
    if pos.max() > 10:
        raise DataError(f"{where}: the RLE counts string holds a number too long to be a run length")
    vals = np.zeros(len(ends), np.int64)
    np.add.at(vals, group, (b & 0x1F) << (5 * pos))
    neg = (b[ends] & 0x10) != 0
    vals[neg] -= np.int64(1) << (5 * (pos[ends][neg] + 1))
    out = vals.copy()
    if len(out) > 2:
        out[2::2] = np.cumsum(vals[2::2])
        out[1::2] = vals[1] + np.r_[0, np.cumsum(vals[3::2])]
    return out


def rle_mask(rle, shape: tuple[int, int], where: str) -> np.ndarray:
    """``(H, W)`` bool mask of a COCO RLE (``{"size": [H, W], "counts": list | compressed string}``,
    column-major runs starting with background)."""
    H, W = shape
    size = rle.get("size")
    if not (isinstance(size, list) and len(size) == 2 and [_int(v, f"{where}: segmentation.size") for v in size] == [H, W]):
        raise DataError(f"{where}: segmentation.size must be the image size [{H}, {W}], got {size!r}")
    counts = rle.get("counts")
    if isinstance(counts, str):
        c = _coco_counts(counts, f"{where}: segmentation.counts")
    else:
        c = finite_array(counts, (-1,), f"{where}: segmentation.counts", "run lengths")
        if np.any(c != np.round(c)):
            raise DataError(f"{where}: segmentation.counts must be whole numbers")
        c = c.astype(np.int64)
    if (c < 0).any() or int(c.sum()) != H * W:
        raise DataError(
            f"{where}: segmentation.counts must be run lengths >= 0 summing to {H} x {W} = {H * W}, got {int(c.sum())}"
        )
    on = np.zeros(len(c), bool)
    on[1::2] = True
    return np.repeat(on, c).reshape(W, H).T


def _segmentation_mask(seg, shape: tuple[int, int], where: str) -> np.ndarray:
    if isinstance(seg, dict):
        return rle_mask(seg, shape, where)
    if isinstance(seg, list) and seg and all(isinstance(s, dict) for s in seg):
        out = np.zeros(shape, bool)
        for i, s in enumerate(seg):
            out |= rle_mask(s, shape, f"{where}[{i}]")
        return out
    return polygon_mask(seg, shape, where)


def _urdf_metas(path: Path) -> dict[int, dict]:
    d = read_data_json(path, "URDF metadata (urdf_metas.json)")
    if not isinstance(d, dict) or not isinstance(d.get("urdf_metas"), list):
        raise DataError(f"{path}: expected {{'urdf_metas': [...]}}")
    out = {}
    for i, m in enumerate(d["urdf_metas"]):
        if isinstance(m, list) and not m:  # the authors' files hold empty placeholders
            continue
        if not isinstance(m, dict):
            raise DataError(f"{path}: urdf_metas[{i}] must be an object, got {type(m).__name__}")
        if "id" not in m:
            raise DataError(f"{path}: urdf_metas[{i}] has no 'id'")
        out[_int(m["id"], f"{path}: urdf_metas[{i}].id")] = m
    return out


class _Urdf:
    """One ``urdf_metas`` entry checked against a category: boxes per part, joints in ucope's order."""

    def __init__(self, meta: dict, K: int, spec_joints, where: str):
        if "corner_pts" not in meta:
            raise DataError(f"{where}: needs corner_pts")
        try:
            corners = np.asarray(meta["corner_pts"], np.float64)
        except (TypeError, ValueError):
            raise DataError(
                f"{where}: corner_pts must be a ({K + 1}, 2, 1, 3) array of numbers (ragged or not numbers)"
            ) from None
        if corners.shape == (K + 1, 2, 1, 3):
            corners = corners[:, :, 0]
        if corners.shape != (K + 1, 2, 3):
            raise DataError(
                f"{where}: corner_pts must have shape ({K + 1}, 2, 1, 3) (the whole object, then {K} links), got {corners.shape}"
            )
        if not np.all(np.isfinite(corners)):
            raise DataError(f"{where}: corner_pts must be finite, got NaN or Inf")
        if np.any(corners[:, 1] < corners[:, 0]):
            raise DataError(f"{where}: corner_pts has a box whose max corner is below its min corner")
        self.corners = corners[1:]  # (K, 2, 3): ucope part k
        self.diag = float(np.linalg.norm(corners[0, 1] - corners[0, 0]))
        keys = ("joint_types", "joint_parents", "joint_children", "joint_xyz", "joint_rpy")
        missing = [k for k in keys if k not in meta]
        if missing:
            raise DataError(f"{where}: needs {', '.join(keys)} (missing {', '.join(missing)})")
        lists = [meta[k] for k in keys]
        if not all(isinstance(v, list) for v in lists) or len({len(v) for v in lists}) != 1 or len(lists[0]) != K - 1:
            raise DataError(
                f"{where}: a {K}-part object needs {K - 1} entries in each of {', '.join(keys)}, got "
                f"{[len(v) if isinstance(v, list) else type(v).__name__ for v in lists]}"
            )
        self.types = [str(t) for t in meta["joint_types"]]
        self.parents = [_int(v, f"{where}: joint_parents[{i}]") for i, v in enumerate(meta["joint_parents"])]
        self.children = [_int(v, f"{where}: joint_children[{i}]") for i, v in enumerate(meta["joint_children"])]
        self.xyz = urdf_vector(finite_array(meta["joint_xyz"], (K - 1, 3), f"{where}: joint_xyz"))
        self.axis = urdf_vector(finite_array(meta["joint_rpy"], (K - 1, 3), f"{where}: joint_rpy"))
        self.K, self.spec_joints, self.where = K, spec_joints, where

    def joints(self, base: int) -> list[dict]:
        """The joints in ucope's order, for link ids starting at ``base`` (0 or 1)."""
        by_child = {c - base: i for i, c in enumerate(self.children)}
        out = []
        for parent, child, jtype in self.spec_joints:
            i = by_child.get(child)
            if i is None or self.parents[i] - base != parent:
                raise DataError(
                    f"{self.where}: no joint from link {parent + base} to link {child + base} "
                    f"(joint_parents {self.parents}, joint_children {self.children}, link ids from {base})"
                )
            if self.types[i] != jtype:
                raise DataError(
                    f"{self.where}: the joint of link {child + base} is {self.types[i]!r}; this category's is {jtype!r}"
                )
            n = float(np.linalg.norm(self.axis[i]))
            if not n > 1e-9:
                raise DataError(f"{self.where}: joint_rpy of link {child + base} (its axis) is zero")
            out.append({"type": jtype, "parent": parent, "child": child, "xyz": self.xyz[i], "axis": self.axis[i] / n})
        return out


def _joint_state(
    jtype: str, rel: np.ndarray, xyz: np.ndarray, axis: np.ndarray, scale: float, diag: float
) -> tuple[float, float]:
    """``(state, residual_deg)`` of a child's rest-frame motion ``rel`` (4x4, parent -> child) about /
    along a joint; the residual is how far the motion's rotation turns off the axis (a slide: how far
    it turns at all), plus, for a turn, how far its translation is off a turn about the pivot, as an
    angle seen from the object's diagonal ``diag`` (rest-frame units)."""
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(rel[:3, :3]).as_rotvec()
    if jtype == "prismatic":
        return float(scale * rel[:3, 3] @ axis), float(np.degrees(np.linalg.norm(rotvec)))
    q = float(rotvec @ axis)
    off = float(np.degrees(np.linalg.norm(rotvec - q * axis)))
    R = rel[:3, :3]
    t_turn = xyz - R @ xyz  # a turn about the axis through the pivot moves the origin by this
    return q, off + float(np.degrees(np.linalg.norm(rel[:3, 3] - t_turn) / max(diag, 1e-9)))


def read_artimage(
    root: str | Path,
    category: str,
    max_points: int = 4096,
    intrinsics: str | Path | None = None,
    urdf_metas: str | Path | None = None,
) -> list[dict]:
    """Every annotated object under ``root`` (the layout of the module docstring) as a ucope sample.

    Args:
        root: the category's folder (``camera_intrinsic.json``, ``urdf_metas.json``, ``annotations/``,
            ``depth/``).
        category: the ucope category (laptop, eyeglasses, dishwasher, scissors, drawer): its part count
            and joints are checked against each object.
        max_points: clouds are subsampled (deterministically) to this many points.
        intrinsics: the Open3D ``camera_intrinsic.json`` (default ``root/camera_intrinsic.json``).
        urdf_metas: the ``urdf_metas.json`` (default ``root/urdf_metas.json``).

    Returns:
        samples (:mod:`ucope.data.sample` fields) in file and instance order, with ``frame`` (the
        annotation's path below ``annotations/``), ``urdf_id``, ``artimage_instance`` (the instance's
        ``id``) and ``joint_fit_residual`` (degrees, see the module docstring). Objects with fewer than
        32 measured pixels are skipped with a warning.

    Raises:
        DataError: a missing or corrupt file, a field of the wrong type or shape, NaN or Inf, a
            transformation that is not a similarity, a link or joint count other than the category's, a
            ``depth_path`` leading outside ``root`` (each naming the file and the field).
        InputError: an unknown category.
    """
    from ...objects.categories import get_category, make_instance

    root = Path(root)
    spec = get_category(category)
    K = spec.num_parts
    spec_joints = [(j.parent, j.child, j.type) for j in make_instance(category, "test", 0).joints]
    if not root.is_dir():
        raise DataError(
            f"{root} is not a folder (expected an ArtImage / ReArt category folder with annotations/, depth/, urdf_metas.json)"
        )
    ann_dir = root / "annotations"
    files = sorted(ann_dir.rglob("*.json")) if ann_dir.is_dir() else []
    if not files:
        raise DataError(f"{ann_dir} holds no annotation JSON files (annotations/<scene>/<name>.json)")
    K_cam, shape = read_open3d_intrinsics(intrinsics if intrinsics is not None else root / "camera_intrinsic.json")
    metas_path = Path(urdf_metas) if urdf_metas is not None else root / "urdf_metas.json"
    metas = _urdf_metas(metas_path)
    urdfs: dict[int, _Urdf] = {}
    samples, skipped, foreign, bad_joints = [], [], [], []
    for f in files:
        a = read_data_json(f, "ArtImage / ReArt annotation")
        rel = f.relative_to(ann_dir).with_suffix("").as_posix()
        if not isinstance(a, dict):
            raise DataError(f"{f}: an annotation must be a JSON object, got {type(a).__name__}")
        missing = [k for k in ("width", "height", "depth_path", "instances") if k not in a]
        if missing:
            raise DataError(f"{f}: needs width, height, depth_path and instances (missing {', '.join(missing)})")
        W, H = _int(a["width"], f"{f}: width"), _int(a["height"], f"{f}: height")
        if (H, W) != shape:
            raise DataError(f"{f}: the image is {W}x{H}, the camera intrinsics say {shape[1]}x{shape[0]}")
        if not isinstance(a["instances"], list):
            raise DataError(f"{f}: instances must be a list, got {type(a['instances']).__name__}")
        depth = None
        for n, inst in enumerate(a["instances"]):
            w_inst = f"{f}: instances[{n}]"
            if not isinstance(inst, dict):
                raise DataError(f"{w_inst}: must be an object, got {type(inst).__name__} {inst!r}")
            if "urdf_id" not in inst or "links" not in inst:
                raise DataError(f"{w_inst}: needs urdf_id and links")
            uid = _int(inst["urdf_id"], f"{w_inst}.urdf_id")
            if uid not in metas:
                foreign.append(f"{rel} instance {n} (urdf_id {uid})")
                continue
            links = inst["links"]
            if not isinstance(links, list) or not all(isinstance(ln, dict) for ln in links):
                raise DataError(f"{w_inst}.links: must be a list of objects")
            for i, ln in enumerate(links):
                if "link_category_id" not in ln:
                    raise DataError(f"{w_inst}.links[{i}]: needs link_category_id")
            ids = [_int(ln["link_category_id"], f"{w_inst}.links[{i}].link_category_id") for i, ln in enumerate(links)]
            if sorted(ids) == list(range(1, K + 1)):
                base = 1
            elif sorted(ids) == list(range(K)):
                base = 0
            else:
                raise DataError(
                    f"{w_inst}: a {category} has {K} links with link_category_id 1..{K} (or 0..{K - 1}), got {sorted(ids)}"
                )
            by_part = [links[ids.index(k + base)] for k in range(K)]
            if uid not in urdfs:
                urdfs[uid] = _Urdf(metas[uid], K, spec_joints, f"{metas_path} (urdf {uid})")
            urdf = urdfs[uid]
            joints = urdf.joints(base)
            if depth is None:
                depth_path = inside_root(root, a["depth_path"], "depth image", f"{f}: depth_path", ("depth", ""))
                depth = read_depth(depth_path, shape).astype(np.float64) / 1000.0
            labels = np.full(shape, -1, np.int64)
            sims = []
            cam_from_part, size = np.zeros((K, 4, 4)), np.zeros((K, 3))
            for k, ln in enumerate(by_part):
                w_link = f"{w_inst}.links[{ids.index(k + base)}] (link {k + base})"
                if "transformation" not in ln:
                    raise DataError(f"{w_link}: needs transformation")
                s, R, t = decompose_similarity(ln["transformation"], w_link)
                lo, hi = urdf.corners[k]
                cam_from_part[k] = np.eye(4)
                cam_from_part[k, :3, :3] = R
                cam_from_part[k, :3, 3] = s * R @ (0.5 * (lo + hi)) + t
                size[k] = s * (hi - lo)
                sims.append((s, R, t))
                seg = ln.get("segmentation")
                if seg:
                    labels[_segmentation_mask(seg, shape, f"{w_link}.segmentation")] = k
            piv, ax, state = np.zeros((K - 1, 3)), np.zeros((K - 1, 3)), np.zeros(K - 1)
            residual = np.zeros(K - 1)
            for i, j in enumerate(joints):
                s, R, t = sims[j["parent"]]
                piv[i] = s * R @ j["xyz"] + t
                ax[i] = R @ j["axis"]
                sc, Rc, tc = sims[j["child"]]
                Tp, Tc = np.eye(4), np.eye(4)
                Tp[:3, :3], Tp[:3, 3] = s * R, t
                Tc[:3, :3], Tc[:3, 3] = sc * Rc, tc
                rel_motion = np.linalg.inv(Tp) @ Tc
                rel_motion[:3, :3] /= np.cbrt(max(np.linalg.det(rel_motion[:3, :3]), 1e-12))
                state[i], residual[i] = _joint_state(j["type"], rel_motion, j["xyz"], j["axis"], s, urdf.diag)
            if residual.size and residual.max() > JOINT_FIT_TOL_DEG:
                bad_joints.append(f"{rel} instance {n} ({residual.max():.1f} deg)")
            gt = {
                "cam_from_part": cam_from_part,
                "size_m": size,
                "joint_type": np.array([JOINT_CODES[j["type"]] for j in joints], np.int64),
                "joint_pivot": piv,
                "joint_axis": ax,
                "joint_state": state,
                "frame": rel,
                "urdf_id": uid,
                "artimage_instance": inst.get("id", n),
                "joint_fit_residual": residual,
            }
            sample = sample_from_pixels(
                depth, K_cam, labels, gt, category, f"{rel}/{inst.get('id', n)}", len(samples), max_points
            )
            if sample is None:
                skipped.append(f"{rel} instance {n}")
                continue
            samples.append(sample)
    if foreign:
        warnings.warn(
            f"skipped {len(foreign)} instance(s) whose urdf_id is not in {metas_path} (first: {foreign[0]})", stacklevel=2
        )
    if bad_joints:
        warnings.warn(
            f"{len(bad_joints)} object(s) whose link poses do not move about / along their joints within "
            f"{JOINT_FIT_TOL_DEG} deg (first: {bad_joints[0]}); their joint states are the projections on the axes",
            stacklevel=2,
        )
    if skipped:
        warnings.warn(
            f"skipped {len(skipped)} ArtImage object(s) with fewer than 32 measured pixels (first: {skipped[0]})", stacklevel=2
        )
    if not samples:
        raise DataError(f"{root}: no {category} object with enough measured pixels")
    return samples
