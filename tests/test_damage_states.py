"""Studies as engineers report them (issue 25): fragility and IDA per grid combination (never
pooled), damage states per block of a stack (overturning of block 1, of block 2, rotation beyond
a fraction of alpha) checked against an independent maximum-likelihood fit of the exported
points, each block's own demands in the IDA, and the refusals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize
from scipy.special import log_ndtr
from sqlalchemy import select

from conftest import run_cli
from db.schema import Run, RunSummary
from db.session import open_database
from test_record_sweeps import db, template  # noqa: F401  (fixtures: a database with the 28 near-field records)

G0 = 9.80665
RECORDS = "1,2,3,4,5,6,7,8,9,10,11,12"
STATUE = 'name = "statue"\n[block]\nhalf_width = 0.125\nhalf_height = 0.5\nmass = 150\n'
# a slender plinth (0.3 m x 1.0 m) carrying a statue (0.3 m x 0.8 m): either can overturn alone
PLINTH = ('name = "statue on plinth"\n[block]\nhalf_width = 0.15\nhalf_height = 0.5\nmass = 300\n'
          "[block2]\nhalf_width = 0.15\nhalf_height = 0.4\nmass = 80\n")


def _run(*args, db, fmu_path):
    return run_cli(*args, db=db, fmu_path=fmu_path)


def independent_fit(points: list[dict]) -> tuple[float, float]:
    """(median, beta) maximising the binomial likelihood of the points' fractions per level
    (Baker 2015 eq. 11), found as the root of its gradient in (ln median, beta) by scipy, from a
    Nelder-Mead start: written here, not by calling runners' fit. Only the points in the fit
    ("in_fit": the runs the model did not answer are left out by default)."""
    points = [p for p in points if p.get("in_fit", True)]
    x = np.array([p["x"] for p in points])
    y = np.array([p["reached"] for p in points], dtype=float)
    levels = np.unique(x)
    n = np.array([np.sum(x == v) for v in levels], dtype=float)
    k = np.array([y[x == v].sum() for v in levels])
    lx = np.log(levels)

    def nll(q):
        mu, beta = q
        if beta <= 0:
            return np.inf
        eta = (lx - mu) / beta
        return -float(np.sum(k * log_ndtr(eta) + (n - k) * log_ndtr(-eta)))

    def gradient(q):
        mu, beta = q
        eta = (lx - mu) / beta
        log_phi = -0.5 * eta**2 - 0.5 * math.log(2 * math.pi)
        dl = k * np.exp(log_phi - log_ndtr(eta)) - (n - k) * np.exp(log_phi - log_ndtr(-eta))
        return np.array([np.sum(dl * -1.0 / beta), np.sum(dl * -eta / beta)])

    start = optimize.minimize(nll, [float(np.median(lx)), 0.5], method="Nelder-Mead",
                              options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000}).x
    sol = optimize.root(gradient, start, method="hybr", options={"xtol": 1e-13})
    assert np.max(np.abs(gradient(sol.x))) < 1e-9 * n.sum(), sol.message  # a stationary point, to rounding
    assert nll(sol.x) <= nll(start) + 1e-9  # the root is the maximum Nelder-Mead approached
    return math.exp(sol.x[0]), float(sol.x[1])


def stored_runs(db_url: str, sweep_id: int) -> dict[tuple[str, float], RunSummary]:
    with open_database(db_url)() as s:
        rows = s.execute(select(Run, RunSummary).join(RunSummary, RunSummary.run_id == Run.id)
                         .where(Run.sweep_id == sweep_id)).all()
        return {(r.point["record"], r.point["level"], round(r.point.get("block1.halfWidth", 0.0), 9)): (r, rs)
                for r, rs in rows}


def test_a_sweep_with_an_extra_grid_axis_gives_one_curve_per_combination_never_pooled(db, fmu_path, tmp_path):
    """The issue's repro, smaller: a record sweep with --grid block1.halfWidth=...:3 and --im pgv.
    Before, fragility pooled the three blocks into one curve titled with one of them."""
    scene = tmp_path / "statue.toml"
    scene.write_text(STATUE)
    p = _run("sweep", str(scene), "--records", RECORDS, "--im", "pgv=0.2:1.6:6", "--grid",
             "block1.halfWidth=0.1:0.15:3", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    png = tmp_path / "f.png"
    p = _run("fragility", "latest", "--im", "pgv", "--out", str(png), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["axes"] == ["block1.halfWidth"] and len(out["curves"]) == 3 and "median" not in out
    stored = stored_runs(db, 1)
    medians = []
    for curve, b in zip(out["curves"], (0.1, 0.125, 0.15)):
        assert curve["combination"] == {"block1.halfWidth": pytest.approx(b, rel=1e-12)}
        assert curve["block"] == f"one block {2 * b:g} m wide, 1 m high"
        assert curve["runs"] == 72 and curve["records"] == 12  # 12 records x 6 levels, not 216
        for pt in curve["points"]:  # every point is a run of this block, with its own outcome
            _, summary = stored[(pt["record"], pt["x"], round(b, 9))]
            assert pt["reached"] == summary.overturned
        assert independent_fit(curve["points"]) == pytest.approx((curve["median"], curve["beta"]), rel=1e-9)
        medians.append(curve["median"])
    assert medians[0] < medians[1] < medians[2]  # wider blocks are harder to topple
    text = _run("fragility", "1", "--im", "pgv", "--out", str(png), db=db, fmu_path=fmu_path).stdout
    assert text.count("at block1.halfWidth = ") == 3 and "one block 0.2 m wide" in text and "0.3 m wide" in text
    # one combination on request; a value or axis the sweep did not run is refused in one line
    one = json.loads(_run("fragility", "1", "--im", "pgv", "--select", "block1.halfWidth=0.125", "--out", str(png),
                          "--json", db=db, fmu_path=fmu_path).stdout)
    assert len(one["curves"]) == 1 and one["median"] == out["curves"][1]["median"] and one["runs"] == 72
    for args, expected in ((["--select", "block1.halfWidth=0.13"], "ran block1.halfWidth at 0.1, 0.125, 0.15 only"),
                           (["--select", "block1.halfHeight=0.5"], "does not vary block1.halfHeight"),
                           (["--select", "block1.halfWidth"], "expected NAME=VALUE")):
        e = _run("fragility", "1", *args, "--out", str(png), db=db, fmu_path=fmu_path)
        assert e.returncode == 2 and expected in e.stderr and e.stderr.count("\n") == 1, e.stderr
    # the IDA too: one set of runs per combination, each run with its block's value
    ida = json.loads(_run("ida", "1", "--out", str(tmp_path / "i.png"), "--json", db=db, fmu_path=fmu_path).stdout)
    assert len(ida["combinations"]) == 3 and len(ida["runs"]) == 216
    assert sorted({r["block1.halfWidth"] for r in ida["runs"]}) == pytest.approx([0.1, 0.125, 0.15])
    # the Python API: one combination must be chosen, or all taken
    import runners
    from runners.engine.study import StudyError

    sw = runners.open_db(db).sweep(1)
    with pytest.raises(StudyError, match=r"varies block1.halfWidth \(0.1, 0.125, 0.15\).*select"):
        sw.fragility("pgv")
    assert sw.fragility("pgv", select={"block1.halfWidth": 0.15}).median == out["curves"][2]["median"]
    assert [c.outcomes.combination["block1.halfWidth"] for c in sw.fragilities("pgv")] == pytest.approx(
        [0.1, 0.125, 0.15])


def test_a_statue_on_a_plinth_gives_a_curve_per_block_and_damage_state_equal_to_an_independent_fit(
        db, fmu_path, tmp_path):
    """Acceptance (issue 25): block 1 overturning, block 2 overturning and rotation beyond 0.5
    alpha, in one figure and in JSON, each the maximum-likelihood fit of its exported points."""
    scene = tmp_path / "plinth.toml"
    scene.write_text(PLINTH)
    p = _run("sweep", str(scene), "--records", RECORDS, "--im", "pga=0.15:1.35:13", "--quiet", db=db,
             fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    png = tmp_path / "states.png"
    states = ["block1:overturn", "block2:overturn", "rot>0.5alpha"]
    p = _run("fragility", "1", *[a for ds in states for a in ("--ds", ds)], "--out", str(png), "--json", db=db,
             fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["damage_states"] == states and [c["damage_state"] for c in out["curves"]] == states
    stored = {key[:2]: v for key, v in stored_runs(db, 1).items()}
    counts = {}
    for curve in out["curves"]:
        assert curve["runs"] == 156 and len(curve["points"]) == 156
        for pt in curve["points"]:  # the state as each run stored it
            _, s = stored[(pt["record"], pt["x"])]
            over = (s.overturned_blocks or "").split(",")
            expected = {"block1:overturn": "1" in over, "block2:overturn": "2" in over,
                        "rot>0.5alpha": "1" in over or "2" in over or s.peak1_over_alpha > 0.5
                        or s.peak2_over_alpha > 0.5}[curve["damage_state"]]
            assert pt["reached"] == expected
        counts[curve["damage_state"]] = curve["reached"]
        assert curve["median"] is not None, curve["why"]
        assert independent_fit(curve["points"]) == pytest.approx((curve["median"], curve["beta"]), rel=1e-9)
    # the blocks fall separately: the statue alone most often, the plinth sometimes
    assert 0 < counts["block1:overturn"] < counts["block2:overturn"] <= counts["rot>0.5alpha"] < 156
    # the run ends when the statue falls off: the plinth's curve says what it counts
    alone = sum(1 for _, s in stored.values() if s.overturned_blocks == "2")
    assert alone > 0 and any(f"in {alone} of 156 runs block 2 fell off first" in n for n in out["curves"][0]["notes"])
    assert not any("fell off first" in n for c in out["curves"][1:] for n in c["notes"])
    assert png.stat().st_size > 30_000
    text = _run("fragility", "1", *[a for ds in states for a in ("--ds", ds)], "--out", str(png), db=db,
                fmu_path=fmu_path).stdout
    for ds, label in zip(states, ("block 1 overturned", "block 2 overturned", "either block: peak |theta| / alpha")):
        assert f"{ds} " in text and label in text
    # the same curves from Python, drawn on one figure
    import matplotlib

    matplotlib.use("Agg")
    import runners
    from runners.analysis import study_figures

    curves = runners.open_db(db).sweep(1).fragilities("pga", states)
    assert [(c.fragility.median, c.fragility.beta) for c in curves] == \
        [(c["median"], c["beta"]) for c in out["curves"]]
    fig = study_figures.curves_figure(curves)
    panels = [ax for ax in fig.axes if ax.get_legend() is not None]  # (a strip below counts unanswered runs)
    legend = [t.get_text().replace("\n", " ") for t in panels[0].get_legend().get_texts()]
    assert len(panels) == 1 and all(any(c.label in t for t in legend) for c in curves)
    assert runners.open_db(db).sweep(1).fragility(ds="block1:overturn").median == out["curves"][0]["median"]


def test_the_ida_of_a_stack_shows_each_blocks_own_peak_and_overturn(db, fmu_path, tmp_path):
    """Before, the plinth's panel drew the plinth as overturned whenever the statue fell, and
    ida --json had no block-2 demands."""
    import matplotlib

    matplotlib.use("Agg")
    from runners.analysis import study_figures
    from runners.engine import study

    scene = tmp_path / "plinth.toml"
    scene.write_text(PLINTH)
    assert _run("sweep", str(scene), "--records", "1,2,3,4,5,6", "--im", "pga=0.3:1.3:5", "--quiet", db=db,
                fmu_path=fmu_path).returncode == 0
    out = json.loads(_run("ida", "1", "--out", str(tmp_path / "ida.png"), "--json", db=db, fmu_path=fmu_path).stdout)
    stored = {key[:2]: v for key, v in stored_runs(db, 1).items()}
    statue_alone = 0
    for r in out["runs"]:
        _, s = stored[(r["record"], r["x"])]
        over = (s.overturned_blocks or "").split(",")
        assert (r["block1_overturned"], r["block2_overturned"]) == ("1" in over, "2" in over)
        assert (r["peak1_over_alpha"], r["peak2_over_alpha"]) == (s.peak1_over_alpha, s.peak2_over_alpha)
        statue_alone += r["block2_overturned"] and not r["block1_overturned"]
    assert statue_alone > 0
    oc = study.outcome_sets(open_database(db), 1)[0]
    fig = study_figures.ida_figure(oc)
    plinth = fig.axes[1]  # block 1's demand axes (above it, the strip of its overturns)
    names = list(dict.fromkeys(oc.record))
    answered = np.ones(len(oc.x), bool) if oc.broke is None else ~oc.broke
    for name, line in zip(names, plinth.get_lines()[:len(names)]):  # one line per record, in order
        sel = np.array([r == name for r in oc.record])
        order = np.argsort(oc.x[sel])
        # the plinth's own peak, even where the statue fell; broken where the plinth overturned or
        # where rigid rocking did not answer the run
        standing = ~oc.over1[sel][order] & answered[sel][order]
        expected = np.where(standing, oc.peak1[sel][order], np.nan)
        assert np.array_equal(line.get_ydata(), expected, equal_nan=True)
    legend = [t.get_text() for t in plinth.get_legend().get_texts()]
    assert legend[:len(names)] == names


def test_damage_states_that_are_not_stored_or_not_in_the_scene_are_refused_in_one_line(db, fmu_path, tmp_path):
    scene = tmp_path / "statue.toml"
    scene.write_text(STATUE)
    assert _run("sweep", str(scene), "--records", RECORDS, "--im", "pga=0.15:1.35:9", "--quiet", db=db,
                fmu_path=fmu_path).returncode == 0
    png = str(tmp_path / "f.png")
    for ds, expected in (("slide>0.05", "runs rigid rocking, which computes no slip: set contact.model = "
                                        "rocking-sliding"),
                         ("block2:overturn", "the scene has one block"),
                         ("rot>-1alpha", "must be a number above 0"),
                         ("rot>0.5", "unknown damage state"),
                         ("plinth:overturn", "is not a block")):
        p = _run("fragility", "1", "--ds", ds, "--out", png, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and expected in p.stderr and p.stderr.count("\n") == 1, (ds, p.stderr)
    # what is stored is offered: whether a contact needed more friction than its mu
    out = json.loads(_run("fragility", "1", "--ds", "overturn", "--ds", "slides", "--out", png, "--json", db=db,
                          fmu_path=fmu_path).stdout)
    stored = {key[:2]: v for key, v in stored_runs(db, 1).items()}
    slides = out["curves"][1]
    assert slides["damage_state"] == "slides" and len(slides["points"]) == 108
    assert all(pt["reached"] == (stored[(pt["record"], pt["x"])][1].slide_time is not None) for pt in slides["points"])
    text = _run("fragility", "1", "--out", png, db=db, fmu_path=fmu_path).stdout
    # the uplift threshold with both g's named: the model's 9.81 m/s2 and PGA's g0
    assert f"{0.25 * 9.81 / G0:.4g} g" in text and "with the model's g = 9.81 m/s2" in text and str(G0) in text
    import runners
    from runners.errors import ArgumentError, RockingError

    sw = runners.open_db(db).sweep(1)
    with pytest.raises(ArgumentError):
        sw.fragility(ds=["overturn"])
    with pytest.raises(ArgumentError):
        sw.fragilities(ds="overturn")
    with pytest.raises(RockingError, match="unknown damage state 'tilt'"):
        sw.fragilities(ds=["tilt"])
