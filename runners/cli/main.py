"""The ``runners`` command line: simulate scenes and benchmark the FMU.

Every failure prints one line ``error: ...`` to stderr and exits non-zero.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from db.session import DB_HELP, DatabaseError
from runners.api import FIXED_STEP_METHODS, PYTHON_METHODS
from runners.cli.args import Parser, count, finite, folder, output_file, positive, tolerance
from runners.engine.fmu import FMUError, fmu_path_from
from runners.engine.scene import SceneError
from runners.engine.sweep import SweepError


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
        raise ValueError("--measured overlays a measurement on a recording: give --rrd too")
    if args.scale is not None and args.pga is not None:
        raise ValueError("give --scale or --pga, not both")
    if args.motion is not None:  # the record a stored ground or table motion amounts to
        from db.session import open_database
        from runners.cli.measured import motion_record

        record = str(motion_record(open_database(args.db), args.motion))
    run = simulate(args.scene, stop_time=args.stop_time, step=args.step, method=args.method, accuracy=args.accuracy,
                   h=args.h, rtol=args.rtol, record=record, scale=args.scale, pga=args.pga, recording=args.rrd,
                   measured=args.measured, store=not args.no_store, db=args.db, fmu=args.fmu)
    print(json.dumps(run.summary, indent=2) if args.json else run.report)
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """runners sweep: runners.api.sweep, with its notes and statistics printed."""
    from runners.api import SweepStopped, sweep

    try:
        sw = sweep(args.scene, args.grid, records=args.records, im=args.im, resume=args.resume,
                   stop_time=args.stop_time, workers=args.workers, db=args.db, fmu=args.fmu,
                   progress=not args.no_progress, record=args.record, record_dir=args.record_dir,
                   executor=args.executor, scheduler=args.scheduler, chunk=args.chunk,
                   on_note=lambda note: print(f"note: {note}"))
    except SweepStopped as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 130 if exc.interrupted else 2
    st, sweep_id = sw.stats, sw.sweep_id
    n = max(st["ran"], 1)
    skipped = f", {st['skipped']} already stored by another process" if st["skipped"] else ""
    print(f"sweep {sweep_id}: {st['stored']}/{st['total']} points stored ({st['ran'] - st['skipped']} now, "
          f"{st['errors']} failed{skipped}) in {st['wall_seconds']:.2f} s wall; per point: FMU {1e3 * st['fmu_seconds'] / n:.3f} ms "
          f"in a worker, database {1e3 * st['db_seconds'] / n:.3f} ms, Python bookkeeping "
          f"{1e3 * st['python_seconds'] / n:.3f} ms in the main process")
    if st["recorded"]:
        print(f"recorded {st['recorded']} points in full in {args.record_dir or f'recordings/sweep-{sweep_id}'}")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    from runners.analysis.sweep_map import draw

    from db.session import open_database

    print(draw(open_database(args.db), args.sweep, Path(args.out)))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from runners.analysis.bench import run_fmpy_bench, run_native_bench, run_recording_bench, run_sweep_recording_bench

    if args.quick and not args.chart:
        raise ValueError("--quick applies to --chart only")
    fmu = fmu_path_from(args.fmu)
    if args.dask:
        from runners.analysis.bench import run_dask_bench

        print(run_dask_bench(fmu))
        return 0
    from runners.analysis.bench_records import run_record_bench, run_study_bench

    if args.sweep_size:
        from runners.analysis.bench import run_sweep_size_bench

        print(run_sweep_size_bench(fmu))
        return 0
    if args.records:
        print(run_record_bench(fmu, repeats=args.fmpy_repeats))
        print()
        print(run_study_bench(fmu))
        return 0
    if args.chart:
        from runners.analysis.overturning_map import run_overturning_map
        from runners.analysis.stability import run_stability
        from runners.analysis.work_precision import run_work_precision

        print(run_work_precision(fmu, Path(args.chart), quick=args.quick))
        print()
        print(run_stability(fmu, Path(args.chart)))
        print()
        print(run_overturning_map(Path(args.chart), quick=args.quick))
        return 0
    print(run_native_bench(fmu, repeats=args.repeats))
    print()
    print(run_fmpy_bench(fmu, repeats=args.fmpy_repeats))
    print()
    print(run_recording_bench(fmu))
    print()
    print(run_sweep_recording_bench(fmu))
    print()
    print(run_record_bench(fmu, repeats=args.fmpy_repeats))
    print()
    print(run_study_bench(fmu))
    print()
    from runners.analysis.bench import run_sweep_size_bench

    print(run_sweep_size_bench(fmu))
    return 0


def cmd_figures(args: argparse.Namespace) -> int:
    from runners.analysis.figures import select, write_figures

    select(args.only)  # an unknown name is an error before anything runs
    progress = sys.stderr.isatty() and not getattr(args, "no_progress", False) and not getattr(args, "quiet", False)
    for path in write_figures(fmu_path_from(args.fmu), Path(args.out), args.only, progress=progress,
                              note=lambda text: print(text, file=sys.stderr)):
        print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="runners", description="Rocking rigid blocks: run scenes through RockingBlock.fmu")
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="run one scene file and print a summary")
    sim.add_argument("scene", help="scene file (TOML), see examples/")
    sim.add_argument("--fmu", help="FMU to use (default: build/RockingBlock.fmu, built if needed)")
    sim.add_argument("--json", action="store_true", help="print the summary as JSON")
    sim.add_argument("--stop-time", type=positive, help="override [simulation] stop_time (s)")
    sim.add_argument("--step", type=positive, help="override [simulation] step (s)")
    sim.add_argument("--method", choices=["fmu", "auto", "closed-form", *PYTHON_METHODS], default="fmu",
                     help="fmu: the model the scene describes (default); auto: the least model that meets "
                          "--accuracy (closed form, one block, two blocks; docs/methods.md); closed-form: Dimitrakopoulos & DeJong (2012)'s "
                          "closed forms, or an error if they do not apply; scipy, rk4, rk4-located, newmark, euler: "
                          "the independent Python solvers (docs/methods.md)")
    sim.add_argument("--h", type=positive, help="fixed step (s) of rk4, rk4-located, newmark, euler (default 1e-4)")
    sim.add_argument("--rtol", type=tolerance, help="relative tolerance of --method scipy (default 1e-10)")
    sim.add_argument("--db", help=DB_HELP)
    sim.add_argument("--no-store", action="store_true", help="do not store the run in the database")
    sim.add_argument("--rrd", type=output_file, metavar="PATH", help="also write a Rerun recording (.rrd) of the run")
    sim.add_argument("--measured", metavar="CSV", help="with --rrd: overlay a measured series (runners/engine/measured.py)")
    sim.add_argument("--record", metavar="NAME|ID",
                     help="drive the block with a stored record (runners records list) instead of the scene's "
                          "excitation")
    sim.add_argument("--scale", type=finite, help="multiply the record's accelerations (excitation.scale)")
    sim.add_argument("--pga", type=positive, metavar="G", help="scale the record so that its PGA is G (in g)")
    sim.add_argument("--motion", type=int, metavar="MEASUREMENT_ID",
                     help="drive the block with the record of a stored ground or table motion "
                          "(runners import-measured), instead of the scene's excitation")
    sim.add_argument("--accuracy", type=tolerance, default=1e-2,
                     help="relative accuracy asked of --method auto (default 1e-2)")
    sim.set_defaults(func=cmd_simulate)
    bench = sub.add_parser("bench", help="measure the cost of simulations, natively and through fmpy")
    bench.add_argument("--fmu", help="FMU to use (default: build/RockingBlock.fmu)")
    bench.add_argument("--repeats", type=count, default=2000, help="native simulations per case")
    bench.add_argument("--fmpy-repeats", type=count, default=20, help="fmpy runs per case")
    bench.add_argument("--chart", metavar="DIR",
                       help="instead: the work-precision comparison of every method, written to DIR")
    bench.add_argument("--quick", action="store_true", help="with --chart: fewer settings (a smoke run)")
    bench.add_argument("--dask", action="store_true",
                       help="sweep executors: local against a local Dask cluster, 1 and 2 workers")
    bench.add_argument("--records", action="store_true",
                       help="only the record benchmarks: one record-driven run, and a 560-run fragility study")
    bench.add_argument("--sweep-size", action="store_true",
                       help="only the sweep-size benchmark: memory and start-up of 1e4- to 1e7-point sweeps")
    bench.set_defaults(func=cmd_bench)
    from runners.cli.db import add_parser as add_db_parser

    sw = sub.add_parser("sweep", help="run a grid of one scene in parallel and store it (resumable)")
    sw.add_argument("scene", nargs="?", help="scene file (TOML); omit with --resume")
    sw.add_argument("--grid", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                    help="an axis: w (omega_g/p), a (a_g/(g tan alpha)), scale (a record's multiplier) or a Real "
                         "or Integer FMU parameter (whole numbers: solver.method=0:1:2); repeatable")
    sw.add_argument("--records", metavar="SUITE|NAMES|FOLDER",
                    help="run every record of a suite (e.g. fema-p695/nearfield_pulse), of a comma-separated list "
                         "of record names or ids, or of a folder of record files (docs/records.md)")
    sw.add_argument("--im", metavar="pga=START:STOP:COUNT",
                    help="scale each record so that its PGA (in g) or PGV (pgv=..., in m/s) takes COUNT levels")
    sw.add_argument("--resume", type=int, metavar="SWEEP_ID", help="finish an interrupted sweep")
    sw.add_argument("--workers", type=count, help="worker processes (default: all cores)")
    sw.add_argument("--stop-time", type=positive, help="override [simulation] stop_time (s)")
    sw.add_argument("--db", help=DB_HELP)
    sw.add_argument("--fmu", help="FMU to use (default: build/RockingBlock.fmu, built if needed)")
    sw.add_argument("--no-progress", action="store_true", help="no progress bar")
    sw.add_argument("--record", metavar="POINTS",
                    help="grid points to simulate in full and record (.rrd), e.g. 0,17,40-45 or all")
    sw.add_argument("--record-dir", type=folder, metavar="DIR", help="where --record writes (default: recordings/sweep-ID)")
    sw.add_argument("--executor", choices=["local", "dask"], default="local",
                    help="local: worker processes on this machine (default); dask: a Dask cluster")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="with --executor dask: tcp://HOST:PORT of the scheduler, or local:N for N local workers")
    sw.add_argument("--chunk", type=count, metavar="N",
                    help="with --executor dask: grid points per task (default: about 4 tasks per worker)")
    sw.set_defaults(func=cmd_sweep)
    from runners.cli.measured import add_parser as add_measured_parser
    from runners.cli.records import add_parser as add_records_parser
    from runners.cli.export import add_parser as add_export_parser
    from runners.cli.rrd import add_parser as add_rrd_parser

    add_rrd_parser(sub)
    add_export_parser(sub)
    add_measured_parser(sub)
    add_records_parser(sub)

    mp = sub.add_parser("map", help="draw the overturning map of a stored sweep")
    mp.add_argument("sweep", help="sweep id, or 'latest'")
    mp.add_argument("--out", type=output_file, default="overturning_map.png", help="PNG file (default: overturning_map.png)")
    mp.add_argument("--db", help=DB_HELP)
    mp.set_defaults(func=cmd_map)

    add_db_parser(sub)
    figs = sub.add_parser("figures", help="draw the figures of docs/ from fresh FMU runs")
    figs.add_argument("--fmu", help="FMU to use (default: build/RockingBlock.fmu)")
    figs.add_argument("--out", type=folder, default="figures",
                      help="folder for the PNG files (default: ./figures; --out docs/figures replaces the "
                           "tracked ones)")
    figs.add_argument("--only", nargs="+", metavar="NAME", help="draw only these figures (docs/figures.md lists them)")
    figs.add_argument("--no-progress", action="store_true", help="no progress bar")
    figs.set_defaults(func=cmd_figures)
    return parser


def _crash_report() -> str:
    """Write the traceback being handled to a file in the temporary folder; its path."""
    import tempfile
    import time
    import traceback

    path = Path(tempfile.gettempdir()) / f"runners-error-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.txt"
    path.write_text(f"runners {' '.join(sys.argv[1:])}\n\n{traceback.format_exc()}")
    return str(path)


def _terminated(signum, _frame) -> None:
    raise KeyboardInterrupt  # SIGTERM stops a command as Ctrl-C does: workers stopped, temporary files removed


def main(argv: list[str] | None = None) -> int:
    import signal
    import threading

    from sqlalchemy.exc import SQLAlchemyError

    from db.session import database_failure

    args = build_parser().parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        return args.func(args)
    except BrokenPipeError:  # the reader stopped (runners records list | head): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (SceneError, FMUError, FileNotFoundError, ValueError, OSError, DatabaseError, SweepError) as exc:
        print(f"error: {exc}".splitlines()[0], file=sys.stderr)
        return 2
    except SQLAlchemyError as exc:  # a database failure the command did not foresee: one line, not a traceback
        print(f"error: {database_failure(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a defect of ours: one line for the user, the traceback in a file for us
        if os.environ.get("ROCKING_DEBUG"):
            raise
        print(f"error: unexpected {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''} "
              f"(details in {_crash_report()}; please report it)", file=sys.stderr)
        return 3
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
