"""``runners map SWEEP_ID --by mode`` and ``--by slip``: the maps of a rocking–sliding sweep
(contact.model = 1, docs/contact.md).

- The mode map (after Shenton 1996's maps of a block's response on a base with friction): what
  the block does at each grid point, one colour per motion class (runners.engine.motion:
  rests, slides, rocks, slide-rocks, overturns), failed points in grey. Where a grid axis is
  the friction coefficient (contact.muGround), the line mu = b/h (tan alpha) is drawn: below it
  a block at rest slides before it can rock (Shenton 1996).
- The slip map: block 1's peak |slip| (m) at each point on a colour scale; overturned points
  are crossed (their slip is the slip up to the overturn).

Points whose block lifted off (flight: outside the rocking–sliding model) before the outcome
was decided are dotted in the colour every map uses for a broken model
(runners.analysis.sweep_map.BROKE_COLOUR). The axes are those of every overturning map
(runners.analysis.sweep_map: omega_g/p and a_g/(g tan alpha) for w and a).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from runners.analysis.sweep_map import (BROKE_COLOUR, FREQUENCY, amplitude_label, broke, map_title, mappable,
                                        sweep_and_scene, sweep_parameters)
from runners.engine.motion import MOTIONS, ROCKING_SLIDING, rocking_sliding
from runners.engine.sweep import scales

MOTION_COLOURS = {"rests": "#e5f5e0", "slides": "#6baed6", "rocks": "#fdae6b", "slide-rocks": "#9e9ac8",
                  "overturns": "#cb181d"}
FAILED_COLOUR = "#888888"
RIGID_COLOUR = "#ffffff"  # points of a rigid-rocking model (a sweep over contact.model): no mode
LIFT_LABEL = "lifted off first (flight: outside the rocking–sliding model)"
MU = "contact.muGround"


class NoSlip(ValueError):
    """A map of slip or mode asked of a sweep that computed none (rigid rocking); one line."""


def no_slip(sweep_id: int) -> str:
    """Why a rigid-rocking sweep has no slip, and how to get one."""
    return (f"sweep {sweep_id} runs rigid rocking, which computes no slip (the block never slides): set "
            "contact.model = rocking-sliding ([contact] model = \"rocking-sliding\" in the scene, or --grid "
            "contact.model=rocking-sliding) and sweep again")


def mode_of(run) -> str:
    """A point's motion class (runners.engine.motion.MOTIONS), "failed", or "rigid" (no mode)."""
    if run.status != "ok" or run.summary is None:
        return "failed"
    return run.summary.motion or "rigid"


def _sliding_sweep(factory, sweep_id: str):
    """(sweep, scene, runs, drawn axes, parameters) of a stored rocking–sliding sweep a map can
    draw; ValueError (NoSlip for rigid rocking) in one line otherwise."""
    sw, scene = sweep_and_scene(factory, sweep_id)
    instead = ("runners fragility {id} --ds slide>5cm or runners ida {id} --demand slip"
               if sliding_sweep(sw, sweep_parameters(sw, scene)) else
               "runners fragility {id} or runners ida {id} (its runs are rigid rocking, which has no modes or slip: "
               "contact.model = rocking-sliding gives them)")
    sw, scene, runs, axes, p = mappable(factory, sweep_id, instead)
    if not sliding_sweep(sw, p):
        raise NoSlip(no_slip(sw.id))
    if all(r.summary is None or r.summary.motion is None for r in runs):
        raise ValueError(f"sweep {sw.id} has no successful rocking–sliding points to map yet")
    return sw, scene, runs, axes, p


def sliding_sweep(sw, p: dict) -> bool:
    """Whether any point of sweep `sw` (scene parameters with defaults `p`) runs the rocking–sliding
    model: the scene's contact.model, or a contact.model grid axis that takes the value 1."""
    if rocking_sliding(p):
        return True
    return any(a[0] == "contact.model" and max(a[1], a[2]) >= ROCKING_SLIDING for a in sw.grid["axes"])


def _field(runs, axes: list[str], value) -> tuple[list, list, np.ndarray]:
    """(x values, y values, field[y, x]) of a two-axis grid, NaN where no point is stored."""
    xs = sorted({r.point[axes[0]] for r in runs})
    ys = sorted({r.point[axes[1]] for r in runs})
    field = np.full((len(ys), len(xs)), np.nan)
    for r in runs:
        field[ys.index(r.point[axes[1]]), xs.index(r.point[axes[0]])] = value(r)
    return xs, ys, field


def _label_axes(ax, axes: list[str], p: dict) -> None:
    names = {"w": FREQUENCY, "a": amplitude_label(p), MU: "friction coefficient mu (contact.muGround)"}
    ax.set_xlabel(names.get(axes[0], _with_unit(axes[0])))
    if len(axes) == 2:
        ax.set_ylabel(names.get(axes[1], _with_unit(axes[1])))
    if axes[0] == "w":  # the pulse frequency in Hz on top, as the overturning map
        pf, _ = scales(p)
        top = ax.secondary_xaxis("top", functions=(lambda w: w * pf / (2 * math.pi), lambda f: f * 2 * math.pi / pf))
        top.set_xlabel("pulse frequency f_g = omega_g / 2 pi (Hz)", fontsize=9)


def _with_unit(name: str) -> str:
    """An FMU parameter's name with its unit, e.g. 'excitation.amplitude (m/s2)'."""
    from runners.engine.tables import variable_units

    try:
        unit = variable_units().get(name, "")
    except (OSError, ImportError):  # an installation without the model's sources: the name alone
        unit = ""
    return f"{name} ({unit})" if unit and unit != "1" else name


def _mu_line(ax, axes: list[str], p: dict) -> None:
    """mu = b/h on a friction axis: below it a block at rest slides before it can rock."""
    if MU not in axes or "block1.halfWidth" in axes or "block1.halfHeight" in axes:
        return
    tan_alpha = p["block1.halfWidth"] / p["block1.halfHeight"]
    label = f"mu = b/h = tan alpha = {tan_alpha:.3g}: below it the block slides before it can rock (Shenton 1996)"
    if axes[0] == MU:
        ax.axvline(tan_alpha, color="k", ls="--", lw=1.2, label=label)
    elif len(axes) == 2:
        ax.axhline(tan_alpha, color="k", ls="--", lw=1.2, label=label)


def _lifted(ax, runs, axes: list[str], y_of) -> int:
    """Dot the points that lifted off first; their count."""
    lifted = [r for r in runs if broke(r) and r.summary.motion is not None]  # (not a rigid point of a mixed sweep)
    if lifted:
        size = max(1.5, min(30.0, 2.2e4 / len(runs)))
        ax.scatter([r.point[axes[0]] for r in lifted], [y_of(r) for r in lifted], s=size, marker="o",
                   color=BROKE_COLOUR, lw=0, zorder=4)
    return len(lifted)




def mode_figure(factory, sweep_id: str):
    """The mode map of a stored rocking–sliding sweep as a matplotlib Figure, the count of points
    per class (MOTIONS, then failed and rigid where there are any), the count of points that
    lifted off first, and the sweep."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    sw, scene, runs, axes, p = _sliding_sweep(factory, sweep_id)
    classes = MOTIONS + ["failed", "rigid"]
    colours = [MOTION_COLOURS[m] for m in MOTIONS] + [FAILED_COLOUR, RIGID_COLOUR]
    modes = [mode_of(r) for r in runs]
    counts = {c: modes.count(c) for c in classes}
    fig, ax = plt.subplots(figsize=(9, 7.5))
    if len(axes) == 2:
        xs, ys, field = _field(runs, axes, lambda r: classes.index(mode_of(r)))
        ax.pcolormesh(xs, ys, field, cmap=ListedColormap(colours), vmin=-0.5, vmax=len(classes) - 0.5,
                      shading="nearest")
        n_lifted = _lifted(ax, runs, axes, lambda r: r.point[axes[1]])
    else:
        ax.scatter([r.point[axes[0]] for r in runs], [classes.index(m) for m in modes],
                   c=[colours[classes.index(m)] for m in modes], edgecolors="k", linewidths=0.8, zorder=3)
        n_lifted = _lifted(ax, runs, axes, lambda r: classes.index(mode_of(r)))
        shown = [c for c in classes if c in MOTIONS or counts[c]]
        ax.set_yticks([classes.index(c) for c in shown], shown)
    _mu_line(ax, axes, p)
    _label_axes(ax, axes, p)
    handles = [plt.Rectangle((0, 0), 1, 1, facecolor=col, edgecolor="0.6")
               for c, col in zip(classes, colours) if c in MOTIONS or counts[c]]
    labels = [f"{c} ({counts[c]})" for c in classes if c in MOTIONS or counts[c]]
    handles.append(plt.Line2D([], [], ls="", marker="o", color=BROKE_COLOUR))
    labels.append(f"{LIFT_LABEL} ({n_lifted})")
    h2, l2 = ax.get_legend_handles_labels()
    ax.legend(handles + h2, labels + l2, fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.09),
              frameon=False)
    map_title(fig, ax, sw, scene, p, axes, "what the block does (Shenton 1996's modes)", len(runs))
    return fig, {c: n for c, n in counts.items() if c in MOTIONS or n}, n_lifted, sw


def slip_figure(factory, sweep_id: str):
    """The peak-slip map of a stored rocking–sliding sweep as a matplotlib Figure, with the
    largest peak |slip| (m, None when no point ran), the count of points that lifted off first
    and the sweep."""
    import matplotlib.pyplot as plt

    sw, scene, runs, axes, p = _sliding_sweep(factory, sweep_id)

    def slip(r) -> float:
        s = r.summary
        return np.nan if r.status != "ok" or s is None or s.max_abs_slip is None else float(s.max_abs_slip)

    values = np.array([slip(r) for r in runs])
    largest = float(np.nanmax(values)) if np.isfinite(values).any() else None
    fell = [r for r in runs if r.status == "ok" and r.summary is not None and r.summary.overturned]
    fig, ax = plt.subplots(figsize=(9, 7.5))
    if len(axes) == 2:
        xs, ys, field = _field(runs, axes, slip)
        cmap = plt.get_cmap("viridis").with_extremes(bad=FAILED_COLOUR)
        mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(field), cmap=cmap, vmin=0.0,
                             vmax=max(largest or 0.0, 1e-12), shading="nearest")
        fig.colorbar(mesh, ax=ax, label="peak |slip| of block 1 (m)")
        y_of = lambda r: r.point[axes[1]]  # noqa: E731
    else:
        order = np.argsort([r.point[axes[0]] for r in runs])
        ax.plot(np.array([r.point[axes[0]] for r in runs])[order], values[order], "o-", color="#08519c", ms=4,
                label="peak |slip| of block 1")
        ax.set_ylabel("peak |slip| of block 1 (m)")
        ax.set_ylim(bottom=0.0)
        y_of = slip
    size = max(1.5, min(30.0, 6e3 / len(runs)))  # crosses that leave the colour beneath visible
    ax.scatter([r.point[axes[0]] for r in fell], [y_of(r) for r in fell], marker="x", color="0.75" if len(axes) == 2
               else "k", s=size, lw=0.5 if size < 10 else 1.2, zorder=5)
    n_lifted = _lifted(ax, runs, axes, y_of)
    _mu_line(ax, axes, p)
    _label_axes(ax, axes, p)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(plt.Line2D([], [], ls="", marker="x", color="k"))
    labels.append(f"overturned ({len(fell)}): slip up to the overturn")
    handles.append(plt.Line2D([], [], ls="", marker="o", color=BROKE_COLOUR))
    labels.append(f"{LIFT_LABEL} ({n_lifted})")
    if len(axes) == 2 and np.isnan(values).any():
        handles.append(plt.Rectangle((0, 0), 1, 1, color=FAILED_COLOUR))
        labels.append(f"failed or no slip ({int(np.isnan(values).sum())})")
    ax.legend(handles, labels, fontsize=8, ncol=1, loc="upper center", bbox_to_anchor=(0.5, -0.09), frameon=False)
    map_title(fig, ax, sw, scene, p, axes, "peak |slip| of block 1 (m)", len(runs))
    return fig, largest, n_lifted, sw


def draw_mode(factory, sweep_id: str, out: Path) -> tuple[str, dict[str, int], int]:
    """Write the mode map as a PNG: (one-line summary, points per class, points that lifted off first)."""
    from runners.analysis.plotting import save_png

    fig, counts, n_lifted, sw = mode_figure(factory, sweep_id)
    save_png(fig, out)
    text = (f"sweep {sw.id}: " + ", ".join(f"{n} {c}" for c, n in counts.items())
            + f"; lifted off first at {n_lifted}; mode map written to {out}")
    return text, counts, n_lifted


def draw_slip(factory, sweep_id: str, out: Path) -> tuple[str, float | None, int]:
    """Write the peak-slip map as a PNG: (one-line summary, largest peak |slip| in m, points that
    lifted off first)."""
    from runners.analysis.plotting import save_png

    fig, largest, n_lifted, sw = slip_figure(factory, sweep_id)
    save_png(fig, out)
    big = "no point ran" if largest is None else f"largest peak |slip| {largest:.4g} m"
    return f"sweep {sw.id}: {big}; lifted off first at {n_lifted}; slip map written to {out}", largest, n_lifted
