"""Equations of motion of two stacked rocking blocks (independent Python reference).

Generalised coordinates q = (theta1, theta2): absolute rotations of the lower
block 1 and the upper block 2, clockwise positive (docs/conventions.md). The
pivot indicators s1, s2 = +1 (right corner) or -1 (left corner) choose the
corner block 1 turns about on the ground and the corner block 2 turns about on
block 1. The derivation is in docs/two_blocks.md: the centres of mass r_i(q)
are written from the kinematics, their Jacobians J_i = dr_i/dq give the mass
matrix M(q) = sum m_i J_i^T J_i + diag(Ic1, Ic2), and d'Alembert's principle in
the (accelerating) ground frame gives

    M(q) q'' = -sum_i m_i J_i^T (c_i(q, q') + (a_h, g + a_v))

with c_i the velocity-product part of the acceleration of centre i. This module
covers the patterns in which both blocks rock, the pair turns as one body
about block 1's corner (locked), or block 2 rocks on block 1 at rest (upper),
and the momentum impact map. It is the independent check of the C core
(model/c/stack.c), which uses the expanded Lagrange form instead.

Units SI, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def rot(theta: float) -> np.ndarray:
    """Clockwise rotation by theta: (0, 1) tilts towards +x."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s], [-s, c]])


def drot(theta: float) -> np.ndarray:
    """d rot / d theta; note d^2 rot / d theta^2 = -rot."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[-s, c], [-c, -s]])


@dataclass(frozen=True)
class Stack:
    """Lower block 1 and upper block 2: half widths b, half heights h (m), masses m (kg).

    Block 2 stands centred on block 1; their contact spans |x| <= min(b1, b2).
    """

    b1: float
    h1: float
    m1: float
    b2: float
    h2: float
    m2: float
    g: float = 9.81

    @property
    def c(self) -> float:
        """Half width of the contact between the blocks (m)."""
        return min(self.b1, self.b2)

    @property
    def Ic1(self) -> float:
        return self.m1 * (self.b1**2 + self.h1**2) / 3.0

    @property
    def Ic2(self) -> float:
        return self.m2 * (self.b2**2 + self.h2**2) / 3.0


def _lever_arms(st: Stack, s1: int, s2: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Body-frame vectors: ground pivot P1, P1 -> centre 1, P1 -> pivot K, K -> centre 2."""
    P1 = np.array([s1 * st.b1, 0.0])
    u1 = np.array([0.0, st.h1]) - P1
    uK = np.array([s2 * st.c, 2.0 * st.h1]) - P1
    u2 = np.array([0.0, st.h2]) - np.array([s2 * st.c, 0.0])
    return P1, u1, uK, u2


def centres(st: Stack, q: np.ndarray, s1: int, s2: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (m) of the centres of mass in the ground frame (origin: block 1's bottom centre at rest)."""
    P1, u1, uK, u2 = _lever_arms(st, s1, s2)
    R1, R2 = rot(q[0]), rot(q[1])
    return P1 + R1 @ u1, P1 + R1 @ uK + R2 @ u2


def _jacobians(st, q, s1, s2):
    _, u1, uK, u2 = _lever_arms(st, s1, s2)
    D1, D2 = drot(q[0]), drot(q[1])
    J1 = np.column_stack([D1 @ u1, np.zeros(2)])
    J2 = np.column_stack([D1 @ uK, D2 @ u2])
    return J1, J2, u1, uK, u2


def mass_matrix(st: Stack, q: np.ndarray, s1: int, s2: int) -> np.ndarray:
    J1, J2, *_ = _jacobians(st, q, s1, s2)
    return st.m1 * J1.T @ J1 + st.m2 * J2.T @ J2 + np.diag([st.Ic1, st.Ic2])


def _forces(st, q, w, s1, s2, ah, av):
    """Mass matrix and right-hand side of M q'' = f."""
    J1, J2, u1, uK, u2 = _jacobians(st, q, s1, s2)
    R1, R2 = rot(q[0]), rot(q[1])
    c1 = -R1 @ u1 * w[0] ** 2
    c2 = -R1 @ uK * w[0] ** 2 - R2 @ u2 * w[1] ** 2
    G = np.array([ah, st.g + av])
    M = st.m1 * J1.T @ J1 + st.m2 * J2.T @ J2 + np.diag([st.Ic1, st.Ic2])
    f = -st.m1 * J1.T @ (c1 + G) - st.m2 * J2.T @ (c2 + G)
    return M, f


def accelerations(st: Stack, q, w, s1: int, s2: int, ah: float = 0.0, av: float = 0.0) -> np.ndarray:
    """q'' (rad/s^2) with both blocks rocking, for ground accelerations ah, av (m/s^2)."""
    M, f = _forces(st, np.asarray(q, float), np.asarray(w, float), s1, s2, ah, av)
    return np.linalg.solve(M, f)


def locked_acceleration(st: Stack, theta: float, omega: float, s1: int, s2: int,
                        ah: float = 0.0, av: float = 0.0) -> float:
    """theta'' of the pair turning as one body about block 1's corner (theta1 = theta2)."""
    q = np.array([theta, theta])
    w = np.array([omega, omega])
    M, f = _forces(st, q, w, s1, s2, ah, av)
    L = np.array([1.0, 1.0])
    return float(L @ f / (L @ M @ L))


def energy(st: Stack, q, w, s1: int, s2: int) -> float:
    """Kinetic plus gravitational potential energy (J), potential zero with both blocks at rest."""
    q = np.asarray(q, float)
    w = np.asarray(w, float)
    J1, J2, *_ = _jacobians(st, q, s1, s2)
    v1, v2 = J1 @ w, J2 @ w
    r1, r2 = centres(st, q, s1, s2)
    T = 0.5 * (st.m1 * v1 @ v1 + st.m2 * v2 @ v2 + st.Ic1 * w[0] ** 2 + st.Ic2 * w[1] ** 2)
    V = st.g * (st.m1 * (r1[1] - st.h1) + st.m2 * (r2[1] - 2 * st.h1 - st.h2))
    return float(T + V)


def _velocity_map(st: Stack, q: np.ndarray, s1: int, s2: int) -> tuple[np.ndarray, np.ndarray]:
    """Body velocities (v1x, v1y, w1, v2x, v2y, w2) = V q' and the body mass diagonal."""
    J1, J2, *_ = _jacobians(st, q, s1, s2)
    V = np.vstack([J1, [1.0, 0.0], J2, [0.0, 1.0]])
    mass = np.array([st.m1, st.m1, st.Ic1, st.m2, st.m2, st.Ic2])
    return V, mass


def impact_map(st: Stack, q, w_minus, old: tuple[int, int], new: tuple[int, int]) -> np.ndarray:
    """Post-impact q' when the pivots change from old = (s1, s2) to new (both blocks rocking after).

    Impulses act only where the blocks touch after the impact (block 1's new
    ground pivot and block 2's pivot on block 1), so for every virtual velocity
    compatible with the new pivots the momentum change does no work:
        V_new^T D (V_new q'+ - V_old q'-) = 0,   D = diag(m1, m1, Ic1, m2, m2, Ic2).
    V_new q'+ is then the D-orthogonal projection of the pre-impact velocity
    field onto the motions the new pivots allow, so an impact never adds
    energy. For one block this is Housner's 1 - 1.5 sin^2(alpha).
    """
    q = np.asarray(q, float)
    Vo, D = _velocity_map(st, q, *old)
    Vn, _ = _velocity_map(st, q, *new)
    A = Vn.T @ (D[:, None] * Vn)
    B = Vn.T @ (D[:, None] * Vo)
    return np.linalg.solve(A, B @ np.asarray(w_minus, float))


def angular_momentum(st: Stack, q, w, s1: int, s2: int, point, blocks=(1, 2)) -> float:
    """Counter-clockwise angular momentum (kg m^2/s) of the given blocks about a fixed point."""
    q, w = np.asarray(q, float), np.asarray(w, float)
    J1, J2, *_ = _jacobians(st, q, s1, s2)
    r1, r2 = centres(st, q, s1, s2)
    H = 0.0
    for i, (m, Ic, r, v) in enumerate(((st.m1, st.Ic1, r1, J1 @ w), (st.m2, st.Ic2, r2, J2 @ w)), start=1):
        if i in blocks:
            d = r - np.asarray(point, float)
            H += m * (d[0] * v[1] - d[1] * v[0]) - Ic * w[i - 1]  # theta is clockwise
    return H


def pivot_K(st: Stack, q, s1: int, s2: int) -> np.ndarray:
    """Position of block 2's pivot on block 1 (m)."""
    P1, _, uK, _ = _lever_arms(st, s1, s2)
    return P1 + rot(float(np.asarray(q, float)[0])) @ uK


def upper_acceleration(st: Stack, theta2: float, omega2: float, s2: int,
                       ah: float = 0.0, av: float = 0.0) -> float:
    """theta2'' of block 2 rocking on block 1 held flat on the ground (theta1 = 0)."""
    M, f = _forces(st, np.array([0.0, theta2]), np.array([0.0, omega2]), s2, s2, ah, av)
    return float(f[1] / M[1, 1])


def contact_margins(st: Stack, pattern: str, q, w, s1: int, s2: int,
                    ah: float = 0.0, av: float = 0.0) -> np.ndarray:
    """Reaction margins (right end, left end) of the closed contact of a pattern.

    pattern "locked": the interface (block 2 seated on block 1 rocking on s1);
    pattern "upper": the ground (block 1 flat, block 2 rocking on s2). A
    margin is e * Q_e / (weight * half width), Q_e the generalised force the
    closed contact must supply in the coordinates that pivot about its end e:
    negative means the contact would have to pull, so it opens about e.
    """
    q, w = np.asarray(q, float), np.asarray(w, float)
    if pattern == "locked":
        L, comp, scale = np.array([1.0, 1.0]), 1, st.m2 * st.g * st.c
        qdd = L * locked_acceleration(st, q[0], w[0], s1, s1, ah, av)
    elif pattern == "upper":
        L, comp, scale = np.array([0.0, 1.0]), 0, (st.m1 + st.m2) * st.g * st.b1
        qdd = L * upper_acceleration(st, q[1], w[1], s2, ah, av)
    else:
        raise ValueError(f"pattern must be 'locked' or 'upper', got {pattern!r}")
    out = []
    for e in (1, -1):
        piv = (s1, e) if pattern == "locked" else (e, s2)
        M, f = _forces(st, q, w, *piv, ah, av)
        out.append(e * (M @ qdd - f)[comp] / scale)
    return np.array(out)


# Velocity subspaces of the patterns: q' = L p'
PATTERN_L = {"both": np.eye(2), "locked": np.array([[1.0], [1.0]]), "upper": np.array([[0.0], [1.0]]),
             "rest": np.zeros((2, 0))}


def pattern_accelerations(st: Stack, pattern: str, q, w, s1: int, s2: int,
                          ah: float = 0.0, av: float = 0.0) -> np.ndarray:
    """q'' of a pattern: both, locked (theta1 = theta2), upper (theta1 = 0) or rest."""
    if pattern == "both":
        return accelerations(st, q, w, s1, s2, ah, av)
    if pattern == "locked":
        return np.full(2, locked_acceleration(st, q[0], w[0], s1, s1, ah, av))
    if pattern == "upper":
        return np.array([0.0, upper_acceleration(st, q[1], w[1], s2, ah, av)])
    return np.zeros(2)


def pattern_impact(st: Stack, q, w_minus, old: tuple[int, int], new: tuple[int, int],
                   pattern: str) -> tuple[np.ndarray, bool]:
    """Momentum impact map onto the rates a pattern allows, and whether its closed contact pushes.

    The projection of impact_map restricted to q' = L p'. The generalised
    impulse left on the closed contact, written in the coordinates that pivot
    about each end e of it, must satisfy e * impulse >= 0 at both ends
    (the contact pushes); the boolean says whether it does.
    """
    q = np.asarray(q, float)
    w_minus = np.asarray(w_minus, float)
    L = PATTERN_L[pattern]
    Vo, D = _velocity_map(st, q, *old)

    def matrices(piv):
        Vn, _ = _velocity_map(st, q, *piv)
        return Vn.T @ (D[:, None] * Vn), Vn.T @ (D[:, None] * Vo)

    A, B = matrices(new)
    if L.shape[1] == 0:
        w_plus = np.zeros(2)
    else:
        w_plus = L @ np.linalg.solve(L.T @ A @ L, L.T @ B @ w_minus)
    if pattern == "both":
        return w_plus, True
    tol = 1e-12 * np.max(np.abs(B @ w_minus))
    for e in (1, -1):
        if pattern == "locked":
            Ae, Be = matrices((new[0], e))
            impulse = (Ae @ w_plus - Be @ w_minus)[1]
        elif pattern == "upper":
            Ae, Be = matrices((e, new[1]))
            impulse = (Ae @ w_plus - Be @ w_minus)[0]
        else:  # rest: interface and ground both closed
            Ae, Be = matrices((e, e))
            P = Ae @ w_plus - Be @ w_minus
            if e * P[1] < -tol:
                return w_plus, False
            impulse = P[0] + P[1]
        if e * impulse < -tol:
            return w_plus, False
    return w_plus, True


def kinetic_energy(st: Stack, q, w, s1: int, s2: int) -> float:
    """Kinetic energy (J)."""
    return energy(st, q, w, s1, s2) - energy(st, q, np.zeros(2), s1, s2)
