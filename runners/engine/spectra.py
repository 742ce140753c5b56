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

# _states' blocks: at most e^BLOCK_DECAY between a block's largest and smallest exponential (e^709 overflows),
# and arguments of at most BLOCK_PHASE radians (their rounding, BLOCK_PHASE x 1.1e-16, stays below 1e-13)
BLOCK_DECAY = 300.0
BLOCK_PHASE = 500.0
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
    """u and u' at every sample (rows) of every oscillator (columns): Nigam & Jennings' exact map of each
    segment, in the oscillator's modal coordinate, by blocks of numpy sums.

    (u, u') = 2 Re(p z) with p = (1, mu), mu = -zeta w + i w_d: p is the eigenvector whatever a segment's
    length, so z = q (u, u') (q the left eigenvector, q p = 1) goes over segment i to e^(mu h_i) z plus g_i,
    its forcing's response from rest (_Segments' closed forms, into z by q). From a block's first sample s,

        z_(s+j) = e^(mu tau_j) (z_s + sum_(i<j) e^(-mu tau_(i+1)) g_(s+i)),   tau_j = t_(s+j) - t_s,

    the exponentials taken from the times themselves (exact for any sampling), each block short enough that
    they stay far inside the doubles' range and their arguments' rounding far below the result's (BLOCK_DECAY,
    BLOCK_PHASE). The sums' rounding is the recurrence's: each term is about its share of z."""
    n, w = len(t), np.asarray(w, float)
    h = np.diff(t)
    slope = np.diff(a) / h
    wd = w * np.sqrt(1.0 - zeta * zeta)
    mu = -zeta * w + 1j * wd
    q1, q2 = -np.conj(mu) / (2j * wd), 1.0 / (2j * wd)
    # each distinct length's responses from rest to a unit a0 and a unit a1, in z (lengths x oscillators)
    lengths, which = np.unique(h, return_inverse=True)
    s0 = _Segments(w[None, :], zeta, 0.0, 0.0, 1.0, 0.0)
    s1 = _Segments(w[None, :], zeta, 0.0, 0.0, 0.0, 1.0)
    L = lengths[:, None]
    c0, c1 = q1 * s0.u(L) + q2 * s0.v(L), q1 * s1.u(L) + q2 * s1.v(L)
    g = c0[which] * a[:-1, None] + c1[which] * slope[:, None]
    z = np.zeros((n, len(w)), dtype=complex)
    span = min(BLOCK_PHASE / np.max(np.abs(mu)), BLOCK_DECAY / max(zeta * np.max(w), 1e-300))
    s = 0
    while s < n - 1:
        e = min(max(int(np.searchsorted(t, t[s] + span, side="right")) - 1, s + 1), n - 1)
        tau = (t[s + 1:e + 1] - t[s])[:, None]
        if e == s + 1 and zeta * np.max(w) * tau[0, 0] > BLOCK_DECAY:  # one segment longer than a block
            z[e] = np.exp(mu * tau[0]) * z[s] + g[s]
        else:
            E = np.exp(mu * tau)
            z[s + 1:e + 1] = E * (z[s] + np.cumsum(g[s:e] / E, axis=0))
        s = e
    return 2.0 * z.real, 2.0 * (mu * z).real


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
