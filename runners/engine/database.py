"""A stored database seen from Python: its blocks, scenes, runs, sweeps, records and
measurements as pandas DataFrames, and one run or sweep as the API's result types.

    >>> db = open_db("results.db")              # an SQLite file, or any SQLAlchemy URL
    >>> db.runs(single=True, limit=5)           # the newest five runs that are in no sweep
    >>> db.run(12).series["block1.theta"]       # rad, indexed by time in s
    >>> db.sweep(3).to_pandas()                 # one row per grid point
    >>> db.cosims()                             # the co-simulated runs (runners cosim), newest first
    >>> db.cosim(2)["building.storey[3].a"]     # m/s2, at db.cosim(2).time (s)

Units are SI and angles radians (docs/conventions.md); docs/export.md lists every column.
"""

from __future__ import annotations

from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any

from sqlalchemy.orm import sessionmaker

from db.schema import Excitation, Run, RunSummary, Scene, Sweep
from db.session import display_url, open_database
from runners import arguments
from runners.errors import ArgumentError
from runners.engine.results import RunResult, SweepResult
from runners.engine.tables import OUTCOMES, fmu_defaults, stored_table

if TYPE_CHECKING:
    import pandas as pd

    from runners.engine.cosim_store import StoredCosim
    from runners.engine.deletion import Deleted


class Database:
    """A database of runs, opened by open_db. Every method reads but delete().

    Tables come back as DataFrames indexed by ``id`` with readable columns (names next to
    ids, no blob columns); runs are newest first, the other tables in id order.
    """

    def __init__(self, factory: sessionmaker):
        self.factory = factory  # the SQLAlchemy session factory (db.session.open_database)

    @property
    def url(self) -> str:
        """The database's URL, password hidden (sqlite:///path for an SQLite file)."""
        return display_url(self.factory.kw["bind"])

    def __repr__(self) -> str:
        return f"Database({self.url!r})"

    # -- tables -------------------------------------------------------------------------------

    def blocks(self) -> "pd.DataFrame":
        """The block catalogue: half_width, half_height (m), mass (kg), material, restitution
        law and its parameters (k, eta, correction), source."""
        return stored_table(self.factory, "blocks")

    def scenes(self) -> "pd.DataFrame":
        """Stored scenes: name, number of blocks, excitation kind, catalogue blocks, how many
        runs and sweeps use each, created_at, and the FMU parameters each sets (a dict)."""
        return stored_table(self.factory, "scenes")

    def runs(self, sweep: int | None = None, single: bool = False, limit: int | None = None) -> "pd.DataFrame":
        """Stored runs, newest first: scene name, sweep id and grid index (<NA> for single runs),
        model, method, excitation, record and scale, stop_time (s), status, the outcomes
        (peak1_over_alpha, overturned, overturn_time in s, impacts, rest_time in s, ...),
        has_series (whether run() has a time history), wall_time (s), created_at.

        sweep: only the points of this sweep; single: only runs in no sweep; limit: the
        newest N. A sweep of a million points makes a million rows: filter."""
        sweep, limit = arguments.optional(arguments.whole, sweep, "sweep"), arguments.optional(arguments.whole,
                                                                                                limit, "limit", 0)
        single = arguments.flag(single, "single")
        return stored_table(self.factory, "runs", sweep=sweep, single=single, limit=limit)

    def sweeps(self) -> "pd.DataFrame":
        """Stored sweeps: scene name, the grid in one line (w=1:12:5, a=1.01:8:4), stop_time (s),
        total points, points stored (done), status, created_at. The status is running (a process
        runs it now), interrupted (Ctrl-C, SIGTERM), stopped (its database or a worker failed, or its
        process was killed), failed (its executor could not start) or done."""
        from runners.engine.sweep_lock import shown_status

        df = stored_table(self.factory, "sweeps")
        shown = shown_status(self.factory, dict(zip(df.index.tolist(), df["status"].tolist())))
        df["status"] = [shown[i] for i in df.index.tolist()]
        return df

    def records(self, suite: str | None = None) -> "pd.DataFrame":
        """Stored ground-motion records with their provenance and intensity measures (pga in
        m/s^2 and pga_g in g, pgv m/s, pgd m, arias m/s, d5_95 and mean_period s); `suite`: only
        that suite and those under it (e.g. "fema-p695")."""
        suite = arguments.optional(arguments.text, suite, "suite", "a suite's name (str)")
        return stored_table(self.factory, "records", **({} if suite is None else {"suite": suite}))

    def measurements(self) -> "pd.DataFrame":
        """Stored measurements: name, kind, blocks, columns, number of samples, sampling rate
        (Hz), instrument, uncertainties (rad, s, m or m/s^2), source."""
        return stored_table(self.factory, "measurements")

    def cosims(self, limit: int | None = None) -> "pd.DataFrame":
        """Stored co-simulated runs (runners cosim), newest first: the system's name, engine,
        coupling, communication step and stop time (s), storeys, floor, base record and scale, the
        summary's numbers (peak_floor_acceleration in m/s2, peak_abs_theta in rad, impacts,
        overturned, energy_residual_end_relative, ...), wall_time (s), code_version, created_at.
        limit: the newest N (runners.engine.cosim_store.table)."""
        from runners.engine.cosim_store import table

        return table(limit, factory=self.factory)

    # -- one run, one sweep -------------------------------------------------------------------

    def run(self, run_id: int) -> RunResult:
        """A stored run: its series (index time in s, one column per FMU output) and events,
        its outcome (summary), the FMU parameters it ran with and its scene's name.

        Runs stored without a time history (sweep points keep their outcomes only, and the
        closed form has none) have empty series and events; summary["has_series"] says so.
        ValueError for a run that is not there."""
        from db import series as packed
        from runners.engine.tables import events_frame, series_frame

        run_id = arguments.whole(run_id, "run_id")  # np.int64 included: a plain int for the database
        with self.factory() as session:
            run = session.get(Run, run_id)
            if run is None:
                raise ArgumentError(f"no run {run_id} in the database")
            summary = _summary(session, run)
            parameters = _parameters(session, run)
            scene = run.scene.name
            recording = run.recording
            stored = run.series
            if stored is not None:
                t, cols = packed.unpack(stored.names, stored.n_samples, stored.data)
                events = list(stored.events or [])
        if stored is None:
            t, cols, events = [], {}, []
        else:
            summary = {**summary, **_full_summary(scene, parameters, t, cols, events)}
        from pathlib import Path

        return RunResult(scene=scene, series=series_frame(t, cols), events=events_frame(events), summary=summary,
                         parameters=parameters, run_id=run_id, recording=Path(recording) if recording else None)

    def sweep(self, sweep_id: int) -> SweepResult:
        """A stored sweep; its points come with to_pandas() (one row per grid point). stats
        holds its scene, grid, total points, points stored and status (as sweeps() gives it).
        ValueError for a sweep that is not there."""
        from runners.engine.sweep_lock import shown_status
        from runners.engine.tables import grid_text

        sweep_id = arguments.whole(sweep_id, "sweep_id")
        with self.factory() as session:
            sw = session.get(Sweep, sweep_id)
            if sw is None:
                raise ArgumentError(f"no sweep {sweep_id} in the database")
            stats = {"sweep": sw.id, "scene": session.get(Scene, sw.scene_id).name, "grid": grid_text(sw.grid),
                     "total": sw.total, "stored": sw.done,
                     "status": shown_status(self.factory, {sw.id: sw.status})[sw.id]}
        return SweepResult(sweep_id=sweep_id, factory=self.factory, stats=stats)


    def cosim(self, cosim_id: int | str) -> "StoredCosim":
        """A stored co-simulated run (its id, or "latest"): a runners.engine.cosim.CosimResult
        (``time`` in s, ``series`` by output name, ``system``, ``engine``, ``block_parameters``) as
        the run gave it, bit for bit, with its ``cosim_id``, ``summary``, ``building_parameters``,
        the system file's text (``source``), ``wall_time`` (s), ``code_version`` and ``created_at``;
        runners.analysis.cosim's checks and figure take it as they take a fresh run. ValueError for a
        run that is not there."""
        from runners.engine.cosim_store import load

        if not (cosim_id == "latest" or arguments.is_whole(cosim_id)):
            raise ArgumentError(f"cosim_id must be a whole number or 'latest', got {cosim_id!r}")
        return load(cosim_id if cosim_id == "latest" else int(cosim_id), factory=self.factory)

    # -- deleting ----------------------------------------------------------------------------

    def delete(self, kind: str, key: int | str, *, force: bool = False) -> "Deleted":
        """Delete a stored sweep, run or co-simulated run (kind "cosim"; its id, or "latest") or record
        (its name or id) with every row that belongs to it, in one transaction
        (runners.engine.deletion): a sweep's points with their summaries and series, a run's summary,
        series and excitation, and the scenes no other row uses, a co-simulated run's series.
        Something other rows need is refused (InUse, a RockingError and ValueError, one line naming
        them; nothing changes): a record that runs, co-simulated runs, sweeps or measurements were
        driven by or made from, a run that is a point of a sweep; with force=True those go too (a sweep's point
        is taken out of it, to be run again by resuming it). A sweep a process is running is never
        deleted. Returns a runners.engine.deletion.Deleted: rows deleted per table (.rows), what
        went with it (.with_it), .text(), .as_dict(). The database is opened for writing for this
        (DatabaseError, in one line, if it cannot be written)."""
        from runners.engine.deletion import KEY_WORDS, KINDS, delete_stored

        kind = arguments.text(kind, "kind", f"one of {', '.join(KINDS)}")
        if kind not in KINDS:
            raise ArgumentError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        if not (isinstance(key, str) and key.strip()) and not arguments.is_whole(key):
            raise ArgumentError(f"key must be {KEY_WORDS[kind]}, got {key!r}")
        key = key.strip() if isinstance(key, str) else int(key)
        if kind != "record" and isinstance(key, str) and key != "latest":
            if not key.isdecimal():
                raise ArgumentError(f"{kind} ids are whole numbers (or 'latest'), got {key!r}")
            key = int(key)
        writable = open_database(_url_of(self.factory), write=True)
        try:
            return delete_stored(writable, kind, key, force=arguments.flag(force, "force"))
        finally:
            writable.kw["bind"].dispose()


def _url_of(factory: sessionmaker) -> str:
    """The URL a session factory was opened with, password included (a read-only SQLite file's own)."""
    from db.session import sqlite_file

    engine = factory.kw["bind"]
    path = sqlite_file(engine)
    return f"sqlite:///{path}" if path is not None else engine.url.render_as_string(hide_password=False)


def _full_summary(scene: str, parameters: dict[str, Any], t, cols: dict, events: list[dict]) -> dict[str, Any]:
    """The summary runners.simulate gives (runners.engine.summary.summarize), rebuilt from a
    stored series that holds every summary output; {} for one that does not."""
    from runners.engine.fmu import Event, RunResult as Sampled
    from runners.engine.scene import Scene
    from runners.engine.summary import SUMMARY_OUTPUTS, summarize

    if any(o not in cols for o in SUMMARY_OUTPUTS):
        return {}
    sampled = Sampled(t, cols, [Event.from_dict(e) for e in events], float("nan"))
    s = summarize(Scene(name=scene, parameters=dict(parameters), stop_time=float(t[-1])), sampled, parameters)
    s.pop("wall_time_s", None)  # not stored with the series
    return s


def _summary(session, run: Run) -> dict[str, Any]:
    """A stored run's outcome: what ran (model, method, stop time in s) and how it went."""
    out: dict[str, Any] = {"scene": run.scene.name, "model": run.model, "method": run.method,
                           "status": run.status, "error_message": run.error_message, "stop_time": run.stop_time,
                           "rel_tol": run.rel_tol, "wall_time_s": run.wall_time, "sweep_id": run.sweep_id,
                           "grid_index": run.grid_index, "point": run.point, "has_series": run.series is not None,
                           "code_version": run.code_version, "created_at": _utc(run.created_at).isoformat()}
    s: RunSummary | None = run.summary
    out.update({k: None if s is None else getattr(s, k) for k in OUTCOMES})
    exc: Excitation | None = run.excitation
    if exc is not None and exc.record is not None:
        out["record"] = {"id": exc.record.id, "name": exc.record.name,
                         "scale": exc.scale if exc.scale is not None else 1.0}
    return out


def _utc(when: datetime) -> datetime:
    """A stored time in UTC (SQLite hands it back without its time zone)."""
    return when.replace(tzinfo=timezone.utc) if when.tzinfo is None else when


def _parameters(session, run: Run) -> dict[str, Any]:
    """The FMU parameters a stored run ran with: the FMU's defaults, the scene's, and a sweep
    point's grid values. A stored record's samples are named, not given as a file:
    excitation.file is left out (summary["record"] says which record drove the run)."""
    if run.sweep_id is None:
        params = {**fmu_defaults(), **run.scene.parameters}
    else:
        from runners.engine.tables import grid_of, record_refs

        sw = session.get(Sweep, run.sweep_id)
        base = {**sw.grid["defaults"], **run.scene.parameters}
        _, over, _ = grid_of(sw, record_refs(session, sw)).point(run.grid_index, base)
        params = {**base, **over}
    if run.excitation is not None and run.excitation.record is not None:
        params.pop("excitation.file", None)
    return params


def open_db(url: str | None = None, *, write: bool = False) -> Database:
    """Open a database of runs: an SQLAlchemy URL (sqlite:///results.db,
    postgresql+psycopg://user@host/name) or an SQLite file's path; None: ROCKING_DB, else
    rocking.db in the working folder, as the command line's --db.

    By default it is opened read-only: nothing is created or migrated, and a file that is not
    there is an error (runners db init creates one). write=True opens it for writing
    (creating and migrating it as the commands that store runs do). DatabaseError, in one
    line, for a database that cannot be opened."""
    return Database(open_database(arguments.database_url(url, "url"), write=arguments.flag(write, "write")))
