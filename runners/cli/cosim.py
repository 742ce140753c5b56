"""``runners cosim SYSTEM.toml``: blocks on a floor of a shear building, co-simulated through an
SSP file by fmpy or libcosim (runners.engine.cosim; docs/cosimulation.md)."""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from runners.cli import output
from runners.cli.args import common, files, output_file, positive
from runners.engine.files import staged

ENGINES = ("fmpy", "libcosim")  # runners.engine.cosim.ENGINES (imported when the command runs)
COUPLINGS = ("one-way", "two-way")
# the energy balance's scale when every energy of the run is zero (runners.analysis.cosim floors it
# there to divide by it): nothing to balance, no error to give
NO_ENERGY_J = 1e-300


def _progress_bar(desc: str):
    """A tqdm bar over the communication steps, or None (no terminal, --quiet)."""
    if not output.progress():
        return None, None
    import sys

    from tqdm import tqdm

    bar = tqdm(desc=desc, unit="step", file=sys.stderr, leave=False, mininterval=0.3)

    def tick(k: int, n: int) -> None:
        bar.total = n
        bar.n = k
        if k == n or k % 200 == 0:
            bar.refresh()

    return bar, tick


def _check_figure_path(out: str) -> None:
    """ValueError, before any run, unless the figure can be written there in a format matplotlib knows."""
    from matplotlib.figure import Figure

    path = Path(out)
    if not path.parent.is_dir():
        raise ValueError(f"--out {out}: the folder {path.parent} does not exist")
    formats = Figure().canvas.get_supported_filetypes()
    if path.suffix.lower().lstrip(".") not in formats:
        raise ValueError(f"--out {out}: give a file name ending in one of {', '.join('.' + f for f in sorted(formats))}")


def _csv_files(csv: str | None, compare: bool) -> dict[str, Path]:
    """The series files --csv names, by the label a refusal names them with: FILE itself, or with
    --compare FILE-one-way.csv and FILE-two-way.csv (the suffix kept), in the order of COUPLINGS."""
    if not csv:
        return {}
    path = Path(csv)
    if not compare:
        return {"--csv": path}
    return {f"--csv ({c})": path.with_name(f"{path.stem}-{c}{path.suffix or '.csv'}") for c in COUPLINGS}


def _load(args: argparse.Namespace) -> tuple[Any, list[str], Any]:
    """The system of the command line (its file, --coupling and --step over it), checked as the API
    checks it, the couplings to run and the database the runs are stored in (None with --no-store).
    ValueError, before anything runs, if an output would overwrite another, the database or a file
    the system names (its base record, the FMUs: runners.cli.clobber; _precheck refused what it could
    before the database was opened); DatabaseError, before anything runs, for a database that cannot
    be opened or written."""
    from runners.engine import cosim

    factory = None
    if not args.no_store:  # where the runs are stored, and a stored base record read
        from db.session import open_database, require_writable

        factory = open_database(args.db)
        require_writable(factory, "or run with --no-store")
    elif args.db:  # where a stored base record is read (without --db: ROCKING_DB or rocking.db, when one is named)
        from db.session import open_database

        factory = open_database(args.db)
    system = cosim.load_system(args.system, factory)
    names = dict(cosim.FILE_NAMES)
    if args.coupling:
        system, names["coupling"] = replace(system, coupling=args.coupling), "--coupling"
    if args.step is not None:
        system, names["step"] = replace(system, step=args.step), "--step"
    cosim.check_system(system, names, args.system)
    block, building = cosim.fmu_files(Path(args.fmu) if args.fmu else None)
    _refuse_clobbering(args, {"record file": system.record_file and str(system.record_file),
                              "blocks' FMU": str(block), "building's FMU": str(building)})
    return system, list(COUPLINGS) if args.compare else [system.coupling], None if args.no_store else factory


def _precheck(args: argparse.Namespace) -> None:
    """What can be refused before a database is opened (or made): an output that would overwrite
    another, the database, the record file the system file names or an FMU (runners.cli.clobber), a
    system file whose tables are invalid, a figure or series file that cannot be written."""
    from runners.engine import cosim

    _refuse_clobbering(args, {})
    record = cosim.check_system_file(args.system)
    block, building = cosim.fmu_files(Path(args.fmu) if args.fmu else None)
    _refuse_clobbering(args, {"record file": record and str(record), "blocks' FMU": str(block),
                              "building's FMU": str(building)})
    if args.out:
        _check_figure_path(args.out)
    if args.csv and not Path(args.csv).parent.is_dir():
        raise ValueError(f"--csv {args.csv}: the folder {Path(args.csv).parent} does not exist")


def _outputs(args: argparse.Namespace) -> dict[str, str | None]:
    """The files the command writes, by the label messages name them with: --ssp, --out and the
    series files of --csv each (--compare derives one per coupling)."""
    return {"--ssp": args.ssp, "--out": args.out, **{k: str(v) for k, v in _csv_files(args.csv, args.compare).items()}}


def _refuse_clobbering(args: argparse.Namespace, reads: dict[str, str | None]) -> None:
    """runners.engine.files.refuse for the command's outputs (_outputs), against ``reads`` and the
    database."""
    from runners.engine.files import refuse

    refuse(_outputs(args), reads, args.db)


def _notes(system: Any, couplings: list[str]) -> list[str]:
    """The notes of every coupling to run (runners.engine.cosim.system_notes), each once."""
    from runners.engine.cosim import system_notes

    return list(dict.fromkeys(n for c in couplings for n in system_notes(replace(system, coupling=c))))


def cmd_cosim(args: argparse.Namespace) -> int:
    from runners.analysis import cosim as checks

    _precheck(args)
    system, couplings, factory = _load(args)
    csvs = _csv_files(args.csv, args.compare)
    if "two-way" in couplings and int(system.blocks.get("contact.model", 0)) != 1:
        output.note("no energy balance: it needs the blocks' friction and impact losses, which the rocking-sliding "
                    "model reports ([contact] model = \"rocking-sliding\")")
    notes = _notes(system, couplings)
    for text in notes:
        output.note(text)
    with staged(_outputs(args)) as tmp:  # each written beside its file, moved onto it only if the command succeeds
        results = _run(args, system, couplings, tmp.get("--ssp"))
        docs = [_summary(r, seconds) for r, seconds in results]
        if not args.no_estimate:
            for (r, _), doc in zip(results, docs):
                doc.update(_estimate(r))
        for (r, _), (label, path) in zip(results, csvs.items()):
            _write(path, r.to_pandas().to_csv, tmp[label], index=False, float_format="%.17g")
        if args.out:
            fig = checks.figure([r for r, _ in results], title=system.name)
            _write(args.out, fig.savefig, tmp["--out"], dpi=120)
        if factory is not None:  # last: a run the database does not take is kept in a file, the outputs not written
            database = _store(factory, results, docs)
    out_files = [str(path) for path in csvs.values()]
    if args.json:
        out = {"runs": docs, "notes": notes}
        if factory is not None:
            out["database"] = database
        if args.ssp:
            out["ssp"] = str(args.ssp)
        if args.out:
            out["figure"] = str(args.out)
        if out_files:
            out["series"] = out_files
        output.emit_json(out)
        return 0
    _print_summaries(docs, database if factory is not None else None)
    if args.ssp:
        print(f"SSP written to {args.ssp}")
    if args.out:
        print(f"figure written to {args.out}")
    for path in out_files:
        print(f"series written to {path}")
    return 0


def _run(args: argparse.Namespace, system: Any, couplings: list[str], ssp: str | None) -> list[tuple[Any, float]]:
    """Each coupling's run and its wall time (s); the system's own coupling writes its SSP to ``ssp``."""
    from runners.engine import cosim

    block_fmu = Path(args.fmu) if args.fmu else None
    results = []
    for coupling in couplings:
        bar, tick = _progress_bar(f"{args.engine}, {coupling}")
        t0 = time.perf_counter()
        try:
            r = cosim.run(replace(system, coupling=coupling), engine=args.engine, block_fmu=block_fmu,
                          ssp=ssp if coupling == system.coupling else None, progress=tick)
        finally:
            if bar is not None:
                bar.close()
        results.append((r, time.perf_counter() - t0))
    return results


def _estimate(r: Any) -> dict:
    """runners.analysis.cosim.error_estimate of a run (the same system at twice its step), with a progress bar."""
    from runners.analysis import cosim as checks

    bar, tick = _progress_bar(f"{r.engine}, {r.system.coupling}, error estimate at {2 * r.system.step:g} s")
    try:
        return checks.error_estimate(r, progress=tick)
    finally:
        if bar is not None:
            bar.close()


def _store(factory: Any, results: list[tuple[Any, float]], docs: list[dict]) -> str:
    """Store the runs in one transaction (runners.engine.cosim_store); each summary gets its run's
    id (``cosim_id``). The database's URL, password hidden."""
    from db.session import display_url
    from runners.engine.cosim_store import pending_cosim, store_pending

    with output.busy("storing the run" + ("s" if len(results) > 1 else "")):
        ids = store_pending(factory, [pending_cosim(r, d, wall_time=seconds) for (r, seconds), d in zip(results, docs)])
    for d, ident in zip(docs, ids):
        d["cosim_id"] = ident
    return display_url(factory.kw["bind"])


def _summary(r: Any, seconds: float) -> dict:
    """summary() of one run, with its energy balance where the run allows one, and its wall time."""
    from runners.analysis import cosim as checks

    return {**checks.run_summary(r), "seconds": round(seconds, 3)}


def _write(path: str | Path, write, *args: Any, **kw: Any) -> None:
    """``write(*args, **kw)``, which writes the output ``path`` (to its temporary file): ValueError,
    in one line naming ``path``, if it cannot."""
    try:
        write(*args, **kw)
    except OSError as exc:
        raise ValueError(f"cannot write {path}: {exc.strerror or exc}") from None


def _print_summaries(docs: list[dict], database: str | None = None) -> None:
    """The runs' summaries (runners.analysis.cosim.summary) as text, each with the id it was stored
    under in ``database``."""
    g = 9.81
    for d in docs:
        f = ", ".join(f"{x:.3g}" for x in d["frequencies_hz"][:3])
        print(f"{d['system']}: {d['storeys']}-storey building (f = {f} Hz), blocks on floor {d['floor']}, "
              f"{d['coupling']} coupling, {d['engine']}, h = {d['step_s']:g} s: {d['steps']} steps to "
              f"{d['stop_time_s']:.6g} s in {d['seconds']:.2f} s")
        spikes = d["peak_floor_acceleration"] > 1.01 * d["peak_floor_acceleration_between_impacts"]
        peak = (f"{d['peak_floor_acceleration_between_impacts'] / g:.3g} g ({d['peak_floor_acceleration'] / g:.3g} g "
                "with the one-step spikes of the blocks' impacts)" if spikes else f"{d['peak_floor_acceleration'] / g:.3g} g")
        print(f"  floor {d['floor']}: peak acceleration {peak} (base {d['peak_base_acceleration'] / g:.3g} g), "
              f"peak displacement {1000 * d['peak_floor_displacement']:.3g} mm; peak base shear "
              f"{d['peak_base_shear'] / 1000:.4g} kN")
        verdicts = ", ".join(n for n in ("overturned", "lifts", "slides") if d[n]) or "none"
        if d.get("block2_overturned"):
            verdicts = verdicts.replace("overturned", "overturned (block 2)" if not d["overturned"] else "overturned")
        print(f"  block 1: peak |theta| {d['peak_abs_theta']:.4g} rad, {d['impacts']} impacts, "
              f"slip at the end {1000 * d['final_slip']:.3g} mm; verdicts: {verdicts}")
        if "energy_residual_end_j" in d:
            e, sc = d["energy_residual_end_j"], d["energy_scale_j"]
            until = " up to the overturn" if d["overturned"] else ""
            print(f"  energy balance (building + blocks){until}: " + (
                "no energy to balance (the base did no work and nothing moved)" if sc <= NO_ENERGY_J else
                f"residual {e:.3g} J at the end, {100 * abs(e) / sc:.2g} % of {sc:.4g} J: the coupling's error "
                "(docs/cosimulation.md; the same system without a step: runners simulate SYSTEM, docs/supports.md)"))
        if "error_estimate_step_s" in d:
            n, m = d["error_estimate_impacts"]
            same = "the same" if n == m else f"{m} at the double step: not settled"
            print(f"  error estimate (the same run at h = {d['error_estimate_step_s']:g} s): peak |theta| "
                  f"{d['error_estimate_peak_abs_theta']:.2g} rad, slip {1000 * d['error_estimate_final_slip']:.2g} mm; "
                  f"impacts {n} ({same})")
        if "cosim_id" in d:
            i = d["cosim_id"]
            print(f"  stored as co-simulated run {i} in {database} (runners db show cosim {i}; runners export "
                  f"--cosim {i} writes its series)")


def add_parser(sub) -> None:
    p = sub.add_parser("cosim", help="co-simulate blocks on a floor of a shear building (an SSP run by fmpy or libcosim)")
    p.add_argument("system", metavar="SYSTEM.toml",
                   help="a scene file with [building] and [coupling] tables; its [excitation] is the base's record "
                        "(docs/cosimulation.md, examples/cabinet_on_floor.toml)")
    p.add_argument("--engine", choices=list(ENGINES), default="fmpy",
                   help="the co-simulation master: fmpy (reads the SSP, steps the FMUs here) or libcosim (its SSP "
                        "loader and fixed-step algorithm); default fmpy")
    p.add_argument("--coupling", choices=list(COUPLINGS), help="override [coupling] mode")
    p.add_argument("--compare", action="store_true", help="run one-way and two-way coupling and plot both")
    p.add_argument("--step", type=positive, metavar="SECONDS", help="override [coupling] step (communication step)")
    p.add_argument("--ssp", type=output_file, metavar="FILE.ssp",
                   help="also keep the SSP file (both FMUs inside) to open in another co-simulation tool")
    p.add_argument("--out", type=output_file, metavar="FILE.png", help="draw the floor motion and block response")
    p.add_argument("--csv", type=output_file, metavar="FILE.csv",
                   help="write every output at every communication point (SI units); with --compare, FILE-one-way.csv "
                        "and FILE-two-way.csv")
    p.add_argument("--no-store", action="store_true",
                   help="do not store the runs in the database (by default each run is stored, as runners simulate "
                        "stores its run: runners db list cosims, runners export --cosim ID)")
    p.add_argument("--no-estimate", action="store_true",
                   help="skip the error estimate (by default each run is run again at twice the step, half the cost, "
                        "and the differences are its error estimate: docs/cosimulation.md#error-estimate)")
    common(p, db=True, fmu=True)
    files(p, reads=[("system", "system file"), "fmu"], writes=["ssp", "out", "csv"])
    p.set_defaults(func=cmd_cosim)
