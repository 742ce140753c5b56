"""Figures people can read, checked on the matplotlib Figures drawn from real runs (no PNG
parsing): distinct styles in the work-precision chart, the criterion on the stability chart, one
normalisation and the block in the title of every overturning map; and ``runners figures``
drawing the figures of docs/figures into the folder it is given."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from db.session import open_database  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def _texts(fig) -> str:
    """Every piece of text of a Figure: titles, labels, tick labels, legends, free text."""
    parts = [t.get_text() for t in fig.findobj(matplotlib.text.Text)]
    return "\n".join(parts)


def test_work_precision_gives_every_method_its_own_colour_and_marker(fmu_path):
    """The quick chart (runners bench --chart --quick, one repeat) of every method: no two lines
    of a panel share (colour, marker), and a method looks the same in every panel."""
    from matplotlib.colors import to_hex

    from runners.analysis.work_precision import STYLES, chart_figure, compute_points

    points = compute_points(fmu_path, repeats=1, quick=True)
    methods = {p.method for p in points}
    assert methods == set(STYLES)  # every method of the chart, each with its style
    fig = chart_figure(points)
    try:
        seen: dict[str, tuple[str, str, str]] = {}
        for ax in fig.axes:
            styles = [(line.get_label(), to_hex(line.get_color()), line.get_marker(), line.get_linestyle())
                      for line in ax.get_lines()]
            assert len(styles) >= 3
            pairs = [(c, m) for _, c, m, _ in styles]
            assert len(set(pairs)) == len(pairs), pairs
            for label, *style in styles:
                assert seen.setdefault(label, tuple(style)) == tuple(style), label  # same in every panel
        assert len(seen) == len(STYLES)
        assert len({s[:2] for s in seen.values()}) == len(STYLES)  # across panels too
        assert len({s[0] for s in seen.values()}) == len(STYLES) and len({s[1] for s in seen.values()}) == len(STYLES)
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        assert sorted(legend) == sorted(methods)
        assert "Čeh & Jelenić 2022" in _texts(fig) and "seed" not in _texts(fig)
    finally:
        plt.close(fig)


def test_the_stability_chart_states_its_criterion(fmu_path):
    """On real outcomes (the FMU and RK4 with sign-change impacts on free rocking to rest): the
    criterion with its 1% threshold is on the chart, the reference's row is there, and the red
    cell says what differs."""
    from runners.analysis.stability import REFERENCE, THETA_TOLERANCE, compute, free_rocking_scene, \
        stability_figure

    rows, names, refs = compute(fmu_path, methods=[("FMU", {"rtol": 1e-6}), ("RK4 sign change", {"h": 1e-3})],
                                cases=[free_rocking_scene()])
    assert [r["right"] for r in rows] == [True, False]  # RK4 at 1 ms misses impacts (as the full chart shows)
    fig = stability_figure(rows, names)
    try:
        text = _texts(fig)
        ax = fig.axes[0]
        assert f"within {100 * THETA_TOLERANCE:g}%" in "\n".join(t.get_text() for t in ax.get_legend().get_texts())
        assert "same number of impacts" in text and "overturns or not" in text
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert labels[0] == f"reference: {REFERENCE}" and len(labels) == 3
        assert str(refs[0].impacts) in [t.get_text() for t in ax.texts]  # the reference's impacts, in its row
        red = [t.get_text() for t in ax.texts if "ref." in t.get_text()]
        assert red == [f"{rows[1]['impacts']}\n(ref. {refs[0].impacts} impacts)"]
    finally:
        plt.close(fig)


def _block_numbers(b: float, h: float, g: float = 9.81) -> tuple[str, str]:
    p = math.sqrt(3 * g / (4 * math.hypot(b, h)))
    return f"{p:.3f} rad/s", f"{p / (2 * math.pi):.3f} Hz"


def test_every_overturning_map_has_one_normalisation_and_names_its_block(tmp_path, fmu):
    """A real sweep's map (runners map) and the closed-form map (runners bench --chart) plot the
    same groups, omega_g / p against a_g / (g tan alpha) (Dimitrakopoulos & DeJong 2012), and their
    titles give the block (half-width, half-height, p in rad/s and Hz) and the restitution."""
    from runners.analysis import overturning_map, sweep_map
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    factory = open_database(f"sqlite:///{tmp_path / 'm.db'}")
    sid = create_sweep(factory, load_scene(ROOT / "examples" / "fig18_housner.toml"),
                       [Axis("w", 0.5, 10.0, 8), Axis("a", 1.01, 7.0, 6)], fmu.defaults())
    run_sweep(factory, sid, fmu.path, progress=False)
    fig, counts, _, _ = sweep_map.map_figure(factory, str(sid))
    bench = overturning_map.map_figure([], resolution=(20, 16))
    try:
        ax, bx = fig.axes[0], bench.axes[0]
        assert sum(counts) == 48
        for a in (ax, bx):
            assert a.get_ylabel() == sweep_map.AMPLITUDE and a.get_xlabel() == sweep_map.FREQUENCY
        assert "a_g / (g tan alpha)" in sweep_map.AMPLITUDE and "(1 = uplift)" in sweep_map.AMPLITUDE
        # one quantity on the axis; how it relates to the closed forms' a_g / (g alpha) in the map's foot
        assert "Dimitrakopoulos & DeJong (2012)" not in sweep_map.AMPLITUDE
        assert any(sweep_map.AMPLITUDE_NOTE in t.get_text() for t in fig.texts)
        assert "Dimitrakopoulos & DeJong (2012)'s a_g / (g alpha)" in sweep_map.AMPLITUDE_NOTE
        title = ax.get_title().replace("\n", " ")
        rad_s, hz = _block_numbers(0.03, 0.06)
        for part in ("b = 0.03 m", "h = 0.06 m", "half-width, half-height", rad_s, hz,
                     "Housner (1963) restitution, eta = 0.700"):
            assert part in title, (part, title)
        assert any("Hz" in a.get_xlabel() for a in ax.child_axes)  # the pulse frequency on top
        btitle = bx.get_title().replace("\n", " ")
        assert "constant restitution eta = 0.9" in btitle
        for block in (overturning_map.SLENDER, overturning_map.STOCKY):
            rad_s, hz = _block_numbers(block.b, block.h, block.g)
            assert f"b = {block.b:g} m, h = {block.h:g} m" in btitle and rad_s in btitle and hz in btitle
        assert "g alpha" not in bx.get_ylabel().split("\n")[0]  # not g alpha / a_g any more
    finally:
        plt.close(fig)
        plt.close(bench)


def runners_cli(*args: str, fmu_path: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    e = {**os.environ, "ROCKING_FMU": str(fmu_path), **(env or {})}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=e,
                          cwd=ROOT)


def test_runners_figures_draws_the_chosen_figures_into_the_folder_given(tmp_path, fmu_path):
    out = tmp_path / "figs"
    before = {p: p.stat().st_mtime_ns for p in (ROOT / "docs" / "figures").glob("*.png")}
    p = runners_cli("figures", "--only", "two_blocks_mirror", "records_imperial_valley.png", "compare_peaks",
                    "--out", str(out), fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    names = sorted(x.name for x in out.iterdir())
    assert names == ["compare_peaks.png", "records_imperial_valley.png", "two_blocks_mirror.png"]
    assert all((out / n).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for n in names)
    assert sorted(Path(line).name for line in p.stdout.split()) == names
    assert {p: p.stat().st_mtime_ns for p in (ROOT / "docs" / "figures").glob("*.png")} == before  # untouched


def test_runners_figures_refuses_an_unknown_name_and_skips_the_viewer_without_chromium(tmp_path, fmu_path):
    p = runners_cli("figures", "--only", "work_precision", "no_such_figure", "--out", str(tmp_path / "x"),
                    fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
    assert p.stderr.startswith("error: no figure no_such_figure (figures: compare_peaks")
    assert not (tmp_path / "x").exists() or not any((tmp_path / "x").iterdir())
    bin_dir = Path(sys.executable).parent  # python, without chromium on PATH
    p = runners_cli("figures", "--only", "rerun_viewer", "--out", str(tmp_path / "y"), fmu_path=fmu_path,
                    env={"PATH": str(bin_dir)})
    assert p.returncode == 0 and p.stdout == "", p.stderr
    assert p.stderr.count("\n") == 1 and p.stderr.startswith("note: skipped rerun_viewer:") and "Chromium" in p.stderr


def test_docs_figures_md_lists_every_figure_and_how_to_draw_it():
    """docs/figures.md has a row for every PNG in docs/figures, which runners figures draws, with
    the command that draws it alone."""
    from runners.analysis.figures import FIGURES, NAMES

    pngs = sorted(p.stem for p in (ROOT / "docs" / "figures").glob("*.png"))
    assert sorted(NAMES) == pngs
    table = (ROOT / "docs" / "figures.md").read_text()
    rows = {m.group(1): line for line in table.splitlines() for m in [re.match(r"\| `?(\w+)\.png`? \|", line)] if m}
    assert sorted(rows) == pngs
    for fig in FIGURES:
        for name in fig.names:
            assert fig.command.split(";")[0].strip() in rows[name], name
