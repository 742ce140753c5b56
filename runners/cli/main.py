"""The ``runners`` commands simulate, sweep, map, bench and figures (their options and the
dispatch: runners.cli.parser).

Every failure prints one line ``error: ...`` to stderr and exits non-zero.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from db.session import DB_HELP, DatabaseError, require_writable
from runners.cli import output
from runners.engine.fmu import FMUError, RockingFMU, fmu_path_from
from runners.engine.scene import SceneError, check_times, load_scene, unused_parameter
from runners.engine.summary import SUMMARY_OUTPUTS, format_summary, summarize
from runners.engine.sweep import SweepError

from runners.cli.parser import PYTHON_METHODS  # noqa: E402


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
    from db.schema import Sweep
    from runners.analysis.sweep_map import draw
    from runners.cli.parser import resolve_latest

    factory = _database(args.db)
    sweep_id = resolve_latest(factory, Sweep, args.sweep, "sweep")
    with output.busy(f"map of sweep {sweep_id}"):
        text = draw(factory, str(sweep_id), Path(args.out))
    if args.json:
        output.emit_json({"sweep": sweep_id, "figure": str(args.out), "summary": text})
    else:
        print(text)
    return 0


def _bench_stages(args: argparse.Namespace, fmu: Path) -> list[tuple[str, object]]:
    """(name, callable returning a Markdown section) of the benchmarks the options ask for."""
    from runners.analysis import bench as b

    def records():
        from runners.analysis.bench_records import run_record_bench

        return run_record_bench(fmu, repeats=args.fmpy_repeats)

    def study():
        from runners.analysis.bench_records import run_study_bench

        return run_study_bench(fmu)

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
            ("record-driven run", records), ("fragility study", study),
            ("sweep size", lambda: b.run_sweep_size_bench(fmu))]


def cmd_bench(args: argparse.Namespace) -> int:
    from runners.analysis.bench import markdown_sections

    if args.quick and not args.charts:
        raise ValueError("--quick applies to --charts only")
    if args.charts and not args.out:
        raise ValueError("--charts writes its charts to a folder: give --out DIR")
    if args.out and not args.charts:
        raise ValueError("--out is the folder of --charts")
    if sum(map(bool, (args.dask, args.sweep_size, args.records, args.charts))) > 1:
        raise ValueError("give one of --charts, --dask, --records and --sweep-size (or none: every benchmark)")
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
    from runners.analysis.figures import write_figures

    with output.busy("figures"):
        paths = [str(p) for p in write_figures(fmu_path_from(args.fmu), Path(args.out))]
    if args.json:
        output.emit_json({"figures": paths})
    else:
        print("\n".join(paths))
    return 0


# the parser and the dispatch live in runners.cli.parser, which imports nothing heavy (runners --help)
from runners.cli.parser import build_parser, main  # noqa: E402,F401


if __name__ == "__main__":
    sys.exit(main())
