"""``runners map SWEEP_ID --out map.png``: the overturning map of a stored sweep.

Each grid point is safe (rocks and settles, or never lifts), overturns after
one or more impacts, or overturns without impact (Anagnostopoulos Fig. 18's three
regions), or failed. Points whose contacts slid or lifted off before the outcome was
decided (docs/contact.md) are marked on top in their own colour and counted: rigid
rocking's outcome is drawn there, but it does not answer for the block. A (w, a) grid is drawn in the dimensionless groups of
Dimitrakopoulos & DeJong (2012): omega_g/p and the amplitude over the uplift
acceleration, a_g / (g tan alpha) for one block (1 = uplift; their a_g/(g alpha)
is its slender-block limit). A one-block grid under a one-sine pulse gets their
closed-form boundaries of the linearised block overlaid (their a converted by
alpha / tan(alpha)). Every overturning map in runners (this one and the closed-form
map of runners bench --charts, runners.analysis.overturning_map) uses this
normalisation and names the block (half-width b, half-height h, p) and its
restitution in the title.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
from sqlalchemy import select

from db.schema import Run, RunSummary, Sweep
from model import closed_form as cf
from runners.engine.scene import restitution
from runners.engine.summary import outcome_held
from runners.engine.sweep_runs import (broke, fixed_axes, load, rigid_rocking_held,  # noqa: F401 (the maps')
                                       sweep_and_scene, sweep_parameters)
from runners.engine.sweep import Axis, scales

# the axes of every overturning map (Dimitrakopoulos & DeJong 2012's dimensionless groups)
FREQUENCY = "omega_g / p (pulse over block frequency)"
AMPLITUDE = "a_g / (g tan alpha)   (1 = uplift)"
# the foot of a map with that axis: how it relates to the closed forms' amplitude
AMPLITUDE_NOTE = ("a_g / (g tan alpha) tends to Dimitrakopoulos & DeJong (2012)'s a_g / (g alpha) for a slender block; "
                  "their closed-form curves are converted by alpha / tan(alpha)")

REGIONS = ["safe", "overturns after impact(s)", "overturns without impact", "failed"]
COLOURS = ["#b8e0b0", "#f6c9c9", "#c9d7f3", "#888888"]
BROKE_COLOUR = "#e07000"  # points where rigid rocking broke first, in every map and study figure
BROKE_LABEL = "rigid rocking broke first: a contact slid or lifted off before the outcome was decided"
DOTS_UP_TO = 20_000  # points of a map up to which those points are dots; above, hatching


def region(run: Run) -> int:
    """The outcome of a point (REGIONS index), as rigid rocking gives it."""
    if run.status != "ok" or run.summary is None:
        return 3
    if not run.summary.overturned:
        return 0
    return 1 if (run.summary.impacts or 0) > 0 else 2


MAP_ROWS = 200_000  # stored points read at a time by map_columns


def map_columns(factory, sw: Sweep) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(grid indices, REGIONS index, rigid rocking broke first) of every stored point of sweep
    `sw`, read in columns MAP_ROWS points at a time (a map of 10^6 points needs neither the
    runs as objects nor their JSON points: the grid gives each index's values)."""
    cols = (Run.grid_index, Run.status, RunSummary.run_id, RunSummary.overturned, RunSummary.impacts,
            RunSummary.assumptions_held, RunSummary.motion, RunSummary.slide_time, RunSummary.lift_time,
            RunSummary.fall_time)
    stmt = select(*cols).outerjoin(RunSummary, RunSummary.run_id == Run.id).where(Run.sweep_id == sw.id)
    index, regions, broken = [], [], []
    with factory() as session:
        for part in session.connection().execution_options(yield_per=MAP_ROWS).execute(stmt).partitions():
            gi, status, sid, over, impacts, held, motion, slide, lift, fall = zip(*part)
            ok = np.array([st == "ok" and k is not None for st, k in zip(status, sid)])
            overturned = np.array([bool(o) for o in over])
            hit = np.array([(i or 0) > 0 for i in impacts])
            region_ = np.where(~ok, 3, np.where(~overturned, 0, np.where(hit, 1, 2)))
            doubt = [k for k, h in enumerate(held) if ok[k] and h is not None and not h]
            b = np.zeros(len(part), dtype=bool)
            for k in doubt:  # as rigid_rocking_held, on the columns
                b[k] = not outcome_held(bool(over[k]), None if motion[k] is not None else slide[k], lift[k], fall[k])
            index.append(np.array(gi, dtype=np.int64))
            regions.append(region_)
            broken.append(b)
    if not index:
        return np.zeros(0, np.int64), np.zeros(0, int), np.zeros(0, bool)
    return np.concatenate(index), np.concatenate(regions), np.concatenate(broken)


def closed_form_curves(p: dict, ws: np.ndarray) -> list[tuple[str, np.ndarray]] | None:
    """Dimitrakopoulos & DeJong (2012)'s smallest overturning a and its no-impact boundary, in a_g/(g tan alpha); None if they do not apply."""
    if (int(p.get("nBlocks", 1)) != 1 or int(p["excitation.kind"]) != 1 or p["excitation.cycles"] != 1
            or p.get("excitation.verticalAmplitude", 0.0) != 0):  # theirs is a horizontal pulse
        return None
    alpha = math.atan2(p["block1.halfWidth"], p["block1.halfHeight"])
    eta = restitution(p, alpha)
    to_tan = alpha / math.tan(alpha)
    smallest = [cf.smallest_overturning_a(lambda a, w: cf.overturns(a, w, eta)[0], w) for w in ws]
    no_impact = [cf.smallest_overturning_a(lambda a, w: cf.no_impact_margin(a, w) > 0
                                           and cf.first_impact_in_pulse(cf.groups(a, w)) is None, w, a_max=200.0)
                 for w in ws]
    conv = lambda xs: np.array([x * to_tan if x else np.nan for x in xs])  # noqa: E731
    return [("Dimitrakopoulos & DeJong (2012) closed forms: smallest overturning amplitude", conv(smallest)),
            ("Dimitrakopoulos & DeJong (2012) closed forms: overturning without impact above", conv(no_impact))]


LAW_NAMES = {0: "Housner (1963)", 1: "modified", 2: "constant"}


def amplitude_label(p: dict) -> str:
    """The y label of a (w, a) map: a over the uplift acceleration of the scene's block or stack."""
    if int(p.get("nBlocks", 1)) == 2:
        _, uplift = scales(p)
        return f"a_g / a_uplift of the stack   (1 = first uplift)\na_uplift = {uplift / p['g']:.3f} g"
    return AMPLITUDE


def block_title(p: dict) -> str:
    """The block (or stack) and its restitution in one line: half-width b, half-height h (m),
    alpha, p (rad/s, and p / 2 pi in Hz, so that omega_g / p converts to a pulse frequency)."""
    pf, _ = scales(p)
    blocks = [("", 1)] if int(p.get("nBlocks", 1)) != 2 else [("lower ", 1), ("upper ", 2)]
    parts = [f"{w}b = {p[f'block{i}.halfWidth']:g} m, h = {p[f'block{i}.halfHeight']:g} m" for w, i in blocks]
    alpha = math.atan2(p["block1.halfWidth"], p["block1.halfHeight"])
    law = int(p["restitution.law"])
    if law == 2 and int(p.get("nBlocks", 1)) == 2 and "restitution.etaGround" in p:
        rest = f"constant restitution, ground {p['restitution.etaGround']:g}, interface {p['restitution.etaInterface']:g}"
    else:
        rest = f"{LAW_NAMES.get(law, law)} restitution, eta = {restitution(p, alpha):.3f}"
        if law != 2 and p.get("restitution.correction", 1.0) != 1.0:
            rest += f" (x {p['restitution.correction']:g})"
    one = "" if len(blocks) == 1 else " of the lower block"
    return (f"{'; '.join(parts)} (half-width, half-height), alpha = {alpha:.3f} rad, "
            f"p{one} = {pf:.3f} rad/s (p / 2 pi = {pf / (2 * math.pi):.3f} Hz); {rest}")


def map_title(fig, ax, sw: Sweep, scene, p: dict, axes: list[str], what: str, n_points: int) -> None:
    """The title of a map of sweep `sw`: what it shows, the block(s) in the map's terms (half
    sizes, alpha, p, restitution), the contact model and its friction, the excitation (what the
    map's axes do not vary) and any one-value --grid override: the parameters the points ran
    with (`p`: runners.engine.sweep_runs.sweep_parameters), not the scene's name, which goes to
    the foot of the figure. Lays the figure out (tight_layout) below it."""
    from runners.engine import describe

    fixed = {k: v for k, v in fixed_axes(sw.grid).items() if k not in axes}
    lines = [f"sweep {sw.id}: {what} ({n_points} of {sw.total} points)", block_title(p),
             f"{describe.contact(p, axes)}; {describe.excitation(p, axes)}"
             + (f"; set by --grid: {describe.overrides(fixed)}" if fixed else "")]
    ax.set_title("\n".join(textwrap.fill(t, 110) for t in lines), fontsize=8.5)
    foot = f"scene file's name: {scene.name!r} (the title gives the parameters the points ran with)"
    if "a" in axes:
        foot = f"{AMPLITUDE_NOTE}\n{foot}"
    fig.text(0.01, 0.005, foot, fontsize=6.5, color="0.35")
    fig.tight_layout(rect=(0, 0.015 * (foot.count("\n") + 1.5), 1, 1))


def drawn_axes(sw: Sweep) -> list[str]:
    """The --grid axes a map of sweep `sw` draws: those with more than one value (a fixed value,
    such as --grid contact.model=rocking-sliding, is the scene's, not an axis of the map)."""
    axes = sw.grid["axes"]
    return [a[0] for a in axes if a[3] > 1] or [a[0] for a in axes[:1]]


def mappable(factory, sweep_id: str, instead: str, runs: bool = True):
    """(sweep, scene, runs, drawn axes, parameters) of a stored sweep a map can draw (one or two
    axes, not over records, points stored); ValueError in one line otherwise, naming `instead`
    (the commands that draw a record sweep, with {id} for the sweep's id). With runs=False the
    runs are not loaded (None): the map reads its columns itself (map_columns)."""
    sw, scene, runs = load(factory, sweep_id) if runs else (*sweep_and_scene(factory, sweep_id), None)
    if runs is None and not sw.done:
        runs = []
    if sw.grid.get("records"):
        raise ValueError(f"sweep {sw.id} runs over records: draw it with {instead.format(id=sw.id)}")
    axes = drawn_axes(sw)
    if len(axes) > 2:
        raise ValueError(f"sweep {sw.id} has {len(axes)} axes ({', '.join(axes)}): a map draws one or two "
                         "(sweep two of them, with the others fixed in the scene)")
    if runs is not None and not runs:
        raise ValueError(f"sweep {sw.id} has no stored points yet: finish it with runners sweep {sw.id}")
    return sw, scene, runs, axes, sweep_parameters(sw, scene)


def map_figure(factory, sweep_id: str):
    """The map of a stored sweep as a matplotlib Figure, the count of points per region
    (REGIONS order), the count of points where rigid rocking broke first, and the sweep."""
    import matplotlib.pyplot as plt

    sw, scene, _, axes, p = mappable(factory, sweep_id, "runners fragility {id} or runners ida {id}", runs=False)
    gi, reg, brk = map_columns(factory, sw)
    if not len(gi):
        raise ValueError(f"sweep {sw.id} has no stored points yet: finish it with runners sweep {sw.id}")
    counts = np.bincount(reg, minlength=len(REGIONS)).tolist()
    n_broke = int(brk.sum())
    grid_axes = [Axis(*a) for a in sw.grid["axes"]]
    at, values = {}, {}
    for a, i in zip(grid_axes, np.unravel_index(gi, [a.count for a in grid_axes])):
        v = a.values  # each value as the sweep computed it (Axis.value), ascending for the drawing
        order = np.argsort(v, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        at[a.name], values[a.name] = rank[i], v[order]
    fig, ax = plt.subplots(figsize=(9, 7.5))
    if len(axes) == 2:
        xs, ys = values[axes[0]], values[axes[1]]
        field = np.full((len(ys), len(xs)), np.nan)
        field[at[axes[1]], at[axes[0]]] = reg
        from matplotlib.colors import ListedColormap

        ax.pcolormesh(xs, ys, field, cmap=ListedColormap(COLOURS), vmin=-0.5, vmax=len(REGIONS) - 0.5,
                      shading="nearest")
        if len(gi) <= DOTS_UP_TO:  # a dot per point, which leaves the colour beneath visible
            size = max(1.5, min(30.0, 2.2e4 / len(gi)))
            ax.scatter(xs[at[axes[0]][brk]], ys[at[axes[1]][brk]], s=size, marker="o", color=BROKE_COLOUR, lw=0)
        else:  # too many for dots: hatching over those points, the regions' colours show between its lines
            layer = np.zeros(field.shape)
            layer[at[axes[1]][brk], at[axes[0]][brk]] = 1.0
            with plt.rc_context({"hatch.color": BROKE_COLOUR, "hatch.linewidth": 1.2}):
                ax.contourf(xs, ys, layer, levels=[0.5, 1.5], colors="none", hatches=["////"])
        if axes == ["w", "a"]:
            ws = np.linspace(min(xs), max(xs), 25)
            curves = closed_form_curves(p, ws)
            for (label, ys_cf), style in zip(curves or [], ["k-", "k--"]):
                ax.plot(ws, ys_cf, style, lw=1.2, label=label)
            ax.set_ylim(min(ys), max(ys))
    else:
        xs = values[axes[0]][at[axes[0]]]
        ax.scatter(xs, reg, c=[COLOURS[r] for r in reg.tolist()],
                   edgecolors=[BROKE_COLOUR if b else "k" for b in brk.tolist()],
                   linewidths=np.where(brk, 2.0, 0.8))
        ax.set_yticks(range(len(REGIONS)), REGIONS)
    names = {"w": FREQUENCY, "a": amplitude_label(p)}
    ax.set_xlabel(names.get(axes[0], axes[0]))
    if len(axes) == 2:
        ax.set_ylabel(names.get(axes[1], axes[1]))
    if axes[0] == "w":  # the pulse frequency in Hz on top: f_g = (omega_g / p) p / (2 pi)
        pf, _ = scales(p)
        top = ax.secondary_xaxis("top", functions=(lambda w: w * pf / (2 * math.pi),
                                                   lambda f: f * 2 * math.pi / pf))
        top.set_xlabel("pulse frequency f_g = omega_g / 2 pi (Hz)", fontsize=9)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in COLOURS]
    handles.append(plt.Line2D([], [], ls="", marker="o", color=BROKE_COLOUR) if len(gi) <= DOTS_UP_TO or len(axes) < 2
                   else plt.Rectangle((0, 0), 1, 1, facecolor="none", edgecolor=BROKE_COLOUR, hatch="////"))
    labels = [f"{n} ({c})" for n, c in zip(REGIONS, counts)] + [f"{BROKE_LABEL} ({n_broke})"]
    h2, l2 = ax.get_legend_handles_labels()
    ax.legend(handles + h2, labels + l2, fontsize=8, ncol=2,
              loc="upper center", bbox_to_anchor=(0.5, -0.09), frameon=False)
    map_title(fig, ax, sw, scene, p, axes, "outcome (Anagnostopoulos's regions)", len(gi))
    return fig, counts, n_broke, sw


def draw(factory, sweep_id: str, out: Path) -> str:
    """Write the map of a stored sweep as a PNG; return a one-line summary."""
    return draw_counted(factory, sweep_id, out)[0]


def draw_counted(factory, sweep_id: str, out: Path) -> tuple[str, dict[str, int], int]:
    """draw, and the count of points per region (by name) and of points where rigid rocking
    broke first."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, counts, n_broke, sw = map_figure(factory, sweep_id)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    text = (f"sweep {sw.id}: " + ", ".join(f"{n} {c}" for n, c in zip(REGIONS, counts))
            + f"; rigid rocking broke first at {n_broke}; map written to {out}")
    return text, dict(zip(REGIONS, counts)), n_broke


def sweep_picture(factory, sweep_id: int) -> bytes:
    """A PNG of a stored sweep, for its recording (runners.engine.recording.write_sweep_recording):
    its overturning map, or for a sweep over records its IDA curves (of the PGA)."""
    import tempfile

    sw, _ = sweep_and_scene(factory, str(sweep_id))
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "picture.png"
        if sw.grid.get("records"):  # a sweep over records has no map: its IDA curves instead
            from runners.analysis.study_figures import plot_ida
            from runners.engine.study import outcomes

            plot_ida(png, outcomes(factory, sweep_id, "pga"))
        else:
            draw(factory, str(sweep_id), png)
        return png.read_bytes()
