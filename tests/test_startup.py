"""A command loads only the libraries it uses (docs/cli.md, "Start-up time"): `runners simulate
--no-store` of a scene without a record starts without pandas, SciPy, SQLAlchemy, Alembic,
Matplotlib, Rerun or pyarrow; `runners db list` on an up-to-date database with SQLAlchemy alone.

Nothing here is timed (times depend on the machine): each test drives the real command in a fresh
Python process and lists the heavy libraries loaded by the end of it. A top-level import of one
of them in a module on these paths fails the test; move it into the function that needs it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"
HEAVY = ("pandas", "scipy", "sqlalchemy", "alembic", "matplotlib", "rerun", "pyarrow")

# runs the command line in this process, then prints (exit code, the heavy libraries loaded)
DRIVE = """\
import json, sys
from runners.cli import parser
code = parser.main(sys.argv[1:])
print(json.dumps([code, sorted({m.split(".")[0] for m in sys.modules} & set(%r))]))
""" % (HEAVY,)


def loaded_by(*args: str, db: str, fmu_path: Path) -> list[str]:
    """The heavy libraries a fresh process has loaded after running `runners ARGS` (which must succeed)."""
    env = {**os.environ, "ROCKING_DB": db, "ROCKING_FMU": str(fmu_path)}
    p = subprocess.run([sys.executable, "-c", DRIVE, *args], capture_output=True, text=True, cwd=ROOT, env=env,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    code, heavy = json.loads(p.stdout.strip().splitlines()[-1])
    assert code == 0, p.stdout + p.stderr
    return heavy


@pytest.fixture(scope="module")
def up_to_date(tmp_path_factory, fmu_path) -> str:
    """An SQLite database at the newest schema revision, with one stored run."""
    db = f"sqlite:///{tmp_path_factory.mktemp('startup') / 's.db'}"
    for args in (("db", "init"), ("simulate", str(EX / "free_rocking.toml"))):
        p = run_cli(*args, db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
    return db


def test_simulate_no_store_loads_no_heavy_library(up_to_date, fmu_path):
    assert loaded_by("simulate", str(EX / "free_rocking.toml"), "--no-store", db=up_to_date, fmu_path=fmu_path) == []


def test_simulate_no_store_as_json_loads_no_heavy_library(up_to_date, fmu_path):
    heavy = loaded_by("simulate", str(EX / "sine_pulse.toml"), "--no-store", "--json", db=up_to_date,
                      fmu_path=fmu_path)
    assert heavy == []


@pytest.mark.parametrize("table", ["runs", "blocks", "scenes"])
def test_db_list_loads_sqlalchemy_alone(up_to_date, fmu_path, table):
    """An up-to-date database is opened without Alembic: its revision is the newest one the
    migration scripts name, which db.session reads from them without loading Alembic."""
    assert loaded_by("db", "list", table, db=up_to_date, fmu_path=fmu_path) == ["sqlalchemy"]


def test_the_plain_reading_of_the_newest_revision_is_alembics():
    """db.session reads the newest revision from the migration scripts' lines; Alembic, which
    decides when a database is migrated, must find the same one."""
    from alembic.config import Config
    from alembic.script import ScriptDirectory

    from db.session import MIGRATIONS, _plain_head

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    assert _plain_head() is not None
    assert _plain_head() == ScriptDirectory.from_config(cfg).get_current_head()


def test_the_package_loads_its_api_on_first_use():
    """`import runners` (which every command does first) does not load runners.api; its names do,
    on first use, and are runners.api's own."""
    code = ("import sys, runners; before = 'runners.api' in sys.modules; import runners.api as api; "
            "print(before, runners.simulate is api.simulate, runners.RunResult is api.RunResult, "
            "'simulate' in dir(runners), bool(runners.__version__))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["False", "True", "True", "True", "True"]
    p = subprocess.run([sys.executable, "-c", "import runners; runners.no_such_name"], capture_output=True, text=True,
                       cwd=ROOT, timeout=120)
    assert p.returncode == 1 and "AttributeError: module 'runners' has no attribute 'no_such_name'" in p.stderr


@pytest.mark.slow  # (a benchmark: each command timed by both installations, with and without bytecode: 11 s)
def test_bench_startup_times_both_commands_of_both_installations():
    """runners bench --startup --baseline PYTHON: each command's CPU time by both installations,
    with and without cached bytecode, and the ratio (here both are this one: the values are the
    machine's, only their presence and consistency are checked)."""
    from runners.analysis.bench import markdown_sections
    from runners.analysis.bench_startup import run_startup_bench

    (section,) = markdown_sections(run_startup_bench(sys.executable, repeats=1))
    assert section["columns"] == ["command", "bytecode", "CPU s, baseline", "CPU s, this", "ratio this / baseline"]
    assert len(section["rows"]) == 8
    for command, _, old, new, ratio in section["rows"]:
        rounding = ratio * (5e-4 / old + 5e-4 / new) + 5e-4  # the table's three decimals
        assert old > 0 and new > 0 and abs(ratio - new / old) <= rounding, (command, old, new, ratio)
    until_fmu, whole = section["rows"][0][3], section["rows"][1][3]
    assert until_fmu < whole  # the start-up is part of the command


def test_bench_baseline_without_startup_is_a_one_line_error(fmu_path, tmp_path):
    p = run_cli("bench", "--baseline", sys.executable, db=f"sqlite:///{tmp_path / 'b.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stdout == "" and p.stderr.strip() == "error: --baseline is the other installation " \
                                                                        "of --startup or --throughput"


def test_a_run_whose_frames_are_not_built_yet_pickles_and_builds_them_after(fmu_path):
    """runners.simulate builds a run's series and events on first use; the result still pickles
    (as one returned from a worker process does) and gives the same frames after."""
    import pickle

    from runners import simulate

    run = simulate(EX / "free_rocking.toml", fmu=fmu_path, stop_time=0.5)
    copy = pickle.loads(pickle.dumps(run))
    assert copy.summary == run.summary and copy.report == run.report
    assert copy.series.equals(run.series) and copy.events.equals(run.events)
    assert len(run.series) > 10 and (run.events["kind"] == "impact").any()
