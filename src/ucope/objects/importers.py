"""Importers: URDF and MJCF articulated models and rigid mesh files, read into one source model.

A :class:`SourceModel` is a file's link tree as written: every link's geometry (triangle meshes in the
link frame, metres of the file) and every joint (type, parent and child link, placement, axis, limits).
:func:`load_model` reads one by the file's suffix:

* ``.urdf``: through ``yourdfpy`` (extra ``urdf``: ``pip install ucope[urdf]``), after a strict XML parse
  and structure check of its own (a malformed file is refused naming the file, the link or joint and the
  element); the visual geometry of each link, as a viewer shows it (a link with collision geometry only is
  left out of the surface; a file without any visual geometry is read from its collision geometry). Meshes
  referenced as ``package://PKG/...``, ``file://...`` or relative paths are resolved against the URDF's
  folder, then every folder of the search path (``DIR/PKG/...`` and ``DIR/...`` for a package path).
* ``.xml`` / ``.mjcf``: through ``mujoco`` (extra ``mjcf``: ``pip install ucope[mjcf]``), for the geometry
  only (:func:`load_mjcf`: textures, materials and physics settings are left out, mesh files are read with
  trimesh), from the compiled model (so MJCF angles in degrees are read in radians); bodies are links, the
  world body is link ``"world"``; plane and height-field geoms are skipped. Geoms in the groups MuJoCo's
  viewer hides (3-5) are left out when the file has geoms in groups 0-2, and a body that has visual-only
  geoms (``contype = conaffinity = 0``, MuJoCo's way to mark them) is its visual geoms only, its colliding
  geoms being its collision model (as a URDF link's visual geometry wins over its collision geometry).
* ``.obj``, ``.stl``, ``.ply``, ``.glb``, ``.gltf``, ``.off``, ``.dae``: one rigid link named ``"body"``.

Every file read (model, include, mesh) is checked against :class:`MeshLimits` (size on disk, vertex and
face counts) and, when ``roots`` are given (category specs), must lie inside them.

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
import re
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
    "MJCF_HIDDEN_GROUPS",
    "MeshLimits",
    "DEFAULT_MESH_LIMITS",
    "is_inside",
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


# ----------------------------------------------------------------------------------- limits, paths
@dataclass(frozen=True)
class MeshLimits:
    """The largest files and meshes the importers read; a file beyond them raises :class:`InputError`
    naming it, before it is parsed where the size on disk tells (``max_file_bytes``), after it is read
    otherwise (vertex and face counts).

    Attributes:
        max_file_bytes: a mesh, URDF, MJCF or included file's size on disk.
        max_vertices, max_faces: one mesh's vertices and triangles.
    """

    max_file_bytes: int = 256 * 2**20
    max_vertices: int = 4_000_000
    max_faces: int = 8_000_000

    def check_file(self, path: Path, what: str) -> None:
        """Raise :class:`InputError` when ``path`` is larger than ``max_file_bytes`` (``what``: how to name it)."""
        try:
            size = path.stat().st_size
        except OSError as e:
            raise InputError(f"{what}: cannot read {path} ({e.strerror or e})") from None
        if size > self.max_file_bytes:
            raise InputError(
                f"{what}: {path} is {size / 2**20:.1f} MiB, above the limit of {self.max_file_bytes / 2**20:.1f} MiB "
                "(raise it with the spec's mesh_limits.max_file_mb)"
            )

    def check_counts(self, vertices: int, faces: int, path, what: str) -> None:
        """Raise :class:`InputError` when a mesh of ``path`` has more vertices or faces than allowed."""
        for n, most, name, field_ in (
            (vertices, self.max_vertices, "vertices", "max_vertices"),
            (faces, self.max_faces, "faces", "max_faces"),
        ):
            if n > most:
                raise InputError(
                    f"{what}: {path} has {n:,} {name}, above the limit of {most:,} (raise it with the spec's "
                    f"mesh_limits.{field_})"
                )


DEFAULT_MESH_LIMITS = MeshLimits()
"""The limits of :class:`MeshLimits` used when none are given."""


def _real(path: str | os.PathLike) -> str:
    return os.path.realpath(os.path.abspath(path))


def is_inside(path: str | os.PathLike, roots: Sequence[str | os.PathLike]) -> bool:
    """Whether ``path`` lies in one of the folders ``roots`` (both with symbolic links resolved)."""
    p = _real(path)
    for r in roots:
        r = _real(r)
        if p == r or p.startswith(r.rstrip(os.sep) + os.sep):
            return True
    return False


def _outside_message(ref: str, roots: Sequence[str | os.PathLike]) -> str:
    where = ", ".join(str(r) for r in roots)
    return (
        f"{ref!r} lies outside the spec's folders ({where}); a spec reads files only under base_dir and its "
        'mesh_search_path unless it sets "allow_outside_paths": true'
    )


# ------------------------------------------------------------------------------------------ meshes
def resolve_mesh_path(
    ref: str,
    base_dir: str | os.PathLike,
    search_path: Sequence[str | os.PathLike] = (),
    roots: Sequence[str | os.PathLike] | None = None,
) -> Path:
    """The file a mesh (or included file) reference names.

    ``package://PKG/REST`` is looked up as ``DIR/PKG/REST`` and ``DIR/REST`` for ``DIR`` in
    ``base_dir`` and then the ``search_path``, then in the ROS layout (up to four folders above ``base_dir``:
    ``UP/REST`` where ``UP`` is named ``PKG``, and ``UP/PKG/REST``); ``file://PATH`` and absolute
    paths are taken as they are; a relative path is looked up under ``base_dir``, then the ``search_path``.

    ``roots``: ``None`` reads any file; otherwise the folders the file must lie in (symbolic links resolved:
    a ``..`` that leaves them is refused), and ``file://`` and absolute references are refused.

    Raises :class:`InputError` naming the reference and every place looked when no file is found, or
    saying that the reference leaves the roots."""
    base = Path(base_dir)
    dirs = [base, *[Path(d) for d in search_path]]
    absolute = ref.startswith("file://") or os.path.isabs(ref)
    if absolute and roots is not None:
        raise InputError(f"mesh file {ref!r}: an absolute or file:// path; " + _outside_message(ref, roots))
    if ref.startswith("package://"):
        rest = ref[len("package://") :]
        pkg, _, tail = rest.partition("/")
        candidates = [d / pkg / tail for d in dirs] + [d / tail for d in dirs]
        # the ROS layout: the model file lies in its package's folder (named like the package, the file in
        # a subfolder such as urdf/), other packages beside it
        for up in list(base.absolute().parents)[:4]:
            candidates += [up / tail] if up.name == pkg else []
            candidates += [up / pkg / tail]
    elif ref.startswith("file://"):
        candidates = [Path(ref[len("file://") :])]
    elif absolute:
        candidates = [Path(ref)]
    else:
        candidates = [d / ref for d in dirs]
    outside = []
    for c in candidates:
        if c.is_file():
            if roots is None or is_inside(c, roots):
                return c
            outside.append(c)
    if outside:
        raise InputError(f"mesh file {_outside_message(ref, roots or ())} (found at {outside[0]})")
    looked = ", ".join(str(c) for c in dict.fromkeys(candidates))
    raise InputError(f"mesh file {ref!r} not found (looked at {looked}); give its folder in the spec's mesh_search_path")


def _read_msh(path: Path) -> trimesh.Trimesh:
    """MuJoCo's binary ``.msh`` mesh: int32 counts (vertices, normals, texture coordinates, faces), then
    float32 vertices, normals, texture coordinates and int32 faces (no faces: the vertices' convex hull)."""
    data = path.read_bytes()
    if len(data) < 16:
        raise ValueError("shorter than the 16-byte header")
    nv, nn, nt, nf = (int(x) for x in np.frombuffer(data[:16], dtype="<i4"))
    if min(nv, nn, nt, nf) < 0 or len(data) != 16 + 4 * (3 * nv + 3 * nn + 2 * nt + 3 * nf):
        raise ValueError(f"its size does not match its header ({nv} vertices, {nf} faces)")
    v = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=16).reshape(nv, 3).astype(np.float64)
    if nf == 0:
        return trimesh.convex.convex_hull(v)
    f = np.frombuffer(data, dtype="<i4", count=3 * nf, offset=16 + 4 * (3 * nv + 3 * nn + 2 * nt)).reshape(nf, 3)
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def load_mesh(path: str | os.PathLike, element: str = "", limits: MeshLimits | None = None) -> trimesh.Trimesh:
    """One triangle mesh from ``path`` (a scene is merged into one mesh; materials and textures are not
    read), vertices as in the file.

    Raises :class:`InputError` naming the file (and ``element``, the link or body it belongs to) when
    the file is missing, larger than ``limits`` (:class:`MeshLimits`, default :data:`DEFAULT_MESH_LIMITS`),
    unreadable, has no triangles, or holds NaN / Inf vertices."""
    path = Path(path)
    limits = limits or DEFAULT_MESH_LIMITS
    what = f"{element}: " if element else ""
    if not path.is_file():
        raise InputError(f"{what}mesh file {path} does not exist")
    limits.check_file(path, f"{element or path.name}: mesh file")
    try:
        if path.suffix.lower() == ".msh":
            mesh = _read_msh(path)
        else:
            mesh = trimesh.load(str(path), force="mesh", process=False, skip_materials=True)
    except Exception as e:  # trimesh raises many kinds on broken files
        raise InputError(f"{what}cannot read mesh file {path} ({type(e).__name__}: {e})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(getattr(mesh, "faces", ())) == 0:
        raise InputError(f"{what}mesh file {path} holds no triangles")
    limits.check_counts(len(mesh.vertices), len(mesh.faces), path, f"{element or path.name}: mesh file")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise InputError(f"{what}mesh file {path} has NaN or Inf vertices")
    f = np.asarray(mesh.faces, dtype=np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InputError(f"{what}mesh file {path} has faces that index missing vertices")
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def _transformed(mesh: trimesh.Trimesh, T: np.ndarray, scale=None) -> trimesh.Trimesh:
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    if scale is not None:
        s = np.asarray(scale, dtype=np.float64).reshape(-1)
        v = v * s
        if np.prod(np.broadcast_to(s, 3)) < 0:  # a mirroring scale: keep the faces' winding outward
            f = f[:, ::-1]
    return trimesh.Trimesh(vertices=v @ T[:3, :3].T + T[:3, 3], faces=f, process=False)


def _parse_xml(path: Path, kind: str, limits: MeshLimits) -> ET.Element:
    """The root element of an XML file, refusing a malformed one with the parser's line and column."""
    limits.check_file(path, f"{kind} file")
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as e:
        line, col = getattr(e, "position", (0, 0))
        msg = str(e).split(":")[0]
        raise InputError(f"{kind} file {path} is not well-formed XML: {msg} (line {line}, column {col + 1})") from None
    except OSError as e:
        raise InputError(f"cannot read {kind} file {path} ({e.strerror or e})") from None


# -------------------------------------------------------------------------------------------- URDF
def _import_extra(module: str, extra: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"reading this file needs {module}: pip install ucope[{extra}]") from None


_URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def _numbers(el: ET.Element, attr: str, n: int, where: str, default: str | None = None) -> None:
    """Check that attribute ``attr`` of ``el`` holds ``n`` finite numbers (``default`` when absent)."""
    text = el.get(attr, default)
    if text is None:
        raise InputError(f"{where}: <{el.tag}> has no {attr!r}")
    try:
        vals = [float(x) for x in text.split()]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{where}: <{el.tag} {attr}={text!r}> must be {n} finite number(s)")


def _check_urdf(path: Path, root: ET.Element) -> None:
    """The structure yourdfpy relies on, checked with errors naming the file, the link or joint and the
    element (a malformed file would otherwise give parser noise and an AttributeError)."""
    if root.tag != "robot":
        raise InputError(f"URDF file {path}: the root element is <{root.tag}>, not <robot>")
    names = []
    for i, link in enumerate(root.findall("link")):
        name = link.get("name")
        if not name:
            raise InputError(f"URDF file {path}: link {i} has no name")
        names.append(name)
        for kind in ("visual", "collision"):
            for k, el in enumerate(link.findall(kind)):
                where = f"URDF file {path}: link {name!r} {kind} {k}"
                origin = el.find("origin")
                if origin is not None:
                    _numbers(origin, "xyz", 3, where, "0 0 0")
                    _numbers(origin, "rpy", 3, where, "0 0 0")
                geo = el.find("geometry")
                shapes = [] if geo is None else [g for g in geo if g.tag in ("box", "cylinder", "sphere", "mesh", "capsule")]
                if len(shapes) != 1:
                    raise InputError(f"{where}: <geometry> must hold one box, cylinder, sphere or mesh")
                g = shapes[0]
                if g.tag == "box":
                    _numbers(g, "size", 3, where)
                elif g.tag in ("cylinder", "capsule"):
                    _numbers(g, "radius", 1, where)
                    _numbers(g, "length", 1, where)
                elif g.tag == "sphere":
                    _numbers(g, "radius", 1, where)
                else:
                    if not g.get("filename"):
                        raise InputError(f"{where}: <mesh> has no filename")
                    if g.get("scale") is not None and len(g.get("scale", "").split()) != 1:
                        _numbers(g, "scale", 3, where)
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"URDF file {path}: link names must be unique, repeated: {dup}")
    known = set(names)
    jnames = []
    for i, j in enumerate(root.findall("joint")):
        name = j.get("name")
        if not name:
            raise InputError(f"URDF file {path}: joint {i} has no name")
        jnames.append(name)
        where = f"URDF file {path}: joint {name!r}"
        if j.get("type") not in _URDF_JOINT_TYPES:
            raise InputError(f"{where}: type {j.get('type')!r} is not one of {', '.join(_URDF_JOINT_TYPES)}")
        for end in ("parent", "child"):
            el = j.find(end)
            if el is None or not el.get("link"):
                raise InputError(f"{where}: no <{end} link=...>")
            if el.get("link") not in known:
                raise InputError(f"{where}: {end} link {el.get('link')!r} is not a link of the file")
        origin = j.find("origin")
        if origin is not None:
            _numbers(origin, "xyz", 3, where, "0 0 0")
            _numbers(origin, "rpy", 3, where, "0 0 0")
        if j.find("axis") is not None:
            _numbers(j.find("axis"), "xyz", 3, where, "1 0 0")
        lim = j.find("limit")
        if lim is not None:
            for a in ("lower", "upper"):
                if lim.get(a) is not None:
                    _numbers(lim, a, 1, where)
    dup = sorted({n for n in jnames if jnames.count(n) > 1})
    if dup:
        raise InputError(f"URDF file {path}: joint names must be unique, repeated: {dup}")


def load_urdf(
    path: str | os.PathLike,
    search_path: Sequence[str | os.PathLike] = (),
    roots: Sequence[str | os.PathLike] | None = None,
    limits: MeshLimits | None = None,
) -> SourceModel:
    """Read a URDF file (extra ``urdf``) into a :class:`SourceModel` (see the module docstring).

    ``roots`` and ``limits``: as for :func:`load_model`. Raises :class:`InputError` naming the file (and
    the link or joint) on malformed XML, a missing or broken element, a mesh that is not found or too large."""
    yourdfpy = _import_extra("yourdfpy", "urdf")
    path = Path(path)
    limits = limits or DEFAULT_MESH_LIMITS
    if not path.is_file():
        raise InputError(f"URDF file {path} does not exist")
    _check_urdf(path, _parse_xml(path, "URDF", limits))
    import logging

    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # its messages repeat what the checks above say, or are about meshes it does not read here
    try:
        urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False, load_collision_meshes=False)
    except Exception as e:
        raise InputError(f"cannot read URDF file {path} ({type(e).__name__}: {e})") from None
    finally:
        log.setLevel(level)
    robot = urdf.robot
    if not robot.links:
        raise InputError(f"URDF file {path} has no links")
    links: dict[str, list[trimesh.Trimesh]] = {}
    has_visual = any(link.visuals for link in robot.links)
    for link in robot.links:
        elements = link.visuals if has_visual else link.collisions  # what a viewer shows; collisions for a file without visuals
        meshes = []
        for k, el in enumerate(elements):
            where = f"{path.name}: link {link.name!r} geometry {k}"
            T = np.eye(4) if el.origin is None else np.asarray(el.origin, dtype=np.float64)
            g = el.geometry
            if g.mesh is not None:
                try:
                    file = resolve_mesh_path(g.mesh.filename, path.parent, search_path, roots)
                except InputError as e:
                    raise InputError(f"URDF file {path}: link {link.name!r}: {e}") from None
                meshes.append(_transformed(load_mesh(file, where, limits), T, g.mesh.scale))
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
        limits_ = None
        if (
            j.type in ("revolute", "prismatic")
            and j.limit is not None
            and j.limit.lower is not None
            and j.limit.upper is not None
        ):
            limits_ = (float(j.limit.lower), float(j.limit.upper))
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
            limits=limits_,
        )
    children = {j.child for j in joints.values()}
    roots_ = [n for n in links if n not in children]
    if len(roots_) != 1:
        raise InputError(f"{path}: the links must form one tree; links without a parent joint: {roots_}")
    return SourceModel(path=path, root=roots_[0], links=links, joints=joints)


# -------------------------------------------------------------------------------------------- MJCF
_MJCF_TOP_KEPT = ("compiler", "default", "asset", "worldbody")
_MJCF_TOP_KNOWN = {
    "option",
    "size",
    "visual",
    "statistic",
    "actuator",
    "sensor",
    "tendon",
    "equality",
    "contact",
    "keyframe",
    "custom",
    "extension",
    "deformable",
}
_MJCF_BODY_KEPT = ("body", "geom", "joint", "freejoint", "frame", "replicate")
_MJCF_BODY_KNOWN = {"site", "camera", "light", "plugin", "inertial", "skin"}  # left out without a word: no geometry
_MJCF_DEFAULT_KEPT = ("default", "geom", "joint", "mesh")
_MJCF_INCLUDE_DEPTH = 16
_PLACEHOLDER = trimesh.creation.box(extents=[0.1, 0.2, 0.3])  # centred, principal axes x < y < z: MuJoCo leaves its frame as is
_PLACEHOLDER_STL = None


def _placeholder_stl() -> bytes:
    global _PLACEHOLDER_STL
    if _PLACEHOLDER_STL is None:
        _PLACEHOLDER_STL = _PLACEHOLDER.export(file_type="stl")
    return _PLACEHOLDER_STL


@dataclass
class _MjcfDocument:
    """An MJCF file made ready for a geometry-only compile (see :func:`load_mjcf`)."""

    root: ET.Element
    assets: dict[str, bytes] = field(default_factory=dict)
    meshes: dict[str, tuple[Path, np.ndarray]] = field(default_factory=dict)  # mesh name -> its file, its scale
    dropped: set[str] = field(default_factory=set)


def _inline_includes(el: ET.Element, path: Path, here: Path, roots, limits: MeshLimits, depth: int) -> None:
    """Replace every ``<include file=...>`` under ``el`` by the included file's elements (recursively).
    A file is looked up next to the main file (MuJoCo's rule), then next to the including file."""
    i = 0
    while i < len(el):
        child = el[i]
        if child.tag != "include":
            _inline_includes(child, path, here, roots, limits, depth)
            i += 1
            continue
        ref = child.get("file") or ""
        if depth >= _MJCF_INCLUDE_DEPTH:
            raise InputError(f"MJCF file {path}: includes nest deeper than {_MJCF_INCLUDE_DEPTH} files (a cycle?) at {ref!r}")
        try:
            found = resolve_mesh_path(ref, path.parent, [here], roots)
        except InputError as e:
            raise InputError(f"MJCF file {path}: <include file={ref!r}>: {str(e).replace('mesh file ', 'file ')}") from None
        sub = _parse_xml(found, "MJCF", limits)
        _inline_includes(sub, path, found.parent, roots, limits, depth + 1)
        el.remove(child)
        for k, new in enumerate(list(sub)):
            el.insert(i + k, new)
        i += len(sub)


def _defaults(root: ET.Element) -> dict[str, tuple[str | None, ET.Element]]:
    """Default class name -> (its parent class, its element); the top ``<default>`` is class ``"main"``."""
    out: dict[str, tuple[str | None, ET.Element]] = {}

    def walk(d: ET.Element, parent: str | None) -> None:
        name = d.get("class", "main" if parent is None else None)
        if name is None:
            return
        out[name] = (parent, d)
        for c in d.findall("default"):
            walk(c, name)

    for d in root.findall("default"):
        walk(d, None)
    return out


def _default_attr(defaults, cls: str | None, tag: str, attr: str) -> str | None:
    """``attr`` of element ``tag`` as default class ``cls`` (and its ancestors) sets it."""
    cls = cls or "main"
    while cls is not None and cls in defaults:
        parent, d = defaults[cls]
        el = d.find(tag)
        if el is not None and el.get(attr) is not None:
            return el.get(attr)
        cls = parent
    return None


def _clean_bodies(el: ET.Element, dropped: set[str]) -> None:
    """Keep what makes the kinematic tree and its geometry (height-field and SDF geoms are scenery whose
    assets are left out); every body gets a unit inertia."""
    for child in list(el):
        if child.tag == "geom" and (child.get("hfield") or child.get("type") in ("hfield", "sdf")):
            el.remove(child)
        elif child.tag in _MJCF_BODY_KEPT:
            if child.tag == "geom":
                child.attrib.pop("material", None)
            if child.tag in ("body", "frame", "replicate"):
                _clean_bodies(child, dropped)
        else:
            el.remove(child)
            if child.tag not in _MJCF_BODY_KNOWN:
                dropped.add(child.tag)
    if el.tag == "body":  # mass and inertia play no part in the geometry: any valid values will do
        el.insert(0, ET.Element("inertial", {"pos": "0 0 0", "mass": "1", "diaginertia": "1 1 1"}))


def _fitted_meshes(el: ET.Element, defaults, cls: str | None, out: set[str]) -> set[str]:
    """Meshes that a primitive geom is fitted to (``<geom type="box" mesh=...>``): MuJoCo must read them."""
    for child in el:
        if child.tag == "geom" and child.get("mesh"):
            kind = child.get("type") or _default_attr(defaults, child.get("class") or cls, "geom", "type") or "mesh"
            if kind != "mesh":
                out.add(child.get("mesh"))
        elif child.tag in ("body", "frame", "replicate"):
            _fitted_meshes(child, defaults, child.get("childclass") or cls, out)
    return out


def _mjcf_document(path: Path, search_path, roots, limits: MeshLimits) -> _MjcfDocument:
    """Parse ``path``, inline its includes and strip it to what the geometry needs: no textures,
    materials, sensors, actuators, contacts or keyframes, a unit inertia on every body (physics
    requirements play no part), unknown elements left out (named in ``dropped``), and every mesh file
    replaced by a placeholder (the real file is read with trimesh, see :func:`load_mjcf`)."""
    root = _parse_xml(path, "MJCF", limits)
    if root.tag != "mujoco":
        raise InputError(f"MJCF file {path}: the root element is <{root.tag}>, not <mujoco>")
    _inline_includes(root, path, path.parent, roots, limits, 0)
    doc = _MjcfDocument(root=root)
    compilers = root.findall("compiler")
    meshdir = ""
    strip = False
    for c in compilers:
        meshdir = c.get("meshdir") or c.get("assetdir") or meshdir
        strip = c.get("strippath", "false") == "true" or strip
    for child in list(root):
        if child.tag not in _MJCF_TOP_KEPT:
            root.remove(child)
            if child.tag not in _MJCF_TOP_KNOWN:
                doc.dropped.add(child.tag)
    if not root.findall("compiler"):
        root.insert(0, ET.Element("compiler"))
    for c in root.findall("compiler"):
        for a in ("meshdir", "assetdir", "texturedir", "strippath", "inertiagrouprange", "settotalmass"):
            c.attrib.pop(a, None)
        c.attrib.update(inertiafromgeom="false", discardvisual="false", fusestatic="false")
    for d in root.iter("default"):
        for child in list(d):
            if child.tag not in _MJCF_DEFAULT_KEPT:
                d.remove(child)
            elif child.tag == "geom":
                child.attrib.pop("material", None)
    defaults = _defaults(root)
    for asset in root.findall("asset"):
        for child in list(asset):
            if child.tag != "mesh":
                asset.remove(child)
    for wb in root.findall("worldbody"):
        _clean_bodies(wb, doc.dropped)
    fitted: set[str] = set()
    for wb in root.findall("worldbody"):
        _fitted_meshes(wb, defaults, None, fitted)
    base = path.parent / meshdir
    for n, el in enumerate(m for a in root.findall("asset") for m in a.findall("mesh")):
        ref = el.get("file")
        if not ref:
            continue  # vertices written in the file: MuJoCo reads them
        name = el.get("name") or Path(ref).stem
        el.set("name", name)
        lookup = os.path.basename(ref) if strip else ref
        try:
            found = resolve_mesh_path(lookup, base, [path.parent, *search_path], roots)
        except InputError as e:
            raise InputError(f"MJCF file {path}: mesh {name!r}: {e}") from None
        limits.check_file(found, f"MJCF file {path.name}: mesh {name!r}")
        cls = el.get("class", "main")
        scale_text = el.get("scale") or _default_attr(defaults, cls, "mesh", "scale") or "1 1 1"
        try:
            scale = np.asarray([float(x) for x in scale_text.split()], dtype=np.float64)
        except ValueError:
            raise InputError(f"MJCF file {path}: mesh {name!r}: scale {scale_text!r} must be numbers") from None
        suffix = Path(ref).suffix.lower()
        content = (el.get("content_type") or "").lower()
        if content:
            suffix = {"model/stl": ".stl", "model/obj": ".obj", "model/vnd.mujoco.msh": ".msh"}.get(content, suffix)
        # MuJoCo reads a mesh itself where its own processing matters: a primitive fitted to it, or the
        # legacy reference frame (refpos / refquat); every other mesh file is read with trimesh
        real = name in fitted or el.get("refpos") is not None or el.get("refquat") is not None
        key = f"ucope_mesh_{n}{suffix if real else '.stl'}"
        if real:
            doc.assets[key] = found.read_bytes()
        else:
            for a in ("scale", "content_type", "inertia", "maxhullvert", "smoothnormal"):
                el.attrib.pop(a, None)
            el.set("scale", "1 1 1")
            doc.assets[key] = _placeholder_stl()
            doc.meshes[name] = (found, scale)
        el.set("file", key)
    return doc


_UNKNOWN_ATTR = re.compile(r"unrecognized attribute: '([^']+)'\s*Element '([^']+)'")
_UNKNOWN_ELEMENT = re.compile(r"unrecognized element\s*Element '([^']+)'")


def _compile_mjcf(mujoco, path: Path, doc: _MjcfDocument):
    """Compile the stripped document; an attribute or element this MuJoCo does not know (a file written
    for another version) is left out and the compile retried."""
    for _ in range(64):
        xml = ET.tostring(doc.root, encoding="unicode")
        try:
            return mujoco.MjModel.from_xml_string(xml, doc.assets)
        except Exception as e:
            msg = str(e)
            a, el = _UNKNOWN_ATTR.search(msg), _UNKNOWN_ELEMENT.search(msg)
            if a is not None:
                for node in doc.root.iter(a.group(2)):
                    node.attrib.pop(a.group(1), None)
                doc.dropped.add(f"{a.group(2)}/@{a.group(1)}")
                continue
            if el is not None:
                for parent in list(doc.root.iter()):
                    for node in [c for c in parent if c.tag == el.group(1)]:
                        parent.remove(node)
                doc.dropped.add(el.group(1))
                continue
            detail = " ".join(msg.split())
            raise InputError(f"cannot read MJCF file {path} (MuJoCo: {detail})") from None
    raise InputError(f"cannot read MJCF file {path}: too many elements this MuJoCo does not know")  # pragma: no cover


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    w, x, y, z = (float(v) for v in q)
    return Rotation.from_quat([x, y, z, w]).as_matrix()


MJCF_HIDDEN_GROUPS = (3, 4, 5)
"""Geom groups MuJoCo's viewer hides by default: asset libraries put collision proxies there."""


def load_mjcf(
    path: str | os.PathLike,
    search_path: Sequence[str | os.PathLike] = (),
    roots: Sequence[str | os.PathLike] | None = None,
    limits: MeshLimits | None = None,
    exclude_geom_groups: Sequence[int] | str = "auto",
) -> SourceModel:
    """Read an MJCF file (extra ``mjcf``) into a :class:`SourceModel`, for its geometry only.

    The file (with its ``<include>`` files) is stripped before MuJoCo compiles it: textures, materials,
    sensors, actuators, tendons, contacts, keyframes and options are left out, every body gets a unit
    inertia (masses and inertias play no part), elements MuJoCo does not know are left out with a warning
    naming them, and mesh files are read with trimesh (no convex hulls, so flat or open visual meshes read).

    Geometry: ``exclude_geom_groups`` ``"auto"`` leaves out geoms in groups 3-5 (:data:`MJCF_HIDDEN_GROUPS`)
    when the file has geoms in groups 0-2; a list leaves out those groups; then a body that has visual-only
    geoms (``contype = conaffinity = 0``) is those geoms only. Plane, height-field and SDF geoms are scenery.
    ``roots`` and ``limits``: as for :func:`load_model`."""
    mujoco = _import_extra("mujoco", "mjcf")
    path = Path(path)
    limits = limits or DEFAULT_MESH_LIMITS
    if not path.is_file():
        raise InputError(f"MJCF file {path} does not exist")
    doc = _mjcf_document(path, search_path, roots, limits)
    m = _compile_mjcf(mujoco, path, doc)
    if doc.dropped:
        warnings.warn(
            f"MJCF file {path}: left out what MuJoCo or ucope's geometry reader does not know: {', '.join(sorted(doc.dropped))}",
            stacklevel=2,
        )
    names = ["world" if i == 0 else (m.body(i).name or f"body{i}") for i in range(m.nbody)]
    if len(set(names)) != len(names):
        raise InputError(f"{path}: body names must be unique (unnamed bodies are called body<i>), got {names}")
    G = mujoco.mjtGeom
    links: dict[str, list[trimesh.Trimesh]] = {n: [] for n in names}
    scenery = (int(G.mjGEOM_PLANE), int(G.mjGEOM_HFIELD), int(getattr(G, "mjGEOM_SDF", -1)))
    types = np.asarray(m.geom_type, dtype=np.int64)
    groups = np.asarray(m.geom_group, dtype=np.int64)
    solid = ~np.isin(types, scenery)
    if isinstance(exclude_geom_groups, str):
        if exclude_geom_groups != "auto":
            raise InputError(f"exclude_geom_groups must be 'auto' or a list of groups, got {exclude_geom_groups!r}")
        visible = solid & ~np.isin(groups, MJCF_HIDDEN_GROUPS)
        excluded = MJCF_HIDDEN_GROUPS if visible.any() else ()
    else:
        excluded = tuple(int(g) for g in exclude_geom_groups)
    keep = solid & ~np.isin(groups, excluded)
    visual_only = (np.asarray(m.geom_contype) == 0) & (np.asarray(m.geom_conaffinity) == 0)
    bodies_with_visual = set(np.asarray(m.geom_bodyid)[keep & visual_only].tolist())
    mesh_names = [m.mesh(i).name for i in range(m.nmesh)]
    cache: dict[int, trimesh.Trimesh] = {}
    for g in np.flatnonzero(keep):
        t = int(types[g])
        b = int(m.geom_bodyid[g])
        if b in bodies_with_visual and not visual_only[g]:
            continue  # a body with visual-only geoms: its colliding geoms are its collision model, not its surface
        body = names[b]
        size = np.asarray(m.geom_size[g], dtype=np.float64)
        T = make_transform(_quat_matrix(m.geom_quat[g]), m.geom_pos[g])
        if t == G.mjGEOM_MESH:
            mid = int(m.geom_dataid[g])
            if mid not in cache:
                cache[mid] = _mjcf_mesh(m, mid, mesh_names[mid], doc, path, limits)
            mesh = cache[mid]
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
        else:  # pragma: no cover - every solid type is handled above
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


def _mjcf_mesh(m, mid: int, name: str, doc: _MjcfDocument, path: Path, limits: MeshLimits) -> trimesh.Trimesh:
    """Mesh ``mid`` of a compiled document in its geom's frame: the file read with trimesh and scaled (a
    placeholder took its place in the compile), or MuJoCo's own vertices (:func:`_mjcf_document`)."""
    if name in doc.meshes:
        file, scale = doc.meshes[name]
        return _transformed(load_mesh(file, f"{path.name}: mesh {name!r}", limits), np.eye(4), scale)
    va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
    fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
    if fn == 0:
        raise InputError(f"{path}: mesh {name!r} holds no triangles")
    limits.check_counts(vn, fn, path, f"mesh {name!r}")
    return trimesh.Trimesh(
        vertices=np.asarray(m.mesh_vert[va : va + vn], np.float64), faces=m.mesh_face[fa : fa + fn], process=False
    )


# -------------------------------------------------------------------------------------- mesh files
def load_mesh_model(path: str | os.PathLike, limits: MeshLimits | None = None) -> SourceModel:
    """A mesh file as a one-link model (link ``"body"``, no joints)."""
    path = Path(path)
    return SourceModel(path=path, root="body", links={"body": [load_mesh(path, path.name, limits)]}, joints={})


def load_model(
    path: str | os.PathLike,
    search_path: Sequence[str | os.PathLike] = (),
    *,
    roots: Sequence[str | os.PathLike] | None = None,
    limits: MeshLimits | None = None,
    exclude_links: Sequence[str] = (),
    exclude_geom_groups: Sequence[int] | str = "auto",
) -> SourceModel:
    """Read a URDF, MJCF or mesh file by its suffix (:data:`MODEL_SUFFIXES`).

    Args:
        search_path: folders where referenced meshes are looked up (see :func:`resolve_mesh_path`).
        roots: ``None`` reads referenced files (meshes, MJCF includes) wherever they are; otherwise the
            folders they must lie in (absolute and ``file://`` references are then refused).
        limits: file size and mesh size limits (:class:`MeshLimits`, default :data:`DEFAULT_MESH_LIMITS`).
        exclude_links: links (bodies) whose geometry is left out (they stay in the tree); a name the file
            lacks raises :class:`InputError`.
        exclude_geom_groups: MJCF geom groups left out (see :func:`load_mjcf`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        model = load_urdf(path, search_path, roots, limits)
    elif suffix in (".xml", ".mjcf"):
        model = load_mjcf(path, search_path, roots, limits, exclude_geom_groups)
    elif suffix in MESH_SUFFIXES:
        model = load_mesh_model(path, limits)
    else:
        raise InputError(f"{path}: unknown model file type {suffix!r}; ucope reads {', '.join(MODEL_SUFFIXES)}")
    unknown = [n for n in exclude_links if n not in model.links]
    if unknown:
        raise InputError(f"{path}: links to exclude {unknown} are not in the file; its links: {sorted(model.links)}")
    for n in exclude_links:
        model.links[n] = []
    return model


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
