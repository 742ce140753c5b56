"""Drive RockingBlock.fmu through fmpy's FMI 2.0 Co-Simulation API.

Units are SI and angles radians, with the sign convention of
docs/conventions.md (theta > 0: clockwise, rocking on the right corner).
"""

from __future__ import annotations

import os
import re
import shutil
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2LastSuccessfulTime,
    fmi2Terminated,
)

from runners.errors import RockingError

def _allocator():
    """calloc and free for the FMU's callbacks. On POSIX from the process's global symbol
    namespace, so that an AddressSanitizer preloaded by make sanitize sees (and guards) the
    FMU's heap; fmpy's own pair comes straight from libc and would bypass it."""
    if os.name == "posix":
        import ctypes

        lib = ctypes.CDLL(None)
        lib.calloc.restype, lib.calloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t, ctypes.c_size_t]
        lib.free.restype, lib.free.argtypes = None, [ctypes.c_void_p]
        return lib.calloc, lib.free
    from fmpy.fmi2 import calloc, free  # the C runtime's allocator, as fmpy uses it

    return calloc, free


calloc, free = _allocator()

DEFAULT_OUTPUTS = (
    "block1.theta",
    "block1.omega",
    "block1.alpha_dd",
    "impacts",
    "overturned",
    "atRest",
    "energy",
    "ground.ahTotal",
)

# fmpy changes the process's working directory while it loads an FMU's shared
# library and restores it afterwards; two threads loading at once can leave the
# process in the wrong directory, so loading is serialised.
_LOAD_LOCK = threading.Lock()

# events one run may log (each a Python object of about 500 bytes): more is refused mid-run
MAX_EVENTS = 1_000_000

# the event kinds of logEvents; rocking-sliding adds slide (stick to slip), stick (slip to stick),
# reverse (the slip turns) and slide-rock (uplift onto a sliding corner); the rocking-sliding stack
# adds fell-off (block 2 left block 1) and flight (a contact would have to pull: the run ends); the contact
# engine of one block (docs/flight.md) adds flight (it leaves the ground), land, flat (a negligible rebound
# lands flat), painleve (an impact without collision) and rechoose (a set chosen again at a step's start); a
# column's overhang (a block's corner passes the edge of the one below: the contact there changes its pair)
_EVENT = re.compile(r"^(impact|peak|uplift|rest|settle|open|overturn|slide-rock|slide|stick|reverse|lift|fell-off|flight|land|flat|painleve|rechoose|overhang) (.*)$")


def fmu_path_from(arg: str | None) -> Path:
    """The FMU to use: `arg` (--fmu), else $ROCKING_FMU, else build/RockingBlock.fmu (built if needed)."""
    if arg:
        return Path(arg)
    if os.environ.get("ROCKING_FMU"):
        return Path(os.environ["ROCKING_FMU"])
    from fmu_build import build_fmu

    return build_fmu()


class FMUError(RockingError, RuntimeError):
    """The FMU returned an error; the message is the FMU's own log line."""


@dataclass
class Event:
    """An event the FMU reported through its ``logEvents`` category."""

    kind: str  # impact, peak, uplift, rest, settle, open, overturn, slide, stick, slide-rock or lift
    t: float  # s
    values: dict[str, float] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)  # non-numeric fields, e.g. contact=ground

    def as_dict(self) -> dict:
        """JSON-ready form, as stored with a run's series (db.schema.RunSeries.events)."""
        return {"kind": self.kind, "t": self.t, "values": dict(self.values), "labels": dict(self.labels)}

    @classmethod
    def from_dict(cls, d: dict) -> "Event":
        return cls(d["kind"], float(d["t"]), {k: float(v) for k, v in d.get("values", {}).items()},
                   dict(d.get("labels", {})))


@dataclass
class RunResult:
    """Sampled outputs (one array per variable, at ``time``) and the events."""

    time: np.ndarray
    outputs: dict[str, np.ndarray]
    events: list[Event]
    wall_time: float  # s, instantiate to terminate

    def event_times(self, kind: str) -> np.ndarray:
        return np.array([e.t for e in self.events if e.kind == kind])

    def event_values(self, kind: str, key: str) -> np.ndarray:
        return np.array([e.values[key] for e in self.events if e.kind == kind])


def parse_event(message: str) -> Event | None:
    m = _EVENT.match(message)
    if not m:
        return None
    values: dict[str, float] = {}
    labels: dict[str, str] = {}
    for item in m.group(2).split():
        key, _, val = item.partition("=")
        try:
            values[key] = float(val)
        except ValueError:
            labels[key] = val
    return Event(m.group(1), values.pop("t"), values, labels)


SCENE_DEFAULTS: dict[str, float] = {"block1.theta0": 0.0}
"""Where the runners' defaults differ from the FMU's start values. A scene starts at rest;
the FMU's start value of block1.theta0 (0.1 rad) makes an importer's default experiment
show free rocking instead of a flat line."""


def with_scene_defaults(parameters: dict) -> dict:
    """`parameters` with :data:`SCENE_DEFAULTS` for the names they leave out."""
    return {**SCENE_DEFAULTS, **parameters}


def fmi2_callbacks(log: Callable[[int, str, str, str], None]) -> fmi2CallbackFunctions:
    """FMI 2.0 callbacks whose logger calls ``log(status, instance name, category, message)``
    (text, a printf format's "%%" back to "%"), with the C runtime's allocator. Keep them alive
    as long as the instance they are given to."""

    def logger(env, name, status, category, message):
        # the FMU writes a message as a printf format (FMI 2.0): a literal % is "%%"
        log(status, (name or b"").decode(errors="replace"), (category or b"").decode(),
            (message or b"").decode(errors="replace").replace("%%", "%"))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return callbacks


def set_value(slave: FMU2Slave, v, value) -> None:
    """Set variable ``v`` (an fmpy ModelVariable; an Enumeration as an Integer) of an FMI 2.0 instance."""
    if v.type == "Real":
        slave.setReal([v.valueReference], [float(value)])
    elif v.type in ("Integer", "Enumeration"):
        slave.setInteger([v.valueReference], [int(value)])
    elif v.type == "Boolean":
        slave.setBoolean([v.valueReference], [bool(value)])
    elif v.type == "String":
        slave.setString([v.valueReference], [str(value)])
    else:
        raise TypeError(f"unsupported variable type {v.type} of '{v.name}'")


def getter(slave: FMU2Slave, variables: list) -> Callable[[], list[float]]:
    """A function reading ``variables`` (fmpy ModelVariables) of an instance as floats, one
    FMI call per type."""
    groups: dict[str, list[tuple[int, int]]] = {"Real": [], "Integer": [], "Boolean": []}
    for i, v in enumerate(variables):
        groups["Integer" if v.type == "Enumeration" else v.type].append((i, v.valueReference))
    getters = {"Real": slave.getReal, "Integer": slave.getInteger, "Boolean": slave.getBoolean}

    def get() -> list[float]:
        row = [0.0] * len(variables)
        for typ, items in groups.items():
            if items:
                vals = getters[typ]([vr for _, vr in items])
                for (i, _), val in zip(items, vals):
                    row[i] = float(val)
        return row

    return get


class UnknownVariable(KeyError):
    """A variable the FMU does not have; str() is the one-line message (KeyError's would quote it)."""

    def __str__(self) -> str:
        return str(self.args[0])


class RockingFMU:
    """One extracted copy of the FMU; :meth:`run` simulates a scene with it.

    Extracting once and instantiating many times keeps sweeps cheap. Use as a
    context manager or call :meth:`close` to remove the extracted files.
    Parameters a scene leaves out take the FMU's start values, except those in
    :data:`SCENE_DEFAULTS` (a scene starts at rest).
    """

    def __init__(self, fmu_path: str | Path, unzipdir: str | None = None):
        """unzipdir: an extraction another RockingFMU made (shared, e.g. by sweep workers; not removed here)."""
        fmu_path = Path(fmu_path)
        if fmu_path.is_dir():
            raise FMUError(f"{fmu_path} is a folder, not an FMU file")
        if not fmu_path.is_file():
            raise FileNotFoundError(f"FMU not found: {fmu_path} (run: python -m fmu_build)")
        self.path = fmu_path
        try:
            self.model_description = read_model_description(str(fmu_path))
        except Exception as exc:  # fmpy raises what its zip and XML readers raise
            raise FMUError(f"{fmu_path} is not a usable FMU ({type(exc).__name__}: "
                           f"{str(exc).splitlines()[0] if str(exc) else 'unreadable'})") from None
        version = self.model_description.fmiVersion
        if version != "2.0":  # the fmu given is the wrong argument (runners.simulate(fmu=...), --fmu)
            from runners.errors import ArgumentError

            raise ArgumentError(f"fmu {fmu_path} is an FMI {version} FMU: the runners take the FMI 2.0 FMU "
                           f"(build/RockingBlock.fmu, python -m fmu_build); RockingBlock3.fmu is for FMI 3.0 importers")
        if self.model_description.coSimulation is None or "block1.theta" not in \
                {v.name for v in self.model_description.modelVariables}:
            raise FMUError(f"{fmu_path} is an FMU, but not a RockingBlock co-simulation FMU (python -m fmu_build)")
        self._owns_dir = unzipdir is None
        self.unzipdir = extract(str(fmu_path)) if unzipdir is None else unzipdir
        for v in self.model_description.modelVariables:
            if v.type == "Enumeration":  # read and set as an Integer in FMI 2.0 (fmi2GetInteger)
                v.type = "Integer"
        self.vars = {v.name: v for v in self.model_description.modelVariables}

    def close(self) -> None:
        if self._owns_dir:
            shutil.rmtree(self.unzipdir, ignore_errors=True)

    def __enter__(self) -> "RockingFMU":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def defaults(self) -> dict[str, float]:
        """The values of the Real and Integer parameters a scene leaves out: the FMU's start
        values with :data:`SCENE_DEFAULTS` over them."""
        start = {n: float(v.start) for n, v in self.vars.items() if v.start is not None and v.type in ("Real", "Integer")}
        return {**start, **SCENE_DEFAULTS}

    def variable(self, name: str):
        try:
            return self.vars[name]
        except KeyError:
            raise UnknownVariable(f"the FMU {self.path} has no variable '{name}': a build from older sources lacks "
                                  "the newer ones (make fmu builds build/RockingBlock.fmu)") from None

    def instantiate(self, log: Callable[[int, str, str], None], instance_name: str = "block",
                    logging_on: bool = True, interface: str = "CoSimulation",
                    ) -> tuple[FMU2Slave | FMU2Model, fmi2CallbackFunctions]:
        """Instantiate a slave (``interface="ModelExchange"``: a model) whose log lines go to
        ``log(status, category, message)``. Keep the returned callbacks alive as long as the instance.

        The FMU writes complete messages (no printf arguments), so its logger is called
        directly; fmpy's native formatting proxy is not used: it keeps one process-wide
        pointer to the last Python logger given to it, which dangles once that logger is
        collected and then crashes any other FMU that logs through fmpy's defaults."""

        callbacks = fmi2_callbacks(lambda status, _name, category, message: log(status, category, message))
        md = self.model_description
        cls, kind = (FMU2Model, md.modelExchange) if interface == "ModelExchange" else (FMU2Slave, md.coSimulation)
        with _LOAD_LOCK:
            instance = cls(guid=md.guid, unzipDirectory=self.unzipdir, modelIdentifier=kind.modelIdentifier,
                           instanceName=instance_name)
        instance.instantiate(callbacks=callbacks, loggingOn=logging_on)
        return instance, callbacks

    def validate(self, parameters: dict[str, float | int | bool | str]) -> None:
        """FMUError with the FMU's message unless it accepts `parameters` (it initialises with them)."""
        errors: list[str] = []
        slave, _callbacks = self.instantiate(lambda status, _c, msg: errors.append(msg) if status >= 3 else None,
                                             logging_on=False)
        try:
            slave.setupExperiment(startTime=0.0)
            self.set_parameters(slave, parameters)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            slave.terminate()
        except Exception as exc:
            raise FMUError(errors[-1] if errors else str(exc)) from None
        finally:
            slave.freeInstance()

    def initial_values(self, runs: Iterable[dict[str, float | int | bool | str]], output: str) -> list[float]:
        """``output`` (a Real) just after initialisation for each parameter set of ``runs``, on one instance
        reset between them (no fmpy instance to build per run). Raises :class:`FMUError` with the FMU's
        message if a set is refused."""
        errors: list[str] = []
        slave, _callbacks = self.instantiate(lambda status, _c, msg: errors.append(msg) if status >= 3 else None,
                                             logging_on=False)
        vr = [self.variable(output).valueReference]
        out = []
        try:
            for k, parameters in enumerate(runs):
                try:
                    if k:
                        slave.reset()
                    slave.setupExperiment(startTime=float(parameters.get("excitation.startTime", 0.0)))
                    self.set_parameters(slave, parameters)
                    slave.enterInitializationMode()
                    slave.exitInitializationMode()
                    out.append(float(slave.getReal(vr)[0]))
                except Exception as exc:
                    raise FMUError(errors[-1] if errors else str(exc)) from None
        finally:
            slave.freeInstance()
        return out

    def set_parameters(self, slave: FMU2Slave, parameters: dict[str, float | int | bool]) -> None:
        """Set a scene's parameters on an instance before initialisation, with
        :data:`SCENE_DEFAULTS` for those it leaves out."""
        for name, value in with_scene_defaults(parameters).items():
            set_value(slave, self.variable(name), value)

    def _getter(self, slave: FMU2Slave, names: Iterable[str]) -> Callable[[], list[float]]:
        return getter(slave, [self.variable(n) for n in names])

    @staticmethod
    def _step(slave: FMU2Slave, t: float, h: float) -> bool:
        """One fmi2DoStep; False if it ended the run (fmi2Discard with fmi2Terminated: an
        overturn with solver.stopAtOverturn), an exception for any other failure."""
        try:
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            return True
        except Exception:
            try:
                ended = bool(slave.getBooleanStatus(fmi2Terminated))
            except Exception:
                ended = False
            if ended:
                return False
            raise

    def run(
        self,
        parameters: dict[str, float | int | bool],
        stop_time: float,
        step: float,
        outputs: Iterable[str] = DEFAULT_OUTPUTS,
        start_time: float = 0.0,
        inputs: Callable[[float], tuple[float, float]] | None = None,
        events: bool = True,
    ) -> RunResult:
        """Simulate from ``start_time`` to ``stop_time`` with communication step ``step`` (s).

        ``inputs(t)`` may return (ground.ah, ground.av) in m/s^2, held over each step.
        Raises :class:`FMUError` with the FMU's message if any call fails.
        """
        from runners.engine.scene import MAX_SAMPLES, n_samples

        if not (np.isfinite(step) and step > 0 and np.isfinite(stop_time) and stop_time > start_time):
            raise ValueError(f"need a finite step > 0 and a finite stop_time > start_time (got {step}, "
                             f"{start_time}..{stop_time})")
        n = n_samples(stop_time, step, start_time)  # the last step shortened to end at stop_time
        if n > MAX_SAMPLES:
            raise ValueError(f"{start_time:g}..{stop_time:g} s at step {step:g} s is {n:.3g} output samples, more "
                             f"than the {MAX_SAMPLES:.0e} one run may hold: use a larger step")
        log_events: list[Event] = []
        errors: list[str] = []
        overflow: list[float] = []  # times of the events beyond MAX_EVENTS (only the first kept)

        def log(status: int, category: str, message: str) -> None:
            if status >= 3:
                errors.append(message)
            elif events and category == "logEvents":
                ev = parse_event(message)
                if ev:
                    if len(log_events) < MAX_EVENTS:  # (an exception cannot leave a C callback)
                        log_events.append(ev)
                    elif not overflow:
                        overflow.append(ev.t)

        t0 = time.perf_counter()
        slave, _callbacks = self.instantiate(log, logging_on=events)
        names = list(outputs)
        times = start_time + step * np.arange(n + 1)
        times[-1] = stop_time
        data = np.empty((n + 1, len(names)))
        try:
            try:
                slave.setupExperiment(startTime=start_time, stopTime=stop_time)
                self.set_parameters(slave, parameters)
                slave.enterInitializationMode()
                slave.exitInitializationMode()
                get = self._getter(slave, names)
                ah_av = (self.variable("ground.ah").valueReference, self.variable("ground.av").valueReference)
                data[0] = get()
                for i in range(n):
                    if inputs is not None:
                        slave.setReal(list(ah_av), list(inputs(times[i])))
                    if not self._step(slave, times[i], times[i + 1] - times[i]):
                        # solver.stopAtOverturn: the run ended at the overturn; the series ends there
                        times[i + 1] = slave.getRealStatus(fmi2LastSuccessfulTime)
                        data[i + 1] = get()
                        times, data = times[:i + 2], data[:i + 2]
                        break
                    data[i + 1] = get()
                    if overflow:
                        raise FMUError(f"more than {MAX_EVENTS:.0e} events (impacts, peaks...) by t = "
                                       f"{overflow[0]:g} s: shorten the stop time")
                slave.terminate()
            except Exception as exc:
                raise FMUError(errors[-1] if errors else str(exc)) from None
        finally:
            slave.freeInstance()
        wall = time.perf_counter() - t0
        return RunResult(times, {k: data[:, j] for j, k in enumerate(names)}, log_events, wall)
