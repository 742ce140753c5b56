"""Shared fixtures: the real FMU, built from model/c (or ROCKING_FMU)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from fmu_build import build_fmu
from runners.fmu import RockingFMU


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    env = os.environ.get("ROCKING_FMU")
    return Path(env).resolve() if env else build_fmu()


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


@pytest.fixture(autouse=True)
def _scratch_database(tmp_path_factory, monkeypatch):
    """Runs stored by the tests go to a scratch SQLite file, never to ./rocking.db."""
    monkeypatch.setenv("ROCKING_DB", f"sqlite:///{tmp_path_factory.getbasetemp() / 'tests.db'}")


def run_cli(*args: str, db: str, fmu_path: Path) -> subprocess.CompletedProcess:
    """The runners command line in this process (runners.cli.main, as the console script
    calls it): exit status and what it printed, without a Python start-up per call."""
    import contextlib
    import io

    from runners.cli import main

    out, err = io.StringIO(), io.StringIO()
    old = {k: os.environ.get(k) for k in ("ROCKING_FMU", "ROCKING_DB")}
    os.environ.update(ROCKING_FMU=str(fmu_path), ROCKING_DB=db)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(list(args))
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return subprocess.CompletedProcess(["runners", *args], code, out.getvalue(), err.getvalue())
