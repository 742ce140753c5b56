"""Independent reference: one rigid block that rests, slides, rocks, slide-rocks and FLIES.

Written from Newton-Euler and the complementarity conditions of unilateral contact with Coulomb
friction (Pfeiffer & Glocker 1996; Shenton & Jones 1991; Shenton 1996), without reading the C
engine or the other Python sliding references, so that the C contact engine can be tested against
it. SI units; the signs of docs/conventions.md: ``x`` right, ``y`` up, ``theta > 0`` clockwise
(the block on its right corner), ``a_h > 0`` accelerates the ground towards ``+x``, ``a_v > 0``
upwards, ``G = g + a_v``.

Model
-----
A rectangle of half width ``b``, half height ``h``, mass ``m``, centroidal inertia
``Ic = m (b^2 + h^2) / 3``, on a rigid ground moving with ``a_h(t)``, ``a_v(t)``. Everything is
written in the ground's (non-inertial) frame, where the block feels ``-m a_h`` horizontally and
``-m G`` vertically. Generalised coordinates ``q = (X, Y, theta)``: the centre of mass relative to
the ground (at rest ``X = 0``, ``Y = h``) and the clockwise rotation. A bottom corner ``s``
(``+1`` right, ``-1`` left) sits at ``(X, Y) + rot(theta) (s b, -h)`` with
``rot(theta) (x, y) = (x cos + y sin, -x sin + y cos)``; write ``(rx, ry)`` for that offset.
Its velocity is ``(VX + ry w, VY - rx w)`` and its acceleration
``(X'' + ry w' - rx w^2, Y'' - rx w' - ry w^2)`` (``w = theta'``).

Equations of motion: ``M q'' = F + sum_c Wn_c N_c + Wt T`` with ``M = diag(m, m, Ic)``,
``F = (-m a_h, -m G, 0)``, ``Wn_c = (0, 1, -rx_c)`` (normal force ``N_c`` at corner ``c``) and
``Wt = (1, 0, ry)`` (the tangential force ``T`` at the contact; with both corners down,
``theta = 0``, both corners share ``Wt = (1, 0, -h)`` and ``T`` is the total friction force, which is
all that acts on the rigid block).

Modes (:class:`Mode`; the FMU's block1.mode values, ``FLIGHT = 6``):

===========  =============================  =========================================
mode         active contact                 friction
===========  =============================  =========================================
REST         both corners (flat)            stick: base acceleration 0, ``|T| <= mu (N_R + N_L)``
SLIDE        both corners (flat)            ``T = -sigma mu (N_R + N_L)``, ``sigma`` = sign of slip rate
ROCK         one corner                     stick: corner acceleration 0, ``|T| <= mu N``
SLIDE_ROCK   one corner                     ``T = -sigma mu N``
FLIGHT       none                           none: ``X'' = -a_h``, ``Y'' = -G``, ``theta'' = 0``
OVERTURNED   ``|theta|`` reached ``pi/2``   the run stops there
===========  =============================  =========================================

Each active corner has zero normal acceleration; a sticking contact zero tangential acceleration.
The linear system of the mode gives ``q''``, the ``N_c`` and ``T``.

Choosing the mode (at the start, at every event, after every impact, at every break of the ground
motion): every candidate active set (a subset of the corners that touch the ground with zero
normal velocity) with every friction state (stick; slide ``+1``/``-1`` if the contact's tangential
velocity is zero, else slide with its sign) is solved, and a candidate is consistent when the
complementarity conditions hold at acceleration level: ``N_c >= 0`` for its active corners, the
normal acceleration ``>= 0`` for the touching corners it leaves inactive, ``|T| <= mu N`` if it
sticks, and a slip that starts from rest accelerates the way ``sigma`` says
(``sigma * a_t >= 0``). Flight is the candidate with no active corner: taken when it is the
consistent one (``G < 0``, or a corner that would have to pull). When an event of the current mode
triggered the choice (a normal force, friction margin or slip rate reaching zero), the current mode
is excluded. At an event several candidates are consistent to rounding (their inequalities are
zero there); they are told apart by looking ahead ``delta = 1e-7 sqrt(R / g)`` along each
candidate's own motion (one RK4 step) and taking the candidate whose smallest inequality is largest
there.

Events (all located as sign changes of indicators with scipy's ``solve_ivp``, DOP853,
``rtol = 1e-12``, ``atol = 1e-14``, then refined to full precision by Brent's method on
re-integrations from the last accepted step, so that event states are exact to ~1e-12):
normal forces reaching zero (contact opens), ``mu N - |T|`` reaching zero (slip starts) -- these two
trigger at ``-1e-14 m g`` so that a constant load held exactly at a limit is no event --, the slip
rate reaching zero (stick or reversal), ``theta`` returning to zero on a corner (impact), a corner's
height reaching zero in flight (landing), ``|theta| = pi/2`` (overturn).

Impacts: plastic, with Coulomb friction on the impulses. The touching corners (height zero) either
take a normal impulse ``P_N >= 0`` and leave with zero normal velocity, or take none and leave with
normal velocity ``>= 0`` (complementarity at impulse level); the tangential impulse sticks
(``|P_T| <= mu P_N``, tangential velocity zero after) or else slides, ``P_T = -sigma mu P_N`` with
``sigma`` the sign of the tangential velocity after. The impulses act at the corners, so the
angular momentum about the landing corner is conserved. For a block landing from rocking at
``theta = 0`` on corner ``s' = -s`` this is exactly the project's one-block rule of the rocking-
sliding model with Housner's (1963) ``eta = 1 - 3/2 sin^2(alpha)``:
``I0 w+ + m h v+ = eta I0 w- + m h v-`` (``v`` the slip rate of the pivot before and of the landing
corner after, ``I0 = 4/3 m R^2``), for sticking and for sliding impacts alike, and a flat landing
when the old pivot would have to be pulled down. Only Housner's law is implemented (no other
restitution coefficient). Landings from flight use the same plain plastic impulse-momentum law:
a flat landing (both corners at once, ``theta = w = 0``) takes ``P_N = m |VY-|`` and friction takes
what it can of the horizontal velocity: slip rate after ``VX- - sign(VX-) min(|VX-|, mu |VY-|)``.

Rest criterion (for the endless sequence of shrinking rocking impacts): after a rocking impact whose
rebound would peak (energy estimate ``theta_p = I0 w+^2 / (2 m G b)``) below ``rest_ratio * alpha``
the block is laid flat by a second plastic impulse on both corners (rotation and vertical velocity
zeroed, friction on the horizontal part as above; signs of its tiny normal impulses not required).

Energy: ``E = 1/2 m |V|^2 + 1/2 Ic w^2 + m g (Y - h)`` (``V`` relative to the ground), the ground
work ``W = integral -m (a_h X' + a_v Y') dt`` and the friction loss ``integral mu N |slip rate| dt``
ride along as integrated states; the impact loss sums the kinetic energy lost at impacts (and by the
rest criterion), so that ``E + friction loss + impact loss = E(t0) + W``.

Outputs (:class:`Run`): ``slip`` follows docs/conventions.md: the base centre's ``x`` relative to
the ground whenever the base is flat (rest, slide) and in flight (``X - h sin(theta)``); while on a
corner, the ``x`` of the pivot corner minus its rest offset ``s b`` (constant while it sticks).
``x_base`` is the base centre's ``x`` always, ``X`` the centre of mass's. ``gap`` is the height of
the lowest corner (0 in every contact mode). Samples at an event's time give the state after it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from model.sliding_closed_form import Mode  # the project's contact modes (values of the FMU's block1.mode)

G_DEFAULT = 9.81  # m/s^2
RTOL = 1e-12
ATOL = 1e-14
EPS = float(np.finfo(float).eps)
SIDES = (1, -1)  # right, left corner
FORCE_SLACK = 1e-14  # force indicators (over m g) trigger below -1e-14: a load held exactly at a limit is no event

Ground = Callable[[float], tuple[float, float]]



# ----------------------------------------------------------------------------- ground motions


@dataclass(frozen=True)
class SinePulse:
    """``a_h = ah0 + A s(t)``, ``a_v = av0 + V s(t)`` (m/s^2), ``s = sin(2 pi f (t - t0))`` on
    ``[t0, t0 + cycles / f)`` and 0 outside it: the FMU's excitation.kind = 1 with
    excitation.verticalAmplitude = V, plus constant accelerations."""

    amplitude: float  # A, m/s^2
    frequency: float  # f, Hz
    cycles: float = 1.0
    t0: float = 0.0  # s
    vertical: float = 0.0  # V, m/s^2
    ah0: float = 0.0  # m/s^2
    av0: float = 0.0  # m/s^2

    @property
    def t_end(self) -> float:
        """End of the pulse's window (s)."""
        return self.t0 + self.cycles / self.frequency

    def __call__(self, t: float) -> tuple[float, float]:
        """``(a_h, a_v)`` at ``t`` (m/s^2)."""
        w = math.sin(2.0 * math.pi * self.frequency * (t - self.t0)) if self.t0 <= t < self.t_end else 0.0
        return self.ah0 + self.amplitude * w, self.av0 + self.vertical * w

    @property
    def breaks(self) -> tuple[float, ...]:
        """Times (s) where the motion's expression changes."""
        return (self.t0, self.t_end)


def constant_ground(ah: float, av: float = 0.0) -> SinePulse:
    """Constant accelerations ``a_h``, ``a_v`` (m/s^2) for all times."""
    return SinePulse(0.0, 1.0, 0.0, 0.0, 0.0, ah, av)


# ----------------------------------------------------------------------------- block and modes


@dataclass(frozen=True)
class Block:
    """Half width ``b`` (m), half height ``h`` (m), mass ``m`` (kg), friction ``mu``, gravity ``g``."""

    b: float
    h: float
    mu: float
    m: float = 1.0
    g: float = G_DEFAULT

    @property
    def R(self) -> float:
        """Half diagonal (m)."""
        return math.hypot(self.b, self.h)

    @property
    def alpha(self) -> float:
        """Slenderness angle atan(b / h) (rad)."""
        return math.atan2(self.b, self.h)

    @property
    def Ic(self) -> float:
        """Centroidal moment of inertia m (b^2 + h^2) / 3 (kg m^2)."""
        return self.m * (self.b ** 2 + self.h ** 2) / 3.0

    @property
    def I0(self) -> float:
        """Moment of inertia about a bottom corner 4/3 m R^2 (kg m^2)."""
        return 4.0 * self.m * (self.b ** 2 + self.h ** 2) / 3.0

    @property
    def eta_housner(self) -> float:
        """Housner's (1963) coefficient 1 - 3/2 sin^2(alpha)."""
        return 1.0 - 1.5 * math.sin(self.alpha) ** 2


@dataclass(frozen=True)
class Contact:
    """Active corners (``()`` flight, ``(1,)`` right, ``(-1,)`` left, ``(1, -1)`` flat) and the
    friction state: ``sigma = 0`` sticks, ``+-1`` slides with that sign of the slip rate."""

    corners: tuple[int, ...]
    sigma: int = 0

    @property
    def mode(self) -> Mode:
        """The :class:`Mode` of this contact."""
        if not self.corners:
            return Mode.FLIGHT
        if len(self.corners) == 2:
            return Mode.REST if self.sigma == 0 else Mode.SLIDE
        return Mode.ROCK if self.sigma == 0 else Mode.SLIDE_ROCK

    @property
    def flat(self) -> bool:
        return len(self.corners) == 2


FLIGHT = Contact(())


def offset(theta: float, s: int, b: float, h: float) -> tuple[float, float]:
    """``(rx, ry)`` = rot(theta) (s b, -h): corner ``s`` relative to the centre (m)."""
    c, sn = math.cos(theta), math.sin(theta)
    return s * b * c - h * sn, -s * b * sn - h * c


@dataclass
class Dynamics:
    """Accelerations and contact forces of one contact at one instant."""

    qdd: np.ndarray  # (X'', Y'', theta'') m/s^2, rad/s^2
    normal: tuple[float, ...]  # N per active corner, N
    T: float  # tangential force, N (+x)
    at: float  # tangential acceleration of the contact point, m/s^2
    vt: float  # tangential velocity of the contact point (slip rate), m/s
    ah: float
    av: float


@dataclass
class Event:
    """One event: time (s), kind, mode after it, and details (velocities, impulses)."""

    t: float
    kind: str
    mode: Mode
    detail: dict = field(default_factory=dict)


@dataclass
class Run:
    """Samples at ``t`` and the run's events. Lengths in m, angles in rad, energies in J."""

    block: Block
    t: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    theta: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    omega: np.ndarray
    slip: np.ndarray
    slip_rate: np.ndarray
    x_base: np.ndarray
    gap: np.ndarray
    mode: np.ndarray
    energy: np.ndarray
    ground_work: np.ndarray
    friction_loss: np.ndarray
    impact_loss: np.ndarray
    events: list[Event]
    flight_time: float
    max_gap: float
    t_final: float
    state_final: np.ndarray  # (X, Y, theta, VX, VY, w) at t_final
    mode_final: Mode

    @property
    def energy_residual(self) -> np.ndarray:
        """``E + friction loss + impact loss - E(t0) - W`` at the samples (J)."""
        return self.energy + self.friction_loss + self.impact_loss - self.energy[0] - self.ground_work

    def times(self, kind: str) -> list[float]:
        """Times (s) of the events of one kind."""
        return [e.t for e in self.events if e.kind == kind]

    def first(self, kind: str) -> Event | None:
        """The first event of one kind, or None."""
        return next((e for e in self.events if e.kind == kind), None)


# ----------------------------------------------------------------------------- the solver


class FlightSolver:
    """Event-driven solver of one block (see the module's docstring); use :func:`simulate`."""

    def __init__(self, block: Block, ground: Ground, rest_ratio: float = 1e-12, max_step: float = 1e-2) -> None:
        self.p = block
        self.ground = ground
        self.rest_ratio = rest_ratio
        self.max_step = max_step
        size = block.b + block.h
        self.ptol = 1e-10 * size  # a corner this close to the ground touches it (m)
        self.vtol = 1e-10 * math.sqrt(block.g * size)  # a velocity this small is zero (m/s)
        self.ftol = 1e-9  # slack tolerance on forces / (m g) and accelerations / g
        self.delta = 1e-7 * math.sqrt(block.R / block.g)  # look-ahead (s)
        self._cache: tuple | None = None

    # ------------------------------------------------------------------ mechanics

    def dynamics(self, t: float, y: np.ndarray, c: Contact) -> Dynamics:
        """Solve the equations of motion of contact ``c`` at ``(t, y)``."""
        key = (t, c, y[0], y[1], y[2], y[3], y[4], y[5])
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        p = self.p
        ah, av = self.ground(t)
        G = p.g + av
        th, vx, w = y[2], y[3], y[5]
        F = np.array([-p.m * ah, -p.m * G, 0.0])
        if not c.corners:
            qdd = F / np.array([p.m, p.m, p.Ic])
            d = Dynamics(qdd, (), 0.0, 0.0, 0.0, ah, av)
        else:
            k, stick = len(c.corners), c.sigma == 0
            n = 3 + k + int(stick)
            A = np.zeros((n, n))
            r = np.zeros(n)
            A[0, 0], A[1, 1], A[2, 2] = p.m, p.m, p.Ic
            r[:3] = F
            rx0, ry0 = offset(th, c.corners[0], p.b, p.h)
            Wt = np.array([1.0, 0.0, ry0])
            for i, s in enumerate(c.corners):
                rx, ry = offset(th, s, p.b, p.h)
                Wn = np.array([0.0, 1.0, -rx])
                A[:3, 3 + i] = -Wn if stick else -Wn + c.sigma * p.mu * Wt
                A[3 + i, :3] = Wn
                r[3 + i] = ry * w * w
            if stick:
                A[:3, 3 + k] = -Wt
                A[3 + k, :3] = Wt
                r[3 + k] = rx0 * w * w
            z = np.linalg.solve(A, r)
            qdd = z[:3]
            normal = tuple(float(x) for x in z[3:3 + k])
            T = float(z[3 + k]) if stick else -c.sigma * p.mu * sum(normal)
            at = float(Wt @ qdd - rx0 * w * w)
            vt = vx + ry0 * w
            d = Dynamics(qdd, normal, T, at, vt, ah, av)
        self._cache = (key, d)
        return d

    def rhs(self, c: Contact) -> Callable[[float, np.ndarray], np.ndarray]:
        """The ODE of contact ``c`` on the state (X, Y, theta, VX, VY, w, ground work, friction loss)."""
        p = self.p

        def f(t: float, y: np.ndarray) -> np.ndarray:
            d = self.dynamics(t, y, c)
            out = np.empty(8)
            out[0:3] = y[3:6]
            out[3:6] = d.qdd
            if c.flat:  # base flat: exactly no rotation and no vertical motion
                out[1] = out[2] = out[4] = out[5] = 0.0
                if c.sigma == 0:
                    out[0] = out[3] = 0.0
            out[6] = -p.m * (d.ah * y[3] + d.av * y[4])
            out[7] = p.mu * sum(d.normal) * abs(d.vt) if (c.corners and c.sigma != 0) else 0.0
            return out

        return f

    def corner_gap(self, y: np.ndarray, s: int) -> float:
        """Height (m) of corner ``s`` above the ground."""
        return y[1] + offset(y[2], s, self.p.b, self.p.h)[1]

    def corner_velocity(self, y: np.ndarray, s: int) -> tuple[float, float]:
        """(tangential, normal) velocity (m/s) of corner ``s``."""
        rx, ry = offset(y[2], s, self.p.b, self.p.h)
        return y[3] + ry * y[5], y[4] - rx * y[5]

    def energy(self, y: np.ndarray) -> float:
        """Kinetic energy relative to the ground plus m g (Y - h) (J)."""
        p = self.p
        return 0.5 * p.m * (y[3] ** 2 + y[4] ** 2) + 0.5 * p.Ic * y[5] ** 2 + p.m * p.g * (y[1] - p.h)

    def kinetic(self, y: np.ndarray) -> float:
        """Kinetic energy relative to the ground (J)."""
        p = self.p
        return 0.5 * p.m * (y[3] ** 2 + y[4] ** 2) + 0.5 * p.Ic * y[5] ** 2

    # ------------------------------------------------------------------ indicators

    def indicators(self, c: Contact) -> list[tuple[str, Callable[[float, np.ndarray], float]]]:
        """Event indicators of contact ``c``: (name, g(t, y)); an event is g falling through 0."""
        p = self.p
        scale = p.m * p.g
        out: list[tuple[str, Callable[[float, np.ndarray], float]]] = []
        if not c.corners:
            for s in SIDES:
                out.append((f"landing{s:+d}", lambda t, y, s=s: self.corner_gap(y, s)))
            out.append(("overturn", lambda t, y: 0.5 * math.pi - abs(y[2])))
            return out
        for i, _ in enumerate(c.corners):
            out.append((f"open{i}", lambda t, y, i=i: self.dynamics(t, y, c).normal[i] / scale + FORCE_SLACK))
        if c.sigma == 0:
            def margin(t: float, y: np.ndarray) -> float:
                d = self.dynamics(t, y, c)
                return (p.mu * sum(d.normal) - abs(d.T)) / scale + FORCE_SLACK
            out.append(("friction", margin))
        else:
            out.append(("slip-rate", lambda t, y: c.sigma * self.dynamics(t, y, c).vt))
        if not c.flat:
            s = c.corners[0]
            out.append(("impact", lambda t, y: s * y[2]))
            out.append(("overturn", lambda t, y: 0.5 * math.pi - abs(y[2])))
        return out

    # ------------------------------------------------------------------ choosing the mode

    def touching(self, y: np.ndarray) -> tuple[int, ...]:
        """Corners on the ground with zero normal velocity."""
        return tuple(s for s in SIDES
                     if abs(self.corner_gap(y, s)) <= self.ptol and abs(self.corner_velocity(y, s)[1]) <= self.vtol)

    def candidates(self, y: np.ndarray, touch: tuple[int, ...]) -> list[Contact]:
        """Every active set within ``touch`` with every admissible friction state."""
        out: list[Contact] = []
        for k in range(len(touch), 0, -1):
            for S in combinations(touch, k):
                vt = self.corner_velocity(y, S[0])[0]
                sig = [0, 1, -1] if abs(vt) <= self.vtol else [int(np.sign(vt))]
                out.extend(Contact(tuple(S), s) for s in sig)
        out.append(FLIGHT)
        return out

    def slacks(self, t: float, y: np.ndarray, c: Contact, touch: tuple[int, ...], starting: bool) -> float:
        """Smallest normalised inequality of contact ``c`` (>= 0: consistent)."""
        p = self.p
        d = self.dynamics(t, y, c)
        vals = [n / (p.m * p.g) for n in d.normal]
        if c.corners and c.sigma == 0:
            vals.append((p.mu * sum(d.normal) - abs(d.T)) / (p.m * p.g))
        elif c.corners and starting:
            vals.append(c.sigma * d.at / p.g)
        w = y[5]
        for s in touch:
            if s not in c.corners:
                rx, ry = offset(y[2], s, p.b, p.h)
                vals.append((d.qdd[1] - rx * d.qdd[2] - ry * w * w) / p.g)
        return min(vals) if vals else math.inf

    def lookahead(self, t: float, y: np.ndarray, c: Contact) -> np.ndarray:
        """The state one RK4 step of ``delta`` later along contact ``c``'s motion."""
        f, dt = self.rhs(c), self.delta
        k1 = f(t, y)
        k2 = f(t + dt / 2, y + dt / 2 * k1)
        k3 = f(t + dt / 2, y + dt / 2 * k2)
        k4 = f(t + dt, y + dt * k3)
        return y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def select(self, t: float, y: np.ndarray, exclude: Contact | None = None) -> Contact:
        """The consistent contact at ``(t, y)`` (see the module's docstring)."""
        touch = self.touching(y)
        cands = [c for c in self.candidates(y, touch) if c != exclude]
        starting = {c: bool(c.corners) and abs(self.corner_velocity(y, c.corners[0])[0]) <= self.vtol for c in cands}
        ok = [c for c in cands if self.slacks(t, y, c, touch, starting[c]) >= -self.ftol]
        if len(ok) == 1:
            return ok[0]
        pool = ok or cands
        scores = [self.slacks(t + self.delta, self.lookahead(t, y, c), c, touch, starting[c]) for c in pool]
        top = max(scores)
        # ties (a load exactly at a limit, constant in time) go to the first: more contact, sticking
        return next(c for c, x in zip(pool, scores) if x >= top - 1e-10)

    def project(self, y: np.ndarray, c: Contact) -> np.ndarray:
        """Enforce contact ``c``'s position and velocity constraints exactly."""
        y = y.copy()
        p = self.p
        if c.flat:
            y[1], y[2], y[4], y[5] = p.h, 0.0, 0.0, 0.0
            if c.sigma == 0:
                y[3] = 0.0
        elif c.corners:
            s = c.corners[0]
            rx, ry = offset(y[2], s, p.b, p.h)
            y[1] = -ry
            y[4] = rx * y[5]
            if c.sigma == 0:
                y[3] = -ry * y[5]
        return y

    # ------------------------------------------------------------------ impacts

    def impulse(self, y: np.ndarray, S: tuple[int, ...], sigma: int | None
                ) -> tuple[np.ndarray, tuple[float, ...], float]:
        """Velocities after plastic impulses at corners ``S`` (normal velocity zeroed), sticking
        (``sigma = None``: tangential velocity zeroed) or sliding (``P_T = -sigma mu sum P_N``).
        Returns (new state, normal impulses, tangential impulse) in N s."""
        p = self.p
        th, v = y[2], y[3:6]
        k, stick = len(S), sigma is None
        n = 3 + k + int(stick)
        A = np.zeros((n, n))
        r = np.zeros(n)
        A[0, 0], A[1, 1], A[2, 2] = p.m, p.m, p.Ic
        Wt = np.array([1.0, 0.0, offset(th, S[0], p.b, p.h)[1]])
        for i, s in enumerate(S):
            Wn = np.array([0.0, 1.0, -offset(th, s, p.b, p.h)[0]])
            A[:3, 3 + i] = -Wn if stick else -Wn + sigma * p.mu * Wt
            A[3 + i, :3] = Wn
            r[3 + i] = -Wn @ v
        if stick:
            A[:3, 3 + k] = -Wt
            A[3 + k, :3] = Wt
            r[3 + k] = -Wt @ v
        z = np.linalg.solve(A, r)
        out = y.copy()
        out[3:6] = v + z[:3]
        Pn = tuple(float(x) for x in z[3:3 + k])
        Pt = float(z[3 + k]) if stick else -sigma * p.mu * sum(Pn)
        return out, Pn, Pt

    def impact(self, y: np.ndarray) -> tuple[np.ndarray, dict]:
        """Resolve a plastic impact with friction at the corners on the ground."""
        p = self.p
        contacts = tuple(s for s in SIDES if abs(self.corner_gap(y, s)) <= self.ptol)
        vscale = max([abs(self.corner_velocity(y, s)[1]) for s in contacts] + [self.vtol])
        P = p.m * vscale
        best: tuple | None = None
        for k in range(len(contacts), 0, -1):
            for S in combinations(contacts, k):
                for sigma in (None, 1, -1):
                    yp, Pn, Pt = self.impulse(y, S, sigma)
                    vals = [x / P for x in Pn]
                    vt = self.corner_velocity(yp, S[0])[0]
                    vals.append((p.mu * sum(Pn) - abs(Pt)) / P if sigma is None else sigma * vt / vscale)
                    vals += [self.corner_velocity(yp, s)[1] / vscale for s in contacts if s not in S]
                    score = min(vals)
                    if score >= -1e-9:
                        return yp, {"corners": S, "sigma": sigma or 0, "Pn": Pn, "Pt": Pt}
                    if best is None or score > best[0]:
                        best = (score, yp, {"corners": S, "sigma": sigma or 0, "Pn": Pn, "Pt": Pt})
        if all(self.corner_velocity(y, s)[1] >= -self.vtol for s in contacts):
            return y.copy(), {"corners": (), "sigma": 0, "Pn": (), "Pt": 0.0}
        assert best is not None
        return best[1], best[2]

    def lay_flat(self, y: np.ndarray) -> tuple[np.ndarray, dict]:
        """The rest criterion's flat impulse on both corners (rotation and vertical velocity
        zeroed; friction sticks if it can, else slides)."""
        y = y.copy()
        y[1], y[2] = self.p.h, 0.0
        yp, Pn, Pt = self.impulse(y, (1, -1), None)
        if abs(Pt) > self.p.mu * abs(sum(Pn)):
            vt = self.corner_velocity(y, 1)[0]
            sigma = int(np.sign(vt)) or 1
            yp, Pn, Pt = self.impulse(y, (1, -1), sigma)
        return yp, {"corners": (1, -1), "Pn": Pn, "Pt": Pt, "rest": True}


def rocking_state(block: Block, theta: float, omega: float, slip: float = 0.0, slip_rate: float = 0.0
                  ) -> np.ndarray:
    """State (X, Y, theta, VX, VY, w) of a block on corner ``sign(theta)`` (``theta != 0``, rad),
    rotating at ``omega`` (rad/s, clockwise), its pivot at ``slip + s b`` (m) moving at ``slip_rate``."""
    s = 1 if theta > 0 else -1
    rx, ry = offset(theta, s, block.b, block.h)
    return np.array([slip + s * block.b - rx, -ry, theta, slip_rate - ry * omega, rx * omega, omega])


def _sample_grid(t0: float, t_end: float, t_out: Sequence[float] | None) -> np.ndarray:
    if t_out is None:
        return np.linspace(t0, t_end, 501)
    return np.asarray(t_out, dtype=float)


@dataclass
class _Segment:
    t_a: float
    t_b: float
    sol: object  # scipy OdeSolution or None (a single point)
    y_a: np.ndarray
    contact: Contact | None  # None: overturned
    impact_loss: float  # accumulated before this segment, J


def _event_kind(old: Contact, new: Contact, name: str) -> str:
    """A name for the transition old -> new caused by indicator ``name``."""
    if name == "overturn":
        return "overturn"
    if new == FLIGHT:
        return "lift-off"
    if old.corners == new.corners:
        if old.sigma == 0 and new.sigma != 0:
            return "slide"
        if old.sigma != 0 and new.sigma == 0:
            return "stick"
        if old.sigma == -new.sigma:
            return "reverse"
    if old.flat and not new.flat:
        return "uplift"
    if new.flat and not old.flat:
        return "flat"
    return "mode"


class _Driver:
    """The event loop of :func:`simulate`."""

    def __init__(self, solver: FlightSolver, breaks: Iterable[float], t0: float, t_end: float) -> None:
        self.s = solver
        self.t_end = t_end
        self.breaks = sorted(x for x in set(breaks) if t0 < x < t_end) + [t_end]
        self.segments: list[_Segment] = []
        self.events: list[Event] = []
        self.impact_loss = 0.0
        self.max_events = 100_000

    def _integrate_to(self, c: Contact, t_a: float, y_a: np.ndarray, t_b: float) -> np.ndarray:
        """State at ``t_b`` integrating contact ``c``'s motion from ``(t_a, y_a)``."""
        if t_b == t_a:
            return y_a.copy()
        sol = solve_ivp(self.s.rhs(c), (t_a, t_b), y_a, method="DOP853", rtol=RTOL, atol=ATOL,
                        max_step=self.s.max_step)
        return sol.y[:, -1]

    def _refine(self, c: Contact, g: Callable, t_node: float, y_node: np.ndarray, t_guess: float,
                t_limit: float) -> tuple[float, np.ndarray]:
        """Event time where ``g`` falls through zero, to full precision, and the state there."""
        phi = lambda t: g(t, self._integrate_to(c, t_node, y_node, t))
        if phi(t_node) <= 0.0:
            return t_node, y_node.copy()
        lo, hi = t_node, None
        d = 1e-13 * max(1.0, abs(t_guess))
        while hi is None:
            tb = min(t_guess + d, t_limit)
            if phi(tb) <= 0.0:
                hi = tb
            elif tb >= t_limit:  # no sign change found: take the integrator's time
                return t_guess, self._integrate_to(c, t_node, y_node, t_guess)
            else:
                lo = max(lo, tb)
                d *= 10.0
        ta = t_guess - 1e-13 * max(1.0, abs(t_guess))
        if lo < ta < hi and phi(ta) > 0.0:
            lo = ta
        if phi(hi) == 0.0:
            return hi, self._integrate_to(c, t_node, y_node, hi)
        te = brentq(phi, lo, hi, xtol=1e-300, rtol=4 * EPS, maxiter=200)
        step = EPS * max(abs(te), 1e-300)
        while phi(te) > 0.0 and te < hi:  # take the first time just after the crossing
            te = min(te + step, hi)
            step *= 2.0
        return te, self._integrate_to(c, t_node, y_node, te)

    def _enter(self, t: float, y: np.ndarray, exclude: Contact | None = None, rocking_impact: bool = False
               ) -> tuple[Contact, np.ndarray, dict]:
        """Impacts if a corner on the ground moves into it (``rocking_impact``: the block returned to
        ``theta = 0`` from a corner), then the consistent contact, projected."""
        s = self.s
        detail: dict = {}
        down = [q for q in SIDES if abs(s.corner_gap(y, q)) <= s.ptol and s.corner_velocity(y, q)[1] < -s.vtol]
        if down or rocking_impact:
            ke = s.kinetic(y)
            before = y.copy()
            if down:
                y, detail = s.impact(y)
            else:  # a rocking impact too slow to resolve: the rebound is negligible
                detail = {"corners": (), "sigma": 0, "Pn": (), "Pt": 0.0}
            detail.update(v_minus=tuple(before[3:6]), v_plus=tuple(y[3:6]))
            if down:
                y = self._rest_criterion(t, y, before, detail)
            else:
                y, detail["rest"] = s.lay_flat(y)
            loss = ke - s.kinetic(y)
            self.impact_loss += loss
            detail["loss"] = loss
            exclude = None
        c = s.select(t, y, exclude)
        return c, s.project(y, c), detail

    def _rest_criterion(self, t: float, y: np.ndarray, before: np.ndarray, detail: dict) -> np.ndarray:
        """Lay the block flat after a rocking impact whose rebound is negligible."""
        s, p = self.s, self.s.p
        if len(detail["corners"]) != 1 or abs(y[2]) > s.ptol / p.h:
            return y
        G = p.g + self.s.ground(t)[1]
        if G <= 0.0:
            return y
        peak = p.I0 * y[5] ** 2 / (2.0 * p.m * G * p.b)
        if peak >= s.rest_ratio * p.alpha:
            return y
        y, flat = s.lay_flat(y)
        detail["rest"] = flat
        return y

    def run(self, t0: float, y0: np.ndarray) -> None:
        """Integrate from ``(t0, y0)`` to ``t_end``."""
        y = np.concatenate([np.asarray(y0, dtype=float), [0.0, 0.0]])
        c, y, detail = self._enter(t0, y)
        self.events.append(Event(t0, "start", c.mode, detail))
        t = t0
        bi = 0
        while t < self.t_end:
            if len(self.events) > self.max_events:
                raise RuntimeError(f"more than {self.max_events} events by t = {t} s")
            while self.breaks[bi] <= t:
                bi += 1
            t_stop = self.breaks[bi]
            t, y, c = self._segment(c, t, y, t_stop)
            if c is None:
                return

    def _segment(self, c: Contact, t: float, y: np.ndarray, t_stop: float
                 ) -> tuple[float, np.ndarray, Contact | None]:
        """Integrate contact ``c`` until an event or ``t_stop``; handle what ends it."""
        s = self.s
        inds = s.indicators(c)
        evs = []
        for _, g in inds:
            e = (lambda t_, y_, g=g: g(t_, y_))
            e.terminal, e.direction = True, -1
            evs.append(e)
        sol = solve_ivp(s.rhs(c), (t, t_stop), y, method="DOP853", rtol=RTOL, atol=ATOL, events=evs,
                        dense_output=True, max_step=s.max_step)
        if sol.status == -1:
            raise RuntimeError(f"integration failed at t = {sol.t[-1]}: {sol.message}")
        hits = [(float(te[0]), i) for i, te in enumerate(sol.t_events) if len(te)]
        if not hits:
            self.segments.append(_Segment(t, t_stop, sol.sol, y, c, self.impact_loss))
            y_end = sol.y[:, -1]
            c2 = s.select(t_stop, y_end)
            if c2 != c:
                c2_, y2, detail = self._enter(t_stop, y_end)
                self.events.append(Event(t_stop, _event_kind(c, c2_, "break"), c2_.mode, detail))
                return t_stop, y2, c2_
            return t_stop, s.project(y_end, c), c
        t_guess, i = min(hits)
        name, g = inds[i]
        j = len(sol.t) - 2
        t_node, y_node = float(sol.t[j]), sol.y[:, j]
        te, ye = self._refine(c, g, t_node, y_node, t_guess, t_stop)
        self.segments.append(_Segment(t, te, sol.sol, y, c, self.impact_loss))
        if name == "overturn":
            self.events.append(Event(te, "overturn", Mode.OVERTURNED, {}))
            self.segments.append(_Segment(te, self.t_end, None, ye, None, self.impact_loss))
            return te, ye, None
        if name == "impact" or name.startswith("landing"):
            if name == "impact":
                ye = ye.copy()
                ye[2] = 0.0
                ye[1] = s.p.h
            c2, y2, detail = self._enter(te, ye, rocking_impact=name == "impact")
            kind = "landing" if c == FLIGHT else "impact"
            self.events.append(Event(te, kind, c2.mode, detail))
            return te, y2, c2
        c2, y2, detail = self._enter(te, ye, exclude=c)
        self.events.append(Event(te, _event_kind(c, c2, name), c2.mode, detail))
        return te, y2, c2

    # ------------------------------------------------------------------ output

    def state_at(self, t: float) -> tuple[np.ndarray, _Segment]:
        """Augmented state at ``t`` (after any event at ``t``) and its segment."""
        seg = self.segments[0]
        for sg in self.segments:
            if sg.t_a <= t:
                seg = sg
            else:
                break
        if seg.sol is None or t == seg.t_a:
            return seg.y_a.copy(), seg
        return np.asarray(seg.sol(min(t, seg.t_b)) if t <= seg.t_b else seg.sol(t)), seg

    def max_gap(self) -> float:
        """Largest height (m) of the lowest corner over the flight segments."""
        best = 0.0
        for sg in self.segments:
            if sg.contact != FLIGHT or sg.t_b <= sg.t_a:
                continue
            def low(t: float, sol: object = sg.sol) -> float:
                return min(self.s.corner_gap(sol(t), q) for q in SIDES)

            ts = np.linspace(sg.t_a, sg.t_b, 65)
            vals = [low(x) for x in ts]
            k = int(np.argmax(vals))
            a, b = ts[max(k - 1, 0)], ts[min(k + 1, len(ts) - 1)]
            res = minimize_scalar(lambda x, low=low: -low(x), bounds=(a, b), method="bounded", options={"xatol": 1e-13})
            best = max(best, vals[k], -float(res.fun))
        return best


def simulate(block: Block, ground: Ground, t_end: float, breaks: Iterable[float] = (), t0: float = 0.0,
             t_out: Sequence[float] | None = None, state0: Sequence[float] | None = None,
             rest_ratio: float = 1e-12, max_step: float = 1e-2) -> Run:
    """Run one block from ``t0`` to ``t_end`` (s) under ``ground(t) -> (a_h, a_v)`` (m/s^2).

    ``breaks``: times (s) where the ground motion is not smooth (the integrator stops there).
    ``state0``: (X, Y, theta, VX, VY, w) relative to the ground (m, rad, m/s, rad/s); default the
    block at rest, flat (0, h, 0, 0, 0, 0). ``t_out``: sample times (default 501 points).
    ``rest_ratio``: rebounds that would peak below ``rest_ratio * alpha`` lay the block flat.
    ``max_step``: largest integrator step (s), which bounds the indicators' sampling."""
    if not (block.b > 0 and block.h > 0 and block.m > 0 and block.mu >= 0 and block.g > 0):
        raise ValueError(f"bad block {block}")
    if not t_end > t0:
        raise ValueError(f"t_end = {t_end} must be after t0 = {t0}")
    y0 = np.array([0.0, block.h, 0.0, 0.0, 0.0, 0.0] if state0 is None else state0, dtype=float)
    solver = FlightSolver(block, ground, rest_ratio, max_step)
    if min(solver.corner_gap(y0, q) for q in SIDES) < -solver.ptol:
        raise ValueError("the block starts below the ground")
    if abs(y0[2]) >= 0.5 * math.pi:
        raise ValueError("the block starts overturned")
    drv = _Driver(solver, breaks, t0, t_end)
    drv.run(t0, y0)
    return _collect(drv, block, _sample_grid(t0, t_end, t_out))


def _collect(drv: _Driver, block: Block, ts: np.ndarray) -> Run:
    """Evaluate the samples and summaries of a finished run."""
    s = drv.s
    rows = []
    for t in ts:
        y, seg = drv.state_at(float(t))
        c = seg.contact
        mode = Mode.OVERTURNED if c is None else c.mode
        th = y[2]
        xb = y[0] - block.h * math.sin(th)
        if c is not None and c.corners and not c.flat:
            q = c.corners[0]
            slip = y[0] + offset(th, q, block.b, block.h)[0] - q * block.b
            rate = s.corner_velocity(y, q)[0]
        else:
            slip, rate = xb, y[3] - block.h * math.cos(th) * y[5]
        gap = min(s.corner_gap(y, q) for q in SIDES) if c == FLIGHT else 0.0
        loss = seg.impact_loss
        rows.append((*y[:6], slip, rate, xb, gap, int(mode), s.energy(y), y[6], y[7], loss))
    a = np.array(rows, dtype=float).reshape(len(ts), 15)
    last = drv.segments[-1]
    y_fin, _ = drv.state_at(last.t_b if last.sol is not None else last.t_a)
    flight = sum(sg.t_b - sg.t_a for sg in drv.segments if sg.contact == FLIGHT)
    return Run(block, ts, *[a[:, k] for k in range(6)], a[:, 6], a[:, 7], a[:, 8], a[:, 9],
               a[:, 10].astype(int), a[:, 11], a[:, 12], a[:, 13], a[:, 14], drv.events, flight,
               drv.max_gap(), last.t_b, y_fin[:6],
               Mode.OVERTURNED if last.contact is None else last.contact.mode)
