"""Seed 001's closed forms (model/closed_form.py) against the linearised simulation of
model/solvers.py, an independent solver of the same equation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import closed_form as cf
from model.reference import Block
from model.solvers import Scene, sine_pulse, solve_event_driven

BLOCK = Block(0.05, 1.0)  # slender: alpha = 0.05 rad
ALPHA, P = BLOCK.alpha, math.sqrt(BLOCK.p2)


def simulate(a: float, w: float, eta: float, linear: bool = True):
    """The one-sine pulse of groups (a, omega) on BLOCK, from rest, long enough to settle the outcome."""
    ground, breaks = sine_pulse(a * BLOCK.g * ALPHA, w * P / (2 * math.pi))
    scene = Scene(BLOCK, eta, ground=ground, breaks=breaks, linear=linear)
    return solve_event_driven(scene, breaks[1] + 25.0 / P, rtol=1e-10, atol=1e-13)


def test_groups_reproduce_the_forced_solution():
    """At tau = 0 the forced solution starts from rest, and it solves the linear equation."""
    g = cf.groups(3.0, 2.0)
    assert cf.forced_theta(g, 0.0) == pytest.approx(0.0, abs=1e-13)
    assert cf.forced_rate(g, 0.0) == pytest.approx(0.0, abs=1e-13)
    tau, h = 0.7, 1e-4  # theta'' = theta + alpha - a alpha sin(omega tau + psi), in units of alpha/2
    f = [cf.forced_theta(g, tau + k * h) for k in (-1, 0, 1)]
    second = (f[0] - 2 * f[1] + f[2]) / h**2
    assert second == pytest.approx(f[1] + 2 - 2 * g.a * math.sin(g.w * tau + g.psi), rel=1e-6)


@pytest.mark.parametrize("w", [1.0, 2.0, 3.0, 5.0, 8.0])
@pytest.mark.parametrize("eta", [0.8, 0.95])
def test_overturning_classification_matches_the_linearised_simulation(w, eta):
    for a in (1.2, 1.8, 2.5, 3.5, 5.0, 8.0, 12.0):
        closed, case = cf.overturns(a, w, eta)
        assert closed == simulate(a, w, eta).overturned, (a, w, eta, case)


@pytest.mark.parametrize("w", [1.5, 3.0, 6.0])
def test_smallest_overturning_amplitude_agrees_within_one_percent(w):
    eta = 0.9
    closed = cf.smallest_overturning_a(lambda a, ww: cf.overturns(a, ww, eta)[0], w)
    simulated = cf.smallest_overturning_a(lambda a, ww: simulate(a, ww, eta).overturned, w, rel=1e-3)
    assert closed is not None and simulated is not None
    assert abs(simulated / closed - 1) < 0.01


def test_semi_analytical_impact_time_is_close_to_the_exact_root_near_tau_one():
    """Eq. 3.29 fits the sine by exponentials at tau = 1: close to the root of eq. 3.21 there."""
    checked = 0
    for w in (1.5, 2.0, 3.0, 4.0, 5.0):
        for a in (1.2, 1.5, 2.0):
            exact = cf.first_impact_in_pulse(cf.groups(a, w))
            if exact is None or not 0.75 < exact < 1.25:
                continue
            assert abs(cf.semi_analytical_impact_time(a, w) / exact - 1) < 0.05, (a, w, exact)
            checked += 1
    assert checked >= 4


def test_semi_analytical_boundary_is_the_exact_one_where_case_1_1_decides():
    """Seed 001: the smallest a from eq. 3.30 coincides with the one from eqs. 3.20-3.21."""
    eta, w = 0.9, 4.0
    exact = cf.smallest_overturning_a(lambda a, ww: (cf.case_11_margin(a, ww, eta) or -1.0) >= 0, w)
    approx = cf.smallest_overturning_a(lambda a, ww: cf.case_11_margin_semi_analytical(a, ww, eta) >= 0, w)
    assert exact is not None and approx is not None and abs(approx / exact - 1) < 0.01


def test_limit_where_the_impact_coincides_with_the_pulse_end():
    """Eq. 3.31 changes sign where the first impact moves from inside to after the pulse."""
    w = 3.0
    inside = [a for a in np.linspace(1.05, 10, 60) if cf.first_impact_in_pulse(cf.groups(a, w)) is not None]
    a_switch = max(inside)
    assert cf.impact_at_pulse_end_margin(a_switch * 0.97, w) * cf.impact_at_pulse_end_margin(a_switch * 1.05, w) < 0


@pytest.mark.parametrize("a,w", [(3.0, 6.0), (4.0, 8.0)])
def test_maximum_rotation_after_the_first_impact_is_eq_4_13(a, w):
    """When the first impact comes after the pulse, the next peak is theta_m = alpha (1 - sqrt(1 - eta^2 (1 - D)))."""
    eta = 0.9
    assert cf.first_impact_in_pulse(cf.groups(a, w)) is None and not cf.overturns(a, w, eta)[0]
    s = simulate(a, w, eta)
    peak = s.peak_thetas[[i for i, t in enumerate(s.peak_times) if t > s.impact_times[0]][0]]
    assert abs(peak) / ALPHA == pytest.approx(cf.max_rotation_after_impact(a, w, eta), rel=1e-6)


def test_invalid_groups_are_errors():
    with pytest.raises(ValueError, match="must exceed 1"):
        cf.groups(0.9, 2.0)
    with pytest.raises(ValueError, match="positive"):
        cf.groups(2.0, 0.0)
