"""Engines and sessions: SQLite by default (rocking.db in the working folder, WAL mode,
foreign keys on), any SQLAlchemy URL through --db or ROCKING_DB; the schema is brought
to the newest Alembic revision on opening.

Opening checks the database before anything writes to it: a file that is not an SQLite
database or was cut short, a schema from a newer version of the tool (an unknown Alembic
revision), and a schema at the newest revision that lacks a table or column are one-line
errors (DatabaseError), and the file is left as it was. A database that cannot be written
(read-only file, folder or mount) is opened read-only and never migrated; commands that
write call require_writable first, so that they fail before doing any work."""

from __future__ import annotations

import contextlib
import fcntl
import math
import os
import re
import threading
import weakref
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

from sqlalchemy import URL, create_engine, event, inspect, make_url, text
from sqlalchemy.engine import Engine
from sqlalchemy.exc import ArgumentError, SQLAlchemyError
from sqlalchemy.orm import Session, sessionmaker

from runners.errors import RockingError

if TYPE_CHECKING:  # Alembic is imported where a schema is created or migrated, not to open an up-to-date one
    from alembic.config import Config

DEFAULT_URL = "sqlite:///rocking.db"
MIGRATIONS = Path(__file__).resolve().parent / "migrations"
MAX_ID = 2 ** 63 - 1  # ids are 64-bit integers at most (SQLite's INTEGER); larger ones name no row
BUSY_TIMEOUT = 60.0  # s a writer waits for another process's lock (ROCKING_DB_BUSY_TIMEOUT)
CONNECT_TIMEOUT = 5  # s a PostgreSQL server has to answer a new connection (connect_timeout in the URL sets it)
SQLITE_MAGIC = b"SQLite format 3\x00"
_READ_ONLY: weakref.WeakKeyDictionary[Engine, str] = weakref.WeakKeyDictionary()  # our read-only engines: their file


class DatabaseError(RockingError, RuntimeError):
    """The database cannot be opened or used; str() is a one-line message."""


DB_HELP = "database URL or SQLite file (default: ROCKING_DB, else sqlite:///rocking.db)"  # for --db


def database_url(arg: str | None = None) -> str:
    """--db, else ROCKING_DB, else rocking.db in the working folder. A value without
    "://" is a path to an SQLite file (results.db means sqlite:///results.db)."""
    if arg is not None and not arg.strip():
        raise DatabaseError("--db is empty: give a database URL or an SQLite file")
    url = arg or os.environ.get("ROCKING_DB") or DEFAULT_URL
    return url if "://" in url else f"sqlite:///{url}"


def busy_timeout() -> float:
    """Seconds an SQLite writer waits for a lock another process holds before giving up:
    ROCKING_DB_BUSY_TIMEOUT, else 60."""
    raw = os.environ.get("ROCKING_DB_BUSY_TIMEOUT", "").strip()
    if not raw:
        return BUSY_TIMEOUT
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise DatabaseError(f"ROCKING_DB_BUSY_TIMEOUT must be a number of seconds (0 or more), got {raw!r}")
    return value


def _sqlite_pragmas(busy_ms: int, readonly: bool):
    def on_connect(dbapi_connection, _record) -> None:
        cur = dbapi_connection.cursor()
        cur.execute("PRAGMA foreign_keys=ON")
        cur.execute(f"PRAGMA busy_timeout={busy_ms}")  # ms: concurrent writers wait instead of failing
        if readonly:  # no statement may write, not even the journal mode
            cur.execute("PRAGMA query_only=ON")
        else:
            cur.execute("PRAGMA journal_mode=WAL")
        cur.close()
    return on_connect


def connect_timeout(url: str | URL) -> float | None:
    """Seconds a PostgreSQL server (psycopg or psycopg2) has to answer a new connection: the
    URL's connect_timeout, else CONNECT_TIMEOUT; None for other databases. Without one, a
    server whose port accepts connections but never answers kept a command waiting 2.5 min."""
    try:
        u = make_url(url)
    except (ArgumentError, ValueError):  # make_engine says what is wrong with it
        return None
    if u.get_backend_name() != "postgresql" or u.get_driver_name() not in ("psycopg", "psycopg2"):
        return None
    given = u.query.get("connect_timeout")
    try:
        return float(given if isinstance(given, str) else given[-1]) if given else float(CONNECT_TIMEOUT)
    except ValueError:
        return None  # the driver says what is wrong with it


def make_engine(url: str | URL, *, readonly: bool = False) -> Engine:
    try:
        default = connect_timeout(url) is not None and "connect_timeout" not in make_url(url).query
        engine = create_engine(url, **({"connect_args": {"connect_timeout": CONNECT_TIMEOUT}} if default else {}))
    except (ArgumentError, ImportError, ValueError) as exc:
        raise DatabaseError(f"cannot use database URL {str(url)!r}: {exc}") from None
    if engine.dialect.name == "sqlite":
        busy_ms = min(round(busy_timeout() * 1000), 2 ** 31 - 1)
        event.listen(engine, "connect", _sqlite_pragmas(busy_ms, readonly))
    return engine


class RockingSession(Session):
    """A Session whose get() finds nothing for an id no row can have: beyond the 64-bit
    integers ids are stored as, which SQLite cannot even bind (runners db show run 1e30)."""

    def get(self, entity, ident, **kw):
        if isinstance(ident, int) and not isinstance(ident, bool) and not -MAX_ID - 1 <= ident <= MAX_ID:
            return None
        return super().get(entity, ident, **kw)


# ---------------------------------------------------------------------------------------------
# SQLite files: what they are, whether they can be written, and opening them read-only


def sqlite_file(engine: Engine) -> str | None:
    """The SQLite file behind an engine of ours (read-only ones included), as given; None for
    other databases, in-memory ones and URLs that are already SQLite URIs."""
    if engine in _READ_ONLY:
        return _READ_ONLY[engine]
    url = engine.url
    if engine.dialect.name != "sqlite" or not url.database or url.database == ":memory:" or url.query.get("uri"):
        return None
    return url.database


def display_url(engine: Engine) -> str:
    """The database's URL, password hidden (a read-only SQLite file's as if it were not)."""
    path = sqlite_file(engine)
    return f"sqlite:///{path}" if path is not None else engine.url.render_as_string(hide_password=True)


def database_name(engine: Engine) -> str:
    """The database in a message: the SQLite file, else the URL (password hidden)."""
    path = sqlite_file(engine)
    return path if path is not None else engine.url.render_as_string(hide_password=True)


def _check_file(path: str) -> bool:
    """True if the file holds a database; False if there is none yet (no file, or an empty one,
    which SQLite takes as a new database). A file that is not an SQLite database, or one cut
    short (fewer bytes than its header says, or not whole pages), is a DatabaseError: the
    file is only read here, so it is left as it was."""
    p = Path(path)
    try:
        if p.is_dir():
            raise DatabaseError(f"{path} is a folder, not an SQLite database file")
        st = p.stat()
        if st.st_size == 0:
            return False
        if (st.st_dev, st.st_ino) in _HEADERS_READ:
            return True
        # Closing a file descriptor of a database file releases every POSIX lock this process
        # holds on it, the locks of its open SQLite connections included (whoever opened them;
        # https://www.sqlite.org/howtocorrupt.html, 2.2): the descriptor the header is read
        # through stays open for the life of the process, and each file is read once.
        fd = os.open(path, os.O_RDONLY)
        _HEADER_FDS.append(fd)
        head = os.pread(fd, 100, 0)
        size = st.st_size
    except FileNotFoundError:
        return False
    except OSError as exc:
        raise DatabaseError(f"cannot read the database {path}: {exc.strerror}") from None
    if not head.startswith(SQLITE_MAGIC[:len(head)]) or len(head) < len(SQLITE_MAGIC):
        raise DatabaseError(f"{path} is not an SQLite database (it does not start as one); it was left untouched")
    if len(head) < 100:
        raise DatabaseError(f"the database {path} is damaged: it is cut short ({size} bytes, less than its "
                            "100-byte header); it was left untouched")
    page = int.from_bytes(head[16:18], "big")
    page = 65536 if page == 1 else page
    if page < 512 or page & (page - 1):
        raise DatabaseError(f"the database {path} is damaged: its header is invalid (page size {page}); "
                            "it was left untouched")
    if size % page:
        raise DatabaseError(f"the database {path} is damaged: it is cut short ({size} bytes, not a whole number "
                            f"of {page}-byte pages); it was left untouched")
    pages = int.from_bytes(head[28:32], "big")
    wal = Path(f"{path}-wal")
    pending_wal = wal.is_file() and wal.stat().st_size > 0  # a checkpoint may have been cut off: SQLite recovers
    if pages and head[24:28] == head[92:96] and size < pages * page and not pending_wal:
        raise DatabaseError(f"the database {path} is damaged: it is cut short ({size} bytes of the "
                            f"{pages * page} its header announces); it was left untouched")
    _HEADERS_READ.add((st.st_dev, st.st_ino))
    return True


_HEADERS_READ: set[tuple[int, int]] = set()  # (device, inode) of the database files _check_file has read
_HEADER_FDS: list[int] = []  # their descriptors, never closed (see _check_file)


def _unwritable(path: str) -> str | None:
    """Why runs cannot be written to this SQLite file (None if they can): no write permission
    on the file, or on its folder, where SQLite keeps the -wal and -shm files next to it."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        return f"its folder {folder} does not exist"
    try:
        read_only_fs = bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except OSError:
        read_only_fs = False
    why = "a read-only file system" if read_only_fs else "no write permission"
    if os.path.exists(path) and not os.access(path, os.W_OK):
        return f"the file is read-only ({why})"
    if not os.access(folder, os.W_OK | os.X_OK):
        if os.path.exists(path) and all(os.access(f"{path}-{x}", os.W_OK) for x in ("wal", "shm")):
            return None  # SQLite has the files it needs
        return f"its folder {folder} is read-only ({why}), and SQLite keeps its -wal and -shm files there"
    return None


def _readonly_engine(path: str) -> Engine:
    """A connection that never writes. A file that could be written is opened as usual with
    every statement refused (query_only), so that the last connection still tidies up the
    -wal and -shm files; one that cannot is opened in SQLite's read-only mode, or, when its
    folder cannot hold the -shm file a WAL reader needs and there is no -wal file to read,
    as immutable."""
    if _unwritable(path) is None:
        url = URL.create("sqlite", database=path)
    else:
        folder = os.path.dirname(os.path.abspath(path))
        wal = Path(f"{path}-wal")
        immutable = (not os.access(folder, os.W_OK | os.X_OK) and not Path(f"{path}-shm").exists()
                     and not (wal.is_file() and wal.stat().st_size > 0))
        mode = {"immutable": "1"} if immutable else {"mode": "ro"}
        url = URL.create("sqlite", database=f"file:{quote(path)}", query={**mode, "uri": "true"})
    engine = make_engine(url, readonly=True)
    _READ_ONLY[engine] = path
    return engine


# ---------------------------------------------------------------------------------------------
# the schema: which revision, which tables, and whether this version of the tool can use it


def _alembic_config() -> Config:
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    return cfg


@lru_cache(maxsize=None)
def _revisions() -> tuple[str, frozenset[str]]:
    """(newest revision, all revisions) of db/migrations."""
    from alembic.script import ScriptDirectory

    script = ScriptDirectory.from_config(_alembic_config())
    return script.get_current_head(), frozenset(r.revision for r in script.walk_revisions())


# revision = "0009", down_revision: str | None = '0008' (as db/migrations/script.py.mako writes them)
_REVISION_LINE = re.compile(r"^(revision|down_revision)(?:\s*:[^=\n]*)?\s*=\s*(None|\"\w+\"|'\w+')\s*$", re.MULTILINE)


@lru_cache(maxsize=None)
def _plain_head() -> str | None:
    """The newest revision of db/migrations read from its scripts' ``revision = "..."`` and
    ``down_revision = "..."`` lines without loading Alembic (which costs about 0.3 s of CPU, the
    scripts it loads included): the one revision no script names as its down_revision. None
    where a script does not say both plainly or the revisions are not one line of descent:
    Alembic decides then (_revisions)."""
    revisions, downs = set(), set()
    for script in (MIGRATIONS / "versions").glob("*.py"):
        if script.name == "__init__.py":
            continue
        found = dict(_REVISION_LINE.findall(script.read_text(encoding="utf-8")))
        if set(found) != {"revision", "down_revision"} or found["revision"] == "None":
            return None
        revisions.add(found["revision"].strip("\"'"))
        downs.add(found["down_revision"].strip("\"'"))
    heads = revisions - downs
    return heads.pop() if len(heads) == 1 and len(downs) == len(revisions) else None


def _current_revision(conn) -> str | None:
    """The schema revision a database's alembic_version table holds (None without one); Alembic
    reads it only when the table does not hold exactly one revision."""
    rows = conn.execute(text("SELECT version_num FROM alembic_version")).scalars().all()
    if len(rows) == 1:
        return rows[0]
    from alembic.migration import MigrationContext

    return MigrationContext.configure(conn).get_current_revision()


@dataclass
class _Schema:
    revision: str | None
    tables: dict[str, set[str]] = field(default_factory=dict)  # table -> its columns


def _probe(engine: Engine) -> _Schema:
    """The schema as it is, read without writing."""
    from db.schema import Base

    with engine.connect() as conn:
        insp = inspect(conn)
        names = set(insp.get_table_names())
        revision = _current_revision(conn) if "alembic_version" in names else None
        ours = {t: {c["name"] for c in insp.get_columns(t)} for t in Base.metadata.tables if t in names}
    return _Schema(revision, {**{t: set() for t in names}, **ours})


def _check(schema: _Schema, where: str) -> bool:
    """True at the newest revision with every table and column; False if a migration can bring
    it there (a new or older database); DatabaseError if this version of the tool cannot use it."""
    from db.schema import Base

    if schema.revision is not None and schema.revision == _plain_head():  # at the newest: no need of Alembic
        head, known = schema.revision, frozenset({schema.revision})
    else:
        head, known = _revisions()
    if schema.revision is not None and schema.revision not in known:
        raise DatabaseError(f"the database {where} was written by a newer version of this tool (schema revision "
                            f"{schema.revision} is unknown here; the newest known is {head}): upgrade the tool "
                            "to use it; it was not changed")
    if schema.revision is None:  # new; or being created by another process (Alembic makes its table first)
        other = sorted(set(schema.tables) - {"alembic_version"})
        if other and "alembic_version" not in schema.tables:
            raise DatabaseError(f"the database {where} is not one of this tool's: it has tables ({', '.join(other[:5])}"
                                f"{', ...' if len(other) > 5 else ''}) but no schema revision; it was not changed")
        return False
    if schema.revision != head:
        return False
    missing = [t for t in Base.metadata.tables if t not in schema.tables]
    if missing:
        raise DatabaseError(f"the database {where} is damaged: table{'s' if len(missing) > 1 else ''} "
                            f"{', '.join(missing)} {'are' if len(missing) > 1 else 'is'} missing (schema revision "
                            f"{head} has {'them' if len(missing) > 1 else 'it'})")
    for name, table in Base.metadata.tables.items():
        lacking = [c.name for c in table.columns if c.name not in schema.tables[name]]
        if lacking:
            raise DatabaseError(f"the database {where} is damaged: table {name} has no column {', '.join(lacking)} "
                                f"(schema revision {head} has)")
    return True


def database_failure(exc: BaseException, where: str | None = None, doing: str = "") -> str:
    """One line saying why a database operation failed (an SQLAlchemy or driver error);
    `doing` (e.g. "cannot open the database X") prefixes the driver's own words when the
    failure is none of the usual ones (full, locked, read-only, damaged)."""
    orig = getattr(exc, "orig", None) or exc
    msg = (str(orig).strip().splitlines() or [type(orig).__name__])[0]
    low = msg.lower()
    db = f"the database {where}" if where else "the database"
    if "database or disk is full" in low or "no space left" in low or "disk full" in low:
        return f"the disk is full ({msg})"
    if "database is locked" in low or "database table is locked" in low:
        return (f"{db} is locked by another process (waited {busy_timeout():g} s; ROCKING_DB_BUSY_TIMEOUT sets "
                "how long)")
    if "readonly database" in low or "read-only" in low:
        return f"{db} is read-only ({msg})"
    if "not a database" in low:
        return f"{db} is not an SQLite database ({msg})"
    if "malformed" in low or "corrupt" in low:
        return f"{db} is damaged ({msg})"
    if "connection timeout expired" in low or "timeout expired" == low:
        seconds = connect_timeout(where) if where and "://" in where else None
        return (f"no answer from {db} within {seconds or CONNECT_TIMEOUT:g} s (is the server up, and is it a "
                "PostgreSQL server? connect_timeout=SECONDS in the URL sets how long to wait)")
    return f"{doing or f'{db} failed'}: {msg}"


def _open_failure(exc: BaseException, where: str) -> DatabaseError:
    return DatabaseError(database_failure(exc, where, f"cannot open the database {where!r}"))


@contextmanager
def _migration_lock(engine: Engine):
    """Processes opening the same SQLite file for the first time migrate one after the other
    (SQLite's DDL is not transactional through the driver); other databases rely on their own locks."""
    path = sqlite_file(engine)
    if not path:
        yield
        return
    with open(f"{path}.migrate-lock", "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def upgrade(engine: Engine, where: str | None = None) -> None:
    """Create or migrate the schema to the newest revision; DatabaseError (nothing written)
    for a schema from a newer version of the tool, a damaged one, or another program's.
    `where`: the database in messages (default: the engine's)."""
    from alembic import command

    cfg = _alembic_config()
    where = where or database_name(engine)
    sqlite = engine.dialect.name == "sqlite"
    try:
        if _check(_probe(engine), where):
            return
        with _migration_lock(engine):
            if _check(_probe(engine), where):  # another process migrated it meanwhile
                return
            with engine.begin() as conn:
                if sqlite:  # a batch migration rebuilds tables others refer to: check the keys after, not during
                    conn.exec_driver_sql("PRAGMA foreign_keys=OFF")
                cfg.attributes["connection"] = conn
                command.upgrade(cfg, "head")
                if sqlite:
                    broken = conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
                    if broken:
                        raise DatabaseError(f"migrating {where} would break foreign keys: {broken[:3]}")
        if sqlite:
            engine.dispose()  # new connections get foreign_keys=ON again (_sqlite_pragmas)
    except SQLAlchemyError as exc:
        raise _open_failure(exc, where) from None


def _create_whole(path: str) -> bool:
    """Create a new SQLite database at `path` with the whole schema, or not at all: the schema is
    built in a file of its own beside it, which then takes the name in one step (a hard link,
    which fails if the name exists). SQLite's DDL is not one transaction through the driver, and
    a process killed while creating the schema in place left a file no command could open.
    False (nothing done) if `path` exists by then. Messages name `path`, not the file beside it;
    such files that killed processes left are removed (db.leftovers)."""
    from db.leftovers import remove_stale, tag

    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise DatabaseError(f"cannot create the database {path}: its folder {folder} does not exist")
    remove_stale(Path(folder), f"{os.path.basename(path)}.new-")
    tmp = f"{path}.new-{tag()}-{threading.get_ident()}"
    try:
        engine = make_engine(URL.create("sqlite", database=tmp))
        try:
            upgrade(engine, where=path)
        finally:
            engine.dispose()  # the last connection folds the write-ahead log into the file
        try:
            os.link(tmp, path)
            return True
        except OSError:  # the name exists (or the file system has no hard links: then in place)
            return False
    finally:
        for leftover in (tmp, f"{tmp}-wal", f"{tmp}-shm", f"{tmp}.migrate-lock"):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(leftover)


def open_database(url: str | None = None, *, write: bool | None = None) -> sessionmaker[Session]:
    """A session factory on an up-to-date schema.

    write=None (most commands): migrate when needed, but a database that cannot be written
    (read-only file or folder) is opened read-only. write=True: it must be writable
    (require_writable). write=False (read commands): opened read-only and never created or
    migrated."""
    engine = make_engine(database_url(url))
    if engine.dialect.name == "sqlite" and (engine.url.database or ":memory:") == ":memory:":
        raise DatabaseError(f"{database_url(url)} is an in-memory database, which forgets everything when the command "
                            "ends (and each connection gets its own): give an SQLite file")
    path = sqlite_file(engine)
    if write:
        require_writable(engine)
    if path is None:
        if write is False:
            try:
                if not _check(_probe(engine), database_name(engine)):
                    raise DatabaseError(_behind(engine, database_name(engine), None))
            except SQLAlchemyError as exc:
                raise _open_failure(exc, database_name(engine)) from None
        else:
            upgrade(engine)
        return sessionmaker(engine, class_=RockingSession, expire_on_commit=False)
    where = database_name(engine)
    exists = _check_file(path)
    unwritable = _unwritable(path) if exists else None
    if not exists:
        if write is False:
            raise DatabaseError(f"cannot open the database {where!r}: there is no such database "
                                "(runners db init creates it)")
        if not _create_whole(path):  # an empty file was there, or another process created it first
            upgrade(engine)
        st = os.stat(path)  # created here: its header needs no reading, which could break our locks
        _HEADERS_READ.add((st.st_dev, st.st_ino))
        return sessionmaker(engine, class_=RockingSession, expire_on_commit=False)
    readonly = _readonly_engine(path)
    try:  # read without writing first: nothing touches a file this version cannot use
        at_head = _check(_probe(readonly), where)
    except SQLAlchemyError as exc:
        readonly.dispose()
        raise _open_failure(exc, where) from None
    except DatabaseError:
        readonly.dispose()
        raise
    if write is False or unwritable:
        if not at_head:
            readonly.dispose()
            raise DatabaseError(_behind(readonly, where, unwritable))
        engine.dispose()
        return sessionmaker(readonly, class_=RockingSession, expire_on_commit=False)
    readonly.dispose()
    if not at_head:
        upgrade(engine)
    return sessionmaker(engine, class_=RockingSession, expire_on_commit=False)


def _behind(engine: Engine, where: str, unwritable: str | None) -> str:
    head, _ = _revisions()
    try:
        rev = _probe(engine).revision
    except SQLAlchemyError:
        rev = None
    state = f"at schema revision {rev}, older than this tool's {head}" if rev else "empty (no schema yet)"
    if unwritable:
        return (f"the database {where} is {state}, and it cannot be migrated as {unwritable}; migrate a writable "
                "copy (runners db init --db COPY)")
    return f"the database {where} is {state}; read commands do not migrate it: runners db init --db {where} does"


def require_writable(db, hint: str = "") -> None:
    """DatabaseError (one line) unless runs can be written to the database: a URL, an engine or
    a session factory. Commands that write call it before doing any work; `hint` ends the
    message (e.g. "or run with --no-store")."""
    if isinstance(db, sessionmaker):
        engine, own = db.kw["bind"], False
    elif isinstance(db, Engine):
        engine, own = db, False
    else:
        engine, own = make_engine(database_url(db)), True
    try:
        path = sqlite_file(engine)
        if path is not None:
            why = _unwritable(path)
            if why:
                raise DatabaseError(f"the database {path} cannot be written: {why}; nothing can be stored in it "
                                    f"(read commands such as runners db list still work{hint and '; ' + hint})")
            if engine in _READ_ONLY:  # opened read-only although writable (open_database(write=False))
                raise DatabaseError(f"the database {path} was opened read-only")
        elif engine.dialect.name == "postgresql":
            with engine.connect() as conn:
                ro = conn.exec_driver_sql("SHOW transaction_read_only").scalar() == "on"
                can = conn.execute(text("SELECT to_regclass('runs') IS NULL OR "
                                        "has_table_privilege('runs', 'INSERT')")).scalar()
            if ro or not can:
                raise DatabaseError(f"the database {database_name(engine)} cannot be written: "
                                    f"{'its transactions are read-only' if ro else 'no INSERT privilege on runs'}; "
                                    f"nothing can be stored in it{hint and ' (' + hint + ')'}")
    except SQLAlchemyError as exc:
        raise _open_failure(exc, database_name(engine)) from None
    finally:
        if own:
            engine.dispose()


def integrity_ok(engine: Engine) -> bool:
    """SQLite's own integrity check (True for other databases)."""
    if engine.dialect.name != "sqlite":
        return True
    with engine.connect() as conn:
        return conn.execute(text("PRAGMA integrity_check")).scalar() == "ok"


def tables(engine: Engine) -> list[str]:
    return sorted(inspect(engine).get_table_names())
