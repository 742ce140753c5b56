"""Independent reference for one rigid block that rocks and slides on a rigid ground (Coulomb friction).

Written from Newton-Euler, independently of the C core (model/c), to check the FMU's
rocking-sliding model (``contact.model = 1``). Units SI, angles in radians; conventions of
docs/conventions.md: x right, y up, theta > 0 clockwise on the bottom right corner (pivot side
s = +1), theta < 0 on the bottom left corner (s = -1); a_h > 0 accelerates the ground towards +x,
a_v > 0 upwards, G = g + a_v.

Derivation (in the ground's frame, so the inertial force -m (a_h, a_v) acts at the centre of mass)
---------------------------------------------------------------------------------------------------
Half width b, half height h, R = sqrt(b^2 + h^2), alpha = atan(b / h), Ic = m R^2 / 3,
I0 = Ic + m R^2 = 4/3 m R^2. The slip u is the x of the pivot corner minus s b (the base centre's
displacement when the base is flat). With phi = theta - s alpha the centre of mass is at

    X = u + s b + R sin(phi),   Y = R cos(phi),
    X' = u' + R cos(phi) w,     Y' = -R sin(phi) w,            (w = theta')
    X'' = u'' + R cos(phi) w' - R sin(phi) w^2,   Y'' = -R sin(phi) w' - R cos(phi) w^2.

The ground acts at the pivot with (T, N) (T > 0 towards +x, N > 0 compression). Newton-Euler:

    m X'' = T - m a_h,   m Y'' = N - m G,   Ic w' = R sin(phi) N - R cos(phi) T   (clockwise moment).

- Rest (flat, sticks): u'' = 0, T = m a_h, N = m G; holds while |a_h| <= min(mu, tan alpha) G.
- Slide (flat, u' of sign sigma): T = -sigma mu m G, N = m G, u'' = -a_h - sigma mu G. The
  moment balance puts the normal resultant mu h from the centre, so the base stays flat only
  while mu <= tan alpha; with mu > tan alpha a flat slide tips at once onto its corner s = sigma.
- Rock (u'' = 0): eliminating T and N,
      I0 w' = m R (G sin(phi) - a_h cos(phi)),
      T = m (a_h + R cos(phi) w' - R sin(phi) w^2),  N = m (G - R sin(phi) w' - R cos(phi) w^2).
  Friction demand |T| / N; the pivot starts to slip (opposite to T) when |T| reaches mu N.
- SlideRock (T = -sigma mu N, u' of sign sigma): with q = sin(phi) + sigma mu cos(phi),
      w' = q (G - R cos(phi) w^2) / (R (1/3 + q sin(phi))),
      N = m (G - R sin(phi) w' - R cos(phi) w^2),   u'' = T / m - a_h - R cos(phi) w' + R sin(phi) w^2.
  (a_h does not enter w': the friction force is set by N alone.)

Power: d/dt (1/2 m |V|^2 + 1/2 Ic w^2 + m g Y) = -m a_h X' - m a_v Y' + T u', so energy
+ friction loss (integral of -T u' = mu N |u'|) + impact losses = energy(t0) + ground work
(integral of -m a_h X' - m a_v Y'), which is integrated alongside the motion and checked.

Impact at theta = 0 on pivot s, landing corner s' = -s (pre-impact w-, slip rate v-). At
theta = 0: X' = v + h w, Y' = s b w before; X' = v+ + h w+, Y' = -s b w+ after (rotation about
the landing corner). Impulses on the landing corner from the change of linear momentum:
Pt = m (v+ + h w+ - v- - h w-), Pn = -m s b (w+ + w-). The three equations:
  (1) I0 w+ + m h v+ = eta I0 w- + m h v-  (the generalised Housner relation about the landing
      corner; eta = 1 - 3/2 sin^2 alpha is conservation of its angular momentum, Housner 1963);
  (2) sticking: v+ = 0, accepted if |Pt| <= mu Pn; otherwise sliding: Pt = c mu Pn with
      c = sign(Pt of the sticking impact), the impulse opposing the slip it leaves;
  (3) the landing corner's vertical velocity is 0 after (built into the kinematics above).
If w+ does not rock the block away from the landing corner (s' w+ <= 0), the block lands flat:
w+ = 0 and v+ = 0 if |v- + h w-| <= mu b |w-|, else v+ = (v- + h w-) - sign(v- + h w-) mu b |w-|;
then Rest or Slide (or SlideRock if mu > tan alpha). If the rigid model's rest rule holds
(|a_h| <= G tan alpha and the rebound would peak below rest_ratio alpha), the rebound is dropped
(w+ = 0) and the impact's own v+ is kept: 0 after a sticking impact, so the block rests. (The
rule stands for the Zeno tail of ever smaller impacts; when they stick, that tail ends at rest
without slip. The flat-landing formula there would invent a slip (h - mu b)|w-| whenever
mu < h / b, and with mu > tan alpha a spurious cascade of slide-rock phases.)

Mode logic (the shared modelling choices of the spec, Shenton 1996): from rest the block moves
when |a_h| exceeds min(mu, tan alpha) G: it slides if mu <= tan alpha, else it rocks on
s = -sign(a_h) if the rocking friction demand is <= mu, else it slide-rocks. A slip rate reaching
zero ends the slip if the sticking mode (Rest, Rock) needs at most mu N (with N >= 0), else the slip
reverses. On a pivot the consistent mode is chosen explicitly (after a slip stop, after an impact
that leaves the pivot sticking, at uplift): Rock if its N >= 0 and |T| <= mu N, else the slide-rock
whose N > 0 and whose slip acceleration has the sign of its slip (where rocking would need a
tensile N, the reversed slide can still press on the ground).

Integration: scipy.integrate.solve_ivp (DOP853) piece by piece between the excitation's break
points, with terminal events per mode (impact, overturn, slip rate zero, friction limit in Rock);
the start from rest is located by bisection on cells where |a_h| and a_v are monotone.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from model.ground_motions import record as _record

Ground = Callable[[float], tuple[float, float]]

REST, SLIDE, ROCK, SLIDE_ROCK, OVERTURNED = 0, 1, 2, 3, 4
MODE_NAMES = {REST: "rest", SLIDE: "slide", ROCK: "rock", SLIDE_ROCK: "slide-rock", OVERTURNED: "overturned"}


class SlidingReferenceError(RuntimeError):
    """The reference cannot go on (e.g. no consistent mode, or no progress at an event)."""


# ----------------------------------------------------------------------------------------- excitations


def _no_ground(t: float) -> tuple[float, float]:
    return 0.0, 0.0


@dataclass(frozen=True)
class Excitation:
    """Ground acceleration ``ground(t) -> (a_h, a_v)`` (m/s^2), its break points (s: where it is not
    smooth, integration stops there) and ``cells(t0, t1)``: points between which |a_h| and a_v are
    monotone (None: sampled every millisecond), used to find the start from rest exactly."""

    ground: Ground = _no_ground
    breaks: tuple[float, ...] = ()
    cells: Callable[[float, float], np.ndarray] | None = None


def _quarter_cells(t0: float, frequency: float, t1_window: float | None) -> Callable[[float, float], np.ndarray]:
    q = 0.25 / frequency

    def cells(a: float, b: float) -> np.ndarray:
        lo, hi = max(a, t0), b if t1_window is None else min(b, t1_window)
        if hi <= lo:
            return np.array([a, b])
        k0, k1 = math.floor((lo - t0) / q), math.ceil((hi - t0) / q)
        pts = t0 + q * np.arange(k0, k1 + 1)
        return np.union1d(pts[(pts > a) & (pts < b)], [a, b])

    return cells


def sine_pulse(amplitude: float, frequency: float, cycles: float = 1.0, t0: float = 0.0,
               vertical: float = 0.0) -> Excitation:
    """a_h = A sin(2 pi f (t - t0)) on [t0, t0 + cycles / f) (FMU excitation.kind 1); a_v has the same
    shape with amplitude ``vertical`` (m/s^2, excitation.verticalAmplitude)."""
    w, t1 = 2.0 * math.pi * frequency, t0 + cycles / frequency

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t1:
            return 0.0, 0.0
        s = math.sin(w * (t - t0))
        return amplitude * s, vertical * s

    return Excitation(ground, (t0, t1), _quarter_cells(t0, frequency, t1))


def harmonic(displacement: float, frequency: float, cycles: float = 0.0, t0: float = 0.0) -> Excitation:
    """Table displacement D sin(2 pi f (t - t0)), so a_h = -D (2 pi f)^2 sin(2 pi f (t - t0))
    (FMU excitation.kind 3); ``cycles`` = 0 is endless."""
    w = 2.0 * math.pi * frequency
    t1 = math.inf if cycles == 0 else t0 + cycles / frequency
    amp = -displacement * w * w

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t1:
            return 0.0, 0.0
        return amp * math.sin(w * (t - t0)), 0.0

    return Excitation(ground, (t0,) if cycles == 0 else (t0, t1),
                      _quarter_cells(t0, frequency, None if cycles == 0 else t1))


def record(time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None, scale: float = 1.0,
           t0: float = 0.0) -> Excitation:
    """Samples joined by straight lines (FMU excitation.kind 4; model.ground_motions.record): every
    sample is a break, and |a_h| - c a_v is convex on each segment, so its samples decide the start."""
    ground, breaks = _record(time, ah, av, scale=scale, t0=t0)
    pts = np.asarray(breaks, dtype=float)

    def cells(a: float, b: float) -> np.ndarray:
        return np.union1d(pts[(pts > a) & (pts < b)], [a, b])

    return Excitation(ground, breaks, cells)


# ----------------------------------------------------------------------------------------- the model


@dataclass(frozen=True)
class SlidingBlock:
    """One block on the ground: half width b and half height h (m), friction coefficient mu (static =
    kinetic), mass m (kg), gravity g (m/s^2), restitution eta (None: Housner's 1 - 3/2 sin^2 alpha)."""

    b: float
    h: float
    mu: float
    m: float = 10.0
    g: float = 9.81
    eta: float | None = None
    rest_ratio: float = 1e-6

    @property
    def R(self) -> float:
        return math.hypot(self.b, self.h)

    @property
    def alpha(self) -> float:
        return math.atan2(self.b, self.h)

    @property
    def restitution(self) -> float:
        return 1.0 - 1.5 * math.sin(self.alpha) ** 2 if self.eta is None else self.eta


@dataclass
class Forces:
    """Accelerations and contact reaction of one mode at one instant."""

    omega_dot: float  # rad/s^2
    slip_acc: float  # m/s^2
    T: float  # N, +x
    N: float  # N, compression


def mode_forces(blk: SlidingBlock, mode: int, s: int, sigma: int, theta: float, omega: float,
                ah: float, av: float) -> Forces:
    """The Newton-Euler solution of ``mode`` (see the module docstring)."""
    m, G, R = blk.m, blk.g + av, blk.R
    if mode == REST or mode == OVERTURNED:
        return Forces(0.0, 0.0, m * ah, m * G)
    if mode == SLIDE:
        return Forces(0.0, -ah - sigma * blk.mu * G, -sigma * blk.mu * m * G, m * G)
    phi = theta - s * blk.alpha
    sp, cp = math.sin(phi), math.cos(phi)
    if mode == ROCK:
        wd = 0.75 / R * (G * sp - ah * cp)
        T = m * (ah + R * cp * wd - R * sp * omega * omega)
        N = m * (G - R * sp * wd - R * cp * omega * omega)
        return Forces(wd, 0.0, T, N)
    q = sp + sigma * blk.mu * cp
    den = 1.0 / 3.0 + q * sp
    if den <= 0.0:
        raise SlidingReferenceError(f"slide-rock has no solution at theta={theta!r} (Painleve: mu too large)")
    wd = q * (G - R * cp * omega * omega) / (R * den)
    N = m * (G - R * sp * wd - R * cp * omega * omega)
    T = -sigma * blk.mu * N
    return Forces(wd, T / m - ah - R * cp * wd + R * sp * omega * omega, T, N)


def centre_velocity(blk: SlidingBlock, s: int, theta: float, omega: float, slip_rate: float) -> tuple[float, float]:
    """(X', Y') of the centre of mass relative to the ground (m/s)."""
    phi = theta - s * blk.alpha
    return slip_rate + blk.R * math.cos(phi) * omega, -blk.R * math.sin(phi) * omega


def energy(blk: SlidingBlock, s: int, theta: float, omega: float, slip_rate: float) -> float:
    """1/2 m |V|^2 + 1/2 Ic omega^2 + m g (Y - h) (J), V relative to the ground, g constant."""
    vx, vy = centre_velocity(blk, s, theta, omega, slip_rate)
    Y = blk.R * math.cos(theta - s * blk.alpha)
    kinetic = 0.5 * blk.m * (vx * vx + vy * vy) + 0.5 * blk.m * blk.R ** 2 / 3.0 * omega * omega
    return kinetic + blk.m * blk.g * (Y - blk.h)


@dataclass
class ImpactResult:
    omega_plus: float
    slip_rate_plus: float
    sticking: bool
    flat: bool
    Pt: float
    Pn: float


def impact(blk: SlidingBlock, s: int, omega_minus: float, slip_rate_minus: float, ah: float, av: float) -> ImpactResult:
    """The impact law at theta = 0 on pivot s (landing corner -s); see the module docstring."""
    m, b, h, mu = blk.m, blk.b, blk.h, blk.mu
    I0 = 4.0 / 3.0 * m * blk.R ** 2
    eta = blk.restitution
    wm, vm = omega_minus, slip_rate_minus
    rhs1 = eta * I0 * wm + m * h * vm
    # sticking: v+ = 0
    wp, vp = rhs1 / I0, 0.0
    Pt = m * (h * wp - vm - h * wm)
    Pn = -m * s * b * (wp + wm)
    sticking = abs(Pt) <= mu * Pn
    if not sticking:
        c = 1.0 if Pt > 0 else -1.0
        # I0 w + m h v = rhs1 ;  (h + c mu s b) w + v = vm + h wm - c mu s b wm
        a11, a12, a21, a22 = I0, m * h, h + c * mu * s * b, 1.0
        r2 = vm + h * wm - c * mu * s * b * wm
        det = a11 * a22 - a12 * a21
        wp = (rhs1 * a22 - a12 * r2) / det
        vp = (a11 * r2 - a21 * rhs1) / det
        Pt = m * (vp + h * wp - vm - h * wm)
        Pn = -m * s * b * (wp + wm)
    flat = (-s) * wp <= 0.0
    if not flat and abs(ah) <= (blk.g + av) * math.tan(blk.alpha):  # the rigid model's rest rule
        k = 0.75 / blk.R
        cpk = math.cos(blk.alpha) + wp * wp / (2.0 * k * (blk.g + av))
        if cpk < 1.0 and blk.alpha - math.acos(cpk) < blk.rest_ratio * blk.alpha:
            # a negligible rebound: drop it, keep the impact's slip rate (0 after a sticking impact)
            return ImpactResult(0.0, vp, sticking, True, Pt, Pn)
    if flat:
        x = vm + h * wm
        wp = 0.0
        vp = 0.0 if abs(x) <= mu * b * abs(wm) else x - math.copysign(mu * b * abs(wm), x)
        Pt, Pn = m * (vp - x), m * s * (-b) * wm  # Y' before s b w-, after 0
    return ImpactResult(wp, vp, sticking, flat, Pt, Pn)


# ----------------------------------------------------------------------------------------- the run


def mode_after_impact(flat: bool, vp: float, mode: int, s_new: int,
                      mu_below_tan: bool) -> tuple[int, int, int, str | None]:
    """The mode after an impact that left the block flat (``flat``) or on pivot side ``s_new``, slipping at
    ``vp`` (m/s; 0: it sticks); ``mode`` is the mode before, ``mu_below_tan`` says mu <= tan(alpha). Returns
    (mode, its side or slip sign, slip direction sigma, the switch to record or None). A flat landing rests (no slip left) or slides (a squat block, mu <= tan(alpha))
    or slide-rocks; otherwise the block rocks on its landing corner, sticking or sliding."""
    if flat:
        if vp == 0.0:
            return REST, s_new, 0, "rest"
        sig = 1 if vp > 0 else -1
        return (SLIDE, sig, sig, "slide") if mu_below_tan else (SLIDE_ROCK, sig, sig, "slide-rock")
    if vp == 0.0:
        return ROCK, s_new, 0, None if mode == ROCK else "stick"
    sig = 1 if vp > 0 else -1
    return SLIDE_ROCK, s_new, sig, None if mode == SLIDE_ROCK else "slide-rock"


@dataclass
class Run:
    """What one run of the reference gives. Arrays at the integrator's steps and at events."""

    t: np.ndarray = field(default_factory=lambda: np.empty(0))
    theta: np.ndarray = field(default_factory=lambda: np.empty(0))
    omega: np.ndarray = field(default_factory=lambda: np.empty(0))
    slip: np.ndarray = field(default_factory=lambda: np.empty(0))
    slip_rate: np.ndarray = field(default_factory=lambda: np.empty(0))
    mode: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))
    energy: np.ndarray = field(default_factory=lambda: np.empty(0))  # J
    friction_loss: np.ndarray = field(default_factory=lambda: np.empty(0))  # J, running
    impact_loss: np.ndarray = field(default_factory=lambda: np.empty(0))  # J, running
    ground_work: np.ndarray = field(default_factory=lambda: np.empty(0))  # J, running
    events: list[tuple[str, float]] = field(default_factory=list)  # (kind, t)
    switches: list[tuple[float, int, int]] = field(default_factory=list)  # (t, mode before, mode after)
    impact_times: list[float] = field(default_factory=list)
    impact_energy_change: list[float] = field(default_factory=list)  # J, energy after - before (<= 0)
    min_normal: float = math.inf  # N, smallest normal reaction while in contact modes (< 0: lift-off)
    overturned: bool = False

    @property
    def peak_abs_slip(self) -> float:
        return float(np.max(np.abs(self.slip))) if self.slip.size else 0.0

    @property
    def final_slip(self) -> float:
        return float(self.slip[-1])

    @property
    def switch_times(self) -> np.ndarray:
        return np.array([t for t, _, _ in self.switches])

    def event_times(self, kind: str) -> np.ndarray:
        return np.array([t for k, t in self.events if k == kind])

    @property
    def balance_error(self) -> np.ndarray:
        """energy + friction loss + impact loss - energy(t0) - ground work along the run (J)."""
        return self.energy + self.friction_loss + self.impact_loss - self.energy[0] - self.ground_work


class _Solver:
    def __init__(self, blk: SlidingBlock, exc: Excitation, t_end: float, rtol: float, atol: float):
        if not blk.mu > 0 or not (blk.b > 0 and blk.h > 0):
            raise ValueError("need mu > 0, b > 0, h > 0")
        self.blk, self.exc, self.t_end, self.rtol, self.atol = blk, exc, t_end, rtol, atol
        self.tan_a = math.tan(blk.alpha)
        self.breaks = sorted(x for x in exc.breaks if math.isfinite(x))
        self.run = Run()
        self.rows: list[tuple] = []
        self.w_ground = self.w_friction = self.w_impact = 0.0

    # --- ground, clamped to the piece being integrated (one side of a discontinuity)
    def piece_ground(self, lo: float, hi: float) -> Ground:
        g, top = self.exc.ground, math.nextafter(hi, -math.inf)
        return lambda t: g(min(max(t, lo), top))

    def record_row(self, t, theta, omega, u, ud, mode, s):
        e = energy(self.blk, s, theta, omega, ud)
        self.rows.append((t, theta, omega, u, ud, mode, e, self.w_friction, self.w_impact, self.w_ground))

    def switch(self, t, old, new, kind):
        self.run.events.append((kind, t))
        if old != new:
            self.run.switches.append((t, old, new))

    # --- start from rest
    def start_indicator(self, t: float) -> float:
        ah, av = self.exc.ground(t)
        return abs(ah) - min(self.blk.mu, self.tan_a) * (self.blk.g + av)

    def find_start(self, t0: float) -> float | None:
        """First time >= t0 where the rest criterion fails (right end of a 1-ulp bracket)."""
        f = self.start_indicator
        if f(t0) > 0:
            return t0
        if self.exc.cells is not None:
            grid = self.exc.cells(t0, self.t_end)
            bks = np.asarray(self.breaks)
            grid = np.union1d(grid, bks[(bks > t0) & (bks < self.t_end)])
        else:
            grid = np.union1d(np.append(np.arange(t0, self.t_end, 1e-3), self.t_end),
                              [x for x in self.breaks if t0 < x < self.t_end])
        prev = float(grid[0])
        for x in grid[1:]:
            x = float(x)
            if f(x) > 0:
                # a jump at a break: the break itself (ground(x) is the value just after it)
                lo, hi = prev, x
                while True:
                    mid = 0.5 * (lo + hi)
                    if mid <= lo or mid >= hi:
                        break
                    if f(mid) > 0:
                        hi = mid
                    else:
                        lo = mid
                return hi
            prev = x
        return None

    def pivot_mode(self, s: int, theta: float, omega: float, ah: float, av: float) -> tuple[int, int]:
        """(mode, sigma) consistent on pivot s with a zero slip rate: Rock if it needs N >= 0 and
        |T| <= mu N; else the slide-rock whose N > 0 and slip acceleration has the sign of its slip,
        the one opposing rocking's T first; else (none consistent: lift-off) the slip opposing T."""
        blk = self.blk
        f = mode_forces(blk, ROCK, s, 0, theta, omega, ah, av)
        if f.N >= 0.0 and abs(f.T) <= blk.mu * f.N:
            return ROCK, 0
        preferred = -1 if f.T > 0 else 1
        for sigma in (preferred, -preferred):
            try:
                g = mode_forces(blk, SLIDE_ROCK, s, sigma, theta, omega, ah, av)
            except SlidingReferenceError:  # this slip direction has no motion (Painleve)
                continue
            if g.N > 0.0 and sigma * g.slip_acc > 0.0:
                return SLIDE_ROCK, sigma
        return SLIDE_ROCK, preferred

    def leave_rest(self, t: float) -> tuple[int, int, int, str]:
        """(mode, s, sigma, event kind) the block takes when it starts to move at t."""
        blk = self.blk
        ah, av = self.exc.ground(t)
        direction = -1 if ah > 0 else 1  # where the block goes relative to the ground
        if blk.mu <= self.tan_a:
            return SLIDE, direction, direction, "slide"
        mode, sigma = self.pivot_mode(direction, 0.0, 0.0, ah, av)
        return mode, direction, sigma, "uplift" if mode == ROCK else "slide-rock"

    # --- main loop
    def solve(self, theta0: float, omega0: float, slip0: float, slip_rate0: float) -> Run:
        blk, run = self.blk, self.run
        t, theta, omega, u, ud = 0.0, theta0, omega0, slip0, slip_rate0
        if theta == 0.0 and omega == 0.0:
            s = 1 if ud >= 0 else -1
            mode, sigma = (REST, 0) if ud == 0.0 else (SLIDE, 1 if ud > 0 else -1)
            if mode == SLIDE and blk.mu > self.tan_a:
                mode, s = SLIDE_ROCK, sigma
        else:
            s = (1 if theta > 0 else -1) if theta != 0.0 else (1 if omega > 0 else -1)
            if ud != 0.0:
                mode, sigma = SLIDE_ROCK, (1 if ud > 0 else -1)
            else:
                mode, sigma = ROCK, 0
        self.record_row(t, theta, omega, u, ud, mode, s)
        stalls = 0
        while t < self.t_end and mode != OVERTURNED:
            if mode == REST:
                ts = self.find_start(t)
                if ts is None:
                    t = self.t_end
                    self.record_row(t, 0.0, 0.0, u, 0.0, REST, s)
                    break
                if ts > t:
                    self.record_row(ts, 0.0, 0.0, u, 0.0, REST, s)
                t = ts
                new, s, sigma, kind = self.leave_rest(t)
                self.switch(t, REST, new, kind)
                mode, theta, omega, ud = new, 0.0, 0.0, 0.0
                continue
            if mode == ROCK:  # a sticking pivot must be able to stick now
                ah, av = self.exc.ground(t)
                mode, sigma = self.pivot_mode(s, theta, omega, ah, av)
                if mode == SLIDE_ROCK:
                    self.switch(t, ROCK, SLIDE_ROCK, "slide-rock")
            t_new, state, mode_new, s, sigma = self.integrate(t, mode, s, sigma, theta, omega, u, ud)
            stalls = stalls + 1 if t_new <= t else 0
            if stalls > 8:
                raise SlidingReferenceError(f"no progress at t={t!r} in mode {MODE_NAMES[mode]}")
            t, (theta, omega, u, ud), mode = t_new, state, mode_new
        run.overturned = mode == OVERTURNED
        a = np.array(self.rows, dtype=float)
        (run.t, run.theta, run.omega, run.slip, run.slip_rate, modes, run.energy, run.friction_loss,
         run.impact_loss, run.ground_work) = a.T
        run.mode = modes.astype(int)
        return run

    def integrate(self, t, mode, s, sigma, theta, omega, u, ud):
        """One solve_ivp from t to the next break (or the first event); returns the new time, state,
        mode, side and slip direction."""
        blk, run = self.blk, self.run
        k = bisect.bisect_right(self.breaks, t)
        t_stop = min(self.breaks[k], self.t_end) if k < len(self.breaks) else self.t_end
        ground = self.piece_ground(t, t_stop)
        m = blk.m

        def rhs(tt, y):
            ah, av = ground(tt)
            f = mode_forces(blk, mode, s, sigma, y[0], y[1], ah, av)
            vx, vy = centre_velocity(blk, s, y[0], y[1], y[3])
            return [y[1], f.omega_dot, y[3], f.slip_acc, -m * ah * vx - m * av * vy, -f.T * y[3]]

        events = []

        def ev_impact(tt, y):
            return s * y[0]

        ev_impact.terminal, ev_impact.direction = True, -1

        def ev_overturn(tt, y):
            return s * y[0] - 0.5 * math.pi

        ev_overturn.terminal, ev_overturn.direction = True, 1

        def ev_stop(tt, y):
            return sigma * y[3]

        ev_stop.terminal, ev_stop.direction = True, -1

        def friction_margin(sign):
            def ev(tt, y):
                ah, av = ground(tt)
                f = mode_forces(blk, ROCK, s, 0, y[0], y[1], ah, av)
                return blk.mu * f.N - sign * f.T

            ev.terminal, ev.direction = True, -1
            return ev

        if mode == SLIDE:
            events = [ev_stop]
        elif mode == ROCK:
            events = [ev_impact, ev_overturn, friction_margin(1), friction_margin(-1)]
        else:
            events = [ev_impact, ev_overturn, ev_stop]
        y0 = [theta, omega, u, ud, 0.0, 0.0]
        try:
            r = solve_ivp(rhs, (t, t_stop), y0, method="DOP853", rtol=self.rtol, atol=self.atol, events=events,
                          dense_output=True)
        except SlidingReferenceError as exc:
            raise SlidingReferenceError(f"{exc}, integrating from t={t!r} s") from None
        if r.status < 0:
            raise SlidingReferenceError(f"solve_ivp failed at t={t!r}: {r.message}")
        hit = [(float(te[0]), i) for i, te in enumerate(r.t_events) if te.size]
        if hit:
            te, i = min(hit)
            ye = r.y_events[i][0]
            if te <= t and events[i] in (ev_impact, ev_stop):
                # the indicator starts at 0 (an impact or a slip stop has just happened): scipy's
                # bracket then has the root at its left end. Look inside the step for the real one.
                found = _relocate(r.sol.interpolants[-1], events[i], t)
                if found is not None:
                    te, ye = found
        else:
            te = None
        w_g0, w_f0 = self.w_ground, self.w_friction
        for j in range(1, r.t.size):
            y = r.y[:, j]
            self.w_ground, self.w_friction = w_g0 + y[4], w_f0 + y[5]
            self.record_row(float(r.t[j]), y[0], y[1], y[2], y[3], mode, s)
            if mode != SLIDE:
                ah, av = ground(float(r.t[j]))
                f = mode_forces(blk, mode, s, sigma, y[0], y[1], ah, av)
                run.min_normal = min(run.min_normal, f.N)
        if te is None:
            y = r.y[:, -1]
            return float(r.t[-1]), (y[0], y[1], y[2], y[3]), mode, s, sigma
        self.w_ground, self.w_friction = w_g0 + ye[4], w_f0 + ye[5]
        theta, omega, u, ud = ye[0], ye[1], ye[2], ye[3]
        ah, av = ground(te)
        ev = events[i]
        if ev is ev_overturn:
            self.record_row(te, theta, omega, u, ud, mode, s)
            self.switch(te, mode, OVERTURNED, "overturn")
            return te, (theta, omega, u, ud), OVERTURNED, s, sigma
        if ev is ev_stop:
            ud = 0.0
            self.record_row(te, theta, omega, u, ud, mode, s)
            if mode == SLIDE:
                if abs(ah) <= blk.mu * (blk.g + av):
                    self.switch(te, SLIDE, REST, "stick")
                    return te, (0.0, 0.0, u, 0.0), REST, s, 0
                self.switch(te, SLIDE, SLIDE, "reverse")
                return te, (0.0, 0.0, u, 0.0), SLIDE, -sigma, -sigma
            new_mode, new_sigma = self.pivot_mode(s, theta, omega, ah, av)
            if new_mode == ROCK:
                self.switch(te, SLIDE_ROCK, ROCK, "stick")
                return te, (theta, omega, u, 0.0), ROCK, s, 0
            self.switch(te, SLIDE_ROCK, SLIDE_ROCK, "reverse" if new_sigma != sigma else "slide-rock")
            return te, (theta, omega, u, 0.0), SLIDE_ROCK, s, new_sigma
        if ev is ev_impact:
            theta = 0.0
            self.record_row(te, theta, omega, u, ud, mode, s)
            e_before = energy(blk, s, 0.0, omega, ud)
            res = impact(blk, s, omega, ud, ah, av)
            s_new = -s
            e_after = energy(blk, s_new, 0.0, res.omega_plus, res.slip_rate_plus)
            self.w_impact += e_before - e_after
            run.impact_times.append(te)
            run.impact_energy_change.append(e_after - e_before)
            run.events.append(("impact", te))
            wp, vp = res.omega_plus, res.slip_rate_plus
            new, s_out, sig, why = mode_after_impact(res.flat, vp, mode, s_new, blk.mu <= self.tan_a)
            if why:
                self.switch(te, mode, new, why)
            self.record_row(te, 0.0, wp, u, vp, new, s_out)
            return te, (0.0, wp, u, vp), new, s_out, sig
        # friction limit in Rock
        f = mode_forces(blk, ROCK, s, 0, theta, omega, ah, av)
        sigma = -1 if f.T > 0 else 1
        self.record_row(te, theta, omega, u, ud, mode, s)
        self.switch(te, ROCK, SLIDE_ROCK, "slide-rock")
        return te, (theta, omega, u, 0.0), SLIDE_ROCK, s, sigma


def _relocate(step, event, t0: float, samples: int = 256) -> tuple[float, np.ndarray] | None:
    """The first crossing of ``event`` downwards after it has been positive, on one step's dense
    output ``step`` (from t0): (time, state), or None if it never leaves 0 upwards."""
    ts = np.linspace(t0, step.t, samples + 1)[1:]
    was_positive, prev = False, t0
    for tt in ts:
        g = event(tt, step(tt))
        if g > 0:
            was_positive, prev = True, tt
        elif was_positive:
            a, b = prev, tt
            while True:
                mid = 0.5 * (a + b)
                if mid <= a or mid >= b:
                    break
                if event(mid, step(mid)) > 0:
                    a = mid
                else:
                    b = mid
            return float(b), step(b)
    return None


def simulate(block: SlidingBlock, excitation: Excitation | None, t_end: float, theta0: float = 0.0,
             omega0: float = 0.0, slip0: float = 0.0, slip_rate0: float = 0.0, rtol: float = 1e-12,
             atol: float = 1e-14) -> Run:
    """Run the reference from t = 0 to ``t_end`` (s). The block starts flat at rest unless theta0 (rad),
    omega0 (rad/s) or slip_rate0 (m/s, slides flat or, with theta0, slide-rocks) say otherwise."""
    solver = _Solver(block, excitation or Excitation(), t_end, rtol, atol)
    return solver.solve(theta0, omega0, slip0, slip_rate0)
