"""``runners db init | list | show | delete | import-unsaved``: the database from the command line."""

from __future__ import annotations

import argparse
from typing import Any

from runners.cli.args import common, count, files, object_id
from runners.cli.output import emit_json

TABLE_NAMES = ["blocks", "runs", "scenes", "sweeps", "measurements", "cosims"]
DEFAULT_LIMIT = 20


def _tables() -> dict:
    from db.schema import Block, Measurement, Run, Scene, Sweep

    return {"blocks": Block, "runs": Run, "scenes": Scene, "sweeps": Sweep, "measurements": Measurement}


def _url(factory) -> str:
    from db.session import display_url

    return display_url(factory.kw["bind"])


def cmd_init(args: argparse.Namespace) -> int:
    from db.catalogue import load_catalogue
    from db.session import open_database

    factory = open_database(args.db, write=True)
    with factory.begin() as session:
        added, updated = load_catalogue(session)
    if args.json:
        emit_json({"database": _url(factory), "blocks_added": added, "blocks_updated": updated})
    else:
        print(f"database ready: {_url(factory)}; catalogue: {added} blocks added, {updated} updated")
    return 0


def _row(obj) -> dict[str, Any]:
    out = {}
    for col in obj.__table__.columns:
        v = getattr(obj, col.key)
        out[col.key] = (v.isoformat() if hasattr(v, "isoformat") else
                        f"<{len(v)} bytes>" if isinstance(v, bytes) else v)
    return out


def _outcome(r) -> str:
    summ = r.summary
    return "error" if r.status == "error" else ("overturned" if summ and summ.overturned else "survived")


def _run_row(r) -> dict[str, Any]:
    return _row(r) | {"scene": r.scene.name, "outcome": _outcome(r),
                      "impacts": r.summary.impacts if r.summary else None}


RUN_HEAD = f"{'id':>7}  {'created (UTC)':16}  {'scene':28} {'sweep, point':13} {'model':22} {'method':12} " \
           f"{'outcome':10} impacts"


def _run_line(r) -> str:
    where = f"{r.sweep_id}, {r.grid_index}" if r.sweep_id is not None else "-"
    created = r.created_at.strftime("%Y-%m-%d %H:%M") if r.created_at else "-"
    impacts = r.summary.impacts if r.summary and r.summary.impacts is not None else "-"
    return (f"{r.id:>7}  {created:16}  {r.scene.name[:28]:28} {where:13} {r.model[:22]:22} {r.method[:12]:12} "
            f"{_outcome(r):10} {impacts}")


def _list_runs(args: argparse.Namespace, factory) -> int:
    """Runs, newest first: the single runs with each sweep as one line (default), the single
    runs only (--single), or the points of one sweep (--sweep ID)."""
    from sqlalchemy import func, select
    from sqlalchemy.orm import selectinload

    from db.schema import Run, Scene, Sweep
    from runners.cli.parser import resolve_latest

    if args.sweep is not None and args.single:
        raise ValueError("give --sweep ID or --single, not both")
    limit = min(args.limit, MAX_ID())
    with factory() as session:
        total = session.scalar(select(func.count()).select_from(Run))
        singles = session.scalar(select(func.count()).select_from(Run).where(Run.sweep_id.is_(None)))
        load = (selectinload(Run.summary), selectinload(Run.scene))
        if args.sweep is not None:
            sweep_id = resolve_latest(factory, Sweep, args.sweep, "sweep")
            if session.get(Sweep, sweep_id) is None:
                raise ValueError(f"no sweep {args.sweep} in {_url(factory)}")
            where = Run.sweep_id == sweep_id
            matching = session.scalar(select(func.count()).select_from(Run).where(where))
            rows = session.scalars(select(Run).where(where).options(*load).order_by(Run.id.desc()).limit(limit)).all()
            items, what = [("run", r) for r in rows], f"points of sweep {sweep_id}"
        else:
            rows = session.scalars(select(Run).where(Run.sweep_id.is_(None)).options(*load)
                                   .order_by(Run.id.desc()).limit(limit)).all()
            items = [("run", r) for r in rows]
            matching, what = singles, "single runs"
            if not args.single:  # each sweep as one line, where its newest point would stand
                groups = session.execute(select(Run.sweep_id, func.count(), func.max(Run.id))
                                         .where(Run.sweep_id.is_not(None)).group_by(Run.sweep_id)).all()
                names = dict(session.execute(select(Sweep.id, Scene.name).join(Scene, Sweep.scene_id == Scene.id)
                                             .where(Sweep.id.in_([g[0] for g in groups]))).all())
                items += [("sweep", {"sweep": g[0], "points": g[1], "newest_run": g[2], "scene": names.get(g[0])})
                          for g in groups]
                items.sort(key=lambda it: -(it[1].id if it[0] == "run" else it[1]["newest_run"]))
                matching, what = singles + len(groups), "single runs and sweeps"
                items = items[:limit]
        more = matching - len(items)
        if args.json:
            emit_json({"database": _url(factory), "total": total, "shown": len(items), "more": more,
                       "runs": [_run_row(r) for kind, r in items if kind == "run"],
                       "sweeps": [g for kind, g in items if kind == "sweep"]})
            return 0
        points = total - singles
        print(f"runs: {total} in {_url(factory)} ({singles} single, {points} sweep point{'s' if points != 1 else ''}); "
              f"{what}, newest first")
        if items:
            print(RUN_HEAD)
        for kind, r in items:
            print(_run_line(r) if kind == "run" else
                  f"{'':>7}  sweep {r['sweep']}: {r['points']} point{'s' if r['points'] != 1 else ''} of "
                  f"{r['scene'] or '?'} (runners db list runs --sweep {r['sweep']})")
        if more > 0:
            print(f"... {more} more {what}: --limit {len(items) + more} shows them all")
    return 0


def MAX_ID() -> int:
    from db.session import MAX_ID as most

    return most


def cmd_list(args: argparse.Namespace) -> int:
    from sqlalchemy import func, select

    from db.schema import Block, Measurement, Scene
    from db.session import open_database

    if (args.sweep is not None or args.single) and args.table != "runs":
        raise ValueError("--sweep and --single filter runs: runners db list runs --sweep ID")
    factory = open_database(args.db, write=False)
    if args.table == "runs":
        return _list_runs(args, factory)
    if args.table == "cosims":
        return _list_cosims(args, factory)
    model = _tables()[args.table]
    with factory() as session:
        total = session.scalar(select(func.count()).select_from(model))
        rows = session.scalars(select(model).order_by(model.id.desc()).limit(min(args.limit, MAX_ID()))).all()
        status = _statuses(factory, rows) if args.table == "sweeps" else {}
        if args.json:
            emit_json({"database": _url(factory), "total": total, "shown": len(rows), "more": total - len(rows),
                       args.table: [_row(r) | ({"status": status[r.id]} if status else {}) for r in rows]})
            return 0
        print(f"{args.table}: {total} in {_url(factory)}" + (f", newest {args.limit}" if total > args.limit else ""))
        for r in rows:
            if model is Block:
                print(f"  {r.id:5d}  {r.name:16s} b = {r.half_width:.5g} m  h = {r.half_height:.5g} m  "
                      f"m = {r.mass:.4g} kg  {r.restitution_law}"
                      + (f" k = {r.k:g}" if r.k is not None else "")
                      + (f" x {r.correction:g}" if r.correction != 1 else ""))
            elif model is Measurement:
                blocks = ", ".join(b.name for b in (r.block1, r.block2) if b is not None) or "-"
                print(f"  {r.id:5d}  {r.kind:20s} {r.n_samples:7d} rows  block {blocks:20s} {r.name}")
            elif model is Scene:
                print(f"  {r.id:5d}  {r.name}  ({r.n_blocks} block{'s' if r.n_blocks > 1 else ''})")
            else:
                name = session.get(Scene, r.scene_id).name
                how = status[r.id] + (f" (runners sweep {r.id} finishes it)" if status[r.id] in UNFINISHED else "")
                print(f"  {r.id:5d}  scene {name[:28]:28s} {r.done}/{r.total} {how}")
        if total > len(rows):
            print(f"... {total - len(rows)} more: --limit {total} shows them all")
    return 0


COSIM_HEAD = (f"{'id':>7}  {'created (UTC)':16}  {'system':28} {'engine':9} {'coupling':9} {'step (s)':>9} "
              f"{'stop (s)':>8} {'floor':>9} {'PFA (g)':>8} {'theta (rad)':>11} impacts  verdicts")


def _cosim_line(r) -> str:
    s = r.summary or {}
    created = r.created_at.strftime("%Y-%m-%d %H:%M") if r.created_at else "-"
    key = "peak_floor_acceleration_between_impacts"
    pfa = f"{s[key] / 9.81:.3g}" if key in s else "-"
    theta = f"{s['peak_abs_theta']:.4g}" if "peak_abs_theta" in s else "-"
    verdicts = ", ".join(n for n in ("overturned", "lifts", "slides") if s.get(n)) or ("none" if s else "-")
    return (f"{r.id:>7}  {created:16}  {r.name[:28]:28} {r.engine:9} {r.coupling:9} {r.step:>9.4g} {r.stop_time:>8.4g} "
            f"{f'{r.floor} of {r.storeys}':>9} {pfa:>8} {theta:>11} {s.get('impacts', '-'):>7}  {verdicts}")


def _list_cosims(args: argparse.Namespace, factory) -> int:
    """Co-simulated runs (runners cosim), newest first: one line each (--json: every column but
    the blobs, as db show cosim gives them)."""
    from sqlalchemy import func, select
    from sqlalchemy.orm import selectinload

    from db.schema import CosimRun
    from runners.engine.cosim_store import row

    with factory() as session:
        total = session.scalar(select(func.count()).select_from(CosimRun))
        rows = session.scalars(select(CosimRun).options(selectinload(CosimRun.series), selectinload(CosimRun.record))
                               .order_by(CosimRun.id.desc()).limit(min(args.limit, MAX_ID()))).all()
        if args.json:
            emit_json({"database": _url(factory), "total": total, "shown": len(rows), "more": total - len(rows),
                       "cosims": [{k: v for k, v in row(r).items() if k not in ("source", "system", "block_parameters",
                                                                                "building_parameters")}
                                  for r in rows]})
            return 0
        print(f"co-simulated runs: {total} in {_url(factory)}" + (f", newest {args.limit}" if total > args.limit else "")
              + "; PFA: the floor's peak absolute acceleration between the blocks' impacts")
        if rows:
            print(COSIM_HEAD)
        for r in rows:
            print(_cosim_line(r))
        if total > len(rows):
            print(f"... {total - len(rows)} more: --limit {total} shows them all")
    return 0


UNFINISHED = ("interrupted", "stopped", "failed")  # statuses of a sweep that runners sweep ID finishes


def _statuses(factory, sweeps) -> dict[int, str]:
    """Each sweep's status as it is: "running" only while a process runs it (runners.engine.sweep_lock)."""
    from runners.engine.sweep_lock import shown_status

    return shown_status(factory, {r.id: r.status for r in sweeps})


def cmd_show(args: argparse.Namespace) -> int:
    from sqlalchemy import select

    from db.schema import Block, Run
    from db.session import open_database
    from runners.cli.parser import resolve_latest

    factory = open_database(args.db, write=False)
    if args.what == "cosim":
        from db.schema import CosimRun
        from runners.engine.cosim_store import resolve, row

        if not (args.key.isdecimal() or args.key == "latest"):
            raise ValueError(f"cosim ids are integers (or 'latest'), got {args.key!r}")
        ident = resolve(factory, args.key)
        with factory() as session:
            emit_json(row(session.get(CosimRun, ident)))
        return 0
    with factory() as session:
        if args.what == "block":
            obj = session.scalar(select(Block).where(Block.name == args.key))
            if obj is None and args.key.isdecimal():
                obj = session.get(Block, int(args.key))
        else:
            if not (args.key.isdecimal() or args.key == "latest"):
                raise ValueError(f"{args.what} ids are integers (or 'latest'), got {args.key!r}")
            model = _tables()[args.what + "s"]
            obj = session.get(model, resolve_latest(factory, model, args.key if args.key == "latest"
                                                    else int(args.key), args.what))
        if obj is None:
            raise ValueError(f"no {args.what} {args.key!r} in {_url(factory)}")
        out = _row(obj)
        if args.what == "sweep":
            out["status"] = _statuses(factory, [obj])[obj.id]
        if isinstance(obj, Run):
            out["summary"] = _row(obj.summary) if obj.summary else None
            out["series"] = ({"names": obj.series.names, "n_samples": obj.series.n_samples}
                             if obj.series else None)
            out["scene"] = {"name": obj.scene.name, "parameters": obj.scene.parameters}
    emit_json(out)
    return 0




def cmd_delete(args: argparse.Namespace) -> int:
    """runners db delete sweep|run|record KEY [--force]: runners.engine.database.Database.delete."""
    from runners.cli import output
    from runners.engine.database import open_db

    if not args.key.strip():
        from runners.engine.deletion import KEY_WORDS

        raise ValueError(f"the {args.what} to delete is empty: give {KEY_WORDS[args.what]}")
    db = open_db(args.db)
    with output.busy(f"deleting {args.what} {args.key}"):
        done = db.delete(args.what, args.key, force=args.force)
    if args.json:
        emit_json({**done.as_dict(), "database": db.url})
    else:
        print(f"{done.text()} (in {db.url})")
    return 0


def cmd_import_unsaved(args: argparse.Namespace) -> int:
    from db.session import open_database
    from db.store import COSIM_UNSAVED_FORMAT, read_unsaved, store_pending, stored_already

    pending = read_unsaved(args.file)
    factory = open_database(args.db, write=True)
    if pending["format"] == COSIM_UNSAVED_FORMAT:
        return _import_unsaved_cosim(args, pending, factory)
    with factory.begin() as session:
        done = stored_already(session, pending)
        run_id = done if done is not None else store_pending(session, pending).id
    what = f"{pending['scene']['name']}, {pending['model']}, run at {pending['created_at']}"
    if args.json:
        emit_json({"run_id": run_id, "stored_already": done is not None, "file": str(args.file),
                   "database": _url(factory)})
    elif done is not None:
        print(f"{args.file} is stored already: run {run_id} ({what}) in {_url(factory)}")
    else:
        print(f"stored run {run_id} ({what}) from {args.file} in {_url(factory)}; the file can now be deleted")
    return 0


def _import_unsaved_cosim(args: argparse.Namespace, pending: dict, factory) -> int:
    """import-unsaved of a co-simulated run runners cosim kept in a file (db.store.store_cosims)."""
    from db.store import cosim_stored_already, store_cosim_pending

    with factory.begin() as session:
        done = cosim_stored_already(session, pending)
        cosim_id = done if done is not None else store_cosim_pending(session, pending).id
    what = f"{pending['name']}, co-simulated ({pending['engine']}, {pending['coupling']}), run at {pending['created_at']}"
    if args.json:
        emit_json({"cosim_id": cosim_id, "stored_already": done is not None, "file": str(args.file),
                   "database": _url(factory)})
    elif done is not None:
        print(f"{args.file} is stored already: co-simulated run {cosim_id} ({what}) in {_url(factory)}")
    else:
        print(f"stored co-simulated run {cosim_id} ({what}) from {args.file} in {_url(factory)}; the file can now be "
              "deleted")
    return 0


def add_parser(sub) -> None:
    dbp = sub.add_parser("db", help="the experiment database: init, list, show, delete, import-unsaved")
    dsub = dbp.add_subparsers(dest="db_command", required=True, metavar="COMMAND")
    init = dsub.add_parser("init", help="create or migrate the database and load the block catalogue")
    init.set_defaults(func=cmd_init)
    lst = dsub.add_parser("list", help="list blocks, runs, scenes, sweeps, measurements or co-simulated runs "
                                       "(cosims; newest first)")
    lst.add_argument("table", choices=TABLE_NAMES)
    lst.add_argument("--limit", type=count, default=DEFAULT_LIMIT, metavar="N",
                     help=f"show the newest N (default {DEFAULT_LIMIT}); a last line says how many more there are")
    lst.add_argument("--sweep", type=object_id, metavar="SWEEP_ID",
                     help="runs: the points of this sweep (or 'latest')")
    lst.add_argument("--single", action="store_true", help="runs: only the runs that are not sweep points "
                                                           "(by default each sweep is one line)")
    lst.set_defaults(func=cmd_list)
    show = dsub.add_parser("show", help="one block (by name or id), run, scene, sweep, measurement or co-simulated "
                                        "run (cosim), as JSON")
    show.add_argument("what", choices=["block", "run", "scene", "sweep", "measurement", "cosim"])
    show.add_argument("key", metavar="ID", help="the id (or 'latest'); a block's name or id")
    show.set_defaults(func=cmd_show)
    rm = dsub.add_parser("delete", help="delete a sweep, a run, a co-simulated run or a record with every row that "
                                        "belongs to it (refused if other rows need it, unless --force)",
                         description="Delete a sweep, a run, a co-simulated run (cosim) or a record with every row that "
                                     "belongs to it, in one transaction (refused if other rows need it, unless --force). "
                                     "A deleted sweep's or co-simulated run's id is never given again; in an SQLite "
                                     "database a deleted run's or record's id is, when it was the newest "
                                     "(docs/database.md#deleting).")
    rm.add_argument("what", choices=["sweep", "run", "cosim", "record"])
    rm.add_argument("key", metavar="ID|NAME", help="a sweep's, run's or cosim's id (or 'latest'); a record's name or id")
    rm.add_argument("--force", action="store_true",
                    help="also delete what needs it (a record's runs, co-simulated runs, sweeps and measurements) and "
                         "take a run out of its sweep; says how many")
    rm.set_defaults(func=cmd_delete)
    imp = dsub.add_parser("import-unsaved", help="store a run (simulated or co-simulated) that could not be stored when it ran "
                                                 "(the rocking-unsaved-*.json file the error named)")
    imp.add_argument("file", help="rocking-unsaved-*.json")
    files(imp, reads=[("file", "unsaved run file")])
    imp.set_defaults(func=cmd_import_unsaved)
    for p in (init, lst, show, rm, imp):
        common(p, db=True)
