"""Co-simulated runs in the database: ``runners cosim`` stores each run (as ``runners simulate``
stores its own; ``--no-store`` skips it), and they are listed, read back and exported as
simulated runs are (docs/cosimulation.md#stored-runs, docs/database.md).

A stored run (tables cosim_runs and cosim_series, db/schema.py) holds the system as it ran (the
system file's text and its sha256, the building, the blocks' floor, the blocks' and the building's
FMU parameters, the base record, its scale and the sha256 of the file the building's FMU read),
the engine, the coupling, the communication step and stop time (s), the summary
(runners.analysis.cosim.summary: peaks, verdicts, the energy balance's residual), the FMUs'
sha256, the code version and wall time, and every output at every communication point, bit for
bit (db.series, as a simulated run's series).

Python API::

    from runners.analysis import cosim as checks
    from runners.engine import cosim, cosim_store
    result = cosim.run(cosim.load_system("examples/cabinet_on_floor.toml"))
    cosim_id = cosim_store.store(result, checks.run_summary(result), db="results.db")
    stored = cosim_store.load(cosim_id, db="results.db")   # a CosimResult: stored.series, .system, .summary
    cosim_store.table(db="results.db")                     # one row per stored run (a DataFrame)

Units SI (s, m, kg, N, J), angles in radians (docs/conventions.md).
"""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from runners.engine.cosim import CosimResult, System
from runners.errors import ArgumentError

if TYPE_CHECKING:
    import pandas as pd
    from sqlalchemy.orm import sessionmaker

# the summary's keys that are columns of their own (the table and db show give them once)
_SUMMARY_COLUMNS = {"system", "engine", "coupling", "floor", "storeys", "step_s", "stop_time_s"}


def _plain(value: Any) -> Any:
    """A value as JSON holds it: numpy scalars and arrays as Python's, paths as texts."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def system_dict(system: System) -> dict[str, Any]:
    """The system as stored (cosim_runs.system): its name, the building (masses in kg, storey
    stiffnesses in N/m, damping ratio), the blocks' floor, the coupling, the communication step and
    the stop time asked for (s; None: the base record's end plus 5 s, default_stop_time), the base
    (its record file, scale, start time in s, the stored record's id and name), the blocks' own
    parameters (the system's, without the FMU's defaults) and the base record's notes."""
    b = system.building
    return _plain({
        "name": system.name, "building": {"mass": list(b.mass), "stiffness": list(b.stiffness),
                                          "damping_ratio": b.damping_ratio},
        "floor": system.floor, "coupling": system.coupling, "step": system.step, "stop_time": system.stop_time,
        "default_stop_time": system.default_stop_time,
        "base": {"file": str(system.base_file), "scale": system.base_scale, "start_time": system.base_start,
                 "record": system.record, "record_file": None if system.record_file is None else str(system.record_file)},
        "blocks": dict(system.blocks), "notes": list(system.notes)})


def system_of(d: dict[str, Any], source: str = "") -> System:
    """The System a stored system_dict describes (its base record file may no longer exist)."""
    from runners.engine.supports import Building

    b, base = d["building"], d["base"]
    return System(name=d["name"], blocks=dict(d["blocks"]),
                  building=Building(mass=list(b["mass"]), stiffness=list(b["stiffness"]),
                                    damping_ratio=b["damping_ratio"]),
                  floor=d["floor"], coupling=d["coupling"], step=d["step"], stop_time=d["stop_time"],
                  base_file=Path(base["file"]), base_scale=base["scale"], base_start=base["start_time"],
                  source=source, notes=list(d.get("notes") or []), default_stop_time=d.get("default_stop_time"),
                  record_file=Path(base["record_file"]) if base.get("record_file") else None,
                  record=base.get("record"))


def _sha256_file(path: Path | str | None) -> str | None:
    if path is None or not Path(path).is_file():
        return None
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def pending_cosim(result: CosimResult, summary: dict[str, Any] | None = None, *,
                  wall_time: float | None = None) -> dict[str, Any]:
    """A co-simulated run as plain JSON values, ready to store (db.store.store_cosims) or to keep
    in a file (db.store.keep_unsaved): what cosim_runs holds, and its series packed as stored
    (db.series, base64). ``summary``: runners.analysis.cosim.summary's (None: none stored);
    ``wall_time``: s."""
    from db import series
    from db.store import COSIM_UNSAVED_FORMAT, COSIM_UNSAVED_VERSION, code_version

    if not isinstance(result, CosimResult):
        raise ArgumentError(f"result must be a CosimResult (runners.engine.cosim.run), got {type(result).__name__}")
    system = result.system
    source_path = Path(system.source) if system.source else None
    text = None
    if source_path is not None and source_path.is_file():
        try:
            text = source_path.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError):
            text = None
    names, n, blob = series.pack(result.time, result.series)
    summary = None if summary is None else _plain({k: v for k, v in summary.items() if k != "seconds"})
    return {
        "format": COSIM_UNSAVED_FORMAT, "version": COSIM_UNSAVED_VERSION,
        "created_at": datetime.now(timezone.utc).isoformat(), "code_version": code_version(),
        "name": system.name, "source": text,
        "source_sha256": None if text is None else hashlib.sha256(text.encode("utf-8")).hexdigest(),
        "source_file": str(source_path.resolve()) if text is not None else (system.source or None),
        "engine": result.engine, "coupling": system.coupling, "step": float(system.step),
        "stop_time": float(result.time[-1]), "storeys": int(system.building.storeys), "floor": int(system.floor),
        "system": system_dict(system), "block_parameters": _plain(dict(result.block_parameters)),
        "building_parameters": _plain(system.building_parameters()), "record": _plain(system.record),
        "base_scale": float(system.base_scale), "base_sha256": _sha256_file(system.base_file),
        "summary": summary, "block_fmu_sha256": _sha256_file(result.block_fmu),
        "building_fmu_sha256": _sha256_file(result.building_fmu),
        "wall_time": None if wall_time is None else float(wall_time),
        "series": {"names": names, "n_samples": n, "data": base64.b64encode(blob).decode("ascii")}}


def check_records(factory: "sessionmaker", pending: list[dict[str, Any]]) -> None:
    """ValueError, in one line and before anything is stored, for a run whose base is a stored
    record this database does not hold (a system loaded from another database)."""
    from db.store import _record_of

    with factory() as session:
        for p in pending:
            if p["record"] is not None and p["record"].get("id") is not None:
                _record_of(session, p["record"])


def store_pending(factory: "sessionmaker", pending: list[dict[str, Any]]) -> list[int]:
    """Store pending runs (pending_cosim) in one transaction; their ids. If the database fails,
    each run is kept in a file and a one-line DatabaseError names them (db.store.store_cosims)."""
    from db.store import store_cosims

    check_records(factory, pending)
    return store_cosims(factory, pending)


def store(result: CosimResult, summary: dict[str, Any] | None = None, *, db: str | None = None,
          wall_time: float | None = None) -> int:
    """Store one co-simulated run in the database ``db`` (an SQLAlchemy URL or an SQLite file's
    path; None: ROCKING_DB, else rocking.db in the working folder) and return its id.
    ``summary``: the run's numbers as runners cosim stores them
    (runners.analysis.cosim.run_summary(result)); ``wall_time``: s. DatabaseError, in one line,
    for a database that cannot be opened or written; a run the database then fails to take is kept
    in a file (rocking-unsaved-*.json) that ``runners db import-unsaved`` stores later."""
    from db.session import open_database, require_writable
    from runners import arguments

    factory = open_database(arguments.database_url(db, "db"))
    require_writable(factory)
    if summary is not None and not isinstance(summary, dict):
        raise ArgumentError(f"summary must be a dict (runners.analysis.cosim.run_summary), got {type(summary).__name__}")
    if wall_time is not None:
        wall_time = arguments.number(wall_time, "wall_time")
    return store_pending(factory, [pending_cosim(result, summary, wall_time=wall_time)])[0]


# ------------------------------------------------------------------ reading back

@dataclass
class StoredCosim(CosimResult):
    """A stored co-simulated run: a CosimResult (``system``, ``engine``, ``time``, ``series``,
    ``block_parameters``; the analysis functions take it as they take a fresh run) with what the
    database adds: its id, the summary stored with it, the building's parameters as run, the
    system file's text, its wall time (s), the code version and when it ran."""

    cosim_id: int = 0
    summary: dict[str, Any] | None = None
    building_parameters: dict[str, Any] = field(default_factory=dict)
    source: str | None = None
    wall_time: float | None = None
    code_version: str = ""
    created_at: datetime | None = None


def _utc(when: datetime) -> datetime:
    return when.replace(tzinfo=timezone.utc) if when.tzinfo is None else when


def _open(factory: "sessionmaker | None", db: str | None) -> "sessionmaker":
    if factory is not None:
        return factory
    from db.session import open_database
    from runners import arguments

    return open_database(arguments.database_url(db, "db"), write=False)


def resolve(factory: "sessionmaker", key: int | str) -> int:
    """A stored co-simulated run's id from an id or 'latest' (the newest); ValueError, in one line,
    for one that is not there."""
    from sqlalchemy import func, select

    from db.schema import CosimRun

    with factory() as session:
        if key == "latest":
            newest = session.scalar(select(func.max(CosimRun.id)))
            if newest is None:
                raise ValueError("no co-simulated run in the database, so none is the latest")
            return int(newest)
        from db.session import MAX_ID
        from runners import arguments

        ident = int(key) if isinstance(key, str) and key.strip().isdecimal() else \
            arguments.whole(key, "cosim_id", 0) if not isinstance(key, str) else None
        if ident is None:
            raise ValueError(f"co-simulated runs' ids are whole numbers (or 'latest'), got {key!r}")
        if ident > MAX_ID or session.get(CosimRun, ident) is None:
            raise ValueError(f"no co-simulated run {key} in the database (runners db list cosims lists them)")
        return ident


def load(cosim_id: int | str, *, db: str | None = None, factory: "sessionmaker | None" = None) -> StoredCosim:
    """A stored co-simulated run (an id, or 'latest'), its series bit for bit as they were run.
    ``db``: as store()'s, opened read-only. ValueError for a run that is not there."""
    from db import series
    from db.schema import CosimRun

    factory = _open(factory, db)
    ident = resolve(factory, cosim_id)
    with factory() as session:
        run = session.get(CosimRun, ident)
        t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
        return StoredCosim(system=system_of(run.system, run.source_file or ""), engine=run.engine, time=t,
                           series=cols, block_parameters=dict(run.block_parameters), cosim_id=run.id,
                           summary=None if run.summary is None else dict(run.summary),
                           building_parameters=dict(run.building_parameters), source=run.source,
                           wall_time=run.wall_time, code_version=run.code_version,
                           created_at=_utc(run.created_at))


def row(run) -> dict[str, Any]:
    """A stored run (a CosimRun) as ``runners db show cosim`` gives it: every column but the
    blobs, the record's name, and its series' names and number of samples."""
    out: dict[str, Any] = {}
    for col in run.__table__.columns:
        v = getattr(run, col.key)
        out[col.key] = _utc(v).isoformat() if isinstance(v, datetime) else v
    out["record"] = None if run.record is None else {"id": run.record.id, "name": run.record.name}
    out["series"] = None if run.series is None else {"names": run.series.names, "n_samples": run.series.n_samples}
    return out


def table(limit: int | None = None, *, db: str | None = None, factory: "sessionmaker | None" = None) -> "pd.DataFrame":
    """The stored co-simulated runs, newest first, indexed by ``id``: the system's name, engine,
    coupling, communication step and stop time (s), storeys, floor, base record and scale, then
    the summary's numbers (peak_floor_acceleration in m/s2, peak_abs_theta in rad, impacts,
    overturned, energy_residual_end_relative, ...), wall_time (s), code_version, created_at.
    ``limit``: the newest N."""
    import pandas as pd
    from sqlalchemy import select
    from sqlalchemy.orm import selectinload

    from db.schema import CosimRun
    from runners import arguments

    limit = arguments.optional(arguments.whole, limit, "limit", 0)
    factory = _open(factory, db)
    with factory() as session:
        query = select(CosimRun).options(selectinload(CosimRun.record)).order_by(CosimRun.id.desc())
        runs = session.scalars(query if limit is None else query.limit(limit)).all()
        rows = []
        for r in runs:
            s = {k: v for k, v in (r.summary or {}).items() if k not in _SUMMARY_COLUMNS}
            rows.append({"id": r.id, "name": r.name, "engine": r.engine, "coupling": r.coupling, "step": r.step,
                         "stop_time": r.stop_time, "storeys": r.storeys, "floor": r.floor,
                         "record": None if r.record is None else r.record.name, "base_scale": r.base_scale, **s,
                         "wall_time": r.wall_time, "code_version": r.code_version,
                         "created_at": _utc(r.created_at)})
    columns = ["id", "name", "engine", "coupling", "step", "stop_time", "storeys", "floor", "record", "base_scale"]
    df = pd.DataFrame(rows, columns=list(dict.fromkeys(columns + [k for r in rows for k in r])))
    return df.set_index("id")


# ------------------------------------------------------------------ units (export)

_BUILDING_UNITS = {"u": "m", "v": "m/s", "a": "m/s2", "base.aTotal": "m/s2", "baseShear": "N", "energy": "J",
                   "baseWork": "J", "forceWork": "J", "dampingLoss": "J", "force": "N"}


def units(names: list[str]) -> dict[str, str]:
    """The unit of each stored output ("building.storey[3].a": m/s2, "block.block1.theta": rad; ""
    for counts and flags)."""
    from runners.engine.tables import variable_units

    block = variable_units()
    out = {"time": "s"}
    for name in names:
        comp, _, var = name.partition(".")
        if comp == "building":
            out[name] = _BUILDING_UNITS.get(var.rsplit(".", 1)[-1] if var.startswith("storey[") else var, "")
        else:
            out[name] = block.get(var, "")
    return out
