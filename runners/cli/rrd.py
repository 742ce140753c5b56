"""``runners rrd | view | screenshot``: Rerun recordings of stored runs and sweeps."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from runners.cli import output
from runners.cli.args import common, files, folder, object_id, output_file, renamed
from runners.cli.output import emit_json


def record_run(factory, run_id: int, out: Path, fmu_arg: str | None, measured: dict | None = None,
               remember: bool = True) -> Path:
    """Write the recording of stored run `run_id` (its series, events and parameters) to `out`;
    with `remember`, store the path with the run."""
    from db.schema import Run
    from db.store import load_run_series
    from runners.engine.fmu import Event, RockingFMU, fmu_path_from
    from runners.engine.recording import write_recording

    with factory() as session:
        run = session.get(Run, run_id)
        hint = (f"sweep points keep summaries only; record them with runners rrd --sweep {run.sweep_id} "
                f"--points {run.grid_index}" if run is not None and run.sweep_id is not None else "")
        run, time_, cols, stored_events = load_run_series(session, run_id, hint)
        events = [Event.from_dict(e) for e in stored_events]
        params, name = dict(run.scene.parameters), run.scene.name
        if run.sweep_id is not None:
            from runners.engine.sweep import stored_point_parameters

            params = stored_point_parameters(session, run)
            name = f"{name} (sweep {run.sweep_id}, point {run.grid_index})"
        record = None
        if run.excitation is not None and run.excitation.record is not None:
            from runners.engine.records import file_of, row

            r = run.excitation.record
            record = row(r) | {"source": r.source}
            params.update({"excitation.kind": 4, "excitation.file": str(file_of(r)),
                           "excitation.scale": run.excitation.scale if run.excitation.scale is not None else 1.0})
    with RockingFMU(fmu_path_from(fmu_arg)) as fmu:
        defaults = fmu.defaults()
    write_recording(out, name, time_, cols, {**defaults, **params}, events, measured, record)
    if remember:
        with factory.begin() as session:
            session.get(Run, run_id).recording = str(Path(out).resolve())
    return Path(out)


def _checked(text: str, check, option: str = "--out") -> str:
    """A path given to --out, checked as argparse would (`check`: args.output_file or args.folder)."""
    import argparse

    try:
        return check(text)
    except argparse.ArgumentTypeError as exc:
        raise ValueError(f"argument {option}: {exc}") from None


def cmd_rrd(args: argparse.Namespace) -> int:
    from db.schema import Run, Sweep
    from db.session import open_database
    from runners.cli.parser import resolve_latest
    from runners.engine.fmu import fmu_path_from

    factory = open_database(args.db, write=True)  # the recording's path is stored with its run
    if args.sweep is not None:
        args.sweep = resolve_latest(factory, Sweep, args.sweep, "sweep")
    if args.points is not None:
        if args.sweep is None:
            raise ValueError("--points records grid points of a sweep: give --sweep SWEEP_ID too")
        from runners.engine.sweep import parse_points, record_points

        out = _checked(args.out, folder) if args.out else None
        with factory() as session:
            sw = session.get(Sweep, args.sweep)
            if sw is None:
                raise ValueError(f"no sweep {args.sweep} in the database")
            indices = parse_points(args.points, sw.total)
        done = []
        for index, path in record_points(factory, args.sweep, indices, fmu_path_from(args.fmu), out,
                                         progress=output.progress()):
            done.append({"point": index, "recording": str(path)})
            if not args.json:
                print(f"point {index}: {path}")
        if args.json:
            emit_json({"sweep": args.sweep, "points": done})
        return 0
    out = _checked(args.out, output_file) if args.out else None
    if args.sweep is not None:
        if args.run is not None:
            raise ValueError("give a RUN_ID or --sweep SWEEP_ID, not both")
        from runners.analysis.sweep_map import sweep_picture
        from runners.engine.recording import write_sweep_recording

        with output.busy(f"recording sweep {args.sweep}"):
            path = write_sweep_recording(Path(out or f"recordings/sweep-{args.sweep}.rrd"), factory, args.sweep,
                                         sweep_picture(factory, args.sweep))
        emit_json({"sweep": args.sweep, "recording": str(path)}) if args.json else print(path)
        return 0
    if args.run is None:
        raise ValueError("give a RUN_ID, or --sweep SWEEP_ID")
    run_id = resolve_latest(factory, Run, args.run, "run")
    measured = None
    if args.measured:
        from runners.engine.measured import read_measured_csv

        measured = read_measured_csv(args.measured)
    path = record_run(factory, run_id, Path(out or f"recordings/run-{run_id}.rrd"), args.fmu, measured)
    emit_json({"run": run_id, "recording": str(path)}) if args.json else print(path)
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    """Open a stored run's recording in the Rerun viewer (written first if it has none)."""
    from db.schema import Run
    from db.session import open_database
    from runners.cli.parser import resolve_latest

    factory = open_database(args.db)
    args.run = resolve_latest(factory, Run, args.run, "run")
    with factory() as session:
        run = session.get(Run, args.run)
        if run is None:
            raise ValueError(f"no run {args.run} in the database")
        path = run.recording
    if not path or not Path(path).is_file():
        path = str(record_run(factory, args.run, Path(f"recordings/run-{args.run}.rrd"), args.fmu).resolve())
    viewer = shutil.which("rerun") or str(Path(sys.executable).parent / "rerun")
    if not Path(viewer).exists():
        raise OSError("the Rerun viewer (rerun, from pip rerun-sdk) is not installed")
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise OSError(f"no display to open the viewer on; the recording is {path} "
                      "(open it with the Rerun viewer on a machine with a display)")
    subprocess.Popen([viewer, path])
    emit_json({"run": args.run, "recording": path}) if args.json else print(f"opened {path} in the Rerun viewer")
    return 0


def cmd_screenshot(args: argparse.Namespace) -> int:
    """A stored run in Rerun's web viewer, drawn by headless Chromium, as a PNG (the viewer
    starts playing the run when it opens, so the scene shows it a fraction of a second in)."""
    from db.schema import Run
    from db.session import open_database
    from runners.analysis.screenshot import screenshot
    from runners.cli.parser import resolve_latest

    factory = open_database(args.db)
    args.run = resolve_latest(factory, Run, args.run, "run")
    with tempfile.TemporaryDirectory() as tmp, output.busy(f"screenshot of run {args.run}"):
        rrd = record_run(factory, args.run, Path(tmp) / f"run-{args.run}.rrd", args.fmu, remember=False)
        png = screenshot(rrd, Path(args.out))
    emit_json({"run": args.run, "figure": str(png)}) if args.json else print(png)
    return 0


def add_parser(sub) -> None:
    rr_ = sub.add_parser("rrd", help="write the Rerun recording (.rrd) of a stored run or sweep")
    rr_.add_argument("run", type=object_id, nargs="?", metavar="RUN_ID", help="run id (or 'latest')")
    rr_.add_argument("--sweep", type=object_id, metavar="SWEEP_ID",
                     help="record a sweep (or 'latest'): its map and per-point summaries")
    rr_.add_argument("--points", metavar="POINTS",
                     help="with --sweep: simulate these stored grid points again in full and record each "
                          "(e.g. 0,17,40-45), storing their series")
    rr_.add_argument("--out", metavar="RRD|DIR",
                     help="recording to write (default: recordings/run-ID.rrd or recordings/sweep-ID.rrd); "
                          "with --points, the folder the recordings go to (default: recordings/sweep-ID)")
    renamed(rr_, "--record-dir", "--out", dest="out")
    rr_.add_argument("--measured", metavar="CSV", help="overlay a measured series on a run's recording "
                                                        "(docs/measured.md)")
    renamed(rr_, "--no-progress", "--quiet", dest="no_progress", value=True)
    files(rr_, reads=[("measured", "measured file"), "fmu"], writes=["out"])
    rr_.set_defaults(func=cmd_rrd, no_progress=False)
    vw = sub.add_parser("view", help="open a stored run's recording in the Rerun viewer")
    vw.add_argument("run", type=object_id, metavar="RUN_ID", help="run id (or 'latest')")
    vw.set_defaults(func=cmd_view)
    sh = sub.add_parser("screenshot", help="a PNG of Rerun's viewer showing a stored run (needs Chromium)")
    sh.add_argument("run", type=object_id, metavar="RUN_ID", help="run id (or 'latest')")
    sh.add_argument("--out", type=output_file, default="rerun_viewer.png", metavar="PNG",
                    help="figure to write (default: ./rerun_viewer.png; --out docs/figures/rerun_viewer.png "
                         "replaces the tracked one)")
    files(sh, writes=["out"])
    sh.set_defaults(func=cmd_screenshot)
    for p in (rr_, vw, sh):
        common(p, db=True, fmu=True, fmu_help="FMU whose parameter defaults the recording shows "
                                              "(default: ROCKING_FMU, else build/RockingBlock.fmu)")
