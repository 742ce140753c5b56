"""Servers that do not answer as they should: a PostgreSQL URL or a Dask scheduler address
whose port accepts connections but never answers, or answers HTTP. Each command fails within
seconds with one line saying how long it waited, and a sweep whose executor cannot start is
marked failed, not left "running". The servers are sockets on the loopback address, in a
thread of this process; a test's bound is its subprocess's timeout."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from db.schema import Sweep
from db.session import open_database

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "sweep_sine_pulse.toml"
BOUND = 120  # s: far beyond the 5 s the commands wait, far below the 136 s and more they waited before


class _Server:
    """A listening socket on 127.0.0.1 whose connections are held open, unanswered (silent)
    or answered with an HTTP error (http)."""

    def __init__(self, http: bool):
        self.http = http
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(64)  # listening before its port is handed out: connections queue from now on
        self.port = self.sock.getsockname()[1]
        self.held: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:  # closed
                return
            self.held.append(conn)
            if self.http:
                threading.Thread(target=self._answer, args=(conn,), daemon=True).start()

    @staticmethod
    def _answer(conn: socket.socket) -> None:
        try:
            conn.recv(65536)
            conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\nContent-Length: 11\r\n\r\n"
                         b"Bad Request")
        except OSError:
            pass

    def close(self) -> None:
        self.sock.close()
        for conn in self.held:
            conn.close()


@pytest.fixture
def silent() -> Iterator[_Server]:
    server = _Server(http=False)
    yield server
    server.close()


@pytest.fixture
def http() -> Iterator[_Server]:
    server = _Server(http=True)
    yield server
    server.close()


def runners(*args: str, fmu_path: Path, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """The command line in a process of its own, which must end within BOUND seconds."""
    environ = {**os.environ, "ROCKING_FMU": str(fmu_path), **(env or {})}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, cwd=cwd,
                          env=environ, timeout=BOUND)


def one_line(p: subprocess.CompletedProcess, *words: str) -> None:
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    assert p.stderr.startswith("error: ") and p.stderr.count("\n") == 1, p.stderr[-2000:]
    assert "Traceback" not in p.stderr
    for w in words:
        assert w in p.stderr, (w, p.stderr)


# The first command waits the default connect timeout (5 s); the others name 1 s in the URL (the same rule
# gives both, db.session.connect_timeout), so that the suite does not wait 5 s for each.
@pytest.mark.parametrize("command,query,seconds", [
    (["db", "list", "runs"], "", 5),
    (["simulate", str(ROOT / "examples" / "free_rocking.toml")], "?connect_timeout=1", 1),
    (["sweep", str(SCENE), "--grid", "w=1:2:3"], "?connect_timeout=1", 1),
    (["export", "--sweep", "1", "--out", "x.csv"], "?connect_timeout=1", 1),
])
def test_a_postgresql_port_that_never_answers_fails_within_seconds(silent, fmu_path, tmp_path, command, query, seconds):
    url = f"postgresql+psycopg://rocking@127.0.0.1:{silent.port}/rocking{query}"
    p = runners(*command, "--db", url, fmu_path=fmu_path, cwd=tmp_path)
    one_line(p, f"127.0.0.1:{silent.port}", "no answer", f"within {seconds} s", "connect_timeout")


def test_rocking_db_naming_a_silent_server_fails_within_its_own_connect_timeout(silent, fmu_path, tmp_path):
    url = f"postgresql+psycopg://rocking@127.0.0.1:{silent.port}/rocking?connect_timeout=2"
    p = runners("db", "list", "runs", fmu_path=fmu_path, cwd=tmp_path, env={"ROCKING_DB": url})
    one_line(p, "no answer", "within 2 s")


def _sweeps(db: Path) -> list[tuple[int, int, str]]:
    with open_database(str(db), write=False)() as session:
        return [(s.done, s.total, s.status) for s in session.query(Sweep).order_by(Sweep.id)]


@pytest.mark.parametrize("server, words", [("silent", ["no answer from the Dask scheduler", "within 5 s"]),
                                           ("http", ["not as a Dask scheduler does"])])
def test_a_scheduler_that_does_not_answer_fails_the_sweep_within_seconds(server, words, request, fmu_path,
                                                                         tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install -e '.[dask]')")
    port = request.getfixturevalue(server).port
    db = tmp_path / "s.db"
    p = runners("sweep", str(SCENE), "--grid", "w=1:2:3", "--executor", "dask", "--scheduler",
                f"tcp://127.0.0.1:{port}", "--db", str(db), fmu_path=fmu_path, cwd=tmp_path)
    one_line(p, *words, f"tcp://127.0.0.1:{port}", "sweep 1 has 0 of 3 points stored")
    assert "MemoryError" not in p.stderr and "EiB" not in p.stderr
    assert _sweeps(db) == [(0, 3, "failed")]  # not listed as running


def test_a_postgresql_url_at_an_http_server_is_one_line(http, fmu_path, tmp_path):
    p = runners("db", "list", "runs", "--db", f"postgresql+psycopg://rocking@127.0.0.1:{http.port}/rocking",
                fmu_path=fmu_path, cwd=tmp_path)
    one_line(p, f"127.0.0.1:{http.port}", "cannot open the database")
