"""Stored results as pandas DataFrames: a run's series and events, a sweep's points, and
the stored blocks, scenes, runs, sweeps, records and measurements as readable tables.

Units are SI and angles radians (docs/conventions.md); docs/export.md lists every column.

- series_frame / events_frame: one run's time history (index ``time`` in s, one float64
  column per FMU output, bit for bit as stored) and its events (one row per event).
- run_frames: both, for a run stored in a database.
- sweep_frame / iter_sweep_frames: one row per grid point of a sweep, in grid order, read in
  chunks of grid indices (SQL Core selects, no ORM objects per point), so a sweep of a
  million points costs one DataFrame, not a million Python objects. Points not stored yet
  are rows too, with status "pending", their grid values and no outcomes.
- stored_table: the rows of one table, with names instead of bare ids and no blob columns.

pandas is imported here only: the rest of the tool works without it.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from typing import Any, Iterator

import numpy as np
import pandas as pd
from sqlalchemy import Text, exists, false, func, or_, select, type_coerce
from sqlalchemy.orm import aliased, sessionmaker

from db import series as packed
from db.records import MEASURES
from runners.engine.intensity import SUPPORT_MEASURES
from db.schema import Block, Excitation, Measurement, Record, Run, RunSeries, RunSummary, Scene, Sweep

# outcome columns of a run (db.schema.RunSummary) and their pandas dtypes; nullable ones hold
# <NA> (integers, booleans) or NaN (floats) where a run has no value (an error, a pending point)
OUTCOMES: dict[str, str] = {
    "peak1_over_alpha": "float64",  # max |theta1| / alpha1 (alpha = atan(b / h) of block 1)
    "peak2_over_alpha": "float64",  # max |theta2| / alpha2 (two blocks)
    "overturned": "boolean",
    "overturned_blocks": "string",  # "1", "2" or "1,2"
    "overturn_time": "float64",  # s
    "impacts": "Int64",
    "impacts_ground": "Int64",
    "impacts_interface": "Int64",
    "rest_time": "float64",  # s
    # the rigid-rocking assumptions (docs/contact.md); empty for methods that do not monitor them
    "assumptions_held": "boolean",  # no contact slid or lifted off at all
    "slide_time": "float64",  # s, first sliding
    "lift_time": "float64",  # s, first lift-off
    "fall_time": "float64",  # s, start of the overturning fall
    "friction_demand_max": "float64",  # largest |T| / N on the ground
    "normal_min": "float64",  # smallest N of the ground over the weight it carries
    "friction_demand_max_interface": "float64",
    "normal_min_interface": "float64",
    "impulse_demand_max": "float64",  # largest |tangential| / normal impulse of an impact
    # rocking–sliding runs (contact.model = 1, runners.engine.motion); empty for rigid rocking
    "motion": "string",  # rests, slides, rocks, slide-rocks or overturns
    "max_abs_slip": "float64",  # m, peak |block1.slip|
    "residual_slip": "float64",  # m, block1.slip at the end (+x)
    "slide_duration": "float64",  # s, time spent sliding
    # rocking–sliding stacks: block 2 on block 1 (the four above are block 1's on the ground)
    "block2_motion": "string",  # as motion, or falls-off
    "block2_max_abs_slip": "float64",  # m, peak |block2.slip| along block 1's top
    "block2_residual_slip": "float64",  # m, block2.slip at the end (+x, relative to block 1)
    "block2_slide_duration": "float64",  # s
    "block2_slide_time": "float64",  # s, block 2's first slide
    "block2_fell_off": "boolean",  # block 2 left block 1's top
    "block2_fell_off_time": "float64",  # s
    # columns (3 to 8 blocks; each block's: BLOCK_OUTCOMES); empty for one block and two
    "collapsed": "boolean",  # a block overturned or fell off
    "lowest_fallen": "Int64",  # the lowest block that did
    "max_residual_slip": "float64",  # m, the largest |residual slip| of a standing block ("any drum")
    "max_residual_slip_block": "Int64",  # the block it is of
}
# each block's outcome in a column's run (db.schema.RunBlock), as columns block{K}_{name} of a sweep's frame
BLOCK_OUTCOMES: dict[str, str] = {
    "peak_over_alpha": "float64",  # peak |theta| over its own alpha (empty once it fell)
    "max_abs_slip": "float64",  # m, peak |slip| on what it stands on
    "residual_slip": "float64",  # m, slip at the end (+x): the residual dislocation
    "overturned": "boolean",  # it fell, or rode a block under it that fell
    "fell_off": "boolean",  # it left the top of the block below
}
EVENT_COLUMNS = ("time", "kind")  # every events frame starts with these: time in s, kind of event
SCALED = ("pga", "pgv", "pgd", "arias")  # a scaled record's measures a sweep point stores (SI)
CHUNK = 50_000  # grid points read at a time
KINDS = ("blocks", "scenes", "runs", "sweeps", "records", "measurements")


# ---------------------------------------------------------------------------------------------
# one run


def series_frame(time: np.ndarray, outputs: dict[str, np.ndarray]) -> pd.DataFrame:
    """A run's time history: index ``time`` (s), one float64 column per output in the given
    order (SI units, angles in rad), the values bit for bit."""
    t = np.asarray(time, dtype="<f8")
    cols = {}
    for name, values in outputs.items():
        a = np.asarray(values, dtype="<f8")
        if a.shape != t.shape:
            raise ValueError(f"output {name!r} has {a.shape} values, the time {t.shape}")
        cols[name] = a
    return pd.DataFrame(cols, index=pd.Index(t, name="time"), columns=list(outputs), dtype="float64")


def events_frame(events: list[dict[str, Any]]) -> pd.DataFrame:
    """A run's events, one row per event in the order they happened: ``time`` (s), ``kind``
    (impact, peak, uplift, rest, settle, open, overturn), then every field the events report,
    in the order first seen: numbers as float64 (theta in rad, omega_minus / omega_plus in
    rad/s, side, ...; NaN where an event lacks the field) and labels as text (contact,
    pattern, blocks; <NA> where it lacks it). `events` are as stored with a run's series
    (runners.engine.fmu.Event.as_dict: kind, t, values, labels). With no events the frame is
    empty with the columns time and kind."""
    numbers: dict[str, None] = {}
    labels: dict[str, None] = {}
    for e in events:
        numbers.update(dict.fromkeys(e.get("values") or {}))
        labels.update(dict.fromkeys(e.get("labels") or {}))
    taken = set(EVENT_COLUMNS)
    clash = [k for k in (*numbers, *labels) if k in taken]
    if clash:
        raise ValueError(f"an event field is named {clash[0]!r}, which the events frame uses for itself")
    data: dict[str, Any] = {
        "time": np.array([float(e["t"]) for e in events], dtype="float64"),
        "kind": pd.array([str(e["kind"]) for e in events], dtype="string"),
    }
    for k in numbers:
        data[k] = np.array([float((e.get("values") or {}).get(k, math.nan)) for e in events], dtype="float64")
    for k in labels:
        if k in data:  # numeric in some events, text in others: text
            data[k] = pd.array([_label(e, k) for e in events], dtype="string")
        else:
            data[k] = pd.array([(e.get("labels") or {}).get(k) for e in events], dtype="string")
    return pd.DataFrame(data, columns=list(data))


def _label(e: dict[str, Any], key: str) -> str | None:
    if key in (e.get("labels") or {}):
        return e["labels"][key]
    v = (e.get("values") or {}).get(key)
    if v is None:
        return None
    v = float(v)
    return str(int(v)) if v.is_integer() else repr(v)  # blocks=2 beside blocks=1+2: "2"


def run_frames(factory: sessionmaker, run_id: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(series, events) of a stored run (series_frame, events_frame). ValueError, in one line,
    for a run that is not there or was stored without series: sweep points keep their outcomes
    only (runners rrd --sweep ID --points N simulates them again in full), and the closed form
    has no time history."""
    with factory() as session:
        row = session.execute(select(Run.id, Run.sweep_id, Run.grid_index, Run.model, RunSeries.names,
                                     RunSeries.n_samples, RunSeries.data, RunSeries.events)
                              .outerjoin(RunSeries, RunSeries.run_id == Run.id).where(Run.id == run_id)).first()
    if row is None:
        raise ValueError(f"no run {run_id} in the database")
    if row.names is None:
        raise ValueError(no_series(run_id, row.sweep_id, row.grid_index, row.model))
    t, cols = packed.unpack(row.names, row.n_samples, row.data)
    return series_frame(t, cols), events_frame(list(row.events or []))


def no_series(run_id: int, sweep_id: int | None, grid_index: int | None, model: str) -> str:
    """Why a run has no stored series, and what to do about it."""
    if sweep_id is not None:
        return (f"run {run_id} is point {grid_index} of sweep {sweep_id}, which stores outcomes only: export the "
                f"sweep (runners export --sweep {sweep_id}), or simulate the point in full with "
                f"runners rrd --sweep {sweep_id} --points {grid_index}")
    if model == "closed form":
        return f"run {run_id} is a closed-form result, which has no time history"
    return f"run {run_id} has no stored series"


@lru_cache(maxsize=1)
def fmu_defaults() -> dict[str, float]:
    """Start values of the FMU's Real and Integer parameters, from model/c/variables.def (the
    table modelDescription.xml is generated from), with the runners' SCENE_DEFAULTS over them,
    as runners.engine.fmu.RockingFMU.defaults reads them from the FMU: the values a scene leaves out."""
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_variables
    from runners.engine.fmu import with_scene_defaults

    return with_scene_defaults({v.name: float(v.start) for v in read_variables(C_DIR / "variables.def")
                                if v.causality == "parameter" and v.type in ("Real", "Integer")})


@lru_cache(maxsize=1)
def variable_units() -> dict[str, str]:
    """Unit of each FMU variable, outputs and parameters ("rad", "rad/s", "m/s2", "J", "s",
    ...; "" for counts, flags and ratios), from model/c/variables.def."""
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_variables

    return {v.name: v.unit for v in read_variables(C_DIR / "variables.def")}


# ---------------------------------------------------------------------------------------------
# one sweep: a row per grid point


def record_refs(session, sw: Sweep) -> list | None:
    """The records a sweep runs over (runners.engine.sweep.RecordRef, in grid order), read
    without writing; None for a sweep over built-in excitations."""
    ids = sw.grid.get("records")
    if not ids:
        return None
    from runners.engine.sweep import RecordRef

    cols = [Record.id, Record.name, Record.sha256] + [getattr(Record, m) for m in MEASURES]
    found = {r.id: r for r in session.execute(select(*cols).where(Record.id.in_(ids)))}
    missing = [i for i in ids if i not in found]
    if missing:
        raise ValueError(f"record {missing[0]} of sweep {sw.id} is no longer in the database")
    through = sw.grid.get("support_measures") or {}  # measures through the sweep's support
    return [RecordRef(i, found[i].name, found[i].sha256, 0.0,
                      {**{m: getattr(found[i], m) for m in MEASURES}, **through.get(str(i), {})}) for i in ids]


def stored_sweep(factory: sessionmaker, sweep_id: int) -> tuple[Sweep, dict, list | None]:
    """(sweep, its scene's parameters, its records or None)."""
    with factory() as session:
        sw = session.get(Sweep, sweep_id)
        if sw is None:
            raise ValueError(f"no sweep {sweep_id} in the database")
        return sw, dict(session.get(Scene, sw.scene_id).parameters), record_refs(session, sw)


def grid_of(sw: Sweep, refs: list | None):
    """The grid of a stored sweep (runners.engine.sweep.Grid), its records `refs` (record_refs)."""
    from runners.engine.sweep import Axis, Grid, Intensity

    g = sw.grid
    return Grid([Axis(*a) for a in g["axes"]], refs, Intensity(*g["intensity"]) if g.get("intensity") else None)


def column_blocks(sw: Sweep, params: dict | None = None) -> int:
    """The blocks of a sweep's column (3 to 8) from its defaults and its scene's parameters `params`; 0
    for one block or two."""
    n = int({**(sw.grid.get("defaults") or {}), **(params or {})}.get("nBlocks", 1))
    return n if n >= 3 else 0


def sweep_columns(sw: Sweep, params: dict | None = None) -> dict[str, str]:
    """The columns of a sweep's frame and their dtypes, from its grid alone (the same in
    every chunk): grid_index, run_id, the records and levels where it runs records, the
    --grid axes, status, error_message, then the outcomes; of a column (its scene's parameters
    `params` say) each block's, block{K}_peak_over_alpha ... block{K}_fell_off."""
    g = sw.grid
    cols: dict[str, str] = {"grid_index": "int64", "run_id": "Int64"}
    if g.get("records"):
        cols.update(record="string", record_id="Int64")
        if g.get("intensity"):
            cols.update(level="float64", level_measure="string", level_unit="string")
    for name, *_ in g["axes"]:
        cols[name] = "float64"
    if g.get("records"):
        cols["scale"] = "float64"
        cols.update({m: "float64" for m in SCALED})
        cols["pga_g"] = "float64"
        if g.get("support_measures"):  # through the scene's support (runners.engine.floor_motion)
            cols.update({m: "float64" for m in SUPPORT_MEASURES})
    cols.update(status="string", error_message="string")
    cols.update(OUTCOMES)
    for k in range(1, column_blocks(sw, params) + 1):
        cols.update({f"block{k}_{name}": dtype for name, dtype in BLOCK_OUTCOMES.items()})
    return cols


def iter_sweep_frames(factory: sessionmaker, sweep_id: int, chunk: int = CHUNK,
                      stored_only: bool = False) -> Iterator[pd.DataFrame]:
    """sweep_frame in pieces of at most `chunk` grid points, in grid order (for exports of
    sweeps of any size in bounded memory). With `stored_only`, the points not stored yet are
    left out instead of being rows with status "pending"."""
    sw, params, refs = stored_sweep(factory, sweep_id)
    yield from frames_of(factory, sw, params, refs, chunk, stored_only)


FIXED = ("grid_index", "run_id", "status", "error_message")  # sweep columns a point's grid values never set


def _points(raw: list) -> list[dict]:
    """The stored grid values of a chunk's runs: JSON texts decoded in one call (SQLite), or
    dicts as the driver decoded them (PostgreSQL)."""
    texts = [i for i, v in enumerate(raw) if isinstance(v, str)]
    out = [v if isinstance(v, dict) else {} for v in raw]
    if texts:
        decoded = json.loads("[" + ",".join(raw[i] for i in texts) + "]")
        for i, d in zip(texts, decoded):
            out[i] = d or {}
    return out


def frames_of(factory, sw, params, refs, chunk: int, stored_only: bool) -> Iterator[pd.DataFrame]:
    """The frames of a sweep's grid points lo..lo+chunk-1, one chunk at a time: one select
    each (SQL Core on the session's connection: rows are tuples, not ORM objects)."""
    from runners.engine.intensity import G0

    columns = sweep_columns(sw, params)
    n_blocks = column_blocks(sw, params)
    grid = None
    base = {**sw.grid["defaults"], **params}
    stmt = (select(Run.grid_index, Run.id, type_coerce(Run.point, Text), Run.status, Run.error_message,
                   *[getattr(RunSummary, k) for k in OUTCOMES])
            .outerjoin(RunSummary, RunSummary.run_id == Run.id))
    for lo in range(0, sw.total, chunk):
        hi = min(sw.total, lo + chunk)
        with factory() as session:
            rows = session.connection().execute(
                stmt.where(Run.sweep_id == sw.id, Run.grid_index >= lo, Run.grid_index < hi)
                .order_by(Run.grid_index)).all()
        stored = list(zip(*rows)) if rows else [()] * (5 + len(OUTCOMES))
        indices = np.array(stored[0], dtype="int64")
        index = indices if stored_only else np.arange(lo, hi, dtype="int64")
        n = len(index)
        if n == 0:
            continue
        at = np.arange(len(rows)) if stored_only else indices - lo  # row of each stored point
        data: dict[str, list] = {c: [None] * n for c in columns}
        data["grid_index"] = index

        def put(column: str, values) -> None:
            target = data[column]
            for k, v in zip(at.tolist(), values):
                target[k] = v

        data["status"] = ["pending"] * n
        for column, values in zip(("run_id", "status", "error_message", *OUTCOMES), (stored[1], *stored[3:])):
            put(column, values)
        points = _points(list(stored[2]))
        for key in set().union(*points):  # a record lacking a measure lacks its key
            if key in data and key not in FIXED:
                put(key, [p.get(key) for p in points])
        if len(rows) < n:  # pending points: their grid values, computed as their runs will store them
            grid = grid or grid_of(sw, refs)
            seen = np.zeros(n, dtype=bool)
            seen[at] = True
            for k in np.flatnonzero(~seen).tolist():
                values, _, _ = grid.point(int(index[k]), base)
                for key, v in values.items():
                    if key in data and key not in FIXED:
                        data[key][k] = v
        if "pga_g" in data:
            data["pga_g"] = [None if v is None else v / G0 for v in data["pga"]]
        if n_blocks and rows:  # a column: each block's outcome, one select for the chunk
            _put_blocks(factory, data, dict(zip(stored[1], at.tolist())))
        yield pd.DataFrame({c: _column(data[c], dtype) for c, dtype in columns.items()}, columns=list(columns))


def _put_blocks(factory, data: dict[str, list], row_of: dict[int, int]) -> None:
    """Each block's outcome (run_blocks) into the frame's columns block{K}_{name}, at the row of each run."""
    from db.schema import RunBlock

    names = list(BLOCK_OUTCOMES)
    stmt = select(RunBlock.run_id, RunBlock.block, *[getattr(RunBlock, k) for k in names])
    with factory() as session:
        ids = list(row_of)
        for lo in range(0, len(ids), 30_000):  # (SQLite's bound variables)
            for run_id, block, *values in session.connection().execute(
                    stmt.where(RunBlock.run_id.in_(ids[lo:lo + 30_000]))).all():
                for name, v in zip(names, values):
                    column = data.get(f"block{block}_{name}")
                    if column is not None:
                        column[row_of[run_id]] = v


def _column(values, dtype: str) -> pd.Series | np.ndarray:
    if dtype == "float64":
        return np.array(values, dtype="float64")  # None becomes NaN
    if dtype == "object":
        return _objects(values)
    if dtype == "int64":
        return np.asarray(values, dtype="int64")
    return pd.array(values, dtype=dtype)


def sweep_frame(factory: sessionmaker, sweep_id: int, stored_only: bool = False) -> pd.DataFrame:
    """One row per grid point of a stored sweep, in grid order.

    Columns: ``grid_index``; ``run_id`` (<NA> until the point is stored); for a sweep over
    records ``record`` (its name), ``record_id`` and, with intensity levels, ``level`` (in
    ``level_unit``: g for PGA, m/s for PGV) and ``level_measure``; each --grid axis under its
    name (``w`` = omega_g / p, ``a`` = a_g / (g tan alpha), or an FMU parameter in SI units);
    for records ``scale`` (the multiplier of the record's accelerations) and the scaled
    record's ``pga`` (m/s^2), ``pgv`` (m/s), ``pgd`` (m), ``arias`` (m/s) and ``pga_g`` (g);
    ``status`` (ok, error, or pending for a point not stored yet), ``error_message``; and the
    outcomes peak1_over_alpha, peak2_over_alpha, overturned, overturned_blocks, overturn_time
    (s), impacts, impacts_ground, impacts_interface, rest_time (s). Points not stored yet are
    rows with status "pending" (left out with `stored_only`).

    Read in chunks of grid indices with SQL Core selects: memory grows with the frame, not
    with ORM objects. ValueError for a sweep that is not there."""
    sw, params, refs = stored_sweep(factory, sweep_id)
    parts = list(frames_of(factory, sw, params, refs, CHUNK, stored_only))
    if not parts:
        return pd.DataFrame({c: _column([], d) for c, d in sweep_columns(sw, params).items()})
    return parts[0] if len(parts) == 1 else pd.concat(parts, ignore_index=True)


# ---------------------------------------------------------------------------------------------
# stored tables


def _objects(values) -> np.ndarray:
    """An object array of the values as they are (lists and dicts stay whole)."""
    out = np.empty(len(values), dtype=object)
    for i, v in enumerate(values):
        out[i] = v
    return out


def _dtype(column) -> str:
    """The pandas dtype of a selected column: nullable integers, booleans and text, float64
    (NaN where missing) for reals; object for JSON and anything else."""
    try:
        py = column.type.python_type
    except NotImplementedError:
        return "object"
    return {float: "float64", int: "Int64", bool: "boolean", str: "string"}.get(py, "object")


def _read(factory: sessionmaker, stmt, dtypes: dict[str, str] | None = None) -> pd.DataFrame:
    """The rows of a select as a DataFrame indexed by ``id``, each column of the dtype its SQL
    type gives (_dtype) unless `dtypes` says otherwise; created_at as UTC timestamps."""
    with factory() as session:
        result = session.execute(stmt)
        names = list(result.keys())
        rows = result.all()
    types = {c.key: _dtype(c) for c in stmt.selected_columns} | (dtypes or {})
    columns = list(zip(*rows)) if rows else [()] * len(names)
    data = {}
    for name, values in zip(names, columns):
        if name.endswith("created_at"):
            data[name] = pd.to_datetime(list(values), utc=True)
        elif types.get(name, "object") == "float64":
            data[name] = np.array([math.nan if v is None else v for v in values], dtype="float64")
        elif types.get(name, "object") == "object":
            data[name] = _objects(values)
        else:
            data[name] = pd.array(list(values), dtype=types[name])
    df = pd.DataFrame(data, columns=names)
    df["id"] = df["id"].astype("int64")
    return df.set_index("id")


def _blocks(factory: sessionmaker) -> pd.DataFrame:
    cols = [c for c in Block.__table__.columns]
    return _read(factory, select(*cols).order_by(Block.id))


def _scenes(factory: sessionmaker) -> pd.DataFrame:
    b1, b2 = aliased(Block), aliased(Block)
    runs = select(func.count()).where(Run.scene_id == Scene.id).scalar_subquery()
    sweeps = select(func.count()).where(Sweep.scene_id == Scene.id).scalar_subquery()
    stmt = (select(Scene.id, Scene.name, Scene.n_blocks, b1.name.label("block1"), b2.name.label("block2"),
                   Scene.parameters, runs.label("runs"), sweeps.label("sweeps"), Scene.created_at)
            .outerjoin(b1, b1.id == Scene.block1_id).outerjoin(b2, b2.id == Scene.block2_id).order_by(Scene.id))
    df = _read(factory, stmt, {"runs": "int64", "sweeps": "int64"})
    params = df.pop("parameters")
    from runners.engine.scene import KIND_NAMES

    df.insert(2, "excitation", pd.array([KIND_NAMES.get(int(p.get("excitation.kind", 0)), "unknown") for p in params],
                                        dtype="string"))
    df["parameters"] = params  # the FMU parameters the scene sets (a dict per row)
    return df


def _runs(factory: sessionmaker, sweep: int | None = None, single: bool = False,
          limit: int | None = None) -> pd.DataFrame:
    if sweep is not None and single:
        raise ValueError("a run is in a sweep or single: give sweep or single, not both")
    if limit is not None and limit < 1:
        raise ValueError(f"limit must be at least 1, got {limit}")
    has_series = exists().where(RunSeries.run_id == Run.id)
    stmt = (select(Run.id, Scene.name.label("scene"), Run.scene_id, Run.sweep_id, Run.grid_index, Run.model,
                   Run.method, Excitation.kind.label("excitation"), Record.name.label("record"),
                   Excitation.scale, Run.stop_time, Run.rel_tol, Run.status, Run.error_message,
                   *[getattr(RunSummary, k) for k in OUTCOMES], has_series.label("has_series"), Run.wall_time,
                   Run.recording, Run.code_version, Run.created_at)
            .join(Scene, Scene.id == Run.scene_id)
            .outerjoin(RunSummary, RunSummary.run_id == Run.id)
            .outerjoin(Excitation, Excitation.id == Run.excitation_id)
            .outerjoin(Record, Record.id == Excitation.record_id)
            .order_by(Run.id.desc()))
    if sweep is not None:
        from db.session import MAX_ID

        stmt = stmt.where(Run.sweep_id == sweep if -MAX_ID - 1 <= sweep <= MAX_ID else false())  # no such id
    if single:
        stmt = stmt.where(Run.sweep_id.is_(None))
    if limit is not None:
        from db.session import MAX_ID

        stmt = stmt.limit(min(limit, MAX_ID))
    return _read(factory, stmt, {"sweep_id": "Int64", "grid_index": "Int64", "has_series": "bool",
                                 **{k: v for k, v in OUTCOMES.items() if v != "float64"}})


def grid_text(grid: dict) -> str:
    """A sweep's grid in one line: w=1:12:5, a=1.01:8:4; records and levels first."""
    parts = []
    if grid.get("records"):
        parts.append(f"{len(grid['records'])} records")
    if grid.get("intensity"):
        m, lo, hi, n = grid["intensity"]
        parts.append(f"{m}={lo:g}:{hi:g}:{n}")
    parts += [f"{name}={lo:g}" if n == 1 and lo == hi else f"{name}={lo:g}:{hi:g}:{n}"
              for name, lo, hi, n, *_ in grid["axes"]]  # (an Integer axis has a fifth field)
    return ", ".join(parts)


def _sweeps(factory: sessionmaker) -> pd.DataFrame:
    stmt = (select(Sweep.id, Scene.name.label("scene"), Sweep.scene_id, Sweep.grid, Sweep.total, Sweep.done,
                   Sweep.status, Sweep.created_at)
            .join(Scene, Scene.id == Sweep.scene_id).order_by(Sweep.id))
    df = _read(factory, stmt, {"total": "int64", "done": "int64"})
    grids = df.pop("grid")
    df.insert(2, "grid", pd.array([grid_text(g) for g in grids], dtype="string"))
    df.insert(3, "stop_time", np.array([float(g["stop_time"]) for g in grids], dtype="float64"))
    return df


def _records(factory: sessionmaker, suite: str | None = None) -> pd.DataFrame:
    from runners.engine.intensity import G0

    stmt = select(Record.id, Record.name, Record.suite, Record.event, Record.year, Record.magnitude,
                  Record.station, Record.distance_km, Record.component, Record.n_samples, Record.dt,
                  Record.duration, *[getattr(Record, m) for m in MEASURES], Record.source,
                  Record.created_at).order_by(Record.id)
    if suite is not None:
        s = suite.strip().rstrip("/")
        stmt = stmt.where(or_(Record.suite == s, Record.suite.like(f"{s}/%")))
    df = _read(factory, stmt, {"year": "Int64", **{m: "float64" for m in MEASURES}})
    df.insert(df.columns.get_loc("pga") + 1, "pga_g", df["pga"] / G0)
    return df


def _measurements(factory: sessionmaker) -> pd.DataFrame:
    b1, b2 = aliased(Block), aliased(Block)
    stmt = (select(Measurement.id, Measurement.name, Measurement.kind, b1.name.label("block1"),
                   b2.name.label("block2"), Measurement.names.label("columns"), Measurement.n_samples,
                   Measurement.sampling_rate, Measurement.instrument, Measurement.uncertainty_angle,
                   Measurement.uncertainty_time, Measurement.uncertainty_value, Measurement.excitation_id,
                   Measurement.source, Measurement.file_name, Measurement.created_at)
            .outerjoin(b1, b1.id == Measurement.block1_id).outerjoin(b2, b2.id == Measurement.block2_id)
            .order_by(Measurement.id))
    df = _read(factory, stmt, {"excitation_id": "Int64"})
    df["columns"] = pd.array([", ".join(c) for c in df["columns"]], dtype="string")
    return df


def stored_table(factory: sessionmaker, kind: str, **filters: Any) -> pd.DataFrame:
    """The stored `kind` (blocks, scenes, runs, sweeps, records, measurements) as a DataFrame
    indexed by id: readable columns (a run shows its scene's name, sweep, model, method,
    excitation, record, outcomes, whether a series is stored, created_at), no blob columns.

    Filters: runs(sweep=ID, single=True for runs in no sweep, limit=N newest); records
    (suite=NAME, the suite and those under it). Runs are newest first, the others in id
    order. ValueError for an unknown kind or filter."""
    readers = {"blocks": _blocks, "scenes": _scenes, "runs": _runs, "sweeps": _sweeps, "records": _records,
               "measurements": _measurements}
    if kind not in readers:
        raise ValueError(f"unknown table {kind!r}: one of {', '.join(KINDS)}")
    allowed = {"runs": {"sweep", "single", "limit"}, "records": {"suite"}}.get(kind, set())
    unknown = sorted(set(filters) - allowed)
    if unknown:
        raise ValueError(f"{kind} cannot be filtered by {unknown[0]!r}"
                         + (f" (filters: {', '.join(sorted(allowed))})" if allowed else ""))
    return readers[kind](factory, **filters)
