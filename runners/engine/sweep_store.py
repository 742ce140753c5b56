"""Storing a sweep's points in bulk: one transaction per batch of chunks (runners.engine.sweep_worker.Chunk).

Each point is one row of runs and, when it ran, one of run_summaries (plus one of excitations
for a point on a record and one of run_series for a point recorded in full), as for any run, so
every reader of the database sees a sweep's points as it sees single runs. The sweep's done
counter moves in the same transaction, so a sweep killed at any moment (even SIGKILL) keeps
exactly the points whose transaction committed, and --resume runs the others.

On SQLite the rows go in through the driver's executemany with ids given here (the largest id
plus one: the transaction holds SQLite's write lock from its first statement on, so no other
writer can take them), which costs a few microseconds a point instead of the ORM's tens. Other
databases (PostgreSQL) take SQLAlchemy Core's multi-row INSERT ... RETURNING.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime, timezone

from sqlalchemy import insert, update

from db.schema import Excitation, Run, RunBlock, RunSeries, RunSummary, Sweep
from db.series import pack as pack_series
from runners.engine.sweep_worker import Chunk, Recorded



def _driver_errors(kind: str) -> tuple[type[BaseException], ...]:
    """SQLAlchemy's error class `kind` (IntegrityError, or SQLAlchemyError for any) and those of
    the drivers that store() uses directly (sqlite3, psycopg)."""
    import sqlite3

    from sqlalchemy import exc

    driver = "Error" if kind == "SQLAlchemyError" else kind
    found: list[type[BaseException]] = [getattr(exc, kind), getattr(sqlite3, driver)]
    try:
        import psycopg

        found.append(getattr(psycopg, driver))
    except ImportError:
        pass
    return tuple(found)


INTEGRITY_ERRORS = _driver_errors("IntegrityError")  # a point another process stored meanwhile (a concurrent resume)
DATABASE_ERRORS = _driver_errors("SQLAlchemyError")  # any failure of the database (full, locked, gone)
SUMMARY_COLUMNS = [c.name for c in RunSummary.__table__.columns if c.name != "run_id"]


@dataclass(frozen=True)
class RunConstants:
    """The columns every point of a sweep shares."""

    scene_id: int
    sweep_id: int
    model: str  # "one block" or "two blocks"
    fmu_sha256: str
    code_version: str


def series_row(run_id: int, rec: Recorded) -> dict:
    names, n, blob = pack_series(rec.time, rec.outputs)
    return {"run_id": run_id, "names": names, "n_samples": n, "data": blob, "events": rec.events}


def _run_table(c: RunConstants, chunk: Chunk, ids: list[int] | None, exc_ids: list[int] | None,
               created) -> dict[str, list]:
    """The runs columns of a chunk (column -> one value per point); without `ids` the database
    gives them."""
    n = len(chunk)
    cols = {"id": ids} if ids is not None else {}
    cols.update({"scene_id": [c.scene_id] * n, "excitation_id": exc_ids or [None] * n,
                 "sweep_id": [c.sweep_id] * n, "model": [c.model] * n, "method": ["fmu"] * n,
                 "fmu_sha256": [c.fmu_sha256] * n, "code_version": [c.code_version] * n,
                 "created_at": [created] * n, **chunk.runs})
    return cols


def _summary_table(chunk: Chunk, ids: list[int]) -> dict[str, list]:
    """The run_summaries columns of a chunk's points that ran (run_id first); {} if none did."""
    status = chunk.runs["status"]
    ok = range(len(chunk)) if status.count("ok") == len(chunk) else [k for k, v in enumerate(status) if v == "ok"]
    if not chunk.summaries or not ok:
        return {}
    cols = {"run_id": ids, **{k: chunk.summaries[k] for k in SUMMARY_COLUMNS if k in chunk.summaries}}
    return cols if len(ok) == len(chunk) else {k: [v[i] for i in ok] for k, v in cols.items()}


BLOCK_COLUMNS = [c.name for c in RunBlock.__table__.columns]


def _block_table(chunk: Chunk, ids: list[int]) -> dict[str, list]:
    """The run_blocks columns of a chunk's points of a column that ran (run_id first); {} if none."""
    if not chunk.blocks:
        return {}
    rows = [{"run_id": i, **b} for i, blocks in zip(ids, chunk.blocks) for b in blocks]
    if not rows:
        return {}
    return {k: [r[k] for r in rows] for k in BLOCK_COLUMNS}


def _rows(cols: dict[str, list]) -> list[tuple]:
    return list(zip(*cols.values()))


def store(session, c: RunConstants, chunks: list[Chunk]) -> None:
    """Store the points of `chunks` in the session's transaction (which the caller commits),
    and move the sweep's done counter (and its status to done when it is complete)."""
    total = sum(len(ch) for ch in chunks)
    # the first statement writes: on SQLite it takes the write lock, which the ids below rely on
    session.execute(update(Sweep).where(Sweep.id == c.sweep_id).values(done=Sweep.done + total))
    session.execute(update(Sweep).where(Sweep.id == c.sweep_id, Sweep.done >= Sweep.total).values(status="done"))
    created = datetime.now(timezone.utc)
    dialect = session.get_bind().dialect
    if dialect.name == "sqlite":
        _store_sqlite(session, c, chunks, created)
        return
    if dialect.name == "postgresql" and dialect.driver == "psycopg":
        _store_postgresql(session, c, chunks, created)
        return
    _store_core(session, c, chunks, created)


def _store_core(session, c: RunConstants, chunks: list[Chunk], created: datetime) -> None:
    """Any other database: SQLAlchemy Core's multi-row INSERT ... RETURNING."""
    for chunk in chunks:
        exc_ids = None
        if chunk.excitations is not None:
            exc_ids = list(session.scalars(insert(Excitation).returning(Excitation.id, sort_by_parameter_order=True),
                                           [dict(zip(chunk.excitations, r)) for r in _rows(chunk.excitations)]))
        runs = _run_table(c, chunk, None, exc_ids, created)
        runs["point"] = [json.loads(p) for p in runs["point"]]  # (the JSON column encodes it again)
        ids = list(session.scalars(insert(Run).returning(Run.id, sort_by_parameter_order=True),
                                   [dict(zip(runs, r)) for r in _rows(runs)]))
        summaries = _summary_table(chunk, ids)
        if summaries:
            session.execute(insert(RunSummary), [dict(zip(summaries, r)) for r in _rows(summaries)])
        blocks = _block_table(chunk, ids)
        if blocks:
            session.execute(insert(RunBlock), [dict(zip(blocks, r)) for r in _rows(blocks)])
        _store_series(session, chunk, ids)


def _store_series(session, chunk: Chunk, ids: list[int]) -> None:
    if chunk.recorded:
        session.execute(insert(RunSeries), [series_row(ids[k], rec) for k, rec in chunk.recorded.items()])


def _next_id(cur, table: str) -> int:
    return cur.execute(f"SELECT coalesce(max(id), 0) FROM {table}").fetchone()[0] + 1


def _store_postgresql(session, c: RunConstants, chunks: list[Chunk], created: datetime) -> None:
    """PostgreSQL through psycopg: ids drawn from the tables' sequences, rows sent by COPY."""
    conn = session.connection().connection.driver_connection

    def ids(table: str, n: int) -> list[int]:
        return [r[0] for r in conn.execute(f"SELECT nextval(pg_get_serial_sequence('{table}', 'id')) "
                                           "FROM generate_series(1, %s)", (n,)).fetchall()]

    def copy(table: str, columns: list[str], rows: list[tuple]) -> None:
        with conn.cursor().copy(f"COPY {table} ({', '.join(columns)}) FROM STDIN") as cp:
            for row in rows:
                cp.write_row(row)

    for chunk in chunks:
        n = len(chunk)
        exc_ids = None
        if chunk.excitations is not None:
            exc_ids = ids("excitations", n)
            copy("excitations", ["id", *chunk.excitations], list(zip(exc_ids, *chunk.excitations.values())))
        run_ids = ids("runs", n)
        runs = _run_table(c, chunk, run_ids, exc_ids, created)
        copy("runs", list(runs), _rows(runs))
        summaries = _summary_table(chunk, run_ids)
        if summaries:
            copy("run_summaries", list(summaries), _rows(summaries))
        blocks = _block_table(chunk, run_ids)
        if blocks:
            copy("run_blocks", list(blocks), _rows(blocks))
        _store_series(session, chunk, run_ids)


def _literal(value) -> str:
    """An int, bool, str or None as an SQL literal."""
    if value is None:
        return "NULL"
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, int):
        return str(value)
    return "'" + str(value).replace("'", "''") + "'"


def _float_literal(cur, value: float) -> str | None:
    """repr(value) if SQLite reads that text back as exactly `value` (it does not for every
    double), else None."""
    text = repr(value)
    if not math.isfinite(value) or cur.execute(f"SELECT {text} = ?", (value,)).fetchone()[0] != 1:
        return None
    return text


def _insert(cur, table: str, columns: dict[str, list], n: int) -> tuple[str, list[tuple]]:
    """(INSERT statement, rows) of `columns` (name -> n values): a column of one value throughout
    goes into the statement as a literal and is not bound for every row (binding is most of the
    cost of a row; a float only where SQLite reads its text back exactly), a column of None only
    is left out."""
    names, marks, bound = [], [], []
    for name, col in columns.items():
        first = col[0]
        if first is None and col.count(None) == n:
            continue
        names.append(name)
        literal = None
        if col.count(first) == n:
            literal = _float_literal(cur, first) if isinstance(first, float) else _literal(first)
        if literal is not None:
            marks.append(literal)
        else:
            marks.append("?")
            bound.append(col)
    return (f"INSERT INTO {table} ({', '.join(names)}) VALUES ({', '.join(marks)})",
            list(zip(*bound)) if bound else [()] * n)


def _store_sqlite(session, c: RunConstants, chunks: list[Chunk], created: datetime) -> None:
    conn = session.connection()
    typ = Run.__table__.c.created_at.type.dialect_impl(conn.dialect)
    process = typ.bind_processor(conn.dialect)  # the text SQLAlchemy stores a DateTime as
    stamp = process(created) if process else created
    cur = conn.connection.driver_connection.cursor()
    try:
        next_run = _next_id(cur, "runs")
        for chunk in chunks:
            n = len(chunk)
            exc_ids = None
            if chunk.excitations is not None:
                first = _next_id(cur, "excitations")
                exc_ids = list(range(first, first + n))
                cur.executemany(*_insert(cur, "excitations", {"id": exc_ids, **chunk.excitations}, n))
            ids = list(range(next_run, next_run + n))
            next_run += n
            cur.executemany(*_insert(cur, "runs", _run_table(c, chunk, ids, exc_ids, stamp), n))
            summaries = _summary_table(chunk, ids)
            if summaries:
                cur.executemany(*_insert(cur, "run_summaries", summaries, len(summaries["run_id"])))
            blocks = _block_table(chunk, ids)
            if blocks:
                cur.executemany(*_insert(cur, "run_blocks", blocks, len(blocks["run_id"])))
            _store_series(session, chunk, ids)
    finally:
        cur.close()
