"""The motion of a support's floor under a record, for intensity measures and floor spectra.

A support (docs/supports.md: a shear building, or an isolation platform) under a base acceleration
a_g(t) linear between the record's samples is a linear system z' = A z + B a_g(t), z the floors'
displacements and velocities relative to the base. On each segment of the record its flow is exact:
the matrix exponential of the system augmented by the input and its slope (Van Loan 1978),
computed once per segment length. The blocks' floor j then has the absolute acceleration
a_f = a_g + u_j'' at any time. (RockingBlock.fmu computes the same motion by another road, the
modes in closed form, model/c/support.c; tests/test_floor_motion.py compares them.)

- :func:`floor_acceleration` at given times (m/s^2);
- :func:`peak_floor_acceleration`: PFA (m/s^2), the largest |a_f| over the record and the free
  vibration after it, located on a grid of ``GRID`` points per period of the support's fastest
  mode, but no finer than ``SEGMENT_GRID`` per record interval (every sample among them), then refined
  around the largest grid values by Newton's method on a_f' = 0 (a_f' and a_f'' exact from the state):
  the value is exact at the peak found;
- :func:`floor_spectrum`: the pseudo-spectral acceleration of a_f (runners.engine.spectra), a_f
  sampled exactly on that grid and joined by straight lines (relative error of the order of
  (w dt_grid)^2 / 8 at the oscillator's w: below 1e-3 over 0.02 to 5 s on the docs' frames).

Units SI; a > 0 towards +x (docs/conventions.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from runners.engine import spectra

GRID = 64  # points per period of the fastest mode...
SEGMENT_GRID = 16  # ...but no finer than this many per record interval (a mode that fast barely moves the floor)
TAIL_PERIODS = 5.0  # the free vibration is followed for this many periods of the slowest mode
REFINED = 3  # grid maxima refined by Newton's method


@dataclass(frozen=True)
class Support:
    """A support's linear system: z' = A z + B a_g, the floor's row j (0-based) of u, its modes' periods (s)."""

    A: np.ndarray
    B: np.ndarray
    floor: int
    periods: np.ndarray  # natural periods, s (inf for a platform without spring)

    @property
    def n(self) -> int:
        return self.A.shape[0] // 2


def support_of(p: dict[str, Any]) -> Support | None:
    """The support of RockingBlock.fmu's parameters ``p`` (support.kind and building.* or platform.*),
    None on the ground."""
    kind = int(p.get("support.kind", 0))
    if kind == 0:
        return None
    if kind == 2:
        m, k, c = float(p["platform.mass"]), float(p["platform.stiffness"]), float(p["platform.damping"])
        M, K, C, floor = np.array([[m]]), np.array([[k]]), np.array([[c]]), 0
    elif kind == 1:
        n = int(p["building.storeys"])
        m = np.array([float(p[f"building.storey[{i}].mass"]) for i in range(1, n + 1)])
        k = np.append([float(p[f"building.storey[{i}].stiffness"]) for i in range(1, n + 1)], 0.0)
        M = np.diag(m)
        K = np.diag(k[:n] + k[1:]) - np.diag(k[1:n], 1) - np.diag(k[1:n], -1)
        w = np.sqrt(_squared_frequencies(K, m))
        zeta = float(p["building.dampingRatio"])
        a0, a1 = (2 * zeta * w[0] * w[1] / (w[0] + w[1]), 2 * zeta / (w[0] + w[1])) if n > 1 else (0.0, 2 * zeta / w[0])
        C = a0 * M + a1 * K
        floor = (int(p.get("building.floor", 0)) or n) - 1
    else:
        raise ValueError(f"support.kind = {kind} is not a support (0 ground, 1 building, 2 platform)")
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.r_[np.zeros(n), -np.ones(n)]
    w2 = _squared_frequencies(K, np.diag(M))
    periods = np.array([2 * math.pi / math.sqrt(x) if x > 0 else math.inf for x in w2])
    return Support(A, B, floor, periods)


def _squared_frequencies(K: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The eigenvalues w^2 (1/s^2, ascending) of K x = w^2 M x for the diagonal mass matrix of masses m (kg):
    those of the symmetric M^-1/2 K M^-1/2 (numpy's eigvalsh; scipy.linalg's import alone took 0.2 s of every
    study on a support)."""
    d = 1.0 / np.sqrt(np.asarray(m, float))
    return np.linalg.eigvalsh(d[:, None] * K * d[None, :])


class _Flow:
    """The exact flow of the augmented system over offsets h: [z, a0, a1] -> z(h), cached by h."""

    def __init__(self, s: Support):
        n2 = 2 * s.n
        self.aug = np.zeros((n2 + 2, n2 + 2))
        self.aug[:n2, :n2] = s.A
        self.aug[:n2, n2] = s.B
        self.aug[n2, n2 + 1] = 1.0
        self.cache: dict[float, np.ndarray] = {}
        self.n2 = n2

    def matrix(self, h: float) -> np.ndarray:
        m = self.cache.get(h)
        if m is None:
            from scipy.linalg import expm  # (imported here: only the reference path needs it)

            m = self.cache[h] = expm(self.aug * h)[:self.n2]
        return m


def _segments(t: np.ndarray, a: np.ndarray, s: Support, flow: _Flow) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The state at each sample and each segment's (a0, slope); the last 'segment' is the free vibration."""
    slope = np.append(np.diff(a) / np.diff(t), 0.0)
    a0 = np.append(a[:-1], 0.0)
    n2 = 2 * s.n
    z = np.zeros((len(t), n2))
    parts: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for i, h in enumerate(np.diff(t).tolist()):
        if h not in parts:
            m = flow.matrix(h)
            parts[h] = (m[:, :n2], m[:, n2], m[:, n2 + 1])
        F, fa, fs = parts[h]
        z[i + 1] = F @ z[i] + fa * a0[i] + fs * slope[i]
    return z, a0, slope


def _acceleration(s: Support, z: np.ndarray, ag: np.ndarray) -> np.ndarray:
    """a_f = a_g + u_j'' of states z (rows) under base accelerations ag."""
    j = s.n + s.floor
    return ag + z @ s.A[j] + s.B[j] * ag


def _grid(t: np.ndarray, s: Support) -> tuple[np.ndarray, float]:
    fastest = float(np.min(s.periods))
    slowest = float(np.max(s.periods[np.isfinite(s.periods)])) if np.isfinite(s.periods).any() else 1.0
    coarsest = float(np.min(np.diff(t))) / SEGMENT_GRID
    dt = max(fastest / GRID, coarsest) if math.isfinite(fastest) else coarsest
    return dt, t[-1] + min(TAIL_PERIODS * slowest, 60.0)


class FloorMotion:
    """The floor's absolute acceleration under one record (t in s, a in m/s^2), at any time."""

    def __init__(self, p: dict[str, Any], t, a):
        self.support = support_of(p)
        if self.support is None:
            raise ValueError("the blocks stand on the ground: no floor motion (support.kind = 0)")
        self.t = np.asarray(t, float)
        self.a = np.asarray(a, float)
        self.flow = _Flow(self.support)
        self.z, self.a0, self.slope = _segments(self.t, self.a, self.support, self.flow)

    def __call__(self, times) -> np.ndarray:
        times = np.atleast_1d(np.asarray(times, float))
        out = np.zeros(len(times))
        i = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, len(self.t) - 1)
        inside = times >= self.t[0]
        for k in np.nonzero(inside)[0]:
            h = float(times[k] - self.t[i[k]])
            z = self.flow.matrix(h) @ np.r_[self.z[i[k]], self.a0[i[k]], self.slope[i[k]]]
            ag = self.a0[i[k]] + self.slope[i[k]] * h
            out[k] = _acceleration(self.support, z[None, :], np.array([ag]))[0]
        return out

    def peak(self) -> float:
        """PFA (m/s^2): the grid's largest |a_f|, each of the REFINED largest refined by Newton's method."""
        times, acc = self.sampled()
        best = float(np.abs(acc).max())
        step = float(np.max(np.diff(times))) if len(times) > 1 else 0.0
        for k in np.argsort(-np.abs(acc))[:REFINED]:
            best = max(best, self._extremum(float(times[k]), max(times[0], times[k] - step),
                                            min(times[-1], times[k] + step)))
        return best

    def _extremum(self, t: float, lo: float, hi: float) -> float:
        """|a_f| at the zero of a_f' that Newton's method finds from t inside [lo, hi] (|a_f(t)| if it leaves
        the interval or stalls). On a record segment a_g is linear, so with z' = A z + B a_g:
        a_f' = A_j z' + (B_j + 1) a_g' and a_f'' = A_j (A z' + B a_g')."""
        s, j = self.support, self.support.n + self.support.floor
        value = abs(float(self(t)[0]))
        for _ in range(12):
            i = min(max(int(np.searchsorted(self.t, t, side="right")) - 1, 0), len(self.t) - 1)
            h = t - float(self.t[i])
            z = self.flow.matrix(h) @ np.r_[self.z[i], self.a0[i], self.slope[i]]
            zd = s.A @ z + s.B * (self.a0[i] + self.slope[i] * h)
            d1 = float(s.A[j] @ zd + (s.B[j] + 1.0) * self.slope[i])
            d2 = float(s.A[j] @ (s.A @ zd + s.B * self.slope[i]))
            if d2 == 0.0:
                break
            tn = t - d1 / d2
            if not lo <= tn <= hi:
                break
            done = abs(tn - t) <= 8 * np.finfo(float).eps * max(abs(t), 1.0)
            t = tn
            value = max(value, abs(float(self(t)[0])))
            if done:
                break
        return value

    def spectrum(self, periods, zeta: float = 0.05) -> np.ndarray:
        """Pseudo-spectral acceleration (m/s^2) of a_f at ``periods`` (s): a_f on the grid, joined by lines."""
        times, acc = self.sampled()
        return spectra.spectrum(times, acc, periods, zeta).sa

    def sampled(self) -> tuple[np.ndarray, np.ndarray]:
        """(times, a_f) on the grid: every segment cut into pieces of at most the grid step, and the free
        vibration after the record."""
        if getattr(self, "_sampled", None) is None:
            self._sampled = self._sample()
        return self._sampled

    def _sample(self) -> tuple[np.ndarray, np.ndarray]:
        dt, end = _grid(self.t, self.support)
        pieces = np.maximum(1, np.ceil(np.diff(self.t) / dt).astype(int))
        times, acc = [], []
        for m in np.unique(pieces):  # segments cut into m pieces, all at once
            seg = np.nonzero(pieces == m)[0]
            for f in range(m):
                h = np.diff(self.t)[seg] * f / m
                for hv in np.unique(h):
                    sel = seg[h == hv]
                    Z = np.c_[self.z[sel], self.a0[sel], self.slope[sel]] @ self.flow.matrix(float(hv)).T
                    times.append(self.t[sel] + hv)
                    acc.append(_acceleration(self.support, Z, self.a0[sel] + self.slope[sel] * hv))
        tail = dt * np.arange(int(np.ceil((end - self.t[-1]) / dt)))
        step = self.flow.matrix(dt)[:, :2 * self.support.n]  # a = 0 after the record
        Z = np.empty((len(tail), 2 * self.support.n))
        Z[0] = self.z[-1]
        for k in range(1, len(tail)):
            Z[k] = step @ Z[k - 1]
        times.append(self.t[-1] + tail)
        acc.append(_acceleration(self.support, Z, np.zeros(len(tail))))
        times, acc = np.concatenate(times), np.concatenate(acc)
        order = np.argsort(times, kind="stable")
        return times[order], acc[order]


def peak_floor_acceleration(p: dict[str, Any], t, a) -> float:
    """PFA (m/s^2): the largest |a_f| of the floor the blocks stand on, under the record (t, a)."""
    return FloorMotion(p, t, a).peak()


def floor_spectrum(p: dict[str, Any], t, a, periods, zeta: float = 0.05) -> np.ndarray:
    """Pseudo-spectral acceleration (m/s^2) of the floor's absolute acceleration at ``periods`` (s)."""
    return FloorMotion(p, t, a).spectrum(periods, zeta)


def first_period(p: dict[str, Any]) -> float | None:
    """The support's fundamental period (s), None on the ground or for a platform without spring."""
    s = support_of(p)
    if s is None or not np.isfinite(s.periods).any():
        return None
    return float(np.max(s.periods[np.isfinite(s.periods)]))


# the measures of a record through a support (m/s^2, scaled with the record; intensity.SUPPORT_MEASURES):
# the peak floor acceleration and the base's Sa at the support's fundamental period, 5 % damping
SA_DAMPING = 0.05


def fmu_peak_floor_accelerations(fmu, p: dict[str, Any], record_files) -> list[float]:
    """PFA (m/s^2) of the bare support of FMU parameters ``p`` under each record file at scale 1, as
    RockingBlock.fmu computes it at initialisation (``fmu``, a runners.engine.fmu.RockingFMU; its output
    support.peakFloorAcceleration: the extrema of the support's closed form located by its bound-certified search,
    model/c/support.c). It equals :func:`peak_floor_acceleration` to rounding (tests/test_floor_motion.py) at a
    fraction of its cost. (Computed one-way whatever ``p``'s coupling: the bare support's motion is the same, and a
    two-way instance would also build the table of the blocks at rest, which this does not read.)"""
    return fmu.initial_values(({**p, "support.coupling": 0, "excitation.kind": 4, "excitation.file": str(f),
                                "excitation.scale": 1.0} for f in record_files), "support.peakFloorAcceleration")


def base_measures(p: dict[str, Any], t, a) -> dict[str, float]:
    """{"sa_t1": Sa(T1, 5 %)} (m/s^2) of the record (t, a) at the base of the support of FMU parameters ``p``
    (empty for a platform without spring)."""
    T1 = first_period(p)
    return {} if T1 is None else {"sa_t1": spectra.pseudo_acceleration(t, a, T1, SA_DAMPING)}


# periods of a floor spectrum (s): 0.02 to 5 s, 48 of them evenly in log (and the support's own)
SPECTRUM_PERIODS = np.geomspace(0.02, 5.0, 48)


@dataclass(frozen=True)
class FloorSpectra:
    """Response spectra (5 % damping) of each record of a study at the base and on the blocks' floor, per
    unit of the base's PGA: Sa / PGA (1), at ``periods`` (s); rows in the order of ``records``."""

    periods: np.ndarray
    records: list[str]
    base: np.ndarray
    floor: np.ndarray
    pfa: np.ndarray  # each record's PFA / PGA
    support_periods: np.ndarray  # the support's natural periods, s
    description: str

    def percentiles(self, which: str, q=(16, 50, 84)) -> np.ndarray:
        """Percentiles over the records of the base's or the floor's spectrum, at each period."""
        return np.percentile(getattr(self, which), q, axis=0)

    def as_dict(self) -> dict[str, Any]:
        b16, b50, b84 = self.percentiles("base")
        f16, f50, f84 = self.percentiles("floor")
        return {"periods_s": self.periods.tolist(), "support": self.description,
                "support_periods_s": self.support_periods.tolist(), "records": self.records,
                "base_median": b50.tolist(), "base_p16": b16.tolist(), "base_p84": b84.tolist(),
                "floor_median": f50.tolist(), "floor_p16": f16.tolist(), "floor_p84": f84.tolist(),
                "pfa_over_pga_median": float(np.median(self.pfa)), "damping_ratio": SA_DAMPING}


def floor_spectra(p: dict[str, Any], records: list[tuple[str, np.ndarray, np.ndarray]],
                  periods=SPECTRUM_PERIODS, progress=None) -> FloorSpectra:
    """The spectra of ``records`` ((name, t in s, a in m/s^2), unscaled: the spectra are per unit PGA) at the
    base and on the floor of the support of FMU parameters ``p``. ``progress(i)`` after each record."""
    from runners.engine import supports

    s = support_of(p)
    if s is None:
        raise ValueError("the scene's blocks stand on the ground: a floor spectrum needs a [building] or [platform]")
    own = s.periods[np.isfinite(s.periods)]
    periods = np.unique(np.concatenate([np.asarray(periods, float), own[(own >= periods[0]) & (own <= periods[-1])]]))
    base, floor, pfa = [], [], []
    for i, (_, t, a) in enumerate(records):
        pga = float(np.abs(a).max())
        if not pga > 0:
            raise ValueError(f"record {records[i][0]} has no acceleration")
        motion = FloorMotion(p, t, a)
        base.append(spectra.spectrum(t, a, periods, SA_DAMPING).sa / pga)
        floor.append(motion.spectrum(periods, SA_DAMPING) / pga)
        pfa.append(motion.peak() / pga)
        if progress:
            progress(i)
    return FloorSpectra(np.asarray(periods, float), [r[0] for r in records], np.array(base), np.array(floor),
                        np.array(pfa), s.periods, supports.describe(p) or "")
