"""Checks of the Python API's arguments: numbers (Python's or numpy's scalars), whole numbers,
texts, paths. Each returns the value as a plain Python type or raises
:class:`runners.errors.ArgumentError` with a one-line message naming the argument and what it
takes.

A number is any ``numbers.Real`` (int, float, numpy's np.floating and np.integer scalars,
fractions...) except bool: True is not 1 s. A whole number is a ``numbers.Integral`` (int,
np.int64, ...), again not bool.
"""

from __future__ import annotations

import math
import numbers
import os
from typing import Any

from runners.errors import ArgumentError


def _shown(value: Any) -> str:
    """The value in a message: its repr, cut to one short line."""
    text = repr(value).replace("\n", " ")
    return text if len(text) <= 60 else text[:57] + "..."


def is_number(value: Any) -> bool:
    """Whether `value` is a real number (numpy scalars included, bool excluded)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_whole(value: Any) -> bool:
    """Whether `value` is an integer type (int, np.int64, ...; bool excluded)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def number(value: Any, name: str, what: str = "a finite number") -> float:
    """`value` as a float: a finite real number, else ArgumentError."""
    if not is_number(value) or not math.isfinite(float(value)):
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return float(value)


def positive(value: Any, name: str, what: str = "a finite number > 0") -> float:
    """`value` as a float: a finite real number > 0, else ArgumentError."""
    x = number(value, name, what)
    if not x > 0:
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return x


def whole(value: Any, name: str, minimum: int | None = None) -> int:
    """`value` as an int: an integer (int or numpy integer, not bool, not 1.0) of at least
    `minimum`, else ArgumentError."""
    what = "a whole number" if minimum is None else f"a whole number >= {minimum}"
    if not is_whole(value) or (minimum is not None and int(value) < minimum):
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return int(value)


def text(value: Any, name: str, what: str = "a text (str)") -> str:
    """`value` if it is a non-empty str, else ArgumentError."""
    if not isinstance(value, str) or not value.strip():
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return value


def flag(value: Any, name: str) -> bool:
    """`value` if it is True or False (or numpy's bool_), else ArgumentError."""
    if isinstance(value, bool) or (type(value).__module__ == "numpy" and type(value).__name__ in ("bool", "bool_")):
        return bool(value)  # (numpy 2 names its bool scalar numpy.bool, numpy 1 numpy.bool_)
    raise ArgumentError(f"{name} must be True or False, got {_shown(value)}")


def path(value: Any, name: str, what: str = "a path (str or pathlib.Path)") -> str:
    """`value` as a str path: a non-empty str or an os.PathLike, else ArgumentError."""
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if isinstance(value, bytes) or not isinstance(value, str) or not value.strip():
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return value


def optional(check, value: Any, name: str, *args: Any) -> Any:
    """None, or `value` checked by `check(value, name, *args)`."""
    return None if value is None else check(value, name, *args)


def database_url(value: Any, name: str = "db") -> str | None:
    """A database: None (the default), an SQLAlchemy URL or an SQLite file's path."""
    if value is None or isinstance(value, str):  # (the database layer judges the text: empty, in-memory...)
        return value
    return path(value, name, "an SQLAlchemy URL or an SQLite file's path (str), or None for the default")


def names(value: Any, name: str, what: str) -> list[str]:
    """A list of texts from a sequence of str (not a str itself: that is one name)."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)) or \
            not all(isinstance(v, str) and v.strip() for v in value):
        raise ArgumentError(f"{name} must be {what}, got {_shown(value)}")
    return list(value)
