"""A large sweep is estimated and confirmed before it starts (issue 36, item 4a): its points, the
database it fills and its time from a few of its points timed through the real worker code; on a
terminal it asks, elsewhere it is refused in one line unless --yes (runners.sweep: confirm=True);
small sweeps start as before. The real FMU, real SQLite files, a real pseudo-terminal."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy import func, select

import runners
from conftest import PATIENCE, run_cli, wait_for
from db.schema import Run, Sweep
from db.session import open_database
from runners.engine.sweep import BYTES_PER_POINT, CONFIRM_BYTES, ESTIMATE_FROM, SweepEstimate

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "sweep_sine_pulse.toml"
HUGE = ["--grid", "w=1:12:10000", "--grid", "a=1.01:8:1000"]  # 10^7 points: 4 GB of results


def sweeps_in(url: str) -> int:
    path = Path(url.removeprefix("sqlite:///"))
    if not path.exists():
        return 0
    with open_database(url)() as s:
        return s.scalar(select(func.count()).select_from(Sweep))


def stored(url: str) -> int:
    import sqlite3

    try:
        with sqlite3.connect(f"file:{url.removeprefix('sqlite:///')}?mode=ro", uri=True) as conn:
            return conn.execute("SELECT count(*) FROM runs").fetchone()[0]
    except sqlite3.Error:
        return 0


def test_a_huge_sweep_off_a_terminal_is_refused_in_one_line_with_its_estimate(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    p = run_cli("sweep", str(SCENE), *HUGE, "--workers", "2", db=url, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stdout == "", p.stderr
    line = p.stderr.strip()
    assert line.startswith("error: a large sweep: 10,000,000 points: about 4 GB in the database and about ")
    assert "with 2 workers" in line and "add --yes to run it" in line and "nothing was stored" in line, line
    assert re.search(r"\(\d[\d.e+-]* ms a point, measured on \d+ of them\)", line), line
    assert sweeps_in(url) == 0


def test_the_python_api_asks_for_confirm(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    grid = {"w": (1, 12, 10000), "a": (1.01, 8, 1000)}
    with pytest.raises(runners.ArgumentError, match=r"^a large sweep: 10,000,000 points: .* give confirm=True"):
        runners.sweep(SCENE, grid, db=url, fmu=fmu_path, workers=2)
    asked: list[SweepEstimate] = []
    with pytest.raises(runners.ArgumentError, match="give confirm=True"):
        runners.sweep(SCENE, grid, db=url, fmu=fmu_path, workers=2, confirm=lambda e: asked.append(e) or False)
    (estimate,) = asked
    assert estimate.points == 10 ** 7 and estimate.bytes == 10 ** 7 * BYTES_PER_POINT >= CONFIRM_BYTES
    assert estimate.workers == 2 and estimate.seconds_per_point > 0 and estimate.measured >= 1
    assert estimate.seconds == pytest.approx(10 ** 7 * estimate.seconds_per_point / 2) and estimate.large
    assert sweeps_in(url) == 0
    with pytest.raises(runners.ArgumentError, match="confirm must be"):
        runners.sweep(SCENE, grid, db=url, fmu=fmu_path, confirm="yes")


def test_a_sweep_below_the_thresholds_starts_without_asking(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    assert 100 * 120 >= ESTIMATE_FROM  # estimated, and small: it runs
    sw = runners.sweep(SCENE, {"w": (1, 12, 100), "a": (1.01, 8, 120)}, db=url, fmu=fmu_path, workers=2)
    assert sw.stats["stored"] == 12000
    p = run_cli("sweep", str(SCENE), "--grid", "w=1:12:10", "--grid", "a=1.01:8:10", "--quiet", db=url,
                fmu_path=fmu_path)
    assert p.returncode == 0 and p.stderr == "", p.stderr


def _on_a_terminal(url: str, fmu_path: Path, answer: str, *extra: str) -> tuple[subprocess.Popen, int, str]:
    """runners sweep of HUGE with stdin and stderr on a pseudo-terminal, answering `answer` once it
    asks; (the process, the terminal's master end, what the terminal showed up to the question)."""
    master, slave = os.openpty()
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": url}
    p = subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", str(SCENE), *HUGE, "--workers", "1",
                          "--quiet", *extra], stdin=slave, stderr=slave, stdout=subprocess.PIPE, text=True, env=env,
                         cwd=ROOT, start_new_session=True)
    os.close(slave)
    shown = [""]

    def asked() -> bool:
        import select as sel

        while sel.select([master], [], [], 0)[0]:
            try:
                shown[0] += os.read(master, 4096).decode()
            except OSError:
                break
        return "Run it? [y/N]" in shown[0]

    wait_for(asked, "the question on the terminal", p)
    os.write(master, f"{answer}\n".encode())
    return p, master, shown[0]


def test_on_a_terminal_it_asks_and_a_no_stores_nothing(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    p, master, shown = _on_a_terminal(url, fmu_path, "n")
    try:
        assert "a large sweep: 10,000,000 points: about 4 GB in the database" in shown, shown
        p.wait(timeout=PATIENCE)
        assert p.returncode == 2
    finally:
        os.close(master)
    assert sweeps_in(url) == 0


def test_on_a_terminal_a_yes_starts_it(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    p, master, _ = _on_a_terminal(url, fmu_path, "y")
    try:
        wait_for(lambda: stored(url) >= 500, "500 points stored", p)
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        p.wait(timeout=PATIENCE)
        os.close(master)
    with open_database(url)() as s:
        assert s.get(Sweep, 1).total == 10 ** 7 and s.scalar(select(func.count()).select_from(Run)) >= 500


def test_yes_starts_it_off_a_terminal_with_its_estimate_as_a_note(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 's.db'}"
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": url}
    p = subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", str(SCENE), *HUGE, "--workers", "1", "--yes"],
                         stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                         cwd=ROOT, start_new_session=True)
    try:
        wait_for(lambda: stored(url) >= 500, "500 points stored", p)
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        _, err = p.communicate(timeout=PATIENCE)
    assert err.startswith("note: a large sweep: 10,000,000 points: about 4 GB"), err
