"""Stored ground-motion records: add, find, select a suite, read the samples.

A record's samples are time (s), horizontal and optionally vertical ground acceleration
(m/s^2) in the sign convention of docs/conventions.md, packed by db.series. Its intensity
measures are computed by runners.engine.intensity when it is stored (runners.engine.records)."""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import or_, select
from sqlalchemy.orm import Session

from db import series
from db.schema import Record

MEASURES = ("pga", "pgv", "pgd", "arias", "d5_95", "mean_period")
PROVENANCE = ("suite", "event", "year", "magnitude", "station", "distance_km", "component", "source", "meta",
              "file_name")


def add_record(session: Session, name: str, time: np.ndarray, ah: np.ndarray, av: np.ndarray | None, sha256: str,
               measures: dict[str, float] | None = None, **provenance: Any) -> Record:
    """A new record (the name must be free); `provenance` takes the keys of PROVENANCE."""
    unknown = set(provenance) - set(PROVENANCE)
    if unknown:
        raise TypeError(f"unknown record fields {sorted(unknown)}")
    cols = {"ah": np.asarray(ah, float)} | ({} if av is None else {"av": np.asarray(av, float)})
    names, n, blob = series.pack(np.asarray(time, float), cols)
    t = np.asarray(time, float)
    rec = Record(name=name, names=names, n_samples=n, data=blob, sha256=sha256, dt=float(np.min(np.diff(t))),
                 duration=float(t[-1] - t[0]), **provenance, **(measures or {}))
    session.add(rec)
    return rec


def free_name(session: Session, name: str) -> str:
    """name, or name-2, name-3, ... whichever no stored record holds."""
    taken = set(session.scalars(select(Record.name).where(Record.name.like(f"{name}%"))))
    return next(n for n in (name, *(f"{name}-{i}" for i in range(2, 100000))) if n not in taken)


def samples(rec: Record) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(time in s, horizontal acceleration, vertical acceleration or None) in m/s^2."""
    t, cols = series.unpack(rec.names, rec.n_samples, rec.data)
    return t, cols["ah"], cols.get("av")


def find_record(session: Session, key: str | int) -> Record:
    """A record by name or id; ValueError with a hint when there is none."""
    rec = session.scalar(select(Record).where(Record.name == str(key)))
    if rec is None and str(key).strip().isdigit():
        rec = session.get(Record, int(str(key).strip()))
    if rec is None:
        file = " and no such record file" if str(key).lower().endswith((".at2", ".csv", ".txt")) else ""
        raise ValueError(f"no record {key!r} in the database{file}{closest_names(session, str(key))} (runners records "
                         "list shows them; runners records import adds them)")
    return rec


def closest_names(session: Session, key: str, spread: float = 0.01) -> str:
    """': did you mean ...?' naming the stored suites or record names closest to a mistyped `key`
    (difflib; those within `spread` of the best ratio, at most three, suites first where one is
    the closest), or the FEMA P695 set `key` names when it is not stored; '' when nothing is close."""
    import difflib

    from runners.engine.fema import SETS

    stored = dict(suites(session))
    head, _, rest = key.strip().partition("/")
    fema_set = rest.split("/")[0]
    if head == "fema-p695" and fema_set in SETS and f"fema-p695/{fema_set}" not in stored:
        return f": the FEMA P695 set {fema_set} is not stored; runners records import fema-p695 {fema_set} stores it"
    names = [*stored, *session.scalars(select(Record.name))]
    ratios = sorted(((difflib.SequenceMatcher(None, key, n).ratio(), n) for n in names), reverse=True)
    close = [n for r, n in ratios[:3] if r >= max(0.6, ratios[0][0] - spread)] if ratios else []
    if not close:
        return ""
    said = [f"the suite {n}" if n in stored else n for n in close]
    return f": did you mean {' or '.join([', '.join(said[:-1]), said[-1]] if len(said) > 1 else said)}?"


def suite_records(session: Session, suite: str) -> list[Record]:
    """The records of a suite, in id order: its exact name or any suite under it
    ("fema-p695" holds "fema-p695/farfield", ...)."""
    suite = suite.strip().rstrip("/")
    return list(session.scalars(select(Record).where(or_(Record.suite == suite, Record.suite.like(f"{suite}/%")))
                                .order_by(Record.id)))


def suites(session: Session) -> list[tuple[str, int]]:
    """(suite, number of records) of every suite."""
    from sqlalchemy import func

    rows = session.execute(select(Record.suite, func.count()).where(Record.suite.is_not(None))
                           .group_by(Record.suite).order_by(Record.suite))
    return [(s, int(n)) for s, n in rows]
