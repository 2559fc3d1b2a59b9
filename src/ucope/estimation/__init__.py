"""Estimation: from what a user holds (a cloud, a depth frame) to a :class:`PoseResult`.

On top of the network (:mod:`ucope.model`), the voting maths (:mod:`ucope.voting`) and the stages
(:mod:`ucope.stages`):

* :class:`Estimator` (:mod:`.estimator`): load a model, predict on a cloud or an RGB-D frame;
* :mod:`.pipeline`: a model's stage list, parameters and search policy as its card stores them;
* :mod:`.search`: how many estimates one view gets and which stands (:data:`FAST`: one);
* :mod:`.inputs`: checking and cleaning input clouds, back-projecting depth images;
* :class:`PoseResult` (:mod:`.result`): the result and its stable JSON form (``ucope-result/2``);
* :mod:`.draw`: pictures of results.
"""

from __future__ import annotations

from .estimator import Estimator
from .inputs import MIN_POINTS, label_points, prepare_points, rgbd_points
from .result import JointEstimate, PartEstimate, PoseResult
from .search import FAST

__all__ = [
    "Estimator",
    "FAST",
    "PoseResult",
    "PartEstimate",
    "JointEstimate",
    "MIN_POINTS",
    "prepare_points",
    "rgbd_points",
    "label_points",
]
