"""Per-block outcomes of a stack in the runners: the summary, the stored row, the export, and
fragility and IDA per block and per damage state (statue overturns, statue falls off, plinth
slides more than D, plinth overturns), for the rigid stack and the rocking–sliding stack.

Every number is checked against the FMU's own outputs read through fmpy's simulate_fmu (not
through runners.engine.fmu), and the damage states are counted here from those outputs, not
taken from the code under test."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import select

import runners
from conftest import run_cli
from db.schema import Run, RunSummary
from db.session import open_database
from test_damage_states import independent_fit
from test_record_sweeps import db, template  # noqa: F401  (fixtures: a database with the 28 near-field records)

# a plinth 0.6 m x 1.0 m (450 kg) carrying a statue 0.4 m x 1.6 m (690 kg), half sizes in m
STACK = {"block1.halfWidth": 0.3, "block1.halfHeight": 0.5, "block1.mass": 450.0,
         "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 690.0, "nBlocks": 2}
SLIDING = {**STACK, "contact.model": 1, "contact.muGround": 0.5}
FINAL = ["block1.overturned", "block2.overturned", "overturnTime", "block1.maxAbsTheta", "block2.maxAbsTheta",
         "impactsGround", "impactsInterface"]
SLIP = [f"block{i}.{n}" for i in (1, 2) for n in ("slip", "maxAbsSlip", "slideDuration", "slideStartTime")] + [
    "block2.fellOff", "block2.fellOffTime", "liftTime"]
STOP = 4.0
STEP = 0.01


def scene(params: dict, amplitude: float, frequency: float) -> dict:
    """A scene dict of a stack under a one-sine pulse (m/s2, Hz)."""
    s = {"name": "statue on plinth", "block": {"half_width": params["block1.halfWidth"],
                                               "half_height": params["block1.halfHeight"],
                                               "mass": params["block1.mass"]},
         "block2": {"half_width": params["block2.halfWidth"], "half_height": params["block2.halfHeight"],
                    "mass": params["block2.mass"]},
         "excitation": {"kind": "sine-pulse", "amplitude": amplitude, "frequency": frequency},
         "simulation": {"stop_time": STOP, "step": STEP}}
    if params.get("contact.model") == 1:
        s["contact"] = {"model": "rocking-sliding", "mu_ground": params["contact.muGround"]}
        if "contact.muInterface" in params:
            s["contact"]["mu_interface"] = params["contact.muInterface"]
    return s


def fmpy_run(fmu_path: Path, params: dict, stop: float, interval: float, names: list[str]):
    """The FMU's own outputs (fmpy.simulate_fmu, Co-Simulation) sampled every `interval` s; the
    blocks start at rest, as a scene's (docs/scenes.md)."""
    from fmpy import simulate_fmu

    return simulate_fmu(str(fmu_path), start_values={"block1.theta0": 0.0, **params}, stop_time=stop,
                        output_interval=interval,
                        output=names, fmi_type="CoSimulation")


def pulse(amplitude: float, frequency: float) -> dict:
    return {"excitation.kind": 1, "excitation.amplitude": amplitude, "excitation.frequency": frequency}


# ------------------------------------------------------------------ rigid stack: which block overturned


@pytest.mark.parametrize("amplitude, frequency, case", [(6.0, 0.5, "both"), (3.0, 0.5, "block 2"), (6.0, 1.0, "none")])
def test_a_rigid_stack_says_which_block_overturned_as_the_fmu_does(tmp_path, fmu_path, amplitude, frequency, case):
    res = fmpy_run(fmu_path, {**STACK, **pulse(amplitude, frequency)}, STOP, STEP, FINAL)
    fmu = {n: res[n][-1] for n in FINAL}
    fell = [i for i in (1, 2) if fmu[f"block{i}.overturned"]]
    assert {"both": [1, 2], "block 2": [2], "none": []}[case] == fell  # the scene shows the case it is named for
    url = f"sqlite:///{tmp_path / 'runs.db'}"
    r = runners.simulate(scene(STACK, amplitude, frequency), store=True, db=url, fmu=fmu_path)
    blocks = r.summary["per_block"]
    assert [b["block"] for b in blocks] == [1, 2]
    for b in blocks:
        i = b["block"]
        assert b["overturned"] == bool(fmu[f"block{i}.overturned"])
        assert b["max_abs_theta_rad"] == pytest.approx(fmu[f"block{i}.maxAbsTheta"], rel=1e-12, abs=1e-15)
        assert (b["overturn_time_s"] is None) == (not b["overturned"])
        if b["overturned"]:
            assert b["overturn_time_s"] == pytest.approx(fmu["overturnTime"], rel=1e-12)
        assert "motion" not in b and "fell_off" not in b  # rigid rocking: no slip, no falling off
    assert blocks[1]["with_block1"] == (fell == [1, 2])  # block 1 takes block 2 with it
    with open_database(url)() as s:
        row = s.get(RunSummary, r.run_id)
        assert row.overturned_blocks == (",".join(map(str, fell)) or None)
        assert row.block2_motion is None and row.block2_fell_off is None and row.motion is None
    outcome = next(line for line in r.report.splitlines() if line.startswith("outcome"))
    assert ("taking block 2 with it" in outcome) == (fell == [1, 2])
    assert ("block 2 overturned" in outcome) == (fell == [2])


# ------------------------------------------------------------------ rocking–sliding stack: one run


def independent_motion(res, i: int, out: dict) -> str:
    """Block i's motion class from the sampled FMU series: it slid if its slip ever changed, it
    rocked (block 1 on the ground, block 2 on block 1) if its rotation relative to what it
    stands on ever left 0; written here from the series, not from the counters the code reads."""
    if out[f"block{i}.overturned"]:
        return "overturns"
    if i == 2 and out["block2.fellOff"]:
        return "falls-off"
    slip = np.asarray(res[f"block{i}.slip"])
    theta1 = np.asarray(res["block1.theta"])
    rot = theta1 if i == 1 else np.asarray(res["block2.theta"]) - theta1
    slid = bool(np.any(slip != slip[0])) or out[f"block{i}.maxAbsSlip"] > 0
    rocked = bool(np.max(np.abs(rot)) > 1e-9)
    return {(True, True): "slide-rocks", (True, False): "slides", (False, True): "rocks",
            (False, False): "rests"}[(slid, rocked)]


# a squat box (0.5 m x 0.6 m, 100 kg) on the plinth, its top slippery (mu 0.1): it slides off
SQUAT_BOX = {**SLIDING, "block2.halfWidth": 0.25, "block2.halfHeight": 0.3, "block2.mass": 100.0,
             "contact.muGround": 5.0, "contact.muInterface": 0.1}


@pytest.mark.parametrize("stack, amplitude, frequency, case", [
    (SQUAT_BOX, 6.0, 0.5, "falls-off"), (SLIDING, 6.0, 2.0, "overturns"), (SLIDING, 6.0, 1.0, "rocks"),
    ({**SLIDING, "contact.muInterface": 0.22}, 3.5, 1.5, "slide-rocks")])
def test_a_sliding_stack_run_summarises_and_stores_each_contact_as_the_fmu_does(tmp_path, fmu_path, stack, amplitude,
                                                                                 frequency, case):
    names = FINAL + SLIP + ["block1.theta", "block2.theta", "liftTime"]
    res = fmpy_run(fmu_path, {**stack, **pulse(amplitude, frequency)}, STOP, STEP, names)
    out = {n: res[n][-1] for n in names}
    motions = [independent_motion(res, i, out) for i in (1, 2)]
    assert motions[1] == case  # the scene shows what it is named for
    url = f"sqlite:///{tmp_path / 'runs.db'}"
    r = runners.simulate(scene(stack, amplitude, frequency), store=True, db=url, fmu=fmu_path)
    blocks = r.summary["per_block"]
    for b, motion in zip(blocks, motions):
        i = b["block"]
        assert b["motion"] == motion, (i, b)
        assert b["max_abs_slip_m"] == pytest.approx(out[f"block{i}.maxAbsSlip"], rel=1e-12, abs=1e-15)
        assert b["residual_slip_m"] == pytest.approx(out[f"block{i}.slip"], rel=1e-12, abs=1e-15)
        assert b["slide_duration_s"] == pytest.approx(out[f"block{i}.slideDuration"], rel=1e-12, abs=1e-15)
        start = out[f"block{i}.slideStartTime"]
        assert b["slide_start_time_s"] == (None if start < 0 else pytest.approx(start, rel=1e-12))
        assert b["max_abs_slip_m"] >= np.max(np.abs(res[f"block{i}.slip"])) - 1e-15  # never below a sample
    fell = bool(out["block2.fellOff"])
    assert blocks[1]["fell_off"] == fell
    assert blocks[1]["fell_off_time_s"] == (pytest.approx(out["block2.fellOffTime"], rel=1e-12) if fell else None)
    with open_database(url)() as s:
        row = s.get(RunSummary, r.run_id)
        stored = {k: getattr(row, k) for k in ("motion", "max_abs_slip", "residual_slip", "slide_duration",
                                               "block2_motion", "block2_max_abs_slip", "block2_residual_slip",
                                               "block2_slide_duration", "block2_fell_off", "block2_fell_off_time",
                                               "overturned_blocks")}
    assert stored["motion"] == motions[0] and stored["block2_motion"] == motions[1]
    for key, name in (("max_abs_slip", "block1.maxAbsSlip"), ("residual_slip", "block1.slip"),
                      ("block2_max_abs_slip", "block2.maxAbsSlip"), ("block2_residual_slip", "block2.slip"),
                      ("block2_slide_duration", "block2.slideDuration")):
        assert stored[key] == pytest.approx(out[name], rel=1e-12, abs=1e-15), key
    assert stored["block2_fell_off"] == fell
    assert (stored["block2_fell_off_time"] is None) == (not fell)
    assert stored["overturned_blocks"] == (",".join(str(i) for i in (1, 2) if out[f"block{i}.overturned"]) or None)
    # the text: one line per block, with block 2's fall off block 1 at the FMU's time
    lines = r.report.splitlines()
    upper = next(line for line in lines if line.startswith("block 2 (")).split()
    assert upper[2] == f"({motions[1]})"
    # the contact engine follows flight: no run ends outside the model
    assert r.summary["final_state"] != "flight" and out["liftTime"] < 0
    if fell:
        assert f"fell off block 1 at t = {out['block2.fellOffTime']:.4f} s" in " ".join(upper)
        outcome = next(line for line in lines if line.startswith("outcome"))
        assert outcome.startswith("outcome          block 2 fell off")
    # read back through the Python API as stored
    back = runners.open_db(url).run(r.run_id).summary
    assert back["block2_motion"] == motions[1] and back["block2_fell_off"] == fell
    assert back["block2_max_abs_slip"] == stored["block2_max_abs_slip"]


# ------------------------------------------------------------------ a study of the statue on its plinth

RECORDS = "1,2,3,4,5,6,7,8"
STATES = ["block2:overturn", "block2:falloff", "block1:slide>5cm", "block1:overturn"]


def plinth_scene(tmp_path: Path) -> Path:
    path = tmp_path / "statue_on_plinth.toml"
    path.write_text('name = "statue on a free plinth"\n[block]\nhalf_width = 0.3\nhalf_height = 0.5\nmass = 450\n'
                    "[block2]\nhalf_width = 0.2\nhalf_height = 0.8\nmass = 690\n"
                    '[contact]\nmodel = "rocking-sliding"\nmu_ground = 0.5\n[simulation]\nstop_time = 20.0\n')
    return path


def fmu_outcomes(db_url: str, sweep_id: int, fmu_path: Path) -> dict[tuple[str, float], dict]:
    """Each stored point of the sweep run again through fmpy (one step to the end, as a sweep
    point), keyed by (record, PGA level): the FMU's own final outputs."""
    from runners.engine.sweep import stored_point_parameters

    out = {}
    with open_database(db_url)() as s:
        for run in s.scalars(select(Run).where(Run.sweep_id == sweep_id)):
            p = stored_point_parameters(s, run)
            start = {k: v for k, v in p.items() if not isinstance(v, str) or k == "excitation.file"}
            res = fmpy_run(fmu_path, start, run.stop_time, run.stop_time, FINAL + SLIP)
            out[(run.point["record"], round(run.point["level"], 9))] = {n: float(res[n][-1]) for n in FINAL + SLIP}
    return out


def reached_here(state: str, o: dict) -> bool:
    """Whether the FMU's outputs `o` of one run reach `state`, counted here."""
    return {"block2:overturn": bool(o["block2.overturned"]),
            "block2:falloff": bool(o["block2.fellOff"]),
            "block1:slide>5cm": bool(o["block1.overturned"]) or o["block1.maxAbsSlip"] > 0.05,
            "block1:overturn": bool(o["block1.overturned"])}[state]


def test_fragility_and_ida_of_a_sliding_stack_count_each_block_and_damage_state_as_the_fmu_runs_say(
        db, fmu_path, tmp_path):  # noqa: F811
    p = run_cli("sweep", str(plinth_scene(tmp_path)), "--records", RECORDS, "--im", "pga=0.1:1.2:8", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    fmu = fmu_outcomes(db, 1, fmu_path)
    assert len(fmu) == 64
    counts = {s: sum(reached_here(s, o) for o in fmu.values()) for s in STATES}
    assert counts["block2:overturn"] > 0 and counts["block2:falloff"] > 0  # the study has both kinds of loss
    p = run_cli("fragility", "1", *[a for s in STATES for a in ("--ds", s)], "--out", str(tmp_path / "f.png"),
                "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["damage_states"] == ["block2:overturn", "block2:falloff", "block1:slide>0.05m", "block1:overturn"]
    flights = sum(o["liftTime"] >= 0 for o in fmu.values())
    assert flights == 0  # the contact engine follows flight: every run of the study is answered
    for state, curve in zip(STATES, doc["curves"]):
        assert curve["reached"] == counts[state], state
        for pt in curve["points"]:
            o = fmu[(pt["record"], round(pt["x"], 9))]
            assert pt["reached"] == reached_here(state, o), (state, pt)
            # a run that ended in flight (a contact lifted off: outside the model) answers only what it
            # reached before; the rest is left out of the fit
            assert pt["in_fit"] == pt["answered"] == (reached_here(state, o) or o["liftTime"] < 0), (state, pt)
        assert curve["unanswered"]["runs"] == sum(o["liftTime"] >= 0 and not reached_here(state, o)
                                                  for o in fmu.values()) <= flights
        if curve["median"] is not None and curve["reached"] >= 5:
            median, beta = independent_fit(curve["points"])
            assert curve["median"] == pytest.approx(median, rel=1e-6) and curve["beta"] == pytest.approx(beta, rel=1e-6)
    assert (tmp_path / "f.png").stat().st_size > 10_000
    # each contact's sliding: block 1 on the ground, block 2 on block 1
    p = run_cli("fragility", "1", "--ds", "block1:slides", "--ds", "block2:slides", "--out", str(tmp_path / "s.png"),
                "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    for i, curve in zip((1, 2), json.loads(p.stdout)["curves"]):
        for pt in curve["points"]:
            o = fmu[(pt["record"], round(pt["x"], 9))]
            assert pt["reached"] == (o[f"block{i}.maxAbsSlip"] > 0 or o[f"block{i}.slideDuration"] > 0), (i, pt)
    # IDA: each block's own demands, as the FMU computed them
    for block, want in ((None, [1, 2]), ("2", [2]), ("1", [1])):
        args = ["ida", "1", "--demand", "slip", "--out", str(tmp_path / f"ida{block}.png"), "--json"]
        p = run_cli(*args, *(["--block", block] if block else []), db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
        doc = json.loads(p.stdout)
        assert doc["blocks"] == want and doc["demand_unit"] == "m"
    for run in doc["runs"]:
        o = fmu[(run["record"], round(run["x"], 9))]
        b1, b2 = run["blocks"]
        assert b1["max_abs_slip"] == pytest.approx(o["block1.maxAbsSlip"], rel=1e-9, abs=1e-14)
        assert b2["max_abs_slip"] == pytest.approx(o["block2.maxAbsSlip"], rel=1e-9, abs=1e-14)
        assert b2["fell_off"] == bool(o["block2.fellOff"]) and b2["overturned"] == bool(o["block2.overturned"])
        assert b1["overturned"] == bool(o["block1.overturned"])
    # the sweep's export has the per-block columns, as the FMU computed them
    out = tmp_path / "sweep.csv"
    p = run_cli("export", "--sweep", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with out.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 64 and {"block2_motion", "block2_max_abs_slip", "block2_fell_off"} <= set(rows[0])
    fell = sum(str(r["block2_fell_off"]).lower() in ("true", "1") for r in rows)
    assert fell == counts["block2:falloff"]


@pytest.mark.parametrize("args, words", [
    (["fragility", "1", "--ds", "block1:falloff"], "only block 2 can fall off"),
    (["fragility", "1", "--ds", "block2:slide>5xm"], "D in slide>D must be a distance"),
    (["fragility", "1", "--ds", "block3:overturn"], "is not a block"),
    (["fragility", "1", "--ds", "block2:fall"], "unknown damage state"),
    (["ida", "1", "--block", "3"], "--block '3': expected 1"),
    (["ida", "1", "--block", "two"], "--block 'two': expected 1"),
    (["fragility", "2", "--ds", "block2:falloff"], "runs the rigid stack"),
    (["fragility", "2", "--ds", "block2:slide>5cm"], "computes no slip"),
    (["ida", "3", "--block", "2"], "has one block"),
    (["fragility", "3", "--ds", "block2:falloff"], "has one block"),
])
def test_bad_damage_states_and_blocks_are_one_line_errors(db, fmu_path, tmp_path, args, words):  # noqa: F811
    rigid = tmp_path / "rigid.toml"
    rigid.write_text(plinth_scene(tmp_path).read_text().replace('model = "rocking-sliding"', 'model = "rigid-rocking"'))
    one = tmp_path / "one.toml"
    one.write_text('name = "one"\n[block]\nhalf_width = 0.125\nhalf_height = 0.5\nmass = 150\n')
    for path in (plinth_scene(tmp_path), rigid, one):  # sweeps 1 (sliding stack), 2 (rigid stack), 3 (one block)
        p = run_cli("sweep", str(path), "--records", "1,2,3", "--im", "pga=0.2:0.8:3", "--quiet", db=db,
                    fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
    p = run_cli(*args, "--out", str(tmp_path / "x.png"), db=db, fmu_path=fmu_path)
    assert p.returncode != 0 and p.stdout == ""
    assert p.stderr.startswith("error: ") and p.stderr.count("\n") == 1 and words in p.stderr, p.stderr


def test_a_sliding_stack_recording_draws_block_two_where_both_contacts_slid(tmp_path, fmu_path):
    """A squat box on a plinth, both sliding flat (mu 0.2 on the floor, 0.1 between them): the
    recording holds block 2's slip, and draws its base's centre at block 1's slip plus its own."""
    from test_recording import column, read_back

    stack = {**SLIDING, "block2.halfWidth": 0.25, "block2.halfHeight": 0.3, "block2.mass": 100.0,
             "contact.muGround": 0.2, "contact.muInterface": 0.1}
    rrd = tmp_path / "stack.rrd"
    r = runners.simulate(scene(stack, 3.0, 1.0), recording=rrd, fmu=fmu_path)
    s1, s2 = r.series["block1.slip"].to_numpy(), r.series["block2.slip"].to_numpy()
    th1, th2 = r.series["block1.theta"].to_numpy(), r.series["block2.theta"].to_numpy()
    assert np.abs(s1).max() > 0.01 and np.abs(s2).max() > 0.01 and not th1.any() and not th2.any()
    table = read_back(rrd)
    _, rows = column(table, "/block2/slip")
    np.testing.assert_array_equal(np.array([row[1][0] for row in rows]), s2)
    time_ = r.series.index.to_numpy() if "time" not in r.series.columns else r.series["time"].to_numpy()
    ft, frames = column(table, "/scene/block2", "LineStrips2D:strips")
    _, ground = column(table, "/scene/ground", "LineStrips2D:strips")
    far = 0
    for tf, (_, strips), (_, g) in zip(ft, frames, ground):
        i = int(np.argmin(np.abs(time_ - tf)))
        corners = np.array(strips[0])
        base_x = 0.5 * (corners[0][0] + corners[1][0])
        line = np.array(g[0])
        assert base_x - 0.5 * (line[0][0] + line[1][0]) == pytest.approx(s1[i] + s2[i], abs=2e-6), tf
        far += abs(s1[i] + s2[i]) > 0.01
    assert far > 0
