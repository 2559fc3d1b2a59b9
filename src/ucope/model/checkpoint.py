"""Saving and loading models and training checkpoints: safetensors weights + a JSON description.

Nothing here unpickles anything: weights are read with ``safetensors`` (a flat table of tensors) and
everything else is JSON. Every JSON records the SHA-256 and byte size of its weights file, and loading
refuses a weights file that does not match (tampered, truncated, or from another save) with a
:class:`ucope.errors.DataError` that names the file.

Files
-----
* A **model** (what inference needs): ``<stem>.json`` + ``<stem>.safetensors`` (``model.json`` /
  ``model.safetensors`` in a training run folder). The JSON holds the format tag, the conventions
  version, the :class:`ModelConfig` (with the category's :class:`ucope.priors.CategoryPriors`), the
  weights' digest and dtype, and free-form ``info`` (the model card). The safetensors file holds the
  network's weights and, under ``priors.``, the priors' shape templates. A model of another format or
  conventions version is refused with both versions named.
* A **training checkpoint**: ``checkpoint.json`` + ``checkpoint-<step>.safetensors`` holding the model
  weights (``model.<name>``), the priors' tensors (``priors.<name>``) and the optimiser's tensors
  (``optim.<param>.<key>``); the JSON holds the
  rest of the optimiser and scheduler state, the step/epoch counters and the training configuration.
  The weights file is written first under a new name and the JSON replaced atomically after it, so a
  run killed at any moment leaves a consistent checkpoint behind.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

import safetensors.torch
import torch

from ..errors import DataError, InputError
from ..fileio import atomic_write_bytes, atomic_write_json, read_json
from ..versions import CHECKPOINT_FORMAT, CONVENTIONS_VERSION, MODEL_FORMAT, __version__
from .config import ModelConfig

__all__ = [
    "MODEL_FORMAT",
    "CHECKPOINT_FORMAT",
    "save_model",
    "load_model",
    "read_model_json",
    "resolve_model_path",
    "find_model",
    "pretrained_dir",
    "list_pretrained",
    "save_checkpoint",
    "load_checkpoint",
    "sha256_file",
]

_DTYPES = {"float32": torch.float32, "float16": torch.float16, "bfloat16": torch.bfloat16}


def sha256_file(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _write_weights(path: Path, tensors: dict[str, torch.Tensor]) -> dict[str, Any]:
    data = safetensors.torch.save({k: v.detach().contiguous().cpu() for k, v in tensors.items()})
    atomic_write_bytes(path, data)
    return {"file": path.name, "sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}


def _read_weights(json_path: Path, desc: dict) -> dict[str, torch.Tensor]:
    try:
        name = str(desc["file"])
        digest, size = str(desc["sha256"]), int(desc["bytes"])
    except (KeyError, TypeError, ValueError):
        raise DataError(f"{json_path} does not describe its weights file (file, sha256, bytes)") from None
    if Path(name).name != name:
        raise DataError(f"{json_path}: weights file name {name!r} must be a plain file name")
    path = json_path.parent / name
    if not path.is_file():
        raise DataError(f"weights file {path} (named in {json_path}) does not exist")
    actual = path.stat().st_size
    if actual != size:
        raise DataError(f"weights file {path} is {actual} bytes, {json_path} says {size}: truncated or replaced")
    data = path.read_bytes()
    if hashlib.sha256(data).hexdigest() != digest:
        raise DataError(f"weights file {path} does not match the SHA-256 recorded in {json_path}: it was modified")
    try:
        return safetensors.torch.load(data)
    except Exception as e:  # safetensors raises its own error types
        raise DataError(f"weights file {path} is not a valid safetensors file ({e})") from None


# ------------------------------------------------------------------------------------------- models
def save_model(
    model: torch.nn.Module,
    path: str | os.PathLike,
    info: dict | None = None,
    dtype: str = "float32",
) -> Path:
    """Save a :class:`ucope.model.network.UCOPENet` for inference.

    Args:
        model: the network (its ``cfg`` is saved with it).
        path: a folder (writes ``model.json`` / ``model.safetensors`` in it) or a ``.json`` path
            (writes ``<stem>.json`` / ``<stem>.safetensors``).
        info: JSON-safe extra fields (the model card: training data, steps, validation figures...).
        dtype: storage precision of floating-point weights and priors arrays: ``"float32"``,
            ``"float16"`` or ``"bfloat16"``; loading always returns float32.

    Returns:
        the JSON path.
    """
    if dtype not in _DTYPES:
        raise InputError(f"dtype must be one of {sorted(_DTYPES)}, got {dtype!r}")
    json_path = _json_path(path, create=True)
    tensors = {k: v for k, v in model.state_dict().items()}
    tensors.update(_priors_tensors(model.cfg))
    tensors = {k: (v.to(_DTYPES[dtype]) if v.is_floating_point() else v) for k, v in tensors.items()}
    weights = _write_weights(json_path.with_suffix(".safetensors"), tensors)
    atomic_write_json(
        json_path,
        {
            "format": MODEL_FORMAT,
            "ucope_version": __version__,
            "conventions_version": CONVENTIONS_VERSION,
            "config": model.cfg.to_dict(),
            "weights": {**weights, "dtype": dtype},
            "info": info or {},
        },
    )
    return json_path


def _priors_tensors(cfg: ModelConfig) -> dict[str, torch.Tensor]:
    """The priors' arrays (shape templates) as float32 tensors named ``priors.<name>``."""
    return {f"priors.{k}": torch.from_numpy(v.astype("float32")) for k, v in cfg.priors.tensors().items()}


def _split_priors(tensors: dict[str, torch.Tensor]) -> tuple[dict[str, torch.Tensor], dict]:
    """``(network tensors, priors arrays)`` of a weights file."""
    pri = {k[len("priors.") :]: v.float().numpy() for k, v in tensors.items() if k.startswith("priors.")}
    return {k: v for k, v in tensors.items() if not k.startswith("priors.")}, pri


def _config(meta: dict, where: Path, priors_tensors: dict) -> ModelConfig:
    try:
        return ModelConfig.from_dict(meta["config"], priors_tensors)
    except KeyError:
        raise DataError(f"{where} holds no model config") from None
    except InputError as e:
        raise DataError(f"{where}: {e}") from None


def _json_path(path: str | os.PathLike, create: bool = False) -> Path:
    p = Path(path)
    if p.suffix == ".json":
        if create:
            p.parent.mkdir(parents=True, exist_ok=True)
        return p
    if p.suffix == ".safetensors":
        return p.with_suffix(".json")
    if create:
        p.mkdir(parents=True, exist_ok=True)
    return p / "model.json"


def pretrained_dir() -> Path:
    """The folder of the models shipped inside the package (``<category>.json`` + ``.safetensors``)."""
    return Path(__file__).resolve().parent.parent / "pretrained"


def list_pretrained() -> list[str]:
    """Names of the shipped models."""
    d = pretrained_dir()
    return sorted(p.stem for p in d.glob("*.json")) if d.is_dir() else []


def find_model(model: str | os.PathLike) -> Path:
    """The model JSON meant by ``model``: a run folder / model ``.json`` / ``.safetensors`` path, or
    the name of a shipped model (``"laptop"``; :func:`list_pretrained`).

    A path wins, unless it is a folder without a model in it and a shipped model has that name (a data
    folder called ``laptop`` next to you does not hide the shipped laptop model). Raises
    :class:`DataError` naming the shipped models if ``model`` is neither.
    """
    p = Path(model)
    shipped = pretrained_dir() / f"{model}.json"
    if p.exists() and not (p.is_dir() and not (p / "model.json").is_file() and shipped.is_file()):
        return resolve_model_path(p)
    if shipped.is_file():
        return shipped
    names = list_pretrained()
    raise DataError(
        f"no model {str(model)!r}: not a file or folder, and not a shipped model"
        + (f" (shipped: {', '.join(names)})" if names else " (this install ships no models)")
    )


def resolve_model_path(path: str | os.PathLike) -> Path:
    """The model JSON for ``path``: a run folder (its ``model.json``), a ``.json`` or a ``.safetensors``
    file (its sibling ``.json``). Raises :class:`DataError` if there is none."""
    p = Path(path)
    if p.is_dir():
        j = p / "model.json"
        if not j.is_file():
            hint = (
                " (training is still running or was stopped: its checkpoint.json can be resumed)"
                if (p / "checkpoint.json").is_file()
                else ""
            )
            raise DataError(f"{p} holds no model.json{hint}")
        return j
    j = _json_path(p)
    if not j.is_file():
        raise DataError(f"model file {j} does not exist")
    return j


def read_model_json(path: str | os.PathLike) -> dict:
    """The model JSON with its format tag and conventions version checked, without loading the weights.

    Raises :class:`DataError` naming both versions when the file is of another format or conventions
    version (re-package or retrain the model with this ucope)."""
    j = resolve_model_path(path)
    meta = read_json(j)
    fmt = meta.get("format") if isinstance(meta, dict) else None
    if fmt != MODEL_FORMAT:
        raise DataError(f"{j} is not a model this ucope ({__version__}) reads: format {fmt!r}, expected {MODEL_FORMAT!r}")
    conv = str(meta.get("conventions_version"))
    if conv != CONVENTIONS_VERSION:
        raise DataError(
            f"{j} was made under conventions version {conv}, this ucope uses version {CONVENTIONS_VERSION} "
            "(frames or units differ: retrain or re-package the model)"
        )
    return meta


def load_model(path: str | os.PathLike, device: str | torch.device = "cpu"):
    """Load a model saved by :func:`save_model`; returns ``(model, meta)`` with the model in eval mode.

    Raises :class:`DataError` for a missing, truncated, tampered or mismatched file.
    """
    from .factory import build_model

    j = resolve_model_path(path)
    meta = read_model_json(j)
    tensors, pri = _split_priors(_read_weights(j, meta.get("weights", {})))
    model = build_model(_config(meta, j, pri))
    _load_state(model, tensors, j)
    return model.to(device).eval(), meta


def _load_state(model: torch.nn.Module, tensors: dict[str, torch.Tensor], where: Path) -> None:
    own = model.state_dict()
    missing = sorted(set(own) - set(tensors))
    extra = sorted(set(tensors) - set(own))
    if missing or extra:
        raise DataError(f"{where}: weights do not fit the model config (missing {missing[:3]}, unexpected {extra[:3]})")
    for k, v in own.items():
        if tensors[k].shape != v.shape:
            raise DataError(f"{where}: weight {k} has shape {tuple(tensors[k].shape)}, the model needs {tuple(v.shape)}")
    model.load_state_dict({k: t.to(own[k].dtype) for k, t in tensors.items()})


# -------------------------------------------------------------------------------------- checkpoints
def save_checkpoint(run: str | os.PathLike, model: torch.nn.Module, optimizer: torch.optim.Optimizer, state: dict) -> Path:
    """Write a training checkpoint into the run folder ``run`` (see the module docstring).

    Args:
        model: the (unwrapped) network; optimizer: its optimiser.
        state: JSON-safe training state (step, epoch, scheduler state, training config...).

    Returns:
        the checkpoint JSON path.
    """
    run = Path(run)
    run.mkdir(parents=True, exist_ok=True)
    tensors = {f"model.{k}": v for k, v in model.state_dict().items()}
    tensors.update(_priors_tensors(model.cfg))
    opt = optimizer.state_dict()
    opt_scalars: dict[str, dict[str, Any]] = {}
    for pid, st in opt["state"].items():
        for key, val in st.items():
            if isinstance(val, torch.Tensor):
                tensors[f"optim.{pid}.{key}"] = val
            else:
                opt_scalars.setdefault(str(pid), {})[key] = val
    step = int(state["step"])
    weights = _write_weights(run / f"checkpoint-{step:08d}.safetensors", tensors)
    old = read_json(run / "checkpoint.json").get("weights", {}).get("file") if (run / "checkpoint.json").is_file() else None
    atomic_write_json(
        run / "checkpoint.json",
        {
            "format": CHECKPOINT_FORMAT,
            "ucope_version": __version__,
            "config": model.cfg.to_dict(),
            "weights": weights,
            "optimizer": {"param_groups": opt["param_groups"], "scalars": opt_scalars},
            "state": state,
        },
    )
    if old and old != weights["file"]:
        try:
            (run / old).unlink()
        except FileNotFoundError:
            pass
    return run / "checkpoint.json"


def load_checkpoint(
    run: str | os.PathLike, model: torch.nn.Module | None = None, optimizer: torch.optim.Optimizer | None = None
) -> dict:
    """Read a run's checkpoint; restore ``model`` and ``optimizer`` in place if given.

    Returns:
        the checkpoint JSON (``config``, ``state``...) with ``model_config`` added: its
        :class:`ModelConfig` (priors included). Raises :class:`DataError` for a missing, truncated or
        tampered checkpoint, one of another format, or one whose weights do not fit ``model``.
    """
    j = Path(run) / "checkpoint.json"
    meta = read_json(j)
    fmt = meta.get("format") if isinstance(meta, dict) else None
    if fmt != CHECKPOINT_FORMAT:
        raise DataError(
            f"{j} is not a training checkpoint this ucope ({__version__}) resumes: format {fmt!r}, expected {CHECKPOINT_FORMAT!r}"
        )
    tensors, pri = _split_priors(_read_weights(j, meta.get("weights", {})))
    meta["model_config"] = _config(meta, j, pri)
    if model is not None:
        _load_state(model, {k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, j)
    if optimizer is not None:
        try:
            opt_meta = meta["optimizer"]
            state: dict[int, dict[str, Any]] = {}
            for k, v in tensors.items():
                if k.startswith("optim."):
                    _, pid, key = k.split(".", 2)
                    state.setdefault(int(pid), {})[key] = v
            for pid, d in opt_meta.get("scalars", {}).items():
                state.setdefault(int(pid), {}).update(d)
            optimizer.load_state_dict({"state": state, "param_groups": opt_meta["param_groups"]})
        except (KeyError, ValueError, TypeError, RuntimeError) as e:
            raise DataError(f"{j}: the optimiser state does not fit this model ({e})") from None
    return meta
