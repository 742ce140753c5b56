"""Record files: the plain-text format the FMU reads (excitation.kind = 4, excitation.file).

One sample per line: time (s), horizontal ground acceleration (m/s^2), and optionally the
vertical one (m/s^2), separated by spaces and tabs, or by one comma or semicolon, one way within
a line; lines end with LF, CR LF or CR; '#' starts a comment line. The
FMU joins the samples by straight lines and takes the acceleration as zero before the first
and after the last (docs/records.md). Signs follow docs/conventions.md: a_h > 0 accelerates
the ground towards +x, a_v > 0 upwards.

:func:`read_record_file` applies the same checks as the FMU's own reader (model/c/record.c),
with the same one-line messages naming the file and the line, so the command line refuses a
bad file before anything is stored. :func:`cached_record_file` writes a stored record where
the FMU can read it: one file per content (its sha256), checked against that hash before each
use and written again when it does not hold those samples.
"""

from __future__ import annotations

import array
import hashlib
import logging
import math
import os
import re
from pathlib import Path

import numpy as np

from runners.engine.files import create_beside
from runners.errors import RockingError

MAX_SAMPLES = 10_000_000
MAX_BYTES = 1 << 30  # the FMU's limit on a record file's size (model/c/record.c)
MIN_INTERVAL, MAX_INTERVAL = 1e-6, 100.0  # s
MAX_TIME = 1e6  # s
MAX_ACCELERATION = 98.0665  # m/s^2, 10 g exactly
MAX_TOKEN = 512  # characters: a number written out longer than this is not a sample
_SPACE = " \t\r\v\f"
_LOG = logging.getLogger("runners.records")


class RecordFileError(RockingError, ValueError):
    """A record file the FMU would refuse; str() is one line naming the file and the line."""


def write_record_file(path: str | Path, time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None,
                      comments: list[str] | tuple[str, ...] = ()) -> Path:
    """Write samples (s, m/s^2) in the FMU's format, every number to 17 significant digits (read
    back bit for bit); `comments` become '#' lines at the top. Written atomically."""
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"cannot write {path}: the folder {path.parent} does not exist")
    cols = [np.asarray(time, float), np.asarray(ah, float)] + ([] if av is None else [np.asarray(av, float)])
    head = [f"# {c}" for line in comments for c in str(line).splitlines()]
    head.append("# time (s), horizontal acceleration (m/s2)" + ("" if av is None else ", vertical acceleration (m/s2)"))
    body = "\n".join(" ".join(repr(float(x)) for x in row) for row in zip(*cols))
    fd, tmp = create_beside(path)  # mode 0666 less the umask, as open() makes it
    with os.fdopen(fd, "w") as fh:
        fh.write("\n".join(head) + "\n" + body + "\n")
    os.replace(tmp, path)
    return path


def _number(token: str) -> float:
    if len(token) >= MAX_TOKEN or not re.fullmatch(r"[0-9.+\-eEnNaAiIfFtTyY]+", token):
        raise ValueError(token)
    return float(token)


def _shortest(x: float) -> str:
    """x in %g form with the fewest significant digits (15 to 17) that read back as x, as the
    FMU's messages write it."""
    for digits in (15, 16, 17):
        text = f"{x:.{digits}g}"
        if float(text) == x:
            break
    return text


class _Line(ValueError):
    """A line's problem (the reader adds the file and the line)."""


def _split(text: str) -> list[str]:
    """The values of a data line, as the FMU's reader splits them (model/c/record.c)."""
    tokens, i, n, spaced, commas = [], 0, len(text), False, False
    while i < n and text[i] in _SPACE:
        i += 1
    while i < n:
        j = i
        while j < n and text[j] not in _SPACE and text[j] not in ",;":
            j += 1
        if j == i:
            raise _Line("an empty value between separators")
        tokens.append(text[i:j])
        i = j
        while i < n and text[i] in _SPACE:
            i += 1
        if i < n and text[i] in ",;":
            i, commas = i + 1, True
            while i < n and text[i] in _SPACE:
                i += 1
            if i == n:
                raise _Line("an empty value between separators")
        elif i < n:
            spaced = True
        if spaced and commas:
            raise _Line("spaces between some values and commas between others: write decimals with '.' and "
                        "separate the values one way")
    return tokens


def read_record_file(path: str | Path, scale: float = 1.0, unit: str = "m/s2"
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(time in s, horizontal acceleration in m/s^2, vertical acceleration or None) of a record
    file; RecordFileError with the FMU's message for anything the FMU would refuse. A file too
    large for a record is refused from its size and its count of lines, before any is parsed.
    `scale` (m/s^2 per `unit`) reads a file whose accelerations are in another unit (g: 9.80665);
    the FMU reads m/s2 only."""
    path = Path(path)
    where = f"record file '{path}'"
    try:
        f = path.open(encoding="latin-1", newline="")  # one character per byte; lines end in LF, CR LF or CR
    except IsADirectoryError:
        raise RecordFileError(f"{where} is not a regular file") from None
    except OSError as exc:
        raise RecordFileError(f"{where} cannot be opened: {exc.strerror or exc}") from None
    with f:
        check_size(path, where)
        t, ah, av = _read_lines(f, where, scale, unit)
    if scale != 1.0:
        ah, av = ah * scale, (None if av is None else av * scale)
    return t, ah, av


def check_size(path: Path, where: str, header_lines: int = 0) -> None:
    """RecordFileError when a file is larger than the FMU reads (1 GiB) or has more than
    MAX_SAMPLES data lines (neither blank nor a '#' comment; `header_lines` of them are not
    samples), found as the FMU's first pass finds them but in blocks with numpy: about a second
    for ten million lines, where parsing them takes minutes."""
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise RecordFileError(f"{where} is {size:.3g} bytes, larger than any record of at most {MAX_SAMPLES} samples")
    if (size + 1) // 4 <= MAX_SAMPLES + header_lines:  # a sample line takes at least 4 bytes ("0 0" and its end)
        return
    n = count_data_lines(path) - header_lines
    if n > MAX_SAMPLES:
        raise RecordFileError(f"{where} has more than {MAX_SAMPLES} samples (the most a record may have)")


_BLOCK = 1 << 22  # bytes read at a time by count_data_lines
_BLANK = np.zeros(256, bool)
_BLANK[[ord(c) for c in " \t\v\f"]] = True


def count_data_lines(path: Path, block: int = _BLOCK) -> int:
    """The lines of a file that are neither blank nor a '#' comment (lines end in LF, CR LF or
    CR; a UTF-8 byte-order mark is skipped), as model/c/record.c counts them, `block` bytes at a
    time."""
    count = 0
    with path.open("rb") as f:
        head = f.read(3)
        carry = b"" if head == b"\xef\xbb\xbf" else head
        while True:
            chunk = f.read(block)
            data = carry + chunk
            cut = max(data.rfind(b"\n"), data.rfind(b"\r")) + 1 if chunk else len(data)
            if chunk and not cut:  # no line end yet: keep what decides the line, its first byte that is not blank
                m = _NOT_BLANK.search(data)
                carry = data[m.start():m.start() + 1] if m else b""
                continue
            count += _data_lines(data[:cut])
            carry = data[cut:]
            if not chunk:
                return count


def _data_lines(data: bytes) -> int:
    """Data lines of whole lines: the segments between LF and CR bytes whose first character
    other than a space, tab, VT or FF is not '#' (a CR LF leaves a blank segment, not counted)."""
    b = np.frombuffer(data, np.uint8)
    if not b.size:
        return 0
    first = np.concatenate(([0], np.flatnonzero((b == 10) | (b == 13)) + 1))
    first = first[first < b.size]
    pending = np.flatnonzero(_BLANK[b[first]])  # lines that start with blanks: move to their first other byte
    for _ in range(64):
        if not pending.size:
            break
        first[pending] += 1
        pending = pending[first[pending] < b.size]
        pending = pending[_BLANK[b[first[pending]]]]
    for i in pending:  # lines indented further (rare): one C-speed search each
        m = _NOT_BLANK.search(data, int(first[i]))
        first[i] = m.start() if m else b.size
    first = first[first < b.size]
    c = b[first]
    return int(np.count_nonzero((c != ord("#")) & (c != 10) & (c != 13)))


_NOT_BLANK = re.compile(rb"[^ \t\v\f]")


def _read_lines(f, where: str, scale: float = 1.0,
                unit: str = "m/s2") -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """read_record_file's reading, streamed: the samples go straight into float64 arrays (8 bytes a
    value), so a record of millions of samples takes its size in memory, not a Python list per line."""
    cols = [array.array("d") for _ in range(3)]
    count = 0
    columns, first_line = 0, 0
    for n, line in enumerate(f, start=1):
        if n == 1 and line.startswith("\xef\xbb\xbf"):  # a UTF-8 byte-order mark, read as Latin-1
            line = line[3:]
        if "\0" in line:
            raise RecordFileError(f"{where}, line {n}: contains a NUL byte: this is not a text record file")
        text = line.rstrip("\r\n").strip(_SPACE)
        if not text or text.startswith("#"):
            continue
        try:
            tokens = _split(text)
            values = [_number(tok) for tok in tokens[:4]]
        except _Line as exc:
            raise RecordFileError(f"{where}, line {n}: {exc}") from None
        except ValueError as exc:
            if not count:  # quote nothing of a file that has shown no sample (/etc/shadow's first line), as the FMU
                raise RecordFileError(f"{where}, line {n}: not a record file: its first data line is not two or three "
                                      "numbers (time in s, horizontal acceleration in m/s2, optional vertical; a "
                                      "header line must start with '#')") from None
            shown = "".join(c if c.isprintable() else "?" for c in str(exc.args[0])[:23])
            raise RecordFileError(f"{where}, line {n}: '{shown}' is not a number") from None
        c = len(tokens)
        if c not in (2, 3):
            raise RecordFileError(f"{where}, line {n}: {c} values, expected 2 or 3 (time in s, horizontal "
                                  "acceleration in m/s2, optional vertical acceleration in m/s2)")
        if not columns:
            columns, first_line = c, n
        elif c != columns:
            raise RecordFileError(f"{where}, line {n}: {c} values, but line {first_line} has {columns} "
                                  "(every line needs the same columns)")
        for j, v in enumerate(values):
            if not math.isfinite(v):
                what = "the time" if j == 0 else "an acceleration"
                raise RecordFileError(f"{where}, line {n}: {what} is not a finite number")
        if abs(values[0]) > MAX_TIME:
            raise RecordFileError(f"{where}, line {n}: |time| = {_shortest(abs(values[0]))} s is beyond a million seconds: "
                                  "is the first column the time in seconds?")
        for j in range(1, c):
            if abs(values[j]) * scale > MAX_ACCELERATION:
                raise RecordFileError(f"{where}, line {n}: |{'horizontal' if j == 1 else 'vertical'} acceleration| "
                                      f"= {abs(values[j]):g} {unit} exceeds 10 g: are the values in {unit}?")
        if count:
            dt = values[0] - cols[0][-1]
            if not dt > 0:
                raise RecordFileError(f"{where}, line {n}: time {_shortest(values[0])} s does not increase "
                                      f"(previous sample {_shortest(cols[0][-1])} s)")
            if dt < MIN_INTERVAL:
                raise RecordFileError(f"{where}, line {n}: sample interval {dt:g} s is below {MIN_INTERVAL:g} s: "
                                      "absurd sampling (is time in seconds?)")
            if dt > MAX_INTERVAL:
                raise RecordFileError(f"{where}, line {n}: sample interval {dt:g} s is above {MAX_INTERVAL:g} s: "
                                      "absurd sampling (is time in seconds?)")
        for a, v in zip(cols, values):
            a.append(v)
        count += 1
        if count > MAX_SAMPLES:
            raise RecordFileError(f"{where} has more than {MAX_SAMPLES} samples (the most a record may have)")
    if not count:
        raise RecordFileError(f"{where} has no samples (expected lines of: time in s, horizontal acceleration in m/s2)")
    if count < 2:
        raise RecordFileError(f"{where} has only one sample: a record needs at least two")
    t, ah, av = (np.frombuffer(a, dtype=float) for a in cols)  # no copy
    return t, ah, (av if columns == 3 else None)


def samples_sha256(time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None) -> str:
    """sha256 of the samples as little-endian float64: time, then ah, then av (db.schema.Record.sha256)."""
    cols = [time, ah] + ([] if av is None else [av])
    return hashlib.sha256(np.vstack([np.asarray(c, "<f8") for c in cols]).tobytes()).hexdigest()


def cache_folder() -> Path:
    """Where record files for the FMU are written: $ROCKING_CACHE/records, else
    $XDG_CACHE_HOME/rocking/records, else ~/.cache/rocking/records."""
    base = os.environ.get("ROCKING_CACHE")
    if base:
        return Path(base) / "records"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rocking" / "records"


def cached_record_file(time: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None,
                       comments: list[str] | tuple[str, ...] = (), folder: Path | None = None) -> Path:
    """The samples as a record file named by their sha256. A file already there is used only if
    its samples hash to its name; one that does not (edited, truncated, written by something
    else) is written again, with a one-line warning (logger runners.records: on stderr unless
    logging is set up). Returns its absolute path (what excitation.file should name)."""
    folder = Path(folder or cache_folder())
    folder.mkdir(parents=True, exist_ok=True)
    sha = samples_sha256(time, ah, av)
    path = folder.resolve() / f"{sha}.txt"  # never resolved itself: a link there is replaced, not what it names
    if path.exists() and not path.is_file():
        raise RecordFileError(f"the record cache file {path} is a folder or a device, not a file: remove it (the "
                              "cache is rebuilt as needed)")
    if path.is_file():
        if cached_file_ok(path, sha):
            return path
        _LOG.warning("note: the record cache file %s did not hold the samples its name is the hash of (edited or "
                     "damaged): written again", path)
    write_record_file(path, time, ah, av, comments)
    return path


# cache files this process has read whole and found right: path -> (sha, inode, size, mtime_ns, ctime_ns) then
_CHECKED: dict[Path, tuple] = {}


def _stamp(path: Path) -> tuple[int, int, int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns


def cached_file_ok(path: Path, sha: str) -> bool:
    """Whether a record cache file holds, as written by write_record_file (comments at the top,
    then 2 or 3 numbers a line), samples whose samples_sha256 is `sha`. A file this process has already
    read whole and found right is taken again without reading while its inode, size, modification and
    change times are unchanged (a sweep's support measures ask for each record's file in turn)."""
    stamp = _stamp(path)
    if stamp is not None and _CHECKED.get(path) == (sha, *stamp):
        return True
    ok = _holds(path, sha)
    if ok and stamp is not None and _stamp(path) == stamp:
        _CHECKED[path] = (sha, *stamp)
    return ok


def _holds(path: Path, sha: str) -> bool:
    try:
        raw = path.read_bytes()
    except OSError:
        return False
    start = 0
    while raw.startswith(b"#", start):  # the comment lines at the top
        start = raw.find(b"\n", start) + 1
        if not start:
            return False
    body = raw[start:]
    columns = len(body[:body.find(b"\n")].split())
    try:
        values = np.array(body.split(), dtype=float)
    except ValueError:
        return False
    if columns not in (2, 3) or values.size < 2 * columns or values.size % columns:
        return False
    cols = values.reshape(-1, columns).T
    return samples_sha256(cols[0], cols[1], cols[2] if columns == 3 else None) == sha
