"""Category specs (ucope.objects.spec): every validation error, the JSON Schema, registration, instances."""

from __future__ import annotations

import copy
import json
import warnings

import numpy as np
import pytest
from own_objects_support import (
    door_spec,
    two_link_spec,
    write_door_pair,
    write_mesh_folder,
    write_spec,
    write_three_link_urdf,
    write_two_link_urdf,
)

from ucope.errors import InputError, UnknownCategoryError
from ucope.objects.categories import get_category, instance_family_and_scale, make_instance, register_category
from ucope.objects.spec import SCHEMA_PATH, check_spec, load_spec, read_spec, register_spec

pytest.importorskip("yourdfpy")

VALID = two_link_spec("two_link.urdf")
DEEP: list = []
for _ in range(49):  # a description 50 lists deep (issue #50: it was turned into a string)
    DEEP = [DEEP]


def _set(path: str, value):
    """A copy of VALID with the field at dotted ``path`` (list indices as numbers) set to ``value``
    (``...`` deletes it)."""
    doc = copy.deepcopy(VALID)
    *head, last = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = doc
    for k in head:
        node = node[k]
    if value is ...:
        del node[last]
    else:
        node[last] = value
    return doc


# (field path, value, error message fragment, whether the JSON Schema alone rejects it too)
BAD = [
    ("surplus", 1, r"surplus: unknown field", True),
    ("ucope_category_spec", ..., r"ucope_category_spec: missing", True),
    ("name", ..., r"name: missing", True),
    ("parts", ..., r"parts: missing", True),
    ("instances", ..., r"instances: missing", True),
    ("ucope_category_spec", 2, r"reads format 1, got 2", True),
    ("name", "my box", r"name: must be a non-empty name", True),
    ("name", "kiste_\u00e4", r"name: must be a non-empty name", True),
    ("name", "laptop", r"'laptop' is a built-in category", False),
    ("parts", [], r"parts: must be a non-empty list", True),
    ("parts.0", {"name": "base"}, r"parts\[0\]: must be an object with name and links", True),
    ("parts.0.colour", "red", r"parts\[0\]: unknown field", True),
    ("parts.0.name", "", r"parts\[0\].name: must be a non-empty string", True),
    ("parts.0.links", [], r"parts\[0\].links: must be a non-empty list", True),
    ("parts.0.links", "base_link", r"parts\[0\].links: must be a non-empty list", True),
    ("parts.0.symmetry", "x", r"parts\[0\].symmetry: must be one of", True),
    ("parts.1.name", "base", r"part names must be unique", False),
    ("joints", [], r"joints: 2 parts need 1 category joints", False),
    ("joints.0", {"joint": "hinge"}, r"joints\[0\]: must be an object with joint and range", True),
    ("joints.0.speed", 1, r"joints\[0\]: unknown field", True),
    ("joints.0.joint", "", r"joints\[0\].joint: must name a joint", True),
    ("joints.0.sign", 2, r"joints\[0\].sign: must be 1 or -1", True),
    ("joints.0.unit", "grad", r"joints\[0\].unit: must be one of rad, deg, m, cm, mm", True),
    ("joints.0.offset", "0", r"joints\[0\].offset: must be a finite number", True),
    ("joints.0.range", [0, 1, 2], r"joints\[0\].range: must be \[lower, upper\]", True),
    ("joints.0.range", [90, 10], r"joints\[0\].range: must be finite with lower <= upper", False),
    ("joints.0.range", [10, 10], r"joints\[0\].range: must span a range", False),
    ("held_joints", {"knob": "open"}, r"held_joints: must map joint names to finite file values", True),
    ("instances", [], r"instances: must be a non-empty list", True),
    ("instances.0", {"scale": 1}, r"instances\[0\]: must be an object with a file", True),
    ("instances.0.colour", 1, r"instances\[0\]: unknown field", True),
    ("instances.0.file", "", r"instances\[0\].file: must be a path", True),
    ("instances.0.rotation", "x_up", r"instances\[0\].rotation: unknown rotation rule 'x_up'", True),
    ("instances.0.rotation", {"euler_xyz_deg": [0, 90]}, r"euler_xyz_deg must be 3 finite numbers", True),
    ("instances.0.rotation", [[1, 0, 0], [0, 1, 0], [0, 0, -1]], r"must be a rotation \(orthonormal, determinant \+1\)", False),
    ("instances.0.rotation", [[2, 0, 0], [0, 1, 0], [0, 0, 1]], r"must be a rotation", False),
    ("instances.0.rotation", [1, 0, 0], r"instances\[0\].rotation: must be a rule", True),
    ("instances.0.scale", 0, r"instances\[0\].scale: must be a positive number", True),
    ("instances.0.held_out", "yes", r"instances\[0\].held_out: must be true or false", True),
    ("instances.0.held_joints", [1], r"instances\[0\].held_joints: must map joint names", True),
    ("instances.0.parts", [["base_link"]], r"instances\[0\].parts: must map part names", True),
    ("instances.0.parts", {"hull": ["b"]}, r"instances\[0\].parts.hull: is not a part of the spec", False),
    ("instances.0.parts", {"lid": []}, r"instances\[0\].parts.lid: must be a non-empty list", True),
    ("instances.0.joints", [], r"instances\[0\].joints: must list this file's joint for each of the 1", False),
    ("instances.0.joints", [{"sign": 1}], r"instances\[0\].joints\[0\]: must be an object with joint", True),
    ("instances.0.joints", [{"joint": "h", "range": [0, 1]}], r"joints\[0\]: unknown field.*unit and range", True),
    ("instances.0.joints", [{"joint": ""}], r"instances\[0\].joints\[0\].joint: must name a joint", True),
    ("instances.0.joints", [{"joint": "h", "sign": 0}], r"instances\[0\].joints\[0\].sign: must be 1 or -1", True),
    ("instances.0.joints", [{"joint": "h", "offset": "1"}], r"joints\[0\].offset: must be a finite number", True),
    ("mesh_search_path", "meshes", r"mesh_search_path: must be a list of folders", True),
    ("size_scale_range", [0, 2], r"size_scale_range: must be positive", False),
    ("size_range_m", [1], r"size_range_m: must be \[lower, upper\]", True),
    ("camera", {"fov": 60}, r"camera: must be an object with distance_range_m", True),
    ("camera.distance_range_m", [-1, 1], r"camera.distance_range_m: must be positive", False),
    ("camera.elevation_range_deg", [10, 120], r"camera.elevation_range_deg: must lie within \[-90, 90\]", False),
    ("description", DEEP, r"description: must be a string \(one line\), got a list", True),
    ("description", 3, r"description: must be a string", True),
    ("allow_outside_paths", "yes", r"allow_outside_paths: must be true or false", True),
    ("mesh_limits", {"max_mb": 1}, r"mesh_limits: must be an object with any of max_file_mb", True),
    ("mesh_limits", {"max_file_mb": 0}, r"mesh_limits.max_file_mb: must be a positive number", True),
    ("exclude_links", "lid_link", r"exclude_links: must be a list of link / body names", True),
    ("exclude_geom_groups", [-1], r"exclude_geom_groups: must be 'auto' or a list of MJCF geom groups", True),
    ("on_axis_mismatch", "ask", r"on_axis_mismatch: must be 'flip' or 'refuse'", True),
    ("joints.0.axis", [0, 0, 0], r"joints\[0\].axis: must be 3 finite numbers, not all zero", False),
    ("joints.0.axis", [0, 1], r"joints\[0\].axis: must be 3 finite numbers", True),
    ("instances.0.pattern", [], r"instances\[0\].pattern: must be a glob pattern", True),
    ("instances.0.pattern", "../*.urdf", r"instances\[0\].pattern: pattern '../\*.urdf' must stay inside the folder", False),
    ("instances.0.exclude_links", [1], r"instances\[0\].exclude_links: must be a list", True),
    ("instances.0.exclude_geom_groups", "all", r"instances\[0\].exclude_geom_groups: must be 'auto' or a list", True),
]


@pytest.mark.parametrize(("path", "value", "match", "schema_too"), BAD, ids=[f"{b[0]}={b[1]!r}"[:60] for b in BAD])
def test_every_spec_error_names_its_field(path, value, match, schema_too):
    doc = _set(path, value)
    with pytest.raises(InputError, match=r"^category spec: .*" + match):
        check_spec(doc)
    jsonschema = pytest.importorskip("jsonschema")
    if schema_too:  # the shipped schema says the same to editors and other tools
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(json.loads(json.dumps(doc)), json.loads(SCHEMA_PATH.read_text()))


def test_valid_spec_passes_the_checks_and_the_schema():
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(SCHEMA_PATH.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.validate(VALID, schema)
    out = check_spec(VALID)
    jsonschema.validate({k: v for k, v in out.items()}, schema)  # normalised docs are valid too
    assert check_spec(out) == out  # normalising is idempotent (data sets compare specs)
    assert out["joints"][0] == {"joint": "hinge", "sign": 1, "offset": 0.0, "unit": "deg", "range": [0.0, 100.0]}
    assert out["size_scale_range"] == [1.0, 1.0] and out["parts"][1]["symmetry"] == "none"


def test_read_spec_names_missing_and_broken_files(tmp_path):
    with pytest.raises(InputError, match=r"category spec .*nope.json does not exist"):
        read_spec(tmp_path / "nope.json")
    (tmp_path / "bad.json").write_text("{parts: ")
    with pytest.raises(InputError, match=r"category spec .*bad.json is not valid JSON"):
        read_spec(tmp_path / "bad.json")
    (tmp_path / "list.json").write_text("[]")
    with pytest.raises(InputError, match=r"must be a JSON object"):
        read_spec(tmp_path / "list.json")
    write_spec(tmp_path / "ok.json", VALID)
    assert read_spec(tmp_path / "ok.json")["base_dir"] == str(tmp_path.resolve())


# ------------------------------------------------------------------------------ reading the files
def test_missing_instance_files_and_empty_folders_are_named(tmp_path):
    with pytest.raises(InputError, match=r"instances\[0\].file: .*two_link.urdf does not exist"):
        load_spec({**VALID, "base_dir": str(tmp_path)})
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"instances\[0\].file: folder .*empty holds no model files"):
        load_spec({**VALID, "base_dir": str(tmp_path), "instances": [{"file": "empty"}]})


def test_a_unit_that_does_not_fit_the_joint_is_named(tmp_path):
    write_two_link_urdf(tmp_path)
    doc = _set("joints.0.unit", "mm")
    with pytest.raises(InputError, match=r"joints\[0\].unit: 'mm' is a prismatic unit but joint 'hinge' .* is revolute"):
        load_spec({**doc, "base_dir": str(tmp_path)})


def test_range_outside_the_file_limits_names_joint_and_file(tmp_path):
    write_two_link_urdf(tmp_path)
    doc = _set("joints.0.range", [0, 130])  # the file allows 0..2 rad = 114.6 deg
    with pytest.raises(InputError, match=r"two_link.urdf: category joint 0 \('hinge'\): sampled range \[0, 2.269\] rad"):
        load_spec({**doc, "base_dir": str(tmp_path)})


def test_instances_of_different_trees_are_refused(tmp_path):
    write_two_link_urdf(tmp_path)
    write_three_link_urdf(tmp_path)
    doc = {
        **VALID,
        "base_dir": str(tmp_path),
        "parts": [{"name": "base", "links": ["base_link", "cabinet"]}, {"name": "lid", "links": "*"}],
        "joints": [{"joint": "hinge", "range": [0, 0.2]}],
        "instances": [{"file": "two_link.urdf"}, {"file": "three_link.urdf"}],
    }
    with pytest.raises(InputError, match=r"names link 'cabinet', which the file lacks"):
        load_spec(doc)


def test_a_mesh_in_millimetres_is_warned_about_by_name(tmp_path):
    folder = write_mesh_folder(tmp_path / "m")
    import trimesh

    trimesh.creation.box(extents=[100.0, 200.0, 100.0]).export(folder / "big_mm.stl")
    doc = {
        "ucope_category_spec": 1,
        "name": "boxes",
        "parts": [{"name": "body", "links": "*"}],
        "instances": [{"file": "m"}],
        "size_range_m": [0.05, 1.0],
        "base_dir": str(tmp_path),
    }
    with pytest.warns(
        UserWarning,
        match=r"big_mm.stl: the object's diagonal is 244.9 m, outside the spec's size_range_m \[0.05, 1\]; "
        r"it looks like millimetres: give the instance scale 0.001",
    ):
        own = load_spec(doc)
    assert len(own.families) == 4 and own.spec.num_parts == 1
    doc["instances"] = [{"file": "m/big_mm.stl", "scale": 0.001}]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # at the right scale: no warning
        own = load_spec(doc)
    np.testing.assert_allclose(own.objects[own.families[0]].parts[0].size_m, [0.1, 0.2, 0.1], atol=1e-9)


def test_mesh_folder_spec_makes_a_rigid_category_with_every_file(tmp_path):
    write_mesh_folder(tmp_path / "m")
    doc = {
        "ucope_category_spec": 1,
        "name": "boxes",
        "parts": [{"name": "body", "links": "*", "symmetry": "none"}],
        "instances": [{"file": "m"}, {"file": "m/c.ply", "held_out": True}],
        "base_dir": str(tmp_path),
    }
    own = load_spec(doc)
    assert own.families == ("000_a", "001_b", "002_c", "003_c")
    assert own.spec.families_for_split("ood") == ("003_c",) and own.spec.joint_types == ()


# ------------------------------------------------------------------------ registry and instances
@pytest.fixture
def registered(tmp_path):
    write_two_link_urdf(tmp_path)
    from ucope.objects import categories

    doc = {**VALID, "base_dir": str(tmp_path), "name": "toy_box_reg", "size_scale_range": [0.8, 1.25]}
    yield register_spec(doc)
    categories._registry().pop("toy_box_reg", None)  # leave the process registry as it was
    categories._DOCS.pop("toy_box_reg", None)


def test_registered_spec_makes_deterministic_scaled_instances(registered):
    spec = get_category("toy_box_reg")
    assert spec.family == "own" and spec.part_names == ("base", "lid") and spec.joint_types == ("revolute",)
    a = make_instance("toy_box_reg", "train", 3, seed=1)
    b = make_instance("toy_box_reg", "train", 3, seed=1)
    np.testing.assert_array_equal(a.parts[0].mesh.vertices, b.parts[0].mesh.vertices)
    assert a.instance_id == "toy_box_reg/train/1/000003" and a.shape_family == "000_two_link"
    scales = [make_instance("toy_box_reg", "train", i).scale for i in range(12)]
    assert all(0.8 <= s <= 1.25 for s in scales) and len(set(scales)) == 12
    np.testing.assert_allclose(a.limits, [[0.0, np.radians(100.0)]])
    base = registered.objects["000_two_link"]
    np.testing.assert_allclose(a.size_m, base.size_m * a.scale, atol=1e-12)
    with pytest.raises(InputError, match=r"no shape families held out \(ood\): it has no 'ood' split"):
        instance_family_and_scale("toy_box_reg", "ood", 0)


def test_builtin_names_cannot_be_registered_and_unknown_names_point_to_specs(registered):
    import dataclasses

    with pytest.raises(InputError, match=r"cannot register 'laptop'"):
        register_category(dataclasses.replace(registered.spec, name="laptop"))
    with pytest.raises(UnknownCategoryError, match=r"registered from specs: .*toy_box_reg.*ucope generate --spec"):
        get_category("nope")


def test_generated_samples_of_a_spec_are_identical_after_registering_again(registered):
    from ucope.data.generate import GenerateConfig, make_sample
    from ucope.objects import categories

    cfg = GenerateConfig(category="toy_box_reg", split="train", num=4, views_per_instance=2, max_points=256, spec=registered.doc)
    cfg.validate()
    a = make_sample(cfg, 3)
    # a fresh process (a spawned worker) knows only the config: forget the registration and rebuild
    categories._registry().pop("toy_box_reg")
    categories._DOCS.pop("toy_box_reg")
    b = make_sample(cfg, 3)
    for k in ("points", "part_labels", "cam_from_part", "size_m", "joint_state"):
        np.testing.assert_array_equal(a[k], b[k])
    assert a["category"] == "toy_box_reg" and a["points"].shape == (256, 3)
    meta = cfg.meta()
    assert meta["spec"] == registered.doc and meta["family"] == "own" and len(meta["structure"]["joints"]) == 1
    with pytest.raises(InputError, match=r"the spec describes category 'toy_box_reg', not 'other'"):
        GenerateConfig(category="other", spec=registered.doc).validate()


def test_spawned_workers_write_the_same_spec_data_as_one_process(tmp_path):
    """Workers are spawned processes that know the category only from the config's spec."""
    from ucope.data.dataset import load_dataset
    from ucope.data.generate import GenerateConfig, generate_dataset

    write_two_link_urdf(tmp_path / "src")
    own = load_spec({**VALID, "base_dir": str(tmp_path / "src"), "size_scale_range": [0.8, 1.25]})
    cfg = GenerateConfig(category="toy_box", spec=own.doc, num=8, shard_size=2, views_per_instance=2, max_points=256)
    one = load_dataset(generate_dataset(tmp_path / "one", cfg, workers=1, progress=False))
    two = load_dataset(generate_dataset(tmp_path / "two", cfg, workers=2, progress=False))
    for i in range(8):
        for k in ("points", "part_labels", "cam_from_part", "size_m", "joint_state"):
            np.testing.assert_array_equal(one[i][k], two[i][k])


def test_an_instance_names_its_own_links_and_joints(tmp_path):
    """Files of one category whose links and joints are named differently: each instance entry maps
    them (``parts``: its links per part; ``joints``: its joint, sign and offset per category joint)."""
    write_two_link_urdf(tmp_path / "a")
    write_two_link_urdf(tmp_path / "b")
    text = (tmp_path / "b" / "two_link.urdf").read_text()
    text = text.replace("base_link", "body").replace("lid_link", "flap").replace('"hinge"', '"flap_hinge"')
    text = text.replace('<axis xyz="1 0 0"/>', '<axis xyz="-1 0 0"/>').replace('lower="0" upper="2.0"', 'lower="-2.0" upper="0"')
    (tmp_path / "b" / "other.urdf").write_text(text)
    own_b = {"parts": {"base": ["body"], "lid": ["flap"]}, "joints": [{"joint": "flap_hinge", "sign": -1}]}
    a, b = "a/two_link.urdf", "b/other.urdf"
    doc = two_link_spec(a, instances=[{"file": a}, {"file": b, **own_b}], base_dir=str(tmp_path))
    out = check_spec(doc)
    assert out["instances"][1]["joints"] == [{"joint": "flap_hinge", "sign": -1}] and "parts" not in out["instances"][0]
    own = load_spec(doc)
    A, B = (own.objects[f] for f in own.families)
    for q in (0.0, 0.7, 1.5):  # the same motion: the flipped axis and the sign cancel
        np.testing.assert_allclose(A.object_from_part([q]), B.object_from_part([q]), atol=1e-9)
    np.testing.assert_allclose(A.joints[0].axis, B.joints[0].axis, atol=1e-12)
    with pytest.raises(InputError, match=r"part 'base' names link 'base_link', which the file lacks"):
        load_spec(two_link_spec(a, instances=[{"file": b}], base_dir=str(tmp_path)))
    bad = two_link_spec(a, instances=[{"file": b, **own_b, "joints": [{"joint": "flap_hinge"}]}], base_dir=str(tmp_path))
    with pytest.raises(InputError, match=r"sampled range .* is outside the file's limits"):
        load_spec(bad)  # the category's sign +1 maps the file's -2..0 rad outside 0..100 deg


# ------------------------------------------------------------------------ paths, limits, folders
def test_spec_files_stay_inside_base_dir_unless_the_spec_allows_otherwise(tmp_path):
    """Issue #50, class 12: '..', absolute, file:// and symbolic-link escapes from base_dir (and its
    mesh_search_path) are refused, naming the field or the file and link; "allow_outside_paths" lets them."""
    base = tmp_path / "spec"
    write_two_link_urdf(tmp_path / "outside")
    write_two_link_urdf(base)
    cases = [
        ({"instances": [{"file": "../outside/two_link.urdf"}]}, r"instances\[0\].file: '../outside/two_link.urdf' lies outside"),
        ({"instances": [{"file": str(tmp_path / "outside" / "two_link.urdf")}]}, r"instances\[0\].file: .* is an absolute path"),
        ({"mesh_search_path": ["../outside"]}, r"mesh_search_path\[0\]: '../outside' lies outside base_dir"),
    ]
    for extra, match in cases:
        doc = two_link_spec("two_link.urdf", base_dir=str(base), **extra)
        with pytest.raises(InputError, match=r"^category spec: " + match):
            load_spec(doc)
        assert load_spec({**doc, "allow_outside_paths": True}).spec.num_parts == 2
    # a mesh reference inside a file that leaves the folders: '..' and a symbolic link
    text = (base / "two_link.urdf").read_text()
    (base / "escape.urdf").write_text(text.replace("package://toy_pkg/meshes/base.stl", "../outside/toy_pkg/meshes/base.stl"))
    (base / "link.stl").symlink_to(tmp_path / "outside" / "toy_pkg" / "meshes" / "base.stl")
    (base / "linked.urdf").write_text(text.replace("package://toy_pkg/meshes/base.stl", "link.stl"))
    for name in ("escape.urdf", "linked.urdf"):
        doc = two_link_spec(name, base_dir=str(base))
        with pytest.raises(
            InputError, match=rf"URDF file .*{name}: link 'base_link': mesh file .*lies outside the spec's folders"
        ):
            load_spec(doc)
        assert load_spec({**doc, "allow_outside_paths": True}).spec.num_parts == 2


def test_mesh_limits_are_set_by_the_spec_and_name_the_file(tmp_path):
    write_two_link_urdf(tmp_path)
    doc = two_link_spec("two_link.urdf", base_dir=str(tmp_path), mesh_limits={"max_vertices": 10})
    assert check_spec(doc)["mesh_limits"] == {"max_vertices": 10}
    with pytest.raises(
        InputError, match=r"base_link.*base.stl has 36 vertices, above the limit of 10 .*mesh_limits.max_vertices"
    ):
        load_spec(doc)
    doc["mesh_limits"] = {"max_file_mb": 1e-4}  # 104 bytes: the URDF file itself is larger
    with pytest.raises(InputError, match=r"URDF file: .*two_link.urdf is 0.0 MiB, above the limit of 0.0 MiB"):
        load_spec(doc)
    assert "mesh_limits" not in check_spec(VALID)  # absent when not given: older specs normalise as before


def test_folder_entries_take_meshes_and_skip_collision_meshes(tmp_path):
    """A folder of mugs as asset libraries ship them: each mesh, its '_col' collision mesh, a collision/
    folder and the library's .xml; by default the meshes (at any depth) are taken and the collision ones
    left out; ``pattern`` and ``exclude`` choose otherwise."""
    import trimesh

    folder = tmp_path / "mugs"
    for rel, ext in (
        ("mug_a.obj", [0.1, 0.12, 0.1]),
        ("mug_a_col.obj", [0.11, 0.13, 0.11]),
        ("collision/mug_b.stl", [0.12, 0.12, 0.12]),
        ("mug_b.stl", [0.1, 0.1, 0.1]),
        ("tall/mug_c.ply", [0.08, 0.15, 0.08]),
        ("mug_colour.stl", [0.09, 0.1, 0.09]),
    ):
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        trimesh.creation.box(extents=ext).export(folder / rel)
    (folder / "mugs.xml").write_text("<mujoco/>")
    doc = {
        "ucope_category_spec": 1,
        "name": "mugs",
        "parts": [{"name": "body", "links": "*", "symmetry": "y"}],
        "instances": [{"file": "mugs"}],
        "base_dir": str(tmp_path),
    }
    own = load_spec(doc)
    assert own.families == ("000_mug_a", "001_mug_b", "002_mug_colour", "003_mug_c")
    assert sorted(f.relative_to(folder).as_posix() for f in own.skipped[0]) == ["collision/mug_b.stl", "mug_a_col.obj"]
    assert own.objects["003_mug_c"].params["source"] == "mugs/tall/mug_c.ply"
    own = load_spec({**doc, "instances": [{"file": "mugs", "pattern": "**/*.stl", "exclude": []}]})
    assert own.families == ("000_collision-mug_b", "001_mugs-mug_b", "002_mug_colour")
    with pytest.raises(
        InputError, match=r"instances\[0\].file: folder .*mugs holds no model files matching its pattern \['\*.urdf'\]"
    ):
        load_spec({**doc, "instances": [{"file": "mugs", "pattern": "*.urdf"}]})
    with pytest.raises(InputError, match=r"instances\[0\].pattern: is for folder entries"):
        load_spec({**doc, "instances": [{"file": "mugs/mug_b.stl", "pattern": "*.stl"}]})


def test_instances_of_one_file_name_are_told_apart_and_samples_record_their_file(tmp_path):
    """Two arms both called robot.urdf were 000_robot and 001_robot; the folder tells them apart, and every
    generated sample records the file its instance was read from (relative to base_dir)."""
    from ucope.data.dataset import load_dataset
    from ucope.data.generate import GenerateConfig, generate_dataset
    from ucope.objects.spec import family_names

    for arm in ("arm_a", "arm_b"):
        write_two_link_urdf(tmp_path / arm)
        (tmp_path / arm / "two_link.urdf").rename(tmp_path / arm / "robot.urdf")
    doc = two_link_spec("x", instances=[{"file": "arm_a/robot.urdf"}, {"file": "arm_b/robot.urdf"}], base_dir=str(tmp_path))
    own = load_spec(doc)
    assert own.families == ("000_arm_a-robot", "001_arm_b-robot")
    assert [own.objects[f].params["source"] for f in own.families] == ["arm_a/robot.urdf", "arm_b/robot.urdf"]
    assert [f.description for f in own.spec.shape_families] == ["arm_a/robot.urdf", "arm_b/robot.urdf"]
    names = family_names([tmp_path / p for p in ("x/a/r.urdf", "y/a/r.urdf", "z/b.urdf", "x/a/r.urdf")], tmp_path)
    assert names == ["000_x-a-r", "001_y-a-r", "002_b", "003_x-a-r"]
    cfg = GenerateConfig(category="toy_box", spec=own.doc, num=4, shard_size=4, views_per_instance=1, max_points=128)
    ds = load_dataset(generate_dataset(tmp_path / "data", cfg, workers=1, progress=False))
    sources = {ds[i]["source"] for i in range(4)}
    assert sources <= {"arm_a/robot.urdf", "arm_b/robot.urdf"} and len(sources) == 2


# ----------------------------------------------------------------------------------- axis signs
def _door_axes(own):
    return [own.objects[f].joints[0].axis for f in own.families]


def test_disagreeing_joint_axes_are_brought_to_one_sign(tmp_path):
    """Issue #48 defect 1: two doors hinged on opposite edges (file axes -z and +z, both opening to the
    front by positive file values). The second file is turned round to the first's axis with its states
    negated (a warning names both files): every instance, and so every split's meta.json, has one axis, and
    both doors open to the front, one by positive states and one by negative."""
    from ucope.data.generate import GenerateConfig

    write_door_pair(tmp_path)
    with pytest.warns(
        UserWarning, match=r"001_right-door \(right/door.urdf\): the axis of category joint\(s\) \[0\] points against"
    ):
        own = load_spec(door_spec(tmp_path))
    assert own.families == ("000_left-door", "001_right-door") and own.flipped == {"001_right-door": (0,)}
    for a in _door_axes(own):
        np.testing.assert_allclose(a, [0.0, -1.0, 0.0], atol=1e-12)  # file -z = canonical -y
    left, right = (own.objects[f] for f in own.families)
    np.testing.assert_allclose(left.limits, [[0.0, np.pi / 2]])
    np.testing.assert_allclose(right.limits, [[-np.pi / 2, 0.0]])
    assert own.joint_limits["001_right-door"][0] == ("hinge", (0.0, 2.0), (-2.0, 0.0))
    for obj, q in ((left, 1.2), (right, -1.2)):
        assert obj.object_from_part([q])[1, 2, 3] > obj.object_from_part([0.0])[1, 2, 3] + 0.1  # the leaf swings to +z
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        doc = load_spec(door_spec(tmp_path)).doc
        metas = [GenerateConfig(category="door_pair", spec=doc, split=s, num=1).meta() for s in ("train", "test", "val")]
    assert len({tuple(m["structure"]["joints"][0]["axis_in_parent"]) for m in metas}) == 1


def test_axis_sign_refusal_and_the_specs_own_axis(tmp_path):
    write_door_pair(tmp_path)
    with pytest.raises(
        InputError,
        match=r"joint 0 \('hinge'\): the axis of 001_right-door \(right/door.urdf\), \[0.0, 1.0, 0.0\], points against that of "
        r"000_left-door \(left/door.urdf\)",
    ):
        load_spec(door_spec(tmp_path, on_axis_mismatch="refuse"))
    joints = [{"joint": "hinge", "unit": "deg", "range": [0, 90], "axis": [0, 1, 0]}]
    with pytest.warns(UserWarning, match=r"000_left-door .* points against the category's \(the spec\)"):
        own = load_spec(door_spec(tmp_path, joints=joints))
    assert own.flipped == {"000_left-door": (0,)}
    for a in _door_axes(own):
        np.testing.assert_allclose(a, [0.0, 1.0, 0.0], atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # both files agree with a spec axis along their own: no flip, no warning
        one = load_spec(door_spec(tmp_path, joints=joints, instances=[{"file": "right/door.urdf"}]))
    assert one.flipped == {}
    sideways = [{"joint": "hinge", "unit": "deg", "range": [0, 90], "axis": [1, 0, 0]}]
    with pytest.raises(
        InputError, match=r"the axis of 000_left-door .* is 90 degrees off the axis of the spec's joints\[0\].axis"
    ):
        load_spec(door_spec(tmp_path, joints=sideways))


def test_spec_excludes_links_and_geom_groups(tmp_path):
    pytest.importorskip("mujoco")
    from own_objects_support import write_grouped_arm_mjcf

    write_grouped_arm_mjcf(tmp_path)
    doc = {
        "ucope_category_spec": 1,
        "name": "grouped_arm",
        "parts": [{"name": "base", "links": ["base"]}, {"name": "link1", "links": ["link1"]}, {"name": "link2", "links": "*"}],
        "joints": [{"joint": "joint1", "range": [-1, 1]}, {"joint": "joint2", "range": [-1, 1]}],
        "instances": [{"file": "grouped_arm.xml", "rotation": "identity"}],
        "base_dir": str(tmp_path),
    }
    assert load_spec(doc).objects["000_grouped_arm"].parts[2].size_m[2] == pytest.approx(0.231, abs=1e-3)
    for extra in ({"exclude_links": ["link2_proxy", "not_in_this_file"]}, {"exclude_geom_groups": [0, 3, 4, 5]}):
        own = load_spec({**doc, **extra})
        np.testing.assert_allclose(own.objects["000_grouped_arm"].parts[2].size_m, [0.1, 0.08, 0.196], atol=1e-6)
    bad = {**doc, "instances": [{"file": "grouped_arm.xml", "exclude_links": ["nope"]}]}
    with pytest.raises(InputError, match=r"instances\[0\].exclude_links: \['nope'\] are not links of .*grouped_arm.xml"):
        load_spec(bad)
    write_two_link_urdf(tmp_path)
    urdf = two_link_spec(
        "two_link.urdf", base_dir=str(tmp_path), instances=[{"file": "two_link.urdf", "exclude_geom_groups": [3]}]
    )
    with pytest.raises(InputError, match=r"instances\[0\].exclude_geom_groups: is for MJCF files"):
        load_spec(urdf)
