"""The closed form of a Coulomb block on an accelerating base (model/sliding_closed_form.py):
against a plain numerical integration with its own stick-slip logic (scipy's DOP853 with
events), against the elementary solutions it must reduce to, and then the FMU's rocking-sliding
model (contact.model = 1) against it on a squat block that can only slide."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model.sliding_closed_form import coulomb_block, constant, harmonic, sine_pulse

G = 9.81
Accel = Callable[[float], float]


# ------------------------------------------------------------------ an independent numerical solution


def windowed(amplitude: float, frequency: float, t0: float, t_end: float) -> Accel:
    """amplitude * sin(2 pi f (t - t0)) on [t0, t_end), 0 elsewhere (the FMU's built-in sines)."""
    w = 2 * math.pi * frequency
    return lambda t: amplitude * math.sin(w * (t - t0)) if t0 <= t < t_end else 0.0


def integrate(ah: Accel, av: Accel, breaks: list[float], mu: float, t_stop: float, max_step: float):
    """Slip of a Coulomb block by DOP853 (rtol 1e-13; the right-hand side does not depend on the state,
    so it integrates to about 1e-15) with its own mode logic: while sticking, an
    event where |a_h| - mu (g + a_v) rises through 0; while sliding (u'' = -a_h - sigma mu (g + a_v)),
    an event where u' returns to 0, then stick if |a_h| <= mu (g + a_v), else slide back.
    Returns the switches [(kind, t)] and a function u(t)."""
    stops = sorted({t for t in breaks if 0 < t < t_stop} | {t_stop})
    t, y, sigma = 0.0, np.zeros(2), 0
    switches: list[tuple[str, float]] = []
    pieces: list[tuple[float, float, Callable]] = []

    def gap(t, y):
        return abs(ah(t)) - mu * (G + av(t))

    gap.terminal, gap.direction = True, 1

    while t < t_stop:
        end = next(s for s in stops if s > t)
        if sigma == 0 and gap(t, y) > 0:  # a jump of the ground motion at a break
            sigma = -1 if ah(t) > 0 else 1
            switches.append(("slide", t))
        if sigma == 0:
            sol = solve_ivp(lambda t, y: [0.0, 0.0], (t, end), y, events=gap, max_step=max_step,
                            rtol=1e-13, atol=1e-15)
            u_stuck = float(y[0])
            pieces.append((t, float(sol.t[-1]), lambda s, u=u_stuck: u))
            if sol.status == 1:
                t = float(sol.t_events[0][0])
                sigma = -1 if ah(t) > 0 else 1
                switches.append(("slide", t))
            else:
                t = end
            continue

        def rate(t, y):
            return y[1]

        rate.terminal, rate.direction = True, -sigma
        s = sigma
        sol = solve_ivp(lambda t, y: [y[1], -ah(t) - s * mu * (G + av(t))], (t, end), y, method="DOP853",
                        events=rate, dense_output=True, rtol=1e-13, atol=1e-15, max_step=max_step)
        pieces.append((t, float(sol.t[-1]), lambda x, d=sol.sol: float(d(x)[0])))
        if sol.status == 1:
            t = float(sol.t_events[0][0])
            y = np.array([sol.y_events[0][0][0], 0.0])
            if abs(ah(t)) <= mu * (G + av(t)):
                sigma = 0
                switches.append(("stick", t))
            else:
                sigma = -sigma
                switches.append(("reverse", t))
        else:
            t, y = end, sol.y[:, -1]

    def u(x: float) -> float:
        for a, b, f in pieces:
            if a <= x <= b:
                return f(x)
        raise ValueError(x)

    return switches, u


CASES = {
    # name: (closed-form ground, a_h, a_v, breaks, mu, t_stop)
    "one-sine pulse": (sine_pulse(4.0, 2.0), windowed(4.0, 2.0, 0, 0.5), lambda t: 0.0, [0.5], 0.3, 1.0),
    "three cycles, stick phases between": (sine_pulse(4.0, 2.0, cycles=3), windowed(4.0, 2.0, 0, 1.5),
                                           lambda t: 0.0, [1.5], 0.3, 2.0),
    "the issue's squat block (12 m/s2, 2 Hz, mu 0.3)": (sine_pulse(12.0, 2.0), windowed(12.0, 2.0, 0, 0.5),
                                                         lambda t: 0.0, [0.5], 0.3, 1.0),
    "pulse with a late start and a vertical sine": (
        sine_pulse(5.0, 1.5, cycles=2, t0=0.3, vertical=2.0), windowed(5.0, 1.5, 0.3, 0.3 + 2 / 1.5),
        windowed(2.0, 1.5, 0.3, 0.3 + 2 / 1.5), [0.3, 0.3 + 2 / 1.5], 0.35, 2.5),
    "pulse cut mid-slide (1.3 cycles) under a constant a_v": (
        sine_pulse(6.0, 3.0, cycles=1.3, av0=-0.3 * G), windowed(6.0, 3.0, 0, 1.3 / 3),
        lambda t: -0.3 * G, [1.3 / 3], 0.4, 1.2),
    "pulse on a constant a_h": (sine_pulse(3.5, 2.0, cycles=2, t0=0.2, ah0=-1.2),
                                lambda t: -1.2 + windowed(3.5, 2.0, 0.2, 1.2)(t), lambda t: 0.0, [0.2, 1.2], 0.2, 1.6),
    "harmonic, four cycles, stick phases": (harmonic(0.012, 2.5, cycles=4), windowed(-0.012 * (5 * math.pi) ** 2,
                                            2.5, 0, 1.6), lambda t: 0.0, [1.6], 0.2, 2.5),
    "endless harmonic with reversals": (harmonic(0.02, 2.5), windowed(-0.02 * (5 * math.pi) ** 2, 2.5, 0, math.inf),
                                        lambda t: 0.0, [], 0.1, 2.0),
    "harmonic with a vertical table motion": (harmonic(0.01, 3.0, cycles=3, vertical=3.0),
                                              windowed(-0.01 * (6 * math.pi) ** 2, 3.0, 0, 1.0),
                                              windowed(-3.0, 3.0, 0, 1.0), [1.0], 0.25, 1.5),
}


@pytest.mark.parametrize("case", list(CASES))
def test_closed_form_matches_a_numerical_integration_with_its_own_stick_slip_logic(case):
    ground, ah, av, breaks, mu, t_stop = CASES[case]
    exact = coulomb_block(ground, mu, t_stop, g=G)
    switches, u = integrate(ah, av, breaks, mu, t_stop, max_step=0.01 / ground.frequency)
    assert [k for k, _ in switches] == [s.kind for s in exact.switches]
    assert len(exact.switches) >= 2
    np.testing.assert_allclose([s.t for s in exact.switches], [t for _, t in switches], rtol=0, atol=1e-12)
    times = np.linspace(0, t_stop, 301)
    np.testing.assert_allclose(exact.slip(times), [u(t) for t in times], rtol=0, atol=1e-12)
    # u' is the derivative of u (central differences of the closed form)
    inner = times[1:-1]
    d = 1e-6
    np.testing.assert_allclose(exact.slip_rate(inner), (exact.slip(inner + d) - exact.slip(inner - d)) / (2 * d),
                               rtol=0, atol=1e-7)


def test_the_cases_cover_stick_phases_reversals_and_slides_over_a_break():
    kinds = {case: [s.kind for s in coulomb_block(c[0], c[4], c[5], g=G).switches] for case, c in CASES.items()}
    assert kinds["three cycles, stick phases between"].count("stick") >= 3
    assert "reverse" in kinds["endless harmonic with reversals"]
    assert "reverse" in kinds["the issue's squat block (12 m/s2, 2 Hz, mu 0.3)"]
    cut = coulomb_block(*CASES["pulse cut mid-slide (1.3 cycles) under a constant a_v"][0:1], 0.4, 1.2, g=G)
    end = 1.3 / 3
    assert cut.slip_rate(end) != 0 and cut.times("stick")[-1] > end  # still sliding when the pulse stops


@pytest.mark.parametrize("A, f, mu, t0", [(4.0, 2.0, 0.3, 0.0), (12.0, 2.0, 0.3, 0.25), (3.0, 5.0, 0.1, 1.0)])
def test_stick_to_slip_from_rest_is_at_asin_mu_g_over_a(A, f, mu, t0):
    s = coulomb_block(sine_pulse(A, f, t0=t0), mu, t0 + 1 / f, g=G)
    assert s.switches[0].kind == "slide" and s.switches[0].sigma == -1  # the ground pulls away to +x
    assert s.first_slide_time == pytest.approx(t0 + math.asin(mu * G / A) / (2 * math.pi * f), rel=0, abs=1e-15)
    assert s.slip(s.first_slide_time) == 0.0


def test_a_constant_push_gives_the_uniformly_accelerated_slide():
    """a_h > mu (g + a_v) from t = 0: u = -(a_h - mu (g + a_v)) t^2 / 2, sliding from the start."""
    ah, av, mu = 5.0, 1.5, 0.3
    s = coulomb_block(constant(ah, av), mu, 2.0, g=G)
    assert [(w.kind, w.t, w.sigma) for w in s.switches] == [("slide", 0.0, -1)]
    t = np.linspace(0, 2, 11)
    np.testing.assert_allclose(s.slip(t), -(ah - mu * (G + av)) * t**2 / 2, rtol=1e-14, atol=1e-16)
    assert s.slide_duration == 2.0
    rest = coulomb_block(constant(-2.0, -1.0), mu, 1.0, g=G)  # |a_h| < mu (g + a_v): it stays
    assert rest.switches == [] and rest.max_abs_slip == 0.0 and rest.first_slide_time == -1


def test_a_block_that_slides_within_the_pulse_ends_where_the_relative_velocity_returns_to_zero():
    """Stuck again once the slip rate is zero and |a_h| <= mu g: u' = 0 there is the integral of
    -a_h + mu g from the slide's start, a scalar identity independent of the phase logic."""
    A, f, mu = 4.0, 2.0, 0.3
    s = coulomb_block(sine_pulse(A, f), mu, 0.5, g=G)
    t1, t2 = s.times("slide")[0], s.times("stick")[0]
    w = 2 * math.pi * f
    impulse = A / w * (math.cos(w * t1) - math.cos(w * t2)) - mu * G * (t2 - t1)  # integral of a_h - mu g
    assert abs(impulse) < 1e-14 and abs(A * math.sin(w * t2)) <= mu * G


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="mu"):
        coulomb_block(sine_pulse(4.0, 2.0), 0.0, 1.0)
    with pytest.raises(ValueError, match="mu"):
        coulomb_block(sine_pulse(4.0, 2.0), float("nan"), 1.0)
    with pytest.raises(ValueError, match="leave the ground"):
        coulomb_block(sine_pulse(4.0, 2.0, vertical=12.0), 0.3, 1.0)


# ------------------------------------------------------------------ the FMU against the closed form

SQUAT = {"block1.halfWidth": 0.3, "block1.halfHeight": 0.36, "block1.mass": 50.0, "block1.theta0": 0.0,
         "contact.model": 1}  # b/h = 0.83: with mu < b/h the block can only slide
OUT = ["block1.slip", "block1.slipRate", "block1.mode", "block1.theta", "block1.maxAbsSlip",
       "block1.slideDuration", "block1.slideStartTime", "block1.slides"]
EVENT_KINDS = ("slide", "stick", "reverse", "slide-rock", "uplift", "impact", "rest")


def run_fmu(fmu, params: dict, stop: float, step: float):
    """Sampled outputs and the event log's lines [(kind, {key: value})] of one FMU run."""
    lines: list[str] = []
    errors: list[str] = []

    def log(status, category, message):
        if status >= 3:
            errors.append(message)
        elif category == "logEvents":
            lines.append(message)

    slave, _cb = fmu.instantiate(log)
    vrs = [fmu.variable(n) for n in OUT]
    n = int(round(stop / step))
    rows = []
    try:
        try:
            slave.setupExperiment(startTime=0.0, stopTime=stop)
            fmu.set_parameters(slave, params)
            slave.enterInitializationMode()
            slave.exitInitializationMode()

            def get():
                real = slave.getReal([v.valueReference for v in vrs if v.type == "Real"])
                ints = slave.getInteger([v.valueReference for v in vrs if v.type == "Integer"])
                it_r, it_i = iter(real), iter(ints)
                return [next(it_r) if v.type == "Real" else next(it_i) for v in vrs]

            rows.append(get())
            for i in range(n):
                slave.doStep(currentCommunicationPoint=i * step, communicationStepSize=step)
                rows.append(get())
        except Exception as exc:
            raise AssertionError(errors[-1] if errors else str(exc)) from None
    finally:
        slave.freeInstance()
    data = np.array(rows, dtype=float)
    events = []
    for line in lines:
        kind, _, rest = line.partition(" ")
        if kind in EVENT_KINDS:
            values = dict(item.partition("=")[::2] for item in rest.split())
            events.append((kind, values))
    return step * np.arange(n + 1), {k: data[:, j] for j, k in enumerate(OUT)}, events


def fmu_switches(events) -> list[tuple[str, float]]:
    """The FMU's mode switches of the sliding model as (kind, t): slide (with sigma), stick, reverse."""
    return [(k, float(v["t"])) for k, v in events if k in ("stick", "reverse") or (k == "slide" and "sigma" in v)]


def excitation(kind: int, **kw) -> dict:
    names = {"A": "excitation.amplitude", "f": "excitation.frequency", "cycles": "excitation.cycles",
             "t0": "excitation.startTime", "V": "excitation.verticalAmplitude", "D": "excitation.displacement",
             "ah": "ground.ah", "av": "ground.av"}
    return {"excitation.kind": kind, **{names[k]: v for k, v in kw.items()}}


FMU_CASES = {
    # name: (FMU parameters, closed-form ground, mu, stop time)
    "one-sine pulse": (excitation(1, A=4.0, f=2.0, cycles=1), sine_pulse(4.0, 2.0), 0.3, 1.0),
    "three cycles with stick phases": (excitation(1, A=5.0, f=2.5, cycles=3, t0=0.1),
                                       sine_pulse(5.0, 2.5, cycles=3, t0=0.1), 0.3, 1.6),
    "pulse under a constant a_v": (excitation(1, A=4.0, f=1.5, cycles=2, av=-0.3 * G),
                                   sine_pulse(4.0, 1.5, cycles=2, av0=-0.3 * G), 0.25, 1.8),
    "pulse with a vertical sine": (excitation(1, A=5.0, f=2.0, cycles=2, V=2.5),
                                   sine_pulse(5.0, 2.0, cycles=2, vertical=2.5), 0.35, 1.5),
    "pulse on a constant a_h": (excitation(1, A=3.5, f=2.0, cycles=2, t0=0.2, ah=-1.2),
                                sine_pulse(3.5, 2.0, cycles=2, t0=0.2, ah0=-1.2), 0.2, 1.6),
    "constant push from the start": (excitation(0, ah=4.0, av=1.0), constant(4.0, 1.0), 0.3, 0.5),
    "harmonic table, five cycles": (excitation(3, D=0.015, f=2.5, cycles=5), harmonic(0.015, 2.5, cycles=5),
                                    0.2, 2.5),
    "harmonic with a vertical table motion": (excitation(3, D=0.01, f=3.0, cycles=3, V=3.0),
                                              harmonic(0.01, 3.0, cycles=3, vertical=3.0), 0.25, 1.5),
    "harmonic with reversals": (excitation(3, D=0.02, f=2.5, cycles=4), harmonic(0.02, 2.5, cycles=4), 0.1, 2.0),
}


@pytest.mark.parametrize("case", list(FMU_CASES))
def test_fmu_slip_and_switches_match_the_closed_form(fmu, case):
    """A squat block with mu < b/h under motions below the uplift threshold: the FMU's slip to
    1e-9 m at every communication point, its mode switches (event log) to 1e-9 s, the block
    never tilts, and the summaries (peak slip, time sliding, first slide, slide count) agree."""
    params, ground, mu, stop = FMU_CASES[case]
    peak_ah = max(abs(ground.ah0) + abs(ground.amplitude), 1e-300)
    assert peak_ah < SQUAT["block1.halfWidth"] / SQUAT["block1.halfHeight"] * (G + ground.av0 - abs(ground.vertical))
    exact = coulomb_block(ground, mu, stop, g=G)
    t, out, events = run_fmu(fmu, {**SQUAT, **params, "contact.muGround": mu}, stop, 0.01)
    np.testing.assert_allclose(out["block1.slip"], exact.slip(t), rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["block1.slipRate"], exact.slip_rate(t), rtol=0, atol=1e-9)
    assert np.all(out["block1.theta"] == 0.0)
    expected = [(s.kind, s.t) for s in exact.switches]
    got = fmu_switches(events)
    assert [k for k, _ in got] == [k for k, _ in expected], (got, expected)
    np.testing.assert_allclose([x for _, x in got], [x for _, x in expected], rtol=0, atol=1e-9)
    assert [int(float(v["sigma"])) for k, v in events if k in ("slide", "reverse")] == \
        [s.sigma for s in exact.switches if s.kind in ("slide", "reverse")]
    assert out["block1.maxAbsSlip"][-1] == pytest.approx(exact.max_abs_slip, abs=1e-9)
    assert out["block1.slideDuration"][-1] == pytest.approx(exact.slide_duration, abs=1e-9)
    assert out["block1.slideStartTime"][-1] == pytest.approx(exact.first_slide_time, abs=1e-12)
    assert out["block1.slides"][-1] == len(exact.times("slide"))
    sliding = np.array([exact.phase_at(x).sigma != 0 for x in t])
    away = np.array([min(abs(x - s.t) for s in exact.switches) > 1e-6 for x in t])
    np.testing.assert_array_equal(out["block1.mode"][away], np.where(sliding[away], 1, 0))


@pytest.mark.parametrize("A, f, mu, t0", [(4.0, 2.0, 0.3, 0.0), (6.5, 3.0, 0.5, 0.37), (2.0, 1.0, 0.1, 0.05)])
def test_fmu_starts_to_slide_from_rest_at_asin_mu_g_over_a(fmu, A, f, mu, t0):
    """Stick to slip from rest at t0 + asin(mu g / A) / (2 pi f), to 1e-12 s, sliding to -x."""
    expected = t0 + math.asin(mu * G / A) / (2 * math.pi * f)
    stop = t0 + 0.5 / f
    _, out, events = run_fmu(fmu, {**SQUAT, **excitation(1, A=A, f=f, cycles=1, t0=t0), "contact.muGround": mu},
                             stop, stop / 4)
    slides = [(float(v["t"]), float(v["sigma"])) for k, v in events if k == "slide" and "sigma" in v]
    assert slides and slides[0][1] == -1
    assert abs(slides[0][0] - expected) <= 1e-12
    assert abs(out["block1.slideStartTime"][-1] - expected) <= 1e-12


def test_fmu_squat_block_of_the_issue_slides_and_never_rocks(fmu):
    """Half sizes 0.3 m x 0.36 m, mu = 0.3, a 12 m/s2 one-sine pulse at 2 Hz: above the uplift
    threshold g b / h, but friction cannot carry the force uplift needs; it slides (peak about
    0.24 m) exactly as the Coulomb block does."""
    ground = sine_pulse(12.0, 2.0)
    exact = coulomb_block(ground, 0.3, 1.0, g=G)
    t, out, events = run_fmu(fmu, {**SQUAT, **excitation(1, A=12.0, f=2.0, cycles=1), "contact.muGround": 0.3},
                             1.0, 0.01)
    assert 12.0 > G * 0.3 / 0.36 and np.all(out["block1.theta"] == 0.0)
    assert not [k for k, _ in events if k in ("uplift", "slide-rock", "impact")]
    np.testing.assert_allclose(out["block1.slip"], exact.slip(t), rtol=0, atol=1e-9)
    assert out["block1.maxAbsSlip"][-1] == pytest.approx(exact.max_abs_slip, abs=1e-9)
    assert 0.23 < exact.max_abs_slip < 0.25


def random_cases(n: int, seed: int):
    """Random sine pulses and harmonics below the squat block's uplift threshold, with mu, a
    constant a_h and a_v and a vertical sine: (FMU parameters, closed-form ground, mu, stop)."""
    rng = np.random.default_rng(seed)
    beta = SQUAT["block1.halfWidth"] / SQUAT["block1.halfHeight"]
    out = []
    while len(out) < n:
        mu, f = rng.uniform(0.05, 0.6), rng.uniform(0.5, 6.0)
        cycles, t0 = float(rng.integers(1, 4)) + rng.choice([0.0, 0.5]), rng.uniform(0.0, 0.3)
        ah0, av0, V = rng.uniform(-1.0, 1.0), rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0)
        A = rng.uniform(1.0, 8.0) * rng.choice([-1, 1])
        if abs(ah0) + abs(A) >= 0.95 * beta * (G + av0 - abs(V)):
            continue  # the block must not be able to tip
        if rng.random() < 0.5:
            params, ground = excitation(1, A=A, f=f, cycles=cycles, t0=t0, V=V, ah=ah0, av=av0), \
                sine_pulse(A, f, cycles, t0, V, ah0, av0)
        else:
            D = A / (2 * math.pi * f) ** 2
            params, ground = excitation(3, D=D, f=f, cycles=cycles, t0=t0, V=V, ah=ah0, av=av0), \
                harmonic(D, f, cycles, t0, V, ah0, av0)
        out.append((params, ground, mu, t0 + cycles / f + 0.5))
    return out


def test_closed_form_matches_the_numerical_integration_on_random_motions():
    for params, ground, mu, stop in random_cases(12, seed=7):
        exact = coulomb_block(ground, mu, stop, g=G)
        ah = lambda t, gr=ground: gr(t)[0]  # noqa: E731
        av = lambda t, gr=ground: gr(t)[1]  # noqa: E731
        switches, u = integrate(ah, av, list(ground.breaks()), mu, stop, max_step=0.01 / ground.frequency)
        assert [k for k, _ in switches] == [s.kind for s in exact.switches], params
        np.testing.assert_allclose([s.t for s in exact.switches], [t for _, t in switches], rtol=0, atol=1e-11)
        times = np.linspace(0, stop, 101)
        np.testing.assert_allclose(exact.slip(times), [u(t) for t in times], rtol=0, atol=1e-11)


def test_fmu_matches_the_closed_form_on_random_motions(fmu):
    """40 random pulses and harmonic table motions (with constant a_h, a_v and a vertical sine)
    on the squat block: slip to 1e-9 m, switches to 1e-9 s."""
    for params, ground, mu, stop in random_cases(40, seed=26):
        t, out, events = run_fmu(fmu, {**SQUAT, **params, "contact.muGround": mu}, stop, stop / 50)
        exact = coulomb_block(ground, mu, float(t[-1]), g=G)  # 50 steps of stop / 50: t[-1] may differ by an ulp
        np.testing.assert_allclose(out["block1.slip"], exact.slip(t), rtol=0, atol=1e-9, err_msg=str(params))
        got = fmu_switches(events)
        assert [k for k, _ in got] == [s.kind for s in exact.switches], params
        np.testing.assert_allclose([x for _, x in got], [s.t for s in exact.switches], rtol=0, atol=1e-9,
                                   err_msg=str(params))
