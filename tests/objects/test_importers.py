"""URDF, MJCF and mesh-file importers (ucope.objects.importers), on files the tests write themselves."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import trimesh
from own_objects_support import (
    write_base_mesh,
    write_cabinet_mjcf,
    write_grouped_arm_mjcf,
    write_mesh_folder,
    write_ros_package,
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
    with pytest.raises(InputError, match=r"URDF file .*bad.urdf is not well-formed XML: syntax error \(line 1, column 1\)"):
        load_model(path)
    path.write_text('<robot name="x"></robot>')
    with pytest.raises(InputError, match=r"URDF file .*bad.urdf has no links"):
        load_model(path)


TWO_LINKS = '<link name="a"/><link name="b"><visual><geometry><box size="1 1 1"/></geometry></visual></link>'


@pytest.mark.parametrize(
    ("body", "match"),
    [
        (TWO_LINKS + '<joint name="j" type="revolute"><child link="b"/></joint>', r"joint 'j': no <parent link=...>"),
        (
            TWO_LINKS + '<joint name="j" type="revolute"><parent link="a"/><child link="c"/></joint>',
            r"child link 'c' is not a link",
        ),
        (
            TWO_LINKS + '<joint name="j" type="hinge"><parent link="a"/><child link="b"/></joint>',
            r"joint 'j': type 'hinge' is not",
        ),
        (
            '<link name="a"><visual><origin xyz="0 0"/><geometry><box size="1 1 1"/></geometry></visual></link>',
            r"link 'a' visual 0: <origin xyz='0 0'> must be 3",
        ),
        ('<link name="a"><visual><geometry><mesh/></geometry></visual></link>', r"link 'a' visual 0: <mesh> has no filename"),
        ('<link name="a"><visual><geometry/></visual></link>', r"link 'a' visual 0: <geometry> must hold one box"),
        ("<link/>", r"link 0 has no name"),
        ('<link name="a"/><link name="a"/>', r"link names must be unique, repeated: \['a'\]"),
        ('<link name="a"></link><link name="b"', r"is not well-formed XML: .*\(line 1, column"),
    ],
)
def test_malformed_urdf_is_refused_naming_file_link_and_element_without_parser_noise(tmp_path, capfd, body, match):
    """yourdfpy's recovering parser printed stray lines and then raised AttributeError (or read a broken
    file on); the strict check before it names the file, the link or joint and the element."""
    path = tmp_path / "arm.urdf"
    path.write_text(f'<robot name="r">{body}</robot>')
    with pytest.raises(InputError, match=r"URDF file .*arm.urdf.*" + match):
        load_model(path)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_missing_urdf_mesh_names_the_urdf_and_the_link(tmp_path):
    path = write_two_link_urdf(tmp_path)
    (tmp_path / "toy_pkg" / "meshes" / "base.stl").unlink()
    with pytest.raises(
        InputError, match=r"URDF file .*two_link.urdf: link 'base_link': mesh file 'package://toy_pkg/.*not found"
    ):
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


# ------------------------------------------------------------------ files in asset-library layouts
def test_mjcf_with_textures_materials_and_physics_reads_its_visual_geometry(tmp_path):
    """Menagerie layout: the texture file is not there, the label mesh is flat (no convex hull), collision
    proxies in group 3 are larger than the meshes, sensors / actuators / keyframes name joints, and an
    element MuJoCo does not know is left out with a warning naming it."""
    pytest.importorskip("mujoco")
    path = write_cabinet_mjcf(tmp_path / "cabinet")
    with pytest.warns(UserWarning, match=r"cabinet.xml: left out .*: region"):
        m = load_model(path)
    assert set(m.links) == {"world", "cabinet", "door"} and m.links["world"] == []
    assert len(m.links["cabinet"]) == 2 and len(m.links["door"]) == 1  # the meshes, not the boxes and capsules
    body = trimesh.util.concatenate(m.links["cabinet"])
    np.testing.assert_allclose(body.bounds, [[-0.2, -0.201, -0.3], [0.2, 0.2, 0.3]], atol=1e-6)
    np.testing.assert_allclose(m.links["door"][0].extents, [0.4, 0.02, 0.6], atol=1e-6)
    j = m.joints["door_hinge"]
    assert j.type == "revolute" and j.limits == pytest.approx((-2.0, 0.0))
    np.testing.assert_allclose(j.origin[:3, 3], [-0.2, -0.2, 0.0])
    obj = model_to_object(
        m,
        "c",
        "c/0",
        [("body", ["cabinet"], "none"), ("door", ["door"], "none")],
        [JointMapping("door_hinge", sign=-1.0, range=(0.0, 1.5))],
        canonical_from_file=Z_UP,
    )
    np.testing.assert_allclose(obj.parts[1].size_m, [0.4, 0.6, 0.02], atol=1e-6)


def test_mjcf_with_visual_geoms_in_their_own_group(tmp_path):
    """Visual geoms in group 1 (colliding by MuJoCo's defaults), collision capsules in group 3 with the
    inertia taken from group 3 only and a mass-0 inertial (MuJoCo's physics refuses both): the geometry is
    read, group 3 is left out because the file has geoms in the groups MuJoCo shows; the collision-only
    body in group 0 stays until the spec excludes it by name or by group."""
    pytest.importorskip("mujoco")
    path = write_grouped_arm_mjcf(tmp_path)
    m = load_model(path)
    assert len(m.links["base"]) == 1 and len(m.links["link2"]) == 1 and len(m.links["link2_proxy"]) == 1
    np.testing.assert_allclose(m.links["base"][0].extents[2], 0.1, atol=1e-6)  # the visual cylinder, not the capsule
    np.testing.assert_allclose(m.links["link2"][0].extents, [0.1, 0.08, 0.196], atol=1e-6)
    parts = [("base", ["base"], "none"), ("link1", ["link1"], "none"), ("link2", "*", "none")]
    joints = [JointMapping("joint1", range=(-1.0, 1.0)), JointMapping("joint2", range=(-1.0, 1.0))]
    with_proxy = model_to_object(m, "a", "a/0", parts, joints)
    assert with_proxy.parts[2].size_m[2] == pytest.approx(0.231, abs=1e-3)  # the proxy's capsule reaches beyond
    for kw in ({"exclude_links": ["link2_proxy"]}, {"exclude_geom_groups": [0, 3]}):
        clean = model_to_object(load_model(path, **kw), "a", "a/0", parts, joints)
        np.testing.assert_allclose(clean.parts[2].size_m, [0.1, 0.08, 0.196], atol=1e-6)
    with pytest.raises(InputError, match=r"links to exclude \['nope'\] are not in the file"):
        load_model(path, exclude_links=["nope"])
    every = load_model(path, exclude_geom_groups=[])
    assert len(every.links["base"]) == 2  # nothing left out: the collision capsule too


def test_urdf_in_a_ros_package_finds_its_package_meshes_and_leaves_out_a_collision_only_link(tmp_path):
    path = write_ros_package(tmp_path)
    m = load_model(path)  # package://my_arm_description/... from .../my_arm_description/urdf/: no search path needed
    assert len(m.links["base_link"]) == 1 and m.links["tool_collision"] == []
    np.testing.assert_allclose(m.links["base_link"][0].bounds, [[-0.1, -0.1, 0.0], [0.1, 0.1, 0.1]], atol=1e-6)
    np.testing.assert_allclose(m.links["arm_link"][0].extents, [0.06, 0.06, 0.3], atol=1e-6)
    # inside the package folder the reference resolves; with the roots elsewhere it is refused, not read
    load_model(path, roots=[tmp_path])
    with pytest.raises(InputError, match=r"lies outside the spec's folders"):
        load_model(path, roots=[tmp_path / "my_arm_description" / "urdf"])


def test_a_file_without_visual_geometry_is_read_from_its_collision_geometry(tmp_path):
    path = tmp_path / "col.urdf"
    path.write_text(
        '<robot name="c"><link name="a"><collision><geometry><box size="0.2 0.3 0.4"/></geometry></collision></link></robot>'
    )
    np.testing.assert_allclose(load_model(path).links["a"][0].extents, [0.2, 0.3, 0.4], atol=1e-9)


def test_mjcf_meshes_match_mujocos_own_geometry(tmp_path):
    """Meshes are read with trimesh (a placeholder stands in for the compile): scaled, placed by the geom
    and a mesh default class exactly as MuJoCo places its own copy (float32 there)."""
    mujoco = pytest.importorskip("mujoco")
    from scipy.spatial.transform import Rotation

    (tmp_path / "m").mkdir()
    part = trimesh.creation.box(extents=[0.3, 0.1, 0.05])
    part.apply_transform(trimesh.transformations.euler_matrix(0.2, 0.4, 0.6))
    part.apply_translation([0.2, -0.1, 0.4])
    part.export(tmp_path / "m" / "part.stl")
    for extra in ('scale="2 1.5 0.5"', 'class="big"', 'refpos="0.1 0.2 0.3" refquat="0.9 0.1 0.2 0.3"'):
        path = tmp_path / "t.xml"
        path.write_text(
            f"""<mujoco><compiler angle="degree" meshdir="m"/>
            <default><default class="big"><mesh scale="3 3 3"/></default></default>
            <asset><mesh name="p" file="part.stl" {extra}/></asset>
            <worldbody><body name="a" pos="0 0 1" euler="5 6 7"><joint name="j" type="hinge" axis="0 1 0"/>
            <geom type="mesh" mesh="p" pos="0.1 0.2 0.3" euler="40 50 60"/></body></worldbody></mujoco>"""
        )
        ours = load_model(path).links["a"][0]
        mj = mujoco.MjModel.from_xml_path(str(path))
        w, x, y, z = mj.geom_quat[0]
        theirs = np.asarray(mj.mesh_vert, np.float64) @ Rotation.from_quat([x, y, z, w]).as_matrix().T + mj.geom_pos[0]
        np.testing.assert_allclose(np.sort(ours.vertices, 0)[[0, -1]], np.sort(theirs, 0)[[0, -1]], atol=1e-6)
        from scipy.spatial import cKDTree

        assert cKDTree(theirs).query(ours.vertices)[0].max() < 1e-6, extra


def test_mjcf_msh_meshes_and_unknown_attributes(tmp_path):
    """MuJoCo's binary .msh format is read; an attribute this MuJoCo does not know is left out with a warning."""
    pytest.importorskip("mujoco")
    box = trimesh.creation.box(extents=[0.1, 0.2, 0.3])
    v, f = np.asarray(box.vertices, "<f4"), np.asarray(box.faces, "<i4")
    header = np.array([len(v), 0, 0, len(f)], "<i4")
    (tmp_path / "b.msh").write_bytes(header.tobytes() + v.tobytes() + f.tobytes())
    path = tmp_path / "m.xml"
    path.write_text(
        '<mujoco><asset><mesh name="b" file="b.msh"/></asset><worldbody><body name="a">'
        '<geom type="mesh" mesh="b" shinyness="2"/></body></worldbody></mujoco>'
    )
    with pytest.warns(UserWarning, match=r"left out .*geom/@shinyness"):
        m = load_model(path)
    np.testing.assert_allclose(m.links["a"][0].extents, [0.1, 0.2, 0.3], atol=1e-6)
    (tmp_path / "b.msh").write_bytes(header.tobytes() + v.tobytes())
    with pytest.warns(UserWarning), pytest.raises(InputError, match=r"cannot read mesh file .*b.msh \(ValueError: its size does"):
        load_model(path)


def test_mjcf_includes_are_inlined_and_kept_inside_the_roots(tmp_path):
    pytest.importorskip("mujoco")
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "body.xml").write_text(
        '<mujocoinclude><body name="b"><geom type="box" size="0.1 0.2 0.3"/></body></mujocoinclude>'
    )
    path = tmp_path / "scene.xml"
    path.write_text('<mujoco><worldbody><include file="parts/body.xml"/></worldbody></mujoco>')
    np.testing.assert_allclose(load_model(path, roots=[tmp_path]).links["b"][0].extents, [0.2, 0.4, 0.6], atol=1e-9)
    (tmp_path / "sub").mkdir()
    inner = tmp_path / "sub" / "scene.xml"
    inner.write_text('<mujoco><worldbody><include file="../parts/body.xml"/></worldbody></mujoco>')
    with pytest.raises(InputError, match=r"scene.xml: <include file='../parts/body.xml'>: .*outside the spec's folders"):
        load_model(inner, roots=[tmp_path / "sub"])
    (tmp_path / "loop.xml").write_text('<mujoco><worldbody><include file="loop.xml"/></worldbody></mujoco>')
    with pytest.raises(InputError, match=r"includes nest deeper than 16 files \(a cycle\?\)"):
        load_model(tmp_path / "loop.xml")


def test_mesh_references_stay_inside_the_roots(tmp_path):
    """With roots (a spec's base_dir and search path), '..' that leaves them, absolute and file:// mesh
    references are refused; without roots (the Python API on a file of one's own) they are read."""
    secret = write_base_mesh(tmp_path / "elsewhere" / "secret.stl")
    (tmp_path / "spec").mkdir()
    for ref in ("../elsewhere/secret.stl", str(secret), f"file://{secret}"):
        path = tmp_path / "spec" / "escape.urdf"
        path.write_text(
            f'<robot name="e"><link name="a"><visual><geometry><mesh filename="{ref}"/></geometry></visual></link></robot>'
        )
        assert len(load_model(path).links["a"]) == 1
        with pytest.raises(InputError, match=r"escape.urdf: link 'a': mesh file .*(outside the spec's folders|absolute)"):
            load_model(path, roots=[tmp_path / "spec"])


def test_mesh_size_limits_name_the_file(tmp_path):
    from ucope.objects.importers import MeshLimits

    path = write_two_link_urdf(tmp_path)
    size = (tmp_path / "toy_pkg" / "meshes" / "base.stl").stat().st_size
    with pytest.raises(
        InputError, match=r"base.stl is 0.0 MiB, above the limit of 0.0 MiB \(raise it with the spec's mesh_limits"
    ):
        load_model(path, limits=MeshLimits(max_file_bytes=size - 1))
    with pytest.raises(InputError, match=r"base.stl has 36 vertices, above the limit of 10 \(raise it .*max_vertices\)"):
        load_model(path, limits=MeshLimits(max_vertices=10))
    with pytest.raises(InputError, match=r"has 12 faces, above the limit of 11"):
        load_model(path, limits=MeshLimits(max_faces=11))
    assert len(load_model(path, limits=MeshLimits(max_file_bytes=size)).links["base_link"]) == 1
    # a sparse file of 2 GiB is refused by its size on disk before anything reads it
    big = tmp_path / "toy_pkg" / "meshes" / "base.stl"
    with open(big, "r+b") as f:
        f.truncate(2 * 2**30)
    with pytest.raises(InputError, match=r"base.stl is 2048.0 MiB, above the limit of 256.0 MiB"):
        load_model(path)
