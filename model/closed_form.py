"""Closed forms of Dimitrakopoulos & DeJong (2012) for the linearised
rocking block under a one-sine pulse, in its dimensionless groups.

The linearised block (slender, small angles) obeys, with tau = p t,

    theta_tautau - theta + alpha sgn(theta) = -(a_g / g) sin(omega tau + psi)

where the pulse a_h = a_g sin(omega_g t) has been shifted so that tau = 0 is
the instant of uplift, sin(psi) = 1 / a, and the pulse ends at
tau_ex = (2 pi - psi) / omega. The groups are

    omega = omega_g / p,   a = a_g / (g alpha),   eta (restitution).

All functions take (a, omega[, eta]) with a > 1 (the block lifts) and
return dimensionless numbers. The block first rotates towards the side the
pulse pushes it (theta < 0 for a_g > 0 in docs/conventions.md); the formulas
below are written for that side, as in the paper. Equation numbers refer to
Dimitrakopoulos & DeJong (2012), Proc. R. Soc. A 468 (docs/references.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq


@dataclass(frozen=True)
class Groups:
    """The constants of the forced stage from rest (eqs. 3.7, 3.9) for given a, omega."""

    a: float
    w: float
    psi: float  # phase of the pulse at uplift
    tau_ex: float  # dimensionless time from uplift to the end of the pulse
    A: float  # A0* (coefficient of e^-tau, times 2/alpha)
    B: float  # B0* (coefficient of e^tau)
    C: float  # C0* (amplitude of the forced sine)

    @property
    def D(self) -> float:
        """D0* of eq. 3.9: product of the free-stage coefficients after the pulse."""
        half = 0.5 * self.w * self.C
        return (self.A - half * math.exp(self.tau_ex)) * (self.B + half * math.exp(-self.tau_ex))


def groups(a: float, w: float) -> Groups:
    if not a > 1.0:
        raise ValueError(f"a = a_g / (g alpha) = {a} must exceed 1 (the block must lift)")
    if not w > 0.0:
        raise ValueError(f"omega = omega_g / p = {w} must be positive")
    psi = math.asin(1.0 / a)
    r = math.sqrt(a * a - 1.0)
    d = w * w + 1.0
    return Groups(a, w, psi, (2.0 * math.pi - psi) / w, (w * w + w * r) / d, (w * w - w * r) / d, 2.0 * a / d)


def forced_theta(g: Groups, tau: float) -> float:
    """2 theta / alpha in the forced stage before the first impact (theta < 0 side), eq. 3.21's left side."""
    return g.A * math.exp(-tau) + g.B * math.exp(tau) + g.C * math.sin(g.w * tau + g.psi) - 2.0


def forced_rate(g: Groups, tau: float) -> float:
    """2 theta' / (p alpha) in the forced stage, eq. 3.22."""
    return g.B * math.exp(tau) - g.A * math.exp(-tau) + g.C * g.w * math.cos(g.w * tau + g.psi)


def first_impact_in_pulse(g: Groups, samples: int = 400) -> float | None:
    """tau of the first impact before the pulse ends (root of eq. 3.21), or None."""
    taus = np.linspace(0.0, g.tau_ex, samples + 1)[1:]
    prev = 1e-9
    f_prev = forced_theta(g, prev)
    for t in taus:
        f = forced_theta(g, t)
        if f_prev < 0.0 <= f:
            return brentq(lambda x: forced_theta(g, x), prev, t, xtol=1e-14)
        prev, f_prev = t, f
    return None


def no_impact_margin(a: float, w: float) -> float:
    """Eq. 3.10: positive when the block overturns during or after the pulse without any impact
    (sqrt(a^2 - 1) - a exp(-tau_ex) - omega); meaningful when no impact happens within the pulse."""
    g = groups(a, w)
    return math.sqrt(a * a - 1.0) - a * math.exp(-g.tau_ex) - w


def impact_rate_after_pulse(a: float, w: float) -> float:
    """Eq. 3.15: theta' / (p alpha) just before an impact that comes after the pulse, sqrt(1 - D0*)."""
    return math.sqrt(max(0.0, 1.0 - groups(a, w).D))


def case_12_margin(a: float, w: float, eta: float) -> float:
    """Eqs. 3.17-3.18: eta theta'_i2 / (p alpha) - 1, positive when the block overturns after an
    impact that comes after the pulse."""
    return eta * impact_rate_after_pulse(a, w) - 1.0


def case_11_margin(a: float, w: float, eta: float, tau_i: float | None = None) -> float | None:
    """Eqs. 3.20-3.21: half the left side of 3.20 minus 1, positive when the block overturns after an
    impact within the pulse; None if there is no such impact. tau_i overrides the root of 3.21
    (for the semi-analytical 3.29)."""
    g = groups(a, w)
    if tau_i is None:
        tau_i = first_impact_in_pulse(g)
        if tau_i is None:
            return None
    wt = g.w * tau_i + g.psi
    lhs = eta * forced_rate(g, tau_i) + g.C * (g.w * math.exp(tau_i - g.tau_ex) - g.w * math.cos(wt) - math.sin(wt))
    return 0.5 * lhs - 1.0


def semi_analytical_impact_time(a: float, w: float) -> float:
    """Eq. 3.29: the impact time of case 1.1 with sin(omega tau + psi) fitted by exponentials at tau = 1."""
    g = groups(a, w)
    s, c = math.sin(w + g.psi), math.cos(w + g.psi)
    kappa = -math.e * w / 2.0 * (c + w * s)
    lam = w / (2.0 * math.e) * (c - w * s)
    P, Q = g.A + g.C * kappa, g.B + g.C * lam
    disc = (a * s - 1.0) ** 2 - P * Q
    x = (1.0 - a * s + math.sqrt(disc)) / Q if disc >= 0.0 and Q != 0.0 else math.nan
    return math.log(x) if x > 0.0 else math.nan  # nan: the fit has no positive root there


def case_11_margin_semi_analytical(a: float, w: float, eta: float) -> float:
    """Eq. 3.30: case_11_margin with the impact time of eq. 3.29 (nan where 3.29 has no root)."""
    tau = semi_analytical_impact_time(a, w)
    return math.nan if math.isnan(tau) else case_11_margin(a, w, eta, tau_i=tau)


def impact_at_pulse_end_margin(a: float, w: float) -> float:
    """Eq. 3.31: (w^2 - w sqrt(a^2-1)) e^tau_ex - (1 + w^2 + sqrt(1 + (a^2+1) w^2)); zero where the
    first impact coincides with the end of the pulse."""
    g = groups(a, w)
    return (w * w - w * math.sqrt(a * a - 1.0)) * math.exp(g.tau_ex) - (
        1.0 + w * w + math.sqrt(1.0 + (a * a + 1.0) * w * w))


def overturns(a: float, w: float, eta: float) -> tuple[bool, str]:
    """Whether the linearised block overturns, and by which case of Dimitrakopoulos & DeJong (2012) (1.1, 1.2, 2, or safe)."""
    m11 = case_11_margin(a, w, eta)
    if m11 is not None:
        return m11 >= 0.0, "1.1" if m11 >= 0.0 else "safe (impact in the pulse)"
    if no_impact_margin(a, w) > 0.0:
        return True, "2"
    m12 = case_12_margin(a, w, eta)
    return m12 >= 0.0, "1.2" if m12 >= 0.0 else "safe (impact after the pulse)"


def max_rotation_after_impact(a: float, w: float, eta: float) -> float:
    """Eq. 4.13: theta_m / alpha, the peak after the first impact when it comes after the pulse
    (1 - sqrt(1 - eta^2 (1 - D0*))); nan when the block overturns."""
    x = eta * eta * (1.0 - groups(a, w).D)
    return 1.0 - math.sqrt(1.0 - x) if x < 1.0 else math.nan


def smallest_overturning_a(overturn, w: float, a_max: float = 50.0, rel: float = 1e-5) -> float | None:
    """Smallest a <= a_max at which overturn(a, w) is true: a log-spaced scan, then bisection.

    overturn is any classifier (a, w) -> bool: the closed forms above or a simulation."""
    grid = np.geomspace(1.0005, a_max, 60)
    prev = None
    for a in grid:
        if overturn(a, w):
            if prev is None:
                return float(a)
            lo, hi = prev, float(a)
            while hi / lo - 1.0 > rel:
                mid = math.sqrt(lo * hi)
                if overturn(mid, w):
                    hi = mid
                else:
                    lo = mid
            return hi
        prev = float(a)
    return None
