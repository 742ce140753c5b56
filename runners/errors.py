"""The one exception base class of the package.

Every error the package raises on purpose (a bad scene, a record file the FMU would refuse, a
database that cannot be used, an argument of the wrong type, ...) derives from
:class:`RockingError`, and its ``str()`` is one line that says what is wrong and, where it can,
what to do. ``except runners.RockingError`` catches them all; anything else is a defect.

This module imports nothing, so every layer (db, runners.engine, runners.analysis, runners.cli)
can use it without depending on another.
"""

from __future__ import annotations


class RockingError(Exception):
    """Base of every error the package raises on purpose; str() is a one-line message."""


class ArgumentError(RockingError, TypeError, ValueError):
    """An argument of the Python API has the wrong type or value; str() names it and what it takes."""


class FileError(RockingError, OSError):
    """A file or folder given to the Python API cannot be read (missing, a folder, not permitted)."""
