"""ucope.fileio: the one JSON loader and the atomic writes refuse what is not a regular file."""

from __future__ import annotations

import os

import pytest

from ucope.errors import DataError
from ucope.fileio import MAX_JSON_DEPTH, atomic_write_json, open_regular, parse_json, read_json

posix_only = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")


def test_read_json_names_the_file_and_its_role(tmp_path):
    with pytest.raises(DataError, match=r"^category spec .*nope.json does not exist$"):
        read_json(tmp_path / "nope.json", "category spec")
    with pytest.raises(DataError, match="is a folder, not a file"):
        read_json(tmp_path)
    (tmp_path / "bad.json").write_text('{"a": ')
    with pytest.raises(DataError, match=r"bad.json is not valid JSON \(Expecting value"):
        read_json(tmp_path / "bad.json")
    (tmp_path / "latin1.json").write_bytes(b'{"a": "\xe9"}')
    with pytest.raises(DataError, match="latin1.json is not valid JSON"):
        read_json(tmp_path / "latin1.json")
    (tmp_path / "bom.json").write_bytes(b'\xef\xbb\xbf{"a": 1}')  # as some Windows editors save it
    assert read_json(tmp_path / "bom.json") == {"a": 1}


def test_the_depth_limit_holds_whatever_the_stack(tmp_path):
    assert parse_json("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH) is not None
    deep = {"a": [1, {"b": None}]}
    for _ in range(MAX_JSON_DEPTH):
        deep = [deep]
    atomic_write_json(tmp_path / "d.json", deep)  # a file ucope could write but will not read back
    with pytest.raises(DataError, match=rf"d.json nests arrays / objects more than {MAX_JSON_DEPTH} levels deep"):
        read_json(tmp_path / "d.json")
    assert read_json(tmp_path / "d.json", max_depth=MAX_JSON_DEPTH + 3) == deep


@posix_only
def test_fifos_are_neither_read_nor_replaced(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(DataError, match="pipe.json is a FIFO: only regular files are read"):
        open_regular(fifo)  # returns at once: no writer is waited for
    with pytest.raises(DataError, match="pipe.json: it is not a regular file"):
        atomic_write_json(fifo, {"a": 1})
    assert fifo.is_fifo()
