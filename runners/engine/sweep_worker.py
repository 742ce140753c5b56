"""What a sweep's worker does: simulate a chunk of grid points and summarise them in columns.

A worker (a local process or a Dask worker's thread) is set up once per sweep with one FMU
instance (start_worker). It then takes chunks of flat grid indices (run_chunk): it computes the
points' parameters from the grid itself (runners.engine.grid), simulates them all in one call
into the C batch loop (runners.engine.batch; one fmpy call per FMI function where that library
cannot be built) and returns a Chunk: the runs' columns and their summaries, ready for the
database, so that the process that stores them does no per-point work but the insert. Points
asked for with a recording are simulated in full through fmpy and write their Rerun recording
here. Units SI; angles in rad; the summaries' columns are those of db.schema.RunSummary.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from runners.engine import batch as batch_lib
from runners.engine.fmu import RockingFMU, with_scene_defaults
from runners.engine.column import MIN_COLUMN, final_outputs, sweep_rows
from runners.engine.grid import Grid, Points
from runners.engine.motion import ROCKING_SLIDING, SLIP_OUTPUTS, STACK_SLIP_OUTPUTS, slip_summary, stack_slip_summary

# the FMU outputs a sweep reads at the end of each point: of one block, and those a stack adds
ONE = ["overturned", "impacts", "block1.maxAbsTheta", "overturnTime", "restTime", "atRest",
       "slideTime", "liftTime", "friction.demandMaxGround", "contact.normalMinGround", "friction.impulseDemandMax",
       "fallTime"]
TWO = ["block2.maxAbsTheta", "impactsGround", "impactsInterface", "block1.overturned", "block2.overturned",
       "friction.demandMaxInterface", "contact.normalMinInterface"]

_LOCAL = threading.local()  # one worker state per thread (a Dask worker may run several threads)


@dataclass(frozen=True)
class Setup:
    """What every worker of a sweep needs: the scene's parameters `params` (without defaults:
    the FMU's start values and SCENE_DEFAULTS fill the rest), the grid and the parameters its
    points are computed and summarised with (`grid_base`: the sweep's defaults and the scene's),
    the stop time (s) and output step (s) of recorded points, whether it is a stack, whether the
    stop time applies to every point (else each record's end + TAIL), the record files (sha256 ->
    file, on the worker's machine) and the batch library (None: one call per point)."""

    params: dict
    grid: Grid
    grid_base: dict
    stop_time: float
    step: float
    two: bool
    stop_given: bool = True
    files: dict = field(default_factory=dict)
    batch: str | None = None


@dataclass
class Recorded:
    """A grid point simulated in full: its series, events and the recording written by the worker."""

    time: np.ndarray
    outputs: dict[str, np.ndarray]
    events: list[dict]
    path: str


@dataclass
class Chunk:
    """The results of a chunk of grid points, one entry per point in each column.

    runs: grid_index, point (JSON text), rel_tol, abs_tol, stop_time (s), wall_time (s of the
    simulation), status ("ok" or "error"), error_message, recording (path or None);
    summaries: the db.schema.RunSummary columns (entries of failed points are None and not
    stored); excitations: a record sweep's kind, record_id, scale and start_time (s), else None;
    recorded: position in the chunk -> the full result of a recorded point; blocks: a column's
    points' run_blocks rows (without run_id; [] for a failed point), None for one block or two."""

    runs: dict[str, list]
    summaries: dict[str, list]
    excitations: dict[str, list] | None
    recorded: dict[int, Recorded]
    blocks: list[list[dict]] | None = None

    def __len__(self) -> int:
        return len(self.runs["grid_index"])

    @property
    def fmu_seconds(self) -> float:
        return float(sum(self.runs["wall_time"]))

    @property
    def errors(self) -> int:
        return self.runs["status"].count("error")

    def without(self, indices: set[int]) -> "Chunk":
        """This chunk without the points of grid indices `indices`."""
        keep = [k for k, i in enumerate(self.runs["grid_index"]) if i not in indices]

        def pick(cols: dict[str, list] | None) -> dict[str, list] | None:
            return None if cols is None else {name: [col[k] for k in keep] for name, col in cols.items()}

        return Chunk(pick(self.runs), pick(self.summaries), pick(self.excitations),
                     {j: self.recorded[k] for j, k in enumerate(keep) if k in self.recorded},
                     None if self.blocks is None else [self.blocks[k] for k in keep])


def check_outputs(fmu_path: str | Path, two: bool) -> None:
    """ValueError, in one line, for an FMU that lacks an output a sweep reads (an older build)."""
    from fmpy import read_model_description

    names = {v.name for v in read_model_description(str(fmu_path)).modelVariables}
    missing = [n for n in ONE + (TWO if two else []) if n not in names]
    if missing:
        raise ValueError(f"the FMU {fmu_path} lacks the output{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''} a sweep stores: it is an older "
                         "build (make fmu, or python -m fmu_build, builds build/RockingBlock.fmu)")


def column_size(setup: Setup) -> int:
    """The blocks of a sweep's column (3 to 8), 0 for one block or two."""
    n = int(setup.grid_base.get("nBlocks", 1))
    return n if n >= MIN_COLUMN else 0


def worker() -> dict[str, Any]:
    return _LOCAL.state


def start_worker(fmu_path: str, unzipdir: str, setup: Setup) -> None:
    """Set up this thread's FMU instance for the points of one sweep."""
    fmu = RockingFMU(fmu_path, unzipdir)
    errors: list[str] = []
    slips = SLIP_OUTPUTS + (STACK_SLIP_OUTPUTS if setup.two else [])
    names = ONE + (TWO if setup.two else []) + [n for n in slips if n in fmu.vars]  # (an FMU without sliding lacks them)
    blocks = column_size(setup)
    if blocks:  # a column: every block's final outcome (and block 2's, as a stack's)
        names = list(dict.fromkeys(names + TWO + final_outputs(blocks)))
    runner = None
    if setup.batch:
        md = fmu.model_description
        binary = Path(fmu.unzipdir, "binaries", "linux64", md.coSimulation.modelIdentifier + ".so")
        try:
            runner = batch_lib.BatchRunner(binary, md.guid, Path(fmu.unzipdir, "resources").as_uri(), setup.batch)
        except (OSError, batch_lib.BatchUnavailable):
            runner = None  # (another platform's worker): one call per point
    # base: the scene's parameters; the FMU's start values fill the rest, but for SCENE_DEFAULTS
    base = with_scene_defaults(setup.params)
    _LOCAL.state = dict(fmu=fmu, slave=None, cb=None, errors=errors, base=base, setup=setup, runner=runner,
                        names=names, vrs={n: fmu.variable(n) for n in names}, files=setup.files,
                        start={**fmu.defaults(), **base}, grid_base=setup.grid_base,
                        summary_base={**fmu.defaults(), **setup.grid_base})


def local_files(over: dict) -> dict:
    """The overrides with a record's "@SHA256" replaced by this worker's file of it."""
    f = over.get("excitation.file")
    if isinstance(f, str) and f.startswith("@"):
        return {**over, "excitation.file": worker()["files"][f[1:]]}
    return over


def set_all(fmu: RockingFMU, slave, params: dict) -> None:
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


def record_point(over: dict, stop: float, path: str, name: str, record: dict | None) -> tuple[dict, Recorded]:
    """Simulate one point with output at every communication step and write its recording
    (in this worker process, to its own file: recordings never wait for each other)."""
    from runners.engine.recording import write_recording
    from runners.engine.summary import SUMMARY_OUTPUTS, sliding_outputs

    w = worker()
    fmu = w["fmu"]
    params = {**w["base"], **over}
    own = sliding_outputs(params)  # a sliding point's recording draws its slip
    res = fmu.run(params, stop, min(w["setup"].step, stop),
                  outputs=list(dict.fromkeys([*SUMMARY_OUTPUTS, *own, *w["names"]])))
    write_recording(Path(path), name, res.time, res.outputs, {**fmu.defaults(), **params}, res.events,
                    record=record)
    out = {n: res.outputs[n][-1] for n in w["names"]}
    return out, Recorded(res.time, res.outputs, [e.as_dict() for e in res.events], str(Path(path).resolve()))


def run_point(task: tuple) -> tuple[int, dict | None, float, str | None, Recorded | None]:
    """One grid point through fmpy: (index, FMU overrides, None or (recording path, name, record
    info), stop time or None for the sweep's) -> (index, final outputs or None, seconds, error
    or None, Recorded or None)."""
    index, over, record, stop = task
    w = worker()
    if w["slave"] is None:  # (instantiated on first use: a sweep in the batch loop needs none)
        errors = w["errors"]
        w["slave"], w["cb"] = w["fmu"].instantiate(lambda status, cat, msg: errors.append(msg) if status >= 3
                                                    else None, logging_on=False)
    s, fmu = w["slave"], w["fmu"]
    stop = w["setup"].stop_time if stop is None else stop
    w["errors"].clear()
    t0 = time.perf_counter()
    try:
        over = local_files(over)
        if record is not None:
            out, rec = record_point(over, stop, *record)
            return index, out, time.perf_counter() - t0, None, rec
        s.reset()
        s.setupExperiment(startTime=0.0, stopTime=stop)
        set_all(fmu, s, {**w["base"], **over})
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


def run_points(tasks: list[tuple]) -> list[tuple]:
    """run_point of each task."""
    return [run_point(t) for t in tasks]


# ------------------------------------------------------------------ a chunk of points

def _stops(pts: Points, setup: Setup, base: dict) -> np.ndarray:
    """Stop time (s) of each point: the sweep's, or on records without a given stop time each
    record's end + TAIL after the excitation's start."""
    n = len(pts)
    if pts.records is None or setup.stop_given:
        return np.full(n, float(setup.stop_time))
    from runners.engine.records import TAIL

    start = float(base.get("excitation.startTime", 0.0))
    return np.array([start + r.end + TAIL for r in pts.records])


def _column(pts: Points, name: str, start: Mapping[str, Any]) -> np.ndarray | list:
    """FMU parameter `name` of every point: its override, else the scene's (or the FMU's) value."""
    col = pts.over.get(name)
    if col is None:
        return np.full(len(pts), start.get(name, np.nan), dtype=object if isinstance(start.get(name), str) else None)
    if isinstance(col, list):
        return [start.get(name) if v is None else v for v in col]
    return col


def _batch_args(w: dict, pts: Points, stops: np.ndarray, rows: np.ndarray) -> tuple:
    """The arguments of BatchRunner.run for points `rows` of pts."""
    fmu, start = w["fmu"], w["start"]
    names = list(dict.fromkeys([*w["base"], *pts.over]))
    by_type: dict[str, list[str]] = {"Real": [], "Integer": [], "Boolean": [], "String": []}
    for name in names:
        by_type[fmu.variable(name).type].append(name)

    def matrix(typ: str, dtype) -> tuple[list[int], np.ndarray]:
        data = np.empty((len(rows), len(by_type[typ])), dtype)
        for j, n in enumerate(by_type[typ]):
            col = pts.over.get(n)
            data[:, j] = start[n] if col is None else np.asarray(_column(pts, n, start))[rows]  # (one value: broadcast)
        return [fmu.variable(n).valueReference for n in by_type[typ]], data

    files = [[local_files({"excitation.file": v})["excitation.file"] for v in np.asarray(_column(pts, n, start),
                                                                                         dtype=object)[rows]]
             for n in by_type["String"]]
    strings = ([fmu.variable(n).valueReference for n in by_type["String"]], [list(r) for r in zip(*files)]
               if files else [[] for _ in rows])
    outs = tuple([w["vrs"][n].valueReference for n in w["names"] if w["vrs"][n].type == t]
                 for t in ("Real", "Integer", "Boolean"))
    return stops[rows], matrix("Real", np.float64), matrix("Integer", np.int32), matrix("Boolean", np.int32), \
        strings, outs


def batch_inputs(w: dict, indices: np.ndarray) -> tuple:
    """The arguments of BatchRunner.run for the grid points of flat indices `indices` (what the
    native benchmark of a grid times: runners.analysis.throughput)."""
    pts = w["setup"].grid.columns(np.asarray(indices, dtype=np.int64), w["grid_base"])
    return _batch_args(w, pts, _stops(pts, w["setup"], w["grid_base"]), np.arange(len(pts)))


def _simulate_batch(w: dict, pts: Points, stops: np.ndarray, rows: np.ndarray) -> tuple[dict, np.ndarray, np.ndarray,
                                                                                     dict[int, str]]:
    """Simulate points `rows` of pts in the C batch loop: (outputs by name, seconds, failed,
    messages by position in rows)."""
    res = w["runner"].run(*_batch_args(w, pts, stops, rows))
    out = {}
    for typ, values in (("Real", res.reals), ("Integer", res.ints), ("Boolean", res.bools)):
        names = [n for n in w["names"] if w["vrs"][n].type == typ]
        out.update({n: values[:, j] for j, n in enumerate(names)})
    return out, res.seconds, res.failed, res.messages


def _simulate_each(w: dict, pts: Points, stops: np.ndarray, rows: np.ndarray) -> tuple[dict, np.ndarray, np.ndarray,
                                                                                    dict[int, str]]:
    """As _simulate_batch, one point at a time through fmpy."""
    n = len(rows)
    out = {name: np.zeros(n, dtype=bool if v.type == "Boolean" else np.int64 if v.type == "Integer" else np.float64)
           for name, v in w["vrs"].items()}
    seconds, failed, messages = np.zeros(n), np.zeros(n, dtype=bool), {}
    for j, k in enumerate(rows.tolist()):
        _, values, seconds[j], error, _ = run_point((0, pts.over_of(k), None, float(stops[k])))
        if error is not None:
            failed[j], messages[j] = True, error
            continue
        for name, v in values.items():
            out[name][j] = v
    return out, seconds, failed, messages


def run_chunk(task: tuple[np.ndarray, dict[int, tuple]]) -> Chunk:
    """Simulate and summarise the grid points of flat indices task[0]; task[1] maps the index of
    each point to record in full to its (recording path, name, record info)."""
    indices, recorded = task
    w = worker()
    setup: Setup = w["setup"]
    gb = w["grid_base"]
    pts = setup.grid.columns(np.asarray(indices, dtype=np.int64), gb)
    n = len(pts)
    stops = _stops(pts, setup, gb)
    full = np.array([int(i) in recorded for i in pts.index.tolist()], dtype=bool) if recorded else np.zeros(n, bool)
    plain = np.flatnonzero(~full)
    simulate = _simulate_batch if w["runner"] is not None else _simulate_each
    out, sec, bad, msg = simulate(w, pts, stops, plain) if len(plain) else ({}, np.zeros(0), np.zeros(0, bool), {})
    columns = {name: np.zeros(n, dtype=col.dtype) for name, col in out.items()}
    for name, col in out.items():
        columns[name][plain] = col
    seconds, failed, messages = np.zeros(n), np.zeros(n, dtype=bool), {}
    seconds[plain], failed[plain] = sec, bad
    messages.update({int(plain[j]): m for j, m in msg.items()})
    done: dict[int, Recorded] = {}
    for k in np.flatnonzero(full).tolist():
        _, values, seconds[k], error, rec = run_point((int(pts.index[k]), pts.over_of(k),
                                                       recorded[int(pts.index[k])], float(stops[k])))
        if error is not None:
            failed[k], messages[k] = True, error
            continue
        done[k] = rec
        for name, v in values.items():
            if name not in columns:
                columns[name] = np.zeros(n, dtype=np.asarray(v).dtype)
            columns[name][k] = v
    base = gb
    summaries = summary_columns(columns, lambda name: _column(pts, name, w["summary_base"]), setup.two) \
        if "impacts" in columns else {}
    blocks = None
    if summaries and column_size(setup):
        extra, blocks = sweep_rows(columns, lambda name: _column(pts, name, w["summary_base"]), column_size(setup),
                                   (~failed).tolist())
        summaries.update(extra)
        alpha2 = _alphas(lambda name: _column(pts, name, w["summary_base"]), 2, n)
        summaries["peak2_over_alpha"] = (np.asarray(columns["block2.maxAbsTheta"], float) / alpha2).tolist()
        summaries["friction_demand_max_interface"] = np.asarray(columns["friction.demandMaxInterface"], float).tolist()
        summaries["normal_min_interface"] = np.asarray(columns["contact.normalMinInterface"], float).tolist()
        summaries["impacts_ground"] = np.asarray(columns["impactsGround"]).astype(int).tolist()
        summaries["impacts_interface"] = np.asarray(columns["impactsInterface"]).astype(int).tolist()
    for col in summaries.values():
        for k in np.flatnonzero(failed).tolist():
            col[k] = None
    runs = {"grid_index": pts.index.tolist(), "point": pts.json(),
            "rel_tol": _nullable_floats(_column(pts, "solver.relTol", base)),
            "abs_tol": _nullable_floats(_column(pts, "solver.absTol", base)), "stop_time": stops.tolist(),
            "wall_time": seconds.tolist(), "status": np.where(failed, "error", "ok").tolist(),
            "error_message": [messages.get(k) for k in range(n)],
            "recording": [done[k].path if k in done else None for k in range(n)]}
    excitations = None
    if pts.records is not None:
        excitations = {"kind": ["record"] * n, "record_id": [r.id for r in pts.records],
                       "scale": _floats(pts, "excitation.scale", {"excitation.scale": 1.0, **base}),
                       "start_time": _floats(pts, "excitation.startTime", {"excitation.startTime": 0.0, **base})}
    return Chunk(runs, summaries, excitations, done, blocks)


def _floats(pts: Points, name: str, start: Mapping[str, Any]) -> list[float]:
    """FMU parameter `name` of every point as floats (_column)."""
    return np.asarray(_column(pts, name, start), dtype=float).tolist()


def _nullable_floats(col) -> list:
    """The values as floats, None for a missing (None or NaN) one."""
    if isinstance(col, np.ndarray) and col.dtype.kind in "fiu":
        a = col.astype(np.float64)
        return np.where(np.isnan(a), None, a).tolist()
    return [None if v is None or (isinstance(v, float) and math.isnan(v)) else float(v) for v in col]


# ------------------------------------------------------------------ summaries

def _pairwise(f: Callable[[float, float], float], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """f(x, y) elementwise by the scalar function, once per distinct pair."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) and (x == x[0]).all() and (y == y[0]).all():  # (the usual case: not on an axis)
        return np.full(len(x), f(float(x[0]), float(y[0])))
    pairs = np.column_stack([x, y])
    u, inv = np.unique(pairs, axis=0, return_inverse=True)
    return np.array([f(a, b) for a, b in u.tolist()])[inv.reshape(-1)]


SHAPE_PARAMETERS = ("outline", "mass", "centreX", "centreY", "inertia")


def _alphas(param: Callable[[str], Any], k: int, n: int) -> np.ndarray:
    """Block `k`'s alpha (rad) at each of `n` points of parameters `param(name)`: atan(b / h) of a rectangle,
    of a body of real shape the smaller side's (runners.engine.shapes.alpha), once per distinct body."""
    outline = np.broadcast_to(np.asarray(param(f"block{k}.outline"), dtype=object), (n,))
    if not any(isinstance(v, str) and v.strip() for v in outline.tolist()):
        return _pairwise(math.atan2, param(f"block{k}.halfWidth"), param(f"block{k}.halfHeight"))
    from runners.engine.shapes import alpha as shape_alpha

    cols = {name: np.broadcast_to(np.asarray(param(f"block{k}.{name}"), dtype=object), (n,)).tolist()
            for name in (*SHAPE_PARAMETERS, "halfWidth", "halfHeight")}
    found: dict[tuple, float] = {}
    out = np.empty(n)
    for i in range(n):
        key = tuple(cols[name][i] for name in cols)
        if key not in found:
            values = {f"block{k}.{name}": v for name, v in zip(cols, key)
                      if v is not None and not (isinstance(v, float) and math.isnan(v))}
            try:
                found[key] = shape_alpha(values, k)
            except (KeyError, ValueError):  # (a point the FMU refused: its row is failed anyway)
                found[key] = math.nan
        out[i] = found[key]
    return out


def _where(keep: np.ndarray, values: np.ndarray) -> list:
    """values where keep, None elsewhere, as Python floats."""
    return np.where(keep, np.asarray(values, dtype=float), None).tolist()


@np.errstate(divide="ignore", invalid="ignore")  # (a point whose block has no size failed anyway)
def summary_columns(out: Mapping[str, np.ndarray], param: Callable[[str], Any], two: bool) -> dict[str, list]:
    """The db.schema.RunSummary columns of points from their final FMU outputs `out` (name ->
    one value per point) and their FMU parameters (`param(name)`: one value per point):
    peaks over alpha, overturning, impacts, rest, first slide and lift-off, contact monitors,
    and the rocking–sliding columns (runners.engine.motion) of points with contact.model = 1."""
    n = len(out["impacts"])
    none = [None] * n
    alpha1 = _alphas(param, 1, n)
    over = np.asarray(out["overturned"]).astype(bool)
    slide, lift, fall = (np.asarray(out[k], dtype=float) for k in ("slideTime", "liftTime", "fallTime"))
    rest = np.asarray(out["restTime"], dtype=float)
    row: dict[str, list] = {
        "peak1_over_alpha": (np.asarray(out["block1.maxAbsTheta"], dtype=float) / alpha1).tolist(),
        "peak2_over_alpha": list(none), "overturned": over.tolist(), "overturned_blocks": list(none),
        "overturn_time": _where(over, out["overturnTime"]), "impacts": np.asarray(out["impacts"]).astype(int).tolist(),
        "impacts_ground": list(none), "impacts_interface": list(none),
        "rest_time": _where(np.asarray(out["atRest"]).astype(bool) & (rest >= 0), rest),
        "slide_time": _where(slide >= 0, slide), "lift_time": _where(lift >= 0, lift),
        "friction_demand_max": np.asarray(out["friction.demandMaxGround"], dtype=float).tolist(),
        "normal_min": np.asarray(out["contact.normalMinGround"], dtype=float).tolist(),
        "impulse_demand_max": np.asarray(out["friction.impulseDemandMax"], dtype=float).tolist(),
        "friction_demand_max_interface": list(none), "normal_min_interface": list(none),
        "assumptions_held": (~(slide >= 0) & ~(lift >= 0)).tolist(), "fall_time": _where(fall >= 0, fall)}
    model = np.asarray(param("contact.model"), dtype=float)
    for k in np.flatnonzero(np.nan_to_num(model) == ROCKING_SLIDING).tolist():
        # sliding is the model's now: only a lift-off (flight) is outside it
        final = {name: np.asarray(col)[k].item() for name, col in out.items()}
        cols = stack_slip_summary(final) if two else slip_summary(final)
        for key, v in cols.items():
            row.setdefault(key, list(none))[k] = v
        row["assumptions_held"][k] = row["lift_time"][k] is None
    if two:
        alpha2 = _alphas(param, 2, n)
        row["friction_demand_max_interface"] = np.asarray(out["friction.demandMaxInterface"], dtype=float).tolist()
        row["normal_min_interface"] = np.asarray(out["contact.normalMinInterface"], dtype=float).tolist()
        row["peak2_over_alpha"] = (np.asarray(out["block2.maxAbsTheta"], dtype=float) / alpha2).tolist()
        row["impacts_ground"] = np.asarray(out["impactsGround"]).astype(int).tolist()
        row["impacts_interface"] = np.asarray(out["impactsInterface"]).astype(int).tolist()
        b1, b2 = (np.asarray(out[f"block{i}.overturned"]).astype(bool).tolist() for i in (1, 2))
        row["overturned_blocks"] = [",".join(s for s, o in (("1", x), ("2", y)) if o) or None for x, y in zip(b1, b2)]
    else:
        row["overturned_blocks"] = ["1" if o else None for o in over.tolist()]
    return row
