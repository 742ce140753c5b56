"""``runners bench --interfaces``: the cost of one run through each FMI interface.

The same scenes run through fmpy as a co-simulation tool would run them: the
FMI 2.0 Co-Simulation interface (the FMU's own event-driven solver), the FMI 2.0
Model Exchange interface integrated by fmpy's CVode (rtol 1e-10) and by its
forward Euler (1e-4 s), and the FMI 3.0 edition's Co-Simulation with early
return at every event (the master restarts its step there). Outputs every
10 ms; each run instantiates, simulates and frees (the FMUs are unzipped once).
Times are the minimum over the repeats, all measured in one process, so the
ratios compare like with like on a shared machine.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu

from runners.engine.fmu import with_scene_defaults

SCENES = [
    ("free rocking, theta0 = 0.1 rad", {"block1.theta0": 0.1}),
    ("sine pulse 4 m/s2, 2 Hz", {"excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 2.0}),
]
STOP = 5.0  # s
INTERVAL = 0.01  # s


def _interfaces(fmu3: Path | None) -> list[tuple[str, str, dict]]:
    """(label, which FMU, simulate_fmu keywords) of every interface."""
    out = [
        ("FMI 2.0 Co-Simulation", "fmi2", {"fmi_type": "CoSimulation"}),
        ("FMI 2.0 Model Exchange, fmpy CVode rtol 1e-10", "fmi2",
         {"fmi_type": "ModelExchange", "solver": "CVode", "relative_tolerance": 1e-10}),
        # fmpy's Euler steps from one output point to the next: outputs at its step, compared at 10 ms
        ("FMI 2.0 Model Exchange, fmpy Euler 1e-4 s", "fmi2",
         {"fmi_type": "ModelExchange", "solver": "Euler", "step_size": 1e-4, "output_interval": 1e-4}),
    ]
    if fmu3 is not None:
        out.append(("FMI 3.0 Co-Simulation, early return at events", "fmi3",
                    {"fmi_type": "CoSimulation", "early_return_allowed": True, "use_event_mode": True}))
    return out


def run_interface_bench(fmu_path: Path, fmu3_path: Path | None = None, repeats: int = 5) -> str:
    """Markdown table: ms per run through each interface, its ratio to FMI 2.0 Co-Simulation,
    impacts, and the largest difference of theta from Co-Simulation at the output points."""
    if repeats < 1:
        raise ValueError("--repeats must be >= 1")
    tmp = Path(tempfile.mkdtemp(prefix="rocking-bench-"))
    try:
        dirs = {"fmi2": Path(extract(str(fmu_path), unzipdir=str(tmp / "fmi2")))}
        if fmu3_path is not None:
            dirs["fmi3"] = Path(extract(str(fmu3_path), unzipdir=str(tmp / "fmi3")))
        mds = {k: read_model_description(str(d)) for k, d in dirs.items()}
        out = [f"One run through each FMI interface: {STOP:g} s simulated, outputs every {INTERVAL * 1e3:g} ms, "
               f"minimum of {repeats} runs (instantiate to free)", "",
               "| scene | interface | ms / run | × Co-Simulation | impacts | max abs(theta - theta CS) (rad) |",
               "|---|---|---:|---:|---:|---:|"]
        for scene, params in SCENES:
            reference = None
            base_ms = None
            for label, which, kw in _interfaces(fmu3_path):
                best = float("inf")
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    r = simulate_fmu(str(dirs[which]), validate=False, model_description=mds[which],
                                     start_values=with_scene_defaults(params), stop_time=STOP, output=["block1.theta", "impacts"],
                                     record_events=False, **{"output_interval": INTERVAL, **kw})
                    best = min(best, time.perf_counter() - t0)
                grid = np.isclose(np.round(r["time"] / INTERVAL) * INTERVAL, r["time"], atol=1e-9, rtol=0)
                theta = r["block1.theta"][grid]
                if reference is None:
                    reference, base_ms = theta, 1e3 * best
                diff = float(np.max(np.abs(theta - reference))) if len(theta) == len(reference) else float("nan")
                out.append(f"| {scene} | {label} | {1e3 * best:.2f} | {1e3 * best / base_ms:.2f} | "
                           f"{int(r['impacts'][-1])} | {diff:.1e} |")
        return "\n".join(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
