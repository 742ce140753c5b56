"""Elastic response spectra of a ground-acceleration record, exact for the signal the FMU integrates.

The FMU joins a record's samples by straight lines and takes the acceleration as zero before the first
sample and after the last (docs/records.md). A linear oscillator of period T (s) and damping ratio zeta,
at rest at the first sample,

    u'' + 2 zeta w u' + w^2 u = -a(t),   w = 2 pi / T,

has on each segment a closed-form response: the state at the samples follows the exact recurrence of
Nigam & Jennings (1969), and between two samples u is a particular straight line plus a damped
sinusoid. Its extrema inside a segment are the zeros of u'; u'' is a damped sinusoid alone (the
line's second derivative is zero), so its zeros are known in closed form and cut the segment into
pieces on which u' is monotone: each piece holds at most one zero of u', bracketed by the signs at
its ends and found by bisection. After the last sample the oscillator vibrates freely; its
extrema decay, so the first one after the end is the last candidate.

- ``Sd`` = max over t of |u| (m), the spectral displacement;
- ``Sa`` = w^2 Sd (m/s^2), the pseudo-spectral acceleration;
- ``Sv`` = w Sd (m/s), the pseudo-spectral velocity.

Units SI. Sign convention (docs/conventions.md): a > 0 accelerates the ground towards +x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SCALAR_PERIODS = 4  # at most this many periods: the recurrence runs on plain floats, one period at a time
BISECTIONS = 36  # halvings of a bracket: the extremum to 1.5e-11 of its segment, |u| there to rounding (its error is quadratic)


@dataclass(frozen=True)
class Spectrum:
    """Response spectrum at ``period`` (s) for damping ratio ``zeta``: Sd (m), Sv (m/s), Sa (m/s^2)."""

    period: np.ndarray
    zeta: float
    sd: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        return 2.0 * np.pi / self.period

    @property
    def sa(self) -> np.ndarray:
        return self.omega ** 2 * self.sd

    @property
    def sv(self) -> np.ndarray:
        return self.omega * self.sd


def _check(t: np.ndarray, a: np.ndarray, periods: np.ndarray, zeta: float) -> None:
    if t.ndim != 1 or a.shape != t.shape or len(t) < 2:
        raise ValueError("a record needs at least two samples of time and acceleration of the same length")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise ValueError("the record's times and accelerations must be finite numbers")
    if not np.all(np.diff(t) > 0):
        raise ValueError("the record's times must increase strictly")
    if not (np.all(np.isfinite(periods)) and np.all(periods > 0)):
        raise ValueError("periods must be finite and > 0 s")
    if not (0.0 <= zeta < 1.0):
        raise ValueError(f"the damping ratio {zeta} must be in [0, 1)")


class _Segments:
    """Closed forms of u on segments of length h (s) from (u0, v0) under a0 + a1 s, one oscillator
    per row of w (rad/s): u(s) = p0 + p1 s + e^(-sigma s) (A cos(wd s) + B sin(wd s))."""

    def __init__(self, w: np.ndarray, zeta: float, u0, v0, a0, a1):
        self.w, self.zeta = w, zeta
        self.sigma = zeta * w
        self.wd = w * np.sqrt(1.0 - zeta * zeta)
        self.p1 = -a1 / w ** 2
        self.p0 = -(a0 - 2.0 * zeta * a1 / w) / w ** 2
        self.A = u0 - self.p0
        self.B = (v0 - self.p1 + self.sigma * self.A) / self.wd

    def _damped(self, s):
        e = np.exp(-self.sigma * s)
        return e * np.cos(self.wd * s), e * np.sin(self.wd * s)

    def u(self, s):
        c, sn = self._damped(s)
        return self.p0 + self.p1 * s + self.A * c + self.B * sn

    def v(self, s):
        c, sn = self._damped(s)
        return self.p1 + (self.wd * self.B - self.sigma * self.A) * c - (self.wd * self.A + self.sigma * self.B) * sn

    def second_zero_phase(self):
        """phi in [0, pi) with u''(s) = 0 exactly where wd s = phi + k pi."""
        sg, wd = self.sigma, self.wd
        # u'' = e^(-sigma s) (C cos + D sin), the damped part's second derivative
        C = (sg * sg - wd * wd) * self.A - 2.0 * sg * wd * self.B
        D = (sg * sg - wd * wd) * self.B + 2.0 * sg * wd * self.A
        return np.mod(np.arctan2(-C, D), np.pi)


def _peaks_inside(seg: _Segments, h: np.ndarray) -> np.ndarray:
    """Largest |u| at the zeros of u' strictly inside each segment (0 where none)."""
    phi = seg.second_zero_phase()
    k_max = int(np.ceil(np.max(seg.wd * h) / np.pi)) + 1
    # the cuts: 0, the zeros of u'' inside, h; sorted (NaN last), then consecutive pairs bracket u''s zeros
    cuts = [np.zeros_like(h)]
    for k in range(k_max):
        s = (phi + k * np.pi) / seg.wd
        cuts.append(np.where((s > 0) & (s < h), s, np.nan))
    cuts.append(h)
    cuts = np.sort(np.array(cuts), axis=0)
    lo, hi = cuts[:-1], cuts[1:]
    ok = np.isfinite(lo) & np.isfinite(hi) & (hi > lo)
    shape = (cuts.shape[0] - 1,) + h.shape
    where = np.nonzero(ok)  # (cut, *index)
    lo, hi = lo[where], hi[where]
    index = where[1:]
    # the closed form of the segment each bracket belongs to
    pick = _Segments.__new__(_Segments)
    for name in ("w", "sigma", "wd", "p0", "p1", "A", "B"):
        value = np.broadcast_to(getattr(seg, name), h.shape)
        setattr(pick, name, value[index])
    vlo, vhi = pick.v(lo), pick.v(hi)
    bracket = np.sign(vlo) * np.sign(vhi) < 0
    best = np.zeros(shape)
    if bracket.any():
        for name in ("w", "sigma", "wd", "p0", "p1", "A", "B"):
            setattr(pick, name, getattr(pick, name)[bracket])
        a, b, fa = lo[bracket], hi[bracket], vlo[bracket]
        for _ in range(BISECTIONS):
            m = 0.5 * (a + b)
            fm = pick.v(m)
            left = np.sign(fm) == np.sign(fa)
            a = np.where(left, m, a)
            fa = np.where(left, fm, fa)
            b = np.where(left, b, m)
        cells = tuple(x[bracket] for x in where)
        best[cells] = np.abs(pick.u(0.5 * (a + b)))
    return best.max(axis=0)


def _affine_scan(a, b, c, d, e, f) -> tuple[np.ndarray, np.ndarray]:
    """Every (u, v) of the recurrence (u, v)_(i+1) = [[a_i, b_i], [c_i, d_i]] (u, v)_i + (e_i, f_i) from (0, 0):
    an inclusive scan over the affine maps, composed in log2(n) passes of whole arrays (Hillis & Steele 1986)
    instead of n steps of Python. The maps contract (a damped oscillator's), so the order of the sums costs
    rounding alone."""
    a, b, c, d, e, f = (np.array(x, dtype=float) for x in (a, b, c, d, e, f))
    s = 1
    while s < len(a):
        # map i after map i - s: M_i M_(i-s), M_i (e, f)_(i-s) + (e, f)_i
        a2, b2, c2, d2 = a[s:], b[s:], c[s:], d[s:]
        a1, b1, c1, d1, e1, f1 = a[:-s], b[:-s], c[:-s], d[:-s], e[:-s], f[:-s]
        e[s:], f[s:] = a2 * e1 + b2 * f1 + e[s:], c2 * e1 + d2 * f1 + f[s:]
        a[s:], b[s:], c[s:], d[s:] = a2 * a1 + b2 * c1, a2 * b1 + b2 * d1, c2 * a1 + d2 * c1, c2 * b1 + d2 * d1
        s *= 2
    return e, f


def _may_pass(w: np.ndarray, zeta: float, u: np.ndarray, v: np.ndarray, a: np.ndarray, h: np.ndarray,
              peak: np.ndarray) -> np.ndarray:
    """Which segments (rows) of which oscillators (columns) may hold a |u| above ``peak`` (each oscillator's
    largest at the samples): |u| on a segment exceeds the larger of its ends by at most h^2 / 8 max|u''|, and
    u'' = -a - 2 zeta w u' - w^2 u with R = sqrt(u'^2 + w^2 u^2) growing by at most |a| a second (R R' =
    -u' a - 2 zeta w u'^2), so max|u''| <= A + (2 zeta + 1) w (R0 + A h), A the larger |a| at the segment's ends."""
    A = np.maximum(np.abs(a[:-1]), np.abs(a[1:]))[:, None]
    R = np.sqrt(v[:-1] ** 2 + (w * u[:-1]) ** 2) + A * h
    excess = h * h / 8.0 * (A + (2.0 * zeta + 1.0) * w * R)
    return np.maximum(np.abs(u[:-1]), np.abs(u[1:])) + excess * (1.0 + 1e-9) >= peak


def _states(w: np.ndarray, zeta: float, t: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """u and u' at every sample (rows) of every oscillator (columns): Nigam & Jennings' recurrence, the
    exact map of a segment, linear in (u0, v0, a0, a1), with its coefficients computed once per length."""
    n = len(t)
    u = np.zeros((n, len(w)))
    v = np.zeros((n, len(w)))
    h = np.diff(t)
    slope = np.diff(a) / h
    if len(w) <= SCALAR_PERIODS:  # a few oscillators: each one's maps for every distinct length at once, then a scan
        lengths, which = np.unique(h, return_inverse=True)
        for k in range(len(w)):
            # the map's (u, v) rows: responses to unit u0, v0, a0, a1 over each length
            cu, cv = zip(*((seg.u(lengths), seg.v(lengths)) for seg in
                           (_Segments(w[k], zeta, *basis) for basis in np.eye(4))))
            cu, cv = np.array(cu)[:, which], np.array(cv)[:, which]
            u[1:, k], v[1:, k] = _affine_scan(cu[0], cu[1], cv[0], cv[1], cu[2] * a[:-1] + cu[3] * slope,
                                              cv[2] * a[:-1] + cv[3] * slope)
        return u, v
    maps: dict[float, tuple[np.ndarray, ...]] = {}
    zero, one = np.zeros_like(w), np.ones_like(w)
    for i, hi in enumerate(h.tolist()):
        if hi not in maps:
            hh = np.full_like(w, hi)
            cols = []
            for basis in ((one, zero, zero, zero), (zero, one, zero, zero), (zero, zero, one, zero), (zero, zero, zero, one)):
                seg = _Segments(w, zeta, *basis)
                cols.append((seg.u(hh), seg.v(hh)))
            cu, cv = (np.array(c) for c in zip(*cols))  # (u row: 4 coefficients), (v row)
            maps[hi] = (cu, cv)
    for i, hi in enumerate(h.tolist()):
        cu, cv = maps[hi]
        u[i + 1] = cu[0] * u[i] + cu[1] * v[i] + cu[2] * a[i] + cu[3] * slope[i]
        v[i + 1] = cv[0] * u[i] + cv[1] * v[i] + cv[2] * a[i] + cv[3] * slope[i]
    return u, v


def spectrum(t, a, periods, zeta: float = 0.05) -> Spectrum:
    """The response spectrum of the record (t in s, a in m/s^2) at ``periods`` (s), damping ratio ``zeta``."""
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    periods = np.atleast_1d(np.asarray(periods, float))
    _check(t, a, periods, zeta)
    w = 2.0 * np.pi / periods
    u, v = _states(w, zeta, t, a)
    peak = np.abs(u).max(axis=0)
    # inside the segments that may hold more than the samples' peak (_may_pass), all at once
    h = np.diff(t)[:, None] * np.ones_like(w)
    slope = (np.diff(a) / np.diff(t))[:, None]
    seg, osc = np.nonzero(_may_pass(w, zeta, u, v, a, h, peak))
    if seg.size:
        segments = _Segments(w[osc], zeta, u[seg, osc], v[seg, osc], a[seg], slope[seg, 0])
        np.maximum.at(peak, osc, _peaks_inside(segments, h[seg, osc]))
    # free vibration after the last sample (a = 0): its first extremum is its largest
    free = _Segments(w, zeta, u[-1], v[-1], 0.0, 0.0)
    theta = np.mod(np.arctan2(free.wd * free.B - free.sigma * free.A, free.wd * free.A + free.sigma * free.B), np.pi)
    peak = np.maximum(peak, np.abs(free.u(theta / free.wd)))
    return Spectrum(periods, zeta, peak)


def pseudo_acceleration(t, a, period: float, zeta: float = 0.05) -> float:
    """Sa(T, zeta) (m/s^2) of the record: omega^2 times the largest |u|."""
    return float(spectrum(t, a, [period], zeta).sa[0])
