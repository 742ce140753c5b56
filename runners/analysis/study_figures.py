"""Figures of the studies of runners.engine.study: fragility curves of damage states (one panel per
grid combination) and IDA curves, as matplotlib Figures (shown inline in a notebook) or PNG files.

    from runners.engine import study
    from runners.analysis import study_figures
    sets = study.outcome_sets(factory, sweep_id, "pga")
    study_figures.curves_figure(study.curves(sets, ["block2:overturn", "block2:falloff"]))
    study_figures.plot_ida("ida.png", sets, "slip", block=2)

Intensities in g (PGA), m/s (PGV, Arias intensity) or m (PGD); rotations over alpha; slips in m.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from runners.analysis.sweep_map import BROKE_COLOUR
from runners.engine.fragility import Fragility
from runners.engine.intensity import G0
from runners.engine.study import (Curve, DamageState, Outcomes, StudyError, by_combination, check_block,
                                  check_demand, ida_panels, state_notes)


def _save(fig, out: str | Path) -> Path:
    import matplotlib.pyplot as plt

    out = Path(out)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_fragility(out: str | Path, frag: Fragility | None, oc: Outcomes) -> Path:
    """fragility_figure written to `out` (PNG)."""
    return _save(fragility_figure(frag, oc), out)


def plot_ida(out: str | Path, oc: Outcomes | list[Outcomes], demand: str = "rotation",
             block: int | str | None = None) -> Path:
    """ida_figure written to `out` (PNG)."""
    return _save(ida_figure(oc, demand, block), out)


MAX_PANELS = 12  # grid combinations one figure draws (more: select some)
CURVE_COLOURS = ["#08519c", "#cb181d", "#6a51a3", "#d94801", "#525252", "#8c510a"]
CURVE_MARKERS = ["o", "s", "^", "v", "D", "P"]


def _uplift_label(oc: Outcomes) -> str | None:
    thr = oc.uplift_threshold()
    if thr is None:
        return None
    if oc.sliding and oc.two:
        return f"no motion from rest below the stack's uplift and mu g of both contacts = {thr:.4g} g"
    if oc.sliding:
        return f"no motion from rest below min(mu, tan alpha) g = {thr:.4g} g (Shenton 1996)"
    return (f"static uplift threshold {thr:.4g} g (= {thr * G0:.3g} m/s2 with the model's g = {oc.params['g']:g} "
            f"m/s2, over g0 = {G0})")


def _panel(ax, cs: list[Curve]) -> None:
    """One combination's damage states on `ax`: per state the fraction of runs that reached it per
    level (marker area ~ runs) and, with a fit, its curve and 95 % band; one state alone also gets
    the median with its interval. Runs where rigid rocking broke first, and for PGA the uplift
    threshold, are marked."""
    oc = cs[0].outcomes
    groups = oc.bins()
    xs = np.array([np.median(oc.x[g]) for g in groups])
    n = np.array([g.size for g in groups])
    grid = np.geomspace(max(xs.min() * 0.5, 1e-6), xs.max() * 1.3, 400)
    single = len(cs) == 1
    per_level = f"{int(n.min())}" if n.min() == n.max() else f"{int(n.min())}-{int(n.max())}"
    from matplotlib.lines import Line2D

    states = []  # one legend entry per damage state (its curve and its markers), several states
    for i, c in enumerate(cs):
        colour = CURVE_COLOURS[i % len(CURVE_COLOURS)]
        marker = CURVE_MARKERS[i % len(CURVE_MARKERS)]
        k = np.array([int(c.reached[g].sum()) for g in groups])
        f = c.fragility
        if f is not None:
            if single:  # several states' bands would hide each other
                lo, hi = f.band(grid)
                ax.fill_between(grid, lo, hi, color="#9ecae1", alpha=0.5, lw=0, label="95 % band")
            ax.plot(grid, f.probability(grid), color=colour, lw=2,
                    label=f"fit: median {f.median:.3g} {oc.unit}, beta {f.beta:.2f} (Baker 2015)" if single else None)
        what = "overturned" if c.state == DamageState("overturn") else f"where {c.label}"
        ax.scatter(xs, k / n, s=12 + 60 * n / n.max(), color="#cb181d" if single else colour, zorder=3,
                   marker=marker, edgecolor="k", lw=0.4,
                   label=f"fraction {what} ({per_level} runs per level)" if single else None)
        fitted = f"median {f.median:.3g} {oc.unit}, beta {f.beta:.2f}" if f is not None else "no fit"
        states.append(Line2D([], [], color=colour, marker=marker, markeredgecolor="k", markeredgewidth=0.4,
                             lw=2 if f is not None else 0, label=f"{c.label}: {fitted}"))
        if single and f is not None:
            ax.axvline(f.median, color=colour, lw=0.8, ls="--")
            ax.axvspan(*f.median_interval, color=colour, alpha=0.08,
                       label=f"median 95 %: {f.median_interval[0]:.3g}-{f.median_interval[1]:.3g} {oc.unit}")
    if oc.n_broke:
        b = np.array([int(oc.broke[g].sum()) for g in groups])
        ax.scatter(xs[b > 0], (b / n)[b > 0], s=30, marker="D", color=BROKE_COLOUR, zorder=4, edgecolor="k", lw=0.4,
                   label=f"fraction where {oc.broke_words()} ({oc.n_broke} of {len(oc.x)} runs)")
    thr = _uplift_label(oc)
    if thr is not None:
        ax.axvline(oc.uplift_threshold(), color="#238b45", lw=1.2, ls=":", label=thr)
    ax.set_xlabel(f"{oc.label} ({oc.unit})")
    what = f"P({'overturn' if cs[0].state == DamageState('overturn') else 'damage state'})" if single \
        else "P(damage state reached)"
    ax.set_ylabel(what + (f";\nfraction where {oc.broke_words()}" if oc.n_broke else ""))
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(0, grid.max())
    handles, labels = ax.get_legend_handles_labels()
    if not single:
        handles, labels = states + handles, [h.get_label() for h in states] + labels
    ax.legend(handles, labels, fontsize=8 if single else 7, loc="best")



def _grid_of_axes(n: int, width: float, height: float):
    import matplotlib.pyplot as plt

    if n > MAX_PANELS:
        raise StudyError(f"{n} grid combinations are more than one figure draws ({MAX_PANELS}): select some "
                         "(--select NAME=VALUE)")
    cols = 1 if n == 1 else min(3, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes


def curves_figure(cs: list[Curve]):
    """A matplotlib Figure of damage-state fragility curves (curves()): one panel per grid
    combination, each damage state's fractions and fitted curve in its own colour; the title of
    each panel names its combination and block(s)."""
    import textwrap

    groups = by_combination(cs)
    oc0 = groups[0][0].outcomes
    single = len(groups) == 1
    fig, axes = _grid_of_axes(len(groups), 8 if single else 6.2, 5.5 if single else 4.8)
    for ax, group in zip(axes.flat, groups):
        _panel(ax, group)
        oc = group[0].outcomes
        head = f"sweep {oc.sweep_id}: {oc.scene}\n" if single else ""
        at = f"{oc.combination_text()}: " if oc.combination else ""
        reached = (f", {int(oc.overturned.sum())} overturned" if len(group) == 1 and group[0].state.kind == "overturn"
                   and group[0].state.block == "either" else "")
        ax.set_title(head + textwrap.fill(
            f"{at}{oc.block_text()}; {oc.records_text()}, {len(oc.x)} runs{reached}"
            + (f", {oc.n_broke} where {oc.broke_words()}" if oc.n_broke else ""), 105 if single else 80),
            fontsize=9 if single else 8)
    if not single:
        fig.suptitle(f"sweep {oc0.sweep_id}: {oc0.scene}; one panel per value of "
                     f"{', '.join(oc0.combination)} (never pooled)", fontsize=10)
    methods = list(dict.fromkeys(c.fragility.interval_method for c in cs if c.fragility is not None))
    several = any(len(g) > 1 for g in groups)
    foot = (["markers: the fraction of each level's runs that reached the state; curves: lognormal, maximum "
             "likelihood (Baker 2015)"] if several else []) + [f"intervals: {m}" for m in methods]
    cut = [c.outcomes for c in cs if state_notes(c.state, c.outcomes)]
    if cut:
        foot.append("block 1 states: where block 2 overturned or fell off first the run ended there (docs/two_blocks.md, "
                    "docs/stack_sliding.md), so they count block 1 reaching the state before that")
    foot += [f"no fit ({c.state.spec}" + (f", {c.outcomes.combination_text()}" if c.outcomes.combination else "")
             + f"): {c.why}" for c in cs if c.fragility is None]
    text = "\n".join(line for f in foot for line in textwrap.wrap(f, 150)) or ""
    fig.text(0.01, 0.005, text, fontsize=6.5, color="0.35")
    fig.tight_layout(rect=(0, 0.012 * (text.count("\n") + 2), 1, 1))
    return fig


def fragility_figure(frag: Fragility | None, oc: Outcomes):
    """A matplotlib Figure: the fraction overturned per level (marker area ~ runs), and, with a
    fit, the curve, its 95 % band, the median with its interval; for PGA the static uplift
    threshold. Without a fit (frag None: the outcomes could not give one), the fractions alone."""
    state = DamageState("overturn")
    why = None if frag is not None else "the outcomes do not determine one"
    return curves_figure([Curve(oc, state, state.reached(oc), frag, why)])


def plot_curves(out: str | Path, cs: list[Curve]) -> Path:
    """curves_figure written to `out` (PNG)."""
    return _save(curves_figure(cs), out)


def ida_figure(oc: Outcomes | list[Outcomes], demand: str = "rotation", block: int | str | None = None):
    """A matplotlib Figure: the demand against intensity, one line per record (named in a legend up
    to 12 records), each block's own overturns (and block 2's falls off block 1) marked at the top;
    the median over records (the block's gone runs counted as infinite) in black. `demand`
    rotation: peak |theta| / alpha; slip: peak |slip| (m) of rocking–sliding runs (block 2's along
    block 1's top). One row per block of a stack (`block` 1 or 2: that block's only). For several
    grid combinations (a list of Outcomes, outcome_sets) one column each."""
    import textwrap

    import matplotlib.pyplot as plt

    sets = [oc] if isinstance(oc, Outcomes) else list(oc)
    check_demand(demand, sets, block)
    block = check_block(block, sets)
    if len(sets) > MAX_PANELS // 2:
        raise StudyError(f"{len(sets)} grid combinations are more than one figure draws ({MAX_PANELS // 2}): select "
                         "some (--select NAME=VALUE)")
    rows = len(ida_panels(sets[0], demand, block))
    fig, axes = plt.subplots(rows, len(sets), figsize=(8 if len(sets) == 1 else 6.2 * len(sets), 4.8 * rows),
                             sharex="col", squeeze=False)
    for col, o in enumerate(sets):
        _ida_column(axes[:, col], o, demand, block)
        at = f"{o.combination_text()}: " if o.combination else ""
        axes[0, col].set_title(f"IDA, sweep {o.sweep_id}: {o.scene}\n" + textwrap.fill(
            f"{at}{o.block_text()}; {o.records_text()}, one line each", 100 if len(sets) == 1 else 80),
            fontsize=9 if len(sets) == 1 else 8)
    fig.tight_layout()
    return fig


def _ida_column(axes, oc: Outcomes, demand: str = "rotation", block: int | None = None) -> None:
    names = list(dict.fromkeys(oc.record))
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("tab20", max(len(names), 1))
    for ax, (i, peak, over) in zip(axes, ida_panels(oc, demand, block)):
        title = f"block {i}"
        top = 1.08
        if demand == "slip":  # gone runs at the top, above every standing run's slip
            standing = peak[~over]
            top = 1.08 * (float(standing.max()) if standing.size and standing.max() > 0 else 0.01)
        groups = oc.bins()
        levels = np.array([np.median(oc.x[g]) for g in groups])
        med = [np.median(np.where(over[g], np.inf, peak[g])) for g in groups]
        for k, name in enumerate(names):
            sel = np.array([r == name for r in oc.record])
            order = np.argsort(oc.x[sel])
            xs, ys, fell = oc.x[sel][order], peak[sel][order], over[sel][order]
            ys = np.where(fell, top, np.minimum(ys, top))
            ax.plot(xs, ys, lw=0.8, color=cmap(k), alpha=0.8, label=name if len(names) <= 12 else None)
            ax.scatter(xs[fell], ys[fell], marker="x", s=18, color=cmap(k), lw=1)
            if oc.n_broke:
                broke = oc.broke[sel][order]
                ax.scatter(xs[broke], ys[broke], marker="o", s=40, facecolors="none", edgecolors=BROKE_COLOUR,
                           lw=1.2, label=oc.broke_words() if k == 0 else None)
        med = np.minimum(np.array(med), top)
        ax.plot(levels, med, color="k", lw=2.2, label="median over records")
        if demand == "rotation":
            ax.axhline(1.0, color="0.5", lw=0.8, ls=":")
        gone = "overturned or fell off" if i == 2 and oc.fell_off is not None else "overturned"
        ax.text(levels.min(), top, f" x {title + ' ' if oc.two else ''}{gone}", va="bottom", fontsize=8,
                color="0.3")
        ax.set_ylim(0, top * (1 + 0.07 / 1.08))
        where = "" if not oc.two else " on the ground" if i == 1 else " on block 1"
        ax.set_ylabel(f"peak |theta| / alpha, {title}" if demand == "rotation" else
                      f"peak |slip| of {title}{where} (m), rocking–sliding")
        ax.legend(fontsize=7 if len(names) <= 12 else 8, loc="center right")
    axes[-1].set_xlabel(f"{oc.label} ({oc.unit})")
