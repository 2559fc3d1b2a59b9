"""Shape families, the splits (held-out families, the ood split) and scaled instances (ucope.objects.categories)."""

from __future__ import annotations

import numpy as np
import pytest

from ucope.errors import InputError
from ucope.objects.categories import (
    CATEGORY_NAMES,
    IN_DISTRIBUTION_SPLITS,
    OOD_SCALE_RANGE,
    SPLITS,
    get_category,
    instance_family_and_scale,
    instance_rng,
    make_instance,
)

N_DRAWS = 1000  # family draws per split and category (cheap: nothing is built)


def _key(obj) -> tuple:
    return tuple(sorted(obj.params.items()))


@pytest.mark.parametrize("name", CATEGORY_NAMES)
def test_every_category_has_families_and_one_or_two_held_out(name):
    spec = get_category(name)
    assert len(spec.shape_families) >= 4
    assert 1 <= len(spec.held_out_families) <= 2
    train = spec.families_for_split("train")
    assert len(train) >= 3 and not set(train) & set(spec.held_out_families)
    assert set(train) | set(spec.held_out_families) == set(spec.family_names)
    assert spec.families_for_split("ood") == spec.held_out_families
    assert all(f.description for f in spec.shape_families)


def test_splits():
    assert SPLITS == ("train", "val", "test", "ood")
    assert IN_DISTRIBUTION_SPLITS == ("train", "val", "test")
    assert OOD_SCALE_RANGE == (0.5, 2.0)


@pytest.mark.parametrize("name", CATEGORY_NAMES)
def test_held_out_families_never_appear_in_train_val_test(name):
    spec = get_category(name)
    held = set(spec.held_out_families)
    for split in IN_DISTRIBUTION_SPLITS:
        draws = [instance_family_and_scale(name, split, i) for i in range(N_DRAWS)]
        fams = {f for f, _ in draws}
        assert not fams & held, (split, fams & held)
        assert fams == set(spec.families_for_split(split))  # every training family is drawn
        assert all(s == 1.0 for _, s in draws)
    ood = [instance_family_and_scale(name, "ood", i) for i in range(N_DRAWS)]
    assert {f for f, _ in ood} == held
    scales = np.array([s for _, s in ood])
    assert scales.min() >= 0.5 and scales.max() <= 2.0
    # log-uniform: as many below 1 as above, and a quarter below 1/sqrt(2)
    assert 0.4 < (scales < 1.0).mean() < 0.6
    assert 0.17 < (scales < 2**-0.5).mean() < 0.33


@pytest.mark.parametrize("name", CATEGORY_NAMES)
def test_built_instances_record_the_drawn_family_and_scale(name):
    for split in SPLITS:
        for i in range(3):
            obj = make_instance(name, split, i)
            assert (obj.shape_family, obj.scale) == instance_family_and_scale(name, split, i)
            assert obj.instance_id == f"{name}/{split}/0/{i:06d}"


def test_ood_stream_is_disjoint_from_the_others():
    for name in ("laptop", "mug", "drawer"):
        first = {split: instance_rng(name, split, 0).random(4).tolist() for split in SPLITS}
        assert len({tuple(v) for v in first.values()}) == len(SPLITS)
        ood = {_key(make_instance(name, "ood", i)) for i in range(10)}
        others = {_key(make_instance(name, s, i)) for s in IN_DISTRIBUTION_SPLITS for i in range(10)}
        assert len(ood) == 10 and not ood & others


@pytest.mark.parametrize("name", CATEGORY_NAMES)
def test_scaled_instance_is_the_same_shape_scaled(name):
    for split, i in (("test", 1), ("ood", 2)):
        base = make_instance(name, split, i, scale=1.0)
        assert base.scale == 1.0
        for s in (0.5, 1.5):
            obj = make_instance(name, split, i, scale=s)
            assert obj.scale == s and obj.shape_family == base.shape_family and obj.params == base.params
            np.testing.assert_allclose(obj.size_m, s * base.size_m, rtol=1e-12)
            for pa, pb in zip(obj.parts, base.parts, strict=False):
                np.testing.assert_allclose(pa.mesh.vertices, s * np.asarray(pb.mesh.vertices), rtol=1e-12, atol=1e-15)
                np.testing.assert_array_equal(pa.mesh.faces, pb.mesh.faces)
            # joints: the same axes and revolute limits; pivots, prismatic limits and rest states scale
            for ja, jb in zip(obj.joints, base.joints, strict=False):
                np.testing.assert_array_equal(ja.axis, jb.axis)
                np.testing.assert_allclose(ja.pivot, s * jb.pivot, rtol=1e-12, atol=1e-15)
                k = s if ja.type == "prismatic" else 1.0
                np.testing.assert_allclose(ja.limits, np.multiply(jb.limits, k), rtol=1e-12)
                assert ja.rest == pytest.approx(k * jb.rest)
            # canonical frames: the same rotations at corresponding states, translations scaled
            q = base.limits.mean(axis=1) if base.joints else None
            qs = None if q is None else np.where([j.type == "prismatic" for j in base.joints], s * q, q)
            A, B = obj.object_from_part(qs), base.object_from_part(q)
            np.testing.assert_allclose(A[:, :3, :3], B[:, :3, :3], atol=1e-12)
            np.testing.assert_allclose(A[:, :3, 3], s * B[:, :3, 3], atol=1e-12)
            assert obj.structure()["parts"] == base.structure()["parts"]


def test_ood_default_scale_and_explicit_scale():
    fam, s = instance_family_and_scale("bowl", "ood", 5)
    obj = make_instance("bowl", "ood", 5)
    assert obj.scale == s and obj.shape_family == fam
    unit = make_instance("bowl", "ood", 5, scale=1.0)
    np.testing.assert_allclose(obj.size_m, s * unit.size_m, rtol=1e-12)
    # scaling an instance again multiplies its scale
    assert obj.scaled(2.0).scale == pytest.approx(2 * s)


def test_explicit_family_keeps_the_rest_of_the_stream():
    spec = get_category("mug")
    for fam in spec.family_names:
        obj = make_instance("mug", "train", 4, family=fam)
        assert obj.shape_family == fam
    drawn, _ = instance_family_and_scale("mug", "train", 4)
    a, b = make_instance("mug", "train", 4), make_instance("mug", "train", 4, family=drawn)
    np.testing.assert_array_equal(a.parts[0].mesh.vertices, b.parts[0].mesh.vertices)


def test_deterministic():
    for split in SPLITS:
        a, b = make_instance("eyeglasses", split, 6), make_instance("eyeglasses", split, 6)
        assert a.params == b.params and a.scale == b.scale and a.shape_family == b.shape_family
        for pa, pb in zip(a.parts, b.parts, strict=False):
            np.testing.assert_array_equal(pa.mesh.vertices, pb.mesh.vertices)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(split="toast"),
        dict(scale=0.0),
        dict(scale=-1.0),
        dict(scale=float("nan")),
        dict(scale=True),
        dict(scale="2"),
        dict(family="teapot"),
        dict(index=-1),
    ],
)
def test_bad_arguments(kwargs):
    args = dict(category="mug", split="test", index=0) | kwargs
    with pytest.raises(InputError):
        make_instance(**args)


@pytest.mark.parametrize("name", ["dishwasher", "drawer", "bottle", "camera"])
def test_stretched_instance_is_the_same_shape_with_factors_from_their_own_stream(name):
    base = make_instance(name, "train", 3)
    st = make_instance(name, "train", 3, stretch_range=(0.5, 2.0))
    f = np.asarray(st.stretch)
    assert st.params == base.params and st.shape_family == base.shape_family
    assert np.all((f >= 0.5) & (f <= 2.0)) and not np.allclose(f, 1.0)
    np.testing.assert_allclose(st.size_m, base.size_m * f, rtol=1e-12)  # every part aligned at state 0
    # the same factors every time, other factors for another instance, index or seed
    np.testing.assert_array_equal(make_instance(name, "train", 3, stretch_range=(0.5, 2.0)).stretch, st.stretch)
    assert make_instance(name, "train", 4, stretch_range=(0.5, 2.0)).stretch != st.stretch
    assert make_instance(name, "train", 3, seed=1, stretch_range=(0.5, 2.0)).stretch != st.stretch
    if get_category(name).symmetry[0] == "y":
        assert f[0] == pytest.approx(f[2])
    for bad in ((1.2, 2.0), (0.5, 0.9), (0.0, 2.0), (2.0, 0.5), (0.5,), "ab"):
        with pytest.raises(InputError, match="stretch range"):
            make_instance(name, "train", 3, stretch_range=bad)
    # a share of the instances: the stretched ones get the factors every instance gets at share 1
    some = [make_instance(name, "train", i, stretch_range=(0.5, 2.0), stretch_share=0.5).stretch for i in range(12)]
    every = [make_instance(name, "train", i, stretch_range=(0.5, 2.0)).stretch for i in range(12)]
    kept = [a == (1.0, 1.0, 1.0) for a in some]
    assert 0 < sum(kept) < 12
    assert all(a == b for a, b, k in zip(some, every, kept, strict=True) if not k)
    none = make_instance(name, "train", 3, stretch_range=(0.5, 2.0), stretch_share=0.0)
    np.testing.assert_array_equal(none.size_m, base.size_m)
    with pytest.raises(InputError, match="stretch share"):
        make_instance(name, "train", 3, stretch_range=(0.5, 2.0), stretch_share=1.5)
