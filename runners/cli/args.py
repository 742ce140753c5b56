"""Argument types and the parser class of the ``runners`` command line: every bad
argument is refused by argparse itself, in one line, before any work is done."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
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


def _writable(text: str, path) -> None:
    """Refuse a file (or folder) that exists and may not be written, or whose folder (the nearest
    that exists: the rest would be made) may not be written into: the command would fail after its
    work. (For root, os.access allows nearly everything: runners.engine.files.staged and the
    writers then fail in one line.)"""
    where = path if path.exists() else next((p for p in path.parents if p.exists()), None)
    if where is not None and not os.access(where, os.W_OK):
        what = "it may not be written" if where == path else f"its folder {where} may not be written into"
        raise argparse.ArgumentTypeError(f"{text!r}: {what} (permission denied)")


def output_file(text: str):
    """A file to write (a figure, a recording, an export): not a folder, its folder not a file,
    not a device or pipe, and writable (the file, else its folder); through a symbolic link, the
    file it points to. Its folder, if missing, is created once the whole command line has been
    checked (make_folders), as a folder output and a recording's folder are."""
    from pathlib import Path

    path = Path(text)
    if text == "-":  # (not standard output: every such option writes files, and a run's export writes two)
        raise argparse.ArgumentTypeError("'-' would be a file named '-' here, not standard output: give a file's path")
    try:
        if not text or path.is_dir() or text.endswith(("/", "\\")):
            raise argparse.ArgumentTypeError(f"{text!r} is a folder: give a file name")
        if path.exists() and not path.resolve().is_file():  # a device, a pipe, a socket: never replaced
            raise argparse.ArgumentTypeError(f"{text!r} exists and is not a regular file")
        _parents_are_folders(text, path)
        _writable(text, path)
        return str(path.resolve()) if path.is_symlink() else text
    except OSError as exc:
        raise _unusable(text, exc) from None


@contextlib.contextmanager
def output_folders(args: argparse.Namespace):
    """Around a command's work: first create the missing folders of the files its parsed command
    line writes (those it declares, files()), as a folder output (folder) and a recording's are
    made; after a failure, remove those of them that stayed empty. ValueError, in one line naming
    the option, for a folder that cannot be made (before any work)."""
    from pathlib import Path

    made: list[Path] = []
    for dest, label in (getattr(args, "_files", None) or ((), ()))[1]:
        value = getattr(args, dest, None)
        for path in value if isinstance(value, (list, tuple)) else [value]:
            if not isinstance(path, str) or not path:
                continue
            parent = Path(path).parent
            missing = [p for p in (parent, *parent.parents) if not p.exists()]
            try:
                parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                _remove_empty(made)
                raise ValueError(f"{label}: cannot write {path}: its folder {parent} cannot be created "
                                 f"({exc.strerror or exc})") from None
            made.extend(missing)
    try:
        yield
    except BaseException:
        _remove_empty(made)
        raise


def _remove_empty(folders: list) -> None:
    """Remove the folders that are empty, deepest first (a folder written into stays): a folder
    made for one output may hold another's (--ssp new/a/x.ssp --csv new/b/x.csv: new holds both)."""
    for path in sorted(folders, key=lambda p: len(os.path.abspath(p).split(os.sep)), reverse=True):
        with contextlib.suppress(OSError):
            path.rmdir()


def folder(text: str) -> str:
    """A folder to write into (created if missing): not a file, nor inside one, and writable
    (itself, else the nearest folder that holds it)."""
    from pathlib import Path

    path = Path(text)
    try:
        if not text or (path.exists() and not path.is_dir()):
            raise argparse.ArgumentTypeError(f"{text!r} is not a folder")
        _parents_are_folders(text, path)
        _writable(text, path)
        return text
    except OSError as exc:
        raise _unusable(text, exc) from None


DB_HELP = "database URL or SQLite file (default: ROCKING_DB, else sqlite:///rocking.db)"  # = db.session.DB_HELP,
# copied so that building the parser does not import SQLAlchemy and Alembic (tests/test_cli_conventions.py checks)
FMU_HELP = "FMU to use (default: ROCKING_FMU, else build/RockingBlock.fmu, built if needed)"


def object_id(text: str) -> int | str:
    """A stored run's, sweep's or measurement's id: a whole number, or 'latest' (the newest);
    ids beyond 64 bits pass, and then name no row."""
    if text == "latest":
        return text
    if not text.isdecimal():
        raise argparse.ArgumentTypeError(f"{text!r} is not an id (a whole number, or 'latest')")
    return int(text)


class Once(argparse.Action):
    """An option that takes one value and may be given once: a second one is refused (argparse
    would keep the last and drop the first without a word)."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = getattr(namespace, "_once", None) or {}
        if self.dest in given:
            raise argparse.ArgumentError(self, f"given twice ({given[self.dest]} and {values}): give it once")
        given[self.dest] = values
        namespace._once = given
        setattr(namespace, self.dest, values)


class Renamed(argparse.Action):
    """An option's former spelling: it still works, stores into the new option's dest, and
    leaves a one-line note (printed after parsing, unless --quiet)."""

    def __init__(self, option_strings, dest, new: str, value=None, **kw):
        self.new, self.value = new, value
        kw.setdefault("help", argparse.SUPPRESS)
        if value is not None:  # a former flag: takes no argument
            kw["nargs"] = 0
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, self.value if self.value is not None else values)
        renamed = getattr(namespace, "_renamed", None) or []
        renamed.append(f"{option_string} is now {self.new}")
        namespace._renamed = renamed


def renamed(p: argparse.ArgumentParser, old: str, new: str, dest: str, value=None, **kw) -> None:
    """Accept `old` as a hidden, deprecated spelling of `new` (same dest)."""
    p.add_argument(old, dest=dest, action=Renamed, new=new, value=value, default=argparse.SUPPRESS, **kw)


def common(p: argparse.ArgumentParser, json: bool = True, db: bool = False, fmu: bool = False,
           fmu_help: str = FMU_HELP) -> argparse.ArgumentParser:
    """The options every command spells the same way: --json, --quiet, --db, --fmu."""
    if json:
        p.add_argument("--json", action="store_true",
                       help="print the result as one JSON document on stdout (notes and progress go to stderr)")
    p.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                   help="no progress bars and no notes: only results and errors")
    if db:
        p.add_argument("--db", help=DB_HELP)
    if fmu:
        p.add_argument("--fmu", help=fmu_help)
    return p


def files(p: argparse.ArgumentParser, reads: tuple = (), writes: tuple = ()) -> None:
    """Declare which of a command's arguments (by dest, or (dest, label)) name files it reads and
    files it writes: runners.cli.clobber.check refuses, before the command runs, an output that is
    an input, the database or another output. Each is named in messages by its label, else as the
    user spelt it (its first long option; a positional by its dest). tests/test_cli_conventions.py
    checks that every declared dest exists and that every option of type output_file is declared."""
    def entry(item) -> tuple[str, str]:
        dest, given = (item, None) if isinstance(item, str) else item
        for action in p._actions:
            if action.dest == dest and not isinstance(action, Renamed):
                if given:
                    return dest, given
                if action.option_strings:
                    return dest, next((o for o in action.option_strings if o.startswith("--")),
                                      action.option_strings[0])
                return dest, dest.replace("_", " ")
        return dest, given or "--" + dest.replace("_", "-")  # an option common() adds later (--fmu)

    p.set_defaults(_files=([entry(d) for d in reads], [entry(d) for d in writes]))


FIGURE_SUFFIXES = (".png", ".pdf", ".svg")  # what a figure may be written as (matplotlib's formats for reports)


def figure_file(text: str):
    """A figure to write: an output file (output_file) named .png, .pdf or .svg, which sets its
    format; any other name is refused before any work (matplotlib would add .png to a name without
    one, or refuse the format after the work)."""
    from pathlib import Path

    path = output_file(text)
    if Path(path).suffix.lower() not in FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(f"{text!r}: a figure is written as {', '.join(FIGURE_SUFFIXES)}: give a "
                                         f"file name ending in one of them (e.g. {Path(text).stem or 'figure'}.png)")
    return path
