"""Figure of one record: ground acceleration, velocity and displacement against time."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from runners.engine.intensity import G0, displacement, velocity


def plot_record(out: Path, info: dict[str, Any], t: np.ndarray, ah: np.ndarray) -> Path:
    """Acceleration (g), velocity (m/s) and displacement (m, least-squares line removed, as PGD is
    measured) of the record `info` (runners.engine.records.row) with its measures in the panels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from runners.engine.intensity import _baseline

    v, d = velocity(t, ah), displacement(t, ah)
    c0, c1 = _baseline(t, ah)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    title = info["name"] + (f": {info['event']} {info['year'] or ''}, {info['station']}" if info.get("event") else "")
    axes[0].set_title(title, loc="left", fontsize=9)
    for ax, y, label, note in (
            (axes[0], ah / G0, "a_h (g)", f"PGA {info['pga'] / G0:.3f} g, Arias {info['arias']:.3f} m/s, "
                                          f"D5-95 {info['d5_95']:.2f} s"),
            (axes[1], v, "v (m/s)", f"PGV {info['pgv']:.3f} m/s, PGV/PGA {info['pgv'] / info['pga']:.3f} s"),
            (axes[2], d - (c0 + c1 * t), "d (m)", f"PGD {info['pgd']:.3f} m (least-squares line removed)")):
        ax.plot(t, y, lw=0.7, color="#1f4e79")
        ax.axhline(0, color="0.6", lw=0.5)
        ax.set_ylabel(label)
        ax.set_title(note, loc="right", fontsize=8, color="0.25")  # above the panel, off the curve
    axes[2].set_xlabel("time (s)")
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
