"""Model Exchange in importers whose solvers stop exactly on a located event (issue 29).

A block lifting off from rest starts at theta = omega = 0, on the boundary of the impact and
peak indicators. Importers whose root finders stop exactly there (PyFMI's Dopri5, Radau5 and
LSODAR; scipy's solve_ivp) counted a false impact and a false lift-off, or gave up (LSODAR
flag -3: a root at the initial point). Each importer that installs here runs the pulse scenes
of the docs in Model Exchange and must give the Co-Simulation verdicts of the same FMU:
impact and peak counts, `lifts`, `slides`, `overturned`, `atRest`, the final rotation and
the largest one.

Importers (each skipped with its reason where it does not install):
- fmpy's CVode and Euler (simulate_fmu, fmi_type="ModelExchange");
- scipy's solve_ivp (RK45 = Dormand-Prince, Radau, LSODA) and Assimulo's CVode, Dopri5,
  Radau5ODE and LSODAR (pip assimulo-testing), each driven by the small masters of
  tests/me_master.py over fmpy's FMU2Model, as PyFMI's FMIODE2 drives them;
- PyFMI itself (needs the FMI Library, FMIL, which neither PyPI nor Debian ships) and
  Reference-FMUs' fmusim (FMUSIM=path to the executable) when present.
"""

from __future__ import annotations

import functools
import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.util import read_csv

from me_master import MeModel, MeRun, run_assimulo, run_scipy
from runners.engine.fmu import with_scene_defaults
from runners.engine.scene import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
INTERVAL = 0.01  # s, output interval
RTOL = 1e-10
VERDICTS = ["impacts", "peaks", "lifts", "slides", "overturned", "atRest"]
EXTREMES = ["block1.maxAbsTheta", "block2.maxAbsTheta", "friction.demandMaxGround", "friction.demandMaxInterface",
            "contact.normalMinGround", "contact.normalMinInterface"]
OUTPUTS = ["block1.theta", "block1.omega", *VERDICTS, *EXTREMES]


def _scene(name: str, **overrides) -> tuple[dict, float]:
    s = load_scene(EXAMPLES / f"{name}.toml")
    return with_scene_defaults({**s.parameters, **overrides}), s.stop_time


# The one-block pulse scenes of the docs that move the block (fig18_*.toml and
# sliding_pulse.toml set no amplitude: their block stays at rest), and one point of the
# sweep's documented map (a = a_g / (g tan alpha) = 1.38) where the contact lifts off.
SCENES = {
    "sine_pulse": _scene("sine_pulse"),  # rocks and comes to rest
    "ricker_pulse": _scene("ricker_pulse"),  # tips towards theta < 0, rocks, rests
    "sweep_sine_pulse": _scene("sweep_sine_pulse"),  # overturns; slides
    "sweep_point_lifts": _scene("sweep_sine_pulse", **{"excitation.amplitude": 6.0}),  # one impact, lifts, overturns
    # the other built-in pulses of docs/records.md on the same block
    "cosine_pulse": _scene("sine_pulse", **{"excitation.kind": 2}),  # rocks and comes to rest
    "ricker_antisymmetric": _scene("ricker_pulse", **{"excitation.kind": 6}),  # rocks and comes to rest
    "mavroeidis_papageorgiou": _scene("ricker_pulse", **{"excitation.kind": 7, "excitation.amplitude": 5.0,
                                                        "excitation.frequency": 1.5}),  # lifts, slides, overturns
}


@functools.cache
def co_simulation(fmu_path: Path, scene: str) -> dict[str, float]:
    params, stop = SCENES[scene]
    r = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", start_values=params, stop_time=stop,
                     output_interval=INTERVAL, output=OUTPUTS)
    return {k: float(r[k][-1]) for k in OUTPUTS}


def _fmpy_cvode(fmu_path, params, stop):
    # rtol 1e-11: fmpy sets CVode's absolute tolerance to rtol times the nominal (alpha), 1e-10
    # left 1.1e-9 rad on the largest rotation of sine_pulse
    r = simulate_fmu(str(fmu_path), fmi_type="ModelExchange", solver="CVode", relative_tolerance=RTOL / 10,
                     start_values=params, stop_time=stop, output_interval=INTERVAL, output=OUTPUTS, record_events=False)
    return {k: float(r[k][-1]) for k in OUTPUTS}


def _master(run, solver):
    def go(fmu_path, params, stop):
        r = run(fmu_path, params, stop, OUTPUTS, solver, interval=INTERVAL, rtol=RTOL, atol=RTOL * 1e-2)
        return {**r.samples[-1].values, **({"_steps": r.steps} if r.steps else {})}
    return go


@functools.cache
def _lift_window(fmu_path: Path, scene: str) -> tuple[float, float]:
    """(first, last) time (s) at which Co-Simulation's ground contact pulls (N < 0) in `scene`,
    checked to be one window from the lift-off (liftTime) to the overturn (overturnTime)."""
    params, stop = SCENES[scene]
    r = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", start_values=params, stop_time=stop,
                     output_interval=1e-4, output=["contact.groundN", "liftTime", "overturnTime"])
    pulls = r["time"][r["contact.groundN"] < 0]
    lift, over = float(r["liftTime"][-1]), float(r["overturnTime"][-1])
    assert lift > 0 and over > lift and pulls.size and lift <= pulls.min() and pulls.max() <= over
    assert np.all(np.diff(pulls) < 1.5e-4)  # one window, no gap
    return lift, over


def _assimulo(solver):
    def go(fmu_path, params, stop):
        pytest.importorskip("assimulo", reason="Assimulo is not installed (pip install assimulo-testing)")
        return _master(run_assimulo, solver)(fmu_path, params, stop)
    return go


def _pyfmi(solver):
    def go(fmu_path, params, stop):
        pyfmi = pytest.importorskip(
            "pyfmi", reason="PyFMI is not installed: PyPI has only the 2.5 sdist, which needs the FMI Library "
                            "(FMIL), shipped by neither PyPI nor Debian")
        model = pyfmi.load_fmu(str(fmu_path), kind="ME")
        for name, value in params.items():
            model.set(name, value)
        opts = model.simulate_options()
        opts["solver"] = solver
        opts["ncp"] = round(stop / INTERVAL)
        opts[f"{solver}_options"]["rtol"] = RTOL
        r = model.simulate(final_time=stop, options=opts)
        return {k: float(r[k][-1]) for k in OUTPUTS}
    return go


def _fmusim(fmu_path, params, stop):
    exe = os.environ.get("FMUSIM")
    if not exe or not shutil.which(exe):
        pytest.skip("fmusim (Reference-FMUs) not available: set FMUSIM=path (it is published on GitHub only, "
                    "not on PyPI or Debian)")
    # options as in Reference-FMUs v0.0.39's fmusim; its tolerance as fmpy's CVode's (its default,
    # 1e-4, is too coarse for the impact counts)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "fmusim.csv"
        cmd = [exe, "--interface-type", "me", "--solver", "cvode", "--stop-time", str(stop),
               "--output-interval", str(INTERVAL), "--tolerance", str(RTOL / 10), "--output-file", str(out)]
        for name, value in params.items():
            cmd += ["--start-value", name, str(int(value) if isinstance(value, bool) else value)]
        for name in OUTPUTS:
            cmd += ["--output-variable", name]
        subprocess.run([*cmd, str(fmu_path)], check=True, capture_output=True, timeout=120)
        data = read_csv(str(out))  # fmusim quotes the column names
    return {k: float(data[k][-1]) for k in OUTPUTS}


IMPORTERS = {
    "fmpy-CVode": _fmpy_cvode,
    "scipy-RK45": _master(run_scipy, "RK45"),
    "scipy-Radau": _master(run_scipy, "Radau"),
    "scipy-LSODA": _master(run_scipy, "LSODA"),
    "assimulo-Dopri5": _assimulo("Dopri5"),
    "assimulo-Radau5ODE": _assimulo("Radau5ODE"),
    "assimulo-LSODAR": _assimulo("LSODAR"),
    "assimulo-CVode": _assimulo("CVode"),
    "pyfmi-CVode": _pyfmi("CVode"),
    "pyfmi-Dopri5": _pyfmi("Dopri5"),
    "pyfmi-Radau5ODE": _pyfmi("Radau5ODE"),
    "pyfmi-LSODAR": _pyfmi("LSODAR"),
    "fmusim-CVODE": _fmusim,
}
# a verdict an importer's solver cannot see: the Mavroeidis-Papageorgiou pulse lifts the block off
# 14 ms before it overturns (N down to -0.0055 W); where scipy's Radau steps from before the lift-off to
# past pi/2 in one step (scipy before 1.17), it reaches a state beyond the model where the event update
# does not sample the contact. The test then says so (xfail); where a step ends inside the window
# (scipy 1.17.1), every verdict is checked
MISSED = {("scipy-Radau", "mavroeidis_papageorgiou"): "one Radau step spans the 14 ms lift-off before the overturn"}
# a lift-off whose window (N < 0 from the lift-off to the overturn) is shorter than an importer's step:
# a solver sees it only if one of its steps ends inside the window (the indicator N has the same
# sign at both ends of a step that spans it). For the importers that report their steps (scipy's),
# the expected `lifts` is whether one did; scipy 1.17's RK45 steps over the Mavroeidis-Papageorgiou
# pulse's 14 ms window, earlier releases ended a step inside it
NARROW_LIFTS = {"mavroeidis_papageorgiou"}
SLOW = {"scipy-Radau", "scipy-LSODA"}  # about 1 s a run: solve_ivp's implicit methods in Python


def _cases():
    for importer in IMPORTERS:
        for scene in SCENES:
            marks = [pytest.mark.slow] if importer in SLOW else []
            yield pytest.param(importer, scene, marks=marks, id=f"{importer}-{scene}")


@pytest.mark.parametrize("importer,scene", list(_cases()))
def test_importer_gives_the_co_simulation_verdicts(fmu_path, importer, scene):
    params, stop = SCENES[scene]
    me = IMPORTERS[importer](fmu_path, params, stop)
    cs = co_simulation(fmu_path, scene)
    expected = {k: cs[k] for k in VERDICTS}
    steps = me.pop("_steps", None)
    if scene in NARROW_LIFTS and steps is not None:
        window = _lift_window(fmu_path, scene)
        expected["lifts"] = float(any(window[0] <= t <= window[1] for t in steps))
        if (importer, scene) in MISSED and not expected["lifts"]:
            pytest.xfail(MISSED[importer, scene])
    assert {k: me[k] for k in VERDICTS} == expected
    # every scene ends at rest (theta = 0) or overturned (theta = +-pi/2): exact values, but for
    # fmusim's CSV, which prints 16 significant digits (pi/2 comes back 4.4e-16 off)
    assert me["block1.theta"] == pytest.approx(cs["block1.theta"], abs=1e-15 if importer.startswith("fmusim") else 0)
    # the largest rotation is reached at a peak, an event of both interfaces: the importer's
    # tolerance (rtol 1e-10) and the indicators' hysteresis (1e-10 alpha) stay below 1e-9
    assert me["block1.maxAbsTheta"] == pytest.approx(cs["block1.maxAbsTheta"], abs=1e-9)
    # the contact extremes are sampled at the importer's steps in Model Exchange, on the
    # built-in solver's steps in Co-Simulation: equal to that sampling, here 1e-3 (the
    # antisymmetric Ricker wavelet's peak demand, 0.351, falls between samples). Only where
    # the block stays on the ground: towards an overturn N -> 0 and the demand |T| / N grows
    # without bound (1.08 to 160 in the sweep's scenes), whatever samples it then
    if cs["contact.normalMinGround"] > 0.5:
        for k in ("friction.demandMaxGround", "contact.normalMinGround"):
            assert me[k] == pytest.approx(cs[k], abs=1e-3), k


@pytest.mark.parametrize("scene", list(SCENES))
def test_euler_gives_the_co_simulation_monitor_verdicts(fmu_path, scene):
    """fmpy's fixed-step Euler at 0.1 ms: the monitors' and the overturn's verdicts. Not the
    counts: a first-order step gains energy at each impact near rest, where the rest
    criterion then waits (1092 impacts instead of 41 at 0.1 ms, 43 at 0.01 ms on sine_pulse)."""
    params, stop = SCENES[scene]
    r = simulate_fmu(str(fmu_path), fmi_type="ModelExchange", solver="Euler", step_size=1e-4, start_values=params,
                     stop_time=stop, output_interval=1e-4, output=["lifts", "slides", "overturned"], record_events=False)
    cs = co_simulation(fmu_path, scene)
    assert {k: float(r[k][-1]) for k in ("lifts", "slides", "overturned")} == \
        {k: cs[k] for k in ("lifts", "slides", "overturned")}


# --------------------------------------------------------------------- the lift-off itself

BLOCK = {"block1.theta0": 0.0, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0}
G = 9.81
THRESHOLD = G * 0.1 / 0.3  # m/s2, g tan(alpha)


def _released(fmu_path, ah):
    """A block at rest that the input ground.ah tips at the start (ah < 0: towards theta > 0)."""
    m = MeModel(fmu_path, ["block1.theta", "block1.omega", "block1.alpha_dd", "impacts", "peaks", "lifts", "atRest"])
    m.start({**BLOCK, "ground.ah": ah}, 1.0)
    return m


def _alpha_dd(side, ah):
    """theta'' at theta = 0 on pivot side `side` (Dimitrakopoulos & DeJong 2012, with m R / I0 = 3 / (4 R))."""
    b, h = 0.1, 0.3
    R, alpha = math.hypot(b, h), math.atan2(b, h)
    return -3 / (4 * R) * (G * math.sin(side * alpha) + ah * math.cos(side * alpha))


@pytest.mark.parametrize("ah,side", [(-2 * THRESHOLD, 1), (2 * THRESHOLD, -1)])
def test_no_indicator_is_zero_where_the_solver_starts_after_a_release(fmu_path, ah, side):
    """Released at theta = omega = 0: every indicator is away from 0 when continuous time
    starts (LSODAR's flag -3 was a root at the initial point), and the impact and peak
    indicators stay positive as the block rises on its pivot side."""
    m = _released(fmu_path, ah)
    try:
        assert m.get("atRest") == 0 and list(m.states()) == [0.0, 0.0]
        assert m.get("block1.alpha_dd") == pytest.approx(_alpha_dd(side, ah), rel=1e-12)
        z = m.indicators(0.0, np.zeros(2))
        assert np.all(z > 0), z
        t = 1e-3  # rising: theta = alpha_dd t^2 / 2, omega = alpha_dd t on the side it tips to
        a = _alpha_dd(side, ah)
        z1 = m.indicators(t, np.array([a * t * t / 2, a * t]))
        assert z1[0] > z[0] and z1[3] > z[3]
    finally:
        m.close()


@pytest.mark.parametrize("ah,side", [(-2 * THRESHOLD, 1), (2 * THRESHOLD, -1)])
def test_a_crossing_that_leaves_the_ground_is_not_an_impact(fmu_path, ah, side):
    """The state at which PyFMI's Dopri5 stopped right after a lift-off (issue 29): theta a
    hair on the far side of 0 (-1.5e-36 on the right pivot), omega at rounding level pointing
    away from the ground. The event update must count no impact and no lift-off of the
    contact, and keep the block rocking on its pivot side, from theta = 0."""
    m = _released(fmu_path, ah)
    run = MeRun()
    try:
        t, x = 1e-9, np.array([-side * 1.5e-36, side * 1.6e-25])
        m.completed(t, x)
        m.event(t, run)
        after = run.samples[-1].values
        assert (after["impacts"], after["peaks"], after["lifts"], after["atRest"]) == (0, 0, 0, 0)
        assert list(m.states()) == [0.0, side * 1.6e-25]
        assert m.get("block1.alpha_dd") == pytest.approx(_alpha_dd(side, ah), rel=1e-12)  # same pivot
        assert np.all(m.indicators(t, m.states()) > 0)
    finally:
        m.close()


def test_a_crossing_into_the_ground_is_still_an_impact(fmu_path):
    """The same hair past theta = 0 with omega turning the block into the ground: an impact
    (Housner's restitution for h/b = 3: omega+ = (1 - 1.5 sin^2 alpha) omega-)."""
    m = MeModel(fmu_path, ["impacts", "block1.omega"])
    run = MeRun()
    try:
        m.start({**BLOCK, "block1.theta0": 0.05}, 1.0)
        t, x = 0.1, np.array([-1e-15, -0.5])
        m.completed(t, x)
        m.event(t, run)
        alpha = math.atan2(0.1, 0.3)
        assert run.samples[-1].values["impacts"] == 1
        assert m.states()[1] == pytest.approx(-0.5 * (1 - 1.5 * math.sin(alpha) ** 2), rel=1e-12)
    finally:
        m.close()


def test_a_monitor_violation_stepped_over_is_a_step_event(fmu_path):
    """A fixed-step importer that steps over the lift-off indicator's root (N / W < 0 at the
    step's end): fmi2CompletedIntegratorStep asks for an event, and `lifts` (discrete) turns
    true in the event update, not in continuous-time mode. N < 0 needs omega^2 R > g about:
    8 rad/s on this block (R = 0.32 m)."""
    m = MeModel(fmu_path, ["lifts", "liftTime"])
    run = MeRun()
    try:
        m.start({**BLOCK, "block1.theta0": 0.05}, 1.0)
        t, x = 0.01, np.array([0.05, -8.0])  # falling back as released: no peak, no impact
        assert m.indicators(t, x)[5] < 0 < m.indicators(0.0, np.array([0.05, 0.0]))[5]
        assert m.completed(t, x)
        assert m.get("lifts") == 0
        m.event(t, run)
        assert run.samples[-1].values == {"lifts": 1, "liftTime": t}
    finally:
        m.close()


# ------------------------------------------------------ running extremes change at events

def _masters():
    yield pytest.param(run_scipy, "RK45", id="scipy-RK45")
    yield pytest.param(run_assimulo, "Dopri5", id="assimulo-Dopri5")
    yield pytest.param(run_assimulo, "LSODAR", id="assimulo-LSODAR")


@pytest.mark.parametrize("run,solver", list(_masters()))
@pytest.mark.parametrize("scene", ["ricker_pulse", "sweep_point_lifts"])
def test_running_extremes_change_only_at_events(fmu_path, run, solver, scene):
    """block1.maxAbsTheta, friction.demandMax*, contact.normalMin* (and block 2's, 0 here), like
    `lifts` and `slides`, are discrete: read at every output point and on both sides of every
    event, they change only across an event update. The run ends at an event (rest, overturn): then the largest
    rotation is Co-Simulation's to 1e-9."""
    if run is run_assimulo:
        pytest.importorskip("assimulo", reason="Assimulo is not installed (pip install assimulo-testing)")
    params, stop = SCENES[scene]
    r = run(fmu_path, params, stop, OUTPUTS, solver, interval=INTERVAL, rtol=RTOL, atol=RTOL * 1e-2)
    changes = 0
    for before, after in zip(r.samples, r.samples[1:]):
        for k in (*EXTREMES, "lifts", "slides"):
            if after.values[k] != before.values[k]:
                assert after.kind == "post" and after.t == before.t, (k, before, after)
                changes += 1
    assert changes >= 3  # the peaks raise maxAbsTheta, the motion the demand, ...
    outs = [s for s in r.samples if s.kind == "out"]
    assert len(outs) == round(stop / INTERVAL) + 1
    assert r.final("block1.maxAbsTheta") == pytest.approx(co_simulation(fmu_path, scene)["block1.maxAbsTheta"],
                                                          abs=1e-9)
