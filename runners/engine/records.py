"""Ground-motion records as excitations: store them with their intensity measures, import the
FEMA P695 sets and record files, and hand a stored record to the FMU as a file.

Python API (the ``runners records`` commands are a thin layer over it)::

    from db.session import open_database
    from runners.engine import records
    factory = open_database()                                  # rocking.db by default
    records.import_fema(factory, ["nearfield_pulse"])          # 28 components
    rec = records.import_file(factory, "my_record.AT2")        # PEER NGA .AT2, CSV or our text format
    rows = records.table(factory, "fema-p695/nearfield_pulse")  # names, provenance, measures
    path = records.file_of(factory, "fema-p695/nearfield_pulse/1a")  # for excitation.file

Units SI (time in s, accelerations in m/s^2), signs as docs/conventions.md.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterable

import numpy as np
from sqlalchemy import select

from db.records import MEASURES, add_record, find_record, free_name, samples, suite_records
from db.schema import Record
from runners.engine.intensity import G0, measures
from runners.engine.record_files import (MAX_INTERVAL, MAX_SAMPLES, MIN_INTERVAL, cache_folder, cached_file_ok,
                                         cached_record_file, check_size, read_record_file, samples_sha256)
from runners.engine.scene import KIND_NAMES, KINDS, MAX_PGA_G, Scene, check_pga, with_times

TAIL = 5.0  # s simulated after a record ends, unless a scene or a sweep says otherwise
PLAIN_TEXT_HINT = 1.0  # m/s^2: a record file (our text format) whose PGA is below this may be in g
# Notes (not errors) on a scaled record (docs/limits.md, "Notes, not errors"). The
# strongest motions recorded: Anderson (2010) lists the 100 largest PGAs up to 2007 (35 above 1 g)
# and PGVs (the largest 3.18 m/s, Chi-Chi 1999); the largest horizontal PGA since is about 2.7 g
# (K-NET MYG004, Tohoku 2011; NIED). Scaling a record far changes more than its size: the response
# to records scaled by large factors is biased (Luco & Bazzurro 2007).
HIGH_PGA_G = 2.0  # g: a scaled PGA above this is beyond all but a handful of recorded motions
# the strongest horizontal shaking recorded, as the notes and refusals of scaled records give it
# (MAX_PGA_G, 5 g, leaves room above it). About 4 g was recorded only vertically, 3.9 g at KiK-net
# IWTH25 in the 2008 Iwate-Miyagi earthquake (Aoi et al. 2008)
LARGEST_PGA = ("the largest horizontal PGA recorded is about 2.7 g, at K-NET MYG004 in the 2011 Tohoku earthquake "
               "(NIED 2011)")
LARGE_SCALE = 4.0  # a record scaled by more than this (in absolute value)
HIGH_PGV = 2.0  # m/s: or to a PGV above this


def store_record(session, name: str, time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None,
                 **provenance: Any) -> Record:
    """A new record with its intensity measures (runners.engine.intensity)."""
    m = measures(time, ah)
    return add_record(session, name, time, ah, av, samples_sha256(time, ah, av), measures=m.as_dict(),
                      **provenance)


def unit_notes(rec: Record, units_given: bool = False) -> list[str]:
    """Warnings when a record's PGA suggests the wrong units (it is stored all the same). A record
    read from our text format without `units_given` (its values taken as m/s2) whose PGA is below
    PLAIN_TEXT_HINT (0.1 g) gets the option that reads it in g: accelerograms in g read as m/s2
    look like weak motions."""
    if rec.pga is None:
        return []
    g = rec.pga / G0
    plain = (not units_given and rec.file_name is not None
             and Path(rec.file_name).suffix.lower() not in (".at2", ".csv"))
    hint = "; if they are in g, import the file with --units acceleration=g" if plain else ""
    if g > 3.0:
        return [f"PGA {g:.3g} g is larger than almost any recorded earthquake's: are the values in m/s2?"]
    if g < 0.005:
        return [f"PGA {g:.3g} g is very small for an earthquake: are the values in m/s2 (not g or cm/s2 "
                f"read as m/s2)?{hint}"]
    if plain and rec.pga < PLAIN_TEXT_HINT:
        return [f"PGA {g:.3g} g: the values of {rec.file_name} were read as m/s2 (a record file's unit){hint}"]
    return []


def check_scaled(label: str, ah: np.ndarray, av: np.ndarray | None, scale: float) -> None:
    """The FMU's checks of a scaled record, made here first so the message names the record, not
    the cached file the FMU reads: peak at most 1000 m/s2. (A vertical column below -g is
    allowed: the run reports the flight, docs/contact.md.)"""
    pga = abs(scale) * float(np.max(np.abs(ah))) / G0
    if not pga <= MAX_PGA_G:
        raise ValueError(f"{label}: scale {scale:g} brings its PGA to {pga:.3g} g, beyond {MAX_PGA_G:g} g: "
                         f"{LARGEST_PGA}; check the scale")
    top = float(max(np.max(np.abs(ah)), 0.0 if av is None else np.max(np.abs(av))))
    if not abs(scale) * top <= 1000.0:
        raise ValueError(f"{label}: scale {scale:g} brings its peak acceleration to {abs(scale) * top:g} m/s2, beyond "
                         "1000 m/s2 (about 100 g)")


def scaling_notes(cases: Iterable[tuple[str, str, float, dict[str, Any]]]) -> list[str]:
    """Notes on records scaled beyond recorded motions, at most two whatever the number of runs:
    a PGA above HIGH_PGA_G (likely a PGA meant in m/s2 given in g), and a scale factor above
    LARGE_SCALE or a PGV above HIGH_PGV. `cases`: (record name, level as text or "", scale, the
    unscaled record's measures in SI: pga in m/s2, pgv in m/s), one per scaled record the runs use."""
    cases = [(name, level, abs(scale), m) for name, level, scale, m in cases if m.get("pga")]
    place, seen = [], {}  # each case's position among its record's cases
    for name, *_ in cases:
        place.append(seen.get(name, 0))
        seen[name] = place[-1] + 1
    keep = [k for k, (_, _, scale, m) in enumerate(cases) if _high(scale, m) or _far(scale, m)]
    return _notes([cases[k] for k in keep], [place[k] for k in keep], list(seen))


def _high(scale, m: dict[str, Any]):
    """Whether a record of measures `m` (SI) scaled by `scale` (>= 0; a float, or an array of them)
    has a PGA above HIGH_PGA_G."""
    return scale * m["pga"] / G0 > HIGH_PGA_G


def _far(scale, m: dict[str, Any]):
    """Whether a record of measures `m` (SI) scaled by `scale` (>= 0; a float, or an array of them)
    is scaled by more than LARGE_SCALE or to a PGV above HIGH_PGV."""
    return (scale > LARGE_SCALE) | (scale * (m.get("pgv") or 0.0) > HIGH_PGV)


def _notes(cases: list[tuple[str, str, float, dict]], place: list[int], names: list[str]) -> list[str]:
    """scaling_notes of the `cases` beyond recorded motions (_high or _far; scales >= 0), each at
    `place` among its record's cases, of the records `names` the runs use. Linear in the cases."""
    high = [k for k, (_, _, scale, m) in enumerate(cases) if _high(scale, m)]
    large = [k for k, (_, _, scale, m) in enumerate(cases) if _far(scale, m)]
    notes = []
    if high:
        top = max(cases[k][2] * cases[k][3]["pga"] / G0 for k in high)  # the largest PGA given, in g
        notes.append(f"PGA above {HIGH_PGA_G:g} g: {_listing(high, cases, place, names)}. PGAs are in g ({top:.3g} "
                     f"m/s2 is {top / G0:.3g} g); {LARGEST_PGA}, and only 35 records up to 2007 exceed 1 g "
                     "(Anderson 2010)")
    if large:
        notes.append(f"scaled by more than {LARGE_SCALE:g} or to a PGV above {HIGH_PGV:g} m/s: "
                     f"{_listing(large, cases, place, names)}. The largest PGV recorded is 3.18 m/s (Anderson 2010), "
                     "and the response to a record scaled far from its own intensity is biased (Luco & Bazzurro "
                     "2007): prefer records nearer the level")
    return notes


def _listing(chosen: list[int], cases: list[tuple[str, str, float, dict]], place: list[int], names: list[str]) -> str:
    """The records and levels of the cases numbered `chosen` (each at `place` among its record's
    cases; `names`: every record of the runs) in one phrase: each record with its levels
    (consecutive ones as a range), scale factors and largest scaled PGA (g) and PGV (m/s), their
    common suite named once; or "all N records at LEVELS" when every record is concerned at the
    same levels."""
    by: dict[str, list[int]] = {}
    for k in chosen:
        by.setdefault(cases[k][0], []).append(k)
    levels = {name: _levels_text([cases[k][1] for k in ks if cases[k][1]], [place[k] for k in ks if cases[k][1]])
              for name, ks in by.items()}
    first = next(iter(levels.values()))
    if len(names) > 1 and len(by) == len(names) and first and all(lv == first for lv in levels.values()):
        return f"all {len(names)} records at {first}"
    suite = os.path.commonprefix(names).rpartition("/")[0] if len(names) > 1 else ""
    parts = []
    for name, ks in by.items():
        scales = [cases[k][2] for k in ks]
        pga = max(cases[k][2] * cases[k][3]["pga"] / G0 for k in ks)
        pgv = max(cases[k][2] * (cases[k][3].get("pgv") or 0.0) for k in ks)
        at = f" at {levels[name]}" if levels[name] else ""
        span = f"x{min(scales):.3g}" + (f" to x{max(scales):.3g}" if max(scales) > min(scales) else "")
        parts.append(f"{name.removeprefix(suite + '/') if suite else name}{at} ({span}, PGA "
                     f"{'up to ' * (len(ks) > 1)}{pga:.3g} g, PGV {'up to ' * (len(ks) > 1)}{pgv:.3g} m/s)")
    return (f"in {suite}, " if suite else "") + "; ".join(parts)


LISTED_LEVELS = 6  # levels named one by one at most; more are shortened to the first few and the last


def _levels_text(levels: list[str], at: list[int]) -> str:
    """Levels as text: "0.8 g to 1.2 g" for more than two consecutive ones (`at`: their positions
    among the record's levels, increasing), else each of them (the first three, "...", and the
    last when there are more than LISTED_LEVELS)."""
    if len(levels) > 2 and at[-1] - at[0] == len(at) - 1:
        return f"{levels[0]} to {levels[-1]}"
    if len(levels) > LISTED_LEVELS:
        return f"{', '.join(levels[:3])}, ..., {levels[-1]} ({len(levels):,} levels)"
    return ", ".join(levels)


def sweep_scaling_notes(refs: list, intensity, axes: list, parameters: dict[str, Any]) -> list[str]:
    """scaling_notes of a record sweep, once for the whole sweep: its records (RecordRefs) at each
    intensity level (runners.engine.grid.Intensity: its levels in g or m/s), at each value of a
    --grid scale axis, or else at the scene's own excitation.scale (`parameters`). Levels are
    weighed in arrays, a record at a time: only those beyond recorded motions become cases, so a
    sweep of a million levels is noted in a fraction of a second."""
    if intensity is None:
        axis = next((a for a in axes if a.name == "excitation.scale"), None)
        scales = [float(parameters.get("excitation.scale", 1.0))] if axis is None else axis.values.tolist()
        return scaling_notes([(r.name, "" if axis is None else f"scale {s:g}", s, r.measures)
                              for r in refs for s in scales])
    levels = intensity.values
    cases, place, names = [], [], []
    for r in refs:
        m = r.measures
        if not (m.get(intensity.measure) and m.get("pga")):
            continue
        names.append(r.name)
        scale = np.abs(intensity.si(levels) / m[intensity.measure])
        beyond = np.flatnonzero(_high(scale, m) | _far(scale, m)).tolist()
        cases += [(r.name, f"{levels[i]:g} {intensity.unit}", float(scale[i]), m) for i in beyond]
        place += beyond
    return _notes(cases, place, names)


def fill_missing_measures(session) -> int:
    """Compute the measures of records stored without them (records migrated from older
    databases); returns how many were filled."""
    todo = list(session.scalars(select(Record).where(Record.pga.is_(None))))
    for rec in todo:
        t, ah, _ = samples(rec)
        for k, v in measures(t, ah).as_dict().items():
            setattr(rec, k, v)
    return len(todo)


def import_fema(factory, sets: Iterable[str], progress: bool = False) -> dict[str, int]:
    """Store the components of FEMA P695 sets (farfield, nearfield_pulse, nearfield_no_pulse);
    components already stored (by name) are skipped. One transaction per set."""
    from tqdm import tqdm

    from runners.engine.fema import components

    from sqlalchemy.exc import IntegrityError

    counts = {"added": 0, "already": 0}
    for s in sets:
        comps = list(components(s))
        for attempt in range(3):  # another process importing the same set stores it first: count it as there
            added = already = 0
            try:
                with factory.begin() as session:
                    have = set(session.scalars(select(Record.name).where(Record.name.in_([c.name for c in comps]))))
                    for c in tqdm(comps, desc=f"FEMA P695 {s}", unit="component", disable=not progress):
                        if c.name in have:
                            already += 1
                            continue
                        store_record(session, c.name, c.time, c.ah, None, **c.provenance)
                        added += 1
                break
            except IntegrityError:
                if attempt == 2:
                    raise
        counts["added"] += added
        counts["already"] += already
    return counts


def read_any(path: str | Path, units: str | None = None, sign: str | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict[str, Any]]:
    """(time, ah, av or None, provenance) of a record file: PEER NGA .AT2, a measured CSV
    (runners.engine.measured, kind ground-acceleration) or our text format (anything else)."""
    from runners.engine.measured import read_at2, read_csv

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"record file {path} does not exist" if not path.exists() else
                                f"record file {path} is not a file")
    given = {"units": units, "sign": sign}
    suffix = path.suffix.lower()
    if suffix in (".at2", ".csv"):
        if suffix == ".at2":
            if units:
                raise ValueError(f"{path}: an .AT2 file states its own units")
            _check_at2_size(path)
            m = read_at2(path, {"sign": sign})
        else:
            check_size(path, str(path), header_lines=1)  # the column names row
            m = read_csv(path, given, defaults={"kind": "ground-acceleration"})
            if m.kind != "ground-acceleration":
                raise ValueError(f"{path}: a record is a ground-acceleration series, not {m.kind}")
            _refuse_nan_cells(path, m.columns["acceleration"])
        t, a = m.series("acceleration")
        check_sampling(path, t)
        return t, a, None, {"source": m.meta.get("source"), "file_name": path.name}
    if sign:
        raise ValueError(f"{path}: a record file has our signs (docs/conventions.md); --sign applies to .AT2 and "
                         ".csv files")
    scale, unit = _plain_units(path, units) if units else (1.0, "m/s2")
    t, ah, av = read_record_file(path, scale, unit)
    return t, ah, av, {"file_name": path.name}


def _plain_units(path: Path, units: str) -> tuple[float, str]:
    """(m/s^2 per unit, unit) of the accelerations of a record file read with --units (e.g.
    'acceleration=g'; its time is in s)."""
    from runners.engine.measured import UNITS, parse_units

    given = parse_units(units, str(path))
    extra = sorted(set(given) - {"time", "acceleration"})
    if extra or given.get("time", "s") != "s":
        raise ValueError(f"{path}: a record file's time is in s; --units can give its acceleration's unit "
                         "(e.g. acceleration=g)")
    unit = given.get("acceleration", "m/s2")
    return UNITS["acceleration"][unit], unit


def _check_at2_size(path: Path) -> None:
    """ValueError when an .AT2 file's header (line 4, NPTS) promises more than MAX_SAMPLES
    samples, before its values are read."""
    from runners.engine.measured import _NPTS_DT, _OLD_NPTS_DT

    with path.open("rb") as f:
        head = [f.readline(4096).decode("latin-1") for _ in range(4)]
    m = _NPTS_DT.search(head[3]) or _OLD_NPTS_DT.search(head[3])
    if m is not None and int(m.group(1)) > MAX_SAMPLES:
        raise ValueError(f"{path}, line 4: NPTS={m.group(1)}, more than the {MAX_SAMPLES} samples a record may have")


def _refuse_nan_cells(path: Path, a: np.ndarray) -> None:
    """ValueError naming the line of the first 'nan' acceleration of a CSV record (the measured
    reader keeps NaN as 'not measured', as for an empty cell; a record's .txt and .AT2 files
    refuse NaN)."""
    if not np.isnan(a).any():
        return
    import csv

    with path.open(newline="", encoding="latin-1") as f:
        reader = csv.reader(f)
        for row in reader:
            if row and not row[0].lstrip().startswith("#") and any(_is_nan(c) for c in row):
                raise ValueError(f"{path}, line {reader.line_num}: the acceleration is not a finite number "
                                 "(leave the cell empty where nothing was measured)")


def _is_nan(cell: str) -> bool:
    try:
        return math.isnan(float(cell))
    except ValueError:
        return False


def check_sampling(where: str | Path, t: np.ndarray) -> None:
    """ValueError unless a record's times (s) increase by intervals the FMU accepts (the
    limits of runners.engine.record_files, which our own format is read with) and it has at most
    MAX_SAMPLES samples."""
    if len(t) > MAX_SAMPLES:
        raise ValueError(f"{where} has {len(t)} samples, more than the {MAX_SAMPLES} a record may have")
    dt = np.diff(t)
    for bad, limit, word in ((dt < MIN_INTERVAL, MIN_INTERVAL, "below"), (dt > MAX_INTERVAL, MAX_INTERVAL, "above")):
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"{where}: the sample interval at t = {t[i]:g} s is {dt[i]:g} s, {word} {limit:g} s: "
                             "absurd sampling (is time in seconds?)")


def ensure_record(session, name: str, time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None,
                  **provenance: Any) -> Record:
    """The stored record with these samples (by their sha256), or a new one under `name` (made
    unique with -2, -3, ... if another record holds it)."""
    old = session.scalar(select(Record).where(Record.sha256 == samples_sha256(time, ah, av)))
    if old is not None:
        return old
    return store_record(session, free_name(session, name), time, ah, av, **provenance)


def _store_read(session, path: Path, read: tuple, name: str | None, suite: str | None,
                source: str | None, notes: list[str] | None = None) -> tuple[Record, bool]:
    """Store one record read by read_any, unless the same samples are stored under its name or,
    without a suite, under any name. With a suite, samples stored only outside it (a record
    imported on its own, then with its folder) become a record of the suite, under the suite's
    name for them, so that the suite holds every file it was given (a note says so)."""
    t, ah, av, prov = read
    name = name or (f"{suite}/{path.stem}" if suite else path.stem)
    if source:
        prov["source"] = source
    sha = samples_sha256(t, ah, av)
    old = session.scalar(select(Record).where(Record.name == name))
    if old is not None:
        if old.sha256 != sha:
            raise ValueError(f"a record named {name!r} already exists with other samples: give another --name")
        return old, False
    same = list(session.scalars(select(Record).where(Record.sha256 == sha).order_by(Record.id)))
    mine = [r for r in same if suite is None or r.suite == suite]
    if mine:  # the same samples under another name: one record, not two
        return mine[0], False
    rec = store_record(session, name, t, ah, av, suite=suite, **prov)
    session.flush()
    if same and notes is not None:
        notes.append(f"{name}: the same samples as record {same[0].id} {same[0].name}, stored again as a record of "
                     f"suite {suite}")
    return rec, True


def import_file(factory, path: str | Path, name: str | None = None, suite: str | None = None,
                source: str | None = None, units: str | None = None, sign: str | None = None,
                notes: list[str] | None = None) -> tuple[Record, bool]:
    """Store a record file; returns (record, True if new). Importing the same samples under the
    same name again is a no-op; another record under a taken name is an error. `notes` (a list)
    receives what a reader should know (_store_read)."""
    path = Path(path)
    read = read_any(path, units, sign)  # checked before the database is touched
    with factory.begin() as session:
        rec, new = _store_read(session, path, read, name, suite, source, notes)
        session.expunge(rec)
        return rec, new


def import_folder(factory, folder: str | Path, suite: str | None = None,
                  notes: list[str] | None = None) -> list[tuple[Record, bool]]:
    """Every file of a folder (sorted by name, hidden files skipped) as a suite (default: the
    folder's name), named SUITE/STEM: all files are read and checked first, then stored in one
    transaction, so a bad file stores nothing. Returns (record, True if new) once per record of
    the suite: a file with the samples of an earlier file of the folder is stored once, under
    the earlier one's name, with a note in `notes` (a list)."""
    folder = Path(folder)
    files = sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))
    if not files:
        raise ValueError(f"{folder}: no record files in the folder")
    suite = suite or folder.resolve().name
    reads = [(p, read_any(p)) for p in files]
    notes = [] if notes is None else notes
    with factory.begin() as session:
        done: list[tuple[Record, bool]] = []
        first: dict[int, str] = {}  # record id -> the file that gave it
        for p, read in reads:
            rec, new = _store_read(session, p, read, None, suite, None, notes)
            if rec.id in first:
                notes.append(f"{p.name} has the same samples as {first[rec.id]}: one record, {rec.name}")
                continue
            first[rec.id] = p.name
            done.append((rec, new))
        for rec, _ in done:
            session.expunge(rec)
        return done


def select_records(factory, spec: str) -> list[Record]:
    """Records from a suite name ("fema-p695/nearfield_pulse", or a prefix such as "fema-p695"), a
    comma-separated list of names or ids, or a folder of record files (imported first: the
    records of its suite, import_folder)."""
    spec = spec.strip()
    if not spec:
        raise ValueError("--records: name a suite, a list of record names or ids, or a folder")
    if Path(spec).is_dir():
        return [r for r, _ in import_folder(factory, spec)]
    with factory() as session:
        found = suite_records(session, spec)
        if not found:
            found = [find_record(session, key.strip()) for key in spec.split(",") if key.strip()]
        if len({r.id for r in found}) != len(found):
            raise ValueError(f"--records {spec!r} names a record twice")
        for r in found:
            session.expunge(r)
    if not found:
        raise ValueError(f"--records {spec!r}: no records")
    return found


def file_of(factory_or_record, key: str | int | None = None) -> Path:
    """The record (a Record, or a name or id looked up in the factory's database) as a file
    the FMU reads, in the record cache (runners.engine.record_files.cache_folder)."""
    if isinstance(factory_or_record, Record):
        rec = factory_or_record
    else:
        with factory_or_record() as session:
            rec = find_record(session, key)
            session.expunge(rec)
    # its file already in the cache and holding the samples it is named by (Record.sha256 is their hash): no
    # decompression, nor hashing (a sweep on a support asks for every record's file at its start)
    known = cache_folder().resolve() / f"{rec.sha256}.txt" if rec.sha256 else None
    if known is not None and known.is_file() and cached_file_ok(known, rec.sha256):
        return known
    t, ah, av = samples(rec)
    return cached_record_file(t, ah, av, comments=[f"record {rec.name}", *([rec.source] if rec.source else [])])


def table(factory, suite: str | None = None) -> list[dict[str, Any]]:
    """One dict per record (id, name, suite, event, year, magnitude, station, distance_km,
    component, dt, n_samples, duration, vertical, and the measures in SI units)."""
    with factory.begin() as session:
        fill_missing_measures(session)
        recs = suite_records(session, suite) if suite else list(session.scalars(select(Record).order_by(Record.id)))
        if suite and not recs:
            raise ValueError(f"no records in suite {suite!r} (runners records list shows the suites)")
        return [row(r) for r in recs]


def row(r: Record) -> dict[str, Any]:
    out = {k: getattr(r, k) for k in ("id", "name", "suite", "event", "year", "magnitude", "station",
                                      "distance_km", "component", "dt", "n_samples", "duration")}
    out["vertical"] = "av" in r.names
    out.update({k: getattr(r, k) for k in MEASURES})
    out["pga_g"] = r.pga / G0 if r.pga is not None else None
    out["pgv_pga"] = r.pgv / r.pga if r.pga else None
    return out


@dataclass
class SceneRecord:
    """The record a scene runs on."""

    record_id: int | None  # None when not stored (runners simulate --no-store of a scene's file)
    name: str
    path: Path  # the file the FMU reads (excitation.file)
    end: float  # s, time of the last sample
    info: dict[str, Any]  # provenance and measures (row())
    notes: list[str] = field(default_factory=list)  # what a reader of the run should know

    def describe(self, scale: float) -> str:
        i = self.info
        where = f" ({i['event']} {i['year'] or ''}, {i['station']})" if i.get("event") else ""
        pga = f" (PGA {abs(scale) * i['pga_g']:.3g} g)" if i.get("pga_g") else ""
        return f"record {self.name}{where} x {scale:g}{pga}"

    def summary(self, scale: float) -> dict[str, Any]:
        """The run's summary keys of the record scaled by `scale`: ``excitation`` (in words) and
        ``record`` (id, name, end_s: its last sample's time in s, scale, pga_g: the scaled PGA in g)."""
        return {"excitation": self.describe(scale),
                "record": {"id": self.record_id, "name": self.name, "end_s": self.end, "scale": scale,
                           "pga_g": abs(scale) * self.info["pga_g"]}}

    def scaling_notes(self, scale: float) -> list[str]:
        """scaling_notes of this record scaled by `scale`."""
        return scaling_notes([(self.name, "", scale, self.info)])


def prepare_run(scene: Scene, record: str | int | Path | None = None, scale: float | None = None,
                pga: float | None = None, *, stop_time: float | None = None, step: float | None = None,
                factory=None, db: str | None = None) -> tuple[Scene, SceneRecord | None]:
    """The scene of one run and its record (None without one): ``runners.simulate``'s preparation
    of a record, in one place.

    record: a stored record's name or id, or a record file (a Path, or a str naming an existing
        file), which replaces the scene's excitation and the times the scene set for it (a note
        says what it replaced); None keeps the scene's own record, if any.
    scale: the record's multiplier; pga: scale it to this PGA instead (in g). ValueError for either
        without a record, or both.
    stop_time, step: s, the run's own times, which replace the scene's; without them a record runs
        to its end plus TAIL seconds at its own sampling (prepare_scene).
    factory, db: the database of a stored record (a sessionmaker, else the SQLAlchemy URL db, else
        the default SQLite file); a record file is stored there only when factory is given.
    """
    replaced = []
    if record is not None:
        kind = int(scene.parameters.get("excitation.kind", 0))
        if kind not in (0, KINDS["record"]):
            replaced.append(f"the record replaces the scene's {KIND_NAMES[kind]}")
        from_file = isinstance(record, Path) or (isinstance(record, str) and Path(record).is_file())
        scene = replace(scene, record=None if from_file else str(record),
                        file=str(Path(record).resolve()) if from_file else None, stop_time_given=False,
                        step_given=False, parameters={**{k: v for k, v in scene.parameters.items()
                                                         if not k.startswith("excitation.")
                                                         or k == "excitation.startTime"},
                                                      "excitation.kind": KINDS["record"]})
    scene = with_times(scene, stop_time, step)
    if scale is not None or pga is not None:
        if not scene.is_record:
            raise ValueError("scale and pga scale a record: give the record (record=NAME, an id or a file) or a "
                             "scene whose [excitation] names one (record = NAME or file = PATH)")
        if scale is not None and pga is not None:
            raise ValueError("give scale or pga, not both")
        if pga is not None:
            check_pga(pga, "pga")
        scene.parameters.pop("excitation.scale", None)
        scene.pga = pga
        if scale is not None:
            scene.parameters["excitation.scale"] = float(scale)
    if not scene.is_record:
        return scene, None
    if factory is None and scene.record is not None:  # a stored record: its database
        from db.session import open_database

        factory = open_database(db)
    rec = prepare_scene(scene, factory)
    rec.notes[:0] = replaced
    return scene, rec


def prepare_scene(scene: Scene, factory=None) -> SceneRecord | None:
    """For a record scene: find its stored record (or read its file, storing it when a
    database is given), point excitation.file at a file the FMU reads and, without a
    [simulation] stop_time, run until the record ends plus TAIL seconds. None otherwise."""
    if not scene.is_record:
        return None

    def scale_of(pga: float) -> float:  # the scene's scale, or the one that gives its PGA (in g)
        if scene.pga is not None:
            if not pga > 0:
                raise ValueError("the record's accelerations are all zero: no scale gives it a PGA of "
                                 f"{scene.pga:g} g")
            scene.parameters["excitation.scale"] = scene.pga * G0 / pga
        return float(scene.parameters.get("excitation.scale", 1.0))

    if scene.record is not None:
        if factory is None:
            from db.session import open_database

            factory = open_database()
        with factory.begin() as session:
            fill_missing_measures(session)
            rec = find_record(session, scene.record)
            session.expunge(rec)
    else:
        t, ah, av, prov = read_any(scene.file)
        check_scaled(f"record file {scene.file}", ah, av, scale_of(float(np.max(np.abs(ah)))))
        if factory is None:
            m = measures(t, ah)
            rec = Record(id=None, name=Path(scene.file).stem, names=["ah"] + (["av"] if av is not None else []),
                         n_samples=len(t), dt=float(np.min(np.diff(t))), duration=float(t[-1] - t[0]),
                         **m.as_dict(), **prov)
            path = cached_record_file(t, ah, av, comments=[f"record file {scene.file}"])
            return _finish(scene, rec, path, float(t[-1]), unit_notes(rec))
        with factory.begin() as session:
            rec = ensure_record(session, Path(scene.file).stem, t, ah, av,
                                **{"source": f"record file {scene.file}", **prov})
            session.flush()
            session.expunge(rec)
    t, ah, av = samples(rec)
    check_scaled(f"record {rec.name}", ah, av, scale_of(float(np.max(np.abs(ah)))))
    return _finish(scene, rec, file_of(rec), float(t[-1]), unit_notes(rec) if scene.record is None else [])


def _finish(scene: Scene, rec: Record, path: Path, end: float, notes: list[str] | None = None) -> SceneRecord:
    scene.parameters["excitation.file"] = str(path)
    start = float(scene.parameters.get("excitation.startTime", 0.0))
    notes = list(notes or [])
    if not scene.stop_time_given:
        scene.stop_time = start + end + TAIL
    elif scene.stop_time < start + end:
        notes.append(f"the run stops at {scene.stop_time:g} s, before the record ends at {start + end:g} s "
                     "(without a stop time it runs to the record's end plus 5 s)")
    if not scene.step_given:  # outputs at the record's own sampling, between 1 kHz and 100 Hz
        scene.step = min(min(max(float(rec.dt), 1e-3), 0.01), scene.stop_time)
    return SceneRecord(rec.id, rec.name, path, end, row(rec) | {"source": rec.source}, notes)
