"""Writing matplotlib figures to files, the same way for every chart of runners.analysis."""

from __future__ import annotations

from pathlib import Path


def save_png(fig, out: str | Path, dpi: int = 110) -> Path:
    """Write Figure ``fig`` to ``out`` as a PNG (files only: the Agg backend) and close it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
