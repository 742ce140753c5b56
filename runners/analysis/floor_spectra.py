"""The floor response spectra of a study on a support (runners.engine.floor_motion.FloorSpectra): Sa / PGA
at 5 % damping of every record on the blocks' floor, their median and 16th to 84th percentiles, against the
same of the base, with the support's natural periods marked: the amplification nonstructural design works
with (ASCE 7-22 chapter 13; FEMA P-58)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from runners.engine.floor_motion import FloorSpectra


def plot_floor_spectra(path: str | Path, fs: FloorSpectra, title: str) -> Path:
    """Draw ``fs`` into the figure file ``path`` (.png, .pdf or .svg)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5.5))
    for row in fs.floor:
        ax.plot(fs.periods, row, color="#9ecae1", lw=0.6, alpha=0.7)
    f16, f50, f84 = fs.percentiles("floor")
    b16, b50, b84 = fs.percentiles("base")
    ax.fill_between(fs.periods, f16, f84, color="#3182bd", alpha=0.25, lw=0, label="floor: 16th to 84th percentile")
    ax.plot(fs.periods, f50, color="#08519c", lw=2.2, label=f"floor: median of {len(fs.records)} records")
    ax.fill_between(fs.periods, b16, b84, color="#969696", alpha=0.25, lw=0, label="base: 16th to 84th percentile")
    ax.plot(fs.periods, b50, color="#252525", lw=1.8, ls="--", label="base (the records): median")
    for i, T in enumerate(t for t in fs.support_periods if fs.periods[0] <= t <= fs.periods[-1]):
        ax.axvline(T, color="#e6550d", lw=1.0, ls=":", label="the support's natural periods" if i == 0 else None)
    ax.set_xscale("log")
    ax.set_xlabel("period T (s)")
    ax.set_ylabel("Sa(T, 5 %) / PGA of the base (1)")
    ax.set_title(title, loc="left", fontsize=10)
    ax.grid(True, which="both", color="#eeeeee")
    ax.legend(loc="upper right", fontsize=8, frameon=False)
    fig.text(0.01, 0.01, f"{fs.description}; median PFA / PGA {float(np.median(fs.pfa)):.3g}\n"
             "base: the piecewise-linear records (Nigam & Jennings 1969); floor: its exact motion sampled at 1/64 of "
             "the support's shortest period", fontsize=7, color="#555555")
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
