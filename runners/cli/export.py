"""``runners export RUN_ID | --sweep SWEEP_ID | --cosim COSIM_ID``: stored results to CSV,
Parquet or JSON files (runners.engine.export; docs/export.md)."""

from __future__ import annotations

import argparse

from runners.cli import output
from runners.cli.args import common, files, object_id, output_file

FORMATS = ("csv", "parquet", "json")  # runners.engine.export.FORMATS (imported when the command runs)


def cmd_export(args: argparse.Namespace) -> int:
    from runners.engine.export import choose_format, export_cosim, export_run, export_sweep

    if sum(x is not None for x in (args.run, args.sweep, args.cosim)) != 1:
        raise ValueError("give a RUN_ID, or --sweep SWEEP_ID, or --cosim COSIM_ID (one of them)")
    fmt = choose_format(args.format, args.out)  # before opening the database: a bad option is refused first
    from db.schema import Run, Sweep
    from db.session import open_database
    from runners.cli.parser import resolve_latest

    factory = open_database(args.db, write=False)
    progress = output.progress()
    if args.cosim is not None:
        from runners.engine.cosim_store import resolve

        cosim_id = resolve(factory, args.cosim)
        done = export_cosim(factory, cosim_id, fmt, args.out, progress=progress)
        if args.json:
            output.emit_json({"files": [str(p) for p in done.files], "rows": done.rows})
        else:
            print(f"exported co-simulated run {cosim_id}: {done.rows} samples to {', '.join(map(str, done.files))}")
        return 0
    if args.sweep is not None:
        args.sweep = resolve_latest(factory, Sweep, args.sweep, "sweep")
    elif args.run == "latest":  # the newest run with a time history: sweep points keep outcomes only
        from sqlalchemy import func, select

        with factory() as session:
            newest = session.scalar(select(func.max(Run.id)).where(Run.sweep_id.is_(None)))
        if newest is None:
            raise ValueError("no single run in the database (sweep points are exported with --sweep ID)")
        args.run = int(newest)
    if args.sweep is not None:
        done = export_sweep(factory, args.sweep, fmt, args.out, progress=progress)
        what = f"sweep {args.sweep}: {done.rows} grid points" + (f" ({done.pending} not stored yet, status pending)"
                                                                 if done.pending else "")
    else:
        done = export_run(factory, args.run, fmt, args.out, progress=progress)
        what = f"run {args.run}: {done.rows} samples and {done.events} events"
    if args.json:
        out = {"files": [str(p) for p in done.files], "rows": done.rows}
        if done.events is not None:
            out["events"] = done.events
        if args.sweep is not None:
            out["pending"] = done.pending
        output.emit_json(out)
    else:
        print(f"exported {what} to {', '.join(str(p) for p in done.files)}")
    return 0


def add_parser(sub) -> None:
    ex = sub.add_parser("export", help="write a stored run's series and events, a sweep's points, or a "
                                       "co-simulated run's series, as CSV, Parquet or JSON")
    ex.add_argument("run", nargs="?", type=object_id, metavar="RUN_ID",
                    help="the run to export (or 'latest': the newest run that is not a sweep point)")
    ex.add_argument("--sweep", type=object_id, metavar="SWEEP_ID",
                    help="export a sweep instead (or 'latest'): one row per grid point")
    ex.add_argument("--cosim", type=object_id, metavar="COSIM_ID",
                    help="export a co-simulated run instead (runners cosim; or 'latest'): every output at every "
                         "communication point")
    ex.add_argument("--format", choices=list(FORMATS),
                    help="file format (default: from --out's suffix, else csv)")
    ex.add_argument("--out", type=output_file, metavar="PATH",
                    help="file to write (default: run-ID.EXT, sweep-ID.EXT or cosim-ID.EXT in the working folder; a run's "
                         "events go beside it, as NAME-events.EXT; an existing file is replaced)")
    common(ex, db=True)
    files(ex, writes=["out"])
    ex.set_defaults(func=cmd_export)
