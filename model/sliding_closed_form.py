"""Closed forms of sliding: a Coulomb block on an accelerating base, and which mode starts from rest.

Written from Newton-Euler for the references of the rocking-sliding model (docs/sliding.md),
independently of the C core. SI units (m, s, m/s^2), the signs of docs/conventions.md: ``x``
to the right, ``a_h > 0`` accelerates the ground towards ``+x``, ``a_v > 0`` upwards (effective
gravity ``G = g + a_v``).

A block that can only slide
---------------------------
``u`` is the slip of the block relative to the ground (m, ``+x``), ``u'`` the slip rate. In the
ground's frame the block feels ``-m a_h`` horizontally and ``m G`` down; the ground pushes up by
``N = m G`` and along by the friction ``T``. While it sticks ``T = m a_h``, possible while
``|a_h| <= mu G``. While it slides with ``sigma = sign(u')``, ``T = -sigma mu N`` and

    u'' = -a_h - sigma mu (g + a_v).

The ground motions here are the FMU's built-in sines (``model/c/ground.c`` and docs/records.md
describe the same waveforms): ``a_h = ah0 + A s(t)``, ``a_v = av0 + V s(t)`` with
``s(t) = sin(Omega (t - t0))`` on the excitation's window ``[t0, t_end)`` and 0 outside it,
``Omega = 2 pi f``. ``ah0``, ``av0`` are constant accelerations (the FMU's inputs ``ground.ah``,
``ground.av``). A sine pulse has ``A`` the amplitude; a harmonic table motion of displacement
``D sin(Omega (t - t0))`` has ``A = -D Omega^2`` (its vertical acceleration has the same shape,
``-verticalAmplitude sin(...)``). On each piece of a sliding phase that starts at ``t1`` with
``u1``, ``v1`` (``phi = Omega (t - t0)``, ``c = ah0 + sigma mu (g + av0)``, ``k = A + sigma mu V``):

    u'(t) = v1 - c (t - t1) + (k / Omega) [cos(phi) - cos(phi1)]
    u(t)  = u1 + (v1 - (k / Omega) cos(phi1)) (t - t1) - c (t - t1)^2 / 2 + (k / Omega^2) [sin(phi) - sin(phi1)]

A phase ends where ``u'`` returns to zero: the first root after ``t1``, bracketed between the
closed-form extrema of ``u'`` (where ``u'' = 0``: ``sin(phi) = -c / k``) so that no root is
missed, and polished by Brent's method to full double precision. The block then sticks if
``|a_h| <= mu G`` there, else the slide reverses. Sticking ends where ``+-a_h - mu G`` crosses
zero upwards: ``(+-ah0 - mu (g + av0)) + (+-A - mu V) sin(phi) = 0``, solved by ``asin``; from
rest under a sine pulse that is ``t0 + asin(mu g / A) / (2 pi f)``.

Which mode starts from rest (Ishiyama 1982; Shenton 1996)
--------------------------------------------------------
A block at rest, suddenly loaded by constant ``a_h``, ``a_v`` (``G > 0``), half width ``b``,
half height ``h``, ``beta = b / h``, ``lambda = |a_h| / G``:

- rest while ``lambda <= min(mu, beta)``: the ground then carries ``T = m a_h``, ``N = m G``,
  whose resultant sits ``h |a_h| / G`` from the centre of the base (inside it while
  ``lambda <= beta``);
- slide if ``mu <= beta`` and ``lambda > mu``: the flat slide keeps the normal resultant at
  ``mu h <= b`` from the centre, so it cannot tip (Ishiyama 1982);
- if ``mu > beta`` and ``lambda > beta``: rocking on the corner the load tips it to, with the
  pivot sticking, needs the friction ratio (:func:`rocking_onset_demand`)

      |T| / N = ((4 beta^2 + 1) lambda + 3 beta) / ((beta^2 + 4) + 3 beta lambda),

  which equals ``beta`` at ``lambda = beta`` and grows with ``lambda`` towards
  ``(4 beta^2 + 1) / (3 beta)``. Rock if it is at most ``mu`` (Ishiyama 1982 stops at
  ``mu > beta``), else slide-rock (Shenton 1996).

Derivation of the demand: rocking about the left corner (``a_h > 0``), the centre is at
``(b, h)`` from the pivot; the moment about the pivot of ``-m a_h`` and ``-m G`` gives the
counter-clockwise angular acceleration ``psi'' = m (h a_h - b G) / I0``, ``I0 = 4/3 m R^2``. At
``omega = 0`` the centre accelerates by ``psi'' (-h, b)``, so ``T = m a_h - m h psi''`` and
``N = m G + m b psi''``; the ratio above follows with ``R^2 = b^2 + h^2``.

Flight, and the mode after a landing (Shenton & Jones 1991; Taniguchi 2002)
--------------------------------------------------------------------------
With ``G <= 0`` the block flies (:func:`initiation_mode` answers ``Mode.FLIGHT``); no load with
``G > 0`` makes it fly. Where ``G < 0`` and ``mu > mu_P = (4 beta^2 + 1) / (3 beta)`` friction can also
jam a corner into the ground (:func:`initiation_modes`, :func:`jam_ratio`). A plastic landing with
Coulomb friction is the same complementarity problem at the impulse level, with the landing velocity
``(vx, vy)`` in place of ``(-a_h, -G)``: a flat landing has the separatrices above with
``lambda -> r = |vx| / |vy|`` (:func:`flat_landing`); a landing on one corner sticks or slides by the
thresholds of :func:`corner_landing_thresholds`. Derivations: docs/flight.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Iterator

import numpy as np
from scipy.optimize import brentq

G_DEFAULT = 9.81  # m/s^2, the FMU's default g


# ----------------------------------------------------------------------------- ground motions


@dataclass(frozen=True)
class SineGround:
    """``a_h(t) = ah0 + A s(t)``, ``a_v(t) = av0 + V s(t)`` (m/s^2), ``s(t) = sin(2 pi f (t - t0))``
    on ``[t0, t_end)`` and 0 outside it (``t_end = inf``: endless)."""

    amplitude: float  # A, m/s^2 (signed)
    frequency: float  # f, Hz
    t0: float = 0.0  # s
    t_end: float = math.inf  # s
    vertical: float = 0.0  # V, m/s^2 (signed)
    ah0: float = 0.0  # m/s^2
    av0: float = 0.0  # m/s^2

    @property
    def omega(self) -> float:
        """Circular frequency 2 pi f (rad/s)."""
        return 2.0 * math.pi * self.frequency

    def s(self, t: float) -> float:
        """The waveform of unit amplitude at ``t`` (0 outside the window)."""
        return math.sin(self.omega * (t - self.t0)) if self.t0 <= t < self.t_end else 0.0

    def __call__(self, t: float) -> tuple[float, float]:
        """``(a_h, a_v)`` at ``t`` (m/s^2)."""
        w = self.s(t)
        return self.ah0 + self.amplitude * w, self.av0 + self.vertical * w

    def breaks(self) -> tuple[float, ...]:
        """Times where the expression of the motion changes (the window's ends)."""
        return tuple(x for x in (self.t0, self.t_end) if math.isfinite(x))


def sine_pulse(amplitude: float, frequency: float, cycles: float = 1.0, t0: float = 0.0,
               vertical: float = 0.0, ah0: float = 0.0, av0: float = 0.0) -> SineGround:
    """The FMU's sine pulse (excitation.kind 1): ``A sin(2 pi f (t - t0))`` for ``cycles / f`` s,
    vertical ``V sin(...)`` (excitation.verticalAmplitude), plus the constant inputs."""
    return SineGround(amplitude, frequency, t0, t0 + cycles / frequency, vertical, ah0, av0)


def harmonic(displacement: float, frequency: float, cycles: float = 0.0, t0: float = 0.0,
             vertical: float = 0.0, ah0: float = 0.0, av0: float = 0.0) -> SineGround:
    """The FMU's harmonic table motion (excitation.kind 3): table displacement
    ``D sin(2 pi f (t - t0))`` from ``t0`` (no ramp), so ``a_h = -D (2 pi f)^2 sin(...)``, and
    ``a_v = -V sin(...)`` with ``V`` the excitation.verticalAmplitude; ``cycles = 0``: endless."""
    w = 2.0 * math.pi * frequency
    t_end = math.inf if cycles == 0 else t0 + cycles / frequency
    return SineGround(-displacement * w * w, frequency, t0, t_end, -vertical, ah0, av0)


def constant(ah: float, av: float = 0.0) -> SineGround:
    """Constant accelerations from the start (the FMU's inputs ground.ah, ground.av, excitation.kind 0)."""
    return SineGround(0.0, 1.0, 0.0, 0.0, 0.0, ah, av)  # an empty window


# ----------------------------------------------------------------------------- the sliding block

STICK = 0


@dataclass(frozen=True)
class Phase:
    """One phase on one piece of the ground motion: the block sticks (``sigma = 0``) or slides with
    ``sigma = sign(u')``; ``u'' = -c - k sin(Omega (t - t0))`` on ``[t_start, t_end]``."""

    t_start: float
    t_end: float
    u0: float  # slip at t_start, m
    v0: float  # slip rate at t_start, m/s
    sigma: int
    c: float = 0.0  # m/s^2
    k: float = 0.0  # m/s^2
    omega: float = 1.0  # rad/s
    t_ref: float = 0.0  # the waveform's t0, s

    def rate(self, t: float) -> float:
        """Slip rate u'(t) (m/s), closed form."""
        if self.sigma == STICK:
            return 0.0
        tau = t - self.t_start
        p1, half = self.omega * (self.t_start - self.t_ref), 0.5 * self.omega * tau
        dcos = -2.0 * math.sin(p1 + half) * math.sin(half)  # cos(phi) - cos(phi1)
        return self.v0 - self.c * tau + self.k / self.omega * dcos

    def slip(self, t: float) -> float:
        """Slip u(t) (m), closed form."""
        if self.sigma == STICK:
            return self.u0
        tau = t - self.t_start
        p1, half = self.omega * (self.t_start - self.t_ref), 0.5 * self.omega * tau
        dsin = 2.0 * math.cos(p1 + half) * math.sin(half)  # sin(phi) - sin(phi1)
        return (self.u0 + (self.v0 - self.k / self.omega * math.cos(p1)) * tau - 0.5 * self.c * tau * tau
                + self.k / self.omega ** 2 * dsin)


@dataclass(frozen=True)
class Switch:
    """A mode switch: ``slide`` (stick to slip, ``sigma`` the sign of the slip rate that starts),
    ``stick`` (slip to stick) or ``reverse`` (the slip rate passes zero and the slide goes on the
    other way, ``sigma`` the new sign)."""

    kind: str
    t: float  # s
    sigma: int


@dataclass
class SlidingSolution:
    """The piecewise closed-form motion of a Coulomb block on ``[t_start, t_stop]``."""

    phases: list[Phase]
    switches: list[Switch]
    t_start: float
    t_stop: float
    _ends: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._ends = np.array([p.t_end for p in self.phases])

    def phase_at(self, t: float) -> Phase:
        """The phase that holds at ``t`` (s); at a switch, the one that ends there."""
        if not self.t_start <= t <= self.t_stop:
            raise ValueError(f"t = {t} is outside the solution's span [{self.t_start}, {self.t_stop}]")
        i = int(np.searchsorted(self._ends, t, side="left"))
        return self.phases[min(i, len(self.phases) - 1)]

    def slip(self, t: float | np.ndarray) -> float | np.ndarray:
        """Slip u (m) at ``t`` (s): a float or an array like ``t``."""
        if np.ndim(t) == 0:
            return self.phase_at(float(t)).slip(float(t))
        return np.array([self.phase_at(float(x)).slip(float(x)) for x in np.asarray(t, dtype=float)])

    def slip_rate(self, t: float | np.ndarray) -> float | np.ndarray:
        """Slip rate u' (m/s) at ``t`` (s)."""
        if np.ndim(t) == 0:
            return self.phase_at(float(t)).rate(float(t))
        return np.array([self.phase_at(float(x)).rate(float(x)) for x in np.asarray(t, dtype=float)])

    def times(self, kind: str) -> list[float]:
        """Times (s) of the switches of one kind."""
        return [s.t for s in self.switches if s.kind == kind]

    @property
    def first_slide_time(self) -> float:
        """First stick-to-slip time (s), -1 if it never slides."""
        slides = self.times("slide")
        return slides[0] if slides else -1.0

    @property
    def slide_duration(self) -> float:
        """Time spent sliding (s)."""
        return sum(p.t_end - p.t_start for p in self.phases if p.sigma != STICK)

    @property
    def max_abs_slip(self) -> float:
        """Largest |u| (m): u is monotone within a sliding phase, so it is at a phase's end."""
        return max([abs(self.phases[0].u0)] + [abs(p.slip(p.t_end)) for p in self.phases])

    @property
    def residual_slip(self) -> float:
        """u at t_stop (m)."""
        return self.phases[-1].slip(self.t_stop)


def _pieces(ground: SineGround, t_start: float, t_stop: float) -> list[tuple[float, float, bool]]:
    """The intervals between the motion's breaks, clipped to [t_start, t_stop], each with
    whether the sine is on there."""
    cuts = sorted({t_start, t_stop, *[x for x in ground.breaks() if t_start < x < t_stop]})
    return [(a, b, ground.t0 <= a < ground.t_end) for a, b in zip(cuts[:-1], cuts[1:])]


def _upward_crossing(alpha: float, beta: float, omega: float, t_ref: float, t_from: float) -> float:
    """First t >= t_from where alpha + beta sin(omega (t - t_ref)) crosses 0 upwards (inf if never;
    t_from itself if it is already positive there)."""
    phi_from = omega * (t_from - t_ref)
    if alpha + beta * math.sin(phi_from) > 0.0:
        return t_from
    if beta == 0.0 or abs(alpha) > abs(beta):
        return math.inf
    a = math.asin(-alpha / beta)
    root = a if beta > 0 else math.pi - a  # where beta cos(phi) > 0
    n = math.ceil((phi_from - root) / (2.0 * math.pi))
    phi = root + 2.0 * math.pi * n
    if phi < phi_from:
        phi += 2.0 * math.pi
    return t_ref + phi / omega


def _critical_times(c: float, k: float, omega: float, t_ref: float, t_from: float, t_to: float
                    ) -> Iterator[float]:
    """The times in (t_from, t_to) where -c - k sin(omega (t - t_ref)) = 0 (the extrema of the
    slip rate), in order; the slip rate is monotone between consecutive ones."""
    if k == 0.0 or abs(c) >= abs(k):
        return
    a = math.asin(-c / k)
    period = 2.0 * math.pi
    phi_from = omega * (t_from - t_ref)
    n = math.floor((phi_from - math.pi) / period) - 1
    skip = 1e-9 * period  # a root at t_from itself (a slide that starts where u'' = 0) is not a bracket end
    while True:
        for root in sorted((a + period * n, math.pi - a + period * n)):
            if root > phi_from + skip:
                t = t_ref + root / omega
                if t >= t_to:
                    return
                yield t
        n += 1


def coulomb_block(ground: SineGround, mu: float, t_stop: float, g: float = G_DEFAULT,
                  t_start: float = 0.0, slip0: float = 0.0) -> SlidingSolution:
    """The exact motion of a block that can only slide, at rest at ``t_start`` with slip ``slip0``
    (m), under ``ground`` with Coulomb friction ``mu`` (static = kinetic) and gravity ``g``.

    ValueError for mu <= 0, g <= 0, or a vertical motion that reaches ``G = g + a_v <= 0``
    (the block would leave the ground)."""
    if not (math.isfinite(mu) and mu > 0):
        raise ValueError(f"mu = {mu} must be a finite number > 0")
    if not (math.isfinite(g) and g > 0):
        raise ValueError(f"g = {g} must be > 0")
    if not (math.isfinite(t_stop) and t_stop > t_start):
        raise ValueError(f"t_stop = {t_stop} must be finite and after t_start = {t_start}")
    low = g + ground.av0 - (abs(ground.vertical) if ground.t0 < t_stop and ground.t_end > t_start else 0.0)
    if not low > 0:
        raise ValueError(f"g + a_v reaches {low} m/s2 <= 0: the block would leave the ground")

    phases: list[Phase] = []
    switches: list[Switch] = []
    u, v, sigma = float(slip0), 0.0, STICK
    w = ground.omega
    for a, b, on in _pieces(ground, t_start, t_stop):
        A, V = (ground.amplitude, ground.vertical) if on else (0.0, 0.0)
        t = a
        while t < b:
            if sigma == STICK:
                # +a_h - mu G and -a_h - mu G: the first to cross zero upwards ends the stick
                up = _upward_crossing(ground.ah0 - mu * (g + ground.av0), A - mu * V, w, ground.t0, t)
                down = _upward_crossing(-ground.ah0 - mu * (g + ground.av0), -A - mu * V, w, ground.t0, t)
                t1 = min(up, down)
                if t1 >= b:
                    phases.append(Phase(t, b, u, 0.0, STICK))
                    t = b
                    continue
                if t1 > t:
                    phases.append(Phase(t, t1, u, 0.0, STICK))
                sigma = -1 if up <= down else 1  # a_h > mu G drags the ground away towards +x: slip to -x
                switches.append(Switch("slide", t1, sigma))
                t, v = t1, 0.0
                continue
            c = ground.ah0 + sigma * mu * (g + ground.av0)
            k = A + sigma * mu * V
            phase = Phase(t, b, u, v, sigma, c, k, w, ground.t0)
            end = _slip_rate_zero(phase, b)
            if end is None:
                phases.append(phase)
                u, v, t = phase.slip(b), phase.rate(b), b
                continue
            if not end > t:  # cannot happen for a slide that has started; never loop on it
                raise RuntimeError(f"a sliding phase from t = {t} s ends where it starts")
            phase = Phase(t, end, u, v, sigma, c, k, w, ground.t0)
            phases.append(phase)
            u, v, t = phase.slip(end), 0.0, end
            ah = ground.ah0 + A * math.sin(w * (end - ground.t0))
            av = ground.av0 + V * math.sin(w * (end - ground.t0))
            if abs(ah) <= mu * (g + av):
                sigma = STICK
                switches.append(Switch("stick", end, STICK))
            else:
                sigma = -sigma
                switches.append(Switch("reverse", end, sigma))
    return SlidingSolution(phases, switches, t_start, t_stop)


def _slip_rate_zero(phase: Phase, t_to: float) -> float | None:
    """The first time in (t_start, t_to) where the phase's slip rate returns to zero, or None."""
    s = phase.sigma
    edges = [*_critical_times(phase.c, phase.k, phase.omega, phase.t_ref, phase.t_start, t_to), t_to]
    lo = phase.t_start
    for hi in edges:
        rate_hi = s * phase.rate(hi)
        if rate_hi <= 0.0:
            if rate_hi == 0.0 and hi < t_to:
                return hi
            if s * phase.rate(lo) <= 0.0:  # the slide has just started here: look just inside
                return _bracketed(phase, lo, hi)
            return brentq(phase.rate, lo, hi, xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=400)
        lo = hi
    return None


def _bracketed(phase: Phase, lo: float, hi: float) -> float | None:
    """A root of the rate in (lo, hi] where the rate is 0 at lo too (the slide starts at lo, with
    u'' = 0 there): bisect for an inner point where the rate has the slide's sign first."""
    s = phase.sigma
    a, b = lo, hi
    for _ in range(200):
        mid = 0.5 * (a + b)
        if s * phase.rate(mid) > 0.0:
            return brentq(phase.rate, mid, hi, xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=400)
        b = mid
        if b - lo <= 4.0 * np.finfo(float).eps * max(abs(lo), 1.0):
            break
    return None


# ----------------------------------------------------------------------------- initiation from rest


class Mode(IntEnum):
    """The FMU's block1.mode (Enumeration ContactMode): 0 to 4, and ``FLIGHT`` (6): no contact
    carries a force (5 is the FMU's "fell off", a stack's block 2 only)."""

    REST = 0
    SLIDE = 1
    ROCK = 2
    SLIDE_ROCK = 3
    OVERTURNED = 4
    FLIGHT = 6


def _check_block(mu: float, b_over_h: float) -> None:
    """ValueError unless mu and b / h are finite numbers > 0."""
    for name, x in (("mu", mu), ("b_over_h", b_over_h)):
        if not (math.isfinite(x) and x > 0):
            raise ValueError(f"{name} = {x} must be a finite number > 0")


def _check_load(ah_over_g: float, av_over_g: float) -> None:
    """ValueError unless a_h / g and a_v / g are finite."""
    if not (math.isfinite(ah_over_g) and math.isfinite(av_over_g)):
        raise ValueError(f"a_h / g = {ah_over_g} and a_v / g = {av_over_g} must be finite")


def _check(mu: float, b_over_h: float, ah_over_g: float, av_over_g: float) -> float:
    """lambda = |a_h| / (g + a_v); ValueError for a bad argument or flight (g + a_v <= 0)."""
    _check_block(mu, b_over_h)
    _check_load(ah_over_g, av_over_g)
    if not 1.0 + av_over_g > 0:
        raise ValueError(f"a_v / g = {av_over_g}: the ground falls faster than gravity, the block would fly")
    return abs(ah_over_g) / (1.0 + av_over_g)


def _demand(beta: float, lam: float) -> float:
    """((4 beta^2 + 1) lam + 3 beta) / ((beta^2 + 4) + 3 beta lam): the friction ratio a corner needs
    to stick as the block tips onto it (the same form at the acceleration and at the impulse level)."""
    return ((4 * beta * beta + 1) * lam + 3 * beta) / ((beta * beta + 4) + 3 * beta * lam)


def rocking_onset_demand(b_over_h: float, ah_over_g: float, av_over_g: float = 0.0) -> float:
    """Friction ratio |T| / N (1) that rocking needs at its first instant from rest (omega = 0, the
    pivot sticking), on the corner the load tips the block to: ((4 beta^2 + 1) lambda + 3 beta) /
    ((beta^2 + 4) + 3 beta lambda), beta = b / h, lambda = |a_h| / (g + a_v). Meaningful where
    lambda > beta (rocking starts)."""
    lam = _check(1.0, b_over_h, ah_over_g, av_over_g)
    return _demand(b_over_h, lam)


def rock_friction_limit(b_over_h: float, ah_over_g: float, av_over_g: float = 0.0) -> float:
    """Shenton's (1996) boundary between slide-rock and rock: the smallest mu (1) with which a
    block of ``b / h`` starts to rock without sliding under a_h, a_v (above the uplift threshold
    lambda > beta); below it (and above b / h) it starts to slide-rock."""
    return rocking_onset_demand(b_over_h, ah_over_g, av_over_g)


def rest_limit(mu: float, b_over_h: float) -> float:
    """The largest |a_h| / (g + a_v) that leaves the block at rest: min(mu, b / h) (Ishiyama 1982)."""
    _check(mu, b_over_h, 0.0, 0.0)
    return min(mu, b_over_h)


def painleve_friction(b_over_h: float) -> float:
    """mu_P = (4 beta^2 + 1) / (3 beta) (1), beta = b / h: the friction coefficient above which a corner
    sliding outwards would need a negative normal force (the denominator 4 b^2 + h^2 - 3 mu b h of
    slide-rock changes sign). It is the limit of the rocking demand as lambda -> inf, and at least 4/3
    (at beta = 1/2). With mu > mu_P no block slide-rocks from rest under G > 0, and under G < 0 a
    block may jam on a corner instead of flying (:func:`initiation_modes`)."""
    _check_block(1.0, b_over_h)
    return (4 * b_over_h * b_over_h + 1) / (3 * b_over_h)


def slide_rock_ratio(mu: float, b_over_h: float) -> float:
    """The ratio (1) above which a block with b / h < mu < mu_P slide-rocks rather than rocks:
    r_sr = (mu (beta^2 + 4) - 3 beta) / (4 beta^2 + 1 - 3 mu beta), the inverse of the rocking demand
    (lambda = |a_h| / G at initiation, r = |vx| / |vy| at a flat landing); inf for mu >= mu_P
    (:func:`painleve_friction`). For mu <= b / h it is not a boundary (the block slides flat)."""
    _check_block(mu, b_over_h)
    beta = b_over_h
    den = 4 * beta * beta + 1 - 3 * mu * beta
    return (mu * (beta * beta + 4) - 3 * beta) / den if den > 0 else math.inf


def _flat_contact_mode(mu: float, beta: float, lam: float) -> Mode:
    """The one consistent mode of a flat block whose base is pressed (G > 0, or vy < 0 at a landing)
    with the ratio lam of the tangential to the normal drive: rest, slide, rock or slide-rock."""
    if lam <= min(mu, beta):
        return Mode.REST
    if mu <= beta:
        return Mode.SLIDE
    return Mode.ROCK if _demand(beta, lam) <= mu else Mode.SLIDE_ROCK


def _flat_contact_margin(mu: float, beta: float, lam: float) -> float:
    """Distance of (mu, beta, lam) from the nearest boundary of :func:`_flat_contact_mode` that concerns it."""
    margins = [abs(lam - min(mu, beta))]
    if lam > min(mu, beta):
        margins.append(abs(mu - beta))
        if mu > beta:
            margins.append(abs(mu - _demand(beta, lam)))
    return min(margins)


def initiation_mode(mu: float, b_over_h: float, ah_over_g: float, av_over_g: float = 0.0) -> Mode:
    """The mode a block at rest takes under suddenly applied constant a_h, a_v (in units of g).

    With G = g + a_v > 0: REST if |a_h| <= min(mu, b/h) (g + a_v); else SLIDE if mu <= b/h (Ishiyama
    1982); else ROCK if rocking's onset demand is <= mu, SLIDE_ROCK otherwise (Shenton 1996). No load
    with G > 0 makes the block fly: every pressing mode has N > 0 at its first instant.

    With G <= 0 (a_v <= -g, the ground falls at least as fast as gravity): FLIGHT (Shenton & Jones
    1991; Taniguchi 2002). At G = 0 the flight carries no force and the block grazes the ground
    (relative acceleration (-a_h, 0)). Where mu > mu_P the contact problem also admits a block jammed
    on a corner (:func:`initiation_modes`); this function still answers FLIGHT there."""
    _check_block(mu, b_over_h)
    _check_load(ah_over_g, av_over_g)
    if not 1.0 + av_over_g > 0:
        return Mode.FLIGHT
    return _flat_contact_mode(mu, b_over_h, abs(ah_over_g) / (1.0 + av_over_g))


def jam_ratio(mu: float, b_over_h: float) -> float:
    """For G < 0 and mu > mu_P: the ratio kappa = |a_h| / |G| (1) above which a block at rest may also
    rock (pivot sticking, N > 0) or slide-rock (pivot sliding outwards) instead of flying,
    K = (mu (beta^2 + 4) - 3 beta) / (3 mu beta - 4 beta^2 - 1); inf for mu <= mu_P."""
    _check_block(mu, b_over_h)
    beta = b_over_h
    den = 3 * mu * beta - 4 * beta * beta - 1
    return (mu * (beta * beta + 4) - 3 * beta) / den if den > 0 else math.inf


def initiation_modes(mu: float, b_over_h: float, ah_over_g: float, av_over_g: float = 0.0) -> frozenset[Mode]:
    """Every mode consistent with Newton-Euler, unilateral contact and Coulomb's law at the first
    instant from rest (the closed form of the acceleration-level complementarity problem).

    - G > 0: the one mode of :func:`initiation_mode`.
    - G < 0, kappa = |a_h| / |G|: FLIGHT; with mu > mu_P (:func:`painleve_friction`) and kappa > K
      (:func:`jam_ratio`) also ROCK and SLIDE_ROCK on the corner the load pushes the block to
      (Painleve-like non-uniqueness: friction jams the corner into the ground; ROCK holds already at
      kappa = K).
    - G = 0: FLIGHT (grazing, no force); with mu >= mu_P and a_h != 0 also ROCK (the G -> 0+ limit)."""
    mode = initiation_mode(mu, b_over_h, ah_over_g, av_over_g)
    big_g = 1.0 + av_over_g
    if big_g > 0:
        return frozenset({mode})
    modes = {Mode.FLIGHT}
    if big_g == 0:
        if ah_over_g != 0 and mu >= painleve_friction(b_over_h):
            modes.add(Mode.ROCK)
        return frozenset(modes)
    if mu > painleve_friction(b_over_h):
        kappa, k = abs(ah_over_g) / -big_g, jam_ratio(mu, b_over_h)
        if kappa >= k:
            modes.add(Mode.ROCK)
        if kappa > k:
            modes.add(Mode.SLIDE_ROCK)
    return frozenset(modes)


def initiation_margin(mu: float, b_over_h: float, ah_over_g: float, av_over_g: float = 0.0) -> float:
    """Distance (1) of a point from the nearest boundary of :func:`initiation_mode` that concerns it,
    in the ratios compared: lambda against min(mu, b/h), mu against b/h, mu against the demand, and
    1 + a_v / g (the flight boundary G = 0). For G < 0 also the boundaries of the non-unique region
    of :func:`initiation_modes`: mu against mu_P and, above it, kappa against K. Small values flag
    grid points that a tolerance could put on either side."""
    _check_block(mu, b_over_h)
    _check_load(ah_over_g, av_over_g)
    big_g = 1.0 + av_over_g
    if big_g > 0:
        return min(big_g, _flat_contact_margin(mu, b_over_h, abs(ah_over_g) / big_g))
    margins = [abs(big_g), abs(mu - painleve_friction(b_over_h))]
    if big_g < 0 and mu > painleve_friction(b_over_h):
        margins.append(abs(abs(ah_over_g) / -big_g - jam_ratio(mu, b_over_h)))
    return min(margins)


# ----------------------------------------------------------------------------- landing from flight


@dataclass(frozen=True)
class Landing:
    """What a plastic impact with Coulomb friction leaves of a block landing from flight. Velocities
    are relative to the ground (m/s, ``+x`` right, ``+y`` up), impulses per unit mass (m/s).

    ``side``: the corner the block turns about after the impact (+1 right, -1 left), 0 if it lies flat.
    ``omega``: angular velocity after (rad/s, clockwise positive as ``theta``, docs/conventions.md).
    ``slip_rate``: the contact's tangential velocity after (m/s; the base's or the pivot corner's).
    ``p_t``: the ground's tangential impulse (``+x``), ``p_n`` its total normal impulse (>= 0)."""

    mode: Mode
    side: int
    vx: float
    vy: float
    omega: float
    slip_rate: float
    p_t: float
    p_n: float

    def kinetic_energy(self, b: float, h: float) -> float:
        """Kinetic energy per unit mass after the impact (J/kg): 1/2 |V|^2 + 1/2 Ic omega^2, Ic = R^2 / 3."""
        return 0.5 * (self.vx ** 2 + self.vy ** 2) + 0.5 * (b * b + h * h) / 3.0 * self.omega ** 2


def _check_landing(vx: float, vy: float) -> None:
    """ValueError unless the landing velocity is finite and downwards (vy < 0)."""
    if not (math.isfinite(vx) and math.isfinite(vy)):
        raise ValueError(f"vx = {vx}, vy = {vy} must be finite")
    if not vy < 0:
        raise ValueError(f"vy = {vy} m/s: a landing needs the block to move down (vy < 0)")


def flat_landing_mode(mu: float, b_over_h: float, vx: float, vy: float) -> Mode:
    """The mode after a flat landing (theta = 0, omega = 0) with centre velocity (vx, vy < 0) relative
    to the ground (m/s), plastic impact with Coulomb friction. With r = |vx| / |vy|, beta = b / h:
    REST if r <= min(mu, beta); else SLIDE if mu <= beta; else ROCK if mu >= mu_rock(r) =
    ((4 beta^2 + 1) r + 3 beta) / ((beta^2 + 4) + 3 beta r), else SLIDE_ROCK. The block tips onto the
    corner it moves towards (sign(vx)). The same separatrices as initiation with lambda -> r."""
    _check_block(mu, b_over_h)
    _check_landing(vx, vy)
    return _flat_contact_mode(mu, b_over_h, abs(vx) / -vy)


def landing_margin(mu: float, b_over_h: float, vx: float, vy: float) -> float:
    """Distance (1) of a flat landing from the nearest separatrix of :func:`flat_landing_mode` that
    concerns it: r against min(mu, b/h), mu against b/h, mu against mu_rock(r)."""
    _check_block(mu, b_over_h)
    _check_landing(vx, vy)
    return _flat_contact_margin(mu, b_over_h, abs(vx) / -vy)


def flat_landing(mu: float, b: float, h: float, vx: float, vy: float) -> Landing:
    """The flat landing of :func:`flat_landing_mode` with its post-impact motion, half width ``b`` and
    half height ``h`` (m), centre velocity (vx, vy < 0) (m/s) relative to the ground before.
    ``c = sign(vx)``, ``R^2 = b^2 + h^2``:

    - REST: everything 0; p_t = -vx, p_n = |vy|.
    - SLIDE: vx+ = vx - c mu |vy|, vy+ = omega+ = 0; p_t = -c mu |vy|, p_n = |vy|.
    - ROCK (about corner c, angular momentum about it conserved):
      omega+ = 3 c (h |vx| - b |vy|) / (4 R^2), vx+ = h omega+, vy+ = c b omega+,
      p_n = (|vy| (b^2 + 4 h^2) + 3 b h |vx|) / (4 R^2).
    - SLIDE_ROCK (corner c slides outwards, p_t = -c mu p_n):
      p_n = |vy| R^2 / (4 b^2 + h^2 - 3 mu b h), omega+ = 3 c |vy| (mu h - b) / (4 b^2 + h^2 - 3 mu b h),
      vx+ = vx - c mu p_n, vy+ = c b omega+, slip rate vx+ - h omega+ (sign c)."""
    _check_block(mu, b / h if h > 0 else -1.0)
    mode = flat_landing_mode(mu, b / h, vx, vy)
    c = 1 if vx > 0 else -1
    ax, ay, r2 = abs(vx), -vy, b * b + h * h
    if mode == Mode.REST:
        return Landing(mode, 0, 0.0, 0.0, 0.0, 0.0, -vx, ay)
    if mode == Mode.SLIDE:
        vxp = vx - c * mu * ay
        return Landing(mode, 0, vxp, 0.0, 0.0, vxp, -c * mu * ay, ay)
    if mode == Mode.ROCK:
        w = 3.0 * c * (h * ax - b * ay) / (4.0 * r2)
        pn = (ay * (b * b + 4 * h * h) + 3 * b * h * ax) / (4.0 * r2)
        return Landing(mode, c, h * w, c * b * w, w, 0.0, h * w - vx, pn)
    den = 4 * b * b + h * h - 3 * mu * b * h
    pn = ay * r2 / den
    w = 3.0 * c * ay * (mu * h - b) / den
    vxp = vx - c * mu * pn
    return Landing(mode, c, vxp, c * b * w, w, vxp - h * w, -c * mu * pn, pn)


def _corner_geometry(b: float, h: float, theta: float) -> tuple[int, float, float]:
    """The lower corner ``c = sign(theta)`` of a block turned by ``theta`` (clockwise) and its position
    (rx, ry) from the centre (m)."""
    c = 1 if theta > 0 else -1
    ct, st = math.cos(theta), math.sin(theta)
    return c, c * b * ct - h * st, -c * b * st - h * ct


def corner_landing_thresholds(mu: float, b: float, h: float, theta: float) -> tuple[float, float]:
    """The separatrices (t_minus, t_plus) (1) of a corner landing in rho = wt / |wn|, the landing corner's
    tangential over normal velocity before the impact: it sticks (ROCK) for t_minus <= rho <= t_plus,
    slides towards +x (SLIDE_ROCK) above t_plus and towards -x below t_minus.

    With the corner at (rx, ry) from the centre and Ic = R^2 / 3, the Delassus matrix (velocity change of
    the corner per unit impulse, unit mass) is W11 = 1 + ry^2 / Ic, W22 = 1 + rx^2 / Ic,
    W12 = -rx ry / Ic (det W = 4), and
    t_plus = (mu W11 - W12) / (W22 - mu W12), t_minus = -(mu W11 + W12) / (W22 + mu W12);
    a denominator <= 0 (mu >= W22 / |W12|, the impulse analogue of mu_P) makes that threshold infinite.
    At theta -> 0 with q = c rho: -(mu (beta^2 + 4) + 3 beta) / (4 beta^2 + 1 + 3 mu beta) <= q <=
    (mu (beta^2 + 4) - 3 beta) / (4 beta^2 + 1 - 3 mu beta)."""
    _, rx, ry = _corner_geometry(b, h, theta)
    ic = (b * b + h * h) / 3.0
    w11, w22, w12 = 1 + ry * ry / ic, 1 + rx * rx / ic, -rx * ry / ic
    dp, dm = w22 - mu * w12, w22 + mu * w12
    t_plus = (mu * w11 - w12) / dp if dp > 0 else math.inf
    t_minus = -(mu * w11 + w12) / dm if dm > 0 else -math.inf
    return t_minus, t_plus


def corner_landing(mu: float, b: float, h: float, theta: float, omega: float, vx: float, vy: float) -> Landing:
    """A block flying at angle ``theta`` (rad, clockwise positive, theta != 0, |theta| < pi/2) with angular
    velocity ``omega`` (rad/s, clockwise) and centre velocity (vx, vy) (m/s, relative to the ground) lands
    on its lower corner c = sign(theta), which must be moving down. Plastic impact, Coulomb friction on
    the impulses. The corner's velocity before is (wt, wn) = (vx + omega ry, vy - omega rx); with
    rho = wt / |wn| and (t_minus, t_plus) of :func:`corner_landing_thresholds`:

    - ROCK (corner sticks, angular momentum about it conserved): (p_t, p_n) = -W^-1 (wt, wn);
    - SLIDE_ROCK with s = sign(rho - t_plus) outside the interval: p_t = -s mu p_n,
      p_n = |wn| / (W22 - s mu W12), and the corner's slip rate after wt + (W12 - s mu W11) p_n.

    After it: V+ = V + (p_t, p_n), omega+ = omega - (rx p_n - ry p_t) / Ic. A rotation that lowers the
    other corner (c omega+ < 0) brings the block flat soon after (the rocking impact of docs/sliding.md)."""
    if not (math.isfinite(theta) and theta != 0 and abs(theta) < math.pi / 2):
        raise ValueError(f"theta = {theta} must be nonzero with |theta| < pi/2 (a flat landing: flat_landing)")
    _check_block(mu, b / h if h > 0 and b > 0 else -1.0)
    c, rx, ry = _corner_geometry(b, h, theta)
    ic = (b * b + h * h) / 3.0
    wt, wn = vx + omega * ry, vy - omega * rx
    if not (math.isfinite(wt) and wn < 0):
        raise ValueError(f"the lower corner moves up or along the ground (wn = {wn} m/s): no impact")
    w11, w22, w12 = 1 + ry * ry / ic, 1 + rx * rx / ic, -rx * ry / ic
    t_minus, t_plus = corner_landing_thresholds(mu, b, h, theta)
    rho = wt / -wn
    if t_minus <= rho <= t_plus:
        pt, pn = -(w22 * wt - w12 * wn) / 4.0, -(-w12 * wt + w11 * wn) / 4.0  # det W = 4
        mode, slip = Mode.ROCK, 0.0
    else:
        s = 1 if rho > t_plus else -1
        pn = -wn / (w22 - s * mu * w12)
        pt = -s * mu * pn
        mode, slip = Mode.SLIDE_ROCK, wt + (w12 - s * mu * w11) * pn
    return Landing(mode, c, vx + pt, vy + pn, omega - (rx * pn - ry * pt) / ic, slip, pt, pn)


def corner_landing_margin(mu: float, b: float, h: float, theta: float, omega: float, vx: float, vy: float) -> float:
    """Distance (1) of a corner landing's rho from the nearer of its two separatrices."""
    _, rx, ry = _corner_geometry(b, h, theta)
    wt, wn = vx + omega * ry, vy - omega * rx
    t_minus, t_plus = corner_landing_thresholds(mu, b, h, theta)
    return min(abs(wt / -wn - t_minus), abs(wt / -wn - t_plus))
