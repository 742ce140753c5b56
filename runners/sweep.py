"""``runners sweep``: a grid of runs of one scene, in parallel worker processes, stored in
batches; resumable after any interruption (each batch is one transaction and each grid
point has one unique slot, so a resumed sweep stores every point exactly once).

Grid axes (NAME=START:STOP:COUNT) are FMU parameters (dimensional, e.g.
excitation.amplitude) or the dimensionless groups of the seeds:

- ``w`` (or ``omega_g/p``): excitation.frequency = w p / (2 pi), with
  p = sqrt(3 g / (4 R)) of block 1;
- ``a`` (or ``a_g/(g tan alpha)``): excitation.amplitude = a g tan(alpha) for
  one block, a g kappa for two (kappa = min(b1 / yG, c / h2), the stack's
  uplift threshold, docs/two_blocks.md).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import insert, select

from db.schema import Run, RunSummary, Scene, Sweep
from db.store import add_scene, code_version, file_sha256
from runners.fmu import RockingFMU

ALIASES = {"w": "w", "omega_g/p": "w", "a": "a", "a_g/(g tan alpha)": "a"}
ONE = ["overturned", "impacts", "block1.maxAbsTheta", "overturnTime", "restTime", "atRest"]
TWO = ["block2.maxAbsTheta", "impactsGround", "impactsInterface", "block1.overturned", "block2.overturned"]


@dataclass(frozen=True)
class Axis:
    name: str  # "w", "a" or an FMU parameter
    start: float
    stop: float
    count: int

    @property
    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.count)


def parse_axis(spec: str, parameter_names: set[str]) -> Axis:
    """NAME=START:STOP:COUNT, with a one-line reason when it is malformed."""
    name, eq, rng = spec.partition("=")
    parts = rng.split(":")
    if not eq or len(parts) != 3:
        raise ValueError(f"--grid {spec!r}: expected NAME=START:STOP:COUNT")
    name = ALIASES.get(name.strip(), name.strip())
    if name not in ("w", "a") and name not in parameter_names:
        raise ValueError(f"--grid {spec!r}: unknown name {name!r} (w, a, or a Real FMU parameter)")
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"--grid {spec!r}: START and STOP must be numbers and COUNT an integer") from None
    if count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
        raise ValueError(f"--grid {spec!r}: COUNT must be >= 1 and START, STOP finite")
    return Axis(name, start, stop, count)


def scales(p: dict[str, Any]) -> tuple[float, float]:
    """(p, uplift acceleration) of the scene: rad/s and m/s^2 per unit of w and a."""
    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    pf = math.sqrt(3 * g / (4 * math.hypot(b, h)))
    if int(p.get("nBlocks", 1)) == 2:
        b2, h2, m1, m2 = p["block2.halfWidth"], p["block2.halfHeight"], p["block1.mass"], p["block2.mass"]
        y_g = (m1 * h + m2 * (2 * h + h2)) / (m1 + m2)
        return pf, g * min(b / y_g, min(b, b2) / h2)
    return pf, g * b / h


def point_parameters(axes: list[Axis], index: int, base: dict[str, Any]) -> tuple[dict, dict]:
    """(grid values, FMU parameter overrides) of the flat grid index (row-major, last axis fastest)."""
    idx = np.unravel_index(index, [ax.count for ax in axes])
    values = {ax.name: float(ax.values[i]) for ax, i in zip(axes, idx)}
    over = {k: v for k, v in values.items() if k not in ("w", "a")}
    merged = {**base, **over}
    pf, acc = scales(merged)
    if "w" in values:
        over["excitation.frequency"] = values["w"] * pf / (2 * math.pi)
    if "a" in values:
        over["excitation.amplitude"] = values["a"] * acc
    return values, over


# ------------------------------------------------------------------ workers

_WORKER: dict[str, Any] = {}  # state of one worker process (set by _start_worker)


def _start_worker(fmu_path: str, unzipdir: str, base: dict, stop_time: float, two: bool) -> None:
    fmu = RockingFMU(fmu_path, unzipdir)
    errors: list[str] = []
    slave, cb = fmu.instantiate(lambda status, cat, msg: errors.append(msg) if status >= 3 else None,
                                logging_on=False)
    names = ONE + (TWO if two else [])
    _WORKER.update(fmu=fmu, slave=slave, cb=cb, errors=errors, base=base, stop=stop_time,
                   names=names, vrs={n: fmu.variable(n) for n in names})


def _set_all(fmu: RockingFMU, slave, params: dict) -> None:
    """All parameters in one call per type (each call through ctypes costs microseconds)."""
    by_type: dict[str, tuple[list, list]] = {"Real": ([], []), "Integer": ([], []), "Boolean": ([], [])}
    for name, value in params.items():
        v = fmu.variable(name)
        vrs, vals = by_type[v.type]
        vrs.append(v.valueReference)
        vals.append(float(value) if v.type == "Real" else int(value) if v.type == "Integer" else bool(value))
    if by_type["Real"][0]:
        slave.setReal(*by_type["Real"])
    if by_type["Integer"][0]:
        slave.setInteger(*by_type["Integer"])
    if by_type["Boolean"][0]:
        slave.setBoolean(*by_type["Boolean"])


def _run_point(task: tuple[int, dict]) -> tuple[int, dict | None, float, str | None]:
    index, over = task
    w = _WORKER
    s, fmu = w["slave"], w["fmu"]
    w["errors"].clear()
    t0 = time.perf_counter()
    try:
        s.reset()
        s.setupExperiment(startTime=0.0, stopTime=w["stop"])
        _set_all(fmu, s, {**w["base"], **over})
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.doStep(0.0, w["stop"])
        out = {}
        for typ, get in (("Real", s.getReal), ("Integer", s.getInteger), ("Boolean", s.getBoolean)):
            names = [n for n, v in w["vrs"].items() if v.type == typ]
            if names:
                out.update(zip(names, get([w["vrs"][n].valueReference for n in names])))
        return index, out, time.perf_counter() - t0, None
    except Exception as exc:  # the point fails, the sweep goes on
        message = w["errors"][-1] if w["errors"] else str(exc)
        return index, None, time.perf_counter() - t0, message.splitlines()[0] if message else "error"


# ------------------------------------------------------------------ driver

def _summary(out: dict, merged: dict, two: bool) -> dict:
    alpha1 = math.atan2(merged["block1.halfWidth"], merged["block1.halfHeight"])
    row = {"peak1_over_alpha": out["block1.maxAbsTheta"] / alpha1, "peak2_over_alpha": None,
           "overturned": bool(out["overturned"]), "overturned_blocks": None,
           "overturn_time": out["overturnTime"] if out["overturned"] else None, "impacts": int(out["impacts"]),
           "impacts_ground": None, "impacts_interface": None,
           "rest_time": out["restTime"] if out["atRest"] and out["restTime"] >= 0 else None}
    if two:
        alpha2 = math.atan2(merged["block2.halfWidth"], merged["block2.halfHeight"])
        row.update(peak2_over_alpha=out["block2.maxAbsTheta"] / alpha2, impacts_ground=int(out["impactsGround"]),
                   impacts_interface=int(out["impactsInterface"]),
                   overturned_blocks=",".join(str(i) for i in (1, 2) if out[f"block{i}.overturned"]) or None)
    elif out["overturned"]:
        row["overturned_blocks"] = "1"
    return row


def create_sweep(factory, scene, axes: list[Axis], defaults: dict) -> int:
    source = Path(scene.source).read_text() if scene.source and Path(scene.source).is_file() else None
    grid = {"axes": [[a.name, a.start, a.stop, a.count] for a in axes], "stop_time": scene.stop_time,
            "defaults": defaults}
    with factory.begin() as session:
        sc = add_scene(session, scene.name, scene.parameters, source)
        session.flush()
        sw = Sweep(scene_id=sc.id, grid=grid, total=int(np.prod([a.count for a in axes])), done=0, status="running")
        session.add(sw)
        session.flush()
        return sw.id


def run_sweep(factory, sweep_id: int, fmu_path: Path, workers: int | None = None, batch: int = 500,
              progress: bool = True) -> dict[str, Any]:
    """Run the grid points of a sweep that are not stored yet; returns counts and timings."""
    from tqdm import tqdm

    with factory() as session:
        sw = session.get(Sweep, sweep_id)
        if sw is None:
            raise ValueError(f"no sweep {sweep_id} in the database")
        scene = session.get(Scene, sw.scene_id)
        grid, total, scene_id = sw.grid, sw.total, sw.scene_id
        params = dict(scene.parameters)
        stored = set(session.scalars(select(Run.grid_index).where(Run.sweep_id == sweep_id)))
    axes = [Axis(*a) for a in grid["axes"]]
    base = {**grid["defaults"], **params}
    two = int(base.get("nBlocks", 1)) == 2
    pending = [i for i in range(total) if i not in stored]
    points = {i: point_parameters(axes, i, base) for i in pending}  # (grid values, overrides), once per point
    tasks = [(i, points[i][1]) for i in pending]
    workers = max(1, min(workers or os.cpu_count() or 1, max(1, len(tasks))))
    sha, version = file_sha256(str(fmu_path)), code_version()
    stats = {"sweep": sweep_id, "total": total, "already": len(stored), "ran": 0, "errors": 0,
             "fmu_seconds": 0.0, "db_seconds": 0.0, "python_seconds": 0.0}
    t_start = time.perf_counter()
    rows: list[tuple] = []

    def flush() -> None:
        if not rows:
            return
        t0 = time.perf_counter()
        with factory.begin() as session:
            ids = session.execute(insert(Run).returning(Run.id, Run.grid_index), [r[0] for r in rows]).all()
            by_index = {gi: rid for rid, gi in ids}
            summaries = [{"run_id": by_index[r[0]["grid_index"]], **r[1]} for r in rows if r[1] is not None]
            if summaries:
                session.execute(insert(RunSummary), summaries)
            sw = session.get(Sweep, sweep_id)
            sw.done = sw.done + len(rows)
            sw.status = "done" if sw.done >= sw.total else "running"
        stats["db_seconds"] += time.perf_counter() - t0
        rows.clear()

    bar = tqdm(total=total, initial=len(stored), disable=not progress, unit="run", desc=f"sweep {sweep_id}")
    ctx = get_context("fork") if hasattr(os, "fork") else get_context()
    shared = RockingFMU(fmu_path)  # one extraction for every worker
    with shared, ctx.Pool(workers, initializer=_start_worker,
                          initargs=(str(fmu_path), shared.unzipdir, params, grid["stop_time"], two)) as pool:
        chunk = max(1, min(64, len(tasks) // (workers * 8) or 1))
        for index, out, seconds, error in pool.imap_unordered(_run_point, tasks, chunksize=chunk):
            t_py = time.perf_counter()
            values, over = points[index]
            merged = {**base, **over}
            run = {"scene_id": scene_id, "sweep_id": sweep_id, "grid_index": index, "point": values,
                   "model": "two blocks" if two else "one block", "method": "fmu",
                   "rel_tol": merged.get("solver.relTol"), "abs_tol": merged.get("solver.absTol"),
                   "stop_time": grid["stop_time"], "fmu_sha256": sha, "code_version": version,
                   "wall_time": seconds, "status": "error" if error else "ok", "error_message": error}
            rows.append((run, None if out is None else _summary(out, merged, two)))
            stats["ran"] += 1
            stats["errors"] += error is not None
            stats["fmu_seconds"] += seconds
            bar.update(1)
            stats["python_seconds"] += time.perf_counter() - t_py
            if len(rows) >= batch:
                flush()
        flush()
    bar.close()
    stats["wall_seconds"] = time.perf_counter() - t_start
    return stats
