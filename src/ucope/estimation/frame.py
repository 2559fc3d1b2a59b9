"""Several objects in one frame, each with its model, in one call: an instance mask with several ids over a
depth image, or a segmented cloud whose points carry instance ids.

:func:`predict_frame` back-projects each instance's pixels of a depth image (:func:`rgbd_points`),
:func:`predict_cloud` takes each instance's points of a cloud; both run the instance's model's
:class:`Estimator` and return a :class:`FrameResult`: one :class:`FrameObject` per instance (its id,
model, result, or why it has none), saved as one JSON file (``format: "ucope-results/1"``, schema
``$defs/results`` of :func:`ucope.estimation.result.result_schema`)::

    {"format": "ucope-results/1", "ucope_version": "0.2.0",
     "objects": [{"instance_id": 1, "model": "mug", "num_pixels": 5321, "result": {...ucope-result/2...}},
                 {"instance_id": 2, "model": "laptop", "num_pixels": 12, "result": null,
                  "error": "..."}],
     "source": {"depth": ..., "mask": ..., "intrinsics": [fx, fy, cx, cy], "image_size": [W, H], "depth_scale": 1000.0},
     "timings_ms": {"total": ...}}

A cloud's objects carry ``num_points`` instead of ``num_pixels``, and its ``source`` names the ``input`` file.
Frames and units: camera frame (OpenCV), metres; the depth image in raw units (``depth / depth_scale``
= metres).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError
from ..fileio import atomic_write_json, read_json
from ..versions import RESULTS_FORMAT, __version__
from .inputs import rgbd_points
from .result import PoseResult

__all__ = ["RESULTS_FORMAT", "FrameObject", "FrameResult", "predict_frame", "predict_cloud", "parse_instance_models"]


@dataclass
class FrameObject:
    """One instance of a frame: its id in the instance mask (or the cloud's ids), the model that estimated
    it, its result (``None`` when it could not be estimated, ``error`` then says why) and its measured
    pixels (a depth frame) or points (a segmented cloud: ``num_points``)."""

    instance_id: int
    model: str
    result: PoseResult | None
    num_pixels: int = 0
    error: str | None = None
    points: np.ndarray | None = field(default=None, repr=False)  # (N, 3) the cloud it was estimated from (not saved)
    num_points: int | None = None

    def to_dict(self) -> dict:
        d = {
            "instance_id": int(self.instance_id),
            "model": self.model,
            "result": None if self.result is None else self.result.to_dict(),
        }
        if self.num_points is None:
            d["num_pixels"] = int(self.num_pixels)
        else:
            d["num_points"] = int(self.num_points)
        if self.error is not None:
            d["error"] = self.error
        return d


@dataclass
class FrameResult:
    """Every object of one frame (see the module docstring for the JSON form)."""

    objects: list[FrameObject]
    source: dict = field(default_factory=dict)
    timings_ms: dict = field(default_factory=dict)

    @property
    def results(self) -> list[PoseResult]:
        """The results of the objects that have one, in instance order."""
        return [o.result for o in self.objects if o.result is not None]

    def to_dict(self) -> dict:
        return {
            "format": RESULTS_FORMAT,
            "objects": [o.to_dict() for o in self.objects],
            "source": dict(self.source),
            "timings_ms": {k: round(float(v), 3) for k, v in self.timings_ms.items()},
            "ucope_version": __version__,
        }

    @classmethod
    def from_dict(cls, d: dict) -> FrameResult:
        if not isinstance(d, dict) or d.get("format") != RESULTS_FORMAT:
            raise DataError(
                f"not a ucope frame result (format {d.get('format') if isinstance(d, dict) else None!r}, "
                f"expected {RESULTS_FORMAT!r})"
            )
        try:
            objs = [
                FrameObject(
                    instance_id=int(o["instance_id"]),
                    model=str(o["model"]),
                    result=None if o.get("result") is None else PoseResult.from_dict(o["result"]),
                    num_pixels=int(o.get("num_pixels", 0)),
                    error=o.get("error"),
                    num_points=None if o.get("num_points") is None else int(o["num_points"]),
                )
                for o in d["objects"]
            ]
        except (KeyError, TypeError, ValueError) as e:
            raise DataError(f"malformed ucope frame result: {e}") from None
        return cls(objs, dict(d.get("source", {})), dict(d.get("timings_ms", {})))

    def save(self, path: str | os.PathLike) -> Path:
        """Write the JSON form to ``path`` atomically (folders created)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, self.to_dict())
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> FrameResult:
        return cls.from_dict(read_json(path))


def parse_instance_models(specs) -> dict[int, str]:
    """``{instance id: model}`` from ``["1=mug", "2=laptop"]`` (the ``--instances`` option).

    Raises :class:`InputError` naming the bad entry (not ``ID=MODEL``, a non-integer or negative id,
    an id given twice)."""
    out: dict[int, str] = {}
    for spec in specs:
        key, sep, model = str(spec).partition("=")
        try:
            iid = int(key)
        except ValueError:
            iid = -1
        if not sep or not model or iid < 0:
            raise InputError(f"--instances entries look like ID=MODEL (a mask value and a model, e.g. 1=mug), got {spec!r}")
        if iid in out:
            raise InputError(f"instance id {iid} is given twice ({out[iid]} and {model})")
        out[iid] = model
    if not out:
        raise InputError("give at least one ID=MODEL instance")
    return out


def predict_frame(
    depth,
    intrinsics,
    instance_mask,
    models: Mapping[int, object],
    depth_scale: float = 1000.0,
    estimator_options: Mapping | None = None,
    keep_going: bool = True,
    source: Mapping | None = None,
    up=None,
    box=None,
) -> FrameResult:
    """Estimate every instance of a frame with its own model.

    Args:
        depth: ``(H, W)`` depth image, raw units (``depth / depth_scale`` = metres, 0 = none).
        intrinsics: ``(fx, fy, cx, cy)`` or a 3x3 K.
        instance_mask: ``(H, W)`` integer image; the pixels of instance ``i`` hold ``i``.
        models: ``{instance id: model}``, a model being a shipped model name, a run folder / model JSON,
            or an :class:`~ucope.estimation.estimator.Estimator`. Instances of the same model share one
            loaded estimator.
        estimator_options: keyword arguments of :meth:`Estimator.load` for models given by name.
        keep_going: an instance that cannot be estimated (no or too few measured pixels) gets
            ``result=None`` and an ``error``; ``False`` raises instead.
        source: what to record under ``"source"`` (file names...); intrinsics, image size and depth
            scale are added.
        up: optional ``(3,)`` the world's up direction in the camera frame (see :meth:`Estimator.predict`).
        box: optional ``(x_min, y_min, x_max, y_max)`` pixel box (max exclusive): only the instances'
            pixels inside it are used (a region of interest); ``num_pixels`` counts those.

    Returns:
        a :class:`FrameResult` with one object per entry of ``models``, in increasing id order.

    Raises:
        InputError: shapes that differ, a mask that is not an integer image, an id absent from the
            mask (naming it and the ids the mask holds), a model that cannot be loaded.
    """
    from .estimator import Estimator

    t0 = time.perf_counter()
    d = np.asarray(depth)
    m = np.asarray(instance_mask)
    _check_frame(d, m, models)
    inside = _box_mask(box, d.shape)
    opts = dict(estimator_options or {})
    cache: dict[str, Estimator] = {}
    objects = []
    for iid in sorted(models, key=int):
        est, name = _estimator_for(models[iid], cache, opts)
        sel = (m == int(iid)) & inside
        valid = sel & np.isfinite(d) & (d > 0)
        npix = int(np.count_nonzero(valid))
        try:
            pts = rgbd_points(d, intrinsics, mask=sel, depth_scale=depth_scale)
            res = est.predict(pts, up=up)
            objects.append(FrameObject(int(iid), name, res, npix, points=pts))
        except InputError as e:
            if not keep_going:
                raise InputError(f"instance {iid} ({name}): {e}") from None
            objects.append(FrameObject(int(iid), name, None, npix, error=str(e)))
    K = np.asarray(intrinsics, np.float64)
    if K.shape == (3, 3):
        K = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    src = dict(source or {})
    src.update(
        intrinsics=[float(v) for v in K.reshape(-1)[:4]],
        image_size=[int(d.shape[1]), int(d.shape[0])],
        depth_scale=float(depth_scale),
    )
    return FrameResult(objects, src, {"total": 1e3 * (time.perf_counter() - t0)})


def _check_frame(d: np.ndarray, m: np.ndarray, models: Mapping) -> None:
    """A depth image ``d`` and an integer instance mask ``m`` of its size holding every id of ``models``."""
    if d.ndim != 2:
        raise InputError(f"depth must be an (H, W) image, got shape {d.shape}")
    if m.shape != d.shape:
        raise InputError(f"the instance mask is {m.shape}, the depth image {d.shape}: they must be the same size")
    if not np.issubdtype(m.dtype, np.integer):
        raise InputError(f"the instance mask must hold integer ids, got dtype {m.dtype}")
    if not models:
        raise InputError("no instances given: pass {instance id: model}")
    present = np.unique(m)
    missing = sorted(int(i) for i in models if int(i) not in set(present.tolist()))
    if missing:
        raise InputError(f"instance id(s) {missing} do not occur in the instance mask (it holds {present.tolist()})")


def _box_mask(box, shape: tuple[int, ...]) -> np.ndarray:
    """``(H, W)`` bool: the pixels inside ``box`` ``(x_min, y_min, x_max, y_max)`` (max exclusive; fractional
    bounds widened to whole pixels), or every pixel when ``box`` is ``None``."""
    inside = np.ones(shape, bool)
    if box is None:
        return inside
    b = np.asarray(box, np.float64).reshape(-1)
    if b.shape != (4,) or not np.all(np.isfinite(b)):
        raise InputError(f"box must be 4 finite numbers (x_min, y_min, x_max, y_max), got {box!r}")
    x0, y0, x1, y1 = (int(np.floor(b[0])), int(np.floor(b[1])), int(np.ceil(b[2])), int(np.ceil(b[3])))
    if not (0 <= x0 < x1 <= shape[1] and 0 <= y0 < y1 <= shape[0]):
        raise InputError(f"box {b.tolist()} is not a box inside the {shape[1]}x{shape[0]} image")
    inside[:] = False
    inside[y0:y1, x0:x1] = True
    return inside


def _estimator_for(spec, cache: dict, opts: dict):
    """``(estimator, name)`` of a model spec (an :class:`Estimator`, or a name loaded once per name)."""
    from .estimator import Estimator

    if isinstance(spec, Estimator):
        return spec, spec.name
    name = str(spec)
    if name not in cache:
        cache[name] = Estimator.load(name, **opts)
    return cache[name], name


def predict_cloud(
    points,
    instance_ids,
    models: Mapping[int, object],
    normals=None,
    units: str = "m",
    estimator_options: Mapping | None = None,
    keep_going: bool = True,
    source: Mapping | None = None,
    up=None,
) -> FrameResult:
    """Estimate every instance of a segmented cloud with its own model.

    Args:
        points: ``(N, 3)`` the cloud, camera frame, in ``units``.
        instance_ids: ``(N,)`` integer id of every point (:func:`ucope.data.readers.clouds.read_segmented_cloud`).
        models: ``{instance id: model}`` (as :func:`predict_frame`).
        normals: optional ``(N, 3)`` normals.
        units: ``"m"``, ``"cm"`` or ``"mm"`` (results in metres).
        keep_going: an instance that cannot be estimated gets ``result=None`` and an ``error``;
            ``False`` raises instead.
        source: what to record under ``"source"`` (e.g. ``{"input": path}``).

    Returns:
        a :class:`FrameResult`, one object per entry of ``models`` in increasing id order, with
        ``num_points`` (the points of that id) and ``points`` (in metres, for pictures).

    Raises:
        InputError: points and ids of different lengths, ids that are not integers, an id absent from the
            cloud (naming the ids it holds), a model that cannot be loaded.
    """
    from .inputs import UNITS

    t0 = time.perf_counter()
    P = np.asarray(points, np.float64)
    ids = np.asarray(instance_ids)
    if P.ndim != 2 or P.shape[1] != 3:
        raise InputError(f"points must be (N, 3), got shape {P.shape}")
    if ids.shape != (len(P),) or not np.issubdtype(ids.dtype, np.integer):
        raise InputError(f"instance_ids must be ({len(P)},) integers (one per point), got shape {ids.shape} dtype {ids.dtype}")
    N = None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3)
    if N is not None and len(N) != len(P):
        raise InputError(f"normals has {len(N)} rows, points {len(P)}")
    if units not in UNITS:
        raise InputError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
    if not models:
        raise InputError("no instances given: pass {instance id: model}")
    present = set(np.unique(ids).tolist())
    missing = sorted(int(i) for i in models if int(i) not in present)
    if missing:
        raise InputError(f"instance id(s) {missing} do not occur in the cloud's instance ids (it holds {sorted(present)})")
    opts = dict(estimator_options or {})
    cache: dict = {}
    objects = []
    for iid in sorted(models, key=int):
        est, name = _estimator_for(models[iid], cache, opts)
        sel = ids == int(iid)
        pts = P[sel]
        try:
            res = est.predict(pts, None if N is None else N[sel], units=units, up=up)
            objects.append(FrameObject(int(iid), name, res, points=pts * UNITS[units], num_points=int(sel.sum())))
        except InputError as e:
            if not keep_going:
                raise InputError(f"instance {iid} ({name}): {e}") from None
            objects.append(FrameObject(int(iid), name, None, error=str(e), num_points=int(sel.sum())))
    return FrameResult(objects, dict(source or {}), {"total": 1e3 * (time.perf_counter() - t0)})
