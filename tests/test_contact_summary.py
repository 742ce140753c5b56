"""The run summary states whether the rigid-rocking assumptions held; --strict makes a
violation a non-zero exit (docs/contact.md, docs/cli.md)."""

from __future__ import annotations

import json
import math

from conftest import run_cli

ROOT_EXAMPLE = "examples/sine_pulse.toml"
SQUAT = """name = "squat block, strong pulse"
[block]
half_width = 0.25
half_height = 0.3
[restitution]
law = "constant"
[contact]
mu_ground = {mu}
[excitation]
kind = "sine-pulse"
amplitude = 9.0
frequency = 2.0
[simulation]
stop_time = 2.0
step = 0.01
"""


def _squat(tmp_path, mu=0.7):
    path = tmp_path / "squat.toml"
    path.write_text(SQUAT.format(mu=mu))
    return str(path)


def test_a_squat_block_that_slides_is_reported_and_strict_fails(tmp_path, db_url, fmu_path):
    p = run_cli("simulate", _squat(tmp_path), "--json", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    a = json.loads(p.stdout)["assumptions"]
    assert not a["held"] and a["lifts"] is None and a["slides"]["contact"] == "ground"
    assert abs(a["slides"]["t_s"] - math.asin(0.7 * 9.81 / 9.0) / (2 * math.pi * 2.0)) <= 1e-9
    assert a["friction_demand_max_ground"] > a["mu_ground"] == 0.7

    text = run_cli("simulate", _squat(tmp_path), "--strict", db=db_url, fmu_path=fmu_path)
    assert text.returncode == 4
    assert "assumptions      NOT HELD: slides on the ground at t = 0.0690686 s" in text.stdout
    assert text.stderr.strip().splitlines() == [
        "error: rigid rocking did not hold (--strict): slides on the ground at t = 0.0690686 s "
        "(friction demand up to 0.853, mu 0.7)"]


def test_enough_friction_keeps_the_same_scene_clean(tmp_path, db_url, fmu_path):
    p = run_cli("simulate", _squat(tmp_path, mu=1.0), "--strict", "--json", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    a = json.loads(p.stdout)["assumptions"]
    assert a["held"] and a["slides"] is None and a["lifts"] is None
    assert 0 < a["friction_demand_max_ground"] < 1.0 and a["normal_min_ground"] > 0


def test_the_summary_line_of_a_clean_run(db_url, fmu_path):
    p = run_cli("simulate", ROOT_EXAMPLE, "--strict", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if x.startswith("assumptions"))
    assert line.startswith("assumptions      held: no sliding (friction demand at most 0.")
    assert "mu 0.7); no flight (normal force at least 0." in line


def test_strict_needs_a_method_that_monitors_the_contacts(db_url, fmu_path):
    """Refused before the run: nothing printed, nothing stored."""
    from sqlalchemy import func, select

    from db.schema import Run
    from db.session import open_database

    for method in ("rk4", "closed-form"):
        p = run_cli("simulate", ROOT_EXAMPLE, "--method", method, "--strict", db=db_url, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stdout == ""
        assert p.stderr.strip().count("\n") == 0 and "--strict" in p.stderr and "--method fmu" in p.stderr
    with open_database(db_url)() as s:
        assert s.scalar(select(func.count()).select_from(Run)) == 0


def test_runs_and_sweep_points_store_the_assumptions(tmp_path, db_url, fmu_path):
    from sqlalchemy import select

    from db.schema import Run, RunSummary
    from db.session import open_database

    p = run_cli("simulate", _squat(tmp_path), db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli("sweep", _squat(tmp_path), "--grid", "excitation.amplitude=4.5:9.0:2", "--quiet", db=db_url,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db_url)() as s:
        single = s.scalars(select(RunSummary).join(Run).where(Run.sweep_id.is_(None))).one()
        assert single.assumptions_held is False and single.lift_time is None
        assert abs(single.slide_time - math.asin(0.7 * 9.81 / 9.0) / (4 * math.pi)) <= 1e-9
        assert single.friction_demand_max > 0.7 and single.normal_min > 0
        points = {r.point["excitation.amplitude"]: r.summary
                  for r in s.scalars(select(Run).where(Run.sweep_id.is_not(None)))}
    slid, clean = points[9.0], points[4.5]
    assert slid.assumptions_held is False and abs(slid.slide_time - math.asin(0.7 * 9.81 / 9.0) / (4 * math.pi)) <= 1e-9
    assert clean.assumptions_held is True and clean.slide_time is None and clean.friction_demand_max < 0.7


def test_a_sweep_over_friction_is_refused_because_friction_does_not_change_the_motion(tmp_path, db_url, fmu_path):
    """The friction coefficients enter the contact monitors only: a grid over them would run one
    simulation many times. The sweep says so in one line, stores nothing, and names what each run
    stores instead (the friction demand, against which any mu can be read)."""
    from sqlalchemy import func, select

    from db.schema import Sweep
    from db.session import open_database

    stack = tmp_path / "stack.toml"
    stack.write_text(SQUAT.format(mu=0.7) + "[block2]\nhalf_width = 0.1\nhalf_height = 0.2\n")
    for scene, axis, column in ((_squat(tmp_path), "contact.muGround=0.5:1.0:2", "friction_demand_max"),
                                (str(stack), "contact.muInterface=0.3:0.9:3", "friction_demand_max_interface")):
        p = run_cli("sweep", scene, "--grid", axis, "--quiet", db=db_url, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
        assert "friction does not change the motion" in p.stderr and column in p.stderr
    with open_database(db_url)() as s:
        assert s.scalar(select(func.count()).select_from(Sweep)) == 0


def test_the_recording_shows_the_friction_demand_against_mu(tmp_path, fmu_path):
    """The .rrd read back: /contact/ground/demand is |T| / N of the run's reactions, /mu the line
    it must stay under, and the demand crosses it where the run reports sliding."""
    import numpy as np

    import runners
    from test_recording import column, read_back

    rrd = tmp_path / "squat.rrd"
    run = runners.simulate(_squat(tmp_path), fmu=fmu_path, recording=rrd, db=f"sqlite:///{tmp_path / 'r.db'}")
    table = read_back(rrd)
    t, rows = column(table, "/contact/ground/demand")
    demand = np.array([r[1][0] if r[1] else np.nan for r in rows], float)
    T, N = run.series["contact.groundT"].to_numpy(), run.series["contact.groundN"].to_numpy()
    np.testing.assert_allclose(t, run.series.index.to_numpy(), rtol=0, atol=1e-9)
    np.testing.assert_allclose(demand, np.abs(T) / N, rtol=1e-12)
    _, mu_rows = column(table, "/contact/ground/mu")
    assert {r[1][0] for r in mu_rows} == {0.7}
    slide = run.summary["assumptions"]["slides"]["t_s"]
    assert np.all(demand[t < slide - 0.01] <= 0.7) and np.any(demand[t > slide] > 0.7)


def test_a_run_that_slides_only_while_it_falls_held_until_the_fall(tmp_path, db_url, fmu_path):
    """A block toppled by a pulse slides or lifts off while it falls past its corner; rigid
    rocking still decided that it falls: the line says so and --strict passes. At the reported
    violation the block is already beyond its stability limit."""
    from runners.engine.fmu import RockingFMU

    scene = tmp_path / "topple.toml"
    scene.write_text('name = "h/b = 2 toppled"\n[block]\nhalf_width = 0.03\nhalf_height = 0.06\n'
                     '[excitation]\nkind = "sine-pulse"\namplitude = 6.0\nfrequency = 1.5\n'
                     "[simulation]\nstop_time = 3.0\n")
    p = run_cli("simulate", str(scene), "--strict", "--json", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    a = s["assumptions"]
    assert s["overturned"] and not a["held"] and a["outcome_held"]
    first = min(a[k]["t_s"] for k in ("slides", "lifts") if a[k])
    assert a["fall_time_s"] < first < s["overturn_time_s"]
    params = {"block1.halfWidth": 0.03, "block1.halfHeight": 0.06, "excitation.kind": 1,
              "excitation.amplitude": 6.0, "excitation.frequency": 1.5}
    with RockingFMU(fmu_path) as fmu:
        theta = fmu.run(params, first, first, outputs=["block1.theta"]).outputs["block1.theta"][-1]
    assert abs(theta) > math.atan2(0.03, 0.06)
    text = run_cli("simulate", str(scene), "--no-store", db=db_url, fmu_path=fmu_path).stdout
    assert "assumptions      held until the overturning fall (from t = " in text


def test_the_map_marks_points_where_rigid_rocking_broke_first(tmp_path, fmu_path):
    """A 6 x 6 map of Anagnostopoulos's h/b = 2 block: the marked points are exactly those whose
    first sliding or lift-off came while every state so far was within the block's limit, which
    a single run at the violation time confirms (|theta| <= alpha there; beyond alpha for the
    points that overturned and slid only during the fall). The PNG shows the marks."""
    import matplotlib.image as mpimg
    import numpy as np
    from sqlalchemy import select

    from db.schema import Run
    from db.session import open_database
    from runners.analysis.sweep_map import BROKE_COLOUR, broke
    from runners.engine.fmu import RockingFMU

    db = f"sqlite:///{tmp_path / 'map.db'}"
    p = run_cli("sweep", "examples/fig18_housner.toml", "--grid", "w=1:8:6", "--grid", "a=1.5:6:6", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    png = tmp_path / "map.png"
    m = run_cli("map", "latest", "--out", str(png), db=db, fmu_path=fmu_path)
    assert m.returncode == 0, m.stderr
    n_broke = int(m.stdout.split("rigid rocking broke first at ")[1].split(";")[0])
    js = json.loads(run_cli("map", "latest", "--out", str(tmp_path / "again.png"), "--json", db=db,
                            fmu_path=fmu_path).stdout)
    assert js["rigid_rocking_broke"] == n_broke and sum(js["regions"].values()) == 36
    with open_database(db)() as s:
        runs = list(s.scalars(select(Run).where(Run.sweep_id == 1)))
        points = [(r.point["w"], r.point["a"], broke(r), r.summary.overturned,
                   min(t for t in (r.summary.slide_time, r.summary.lift_time, math.inf) if t is not None))
                  for r in runs]
    assert 0 < n_broke == sum(b for *_, b, _, _ in points) < 36
    b, h, g = 0.03, 0.06, 9.81
    alpha, pf = math.atan2(b, h), math.sqrt(3 * g / (4 * math.hypot(b, h)))
    checked = {"inside": 0, "falling": 0}
    with RockingFMU(fmu_path) as fmu:
        for w, a, mark, fell, first in points:
            if not fell or not math.isfinite(first):
                continue
            params = {"block1.halfWidth": b, "block1.halfHeight": h, "excitation.kind": 1,
                      "excitation.amplitude": a * g * b / h, "excitation.frequency": w * pf / (2 * math.pi)}
            theta = fmu.run(params, first, first, outputs=["block1.theta"]).outputs["block1.theta"][-1]
            if mark:
                assert abs(theta) <= alpha, (w, a)
                checked["inside"] += 1
            else:
                assert abs(theta) > alpha, (w, a)
                checked["falling"] += 1
    assert checked["inside"] and checked["falling"]
    image = mpimg.imread(png)[..., :3]
    colour = np.array([int(BROKE_COLOUR[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    assert np.sum(np.all(np.abs(image - colour) < 0.02, axis=-1)) > 50


SLENDER_PULSE = """name = "slender block, one-sine pulse"
[block]
half_width = 0.05
half_height = 0.5
[contact]
mu_ground = {mu}
[excitation]
kind = "sine-pulse"
amplitude = 3.0
frequency = 2.0
[simulation]
stop_time = 3.0
"""


def test_method_auto_refuses_to_call_a_scene_fine_when_rigid_rocking_breaks(tmp_path, db_url, fmu_path):
    """auto picks the closed form for a slender block under a one-sine pulse. On a slippery floor
    (mu = 0.05 < b/h = 0.1, the pulse above mu g) the block slides before it can tip: rigid rocking
    does not suffice, and auto runs rocking-sliding instead, saying why. With mu = 0.7 the
    closed form is called sufficient. A stack that slides runs the rocking-sliding stack (below)."""
    scene = tmp_path / "slender.toml"
    scene.write_text(SLENDER_PULSE.format(mu=0.05))
    p = run_cli("simulate", str(scene), "--method", "auto", "--accuracy", "0.05", "--json", db=db_url,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["model"] == "rocking-sliding" and s["model_sufficient"] is True
    start = math.asin(0.05 * 9.81 / 3.0) / (4 * math.pi)
    assert abs(s["slide_start_time_s"] - start) <= 1e-9
    assert f"mu 0.05 (the block slides from t = {start:.6g} s): rocking-sliding used" in s["model_reason"]
    scene.write_text(SLENDER_PULSE.format(mu=0.7))
    ok = run_cli("simulate", str(scene), "--method", "auto", "--accuracy", "0.05", db=db_url, fmu_path=fmu_path)
    assert ok.returncode == 0, ok.stderr
    assert "model check      sufficient: rigid rocking held until the outcome was decided" in ok.stdout
    fmu_run = run_cli("simulate", _squat(tmp_path), "--method", "auto", "--json", db=db_url, fmu_path=fmu_path)
    assert fmu_run.returncode == 0, fmu_run.stderr
    assert json.loads(fmu_run.stdout)["model"] == "rocking-sliding"


def test_method_auto_checks_the_interface_of_a_stack_it_runs_as_one_block(tmp_path, db_url, fmu_path):
    """A negligible upper block lets auto run the lower block alone, but only the two-block
    model sees the interface: on a slippery one (mu 0.01) auto must not call the one-block answer
    fine; the upper block slides, so it runs the rocking-sliding stack, named by its interface."""
    scene = tmp_path / "stack.toml"
    scene.write_text('name = "negligible upper block"\n[block]\nhalf_width = 0.1\nhalf_height = 0.3\nmass = 10.0\n'
                     "[block2]\nhalf_width = 0.1\nhalf_height = 0.2\nmass = 0.00001\n[contact]\nmu_interface = 0.01\n"
                     '[excitation]\nkind = "sine-pulse"\namplitude = 5.0\nfrequency = 3.0\n'
                     "[simulation]\nstop_time = 2.0\n")
    p = run_cli("simulate", str(scene), "--method", "auto", "--json", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["rigid_rocking_assumptions"]["slides"]["contact"] == "interface"  # the two-block monitors saw it
    assert s["model"] == "rocking-sliding stack" and s["sliding_contact"] == "interface"
    assert "between the blocks" in s["model_reason"] and s["model_sufficient"] is True


def test_a_block_released_beyond_its_limit_falls_from_the_start(db_url, fmu_path, tmp_path):
    """theta0 > alpha and nothing else: it falls; what slides or lifts on the way down does
    not change that, so the run held until its fall, which starts at t = 0."""
    scene = tmp_path / "tilted.toml"
    scene.write_text('name = "released past its corner"\n[block]\nhalf_width = 0.1\nhalf_height = 0.3\n'
                     "theta0 = 0.4\n[simulation]\nstop_time = 3.0\n")
    p = run_cli("simulate", str(scene), "--strict", "--json", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["overturned"] and s["assumptions"]["fall_time_s"] == 0.0 and s["assumptions"]["outcome_held"]


def test_a_one_block_scene_with_an_interface_friction_gets_a_note(tmp_path, db_url, fmu_path):
    scene = tmp_path / "one.toml"
    scene.write_text('name = "one block"\n[block]\nhalf_width = 0.1\nhalf_height = 0.3\n[contact]\nmu_interface = 0.2\n'
                     "[simulation]\nstop_time = 0.5\n")
    p = run_cli("simulate", str(scene), "--no-store", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0 and "contact.muInterface is the friction between two blocks" in p.stderr
