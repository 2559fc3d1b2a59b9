"""Atomic file writes and checked JSON reads, for every layer that writes files.

A write goes to a temporary file in the target's folder, is flushed to disk and renamed over the
target, so a reader sees either the old file or the new one whole, never a half-written one. The new
file gets the permissions an ordinary ``open(path, "w")`` would give it (``0666`` minus the process's
umask), not the ``0600`` of the temporary file.

Every JSON file ucope reads goes through :func:`read_json`: regular files only (a FIFO or a device is
refused, never waited on), a nesting limit, and one error type (:class:`~ucope.errors.DataError`)
naming the file and the problem.
"""

from __future__ import annotations

import functools
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

from .errors import DataError

__all__ = [
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_write_json",
    "read_json",
    "parse_json",
    "open_regular",
    "MAX_JSON_DEPTH",
]


@functools.lru_cache(maxsize=1)
def _umask() -> int:
    """The process's umask (read from /proc where it exists, so that it is never changed, even briefly)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (the folder must exist).

    Raises :class:`ucope.errors.DataError` naming the path when it cannot be written (a folder, a FIFO
    or a device, no permission, a missing parent folder, a full disk)."""
    path = Path(path)
    if path.is_dir():
        raise DataError(f"cannot write {path}: it is a folder")
    if path.exists() and not path.is_file():  # a FIFO, a device (/dev/null), a socket: never replaced by a file
        raise DataError(f"cannot write {path}: it is not a regular file (a FIFO or a device); give a file name")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as e:
        raise DataError(f"cannot write {path}: {e.strerror or e}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(e, OSError):
            raise DataError(f"cannot write {path}: {e.strerror or e}") from None
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """:func:`atomic_write_bytes` of UTF-8 text."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any) -> None:
    """Write ``obj`` as indented, key-sorted JSON, atomically."""
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=True) + "\n")


MAX_JSON_DEPTH = 100
"""The deepest nesting of arrays and objects :func:`read_json` accepts (ucope's own files nest fewer
than 10 levels; the limit keeps a hostile file from exhausting the parser's stack)."""


def open_regular(path: str | os.PathLike, what: str = "file"):
    """Open ``path`` for reading in binary mode, refusing anything but a regular file.

    A FIFO, a device or a socket would block a reader (or never end), so it is refused without
    blocking: the file is opened non-blocking and checked with ``fstat`` before anything is read.
    ``what`` names the file in the messages (``"category spec"``, ``"camera intrinsics"``...).

    Raises :class:`DataError` naming the path: missing, a folder, not a regular file, unreadable."""
    path = Path(path)
    label = f"{what} {path}" if what != "file" else str(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except FileNotFoundError:
        raise DataError(f"{label} does not exist") from None
    except IsADirectoryError:
        raise DataError(f"{label} is a folder, not a file") from None
    except OSError as e:
        raise DataError(f"cannot read {label}: {e.strerror or e}") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise DataError(f"{label} is a folder, not a file")
        if not stat.S_ISREG(st.st_mode):
            kind = (
                "a FIFO"
                if stat.S_ISFIFO(st.st_mode)
                else "a device"
                if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "not a regular file"
            )
            raise DataError(f"{label} is {kind}: only regular files are read")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _depth_exceeds(obj: Any, limit: int) -> bool:
    """Whether ``obj`` (parsed JSON) nests lists / dicts deeper than ``limit`` (iterative: no recursion)."""
    level = [obj] if isinstance(obj, list | dict) else []
    depth = 0
    while level:
        depth += 1
        if depth > limit:
            return True
        nxt = []
        for c in level:
            values = c.values() if isinstance(c, dict) else c
            nxt.extend(v for v in values if isinstance(v, list | dict))
        level = nxt
    return False


def parse_json(text: str | bytes, source: str = "JSON text", max_depth: int = MAX_JSON_DEPTH) -> Any:
    """Parse JSON text with the checks of :func:`read_json`; ``source`` names it in the messages.

    Raises :class:`DataError`: not valid JSON (or not UTF-8), nested deeper than ``max_depth``."""
    try:
        if isinstance(text, bytes):
            text = text.decode("utf-8-sig")
        obj = json.loads(text)
    except RecursionError:
        raise DataError(f"{source} nests arrays / objects more than {max_depth} levels deep: refused") from None
    except (ValueError, UnicodeDecodeError) as e:  # JSONDecodeError, and Python's limit on the digits of an integer
        raise DataError(f"{source} is not valid JSON ({e})") from None
    if _depth_exceeds(obj, max_depth):
        raise DataError(f"{source} nests arrays / objects more than {max_depth} levels deep: refused")
    return obj


def read_json(path: str | os.PathLike, what: str = "file", max_depth: int = MAX_JSON_DEPTH) -> Any:
    """Read a JSON file: the one loader of every JSON file ucope reads.

    Only a regular file is read (:func:`open_regular`: a FIFO or a device is refused, never waited on);
    ``what`` names the file's role in the messages (``"category spec"``...).

    Raises :class:`DataError` naming the file: missing, a folder, not a regular file, unreadable, not
    valid UTF-8 JSON, nested deeper than ``max_depth`` (:data:`MAX_JSON_DEPTH`)."""
    path = Path(path)
    label = f"{what} {path}" if what != "file" else str(path)
    with open_regular(path, what) as f:
        try:
            data = f.read()
        except OSError as e:
            raise DataError(f"cannot read {label}: {e.strerror or e}") from None
    return parse_json(data, label, max_depth)
