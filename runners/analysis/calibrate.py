"""Calibrating the restitution of one block on a measured free-rocking decay.

The model is the FMU's one block released at rest from theta0 (fitted too, as a
nuisance parameter). Its peak events, in order, are matched with the measured
peaks (runners.analysis.compare.Decay). The residuals are

    (|theta_sim,i| - |theta_meas,i|) / sigma_theta   and   (t_sim,i - t_meas,i) / sigma_t.

They are minimised by scipy.optimize.least_squares over the law's parameter
and theta0:

- ``constant``: eta, the ratio of angular velocities after/before impact;
- ``modified``: the impact position k;
- ``correction``: the factor on Housner's coefficient (Anagnostopoulos, BEng thesis, Table 3).

A measured peak that the model does not reach (the block came to rest first)
counts as a simulated amplitude of zero.

The confidence interval is the linearised one of the fit: the covariance is
(J^T J)^-1 scaled by the reduced chi-square, as scipy's curve_fit does with
absolute_sigma=False, so stated uncertainties weight angles against times.
The 95% interval uses Student's t with n - 2 degrees of freedom.

:func:`assess` judges a fit before anyone believes it (runners calibrate refuses to
store one it finds poor). A fit is poor when

- chi2/dof exceeds CHI2_LIMIT = 5. If the model describes the data and the stated
  uncertainty is right, chi2/dof averages 1 and exceeds 5 with a probability below
  0.05% even at the fewest degrees of freedom a calibration has (4: three peaks), and
  far less with more peaks. Beyond it, the model does not describe the data, or the
  scatter is more than sqrt(5) = 2.2 times the stated uncertainty;
- the parameter (or theta0) stopped at a bound of the search: the optimum lies outside
  it, and the linearised interval means nothing there;
- the 95% interval is not finite or leaves the parameter's physical range: eta in
  (0, 1] (an impact cannot add energy); k in [0, 1] (the impact point lies between the
  centre and the corner); the correction factor in (0, 1/r], so that the corrected
  coefficient f r stays in (0, 1].

It also says why, where the data show it: peaks that grow, peaks that come far sooner
or later than the block's (time units), a release beyond the block's slenderness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from model.reference import housner_restitution
from runners.analysis.compare import Decay
from runners.engine.fmu import RockingFMU

LAW_PARAMETERS = {  # law -> (restitution.law, FMU parameter, lower bound, upper bound, start)
    "constant": (2, "restitution.eta", 0.05, 1.0, 0.9),
    "modified": (1, "restitution.k", 0.0, 1.0, 0.8),
    "correction": (0, "restitution.correction", 0.3, None, 1.0),
}
THESIS_SIGMA = (0.5 * math.pi / 180, 0.1)  # rad, s: Anagnostopoulos (BEng thesis) section 4.2, used when none is stated
PARAMETER_NAMES = {"constant": "eta", "modified": "k", "correction": "correction factor"}
CHI2_LIMIT = 5.0  # chi2/dof beyond which a fit is poor (module docstring: P < 0.05% at 4 dof)
TIME_SCALE_LIMIT = 3.0  # measured peaks this many times sooner or later than the model's: units?


@dataclass
class Fit:
    law: str
    value: float
    low: float  # 95% interval
    high: float
    theta0: float  # rad, signed
    chi2_per_dof: float
    dof: int
    evaluations: int
    sigma_theta: float
    sigma_time: float
    sigma_assumed: bool
    alpha: float = math.nan  # the block's slenderness, rad
    bounds: tuple[float, float] = (-math.inf, math.inf)  # the search's bounds on the parameter
    at_bound: tuple[int, int] = (0, 0)  # parameter, theta0: -1 at the lower bound, 1 at the upper, else 0
    sim_times: np.ndarray | None = None  # the model's peaks at the fit (s from the release)
    sim_amplitudes: np.ndarray | None = None  # rad


def physical_range(law: str, alpha: float) -> tuple[float, float, bool, str]:
    """(low, high, low excluded, text) of the law's parameter: eta in (0, 1], k in [0, 1],
    the correction factor in (0, 1/r] so that the corrected coefficient stays in (0, 1]."""
    if law == "constant":
        return 0.0, 1.0, True, "(0, 1]"
    if law == "modified":
        return 0.0, 1.0, False, "[0, 1]"
    top = 1.0 / housner_restitution(alpha)
    return 0.0, top, True, f"(0, {top:.4g}]"


def simulate_peaks(fmu: RockingFMU, base: dict, law: str, value: float, theta0: float, stop_time: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(times, theta) of the one-block model's peak events, released at rest from theta0."""
    code, name, *_ = LAW_PARAMETERS[law]
    p = {**base, "nBlocks": 1, "restitution.law": code, "restitution.correction": 1.0, name: value,
         "block1.theta0": theta0, "block1.omega0": 0.0, "excitation.kind": 0}  # the fitted law alone
    res = fmu.run(p, stop_time, stop_time, outputs=["block1.theta"])
    return res.event_times("peak"), res.event_values("peak", "theta")


def calibrate(fmu: RockingFMU, base: dict, decay: Decay, law: str, sigma_theta: float | None = None,
              sigma_time: float | None = None, progress: bool = False) -> Fit:
    """Fit the law's parameter (and theta0) to `decay`; `base` holds the block's FMU parameters.
    With `progress`, a bar on stderr counts the simulations (their number is not known ahead)."""
    import sys

    from scipy import optimize, stats
    from tqdm import tqdm

    if law not in LAW_PARAMETERS:
        raise ValueError(f"--law must be one of {', '.join(LAW_PARAMETERS)}")
    if len(decay.times) < 3:
        raise ValueError(f"a calibration needs at least 3 measured peaks after the release (got {len(decay.times)})")
    assumed = sigma_theta is None or sigma_time is None
    st = sigma_theta or THESIS_SIGMA[0]
    su = sigma_time or THESIS_SIGMA[1]
    alpha = math.atan2(base["block1.halfWidth"], base["block1.halfHeight"])
    if not abs(decay.theta0) >= 1e-4 * alpha:
        raise ValueError(f"the release (the first row, at {decay.t0:g} s) has theta = {decay.theta0:.3g} rad: free rocking "
                         "starts from the block held at an angle and let go, so the first row must be that release "
                         "angle (docs/measured.md); was it left out?")
    side = 1.0 if decay.theta0 >= 0 else -1.0
    _, _, lo, hi, start = LAW_PARAMETERS[law]
    if law == "correction":  # the corrected coefficient must stay below 1
        hi = 1.0 / housner_restitution(alpha)
        start = min(start, 0.5 * (1 + hi))
    stop = float(decay.times[-1] + 2.0)
    n = len(decay.times)
    calls = [0]
    bar = tqdm(desc=f"calibrating {PARAMETER_NAMES[law]}", unit="simulation", disable=not progress,
               file=sys.stderr, leave=False)

    def residuals(x: np.ndarray) -> np.ndarray:
        calls[0] += 1
        bar.update()
        t, th = simulate_peaks(fmu, base, law, float(x[0]), side * float(x[1]), stop)
        m = min(n, len(t))
        amp = np.zeros(n)
        amp[:m] = np.abs(th[:m])
        dt = np.zeros(n)
        dt[:m] = t[:m] - decay.times[:m]
        return np.concatenate([(amp - decay.amplitudes) / st, dt / su])

    theta_start = min(abs(decay.theta0), 0.95 * alpha)
    hi = hi if hi is not None else np.inf
    lower, upper = [lo, 1e-4 * alpha], [hi, 0.999 * alpha]
    with bar:
        sol = optimize.least_squares(residuals, [start, theta_start], bounds=(lower, upper),
                                     diff_step=1e-6, x_scale=[0.1, 0.1 * alpha])
    at_bound = tuple(_at_bound(float(sol.x[i]), lower[i], upper[i], int(sol.active_mask[i])) for i in range(2))
    sim_t, sim_th = simulate_peaks(fmu, base, law, float(sol.x[0]), side * float(sol.x[1]), stop)
    dof = max(1, 2 * n - 2)
    chi2 = float(np.sum(sol.fun ** 2))
    jtj = sol.jac.T @ sol.jac
    try:
        cov = np.linalg.inv(jtj) * chi2 / dof
    except np.linalg.LinAlgError:
        why = diagnose(decay, alpha, sim_t, np.abs(sim_th), st)
        raise ValueError(f"the measurement does not determine {PARAMETER_NAMES[law]} (singular fit)"
                         + (f": {why}" if why else "")) from None
    half = float(stats.t.ppf(0.975, dof) * math.sqrt(max(cov[0, 0], 0.0)))
    return Fit(law, float(sol.x[0]), float(sol.x[0]) - half, float(sol.x[0]) + half, side * float(sol.x[1]),
               chi2 / dof, dof, calls[0], st, su, assumed, alpha, (lo, hi), at_bound, sim_t, np.abs(sim_th))


def _at_bound(x: float, lower: float, upper: float, active: int) -> int:
    """-1 at the lower bound, 1 at the upper one (least_squares' active mask, or within 1e-9 of
    the bounds' span), else 0."""
    tol = 1e-9 * ((upper - lower) if math.isfinite(upper - lower) else max(1.0, abs(x)))
    return active or (-1 if x <= lower + tol else 1 if x >= upper - tol else 0)


def diagnose(decay: Decay, alpha: float, sim_times: np.ndarray, sim_amplitudes: np.ndarray, sigma_theta: float,
             time_unit: str | None = None) -> str:
    """What in the data the model cannot follow, in words ("" when nothing stands out)."""
    deg = 180 / math.pi
    amps = np.concatenate([[abs(decay.theta0)], decay.amplitudes])
    why = []
    top = float(np.max(amps))
    if top >= alpha:
        why.append(f"|theta| reaches {top * deg:.3g} deg, beyond the block's slenderness alpha = {alpha * deg:.3g} deg, "
                   "where it would fall over: is it the right block, and are the angle units right?")
    slope = np.polyfit(np.arange(len(amps)), amps, 1)[0] if len(amps) > 1 else 0.0
    if slope > 0 and amps[-1] > amps[0] + sigma_theta:
        why.append(f"the peaks grow (from {amps[0] * deg:.3g} to {amps[-1] * deg:.3g} deg), which free rocking cannot "
                   "do: each impact loses energy")
    m = min(len(decay.times), len(sim_times))
    if m:
        ratio = float(decay.times[m - 1] / sim_times[m - 1]) if sim_times[m - 1] > 0 else math.inf
        if not (1 / TIME_SCALE_LIMIT <= ratio <= TIME_SCALE_LIMIT):
            how = f"{1 / ratio:.3g} times sooner" if ratio < 1 else f"{ratio:.3g} times later"
            why.append(f"the measured peaks come {how} than the model's: are the time units right"
                       + (f" (declared {time_unit})" if time_unit else "") + ", and is it the right block?")
    return "; ".join(why)


def assess(fit: Fit, decay: Decay, time_unit: str | None = None) -> tuple[list[str], str]:
    """(problems, why) of a fit: what makes it untrustworthy (module docstring), and what in
    the data explains it; no problems means a fit to believe."""
    name = PARAMETER_NAMES[fit.law]
    low, high, open_low, text = physical_range(fit.law, fit.alpha)
    problems = []
    if not fit.chi2_per_dof <= CHI2_LIMIT:
        problems.append(f"chi2/dof {fit.chi2_per_dof:.3g} > {CHI2_LIMIT:g}")
    if fit.at_bound[0]:
        problems.append(f"{name} stopped at the search's {'upper' if fit.at_bound[0] > 0 else 'lower'} bound "
                        f"{fit.bounds[fit.at_bound[0] > 0]:.4g}")
    if fit.at_bound[1]:
        problems.append(f"theta0 stopped at the search's {'upper' if fit.at_bound[1] > 0 else 'lower'} bound "
                        f"({'0.999 alpha' if fit.at_bound[1] > 0 else '1e-4 alpha'})")
    if not (math.isfinite(fit.low) and math.isfinite(fit.high)):
        problems.append("the 95% interval is not finite")
    elif fit.low < low or (open_low and fit.low <= low) or fit.high > high:
        problems.append(f"the 95% interval leaves {name}'s physical range {text}")
    why = ""
    if problems:
        why = diagnose(decay, fit.alpha, fit.sim_times if fit.sim_times is not None else np.array([]),
                       fit.sim_amplitudes if fit.sim_amplitudes is not None else np.array([]), fit.sigma_theta,
                       time_unit)
        if not why and fit.sigma_assumed and not fit.chi2_per_dof <= CHI2_LIMIT:
            why = ("no uncertainty was stated and Anagnostopoulos's 0.5 deg and 0.1 s were assumed: state the reading "
                   "uncertainty (import-measured --uncertainty)")
    return problems, why
