"""Depth / mask PNGs and BOP-style ``scene_camera.json`` / ``scene_gt.json`` for generated views.

Layout under ``<out>/images``: ``depth/NNNNNN.png`` (uint16, millimetres, 0 = no return),
``mask/NNNNNN.png`` (uint8: part index, 254 = distractor, 255 = background), and the two BOP JSON
files keyed by image id (= sample index): ``cam_K`` row-wise with ``depth_scale = 1.0`` (mm), and per
part ``obj_id`` (= part index + 1), ``cam_R_m2c`` (row-wise) and ``cam_t_m2c`` (millimetres), where the
"model" frame is the part's canonical frame. Needs Pillow (``pip install "ucope[images]"``).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError
from ..fileio import atomic_write_bytes, atomic_write_json, read_json

__all__ = ["write_png", "read_png", "bop_entries", "merge_bop_parts"]


def _pil():
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - depends on the environment
        raise InputError('writing or reading PNG images needs Pillow: pip install "ucope[images]"') from None
    return Image


def write_png(path: str | Path, image: np.ndarray) -> None:
    """Write a ``(H, W)`` uint8 or uint16 image as a lossless PNG, atomically."""
    Image = _pil()
    img = np.asarray(image)
    if img.ndim != 2 or img.dtype not in (np.uint8, np.uint16):
        raise InputError(f"PNG image must be (H, W) uint8 or uint16, got {img.shape} {img.dtype}")
    pil = Image.fromarray(img.astype("<u2") if img.dtype == np.uint16 else img)
    buf = io.BytesIO()
    pil.save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())


def read_png(path: str | Path) -> np.ndarray:
    """Read a single-channel PNG as uint8 or uint16; a missing or corrupt file raises :class:`DataError`."""
    Image = _pil()
    try:
        with Image.open(path) as im:
            arr = np.array(im)
    except FileNotFoundError:
        raise DataError(f"{path} does not exist") from None
    except Exception as e:  # PIL raises many types for corrupt files
        raise DataError(f"{path} is not a readable PNG image ({e})") from None
    if arr.dtype == np.int32:  # 16-bit PNGs may come back as mode "I"
        arr = arr.astype(np.uint16)
    return arr


def bop_entries(sample: dict) -> tuple[dict, list[dict]]:
    """The ``scene_camera`` and ``scene_gt`` entries of one sample."""
    fx, fy, cx, cy = (float(v) for v in sample["intrinsics"])
    cam = {"cam_K": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0], "depth_scale": 1.0}
    gt = []
    for k, T in enumerate(np.asarray(sample["cam_from_part"])):
        gt.append(
            {
                "obj_id": k + 1,
                "cam_R_m2c": [float(v) for v in T[:3, :3].reshape(-1)],
                "cam_t_m2c": [float(v) * 1000.0 for v in T[:3, 3]],
            }
        )
    return cam, gt


def merge_bop_parts(images_dir: Path, part_files: list[Path]) -> None:
    """Merge per-shard partial JSON files into ``scene_camera.json`` and ``scene_gt.json``."""
    cams, gts = {}, {}
    for p in part_files:
        d = read_json(p)
        cams.update(d["scene_camera"])
        gts.update(d["scene_gt"])
    order = sorted(cams, key=int)
    atomic_write_json(images_dir / "scene_camera.json", {k: cams[k] for k in order})
    atomic_write_json(images_dir / "scene_gt.json", {k: gts[k] for k in order})
