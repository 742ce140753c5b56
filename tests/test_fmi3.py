"""RockingBlock3.fmu, the FMI 3.0 Co-Simulation edition, against the FMI 2.0
RockingBlock.fmu built from the same C core: early return at events, event
mode, intermediate update, solver.stopAtOverturn, bad calls, and fmpy's own
FMI 3.0 master. Both FMUs are real compiled binaries driven through fmpy."""

from __future__ import annotations

import ctypes
import shutil
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64, fmi3ValueReference

from fmu_build.build3 import build_fmu3
from runners.engine.fmu import parse_event, with_scene_defaults

FREE = {"block1.theta0": 0.1}
PULSE = {"excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0}  # uplift, rocking, rest
OVERTURN = {"excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 1.0}  # falls after an impact
# two stacked blocks leaning opposite ways on a shaking table: ground and interface impacts, pattern changes
STACK = {"nBlocks": 2, "block1.theta0": 0.05, "block2.theta0": -0.08, "excitation.kind": 3,
         "excitation.frequency": 2.0, "excitation.displacement": 0.04, "excitation.cycles": 0}
# a statue on a plinth that slides on the floor (the rocking-sliding stack): slides, slide-rocks, impacts
SLIDING_STACK = {"nBlocks": 2, "contact.model": 1, "block1.halfWidth": 0.3, "block1.halfHeight": 0.5,
                 "block1.mass": 450.0, "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 690.0,
                 "block1.theta0": 0.0, "contact.muGround": 0.5, "contact.muInterface": 0.5, "excitation.kind": 1,
                 "excitation.amplitude": 6.0, "excitation.frequency": 2.0}
STATE1 = ["block1.theta", "block1.omega"]
STATE2 = STATE1 + ["block2.theta", "block2.omega"]
SLIPS = STATE2 + ["block1.slip", "block2.slip", "block1.slipRate", "groundWork", "impactLoss"]
# the events that end an early-returning step (the FMI 2.0 log's kinds); peaks and rest lines are not
# events of their own (a rest is logged with the impact it comes with)
STOPPING = {"impact", "uplift", "overturn", "settle", "open"}
OK, DISCARD, ERROR = 0, 2, 3


@dataclass
class FMU3:
    path: Path
    unzipdir: str
    md: object
    vars: dict = field(default_factory=dict)


@pytest.fixture(scope="session")
def fmu3(fmu3_path):
    md = read_model_description(str(fmu3_path))
    unzipdir = extract(str(fmu3_path))
    yield FMU3(fmu3_path, unzipdir, md, {v.name: v for v in md.modelVariables})
    shutil.rmtree(unzipdir, ignore_errors=True)


class Instance:
    """One FMU3Slave with its log; raw(name, ...) calls an FMI function and returns its status."""

    def __init__(self, f: FMU3, event_mode=False, early=False, callback=None, required=None, token=None):
        self.f, self.log = f, []

        def log(env, status, category, message):
            self.log.append((status, category.decode(), message.decode()))

        self.slave = FMU3Slave(guid=token or f.md.guid, unzipDirectory=f.unzipdir,
                               modelIdentifier=f.md.coSimulation.modelIdentifier, instanceName="block")
        self.slave.instantiate(loggingOn=True, eventModeUsed=event_mode, earlyReturnAllowed=early, logMessage=log,
                               intermediateUpdate=callback, requiredIntermediateVariables=required)

    def raw(self, name, *args):
        return getattr(self.slave.dll, name)(self.slave.component, *args)

    def vr(self, name):
        return self.f.vars[name].valueReference

    def set(self, params):
        for name, value in params.items():
            v = self.f.vars[name]
            setter = {"Float64": self.slave.setFloat64, "Int32": self.slave.setInt32, "Boolean": self.slave.setBoolean,
                      "String": self.slave.setString, "Enumeration": self.slave.setInt64}[v.type]
            setter([v.valueReference], [value])

    def get(self, names):
        out = []
        for n in names:
            v = self.f.vars[n]
            getter = {"Float64": self.slave.getFloat64, "Int32": self.slave.getInt32,
                      "Boolean": self.slave.getBoolean, "Enumeration": self.slave.getInt64}[v.type]
            out.append(float(getter([v.valueReference])[0]))
        return out

    def do_step(self, t, h):
        """fmi3DoStep without fmpy's exception on fmi3Discard: (status, event, terminate, early, last)."""
        ev, term, early, last = fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()
        status = self.raw("fmi3DoStep", t, h, fmi3Boolean(True), ctypes.byref(ev), ctypes.byref(term),
                          ctypes.byref(early), ctypes.byref(last))
        return status, ev.value, term.value, early.value, last.value

    def errors(self):
        return [m for s, _, m in self.log if s >= ERROR]

    def free(self):
        self.slave.freeInstance()


def grid(stop, step):
    n = int(round(stop / step))
    t = step * np.arange(n + 1)
    t[-1] = stop
    return t


@dataclass
class Run3:
    rows: np.ndarray  # the outputs at the grid points
    returns: list  # the times of the early returns
    ended: float | None  # lastSuccessfulTime of a step with terminateSimulation
    events: list  # the logEvents lines, parsed


def run3(f, params, stop, step, names=STATE1, early=False, event_mode=False) -> Run3:
    """A master over the grid of RockingFMU.run (the FMI 2.0 runner), returning early when allowed."""
    x = Instance(f, event_mode=event_mode, early=early)
    try:
        x.set(with_scene_defaults(params))  # as RockingFMU.run sets them
        x.slave.enterInitializationMode(startTime=0.0, stopTime=stop)
        x.slave.exitInitializationMode()
        if event_mode:
            assert x.slave.updateDiscreteStates()[0] is False
            x.slave.enterStepMode()
        times = grid(stop, step)
        rows, returns, k, t, ended = [x.get(names)], [], 0, 0.0, None
        while k + 1 < len(times):
            status, ev, term, er, last = x.do_step(t, times[k + 1] - t)
            assert status == OK, x.errors()
            assert er == (last < times[k + 1])
            if er:
                assert early
                returns.append(last)
                t = last
            else:
                k, t = k + 1, times[k + 1]
                rows.append(x.get(names))
            if term:
                ended = last
                break
            if event_mode and ev:
                x.slave.enterEventMode()
                need, term_, *_ = x.slave.updateDiscreteStates()
                assert not need and not term_
                x.slave.enterStepMode()
        x.slave.terminate()
        events = [parse_event(m) for _, c, m in x.log if c == "logEvents"]
        return Run3(np.array(rows), returns, ended, [e for e in events if e])
    except FMICallException as exc:
        raise AssertionError(f"{exc}: {x.errors()}") from None
    finally:
        x.free()


def stopping_times(run2):
    return sorted({e.t for e in run2.events if e.kind in STOPPING})


# ------------------------------------------------------------------ early return

@pytest.mark.parametrize("params", [FREE, PULSE], ids=["free", "pulse"])
@pytest.mark.parametrize("event_mode", [False, True], ids=["step-mode", "event-mode"])
def test_early_return_at_every_event_of_the_fmi2_run(fmu, fmu3, params, event_mode):
    stop = 4.0
    r2 = fmu.run(params, stop, 1.0, outputs=STATE1)
    r3 = run3(fmu3, params, stop, 1.0, early=True, event_mode=event_mode)
    returns = r3.returns
    expected = [t for t in stopping_times(r2) if t not in (1.0, 2.0, 3.0, 4.0)]
    impacts = r2.event_times("impact")
    assert len(impacts) > 5 and set(impacts) <= set(expected)
    if params is PULSE:
        assert len(r2.event_times("uplift")) > 0
    assert len(returns) == len(expected)
    diff = np.max(np.abs(np.array(returns) - np.array(expected)))
    print(f"\nearly-return times vs FMI 2.0 events ({len(returns)}): max |dt| = {diff:.3g} s")
    assert diff <= 1e-12
    # and the FMU logs the same events (impacts with their velocities, peaks, rest...) as FMI 2.0's
    assert [e.as_dict() for e in r3.events] == [e.as_dict() for e in r2.events]


@pytest.mark.parametrize("scene,names", [(FREE, STATE1), (PULSE, STATE1), (STACK, STATE2),
                                         ({**PULSE, "solver.method": 1}, STATE1), (SLIDING_STACK, SLIPS)],
                         ids=["free", "pulse", "two-blocks", "pulse-taylor", "sliding-stack"])
@pytest.mark.parametrize("mode", [dict(), dict(early=True), dict(early=True, event_mode=True)],
                         ids=["plain", "early", "early+events"])
def test_trajectories_equal_the_fmi2_fmu(fmu, fmu3, scene, names, mode):
    stop, step = 3.0, 0.01
    r2 = fmu.run(scene, stop, step, outputs=names + ["impacts"])
    r3 = run3(fmu3, scene, stop, step, names=names + ["impacts"], **mode)
    rows, returns = r3.rows, r3.returns
    assert r2.outputs["impacts"][-1] > 3
    assert (len(returns) > 0) == bool(mode)
    ref = np.column_stack([r2.outputs[n] for n in names + ["impacts"]])
    assert rows.shape == ref.shape
    diff = np.max(np.abs(rows - ref))
    print(f"\nmax |FMI 3.0 - FMI 2.0| over {rows.shape[0]} samples of {names}: {diff:.3g}")
    assert diff <= 1e-12


def test_a_two_block_stack_returns_at_each_pattern_change(fmu, fmu3):
    stop = 3.0
    r2 = fmu.run(STACK, stop, 1.0, outputs=STATE2)
    returns = run3(fmu3, STACK, stop, 1.0, names=STATE2, early=True).returns
    expected = stopping_times(r2)
    assert len(expected) > 3
    assert np.max(np.abs(np.array(returns) - np.array(expected))) <= 1e-12


# ------------------------------------------------------------- stop at overturn

def test_stop_at_overturn_terminates_at_the_overturn_time(fmu, fmu3):
    r2 = fmu.run(OVERTURN, 5.0, 0.5, outputs=["overturned", "overturnTime"])
    t_over = r2.outputs["overturnTime"][-1]
    assert r2.outputs["overturned"][-1] == 1.0 and 0 < t_over < 5
    params = {**OVERTURN, "solver.stopAtOverturn": True}

    # early return allowed: fmi3OK, terminateSimulation and earlyReturn at the overturn
    r3 = run3(fmu3, params, 5.0, 0.5, early=True, event_mode=True)
    assert r3.ended == t_over == r3.returns[-1]

    # not allowed: the step computed only up to the overturn (fmi3Discard)
    x = Instance(fmu3)
    try:
        x.set(with_scene_defaults(params))
        x.slave.enterInitializationMode(startTime=0.0, stopTime=5.0)
        x.slave.exitInitializationMode()
        status, ev, term, early, last = x.do_step(0.0, 5.0)
        assert (status, ev, term, early, last) == (DISCARD, False, True, False, t_over)
        assert x.get(["overturned", "overturnTime"]) == [1.0, t_over]
        assert any("overturn" in m for s, _, m in x.log if s == DISCARD)
        status, *_ = x.do_step(last, 1.0)  # the run has ended
        assert status == ERROR and "fmi3Terminate" in x.errors()[-1]
        assert x.slave.terminate() == OK
    finally:
        x.free()


# ---------------------------------------------------------- intermediate update

def _callback_run(fmu3, stop, early_allowed, request=None):
    """One fmi3DoStep over [0, stop] (and more until stop) with an intermediateUpdate callback that
    records (time, impacts) and asks for an early return as request(time, index) says
    (None: no; a number: the time to return at)."""
    seen, nested, x = [], [], None

    def callback(env, t, set_requested, get_allowed, step_finished, can_return_early, requested, when):
        assert get_allowed and step_finished and not set_requested and can_return_early == early_allowed
        seen.append((t, x.get(["impacts"])[0]))
        # no step, state or setter may be called from here
        nested.append(x.do_step(t, 0.1)[0])
        want = request(t, len(seen) - 1) if request else None
        requested[0] = want is not None
        when[0] = want if want is not None else t

    x = Instance(fmu3, early=early_allowed, callback=callback,
                 required=[fmu3.vars[n].valueReference for n in ("impacts", "block1.theta")])
    try:
        x.set(FREE)
        x.slave.enterInitializationMode(startTime=0.0, stopTime=stop)
        x.slave.exitInitializationMode()
        t, steps = 0.0, []
        while t < stop:
            status, ev, term, early, last = x.do_step(t, stop - t)
            assert status == OK, x.errors()
            steps.append((early, last))
            t = last
        return seen, steps, nested, x.errors()
    finally:
        x.free()


def test_intermediate_update_sees_every_event_and_can_end_the_step(fmu, fmu3):
    stop = 3.0
    impacts = fmu.run(FREE, stop, stop, outputs=STATE1).event_times("impact")
    assert len(impacts) > 10

    # no request: one step, the callback sees each impact, with the outputs at that time
    seen, steps, nested, errors = _callback_run(fmu3, stop, True)
    assert steps == [(False, stop)]
    assert np.max(np.abs(np.array([t for t, _ in seen]) - impacts)) <= 1e-12
    assert [n for _, n in seen] == list(range(1, len(impacts) + 1))
    assert set(nested) == {ERROR} and "intermediateUpdate callback" in errors[0]

    # a request at the 4th impact ends the step there; the next step goes on from it
    seen2, steps2, _, _ = _callback_run(fmu3, stop, True, lambda t, i: t if i == 3 else None)
    assert steps2 == [(True, seen[3][0]), (False, stop)]
    assert [t for t, _ in seen2] == [t for t, _ in seen]

    # a request for a time between the 4th and the 5th impact ends the step at that time
    mid = 0.5 * (seen[3][0] + seen[4][0])
    _, steps3, _, _ = _callback_run(fmu3, stop, True, lambda t, i: mid if i == 3 else None)
    assert steps3 == [(True, mid), (False, stop)]

    # early return not allowed: requests are ignored
    seen4, steps4, _, _ = _callback_run(fmu3, stop, False, lambda t, i: t)
    assert steps4 == [(False, stop)] and [t for t, _ in seen4] == [t for t, _ in seen]


# ------------------------------------------------------------------ resources

def test_a_relative_record_file_is_read_from_the_resources_path(fmu3_path, tmp_path):
    """FMI 3.0 gives the resources folder as a path (not a URI): a '%' in it is a plain character."""
    folder = tmp_path / "a %41 folder"
    extract(str(fmu3_path), unzipdir=str(folder))
    (folder / "resources" / "records").mkdir(parents=True)
    record = folder / "resources" / "records" / "pulse.txt"
    t = np.arange(0, 1.0001, 0.01)
    np.savetxt(record, np.column_stack([t, 5.0 * np.sin(2 * np.pi * 3 * t)]), fmt="%.17g", header="time (s), ah (m/s2)")
    md = read_model_description(str(fmu3_path))
    f = FMU3(fmu3_path, str(folder), md, {v.name: v for v in md.modelVariables})
    names = STATE1 + ["impacts"]
    inside = run3(f, {"excitation.kind": 4, "excitation.file": f"records/{record.name}"}, 2.0, 0.01, names)
    outside = run3(f, {"excitation.kind": 4, "excitation.file": str(record)}, 2.0, 0.01, names)
    assert inside.rows[-1, 2] > 3
    np.testing.assert_array_equal(inside.rows, outside.rows)


# ------------------------------------------------------------- FMU state, event mode

def test_a_state_saved_in_event_mode_restores(fmu3):
    x = Instance(fmu3, event_mode=True, early=True)
    try:
        x.set(PULSE)
        x.slave.enterInitializationMode(startTime=0.0)
        x.slave.exitInitializationMode()
        x.slave.enterStepMode()
        t = 0.0
        for _ in range(3):  # to the third event
            status, ev, term, early, t = x.do_step(t, 10.0 - t)
            assert status == OK and ev and early
            x.slave.enterEventMode()
            x.slave.updateDiscreteStates()
            if _ < 2:
                x.slave.enterStepMode()
        state = x.slave.getFMUState()
        again = x.slave.deserializeFMUState(x.slave.serializeFMUState(state))
        x.slave.enterStepMode()
        first = x.do_step(t, 1.0), x.get(STATE1)
        for s in (state, again):
            x.slave.setFMUState(s)
            assert x.do_step(t, 1.0)[0] == ERROR  # restored into event mode: no step yet
            x.slave.enterStepMode()
            assert (x.do_step(t, 1.0), x.get(STATE1)) == first
        x.slave.freeFMUState(state)
        x.slave.freeFMUState(again)
    finally:
        x.free()


# --------------------------------------------------------------------- bad calls

def test_bad_calls_return_fmi3Error_with_a_message(fmu3):
    # a foreign instantiationToken: no instance, and a message saying why
    msgs = []
    bad = FMU3Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=fmu3.unzipdir,
                    modelIdentifier=fmu3.md.coSimulation.modelIdentifier, instanceName="bad")
    with pytest.raises(Exception, match="Failed to instantiate"):
        bad.instantiate(logMessage=lambda env, s, c, m: msgs.append(m.decode()))
    assert len(msgs) == 1 and "instantiationToken" in msgs[0]
    bad.freeLibrary()

    x = Instance(fmu3)
    try:
        theta, vrs = x.vr("block1.theta"), (fmi3ValueReference * 2)(x.vr("block1.theta"), x.vr("block1.omega"))
        values = (fmi3Float64 * 2)()
        calls = [
            ("fmi3DoStep before initialization", lambda: x.do_step(0.0, 0.1)[0], "must not be called"),
            ("fmi3EnterStepMode outside event mode", lambda: x.raw("fmi3EnterStepMode"), "must not be called"),
            ("a Model Exchange function", lambda: x.raw("fmi3EnterContinuousTimeMode"), "Model Exchange"),
        ]
        for what, call, text in calls:
            n = len(x.errors())
            assert call() == ERROR, what
            assert len(x.errors()) == n + 1 and text in x.errors()[-1], what
        x.slave.enterInitializationMode(startTime=0.0, stopTime=1.0)
        x.slave.exitInitializationMode()
        calls = [
            ("nValues != nvr", lambda: x.raw("fmi3GetFloat64", vrs, 2, values, 1), "nValues = 1"),
            ("NULL arrays", lambda: x.raw("fmi3GetFloat64", None, 2, None, 2), "NULL array"),
            ("unknown value reference", lambda: x.raw("fmi3GetFloat64", (fmi3ValueReference * 1)(999), 1, values, 1),
             "unknown Real value reference 999"),
            ("a Float64 value reference as Int32", lambda: x.raw("fmi3GetInt32", (fmi3ValueReference * 1)(theta), 1,
                                                                 (ctypes.c_int32 * 1)(), 1), "unknown Integer"),
            ("a type without variables", lambda: x.raw("fmi3GetUInt8", (fmi3ValueReference * 1)(theta), 1,
                                                       (ctypes.c_uint8 * 1)(), 1), "no UInt8 variables"),
            ("setting a parameter while stepping", lambda: x.raw(
                "fmi3SetFloat64", (fmi3ValueReference * 1)(x.vr("block1.mass")), 1, (fmi3Float64 * 1)(2.0), 1),
             "cannot be set after initialization"),
            ("setting time", lambda: x.raw("fmi3SetFloat64", (fmi3ValueReference * 1)(0), 1, (fmi3Float64 * 1)(2.0),
                                           1), "independent variable"),
            ("event mode without eventModeUsed", lambda: x.raw("fmi3EnterEventMode"), "eventModeUsed"),
            ("a zero step", lambda: x.do_step(0.0, 0.0)[0], "must be > 0"),
            ("a step past the stop time", lambda: x.do_step(0.0, 2.0)[0], "after the stop time"),
            ("a wrong communication point", lambda: x.do_step(0.5, 0.1)[0], "does not match"),
        ]
        for what, call, text in calls:
            n = len(x.errors())
            assert call() == ERROR, what
            assert len(x.errors()) == n + 1 and text in x.errors()[-1], what
        # none of them changed the instance: it steps on as if they had not been made
        assert x.slave.getFloat64([0]) == [0.0]
        assert x.do_step(0.0, 1.0)[:4] == (OK, False, False, False)
        assert all("\n" not in m and "%%" not in m for m in x.errors())
    finally:
        x.free()


# ------------------------------------------------------------------------- fmpy

def test_fmpy_simulate_fmu_with_early_return_and_event_mode_gives_the_fmi2_results(fmu_path, fmu3_path):
    kw = dict(stop_time=3.0, output_interval=0.05, start_values=PULSE, output=STATE1 + ["impacts"])
    r2 = simulate_fmu(str(fmu_path), **kw)
    r3 = simulate_fmu(str(fmu3_path), early_return_allowed=True, use_event_mode=True, **kw)
    on_grid = np.isclose(r3["time"] / 0.05, np.round(r3["time"] / 0.05), rtol=0, atol=1e-9)
    # the last row at each output time (fmpy records a time again after event mode)
    last = np.r_[r3["time"][on_grid][1:] != r3["time"][on_grid][:-1], True]
    grid3 = r3[on_grid][last]
    assert len(grid3) == len(r2) and len(r3) > len(r2)
    for n in STATE1 + ["impacts"]:
        assert np.max(np.abs(grid3[n] - r2[n])) <= 1e-12, n
    # the rows between output times are the events, with the outputs there
    events = sorted(set(r3["time"][~on_grid]))
    assert len(events) >= r2["impacts"][-1]

    # solver.stopAtOverturn: fmpy's master stops at the overturn
    r2 = simulate_fmu(str(fmu_path), stop_time=5.0, output_interval=0.5, start_values=OVERTURN,
                      output=["overturnTime"])
    r3 = simulate_fmu(str(fmu3_path), stop_time=5.0, output_interval=0.5, early_return_allowed=True,
                      use_event_mode=True, start_values={**OVERTURN, "solver.stopAtOverturn": True},
                      output=["overturnTime"])
    assert r3["time"][-1] == r2["overturnTime"][-1] == r3["overturnTime"][-1] < 5.0


# ------------------------------------------------------------------------ build

def test_the_fmi3_build_is_valid_and_rebuilt_only_when_its_sources_change(fmu3_path, tmp_path):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu3_path)) == []
    md = read_model_description(str(fmu3_path))
    cs = md.coSimulation
    assert (md.fmiVersion, cs.modelIdentifier) == ("3.0", "RockingBlock3")
    assert cs.hasEventMode and cs.mightReturnEarlyFromDoStep and cs.canReturnEarlyAfterIntermediateUpdate
    assert cs.providesIntermediateUpdate and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate  # (fmpy's spelling)
    assert cs.canHandleVariableCommunicationStepSize and cs.fixedInternalStepSize is None
    assert md.buildConfigurations[0].sourceFileSets[0].sourceFiles[0] == "fmi3.c"

    out = build_fmu3(tmp_path / "RockingBlock3.fmu")
    names = set(zipfile.ZipFile(out).namelist())
    assert {"modelDescription.xml", "binaries/x86_64-linux/RockingBlock3.so", "sources/buildDescription.xml",
            "sources/fmi3.c", "sources/instance.c", "sources/config.h", "sources/variables.def"} <= names
    assert "sources/fmi2.c" not in names
    # the Windows binary whenever the FMI 2.0 build makes one (mingw-w64 installed)
    from fmu_build.build import win64_compiler
    assert ("binaries/x86_64-windows/RockingBlock3.dll" in names) == (win64_compiler() is not None)
    stamp = out.stat().st_mtime_ns
    assert build_fmu3(out) == out and out.stat().st_mtime_ns == stamp  # unchanged sources: nothing to do


def test_the_runners_refuse_the_fmi3_fmu_in_one_line(fmu3_path, tmp_path):
    """`runners simulate ... --fmu RockingBlock3.fmu` failed with "unexpected KeyError:
    'nBlocks'", and runners.simulate(fmu=...) raised the KeyError: both now say that the runners
    take the FMI 2.0 FMU, naming the file given; nothing is stored."""
    import runners
    from conftest import run_cli

    db = f"sqlite:///{tmp_path / 'r.db'}"
    p = run_cli("simulate", "examples/sine_pulse.toml", "--fmu", str(fmu3_path), db=db, fmu_path=fmu3_path)
    assert p.returncode == 2 and p.stdout == "", p.stderr
    assert p.stderr.count("\n") == 1 and "FMI 3.0" in p.stderr and "FMI 2.0 FMU" in p.stderr, p.stderr
    assert str(fmu3_path) in p.stderr
    with pytest.raises(runners.RockingError, match="the runners take the FMI 2.0 FMU") as err:
        runners.simulate(Path(__file__).parent.parent / "examples" / "sine_pulse.toml", fmu=fmu3_path, db=db)
    assert "\n" not in str(err.value)
    if (tmp_path / "r.db").exists():
        import sqlite3
        with sqlite3.connect(tmp_path / "r.db") as con:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            assert "runs" not in tables or con.execute("SELECT count(*) FROM runs").fetchone()[0] == 0


# ------------------------------------------------------------------ Enumerations

def test_the_enumerations_are_enumeration_types_with_the_items_of_variables_def(fmu3):
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_enumerations

    enumerations = read_enumerations(C_DIR / "variables.def")
    types = {t.name: t for t in fmu3.md.typeDefinitions}
    for name, enum in enumerations.items():
        v = fmu3.vars[name]
        assert v.type == "Enumeration" and v.declaredType.name == enum.name, name
        assert types[enum.name].type == "Enumeration"
        assert [(int(i.value), i.name, i.description) for i in types[enum.name].items] == list(enum.items)
    plain = {n for n, v in fmu3.vars.items() if v.type == "Int32"}
    assert {"nBlocks", "impacts", "excitation.kindCode"} <= plain and not plain & set(enumerations)


def test_enumerations_are_read_and_set_with_int64_alone(fmu3, fmu_path):
    """FMI 3.0 gives an Enumeration the C type fmi3Int64: fmi3GetInt64/fmi3SetInt64 serve the
    Enumerations (a pulse chosen so runs as the FMI 2.0 FMU's), fmi3GetInt32/fmi3SetInt32 refuse
    them with fmi3Error and say why, and the Int64 functions refuse the Int32 variables."""
    x = Instance(fmu3)
    try:
        kind, n_blocks = x.vr("excitation.kind"), x.vr("nBlocks")
        one = (fmi3ValueReference * 1)
        assert x.raw("fmi3SetInt32", one(kind), 1, (ctypes.c_int32 * 1)(1), 1) == ERROR
        assert "is an Enumeration" in x.errors()[-1] and "fmi3SetInt64" in x.errors()[-1]
        assert x.raw("fmi3SetInt64", one(n_blocks), 1, (ctypes.c_int64 * 1)(1), 1) == ERROR
        assert "unknown Int64 value reference" in x.errors()[-1]
        assert x.raw("fmi3SetInt64", one(kind), 1, (ctypes.c_int64 * 1)(2 ** 40), 1) == ERROR
        x.set({**PULSE, "block1.theta0": 0.0})  # excitation.kind through fmi3SetInt64
        x.slave.enterInitializationMode(startTime=0.0, stopTime=3.0)
        x.slave.exitInitializationMode()
        assert x.slave.getInt64([kind, x.vr("pattern")]) == [1, 1]
        assert x.raw("fmi3GetInt32", one(kind), 1, (ctypes.c_int32 * 1)(), 1) == ERROR
        assert "is an Enumeration" in x.errors()[-1]
        assert x.do_step(0.0, 3.0)[0] == OK
        theta, impacts = x.get(["block1.theta", "impacts"])
    finally:
        x.free()
    r2 = simulate_fmu(str(fmu_path), stop_time=3.0, output_interval=3.0,
                      start_values={**PULSE, "block1.theta0": 0.0}, output=["block1.theta", "impacts"])
    assert impacts == r2["impacts"][-1] > 0
    assert theta == r2["block1.theta"][-1]
