"""Work-precision comparison: error against cost for every method (``runners bench --charts``).

Case "free rocking": a block with h/b = 3 released at 0.6 alpha, constant
restitution 0.9; the error is the largest relative error of the first 10
impact times and the 9 peaks between them against the exact reference
(model/reference.py). Case "sine pulse": the same block, eta 0.85, a one-sine
pulse of 5 m/s2 at 3 Hz; the error is the largest relative error of the
first 10 impact times against scipy's DOP853 at rtol 1e-13, an independent
solver. Case "two blocks": the free stack of Anagnostopoulos Fig. 14 (opposite tilts,
momentum law); the error of its first 20 impact times (ground and interface)
against the event-driven two-block reference at rtol 1e-13
(model/two_block_solver.py).

The FMU runs with its default integrator (solver.method 2, auto: for one block
under a built-in excitation the Taylor series, to the bit the run of solver.method 1) and with Dormand-Prince
(solver.method 0, the earlier default); two blocks have Dormand-Prince
only (auto's choice for them). Costs are wall
seconds per simulation. The FMU appears three times: natively
(the C harness of runners/analysis/bench.py, instantiate to free, mean of many runs),
through fmpy with one instance reset between runs and one doStep (what a
Python sweep pays per simulation), and through fmpy with 10 ms communication
steps reading theta at each (what a co-simulation pays); the error does not
depend on the communication step (a test), only the cost does. Its Model Exchange
interface appears integrated by fmpy's CVode (BDF, at several tolerances) and by
fmpy's forward Euler (fixed steps; events found at the step's end). The Python
methods are model/solvers.py (minimum over repeats).
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from model import two_blocks as tb
from model.reference import Block, free_rocking
from model.solvers import Scene, sine_pulse, solve_event_driven, solve_fixed_step
from model.two_block_solver import StackScene, solve_stack
from runners.analysis.bench import NativeTimer
from runners.engine.fmu import RockingFMU, parse_event, with_scene_defaults

BLOCK = Block(0.1, 0.3)
N_IMPACTS = 10
# solver.method: 2 (auto) is the FMU's default, the Taylor series for one block; 0 Dormand-Prince
DEFAULT_METHOD = 2
DEFAULT_SUFFIX = ", default (Taylor series)"
DOPRI_SUFFIX = ", Dormand-Prince"


@dataclass
class Point:
    case: str
    method: str  # one line of the chart
    setting: str  # tolerance or step of this point
    error: float  # largest relative error
    seconds: float  # wall time per simulation


@dataclass
class Case:
    name: str
    scene: Scene
    fmu_parameters: dict
    t_end: float
    reference_times: np.ndarray
    reference_peaks: np.ndarray | None  # None: impact times only

    @property
    def fmu_stop(self) -> float:
        """The FMU runs just past the last reference impact (the Python solvers stop at it)."""
        t = self.reference_times
        return float(t[-1] + 0.2 * (t[-1] - t[-2]))

    def error(self, impact_times, peak_thetas) -> float:
        ti = np.asarray(impact_times[:N_IMPACTS], float)
        if len(ti) < N_IMPACTS:
            return math.inf
        e = float(np.max(np.abs(ti / self.reference_times - 1)))
        if self.reference_peaks is not None:
            pk = np.asarray(peak_thetas[: N_IMPACTS - 1], float)
            if len(pk) < N_IMPACTS - 1:
                return math.inf
            e = max(e, float(np.max(np.abs(pk / self.reference_peaks - 1))))
        return e


def free_rocking_case() -> Case:
    theta0, eta = 0.6 * BLOCK.alpha, 0.9
    ref = free_rocking(BLOCK, theta0, eta, N_IMPACTS)
    return Case("free rocking", Scene(BLOCK, eta, theta0=theta0),
                {"block1.theta0": theta0, "restitution.law": 2, "restitution.eta": eta},
                1.5 * ref.impact_times[-1], ref.impact_times, ref.peak_thetas[: N_IMPACTS - 1])


def sine_pulse_case() -> Case:
    A, f, eta = 5.0, 3.0, 0.85
    ground, breaks = sine_pulse(A, f)
    scene = Scene(BLOCK, eta, ground=ground, breaks=breaks)
    ref = solve_event_driven(scene, 5.0, "DOP853", 1e-13, 1e-15, max_impacts=N_IMPACTS)
    return Case("sine pulse", scene, {"excitation.kind": 1, "excitation.amplitude": A,
                                       "excitation.frequency": f, "restitution.law": 2, "restitution.eta": eta},
                1.5 * ref.impact_times[N_IMPACTS - 1], np.array(ref.impact_times[:N_IMPACTS]), None)


TWO_BLOCKS = tb.Stack(0.1, 0.3, 10.0, 0.1, 0.2, 5.0)
TWO_BLOCK_START = (0.05, -0.08)  # Anagnostopoulos Fig. 14's opposite tilts
N_TWO = 20


def two_block_reference() -> np.ndarray:
    """The first N_TWO impact times of the free stack, by the Python reference at rtol 1e-13."""
    ref = solve_stack(StackScene(TWO_BLOCKS, theta0=TWO_BLOCK_START), 2.0, rtol=1e-13, atol=1e-15,
                      max_impacts=N_TWO)
    return np.array(ref.impacts()[:N_TWO])


def two_block_points(fmu: RockingFMU, native: NativeTimer, repeats: int, quick: bool) -> list[Point]:
    """Free two-block rocking (momentum law): error of the first N_TWO impact times."""
    ref = two_block_reference()
    err = lambda times: (float(np.max(np.abs(np.array(times[:N_TWO]) / ref - 1)))  # noqa: E731
                         if len(times) >= N_TWO else math.inf)
    stop = float(ref[-1] + 0.2 * (ref[-1] - ref[-2]))
    st = TWO_BLOCKS
    base = {"nBlocks": 2, "block1.halfWidth": st.b1, "block1.halfHeight": st.h1, "block1.mass": st.m1,
            "block2.halfWidth": st.b2, "block2.halfHeight": st.h2, "block2.mass": st.m2,
            "block1.theta0": TWO_BLOCK_START[0], "block2.theta0": TWO_BLOCK_START[1]}
    points = []
    for rtol in QUICK_TOLS if quick else FMU_TOLS:
        params = {**base, "solver.relTol": rtol, "solver.absTol": 1e-2 * rtol}
        r = fmu.run(params, stop, stop)
        points.append(Point("two blocks", "FMU native (C harness)" + DOPRI_SUFFIX, f"rtol {rtol:g}",
                            err(list(r.event_times("impact"))), native.seconds(params, stop, 20 * repeats)))
    for method, tols in (("DOP853", [1e-6, 1e-8, 1e-10]), ("RK45", [1e-6, 1e-8])):
        for rtol in tols[:1] if quick else tols:
            seconds, sol = _timed(lambda: solve_stack(StackScene(TWO_BLOCKS, theta0=TWO_BLOCK_START), stop, method,
                                                      rtol, 1e-2 * rtol, max_impacts=N_TWO), 1)
            points.append(Point("two blocks", f"scipy {method}, event-driven", f"rtol {rtol:g}",
                                err(sol.impacts()), seconds))
    return points


def _timed(run: Callable[[], tuple[list, list]], repeats: int) -> tuple[float, tuple[list, list]]:
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - t0)
    return best, out


def fmu_points(fmu: RockingFMU, native: NativeTimer, case: Case, rel_tols, repeats: int) -> list[Point]:
    """The FMU at several tolerances; one doStep over the horizon, events from its log."""
    events = []

    def log(status, category, message):
        if category == "logEvents":
            ev = parse_event(message)
            if ev:
                events.append(ev)

    slave, _cb = fmu.instantiate(log, logging_on=True)
    theta_vr = fmu.variable("block1.theta").valueReference
    points = []
    try:
        for method, rtol in [(0, r) for r in rel_tols] + [(DEFAULT_METHOD, r) for r in rel_tols]:
            params = {**BLOCK_PARAMETERS, **case.fmu_parameters, "solver.relTol": rtol, "solver.absTol": 1e-2 * rtol,
                      "solver.method": method}
            suffix = DEFAULT_SUFFIX if method == DEFAULT_METHOD else DOPRI_SUFFIX

            def run(step=None):
                """One doStep over the horizon, or steps of `step` s reading theta at each."""
                events.clear()
                slave.reset()
                slave.setupExperiment(startTime=0.0)
                fmu.set_parameters(slave, params)
                slave.enterInitializationMode()
                slave.exitInitializationMode()
                if step is None:
                    slave.doStep(0.0, case.fmu_stop)
                else:
                    n = int(math.ceil(case.fmu_stop / step))
                    for i in range(n):
                        slave.doStep(i * step, step)
                        slave.getReal([theta_vr])
                return ([e.t for e in events if e.kind == "impact"],
                        [e.values["theta"] for e in events if e.kind == "peak"])

            seconds, (ti, pk) = _timed(run, repeats)
            error = case.error(ti, pk)
            points.append(Point(case.name, "FMU through fmpy" + suffix, f"rtol {rtol:g}", error, seconds))
            if method == DEFAULT_METHOD:
                seconds, (ti, pk) = _timed(lambda: run(0.01), max(1, repeats // 5))
                points.append(Point(case.name, "FMU through fmpy, default, 10 ms communication steps", f"rtol {rtol:g}",
                                    case.error(ti, pk), seconds))
            points.append(Point(case.name, "FMU native (C harness)" + suffix, f"rtol {rtol:g}", error,
                                native.seconds(params, case.fmu_stop, 50 * repeats)))
    finally:
        slave.freeInstance()
    return points


BLOCK_PARAMETERS = {"block1.halfWidth": BLOCK.b, "block1.halfHeight": BLOCK.h}
ME_TOLS = [1e-4, 1e-6, 1e-8, 1e-10]
ME_STEPS = [1e-3, 3e-4, 1e-4]  # s, fmpy's Euler steps from one output point to the next


def me_points(fmu: RockingFMU, case: Case, repeats: int, quick: bool = False) -> list[Point]:
    """The FMU's Model Exchange interface integrated by fmpy's CVode (several tolerances) and its
    forward Euler (fixed steps): one instance reset between runs, events from its log."""
    from fmpy import simulate_fmu

    events = []

    def log(_status, category, message):
        if category == "logEvents":
            ev = parse_event(message)
            if ev:
                events.append(ev)

    md = fmu.model_description
    model, _callbacks = fmu.instantiate(log, "me", interface="ModelExchange")
    params = with_scene_defaults({**BLOCK_PARAMETERS, **case.fmu_parameters})
    points = []
    try:
        for solver, settings in (("CVode", QUICK_TOLS if quick else ME_TOLS), ("Euler", ME_STEPS)):
            for x in settings:
                def run():
                    events.clear()
                    model.reset()
                    simulate_fmu(fmu.unzipdir, validate=False, stop_time=case.fmu_stop, solver=solver,
                                 relative_tolerance=x if solver == "CVode" else None,
                                 step_size=x if solver == "Euler" else None,
                                 output_interval=x if solver == "Euler" else case.fmu_stop / 10,
                                 record_events=False, fmi_type="ModelExchange", start_values=params, output=[],
                                 model_description=md, fmu_instance=model, terminate=True)
                    return ([e.t for e in events if e.kind == "impact"],
                            [e.values["theta"] for e in events if e.kind == "peak"])

                seconds, (ti, pk) = _timed(run, max(1, repeats // 5) if solver == "CVode" else 1)
                setting = f"rtol {x:g}" if solver == "CVode" else f"h {x:g} s"
                points.append(Point(case.name, f"FMU Model Exchange, fmpy {solver}", setting,
                                    case.error(ti, pk), seconds))
    finally:
        model.freeInstance()
    return points

SCIPY = {"DOP853": [1e-4, 1e-6, 1e-8, 1e-10, 1e-12], "RK45": [1e-4, 1e-6, 1e-8, 1e-10],
         "Radau": [1e-4, 1e-6, 1e-8]}
FIXED = {  # (method, locate): steps in s
    ("euler", False): [1e-3, 3e-4, 1e-4],
    ("rk4", False): [3e-3, 1e-3, 3e-4, 1e-4],
    ("rk4", True): [4e-2, 2e-2, 1e-2, 5e-3, 2e-3],
    ("newmark", True): [1e-2, 3e-3, 1e-3, 3e-4],
}
FIXED_NAMES = {("euler", False): "Euler, sign change (Anagnostopoulos)",
               ("rk4", False): "RK4, sign change (Anagnostopoulos)", ("rk4", True): "RK4, located impacts", ("newmark", True): "Newmark + Newton, located (Čeh & Jelenić 2022)"}
FMU_TOLS = [1e-4, 1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]
QUICK_TOLS = [1e-6, 1e-10]  # --quick: a smoke run


def python_points(case: Case, quick: bool = False) -> list[Point]:
    points = []
    for method, tols in SCIPY.items():
        for rtol in tols[:2] if quick else tols:
            seconds, sol = _timed(lambda: solve_event_driven(case.scene, case.t_end, method, rtol, 1e-2 * rtol,
                                                             max_impacts=N_IMPACTS), 1 if quick else 3)
            points.append(Point(case.name, f"scipy {method}, event-driven", f"rtol {rtol:g}",
                                case.error(sol.impact_times, sol.peak_thetas), seconds))
    for (method, locate), steps in FIXED.items():
        for h in steps[:2] if quick else steps:
            seconds, sol = _timed(lambda: solve_fixed_step(case.scene, case.t_end, method, h, locate,
                                                           max_impacts=N_IMPACTS), 1)
            points.append(Point(case.name, FIXED_NAMES[(method, locate)], f"h {h:g} s",
                                case.error(sol.impact_times, sol.peak_thetas), seconds))
    return points


def speedups(points: list[Point]) -> list[str]:
    """For reference points of other methods, the FMU's cheapest setting at equal or better accuracy."""
    lines = []
    for case in sorted({p.case for p in points}):
        fmu = [p for p in points if p.case == case and p.method.startswith("FMU native")]  # either integrator
        others = [p for p in points if p.case == case and not p.method.startswith("FMU") and math.isfinite(p.error)]
        for ref in others:
            if not (ref.method.startswith("scipy DOP853") or ref.setting == "h 0.0001 s"):
                continue
            ok = [p for p in fmu if p.error <= ref.error]
            if ok:
                best = min(ok, key=lambda p: p.seconds)
                lines.append(f"{case}: {ref.method} {ref.setting} (error {ref.error:.1e}, {1e3 * ref.seconds:.2f} ms) "
                             f"vs {best.method} {best.setting} (error {best.error:.1e}, "
                             f"{1e3 * best.seconds:.3f} ms): {ref.seconds / best.seconds:.0f} times faster")
    return lines


# One style per method, the same in every chart: (colour, marker, line style). The FMU in blues and
# purples with full lines, scipy's event-driven solvers in warm colours with dashes, the fixed-step
# methods in greens and greys with dots or dash-dots; no two methods share a colour or a marker.
STYLES: dict[str, tuple[str, str, str]] = {
    "FMU native (C harness)" + DEFAULT_SUFFIX: ("#6a3d9a", "D", "-"),
    "FMU native (C harness)" + DOPRI_SUFFIX: ("#08306b", "o", "-"),
    "FMU through fmpy" + DEFAULT_SUFFIX: ("#b15fd3", "^", "-"),
    "FMU through fmpy" + DOPRI_SUFFIX: ("#1f78b4", "s", "-"),
    "FMU through fmpy, default, 10 ms communication steps": ("#56b4e9", "v", "-"),
    "FMU Model Exchange, fmpy CVode": ("#17becf", "h", "-"),
    "FMU Model Exchange, fmpy Euler": ("#9edae5", "d", "-"),
    "scipy DOP853, event-driven": ("#d62728", "P", "--"),
    "scipy RK45, event-driven": ("#ff7f0e", "X", "--"),
    "scipy Radau, event-driven": ("#8c564b", "*", "--"),
    FIXED_NAMES[("euler", False)]: ("#7f7f7f", "x", ":"),
    FIXED_NAMES[("rk4", False)]: ("#bcbd22", "+", ":"),
    FIXED_NAMES[("rk4", True)]: ("#2ca02c", "<", "-."),
    FIXED_NAMES[("newmark", True)]: ("#e377c2", ">", "-."),
}


def style(method: str) -> dict:
    """Matplotlib keywords of a method's line: its colour, marker and line style (STYLES), thicker
    for the FMU."""
    colour, marker, ls = STYLES[method]
    return {"color": colour, "marker": marker, "ls": ls, "ms": 6, "mfc": "none" if marker not in "x+" else colour,
            "lw": 2.2 if method.startswith("FMU") else 1.2}


def chart_figure(points: list[Point]):
    """The work-precision chart as a matplotlib Figure: one panel per case, error against wall
    time per simulation, one line per method styled by STYLES, one legend for all panels."""
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(p.case for p in points))
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 6.0), squeeze=False)
    methods = list(dict.fromkeys(p.method for p in points))
    unknown = [m for m in methods if m not in STYLES]
    if unknown:
        raise ValueError(f"no chart style for {', '.join(unknown)} (runners.analysis.work_precision.STYLES)")
    legend: dict[str, object] = {}
    for ax, case in zip(axes[0], cases):
        for method in methods:
            pts = [p for p in points if p.case == case and p.method == method and math.isfinite(p.error)]
            if not pts:
                continue
            (line,) = ax.loglog([p.seconds for p in pts], [max(p.error, 1e-16) for p in pts], label=method,
                                **style(method))
            legend.setdefault(method, line)
        ax.set_title(f"{case}: error of the first {N_TWO if case == 'two blocks' else N_IMPACTS} impacts" +
                     (" and peaks" if case == "free rocking" else ""), fontsize=10)
        ax.set_xlabel("wall time per simulation (s)")
        ax.set_ylabel("largest relative error")
        ax.grid(alpha=0.3, which="both")
    order = [m for m in STYLES if m in legend]  # the same order in every chart
    fig.legend([legend[m] for m in order], order, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.13, 1, 1))
    return fig


def chart(points: list[Point], out: Path) -> Path:
    """Write chart_figure(points) as a PNG."""
    from runners.analysis.plotting import save_png

    return save_png(chart_figure(points), out)


def compute_points(fmu_path: Path, repeats: int = 20, quick: bool = False, progress: bool = False) -> list[Point]:
    """Every point of the chart: the three cases, each with the FMU and the Python methods."""
    from tqdm import tqdm

    points: list[Point] = []
    with RockingFMU(fmu_path) as fmu, NativeTimer(fmu_path) as native, \
            tqdm(total=5, desc="work-precision", unit="part", disable=not progress) as bar:
        for case in (free_rocking_case(), sine_pulse_case()):
            points += fmu_points(fmu, native, case, QUICK_TOLS if quick else FMU_TOLS, repeats)
            points += me_points(fmu, case, repeats, quick)
            bar.update()
            points += python_points(case, quick)
            bar.update()
        points += two_block_points(fmu, native, repeats, quick)
        bar.update()
    return points


def run_work_precision(fmu_path: Path, out_dir: Path, repeats: int = 20, quick: bool = False,
                       progress: bool = False) -> str:
    """Compute every point, write work_precision.{png,csv,json} to out_dir, return a text summary."""
    out_dir.mkdir(parents=True, exist_ok=True)
    points = compute_points(fmu_path, repeats, quick, progress)
    with open(out_dir / "work_precision.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(asdict(points[0])))
        w.writeheader()
        w.writerows(asdict(p) for p in points)
    (out_dir / "work_precision.json").write_text(json.dumps([asdict(p) for p in points], indent=1))
    chart(points, out_dir / "work_precision.png")
    lines = ["| case | method | setting | error | ms / simulation |", "|---|---|---|---:|---:|"]
    lines += [f"| {p.case} | {p.method} | {p.setting} | {p.error:.1e} | {1e3 * p.seconds:.3f} |" for p in points]
    return "\n".join(lines + [""] + speedups(points) + ["", f"written: {out_dir}/work_precision.png, .csv, .json"])
