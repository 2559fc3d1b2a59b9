"""What ``ucope predict`` / ``show`` / ``eval`` do with results beyond their JSON: pictures (``--vis``),
the 3D viewer (``--view``, ``--view-html``), the BOP results CSV (``--bop-csv``), several objects per
frame (``--instances``) and data sets in other formats (``eval --format``). Kept apart from
:mod:`ucope.cli.main` so that its sub-commands only call in here."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import UcopeError

__all__ = [
    "VIEW_HOST",
    "VIEW_PORT",
    "writable_path",
    "check_outputs",
    "check_view_options",
    "add_output_options",
    "add_view_options",
    "add_eval_format_options",
    "check_eval_format_options",
    "Job",
    "write_outputs",
    "predict_instances",
    "eval_samples",
    "show_view",
    "truth_result",
]


class Job:
    """One estimated object for the outputs: its name, result, cloud, ground truth and errors, and the
    BOP image id it belongs to."""

    def __init__(self, name: str, result, points, sample=None, errors=None, im_id: int = 0):
        self.name, self.result, self.points, self.sample, self.errors = name, result, points, sample, errors
        self.im_id = int(im_id)


VIEW_HOST, VIEW_PORT = "127.0.0.1", 8080
"""Where the ``--view`` server listens unless ``--view-host`` / ``--view-port`` say otherwise."""


def add_view_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--view", action="store_true", help='open the 3D viewer in the browser (needs "ucope[view]"; Ctrl-C stops it)')
    p.add_argument("--view-html", default=None, metavar="FILE", help="write the 3D view as one self-contained HTML file")
    p.add_argument(
        "--view-port", type=int, default=None, help=f"with --view: port of the server (default {VIEW_PORT}; 0: any free)"
    )
    p.add_argument(
        "--view-host",
        default=None,
        help=f"with --view: address the server listens on (default {VIEW_HOST}: this machine only; 0.0.0.0 opens it to every "
        "machine that can reach this one, without authentication)",
    )


def writable_path(path: str | os.PathLike, option: str, folder: bool = False) -> Path:
    """Check, before any work starts, that the output ``path`` of ``option`` can be written: a file
    (``folder=False``) or a folder (created later with its parents). Creates nothing: a probe file is
    made and removed in the nearest existing folder.

    Raises :class:`UcopeError` naming the option, the path and the problem: a folder where a file is
    wanted (or a file where a folder is), a FIFO or a device, a file where a parent folder should be,
    a name too long, no permission or a read-only file system."""
    p = Path(path)
    where = f"{option} {p}"
    try:
        if p.exists():
            if folder and not p.is_dir():
                raise UcopeError(f"{where}: it exists and is not a folder")
            if not folder and p.is_dir():
                raise UcopeError(f"{where} is a folder: give a file name")
            if not folder and not p.is_file():
                raise UcopeError(f"{where} is not a regular file (a FIFO or a device): give a file name")
        base = p if folder and p.is_dir() else p.parent
        new = [] if base is p else [p.name]
        while not base.exists():
            if base.parent == base:  # the root (or a removed working folder) does not exist
                raise UcopeError(f"{where}: {base} does not exist")
            new.append(base.name)
            base = base.parent
        if not base.is_dir():
            raise UcopeError(f"{where}: {base} is a file, not a folder")
        try:
            name_max = int(os.pathconf(base, "PC_NAME_MAX"))
        except (OSError, ValueError, AttributeError):
            name_max = 255
        for name in new:
            if len(os.fsencode(name)) > name_max:
                raise UcopeError(f"{where}: the name {name[:24]}... is too long (the file system allows {name_max} bytes)")
        fd, probe = tempfile.mkstemp(prefix=".ucope_write_test_", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise UcopeError(f"{where}: cannot write there ({e.strerror or e})") from None
    return p


def check_outputs(targets: list[tuple[str, str | os.PathLike | None, bool]]) -> None:
    """:func:`writable_path` of every ``(option, path, is_folder)`` given (``path`` not ``None``), and no
    two options naming one file (a picture would overwrite the result JSON)."""
    seen: dict[str, str] = {}
    for option, path, folder in targets:
        if path is None:
            continue
        writable_path(path, option, folder)
        key = os.path.normcase(os.path.abspath(path))
        if key in seen:
            raise UcopeError(f"{seen[key]} and {option} name the same path {path}: give each its own")
        seen[key] = option


def _view_address(args: argparse.Namespace) -> tuple[str, int]:
    host, port = getattr(args, "view_host", None), getattr(args, "view_port", None)
    return (VIEW_HOST if host is None else host), (VIEW_PORT if port is None else port)


def check_view_options(args: argparse.Namespace) -> None:
    """Before any work: ``--view-host`` / ``--view-port`` only with ``--view``; the viewer's extra
    installed; the address usable (:func:`ucope.estimation.view3d.check_address`). Fills in the
    default host and port."""
    given = [o for o, v in (("--view-host", args.view_host), ("--view-port", args.view_port)) if v is not None]
    if given and not args.view:
        raise UcopeError(f"{' and '.join(given)} {'are' if len(given) > 1 else 'is'} for the --view server: add --view")
    args.view_host, args.view_port = _view_address(args)
    if args.view or args.view_html:
        from ..estimation.view3d import check_address, viser_module

        viser_module()
        if args.view:
            check_address(args.view_host, args.view_port, names=("--view-host", "--view-port"))


def add_output_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`write_outputs` and :func:`predict_instances` (for ``ucope predict``)."""
    p.add_argument("--rgb", default=None, help="colour image of the --depth frame: --vis also draws the estimates over it")
    p.add_argument(
        "--instances",
        nargs="+",
        default=None,
        metavar="ID=MODEL",
        help="several objects in one frame: --mask is an instance mask over --depth (or --input a cloud with per-point "
        "instance ids: an .npz 'instance' array or a PLY 'instance' property), each ID estimated by its MODEL; "
        "--out is one JSON with all of them (ucope-results/1)",
    )
    add_view_options(p)
    p.add_argument(
        "--bop-csv",
        default=None,
        metavar="FILE",
        help="also write the estimates as a BOP results CSV (obj_id of part k = base + k; the objects of one image "
        "numbered on; the obj_id of every (object, part) in FILE's .obj_ids.json beside it)",
    )
    p.add_argument("--bop-scene-id", type=int, default=None, help="with --bop-csv: BOP scene_id of the rows (default 0)")
    p.add_argument(
        "--bop-im-id",
        type=int,
        default=None,
        help="with --bop-csv: BOP im_id of the rows (default: the sample index with --data, the file name when it is a number, "
        "else the input's position)",
    )
    p.add_argument(
        "--bop-obj-id",
        type=int,
        default=None,
        help="BOP obj_id of the first object's part 0 (default 1); part k gets this + k, and the next object of the "
        "image (--instances, in id order) goes on from there",
    )


def add_eval_format_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`eval_samples` (for ``ucope eval``)."""
    p.add_argument(
        "--format",
        choices=["ucope", "nocs", "artimage", "bop"],
        default="ucope",
        help="data set format: ucope (ucope generate, default), nocs (CAMERA25 / REAL275 frames), artimage, bop "
        "(docs/formats.md)",
    )
    p.add_argument(
        "--intrinsics",
        default=None,
        help="with --format nocs: intrinsics JSON overriding CAMERA's / REAL275's; with --format artimage: the Open3D "
        "camera_intrinsic.json (default DIR/camera_intrinsic.json)",
    )
    p.add_argument(
        "--dataset",
        choices=["real", "camera"],
        default=None,
        help="with --format nocs: REAL275 (real) or CAMERA25 (camera) intrinsics (default: told by the folder names from "
        "DIR down: real / real_test..., camera / camera_val...)",
    )
    p.add_argument(
        "--nocs-gts",
        default=None,
        metavar="DIR",
        help="with --format nocs: NOCS's gts folder (results_*.pkl): official poses and model boxes instead of the "
        "coordinate-map fit (default DIR/gts when it exists); read without unpickling anything but arrays",
    )
    p.add_argument(
        "--urdf-metas",
        default=None,
        metavar="FILE",
        help="with --format artimage: the urdf_metas.json (default DIR/urdf_metas.json)",
    )
    p.add_argument(
        "--bop-obj-id", type=int, default=None, help="with --format bop: the obj_id of part 0 (part k is this + k; default 1)"
    )
    p.add_argument(
        "--models-info", default=None, help="with --format bop: the models_info.json holding the object boxes (default: searched)"
    )


def check_eval_format_options(args: argparse.Namespace) -> None:
    """Refuse the ``eval`` options that the chosen ``--format`` would ignore; fill in ``--bop-obj-id``'s default."""
    only = {  # --intrinsics (nocs, artimage) is checked with the other formats' options in eval_samples
        "--models-info": ("bop", args.models_info),
        "--bop-obj-id": ("bop", args.bop_obj_id),
    }
    for option, (fmt, value) in only.items():
        if value is not None and args.format != fmt:
            raise UcopeError(f"{option} is for --format {fmt} only; --format {args.format} would ignore it")
    if args.bop_obj_id is None:
        args.bop_obj_id = 1


def _im_id(name: str, position: int) -> int:
    return int(name) if name.isdigit() else position


def job_im_ids(names: list[str], args: argparse.Namespace, samples: list | None = None) -> list[int]:
    """The BOP ``im_id`` of each job (see ``--bop-im-id``)."""
    if args.bop_im_id is not None:
        return [int(args.bop_im_id)] * len(names)
    if samples is not None and all(s is not None for s in samples):
        return [int(s.get("index", i)) for i, s in enumerate(samples)]
    return [_im_id(n, i) for i, n in enumerate(names)]


def _scenes(jobs: list[Job], frame: dict | None):
    from ..estimation.draw import DrawnObject, Scene

    if frame is not None:  # one frame: every job is an object of it
        return [
            Scene(
                [DrawnObject(j.result, j.points, j.sample, j.errors, name=j.name if len(jobs) > 1 else "") for j in jobs],
                title=frame.get("title", ""),
                depth_m=frame.get("depth_m"),
                rgb=frame.get("rgb"),
                intrinsics=frame.get("intrinsics"),
            )
        ]
    return [Scene([DrawnObject(j.result, j.points, j.sample, j.errors)], title=j.name) for j in jobs]


def write_outputs(args: argparse.Namespace, jobs: list[Job], frame: dict | None = None) -> None:
    """``--vis`` PNG, ``--bop-csv``, ``--view-html`` and ``--view`` (last: it blocks) of estimated jobs.

    ``frame``: when the jobs are the objects of one RGB-D frame, ``{"depth_m", "rgb", "intrinsics", "title"}``
    to draw them over it."""
    jobs = [j for j in jobs if j.result is not None]
    if not jobs:
        return
    scenes = None
    if getattr(args, "vis", None):
        from ..estimation.draw import plot_scenes

        scenes = _scenes(jobs, frame)
        print(f"wrote {plot_scenes(scenes, args.vis)}")
    if getattr(args, "bop_csv", None):
        from ..estimation.export import frame_bop_rows, obj_id_map_path, write_bop_csv

        base = int(args.bop_obj_id) if args.bop_obj_id is not None else 1
        if base < 1:
            raise UcopeError(f"--bop-obj-id must be a positive integer, got {base}")
        by_image: dict[int, list] = {}
        for j in jobs:
            by_image.setdefault(j.im_id, []).append((j.result, base, j.name))
        rows = [r for im, objs in sorted(by_image.items()) for r in frame_bop_rows(objs, args.bop_scene_id, im, base=base)]
        path = write_bop_csv(args.bop_csv, rows)
        print(
            f"wrote {path} ({len(rows)} rows: one per part; obj_id of part k = base + k, the objects of an image numbered on) "
            f"and {obj_id_map_path(path).name}"
        )
    if getattr(args, "view_html", None) or getattr(args, "view", False):
        from ..estimation.view3d import show, write_html

        scenes = scenes or _scenes(jobs, frame)
        if args.view_html:
            print(f"wrote {write_html(scenes, args.view_html)} (open it in a browser)")
        if args.view:
            show(scenes, *_view_address(args), block=True)


def read_rgb(path: str, shape: tuple[int, int] | None) -> np.ndarray:
    """An RGB image ``(H, W, 3)`` uint8 of the depth's size ``shape``."""
    from ..data.readers.common import read_image

    img = read_image(path, "RGB image")
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise UcopeError(f"{path}: an RGB image must have 3 channels, got shape {img.shape}")
    if shape is not None and img.shape[:2] != tuple(shape):
        raise UcopeError(f"{path}: the RGB image is {img.shape[1]}x{img.shape[0]}, the depth image {shape[1]}x{shape[0]}")
    if img.dtype != np.uint8:
        img = (img / max(1, int(img.max())) * 255).astype(np.uint8)
    return img[..., :3]


def estimator_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :meth:`ucope.estimation.Estimator.load` that the ``predict`` / ``eval`` /
    ``pipeline`` options ask for: the model's stages changed by ``--stages`` / ``--drop-stage``, parameters by
    ``--pairs`` and ``--set``."""
    from ..estimation.search import FAST
    from ..stages import get_stage, parse_overrides

    overrides = dict(FAST) if getattr(args, "fast", False) else {}
    overrides.update(parse_overrides(getattr(args, "set", None) or []))
    if getattr(args, "pairs", None) is not None:
        overrides["vote_parts.num_pairs"] = args.pairs
    stages = None
    if getattr(args, "stages", None):
        stages = [n.strip() for n in args.stages.split(",") if n.strip()]
        for name in stages:
            get_stage(name)
    drop = list(getattr(args, "drop_stage", None) or [])
    for name in drop:
        get_stage(name)
    return dict(stages=stages, drop=drop, overrides=overrides, seed=args.seed, device=args.device)


def _instances_checks(args: argparse.Namespace) -> None:
    """Refuse the options ``--instances`` cannot honour, before any work."""
    if args.model is not None:
        raise UcopeError("give either --model (one object) or --instances ID=MODEL ... (several), not both")
    if getattr(args, "mask_label", None) is not None:
        raise UcopeError(
            "--mask-label picks one object's values in its mask; with --instances the mask values are the instance ids "
            "given as ID=MODEL: leave --mask-label out"
        )
    if getattr(args, "data", None) is not None:
        raise UcopeError("--instances estimates the objects of one frame (--depth/--mask or --input), not --data samples")
    if args.input is not None:
        given = [o for o in ("depth", "mask", "intrinsics", "box", "rgb") if getattr(args, o, None) is not None]
        if given:
            raise UcopeError(
                f"--input with --instances takes the instance ids from the cloud; --{', --'.join(given)} belong to a depth "
                "frame (--depth --mask --intrinsics): give one or the other"
            )
    elif args.depth is None or args.mask is None or args.intrinsics is None:
        raise UcopeError(
            "--instances needs --depth D.png, --mask INSTANCES.png and --intrinsics K.json, or --input CLOUD with per-point "
            "instance ids"
        )


def _predict_cloud_instances(args: argparse.Namespace, models: dict, opts: dict):
    """``(FrameResult, frame picture dict)`` of ``--input CLOUD --instances ...``."""
    from ..data.readers.clouds import read_segmented_cloud
    from ..estimation.frame import predict_cloud
    from .main import _expand_inputs

    files = _expand_inputs(args.input)
    if len(files) != 1:
        raise UcopeError(f"--input with --instances takes one segmented cloud, got {len(files)} files")
    pts, nrm, ids = read_segmented_cloud(files[0])
    fr = predict_cloud(
        pts,
        ids,
        models,
        None if args.ignore_normals else nrm,
        units=args.units,
        estimator_options=opts,
        source={"input": str(files[0])},
        up=args.up,
    )
    return fr, {"title": files[0].stem}, files[0].stem


def predict_instances(args: argparse.Namespace) -> int:
    """``ucope predict --instances ID=MODEL ... --depth D --mask M --intrinsics K`` (or ``--input CLOUD`` with
    per-point instance ids): one JSON for all."""
    from ..data.io import read_depth_png, read_intrinsics
    from ..estimation.frame import parse_instance_models, predict_frame

    models = parse_instance_models(args.instances)
    _instances_checks(args)
    opts = estimator_options(args)
    if args.input is not None:
        fr, frame, stem = _predict_cloud_instances(args, models, opts)
    else:
        depth = read_depth_png(args.depth)
        mask = read_depth_png(args.mask)
        K = read_intrinsics(args.intrinsics)
        rgb = read_rgb(args.rgb, depth.shape) if args.rgb else None
        fr = predict_frame(
            depth,
            K,
            mask,
            models,
            depth_scale=args.depth_scale,
            estimator_options=opts,
            source={"depth": str(args.depth), "mask": str(args.mask), "rgb": args.rgb},
            up=args.up,
            box=args.box,
        )
        stem = Path(args.depth).stem
        frame = {"depth_m": depth.astype(np.float64) / args.depth_scale, "intrinsics": K, "title": stem, "rgb": rgb}
    out = fr.save(args.out)
    for o in fr.objects:
        if o.result is None:
            print(f"instance {o.instance_id} ({o.model}): no estimate: {o.error}")
        else:
            print(
                f"instance {o.instance_id} ({o.model}): {len(o.result.parts)} part(s), {len(o.result.joints)} joint(s) in "
                f"{o.result.timings_ms.get('total', 0.0):.0f} ms"
            )
    print(f"wrote {out} ({len(fr.results)} of {len(fr.objects)} objects estimated)")
    im_id = args.bop_im_id if args.bop_im_id is not None else _im_id(stem, 0)
    jobs = [Job(f"{o.instance_id}: {o.model}", o.result, o.points, im_id=im_id) for o in fr.objects]
    write_outputs(args, jobs, frame)
    return 0


def eval_samples(args: argparse.Namespace, category: str) -> tuple[list[dict], dict]:
    """The samples of ``ucope eval --format nocs|artimage|bop DIR`` for a model of ``category``, and what
    the report records about the data."""
    from ..data.readers import read_samples

    kw: dict = {}
    only = {"dataset": "nocs", "nocs_gts": "nocs", "urdf_metas": "artimage", "models_info": "bop"}
    for option, fmt in only.items():
        if getattr(args, option, None) is not None and args.format != fmt:
            raise UcopeError(f"--{option.replace('_', '-')} is an option of --format {fmt}, not --format {args.format}")
    if args.intrinsics is not None and args.format not in ("nocs", "artimage"):
        raise UcopeError(
            f"--intrinsics is an option of --format nocs and artimage; --format {args.format} data sets carry their cameras"
        )
    if args.format == "nocs":
        if args.intrinsics is not None:
            from ..data.io import read_intrinsics

            kw["intrinsics"] = read_intrinsics(args.intrinsics)
        kw.update(dataset=args.dataset, gts=args.nocs_gts)
    if args.format == "artimage":
        kw.update(intrinsics=args.intrinsics, urdf_metas=args.urdf_metas)
    if args.format == "bop":
        kw.update(obj_id=args.bop_obj_id, models_info=args.models_info)
    samples = read_samples(args.format, args.data, category, **kw)
    if not samples:
        raise UcopeError(f"{args.data} holds no {category} objects in {args.format} format")
    info = {"path": str(Path(args.data).resolve()), "format": args.format}
    if args.format == "bop":
        info["obj_id"] = args.bop_obj_id
    if args.format == "nocs":
        info["ground_truth"] = sorted({str(s.get("gt_source", "coord")) for s in samples})
    return samples, info


def truth_result(sample: dict):
    """A data-set sample's ground truth as a :class:`PoseResult` (score 1), to draw it like an estimate."""
    from ..estimation.result import JointEstimate, PartEstimate, PoseResult
    from ..objects.categories import get_category, make_instance
    from ..vocab import JointType

    cat = str(sample.get("category", ""))
    J = len(np.asarray(sample.get("joint_type", [])))
    try:
        spec = get_category(cat)
        names, sym = spec.part_names, spec.symmetry
        links = [(j.parent, j.child) for j in make_instance(cat, "test", 0).joints]
    except UcopeError:
        K = len(sample["size_m"])
        names, sym = tuple(f"part {k}" for k in range(K)), ("none",) * K
        links = [(0, i + 1) for i in range(J)]
    T = np.asarray(sample["cam_from_part"], np.float64)
    parts = [PartEstimate(k, names[k], T[k], np.asarray(sample["size_m"][k], np.float64), 1.0, sym[k]) for k in range(len(T))]
    joints = []
    for i, code in enumerate(np.asarray(sample.get("joint_type", []), np.int64)):
        jt = JointType.parse(int(code)).label
        piv = np.asarray(sample["joint_pivot"][i], np.float64)
        joints.append(
            JointEstimate(
                jt,
                links[i][0],
                links[i][1],
                piv if jt == "revolute" else None,
                np.asarray(sample["joint_axis"][i], np.float64),
                float(sample["joint_state"][i]),
                1.0,
            )
        )
    return PoseResult(
        cat, parts, joints, np.asarray(sample["part_labels"], np.int64), model="ground truth", num_points=len(sample["points"])
    )


def show_view(args: argparse.Namespace, samples: list[dict]) -> None:
    """``ucope show DIR --view / --view-html``: the samples' clouds, boxes and joints in the 3D viewer."""
    from ..estimation.draw import DrawnObject, Scene
    from ..estimation.view3d import show, write_html

    scenes = [
        Scene([DrawnObject(truth_result(s), s["points"], truth=True)], title=f"{s['category']} #{s['index']}") for s in samples
    ]
    if args.view_html:
        print(f"wrote {write_html(scenes, args.view_html)} (open it in a browser)")
    if args.view:
        show(scenes, *_view_address(args), block=True)
    if not (args.view or args.view_html):  # pragma: no cover - the caller checks
        print("nothing to show", file=sys.stderr)
