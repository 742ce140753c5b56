"""Independent Python solvers for one rocking block (no code shared with the C core).

Two families, for the speed-versus-accuracy comparison of ``runners bench``:

- :func:`solve_event_driven`: ``scipy.integrate.solve_ivp`` (any of its
  methods) between events, with impacts and overturn located by its event
  finder and the integration restarted after each impact;
- :func:`solve_fixed_step`: the classic fixed-step schemes as the sources used
  them: explicit Euler and RK4 (Anagnostopoulos, impacts found by a sign change of
  theta, optionally located inside the step) and the Newmark trapezoidal rule
  with Newton iterations and impact-time location (Čeh & Jelenić 2022).

Both integrate the nonlinear equation of motion or, with ``linear=True``, the
linearised one of Dimitrakopoulos & DeJong (2012) (eq. 3.1), in the conventions of
docs/conventions.md: theta > 0 on the right corner, clockwise; a_h > 0 pushes
the ground to +x. Units SI, angles in radians.

    theta'' = -(3 / (4 R)) [ (g + a_v) sin(s alpha - theta) + a_h cos(s alpha - theta) ]

with s = +1 on the right corner and -1 on the left one. An impact (theta
through 0) multiplies the angular velocity by eta and flips s. A block at
rest lifts when |a_h| > (g + a_v) tan(alpha) (alpha for the linearised block) and comes to rest when, below
that threshold, an impact's rebound would peak under rest_ratio * alpha (the
FMU's rule, docs/model.md).
"""

from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from model.reference import Block

Ground = Callable[[float], tuple[float, float]]


def no_ground(t: float) -> tuple[float, float]:
    """No excitation: (a_h, a_v) = (0, 0)."""
    return 0.0, 0.0


def sine_pulse(amplitude: float, frequency: float, t0: float = 0.0) -> tuple[Ground, tuple[float, ...]]:
    """One-sine pulse a_h = A sin(2 pi f (t - t0)) on [t0, t0 + 1/f]; returns the function and its break points."""
    w, t1 = 2.0 * math.pi * frequency, t0 + 1.0 / frequency

    def ground(t: float) -> tuple[float, float]:
        return (amplitude * math.sin(w * (t - t0)) if t0 <= t < t1 else 0.0), 0.0

    return ground, (t0, t1)


@dataclass(frozen=True)
class Scene:
    """One block, its restitution coefficient and excitation."""

    block: Block
    eta: float  # coefficient of restitution (omega+ / omega-)
    theta0: float = 0.0  # rad
    omega0: float = 0.0  # rad/s
    ground: Ground = no_ground  # (a_h, a_v) in m/s^2
    breaks: tuple[float, ...] = ()  # times where the excitation is not smooth, s
    rest_ratio: float = 1e-6
    linear: bool = False  # Dimitrakopoulos & DeJong (2012)'s linearised equation (3.1)


@dataclass
class Solution:
    """Events of one simulation, and what it cost."""

    method: str
    impact_times: list[float] = field(default_factory=list)  # s
    omega_minus: list[float] = field(default_factory=list)  # rad/s
    peak_times: list[float] = field(default_factory=list)  # s
    peak_thetas: list[float] = field(default_factory=list)  # rad, signed
    overturned: bool = False
    overturn_time: float | None = None  # s
    rest_time: float | None = None  # s, last time the block came to rest
    at_rest: bool = False  # resting at the end
    max_abs_theta: float = 0.0  # rad
    rhs_evaluations: int = 0
    wall_time: float = 0.0  # s


class _Model:
    """Equation of motion and the rules shared by both solver families."""

    def __init__(self, scene: Scene):
        self.s = scene
        blk = scene.block
        self.k = 3.0 / (4.0 * blk.R)  # m R / I0, 1/m
        self.alpha, self.g = blk.alpha, blk.g
        # the linearised block lifts where its own equation starts to move: |a_h| > g alpha
        self.tan_alpha = blk.alpha if scene.linear else math.tan(blk.alpha)
        self.evaluations = 0

    def accel(self, t: float, theta: float, side: int) -> float:
        self.evaluations += 1
        ah, av = self.s.ground(t)
        phi = side * self.alpha - theta
        if self.s.linear:
            return -self.k * ((self.g + av) * phi + ah)
        return -self.k * ((self.g + av) * math.sin(phi) + ah * math.cos(phi))

    def daccel_dtheta(self, t: float, theta: float, side: int) -> float:
        ah, av = self.s.ground(t)
        if self.s.linear:
            return self.k * (self.g + av)
        phi = side * self.alpha - theta
        return self.k * ((self.g + av) * math.cos(phi) - ah * math.sin(phi))

    def uplift_indicator(self, t: float) -> float:
        """Positive once the ground tips the resting block (either side)."""
        ah, av = self.s.ground(t)
        return abs(ah) - (self.g + av) * self.tan_alpha

    def uplift_side(self, t: float) -> int:
        return -1 if self.s.ground(t)[0] > 0 else 1

    def comes_to_rest(self, t: float, omega_plus: float) -> bool:
        """The FMU's rest rule: below the uplift threshold, a rebound peaking under rest_ratio * alpha."""
        if self.uplift_indicator(t) > 0:
            return False
        ge = self.g + self.s.ground(t)[1]
        c = math.cos(self.alpha) + omega_plus**2 / (2.0 * self.k * ge)
        return c < 1.0 and self.alpha - math.acos(c) < self.s.rest_ratio * self.alpha

    def find_uplift(self, t0: float, t1: float, dt: float) -> float | None:
        """First time in [t0, t1] the ground tips the block: samples every dt and at the scene's
        breaks (a record's samples, where |a_h| of a piecewise-linear record peaks), then Brent's method."""
        if self.uplift_indicator(t0) > 0:
            return t0
        breaks = np.asarray(self.s.breaks, dtype=float)
        grid = np.union1d(np.append(np.arange(t0, t1, dt), t1), breaks[(breaks > t0) & (breaks < t1)])
        for a, b in zip(grid[:-1], grid[1:]):
            if self.uplift_indicator(b) > 0:
                return brentq(self.uplift_indicator, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        return None


def _finish(sol: Solution, m: _Model, resting: bool, start: float) -> Solution:
    sol.at_rest = resting and not sol.overturned
    sol.rhs_evaluations = m.evaluations
    sol.wall_time = time.perf_counter() - start
    return sol


def _initial_side(scene: Scene) -> int:
    if scene.theta0 != 0.0:
        return 1 if scene.theta0 > 0 else -1
    return 1 if scene.omega0 >= 0 else -1


def solve_event_driven(scene: Scene, t_end: float, method: str = "DOP853", rtol: float = 1e-10,
                       atol: float = 1e-12, max_impacts: int | None = None) -> Solution:
    """solve_ivp between events; impacts, overturn and peaks located by its event finder."""
    m = _Model(scene)
    sol = Solution(f"scipy {method} rtol {rtol:g}")
    start = time.perf_counter()
    t, theta, omega = 0.0, scene.theta0, scene.omega0
    side = _initial_side(scene)
    resting = theta == 0.0 and omega == 0.0
    sol.max_abs_theta = abs(theta)
    breaks = sorted(b for b in scene.breaks if b > 0)
    while t < t_end:
        if resting:
            tu = m.find_uplift(t, t_end, 1e-3)
            if tu is None:
                break
            t, theta, omega, side, resting = tu, 0.0, 0.0, m.uplift_side(tu), False
        k = bisect.bisect_right(breaks, t)
        t_stop = min(breaks[k], t_end) if k < len(breaks) else t_end

        def rhs(tt, y, s=side):
            return [y[1], m.accel(tt, y[0], s)]

        def impact(tt, y):
            return y[0]

        impact.terminal, impact.direction = True, -side

        def overturn(tt, y):
            return abs(y[0]) - math.pi / 2

        overturn.terminal, overturn.direction = True, 1

        def peak(tt, y):
            return y[1]

        peak.direction = -side  # omega changes sign while away from the pivot's side
        r = solve_ivp(rhs, (t, t_stop), [theta, omega], method=method, rtol=rtol, atol=atol,
                      events=[impact, overturn, peak])
        for tp, yp in zip(r.t_events[2], r.y_events[2]):
            if tp <= t:  # a release from rest (omega = 0 at the start) is not a peak
                continue
            sol.peak_times.append(float(tp))
            sol.peak_thetas.append(float(yp[0]))
            sol.max_abs_theta = max(sol.max_abs_theta, abs(float(yp[0])))
        sol.max_abs_theta = max([sol.max_abs_theta] + [abs(v) for v in r.y[0]])
        if r.t_events[1].size:
            sol.overturned, sol.overturn_time = True, float(r.t_events[1][0])
            break
        t, theta, omega = float(r.t[-1]), float(r.y[0, -1]), float(r.y[1, -1])
        if r.t_events[0].size:
            t, omega = float(r.t_events[0][0]), float(r.y_events[0][0][1])
            sol.impact_times.append(t)
            sol.omega_minus.append(omega)
            theta, omega, side = 0.0, scene.eta * omega, -side
            if m.comes_to_rest(t, omega):
                resting, omega, sol.rest_time = True, 0.0, t
            if max_impacts is not None and len(sol.impact_times) >= max_impacts:
                break
    return _finish(sol, m, resting, start)


def _euler(m: _Model, t, theta, omega, acc, side, h):
    a = m.accel(t, theta, side) if acc is None else acc
    return theta + h * omega, omega + h * a, None


def _rk4(m: _Model, t, theta, omega, acc, side, h):
    k1t, k1w = omega, m.accel(t, theta, side)
    k2t, k2w = omega + 0.5 * h * k1w, m.accel(t + 0.5 * h, theta + 0.5 * h * k1t, side)
    k3t, k3w = omega + 0.5 * h * k2w, m.accel(t + 0.5 * h, theta + 0.5 * h * k2t, side)
    k4t, k4w = omega + h * k3w, m.accel(t + h, theta + h * k3t, side)
    return (theta + h / 6.0 * (k1t + 2 * k2t + 2 * k3t + k4t),
            omega + h / 6.0 * (k1w + 2 * k2w + 2 * k3w + k4w), None)


def _newmark(m: _Model, t, theta, omega, acc, side, h):
    """Trapezoidal rule (Newmark beta = 1/4, gamma = 1/2) with Newton iterations on the new acceleration."""
    a0 = m.accel(t, theta, side) if acc is None else acc
    a1 = a0
    for _ in range(30):
        th1 = theta + h * omega + 0.25 * h * h * (a0 + a1)
        r = a1 - m.accel(t + h, th1, side)
        da = -r / (1.0 - 0.25 * h * h * m.daccel_dtheta(t + h, th1, side))
        a1 += da
        if abs(da) <= 1e-14 * (1.0 + abs(a1)):
            break
    th1 = theta + h * omega + 0.25 * h * h * (a0 + a1)
    return th1, omega + 0.5 * h * (a0 + a1), a1


STEPPERS = {"euler": _euler, "rk4": _rk4, "newmark": _newmark}


def _hermite_peak(t, h, th0, w0, th1, w1) -> tuple[float, float]:
    """Extremum of the cubic Hermite interpolant on [t, t + h], where omega changes sign."""
    # theta(s) = th0 + c1 s + c2 s^2 + c3 s^3 for s in [0, 1]
    c1, c2 = h * w0, 3.0 * (th1 - th0) - h * (2.0 * w0 + w1)
    c3 = 2.0 * (th0 - th1) + h * (w0 + w1)
    s = w0 / (w0 - w1)  # linear interpolation of omega, the fallback
    for r in np.roots([3.0 * c3, 2.0 * c2, c1]):
        if abs(r.imag) < 1e-12 and 0.0 <= r.real <= 1.0:
            s = r.real
            break
    return t + s * h, th0 + c1 * s + c2 * s * s + c3 * s**3


def solve_fixed_step(scene: Scene, t_end: float, method: str = "rk4", h: float = 1e-4, locate: bool = False,
                     max_impacts: int | None = None) -> Solution:
    """Fixed step h (s). Impacts by a sign change of theta at the step's end (locate=False, as Anagnostopoulos),
    or located inside the step by re-stepping to theta = 0 (locate=True, as Čeh & Jelenić 2022)."""
    step = STEPPERS[method]
    m = _Model(scene)
    sol = Solution(f"{method} h {h:g}" + (" located" if locate else ""))
    start = time.perf_counter()
    t, theta, omega, acc = 0.0, scene.theta0, scene.omega0, None
    side = _initial_side(scene)
    resting = theta == 0.0 and omega == 0.0
    sol.max_abs_theta = abs(theta)
    h_max = h
    while t < t_end - 1e-12 * h_max:
        h = min(h_max, t_end - t)  # the last step ends at t_end
        if resting:  # the classic loop checks the threshold at every step
            if m.uplift_indicator(t) > 0:
                theta, omega, side, resting, acc = 0.0, 0.0, m.uplift_side(t), False, None
            else:
                t += h
                continue
        th1, w1, a1 = step(m, t, theta, omega, acc, side, h)
        hh = h
        if side * th1 < 0:  # crossed the pivot: impact
            if locate:
                gap = lambda s: side * step(m, t, theta, omega, acc, side, s)[0]  # noqa: E731
                lo = 0.0
                if theta == 0.0:  # just after an impact: bracket from where the block is off its pivot
                    lo = 0.5 * h
                    while lo > 1e-9 * h and gap(lo) <= 0.0:
                        lo *= 0.5
                if gap(lo) > 0.0 or theta != 0.0:
                    hh = brentq(gap, lo, h, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                else:
                    hh = h  # it never leaves the pivot within the step
                th1, w1, a1 = step(m, t, theta, omega, acc, side, hh)
                th1 = 0.0
            sol.impact_times.append(t + hh)
            sol.omega_minus.append(w1)
            w1, side, a1 = scene.eta * w1, -side, None
            if m.comes_to_rest(t + hh, w1):
                resting, sol.rest_time, th1, w1 = True, t + hh, 0.0, 0.0
        elif omega * w1 < 0 and th1 != 0:
            tp, thp = _hermite_peak(t, h, theta, omega, th1, w1)
            sol.peak_times.append(tp)
            sol.peak_thetas.append(thp)
            sol.max_abs_theta = max(sol.max_abs_theta, abs(thp))
        t, theta, omega, acc = t + hh, th1, w1, a1
        sol.max_abs_theta = max(sol.max_abs_theta, abs(theta))
        if abs(theta) >= math.pi / 2:
            sol.overturned, sol.overturn_time = True, t
            break
        if max_impacts is not None and len(sol.impact_times) >= max_impacts:
            break
    return _finish(sol, m, resting, start)
