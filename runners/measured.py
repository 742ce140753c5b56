"""Measured time series read from CSV files, to overlay on simulated runs.

A file starts with a header row naming its columns: ``time`` (s) first, then any
of ``block1.theta``, ``block2.theta`` (rad) and ``block1.omega``, ``block2.omega``
(rad/s), in the sign convention of docs/conventions.md (theta > 0 clockwise).
Lines starting with ``#`` are comments. An empty cell means "not measured at this
time" for that column only. Time must increase strictly.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

COLUMNS = ("block1.theta", "block1.omega", "block2.theta", "block2.omega")


def read_measured_csv(path: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{column: (time in s, values)} of a measured CSV file; ValueError naming the line on bad input."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"measured file {path} does not exist")
    with path.open(newline="") as f:
        rows = [(n, r) for n, r in enumerate(csv.reader(f), start=1)
                if r and not r[0].lstrip().startswith("#") and any(c.strip() for c in r)]
    if not rows:
        raise ValueError(f"{path}: no header row (time, then any of {', '.join(COLUMNS)})")
    _, header = rows[0]
    header = [h.strip() for h in header]
    if header[0] != "time":
        raise ValueError(f"{path}: the first column must be 'time' (s), not {header[0]!r}")
    bad = [h for h in header[1:] if h not in COLUMNS]
    if bad or len(header) < 2 or len(set(header)) != len(header):
        raise ValueError(f"{path}: columns after 'time' must be distinct names among {', '.join(COLUMNS)}"
                         + (f" (got {', '.join(bad)})" if bad else ""))
    if len(rows) < 3:
        raise ValueError(f"{path}: needs at least two data rows")
    t: list[float] = []
    cols: dict[str, list[tuple[float, float]]] = {h: [] for h in header[1:]}
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise ValueError(f"{path}, line {line}: {len(row)} fields, the header has {len(header)}")
        try:
            values = [float(c) if c.strip() else math.nan for c in row]
        except ValueError:
            raise ValueError(f"{path}, line {line}: not a number in {','.join(row)!r}") from None
        if not math.isfinite(values[0]):
            raise ValueError(f"{path}, line {line}: time must be a finite number")
        if t and values[0] <= t[-1]:
            raise ValueError(f"{path}, line {line}: time {values[0]:g} s does not increase (previous {t[-1]:g} s)")
        if any(math.isinf(v) for v in values[1:]):
            raise ValueError(f"{path}, line {line}: values must be finite")
        t.append(values[0])
        for h, v in zip(header[1:], values[1:]):
            if not math.isnan(v):
                cols[h].append((values[0], v))
    out = {}
    for h, pairs in cols.items():
        if pairs:
            a = np.array(pairs)
            out[h] = (a[:, 0], a[:, 1])
    if not out:
        raise ValueError(f"{path}: no measured values")
    return out
