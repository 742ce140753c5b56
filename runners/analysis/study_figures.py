"""Figures of the studies of runners.engine.study: fragility curves of damage states (one panel per
grid combination) and IDA curves, as matplotlib Figures (shown inline in a notebook) or PNG files.

    from runners.engine import study
    from runners.analysis import study_figures
    sets = study.outcome_sets(factory, sweep_id, "pga")
    study_figures.curves_figure(study.curves(sets, ["block2:overturn", "block2:falloff"]))
    study_figures.plot_ida("ida.png", sets, "slip", block=2)

What a reviewer needs is on the figure itself: each curve with its 95 % band, solid over the
intensities run and dashed where it extrapolates; states reached by the same runs drawn as one
curve that names them all; the runs the model did not answer (runners.engine.study.UNANSWERED)
counted per level in a strip of their own, never mixed into the probability axis; titles built
from the parameters the runs used (runners.engine.describe), not from the scene's name; the
warnings of the fit (runners.engine.study.fit_warnings) in the footer; legends beside the axes,
never over the data. In an IDA a run the model did not answer is a lower bound (an open
triangle, its record's line broken there); a block that overturned or fell off is marked in a
strip above the demand axis, never at an invented demand.

Intensities in g (PGA), m/s (PGV, Arias intensity) or m (PGD); rotations over alpha; slips in m.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from runners.analysis.sweep_map import BROKE_COLOUR
from runners.engine import describe
from runners.engine.intensity import G0
from runners.engine.study import (IDA_UNANSWERED, UNANSWERED, Curve, DamageState, Outcomes, StudyError,
                                  by_combination, check_block, check_demand, check_unanswered, curves, fit_warnings,
                                  ida_median, ida_panels, state_notes)

MAX_PANELS = 12  # grid combinations one figure draws (more: select some)
CURVE_COLOURS = ["#08519c", "#cb181d", "#6a51a3", "#d94801", "#525252", "#8c510a"]
CURVE_MARKERS = ["o", "s", "^", "v", "D", "P"]
WARNING_COLOUR = "#a50f15"
SLIP_FLOOR = 1e-4  # m: an IDA's log axis of slips starts here; smaller peaks (no slip) sit on it


def _save(fig, out: str | Path) -> Path:
    from runners.analysis.plotting import save_png

    return save_png(fig, out, dpi=120)


def plot_fragility(out: str | Path, oc: Outcomes, unanswered: str = "omit") -> Path:
    """fragility_figure written to `out` (PNG)."""
    return _save(fragility_figure(oc, unanswered), out)


def plot_ida(out: str | Path, oc: Outcomes | list[Outcomes], demand: str = "rotation",
             block: int | str | None = None, unanswered: str = "omit") -> Path:
    """ida_figure written to `out` (PNG)."""
    return _save(ida_figure(oc, demand, block, unanswered), out)


def plot_curves(out: str | Path, cs: list[Curve]) -> Path:
    """curves_figure written to `out` (PNG)."""
    return _save(curves_figure(cs), out)


def _uplift_label(oc: Outcomes) -> str | None:
    thr = oc.uplift_threshold()
    if thr is None:
        return None
    if oc.sliding and oc.two:
        return f"no motion from rest below {thr:.3g} g (the stack's uplift, mu g of both contacts)"
    if oc.sliding:
        return f"no motion from rest below min(mu, tan alpha) g = {thr:.3g} g (Shenton 1996)"
    return f"static uplift threshold {thr:.3g} g (g tan alpha, model g {oc.params['g']:g} m/s2, over g0 = {G0})"


def _title_lines(oc: Outcomes, demand_of: str) -> list[str]:
    """A panel's title: what is drawn, of which runs, and the parameters the runs used."""
    at = f" at {oc.combination_text()}" if oc.combination else ""
    head = f"sweep {oc.sweep_id}{at}: {demand_of}, {oc.records_text()}, {len(oc.x)} runs"
    return [head, *describe.describe(oc.params, (), oc.fixed, with_excitation=False)]


def _same_runs(cs: list[Curve]) -> list[list[Curve]]:
    """The curves grouped where they fit the same runs counted the same way: one line each."""
    groups: list[list[Curve]] = []
    for c in cs:
        for g in groups:
            if np.array_equal(g[0].used, c.used) and np.array_equal(g[0].counted[c.used], c.counted[c.used]):
                g.append(c)
                break
        else:
            groups.append([c])
    return groups


def _levels(oc: Outcomes, mask: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The bins of `oc` (Outcomes.bins) restricted to the runs of `mask`: (index groups, median
    intensity of each, runs in each)."""
    groups = [g[mask[g]] for g in oc.bins()]
    groups = [g for g in groups if g.size]
    return groups, np.array([np.median(oc.x[g]) for g in groups]), np.array([g.size for g in groups])


def _draw_fit(ax, c: Curve, grid: np.ndarray, colour: str, band_alpha: float, lw: float = 2.0) -> bool:
    """Curve `c`'s fit and 95 % band on `ax`: solid over the intensities of the runs in its fit,
    dashed beyond (an extrapolation), `lw` wide. Whether any of it was dashed."""
    f = c.fragility
    x = c.outcomes.x[c.used]
    inside = (grid >= x.min()) & (grid <= x.max())
    lo, hi = f.band(grid)
    ax.fill_between(grid, lo, hi, color=colour, alpha=band_alpha, lw=0)
    p = f.probability(grid)
    ax.plot(np.where(inside, grid, np.nan), p, color=colour, lw=lw)
    ax.plot(np.where(inside, np.nan, grid), p, color=colour, lw=0.8 * lw, ls="--")
    return bool((~inside).any())


def _panel(ax, strip, cs: list[Curve]) -> None:
    """One combination's damage states: per state (states fitted on the same runs alike drawn
    once) the fraction of its fitted runs that reached it per level (marker area ~ runs), its
    fitted curve (dashed where extrapolated) and 95 % band; one state alone also gets the median
    with its interval. In `strip` (None: every run answered), the runs the model did not answer,
    per level. For PGA the uplift threshold."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    oc = cs[0].outcomes
    groups_all, xs_all, _ = _levels(oc, np.ones(len(oc.x), bool))
    grid = np.geomspace(max(float(oc.x.min()) * 0.5, 1e-6), float(oc.x.max()) * 1.3, 400)
    lines = _same_runs(cs)
    single = len(lines) == 1
    handles = []
    extrapolated = False
    for i, same in enumerate(lines):
        c = same[0]
        colour = CURVE_COLOURS[i % len(CURVE_COLOURS)]
        marker = CURVE_MARKERS[i % len(CURVE_MARKERS)]
        groups, xs, n = _levels(oc, c.used)
        k = np.array([int(c.counted[g].sum()) for g in groups])
        f = c.fragility
        # the first curves wider, their markers larger: a curve close to a later one still shows around it
        later = len(lines) - 1 - i
        wide = 1.0 + 0.9 * later
        if f is not None:
            extrapolated |= _draw_fit(ax, c, grid, colour, 0.25 if single else 0.12, 2.0 * wide)
        if n.size:  # (none where the model answered no run)
            ax.scatter(xs, k / n, s=(12 + 60 * n / max(n.max(), 1)) * (1 + 0.2 * later) ** 2, color=colour, zorder=3,
                       marker=marker, edgecolor="k", lw=0.4)
        names = " = ".join(s.label for s in same)
        same_note = " (the same runs reach each)" if len(same) > 1 else ""
        fitted = (f"median {f.median:.3g} {oc.unit} (95 %: {f.median_interval[0]:.3g} to "
                  f"{f.median_interval[1]:.3g}), beta {f.beta:.2f}" if f is not None else "no fit")
        handles.append(Line2D([], [], color=colour, marker=marker, markeredgecolor="k", markeredgewidth=0.4,
                              lw=2 * wide if f is not None else 0, label=textwrap.fill(f"{names}{same_note}: {fitted}", 60)))
        if single and f is not None:
            ax.axvline(f.median, color=colour, lw=0.8, ls=":")
            ax.axvspan(*f.median_interval, color=colour, alpha=0.06)
    per = "fractions: the runs of each level in the fit that reached the state (marker area ~ runs)"
    handles.append(Line2D([], [], ls="", marker="o", color="0.6", label=textwrap.fill(per, 60)))
    if any(c.fragility is not None for c in cs):
        handles.append(Patch(color=CURVE_COLOURS[0], alpha=0.25 if single else 0.12,
                             label="95 % band of the fit" if single else "95 % band of each fit"))
    if extrapolated:
        handles.append(Line2D([], [], color="0.3", ls="--", lw=1.6,
                              label="dashed: beyond the intensities run (extrapolated)"))
    thr = _uplift_label(oc)
    if thr is not None:
        for a in (ax, strip):
            if a is not None:
                a.axvline(oc.uplift_threshold(), color="#238b45", lw=1.2, ls=":")
        handles.append(Line2D([], [], color="#238b45", lw=1.2, ls=":", label=textwrap.fill(thr, 60)))
    ax.set_ylabel("P(overturn)" if len(cs) == 1 and cs[0].state == DamageState("overturn") else
                  "P(damage state reached)")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(0, grid.max())
    if strip is not None:
        b = np.array([int(oc.broke[g].sum()) for g in groups_all])
        n_all = np.array([g.size for g in groups_all])
        width = 0.6 * float(np.min(np.diff(xs_all))) if xs_all.size > 1 else 0.05 * grid.max()
        strip.bar(xs_all, b, width=width, color=BROKE_COLOUR, edgecolor="k", lw=0.4)
        strip.set_ylim(0, min(max(1.25 * int(b.max()), 1), 1.05 * int(n_all.max())))
        strip.set_xlim(ax.get_xlim())
        per = f"{int(n_all.min())}" if n_all.min() == n_all.max() else f"{int(n_all.min())}-{int(n_all.max())}"
        strip.set_ylabel(f"runs\n(of {per})", fontsize=7)
        strip.yaxis.set_major_locator(MaxNLocator(integer=True, nbins=3))
        treatment = {c.unanswered for c in cs}.pop() if len({c.unanswered for c in cs}) == 1 else "omit"
        handles.append(Patch(facecolor=BROKE_COLOUR, edgecolor="k", lw=0.4, label=textwrap.fill(
            f"lower strip: runs per level whose model broke first ({oc.n_broke} of {len(oc.x)}: "
            f"{oc.unanswered_words()}); those that had not reached a state before it are "
            + ("left out of its fit" if treatment == "omit" else
               f"{UNANSWERED[treatment].replace('the state', 'it')} in its fit (--unanswered)"), 60)))
        strip.set_xlabel(f"{oc.label} ({oc.unit})")
        ax.tick_params(labelbottom=False)
    else:
        ax.set_xlabel(f"{oc.label} ({oc.unit})")
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)


def _panel_axes(fig, n: int, strips: bool, width: float, height: float):
    """(main axes, strip axes or None) of n panels, at most three a row, each a strip below it."""
    if n > MAX_PANELS:
        raise StudyError(f"{n} grid combinations are more than one figure draws ({MAX_PANELS}): select some "
                         "(--select NAME=VALUE)")
    cols = 1 if n == 1 else min(3, n)
    rows = -(-n // cols)
    fig.set_size_inches(width * cols, height * rows)
    gs = fig.add_gridspec(rows * (2 if strips else 1), cols, height_ratios=[4, 1] * rows if strips else None)
    out = []
    for k in range(n):
        r, c = divmod(k, cols)
        main = fig.add_subplot(gs[2 * r if strips else r, c])
        strip = fig.add_subplot(gs[2 * r + 1, c], sharex=main) if strips else None
        out.append((main, strip))
    return out


FOOT_LINE = 0.125  # in: the height of a footer line at its font size (6.5 pt, spaced)


def _footer(fig, lines: list[tuple[str, str]]) -> None:
    """Notes (grey) and warnings (red) at the foot of `fig`, wrapped to its width, in a band the
    figure's (constrained) layout keeps clear of the axes."""
    width, height = fig.get_size_inches()
    chars = max(int(width * 15), 60)  # characters a line of 6.5 pt holds
    y = 0.06 / height
    for text, colour in reversed(lines):
        wrapped = textwrap.wrap(text, chars)
        fig.text(0.01, y, "\n".join(wrapped), fontsize=6.5, color=colour, va="bottom")
        y += FOOT_LINE * len(wrapped) / height
    fig.get_layout_engine().set(rect=(0, min(y + 0.01, 0.5), 1, 1 - min(y + 0.01, 0.5)))


def curves_figure(cs: list[Curve]):
    """A matplotlib Figure of damage-state fragility curves (runners.engine.study.curves): one
    panel per grid combination, each damage state (or states reached by the same runs) in its
    own colour with its 95 % band, the runs the model did not answer counted per level in a strip
    below, titles from the parameters the runs used, warnings and notes in the footer."""
    import matplotlib.pyplot as plt

    groups = by_combination(cs)
    oc0 = groups[0][0].outcomes
    single = len(groups) == 1
    strips = any(g[0].outcomes.n_broke for g in groups)
    fig = plt.figure(layout="constrained")
    panels = _panel_axes(fig, len(groups), strips, 11.5 if single else 9.5, 6.2 if single else 5.4)
    for (ax, strip), group in zip(panels, groups):
        oc = group[0].outcomes
        _panel(ax, strip if oc.n_broke else None, group)
        if strip is not None and not oc.n_broke:
            strip.set_visible(False)
            ax.tick_params(labelbottom=True)
            ax.set_xlabel(f"{oc.label} ({oc.unit})")
        ax.set_title("\n".join(textwrap.fill(t, 95 if single else 70) for t in _title_lines(oc, "fragility")),
                     fontsize=8.5 if single else 7.5, loc="left")
    if not single:
        fig.suptitle(f"sweep {oc0.sweep_id}: one panel per value of {', '.join(oc0.combination)} (never pooled)",
                     fontsize=10)
    foot: list[tuple[str, str]] = []
    for c in cs:
        at = f" ({c.outcomes.combination_text()})" if c.outcomes.combination else ""
        foot += [(f"warning, {c.state.spec}{at}: {w}", WARNING_COLOUR) for w in fit_warnings(c)]
        if c.fragility is None:
            foot.append((f"no fit, {c.state.spec}{at}: {c.why}", WARNING_COLOUR))
    methods = list(dict.fromkeys(c.fragility.interval_method for c in cs if c.fragility is not None))
    if methods:
        foot += [("curves: lognormal, maximum likelihood (Baker 2015); intervals: " + "; ".join(methods), "0.35")]
    if any(state_notes(c.state, c.outcomes) for c in cs):
        foot.append(("block 1 states: where block 2 overturned or fell off first the run ended there "
                     "(docs/two_blocks.md, docs/stack_sliding.md), so they count block 1 reaching the state before "
                     "that", "0.35"))
    foot.append((f"scene file's name: {oc0.scene!r} (the titles give the parameters the runs used)", "0.35"))
    _footer(fig, foot)
    return fig


def fragility_figure(oc: Outcomes, unanswered: str = "omit"):
    """curves_figure of overturning (either block) alone: the fractions overturned per level, the
    fit with its 95 % band and the median with its interval, the runs the model did not answer
    (`unanswered`: left out by default, UNANSWERED); for PGA the static uplift threshold. Without
    a fit (the outcomes do not determine one) the fractions alone, and why in the footer."""
    return curves_figure(curves(oc, ["overturn"], unanswered))


def ida_figure(oc: Outcomes | list[Outcomes], demand: str = "rotation", block: int | str | None = None,
               unanswered: str = "omit"):
    """A matplotlib Figure: the demand against intensity, one line per record (named beside the
    axes up to 12 records; the record with the largest demand named on the axes always), broken
    where the model did not answer a run (its peak up to the break drawn as a lower bound, an open
    triangle) and where the block is gone (overturned: a cross, block 2 fell off: a triangle, in
    a strip above the demand axis); the median over records in black, with the unanswered runs
    treated as `unanswered` says (ida_median). `demand` rotation: peak |theta| / alpha; slip:
    peak |slip| (m, on a log axis) of rocking–sliding runs (block 2's along block 1's top). One
    row per block of a stack (`block` 1 or 2: that block's only). For several grid combinations
    (a list of Outcomes, outcome_sets) one column each."""
    import matplotlib.pyplot as plt

    sets = [oc] if isinstance(oc, Outcomes) else list(oc)
    check_demand(demand, sets, block)
    block = check_block(block, sets)
    unanswered = check_unanswered(unanswered)
    if len(sets) > MAX_PANELS // 2:
        raise StudyError(f"{len(sets)} grid combinations are more than one figure draws ({MAX_PANELS // 2}): select "
                         "some (--select NAME=VALUE)")
    rows = max(len(ida_panels(o, demand, block)) for o in sets)
    fig = plt.figure(figsize=(12.5 if len(sets) == 1 else 9 * len(sets), 5.6 * rows + 0.8), layout="constrained")
    gs = fig.add_gridspec(2 * rows, len(sets), height_ratios=[1, 5] * rows)
    for col, o in enumerate(sets):
        pairs = [(fig.add_subplot(gs[2 * r, col]), fig.add_subplot(gs[2 * r + 1, col])) for r in range(rows)]
        for top, main in pairs:
            top.sharex(main)
        _ida_column(pairs, o, demand, block, unanswered)
        for top, main in pairs[len(ida_panels(o, demand, block)):]:  # (a one-block combination among stacks)
            top.set_visible(False)
            main.set_visible(False)
        title = _title_lines(o, "IDA, one line per record")
        pairs[0][0].set_title("\n".join(textwrap.fill(t, 95 if len(sets) == 1 else 70) for t in title),
                              fontsize=8.5 if len(sets) == 1 else 7.5, loc="left")
    _footer(fig, [(f"scene file's name: {sets[0].scene!r} (the titles give the parameters the runs used)",
                   "0.35")])
    return fig


def _ida_column(pairs, oc: Outcomes, demand: str, block: int | None, unanswered: str) -> None:
    """One combination's IDA: per block (top strip, main axes) of `pairs`."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    names = list(dict.fromkeys(oc.record))
    cmap = plt.get_cmap("tab20", max(len(names), 1))
    record = np.array(oc.record)
    for (top, ax), (i, peak, gone, answered) in zip(pairs, ida_panels(oc, demand, block)):
        fell = None if i != 2 or oc.fell_off is None else np.asarray(oc.fell_off, bool) & ~np.asarray(oc.over2, bool)
        over = gone if fell is None else gone & ~fell
        shown = np.maximum(peak, SLIP_FLOOR) if demand == "slip" else peak
        for k, name in enumerate(names):
            sel = np.flatnonzero(record == name)
            sel = sel[np.argsort(oc.x[sel])]
            xs, ys = oc.x[sel], shown[sel]
            standing = ~gone[sel] & answered[sel]
            ax.plot(xs, np.where(standing, ys, np.nan), lw=0.8, color=cmap(k), alpha=0.85, marker=".", ms=3)
            lower = ~gone[sel] & ~answered[sel]
            ax.scatter(xs[lower], ys[lower], marker="^", s=34, facecolors="none", edgecolors=BROKE_COLOUR, lw=1.1,
                       zorder=4)
            top.scatter(xs[over[sel]], np.ones(int(over[sel].sum())), marker="x", s=22, color=cmap(k), lw=1.1)
            if fell is not None:
                top.scatter(xs[fell[sel]], np.zeros(int(fell[sel].sum())), marker="v", s=22, color=cmap(k))
        levels, med, left = ida_median(oc, peak, gone, answered, unanswered)
        finite = np.isfinite(med)
        ax.plot(levels, np.where(finite, np.maximum(med, SLIP_FLOOR) if demand == "slip" else med, np.nan), color="k",
                lw=2.4, zorder=5)
        standing = ~gone & answered
        if standing.any() and peak[standing].max() > (SLIP_FLOOR if demand == "slip" else 0.0):
            # name the record with the largest demand: it sets the axis
            j = int(np.flatnonzero(standing)[np.argmax(shown[standing])])
            right = oc.x[j] > 0.5 * (oc.x.min() + oc.x.max())
            ax.annotate(f"largest: record {oc.record[j]}", (oc.x[j], shown[j]), xytext=(-6 if right else 6, -10),
                        textcoords="offset points", fontsize=7, color="0.2", ha="right" if right else "left",
                        arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.6})
        where = ("" if not (oc.two or oc.column is not None) or i == 0 else " on the ground" if i == 1 else
                 f" on block {i - 1}")
        who = "any standing block" if i == 0 else f"block {i}"
        if demand == "slip":
            ax.set_yscale("log")
            ax.set_ylabel(f"peak |slip| of {who}{where} (m, log axis;\nat {SLIP_FLOOR:g} m: no slip or less)")
        else:
            ax.axhline(1.0, color="0.5", lw=0.8, ls=":")
            ax.set_ylim(bottom=0)
            ax.set_ylabel(f"peak |theta| / alpha of {who}")
        top.set_ylim(-0.6, 1.6)
        top.set_yticks([1, 0] if fell is not None else [1],
                       ["overturned", "fell off"] if fell is not None else ["overturned"], fontsize=7)
        top.tick_params(labelbottom=False)
        top.set_title(("collapse (any block)" if i == 0 else f"block {i}") if oc.column is not None else
                      f"block {i}" if oc.two else "", fontsize=8, loc="right")
        ax.set_xlabel(f"{oc.label} ({oc.unit})")
        handles = [Line2D([], [], color=cmap(k), lw=0.8, marker=".", label=n) for k, n in enumerate(names)] \
            if len(names) <= 12 else [Line2D([], [], color="0.5", lw=0.8, label=f"{len(names)} records, one line each")]
        infinite = levels[np.isinf(med)]
        beyond = (f" (infinite from {infinite.min():.3g} {oc.unit}: more than half gone)"
                  if infinite.size else "")
        treated = (f"; the runs the model did not answer {IDA_UNANSWERED[unanswered].replace(' demand', '')}"
                   if oc.n_broke else "")
        handles += [Line2D([], [], color="k", lw=2.4, label=textwrap.fill(
                        f"median over records (gone: infinite){beyond}{treated}", 55)),
                    Line2D([], [], ls="", marker="x", color="0.3", label="overturned (upper strip)")]
        if fell is not None:
            handles.append(Line2D([], [], ls="", marker="v", color="0.3", label="fell off block 1 (upper strip)"))
        if oc.n_broke:
            handles.append(Line2D([], [], ls="", marker="^", markerfacecolor="none", markeredgecolor=BROKE_COLOUR,
                                  label=textwrap.fill(f"the model did not answer ({oc.unanswered_words()}): the "
                                                      f"peak up to the break, a lower bound ({int(left.sum())} runs "
                                                      "left out of the median)" if unanswered == "omit" else
                                                      f"the model did not answer ({oc.unanswered_words()}): the "
                                                      "peak up to the break, a lower bound", 55)))
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
