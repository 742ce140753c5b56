"""Checks and figures of co-simulated systems (runners.engine.cosim): the energy balance of
two-way coupling, one-way coupling against the record run, and the floor and block responses.

Energy, in the frame of the building's base (docs/cosimulation.md). With u_j' the velocity of
the blocks' floor relative to the base and p the blocks' momentum relative to the floor, the
system's energy E = E_building + E_blocks + u_j' p (E_blocks is the blocks' own, relative to
their floor; the building's counts the blocks' mass moving with the floor) changes by the work
of the base's motion, -integral of a_g (1^T M u' + p) dt, less the building's damping loss
and the blocks' friction and impact losses. What a co-simulation adds to that is its coupling
error, the residual R(t). Its value at the end of the run is the error measure. With the default
two-way master (the blocks' floor's mass in their FMU, the load a line over each step) it and its
largest value along the run both shrink with the step; with held inputs (libcosim's algorithm) the
end value is first order and the largest does not shrink: each impact's impulse reaches the floor
one step late (docs/cosimulation.md).

An error estimate of a run (:func:`error_estimate`): the same system at twice the step, compared at
their last common communication point (peak rotation, slip, impacts, energy residual).
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
    def relative_end(self) -> float:
        """|residual| at the end / scale: the coupling's error measure (it shrinks with the step)."""
        return float(abs(self.residual[-1]) / self.scale)

    @property
    def relative_max(self) -> float:
        """max |residual| / scale along the run. It shrinks with the step under the default master; with held inputs,
        where the blocks impact, it includes the one-step transient of each impact (the impulse reaches the floor a
        step later), which does not."""
        return float(np.max(np.abs(self.residual)) / self.scale)

    @property
    def relative(self) -> float:
        """Former name of :attr:`relative_max` (deprecated: say which, relative_end or relative_max)."""
        import warnings

        warnings.warn("EnergyBalance.relative is relative_max; the error measure is relative_end",
                      DeprecationWarning, stacklevel=2)
        return self.relative_max


def coarse_system(system: System) -> System | None:
    """The system at twice its step, to the last communication point the two share (None: a run of one step)."""
    from dataclasses import replace

    from runners.engine.cosim import n_steps

    n = n_steps(system) // 2
    return replace(system, step=2 * system.step, stop_time=n * 2 * system.step) if n else None


def error_estimate(result: CosimResult, coarse: CosimResult | None = None, progress=None) -> dict:
    """An estimate of a run's error from the same system run at twice the step (``coarse``; else run here with the
    same engine, FMUs and scheme): at their last common communication point, the difference of the peak |theta| so far
    (rad) and of block 1's slip (m), both impact counts, and the energy residual's (two-way). Where the error falls
    at least as the step, the difference is of the finer run's error's size or above (for order p, 2^p - 1 times
    it); an estimate, not a bound: where it does not fall with the step the two runs can agree by chance
    (docs/cosimulation.md#error-estimate). Keys ``error_estimate_*``; {} for a run of one step."""
    from runners.engine import cosim

    system = result.system
    if coarse is None:
        twice = coarse_system(system)
        if twice is None:
            return {}
        coarse = cosim.run(twice, engine=result.engine, block_fmu=result.block_fmu, building_fmu=result.building_fmu,
                           progress=progress, interpolate=result.scheme != "held", iterate=result.scheme == "iterated")
    k = int(round(coarse.time[-1] / system.step)) - 1  # the fine run's sample at the coarse run's end
    b = f"{BLOCK}."
    peak = b + "block1.maxAbsTheta"
    out = {"error_estimate_step_s": coarse.system.step,
           "error_estimate_peak_abs_theta": float(abs(result[peak][k] - coarse[peak][-1])),
           "error_estimate_final_slip": float(abs(result[b + "block1.slip"][k] - coarse[b + "block1.slip"][-1])),
           "error_estimate_impacts": [int(result[b + "impacts"][k]), int(coarse[b + "impacts"][-1])]}
    if has_balance(coarse):
        out["error_estimate_energy_residual_relative"] = energy_balance(coarse).relative_end
    return out


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


def impact_steps(result: CosimResult) -> np.ndarray:
    """True at the samples where the blocks' impacts count or their overturn flag changed: the steps
    whose impulse two-way coupling passes to the floor over the next step."""
    k = f"{BLOCK}."
    changed = np.diff(result[k + "impacts"], prepend=0.0) != 0
    if k + "overturned" in result.series:
        changed |= np.diff(result[k + "overturned"], prepend=0.0) != 0
    return changed


def near_impacts(result: CosimResult, reach: int = 2) -> np.ndarray:
    """True at the samples within ``reach`` steps of an impact or overturn (impact_steps), where a floor model that
    takes the blocks' impulse over a step (a building FMU's own storey[j].a) spikes; any length of run, one step
    included."""
    hit = impact_steps(result)
    near = hit.copy()
    for k in range(1, min(reach, len(hit) - 1) + 1):
        near[k:] |= hit[:-k]
        near[:-k] |= hit[k:]
    return near


def between_impacts(result: CosimResult) -> np.ndarray:
    """The floor's acceleration (m/s2) at the samples at least three steps away from an impact or the
    overturn of the blocks (all of it when none is)."""
    a = result.floor("a")
    near = near_impacts(result)
    return a[~near] if np.any(~near) else a


def has_balance(result: CosimResult) -> bool:
    """Whether energy_balance accounts for the run: two-way coupling, blocks that report their losses
    (the rocking–sliding model) and start at rest."""
    b = result.system.blocks
    return result.system.coupling == "two-way" and int(b.get("contact.model", 0)) == 1 and \
        not any(float(b.get(k, 0.0)) for k in ("block1.theta0", "block1.omega0"))


def summary(result: CosimResult, balance: EnergyBalance | None = None) -> dict:
    """The run in numbers (SI units): floor, building and block peaks, and the energy balance's
    residual at the end (the coupling's error measure; docs/cosimulation.md). What runners cosim
    prints, gives in --json and stores (runners.engine.cosim_store)."""
    from runners.engine.cosim import natural_frequencies

    s, sys_ = result.series, result.system
    out = {"system": sys_.name, "engine": result.engine, "coupling": sys_.coupling, "floor": sys_.floor,
           "storeys": sys_.building.storeys, "step_s": sys_.step, "steps": len(result.time),
           "stop_time_s": float(result.time[-1]),
           "frequencies_hz": [round(f, 6) for f in natural_frequencies(sys_)],
           "peak_base_acceleration": float(np.max(np.abs(s[f"{BUILDING}.base.aTotal"]))),
           "peak_floor_acceleration": float(np.max(np.abs(result.floor("a")))),
           "peak_floor_acceleration_between_impacts": float(np.max(np.abs(between_impacts(result)))),
           "peak_floor_displacement": float(np.max(np.abs(result.floor("u")))),
           "peak_base_shear": float(np.max(np.abs(s[f"{BUILDING}.baseShear"]))),
           # the FMU's own peak (between communication points too), where the run kept it
           "peak_abs_theta": float(s[f"{BLOCK}.block1.maxAbsTheta"][-1]) if f"{BLOCK}.block1.maxAbsTheta" in s
           else float(np.max(np.abs(s[f"{BLOCK}.block1.theta"]))),
           "impacts": int(s[f"{BLOCK}.impacts"][-1]),
           "final_slip": float(s[f"{BLOCK}.block1.slip"][-1]),
           "overturned": bool(s[f"{BLOCK}.overturned"][-1]), "lifts": bool(s[f"{BLOCK}.lifts"][-1]),
           "slides": bool(s[f"{BLOCK}.slides"][-1])}
    if f"{BLOCK}.block2.overturned" in s:
        out["block2_overturned"] = bool(s[f"{BLOCK}.block2.overturned"][-1])
    if balance is not None:
        out["energy_residual_end_j"] = float(balance.residual[-1])
        out["energy_residual_end_relative"] = balance.relative_end
        out["energy_scale_j"] = balance.scale
    return out


def run_summary(result: CosimResult) -> dict:
    """summary() with the energy balance where the run allows one (has_balance)."""
    return summary(result, energy_balance(result) if has_balance(result) else None)


def _param(r: CosimResult, name: str) -> float | None:
    value = r.block_parameters.get(name, r.system.blocks.get(name))
    return None if value is None else float(value)


def describe(r: CosimResult) -> str:
    """Two lines for a figure's title: the blocks (full sizes, mass, slenderness, contact model and
    friction) and the building, the floor, the coupling, the step and the engine."""
    from runners.engine.scene import CONTACT_MODEL_NAMES

    blocks = []
    for i in (1, 2) if int(_param(r, "nBlocks") or 1) == 2 else (1,):
        b, h, m = (_param(r, f"block{i}.{q}") for q in ("halfWidth", "halfHeight", "mass"))
        size = f"{2 * b:.3g} m x {2 * h:.3g} m" if b and h else "?"
        blocks.append(f"block {i}: {size}, {m:g} kg" if m else f"block {i}: {size}")
    model = int(_param(r, "contact.model") or 0)
    mu = _param(r, "contact.muGround")
    contact = CONTACT_MODEL_NAMES.get(model, str(model)).replace("rigid-rocking", "rigid rocking")
    friction = f", mu = {mu:g}" if mu is not None else ""
    s, b = r.system, r.system.building
    masses = f"{b.mass[0]:g} kg" if len(set(b.mass)) == 1 else "masses " + "/".join(f"{m:g}" for m in b.mass) + " kg"
    stiff = (f"{b.stiffness[0]:g}" if len(set(b.stiffness)) == 1 else "/".join(f"{k:g}" for k in b.stiffness)) + " N/m"
    return (f"{'; '.join(blocks)}; {contact}{friction}\n"
            f"on floor {s.floor} of a {b.storeys}-storey shear building ({masses}, {stiff} per storey, "
            f"damping {b.damping_ratio:g}); h = {s.step:g} s, {r.engine}")


def _alpha(r: CosimResult) -> float | None:
    b, h = _param(r, "block1.halfWidth"), _param(r, "block1.halfHeight")
    return float(np.arctan2(b, h)) if b and h else None


def figure(results: list[CosimResult], title: str = ""):
    """Floor motion and block response, one column of panels; one colour per result (labelled by
    its coupling): the base and floor accelerations (two-way, the floor's as the blocks' FMU has it, the floor's mass
    with the blocks' forces: their impulses change its velocity, no sample of its acceleration), the floor's
    displacement, block 1's rotation with
    +-alpha (its slenderness: its centre of mass above a corner) and its impacts marked, and
    (rocking-sliding) its slip. The title (``title``, then the blocks, the building, the coupling and
    the step) and one legend above the panels, outside the data."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    if not results:
        raise CosimError("no result to plot")
    sliding = any(int(_param(r, "contact.model") or 0) == 1 for r in results)
    rows = 4 if sliding else 3
    fig, ax = plt.subplots(rows, 1, figsize=(8, 2.1 * rows + 1.4), sharex=True, layout="constrained")
    first, g = results[0], 9.81
    base = first[f"{BUILDING}.base.aTotal"] / g
    ax[0].plot(first.time, base, color="0.6", lw=0.8)
    handles = [Line2D([], [], color="0.6", lw=0.8, label="base")]
    for n, r in enumerate(results):
        color = f"C{n}"
        held = " (held inputs)" if r.system.coupling == "two-way" and r.scheme == "held" else ""
        handles.append(Line2D([], [], color=color, lw=1.2, label=f"{r.system.coupling} coupling{held}"))
        t = r.time
        ax[0].plot(t, r.floor("a") / g, lw=0.9, color=color)
        ax[1].plot(t, 1000 * r.floor("u"), lw=0.9, color=color)
        theta = r[f"{BLOCK}.block1.theta"]
        ax[2].plot(t, theta, lw=0.9, color=color)
        hit = np.flatnonzero(np.diff(r[f"{BLOCK}.impacts"], prepend=0.0) > 0)
        ax[2].plot(t[hit], theta[hit], "o", ms=4, mfc="none", mec=color)
        if sliding:
            ax[3].plot(t, 1000 * r[f"{BLOCK}.block1.slip"], lw=0.9, color=color)
    handles.append(Line2D([], [], ls="none", marker="o", ms=4, mfc="none", mec="0.3", label="impacts"))
    alpha = _alpha(first)
    if alpha is not None:
        for sign in (1, -1):
            ax[2].axhline(sign * alpha, color="0.3", ls="--", lw=0.8)
        handles.append(Line2D([], [], color="0.3", ls="--", lw=0.8,
                              label=f"\u00b1alpha = \u00b1{alpha:.3g} rad: centre of mass over a corner"))
    ax[0].set_ylabel(f"floor {first.system.floor} and base\nacceleration (g)")
    ax[1].set_ylabel("floor displacement\nrelative to base (mm)")
    ax[2].set_ylabel("block 1 rotation\ntheta (rad)")
    if sliding:
        ax[3].set_ylabel("block 1 slip (mm)")
    ax[-1].set_xlabel("time (s)")
    for a in ax:
        a.grid(True, lw=0.3)
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=7, frameon=False)
    fig.suptitle((f"{title}\n" if title else "") + describe(first), fontsize=9)
    return fig
