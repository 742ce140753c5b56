"""The exact free-rocking reference checked against independent closed forms."""

import math

import pytest

from model.reference import Block, free_rocking, housner_restitution, modified_restitution, quarter_period


def test_quarter_period_matches_linearised_closed_form_for_a_slender_block():
    # theta'' = -p^2 (alpha - theta) gives theta = alpha - (alpha - tp) cosh(p t)
    blk = Block(0.001, 0.1)  # alpha = 0.01 rad
    tp = 0.5 * blk.alpha
    linear = math.acosh(blk.alpha / (blk.alpha - tp)) / math.sqrt(blk.p2)
    assert quarter_period(blk, tp) == pytest.approx(linear, rel=1e-4)


def test_quarter_period_matches_direct_ode_integration():
    from scipy.integrate import solve_ivp

    blk = Block(0.1, 0.3)
    tp = 0.25

    def rhs(t, y):
        return [y[1], -blk.p2 * math.sin(blk.alpha - y[0])]

    hit = lambda t, y: y[0]  # noqa: E731
    hit.terminal = True
    sol = solve_ivp(rhs, (0, 5), [tp, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, events=hit)
    assert quarter_period(blk, tp) == pytest.approx(sol.t_events[0][0], rel=1e-9)


def test_restitution_laws_agree_at_their_limits():
    a = 0.4
    assert modified_restitution(a, 1.0) == pytest.approx(housner_restitution(a), rel=1e-15)
    assert modified_restitution(a, 0.0) == pytest.approx(1.0, rel=1e-15)


def test_elastic_free_rocking_repeats_its_peak():
    blk = Block(0.1, 0.3)
    ref = free_rocking(blk, 0.2, 1.0, 4)
    assert ref.peak_thetas == pytest.approx([-0.2, 0.2, -0.2, 0.2], rel=1e-12)
