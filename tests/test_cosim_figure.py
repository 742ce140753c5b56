"""The co-simulation figure (runners cosim --out, docs/figures/cosim_cabinet.png) says what a reviewer
needs: the blocks, friction, contact model, coupling and step in its title, the block's slenderness
+-alpha and its impacts on the rotation panel, the two-way floor without spikes at impacts, and a legend that covers no data. Drawn from real runs of the example cabinet."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from runners.analysis.cosim import figure
from runners.engine import cosim

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def drawn(fmu_path, building_fmu_path):
    system = replace(cosim.load_system(ROOT / "examples" / "cabinet_on_floor.toml"), stop_time=1.5)
    results = [cosim.run(replace(system, coupling=c), block_fmu=fmu_path, building_fmu=building_fmu_path)
               for c in cosim.COUPLINGS]
    results.append(cosim.run(replace(system, coupling="two-way"), block_fmu=fmu_path, building_fmu=building_fmu_path,
                             interpolate=False))  # held inputs: libcosim's algorithm
    fig = figure(results, title=system.name)
    fig.canvas.draw()
    return fig, results


def test_the_title_names_blocks_friction_contact_model_building_and_step(drawn):
    fig, _ = drawn
    title = fig._suptitle.get_text()
    for words in ("heavy cabinet on a light floor", "0.6 m x 2 m", "1000 kg", "rocking-sliding", "mu = 0.5",
                  "floor 3 of a 3-storey", "h = 0.001 s", "fmpy"):
        assert words in title, (words, title)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "one-way coupling" in labels and "two-way coupling" in labels


def test_the_rotation_panel_has_alpha_and_the_impacts(drawn):
    fig, results = drawn
    rotation = fig.axes[2]
    alpha = float(np.arctan2(0.3, 1.0))
    levels = sorted(line.get_ydata()[0] for line in rotation.lines if len(set(line.get_ydata())) == 1
                    and line.get_linestyle() == "--")
    assert levels == pytest.approx([-alpha, alpha])
    marks = [line for line in rotation.lines if line.get_marker() == "o"]
    assert [len(m.get_xdata()) for m in marks] == [int(r["block.impacts"][-1]) for r in results]
    assert all(len(m.get_xdata()) >= 2 for m in marks)


def test_the_two_way_floor_has_no_impact_spike(drawn):
    """The blocks' floor's acceleration, two-way, is the blocks' FMU's (the floor's mass with their forces at each
    instant; an impulse changes its velocity): on the building's frame its peak stays within the base's and the
    one-way floor's scale, with held inputs too, and every curve is inside the panel."""
    fig, results = drawn
    one, two_way, held = results
    assert (one.scheme, two_way.scheme, held.scheme) == ("interpolated", "interface", "held")
    lo, hi = fig.axes[0].get_ylim()
    for r in results:
        assert np.max(np.abs(r.floor("a"))) / 9.81 < hi
    assert np.max(np.abs(held.floor("a"))) < 1.5 * np.max(np.abs(one.floor("a")))
    assert not [line for line in fig.axes[0].lines if line.get_marker() in ("^", "v")]
    assert "two-way coupling (held inputs)" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_the_legend_covers_no_data(drawn):
    fig, _ = drawn
    renderer = fig.canvas.get_renderer()
    legend = fig.legends[0].get_window_extent(renderer)
    for ax in fig.axes:
        assert not legend.overlaps(ax.get_window_extent(renderer)), ax.get_ylabel()
    assert not [ax for ax in fig.axes if ax.get_legend() is not None]
