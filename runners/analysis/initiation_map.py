"""Which mode starts from rest: the initiation map of docs/sliding.md (``runners figures --only
initiation_map``).

A block at rest under a suddenly applied constant ground acceleration ``a_h`` (and ``a_v``)
stays at rest, slides, rocks or slide-rocks (Ishiyama 1982; Shenton 1996). The regions are the
criteria of model/sliding_closed_form.py, drawn in the plane of the friction coefficient ``mu``
and the width-to-height ratio ``b / h`` for a few ``a_h / g``, the plane in which Shenton (1996)
draws his mode-initiation regions. Over them go the modes the FMU's rocking-sliding model
(``contact.model = 1``) takes at grid points: it is driven by the constant inputs ``ground.ah``,
``ground.av`` from ``t = 0`` (``excitation.kind = 0``, the block flat) and its ``block1.mode`` is
read after one short step. tests/test_initiation.py checks the FMU against the same criteria.
SI units; ``a_h > 0`` pushes the ground to ``+x`` (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from model.sliding_closed_form import Mode, initiation_mode, rocking_onset_demand  # noqa: E402
from runners.engine.fmu import FMUError, RockingFMU  # noqa: E402

G = 9.81  # m/s^2, the FMU's default g
HALF_HEIGHT = 0.5  # m: the blocks of the map are 1 m high
START_STEP = 2e-3  # s: the mode is read after this first step
PANELS = (0.3, 0.7, 1.5)  # a_h / g of the figure's panels
AXIS = (0.05, 1.5)  # b/h and mu shown
MODE_NAMES = {Mode.REST: "rest", Mode.SLIDE: "slide", Mode.ROCK: "rock", Mode.SLIDE_ROCK: "slide-rock",
              Mode.OVERTURNED: "overturned"}
MODE_COLOURS = {Mode.REST: "#e6e6e6", Mode.SLIDE: "#9ecae1", Mode.ROCK: "#fdae6b", Mode.SLIDE_ROCK: "#a1d99b"}
MODE_EDGES = {Mode.REST: "#636363", Mode.SLIDE: "#08519c", Mode.ROCK: "#a63603", Mode.SLIDE_ROCK: "#006d2c"}
MODE_MARKERS = {Mode.REST: "o", Mode.SLIDE: "s", Mode.ROCK: "^", Mode.SLIDE_ROCK: "D", Mode.OVERTURNED: "x"}


@dataclass(frozen=True)
class StartPoint:
    """One block and load: friction coefficient, b/h, a_h/g, a_v/g (1)."""

    mu: float
    b_over_h: float
    ah_over_g: float
    av_over_g: float = 0.0

    def parameters(self, g: float = G, half_height: float = HALF_HEIGHT) -> dict[str, float]:
        """The FMU's parameters and inputs for this point: rocking-sliding, flat at rest, constant inputs.
        The restitution law is the constant eta = 0.9 (no impact happens at the start; Housner's
        coefficient would be negative for b/h > sqrt(2))."""
        return {"contact.model": 1, "contact.muGround": self.mu, "block1.halfHeight": half_height,
                "restitution.law": 2, "restitution.eta": 0.9,
                "block1.halfWidth": self.b_over_h * half_height, "block1.theta0": 0.0, "block1.omega0": 0.0,
                "excitation.kind": 0, "g": g, "ground.ah": self.ah_over_g * g, "ground.av": self.av_over_g * g}


@dataclass(frozen=True)
class StartState:
    """What the FMU reports after its first step from rest."""

    mode: Mode
    theta: float  # rad
    slip: float  # m
    slip_rate: float  # m/s


def fmu_start_states(fmu: RockingFMU, points: Iterable[StartPoint], step: float = START_STEP,
                     g: float = G) -> list[StartState]:
    """The FMU's state after one step of ``step`` s from rest at each point: one instance, reset
    between points. FMUError with the FMU's own message if it refuses a point."""
    errors: list[str] = []
    slave, _callbacks = fmu.instantiate(lambda status, _c, msg: errors.append(msg) if status >= 3 else None,
                                        logging_on=False)
    vr = [fmu.variable(n).valueReference for n in ("block1.theta", "block1.slip", "block1.slipRate")]
    mode_vr = fmu.variable("block1.mode").valueReference
    out: list[StartState] = []
    try:
        for i, p in enumerate(points):
            try:
                if i:
                    slave.reset()
                slave.setupExperiment(startTime=0.0)
                fmu.set_parameters(slave, p.parameters(g))
                slave.enterInitializationMode()
                slave.exitInitializationMode()
                slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=step)
            except Exception as exc:
                raise FMUError(f"{p}: {errors[-1] if errors else exc}") from None
            theta, slip, rate = slave.getReal(vr)
            out.append(StartState(Mode(slave.getInteger([mode_vr])[0]), theta, slip, rate))
    finally:
        slave.freeInstance()
    return out


def _regions(ah_over_g: float, n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.linspace(*AXIS, n)
    y = np.linspace(*AXIS, n)
    modes = np.array([[int(initiation_mode(mu, beta, ah_over_g)) for beta in x] for mu in y])
    return x, y, modes


def _boundaries(ax, lam: float) -> None:
    """The criteria's boundaries for a_h / g = lam (a_v = 0): mu = lam and b/h = lam (rest),
    mu = b/h (slide against tipping), mu = rocking's onset demand (Shenton's rock / slide-rock)."""
    lo, hi = AXIS
    kw = {"color": "k", "lw": 1.0}
    if lam < hi:
        ax.plot([max(lam, lo), hi], [lam, lam], **kw)  # slide above mu = lam where mu <= b/h
        ax.plot([lam, lam], [lam, hi], **kw)  # rock or slide-rock for b/h < lam where mu > b/h
    beta = np.linspace(lo, min(lam, hi), 200)
    ax.plot(beta, beta, **kw)
    demand = [rocking_onset_demand(b, lam) for b in beta]
    ax.plot(beta, demand, color="k", lw=1.0, ls="--")


def map_figure(panels: Iterable[float], points: dict[float, list[tuple[StartPoint, StartState]]] | None,
               out: Path) -> Path:
    """The initiation map, one panel per a_h / g, with the FMU's modes at ``points`` (per panel) if given."""
    panels = list(panels)
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels) + 0.6, 4.6), sharey=True,
                             layout="constrained")
    axes = np.atleast_1d(axes)
    cmap = ListedColormap([MODE_COLOURS[m] for m in (Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK)])
    for ax, lam in zip(axes, panels):
        x, y, modes = _regions(lam)
        ax.pcolormesh(x, y, modes, cmap=cmap, vmin=-0.5, vmax=3.5, shading="auto", rasterized=True)
        _boundaries(ax, lam)
        for p, s in (points or {}).get(lam, []):
            ax.scatter([p.b_over_h], [p.mu], marker=MODE_MARKERS[s.mode], s=26, linewidths=0.9,
                       facecolors=MODE_COLOURS.get(s.mode, "w"), edgecolors=MODE_EDGES.get(s.mode, "k"), zorder=3)
        ax.set_xlim(*AXIS)
        ax.set_ylim(*AXIS)
        ax.set_aspect("equal")
        ax.set_xlabel("b / h (half width over half height)")
        ax.set_title(f"a_h / g = {lam:g}, a_v = 0")
    axes[0].set_ylabel("friction coefficient mu")
    handles = [Patch(facecolor=MODE_COLOURS[m], edgecolor="0.4", label=f"{MODE_NAMES[m]} (criteria)")
               for m in (Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK)]
    if points:
        handles += [Line2D([], [], ls="", marker=MODE_MARKERS[m], markerfacecolor=MODE_COLOURS[m],
                           markeredgecolor=MODE_EDGES[m], label=f"FMU: {MODE_NAMES[m]}")
                    for m in (Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK)]
    handles.append(Line2D([], [], color="k", ls="--", label="friction rocking needs at its onset"))
    fig.legend(handles=handles, loc="outside right center", fontsize=8, frameon=False)
    fig.suptitle("Which mode starts from rest under a suddenly applied a_h (Ishiyama 1982; Shenton 1996)",
                 fontsize=11)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def panel_points(lam: float, n: int) -> list[StartPoint]:
    """An n x n grid of (b/h, mu) for one panel, off the figure's edges."""
    lo, hi = AXIS
    values = lo + (hi - lo) * (np.arange(n) + 0.5) / n
    return [StartPoint(float(mu), float(beta), lam) for mu in values for beta in values]


def initiation_map(fmu: RockingFMU, out: Path, quick: bool = False) -> Path:
    """Draw docs/figures/initiation_map.png: the criteria's regions and the FMU's modes over them."""
    n = 6 if quick else 14
    points = {}
    for lam in PANELS:
        grid = panel_points(lam, n)
        points[lam] = list(zip(grid, fmu_start_states(fmu, grid)))
    return map_figure(PANELS, points, out)

