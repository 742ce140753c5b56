"""Checks and figures of co-simulated systems (runners.engine.cosim): the energy balance of
two-way coupling, one-way coupling against the record run, and the floor and block responses.

Energy, in the frame of the building's base (docs/cosimulation.md). With u_j' the velocity of
the blocks' floor relative to the base and p the blocks' momentum relative to the floor, the
system's energy E = E_building + E_blocks + u_j' p (E_blocks is the blocks' own, relative to
their floor; the building's counts the blocks' mass moving with the floor) changes by the work
of the base's motion, -integral of a_g (1^T M u' + p) dt, less the building's damping loss
and the blocks' friction and impact losses. What a co-simulation adds to that is its coupling
error, the residual R(t); it shrinks with the communication step.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from runners.engine.cosim import BLOCK, BUILDING, CosimError, CosimResult, System


@dataclass
class EnergyBalance:
    """The two-way system's energy terms at t_1 .. t_n (J), up to the blocks' overturn if they
    overturn (the model then lays them down, outside any balance): ``energy`` E(t) - E(0) and
    ``expected`` (the base's work less the losses); ``residual`` their difference, ``scale`` the
    largest energy the system held or took in (the denominator a relative residual uses)."""

    time: np.ndarray
    energy: np.ndarray
    expected: np.ndarray
    residual: np.ndarray
    scale: float

    @property
    def relative(self) -> float:
        """max |residual| / scale."""
        return float(np.max(np.abs(self.residual)) / self.scale)


def _cumtrapz0(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid over (0, 0), (t_1, y_1), ...: the integral from 0 (where y is 0, the
    system at rest) to each t_k."""
    tt = np.concatenate([[0.0], t])
    yy = np.concatenate([[0.0], y])
    return np.cumsum(0.5 * (yy[1:] + yy[:-1]) * np.diff(tt))


def energy_balance(result: CosimResult) -> EnergyBalance:
    """The energy balance of a two-way coupled run that starts at rest (docs/cosimulation.md).
    The blocks must use contact.model = 1 (rocking-sliding), which reports its friction and
    impact losses."""
    sys_ = result.system
    if sys_.coupling != "two-way":
        raise CosimError("the energy balance is the two-way coupled system's (one-way: the floor does not feel the blocks)")
    if int(sys_.blocks.get("contact.model", 0)) != 1:
        raise CosimError("the energy balance needs the blocks' losses: contact.model = 1 (rocking-sliding) reports them")
    if any(float(sys_.blocks.get(k, 0.0)) != 0.0 for k in ("block1.theta0", "block1.omega0", "block2.theta0", "block2.omega0")):
        raise CosimError("the energy balance starts from rest: the blocks' theta0 and omega0 must be 0")
    b, k = f"{BUILDING}.", f"{BLOCK}."
    standing = result.series[k + "overturned"] == 0
    if not standing[0]:
        raise CosimError("the blocks overturned in the first step: no energy balance to draw")
    end = len(standing) if standing.all() else int(np.argmin(standing))
    s = {name: x[:end] for name, x in result.series.items()}
    p = s[k + "momentum"]
    e = s[b + "energy"] + s[k + "energy"] + s[f"{b}storey[{sys_.floor}].v"] * p
    losses = s[b + "dampingLoss"] + s[k + "block1.frictionLoss"] + s[k + "impactLoss"]
    if k + "block2.frictionLoss" in s:
        losses = losses + s[k + "block2.frictionLoss"]
    time = result.time[:end]
    expected = s[b + "baseWork"] - _cumtrapz0(time, s[b + "base.aTotal"] * p) - losses
    scale = float(max(np.max(np.abs(e)), np.max(np.abs(s[b + "baseWork"])), np.max(np.abs(losses)), 1e-300))
    return EnergyBalance(time, e, expected, e - expected, scale)


def record_run(system: System, result: CosimResult, block_fmu: Path | None = None) -> dict[str, np.ndarray]:
    """The blocks alone under the floor acceleration a one-way run gave them, stored as a record
    (samples at t_0 = 0 and every t_k, linearly interpolated by the FMU), sampled at the same
    times as ``result``; what one-way coupling must reproduce up to that interpolation."""
    import tempfile

    from fmpy import simulate_fmu

    from runners.engine.fmu import fmu_path_from
    from runners.engine.record_files import write_record_file

    if system.coupling != "one-way":
        raise CosimError("the record run reproduces a one-way coupled run")
    fmu = fmu_path_from(str(block_fmu) if block_fmu else None)
    a = result.floor("a")
    # the blocks saw a_f(t_k) over [t_k, t_k+1]: a_f(0) = 0 for a building at rest, then the samples
    t = np.concatenate([[0.0], result.time])
    af = np.concatenate([[0.0], a])
    outputs = ["block1.theta", "impacts", "block1.slip"]
    with tempfile.TemporaryDirectory(prefix="rocking-floor-") as tmp:
        rec = write_record_file(Path(tmp) / "floor.txt", t, af, comments=["floor acceleration of a one-way run"])
        params = {**system.block_parameters(), "excitation.kind": 4, "excitation.file": str(rec)}
        r = simulate_fmu(str(fmu), start_values=params, stop_time=float(result.time[-1]),
                         output_interval=system.step, output=outputs)
    return {"time": r["time"][1:], **{n: np.asarray(r[n][1:], float) for n in outputs}}


def figure(results: list[CosimResult], title: str = ""):
    """Floor motion and block response, one column of panels; one line per result (labelled by its
    coupling): the base and floor accelerations, the floor's displacement, the block's rotation
    and (rocking-sliding) slip."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not results:
        raise CosimError("no result to plot")
    sliding = any(int(r.system.blocks.get("contact.model", 0)) == 1 for r in results)
    rows = 4 if sliding else 3
    fig, ax = plt.subplots(rows, 1, figsize=(8, 2.2 * rows + 0.6), sharex=True, constrained_layout=True)
    first = results[0]
    g = 9.81
    ax[0].plot(first.time, first[f"{BUILDING}.base.aTotal"] / g, color="0.6", lw=0.8, label="base")
    for r in results:
        lab = f"floor {r.system.floor}, {r.system.coupling}"
        ax[0].plot(r.time, r.floor("a") / g, lw=0.9, label=lab)
        ax[1].plot(r.time, 1000 * r.floor("u"), lw=0.9, label=lab)
        ax[2].plot(r.time, r[f"{BLOCK}.block1.theta"], lw=0.9, label=f"{r.system.coupling} ({r.engine})")
        if sliding:
            ax[3].plot(r.time, 1000 * r[f"{BLOCK}.block1.slip"], lw=0.9, label=r.system.coupling)
    ax[0].set_ylabel("acceleration (g)")
    ax[1].set_ylabel("floor displacement\nrelative to base (mm)")
    ax[2].set_ylabel("block rotation\ntheta (rad)")
    if sliding:
        ax[3].set_ylabel("block slip (mm)")
    ax[-1].set_xlabel("time (s)")
    for a in ax:
        a.grid(True, lw=0.3)
        a.legend(fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
