"""Checks of model/polygon_reference.py (rocking of a body with an off-centre
centre of mass) against closed forms and against computations done another way:
static and dynamic equilibrium by linear solves (Newton-Euler), the impact by an
impulse balance, times by elliptic integrals, quadrature against solve_ivp."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ellipk, ellipkinc

from model.polygon_reference import (
    RockingBody,
    angular_acceleration,
    apply_impact,
    body_from_polygon,
    free_rocking,
    impact_ratio,
    landing_angles,
    peak_angle,
    pivot_geometry,
    potential_energy,
    rocking_time,
    simulate_rocking,
    simulate_sine_pulse,
    total_energy,
    uniform_polygon_properties,
    uplift_thresholds,
)

G = 9.81
OFF = RockingBody(xL=-0.2, xR=0.3, xG=0.02, yG=0.6, m=2.0, IG=0.1)
VASE = [(-0.15, 0.0), (0.2, 0.0), (0.3, 1.0), (-0.25, 0.9)]


def rectangle(b: float, h: float, m: float = 1.0) -> RockingBody:
    """Rectangle of half width b, half height h, centred at x = 0."""
    return RockingBody(xL=-b, xR=b, xG=0.0, yG=h, m=m, IG=m * (b * b + h * h) / 3.0)


BODIES = {
    "rectangle": rectangle(0.2, 0.6),
    "off_centre": OFF,
    "vase": body_from_polygon(VASE, 3.0),
}


# ---------------------------------------------------------------------------
# uniform polygons
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("ccw", [True, False])
def test_polygon_rectangle(ccw: bool) -> None:
    w, H, m, x0, y0 = 0.4, 1.3, 2.5, 0.7, -0.2
    v = [(x0, y0), (x0 + w, y0), (x0 + w, y0 + H), (x0, y0 + H)]
    if not ccw:
        v = v[::-1]
    area, (cx, cy), IG = uniform_polygon_properties(v, m)
    assert area == pytest.approx(w * H, rel=1e-14)
    assert (cx, cy) == pytest.approx((x0 + w / 2, y0 + H / 2), rel=1e-14)
    assert IG == pytest.approx(m * (w * w + H * H) / 12.0, rel=1e-13)
    bl, br = landing_angles(v)
    assert (bl, br) == pytest.approx((math.pi / 2, math.pi / 2), abs=1e-15)
    body = body_from_polygon(v, m)
    assert (body.xL, body.xR, body.xG, body.yG) == pytest.approx((x0, x0 + w, x0 + w / 2, H / 2),
                                                                  rel=1e-13)


def test_polygon_triangle() -> None:
    a, c, h, m = 1.0, 0.3, 0.8, 4.0
    v = [(0.0, 0.0), (a, 0.0), (c, h)]
    area, (cx, cy), IG = uniform_polygon_properties(v, m)
    assert area == pytest.approx(a * h / 2, rel=1e-14)
    assert (cx, cy) == pytest.approx(((a + c) / 3, h / 3), rel=1e-14)
    # polar moment about the centroid: m (sum of squared side lengths) / 36
    sides2 = a * a + (c * c + h * h) + ((a - c) ** 2 + h * h)
    assert IG == pytest.approx(m * sides2 / 36.0, rel=1e-13)
    bl, br = landing_angles(v)
    assert bl == pytest.approx(math.pi - math.atan2(h, c), rel=1e-14)
    assert br == pytest.approx(math.atan2(h, c - a), rel=1e-14)


def test_vase_hull_and_landing() -> None:
    # an interior point and a duplicated collinear base point must not change the body
    body = body_from_polygon(VASE + [(0.0, 0.5), (0.05, 0.0)], 3.0)
    assert body == BODIES["vase"]
    assert body.beta_right == pytest.approx(math.atan2(1.0, 0.1))
    assert body.beta_left == pytest.approx(math.pi - math.atan2(0.9, -0.1))


# ---------------------------------------------------------------------------
# thresholds and equation of motion
# ---------------------------------------------------------------------------

def test_rectangle_thresholds() -> None:
    b, h = 0.25, 1.0
    ar, al = uplift_thresholds(rectangle(b, h), G)
    assert (ar, al) == pytest.approx((-G * b / h, G * b / h), rel=1e-15)
    ar, al = uplift_thresholds(rectangle(b, h), G, a_v=-2.0)
    assert al == pytest.approx((G - 2.0) * b / h, rel=1e-15)


def _static_reactions(body: RockingBody, a_h: float, a_v: float, g: float) -> np.ndarray:
    """(F, N_L, N_R) of the body at rest moving with the ground, by a linear solve.

    Unknowns: total friction F, normal forces at L and R. Equations: the two
    components of m a = sum of forces and the moment balance about G."""
    A = np.array([[1.0, 0.0, 0.0],
                  [0.0, 1.0, 1.0],
                  [body.yG, body.xL - body.xG, body.xR - body.xG]])
    rhs = np.array([body.m * a_h, body.m * (g + a_v), 0.0])
    return np.linalg.solve(A, rhs)


@pytest.mark.parametrize("name", list(BODIES))
@pytest.mark.parametrize("a_v", [0.0, 1.7])
def test_thresholds_by_reactions(name: str, a_v: float) -> None:
    body = BODIES[name]
    ar, al = uplift_thresholds(body, G, a_v)
    # rocking onto R starts when the reaction at L vanishes, and vice versa
    ar_ref = brentq(lambda a: _static_reactions(body, a, a_v, G)[1], -10 * G, 0.0, xtol=1e-15)
    al_ref = brentq(lambda a: _static_reactions(body, a, a_v, G)[2], 0.0, 10 * G, xtol=1e-15)
    assert ar == pytest.approx(ar_ref, rel=1e-12)
    assert al == pytest.approx(al_ref, rel=1e-12)
    # beyond the threshold the equation of motion lifts the right corner
    assert angular_acceleration(body, 0.0, ar * 1.01, a_v, G, side=1) > 0
    assert angular_acceleration(body, 0.0, ar * 0.99, a_v, G, side=1) < 0
    assert angular_acceleration(body, 0.0, al * 1.01, a_v, G, side=-1) < 0
    assert angular_acceleration(body, 0.0, al * 0.99, a_v, G, side=-1) > 0


def _newton_euler_thetaddot(body: RockingBody, theta: float, omega: float, a_h: float,
                            a_v: float, g: float) -> float:
    """thetaddot from Newton-Euler in the inertial frame (unknowns Fx, Fy, thetaddot)."""
    s = 1 if theta > 0 else -1
    p = np.array([body.xR if s > 0 else body.xL, 0.0])
    d = np.array([body.xG, body.yG]) - p
    c, sn = math.cos(theta), math.sin(theta)
    r = np.array([c * d[0] + sn * d[1], -sn * d[0] + c * d[1]])  # clockwise rotation
    m = body.m
    # a_G = a_ground + Omegadot z x r - Omega^2 r with Omega = -thetadot (ccw)
    # m a_Gx = Fx ; m a_Gy = Fy - m g ; IG Omegadot = (p - G) x F
    A = np.array([[1.0, 0.0, -m * r[1]],
                  [0.0, 1.0, m * r[0]],
                  [-r[1], r[0], -body.IG]])
    rhs = np.array([m * (a_h - omega ** 2 * r[0]),
                    m * (a_v + g - omega ** 2 * r[1]),
                    0.0])
    return float(np.linalg.solve(A, rhs)[2])


@pytest.mark.parametrize("name", list(BODIES))
def test_equation_of_motion_newton_euler(name: str) -> None:
    body = BODIES[name]
    rng = np.random.default_rng(1)
    for _ in range(40):
        theta = rng.uniform(-0.6, 0.6)
        omega, a_h, a_v = rng.uniform(-2, 2), rng.uniform(-8, 8), rng.uniform(-3, 3)
        ref = _newton_euler_thetaddot(body, theta, omega, a_h, a_v, G)
        got = angular_acceleration(body, theta, a_h, a_v, G)
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-12)


# ---------------------------------------------------------------------------
# impact
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("b, h", [(0.2, 0.6), (0.1, 1.0), (0.5, 0.7)])
def test_rectangle_impact_is_housner(b: float, h: float) -> None:
    alpha = math.atan(b / h)
    for side in (1, -1):
        assert impact_ratio(rectangle(b, h), side) == pytest.approx(
            1.0 - 1.5 * math.sin(alpha) ** 2, rel=1e-14)


def _impulse_ratio(body: RockingBody, new_side: int) -> float:
    """thetadot+/thetadot- by an impulse balance (unknowns vx, vy, Omega+, Px, Py)."""
    gpos = np.array([body.xG, body.yG])
    old = np.array([body.xL if new_side > 0 else body.xR, 0.0])
    new = np.array([body.xR if new_side > 0 else body.xL, 0.0])
    w0 = 1.0  # ccw rate before (sign irrelevant, the law is linear)
    ro, rn = gpos - old, new - gpos
    v0 = w0 * np.array([-ro[1], ro[0]])
    m, IG = body.m, body.IG
    # m (v - v0) = P ; IG (W - w0) = rn x P ; v + W z x rn = 0
    A = np.array([[m, 0, 0, -1, 0],
                  [0, m, 0, 0, -1],
                  [0, 0, IG, rn[1], -rn[0]],
                  [1, 0, -rn[1], 0, 0],
                  [0, 1, rn[0], 0, 0]], dtype=float)
    rhs = np.array([m * v0[0], m * v0[1], IG * w0, 0.0, 0.0])
    return float(np.linalg.solve(A, rhs)[2] / w0)


@pytest.mark.parametrize("name", list(BODIES))
def test_impact_by_impulse(name: str) -> None:
    body = BODIES[name]
    for new_side in (1, -1):
        r = impact_ratio(body, new_side)
        assert r == pytest.approx(_impulse_ratio(body, new_side), rel=1e-12)
        # a plastic impact loses energy
        _, _, i_new = pivot_geometry(body, new_side)
        _, _, i_old = pivot_geometry(body, -new_side)
        assert 0.0 < r * r * i_new < i_old
    # the two directions differ for an off-centre body
    if name != "rectangle":
        assert abs(impact_ratio(body, 1) - impact_ratio(body, -1)) > 1e-3
    assert apply_impact(body, 2.0) == pytest.approx(2.0 * impact_ratio(body, 1))
    assert apply_impact(body, -2.0) == pytest.approx(-2.0 * impact_ratio(body, -1))


# ---------------------------------------------------------------------------
# free rocking: energy, quadrature, elliptic integrals, solve_ivp
# ---------------------------------------------------------------------------

def _elliptic_time_to_peak(body: RockingBody, side: int, theta_peak: float, g: float) -> float:
    """Time from theta = 0 to the peak as K(m) - F(phi1|m), m = cos^2(u_p/2)."""
    rho, alpha, ip = pivot_geometry(body, side)
    k = 2 * body.m * g * rho / ip
    up = alpha - side * theta_peak
    mpar = math.cos(up / 2) ** 2
    phi1 = math.asin(math.cos(alpha / 2) / math.cos(up / 2))
    return math.sqrt(2 / k) * (ellipk(mpar) - ellipkinc(phi1, mpar))


@pytest.mark.parametrize("name", list(BODIES))
@pytest.mark.parametrize("frac", [0.02, 0.3, 0.9])
def test_quarter_times_elliptic(name: str, frac: float) -> None:
    body = BODIES[name]
    for side in (1, -1):
        _, alpha, _ = pivot_geometry(body, side)
        thp = side * frac * alpha
        t_q = rocking_time(body, side, 0.0, thp, thp, G)
        assert t_q == pytest.approx(_elliptic_time_to_peak(body, side, thp, G), rel=1e-12)
        # splitting the interval adds up
        mid = 0.4 * thp
        t_split = rocking_time(body, side, 0.0, mid, thp, G) + rocking_time(body, side, mid, thp, thp, G)
        assert t_split == pytest.approx(t_q, rel=1e-13)


def test_slender_rectangle_linearised_housner() -> None:
    """For a slender block the exact time tends to Housner's linearised one."""
    b, h = 0.01, 1.0
    body = rectangle(b, h)
    alpha, rho = math.atan(b / h), math.hypot(b, h)
    p = math.sqrt(3 * G / (4 * rho))
    theta0 = 0.5 * alpha
    t_lin = math.acosh(1.0 / (1.0 - theta0 / alpha)) / p
    t = rocking_time(body, 1, theta0, 0.0, theta0, G)
    assert t == pytest.approx(t_lin, rel=2 * alpha ** 2)
    assert abs(t / t_lin - 1) > 1e-9  # but it is not the same formula


@pytest.mark.parametrize("name", list(BODIES))
def test_peak_energy(name: str) -> None:
    body = BODIES[name]
    for theta, omega in [(0.0, 0.8), (0.0, -0.8), (0.05, 0.3), (-0.04, -0.2), (0.05, -0.3)]:
        thp = peak_angle(body, theta, omega, G)
        assert np.sign(thp) == (np.sign(theta) or np.sign(omega))
        assert total_energy(body, thp, 0.0, G) == pytest.approx(total_energy(body, theta, omega, G),
                                                                rel=1e-14)
    with pytest.raises(ValueError):
        peak_angle(body, 0.0, 5.0, G)


CASES = [("rectangle", 0.15, 0.0), ("rectangle", 0.0, -0.9), ("off_centre", 0.1, 0.0),
         ("off_centre", -0.2, 0.3), ("off_centre", 0.12, -0.4), ("vase", 0.0, 0.7),
         ("vase", -0.1, 0.0)]


@pytest.mark.parametrize("name, theta0, omega0", CASES)
def test_free_rocking_quadrature_vs_solve_ivp(name: str, theta0: float, omega0: float) -> None:
    body = BODIES[name]
    t_end = 4.0
    q = free_rocking(body, theta0, omega0, t_end, G)
    n = 12
    assert len(q.impact_times) > n
    s = simulate_rocking(body, t_end, G, theta0=theta0, omega0=omega0)
    assert len(s.impact_times) > n
    assert np.allclose(q.impact_times[:n], s.impact_times[:n], rtol=1e-9, atol=0)
    assert np.allclose(q.omega_before[:n], s.omega_before[:n], rtol=1e-9, atol=0)
    assert np.allclose(q.omega_after[:n], s.omega_after[:n], rtol=1e-9, atol=0)
    assert np.allclose(q.peak_times[:n], s.peak_times[:n], rtol=1e-9, atol=0)
    assert np.allclose(q.peak_thetas[:n], s.peak_thetas[:n], rtol=1e-9, atol=0)
    # events alternate: peaks and impacts interleave, signs alternate
    assert np.all(np.diff(np.sign(q.peak_thetas[:n])) != 0)
    assert np.all(np.diff(q.impact_times[:n]) > 0)
    assert s.max_abs_theta == pytest.approx(max([abs(theta0)] + [abs(x) for x in q.peak_thetas]),
                                            rel=1e-9)


@pytest.mark.parametrize("name", list(BODIES))
def test_energy_between_impacts(name: str) -> None:
    body = BODIES[name]
    s = simulate_rocking(body, 3.0, G, theta0=0.0, omega0=0.6)
    assert len(s.impact_times) > 10
    checked = 0
    for k, (side, ta, tb, sol) in enumerate(s.segments[:10]):
        assert tb == s.impact_times[k]
        ts = np.linspace(ta, tb, 200)
        y = sol(ts)
        e = np.array([potential_energy(body, th, G) + 0.5 * pivot_geometry(body, side)[2] * w * w
                      for th, w in zip(y[0], y[1])])
        assert np.max(np.abs(e / e[0] - 1)) < 1e-11
        # each impact loses the kinetic energy I_old w-^2/2 - I_new w+^2/2 > 0
        nxt = s.segments[k + 1]
        th_n, w_n = nxt[3](nxt[1])
        assert th_n == 0.0 and w_n == s.omega_after[k]
        _, _, i_old = pivot_geometry(body, side)
        _, _, i_new = pivot_geometry(body, -side)
        loss = 0.5 * i_old * s.omega_before[k] ** 2 - 0.5 * i_new * w_n ** 2
        assert loss > 0.1 * (1 - impact_ratio(body, -side) ** 2) * 0.5 * i_old * s.omega_before[k] ** 2
        assert e[-1] - total_energy(body, 0.0, w_n, G) == pytest.approx(loss, rel=1e-8)
        checked += 1
    assert checked == 10


def test_free_rocking_overturns_and_rest() -> None:
    body = OFF
    _, alpha_r, _ = pivot_geometry(body, 1)
    assert free_rocking(body, 0.999 * alpha_r, 0.05, 5.0, G).status == "overturns"
    assert free_rocking(body, 0.0, 0.0, 5.0, G).status == "at_rest"
    q = free_rocking(body, 0.1, 0.0, 10.0, G, omega_rest=1e-6)
    assert q.status == "at_rest" and abs(q.omega_after[-1]) < 1e-6
    s = simulate_rocking(body, 1.0, G, theta0=0.0, omega0=3.0)
    assert s.status == "overturned"


# ---------------------------------------------------------------------------
# forced rocking (sine pulse)
# ---------------------------------------------------------------------------

def test_sine_pulse_below_threshold_stays_at_rest() -> None:
    ar, al = uplift_thresholds(OFF, G)
    s = simulate_sine_pulse(OFF, 0.999 * min(al, -ar), 2.0, 1.0, G)
    assert s.uplift_times == [] and s.impact_times == [] and s.max_abs_theta == 0.0
    # between the two thresholds a positive-first pulse lifts the left corner only
    s = simulate_sine_pulse(OFF, 1.01 * al, 2.0, 0.6, G)
    assert s.uplift_sides == [-1]


@pytest.mark.parametrize("A", [8.0, -6.0])
def test_sine_pulse_uplift_and_continuation(A: float) -> None:
    f, t_end = 2.0, 3.0
    s = simulate_sine_pulse(OFF, A, f, t_end, G)
    ar, al = uplift_thresholds(OFF, G)
    # uplift: A sin(2 pi f t) reaches the threshold of the corner it pushes onto
    thr = al if A > 0 else ar
    assert s.uplift_times[0] == pytest.approx(math.asin(thr / A) / (2 * math.pi * f), rel=1e-10)
    assert s.uplift_sides[0] == (-1 if A > 0 else 1)
    assert len(s.impact_times) > 5 and 0 < s.max_abs_theta < 0.5
    # after the pulse the motion is free rocking from the state at its end
    tp = 1.0 / f
    s_p = simulate_sine_pulse(OFF, A, f, tp, G)
    assert s_p.impact_times == s.impact_times[:len(s_p.impact_times)]
    q = free_rocking(OFF, s_p.theta_end, s_p.omega_end, t_end - tp, G)
    later = [t - tp for t in s.impact_times if t > tp][:8]
    assert np.allclose(q.impact_times[:8], later, rtol=1e-9, atol=0)
    later_peaks = [th for t, th in zip(s.peak_times, s.peak_thetas) if t > tp][:8]
    assert np.allclose(q.peak_thetas[:8], later_peaks, rtol=1e-9, atol=0)


def test_forced_energy_balance() -> None:
    """d(T + m g y_G)/dt = -m a_h xdot_G (work of the d'Alembert force) between impacts."""
    A, f = 8.0, 2.0
    s = simulate_sine_pulse(OFF, A, f, 0.5, G)
    side, t0, t1, sol = next(seg for seg in s.segments if seg[0] != 0)
    rho, alpha, _ = pivot_geometry(OFF, side)

    def power(t: float) -> float:
        th, w = sol(t)
        return -OFF.m * A * math.sin(2 * math.pi * f * t) * rho * math.cos(th - side * alpha) * w

    work = quad(power, t0, t1, epsabs=0, epsrel=1e-12, limit=200)[0]
    e = [total_energy(OFF, *sol(t), G) for t in (t0, t1)]
    assert e[1] - e[0] == pytest.approx(work, rel=1e-9)
    assert abs(work) > 1e-3
    # the potential with the horizontal term is a Lyapunov-like check of signs too
    assert potential_energy(OFF, -0.1, G, a_h=1.0) < potential_energy(OFF, -0.1, G, a_h=0.0)
