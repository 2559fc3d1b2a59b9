"""Files for the bring-your-own-objects tests, written by the tests themselves (URDF, MJCF, meshes, specs).

Every object is z up in its file (the URDF / MJCF convention), in metres:

* ``two_link.urdf``: a 0.4 x 0.3 x 0.1 base (a mesh, ``package://toy_pkg/meshes/base.stl``) and a
  0.4 x 0.3 x 0.02 lid (a box) on a revolute hinge along x at the base's back top edge (limits 0..2 rad).
* ``three_link.urdf``: a 0.5 x 0.4 x 0.3 cabinet, a 0.4 x 0.35 x 0.2 drawer on a prismatic joint along -y
  (0..0.3 m) and a handle fixed to the drawer (it merges into the drawer part).
* ``two_body.xml``: the two-link object in MJCF (a hinge with its range in degrees, the base a mesh).
* ``meshes/``: three rigid boxes as .obj, .stl and .ply.
"""

from __future__ import annotations

import json
from pathlib import Path

import trimesh

TWO_LINK_URDF = """<?xml version="1.0"?>
<robot name="toy_box">
  <link name="base_link">
    <visual><origin xyz="0 0 0.05"/><geometry><mesh filename="package://toy_pkg/meshes/base.stl"/></geometry></visual>
  </link>
  <link name="lid_link">
    <visual><origin xyz="0 0.15 0.01"/><geometry><box size="0.4 0.3 0.02"/></geometry></visual>
  </link>
  <joint name="hinge" type="{hinge_type}">
    <parent link="base_link"/><child link="lid_link"/>
    <origin xyz="0 -0.15 0.1"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="2.0" effort="1" velocity="1"/>
  </joint>
</robot>
"""

THREE_LINK_URDF = """<?xml version="1.0"?>
<robot name="toy_cabinet">
  <link name="cabinet">
    <visual><origin xyz="0 0 0.15"/><geometry><box size="0.5 0.4 0.3"/></geometry></visual>
  </link>
  <link name="drawer">
    <visual><geometry><box size="0.4 0.35 0.2"/></geometry></visual>
  </link>
  <link name="handle">
    <visual><geometry><cylinder radius="0.01" length="0.2"/></geometry></visual>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="cabinet"/><child link="drawer"/>
    <origin xyz="0 -0.03 0.15"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.3" effort="1" velocity="1"/>
  </joint>
  <joint name="handle_mount" type="fixed">
    <parent link="drawer"/><child link="handle"/>
    <origin xyz="0 -0.2 0" rpy="0 1.5707963 0"/>
  </joint>
</robot>
"""

TWO_BODY_MJCF = """<mujoco model="toy_box">
  <compiler angle="degree" meshdir="{meshdir}"/>
  <asset><mesh name="base_mesh" file="base.stl"/></asset>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body name="base" pos="0 0 0.05">
      <geom type="mesh" mesh="base_mesh"/>
      <body name="lid" pos="0 -0.15 0.05">
        <joint name="hinge" type="hinge" axis="1 0 0" range="0 115"/>
        <geom type="box" pos="0 0.15 0.01" size="0.2 0.15 0.01"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def write_base_mesh(path: Path) -> Path:
    """The two-link base, a 0.4 x 0.3 x 0.1 box centred on the origin, as a mesh file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=[0.4, 0.3, 0.1]).export(path)
    return path


def write_two_link_urdf(folder: Path, hinge_type: str = "revolute", mesh_outside: bool = False) -> Path:
    """``two_link.urdf`` in ``folder``; its base mesh in ``folder/toy_pkg/meshes`` (or, with
    ``mesh_outside``, in ``folder/../pkgs/toy_pkg/meshes``, found only through a search path)."""
    folder.mkdir(parents=True, exist_ok=True)
    root = folder.parent / "pkgs" if mesh_outside else folder
    write_base_mesh(root / "toy_pkg" / "meshes" / "base.stl")
    path = folder / "two_link.urdf"
    path.write_text(TWO_LINK_URDF.format(hinge_type=hinge_type))
    return path


def write_three_link_urdf(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "three_link.urdf"
    path.write_text(THREE_LINK_URDF)
    return path


def write_two_body_mjcf(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    write_base_mesh(folder / "assets" / "base.stl")
    path = folder / "two_body.xml"
    path.write_text(TWO_BODY_MJCF.format(meshdir="assets"))
    return path


def write_mesh_folder(folder: Path) -> Path:
    """Three boxes (0.1-0.2 m) as .obj, .stl and .ply in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, ext in (("a.obj", [0.1, 0.2, 0.1]), ("b.stl", [0.15, 0.2, 0.12]), ("c.ply", [0.12, 0.18, 0.2])):
        trimesh.creation.box(extents=ext).export(folder / name)
    return folder


def two_link_spec(urdf: Path, **overrides) -> dict:
    """A spec of the two-link URDF: parts base and lid, the hinge in degrees 0..100."""
    doc = {
        "ucope_category_spec": 1,
        "name": "toy_box",
        "description": "a box with a hinged lid (test)",
        "parts": [{"name": "base", "links": ["base_link"]}, {"name": "lid", "links": ["lid_link"]}],
        "joints": [{"joint": "hinge", "unit": "deg", "range": [0, 100]}],
        "instances": [{"file": str(urdf)}],
        "size_range_m": [0.1, 2.0],
        "camera": {"distance_range_m": [0.8, 1.2], "elevation_range_deg": [15, 50]},
    }
    doc.update(overrides)
    return doc


def write_spec(path: Path, doc: dict) -> Path:
    path.write_text(json.dumps(doc, indent=2))
    return path


# ----------------------------------------------------------------- files in asset-library layouts
# Small stand-ins for what public asset libraries ship (written here, a few hundred bytes each): MuJoCo
# Menagerie / robosuite style MJCF (textures and materials, visual and collision classes, sensors,
# actuators, keyframes), an MJCF whose visual geoms sit in their own group with the inertia taken from the
# collision group, and a ROS description package (package:// meshes, a collision-only link).

CABINET_MJCF = """<mujoco model="cabinet">
  <compiler angle="radian" meshdir="assets" texturedir="textures"/>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <asset>
    <texture name="wood" type="2d" file="wood.png"/>
    <material name="wood" texture="wood" rgba="1 1 1 1"/>
    <material name="metal" rgba="0.6 0.6 0.6 1"/>
    <mesh name="body" file="body.stl"/>
    <mesh file="door.obj" scale="1 1 1"/>
    <mesh name="label" file="label.stl"/>
  </asset>
  <default>
    <default class="visual"><geom type="mesh" contype="0" conaffinity="0" group="2" material="wood"/></default>
    <default class="collision"><geom group="3" material="metal"/><site size="0.01"/></default>
  </default>
  <worldbody>
    <light name="top" pos="0 0 2"/>
    <body name="cabinet" pos="0 0 0.3">
      <inertial pos="0 0 0" mass="5" diaginertia="0.1 0.1 0.1"/>
      <geom class="visual" mesh="body"/>
      <geom class="visual" mesh="label" pos="0 -0.201 0.1"/>
      <geom class="collision" type="box" size="0.3 0.25 0.35"/>
      <site name="handle_site" pos="0 -0.2 0"/>
      <body name="door" pos="-0.2 -0.2 0">
        <joint name="door_hinge" type="hinge" axis="0 0 1" range="-2 0"/>
        <geom class="visual" mesh="door"/>
        <geom class="collision" type="capsule" fromto="0 0 -0.3 0.4 0 0.3" size="0.05"/>
        <region name="shelf_zone" size="0.1"/>
      </body>
    </body>
  </worldbody>
  <actuator><position name="door_motor" joint="door_hinge" kp="10"/></actuator>
  <sensor><jointpos name="door_pos" joint="door_hinge"/></sensor>
  <keyframe><key name="open" qpos="-1"/></keyframe>
</mujoco>
"""

GROUPED_ARM_MJCF = """<mujoco model="grouped_arm">
  <compiler angle="degree" inertiagrouprange="3 3" meshdir="meshes"/>
  <asset><mesh name="link2_visual" file="link2.stl"/></asset>
  <default>
    <default class="visual"><geom group="1" type="mesh"/></default>
    <default class="collision"><geom group="3" type="capsule"/></default>
  </default>
  <worldbody>
    <body name="base">
      <geom class="visual" type="cylinder" size="0.08 0.05"/>
      <geom class="collision" size="0.1 0.06"/>
      <body name="link1" pos="0 0 0.05">
        <joint name="joint1" type="hinge" axis="0 0 1" range="-170 170"/>
        <geom class="visual" type="box" pos="0 0 0.1" size="0.05 0.05 0.1"/>
        <body name="link2" pos="0 0 0.2">
          <joint name="joint2" type="hinge" axis="0 1 0" range="-120 120"/>
          <inertial pos="0 0 0" mass="0" diaginertia="0 0 0"/>
          <geom class="visual" mesh="link2_visual"/>
          <body name="link2_proxy">
            <geom type="capsule" fromto="0 0 0.04 0 0 0.191" size="0.04"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

ROS_ARM_URDF = """<?xml version="1.0"?>
<robot name="my_arm">
  <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
  <link name="base_link">
    <visual><geometry><mesh filename="package://my_arm_description/meshes/visual/base.stl"/></geometry>
      <material name="grey"/></visual>
    <collision><geometry><mesh filename="package://my_arm_description/meshes/collision/base_col.stl"/></geometry></collision>
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  </link>
  <link name="arm_link">
    <visual><origin xyz="0 0 0.15"/><geometry><box size="0.06 0.06 0.3"/></geometry></visual>
    <collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.05" length="0.34"/></geometry></collision>
  </link>
  <link name="tool_collision">
    <collision><geometry><sphere radius="0.08"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="arm_link"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
  </joint>
  <joint name="tool_mount" type="fixed">
    <parent link="arm_link"/><child link="tool_collision"/><origin xyz="0 0 0.3"/>
  </joint>
  <gazebo reference="arm_link"><material>Gazebo/Grey</material></gazebo>
  <transmission name="t"><type>transmission_interface/SimpleTransmission</type></transmission>
</robot>
"""


def write_cabinet_mjcf(folder: Path) -> Path:
    """``cabinet/cabinet.xml`` (Menagerie layout, the texture file not shipped): a 0.4 x 0.4 x 0.6 body
    mesh, a flat label mesh on its front, a 0.4 x 0.02 x 0.6 door (OBJ) on a hinge about z; collision
    proxies larger than the meshes in group 3; a site, a light, sensors, an actuator, a keyframe and an
    element MuJoCo does not know (``<region>``)."""
    folder.mkdir(parents=True, exist_ok=True)
    assets = folder / "assets"
    assets.mkdir(exist_ok=True)
    trimesh.creation.box(extents=[0.4, 0.4, 0.6]).export(assets / "body.stl")
    door = trimesh.creation.box(extents=[0.4, 0.02, 0.6])
    door.apply_translation([0.2, 0.0, 0.0])
    door.export(assets / "door.obj")
    label = trimesh.Trimesh(vertices=[[-0.1, 0, 0], [0.1, 0, 0], [0.1, 0, 0.05], [-0.1, 0, 0.05]], faces=[[0, 1, 2], [0, 2, 3]])
    label.export(assets / "label.stl")  # flat: MuJoCo cannot take its convex hull
    path = folder / "cabinet.xml"
    path.write_text(CABINET_MJCF)
    return path


def write_grouped_arm_mjcf(folder: Path) -> Path:
    """``grouped_arm.xml``: visual geoms in group 1 (colliding, as MuJoCo's defaults make them), collision
    capsules in group 3 and ``inertiagrouprange="3 3"`` (the moving link 2 has no collision geom, and an
    inertial of mass 0: MuJoCo's physics refuses it); link 2 is a 0.1 x 0.08 x 0.196 mesh box standing on
    its joint, and a collision-only body ``link2_proxy`` (a capsule in group 0) reaches 0.231 m up."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "meshes").mkdir(exist_ok=True)
    box = trimesh.creation.box(extents=[0.1, 0.08, 0.196])
    box.apply_translation([0.0, 0.0, 0.098])
    box.export(folder / "meshes" / "link2.stl")
    path = folder / "grouped_arm.xml"
    path.write_text(GROUPED_ARM_MJCF)
    return path


def write_ros_package(folder: Path) -> Path:
    """``my_arm_description/urdf/my_arm.urdf`` in a ROS description package: ``package://`` meshes under
    ``meshes/visual`` (a 0.2 x 0.2 x 0.1 base) and ``meshes/collision`` (a larger hull), an arm link and a
    collision-only link ``tool_collision`` (a sphere); materials, a Gazebo tag and a transmission."""
    pkg = folder / "my_arm_description"
    for sub in ("urdf", "meshes/visual", "meshes/collision"):
        (pkg / sub).mkdir(parents=True, exist_ok=True)
    (pkg / "package.xml").write_text('<package format="2"><name>my_arm_description</name></package>\n')
    base = trimesh.creation.box(extents=[0.2, 0.2, 0.1])
    base.apply_translation([0.0, 0.0, 0.05])
    base.export(pkg / "meshes" / "visual" / "base.stl")
    trimesh.creation.box(extents=[0.3, 0.3, 0.2]).export(pkg / "meshes" / "collision" / "base_col.stl")
    path = pkg / "urdf" / "my_arm.urdf"
    path.write_text(ROS_ARM_URDF)
    return path


def write_door_pair(folder: Path) -> tuple[Path, Path]:
    """Two doors of one category in their own folders, both named ``door.urdf``: a frame and a 0.4 x 0.02
    x 0.6 leaf opening towards the front (file -y) by positive file values 0..2 rad: ``left/door.urdf``
    hinged on its left edge about -z, ``right/door.urdf`` on its right edge, so about +z."""
    paths = []
    for side, x, axis, leaf in (("left", -0.2, "0 0 -1", 0.2), ("right", 0.2, "0 0 1", -0.2)):
        (folder / side).mkdir(parents=True, exist_ok=True)
        text = f"""<?xml version="1.0"?>
<robot name="{side}_door">
  <link name="frame"><visual><origin xyz="0 0.05 0.3"/><geometry><box size="0.44 0.1 0.64"/></geometry></visual></link>
  <link name="leaf"><visual><origin xyz="{leaf} 0 0"/><geometry><box size="0.4 0.02 0.6"/></geometry></visual></link>
  <joint name="hinge" type="revolute">
    <parent link="frame"/><child link="leaf"/><origin xyz="{x} -0.01 0.3"/><axis xyz="{axis}"/>
    <limit lower="0" upper="2" effort="1" velocity="1"/>
  </joint>
</robot>
"""
        path = folder / side / "door.urdf"
        path.write_text(text)
        paths.append(path)
    return paths[0], paths[1]


def door_spec(base_dir: Path, **overrides) -> dict:
    """A spec of :func:`write_door_pair`'s two doors: frame and leaf, the hinge opening 0..90 degrees."""
    doc = {
        "ucope_category_spec": 1,
        "name": "door_pair",
        "parts": [{"name": "frame", "links": ["frame"]}, {"name": "leaf", "links": ["leaf"]}],
        "joints": [{"joint": "hinge", "unit": "deg", "range": [0, 90]}],
        "instances": [{"file": "left/door.urdf"}, {"file": "right/door.urdf"}],
        "size_range_m": [0.1, 2.0],
        "base_dir": str(base_dir),
    }
    doc.update(overrides)
    return doc
