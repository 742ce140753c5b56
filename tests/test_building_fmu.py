"""ShearBuilding.fmu (model/c/building), the real FMU through fmpy, against independent references:
the exact modal solution (scipy.linalg.eigh), a second integrator (scipy's DOP853) under a
record file, the energy balance, and its refusals of bad parameters and call sequences.

The references build M, K and the Rayleigh damping C = a0 M + a1 K from the parameters
themselves (damping ratio zeta at modes 1 and 2 from eigh's frequencies; N = 1: C = 2 zeta w1 m).
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)
from scipy.integrate import solve_ivp
from scipy.linalg import eigh


# a three-storey building with unequal floors (kg, N/m)
MASSES = [2.0e4, 1.5e4, 1.0e4]
STIFFNESSES = [3.0e7, 2.0e7, 1.5e7]
ZETA = 0.05


@pytest.fixture(scope="module")
def building_fmu(building_fmu_path, tmp_path_factory) -> tuple[str, object]:
    path = building_fmu_path
    return extract(str(path), str(tmp_path_factory.mktemp("shear_building"))), read_model_description(str(path))


class Building:
    """One instance of the FMU, its log captured."""

    def __init__(self, fmu: tuple[str, object]):
        unzipdir, md = fmu
        self.messages: list[str] = []

        def logger(env, name, status, category, message):
            self.messages.append((message or b"").decode(errors="replace").replace("%%", "%"))

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.vars = {v.name: v for v in md.modelVariables}
        self.s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="ShearBuilding",
                           instanceName="building")
        self.s.instantiate(callbacks=self._callbacks)
        self.t = 0.0

    def set(self, values: dict[str, float | int | str]) -> None:
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Integer":
                self.s.setInteger([v.valueReference], [int(value)])
            elif v.type == "String":
                self.s.setString([v.valueReference], [str(value)])
            else:
                self.s.setReal([v.valueReference], [float(value)])

    def start(self, params: dict[str, float | int | str], t0: float = 0.0, tolerance: float | None = None) -> None:
        self.s.setupExperiment(startTime=t0, tolerance=tolerance)
        self.set(params)
        self.s.enterInitializationMode()
        self.s.exitInitializationMode()
        self.t = t0

    def get(self, names: Sequence[str]) -> np.ndarray:
        return np.array(self.s.getReal([self.vars[n].valueReference for n in names]))

    def run(self, stop: float, h: float, names: Sequence[str],
            inputs: Callable[[float], dict[str, float]] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Step to ``stop`` by ``h`` (inputs(t) set at each communication point): times and outputs."""
        n = int(round((stop - self.t) / h))
        times, rows = [self.t], [self.get(names)]
        for _ in range(n):
            if inputs:
                self.set(inputs(self.t))
            self.s.doStep(self.t, h)
            self.t += h  # the FMU's own arithmetic: its time is the communication point plus the step
            times.append(self.t)
            rows.append(self.get(names))
        return np.array(times), np.array(rows)

    def close(self) -> None:
        self.s.freeInstance()


@pytest.fixture
def building(building_fmu):
    b = Building(building_fmu)
    yield b
    b.close()


def structure(params: dict) -> dict:
    """The parameters of a building of the given masses and stiffnesses."""
    out = {"nStoreys": len(params["m"]), "damping.ratio": params["zeta"]}
    for i, (m, k) in enumerate(zip(params["m"], params["k"]), start=1):
        out[f"storey[{i}].mass"] = m
        out[f"storey[{i}].stiffness"] = k
    return out


class Reference:
    """M, K, the modes (eigh) and the Rayleigh damping of a shear building, independently of the FMU."""

    def __init__(self, m: Sequence[float], k: Sequence[float], zeta: float):
        n = len(m)
        self.M = np.diag(m)
        self.K = np.zeros((n, n))
        for i in range(n):  # storey i joins floor i-1 (or the base) and floor i
            self.K[i, i] += k[i]
            if i > 0:
                self.K[i - 1, i - 1] += k[i]
                self.K[i - 1, i] -= k[i]
                self.K[i, i - 1] -= k[i]
        w2, self.phi = eigh(self.K, self.M)  # phi^T M phi = I
        self.w = np.sqrt(w2)
        if n == 1:
            self.a0, self.a1 = 0.0, 2 * zeta / self.w[0]
        else:
            w1, w2_ = self.w[0], self.w[1]
            self.a0, self.a1 = 2 * zeta * w1 * w2_ / (w1 + w2_), 2 * zeta / (w1 + w2_)
        self.C = self.a0 * self.M + self.a1 * self.K
        self.zeta = self.a0 / (2 * self.w) + self.a1 * self.w / 2  # modal damping ratios

    def free(self, q0: np.ndarray, v0: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
        """Damped free vibration of the modal coordinates from (q0, v0) after tau seconds."""
        s, wd = self.zeta * self.w, self.w * np.sqrt(1 - self.zeta ** 2)
        a, b = q0, (v0 + s * q0) / wd
        e, c, sn = np.exp(-s * tau), np.cos(wd * tau), np.sin(wd * tau)
        return e * (a * c + b * sn), e * ((-s * a + wd * b) * c + (-s * b - wd * a) * sn)

    def step_response(self, force: np.ndarray, release: float, t: float) -> tuple[np.ndarray, np.ndarray]:
        """u, u' at t from rest under a force held over [0, release] and zero after (exact, modal)."""
        p = self.phi.T @ force
        qs = p / self.w ** 2  # the static deflection under the force
        if t <= release:
            q, v = self.free(-qs, np.zeros_like(qs), t)
            q = q + qs
        else:
            q1, v1 = self.free(-qs, np.zeros_like(qs), release)
            q, v = self.free(q1 + qs, v1, t - release)
        return self.phi @ q, self.phi @ v


def names(n: int, *members: str) -> list[str]:
    return [f"storey[{i}].{m}" for m in members for i in range(1, n + 1)]


TEN_STOREYS = (list(np.linspace(3.0e4, 1.0e4, 10)), list(np.linspace(5.0e7, 2.0e7, 10)))  # 23 integrator states


@pytest.mark.parametrize("m,k", [([3.0e4], [2.0e7]), (MASSES, STIFFNESSES), TEN_STOREYS],
                         ids=["one storey", "three storeys", "ten storeys"])
def test_free_vibration_after_a_force_step_is_the_exact_modal_solution(building, m, k):
    ref = Reference(m, k, ZETA)
    n = len(m)
    force = np.zeros(n)
    force[-1] = 5.0e4  # N on the top floor, released at 0.5 s
    building.start(structure({"m": m, "k": k, "zeta": ZETA}))
    cols = names(n, "u", "v", "a")
    times, out = building.run(3.0, 0.01, cols, inputs=lambda t: {f"storey[{n}].force": force[-1] if t < 0.5 - 1e-9
                                                                  else 0.0})
    exact = []
    for t in times:
        u, v = ref.step_response(force, 0.5, t)
        f = force if 0 < t < 0.5 + 1e-9 else 0 * force  # the force set when the output was read (feedthrough)
        exact.append(np.concatenate([u, v, np.linalg.solve(ref.M, f - ref.C @ v - ref.K @ u)]))  # a: absolute
    exact = np.array(exact)
    assert np.abs(exact[:, :n]).max() > 1e-3  # displacements of millimetres
    for j in range(3):  # u, v, a: each to 1e-7 of its largest value
        part = slice(j * n, (j + 1) * n)
        np.testing.assert_allclose(out[:, part], exact[:, part], rtol=0, atol=1e-7 * np.abs(exact[:, part]).max())


def write_record(path: Path, t: np.ndarray, a: np.ndarray) -> None:
    lines = "".join(f"{float(x)!r} {float(y)!r}\n" for x, y in zip(t, a))
    path.write_text("# time s, horizontal acceleration m/s2\n" + lines)


def reference_record_run(ref: Reference, t_rec: np.ndarray, a_rec: np.ndarray, stop: float,
                         t_out: np.ndarray) -> np.ndarray:
    """u, u' at t_out of M u'' + C u' + K u = -M 1 a_g by DOP853 (rtol 1e-11), piece by piece between
    the record's samples (a_g linear between them, zero outside)."""
    n = ref.M.shape[0]
    minv = np.linalg.inv(ref.M)
    ones = np.ones(n)

    def ag(t):
        return float(np.interp(t, t_rec, a_rec, left=0.0, right=0.0))

    def rhs(t, y, piece):
        u, v = y[:n], y[n:]
        return np.concatenate([v, -minv @ (ref.C @ v + ref.K @ u) - ones * piece(t)])

    # break points at the record's samples and at the output times
    breaks = np.unique(np.concatenate([[0.0], t_rec[(t_rec > 0) & (t_rec < stop)], t_out]))
    y = np.zeros(2 * n)
    states = {0.0: y}
    for t0, t1 in zip(breaks[:-1], breaks[1:]):
        mid = 0.5 * (t0 + t1)
        g0, g1 = (ag(t0), ag(t1)) if t_rec[0] <= mid <= t_rec[-1] else (0.0, 0.0)

        def piece(t, t0=t0, t1=t1, g0=g0, g1=g1):
            return g0 + (g1 - g0) * (t - t0) / (t1 - t0)

        y = solve_ivp(rhs, (t0, t1), y, method="DOP853", rtol=1e-11, atol=1e-14, args=(piece,)).y[:, -1]
        states[t1] = y
    return np.array([states[t] for t in t_out])


def test_base_excitation_from_a_record_matches_a_second_integrator(building, tmp_path):
    ref = Reference(MASSES, STIFFNESSES, ZETA)
    n = 3
    t_rec = np.round(np.arange(0, 201) * 0.01, 12)
    a_rec = 0.5 * np.sin(2 * np.pi * 1.7 * t_rec)
    write_record(tmp_path / "sine.txt", t_rec, a_rec)
    scale, start = 2.0, 0.3
    building.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}), "excitation.file":
                    str(tmp_path / "sine.txt"), "excitation.scale": scale, "excitation.startTime": start})
    cols = names(n, "u", "v", "a") + ["base.aTotal", "baseShear"]
    times, out = building.run(4.0, 0.05, cols)
    y = reference_record_run(ref, t_rec + start, scale * a_rec, 4.0, times)
    u, v = y[:, :n], y[:, n:]
    ag = np.interp(times, t_rec + start, scale * a_rec, left=0.0, right=0.0)
    a_abs = np.linalg.solve(ref.M, -(ref.C @ v.T + ref.K @ u.T)).T  # = u'' + a_g
    umax, vmax, amax = np.abs(u).max(), np.abs(v).max(), np.abs(a_abs).max()
    assert umax > 1e-3  # the record shakes it
    np.testing.assert_allclose(out[:, :n], u, rtol=0, atol=1e-7 * umax)
    np.testing.assert_allclose(out[:, n:2 * n], v, rtol=0, atol=1e-7 * vmax)
    np.testing.assert_allclose(out[:, 2 * n:3 * n], a_abs, rtol=0, atol=1e-7 * amax)
    np.testing.assert_allclose(out[:, 3 * n], ag, rtol=0, atol=1e-12)
    # the force of the building on the base: 1^T (K u + C u')
    shear = (ref.K @ u.T + ref.C @ v.T).sum(axis=0)
    np.testing.assert_allclose(out[:, 3 * n + 1], shear, rtol=0, atol=1e-7 * np.abs(shear).max())


def test_energy_balance_holds_under_record_force_and_base_input(building, tmp_path):
    t_rec = np.round(np.arange(0, 301) * 0.01, 12)
    a_rec = 1.5 * np.sin(2 * np.pi * 2.3 * t_rec) * np.exp(-t_rec)
    write_record(tmp_path / "decay.txt", t_rec, a_rec)
    building.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}),
                    "excitation.file": str(tmp_path / "decay.txt")})
    cols = ["energy", "baseWork", "forceWork", "dampingLoss"]
    _, out = building.run(5.0, 0.02, cols, inputs=lambda t: {"storey[2].force": 2e4 * np.sin(5 * t),
                                                             "base.a": 0.2 if t < 1.0 else 0.0})
    energy, base, force, loss = out.T
    assert energy.max() > 10 and np.abs(force).max() > 1 and np.abs(base).max() > 1 and loss[-1] > 1
    assert np.all(np.diff(loss) >= 0)
    np.testing.assert_allclose(energy - energy[0], base + force - loss, rtol=0, atol=1e-8 * energy.max())


@pytest.mark.parametrize("n", [1, 2, 3, 10])
def test_frequencies_are_those_of_the_generalised_eigenproblem(building, n):
    rng = np.random.default_rng(n)
    m = list(rng.uniform(5e3, 5e4, n))
    k = list(rng.uniform(5e6, 5e7, n))
    building.start(structure({"m": m, "k": k, "zeta": ZETA}))
    f1, f2 = building.get(["frequency1", "frequency2"])
    w = Reference(m, k, ZETA).w / (2 * np.pi)
    assert f1 == pytest.approx(w[0], rel=1e-10)
    assert f2 == pytest.approx(w[1] if n > 1 else w[0], rel=1e-10)


def test_results_do_not_depend_on_the_communication_step(building_fmu, tmp_path):
    t_rec = np.round(np.arange(0, 101) * 0.01, 12)
    write_record(tmp_path / "r.txt", t_rec, np.cos(2 * np.pi * 3 * t_rec))
    params = {**structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}), "excitation.file": str(tmp_path / "r.txt"),
              "storey[2].force": 3e4, "base.a": -0.4}
    cols = names(3, "u", "v", "a") + ["energy", "dampingLoss", "baseWork", "forceWork", "baseShear"]
    runs = []
    for h in (0.01, 0.001):
        b = Building(building_fmu)
        b.start(params)
        runs.append(b.run(1.5, h, cols))
        b.close()
    (t1, coarse), (t2, fine) = runs
    np.testing.assert_allclose(t2[::10], t1, atol=1e-12)
    scale = np.abs(coarse).max(axis=0)
    np.testing.assert_allclose(fine[::10] / scale, coarse / scale, rtol=0, atol=1e-8)


def test_the_tighter_of_its_relative_tolerance_and_the_importers_is_used(building_fmu, tmp_path):
    """An importer's coarse tolerance (OMSimulator passes 1e-4) leaves the run as it is; a tighter
    one than solver.relTol is used (reading solver.relTol shows the value in use)."""
    t_rec = np.round(np.arange(0, 101) * 0.01, 12)
    write_record(tmp_path / "r.txt", t_rec, np.cos(2 * np.pi * 3 * t_rec))
    params = {**structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}), "excitation.file": str(tmp_path / "r.txt")}
    cols = names(3, "u", "v", "a")
    runs, used = [], []
    for tolerance in (None, 1e-4, 1e-12):
        b = Building(building_fmu)
        b.start(params, tolerance=tolerance)
        used.append(float(b.get(["solver.relTol"])[0]))
        runs.append(b.run(1.0, 0.01, cols)[1])
        b.close()
    assert used[0] == used[1] > 1e-12 and used[2] == 1e-12
    assert np.array_equal(runs[0], runs[1])  # bit for bit
    assert not np.array_equal(runs[0], runs[2])  # the tighter tolerance was used
    np.testing.assert_allclose(runs[2], runs[0], rtol=0, atol=1e-6 * np.abs(runs[0]).max())


def test_storeys_above_n_read_zero_and_take_no_force(building_fmu):
    """Storeys above nStoreys read 0 and their parameters are not checked; their force may be set
    to its start value, 0 (as importers set every input), which changes nothing."""
    cols = names(10, "u", "a")
    runs = []
    for extra in ({}, {"storey[5].force": 0.0, "storey[10].force": 0.0}):
        b = Building(building_fmu)
        b.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}), "storey[5].mass": 0.0,
                 "storey[7].stiffness": -1.0})  # inactive storeys: not checked
        _, out = b.run(0.5, 0.05, cols, inputs=lambda t, extra=extra: {"storey[1].force": 1e5, **extra})
        b.close()
        runs.append(out)
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.all(runs[0][:, 3:10] == 0) and np.all(runs[0][:, 13:] == 0)
    assert np.abs(runs[0][:, :3]).max() > 0


def test_a_force_on_a_storey_the_building_does_not_have_is_an_error(building_fmu):
    """storey[5].force on a two-storey building would act on nothing: refused with a logged message,
    when set after initialisation, and at initialisation when set before it."""
    two = {"nStoreys": 2, "storey[1].mass": 1e4, "storey[2].mass": 1e4}
    b = Building(building_fmu)
    try:
        b.start(two)
        with pytest.raises(FMICallException):
            b.set({"storey[5].force": 1e6})
        assert any("storey[5].force = 1e+06 N acts on a storey the building does not have (nStoreys = 2)" in m
                   for m in b.messages), b.messages
        b.set({"storey[2].force": 1e6})  # a storey it has: still usable
        b.s.doStep(0.0, 0.01)
        assert b.get(["storey[2].u"])[0] > 0
    finally:
        b.close()
    b = Building(building_fmu)
    try:
        b.s.setupExperiment(startTime=0.0)
        b.set({**two, "storey[3].force": -5.0})
        b.s.enterInitializationMode()
        with pytest.raises(FMICallException):
            b.s.exitInitializationMode()
        assert any("storey[3].force = -5 N acts on a storey the building does not have" in m for m in b.messages)
    finally:
        b.close()


@pytest.mark.parametrize("name,value,words", [
    ("nStoreys", 0, "nStoreys = 0"),
    ("nStoreys", 11, "nStoreys = 11"),
    ("storey[2].mass", 0.0, "storey[2].mass"),
    ("storey[3].stiffness", -5.0, "storey[3].stiffness"),
    ("damping.ratio", 1.0, "damping.ratio"),
    ("damping.ratio", -0.01, "damping.ratio"),
    ("solver.relTol", 0.0, "solver.relTol"),
    ("solver.absTol", 0.0, "solver.absTol"),
    ("solver.absTol", 1.0, "solver.absTol = 1 must be in (0, 1e-06]"),
    ("excitation.file", "/nonexistent/record.txt", "cannot be opened"),
])
def test_bad_parameters_are_errors_with_a_one_line_message(building, name, value, words):
    building.s.setupExperiment(startTime=0.0)
    building.set({name: value})
    building.s.enterInitializationMode()
    with pytest.raises(FMICallException):
        building.s.exitInitializationMode()
    assert any(words in m for m in building.messages), building.messages
    assert all("\n" not in m for m in building.messages)


@pytest.mark.parametrize("masses,stiffness", [([1e-6, 1e-6, 2000.0], 1e12), ([5e-324, 1.0, 1.0], 1e6)])
def test_a_building_too_stiff_for_its_masses_is_refused_not_run_for_hours(building, masses, stiffness):
    """Floors of a microgram on a stiff frame vibrate at megahertz (or overflow): refused at
    initialisation with the highest frequency, instead of an explicit integration that would take
    hours (or give NaN)."""
    building.s.setupExperiment(startTime=0.0)
    building.set({"nStoreys": 3, **{f"storey[{i}].mass": m for i, m in enumerate(masses, start=1)},
                  **{f"storey[{i}].stiffness": stiffness for i in (1, 2, 3)}})
    building.s.enterInitializationMode()
    with pytest.raises(FMICallException):
        building.s.exitInitializationMode()
    assert any("highest natural frequency" in m for m in building.messages), building.messages


def test_the_declared_ranges_are_those_the_fmu_checks(building_fmu):
    """Every parameter's declared min and max (modelDescription.xml): the bound itself is accepted,
    the next value beyond it refused at initialisation."""
    md = building_fmu[1]
    ranged = [v for v in md.modelVariables if v.min is not None or v.max is not None]
    assert {v.name for v in ranged} >= {"nStoreys", "storey[1].mass", "storey[10].stiffness", "damping.ratio",
                                        "solver.relTol", "solver.absTol"}
    base = {"nStoreys": 2, "storey[1].mass": 1e4, "storey[2].mass": 1e4}
    for v in ranged:
        for bound, outward in ((v.min, -np.inf), (v.max, np.inf)):
            if bound is None:
                continue
            b = float(bound)
            beyond = b + (1 if outward > 0 else -1) if v.type == "Integer" else float(np.nextafter(b, outward))
            for value, ok in ((b, True), (beyond, False)):
                if v.name.startswith("storey[") and v.name.split(".")[0] not in ("storey[1]", "storey[2]"):
                    continue  # storeys above nStoreys = 2 are not checked
                if "mass" in v.name and ok and value < 1e-3:
                    continue  # the smallest positive double: a valid mass, but megahertz floors (the check above)
                b_ = Building(building_fmu)
                try:
                    b_.s.setupExperiment(startTime=0.0)
                    b_.set({**base, v.name: value})
                    b_.s.enterInitializationMode()
                    if ok:
                        b_.s.exitInitializationMode()
                    else:
                        with pytest.raises(FMICallException):
                            b_.s.exitInitializationMode()
                finally:
                    b_.close()


def test_an_unreadable_record_is_an_error_naming_the_line(building, tmp_path):
    (tmp_path / "bad.txt").write_text("0 0\n0.01 zero\n")
    building.s.setupExperiment(startTime=0.0)
    building.set({"excitation.file": str(tmp_path / "bad.txt")})
    building.s.enterInitializationMode()
    with pytest.raises(FMICallException):
        building.s.exitInitializationMode()
    assert any("line 2" in m and "'zero' is not a number" in m for m in building.messages), building.messages


def test_invalid_call_sequences_are_errors_not_crashes(building):
    with pytest.raises(FMICallException):
        building.s.doStep(0.0, 0.1)  # before initialisation
    with pytest.raises(FMICallException):
        building.get(["storey[1].u"])  # nothing to read before initialisation
    assert any("fmi2DoStep must not be called" in m for m in building.messages)
    building.start({})
    with pytest.raises(FMICallException):
        building.set({"storey[1].mass": 2e4})  # a parameter after initialisation
    with pytest.raises(FMICallException):
        building.set({"energy": 1.0})  # an output
    with pytest.raises(FMICallException):
        building.s.doStep(0.5, 0.1)  # not the FMU's time
    with pytest.raises(FMICallException):
        building.s.serializeFMUstate(building.s.getFMUstate())  # canSerializeFMUstate is false
    building.s.doStep(0.0, 0.1)  # still usable
    assert building.get(["storey[1].u"])[0] == 0.0  # at rest without excitation
    building.s.terminate()
    with pytest.raises(FMICallException):
        building.s.doStep(0.1, 0.1)


def test_the_fmu_validates_and_declares_its_interface(building_fmu, building_fmu_path):
    from fmpy.validation import validate_fmu

    path = str(building_fmu_path)
    assert validate_fmu(path) == []
    md = building_fmu[1]
    assert md.coSimulation.canHandleVariableCommunicationStepSize and md.modelExchange is None
    by_name = {v.name: v for v in md.modelVariables}
    for i in range(1, 11):
        for member, causality in (("mass", "parameter"), ("stiffness", "parameter"), ("force", "input"),
                                  ("u", "output"), ("v", "output"), ("a", "output")):
            assert by_name[f"storey[{i}].{member}"].causality == causality
    assert by_name["frequency1"].causality == "calculatedParameter"
    assert by_name["excitation.file"].type == "String"


def test_a_relative_record_path_is_read_from_the_resources_folder(building_fmu, tmp_path):
    t_rec = np.round(np.arange(0, 51) * 0.02, 12)
    a_rec = np.sin(2 * np.pi * t_rec)
    resources = Path(building_fmu[0]) / "resources"
    resources.mkdir(exist_ok=True)
    write_record(resources / "in_resources.txt", t_rec, a_rec)
    write_record(tmp_path / "absolute.txt", t_rec, a_rec)
    runs = []
    for file in ("in_resources.txt", str(tmp_path / "absolute.txt")):
        b = Building(building_fmu)
        b.start({"excitation.file": file})
        runs.append(b.run(1.0, 0.1, ["storey[3].u", "base.aTotal"])[1])
        b.close()
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[0][:, 0]).max() > 0


def test_only_fmi2_functions_are_exported(building_fmu):
    so = Path(building_fmu[0]) / "binaries" / "linux64" / "ShearBuilding.so"
    out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    exported = [line.split()[-1] for line in out.splitlines() if line.strip()]
    assert "fmi2DoStep" in exported and all(n.startswith("fmi2") for n in exported), exported


def test_the_shipped_sources_rebuild_into_the_same_model(building_fmu, building_fmu_path, tmp_path):
    from fmpy.build import build_platform_binary

    path = str(building_fmu_path)
    unzipdir = tmp_path / "fmu"
    with zipfile.ZipFile(path) as zf:
        zf.extractall(unzipdir)
    shutil.rmtree(unzipdir / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzipdir, build_dir=tmp_path / "cmake")
    cols = names(3, "u", "a")
    runs = []
    for fmu in (building_fmu, (str(unzipdir), building_fmu[1])):
        b = Building(fmu)
        b.start({"damping.ratio": 0.02})
        runs.append(b.run(1.0, 0.05, cols, inputs=lambda t: {"storey[2].force": 1e5 * np.cos(7 * t)})[1])
        b.close()
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-9 * np.abs(runs[0]).max())


def test_libcosim_runs_it_as_fmpy_does(building_fmu, building_fmu_path):
    """libcosim (pip libcosimpy, the engine of the SSP runs) sees every variable, sets start values
    and inputs, and steps it to the same result as fmpy (it keeps time in integer nanoseconds)."""
    pytest.importorskip("libcosimpy", reason="libcosimpy is not installed")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    path = str(building_fmu_path)
    execution = CosimExecution.from_step_size(10_000_000)  # 10 ms
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=path, instance_name="building"))
    assert index >= 0
    variables = {v.name.decode(): v for v in execution.slave_variables(index)}
    assert set(variables) == {v.name for v in building_fmu[1].modelVariables}
    assert execution.integer_initial_value(index, variables["nStoreys"].reference, 2)
    assert execution.real_initial_value(index, variables["storey[2].mass"].reference, 2e4)
    observer = CosimObserver.create_last_value()
    assert execution.add_observer(observer)
    manipulator = CosimManipulator.create_override()
    assert execution.add_manipulator(manipulator)
    outputs = ["storey[2].u", "storey[2].a", "energy", "forceWork", "baseWork", "frequency2"]

    def inputs(t: float) -> dict[str, float]:
        return {"storey[2].force": 1e4 * np.sin(6 * t), "base.a": 0.3}

    rows = []
    for k in range(100):
        values = inputs(k * 0.01)
        assert manipulator.slave_real_values(index, [variables[n].reference for n in values], list(values.values()))
        assert execution.step()
        rows.append(observer.last_real_values(index, [variables[n].reference for n in outputs]))
    b = Building(building_fmu)
    b.start({"nStoreys": 2, "storey[2].mass": 2e4})
    _, ours = b.run(1.0, 0.01, outputs, inputs=inputs)
    b.close()
    assert np.abs(ours[:, 0]).max() > 1e-4
    scale = np.abs(ours).max(axis=0)
    np.testing.assert_allclose(np.array(rows) / scale, ours[1:] / scale, rtol=0, atol=1e-12)


def test_the_sanitizer_build_makes_the_building_too(tmp_path):
    """python -m fmu_build --sanitize (make sanitize) builds ShearBuilding with AddressSanitizer and
    UBSan, and make sanitize runs this file against it."""
    from fmu_build.building import build_building_fmu, default_building_path

    assert default_building_path(sanitize=True).name == "ShearBuilding-sanitize.fmu"
    path = build_building_fmu(tmp_path / "ShearBuilding-sanitize.fmu", sanitize=True)
    with zipfile.ZipFile(path) as zf:
        zf.extract("binaries/linux64/ShearBuilding.so", tmp_path)
    so = tmp_path / "binaries" / "linux64" / "ShearBuilding.so"
    symbols = subprocess.run(["nm", "-D", str(so)], capture_output=True, text=True, check=True).stdout
    assert "__asan_init" in symbols and "__ubsan_handle" in symbols
    makefile = (Path(__file__).resolve().parents[1] / "Makefile").read_text()
    recipe = makefile.split("\nsanitize:", 1)[1].split("\n\n", 1)[0]
    assert "ROCKING_BUILDING_FMU=build/ShearBuilding-sanitize.fmu" in recipe and "tests/test_building_fmu.py" in recipe


def test_output_derivatives_are_the_floors_rates(building, tmp_path):
    """fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder = 1): storey[i].u's is storey[i].v, storey[i].v's is
    u_i'' = storey[i].a - base.aTotal, and storey[i].a's is -(K u' + C u'')_i / m_i: against a one-sided difference of
    the outputs (second order, steps of 0.1 ms at relTol 1e-13), with a force held on floor 2."""
    t_rec = np.round(np.arange(0, 301) * 0.01, 12)
    write_record(tmp_path / "decay.txt", t_rec, 1.5 * np.sin(2 * np.pi * 2.3 * t_rec) * np.exp(-t_rec))
    building.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}),
                    "excitation.file": str(tmp_path / "decay.txt"), "storey[2].force": 3e4, "solver.relTol": 1e-13})
    building.run(1.0, 0.05, ["energy"])
    names = [f"storey[{i}].{q}" for i in (1, 2, 3) for q in ("u", "v", "a")]
    vrs = [building.vars[n].valueReference for n in names]
    d = np.array(building.s.getRealOutputDerivatives(vrs, [1] * len(vrs)))
    out = building.get(names + ["base.aTotal"])
    np.testing.assert_array_equal(d[0::3], out[1:9:3])  # u' = v
    np.testing.assert_allclose(d[1::3], out[2:9:3] - out[-1], rtol=0, atol=1e-12 * np.abs(out[2:9:3]).max())
    dt, x = 1e-4, [out[:9]]
    for _ in range(2):
        building.s.doStep(building.t, dt)
        building.t += dt
        x.append(building.get(names))
    fd = (-3 * x[0] + 4 * x[1] - x[2]) / (2 * dt)
    np.testing.assert_allclose(d[2::3], fd[2::3], rtol=2e-4)


def test_output_derivatives_it_does_not_have_are_refused_in_one_line(building):
    building.start(structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}))
    a = building.vars["storey[1].a"].valueReference
    for vrs, orders, words in (([a], [2], "maxOutputDerivativeOrder is 1"),
                               ([building.vars["energy"].valueReference], [1], "has no derivative output")):
        n = len(building.messages)
        with pytest.raises(FMICallException):
            building.s.getRealOutputDerivatives(vrs, orders)
        assert any(words in m for m in building.messages[n:]), building.messages[n:]


def test_a_state_taken_and_restored_repeats_the_steps_bit_for_bit(building_fmu, tmp_path):
    """canGetAndSetFMUstate: a master that rolls a step back (to iterate it) gets the same run again, force input
    and record included; a state from a run on another record is refused in one line."""
    t_rec = np.round(np.arange(0, 301) * 0.01, 12)
    write_record(tmp_path / "decay.txt", t_rec, 1.5 * np.sin(2 * np.pi * 2.3 * t_rec) * np.exp(-t_rec))
    b = Building(building_fmu)
    b.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}), "excitation.file": str(tmp_path / "decay.txt")})
    b.run(0.5, 0.05, ["energy"])
    state, t_state = b.s.getFMUstate(), b.t
    names = ["storey[3].u", "storey[3].a", "energy", "baseWork", "forceWork"]
    force = lambda t: {"storey[2].force": 2e4 * np.sin(5 * t)}  # noqa: E731
    first = b.run(1.0, 0.05, names, inputs=force)[1]
    b.s.setFMUstate(state)
    b.t = t_state
    again = b.run(1.0, 0.05, names, inputs=force)[1]
    np.testing.assert_array_equal(first, again)
    assert np.abs(first[:, 0]).max() > 0
    other = Building(building_fmu)
    write_record(tmp_path / "other.txt", t_rec[:100], 0.5 * np.ones(100))
    other.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}), "excitation.file": str(tmp_path / "other.txt")})
    with pytest.raises(FMICallException):
        other.s.setFMUstate(state)
    assert any("the state ran on another record" in m for m in other.messages)
    b.s.freeFMUstate(state)
    other.close()
    b.close()


def test_a_copy_that_carries_its_base_record_runs_it_with_no_file_set(building_fmu_path, tmp_path):
    """resources/base_record.txt in a copy of the FMU (what the runners' SSP makes, for tools that set no String
    parameters) is its base when excitation.file is empty; the FMU without it stays at rest."""
    from runners.engine.cosim import _with_record

    t_rec = np.round(np.arange(0, 101) * 0.01, 12)
    write_record(tmp_path / "pulse.txt", t_rec, 2.0 * np.sin(2 * np.pi * 3.0 * t_rec))
    (tmp_path / "copy").mkdir()
    copy = _with_record(building_fmu_path, tmp_path / "pulse.txt", tmp_path / "copy")
    moved = []
    for path in (building_fmu_path, copy):
        b = Building((extract(str(path), str(tmp_path / f"x{len(moved)}")), read_model_description(str(path))))
        b.start(structure({"m": MASSES, "k": STIFFNESSES, "zeta": 0.03}))
        moved.append(np.abs(b.run(0.5, 0.05, ["storey[3].u"])[1]).max())
        b.close()
    assert moved[0] == 0.0 and moved[1] > 1e-4


# ------------------------------------------------------------------ a floor carrying blocks another FMU moves

def test_a_force_line_on_a_carried_mass_matches_a_second_integrator(building):
    """storey[2].force given at each communication point as its value and its first derivative (a straight line over
    the step, fmi2SetRealInputDerivatives), on a floor carrying 4 t more (storey[2].carriedMass: inertia, not in the
    Rayleigh damping nor in the frequencies it is set at): u and u' at every communication point equal scipy's
    DOP853 on M_inertia u'' + C u' + K u = F(t), F piecewise linear, C of the structure's own masses; the storeys'
    force output is -(K u + C u') and its derivative -(K u' + C u'')."""
    ref, carried, h = Reference(MASSES, STIFFNESSES, ZETA), 4000.0, 0.02
    knots = np.round(np.arange(0, 51) * h, 12)
    values = 3e5 * np.sin(9.0 * knots) * np.exp(-knots)
    building.start({**structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}), "storey[2].carriedMass": carried,
                    "solver.relTol": 1e-12})
    f1 = building.vars["storey[2].force"].valueReference
    rows = [building.get(names(3, "u", "v", "structureForce"))]
    for k in range(50):
        building.set({"storey[2].force": values[k]})
        building.s.setRealInputDerivatives([f1], [1], [(values[k + 1] - values[k]) / h])
        building.s.doStep(building.t, h)
        building.t += h
        rows.append(building.get(names(3, "u", "v", "structureForce")))
    rows = np.array(rows)
    M = ref.M + np.diag([0.0, carried, 0.0])

    def rhs(t, y):
        force = np.array([0.0, np.interp(t, knots, values), 0.0])
        return np.concatenate([y[3:], np.linalg.solve(M, force - ref.C @ y[3:] - ref.K @ y[:3])])

    sol = solve_ivp(rhs, (0, knots[-1]), np.zeros(6), method="DOP853", t_eval=knots, rtol=1e-12, atol=1e-15,
                    max_step=h / 4)
    u, v = sol.y[:3].T, sol.y[3:].T
    np.testing.assert_allclose(rows[:, :3], u, rtol=0, atol=1e-9 * np.abs(u).max())
    np.testing.assert_allclose(rows[:, 3:6], v, rtol=0, atol=1e-9 * np.abs(v).max())
    np.testing.assert_allclose(rows[:, 6:], -(u @ ref.K.T + v @ ref.C.T), rtol=0, atol=1e-9 * np.abs(rows[:, 6:]).max())
    # the rate of the storeys' force at the end, from the outputs and the structure's own matrices
    vrs = [building.vars[n].valueReference for n in names(3, "structureForce")]
    d = np.array(building.s.getRealOutputDerivatives(vrs, [1, 1, 1]))
    out = building.get(names(3, "u", "v", "a") + ["base.aTotal"])
    acc = out[6:9] - out[9]
    np.testing.assert_allclose(d, -(ref.K @ out[3:6] + ref.C @ acc), rtol=1e-12, atol=1e-9)
    assert building.get(["frequency1"])[0] == pytest.approx(ref.w[0] / (2 * np.pi), rel=1e-12)


def test_a_force_value_set_at_a_later_point_is_held(building_fmu):
    """A derivative lasts until the force's value is set at a later communication point: then the force is held, bit
    for bit as when the derivative is set to 0 there, and not as when the line goes on."""
    runs = []
    for later in (None, 0.0, 5e5):  # at t = 0.01 s: the value alone, with a zero derivative, with the slope again
        b = Building(building_fmu)
        b.start(structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}))
        f = b.vars["storey[3].force"].valueReference
        b.set({"storey[3].force": 1e4})
        b.s.setRealInputDerivatives([f], [1], [5e5])
        b.s.doStep(0.0, 0.01)
        b.t = 0.01
        b.set({"storey[3].force": 2e4})
        if later is not None:
            b.s.setRealInputDerivatives([f], [1], [later])
        runs.append(b.run(0.2, 0.01, ["storey[3].u", "storey[3].v"])[1])
        b.close()
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[2] - runs[0]).max() > 1e-3 * np.abs(runs[0]).max()


@pytest.mark.parametrize("call, words", [
    (lambda b, vr: b.s.setRealInputDerivatives([vr("storey[1].force")], [2], [1.0]), "derivative of order 2"),
    (lambda b, vr: b.s.setRealInputDerivatives([vr("base.a")], [1], [1.0]), "takes no derivatives"),
    (lambda b, vr: b.s.setRealInputDerivatives([vr("storey[1].u")], [1], [1.0]), "cannot be set"),
    (lambda b, vr: b.s.setRealInputDerivatives([vr("storey[1].force")], [1], [float("nan")]), "not a finite number"),
    (lambda b, vr: b.s.setRealInputDerivatives([vr("storey[7].force")], [1], [1.0]), "does not have"),
])
def test_force_derivatives_it_does_not_take_are_refused_in_one_line(building, call, words):
    building.start(structure({"m": MASSES, "k": STIFFNESSES, "zeta": ZETA}))
    n = len(building.messages)
    with pytest.raises(FMICallException):
        call(building, lambda name: building.vars[name].valueReference)
    assert any(words in m for m in building.messages[n:]), building.messages[n:]
    building.s.doStep(0.0, 0.01)  # and it runs on
