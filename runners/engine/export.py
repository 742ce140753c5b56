"""Write stored results to files other tools read: a run's series and events, or a sweep's
points (one row per grid point), as CSV, Parquet or JSON (docs/export.md).

Files (ID the run's or sweep's id; --out names the main file, the events file is named
after it: results.csv and results-events.csv):

- a run, csv:     run-ID.csv (time in s, then one column per FMU output) and
                  run-ID-events.csv (time, kind, then the events' fields);
- a run, parquet: run-ID.parquet and run-ID-events.parquet, the same columns; each file's
                  schema metadata holds, under the key "rocking", the units of the columns,
                  the run's outcome and the FMU parameters it ran with;
- a run, json:    run-ID.json, one object {run, scene, parameters, summary, units,
                  series: {time: [...], column: [...]}, events: [{time, kind, ...}]};
- a sweep:        sweep-ID.csv, sweep-ID.parquet (units and the sweep's grid in the metadata)
                  or sweep-ID.json ({sweep, units, points: [{column: value}, ...]});
- a co-simulated run (runners cosim): cosim-ID.csv (time in s, then every output of the
                  building and the blocks, "building.storey[3].a", "block.block1.theta", ...),
                  cosim-ID.parquet (the units, the system, summary and parameters in the
                  metadata) or cosim-ID.json ({cosim, system, engine, coupling, step, parameters,
                  summary, units, series: {time: [...], column: [...]}}); no events file.

Floats are written so that they read back bit for bit: in CSV and JSON as the shortest
decimal that does (what Python's repr prints; 0.1, not 0.10000000000000001), in Parquet as
float64. Units are SI and
angles radians (docs/conventions.md); CSV files hold no units (docs/export.md lists them).

Every file is written beside its destination under a temporary name and renamed into place
once all of an export's files are whole: an export that fails leaves nothing behind, and an
existing file is replaced whole or not at all (as runners map --out and runners rrd replace
theirs). Sweeps are read and written a chunk of grid points at a time, in bounded memory.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from sqlalchemy.orm import sessionmaker

FORMATS = {"csv": ".csv", "parquet": ".parquet", "json": ".json"}  # format -> file suffix
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet", ".json": "json"}
ROWS_PER_WRITE = 100_000  # series rows written at a time (progress, bounded memory)
METADATA_KEY = b"rocking"  # Parquet schema metadata: units, run or sweep


@dataclass
class Exported:
    """What an export wrote: the files (main first) and the rows of the main file (samples of
    a run's series, grid points of a sweep)."""

    files: list[Path]
    rows: int
    events: int | None = None  # rows of a run's events file
    pending: int = 0  # grid points of a sweep not stored yet (rows with status "pending")


def choose_format(fmt: str | None, out: str | None) -> str:
    """The format to write: `fmt` if given, else the suffix of `out` (.csv, .parquet or .pq,
    .json), else csv. ValueError for an unknown format, an --out whose suffix is none of those
    (x.xlsx would hold CSV text that Excel refuses to open), or --out naming another format."""
    if fmt is not None and fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}: csv, parquet or json")
    suffix = Path(out).suffix.lower() if out else ""
    if suffix and suffix not in SUFFIXES:
        raise ValueError(f"--out {out}: runners export writes csv, parquet or json files (.csv, .parquet or .pq, "
                         f".json), not {suffix} (spreadsheets open the .csv)")
    by_suffix = SUFFIXES.get(suffix) if out else None
    if fmt is not None and by_suffix is not None and by_suffix != fmt:
        raise ValueError(f"--out {out} names a {by_suffix} file, and --format is {fmt}: make them agree")
    return fmt or by_suffix or "csv"


def events_path(main: Path) -> Path:
    """The events file that goes with a run's main file: results.csv -> results-events.csv."""
    return main.with_name(f"{main.stem}-events{main.suffix}")


def check_destination(dest: Path) -> None:
    """OSError, in one line, for a destination that exists and is not a regular file."""
    if dest.is_dir() or (dest.exists() and not dest.resolve().is_file()):
        raise OSError(f"cannot write {dest}: it exists and is not a file")


class _Files:
    """Files written under temporary names beside their destinations, renamed into place by
    commit(); removed if the export fails before."""

    def __init__(self) -> None:
        self.pending: list[tuple[Path, Path]] = []  # (temporary, destination)

    def open(self, dest: Path, mode: str = "w"):
        """A new temporary file beside `dest`, opened for writing."""
        check_destination(dest)
        folder = dest.parent
        from db.leftovers import remove_stale, tag

        try:
            folder.mkdir(parents=True, exist_ok=True)
            remove_stale(folder, f".{dest.name}.", ".part")  # left by exports killed outright
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.{tag()}-", suffix=".part", dir=folder)
        except OSError as exc:
            raise OSError(f"cannot write {dest}: {exc.strerror or exc}") from None
        self.pending.append((Path(tmp), dest))
        return os.fdopen(fd, mode, **({"newline": "", "encoding": "utf-8"} if "b" not in mode else {}))

    def commit(self) -> list[Path]:
        for tmp, dest in self.pending:
            try:
                os.chmod(tmp, 0o666 & ~_UMASK)  # as open() would have made it (mkstemp makes 0600)
                os.replace(tmp, dest)
            except OSError as exc:
                raise OSError(f"cannot write {dest}: {exc.strerror or exc}") from None
        done = [dest for _, dest in self.pending]
        self.pending.clear()
        return done

    def discard(self) -> None:
        for tmp, _ in self.pending:
            tmp.unlink(missing_ok=True)
        self.pending.clear()

    def __enter__(self) -> "_Files":
        return self

    def __exit__(self, *exc) -> None:
        self.discard()  # nothing left if commit() was not reached


def _read_umask() -> int:
    """The process's umask (read once, at import: setting it to read it is not thread-safe)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _read_umask()


def _bar(total: int, desc: str, progress: bool, unit: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, disable=not (progress and sys.stderr.isatty()), leave=False)


def _plain(v: Any) -> Any:
    """A value as JSON has it: numpy scalars as Python ones, NaN as null."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and math.isnan(v):
        return None
    return v


def _json(obj: Any) -> str:
    def default(o: Any) -> Any:
        if isinstance(o, np.generic):
            return o.item()
        if hasattr(o, "isoformat"):
            return o.isoformat()
        return str(o)

    return json.dumps(obj, default=default, allow_nan=True)


# ---------------------------------------------------------------------------------------------
# a run


def export_run(factory: sessionmaker, run_id: int, fmt: str = "csv", out: str | Path | None = None,
               progress: bool = False) -> Exported:
    """Write stored run `run_id`'s series and events as `fmt` (csv, parquet, json) to `out`
    (default: run-ID.EXT in the working folder; the events beside it). ValueError for a run
    that is not there or has no stored series (sweep points, the closed form)."""
    from runners.engine.database import Database
    from runners.engine.tables import no_series, variable_units

    fmt = choose_format(fmt, str(out) if out is not None else None)
    result = Database(factory).run(run_id)
    s = result.summary
    if not s["has_series"]:
        raise ValueError(no_series(run_id, s["sweep_id"], s["grid_index"], s["model"]))
    main = Path(out) if out is not None else Path(f"run-{run_id}{FORMATS[fmt]}")
    units = {"time": "s", **{c: variable_units().get(c, "") for c in result.series.columns}}
    meta = {"run": run_id, "scene": result.scene, "units": units, "summary": s, "parameters": result.parameters}
    series, events = result.series, result.events
    for dest in [main] if fmt == "json" else [main, events_path(main)]:
        check_destination(dest)  # before writing anything
    with _Files() as files:
        if fmt == "csv":
            _frame_csv(files, main, series, progress, f"run {run_id}")
            _frame_csv(files, events_path(main), events)
        elif fmt == "parquet":
            _parquet(files, main, series, meta, index=True)
            _parquet(files, events_path(main), events, {**meta, "units": _event_units(events)}, index=False)
        else:
            _run_json(files, main, meta, series, _stored_events(factory, run_id), progress)
        written = files.commit()
    return Exported(written, len(series), len(events))


def export_cosim(factory: sessionmaker, cosim_id: int, fmt: str = "csv", out: str | Path | None = None,
                 progress: bool = False) -> Exported:
    """Write stored co-simulated run `cosim_id`'s series (every output at every communication
    point) as `fmt` (csv, parquet, json) to `out` (default: cosim-ID.EXT in the working folder).
    ValueError for a run that is not there."""
    from runners.engine.cosim_store import load, system_dict, units
    from runners.engine.tables import series_frame

    fmt = choose_format(fmt, str(out) if out is not None else None)
    run = load(cosim_id, factory=factory)
    main = Path(out) if out is not None else Path(f"cosim-{cosim_id}{FORMATS[fmt]}")
    series = series_frame(run.time, run.series)
    meta = {"cosim": cosim_id, "system": run.system.name, "engine": run.engine, "coupling": run.system.coupling,
            "step": run.system.step, "units": units(list(run.series)), "summary": run.summary,
            "parameters": {"system": system_dict(run.system), "blocks": run.block_parameters,
                           "building": run.building_parameters}}
    check_destination(main)  # before writing anything
    with _Files() as files:
        if fmt == "csv":
            _frame_csv(files, main, series, progress, f"cosim {cosim_id}")
        elif fmt == "parquet":
            _parquet(files, main, series, meta, index=True)
        else:
            _cosim_json(files, main, meta, series, progress)
        written = files.commit()
    return Exported(written, len(series))


def _series_json(fh, head: dict, series, bar) -> None:
    """head as JSON with its "series": time and every column, one column at a time (the object left open)."""
    fh.write(_json(head)[:-1] + ', "series": {')
    columns = [("time", series.index.to_numpy())] + [(c, series[c].to_numpy()) for c in series.columns]
    for k, (name, values) in enumerate(columns):
        fh.write(("" if k == 0 else ", ") + json.dumps(name) + ": ")
        fh.write(json.dumps([_plain(v) for v in values.tolist()]))
        bar.update(1)


def _cosim_json(files: _Files, path: Path, meta: dict, series, progress: bool) -> None:
    head = {k: meta[k] for k in ("cosim", "system", "engine", "coupling", "step", "parameters", "summary", "units")}
    with files.open(path) as fh, _bar(series.shape[1] + 1, f"cosim {meta['cosim']}", progress, "column") as bar:
        _series_json(fh, head, series, bar)
        fh.write("}}\n")


def _stored_events(factory: sessionmaker, run_id: int) -> list[dict]:
    """A run's events as JSON writes them: time, kind, then its fields as the FMU logged them."""
    from sqlalchemy import select

    from db.schema import RunSeries

    with factory() as session:
        events = session.scalar(select(RunSeries.events).where(RunSeries.run_id == run_id)) or []
    return [{"time": e["t"], "kind": e["kind"], **(e.get("values") or {}), **(e.get("labels") or {})}
            for e in events]


def _event_units(events) -> dict[str, str]:
    known = {"time": "s", "theta": "rad", "theta1": "rad", "theta2": "rad", "omega_minus": "rad/s",
             "omega_plus": "rad/s", "w1": "rad/s", "w2": "rad/s", "w1m": "rad/s", "w2m": "rad/s", "w1p": "rad/s",
             "w2p": "rad/s"}
    return {c: known.get(c, "") for c in events.columns}


def _csv_writer(fh, schema):
    """A pyarrow CSV writer on binary file `fh`: the header written here (names quoted only
    where CSV needs it), floats in their shortest form that reads back bit for bit, empty
    fields for missing values, true/false for flags."""
    import csv
    import io

    import pyarrow.csv as pcsv

    head = io.StringIO()
    csv.writer(head, lineterminator="\n").writerow(schema.names)
    fh.write(head.getvalue().encode("utf-8"))
    return pcsv.CSVWriter(fh, schema, write_options=pcsv.WriteOptions(include_header=False,
                                                                      quoting_style="needed"))


def _frame_csv(files: _Files, path: Path, frame, progress: bool = False, desc: str = "") -> None:
    """A frame (its index first, when named) to a CSV file, ROWS_PER_WRITE rows at a time."""
    import pyarrow as pa

    if frame.index.name is not None:
        frame = frame.reset_index()
    schema = pa.Table.from_pandas(frame.iloc[:0], preserve_index=False).schema
    with files.open(path, "wb") as fh, _bar(len(frame), desc, progress, "row") as bar:
        with _csv_writer(fh, schema) as writer:
            for lo in range(0, len(frame), ROWS_PER_WRITE):
                part = frame.iloc[lo:lo + ROWS_PER_WRITE]
                writer.write_table(pa.Table.from_pandas(part, schema=schema, preserve_index=False))
                bar.update(len(part))


def _parquet(files: _Files, path: Path, frame, meta: dict, index: bool) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame, preserve_index=index)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), METADATA_KEY: _json(meta).encode()})
    with files.open(path, "wb") as fh:
        pq.write_table(table, fh)


def _run_json(files: _Files, path: Path, meta: dict, series, events, progress: bool) -> None:
    head = {"run": meta["run"], "scene": meta["scene"], "parameters": meta["parameters"], "summary": meta["summary"],
            "units": meta["units"]}
    with files.open(path) as fh, _bar(series.shape[1] + 1, f"run {meta['run']}", progress, "column") as bar:
        _series_json(fh, head, series, bar)
        fh.write('}, "events": ' + json.dumps(events) + "}\n")


# ---------------------------------------------------------------------------------------------
# a sweep


def sweep_units(grid: dict) -> dict[str, str]:
    """Units of a sweep frame's columns ("" for counts, flags, texts and ratios; docs/export.md)."""
    from runners.engine.tables import variable_units

    units = {"w": "1 (omega_g / p)", "a": "1 (a_g / (g tan alpha))", "scale": "", "pga": "m/s2", "pgv": "m/s",
             "pgd": "m", "arias": "m/s", "pga_g": "g", "pfa": "m/s2", "sa_t1": "m/s2", "overturn_time": "s", "rest_time": "s",
             "slide_time": "s", "lift_time": "s", "fall_time": "s",
             "peak1_over_alpha": "1 (max |theta1| / alpha1)", "peak2_over_alpha": "1 (max |theta2| / alpha2)",
             "max_abs_slip": "m", "residual_slip": "m", "block2_max_abs_slip": "m", "block2_residual_slip": "m",
             "max_residual_slip": "m"}
    for k in range(1, 9):  # a column's blocks
        units.update({f"block{k}_peak_over_alpha": f"1 (max |theta{k}| / alpha{k})", f"block{k}_max_abs_slip": "m",
                      f"block{k}_residual_slip": "m"})
    if grid.get("intensity"):
        from runners.engine.sweep import IM_UNITS

        units["level"] = IM_UNITS[grid["intensity"][0]][0]
    for name, *_ in grid["axes"]:
        units.setdefault(name, variable_units().get(name, ""))
    return units


def export_sweep(factory: sessionmaker, sweep_id: int, fmt: str = "csv", out: str | Path | None = None,
                 progress: bool = False, chunk: int | None = None) -> Exported:
    """Write stored sweep `sweep_id` as `fmt` (csv, parquet, json) to `out` (default:
    sweep-ID.EXT in the working folder): one row per grid point in grid order (the columns of
    runners.engine.tables.sweep_frame), points not stored yet with status "pending". Read and
    written `chunk` grid points at a time. ValueError for a sweep that is not there or has no
    stored point yet."""
    from runners.engine.tables import CHUNK, frames_of, grid_text, stored_sweep, sweep_columns

    fmt = choose_format(fmt, str(out) if out is not None else None)
    sw, params, refs = stored_sweep(factory, sweep_id)
    if sw.done == 0:
        raise ValueError(f"sweep {sweep_id} has no stored points yet: run them with runners sweep {sweep_id}")
    main = Path(out) if out is not None else Path(f"sweep-{sweep_id}{FORMATS[fmt]}")
    columns = sweep_columns(sw, params)
    units = {c: sweep_units(sw.grid).get(c, "") for c in columns}
    meta = {"sweep": sweep_id, "grid": grid_text(sw.grid), "axes": sw.grid["axes"], "total": sw.total,
            "stored": sw.done, "status": sw.status, "stop_time": sw.grid["stop_time"], "units": units,
            "scene": params, "defaults": sw.grid["defaults"]}
    frames = frames_of(factory, sw, params, refs, chunk or CHUNK, False)
    with _Files() as files, _bar(sw.total, f"sweep {sweep_id}", progress, "point") as bar:
        writer = {"csv": _sweep_csv, "parquet": _sweep_parquet, "json": _sweep_json}[fmt]
        rows, pending = writer(files, main, _counted(frames, bar), columns, meta)
        written = files.commit()
    return Exported(written, rows, pending=pending)


def _counted(frames: Iterator, bar) -> Iterator:
    for df in frames:
        yield df
        bar.update(len(df))


def _sweep_csv(files: _Files, path: Path, frames, columns: dict, meta: dict) -> tuple[int, int]:
    import pyarrow as pa

    schema = _arrow_schema(columns, meta)
    rows = pending = 0
    with files.open(path, "wb") as fh, _csv_writer(fh, schema) as writer:
        for df in frames:
            writer.write_table(pa.Table.from_pandas(df, schema=schema, preserve_index=False))
            rows += len(df)
            pending += int((df["status"] == "pending").sum())
    return rows, pending


def _arrow_schema(columns: dict, meta: dict):
    import pyarrow as pa

    types = {"float64": pa.float64(), "int64": pa.int64(), "Int64": pa.int64(), "boolean": pa.bool_(),
             "string": pa.string()}
    schema = pa.schema([pa.field(c, types[d], nullable=d != "int64") for c, d in columns.items()])
    return schema.with_metadata({METADATA_KEY: _json(meta).encode()})


def _sweep_parquet(files: _Files, path: Path, frames, columns: dict, meta: dict) -> tuple[int, int]:
    """One row group per chunk, under a schema fixed before the first (a chunk whose column
    holds no value gets its type from the sweep's columns, not from its values); pandas'
    own metadata rides along, so pandas.read_parquet gives back the frame's dtypes."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = _arrow_schema(columns, meta)
    rows = pending = 0
    with files.open(path, "wb") as fh, ExitStack() as stack:
        writer = None
        for df in frames:
            table = pa.Table.from_pandas(df, schema=schema, preserve_index=False)
            if writer is None:
                full = table.schema.with_metadata({**(table.schema.metadata or {}), **schema.metadata})
                writer = stack.enter_context(pq.ParquetWriter(fh, full))
            writer.write_table(table.replace_schema_metadata(writer.schema.metadata))
            rows += len(df)
            pending += int((df["status"] == "pending").sum())
    return rows, pending


def _sweep_json(files: _Files, path: Path, frames, columns: dict, meta: dict) -> tuple[int, int]:
    rows = pending = 0
    with files.open(path) as fh:
        fh.write('{"sweep": ' + _json({k: v for k, v in meta.items() if k != "units"}) + ', "units": '
                 + _json(meta["units"]) + ', "points": [')
        for df in frames:
            lists = [[_plain(v) for v in df[c].astype(object).where(df[c].notna(), None).tolist()]
                     for c in columns]
            for k, values in enumerate(zip(*lists)):
                fh.write(("," if rows + k else "") + "\n" + json.dumps(dict(zip(columns, values))))
            rows += len(df)
            pending += int((df["status"] == "pending").sum())
        fh.write("\n]}\n")
    return rows, pending
