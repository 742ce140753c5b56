"""The ``runners`` command line: simulate scenes and benchmark the FMU.

Every failure prints one line ``error: ...`` to stderr and exits non-zero.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from db.session import DB_HELP, DatabaseError, require_writable
from runners.cli.args import Parser, count, finite, folder, output_file, positive, tolerance
from runners.engine.fmu import FMUError, RockingFMU, fmu_path_from
from runners.engine.scene import SceneError, check_times, load_scene, unused_parameter
from runners.engine.summary import SUMMARY_OUTPUTS, format_summary, summarize
from runners.engine.sweep import SweepError

PYTHON_METHODS = ["scipy", "rk4", "rk4-located", "newmark", "euler"]


def cmd_simulate(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from runners.analysis.least_model import (choose_model, closed_form_summary, combined_block_parameters,
                                     format_closed_form, one_block_parameters)

    from runners.engine.records import prepare_scene

    scene = load_scene(args.scene)
    if args.stop_time is not None:
        scene.stop_time, scene.stop_time_given = args.stop_time, True
    if args.step is not None:
        scene.step, scene.step_given = args.step, True
    if args.h is not None and args.method not in ("rk4", "rk4-located", "newmark", "euler"):
        raise ValueError("--h is the fixed step of --method rk4, rk4-located, newmark or euler")
    if args.rtol is not None and args.method != "scipy":
        raise ValueError("--rtol is the tolerance of --method scipy (the FMU's is [simulation] rel_tol)")
    measured = _measured(args.measured, args.rrd)  # fail on a bad file before simulating
    factory = None if args.no_store else _database(args.db)  # fail on a bad database before simulating
    if factory is not None:
        from db.session import require_writable

        require_writable(factory, "or run with --no-store")  # else the run would be lost after it ran
    fmu_path = fmu_path_from(args.fmu)
    if args.record is not None and args.motion is not None:
        raise ValueError("give --record or --motion, not both")
    if args.motion is not None:  # the record a stored ground or table motion amounts to
        from runners.cli.measured import motion_record

        args.record = str(motion_record(factory or _database(args.db), args.motion))
    notes = []
    if args.record is not None:  # the record replaces the scene's excitation, and the times set for it
        from runners.engine.scene import KIND_NAMES

        kind = int(scene.parameters.get("excitation.kind", 0))
        if kind not in (0, 4):
            notes.append(f"the record replaces the scene's {KIND_NAMES[kind]}")
        scene = replace(scene, record=args.record, file=None,
                        stop_time_given=args.stop_time is not None, step_given=args.step is not None,
                        parameters={**{k: v for k, v in scene.parameters.items()
                                       if not k.startswith("excitation.") or k == "excitation.startTime"},
                                    "excitation.kind": 4})
    if args.scale is not None or args.pga is not None:
        if not scene.is_record:
            raise ValueError("--scale and --pga scale a record: give a record scene or --record")
        if args.scale is not None and args.pga is not None:
            raise ValueError("give --scale or --pga, not both")
        if args.pga is not None:
            from runners.engine.scene import check_pga

            check_pga(args.pga, "--pga")
        scene.parameters.pop("excitation.scale", None)
        scene.pga = args.pga
        if args.scale is not None:
            scene.parameters["excitation.scale"] = args.scale
    rec = prepare_scene(scene, factory if factory is not None or scene.record is None else _database(args.db))
    check_times(scene.stop_time, scene.step, "the stop time", "the output step")
    result = None
    with RockingFMU(fmu_path) as fmu:
        defaults = fmu.defaults()
        merged = {**defaults, **scene.parameters}
        notes += [f"{why} (the scene sets it)" for k in scene.parameters if k != "block1.mass"
                  and (why := unused_parameter(k, merged))]
        if args.method in PYTHON_METHODS:
            from runners.engine.python_methods import format_python, run_python

            s = {"scene": scene.name, **run_python(args.method, merged, scene.stop_time,
                                                    1e-4 if args.h is None else args.h,
                                                    1e-10 if args.rtol is None else args.rtol)}
            text_out = format_python(scene.name, s, scene.stop_time)
            model, method = s["model"], args.method
        else:
            if args.method == "fmu":
                model = "two blocks" if int(merged["nBlocks"]) == 2 else "one block"
                why = "the model the scene describes (--method fmu)"
            else:
                model, why = choose_model(merged, args.accuracy)
                if args.method == "closed-form" and model != "closed form":
                    raise ValueError("--method closed-form does not apply to this scene: "
                                     f"{why.removeprefix('no closed form: ')}")
            method = args.method
            if model == "closed form":
                s = {"scene": scene.name, "model": model, "model_reason": why, **closed_form_summary(merged)}
                text_out = format_closed_form(scene.name, why, s)
            else:
                if model == "one block" and int(merged["nBlocks"]) == 2:
                    scene = replace(scene, parameters=one_block_parameters(scene.parameters))
                if model == "one block (combined)":
                    combined = combined_block_parameters(merged)
                    scene = replace(scene, parameters={k: v for k, v in combined.items()
                                                       if k in scene.parameters or k.startswith("block1.")})
                result = fmu.run(scene.parameters, scene.stop_time, scene.step, outputs=SUMMARY_OUTPUTS)
                s = summarize(scene, result, defaults)
                s["model"], s["model_reason"] = model, why
                if rec is not None:
                    s["excitation"] = rec.describe(float(merged["excitation.scale"]))
                    s["record"] = {"id": rec.record_id, "name": rec.name, "end_s": rec.end,
                                   "scale": float(merged["excitation.scale"]),
                                   "pga_g": abs(float(merged["excitation.scale"])) * rec.info["pga_g"]}
                    notes += rec.notes
                if notes:
                    s["notes"] = notes
                text_out = format_summary(s)
    recording = None
    if args.rrd:
        if result is None:
            raise ValueError("--rrd records FMU runs (--method fmu or auto running the FMU)")
        from runners.engine.recording import write_recording

        recording = write_recording(Path(args.rrd), scene.name, result.time, result.outputs,
                                    {**defaults, **scene.parameters}, result.events, measured,
                                    record=None if rec is None else rec.info)
        s["recording"] = str(recording)
        text_out += f"\nrecording        {recording}"
    if factory is not None:
        s["run_id"] = _store(factory, scene, {**defaults, **scene.parameters}, s, model, method, fmu_path, result,
                             recording, None if rec is None else (rec.record_id, rec.name))
        text_out += f"\nstored           run {s['run_id']} in {factory.kw['bind'].url.render_as_string(hide_password=True)}"
    print(json.dumps(s, indent=2) if args.json else text_out)
    return 0


def _measured(path: str | None, rrd: str | None) -> dict | None:
    """The measured series to overlay (--measured), read and checked before any work."""
    if path is None:
        return None
    if not rrd:
        raise ValueError("--measured overlays a measurement on a recording: give --rrd too")
    from runners.engine.measured import read_measured_csv

    return read_measured_csv(path)


def _database(url: str | None):
    from db.session import open_database

    return open_database(url)


def _store(factory, scene, merged, s, model, method, fmu_path, result, recording=None,
           record: tuple[int, str] | None = None) -> int:
    """The run and everything it refers to, in one transaction; if the database fails, the run
    is kept in a file that runners db import-unsaved stores later (db.store.store_or_keep)."""
    from db.store import pending_run, store_or_keep
    from runners.engine.summary import summary_row

    source = Path(scene.source).read_text() if scene.source and Path(scene.source).is_file() else None
    pending = pending_run(scene_name=scene.name, parameters=scene.parameters, source=source, merged=merged,
                          summary=summary_row(s, merged), model=model, method=method, stop_time=scene.stop_time,
                          fmu_path=str(fmu_path) if result is not None else None, wall_time=s.get("wall_time_s"),
                          time=None if result is None else result.time,
                          outputs=None if result is None else result.outputs,
                          events=None if result is None else [e.as_dict() for e in result.events],
                          recording=None if recording is None else str(Path(recording).resolve()),
                          record=record)
    return store_or_keep(factory, pending)


def cmd_sweep(args: argparse.Namespace) -> int:
    from db.schema import Sweep
    from runners.engine.sweep import (Grid, check_axes, check_corners, check_size, create_sweep, local_workers, parse_axis,
                               parse_points, record_axes, run_sweep)

    if (args.resume is None) == (args.scene is None):
        raise ValueError("give a scene file with --grid, or --resume SWEEP_ID")
    # the executor's settings are checked before anything is stored
    if (args.chunk is not None and args.chunk < 1) or (args.workers is not None and args.workers < 1):
        raise ValueError("--chunk and --workers must be at least 1")
    cores = os.cpu_count() or 1
    if args.workers is not None and args.workers > 4 * cores:
        raise ValueError(f"--workers {args.workers} is more than 4 per core of this machine ({cores} cores): "
                         "they would only wait for each other")
    if args.executor == "dask":
        if not args.scheduler:
            raise ValueError("--executor dask needs --scheduler tcp://HOST:PORT (or local:N)")
        if args.workers:
            raise ValueError("--workers applies to the local executor; a Dask cluster has its own workers")
        if args.record:
            raise ValueError("--record writes recordings where the point runs: use the local executor, or "
                             "record points after the sweep with runners rrd --sweep ID --points")
        local_workers(args.scheduler)
    elif args.scheduler or args.chunk:
        raise ValueError("--scheduler and --chunk apply to --executor dask")
    if args.resume is not None and (args.records or args.im or args.grid or args.stop_time is not None):
        given = [o for o, v in (("--grid", args.grid), ("--records", args.records), ("--im", args.im),
                                ("--stop-time", args.stop_time is not None)) if v]
        raise ValueError(f"--resume finishes sweep {args.resume} as it was created: drop {', '.join(given)} "
                         "(start a new sweep to change them)")
    factory = _database(args.db)
    require_writable(factory)  # before any work: a sweep stores every point
    fmu_path = fmu_path_from(args.fmu)
    if args.resume is None:
        scene = load_scene(args.scene)
        if args.stop_time is not None:
            scene.stop_time, scene.stop_time_given = args.stop_time, True
        check_times(scene.stop_time, scene.step, "the stop time", "the output step")
        with RockingFMU(fmu_path) as fmu:
            reals = {n for n, v in fmu.vars.items() if v.type == "Real" and v.causality == "parameter"}
            defaults = fmu.defaults()
            axes = [parse_axis(spec, reals) for spec in args.grid]
            records, intensity, notes = record_axes(factory, scene, axes, args.records, args.im,
                                                    args.stop_time is not None)
            if not axes and not records:
                raise ValueError("a sweep needs at least one --grid NAME=START:STOP:COUNT, or --records")
            check_axes(axes, {**defaults, **scene.parameters})
            grid = Grid(axes, records, intensity)
            check_size(grid.total, factory)
            if not records:  # the FMU's own checks, at the grid's corners, before the sweep exists
                notes += check_corners(fmu, grid, {**defaults, **scene.parameters})
        for note in notes:
            print(f"note: {note}")
        record = parse_points(args.record, grid.total) if args.record else None
        sweep_id = create_sweep(factory, scene, axes, defaults, records, intensity)
    else:
        sweep_id = args.resume
        with factory() as session:
            sw = session.get(Sweep, sweep_id)
            if sw is None:
                raise ValueError(f"no sweep {sweep_id} in the database")
            record = parse_points(args.record, sw.total) if args.record else None
    client = None
    if args.executor == "dask":
        from runners.engine.sweep import dask_client

        client = dask_client(args.scheduler)
    try:
        st = run_sweep(factory, sweep_id, fmu_path, workers=args.workers, progress=not args.no_progress,
                       record=record, record_dir=args.record_dir, client=client, chunk=args.chunk)
    except (KeyboardInterrupt, SweepError) as exc:
        with factory() as session:
            sw = session.get(Sweep, sweep_id)
            where = f"sweep {sweep_id} has {sw.done} of {sw.total} points stored: finish it with " \
                    f"runners sweep --resume {sweep_id}"
        print(f"error: {'interrupted' if isinstance(exc, KeyboardInterrupt) else exc}; {where}", file=sys.stderr)
        return 130 if isinstance(exc, KeyboardInterrupt) else 2
    finally:
        if client is not None:
            cluster = client.cluster
            client.close()
            if cluster is not None and args.scheduler.startswith("local:"):
                cluster.close()
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

    print(draw(_database(args.db), args.sweep, Path(args.out)))
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
                         "FMU parameter; repeatable")
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
    from runners.cli.rrd import add_parser as add_rrd_parser

    add_rrd_parser(sub)
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
