"""FMI 2.0 Model Exchange: the importer's solver integrates the block (fmpy's CVode and
Euler here). Compared with exact free rocking (quadrature, model.reference) and with the
Co-Simulation interface of the same FMU."""

from __future__ import annotations

import math
from ctypes import POINTER, c_double

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi2 import FMU2Model

from model.reference import Block, free_rocking
from runners.engine.fmu import with_scene_defaults

OUT = ["block1.theta", "block1.omega", "impacts", "lastImpactTime", "peaks", "lastPeakTime", "lastPeakTheta",
       "overturned", "overturnTime", "atRest", "restTime"]


def _me(fmu_path, start, stop=3.0, solver="CVode", rtol=1e-10, step=None, interval=1e-3):
    return simulate_fmu(str(fmu_path), fmi_type="ModelExchange", solver=solver, relative_tolerance=rtol,
                        step_size=step, start_values=with_scene_defaults(start), stop_time=stop, output_interval=interval, output=OUT,
                        record_events=False)


def _cs(fmu_path, start, stop=3.0, interval=1e-3):
    return simulate_fmu(str(fmu_path), fmi_type="CoSimulation", start_values=with_scene_defaults(start), stop_time=stop,
                        output_interval=interval, output=OUT)


def _changes(r, name):
    """The values a discrete 'last time' output took, in order (its events)."""
    v = r[name]
    return v[np.r_[True, v[1:] != v[:-1]] & (v > 0)]


def test_cvode_matches_exact_free_rocking(fmu_path):
    """CVode at rtol 1e-10: impact times and peaks of free rocking to 1e-7 (s, rad)."""
    theta0, n = 0.1, 12
    r = _me(fmu_path, {"block1.theta0": theta0})
    block = Block(0.1, 0.3)  # the FMU's default block
    exact = free_rocking(block, theta0, 1.0 - 1.5 * math.sin(block.alpha) ** 2, n)
    impacts = _changes(r, "lastImpactTime")[:n]
    peak_times = _changes(r, "lastPeakTime")[:n]
    peaks = np.array([r["lastPeakTheta"][np.argmax(r["lastPeakTime"] == t)] for t in peak_times])
    assert len(impacts) == n and len(peak_times) == n
    assert np.max(np.abs(impacts - exact.impact_times)) < 1e-7
    assert np.max(np.abs(peak_times - exact.peak_times)) < 1e-7
    assert np.max(np.abs(peaks - exact.peak_thetas)) < 1e-7


PULSE = {"excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 2.0}


@pytest.mark.parametrize("scene", [PULSE, {**PULSE, "excitation.kind": 2}, {**PULSE, "excitation.amplitude": 5.0,
                                                                            "excitation.frequency": 2.5,
                                                                            "excitation.verticalAmplitude": 2.0}],
                         ids=["sine pulse", "cosine pulse", "with vertical"])
def test_cvode_matches_co_simulation_on_a_pulse(fmu_path, scene):
    """Uplift, impacts, rest: Model Exchange through CVode against the FMU's own solver."""
    me, cs = _me(fmu_path, scene), _cs(fmu_path, scene)
    assert cs["impacts"][-1] > 3 and me["impacts"][-1] == cs["impacts"][-1]
    assert np.max(np.abs(me["block1.theta"] - cs["block1.theta"])) < 1e-6
    # impact times: the first ones to 1e-7 s; the last, quick ones of the settling block amplify
    # the integration error (the time to the next impact shrinks with the amplitude)
    dt = np.abs(_changes(me, "lastImpactTime") - _changes(cs, "lastImpactTime"))
    assert np.max(dt[:6]) < 1e-7 and np.max(dt) < 1e-5


def test_a_short_uplift_window_is_not_stepped_over(fmu_path):
    """|ah| exceeds the threshold (g + av) tan(alpha) for about 0.03 s at the pulse's peak only;
    CVode's long steps at rest would cross it without a sign change at a step's end. Time
    events at the edges of the cells where the excitation is monotone catch it."""
    scene = {**PULSE, "excitation.verticalAmplitude": 2.0}
    me, cs = _me(fmu_path, scene, stop=0.5), _cs(fmu_path, scene, stop=0.5)
    first = [int(np.argmax(~r["atRest"].astype(bool))) for r in (me, cs)]
    assert first[0] == first[1] > 0
    assert me["impacts"][-1] > 0 and cs["impacts"][-1] > 0


def test_overturn_and_stop_at_overturn(fmu_path):
    scene = {"excitation.kind": 1, "excitation.amplitude": 12.0, "excitation.frequency": 1.0}
    me, cs = _me(fmu_path, scene), _cs(fmu_path, scene)
    assert cs["overturned"][-1] and me["overturned"][-1]
    assert me["overturnTime"][-1] == pytest.approx(cs["overturnTime"][-1], abs=1e-7)
    ended = _me(fmu_path, {**scene, "solver.stopAtOverturn": True})
    # terminateSimulation at the overturn: fmpy keeps the samples up to it
    assert cs["overturnTime"][-1] - 1e-3 <= ended["time"][-1] <= cs["overturnTime"][-1]


def test_euler_converges_to_co_simulation(fmu_path):
    """A fixed-step Euler run (fmpy steps it from one output point to the next) has the error
    of its step, shrinking with it (first order)."""
    errors = []
    for h in (1e-3, 1e-4):
        cs = _cs(fmu_path, {"block1.theta0": 0.1}, stop=1.0, interval=h)
        r = _me(fmu_path, {"block1.theta0": 0.1}, stop=1.0, solver="Euler", step=h, interval=h)
        errors.append(np.max(np.abs(r["block1.theta"] - cs["block1.theta"])))
    assert errors[1] < 0.3 * errors[0]
    assert errors[0] > 1e-4  # the coarse step's error is visible


def _instance(fmu, messages):
    md = fmu.model_description
    model = FMU2Model(guid=md.guid, unzipDirectory=fmu.unzipdir, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName="me")
    model.instantiate(loggingOn=True)
    return model


def test_two_blocks_and_the_builtin_early_overturn_are_co_simulation_only(fmu_path, fmu):
    for params, text in (({"nBlocks": 2}, "Model Exchange runs one block"),
                         ({"solver.earlyOverturn": True}, "solver.earlyOverturn")):
        with pytest.raises(Exception):
            simulate_fmu(str(fmu_path), fmi_type="ModelExchange", start_values=params, stop_time=0.1,
                         logger=None)
        model = _instance(fmu, [])
        model.setupExperiment(startTime=0.0)
        for name, value in params.items():
            v = fmu.vars[name]
            (model.setInteger if v.type == "Integer" else model.setBoolean)([v.valueReference], [value])
        with pytest.raises(Exception):
            model.enterInitializationMode()
        model.freeInstance()


def test_model_exchange_functions_check_their_arguments(fmu):
    model = _instance(fmu, [])
    model.setupExperiment(startTime=0.0)
    model.setReal([fmu.vars["block1.theta0"].valueReference], [0.1])
    model.enterInitializationMode()
    model.exitInitializationMode()
    model.newDiscreteStates()
    model.enterContinuousTimeMode()
    x = np.zeros(2)
    model.getContinuousStates(x.ctypes.data_as(POINTER(c_double)), 2)
    assert list(x) == [0.1, 0.0]
    with pytest.raises(Exception):  # the model has two states
        model.getContinuousStates(x.ctypes.data_as(POINTER(c_double)), 3)
    bad = np.array([math.nan, 0.0])
    with pytest.raises(Exception):
        model.setContinuousStates(bad.ctypes.data_as(POINTER(c_double)), 2)
    with pytest.raises(Exception):
        model.doStep(0.0, 0.1)  # a Co-Simulation function on a Model Exchange instance
    model.freeInstance()
