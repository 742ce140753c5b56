"""``runners sweep``: a grid of runs of one scene, in parallel worker processes, stored in
batches; resumable after any interruption (each batch is one transaction and each grid
point has one unique slot, so a resumed sweep stores every point exactly once).

Grid axes (NAME=START:STOP:COUNT) are FMU parameters (dimensional, e.g.
excitation.amplitude; an Integer parameter such as solver.method takes whole numbers
only, solver.method=0:1:2, and is stored and set as an int) or the dimensionless groups of
Dimitrakopoulos & DeJong (2012):

- ``w`` (or ``omega_g/p``): excitation.frequency = w p / (2 pi), with
  p = sqrt(3 g / (4 R)) of block 1;
- ``a`` (or ``a_g/(g tan alpha)``): excitation.amplitude = a g tan(alpha) for
  one block, a g kappa for two (kappa = min(b1 / yG, c / h2), the stack's
  uplift threshold, docs/two_blocks.md);
- ``scale``: excitation.scale, the multiplier of a record.

A sweep over records (``--records``, docs/records.md) runs every record of a list with
each point of the grid; ``--im pga=START:STOP:COUNT`` (in g; or ``pgv=`` in m/s) scales
each record so that its PGA (PGV) takes each of COUNT values. The flat grid index runs
over records first, then intensity levels, then the --grid axes (last fastest). Each
point stores its record, scale and the scaled record's intensity measures; workers get
each record's samples once and read them as a file (runners.engine.record_files).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
from sqlalchemy import func, insert, select, update
from sqlalchemy.exc import IntegrityError

from db.schema import Excitation, Run, RunSeries, RunSummary, Scene, Sweep
from db.series import pack as pack_series
from db.store import add_scene, code_version, file_sha256
from runners.engine.fmu import FMUError, RockingFMU, with_scene_defaults
from runners.engine.intensity import G0, SCALING
from runners.engine.motion import (SLIP_OUTPUTS, STACK_SLIP_OUTPUTS, contact_model_value, rocking_sliding,
                                   slip_summary, stack_slip_summary)
from runners.engine.scene import KINDS, MAX_PGA_G, unused_parameter
from runners.errors import RockingError

ALIASES = {"w": "w", "omega_g/p": "w", "a": "a", "a_g/(g tan alpha)": "a", "scale": "excitation.scale"}
ONE = ["overturned", "impacts", "block1.maxAbsTheta", "overturnTime", "restTime", "atRest",
       "slideTime", "liftTime", "friction.demandMaxGround", "contact.normalMinGround", "friction.impulseDemandMax", "fallTime"]
TWO = ["block2.maxAbsTheta", "impactsGround", "impactsInterface", "block1.overturned", "block2.overturned",
       "friction.demandMaxInterface", "contact.normalMinInterface"]


@dataclass(frozen=True)
class Axis:
    name: str  # "w", "a" or an FMU parameter
    start: float
    stop: float
    count: int
    integer: bool = False  # an Integer FMU parameter: every value a whole number, given to the FMU as an int

    @property
    def values(self) -> np.ndarray:
        return np.array([self.value(i) for i in range(self.count)]) if self.integer \
            else np.linspace(self.start, self.stop, self.count)

    def value(self, i: int) -> float | int:
        """values[i], computed alone (a grid point must not cost the whole axis), bit for bit."""
        v = _linspace_at(self.start, self.stop, self.count, i)
        return int(round(v)) if self.integer else v


def _linspace_at(start: float, stop: float, count: int, i: int) -> float:
    """np.linspace(start, stop, count)[i], by numpy's own arithmetic."""
    if count == 1:
        return float(start)
    if i == count - 1:
        return float(stop)
    step = (stop - start) / (count - 1)
    if step == 0:
        return float(i / (count - 1) * (stop - start) + start)
    return float(i * step + start)


def axis_parameters(fmu: RockingFMU) -> dict[str, str]:
    """The FMU parameters a --grid axis may set, name -> type ("Real" or "Integer")."""
    return {n: v.type for n, v in fmu.vars.items() if v.causality == "parameter" and v.type in ("Real", "Integer")}


def parse_axis(spec: str, parameters: Mapping[str, str] | Iterable[str]) -> Axis:
    """NAME=START:STOP:COUNT, with a one-line reason when it is malformed. `parameters`: the FMU
    parameters an axis may set, name -> type ("Real" or "Integer"; axis_parameters), or a set of
    Real parameters' names. An Integer parameter's axis takes whole numbers only (START, STOP and
    the spacing (STOP - START) / (COUNT - 1)), e.g. solver.method=0:1:2."""
    types = dict(parameters) if isinstance(parameters, Mapping) else dict.fromkeys(parameters, "Real")
    name, eq, rng = spec.partition("=")
    parts = rng.split(":")
    if name.strip() == "contact.model" and eq and len(parts) == 1 and types.get("contact.model") == "Integer":
        try:  # one model for every point: contact.model=rocking-sliding (or =1)
            model = contact_model_value(rng)
        except ValueError as exc:
            raise ValueError(f"--grid {spec!r}: {exc}") from None
        return Axis("contact.model", model, model, 1, True)
    if not eq or len(parts) != 3:
        raise ValueError(f"--grid {spec!r}: expected NAME=START:STOP:COUNT")
    name = ALIASES.get(name.strip(), name.strip())
    if name not in ("w", "a") and types.get(name) not in ("Real", "Integer"):
        raise ValueError(f"--grid {spec!r}: unknown name {name!r} (w, a, or a Real or Integer FMU parameter)")
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"--grid {spec!r}: START and STOP must be numbers and COUNT an integer") from None
    if count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
        raise ValueError(f"--grid {spec!r}: COUNT must be >= 1 and START, STOP finite")
    if count > 1 and start == stop:
        raise ValueError(f"--grid {spec!r}: START = STOP gives {count} identical points (COUNT 1, or set it in the "
                         "scene)")
    if types.get(name) == "Integer":
        gap = (stop - start) / (count - 1) if count > 1 else 1.0
        if not (start.is_integer() and stop.is_integer() and gap.is_integer()):
            raise ValueError(f"--grid {spec!r}: {name} is an Integer parameter: START, STOP and the spacing "
                             f"(STOP - START) / (COUNT - 1) must be whole numbers, e.g. {name}="
                             f"{math.floor(start)}:{math.floor(start) + 1}:2")
        if name == "contact.model" and not {start, stop} <= {0.0, 1.0}:
            raise ValueError(f"--grid {spec!r}: contact.model is 0 (rigid-rocking) or 1 (rocking-sliding): "
                             "contact.model=0:1:2 runs both, contact.model=rocking-sliding one")
        return Axis(name, int(start), int(stop), count, True)
    return Axis(name, start, stop, count)


def target(name: str, p: dict[str, Any]) -> str:
    """The FMU parameter an axis sets in a scene of parameters `p`: w the frequency, a the
    amplitude (a harmonic's displacement), any other axis the parameter it names."""
    if name == "w":
        return "excitation.frequency"
    if name == "a":
        return "excitation.displacement" if int(p.get("excitation.kind", 0)) == KINDS["harmonic"] \
            else "excitation.amplitude"
    return name


# parameters rigid rocking does not let change the motion: the friction coefficients enter the
# contact monitors only (docs/contact.md); the column that answers for any mu instead. The
# rocking–sliding model (contact.model = 1, one block) slides on contact.muGround: there it may be swept
MOTION_FREE = {"contact.muGround": "friction_demand_max", "contact.muInterface": "friction_demand_max_interface"}
SLIDING_ON = {"contact.muGround"}  # the friction coefficients the rocking–sliding model slides on


def check_axes(axes: list[Axis], p: dict[str, Any]) -> None:
    """ValueError, in one line, for axes that would give a grid of identical or contradictory
    points in a scene of FMU parameters `p` (defaults included): two axes setting one
    parameter, an axis on a friction coefficient (MOTION_FREE), or an axis on a parameter the
    scene does not use (with any value of the grid's Integer axes, e.g. restitution.k on a
    restitution.law axis that includes "modified")."""
    import itertools

    setters: dict[str, str] = {}
    for ax in axes:
        param = target(ax.name, p)
        if param in setters:
            raise ValueError(f"--grid {setters[param]} and --grid {ax.name} both set {param}: keep one")
        setters[param] = ax.name
    ints = [ax for ax in axes if ax.integer]
    cases = [{**p, **dict(zip([ax.name for ax in ints], combo))}
             for combo in itertools.islice(itertools.product(*[ax.values.tolist() for ax in ints]), 1024)]
    sliding = any(rocking_sliding(q) and int(q.get("nBlocks", 1)) == 1 for q in cases)
    for ax in axes:
        if ax.name in MOTION_FREE and not (sliding and ax.name in SLIDING_ON):
            raise ValueError(f"--grid {ax.name}: with rigid rocking friction does not change the motion (every point "
                             f"would run the same simulation; each run stores {MOTION_FREE[ax.name]}, the friction it "
                             "needed): let one block slide, contact.model = rocking-sliding "
                             "(--grid contact.model=rocking-sliding)")
    for ax in axes:
        whys = [unused_parameter(target(ax.name, q), q) for q in cases]
        if all(whys):
            raise ValueError(f"--grid {ax.name}: {whys[0]}, so every point would be the same")


def scales(p: dict[str, Any]) -> tuple[float, float]:
    """(p, uplift acceleration) of the scene: rad/s and m/s^2 per unit of w and a."""
    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    pf = math.sqrt(3 * g / (4 * math.hypot(b, h)))
    if int(p.get("nBlocks", 1)) == 2:
        b2, h2, m1, m2 = p["block2.halfWidth"], p["block2.halfHeight"], p["block1.mass"], p["block2.mass"]
        y_g = (m1 * h + m2 * (2 * h + h2)) / (m1 + m2)
        return pf, g * min(b / y_g, min(b, b2) / h2)
    return pf, g * b / h


IM_UNITS = {"pga": ("g", G0), "pgv": ("m/s", 1.0)}  # --im measure: unit of its levels, factor to SI
# levels beyond these are a mistake of units, not an earthquake (the largest recorded PGA is
# about 4 g, the largest PGV about 3 m/s)
IM_LIMITS = {"pga": MAX_PGA_G, "pgv": 10.0}


@dataclass(frozen=True)
class Intensity:
    """--im MEASURE=START:STOP:COUNT: each record scaled so that MEASURE takes COUNT values."""

    measure: str  # pga (levels in g) or pgv (m/s)
    start: float
    stop: float
    count: int

    @property
    def unit(self) -> str:
        return IM_UNITS[self.measure][0]

    @property
    def values(self) -> np.ndarray:
        """The levels, in self.unit (12 significant digits: 0.8, not 0.7999999999999999)."""
        return np.array([self.level(i) for i in range(self.count)])

    def level(self, i: int) -> float:
        """values[i], computed alone."""
        return float(f"{_linspace_at(self.start, self.stop, self.count, i):.12g}")

    def si(self, level: float) -> float:
        return level * IM_UNITS[self.measure][1]


def parse_intensity(spec: str) -> Intensity:
    """pga=START:STOP:COUNT (g) or pgv=START:STOP:COUNT (m/s), levels above zero."""
    name, eq, rng = spec.partition("=")
    parts = rng.split(":")
    name = name.strip().lower()
    if not eq or len(parts) != 3 or name not in IM_UNITS:
        raise ValueError(f"--im {spec!r}: expected pga=START:STOP:COUNT (in g) or pgv=START:STOP:COUNT (in m/s)")
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"--im {spec!r}: START and STOP must be numbers and COUNT an integer") from None
    if count < 1 or not (math.isfinite(start) and math.isfinite(stop) and start > 0 and stop > 0):
        raise ValueError(f"--im {spec!r}: levels must be finite and above zero, COUNT at least 1")
    unit, limit = IM_UNITS[name][0], IM_LIMITS[name]
    if max(start, stop) > limit:
        raise ValueError(f"--im {spec!r}: {name} levels are in {unit}, and {max(start, stop):g} {unit} is beyond any "
                         f"recorded earthquake (at most {limit:g} {unit} here)" + (": did you mean m/s2?"
                                                                                  if name == "pga" else ""))
    return Intensity(name, start, stop, count)


@dataclass(frozen=True)
class RecordRef:
    """A record of a sweep, as the runner and its workers need it."""

    id: int
    name: str
    sha256: str  # of its samples: workers read the file cached under this name
    end: float  # s, time of its last sample
    measures: dict  # intensity measures of the unscaled record (SI; runners.engine.intensity)


@dataclass
class Grid:
    """The points of a sweep: records (optional), intensity levels (optional), then --grid axes."""

    axes: list[Axis]
    records: list[RecordRef] | None = None
    intensity: Intensity | None = None

    @property
    def counts(self) -> list[int]:
        return ([len(self.records)] if self.records else []) + ([self.intensity.count] if self.intensity else []) \
            + [ax.count for ax in self.axes]

    @property
    def total(self) -> int:
        return math.prod(self.counts)

    def point(self, index: int, base: dict[str, Any]) -> tuple[dict, dict, RecordRef | None]:
        """(grid values, FMU parameter overrides, record) of the flat grid index (last axis fastest).
        A record's file is given as "@SHA256" (each worker knows where it keeps that file)."""
        idx = list(np.unravel_index(index, self.counts))
        values: dict[str, Any] = {}
        over: dict[str, Any] = {}
        rec = None
        if self.records:
            rec = self.records[idx.pop(0)]
            values.update(record=rec.name, record_id=rec.id)
            over.update({"excitation.kind": 4, "excitation.file": f"@{rec.sha256}"})
        if self.intensity:
            level = self.intensity.level(idx.pop(0))
            values.update(level=level, level_measure=self.intensity.measure, level_unit=self.intensity.unit)
            over["excitation.scale"] = self.intensity.si(level) / rec.measures[self.intensity.measure]
        on_axes = {ax.name: ax.value(i) for ax, i in zip(self.axes, idx)}
        values.update(on_axes)
        over.update({k: v for k, v in on_axes.items() if k not in ("w", "a")})
        merged = {**base, **over}
        pf, acc = scales(merged)
        if "w" in values:
            over["excitation.frequency"] = values["w"] * pf / (2 * math.pi)
        if "a" in values:
            if int(merged.get("excitation.kind", 0)) == KINDS["harmonic"]:  # its peak is D (2 pi f)^2
                f = over.get("excitation.frequency", merged.get("excitation.frequency"))
                over["excitation.displacement"] = values["a"] * acc / (2 * math.pi * f) ** 2
            else:
                over["excitation.amplitude"] = values["a"] * acc
        if rec is not None:  # the scaled record's measures, for fragility and IDA
            scale = float(merged.get("excitation.scale", 1.0))
            values["scale"] = scale
            for k, v in rec.measures.items():
                if v is not None and SCALING.get(k, 0):
                    values[k] = abs(scale) ** SCALING[k] * v
        return values, over, rec

    def as_json(self) -> dict[str, Any]:
        return {"axes": [[a.name, a.start, a.stop, a.count] + ([True] if a.integer else []) for a in self.axes],
                "records": [r.id for r in self.records] if self.records else None,
                "intensity": None if self.intensity is None else
                [self.intensity.measure, self.intensity.start, self.intensity.stop, self.intensity.count]}


# parameters of the built-in waveforms: a record ignores them, so a record sweep may not vary them
BUILT_IN = {"w", "a", "excitation.amplitude", "excitation.frequency", "excitation.cycles",
            "excitation.verticalAmplitude", "excitation.displacement", "excitation.gamma", "excitation.phase"}


def record_axes(factory, scene, axes: list[Axis], records_spec: str | None, im_spec: str | None,
                stop_given: bool) -> tuple[list[RecordRef] | None, Intensity | None, list[str]]:
    """(records, intensity, notes) of a new sweep of `scene` (runners.engine.scene.Scene, changed in
    place when records replace its excitation), checked against its axes: records from
    `records_spec` (runners.engine.records.select_records) or the scene's own record, scaled by
    `im_spec` (pga=START:STOP:COUNT, ...); `stop_given`: a stop time was given for this sweep.
    ValueError, before anything is stored, for combinations a record would ignore or that conflict."""
    from runners.engine.records import prepare_scene, select_records

    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise ValueError(f"--grid {names[[names.count(n) > 1 for n in names].index(True)]} is given twice")
    intensity = parse_intensity(im_spec) if im_spec else None
    chosen = None
    if records_spec:
        chosen = select_records(factory, records_spec)
        scene.parameters = {k: v for k, v in scene.parameters.items()  # the records replace the excitation
                            if not k.startswith("excitation.") or k in ("excitation.startTime", "excitation.scale")}
        scene.parameters["excitation.kind"] = 4
        scene.stop_time_given = stop_given  # the scene's own stop time was set for the excitation replaced
    elif scene.is_record:
        from db.records import find_record

        rec = prepare_scene(scene, factory)
        with factory() as session:
            chosen = [find_record(session, rec.record_id)]
    if chosen is None:
        if intensity is not None or "excitation.scale" in names:
            raise ValueError(f"{'--im' if intensity else '--grid scale'} scales records: give --records SUITE "
                             "(or a record scene)")
        return None, None, []
    ignored = [n for n in names if n in BUILT_IN]
    if ignored:
        raise ValueError(f"--grid {ignored[0]} sets a built-in waveform, which a record sweep does not use: "
                         "scale records with --im or --grid scale")
    if intensity is not None and "excitation.scale" in names:
        raise ValueError("--im already sets each record's scale: drop --grid scale")
    if intensity is not None:
        bad = [r.name for r in chosen if not (r.pga or 0) > 0 or (intensity.measure == "pgv" and not (r.pgv or 0) > 0)]
        if bad:
            raise ValueError(f"record {bad[0]} has no {intensity.measure}: it cannot be scaled to a level of it")
    with factory.begin() as session:
        refs = record_refs(session, [r.id for r in chosen])
    notes = []
    start = float(scene.parameters.get("excitation.startTime", 0.0))
    longer = [r for r in refs if start + r.end > scene.stop_time] if scene.stop_time_given else []
    if longer:
        notes.append(f"every point stops at {scene.stop_time:g} s, before {len(longer)} of the {len(refs)} records "
                     f"end (the longest at {start + max(r.end for r in longer):g} s); without a stop time each "
                     "record runs to its end plus 5 s")
    return refs, intensity, notes


def record_refs(session, ids: list[int]) -> list[RecordRef]:
    """The RecordRefs of stored records, in the given order (their measures computed if missing)."""
    from db.records import MEASURES, samples
    from db.schema import Record
    from runners.engine.records import fill_missing_measures

    fill_missing_measures(session)
    by_id = {r.id: r for r in session.scalars(select(Record).where(Record.id.in_(ids)))}
    missing = [i for i in ids if i not in by_id]
    if missing:
        raise ValueError(f"record {missing[0]} of the sweep is no longer in the database")
    out = []
    for i in ids:
        r = by_id[i]
        t, _, _ = samples(r)
        out.append(RecordRef(r.id, r.name, r.sha256, float(t[-1]), {k: getattr(r, k) for k in MEASURES}))
    return out


def grid_of(session, sw: Sweep) -> Grid:
    g = sw.grid
    recs = record_refs(session, g["records"]) if g.get("records") else None
    return Grid([Axis(*a) for a in g["axes"]], recs, Intensity(*g["intensity"]) if g.get("intensity") else None)


def stored_point_parameters(session, run: Run) -> dict[str, Any]:
    """The FMU parameters (defaults included) that a stored sweep run ran with; a record's file
    is the record cache's (runners.engine.records.file_of)."""
    sw = session.get(Sweep, run.sweep_id)
    base = {**sw.grid["defaults"], **session.get(Scene, sw.scene_id).parameters}
    _, over, rec = grid_of(session, sw).point(run.grid_index, base)
    if rec is not None:
        from db.schema import Record
        from runners.engine.records import file_of

        over["excitation.file"] = str(file_of(session.get(Record, rec.id)))
    return {**base, **over}


# ------------------------------------------------------------------ workers

_LOCAL = threading.local()  # one worker state per thread (a Dask worker may run several threads)


def _worker() -> dict[str, Any]:
    return _LOCAL.state


def _start_worker(fmu_path: str, unzipdir: str, base: dict, stop_time: float, step: float, two: bool,
                  files: dict[str, str] | None = None) -> None:
    """Set up this thread's FMU instance for the points of one sweep; `files` maps a record's
    sha256 to the file this worker reads it from."""
    fmu = RockingFMU(fmu_path, unzipdir)
    errors: list[str] = []
    slave, cb = fmu.instantiate(lambda status, cat, msg: errors.append(msg) if status >= 3 else None,
                                logging_on=False)
    slips = SLIP_OUTPUTS + (STACK_SLIP_OUTPUTS if two else [])
    names = ONE + (TWO if two else []) + [n for n in slips if n in fmu.vars]  # (an FMU without sliding lacks them)
    # base: the scene's parameters; the FMU's start values fill the rest, but for SCENE_DEFAULTS
    _LOCAL.state = dict(fmu=fmu, slave=slave, cb=cb, errors=errors, base=with_scene_defaults(base),
                        stop=stop_time, step=step,
                        names=names, vrs={n: fmu.variable(n) for n in names}, files=files or {})


def _local_files(over: dict) -> dict:
    """The overrides with a record's "@SHA256" replaced by this worker's file of it."""
    f = over.get("excitation.file")
    if isinstance(f, str) and f.startswith("@"):
        return {**over, "excitation.file": _worker()["files"][f[1:]]}
    return over


def _set_all(fmu: RockingFMU, slave, params: dict) -> None:
    """All parameters in one call per type (each call through ctypes costs microseconds)."""
    by_type: dict[str, tuple[list, list]] = {"Real": ([], []), "Integer": ([], []), "Boolean": ([], []),
                                             "String": ([], [])}
    cast = {"Real": float, "Integer": int, "Boolean": bool, "String": str}
    for name, value in params.items():
        v = fmu.variable(name)
        vrs, vals = by_type[v.type]
        vrs.append(v.valueReference)
        vals.append(cast[v.type](value))
    setters = {"Real": slave.setReal, "Integer": slave.setInteger, "Boolean": slave.setBoolean,
               "String": slave.setString}
    for typ, (vrs, vals) in by_type.items():
        if vrs:
            setters[typ](vrs, vals)


@dataclass
class Recorded:
    """A grid point simulated in full: its series, events and the recording written by the worker."""

    time: np.ndarray
    outputs: dict[str, np.ndarray]
    events: list[dict]
    path: str


def _record_point(over: dict, stop: float, path: str, name: str, record: dict | None) -> tuple[dict, Recorded]:
    """Simulate one point with output at every communication step and write its recording
    (in this worker process, to its own file: recordings never wait for each other)."""
    from runners.engine.recording import write_recording
    from runners.engine.summary import SUMMARY_OUTPUTS, sliding_outputs

    w = _worker()
    fmu = w["fmu"]
    params = {**w["base"], **over}
    own = sliding_outputs(params)  # a sliding point's recording draws its slip
    res = fmu.run(params, stop, min(w["step"], stop),
                  outputs=list(dict.fromkeys([*SUMMARY_OUTPUTS, *own, *w["names"]])))
    write_recording(Path(path), name, res.time, res.outputs, {**fmu.defaults(), **params}, res.events,
                    record=record)
    out = {n: res.outputs[n][-1] for n in w["names"]}
    return out, Recorded(res.time, res.outputs, [e.as_dict() for e in res.events], str(Path(path).resolve()))


def _run_point(task: tuple) -> tuple[int, dict | None, float, str | None, Recorded | None]:
    """One grid point: (index, FMU overrides, None or (recording path, name, record info),
    stop time or None for the sweep's) -> (index, final outputs or None, seconds, error or
    None, Recorded or None)."""
    index, over, record, stop = task
    w = _worker()
    s, fmu = w["slave"], w["fmu"]
    stop = w["stop"] if stop is None else stop
    w["errors"].clear()
    t0 = time.perf_counter()
    try:
        over = _local_files(over)
        if record is not None:
            out, rec = _record_point(over, stop, *record)
            return index, out, time.perf_counter() - t0, None, rec
        s.reset()
        s.setupExperiment(startTime=0.0, stopTime=stop)
        _set_all(fmu, s, {**w["base"], **over})
        s.enterInitializationMode()
        s.exitInitializationMode()
        RockingFMU._step(s, 0.0, stop)  # with solver.stopAtOverturn it may end at the overturn
        out = {}
        for typ, get in (("Real", s.getReal), ("Integer", s.getInteger), ("Boolean", s.getBoolean)):
            names = [n for n, v in w["vrs"].items() if v.type == typ]
            if names:
                out.update(zip(names, get([w["vrs"][n].valueReference for n in names])))
        return index, out, time.perf_counter() - t0, None, None
    except Exception as exc:  # the point fails, the sweep goes on
        message = w["errors"][-1] if w["errors"] else str(exc)
        return index, None, time.perf_counter() - t0, message.splitlines()[0] if message else "error", None


def parse_points(spec: str, total: int) -> list[int]:
    """Grid indices from "3,17,40-45" or "all"; ValueError on anything outside 0..total-1."""
    if spec.strip() == "all":
        return list(range(total))
    points: set[int] = set()
    for part in spec.split(","):
        lo, dash, hi = part.strip().partition("-")
        try:
            a, b = int(lo), int(hi) if dash else int(lo)
        except ValueError:
            raise ValueError(f"points {spec!r}: expected grid indices like 3,17,40-45 or 'all'") from None
        if not 0 <= a <= b < total:
            raise ValueError(f"points {spec!r}: {part.strip()} is outside the grid's indices 0..{total - 1}")
        points.update(range(a, b + 1))
    return sorted(points)


# ------------------------------------------------------------------ driver

def _summary(out: dict, merged: dict, two: bool) -> dict:
    alpha1 = math.atan2(merged["block1.halfWidth"], merged["block1.halfHeight"])
    row = {"peak1_over_alpha": out["block1.maxAbsTheta"] / alpha1, "peak2_over_alpha": None,
           "overturned": bool(out["overturned"]), "overturned_blocks": None,
           "overturn_time": out["overturnTime"] if out["overturned"] else None, "impacts": int(out["impacts"]),
           "impacts_ground": None, "impacts_interface": None,
           "rest_time": out["restTime"] if out["atRest"] and out["restTime"] >= 0 else None,
           "slide_time": out["slideTime"] if out["slideTime"] >= 0 else None,
           "lift_time": out["liftTime"] if out["liftTime"] >= 0 else None,
           "friction_demand_max": out["friction.demandMaxGround"], "normal_min": out["contact.normalMinGround"],
           "impulse_demand_max": out["friction.impulseDemandMax"],
           "friction_demand_max_interface": None, "normal_min_interface": None}
    row["assumptions_held"] = row["slide_time"] is None and row["lift_time"] is None
    row["fall_time"] = out["fallTime"] if out["fallTime"] >= 0 else None
    if rocking_sliding(merged):  # sliding is the model's now: only a lift-off (flight) is outside it
        row.update(stack_slip_summary(out) if two else slip_summary(out))
        row["assumptions_held"] = row["lift_time"] is None
    if two:
        alpha2 = math.atan2(merged["block2.halfWidth"], merged["block2.halfHeight"])
        row.update(friction_demand_max_interface=out["friction.demandMaxInterface"],
                   normal_min_interface=out["contact.normalMinInterface"])
        row.update(peak2_over_alpha=out["block2.maxAbsTheta"] / alpha2, impacts_ground=int(out["impactsGround"]),
                   impacts_interface=int(out["impactsInterface"]),
                   overturned_blocks=",".join(str(i) for i in (1, 2) if out[f"block{i}.overturned"]) or None)
    elif out["overturned"]:
        row["overturned_blocks"] = "1"
    return row


MAX_POINTS = 100_000_000  # grid points one sweep may have (about 40 GB in SQLite): split larger studies
BYTES_PER_POINT = 400  # stored bytes of one point (run row, summary, index; 280 measured in SQLite)


def check_size(total: int, factory) -> None:
    """ValueError, before the sweep exists, for a grid too large to store: more than MAX_POINTS
    points, or (SQLite) more than the free space of the database's disk."""
    if total > MAX_POINTS:
        raise ValueError(f"the grid has {total:.3g} points, more than the {MAX_POINTS:.0e} one sweep may have "
                         "(about 40 GB of results): use fewer points, or split it into several sweeps")
    url = factory.kw["bind"].url
    if url.get_backend_name() == "sqlite" and url.database and url.database != ":memory:":
        import shutil

        free = shutil.disk_usage(Path(url.database).resolve().parent).free
        if total * BYTES_PER_POINT > free:
            raise ValueError(f"the grid's {total:.3g} points need about {total * BYTES_PER_POINT / 1e9:.3g} GB and "
                             f"the database's disk has {free / 1e9:.3g} GB free: use fewer points")


def check_corners(fmu: RockingFMU, grid: Grid, base: dict[str, Any], limit: int = 64) -> list[str]:
    """Initialise the FMU at the corners of the grid (the first and last value of every axis;
    at most `limit` corners). ValueError naming a point when it refuses every corner (every
    point would fail); notes when it refuses some (their points are stored as errors)."""
    import itertools

    counts = grid.counts
    corners = list(itertools.islice(itertools.product(*[sorted({0, c - 1}) for c in counts]), limit))
    refused = []
    for corner in corners:
        index = int(np.ravel_multi_index(corner, counts))
        values, over, _ = grid.point(index, base)
        try:
            fmu.validate({**base, **over})
        except FMUError as exc:
            at = ", ".join(f"{k} = {v:.4g}" for k, v in values.items()
                           if isinstance(v, float) or k in {ax.name for ax in grid.axes if ax.integer})
            refused.append(f"grid point {index} ({at}): {exc}")
    if refused and len(refused) == len(corners):
        raise ValueError(refused[0] if len(corners) == 1 else f"every corner of the grid is refused, e.g. {refused[0]}")
    return [f"{len(refused)} of the grid's {len(corners)} corners are refused by the FMU (their points are stored "
            f"as errors), e.g. {refused[0]}"] if refused else []


def create_sweep(factory, scene, axes: list[Axis], defaults: dict, records: list[RecordRef] | None = None,
                 intensity: Intensity | None = None) -> int:
    """A new sweep of `scene` over the grid (records, intensity levels, axes); returns its id."""
    source = Path(scene.source).read_text() if scene.source and Path(scene.source).is_file() else None
    g = Grid(axes, records, intensity)
    grid = {**g.as_json(), "stop_time": scene.stop_time, "stop_time_given": bool(scene.stop_time_given),
            "step": scene.step, "defaults": defaults}
    params = {k: v for k, v in scene.parameters.items() if k != "excitation.file" or not records}
    with factory.begin() as session:
        sc = add_scene(session, scene.name, params, source)
        session.flush()
        sw = Sweep(scene_id=sc.id, grid=grid, total=g.total, done=0, status="running")
        session.add(sw)
        session.flush()
        return sw.id


@dataclass
class _Plan:
    """What a sweep's workers need to know, read from the database once."""

    sweep_id: int
    scene_id: int
    scene_name: str
    total: int
    stop_time: float
    step: float  # s, output step of recorded points
    params: dict  # the scene's parameters (without defaults)
    base: dict  # defaults + scene parameters
    grid: Grid
    already: int  # points stored before this run
    stop_given: bool = True  # the scene's stop time applies to every point (else: each record's end + TAIL)
    infos: dict[int, dict] | None = None  # record id -> provenance and measures, for recordings
    record_data: dict[int, tuple] | None = None  # record id -> (names, n_samples, data) of db.series

    @property
    def two(self) -> bool:
        return int(self.base.get("nBlocks", 1)) == 2

    @property
    def axes(self) -> list[Axis]:
        return self.grid.axes

    def stop_of(self, rec: RecordRef | None) -> float | None:
        """Stop time of a point on record `rec` (None: the sweep's)."""
        if rec is None or self.stop_given:
            return None
        from runners.engine.records import TAIL

        return float(self.base.get("excitation.startTime", 0.0)) + rec.end + TAIL

    def files(self) -> dict[str, str]:
        """sha256 -> the record's file in this machine's record cache (written if missing)."""
        if not self.grid.records:
            return {}
        from db.schema import Record
        from runners.engine.records import file_of

        out = {}
        for r in self.grid.records:
            if r.sha256 not in out:
                names, n, data = self.record_data[r.id]
                out[r.sha256] = str(file_of(Record(name=r.name, names=names, n_samples=n, data=data)))
        return out


def _plan(factory, sweep_id: int) -> _Plan:
    from db.schema import Record
    from runners.engine.records import row

    with factory.begin() as session:
        sw = session.get(Sweep, sweep_id)
        if sw is None:
            raise ValueError(f"no sweep {sweep_id} in the database")
        scene = session.get(Scene, sw.scene_id)
        params = dict(scene.parameters)
        already = session.scalar(select(func.count()).select_from(Run).where(Run.sweep_id == sweep_id))
        grid = grid_of(session, sw)
        plan = _Plan(sweep_id, sw.scene_id, scene.name, sw.total, sw.grid["stop_time"], sw.grid.get("step", 0.01),
                     params, {**sw.grid["defaults"], **params}, grid, already,
                     sw.grid.get("stop_time_given", True) or not grid.records)
        if grid.records:
            recs = {r.id: r for r in session.scalars(select(Record).where(Record.id.in_([x.id for x in grid.records])))}
            plan.infos = {i: row(r) | {"source": r.source} for i, r in recs.items()}
            plan.record_data = {i: (r.names, r.n_samples, r.data) for i, r in recs.items()}
        return plan


def _start_pool_worker(*args) -> None:
    """_start_worker in a local worker process, which leaves Ctrl-C to the main process (that
    stops the pool) and dies quietly on SIGTERM (the main process's handler is not inherited)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):  # a main process killed outright (SIGKILL) takes its workers along
        import ctypes

        parent = os.getppid()
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # it died before the call
            os._exit(0)
    _start_worker(*args)


def _run_chunk(tasks: list) -> list[tuple]:
    return [_run_point(t) for t in tasks]


class SweepError(RockingError, RuntimeError):
    """A sweep cannot go on (e.g. a worker process died); str() is a one-line message."""


class _LocalExecutor:
    """Worker processes on this machine (forked where possible), sharing one extraction of the
    FMU. A worker that dies (killed, out of memory) stops the sweep with SweepError instead of
    hanging it; on an interruption the workers are stopped at once."""

    def __init__(self, plan: _Plan, fmu_path: Path, workers: int):
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        self.shared = RockingFMU(fmu_path)
        ctx = get_context("fork") if hasattr(os, "fork") else get_context()
        self.pool = ProcessPoolExecutor(workers, mp_context=ctx, initializer=_start_pool_worker,
                                        initargs=(str(fmu_path), self.shared.unzipdir, plan.params, plan.stop_time,
                                                  plan.step, plan.two, plan.files()))

    def results(self, tasks: list, size: int | None = None):
        from concurrent.futures import as_completed
        from concurrent.futures.process import BrokenProcessPool

        size = size or max(1, min(64, len(tasks) // (self.workers * 8) or 1))
        try:
            futures = [self.pool.submit(_run_chunk, tasks[i:i + size]) for i in range(0, len(tasks), size)]
            for future in as_completed(futures):
                yield from future.result()
        except BrokenProcessPool:
            raise SweepError("a worker process died (killed, or out of memory)") from None

    def __enter__(self) -> "_LocalExecutor":
        return self

    def __exit__(self, exc_type, *_exc) -> None:
        processes = list((getattr(self.pool, "_processes", None) or {}).values())
        self.pool.shutdown(wait=exc_type is None, cancel_futures=True)
        if exc_type is not None:  # interrupted or failed: stop the workers now, not after their chunks
            for proc in processes:
                if proc.is_alive():
                    proc.kill()
            for proc in processes:
                proc.join(timeout=5)
        self.shared.close()


def _recording_task(plan: _Plan, index: int, record_dir: Path, rec: RecordRef | None) -> tuple:
    return (str(Path(record_dir) / f"point-{index}.rrd"),
            f"{plan.scene_name} (sweep {plan.sweep_id}, point {index})",
            None if rec is None else plan.infos[rec.id])


def _series_row(run_id: int, rec: Recorded) -> dict:
    names, n, blob = pack_series(rec.time, rec.outputs)
    return {"run_id": run_id, "names": names, "n_samples": n, "data": blob, "events": rec.events}


@contextlib.contextmanager
def _interrupts_deferred():
    """Ctrl-C or SIGTERM arriving inside the block takes effect (KeyboardInterrupt) when it ends.

    A database transaction interrupted half-way can leave its connection holding SQLite's
    write lock while the traceback keeps it alive, and the flush that follows (of the points
    already run) then waits on that lock; so each transaction of a sweep runs whole. Only in
    the main thread, where Python runs signal handlers."""
    import signal

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {s: signal.signal(s, lambda signum, _frame: caught.append(signum))
                for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    if caught:
        raise KeyboardInterrupt


def _stored_among(factory, sweep_id: int, lo: int, hi: int) -> set[int]:
    """The grid indices in lo..hi-1 of a sweep that are stored."""
    with factory() as session:
        return set(session.scalars(select(Run.grid_index).where(Run.sweep_id == sweep_id, Run.grid_index >= lo,
                                                                 Run.grid_index < hi)))


_DASK_FMUS: dict[str, RockingFMU] = {}  # FMU sha256 -> its extraction, once per Dask worker process
_DASK_FILES: dict[str, str] = {}  # record sha256 -> its file, written once per Dask worker process
_DASK_LOCK = threading.Lock()


def _dask_chunk(fmu_bytes: bytes, sha: str, params: dict, stop: float, step: float, two: bool,
                tasks: list, record_files: dict[str, bytes] | None = None) -> list[tuple]:
    """Run a chunk of grid points on a Dask worker. The FMU arrives as bytes (the workers
    need this package, not a build of the FMU) and is extracted once per worker process;
    so do the sweep's record files (sha256 -> their bytes), written once per process."""
    with _DASK_LOCK:
        if sha not in _DASK_FMUS:
            folder = Path(tempfile.mkdtemp(prefix="rocking-fmu-"))
            (folder / "RockingBlock.fmu").write_bytes(fmu_bytes)
            _DASK_FMUS[sha] = RockingFMU(folder / "RockingBlock.fmu")
        for rsha, data in (record_files or {}).items():
            if rsha not in _DASK_FILES:
                path = Path(tempfile.mkdtemp(prefix="rocking-record-")) / f"{rsha}.txt"
                path.write_bytes(data)
                _DASK_FILES[rsha] = str(path)
    fmu = _DASK_FMUS[sha]
    key = (sha, repr(sorted(params.items())), stop, step, two, tuple(sorted(record_files or ())))
    if getattr(_LOCAL, "key", None) != key:  # this thread's instance, set up once per sweep
        _start_worker(str(fmu.path), fmu.unzipdir, params, stop, step, two,
                      {k: _DASK_FILES[k] for k in record_files or ()})
        _LOCAL.key = key
    return [_run_point(t) for t in tasks]


def local_workers(scheduler: str) -> int | None:
    """N of a 'local:N' scheduler (None for an address); ValueError when N is not a count or the
    address's scheme is not one of Dask's."""
    if not scheduler.startswith("local:"):
        scheme = scheduler.split("://")[0] if "://" in scheduler else "tcp"
        if scheme not in ("tcp", "tls", "ws", "wss", "ucx"):  # Dask's comms (distributed.comm)
            raise ValueError(f"--scheduler {scheduler!r}: expected tcp://HOST:PORT (or tls://, ws://, wss://, "
                             "ucx://) of a Dask scheduler, or local:N")
        return None
    try:
        n = int(scheduler.removeprefix("local:"))
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"--scheduler {scheduler!r}: expected local:N with N >= 1 workers")
    return n


def dask_client(scheduler: str):
    """A Dask client: 'tcp://HOST:PORT' of a running scheduler, or 'local:N' for a cluster of
    N single-threaded worker processes on this machine (to try it out and to measure)."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise OSError("--executor dask needs dask.distributed: pip install -e '.[dask]'") from None
    n = local_workers(scheduler)
    if n is not None:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0")
        return Client(cluster)
    check_scheduler(scheduler)
    try:
        return Client(scheduler, timeout=20)
    except (OSError, TimeoutError) as exc:
        raise OSError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None


SCHEDULER_TIMEOUT = 5.0  # s a Dask scheduler has to answer a new connection


def check_scheduler(address: str, timeout: float = SCHEDULER_TIMEOUT) -> None:
    """OSError, in one line, unless a Dask scheduler answers at `address` within `timeout` s.

    dask.distributed's own connect waits for the other end's handshake without a limit (an
    address that accepts connections but never answers kept a sweep waiting for good), and
    reads a server of another protocol's answer as a frame length (an HTTP server's gave a
    MemoryError of 3 EiB). The handshake is tried here, in a thread of its own (the caller
    may run an event loop, as Jupyter does), and abandoned after `timeout` s."""
    import asyncio

    from distributed.comm import connect

    async def hello() -> None:
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        await comm.close()

    outcome: list[BaseException | None] = []

    def attempt() -> None:
        try:
            asyncio.run(hello())
            outcome.append(None)
        except BaseException as exc:  # MemoryError included: reported below, in one line
            outcome.append(exc)

    thread = threading.Thread(target=attempt, name="rocking-scheduler-check", daemon=True)
    thread.start()
    thread.join(timeout + 5)  # wait_for ends it after `timeout`; the margin is for a loaded machine
    exc = outcome[0] if outcome else TimeoutError()
    if exc is None:
        return
    if isinstance(exc, (TimeoutError, asyncio.TimeoutError)) or "timed out" in str(exc).lower():
        raise OSError(f"no answer from the Dask scheduler {address} within {timeout:g} s (is the scheduler "
                      "running, and is this its address?)") from None
    if isinstance(exc, ValueError) and "address" in str(exc).lower():
        raise OSError(f"--scheduler {address!r}: {str(exc).splitlines()[0]}") from None
    raise OSError(f"{address} answers, but not as a Dask scheduler does: is it the scheduler's address "
                  "(tcp://HOST:PORT, port 8786 by default)?") from None


class _DaskExecutor:
    """Runs lists of tasks on a Dask cluster in chunks; the FMU and the record files are
    sent to every worker once. A chunk whose worker dies is run again elsewhere (retries);
    results are stored only by the caller, in one slot per grid point, so a rerun chunk
    cannot store a point twice."""

    def __init__(self, plan: _Plan, fmu_path: Path, sha: str, client, chunk: int | None):
        self.plan, self.sha, self.client, self.chunk = plan, sha, client, chunk
        self.n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        self.blob = client.scatter(Path(fmu_path).read_bytes(), broadcast=True)
        local = plan.files()
        self.files = client.scatter({k: Path(v).read_bytes() for k, v in local.items()},
                                    broadcast=True) if local else None

    def results(self, tasks: list):
        from distributed import as_completed

        p = self.plan
        size = self.chunk or max(1, min(1000, math.ceil(len(tasks) / (4 * self.n_workers))))
        futures = [self.client.submit(_dask_chunk, self.blob, self.sha, p.params, p.stop_time, p.step, p.two,
                                      tasks[i:i + size], self.files, pure=False, retries=3)
                   for i in range(0, len(tasks), size)]
        for future in as_completed(futures):
            yield from future.result()


def _dask_results(plan: _Plan, fmu_path: Path, sha: str, client, chunk: int | None):
    """_DaskExecutor(...).results; _ExecutorFailed, in one line, when the cluster cannot take the
    sweep (e.g. a scheduler without workers, which cannot hold the FMU sent to them)."""
    try:
        return _DaskExecutor(plan, fmu_path, sha, client, chunk).results
    except Exception as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise _ExecutorFailed(f"the Dask cluster cannot start the sweep: {text}") from None


def _row(plan: _Plan, index: int, point: tuple, out: dict | None, seconds: float, error: str | None,
         rec: Recorded | None, sha: str, version: str) -> tuple:
    """(run row, summary row or None, Recorded or None, excitation row or None) of one point's result."""
    values, over, record_ref = point
    merged = {**plan.base, **over}
    stop = plan.stop_of(record_ref)
    run = {"scene_id": plan.scene_id, "sweep_id": plan.sweep_id, "grid_index": index, "point": values,
           "model": "two blocks" if plan.two else "one block", "method": "fmu",
           "rel_tol": merged.get("solver.relTol"), "abs_tol": merged.get("solver.absTol"),
           "stop_time": plan.stop_time if stop is None else stop, "fmu_sha256": sha, "code_version": version,
           "wall_time": seconds, "status": "error" if error else "ok", "error_message": error,
           "recording": rec.path if rec else None}
    excitation = None if record_ref is None else {
        "kind": "record", "record_id": record_ref.id, "scale": float(merged.get("excitation.scale", 1.0)),
        "start_time": float(merged.get("excitation.startTime", 0.0))}
    return run, None if out is None else _summary(out, merged, plan.two), rec, excitation


def _set_status(factory, sweep_id: int, status: str) -> None:
    """Mark an unfinished sweep running, interrupted or failed (a finished one stays done)."""
    with factory.begin() as session:
        session.execute(update(Sweep).where(Sweep.id == sweep_id, Sweep.done < Sweep.total).values(status=status))


def mark_failed(factory, sweep_id: int) -> tuple[int, int]:
    """Mark an unfinished sweep failed (its executor could not start); (points stored, total)."""
    _set_status(factory, sweep_id, "failed")
    with factory() as session:
        sw = session.get(Sweep, sweep_id)
        return sw.done, sw.total


class _ExecutorFailed(SweepError):
    """The executor of a sweep could not start (a Dask cluster that cannot take its tasks)."""


WINDOW = 20_000  # grid points planned at a time: a sweep of any size runs in bounded memory


def run_sweep(factory, sweep_id: int, fmu_path: Path, workers: int | None = None, batch: int = 500,
              progress: bool = True, record: list[int] | None = None, record_dir: Path | None = None,
              client=None, chunk: int | None = None) -> dict[str, Any]:
    """Run the grid points of a sweep that are not stored yet; returns counts and timings.

    Points in `record` (grid indices) are simulated in full: their workers write a
    recording to record_dir/point-INDEX.rrd and their series and events are stored.
    With a Dask `client` the points run on its cluster in chunks of `chunk` points
    (default: about four chunks per worker); results are stored here as they arrive.
    The grid is planned WINDOW points at a time, so memory does not grow with its size;
    a point another process stored meanwhile (a concurrent --resume) is skipped.
    """
    from contextlib import ExitStack

    from tqdm import tqdm

    plan = _plan(factory, sweep_id)
    record_dir = Path(record_dir or f"recordings/sweep-{sweep_id}")
    recorded = set(record or ())
    remaining = plan.total - plan.already
    workers = max(1, min(workers or os.cpu_count() or 1, max(1, remaining)))
    sha, version = file_sha256(str(fmu_path)), code_version()
    stats = {"sweep": sweep_id, "total": plan.total, "already": plan.already, "ran": 0, "errors": 0,
             "recorded": 0, "skipped": 0, "fmu_seconds": 0.0, "db_seconds": 0.0, "python_seconds": 0.0}
    t_start = time.perf_counter()
    rows: list[tuple] = []

    def insert_rows(session, batch_rows: list[tuple]) -> None:
        excited = [r for r in batch_rows if r[3] is not None]  # points on records: their excitation first
        if excited:
            eids = session.scalars(insert(Excitation).returning(Excitation.id, sort_by_parameter_order=True),
                                   [r[3] for r in excited]).all()
            for r, eid in zip(excited, eids):
                r[0]["excitation_id"] = eid
        ids = session.execute(insert(Run).returning(Run.id, Run.grid_index), [r[0] for r in batch_rows]).all()
        by_index = {gi: rid for rid, gi in ids}
        summaries = [{"run_id": by_index[r[0]["grid_index"]], **r[1]} for r in batch_rows if r[1] is not None]
        if summaries:
            session.execute(insert(RunSummary), summaries)
        full = [_series_row(by_index[r[0]["grid_index"]], r[2]) for r in batch_rows if r[2] is not None]
        if full:
            session.execute(insert(RunSeries), full)
        session.execute(update(Sweep).where(Sweep.id == sweep_id).values(done=Sweep.done + len(batch_rows)))
        session.execute(update(Sweep).where(Sweep.id == sweep_id, Sweep.done >= Sweep.total).values(status="done"))

    def flush() -> None:
        if not rows:
            return
        t0 = time.perf_counter()
        pending = list(rows)
        while pending:  # each pass stores them all, or finds some another process stored: it ends
            try:
                with _interrupts_deferred(), factory.begin() as session:
                    insert_rows(session, pending)
                break
            except IntegrityError:  # a concurrent resume stored some of these points meanwhile: store the others
                indices = {r[0]["grid_index"] for r in pending}
                taken = _stored_among(factory, sweep_id, min(indices), max(indices) + 1) & indices
                if not taken:  # not a point stored twice
                    raise
                pending = [r for r in pending if r[0]["grid_index"] not in taken]
                stats["skipped"] += len(taken)
                for r in pending:
                    r[0].pop("excitation_id", None)
        stats["db_seconds"] += time.perf_counter() - t0
        rows.clear()

    def task(i: int, point: tuple) -> tuple:
        _, over, rec = point
        return i, over, _recording_task(plan, i, record_dir, rec) if i in recorded else None, plan.stop_of(rec)

    if client is not None and recorded:
        raise ValueError("--record writes recordings where the point runs: use the local executor, or record "
                         "points after the sweep with runners rrd --sweep ID --points")
    bar = tqdm(total=plan.total, initial=plan.already, disable=not progress, unit="run", desc=f"sweep {sweep_id}")
    _set_status(factory, sweep_id, "running")
    try:
        with ExitStack() as stack:
            if remaining <= 0:
                run_tasks = None
            elif client is not None:
                run_tasks = _dask_results(plan, fmu_path, sha, client, chunk)
            else:
                run_tasks = stack.enter_context(_LocalExecutor(plan, fmu_path, workers)).results
            for lo in range(0, plan.total if run_tasks else 0, WINDOW):
                hi = min(plan.total, lo + WINDOW)
                stored = _stored_among(factory, sweep_id, lo, hi)  # (another process may be storing this sweep too)
                points = {i: plan.grid.point(i, plan.base) for i in range(lo, hi) if i not in stored}  # one window's
                tasks = [task(i, point) for i, point in points.items()]
                for index, out, seconds, error, rec in run_tasks(tasks) if tasks else ():
                    if index not in points:  # a chunk run twice (its worker died after sending): keep the first
                        continue
                    t_py = time.perf_counter()
                    rows.append(_row(plan, index, points.pop(index), out, seconds, error, rec, sha, version))
                    stats["ran"] += 1
                    stats["errors"] += error is not None
                    stats["recorded"] += rec is not None
                    stats["fmu_seconds"] += seconds
                    bar.update(1)
                    stats["python_seconds"] += time.perf_counter() - t_py
                    if len(rows) >= batch:
                        flush()
                flush()
    except BaseException as exc:  # interrupted or failed: keep what arrived, and say the sweep is not running
        with contextlib.suppress(Exception):
            flush()
        with contextlib.suppress(Exception):
            _set_status(factory, sweep_id, "failed" if isinstance(exc, _ExecutorFailed) else "interrupted")
        raise
    bar.close()
    with factory() as session:
        stats["stored"] = session.get(Sweep, sweep_id).done  # by this process and any other
    stats["wall_seconds"] = time.perf_counter() - t_start
    return stats


def record_points(factory, sweep_id: int, indices: list[int], fmu_path: Path, record_dir: Path | None = None,
                  workers: int | None = None, progress: bool = True) -> list[tuple[int, str]]:
    """Simulate stored grid points of a sweep again in full, write their recordings
    (record_dir/point-INDEX.rrd) and store their series and events with their runs.

    Returns (grid index, recording path) pairs. Points not stored yet are an error
    (finish the sweep with --resume first).
    """
    from tqdm import tqdm

    plan = _plan(factory, sweep_id)
    missing = sorted(set(indices) - _stored_among(factory, sweep_id, min(indices), max(indices) + 1)) \
        if indices else []
    if missing:
        raise ValueError(f"sweep {sweep_id} has no stored point {missing[0]} (finish it with runners sweep SWEEP_ID)")
    record_dir = Path(record_dir or f"recordings/sweep-{sweep_id}")
    points = {i: plan.grid.point(i, plan.base) for i in indices}
    tasks = [(i, points[i][1], _recording_task(plan, i, record_dir, points[i][2]), plan.stop_of(points[i][2]))
             for i in indices]
    workers = max(1, min(workers or os.cpu_count() or 1, len(tasks)))
    done: list[tuple[int, str]] = []
    with _LocalExecutor(plan, fmu_path, workers) as pool, \
            tqdm(total=len(tasks), disable=not progress, unit="point", desc=f"recording sweep {sweep_id}") as bar:
        for index, _out, _seconds, error, rec in pool.results(tasks, size=1):
            if error is not None:
                raise ValueError(f"sweep {sweep_id} point {index}: {error}")
            with factory.begin() as session:
                run = session.scalars(select(Run).where(Run.sweep_id == sweep_id, Run.grid_index == index)).one()
                run.recording = rec.path
                row = _series_row(run.id, rec)
                if run.series is None:
                    run.series = RunSeries(**{k: v for k, v in row.items() if k != "run_id"})
                else:
                    for k, v in row.items():
                        setattr(run.series, k, v)
            done.append((index, rec.path))
            bar.update(1)
    return sorted(done)
