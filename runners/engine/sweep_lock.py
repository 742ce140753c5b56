"""Which stored sweeps a live process is running: a lock each runner holds while it runs a sweep.

A sweep's row says ``running`` from the moment a runner starts it; a runner that stops marks it
``interrupted``, ``stopped`` or ``done``. One that cannot (its database failed: a full disk, a
server that went away, a file made read-only; or the process was killed outright) leaves
``running`` behind. So a runner also holds a lock that the operating system or the database
server releases when the runner ends, whatever ends it, and readers believe ``running`` only
while someone holds that lock:

- SQLite: a shared flock(2) on the file ``DATABASE.sweep-ID.running`` beside the database (several
  runners of one sweep, concurrent resumes, share it); a reader tries an exclusive lock on it
  without waiting. The last runner removes the file; a killed one leaves it, unlocked.
- PostgreSQL: a shared session-level advisory lock (LOCK_SPACE, sweep id) on a connection of its
  own; a reader looks for it in pg_locks, without taking any lock.
- Other databases cannot tell: their stored status is shown as it is.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from typing import Iterable, Iterator

from sqlalchemy import text
from sqlalchemy.orm import sessionmaker

from db.session import sqlite_file

LOCK_SPACE = 0x726F636B  # the first key of the sweeps' advisory locks ("rock"): other programs' keys differ


def _lock_path(database: str, sweep_id: int) -> str:
    return f"{database}.sweep-{sweep_id}.running"


def _key(sweep_id: int) -> int:
    """The advisory lock's second key: an int4, as PostgreSQL's two-key form takes."""
    return sweep_id % 2 ** 31


@contextlib.contextmanager
def running(factory: sessionmaker, sweep_id: int) -> Iterator[None]:
    """Hold the lock that says this process is running sweep `sweep_id` while the block runs
    (it may be taken again, nested, by the same or another process). OSError, in one line, where
    the lock cannot be taken (an SQLite database whose folder cannot hold its lock file)."""
    engine = factory.kw["bind"]
    path = sqlite_file(engine)
    if path is not None:
        with _file_lock(_lock_path(path, sweep_id)):
            yield
    elif engine.dialect.name == "postgresql":
        with _advisory_lock(engine, sweep_id):
            yield
    else:
        yield


@contextlib.contextmanager
def _file_lock(path: str) -> Iterator[None]:
    while True:  # until the file locked is the one the name names (the last runner of a sweep removes it)
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise OSError(f"cannot create {path}, which says that the sweep is running: {exc.strerror}") from None
        fcntl.flock(fd, fcntl.LOCK_SH)
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        yield
    finally:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # the last holder: the file goes
            with contextlib.suppress(OSError):
                os.unlink(path)
        except OSError:
            pass  # another runner (or a reader looking) holds it: it stays
        os.close(fd)


@contextlib.contextmanager
def _advisory_lock(engine, sweep_id: int) -> Iterator[None]:
    conn = engine.connect()
    try:
        conn.execute(text("SELECT pg_advisory_lock_shared(:space, :key)"), {"space": LOCK_SPACE, "key": _key(sweep_id)})
        conn.commit()
        yield
    finally:
        try:  # (the lock outlives the connection's return to the pool: release it)
            conn.execute(text("SELECT pg_advisory_unlock_shared(:space, :key)"),
                         {"space": LOCK_SPACE, "key": _key(sweep_id)})
            conn.commit()
        except Exception:  # the server went away, and the lock with it
            conn.invalidate()
        conn.close()


def held(factory: sessionmaker, sweep_ids: Iterable[int]) -> set[int] | None:
    """The sweeps among `sweep_ids` that a live process is running (holds the lock of), or None
    where the database cannot tell. Reads only: takes no lock it keeps, writes nothing."""
    ids = list(sweep_ids)
    engine = factory.kw["bind"]
    path = sqlite_file(engine)
    if path is not None:
        return {i for i in ids if _file_held(_lock_path(path, i))}
    if engine.dialect.name == "postgresql":
        if not ids:
            return set()
        with engine.connect() as conn:
            keys = set(conn.execute(text(
                "SELECT objid::bigint FROM pg_locks WHERE locktype = 'advisory' AND granted AND objsubid = 2 "
                "AND classid = :space AND database = (SELECT oid FROM pg_database WHERE datname = current_database())"),
                {"space": LOCK_SPACE}).scalars())
        return {i for i in ids if _key(i) in keys}
    return None


def _file_held(path: str) -> bool:
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:  # no such file: no runner (one cannot run without it)
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except BlockingIOError:
        return True
    finally:
        os.close(fd)


def shown_status(factory: sessionmaker, statuses: dict[int, str]) -> dict[int, str]:
    """The statuses of sweeps (id -> stored status) as they are: a sweep stored as running that no
    live process runs stopped without saying so (its database failed, or its process was killed):
    "stopped"."""
    maybe = [i for i, s in statuses.items() if s == "running"]
    alive = held(factory, maybe) if maybe else set()
    if alive is None:
        return dict(statuses)
    return {i: "stopped" if i in maybe and i not in alive else s for i, s in statuses.items()}


def remove_leftover(factory: sessionmaker, sweep_id: int) -> None:
    """Remove the lock file a killed runner of a deleted sweep left (SQLite; nothing elsewhere)."""
    path = sqlite_file(factory.kw["bind"])
    if path is not None and not _file_held(_lock_path(path, sweep_id)):
        with contextlib.suppress(OSError):
            os.unlink(_lock_path(path, sweep_id))
