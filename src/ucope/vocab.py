"""The shared vocabulary of every layer: joint types and part symmetries.

* :class:`JointType`: ``REVOLUTE`` (state in radians), ``PRISMATIC`` (metres) or ``FIXED``; its integer
  value is the code stored in data sets (``joint_type`` arrays) and its lower-case name the word stored
  in JSON files.
* Part symmetry: ``"none"`` or ``"y"`` (continuous rotational symmetry about the part's own y axis);
  :data:`SYMMETRIES` lists them, :func:`parse_symmetry` checks one.
* The names of the network's per-pair outputs that the voting reads (:data:`VOTE_HEADS`,
  :data:`AXIS_HEADS`): the contract between :mod:`ucope.model` and :mod:`ucope.voting`.

Imports nothing from ucope but :mod:`ucope.errors`.
"""

from __future__ import annotations

import enum

from .errors import InputError

__all__ = ["JointType", "JOINT_TYPES", "SYMMETRIES", "parse_symmetry", "VOTE_HEADS", "AXIS_HEADS", "MIN_POINTS"]

MIN_POINTS = 32
"""The fewest finite points a cloud needs to be estimated (and a part of it to be left out or kept)."""


class JointType(enum.IntEnum):
    """A joint's type. ``int(t)`` is its data-set code, ``t.label`` its JSON word."""

    REVOLUTE = 0
    PRISMATIC = 1
    FIXED = 2

    @property
    def label(self) -> str:
        """``"revolute"``, ``"prismatic"`` or ``"fixed"``."""
        return self.name.lower()

    @property
    def state_unit(self) -> str:
        """Unit of the joint state: ``"rad"`` (revolute), ``"m"`` (prismatic), ``""`` (fixed)."""
        return {JointType.REVOLUTE: "rad", JointType.PRISMATIC: "m"}.get(self, "")

    @classmethod
    def parse(cls, value) -> JointType:
        """A :class:`JointType` from itself, its code (``0``/``1``/``2``) or its word (``"revolute"``...).

        Raises :class:`ucope.errors.InputError` naming the accepted values otherwise."""
        if isinstance(value, cls):
            return value
        if isinstance(value, str):
            try:
                return cls[value.upper()]
            except KeyError:
                pass
        elif not isinstance(value, bool):
            try:
                code = int(value)
                if code == value:
                    return cls(code)
            except (TypeError, ValueError):
                pass
        raise InputError(f"joint type must be one of {', '.join(JOINT_TYPES)} (or codes 0-2), got {value!r}")


JOINT_TYPES = tuple(t.label for t in JointType)
"""The joint-type words in code order: ``("revolute", "prismatic", "fixed")``."""

SYMMETRIES = ("none", "y")
"""Part symmetry tags: ``"none"``, or ``"y"`` = continuous symmetry about the part's y axis."""


def parse_symmetry(value) -> str:
    """``value`` if it is one of :data:`SYMMETRIES`; else :class:`ucope.errors.InputError`."""
    if value not in SYMMETRIES:
        raise InputError(f"symmetry must be one of {SYMMETRIES}, got {value!r}")
    return value


VOTE_HEADS = ("mu_logits", "nu_logits", "gamma", "part_score")
"""Per-pair outputs every voting pair needs: centre bins, log-size offsets, part-score logit."""

AXIS_HEADS = ("alpha_logits", "beta_logits", "sign_logits")
"""Per-pair outputs only the pairs voting the axes need (an estimator computes them lazily for those)."""
