"""Writing runs: the scene, its excitation, the run, its summary and its series in one
transaction (all or nothing)."""

from __future__ import annotations

import hashlib
import subprocess
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from db import series
from db.schema import Block, Excitation, Measurement, Record, Run, RunSeries, RunSummary, Scene

KINDS = {0: "none", 1: "sine-pulse", 2: "cosine-pulse", 3: "harmonic", 4: "record", 5: "ricker",
         6: "ricker-antisymmetric", 7: "mavroeidis-papageorgiou"}


@lru_cache(maxsize=None)
def code_version() -> str:
    """Package version, plus the git commit when running from a checkout."""
    try:
        v = version("rocking")
    except PackageNotFoundError:
        v = "unknown"
    try:
        root = Path(__file__).resolve().parent.parent
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"], capture_output=True,
                                text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return f"{v}+{commit}" if commit else v


@lru_cache(maxsize=None)
def file_sha256(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def excitation_of(p: dict[str, Any], record: Record | None = None) -> Excitation:
    """The excitation the FMU parameters p describe (a record's samples are `record`)."""
    kind = int(p["excitation.kind"])
    if kind == 4:
        return Excitation(kind="record", record=record, scale=p.get("excitation.scale", 1.0),
                          start_time=p["excitation.startTime"])
    mp = kind == 7
    return Excitation(kind=KINDS[kind], amplitude=p["excitation.amplitude"],
                      frequency=p["excitation.frequency"], cycles=p["excitation.cycles"],
                      start_time=p["excitation.startTime"], vertical_amplitude=p["excitation.verticalAmplitude"],
                      displacement=p["excitation.displacement"], gamma=p.get("excitation.gamma") if mp else None,
                      phase=p.get("excitation.phase") if mp else None)


def add_scene(session: Session, name: str, parameters: dict[str, Any], source: str | None = None) -> Scene:
    scene = Scene(name=name, n_blocks=int(parameters.get("nBlocks", 1)), parameters=dict(parameters),
                  source=source)
    session.add(scene)
    return scene


def add_run(session: Session, scene: Scene, merged: dict[str, Any], summary: dict[str, Any] | None, *,
            model: str, method: str, stop_time: float, fmu_path: str | None, wall_time: float | None,
            time: np.ndarray | None = None, outputs: dict[str, np.ndarray] | None = None,
            events: list[dict[str, Any]] | None = None, error: str | None = None,
            sweep_id: int | None = None, grid_index: int | None = None, excitation: Excitation | None = None) -> Run:
    """One run with its summary (if it succeeded) and series (if sampled); its excitation is
    `excitation` (a recorded one, say) or the built-in one its parameters describe."""
    run = Run(scene=scene, excitation=excitation if excitation is not None else excitation_of(merged), sweep_id=sweep_id, grid_index=grid_index,
              model=model, method=method, rel_tol=merged.get("solver.relTol"), abs_tol=merged.get("solver.absTol"),
              stop_time=stop_time, fmu_sha256=file_sha256(str(fmu_path)) if fmu_path else None,
              code_version=code_version(), wall_time=wall_time, status="error" if error else "ok",
              error_message=error)
    session.add(run)
    if summary is not None:
        run.summary = RunSummary(**summary)
    if time is not None and outputs:
        names, n, blob = series.pack(time, outputs)
        run.series = RunSeries(names=names, n_samples=n, data=blob, events=events)
    return run


def add_measurement(session: Session, *, name: str, kind: str, time: np.ndarray, columns: dict[str, np.ndarray],
                    units: dict[str, str], sign: str, block1: Block | None = None, block2: Block | None = None,
                    source: str | None = None, instrument: str | None = None, sampling_rate: float | None = None,
                    uncertainty: dict[str, float] | None = None, file_name: str | None = None,
                    file_sha256: str | None = None, record: Record | None = None) -> Measurement:
    """One measurement (SI, our signs); with `record` (the ground motion a motion measurement
    amounts to, runners.records.store_record) also its excitation, which runs can be driven by."""
    u = uncertainty or {}
    names, n, blob = series.pack(time, columns)
    m = Measurement(name=name, kind=kind, block1=block1, block2=block2, source=source, instrument=instrument,
                    sampling_rate=sampling_rate, uncertainty_angle=u.get("theta"), uncertainty_time=u.get("time"),
                    uncertainty_value=u.get("value"), units=dict(units), sign=sign, file_name=file_name,
                    file_sha256=file_sha256, names=names, n_samples=n, data=blob)
    if record is not None:
        m.excitation = Excitation(kind="record", record=record, scale=1.0, start_time=0.0)
    session.add(m)
    return m


def load_run_series(session: Session, run_id: int, hint: str = "") -> tuple[Run, np.ndarray, dict[str, np.ndarray],
                                                                              list[dict[str, Any]]]:
    """(run, time, columns, events) of a stored run; ValueError if it is missing or was not
    sampled (`hint` says what to do then)."""
    run = session.get(Run, run_id)
    if run is None:
        raise ValueError(f"no run {run_id} in the database")
    if run.series is None:
        raise ValueError(f"run {run_id} has no stored series" + (f" ({hint})" if hint else ""))
    t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    return run, t, cols, list(run.series.events or [])
