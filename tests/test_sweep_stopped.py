"""A sweep that its database stopped is listed as stopped, not running, and resumes (issue 36,
item 17b): a disk that fills up under an SQLite database, a PostgreSQL server that goes away and
comes back, a runner killed outright. Real failures of real databases: a small tmpfs in a private
mount namespace, a throw-away PostgreSQL server stopped mid-sweep (runners.engine.sweep_lock)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy import create_engine, func, select, text

import runners
from conftest import PATIENCE, PostgresServer, run_cli, wait_for
from db.schema import Run, Sweep
from db.session import open_database

ROOT = Path(__file__).resolve().parent.parent
# 1600 points of about 2.4 ms each on one worker: seconds of work, stopped below a second in
HARMONIC = [str(ROOT / "examples" / "harmonic.toml"), "--grid", "excitation.frequency=2:8:40", "--grid",
            "excitation.displacement=0.001:0.004:40", "--stop-time", "20", "--quiet", "--workers", "1"]
TOTAL = 1600


def runner(url: str, fmu_path: Path, *args: str) -> subprocess.Popen:
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": url}
    return subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT, start_new_session=True)


def count_runs(url: str) -> int:
    try:
        with open_database(url, write=False)() as s:
            return s.scalar(select(func.count()).select_from(Run))
    except Exception:  # not created yet, or the server is starting
        return 0


def sweep_status(url: str) -> str | None:
    """Sweep 1's stored status, None before the database or the sweep exists."""
    try:
        with open_database(url, write=False)() as s:
            sw = s.get(Sweep, 1)
            return sw.status if sw is not None else None
    except Exception:  # not created yet, or the server is starting
        return None


def pause(p: subprocess.Popen) -> None:
    """Stop the runner and its workers where they are (SIGSTOP to its process group): a sweep paused after its
    first points is still running whatever the machine's speed, so its listing cannot race its end."""
    os.killpg(p.pid, signal.SIGSTOP)


def listed_status(url: str, fmu_path: Path) -> str:
    """The status `runners db list sweeps` prints for sweep 1, checked against runners.open_db's."""
    p = run_cli("db", "list", "sweeps", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if x.strip().startswith("1 "))
    api = runners.open_db(url).sweeps().loc[1, "status"]
    status = line.split(f"/{TOTAL} ")[1]
    assert status.split(" ")[0] == api == runners.open_db(url).sweep(1).stats["status"], line
    return status


def finish(url: str, fmu_path: Path) -> None:
    p = run_cli("sweep", "1", "--quiet", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(url)() as s:
        assert s.scalar(select(func.count(func.distinct(Run.grid_index)))) == TOTAL == s.get(Sweep, 1).done
    assert listed_status(url, fmu_path) == "done"


# Run inside a private mount namespace whose folder argv[1] is a 20 MB tmpfs (SQLite must see the
# tmpfs by its own path: through /proc/PID/root it resolves the link and writes elsewhere): a sweep,
# the disk filled once it has stored points, what the list then says, the sweep finished with the
# space freed. Prints the facts as JSON.
FULL_DISK = """
import json, os, sys
import runners
from conftest import PATIENCE, run_cli, wait_for
from test_sweep_stopped import HARMONIC, TOTAL, count_runs, runner

disk = sys.argv[1]
url = f"sqlite:///{disk}/s.db"
fmu = os.environ["ROCKING_FMU"]
p = runner(url, fmu, *HARMONIC)
wait_for(lambda: count_runs(url) >= 1, "the first points stored", p)
with open(f"{disk}/filler", "wb", buffering=0) as f:
    for size in (1 << 20, 1 << 12, 1):  # large blocks, then to the last page and byte
        try:
            while True:
                f.write(bytes(size))
        except OSError:
            pass
_, err = p.communicate(timeout=PATIENCE)
os.unlink(f"{disk}/filler")
facts = {"code": p.returncode, "error": err, "listed": run_cli("db", "list", "sweeps", db=url, fmu_path=fmu).stdout,
         "api": runners.open_db(url).sweeps().loc[1, "status"]}
resumed = run_cli("sweep", "1", "--quiet", db=url, fmu_path=fmu)
facts.update(resumed=resumed.returncode, resume_error=resumed.stderr, count=count_runs(url),
             final=runners.open_db(url).sweeps().loc[1, "status"])
print(json.dumps(facts))
"""


def test_a_sweep_stopped_by_a_full_disk_is_listed_stopped_and_resumes(tmp_path, fmu_path):
    if os.geteuid() != 0 or not shutil.which("unshare"):
        pytest.skip("a tmpfs of its own needs root and unshare -m")
    disk = tmp_path / "disk"
    disk.mkdir()
    (tmp_path / "full_disk.py").write_text(FULL_DISK)
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "PYTHONPATH": f"{ROOT}:{ROOT / 'tests'}"}
    p = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c",
                        'mount -t tmpfs -o size=20m tmpfs "$1" && exec "$2" "$3" "$1"', "sh", str(disk),
                        sys.executable, str(tmp_path / "full_disk.py")], capture_output=True, text=True, env=env,
                       cwd=ROOT, timeout=PATIENCE)
    if p.returncode != 0 and "mount" in p.stderr and not p.stdout:
        pytest.skip(f"cannot mount a tmpfs in a private mount namespace: {p.stderr.strip()}")
    assert p.returncode == 0, p.stderr
    facts = json.loads(p.stdout.splitlines()[-1])
    err = facts["error"]
    assert facts["code"] == 2 and err.count("\n") == 1 and "the disk is full" in err and "runners sweep 1" in err, err
    assert f"/{TOTAL} stopped (runners sweep 1 finishes it)" in facts["listed"] and facts["api"] == "stopped", facts
    assert facts["resumed"] == 0 and facts["count"] == TOTAL and facts["final"] == "done", facts


@pytest.fixture
def own_postgres_server():
    """A PostgreSQL server of this test's own, which it may stop and start again, with a database
    "sweeps": (its URL, stop, start). Skipped where PostgreSQL is not installed."""
    server = PostgresServer()
    engine = create_engine(f"{server.url}/postgres", isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        conn.execute(text("CREATE DATABASE sweeps"))
    engine.dispose()
    yield f"{server.url}/sweeps", server.stop, server.start
    server.remove()


def test_a_sweep_whose_database_server_went_away_is_listed_stopped_and_resumes(own_postgres_server, fmu_path):
    url, stop, start = own_postgres_server
    p = runner(url, fmu_path, *HARMONIC)
    wait_for(lambda: sweep_status(url) == "running", "the sweep stored as running", p)
    pause(p)
    assert listed_status(url, fmu_path) == "running"  # while it runs
    stop()
    os.killpg(p.pid, signal.SIGCONT)  # on into the server that went away
    _, err = p.communicate(timeout=PATIENCE)
    assert p.returncode == 2 and err.count("\n") == 1 and err.startswith("error: ") and "runners sweep 1" in err, err
    start()
    with open_database(url)() as s:
        assert s.get(Sweep, 1).status == "running"  # what the runner could not change: the server was gone
    assert listed_status(url, fmu_path) == "stopped (runners sweep 1 finishes it)"
    finish(url, fmu_path)


def test_a_runner_killed_outright_leaves_its_sweep_listed_stopped(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    p = runner(url, fmu_path, *HARMONIC)
    wait_for(lambda: sweep_status(url) == "running", "the sweep stored as running", p)
    pause(p)
    assert listed_status(url, fmu_path) == "running"
    os.killpg(p.pid, signal.SIGKILL)  # the runner and its workers, as the out-of-memory killer would
    p.communicate(timeout=PATIENCE)
    assert listed_status(url, fmu_path) == "stopped (runners sweep 1 finishes it)"
    finish(url, fmu_path)
    assert not list(tmp_path.glob("s.db.sweep-*"))  # the lock file the killed runner left is gone
