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
    if text is None:
        return None
    try:
        a, b = text.split(":")
        return range(int(a), int(b))
    except ValueError:
        raise UcopeError(f"--shards must look like START:STOP (e.g. 0:10), got {text!r}") from None


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

    if args.spec is not None:
        import warnings

        from ..objects.spec import load_spec

        with warnings.catch_warnings(record=True) as caught:  # one line each (a size off, an axis turned round)
            warnings.simplefilter("always")
            own = load_spec(args.spec)
        for w in caught:
            print(f"warning: {w.message}", file=sys.stderr)
        print(_spec_summary(own))
        if not args.no_picture:
            out = Path(args.picture or f"conventions_{own.name}.png")
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

    cfg = _generate_config(args)
    t0 = time.perf_counter()
    out = generate_dataset(args.out, cfg, workers=args.workers, shards=_parse_shards(args.shards), progress=not args.quiet)
    if not args.quiet:
        print(f"wrote {cfg.num} {cfg.category}/{cfg.split} views to {out} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
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
    if args.out is not None:
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

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    items = []
    t0 = time.perf_counter()
    for cat in args.categories:
        est = Estimator.load(cat, num_pairs=args.pairs, seed=args.seed)
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
        refine = " kinematic refinement on by default;" if (info.get("defaults") or {}).get("refine") else ""
        print(
            f"{name}: {len(part_names)} part(s) ({', '.join(part_names)}); {joints}; "
            f"{cfg['head']} head;{refine} {w['bytes'] / 1e6:.2f} MB {w.get('dtype', 'float32')}; "
            f"trained {' + '.join(str(x) for x in steps)} steps{tuned}"
        )
        if test:
            line = (
                f"  test split ({test.get('num_samples')} unseen views): rotation "
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
    from ..data.io import read_depth_png, read_intrinsics, read_point_cloud
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
        return [(f.stem, lambda f=f: (*read_point_cloud(f), None, args.units)) for f in _expand_inputs(args.input)], None
    raise UcopeError("give --input CLOUD (or a folder / glob), --depth D.png --intrinsics K.json, or --data DIR --index I")


def _result_path(out: str, name: str, many: bool) -> Path:
    """Where a result goes: ``OUT/NAME.json`` when there are several results or ``--out`` names a folder
    (it exists as one, or ends with a slash), else ``OUT`` itself."""
    folder = many or out.endswith(("/", "\\")) or Path(out).is_dir()
    return Path(out) / f"{name}.json" if folder else Path(out)


def cmd_predict(args: argparse.Namespace) -> int:
    import numpy as np

    from ..estimation.inputs import UNITS
    from ..fileio import atomic_write_json
    from .outputs import Job, job_im_ids, predict_instances, write_outputs

    if args.vis is not None:
        from ..plotting import pyplot

        pyplot()  # a missing matplotlib is said before any work
    if args.instances:
        return predict_instances(args)
    if args.model is None:
        raise UcopeError("--model is required (or --instances ID=MODEL ... for several objects in one frame)")
    est = _estimator(args)
    jobs, frame = _predict_jobs(args)
    many = len(jobs) > 1
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
            d = res.to_dict()
            if s is not None:
                from ..eval.evaluate import sample_errors

                d["errors"] = sample_errors(res, s)
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

    est = _estimator(args)
    args.data = args.data or args.data_dir
    if args.data is None:
        raise UcopeError("give the data set: --data DIR (or DIR)")
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
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out, report)
    print(format_report(report))
    print(f"wrote {out}")
    return 0


def _estimator_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`_estimator` (shared by predict and eval)."""
    p.add_argument("--pairs", type=int, default=20000, help="point pairs per object (default 20000)")
    p.add_argument("--no-awareness", action="store_true", help="turn part and joint awareness off (ablation)")
    p.add_argument(
        "--refine",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="kinematic refinement of the part poses, on or off (default: the model's own; the shipped "
        "eyeglasses, drawer, dishwasher and scissors models have it on)",
    )
    p.add_argument(
        "--remove-plane",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="leave out a floor or table plane under the object that the mask let in (default: the model's own; "
        "on for the shipped models where it measured better, docs/robustness.md)",
    )
    p.add_argument(
        "--grow-boxes",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="widen every part's box to hold the points segmented as that part, for objects of shapes the model "
        "never saw (default: the model's own; on for the shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--fit-extents",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="set the box axes that views like this one see whole from the points segmented as that part, larger or "
        "smaller than voted (default: the model's own; on for the shipped models where it measured better, "
        "docs/results.md)",
    )
    p.add_argument(
        "--anchor-faces",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="move the root part's box so that the faces the camera faces sit where its points put them (default: "
        "the model's own; on for the shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--align-faces",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="turn each part's voted rotation so that its box axes meet the normals of its flat faces (default: the "
        "model's own; on for the shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--free-space",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="turn a part that shows few points (a laptop base behind its lid) about its joint to where its box hides "
        "none of the points the camera sees and its own points lie on it (default: the model's own; on for the "
        "shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--carry-in-cone",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="re-place a part from its neighbour as soon as it tilts out of the upright cone of its training views, "
        "not only 10 degrees beyond (default: the model's own; on for the shipped models where it measured better, "
        "docs/results.md)",
    )
    p.add_argument(
        "--pick-seen-parts",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="let the scale search and the restarts compare estimates by the parts given points only (default: the "
        "model's own; on for the shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--seat-parts",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="put a part that shows few points and stands off its hinge (a closed door seen from behind) where its "
        "hinge meets its well-seen neighbour's (default: the model's own; on for the shipped models where it "
        "measured better, docs/results.md)",
    )
    p.add_argument(
        "--free-slides",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="slide a prismatic child that shows no points (a hidden drawer) back to the nearest state where the "
        "camera would not have seen it (default: the model's own; on for the shipped models where it measured "
        "better, docs/results.md)",
    )
    p.add_argument(
        "--denoise-above",
        type=float,
        default=None,
        metavar="MM",
        help="smooth a cloud whose surface noise is above this many millimetres (default: the model's own; "
        "docs/robustness.md)",
    )
    p.add_argument("--no-denoise", action="store_true", help="never smooth the cloud (whatever the model's default)")
    p.add_argument(
        "--no-recrop",
        action="store_true",
        help="one pass only: no second estimate on the points the first segmented as the object (default: two passes "
        "where the first leaves points out or finds the object outside the model's sizes; docs/robustness.md)",
    )
    p.add_argument(
        "--no-revolution-fit",
        action="store_true",
        help="keep the voted box of a part symmetric about y even where a surface-of-revolution fit to its points "
        "disagrees (default: the fit wins beyond 1.2x; docs/robustness.md)",
    )
    p.add_argument(
        "--no-scale-search",
        action="store_true",
        help="estimate once, at the scale the rescaling gives the cloud (default: also on the cloud normalised to the "
        "model's typical size, keeping the higher-scored estimate; docs/results.md)",
    )
    p.add_argument(
        "--wide-scale-search",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the scale search also tries the cloud normalised to 0.8x and 1.25x the model's typical size (default: "
        "the model's own; on for the shipped models where it measured better, docs/results.md)",
    )
    p.add_argument(
        "--restarts",
        type=int,
        default=None,
        metavar="N",
        help="up to N further estimates from other draws of the network's points while the best score stays low, "
        "keeping the highest-scored (default: the model's own; docs/results.md)",
    )
    p.add_argument(
        "--no-hold-children",
        action="store_true",
        help="keep a cabinet's box as voting and the fits made it (default: widened across the drawers' slides to "
        "hold the drawers' points too; docs/voting.md)",
    )
    p.add_argument(
        "--no-carry-depths",
        action="store_true",
        help="keep a drawer as deep as voting made it (default: as deep as its cabinet says, its front kept; " "docs/voting.md)",
    )
    p.add_argument(
        "--no-place-children",
        action="store_true",
        help="keep a drawer where voting put it (default: centred in its cabinet where the model's training views "
        "always had it so; docs/voting.md)",
    )
    p.add_argument(
        "--no-slide-fronts",
        action="store_true",
        help="keep a drawer where voting put it along its slide (default: slid until its front meets its points; "
        "docs/voting.md)",
    )
    p.add_argument(
        "--no-stack-children",
        action="store_true",
        help="keep a hidden drawer where voting put it (default: stacked against a seen drawer or under its "
        "cabinet's top; docs/voting.md)",
    )
    p.add_argument(
        "--no-turn-children",
        action="store_true",
        help="keep a door's or a lid's angle as voting made it (default: turned about its hinge to lie along its "
        "points; docs/voting.md)",
    )
    p.add_argument(
        "--no-flip-fronts",
        action="store_true",
        help="keep a cabinet facing the way voting turned it (default: turned round where its drawers' points say "
        "its front is its back; docs/voting.md)",
    )
    p.add_argument(
        "--no-rescale",
        action="store_true",
        help="estimate a cloud outside the model's training sizes as it is (default: scale it into them and the result back)",
    )
    p.add_argument(
        "--no-score-filter",
        action="store_true",
        help="every pair votes for its part, whatever its part score (ablation of the paper's eq. (10) alone)",
    )
    p.add_argument(
        "--pairs-from-cloud",
        action="store_true",
        help="draw each part's pairs from the whole cloud, not from the points segmented as that part (ablation)",
    )
    p.add_argument(
        "--no-vote-caps",
        action="store_true",
        help="every pair votes the axes and the centre grid (ablation; default: evenly strided subsets of at most "
        "1,024 pairs per part vote the axes and 4,096 the centre grid, which is as accurate and faster)",
    )
    p.add_argument(
        "--keep-flips",
        action="store_true",
        help="do not turn back half-turn flips (parts against their revolute joint, rigid objects against their shape; ablation)",
    )
    p.add_argument(
        "--no-upright",
        action="store_true",
        help="do not re-place a part voted far off the upright the training views kept it in from its neighbour, "
        "nor turn a rigid object voted upside down over (use with a rolled camera or one below the object)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the subsampling and pair draws (>= 0)")
    p.add_argument("--device", default="cpu", help="torch device of the network: cpu (default), cuda, cuda:1, mps")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


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
    pr.add_argument("--units", choices=["m", "cm", "mm"], default="m", help="length unit of the --input clouds (default m)")
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
    pr.add_argument("--depth-scale", type=float, default=1000.0, help="depth units per metre (default 1000: millimetres)")
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
        print(
            f"ucope {args.command}: internal error: {type(e).__name__}: {e} (please report it; UCOPE_DEBUG=1 shows the "
            "traceback)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
