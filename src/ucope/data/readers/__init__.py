"""Readers of the data sets users evaluate on: each object becomes a sample (:mod:`ucope.data.sample`
fields: its cloud, and its ground truth in ucope's frames and units), ready for
:func:`ucope.eval.evaluate.evaluate`.

* :func:`read_nocs`: NOCS CAMERA25 / REAL275 frames (depth, mask, coordinate map, meta; NOCS's ``gts``
  pickles through an unpickler that builds arrays only);
* :func:`read_artimage`: ArtImage / ReArt annotation files, in the authors' published layout (:mod:`.artimage`);
* :func:`read_bop`: BOP scenes (scene_camera, scene_gt, depth, masks, models_info);
* :func:`read_samples`: one of them by name (``ucope eval --format nocs|artimage|bop``).

The layouts each reader expects are in docs/formats.md and the modules' docstrings; every reader is
strict: a missing file or field, a field of the wrong type, NaN or Inf, a file that is not a regular file
(a FIFO), a reference leading outside the data set's folder raises :class:`ucope.errors.DataError`
naming the file and element. Reading images needs Pillow (``ucope[images]``).
"""

from __future__ import annotations

from pathlib import Path

from ...errors import InputError
from .artimage import read_artimage
from .bop import read_bop
from .nocs import read_nocs

__all__ = ["FORMATS", "read_nocs", "read_artimage", "read_bop", "read_samples"]

FORMATS = ("nocs", "artimage", "bop")
"""The data-set formats :func:`read_samples` reads."""


def read_samples(fmt: str, root: str | Path, category: str, **kwargs) -> list[dict]:
    """The samples of ``category`` in the data set at ``root`` in format ``fmt`` (one of :data:`FORMATS`);
    keyword arguments go to the reader (``intrinsics``, ``dataset``, ``gts`` for NOCS; ``intrinsics``,
    ``urdf_metas`` for ArtImage; ``obj_id`` / ``models_info`` for BOP; ``max_points``)."""
    if fmt == "nocs":
        return read_nocs(root, category, **kwargs)
    if fmt == "artimage":
        return read_artimage(root, category, **kwargs)
    if fmt == "bop":
        return read_bop(root, category, **kwargs)
    raise InputError(f"unknown data-set format {fmt!r}; use one of {', '.join(FORMATS)}")
