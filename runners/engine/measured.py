"""Measured series read from files, converted to SI units and our sign convention.

Two formats:

- **CSV** with a header of ``# key: value`` lines, then a row of column names,
  then data rows. Keys (each can also be given on the command line, which wins):

  ``kind``
      ``peaks`` (free-rocking peak table: time, peak angle, as read from video),
      ``rotation`` (rotation history: time, theta per block),
      ``table-displacement`` / ``table-acceleration`` (shaking-table record),
      ``ground-acceleration`` (recorded ground motion).
  ``units``
      e.g. ``time=s, theta=deg``: time in s or ms; theta in rad or deg;
      displacement in m, cm or mm; acceleration in m/s2, cm/s2, gal or g.
  ``sign``
      angles: ``clockwise`` (ours: theta > 0 clockwise, rocking on the right
      corner) or ``counterclockwise``; motions: ``+x`` (ours: positive moves
      the ground to the right) or ``-x``.
  ``block``, ``block2``, ``name``, ``source``, ``instrument``,
  ``sampling_rate`` (Hz), ``uncertainty`` (e.g. ``theta=0.5 deg, time=0.1 s``).

  Columns: ``time`` first, then ``theta`` (same as ``block1.theta``) and/or
  ``block2.theta`` for peaks and rotations (``block1.omega``/``block2.omega``
  in rad/s or deg/s may follow, for overlays), ``displacement`` or
  ``acceleration`` for motions. An empty cell means "not measured at this
  time" for that column. Time must increase strictly.

- **PEER NGA .AT2** (recorded ground acceleration): four header lines, the
  third naming the units (G), the fourth NPTS and DT, then the values. The
  record's positive direction becomes +x unless ``--sign -x`` is given.

Both are read as UTF-8 text (a byte-order mark is skipped); a byte that is not
UTF-8 is read as Windows-1252 (Latin-1), so a header or station name saved in
Latin-1 keeps its accents. A control character (a binary file) or UTF-16 text is
refused. A CSV is streamed: its values go straight into float64 arrays, so a file
of millions of rows takes about 8 bytes per value, not a Python object per cell.

Every problem raises ValueError (or FileNotFoundError, IsADirectoryError) with one
line naming the file, the line and what is wrong; nothing is returned half-read.
"""

from __future__ import annotations

import array
import codecs
import csv
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

G0 = 9.80665  # m/s^2, standard gravity (the "g" of accelerograms)

KINDS: dict[str, str] = {  # kind -> the quantity of its value columns
    "peaks": "theta",
    "rotation": "theta",
    "table-displacement": "displacement",
    "table-acceleration": "acceleration",
    "ground-acceleration": "acceleration",
}
UNITS: dict[str, dict[str, float]] = {  # quantity -> unit -> factor to SI
    "time": {"s": 1.0, "ms": 1e-3},
    "theta": {"rad": 1.0, "deg": math.pi / 180},
    "omega": {"rad/s": 1.0, "deg/s": math.pi / 180},
    "displacement": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "acceleration": {"m/s2": 1.0, "m/s^2": 1.0, "cm/s2": 1e-2, "cm/s^2": 1e-2, "gal": 1e-2, "g": G0},
}
SIGNS: dict[str, dict[str, float]] = {
    "theta": {"clockwise": 1.0, "counterclockwise": -1.0},
    "motion": {"+x": 1.0, "-x": -1.0},
}
COLUMNS: dict[str, tuple[str, ...]] = {
    "theta": ("block1.theta", "block2.theta", "block1.omega", "block2.omega"),
    "displacement": ("displacement",),
    "acceleration": ("acceleration",),
}
ALIASES = {"theta": "block1.theta", "omega": "block1.omega"}
META_KEYS = ("kind", "units", "sign", "block", "block2", "name", "source", "instrument", "sampling_rate",
             "uncertainty")


@dataclass
class Measured:
    """A measurement in SI units and our sign convention (docs/conventions.md)."""

    kind: str
    time: np.ndarray  # s
    columns: dict[str, np.ndarray]  # rad, rad/s, m or m/s^2; NaN where not measured
    units: dict[str, str]  # as declared
    sign: str  # as declared
    meta: dict[str, Any] = field(default_factory=dict)  # name, block, block2, source, instrument, sampling_rate
    uncertainty: dict[str, float] = field(default_factory=dict)  # theta (rad), time (s), value (m or m/s^2)
    file_name: str | None = None
    sha256: str | None = None

    def series(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(time, values) of one column where it was measured."""
        v = self.columns[name]
        ok = ~np.isnan(v)
        return self.time[ok], v[ok]


def _quantity_of(column: str) -> str:
    return "omega" if column.endswith(".omega") else "theta" if column.endswith(".theta") else column


def parse_units(spec: str, where: str) -> dict[str, str]:
    """'time=s, theta=deg' -> {'time': 's', 'theta': 'deg'}, each unit checked against its quantity."""
    out: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in spec.split(","))):
        q, eq, unit = (x.strip() for x in part.partition("="))
        if not eq or q not in UNITS:
            raise ValueError(f"{where}: units {spec!r}: expected QUANTITY=UNIT with QUANTITY in {', '.join(UNITS)}")
        if unit not in UNITS[q]:
            raise ValueError(f"{where}: units: {unit!r} is not a unit of {q} ({', '.join(UNITS[q])})")
        out[q] = unit
    return out


def parse_uncertainty(spec: str, where: str) -> dict[str, float]:
    """'theta=0.5 deg, time=0.1 s' -> {'theta': rad, 'time': s}; motions: 'acceleration=0.01 g'."""
    out: dict[str, float] = {}
    for part in filter(None, (p.strip() for p in spec.split(","))):
        q, eq, rest = (x.strip() for x in part.partition("="))
        value, _, unit = rest.partition(" ")
        unit = unit.strip()
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not eq or q not in UNITS or unit not in UNITS[q] or not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"{where}: uncertainty {part!r}: expected QUANTITY=VALUE UNIT, e.g. theta=0.5 deg")
        out["value" if q in ("displacement", "acceleration") else q] = v * UNITS[q][unit]
    return out


_CP1252_UNDEFINED = {0x81, 0x8D, 0x8F, 0x90, 0x9D}


def _cp1252_fallback(exc: UnicodeError) -> tuple[str, int]:
    """Codec error handler: bytes that are not UTF-8 are read as Windows-1252 (Latin-1 where
    cp1252 leaves a byte undefined), so a Latin-1 header's 'Ñ' or 'é' survives."""
    if not isinstance(exc, UnicodeDecodeError):
        raise exc
    bad = exc.object[exc.start:exc.end]
    return "".join(chr(b) if b in _CP1252_UNDEFINED else bytes([b]).decode("cp1252") for b in bad), exc.end


codecs.register_error("rocking.cp1252", _cp1252_fallback)
TEXT_ENCODING = {"encoding": "utf-8-sig", "errors": "rocking.cp1252"}  # a UTF-8 BOM is skipped
_CONTROL = re.compile(r"[\x00-\x08\x0e-\x1f\x7f]")  # not in a text file (tab, LF, VT, FF, CR are)


def decode_text(raw: bytes) -> str:
    """Bytes of a text file: UTF-8 (a byte-order mark skipped), any byte that is not read as Windows-1252."""
    return raw.decode(**TEXT_ENCODING)


def _check_file(path: Path) -> None:
    """FileNotFoundError or IsADirectoryError (one line) unless `path` is a readable text file."""
    if path.is_dir():
        raise IsADirectoryError(f"measured file {path} is a directory, not a file")
    if not path.exists():
        raise FileNotFoundError(f"measured file {path} does not exist")
    if not path.is_file():
        raise ValueError(f"measured file {path} is not a regular file")
    with path.open("rb") as f:
        start = f.read(2)
    if start in (b"\xff\xfe", b"\xfe\xff"):
        raise ValueError(f"{path}, line 1: the file is UTF-16 text: save it as UTF-8 (or plain ASCII)")


def _not_text(where: str, line: int, text: str) -> ValueError | None:
    """The error for a line holding a control character (a binary file), else None."""
    m = _CONTROL.search(text)
    if m is None:
        return None
    return ValueError(f"{where}, line {line}: byte 0x{ord(m.group()):02x} at character {m.start() + 1} is not text: "
                      "is this a binary file rather than a CSV?")


def _sha256(path: Path) -> str:
    with path.open("rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


@dataclass
class _Table:
    """A CSV file read in one pass: header keys, the column names row, the data as float64."""

    meta: dict[str, tuple[int, str]]
    names_line: int = 0
    names: list[str] | None = None
    columns: list[np.ndarray] = field(default_factory=list)  # raw values, one array per column
    data_rows: int = 0  # rows after the names row (read or not)
    error: str | None = None  # the first bad data row's "line N: ..." (rows after it are not read)


def _read_table(path: Path, where: str) -> _Table:
    """Stream the file: values go straight into growing float64 arrays (8 bytes per value), so
    memory stays near the data's size whatever the file's length. The first bad data row is kept
    as an error, raised by read_csv after the header's checks, as the rows were read before."""
    table = _Table({})
    cols: list[array.array] = []
    width, prev, inf = 0, -math.inf, math.inf
    with path.open(newline="", **TEXT_ENCODING) as f:
        reader = csv.reader(f)
        try:
            for row in reader:
                if width and table.error is None:  # the fast path: a data row of numbers
                    try:
                        vals = list(map(float, row))
                    except ValueError:
                        vals = None
                    if vals is not None and len(vals) == width and prev < vals[0] < inf \
                            and -inf < sum(vals) < inf:  # no infinite value (NaN: the slow path)
                        for a, v in zip(cols, vals):
                            a.append(v)
                        prev = vals[0]
                        table.data_rows += 1
                        continue
                line = reader.line_num
                if not row or not any(c.strip() for c in row):
                    continue
                first = row[0].lstrip()
                if first.startswith("#"):
                    text = ",".join(row)
                    bad = _not_text(where, line, text)
                    if bad:
                        raise bad
                    text = text.lstrip()[1:].strip()
                    key, colon, value = text.partition(":")
                    key = key.strip().lower().replace(" ", "_")
                    if colon and key in META_KEYS:
                        table.meta[key] = (line, value.strip())
                    continue
                if table.names is None:
                    bad = _not_text(where, line, ",".join(row))
                    if bad:
                        raise bad
                    table.names_line, table.names, width = line, row, len(row)
                    cols = [array.array("d") for _ in row]
                    continue
                table.data_rows += 1
                if table.error is not None:
                    continue
                if len(row) != width:
                    table.error = f"line {line}: {len(row)} fields, the column names row has {width}"
                    continue
                try:
                    vals = [float(c) if c.strip() else math.nan for c in row]
                except ValueError:
                    bad = _not_text(where, line, ",".join(row))
                    if bad:
                        raise bad from None
                    table.error = f"line {line}: not a number in {','.join(row)!r}"
                    continue
                if not math.isfinite(vals[0]):
                    table.error = f"line {line}: time must be a finite number"
                elif not vals[0] > prev:
                    table.error = f"line {line}: time {vals[0]:g} does not increase (previous {prev:g})"
                elif bad := [c.strip() for c, v in zip(row[1:], vals[1:]) if c.strip() and not math.isfinite(v)]:
                    table.error = (f"line {line}: values must be finite numbers, not {bad[0]!r} (leave the cell "
                                   "empty for a value not measured)")
                else:
                    for a, v in zip(cols, vals):
                        a.append(v)
                    prev = vals[0]
        except csv.Error as exc:
            raise ValueError(f"{where}, line {reader.line_num}: not a CSV row ({exc})") from None
    table.columns = [np.frombuffer(a, dtype=float) if len(a) else np.empty(0) for a in cols]  # no copy
    return table


def _header(table: _Table, meta: dict[str, str], where: str, kind_implied: bool
            ) -> tuple[str, list[str], dict[str, str], str]:
    """(kind, column names, units, sign) a CSV declares (`meta`: its header's keys with the command
    line's); ValueError naming, in one line, everything the header lacks or gets wrong at once, with
    a header that works (`kind_implied`: the caller's default kind, left out of it)."""
    problems: list[str] = []
    kind = meta.get("kind")
    if kind not in KINDS:
        problems.append(f"declare the kind (# kind: or --kind) as one of {', '.join(KINDS)}"
                        + (f", not {kind!r}" if kind else ""))
    names = None if table.names is None else [ALIASES.get(h.strip(), h.strip()) for h in table.names]
    allowed = COLUMNS[KINDS[kind]] if kind in KINDS else None
    columns_ok = False
    if names is None:
        problems.append("no column names row (time, then the measured columns)")
    elif names[0] != "time":  # (quoting the line showed /etc/shadow's)
        problems.append(f"line {table.names_line}: the first column must be 'time' (lower case; a column names row "
                        "such as time,acceleration): this line is not one")
    elif allowed is not None:
        bad = [h for h in names[1:] if h not in allowed]
        columns_ok = not bad and len(names) >= 2 and len(set(names)) == len(names)
        if not columns_ok:
            problems.append(f"line {table.names_line}: columns after 'time' must be distinct names among "
                            f"{', '.join(allowed)} for kind {kind}" + (f" (got {', '.join(bad)})" if bad else ""))
    example_names = names if columns_ok else ["time", allowed[0] if allowed else "theta"]
    needed = ["time", *dict.fromkeys(_quantity_of(h) for h in example_names[1:])]
    units: dict[str, str] = {}
    if "units" not in meta:
        problems.append(f"declare the units (# units: or --units) of {' and '.join(needed)}")
    else:
        try:
            units = parse_units(meta["units"], where)
        except ValueError as exc:
            problems.append(str(exc).removeprefix(f"{where}: "))
        else:
            missing = [q for q in needed if q not in units]
            if missing:
                problems.append(f"units: no unit declared for {', '.join(missing)}")
    sign_kind = "motion" if needed[1] in ("displacement", "acceleration") else "theta"
    sign = meta.get("sign")
    if sign not in SIGNS[sign_kind]:
        problems.append(f"declare the sign convention (# sign: or --sign) as one of {', '.join(SIGNS[sign_kind])}"
                        + (f", not {sign!r}" if sign else ""))
    if problems:
        raise ValueError(f"{where}: {'; '.join(problems)}. A header that works: "
                         + _example_header(kind, not kind_implied, example_names, needed, sign_kind))
    return kind, names, units, sign


def _example_header(kind: str | None, show_kind: bool, names: list[str], quantities: list[str],
                    sign_kind: str) -> str:
    """The lines of a CSV header, quoted on one line: its kind (if `show_kind`: `kind`, or the first
    its columns fit), units, sign convention and column names; the other units each quantity takes."""
    kind = kind if kind in KINDS else next(k for k, q in KINDS.items() if q == _quantity_of(names[1]))
    first = {q: next(iter(UNITS[q])) for q in quantities}
    lines = ([f"# kind: {kind}"] if show_kind else []) + ["# units: " + ", ".join(f"{q}={u}" for q, u in first.items()),
                                                    f"# sign: {next(iter(SIGNS[sign_kind]))}", ",".join(names)]
    others = "; ".join(f"{q} also in {', '.join(u for u in UNITS[q] if u != first[q] and '^' not in u)}"
                       for q in quantities)
    return " / ".join(f"'{line}'" for line in lines) + f" ({others})"


def read_csv(path: str | Path, given: dict[str, str] | None = None,
             defaults: dict[str, str] | None = None) -> Measured:
    """A measured CSV file. `given` (command line) wins over the file's header, which wins
    over `defaults`; kind, units and sign must be declared by one of them."""
    path = Path(path)
    _check_file(path)
    where = str(path)
    table = _read_table(path, where)
    meta = {**(defaults or {}), **{k: v for k, (_, v) in table.meta.items()},
            **{k: v for k, v in (given or {}).items() if v is not None}}
    kind, names, units, sign = _header(table, meta, where, "kind" in (defaults or {}))
    quantity = KINDS[kind]
    sign_kind = "theta" if quantity == "theta" else "motion"
    if table.data_rows < 2:
        raise ValueError(f"{where}: needs at least two data rows")
    if table.error is not None:
        raise ValueError(f"{where}, {table.error}")
    time = table.columns[0]
    if UNITS["time"][units["time"]] != 1.0:
        time *= UNITS["time"][units["time"]]  # in place: the arrays are the only copy of the data
    columns = {}
    for h, v in zip(names[1:], table.columns[1:]):
        factor = UNITS[_quantity_of(h)][units[_quantity_of(h)]] * SIGNS[sign_kind][sign]
        if factor != 1.0:
            v *= factor
        columns[h] = v
    if all(np.isnan(v).all() for v in columns.values()):
        raise ValueError(f"{where}: no measured values")
    out = Measured(kind, time, columns, units, sign, file_name=path.name, sha256=_sha256(path))
    _finish(out, meta, where)
    return out


_NPTS_DT = re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([0-9.Ee+-]+)", re.I)
_OLD_NPTS_DT = re.compile(r"^\s*(\d+)\s+([0-9.Ee+-]+)\s+NPTS", re.I)
_AT2_UNITS = {"G": "g", "CM/S/S": "cm/s2", "CM/S^2": "cm/s2", "CM/SEC/SEC": "cm/s2", "M/S/S": "m/s2"}


def read_at2(path: str | Path, given: dict[str, str] | None = None) -> Measured:
    """A PEER NGA .AT2 accelerogram as a ground-acceleration measurement (m/s^2)."""
    path = Path(path)
    _check_file(path)
    where = str(path)
    raw = path.read_bytes()
    lines = re.split(r"\r\n|\r|\n", decode_text(raw))  # a Latin-1 station name is read as such
    if lines and not lines[-1].strip():
        lines.pop()
    for n, text in enumerate(lines[:4], start=1):
        bad = _not_text(where, n, text)
        if bad:
            raise bad
    if len(lines) < 5:
        raise ValueError(f"{where}: an .AT2 file has four header lines and then values")
    m = re.search(r"UNITS\s+OF\s+(\S+)", lines[2], re.I)
    unit = _AT2_UNITS.get(m.group(1).upper()) if m else None
    if unit is None:
        raise ValueError(f"{where}, line 3: expected 'ACCELERATION TIME SERIES IN UNITS OF G' (or CM/S/S)")
    m = _NPTS_DT.search(lines[3]) or _OLD_NPTS_DT.search(lines[3])
    if m is None:
        raise ValueError(f"{where}, line 4: expected 'NPTS= N, DT= dt SEC'")
    npts, dt = int(m.group(1)), float(m.group(2))
    if npts < 2 or not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"{where}, line 4: NPTS must be at least 2 and DT positive (got {npts}, {dt:g})")
    values: list[float] = []
    for n, text in enumerate(lines[4:], start=5):
        for item in text.replace(",", " ").split():
            try:
                v = float(item)
            except ValueError:
                raise (_not_text(where, n, text) or ValueError(f"{where}, line {n}: not a number: {item!r}")) from None
            if not math.isfinite(v):
                raise ValueError(f"{where}, line {n}: values must be finite")
            values.append(v)
    if len(values) != npts:
        raise ValueError(f"{where}: the header says NPTS={npts} but the file has {len(values)} values")
    meta = {"kind": "ground-acceleration", "sign": "+x", "name": lines[1].strip()[:200] or path.stem,
            "source": f"PEER NGA record: {lines[1].strip()}", "sampling_rate": str(1.0 / dt),
            **{k: v for k, v in (given or {}).items() if v is not None}}
    if meta["kind"] not in ("ground-acceleration", "table-acceleration"):
        raise ValueError(f"{where}: an .AT2 file is an acceleration record, not kind {meta['kind']!r}")
    if meta["sign"] not in SIGNS["motion"]:
        raise ValueError(f"{where}: --sign must be one of {', '.join(SIGNS['motion'])} for an accelerogram")
    a = np.asarray(values) * UNITS["acceleration"][unit] * SIGNS["motion"][meta["sign"]]
    out = Measured(meta["kind"], dt * np.arange(npts), {"acceleration": a}, {"time": "s", "acceleration": unit},
                   meta["sign"], file_name=path.name, sha256=hashlib.sha256(raw).hexdigest())
    _finish(out, meta, where)
    return out


def _finish(out: Measured, meta: dict[str, str], where: str) -> None:
    """Provenance, uncertainty and plausibility checks that catch wrong units."""
    for key in ("name", "block", "block2", "source", "instrument"):
        if meta.get(key):
            out.meta[key] = meta[key]
    out.meta.setdefault("name", Path(where).stem)
    if meta.get("sampling_rate"):
        try:
            rate = float(meta["sampling_rate"])
        except ValueError:
            rate = math.nan
        if not (rate > 0 and math.isfinite(rate)):
            raise ValueError(f"{where}: sampling_rate must be a positive number of Hz, not {meta['sampling_rate']!r}")
        out.meta["sampling_rate"] = rate
    if meta.get("uncertainty"):
        out.uncertainty = parse_uncertainty(meta["uncertainty"], where)
    for name, v in out.columns.items():
        top = max(-float(np.fmin.reduce(v)), float(np.fmax.reduce(v)))  # max |v|, NaN ignored, no copy
        if name.endswith(".theta") and top > math.pi / 2:
            raise ValueError(f"{where}: |{name}| reaches {top:.3g} rad, beyond a fallen block (pi/2): "
                             f"are the units right (declared {out.units.get('theta')})?")
        if name == "acceleration" and top > 10 * G0:
            raise ValueError(f"{where}: |acceleration| reaches {top / G0:.3g} g: are the units right "
                             f"(declared {out.units.get('acceleration')})?")
        if name == "displacement" and top > 5.0:
            raise ValueError(f"{where}: |displacement| reaches {top:.3g} m: are the units right "
                             f"(declared {out.units.get('displacement')})?")


def read_measured(path: str | Path, given: dict[str, str] | None = None) -> Measured:
    """A measured file, CSV or .AT2 (by its suffix)."""
    if Path(path).suffix.lower() == ".at2":
        return read_at2(path, given)
    return read_csv(path, given)


def read_measured_csv(path: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """A rotation CSV to overlay on a recording: {column: (time in s, values)}. Without a
    header it is taken as SI units and our sign convention."""
    m = read_csv(path, defaults={"kind": "rotation", "units": "time=s, theta=rad, omega=rad/s",
                                 "sign": "clockwise"})
    return {name: m.series(name) for name in m.columns if not np.isnan(m.columns[name]).all()}
