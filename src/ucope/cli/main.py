"""The ``ucope`` command line (one entry point, one sub-command per job)."""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from pathlib import Path

from ..errors import UcopeError
from ..versions import __version__

__all__ = ["main", "build_parser"]


def _parse_shards(text: str | None) -> range | None:
    """``--shards START:STOP`` as a range (STOP exclusive); an empty, reversed or negative range is refused."""
    if text is None:
        return None
    try:
        a, b = (int(v) for v in text.split(":"))
    except ValueError:
        raise UcopeError(f"--shards must look like START:STOP (e.g. 0:10), got {text!r}") from None
    if a < 0 or b <= a:
        raise UcopeError(f"--shards {text}: START must be >= 0 and below STOP (STOP is exclusive: 0:1 is shard 0 alone)")
    return range(a, b)


def _spec_summary(own) -> str:
    """What ``ucope categories --spec`` prints: the parts, the category joints, and per instance file its
    extents and each category joint's limits in the file and as category states."""
    import numpy as np

    lines = [f"{own.name}: valid spec, {len(own.families)} instance file(s), K = {own.spec.num_parts}"]
    for p in own.doc["parts"]:
        links = p["links"] if p["links"] == "*" else ", ".join(p["links"])
        lines.append(f"  part {p['name']}: links {links}; symmetry {p['symmetry']}")
    first = own.objects[own.families[0]]
    for i, (j, js) in enumerate(zip(own.doc["joints"], first.joints, strict=True)):
        unit = "rad" if js.type == "revolute" else "m"
        lines.append(
            f"  joint {i} {j['joint']!r}: {js.type} part {js.parent} -> {js.child}, "
            f"states [{js.limits[0]:.4g}, {js.limits[1]:.4g}] {unit} "
            f"(spec: {j['range']} {j['unit']}, sign {j['sign']:+d}, offset {j['offset']:g})"
        )
    for k, files in sorted(own.skipped.items()):
        names = ", ".join(f.name for f in files[:6]) + (", ..." if len(files) > 6 else "")
        lines.append(f"  instances[{k}] (folder {own.doc['instances'][k]['file']}): left out {len(files)} file(s): {names}")
    entries = {fam: own.doc["instances"][k] for fam, k in own.entry_of.items()}
    for fam in own.families:
        o, it = own.objects[fam], entries[fam]
        lo, hi = o.bounds(o.rest_state)
        held = " (held out: ood)" if any(f.held_out for f in own.spec.shape_families if f.name == fam) else ""
        ext = np.round(100 * (hi - lo), 1).tolist()
        lines.append(f"  instance {fam}{held}: {o.params['source']}, rest-state extents {ext} cm")
        if "parts" in it:
            lines.append("    its links: " + "; ".join(f"{k} {v if v == '*' else ', '.join(v)}" for k, v in it["parts"].items()))
        if "joints" in it:
            js = [{**j, **e} for j, e in zip(own.doc["joints"], it["joints"], strict=True)]
            named = [f"{j['joint']} (sign {j['sign']:+d}, offset {j['offset']:g})" for j in js]
            lines.append("    its joints: " + "; ".join(named))
        for i, (jname, file_lim, state_lim) in enumerate(own.joint_limits.get(fam, ())):
            unit = "rad" if o.joints[i].type == "revolute" else "m"
            fl = "none (unlimited)" if file_lim is None else f"[{file_lim[0]:.4g}, {file_lim[1]:.4g}] {unit}"
            sl = "" if state_lim is None else f" = states [{state_lim[0]:.4g}, {state_lim[1]:.4g}] {unit}"
            smp = f"; sampled [{o.limits[i][0]:.4g}, {o.limits[i][1]:.4g}] {unit}"
            flip = "; axis turned round to the category's, states negated" if i in own.flipped.get(fam, ()) else ""
            lines.append(f"    joint {i} {jname!r}: file limits {fl}{sl}{smp}{flip}")
    return "\n".join(lines)


def _draw_instances(own, out: Path) -> Path:
    """Every instance of a spec at the middle of its sampled states, one panel each, in one picture."""
    import math
    import tempfile

    from ..data.visualize import plot_object
    from ..plotting import pyplot, save_figure

    plt = pyplot()
    n = len(own.families)
    cols = min(4, n)
    rows = math.ceil(n / cols)
    with tempfile.TemporaryDirectory(prefix="ucope_categories_") as tmp:
        panels = []
        for fam in own.families:
            obj = own.objects[fam]
            state = obj.limits.mean(axis=1) if obj.joints else None
            title = f"{own.name} {fam}" + (f": state {[round(float(v), 2) for v in state]}" if state is not None else "")
            panels.append(plt.imread(plot_object(obj, Path(tmp) / f"{fam}.png", state=state, title=title)))
            plt.close("all")
        h, w = panels[0].shape[:2]
        fig, axes = plt.subplots(rows, cols, figsize=(cols * w / 110, rows * h / 110), dpi=110, squeeze=False)
        for ax in axes.ravel():
            ax.axis("off")
        for ax, img in zip(axes.ravel(), panels, strict=False):
            ax.imshow(img)
        fig.subplots_adjust(left=0, right=1, top=1, bottom=0, wspace=0.02, hspace=0.02)
        return save_figure(fig, out)


def cmd_categories(args: argparse.Namespace) -> int:
    from ..objects.categories import list_categories

    if args.spec is None and (args.picture is not None or args.no_picture):
        raise UcopeError("--picture and --no-picture are for checking a category spec: add --spec FILE")
    if args.picture is not None and args.no_picture:
        raise UcopeError("--picture FILE and --no-picture contradict each other: give one")
    if args.spec is not None:
        import warnings

        from ..objects.spec import load_spec
        from .outputs import writable_path

        if not args.no_picture:
            from ..plotting import pyplot

            pyplot()  # a missing matplotlib is said before the spec's files are read
        with warnings.catch_warnings(record=True) as caught:  # one line each (a size off, an axis turned round)
            warnings.simplefilter("always")
            own = load_spec(args.spec)
        for w in caught:
            print(f"warning: {w.message}", file=sys.stderr)
        out = Path(args.picture or f"conventions_{own.name}.png")
        if not args.no_picture:
            writable_path(out, "--picture")
        print(_spec_summary(own))
        if not args.no_picture:
            print(f"wrote {_draw_instances(own, out)} ({len(own.families)} instance(s))")
        return 0
    rows = [("name", "family", "K", "joints", "symmetry", "parts")]
    for s in list_categories():
        rows.append(
            (s.name, s.family, str(s.num_parts), ",".join(s.joint_types) or "-", ",".join(s.symmetry), ",".join(s.part_names))
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=False)).rstrip())
    return 0


def _generate_config(args: argparse.Namespace, **overrides):
    from ..data.generate import GenerateConfig
    from ..render.noise import DepthNoise
    from ..render.views import ViewConfig

    view = ViewConfig(noise=DepthNoise(enabled=not args.no_noise), floor=not args.no_floor, num_distractors=args.distractors)
    category, spec = args.category, None
    if getattr(args, "spec", None) is not None:
        from ..objects.spec import register_spec

        own = register_spec(args.spec)
        category, spec = own.name, own.doc
    kw = dict(
        category=category,
        spec=spec,
        split=args.split,
        num=args.num,
        seed=args.seed,
        shard_size=args.shard_size,
        views_per_instance=args.views_per_instance,
        max_points=args.max_points,
        images=args.images,
        view=view,
        scale=args.scale,
        stretch=getattr(args, "stretch", None),
        stretch_share=getattr(args, "stretch_share", 1.0),
        adjacent_distractor=args.adjacent_distractor,
    )
    kw.update(overrides)
    return GenerateConfig(**kw)


def _number_pair(text: str) -> tuple[float, float]:
    """``"a,b"`` as two floats (an argparse type: a malformed pair is a usage error naming it)."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two numbers LOW,HIGH, got {text!r}") from None


def cmd_generate(args: argparse.Namespace) -> int:
    from ..data.generate import generate_dataset

    shards = _parse_shards(args.shards)
    cfg = _generate_config(args)
    t0 = time.perf_counter()
    out = generate_dataset(args.out, cfg, workers=args.workers, shards=shards, progress=not args.quiet)
    if not args.quiet:
        if shards is None:
            what = f"{cfg.num} {cfg.category}/{cfg.split} views"
        else:
            n = min(cfg.num, shards.stop * cfg.shard_size) - shards.start * cfg.shard_size
            what = f"shards {shards.start}:{shards.stop} of {cfg.num_shards} ({n} {cfg.category}/{cfg.split} views)"
        print(f"wrote {what} to {out} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from ..data.dataset import load_dataset
    from ..data.visualize import plot_samples

    ds = load_dataset(args.data)
    idx = args.index or [0]
    for i in idx:
        if not -len(ds) <= i < len(ds):
            raise UcopeError(f"--index {i} is out of range: {args.data} holds {len(ds)} samples")
    if args.out is None and not (args.view or args.view_html):
        raise UcopeError("give --out PNG, --view or --view-html FILE")
    from .outputs import check_outputs, check_view_options

    check_view_options(args)
    check_outputs([("--out", args.out, False), ("--view-html", args.view_html, False)])
    if args.out is not None:
        from ..plotting import pyplot

        pyplot()
        print(f"wrote {plot_samples([ds[i] for i in idx], args.out)}")
    if args.view or args.view_html:
        from .outputs import show_view

        show_view(args, [ds[i] for i in idx])
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from ..data.generate import GenerateConfig, make_sample
    from ..estimation.draw import plot_results
    from ..estimation.estimator import Estimator
    from ..eval.evaluate import sample_errors
    from ..fileio import atomic_write_json
    from ..plotting import pyplot
    from .outputs import writable_path

    pyplot()  # the demo ends with a picture: a missing matplotlib is said first
    out = writable_path(args.out, "--out", folder=True)
    if args.num <= 0:
        raise UcopeError(f"--num must be a positive number of views, got {args.num}")
    out.mkdir(parents=True, exist_ok=True)
    items = []
    t0 = time.perf_counter()
    for cat in args.categories:
        est = Estimator.load(cat, overrides={"vote_parts.num_pairs": args.pairs}, seed=args.seed)
        # Unseen instances: the test split's instance stream is disjoint from the training one.
        gen = GenerateConfig(category=cat, split="test", num=args.num, seed=args.seed, views_per_instance=1)
        for i in range(args.num):
            s = make_sample(gen, i)
            res = est.predict_sample(s)
            err = sample_errors(res, s)
            name = f"{cat}_{i:02d}"
            d = res.to_dict()
            d["errors"] = err
            atomic_write_json(out / f"{name}.json", d)
            print(f"{cat} test view {i} ({s['instance_id']}, unseen instance), {res.timings_ms['total']:.0f} ms:")
            print(format_errors(res, err))
            items.append((s["points"], res, s, f"{name}: predicted (solid) vs ground truth (dashed)", err))
    pic = plot_results(items, out / "demo.png", cols=max(1, args.num))
    print(f"wrote {pic} and one result JSON per view in {out}/ ({time.perf_counter() - t0:.1f} s)")
    return 0


def cmd_models(args: argparse.Namespace) -> int:
    from ..model.checkpoint import list_pretrained, pretrained_dir, read_model_json

    names = list_pretrained()
    if not names:
        print("this install ships no models")
        return 0
    for name in names:
        meta = read_model_json(pretrained_dir() / f"{name}.json")
        cfg, info = meta["config"], meta.get("info", {})
        test = info.get("test", {})
        w = meta["weights"]
        part_names = [p["name"] for p in cfg["priors"]["parts"]]
        joints = ", ".join(j["type"] for j in cfg["priors"]["joints"]) or "rigid"
        steps, stage = [info.get("steps", "?")], info.get("initialised_from")
        while stage:  # a fine-tuned model: every stage, oldest first
            steps.insert(0, stage.get("steps", "?"))
            stage = stage.get("initialised_from")
        tuned = f" ({len(steps) - 1} fine-tuning stage{'s' if len(steps) > 2 else ''})" if len(steps) > 1 else ""
        stages = len((info.get("pipeline") or {}).get("stages") or [])
        print(
            f"{name}: {len(part_names)} part(s) ({', '.join(part_names)}); {joints}; "
            f"{cfg['head']} head; {stages or 'default'} stages (ucope pipeline --model {name}); "
            f"{w['bytes'] / 1e6:.2f} MB {w.get('dtype', 'float32')}; trained {' + '.join(str(x) for x in steps)} steps{tuned}"
        )
        for split, what in (("test", "unseen objects"), ("ood", "held-out shapes and sizes")):
            fig = info.get(split) or {}
            if fig.get("success") is not None:
                lo, hi = fig.get("success_interval_95_objects") or (fig["success"], fig["success"])
                print(
                    f"  {split} ({fig.get('num_samples')} views of {fig.get('num_objects')} {what}): success "
                    f"{100 * fig['success']:.0f} % (95 % over objects: {100 * lo:.0f}-{100 * hi:.0f})"
                )
        if test:
            line = (
                f"  test split ({test.get('num_samples')} views): rotation "
                f"{_fmt_list(test.get('rotation_deg_mean'), '{:.1f}')} deg, "
                f"translation {_fmt_list(test.get('translation_m_mean'), '{:.3f}')} m, IoU "
                f"{_fmt_list(test.get('iou_mean'), '{:.2f}')}"
            )
            if test.get("joint_axis_deg_mean"):
                line += f"; joint axis {_fmt_list(test['joint_axis_deg_mean'], '{:.1f}')} deg"
            if test.get("map"):
                line += f"; mAP 10deg5cm {100 * test['map']['10deg5cm']:.1f}%, 3D50 {100 * test['map']['3D50']:.1f}%"
            print(line)
    return 0


def _fmt_list(values, fmt: str) -> str:
    return "/".join("-" if v is None else fmt.format(v) for v in (values or []))


def cmd_train(args: argparse.Namespace) -> int:
    from ..model.train import TrainConfig, train
    from .outputs import writable_path

    writable_path(args.out, "--out", folder=True)  # the run folder: said before any data is read
    overrides = {}
    if args.pairs_per_part is not None:
        overrides["pairs_per_part"] = args.pairs_per_part
    if args.head != "voting":
        overrides["head"] = args.head
    for name in ("seg_weighting", "lambda_seg", "lambda_joint", "lambda_pose"):
        if getattr(args, name) is not None:
            overrides[name] = getattr(args, name)
    tc = TrainConfig(
        category=args.category,
        out=args.out,
        data=args.data,
        val_data=args.val_data,
        on_the_fly=args.on_the_fly,
        stretch=args.stretch,
        stretch_share=args.stretch_share,
        steps=args.steps,
        epochs=args.epochs,
        batch_size=args.batch_size,
        lr=args.lr,
        lr_step_epochs=args.lr_step_epochs,
        lr_gamma=args.lr_gamma,
        model_size=args.size,
        model_overrides=overrides,
        seed=args.seed,
        data_seed=args.data_seed,
        epoch_size=args.epoch_size,
        val_samples=args.val_samples,
        workers=args.workers,
        log_every=args.log_every,
        val_every=args.val_every,
        checkpoint_every=args.checkpoint_every,
        max_minutes=args.max_minutes,
        threads=args.threads,
        device=args.device,
        resume=args.resume,
        init_from=args.init,
        progress=not args.quiet,
        allow_changed_settings=args.allow_changed_settings,
        augment=args.augment,
        augment_settings=_augment_settings(args.augment_set),
        new_priors=args.new_priors,
    )
    card = train(tc)
    if card:
        val = card.get("final_validation", {})
        extra = f", validation loss {val['loss']:.4f}" if "loss" in val else ""
        print(f"trained {card['category']} for {card['steps']} steps ({card['train_time_s']:.0f} s{extra}); model in {args.out}")
    return 0


def _augment_settings(items: list[str] | None) -> dict:
    """``--augment-set KEY=VALUE ...`` as ``{key: float or [lo, hi]}`` (checked by the training config)."""
    out: dict = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise UcopeError(f"--augment-set {item!r}: write KEY=VALUE, e.g. p_noise=0.6 or noise_m=0.002,0.010")
        try:
            nums = [float(x) for x in value.split(",")]
        except ValueError:
            raise UcopeError(f"--augment-set {item!r}: the value must be a number or LO,HI") from None
        out[key.strip()] = nums[0] if len(nums) == 1 else nums
    return out


def _estimator(args: argparse.Namespace):
    from ..estimation.estimator import Estimator
    from .outputs import estimator_options

    return Estimator.load(args.model, **estimator_options(args))


def _expand_inputs(spec: str) -> list[Path]:
    import glob

    from ..data.io import POINT_CLOUD_SUFFIXES

    p = Path(spec)
    if p.is_dir():
        files = sorted(f for f in p.iterdir() if f.suffix.lower() in POINT_CLOUD_SUFFIXES)
    elif any(ch in spec for ch in "*?["):
        files = sorted(Path(f) for f in glob.glob(spec))
    else:
        files = [p]
    if not files:
        raise UcopeError(f"--input {spec!r} matches no point cloud files ({', '.join(POINT_CLOUD_SUFFIXES)})")
    return files


def format_errors(result, errors: dict) -> str:
    lines = []
    for p, e in zip(result.parts, errors["parts"], strict=False):
        lines.append(
            f"  {p.label:14s} rotation {e['rotation_deg']:6.2f} deg  translation {100 * e['translation_m']:6.2f} cm  3D IoU "
            f"{e['iou']:.3f}"
        )
    for j, e in zip(result.joints, errors["joints"], strict=False):
        if e is None:  # no ground truth for this joint (BOP)
            continue
        piv = f"  pivot {100 * e['pivot_m']:5.2f} cm" if e["pivot_m"] is not None else ""
        st = f"{e['state_error']:.2f} deg" if e["state_unit"] == "deg" else f"{100 * e['state_error']:.2f} cm"
        lines.append(f"  joint {j.parent}->{j.child} ({j.type}): axis {e['axis_deg']:5.2f} deg{piv}  state {st}")
    return "\n".join(lines)


def _predict_jobs(args: argparse.Namespace) -> tuple[list, dict | None]:
    """``(jobs, frame)``: ``(name, load)`` per input, ``load() -> (points, normals, sample_or_None, units)``
    (files are read inside their own job, so that one bad file fails alone), and the RGB-D frame to draw
    over (``--depth``) or ``None``."""
    from ..data.io import read_depth_png, read_intrinsics
    from .outputs import read_rgb

    if args.depth is not None:
        from ..estimation.inputs import rgbd_points

        if args.intrinsics is None:
            raise UcopeError("--depth needs --intrinsics K.json")
        mask = read_depth_png(args.mask) if args.mask is not None else None
        depth, K = read_depth_png(args.depth), read_intrinsics(args.intrinsics)
        pts = rgbd_points(depth, K, mask=mask, box=args.box, depth_scale=args.depth_scale, mask_label=args.mask_label)
        frame = {
            "depth_m": depth.astype(float) / args.depth_scale,
            "intrinsics": K,
            "title": Path(args.depth).stem,
            "rgb": read_rgb(args.rgb, depth.shape) if args.rgb else None,
        }
        return [(Path(args.depth).stem, lambda: (pts, None, None, "m"))], frame
    if args.data is not None:
        from ..data.dataset import load_dataset

        ds = load_dataset(args.data)
        for i in args.index or [0]:
            if not -len(ds) <= i < len(ds):
                raise UcopeError(f"--index {i} is out of range: {args.data} holds {len(ds)} samples")
        jobs = [
            (f"{ds.category}_{i % len(ds):06d}", lambda i=i: (ds[i]["points"], ds[i]["normals"], ds[i], "m"))
            for i in args.index or [0]
        ]
        return jobs, None
    if args.input is not None:
        return [(f.stem, lambda f=f: (*_read_cloud(f), None, args.units)) for f in _expand_inputs(args.input)], None
    raise UcopeError("give --input CLOUD (or a folder / glob), --depth D.png --intrinsics K.json, or --data DIR --index I")


def _read_cloud(path: Path):
    """``(points, normals)`` of one ``--input`` file; a note on stderr when its points carry several instance
    ids (it is then estimated as one object: ``--instances`` estimates each)."""
    import numpy as np

    from ..data.io import read_point_cloud
    from ..data.readers.clouds import read_instance_ids

    pts, nrm = read_point_cloud(path)
    ids = read_instance_ids(path)
    if ids is not None and len(np.unique(ids)) > 1:
        shown = np.unique(ids).tolist()
        print(
            f"ucope predict: {path.name} carries per-point instance ids {shown[:8]}{'...' if len(shown) > 8 else ''}: "
            "estimated as one object; --instances ID=MODEL ... estimates each with its model",
            file=sys.stderr,
        )
    return pts, nrm


def _check_predict_options(args: argparse.Namespace) -> None:
    """Refuse the ``predict`` options that the others given would ignore, then fill in the defaults of
    those whose use depends on another (``--units``, ``--depth-scale``, ``--bop-scene-id``)."""
    sources = [o for o, v in (("--input", args.input), ("--depth", args.depth), ("--data", args.data)) if v is not None]
    if len(sources) > 1:
        raise UcopeError(f"give one input: {' and '.join(sources)} cannot be combined (all but one would be ignored)")
    if args.instances:
        for option, value in (("--data", args.data),):
            if value is not None:
                raise UcopeError(
                    f"{option} does not go with --instances (the instance mask --mask, or the cloud's per-point ids, select "
                    "each object)"
                )
    if args.depth is None:
        frame_only = {
            "--mask": args.mask,
            "--box": args.box,
            "--rgb": args.rgb,
            "--intrinsics": args.intrinsics,
            "--depth-scale": args.depth_scale,
            "--mask-label": args.mask_label,
        }
        given = [o for o, v in frame_only.items() if v is not None]
        if given:
            raise UcopeError(f"{', '.join(given)} {'is' if len(given) == 1 else 'are'} for a --depth frame: add --depth D.png")
    if args.mask_label is not None and args.mask is None:
        raise UcopeError("--mask-label picks values of the --mask image: add --mask M.png")
    if args.rgb is not None and args.vis is None and not args.instances:
        raise UcopeError("--rgb is drawn under the estimates by --vis: add --vis PNG")
    if args.index is not None and args.data is None:
        raise UcopeError("--index picks samples of a data set: add --data DIR")
    if args.units is not None and args.input is None:
        raise UcopeError(
            "--units is the length unit of --input clouds (depth images have --depth-scale; data sets are in metres)"
        )
    bop = [("--bop-scene-id", args.bop_scene_id), ("--bop-im-id", args.bop_im_id), ("--bop-obj-id", args.bop_obj_id)]
    given = [o for o, v in bop if v is not None]
    if given and args.bop_csv is None:
        raise UcopeError(f"{', '.join(given)} {'sets' if len(given) == 1 else 'set'} the rows of --bop-csv: add --bop-csv FILE")
    args.units = "m" if args.units is None else args.units
    args.depth_scale = 1000.0 if args.depth_scale is None else args.depth_scale
    args.bop_scene_id = 0 if args.bop_scene_id is None else args.bop_scene_id


def _result_path(out: str, name: str, many: bool) -> Path:
    """Where a result goes: ``OUT/NAME.json`` when there are several results or ``--out`` names a folder
    (it exists as one, or ends with a slash), else ``OUT`` itself."""
    return Path(out) / f"{name}.json" if _out_is_folder(out, many) else Path(out)


def _out_is_folder(out: str, many: bool) -> bool:
    return many or out.endswith(("/", "\\")) or Path(out).is_dir()


def cmd_predict(args: argparse.Namespace) -> int:
    import numpy as np

    from ..estimation.inputs import UNITS, roll_to_up
    from ..fileio import atomic_write_json
    from .outputs import Job, check_outputs, check_view_options, job_im_ids, predict_instances, write_outputs

    _check_predict_options(args)
    check_view_options(args)
    if args.up is not None:
        try:
            roll_to_up(args.up)
        except UcopeError as e:
            raise UcopeError(f"--up: {e}") from None
    if args.vis is not None:
        from ..plotting import pyplot

        pyplot()  # a missing matplotlib is said before any work
    pictures = [("--vis", args.vis, False), ("--bop-csv", args.bop_csv, False), ("--view-html", args.view_html, False)]
    if args.instances:
        check_outputs([("--out", args.out, False), *pictures])
        return predict_instances(args)
    if args.model is None:
        raise UcopeError("--model is required (or --instances ID=MODEL ... for several objects in one frame)")
    jobs, frame = _predict_jobs(args)
    many = len(jobs) > 1
    check_outputs([("--out", args.out, _out_is_folder(args.out, many)), *pictures])
    est = _estimator(args)
    bar = None
    if many and not args.quiet:
        try:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(jobs), desc="predict", unit="cloud", file=sys.stderr)
        except ImportError:  # pragma: no cover - tqdm is an optional extra
            bar = None
    done, failed = [], []
    for name, load in jobs:
        try:
            pts, nrm, s, units = load()
            res = est.predict(pts, None if args.ignore_normals else nrm, units=units, up=args.up)
            if s is not None:
                from ..eval.evaluate import sample_errors

                res.errors = sample_errors(res, s)
            d = res.to_dict()
            path = _result_path(args.out, name, many)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise UcopeError(f"cannot create the folder {path.parent}: {e.strerror or e}") from None
            atomic_write_json(path, d)
        except UcopeError as e:
            failed.append(name)
            print(f"ucope predict: {name}: error: {e}", file=sys.stderr)
            continue
        finally:
            if bar is not None:
                bar.update(1)
        t = res.timings_ms.get("total", 0.0)
        print(f"{name}: {len(res.parts)} part(s), {len(res.joints)} joint(s) in {t:.0f} ms -> {path}")
        for w in res.warnings:
            print(f"  warning: {w}")
        if s is not None:
            print(format_errors(res, d["errors"]))
        done.append((name, res, np.asarray(pts, dtype=np.float64).reshape(-1, 3) * UNITS[units], s, d.get("errors")))
    if bar is not None:
        bar.close()
    im_ids = job_im_ids([name for name, *_ in done], args, [s for *_, s, _ in done])
    write_outputs(
        args, [Job(name, res, pts, s, err, im_id=i) for (name, res, pts, s, err), i in zip(done, im_ids, strict=False)], frame
    )
    if failed:
        print(f"ucope predict: {len(failed)} of {len(jobs)} input(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 2
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from ..data.dataset import load_dataset
    from ..eval.evaluate import evaluate, format_report
    from ..fileio import atomic_write_json
    from .outputs import check_eval_format_options, writable_path

    if args.data is not None and args.data_dir is not None:
        raise UcopeError(f"give the data set once: DIR ({args.data_dir}) or --data ({args.data})")
    args.data = args.data or args.data_dir
    if args.data is None:
        raise UcopeError("give the data set: --data DIR (or DIR)")
    if args.num is not None and args.num <= 0:
        raise UcopeError(f"--num must be positive, got {args.num}")
    check_eval_format_options(args)
    writable_path(args.out, "--out")
    est = _estimator(args)
    if args.format != "ucope":
        from .outputs import eval_samples

        ds, info = eval_samples(args, est.category)
    else:
        ds = load_dataset(args.data)
        info = {
            "path": str(Path(args.data).resolve()),
            "split": ds.meta.get("split"),
            "seed": ds.meta.get("seed"),
            "generator_version": ds.meta.get("generator_version"),
            "category_revision": ds.meta.get("category_revision", 1),
        }
    n = len(ds) if args.num is None else min(len(ds), args.num)
    if n <= 0:
        raise UcopeError(f"--num must be positive, got {args.num}")
    report = evaluate(est, ds[:n], progress=not args.quiet, data_info=info)
    report["command"] = "ucope " + shlex.join(args.argv)
    out = Path(args.out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UcopeError(f"--out {out}: cannot create its folder ({e.strerror or e})") from None
    atomic_write_json(out, report)
    print(format_report(report))
    print(f"wrote {out}")
    return 0


def _estimator_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`_estimator` (shared by predict and eval): the model card's pipeline, changed."""
    p.add_argument("--pairs", type=int, default=None, help="point pairs per object (default: the model's, 20000)")
    p.add_argument(
        "--stages",
        default=None,
        help="the stages to run, in order, comma-separated (default: the model's own; `ucope pipeline --model M` lists them)",
    )
    p.add_argument("--drop-stage", nargs="+", default=[], metavar="STAGE", help="leave these stages of the model's list out")
    p.add_argument("--fast", action="store_true", help="one estimate of one pass (no recrop, scale search or restarts)")
    p.add_argument(
        "--set",
        nargs="+",
        default=[],
        metavar="STAGE.PARAM=VALUE",
        help="change a stage parameter or the search policy, e.g. vote_parts.num_pairs=5000 search.restarts=0 "
        "free_space.upright_margin_deg=null (docs/pipeline.md lists them)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the subsampling and pair draws (>= 0)")
    p.add_argument("--device", default="cpu", help="torch device of the network: cpu (default), cuda, cuda:1, mps")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def cmd_pipeline(args: argparse.Namespace) -> int:
    from ..estimation.pipeline import describe

    est = _estimator(args)
    print(f"{est.name}: {len(est.pipeline.stages)} stages ({est.category}, {est.cfg.num_parts} parts)")
    print(describe(est.pipeline))
    return 0


def build_parser() -> argparse.ArgumentParser:
    from ..objects.categories import CATEGORY_NAMES, SPLITS
    from .outputs import add_eval_format_options, add_output_options, add_view_options

    p = argparse.ArgumentParser(
        prog="ucope", description="Universal 9D category-level pose estimation of rigid and articulated objects."
    )
    p.add_argument("--version", action="version", version=f"ucope {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    c = sub.add_parser(
        "categories",
        help="list the procedural categories (K, joints, symmetry), or check a category spec of your own objects",
    )
    c.add_argument(
        "--spec", default=None, help="category spec JSON file (docs/own_objects.md): check it, read its files, draw it"
    )
    c.add_argument("--picture", default=None, help="with --spec: the conventions picture to write (default conventions_NAME.png)")
    c.add_argument("--no-picture", action="store_true", help="with --spec: check only, draw nothing")
    c.set_defaults(func=cmd_categories)

    g = sub.add_parser("generate", help="generate a synthetic data set (sharded, resumable)")
    what = g.add_mutually_exclusive_group(required=True)
    what.add_argument("--category", help=f"one of: {', '.join(CATEGORY_NAMES)}")
    what.add_argument("--spec", help="a category spec JSON file of your own objects (docs/own_objects.md)")
    g.add_argument("--split", default="train", choices=SPLITS, help="instance split (disjoint instance streams)")
    g.add_argument("--num", type=int, required=True, help="number of views")
    g.add_argument("--out", required=True, help="output folder (created; re-running resumes)")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--workers", type=int, default=1, help="processes (the output does not depend on it)")
    g.add_argument("--shards", default=None, help="START:STOP: make only these shards (to split work across machines)")
    g.add_argument("--shard-size", type=int, default=100, help="views per shard file")
    g.add_argument("--views-per-instance", type=int, default=8, help="consecutive views of each object instance")
    g.add_argument("--max-points", type=int, default=4096, help="points kept per view")
    g.add_argument("--images", action="store_true", help="also write depth/mask PNGs and BOP-style scene_camera/scene_gt JSON")
    g.add_argument("--no-noise", action="store_true", help="clean depth (no sensor noise model)")
    g.add_argument("--no-floor", action="store_true", help="no floor plane")
    g.add_argument("--distractors", type=int, default=2, help="maximum number of distractor objects per view")
    g.add_argument(
        "--adjacent-distractor",
        type=float,
        default=0.5,
        metavar="P",
        help="chance that a view gets a distractor right next to the object in the image (default 0.5)",
    )
    g.add_argument(
        "--scale",
        type=float,
        default=None,
        help="build every instance at this uniform scale (the camera distance " "scales too): the same shapes at another size",
    )
    g.add_argument(
        "--stretch",
        type=_number_pair,
        default=None,
        metavar="LOW,HIGH",
        help="stretch every instance along its x, y and z axes by factors drawn log-uniformly in [LOW, HIGH] "
        "(0 < LOW <= 1 <= HIGH): training data with other proportions than the generators make",
    )
    g.add_argument(
        "--stretch-share",
        type=float,
        default=1.0,
        metavar="P",
        help="with --stretch: the share of instances stretched, the others kept as generated (default 1)",
    )
    g.add_argument("--quiet", action="store_true", help="no progress bar")
    g.set_defaults(func=cmd_generate)

    s = sub.add_parser("show", help="draw samples of a data set: points by part, GT boxes and joint axes")
    s.add_argument("data", help="data set folder")
    s.add_argument("--index", type=int, nargs="+", default=None, help="sample index(es), default 0")
    s.add_argument("--out", default=None, help="PNG file to write (or --view / --view-html)")
    add_view_options(s)
    s.set_defaults(func=cmd_show)

    t = sub.add_parser(
        "train",
        help="train a model (single process, or DDP under torchrun)",
        description="Train a U-COPE model. Multi-GPU / multi-machine: torchrun --nproc_per_node=N -m ucope train ...",
    )
    t.add_argument("--category", required=True, help=f"one of: {', '.join(CATEGORY_NAMES)}")
    src = t.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="training data set folder (from `ucope generate --split train`)")
    src.add_argument("--on-the-fly", action="store_true", help="generate training samples in the data-loader workers instead")
    t.add_argument(
        "--val-data", default=None, help="held-out data set folder (default: --val-samples views generated from the val split)"
    )
    t.add_argument("--out", required=True, help="run folder (metrics, checkpoints, model)")
    n = t.add_mutually_exclusive_group(required=True)
    n.add_argument("--steps", type=int, help="optimiser steps")
    n.add_argument("--epochs", type=float, help="passes over the data (on the fly: of --epoch-size samples)")
    t.add_argument("--batch-size", type=int, default=8, help="items per step and per process (default 8)")
    t.add_argument(
        "--size", choices=["slim", "full"], default="slim", help="slim: 1024 points, half widths (default); full: 2048 points"
    )
    t.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (default 1e-3)")
    t.add_argument(
        "--lr-step-epochs", type=float, default=10.0, help="multiply the lr by --lr-gamma every this many epochs (default 10)"
    )
    t.add_argument("--lr-gamma", type=float, default=0.1)
    t.add_argument("--pairs-per-part", type=int, default=None, help="point pairs per part per item (default 512)")
    t.add_argument(
        "--seg-weighting",
        choices=["balanced", "points"],
        default=None,
        help="segmentation cross-entropy: balanced over parts (default) or over points (better for look-alike parts)",
    )
    t.add_argument("--lambda-seg", type=float, default=None, help="weight of the segmentation loss in eq. (7) (default 0.2)")
    t.add_argument("--lambda-joint", type=float, default=None, help="weight of the joint loss (default 0.2)")
    t.add_argument("--lambda-pose", type=float, default=None, help="weight of the pose loss (default 0.6)")
    t.add_argument(
        "--augment",
        type=float,
        default=0.0,
        metavar="P",
        help="corrupt each training item with chance P (occlusion, floor and neighbour points, outliers, noise, "
        "fewer points; the model gets a background class); default 0: off",
    )
    t.add_argument(
        "--augment-set",
        nargs="+",
        default=None,
        metavar="KEY=VALUE",
        help="with --augment: change a corruption's chance or level range from ucope.data.augment's table, "
        "e.g. p_noise=0.6 noise_m=0.002,0.010 resample_points=100,1000 (ranges as LO,HI; metres for noise_m)",
    )
    t.add_argument(
        "--head",
        choices=["voting", "regression"],
        default="voting",
        help="voting: U-COPE (default); regression: the direct-regression baseline (same encoder, masks and joint heads)",
    )
    t.add_argument("--seed", type=int, default=0, help="seed of the weights, sample order and draws")
    t.add_argument("--data-seed", type=int, default=0, help="seed of generated samples (--on-the-fly, default validation set)")
    t.add_argument("--epoch-size", type=int, default=4000, help="samples per epoch with --on-the-fly")
    t.add_argument(
        "--stretch",
        type=_number_pair,
        default=None,
        metavar="LOW,HIGH",
        help="with --on-the-fly: stretch the generated instances as `ucope generate --stretch` does",
    )
    t.add_argument(
        "--stretch-share",
        type=float,
        default=1.0,
        metavar="P",
        help="with --stretch: the share of instances stretched (default 1)",
    )
    t.add_argument("--val-samples", type=int, default=200, help="validation samples (default 200)")
    t.add_argument("--workers", type=int, default=0, help="data-loader worker processes (default 0)")
    t.add_argument("--log-every", type=int, default=25)
    t.add_argument("--val-every", type=int, default=500)
    t.add_argument("--checkpoint-every", type=int, default=500)
    t.add_argument("--max-minutes", type=float, default=None, help="stop with a checkpoint and a model after this wall time")
    t.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    t.add_argument("--device", choices=["auto", "cpu", "cuda"], default="auto")
    t.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint (with the same settings)")
    t.add_argument(
        "--allow-changed-settings",
        action="store_true",
        help="with --resume: go on even though settings that change the model differ from the checkpoint's",
    )
    t.add_argument(
        "--init",
        default=None,
        metavar="MODEL",
        help="fine-tune: start from this model's weights (a shipped model name such as laptop, a run folder "
        "or a model .json) with a fresh optimiser; its network and category statistics are kept",
    )
    t.add_argument(
        "--new-priors",
        action="store_true",
        help="with --init: measure the category priors on this training data instead of keeping the initial model's",
    )
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.set_defaults(func=cmd_train)

    pr = sub.add_parser(
        "predict",
        help="estimate part poses, joints and segmentation of objects",
        description="Estimate 9D part poses from a point cloud, a folder / glob of clouds, an RGB-D frame, or data-set samples. "
        "A cloud is ONE segmented object (not a whole scene) in the CAMERA frame (OpenCV axes: x right, "
        "y down, z forward from the camera), in metres unless --units says otherwise. Results are in metres.",
    )
    pr.add_argument(
        "--model",
        default=None,
        help="a shipped model name (e.g. laptop), a run folder or a model .json (required unless --instances)",
    )
    pr.add_argument(
        "--input",
        help="point cloud file (.npy .npz .ply .pcd .xyz .txt .pts; organised clouds too), a folder or a "
        "glob (quote it): one segmented object in the camera frame",
    )
    pr.add_argument("--units", choices=["m", "cm", "mm"], default=None, help="length unit of the --input clouds (default m)")
    pr.add_argument("--ignore-normals", action="store_true", help="estimate normals even when the file holds some")
    pr.add_argument(
        "--up",
        type=float,
        nargs=3,
        default=None,
        metavar=("X", "Y", "Z"),
        help="the world's up direction in the camera frame (e.g. from an IMU): the cloud is turned about the optical "
        "axis to take out the camera's roll for the estimate (the models were trained on upright cameras)",
    )
    pr.add_argument("--depth", help="depth PNG (16-bit; see --depth-scale)")
    pr.add_argument("--intrinsics", help="camera intrinsics JSON (fx, fy, cx, cy or K / cam_K)")
    pr.add_argument("--mask", help="object mask PNG (non-zero = object, or see --mask-label)")
    pr.add_argument("--mask-label", type=int, nargs="+", default=None, help="mask values that belong to the object")
    pr.add_argument(
        "--box", type=float, nargs=4, default=None, metavar=("X0", "Y0", "X1", "Y1"), help="pixel box to crop the depth to"
    )
    pr.add_argument(
        "--depth-scale", type=float, default=None, help="with --depth: depth units per metre (default 1000: millimetres)"
    )
    pr.add_argument(
        "--data", help="a data set folder: predict on its samples (--index) and report errors against the ground truth"
    )
    pr.add_argument("--index", type=int, nargs="+", default=None, help="sample index(es) with --data (default 0)")
    pr.add_argument(
        "--out",
        required=True,
        help="result JSON, or a folder (an existing one, or a path ending with /; always with several inputs)",
    )
    pr.add_argument(
        "--vis", default=None, help="also draw the estimates into this PNG (over the depth image, and the --rgb image)"
    )
    add_output_options(pr)
    _estimator_options(pr)
    pr.set_defaults(func=cmd_predict)

    pl = sub.add_parser("pipeline", help="print a model's stages, in order, with what each does, and its search policy")
    pl.add_argument("--model", required=True, help="a shipped model name (e.g. drawer), a run folder or a model .json")
    _estimator_options(pl)
    pl.set_defaults(func=cmd_pipeline)

    mo = sub.add_parser("models", help="list the models shipped inside the package, with their test-split figures")
    mo.set_defaults(func=cmd_models)

    ev = sub.add_parser(
        "eval",
        help="evaluate a model on a (test) data set: Table-2 / Table-1 shaped figures and a JSON report",
        description="Predict on every sample of --data and measure per-part, joint, segmentation and (rigid) mAP metrics.",
    )
    ev.add_argument("--model", required=True, help="a shipped model name (e.g. laptop), a run folder or a model .json")
    ev.add_argument("data_dir", nargs="?", default=None, metavar="DIR", help="the data set folder (or --data DIR)")
    ev.add_argument("--data", default=None, help="data set folder (e.g. from `ucope generate --split test`; see --format)")
    ev.add_argument("--out", required=True, help="report JSON to write")
    ev.add_argument("--num", type=int, default=None, help="evaluate only the first NUM samples")
    add_eval_format_options(ev)
    _estimator_options(ev)
    ev.set_defaults(func=cmd_eval)

    d = sub.add_parser(
        "demo", help="run the shipped models on unseen test views, print errors against the ground truth, draw them"
    )
    d.add_argument("--out", default="demo_out", help="folder for the pictures and result JSONs (default demo_out)")
    d.add_argument("--categories", nargs="+", default=["laptop", "mug"], help="shipped models to run (default laptop mug)")
    d.add_argument("--num", type=int, default=2, help="views per category (default 2)")
    d.add_argument("--pairs", type=int, default=20000, help="point pairs per object (default 20000)")
    d.add_argument("--seed", type=int, default=0)
    d.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    args.argv = argv
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except UcopeError as e:
        print(f"ucope {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print(f"ucope {args.command}: error: out of memory (lower --pairs, or the size of the input)", file=sys.stderr)
        return 2
    except Exception as e:  # a bug of ours: one line, the traceback on request
        if os.environ.get("UCOPE_DEBUG"):
            raise
        if isinstance(e, OSError) and e.filename is not None:  # the file system said no (a full disk...): not a bug
            print(f"ucope {args.command}: error: {e.filename}: {e.strerror or e}", file=sys.stderr)
            return 2
        print(
            f"ucope {args.command}: internal error: {type(e).__name__}: {e} (please report it; UCOPE_DEBUG=1 shows the "
            "traceback)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
