"""Independent event-driven reference for a rocking-sliding stack of two blocks.

Derivation: docs/stack_sliding.md. Block 1 stands on the ground, block 2 on block 1's top.
Generalised coordinates ``q = (u1, theta1, u2, theta2)``:

- ``u1`` (m): x of block 1's pivot corner on the ground minus its rest offset ``s1 b1`` (the
  displacement of block 1's base centre whenever it is flat), positive towards ``+x``;
- ``theta1`` (rad): block 1's absolute rotation, clockwise positive;
- ``u2`` (m): position of block 2's pivot corner along block 1's top surface (block 1's frame)
  minus its rest offset ``s2 b2``: block 2's slip relative to block 1;
- ``theta2`` (rad): block 2's absolute rotation, clockwise positive.

Each contact (ground, interface) has a mode: flat or rocking on the corner ``s`` (+1 right,
-1 left), sticking or sliding with ``sigma`` (the sign of the slip rate). Every combined
pattern is one 10 x 10 linear system (Newton-Euler on both blocks, six equations, plus two
kinematic or friction rows per contact) in the four generalised accelerations and the six
contact unknowns ``(T0, N0, M0, T1, N1, M1)``: tangential force, normal force and couple at
the ground (on block 1, at its pivot) and at the interface (on block 2, at its pivot, in block
1's surface frame). Patterns are chosen at every event by enumerating the candidates and
keeping the first consistent one (a small LCP solved by enumeration); impacts use the same
matrix with velocities and impulses. scipy's solve_ivp (DOP853) integrates between events.

Limits: block 2 no wider than block 1 (``b2 <= b1``), so block 2 turns about its own corners;
a block that leaves a contact (flight) ends the run with the outcome reported.
SI units throughout; signs as docs/conventions.md.
"""

from __future__ import annotations

import bisect
import itertools
import math
import time as _time
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from model.two_blocks import drot, rot

Ground = Callable[[float], tuple[float, float]]

TOL_OPEN = 1e-9  # normalised margin below which a closed contact opens (as docs/two_blocks.md)
TOL_FRICTION = 1e-12  # normalised friction margin offset of the stick-to-slip events
GAP_EPS = 1e-15  # rad: impact events are s * gap + GAP_EPS falling through 0
TOL_SLIP_ACC = 1e-9  # a slip starting from rest may accelerate against its sign by this much of g
EDGE_EPS = 1e-12  # m: block 2's pivot falls off once it is this far beyond block 1's edge
SLIP_EPS = 1e-15  # m/s: slip-stop events are sigma u' + SLIP_EPS falling through 0 (not the start's 0)
NX = 10  # unknowns of a pattern: 4 generalised accelerations + 6 contact unknowns


def no_ground(t: float) -> tuple[float, float]:
    """No excitation: ``(a_h, a_v) = (0, 0)`` (m/s^2)."""
    return 0.0, 0.0


class StackReferenceError(RuntimeError):
    """No consistent pattern, or no progress at an event."""


# ----------------------------------------------------------------------------------------- the model


@dataclass(frozen=True)
class SlidingStack:
    """Two blocks: half widths b, half heights h (m), masses m (kg), one friction coefficient per
    contact (static = kinetic), the restitution law ("momentum": plastic impact with friction;
    "constant": that impact's velocity field scaled to keep ``eta^2`` of the kinetic energy)."""

    b1: float
    h1: float
    m1: float
    b2: float
    h2: float
    m2: float
    mu_ground: float = 0.7
    mu_interface: float = 0.7
    g: float = 9.81
    law: str = "momentum"
    eta_ground: float = 0.95
    eta_interface: float = 0.98
    rest_ratio: float = 1e-6

    def __post_init__(self) -> None:
        if self.b2 > self.b1:
            raise ValueError("the reference needs block 2 no wider than block 1 (b2 <= b1)")
        if self.law not in ("momentum", "constant"):
            raise ValueError(f"law must be 'momentum' or 'constant', got {self.law!r}")

    @property
    def Ic1(self) -> float:
        """Moment of inertia of block 1 about its centre (kg m^2)."""
        return self.m1 * (self.b1**2 + self.h1**2) / 3.0

    @property
    def Ic2(self) -> float:
        """Moment of inertia of block 2 about its centre (kg m^2)."""
        return self.m2 * (self.b2**2 + self.h2**2) / 3.0

    @property
    def yG(self) -> float:
        """Height of the stack's centre of mass at rest (m)."""
        return (self.m1 * self.h1 + self.m2 * (2 * self.h1 + self.h2)) / (self.m1 + self.m2)


class ContactMode(NamedTuple):
    """One contact's mode: flat (faces together) or rocking on corner ``s``; sticking or sliding
    with ``sigma`` = sign of the slip rate (0 while it sticks)."""

    flat: bool
    s: int
    sigma: int

    @property
    def slides(self) -> bool:
        return self.sigma != 0

    def label(self) -> str:
        kind = ("slide" if self.slides else "stick") if self.flat else ("slide-rock" if self.slides else "rock")
        return kind


class Pattern(NamedTuple):
    ground: ContactMode
    interface: ContactMode

    def label(self) -> str:
        return f"{self.ground.label()}/{self.interface.label()}"


REST = Pattern(ContactMode(True, 1, 0), ContactMode(True, 1, 0))


# rot(theta): the clockwise rotation of body-frame vectors, and drot = d rot / d theta (plain
# geometry, shared with the rigid stack's reference)


@dataclass
class Kinematics:
    """Positions (m), Jacobians ``dr/dq`` (2 x 4) and velocity-product accelerations ``c`` (m/s^2)
    of both centres, the ground pivot ``P`` and block 2's pivot ``K``, and block 1's top-surface
    tangent ``t`` and normal ``n``."""

    r1: np.ndarray
    r2: np.ndarray
    J1: np.ndarray
    J2: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    P: np.ndarray
    K: np.ndarray
    t: np.ndarray
    n: np.ndarray


def kinematics(st: SlidingStack, q: np.ndarray, w: np.ndarray, s1: int, s2: int) -> Kinematics:
    """Kinematics of the stack with ground pivot ``s1`` and block 2 pivot ``s2`` (docs/stack_sliding.md)."""
    u1, th1, u2, th2 = q
    R1, D1, R2, D2 = rot(th1), drot(th1), rot(th2), drot(th2)
    ex = np.array([1.0, 0.0])
    P = np.array([s1 * st.b1 + u1, 0.0])
    v1 = np.array([-s1 * st.b1, st.h1])
    k = np.array([s2 * st.b2 + u2 - s1 * st.b1, 2.0 * st.h1])
    v2 = np.array([-s2 * st.b2, st.h2])
    r1 = P + R1 @ v1
    K = P + R1 @ k
    r2 = K + R2 @ v2
    J1 = np.column_stack([ex, D1 @ v1, np.zeros(2), np.zeros(2)])
    JK = np.column_stack([ex, D1 @ k, R1 @ ex, np.zeros(2)])
    J2 = JK + np.column_stack([np.zeros(2), np.zeros(2), np.zeros(2), D2 @ v2])
    c1 = -R1 @ v1 * w[1] ** 2
    cK = -R1 @ k * w[1] ** 2 + 2.0 * (D1 @ ex) * w[1] * w[2]
    c2 = cK - R2 @ v2 * w[3] ** 2
    return Kinematics(r1, r2, J1, J2, c1, c2, P, K, R1 @ ex, R1 @ np.array([0.0, 1.0]))


def _moment_row(d: np.ndarray, direction: np.ndarray) -> float:
    """Clockwise moment (about the point d is measured from) of a unit force along ``direction``
    applied at offset ``d``: ``dy Fx - dx Fy``."""
    return d[1] * direction[0] - d[0] * direction[1]


def pattern_matrix(st: SlidingStack, kin: Kinematics, pat: Pattern) -> np.ndarray:
    """The pattern's 10 x 10 matrix: rows 0-5 Newton-Euler (block 1: x, y, moment; block 2: x, y,
    moment), rows 6-7 the ground's mode, rows 8-9 the interface's. Unknowns
    ``(q''[4], T0, N0, M0, T1, N1, M1)``."""
    A = np.zeros((NX, NX))
    ex, ey = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    T0, N0, M0, T1, N1, M1 = 4, 5, 6, 7, 8, 9
    dP1, dK1, dK2 = kin.P - kin.r1, kin.K - kin.r1, kin.K - kin.r2
    # block 1: m1 r1'' = F0 - F1 - m1 (ah, G);  Ic1 th1'' = mom(F0 at P) + M0 - mom(F1 at K) - M1
    A[0, :4], A[1, :4] = st.m1 * kin.J1[0], st.m1 * kin.J1[1]
    A[0, T0], A[1, N0] = -1.0, -1.0
    A[0, T1], A[0, N1], A[1, T1], A[1, N1] = kin.t[0], kin.n[0], kin.t[1], kin.n[1]
    A[2, 1] = st.Ic1
    A[2, T0], A[2, N0], A[2, M0] = -_moment_row(dP1, ex), -_moment_row(dP1, ey), -1.0
    A[2, T1], A[2, N1], A[2, M1] = _moment_row(dK1, kin.t), _moment_row(dK1, kin.n), 1.0
    # block 2: m2 r2'' = F1 - m2 (ah, G);  Ic2 th2'' = mom(F1 at K) + M1
    A[3, :4], A[4, :4] = st.m2 * kin.J2[0], st.m2 * kin.J2[1]
    A[3, T1], A[3, N1], A[4, T1], A[4, N1] = -kin.t[0], -kin.n[0], -kin.t[1], -kin.n[1]
    A[5, 3] = st.Ic2
    A[5, T1], A[5, N1], A[5, M1] = -_moment_row(dK2, kin.t), -_moment_row(dK2, kin.n), -1.0
    _mode_rows(A, 6, pat.ground, rot_cols=(1,), slip_col=0, T=T0, N=N0, M=M0, mu=st.mu_ground)
    _mode_rows(A, 8, pat.interface, rot_cols=(3, 1), slip_col=2, T=T1, N=N1, M=M1, mu=st.mu_interface)
    return A


def _mode_rows(A: np.ndarray, row: int, mode: ContactMode, rot_cols: tuple[int, ...], slip_col: int,
               T: int, N: int, M: int, mu: float) -> None:
    """Two rows of one contact: flat (relative rotation fixed) or rocking (no couple); sticking
    (slip fixed) or sliding (``T + sigma mu N = 0``)."""
    if mode.flat:
        A[row, rot_cols[0]] = 1.0
        if len(rot_cols) > 1:
            A[row, rot_cols[1]] = -1.0
    else:
        A[row, M] = 1.0
    if mode.slides:
        A[row + 1, T], A[row + 1, N] = 1.0, mode.sigma * mu
    else:
        A[row + 1, slip_col] = 1.0


def _pivots(pat: Pattern) -> tuple[int, int]:
    return pat.ground.s, pat.interface.s


@dataclass
class PatternSolution:
    """Generalised accelerations ``qdd`` (m/s^2, rad/s^2) and contact forces (N, N m):
    ``T0, N0, M0`` on block 1 from the ground at its pivot, ``T1, N1, M1`` on block 2 from block 1
    at block 2's pivot (T along block 1's top surface, N normal to it, M clockwise)."""

    qdd: np.ndarray
    forces: np.ndarray
    kin: Kinematics


def solve_pattern(st: SlidingStack, pat: Pattern, q, w, ah: float, av: float) -> PatternSolution:
    """Solve the pattern's linear system at state (q, w) under ground accelerations (ah, av)."""
    q, w = np.asarray(q, float), np.asarray(w, float)
    kin = kinematics(st, q, w, *_pivots(pat))
    A = pattern_matrix(st, kin, pat)
    G = st.g + av
    b = np.zeros(NX)
    b[0:2] = -st.m1 * (kin.c1 + np.array([ah, G]))
    b[3:5] = -st.m2 * (kin.c2 + np.array([ah, G]))
    z = np.linalg.solve(A, b)
    qdd = _exact_constraints(z[:4].copy(), pat)
    return PatternSolution(qdd, z[4:].copy(), kin)


def _exact_constraints(qd: np.ndarray, pat: Pattern) -> np.ndarray:
    """Set the components a pattern fixes exactly (the solve leaves rounding residue)."""
    if pat.ground.flat:
        qd[1] = 0.0
    if not pat.ground.slides:
        qd[0] = 0.0
    if pat.interface.flat:
        qd[3] = qd[1]
    if not pat.interface.slides:
        qd[2] = 0.0
    return qd


def residuals(st: SlidingStack, sol: PatternSolution, ah: float, av: float) -> np.ndarray:
    """Newton-Euler residuals (N, N, N m, N, N, N m) of both blocks with the solved accelerations and
    forces, written out from the free-body diagrams (independent of the matrix assembly)."""
    kin, f, qdd = sol.kin, sol.forces, sol.qdd
    T0, N0, M0, T1, N1, M1 = f
    G = st.g + av
    a1 = kin.J1 @ qdd + kin.c1
    a2 = kin.J2 @ qdd + kin.c2
    F0 = np.array([T0, N0])
    F1 = T1 * kin.t + N1 * kin.n

    def mom(p: np.ndarray, r: np.ndarray, F: np.ndarray) -> float:
        d = p - r
        return -(d[0] * F[1] - d[1] * F[0])

    res = np.zeros(6)
    res[0:2] = st.m1 * a1 - (F0 - F1 + st.m1 * np.array([-ah, -G]))
    res[2] = st.Ic1 * qdd[1] - (mom(kin.P, kin.r1, F0) + M0 - mom(kin.K, kin.r1, F1) - M1)
    res[3:5] = st.m2 * a2 - (F1 + st.m2 * np.array([-ah, -G]))
    res[5] = st.Ic2 * qdd[3] - (mom(kin.K, kin.r2, F1) + M1)
    return res


# ------------------------------------------------------------------------------------ contact geometry


def interface_ends(st: SlidingStack, u2: float) -> tuple[float, float]:
    """Left and right ends (m, block 1's top frame) of the overlap of block 2's base, centred at u2,
    with block 1's top."""
    return max(-st.b1, u2 - st.b2), min(st.b1, u2 + st.b2)


def _flat_margins(d_left: float, d_right: float, N: float, M: float) -> tuple[float, float]:
    """Moments (N m) about the right and left ends of a flat contact of its force system (normal N at
    the pivot plus couple M, clockwise): both >= 0 exactly when the resultant passes inside it."""
    return d_right * N + M, -(d_left * N + M)


def contact_indicators(st: SlidingStack, pat: Pattern, q, sol: PatternSolution) -> dict[str, float]:
    """Normalised indicators of both contacts (all must be >= 0 for the pattern to hold).

    ``g_right``/``g_left``, ``i_right``/``i_left``: flat contacts' end margins over weight times
    half width (as docs/two_blocks.md); ``g_N``, ``i_N``: normal forces over the weight carried;
    ``g_fric``: (mu N - |T|) over the weight carried, for sticking contacts."""
    T0, N0, M0, T1, N1, M1 = sol.forces
    W0, W1 = (st.m1 + st.m2) * st.g, st.m2 * st.g
    out = {"g_N": N0 / W0, "i_N": N1 / W1}
    s1, s2 = _pivots(pat)
    if pat.ground.flat:
        r, l_ = _flat_margins(-st.b1 - s1 * st.b1, st.b1 - s1 * st.b1, N0, M0)
        out["g_right"], out["g_left"] = r / (W0 * st.b1), l_ / (W0 * st.b1)
    if pat.interface.flat:
        lo, hi = interface_ends(st, q[2])
        k = s2 * st.b2 + q[2]
        r, l_ = _flat_margins(lo - k, hi - k, N1, M1)
        out["i_right"], out["i_left"] = r / (W1 * st.b2), l_ / (W1 * st.b2)
    if not pat.ground.slides:
        out["g_fric"] = (st.mu_ground * N0 - abs(T0)) / W0
    if not pat.interface.slides:
        out["i_fric"] = (st.mu_interface * N1 - abs(T1)) / W1
    return out


# ----------------------------------------------------------------------------------- pattern choice


def _gap(q, w, contact: str) -> tuple[float, float, float]:
    """(gap angle, its rate, slip rate) of a contact."""
    if contact == "ground":
        return q[1], w[1], w[0]
    return q[3] - q[1], w[3] - w[1], w[2]


def _sign(x: float) -> int:
    return 1 if x > 0 else -1


def contact_candidates(q, w, contact: str, exclude_flat: bool = False,
                       exclude_stick: bool = False) -> list[ContactMode]:
    """Modes a contact may take from state (q, w): flat only with zero gap and zero gap rate,
    a rocking corner fixed by the gap's sign (or its rate's) when open, sliding with the slip rate's
    sign when it slips; both signs are candidates where the state does not decide."""
    gap, rate, slip = _gap(q, w, contact)
    closed = gap == 0.0 and rate == 0.0
    if closed:
        kinds = ([] if exclude_flat else [(True, 1)]) + [(False, 1), (False, -1)]
    else:
        kinds = [(False, _sign(gap) if gap != 0.0 else _sign(rate))]
    sigmas = ([] if exclude_stick else [0]) + [1, -1] if slip == 0.0 else [_sign(slip)]
    return [ContactMode(flat, s, sg) for (flat, s), sg in itertools.product(kinds, sigmas)]


def _order_key(p: Pattern) -> tuple[int, int, int]:
    """Least motion first: fewer rocking contacts, fewer sliding ones, the ground rocking before the
    interface (the rigid stack's order: locked pair before block 2 alone)."""
    n_rock = (not p.ground.flat) + (not p.interface.flat)
    n_slide = p.ground.slides + p.interface.slides
    return n_rock, n_slide, int(p.ground.flat)


def consistent(st: SlidingStack, pat: Pattern, q, w, sol: PatternSolution, allow_overhang: bool = False) -> bool:
    """Whether a solved pattern obeys the contact laws at (q, w): compressive normal forces, flat
    contacts' resultant inside the contact, friction inside the cone where a contact sticks, a
    slip starting from rest accelerating the way friction opposes, a contact opening from zero gap
    accelerating open."""
    ind = contact_indicators(st, pat, q, sol)
    tol_acc = 1e-12 * st.g / math.hypot(st.b1, st.yG)
    for key, val in ind.items():
        tol = TOL_OPEN if key.endswith(("right", "left")) else 1e-12
        if val < -tol:
            return False
    if not pat.interface.flat and abs(q[2] + pat.interface.s * st.b2) > st.b1 and not allow_overhang:
        return False  # block 2's corner is off block 1's top: it cannot turn about it
    for contact, mode in (("ground", pat.ground), ("interface", pat.interface)):
        gap, rate, slip = _gap(q, w, contact)
        slip_acc = sol.qdd[0] if contact == "ground" else sol.qdd[2]
        gap_acc = sol.qdd[1] if contact == "ground" else sol.qdd[3] - sol.qdd[1]
        if mode.slides and slip == 0.0 and mode.sigma * slip_acc < -TOL_SLIP_ACC * st.g:
            return False
        if not mode.flat and gap == 0.0 and rate == 0.0 and mode.s * gap_acc < -tol_acc:
            return False
    return True


def select_pattern(st: SlidingStack, q, w, ah: float, av: float, exclude: dict[str, set[str]] | None = None,
                   allow_rest: bool = True, allow_overhang: bool = False) -> tuple[Pattern, PatternSolution] | None:
    """The first consistent pattern (least motion first) from state (q, w), or None.

    ``exclude[contact]`` may hold "flat" (the contact just opened) or "stick" (it just started
    slipping)."""
    exclude = exclude or {}
    gs = contact_candidates(q, w, "ground", "flat" in exclude.get("ground", ()), "stick" in exclude.get("ground", ()))
    is_ = contact_candidates(q, w, "interface", "flat" in exclude.get("interface", ()),
                             "stick" in exclude.get("interface", ()))
    pats = sorted((Pattern(g, i) for g, i in itertools.product(gs, is_)), key=_order_key)
    for pat in pats:
        if not allow_rest and _is_rest(pat):
            continue
        try:
            sol = solve_pattern(st, pat, q, w, ah, av)
        except np.linalg.LinAlgError:
            continue
        if consistent(st, pat, q, w, sol, allow_overhang):
            return pat, sol
    return None


def _is_rest(p: Pattern) -> bool:
    return p.ground.flat and p.interface.flat and not p.ground.slides and not p.interface.slides


# --------------------------------------------------------------------------------------- energies


def body_velocities(kin: Kinematics, w) -> tuple[np.ndarray, np.ndarray]:
    """Velocities (m/s) of both centres relative to the ground."""
    return kin.J1 @ w, kin.J2 @ w


def kinetic_energy(st: SlidingStack, q, w, s1: int, s2: int) -> float:
    """Kinetic energy (J) of the motion relative to the ground."""
    kin = kinematics(st, np.asarray(q, float), np.asarray(w, float), s1, s2)
    v1, v2 = body_velocities(kin, w)
    return 0.5 * (st.m1 * v1 @ v1 + st.m2 * v2 @ v2 + st.Ic1 * w[1] ** 2 + st.Ic2 * w[3] ** 2)


def energy(st: SlidingStack, q, w, s1: int, s2: int) -> float:
    """Kinetic plus gravitational potential energy (J), zero with both blocks at rest."""
    kin = kinematics(st, np.asarray(q, float), np.asarray(w, float), s1, s2)
    pot = st.g * (st.m1 * (kin.r1[1] - st.h1) + st.m2 * (kin.r2[1] - 2 * st.h1 - st.h2))
    return kinetic_energy(st, q, w, s1, s2) + pot


def power_terms(st: SlidingStack, sol: PatternSolution, w, ah: float, av: float) -> tuple[float, float, float]:
    """Rates (W) of the ground's work ``-sum m (a_h X' + a_v Y')``, and of the friction losses at the
    ground (``-T0 u1'``) and at the interface (``-T1 u2'``)."""
    v1, v2 = body_velocities(sol.kin, w)
    work = -(st.m1 * (ah * v1[0] + av * v1[1]) + st.m2 * (ah * v2[0] + av * v2[1]))
    return work, -sol.forces[0] * w[0], -sol.forces[3] * w[2]


# ----------------------------------------------------------------------------------------- impacts


def _velocity_vector(kin: Kinematics, w) -> np.ndarray:
    """Momentum right-hand side helper: body velocities (v1x, v1y, w1, v2x, v2y, w2)."""
    v1, v2 = body_velocities(kin, w)
    return np.array([v1[0], v1[1], w[1], v2[0], v2[1], w[3]])


@dataclass
class ImpactSolution:
    """Post-impact rates ``w`` and contact impulses ``(PT0, PN0, PM0, PT1, PN1, PM1)`` (N s, N m s)."""

    pattern: Pattern
    w: np.ndarray
    impulses: np.ndarray
    held: bool = False  # the contact that does not land had to pull and was held (flight left out)


def solve_impact(st: SlidingStack, pat: Pattern, q, w_minus, old: tuple[int, int]) -> ImpactSolution:
    """Impulse-momentum with the pattern after the impact: the same 10 x 10 matrix, rates for
    accelerations and impulses for forces; ``old`` the pivots the pre-impact rates refer to."""
    q = np.asarray(q, float)
    kin_old = kinematics(st, q, np.zeros(4), *old)
    kin = kinematics(st, q, np.zeros(4), *_pivots(pat))
    V = _velocity_vector(kin_old, w_minus)
    b = np.zeros(NX)
    b[0:2], b[2] = st.m1 * V[0:2], st.Ic1 * V[2]
    b[3:5], b[5] = st.m2 * V[3:5], st.Ic2 * V[5]
    z = np.linalg.solve(pattern_matrix(st, kin, pat), b)
    return ImpactSolution(pat, _exact_constraints(z[:4].copy(), pat), z[4:].copy())


def impact_consistent(st: SlidingStack, imp: ImpactSolution, q, landing: str, tol: float,
                      check_normal: bool = True, check_other: bool = True) -> bool:
    """Contact laws on impulses: compressive normal impulses, flat contacts' resultant impulse inside
    the contact, sticking impulses inside the friction cone, a sliding contact slipping the way its
    friction impulse opposes, the landing contact's new corner moving open (or staying flat)."""
    pat, P, w = imp.pattern, imp.impulses, imp.w
    s1, s2 = _pivots(pat)
    PT0, PN0, PM0, PT1, PN1, PM1 = P
    if not check_other:  # the contact that does not land is taken as it comes (sticking, see impact())
        if landing == "ground":
            PN1 = max(PN1, 0.0) + abs(PT1) / st.mu_interface + 1.0
        else:
            PN0 = max(PN0, 0.0) + abs(PT0) / st.mu_ground + 1.0
    if check_normal and (PN0 < -tol or PN1 < -tol):
        return False
    # a flat contact's impulse margins: for the contact that does not land (it must not pull); a flat
    # landing is not held to them (a landing block generally cannot be stopped by compressive
    # impulses alone, docs/two_blocks.md), as the one-block law's flat landing
    if check_normal and check_other and pat.ground.flat and landing != "ground":
        r, l_ = _flat_margins(-st.b1 - s1 * st.b1, st.b1 - s1 * st.b1, PN0, PM0)
        if min(r, l_) < -tol * st.b1:
            return False
    if check_normal and check_other and pat.interface.flat and landing != "interface":
        lo, hi = interface_ends(st, q[2])
        k = s2 * st.b2 + q[2]
        r, l_ = _flat_margins(lo - k, hi - k, PN1, PM1)
        if min(r, l_) < -tol * st.b2:
            return False
    for mode, T, N, mu, slip in ((pat.ground, PT0, PN0, st.mu_ground, w[0]),
                                 (pat.interface, PT1, PN1, st.mu_interface, w[2])):
        if not mode.slides and abs(T) > mu * N + tol:
            return False
        if mode.slides and mode.sigma * slip < 0.0:
            return False
    mode = pat.ground if landing == "ground" else pat.interface
    rate = w[1] if landing == "ground" else w[3] - w[1]
    if not mode.flat and mode.s * rate < 0.0:
        return False
    other = pat.interface if landing == "ground" else pat.ground
    orate = w[3] - w[1] if landing == "ground" else w[1]
    ogap = q[3] - q[1] if landing == "ground" else q[1]
    if not other.flat and ogap == 0.0 and other.s * orate < 0.0:
        return False
    return True


def impact(st: SlidingStack, landing: str, pat: Pattern, q, w_minus) -> ImpactSolution:
    """The impact of a contact landing (``landing`` = "ground" or "interface") in pattern ``pat``:
    the first consistent candidate of: rocking on the new corner (sticking, then sliding), the other
    contact keeping its kind (sticking first), then the other contact opening, then a flat landing.
    With law "constant" the rates are scaled to keep ``eta^2`` of the kinetic energy."""
    q = np.asarray(q, float)
    old = _pivots(pat)
    land = pat.ground if landing == "ground" else pat.interface
    other = pat.interface if landing == "ground" else pat.ground
    new_kinds = [ContactMode(False, -land.s, 0), ContactMode(True, -land.s, 0)]
    other_kinds = [(other.flat, other.s, False)]
    if other.flat:
        other_kinds += [(False, 1, True), (False, -1, True)]
    scale = max(1e-300, np.max(np.abs(_velocity_vector(kinematics(st, q, np.zeros(4), *old), w_minus))))
    tol = 1e-12 * scale * (st.m1 + st.m2)
    cands = []
    for nk in new_kinds:
        for ok in other_kinds:
            for sn, so in itertools.product((0, 1, -1), (0, 1, -1)):
                lm = ContactMode(nk.flat, nk.s, sn)
                om = ContactMode(ok[0], ok[1], so)
                p = Pattern(lm, om) if landing == "ground" else Pattern(om, lm)
                cands.append(((nk.flat, ok[2], (sn != 0) + (so != 0)), p))
    cands.sort(key=lambda c: c[0])
    for _, p in cands:
        try:
            imp = solve_impact(st, p, q, w_minus, old)
        except np.linalg.LinAlgError:
            continue
        if impact_consistent(st, imp, q, landing, tol):
            return _restitute(st, imp, q, w_minus, old, landing)
    # The other contact would have to pull (a flight the model leaves out): it is held sticking
    # in its kind, as the rigid stack holds its pivots, and only the landing contact is checked.
    for _, p in cands:
        om = p.interface if landing == "ground" else p.ground
        if om.slides or om.flat != other.flat:
            continue
        imp = solve_impact(st, p, q, w_minus, old)
        if impact_consistent(st, imp, q, landing, tol, check_other=False):
            imp.held = True
            return _restitute(st, imp, q, w_minus, old, landing)
    imp = _saturated_impact(st, landing, pat, q, w_minus, old)
    if imp is not None:
        return _restitute(st, imp, q, w_minus, old, landing)
    raise StackReferenceError(f"no consistent impact at the {landing} in pattern {pat.label()}")


def _saturated_impact(st: SlidingStack, landing: str, pat: Pattern, q, w_minus, old) -> ImpactSolution | None:
    """Last resort when Coulomb's law has no consistent plastic impact (a slip would have to reverse
    within the impact): the one-block law's rule, contact by contact. Both contacts first stick (the
    landing one on its new corner, the other in its kind); each whose sticking impulse leaves the
    friction cone slides with its friction impulse saturated in the direction of that sticking
    impulse, ``P_T = -sigma mu P_N`` with ``sigma = -sign(P_T)``, whatever the slip after. None if the
    landing contact's normal impulse would pull or the kinetic energy would rise."""
    land = pat.ground if landing == "ground" else pat.interface
    other = pat.interface if landing == "ground" else pat.ground
    lm, om = ContactMode(False, -land.s, 0), ContactMode(other.flat, other.s, 0)
    trial = Pattern(lm, om) if landing == "ground" else Pattern(om, lm)
    stick = solve_impact(st, trial, q, w_minus, old)
    modes = []
    for mode, T, N, mu in ((trial.ground, stick.impulses[0], stick.impulses[1], st.mu_ground),
                           (trial.interface, stick.impulses[3], stick.impulses[4], st.mu_interface)):
        sigma = 0 if abs(T) <= mu * max(N, 0.0) else (-1 if T > 0 else 1)
        modes.append(ContactMode(mode.flat, mode.s, sigma))
    imp = solve_impact(st, Pattern(*modes), q, w_minus, old)
    N = imp.impulses[1] if landing == "ground" else imp.impulses[4]
    if N < 0 or kinetic_energy(st, q, imp.w, *_pivots(imp.pattern)) > kinetic_energy(st, q, w_minus, *old):
        return None
    imp.held = True
    return imp


def _restitute(st: SlidingStack, imp: ImpactSolution, q, w_minus, old, landing: str) -> ImpactSolution:
    if st.law != "constant":
        return imp
    eta = st.eta_ground if landing == "ground" else st.eta_interface
    Tm = kinetic_energy(st, q, w_minus, *old)
    Tp = kinetic_energy(st, q, imp.w, *_pivots(imp.pattern))
    return ImpactSolution(imp.pattern, imp.w * (eta * math.sqrt(Tm / Tp) if Tp > 0 else 0.0), imp.impulses, imp.held)


def settle_rate(st: SlidingStack, contact: str, av: float) -> float:
    """Rebound rate (rad/s) below which a landing contact closes: the rate that would lift the body
    (the pair about a corner of block 1 for the ground, block 2 about its corner for the interface)
    to ``rest_ratio`` of its slenderness angle in free rocking under ``g + a_v`` (docs/two_blocks.md)."""
    ge = st.g + av
    if contact == "interface":
        R = math.hypot(st.b2, st.h2)
        W, a, I = st.m2 * ge, math.atan2(st.b2, st.h2), st.Ic2 + st.m2 * R**2
    else:
        R = math.hypot(st.b1, st.yG)
        kin = kinematics(st, np.zeros(4), np.zeros(4), 1, 1)
        L = np.array([0.0, 1.0, 0.0, 1.0])  # the pair turning as one body about block 1's corner
        v1, v2 = kin.J1 @ L, kin.J2 @ L
        I = st.m1 * v1 @ v1 + st.m2 * v2 @ v2 + st.Ic1 + st.Ic2
        W, a = (st.m1 + st.m2) * ge, math.atan2(st.b1, st.yG)
    lift = math.cos(a - st.rest_ratio * a) - math.cos(a)
    return math.sqrt(2 * W * R * lift / I) if lift > 0 else 0.0


def close_contacts(st: SlidingStack, pat: Pattern, q, w, closing: tuple[str, ...]) -> ImpactSolution:
    """Close the rocking contacts ``closing`` (at zero gap) by a plastic impact onto the pattern in
    which they are flat, every contact keeping its friction mode (sticking or sliding with its sign).
    A regularisation of a negligible rebound, like the rigid stack's settling: its impulses are not
    checked (a flat landing generally cannot be stopped by compressive impulses alone)."""
    g, i = pat.ground, pat.interface
    new = Pattern(ContactMode(g.flat or "ground" in closing, g.s, g.sigma),
                  ContactMode(i.flat or "interface" in closing, i.s, i.sigma))
    return solve_impact(st, new, q, w, _pivots(pat))


# ------------------------------------------------------------------------------------------ the run


@dataclass
class StackEvent:
    """One event: kind (start, impact, settle, open, slip, stick, overturn, fell-off, flight,
    inconsistent), time (s), contact, and the pattern after it."""

    kind: str
    t: float
    contact: str = ""
    pattern: str = ""


@dataclass
class StackRun:
    """A run: samples ``t`` (s), ``y`` (rows u1, theta1, u2, theta2 and their rates), pivots ``s``
    (2 x n), accumulated ``work``/``friction`` (ground, interface)/``impact`` losses (J) per sample,
    the events and the outcomes."""

    stack: SlidingStack
    t: np.ndarray
    y: np.ndarray
    s: np.ndarray
    acc: np.ndarray  # rows: ground work, friction loss ground, friction loss interface, impact loss
    events: list[StackEvent]
    overturn_time: tuple[float | None, float | None] = (None, None)
    fell_off_time: float | None = None
    flight_time: float | None = None
    peak_abs_slip: tuple[float, float] = (0.0, 0.0)
    peak_abs_theta: tuple[float, float] = (0.0, 0.0)
    wall_time: float = 0.0

    @property
    def final_slip(self) -> tuple[float, float]:
        return float(self.y[0, -1]), float(self.y[2, -1])

    @property
    def ground_work(self) -> float:
        return float(self.acc[0, -1])

    @property
    def friction_loss(self) -> tuple[float, float]:
        return float(self.acc[1, -1]), float(self.acc[2, -1])

    @property
    def impact_loss(self) -> float:
        return float(self.acc[3, -1])

    def times(self, kind: str, contact: str | None = None) -> list[float]:
        return [e.t for e in self.events if e.kind == kind and (contact is None or e.contact == contact)]

    def energy(self) -> np.ndarray:
        """E (J) at every sample."""
        return np.array([energy(self.stack, self.y[:4, k], self.y[4:, k], int(self.s[0, k]), int(self.s[1, k]))
                         for k in range(self.t.size)])

    def balance_error(self) -> np.ndarray:
        """``E + losses - E(t0) - ground work`` (J) at every sample."""
        E = self.energy()
        return E + self.acc[1] + self.acc[2] + self.acc[3] - E[0] - self.acc[0]


class _Solver:
    def __init__(self, st: SlidingStack, ground: Ground, breaks: tuple[float, ...], t_end: float,
                 rtol: float, atol: float, max_same_instant: int = 16):
        self.st, self.ground, self.t_end = st, ground, t_end
        self.breaks = sorted(b for b in breaks if 0 < b < t_end)
        self.rtol, self.atol = rtol, atol
        self.events: list[StackEvent] = []
        self.ts: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []
        self.ss: list[np.ndarray] = []
        self.accs: list[np.ndarray] = []
        self.acc = np.zeros(4)
        self.outcome: dict[str, float] = {}
        self.peak_slip = [0.0, 0.0]
        self.peak_theta = [0.0, 0.0]
        self.max_same = max_same_instant

    # -- records
    def record(self, t: np.ndarray, y: np.ndarray, acc: np.ndarray, pat: Pattern) -> None:
        if np.size(t) == 0:
            return
        self.ts.append(np.atleast_1d(t))
        self.ys.append(y.reshape(8, -1))
        self.accs.append(acc.reshape(4, -1))
        self.ss.append(np.tile(np.array(_pivots(pat), float)[:, None], (1, self.ts[-1].size)))
        yy = self.ys[-1]
        self.peak_slip = [max(self.peak_slip[0], float(np.max(np.abs(yy[0])))),
                          max(self.peak_slip[1], float(np.max(np.abs(yy[2]))))]
        self.peak_theta = [max(self.peak_theta[0], float(np.max(np.abs(yy[1])))),
                           max(self.peak_theta[1], float(np.max(np.abs(yy[3]))))]

    def log(self, kind: str, t: float, contact: str = "", pat: Pattern | None = None) -> None:
        self.events.append(StackEvent(kind, t, contact, pat.label() if pat else ""))

    # -- rest
    def rest_indicator(self, pat: Pattern, q, t: float) -> float:
        ah, av = self.ground(t)
        sol = solve_pattern(self.st, pat, q, np.zeros(4), ah, av)
        return min(contact_indicators(self.st, pat, q, sol).values())

    def leave_rest(self, pat: Pattern, q, t0: float, dt: float = 1e-3) -> float | None:
        """First time after t0 at which the rest pattern stops holding (sampled every dt and at the
        breaks, then Brent's method), or None before t_end."""
        f = lambda t: self.rest_indicator(pat, q, t)  # noqa: E731
        if f(t0) < 0:
            return t0
        br = np.asarray(self.breaks, float)
        grid = np.union1d(np.append(np.arange(t0, self.t_end, dt), self.t_end), br[(br > t0) & (br < self.t_end)])
        for a, b in zip(grid[:-1], grid[1:]):
            if f(b) < 0:
                return brentq(f, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        return None

    # -- one segment
    def event_functions(self, pat: Pattern) -> tuple[list, list[tuple[str, str]]]:
        st = self.st
        s1, s2 = _pivots(pat)
        cache: dict = {}

        def solved(t: float, y: np.ndarray) -> tuple[PatternSolution, dict[str, float]]:
            key = (t, y[:8].tobytes())
            if key not in cache:
                cache.clear()
                ah, av = self.ground(t)
                sol = solve_pattern(st, pat, y[:4], y[4:8], ah, av)
                cache[key] = (sol, contact_indicators(st, pat, y[:4], sol))
            return cache[key]

        fns, kinds = [], []

        def add(fn, direction: int, kind: str, contact: str, terminal: bool = True) -> None:
            fn.terminal, fn.direction = terminal, direction
            fns.append(fn)
            kinds.append((kind, contact))

        def ind(name: str, offset: float):
            return lambda t, y: solved(t, y)[1][name] + offset

        if not pat.ground.flat:
            add(lambda t, y: s1 * y[1] + GAP_EPS, -1, "impact", "ground")
            add(lambda t, y: s1 * y[1] - math.pi / 2, 1, "overturn", "ground")
            add(ind("g_N", 1e-12), -1, "flight", "ground")
        else:
            add(ind("g_right", TOL_OPEN), -1, "open", "ground")
            add(ind("g_left", TOL_OPEN), -1, "open", "ground")
        if not pat.interface.flat:
            add(lambda t, y: s2 * (y[3] - y[1]) + GAP_EPS, -1, "impact", "interface")
            add(lambda t, y: s2 * (y[3] - y[1]) - math.pi / 2, 1, "overturn", "interface")
            add(ind("i_N", 1e-12), -1, "flight", "interface")
            add(lambda t, y: abs(y[2] + s2 * st.b2) - st.b1 - EDGE_EPS, 1, "fell-off", "interface")
        else:
            add(ind("i_right", TOL_OPEN), -1, "open", "interface")
            add(ind("i_left", TOL_OPEN), -1, "open", "interface")
        for contact, mode, k in (("ground", pat.ground, 0), ("interface", pat.interface, 2)):
            if mode.slides:
                add(lambda t, y, k=k, sg=mode.sigma: sg * y[4 + k] + SLIP_EPS, -1, "stick", contact)
            else:
                add(ind(contact[0] + "_fric", TOL_FRICTION), -1, "slip", contact)
        if not pat.ground.flat:
            add(lambda t, y: y[5], 0, "peak", "ground", terminal=False)
        if not pat.interface.flat:
            add(lambda t, y: y[7], 0, "peak", "interface", terminal=False)
        return fns, kinds

    def integrate(self, pat: Pattern, t: float, q: np.ndarray, w: np.ndarray):
        """Integrate pattern ``pat`` from t to the next break or the first terminal event."""
        st = self.st
        k = bisect.bisect_right(self.breaks, t)
        t_stop = self.breaks[k] if k < len(self.breaks) else self.t_end

        def rhs(tt: float, y: np.ndarray) -> np.ndarray:
            ah, av = self.ground(tt)
            sol = solve_pattern(st, pat, y[:4], y[4:8], ah, av)
            work, f0, f1 = power_terms(st, sol, y[4:8], ah, av)
            return np.concatenate([y[4:8], sol.qdd, [work, f0, f1]])

        fns, kinds = self.event_functions(pat)
        y0 = np.concatenate([q, w, self.acc[:3]])
        atol = np.concatenate([np.full(8, self.atol), np.full(3, self.atol)])
        r = solve_ivp(rhs, (t, t_stop), y0, method="DOP853", rtol=self.rtol, atol=atol, events=fns)
        if r.status == -1:
            raise StackReferenceError(r.message)
        n = r.t.size
        acc = np.vstack([r.y[8:11], np.full((1, n), self.acc[3])])
        hit_any = any(te.size and kinds[i][0] != "peak" for i, te in enumerate(r.t_events))
        last = n - 1 if hit_any else n  # an event's state is recorded below, from real steps
        self.record(r.t[1:last], r.y[:8, 1:last], acc[:, 1:last], pat)
        for i, (kind, _) in enumerate(kinds):
            if kind == "peak" and r.y_events[i].size:
                ye = r.y_events[i]
                self.peak_theta = [max(self.peak_theta[0], float(np.max(np.abs(ye[:, 1])))),
                                   max(self.peak_theta[1], float(np.max(np.abs(ye[:, 3]))))]
        hits = [(te[0], i) for i, te in enumerate(r.t_events) if te.size and kinds[i][0] != "peak"]
        if not hits:
            y = r.y[:, -1]
            self.acc[:3] = y[8:11]
            return float(r.t[-1]), y[:4].copy(), y[4:8].copy(), None
        te, i = min(hits)
        y = self.refine(rhs, r, te, r.y_events[i][0], atol)
        if kinds[i][0] == "impact":  # the gap's root on the real-step trajectory (Newton on the time)
            te, y = self.refine_gap(rhs, r, te, y, fns[i], atol)
        self.acc[:3] = y[8:11]
        self.record(np.array([te]), y[:8], np.append(y[8:11], self.acc[3]), pat)
        return float(te), y[:4].copy(), y[4:8].copy(), kinds[i]

    def refine(self, rhs, r, te: float, y_dense: np.ndarray, atol: np.ndarray) -> np.ndarray:
        """The state at an event by real steps from the last accepted step (the dense output the event
        was located on is an order less accurate), keeping the located event time."""
        k = int(np.searchsorted(r.t, te)) - 1
        while k > 0 and r.t[k] >= te:
            k -= 1
        if k < 0 or r.t[k] >= te:
            return y_dense
        again = solve_ivp(rhs, (float(r.t[k]), te), r.y[:, k], method="DOP853", rtol=self.rtol, atol=atol)
        return again.y[:, -1] if again.success else y_dense

    def refine_gap(self, rhs, r, te: float, y: np.ndarray, fn, atol: np.ndarray, iterations: int = 3):
        """Move an impact's time by Newton steps until the gap's event function vanishes on the
        real-step trajectory (its rate is the gap's rate, ``fn`` being linear in the angles)."""
        k = int(np.searchsorted(r.t, te)) - 1
        while k > 0 and r.t[k] >= te:
            k -= 1
        for _ in range(iterations):
            g = fn(te, y)
            rate = fn(te, np.concatenate([y[4:8], np.zeros(4), y[8:]])) - fn(te, np.zeros_like(y))
            if g == 0.0 or rate == 0.0 or k < 0:
                break
            t_new = te - g / rate
            if not r.t[k] < t_new or abs(t_new - te) > 1e-6:
                break
            again = solve_ivp(rhs, (float(r.t[k]), t_new), r.y[:, k], method="DOP853", rtol=self.rtol, atol=atol)
            if not again.success:
                break
            te, y = t_new, again.y[:, -1]
        return te, y

    # -- events
    def choose(self, t: float, q, w, exclude=None, allow_rest: bool = True) -> Pattern | None:
        ah, av = self.ground(t)
        found = select_pattern(self.st, q, w, ah, av, exclude, allow_rest)
        return None if found is None else found[0]

    def do_impact(self, t: float, landing: str, pat: Pattern, q: np.ndarray, w: np.ndarray):
        st = self.st
        if landing == "ground":
            q[1] = 0.0
            if pat.interface.flat:
                q[3] = 0.0
        else:
            q[3] = q[1]
        ke_minus = kinetic_energy(st, q, w, *_pivots(pat))
        imp = impact(st, landing, pat, q, w)
        self.log("impact", t, landing, imp.pattern)
        if imp.held:
            self.log("held", t, "interface" if landing == "ground" else "ground", imp.pattern)
        imp = self.settle(t, landing, imp, q)
        ke_plus = kinetic_energy(st, q, imp.w, *_pivots(imp.pattern))
        self.acc[3] += ke_minus - ke_plus
        return q, imp.w.copy(), imp.pattern

    def settle(self, t: float, landing: str, imp: ImpactSolution, q) -> ImpactSolution:
        """Close contacts whose rebound is negligible (docs/two_blocks.md, "Settling and locking")."""
        st, pat, w = self.st, imp.pattern, imp.w
        _, av = self.ground(t)
        qualifies = []
        for c, m in (("ground", pat.ground), ("interface", pat.interface)):
            gap, rate, _ = _gap(q, w, c)
            if not m.flat and gap == 0.0 and abs(rate) < settle_rate(st, c, av):
                qualifies.append(c)
        order = [tuple(qualifies)] if len(qualifies) == 2 else []
        order += [(c,) for c in ((landing, "interface" if landing == "ground" else "ground")) if c in qualifies]
        for closing in order:
            cl = close_contacts(st, pat, q, w, closing)
            if kinetic_energy(st, q, cl.w, *_pivots(cl.pattern)) > kinetic_energy(st, q, w, *_pivots(pat)):
                continue  # a friction impulse would push the slip the other way: no settling
            chosen = self.choose(t, q, cl.w)
            if chosen is None:
                continue
            if all((chosen.ground if c == "ground" else chosen.interface).flat for c in closing):
                self.log("settle", t, "+".join(closing), chosen)
                return cl
        return imp

    def fell_off_edge(self, q, end: str) -> bool:
        """Whether the interface opens about block 1's edge with block 2 overhanging it (so that block 2
        would turn about block 1's edge, not about its own corner)."""
        st = self.st
        return (end == "right" and q[2] + st.b2 > st.b1) or (end == "left" and q[2] - st.b2 < -st.b1)

    def run(self, q0, w0, t0: float = 0.0) -> None:
        st = self.st
        t, q, w = t0, np.array(q0, float), np.array(w0, float)
        pat = self.choose(t, q, w)
        if pat is None:
            raise StackReferenceError("no consistent pattern at the start")
        self.record(np.array([t]), np.concatenate([q, w]), self.acc.copy(), pat)
        same, t_last = 0, -math.inf
        while t < self.t_end:
            same = same + 1 if t == t_last else 0
            t_last = t
            if same > self.max_same:
                raise StackReferenceError(f"no progress at t = {t}")
            if _is_rest(pat):
                tl = self.leave_rest(pat, q, t)
                if tl is None:
                    self.record(np.array([self.t_end]), np.concatenate([q, w]), self.acc.copy(), pat)
                    return
                t = tl
                new = self.choose(t, q, w, allow_rest=False)
                if new is None:
                    self.no_pattern(t, q, w, {}, "")
                    return
                pat = new
                self.log("start", t, "", pat)
                self.record(np.array([t]), np.concatenate([q, w]), self.acc.copy(), pat)
                continue
            t, q, w, hit = self.integrate(pat, t, q, w)
            if hit is None:  # a break or the end: the motion's expression changes, choose again
                if t < self.t_end:
                    pat = self._rechoose(t, q, w, pat)
                    if pat is None:
                        return
                continue
            kind, contact = hit
            if kind in ("overturn", "flight", "fell-off"):
                self.log(kind, t, contact)
                self._outcome(kind, contact, t)
                return
            exclude: dict[str, set[str]] = {}
            if kind == "impact":
                try:
                    q, w, pat = self.do_impact(t, contact, pat, q, w)
                except StackReferenceError:
                    self.log("inconsistent", t, contact)
                    self._outcome("flight", contact, t)
                    return
                self.record(np.array([t]), np.concatenate([q, w]), self.acc.copy(), pat)
            elif kind == "open":
                ah, av = self.ground(t)
                sol = solve_pattern(st, pat, q, w, ah, av)
                ind = contact_indicators(st, pat, q, sol)
                prefix = contact[0]
                end = "right" if ind[prefix + "_right"] < ind[prefix + "_left"] else "left"
                if contact == "interface" and self.fell_off_edge(q, end):
                    self.log("fell-off", t, contact)
                    self._outcome("fell-off", contact, t)
                    return
                exclude[contact] = {"flat"}
                self.log("open", t, contact)
            elif kind == "slip":
                exclude[contact] = {"stick"}
                self.log("slip", t, contact)
            elif kind == "stick":
                w[0 if contact == "ground" else 2] = 0.0
                self.log("stick", t, contact)
            new = self.choose(t, q, w, exclude)
            if new is None:
                self.no_pattern(t, q, w, exclude, contact)
                return
            if kind == "stick":
                m = new.ground if contact == "ground" else new.interface
                if m.slides:
                    self.events[-1].kind = "reverse"
            self.events[-1].pattern = new.label()
            if kind in ("impact", "settle"):
                self.log_openings(t, pat, new)
            pat = new

    def log_openings(self, t: float, before: Pattern, after: Pattern) -> None:
        """Log contacts that the pattern chosen after an impact opens (flat before, rocking after)."""
        for c, a, b in (("ground", before.ground, after.ground), ("interface", before.interface, after.interface)):
            if a.flat and not b.flat:
                self.log("open", t, c, after)

    def _rechoose(self, t: float, q, w, pat: Pattern) -> Pattern | None:
        ah, av = self.ground(t)
        sol = solve_pattern(self.st, pat, q, w, ah, av)
        if consistent(self.st, pat, q, w, sol):
            return pat
        new = self.choose(t, q, w)
        if new is None:
            self.no_pattern(t, q, w, {}, "")
        return new

    def no_pattern(self, t: float, q, w, exclude, contact: str) -> None:
        """No consistent pattern: block 2 falls off if turning about its corner beyond block 1's edge
        would be consistent, otherwise a contact would have to pull (flight)."""
        ah, av = self.ground(t)
        found = select_pattern(self.st, q, w, ah, av, exclude, allow_overhang=True)
        if found is not None and not found[0].interface.flat:
            self.log("fell-off", t, "interface")
            self._outcome("fell-off", "interface", t)
            return
        self.log("flight", t, contact)
        self._outcome("flight", contact, t)

    def _outcome(self, kind: str, contact: str, t: float) -> None:
        self.outcome[f"{kind}:{contact}"] = t


def simulate(stack: SlidingStack, t_end: float, ground: Ground = no_ground, breaks: tuple[float, ...] = (),
             q0=(0.0, 0.0, 0.0, 0.0), w0=(0.0, 0.0, 0.0, 0.0), rtol: float = 1e-12, atol: float = 1e-12) -> StackRun:
    """Simulate the stack from state ``q0 = (u1, theta1, u2, theta2)``, ``w0`` (their rates) to
    ``t_end`` (s) under ``ground(t) -> (a_h, a_v)`` (m/s^2), whose non-smooth points are ``breaks``."""
    start = _time.perf_counter()
    sv = _Solver(stack, ground, breaks, t_end, rtol, atol)
    sv.run(q0, w0)
    o = sv.outcome
    return StackRun(
        stack=stack,
        t=np.concatenate(sv.ts), y=np.hstack(sv.ys), s=np.hstack(sv.ss), acc=np.hstack(sv.accs),
        events=sv.events,
        overturn_time=(o.get("overturn:ground"), o.get("overturn:interface")),
        fell_off_time=o.get("fell-off:interface"),
        flight_time=o.get("flight:ground", o.get("flight:interface")),
        peak_abs_slip=(sv.peak_slip[0], sv.peak_slip[1]),
        peak_abs_theta=(sv.peak_theta[0], sv.peak_theta[1]),
        wall_time=_time.perf_counter() - start,
    )
