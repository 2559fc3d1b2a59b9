"""Reading generated data sets: an indexable sequence of samples, and a torch ``Dataset``."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path

from ..errors import DataError
from ..fileio import read_json
from ..objects.categories import CATEGORY_NAMES, get_category
from ..render.camera import PinholeCamera
from ..versions import CONVENTIONS_VERSION, DATA_FORMAT_VERSION, GENERATOR_VERSION
from .shards import read_shard, shard_name

__all__ = ["SyntheticDataset", "load_dataset", "check_versions"]


def check_versions(meta: dict, where) -> None:
    """Refuse a data set made by another generator, by another revision of a built-in category's generator
    (``category_revision``, 1 when absent; :attr:`ucope.objects.categories.CategorySpec.revision`), under
    other conventions or in another shard format, naming both versions (:class:`DataError`). A category of
    your own is checked by the spec its ``meta.json`` records, not here."""
    checks = [  # (what, theirs, ours)
        (key.replace("_", " "), meta.get(key), ours)
        for key, ours in (
            ("format_version", DATA_FORMAT_VERSION),
            ("generator_version", GENERATOR_VERSION),
            ("conventions_version", CONVENTIONS_VERSION),
        )
    ]
    category = meta.get("category")
    if category in CATEGORY_NAMES and "spec" not in meta:
        checks.append((f"{category} generator revision", meta.get("category_revision", 1), get_category(category).revision))
    for what, theirs, ours in checks:
        if str(theirs) != str(ours):
            raise DataError(
                f"{where}: the data set has {what} {theirs}, this ucope uses {ours}; "
                "generate it again with this ucope (or use the ucope that made it)"
            )


class SyntheticDataset(Sequence):
    """A generated data set on disk, as a read-only sequence of sample dicts (see
    :mod:`ucope.data.sample`). Shards are read lazily; the last ``cache_shards`` read are kept in
    memory (``None``: every shard, for training's random access, see :func:`load_dataset`)."""

    def __init__(self, root: str | Path, cache_shards: int | None = 4):
        self.root = Path(root)
        if not self.root.is_dir():
            raise DataError(f"data set folder {self.root} does not exist")
        self.meta = read_json(self.root / "meta.json")
        where = self.root / "meta.json"
        if not isinstance(self.meta, dict):
            raise DataError(f"{where} is not a ucope data set description (not a JSON object)")
        check_versions(self.meta, where)
        try:
            self._num = int(self.meta["num"])
            self._shard_size = int(self.meta["shard_size"])
            self.category = str(self.meta["category"])
            self._num_parts = int(self.meta["num_parts"])
        except (KeyError, ValueError, TypeError) as e:
            raise DataError(f"{where} is not a ucope data set description ({type(e).__name__}: {e})") from None
        if self._num <= 0 or self._shard_size <= 0 or self._num_parts <= 0:
            raise DataError(
                f"{where}: num ({self._num}), shard_size ({self._shard_size}) and num_parts ({self._num_parts}) "
                "must be positive"
            )
        n_shards = -(-self._num // self._shard_size)
        missing = [s for s in range(n_shards) if not (self.root / shard_name(s)).exists()]
        if missing:
            raise DataError(
                f"data set {self.root} is incomplete: {len(missing)} of {n_shards} shards missing "
                f"(first: {shard_name(missing[0])}); re-run the same `ucope generate` command to finish it"
            )
        self._cache: OrderedDict[int, list[dict]] = OrderedDict()
        self._cache_size = n_shards if cache_shards is None else max(1, int(cache_shards))

    @property
    def camera(self) -> PinholeCamera:
        return PinholeCamera.from_dict(self.meta["view"]["camera"])

    @property
    def num_parts(self) -> int:
        return self._num_parts

    def __len__(self) -> int:
        return self._num

    def _shard(self, s: int) -> list[dict]:
        if s in self._cache:
            self._cache.move_to_end(s)
            return self._cache[s]
        path = self.root / shard_name(s)
        lo = s * self._shard_size
        expect = min(self._num, lo + self._shard_size) - lo
        samples = read_shard(path, num_parts=self._num_parts, category=self.category)
        if len(samples) != expect:
            raise DataError(f"shard {path} holds {len(samples)} samples, meta.json says {expect}")
        got = [int(x["index"]) for x in samples]
        if got != list(range(lo, lo + expect)):
            raise DataError(f"shard {path} holds samples {got[0]}..{got[-1]}, meta.json puts {lo}..{lo + expect - 1} there")
        self._cache[s] = samples
        while len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return samples

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        i = int(i)
        if i < 0:
            i += self._num
        if not 0 <= i < self._num:
            raise IndexError(f"sample index {i} out of range for a data set of {self._num}")
        s = i // self._shard_size
        return dict(self._shard(s)[i - s * self._shard_size])

    def __repr__(self) -> str:
        return (
            f"SyntheticDataset({str(self.root)!r}, category={self.category!r}, split={self.meta.get('split')!r}, num={self._num})"
        )


def load_dataset(root: str | Path, cache_bytes: int = 0) -> SyntheticDataset:
    """Open a data set made by ``ucope generate`` (folder with ``meta.json`` and shards).

    Args:
        cache_bytes: keep every shard in memory once read when the shard files add up to at most this
            many bytes (training reads samples in random order: re-reading a 100-sample shard for each
            sample costs more than the training step); otherwise (default) only the last 4.
    """
    root = Path(root)
    size = sum(f.stat().st_size for f in root.glob("shard_*.npz")) if cache_bytes > 0 and root.is_dir() else None
    return SyntheticDataset(root, cache_shards=None if size is not None and size <= cache_bytes else 4)
