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
