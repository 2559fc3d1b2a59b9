"""Samples generated on the fly: an endless, deterministic stream from a category generator.

:class:`GeneratedSamples` looks like a data set of ``epoch_size`` samples, but epoch ``e`` shows samples
``e * epoch_size ... (e + 1) * epoch_size - 1`` of an endless stream, so every epoch brings new object
instances and views. Sample ``j`` of the stream is :func:`ucope.data.generate.make_sample` ``j`` of the
data set ``(category, split, seed)``: exactly what ``ucope generate`` would write at index ``j``, on any
machine and in any worker process.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import InputError
from .generate import GenerateConfig, make_sample

__all__ = ["GeneratedSamples", "STREAM_LENGTH"]

STREAM_LENGTH = 10**12
"""The nominal length of a stream (sample indices are drawn below it)."""


class GeneratedSamples(Sequence):
    """An epoch-sized window on the endless sample stream of ``(category, split, seed)``.

    Args:
        category, split, seed: the stream (as for ``ucope generate``).
        epoch_size: samples per epoch.
        views_per_instance: consecutive views of each object instance.
        stretch, stretch_share: instances stretched (a share of them) by per-axis factors drawn in
            ``stretch`` ``(low, high)``, as :class:`GenerateConfig`'s; ``None``: as generated.
        config: optional :class:`GenerateConfig` overriding the defaults (its ``num`` is ignored; with it,
            ``stretch`` and ``stretch_share`` must be left at their defaults).

    Raises:
        InputError: a bad epoch size, range or share (named), or a stretch given beside ``config``.
    """

    def __init__(
        self,
        category: str,
        split: str = "train",
        seed: int = 0,
        epoch_size: int = 4000,
        views_per_instance: int = 8,
        config: GenerateConfig | None = None,
        stretch: tuple[float, float] | None = None,
        stretch_share: float = 1.0,
    ):
        if int(epoch_size) <= 0:
            raise InputError(f"epoch_size must be positive, got {epoch_size}")
        if config is None:
            config = GenerateConfig(
                category=category,
                split=split,
                seed=seed,
                num=STREAM_LENGTH,
                views_per_instance=views_per_instance,
                stretch=stretch,
                stretch_share=stretch_share,
            )
        elif stretch is not None or stretch_share != 1.0:
            raise InputError("give the stretch in the GenerateConfig (config=) or as arguments, not both")
        else:
            config = GenerateConfig(**{**config.__dict__, "num": STREAM_LENGTH})
        config.validate()
        self.config = config
        self.category = config.category
        self.epoch_size = int(epoch_size)
        self.epoch = 0

    @property
    def meta(self) -> dict:
        """The ``meta.json`` that ``ucope generate`` would write for this stream (its ``num`` nominal)."""
        return self.config.meta()

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def __len__(self) -> int:
        return self.epoch_size

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        i = int(i)
        if not 0 <= i < self.epoch_size:
            raise IndexError(f"index {i} out of range for an epoch of {self.epoch_size}")
        return make_sample(self.config, self.epoch * self.epoch_size + i)

    def __repr__(self) -> str:
        c = self.config
        return (
            f"GeneratedSamples({c.category!r}, split={c.split!r}, seed={c.seed}, "
            f"epoch_size={self.epoch_size}, epoch={self.epoch})"
        )
