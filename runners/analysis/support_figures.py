"""The figures of docs/supports.md's worked example: blocks on a building's floor and on an isolation platform
(``runners figures --only supports_...``). Each draws from fresh runs in the scratch database it is given.

- :func:`floor_study`: the cabinet of examples/cabinet_third_floor.toml under the 28 FEMA P695 near-field pulse
  components at 20 PGA levels: its fragility against the base's PGA and against the peak floor acceleration,
  and the floor response spectra of the records;
- :func:`statue_on_isolator`: examples/statue_on_isolator.toml on its platform against the same statue on the
  ground;
- :func:`exact_against_cosim`: examples/cabinet_on_floor.toml with the building inside the FMU (two-way, exact)
  against the co-simulation of the same system at several communication steps.

Units SI, angles in radians (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from runners.engine.fmu import RockingFMU

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
COSIM_STEPS = (0.004, 0.002, 0.001, 0.0005, 0.00025)  # s, the co-simulation's communication steps


def floor_study(fmu: RockingFMU, factory, out: Path, quick: bool = False) -> list[Path]:
    """supports_fragility_pga.png, supports_fragility_pfa.png and supports_floor_spectra.png."""
    from db.records import samples
    from db.schema import Record
    from runners.analysis import study_figures
    from runners.analysis.floor_spectra import plot_floor_spectra
    from runners.analysis.record_figures import suite_refs
    from runners.engine import study
    from runners.engine.floor_motion import floor_spectra
    from runners.engine.scene import load_scene
    from runners.engine.sweep import create_sweep, parse_intensity, run_sweep, through_support

    scene = load_scene(EXAMPLES / "cabinet_third_floor.toml")
    scene.parameters["excitation.kind"] = 4
    refs = suite_refs(factory, "fema-p695/nearfield_pulse")
    refs = refs[:6] if quick else refs
    intensity = parse_intensity("pga=0.1:2.0:6" if quick else "pga=0.1:2.0:20")
    with factory() as session:
        refs = through_support(session, refs, {**fmu.defaults(), **scene.parameters}, [], intensity, fmu)
        records = [(r.name, *samples(session.get(Record, r.id))[:2]) for r in refs]
    sid = create_sweep(factory, scene, [], fmu.defaults(), refs, intensity)
    run_sweep(factory, sid, fmu.path, progress=False)
    made = [study_figures.plot_fragility(out / f"supports_fragility_{im}.png", study.outcomes(factory, sid, im))
            for im in ("pga", "pfa")]
    fs = floor_spectra({**fmu.defaults(), **scene.parameters}, records)
    made.append(plot_floor_spectra(out / "supports_floor_spectra.png", fs,
                                   f"{scene.name}: floor response spectra, {len(records)} FEMA P695 near-field "
                                   "components, per unit PGA of the base"))
    return made


def statue_on_isolator(fmu: RockingFMU, out: Path) -> Path:
    """supports_statue_isolator.png: the statue's rotation on its platform and on the ground, the platform's
    displacement relative to the base, and the base's and the platform's accelerations."""
    import runners

    path = EXAMPLES / "statue_on_isolator.toml"
    names = ["block1.theta", "ground.ahTotal", "support.u", "support.baseAh"]
    off_run = runners.simulate(path, store=False, outputs=names, support__kind=0)
    on_run = runners.simulate(path, store=False, outputs=names)
    on, off = on_run.series, off_run.series
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    axes[0].plot(off.index, off["ground.ahTotal"], color="0.6", lw=0.8, label="base (the record)")
    axes[0].plot(on.index, on["ground.ahTotal"], color="C0", lw=1.0, label="platform")
    axes[0].set_ylabel("acceleration (m/s$^2$)")
    axes[1].plot(on.index, 100 * on["support.u"], color="C0")
    axes[1].set_ylabel("platform displacement\nrelative to the base (cm)")
    axes[2].plot(off.index, off["block1.theta"], color="C3", label="statue on the ground")
    axes[2].plot(on.index, on["block1.theta"], color="C0", label="statue on the platform")
    axes[2].set_ylabel(r"rotation $\theta$ (rad)")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right")
    axes[2].legend(loc="upper right")
    fig.suptitle(f"{on_run.summary['scene']}: {on_run.summary['impacts']} impacts on the platform, "
                 f"{off_run.summary['impacts']} on the ground ({off_run.summary['final_state']})", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "supports_statue_isolator.png", dpi=110)
    return out / "supports_statue_isolator.png"


def exact_against_cosim(fmu: RockingFMU, out: Path) -> tuple[Path, list[dict]]:
    """supports_exact_cosim.png: examples/cabinet_on_floor.toml (two-way) with the building inside the FMU, at
    solver.relTol 1e-12, against fmpy's co-simulation with ShearBuilding.fmu at COSIM_STEPS, by the default master and
    with held inputs: the cabinet's rotation, and the co-simulations' peak-rotation and floor-displacement errors
    against the step. Returns the figure and the errors (rad, m) per step and master. (Both are the same structure:
    ShearBuilding.fmu carries the cabinet's mass outside its Rayleigh damping, docs/cosimulation.md.)"""
    import runners
    from runners.engine import cosim

    system = cosim.load_system(EXAMPLES / "cabinet_on_floor.toml")
    names = ["block1.theta", "support.u", "impacts"]
    run = runners.simulate(EXAMPLES / "cabinet_on_floor.toml", store=False, outputs=names, solver__relTol=1e-12,
                           solver__absTol=1e-14, step=min(COSIM_STEPS))
    exact = run.series
    peak = float(run.summary["max_abs_theta_rad"])
    rows, fig = [], plt.figure(figsize=(12, 7))
    top = fig.add_subplot(2, 1, 1)
    top.plot(exact.index, exact["block1.theta"], color="k", lw=2.0,
             label=f"building inside the FMU, exact ({int(run.summary['impacts'])} impacts)")
    for held in (False, True):
        for h in COSIM_STEPS:
            res = cosim.run(replace(system, step=h), block_fmu=fmu.path, interpolate=not held)
            u = np.interp(res.time, exact.index, exact["support.u"])
            rows.append({"master": "held" if held else "default", "step_s": h,
                         "peak_theta_error_rad": abs(float(res["block.block1.maxAbsTheta"][-1]) - peak),
                         "floor_u_error_m": float(np.abs(res.floor("u") - u).max()),
                         "impacts": int(res["block.impacts"][-1])})
            if h in (max(COSIM_STEPS), min(COSIM_STEPS)):
                top.plot(res.time, res["block.block1.theta"], lw=0.9, ls="--" if held else "-",
                         label=f"co-simulation, {'held inputs' if held else 'default master'}, h = {1e3 * h:g} ms "
                               f"({rows[-1]['impacts']} impacts)")
    top.set_xlabel("time (s)")
    top.set_ylabel(r"cabinet rotation $\theta$ (rad)")
    top.grid(alpha=0.3)
    top.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # outside the data
    bottom = fig.add_subplot(2, 1, 2)
    hs = 1e3 * np.array(COSIM_STEPS)
    for held, marker in ((False, "o"), (True, "s")):
        mine = [r for r in rows if r["master"] == ("held" if held else "default")]
        label = "held inputs" if held else "default master"
        bottom.loglog(hs, [r["peak_theta_error_rad"] for r in mine], marker + "-", label=f"{label}: peak |theta| (rad)")
        bottom.loglog(hs, [r["floor_u_error_m"] for r in mine], marker + ":", label=f"{label}: floor displacement, "
                      "largest (m)")
    held_u = [r["floor_u_error_m"] for r in rows if r["master"] == "held"]
    bottom.loglog(hs, held_u[0] * hs / hs[0], "k:", lw=0.8, label="first order in h")
    bottom.set_xlabel("communication step h (ms)")
    bottom.set_ylabel("co-simulation's error")
    bottom.grid(alpha=0.3, which="both")
    bottom.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{system.name}, two-way: the building inside the FMU against the co-simulation", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "supports_exact_cosim.png", dpi=110)
    return out / "supports_exact_cosim.png", rows
