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
import dataclasses
import hashlib
import itertools
import math
import os
import shutil
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

import numpy as np
from sqlalchemy import func, select, update

from db.schema import Run, RunSeries, Scene, Sweep
from db.store import add_scene, code_version, file_sha256
from runners.engine.fmu import FMUError, RockingFMU
from runners.engine.grid import IM_UNITS, Axis, Grid, Intensity, RecordRef, parse_intensity, scales  # noqa: F401
from runners.engine import batch as batch_lib
from runners.engine.motion import contact_model_value, rocking_sliding
from runners.engine.scene import KINDS, unused_parameter, weak_excitation
from runners.engine.sweep_lock import running
from runners.engine.sweep_store import INTEGRITY_ERRORS, RunConstants, series_row, store
from runners.engine.sweep_worker import Chunk, Setup, check_outputs, run_chunk, run_points, start_worker
from runners.errors import RockingError

ALIASES = {"w": "w", "omega_g/p": "w", "a": "a", "a_g/(g tan alpha)": "a", "scale": "excitation.scale"}

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
        if not (INT_MIN <= start <= INT_MAX and INT_MIN <= stop <= INT_MAX):
            raise ValueError(f"--grid {spec!r}: {name} is an FMI Integer (32 bits): START and STOP must lie in "
                             f"{INT_MIN}..{INT_MAX}")
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
# rocking–sliding model (contact.model = 1) slides on them, one block on contact.muGround and a stack
# also block 2 on block 1 on contact.muInterface: there they may be swept
MOTION_FREE = {"contact.muGround": "friction_demand_max", "contact.muInterface": "friction_demand_max_interface"}


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
    sliding = any(rocking_sliding(q) for q in cases)  # (contact.muInterface on one block: unused_parameter below)
    for ax in axes:
        if ax.name in MOTION_FREE and not sliding:
            raise ValueError(f"--grid {ax.name}: with rigid rocking friction does not change the motion (every point "
                             f"would run the same simulation; each run stores {MOTION_FREE[ax.name]}, the friction it "
                             "needed): let the blocks slide, contact.model = rocking-sliding "
                             "(--grid contact.model=rocking-sliding)")
    for ax in axes:
        whys = [unused_parameter(target(ax.name, q), q) for q in cases]
        if all(whys):
            raise ValueError(f"--grid {ax.name}: {whys[0]}, so every point would be the same")



# parameters of the built-in waveforms: a record ignores them, so a record sweep may not vary them
BUILT_IN = {"w", "a", "excitation.amplitude", "excitation.frequency", "excitation.cycles",
            "excitation.verticalAmplitude", "excitation.displacement", "excitation.gamma", "excitation.phase"}


def record_axes(factory, scene, axes: list[Axis], records_spec: str | None, im_spec: str | None,
                stop_given: bool, fmu: RockingFMU | None = None) -> tuple[list[RecordRef] | None, Intensity | None, list[str]]:
    """(records, intensity, notes) of a new sweep of `scene` (runners.engine.scene.Scene, changed in
    place when records replace its excitation), checked against its axes: records from
    `records_spec` (runners.engine.records.select_records) or the scene's own record, scaled by
    `im_spec` (pga=START:STOP:COUNT, ...); `stop_given`: a stop time was given for this sweep; `fmu`: the
    sweep's FMU, which gives the records' peak floor accelerations on a support (else computed in Python).
    ValueError, before anything is stored, for combinations a record would ignore or that conflict."""
    from runners.engine.records import prepare_scene, select_records, sweep_scaling_notes

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
        refs = through_support(session, refs, scene.parameters, names, intensity, fmu)
    notes = []
    start = float(scene.parameters.get("excitation.startTime", 0.0))
    longer = [r for r in refs if start + r.end > scene.stop_time] if scene.stop_time_given else []
    if longer:
        notes.append(f"every point stops at {scene.stop_time:g} s, before {len(longer)} of the {len(refs)} records "
                     f"end (the longest at {start + max(r.end for r in longer):g} s); without a stop time each "
                     "record runs to its end plus 5 s")
    notes += sweep_scaling_notes(refs, intensity, axes, scene.parameters)  # scaled beyond recorded motions
    return refs, intensity, notes


SUPPORT_PREFIXES = ("support.", "building.", "platform.")


def through_support(session, refs: list[RecordRef], p: dict[str, Any], names: list[str],
                    intensity: Intensity | None, fmu: RockingFMU | None = None) -> list[RecordRef]:
    """The records with their measures through the scene's support (runners.engine.floor_motion: PFA, from
    ``fmu`` when given, and Sa(T1)), which --im pfa and sa_t1 scale by; unchanged on the ground, or when an axis
    changes the support."""
    from db.records import samples
    from db.schema import Record
    from runners.engine.intensity import SUPPORT_MEASURES

    varied = [n for n in names if n.startswith(SUPPORT_PREFIXES)]
    on_support = int(p.get("support.kind", 0)) != 0
    if intensity is not None and intensity.measure in SUPPORT_MEASURES:
        if not on_support:
            raise ValueError(f"--im {intensity.measure}: a measure of the floor the blocks stand on; the scene has no "
                             "[building] or [platform]")
        if varied:
            raise ValueError(f"--im {intensity.measure}: --grid {varied[0]} changes the support, and with it every "
                             f"record's {intensity.measure}: scale by pga or pgv")
    if not on_support or varied:
        return refs
    from concurrent.futures import ThreadPoolExecutor

    from runners.engine.floor_motion import base_measures, fmu_peak_floor_accelerations, peak_floor_acceleration
    from runners.engine.records import file_of

    recs = [session.get(Record, r.id) for r in refs]
    data = [samples(rec)[:2] for rec in recs]
    files = [file_of(rec) for rec in recs] if fmu is not None else []
    halves = [files[:len(files) // 2], files[len(files) // 2:]]
    with ThreadPoolExecutor(2) as pool:  # the records' PFA by the FMU (in C, outside the GIL) beside their Sa(T1)
        pfas = [pool.submit(fmu_peak_floor_accelerations, fmu, p, half) for half in halves] if fmu is not None else []
        base = [base_measures(p, t, ah) for t, ah in data]
        pfa = [x for f in pfas for x in f.result()] if pfas else [peak_floor_acceleration(p, t, ah) for t, ah in data]
    out = []
    for r, b, f in zip(refs, base, pfa):
        measures = {**r.measures, "pfa": float(f), **b}
        if intensity is not None and not measures.get(intensity.measure, 0) > 0:
            raise ValueError(f"record {r.name} has no {intensity.measure}: it cannot be scaled to a level of it")
        out.append(RecordRef(r.id, r.name, r.sha256, r.end, measures))
    return out


def record_refs(session, ids: list[int], support: dict | None = None) -> list[RecordRef]:
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
        through = (support or {}).get(str(r.id), {})  # the sweep's measures through its support
        out.append(RecordRef(r.id, r.name, r.sha256, float(t[-1]), {**{k: getattr(r, k) for k in MEASURES}, **through}))
    return out


def grid_of(session, sw: Sweep) -> Grid:
    g = sw.grid
    recs = record_refs(session, g["records"], g.get("support_measures")) if g.get("records") else None
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


# ------------------------------------------------------------------ points to record

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

INT_MIN, INT_MAX = -2 ** 31, 2 ** 31 - 1  # an FMI 2.0 Integer (fmi2Integer: int)
MAX_POINTS = 100_000_000  # grid points one sweep may have (about 40 GB in SQLite): split larger studies
BYTES_PER_POINT = 400  # stored bytes of one point (run row, summary, index; 280 measured in SQLite)


def check_size(total: int, factory) -> None:
    """ValueError, before the sweep exists, for a grid too large to store: more than MAX_POINTS
    points, or (SQLite) more than the free space of the database's disk."""
    if total > MAX_POINTS:
        raise ValueError(f"the grid has {total:,} points, more than the {MAX_POINTS:,} one sweep may have "
                         "(about 40 GB of results): use fewer points, or split it into several sweeps")
    url = factory.kw["bind"].url
    if url.get_backend_name() == "sqlite" and url.database and url.database != ":memory:":
        import shutil

        free = shutil.disk_usage(Path(url.database).resolve().parent).free
        if total * BYTES_PER_POINT > free:
            raise ValueError(f"the grid's {total:.3g} points need about {total * BYTES_PER_POINT / 1e9:.3g} GB and "
                             f"the database's disk has {free / 1e9:.3g} GB free: use fewer points")


# A sweep this large is estimated, and run only when confirmed (runners.sweep(confirm=...), runners
# sweep --yes or an answer on the terminal), if it would need CONFIRM_BYTES of database or take
# CONFIRM_SECONDS. Below ESTIMATE_FROM points neither can happen with the points measured here (at
# most a few ms each; docs/BENCHMARKS.md): nothing is measured or asked, and small sweeps start at
# once. 1 GB is more than any study of the docs stores (a 10^6-point map: 0.4 GB) and more than a
# laptop's disk can lose unnoticed; ten minutes is past a sweep one waits for at the terminal.
ESTIMATE_FROM = 10_000  # grid points
CONFIRM_BYTES = 1e9  # B of results in the database
CONFIRM_SECONDS = 600.0  # s of wall time
SAMPLE_POINTS = 16  # grid points, evenly spread, timed for the estimate, unless the first one shows
SAMPLE_SECONDS = 0.5  # that they would take longer than this (s): then that one alone


@dataclass(frozen=True)
class SweepEstimate:
    """What a sweep will cost: its points, the database it fills (B, BYTES_PER_POINT a point) and
    its wall time (s) from the simulation cost of a point (s, in one worker, measured here on
    `measured` of its points through the sweep's own worker code) over `workers` workers (None: a
    Dask cluster's, not known yet)."""

    points: int
    seconds_per_point: float
    measured: int
    workers: int | None

    @property
    def bytes(self) -> float:
        return self.points * BYTES_PER_POINT

    @property
    def seconds(self) -> float:
        """s of wall time (of one worker's time on a Dask cluster)."""
        return self.points * self.seconds_per_point / (self.workers or 1)

    @property
    def large(self) -> bool:
        """Whether the sweep asks to be confirmed (CONFIRM_BYTES, CONFIRM_SECONDS)."""
        return self.bytes >= CONFIRM_BYTES or (self.workers is not None and self.seconds >= CONFIRM_SECONDS)

    def text(self) -> str:
        """One line: '12,000,000 points: about 4.8 GB in the database and about 25 min with 2 workers
        (0.25 ms a point, measured on 16 of them)'."""
        who = (f"with {self.workers} worker{'s' * (self.workers > 1)}" if self.workers else
               "of one worker's time (the Dask cluster's workers share it)")
        return (f"{self.points:,} points: about {self.bytes / 1e9:.2g} GB in the database and about "
                f"{_duration(self.seconds)} {who} ({1e3 * self.seconds_per_point:.3g} ms a point, measured on "
                f"{self.measured} of them)")

    def as_dict(self) -> dict[str, Any]:
        return {"points": self.points, "bytes": self.bytes, "seconds": self.seconds,
                "seconds_per_point": self.seconds_per_point, "measured": self.measured, "workers": self.workers}


def _duration(seconds: float) -> str:
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.2g} s"


def estimate(fm: RockingFMU, scene, grid: Grid, defaults: dict[str, Any], workers: int | None,
             factory) -> SweepEstimate | None:
    """The cost of a new sweep of `scene` (runners.engine.scene.Scene) over `grid`, or None below
    ESTIMATE_FROM points. SAMPLE_POINTS of its points, spread over the grid, run here through the
    sweep's own worker code (the C batch loop where it can be built), in one chunk after the first
    (or the first alone, if the others would take more than SAMPLE_SECONDS); nothing is stored. `fm`: the FMU (its extraction is used), `factory`: the
    database holding the grid's records."""
    if grid.total < ESTIMATE_FROM:
        return None
    indices = np.unique(np.linspace(0, grid.total - 1, SAMPLE_POINTS).astype(np.int64))
    base = {**defaults, **scene.parameters}
    files = {}
    if grid.records:
        from runners.engine.records import file_of

        for rec in (grid.point(int(i), base)[2] for i in indices):
            if rec.sha256 not in files:
                files[rec.sha256] = str(file_of(factory, rec.id))
    setup = Setup({k: v for k, v in scene.parameters.items() if k != "excitation.file" or not grid.records}, grid,
                  base, scene.stop_time, scene.step, int(base.get("nBlocks", 1)) == 2,
                  bool(scene.stop_time_given) or not grid.records, files, batch_library()[0])
    start_worker(str(fm.path), fm.unzipdir, setup)
    t0 = time.perf_counter()
    run_chunk((indices[:1], {}))  # the first point alone (it also sets the worker up)...
    first = time.perf_counter() - t0
    if first * len(indices) > SAMPLE_SECONDS or len(indices) == 1:
        return SweepEstimate(grid.total, first, 1, workers)
    t0 = time.perf_counter()
    run_chunk((indices[1:], {}))  # ...then the others in one chunk, as a worker runs them
    return SweepEstimate(grid.total, (time.perf_counter() - t0) / (len(indices) - 1), len(indices) - 1, workers)


def _corners(counts: list[int], integers: list[bool], limit: int) -> list[tuple[int, ...]]:
    """The corners of a grid of axes with `counts` points (each axis's first and last index; every
    index of an axis where `integers` says so), at most `limit`."""
    ends = [range(c) if whole else sorted({0, c - 1}) for c, whole in zip(counts, integers)]
    return list(itertools.islice(itertools.product(*ends), limit))


def _axis_points(grid: Grid, base: dict[str, Any], every_integer: bool = False,
                 limit: int = 64) -> Iterator[tuple[int, dict, dict]]:
    """(flat index in `grid`, values, FMU parameter overrides) of the corners of the grid's --grid
    axes (_corners; with `every_integer`, every value of its Integer axes), at most `limit`. In a
    sweep over records each is the point of the first record (at the first intensity level) there."""
    axes = Grid(grid.axes)
    lead = (0,) * (len(grid.counts) - len(axes.counts))  # the record and level indices come first
    for corner in _corners(axes.counts, [every_integer and ax.integer for ax in grid.axes], limit):
        values, over, _ = axes.point(int(np.ravel_multi_index(corner, axes.counts)), base) if corner else ({}, {}, None)
        yield int(np.ravel_multi_index(lead + corner, grid.counts)), values, over


def check_corners(fmu: RockingFMU, grid: Grid, base: dict[str, Any], limit: int = 64) -> list[str]:
    """Initialise the FMU at the corners of the grid's --grid axes (the first and last value of
    every axis; at most `limit` corners). ValueError naming a point when it refuses every corner
    (every point would fail); notes when it refuses some (their points are stored as errors). In a
    sweep over records the axes are checked with the scene's parameters and the excitation switched
    off: what they set is checked, not the records (which its workers read)."""
    if grid.records:
        base = {**base, "excitation.kind": KINDS["none"]}
    integer = {ax.name for ax in grid.axes if ax.integer}
    refused = []
    corners = list(_axis_points(grid, base, limit=limit))
    for index, values, over in corners:
        try:
            fmu.validate({**base, **over})
        except FMUError as exc:
            at = ", ".join(f"{k} = {v:.4g}" for k, v in values.items() if isinstance(v, float) or k in integer)
            refused.append(f"grid point {index}" + (f" ({at})" if at else "") + f": {exc}")
    if refused and len(refused) == len(corners):
        raise ValueError(refused[0] if len(corners) == 1 else f"every corner of the grid is refused, e.g. {refused[0]}")
    return [f"{len(refused)} of the grid's {len(corners)} corners are refused by the FMU (their points are stored "
            f"as errors), e.g. {refused[0]}"] if refused else []


def motionless_grid(grid: Grid, base: dict[str, Any], limit: int = 1024) -> list[str]:
    """A note (not an error) when no point of a grid of pulses can move: runners simulate's note
    (runners.engine.scene.weak_excitation: an amplitude below the threshold of motion, often meant
    in g) at every corner of the grid's axes and every value of its Integer axes, given for the
    corner of the largest amplitude. Along each Real axis, the others held, the amplitude's excess
    over the threshold is largest at an end (the threshold, g tan(alpha) of the sizes, mu g or the
    stack's, changes monotonically; |amplitude| and the a axis's a g tan(alpha) over it are convex),
    so the corners hold the grid's largest. Nothing for a sweep over records, or for a grid of more
    than `limit` such points (not all seen)."""
    if grid.records:
        return []
    weak = []
    for index, _values, over in _axis_points(grid, base, every_integer=True, limit=limit + 1):
        p = {**base, **over}
        note = weak_excitation(p)
        if not note or len(weak) == limit:
            return []
        weak.append((abs(float(p["excitation.amplitude"])), -index, note[0]))
    amplitude, index, note = max(weak)
    return [f"no point of the grid can move, e.g. grid point {-index} (its largest amplitude): {note}"]


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

    def setup(self, batch: str | None, files: dict[str, str] | None = None) -> Setup:
        """What the workers need (runners.engine.sweep_worker.Setup); `files`: the record files
        as the workers see them (default: this machine's, self.files())."""
        return Setup(self.params, self.grid, self.base, self.stop_time, self.step, self.two, self.stop_given,
                     self.files() if files is None else files, batch)

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
    start_worker(*args)


class SweepError(RockingError, RuntimeError):
    """A sweep cannot go on (e.g. a worker process died); str() is a one-line message."""


class _Stops:
    """Ctrl-C and SIGTERM while local workers run: their handlers (KeyboardInterrupt, for Ctrl-C
    and for the command line's SIGTERM) run where the sweep looks for them (check(): whenever it
    waits for its workers, at least every POLL_SECONDS) and when it ends (done()), not wherever
    the signal happens to find the main thread.

    There a handler may run inside a finalizer or a weakref callback of the garbage collector,
    whose exceptions Python prints and drops ("Exception ignored in ..."): the stop was lost, and
    the sweep waited for ever for its worker, which the same SIGTERM (sent to the process group)
    had killed in the middle of sending a chunk. Main thread only (where Python runs signal
    handlers); a signal left to SIG_DFL or SIG_IGN stays so."""

    def __init__(self) -> None:
        import signal

        self.previous: dict[int, Any] = {}
        self.caught: list[int] = []
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGINT, signal.SIGTERM):
                if callable(handler := signal.getsignal(s)):
                    self.previous[s] = handler
                    signal.signal(s, lambda signum, _frame: self.caught.append(signum))

    def check(self) -> None:
        """Run the handler of a signal noted (KeyboardInterrupt, for Ctrl-C and the command line's SIGTERM)."""
        if self.caught:
            signum = self.caught[0]
            self.caught.clear()
            self.previous[signum](signum, None)

    def done(self) -> None:
        """Put the handlers back, and run that of a signal noted since the last check."""
        import signal

        for s, handler in self.previous.items():
            signal.signal(s, handler)
        self.check()


POLL_SECONDS = 0.25  # s: the longest a local sweep waiting for its workers takes to see a stop or a dead worker


class _LocalExecutor:
    """Worker processes on this machine (forked where possible), sharing one extraction of the
    FMU. A worker that dies (killed, out of memory) stops the sweep with SweepError instead of
    hanging it, even if it died in the middle of sending a chunk (the pool's reading thread then
    waits for the rest for ever, and never says that the pool broke); on an interruption (_Stops)
    the workers are stopped at once."""

    def __init__(self, plan: _Plan, fmu_path: Path, workers: int, batch: str | None = None):
        from concurrent.futures import ProcessPoolExecutor

        self.workers, self.size = workers, LOCAL_CHUNK
        from fmpy import extract

        self.unzipdir = extract(str(fmu_path))  # one extraction for every worker (its model description is theirs)
        ctx = get_context("fork") if hasattr(os, "fork") else get_context()
        self.pool = ProcessPoolExecutor(workers, mp_context=ctx, initializer=_start_pool_worker,
                                        initargs=(str(fmu_path), self.unzipdir, plan.setup(batch)))

    def stream(self, tasks: Iterator[tuple]) -> Iterator[Chunk]:
        """run_chunk of each task (flat indices, points to record), as they finish; a few tasks
        at a time are handed out, so that `tasks` can plan the grid as the sweep goes."""
        from concurrent.futures.process import BrokenProcessPool

        inflight: set = set()
        try:
            while True:
                while len(inflight) < 2 * self.workers + 2 and (task := next(tasks, None)) is not None:
                    inflight.add(self.pool.submit(run_chunk, task))
                if not inflight:
                    return
                done, inflight = self._wait(inflight)
                for future in done:
                    yield future.result()
        except BrokenProcessPool:
            raise SweepError("a worker process died (killed, or out of memory)") from None

    def _wait(self, futures: set) -> tuple[set, set]:
        """(done, not done) of `futures` once one is done, as concurrent.futures.wait(FIRST_COMPLETED);
        every POLL_SECONDS meanwhile it runs the handler of a stop that arrived (_Stops.check:
        KeyboardInterrupt), and raises SweepError once a worker process has died: the pool does not
        say so when the worker died half-way through sending a chunk."""
        from concurrent.futures import FIRST_COMPLETED, wait
        from multiprocessing.connection import wait as ready

        while True:
            self.stops.check()
            done, pending = wait(futures, timeout=POLL_SECONDS, return_when=FIRST_COMPLETED)
            if done:
                return done, pending
            sentinels = [p.sentinel for p in list((getattr(self.pool, "_processes", None) or {}).values())]
            if sentinels and ready(sentinels, timeout=0):
                raise SweepError("a worker process died (killed, or out of memory)")

    def results(self, tasks: list, size: int | None = None):
        """run_point of each task (one point each, through fmpy), in lists of `size`, as they finish."""
        size = size or max(1, min(64, len(tasks) // (self.workers * 8) or 1))
        for done in self._finished(self.pool.submit(run_points, tasks[i:i + size])
                                   for i in range(0, len(tasks), size)):
            yield from done

    def _finished(self, submitted):
        from concurrent.futures.process import BrokenProcessPool

        pending = set(submitted)
        try:
            while pending:
                done, pending = self._wait(pending)
                for future in done:
                    yield future.result()
        except BrokenProcessPool:
            raise SweepError("a worker process died (killed, or out of memory)") from None

    def __enter__(self) -> "_LocalExecutor":
        self.stops = _Stops()
        return self

    def __exit__(self, exc_type, *_exc) -> None:
        try:
            processes = list((getattr(self.pool, "_processes", None) or {}).values())
            writer = getattr(getattr(self.pool, "_result_queue", None), "_writer", None)  # (shutdown forgets it)
            self.pool.shutdown(wait=exc_type is None, cancel_futures=True)
            if exc_type is not None:  # interrupted or failed: stop the workers now, not after their chunks
                for proc in processes:
                    if proc.is_alive():
                        proc.kill()
                for proc in processes:
                    proc.join(timeout=5)
                # A worker killed half-way through sending a chunk leaves a message cut short, and the pool's
                # thread that reads them would wait for its rest for ever (and the interpreter's exit with it):
                # with this process's end of the pipe closed too, that read ends.
                if writer is not None:
                    with contextlib.suppress(OSError):
                        writer.close()
            shutil.rmtree(self.unzipdir, ignore_errors=True)
        finally:  # the workers stopped, a stop noted and not acted on yet takes effect (KeyboardInterrupt)
            self.stops.done()


def _recording_task(plan: _Plan, index: int, record_dir: Path, rec: RecordRef | None) -> tuple:
    return (str(Path(record_dir) / f"point-{index}.rrd"),
            f"{plan.scene_name} (sweep {plan.sweep_id}, point {index})",
            None if rec is None else plan.infos[rec.id])


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
_DASK_LOCAL = threading.local()  # the sweep setup each thread of a Dask worker has started


def _dask_chunk(fmu_bytes: bytes, sha: str, setup: Setup, key: str, task: tuple,
                record_files: dict[str, bytes] | None = None, batch_bytes: bytes | None = None) -> Chunk:
    """Run a chunk of grid points on a Dask worker. The FMU arrives as bytes (the workers
    need this package, not a build of the FMU) and is extracted once per worker process;
    so do the sweep's record files (sha256 -> their bytes) and the batch library, written
    once per process. `key` names the sweep's setup: a thread sets up its instance once."""
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
        lib = None
        if batch_bytes is not None:
            bsha = hashlib.sha256(batch_bytes).hexdigest()
            if bsha not in _DASK_FILES:
                path = Path(tempfile.mkdtemp(prefix="rocking-batch-")) / "rocking_batch.so"
                path.write_bytes(batch_bytes)
                _DASK_FILES[bsha] = str(path)
            lib = _DASK_FILES[bsha]
    fmu = _DASK_FMUS[sha]
    if getattr(_DASK_LOCAL, "key", None) != key:  # this thread's instance, set up once per sweep
        here = {k: _DASK_FILES[k] for k in record_files or ()}
        start_worker(str(fmu.path), fmu.unzipdir, dataclasses.replace(setup, files=here, batch=lib))
        _DASK_LOCAL.key = key
    return run_chunk(task)


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


def _split(indices: np.ndarray, recorded: dict[int, tuple], size: int, workers: int, after: int = 0) -> list[tuple]:
    """Tasks of run_chunk: `indices` in pieces of at most `size`, each with its points to record.
    Towards the end of the sweep (`after` points follow these) the pieces shrink, to a quarter
    of what is left per worker and at least CHUNK_MIN, so that the workers finish together
    instead of one waiting on the last piece."""
    parts, k, n = [], 0, len(indices)
    while k < n:
        step = max(min(size, math.ceil((n - k + after) / (4 * workers))), CHUNK_MIN)
        parts.append(indices[k:k + step])
        k += step
    return [(part, {i: recorded[i] for i in part.tolist() if i in recorded} if recorded else {}) for part in parts]


def _window_tasks(plan: _Plan, factory, recorded: set[int], record_dir: Path, size: int, workers: int,
                  left: dict[int, set[int]]) -> Iterator[tuple]:
    """The run_chunk tasks of the grid points not stored yet, planned WINDOW points at a time as
    the executor asks for them (memory does not grow with the grid); each window's points to run
    go into left[window start]. A point another process stored meanwhile is not run."""
    for lo in range(0, plan.total, WINDOW):
        hi = min(plan.total, lo + WINDOW)
        stored = _stored_among(factory, plan.sweep_id, lo, hi)  # (another process may be storing this sweep too)
        todo = np.arange(lo, hi, dtype=np.int64)
        if stored:
            todo = np.setdiff1d(todo, np.fromiter(stored, dtype=np.int64, count=len(stored)))
        if not len(todo):
            continue
        full = {i: _recording_task(plan, i, record_dir, plan.grid.point(i, plan.base)[2])
                for i in recorded if lo <= i < hi and i not in stored}
        left[lo] = set(todo.tolist())
        yield from _split(todo, full, size, workers, plan.total - hi)


class _DaskExecutor:
    """Runs a sweep's grid points on a Dask cluster in chunks; the FMU, the record files and
    the batch library are sent to every worker once. A chunk whose worker dies is run again
    elsewhere (retries); results are stored only by the caller, in one slot per grid point,
    so a rerun chunk cannot store a point twice."""

    def __init__(self, plan: _Plan, fmu_path: Path, sha: str, client, chunk: int | None, batch: str | None):
        self.plan, self.sha, self.client = plan, sha, client
        self.workers = max(1, len(client.scheduler_info().get("workers", {})))
        self.size = chunk or DASK_CHUNK
        # hash=False: keys of this sweep's own; a key equal to one an earlier sweep just released
        # can lose its data on the cluster while this sweep's tasks wait for it ("lost dependencies")
        self.blob = client.scatter(Path(fmu_path).read_bytes(), broadcast=True, hash=False)
        local = plan.files()
        self.files = client.scatter({k: Path(v).read_bytes() for k, v in local.items()},
                                    broadcast=True, hash=False) if local else None
        self.batch = client.scatter(Path(batch).read_bytes(), broadcast=True, hash=False) if batch else None
        self.setup = plan.setup(None, files={})
        self.key = f"{plan.sweep_id}:{sha}:{os.getpid()}:{time.time()}"

    def stream(self, tasks: Iterator[tuple]) -> Iterator[Chunk]:
        """As _LocalExecutor.stream, on the cluster: four tasks per worker in flight."""
        from distributed import as_completed

        def submit(task: tuple):
            return self.client.submit(_dask_chunk, self.blob, self.sha, self.setup, self.key, task, self.files,
                                      self.batch, pure=False, retries=3)

        running = as_completed([submit(t) for t in itertools.islice(tasks, 4 * self.workers)])
        for future in running:
            yield future.result()
            task = next(tasks, None)
            if task is not None:
                running.add(submit(task))


def _dask_executor(plan: _Plan, fmu_path: Path, sha: str, client, chunk: int | None,
                   batch: str | None) -> _DaskExecutor:
    """_DaskExecutor(...); _ExecutorFailed, in one line, when the cluster cannot take the
    sweep (e.g. a scheduler without workers, which cannot hold the FMU sent to them)."""
    try:
        return _DaskExecutor(plan, fmu_path, sha, client, chunk, batch)
    except Exception as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise _ExecutorFailed(f"the Dask cluster cannot start the sweep: {text}") from None


def stop_status(exc: BaseException) -> str:
    """The status of a sweep that `exc` stopped: "interrupted" (Ctrl-C, SIGTERM), "failed" (its
    executor could not start) or "stopped" (its database or a worker failed on the way)."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted"
    return "failed" if isinstance(exc, _ExecutorFailed) else "stopped"


def _set_status(factory, sweep_id: int, status: str) -> None:
    """Mark an unfinished sweep running, interrupted, stopped or failed (a finished one stays done)."""
    with factory.begin() as session:
        session.execute(update(Sweep).where(Sweep.id == sweep_id, Sweep.done < Sweep.total).values(status=status))


def progress_of(factory, sweep_id: int) -> tuple[int | None, int | None]:
    """(points stored, total) of a sweep, or (None, None) when the database cannot say (it failed)."""
    from runners.engine.sweep_store import DATABASE_ERRORS

    try:
        with factory() as session:
            sw = session.get(Sweep, sweep_id)
            return sw.done, sw.total
    except DATABASE_ERRORS:
        return None, None


def mark_failed(factory, sweep_id: int) -> tuple[int, int]:
    """Mark an unfinished sweep failed (its executor could not start); (points stored, total)."""
    _set_status(factory, sweep_id, "failed")
    with factory() as session:
        sw = session.get(Sweep, sweep_id)
        return sw.done, sw.total


class _ExecutorFailed(SweepError):
    """The executor of a sweep could not start (a Dask cluster that cannot take its tasks)."""


WINDOW = 100_000  # grid points planned at a time: a sweep of any size runs in bounded memory
LOCAL_CHUNK = 2048  # grid points a local worker runs per task at most (each task costs about 0.2 ms to send)
DASK_CHUNK = 1000  # and a Dask worker (--chunk)
CHUNK_MIN = 16  # and at least, but for the last
FLUSH_SECONDS = 0.5  # results wait at most about this long between transactions (one commit each)
FLUSH_POINTS = 5000  # or until this many points wait: storing keeps pace with the workers


def batch_library() -> tuple[str | None, str | None]:
    """(the C batch library's path, None) for the workers, or (None, why not) when the points
    must run one FMI call at a time (ROCKING_BATCH=0, or no C compiler)."""
    if not batch_lib.enabled():
        return None, f"ROCKING_BATCH={os.environ.get('ROCKING_BATCH', '').strip()}"
    try:
        return str(batch_lib.library()), None
    except batch_lib.BatchUnavailable as exc:
        return None, str(exc)


def run_sweep(factory, sweep_id: int, fmu_path: Path, workers: int | None = None, batch: int = 20_000,
              progress: bool = True, record: list[int] | None = None, record_dir: Path | None = None,
              client=None, chunk: int | None = None) -> dict[str, Any]:
    """Run the grid points of a sweep that are not stored yet; returns counts and timings.

    Workers run the points in chunks through the C batch loop (runners.engine.batch), and this
    process stores their results in bulk (runners.engine.sweep_store): one transaction when
    FLUSH_POINTS (or `batch`, if fewer) points wait, or after FLUSH_SECONDS.
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
    lib, why = batch_library()
    stats = {"sweep": sweep_id, "total": plan.total, "already": plan.already, "ran": 0, "errors": 0,
             "recorded": 0, "skipped": 0, "fmu_seconds": 0.0, "db_seconds": 0.0, "db_cpu_seconds": 0.0,
             "python_seconds": 0.0, "workers": workers, "batch": lib is not None, "batch_unavailable": why}
    n_blocks = int(plan.base.get("nBlocks", 1))
    constants = RunConstants(plan.scene_id, sweep_id, "column" if n_blocks >= 3 else "two blocks" if plan.two
                             else "one block", sha, version)
    t_start = time.perf_counter()
    pending: list[Chunk] = []
    last_flush = [t_start]

    def flush() -> None:
        if not pending:
            return
        t0, c0 = time.perf_counter(), time.thread_time()
        chunks = list(pending)
        while chunks:  # each pass stores them all, or finds some another process stored: it ends
            try:
                with _interrupts_deferred(), factory.begin() as session:
                    store(session, constants, chunks)
                break
            except INTEGRITY_ERRORS:  # a concurrent resume stored some of these points: store the others
                indices = {i for ch in chunks for i in ch.runs["grid_index"]}
                taken = _stored_among(factory, sweep_id, min(indices), max(indices) + 1) & indices
                if not taken:  # not a point stored twice
                    raise
                chunks = [c for c in (ch.without(taken) for ch in chunks) if len(c)]
                stats["skipped"] += len(taken)
        stats["db_seconds"] += time.perf_counter() - t0
        stats["db_cpu_seconds"] += time.thread_time() - c0
        pending.clear()
        last_flush[0] = time.perf_counter()

    if client is not None and recorded:
        raise ValueError("--record writes recordings where the point runs: use the local executor, or record "
                         "points after the sweep with runners rrd --sweep ID --points")
    if remaining > 0:
        check_outputs(fmu_path, plan.two)
    bar = tqdm(total=plan.total, initial=plan.already, disable=not progress, unit="run", desc=f"sweep {sweep_id}")
    try:
        with ExitStack() as stack:
            stack.enter_context(running(factory, sweep_id))  # released when this process ends, however it ends
            _set_status(factory, sweep_id, "running")
            if remaining <= 0:
                executor = None
            elif client is not None:
                executor = _dask_executor(plan, fmu_path, sha, client, chunk, lib)
                stats["workers"] = executor.workers
            else:
                executor = stack.enter_context(_LocalExecutor(plan, fmu_path, workers, lib))
            left: dict[int, set[int]] = {}  # window start -> its points not run yet
            tasks = _window_tasks(plan, factory, recorded, record_dir, executor.size, executor.workers, left) \
                if executor else iter(())
            for ch in executor.stream(tasks) if executor else ():
                t_py = time.perf_counter()
                first = ch.runs["grid_index"][0] if len(ch) else -1
                window = left.get(first - first % WINDOW, set())
                if first not in window:  # a chunk run twice (its worker died after sending): keep the first
                    continue
                window.difference_update(ch.runs["grid_index"])
                if not window:
                    del left[first - first % WINDOW]
                pending.append(ch)
                stats["ran"] += len(ch)
                stats["errors"] += ch.errors
                stats["recorded"] += len(ch.recorded)
                stats["fmu_seconds"] += ch.fmu_seconds
                bar.update(len(ch))
                stats["python_seconds"] += time.perf_counter() - t_py
                waiting = sum(map(len, pending))
                if waiting >= min(batch, FLUSH_POINTS) or time.perf_counter() - last_flush[0] >= FLUSH_SECONDS:
                    flush()
            flush()
    except BaseException as exc:  # interrupted or failed: keep what arrived, and say the sweep is not running
        with contextlib.suppress(Exception):
            flush()
        with contextlib.suppress(Exception):  # (a database that failed may refuse this too: readers see no runner)
            _set_status(factory, sweep_id, stop_status(exc))
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
                row = series_row(run.id, rec)
                if run.series is None:
                    run.series = RunSeries(**{k: v for k, v in row.items() if k != "run_id"})
                else:
                    for k, v in row.items():
                        setattr(run.series, k, v)
            done.append((index, rec.path))
            bar.update(1)
    return sorted(done)
