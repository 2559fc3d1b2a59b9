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
import math
import os
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
from .importers import MODEL_SUFFIXES, JointMapping, load_model, model_to_object, warn_size

__all__ = [
    "SPEC_FORMAT",
    "SCHEMA_PATH",
    "ROTATION_RULES",
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
}
_DEFAULTS = {
    "size_scale_range": [1.0, 1.0],
    "size_range_m": [0.02, 5.0],
    "camera": {"distance_range_m": [0.5, 1.5], "elevation_range_deg": [10.0, 60.0]},
}


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
    out["description"] = str(doc.get("description", ""))
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
        _check_entry(f, j, ("joint", "range"), {"joint", "sign", "offset", "unit", "range"}, "joint and range")
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
        out["joints"].append({"joint": j["joint"], "sign": int(sign), "offset": float(offset), "unit": unit, "range": rng})
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
    return out


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
        families: the family name of each instance file, in order (``"000_<file stem>"``...).
        objects: family name -> its :class:`ArticulatedObject`.
        spec: the :class:`~ucope.objects.categories.CategorySpec` (``family`` ``"own"``).
    """

    doc: dict
    families: tuple[str, ...]
    objects: dict[str, ArticulatedObject]
    spec: Any

    @property
    def name(self) -> str:
        return self.doc["name"]


def _expand_files(doc: Mapping) -> list[tuple[Path, dict]]:
    """Every instance file with its entry (a folder entry gives each model file in it, sorted)."""
    base = Path(doc["base_dir"])
    out = []
    for k, it in enumerate(doc["instances"]):
        p = Path(it["file"])
        p = p if p.is_absolute() else base / p
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.suffix.lower() in MODEL_SUFFIXES and f.is_file())
            if not files:
                raise _fail(f"instances[{k}].file", f"folder {p} holds no model files ({', '.join(MODEL_SUFFIXES)})")
            out += [(f, it) for f in files]
        elif p.is_file():
            out.append((p, it))
        else:
            raise _fail(f"instances[{k}].file", f"{p} does not exist")
    return out


def load_spec(spec: str | os.PathLike | Mapping[str, Any]) -> OwnCategory:
    """Check a spec (a path to its JSON file, or the document) and read every instance file.

    Raises :class:`InputError` naming the field, or the file and element; warns (``UserWarning`` naming
    the file) when an instance's size at state 0 is outside ``size_range_m``."""
    from .categories import CategorySpec, ShapeFamily

    doc = check_spec(read_spec(spec) if isinstance(spec, str | os.PathLike) else spec)
    base = Path(doc["base_dir"])
    search = [Path(s) if Path(s).is_absolute() else base / s for s in doc["mesh_search_path"]]
    files = _expand_files(doc)
    objects: dict[str, ArticulatedObject] = {}
    families = []
    for n, (path, it) in enumerate(files):
        fam = f"{n:03d}_{path.stem}"
        model = load_model(path, search)
        default_rule = "identity" if path.suffix.lower() not in (".urdf", ".xml", ".mjcf") else "z_up"
        R = _rotation(it.get("rotation", default_rule), f"instances[{doc['instances'].index(it)}].rotation")
        own_links = it.get("parts", {})
        parts = [(p["name"], own_links.get(p["name"], p["links"]), p["symmetry"]) for p in doc["parts"]]
        mappings = []
        for i, j in enumerate(doc["joints"]):
            kind, f = _UNITS[j["unit"]]
            j = {**j, **it["joints"][i]} if "joints" in it else j  # the file's own name, sign and offset
            src = model.joints.get(j["joint"])
            if src is not None and src.type in ("revolute", "prismatic") and src.type != kind:
                raise _fail(
                    f"joints[{i}].unit", f"{j['unit']!r} is a {kind} unit but joint {j['joint']!r} of {path} is {src.type}"
                )
            mappings.append(
                JointMapping(
                    joint=j["joint"], sign=j["sign"], offset=j["offset"] * f, range=(j["range"][0] * f, j["range"][1] * f)
                )
            )
        held = {**doc["held_joints"], **it["held_joints"]}
        held = {k: v for k, v in held.items() if k in model.joints or k in it["held_joints"]}
        obj = model_to_object(model, doc["name"], f"{doc['name']}/{fam}", parts, mappings, held, R, it["scale"], shape_family=fam)
        warn_size(obj, str(path), tuple(doc["size_range_m"]))
        objects[fam] = obj
        families.append((fam, it["held_out"]))
    first = objects[families[0][0]]
    for fam, _ in families[1:]:
        o = objects[fam]
        if o.joint_types != first.joint_types or [j.parent for j in o.joints] != [j.parent for j in first.joints]:
            raise InputError(
                f"category spec: instance {fam} has joints {o.joint_types} on parents {[j.parent for j in o.joints]}, "
                f"the first instance {first.joint_types} on {[j.parent for j in first.joints]}: "
                "every instance needs the same tree"
            )
    lo_s, hi_s = doc["size_scale_range"]

    def build(rng: np.random.Generator, instance_id: str, family: str) -> ArticulatedObject:
        factor = float(np.exp(rng.uniform(np.log(lo_s), np.log(hi_s)))) if hi_s > lo_s else float(lo_s)
        obj = dataclasses.replace(objects[family], instance_id=instance_id)
        return obj.scaled(factor) if factor != 1.0 else obj

    cs = CategorySpec(
        name=doc["name"],
        family="own",
        part_names=tuple(p["name"] for p in doc["parts"]),
        joint_types=first.joint_types,
        symmetry=tuple(p["symmetry"] for p in doc["parts"]),
        distance_range_m=tuple(doc["camera"]["distance_range_m"]),
        elevation_range_deg=tuple(doc["camera"]["elevation_range_deg"]),
        shape_families=tuple(ShapeFamily(name=f, description=str(objects[f].params["source"]), held_out=h) for f, h in families),
        build=build,
        description=doc["description"] or f"own category from {len(families)} file(s)",
        procedural=False,
    )
    return OwnCategory(doc=doc, families=tuple(f for f, _ in families), objects=objects, spec=cs)


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
