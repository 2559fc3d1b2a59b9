"""URDF, MJCF and mesh-file importers (ucope.objects.importers), on files the tests write themselves."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import trimesh
from own_objects_support import (
    write_base_mesh,
    write_mesh_folder,
    write_three_link_urdf,
    write_two_body_mjcf,
    write_two_link_urdf,
)

from ucope.errors import InputError
from ucope.objects.importers import JointMapping, load_mesh, load_model, model_to_object, resolve_mesh_path
from ucope.objects.spec import ROTATION_RULES

pytest.importorskip("yourdfpy")

Z_UP = ROTATION_RULES["z_up"]
TWO_PARTS = [("base", ["base_link"], "none"), ("lid", ["lid_link"], "none")]
HINGE = [JointMapping("hinge", range=(0.0, 1.5))]


def test_two_link_urdf_reads_links_joint_and_package_mesh(tmp_path):
    m = load_model(write_two_link_urdf(tmp_path))
    assert m.root == "base_link" and set(m.links) == {"base_link", "lid_link"}
    j = m.joints["hinge"]
    assert (j.type, j.parent, j.child, j.limits) == ("revolute", "base_link", "lid_link", (0.0, 2.0))
    np.testing.assert_allclose(j.origin[:3, 3], [0.0, -0.15, 0.1])
    base = m.links["base_link"][0]  # the package:// mesh, placed by its visual origin
    np.testing.assert_allclose(base.bounds, [[-0.2, -0.15, 0.0], [0.2, 0.15, 0.1]], atol=1e-6)


def test_package_mesh_outside_the_urdf_folder_needs_the_search_path(tmp_path):
    urdf = write_two_link_urdf(tmp_path / "robot", mesh_outside=True)
    with pytest.raises(InputError, match=r"package://toy_pkg/meshes/base.stl.*not found"):
        load_model(urdf)
    m = load_model(urdf, search_path=[tmp_path / "pkgs"])
    assert len(m.links["base_link"]) == 1


def test_resolve_relative_and_package_paths(tmp_path):
    f = write_base_mesh(tmp_path / "extra" / "m" / "x.stl")
    assert resolve_mesh_path("m/x.stl", tmp_path, [tmp_path / "extra"]) == f
    assert resolve_mesh_path("package://pkg/m/x.stl", tmp_path, [tmp_path / "extra"]) == f  # DIR/REST
    assert resolve_mesh_path(str(f), tmp_path) == f
    assert resolve_mesh_path(f"file://{f}", tmp_path) == f


def test_fixed_links_merge_into_their_parent_part_and_prismatic_maps_to_state(tmp_path):
    m = load_model(write_three_link_urdf(tmp_path))
    assert m.joints["handle_mount"].type == "fixed" and m.joints["slide"].type == "prismatic"
    parts = [("cabinet", ["cabinet"], "none"), ("drawer", ["drawer", "handle"], "none")]
    obj = model_to_object(m, "c", "c/0", parts, [JointMapping("slide", range=(0.0, 0.25))], canonical_from_file=Z_UP)
    assert obj.num_parts == 2 and obj.joint_types == ("prismatic",)
    # the drawer part holds the drawer box (0.4 x 0.35 x 0.2, z up) and the handle sticking 0.2 m out at
    # its front (file -y): canonical x, y (up), z = file x, z, -y
    np.testing.assert_allclose(obj.parts[1].size_m, [0.4, 0.2, 0.375 + 0.01], atol=1e-3)
    # the category axis is the file's -y, i.e. canonical +z: opening moves the drawer out of the front
    np.testing.assert_allclose(obj.joints[0].axis, [0.0, 0.0, 1.0], atol=1e-9)
    d = obj.object_from_part([0.2])[1, :3, 3] - obj.object_from_part([0.0])[1, :3, 3]
    np.testing.assert_allclose(d, [0.0, 0.0, 0.2], atol=1e-9)


def test_prismatic_state_follows_the_instance_scale(tmp_path):
    m = load_model(write_three_link_urdf(tmp_path))
    parts = [("cabinet", ["cabinet"], "none"), ("drawer", "*", "none")]
    obj = model_to_object(m, "c", "c/0", parts, [JointMapping("slide", range=(0.0, 0.5))], canonical_from_file=Z_UP, scale=2.0)
    np.testing.assert_allclose(obj.parts[0].size_m, [1.0, 0.6, 0.8], atol=1e-6)
    with pytest.raises(InputError, match=r"slide.*outside the file's limits mapped to category states \[0, 0.6\]"):
        model_to_object(m, "c", "c/0", parts, [JointMapping("slide", range=(0.0, 0.7))], scale=2.0)


def test_continuous_joint_is_an_unlimited_revolute_one(tmp_path):
    m = load_model(write_two_link_urdf(tmp_path, hinge_type="continuous"))
    assert m.joints["hinge"].type == "revolute" and m.joints["hinge"].limits is None
    obj = model_to_object(m, "t", "t/0", TWO_PARTS, [JointMapping("hinge", range=(-3.0, 3.0))])
    assert obj.limits.tolist() == [[-3.0, 3.0]]


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_urdf_joints_are_refused_by_name(tmp_path, kind):
    with pytest.raises(InputError, match=rf"joint 'hinge' is {kind}"):
        load_model(write_two_link_urdf(tmp_path, hinge_type=kind))


def test_mjcf_gives_the_same_object_as_the_urdf(tmp_path):
    pytest.importorskip("mujoco")
    mj = load_model(write_two_body_mjcf(tmp_path / "mj"))
    assert mj.root == "world" and mj.links["world"] == []  # the floor plane is scenery
    assert mj.joints["hinge"].limits == pytest.approx((0.0, np.radians(115.0)))  # degrees in the file
    ur = load_model(write_two_link_urdf(tmp_path / "ur"))
    a = model_to_object(ur, "t", "t/0", TWO_PARTS, HINGE, canonical_from_file=Z_UP)
    b = model_to_object(mj, "t", "t/0", [("base", ["base"], "none"), ("lid", ["lid"], "none")], HINGE, canonical_from_file=Z_UP)
    np.testing.assert_allclose(a.size_m, b.size_m, atol=1e-6)
    for q in (0.0, 0.7, 1.5):
        np.testing.assert_allclose(a.object_from_part([q]), b.object_from_part([q]), atol=1e-6)
    # the empty world body joins the root part even when a later part takes the remaining bodies
    c = model_to_object(mj, "t", "t/0", [("base", ["base"], "none"), ("lid", "*", "none")], HINGE, canonical_from_file=Z_UP)
    np.testing.assert_allclose(c.size_m, b.size_m, atol=1e-12)


@pytest.mark.parametrize(("joint", "word"), [("free", "free"), ("ball", "ball")])
def test_mjcf_free_and_ball_joints_are_refused_by_name(tmp_path, joint, word):
    pytest.importorskip("mujoco")
    path = tmp_path / "m.xml"
    path.write_text(
        f'<mujoco><worldbody><body name="b"><joint name="j0" type="{joint}"/><geom type="box" size="0.1 0.1 0.1"/>'
        "</body></worldbody></mujoco>"
    )
    with pytest.raises(InputError, match=rf"joint 'j0' of body 'b' is {word}"):
        load_model(path)


def test_mjcf_missing_mesh_names_the_mesh(tmp_path):
    pytest.importorskip("mujoco")
    path = write_two_body_mjcf(tmp_path)
    (tmp_path / "assets" / "base.stl").unlink()
    with pytest.raises(InputError, match=r"mesh 'base_mesh'.*base.stl.*not found"):
        load_model(path)


def test_mesh_files_are_rigid_one_link_models(tmp_path):
    folder = write_mesh_folder(tmp_path / "meshes")
    for f in sorted(folder.iterdir()):
        m = load_model(f)
        assert list(m.links) == ["body"] and m.joints == {}
        obj = model_to_object(m, "r", "r/0", [("body", "*", "y")], [])
        assert obj.num_parts == 1 and obj.parts[0].symmetry == "y"
        np.testing.assert_allclose(obj.parts[0].size_m, m.links["body"][0].extents, atol=1e-6)


def test_missing_broken_and_empty_meshes_name_the_file(tmp_path):
    with pytest.raises(InputError, match=r"link 'base': mesh file .*nope.stl does not exist"):
        load_mesh(tmp_path / "nope.stl", "link 'base'")
    (tmp_path / "broken.stl").write_bytes(b"solid x\nfacet normal garbage\n")
    with pytest.raises(InputError, match=r"broken.stl"):
        load_mesh(tmp_path / "broken.stl")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    with pytest.raises(InputError, match=r"empty.obj (holds no triangles|\()"):
        load_mesh(tmp_path / "empty.obj")
    trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], faces=[[0, 1, 2]], process=False).export(
        tmp_path / "nan.ply"
    )
    with pytest.raises(InputError, match=r"nan.ply has NaN or Inf vertices"):
        load_mesh(tmp_path / "nan.ply")
    with pytest.raises(InputError, match=r"unknown model file type '.txt'"):
        load_model(tmp_path / "model.txt")


def test_a_missing_extra_is_named(tmp_path, monkeypatch):
    path = write_two_link_urdf(tmp_path)
    monkeypatch.setitem(sys.modules, "yourdfpy", None)  # import yourdfpy now raises ImportError
    with pytest.raises(InputError, match=r"pip install ucope\[urdf\]"):
        load_model(path)
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(InputError, match=r"pip install ucope\[mjcf\]"):
        load_model(write_two_body_mjcf(tmp_path / "mj"))


def test_broken_urdf_names_the_file(tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text("this is not XML")
    with pytest.raises(InputError, match=r"cannot read URDF file .*bad.urdf"):
        load_model(path)
    path.write_text('<robot name="x"></robot>')
    with pytest.raises(InputError, match=r"URDF file .*bad.urdf has no links"):
        load_model(path)


# ------------------------------------------------------------------------------------ partitions
@pytest.mark.parametrize(
    ("parts", "joints", "match"),
    [
        ([("cab", ["cabinet"], "none"), ("drw", ["drawer"], "none")], ["slide"], r"links \['handle'\] belong to no part"),
        ([("cab", ["cabinet", "handle"], "none"), ("drw", ["drawer"], "none")], ["slide"], r"joint 'handle_mount' joins link"),
        ([("cab", ["cabinet"], "none"), ("drw", ["drawer", "knob"], "none")], ["slide"], r"names link 'knob'"),
        ([("cab", ["cabinet", "drawer"], "none"), ("drw", ["drawer", "handle"], "none")], ["slide"], r"claimed by parts"),
        ([("drw", ["drawer", "handle"], "none"), ("cab", ["cabinet"], "none")], ["slide"], r"root link 'cabinet' must be in"),
        ([("cab", ["cabinet"], "none"), ("drw", "*", "none")], ["hinge"], r"category joint 'hinge' is not in the file"),
        ([("cab", ["cabinet"], "none"), ("drw", "*", "none")], ["handle_mount"], r"'handle_mount' is fixed"),
        ([("cab", ["cabinet"], "none"), ("drw", "*", "none")], [], r"2 parts need 1 category joints"),
    ],
)
def test_links_that_do_not_form_the_declared_parts_are_named(tmp_path, parts, joints, match):
    m = load_model(write_three_link_urdf(tmp_path))
    with pytest.raises(InputError, match=match):
        model_to_object(m, "c", "c/0", parts, [JointMapping(j, range=(0.0, 0.1)) for j in joints])


def test_sampled_range_and_held_values_outside_the_limits_are_named(tmp_path):
    m = load_model(write_two_link_urdf(tmp_path))
    with pytest.raises(InputError, match=r"joint 0 \('hinge'\): sampled range \[0, 2.5\] rad is outside"):
        model_to_object(m, "t", "t/0", TWO_PARTS, [JointMapping("hinge", range=(0.0, 2.5))])
    # sign and offset move the file's limits [0, 2] to category states [-2 + 1, 0 + 1] = [-1, 1]
    obj = model_to_object(m, "t", "t/0", TWO_PARTS, [JointMapping("hinge", sign=-1.0, offset=1.0, range=(-1.0, 1.0))])
    assert obj.limits.tolist() == [[-1.0, 1.0]]
    m3 = load_model(write_three_link_urdf(tmp_path / "c"))
    one = [("all", "*", "none")]
    with pytest.raises(InputError, match=r"held joint 'slide' value 0.5 is outside its limits \(0.0, 0.3\)"):
        model_to_object(m3, "c", "c/0", one, [], held={"slide": 0.5})
    with pytest.raises(InputError, match=r"held joint 'nope' is not in the file"):
        model_to_object(m3, "c", "c/0", one, [], held={"nope": 0.0})


# --------------------------------------------------------------------------- canonical round trip
@pytest.mark.parametrize(("sign", "offset", "scale"), [(1.0, 0.0, 1.0), (-1.0, 0.5, 1.0), (1.0, -0.3, 2.5)])
def test_canonical_frame_round_trip_against_the_file(tmp_path, sign, offset, scale):
    """At every category state q the object's parts are the file's links at file value
    ``sign * (q - offset)``, moved into the canonical frame (rotation and scale), up to the one shift that
    puts the object frame on the base part's box centre; each part fills its own box exactly."""
    m = load_model(write_two_link_urdf(tmp_path))
    lo, hi = sorted((sign * 0.0 + offset, sign * 2.0 + offset))
    obj = model_to_object(
        m, "t", "t/0", TWO_PARTS, [JointMapping("hinge", sign, offset, (lo, hi))], canonical_from_file=Z_UP, scale=scale
    )
    C = scale * Z_UP
    shift = None
    for q in np.linspace(lo, hi, 4):
        file_poses = m.link_poses({"hinge": sign * (q - offset)})
        poses = obj.object_from_part([q])
        for k, (part, link) in enumerate(zip(obj.parts, ["base_link", "lid_link"], strict=True)):
            src = m.links[link][0].vertices @ file_poses[link][:3, :3].T + file_poses[link][:3, 3]
            want = src @ C.T
            got = part.mesh.vertices @ poses[k, :3, :3].T + poses[k, :3, 3]
            shift = want[0] - got[0] if shift is None else shift
            np.testing.assert_allclose(got + shift, want, atol=1e-9)
            # in its own frame the part fills its box: bounds = -size/2 .. +size/2 on every axis
            np.testing.assert_allclose(part.mesh.bounds, [-part.size_m / 2, part.size_m / 2], atol=1e-12)
    np.testing.assert_allclose(obj.parts[0].size_m, scale * np.array([0.4, 0.1, 0.3]), atol=1e-6)


def test_mjcf_body_with_visual_geoms_leaves_out_its_collision_geoms(tmp_path):
    """MuJoCo marks visual geoms with contype = conaffinity = 0: a body that has them is those geoms
    only (its colliding boxes are its collision model); a body with colliding geoms only keeps them."""
    pytest.importorskip("mujoco")
    path = tmp_path / "vis.xml"
    path.write_text(
        """<mujoco><worldbody>
          <body name="a">
            <geom type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0"/>
            <geom type="box" size="0.3 0.3 0.3" group="3"/>
            <body name="b" pos="0 0 0.5"><joint name="j" type="hinge" axis="1 0 0" range="0 1"/>
              <geom type="box" size="0.05 0.05 0.05"/>
            </body>
          </body>
        </worldbody></mujoco>"""
    )
    m = load_model(path)
    assert len(m.links["a"]) == 1 and len(m.links["b"]) == 1
    np.testing.assert_allclose(m.links["a"][0].extents, [0.2, 0.2, 0.2], atol=1e-9)
    np.testing.assert_allclose(m.links["b"][0].extents, [0.1, 0.1, 0.1], atol=1e-9)
