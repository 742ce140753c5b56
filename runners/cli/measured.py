"""``runners import-measured | compare | calibrate``: measured experiments in the database."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from runners.cli import output
from runners.cli.args import common, figure_file, files, object_id, output_file, renamed
from runners.cli.output import emit_json

if TYPE_CHECKING:
    import numpy as np

    from db.schema import Block, Measurement


def find_block(session, key: str) -> Block:
    """A block by name (or id)."""
    from sqlalchemy import select

    from db.schema import Block

    block = session.scalar(select(Block).where(Block.name == key))
    if block is None and key.isdigit():
        block = session.get(Block, int(key))
    if block is None:
        raise ValueError(f"no block {key!r} in the database (runners db init loads the catalogue; "
                         "runners db list blocks shows them)")
    return block


def ground_acceleration(kind: str, time: np.ndarray, columns: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(time, horizontal ground acceleration in m/s^2) of a motion record; a table
    displacement is differentiated twice (np.gradient: central differences inside)."""
    import numpy as np

    if kind == "table-displacement":
        t, x = time, columns["displacement"]
        if np.isnan(x).any():
            raise ValueError("a table displacement record needs a value at every time to be differentiated")
        return t, np.gradient(np.gradient(x, t), t)
    a = columns["acceleration"]
    ok = ~np.isnan(a)
    return time[ok], a[ok]


def cmd_import(args: argparse.Namespace) -> int:
    from db.schema import Excitation
    from db.session import open_database
    from db.store import add_measurement
    from runners.engine.measured import read_measured

    given = {"kind": args.kind, "units": args.units, "sign": args.sign, "block": args.block, "block2": args.block2,
             "name": args.name, "source": args.source, "instrument": args.instrument,
             "sampling_rate": None if args.sampling_rate is None else str(args.sampling_rate),
             "uncertainty": args.uncertainty}
    m = read_measured(args.file, given)  # everything is checked before the database is touched
    motion = m.kind not in ("peaks", "rotation")
    if motion:  # the ground motion it amounts to becomes a record: the checks of runners records import
        from runners.engine.records import check_sampling

        t, a = ground_acceleration(m.kind, m.time, m.columns)
        check_sampling(args.file, t)
    factory = open_database(args.db, write=True)
    with factory.begin() as session:  # one transaction: all of it or nothing
        record = None
        if motion:  # the ground motion it amounts to becomes a record (runners records list)
            from runners.engine.records import ensure_record

            record = ensure_record(session, m.meta["name"], t, a, source=m.meta.get("source"),
                                   file_name=m.file_name)
        b1 = find_block(session, m.meta["block"]) if m.meta.get("block") else None
        b2 = find_block(session, m.meta["block2"]) if m.meta.get("block2") else None
        if not motion and b1 is None:
            raise ValueError(f"a {m.kind} measurement needs its block (# block: or --block NAME)")
        if "block2.theta" in m.columns and b2 is None:
            raise ValueError("block2.theta is measured: name the upper block (# block2: or --block2 NAME)")
        excitation = None
        if args.excitation is not None:
            if motion:
                raise ValueError("--excitation links a rotation or peak table to the motion that drove it; "
                                 "a motion record is its own excitation")
            excitation = session.get(Excitation, args.excitation)
            if excitation is None:
                raise ValueError(f"no excitation {args.excitation} in the database")
        row = add_measurement(session, name=m.meta["name"], kind=m.kind, time=m.time, columns=m.columns,
                              units=m.units, sign=m.sign, block1=b1, block2=b2, source=m.meta.get("source"),
                              instrument=m.meta.get("instrument"), sampling_rate=m.meta.get("sampling_rate"),
                              uncertainty=m.uncertainty, file_name=m.file_name, file_sha256=m.sha256,
                              record=record)
        if excitation is not None:
            row.excitation = excitation
        session.flush()
        mid, eid = row.id, row.excitation_id
        rname = record.name if record is not None else None
    blocks = ", ".join(b.name for b in (b1, b2) if b is not None)
    if args.json:
        emit_json({"measurement": mid, "kind": m.kind, "rows": len(m.time), "start": float(m.time[0]),
                   "end": float(m.time[-1]), "blocks": [b.name for b in (b1, b2) if b is not None],
                   "record": rname, "excitation": eid})
        return 0
    print(f"imported measurement {mid}: {m.kind}, {len(m.time)} rows ({m.time[0]:g} to {m.time[-1]:g} s)"
          + (f", block {blocks}" if blocks else "")
          + (f", record {rname!r} (excitation {eid})" if motion else f", excitation {eid}" if eid else ", free rocking"))
    return 0


def get_measurement(session, mid: int) -> Measurement:
    from db.schema import Measurement

    m = session.get(Measurement, mid)
    if m is None:
        raise ValueError(f"no measurement {mid} in the database (runners db list measurements)")
    return m


def load_measurement(session, mid: int) -> tuple[Measurement, np.ndarray, dict[str, np.ndarray]]:
    from db import series

    m = get_measurement(session, mid)
    t, cols = series.unpack(m.names, m.n_samples, m.data)
    return m, t, cols


def motion_record(factory, mid: int) -> int:
    """The id of the record a stored ground or table motion amounts to (runners simulate --motion)."""
    with factory() as session:
        m = get_measurement(session, mid)
        if m.excitation is None or m.excitation.record_id is None:
            raise ValueError(f"measurement {mid} is a {m.kind}, not a ground or table motion")
        return m.excitation.record_id


def _theta(t: np.ndarray, cols: dict[str, np.ndarray], column: str) -> tuple[np.ndarray, np.ndarray]:
    import numpy as np

    if column not in cols:
        raise ValueError(f"the measurement has no {column} (it has {', '.join(cols)})")
    ok = ~np.isnan(cols[column])
    return t[ok], cols[column][ok]


def cmd_compare(args: argparse.Namespace) -> int:
    import numpy as np

    from db.schema import Measurement, Run
    from db.session import open_database
    from db.store import load_run_series
    from runners.analysis.compare import compare_peaks, compare_rotation, decay_from_peaks, format_comparison, plot_comparison
    from runners.cli.parser import resolve_latest
    from runners.engine.fmu import Event

    factory = open_database(args.db)
    args.run = resolve_latest(factory, Run, args.run, "run")
    args.measurement = resolve_latest(factory, Measurement, args.measurement, "measurement")
    with factory() as session:
        _, t_sim, cols, stored_events = load_run_series(session, args.run, "simulate it without --no-store")
        m, tm, mcols = load_measurement(session, args.measurement)
        if m.kind not in ("peaks", "rotation"):
            raise ValueError(f"measurement {m.id} is a {m.kind} record, not a rotation to compare with")
        events = [Event.from_dict(e) for e in stored_events]
        sigma_theta, sigma_time, kind, name = m.uncertainty_angle, m.uncertainty_time, m.kind, m.name
    column = f"block{args.block}.theta"
    if column not in cols:
        raise ValueError(f"run {args.run} has no {column}")
    t_meas, th_meas = _theta(tm, mcols, column)
    peaks = [e for e in events if e.kind == "peak" and (args.block == 1 or "theta2" in e.values)]
    p_t = np.array([e.t for e in peaks])
    p_th = np.array([e.values.get("theta", e.values.get(f"theta{args.block}", math.nan)) for e in peaks])
    if kind == "peaks":
        c = compare_peaks(decay_from_peaks(t_meas, th_meas), p_t, p_th)
    else:
        impacts = np.array([e.t for e in events if e.kind == "impact"
                            and (args.block == 1 or e.labels.get("contact") != "ground")])
        c = compare_rotation(t_meas, th_meas, t_sim, cols[column], impacts, p_t, p_th, sigma_theta or 0.0)
    text = [f"run {args.run} against measurement {args.measurement} ({name}, {kind}), {column}",
            format_comparison(c, sigma_theta, sigma_time)]
    doc = {"run": args.run, "measurement": args.measurement, "name": name, "kind": kind, "column": column,
           **_comparison_dict(c)}
    if args.out:
        shift = t_meas[0] if kind == "peaks" else 0.0  # a peak table's first row is the run's time 0
        plot_comparison(Path(args.out), f"run {args.run} against measurement {args.measurement}: {name}",
                        t_sim, cols[column], t_meas - shift, th_meas, sigma_theta, sigma_time,
                        kind == "peaks" and bool(np.all(th_meas >= 0)))
        text.append(f"plot             {args.out}")
        doc["figure"] = str(args.out)
    if args.recording:
        from runners.cli.rrd import record_run

        shift = t_meas[0] if kind == "peaks" else 0.0
        path = record_run(factory, args.run, Path(args.recording), args.fmu, {column: (t_meas - shift, th_meas)},
                          remember=False)
        text.append(f"recording        {path}")
        doc["recording"] = str(path)
    if args.json:
        emit_json(doc)
    else:
        print("\n".join(text))
    return 0


def _comparison_dict(c) -> dict:
    """A Comparison (runners.analysis.compare) as JSON: angles in rad, times in s, errors simulated
    minus measured."""
    import numpy as np

    def num(x):
        return None if x is None or not np.isfinite(x) else float(x)

    d_theta, d_time = c.peak_errors()
    impacts = c.impact_errors()
    return {"peaks": [{"t_measured": num(a), "t_simulated": num(b), "theta_measured": num(m), "theta_simulated": num(s)}
                      for a, b, m, s in c.peak_pairs],
            "peak_theta_error_rms": num(np.sqrt(np.mean(d_theta ** 2))) if len(d_theta) else None,
            "peak_time_error_rms": num(np.sqrt(np.mean(d_time ** 2))) if len(d_time) else None,
            "impacts": [{"t_measured": num(a), "t_simulated": num(b)} for a, b in c.impact_pairs],
            "impact_time_error_rms": num(np.sqrt(np.mean(impacts ** 2))) if len(impacts) else None,
            "theta_rms": num(c.theta_rms), "theta_max": num(c.theta_max), "samples": c.samples,
            "missing_peaks": c.missing_peaks}


def cmd_calibrate(args: argparse.Namespace) -> int:
    from sqlalchemy import select

    from db.catalogue import block_parameters
    from db.schema import Block, Measurement
    from db.session import open_database, require_writable
    from runners.analysis.calibrate import PARAMETER_NAMES, assess, calibrate
    from runners.analysis.compare import decay_from_peaks, decay_from_rotation
    from runners.cli.parser import resolve_latest
    from runners.engine.fmu import RockingFMU, fmu_path_from

    factory = open_database(args.db)
    args.measurement = resolve_latest(factory, Measurement, args.measurement, "measurement")
    if not args.no_store:
        require_writable(factory, "or run with --no-store")
    with factory() as session:
        m, tm, mcols = load_measurement(session, args.measurement)
        if m.kind not in ("peaks", "rotation"):
            raise ValueError(f"measurement {m.id} is a {m.kind} record; calibration needs a free-rocking "
                             "peak table or rotation history")
        if m.block1 is None:
            raise ValueError(f"measurement {m.id} names no block")
        block = m.block1
        base = block_parameters(block)
        t, th = _theta(tm, mcols, "block1.theta")
        decay = (decay_from_peaks(t, th) if m.kind == "peaks" else
                 decay_from_rotation(t, th, m.uncertainty_angle or 0.0))
        sig = (m.uncertainty_angle, m.uncertainty_time)
        time_unit = (m.units or {}).get("time")
        block_fields = {c.key: getattr(block, c.key) for c in Block.__table__.columns if c.key != "id"}
    where = f"measurement {args.measurement}, block {block_fields['name']}, law {args.law}"
    with RockingFMU(fmu_path_from(args.fmu)) as fmu:
        try:
            fit = calibrate(fmu, {**fmu.defaults(), **base}, decay, args.law, *sig, progress=output.progress())
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    name = PARAMETER_NAMES[args.law]
    text = (f"{name} = {fit.value:.4f}, 95% interval [{fit.low:.4f}, {fit.high:.4f}] "
            f"(theta0 {fit.theta0:.4f} rad, chi2/dof {fit.chi2_per_dof:.3g}, {fit.dof} dof, "
            f"{fit.evaluations} simulations"
            + ("; uncertainty not stated, Anagnostopoulos's 0.5 deg and 0.1 s assumed" if fit.sigma_assumed else "") + ")")
    problems, why = assess(fit, decay, time_unit)
    verdict = (f"the fit is poor ({name} = {fit.value:.4g}, 95% interval [{fit.low:.4g}, {fit.high:.4g}]: "
               f"{', '.join(problems)})" + (f": {why}" if why else "")) if problems else ""
    if problems and not args.accept_poor_fit:
        raise ValueError(f"{where}: {verdict}; " + ("use --accept-poor-fit to report it anyway" if args.no_store else
                                                    "not stored (use --accept-poor-fit to store it)"))
    out = {"measurement": args.measurement, "law": args.law, "value": fit.value, "low": fit.low, "high": fit.high,
           "theta0": fit.theta0, "chi2_per_dof": fit.chi2_per_dof, "dof": fit.dof, "poor_fit": problems}
    if problems:
        text += f"; accepted with --accept-poor-fit although {verdict}"
    if not args.no_store:
        fields = dict(block_fields)
        fields["restitution_law"] = {"constant": "constant", "modified": "modified", "correction": "housner"}[args.law]
        fields.update({"constant": {"eta": fit.value, "correction": 1.0}, "modified": {"k": fit.value, "correction": 1.0},
                       "correction": {"correction": fit.value}}[args.law])
        fields["source"] = f"calibrated from measurement {args.measurement} ({m.name}): {text}"
        with factory.begin() as session:
            stem = f"{block_fields['name']}-cal-m{args.measurement}-{args.law}"
            taken = set(session.scalars(select(Block.name).where(Block.name.like(f"{stem}%"))))
            fields["name"] = next(n for n in (stem, *(f"{stem}-{i}" for i in range(2, 10000))) if n not in taken)
            new = Block(**fields)
            session.add(new)
            session.flush()
            out["block"], out["block_id"] = new.name, new.id
    if args.json:
        emit_json(out)
    else:
        print(f"measurement {args.measurement}, block {block_fields['name']}, law {args.law}: {text}")
        if "block" in out:
            print(f"stored block     {out['block']} (id {out['block_id']})")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """A stored run written as a measured file, optionally with reading noise: a synthetic
    experiment with known parameters, for checking import, compare and calibrate."""
    import numpy as np

    from db.schema import Run
    from db.session import open_database
    from db.store import load_run_series
    from runners.cli.parser import resolve_latest
    from runners.engine.fmu import Event

    if not (args.noise_theta >= 0 and args.noise_time >= 0 and math.isfinite(args.noise_theta + args.noise_time)):
        raise ValueError("--noise-theta and --noise-time must be finite and >= 0")
    if args.every < 1:
        raise ValueError(f"--every must be at least 1 (got {args.every})")
    if args.max_peaks < 1:
        raise ValueError(f"--max-peaks must be at least 1 (got {args.max_peaks}): it is how many peaks to keep")
    factory = open_database(args.db)
    args.run = resolve_latest(factory, Run, args.run, "run")
    with factory() as session:
        run, t, cols, stored_events = load_run_series(session, args.run)
        events = [Event.from_dict(e) for e in stored_events]
        block, scene_name = args.block, run.scene.name
    rng = np.random.default_rng(args.seed)
    if args.kind == "peaks":
        peaks = [e for e in events if e.kind == "peak"][: args.max_peaks]
        if not peaks:
            raise ValueError(f"run {args.run} has no peak events")
        times = np.array([0.0] + [e.t for e in peaks])
        theta = np.array([cols["block1.theta"][0]] + [e.values["theta"] for e in peaks])
    else:
        times, theta = t[:: args.every], cols["block1.theta"][:: args.every]
    times = times + rng.normal(0, args.noise_time, len(times)) * (np.arange(len(times)) > 0)
    theta = theta + rng.normal(0, args.noise_theta * math.pi / 180, len(theta))
    if np.any(np.diff(times) <= 0):
        raise ValueError(f"--noise-time {args.noise_time:g} s reorders the samples; lower it or use --seed")
    out = Path(args.out)
    header = [f"# kind: {args.kind}", "# units: time=s, theta=deg", "# sign: clockwise",
              f"# source: synthetic: run {args.run} ({scene_name}) exported by runners export-measured, "
              f"normal noise of {args.noise_theta:g} deg and {args.noise_time:g} s, random seed: {args.seed}"]
    if block:
        header.append(f"# block: {block}")
    if args.noise_theta or args.noise_time:
        header.append(f"# uncertainty: theta={args.noise_theta:g} deg, time={args.noise_time:g} s")
    lines = header + ["time,theta"] + [f"{a:.6f},{b * 180 / math.pi:.6f}" for a, b in zip(times, theta)]
    out.write_text("\n".join(lines) + "\n")
    if args.json:
        emit_json({"file": str(out), "kind": args.kind, "rows": len(times), "run": args.run})
    else:
        print(f"{out}: {args.kind}, {len(times)} rows")
    return 0


def add_parser(sub) -> None:
    imp = sub.add_parser("import-measured", help="import a measured file (CSV or PEER .AT2) into the database")
    imp.add_argument("file", help="CSV with '# key: value' header lines, or a PEER NGA .AT2 record "
                                  "(format: docs/measured.md)")
    imp.add_argument("--kind", help="peaks, rotation, table-displacement, table-acceleration or ground-acceleration")
    imp.add_argument("--units", help="e.g. 'time=s, theta=deg' (overrides the file's header)")
    imp.add_argument("--sign", help="clockwise or counterclockwise (angles); +x or -x (motions)")
    imp.add_argument("--block", help="block name in the database (the lower block of a stack)")
    imp.add_argument("--block2", help="upper block name, for a stack")
    imp.add_argument("--name", help="a name for the measurement (default: the file's)")
    imp.add_argument("--source", help="where it comes from (lab, paper, figure)")
    imp.add_argument("--instrument", help="e.g. video 25 fps, LVDT, accelerometer")
    imp.add_argument("--sampling-rate", type=float, help="Hz")
    imp.add_argument("--uncertainty", help="e.g. 'theta=0.5 deg, time=0.1 s' or 'acceleration=0.01 g'")
    imp.add_argument("--excitation", type=int, metavar="EXCITATION_ID",
                     help="for a forced-rocking rotation or peak table: the stored excitation that drove it "
                          "(e.g. the one a table record's import printed); none means free rocking")
    files(imp, reads=[("file", "measured file")])
    imp.set_defaults(func=cmd_import)
    cmp_ = sub.add_parser("compare", help="a stored run against a measurement: aligned errors, plot, recording")
    cmp_.add_argument("run", type=object_id, metavar="RUN_ID", help="run id (or 'latest')")
    cmp_.add_argument("measurement", type=object_id, metavar="MEASUREMENT_ID", help="measurement id (or 'latest')")
    cmp_.add_argument("--block", type=int, choices=[1, 2], default=1, help="which block's theta (default 1)")
    cmp_.add_argument("--out", type=figure_file, metavar="PNG",
                      help="draw both in this figure, with the measurement's uncertainty")
    renamed(cmp_, "--plot", "--out", dest="out", type=figure_file)
    cmp_.add_argument("--recording", type=output_file, metavar="RRD",
                      help="also write the run's Rerun recording with the measurement overlaid to this file")
    renamed(cmp_, "--rrd", "--recording", dest="recording", type=output_file)
    files(cmp_, reads=["fmu"], writes=["out", "recording"])
    cmp_.set_defaults(func=cmd_compare)
    exp = sub.add_parser("export-measured", help="write a stored run as a measured CSV file, with optional noise")
    exp.add_argument("run", type=object_id, metavar="RUN_ID", help="run id (or 'latest')")
    exp.add_argument("--out", type=output_file, required=True, help="CSV file to write")
    exp.add_argument("--kind", choices=["peaks", "rotation"], default="peaks",
                     help="peaks: the release and the peak events; rotation: block 1's theta")
    exp.add_argument("--block", help="block name to declare in the file's header")
    exp.add_argument("--noise-theta", type=float, default=0.0, help="standard deviation of angle noise (deg)")
    exp.add_argument("--noise-time", type=float, default=0.0, help="standard deviation of time noise (s)")
    exp.add_argument("--seed", type=int, default=0, help="random seed of the noise")
    exp.add_argument("--every", type=int, default=1, help="rotation: keep every Nth output sample")
    exp.add_argument("--max-peaks", type=int, default=1000, help="peaks: keep at most this many (at least 1)")
    files(exp, writes=["out"])
    exp.set_defaults(func=cmd_export)
    cal = sub.add_parser("calibrate", help="fit the restitution to a measured free-rocking decay")
    cal.add_argument("measurement", type=object_id, metavar="MEASUREMENT_ID",
                     help="measurement id (or 'latest'): a peak table or rotation history")
    cal.add_argument("--law", required=True, choices=["constant", "modified", "correction"],
                     help="fit eta (constant), k (modified) or Housner's correction factor")
    cal.add_argument("--no-store", action="store_true", help="do not store the calibrated block")
    cal.add_argument("--accept-poor-fit", action="store_true",
                     help="report and store a fit that fails the checks (chi2/dof above 5, the parameter at a bound "
                          "of the search, an interval outside the physical range: docs/measured.md); refused "
                          "otherwise")
    cal.set_defaults(func=cmd_calibrate)
    for p in (imp, exp):
        common(p, db=True)
    for p in (cmp_, cal):
        common(p, db=True, fmu=True)
