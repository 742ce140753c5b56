"""FMI 2.0 behaviour of RockingBlock.fmu: validation, errors, state, instances, importers."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import PATIENCE, Slave, build_container
from runners.engine.fmu import FMUError

ROOT = Path(__file__).resolve().parents[1]

SCENE = {"excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0}
OUT = ["block1.theta", "block1.omega", "impacts", "atRest", "energy", "peaks"]


def test_validate_fmu_reports_nothing(fmu_path):
    assert validate_fmu(str(fmu_path)) == []


def test_only_fmi2_symbols_are_exported(fmu_path, tmp_path):
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp_path)
    so = tmp_path / "binaries" / "linux64" / "RockingBlock.so"
    out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    names = [line.split()[-1] for line in out.splitlines() if line.strip()]
    assert names and all(n.startswith("fmi2") for n in names), names


def test_fmu_ships_the_sources_and_capabilities(fmu):
    cs = fmu.model_description.coSimulation
    assert cs.canHandleVariableCommunicationStepSize and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    names = {v.name for v in fmu.model_description.modelVariables}
    for n in ["nBlocks", "block1.halfWidth", "restitution.law", "excitation.kind", "solver.relTol", "ground.ah",
              "ground.av", "block1.theta", "block1.alpha_dd", "impacts", "overturned", "atRest", "energy",
              "ground.ahTotal"]:
        assert n in names


INVALID = [
    ("block1.halfWidth", 0.0), ("block1.halfWidth", -0.1), ("block1.halfHeight", 0.0), ("block1.halfHeight", -1.0),
    ("block1.mass", 0.0), ("block1.mass", -3.0), ("restitution.eta", -0.01), ("restitution.eta", 1.01),
    ("restitution.k", -0.01), ("restitution.k", 1.5), ("restitution.correction", 0.0), ("g", 0.0),
    ("block1.theta0", 1.6), ("solver.relTol", 0.0), ("solver.absTol", -1.0), ("solver.restRatio", 0.0),
    ("restitution.law", 3), ("excitation.kind", 8), ("excitation.kind", -1), ("nBlocks", 9),
    ("excitation.kind", 4),
]
REAL_PARAMETERS = ["block1.halfWidth", "block1.halfHeight", "block1.mass", "block1.theta0", "block1.omega0", "g",
                   "restitution.k", "restitution.eta", "restitution.correction", "excitation.amplitude",
                   "excitation.frequency", "excitation.cycles", "excitation.startTime",
                   "excitation.verticalAmplitude", "excitation.displacement", "solver.relTol", "solver.absTol",
                   "solver.restRatio", "ground.ah", "ground.av", "excitation.scale", "excitation.gamma",
                   "excitation.phase"]


@pytest.mark.parametrize("name,value", INVALID + [(n, v) for n in REAL_PARAMETERS for v in (math.nan, math.inf)],
                         ids=lambda x: str(x))
def test_invalid_parameter_gives_error_and_message(fmu, name, value):
    with pytest.raises(FMUError) as exc:
        fmu.run({name: value}, 0.1, 0.1)
    assert name in str(exc.value)


def test_invalid_combinations_give_errors(fmu):
    with pytest.raises(FMUError, match="effective restitution"):
        fmu.run({"restitution.law": 2, "restitution.eta": 0.9, "restitution.correction": 1.2}, 0.1, 0.1)
    with pytest.raises(FMUError, match="too squat for Housner's law"):  # its coefficient is negative
        fmu.run({"block1.halfWidth": 1.0, "block1.halfHeight": 0.5}, 0.1, 0.1)
    with pytest.raises(FMUError, match="excitation.frequency"):
        fmu.run({"excitation.kind": 1, "excitation.frequency": 0.0}, 0.1, 0.1)
    with pytest.raises(FMUError, match="verticalAmplitude"):
        fmu.run({"excitation.kind": 1, "excitation.verticalAmplitude": 2000.0}, 0.1, 0.1)


def test_vertical_input_below_minus_g_is_reported_as_flight_not_a_crash(fmu):
    """ground.av = -20 m/s2 from the start: a rocking block's corner is pulled off the ground
    at once; the run goes on (on the model's corner) and says so."""
    r = fmu.run({"block1.theta0": 0.1}, 0.5, 0.01, inputs=lambda t: (0.0, -20.0), outputs=["lifts", "liftTime"])
    assert r.outputs["lifts"][-1] == 1 and r.outputs["liftTime"][-1] == 0.0


@pytest.fixture
def slave(fmu):
    s = Slave(fmu)
    yield s
    s.close()


def test_invalid_call_sequences_are_errors(slave):
    s = slave.s
    slave.expect_error(lambda: s.doStep(0.0, 0.1), "fmi2DoStep must not be called")
    slave.expect_error(lambda: s.getReal([slave.vr["block1.theta"]]), "fmi2GetReal must not be called")
    slave.expect_error(lambda: s.exitInitializationMode(), "fmi2ExitInitializationMode must not be called")
    slave.start()
    slave.expect_error(lambda: s.setReal([slave.vr["block1.mass"]], [2.0]), "cannot be set after initialization")
    slave.expect_error(lambda: s.setReal([slave.vr["block1.theta"]], [2.0]), "cannot be set")
    slave.expect_error(lambda: s.setReal([9999], [1.0]), "unknown Real value reference")
    slave.expect_error(lambda: s.getInteger([slave.vr["block1.theta"]]), "unknown Integer value reference")
    slave.expect_error(lambda: s.doStep(0.5, 0.1), "does not match the FMU time")
    slave.expect_error(lambda: s.doStep(0.0, -0.1), "invalid communication point")
    slave.expect_error(lambda: s.setupExperiment(startTime=0.0), "fmi2SetupExperiment must not be called")
    s.doStep(0.0, 0.1)  # still usable after rejected calls
    s.terminate()
    slave.expect_error(lambda: s.doStep(0.1, 0.1), "fmi2DoStep must not be called")


def test_no_step_may_end_after_a_defined_stop_time(slave):
    """FMI 2.0, fmi2SetupExperiment: with stopTimeDefined, fmi2DoStep past stopTime is fmi2Error."""
    s = slave.s
    s.setupExperiment(startTime=0.0, stopTime=1.0)
    slave.fmu.set_parameters(s, {"block1.theta0": 0.1})
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.doStep(0.0, 0.5)
    slave.expect_error(lambda: s.doStep(0.5, 0.6), "ends after the stop time 1")
    s.doStep(0.5, 0.5)  # to the stop time exactly: allowed
    slave.expect_error(lambda: s.doStep(1.0, 0.5), "ends after the stop time 1")
    s.doStep(1.0, 0.0)  # a zero step at the stop time is not after it
    clean = Slave(slave.fmu)  # the same run without the refused steps: they changed nothing
    clean.s.setupExperiment(startTime=0.0, stopTime=1.0)
    clean.fmu.set_parameters(clean.s, {"block1.theta0": 0.1})
    clean.s.enterInitializationMode()
    clean.s.exitInitializationMode()
    clean.s.doStep(0.0, 0.5)
    clean.s.doStep(0.5, 0.5)
    assert clean.outputs() == slave.outputs()
    clean.close()


def test_without_a_stop_time_steps_go_on(slave):
    slave.start({"block1.theta0": 0.1})  # fmi2SetupExperiment without a stop time
    for k in range(4):
        slave.s.doStep(0.5 * k, 0.5)


def test_fmu_state_round_trip_reproduces_the_continuation(slave):
    slave.start(SCENE)
    s = slave.s
    for i in range(10):
        s.doStep(0.1 * i, 0.1)
    state = s.getFMUstate()
    first = []
    for i in range(10, 30):
        s.doStep(0.1 * i, 0.1)
        first.append(slave.outputs())
    s.setFMUstate(state)
    again = [None] * 20
    for k, i in enumerate(range(10, 30)):
        s.doStep(0.1 * i, 0.1)
        again[k] = slave.outputs()
    assert again == first  # bit for bit
    # serialised state, restored into the same instance after more steps
    blob = s.serializeFMUstate(state)
    s.freeFMUstate(state)
    restored = s.deSerializeFMUstate(blob)
    s.setFMUstate(restored)
    s.doStep(1.0, 0.1)
    assert slave.outputs() == first[0]
    s.freeFMUstate(restored)


def test_deserialising_garbage_is_an_error(slave):
    slave.start()
    slave.expect_error(lambda: slave.s.deSerializeFMUstate(b"\0" * 16), "expected")


def test_reset_then_rerun_reproduces_the_first_run(slave):
    def run():
        slave.start(SCENE)
        rows = []
        for i in range(30):
            slave.s.doStep(0.1 * i, 0.1)
            rows.append(slave.outputs())
        return rows

    first = run()
    slave.s.reset()
    assert run() == first


def _run_scene(fmu, amplitude):
    r = fmu.run({**SCENE, "excitation.amplitude": amplitude}, 3.0, 1e-2, outputs=OUT, events=False)
    return np.column_stack([r.outputs[k] for k in OUT])


def test_instances_run_side_by_side_in_threads(fmu):
    amplitudes = [4.0, 4.5, 5.0, 5.5, 6.0, 7.0]
    sequential = [_run_scene(fmu, a) for a in amplitudes]
    results: dict[int, np.ndarray] = {}

    def work(i):
        results[i] = _run_scene(fmu, amplitudes[i])

    cwd = os.getcwd()
    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(amplitudes))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert os.getcwd() == cwd  # loading libraries in threads must not move the process
    for i, seq in enumerate(sequential):
        np.testing.assert_array_equal(results[i], seq)


def test_fmpy_simulate_fmu_runs_it(fmu_path, fmu):
    params = {"block1.theta0": 0.2, **SCENE}
    r = simulate_fmu(str(fmu_path), start_values=params, stop_time=3.0, output_interval=1e-2, output=["block1.theta"])
    ours = fmu.run(params, 3.0, 1e-2, outputs=["block1.theta"], events=False)
    np.testing.assert_allclose(r["block1.theta"], ours.outputs["block1.theta"], rtol=0, atol=1e-12)


def test_container_fmu_gives_the_same_trajectory(fmu_path, fmu, tmp_path):
    """fmucontainer builds a container FMU whose own C runtime imports ours."""
    container = build_container(fmu_path, tmp_path, 0.004, "RockingContainer.fmu")
    params = {"block1.theta0": 0.15, "excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0}
    r = simulate_fmu(str(container), start_values={f"rockingblock.{k}": v for k, v in params.items()},
                     stop_time=3.0, output_interval=0.02, output=["block1.theta", "impacts"])
    ours = fmu.run(params, 3.0, 0.02, outputs=["block1.theta", "impacts"], events=False)
    assert ours.outputs["impacts"][-1] > 5
    np.testing.assert_allclose(r["time"], ours.time, atol=1e-9)
    np.testing.assert_allclose(r["block1.theta"], ours.outputs["block1.theta"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r["impacts"], ours.outputs["impacts"])


LOGGER_PROBE = """
import gc, sys
from pathlib import Path
from fmpy import simulate_fmu
from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from conftest import build_container
from runners.analysis import work_precision
from runners.engine.fmu import RockingFMU

fmu_path, folder = Path(sys.argv[1]), Path(sys.argv[2])
with RockingFMU(fmu_path) as fmu:
    fmu.run({"block1.theta0": 0.15}, 0.5, 0.1)  # Co-Simulation with our logger
    points = work_precision.me_points(fmu, work_precision.free_rocking_case(), 1, quick=True)
gc.collect()
calls = []
probe = fmi2CallbackLoggerTYPE(lambda *args: calls.append(args))  # takes a freed callback's place
container = build_container(fmu_path, folder, 0.01)
simulate_fmu(str(container), stop_time=0.1)  # the container logs through fmpy's default logger
print(len(calls), min(p.error for p in points))
"""


def test_our_loggers_leave_fmpys_default_logger_alone(fmu_path, tmp_path):
    """fmpy's native formatting proxy keeps one process-wide pointer to the last Python logger
    handed to it. Our instances (Co-Simulation, and Model Exchange as the work-precision chart
    runs it) must not hand it theirs: once collected, that pointer dangles, and the next FMU
    that logs through fmpy's defaults (the container does, while it instantiates) called freed
    memory: the full suite's intermittent segfault. A fresh callback made after ours are
    collected takes their place, so a dangling pointer would show as calls to it."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), str(ROOT)])}
    proc = subprocess.run([sys.executable, "-c", LOGGER_PROBE, str(fmu_path), str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=PATIENCE)
    assert proc.returncode == 0, proc.stderr[-2000:]
    calls, best_error = proc.stdout.split()[-2:]
    assert int(calls) == 0, "the container's messages reached a callback fmpy's default logger does not own"
    assert float(best_error) < 1e-6  # the Model Exchange runs did run


def test_sources_rebuild_with_fmpy_build_platform_binary(fmu_path, fmu, tmp_path):
    from fmpy.build import build_platform_binary

    unzipdir = tmp_path / "fmu"
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(unzipdir)
    shutil.rmtree(unzipdir / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzipdir, build_dir=tmp_path / "cmake")
    rebuilt = tmp_path / "rebuilt.fmu"
    with zipfile.ZipFile(rebuilt, "w") as zf:
        for p in sorted(unzipdir.rglob("*")):
            if p.is_file():
                zf.write(p, p.relative_to(unzipdir).as_posix())
    params = {"block1.theta0": 0.2}
    r = simulate_fmu(str(rebuilt), start_values=params, stop_time=2.0, output_interval=0.01, output=["block1.theta"])
    ours = fmu.run(params, 2.0, 0.01, outputs=["block1.theta"], events=False)
    np.testing.assert_allclose(r["block1.theta"], ours.outputs["block1.theta"], rtol=0, atol=1e-12)
