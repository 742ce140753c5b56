"""Intensity measures of a ground-acceleration record, exact for the signal the FMU integrates.

The FMU joins a record's samples by straight lines (docs/records.md), so every measure here but
the mean period is computed for that piecewise-linear acceleration a(t), in closed form segment
by segment, not by a quadrature of the samples:

- ``pga``: peak |a| (m/s^2): on straight segments, at a sample;
- ``pgv``: peak |v| (m/s), v the exact integral of a from rest (quadratic on each segment, so
  its extrema inside a segment, where a = 0, are included);
- ``pgd``: peak |d| (m), d the exact integral of v (cubic on each segment), after removing the
  least-squares straight line through d: the motion seen from the inertial frame that follows
  the record's mean drift (a small baseline error otherwise grows into metres of displacement;
  a frame moving at constant velocity does not change the rocking response);
- ``arias``: Arias (1970) intensity pi / (2 g) * integral of a^2 dt (m/s), g = 9.80665 m/s^2;
- ``d5_95``: significant duration (Trifunac and Brady 1975), the time between 5 % and 95 % of
  the Arias intensity (s), located exactly inside its segments;
- ``mean_period``: Rathje, Abrahamson and Bray (1998): sum(C_i^2 / f_i) / sum(C_i^2) over the
  Fourier amplitudes C_i at frequencies 0.25 Hz <= f_i <= 20 Hz (s), from the FFT of the
  samples without zero padding (resampled at the smallest interval when the sampling is
  irregular): Rathje's discrete definition, not a property of the piecewise-linear a(t).

Units SI. Sign convention (docs/conventions.md): a > 0 accelerates the ground towards +x.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

G0 = 9.80665  # m/s^2, standard gravity (Arias intensity, accelerations "in g")
MEAN_PERIOD_BAND = (0.25, 20.0)  # Hz


@dataclass(frozen=True)
class Measures:
    """Intensity measures of one record (SI units)."""

    pga: float  # m/s^2
    pgv: float  # m/s
    pgd: float  # m
    arias: float  # m/s
    d5_95: float  # s
    mean_period: float  # s

    @property
    def pgv_pga(self) -> float:
        """PGV / PGA (s): long for pulse-like records."""
        return self.pgv / self.pga if self.pga > 0 else math.nan

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


# how each measure of a record scaled by s changes: s^power (0: it does not change)
SCALING = {"pga": 1, "pgv": 1, "pgd": 1, "arias": 2, "d5_95": 0, "mean_period": 0,
           "pfa": 1, "sa_t1": 1}  # the last two through a support (runners.engine.floor_motion)
SUPPORT_MEASURES = ("pfa", "sa_t1")  # a record's measures through a scene's support, not stored with the record
UNITS = {"pga": "m/s2", "pgv": "m/s", "pgd": "m", "arias": "m/s", "d5_95": "s", "mean_period": "s",
         "pfa": "m/s2", "sa_t1": "m/s2"}


def _check(t: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t, a = np.asarray(t, dtype=float), np.asarray(a, dtype=float)
    if t.ndim != 1 or t.shape != a.shape or t.size < 2:
        raise ValueError("a record needs at least two samples of time and acceleration of equal length")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise ValueError("a record's time and acceleration must be finite")
    if np.any(np.diff(t) <= 0):
        raise ValueError("a record's time must increase strictly")
    return t, a


def velocity(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """v at the samples (m/s): the exact integral of the piecewise-linear a, from rest at t[0]."""
    t, a = _check(t, a)
    return np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))])


def displacement(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """d at the samples (m): the exact double integral of the piecewise-linear a, from rest."""
    t, a = _check(t, a)
    h = np.diff(t)
    v = velocity(t, a)
    step = v[:-1] * h + h * h * (a[:-1] / 3.0 + a[1:] / 6.0)
    return np.concatenate([[0.0], np.cumsum(step)])


def _segment_roots(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray, h: np.ndarray) -> list[tuple[int, float]]:
    """(segment, s) of the roots 0 < s < h of c0 + c1 s + c2 s^2 on each segment."""
    out: list[tuple[int, float]] = []
    lin = np.abs(c2) <= 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        s_lin = np.where(lin, -c0 / c1, np.nan)
        disc = c1 * c1 - 4 * c2 * c0
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        r1 = np.where(lin, s_lin, (-c1 - sq) / (2 * c2))
        r2 = np.where(lin, np.nan, (-c1 + sq) / (2 * c2))
    for r in (r1, r2):
        ok = np.isfinite(r) & (r > 0) & (r < h)
        out.extend(zip(np.nonzero(ok)[0].tolist(), r[ok].tolist()))
    return out


def peak_velocity(t: np.ndarray, a: np.ndarray) -> float:
    """Largest |v| (m/s), including extrema inside segments (where a crosses zero)."""
    t, a = _check(t, a)
    v, h = velocity(t, a), np.diff(t)
    m = (a[1:] - a[:-1]) / h
    best = float(np.max(np.abs(v)))
    for i, s in _segment_roots(a[:-1], m, np.zeros_like(m), h):
        best = max(best, abs(v[i] + a[i] * s + 0.5 * m[i] * s * s))
    return best


def _baseline(t: np.ndarray, a: np.ndarray) -> tuple[float, float]:
    """(intercept, slope) of the straight line nearest to the exact displacement in the least-squares
    sense over the record's time, integral of (d(t) - c0 - c1 t)^2 dt: independent of how the same
    piecewise-linear acceleration is sampled."""
    h = np.diff(t)
    v, d = velocity(t, a), displacement(t, a)
    m = (a[1:] - a[:-1]) / h
    d0, v0, a0, t0 = d[:-1], v[:-1], a[:-1], t[:-1]
    # d(t0 + s) = d0 + v0 s + a0 s^2 / 2 + m s^3 / 6: its integrals against 1 and s over [0, h]
    i_d = d0 * h + v0 * h**2 / 2 + a0 * h**3 / 6 + m * h**4 / 24
    i_sd = d0 * h**2 / 2 + v0 * h**3 / 3 + a0 * h**4 / 8 + m * h**5 / 30
    T0, T1 = t[0], t[-1]
    n00, n01, n11 = T1 - T0, (T1**2 - T0**2) / 2, (T1**3 - T0**3) / 3
    r0, r1 = i_d.sum(), (t0 * i_d + i_sd).sum()
    c0, c1 = np.linalg.solve([[n00, n01], [n01, n11]], [r0, r1])
    return float(c0), float(c1)


def peak_displacement(t: np.ndarray, a: np.ndarray) -> float:
    """Largest |d - baseline| (m), d exact, baseline its least-squares straight line, extrema
    inside segments (where v equals the baseline's slope) included."""
    t, a = _check(t, a)
    v, d, h = velocity(t, a), displacement(t, a), np.diff(t)
    c0, c1 = _baseline(t, a)
    m = (a[1:] - a[:-1]) / h
    r = d - (c0 + c1 * t)
    best = float(np.max(np.abs(r)))
    # v(s) - c1 = (v_i - c1) + a_i s + m s^2 / 2 on each segment
    for i, s in _segment_roots(v[:-1] - c1, a[:-1], 0.5 * m, h):
        di = d[i] + v[i] * s + a[i] * s * s / 2 + m[i] * s**3 / 6
        best = max(best, abs(di - (c0 + c1 * (t[i] + s))))
    return best


def cumulative_arias(t: np.ndarray, a: np.ndarray, g: float = G0) -> np.ndarray:
    """Arias intensity accumulated up to each sample (m/s), exact for the piecewise-linear a."""
    t, a = _check(t, a)
    seg = np.diff(t) * (a[:-1] ** 2 + a[:-1] * a[1:] + a[1:] ** 2) / 3.0
    return math.pi / (2.0 * g) * np.concatenate([[0.0], np.cumsum(seg)])


def arias_intensity(t: np.ndarray, a: np.ndarray, g: float = G0) -> float:
    """Arias intensity pi / (2 g) * integral of a^2 dt (m/s)."""
    return float(cumulative_arias(t, a, g)[-1])


def _arias_time(t: np.ndarray, a: np.ndarray, cum: np.ndarray, target: float) -> float:
    """Time at which the exact cumulative Arias intensity reaches target."""
    i = int(np.searchsorted(cum, target, side="left")) - 1
    i = min(max(i, 0), len(t) - 2)
    h, a0, m = t[i + 1] - t[i], a[i], (a[i + 1] - a[i]) / (t[i + 1] - t[i])
    k = math.pi / (2.0 * G0)  # as in cumulative_arias

    def f(s: float) -> float:
        return cum[i] + k * (a0 * a0 * s + a0 * m * s * s + m * m * s**3 / 3.0) - target

    if f(0.0) >= 0.0:
        return float(t[i])
    if f(h) <= 0.0:
        return float(t[i + 1])
    from scipy.optimize import brentq  # SciPy loads only for the measures that need it

    return float(t[i] + brentq(f, 0.0, h, xtol=1e-14 * max(1.0, t[i + 1]), rtol=1e-15))


def significant_duration(t: np.ndarray, a: np.ndarray, start: float = 0.05, end: float = 0.95) -> float:
    """Time between `start` and `end` fractions of the Arias intensity (s); 0 for a record of zeros."""
    t, a = _check(t, a)
    cum = cumulative_arias(t, a)
    if cum[-1] <= 0:
        return 0.0
    return _arias_time(t, a, cum, end * cum[-1]) - _arias_time(t, a, cum, start * cum[-1])


def mean_period(t: np.ndarray, a: np.ndarray, band: tuple[float, float] = MEAN_PERIOD_BAND) -> float:
    """Rathje et al. (1998) mean period (s); nan when the band holds no frequency of the record."""
    t, a = _check(t, a)
    h = np.diff(t)
    dt = float(np.min(h))
    if np.ptp(h) > 1e-9 * dt:  # irregular: resample at the smallest interval, on the same lines
        n = int(round((t[-1] - t[0]) / dt)) + 1
        tt = t[0] + dt * np.arange(n)
        a = np.interp(tt, t, a)
    c = np.abs(np.fft.rfft(a)) * dt
    f = np.fft.rfftfreq(a.size, dt)
    keep = (f >= band[0]) & (f <= band[1])
    c2 = c[keep] ** 2
    if not keep.any() or c2.sum() <= 0:
        return math.nan
    return float(np.sum(c2 / f[keep]) / np.sum(c2))


def measures(t: np.ndarray, a: np.ndarray) -> Measures:
    """All intensity measures of the horizontal acceleration a(t) (m/s^2 at times t in s)."""
    return Measures(pga=float(np.max(np.abs(_check(t, a)[1]))), pgv=peak_velocity(t, a),
                    pgd=peak_displacement(t, a), arias=arias_intensity(t, a), d5_95=significant_duration(t, a),
                    mean_period=mean_period(t, a))
