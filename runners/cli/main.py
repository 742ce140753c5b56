"""The ``runners`` commands simulate, sweep, map, bench and figures (their options and the
dispatch: runners.cli.parser).

Every failure prints one line ``error: ...`` to stderr and exits non-zero.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from runners.api import FIXED_STEP_METHODS
from runners.cli import output
from runners.engine.fmu import fmu_path_from


def cmd_simulate(args: argparse.Namespace) -> int:
    """runners simulate: runners.api.simulate, printed as text or JSON."""
    from runners.api import simulate

    record = args.record
    if args.record is not None and args.motion is not None:
        raise ValueError("give --record or --motion, not both")
    if args.h is not None and args.method not in FIXED_STEP_METHODS:
        raise ValueError("--h is the fixed step of --method rk4, rk4-located, newmark or euler")
    if args.rtol is not None and args.method != "scipy":
        raise ValueError("--rtol is the tolerance of --method scipy (the FMU's is [simulation] rel_tol)")
    if args.measured is not None and not args.rrd:
        raise ValueError("--measured overlays a measurement on a recording: give --out RUN.rrd too")
    if args.scale is not None and args.pga is not None:
        raise ValueError("give --scale or --pga, not both")
    if args.strict and args.method not in ("fmu", "auto"):  # before anything runs or is stored
        raise ValueError(f"--strict: method {args.method} does not monitor the contacts (the FMU does: "
                         "--method fmu or auto)")
    if (args.pga is not None or args.scale is not None) and record is None and args.motion is None:
        from runners.api import as_scene

        if not as_scene(args.scene).is_record:
            option = "--pga G scales a record to that PGA (in g)" if args.pga is not None else \
                "--scale multiplies a record's accelerations"
            raise ValueError(f"{option}, and the scene {args.scene} names none: give one with --record NAME|ID|FILE (runners "
                             "records list shows the stored ones), or use a scene whose [excitation] names one "
                             "(record = NAME or file = PATH)")
    coupling = None
    if args.coupling is not None:
        from runners.api import as_scene
        from runners.engine.supports import COUPLINGS

        if not int(as_scene(args.scene).parameters.get("support.kind", 0)):
            raise ValueError(f"--coupling couples a support to the blocks, and the scene {args.scene} has none: give it "
                             "a [building] or a [platform] (docs/supports.md)")
        coupling = {"support.coupling": COUPLINGS.index(args.coupling)}
    if args.rrd:  # besides the files of the command line (runners.cli.clobber.check): the scene's record file
        from runners.api import as_scene
        from runners.engine.files import refuse

        refuse({"--out": args.rrd}, {"scene's record file": as_scene(args.scene).file}, database=False)
    if args.motion is not None:  # the record a stored ground or table motion amounts to
        from db.session import open_database
        from runners.cli.measured import motion_record

        record = str(motion_record(open_database(args.db), args.motion))
    with output.busy(f"simulating {args.scene}"):
        run = simulate(args.scene, coupling, stop_time=args.stop_time, step=args.step, method=args.method,
                       accuracy=args.accuracy, h=args.h, rtol=args.rtol, record=record, scale=args.scale,
                       pga=args.pga, recording=args.rrd, measured=args.measured, store=not args.no_store,
                       db=args.db, fmu=args.fmu)
    if args.json:
        output.emit_json(run.summary)
    else:
        print(run.report)
    for text in run.summary.get("notes", ()):
        output.note(text)
    if run.summary.get("model_sufficient") is False:
        from runners.engine.summary import violations

        a = run.summary["assumptions"]
        print(f"error: --method auto: no model here suffices, {_model_of(a)} did not hold: {violations(a)}",
              file=sys.stderr)
        return STRICT_EXIT
    if args.strict:
        from runners.engine.summary import violations

        held = run.summary["assumptions"]  # fmu and auto runs monitor the contacts
        if not held["outcome_held"]:
            print(f"error: {_model_of(held)} did not hold (--strict): {violations(held)}", file=sys.stderr)
            return STRICT_EXIT
    return 0


def _model_of(assumptions: dict) -> str:
    """The contact model whose assumptions a summary's ``assumptions`` checked."""
    return "rocking-sliding" if assumptions.get("sliding_modelled") else "rigid rocking"


STRICT_EXIT = 4  # runners simulate --strict or --method auto: the run finished, but its assumptions did not hold


def confirm_on_terminal(estimate) -> bool:
    """Whether to run a large sweep (runners.engine.sweep.SweepEstimate): asked on the terminal, on
    stderr; not on a terminal (a pipe, CI), ValueError in one line saying to add --yes."""
    if not (sys.stdin.isatty() and sys.stderr.isatty()):
        raise ValueError(f"a large sweep: {estimate.text()}; nothing was stored: add --yes to run it")
    sys.stderr.write(f"a large sweep: {estimate.text()}.\nRun it? [y/N] ")
    sys.stderr.flush()
    answer = sys.stdin.readline().strip().lower()
    if answer not in ("y", "yes"):
        raise ValueError("not confirmed: the sweep was not started and nothing was stored")
    return True


def cmd_sweep(args: argparse.Namespace) -> int:
    """runners sweep: runners.api.sweep, with its notes (stderr) and statistics (stdout)."""
    from runners.api import SweepStopped, sweep

    try:
        sw = sweep(args.scene, args.grid, records=args.records, im=args.im, resume=args.resume,
                   stop_time=args.stop_time, workers=args.workers, db=args.db, fmu=args.fmu,
                   progress=output.progress() and not args.no_progress, record=args.record,
                   record_dir=args.record_dir, executor=args.executor, scheduler=args.scheduler, chunk=args.chunk,
                   on_note=output.note, confirm=True if args.yes else confirm_on_terminal)
    except SweepStopped as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 130 if exc.interrupted else 2
    st, sweep_id = sw.stats, sw.sweep_id
    if not args.json and st["ran"] == 0 and st["stored"] == st["total"]:
        print(f"sweep {sweep_id} is already complete: {st['stored']}/{st['total']} points stored "
              f"(runners map {sweep_id}, runners export --sweep {sweep_id})")
        return 0
    folder = (args.record_dir or f"recordings/sweep-{sweep_id}") if st["recorded"] else None
    if args.json:
        output.emit_json({"sweep": sweep_id, **st, "recordings": folder})
        return 0
    n = max(st["ran"], 1)
    skipped = f", {st['skipped']} already stored by another process" if st["skipped"] else ""
    rate = f", {n / st['wall_seconds']:,.0f} points/s with {st['workers']} worker{'s' * (st['workers'] > 1)}" \
        if st["ran"] and st["wall_seconds"] > 0 else ""
    print(f"sweep {sweep_id}: {st['stored']}/{st['total']} points stored ({st['ran'] - st['skipped']} now, "
          f"{st['errors']} failed{skipped}) in {st['wall_seconds']:.2f} s wall{rate}; per point: simulation "
          f"{1e3 * st['fmu_seconds'] / n:.3f} ms in a worker, storing {1e3 * st['db_cpu_seconds'] / n:.4f} ms of "
          "this process's CPU")
    if st.get("batch_unavailable") and st["ran"]:
        print(f"note: the points ran one FMI call at a time through fmpy, not in the C batch loop "
              f"({st['batch_unavailable']}): the same results, slower")
    if st["recorded"]:
        print(f"recorded {st['recorded']} points in full in {folder}")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    from db.schema import Sweep
    from runners.analysis.sweep_map import draw_counted
    from runners.cli.parser import resolve_latest

    from db.session import open_database

    factory = open_database(args.db, write=False)  # reads only: a mistyped path is not created
    sweep_id = resolve_latest(factory, Sweep, args.sweep, "sweep")
    by = getattr(args, "by", "outcome")
    args.out = args.out or {"outcome": "overturning_map.png"}.get(by, f"{by}_map.png")
    if by != "outcome":
        from runners.analysis.slip_map import draw_mode, draw_slip

        with output.busy(f"{by} map of sweep {sweep_id}"):
            text, found, n_lifted = (draw_mode if by == "mode" else draw_slip)(factory, str(sweep_id), Path(args.out))
        if args.json:
            output.emit_json({"sweep": sweep_id, "figure": str(args.out), "summary": text, "by": by,
                              ("modes" if by == "mode" else "max_abs_slip_m"): found, "lifted_off_first": n_lifted})
        else:
            print(text)
        return 0
    with output.busy(f"map of sweep {sweep_id}"):
        text, regions, n_broke = draw_counted(factory, str(sweep_id), Path(args.out))
    if args.json:
        output.emit_json({"sweep": sweep_id, "figure": str(args.out), "summary": text, "regions": regions,
                          "rigid_rocking_broke": n_broke})
    else:
        print(text)
    return 0


def fmu3_for(fmu: Path) -> Path | None:
    """The FMI 3.0 edition built beside `fmu` (python -m fmu_build), if there is one."""
    path = fmu.with_name(fmu.stem + "3.fmu")
    return path if path.is_file() else None


def _bench_stages(args: argparse.Namespace, fmu: Path) -> list[tuple[str, object]]:
    """(name, callable returning a Markdown section) of the benchmarks the options ask for."""
    from runners.analysis import bench as b

    def records():
        from runners.analysis.bench_records import run_record_bench

        return run_record_bench(fmu, repeats=args.fmpy_repeats)

    def study():
        from runners.analysis.bench_records import run_study_bench

        return run_study_bench(fmu)

    def interfaces():
        from runners.analysis.bench_interfaces import run_interface_bench

        return run_interface_bench(fmu, fmu3_for(fmu))

    if args.startup:
        from runners.analysis.bench_startup import run_startup_bench

        return [("start-up", lambda: run_startup_bench(args.baseline))]
    if args.throughput:
        from runners.analysis.throughput import run_throughput_bench

        return [("sweep throughput", lambda: run_throughput_bench(fmu, args.workers or 2, baseline=args.baseline,
                                                                  progress=output.progress()))]
    if args.interfaces:
        return [("FMI interfaces", interfaces)]
    if args.cosim:
        return [("co-simulation", _cosim_bench(fmu))]
    if args.columns:
        return [("columns of drums", _column_bench(fmu))]
    if args.supports:
        from runners.analysis.bench_supports import run_support_study_bench

        return [("a study on a floor against the ground", lambda: run_support_study_bench(fmu, args.workers or 2))]
    if args.against:
        tasks = [("native, against another build", lambda: b.run_native_against(fmu, Path(args.against), args.repeats))]
        if args.study:
            from runners.analysis.bench_records import run_study_against

            tasks.append(("near-field marble study, against another build",
                          lambda: run_study_against(fmu, Path(args.against))))
        return tasks
    if args.dask:
        return [("sweep executors (Dask)", lambda: b.run_dask_bench(fmu))]
    if args.sweep_size:
        return [("sweep size", lambda: b.run_sweep_size_bench(fmu))]
    if args.records:
        return [("record-driven run", records), ("fragility study", study)]
    if args.charts:
        from runners.analysis.overturning_map import run_overturning_map
        from runners.analysis.stability import run_stability
        from runners.analysis.work_precision import run_work_precision

        out = Path(args.out)
        return [("work-precision", lambda: run_work_precision(fmu, out, quick=args.quick)),
                ("stability", lambda: run_stability(fmu, out)),
                ("overturning map", lambda: run_overturning_map(out, quick=args.quick))]
    return [("native", lambda: b.run_native_bench(fmu, repeats=args.repeats)),
            ("fmpy", lambda: b.run_fmpy_bench(fmu, repeats=args.fmpy_repeats)),
            ("recordings", lambda: b.run_recording_bench(fmu)),
            ("sweep recordings", lambda: b.run_sweep_recording_bench(fmu)),
            ("FMI interfaces", interfaces),
            ("record-driven run", records), ("fragility study", study),
            ("sweep size", lambda: b.run_sweep_size_bench(fmu)), ("co-simulation", _cosim_bench(fmu)),
            ("columns of drums", _column_bench(fmu))]


def _column_bench(fmu: Path):
    def run() -> str:
        from runners.analysis.bench_column import run_column_bench, run_fmu_column_bench

        return run_fmu_column_bench(fmu) + "\n" + run_column_bench()
    return run


def _cosim_bench(fmu: Path):
    def run() -> str:
        from runners.analysis.bench_cosim import run_cosim_bench

        return run_cosim_bench(fmu)
    return run


def cmd_bench(args: argparse.Namespace) -> int:
    from runners.analysis.bench import markdown_sections

    if args.quick and not args.charts:
        raise ValueError("--quick applies to --charts only")
    if args.charts and not args.out:
        raise ValueError("--charts writes its charts to a folder: give --out DIR")
    if args.out and not args.charts:
        raise ValueError("--out is the folder of --charts")
    if sum(map(bool, (args.dask, args.sweep_size, args.records, args.charts, args.interfaces, args.against,
                      args.startup, args.throughput, args.cosim, args.supports, args.columns))) > 1:
        raise ValueError("give one of --charts, --dask, --records, --sweep-size, --interfaces, --against, "
                         "--startup, --throughput, --cosim, --supports and --columns (or none: every benchmark)")
    if args.study and not args.against:
        raise ValueError("--study is a part of --against FMU: give the other build")
    if args.baseline and not (args.startup or args.throughput):
        raise ValueError("--baseline is the other installation of --startup or --throughput")
    if args.workers is not None and not (args.throughput or args.supports):
        raise ValueError("--workers is the number of workers of --throughput or --supports")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers {args.workers}: give 1 or more")
    fmu = fmu_path_from(args.fmu)
    stages = dict(_bench_stages(args, fmu))
    texts = []
    for name in output.stages(list(stages), "bench"):
        texts.append(stages[name]())
        if not args.json:  # each table as soon as it is measured
            output.result(("\n" if len(texts) > 1 else "") + texts[-1])
    if args.json:
        output.emit_json({"benchmarks": [{"stage": name, **section} for name, text in zip(stages, texts)
                                         for section in markdown_sections(text)]})
    return 0


def cmd_figures(args: argparse.Namespace) -> int:
    from runners.analysis.figures import select, write_figures

    select(args.only)  # an unknown name is an error before anything runs
    paths = [str(p) for p in write_figures(fmu_path_from(args.fmu), Path(args.out), args.only,
                                           progress=output.progress(), note=output.note)]
    if args.json:
        output.emit_json({"figures": paths})
    elif paths:
        print("\n".join(paths))
    return 0


# the parser and the dispatch live in runners.cli.parser, which imports nothing heavy (runners --help)
from runners.cli.parser import build_parser, main  # noqa: E402,F401


if __name__ == "__main__":
    sys.exit(main())
