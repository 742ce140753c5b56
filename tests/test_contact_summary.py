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
    p = run_cli("simulate", ROOT_EXAMPLE, "--method", "rk4", "--strict", "--no-store", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 2
    assert p.stderr.strip().count("\n") == 0 and "--strict" in p.stderr and "--method fmu" in p.stderr


def test_runs_and_sweep_points_store_the_assumptions(tmp_path, db_url, fmu_path):
    from sqlalchemy import select

    from db.schema import Run, RunSummary
    from db.session import open_database

    p = run_cli("simulate", _squat(tmp_path), db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli("sweep", _squat(tmp_path), "--grid", "contact.muGround=0.5:1.0:2", "--quiet", db=db_url,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db_url)() as s:
        single = s.scalars(select(RunSummary).join(Run).where(Run.sweep_id.is_(None))).one()
        assert single.assumptions_held is False and single.lift_time is None
        assert abs(single.slide_time - math.asin(0.7 * 9.81 / 9.0) / (4 * math.pi)) <= 1e-9
        assert single.friction_demand_max > 0.7 and single.normal_min > 0
        points = {r.point["contact.muGround"]: r.summary for r in s.scalars(select(Run).where(Run.sweep_id.is_not(None)))}
    slid, clean = points[0.5], points[1.0]
    assert slid.assumptions_held is False and abs(slid.slide_time - math.asin(0.5 * 9.81 / 9.0) / (4 * math.pi)) <= 1e-9
    assert clean.assumptions_held is True and clean.slide_time is None and clean.friction_demand_max < 1.0


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
