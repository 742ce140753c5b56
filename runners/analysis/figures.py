"""``runners figures``: the figures of docs/, drawn from fresh FMU runs.

Each figure is a function of the FMU and an output path, so the
documentation can always be regenerated from the code that it describes
(``runners figures --out docs/figures``). Angles in radians, time in seconds.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from runners.engine.fmu import RockingFMU  # noqa: E402

# Anagnostopoulos Table 2, half dimensions: Block 1 below, Block 4 on top
SEED_STACK = {
    "nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
    "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3,
    "restitution.law": 2, "restitution.etaGround": 0.95, "restitution.etaInterface": 0.98,
}
SEED_CASES = [(7.0, 0.003), (5.5, 0.003), (3.0, 0.005), (4.0, 0.003)]  # Hz, m (Anagnostopoulos Fig. 17 A-D)
PATTERN_COLOURS = {3: "#fde0c5", 4: "#d8e8f5", 5: "#e3f1d8"}  # upper alone, locked, both
PATTERN_NAMES = {3: "upper block alone", 4: "locked pair", 5: "both rock"}
TALL = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
        "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0}


def _shade_patterns(ax, t: np.ndarray, pattern: np.ndarray) -> None:
    """Colour the background by motion pattern."""
    start = 0
    for i in range(1, len(t) + 1):
        if i == len(t) or pattern[i] != pattern[start]:
            colour = PATTERN_COLOURS.get(int(pattern[start]))
            if colour:
                ax.axvspan(t[start], t[min(i, len(t) - 1)], color=colour, lw=0)
            start = i


def _finish(fig, axes, title: str, out: Path) -> Path:
    """Common axes labels, title and the PNG file."""
    for ax in axes:
        ax.set_ylabel("rad")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def seed_forced_cases(fmu: RockingFMU, out: Path, stop_time: float = 10.0, step: float = 2e-3) -> Path:
    """Anagnostopoulos Fig. 17: the four harmonic table motions, theta1 and theta2 against time."""
    fig, axes = plt.subplots(len(SEED_CASES), 1, figsize=(9, 10), sharex=True)
    for ax, (f, d) in zip(axes, SEED_CASES):
        p = {**SEED_STACK, "excitation.kind": 3, "excitation.frequency": f, "excitation.displacement": d,
             "excitation.cycles": 0}
        r = fmu.run(p, stop_time, step, outputs=["block1.theta", "block2.theta", "pattern", "overturnTime",
                                                 "impactsGround", "impactsInterface"], events=False)
        o = r.outputs
        _shade_patterns(ax, r.time, o["pattern"])
        ax.plot(r.time, o["block1.theta"], color="C0", lw=0.9, label="theta1 (lower, Block 1)")
        ax.plot(r.time, o["block2.theta"], color="C3", lw=0.9, label="theta2 (upper, Block 4)")
        acc = d * (2 * np.pi * f) ** 2
        title = f"{f:g} Hz, {1e3 * d:g} mm table motion (peak {acc:.2f} m/s2)"
        if o["overturnTime"][-1] >= 0:
            title += f": overturns at t = {o['overturnTime'][-1]:.2f} s"
            ax.set_ylim(-0.6, 0.6)
        else:
            title += f": {int(o['impactsGround'][-1])} ground, {int(o['impactsInterface'][-1])} interface impacts"
        ax.set_title(title, fontsize=10)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in PATTERN_COLOURS.values()]
    lines, labels = axes[0].get_legend_handles_labels()
    axes[0].legend(lines + handles, labels + list(PATTERN_NAMES.values()), fontsize=8, ncol=3, loc="upper right")
    return _finish(fig, axes, "Two blocks on a shaking table (Anagnostopoulos Fig. 17 cases), "
                   "constant restitution 0.95 / 0.98", out)


def mirror_tests(fmu: RockingFMU, out: Path, stop_time: float = 3.0, step: float = 1e-3) -> Path:
    """Anagnostopoulos Figs. 14-15: opposite and same-direction tilts, and their mirror images."""
    configs = [("opposite tilts (Fig. 14)", 0.05, -0.08), ("same direction (Fig. 15)", 0.03, 0.09)]
    fig, axes = plt.subplots(len(configs), 1, figsize=(9, 6), sharex=True)
    for ax, (name, th1, th2) in zip(axes, configs):
        runs = []
        for sign in (1, -1):
            p = {**TALL, "restitution.law": 0, "block1.theta0": sign * th1, "block2.theta0": sign * th2}
            runs.append(fmu.run(p, stop_time, step, outputs=["block1.theta", "block2.theta", "pattern"],
                                events=False))
        a, b = runs
        _shade_patterns(ax, a.time, a.outputs["pattern"])
        ax.plot(a.time, a.outputs["block1.theta"], color="C0", lw=1.0, label="theta1")
        ax.plot(a.time, a.outputs["block2.theta"], color="C3", lw=1.0, label="theta2")
        ax.plot(b.time, -b.outputs["block1.theta"], color="k", ls=":", lw=1.2, label="-theta1, mirrored start")
        ax.plot(b.time, -b.outputs["block2.theta"], color="k", ls="--", lw=0.8, label="-theta2, mirrored start")
        gap = max(np.max(np.abs(a.outputs[k] + b.outputs[k])) for k in ("block1.theta", "block2.theta"))
        ax.set_title(f"{name}: largest mirror gap {gap:.1e} rad", fontsize=10)
        ax.legend(fontsize=8, ncol=2, loc="upper right")
    return _finish(fig, axes, "Free rocking of two blocks (b = 0.1 m; h1 = 0.3 m, h2 = 0.2 m), "
                   "momentum restitution", out)


FIGURES = {
    "two_blocks_fig17.png": seed_forced_cases,
    "two_blocks_mirror.png": mirror_tests,
}


def write_figures(fmu_path: Path, out_dir: Path) -> list[Path]:
    """Write every figure of docs/ drawn here and in runners.analysis.record_figures into out_dir; returns
    their paths (a drawing may write more than one file)."""
    from runners.analysis.record_figures import FIGURES as RECORD_FIGURES

    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    with RockingFMU(fmu_path) as fmu:
        for name, draw in {**FIGURES, **RECORD_FIGURES}.items():
            made = draw(fmu, out_dir / name)
            paths.extend(made if isinstance(made, list) else [made])
    return paths
