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
