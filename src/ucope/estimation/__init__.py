"""Estimation: from what a user holds (a cloud, a depth frame) to a :class:`PoseResult`.

The pipeline on top of the network (:mod:`ucope.model`) and the voting maths (:mod:`ucope.voting`):

* :class:`Estimator` (:mod:`.estimator`): load a model, predict on a cloud or an RGB-D frame;
* :mod:`.inputs`: checking and cleaning input clouds, back-projecting depth images;
* :class:`PoseResult` (:mod:`.result`): the result and its stable JSON form (``ucope-result/1``);
* :mod:`.draw`: pictures of results.
"""

from __future__ import annotations

from .estimator import Estimator
from .inputs import MIN_POINTS, label_points, prepare_points, rgbd_points
from .result import JointEstimate, PartEstimate, PoseResult

__all__ = [
    "Estimator",
    "PoseResult",
    "PartEstimate",
    "JointEstimate",
    "MIN_POINTS",
    "prepare_points",
    "rgbd_points",
    "label_points",
]
