"""Overturning map of a one-sine pulse: Dimitrakopoulos & DeJong (2012)'s closed forms against simulation.

For each omega = omega_g / p the smallest overturning amplitude, in units of the
uplift acceleration (a = a_g / (g alpha) for the linearised block, a_g / (g tan alpha)
for the real one: the axes of every map, runners.analysis.sweep_map), is found three ways: from the closed forms (model/closed_form.py), from the
linearised simulation of a slender block (alpha = 0.05), and from the
nonlinear simulation of a stocky block (alpha = 0.25, amplitude in units of
g tan(alpha)), both by model/solvers.py. The first two must agree within 1%;
the third shows how far the linearisation is from a real block.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from model import closed_form as cf
from model.reference import Block
from model.solvers import Scene, sine_pulse, solve_event_driven

ETA = 0.9
SLENDER = Block(0.05, 1.0)
STOCKY = Block(0.255, 1.0)  # alpha = 0.25 rad


def simulated_overturn(block: Block, linear: bool):
    """Classifier (a, omega) -> overturned, by simulation of the block."""
    p = math.sqrt(block.p2)
    scale = block.g * (block.alpha if linear else math.tan(block.alpha))

    def overturns(a: float, w: float) -> bool:
        ground, breaks = sine_pulse(a * scale, w * p / (2 * math.pi))
        scene = Scene(block, ETA, ground=ground, breaks=breaks, linear=linear)
        return solve_event_driven(scene, breaks[1] + 25.0 / p, rtol=1e-9, atol=1e-12).overturned

    return overturns


def boundaries(omegas) -> list[dict]:
    rows = []
    closed = lambda a, w: cf.overturns(a, w, ETA)[0]  # noqa: E731
    lin, non = simulated_overturn(SLENDER, True), simulated_overturn(STOCKY, False)
    for w in omegas:
        a_cf = cf.smallest_overturning_a(closed, w)
        a_lin = cf.smallest_overturning_a(lin, w, rel=1e-3)
        a_non = cf.smallest_overturning_a(non, w, rel=1e-3)
        rows.append({"omega": w, "a_closed_form": a_cf, "a_linear_simulation": a_lin,
                     "a_nonlinear_simulation": a_non,
                     "linear_gap": (a_lin / a_cf - 1) if a_cf and a_lin else math.nan,
                     "nonlinear_gap": (a_non / a_cf - 1) if a_cf and a_non else math.nan})
    return rows


def _block_line(name: str, block: Block, unit: str) -> str:
    p = math.sqrt(block.p2)
    return (f"{name}: b = {block.b:g} m, h = {block.h:g} m (half-width, half-height), alpha = {block.alpha:.3f} rad, "
            f"p = {p:.3f} rad/s (p / 2 pi = {p / (2 * math.pi):.3f} Hz), a_g / ({unit})")


def map_figure(rows: list[dict], resolution: tuple[int, int] = (120, 110)):
    """The closed-form map (regions and boundaries, on `resolution` omega x a points) with the
    simulated boundaries of `rows`, as a matplotlib Figure, in the axes of every overturning map
    (runners.analysis.sweep_map)."""
    import matplotlib.pyplot as plt

    from runners.analysis.sweep_map import AMPLITUDE, FREQUENCY

    w_grid = np.linspace(0.6, 10, resolution[0])
    a_grid = np.geomspace(1.02, 50.0, resolution[1])
    cases = {"safe": 0, "1.1": 1, "1.2": 2, "2": 3}
    field = np.array([[cases.get(cf.overturns(a, w, ETA)[1], 0) for w in w_grid] for a in a_grid])
    fig, ax = plt.subplots(figsize=(9, 8.4))
    colours = ["#ffffff", "#f6c9c9", "#f3dfb6", "#c9d7f3"]
    ax.contourf(w_grid, a_grid, field, levels=[-0.5, 0.5, 1.5, 2.5, 3.5], colors=colours)
    limit = [[cf.impact_at_pulse_end_margin(a, w) for w in w_grid] for a in a_grid]
    ax.contour(w_grid, a_grid, limit, levels=[0.0], colors="grey", linestyles=":")
    w = [r["omega"] for r in rows]
    for key, style, label in [
            ("a_closed_form", dict(color="k", ls="-"), "closed forms: smallest overturning amplitude"),
            ("a_linear_simulation", dict(color="#1f78b4", marker="o", ls="none", mfc="none"),
             "linearised simulation, slender block (alpha = 0.05)"),
            ("a_nonlinear_simulation", dict(color="#d62728", marker="s", ls="none", mfc="none"),
             "nonlinear simulation, stocky block (alpha = 0.25)")]:
        ax.plot(w, [r[key] if r[key] else np.nan for r in rows], label=label, **style)
    ax.set_yscale("log")
    ax.set_ylim(1.0, 50.0)
    ticks = [1, 1.5, 2, 3, 5, 7, 10, 20, 30, 50]
    ax.set_yticks(ticks, [f"{t:g}" for t in ticks])
    ax.minorticks_off()
    handles, labels = ax.get_legend_handles_labels()
    handles += [plt.Rectangle((0, 0), 1, 1, color=c, ec="grey") for c in colours[1:]]
    handles += [plt.Line2D([], [], color="grey", ls=":")]
    dd = "Dimitrakopoulos & DeJong 2012"
    labels += [f"overturns after an impact in the pulse ({dd}, eqs. 3.20-3.21)",
               f"overturns after an impact after the pulse ({dd}, eq. 3.18)",
               f"overturns without impact ({dd}, eq. 3.10)",
               f"first impact at the pulse's end ({dd}, eq. 3.31)"]
    ax.legend(handles, labels, fontsize=8, ncol=1, loc="upper center", bbox_to_anchor=(0.5, -0.09), frameon=False)
    ax.set_xlabel(FREQUENCY)
    ax.set_ylabel(AMPLITUDE)
    ax.set_title(f"One-sine pulse, constant restitution eta = {ETA}: Dimitrakopoulos & DeJong (2012)'s closed forms "
                 f"of the linearised block,\n{_block_line('slender', SLENDER, 'g alpha')}, linearised;\n"
                 f"{_block_line('stocky', STOCKY, 'g tan alpha')}", fontsize=8)
    fig.tight_layout()
    return fig


def draw(rows: list[dict], out: Path) -> Path:
    """Write map_figure(rows) as a PNG."""
    from runners.analysis.plotting import save_png

    return save_png(map_figure(rows), out)


def run_overturning_map(out_dir: Path, quick: bool = False) -> str:
    """Write overturning_map.png and .csv; return a Markdown table of the boundaries."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = boundaries([1.5, 4.0] if quick else [1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0])
    with open(out_dir / "overturning_map.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    draw(rows, out_dir / "overturning_map.png")
    lines = ["| omega_g/p | a closed form | a linearised sim | gap | a nonlinear sim (alpha 0.25) | gap |",
             "|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['omega']:g} | {r['a_closed_form']:.4f} | {r['a_linear_simulation']:.4f} | "
                     f"{100 * r['linear_gap']:+.2f}% | {r['a_nonlinear_simulation']:.4f} | "
                     f"{100 * r['nonlinear_gap']:+.1f}% |")
    return "\n".join(lines + ["", f"written: {out_dir}/overturning_map.png, .csv"])
