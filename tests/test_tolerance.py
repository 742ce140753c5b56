"""The importer's tolerance and solver.relTol (docs/model.md, "Tolerance"): the integrator uses the
tighter of the two, in FMI 2.0 (fmi2SetupExperiment) and FMI 3.0 (fmi3EnterInitializationMode).

The case that showed why: the marble statue on its free plinth (examples/marble_statue_on_plinth.toml,
a rocking-sliding stack) under a 6 m/s2, 1.5 Hz one-sine pulse. At solver.relTol 1e-9 to 1e-12 the
statue overturns at 2.0057 s; at 1e-4, which OMSimulator gives every FMU, the run ended in flight
at 0.3154 s, a different outcome, when the importer's tolerance replaced solver.relTol.

Each run here is the compiled FMU driven through fmpy's FMU2Slave or FMU3Slave by a small master
that gives a tolerance or none, as an importer may."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

from runners.api import as_scene
from runners.engine.fmu import with_scene_defaults

ROOT = Path(__file__).resolve().parents[1]
STATES = ("block1.theta", "block2.theta", "block1.slip", "block2.slip")
FINAL = ("block2.overturned", "overturnTime", "lifts", "liftTime", "impacts", "solver.relTol")


def marble_under_a_pulse() -> dict:
    """The FMU parameters of the marble statue on its plinth under a one-sine pulse of 6 m/s2 at 1.5 Hz."""
    scene = as_scene(ROOT / "examples" / "marble_statue_on_plinth.toml")
    return with_scene_defaults({**scene.parameters, "excitation.kind": 1, "excitation.amplitude": 6.0,
                                "excitation.frequency": 1.5, "excitation.cycles": 1.0})


class Master:
    """One co-simulation instance of an FMI 2.0 or 3.0 FMU, set up with or without a tolerance."""

    def __init__(self, path: Path, folder: str):
        self.md = read_model_description(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmi3 = self.md.fmiVersion.startswith("3")
        kind = FMU3Slave if self.fmi3 else FMU2Slave
        self.slave = kind(guid=self.md.guid, unzipDirectory=folder,
                          modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="tolerance")
        self.slave.instantiate()

    def set(self, params: dict) -> None:
        for name, value in params.items():
            v = self.vars[name]
            if self.fmi3:
                setter = {"Float64": self.slave.setFloat64, "Int32": self.slave.setInt32,
                          "Boolean": self.slave.setBoolean, "Enumeration": self.slave.setInt64}[v.type]
            else:
                setter = {"Real": self.slave.setReal, "Integer": self.slave.setInteger,
                          "Boolean": self.slave.setBoolean, "Enumeration": self.slave.setInteger}[v.type]
            setter([v.valueReference], [value])

    def get(self, name: str) -> float:
        v = self.vars[name]
        if self.fmi3:
            getter = {"Float64": self.slave.getFloat64, "Int32": self.slave.getInt32,
                      "Boolean": self.slave.getBoolean}[v.type]
        else:
            getter = {"Real": self.slave.getReal, "Integer": self.slave.getInteger,
                      "Boolean": self.slave.getBoolean}[v.type]
        return float(getter([v.valueReference])[0])

    def run(self, params: dict, tolerance: float | None, stop: float = 4.0, step: float = 0.01) -> dict:
        """The states at every communication point (0 .. stop s by step s) and the final FINAL
        outputs, solver.relTol among them as read after initialisation."""
        if self.fmi3:
            self.set(params)
            self.slave.enterInitializationMode(tolerance=tolerance, startTime=0.0, stopTime=stop)
        else:
            self.slave.setupExperiment(tolerance=tolerance, startTime=0.0, stopTime=stop)
            self.set(params)
            self.slave.enterInitializationMode()
        rel_tol = self.get("solver.relTol")
        self.slave.exitInitializationMode()
        n = int(round(stop / step))
        rows = [[self.get(s) for s in STATES]]
        for k in range(n):
            self.slave.doStep(k * step, step)
            rows.append([self.get(s) for s in STATES])
        out = {name: self.get(name) for name in FINAL}
        out["solver.relTol"] = rel_tol
        self.slave.terminate()
        self.slave.freeInstance()
        return {"states": np.array(rows), **out}


@pytest.fixture(scope="module", params=["fmi2", "fmi3"])
def run(request, fmu_path, fmu3_path):
    """run(params, tolerance): a run of RockingBlock.fmu (fmi2) or RockingBlock3.fmu (fmi3)."""
    path = fmu_path if request.param == "fmi2" else fmu3_path
    folder = extract(str(path))
    yield lambda params, tolerance: Master(path, folder).run(params, tolerance)
    shutil.rmtree(folder, ignore_errors=True)


def test_an_importers_loose_tolerance_leaves_the_marble_stack_as_it_is(run):
    """OMSimulator's 1e-4 against no tolerance at all (solver.relTol's default 1e-10 governs both):
    the same run bit for bit, in which the statue overturns (no flight)."""
    params = marble_under_a_pulse()
    own = run(params, None)
    loose = run(params, 1e-4)
    assert own["solver.relTol"] == loose["solver.relTol"] == 1e-10
    assert np.array_equal(loose["states"], own["states"])
    assert {k: loose[k] for k in FINAL} == {k: own[k] for k in FINAL}
    assert loose["block2.overturned"] == 1 and loose["lifts"] == 0 and loose["liftTime"] == -1
    assert 1.9 < loose["overturnTime"] < 2.1


def test_the_tighter_of_the_two_tolerances_is_used(run):
    """A tolerance tighter than solver.relTol is used (and read back as solver.relTol); a looser one
    leaves solver.relTol: each run equals the run with only the tighter of the two, bit for bit."""
    params = marble_under_a_pulse()
    tight = run({**params, "solver.relTol": 1e-12}, None)
    assert tight["solver.relTol"] == 1e-12 and tight["block2.overturned"] == 1
    for relative, importer in ((1e-6, 1e-12), (1e-12, 1e-4), (1e-12, 1e-12)):
        both = run({**params, "solver.relTol": relative}, importer)
        assert both["solver.relTol"] == 1e-12, (relative, importer)
        assert np.array_equal(both["states"], tight["states"]), (relative, importer)
    # the tolerance in use changes the run (to the integrator's accuracy): 1e-12 is not 1e-10
    default = run(params, None)
    assert not np.array_equal(default["states"], tight["states"])
    assert default["overturnTime"] == pytest.approx(tight["overturnTime"], abs=1e-8)
