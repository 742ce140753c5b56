"""Writing runs: the scene, its excitation, the run, its summary and its series in one
transaction (all or nothing). A simulated run that cannot be stored (disk full, database
locked, ...) is kept in a file instead (keep_unsaved), which runners db import-unsaved stores
later (store_pending): the same rows, bit for bit, as storing it at once would have written.
Co-simulated runs (runners cosim) go the same way: a cosim_runs row and its series in one
transaction (store_cosims, kept in files by keep_unsaved when the database fails), stored later
by store_cosim_pending."""

from __future__ import annotations

import base64
import hashlib
import json
import math
import os
import subprocess
import tempfile
from datetime import datetime, timezone
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session, sessionmaker

from db import leftovers, series
from db.schema import (Block, CosimRun, CosimSeries, Excitation, Measurement, Record, Run, RunBlock, RunSeries,
                       RunSummary, Scene)
from db.session import DatabaseError, database_failure, database_name, display_url, sqlite_file

UNSAVED_FORMAT = "rocking-unsaved-run"  # the "format" of the files keep_unsaved writes
UNSAVED_VERSION = 1
COSIM_UNSAVED_FORMAT = "rocking-unsaved-cosim"  # the "format" of a co-simulated run's (pending_cosim)
COSIM_UNSAVED_VERSION = 1

KINDS = {0: "none", 1: "sine-pulse", 2: "cosine-pulse", 3: "harmonic", 4: "record", 5: "ricker",
         6: "ricker-antisymmetric", 7: "mavroeidis-papageorgiou"}


@lru_cache(maxsize=None)
def code_version() -> str:
    """Package version, plus the git commit when running from a checkout."""
    try:
        v = version("rocking")
    except PackageNotFoundError:
        v = "unknown"
    try:
        root = Path(__file__).resolve().parent.parent
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"], capture_output=True,
                                text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return f"{v}+{commit}" if commit else v


@lru_cache(maxsize=None)
def file_sha256(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def excitation_of(p: dict[str, Any], record: Record | None = None) -> Excitation:
    """The excitation the FMU parameters p describe (a record's samples are `record`)."""
    kind = int(p["excitation.kind"])
    if kind == 4:
        return Excitation(kind="record", record=record, scale=p.get("excitation.scale", 1.0),
                          start_time=p["excitation.startTime"])
    mp = kind == 7
    return Excitation(kind=KINDS[kind], amplitude=p["excitation.amplitude"],
                      frequency=p["excitation.frequency"], cycles=p["excitation.cycles"],
                      start_time=p["excitation.startTime"], vertical_amplitude=p["excitation.verticalAmplitude"],
                      displacement=p["excitation.displacement"], gamma=p.get("excitation.gamma") if mp else None,
                      phase=p.get("excitation.phase") if mp else None)


def add_scene(session: Session, name: str, parameters: dict[str, Any], source: str | None = None) -> Scene:
    scene = Scene(name=name, n_blocks=int(parameters.get("nBlocks", 1)), parameters=dict(parameters),
                  source=source)
    session.add(scene)
    return scene


def add_run(session: Session, scene: Scene, merged: dict[str, Any], summary: dict[str, Any] | None, *,
            model: str, method: str, stop_time: float, fmu_path: str | None, wall_time: float | None,
            time: np.ndarray | None = None, outputs: dict[str, np.ndarray] | None = None,
            events: list[dict[str, Any]] | None = None, error: str | None = None,
            sweep_id: int | None = None, grid_index: int | None = None, excitation: Excitation | None = None,
            blocks: list[dict[str, Any]] | None = None) -> Run:
    """One run with its summary (if it succeeded), its blocks' outcomes (a column's: run_blocks rows
    without run_id) and series (if sampled); its excitation is `excitation` (a recorded one, say) or
    the built-in one its parameters describe."""
    run = Run(scene=scene, excitation=excitation if excitation is not None else excitation_of(merged), sweep_id=sweep_id, grid_index=grid_index,
              model=model, method=method, rel_tol=merged.get("solver.relTol"), abs_tol=merged.get("solver.absTol"),
              stop_time=stop_time, fmu_sha256=file_sha256(str(fmu_path)) if fmu_path else None,
              code_version=code_version(), wall_time=wall_time, status="error" if error else "ok",
              error_message=error)
    session.add(run)
    if summary is not None:
        run.summary = RunSummary(**summary)
    if blocks:
        run.blocks = [RunBlock(**b) for b in blocks]
    if time is not None and outputs:
        names, n, blob = series.pack(time, outputs)
        run.series = RunSeries(names=names, n_samples=n, data=blob, events=events)
    return run


def add_measurement(session: Session, *, name: str, kind: str, time: np.ndarray, columns: dict[str, np.ndarray],
                    units: dict[str, str], sign: str, block1: Block | None = None, block2: Block | None = None,
                    source: str | None = None, instrument: str | None = None, sampling_rate: float | None = None,
                    uncertainty: dict[str, float] | None = None, file_name: str | None = None,
                    file_sha256: str | None = None, record: Record | None = None) -> Measurement:
    """One measurement (SI, our signs); with `record` (the ground motion a motion measurement
    amounts to, runners.engine.records.store_record) also its excitation, which runs can be driven by."""
    u = uncertainty or {}
    names, n, blob = series.pack(time, columns)
    m = Measurement(name=name, kind=kind, block1=block1, block2=block2, source=source, instrument=instrument,
                    sampling_rate=sampling_rate, uncertainty_angle=u.get("theta"), uncertainty_time=u.get("time"),
                    uncertainty_value=u.get("value"), units=dict(units), sign=sign, file_name=file_name,
                    file_sha256=file_sha256, names=names, n_samples=n, data=blob)
    if record is not None:
        m.excitation = Excitation(kind="record", record=record, scale=1.0, start_time=0.0)
    session.add(m)
    return m


def load_run_series(session: Session, run_id: int, hint: str = "") -> tuple[Run, np.ndarray, dict[str, np.ndarray],
                                                                              list[dict[str, Any]]]:
    """(run, time, columns, events) of a stored run; ValueError if it is missing or was not
    sampled (`hint` says what to do then)."""
    run = session.get(Run, run_id)
    if run is None:
        raise ValueError(f"no run {run_id} in the database")
    if run.series is None:
        raise ValueError(f"run {run_id} has no stored series" + (f" ({hint})" if hint else ""))
    t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    return run, t, cols, list(run.series.events or [])


def pending_run(*, scene_name: str, parameters: dict[str, Any], source: str | None, merged: dict[str, Any],
                summary: dict[str, Any] | None, model: str, method: str, stop_time: float, fmu_path: str | None,
                wall_time: float | None, time: np.ndarray | None = None, outputs: dict[str, np.ndarray] | None = None,
                events: list[dict[str, Any]] | None = None, recording: str | None = None,
                record: tuple[int, str] | None = None, blocks: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """A simulated run as plain JSON values, ready to store (store_pending) or to keep in a
    file (keep_unsaved): its scene, the FMU parameters it ran with, its summary row, its series
    packed as they are stored (db.series, base64), when it ran and with which code and FMU,
    and the stored record (id, name) it was driven by."""
    p: dict[str, Any] = {
        "format": UNSAVED_FORMAT, "version": UNSAVED_VERSION,
        "created_at": datetime.now(timezone.utc).isoformat(), "code_version": code_version(),
        "fmu_sha256": file_sha256(str(fmu_path)) if fmu_path else None,
        "scene": {"name": scene_name, "parameters": dict(parameters), "source": source},
        "merged": dict(merged), "summary": summary, "model": model, "method": method, "stop_time": stop_time,
        "wall_time": wall_time, "recording": recording,
        "record": None if record is None else {"id": record[0], "name": record[1]}, "series": None}
    if blocks:  # a column's blocks (run_blocks rows); absent for one block and two, as in files of before
        p["blocks"] = [dict(b) for b in blocks]
    if time is not None and outputs:
        names, n, blob = series.pack(time, outputs)
        p["series"] = {"names": names, "n_samples": n, "data": base64.b64encode(blob).decode("ascii"),
                       "events": events}
    return p


def _record_of(session: Session, ref: dict[str, Any]) -> Record:
    """The stored record a pending run was driven by: by id if the name matches, else by name."""
    rec = session.get(Record, ref["id"])
    if rec is None or rec.name != ref["name"]:
        rec = session.scalar(select(Record).where(Record.name == ref["name"]))
    if rec is None:
        raise ValueError(f"the run was driven by record {ref['name']!r}, which is not in this database "
                         "(runners records import, or the --db the run was meant for)")
    return rec


def store_pending(session: Session, p: dict[str, Any]) -> Run:
    """Add a pending run (pending_run) and everything it refers to; the caller commits."""
    created = datetime.fromisoformat(p["created_at"])
    rec = None if p["record"] is None else _record_of(session, p["record"])
    sc = add_scene(session, p["scene"]["name"], p["scene"]["parameters"], p["scene"]["source"])
    sc.created_at = created
    run = add_run(session, sc, p["merged"], p["summary"], model=p["model"], method=p["method"],
                  stop_time=p["stop_time"], fmu_path=None, wall_time=p["wall_time"],
                  excitation=excitation_of(p["merged"], rec), blocks=p.get("blocks"))
    run.fmu_sha256, run.code_version, run.created_at = p["fmu_sha256"], p["code_version"], created
    run.recording = p["recording"]
    if p["series"] is not None:
        ps = p["series"]
        run.series = RunSeries(names=ps["names"], n_samples=ps["n_samples"], data=base64.b64decode(ps["data"]),
                               events=ps["events"])
    session.flush()
    return run


def stored_already(session: Session, p: dict[str, Any]) -> int | None:
    """The id of the run a pending run was already stored as (same start, code and method), if any."""
    return session.scalar(select(Run.id).where(Run.created_at == datetime.fromisoformat(p["created_at"]),
                                               Run.code_version == p["code_version"], Run.model == p["model"],
                                               Run.method == p["method"]).limit(1))


def _json_value(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON")


def keep_unsaved(p: dict[str, Any], reason: str, database: str, folder: Path | None = None,
                 label: str = "") -> Path:
    """Write a run that could not be stored to rocking-unsaved-<time>-<pid>.json in `folder`
    (default: the working folder, else the temporary folder); OSError if neither can hold it.
    `label` (e.g. "one-way") ends the name, for runs of one command kept in the same second."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    data = json.dumps({**p, "unsaved": {"reason": reason, "database": database}}, default=_json_value)
    folders = [folder] if folder is not None else [Path.cwd(), Path(tempfile.gettempdir())]
    err: OSError | None = None
    for f in folders:
        path = (f / f"rocking-unsaved-{stamp}-{os.getpid()}{'-' + label if label else ''}.json").resolve()
        part = path.with_name(f".rocking-unsaved.{leftovers.tag()}-{stamp}.json.part")  # whole, or not at all
        leftovers.remove_stale(path.parent, ".rocking-unsaved.", ".part")  # those killed processes left
        try:
            part.write_text(data)
            os.replace(part, path)
            return path
        except OSError as exc:
            err = OSError(exc.errno, f"cannot write {path}: {exc.strerror or exc}")  # its name, not the part's
            part.unlink(missing_ok=True)
    raise err


# the largest file keep_unsaved writes: a run's series of MAX_SAMPLES + 1 samples of a few dozen
# columns, compressed and in base64, stays well below this
MAX_UNSAVED_BYTES = 1 << 30


def read_unsaved(path: str | Path) -> dict[str, Any]:
    """A file keep_unsaved wrote; ValueError (one line) for anything else."""
    if Path(path).exists() and not Path(path).is_file():  # a folder, a FIFO or a device would never end
        raise ValueError(f"{path} is not a file of an unsaved run (not a file)")
    if Path(path).exists() and Path(path).stat().st_size > MAX_UNSAVED_BYTES:  # refused before it fills memory
        raise ValueError(f"{path} is not a file of an unsaved run: {Path(path).stat().st_size / 2**30:.1f} GiB, more "
                         f"than a run can hold ({MAX_UNSAVED_BYTES / 2**30:.0f} GiB)")
    try:
        p = json.loads(Path(path).read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} is not a file of an unsaved run (not JSON: {exc})") from None
    if isinstance(p, dict) and p.get("format") == COSIM_UNSAVED_FORMAT:
        return _read_unsaved_cosim(path, p)
    if not isinstance(p, dict) or p.get("format") != UNSAVED_FORMAT:
        raise ValueError(f"{path} is not a file of an unsaved run (rocking-unsaved-*.json)")
    if p.get("version") != UNSAVED_VERSION:
        raise ValueError(f"{path} is an unsaved run of format version {p.get('version')}; this tool reads version "
                         f"{UNSAVED_VERSION}")
    missing = sorted(_UNSAVED_KEYS - set(p)) or sorted({"name", "parameters", "source"} - set(p["scene"] or {}))
    if missing:
        raise ValueError(f"{path} is not a whole unsaved run: it lacks {', '.join(missing)}")
    wrong = _unsaved_problem(p)
    if wrong:
        raise ValueError(f"{path} is not a valid unsaved run: {wrong}")
    return p


def _blocks_problem(blocks: Any) -> str | None:
    """What is wrong with an unsaved run's blocks (run_blocks rows without run_id), None if nothing."""
    if blocks is None:
        return None
    columns = {c.name: c for c in RunBlock.__table__.columns if c.name != "run_id"}
    if not isinstance(blocks, list) or not all(isinstance(b, dict) for b in blocks):
        return "blocks is not a list of tables"
    for b in blocks:
        for k, v in b.items():
            if k not in columns:
                return f"blocks has an unknown field {k!r}"
            want = columns[k].type.python_type
            if (v is None and not columns[k].nullable) or (v is not None and not (
                    isinstance(v, want) or (want is float and isinstance(v, int))) or (want is not bool and isinstance(v, bool))):
                return f"blocks: {k} = {v!r} is not a {want.__name__}"
            if want is float and v is not None and not math.isfinite(v):
                return f"blocks: {k} = {v!r} is not a finite number"
    return None


def _unsaved_problem(p: dict[str, Any]) -> str | None:
    """What is wrong with the values of an unsaved run (None if nothing): the types its rows
    need, and series whose data hold the samples they announce."""
    from db.schema import RunSummary

    scalar = (bool, int, float, str)
    for key in ("parameters",):
        d = p["scene"][key]
        if not isinstance(d, dict) or not all(isinstance(k, str) and isinstance(v, scalar) for k, v in d.items()):
            return f"scene.{key} is not a table of named values"
    if not isinstance(p["merged"], dict) or not all(isinstance(v, scalar) for v in p["merged"].values()):
        return "merged is not a table of named values"
    try:
        excitation_of(p["merged"])
    except (KeyError, ValueError, TypeError) as exc:
        return f"merged does not describe an excitation (no valid {exc})"
    if not isinstance(p["scene"]["name"], str) or not isinstance(p["model"], str) or not isinstance(p["method"], str):
        return "the scene's name, the model and the method must be texts"
    if not isinstance(p["stop_time"], (int, float)) or isinstance(p["stop_time"], bool):
        return "stop_time is not a number"
    if not (math.isfinite(p["stop_time"]) and p["stop_time"] > 0):
        return f"stop_time = {p['stop_time']!r} is not a time after the start (s)"
    for k, v in p["merged"].items():
        if isinstance(v, float) and not math.isfinite(v):
            return f"merged.{k} = {v!r} is not a finite number"
    text = [k for k, v in p["merged"].items() if k.startswith(("block1.", "block2.")) and isinstance(v, str)]
    if text:
        return f"merged.{text[0]} = {p['merged'][text[0]]!r} is not a number"
    if p["merged"].get("nBlocks", 1) not in range(1, 9) or isinstance(p["merged"].get("nBlocks"), (bool, str)):
        return f"merged.nBlocks = {p['merged'].get('nBlocks')!r} is not 1 to 8"
    wrong = _blocks_problem(p.get("blocks"))
    if wrong:
        return wrong
    try:
        datetime.fromisoformat(p["created_at"])
    except (TypeError, ValueError):
        return "created_at is not a date and time"
    if p["summary"] is not None:
        if not isinstance(p["summary"], dict):
            return "summary is not a table"
        columns = RunSummary.__table__.columns
        for k, v in p["summary"].items():
            if k not in columns:
                return f"summary has an unknown field {k!r}"
            want = columns[k].type.python_type
            if v is not None and not (isinstance(v, want) or (want is float and isinstance(v, int))) \
                    or (want is not bool and isinstance(v, bool)):
                return f"summary.{k} = {v!r} is not a {want.__name__}"
            if want is float and v is not None and not math.isfinite(v):
                return f"summary.{k} = {v!r} is not a finite number"
            if want is int and v is not None and not isinstance(v, bool) and v < 0:
                return f"summary.{k} = {v!r} is not a count (0 or more)"
    rec = p["record"]
    if rec is not None and not (isinstance(rec, dict) and isinstance(rec.get("id"), int)
                                and isinstance(rec.get("name"), str)):
        return "record is not an id and a name"
    ps = p["series"]
    if ps is not None:
        if not (isinstance(ps, dict) and isinstance(ps.get("names"), list) and isinstance(ps.get("n_samples"), int)
                and isinstance(ps.get("data"), str) and isinstance(ps.get("events"), (list, type(None)))):
            return "series is not names, n_samples, data and events"
        wrong = _series_problem(ps["names"], ps["n_samples"]) or _events_problem(ps["events"] or [])
        if wrong:
            return wrong
        late = [e["t"] for e in ps["events"] or [] if e["t"] > p["stop_time"] * (1 + 1e-12) + 1e-12]
        if late:
            return f"series.events has an event at t = {late[0]!r} s, after the run's stop_time = {p['stop_time']!r} s"
        return _packed_problem(ps)
    return None


def _packed_problem(ps: dict) -> str | None:
    """What is wrong with a kept run's packed series ps (names, n_samples, data: base64 of the compressed
    float64 columns, time first), or None."""
    try:
        blob = base64.b64decode(ps["data"], validate=True)
    except ValueError:
        return "series.data is not packed samples"
    expected = 8 * (len(ps["names"]) + 1) * ps["n_samples"]
    size = _inflated_size(blob, expected)
    if size is None:
        return "series.data is not packed samples"
    if size != expected:
        return (f"series.data does not hold the {ps['n_samples']} samples of {len(ps['names']) + 1} columns it "
                "announces" + (" (it inflates to more)" if size > expected else ""))
    if not _finite(blob):
        return "series.data holds a sample that is not a finite number (NaN or infinite)"
    return None


def _finite(blob: bytes) -> bool:
    """Whether every sample packed in `blob` (zlib-compressed little-endian float64, its size
    checked) is a finite number: a run's outputs always are, and a NaN once stored made every
    read of the run fail (cannot convert float NaN to integer)."""
    import zlib

    return bool(np.isfinite(np.frombuffer(zlib.decompress(blob), "<f8")).all())


def _series_problem(names: list, n_samples: int) -> str | None:
    """What is wrong with a series' shape (None if nothing): distinct column names, and at least
    one and at most as many samples as a run may hold (runners.engine.scene.MAX_SAMPLES)."""
    from runners.engine.scene import MAX_SAMPLES

    if not all(isinstance(n, str) and n for n in names) or len(set(names)) != len(names):
        return "series.names are not distinct column names"
    if isinstance(n_samples, bool) or not 1 <= n_samples <= MAX_SAMPLES + 1:
        return f"series.n_samples = {n_samples!r} is not a number of samples (1 to {MAX_SAMPLES + 1})"
    return None


def _events_problem(events: list) -> str | None:
    """What is wrong with a series' events (None if nothing): each one a kind (a text), a time t
    (s, a finite number), numeric values and text labels, as runners.engine.fmu.Event.as_dict
    writes them; anything else fails later, in every command that reads the run."""
    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    for i, e in enumerate(events):
        if not isinstance(e, dict) or set(e) - {"kind", "t", "values", "labels"}:
            return f"series.events[{i}] is not an event (kind, t, values, labels)"
        if not isinstance(e.get("kind"), str) or not e["kind"]:
            return f"series.events[{i}] has no kind (a text, e.g. impact)"
        if not number(e.get("t")) or not np.isfinite(e["t"]):
            return f"series.events[{i}] has no time t (a finite number of seconds)"
        values, labels = e.get("values", {}), e.get("labels", {})
        if not isinstance(values, dict) or not all(isinstance(k, str) and number(v) for k, v in values.items()):
            return f"series.events[{i}].values is not a table of named numbers"
        if not isinstance(labels, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                                   for k, v in labels.items()):
            return f"series.events[{i}].labels is not a table of named texts"
    return None


def _inflated_size(blob: bytes, expected: int, chunk: int = 1 << 20) -> int | None:
    """Bytes the zlib stream `blob` inflates to, counted a chunk at a time and no further than
    one chunk beyond `expected` (bytes): a stream packed to inflate to far more (a few MB that
    inflate to GB) is measured in bounded memory. None if it is not a whole zlib stream."""
    import zlib

    d = zlib.decompressobj()
    size, rest = 0, blob
    try:
        while True:
            out = d.decompress(rest, chunk)
            size += len(out)
            rest = d.unconsumed_tail
            if size > expected:
                return size
            if not out and not rest:
                break
        size += len(d.flush())
    except zlib.error:
        return None
    return size if d.eof else None


_UNSAVED_KEYS = {"created_at", "code_version", "fmu_sha256", "scene", "merged", "summary", "model", "method",
                 "stop_time", "wall_time", "recording", "record", "series"}


def store_or_keep(factory: sessionmaker, p: dict[str, Any]) -> int:
    """Store a pending run in one transaction and return its id. If the database fails (disk
    full, locked for longer than the busy timeout, read-only, ...), nothing is written to it:
    the run goes to a file (keep_unsaved) and a one-line DatabaseError says where, and how to
    store it later."""
    engine = factory.kw["bind"]
    try:
        with factory.begin() as session:
            return store_pending(session, p).id
    except SQLAlchemyError as exc:
        reason = database_failure(exc, database_name(engine))
    except Exception as exc:  # whatever went wrong, the computed run is not lost
        reason = f"storing the run in {database_name(engine)} failed ({type(exc).__name__}: {exc})".splitlines()[0]
    path_db = sqlite_file(engine)
    target = os.path.abspath(path_db) if path_db is not None else display_url(engine)  # as --db takes it
    try:
        path = keep_unsaved(p, reason, target)
    except OSError as err:
        raise DatabaseError(f"{reason}: the run was not stored, and keeping it in a file failed too ({err})") from None
    hint = f"runners db import-unsaved {path}" + (f" --db {target}" if path_db is not None else " --db URL")
    raise DatabaseError(f"{reason}: the run was not stored (the database is unchanged); its results are in {path}: "
                        f"store them later with {hint}")


# ---------------------------------------------------------------------------------------------
# co-simulated runs (runners cosim; the pending dict is runners.engine.cosim_store.pending_cosim's)

_COSIM_KEYS = {"created_at", "code_version", "name", "source", "source_sha256", "source_file", "engine", "coupling",
               "step", "stop_time", "storeys", "floor", "system", "block_parameters", "building_parameters", "record",
               "base_scale", "base_sha256", "summary", "block_fmu_sha256", "building_fmu_sha256", "wall_time",
               "series"}


def store_cosim_pending(session: Session, p: dict[str, Any]) -> CosimRun:
    """Add a pending co-simulated run (runners.engine.cosim_store.pending_cosim) and its series;
    its base record, when it names a stored one, by id if the name matches, else by name
    (ValueError if this database does not hold it). The caller commits."""
    rec = None if p["record"] is None or p["record"].get("id") is None else _record_of(session, p["record"])
    ps = p["series"]
    run = CosimRun(name=p["name"], source=p["source"], source_sha256=p["source_sha256"], source_file=p["source_file"],
                   engine=p["engine"], coupling=p["coupling"], step=p["step"], stop_time=p["stop_time"],
                   storeys=p["storeys"], floor=p["floor"], system=p["system"], block_parameters=p["block_parameters"],
                   building_parameters=p["building_parameters"], record=rec, base_scale=p["base_scale"],
                   base_sha256=p["base_sha256"], summary=p["summary"], block_fmu_sha256=p["block_fmu_sha256"],
                   building_fmu_sha256=p["building_fmu_sha256"], code_version=p["code_version"],
                   wall_time=p["wall_time"], created_at=datetime.fromisoformat(p["created_at"]))
    run.series = CosimSeries(names=ps["names"], n_samples=ps["n_samples"], data=base64.b64decode(ps["data"]))
    session.add(run)
    session.flush()
    return run


def cosim_stored_already(session: Session, p: dict[str, Any]) -> int | None:
    """The id of the co-simulated run a pending one was already stored as (same start, code,
    system, engine and coupling), if any."""
    return session.scalar(select(CosimRun.id).where(
        CosimRun.created_at == datetime.fromisoformat(p["created_at"]), CosimRun.code_version == p["code_version"],
        CosimRun.name == p["name"], CosimRun.engine == p["engine"], CosimRun.coupling == p["coupling"]).limit(1))


def store_cosims(factory: sessionmaker, pending: list[dict[str, Any]]) -> list[int]:
    """Store pending co-simulated runs in one transaction (all or none) and return their ids. If
    the database fails, nothing is written to it: each run goes to a file (keep_unsaved, named
    after its coupling when there are several) and a one-line DatabaseError says where, and how
    to store them later (runners db import-unsaved)."""
    engine = factory.kw["bind"]
    try:
        with factory.begin() as session:
            return [store_cosim_pending(session, p).id for p in pending]
    except SQLAlchemyError as exc:
        reason = database_failure(exc, database_name(engine))
    except Exception as exc:  # whatever went wrong, the computed runs are not lost
        reason = f"storing the runs in {database_name(engine)} failed ({type(exc).__name__}: {exc})".splitlines()[0]
    path_db = sqlite_file(engine)
    target = os.path.abspath(path_db) if path_db is not None else display_url(engine)  # as --db takes it
    kept: list[Path] = []
    try:
        for p in pending:
            kept.append(keep_unsaved(p, reason, target, label=p["coupling"] if len(pending) > 1 else ""))
    except OSError as err:
        also = f" (kept so far: {', '.join(map(str, kept))})" if kept else ""
        raise DatabaseError(f"{reason}: the co-simulated run{'s were' if len(pending) > 1 else ' was'} not stored, "
                            f"and keeping {'them' if len(pending) > 1 else 'it'} in a file failed too ({err}){also}"
                            ) from None
    files = " and ".join(str(k) for k in kept)
    hint = "runners db import-unsaved FILE" + (f" --db {target}" if path_db is not None else " --db URL")
    raise DatabaseError(f"{reason}: the co-simulated run{'s were' if len(kept) > 1 else ' was'} not stored (the database "
                        f"is unchanged); {'their' if len(kept) > 1 else 'its'} results are in {files}: store them "
                        f"later with {hint}")


def _read_unsaved_cosim(path: str | Path, p: dict[str, Any]) -> dict[str, Any]:
    """A co-simulated run keep_unsaved wrote (read_unsaved): checked whole before anything is stored."""
    if p.get("version") != COSIM_UNSAVED_VERSION:
        raise ValueError(f"{path} is an unsaved co-simulated run of format version {p.get('version')}; this tool "
                         f"reads version {COSIM_UNSAVED_VERSION}")
    missing = sorted(_COSIM_KEYS - set(p))
    if missing:
        raise ValueError(f"{path} is not a whole unsaved co-simulated run: it lacks {', '.join(missing)}")
    wrong = _cosim_problem(p)
    if wrong:
        raise ValueError(f"{path} is not a valid unsaved co-simulated run: {wrong}")
    return p


def _cosim_problem(p: dict[str, Any]) -> str | None:
    """What is wrong with the values of an unsaved co-simulated run (None if nothing)."""
    def number(v: Any, positive: bool = False) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and (not positive or v > 0)

    def count(v: Any) -> bool:
        return isinstance(v, int) and not isinstance(v, bool) and v >= 1

    texts = ("name", "engine", "coupling", "code_version")
    bad = next((k for k in texts if not isinstance(p[k], str) or not p[k]), None)
    if bad:
        return f"{bad} is not a text"
    bad = next((k for k in ("source", "source_sha256", "source_file", "base_sha256", "block_fmu_sha256",
                            "building_fmu_sha256") if not isinstance(p[k], (str, type(None)))), None)
    if bad:
        return f"{bad} is not a text"
    if p["engine"] not in ("fmpy", "libcosim") or p["coupling"] not in ("one-way", "two-way"):
        return f"engine {p['engine']!r} or coupling {p['coupling']!r} is not one a co-simulation runs with"
    bad = next((k for k in ("step", "stop_time") if not number(p[k], positive=True)), None)
    if bad:
        return f"{bad} = {p[bad]!r} is not a time after the start (s)"
    if not number(p["base_scale"]):
        return f"base_scale = {p['base_scale']!r} is not a finite number"
    if p["wall_time"] is not None and not number(p["wall_time"]):
        return f"wall_time = {p['wall_time']!r} is not a number of seconds"
    if not count(p["storeys"]) or not count(p["floor"]) or p["floor"] > p["storeys"]:
        return f"floor {p['floor']!r} is not a floor of a building of {p['storeys']!r} storeys"
    bad = next((k for k in ("system", "block_parameters", "building_parameters") if not isinstance(p[k], dict)), None)
    if bad:
        return f"{bad} is not a table"
    if p["summary"] is not None and not isinstance(p["summary"], dict):
        return "summary is not a table"
    rec = p["record"]
    if rec is not None and not (isinstance(rec, dict) and isinstance(rec.get("id"), (int, type(None)))
                                and isinstance(rec.get("name"), str)):
        return "record is not an id and a name"
    try:
        datetime.fromisoformat(p["created_at"])
    except (TypeError, ValueError):
        return "created_at is not a date and time"
    ps = p["series"]
    if not (isinstance(ps, dict) and isinstance(ps.get("names"), list) and count(ps.get("n_samples"))
            and isinstance(ps.get("data"), str)):
        return "series is not names, n_samples and data"
    if not all(isinstance(n, str) and n for n in ps["names"]) or len(set(ps["names"])) != len(ps["names"]):
        return "series.names are not distinct column names"
    return _packed_problem(ps)
