"""No command overwrites its inputs, its database or another of its outputs (issue 36, item 11):
the command refuses in one line, exit 2, and every file is left as it was."""

from __future__ import annotations

import argparse
import hashlib
import shutil
from pathlib import Path

import pytest

from conftest import run_cli
from runners.cli import args as cli_args
from runners.cli import clobber
from runners.cli.parser import build_parser

ROOT = Path(__file__).resolve().parents[1]


def _commands(parser: argparse.ArgumentParser, prefix=()):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, (*prefix, name))
            return
    yield " ".join(prefix), parser


def test_every_output_file_option_is_declared_and_every_declared_argument_exists():
    for name, p in _commands(build_parser()):
        reads, writes = p.get_default("_files") or ([], [])
        dests = {a.dest for a in p._actions}
        for dest, _ in (*reads, *writes):
            assert dest in dests, f"runners {name} declares {dest}, which it does not have"
        declared = {d for d, _ in writes}
        outputs = {a.dest for a in p._actions if a.type in (cli_args.output_file, cli_args.figure_file)}
        assert outputs <= declared, f"runners {name}: {outputs - declared} write files but are not declared"
        if any(a.dest == "db" for a in p._actions) and outputs:
            assert declared, name


@pytest.mark.parametrize("url,path", [(None, "rocking.db"), ("r.db", "r.db"), ("sqlite:///r.db", "r.db"),
                                      ("sqlite:////tmp/a/r.db", "/tmp/a/r.db"), ("sqlite:///r.db?mode=ro", "r.db"),
                                      ("sqlite://", None), ("sqlite:///:memory:", None),
                                      ("postgresql+psycopg://u@h/db", None)])
def test_the_sqlite_file_of_a_db_value(url, path, monkeypatch):
    monkeypatch.delenv("ROCKING_DB", raising=False)
    assert clobber.sqlite_path(url) == path


def _digests(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture
def place(tmp_path, monkeypatch):
    """A working folder with a scene, a stored run in r.db and a system file, all hashed."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROOT / "examples" / "sine_pulse.toml", tmp_path / "scene.toml")
    shutil.copy(ROOT / "examples" / "cabinet_on_floor.toml", tmp_path / "system.toml")
    (tmp_path / "x.png").write_bytes(b"not a figure")
    return tmp_path


CASES = [
    (["simulate", "scene.toml", "--out", "scene.toml"], "--out scene.toml is the scene file"),
    (["simulate", "scene.toml", "--out", "r.db", "--db", "r.db"], "--out r.db is the database"),
    (["simulate", "scene.toml", "--out", "r.db", "--db", "sqlite:///r.db"], "--out r.db is the database"),
    (["map", "latest", "--out", "m.png", "--db", "m.png"], "--out m.png is the database"),
    (["fragility", "1", "--out", "x.png", "--db", "sqlite:///x.png"], "--out x.png is the database"),
    (["ida", "1", "--out", "x.png", "--db", "x.png"], "--out x.png is the database"),
    (["export", "1", "--out", "r.db", "--db", "r.db"], "--out r.db is the database"),
    (["records", "export", "a", "--out", "r.db", "--db", "r.db"], "--out r.db is the database"),
    (["cosim", "system.toml", "--db", "sqlite:///r.db", "--csv", "r.db"], "--csv r.db is the database"),
    (["cosim", "system.toml", "--csv", "system.toml"], "--csv system.toml is the system file"),
    (["cosim", "system.toml", "--ssp", "system.toml"], "--ssp system.toml is the system file"),
    (["cosim", "system.toml", "--csv", "x.csv", "--out", "x.csv"], "--out and --csv both name x.csv"),
    (["cosim", "system.toml", "--csv", "x.ssp", "--ssp", "x.ssp"], "--ssp and --csv both name x.ssp"),
    (["compare", "1", "1", "--out", "x.png", "--recording", "x.png"], "--out and --recording both name x.png"),
]


@pytest.mark.parametrize("argv,says", CASES, ids=[" ".join(c[0][:1] + c[0][2:]) for c in CASES])
def test_a_command_refuses_to_overwrite_an_input_the_database_or_another_output(place, fmu_path, argv, says):
    before = _digests(place)
    r = run_cli(*argv, db=str(place / "r.db"), fmu_path=fmu_path)
    assert r.returncode == 2
    assert r.stderr.startswith(f"error: {says}") and r.stderr.count("\n") == 1, r.stderr
    assert _digests(place) == before


def test_the_same_file_through_a_link_is_refused(place, fmu_path):
    (place / "link.rrd").symlink_to(place / "scene.toml")
    (place / "hard.rrd").hardlink_to(place / "scene.toml")
    before = _digests(place)
    for name in ("link.rrd", "hard.rrd", "./sub/../scene.toml"):
        r = run_cli("simulate", "scene.toml", "--out", name, db=str(place / "r.db"), fmu_path=fmu_path)
        assert r.returncode == 2 and "is the scene file this command reads" in r.stderr, (name, r.stderr)
    assert _digests(place) == before


def test_distinct_files_still_run(place, fmu_path):
    r = run_cli("simulate", "scene.toml", "--out", "run.rrd", db=str(place / "r.db"), fmu_path=fmu_path)
    assert r.returncode == 0, r.stderr
    assert (place / "run.rrd").stat().st_size > 0 and (place / "r.db").is_file()
