"""scripts/update_view_priors.py --stacks-only / --slides-only: the stacks of a model, and how far its drawers slide,
measured on its category's views."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from update_view_priors import main  # noqa: E402

from ucope.data.generate import GenerateConfig, generate_dataset  # noqa: E402
from ucope.priors import CategoryPriors  # noqa: E402


@pytest.fixture(scope="module")
def drawer_views(tmp_path_factory):
    cfg = GenerateConfig(category="drawer", split="train", num=12, max_points=300, views_per_instance=2)
    return generate_dataset(tmp_path_factory.mktemp("views") / "drawer", cfg, progress=False)


def test_stacks_only_writes_the_drawers_stack_and_nothing_else(tmp_path, drawer_views, capsys):
    model = tmp_path / "drawer.json"
    shutil.copy(ROOT / "src/ucope/pretrained/drawer.json", model)
    before = json.loads(model.read_text())
    before["config"]["priors"]["stacks"] = []
    model.write_text(json.dumps(before))
    assert main(["--model", str(model), "--data", str(drawer_views), "--stacks-only"]) == 0
    after = json.loads(model.read_text())
    (st,) = CategoryPriors.from_dict(after["config"]["priors"]).stacks
    assert (st.parent, st.axis, st.children) == (0, 1, (1, 2, 3))
    assert after["info"]["stacks_from"]["num_samples"] == 12 and after["info"]["stacks_from"]["split"] == "train"
    # every other prior and the model card stay
    for key in ("parts", "joints", "radius_typical_m", "norm_scale_m"):
        assert after["config"]["priors"][key] == before["config"]["priors"][key]
    assert {k: v for k, v in after["info"].items() if k != "stacks_from"} == {
        k: v for k, v in before["info"].items() if k != "stacks_from"
    }
    assert "stack [1, 2, 3] in part 0 along y" in capsys.readouterr().out


def test_views_of_another_category_and_exclusive_flags_are_refused(tmp_path, drawer_views):
    model = tmp_path / "laptop.json"
    shutil.copy(ROOT / "src/ucope/pretrained/laptop.json", model)
    assert main(["--model", str(model), "--data", str(drawer_views), "--stacks-only"]) == 2
    assert main(["--model", str(model), "--data", str(drawer_views), "--stacks-only", "--extent-only"]) == 2
    assert json.loads(model.read_text()) == json.loads((ROOT / "src/ucope/pretrained/laptop.json").read_text())


def test_slides_only_writes_how_far_the_drawers_slide_and_nothing_else(tmp_path, drawer_views, capsys):
    model = tmp_path / "drawer.json"
    shutil.copy(ROOT / "src/ucope/pretrained/drawer.json", model)
    before = json.loads(model.read_text())
    for jd in before["config"]["priors"]["joints"]:
        jd.pop("max_state_over_extent", None)
    before["info"].pop("slides_from", None)
    model.write_text(json.dumps(before))
    assert main(["--model", str(model), "--data", str(drawer_views), "--slides-only"]) == 0
    after = json.loads(model.read_text())
    joints = CategoryPriors.from_dict(after["config"]["priors"]).joints
    assert all(0.0 < jp.max_state_over_extent <= 0.75 + 1e-9 for jp in joints)
    assert after["info"]["slides_from"]["num_samples"] == 12
    for jd_after, jd_before in zip(after["config"]["priors"]["joints"], before["config"]["priors"]["joints"], strict=True):
        assert {k: v for k, v in jd_after.items() if k != "max_state_over_extent"} == jd_before
    for key in ("parts", "stacks", "radius_typical_m", "norm_scale_m"):
        assert after["config"]["priors"][key] == before["config"]["priors"][key]
    assert {k: v for k, v in after["info"].items() if k != "slides_from"} == before["info"]
    assert "max state over extent" in capsys.readouterr().out
    assert main(["--model", str(model), "--data", str(drawer_views), "--slides-only", "--stacks-only"]) == 2
