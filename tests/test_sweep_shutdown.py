"""A local sweep's shutdown always ends (runners.engine.sweep._LocalExecutor, _Stops): a worker killed
half-way through sending a chunk's results, which leaves the pool's reading thread waiting for the
rest for ever, stops the sweep in one line; a SIGTERM whose handler happens to run inside a finalizer
(where Python prints the exception and drops it) still stops it as an interruption. Both together
hung test_sweep_confirm.py's terminal sweep now and then: the stop lost, the worker dead, the runner
waiting for its chunk. The real FMU, real SQLite files, real signals; Linux (/proc)."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

from conftest import PATIENCE, run_cli, wait_for

ROOT = Path(__file__).resolve().parent.parent
# 100,000 points in chunks of 2048 (a chunk's results: about 370 kB, more than a pipe holds) on one worker
SWEEP = [str(ROOT / "examples" / "sweep_sine_pulse.toml"), "--grid", "w=1:12:100", "--grid", "a=1.01:8:1000",
         "--workers", "1", "--quiet"]
TOTAL = 100_000

# runners with the group's SIGTERM sent from a finalizer of the main thread, that of the first chunk
# of results it lets go once the file ARMED exists (its workers, forked from it, never send it)
FINALIZER = """
import os, runpy, signal, sys, threading
from runners.engine import sweep_worker

armed, main = sys.argv[1], os.getpid()

def finalizer(self):
    if os.getpid() == main and threading.current_thread() is threading.main_thread() and os.path.exists(armed):
        os.remove(armed)
        os.killpg(0, signal.SIGTERM)  # its handler runs here, inside the finalizer

sweep_worker.Chunk.__del__ = finalizer
sys.argv = ["runners", *sys.argv[2:]]
runpy.run_module("runners.cli", run_name="__main__", alter_sys=True)
"""


def stored(db: Path) -> int:
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
            return conn.execute("SELECT count(*) FROM runs").fetchone()[0]
    except sqlite3.Error:  # not created yet
        return 0


def sweep_row(db: Path) -> tuple[str, int, int]:
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT status, done, total FROM sweeps WHERE id = 1").fetchone()


def children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # ended meanwhile
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def state(pid: int) -> str:
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]


def start(db: Path, fmu_path: Path, *command: str) -> subprocess.Popen:
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": f"sqlite:///{db}"}
    return subprocess.Popen([*command, "sweep", *SWEEP], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT, start_new_session=True)


def test_a_worker_killed_while_it_sends_a_chunk_stops_the_sweep_in_one_line_and_it_resumes(tmp_path, fmu_path):
    db = tmp_path / "s.db"
    p = start(db, fmu_path, sys.executable, "-m", "runners.cli")
    wait_for(lambda: stored(db) >= 2048, "a chunk stored", p)
    os.kill(p.pid, signal.SIGSTOP)  # the runner reads nothing more: the worker's next chunk fills the pipe
    try:
        (worker,) = children(p.pid)
        wait_for(lambda: Path(f"/proc/{worker}/wchan").read_text().endswith("pipe_write"),
                 "the worker blocked half-way through sending a chunk", p)
        os.kill(worker, signal.SIGKILL)  # as the out-of-memory killer would; the runner is not told
        wait_for(lambda: state(worker) == "Z", "the worker dead", p)
    finally:
        os.kill(p.pid, signal.SIGCONT)
    out, err = p.communicate(timeout=PATIENCE)
    assert p.returncode == 2 and err.count("\n") == 1, err
    assert err.startswith("error: a worker process died (killed, or out of memory); sweep 1 has "), err
    assert "finish it with runners sweep 1" in err and out == "", err
    status, done, total = sweep_row(db)
    assert status == "stopped" and 2048 <= done == stored(db) < total == TOTAL
    assert not Path(f"/proc/{worker}").exists()  # reaped
    q = run_cli("sweep", "1", "--quiet", db=f"sqlite:///{db}", fmu_path=fmu_path)
    assert q.returncode == 0, q.stderr
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT count(DISTINCT grid_index), count(*) FROM runs").fetchone() == (TOTAL, TOTAL)
    assert sweep_row(db) == ("done", TOTAL, TOTAL)


def test_a_sigterm_whose_handler_runs_in_a_finalizer_still_interrupts_the_sweep(tmp_path, fmu_path):
    db, driver, armed = tmp_path / "s.db", tmp_path / "finalizer.py", tmp_path / "armed"
    driver.write_text(FINALIZER)
    p = start(db, fmu_path, sys.executable, str(driver), str(armed))
    wait_for(lambda: stored(db) >= 2048, "a chunk stored", p)
    armed.touch()
    out, err = p.communicate(timeout=PATIENCE)
    assert not armed.exists()  # the SIGTERM was sent from the finalizer
    # not "Exception ignored in: <function finalizer ...>" and a traceback, then "a worker process died"
    assert p.returncode == 130 and err.count("\n") == 1 and out == "", err
    assert err.startswith("error: interrupted; sweep 1 has ") and "finish it with runners sweep 1" in err, err
    status, done, total = sweep_row(db)
    assert status == "interrupted" and 2048 <= done == stored(db) < total == TOTAL
