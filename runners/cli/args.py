"""Argument types and the parser class of the ``runners`` command line: every bad
argument is refused by argparse itself, in one line, before any work is done."""

from __future__ import annotations

import argparse
import math
import sys

class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (``error: ...``, exit 2), with where to look."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"error: {message} (see {self.prog} --help)", file=sys.stderr)
        sys.exit(2)


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def positive(text: str) -> float:
    """A finite number > 0 (times in s, steps, scales of work)."""
    x = _number(text)
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    return x


def finite(text: str) -> float:
    """Any finite number (e.g. a record's scale, which may be negative to flip it)."""
    x = _number(text)
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number")
    return x


def non_negative(text: str) -> float:
    """A finite number >= 0 (e.g. a noise's standard deviation)."""
    x = _number(text)
    if not (math.isfinite(x) and x >= 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number >= 0")
    return x


def tolerance(text: str) -> float:
    """A relative tolerance: finite, in (0, 0.1]."""
    x = _number(text)
    if not (math.isfinite(x) and 0 < x <= 0.1):
        raise argparse.ArgumentTypeError(f"{text!r} must be a tolerance in (0, 0.1]")
    return x


def count(text: str) -> int:
    """A whole number >= 1 (workers, repeats, chunk sizes, limits)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return n


def _parents_are_folders(text: str, path) -> None:
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise argparse.ArgumentTypeError(f"{text!r}: {parent} is a file, not a folder")
            return


def _unusable(text: str, exc: OSError) -> argparse.ArgumentTypeError:
    """A path the file system refuses (a name too long, a loop of links...)."""
    return argparse.ArgumentTypeError(f"{text[:60]!r}{'...' if len(text) > 60 else ''}: {exc.strerror}")


def output_file(text: str):
    """A file to write (a figure, a recording, an export): not a folder, its folder not a file,
    not a device or pipe; through a symbolic link, the file it points to."""
    from pathlib import Path

    path = Path(text)
    try:
        if not text or path.is_dir() or text.endswith(("/", "\\")):
            raise argparse.ArgumentTypeError(f"{text!r} is a folder: give a file name")
        if path.exists() and not path.resolve().is_file():  # a device, a pipe, a socket: never replaced
            raise argparse.ArgumentTypeError(f"{text!r} exists and is not a regular file")
        _parents_are_folders(text, path)
        return str(path.resolve()) if path.is_symlink() else text
    except OSError as exc:
        raise _unusable(text, exc) from None


def folder(text: str) -> str:
    """A folder to write into (created if missing): not a file, nor inside one."""
    from pathlib import Path

    path = Path(text)
    try:
        if not text or (path.exists() and not path.is_dir()):
            raise argparse.ArgumentTypeError(f"{text!r} is not a folder")
        _parents_are_folders(text, path)
        return text
    except OSError as exc:
        raise _unusable(text, exc) from None
