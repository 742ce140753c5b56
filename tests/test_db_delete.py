"""runners db delete sweep|run|record (issue 36, item 4b): everything that belongs to what is deleted
goes with it in one transaction, nothing else does; what other rows need is refused in one line
(and then nothing changes) unless --force, which deletes those too and counts them; a failure half-way
rolls everything back; a sweep a process is running is never deleted. On SQLite and PostgreSQL, with
the real FMU, real record files and real databases."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import create_engine, func, select, text

import runners
from conftest import PATIENCE, run_cli, wait_for
from db.schema import Base, Excitation, Record, Run, RunSeries, RunSummary, Sweep
from db.session import open_database
from runners.engine.record_files import write_record_file

ROOT = Path(__file__).resolve().parent.parent
PULSE = str(ROOT / "examples" / "sweep_sine_pulse.toml")
STATUE = str(ROOT / "examples" / "statue.toml")
MOTION = ("# kind: ground-acceleration\n# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n"
          + "".join(f"{0.01 * i:.2f},{3 * np.sin(0.3 * i):.6f}\n" for i in range(200)))


def cli(*args: str, db: str, fmu_path: Path):
    return run_cli(*args, db=db, fmu_path=fmu_path)


def ok(p) -> str:
    assert p.returncode == 0, p.stderr
    return p.stdout


def one_line_error(p) -> str:
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("error:"), p.stderr
    assert "Traceback" not in p.stderr and p.stdout == ""
    return p.stderr.strip()


def snapshot(db: str) -> dict[str, list]:
    """Every row of every table (its primary key), in order: what a delete may change."""
    out = {}
    with open_database(db)() as s:
        for table in Base.metadata.sorted_tables:
            keys = [c for c in table.primary_key.columns]
            out[table.name] = [tuple(r) for r in s.execute(select(*keys).order_by(*keys))]
    return out


def rows_of(db: str, sweep_id: int) -> dict[str, int]:
    with open_database(db)() as s:
        runs = select(Run.id).where(Run.sweep_id == sweep_id)
        return {"runs": s.scalar(select(func.count()).where(Run.sweep_id == sweep_id)),
                "run_summaries": s.scalar(select(func.count()).where(RunSummary.run_id.in_(runs))),
                "run_series": s.scalar(select(func.count()).where(RunSeries.run_id.in_(runs)))}


def fill(db: str, fmu_path: Path, folder: Path) -> None:
    """Two sweeps of a one-sine pulse (sweep 1 with two points recorded in full), a single run, a
    record with a sweep (3) and a single run on it, and a measured ground motion (its own record)."""
    ok(cli("sweep", PULSE, "--grid", "w=1:12:5", "--grid", "a=1.01:8:4", "--points", "0,3", "--out",
           str(folder / "rec"), "--quiet", db=db, fmu_path=fmu_path))
    ok(cli("sweep", PULSE, "--grid", "w=1:12:3", "--grid", "a=1.01:8:3", "--quiet", db=db, fmu_path=fmu_path))
    ok(cli("simulate", PULSE, db=db, fmu_path=fmu_path))
    t = np.arange(0, 4, 0.01)
    write_record_file(folder / "quake.txt", t, 2.0 * np.sin(2 * np.pi * t) * np.exp(-t))
    ok(cli("records", "import", str(folder / "quake.txt"), db=db, fmu_path=fmu_path))
    ok(cli("sweep", STATUE, "--records", "quake", "--im", "pga=0.1:0.5:3", "--quiet", db=db, fmu_path=fmu_path))
    ok(cli("simulate", STATUE, "--record", "quake", "--pga", "0.3", db=db, fmu_path=fmu_path))
    (folder / "table.csv").write_text(MOTION)
    ok(cli("import-measured", str(folder / "table.csv"), db=db, fmu_path=fmu_path))


@pytest.fixture(scope="module")
def sqlite_template(tmp_path_factory, fmu_path) -> Path:
    """An SQLite file filled once (fill), to copy."""
    import sqlite3

    folder = tmp_path_factory.mktemp("delete-template")
    fill(f"sqlite:///{folder / 'template.db'}", fmu_path, folder)
    with sqlite3.connect(folder / "template.db") as conn:  # WAL mode: everything into the file before copying
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return folder / "template.db"


@pytest.fixture(scope="module")
def postgresql_template(postgres_server, tmp_path_factory, fmu_path) -> str:
    """A database on the PostgreSQL server filled once (fill), to copy; its name."""
    name = f"t_delete_{uuid.uuid4().hex[:12]}"
    admin(postgres_server, f"CREATE DATABASE {name}")
    fill(f"{postgres_server}/{name}", fmu_path, tmp_path_factory.mktemp("delete-template"))
    return name


def admin(server: str, *statements: str) -> None:
    engine = create_engine(f"{server}/postgres", isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        for statement in statements:
            conn.execute(text(statement))
    engine.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def stored(request, tmp_path) -> str:
    """A copy of the filled database (fill): an SQLite file, and a database on the PostgreSQL server."""
    if request.param == "sqlite":
        shutil.copy(request.getfixturevalue("sqlite_template"), tmp_path / "stored.db")
        return f"sqlite:///{tmp_path / 'stored.db'}"
    server = request.getfixturevalue("postgres_server")
    template = request.getfixturevalue("postgresql_template")
    name = f"t_{uuid.uuid4().hex[:12]}"
    admin(server, f"SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = '{template}'",
          f"CREATE DATABASE {name} TEMPLATE {template}")
    return f"{server}/{name}"


def test_deleting_a_sweep_deletes_what_belongs_to_it_and_nothing_else(stored, fmu_path):
    before = snapshot(stored)
    own = rows_of(stored, 1)
    assert own == {"runs": 20, "run_summaries": 20, "run_series": 2}
    with open_database(stored)() as s:
        scene = s.get(Sweep, 1).scene_id
    out = json.loads(ok(cli("db", "delete", "sweep", "1", "--json", db=stored, fmu_path=fmu_path)))
    assert out["deleted"] == "sweep" and out["id"] == 1 and out["with_it"] == {}
    assert out["rows"] == {**dict.fromkeys(out["rows"], 0), **own, "sweeps": 1, "scenes": 1}
    after = snapshot(stored)
    gone = {t: sorted(set(before[t]) - set(after[t])) for t in before}
    assert [(t, len(v)) for t, v in gone.items() if v] == [("scenes", 1), ("sweeps", 1), ("runs", 20),
                                                           ("run_series", 2), ("run_summaries", 20)]
    assert gone["scenes"] == [(scene,)] and gone["sweeps"] == [(1,)]
    assert all(set(after[t]) <= set(before[t]) for t in before)  # nothing else touched
    assert rows_of(stored, 2)["runs"] == 9 and runners.open_db(stored).sweep(2).to_pandas()["status"].eq("ok").all()
    one_line_error(cli("db", "delete", "sweep", "1", db=stored, fmu_path=fmu_path))  # no sweep 1 now


def test_a_record_that_runs_and_sweeps_need_is_refused_and_nothing_changes(stored, fmu_path):
    before = snapshot(stored)
    err = one_line_error(cli("db", "delete", "record", "quake", db=stored, fmu_path=fmu_path))
    assert "record 'quake'" in err and "is needed by 1 sweep (3) and 1 run (" in err and "--force" in err, err
    assert snapshot(stored) == before
    with pytest.raises(runners.RockingError, match="is needed by 1 sweep"):
        runners.open_db(stored).delete("record", "quake")
    assert snapshot(stored) == before
    # the measured motion's own record: needed by its measurement
    with open_database(stored)() as s:
        motion = s.scalar(select(Record.name).join(Excitation, Excitation.record_id == Record.id)
                          .where(Excitation.id.in_(text("SELECT excitation_id FROM measurements"))))
    err = one_line_error(cli("db", "delete", "record", motion, db=stored, fmu_path=fmu_path))
    assert "is needed by 1 measurement (1)" in err, err
    assert snapshot(stored) == before


def test_force_deletes_what_needs_a_record_and_says_how_many(stored, fmu_path):
    with open_database(stored)() as s:
        single = s.scalar(select(Run.id).join(Excitation).where(Run.sweep_id.is_(None), Excitation.record_id == 1))
    before = snapshot(stored)
    p = cli("db", "delete", "record", "quake", "--force", db=stored, fmu_path=fmu_path)
    line = ok(p).strip()
    assert line.startswith("deleted record 1 (quake); with --force also: sweep 3, run "), line
    assert "rows: 4 runs, 4 run summaries, 1 run series, 4 excitations, 1 sweep, 2 scenes, 1 record" in line, line
    after = snapshot(stored)
    assert (1,) not in after["records"] and (3,) not in after["sweeps"] and (single,) not in after["runs"]
    assert rows_of(stored, 1) == {"runs": 20, "run_summaries": 20, "run_series": 2}  # the other sweeps stay
    assert len(before["measurements"]) == len(after["measurements"]) == 1
    with open_database(stored)() as s:  # nothing refers to what is gone
        assert not s.scalar(select(func.count()).select_from(Excitation).where(Excitation.record_id == 1))
    motion = json.loads(ok(cli("db", "delete", "record", "2", "--force", "--json", db=stored, fmu_path=fmu_path)))
    assert motion["with_it"] == {"measurements": [1]} and motion["rows"]["measurements"] == 1
    assert snapshot(stored)["measurements"] == []


def test_a_sweep_point_is_refused_unless_force_takes_it_out_and_resuming_runs_it_again(db_url, fmu_path):
    ok(cli("sweep", PULSE, "--grid", "w=1:12:3", "--grid", "a=1.01:8:2", "--quiet", db=db_url, fmu_path=fmu_path))
    with open_database(db_url)() as s:
        point = s.scalar(select(Run.id).where(Run.sweep_id == 1, Run.grid_index == 4))
    before = snapshot(db_url)
    err = one_line_error(cli("db", "delete", "run", str(point), db=db_url, fmu_path=fmu_path))
    assert f"run {point} is point 4 of sweep 1" in err and "runners db delete sweep 1" in err, err
    assert snapshot(db_url) == before
    line = ok(cli("db", "delete", "run", str(point), "--force", db=db_url, fmu_path=fmu_path))
    assert "with --force also: taken out of sweep 1; rows: 1 run, 1 run summary" in line, line
    assert runners.open_db(db_url).sweep(1).stats["stored"] == 5
    assert "5/6 stopped (runners sweep 1 finishes it)" in ok(cli("db", "list", "sweeps", db=db_url,
                                                                  fmu_path=fmu_path))
    ok(cli("sweep", "1", "--quiet", db=db_url, fmu_path=fmu_path))
    points = runners.open_db(db_url).sweep(1)
    assert points.stats["stored"] == 6 and points.stats["status"] == "done"
    assert sorted(points.to_pandas()["grid_index"]) == list(range(6))


def test_a_single_run_goes_with_its_summary_series_excitation_and_scene(db_url, fmu_path):
    ok(cli("simulate", PULSE, db=db_url, fmu_path=fmu_path))
    ok(cli("simulate", PULSE, db=db_url, fmu_path=fmu_path))
    deleted = runners.open_db(db_url).delete("run", "latest")
    assert deleted.id == 2 and deleted.rows == {"runs": 1, "run_summaries": 1, "run_series": 1, "excitations": 1,
                                                "sweeps": 0, "scenes": 1, "measurements": 0, "records": 0}
    after = snapshot(db_url)
    assert after["runs"] == [(1,)] and len(after["scenes"]) == len(after["excitations"]) == 1


def _refuse_deleting_sweeps(db: str) -> None:
    """A trigger that makes the database refuse to delete a sweep: a failure after the runs, summaries
    and series of the sweep were deleted in the same transaction."""
    engine = create_engine(db)
    with engine.begin() as conn:
        if engine.dialect.name == "sqlite":
            conn.execute(text("CREATE TRIGGER keep_sweeps BEFORE DELETE ON sweeps "
                              "BEGIN SELECT RAISE(ABORT, 'sweeps are kept'); END"))
        else:
            conn.execute(text("CREATE FUNCTION keep_sweeps() RETURNS trigger AS $$ BEGIN "
                              "RAISE EXCEPTION 'sweeps are kept'; END $$ LANGUAGE plpgsql"))
            conn.execute(text("CREATE TRIGGER keep_sweeps BEFORE DELETE ON sweeps FOR EACH ROW "
                              "EXECUTE FUNCTION keep_sweeps()"))
    engine.dispose()


def test_a_delete_that_fails_half_way_leaves_everything_as_it_was(stored, fmu_path):
    _refuse_deleting_sweeps(stored)
    before = snapshot(stored)
    err = one_line_error(cli("db", "delete", "sweep", "1", db=stored, fmu_path=fmu_path))
    assert "sweeps are kept" in err, err
    assert snapshot(stored) == before  # the runs, summaries and series deleted before the failure are back
    err = one_line_error(cli("db", "delete", "record", "quake", "--force", db=stored, fmu_path=fmu_path))
    assert "sweeps are kept" in err and snapshot(stored) == before


def test_a_sweep_a_process_is_running_is_not_deleted(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    p = subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", str(ROOT / "examples" / "harmonic.toml"),
                          "--grid", "excitation.frequency=2:8:60", "--grid", "excitation.displacement=0.001:0.004:60",
                          "--stop-time", "20", "--quiet", "--workers", "1"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=env, cwd=ROOT, start_new_session=True)
    try:
        def started() -> bool:
            try:
                with open_database(db, write=False)() as s:
                    return bool(s.scalar(select(func.count()).select_from(Run)))
            except Exception:
                return False

        wait_for(started, "the first points stored", p)
        err = one_line_error(cli("db", "delete", "sweep", "1", "--force", db=db, fmu_path=fmu_path))
        assert "sweep 1 is running" in err, err
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        p.communicate(timeout=PATIENCE)
    assert "deleted sweep 1" in ok(cli("db", "delete", "sweep", "1", db=db, fmu_path=fmu_path))
    assert not list(tmp_path.glob("s.db.sweep-*"))


@pytest.mark.parametrize("args,words", [(["sweep", "latest"], "no sweep in the database"),
                                        (["sweep", "abc"], "sweep ids are whole numbers"),
                                        (["run", "99"], "no run 99"),
                                        (["record", "nope"], "no record 'nope'"),
                                        (["block", "1"], "invalid choice")])
def test_what_is_not_there_is_one_line(tmp_path, fmu_path, args, words):
    db = f"sqlite:///{tmp_path / 's.db'}"
    ok(cli("db", "init", db=db, fmu_path=fmu_path))
    p = cli("db", "delete", *args, db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and words in p.stderr, p.stderr
