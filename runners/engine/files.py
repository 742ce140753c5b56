"""The files a command or a run writes: never one it reads, its database or another of its
outputs (``refuse``), and each written whole or not at all (a new file beside the destination,
renamed onto it when complete: ``create_beside``, ``staged``).

Paths are compared as the file system resolves them (symbolic links followed, ``..`` resolved; an
existing file also by inode, so a hard link is the same file). A refusal is one line
(ArgumentError, a ValueError) and nothing has been written.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator, Mapping

from runners.errors import ArgumentError, FileError

DEFAULT_DB = "rocking.db"  # db.session.DEFAULT_URL's file, without importing SQLAlchemy


def create_beside(path: str | Path, suffix: str = "") -> tuple[int, str]:
    """A new file beside ``path`` (its descriptor, open for writing, and its name, ending in
    ``suffix``), to be renamed onto it: created with mode 0666 less the umask, as open() creates a
    file (a file of tempfile.mkstemp would keep its 0600, owner only)."""
    path = Path(path)
    for _ in range(100):
        tmp = str(path.parent / f".{path.name}.{os.urandom(6).hex()}{suffix}")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"cannot create a temporary file beside {path}")


@contextlib.contextmanager
def staged(paths: Mapping[str, str | Path | None]) -> Iterator[dict[str, str]]:
    """Temporary files to write instead of the files ``paths`` names (label, which messages name a
    file by -> path; None: not written), each beside its file and with its suffix (a writer may go
    by it), yielded by label: renamed onto their files when the block ends without an error,
    removed when it raises, so that a failure leaves every file as it was. FileError, in one line
    naming the file, when a temporary file cannot be made (a folder that takes no new file: /proc,
    /sys) or renamed."""
    temps: dict[str, str] = {}
    try:
        for label, path in paths.items():
            if path:
                temps[label] = _temporary(label, Path(path))
        yield dict(temps)
        for label, tmp in temps.items():
            _rename(label, tmp, Path(paths[label]))  # type: ignore[arg-type]
    finally:
        for tmp in temps.values():
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _temporary(label: str, path: Path) -> str:
    """The name of a new, empty file beside ``path`` (create_beside; through a symbolic link, beside
    the file it points to); FileError if none can be made."""
    try:
        fd, tmp = create_beside(os.path.realpath(path), path.suffix)
    except OSError as exc:
        raise FileError(f"cannot write {label} {path}: no file can be created in its folder {path.parent} "
                        f"({exc.strerror or exc})") from None
    os.close(fd)
    return tmp


def _rename(label: str, tmp: str, path: Path) -> None:
    """Move ``tmp`` onto ``path`` (through a symbolic link, onto the file it points to)."""
    try:
        os.replace(tmp, os.path.realpath(path))
    except OSError as exc:
        raise FileError(f"cannot write {label} {path}: {exc.strerror or exc}") from None


def default_fmu() -> str:
    """The FMU a run uses when none is given: ROCKING_FMU, else build/RockingBlock.fmu of this
    installation (runners.engine.fmu.fmu_path_from, without building it or importing fmpy)."""
    return os.environ.get("ROCKING_FMU") or str(Path(__file__).resolve().parents[2] / "build" / "RockingBlock.fmu")


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
    """Whether paths `a` and `b` name one file: by inode when both exist, else resolved."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.exists() and pb.exists():
            return os.path.samefile(pa, pb)
    except OSError:
        pass
    return os.path.realpath(pa) == os.path.realpath(pb)


def refuse(writes: Mapping[str, str | Path | None], reads: Mapping[str, str | Path | None] | None = None,
           db: str | None = None, database: bool = True, reader: str = "this command") -> None:
    """ArgumentError, in one line, if a file in `writes` (label -> path) is one of `reads`, the
    SQLite file of database `db` (a --db value; skipped when `database` is False: the command or
    run uses none) or another entry of `writes`. `reader` names what reads them in the message."""
    outs = [(label, str(path)) for label, path in writes.items() if path]
    ins = [(label, str(path)) for label, path in (reads or {}).items() if path]
    db_file = sqlite_path(db) if database else None
    for i, (label, path) in enumerate(outs):
        for other, second in outs[:i]:
            if _same(path, second):
                raise ArgumentError(f"{other} and {label} both name {path}: the second would overwrite the first; "
                                    "give each its own file")
        for other, source in ins:
            if _same(path, source):
                raise ArgumentError(f"{label} {path} is the {other} {reader} reads: it would be overwritten; "
                                    "give another file")
        if db_file is not None and _same(path, db_file):
            raise ArgumentError(f"{label} {path} is the database {reader} uses ({db_file}): it would be "
                                "overwritten; give another file")
