"""Checks of model/contact.py: contact reactions of rocking blocks from Newton-Euler.

Every check compares the module with something computed another way: the stack
formulas in the limit of a vanishing upper block, an energy balance in the
inertial frame (complex-step derivative and an integrated trajectory), the static
uplift threshold, mirror symmetry, D'Alembert's principle with Jacobians taken
numerically, and momentum balance with accelerations from finite differences.
Positions are recomputed here from the geometry, not taken from the module.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model.contact import (
    friction_demand,
    one_block_angular_acceleration,
    one_block_reactions,
    one_block_rest_reactions,
    stack_angular_accelerations,
    stack_reactions,
)

G0 = 9.81
N_RANDOM = 200


# ---------------------------------------------------------------- helpers (test-side geometry)

def rot(theta):
    """Clockwise rotation; works for complex theta (complex-step derivatives)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, s], [-s, c]])


def one_block_centre(theta, b, h):
    """Centre of mass relative to the ground origin (bottom centre at rest), ground frame."""
    s = 1.0 if np.real(theta) > 0 else -1.0
    P = np.array([s * b, 0.0])
    return P + rot(theta) @ (np.array([0.0, h]) - P)


def stack_centres(theta1, theta2, s1, s2, b1, h1, b2, h2):
    """Centres of block 1 and block 2 in the ground frame, written out corner by corner."""
    c = min(b1, b2)
    P1 = np.array([s1 * b1, 0.0])
    centre1 = P1 + rot(theta1) @ np.array([-s1 * b1, h1])
    K = P1 + rot(theta1) @ np.array([s2 * c - s1 * b1, 2.0 * h1])
    centre2 = K + rot(theta2) @ np.array([-s2 * c, h2])
    return centre1, centre2


# 8th-order central stencil for a second derivative
D2_COEF = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])
D2_STEP = 1e-3


def second_derivative(f, k=D2_STEP):
    vals = [np.asarray(f(j * k)) for j in range(-4, 5)]
    return sum(cj * v for cj, v in zip(D2_COEF, vals)) / k ** 2


def random_block(rng):
    b = rng.uniform(0.05, 0.5)
    h = rng.uniform(0.2, 1.5)
    return b, h


def random_state(rng, alpha):
    theta = rng.choice([-1.0, 1.0]) * rng.uniform(1e-3, 1.3 * alpha)
    omega = rng.uniform(-3.0, 3.0)
    a_h = rng.uniform(-12.0, 12.0)
    a_v = rng.uniform(-5.0, 5.0)
    return theta, omega, a_h, a_v


def random_stack(rng):
    b1, h1 = random_block(rng)
    b2, h2 = random_block(rng)
    m1, m2 = rng.uniform(0.5, 5.0), rng.uniform(0.2, 5.0)
    s1, s2 = rng.choice([-1.0, 1.0]), rng.choice([-1.0, 1.0])
    theta1 = s1 * rng.uniform(0.0, 0.4)
    theta2 = theta1 + s2 * rng.uniform(0.0, 0.4)
    omega1, omega2 = rng.uniform(-3.0, 3.0, size=2)
    a_h, a_v = rng.uniform(-12.0, 12.0), rng.uniform(-5.0, 5.0)
    return dict(theta1=theta1, omega1=omega1, theta2=theta2, omega2=omega2, s1=s1, s2=s2,
                a_h=a_h, a_v=a_v, b1=b1, h1=h1, m1=m1, b2=b2, h2=h2, m2=m2)


def call_reactions(st, alpha1, alpha2):
    return stack_reactions(st["theta1"], st["omega1"], alpha1, st["theta2"], st["omega2"], alpha2,
                           st["s1"], st["s2"], st["a_h"], st["a_v"], st["b1"], st["h1"], st["m1"],
                           st["b2"], st["h2"], st["m2"], g=G0)


def call_accelerations(st):
    return stack_angular_accelerations(st["theta1"], st["omega1"], st["theta2"], st["omega2"],
                                       st["s1"], st["s2"], st["a_h"], st["a_v"], st["b1"], st["h1"],
                                       st["m1"], st["b2"], st["h2"], st["m2"], g=G0)


def mirrored(st):
    out = dict(st)
    for key in ("theta1", "omega1", "theta2", "omega2", "s1", "s2", "a_h"):
        out[key] = -st[key]
    return out


# ---------------------------------------------------------------- one block

def test_one_block_equals_stack_with_vanishing_upper_block():
    rng = np.random.default_rng(20240518)
    for _ in range(N_RANDOM):
        st = random_stack(rng)
        st["m2"] = 1e-13 * st["m1"]
        b1, h1, m1 = st["b1"], st["h1"], st["m1"]
        a1, a2 = call_accelerations(st)
        res = call_reactions(st, a1, a2)
        th1 = st["theta1"] if st["theta1"] != 0 else st["s1"] * 1e-300
        T, N = one_block_reactions(th1, st["omega1"], st["a_h"], st["a_v"], b1, h1, m=m1, g=G0)
        acc = one_block_angular_acceleration(th1, st["a_h"], st["a_v"], b1, h1, g=G0)
        R1 = math.hypot(b1, h1)
        fscale = m1 * (abs(G0 + st["a_v"]) + abs(st["a_h"]) + R1 * st["omega1"] ** 2)
        assert abs(res["ground_T"] - T) <= 1e-9 * fscale
        assert abs(res["ground_N"] - N) <= 1e-9 * fscale
        assert abs(a1 - acc) <= 1e-9 * fscale / (m1 * R1)


def test_one_block_equation_of_motion_against_moment_about_centre():
    """Ic theta'' must equal the clockwise moment of (T, N) about the centre of mass."""
    rng = np.random.default_rng(7)
    for _ in range(N_RANDOM):
        b, h = random_block(rng)
        m = rng.uniform(0.1, 10.0)
        theta, omega, a_h, a_v = random_state(rng, math.atan2(b, h))
        T, N = one_block_reactions(theta, omega, a_h, a_v, b, h, m=m, g=G0)
        acc = one_block_angular_acceleration(theta, a_h, a_v, b, h, g=G0)
        s = np.sign(theta)
        d = np.array([s * b, 0.0]) - one_block_centre(theta, b, h)  # centre -> pivot
        moment_cw = d[1] * T - d[0] * N
        Ic = m * (b * b + h * h) / 3.0
        assert abs(Ic * acc - moment_cw) <= 1e-12 * m * math.hypot(b, h) * (abs(T) + abs(N) + G0)


def inertial_energy(z, b, h, m):
    """Kinetic + potential energy in the inertial frame; z = (theta, omega, xg, yg, vh, vv)."""
    theta, omega, xg, yg, vh, vv = z
    s = 1.0 if np.real(theta) > 0 else -1.0
    u = np.array([-s * b, h])
    drot = np.array([[-np.sin(theta), np.cos(theta)], [-np.cos(theta), -np.sin(theta)]])
    v_rel = drot @ u * omega
    y_rel = one_block_centre(theta, b, h)[1]
    vx, vy = vh + v_rel[0], vv + v_rel[1]
    Ic = m * (b * b + h * h) / 3.0
    return 0.5 * m * (vx * vx + vy * vy) + 0.5 * Ic * omega * omega + m * G0 * (yg + y_rel)


def test_one_block_power_balance_complex_step():
    """dE/dt (inertial) = power of (T, N) at the pivot, which moves with the ground velocity."""
    rng = np.random.default_rng(11)
    for _ in range(N_RANDOM):
        b, h = random_block(rng)
        m = rng.uniform(0.1, 10.0)
        theta, omega, a_h, a_v = random_state(rng, math.atan2(b, h))
        xg, yg = rng.uniform(-1, 1, size=2)
        vh, vv = rng.uniform(-2, 2, size=2)
        acc = one_block_angular_acceleration(theta, a_h, a_v, b, h, g=G0)
        z = np.array([theta, omega, xg, yg, vh, vv], dtype=complex)
        zdot = np.array([omega, acc, vh, vv, a_h, a_v])
        eps = 1e-30
        dEdt = inertial_energy(z + 1j * eps * zdot, b, h, m).imag / eps
        T, N = one_block_reactions(theta, omega, a_h, a_v, b, h, m=m, g=G0)
        power = T * vh + N * vv
        R = math.hypot(b, h)
        scale = abs(T * vh) + abs(N * vv) + m * R * R * abs(omega * acc) + m * abs(vh * a_h) + m * G0 * abs(vv)
        assert abs(dEdt - power) <= 1e-8 * scale


@pytest.mark.parametrize("theta0,omega0", [(0.12, 0.3), (-0.08, -0.5), (0.05, 1.0)])
def test_one_block_power_balance_trajectory(theta0, omega0):
    """E(t) - E(0) = integral of T v_h + N v_v along a trajectory with a moving ground."""
    b, h, m = 0.2, 0.8, 3.0
    ah = lambda t: 6.0 * math.sin(9.0 * t) - 2.0
    av = lambda t: 3.0 * math.cos(13.0 * t)

    def rhs(t, y):
        theta, omega, xg, yg, vh, vv, _ = y
        a_h, a_v = ah(t), av(t)
        T, N = one_block_reactions(theta, omega, a_h, a_v, b, h, m=m, g=G0)
        return [omega, one_block_angular_acceleration(theta, a_h, a_v, b, h, g=G0),
                vh, vv, a_h, a_v, T * vh + N * vv]

    y0 = [theta0, omega0, 0.0, 0.0, 0.7, -0.4, 0.0]
    ts = np.linspace(0.0, 0.08, 17)
    sol = solve_ivp(rhs, (0.0, ts[-1]), y0, method="DOP853", t_eval=ts, rtol=1e-12, atol=1e-14)
    assert sol.success
    assert np.all(np.sign(sol.y[0]) == np.sign(theta0)), "trajectory must not reach an impact"
    E = np.array([inertial_energy(sol.y[:6, k], b, h, m) for k in range(len(ts))])
    W = sol.y[6]
    scale = np.max(np.abs(W)) + np.max(np.abs(E - E[0]))
    assert scale > 1e-2  # the ground does real work
    assert np.max(np.abs((E - E[0]) - W)) <= 1e-8 * scale


@pytest.mark.parametrize("a_v", [0.0, 3.0, -4.0])
def test_uplift_threshold(a_v):
    b, h, m = 0.25, 0.9, 2.0
    Geff = G0 + a_v
    tan_a = b / h
    tiny = 1e-300  # theta -> 0: the pivot sign is set, the geometry is at rest

    # uplift onto the RIGHT corner (theta -> 0+): the LEFT corner unloads
    a_h = -Geff * tan_a
    T_r, N_l, N_r = one_block_rest_reactions(a_h, a_v, b, h, m=m, g=G0)
    assert N_l == pytest.approx(0.0, abs=1e-12 * m * Geff)
    assert N_r == pytest.approx(m * Geff, rel=1e-12)
    assert one_block_angular_acceleration(tiny, a_h, a_v, b, h, g=G0) == pytest.approx(0.0, abs=1e-12)
    T, N = one_block_reactions(tiny, 0.0, a_h, a_v, b, h, m=m, g=G0)
    assert T == pytest.approx(T_r, rel=1e-12)
    assert N == pytest.approx(N_r, rel=1e-12)
    assert N == pytest.approx(N_l + N_r, rel=1e-12)
    # beyond the threshold the rest state would need tension on the left and the block rocks
    T_r, N_l, N_r = one_block_rest_reactions(a_h * 1.01, a_v, b, h, m=m, g=G0)
    assert N_l < 0 < N_r
    assert one_block_angular_acceleration(tiny, a_h * 1.01, a_v, b, h, g=G0) > 0
    assert one_block_angular_acceleration(tiny, a_h * 0.99, a_v, b, h, g=G0) < 0

    # uplift onto the LEFT corner (theta -> 0-): the RIGHT corner unloads
    a_h = +Geff * tan_a
    T_r, N_l, N_r = one_block_rest_reactions(a_h, a_v, b, h, m=m, g=G0)
    assert N_r == pytest.approx(0.0, abs=1e-12 * m * Geff)
    assert N_l == pytest.approx(m * Geff, rel=1e-12)
    assert one_block_angular_acceleration(-tiny, a_h, a_v, b, h, g=G0) == pytest.approx(0.0, abs=1e-12)
    T, N = one_block_reactions(-tiny, 0.0, a_h, a_v, b, h, m=m, g=G0)
    assert T == pytest.approx(T_r, rel=1e-12)
    assert N == pytest.approx(N_l, rel=1e-12)
    T_r, N_l, N_r = one_block_rest_reactions(a_h * 1.01, a_v, b, h, m=m, g=G0)
    assert N_r < 0 < N_l
    assert one_block_angular_acceleration(-tiny, a_h * 1.01, a_v, b, h, g=G0) < 0


def test_rest_reactions_balance():
    rng = np.random.default_rng(3)
    for _ in range(50):
        b, h = random_block(rng)
        m = rng.uniform(0.1, 10.0)
        a_h, a_v = rng.uniform(-12, 12), rng.uniform(-5, 5)
        T, N_l, N_r = one_block_rest_reactions(a_h, a_v, b, h, m=m, g=G0)
        assert T == pytest.approx(m * a_h, rel=1e-14)
        assert N_l + N_r == pytest.approx(m * (G0 + a_v), rel=1e-12)
        # moments about the centre (counter-clockwise): corners at (-b, -h), (b, -h)
        assert abs(-b * N_l + b * N_r + h * T) <= 1e-12 * m * (b + h) * (G0 + abs(a_h) + abs(a_v))


def test_one_block_mirror_symmetry():
    rng = np.random.default_rng(5)
    for _ in range(N_RANDOM):
        b, h = random_block(rng)
        m = rng.uniform(0.1, 10.0)
        theta, omega, a_h, a_v = random_state(rng, math.atan2(b, h))
        T, N = one_block_reactions(theta, omega, a_h, a_v, b, h, m=m, g=G0)
        Tm, Nm = one_block_reactions(-theta, -omega, -a_h, a_v, b, h, m=m, g=G0)
        scale = abs(T) + abs(N)
        assert abs(Tm + T) <= 1e-13 * scale
        assert abs(Nm - N) <= 1e-13 * scale
        acc = one_block_angular_acceleration(theta, a_h, a_v, b, h, g=G0)
        assert one_block_angular_acceleration(-theta, -a_h, a_v, b, h, g=G0) == pytest.approx(-acc, rel=1e-13, abs=1e-13)
        T0, Nl, Nr = one_block_rest_reactions(a_h, a_v, b, h, m=m, g=G0)
        T0m, Nlm, Nrm = one_block_rest_reactions(-a_h, a_v, b, h, m=m, g=G0)
        assert (T0m, Nlm, Nrm) == pytest.approx((-T0, Nr, Nl), rel=1e-13, abs=1e-13)


def test_friction_demand():
    assert friction_demand(3.0, 6.0) == 0.5
    assert friction_demand(-3.0, 6.0) == 0.5
    assert friction_demand(1.0, 0.0) == math.inf
    assert friction_demand(0.0, -1.0) == math.inf


def test_theta_zero_is_rejected():
    with pytest.raises(ValueError):
        one_block_reactions(0.0, 0.0, 0.0, 0.0, 0.2, 0.8)


# ---------------------------------------------------------------- two blocks

def test_stack_mirror_symmetry():
    rng = np.random.default_rng(17)
    for _ in range(N_RANDOM):
        st = random_stack(rng)
        a1, a2 = call_accelerations(st)
        stm = mirrored(st)
        a1m, a2m = call_accelerations(stm)
        assert abs(a1m + a1) <= 1e-10 * (1 + abs(a1))
        assert abs(a2m + a2) <= 1e-10 * (1 + abs(a2))
        # arbitrary (not true) accelerations too: the mirror holds for the residuals as well
        b1_, b2_ = rng.uniform(-50, 50, size=2)
        r = call_reactions(st, b1_, b2_)
        rm = call_reactions(stm, -b1_, -b2_)
        scale = sum(abs(v) for v in r.values())
        for key in ("interface_T", "interface_x", "ground_T", "residual1", "residual2"):
            assert abs(rm[key] + r[key]) <= 1e-12 * scale, key
        for key in ("interface_N", "interface_y", "ground_N"):
            assert abs(rm[key] - r[key]) <= 1e-12 * scale, key


def stack_relative_accelerations(st, a1, a2):
    """r1'', r2'' (ground frame) by finite differences along theta_i(t) = theta_i + omega_i t + a_i t^2 / 2."""
    def centres(t):
        th1 = st["theta1"] + st["omega1"] * t + 0.5 * a1 * t * t
        th2 = st["theta2"] + st["omega2"] * t + 0.5 * a2 * t * t
        c1, c2 = stack_centres(th1, th2, st["s1"], st["s2"], st["b1"], st["h1"], st["b2"], st["h2"])
        return np.concatenate([c1, c2])
    acc = second_derivative(centres)
    return acc[:2], acc[2:]


def test_stack_residuals_and_momentum_balance():
    rng = np.random.default_rng(29)
    for _ in range(N_RANDOM):
        st = random_stack(rng)
        m1, m2 = st["m1"], st["m2"]
        a1, a2 = call_accelerations(st)
        r = call_reactions(st, a1, a2)
        F = np.array([r["interface_x"], r["interface_y"]])
        Q = np.array([r["ground_T"], r["ground_N"]])
        Ic1 = m1 * (st["b1"] ** 2 + st["h1"] ** 2) / 3
        Ic2 = m2 * (st["b2"] ** 2 + st["h2"] ** 2) / 3
        L = st["h1"] * 2 + st["h2"] * 2 + st["b1"] + st["b2"]
        mscale = Ic1 * abs(a1) + Ic2 * abs(a2) + L * (np.abs(F).sum() + np.abs(Q).sum())
        assert abs(r["residual1"]) <= 1e-10 * mscale
        assert abs(r["residual2"]) <= 1e-10 * mscale

        # momentum: external forces = total mass x inertial acceleration of the total centre
        A = np.array([st["a_h"], st["a_v"]])
        acc1, acc2 = stack_relative_accelerations(st, a1, a2)
        M = m1 + m2
        acc_cm = A + (m1 * acc1 + m2 * acc2) / M
        external = Q + np.array([0.0, -M * G0])
        fscale = M * (G0 + np.abs(A).sum() + np.abs(acc1).sum() + np.abs(acc2).sum())
        assert np.max(np.abs(external - M * acc_cm)) <= 1e-8 * fscale
        # and block 2 alone: the interface force carries it
        assert np.max(np.abs(F + np.array([0.0, -m2 * G0]) - m2 * (A + acc2))) <= 1e-8 * fscale

        # interface decomposition along block 1's rotated axes
        ex = rot(st["theta1"]) @ np.array([1.0, 0.0])
        ey = rot(st["theta1"]) @ np.array([0.0, 1.0])
        assert r["interface_T"] == pytest.approx(F @ ex, abs=1e-12 * fscale)
        assert r["interface_N"] == pytest.approx(F @ ey, abs=1e-12 * fscale)
        assert r["interface_T"] ** 2 + r["interface_N"] ** 2 == pytest.approx(F @ F, rel=1e-12)


def test_stack_accelerations_satisfy_dalembert():
    """Virtual work with numerically differentiated positions: sum_i m_i (A + g y + r_i'') . dr_i/dq_j + Ic_j q_j'' = 0."""
    rng = np.random.default_rng(31)
    eps = 1e-30
    for _ in range(N_RANDOM):
        st = random_stack(rng)
        a1, a2 = call_accelerations(st)
        acc1, acc2 = stack_relative_accelerations(st, a1, a2)
        Ag = np.array([st["a_h"], G0 + st["a_v"]])
        Ic = [st["m1"] * (st["b1"] ** 2 + st["h1"] ** 2) / 3, st["m2"] * (st["b2"] ** 2 + st["h2"] ** 2) / 3]
        qdd = [a1, a2]
        for j in range(2):
            dq = [0.0, 0.0]
            dq[j] = 1j * eps
            c1, c2 = stack_centres(st["theta1"] + dq[0], st["theta2"] + dq[1], st["s1"], st["s2"],
                                   st["b1"], st["h1"], st["b2"], st["h2"])
            J1, J2 = c1.imag / eps, c2.imag / eps
            gen = (st["m1"] * (Ag + acc1) @ J1 + st["m2"] * (Ag + acc2) @ J2 + Ic[j] * qdd[j])
            scale = (st["m1"] + st["m2"]) * (np.abs(Ag).sum() + np.abs(acc1).sum() + np.abs(acc2).sum()) \
                * (np.abs(J1).sum() + np.abs(J2).sum()) + Ic[j] * abs(qdd[j])
            assert abs(gen) <= 1e-8 * scale


@pytest.mark.parametrize("s1,s2", [(1, 1), (1, -1), (-1, 1), (-1, -1)])
def test_stack_static(s1, s2):
    rng = np.random.default_rng(41)
    for _ in range(20):
        st = random_stack(rng)
        st.update(theta1=0.0, omega1=0.0, theta2=0.0, omega2=0.0, s1=float(s1), s2=float(s2))
        r = call_reactions(st, 0.0, 0.0)
        m1, m2, a_h, a_v = st["m1"], st["m2"], st["a_h"], st["a_v"]
        assert r["interface_T"] == pytest.approx(m2 * a_h, rel=1e-13)
        assert r["interface_x"] == pytest.approx(m2 * a_h, rel=1e-13)
        assert r["interface_N"] == pytest.approx(m2 * (G0 + a_v), rel=1e-13)
        assert r["interface_y"] == pytest.approx(m2 * (G0 + a_v), rel=1e-13)
        assert r["ground_T"] == pytest.approx((m1 + m2) * a_h, rel=1e-13)
        assert r["ground_N"] == pytest.approx((m1 + m2) * (G0 + a_v), rel=1e-13)


@pytest.mark.parametrize("ratio", [1.5, 2.0, 2.25, 3.0, 4.0])
def test_the_sliding_threshold_of_a_block_just_uplifted_is_where_the_reactions_need_mu(ratio):
    """rocking_slide_threshold: at theta -> 0 on the tipped-to corner, omega = 0, the reactions
    (one_block_reactions) need exactly mu at that |a_h| / G (found here by root finding), and
    the demand at uplift (|a_h| / G = tan alpha) is tan alpha."""
    from scipy.optimize import brentq

    from model.contact import rocking_slide_threshold

    b, h, mu, g = 0.5 / ratio, 0.5, 0.7, 9.81

    def demand(x):  # a_h > 0 tips the block onto its left corner (theta < 0)
        T, N = one_block_reactions(-1e-300, 0.0, x * g, 0.0, b, h, 1.0, g)
        return friction_demand(T, N)

    assert demand(b / h) == pytest.approx(b / h, rel=1e-12)
    root = brentq(lambda x: demand(x) - mu, b / h, 50.0, xtol=1e-14)
    assert rocking_slide_threshold(b, h, mu) == pytest.approx(root, rel=1e-10)
