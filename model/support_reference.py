"""Independent monolithic reference: one rigid block that rocks and slides on a moving support.

Written from Newton-Euler and impulse-momentum balance, independently of the C core (model/c), to
check the FMU's supports: the block stands on floor j of a linear shear building, on an isolation
platform, or on the rigid ground, coupled one way (the support does not feel the block) or two ways
(the block's contact force acts back on the support). Support and block are integrated together in
ONE state vector (no co-simulation, no communication step), so the two-way coupling is exact.

Units SI, angles in radians; signs of docs/conventions.md: x right, y up, theta > 0 clockwise on the
bottom right corner (pivot side s = +1), theta < 0 on the bottom left corner (s = -1); a_g > 0
accelerates the base towards +x. No vertical motion (G = g). The block's model, modes and transition
rules are those of model/sliding_reference.py (read its docstring); this module adds the support.

Supports
--------
- Shear building (``Building``): floors i = 1..N of mass m_i, storey i of stiffness k_i between floor
  i-1 and floor i (floor 0 = the base); u = floor displacements relative to the base:
      M u'' + C u' + K u = -M 1 a_g(t) + e_j F(t),
  K tridiagonal (K_ii = k_i + k_{i+1}, K_{i,i+1} = -k_{i+1}, k_{N+1} = 0), Rayleigh C = a0 M + a1 K,
  a0 = 2 zeta w1 w2 / (w1 + w2), a1 = 2 zeta / (w1 + w2) (w1, w2 the two lowest circular frequencies
  of K phi = w^2 M phi with the structure's own masses); N = 1: a0 = 0, a1 = 2 zeta / w1.
- Isolation platform (``Platform``): M_p u'' + c u' + k u = -M_p a_g + F (one floor).
- Rigid ground (``RigidGround``): no support state, a_f = a_g.
The block stands on "floor j" (the platform for a platform); its absolute acceleration is
a_f = a_g + u_j''. F is the block's horizontal force on floor j: F = -T (T the floor's horizontal
force on the block) in two-way coupling, F = 0 in one-way coupling. The block's mass is NOT in M.

The block on a moving floor (frame of floor j: inertial force -m a_f at the centre)
-------------------------------------------------------------------------------------
With phi = theta - s alpha, R = sqrt(b^2 + h^2), Ic = m R^2 / 3, I0 = 4/3 m R^2, the slip ub (x of the
pivot corner relative to the floor minus s b) and its rate v, the centre relative to the floor moves
with X' = v + R cos(phi) w, Y' = -R sin(phi) w. Newton-Euler (T, N the floor's force on the block):
    m (X'' + a_f) = T,   m Y'' = N - m g,   Ic w' = R sin(phi) N - R cos(phi) T.
In every mode T is AFFINE in a_f, T = T0 + Ta a_f:
    rest:       T = m a_f                                (T0 = 0, Ta = m), N = m g
    slide:      T = -sigma mu m g                        (Ta = 0), ub'' = T/m - a_f
    rock:       w' = 3/(4R) (g sin(phi) - a_f cos(phi)),  ub'' = 0,
                T = m (a_f (1 - 3/4 cos^2 phi) + 3/4 g sin(phi) cos(phi) - R sin(phi) w^2),
                N = m (g - R sin(phi) w' - R cos(phi) w^2)
    slide-rock: q = sin(phi) + sigma mu cos(phi), w' = q (g - R cos(phi) w^2) / (R (1/3 + q sin(phi))),
                N = m (g - R sin(phi) w' - R cos(phi) w^2), T = -sigma mu N (Ta = 0),
                ub'' = T/m - a_f - R cos(phi) w' + R sin(phi) w^2.
Floor j's row then reads M_j u_j'' = r_j - T with r = -C u' - K u - M 1 a_g, i.e.
    u_j'' = (r_j - T0 - Ta a_g) / (M_j + Ta)     (two-way),     u_j'' = r_j / M_j   (one-way),
and u_i'' = r_i / M_i on every other floor (M diagonal). At rest the floor carries M_j + m: the block
moves with its floor as one body. Nothing else couples, so each right-hand side is closed-form.

Energy (two-way, frame of the base): E = 1/2 u'^T M u' + 1/2 u^T K u + 1/2 m ((u_j' + X')^2 + Y'^2)
+ 1/2 Ic w^2 + m g (Y - h), and dE/dt = -a_g (1^T M u' + m (u_j' + X')) - u'^T C u' + T v (the last
term, -mu N |v|, is friction; T u_j' cancels between block and floor). So
    residual = E(t) + damping loss + friction loss + impact loss - E(0) - base work
(base work = integral of -a_g P, P = 1^T M u' + m (u_j' + X') the horizontal momentum in the base's
frame) stays at zero. One-way: E = support energy + block energy relative to its floor, base work =
integral of (-a_g 1^T M u' - m a_f X'). The energy scale is the largest of |E|, |base work| and the
losses over the run.

Two-way impact law (derived here; plastic, with Coulomb friction)
------------------------------------------------------------------
At theta = 0 on pivot s the block lands on corner s' = -s. Floor j's velocity (relative to the base)
jumps from U- to U+; springs and dampers carry no impulse, so no other floor's velocity changes and
floor j takes minus the block's horizontal impulse. The vertical impulse goes into the vertically
rigid support. The old pivot leaves the floor. Unknowns w+, v+ (slip rate of the new pivot), U+,
and the impulses (Pt, Pn) of the floor on the landing corner (at theta = 0 both bottom corners move
horizontally with v; the centre moves, relative to the floor, with (v + h w, s b w) before and
(v + h w, -s b w) after):
    (a) block, horizontal:  m [(U+ + v+ + h w+) - (U- + v- + h w-)] = Pt
    (b) block, vertical:    m [(-s b w+) - (s b w-)] = Pn        =>  Pn = -m s b (w+ + w-)
    (c) floor j:            m_j (U+ - U-) = -Pt
    (d) block, rotation:    Ic (w+ - w-) = -h Pt + s b Pn        (landing corner at (-s b, -h) from
                                                                  the centre; clockwise moments)
(d) + h (a) - s b (b) removes the impulses: the angular momentum about the landing corner is kept,
    I0 w+ + m h (U+ + v+) = eta I0 w- + m h (U- + v-),    eta = 1 - 3/2 sin^2(alpha)  (Housner),
and (a) + (c) keep the horizontal momentum m_j U + m (U + v + h w). From (a), (c):
    U+ - U- = -r (dv + h dw),   Pt = m_e (dv + h dw),   r = m / (m + m_j),   m_e = m m_j / (m + m_j),
(dv = v+ - v-, dw = w+ - w-). Substituting:
    (1) (I0 - r m h^2) w+ + m_e h v+ = (eta I0 - r m h^2) w- + m_e h v-.
Sticking impact: v+ = 0, so
    w+ = [(eta I0 - r m h^2) w- + m_e h v-] / (I0 - r m h^2),
accepted if |Pt| <= mu Pn. Otherwise a sliding impact: Pt = c mu Pn with c = sign(Pt of the sticking
impact) (friction keeps the direction of the impulse sticking needed, as far as mu Pn allows):
    (2) (m_e h + c mu m s b) w+ + m_e v+ = m_e (v- + h w-) - c mu m s b w-,
solved with (1). Then U+ = U- - Pt / m_j. Flat landing (w+ from the above does not rock the block
away from the landing corner, s' w+ <= 0): w+ = 0, Pn = -m s b w-, and with x = v- + h w- the
sticking flat landing needs Pt = -m_e x (v+ = 0); it holds if m_e |x| <= mu Pn, else
Pt = -sign(x) mu Pn and v+ = x + Pt / m_e. In every case U+ = U- - Pt / m_j.
Limit m_j -> infinity (rigid ground; also one-way coupling, where the floor does not feel the
impulse): r -> 0, m_e -> m, and (1), (2) and the flat landing become model/sliding_reference.py's
impact law exactly (tested in ``self_test``). I0 - r m h^2 >= I0 - m h^2 > 0, so (1) always solves.
Rest rule (sliding_reference's): if the landing is not flat, |a_f| <= g tan(alpha) (a_f the floor's
acceleration with the block at rest on it) and the rebound w+ would lift the block by less than
rest_ratio alpha, the rebound is dropped: w+ = 0, v+ kept, and U+ is set so that the horizontal
momentum m_j U + m (U + v + h w) is still the one before the impact (so every impact keeps it).

Rest, uplift and mode changes on a moving floor
-----------------------------------------------
- The floor acceleration every rule uses is a_f of the mode being tested, from the current support
  state: at rest (two-way) floor j carries M_j + m, so a_f,rest = a_g + (r_j - m a_g) / (M_j + m).
- Rest ends when |a_f,rest| reaches min(mu, tan alpha) g (two events located by solve_ivp): slide
  (mu <= tan alpha) to -sign(a_f,rest), else rock on s = -sign(a_f,rest) if rocking's (coupled) friction
  demand |T| / N <= mu (event "uplift"), else slide-rock.
- Slide: slip rate to 0 -> rest if |a_f,rest| <= mu g, else the slide reverses.
- Rock: mu N - |T| to 0 (coupled T, N) -> slide-rock against T. Slide-rock: slip rate to 0 ->
  sliding_reference's pivot_mode with coupled forces (rock if N >= 0 and |T| <= mu N, else the
  consistent slide-rock). Impact at theta = 0, overturn at |theta| = pi / 2.
- Overturn ends the block's motion: it lies on its floor (two-way: with a momentum-conserving
  plastic hit, then moving with the floor as at rest); the energy balance is not followed after it.

Friction: mu = math.inf (or any large mu, e.g. 100) gives rigid rocking without sliding; with
mu = inf the friction-limit events of rock are replaced by N = 0 (lift-off), which ends the run with
SupportReferenceError, as does any other need for free flight (not modelled here; ``Run.min_normal``
reports the smallest normal force met on a corner, which sliding_reference does not check either).
Impacts are the plastic ones above: ``SlidingBlock.eta`` must be None (Housner's eta).

Integration: scipy.integrate.solve_ivp, DOP853 (rtol 1e-12, atol 1e-14), piece by piece between the
excitation's break points (record samples; a sine's quarter periods); the terminal events of the mode
are located by scipy (brentq on the dense output, xtol 4 eps) and then bisected on the dense output to
two adjacent floats, the event time being the first float past the crossing. The rate w = 0 is a
non-terminal event in the rocking modes, so that peak |theta| is exact. ``Run.sample(times)`` evaluates
the dense output anywhere. ``python -m model.support_reference`` runs ``self_test`` (the checks of
this reference: the impact law against sliding_reference's and against the raw impulse equations,
rigid ground against sliding_reference.simulate, huge supports two-way = one-way, momentum on a free
platform, energy balances, the cabinet on a 3-storey frame and on a 50 kg top floor).

API:  Building(masses, stiffnesses, damping_ratio, floor), Platform(mass, stiffness=0, damping=0),
RigidGround(); simulate(block, support, excitation, t_end, coupling="two-way", theta0=0, omega0=0,
rest_ratio=None, ...) -> Run; impact_on_floor(...) (the impact law alone); read_at2 / record_file
(base records); sine_pulse, record (from sliding_reference).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from model.sliding_reference import (MODE_NAMES, OVERTURNED, REST, ROCK, SLIDE, SLIDE_ROCK, Excitation,
                                     SlidingBlock, SlidingReferenceError, mode_after_impact, record, sine_pulse)
from model.sliding_reference import _relocate as _relocate_state

__all__ = ["Building", "Platform", "RigidGround", "Run", "ImpactOutcome", "impact_on_floor", "simulate",
           "read_at2", "record_file", "sine_pulse", "record", "SlidingBlock", "Excitation",
           "SupportReferenceError", "self_test", "G0"]

G0 = 9.80665  # m/s^2, the g of records given in units of g


class SupportReferenceError(SlidingReferenceError):
    """The reference cannot go on (no consistent mode, no progress at an event, Painleve)."""


# ----------------------------------------------------------------------------------------- supports


@dataclass(frozen=True)
class Building:
    """Linear shear building. ``masses`` (kg) of floors 1..N bottom to top, ``stiffnesses`` (N/m) of
    storeys 1..N (storey i joins floor i-1 to floor i), Rayleigh ``damping_ratio`` at modes 1 and 2,
    ``floor`` (1..N) the floor the block stands on."""

    masses: Sequence[float]
    stiffnesses: Sequence[float]
    damping_ratio: float
    floor: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "masses", tuple(float(x) for x in self.masses))
        object.__setattr__(self, "stiffnesses", tuple(float(x) for x in self.stiffnesses))
        n = len(self.masses)
        if not 1 <= n <= 10 or len(self.stiffnesses) != n:
            raise ValueError("need 1 to 10 storeys and as many stiffnesses as masses")
        if min(self.masses) <= 0 or min(self.stiffnesses) <= 0:
            raise ValueError("masses and stiffnesses must be > 0")
        if not 0.0 <= self.damping_ratio < 1.0:
            raise ValueError("damping_ratio must be in [0, 1)")
        if not 1 <= int(self.floor) <= n:
            raise ValueError(f"floor must be 1..{n}")

    def mass_vector(self) -> np.ndarray:
        """Diagonal of M (kg)."""
        return np.array(self.masses)

    def stiffness_matrix(self) -> np.ndarray:
        """K (N/m), tridiagonal."""
        k, n = self.stiffnesses, len(self.masses)
        K = np.zeros((n, n))
        for i in range(n):
            K[i, i] = k[i] + (k[i + 1] if i + 1 < n else 0.0)
            if i + 1 < n:
                K[i, i + 1] = K[i + 1, i] = -k[i + 1]
        return K

    def circular_frequencies(self) -> np.ndarray:
        """Natural circular frequencies (rad/s), ascending, of K phi = w^2 M phi (own masses)."""
        s = 1.0 / np.sqrt(self.mass_vector())
        w2 = np.linalg.eigvalsh(s[:, None] * self.stiffness_matrix() * s[None, :])
        return np.sqrt(np.maximum(w2, 0.0))

    def rayleigh(self) -> tuple[float, float]:
        """(a0 (1/s), a1 (s)) of C = a0 M + a1 K."""
        w, z = self.circular_frequencies(), self.damping_ratio
        if len(w) == 1:
            return 0.0, float(2.0 * z / w[0])
        return float(2.0 * z * w[0] * w[1] / (w[0] + w[1])), float(2.0 * z / (w[0] + w[1]))

    def damping_matrix(self) -> np.ndarray:
        a0, a1 = self.rayleigh()
        return a0 * np.diag(self.mass_vector()) + a1 * self.stiffness_matrix()

    def _system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        return self.mass_vector(), self.stiffness_matrix(), self.damping_matrix(), int(self.floor) - 1


@dataclass(frozen=True)
class Platform:
    """Isolation platform: ``mass`` (kg) on a linear spring ``stiffness`` (N/m, >= 0) and viscous
    damper ``damping`` (N s/m, >= 0) to the base; both 0: a free platform on frictionless rollers."""

    mass: float
    stiffness: float = 0.0
    damping: float = 0.0

    def __post_init__(self) -> None:
        if not self.mass > 0 or self.stiffness < 0 or self.damping < 0:
            raise ValueError("need mass > 0, stiffness >= 0, damping >= 0")

    def _system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        return (np.array([float(self.mass)]), np.array([[float(self.stiffness)]]),
                np.array([[float(self.damping)]]), 0)


@dataclass(frozen=True)
class RigidGround:
    """The rigid ground: the block feels a_g itself (sliding_reference's case)."""

    def _system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        return np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0)), -1


Support = Building | Platform | RigidGround


# ----------------------------------------------------------------------------------------- records


def read_at2(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A PEER NGA .AT2 file (4 header lines, the 4th 'NPTS= n, DT= dt SEC', accelerations in g) or a
    plain two-column file (time s, acceleration m/s^2). Returns (time s, acceleration m/s^2); AT2
    samples are at i dt from 0 and scaled by G0 = 9.80665 m/s^2 per g."""
    text = Path(path).read_text().splitlines()
    if len(text) > 4 and "NPTS" in text[3].upper():
        head = text[3].upper().replace(",", " ").replace("=", " ").split()
        npts = int(head[head.index("NPTS") + 1])
        dt = float(head[head.index("DT") + 1])
        unit = text[2].upper()
        if "UNITS OF G" in unit:
            scale = G0
        elif "CM/S" in unit:
            scale = 0.01
        else:
            raise ValueError(f"{path}: unknown unit line {text[2]!r}")
        vals = np.array([float(x) for line in text[4:] for x in line.split()])
        if vals.size != npts:
            raise ValueError(f"{path}: {vals.size} samples, NPTS says {npts}")
        return dt * np.arange(npts), scale * vals
    data = np.loadtxt(path, comments="#", ndmin=2)
    return data[:, 0], data[:, 1]


def record_file(path: str | Path, scale: float = 1.0, t0: float = 0.0) -> Excitation:
    """The base acceleration of a record file (``read_at2``), linear between samples, zero outside."""
    t, a = read_at2(path)
    return record(t, a, scale=scale, t0=t0)


# ----------------------------------------------------------------------------------------- impact


@dataclass
class ImpactOutcome:
    """Velocities after an impact at theta = 0 on pivot s (landing corner -s): w+ (rad/s), v+ (slip
    rate of the new pivot relative to the floor, m/s), U+ (floor j's velocity, m/s); impulses of the
    floor on the block (N s): Pt (+x), Pn (up)."""

    omega_plus: float
    slip_rate_plus: float
    floor_velocity_plus: float
    Pt: float
    Pn: float
    sticking: bool
    flat: bool
    rest: bool = False  # the rest rule dropped the rebound


def impact_on_floor(blk: SlidingBlock, s: int, omega_minus: float, slip_rate_minus: float,
                    floor_velocity_minus: float, floor_mass: float) -> ImpactOutcome:
    """The plastic impact with Coulomb friction of the block on a floor of mass ``floor_mass`` (kg;
    math.inf: an immovable floor) that moves horizontally only (module docstring, equations (1), (2)
    and the flat landing). The rest rule is not applied here (see ``_Solver.impact``)."""
    if blk.eta is not None:
        raise ValueError("the reference's impact is the plastic one (Housner's eta): leave eta None")
    m, b, h, mu = blk.m, blk.b, blk.h, blk.mu
    I0 = 4.0 / 3.0 * m * blk.R ** 2
    eta = blk.restitution
    if math.isinf(floor_mass):
        r, me = 0.0, m
    else:
        r, me = m / (m + floor_mass), m * floor_mass / (m + floor_mass)
    wm, vm, Um = omega_minus, slip_rate_minus, floor_velocity_minus
    a11, a12 = I0 - r * m * h * h, me * h
    rhs1 = (eta * I0 - r * m * h * h) * wm + me * h * vm
    wp, vp = rhs1 / a11, 0.0
    Pt = me * (vp - vm + h * (wp - wm))
    Pn = -m * s * b * (wp + wm)
    sticking = abs(Pt) <= mu * Pn
    if not sticking:
        c = 1.0 if Pt > 0 else -1.0
        a21, a22 = me * h + c * mu * m * s * b, me
        rhs2 = me * (vm + h * wm) - c * mu * m * s * b * wm
        det = a11 * a22 - a12 * a21
        wp = (rhs1 * a22 - a12 * rhs2) / det
        vp = (a11 * rhs2 - a21 * rhs1) / det
        Pt = me * (vp - vm + h * (wp - wm))
        Pn = -m * s * b * (wp + wm)
    flat = (-s) * wp <= 0.0
    if flat:
        x = vm + h * wm
        Pn = -m * s * b * wm
        if me * abs(x) <= mu * Pn:
            Pt, vp = -me * x, 0.0
        else:
            Pt = -math.copysign(mu * Pn, x)
            vp = x + Pt / me
        wp = 0.0
    Up = Um if math.isinf(floor_mass) else Um - Pt / floor_mass
    return ImpactOutcome(wp, vp, Up, Pt, Pn, sticking, flat)


# ----------------------------------------------------------------------------------------- run


@dataclass
class Run:
    """One run. Row arrays are at the integrator's steps and at events (an event gives two rows:
    before and after); ``grid_*`` arrays on the uniform grid ``grid_t`` (every ``dt_out`` s).
    theta (rad), omega (rad/s), slip (m: x of the pivot corner relative to the floor minus s b, the
    base centre's displacement relative to the floor whenever the base is flat), slip_rate (m/s),
    floor_u, floor_v (m, m/s: floor j relative to the base), floor_a (m/s^2: floor j's absolute
    acceleration a_f; the rigid ground's: a_g), energies and works in J, momentum in N s (horizontal,
    base frame: 1^T M u' + m (u_j' + X'))."""

    coupling: str = "two-way"
    t: np.ndarray = field(default_factory=lambda: np.empty(0))
    theta: np.ndarray = field(default_factory=lambda: np.empty(0))
    omega: np.ndarray = field(default_factory=lambda: np.empty(0))
    slip: np.ndarray = field(default_factory=lambda: np.empty(0))
    slip_rate: np.ndarray = field(default_factory=lambda: np.empty(0))
    mode: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))
    side: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))
    energy: np.ndarray = field(default_factory=lambda: np.empty(0))
    base_work: np.ndarray = field(default_factory=lambda: np.empty(0))
    damping_loss: np.ndarray = field(default_factory=lambda: np.empty(0))
    friction_loss: np.ndarray = field(default_factory=lambda: np.empty(0))
    impact_loss: np.ndarray = field(default_factory=lambda: np.empty(0))
    momentum: np.ndarray = field(default_factory=lambda: np.empty(0))
    floor_u: np.ndarray = field(default_factory=lambda: np.empty(0))
    floor_v: np.ndarray = field(default_factory=lambda: np.empty(0))
    floor_a: np.ndarray = field(default_factory=lambda: np.empty(0))
    valid_balance: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=bool))  # False after overturn
    grid_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_theta: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_omega: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_slip: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_floor_u: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_floor_v: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_floor_a: np.ndarray = field(default_factory=lambda: np.empty(0))
    grid_u: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # all floors, (len(grid_t), N)
    grid_momentum: np.ndarray = field(default_factory=lambda: np.empty(0))
    events: list[tuple[str, float]] = field(default_factory=list)
    switches: list[tuple[float, int, int]] = field(default_factory=list)
    impact_times: list[float] = field(default_factory=list)
    impact_details: list[ImpactOutcome] = field(default_factory=list)
    impact_momentum_jump: list[float] = field(default_factory=list)  # N s, P after - P before
    impact_energy_change: list[float] = field(default_factory=list)  # J, E after - E before (<= 0)
    extrema: list[tuple[float, float]] = field(default_factory=list)  # (t, theta) where omega = 0
    min_normal: float = math.inf  # N, smallest normal force seen at steps while on a corner
    overturned: bool = False
    pieces: int = 0  # solve_ivp calls
    _segments: list = field(default_factory=list, repr=False)  # (t0, t1, dense output, mode, s, sigma, ground)
    _solver: object = field(default=None, repr=False)

    def sample(self, times: Sequence[float] | np.ndarray) -> dict[str, np.ndarray]:
        """The run at any times (s) in [0, t_end], from the integrator's dense output: theta, omega,
        slip, slip_rate, floor_u, floor_v, floor_a (absolute), momentum. At an event time the value
        after the event."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        starts = np.array([seg[0] for seg in self._segments])
        keys = ("theta", "omega", "slip", "slip_rate", "floor_u", "floor_v", "floor_a", "momentum")
        res = {k: np.empty(times.size) for k in keys}
        sv = self._solver
        for idx, tt in enumerate(times):
            k = max(int(np.searchsorted(starts, tt, side="right")) - 1, 0)
            t0, t1, sol, mode, s, sigma, ground = self._segments[k]
            y = sol(tt) if callable(sol) else sol
            af = sv.forces(mode, s, sigma, ground(tt), y)[1]
            vals = (y[sv.iT], y[sv.iW], y[sv.iU], y[sv.iV], float(y[sv.j]) if sv.n else 0.0, sv.floor_velocity(y), af,
                    sv.momentum(s, y))
            for key, v in zip(keys, vals):
                res[key][idx] = v
        return res

    @property
    def impacts(self) -> int:
        return len(self.impact_times)

    @property
    def peak_abs_theta(self) -> float:
        """Largest |theta| (rad), at steps, events and exactly located extrema (omega = 0)."""
        p = float(np.max(np.abs(self.theta))) if self.theta.size else 0.0
        return max([p] + [abs(th) for _, th in self.extrema])

    @property
    def final_slip(self) -> float:
        return float(self.slip[-1])

    @property
    def peak_abs_slip(self) -> float:
        return float(np.max(np.abs(self.slip)))

    @property
    def balance_residual(self) -> np.ndarray:
        """E + damping + friction + impact losses - E(0) - base work (J), NaN after an overturn."""
        r = self.energy + self.damping_loss + self.friction_loss + self.impact_loss - self.energy[0] - self.base_work
        return np.where(self.valid_balance, r, np.nan)

    @property
    def energy_scale(self) -> float:
        """The largest of |E|, |base work| and the losses over the run (J)."""
        v = self.valid_balance
        return float(max(np.max(np.abs(self.energy[v])), np.max(np.abs(self.base_work[v])),
                         np.max(self.damping_loss[v]), np.max(self.friction_loss[v]), np.max(self.impact_loss[v]),
                         1e-300))

    @property
    def max_abs_residual(self) -> float:
        return float(np.nanmax(np.abs(self.balance_residual)))

    @property
    def relative_residual(self) -> float:
        return self.max_abs_residual / self.energy_scale

    @property
    def n_events(self) -> int:
        return len(self.events)

    def event_times(self, kind: str) -> np.ndarray:
        return np.array([t for k, t in self.events if k == kind])


# ----------------------------------------------------------------------------------------- solver


class _Solver:
    def __init__(self, blk: SlidingBlock, support: Support, exc: Excitation, t_end: float, coupling: str,
                 rtol: float, atol: float, max_step: float, dt_out: float):
        if coupling not in ("one-way", "two-way"):
            raise ValueError("coupling must be 'one-way' or 'two-way'")
        if not blk.mu > 0 or not (blk.b > 0 and blk.h > 0 and blk.m > 0):
            raise ValueError("need mu > 0, b > 0, h > 0, m > 0")
        if blk.eta is not None:
            raise ValueError("the reference's impacts are plastic (Housner's eta): leave SlidingBlock.eta None")
        self.blk, self.exc, self.t_end = blk, exc, float(t_end)
        self.rtol, self.atol, self.max_step = rtol, atol, max_step
        self.Mv, self.K, self.C, self.j = support._system()
        self.n = self.Mv.size
        self.two_way = coupling == "two-way" and self.n > 0
        self.mj = float(self.Mv[self.j]) if self.two_way else math.inf
        self.m, self.g, self.R, self.mu = blk.m, blk.g, blk.R, blk.mu
        self.alpha, self.tan_a = blk.alpha, math.tan(blk.alpha)
        self.Ic = blk.m * blk.R ** 2 / 3.0
        n = self.n
        self.iT, self.iW, self.iU, self.iV = 2 * n, 2 * n + 1, 2 * n + 2, 2 * n + 3
        self.iWb, self.iWd, self.iWf = 2 * n + 4, 2 * n + 5, 2 * n + 6
        self.ny = 2 * n + 7
        # the excitation's break points and monotone cells (sine: quarter periods)
        pts = {float(x) for x in exc.breaks if math.isfinite(x) and 0.0 < x < self.t_end}
        if exc.cells is not None:
            pts |= {float(x) for x in exc.cells(0.0, self.t_end) if 0.0 < x < self.t_end}
        self.breaks = sorted(pts)
        probe = np.union1d(np.arange(0.0, self.t_end, 1e-3), self.breaks)
        if any(exc.ground(float(x))[1] != 0.0 for x in probe):
            raise ValueError("the supports move horizontally only: the excitation must have no vertical part (a_v = 0)")
        self.run = Run(coupling=coupling)
        self.rows: list[tuple] = []
        self.w_impact = 0.0
        self.balance_ok = True
        self.grid = np.arange(0.0, self.t_end + 0.5 * dt_out, dt_out)
        self.grid = self.grid[self.grid <= self.t_end * (1 + 1e-15)]
        self.gi = 0
        self.grid_rows: list[np.ndarray] = []

    # --- ground, clamped to one piece (one side of a discontinuity)
    def piece_ground(self, lo: float, hi: float) -> Callable[[float], float]:
        g, top = self.exc.ground, math.nextafter(hi, -math.inf)
        return lambda t: g(min(max(t, lo), top))[0]

    def ground_after(self, t: float) -> Callable[[float], float]:
        k = bisect.bisect_right(self.breaks, t)
        t_stop = min(self.breaks[k], self.t_end) if k < len(self.breaks) else self.t_end
        return self.piece_ground(t, max(t_stop, t))

    # --- the coupled accelerations of a mode
    def forces(self, mode: int, s: int, sigma: int, ag: float, y: np.ndarray):
        """(support accelerations u'' (array), a_f, w', ub'', T, N) of ``mode`` at state y."""
        m, g, R, n = self.m, self.g, self.R, self.n
        theta, w = y[self.iT], y[self.iW]
        sp = cp = 0.0
        if mode == REST or mode == OVERTURNED:
            T0, Ta = 0.0, m
        elif mode == SLIDE:
            T0, Ta = -sigma * self.mu * m * g, 0.0
        else:
            phi = theta - s * self.alpha
            sp, cp = math.sin(phi), math.cos(phi)
            if mode == ROCK:
                T0, Ta = m * (0.75 * g * sp * cp - R * sp * w * w), m * (1.0 - 0.75 * cp * cp)
            else:
                q = sp + sigma * self.mu * cp
                den = 1.0 / 3.0 + q * sp
                if den <= 0.0:
                    raise SupportReferenceError(f"slide-rock has no solution at theta={theta!r} (Painleve)")
                wd_sr = q * (g - R * cp * w * w) / (R * den)
                N_sr = m * (g - R * sp * wd_sr - R * cp * w * w)
                T0, Ta = -sigma * self.mu * N_sr, 0.0
        if n == 0:
            A = None
            af = ag
        else:
            u, ud = y[:n], y[n:2 * n]
            rr = -(self.C @ ud) - (self.K @ u) - self.Mv * ag
            A = rr / self.Mv
            if self.two_way:
                A[self.j] = (rr[self.j] - T0 - Ta * ag) / (self.Mv[self.j] + Ta)
            af = ag + A[self.j]
        T = T0 + Ta * af
        if mode == REST or mode == OVERTURNED:
            return A, af, 0.0, 0.0, T, m * g
        if mode == SLIDE:
            return A, af, 0.0, T / m - af, T, m * g
        if mode == ROCK:
            wd = 0.75 / R * (g * sp - af * cp)
            N = m * (g - R * sp * wd - R * cp * w * w)
            return A, af, wd, 0.0, T, N
        return A, af, wd_sr, T / m - af - R * cp * wd_sr + R * sp * w * w, T, N_sr

    def centre_velocity(self, s: int, y: np.ndarray) -> tuple[float, float]:
        phi = y[self.iT] - s * self.alpha
        w = y[self.iW]
        return y[self.iV] + self.R * math.cos(phi) * w, -self.R * math.sin(phi) * w

    def floor_velocity(self, y: np.ndarray) -> float:
        return float(y[self.n + self.j]) if self.n else 0.0

    def energy(self, s: int, y: np.ndarray) -> float:
        n, m = self.n, self.m
        Xd, Yd = self.centre_velocity(s, y)
        e = 0.0
        if n:
            u, ud = y[:n], y[n:2 * n]
            e = 0.5 * float(ud @ (self.Mv * ud)) + 0.5 * float(u @ (self.K @ u))
        vx = Xd + (self.floor_velocity(y) if self.two_way else 0.0)
        e += 0.5 * m * (vx * vx + Yd * Yd) + 0.5 * self.Ic * y[self.iW] ** 2
        e += m * self.g * (self.R * math.cos(y[self.iT] - s * self.alpha) - self.blk.h)
        return e

    def momentum(self, s: int, y: np.ndarray) -> float:
        Xd, _ = self.centre_velocity(s, y)
        p = self.m * (Xd + self.floor_velocity(y))
        if self.n:
            p += float(self.Mv @ y[self.n:2 * self.n])
        return p

    def rhs_factory(self, mode: int, s: int, sigma: int, ground: Callable[[float], float]):
        n, m, R, alpha = self.n, self.m, self.R, self.alpha
        iT, iW, iU, iV = self.iT, self.iW, self.iU, self.iV
        two_way = self.two_way

        def rhs(t, y):
            ag = ground(t)
            A, af, wd, ubdd, T, N = self.forces(mode, s, sigma, ag, y)
            dy = np.empty(self.ny)
            w, v = y[iW], y[iV]
            Xd = v + R * math.cos(y[iT] - s * alpha) * w
            if n:
                ud = y[n:2 * n]
                dy[:n] = ud
                dy[n:2 * n] = A
                P_s = float(self.Mv @ ud)
                dy[self.iWd] = float(ud @ (self.C @ ud))
                if two_way:
                    dy[self.iWb] = -ag * (P_s + m * (ud[self.j] + Xd))
                else:
                    dy[self.iWb] = -ag * P_s - m * af * Xd
            else:
                dy[self.iWd] = 0.0
                dy[self.iWb] = -m * ag * Xd
            dy[iT], dy[iW], dy[iU], dy[iV] = w, wd, v, ubdd
            dy[self.iWf] = -T * v
            return dy

        return rhs

    # --- bookkeeping
    def record_row(self, t: float, y: np.ndarray, mode: int, s: int, sigma: int, ag: float) -> None:
        A, af, _, _, _, N = self.forces(mode, s, sigma, ag, y)
        if mode in (ROCK, SLIDE_ROCK):
            self.run.min_normal = min(self.run.min_normal, N)
        fu = float(y[self.j]) if self.n else 0.0
        self.rows.append((t, y[self.iT], y[self.iW], y[self.iU], y[self.iV], mode, s, self.energy(s, y),
                          y[self.iWb], y[self.iWd], y[self.iWf], self.w_impact, self.momentum(s, y), fu,
                          self.floor_velocity(y), af, self.balance_ok))

    def fill_grid(self, sol, t_hi: float, mode: int, s: int, sigma: int, ground, inclusive: bool = False) -> None:
        while self.gi < self.grid.size and (self.grid[self.gi] < t_hi or (inclusive and self.grid[self.gi] <= t_hi)):
            tg = float(self.grid[self.gi])
            y = sol(tg) if callable(sol) else sol
            _, af, _, _, _, _ = self.forces(mode, s, sigma, ground(tg), y)
            row = np.concatenate(([tg, y[self.iT], y[self.iW], y[self.iU],
                                   float(y[self.j]) if self.n else 0.0, self.floor_velocity(y), af,
                                   self.momentum(s, y)], y[:self.n]))
            self.grid_rows.append(row)
            self.gi += 1

    def switch(self, t: float, old: int, new: int, kind: str) -> None:
        self.run.events.append((kind, t))
        if old != new:
            self.run.switches.append((t, old, new))

    # --- mode choices
    def pivot_mode(self, s: int, y: np.ndarray, ag: float) -> tuple[int, int]:
        """(mode, sigma) consistent on pivot s with a zero slip rate (sliding_reference's rule, with
        the coupled forces)."""
        _, _, _, _, T, N = self.forces(ROCK, s, 0, ag, y)
        if N >= 0.0 and (math.isinf(self.mu) or abs(T) <= self.mu * N):
            return ROCK, 0
        if math.isinf(self.mu):
            raise SupportReferenceError("rocking would need a tensile normal force (lift-off): flight is not modelled")
        preferred = -1 if T > 0 else 1
        for sigma in (preferred, -preferred):
            try:
                _, _, _, ubdd, _, N2 = self.forces(SLIDE_ROCK, s, sigma, ag, y)
            except SupportReferenceError:
                continue
            if N2 > 0.0 and sigma * ubdd > 0.0:
                return SLIDE_ROCK, sigma
        return SLIDE_ROCK, preferred

    def rest_floor_acc(self, y: np.ndarray, ag: float) -> float:
        return self.forces(REST, 1, 0, ag, y)[1]

    def start_indicator(self, y: np.ndarray, ag: float) -> float:
        return abs(self.rest_floor_acc(y, ag)) - min(self.mu, self.tan_a) * self.g

    def leave_rest(self, y: np.ndarray, ag: float) -> tuple[int, int, int, str]:
        af = self.rest_floor_acc(y, ag)
        direction = -1 if af > 0 else 1
        if self.mu <= self.tan_a:
            return SLIDE, direction, direction, "slide"
        mode, sigma = self.pivot_mode(direction, y, ag)
        return mode, direction, sigma, "uplift" if mode == ROCK else "slide-rock"

    # --- impact with the rest rule
    def impact(self, s: int, y: np.ndarray, ag: float) -> tuple[ImpactOutcome, np.ndarray]:
        blk, m, n = self.blk, self.m, self.n
        wm, vm, Um = y[self.iW], y[self.iV], self.floor_velocity(y)
        res = impact_on_floor(blk, s, wm, vm, Um, self.mj)
        y2 = y.copy()
        y2[self.iT] = 0.0
        if not res.flat:
            # the rest rule: the floor's acceleration with the block at rest on it, and the rebound's peak
            yr = y2.copy()
            yr[self.iW], yr[self.iV] = 0.0, res.slip_rate_plus
            Ur = Um
            if self.two_way:
                Ur = Um + m * (vm + blk.h * wm - res.slip_rate_plus) / (self.mj + m)
                yr[n + self.j] = Ur
            if abs(self.rest_floor_acc(yr, ag)) <= self.g * self.tan_a:
                k = 0.75 / blk.R
                cpk = math.cos(blk.alpha) + res.omega_plus ** 2 / (2.0 * k * self.g)
                if cpk < 1.0 and blk.alpha - math.acos(cpk) < blk.rest_ratio * blk.alpha:
                    out = ImpactOutcome(0.0, res.slip_rate_plus, Ur, m * (Ur + res.slip_rate_plus - Um - vm - blk.h * wm),
                                        res.Pn, res.sticking, True, True)
                    return out, yr
        y2[self.iW], y2[self.iV] = res.omega_plus, res.slip_rate_plus
        if self.two_way:
            y2[n + self.j] = res.floor_velocity_plus
        return res, y2

    # --- main loop
    def solve(self, theta0: float, omega0: float) -> Run:
        run = self.run
        y = np.zeros(self.ny)
        y[self.iT], y[self.iW] = theta0, omega0
        t = 0.0
        if theta0 == 0.0 and omega0 == 0.0:
            mode, s, sigma = REST, 1, 0
        else:
            s = (1 if theta0 > 0 else -1) if theta0 != 0.0 else (1 if omega0 > 0 else -1)
            mode, sigma = ROCK, 0
        g0 = self.ground_after(0.0)
        self.record_row(t, y, mode, s, sigma, g0(0.0))
        stalls = 0
        while t < self.t_end:
            ground = self.ground_after(t)
            if mode == REST and self.start_indicator(y, ground(t)) > 0.0:
                new, s, sigma, kind = self.leave_rest(y, ground(t))
                self.switch(t, REST, new, kind)
                mode = new
                continue
            if mode == ROCK:
                new, sigma = self.pivot_mode(s, y, ground(t))
                if new == SLIDE_ROCK:
                    self.switch(t, ROCK, SLIDE_ROCK, "slide-rock")
                    mode = new
            t_new, y, mode, s, sigma = self.integrate(t, y, mode, s, sigma)
            stalls = stalls + 1 if t_new <= t else 0
            if stalls > 8:
                raise SupportReferenceError(f"no progress at t={t!r} in mode {MODE_NAMES[mode]}")
            t = t_new
        ground = self.ground_after(math.nextafter(self.t_end, -math.inf))
        self.fill_grid(y, self.t_end, mode, s, sigma, ground, inclusive=True)
        run.overturned = any(k == "overturn" for k, _ in run.events)
        run._segments.append((self.t_end, self.t_end, y, mode, s, sigma, ground))
        run._solver = self
        a = np.array(self.rows, dtype=float)
        (run.t, run.theta, run.omega, run.slip, run.slip_rate, modes, sides, run.energy, run.base_work,
         run.damping_loss, run.friction_loss, run.impact_loss, run.momentum, run.floor_u, run.floor_v,
         run.floor_a, valid) = a.T
        run.mode, run.side, run.valid_balance = modes.astype(int), sides.astype(int), valid.astype(bool)
        gr = np.array(self.grid_rows, dtype=float)
        (run.grid_t, run.grid_theta, run.grid_omega, run.grid_slip, run.grid_floor_u, run.grid_floor_v,
         run.grid_floor_a, run.grid_momentum) = gr[:, :8].T
        run.grid_u = gr[:, 8:]
        return run

    def integrate(self, t: float, y0: np.ndarray, mode: int, s: int, sigma: int):
        run, n = self.run, self.n
        k = bisect.bisect_right(self.breaks, t)
        t_stop = min(self.breaks[k], self.t_end) if k < len(self.breaks) else self.t_end
        ground = self.piece_ground(t, t_stop)
        rhs = self.rhs_factory(mode, s, sigma, ground)
        iT, iW, iV = self.iT, self.iW, self.iV
        thr = min(self.mu, self.tan_a) * self.g

        def ev_impact(tt, y):
            return s * y[iT]

        def ev_overturn(tt, y):
            return s * y[iT] - 0.5 * math.pi

        def ev_stop(tt, y):
            return sigma * y[iV]

        def ev_peak(tt, y):
            return y[iW]

        def friction_margin(sign):
            def ev(tt, y):
                _, _, _, _, T, N = self.forces(ROCK, s, 0, ground(tt), y)
                return N if math.isinf(self.mu) else self.mu * N - sign * T
            ev.terminal, ev.direction = True, -1
            return ev

        def start(sign):
            def ev(tt, y):
                return sign * self.rest_floor_acc(y, ground(tt)) - thr
            ev.terminal, ev.direction = True, 1
            return ev

        ev_impact.terminal, ev_impact.direction = True, -1
        ev_overturn.terminal, ev_overturn.direction = True, 1
        ev_stop.terminal, ev_stop.direction = True, -1
        ev_peak.terminal, ev_peak.direction = False, 0
        if mode == REST:
            events = [start(1), start(-1)]
        elif mode == SLIDE:
            events = [ev_stop]
        elif mode == ROCK:
            events = [ev_impact, ev_overturn, friction_margin(1), ev_peak]
            if not math.isinf(self.mu):
                events.insert(3, friction_margin(-1))
        elif mode == SLIDE_ROCK:
            events = [ev_impact, ev_overturn, ev_stop, ev_peak]
        else:  # overturned: the block lies on its floor
            events = []
        try:
            r = solve_ivp(rhs, (t, t_stop), y0, method="DOP853", rtol=self.rtol, atol=self.atol, events=events,
                          dense_output=True, max_step=self.max_step)
        except SlidingReferenceError as exc:
            raise SupportReferenceError(f"{exc}, integrating from t={t!r} s") from None
        if r.status < 0:
            raise SupportReferenceError(f"solve_ivp failed at t={t!r}: {r.message}")
        run.pieces += 1
        hit = []
        for i, te_arr in enumerate(r.t_events):
            if events[i] is ev_peak:
                for te_, ye_ in zip(te_arr, r.y_events[i]):
                    run.extrema.append((float(te_), float(ye_[iT])))
                continue
            if te_arr.size:
                hit.append((float(te_arr[0]), i))
        te = None
        if hit:
            te, i = min(hit)
            ev = events[i]
            if te <= t and ev in (ev_impact, ev_stop):
                found = _relocate(r.sol.interpolants[0], ev, t)
                if found is None:
                    te_ref = te
                else:
                    te_ref = found
            else:
                te_ref = _refine(r.sol, ev, te, ev.direction, t, te + 1e-6)
            te = te_ref
            ye = r.sol(te)
            # drop extrema found after the event (the step was truncated there)
            run.extrema = [(a, b) for a, b in run.extrema if a <= te]
        t_last = te if te is not None else float(r.t[-1])
        for jj in range(1, r.t.size):
            if r.t[jj] >= t_last:
                break
            self.record_row(float(r.t[jj]), r.y[:, jj], mode, s, sigma, ground(float(r.t[jj])))
        self.fill_grid(r.sol, t_last, mode, s, sigma, ground)
        run._segments.append((t, t_last, r.sol, mode, s, sigma, ground))
        if te is None:
            yl = r.y[:, -1].copy()
            self.record_row(t_last, yl, mode, s, sigma, ground(t_last))
            return t_last, yl, mode, s, sigma
        ye = np.array(ye, dtype=float)
        ag = ground(te)
        # the state right after te, for the next piece: the ground of the piece that follows te
        ag_next = self.ground_after(te)(te) if te >= t_stop else ag
        if ev is ev_overturn:
            self.record_row(te, ye, mode, s, sigma, ag)
            self.switch(te, mode, OVERTURNED, "overturn")
            ye[iT] = s * 0.5 * math.pi
            # the block lies on its floor: a plastic, momentum-conserving hit, then it rides with it
            if self.two_way:
                Xd, _ = self.centre_velocity(s, ye)
                ye[n + self.j] += self.m * Xd / (self.mj + self.m)
            ye[iW], ye[iV] = 0.0, 0.0
            self.balance_ok = False
            self.record_row(te, ye, OVERTURNED, s, 0, ag_next)
            return te, ye, OVERTURNED, s, 0
        if mode == REST:
            self.record_row(te, ye, REST, s, 0, ag)
            new, s2, sig2, kind = self.leave_rest(ye, ag_next)
            self.switch(te, REST, new, kind)
            self.record_row(te, ye, new, s2, sig2, ag_next)
            return te, ye, new, s2, sig2
        if ev is ev_stop:
            ye[iV] = 0.0
            self.record_row(te, ye, mode, s, sigma, ag)
            if mode == SLIDE:
                if abs(self.rest_floor_acc(ye, ag_next)) <= self.mu * self.g:
                    self.switch(te, SLIDE, REST, "stick")
                    self.record_row(te, ye, REST, s, 0, ag_next)
                    return te, ye, REST, s, 0
                self.switch(te, SLIDE, SLIDE, "reverse")
                self.record_row(te, ye, SLIDE, -sigma, -sigma, ag_next)
                return te, ye, SLIDE, -sigma, -sigma
            new_mode, new_sigma = self.pivot_mode(s, ye, ag_next)
            if new_mode == ROCK:
                self.switch(te, SLIDE_ROCK, ROCK, "stick")
                self.record_row(te, ye, ROCK, s, 0, ag_next)
                return te, ye, ROCK, s, 0
            self.switch(te, SLIDE_ROCK, SLIDE_ROCK, "reverse" if new_sigma != sigma else "slide-rock")
            self.record_row(te, ye, SLIDE_ROCK, s, new_sigma, ag_next)
            return te, ye, SLIDE_ROCK, s, new_sigma
        if ev is ev_impact:
            ye[iT] = 0.0
            self.record_row(te, ye, mode, s, sigma, ag)
            e_before, p_before = self.energy(s, ye), self.momentum(s, ye)
            res, y2 = self.impact(s, ye, ag_next)
            s_new = -s
            e_after, p_after = self.energy(s_new, y2), self.momentum(s_new, y2)
            self.w_impact += e_before - e_after
            run.impact_times.append(te)
            run.impact_details.append(res)
            run.impact_momentum_jump.append(p_after - p_before)
            run.impact_energy_change.append(e_after - e_before)
            run.events.append(("impact", te))
            new, s_out, sig, why = mode_after_impact(res.flat, res.slip_rate_plus, mode, s_new, self.mu <= self.tan_a)
            if why:
                self.switch(te, mode, new, why)
            self.record_row(te, y2, new, s_out, sig, ag_next)
            return te, y2, new, s_out, sig
        # friction limit in Rock
        if math.isinf(self.mu):
            raise SupportReferenceError(f"the pivot's normal force reached 0 at t={te!r} s (lift-off): flight is not modelled")
        _, _, _, _, T, _ = self.forces(ROCK, s, 0, ag, ye)
        sigma = -1 if T > 0 else 1
        ye[iV] = 0.0
        self.record_row(te, ye, mode, s, 0, ag)
        self.switch(te, ROCK, SLIDE_ROCK, "slide-rock")
        self.record_row(te, ye, SLIDE_ROCK, s, sigma, ag_next)
        return te, ye, SLIDE_ROCK, s, sigma


def _refine(sol, ev, te: float, direction: float, t_lo: float, t_hi: float) -> float:
    """Bisect the event on the dense output to two adjacent floats around scipy's root ``te``: the
    first float past the crossing (direction * g >= 0 after, < 0 before)."""
    def before(x: float) -> bool:
        return direction * ev(x, sol(x)) < 0.0

    d = max(abs(te), 1.0) * 4e-16
    for _ in range(60):
        lo, hi = max(te - d, t_lo), min(te + d, t_hi)
        if lo < hi and before(lo) and not before(hi):
            break
        d *= 2.0
        if d > 1e-6:
            return te
    else:
        return te
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return hi
        if before(mid):
            lo = mid
        else:
            hi = mid


def _relocate(step, event, t0: float, samples: int = 256) -> float | None:
    """The first downward crossing of ``event`` after it has been positive on one step's dense
    output ``step`` (from t0), to one float; None if it never leaves 0 upwards."""
    found = _relocate_state(step, event, t0, samples)
    return None if found is None else found[0]


def simulate(block: SlidingBlock, support: Support, excitation: Excitation | None, t_end: float,
             coupling: str = "two-way", theta0: float = 0.0, omega0: float = 0.0, rest_ratio: float | None = None,
             rtol: float = 1e-12, atol: float = 1e-14, max_step: float = 0.01, dt_out: float = 1e-3) -> Run:
    """Run the block on ``support`` (Building, Platform or RigidGround) from t = 0 to ``t_end`` (s)
    under the base acceleration ``excitation`` (sliding_reference.Excitation; its a_v must be 0),
    coupled "one-way" (the support does not feel the block) or "two-way". The support starts at
    rest (u = u' = 0); the block flat at rest, or rocking from theta0 (rad) with omega0 (rad/s) on a
    sticking pivot. ``rest_ratio`` (None: the block's) sets the rest rule at impacts; ``max_step``
    (s) caps the integrator's step; ``dt_out`` (s) is the spacing of the ``grid_*`` outputs."""
    if rest_ratio is not None:
        from dataclasses import replace
        block = replace(block, rest_ratio=rest_ratio)
    solver = _Solver(block, support, excitation or Excitation(), t_end, coupling, rtol, atol, max_step, dt_out)
    return solver.solve(theta0, omega0)


# ----------------------------------------------------------------------------------------- self-test


def self_test(verbose: bool = True) -> dict:
    """The checks (i)-(vi) of the brief; returns the numbers and prints them."""
    import time
    from model import sliding_reference as sr

    out: dict = {}

    def say(*a):
        if verbose:
            print(*a, flush=True)

    here = Path(__file__).resolve().parent.parent
    at2 = here / "examples" / "pulse_3hz.AT2"
    exc_rec = record_file(at2)
    cab = SlidingBlock(b=0.3, h=1.0, mu=0.5, m=1000.0)

    # (0) the impact law tends to sliding_reference's as the floor mass grows; momentum kept; no energy gain
    rng = np.random.default_rng(1)
    worst_inf, worst_big, worst_p, worst_e = 0.0, 0.0, 0.0, -math.inf
    for _ in range(2000):
        blk = SlidingBlock(b=rng.uniform(0.1, 1), h=rng.uniform(0.2, 2), mu=rng.uniform(0.1, 1.5), m=rng.uniform(1, 1e3))
        s = int(rng.choice([-1, 1]))
        wm = -s * rng.uniform(0.01, 3)
        vm = rng.normal() * 0.5
        a = sr.impact(blk, s, wm, vm, 1e9, 0.0)  # |a_h| > g tan(alpha): no rest rule (applied apart here)
        b_ = impact_on_floor(blk, s, wm, vm, 0.3, math.inf)
        worst_inf = max(worst_inf, abs(a.omega_plus - b_.omega_plus), abs(a.slip_rate_plus - b_.slip_rate_plus))
        c_ = impact_on_floor(blk, s, wm, vm, 0.3, 1e14)
        worst_big = max(worst_big, abs(a.omega_plus - c_.omega_plus), abs(a.slip_rate_plus - c_.slip_rate_plus))
        mj = rng.uniform(0.05, 20) * blk.m
        d_ = impact_on_floor(blk, s, wm, vm, 0.3, mj)
        p0 = mj * 0.3 + blk.m * (0.3 + vm + blk.h * wm)
        p1 = mj * d_.floor_velocity_plus + blk.m * (d_.floor_velocity_plus + d_.slip_rate_plus + blk.h * d_.omega_plus)
        worst_p = max(worst_p, abs(p1 - p0) / (abs(p0) + blk.m * blk.R * abs(wm)))

        def ke(U, v, w, s_):
            return (0.5 * mj * U * U + 0.5 * blk.m * ((U + v + blk.h * w) ** 2 + (s_ * blk.b * w) ** 2)
                    + 0.5 * blk.m * blk.R ** 2 / 3 * w * w)

        e0 = ke(0.3, vm, wm, s)
        worst_e = max(worst_e, (ke(d_.floor_velocity_plus, d_.slip_rate_plus, d_.omega_plus, -s) - e0) / e0)
    out["impact_limit_inf_vs_sliding_reference"] = worst_inf
    out["impact_limit_1e14_vs_sliding_reference"] = worst_big
    out["impact_momentum_rel"] = worst_p
    out["impact_energy_gain_rel_max"] = worst_e
    say(f"(0) impact law vs sliding_reference.impact (2000 random): m_j = inf {worst_inf:.1e}, m_j = 1e14 kg "
        f"{worst_big:.1e} rad/s or m/s; finite m_j: momentum kept to {worst_p:.1e}, largest relative energy "
        f"change {worst_e:.1e} (<= 0: never gains)")
    # (0b) the closed forms against the raw impulse-momentum equations (a)-(d) plus the contact law,
    # solved as one linear system in (w+, v+, U+, Pt, Pn)
    worst_raw = 0.0
    for _ in range(2000):
        blk = SlidingBlock(b=rng.uniform(0.1, 1), h=rng.uniform(0.2, 2), mu=rng.uniform(0.1, 1.5), m=rng.uniform(1, 1e3))
        s = int(rng.choice([-1, 1]))
        wm, vm, Um = -s * rng.uniform(0.01, 3), rng.normal() * 0.5, rng.normal() * 0.3
        mj = rng.uniform(0.05, 20) * blk.m
        res = impact_on_floor(blk, s, wm, vm, Um, mj)
        m, b, h, mu, Ic = blk.m, blk.b, blk.h, blk.mu, blk.m * blk.R ** 2 / 3
        # unknowns z = (w+, v+, U+, Pt, Pn)
        A = np.zeros((5, 5))
        rhs = np.zeros(5)
        A[0] = [m * h, m, m, -1, 0]; rhs[0] = m * (Um + vm + h * wm)          # (a)
        A[1] = [-m * s * b, 0, 0, 0, -1]; rhs[1] = m * s * b * wm               # (b)
        A[2] = [0, 0, mj, 1, 0]; rhs[2] = mj * Um                               # (c)
        if res.flat:
            A[3] = [1, 0, 0, 0, 0]                                              # w+ = 0 (flat)
            A[1] = [0, 0, 0, 0, -1]; rhs[1] = m * s * b * wm                     # Pn = -m s b w-
        else:
            A[3] = [Ic, 0, 0, h, -s * b]; rhs[3] = Ic * wm                      # (d)
        if res.slip_rate_plus == 0.0:
            A[4] = [0, 1, 0, 0, 0]                                              # sticking
        else:
            c = res.Pt / (mu * res.Pn)
            A[4] = [0, 0, 0, 1, -round(c) * mu]                                # sliding: Pt = c mu Pn
        z = np.linalg.solve(A, rhs)
        got = np.array([res.omega_plus, res.slip_rate_plus, res.floor_velocity_plus, res.Pt, res.Pn])
        worst_raw = max(worst_raw, float(np.max(np.abs(z - got) / (1 + np.abs(z)))))
        assert abs(res.Pt) <= mu * res.Pn * (1 + 1e-12) + 1e-15, "friction cone violated"
    out["impact_closed_form_vs_raw_equations"] = worst_raw
    say(f"(0b) impact closed forms vs the raw impulse-momentum equations (2000 random, finite m_j): {worst_raw:.1e}")

    # (i) rigid ground = sliding_reference
    for name, exc, blk in (("record pulse_3hz, cabinet", exc_rec, cab),
                           ("sine 6 m/s2 2 Hz, squat mu=0.3", sine_pulse(6.0, 2.0, 1.0, 0.2), SlidingBlock(0.3, 0.36, 0.3, 100.0)),
                           ("sine 7 m/s2 2.5 Hz, mu=0.6", sine_pulse(7.0, 2.5, 2.0, 0.1), SlidingBlock(0.25, 0.6, 0.6, 50.0))):
        t0 = time.time()
        a = simulate(blk, RigidGround(), exc, 4.0, coupling="two-way")
        ref = sr.simulate(blk, exc, 4.0)
        mine = a.sample(ref.t)
        dth = float(np.max(np.abs(mine["theta"] - ref.theta)))
        dsl = float(np.max(np.abs(mine["slip"] - ref.slip)))
        dti = max([abs(x - y) for x, y in zip(a.impact_times, ref.impact_times)] + [0.0])
        out[f"rigid:{name}"] = dict(impacts=(a.impacts, len(ref.impact_times)), peak=a.peak_abs_theta,
                                    final_slip=(a.final_slip, ref.final_slip), dtheta=dth, dslip=dsl, dimpact_t=dti)
        say(f"(i) rigid ground, {name}: impacts {a.impacts} vs {len(ref.impact_times)} (times within {dti:.1e} s); "
            f"at sliding_reference's {ref.t.size} rows max |dtheta| {dth:.1e} rad, max |dslip| {dsl:.1e} m; "
            f"peak|theta| {a.peak_abs_theta:.12f}; final slip {a.final_slip:.12e} vs {ref.final_slip:.12e}; "
            f"residual {a.relative_residual:.1e}; {time.time() - t0:.1f} s")

    # (i b) random pulses and noisy records on the rigid ground
    rng = np.random.default_rng(7)
    worst, n_imp, n_cases = 0.0, 0, 0
    t0 = time.time()
    for _ in range(16):
        b, h, mu = rng.uniform(0.1, 0.5), rng.uniform(0.3, 1.5), rng.uniform(0.15, 1.2)
        blk = SlidingBlock(b, h, mu, rng.uniform(10, 1000))
        A, f = rng.uniform(0.5, 2.5) * 9.81 * b / h * rng.choice([-1, 1]), rng.uniform(0.8, 4)
        if rng.random() < 0.5:
            exc = sine_pulse(A, f, float(rng.integers(1, 3)), 0.1)
        else:
            tt = np.arange(0, 1.5, 0.005)
            exc = record(tt, A * np.sin(2 * np.pi * f * tt) * np.exp(-tt) + rng.normal(size=tt.size) * 0.3)
        ref = sr.simulate(blk, exc, 3.0)
        a = simulate(blk, RigidGround(), exc, 3.0)
        if a.impacts != len(ref.impact_times) or a.overturned != ref.overturned:
            worst = math.inf
            continue
        keep = ref.t <= a.t[-1]
        mine = a.sample(ref.t[keep])
        worst = max(worst, float(np.max(np.abs(mine["theta"] - ref.theta[keep]))),
                    float(np.max(np.abs(mine["slip"] - ref.slip[keep]))), abs(a.final_slip - ref.final_slip))
        n_imp += a.impacts
        n_cases += 1
    out["rigid_random_worst"] = worst
    say(f"(i) rigid ground, 16 random pulses/records (rock, slide, slide-rock, overturn; {n_imp} impacts): "
        f"theta and slip at sliding_reference's rows within {worst:.1e}; {time.time() - t0:.1f} s")

    # (ii) huge supports: two-way = one-way
    M = 1e12
    wp_ = 2 * math.pi * 2.0
    plat = Platform(M, M * wp_ ** 2, 2 * 0.05 * M * wp_)
    bld = Building([M] * 3, [M * 1250.0] * 3, 0.02, 3)
    for name, sup in (("platform 1e12 kg", plat), ("building 3 x 1e12 kg", bld)):
        one = simulate(cab, sup, exc_rec, 4.0, coupling="one-way")
        two = simulate(cab, sup, exc_rec, 4.0, coupling="two-way")
        dth = float(np.max(np.abs(one.grid_theta - two.grid_theta)))
        dsl = float(np.max(np.abs(one.grid_slip - two.grid_slip)))
        out[f"huge:{name}"] = dict(impacts=(one.impacts, two.impacts), dtheta=dth, dslip=dsl,
                                   peak=(one.peak_abs_theta, two.peak_abs_theta), final=(one.final_slip, two.final_slip))
        say(f"(ii) {name}: impacts one-way {one.impacts}, two-way {two.impacts}; max |dtheta| {dth:.1e} rad, max |dslip| "
            f"{dsl:.1e} m on the grid; peak {one.peak_abs_theta:.10f} / {two.peak_abs_theta:.10f}; "
            f"final slip {one.final_slip:.6e} / {two.final_slip:.6e}")

    # (iii) free platform, tilted block, no excitation: momentum stays 0
    blk_r = SlidingBlock(b=0.3, h=1.0, mu=100.0, m=1000.0)
    t0 = time.time()
    fp = simulate(blk_r, Platform(2000.0), None, 4.0, coupling="two-way", theta0=0.1)
    pscale = blk_r.m * blk_r.R * float(np.max(np.abs(fp.omega)))
    prel = float(np.max(np.abs(fp.momentum))) / pscale
    out["free_platform"] = dict(impacts=fp.impacts, momentum_rel=prel, residual_rel=fp.relative_residual,
                                momentum_max=float(np.max(np.abs(fp.momentum))), scale=pscale)
    say(f"(iii) free platform 2000 kg, theta0 0.1, mu 100: {fp.impacts} impacts, max |P| {np.max(np.abs(fp.momentum)):.2e} N s "
        f"over scale m R max|w| {pscale:.1f} N s = {prel:.1e}; energy residual {fp.relative_residual:.1e}; "
        f"ends in {MODE_NAMES[int(fp.mode[-1])]}; {time.time() - t0:.1f} s")

    # (iv, v) the cabinet scene
    cabinet_bld = Building([2000.0] * 3, [2.5e6] * 3, 0.02, 3)
    for coupling in ("one-way", "two-way"):
        t0 = time.time()
        rr = simulate(cab, cabinet_bld, exc_rec, 4.0, coupling=coupling)
        if coupling == "two-way":
            say(f"      two-way impacts: largest |momentum jump| {max(map(abs, rr.impact_momentum_jump)):.1e} N s, "
                f"energy changes {min(rr.impact_energy_change):.1f} .. {max(rr.impact_energy_change):.1f} J")
        if coupling == "one-way":
            hard = simulate(SlidingBlock(0.3, 1.0, math.inf, 1000.0), cabinet_bld, exc_rec, 4.0, coupling="one-way")
            big = simulate(SlidingBlock(0.3, 1.0, 100.0, 1000.0), cabinet_bld, exc_rec, 4.0, coupling="one-way")
            out["mu_inf_vs_100"] = float(np.max(np.abs(hard.grid_theta - big.grid_theta)))
            say(f"      mu = inf vs mu = 100 (one-way cabinet): impacts {hard.impacts} / {big.impacts}, max |dtheta| "
                f"{out['mu_inf_vs_100']:.1e} rad")
        out[f"cabinet:{coupling}"] = dict(impacts=rr.impacts, peak=rr.peak_abs_theta, final_slip=rr.final_slip,
                                          residual=rr.max_abs_residual, scale=rr.energy_scale, rel=rr.relative_residual,
                                          events=rr.n_events, pieces=rr.pieces, seconds=time.time() - t0,
                                          peak_floor_u=float(np.max(np.abs(rr.grid_floor_u))))
        say(f"(iv,v) cabinet {coupling}: impacts {rr.impacts}, peak|theta| {rr.peak_abs_theta:.12f} rad, final slip "
            f"{rr.final_slip:.12e} m, peak floor u {np.max(np.abs(rr.grid_floor_u)) * 1e3:.3f} mm, residual "
            f"{rr.max_abs_residual:.2e} J of {rr.energy_scale:.1f} J = {rr.relative_residual:.1e}, "
            f"{rr.n_events} events, {rr.pieces} pieces, {time.time() - t0:.1f} s")

    # (vi) chatter: floor 3 of 50 kg
    t0 = time.time()
    light = Building([2000.0, 2000.0, 50.0], [2.5e6] * 3, 0.02, 3)
    try:
        ch = simulate(cab, light, exc_rec, 4.0, coupling="two-way")
        out["chatter"] = dict(impacts=ch.impacts, events=ch.n_events, pieces=ch.pieces, peak=ch.peak_abs_theta,
                              final_slip=ch.final_slip, rel=ch.relative_residual, t_end=float(ch.t[-1]),
                              min_normal=ch.min_normal, seconds=time.time() - t0)
        say(f"(vi) chatter (floor 3 = 50 kg, two-way): reached t = {ch.t[-1]:.6f} s, impacts {ch.impacts}, events {ch.n_events}, "
            f"pieces {ch.pieces}, peak|theta| {ch.peak_abs_theta:.10f}, final slip {ch.final_slip:.6e}, residual "
            f"{ch.max_abs_residual:.2e} of {ch.energy_scale:.1f} J = {ch.relative_residual:.1e}, min N {ch.min_normal:.1f} N, "
            f"{time.time() - t0:.1f} s")
    except SlidingReferenceError as exc:
        out["chatter"] = dict(error=str(exc))
        say(f"(vi) chatter FAILED: {exc}")
    return out


if __name__ == "__main__":
    self_test()
