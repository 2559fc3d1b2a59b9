"""Category specs: a category of your own objects, from URDF, MJCF or mesh files (docs/own_objects.md).

A spec is a JSON document (its JSON Schema ships as ``ucope/objects/category_spec.schema.json``). It names
the category, its instance files, which links form each of the K parts, which joints are the K-1 category
joints and how their file values map to the category's states, the sampled state ranges, a size-scale
augmentation range, the part symmetries and the camera ranges. :func:`load_spec` checks it, reads every
instance file (:mod:`ucope.objects.importers`) and returns an :class:`OwnCategory` whose
:class:`~ucope.objects.categories.CategorySpec` can be registered (:func:`register_spec`), after which
``make_instance``, data generation and everything above treat the category like a built-in one.

Instances and splits: every instance file is a shape family of the category; ``train``, ``val`` and
``test`` draw uniformly among the files not marked ``held_out``, ``ood`` among the held-out ones. Each
drawn instance is scaled by a factor drawn log-uniformly in ``size_scale_range`` from the instance's own
random stream (so instance ``i`` is the same on every machine). An instance entry may name its own links
per part (``parts``: ``{part name: links}``) and its own file joint, sign and offset per category joint
(``joints``: K-1 ``{joint, sign, offset}``; unit and range stay the category's), so files whose links and
joints are named differently (robot arms of different makers) form one category.

Every error is an :class:`~ucope.errors.InputError` naming the spec field (``joints[0].range``...) or the file
and element; an object size outside ``size_range_m`` is a warning naming the file (millimetres are the usual
cause).
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError, InputError
from ..fileio import read_json
from ..vocab import SYMMETRIES
from .articulation import ArticulatedObject
from .importers import (
    MESH_SUFFIXES,
    MODEL_SUFFIXES,
    JointMapping,
    MeshLimits,
    is_inside,
    load_model,
    model_to_object,
    warn_size,
)

__all__ = [
    "SPEC_FORMAT",
    "SCHEMA_PATH",
    "ROTATION_RULES",
    "COLLISION_PATTERNS",
    "OwnCategory",
    "read_spec",
    "check_spec",
    "load_spec",
    "register_spec",
]

SPEC_FORMAT = 1
"""The spec format version this ucope reads (the spec's ``ucope_category_spec`` field)."""

SCHEMA_PATH = Path(__file__).with_name("category_spec.schema.json")
"""The JSON Schema of the spec format."""

ROTATION_RULES = {
    "identity": np.eye(3),
    # z up (URDF / MJCF / ROS convention, x forward) -> the canonical y up: file z -> y, file y -> -z
    "z_up": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
}
"""Named rotations ``canonical_from_file``: ``identity`` (the file is already y up) and ``z_up`` (the
file is z up, the default for URDF and MJCF files; mesh files default to ``identity``)."""

_UNITS = {
    "rad": ("revolute", 1.0),
    "deg": ("revolute", math.pi / 180.0),
    "m": ("prismatic", 1.0),
    "cm": ("prismatic", 0.01),
    "mm": ("prismatic", 0.001),
}
_TOP_KEYS = {
    "ucope_category_spec",
    "name",
    "description",
    "parts",
    "joints",
    "held_joints",
    "instances",
    "mesh_search_path",
    "size_scale_range",
    "size_range_m",
    "camera",
    "base_dir",
    "allow_outside_paths",
    "mesh_limits",
    "exclude_links",
    "exclude_geom_groups",
    "on_axis_mismatch",
}
_DEFAULTS = {
    "size_scale_range": [1.0, 1.0],
    "size_range_m": [0.02, 5.0],
    "camera": {"distance_range_m": [0.5, 1.5], "elevation_range_deg": [10.0, 60.0]},
}


COLLISION_PATTERNS = (
    "*_col.*",
    "*_col_*",
    "*_coll.*",
    "*_collision*",
    "*_collider*",
    "*collision/*",
    "*collisions/*",
    "col/*",
    "*/col/*",
    "coll/*",
    "*/coll/*",
)
"""What a folder instance entry skips by default (``exclude``): collision meshes by their names
(``mug_col.obj``, ``mug_collision.stl``, ``part_col_3.obj``) or folders (``collision/``, ``col/``),
matched case-insensitively against the path relative to the folder."""

_MESH_LIMIT_FIELDS = {"max_file_mb": "max_file_bytes", "max_vertices": "max_vertices", "max_faces": "max_faces"}


def _fail(field: str, msg: str) -> InputError:
    return InputError(f"category spec: {field}: {msg}")


def _check_entry(field: str, value, required: tuple[str, ...], allowed: set[str], need: str, hint: str = "") -> None:
    """``value`` must be a mapping holding ``required`` and no key outside ``allowed``; else an
    :class:`InputError` naming ``field`` (``need`` says what it must hold, ``hint`` follows the unknown keys)."""
    if not isinstance(value, Mapping) or any(k not in value for k in required):
        raise _fail(field, f"must be an object with {need}")
    bad = sorted(set(value) - allowed)
    if bad:
        raise _fail(field, f"unknown field(s) {bad}{hint}")


def _range(doc: Mapping, key: str, field: str, positive: bool = False) -> list[float]:
    v = doc[key]
    if not (
        isinstance(v, list | tuple) and len(v) == 2 and all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)
    ):
        raise _fail(field, f"must be [lower, upper] numbers, got {v!r}")
    a, b = float(v[0]), float(v[1])
    if not (math.isfinite(a) and math.isfinite(b)) or a > b:
        raise _fail(field, f"must be finite with lower <= upper, got {v!r}")
    if positive and a <= 0:
        raise _fail(field, f"must be positive, got {v!r}")
    return [a, b]


def _rotation(v: Any, field: str) -> np.ndarray:
    if isinstance(v, str):
        if v not in ROTATION_RULES:
            raise _fail(field, f"unknown rotation rule {v!r}; rules: {', '.join(ROTATION_RULES)}")
        return ROTATION_RULES[v]
    if isinstance(v, Mapping) and set(v) == {"euler_xyz_deg"}:
        from scipy.spatial.transform import Rotation

        e = np.asarray(v["euler_xyz_deg"], dtype=np.float64)
        if e.shape != (3,) or not np.all(np.isfinite(e)):
            raise _fail(field, f"euler_xyz_deg must be 3 finite numbers, got {v['euler_xyz_deg']!r}")
        return Rotation.from_euler("xyz", e, degrees=True).as_matrix()
    try:
        R = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        R = None
    if R is None or R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise _fail(field, f"must be a rule ({', '.join(ROTATION_RULES)}), {{'euler_xyz_deg': [x, y, z]}} or a 3x3 matrix")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-4 or np.linalg.det(R) < 0:
        raise _fail(field, "the 3x3 matrix must be a rotation (orthonormal, determinant +1)")
    return R


def read_spec(path: str | os.PathLike) -> dict:
    """The spec document at ``path`` (JSON) with ``base_dir`` set to its folder (absolute) unless given;
    an unreadable or malformed file raises :class:`InputError` naming it."""
    path = Path(path)
    try:
        doc = read_json(path, "category spec")
    except DataError as e:
        raise InputError(str(e)) from None
    if not isinstance(doc, dict):
        raise InputError(f"category spec {path} must be a JSON object")
    base = Path(doc.get("base_dir", "."))
    doc["base_dir"] = str((path.parent / base).resolve())
    return doc


def check_spec(doc: Mapping[str, Any]) -> dict:
    """Check a spec document field by field and return it normalised (defaults filled in, JSON-safe).

    Raises :class:`InputError` naming the first bad field. Reads no instance file (:func:`load_spec` does)."""
    if not isinstance(doc, Mapping):
        raise InputError("category spec must be a JSON object")
    unknown = sorted(set(doc) - _TOP_KEYS)
    if unknown:
        raise _fail(", ".join(unknown), f"unknown field(s); the fields are {', '.join(sorted(_TOP_KEYS))}")
    for key in ("ucope_category_spec", "name", "parts", "instances"):
        if key not in doc:
            raise _fail(key, "missing")
    if doc["ucope_category_spec"] != SPEC_FORMAT:
        raise _fail("ucope_category_spec", f"this ucope reads format {SPEC_FORMAT}, got {doc['ucope_category_spec']!r}")
    out: dict[str, Any] = {"ucope_category_spec": SPEC_FORMAT}
    name = doc["name"]
    if not isinstance(name, str) or not name or not all(c.isascii() and (c.isalnum() or c in "_-") for c in name):
        raise _fail("name", f"must be a non-empty name of letters, digits, '_' and '-', got {name!r}")
    from .categories import CATEGORY_NAMES

    if name in CATEGORY_NAMES:
        raise _fail("name", f"{name!r} is a built-in category; choose another name")
    out["name"] = name
    desc = doc.get("description", "")
    if not isinstance(desc, str):
        raise _fail("description", f"must be a string (one line), got a {type(desc).__name__}")
    out["description"] = desc
    parts = doc["parts"]
    if not isinstance(parts, list) or not parts:
        raise _fail("parts", "must be a non-empty list of {name, links, symmetry}")
    out["parts"] = []
    for k, p in enumerate(parts):
        f = f"parts[{k}]"
        _check_entry(f, p, ("name", "links"), {"name", "links", "symmetry"}, "name and links")
        if not isinstance(p["name"], str) or not p["name"]:
            raise _fail(f"{f}.name", f"must be a non-empty string, got {p['name']!r}")
        links = p["links"]
        if links != "*" and not (isinstance(links, list) and links and all(isinstance(x, str) and x for x in links)):
            raise _fail(f"{f}.links", f"must be a non-empty list of link / body names, or '*', got {links!r}")
        sym = p.get("symmetry", "none")
        if sym not in SYMMETRIES:
            raise _fail(f"{f}.symmetry", f"must be one of {SYMMETRIES}, got {sym!r}")
        out["parts"].append({"name": p["name"], "links": links, "symmetry": sym})
    pnames = [p["name"] for p in out["parts"]]
    if len(set(pnames)) != len(pnames):
        raise _fail("parts", f"part names must be unique, got {pnames}")
    joints = doc.get("joints", [])
    if not isinstance(joints, list) or len(joints) != len(parts) - 1:
        raise _fail("joints", f"{len(parts)} parts need {len(parts) - 1} category joints, got {joints!r}")
    out["joints"] = []
    for i, j in enumerate(joints):
        f = f"joints[{i}]"
        _check_entry(f, j, ("joint", "range"), {"joint", "sign", "offset", "unit", "range", "axis"}, "joint and range")
        if not isinstance(j["joint"], str) or not j["joint"]:
            raise _fail(f"{f}.joint", f"must name a joint of the files, got {j['joint']!r}")
        sign = j.get("sign", 1)
        if sign not in (1, -1) or isinstance(sign, bool):
            raise _fail(f"{f}.sign", f"must be 1 or -1, got {sign!r}")
        unit = j.get("unit", "rad")
        if unit not in _UNITS:
            raise _fail(f"{f}.unit", f"must be one of {', '.join(_UNITS)}, got {unit!r}")
        offset = j.get("offset", 0.0)
        if not isinstance(offset, int | float) or isinstance(offset, bool) or not math.isfinite(offset):
            raise _fail(f"{f}.offset", f"must be a finite number, got {offset!r}")
        rng = _range(j, "range", f"{f}.range")
        if rng[0] == rng[1]:
            raise _fail(f"{f}.range", f"must span a range (lower < upper), got {rng}")
        entry_j = {"joint": j["joint"], "sign": int(sign), "offset": float(offset), "unit": unit, "range": rng}
        if "axis" in j:
            entry_j["axis"] = _axis(j["axis"], f"{f}.axis")
        out["joints"].append(entry_j)
    jn = [j["joint"] for j in out["joints"]]
    if len(set(jn)) != len(jn):
        raise _fail("joints", f"joint names must be unique, got {jn}")
    out["held_joints"] = _held(doc.get("held_joints", {}), "held_joints")
    inst = doc["instances"]
    if not isinstance(inst, list) or not inst:
        raise _fail("instances", "must be a non-empty list of {file, rotation, scale, held_out}")
    out["instances"] = []
    for k, it in enumerate(inst):
        f = f"instances[{k}]"
        allowed = {"file", "rotation", "scale", "held_out", "held_joints", "parts", "joints"}
        allowed |= {"pattern", "exclude", "exclude_links", "exclude_geom_groups"}
        _check_entry(f, it, ("file",), allowed, "a file")
        if not isinstance(it["file"], str) or not it["file"]:
            raise _fail(f"{f}.file", f"must be a path, got {it['file']!r}")
        entry: dict[str, Any] = {"file": it["file"]}
        if "rotation" in it:
            _rotation(it["rotation"], f"{f}.rotation")
            r = it["rotation"]
            entry["rotation"] = r if isinstance(r, str | Mapping) else np.asarray(r, float).tolist()
        sc = it.get("scale", 1.0)
        if not isinstance(sc, int | float) or isinstance(sc, bool) or not (math.isfinite(sc) and sc > 0):
            raise _fail(f"{f}.scale", f"must be a positive number, got {sc!r}")
        entry["scale"] = float(sc)
        ho = it.get("held_out", False)
        if not isinstance(ho, bool):
            raise _fail(f"{f}.held_out", f"must be true or false, got {ho!r}")
        entry["held_out"] = ho
        entry["held_joints"] = _held(it.get("held_joints", {}), f"{f}.held_joints")
        if "parts" in it:
            entry["parts"] = _instance_parts(it["parts"], pnames, f"{f}.parts")
        if "joints" in it:
            entry["joints"] = _instance_joints(it["joints"], len(out["joints"]), f"{f}.joints")
        for key in ("pattern", "exclude"):
            if key in it:
                entry[key] = _patterns(it[key], f"{f}.{key}", allow_empty=key == "exclude")
        if "exclude_links" in it:
            entry["exclude_links"] = _names(it["exclude_links"], f"{f}.exclude_links")
        if "exclude_geom_groups" in it:
            entry["exclude_geom_groups"] = _groups(it["exclude_geom_groups"], f"{f}.exclude_geom_groups")
        out["instances"].append(entry)
    sp = doc.get("mesh_search_path", [])
    if not isinstance(sp, list) or not all(isinstance(x, str) for x in sp):
        raise _fail("mesh_search_path", f"must be a list of folders, got {sp!r}")
    out["mesh_search_path"] = list(sp)
    full = {**_DEFAULTS, **{k: doc[k] for k in ("size_scale_range", "size_range_m") if k in doc}}
    out["size_scale_range"] = _range(full, "size_scale_range", "size_scale_range", positive=True)
    out["size_range_m"] = _range(full, "size_range_m", "size_range_m", positive=True)
    cam = doc.get("camera", {})
    if not isinstance(cam, Mapping) or set(cam) - {"distance_range_m", "elevation_range_deg"}:
        raise _fail("camera", f"must be an object with distance_range_m and / or elevation_range_deg, got {cam!r}")
    cam = {**_DEFAULTS["camera"], **cam}
    out["camera"] = {
        "distance_range_m": _range(cam, "distance_range_m", "camera.distance_range_m", positive=True),
        "elevation_range_deg": _range(cam, "elevation_range_deg", "camera.elevation_range_deg"),
    }
    if not -90.0 <= out["camera"]["elevation_range_deg"][0] <= out["camera"]["elevation_range_deg"][1] <= 90.0:
        raise _fail("camera.elevation_range_deg", "must lie within [-90, 90] degrees")
    out["base_dir"] = str(doc.get("base_dir", "."))
    # optional fields appear in the normalised document only when they differ from their default, so that a
    # spec written before they existed normalises as it did (data sets compare the normalised spec)
    allow = doc.get("allow_outside_paths", False)
    if not isinstance(allow, bool):
        raise _fail("allow_outside_paths", f"must be true or false, got {allow!r}")
    if allow:
        out["allow_outside_paths"] = True
    if "mesh_limits" in doc:
        out["mesh_limits"] = _mesh_limits(doc["mesh_limits"])
    if doc.get("exclude_links"):
        out["exclude_links"] = _names(doc["exclude_links"], "exclude_links")
    elif "exclude_links" in doc:
        _names(doc["exclude_links"], "exclude_links")
    if doc.get("exclude_geom_groups", "auto") != "auto":
        out["exclude_geom_groups"] = _groups(doc["exclude_geom_groups"], "exclude_geom_groups")
    mismatch = doc.get("on_axis_mismatch", "flip")
    if mismatch not in ("flip", "refuse"):
        raise _fail("on_axis_mismatch", f"must be 'flip' or 'refuse', got {mismatch!r}")
    if mismatch != "flip":
        out["on_axis_mismatch"] = mismatch
    return out


def _axis(v: Any, field: str) -> list[float]:
    """A category joint's axis direction (3 finite numbers, not zero), normalised."""
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or isinstance(v, str) or a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-9:
        raise _fail(field, f"must be 3 finite numbers, not all zero (a direction in the canonical frame), got {v!r}")
    return (a / np.linalg.norm(a)).tolist()


def _patterns(v: Any, field: str, allow_empty: bool = False) -> list[str]:
    """File name patterns (globs) relative to a folder entry: a string or a list of strings."""
    items = [v] if isinstance(v, str) else v
    if not isinstance(items, list) or not (items or allow_empty) or not all(isinstance(x, str) and x for x in items):
        raise _fail(field, f"must be a glob pattern or a list of them (e.g. '*.urdf', '**/*.obj'), got {v!r}")
    for x in items:
        if os.path.isabs(x) or ".." in Path(x).parts:
            raise _fail(field, f"pattern {x!r} must stay inside the folder (no absolute path, no '..')")
    return list(items)


def _names(v: Any, field: str) -> list[str]:
    if not isinstance(v, list) or not all(isinstance(x, str) and x for x in v):
        raise _fail(field, f"must be a list of link / body names, got {v!r}")
    return list(v)


def _groups(v: Any, field: str) -> list[int] | str:
    if v == "auto":
        return "auto"
    if not isinstance(v, list) or not all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= 31 for x in v):
        raise _fail(field, f"must be 'auto' or a list of MJCF geom groups (integers 0-31), got {v!r}")
    return sorted(set(v))


def _mesh_limits(v: Any) -> dict[str, float]:
    if not isinstance(v, Mapping) or set(v) - set(_MESH_LIMIT_FIELDS):
        raise _fail("mesh_limits", f"must be an object with any of {', '.join(_MESH_LIMIT_FIELDS)}, got {v!r}")
    out = {}
    for k, x in v.items():
        if not isinstance(x, int | float) or isinstance(x, bool) or not (math.isfinite(x) and x > 0):
            raise _fail(f"mesh_limits.{k}", f"must be a positive number, got {x!r}")
        out[k] = float(x) if k == "max_file_mb" else int(x)
    return out


def mesh_limits_of(doc: Mapping[str, Any]) -> MeshLimits:
    """The :class:`~ucope.objects.importers.MeshLimits` a normalised spec sets (the defaults where it sets none)."""
    given = doc.get("mesh_limits", {})
    kw = {_MESH_LIMIT_FIELDS[k]: (int(v * 2**20) if k == "max_file_mb" else int(v)) for k, v in given.items()}
    return MeshLimits(**kw)


def _instance_parts(v: Any, pnames: list[str], field: str) -> dict[str, Any]:
    """An instance's own link names per part: ``{part name: links or "*"}`` (parts not named keep the
    spec's links)."""
    if not isinstance(v, Mapping) or not v:
        raise _fail(field, f"must map part names to this file's link lists (or '*'), got {v!r}")
    out = {}
    for name, links in v.items():
        if name not in pnames:
            raise _fail(f"{field}.{name}", f"is not a part of the spec; the parts are {pnames}")
        if links != "*" and not (isinstance(links, list) and links and all(isinstance(x, str) and x for x in links)):
            raise _fail(f"{field}.{name}", f"must be a non-empty list of link / body names, or '*', got {links!r}")
        out[name] = links
    return out


def _instance_joints(v: Any, n: int, field: str) -> list[dict[str, Any]]:
    """An instance's own file joints for the ``n`` category joints: a list of ``n`` objects
    ``{joint, sign, offset}`` (``sign`` / ``offset`` not given: the category joint's)."""
    if not isinstance(v, list) or len(v) != n:
        raise _fail(field, f"must list this file's joint for each of the {n} category joints, got {v!r}")
    out = []
    for i, j in enumerate(v):
        f = f"{field}[{i}]"
        hint = "; unit and range are the category joint's"
        _check_entry(f, j, ("joint",), {"joint", "sign", "offset"}, "joint (and optionally sign, offset)", hint)
        if not isinstance(j["joint"], str) or not j["joint"]:
            raise _fail(f"{f}.joint", f"must name a joint of the file, got {j['joint']!r}")
        e: dict[str, Any] = {"joint": j["joint"]}
        if "sign" in j:
            if j["sign"] not in (1, -1) or isinstance(j["sign"], bool):
                raise _fail(f"{f}.sign", f"must be 1 or -1, got {j['sign']!r}")
            e["sign"] = int(j["sign"])
        if "offset" in j:
            o = j["offset"]
            if not isinstance(o, int | float) or isinstance(o, bool) or not math.isfinite(o):
                raise _fail(f"{f}.offset", f"must be a finite number, got {o!r}")
            e["offset"] = float(o)
        out.append(e)
    names = [e["joint"] for e in out]
    if len(set(names)) != len(names):
        raise _fail(field, f"joint names must be unique, got {names}")
    return out


def _held(v: Any, field: str) -> dict[str, float]:
    if not isinstance(v, Mapping) or not all(
        isinstance(k, str) and isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for k, x in v.items()
    ):
        raise _fail(field, f"must map joint names to finite file values (radians / metres of the file), got {v!r}")
    return {k: float(x) for k, x in v.items()}


@dataclass(frozen=True, eq=False)
class OwnCategory:
    """A loaded spec: the normalised document, one object per instance file (at scale 1 of the
    augmentation, instance id ``<name>/<family>``) and the registry entry.

    Attributes:
        doc: the normalised spec (:func:`check_spec`), with ``base_dir`` absolute.
        families: the family name of each instance file, in order (``"000_<file stem>"``..., with as many of
            the file's folders before the stem as it takes to tell files of one name apart:
            ``"000_arm_a-robot"``, ``"001_arm_b-robot"``).
        objects: family name -> its :class:`ArticulatedObject` (``params["source"]``: its file, relative to
            ``base_dir`` when inside it).
        spec: the :class:`~ucope.objects.categories.CategorySpec` (``family`` ``"own"``).
        files: family name -> the file read (absolute).
        flipped: family name -> the category joints whose file axis pointed against the category's and was
            turned round, with the states negated (``on_axis_mismatch`` ``"flip"``).
        skipped: instance entry index -> the files a folder entry left out (``exclude``).
        entry_of: family name -> the index of its entry in ``doc["instances"]``.
        joint_limits: family name -> per category joint ``(file joint name, file limits, those limits as
            category states)`` (radians / metres; ``None`` for an unlimited joint).
    """

    doc: dict
    families: tuple[str, ...]
    objects: dict[str, ArticulatedObject]
    spec: Any
    files: dict[str, Path] = dataclasses.field(default_factory=dict)
    flipped: dict[str, tuple[int, ...]] = dataclasses.field(default_factory=dict)
    skipped: dict[int, tuple[Path, ...]] = dataclasses.field(default_factory=dict)
    entry_of: dict[str, int] = dataclasses.field(default_factory=dict)
    joint_limits: dict[str, tuple] = dataclasses.field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.doc["name"]


def _roots(doc: Mapping) -> list[Path] | None:
    """The folders a spec's files must lie in (``base_dir`` and its ``mesh_search_path``), or ``None``
    with ``allow_outside_paths``; a search folder outside ``base_dir`` raises :class:`InputError`."""
    base = Path(doc["base_dir"])
    search = [base / s for s in doc["mesh_search_path"]]
    if doc.get("allow_outside_paths"):
        return None
    for i, (s, folder) in enumerate(zip(doc["mesh_search_path"], search, strict=True)):
        if os.path.isabs(s) or not is_inside(folder, [base]):
            raise _fail(
                f"mesh_search_path[{i}]",
                f'{s!r} lies outside base_dir ({base}); set "allow_outside_paths": true to read files outside it',
            )
    return [base, *search]


def _is_collision(rel: str, patterns: list[str]) -> bool:
    low = rel.lower()
    return any(fnmatch.fnmatchcase(low, p.lower()) for p in patterns)


def _expand_entry(k: int, it: Mapping, base: Path, roots: list[Path] | None) -> tuple[list[Path], list[Path]]:
    """The files of instance entry ``k`` (a folder gives the files its ``pattern`` matches, sorted, less
    those its ``exclude`` matches) and the files left out."""
    field = f"instances[{k}].file"
    ref = it["file"]
    if roots is not None and (os.path.isabs(ref) or ref.startswith("file://")):
        raise _fail(field, f'{ref!r} is an absolute path; set "allow_outside_paths": true to read files outside base_dir')
    p = Path(ref[len("file://") :] if ref.startswith("file://") else ref)
    p = p if p.is_absolute() else base / p
    if roots is not None and not is_inside(p, roots):
        raise _fail(field, f'{ref!r} lies outside base_dir ({base}); set "allow_outside_paths": true to read files outside it')
    if p.is_dir():
        patterns = it.get("pattern")
        if patterns is None:
            found = [f for f in p.rglob("*") if f.suffix.lower() in MESH_SUFFIXES]
        else:
            found = [f for pat in patterns for f in p.glob(pat) if f.suffix.lower() in MODEL_SUFFIXES]
        found = sorted({f for f in found if f.is_file()}, key=lambda f: f.relative_to(p).as_posix())
        exclude = it.get("exclude", list(COLLISION_PATTERNS))
        files = [f for f in found if not _is_collision(f.relative_to(p).as_posix(), exclude)]
        skipped = [f for f in found if f not in files]
        if roots is not None:
            outside = [f for f in files if not is_inside(f, roots)]
            if outside:
                raise _fail(field, f"{outside[0]} (a link?) lies outside base_dir ({base})")
        if not files:
            what = (
                f"matching its pattern {patterns}"
                if patterns is not None
                else f"({', '.join(MESH_SUFFIXES)}) in it or its subfolders"
            )
            also = f"; left out as collision meshes (exclude): {[f.name for f in skipped][:5]}" if skipped else ""
            raise _fail(field, f"folder {p} holds no model files {what}{also}")
        return files, skipped
    if p.is_file():
        for key in ("pattern", "exclude"):
            if key in it:
                raise _fail(f"instances[{k}].{key}", f"is for folder entries; {p} is a file")
        return [p], []
    raise _fail(field, f"{p} does not exist")


def family_names(files: list[Path], base: Path) -> list[str]:
    """Instance family names ``"NNN_<name>"``: ``<name>`` is the file's stem, with as many of its folders
    (relative to ``base`` when inside it) before it, joined by ``-``, as it takes to tell different files
    of one stem apart; characters other than letters, digits, ``_``, ``.`` and ``-`` become ``_``."""
    parts = []
    for f in files:
        try:
            rel = f.resolve().relative_to(base.resolve())
        except ValueError:
            rel = Path(*f.resolve().parts[1:])
        parts.append([*rel.parent.parts, rel.stem])
    depth = [1] * len(files)
    while True:
        names = ["-".join(p[-d:]) for p, d in zip(parts, depth, strict=True)]
        grow = [
            i
            for i, nm in enumerate(names)
            if depth[i] < len(parts[i]) and any(names[j] == nm and parts[j] != parts[i] for j in range(len(files)))
        ]
        if not grow:
            break
        for i in grow:
            depth[i] += 1
    return [f"{n:03d}_{re.sub(r'[^A-Za-z0-9_.-]', '_', nm)}" for n, nm in enumerate(names)]


def _source_name(path: Path, base: Path) -> str:
    try:
        return path.resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        return str(path)


def _mappings(doc: Mapping, it: Mapping, model, path: Path) -> list[JointMapping]:
    out = []
    for i, j in enumerate(doc["joints"]):
        kind, f = _UNITS[j["unit"]]
        j = {**j, **it["joints"][i]} if "joints" in it else j  # the file's own name, sign and offset
        src = model.joints.get(j["joint"])
        if src is not None and src.type in ("revolute", "prismatic") and src.type != kind:
            raise _fail(f"joints[{i}].unit", f"{j['unit']!r} is a {kind} unit but joint {j['joint']!r} of {path} is {src.type}")
        out.append(
            JointMapping(joint=j["joint"], sign=j["sign"], offset=j["offset"] * f, range=(j["range"][0] * f, j["range"][1] * f))
        )
    return out


AXIS_MAX_SPREAD_DEG = 45.0
"""Instances whose axes of one category joint (as lines, sign aside) differ by more than this are refused:
no sign can make them agree."""


def _axis_signs(doc: Mapping, fams: list[str], objects: dict, files: dict) -> dict[str, list[int]]:
    """Category joint -> the instances whose axis points against the category's (the spec's ``axis``, else
    the first instance's); raises :class:`InputError` naming both files when the axes are not near one line
    or, with ``on_axis_mismatch`` ``"refuse"``, point opposite ways."""
    out: dict[str, list[int]] = {}
    for i, j in enumerate(doc["joints"]):
        if "axis" in j:
            ref, ref_name = np.asarray(j["axis"]), f"the spec's joints[{i}].axis"
        else:
            ref, ref_name = objects[fams[0]].joints[i].axis, f"{fams[0]} ({files[fams[0]]})"
        for fam in fams:
            a = objects[fam].joints[i].axis
            cos = float(np.dot(a, ref) / (np.linalg.norm(a) * np.linalg.norm(ref)))
            line_deg = math.degrees(math.acos(min(1.0, abs(cos))))
            where = f"category spec: joint {i} ({j['joint']!r}): the axis of {fam} ({files[fam]}), {np.round(a, 3).tolist()}"
            if line_deg > AXIS_MAX_SPREAD_DEG:
                raise InputError(
                    f"{where}, is {line_deg:.0f} degrees off the axis of {ref_name}, {np.round(ref, 3).tolist()}: the "
                    "instances of a category turn or slide about one axis; check the files' rotation and joint names"
                )
            if cos < 0:
                if doc.get("on_axis_mismatch", "flip") == "refuse":
                    raise InputError(
                        f"{where}, points against that of {ref_name}, {np.round(ref, 3).tolist()}: give that file "
                        "the sign and offset that make its axis agree, or let ucope flip it (on_axis_mismatch 'flip')"
                    )
                out.setdefault(fam, []).append(i)
    return out


def load_spec(spec: str | os.PathLike | Mapping[str, Any]) -> OwnCategory:
    """Check a spec (a path to its JSON file, or the document) and read every instance file.

    Every file read (instance files, meshes, MJCF includes) must lie under ``base_dir`` or a
    ``mesh_search_path`` folder unless the spec sets ``allow_outside_paths``, and within its
    ``mesh_limits``. The instances' axes of each category joint must agree in sign (with the spec's
    ``axis`` when given, else with the first instance's): a file whose axis points the other way is turned
    round with its states negated (a ``UserWarning`` names both files), or refused with
    ``on_axis_mismatch`` ``"refuse"``.

    Raises :class:`InputError` naming the field, or the file and element; warns (``UserWarning`` naming
    the file) when an instance's size at state 0 is outside ``size_range_m``."""
    from .categories import CategorySpec, ShapeFamily

    doc = check_spec(read_spec(spec) if isinstance(spec, str | os.PathLike) else spec)
    base = Path(doc["base_dir"])
    roots = _roots(doc)
    search = [base / s for s in doc["mesh_search_path"]]
    limits = mesh_limits_of(doc)
    entries: list[tuple[Path, dict, int]] = []
    skipped: dict[int, tuple[Path, ...]] = {}
    for k, it in enumerate(doc["instances"]):
        got, left = _expand_entry(k, it, base, roots)
        entries += [(f, it, k) for f in got]
        if left:
            skipped[k] = tuple(left)
    fams = family_names([f for f, _, _ in entries], base)
    objects: dict[str, ArticulatedObject] = {}
    files: dict[str, Path] = {}
    built = {}
    for fam, (path, it, k) in zip(fams, entries, strict=True):
        is_mjcf = path.suffix.lower() in (".xml", ".mjcf")
        if "exclude_geom_groups" in it and not is_mjcf:
            raise _fail(f"instances[{k}].exclude_geom_groups", f"is for MJCF files; {path} is not one")
        model = load_model(
            path,
            search,
            roots=roots,
            limits=limits,
            exclude_geom_groups=it.get("exclude_geom_groups", doc.get("exclude_geom_groups", "auto")) if is_mjcf else "auto",
        )
        own_excl = it.get("exclude_links", [])
        missing = [n for n in own_excl if n not in model.links]
        if missing:
            raise _fail(f"instances[{k}].exclude_links", f"{missing} are not links of {path}; its links: {sorted(model.links)}")
        for n in [*own_excl, *(n for n in doc.get("exclude_links", []) if n in model.links)]:
            model.links[n] = []
        default_rule = "identity" if path.suffix.lower() not in (".urdf", ".xml", ".mjcf") else "z_up"
        R = _rotation(it.get("rotation", default_rule), f"instances[{k}].rotation")
        own_links = it.get("parts", {})
        parts = [(p["name"], own_links.get(p["name"], p["links"]), p["symmetry"]) for p in doc["parts"]]
        mappings = _mappings(doc, it, model, path)
        held = {**doc["held_joints"], **it["held_joints"]}
        held = {k_: v for k_, v in held.items() if k_ in model.joints or k_ in it["held_joints"]}
        args = (model, doc["name"], f"{doc['name']}/{fam}", parts, mappings, held, R, it["scale"])
        obj = model_to_object(*args, shape_family=fam)
        warn_size(obj, str(path), tuple(doc["size_range_m"]))
        objects[fam] = obj
        files[fam] = path
        built[fam] = args
    first = objects[fams[0]]
    for fam in fams[1:]:
        o = objects[fam]
        if o.joint_types != first.joint_types or [j.parent for j in o.joints] != [j.parent for j in first.joints]:
            raise InputError(
                f"category spec: instance {fam} has joints {o.joint_types} on parents {[j.parent for j in o.joints]}, "
                f"the first instance {first.joint_types} on {[j.parent for j in first.joints]}: "
                "every instance needs the same tree"
            )
    flips = _axis_signs(doc, fams, objects, {f: _source_name(p, base) for f, p in files.items()})
    for fam, idx in flips.items():
        model, name, iid, parts, mappings, held, R, scale = built[fam]
        mappings = [
            dataclasses.replace(m, sign=-m.sign, offset=-m.offset, range=(0.0 - m.range[1], 0.0 - m.range[0])) if i in idx else m
            for i, m in enumerate(mappings)
        ]
        objects[fam] = model_to_object(model, name, iid, parts, mappings, held, R, scale, shape_family=fam)
        ranges = [f"joint {i} now samples [{mappings[i].range[0]:.4g}, {mappings[i].range[1]:.4g}]" for i in idx]
        warnings.warn(
            f"category spec: {fam} ({_source_name(files[fam], base)}): the axis of category joint(s) {idx} points against "
            f"the category's ({'the spec' if all('axis' in doc['joints'][i] for i in idx) else fams[0]}): turned round, "
            f"its states negated ({'; '.join(ranges)})",
            stacklevel=2,
        )
    joint_limits = {}
    for fam in fams:
        objects[fam] = dataclasses.replace(objects[fam], params={**objects[fam].params, "source": _source_name(files[fam], base)})
        model, mappings, scale = built[fam][0], built[fam][4], built[fam][7]
        if fam in flips:
            mappings = [
                dataclasses.replace(m, sign=-m.sign, offset=-m.offset) if i in flips[fam] else m for i, m in enumerate(mappings)
            ]
        rows = []
        for m in mappings:
            src = model.joints[m.joint]
            k = scale if src.type == "prismatic" else 1.0
            lim = src.limits
            states = None if lim is None else tuple(sorted(m.sign * k * v + m.offset + 0.0 for v in lim))
            rows.append((m.joint, lim, states))
        joint_limits[fam] = tuple(rows)
    lo_s, hi_s = doc["size_scale_range"]

    def build(rng: np.random.Generator, instance_id: str, family: str) -> ArticulatedObject:
        factor = float(np.exp(rng.uniform(np.log(lo_s), np.log(hi_s)))) if hi_s > lo_s else float(lo_s)
        obj = dataclasses.replace(objects[family], instance_id=instance_id)
        return obj.scaled(factor) if factor != 1.0 else obj

    held_out = {fam: it["held_out"] for fam, (_, it, _) in zip(fams, entries, strict=True)}
    cs = CategorySpec(
        name=doc["name"],
        family="own",
        part_names=tuple(p["name"] for p in doc["parts"]),
        joint_types=first.joint_types,
        symmetry=tuple(p["symmetry"] for p in doc["parts"]),
        distance_range_m=tuple(doc["camera"]["distance_range_m"]),
        elevation_range_deg=tuple(doc["camera"]["elevation_range_deg"]),
        shape_families=tuple(
            ShapeFamily(name=f, description=str(objects[f].params["source"]), held_out=held_out[f]) for f in fams
        ),
        build=build,
        description=doc["description"] or f"own category from {len(fams)} file(s)",
        procedural=False,
    )
    return OwnCategory(
        doc=doc,
        families=tuple(fams),
        objects=objects,
        spec=cs,
        files=files,
        flipped={f: tuple(i) for f, i in flips.items()},
        skipped=skipped,
        entry_of={fam: k for fam, (_, _, k) in zip(fams, entries, strict=True)},
        joint_limits=joint_limits,
    )


def register_spec(spec: str | os.PathLike | Mapping[str, Any], quiet: bool = False) -> OwnCategory:
    """:func:`load_spec` and register the category (replacing an earlier registration of the same name),
    so that :func:`~ucope.objects.categories.get_category` and ``make_instance`` know it in this process.
    ``quiet``: silence the size warnings (they were given when the spec was first checked)."""
    from .categories import register_category

    with warnings.catch_warnings():
        if quiet:
            warnings.simplefilter("ignore")
        own = load_spec(spec)
    register_category(own.spec, doc=own.doc)
    return own
