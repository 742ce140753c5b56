"""Contact reactions of rocking blocks: ground and interface forces from Newton-Euler.

This module derives, independently of the equation-of-motion code elsewhere in
the project, the forces that the no-sliding and no-flight contacts must carry.
Comparing them with the friction and unilateral-contact limits
(:func:`friction_demand`, ``N > 0``) tells whether the rocking idealisation
holds. Everything is SI: metres, kilograms, seconds, newtons, radians.

Conventions (docs/conventions.md): ``x`` to the right, ``y`` up; ``theta > 0``
is a CLOCKWISE rotation about the bottom right corner, ``theta < 0`` a
counter-clockwise rotation about the bottom left corner, ``s = sign(theta)``.
The ground accelerates by ``(a_h, a_v)`` (``a_h > 0`` towards ``+x``,
``a_v > 0`` up); gravity ``g`` points down. Angular velocities and
accelerations (``omega``, ``alpha``) are clockwise positive, like ``theta``.
All positions below are measured in the (translating) ground frame; inertial
accelerations are the ground acceleration plus the relative ones. Reactions
are forces exerted ON the block (by the ground, or by block 1 on block 2).

One block rocking on a corner
-----------------------------
Half width ``b``, half height ``h``, mass ``m``; ``R = sqrt(b^2 + h^2)``,
``alpha = atan(b/h)``, ``Ic = m R^2 / 3`` (centroidal), ``I0 = Ic + m R^2 =
4/3 m R^2`` (about a corner). Let ``phi = alpha - s theta`` (= ``alpha -
|theta|``). With the pivot at ``(s b, 0)``, the centre of mass relative to the
pivot is

    d = rot(theta) (-s b, h) = ( -s R sin(phi),  R cos(phi) ),

where ``rot(theta) = [[cos, sin], [-sin, cos]]`` turns clockwise. Since
``phi' = -s theta'``, differentiating twice gives

    d'  = ( R cos(phi) theta',  s R sin(phi) theta' )
    d'' = ( R cos(phi) theta'' + s R sin(phi) theta'^2,
            s R sin(phi) theta'' - R cos(phi) theta'^2 )

(the ``theta'^2`` terms are the centripetal acceleration ``-theta'^2 d``).

Equation of motion. The pivot moves with the ground, so about the pivot, in the
ground frame, the block feels gravity ``-m g y`` and the inertial force
``-m (a_h, a_v)`` at its centre; the pivot reaction has no moment there. A force
``F`` at offset ``d`` has the clockwise moment ``d_y F_x - d_x F_y``, so with
``G = g + a_v``

    I0 theta'' = -m R [ s G sin(phi) + a_h cos(phi) ]
    theta''    = -(3 / (4 R)) [ s G sin(phi) + a_h cos(phi) ]

(:func:`one_block_angular_acceleration`; ``= -p^2 [ (1 + a_v/g) sin(s alpha -
theta) + (a_h/g) cos(s alpha - theta) ]``, ``p^2 = 3 g / (4 R)``). At rest on
the right corner it starts to rock (``theta'' > 0``) when ``a_h < -G
tan(alpha)``, on the left when ``a_h > +G tan(alpha)``.

Reactions. Newton's second law for the centre of mass in the inertial frame,
``m ((a_h, a_v) + d'') = (T, N) + (0, -m g)``, gives ``T = m (a_h + d_x'')`` and
``N = m (G + d_y'')``. Substituting ``theta''`` (``s^2 = 1``):

    T = m [ a_h (1 - 3/4 cos^2 phi) - 3/4 s G sin(phi) cos(phi) + s R omega^2 sin(phi) ]
    N = m [ G (1 - 3/4 sin^2 phi) - 3/4 s a_h sin(phi) cos(phi) - R omega^2 cos(phi) ]

(:func:`one_block_reactions`). Mirroring ``theta, omega, a_h`` (hence ``s``)
leaves ``phi`` alone, flips ``T`` and keeps ``N``. At the uplift threshold
(``omega = 0``, ``theta'' = 0``) they reduce to ``T = m a_h``, ``N = m G``.

One block at rest on both corners
---------------------------------
The block moves with the ground: ``T = m a_h`` (total of both corners) and
``N_left + N_right = m G``. Moments about the centre of mass (counter-clockwise
``d_x F_y - d_y F_x``; the corners sit at ``(-b, -h)`` and ``(b, -h)``):
``b (N_right - N_left) + h T = 0``. Hence

    N_left  = m/2 [ G + a_h h / b ] = m/2 [ G + a_h / tan(alpha) ]
    N_right = m/2 [ G - a_h h / b ]

(:func:`one_block_rest_reactions`). ``N_left = 0`` at ``a_h = -G tan(alpha)``
(the left corner lifts: the block rocks on its right corner, ``theta > 0``) and
``N_right = 0`` at ``a_h = +G tan(alpha)`` (rocking on the left corner,
``theta < 0``), exactly where the rocking equation above starts the motion.

Two stacked blocks
------------------
Geometry of docs/two_blocks.md: ``c = min(b1, b2)``, ``P1 = (s1 b1, 0)`` the
ground pivot of block 1, ``u1 = (0, h1) - P1``, ``uK = (s2 c, 2 h1) - P1``,
``u2 = (0, h2) - (s2 c, 0)``, and

    r1 = P1 + rot(theta1) u1,   rK = P1 + rot(theta1) uK,
    r2 = rK + rot(theta2) u2

(centre of block 1, interface point K, centre of block 2). With
``rot' = [[-sin, cos], [-cos, -sin]]`` and ``rot'' = -rot``:

    r1'' = rot'(theta1) u1 alpha1 - rot(theta1) u1 omega1^2
    rK'' = rot'(theta1) uK alpha1 - rot(theta1) uK omega1^2
    r2'' = rK'' + rot'(theta2) u2 alpha2 - rot(theta2) u2 omega2^2

Newton-Euler on each block separately, with ``A = (a_h, a_v)``, ``gy = (0, g)``,
``F`` the force of block 1 on block 2 at K and ``Q`` the ground force on
block 1 at P1, and ``cw(d, F) = d_y F_x - d_x F_y`` the clockwise moment:

    block 2:  m2 (A + r2'') = F - m2 gy
              Ic2 alpha2 = cw(rK - r2, F)
    block 1:  m1 (A + r1'') = Q - F - m1 gy
              Ic1 alpha1 = cw(P1 - r1, Q) + cw(rK - r1, -F)

so ``F = m2 (A + gy + r2'')`` and ``Q = m1 (A + gy + r1'') + F``. Given
``alpha1, alpha2`` (as a model computes them), :func:`stack_reactions` returns
``F`` and ``Q`` from the force equations and the moment equations as residuals

    residual2 = Ic2 alpha2 - cw(rK - r2, F)
    residual1 = Ic1 alpha1 - cw(P1 - r1, Q) - cw(rK - r1, -F)

which vanish only for the true accelerations. ``F`` is also decomposed along
block 1's top surface: tangential ``F . rot(theta1) (1, 0)`` (along block 1's
rotated ``+x`` axis) and normal ``F . rot(theta1) (0, 1)`` (along its rotated
``+y`` axis; positive = compression). The residuals are affine in ``(alpha1,
alpha2)`` (``r_i''`` are), so :func:`stack_angular_accelerations` zeroes them
by a 2x2 linear solve. When ``theta1 = theta2`` the same formulas hold with K
the point where the interface force is placed.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "one_block_angular_acceleration",
    "one_block_reactions",
    "one_block_rest_reactions",
    "stack_reactions",
    "stack_angular_accelerations",
    "friction_demand",
]


def _pivot_sign(theta: float) -> float:
    if theta == 0:
        raise ValueError("theta must be nonzero: its sign picks the pivot corner")
    return 1.0 if theta > 0 else -1.0


def one_block_angular_acceleration(theta: float, a_h: float, a_v: float, b: float, h: float,
                                   g: float = 9.81) -> float:
    """Angular acceleration theta'' (rad/s^2, clockwise positive) of a block rocking on a corner.

    ``theta`` (rad, nonzero) picks the pivot: ``> 0`` the bottom right corner, ``< 0`` the
    bottom left one. ``a_h``, ``a_v`` (m/s^2) are the ground accelerations (``+x``, up),
    ``b``, ``h`` (m) the half width and half height, ``g`` (m/s^2) gravity.
    Derived about the accelerating pivot: ``theta'' = -(3/(4R)) [ s (g + a_v) sin(phi) +
    a_h cos(phi) ]`` with ``phi = alpha - s theta``. Independent of the mass.
    """
    s = _pivot_sign(theta)
    R = math.hypot(b, h)
    phi = math.atan2(b, h) - s * theta
    return -0.75 / R * (s * (g + a_v) * math.sin(phi) + a_h * math.cos(phi))


def one_block_reactions(theta: float, omega: float, a_h: float, a_v: float, b: float, h: float,
                        m: float = 1.0, g: float = 9.81) -> tuple[float, float]:
    """Ground reaction ``(T, N)`` (N) on a block rocking on the corner ``sign(theta)``.

    ``T`` is horizontal (positive towards ``+x``), ``N`` vertical (positive up), both in
    the ground's (= inertial) axes, acting at the pivot corner. ``theta`` (rad, nonzero)
    and ``omega`` (rad/s) are clockwise positive; ``a_h``, ``a_v`` (m/s^2) the ground
    accelerations; ``b``, ``h`` (m) half dimensions; ``m`` (kg); ``g`` (m/s^2).
    Closed form (``s = sign(theta)``, ``phi = alpha - s theta``, ``G = g + a_v``)::

        T = m [ a_h (1 - 3/4 cos^2 phi) - 3/4 s G sin phi cos phi + s R omega^2 sin phi ]
        N = m [ G (1 - 3/4 sin^2 phi) - 3/4 s a_h sin phi cos phi - R omega^2 cos phi ]

    The angular acceleration is eliminated with the equation of motion, so the result
    is the reaction the no-slip, no-flight contact must supply in that state.
    """
    s = _pivot_sign(theta)
    R = math.hypot(b, h)
    phi = math.atan2(b, h) - s * theta
    sp, cp = math.sin(phi), math.cos(phi)
    G = g + a_v
    T = m * (a_h * (1.0 - 0.75 * cp * cp) - 0.75 * s * G * sp * cp + s * R * omega * omega * sp)
    N = m * (G * (1.0 - 0.75 * sp * sp) - 0.75 * s * a_h * sp * cp - R * omega * omega * cp)
    return T, N


def one_block_rest_reactions(a_h: float, a_v: float, b: float, h: float, m: float = 1.0,
                             g: float = 9.81) -> tuple[float, float, float]:
    """Reactions on a block resting on both bottom corners and moving with the ground.

    Returns ``(T, N_left, N_right)`` in newtons: ``T = m a_h`` is the total horizontal
    reaction (positive ``+x``; its split between the corners is statically
    indeterminate), ``N_left``, ``N_right`` the vertical (upward positive) forces at the
    corners ``x = -b`` and ``x = +b``, from moment balance about the centre of mass::

        N_left  = m/2 (g + a_v + a_h h / b),   N_right = m/2 (g + a_v - a_h h / b)

    A negative value means that corner would need tension: it lifts.
    """
    G = g + a_v
    T = m * a_h
    N_left = 0.5 * m * (G + a_h * h / b)
    N_right = 0.5 * m * (G - a_h * h / b)
    return T, N_left, N_right


def _rot(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s], [-s, c]])


def _drot(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[-s, c], [-c, -s]])


def _cw(d: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Clockwise moment (N m) of the force F applied at offset d; F may carry extra columns."""
    return d[1] * F[0] - d[0] * F[1]


def _stack_affine(theta1: float, omega1: float, theta2: float, omega2: float, s1: float, s2: float,
                  a_h: float, a_v: float, b1: float, h1: float, m1: float, b2: float, h2: float,
                  m2: float, g: float) -> dict:
    """Kinematics and the forces as affine functions of (alpha1, alpha2).

    Every force/residual X is returned as a pair (X0, X1) with X = X0 + X1 @ (alpha1, alpha2).
    """
    s1 = 1.0 if s1 > 0 else -1.0
    s2 = 1.0 if s2 > 0 else -1.0
    c = min(b1, b2)
    P1 = np.array([s1 * b1, 0.0])
    u1 = np.array([0.0, h1]) - P1
    uK = np.array([s2 * c, 2.0 * h1]) - P1
    u2 = np.array([0.0, h2]) - np.array([s2 * c, 0.0])
    R1, R2 = _rot(theta1), _rot(theta2)
    D1, D2 = _drot(theta1), _drot(theta2)

    r1 = P1 + R1 @ u1
    rK = P1 + R1 @ uK
    r2 = rK + R2 @ u2

    # relative accelerations r'' = J @ (alpha1, alpha2) + cvec
    J1 = np.column_stack([D1 @ u1, np.zeros(2)])
    JK = np.column_stack([D1 @ uK, np.zeros(2)])
    J2 = JK + np.column_stack([np.zeros(2), D2 @ u2])
    c1 = -(R1 @ u1) * omega1 ** 2
    cK = -(R1 @ uK) * omega1 ** 2
    c2 = cK - (R2 @ u2) * omega2 ** 2

    Ag = np.array([a_h, g + a_v])  # ground acceleration plus the "gravity support" term
    # block 2: F = m2 (A + gy + r2'')
    F0, F1 = m2 * (Ag + c2), m2 * J2
    # block 1: Q = m1 (A + gy + r1'') + F
    Q0, Q1 = m1 * (Ag + c1) + F0, m1 * J1 + F1

    Ic1 = m1 * (b1 * b1 + h1 * h1) / 3.0
    Ic2 = m2 * (b2 * b2 + h2 * h2) / 3.0
    e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    res2_0 = -_cw(rK - r2, F0)
    res2_1 = Ic2 * e2 - _cw(rK - r2, F1)
    res1_0 = -_cw(P1 - r1, Q0) + _cw(rK - r1, F0)
    res1_1 = Ic1 * e1 - _cw(P1 - r1, Q1) + _cw(rK - r1, F1)

    return {
        "R1": R1, "F": (F0, F1), "Q": (Q0, Q1),
        "res1": (res1_0, res1_1), "res2": (res2_0, res2_1),
    }


def stack_reactions(theta1: float, omega1: float, alpha1: float, theta2: float, omega2: float,
                    alpha2: float, s1: float, s2: float, a_h: float, a_v: float, b1: float,
                    h1: float, m1: float, b2: float, h2: float, m2: float,
                    g: float = 9.81) -> dict[str, float]:
    """Newton-Euler forces on two stacked blocks in a given state with given accelerations.

    Inputs: absolute clockwise rotations ``theta1``, ``theta2`` (rad), angular velocities
    ``omega1``, ``omega2`` (rad/s) and accelerations ``alpha1``, ``alpha2`` (rad/s^2);
    pivot indicators ``s1`` (block 1's ground corner, +1 right / -1 left) and ``s2`` (end
    ``s2 c`` of the contact on which block 2 turns, ``c = min(b1, b2)``); ground
    accelerations ``a_h``, ``a_v`` (m/s^2); half dimensions (m) and masses (kg); ``g``.

    Returns (newtons, and N m for the residuals):

    - ``interface_x``, ``interface_y``: force of block 1 on block 2 at K, global axes;
    - ``interface_T``, ``interface_N``: the same force along block 1's rotated ``+x``
      axis (tangential) and rotated ``+y`` axis (normal, positive = compression);
    - ``ground_T``, ``ground_N``: ground force on block 1 at its pivot, global x and y;
    - ``residual1``, ``residual2``: ``Ic_i alpha_i`` minus the clockwise moment about the
      block's centre of mass of the contact forces on it; zero only if ``alpha1``,
      ``alpha2`` are the true accelerations (see :func:`stack_angular_accelerations`).
    """
    k = _stack_affine(theta1, omega1, theta2, omega2, s1, s2, a_h, a_v, b1, h1, m1, b2, h2, m2, g)
    al = np.array([alpha1, alpha2], dtype=float)
    F = k["F"][0] + k["F"][1] @ al
    Q = k["Q"][0] + k["Q"][1] @ al
    res1 = k["res1"][0] + k["res1"][1] @ al
    res2 = k["res2"][0] + k["res2"][1] @ al
    R1 = k["R1"]
    ex = R1 @ np.array([1.0, 0.0])  # block 1's rotated +x axis
    ey = R1 @ np.array([0.0, 1.0])  # block 1's rotated +y axis
    return {
        "interface_T": float(F @ ex),
        "interface_N": float(F @ ey),
        "interface_x": float(F[0]),
        "interface_y": float(F[1]),
        "ground_T": float(Q[0]),
        "ground_N": float(Q[1]),
        "residual1": float(res1),
        "residual2": float(res2),
    }


def stack_angular_accelerations(theta1: float, omega1: float, theta2: float, omega2: float,
                                s1: float, s2: float, a_h: float, a_v: float, b1: float,
                                h1: float, m1: float, b2: float, h2: float, m2: float,
                                g: float = 9.81) -> tuple[float, float]:
    """The ``(alpha1, alpha2)`` (rad/s^2, clockwise) that zero both Newton-Euler residuals.

    Same state arguments as :func:`stack_reactions`. The residuals are affine in the
    accelerations, ``res = res0 + M @ alpha``, so this solves the 2x2 system ``M alpha =
    -res0``: the motion with both contacts closed at the given pivots.
    """
    k = _stack_affine(theta1, omega1, theta2, omega2, s1, s2, a_h, a_v, b1, h1, m1, b2, h2, m2, g)
    M = np.vstack([k["res1"][1], k["res2"][1]])
    r0 = np.array([k["res1"][0], k["res2"][0]])
    al = np.linalg.solve(M, -r0)
    return float(al[0]), float(al[1])


def friction_demand(T: float, N: float) -> float:
    """Friction coefficient needed to prevent sliding: ``|T| / N`` for ``N > 0``, else ``inf``.

    ``N <= 0`` means the contact would need tension (it lifts off), so no finite
    coefficient suffices.
    """
    if N > 0:
        return abs(T) / N
    return math.inf


def rocking_slide_threshold(b: float, h: float, mu: float) -> float:
    """Horizontal ground acceleration over G = g + a_v at which a block that has just
    uplifted (theta -> 0 on the corner the ground tips it to, omega = 0) needs more
    friction than ``mu``. From :func:`one_block_reactions` with ``phi = alpha`` and
    ``s a_h < 0`` (the ground tips the block away from its direction of motion)::

        |T| / N = (x (1 - 3/4 cos^2 a) + 3/4 sin a cos a) / ((1 - 3/4 sin^2 a) + 3/4 x sin a cos a)

    with ``x = |a_h| / G``; it equals ``tan(alpha)`` at uplift (``x = tan(alpha)``) and
    grows with ``x``. Solving ``|T| / N = mu``::

        x = (mu (1 - 3/4 sin^2 a) - 3/4 sin a cos a) / ((1 - 3/4 cos^2 a) - 3/4 mu sin a cos a)

    Returns that ``x`` (dimensionless; inf when no ``|a_h|`` reaches ``mu``, the
    denominator being <= 0). For ``mu < tan(alpha)`` the block slides before it
    uplifts, at ``x = mu``, and this is not the threshold that applies.
    """
    a = math.atan2(b, h)
    s, c = math.sin(a), math.cos(a)
    den = (1.0 - 0.75 * c * c) - 0.75 * mu * s * c
    if den <= 0:
        return math.inf
    return (mu * (1.0 - 0.75 * s * s) - 0.75 * s * c) / den
