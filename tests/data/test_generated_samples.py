"""Ground truth of generated samples is consistent with the points, for every category."""

import numpy as np
import pytest

from ucope.data.generate import GenerateConfig, make_sample
from ucope.geometry.transforms import apply_transform, axis_angle_transform, invert_transform, translation_transform
from ucope.objects.categories import CATEGORY_NAMES, get_category, make_instance
from ucope.render.noise import DepthNoise
from ucope.render.views import ViewConfig

CLEAN = ViewConfig(noise=DepthNoise(enabled=False), num_distractors=0)


def _inside_fraction(sample, margin_m):
    T_inv = invert_transform(sample["cam_from_part"])[sample["part_labels"]]
    local = np.einsum("nij,nj->ni", T_inv[:, :3, :3], sample["points"]) + T_inv[:, :3, 3]
    half = sample["size_m"][sample["part_labels"]] / 2 + margin_m
    return np.all(np.abs(local) <= half, axis=1).mean()


@pytest.mark.parametrize("category", CATEGORY_NAMES)
def test_points_fall_inside_their_part_box(category):
    K = get_category(category).num_parts
    for i in range(3):
        clean = make_sample(GenerateConfig(category=category, split="test", view=CLEAN), i)
        assert clean["points"].shape[1] == 3 and len(clean["points"]) >= 16
        assert set(np.unique(clean["part_labels"]).tolist()) <= set(range(K))
        # clean depth is only quantised to 1 mm
        assert _inside_fraction(clean, 0.0015) == 1.0
        noisy = make_sample(GenerateConfig(category=category, split="test"), i)
        assert _inside_fraction(noisy, 0.015) > 0.97


@pytest.mark.parametrize("category", [c for c in CATEGORY_NAMES if get_category(c).num_parts > 1])
def test_child_pose_is_parent_motion_about_gt_joint(category):
    """A child's pose at state q = its pose at the rest state moved about/along the GT joint."""
    spec = get_category(category)
    cfg = GenerateConfig(category=category, split="train", view=CLEAN)
    s = make_sample(cfg, 3)
    obj = make_instance(category, "train", 3 // cfg.views_per_instance)
    rest = obj.object_from_part(obj.rest_state)
    for j, joint in enumerate(obj.joints):
        if joint.parent != 0:
            continue  # all generated categories hang their joints on the root
        dq = s["joint_state"][j] - joint.rest
        axis, pivot = s["joint_axis"][j], s["joint_pivot"][j]
        M = axis_angle_transform(axis, pivot, dq) if spec.joint_types[j] == "revolute" else translation_transform(axis * dq)
        expect = M @ s["cam_from_object"] @ rest[joint.child]
        np.testing.assert_allclose(s["cam_from_part"][joint.child], expect, atol=1e-9)
        # and the child's observed points, moved back by the inverse motion, sit in the rest-state box
        pts = s["points"][s["part_labels"] == joint.child]
        back = apply_transform(invert_transform(s["cam_from_object"] @ rest[joint.child]) @ invert_transform(M), pts)
        assert np.all(np.abs(back) <= obj.parts[joint.child].size_m / 2 + 0.0015)


def test_train_and_test_instances_are_disjoint():
    for category in ("laptop", "mug"):
        train = {tuple(sorted(make_instance(category, "train", i).params.items())) for i in range(40)}
        test = {tuple(sorted(make_instance(category, "test", i).params.items())) for i in range(40)}
        assert len(train) == 40 and len(test) == 40
        assert not train & test


def test_sample_is_deterministic():
    cfg = GenerateConfig(category="eyeglasses", split="train")
    a, b = make_sample(cfg, 11), make_sample(cfg, 11)
    for k in ("points", "normals", "part_labels", "cam_from_part"):
        np.testing.assert_array_equal(a[k], b[k])
    c = make_sample(cfg, 12)
    assert not np.array_equal(a["cam_from_object"], c["cam_from_object"])
