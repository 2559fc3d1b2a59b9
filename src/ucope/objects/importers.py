"""Importers: URDF and MJCF articulated models and rigid mesh files, read into one source model.

A :class:`SourceModel` is a file's link tree as written: every link's geometry (triangle meshes in the
link frame, metres of the file) and every joint (type, parent and child link, placement, axis, limits).
:func:`load_model` reads one by the file's suffix:

* ``.urdf``: through ``yourdfpy`` (extra ``urdf``: ``pip install ucope[urdf]``); the visual geometry of
  each link (its collision geometry when it has no visual one). Meshes referenced as ``package://PKG/...``,
  ``file://...`` or relative paths are resolved against the URDF's folder, then every folder of the
  search path (``DIR/PKG/...`` and ``DIR/...`` for a package path).
* ``.xml`` / ``.mjcf``: through ``mujoco`` (extra ``mjcf``: ``pip install ucope[mjcf]``), from the compiled
  model (so MJCF angles in degrees are read in radians); bodies are links, the world body is link
  ``"world"``; plane and height-field geoms are skipped. A body that has visual-only geoms
  (``contype = conaffinity = 0``, MuJoCo's way to mark them) is its visual geoms only, its colliding
  geoms being its collision model (as a URDF link's visual geometry wins over its collision geometry).
* ``.obj``, ``.stl``, ``.ply``, ``.glb``, ``.gltf``, ``.off``, ``.dae``: one rigid link named ``"body"``.

Joint types are ``revolute`` (a URDF ``continuous`` joint is a revolute one without limits), ``prismatic``
and ``fixed``; ``floating``, ``planar`` and ``ball`` joints (an MJCF ``free`` or ``ball`` joint) are refused
with an :class:`~ucope.errors.InputError` naming the joint and the file.

A link's pose in its parent link's frame at file joint value ``q`` (radians / metres of the file) is::

    parent_from_child(q) = origin @ motion(axis, pivot, q - ref)

with ``origin``, ``axis`` and ``pivot`` in the child's frame as stored in :class:`SourceJoint` (URDF: the
joint origin, pivot 0, ref 0; MJCF: the body's placement, the joint's position and its ``ref``).

:func:`model_to_object` turns a source model into the library's
:class:`~ucope.objects.articulation.ArticulatedObject`: links grouped into K parts (the links of a part, and
the joints between them, held at given values, merge into one rigid part), the K-1 declared category joints
mapped to the category's state convention, the whole moved into the canonical frame.
"""

from __future__ import annotations

import math
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from ..errors import InputError
from ..geometry.transforms import axis_angle_transform, make_transform, translation_transform
from .articulation import ArticulatedObject, build_object, make_part

__all__ = [
    "MESH_SUFFIXES",
    "MODEL_SUFFIXES",
    "SourceJoint",
    "SourceModel",
    "JointMapping",
    "load_model",
    "load_urdf",
    "load_mjcf",
    "load_mesh_model",
    "load_mesh",
    "resolve_mesh_path",
    "model_to_object",
]

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf", ".off", ".dae")
"""Suffixes of mesh files read as one rigid link (through trimesh)."""

MODEL_SUFFIXES = (".urdf", ".xml", ".mjcf") + MESH_SUFFIXES
"""Every suffix :func:`load_model` reads."""

_SUPPORTED = ("revolute", "prismatic", "fixed")
_REFUSED = ("floating", "planar", "ball")


@dataclass(frozen=True, eq=False)
class SourceJoint:
    """One joint of a source file (see the module docstring for the pose formula).

    Attributes:
        name: the joint's name in the file.
        type: ``"revolute"``, ``"prismatic"`` or ``"fixed"``.
        parent, child: link names.
        origin: ``(4, 4)`` the child link's pose in the parent link's frame at ``q = ref``.
        axis: ``(3,)`` unit axis in the child link's frame.
        pivot: ``(3,)`` a point on the axis in the child link's frame, metres of the file.
        limits: ``(lower, upper)`` file values (radians / metres), ``None`` when unlimited.
        ref: the file value at which the child sits at ``origin``.
    """

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    pivot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    limits: tuple[float, float] | None = None
    ref: float = 0.0

    def motion(self, q: float) -> np.ndarray:
        """``(4, 4)`` the child's motion in its own frame at file value ``q``."""
        a = float(q) - self.ref
        if self.type == "revolute":
            return axis_angle_transform(self.axis, self.pivot, a)
        if self.type == "prismatic":
            return translation_transform(self.axis * a)
        return np.eye(4)


@dataclass(frozen=True, eq=False)
class SourceModel:
    """A file's link tree.

    Attributes:
        path: the file read.
        root: the root link's name.
        links: link name -> its meshes in the link frame (possibly empty: a link without geometry).
        joints: joint name -> :class:`SourceJoint`, one per link but the root.
    """

    path: Path
    root: str
    links: dict[str, list[trimesh.Trimesh]]
    joints: dict[str, SourceJoint]

    def joint_into(self, link: str) -> SourceJoint | None:
        """The joint whose child is ``link`` (``None`` for the root)."""
        for j in self.joints.values():
            if j.child == link:
                return j
        return None

    def link_poses(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """Every link's ``(4, 4)`` pose in the root link's frame with joint ``name`` at file value
        ``values[name]`` (a joint not named sits at its ``ref``)."""
        poses = {self.root: np.eye(4)}
        pending = list(self.joints.values())
        while pending:
            ready = [j for j in pending if j.parent in poses]
            if not ready:
                names = ", ".join(sorted(j.name for j in pending))
                raise InputError(f"{self.path}: joints {names} do not hang from the root link {self.root!r}")
            for j in ready:
                poses[j.child] = poses[j.parent] @ j.origin @ j.motion(values.get(j.name, j.ref))
                pending.remove(j)
        return poses


# ------------------------------------------------------------------------------------------ meshes
def resolve_mesh_path(ref: str, base_dir: str | os.PathLike, search_path: Sequence[str | os.PathLike] = ()) -> Path:
    """The file a mesh reference names.

    ``package://PKG/REST`` is looked up as ``DIR/PKG/REST`` and ``DIR/REST`` for ``DIR`` in
    ``base_dir`` and then the ``search_path``; ``file://PATH`` and absolute paths are taken as they are;
    a relative path is looked up under ``base_dir``, then the ``search_path``. Raises
    :class:`InputError` naming the reference and every place looked when no file is found."""
    base = Path(base_dir)
    dirs = [base, *[Path(d) for d in search_path]]
    if ref.startswith("package://"):
        rest = ref[len("package://") :]
        pkg, _, tail = rest.partition("/")
        candidates = [d / pkg / tail for d in dirs] + [d / tail for d in dirs]
        # a package folder's parent is often a level up from the model file
        candidates += [base.parent / pkg / tail]
    elif ref.startswith("file://"):
        candidates = [Path(ref[len("file://") :])]
    elif os.path.isabs(ref):
        candidates = [Path(ref)]
    else:
        candidates = [d / ref for d in dirs]
    for c in candidates:
        if c.is_file():
            return c
    looked = ", ".join(str(c) for c in dict.fromkeys(candidates))
    raise InputError(f"mesh file {ref!r} not found (looked at {looked}); give its folder in the spec's mesh_search_path")


def load_mesh(path: str | os.PathLike, element: str = "") -> trimesh.Trimesh:
    """One triangle mesh from ``path`` (a scene is merged into one mesh), vertices as in the file.

    Raises :class:`InputError` naming the file (and ``element``, the link or body it belongs to) when
    the file is missing, unreadable, has no triangles, or holds NaN / Inf vertices."""
    path = Path(path)
    what = f"{element}: " if element else ""
    if not path.is_file():
        raise InputError(f"{what}mesh file {path} does not exist")
    try:
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as e:  # trimesh raises many kinds on broken files
        raise InputError(f"{what}cannot read mesh file {path} ({type(e).__name__}: {e})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(getattr(mesh, "faces", ())) == 0:
        raise InputError(f"{what}mesh file {path} holds no triangles")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise InputError(f"{what}mesh file {path} has NaN or Inf vertices")
    f = np.asarray(mesh.faces, dtype=np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InputError(f"{what}mesh file {path} has faces that index missing vertices")
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def _transformed(mesh: trimesh.Trimesh, T: np.ndarray, scale=None) -> trimesh.Trimesh:
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if scale is not None:
        v = v * np.asarray(scale, dtype=np.float64).reshape(-1)
    return trimesh.Trimesh(vertices=v @ T[:3, :3].T + T[:3, 3], faces=np.asarray(mesh.faces), process=False)


# -------------------------------------------------------------------------------------------- URDF
def _import_extra(module: str, extra: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"reading this file needs {module}: pip install ucope[{extra}]") from None


def load_urdf(path: str | os.PathLike, search_path: Sequence[str | os.PathLike] = ()) -> SourceModel:
    """Read a URDF file (extra ``urdf``) into a :class:`SourceModel` (see the module docstring)."""
    yourdfpy = _import_extra("yourdfpy", "urdf")
    path = Path(path)
    if not path.is_file():
        raise InputError(f"URDF file {path} does not exist")
    try:
        urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False, load_collision_meshes=False)
    except Exception as e:
        raise InputError(f"cannot read URDF file {path} ({type(e).__name__}: {e})") from None
    robot = urdf.robot
    if not robot.links:
        raise InputError(f"URDF file {path} has no links")
    links: dict[str, list[trimesh.Trimesh]] = {}
    for link in robot.links:
        elements = link.visuals or link.collisions
        meshes = []
        for k, el in enumerate(elements):
            where = f"{path.name}: link {link.name!r} geometry {k}"
            T = np.eye(4) if el.origin is None else np.asarray(el.origin, dtype=np.float64)
            g = el.geometry
            if g.mesh is not None:
                file = resolve_mesh_path(g.mesh.filename, path.parent, search_path)
                meshes.append(_transformed(load_mesh(file, where), T, g.mesh.scale))
            elif g.box is not None:
                meshes.append(_transformed(trimesh.creation.box(extents=np.asarray(g.box.size, float)), T))
            elif g.cylinder is not None:
                cyl = trimesh.creation.cylinder(radius=float(g.cylinder.radius), height=float(g.cylinder.length), sections=24)
                meshes.append(_transformed(cyl, T))
            elif g.sphere is not None:
                meshes.append(_transformed(trimesh.creation.icosphere(subdivisions=2, radius=float(g.sphere.radius)), T))
        links[link.name] = meshes
    joints: dict[str, SourceJoint] = {}
    for j in robot.joints:
        jtype = "revolute" if j.type == "continuous" else j.type
        if jtype in _REFUSED or jtype not in _SUPPORTED:
            raise InputError(
                f"{path}: joint {j.name!r} is {j.type}; ucope takes revolute, continuous, prismatic and fixed joints"
            )
        limits = None
        if (
            j.type in ("revolute", "prismatic")
            and j.limit is not None
            and j.limit.lower is not None
            and j.limit.upper is not None
        ):
            limits = (float(j.limit.lower), float(j.limit.upper))
        axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=np.float64)
        if jtype != "fixed" and not np.linalg.norm(axis) > 1e-9:
            raise InputError(f"{path}: joint {j.name!r} has a zero axis")
        joints[j.name] = SourceJoint(
            name=j.name,
            type=jtype,
            parent=j.parent,
            child=j.child,
            origin=np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=np.float64),
            axis=axis / max(np.linalg.norm(axis), 1e-12),
            limits=limits,
        )
    children = {j.child for j in joints.values()}
    roots = [n for n in links if n not in children]
    if len(roots) != 1:
        raise InputError(f"{path}: the links must form one tree; links without a parent joint: {roots}")
    return SourceModel(path=path, root=roots[0], links=links, joints=joints)


# -------------------------------------------------------------------------------------------- MJCF
def _mjcf_assets(path: Path, search_path: Sequence[str | os.PathLike]) -> dict[str, bytes]:
    """Mesh files the MJCF names that are not where MuJoCo looks (next to the file, under ``meshdir``),
    found on the search path, as MuJoCo's asset dictionary; a mesh found nowhere raises InputError."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise InputError(f"cannot read MJCF file {path} ({e})") from None
    compiler = root.find("compiler")
    meshdir = (compiler.get("meshdir") or compiler.get("assetdir") or "") if compiler is not None else ""
    assets = {}
    for el in root.iter("mesh"):
        ref = el.get("file")
        if not ref:
            continue
        local = path.parent / meshdir / ref
        if local.is_file():
            continue
        try:
            found = resolve_mesh_path(ref, path.parent / meshdir, [path.parent, *search_path])
        except InputError as e:
            raise InputError(f"{path}: mesh {el.get('name') or ref!r}: {e}") from None
        data = found.read_bytes()
        assets[ref] = data
        assets[str(Path(meshdir) / ref)] = data
    return assets


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    w, x, y, z = (float(v) for v in q)
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def load_mjcf(path: str | os.PathLike, search_path: Sequence[str | os.PathLike] = ()) -> SourceModel:
    """Read an MJCF file (extra ``mjcf``) into a :class:`SourceModel` (see the module docstring)."""
    mujoco = _import_extra("mujoco", "mjcf")
    path = Path(path)
    if not path.is_file():
        raise InputError(f"MJCF file {path} does not exist")
    assets = _mjcf_assets(path, search_path)
    try:
        m = mujoco.MjModel.from_xml_path(str(path), assets) if assets else mujoco.MjModel.from_xml_path(str(path))
    except Exception as e:
        raise InputError(f"cannot read MJCF file {path} ({type(e).__name__}: {e})") from None
    names = ["world" if i == 0 else (m.body(i).name or f"body{i}") for i in range(m.nbody)]
    if len(set(names)) != len(names):
        raise InputError(f"{path}: body names must be unique (unnamed bodies are called body<i>), got {names}")
    G = mujoco.mjtGeom
    links: dict[str, list[trimesh.Trimesh]] = {n: [] for n in names}
    scenery = (int(G.mjGEOM_PLANE), int(G.mjGEOM_HFIELD), int(getattr(G, "mjGEOM_SDF", -1)))
    visual_only = (np.asarray(m.geom_contype) == 0) & (np.asarray(m.geom_conaffinity) == 0)
    bodies_with_visual = {int(m.geom_bodyid[g]) for g in range(m.ngeom) if visual_only[g] and int(m.geom_type[g]) not in scenery}
    for g in range(m.ngeom):
        t = int(m.geom_type[g])
        if int(m.geom_bodyid[g]) in bodies_with_visual and not visual_only[g]:
            continue  # a body with visual-only geoms: its colliding geoms are its collision model, not its surface
        body = names[int(m.geom_bodyid[g])]
        size = np.asarray(m.geom_size[g], dtype=np.float64)
        T = make_transform(_quat_matrix(m.geom_quat[g]), m.geom_pos[g])
        if t == G.mjGEOM_MESH:
            mid = int(m.geom_dataid[g])
            va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
            fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
            if fn == 0:
                raise InputError(f"{path}: body {body!r}: mesh {m.mesh(mid).name!r} holds no triangles")
            mesh = trimesh.Trimesh(vertices=m.mesh_vert[va : va + vn], faces=m.mesh_face[fa : fa + fn], process=False)
        elif t == G.mjGEOM_BOX:
            mesh = trimesh.creation.box(extents=2 * size)
        elif t == G.mjGEOM_SPHERE:
            mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
        elif t == G.mjGEOM_CYLINDER:
            mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
        elif t == G.mjGEOM_CAPSULE:
            mesh = trimesh.creation.capsule(radius=size[0], height=2 * size[1], count=[12, 12])
        elif t == G.mjGEOM_ELLIPSOID:
            mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
            mesh = trimesh.Trimesh(vertices=mesh.vertices * size, faces=mesh.faces, process=False)
        else:  # plane, height field, SDF: scenery, not the object
            continue
        links[body].append(_transformed(mesh, T))
    J = mujoco.mjtJoint
    by_body: dict[int, list[int]] = {}
    for j in range(m.njnt):
        by_body.setdefault(int(m.jnt_bodyid[j]), []).append(j)
    joints: dict[str, SourceJoint] = {}
    for b in range(1, m.nbody):
        parent = names[int(m.body_parentid[b])]
        origin = make_transform(_quat_matrix(m.body_quat[b]), m.body_pos[b])
        js = by_body.get(b, [])
        if len(js) > 1:
            jn = [m.joint(j).name or f"joint{j}" for j in js]
            raise InputError(f"{path}: body {names[b]!r} has {len(js)} joints {jn}; ucope takes one joint per body")
        if not js:
            joints[f"{names[b]}_weld"] = SourceJoint(
                name=f"{names[b]}_weld", type="fixed", parent=parent, child=names[b], origin=origin
            )
            continue
        j = js[0]
        jname = m.joint(j).name or f"joint{j}"
        t = int(m.jnt_type[j])
        if t in (int(J.mjJNT_FREE), int(J.mjJNT_BALL)):
            kind = "free (floating)" if t == int(J.mjJNT_FREE) else "ball"
            raise InputError(f"{path}: joint {jname!r} of body {names[b]!r} is {kind}; ucope takes hinge and slide joints")
        limited = bool(m.jnt_limited[j]) if hasattr(m, "jnt_limited") else True
        lo, hi = (float(v) for v in m.jnt_range[j])
        joints[jname] = SourceJoint(
            name=jname,
            type="revolute" if t == int(J.mjJNT_HINGE) else "prismatic",
            parent=parent,
            child=names[b],
            origin=origin,
            axis=np.asarray(m.jnt_axis[j], dtype=np.float64),
            pivot=np.asarray(m.jnt_pos[j], dtype=np.float64),
            limits=(lo, hi) if limited and hi > lo else None,
            ref=float(m.qpos0[int(m.jnt_qposadr[j])]),
        )
    return SourceModel(path=path, root="world", links=links, joints=joints)


# -------------------------------------------------------------------------------------- mesh files
def load_mesh_model(path: str | os.PathLike) -> SourceModel:
    """A mesh file as a one-link model (link ``"body"``, no joints)."""
    path = Path(path)
    return SourceModel(path=path, root="body", links={"body": [load_mesh(path, path.name)]}, joints={})


def load_model(path: str | os.PathLike, search_path: Sequence[str | os.PathLike] = ()) -> SourceModel:
    """Read a URDF, MJCF or mesh file by its suffix (:data:`MODEL_SUFFIXES`)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        return load_urdf(path, search_path)
    if suffix in (".xml", ".mjcf"):
        return load_mjcf(path, search_path)
    if suffix in MESH_SUFFIXES:
        return load_mesh_model(path)
    raise InputError(f"{path}: unknown model file type {suffix!r}; ucope reads {', '.join(MODEL_SUFFIXES)}")


# ------------------------------------------------------------------------------- model -> object
@dataclass(frozen=True)
class JointMapping:
    """How one of a file's joints becomes a category joint.

    The category's state (radians / metres of the canonical frame) of file value ``q_file`` is
    ``state = sign * q_file + offset`` for a revolute joint and ``state = sign * scale * q_file + offset``
    for a prismatic one (``scale``: the instance's scale to the canonical frame).

    Attributes:
        joint: the file's joint name.
        sign: ``+1`` or ``-1``.
        offset: radians (revolute) or metres (prismatic).
        range: ``(lower, upper)`` category states sampled (radians / metres); must lie within the
            file's limits mapped to category states.
    """

    joint: str
    sign: float = 1.0
    offset: float = 0.0
    range: tuple[float, float] = (0.0, 0.0)


def _partition(model: SourceModel, parts: Sequence[tuple[str, Sequence[str] | str]]) -> dict[str, int]:
    """link -> part index; ``"*"`` takes every link no other part names. Raises InputError on an unknown,
    doubly claimed or unclaimed link."""
    where = model.path.name
    owner: dict[str, int] = {}
    star = None
    for k, (pname, links) in enumerate(parts):
        if links == "*":
            if star is not None:
                raise InputError(f"{where}: only one part may take the remaining links ('*'), parts {star} and {k} do")
            star = k
            continue
        for ln in links:
            if ln not in model.links:
                raise InputError(
                    f"{where}: part {pname!r} names link {ln!r}, which the file lacks; its links: {sorted(model.links)}"
                )
            if ln in owner:
                raise InputError(f"{where}: link {ln!r} is claimed by parts {parts[owner[ln]][0]!r} and {pname!r}")
            owner[ln] = k
    rest = [ln for ln in model.links if ln not in owner]
    if model.root == "world" and "world" in rest and not model.links["world"]:
        owner["world"] = 0  # MJCF's world body joins the root part when no part names it and it carries no geometry
        rest.remove("world")
    if star is not None:
        owner.update({ln: star for ln in rest})
    elif rest:
        raise InputError(f"{where}: links {rest} belong to no part; name them in a part's links")
    return owner


def model_to_object(
    model: SourceModel,
    category: str,
    instance_id: str,
    parts: Sequence[tuple[str, Sequence[str] | str, str]],
    joints: Sequence[JointMapping],
    held: Mapping[str, float] | None = None,
    canonical_from_file: np.ndarray | None = None,
    scale: float = 1.0,
    shape_family: str = "",
) -> ArticulatedObject:
    """Build the library's object from a source model.

    Args:
        parts: the K parts in order, each ``(name, links, symmetry)`` (``links``: link names, or ``"*"``
            for every link no other part names). Part 0 holds the root link.
        joints: the K-1 category joints: joint ``i`` moves part ``i + 1`` (its child link is in part
            ``i + 1``, its parent link in a part of lower index).
        held: file values (radians / metres of the file) of joints inside parts; a joint not given is held
            at 0, or at the limit nearest 0 when 0 is outside its limits.
        canonical_from_file: ``(3, 3)`` rotation from the file's root frame to the canonical object frame
            (default identity); ``scale``: the uniform factor to canonical metres.

    Every part's frame has the canonical axes at category state 0, its origin at its amodal box centre.

    Raises:
        InputError naming the file and the element: links that do not form the parts, a category joint
        that is missing, fixed or inside a part, a sampled range outside the joint's limits, a held value
        outside its limits, a part without geometry.
    """
    where = str(model.path)
    held = dict(held or {})
    K = len(parts)
    if len(joints) != K - 1:
        raise InputError(f"{where}: {K} parts need {K - 1} category joints, got {len(joints)}")
    owner = _partition(model, [(n, links) for n, links, _ in parts])
    names = [jm.joint for jm in joints]
    for jm in joints:
        if jm.joint not in model.joints:
            raise InputError(f"{where}: category joint {jm.joint!r} is not in the file; its joints: {sorted(model.joints)}")
        if model.joints[jm.joint].type == "fixed":
            raise InputError(f"{where}: category joint {jm.joint!r} is fixed; a category joint is revolute or prismatic")
    for name in held:
        if name not in model.joints:
            raise InputError(f"{where}: held joint {name!r} is not in the file; its joints: {sorted(model.joints)}")
        if name in names:
            raise InputError(f"{where}: joint {name!r} is both a category joint and held")
    if owner[model.root] != 0:
        raise InputError(f"{where}: the root link {model.root!r} must be in the first part ({parts[0][0]!r})")
    values: dict[str, float] = {}
    for j in model.joints.values():
        pj, cj = owner[j.parent], owner[j.child]
        if j.name in names:
            i = names.index(j.name)
            if cj != i + 1:
                raise InputError(
                    f"{where}: category joint {i} ({j.name!r}) must move part {i + 1} ({parts[i + 1][0]!r}), "
                    f"but its child link {j.child!r} is in part {cj} ({parts[cj][0]!r})"
                )
            if pj >= cj:
                raise InputError(
                    f"{where}: joint {j.name!r} joins part {pj} ({parts[pj][0]!r}) to part {cj}; "
                    "list parts so that every joint's parent part comes before its child part"
                )
            continue
        if pj != cj:
            raise InputError(
                f"{where}: links do not form the declared parts: joint {j.name!r} joins link {j.parent!r} (part "
                f"{parts[pj][0]!r}) to link {j.child!r} (part {parts[cj][0]!r}) but is not a category joint"
            )
        v = float(held.get(j.name, 0.0 if j.limits is None else min(max(0.0, j.limits[0]), j.limits[1])))
        if j.limits is not None and not j.limits[0] - 1e-9 <= v <= j.limits[1] + 1e-9:
            raise InputError(f"{where}: held joint {j.name!r} value {v:.4g} is outside its limits {j.limits}")
        values[j.name] = v
    s = float(scale)
    ranges = []
    for i, jm in enumerate(joints):
        j = model.joints[jm.joint]
        k = s if j.type == "prismatic" else 1.0
        lo, hi = (float(v) for v in jm.range)
        if j.limits is not None:
            a, b = sorted((jm.sign * k * j.limits[0] + jm.offset, jm.sign * k * j.limits[1] + jm.offset))
            if lo < a - 1e-6 or hi > b + 1e-6:
                unit = "rad" if j.type == "revolute" else "m"
                raise InputError(
                    f"{where}: category joint {i} ({jm.joint!r}): sampled range [{lo:.4g}, {hi:.4g}] {unit} is outside the "
                    f"file's limits mapped to category states [{a:.4g}, {b:.4g}] {unit}"
                )
        values[jm.joint] = -jm.sign * jm.offset / k  # category state 0
        ranges.append((lo, hi))
    poses = model.link_poses(values)
    R = np.eye(3) if canonical_from_file is None else np.asarray(canonical_from_file, dtype=np.float64)
    C = make_transform(R * s)  # canonical_from_file with the scale (applied to points)
    built = []
    for k, (pname, _links, symmetry) in enumerate(parts):
        meshes = [_transformed(m, C @ poses[ln]) for ln, o in owner.items() if o == k for m in model.links[ln]]
        if not meshes:
            raise InputError(f"{where}: part {pname!r} has no geometry (its links: {[ln for ln, o in owner.items() if o == k]})")
        built.append(make_part(pname, meshes, symmetry=symmetry))
    jspecs = []
    for i, jm in enumerate(joints):
        j = model.joints[jm.joint]
        Tc = poses[j.child]
        pivot = C[:3, :3] @ (Tc[:3, :3] @ j.pivot + Tc[:3, 3])
        axis = R @ (Tc[:3, :3] @ j.axis) * math.copysign(1.0, jm.sign)
        lo, hi = ranges[i]
        jspecs.append(
            {
                "type": j.type,
                "parent": owner[j.parent],
                "child": i + 1,
                "pivot": pivot,
                "axis": axis,
                "limits": (lo, hi),
                "rest": min(max(0.0, lo), hi),
            }
        )
    return build_object(
        category, instance_id, built, jspecs, params={"source": str(model.path), "scale": s}, shape_family=shape_family
    )


def warn_size(obj: ArticulatedObject, source: str, size_range_m: tuple[float, float]) -> None:
    """Warn (naming ``source``) when ``obj``'s diagonal at its rest state is outside ``size_range_m``,
    saying so when the file looks like millimetres or centimetres."""
    lo, hi = obj.bounds(obj.rest_state)
    diag = float(np.linalg.norm(hi - lo))
    a, b = size_range_m
    if a <= diag <= b:
        return
    hint = ""
    for unit, f in (("millimetres", 1e-3), ("centimetres", 1e-2), ("inches", 0.0254)):
        if a <= diag * f <= b:
            hint = f"; it looks like {unit}: give the instance scale {f:g}"
            break
    warnings.warn(
        f"{source}: the object's diagonal is {diag:.4g} m, outside the spec's size_range_m [{a:g}, {b:g}]{hint}", stacklevel=2
    )
