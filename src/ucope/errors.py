"""Exceptions raised by ucope.

Every error a user can trigger with bad input derives from :class:`UcopeError`, so a caller can catch
one type; each also derives from the matching built-in (``ValueError``, ``FileNotFoundError``...) so that
generic handlers keep working.
"""

from __future__ import annotations


class UcopeError(Exception):
    """Base class of every error ucope raises on purpose."""


class InputError(UcopeError, ValueError):
    """An argument has the wrong shape, type or value (empty cloud, NaN, unknown name...)."""


class DataError(UcopeError, OSError):
    """A file on disk is missing, truncated, corrupt or not what it claims to be."""


class UnknownCategoryError(InputError, KeyError):
    """A category name that is not registered; the message lists the valid names."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""
