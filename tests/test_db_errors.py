"""Bad databases and failing stores: every case is one line on stderr and a non-zero exit,
never a traceback, and stored data are never lost (real SQLite files, the real command line)."""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import pytest
from sqlalchemy import event, func, select, text
from sqlalchemy.pool import Pool

from conftest import cpu_seconds, run_cli, wait_for
from db.schema import Run, RunSeries, RunSummary
from db.session import integrity_ok, open_database

ROOT = Path(__file__).resolve().parent.parent
FREE = str(ROOT / "examples" / "free_rocking.toml")
HUGE = "99999999999999999999999"  # beyond 2**63 - 1


def one_line_error(p: subprocess.CompletedProcess, *words: str) -> str:
    """The command failed with exit 2 and exactly one line on stderr holding `words`."""
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    assert p.stderr.count("\n") == 1 and p.stderr.startswith("error: "), p.stderr
    assert "Traceback" not in p.stderr + p.stdout
    for w in words:
        assert w in p.stderr, (w, p.stderr)
    return p.stderr


def stored_db(path: Path, fmu_path: Path, runs: int = 1) -> str:
    """An SQLite file holding `runs` stored runs, its WAL checkpointed into the file."""
    for _ in range(runs):
        p = run_cli("simulate", FREE, db=str(path), fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
    con = sqlite3.connect(path)
    assert con.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()[0] == 0  # all in the file now
    con.close()
    return str(path)


def copied_db(folder: Path, fmu_path: Path) -> Path:
    """A database with one run copied into `folder` on its own, as onto a read-only medium:
    no -wal or -shm file next to it."""
    folder.mkdir()
    src = folder.parent / f"{folder.name}-source.db"
    stored_db(src, fmu_path)
    shutil.copyfile(src, folder / "runs.db")
    return folder / "runs.db"


def count_runs(db: str) -> int:
    with open_database(db)() as s:
        return s.scalar(select(func.count()).select_from(Run))


# --- 1. files that are not SQLite databases, or are cut short: one line, the file untouched --------------

def test_a_text_file_given_as_db_is_refused_in_one_line_and_left_byte_identical(tmp_path, fmu_path):
    path = tmp_path / "notes.txt"
    path.write_text("not a database\n" * 100)
    before = path.read_bytes()
    for args in (("simulate", FREE), ("db", "list", "runs"), ("db", "init")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), str(path), "is not an SQLite database")
    assert path.read_bytes() == before


def test_a_png_file_given_as_db_is_refused_in_one_line_and_left_byte_identical(tmp_path, fmu_path):
    path = tmp_path / "map.png"
    shutil.copy(ROOT / "docs" / "figures" / "overturning_map.png", path)
    before = path.read_bytes()
    for args in (("simulate", FREE), ("db", "show", "run", "1")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), str(path), "is not an SQLite database")
    assert path.read_bytes() == before


def test_a_database_cut_mid_page_is_damaged_in_one_line_and_left_byte_identical(tmp_path, fmu_path):
    good = Path(stored_db(tmp_path / "good.db", fmu_path))
    path = tmp_path / "cut.db"
    path.write_bytes(good.read_bytes()[:5000])
    for args in (("simulate", FREE), ("db", "list", "runs")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), str(path), "is damaged", "cut short")
    assert path.read_bytes() == good.read_bytes()[:5000]


def test_a_database_cut_at_a_page_boundary_is_damaged_in_one_line_and_left_byte_identical(tmp_path, fmu_path):
    good = Path(stored_db(tmp_path / "good.db", fmu_path))
    data = good.read_bytes()
    assert len(data) > 3 * 4096
    path = tmp_path / "cut.db"
    path.write_bytes(data[:2 * 4096])  # whole pages, fewer than the header announces
    for args in (("simulate", FREE), ("db", "show", "run", "1")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), str(path), "is damaged", "cut short")
    assert path.read_bytes() == data[:2 * 4096]


def test_an_sqlite_file_of_another_program_is_refused_and_left_byte_identical(tmp_path, fmu_path):
    path = tmp_path / "other.db"
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE contacts (name TEXT, phone TEXT)")
    con.execute("INSERT INTO contacts VALUES ('a', '1')")
    con.commit()
    con.close()
    before = path.read_bytes()
    for args in (("simulate", FREE), ("db", "init"), ("db", "list", "runs")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), "is not one of this tool's", "contacts")
    assert path.read_bytes() == before


def altered_db(path: Path, fmu_path, sql: str) -> bytes:
    """A database with one stored run, then changed behind the tool's back by `sql` (and
    checkpointed, so the file holds everything); its bytes."""
    stored_db(path, fmu_path)
    con = sqlite3.connect(path)
    con.execute(sql)
    con.commit()
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    return path.read_bytes()


# --- 2. a newer schema: say so, change nothing ------------------------------------------------------------

def test_a_database_from_a_newer_version_is_refused_in_one_line_and_not_modified(tmp_path, fmu_path):
    path = tmp_path / "newer.db"
    before = altered_db(path, fmu_path, "UPDATE alembic_version SET version_num = 'ffff9999'")
    for args in (("simulate", FREE), ("db", "list", "runs"), ("db", "init")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), "newer version", "ffff9999", "upgrade")
    assert path.read_bytes() == before
    assert not Path(f"{path}-wal").exists() or Path(f"{path}-wal").stat().st_size == 0


# --- 3. and 4. read-only files, folders and mounts --------------------------------------------------------

@pytest.fixture
def read_only(tmp_path):
    """Make paths read-only: chmod, and, as root (whom permissions do not stop), a read-only
    bind mount of each in a private mount namespace that only the command runs in."""
    mounted: list[Path] = []
    if os.geteuid() == 0:
        probe = subprocess.run(["unshare", "-m", "--propagation", "private", "mount", "--bind", str(tmp_path),
                                str(tmp_path)], capture_output=True, text=True) if shutil.which("unshare") else None
        if probe is None or probe.returncode != 0:
            pytest.skip("running as root, where permissions do not apply, and read-only mounts (unshare -m) are "
                        f"not available: {probe.stderr.strip() if probe else 'no unshare'}")

    def make(*paths: Path) -> None:
        for p in paths:
            p.chmod(0o555 if p.is_dir() else 0o444)
        mounted.extend(paths)

    def run(*args: str, db: Path, fmu_path: Path) -> subprocess.CompletedProcess:
        env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": str(db)}
        cmd = [sys.executable, "-m", "runners.cli", *args]
        if os.geteuid() == 0:
            mounts = " && ".join(f'mount --bind "${i}" "${i}" && mount -o remount,bind,ro "${i}"'
                                 for i in range(1, len(mounted) + 1))
            cmd = ["unshare", "-m", "--propagation", "private", "sh", "-c",
                   f'{mounts} && shift {len(mounted)} && exec "$@"', "sh", *map(str, mounted), *cmd]
        return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp_path)

    make.run = run
    yield make
    for p in mounted:
        p.chmod(0o755 if p.is_dir() else 0o644)


def test_simulate_on_a_read_only_file_fails_before_simulating(tmp_path, fmu_path, read_only):
    path = Path(stored_db(tmp_path / "runs.db", fmu_path))
    read_only(path)  # the folder stays writable
    before = path.read_bytes()
    rrd = tmp_path / "run.rrd"  # written after the simulation and before storing: it must not appear
    p = read_only.run("simulate", FREE, "--out", str(rrd), db=path, fmu_path=fmu_path)
    one_line_error(p, str(path), "read-only")
    assert not rrd.exists() and not list(tmp_path.glob("rocking-unsaved-*"))
    assert path.read_bytes() == before


def test_simulate_on_a_read_only_mount_fails_before_simulating(tmp_path, fmu_path, read_only):
    folder = tmp_path / "mount"
    path = copied_db(folder, fmu_path)
    read_only(path, folder)
    before = path.read_bytes()
    rrd = tmp_path / "run.rrd"
    p = read_only.run("simulate", FREE, "--out", str(rrd), db=path, fmu_path=fmu_path)
    one_line_error(p, str(path), "read-only")
    assert not rrd.exists() and path.read_bytes() == before


def test_read_commands_work_on_a_read_only_file(tmp_path, fmu_path, read_only):
    path = Path(stored_db(tmp_path / "runs.db", fmu_path))
    read_only(path)
    before = path.read_bytes()
    p = read_only.run("db", "list", "runs", db=path, fmu_path=fmu_path)
    assert p.returncode == 0 and "runs: 1 in" in p.stdout, p.stderr
    p = read_only.run("db", "show", "run", "1", db=path, fmu_path=fmu_path)
    assert p.returncode == 0 and json.loads(p.stdout)["summary"]["impacts"] > 0, p.stderr
    assert path.read_bytes() == before


def test_read_commands_work_on_a_read_only_mount(tmp_path, fmu_path, read_only):
    """Folder and file not writable: SQLite cannot create the -wal and -shm files a WAL
    reader normally uses, so the file is read as immutable."""
    folder = tmp_path / "mount"
    path = copied_db(folder, fmu_path)
    read_only(path, folder)
    before, files = path.read_bytes(), sorted(folder.iterdir())
    p = read_only.run("db", "list", "runs", db=path, fmu_path=fmu_path)
    assert p.returncode == 0 and "runs: 1 in" in p.stdout, p.stderr
    p = read_only.run("db", "show", "run", "1", db=path, fmu_path=fmu_path)
    assert p.returncode == 0 and json.loads(p.stdout)["series"]["n_samples"] > 100, p.stderr
    assert path.read_bytes() == before and sorted(folder.iterdir()) == files


def test_an_old_database_on_a_read_only_mount_says_it_cannot_be_migrated(tmp_path, fmu_path, read_only):
    from alembic import command

    from db.session import _alembic_config, make_engine

    folder = tmp_path / "mount"
    folder.mkdir()
    path = folder / "old.db"
    engine = make_engine(f"sqlite:///{path}")
    cfg = _alembic_config()
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0005")
    engine.dispose()
    read_only(path, folder)
    before = path.read_bytes()
    p = read_only.run("db", "list", "runs", db=path, fmu_path=fmu_path)
    one_line_error(p, str(path), "revision 0005", "cannot be migrated")
    assert path.read_bytes() == before


def test_read_commands_leave_no_files_next_to_a_writable_database(tmp_path, fmu_path):
    """Opened read-only (query_only), a writable database still has its -wal and -shm files
    tidied away when the command ends, as a writing command does."""
    env = {**os.environ, "ROCKING_FMU": str(fmu_path)}
    path = tmp_path / "runs.db"
    for args in (("simulate", FREE), ("db", "list", "runs"), ("db", "show", "run", "1")):
        p = subprocess.run([sys.executable, "-m", "runners.cli", *args, "--db", str(path)], capture_output=True,
                           text=True, env=env, cwd=tmp_path)
        assert p.returncode == 0, p.stderr
        assert sorted(f.name for f in tmp_path.iterdir()) == ["runs.db"], args  # built beside it: no lock file


# --- 5. and 6. storing fails after the run: the run is kept in a file, the database unchanged -------------

def test_a_full_disk_while_storing_is_one_line_and_keeps_the_stored_runs(tmp_path, fmu_path, monkeypatch):
    """SQLITE_FULL as a full disk gives it: every connection may not grow the file (max_page_count
    is a per-connection setting, so it is set as each one opens)."""
    db = stored_db(tmp_path / "full.db", fmu_path, runs=2)
    monkeypatch.chdir(tmp_path)

    def no_growth(dbapi_connection, _record):
        dbapi_connection.execute("PRAGMA max_page_count = 1")  # never below the current size: no new pages

    event.listen(Pool, "connect", no_growth)
    try:
        p = run_cli("simulate", FREE, db=db, fmu_path=fmu_path)
    finally:
        event.remove(Pool, "connect", no_growth)
    err = one_line_error(p, "the disk is full", "the run was not stored", "runners db import-unsaved")
    kept = list(tmp_path.glob("rocking-unsaved-*.json"))
    assert len(kept) == 1 and str(kept[0]) in err
    assert count_runs(db) == 2 and integrity_ok(open_database(db).kw["bind"])


def test_a_run_that_finds_the_database_locked_is_kept_and_imported_later(tmp_path, fmu_path, monkeypatch):
    db = stored_db(tmp_path / "locked.db", fmu_path)
    reference = stored_db(tmp_path / "reference.db", fmu_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ROCKING_DB_BUSY_TIMEOUT", "1")
    holder = sqlite3.connect(db, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")  # another process's long write
    try:
        p = run_cli("simulate", FREE, db=db, fmu_path=fmu_path)
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    err = one_line_error(p, "is locked by another process", "waited 1 s", "runners db import-unsaved")
    (kept,) = tmp_path.glob("rocking-unsaved-*.json")
    assert str(kept) in err and count_runs(db) == 1
    imported_at = datetime.now(timezone.utc).replace(tzinfo=None)  # SQLite gives naive UTC times back
    p = run_cli("db", "import-unsaved", str(kept), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "stored run 2" in p.stdout, p.stderr
    p = run_cli("db", "import-unsaved", str(kept), db=db, fmu_path=fmu_path)  # a second time: nothing new
    assert p.returncode == 0 and "stored already: run 2" in p.stdout, p.stderr
    assert count_runs(db) == 2
    with open_database(db)() as s, open_database(reference)() as r:  # what storing at once writes, bit for bit
        run, ref = s.get(Run, 2), r.get(Run, 1)
        assert s.get(RunSeries, 2).data == r.get(RunSeries, 1).data
        assert s.get(RunSeries, 2).events == r.get(RunSeries, 1).events
        cols = [c.key for c in RunSummary.__table__.columns if c.key != "run_id"]
        assert [getattr(run.summary, c) for c in cols] == [getattr(ref.summary, c) for c in cols]
        assert (run.model, run.method, run.fmu_sha256, run.scene.parameters, run.scene.source) == \
               (ref.model, ref.method, ref.fmu_sha256, ref.scene.parameters, ref.scene.source)
        assert run.created_at < imported_at  # when it ran, not when it was imported


def test_a_bad_busy_timeout_is_one_line(tmp_path, fmu_path, monkeypatch):
    monkeypatch.setenv("ROCKING_DB_BUSY_TIMEOUT", "soon")
    one_line_error(run_cli("db", "list", "runs", db=str(tmp_path / "x.db"), fmu_path=fmu_path),
                   "ROCKING_DB_BUSY_TIMEOUT")


def test_importing_an_unsaved_run_that_lacks_a_part_is_one_line(tmp_path, fmu_path):
    path = tmp_path / "rocking-unsaved-cut.json"
    path.write_text(json.dumps({"format": "rocking-unsaved-run", "version": 1, "created_at": "2026-01-01T00:00:00"}))
    db = tmp_path / "x.db"
    one_line_error(run_cli("db", "import-unsaved", str(path), db=str(db), fmu_path=fmu_path),
                   "is not a whole unsaved run", "scene")


def test_importing_a_file_that_is_not_an_unsaved_run_is_one_line(tmp_path, fmu_path):
    path = tmp_path / "other.json"
    path.write_text('{"a": 1}')
    one_line_error(run_cli("db", "import-unsaved", str(path), db=str(tmp_path / "x.db"), fmu_path=fmu_path),
                   "is not a file of an unsaved run")


# --- 7. a schema that does not match its revision -----------------------------------------------------------

def test_a_dropped_table_is_reported_as_damage_in_one_line(tmp_path, fmu_path):
    path = tmp_path / "dropped.db"
    before = altered_db(path, fmu_path, "DROP TABLE runs")
    for args in (("simulate", FREE), ("db", "list", "runs"), ("db", "show", "scene", "1")):
        one_line_error(run_cli(*args, db=str(path), fmu_path=fmu_path), str(path), "is damaged",
                       "table runs is missing")
    assert path.read_bytes() == before


# --- 8. ids no row can have --------------------------------------------------------------------------------

@pytest.mark.parametrize("what", ["run", "scene", "sweep", "measurement", "block"])
def test_db_show_of_an_id_beyond_64_bits_is_no_such_row(tmp_path, fmu_path, what):
    db = stored_db(tmp_path / "ids.db", fmu_path)
    one_line_error(run_cli("db", "show", what, HUGE, db=db, fmu_path=fmu_path), f"no {what} '{HUGE}'")


def test_db_list_with_a_limit_beyond_64_bits_lists_everything(tmp_path, fmu_path):
    db = stored_db(tmp_path / "ids.db", fmu_path)
    p = run_cli("db", "list", "runs", "--limit", HUGE, db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "runs: 1 in" in p.stdout, p.stderr


@pytest.mark.parametrize("args", [
    ("rrd", HUGE), ("rrd", "--sweep", HUGE), ("view", HUGE), ("map", HUGE), ("sweep", "--resume", HUGE),
    ("compare", HUGE, "1"), ("compare", "1", HUGE), ("export-measured", HUGE, "--out", "x.csv"),
    ("calibrate", HUGE, "--law", "modified"), ("fragility", HUGE), ("ida", HUGE), ("records", "show", HUGE),
    ("simulate", FREE, "--motion", HUGE),
    ("import-measured", str(ROOT / "examples" / "measured_peaks_block2.csv"), "--block", HUGE)],
    ids=lambda a: " ".join(x for x in a if x != HUGE and "/" not in x))
def test_other_commands_given_an_id_beyond_64_bits_say_there_is_no_such_row(tmp_path, fmu_path, args):
    db = stored_db(tmp_path / "ids.db", fmu_path)
    one_line_error(run_cli(*args, db=db, fmu_path=fmu_path), "no ", HUGE)


def test_read_commands_and_ids_beyond_64_bits_on_every_backend(db_url, fmu_path):
    """The read-only opening of db list / db show, and ids no row can have, on SQLite and PostgreSQL."""
    p = run_cli("simulate", FREE, db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli("db", "list", "runs", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0 and "runs: 1 in" in p.stdout, p.stderr
    one_line_error(run_cli("db", "show", "run", HUGE, db=db_url, fmu_path=fmu_path), f"no run '{HUGE}'")
    one_line_error(run_cli("rrd", HUGE, db=db_url, fmu_path=fmu_path), f"no run {HUGE}")


def test_opening_a_database_again_keeps_the_locks_of_its_open_connections(tmp_path):
    """Reading a database file's header closes a file descriptor of it, which releases every
    POSIX lock the process holds on it, its SQLite connections' included: another process
    closing its connection then believes it is the last one and removes the write-ahead log
    under the first one's feet (what corrupted sweeps watched by a polling reader)."""
    import sqlite3
    import subprocess
    import sys

    from sqlalchemy import text

    path = tmp_path / "locks.db"
    factory = open_database(f"sqlite:///{path}")
    with factory.kw["bind"].connect() as conn:  # an open connection of this process...
        conn.execute(text("SELECT count(*) FROM runs")).scalar()
        open_database(f"sqlite:///{path}")  # ...while the database is opened again
        subprocess.run([sys.executable, "-c", "import sqlite3, sys; c = sqlite3.connect(sys.argv[1]); "
                        "c.execute('SELECT count(*) FROM runs').fetchone(); c.close()", str(path)], check=True)
        assert Path(f"{path}-wal").exists()  # the other process knew it was not the last
        conn.execute(text("SELECT count(*) FROM runs")).scalar()
    assert sqlite3.connect(path).execute("PRAGMA integrity_check").fetchone() == ("ok",)


def test_a_database_killed_while_being_created_is_absent_or_whole(tmp_path):
    """SIGKILL at any moment of a first opening leaves no database, or a whole one: the schema
    is built beside it and takes its name in one step (a kill in the middle once left a file
    that every command refused). The kills fall at points of the opening's own CPU time, spread
    from when an uninterrupted opening starts building to its end (wall-time delays, which a busy
    machine stretches, could all fall before it began); some must find the building under way."""
    import resource
    import signal

    def opening(path: Path) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-c", "import sys; from db.session import open_database; "
                                 "open_database(sys.argv[1])", f"sqlite:///{path}"], cwd=ROOT)

    def building(path: Path) -> list[Path]:  # the file the schema is built in, beside the database
        return list(path.parent.glob(f"{path.name}.new-*"))

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = opening(tmp_path / "whole.db")
    start = wait_for(lambda: building(tmp_path / "whole.db") and [cpu_seconds(p.pid)], "the schema's file", p)[0]
    assert p.wait() == 0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    end = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    caught = 0
    for i in range(18):
        path = tmp_path / f"k{i}.db"
        p = opening(path)
        target = start - 0.05 + (end - start + 0.05) * i / 17
        wait_for(lambda: p.poll() is not None or cpu_seconds(p.pid) >= target, "the kill's moment")
        p.send_signal(signal.SIGKILL)
        p.wait()
        caught += bool(building(path))
        if path.exists():
            with open_database(f"sqlite:///{path}")() as s:  # whole: usable as it is
                s.execute(text("SELECT count(*) FROM runs")).scalar()
    assert caught >= 1


@pytest.mark.parametrize("change,words", [
    (lambda p: p["scene"].update(parameters=5), "scene.parameters"),
    (lambda p: p.update(record={"id": 999}), "record"),
    (lambda p: p["series"].update(n_samples=10**12), "series.n_samples"),
    (lambda p: p["series"].update(n_samples=12), "does not hold"),
    (lambda p: p["merged"].pop("excitation.kind"), "merged does not describe an excitation"),
    (lambda p: p["summary"].update(impacts="many"), "summary.impacts"),
    (lambda p: p["summary"].update(colour=1), "unknown field"),
    (lambda p: p.update(created_at="yesterday"), "created_at"),
    (lambda p: p["series"].update(events=[{"kind": 5}]), "series.events[0] has no kind"),
    (lambda p: p["series"].update(events=[{"kind": "impact"}]), "series.events[0] has no time t"),
    (lambda p: p["series"].update(events=[{"kind": "impact", "t": 0.1, "values": {"omega": "fast"}}]),
     "series.events[0].values"),
    (lambda p: p["series"].update(events=[{"kind": "impact", "t": 0.1, "labels": {"contact": 1}}]),
     "series.events[0].labels"),
    (lambda p: p["series"].update(events=[5]), "series.events[0] is not an event"),
    (lambda p: p["series"].update(names=["block1.theta", "block1.theta"]), "series.names"),
    (lambda p: p["series"].update(n_samples=0), "series.n_samples"),
    # well-typed but impossible values (the hostile re-run: each was stored without a word)
    (lambda p: p["merged"].update(nBlocks=9), "merged.nBlocks"),
    (lambda p: p["merged"].update({"block1.halfWidth": float("nan")}), "merged.block1.halfWidth"),
    (lambda p: p["merged"].update({"block1.halfWidth": "x"}), "merged.block1.halfWidth"),
    (lambda p: p.update(stop_time=0.0), "stop_time"),
    (lambda p: p["summary"].update(impacts=-1), "summary.impacts"),
    (lambda p: p["summary"].update(peak1_over_alpha=float("nan")), "summary.peak1_over_alpha"),
    (lambda p: p["series"].update(events=[{"kind": "impact", "t": 1e300}]), "after the run's stop_time"),
])
def test_an_unsaved_run_with_wrong_values_is_refused_before_storing(tmp_path, fmu, fmu_path, change, words):
    """A changed or damaged unsaved-run file once stored a run no command could read back
    (n_samples 1e12), a summary of impacts "many", or ended in an unforeseen error."""
    import numpy as np

    from db.store import keep_unsaved, pending_run

    t = np.linspace(0.0, 1.0, 11)
    p = pending_run(scene_name="s", parameters={"block1.theta0": 0.1}, source=None,
                    merged={**fmu.defaults(), "block1.theta0": 0.1},
                    summary={"impacts": 3, "overturned": False}, model="one block", method="fmu", stop_time=1.0,
                    fmu_path=str(fmu_path), wall_time=0.01, time=t, outputs={"block1.theta": np.sin(t)}, events=[])
    change(p)
    path = keep_unsaved(p, "test", "nowhere", folder=tmp_path)
    db = f"sqlite:///{tmp_path / 'u.db'}"
    one_line_error(run_cli("db", "import-unsaved", str(path), db=db, fmu_path=fmu_path), "not a valid unsaved run",
                   words)
    with open_database(db)() as s:
        assert s.scalar(select(func.count()).select_from(Run)) == 0


def test_a_first_opening_keeps_the_locks_of_connections_made_without_it(tmp_path):
    """The same, with the database created by another process and connected to here by plain
    sqlite3 before open_database reads its header for the first time (what the signal tests
    do while watching a sweep)."""
    path = tmp_path / "watched.db"
    subprocess.run([sys.executable, "-c", "import sys; from db.session import open_database; "
                    "open_database(sys.argv[1])", f"sqlite:///{path}"], check=True, cwd=ROOT)
    conn = sqlite3.connect(path)
    conn.execute("SELECT count(*) FROM runs").fetchone()
    open_database(f"sqlite:///{path}")  # the header is read here, with conn open
    subprocess.run([sys.executable, "-c", "import sqlite3, sys; c = sqlite3.connect(sys.argv[1]); "
                    "c.execute('SELECT count(*) FROM runs').fetchone(); c.close()", str(path)], check=True)
    assert Path(f"{path}-wal").exists()
    conn.close()


def test_an_exported_run_imported_from_a_file_exports(tmp_path, fmu, fmu_path):
    """The run an unsaved-run file holds, events included, is imported and reads back: its
    export has the events as they were kept (an edited event once imported and then failed
    every export with KeyError: 't')."""
    import numpy as np

    from db.store import keep_unsaved, pending_run

    t = np.linspace(0.0, 1.0, 11)
    events = [{"kind": "impact", "t": 0.5, "values": {"omega": -0.25}, "labels": {"contact": "ground"}}]
    p = pending_run(scene_name="s", parameters={"block1.theta0": 0.1}, source=None,
                    merged={**fmu.defaults(), "block1.theta0": 0.1},
                    summary={"impacts": 1, "overturned": False}, model="one block", method="fmu", stop_time=1.0,
                    fmu_path=str(fmu_path), wall_time=0.01, time=t, outputs={"block1.theta": np.sin(t)},
                    events=events)
    path = keep_unsaved(p, "test", "nowhere", folder=tmp_path)
    db = f"sqlite:///{tmp_path / 'u.db'}"
    assert run_cli("db", "import-unsaved", str(path), db=db, fmu_path=fmu_path).returncode == 0
    out = tmp_path / "run.csv"
    p = run_cli("export", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    import csv

    with open(tmp_path / "run-events.csv", newline="") as fh:
        kept = list(csv.DictReader(fh))
    assert [(float(e["time"]), e["kind"]) for e in kept] == [(0.5, "impact")]


def _peak_memory_of_import(path: Path, db: str) -> tuple[int, str]:
    """(peak resident memory in kB, stderr) of runners db import-unsaved in a process of its own."""
    code = ("import resource, sys; from runners.cli.main import main; code = main(sys.argv[1:]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(code)")
    p = subprocess.run([sys.executable, "-c", code, "db", "import-unsaved", str(path), "--db", db],
                       capture_output=True, text=True, cwd=ROOT, timeout=600)
    return int(p.stdout.split()[-1]), p.stderr


def test_an_unsaved_run_whose_series_inflates_far_beyond_its_size_is_refused_in_little_memory(tmp_path, fmu,
                                                                                            fmu_path):
    """series.data packed to inflate to 512 MB where 11 samples were announced: refused, with
    the memory of importing a right file (it once inflated the whole stream first: 4.27 GB for
    a 2.8 MB file)."""
    import base64
    import zlib

    import numpy as np

    from db.store import keep_unsaved, pending_run

    t = np.linspace(0.0, 1.0, 11)
    p = pending_run(scene_name="s", parameters={"block1.theta0": 0.1}, source=None,
                    merged={**fmu.defaults(), "block1.theta0": 0.1},
                    summary={"impacts": 3, "overturned": False}, model="one block", method="fmu", stop_time=1.0,
                    fmu_path=str(fmu_path), wall_time=0.01, time=t, outputs={"block1.theta": np.sin(t)}, events=[])
    (tmp_path / "right").mkdir()
    (tmp_path / "bomb").mkdir()
    right = keep_unsaved(p, "test", "nowhere", folder=tmp_path / "right")
    z = zlib.compressobj(9)
    zeros = bytes(1 << 20)
    bomb = b"".join([z.compress(zeros) for _ in range(512)] + [z.flush()])  # 512 MB of zeros, about 0.5 MB
    p["series"]["data"] = base64.b64encode(bomb).decode("ascii")
    path = keep_unsaved(p, "test", "nowhere", folder=tmp_path / "bomb")
    base, err = _peak_memory_of_import(right, f"sqlite:///{tmp_path / 'right.db'}")
    assert not err, err
    peak, err = _peak_memory_of_import(path, f"sqlite:///{tmp_path / 'bomb.db'}")
    assert err.startswith("error: ") and err.count("\n") == 1 and "does not hold the 11 samples" in err, err
    assert peak < base + 64 * 1024, (peak, base)  # kB: far below the 512 MB the stream inflates to
    with open_database(f"sqlite:///{tmp_path / 'bomb.db'}")() as s:
        assert s.scalar(select(func.count()).select_from(Run)) == 0


KILLED_AT = """
import os, signal, sys
from pathlib import Path

def killed(*args, **kw):  # SIGKILL where the whole file would take its name
    os.kill(os.getpid(), signal.SIGKILL)

os.{call} = killed
{body}
"""


def killed_at(call: str, body: str, *args: str) -> None:
    """Run `body` in a process of its own that is SIGKILLed where it calls os.`call`."""
    p = subprocess.run([sys.executable, "-c", KILLED_AT.format(call=call, body=body), *args], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == -9, (p.returncode, p.stderr)


def test_the_files_a_killed_database_creation_left_are_removed_by_the_next_opening(tmp_path):
    """SIGKILL just before a new database took its name left its schema beside it
    (x.db.new-PID-THREAD); the next opening removes it, and keeps what live processes write."""
    path = tmp_path / "x.db"
    killed_at("link", "from db.session import open_database; open_database(sys.argv[1])", str(path))
    assert not path.exists() and list(tmp_path.glob("x.db.new-*"))  # the leftover is there
    with open_database(f"sqlite:///{path}")() as s:
        assert s.execute(text("SELECT count(*) FROM runs")).scalar() == 0
    assert list(tmp_path.glob("x.db.new-*")) == []


def test_a_database_that_cannot_be_created_is_named_as_given(tmp_path):
    """The error names the database asked for, not the temporary file it is built in."""
    from db.session import DatabaseError

    with pytest.raises(DatabaseError) as err:
        open_database(str(tmp_path / "no-such-folder" / "x.db"))
    assert str(err.value).startswith(f"cannot create the database {tmp_path / 'no-such-folder' / 'x.db'}:")
    assert ".new-" not in str(err.value) and "does not exist" in str(err.value)


def test_the_part_file_of_a_killed_unsaved_run_is_removed_by_the_next(tmp_path):
    from db.store import keep_unsaved

    body = "from db.store import keep_unsaved; keep_unsaved({'format': 'x'}, 'full', 'db', folder=Path(sys.argv[1]))"
    killed_at("replace", body, str(tmp_path))
    assert list(tmp_path.glob("*.part")) or list(tmp_path.glob(".*.part"))
    kept = keep_unsaved({"format": "x"}, "full", "db", folder=tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [kept.name]


def test_an_unsaved_run_that_cannot_be_kept_names_its_file_not_the_part(tmp_path):
    from db.store import keep_unsaved

    with pytest.raises(OSError) as err:
        keep_unsaved({"format": "x"}, "full", "db", folder=tmp_path / "no-such-folder")
    assert "rocking-unsaved-" in str(err.value) and ".part" not in str(err.value), str(err.value)


def test_the_part_file_of_a_killed_export_is_removed_by_the_next(tmp_path, fmu_path):
    db = stored_db(tmp_path / "r.db", fmu_path)
    out = tmp_path / "out" / "run.csv"
    body = "from runners.cli.main import main; main(['export', '1', '--out', sys.argv[1], '--db', sys.argv[2]])"
    killed_at("replace", body, str(out), db)
    assert not out.exists() and list(out.parent.glob(".run.csv.*.part"))
    assert run_cli("export", "1", "--out", str(out), db=db, fmu_path=fmu_path).returncode == 0
    assert sorted(p.name for p in out.parent.iterdir()) == ["run-events.csv", "run.csv"]


def test_an_unsaved_run_file_larger_than_a_run_can_be_is_refused_before_it_is_read(tmp_path, fmu_path):
    """A 2 GB file once took 4.3 GB of memory before its refusal: its size alone refuses it now
    (a sparse file: nothing is written to the disk)."""
    from db.store import MAX_UNSAVED_BYTES

    path = tmp_path / "rocking-unsaved-big.json"
    with open(path, "wb") as f:
        f.truncate(MAX_UNSAVED_BYTES + 1)
    db = f"sqlite:///{tmp_path / 'u.db'}"
    one_line_error(run_cli("db", "import-unsaved", str(path), db=db, fmu_path=fmu_path), "not a file of an unsaved run",
                   "GiB")
