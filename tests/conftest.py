"""Shared fixtures: the real FMU, built from model/c (or ROCKING_FMU)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from fmu_build import build_fmu
from fmu_build.build3 import build_fmu3
from runners.engine.fmu import RockingFMU


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    env = os.environ.get("ROCKING_FMU")
    return Path(env).resolve() if env else build_fmu()


@pytest.fixture(scope="session")
def fmu3_path() -> Path:
    env = os.environ.get("ROCKING_FMU3")
    return Path(env).resolve() if env else build_fmu3()


@pytest.fixture(scope="session")
def building_fmu_path() -> Path:
    """build/ShearBuilding.fmu (or ROCKING_BUILDING_FMU, which runners cosim reads too)."""
    from fmu_build.building import build_building_fmu

    env = os.environ.get("ROCKING_BUILDING_FMU")
    return Path(env).resolve() if env else build_building_fmu()


@pytest.fixture(scope="session")
def fmu(fmu_path: Path):
    with RockingFMU(fmu_path) as f:
        yield f


def build_container(fmu_path: Path, folder: Path, step_size: float, name: str = "Container.fmu") -> Path:
    """A container FMU (pip fmu-manipulation-toolbox's fmucontainer) whose own
    C runtime imports ours; its variables are ours prefixed "rockingblock."."""
    tool = Path(sys.executable).parent / "fmucontainer"
    if not tool.exists():
        tool = shutil.which("fmucontainer")
    assert tool, "fmucontainer (pip fmu-manipulation-toolbox) is not installed"
    shutil.copy(fmu_path, folder / "RockingBlock.fmu")
    (folder / "container.json").write_text(json.dumps({
        "name": name, "step_size": step_size, "auto_input": True, "auto_output": True,
        "auto_parameter": True, "fmu": ["RockingBlock.fmu"]}))
    proc = subprocess.run([str(tool), "-container", "container.json", "-fmu-directory", "."], cwd=folder,
                          capture_output=True, text=True)
    container = folder / name
    assert container.is_file(), proc.stdout + proc.stderr
    return container


class Slave:
    """A raw fmpy slave with its log captured, for call-sequence tests."""

    def __init__(self, fmu):
        self.messages: list[str] = []
        self.fmu = fmu
        self.s, self._cb = fmu.instantiate(lambda st, cat, msg: self.messages.append(msg))
        self.vr = {n: v.valueReference for n, v in fmu.vars.items()}

    def start(self, params=None, t0=0.0):
        self.s.setupExperiment(startTime=t0)
        self.fmu.set_parameters(self.s, params or {})
        self.s.enterInitializationMode()
        self.s.exitInitializationMode()

    def real(self, *names):
        return self.s.getReal([self.vr[n] for n in names])

    def outputs(self):
        return self.real("block1.theta", "block1.omega", "energy") + self.s.getInteger(
            [self.vr["impacts"], self.vr["peaks"]]
        )

    def expect_error(self, call, text):
        n = len(self.messages)
        with pytest.raises(Exception):
            call()
        assert any(text in m for m in self.messages[n:]), self.messages[n:]

    def close(self):
        self.s.freeInstance()


@pytest.fixture(autouse=True)
def _scratch_database(tmp_path_factory, monkeypatch):
    """Runs stored by the tests go to a scratch SQLite file, never to ./rocking.db."""
    monkeypatch.setenv("ROCKING_DB", f"sqlite:///{tmp_path_factory.getbasetemp() / 'tests.db'}")


def compile_white_box(tmp_path: Path, source: str, *extra: str,
                      flags: tuple[str, ...] = ("-O2", "-Wall", "-Wextra", "-Werror")) -> Path:
    """A white-box check tests/c/<source> (it includes the model/c file it tests) compiled with the system's gcc,
    with the model/c files ``extra``; the executable's path."""
    root = Path(__file__).resolve().parents[1]
    exe = tmp_path / Path(source).stem
    subprocess.run(["gcc", "-std=c99", *flags, f"-I{root / 'model' / 'c'}", "-o", str(exe),
                    str(root / "tests" / "c" / source), *(str(root / "model" / "c" / f) for f in extra), "-lm"],
                   check=True)
    return exe


def run_cli(*args: str, db: str, fmu_path: Path) -> subprocess.CompletedProcess:
    """The runners command line in this process (runners.cli.main.main, as the console script
    calls it): exit status and what it printed, without a Python start-up per call."""
    import contextlib
    import io

    from runners.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    old = {k: os.environ.get(k) for k in ("ROCKING_FMU", "ROCKING_DB")}
    os.environ.update(ROCKING_FMU=str(fmu_path), ROCKING_DB=db)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:  # argparse refuses an argument (runners.cli.args.Parser.error)
                code = exc.code
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return subprocess.CompletedProcess(["runners", *args], code, out.getvalue(), err.getvalue())


# A last resort against a hang, never a measure of speed (s): a working command ends long before it,
# even on a machine running a second full suite beside this one. Tests wait for what they need to see
# (wait_for), never for a time.
PATIENCE = 900.0


def wait_for(condition: Callable[[], object], what: str, proc: subprocess.Popen | None = None,
             timeout: float = PATIENCE) -> object:
    """Poll `condition` until it gives a true value, and return that value: a wait for a readiness
    signal, not for a time (the 10 ms pause between polls only spares the CPU). Fails naming
    `what` if `proc` ends first, or after `timeout` s (PATIENCE: a last resort against a hang)."""
    end = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"the process ended (exit {proc.returncode}) before {what}")
        if time.monotonic() > end:
            raise AssertionError(f"no {what} after {timeout:.0f} s")
        if proc is not None:
            try:  # returns at once if the process ends, which is checked above on the next pass
                proc.wait(timeout=0.01)
            except subprocess.TimeoutExpired:
                pass
        else:
            threading.Event().wait(0.01)  # the pause between polls of the condition, sparing the CPU


def cpu_seconds(pid: int) -> float:
    """The CPU time (user + system, s) process `pid` has used so far (Linux /proc): a measure of
    how far it has got that does not depend on how busy the machine is, as wall time does."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def signal_masks(pid: int) -> dict[str, int | str]:
    """Process `pid`'s state letter and signal masks from /proc/PID/status (Linux): "SigCgt"
    (signals it has a handler for), "SigIgn" (ignored), "State" (R, S, T stopped, Z ended...)."""
    out: dict[str, int | str] = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("SigCgt", "SigIgn"):
            out[key] = int(value, 16)
        elif key == "State":
            out[key] = value.split()[0]
    return out


def _postgres_bin() -> Path | None:
    found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"))
    return found[-1].parent if found else None


class PostgresServer:
    """A throw-away PostgreSQL server from Debian's packages on loopback (initdb in a temporary
    folder, trust authentication, fsync off): .url, and .start(), .stop() (immediate: as a crash,
    no goodbye to its clients), .remove(). pytest.skip with the reason where it is not installed."""

    def __init__(self):
        import socket
        import tempfile

        bindir = _postgres_bin()
        if bindir is None:
            pytest.skip("PostgreSQL is not installed (Debian: apt-get install postgresql; .ci/run installs it)")
        # not under pytest's temporary folder: as root that is private to root, and the server runs as postgres
        self.folder = Path(tempfile.mkdtemp(prefix="rocking-postgres-"))
        self.as_user: list[str] = []
        if os.geteuid() == 0:  # initdb refuses to run as root: run the server as Debian's postgres user
            shutil.chown(self.folder, "postgres")
            self.as_user = ["runuser", "-u", "postgres", "--"]
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        self.bindir, self.data = bindir, self.folder / "data"
        subprocess.run([*self.as_user, str(bindir / "initdb"), "-D", str(self.data), "-A", "trust", "-U", "postgres",
                        "--no-sync"], check=True, capture_output=True)
        self.url = f"postgresql+psycopg://postgres@127.0.0.1:{self.port}"
        self.start()

    def _pg_ctl(self, *args: str, check: bool = True) -> None:
        subprocess.run([*self.as_user, str(self.bindir / "pg_ctl"), "-D", str(self.data), *args], check=check,
                       capture_output=True)

    def start(self) -> None:
        self._pg_ctl("-w", "-t", f"{PATIENCE:.0f}", "-l", str(self.folder / "log"), "-o",  # not 60 s
                     f"-p {self.port} -k {self.folder} -c listen_addresses=127.0.0.1 -c fsync=off "
                     "-c max_connections=200", "start")

    def stop(self) -> None:
        self._pg_ctl("-m", "immediate", "stop")

    def remove(self) -> None:
        self._pg_ctl("-m", "immediate", "stop", check=False)
        shutil.rmtree(self.folder, ignore_errors=True)


@pytest.fixture(scope="session")
def postgres_server(tmp_path_factory):
    """The URL of a PostgreSQL server (PostgresServer) for the session's tests; skipped with the
    reason where the server is not installed."""
    server = PostgresServer()
    yield server.url
    server.remove()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path) -> str:
    """A new empty database: an SQLite file, and a database on the PostgreSQL server."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'test.db'}"
    import uuid

    from sqlalchemy import create_engine, text

    server = request.getfixturevalue("postgres_server")
    name = f"t_{uuid.uuid4().hex[:12]}"
    engine = create_engine(f"{server}/postgres", isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        conn.execute(text(f"CREATE DATABASE {name}"))
    engine.dispose()
    return f"{server}/{name}"
