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
from db.schema import Excitation, Run, RunSeries, RunSummary, Scene

KINDS = {0: "none", 1: "sine-pulse", 2: "cosine-pulse", 3: "harmonic"}


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


def excitation_of(p: dict[str, Any]) -> Excitation:
    return Excitation(kind=KINDS[int(p["excitation.kind"])], amplitude=p["excitation.amplitude"],
                      frequency=p["excitation.frequency"], cycles=p["excitation.cycles"],
                      start_time=p["excitation.startTime"], vertical_amplitude=p["excitation.verticalAmplitude"],
                      displacement=p["excitation.displacement"])


def add_scene(session: Session, name: str, parameters: dict[str, Any], source: str | None = None) -> Scene:
    scene = Scene(name=name, n_blocks=int(parameters.get("nBlocks", 1)), parameters=dict(parameters),
                  source=source)
    session.add(scene)
    return scene


def add_run(session: Session, scene: Scene, merged: dict[str, Any], summary: dict[str, Any] | None, *,
            model: str, method: str, stop_time: float, fmu_path: str | None, wall_time: float | None,
            time: np.ndarray | None = None, outputs: dict[str, np.ndarray] | None = None,
            events: list[dict[str, Any]] | None = None, error: str | None = None,
            sweep_id: int | None = None, grid_index: int | None = None) -> Run:
    """One run with its summary (if it succeeded) and series (if sampled)."""
    run = Run(scene=scene, excitation=excitation_of(merged), sweep_id=sweep_id, grid_index=grid_index,
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
