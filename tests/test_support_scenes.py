"""Scene files with a [building] or a [platform] (runners.engine.supports, docs/scenes.md): the tables
become the FMU's support parameters, the runs are the FMU's own, and bad tables are refused in one
line before anything runs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import runners
from model.support_reference import read_at2
from runners.engine.scene import SceneError, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
PULSE = str(ROOT / "examples" / "pulse_3hz.AT2")
CABINET = {"block": {"half_width": 0.3, "half_height": 1.0, "mass": 1000.0},
           "contact": {"model": "rocking-sliding", "mu_ground": 0.5},
           "excitation": {"file": PULSE}, "simulation": {"stop_time": 4.0}}
FRAME = {"storeys": 3, "mass": [2000.0, 2000.0, 2000.0], "stiffness": 2.5e6, "damping_ratio": 0.02}
ONE_WAY = {"mode": "one-way"}


def test_a_building_table_sets_the_fmus_support():
    p = scene_from_dict({**CABINET, "building": FRAME, "coupling": ONE_WAY}).parameters
    assert p["support.coupling"] == 0
    assert scene_from_dict({**CABINET, "building": FRAME}).parameters["support.coupling"] == 1  # two-way, the default
    assert p["support.kind"] == 1 and p["building.storeys"] == 3 and p["building.floor"] == 3  # the top
    assert [p[f"building.storey[{i}].mass"] for i in (1, 2, 3)] == [2000.0] * 3
    assert [p[f"building.storey[{i}].stiffness"] for i in (1, 2, 3)] == [2.5e6] * 3
    p = scene_from_dict({**CABINET, "building": FRAME, "coupling": {"floor": 2, **ONE_WAY}}).parameters
    assert p["building.floor"] == 2
    p = scene_from_dict({**CABINET, "platform": {"mass": 800.0, "stiffness": 4e4}, "coupling": ONE_WAY}).parameters
    assert (p["support.kind"], p["platform.mass"], p["platform.stiffness"], p["platform.damping"]) == (2, 800.0, 4e4, 0.0)


def test_the_scene_runs_the_floor_the_fmu_is_given(fmu, tmp_path):
    """runners.simulate of a scene on the second floor is the FMU run with the same parameters."""
    scene = {**CABINET, "building": FRAME, "coupling": {"floor": 2, **ONE_WAY}}
    result = runners.simulate(scene, stop_time=4.0)
    assert result.summary["support"].startswith("shear building, 3 storeys")
    t, a = read_at2(PULSE)
    record = tmp_path / "pulse.txt"
    np.savetxt(record, np.column_stack([t, a]), fmt="%.17g")
    p = {**scene_from_dict(scene).parameters, "excitation.kind": 4, "excitation.file": str(record)}
    direct = fmu.run(p, 4.0, 0.001, ["block1.maxAbsTheta", "impacts"])
    assert result.summary["impacts"] == int(direct.outputs["impacts"][-1]) > 0
    assert result.summary["max_abs_theta_rad"] == pytest.approx(direct.outputs["block1.maxAbsTheta"][-1], abs=1e-12)
    on_top = runners.simulate({**CABINET, "building": FRAME, "coupling": ONE_WAY}, stop_time=4.0)  # another floor, another motion
    assert abs(on_top.summary["max_abs_theta_rad"] - result.summary["max_abs_theta_rad"]) > 1e-3


def test_a_statue_on_an_isolator_does_not_tip_where_it_rocks_on_the_ground():
    on_platform = runners.simulate(ROOT / "examples" / "statue_on_isolator.toml")
    on_ground = runners.simulate(ROOT / "examples" / "statue_on_isolator.toml", support__kind=0)
    assert on_platform.summary["impacts"] == 0 and on_platform.summary["max_abs_theta_rad"] == 0.0
    assert on_ground.summary["impacts"] > 10


@pytest.mark.parametrize("tables, words", [
    ({"building": FRAME, "platform": {"mass": 1.0}}, "not both"),
    ({"coupling": {"floor": 1}}, "needs a [building] or a [platform]"),
    ({"building": FRAME, "coupling": {"mode": "sideways"}}, "[coupling] mode must be one of one-way, two-way"),
    ({"building": FRAME, "coupling": {"floor": 4, **ONE_WAY}}, "[coupling] floor must be a floor of the building, 1 to 3"),
    ({"building": {**FRAME, "stiffness": [1.0, 2.0]}, "coupling": ONE_WAY}, "stiffness: 2 values for 3 storeys"),
    ({"building": {**FRAME, "height": 3.0}, "coupling": ONE_WAY}, "[building] unknown key 'height'"),
    ({"platform": {"stiffness": 1.0}, "coupling": ONE_WAY}, "[platform] needs mass"),
    ({"platform": {"mass": 1.0, "damping": -1.0}, "coupling": ONE_WAY}, "[platform] damping must be a number >= 0"),
    ({"platform": {"mass": 1.0}, "coupling": {"floor": 1, **ONE_WAY}}, "floor is a building's"),
    ({"building": 3}, "'building' must be a table"),
])
def test_bad_support_tables_are_refused_in_one_line(tables, words):
    with pytest.raises(SceneError) as err:
        scene_from_dict({**CABINET, **tables}, "floor.toml")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_the_command_line_refuses_a_bad_support_with_status_2(tmp_path):
    scene = tmp_path / "floor.toml"
    scene.write_text(f'[excitation]\nfile = "{PULSE}"\n[building]\nstoreys = 2\nmass = 1000.0\nstiffness = -1.0\n'
                     '[coupling]\nmode = "one-way"\n')
    db = tmp_path / "runs.db"
    done = subprocess.run([sys.executable, "-m", "runners.cli", "simulate", str(scene), "--db", f"sqlite:///{db}"],
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "[building] stiffness: expected positive numbers" in done.stderr
    assert "Traceback" not in done.stderr and not db.exists()


def test_python_solvers_refuse_a_support():
    with pytest.raises(runners.RockingError, match="runs inside the FMU"):
        runners.simulate({**CABINET, "contact": {"model": "rigid-rocking"}, "building": FRAME, "coupling": ONE_WAY},
                         method="scipy")


def test_taylor_on_a_building_runs_one_way_and_is_refused_two_way_in_one_line(fmu_path, tmp_path):
    """The Taylor series integrates rigid rocking on a one-way support, not on a two-way one: a scene that asks for
    it on a building (two-way by default) runs with --coupling one-way, and is refused in one line (exit status 2)
    without it, by runners simulate and by runners sweep, before anything is stored."""
    from conftest import run_cli

    db = f"sqlite:///{tmp_path / 'r.db'}"
    scene = tmp_path / "taylor_floor.toml"
    scene.write_text(f'[block]\nhalf_width = 0.2\nhalf_height = 0.8\n[contact]\nmodel = "rigid-rocking"\n'
                     f'[simulation]\nmethod = "taylor"\nstop_time = 3.0\n[excitation]\nfile = "{PULSE}"\n'
                     '[building]\nstoreys = 2\nmass = 2000.0\nstiffness = 2.5e6\n')
    p = run_cli("simulate", str(scene), "--coupling", "one-way", "--no-store", "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["support"].endswith("one-way")
    for args in (("simulate", str(scene), "--no-store"), ("simulate", str(scene), "--coupling", "two-way"),
                 ("sweep", str(scene), "--grid", "scale=0.5:1.0:2")):
        p = run_cli(*args, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, (args, p.stderr)
        assert "on a two-way support the contact engine integrates it" in p.stderr
    if (tmp_path / "r.db").exists():  # (the database may exist, empty of sweeps and runs)
        import sqlite3

        with sqlite3.connect(tmp_path / "r.db") as con:
            tables = {r[0] for r in con.execute("select name from sqlite_master where type = 'table'")}
            assert all(con.execute(f"select count(*) from {t}").fetchone()[0] == 0
                       for t in ("sweeps", "runs") if t in tables)


def test_simulate_couples_the_support_as_the_command_line_says(fmu_path, tmp_path):
    """runners simulate --coupling one-way | two-way runs the scene's building so, as runners.simulate does with
    support.coupling; a scene on the ground is refused in one line with exit status 2."""
    from conftest import run_cli

    db = f"sqlite:///{tmp_path / 'r.db'}"
    scene = ROOT / "examples" / "cabinet_on_floor.toml"
    got = {}
    for mode in ("one-way", "two-way"):
        p = run_cli("simulate", str(scene), "--coupling", mode, "--no-store", "--json", db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
        got[mode] = json.loads(p.stdout)
        assert got[mode]["support"].endswith(mode)
        api = runners.simulate(scene, support__coupling=["one-way", "two-way"].index(mode)).summary
        assert (got[mode]["impacts"], got[mode]["max_abs_theta_rad"]) == (api["impacts"], api["max_abs_theta_rad"])
    assert got["one-way"]["max_abs_theta_rad"] != got["two-way"]["max_abs_theta_rad"]
    p = run_cli("simulate", str(ROOT / "examples" / "statue.toml"), "--coupling", "two-way", "--no-store", db=db,
                fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "has none" in p.stderr
