"""The independent rocking-sliding reference (model/sliding_reference.py): energy balance, impacts that
never add energy, closed forms of a Coulomb block; then against RockingBlock.fmu (contact.model = 1)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.optimize import brentq

from model.sliding_reference import (REST, ROCK, SLIDE, SLIDE_ROCK, SlidingBlock, energy, harmonic, impact,
                                     mode_forces, record, sine_pulse, simulate)

SQUAT = dict(b=0.3, h=0.36)  # tan(alpha) = 0.833
G = 9.81


def energy_scale(blk: SlidingBlock, run) -> float:
    """Initial energy, the largest |ground work|, or the work to tip the block onto a corner."""
    return max(abs(run.energy[0]), float(np.max(np.abs(run.ground_work))), blk.m * blk.g * (blk.R - blk.h))


FREE = {  # block thrown along the ground at 1 m/s
    "slides, mu < tan(alpha)": (SlidingBlock(mu=0.3, **SQUAT), None, 1.0),
    "tips and slide-rocks, mu > tan(alpha)": (SlidingBlock(mu=0.9, **SQUAT), None, 1.0),
}
EXCITED = {
    "sine pulse, slides": (SlidingBlock(mu=0.3, **SQUAT), sine_pulse(12.0, 2.0), 0.0),
    "sine pulse, rocks then slide-rocks": (SlidingBlock(0.2, 0.4, 0.55), sine_pulse(8.0, 2.0), 0.0),
    "harmonic, slides with stick phases": (SlidingBlock(mu=0.3, **SQUAT), harmonic(0.025, 2.0, cycles=3), 0.0),
}


@pytest.mark.parametrize("case", [*FREE, *EXCITED])
def test_energy_balances_along_the_run_and_impacts_never_add_energy(case):
    blk, exc, v0 = {**FREE, **EXCITED}[case]
    run = simulate(blk, exc, 2.0, slip_rate0=v0)
    scale = energy_scale(blk, run)
    assert np.max(np.abs(run.balance_error)) <= 1e-9 * scale
    assert all(dE <= 1e-12 * scale for dE in run.impact_energy_change)
    assert np.all(np.diff(run.friction_loss) >= -1e-12 * scale)  # friction only dissipates
    assert np.all(np.diff(run.impact_loss) >= -1e-12 * scale)
    # each case does what its name says
    modes = set(run.mode.tolist())
    if "slide" in case and "rock" not in case:
        assert SLIDE in modes and ROCK not in modes and SLIDE_ROCK not in modes
    if "rock" in case:
        assert SLIDE_ROCK in modes and len(run.impact_times) >= 2 and run.impact_loss[-1] > 0
    if "rocks then" in case:
        first = {new: t for t, _, new in reversed(run.switches)}
        assert first[ROCK] < first[SLIDE_ROCK]
    if "stick phases" in case:
        assert [k for k, _ in run.events].count("stick") >= 2 and [k for k, _ in run.events].count("slide") >= 3


def test_a_block_thrown_on_the_ground_stops_where_coulomb_says():
    """Decelerating at mu g: stops after v0 / (mu g), having slid v0^2 / (2 mu g)."""
    for mu, v0 in ((0.3, 1.0), (0.5, -2.5)):
        blk = SlidingBlock(mu=mu, **SQUAT)
        run = simulate(blk, None, 1.5, slip_rate0=v0)
        assert run.events == [("stick", pytest.approx(abs(v0) / (mu * G), abs=1e-12))]
        assert run.final_slip == pytest.approx(math.copysign(v0 * v0 / (2 * mu * G), v0), abs=1e-12)
        assert run.friction_loss[-1] == pytest.approx(0.5 * blk.m * v0 * v0, rel=1e-12)


def test_a_sine_pulse_starts_the_slide_and_reverses_it_where_the_closed_form_says():
    """a_h = A sin(w t): slides at asin(mu g / A) / w (towards -x); while it slides,
    u' = (A / w)(cos w t - cos w ts) + mu g (t - ts), whose zero is the reversal."""
    A, f, mu = 12.0, 2.0, 0.3
    w = 2 * math.pi * f
    run = simulate(SlidingBlock(mu=mu, **SQUAT), sine_pulse(A, f), 1.0)
    ts = math.asin(mu * G / A) / w
    assert run.event_times("slide")[0] == pytest.approx(ts, abs=1e-12)
    rate = lambda t: (A / w) * (math.cos(w * t) - math.cos(w * ts)) + mu * G * (t - ts)  # noqa: E731
    tr = brentq(rate, ts + 1e-3, 1.0 / f, xtol=1e-15)
    assert run.event_times("reverse")[0] == pytest.approx(tr, abs=1e-10)
    slip_tr = ((A / w**2) * (math.sin(w * tr) - math.sin(w * ts)) - (A / w) * math.cos(w * ts) * (tr - ts)
               + 0.5 * mu * G * (tr - ts) ** 2)
    # the slip where the run located the reversal (its time within 1e-10 s of tr, where the slip
    # rate is 0: the slip there differs from slip_tr by far less than 1e-10 m)
    i = np.flatnonzero(run.t == run.event_times("reverse")[0])[0]
    assert run.slip[i] == pytest.approx(slip_tr, abs=1e-10)
    assert run.peak_abs_slip == pytest.approx(abs(slip_tr), abs=1e-10)


def test_the_impact_law_never_adds_energy_and_sticks_when_friction_allows():
    rng = np.random.default_rng(26)
    n_slide = 0
    for _ in range(2000):
        b, h = rng.uniform(0.05, 1.0, 2)
        blk = SlidingBlock(b, h, rng.uniform(0.05, 1.2))
        s = int(rng.choice([-1, 1]))
        wm = s * -rng.uniform(1e-3, 3.0)  # towards the landing corner -s
        vm = rng.normal(0.0, 0.5) * (rng.random() < 0.7)
        res = impact(blk, s, wm, vm, 0.0, 0.0)
        before, after = energy(blk, s, 0.0, wm, vm), energy(blk, -s, 0.0, res.omega_plus, res.slip_rate_plus)
        assert after <= before * (1 + 1e-13)
        assert res.Pn >= 0 and abs(res.Pt) <= blk.mu * res.Pn * (1 + 1e-12)
        if not res.flat:
            # the generalised Housner relation about the landing corner
            I0 = 4 / 3 * blk.m * blk.R**2
            assert I0 * res.omega_plus + blk.m * h * res.slip_rate_plus == pytest.approx(
                blk.restitution * I0 * wm + blk.m * h * vm, rel=1e-12, abs=1e-12)
            if res.slip_rate_plus != 0:
                n_slide += 1
                assert math.copysign(1, res.slip_rate_plus) == -math.copysign(1, res.Pt)  # impulse opposes slip
    assert n_slide > 100


def test_each_mode_satisfies_newton_euler_solved_as_a_linear_system():
    """mode_forces against numpy's solution of m X'' = T - m a_h, m Y'' = N - m G,
    Ic w' = R sin(phi) N - R cos(phi) T, with X'', Y'' from the kinematics of the pivot."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        b, h = rng.uniform(0.05, 1.0, 2)
        blk = SlidingBlock(b, h, rng.uniform(0.05, 0.8))
        s, sigma = int(rng.choice([-1, 1])), int(rng.choice([-1, 1]))
        theta, omega = s * rng.uniform(0, 0.5 * blk.alpha), rng.normal(0, 2.0)
        ah, av = rng.normal(0, 5.0, 2)
        m, R, Gv, phi = blk.m, blk.R, blk.g + av, theta - s * blk.alpha
        sp, cp = math.sin(phi), math.cos(phi)
        Ic = m * R * R / 3
        # unknowns (w', u'', T, N); rows: x, y, moment, then the mode's own condition
        A = np.array([[m * R * cp, m, -1, 0], [-m * R * sp, 0, 0, -1], [Ic, 0, R * cp, -R * sp], [0, 0, 0, 0.0]])
        rhs = np.array([-m * ah + m * R * sp * omega**2, -m * Gv + m * R * cp * omega**2, 0, 0])
        for mode in (ROCK, SLIDE_ROCK):
            A[3] = [0, 1, 0, 0] if mode == ROCK else [0, 0, 1, sigma * blk.mu]  # u'' = 0 or T = -sigma mu N
            if mode == SLIDE_ROCK and 1 / 3 + (sp + sigma * blk.mu * cp) * sp <= 0.05:
                continue  # near the Painleve configuration, where slide-rock has no (or no unique) solution
            wd, ud, T, N = np.linalg.solve(A, rhs)
            f = mode_forces(blk, mode, s, sigma, theta, omega, ah, av)
            np.testing.assert_allclose([f.omega_dot, f.slip_acc, f.T, f.N], [wd, ud, T, N], rtol=1e-9, atol=1e-9)


def test_mode_switch_on_rest_follows_shenton():
    """From rest under a slowly growing push: slide if mu <= tan(alpha), else rock."""
    for mu, expected in ((0.5, SLIDE), (1.0, ROCK)):
        run = simulate(SlidingBlock(mu=mu, **SQUAT), sine_pulse(12.0, 0.5), 0.6)
        t, before, after = run.switches[0]
        assert (before, after) == (REST, expected)
        assert t == pytest.approx(math.asin(min(mu, 0.3 / 0.36) * G / 12.0) / math.pi, abs=1e-12)


# ------------------------------------------------------------------------------------- against the FMU

TIGHT = {"solver.relTol": 1e-12, "solver.absTol": 1e-14}
OUTPUTS = ["block1.slip", "block1.maxAbsSlip", "block1.mode", "block1.frictionLoss", "impactLoss", "groundWork",
           "energy"]
SWITCH_KINDS = ("slide", "stick", "uplift", "slide-rock", "rest", "reverse")


@dataclass
class FmuRun:
    events: list[tuple[str, float]]  # (kind, t) from the event log
    final: dict[str, float]  # outputs at the stop time

    def times(self, *kinds: str) -> np.ndarray:
        return np.array(sorted(t for k, t in self.events if k in kinds))


def run_fmu(fmu, params: dict, stop: float) -> FmuRun:
    """One fmi2DoStep over the whole run (the results do not depend on the communication step),
    the event log parsed line by line: "KIND t=... key=value ..."."""
    lines: list[str] = []
    slave, _cb = fmu.instantiate(lambda status, cat, msg: lines.append(msg) if cat == "logEvents" else None)
    try:
        slave.setupExperiment(startTime=0.0, stopTime=stop)
        fmu.set_parameters(slave, {"contact.model": 1, **TIGHT, **params})
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=stop)
        final = dict(zip(OUTPUTS, fmu._getter(slave, OUTPUTS)()))
        slave.terminate()
    finally:
        slave.freeInstance()
    events = []
    for line in lines:
        m = re.match(r"^(\S+) t=(\S+)", line)
        if m and m.group(1) != "peak":
            events.append((m.group(1), float(m.group(2))))
    return FmuRun(events, final)


@pytest.fixture(scope="module")
def sliding_fmu(fmu):
    if "contact.model" not in fmu.vars:
        pytest.skip("this FMU has no contact.model (rocking-sliding) yet")
    return fmu


def fmu_params(blk: SlidingBlock) -> dict:
    return {"block1.halfWidth": blk.b, "block1.halfHeight": blk.h, "block1.mass": blk.m, "g": blk.g,
            "contact.muGround": blk.mu}


def compare(fmu_run: FmuRun, ref, blk: SlidingBlock, tol: float = 1e-8) -> None:
    """Impact times, mode-switch times (every logged switch), overturn, peak and final slip, and the
    energy terms (to tol of the energy scale)."""
    np.testing.assert_allclose(fmu_run.times("impact"), ref.impact_times, rtol=0, atol=tol)
    ref_switches = sorted(t for k, t in ref.events if k in SWITCH_KINDS)
    # a slide-rock that lands, sticks and slides on at the same instant is logged by the FMU as no
    # switch at all (the contact slides through the impact): drop such cancelling pairs
    sw = ref.switches
    for (t1, o1, n1), (t2, o2, n2) in zip(sw, sw[1:]):
        if t1 == t2 and n1 == o2 and n2 == o1 and ref_switches.count(t1) >= 2:
            ref_switches.remove(t1)
            ref_switches.remove(t1)
    ref_switches = np.array(ref_switches)
    fmu_switches = fmu_run.times(*SWITCH_KINDS)
    if ref.overturned:
        np.testing.assert_allclose(fmu_run.times("overturn"), ref.event_times("overturn"), rtol=0, atol=tol)
    np.testing.assert_allclose(fmu_switches, ref_switches, rtol=0, atol=tol)
    assert fmu_run.final["block1.maxAbsSlip"] == pytest.approx(ref.peak_abs_slip, abs=tol)
    assert fmu_run.final["block1.slip"] == pytest.approx(ref.final_slip, abs=tol)
    scale = energy_scale(blk, ref)
    assert fmu_run.final["block1.frictionLoss"] == pytest.approx(ref.friction_loss[-1], abs=tol * scale)
    assert fmu_run.final["impactLoss"] == pytest.approx(ref.impact_loss[-1], abs=tol * scale)
    assert fmu_run.final["groundWork"] == pytest.approx(ref.ground_work[-1], abs=tol * scale)
    if not ref.overturned:  # the FMU's own balance (from rest: energy(t0) = 0)
        fin = fmu_run.final
        assert abs(fin["energy"] + fin["block1.frictionLoss"] + fin["impactLoss"] - fin["groundWork"]) <= 1e-9 * scale


PULSES = {
    "sine pulse that only slides": (SlidingBlock(mu=0.3, **SQUAT), sine_pulse(12.0, 2.0),
                                    {"excitation.kind": 1, "excitation.amplitude": 12.0,
                                     "excitation.frequency": 2.0}, 2.0),
    "sine pulse that rocks, then slide-rocks": (SlidingBlock(0.2, 0.4, 0.55), sine_pulse(8.0, 2.0),
                                                {"excitation.kind": 1, "excitation.amplitude": 8.0,
                                                 "excitation.frequency": 2.0}, 3.0),
    "sine pulse with a vertical component": (SlidingBlock(0.2, 0.4, 0.55), sine_pulse(8.0, 2.0, vertical=-3.0),
                                             {"excitation.kind": 1, "excitation.amplitude": 8.0,
                                              "excitation.frequency": 2.0, "excitation.verticalAmplitude": -3.0}, 3.0),
    "harmonic with stick phases": (SlidingBlock(mu=0.3, **SQUAT), harmonic(0.025, 2.0, cycles=3),
                                   {"excitation.kind": 3, "excitation.displacement": 0.025,
                                    "excitation.frequency": 2.0, "excitation.cycles": 3}, 2.5),
}


@pytest.mark.parametrize("case", PULSES)
def test_the_fmu_agrees_with_the_reference_on_pulses(sliding_fmu, case):
    blk, exc, params, stop = PULSES[case]
    ref = simulate(blk, exc, stop)
    got = run_fmu(sliding_fmu, {**fmu_params(blk), **params}, stop)
    compare(got, ref, blk)


RECORDS = {  # FEMA P695 record, component, scale, block, stop time
    "near-field 1a x2, squat block slides 0.27 m": ("nearfield_pulse", 1, "a", 2.0, SlidingBlock(mu=0.3, **SQUAT),
                                                    15.0),
    "far-field 1a x3, rocks, slide-rocks, overturns": ("farfield", 1, "a", 3.0, SlidingBlock(0.2, 0.4, 0.55), 20.0),
}


@pytest.mark.parametrize("case", RECORDS)
def test_the_fmu_agrees_with_the_reference_on_fema_records(sliding_fmu, tmp_path, case):
    from tests.test_records_fmu import fema_component, write_record

    record_set, index, component, scale, blk, stop = RECORDS[case]
    t, a = fema_component(record_set, index, component)
    t, a = np.append(t, t[-1] + (t[1] - t[0])), np.append(a, 0.0)  # ends without a jump
    path = write_record(tmp_path / "record.txt", t, a)
    ref = simulate(blk, record(t, a, scale=scale), stop)
    assert len(ref.switches) >= 10
    got = run_fmu(sliding_fmu, {**fmu_params(blk), "excitation.kind": 4, "excitation.file": str(path),
                                "excitation.scale": scale}, stop)
    compare(got, ref, blk)


def _overturning_pulse():
    """The rock-then-slide-rock block under a 12 m/s2 sine pulse at 2 Hz: it overturns from slide-rock."""
    blk = SlidingBlock(0.2, 0.4, 0.55)
    params = {**fmu_params(blk), "excitation.kind": 1, "excitation.amplitude": 12.0, "excitation.frequency": 2.0}
    return blk, sine_pulse(12.0, 2.0), params


def test_after_an_impact_the_fmu_slides_at_once_where_rocking_needs_more_than_mu(sliding_fmu):
    """The block of the rock-then-slide-rock pulse, at 12 m/s2: right after the impact at 0.45267 s rocking
    on the new corner needs |T| / N = 0.55042 > mu = 0.55, so the pivot slides (for 0.17 ms)."""
    blk, exc, params = _overturning_pulse()
    ref = simulate(blk, exc, 3.0)
    t_imp = ref.impact_times[0]
    after = [(t, new) for t, old, new in ref.switches if t_imp <= t < t_imp + 1e-3]
    assert [new for _, new in after] == [SLIDE_ROCK, ROCK]  # the reference: slides at the impact, sticks again
    got = run_fmu(sliding_fmu, params, 3.0)
    assert got.times("slide", "slide-rock")[1] == pytest.approx(t_imp, abs=1e-8)


def test_the_fmu_logs_no_stick_at_an_overturn(sliding_fmu):
    """Overturning from slide-rock is no switch to Rock (the FMU logged 'stick' there until main f4595b3)."""
    blk, exc, params = _overturning_pulse()
    ref = simulate(blk, exc, 3.0)
    assert ref.overturned
    got = run_fmu(sliding_fmu, params, 3.0)
    assert got.final["block1.mode"] == 4
    assert not [t for k, t in got.events if k == "stick" and t >= ref.event_times("overturn")[0] - 1e-8]


def test_the_fmu_locates_the_friction_limit_while_rocking(sliding_fmu):
    """b = 0.15 m, h = 0.45 m, mu = 1.02 b / h, a 15 m/s2 sine pulse at 2 Hz: the third stick-to-slip
    switch, where rocking's friction demand reaches mu while it rocks (mu N - |T| falls at ~570 N/s)."""
    blk = SlidingBlock(0.15, 0.45, 1.02 * 0.15 / 0.45)
    ref = simulate(blk, sine_pulse(15.0, 2.0), 3.0)
    (t_ref,) = [t for t, old, new in ref.switches if (old, new) == (ROCK, SLIDE_ROCK) and t > 1.0]
    got = run_fmu(sliding_fmu, {**fmu_params(blk), "excitation.kind": 1, "excitation.amplitude": 15.0,
                                "excitation.frequency": 2.0}, 3.0)
    (t_fmu,) = [t for t in got.times("slide") if 1.0 < t < 1.2]
    assert t_fmu == pytest.approx(t_ref, abs=1e-8)


LIFT_CASE = (SlidingBlock(0.3, 0.36, 0.9), 30.0, 3.0)  # block, A (m/s2), f (Hz) of a sine pulse


def test_where_rocking_would_need_tension_the_slip_reverses_and_the_block_stays_pressed():
    """Squat block, mu = 0.9 > tan(alpha), 30 m/s2 sine pulse at 3 Hz: its slide-rock slip stops at
    0.2125 s where rocking would need a tensile normal force; the reversed slide is the consistent mode
    (N > 0, slip acceleration along the new slip), and N stays compressive along the whole run."""
    blk, A, f = LIFT_CASE
    exc = sine_pulse(A, f)
    run = simulate(blk, exc, 3.0)
    (t,) = run.event_times("reverse")
    i = np.flatnonzero(run.t == t)[0]
    s = 1 if run.theta[i] > 0 else -1
    ah, av = exc.ground(t)
    rock = mode_forces(blk, ROCK, s, 0, run.theta[i], run.omega[i], ah, av)
    assert rock.N < 0  # rocking on the sticking pivot would pull the ground
    sigma = -1 if rock.T > 0 else 1
    rev = mode_forces(blk, SLIDE_ROCK, s, sigma, run.theta[i], run.omega[i], ah, av)
    assert rev.N > 0 and sigma * rev.slip_acc > 0
    assert run.min_normal > 0


def test_the_fmu_reverses_the_slip_where_rocking_would_need_tension(sliding_fmu):
    blk, A, f = LIFT_CASE
    ref = simulate(blk, sine_pulse(A, f), 3.0)
    got = run_fmu(sliding_fmu, {**fmu_params(blk), "excitation.kind": 1, "excitation.amplitude": A,
                                "excitation.frequency": f}, 3.0)
    assert got.times("lift").size == 0
    compare(got, ref, blk)


def test_where_slide_rock_has_no_solution_the_fmu_takes_the_consistent_contact_set_at_the_same_instant(sliding_fmu):
    """Painleve's paradox: with mu = 1.99 on a squat block (b/h = 1.29) the slide-rock entered at 0.3452 s has
    1/3 + sin(phi) (sin(phi) + sigma mu cos(phi)) <= 0, so no motion on the corner. The reference, which has no
    flight, stops there and says why; the FMU's complementarity problem finds the set that is consistent there,
    the corner leaving the ground (flight), at the same instant."""
    from model.sliding_reference import SlidingReferenceError

    b, h, mu, A, f = 0.28347391911154646, 0.22033535030990375, 1.9893482258777362, 27.023450946233417, 1.213497652940207
    with pytest.raises(SlidingReferenceError, match="Painleve") as ref_err:
        simulate(SlidingBlock(b, h, mu), sine_pulse(A, f), 3.0)
    got = run_fmu(sliding_fmu, {**fmu_params(SlidingBlock(b, h, mu)), "excitation.kind": 1,
                                "excitation.amplitude": A, "excitation.frequency": f}, 1.0)
    t_ref = float(re.search(r"from t=([0-9.eE+-]+)", str(ref_err.value)).group(1))
    (t_fmu,) = got.times("flight")[:1]
    assert t_fmu == pytest.approx(t_ref, abs=1e-8)
