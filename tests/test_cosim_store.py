"""Co-simulated runs in the database (runners.engine.cosim_store, docs/cosimulation.md#stored-runs):
a real co-simulation of the cabinet on its building (0.5 s) stored into a real SQLite file, read back
through the Python API and the command line bit for bit, with the system, engine, coupling and step it
ran with; runners cosim stores by default (both runs of --compare), --no-store stores nothing, a bad
--db is one line and touches nothing, and a run the database does not take is kept in a file that
runners db import-unsaved stores. No mocks: the FMUs, the database and the files are real."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import runners
from runners.analysis import cosim as checks
from runners.engine import cosim, cosim_store
from tests.conftest import run_cli

ROOT = Path(__file__).resolve().parents[1]
STOP = 0.5  # s: the cabinet's first rocking and its first impact, at a 1 ms step


@pytest.fixture
def place(tmp_path, building_fmu_path, monkeypatch) -> Path:
    """A folder with the cabinet's system (stopped at STOP), its base record, and the building's FMU
    the command line uses."""
    monkeypatch.setenv("ROCKING_BUILDING_FMU", str(building_fmu_path))
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROOT / "examples" / "pulse_3hz.AT2", tmp_path / "pulse_3hz.AT2")
    text = (ROOT / "examples" / "cabinet_on_floor.toml").read_text()
    (tmp_path / "system.toml").write_text(text.replace("stop_time = 4.0", f"stop_time = {STOP}"))
    return tmp_path


def digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_line_error(p: subprocess.CompletedProcess, *words: str) -> str:
    assert p.returncode == 2 and p.stdout == "", (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "unexpected" not in lines[0], p.stderr
    assert "Traceback" not in p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def test_the_api_stores_a_run_and_reads_it_back_bit_for_bit(place, fmu_path, building_fmu_path):
    from db.session import open_database

    url = f"sqlite:///{place / 'r.db'}"
    system = cosim.load_system(place / "system.toml", open_database(url))  # the base record is stored there
    result = cosim.run(replace(system, coupling="one-way"), block_fmu=fmu_path, building_fmu=building_fmu_path)
    summary = checks.run_summary(result)
    cosim_id = cosim_store.store(result, summary, db=url, wall_time=0.25)

    stored = runners.open_db(url).cosim(cosim_id)
    assert stored.cosim_id == cosim_id and stored.engine == "fmpy"
    assert np.array_equal(stored.time, result.time) and stored.time.dtype == result.time.dtype
    assert list(stored.series) == list(result.series)
    for name, values in result.series.items():
        assert np.array_equal(stored[name], values), name  # every output, bit for bit
    s = stored.system
    assert (s.name, s.coupling, s.step, s.floor, s.stop_time) == (system.name, "one-way", 0.001, 3, STOP)
    assert (s.building.mass, s.building.stiffness, s.building.damping_ratio) == ([2000.0] * 3, [2.5e6] * 3, 0.02)
    assert s.blocks == system.blocks and (s.base_scale, s.base_start) == (1.0, 0.0)
    assert s.record == {"id": system.record["id"], "name": "pulse_3hz"} and system.record["id"] is not None
    assert stored.block_parameters == result.block_parameters
    assert stored.building_parameters == replace(system, coupling="one-way").building_parameters()
    assert stored.summary == summary and stored.wall_time == 0.25
    assert stored.source == (place / "system.toml").read_text()
    assert checks.run_summary(stored) == summary  # the analysis takes a stored run as a fresh one

    table = runners.open_db(url).cosims()
    assert table.index.tolist() == [cosim_id]
    row = table.loc[cosim_id]
    assert (row["name"], row["engine"], row["coupling"], row["step"], row["stop_time"], row["record"]) == \
        (system.name, "fmpy", "one-way", 0.001, STOP, "pulse_3hz")
    assert row["impacts"] == summary["impacts"] and row["peak_abs_theta"] == summary["peak_abs_theta"]


def test_the_command_line_stores_both_runs_of_compare_and_reads_them_back(place, fmu_path):
    db = str(place / "r.db")
    p = run_cli("cosim", "system.toml", "--compare", "--csv", "s.csv", "--json", "--db", db, "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    one, two = doc["runs"]
    assert doc["database"] == f"sqlite:///{db}" and (one["cosim_id"], two["cosim_id"]) == (1, 2)

    for d, coupling in ((one, "one-way"), (two, "two-way")):
        # the series the command wrote to --csv (every float to 17 digits) are the ones it stored
        written = pd.read_csv(place / f"s-{coupling}.csv")
        stored = runners.open_db(db).cosim(d["cosim_id"])
        assert stored.system.coupling == coupling and stored.engine == "fmpy" and stored.system.step == 0.001
        assert np.array_equal(stored.time, written["time"].to_numpy())
        for name in stored.series:
            assert np.array_equal(stored[name], written[name].to_numpy()), name
        assert stored.summary == {k: v for k, v in d.items() if k not in ("seconds", "cosim_id")}

        # db show and export read the same run
        shown = run_cli("db", "show", "cosim", str(d["cosim_id"]), "--db", db, db=db, fmu_path=fmu_path)
        assert shown.returncode == 0, shown.stderr
        row = json.loads(shown.stdout)
        assert (row["engine"], row["coupling"], row["step"], row["stop_time"], row["storeys"], row["floor"]) == \
            ("fmpy", coupling, 0.001, STOP, 3, 3)
        assert row["system"]["building"]["mass"] == [2000.0] * 3 and row["record"]["name"] == "pulse_3hz"
        assert row["source"] == (place / "system.toml").read_text() and row["series"]["n_samples"] == 500
        out = place / f"export-{coupling}.csv"
        ex = run_cli("export", "--cosim", str(d["cosim_id"]), "--out", str(out), "--db", db, db=db, fmu_path=fmu_path)
        assert ex.returncode == 0, ex.stderr
        exported = pd.read_csv(out)
        assert exported.columns.tolist() == ["time", *stored.series]
        assert all(np.array_equal(exported[c].to_numpy(), written[c].to_numpy()) for c in exported.columns)

    listed = run_cli("db", "list", "cosims", "--db", db, db=db, fmu_path=fmu_path)
    assert listed.returncode == 0, listed.stderr
    lines = listed.stdout.splitlines()
    assert lines[0].startswith("co-simulated runs: 2 in ") and "one-way" in lines[3] and "two-way" in lines[2]
    as_json = json.loads(run_cli("db", "list", "cosims", "--json", "--db", db, db=db, fmu_path=fmu_path).stdout)
    assert [r["id"] for r in as_json["cosims"]] == [2, 1]

    # the text summary names each stored run
    text = run_cli("cosim", "system.toml", "--db", db, "--quiet", db=db, fmu_path=fmu_path)
    assert text.returncode == 0 and f"stored as co-simulated run 3 in sqlite:///{db}" in text.stdout, text.stderr


def test_no_store_stores_nothing_and_a_failed_run_stores_nothing(place, fmu_path):
    db = str(place / "r.db")
    p = run_cli("cosim", "system.toml", "--no-store", "--json", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "cosim_id" not in json.loads(p.stdout)["runs"][0] and not (place / "r.db").exists()
    # floors of 20 kg under the 1 t cabinet at 10 ms: two-way coupling diverges (docs/cosimulation.md#limits)
    (place / "diverges.toml").write_text((place / "system.toml").read_text().replace("mass = 2000.0", "mass = 20.0")
                                         .replace(f"stop_time = {STOP}", "stop_time = 1.0"))
    p = run_cli("cosim", "diverges.toml", "--step", "0.01", "--db", db, "--quiet", db=db, fmu_path=fmu_path)
    one_line_error(p, "two-way coupling diverged")
    assert runners.open_db(db).cosims().empty


@pytest.mark.parametrize("bad, words", [
    ("notes.txt", ["notes.txt is not an SQLite database", "left untouched"]),
    ("missing/r.db", ["cannot create the database missing/r.db: its folder"]),
    ("nope://x", ["cannot use database URL 'nope://x'"]),
])
def test_a_bad_db_is_one_line_and_touches_nothing(place, fmu_path, bad, words):
    (place / "notes.txt").write_text("not a database\n")
    (place / "old.csv").write_text("an earlier series\n")
    before = digests(place)
    exe = Path(sys.executable).parent / "runners"  # the console script, in its own process
    p = subprocess.run([str(exe), "cosim", "system.toml", "--csv", "old.csv", "--db", bad, "--fmu", str(fmu_path)],
                       capture_output=True, text=True, cwd=place, timeout=300)
    one_line_error(p, *words)
    assert digests(place) == before and not (place / "missing").exists()


def test_a_run_the_database_does_not_take_is_kept_and_imported_later(place, fmu_path, monkeypatch):
    """A database locked by another process: nothing is stored, the outputs are not written, each run
    of --compare goes to its own file; runners db import-unsaved stores them, bit for bit, once."""
    db = str(place / "r.db")
    # the base record stored first (loading the system would store it, and wait for the lock before running)
    assert run_cli("records", "import", "pulse_3hz.AT2", "--db", db, "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    monkeypatch.setenv("ROCKING_DB_BUSY_TIMEOUT", "0")
    other = sqlite3.connect(db, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    try:
        p = run_cli("cosim", "system.toml", "--compare", "--csv", "s.csv", "--db", db, "--quiet", db=db,
                    fmu_path=fmu_path)
    finally:
        other.execute("ROLLBACK")
        other.close()
    line = one_line_error(p, "is locked by another process", "the co-simulated runs were not stored",
                          "runners db import-unsaved")
    kept = sorted(place.glob("rocking-unsaved-*.json"))
    assert [k.name.rsplit("-", 2)[-2:] for k in kept] == [["one", "way.json"], ["two", "way.json"]]
    assert all(str(k) in line for k in kept) and not list(place.glob("s*.csv"))
    assert runners.open_db(db).cosims().empty
    for k in kept + kept[-1:]:  # the last one twice: stored once
        q = run_cli("db", "import-unsaved", str(k), "--db", db, "--json", db=db, fmu_path=fmu_path)
        assert q.returncode == 0, q.stderr
    assert json.loads(q.stdout) == {"cosim_id": 2, "stored_already": True, "file": str(kept[-1]),
                                    "database": f"sqlite:///{db}"}
    stored = runners.open_db(db)
    assert stored.cosims()["coupling"].tolist() == ["two-way", "one-way"]
    fresh = cosim.run(cosim.load_system(place / "system.toml"), block_fmu=fmu_path)  # the two-way run again
    two = stored.cosim(2)
    assert all(np.array_equal(two[n], fresh[n]) for n in fresh.series) and np.array_equal(two.time, fresh.time)


def test_deleting_a_cosim_run_or_the_record_it_ran_on(place, fmu_path):
    db = str(place / "r.db")
    p = run_cli("cosim", "system.toml", "--compare", "--db", db, "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli("db", "delete", "record", "pulse_3hz", "--db", db, db=db, fmu_path=fmu_path)
    one_line_error(p, "record 'pulse_3hz'", "is needed by 2 cosim runs (1, 2)", "--force")
    p = run_cli("db", "delete", "cosim", "latest", "--db", db, "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    rows = json.loads(p.stdout)["rows"]
    assert rows == {**dict.fromkeys(rows, 0), "cosim_runs": 1, "cosim_series": 1}
    one_line_error(run_cli("db", "show", "cosim", "2", "--db", db, db=db, fmu_path=fmu_path), "no co-simulated run 2")
    p = run_cli("db", "delete", "record", "pulse_3hz", "--force", "--db", db, db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "with --force also: cosim run 1" in p.stdout, p.stdout + p.stderr
    assert runners.open_db(db).cosims().empty
    # a new run never takes a deleted run's id
    assert run_cli("cosim", "system.toml", "--db", db, "--json", "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    assert runners.open_db(db).cosims().index.tolist() == [3]
