"""No command overwrites what it reads, its database, or another of its own outputs.

Each command declares which of its arguments name files it reads and files it writes
(runners.cli.args.files); runners.cli.parser.main checks them with ``check`` before the command
runs, and a command that learns of more inputs as it goes (the record file a system file names,
say) checks again with ``refuse``. Paths are compared as the file system resolves them (symbolic
links followed, ``..`` resolved; an existing file also by inode, so a hard link is the same file).
A refusal is one line (ValueError, exit 2) and nothing has been written.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Iterable, Mapping

DEFAULT_DB = "rocking.db"  # db.session.DEFAULT_URL's file, without importing SQLAlchemy


def sqlite_path(url: str | None) -> str | None:
    """The SQLite file a --db value names (None: ROCKING_DB, else rocking.db), or None for a
    database that is not a file (a server's URL, an in-memory SQLite)."""
    url = url or os.environ.get("ROCKING_DB") or f"sqlite:///{DEFAULT_DB}"
    if "://" not in url:
        return url
    scheme, _, rest = url.partition("://")
    if not scheme.split("+")[0] == "sqlite":
        return None
    path = rest.split("?", 1)[0]
    if not path.startswith("/") or path in ("/", "/:memory:"):
        return None
    return path[1:]  # sqlite:///rel.db -> rel.db, sqlite:////abs.db -> /abs.db


def _same(a: str, b: str) -> bool:
    pa, pb = Path(a), Path(b)
    try:
        if pa.exists() and pb.exists():
            return os.path.samefile(pa, pb)
    except OSError:
        pass
    return os.path.realpath(pa) == os.path.realpath(pb)


def refuse(writes: Mapping[str, str | None], reads: Mapping[str, str | None] | None = None,
           db: str | None = None, database: bool = True) -> None:
    """ValueError, in one line, if a file in `writes` (option label -> path) is one of `reads`,
    the SQLite file of database `db` (a --db value; skipped when `database` is False: the command
    uses none) or another entry of `writes`."""
    outs = [(label, str(path)) for label, path in writes.items() if path]
    ins = [(label, str(path)) for label, path in (reads or {}).items() if path]
    db_file = sqlite_path(db) if database else None
    for i, (label, path) in enumerate(outs):
        for other, second in outs[:i]:
            if _same(path, second):
                raise ValueError(f"{other} and {label} both name {path}: the second would overwrite the first; "
                                 "give each its own file")
        for other, source in ins:
            if _same(path, source):
                raise ValueError(f"{label} {path} is the {other} this command reads: it would be overwritten; "
                                 "give another file")
        if db_file is not None and _same(path, db_file):
            raise ValueError(f"{label} {path} is the database this command uses ({db_file}): it would be "
                             "overwritten; give another file")


def check(args: argparse.Namespace) -> None:
    """refuse() for the files a parsed command line declares (runners.cli.args.files)."""
    declared = getattr(args, "_files", None)
    if not declared:
        return
    reads, writes = declared

    def named(entries: Iterable[tuple[str, str]]) -> dict[str, str | None]:
        out: dict[str, str | None] = {}
        for dest, label in entries:
            value = getattr(args, dest, None)
            for k, v in enumerate(value if isinstance(value, (list, tuple)) else [value]):
                if isinstance(v, str) and v and not v.isdecimal():  # (an id or 'latest' is not a file)
                    out[label if k == 0 else f"{label} ({k + 1})"] = v
        return out

    ins = {k: v for k, v in named(reads).items() if v is not None and Path(v).is_file()}
    refuse(named(writes), ins, getattr(args, "db", None), database=hasattr(args, "db"))
