import json

import numpy as np
import pytest

from ucope.cli.main import main
from ucope.data.generate import GenerateConfig, make_sample
from ucope.errors import DataError, InputError
from ucope.estimation import MIN_POINTS, Estimator, rgbd_points
from ucope.estimation.result import PoseResult
from ucope.model.train import TrainConfig, train

TINY_ENCODER = dict(width=0.25, npoints=(64, 16), radii=(0.15, 0.3), nsamples=(8, 8))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A tiny laptop model trained for a few steps (end-to-end plumbing, not accuracy)."""
    from ucope.model.pointnet2 import PointNet2Config

    out = tmp_path_factory.mktemp("run")
    train(
        TrainConfig(
            category="laptop",
            out=str(out),
            on_the_fly=True,
            epoch_size=8,
            steps=4,
            batch_size=2,
            val_samples=2,
            model_overrides=dict(encoder=PointNet2Config(**TINY_ENCODER), num_points=256, pairs_per_part=32, hidden=32),
            progress=False,
            threads=1,
        )
    )
    return out


@pytest.fixture(scope="module")
def est(tiny_run):
    return Estimator.load(tiny_run, num_pairs=2000)


@pytest.fixture(scope="module")
def sample():
    return make_sample(GenerateConfig(category="laptop", split="test", num=4, views_per_instance=1), 0)


def test_predict_end_to_end_on_a_data_set_sample(est, sample):
    r = est.predict_sample(sample)
    assert isinstance(r, PoseResult) and r.category == "laptop"
    assert [p.label for p in r.parts] == ["base", "lid"]
    for p in r.parts:
        R = p.cam_from_part[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-5)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-5)
        assert np.all(p.size_m > 0) and np.all(np.isfinite(p.cam_from_part))
    assert len(r.joints) == 1 and r.joints[0].type == "revolute"
    assert np.linalg.norm(r.joints[0].axis) == pytest.approx(1.0, abs=1e-5)
    assert r.part_labels.shape == (len(sample["points"]),) and set(np.unique(r.part_labels)) <= {0, 1}
    assert set(r.timings_ms) >= {"preprocess", "encoder", "pair_encoder", "voting", "total"}
    assert PoseResult.from_json(r.to_json()).to_dict() == r.to_dict()


def test_predict_is_repeatable_and_estimates_normals(est, sample):
    a = est.predict(sample["points"])  # no normals given: estimated
    b = est.predict(sample["points"])
    assert a.to_dict()["parts"] == b.to_dict()["parts"]


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.zeros((0, 3)), "empty"),
        (np.zeros((10, 3)), f"at least {MIN_POINTS}"),
        (np.zeros((100, 2)), r"shape \(N, 3\)"),
        (np.zeros((5, 100, 4)), r"shape \(N, 3\)"),
        (np.zeros((2, 5, 100, 3)), r"shape \(N, 3\)"),
        (np.full((200, 3), np.nan), "usable"),
        (np.array([["a", "b", "c"]] * 40), "real numbers"),
        (np.ones((100, 3)), "coincide"),
    ],
)
def test_bad_clouds_get_clear_errors(est, bad, match):
    with pytest.raises(InputError, match=match):
        est.predict(bad)


def test_nan_rows_are_dropped_with_a_warning(est, sample):
    pts = np.array(sample["points"], dtype=np.float64)
    pts[::7] = np.nan
    pts[3] = np.inf
    r = est.predict(pts)
    assert any("dropped" in w for w in r.warnings)
    bad = ~np.isfinite(pts).all(1)
    assert np.all(r.part_labels[bad] == -1) and np.all(r.part_labels[~bad] >= 0)


def test_wrong_normals_shape_is_named(est, sample):
    with pytest.raises(InputError, match="normals"):
        est.predict(sample["points"], sample["normals"][:10])


def test_huge_cloud_is_subsampled(est, sample):
    rng = np.random.default_rng(0)
    base = np.asarray(sample["points"], np.float32)
    big = base[rng.integers(0, len(base), 2_000_000)] + rng.normal(0, 1e-3, (2_000_000, 3)).astype(np.float32)
    r = est.predict(big)
    assert r.num_points == 2_000_000 and r.part_labels.shape == (2_000_000,) and np.all(r.part_labels >= 0)


def test_rgbd_back_projection_mask_and_box():
    depth = np.zeros((40, 60), np.uint16)
    depth[10:30, 20:40] = 1500
    depth[0, 0] = 500  # a stray pixel outside the mask
    mask = np.zeros((40, 60), np.uint8)
    mask[10:30, 20:40] = 3
    K = (50.0, 50.0, 30.0, 20.0)
    pts = rgbd_points(depth, K, mask=mask, mask_label=3)
    assert len(pts) == 400 and np.allclose(pts[:, 2], 1.5)
    assert len(rgbd_points(depth, K, box=(20, 10, 30, 20))) == 100
    with pytest.raises(InputError, match="no valid depth"):
        rgbd_points(depth, K, mask=mask, mask_label=7)
    with pytest.raises(InputError, match="mask has shape"):
        rgbd_points(depth, K, mask=mask[:5])
    with pytest.raises(InputError, match="intrinsics"):
        rgbd_points(depth, (0.0, 50.0, 30.0, 20.0))
    with pytest.raises(InputError, match="box"):
        rgbd_points(depth, K, box=(50, 10, 20, 30))


def test_missing_or_tampered_model(tiny_run, tmp_path):
    with pytest.raises(DataError, match="no model 'toaster'"):
        Estimator.load("toaster")
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(tiny_run, bad)
    w = bad / "model.safetensors"
    data = bytearray(w.read_bytes())
    data[-50] ^= 0x01
    w.write_bytes(bytes(data))
    with pytest.raises(DataError, match="modified"):
        Estimator.load(bad)


def test_cli_predict_on_files_folder_and_dataset(tiny_run, sample, tmp_path, capsys):
    np.save(tmp_path / "a.npy", sample["points"])
    np.savetxt(tmp_path / "b.xyz", np.asarray(sample["points"])[:800])
    assert (
        main(
            [
                "predict",
                "--model",
                str(tiny_run),
                "--input",
                str(tmp_path / "a.npy"),
                "--out",
                str(tmp_path / "a.json"),
                "--pairs",
                "1000",
                "--vis",
                str(tmp_path / "a.png"),
            ]
        )
        == 0
    )
    d = json.loads((tmp_path / "a.json").read_text())
    assert d["format"] == "ucope-result/1" and len(d["parts"]) == 2
    assert (tmp_path / "a.png").stat().st_size > 1000
    assert (
        main(
            [
                "predict",
                "--model",
                str(tiny_run),
                "--input",
                str(tmp_path),
                "--out",
                str(tmp_path / "many"),
                "--pairs",
                "1000",
                "--quiet",
            ]
        )
        == 0
    )
    assert sorted(p.name for p in (tmp_path / "many").iterdir()) == ["a.json", "b.json"]
    main(
        [
            "generate",
            "--category",
            "laptop",
            "--split",
            "test",
            "--num",
            "2",
            "--shard-size",
            "2",
            "--out",
            str(tmp_path / "d"),
            "--quiet",
        ]
    )
    capsys.readouterr()
    assert (
        main(
            [
                "predict",
                "--model",
                str(tiny_run),
                "--data",
                str(tmp_path / "d"),
                "--index",
                "0",
                "1",
                "--out",
                str(tmp_path / "ds"),
                "--pairs",
                "1000",
                "--vis",
                str(tmp_path / "ds.png"),
                "--quiet",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "rotation" in printed and "joint 0->1 (revolute)" in printed
    d = json.loads((tmp_path / "ds" / "laptop_000000.json").read_text())
    assert set(d["errors"]["parts"][0]) >= {"rotation_deg", "translation_m", "iou"}


def test_cli_predict_rgbd_and_errors(tiny_run, tmp_path, capsys):
    from ucope.data.images import write_png

    cfg = GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1)
    s, view = make_sample(cfg, 0, return_view=True)
    write_png(tmp_path / "d.png", view.depth_mm)
    write_png(tmp_path / "m.png", view.mask)
    (tmp_path / "K.json").write_text(
        json.dumps({"fx": s["intrinsics"][0], "fy": s["intrinsics"][1], "cx": s["intrinsics"][2], "cy": s["intrinsics"][3]})
    )
    assert (
        main(
            [
                "predict",
                "--model",
                str(tiny_run),
                "--depth",
                str(tmp_path / "d.png"),
                "--mask",
                str(tmp_path / "m.png"),
                "--mask-label",
                "0",
                "1",
                "--intrinsics",
                str(tmp_path / "K.json"),
                "--out",
                str(tmp_path / "r.json"),
                "--pairs",
                "1000",
            ]
        )
        == 0
    )
    assert json.loads((tmp_path / "r.json").read_text())["num_points"] > 100
    assert main(["predict", "--model", str(tiny_run), "--depth", str(tmp_path / "d.png"), "--out", str(tmp_path / "r.json")]) == 2
    assert "--intrinsics" in capsys.readouterr().err
    assert main(["predict", "--model", str(tmp_path / "nope"), "--input", "x.npy", "--out", str(tmp_path / "r.json")]) == 2
    assert "no model" in capsys.readouterr().err
    (tmp_path / "broken.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 100\n")
    assert (
        main(["predict", "--model", str(tiny_run), "--input", str(tmp_path / "broken.ply"), "--out", str(tmp_path / "r.json")])
        == 2
    )
    err = capsys.readouterr().err
    assert "broken.ply" in err and "Traceback" not in err


def test_shipped_name_is_not_hidden_by_a_folder_of_that_name(tmp_path, monkeypatch):
    from ucope.model.checkpoint import list_pretrained

    assert "laptop" in list_pretrained()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "laptop").mkdir()  # e.g. a data folder
    est = Estimator.load("laptop")
    assert est.name == "laptop" and est.category == "laptop"


def test_refinement_default_comes_from_the_model(tiny_run, tmp_path, sample):
    """``refine=None`` (the default of load and of the command line) takes ``info.defaults.refine`` of the
    model's JSON; an explicit value wins."""
    assert Estimator.load(tiny_run).refine is False  # no defaults recorded: off
    import shutil

    run = tmp_path / "run"
    shutil.copytree(tiny_run, run)
    meta = json.loads((run / "model.json").read_text())
    meta.setdefault("info", {})["defaults"] = {"refine": True}
    (run / "model.json").write_text(json.dumps(meta))
    assert Estimator.load(run).refine is True
    assert Estimator.load(run, refine=False).refine is False
    out = tmp_path / "r.json"
    np.save(tmp_path / "cloud.npy", sample["points"])
    assert (
        main(
            ["predict", "--model", str(run), "--input", str(tmp_path / "cloud.npy"), "--out", str(out), "--no-refine", "--quiet"]
        )
        == 0
    )
    assert main(["predict", "--model", str(run), "--input", str(tmp_path / "cloud.npy"), "--out", str(out), "--quiet"]) == 0


@pytest.mark.parametrize("name, on", [("eyeglasses", True), ("drawer", True), ("laptop", False), ("mug", False)])
def test_shipped_models_carry_their_measured_refinement_default(name, on):
    from ucope.model.checkpoint import list_pretrained

    if name not in list_pretrained():
        pytest.skip("model not shipped")
    assert Estimator.load(name).refine is on


def test_prediction_needs_only_the_model_not_the_generators(tmp_path):
    """A shipped model predicts in a process where importing ``ucope.objects`` (the generators and the
    mesh kit) fails: everything prediction needs about the category lives in the model files."""
    import subprocess
    import sys

    cfg = GenerateConfig(category="laptop", split="test", num=1, seed=5)
    np.save(tmp_path / "cloud.npy", make_sample(cfg, 0)["points"])
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'ucope.objects' or name.startswith('ucope.objects.'):\n"
        "            raise ImportError('generators are unavailable in this test')\n"
        "sys.meta_path.insert(0, Block())\n"
        "import numpy as np, ucope\n"
        f"r = ucope.Estimator.load('laptop').predict(np.load({str(tmp_path / 'cloud.npy')!r}))\n"
        "assert len(r.parts) == 2 and len(r.joints) == 1\n"
        f"m = ucope.Estimator.load('mug').predict(np.load({str(tmp_path / 'cloud.npy')!r}))\n"  # rigid: the shape-flip check
        "assert len(m.parts) == 1\n"
        "assert not any(m.startswith('ucope.objects') for m in sys.modules)\n"
        "print('ok', r.joints[0].state)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.startswith("ok"), out.stderr


def test_a_carried_part_gets_a_halved_score_and_a_warning(monkeypatch):
    """When :func:`ucope.voting.kinematic.carry_upright` re-places a part, the result says so and halves
    that part's score; ``upright=False`` skips it. (The carry itself: tests/voting/test_kinematic.py.)
    One estimate each: with the scale search, the lower score could make a second estimate win."""
    import ucope.voting.object as vo

    s = make_sample(GenerateConfig(category="laptop", split="test", num=1, views_per_instance=1), 0)
    plain = Estimator.load("laptop", num_pairs=2000, upright=False, scale_search=False).predict_sample(s)
    assert not any("placed from its neighbour" in w for w in plain.warnings)
    monkeypatch.setattr(vo, "carry_upright", lambda T, S, priors, margin: (np.array(T), np.array([True, False])))
    marked = Estimator.load("laptop", num_pairs=2000, scale_search=False).predict_sample(s)
    assert sum("part 'base'" in w and "placed from its neighbour" in w for w in marked.warnings) == 1
    assert marked.parts[0].score == pytest.approx(0.5 * plain.parts[0].score)
    assert marked.parts[1].score == pytest.approx(plain.parts[1].score)
    np.testing.assert_allclose(marked.parts[0].cam_from_part, plain.parts[0].cam_from_part)


def test_shipped_articulated_models_know_their_upright_parts():
    """The shipped models carry the upright and pivot priors that :func:`carry_upright` reads."""
    from ucope.model.checkpoint import list_pretrained

    for name in ("laptop", "scissors", "dishwasher", "drawer", "eyeglasses"):
        if name not in list_pretrained():
            continue
        pri = Estimator.load(name).priors
        assert pri.parts[0].upright_axis is not None, name
        assert all((jp.pivot_in_parent is not None) == (jp.type.label == "revolute") for jp in pri.joints), name


def test_a_noisy_cloud_is_smoothed_above_the_threshold_only(est, sample, tiny_run, tmp_path):
    """``denoise_above_m``: a cloud whose surface noise is above it is smoothed (with a warning), one below it
    is not; the model's JSON default is taken by ``load``; bad values are named."""
    rng = np.random.default_rng(0)
    clean = sample["points"]
    noisy = clean + rng.normal(scale=0.01, size=clean.shape)
    on = Estimator(est.model, num_pairs=2000, denoise_above_m=0.004)
    assert any("smoothed" in w for w in on.predict(noisy).warnings)
    assert not any("smoothed" in w for w in on.predict(clean).warnings)
    assert not any("smoothed" in w for w in Estimator(est.model, num_pairs=2000).predict(noisy).warnings)
    assert not any("smoothed" in w for w in on.predict(noisy[:500]).warnings)  # too few points to judge
    import shutil

    run = tmp_path / "run"
    shutil.copytree(tiny_run, run)
    meta = json.loads((run / "model.json").read_text())
    meta.setdefault("info", {})["defaults"] = {"denoise_above_m": 0.002}
    (run / "model.json").write_text(json.dumps(meta))
    assert Estimator.load(run).denoise_above_m == 0.002
    assert Estimator.load(run, denoise_above_m=None).denoise_above_m is None
    assert Estimator.load(tiny_run).denoise_above_m is None
    for bad in (-0.001, 2.0, True, "1mm"):
        with pytest.raises(InputError, match="denoise_above_m"):
            Estimator(est.model, denoise_above_m=bad)
    with pytest.raises(InputError, match="denoise_above_m"):
        Estimator.load(tiny_run, denoise_above_m="auto")


def test_cli_smoothing_and_revolution_flags_reach_the_estimator(tiny_run):
    import argparse

    from ucope.cli.outputs import estimator_options

    base = dict(
        pairs=100, no_awareness=False, refine=None, seed=0, keep_flips=False, no_upright=False, no_rescale=False,
        remove_plane=None, device="cpu", no_score_filter=False, pairs_from_cloud=False, no_vote_caps=False,
    )  # fmt: skip
    o = estimator_options(argparse.Namespace(**base))
    assert o["denoise_above_m"] == "model" and o["options"] is None
    o = estimator_options(argparse.Namespace(**base, denoise_above=2.5, no_revolution_fit=True))
    assert o["denoise_above_m"] == pytest.approx(0.0025) and o["options"].revolution_factor is None
    o = estimator_options(argparse.Namespace(**base, denoise_above=2.5, no_denoise=True))
    assert o["denoise_above_m"] is None
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_denoise=True))).denoise_above_m is None
    assert o["scale_search"] and o["recrop"]
    o = estimator_options(argparse.Namespace(**base, no_scale_search=True, no_recrop=True))
    assert not o["scale_search"] and not o["recrop"] and not Estimator.load(tiny_run, **o).scale_search


def test_grown_boxes_hold_their_points_and_keep_the_rotations(est, sample, tiny_run, tmp_path):
    """``grow_boxes``: the same estimate with every box at least as large (rotations and scores kept); the
    model's JSON default is taken by ``load``; the CLI flag reaches it."""
    off = Estimator(est.model, num_pairs=2000).predict_sample(sample)
    on = Estimator(est.model, num_pairs=2000, grow_boxes=True).predict_sample(sample)
    for a, b in zip(off.parts, on.parts, strict=True):
        np.testing.assert_allclose(b.cam_from_part[:3, :3], a.cam_from_part[:3, :3])
        assert np.all(b.size_m >= a.size_m - 1e-12) and b.score == a.score
    np.testing.assert_array_equal(on.part_labels, off.part_labels)
    _default_and_flag(tiny_run, tmp_path, "grow_boxes")


def test_aligned_faces_keep_translations_and_reach_the_settings(est, sample, tiny_run, tmp_path):
    """``align_faces``: the sizes and labels are kept (without growth), rotations stay rotations; the
    model's JSON default is taken by ``load``; the CLI flag reaches it."""
    off = Estimator(est.model, num_pairs=2000, grow_boxes=False).predict_sample(sample)
    on = Estimator(est.model, num_pairs=2000, grow_boxes=False, align_faces=True).predict_sample(sample)
    np.testing.assert_array_equal(on.part_labels, off.part_labels)
    for a, b in zip(off.parts, on.parts, strict=True):
        np.testing.assert_allclose(b.size_m, a.size_m)
        R = b.cam_from_part[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-6)
    # after the refinement the tree turns with its re-aligned root: the hinge stays the base's x axis
    refined = Estimator(est.model, num_pairs=2000, refine=True, align_faces=True).predict_sample(sample)
    hinge = refined.parts[0].cam_from_part[:3, :3] @ est.priors.joint_axes[0]
    assert abs(float(refined.joints[0].axis @ hinge)) == pytest.approx(1.0, abs=1e-6)
    _default_and_flag(tiny_run, tmp_path, "align_faces")


def test_the_wide_scale_search_default_and_flag_reach_the_estimator(tiny_run, tmp_path):
    """``wide_scale_search``: the model's JSON default is taken by ``load``; the CLI flag reaches it (its
    effect is measured in tests/estimation/test_scale_search.py)."""
    _default_and_flag(tiny_run, tmp_path, "wide_scale_search")


def test_the_fit_extents_default_and_flag_reach_the_estimator(tiny_run, tmp_path):
    """``fit_extents``: the model's JSON default is taken by ``load``; the CLI flag reaches it; a model
    trained now measures its seen extents (``PartPrior.seen_extent``)."""
    _default_and_flag(tiny_run, tmp_path, "fit_extents")
    assert Estimator.load(tiny_run).seen_extent is not None


def test_the_anchor_faces_default_and_flag_reach_the_estimator(tiny_run, tmp_path):
    """``anchor_faces``: the model's JSON default is taken by ``load``; the CLI flag reaches it; a model trained
    now measures its faced gaps (``PartPrior.faced_gap``)."""
    _default_and_flag(tiny_run, tmp_path, "anchor_faces")
    assert Estimator.load(tiny_run).faced_gap is not None


def test_restarts_are_checked_taken_from_the_model_and_reach_the_estimator(tiny_run, tmp_path):
    """``restarts``: an integer from 0 to MAX_RESTARTS (named otherwise); ``load`` takes the model JSON's
    ``info.defaults.restarts`` (0 without it) unless given; ``--restarts N`` reaches it; a model without a
    calibration (raw vote scores do not predict success) never restarts."""
    import argparse
    import shutil

    from ucope.cli.outputs import estimator_options
    from ucope.estimation.estimator import MAX_RESTARTS

    for bad in (-1, MAX_RESTARTS + 1, 1.5, True, "2"):
        with pytest.raises(InputError, match="restarts must be an integer"):
            Estimator.load(tiny_run, restarts=bad)
    run = tmp_path / "run"
    shutil.copytree(tiny_run, run)
    meta = json.loads((run / "model.json").read_text())
    meta.setdefault("info", {})["defaults"] = {"restarts": 3}
    (run / "model.json").write_text(json.dumps(meta))
    assert Estimator.load(run).restarts == 3 and Estimator.load(run, restarts=0).restarts == 0
    assert Estimator.load(tiny_run).restarts == 0
    base = dict(
        pairs=100, no_awareness=False, refine=None, seed=0, keep_flips=False, no_upright=False, no_rescale=False,
        remove_plane=None, device="cpu", no_score_filter=False, pairs_from_cloud=False, no_vote_caps=False,
    )  # fmt: skip
    assert estimator_options(argparse.Namespace(**base))["restarts"] is None
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, restarts=2))).restarts == 2
    est = Estimator.load(run)
    assert est.calibration is None
    s = make_sample(GenerateConfig(category="laptop", split="test", num=1), 0)
    np.testing.assert_array_equal(est.predict_sample(s).cam_from_part, Estimator.load(tiny_run).predict_sample(s).cam_from_part)


def test_the_shipped_dishwasher_measures_a_cabinet_shorter_than_any_it_was_trained_on():
    """OOD view 7 (``ucope generate --category dishwasher --split ood --num 100``, seed 0): a countertop
    dishwasher of a held-out family, wider than tall, seen from behind and a side (yaw -143 degrees). Voted, its
    body's box is 1.16x as tall as the body and the door, placed from it, sits 19 % of its diagonal off (without
    ``seat_parts``, which puts it back on its hinge: 8.5 %); with ``fit_extents`` (the shipped default) the height
    comes from the body's points (the camera faces the top and a side: the height is seen whole) and every part is
    within 10 %. Both at the one-size scale search: the
    shipped dishwasher searches three sizes, and at the one its score picks the body is voted 1.27x as tall, the
    view still a success (every part within 7.1 %). (The model before the compact built-ins of the dishwasher
    generator's revision 2 voted view 80's body nearly twice as tall as it is; the shipped one votes it 1.5x and
    places both parts within 4 % of their diagonals.)"""
    from ucope.eval.evaluate import sample_errors

    s = make_sample(GenerateConfig(category="dishwasher", split="ood", num=100, seed=0), 7)
    one_size = dict(wide_scale_search=False, free_space=False)
    est = Estimator.load("dishwasher", **one_size)
    assert est.fit_extents and est.seen_extent is not None
    diag = np.linalg.norm(s["size_m"], axis=1)
    ratio, trans = {}, {}
    for name, e in (
        ("fit", est),
        ("voted", Estimator.load("dishwasher", fit_extents=False, seat_parts=False, **one_size)),
        ("shipped", Estimator.load("dishwasher")),
    ):
        res = e.predict(s["points"], s["normals"])
        ratio[name] = res.parts[0].size_m[1] / s["size_m"][0][1]
        trans[name] = [p["translation_m"] / d for p, d in zip(sample_errors(res, s)["parts"], diag, strict=True)]
    assert ratio["voted"] > 1.1 and max(trans["voted"]) > 0.15
    assert abs(ratio["fit"] - 1.0) < 0.05 and max(trans["fit"]) < 0.1
    assert max(trans["shipped"]) < 0.1


def test_the_shipped_eyeglasses_take_a_frame_seen_from_behind_to_its_depth():
    """Test view 70 (``ucope generate --category eyeglasses --split test --num 200``, seed 0), seen from behind
    (yaw -175 degrees): the voted frame sits 6.5 % of its diagonal off, most of it along its depth; with
    ``anchor_faces`` (the shipped default) its back face goes where its points are and the error falls below
    2 %. The temples (children) are not moved."""
    from ucope.eval.evaluate import sample_errors

    s = make_sample(GenerateConfig(category="eyeglasses", split="test", num=200, seed=0), 70)
    est = Estimator.load("eyeglasses")
    assert est.anchor_faces and est.faced_gap is not None
    diag = float(np.linalg.norm(s["size_m"][0]))
    res = {
        name: e.predict(s["points"], s["normals"])
        for name, e in (("on", est), ("off", Estimator.load("eyeglasses", anchor_faces=False)))
    }
    err = {name: sample_errors(r, s)["parts"][0]["translation_m"] / diag for name, r in res.items()}
    assert err["off"] > 0.05 and err["on"] < 0.02
    for a, b in zip(res["on"].parts[1:], res["off"].parts[1:], strict=True):
        np.testing.assert_array_equal(a.cam_from_part, b.cam_from_part)


def test_placing_children_acts_only_where_the_priors_hold_the_spread(tiny_run):
    """``place_children`` (on by default): a model whose priors hold no placement spread (the tiny laptop
    run: revolute joints) gives the same estimate with it on and off."""
    est = Estimator.load(tiny_run, num_pairs=500)
    assert est.place_children and all(jp.child_in_parent_spread is None for jp in est.priors.joints)
    s = make_sample(GenerateConfig(category=est.category, split="test", num=1, seed=5, views_per_instance=1), 0)
    on = est.predict(s["points"])
    off = Estimator.load(tiny_run, num_pairs=500, place_children=False).predict(s["points"])
    for a, b in zip(on.parts, off.parts, strict=True):
        np.testing.assert_array_equal(a.cam_from_part, b.cam_from_part)


def test_the_drawer_step_flags_reach_the_estimator(tiny_run):
    import argparse

    from ucope.cli.outputs import estimator_options

    base = dict(
        pairs=100, no_awareness=False, refine=None, seed=0, keep_flips=False, no_upright=False, no_rescale=False,
        remove_plane=None, device="cpu", no_score_filter=False, pairs_from_cloud=False, no_vote_caps=False,
    )  # fmt: skip
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).place_children
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_place_children=True))).place_children
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).slide_fronts
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_slide_fronts=True))).slide_fronts
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).carry_depths
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).hold_children
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_hold_children=True))).hold_children
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_carry_depths=True))).carry_depths
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).stack_children
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_stack_children=True))).stack_children
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).turn_children
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_turn_children=True))).turn_children
    assert Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base))).flip_fronts
    assert not Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, no_flip_fronts=True))).flip_fronts


def test_the_shipped_drawer_puts_its_drawers_in_the_middle_of_the_cabinet():
    """The shipped drawer's priors hold the spread (0 left-right): with ``place_children`` every drawer's
    centre is on the cabinet's middle plane, x = 0 in the cabinet's frame; without it, the voted ones are
    not; the rest of the estimate is the same."""
    s = make_sample(GenerateConfig(category="drawer", split="test", num=1, seed=5, views_per_instance=1), 0)
    on = Estimator.load("drawer", num_pairs=2000).predict(s["points"])
    off = Estimator.load("drawer", num_pairs=2000, place_children=False).predict(s["points"])
    lateral = {}
    for name, res in (("on", on), ("off", off)):
        cab = res.parts[0].cam_from_part
        lateral[name] = [float(cab[:3, 0] @ (p.cam_from_part[:3, 3] - cab[:3, 3])) for p in res.parts[1:]]
    assert np.allclose(lateral["on"], 0.0, atol=1e-9) and not np.allclose(lateral["off"], 0.0, atol=1e-4)
    for a, b in zip(on.parts, off.parts, strict=True):
        np.testing.assert_array_equal(a.cam_from_part[:3, :3], b.cam_from_part[:3, :3])
        np.testing.assert_array_equal(a.size_m, b.size_m)
    np.testing.assert_allclose([j.state for j in on.joints], [j.state for j in off.joints], atol=1e-9)


def _default_and_flag(tiny_run, tmp_path, key: str) -> None:
    """The model JSON's ``info.defaults[key]`` is taken by ``load`` (and overridden by the keyword); a
    model without it has it off; the command-line flag (``None`` when not given) reaches ``load``."""
    import argparse
    import shutil

    from ucope.cli.outputs import estimator_options

    run = tmp_path / "run"
    shutil.copytree(tiny_run, run)
    meta = json.loads((run / "model.json").read_text())
    meta.setdefault("info", {})["defaults"] = {key: True}
    (run / "model.json").write_text(json.dumps(meta))
    assert getattr(Estimator.load(run), key) and not getattr(Estimator.load(run, **{key: False}), key)
    assert not getattr(Estimator.load(tiny_run), key)
    base = dict(
        pairs=100, no_awareness=False, refine=None, seed=0, keep_flips=False, no_upright=False, no_rescale=False,
        remove_plane=None, device="cpu", no_score_filter=False, pairs_from_cloud=False, no_vote_caps=False,
    )  # fmt: skip
    assert estimator_options(argparse.Namespace(**base))[key] is None
    assert not getattr(Estimator.load(run, **estimator_options(argparse.Namespace(**base, **{key: False}))), key)
    assert getattr(Estimator.load(tiny_run, **estimator_options(argparse.Namespace(**base, **{key: True}))), key)


def test_the_shipped_drawer_reports_states_of_its_boxes_inside_the_limits():
    """Test view 4 of the drawer's test split (generator revision 2): voting put two drawers outside their limits. The
    reported states lie inside the joint limits, say so in a warning each, and are the support gaps of the
    reported boxes (:func:`ucope.voting.settle_joint_states`; the cloud is not rescaled here)."""
    from ucope.geometry.kinematics import joint_state_from_poses

    s = make_sample(GenerateConfig(category="drawer", split="test", num=200, seed=0), 4)
    est = Estimator.load("drawer")
    res = est.predict(s["points"])
    assert not any("scaled by" in w for w in res.warnings)
    assert sum("lay outside the category's limits" in w for w in res.warnings) >= 1
    cab = res.parts[0]
    for je, jp in zip(res.joints, est.priors.joints, strict=True):
        lo, hi = jp.limits
        assert lo - 1e-9 <= je.state <= hi + 1e-9
        child = res.parts[jp.child]
        gap = joint_state_from_poses(
            cab.cam_from_part, child.cam_from_part, je.axis, "prismatic", cab.size_m, child.size_m, jp.zero_offset_m
        )
        assert gap == pytest.approx(je.state, abs=1e-9)


def test_the_shipped_laptop_rigid_turns_a_laptop_voted_upside_down_over():
    """Test view 154 of laptop_rigid's test split: its votes put the laptop upside down (a half turn from the
    truth, the box centre 0.42 of its diagonal off). With ``upright`` (the default) it is turned over and
    placed from its points, within 10 degrees and 10 % of its diagonal, and a warning says so; without, it
    stays upside down (:func:`ucope.voting.turn_upright`)."""
    from ucope.geometry.transforms import rotation_angle_deg

    s = make_sample(GenerateConfig(category="laptop_rigid", split="test", num=200, seed=0), 154)
    T, diag = np.asarray(s["cam_from_part"])[0], float(np.linalg.norm(s["size_m"][0]))
    errors = {}
    for up in (True, False):
        res = Estimator.load("laptop_rigid", upright=up).predict_sample(s)
        P = res.parts[0].cam_from_part
        errors[up] = (rotation_angle_deg(T[:3, :3], P[:3, :3]), float(np.linalg.norm(T[:3, 3] - P[:3, 3])) / diag)
        assert any("upside down" in w for w in res.warnings) == up
    assert errors[True][0] < 10.0 and errors[True][1] < 0.1
    assert errors[False][0] > 150.0 and errors[False][1] > 0.3


def _off_and_on(model: str, key: str, index: int, normals: bool = False):
    """Test view ``index`` of ``model``'s test split (``num=200``, seed 0) estimated with the switch ``key`` off
    and on: ``(sample, off, on, off's part errors, on's part errors)``."""
    from ucope.eval.evaluate import sample_errors

    s = make_sample(GenerateConfig(category=model, split="test", num=200, seed=0), index)
    args = (s["points"], s["normals"]) if normals else (s["points"],)
    off = Estimator.load(model, **{key: False}).predict(*args)
    on = Estimator.load(model, **{key: True}).predict(*args)
    return s, off, on, sample_errors(off, s)["parts"], sample_errors(on, s)["parts"]


def test_free_space_turns_a_laptop_base_hidden_behind_its_lid_and_reaches_the_settings(tiny_run, tmp_path):
    """Test view 19 of the laptop's test split, seen from behind: the base shows few points and voting tilted
    it 23 degrees off. With ``free_space`` it is turned about the hinge to under 10 degrees (measured 7.4),
    the lid is kept, a warning says so and the reported state is the boxes' own; the model's JSON default is
    taken by ``load``; the CLI flag reaches it."""
    from ucope.geometry.kinematics import joint_state_from_poses

    _, off, on, e_off, e_on = _off_and_on("laptop", "free_space", 19)
    assert e_off[0]["rotation_deg"] > 20 and e_on[0]["rotation_deg"] < 10 and e_on[0]["translation_norm"] < 0.1
    np.testing.assert_allclose(on.parts[1].cam_from_part, off.parts[1].cam_from_part)
    assert sum("it showed few points; it was turned by" in w for w in on.warnings) == 1
    assert not any("it showed few points" in w for w in off.warnings)
    j = on.joints[0]
    q = joint_state_from_poses(on.parts[0].cam_from_part, on.parts[1].cam_from_part, j.axis, "revolute")
    assert j.state == pytest.approx(q, abs=1e-9)
    _default_and_flag(tiny_run, tmp_path, "free_space")


def test_seating_puts_a_door_seen_from_behind_back_on_its_hinge_and_reaches_the_settings(tiny_run, tmp_path):
    """Test view 161 of the dishwasher's test split, seen from behind with its door closed: the door shows 128
    points and voting put it 0.4 m in front of the body (its rotation right). With ``seat_parts`` it hangs from
    the body's hinge again (measured 0.56 -> 0.07 of its box diagonal), a warning says so, the body and the door's
    rotation are kept; the model's JSON default is taken by ``load``; the CLI flag reaches it."""
    _, off, on, e_off, e_on = _off_and_on("dishwasher", "seat_parts", 161)
    assert e_off[1]["translation_norm"] > 0.3 and e_on[1]["translation_norm"] < 0.1 and e_on[1]["rotation_deg"] < 5
    np.testing.assert_allclose(on.parts[0].cam_from_part, off.parts[0].cam_from_part)
    np.testing.assert_allclose(on.parts[1].cam_from_part[:3, :3], off.parts[1].cam_from_part[:3, :3])
    assert sum("stood off its hinge" in w for w in on.warnings) == 1
    assert not any("stood off its hinge" in w for w in off.warnings)
    _default_and_flag(tiny_run, tmp_path, "seat_parts")


def test_picking_by_the_seen_parts_keeps_the_estimate_whose_body_is_sure_and_reaches_the_settings(tiny_run, tmp_path):
    """Test view 181 of the dishwasher's test split, seen from behind with its door hidden: the first estimate had
    the body right (score 0.95) and gave the door no point (score 0.00); the scale search's estimate at 1.25x
    gave 533 body points to the door (0.17) and turned the body 48 degrees (0.39), and won on the smallest score.
    Compared over the parts given points, the first stands; the model's JSON default is taken by ``load``; the
    CLI flag reaches it."""
    _, off, on, e_off, e_on = _off_and_on("dishwasher", "pick_seen_parts", 181)
    assert e_off[0]["rotation_deg"] > 30 and e_on[0]["rotation_deg"] < 5 and e_on[0]["translation_norm"] < 0.1
    _default_and_flag(tiny_run, tmp_path, "pick_seen_parts")


def test_the_seen_score_leaves_out_parts_given_no_point():
    from types import SimpleNamespace

    from ucope.estimation.estimator import _object_score, _seen_score

    parts = [SimpleNamespace(score=0.95), SimpleNamespace(score=0.0), SimpleNamespace(score=0.4)]
    p = SimpleNamespace(parts=parts, labels=np.array([0, 0, 2, -1, 2]))
    assert _object_score(p) == 0.0 and _seen_score(p) == 0.4
    p.labels = np.array([0, 1, 2])
    assert _seen_score(p) == 0.0
    p.labels = np.array([-1, -1])  # no part given a point: every part counts
    assert _seen_score(p) == 0.0


def test_carrying_in_the_cone_brings_a_base_seen_from_behind_back_and_reaches_the_settings(tiny_run, tmp_path):
    """Test view 118 of the laptop's test split, seen from behind: the lid is right, the base, showing a strip
    along its hinge, is voted 39 degrees off its training upright (no test view holds it more than 29 degrees off)
    and 43 degrees off the truth. Carried as soon as it leaves the 30-degree cone, it is within 10 degrees (measured
    6.0); the model's JSON default is taken by ``load``; the CLI flag reaches it."""
    _, off, on, e_off, e_on = _off_and_on("laptop", "carry_in_cone", 118, normals=True)
    assert e_off[0]["rotation_deg"] > 30 and e_on[0]["rotation_deg"] < 10 and e_on[0]["translation_norm"] < 0.1
    assert any("placed from its neighbour" in w for w in on.warnings)
    _default_and_flag(tiny_run, tmp_path, "carry_in_cone")


def test_free_slides_bring_back_a_hidden_drawer_voted_beside_its_cabinet_and_reach_the_settings(tiny_run, tmp_path):
    """Test view 48 of the drawer's test split, seen from the side: the middle drawer shows no point and voting
    pulled it 0.35 m further out than it is, where the camera would have seen it beside the cabinet. With
    ``free_slides`` it is slid back in (measured 0.22 -> 0.05 of its box diagonal), a warning says so, the cabinet
    and the drawer's rotation are kept; the model's JSON default is taken by ``load``; the CLI flag reaches it."""
    _, off, on, e_off, e_on = _off_and_on("drawer", "free_slides", 48, normals=True)
    assert e_off[2]["translation_norm"] > 0.2 and e_on[2]["translation_norm"] < 0.1
    np.testing.assert_allclose(on.parts[0].cam_from_part, off.parts[0].cam_from_part)
    np.testing.assert_allclose(on.parts[2].cam_from_part[:3, :3], off.parts[2].cam_from_part[:3, :3])
    assert sum("to the nearest state the view leaves room for" in w for w in on.warnings) >= 1
    assert not any("the view leaves room for" in w for w in off.warnings)
    assert on.joints[1].state < off.joints[1].state - 0.2
    _default_and_flag(tiny_run, tmp_path, "free_slides")
