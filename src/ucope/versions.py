"""Version and format constants, in one module that imports nothing (every layer may read it).

Each file ucope writes names its format, and each reader checks it with both versions named in the error:

* :data:`CONVENTIONS_VERSION`: frames, units and per-category canonical frames (docs/conventions.md);
* :data:`GENERATOR_VERSION`: the procedural generators and the renderer (data sets record it); under it each
  built-in category's generator has a revision of its own (``CategorySpec.revision``, recorded as
  ``category_revision``: raised when only that category's shapes change, so the others' data sets stay valid);
* :data:`DATA_FORMAT_VERSION`: the shard layout of a data set (``meta.json`` + ``shard_NNNNN.npz``);
* :data:`MODEL_FORMAT`, :data:`CHECKPOINT_FORMAT`, :data:`RESULT_FORMAT`, :data:`RESULTS_FORMAT`: the
  JSON format tags of a model, a training checkpoint, a pose result and the results of one frame.
"""

from __future__ import annotations

__all__ = [
    "__version__",
    "CONVENTIONS_VERSION",
    "GENERATOR_VERSION",
    "DATA_FORMAT_VERSION",
    "MODEL_FORMAT",
    "CHECKPOINT_FORMAT",
    "RESULT_FORMAT",
    "RESULTS_FORMAT",
]

__version__ = "0.2.0"

CONVENTIONS_VERSION = "1"
"""Version of the frames / units / per-category canonical frames documented in docs/conventions.md."""

GENERATOR_VERSION = "2"
"""Version of the procedural generators and renderer; data sets record it in meta.json.
2: every category draws one of 4-6 shape families with real-world size ranges (docs/conventions.md), 1-2
of them held out for the new ``ood`` split (scaled 0.5-2x); per-category camera distances follow; views
may get a distractor right next to the object (``GenerateConfig.adjacent_distractor``) and keep their
background pool."""

DATA_FORMAT_VERSION = 2
"""Version of the on-disk shard layout (:mod:`ucope.data.shards`); 2: optional background pools."""

MODEL_FORMAT = "ucope-model/2"
"""Format tag of a model JSON (:mod:`ucope.model.checkpoint`); 2: the category priors live in the model."""

CHECKPOINT_FORMAT = "ucope-checkpoint/2"
"""Format tag of a training checkpoint JSON."""

RESULT_FORMAT = "ucope-result/2"
"""Format tag of a pose result JSON (:mod:`ucope.estimation.result`); 2: ``estimates``, how many the search made."""

RESULTS_FORMAT = "ucope-results/1"
"""Format tag of the JSON of every object's result in one frame (:mod:`ucope.estimation.frame`)."""
