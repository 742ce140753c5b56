"""Intensity measures (runners.engine.intensity) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from runners.engine.intensity import G0, measures, significant_duration

D, F, CYCLES = 0.05, 2.0, 10  # a table displacement D cos(w t) for 10 cycles
W = 2 * math.pi * F


@pytest.fixture(scope="module")
def cosine_record():
    """a(t) = -D w^2 cos(w t): v = -D w sin(w t), d = D (cos(w t) - 1), whose least-squares line is the
    constant -D over whole cycles, so PGD = D, PGV = D w, PGA = D w^2 exactly."""
    t = np.linspace(0.0, CYCLES / F, 20 * 2000 + 1)
    return t, -D * W * W * np.cos(W * t)


def test_peaks_and_arias_intensity_of_a_cosine_record(cosine_record):
    t, a = cosine_record
    m = measures(t, a)
    assert m.pga == pytest.approx(D * W * W, rel=1e-12)
    # interpolation between samples 1/2000 of a cycle apart costs at most (w dt)^2 / 8 relative
    assert m.pgv == pytest.approx(D * W, rel=2e-6)
    assert m.pgd == pytest.approx(D, rel=2e-6)
    T = CYCLES / F
    assert m.arias == pytest.approx(math.pi / (2 * G0) * (D * W * W) ** 2 * T / 2, rel=2e-6)
    assert m.pgv_pga == pytest.approx(1 / W, rel=2e-6)


def test_significant_duration_of_a_sine_record_against_its_closed_form():
    # cumulative a^2 of A sin(w t) is A^2 (t / 2 - sin(2 w t) / (4 w)); the 5 % and 95 % times by root finding
    f, n = 1.3, 7.25
    t = np.linspace(0.0, n / f, 7 * 4000 + 1001)
    w = 2 * math.pi * f
    cum = lambda x: x / 2 - math.sin(2 * w * x) / (4 * w)  # noqa: E731
    total = cum(t[-1])
    t5 = brentq(lambda x: cum(x) - 0.05 * total, 0, t[-1])
    t95 = brentq(lambda x: cum(x) - 0.95 * total, 0, t[-1])
    assert significant_duration(t, 3.0 * np.sin(w * t)) == pytest.approx(t95 - t5, abs=1e-6)


def test_measures_are_exact_for_a_piecewise_linear_record():
    """A triangle (0, 0), (1, 1), (2, 0) m/s^2 is what the FMU integrates: v(2) = 1 m/s exactly,
    the integral of a^2 is 2/3, the 5 % time solves t^3 / 3 = 0.05 * 2/3."""
    t, a = np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 0.0])
    m = measures(t, a)
    assert m.pga == 1.0 and m.pgv == pytest.approx(1.0, rel=1e-15)
    assert m.arias == pytest.approx(math.pi / (2 * G0) * 2 / 3, rel=1e-15)
    t5 = (0.1) ** (1 / 3)  # t^3 / 3 = 0.05 * 2 / 3
    t95 = 2 - t5  # by symmetry
    assert m.d5_95 == pytest.approx(t95 - t5, rel=1e-12)
    # a velocity peak inside a segment (where a crosses zero): a = 1, -1 gives v(0.5) = 0.25
    assert measures(np.array([0.0, 1.0]), np.array([1.0, -1.0])).pgv == pytest.approx(0.25, rel=1e-15)


def test_mean_period_of_two_sines_is_the_weighted_harmonic_mean_of_their_periods():
    """Rathje et al. (1998): Tm = sum(C^2 / f) / sum(C^2); two sines A1, A2 at f1, f2 give
    (A1^2 / f1 + A2^2 / f2) / (A1^2 + A2^2) when the record holds whole cycles of both."""
    t = np.arange(0, 200.0, 0.005)
    a = 1.0 * np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.sin(2 * np.pi * 4.0 * t)
    assert measures(t, a).mean_period == pytest.approx((1 / 1.0 + 0.25 / 4.0) / 1.25, rel=1e-6)


def test_scaling_and_sign_change_the_measures_as_they_should(cosine_record):
    t, a = cosine_record
    m, m2 = measures(t, a), measures(t, -2.5 * a)
    for k in ("pga", "pgv", "pgd"):
        assert getattr(m2, k) == pytest.approx(2.5 * getattr(m, k), rel=1e-12)
    assert m2.arias == pytest.approx(6.25 * m.arias, rel=1e-12)
    assert m2.d5_95 == pytest.approx(m.d5_95, rel=1e-9) and m2.mean_period == pytest.approx(m.mean_period, rel=1e-12)


def test_irregular_sampling_gives_the_same_measures_as_regular_sampling_of_the_same_lines():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 4, 801)
    a = rng.standard_normal(t.size)
    # add points on the straight lines between samples: the signal is unchanged
    extra = np.sort(rng.uniform(0, 4, 300))
    t2 = np.union1d(t, extra)
    a2 = np.interp(t2, t, a)
    m, m2 = measures(t, a), measures(t2, a2)
    for k in ("pga", "pgv", "pgd", "arias", "d5_95"):
        assert getattr(m2, k) == pytest.approx(getattr(m, k), rel=1e-9), k


@pytest.mark.parametrize("t,a,msg", [([0.0], [1.0], "at least two"), ([0.0, 1.0, 1.0], [0, 1, 2], "increase"),
                                     ([0.0, np.nan], [0, 1], "finite")])
def test_bad_series_are_refused(t, a, msg):
    with pytest.raises(ValueError, match=msg):
        measures(np.array(t, float), np.array(a, float))
