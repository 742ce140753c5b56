"""Small FMI 2.0 Model Exchange importers written for the tests, over fmpy's low-level FMU2Model.

They stand in for importers that cannot be installed here (PyFMI needs the FMI Library):

- :func:`run_assimulo` drives the FMU as PyFMI's FMIODE2 does, with Assimulo's solvers
  (CVode, Dopri5, Radau5ODE, LSODAR; pip ``assimulo-testing`` ships them as a wheel): the
  state events are the FMU's event indicators, located by the solver (Assimulo's own locator
  for Dopri5 and Radau5, ODEPACK's for LSODAR, SUNDIALS' for CVode), the time events the
  FMU's nextEventTime, the step events fmi2CompletedIntegratorStep.
- :func:`run_scipy` drives it with scipy's solve_ivp (RK45, i.e. Dormand-Prince, Radau, LSODA),
  the indicators as terminal events located exactly (brentq), then fmi2NewDiscreteStates.

Both stop the integration exactly on a located event, which is what made a block lifting
off from rest count a false impact (issue 29). Each returns a :class:`MeRun`: the outputs at
every output point and on both sides of every event, so that tests can see what changes
where. Nothing here knows the model beyond its variable names.
"""

from __future__ import annotations

import shutil
import tempfile
from ctypes import POINTER, c_double
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model


class ImporterFailure(RuntimeError):
    """The importer gave up (a solver flag, an event that does not let time advance)."""


@dataclass
class Sample:
    """The outputs at time t (s). kind: 'out' (an output point), 'pre' (an event, before the
    event update), 'post' (after it, back in continuous-time mode)."""

    t: float
    kind: str
    values: dict[str, float]


@dataclass
class MeRun:
    samples: list[Sample] = field(default_factory=list)
    events: int = 0  # event iterations after the initialization
    # the times (s) at which the solver evaluated the event indicators: the ends of its steps
    # (run_scipy records them; an indicator whose sign is the same at both ends of a step is
    # not seen, whatever it did in between)
    steps: list[float] = field(default_factory=list)

    def final(self, name: str) -> float:
        return self.samples[-1].values[name]

    def outputs(self, name: str) -> np.ndarray:
        """name at the output points (t = k * interval)."""
        return np.array([s.values[name] for s in self.samples if s.kind == "out"])


class MeModel:
    """One Model Exchange instance: typed access by name and the FMI 2.0 event iteration."""

    def __init__(self, fmu_path: Path, outputs: list[str]):
        self.md = read_model_description(str(fmu_path))
        self.unzipdir = extract(str(fmu_path), unzipdir=tempfile.mkdtemp(prefix="me_master_"))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmu = FMU2Model(guid=self.md.guid, unzipDirectory=self.unzipdir,
                             modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName="me")
        self.fmu.instantiate()
        self.nx = self.md.numberOfContinuousStates
        self.nz = self.md.numberOfEventIndicators
        self.outputs = outputs
        self.terminated = False
        self.next_time = np.inf

    def close(self) -> None:
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self.unzipdir, ignore_errors=True)

    def set(self, name: str, value) -> None:
        v = self.vars[name]
        if v.type == "Real":
            self.fmu.setReal([v.valueReference], [float(value)])
        elif v.type in ("Integer", "Enumeration"):
            self.fmu.setInteger([v.valueReference], [int(value)])
        elif v.type == "Boolean":
            self.fmu.setBoolean([v.valueReference], [bool(value)])
        else:
            self.fmu.setString([v.valueReference], [str(value)])

    def get(self, name: str) -> float:
        v = self.vars[name]
        if v.type == "Real":
            return self.fmu.getReal([v.valueReference])[0]
        if v.type in ("Integer", "Enumeration"):
            return self.fmu.getInteger([v.valueReference])[0]
        return float(self.fmu.getBoolean([v.valueReference])[0])

    def sample(self, t: float, kind: str) -> Sample:
        return Sample(t, kind, {n: self.get(n) for n in self.outputs})

    def start(self, params: dict, stop: float) -> None:
        self.fmu.setupExperiment(startTime=0.0, stopTime=stop)
        for name, value in params.items():
            self.set(name, value)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.iterate()
        self.fmu.enterContinuousTimeMode()

    def iterate(self) -> None:
        """fmi2NewDiscreteStates until no new discrete states are needed."""
        while True:
            needed, terminate, _, _, time_defined, next_time = self.fmu.newDiscreteStates()
            if terminate:
                self.terminated = True
            if not needed or self.terminated:
                break
        self.next_time = next_time if time_defined else np.inf

    def event(self, t: float, run: MeRun) -> None:
        """An event at t: the event iteration, back to continuous-time mode; the outputs before and after."""
        run.samples.append(self.sample(t, "pre"))
        self.fmu.enterEventMode()
        self.iterate()
        self.fmu.enterContinuousTimeMode()
        run.events += 1
        run.samples.append(self.sample(t, "post"))

    def set_point(self, t: float, x: np.ndarray) -> None:
        self.fmu.setTime(t)
        x = np.ascontiguousarray(x, dtype=float)
        self.fmu.setContinuousStates(x.ctypes.data_as(POINTER(c_double)), self.nx)

    def states(self) -> np.ndarray:
        x = np.zeros(self.nx)
        self.fmu.getContinuousStates(x.ctypes.data_as(POINTER(c_double)), self.nx)
        return x

    def derivatives(self, t: float, x: np.ndarray) -> np.ndarray:
        self.set_point(t, x)
        dx = np.zeros(self.nx)
        self.fmu.getDerivatives(dx.ctypes.data_as(POINTER(c_double)), self.nx)
        return dx

    def indicators(self, t: float, x: np.ndarray) -> np.ndarray:
        self.set_point(t, x)
        z = np.zeros(self.nz)
        self.fmu.getEventIndicators(z.ctypes.data_as(POINTER(c_double)), self.nz)
        return z

    def completed(self, t: float, x: np.ndarray) -> bool:
        """fmi2CompletedIntegratorStep at (t, x): does the model ask for an event?"""
        self.set_point(t, x)
        enter, terminate = self.fmu.completedIntegratorStep()
        if terminate:
            self.terminated = True
        return bool(enter)


def _grid(stop: float, interval: float) -> np.ndarray:
    n = round(stop / interval)
    return np.linspace(0.0, stop, n + 1)


def _past_root(m: MeModel, dense, te: float, z_start: np.ndarray) -> tuple[float, np.ndarray]:
    """brentq returns a root to within 4 eps, on either side: step forward on the dense output
    to where an indicator's sign (z > 0 or not, as Assimulo tells them) differs from the
    segment's start, the right end of the bracket, as CVODE, LSODAR and Assimulo stop."""
    dt = 4 * np.finfo(float).eps * max(1.0, abs(te))
    t = te
    for _ in range(64):
        x = dense(t)
        if np.any((m.indicators(t, x) > 0) != z_start):
            return t, x
        t, dt = te + dt, 2 * dt
    return te, dense(te)


def run_scipy(fmu_path: Path, params: dict, stop: float, outputs: list[str], method: str = "RK45",
              interval: float = 1e-2, rtol: float = 1e-10, atol: float = 1e-12) -> MeRun:
    """solve_ivp (method RK45, Radau or LSODA) from output point to output point, stopping at the
    first located root of any event indicator (direction either way) and at the FMU's time events.
    An indicator root located where the integration starts is an event that does not let time
    advance: this importer then gives up (ImporterFailure), as LSODAR does with flag -3."""
    from scipy.integrate import solve_ivp

    m = MeModel(fmu_path, outputs)
    run = MeRun()
    try:
        m.start(params, stop)
        x = m.states()
        t = 0.0
        run.samples.append(m.sample(t, "out"))
        rhs: Callable = m.derivatives
        events = []
        for i in range(m.nz):
            def ev(tt, xx, i=i):
                return m.indicators(tt, xx)[i]
            ev.terminal = True
            events.append(ev)
        for tout in _grid(stop, interval)[1:]:
            while t < tout and not m.terminated:
                end = min(tout, m.next_time)
                z_start = m.indicators(t, x) > 0
                try:
                    sol = solve_ivp(rhs, (t, end), x, method=method, rtol=rtol, atol=atol, events=events,
                                    dense_output=True)
                except ValueError as e:  # brentq: the indicator has no sign change on the dense output
                    raise ImporterFailure(f"solve_ivp {method} failed locating an event after t={t!r}: {e}") from e
                if sol.status < 0:
                    raise ImporterFailure(f"solve_ivp {method} failed at t={t}: {sol.message}")
                t_new, x = sol.t[-1], sol.y[:, -1]
                run.steps.extend(float(s) for s in sol.t[1:])
                if sol.status == 1:
                    t_new, x = _past_root(m, sol.sol, t_new, z_start)
                if sol.status == 1 and not t_new > t:
                    hit = [i for i, te in enumerate(sol.t_events) if len(te)]
                    raise ImporterFailure(f"solve_ivp {method}: event indicator(s) {hit} at the restart point "
                                          f"t={t!r} again: time cannot advance")
                t = t_new
                step_event = m.completed(t, x)
                if sol.status == 1 or step_event or t >= m.next_time:
                    m.event(t, run)
                    x = m.states()
            run.samples.append(m.sample(t, "out"))
            if m.terminated:
                break
        return run
    finally:
        m.close()


def run_assimulo(fmu_path: Path, params: dict, stop: float, outputs: list[str], solver: str = "Dopri5",
                 interval: float = 1e-2, rtol: float = 1e-10, atol: float = 1e-12) -> MeRun:
    """An Assimulo solver (CVode, Dopri5, Radau5ODE, LSODAR) on the FMU as PyFMI's FMIODE2 poses
    it: results at the output points (report_continuously, interpolated), state events on the
    indicators, time events, step events. A solver failure raises ImporterFailure."""
    from assimulo import solvers
    from assimulo.problem import Explicit_Problem

    m = MeModel(fmu_path, outputs)
    run = MeRun()

    class Problem(Explicit_Problem):
        def rhs(self, t, y, sw=None):
            return m.derivatives(t, y)

        def state_events(self, t, y, sw):
            return m.indicators(t, y)

        def time_events(self, t, y, sw):
            return m.next_time if np.isfinite(m.next_time) else None

        def step_events(self, solver):
            return m.completed(solver.t, solver.y)

        def handle_event(self, solver, event_info):
            m.set_point(solver.t, solver.y)
            m.event(solver.t, run)
            solver.y = m.states()
            if m.terminated:
                from assimulo.exception import TerminateSimulation
                raise TerminateSimulation()

        def handle_result(self, solver, t, y):
            m.set_point(t, y)
            run.samples.append(m.sample(t, "out"))

    try:
        m.start(params, stop)
        y0 = m.states()
        problem = Problem(y0=y0, t0=0.0, sw0=[False] * m.nz)
        s = getattr(solvers, solver)(problem)
        s.verbosity = 50
        s.report_continuously = True
        s.rtol = rtol
        if hasattr(s, "atol"):
            s.atol = atol
        if hasattr(s, "store_event_points"):
            s.store_event_points = False
        try:
            s.simulate(stop, round(stop / interval))
        except Exception as e:  # a solver flag (Assimulo's own exception types)
            raise ImporterFailure(f"Assimulo {solver}: {type(e).__name__}: {str(e).splitlines()[0]}") from e
        return run
    finally:
        m.close()
