"""Valid sweep axes that were refused (issue 36, item 13): friction axes on rocking–sliding stacks,
where friction changes the motion, and a grid value a rounding of np.linspace puts a few ulps above
block 1's half width. The real FMU through the real sweep, into real SQLite files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import runners
from conftest import run_cli
from db.schema import Run
from db.session import open_database

ROOT = Path(__file__).resolve().parent.parent
PULSE = '\n[excitation]\nkind = "sine-pulse"\namplitude = 6.0\nfrequency = 1.5\n[simulation]\nstop_time = 3.0\n'


def marble(tmp_path: Path, contact: str = "rocking-sliding") -> Path:
    """examples/marble_statue_on_plinth.toml (a rocking–sliding stack, mu 0.5 at both contacts)
    under a one-sine pulse, with the contact model `contact`."""
    text = (ROOT / "examples" / "marble_statue_on_plinth.toml").read_text()
    path = tmp_path / "marble.toml"
    path.write_text(text.replace('model = "rocking-sliding"', f'model = "{contact}"') + PULSE)
    return path


def one_line_error(p) -> str:
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("error:"), p.stderr
    return p.stderr


def stored(url: str) -> dict[int, Run]:
    with open_database(url)() as s:
        return {r.grid_index: (r.status, r.error_message, r.point, r.summary and r.summary.block2_max_abs_slip,
                               r.summary and r.summary.max_abs_slip) for r in s.query(Run).all()}


def test_friction_axes_of_a_rocking_sliding_stack_run_and_change_the_motion(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'm.db'}"
    p = run_cli("sweep", str(marble(tmp_path)), "--grid", "contact.muInterface=0.3:0.7:2", "--grid",
                "contact.muGround=0.3:0.7:2", "--quiet", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    runs = stored(url)
    assert [runs[i][0] for i in range(4)] == ["ok"] * 4
    # block 2 slides on block 1 by another amount with another mu between them, block 1 on the ground likewise
    assert runs[0][3] != runs[2][3] and runs[0][4] != runs[1][4]


def test_the_python_api_takes_a_friction_axis_of_a_stack(tmp_path, fmu_path):
    sw = runners.sweep(marble(tmp_path), grid={"contact.muInterface": (0.3, 0.7, 2)}, workers=1,
                       db=f"sqlite:///{tmp_path / 'api.db'}", fmu=fmu_path)
    points = sw.to_pandas()
    assert list(points["contact.muInterface"]) == [0.3, 0.7] and (points["status"] == "ok").all()
    assert points["block2_max_abs_slip"].nunique() == 2


def test_friction_axes_of_rigid_rocking_and_the_interface_of_one_block_stay_refused(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'r.db'}"
    for axis in ("contact.muInterface=0.3:0.7:2", "contact.muGround=0.3:0.7:2"):
        err = one_line_error(run_cli("sweep", str(marble(tmp_path, "rigid-rocking")), "--grid", axis, db=url,
                                     fmu_path=fmu_path))
        assert "with rigid rocking friction does not change the motion" in err
    one = tmp_path / "one.toml"
    one.write_text('[block]\nhalf_width = 0.3\nhalf_height = 0.36\n[contact]\nmodel = "rocking-sliding"' + PULSE)
    err = one_line_error(run_cli("sweep", str(one), "--grid", "contact.muInterface=0.3:0.7:2", db=url,
                                 fmu_path=fmu_path))
    assert "contact.muInterface is the friction between two blocks, and the scene has one" in err
    assert not (tmp_path / "r.db").exists() or not stored(url)


def test_a_grid_width_a_rounding_above_block_1_runs_as_equal_widths(tmp_path, fmu_path):
    """block2.halfWidth=0.1:0.2:3 gives 0.15000000000000002 in the middle (np.linspace), against a
    block 1 of 0.15: block 2 as wide as block 1, which a rocking–sliding stack may have; 0.2 is wider."""
    middle = float(np.linspace(0.1, 0.2, 3)[1])
    assert middle > 0.15  # the rounding this is about
    scene = tmp_path / "stack.toml"
    scene.write_text('[block]\nhalf_width = 0.15\nhalf_height = 0.5\n[block2]\nhalf_width = 0.1\n'
                     'half_height = 0.3\n[contact]\nmodel = "rocking-sliding"' + PULSE)
    url = f"sqlite:///{tmp_path / 'w.db'}"
    sw = runners.sweep(scene, grid={"block2.halfWidth": (0.1, 0.2, 3)}, workers=1, db=url, fmu=fmu_path)
    runs = stored(url)
    assert runs[1][0] == "ok" and runs[1][2]["block2.halfWidth"] == middle, runs[1]  # the grid's value is kept
    assert runs[2][0] == "error" and "no wider than block 1" in runs[2][1]  # 0.2 > 0.15: refused as before
    ran = runners.open_db(url).run(int(sw.to_pandas().set_index("grid_index").loc[1, "run_id"]))
    assert ran.parameters["block2.halfWidth"] == 0.15 == ran.parameters["block1.halfWidth"]  # what the FMU ran
