"""Exact reference for free rocking of one rigid block (independent of the C code).

Between impacts the nonlinear single block conserves

    E = 0.5 * omega**2 + p**2 * cos(alpha - |theta|),   p**2 = 3 g / (4 R),

so each peak angle follows from energy and the restitution coefficient, and
each quarter cycle (peak to impact, or impact to peak) lasts

    T(theta_p) = integral_0^theta_p dtheta / sqrt(2 p**2 (cos(alpha - theta_p) - cos(alpha - theta)))

which is evaluated by adaptive quadrature after the substitution
theta = theta_p (1 - w**2) that removes the square-root singularity at the peak.

Units SI, angles in radians; sign convention of docs/conventions.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad


def housner_restitution(alpha: float) -> float:
    """Housner's coefficient 1 - 1.5 sin^2(alpha)."""
    return 1.0 - 1.5 * math.sin(alpha) ** 2


def modified_restitution(alpha: float, k: float) -> float:
    """Modified coefficient with impact position k (Ceh and Jelenic 2022, eq. 10)."""
    s2 = math.sin(alpha) ** 2
    return (4.0 - 3.0 * s2 * (1.0 + k * k)) / (4.0 - 3.0 * s2 * (1.0 - k * k))


@dataclass(frozen=True)
class Block:
    """Rectangular block with half width b and half height h (m), gravity g (m/s^2)."""

    b: float
    h: float
    g: float = 9.81

    @property
    def R(self) -> float:
        return math.hypot(self.b, self.h)

    @property
    def alpha(self) -> float:
        return math.atan2(self.b, self.h)

    @property
    def p2(self) -> float:
        return 3.0 * self.g / (4.0 * self.R)


def quarter_period(block: Block, theta_p: float) -> float:
    """Time (s) from a peak |theta| = theta_p (omega = 0) to the next impact."""
    a, p2 = block.alpha, block.p2

    def integrand(w: float) -> float:
        # cos(a - tp) - cos(a - th) with th = tp (1 - w^2), written without cancellation
        d = theta_p * w * w
        diff = 2.0 * math.sin(a - theta_p + 0.5 * d) * math.sin(0.5 * d)
        if w == 0.0:
            return 2.0 * theta_p / math.sqrt(2.0 * p2 * math.sin(a - theta_p) * theta_p)
        return 2.0 * theta_p * w / math.sqrt(2.0 * p2 * diff)

    value, _ = quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)
    return value


@dataclass
class FreeRocking:
    """Impact times, impact velocities and peaks of free rocking from rest at theta0."""

    impact_times: np.ndarray  # s
    omega_minus: np.ndarray  # rad/s, just before each impact
    peak_times: np.ndarray  # s, peaks after each impact
    peak_thetas: np.ndarray  # rad, signed


def free_rocking(block: Block, theta0: float, eta: float, n_impacts: int) -> FreeRocking:
    """Exact free rocking released at theta0 (rad, |theta0| < alpha) with omega0 = 0."""
    a, p2 = block.alpha, block.p2
    if not 0 < abs(theta0) < a:
        raise ValueError(f"need 0 < |theta0| < alpha = {a}")
    t, theta_p = 0.0, theta0
    impacts, wminus, peaks_t, peaks = [], [], [], []
    for _ in range(n_impacts):
        tp = abs(theta_p)
        t += quarter_period(block, tp)
        # impact: speed from energy, direction towards the other side
        speed = math.sqrt(2.0 * p2 * 2.0 * math.sin(a - 0.5 * tp) * math.sin(0.5 * tp))
        w = -math.copysign(speed, theta_p)
        impacts.append(t)
        wminus.append(w)
        wplus = eta * w
        c = math.cos(a) + wplus * wplus / (2.0 * p2)
        if c >= 1.0:
            raise ValueError("the block would overturn: not a free-rocking reference")
        next_peak = a - math.acos(c)
        theta_p = math.copysign(next_peak, wplus)
        t_peak = t + quarter_period(block, next_peak)
        peaks_t.append(t_peak)
        peaks.append(theta_p)
        t = t_peak
    return FreeRocking(np.array(impacts), np.array(wminus), np.array(peaks_t), np.array(peaks))
