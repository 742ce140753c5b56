"""Ground motions for the independent Python solvers (model/solvers.py): pulses and records.

Written from the published formulas, independently of the C core (model/c/ground.c), so
that the tests can compare the FMU against them. Each function returns ``(ground, breaks)``:
``ground(t) -> (a_h, a_v)`` in m/s^2 (a_h > 0 accelerates the ground towards +x, a_v > 0
upwards; docs/conventions.md) and the times (s) where the motion is not smooth, at which an
integrator must stop.

Formulas and sources (docs/records.md):

- Ricker wavelet (Ricker 1943): the second derivative of a Gaussian, scaled so that its
  Fourier amplitude spectrum peaks at ``f`` and its peak is ``amplitude``,
  ``a(t) = A (1 - 2 pi^2 f^2 tau^2) exp(-pi^2 f^2 tau^2)``;
- antisymmetric Ricker wavelet: the third derivative of a Gaussian with the same
  spectral peak, ``a(t) = (A / beta) (x^2 - 3) x exp(-x^2 / 2)``,
  ``x = 2 pi f tau / sqrt(3)``, ``beta`` its largest magnitude;
- Mavroeidis and Papageorgiou (2003) pulse: the time derivative of their velocity pulse
  ``v(t) = V/2 [1 + cos(2 pi f tau / gamma)] cos(2 pi f tau + nu)`` on
  ``|tau| <= gamma / (2 f)``, scaled so that its peak acceleration is ``amplitude``;
- a record: samples joined by straight lines, zero before the first and after the last.

``tau`` is the time from the pulse's centre. Every pulse starts at ``t0``: a Ricker wavelet
lies on ``[t0, t0 + 6 / f]`` (centre ``t0 + 3 / f``), the Mavroeidis-Papageorgiou pulse on
``[t0, t0 + gamma / f]``.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.optimize import minimize_scalar

Ground = Callable[[float], tuple[float, float]]

RICKER_HALF_WINDOW = 3.0  # periods 1/f on either side of the centre


def ricker(amplitude: float, frequency: float, t0: float = 0.0,
           vertical: float = 0.0) -> tuple[Ground, tuple[float, ...]]:
    """Symmetric Ricker wavelet of peak ``amplitude`` (m/s^2) and spectral peak ``frequency`` (Hz)."""
    tc, half = t0 + RICKER_HALF_WINDOW / frequency, RICKER_HALF_WINDOW / frequency

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t0 + 2 * half:
            return 0.0, 0.0
        u = (math.pi * frequency * (t - tc)) ** 2
        w = (1.0 - 2.0 * u) * math.exp(-u)
        return amplitude * w, vertical * w

    return ground, (t0, t0 + 2 * half)


def ricker_antisymmetric(amplitude: float, frequency: float, t0: float = 0.0,
                         vertical: float = 0.0) -> tuple[Ground, tuple[float, ...]]:
    """Antisymmetric Ricker wavelet (third derivative of a Gaussian) of peak ``amplitude``."""
    tc, half = t0 + RICKER_HALF_WINDOW / frequency, RICKER_HALF_WINDOW / frequency
    k = 2.0 * math.pi * frequency / math.sqrt(3.0)
    # largest |(x^2 - 3) x exp(-x^2/2)|, found numerically (independently of the closed form)
    res = minimize_scalar(lambda x: -abs((x * x - 3.0) * x * math.exp(-0.5 * x * x)), bounds=(0.0, 1.5),
                          method="bounded", options={"xatol": 1e-12})
    beta = -res.fun

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t0 + 2 * half:
            return 0.0, 0.0
        x = k * (t - tc)
        w = (x * x - 3.0) * x * math.exp(-0.5 * x * x) / beta
        return amplitude * w, vertical * w

    return ground, (t0, t0 + 2 * half)


def mp_acceleration(tau: np.ndarray | float, velocity: float, frequency: float, gamma: float,
                    nu: float) -> np.ndarray | float:
    """Acceleration (m/s^2) of the Mavroeidis-Papageorgiou velocity pulse of amplitude ``velocity``
    (m/s) at ``tau`` (s) from its centre: the product rule applied to v(t), zero outside the pulse."""
    w, big = 2.0 * np.pi * frequency, 2.0 * np.pi * frequency / gamma
    tau = np.asarray(tau, dtype=float)
    a = -0.5 * velocity * (big * np.sin(big * tau) * np.cos(w * tau + nu)
                           + w * (1.0 + np.cos(big * tau)) * np.sin(w * tau + nu))
    return np.where(np.abs(tau) <= 0.5 * gamma / frequency, a, 0.0)


def mp_peak_acceleration(velocity: float, frequency: float, gamma: float, nu: float) -> float:
    """Peak |acceleration| (m/s^2) of the Mavroeidis-Papageorgiou pulse with velocity amplitude
    ``velocity`` (m/s): the FMU's ``excitation.amplitude`` for that pulse."""
    half = 0.5 * gamma / frequency
    tau = np.linspace(-half, half, 20001)
    a = np.abs(mp_acceleration(tau, 1.0, frequency, gamma, nu))
    i = int(np.argmax(a))
    lo, hi = tau[max(i - 1, 0)], tau[min(i + 1, len(tau) - 1)]
    res = minimize_scalar(lambda x: -abs(float(mp_acceleration(x, 1.0, frequency, gamma, nu))), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-14})
    return abs(velocity) * max(-res.fun, a[i])


def mp_pulse(amplitude: float, frequency: float, gamma: float, nu: float, t0: float = 0.0,
             vertical: float = 0.0) -> tuple[Ground, tuple[float, ...]]:
    """Mavroeidis-Papageorgiou pulse of peak acceleration ``amplitude`` (m/s^2), prevailing
    frequency ``frequency`` (Hz), oscillatory character ``gamma`` (> 1) and phase ``nu`` (rad)."""
    half = 0.5 * gamma / frequency
    tc = t0 + half
    per_unit = mp_peak_acceleration(1.0, frequency, gamma, nu)

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t0 + 2 * half:
            return 0.0, 0.0
        w = float(mp_acceleration(t - tc, 1.0, frequency, gamma, nu)) / per_unit
        return amplitude * w, vertical * w

    return ground, (t0, t0 + 2 * half)


def record(time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None, scale: float = 1.0,
           t0: float = 0.0) -> tuple[Ground, tuple[float, ...]]:
    """A sampled record: time (s), accelerations (m/s^2), joined by straight lines and multiplied
    by ``scale``; the record's time 0 is placed at ``t0``. Every sample is a break."""
    t = np.asarray(time, dtype=float) + t0
    h = scale * np.asarray(ah, dtype=float)
    v = None if av is None else scale * np.asarray(av, dtype=float)
    first, last = float(t[0]), float(t[-1])

    def ground(tt: float) -> tuple[float, float]:
        if not first <= tt < last:
            return 0.0, 0.0
        i = int(np.searchsorted(t, tt, side="right")) - 1
        s = (tt - t[i]) / (t[i + 1] - t[i])
        return ((1.0 - s) * h[i] + s * h[i + 1],
                0.0 if v is None else (1.0 - s) * v[i] + s * v[i + 1])

    return ground, tuple(float(x) for x in t)


def sampled_sine_bound(t: np.ndarray, amplitude: float, frequency: float, dt: float, b: float, h: float,
                       g: float = 9.81) -> np.ndarray:
    """Bound (rad) on |theta_record(t) - theta_pulse(t)| up to the first impact, when the one-sine
    pulse A sin(2 pi f t) is replaced by its samples every dt joined by straight lines, for a
    block of half width b and half height h at rest until the pulse lifts it (A > g b / h).

    Derivation (docs/records.md, "How exact is a record?"): the interpolant differs from the
    pulse by at most eps = A w^2 dt^2 / 8; theta'' = -k [g sin(phi) + a cos(phi)], k = 3 / (4 R),
    changes by at most L^2 |d theta| + k |d a| with L^2 = k sqrt(g^2 + A^2); the uplift moves by
    at most du, where the pulse climbs through eps above the threshold; over du the first block to
    lift gains at most J du^3 / 6 in angle and J du^2 / 2 in rate (J = k A w bounds the rate of
    change of theta''). Comparing |d theta|'' <= L^2 |d theta| + k eps with its equality case gives
    (d0 + d1 / L) cosh(L s) + k eps / L^2 (cosh(L s) - 1), s the time since the earlier uplift.
    """
    w, R = 2 * math.pi * frequency, math.hypot(b, h)
    k = 3 / (4 * R)
    eps = amplitude * w * w * dt * dt / 8
    L = math.sqrt(k * math.hypot(g, amplitude))
    thr = g * b / h
    tu = math.asin(thr / amplitude) / w
    du = (math.asin(min((thr + eps) / amplitude, 1.0)) - math.asin(thr / amplitude)) / w
    J = k * amplitude * w
    d0, d1 = J * du**3 / 6, J * du**2 / 2
    s = np.asarray(t, dtype=float) - (tu - du)
    bound = (d0 + d1 / L) * np.cosh(L * s) + k * eps / L**2 * (np.cosh(L * s) - 1)
    return np.where(s < 0, 0.0, bound)  # both rest until the earlier uplift
