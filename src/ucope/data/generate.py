"""Synthetic data-set generation: sharded, atomic, resumable and deterministic.

Sample ``i`` of a data set depends only on ``(category, split, seed, i)`` and the settings in
``meta.json``: instance ``i // views_per_instance`` of the split, and a view drawn from a random stream
of its own. So any number of workers, or of machines each generating a range of shards, writes the
same files.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError, InputError
from ..fileio import atomic_write_json, read_json
from ..objects.categories import SPLITS, check_stretch_range, get_category, make_instance
from ..render.views import ViewConfig, render_view
from ..versions import CONVENTIONS_VERSION, GENERATOR_VERSION, __version__
from ..vocab import JOINT_TYPES
from .images import bop_entries, merge_bop_parts, write_png
from .sample import background_fields, sample_from_view
from .scenes import add_adjacent_distractor
from .shards import FORMAT_VERSION, shard_name, write_shard

__all__ = ["GenerateConfig", "generate_dataset", "make_sample", "sample_rng", "category_of", "config_of_model"]

MIN_OBJECT_PIXELS = 64
"""A view must show at least this many object pixels; otherwise another view is drawn."""


@dataclass(frozen=True)
class GenerateConfig:
    """Everything that defines a data set's content (recorded in ``meta.json``).

    Attributes:
        category, split, seed: the instance and view streams; num: views; shard_size: views per shard.
        views_per_instance: consecutive views of each instance.
        max_points: points kept per view (a uniform subset of the object's pixels); normal_k: kNN normals.
        images: also write depth / mask PNGs and BOP-style JSON.
        view: :class:`ucope.render.views.ViewConfig` (camera, ranges, sensor noise, floor, distractors).
        background: store each view's background pool (floor and distractor points next to the object,
            :func:`ucope.data.sample.background_fields`) for the floor / mask-bleed augmentations.
        adjacent_distractor: probability that a view gets one more distractor object standing right next
            to the object in the image (:func:`ucope.data.scenes.add_adjacent_distractor`), so that a
            bleeding mask meets another object, not only the floor.
        spec: the normalised category spec (:func:`ucope.objects.spec.check_spec`) of a category of your own
            objects (``ucope generate --spec``); ``category`` is then its name. It is registered in every
            process that makes samples (so spawned workers too), and stored in ``meta.json``.
        scale: build every instance at this uniform scale factor instead of its split's own (1 for
            train, val and test, the drawn factor for ood): the same shapes at another size (the scale
            curve of docs/results.md). The camera distance range scales with each instance's factor, so
            an object fills the image as much at any size.
        stretch: ``(low, high)`` or ``None``: stretch every instance along its x, y, z axes by factors
            drawn log-uniformly in this range (an augmentation of proportions for training data;
            :func:`ucope.objects.categories.make_instance`). The camera distance range scales with the
            geometric mean of each instance's factors.
        stretch_share: with ``stretch``, the share of instances stretched (in [0, 1]; the others keep the
            generated proportions).
    """

    category: str
    split: str = "train"
    num: int = 1000
    seed: int = 0
    shard_size: int = 100
    views_per_instance: int = 8
    max_points: int = 4096
    normal_k: int = 16
    images: bool = False
    view: ViewConfig = field(default_factory=ViewConfig)
    background: bool = True
    adjacent_distractor: float = 0.5
    scale: float | None = None
    stretch: tuple[float, float] | None = None
    stretch_share: float = 1.0
    spec: dict | None = None

    def validate(self) -> None:
        if self.spec is not None and self.spec.get("name") != self.category:
            raise InputError(f"the spec describes category {self.spec.get('name')!r}, not {self.category!r}")
        category_of(self)  # UnknownCategoryError lists the valid names
        if self.split not in SPLITS:
            raise InputError(f"unknown split {self.split!r}; valid splits: {', '.join(SPLITS)}")
        for name in ("num", "shard_size", "views_per_instance", "max_points"):
            v = getattr(self, name)
            if not isinstance(v, int | np.integer) or v <= 0:
                raise InputError(f"{name} must be a positive integer, got {v!r}")
        if self.max_points < 16:
            raise InputError(f"max_points must be at least 16, got {self.max_points}")
        if not isinstance(self.seed, int | np.integer) or isinstance(self.seed, bool) or self.seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {self.seed!r}")
        if not isinstance(self.normal_k, int | np.integer) or self.normal_k < 3:
            raise InputError(f"normal_k must be an integer >= 3, got {self.normal_k!r}")
        if self.scale is not None and not (np.isfinite(self.scale) and self.scale > 0):
            raise InputError(f"scale must be a positive number, got {self.scale!r}")
        if self.stretch is not None:
            object.__setattr__(self, "stretch", check_stretch_range(self.stretch))
            if not 0.0 <= float(self.stretch_share) <= 1.0:
                raise InputError(f"stretch share must be a fraction in [0, 1], got {self.stretch_share!r}")
        elif self.stretch_share != 1.0:
            raise InputError("a stretch share needs a stretch range (--stretch LOW,HIGH) to draw the factors from")
        if not 0.0 <= float(self.adjacent_distractor) <= 1.0:
            raise InputError(f"adjacent_distractor must be a probability in [0, 1], got {self.adjacent_distractor!r}")
        nd = self.view.num_distractors
        if not isinstance(nd, int | np.integer) or isinstance(nd, bool) or nd < 0:
            raise InputError(f"distractors (the most distractor objects per view) must be an integer >= 0, got {nd!r}")

    @property
    def num_shards(self) -> int:
        return -(-self.num // self.shard_size)

    def settings(self) -> dict:
        """The content-defining settings, as stored in and compared against ``meta.json``."""
        return {
            "category": self.category,
            "split": self.split,
            "num": int(self.num),
            "seed": int(self.seed),
            "shard_size": int(self.shard_size),
            "views_per_instance": int(self.views_per_instance),
            "max_points": int(self.max_points),
            "normal_k": int(self.normal_k),
            "images": bool(self.images),
            "view": self.view.to_dict(),
            "background": bool(self.background),
            "adjacent_distractor": float(self.adjacent_distractor),
            "scale": None if self.scale is None else float(self.scale),
            **(
                {"stretch": [float(v) for v in self.stretch], "stretch_share": float(self.stretch_share)}
                if self.stretch is not None
                else {}
            ),
            "generator_version": GENERATOR_VERSION,
            "category_revision": category_of(self).revision,
            "conventions_version": CONVENTIONS_VERSION,
            "format_version": FORMAT_VERSION,
            **({"spec": self.spec} if self.spec is not None else {}),
        }

    def meta(self) -> dict:
        """``meta.json``: the settings, the category's declared structure (part names and symmetries,
        joint tree, canonical axes, limits: :meth:`ucope.objects.articulation.ArticulatedObject.structure`
        of the split's instance 0) and bookkeeping."""
        spec = category_of(self)
        return {
            **self.settings(),
            "family": spec.family,
            "num_parts": spec.num_parts,
            "part_names": list(spec.part_names),
            "joint_types": list(spec.joint_types),
            "joint_type_codes": list(JOINT_TYPES),
            "symmetry": list(spec.symmetry),
            "num_shards": self.num_shards,
            "ucope_version": __version__,
            "structure": make_instance(
                self.category,
                self.split,
                0,
                self.seed,
                scale=self.scale,
                stretch_range=self.stretch,
                stretch_share=self.stretch_share,
            ).structure(),
        }


def category_of(cfg: GenerateConfig):
    """The :class:`~ucope.objects.categories.CategorySpec` of ``cfg``'s category; a category from a spec
    (``cfg.spec``) is registered in this process first (once: its files are read then)."""
    if cfg.spec is not None:
        from ..objects.categories import registered_doc

        if registered_doc(cfg.category) != cfg.spec:
            from ..objects.spec import register_spec

            register_spec(cfg.spec, quiet=True)
    return get_category(cfg.category)


def config_of_model(category: str, info: dict | None, **kwargs) -> GenerateConfig:
    """A :class:`GenerateConfig` (``kwargs``: its other fields) of the category a model was trained on: for a category
    of your own, the spec stored in its training data set's ``meta.json`` (``info["training_data"]["path"]`` of the
    model card; the files it names must be readable here). Raises :class:`DataError` when that data set is gone."""
    from ..objects.categories import CATEGORY_NAMES

    spec = None
    if category not in CATEGORY_NAMES:
        path = ((info or {}).get("training_data") or {}).get("path")
        meta = Path(path or "") / "meta.json"
        if not path or not meta.is_file():
            raise DataError(
                f"{category!r} is a category of your own: its spec comes from the model's training data ({path}), "
                "which is not here"
            )
        spec = read_json(meta).get("spec")
    return GenerateConfig(category=category, spec=spec, **kwargs)


def sample_rng(category: str, split: str, seed: int, index: int) -> np.random.Generator:
    """The random stream of view ``index`` (independent of the instance streams)."""
    keys = [zlib.crc32(s.encode()) for s in (category, "view", split)]
    return np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=(*keys, int(index))))


_INSTANCE_CACHE: dict = {}


def _instance(cfg: GenerateConfig, inst: int):
    key = (cfg.category, cfg.split, cfg.seed, inst, cfg.scale, cfg.stretch, cfg.stretch_share)
    obj = _INSTANCE_CACHE.get(key)
    if obj is None:
        _INSTANCE_CACHE.clear()  # views of one instance are consecutive: keep only the latest
        obj = _INSTANCE_CACHE[key] = make_instance(
            cfg.category, cfg.split, inst, cfg.seed, scale=cfg.scale, stretch_range=cfg.stretch, stretch_share=cfg.stretch_share
        )
    return obj


def make_sample(cfg: GenerateConfig, index: int, return_view: bool = False):
    """Build sample ``index`` of the data set described by ``cfg`` (deterministic)."""
    spec = category_of(cfg)
    obj = _instance(cfg, index // cfg.views_per_instance)
    size = obj.scale * float(np.prod(obj.stretch)) ** (1.0 / 3.0)
    if size != 1.0:  # a scaled or stretched object: the camera keeps its distance relative to the object's size
        spec = dataclasses.replace(spec, distance_range_m=tuple(d * size for d in spec.distance_range_m))
        if cfg.view.distance_range_m is not None:
            cfg = dataclasses.replace(
                cfg, view=dataclasses.replace(cfg.view, distance_range_m=tuple(d * size for d in cfg.view.distance_range_m))
            )
    rng = sample_rng(cfg.category, cfg.split, cfg.seed, index)
    for _ in range(50):
        view = render_view(obj, cfg.view, rng, spec)
        if int((view.mask < obj.num_parts).sum()) >= MIN_OBJECT_PIXELS:
            break
    else:  # pragma: no cover - would need a degenerate camera configuration
        raise InputError(
            f"could not find a view of {obj.instance_id} with {MIN_OBJECT_PIXELS} object pixels; check the camera settings"
        )
    sample = sample_from_view(obj, view, cfg.view.camera, rng, index, cfg.max_points, cfg.normal_k)
    if cfg.adjacent_distractor > 0 or cfg.background:
        extra = np.random.default_rng(
            np.random.SeedSequence(entropy=int(cfg.seed), spawn_key=(*_stream_key(cfg, "scene"), int(index)))
        )
        if extra.random() < cfg.adjacent_distractor:
            view, _ = add_adjacent_distractor(view, obj.size_m, sample["points"], cfg.view.camera, extra)
        if cfg.background:
            sample.update(background_fields(view, cfg.view.camera, len(sample["points"]), extra))
    return (sample, view) if return_view else sample


def _stream_key(cfg: GenerateConfig, what: str) -> tuple[int, ...]:
    return tuple(zlib.crc32(s.encode()) for s in (cfg.category, what, cfg.split))


def _generate_shard(cfg: GenerateConfig, out: Path, shard: int) -> int:
    lo, hi = shard * cfg.shard_size, min(cfg.num, (shard + 1) * cfg.shard_size)
    samples, cams, gts = [], {}, {}
    for i in range(lo, hi):
        sample, view = make_sample(cfg, i, return_view=True)
        samples.append(sample)
        if cfg.images:
            write_png(out / "images" / "depth" / f"{i:06d}.png", view.depth_mm)
            write_png(out / "images" / "mask" / f"{i:06d}.png", view.mask)
            cams[str(i)], gts[str(i)] = bop_entries(sample)
    if cfg.images:
        atomic_write_json(out / "images" / ".bop_parts" / f"shard_{shard:05d}.json", {"scene_camera": cams, "scene_gt": gts})
    write_shard(out / shard_name(shard), samples)  # written last: its presence marks the shard done
    return hi - lo


def _worker(args) -> int:
    cfg, out, shard, parent = args
    if os.getppid() != parent:  # the parent died: leave no shard behind it
        os._exit(1)
    return _generate_shard(cfg, out, shard)


def _worker_init(parent: int) -> None:
    """Make a worker die with its parent: on Linux the kernel sends SIGTERM when the parent exits
    (``PR_SET_PDEATHSIG``); everywhere, :func:`_worker` checks the parent before each shard."""
    import signal

    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the check in _worker remains
        pass
    if os.getppid() != parent:
        os._exit(1)


LOCK_NAME = ".generate.lock"
"""The file whose lock serialises the start of ``generate`` runs in one folder (see :func:`generate_dataset`)."""

_LOCK_WAIT_S = 30.0
_LOCKS_UNSUPPORTED = False  # set once a file system refused a lock (warned about once)


def _try_lock(fd: int) -> bool:
    """Take an exclusive kernel lock on the open file ``fd`` without waiting; ``False`` when another
    process holds it. The kernel releases it when the process ends, however it ends."""
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt

        try:
            os.lseek(fd, 0, os.SEEK_SET)
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
            return True
        except OSError:
            return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    except OSError as e:  # a file system without locks (some network mounts): go on unguarded, and say so once
        global _LOCKS_UNSUPPORTED
        if not _LOCKS_UNSUPPORTED:
            _LOCKS_UNSUPPORTED = True
            print(
                f"warning: this file system does not support file locks ({e.strerror or e}): concurrent `ucope generate` "
                "runs into one folder are not kept apart",
                file=sys.stderr,
            )
        return True


def _open_lock(path: Path) -> int | None:
    """Open ``path`` (created if missing) and lock it; ``None`` when another process holds its lock."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        if not _try_lock(fd):
            os.close(fd)
            return None
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)  # the file was removed while we waited for it: lock the new one


class _RunLock:
    """This run's claim on its shards of a data-set folder (see :func:`generate_dataset`)."""

    def __init__(self, out: Path, fd: int, path: Path):
        self.out, self.fd, self.path = out, fd, path

    def release(self) -> None:
        if self.fd is None:
            return
        with _folder_lock(self.out):  # no other run probes the file while it goes
            try:
                self.path.unlink()
            except FileNotFoundError:
                pass
            os.close(self.fd)
            self.fd = None


class _folder_lock:
    """The folder's start lock (:data:`LOCK_NAME`), held while a run checks ``meta.json`` and the other
    runs' claims and registers its own; waits up to 30 s for another run's start."""

    def __init__(self, out: Path):
        self.out = out
        self.fd: int | None = None

    def __enter__(self):
        import time

        deadline = time.monotonic() + _LOCK_WAIT_S
        while True:
            fd = _open_lock(self.out / LOCK_NAME)
            if fd is not None:
                self.fd = fd
                return self
            if time.monotonic() > deadline:
                raise DataError(
                    f"{self.out / LOCK_NAME} has been locked by another `ucope generate` for {_LOCK_WAIT_S:.0f} s; "
                    "is one stopped (Ctrl-Z)? Resume or end it, then run again"
                )
            time.sleep(0.05)

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        return False


def _run_info(path: Path) -> tuple[range | None, str]:
    """The shard range and a description of the run whose claim is ``path`` (``None``: unreadable)."""
    try:
        d = read_json(path)
        a, b = (int(v) for v in d["shards"])
        return range(a, b), f"pid {int(d['pid'])} on {d['host']}, shards {a}:{b}, started {d['started']}"
    except (DataError, KeyError, TypeError, ValueError):
        return None, f"see {path}"


def _claim_shards(out: Path, cfg: GenerateConfig, shards: range) -> _RunLock:
    """Under the folder's start lock: check or create ``meta.json``, check the other live runs' shard
    ranges against ``shards`` (an overlap is refused), remove the claims of runs that ended without
    releasing them, and register this run's claim (a locked file ``.generate-run-HOST-PID.json``)."""
    import platform
    import time

    host = "".join(c if c.isalnum() or c in "-_." else "_" for c in platform.node() or "host")
    with _folder_lock(out):
        meta_path = out / "meta.json"
        if not meta_path.exists() and any(out.glob("shard_*.npz")):
            raise DataError(
                f"{out} holds shards but no meta.json: it is not a data set this command can resume (its settings are "
                "unknown); remove the shards or use another --out folder"
            )
        if meta_path.exists():
            old = read_json(meta_path)
            if not isinstance(old, dict):
                raise DataError(f"{meta_path} is not a ucope data set description")
            new = json.loads(json.dumps(cfg.settings()))  # tuples -> lists, as stored
            diff = sorted(k for k in new if old.get(k) != new[k])
            if diff:
                raise DataError(
                    f"{out} already holds a data set made with other settings ({', '.join(diff)} differ); "
                    "use another --out folder, or the same settings to resume"
                )
        for other in sorted(out.glob(".generate-run-*.json")):
            fd = _open_lock(other)
            if fd is not None:  # its run ended without releasing it (killed): the kernel let its lock go
                other.unlink(missing_ok=True)
                os.close(fd)
                continue
            theirs, who = _run_info(other)
            if theirs is None or (theirs.start < shards.stop and shards.start < theirs.stop):
                raise DataError(
                    f"another `ucope generate` is writing into {out} ({who}); wait for it to finish, "
                    "or give this run --shards that do not overlap its"
                )
        if not meta_path.exists():
            atomic_write_json(meta_path, cfg.meta())
        path = out / f".generate-run-{host}-{os.getpid()}.json"
        fd = _open_lock(path)
        if fd is None:  # pragma: no cover - only this process makes this name
            raise DataError(f"{path} is locked by another process")
        info = {
            "pid": os.getpid(),
            "host": platform.node(),
            "shards": [shards.start, shards.stop],
            "started": time.strftime("%Y-%m-%d %H:%M:%S %z"),
        }
        os.ftruncate(fd, 0)
        os.write(fd, (json.dumps(info) + "\n").encode())
        return _RunLock(out, fd, path)


def _prepare_out(out: Path, cfg: GenerateConfig, shards: range) -> _RunLock:
    try:
        out.mkdir(parents=True, exist_ok=True)
        if cfg.images:
            for sub in ("depth", "mask", ".bop_parts"):
                (out / "images" / sub).mkdir(parents=True, exist_ok=True)
        probe = out / f".write_test_{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as e:
        raise DataError(f"cannot write to output folder {out}: {e.strerror or e}") from None
    return _claim_shards(out, cfg, shards)


def _progress(total: int, desc: str, enabled: bool):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # tqdm is an optional extra
        return None
    return tqdm(total=total, desc=desc, unit="view", file=sys.stderr, dynamic_ncols=True)


def generate_dataset(
    out: str | os.PathLike,
    cfg: GenerateConfig,
    workers: int = 1,
    shards: range | None = None,
    progress: bool = True,
) -> Path:
    """Generate (or resume) a data set in folder ``out``.

    Args:
        cfg: what to generate.
        workers: processes; the files do not depend on it.
        shards: the shard indices to make on this machine (default: all; an empty range is refused).
            Shards already on disk are skipped, so an interrupted run resumes where it stopped.

    Returns:
        The output folder.

    Raises:
        InputError: a bad setting, worker count or shard range.
        DataError: the folder cannot be written; it holds a data set of other settings (``meta.json``),
            or shards without ``meta.json``; another live run into it claims overlapping shards.

    Concurrent runs: a run claims its shard range in the folder (a file ``.generate-run-HOST-PID.json``
    holding a kernel lock, registered under the folder's start lock :data:`LOCK_NAME`), so a second run
    whose range overlaps a live run's, or whose settings differ from ``meta.json``, is refused before it
    writes anything; runs of the same settings and disjoint ``shards`` (one machine each) may share a
    folder. A killed run's kernel locks go with its process, so the next run finds its claim unlocked and
    removes it (no stale lock to clear by hand); on a network file system the locks need the server's
    lock support (NFSv4), and those of a crashed machine last until its lease runs out.
    """
    cfg.validate()
    if not isinstance(workers, int | np.integer) or workers < 1:
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    out = Path(out)
    all_shards = range(cfg.num_shards)
    shards = all_shards if shards is None else shards
    if not isinstance(shards, range) or len(shards) == 0 or shards.step != 1:
        raise InputError(f"shards must be a non-empty range of consecutive shard indices, got {shards!r}")
    if shards.start < 0 or shards.stop > cfg.num_shards:
        raise InputError(f"shard range {shards.start}:{shards.stop} is outside 0:{cfg.num_shards}")
    claim = _prepare_out(out, cfg, shards)
    bar = None
    try:
        todo = [s for s in shards if not (out / shard_name(s)).exists()]
        n_todo = sum(min(cfg.num, (s + 1) * cfg.shard_size) - s * cfg.shard_size for s in todo)
        bar = _progress(n_todo, f"{cfg.category}/{cfg.split}", progress)
        if workers == 1 or len(todo) <= 1:
            for s in todo:
                n = _generate_shard(cfg, out, s)
                if bar is not None:
                    bar.update(n)
        else:
            import multiprocessing as mp

            # spawn: workers never inherit a parent's ray-tracing thread pools
            parent = os.getpid()
            with mp.get_context("spawn").Pool(min(workers, len(todo)), initializer=_worker_init, initargs=(parent,)) as pool:
                for n in pool.imap_unordered(_worker, [(cfg, out, s, parent) for s in todo]):
                    if bar is not None:
                        bar.update(n)
        if cfg.images and all((out / shard_name(s)).exists() for s in all_shards):
            merge_bop_parts(out / "images", [out / "images" / ".bop_parts" / f"shard_{s:05d}.json" for s in all_shards])
    finally:
        if bar is not None:
            bar.close()
        claim.release()
    return out
