"""Calibrating the restitution of one block on a measured free-rocking decay.

The model is the FMU's one block released at rest from theta0 (fitted too, as a
nuisance parameter). Its peak events, in order, are matched with the measured
peaks (runners.compare.Decay). The residuals are

    (|theta_sim,i| - |theta_meas,i|) / sigma_theta   and   (t_sim,i - t_meas,i) / sigma_t.

They are minimised by scipy.optimize.least_squares over the law's parameter
and theta0:

- ``constant``: eta, the ratio of angular velocities after/before impact;
- ``modified``: the impact position k;
- ``correction``: the factor on Housner's coefficient (seed 000, Table 3).

A measured peak that the model does not reach (the block came to rest first)
counts as a simulated amplitude of zero.

The confidence interval is the linearised one of the fit: the covariance is
(J^T J)^-1 scaled by the reduced chi-square, as scipy's curve_fit does with
absolute_sigma=False, so stated uncertainties weight angles against times.
The 95% interval uses Student's t with n - 2 degrees of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from model.reference import housner_restitution
from runners.compare import Decay
from runners.fmu import RockingFMU

LAW_PARAMETERS = {  # law -> (restitution.law, FMU parameter, lower bound, upper bound, start)
    "constant": (2, "restitution.eta", 0.05, 1.0, 0.9),
    "modified": (1, "restitution.k", 0.0, 1.0, 0.8),
    "correction": (0, "restitution.correction", 0.3, None, 1.0),
}
SEED000_SIGMA = (0.5 * math.pi / 180, 0.1)  # rad, s: seed 000 section 4.2, used when none is stated


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


def simulate_peaks(fmu: RockingFMU, base: dict, law: str, value: float, theta0: float, stop_time: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(times, theta) of the one-block model's peak events, released at rest from theta0."""
    code, name, *_ = LAW_PARAMETERS[law]
    p = {**base, "nBlocks": 1, "restitution.law": code, "restitution.correction": 1.0, name: value,
         "block1.theta0": theta0, "block1.omega0": 0.0, "excitation.kind": 0}  # the fitted law alone
    res = fmu.run(p, stop_time, stop_time, outputs=["block1.theta"])
    return res.event_times("peak"), res.event_values("peak", "theta")


def calibrate(fmu: RockingFMU, base: dict, decay: Decay, law: str, sigma_theta: float | None = None,
              sigma_time: float | None = None) -> Fit:
    """Fit the law's parameter (and theta0) to `decay`; `base` holds the block's FMU parameters."""
    from scipy import optimize, stats

    if law not in LAW_PARAMETERS:
        raise ValueError(f"--law must be one of {', '.join(LAW_PARAMETERS)}")
    if len(decay.times) < 3:
        raise ValueError(f"a calibration needs at least 3 measured peaks after the release (got {len(decay.times)})")
    assumed = sigma_theta is None or sigma_time is None
    st = sigma_theta or SEED000_SIGMA[0]
    su = sigma_time or SEED000_SIGMA[1]
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

    def residuals(x: np.ndarray) -> np.ndarray:
        calls[0] += 1
        t, th = simulate_peaks(fmu, base, law, float(x[0]), side * float(x[1]), stop)
        m = min(n, len(t))
        amp = np.zeros(n)
        amp[:m] = np.abs(th[:m])
        dt = np.zeros(n)
        dt[:m] = t[:m] - decay.times[:m]
        return np.concatenate([(amp - decay.amplitudes) / st, dt / su])

    theta_start = min(abs(decay.theta0), 0.95 * alpha)
    sol = optimize.least_squares(residuals, [start, theta_start],
                                 bounds=([lo, 1e-4 * alpha], [hi if hi is not None else np.inf, 0.999 * alpha]),
                                 diff_step=1e-6, x_scale=[0.1, 0.1 * alpha])
    dof = max(1, 2 * n - 2)
    chi2 = float(np.sum(sol.fun ** 2))
    jtj = sol.jac.T @ sol.jac
    try:
        cov = np.linalg.inv(jtj) * chi2 / dof
    except np.linalg.LinAlgError:
        raise ValueError("the measurement does not determine the parameter (singular fit)") from None
    half = float(stats.t.ppf(0.975, dof) * math.sqrt(max(cov[0, 0], 0.0)))
    return Fit(law, float(sol.x[0]), float(sol.x[0]) - half, float(sol.x[0]) + half, side * float(sol.x[1]),
               chi2 / dof, dof, calls[0], st, su, assumed)
