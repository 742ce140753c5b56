"""FMI 2.0 rules the FMU keeps beyond the call sequence: outputs after inputs are set,
the declared ModelStructure, the importer's tolerance, ending a run at an overturn,
Enumerations, display units and the default experiment."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

from conftest import Slave
from fmu_build.model_structure import DEPENDENCIES, STATES
from model.reference import Block, free_rocking

ROCKING = {"block1.theta0": 0.15, "excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 2.0}
STACK = {"nBlocks": 2, "block1.theta0": 0.05, "block2.theta0": 0.08}
INPUTS = ("ground.ah", "ground.av")


def _outputs(slave: Slave) -> dict[str, float]:
    values = {}
    for name, v in slave.fmu.vars.items():
        if v.causality != "output":
            continue
        get = {"Real": slave.s.getReal, "Integer": slave.s.getInteger, "Boolean": slave.s.getBoolean}[v.type]
        values[name] = float(get([v.valueReference])[0])
    return values


def _rocking_slave(fmu, params, t=0.37):
    slave = Slave(fmu)
    slave.start(params)
    slave.s.doStep(0.0, t)
    return slave


def test_inputs_set_without_a_step_update_the_feedthrough_outputs(fmu):
    """After fmi2SetReal(ground.ah), ahTotal and alpha_dd are those of the new input at once:
    alpha_dd from the equation of motion written out here, with theta from the outputs."""
    slave = _rocking_slave(fmu, {"block1.theta0": 0.15})
    theta, omega = slave.real("block1.theta", "block1.omega")
    side = math.copysign(1.0, theta)  # the corner it rocks on
    assert theta != 0
    ah, av = 2.5, -1.5
    slave.s.setReal([slave.vr["ground.ah"], slave.vr["ground.av"]], [ah, av])
    b, h, g = 0.1, 0.3, 9.81  # the FMU's default block and gravity
    R, alpha = math.hypot(b, h), math.atan(b / h)
    phi = side * alpha - theta
    expected = -(3.0 / (4.0 * R)) * ((g + av) * math.sin(phi) + ah * math.cos(phi))
    got_ah, got_av, got_add = slave.real("ground.ahTotal", "ground.avTotal", "block1.alpha_dd")
    assert (got_ah, got_av) == (ah, av)
    assert got_add == pytest.approx(expected, rel=1e-12)
    assert slave.real("block1.theta", "block1.omega") == [theta, omega]  # states do not jump
    slave.close()


# a rocking block on a free platform of its floor's mass, coupled two ways (support.force pushes it)
FLOOR = {**ROCKING, "excitation.kind": 0, "block1.omega0": 0.5, "support.kind": 2, "support.coupling": 1,
         "platform.mass": 500.0}


@pytest.mark.parametrize("params, changed", [(ROCKING, "ground.ah"), (ROCKING, "ground.av"), (STACK, "ground.ah"),
                                             (STACK, "ground.av"), (FLOOR, "support.force")],
                         ids=["one block, ah", "one block, av", "two blocks, ah", "two blocks, av",
                              "two-way floor, support.force"])
def test_outputs_declared_independent_of_an_input_do_not_change_with_it(fmu, params, changed):
    """ModelStructure by perturbation: set one input at a communication point (no step);
    an output that does not declare it must keep its value, and some that do must change."""
    slave = _rocking_slave(fmu, params)
    before = _outputs(slave)
    slave.s.setReal([slave.vr[changed]], [3.25])
    after = _outputs(slave)
    moved = {n for n in before if after[n] != before[n]}
    declared = {n for n, deps in DEPENDENCIES.items() if changed in deps}
    assert moved <= declared, f"changed without a declared dependency on {changed}: {moved - declared}"
    must_move = {"ground.avTotal" if changed == "ground.av" else "ground.ahTotal", "block1.alpha_dd"}
    if params is STACK:
        must_move.add("block2.alpha_dd")
    assert must_move <= moved
    slave.close()


def test_model_description_declares_the_structure(fmu):
    md = fmu.model_description
    index = {v.name: i for i, v in enumerate(md.modelVariables, start=1)}
    by_name = {v.name: v for v in md.modelVariables}
    outputs = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}
    assert set(outputs) == {n for n, v in by_name.items() if v.causality == "output"}
    for name, deps in outputs.items():
        assert deps == set(DEPENDENCIES.get(name, ())), name
    assert {u.variable.name for u in md.derivatives} == set(STATES.values())
    for state, der in STATES.items():
        assert by_name[der].derivative is by_name[state]
    assert index  # indices resolved by fmpy


def test_the_tighter_of_the_importers_tolerance_and_solver_relTol_is_used(fmu_path):
    """toleranceDefined: the integrator uses the tighter of the importer's tolerance and
    solver.relTol (1e-10 by default). A looser tolerance changes nothing; a tighter one is used
    (tests/test_tolerance.py has the case that showed why)."""
    kw = dict(start_values={"block1.theta0": 0.15}, stop_time=3.0, output_interval=0.01, output=["block1.theta"])
    own = simulate_fmu(str(fmu_path), **kw)["block1.theta"]  # fmpy gives the default experiment's 1e-10
    loose = simulate_fmu(str(fmu_path), relative_tolerance=1e-3, **kw)["block1.theta"]
    tight = simulate_fmu(str(fmu_path), relative_tolerance=1e-12, **kw)["block1.theta"]
    also_tight = simulate_fmu(str(fmu_path), relative_tolerance=1e-3,
                              **{**kw, "start_values": {**kw["start_values"], "solver.relTol": 1e-12}})["block1.theta"]
    assert np.array_equal(own, loose)
    assert np.array_equal(tight, also_tight) and not np.array_equal(own, tight)


def test_tolerance_is_reported_and_checked(fmu):
    slave = Slave(fmu)
    slave.s.setupExperiment(tolerance=1e-12, startTime=0.0)
    slave.s.enterInitializationMode()
    assert slave.real("solver.relTol") == [1e-12]  # tighter than solver.relTol's 1e-10: used
    slave.close()
    slave = Slave(fmu)
    slave.s.setupExperiment(tolerance=1e-6, startTime=0.0)
    slave.s.enterInitializationMode()
    assert slave.real("solver.relTol") == [1e-10]  # looser: solver.relTol stays
    slave.close()
    bad = Slave(fmu)
    bad.expect_error(lambda: bad.s.setupExperiment(tolerance=0.5, startTime=0.0), "tolerance 0.5 must be in [1e-14, 0.1]")
    bad.close()


OVERTURNING = {"excitation.kind": 1, "excitation.amplitude": 12.0, "excitation.frequency": 1.0}


def test_stop_at_overturn_ends_the_step_there(fmu):
    """solver.stopAtOverturn: the step that contains the overturn returns fmi2Discard,
    fmi2Terminated is true and the last successful time is the overturn time of a run
    without the option."""
    full = Slave(fmu)
    full.start(OVERTURNING)
    for k in range(6):
        full.s.doStep(0.5 * k, 0.5)  # default: steps go on after the overturn
    overturn_time, = full.real("overturnTime")
    assert 0 < overturn_time < 3.0
    assert not full.s.getBooleanStatus(fmi2Terminated)
    full.close()

    slave = Slave(fmu)
    slave.start({**OVERTURNING, "solver.stopAtOverturn": True})
    t = 0.0
    with pytest.raises(Exception):
        while t < 3.0:
            slave.s.doStep(t, 0.5)
            t += 0.5
    assert slave.s.getBooleanStatus(fmi2Terminated)
    assert slave.s.getRealStatus(fmi2LastSuccessfulTime) == overturn_time
    assert slave.real("overturnTime", "block1.theta") == [overturn_time, math.copysign(math.pi / 2,
                                                                                        slave.real("block1.theta")[0])]
    assert slave.s.getBoolean([slave.vr["overturned"]]) == [True]
    slave.close()


def test_stop_at_overturn_in_the_runners_ends_the_series(fmu):
    full = fmu.run(OVERTURNING, 3.0, 0.01, outputs=["block1.theta", "overturnTime"])
    short = fmu.run({**OVERTURNING, "solver.stopAtOverturn": True}, 3.0, 0.01, outputs=["block1.theta", "overturnTime"])
    t_over = full.outputs["overturnTime"][-1]
    assert short.time[-1] == t_over
    n = len(short.time) - 1
    assert np.array_equal(short.time[:n], full.time[:n])
    assert np.array_equal(short.outputs["block1.theta"][:n], full.outputs["block1.theta"][:n])


def test_enumerations_name_exactly_the_values_the_model_accepts(fmu):
    md = fmu.model_description
    typed = {v.name: v.declaredType for v in md.modelVariables if v.declaredType is not None
             and v.declaredType.type == "Enumeration"}
    assert {"restitution.law", "excitation.kind", "solver.method", "pattern"} <= set(typed)
    for name, t in typed.items():
        values = sorted(int(item.value) for item in t.items)
        assert values == list(range(values[0], values[-1] + 1)), name
        assert all(item.description for item in t.items), name
        if fmu.vars[name].causality != "parameter":
            continue
        for outside in (values[0] - 1, values[-1] + 1):
            slave = Slave(fmu)
            slave.s.setupExperiment(startTime=0.0)
            slave.s.setInteger([slave.vr[name]], [outside])
            slave.expect_error(slave.s.enterInitializationMode, name)
            slave.close()


def test_angles_display_in_degrees(fmu):
    md = fmu.model_description
    units = {u.name: u for u in md.unitDefinitions}
    for v in md.modelVariables:
        if v.type == "Real" and v.unit in ("rad", "rad/s", "rad/s2"):
            assert v.displayUnit is not None and v.displayUnit.startswith("deg"), v.name
    for u in ("rad", "rad/s", "rad/s2"):
        (display,) = units[u].displayUnits
        assert display.factor == pytest.approx(180.0 / math.pi, rel=1e-15)


@pytest.mark.parametrize("edition, fmi_type", [("2", "CoSimulation"), ("2", "ModelExchange"), ("3", "CoSimulation")])
def test_the_default_experiment_shows_free_rocking(fmu_path, fmu3_path, edition, fmi_type):
    """An importer's "simulate" with nothing set: the start values tilt block 1 and the default
    experiment lets it rock to rest. Its impacts are those of exact free rocking (Housner 1963,
    eta = 1 - 1.5 sin^2(alpha)) at every output point up to the tenth impact."""
    md = read_model_description(str(fmu_path))
    start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None and v.type == "Real"}
    block = Block(start["block1.halfWidth"], start["block1.halfHeight"], start["g"])
    theta0 = start["block1.theta0"]
    assert 0 < theta0 < block.alpha
    exact = free_rocking(block, theta0, 1 - 1.5 * math.sin(block.alpha) ** 2, 10).impact_times

    r = simulate_fmu(str(fmu_path if edition == "2" else fmu3_path), fmi_type=fmi_type,
                     output=["block1.theta", "impacts", "atRest"])
    experiment = md.defaultExperiment
    assert r["time"][-1] == float(experiment.stopTime) == 5 and float(experiment.tolerance) == 1e-10
    assert r["block1.theta"][0] == theta0 and r["atRest"][-1]
    # Model Exchange adds rows at its events: keep the rows away from the exact impact times
    early = (r["time"] < exact[-1] - 1e-6) & (np.min(np.abs(r["time"][:, None] - exact), axis=1) > 1e-6)
    expected = np.searchsorted(exact, r["time"][early], side="right")
    np.testing.assert_array_equal(r["impacts"][early], expected)


def test_the_runners_start_a_scene_at_rest(fmu):
    """The runners' default of block1.theta0 is 0 (runners.engine.fmu.SCENE_DEFAULTS), not the
    FMU's demonstration start value: a scene that leaves it out and has no excitation stays put."""
    assert fmu.vars["block1.theta0"].start not in (None, "0", 0) and fmu.defaults()["block1.theta0"] == 0.0
    r = fmu.run({}, 1.0, 0.1, outputs=["block1.theta", "impacts"], events=False)
    assert np.all(r.outputs["block1.theta"] == 0.0) and r.outputs["impacts"][-1] == 0
