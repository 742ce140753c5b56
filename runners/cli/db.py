"""``runners db init | list | show | import-unsaved``: the database from the command line."""

from __future__ import annotations

import argparse
import json
from typing import Any

from sqlalchemy import func, select

from db.catalogue import load_catalogue
from db.schema import Block, Measurement, Run, Scene, Sweep
from db.session import DB_HELP, MAX_ID, display_url, open_database

TABLES = {"blocks": Block, "runs": Run, "scenes": Scene, "sweeps": Sweep, "measurements": Measurement}


def _url(factory) -> str:
    return display_url(factory.kw["bind"])


def cmd_init(args: argparse.Namespace) -> int:
    factory = open_database(args.db, write=True)
    with factory.begin() as session:
        added, updated = load_catalogue(session)
    print(f"database ready: {_url(factory)}; catalogue: {added} blocks added, {updated} updated")
    return 0


def _row(obj) -> dict[str, Any]:
    out = {}
    for col in obj.__table__.columns:
        v = getattr(obj, col.key)
        out[col.key] = (v.isoformat() if hasattr(v, "isoformat") else
                        f"<{len(v)} bytes>" if isinstance(v, bytes) else v)
    return out


def cmd_list(args: argparse.Namespace) -> int:
    if args.limit < 1:
        raise ValueError(f"--limit must be at least 1, got {args.limit}")
    factory = open_database(args.db, write=False)
    model = TABLES[args.table]
    with factory() as session:
        total = session.scalar(select(func.count()).select_from(model))
        rows = session.scalars(select(model).order_by(model.id.desc()).limit(min(args.limit, MAX_ID))).all()
        if args.json:
            print(json.dumps([_row(r) for r in rows], indent=1, default=str))
            return 0
        print(f"{args.table}: {total} in {_url(factory)}" + (f", newest {args.limit}" if total > args.limit else ""))
        for r in rows:
            if model is Block:
                print(f"  {r.id:5d}  {r.name:16s} b = {r.half_width:.5g} m  h = {r.half_height:.5g} m  "
                      f"m = {r.mass:.4g} kg  {r.restitution_law}"
                      + (f" k = {r.k:g}" if r.k is not None else "")
                      + (f" x {r.correction:g}" if r.correction != 1 else ""))
            elif model is Run:
                summ = r.summary
                outcome = "error" if r.status == "error" else (
                    "overturned" if summ and summ.overturned else "survived")
                print(f"  {r.id:5d}  scene {r.scene_id:4d}  {r.model:22s} {r.method:12s} {outcome:10s} "
                      f"impacts {summ.impacts if summ else '-'}")
            elif model is Measurement:
                blocks = ", ".join(b.name for b in (r.block1, r.block2) if b is not None) or "-"
                print(f"  {r.id:5d}  {r.kind:20s} {r.n_samples:7d} rows  block {blocks:20s} {r.name}")
            elif model is Scene:
                print(f"  {r.id:5d}  {r.name}  ({r.n_blocks} block{'s' if r.n_blocks > 1 else ''})")
            else:
                print(f"  {r.id:5d}  scene {r.scene_id:4d}  {r.done}/{r.total} {r.status}")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    factory = open_database(args.db, write=False)
    with factory() as session:
        if args.what == "block":
            obj = session.scalar(select(Block).where(Block.name == args.key))
            if obj is None and args.key.isdecimal():
                obj = session.get(Block, int(args.key))
        else:
            if not args.key.isdecimal():
                raise ValueError(f"{args.what} ids are integers, got {args.key!r}")
            obj = session.get(TABLES[args.what + "s"], int(args.key))
        if obj is None:
            raise ValueError(f"no {args.what} {args.key!r} in {_url(factory)}")
        out = _row(obj)
        if isinstance(obj, Run):
            out["summary"] = _row(obj.summary) if obj.summary else None
            out["series"] = ({"names": obj.series.names, "n_samples": obj.series.n_samples}
                             if obj.series else None)
            out["scene"] = {"name": obj.scene.name, "parameters": obj.scene.parameters}
    print(json.dumps(out, indent=1, default=str))
    return 0


def cmd_import_unsaved(args: argparse.Namespace) -> int:
    from db.store import read_unsaved, store_pending, stored_already

    pending = read_unsaved(args.file)
    factory = open_database(args.db, write=True)
    with factory.begin() as session:
        done = stored_already(session, pending)
        run_id = done if done is not None else store_pending(session, pending).id
    what = f"{pending['scene']['name']}, {pending['model']}, run at {pending['created_at']}"
    if done is not None:
        print(f"{args.file} is stored already: run {run_id} ({what}) in {_url(factory)}")
    else:
        print(f"stored run {run_id} ({what}) from {args.file} in {_url(factory)}; the file can now be deleted")
    return 0


def add_parser(sub) -> None:
    dbp = sub.add_parser("db", help="the experiment database: init, list, show, import-unsaved")
    dsub = dbp.add_subparsers(dest="db_command", required=True)
    init = dsub.add_parser("init", help="create or migrate the database and load the block catalogue")
    init.set_defaults(func=cmd_init)
    lst = dsub.add_parser("list", help="list blocks, runs, scenes, sweeps or measurements (newest first)")
    lst.add_argument("table", choices=list(TABLES))
    lst.add_argument("--limit", type=int, default=20)
    lst.add_argument("--json", action="store_true")
    lst.set_defaults(func=cmd_list)
    show = dsub.add_parser("show", help="one block (by name or id), run, scene, sweep or measurement, as JSON")
    show.add_argument("what", choices=["block", "run", "scene", "sweep", "measurement"])
    show.add_argument("key")
    show.set_defaults(func=cmd_show)
    imp = dsub.add_parser("import-unsaved", help="store a run that could not be stored when it ran "
                                                 "(the rocking-unsaved-*.json file the error named)")
    imp.add_argument("file", help="rocking-unsaved-*.json")
    imp.set_defaults(func=cmd_import_unsaved)
    for p in (init, lst, show, imp):
        p.add_argument("--db", help=DB_HELP)
