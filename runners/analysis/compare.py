"""Measured against simulated rocking: aligned errors of peak angles, impact times and theta.

Conventions (docs/measured.md):

- A **peak table**'s first row is the release: time 0 of the run and the initial
  angle. The following rows are the successive peaks, matched in order with the
  run's peak events. Angles are compared in magnitude.
- A **rotation history** is on the run's time axis. theta is compared at the
  measured times (the run's output linearly interpolated). Measured impacts are
  the zero crossings of theta, and measured peaks are the largest |theta|
  between two crossings. A crossing counts only once theta has gone beyond
  the measurement's stated angle uncertainty on the other side, so noise
  around rest makes none. Each is matched with the nearest simulated one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Decay:
    """A free-rocking decay: the release and the successive peaks (s, rad, magnitudes)."""

    t0: float
    theta0: float  # signed: the side the block was released on
    times: np.ndarray  # peak times, s, from the release
    amplitudes: np.ndarray  # |theta| at the peaks, rad


def decay_from_peaks(time: np.ndarray, theta: np.ndarray) -> Decay:
    if len(time) < 2:
        raise ValueError("a peak table needs the release and at least one peak")
    return Decay(float(time[0]), float(theta[0]), np.asarray(time[1:]) - time[0], np.abs(theta[1:]))


def _crossing_indices(theta: np.ndarray, band: float) -> np.ndarray:
    """Indices k where theta changes side between samples k and k+1, counting a change only
    once |theta| has gone beyond `band` on the other side (noise within it is not a crossing)."""
    big = np.nonzero(np.abs(theta) > band)[0]
    if len(big) < 2:
        return np.array([], dtype=int)
    side = np.sign(theta[big])
    flips = np.nonzero(side[:-1] * side[1:] < 0)[0]
    out = []
    for f in flips:
        i, j = big[f], big[f + 1]
        seg = np.sign(theta[i:j + 1])
        k = np.nonzero(seg[:-1] * seg[1:] <= 0)[0]
        out.append(i + int(k[0]) if len(k) else i)
    return np.array(out, dtype=int)


def crossings(time: np.ndarray, theta: np.ndarray, band: float = 0.0) -> np.ndarray:
    """Times where theta changes sign (s), by linear interpolation; see _crossing_indices."""
    k = _crossing_indices(theta, band)
    dth = theta[k + 1] - theta[k]
    frac = np.divide(-theta[k], dth, out=np.zeros(len(k)), where=dth != 0)
    return time[k] + frac * (time[k + 1] - time[k])


def extrema(time: np.ndarray, theta: np.ndarray, band: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(times, |theta|) of the largest |theta| between consecutive crossings (see crossings)."""
    edges = np.concatenate([[0], _crossing_indices(theta, band) + 1, [len(theta)]])
    t, a = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi - lo >= 1:
            j = lo + int(np.argmax(np.abs(theta[lo:hi])))
            if abs(theta[j]) > band:
                t.append(time[j])
                a.append(abs(theta[j]))
    return np.array(t), np.array(a)


def decay_from_rotation(time: np.ndarray, theta: np.ndarray, band: float = 0.0) -> Decay:
    """The release (first sample) and the extrema after it."""
    t, a = extrema(time, theta, band)
    keep = t > time[0]
    return Decay(float(time[0]), float(theta[0]), t[keep] - time[0], a[keep])


@dataclass
class Comparison:
    """Aligned errors, simulated minus measured (rad, s)."""

    peak_pairs: list[tuple[float, float, float, float]] = field(default_factory=list)  # t_meas, t_sim, |th| m, s
    impact_pairs: list[tuple[float, float]] = field(default_factory=list)  # t_meas, t_sim
    theta_rms: float | None = None  # rad, rotation histories only
    theta_max: float | None = None
    samples: int = 0
    missing_peaks: int = 0  # measured peaks the run does not reach (it came to rest, say)

    def peak_errors(self) -> tuple[np.ndarray, np.ndarray]:
        a = np.array(self.peak_pairs).reshape(-1, 4)
        return a[:, 3] - a[:, 2], a[:, 1] - a[:, 0]

    def impact_errors(self) -> np.ndarray:
        a = np.array(self.impact_pairs).reshape(-1, 2)
        return a[:, 1] - a[:, 0]


def _nearest(targets: np.ndarray, values: np.ndarray) -> np.ndarray:
    idx = np.clip(np.searchsorted(values, targets), 1, max(len(values) - 1, 1))
    left, right = values[idx - 1], values[np.minimum(idx, len(values) - 1)]
    return np.where(np.abs(targets - left) <= np.abs(targets - right), left, right)


def compare_peaks(decay: Decay, sim_peak_times: np.ndarray, sim_peak_theta: np.ndarray) -> Comparison:
    """Peak table against a run's peak events, in order."""
    c = Comparison()
    n = min(len(decay.times), len(sim_peak_times))
    for i in range(n):
        c.peak_pairs.append((decay.times[i], float(sim_peak_times[i]), decay.amplitudes[i],
                             abs(float(sim_peak_theta[i]))))
    c.missing_peaks = len(decay.times) - n
    return c


def compare_rotation(t_meas: np.ndarray, th_meas: np.ndarray, t_sim: np.ndarray, th_sim: np.ndarray,
                     sim_impacts: np.ndarray, sim_peak_times: np.ndarray, sim_peak_theta: np.ndarray,
                     band: float = 0.0) -> Comparison:
    """A rotation history against a run's output and events; measured crossings and peaks
    count only beyond `band` (the measurement's angle uncertainty, so noise makes none)."""
    c = Comparison()
    inside = (t_meas >= t_sim[0]) & (t_meas <= t_sim[-1])
    if inside.sum() < 2:
        raise ValueError(f"the measurement ({t_meas[0]:g} to {t_meas[-1]:g} s) and the run "
                         f"({t_sim[0]:g} to {t_sim[-1]:g} s) hardly overlap in time")
    err = np.interp(t_meas[inside], t_sim, th_sim) - th_meas[inside]
    c.theta_rms, c.theta_max, c.samples = float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err))), int(inside.sum())
    meas_impacts = crossings(t_meas, th_meas, band)
    if len(sim_impacts) and len(meas_impacts):
        c.impact_pairs = list(zip(meas_impacts, _nearest(meas_impacts, np.sort(sim_impacts))))
    tp, ap = extrema(t_meas, th_meas, band)
    if len(sim_peak_times) and len(tp):
        order = np.argsort(sim_peak_times)
        st, sa = np.asarray(sim_peak_times)[order], np.abs(np.asarray(sim_peak_theta))[order]
        near = _nearest(tp, st)
        c.peak_pairs = [(t, s, a, float(sa[np.searchsorted(st, s)])) for t, s, a in zip(tp, near, ap)]
    return c


def format_comparison(c: Comparison, sigma_theta: float | None, sigma_time: float | None) -> str:
    """A short report; errors are compared with the measurement's stated uncertainty."""
    deg = 180 / np.pi
    lines = []
    unc = (f"measurement uncertainty: theta +-{sigma_theta * deg:.3g} deg" if sigma_theta else
           "measurement uncertainty: not stated") + (f", time +-{sigma_time:.3g} s" if sigma_time else "")
    lines.append(unc)
    if c.theta_rms is not None:
        lines.append(f"theta            RMS error {c.theta_rms:.4g} rad ({c.theta_rms * deg:.3g} deg), "
                     f"largest {c.theta_max:.4g} rad over {c.samples} samples")
    if c.peak_pairs:
        da, dt = c.peak_errors()
        within = "" if not sigma_theta else f", {int(np.sum(np.abs(da) <= sigma_theta))}/{len(da)} within +-theta"
        lines.append(f"peak angles      {len(da)} matched: RMS error {np.sqrt(np.mean(da ** 2)) * deg:.3g} deg, "
                     f"largest {np.max(np.abs(da)) * deg:.3g} deg{within}")
        within_t = "" if not sigma_time else f", {int(np.sum(np.abs(dt) <= sigma_time))}/{len(dt)} within +-time"
        lines.append(f"peak times       RMS error {np.sqrt(np.mean(dt ** 2)):.3g} s, largest "
                     f"{np.max(np.abs(dt)):.3g} s{within_t}")
    if c.missing_peaks:
        lines.append(f"missing          the run has no peak for the last {c.missing_peaks} measured peaks")
    if c.impact_pairs:
        di = c.impact_errors()
        lines.append(f"impact times     {len(di)} matched: RMS error {np.sqrt(np.mean(di ** 2)):.3g} s, "
                     f"largest {np.max(np.abs(di)):.3g} s")
    return "\n".join(lines)


def plot_comparison(png, title: str, t_sim: np.ndarray, th_sim: np.ndarray, t_meas: np.ndarray,
                    th_meas: np.ndarray, sigma_theta: float | None, sigma_time: float | None, mirror: bool) -> None:
    """theta against time: the run as a line, the measurement as points with error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    ax.plot(t_sim, th_sim, color="C0", lw=1.2, label="simulated")
    if mirror:  # measured peak magnitudes: each may be on either side
        ax.plot(t_sim, -th_sim, color="C0", lw=0.6, alpha=0.4)
    ax.errorbar(t_meas, th_meas, yerr=sigma_theta, xerr=sigma_time, fmt="o", ms=4, color="C3", capsize=2,
                elinewidth=0.8, label="measured" + (" (+- stated uncertainty)" if sigma_theta else ""))
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("theta (rad)")
    ax.set_title(title)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
