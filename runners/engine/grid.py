"""The grid of a sweep: its axes, records and intensity levels, and its points by flat index.

The flat grid index runs over records first, then intensity levels, then the --grid axes (last
fastest). Grid.columns gives any set of points at once, in columns (what a sweep's workers run and
store); Grid.point gives one point as dicts. Both compute every value by the same scalar arithmetic,
so a point is the same bit for bit whichever way it is asked for. Units: SI (frequencies in Hz,
accelerations in m/s^2); the dimensionless w and a are those of Dimitrakopoulos & DeJong (2012).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from runners.engine.intensity import G0, SCALING, SUPPORT_MEASURES
from runners.engine.scene import KINDS, MAX_PGA_G

@dataclass(frozen=True)
class Axis:
    name: str  # "w", "a" or an FMU parameter
    start: float
    stop: float
    count: int
    integer: bool = False  # an Integer FMU parameter: every value a whole number, given to the FMU as an int

    @property
    def values(self) -> np.ndarray:
        return np.array([self.value(i) for i in range(self.count)]) if self.integer \
            else np.linspace(self.start, self.stop, self.count)

    def value(self, i: int) -> float | int:
        """values[i], computed alone (a grid point must not cost the whole axis), bit for bit."""
        v = _linspace_at(self.start, self.stop, self.count, i)
        return int(round(v)) if self.integer else v


def _linspace_at(start: float, stop: float, count: int, i: int) -> float:
    """np.linspace(start, stop, count)[i], by numpy's own arithmetic."""
    if count == 1:
        return float(start)
    if i == count - 1:
        return float(stop)
    step = (stop - start) / (count - 1)
    if step == 0:
        return float(i / (count - 1) * (stop - start) + start)
    return float(i * step + start)



def scales(p: dict[str, Any]) -> tuple[float, float]:
    """(p, uplift acceleration) of the scene: rad/s and m/s^2 per unit of w and a; ValueError,
    in one line, where they do not exist (g or a half height not above zero)."""
    from runners.engine.shapes import has_outline

    if has_outline(p):
        raise ValueError("w and a are scaled by a rectangular block's p = sqrt(3 g / (4 R)) and g tan(alpha); a body of "
                         "real shape (an outline) has one of each per side: use --grid axes on excitation.frequency and "
                         "excitation.amplitude instead")
    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    two = int(p.get("nBlocks", 1)) == 2
    if not (g > 0 and h > 0 and (not two or p["block2.halfHeight"] > 0)):
        raise ValueError(f"w and a are scaled by block 1's p = sqrt(3 g / (4 R)) and the uplift acceleration, which "
                         f"need g and the half heights above zero (g = {g:g}, block1.halfHeight = {h:g}"
                         + (f", block2.halfHeight = {p['block2.halfHeight']:g}" if two else "") + ")")
    pf = math.sqrt(3 * g / (4 * math.hypot(b, h)))
    if two:
        b2, h2, m1, m2 = p["block2.halfWidth"], p["block2.halfHeight"], p["block1.mass"], p["block2.mass"]
        y_g = (m1 * h + m2 * (2 * h + h2)) / (m1 + m2)
        return pf, g * min(b / y_g, min(b, b2) / h2)
    return pf, g * b / h


# --im measure: unit of its levels, factor to SI (pfa and sa_t1: scenes on a support, runners.engine.floor_motion)
IM_UNITS = {"pga": ("g", G0), "pgv": ("m/s", 1.0), "pfa": ("g", G0), "sa_t1": ("g", G0)}
# levels beyond these are a mistake of units, not an earthquake (the largest horizontal PGA
# recorded is about 2.7 g, the largest PGV about 3 m/s: runners.engine.records' notes)
IM_LIMITS = {"pga": MAX_PGA_G, "pgv": 10.0, "pfa": 4 * MAX_PGA_G, "sa_t1": 4 * MAX_PGA_G}


@dataclass(frozen=True)
class Intensity:
    """--im MEASURE=START:STOP:COUNT: each record scaled so that MEASURE takes COUNT values."""

    measure: str  # pga (levels in g) or pgv (m/s)
    start: float
    stop: float
    count: int

    @property
    def unit(self) -> str:
        return IM_UNITS[self.measure][0]

    @property
    def values(self) -> np.ndarray:
        """The levels, in self.unit (12 significant digits: 0.8, not 0.7999999999999999)."""
        return np.array([self.level(i) for i in range(self.count)])

    def level(self, i: int) -> float:
        """values[i], computed alone."""
        return float(f"{_linspace_at(self.start, self.stop, self.count, i):.12g}")

    def si(self, level: float) -> float:
        return level * IM_UNITS[self.measure][1]


def parse_intensity(spec: str) -> Intensity:
    """pga=START:STOP:COUNT (g), pgv=START:STOP:COUNT (m/s), or on a support pfa= or sa_t1= (g), levels above zero."""
    name, eq, rng = spec.partition("=")
    parts = rng.split(":")
    name = name.strip().lower()
    if not eq or len(parts) != 3 or name not in IM_UNITS:
        raise ValueError(f"--im {spec!r}: expected pga=START:STOP:COUNT (in g) or pgv=START:STOP:COUNT (in m/s); on a "
                         "[building] or [platform], also pfa= or sa_t1= (in g)")
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"--im {spec!r}: START and STOP must be numbers and COUNT an integer") from None
    if count < 1 or not (math.isfinite(start) and math.isfinite(stop) and start > 0 and stop > 0):
        raise ValueError(f"--im {spec!r}: levels must be finite and above zero, COUNT at least 1")
    unit, limit = IM_UNITS[name][0], IM_LIMITS[name]
    if max(start, stop) > limit:
        raise ValueError(f"--im {spec!r}: {name} levels are in {unit}, and {max(start, stop):g} {unit} is beyond any "
                         f"recorded earthquake (at most {limit:g} {unit} here)" + (": did you mean m/s2?"
                                                                                  if name == "pga" else ""))
    return Intensity(name, start, stop, count)


@dataclass(frozen=True)
class RecordRef:
    """A record of a sweep, as the runner and its workers need it."""

    id: int
    name: str
    sha256: str  # of its samples: workers read the file cached under this name
    end: float  # s, time of its last sample
    measures: dict  # intensity measures of the unscaled record (SI; runners.engine.intensity)


@dataclass
class Points:
    """Grid points in columns, one entry per point (Grid.columns).

    values: the grid values by name in the order a point stores them (runs.point), each a list or
    array of n entries, None where a point has no such value; over: the FMU parameters the points
    set, by name, each an array or list of n entries (None: the scene's value); records: each
    point's record, or None for a grid without records."""

    index: np.ndarray
    values: dict[str, Any]
    over: dict[str, Any]
    records: list[RecordRef] | None

    def __len__(self) -> int:
        return len(self.index)

    def values_of(self, k: int) -> dict[str, Any]:
        """The grid values of point k (its runs.point)."""
        return {name: _plain(col[k]) for name, col in self.values.items() if col[k] is not None}

    def over_of(self, k: int) -> dict[str, Any]:
        """The FMU parameter overrides of point k."""
        return {name: _plain(col[k]) for name, col in self.over.items() if col[k] is not None}

    def json(self) -> list[str]:
        """runs.point of each point, as json.dumps writes it."""
        if self.records is not None or any(isinstance(c, list) for c in self.values.values()):
            return [json.dumps(self.values_of(k)) for k in range(len(self))]
        template = "{" + ", ".join(json.dumps(name).replace("%", "%%") + ": %s" for name in self.values) + "}"
        return [template % p for p in zip(*(_reprs(col) for col in self.values.values()))]


def _reprs(col: np.ndarray) -> list[str]:
    """repr of each value of a column (as json.dumps writes a number), once per distinct value:
    a grid's axes repeat theirs."""
    col = np.asarray(col)
    bits = col.view(np.int64) if col.dtype == np.float64 else col  # (-0.0 and 0.0 apart)
    _, first, inv = np.unique(bits, return_index=True, return_inverse=True)
    return np.array([repr(v) for v in col[first].tolist()], dtype=object)[inv.reshape(-1)].tolist()


def _plain(v: Any) -> Any:
    """A numpy scalar as the Python int or float it holds."""
    return v.item() if isinstance(v, np.generic) else v


# relative: a block 2 wider than block 1 by at most this is as wide as block 1. A grid's values are
# np.linspace's, whose rounding gives block2.halfWidth=0.1:0.2:3 the middle value 0.15000000000000002:
# a few ulps above a block 1 of 0.15, which the FMU's exact check (a rocking–sliding stack needs
# block 2 no wider than block 1) would refuse, though the user asked for equal widths
WIDTH_RTOL = 1e-12


def _level_widths(over: dict[str, Any], base: dict[str, Any], n: int) -> None:
    """Give the FMU block 1's half width (m) as block 2's at the points of a rocking–sliding stack
    where a --grid axis makes block 2 wider than block 1 by at most WIDTH_RTOL (relative); the
    stored grid value (runs.point) stays the axis's."""
    if "block2.halfWidth" not in over and "block1.halfWidth" not in over:
        return

    def column(name: str) -> np.ndarray:
        col = over.get(name, base.get(name, 0))
        return np.asarray(col if not isinstance(col, list) else [base.get(name, 0) if v is None else v for v in col],
                          dtype=float) * np.ones(n)

    b1, b2 = column("block1.halfWidth"), column("block2.halfWidth")
    level = (b2 > b1) & (b2 <= b1 * (1 + WIDTH_RTOL)) & (column("nBlocks") == 2) & (column("contact.model") == 1)
    if level.any():
        over["block2.halfWidth"] = np.where(level, b1, b2)


def _table(values: np.ndarray, f) -> np.ndarray:
    """f(i) for each i of `values`, computed once per distinct i."""
    u, inv = np.unique(values, return_inverse=True)
    return np.array([f(int(i)) for i in u])[inv.reshape(-1)]


@dataclass
class Grid:
    """The points of a sweep: records (optional), intensity levels (optional), then --grid axes."""

    axes: list[Axis]
    records: list[RecordRef] | None = None
    intensity: Intensity | None = None

    @property
    def counts(self) -> list[int]:
        return ([len(self.records)] if self.records else []) + ([self.intensity.count] if self.intensity else []) \
            + [ax.count for ax in self.axes]

    @property
    def total(self) -> int:
        return math.prod(self.counts)

    def point(self, index: int, base: dict[str, Any]) -> tuple[dict, dict, RecordRef | None]:
        """(grid values, FMU parameter overrides, record) of the flat grid index (last axis fastest).
        A record's file is given as "@SHA256" (each worker knows where it keeps that file)."""
        pts = self.columns(np.array([index], dtype=np.int64), base)
        return pts.values_of(0), pts.over_of(0), pts.records[0] if pts.records else None

    def columns(self, indices: np.ndarray, base: dict[str, Any]) -> Points:
        """The points of the flat grid indices `indices` in columns; `base`: the scene's FMU
        parameters (defaults included), which w and a are scaled by."""
        indices = np.asarray(indices, dtype=np.int64)
        n = len(indices)
        idx = list(np.unravel_index(indices, self.counts)) if n else [np.zeros(0, np.int64)] * len(self.counts)
        values: dict[str, Any] = {}
        over: dict[str, Any] = {}
        recs = None
        ri = None
        if self.records:
            ri = idx.pop(0)
            recs = [self.records[i] for i in ri.tolist()]
            values.update(record=[r.name for r in recs], record_id=[r.id for r in recs])
            over.update({"excitation.kind": np.full(n, KINDS["record"], dtype=np.int64),
                         "excitation.file": [f"@{r.sha256}" for r in recs]})
        if self.intensity:
            li = idx.pop(0)
            im = self.intensity
            values.update(level=_table(li, im.level), level_measure=[im.measure] * n, level_unit=[im.unit] * n)
            pair = ri * im.count + li  # the scale of each (record, level)
            over["excitation.scale"] = _table(pair, lambda p: im.si(im.level(p % im.count))
                                              / self.records[p // im.count].measures[im.measure])
        others = []  # (indices, count) of the axes other than w and a: they may change the scales
        for ax, i in zip(self.axes, idx):
            col = _table(i, ax.value)
            values[ax.name] = col.astype(np.int64) if ax.integer else col.astype(np.float64)
            if ax.name not in ("w", "a"):
                over[ax.name] = values[ax.name]
                others.append((i, ax.count))
        _level_widths(over, base, n)
        if "w" in values or "a" in values:
            self._scale_w_a(values, over, others, base, n)
        if recs is not None:  # the scaled record's measures, for fragility and IDA
            scale = over.get("excitation.scale", np.full(n, float(base.get("excitation.scale", 1.0))))
            values["scale"] = scale
            for k in dict.fromkeys(k for r in self.records for k in r.measures if SCALING.get(k, 0)):
                values[k] = [abs(s) ** SCALING[k] * r.measures[k] if r.measures.get(k) is not None else None
                             for s, r in zip(scale.tolist(), recs)]
        return Points(indices, values, over, recs)

    def _scale_w_a(self, values: dict, over: dict, others: list, base: dict[str, Any], n: int) -> None:
        """The FMU parameters of the w and a axes: each group of points with the same values on
        the other axes shares its scales (p, uplift acceleration) and excitation kind."""
        group = np.zeros(n, dtype=np.int64)
        for i, count in others:
            group = group * count + i
        _, firsts, inv = np.unique(group, return_index=True, return_inverse=True)
        inv = inv.reshape(-1)
        pf, acc, harmonic, freq = [], [], [], []
        for k in firsts.tolist():
            merged = {**base, **{name: _plain(col[k]) for name, col in over.items()
                                 if not isinstance(col, list)}}
            p, a = scales(merged)
            pf.append(p)
            acc.append(a)
            harmonic.append(int(merged.get("excitation.kind", 0)) == KINDS["harmonic"])
            freq.append(float(merged.get("excitation.frequency", 1.0)))
        pf, acc, harmonic, freq = (np.array(x)[inv] for x in (pf, acc, harmonic, freq))
        if "w" in values:
            freq = values["w"] * pf / (2 * math.pi)
            over["excitation.frequency"] = freq
        if "a" in values:
            a = values["a"]
            if harmonic.all():  # its peak is D (2 pi f)^2
                over["excitation.displacement"] = a * acc / (2 * math.pi * freq) ** 2
            elif not harmonic.any():
                over["excitation.amplitude"] = a * acc
            else:  # excitation.kind on an axis: each point sets its own kind's parameter
                over["excitation.displacement"] = [float(x) if h else None for x, h in
                                                   zip((a * acc / (2 * math.pi * freq) ** 2).tolist(), harmonic)]
                over["excitation.amplitude"] = [None if h else float(x) for x, h in zip((a * acc).tolist(), harmonic)]

    def as_json(self) -> dict[str, Any]:
        through = {str(r.id): {k: r.measures[k] for k in SUPPORT_MEASURES if k in r.measures}
                   for r in self.records or [] if any(k in r.measures for k in SUPPORT_MEASURES)}
        return {"axes": [[a.name, a.start, a.stop, a.count] + ([True] if a.integer else []) for a in self.axes],
                **({"support_measures": through} if through else {}),
                "records": [r.id for r in self.records] if self.records else None,
                "intensity": None if self.intensity is None else
                [self.intensity.measure, self.intensity.start, self.intensity.stop, self.intensity.count]}
