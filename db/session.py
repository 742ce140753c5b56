"""Engines and sessions: SQLite by default (rocking.db in the working folder, WAL mode,
foreign keys on), any SQLAlchemy URL through --db or ROCKING_DB; the schema is brought
to the newest Alembic revision on opening."""

from __future__ import annotations

import fcntl
import os
from contextlib import contextmanager
from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import create_engine, event, inspect, text
from sqlalchemy.engine import Engine
from sqlalchemy.exc import ArgumentError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

DEFAULT_URL = "sqlite:///rocking.db"
MIGRATIONS = Path(__file__).resolve().parent / "migrations"


class DatabaseError(RuntimeError):
    """The database cannot be opened or used; str() is a one-line message."""


DB_HELP = "database URL or SQLite file (default: ROCKING_DB, else sqlite:///rocking.db)"  # for --db


def database_url(arg: str | None = None) -> str:
    """--db, else ROCKING_DB, else rocking.db in the working folder. A value without
    "://" is a path to an SQLite file (results.db means sqlite:///results.db)."""
    url = arg or os.environ.get("ROCKING_DB") or DEFAULT_URL
    return url if "://" in url else f"sqlite:///{url}"


def _sqlite_pragmas(dbapi_connection, _record) -> None:
    cur = dbapi_connection.cursor()
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA busy_timeout=60000")  # ms: concurrent writers wait instead of failing
    cur.close()


def make_engine(url: str) -> Engine:
    try:
        engine = create_engine(url)
    except (ArgumentError, ImportError, ValueError) as exc:
        raise DatabaseError(f"cannot use database URL {url!r}: {exc}") from None
    if engine.dialect.name == "sqlite":
        event.listen(engine, "connect", _sqlite_pragmas)
    return engine


def _alembic_config() -> Config:
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    return cfg


@contextmanager
def _migration_lock(engine: Engine):
    """Processes opening the same SQLite file for the first time migrate one after the other
    (SQLite's DDL is not transactional through the driver); other databases rely on their own locks."""
    path = engine.url.database if engine.dialect.name == "sqlite" else None
    if not path or path == ":memory:":
        yield
        return
    with open(f"{path}.migrate-lock", "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _at_head(engine: Engine) -> bool:
    head = ScriptDirectory.from_config(_alembic_config()).get_current_head()
    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision() == head


def upgrade(engine: Engine) -> None:
    """Create or migrate the schema to the newest revision."""
    cfg = _alembic_config()
    try:
        if _at_head(engine):
            return
        sqlite = engine.dialect.name == "sqlite"
        with _migration_lock(engine), engine.begin() as conn:
            if sqlite:  # a batch migration rebuilds tables others refer to: check the keys after, not during
                conn.exec_driver_sql("PRAGMA foreign_keys=OFF")
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")
            if sqlite:
                broken = conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
                if broken:
                    raise DatabaseError(f"migrating {engine.url!r} would break foreign keys: {broken[:3]}")
        if sqlite:
            engine.dispose()  # new connections get foreign_keys=ON again (_sqlite_pragmas)
    except OperationalError as exc:
        raise DatabaseError(f"cannot open the database {engine.url!r}: {str(exc.orig).splitlines()[0]}") from None


def open_database(url: str | None = None) -> sessionmaker[Session]:
    """A session factory on an up-to-date schema."""
    engine = make_engine(database_url(url))
    upgrade(engine)
    return sessionmaker(engine, expire_on_commit=False)


def integrity_ok(engine: Engine) -> bool:
    """SQLite's own integrity check (True for other databases)."""
    if engine.dialect.name != "sqlite":
        return True
    with engine.connect() as conn:
        return conn.execute(text("PRAGMA integrity_check")).scalar() == "ok"


def tables(engine: Engine) -> list[str]:
    return sorted(inspect(engine).get_table_names())
