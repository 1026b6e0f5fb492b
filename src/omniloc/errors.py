"""Exceptions raised by omniloc.

Every error omniloc raises on purpose is an :class:`OmnilocError`. Errors caused by bad input
also subclass :class:`ValueError`, so callers that already catch ``ValueError`` keep working.
The command-line tool catches :class:`OmnilocError` and prints its message on one line.
"""

from __future__ import annotations

__all__ = [
    "DegenerateGeometryError",
    "InputError",
    "MapError",
    "ObservationError",
    "OmnilocError",
    "VisionError",
]


class OmnilocError(Exception):
    """Base class of every error omniloc raises deliberately."""


class InputError(OmnilocError, ValueError):
    """Input that omniloc cannot use: wrong shape, non-finite values, unreadable files."""


class MapError(InputError):
    """A landmark map that is malformed (duplicate ids or positions, too few landmarks...)."""


class ObservationError(InputError):
    """Bearings that are malformed (non-finite, too few, more than the map has landmarks...)."""


class DegenerateGeometryError(OmnilocError, ValueError):
    """No pose exists for the given landmark/bearing pairs (the message says which case)."""


class VisionError(InputError):
    """An image omniloc cannot read or interpret (no mirror rim, absurd parameters...)."""
