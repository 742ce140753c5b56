"""Two-block equations of motion (model/two_blocks.py) against independent checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model import two_blocks as tb
from model.two_blocks import Stack, accelerations, centres, energy, locked_acceleration, mass_matrix

# seed 000 Table 2: lower block 1 (120 x 29 mm, 1.3 kg) and upper block 4 (100 x 60 mm, 2.3 kg), half dimensions
THESIS = Stack(b1=0.0145, h1=0.060, m1=1.3, b2=0.030, h2=0.050, m2=2.3)
SLENDER_ON_WIDE = Stack(b1=0.10, h1=0.20, m1=20.0, b2=0.04, h2=0.25, m2=5.0)
PIVOTS = [(1, 1), (1, -1), (-1, 1), (-1, -1)]


def _integrate(st, q0, w0, s1, s2, t_end=5.0, ah=0.0, rtol=1e-12):
    def rhs(t, y):
        return np.concatenate([y[2:], accelerations(st, y[:2], y[2:], s1, s2, ah)])

    return solve_ivp(rhs, (0, t_end), [*q0, *w0], method="DOP853", rtol=rtol, atol=1e-2 * rtol, dense_output=True)


@pytest.mark.parametrize("st", [THESIS, SLENDER_ON_WIDE], ids=["thesis", "slender_on_wide"])
@pytest.mark.parametrize("s1,s2", PIVOTS)
def test_free_motion_conserves_energy(st, s1, s2):
    """With the pivots held fixed the stack tumbles through full turns within 2 s,
    which exercises every velocity-product term; the energy drift is the
    integrator's (it falls tenfold per decade of rtol), not the model's."""
    q0, w0 = [0.02 * s1, 0.05 * s2], [0.3, -0.4]
    sol = _integrate(st, q0, w0, s1, s2, t_end=2.0, rtol=1e-13)
    e = [energy(st, y[:2], y[2:], s1, s2) for y in sol.y.T]
    scale = abs(e[0]) + st.g * (st.m1 * st.h1 + st.m2 * st.h2) * 1e-2
    assert np.max(np.abs(np.array(e) - e[0])) / scale < 1e-9


@pytest.mark.parametrize("st", [THESIS, SLENDER_ON_WIDE], ids=["thesis", "slender_on_wide"])
def test_mirror_symmetry_of_the_equations(st):
    rng = np.random.default_rng(1)
    for _ in range(50):
        q, w = rng.normal(0, 0.1, 2), rng.normal(0, 1.0, 2)
        s1, s2 = PIVOTS[rng.integers(4)]
        ah, av = rng.normal(0, 3), rng.normal(0, 1)
        a = accelerations(st, q, w, s1, s2, ah, av)
        m = accelerations(st, -q, -w, -s1, -s2, -ah, av)
        np.testing.assert_allclose(m, -a, rtol=1e-12, atol=1e-12)


def test_mirror_symmetry_of_trajectories():
    st = THESIS
    a = _integrate(st, [0.01, 0.03], [0.0, 0.0], 1, 1, t_end=0.3, ah=2.0)
    b = _integrate(st, [-0.01, -0.03], [0.0, 0.0], -1, -1, t_end=0.3, ah=-2.0)
    t = np.linspace(0, 0.3, 50)
    np.testing.assert_allclose(b.sol(t), -a.sol(t), rtol=0, atol=1e-12)


def test_single_block_limit_is_housner_equation():
    """A vanishing upper block leaves the lower block's classic equation of motion."""
    st = Stack(b1=0.1, h1=0.3, m1=10.0, b2=1e-6, h2=1e-6, m2=1e-12)
    R, alpha = math.hypot(0.1, 0.3), math.atan(1 / 3)
    for theta, s1, ah in [(0.05, 1, 0.0), (-0.1, -1, 1.5), (0.2, 1, -2.0)]:
        a = accelerations(st, [theta, theta], [0.3, 0.3], s1, 1, ah)[0]
        exact = -3 / (4 * R) * (9.81 * math.sin(s1 * alpha - theta) + ah * math.cos(s1 * alpha - theta))
        assert a == pytest.approx(exact, rel=1e-9)


@pytest.mark.parametrize("s1,s2", PIVOTS)
def test_locked_pair_is_one_rigid_body(s1, s2):
    """Locked, the stack turns about block 1's corner like one body: compare with
    the parallel-axis moment of inertia and the gravity moment of the combined centre."""
    st = SLENDER_ON_WIDE
    for theta, omega, ah in [(0.03 * s1, 0.2, 0.0), (0.08 * s1, -0.5, 1.0)]:
        P = np.array([s1 * st.b1, 0.0])
        r1, r2 = centres(st, np.array([theta, theta]), s1, s2)
        I = st.Ic1 + st.m1 * np.sum((r1 - P) ** 2) + st.Ic2 + st.m2 * np.sum((r2 - P) ** 2)
        # moment (clockwise positive) of gravity and of the inertial force -m a_h about P
        moment = 0.0
        for m, r in ((st.m1, r1), (st.m2, r2)):
            d = r - P
            F = np.array([-m * ah, -m * st.g])
            moment += -(d[0] * F[1] - d[1] * F[0])  # clockwise = minus the counter-clockwise z moment
        assert locked_acceleration(st, theta, omega, s1, s2, ah) == pytest.approx(moment / I, rel=1e-12)


def test_mass_matrix_is_symmetric_positive_definite():
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = rng.normal(0, 0.3, 2)
        for s1, s2 in PIVOTS:
            M = mass_matrix(THESIS, q, s1, s2)
            assert np.allclose(M, M.T, rtol=0, atol=1e-15)
            assert np.all(np.linalg.eigvalsh(M) > 0)


# ----------------------------------------------------------------- impacts

from model.two_blocks import angular_momentum, impact_map, pivot_K  # noqa: E402


def test_impact_map_reduces_to_housner_for_one_block():
    st = Stack(b1=0.1, h1=0.3, m1=10.0, b2=1e-6, h2=1e-6, m2=1e-12)
    alpha = math.atan(1 / 3)
    w = impact_map(st, [0.0, 0.0], [-1.0, -1.0], old=(1, 1), new=(-1, 1))
    assert w[0] == pytest.approx(-(1 - 1.5 * math.sin(alpha) ** 2), rel=1e-9)


def _random_impacts(rng, n):
    for _ in range(n):
        s1, s2 = PIVOTS[rng.integers(4)]
        w = rng.normal(0, 1.0, 2)
        kind = rng.integers(2)
        if kind == 0:  # block 1 lands on the ground: theta1 = 0, its pivot flips
            q = np.array([0.0, rng.normal(0, 0.1)])
            yield q, w, (s1, s2), (-s1, s2), "ground"
        else:  # block 2 lands on block 1: theta2 = theta1, its pivot flips
            t = rng.normal(0, 0.1)
            yield np.array([t, t]), w, (s1, s2), (s1, -s2), "interface"


@pytest.mark.parametrize("st", [THESIS, SLENDER_ON_WIDE], ids=["thesis", "slender_on_wide"])
def test_impacts_never_increase_energy(st):
    rng = np.random.default_rng(3)
    for q, w, old, new, _ in _random_impacts(rng, 200):
        wp = impact_map(st, q, w, old, new)
        assert energy(st, q, wp, *new) <= energy(st, q, w, *old) + 1e-12 * abs(energy(st, q, w, *old))


@pytest.mark.parametrize("st", [THESIS, SLENDER_ON_WIDE], ids=["thesis", "slender_on_wide"])
def test_impact_map_conserves_the_angular_momenta_of_seed_000_eq_32(st):
    """Ground impact: the system about the new ground corner and block 2 about K.
    Interface impact: the system about the ground pivot and block 2 about its new pivot K'."""
    rng = np.random.default_rng(4)
    for q, w, old, new, kind in _random_impacts(rng, 200):
        wp = impact_map(st, q, w, old, new)
        P_new = np.array([new[0] * st.b1, 0.0])
        K_new = pivot_K(st, q, *new)
        checks = [(P_new, (1, 2)), (K_new, (2,))]
        for point, blocks in checks:
            before = angular_momentum(st, q, w, *old, point, blocks)
            after = angular_momentum(st, q, wp, *new, point, blocks)
            scale = max(1.0, abs(before)) * (st.m1 + st.m2) * (st.b1 + st.h1 + st.h2) ** 2
            assert abs(after - before) <= 1e-12 * scale, (kind, point, blocks)


def test_impact_map_is_mirror_symmetric():
    rng = np.random.default_rng(5)
    for q, w, old, new, _ in _random_impacts(rng, 50):
        a = impact_map(THESIS, q, w, old, new)
        b = impact_map(THESIS, -q, -w, (-old[0], -old[1]), (-new[0], -new[1]))
        np.testing.assert_allclose(b, -a, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("ratio", [1 / 12, 0.5, 1.0, 3.0, 12.0])
def test_a_rectangle_cut_in_two_stays_locked_in_free_rocking(ratio):
    """The evidence for --method auto's locked-stack rule: at every angle and rate that free
    rocking of the combined rectangle reaches, the interface keeps a positive reaction margin, and
    the impulses of its impacts can be carried (equal widths and densities, h1 / h2 = ratio)."""
    b, H = 0.1, 0.6
    h2 = H / (1 + ratio)
    h1 = H - h2
    st = tb.Stack(b, h1, 10 * h1, b, h2, 10 * h2)
    alpha, p2 = math.atan2(b, H), 3 * st.g / (4 * math.hypot(b, H))
    for th0 in np.linspace(0.02, 0.999, 15) * alpha:
        for th in np.linspace(0.0, th0, 15):
            w = math.sqrt(max(0.0, 2 * p2 * (math.cos(alpha - th0) - math.cos(alpha - th))))
            for sign in (1, -1):
                assert tb.contact_margins(st, "locked", [th, th], [sign * w] * 2, 1, 1).min() > 0
        w_minus = -math.sqrt(2 * p2 * (math.cos(alpha - th0) - math.cos(alpha)))
        assert tb.pattern_impact(st, [0.0, 0.0], [w_minus] * 2, (1, 1), (-1, -1), "locked")[1]
