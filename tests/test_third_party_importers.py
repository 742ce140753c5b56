"""RockingBlock.fmu run in third-party co-simulation engines, each against fmpy.

The engines are the Open Simulation Platform's libcosim (pip libcosimpy) and Ecos
(pip ecospy). Each runs four scenes with a fixed communication step: free rocking,
a built-in sine pulse with the constant restitution law (both Enumerations, which neither
engine can set: they set the Integer codes excitation.kindCode and restitution.lawCode
instead, docs/model.md), the ground acceleration given through the input `ground.ah`
(a sampled signal, changed by the engine at each communication point and held over
the step), and a two-block stack. fmpy's simulate_fmu runs the same scenes with the
same start values and an output interval equal to the engine's step; theta must
agree to 1e-9 rad at every sample and the impact counts must be equal.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

H = 0.01  # the engines' communication step, s (10 ms: a whole number of nanoseconds for libcosim)
INSTANCE = "block"
TOLERANCE = 1e-9  # rad


def sampled_pulse(t: np.ndarray) -> np.ndarray:
    """One 3 Hz sine cycle of 4.5 m/s2 (above the uplift threshold g b/h = 3.27 m/s2), then rest."""
    return np.where(t < 1 / 3, 4.5 * np.sin(2 * np.pi * 3.0 * t), 0.0)


@dataclass(frozen=True)
class Scene:
    params: dict
    stop_time: float = 3.0
    signal: Callable[[np.ndarray], np.ndarray] | None = None  # ground.ah(t_k), held over [t_k, t_k + H]
    outputs: tuple[str, ...] = field(default=("block1.theta", "impacts"))

    @property
    def steps(self) -> int:
        return round(self.stop_time / H)

    def held_input(self) -> np.ndarray:
        """The input the engine sets at each communication point t_k = k H, k = 0 .. steps - 1."""
        return self.signal(np.arange(self.steps) * H)


TALL_STACK = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
              "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0}
SCENES = {
    "free": Scene({"block1.theta0": 0.1}),
    # from rest: a master driving the block sets block1.theta0 = 0 (its start value tilts the block)
    # the Enumerations excitation.kind and restitution.law, which the engines set through their Integer
    # codes excitation.kindCode and restitution.lawCode (by_codes)
    "pulse": Scene({"block1.theta0": 0.0, "excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0,
                    "restitution.law": 2, "restitution.eta": 0.8}),
    "input": Scene({"block1.theta0": 0.0}, signal=sampled_pulse, outputs=("block1.theta", "impacts", "ground.ahTotal")),
    # both blocks tilted: they rock, lock and part again, with ground and interface impacts (Housner's
    # law, the default: libcosim and Ecos cannot set the Enumeration restitution.law)
    "stack": Scene({**TALL_STACK, "block1.theta0": 0.05, "block2.theta0": 0.12},
                   outputs=("block1.theta", "block2.theta", "impacts", "impactsGround", "impactsInterface")),
}


@functools.cache
def fmpy_reference(fmu_path: Path, name: str) -> dict[str, np.ndarray]:
    """fmpy's simulate_fmu, sampled at t_1 .. t_n (the samples an engine has after each step)."""
    scene = SCENES[name]
    kwargs = {}
    if scene.signal is not None:
        # a jump at each t_k (two rows at t_k): fmpy sets the value after the jump, u(t_k), before the step from t_k
        tk = np.arange(scene.steps + 1) * H
        u = np.append(scene.held_input(), 0.0)
        signals = np.zeros(2 * len(tk) - 1, dtype=[("time", float), ("ground.ah", float), ("ground.av", float)])
        signals["time"] = np.repeat(tk, 2)[1:]
        signals["ground.ah"] = np.repeat(u, 2)[:-1]
        kwargs["input"] = signals
    r = simulate_fmu(str(fmu_path), start_values=scene.params, stop_time=scene.stop_time, output_interval=H,
                     output=list(scene.outputs), **kwargs)
    assert len(r) == scene.steps + 1
    return {"time": r["time"][1:], **{k: r[k][1:] for k in scene.outputs}}


def types_of(fmu_path: Path) -> dict[str, str]:
    return {v.name: v.type for v in read_model_description(str(fmu_path)).modelVariables}


def by_codes(params: dict, types: dict[str, str]) -> dict:
    """params with each Enumeration replaced by its Integer code (excitation.kind ->
    excitation.kindCode, ...: the CODE lines of model/c/variables.def, docs/model.md): libcosim
    and Ecos cannot set an FMI 2.0 Enumeration variable, they can set an Integer."""
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_codes

    code_of = {enum: code for code, enum in read_codes(C_DIR / "variables.def").items()}
    out = {}
    for name, value in params.items():
        if types[name] == "Enumeration":
            assert name in code_of, f"the Enumeration {name} has no Integer code"
            name = code_of[name]
            assert types[name] == "Integer", name
        out[name] = value
    return out


# ------------------------------------------------------------------ libcosim

def run_libcosim(fmu_path: Path, scene: Scene) -> dict[str, np.ndarray]:
    """libcosim's fixed-step execution (time in integer nanoseconds); start values with
    *_initial_value; the input through an override manipulator, set before each step
    (libcosim applies it to the FMU at the step's start and holds it over the step)."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    execution = CosimExecution.from_step_size(round(H * 1e9))
    slave = CosimLocalSlave(fmu_path=str(fmu_path), instance_name=INSTANCE)
    index = execution.add_local_slave(slave)
    assert index >= 0, "libcosim could not add the FMU"
    variables = {v.name.decode(): v for v in execution.slave_variables(index)}
    set_initial = {CosimVariableType.REAL: (execution.real_initial_value, float),
                   CosimVariableType.INTEGER: (execution.integer_initial_value, int),
                   CosimVariableType.BOOLEAN: (execution.boolean_initial_value, bool)}
    # libcosim 0.0.6 lists no FMI 2.0 Enumeration variable, so it cannot set one: their Integer codes
    for name, value in by_codes(scene.params, types_of(fmu_path)).items():
        setter, cast = set_initial[CosimVariableType(variables[name].type)]
        assert setter(index, variables[name].reference, cast(value)), f"libcosim refused the start value of {name}"
    observer = CosimObserver.create_last_value()
    assert execution.add_observer(observer)
    manipulator = CosimManipulator.create_override()
    assert execution.add_manipulator(manipulator)

    ah = variables["ground.ah"].reference
    real = [n for n in scene.outputs if CosimVariableType(variables[n].type) == CosimVariableType.REAL]
    integer = [n for n in scene.outputs if n not in real]
    u = scene.held_input() if scene.signal is not None else None
    rows = []
    for k in range(scene.steps):
        if u is not None:
            assert manipulator.slave_real_values(index, [ah], [float(u[k])])
        assert execution.step(), f"libcosim step {k} failed: {execution.status()}"
        rows.append([execution.status().current_time * 1e-9,
                     *observer.last_real_values(index, [variables[n].reference for n in real]),
                     *observer.last_integer_values(index, [variables[n].reference for n in integer])])
    data = np.array(rows)
    return {name: data[:, j] for j, name in enumerate(["time", *real, *integer])}


# ------------------------------------------------------------------ Ecos

def run_ecos(fmu_path: Path, scene: Scene) -> dict[str, np.ndarray]:
    """Ecos's fixed-step simulation (time accumulated in double); start values as a
    parameter set applied at initialisation; the input through set_real before each step
    (Ecos caches it and sets it on the FMU just before the step's fmi2DoStep). Not through
    Ecos's timed scenario actions: in ecospy 0.7.2 one fires only when the accumulated time
    equals its time point bit for bit (0.06 never does: the time is 0.060000000000000005),
    and one that never fires holds back all later ones."""
    from ecospy import EcosSimulation, EcosSimulationStructure
    from ecospy.EcosParameterSet import EcosParameterSet

    types = types_of(fmu_path)
    # Ecos 0.7.2 registers no FMI 2.0 Enumeration variable ("No variable named ... of type int"): their codes
    params = by_codes(scene.params, types)
    ident = functools.partial("{}::{}".format, INSTANCE)
    # the structure outlives the simulation made from it: it owns the loaded model
    with EcosSimulationStructure() as structure, EcosParameterSet() as parameter_set:
        structure.add_model(INSTANCE, str(fmu_path))
        add = {"Real": (parameter_set.add_real, float), "Integer": (parameter_set.add_int, int),
               "Boolean": (parameter_set.add_bool, bool)}
        for name, value in params.items():
            setter, cast = add[types[name]]
            setter(ident(name), cast(value))
        assert structure.add_parameter_set("scene", parameter_set)
        with EcosSimulation(structure=structure, step_size=H) as sim:
            assert sim.init(parameter_set="scene")
            get = {"Real": sim.get_real, "Integer": sim.get_integer, "Boolean": sim.get_bool}
            for name, value in params.items():  # the parameter set reached the FMU
                assert get[types[name]](ident(name)) == value, name
            u = scene.held_input() if scene.signal is not None else None
            rows = []
            for k in range(scene.steps):
                if u is not None:
                    sim.set_real(ident("ground.ah"), float(u[k]))
                t = sim.step()
                rows.append([t, *(get[types[n]](ident(n)) for n in scene.outputs)])
            sim.terminate()
    data = np.array(rows)
    return {name: data[:, j] for j, name in enumerate(["time", *scene.outputs])}


# ------------------------------------------------------------------ engines

@pytest.fixture(scope="module")
def libcosim():
    pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (pip install libcosimpy; it is in the "
                                             "test extra for Linux x86-64)")
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    try:  # loads the wheel's libcosimc.so
        log_output_level(CosimLogLevel.WARNING)
    except OSError as exc:
        pytest.skip(f"libcosimpy's native library does not load here: {exc}")
    return run_libcosim


@pytest.fixture(scope="module")
def ecos():
    try:  # ecospy loads its libecosc.so on import
        from ecospy import EcosLib
    except ImportError as exc:
        pytest.skip(f"ecospy is not installed (pip install ecospy; it is in the test extra for Linux x86-64): {exc}")
    except OSError as exc:
        if "libtbb" in str(exc):
            pytest.skip(f"ecospy needs Debian's libtbb12 (apt-get install libtbb12; .ci/run installs it): {exc}")
        pytest.skip(f"ecospy's native library does not load here: {exc}")
    EcosLib.set_log_level("warn")
    return run_ecos


@pytest.fixture(params=["libcosim", "ecos"])
def engine(request, tmp_path, monkeypatch):
    """An engine's run function. Both unpack the FMU into a folder of their own under the
    temporary directory (TMPDIR) and remove it when done: here that is the test's tmp_path."""
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    return request.getfixturevalue(request.param)


@pytest.mark.parametrize("name", list(SCENES))
def test_engine_matches_fmpy(engine, fmu_path, name):
    scene = SCENES[name]
    ref = fmpy_reference(fmu_path, name)
    got = engine(fmu_path, scene)

    assert len(got["time"]) == scene.steps
    np.testing.assert_allclose(got["time"], ref["time"], rtol=0, atol=1e-12)
    for theta in [n for n in scene.outputs if n.endswith(".theta")]:
        diff = np.max(np.abs(got[theta] - ref[theta]))
        assert diff <= TOLERANCE, f"{theta}: max |engine - fmpy| = {diff:.3g} rad"
        assert np.ptp(ref[theta]) > 0.05, f"{theta} hardly moves: the scene tests nothing"
    for count in [n for n in scene.outputs if n.startswith("impacts")]:
        np.testing.assert_array_equal(got[count], ref[count], err_msg=count)
        assert ref[count][-1] > 0, f"no {count} in the scene: the count comparison tests nothing"
    if scene.signal is not None:
        # both applied u(t_k) over step k: the FMU reports the total it used (no built-in excitation here)
        np.testing.assert_array_equal(got["ground.ahTotal"], ref["ground.ahTotal"])
        np.testing.assert_array_equal(ref["ground.ahTotal"], scene.held_input())
