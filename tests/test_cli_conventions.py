"""The command line's conventions (docs/cli.md): --version, --json on every reporting command,
--out for the file a command writes (the former spellings still work, with a note), ids
positional (or 'latest'), --quiet, db list runs' header and filters, one-line errors, and a
parser that loads nothing heavy."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from conftest import PATIENCE, run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"


@pytest.fixture(scope="module")
def stocked(tmp_path_factory, fmu_path):
    """A real SQLite file: two single runs, a 2 x 2 sweep between them, a third single run, a
    measured peak table, a record and a 3-run sweep over it."""
    folder = tmp_path_factory.mktemp("conventions")
    db = f"sqlite:///{folder / 'c.db'}"

    def ok(*args):
        p = run_cli(*args, db=db, fmu_path=fmu_path)
        assert p.returncode == 0, (args, p.stderr)
        return p

    ok("db", "init")
    ok("simulate", str(EX / "free_rocking.toml"))
    ok("simulate", str(EX / "free_rocking_block2.toml"))
    ok("sweep", str(EX / "sweep_sine_pulse.toml"), "--grid", "w=1:2:2", "--grid", "a=1.1:3:2", "--workers", "1", "-q")
    ok("simulate", str(EX / "harmonic.toml"))
    ok("import-measured", str(EX / "measured_peaks_block2.csv"))
    ok("records", "import", str(EX / "pulse_3hz.AT2"), "--name", "pulse3")
    ok("sweep", str(EX / "statue.toml"), "--records", "pulse3", "--im", "pga=0.1:0.5:3", "--workers", "1", "-q")
    return db, folder


def cli(stocked, fmu_path, *args):
    return run_cli(*args, db=stocked[0], fmu_path=fmu_path)


def one_line_error(p, *words):
    assert p.returncode != 0 and p.stdout == "", (p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "unexpected" not in lines[0], p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


# --- --version and start-up ----------------------------------------------------------------------

def test_version_names_the_distribution_and_the_fmu(fmu_path):
    p = subprocess.run([sys.executable, "-m", "runners.cli", "--version"], capture_output=True, text=True, cwd=ROOT,
                       env={**__import__("os").environ, "ROCKING_FMU": str(fmu_path)})
    assert p.returncode == 0 and p.stderr == "", p.stderr
    assert p.stdout.startswith(f"runners {version('rocking')}; FMU {fmu_path}: version "), p.stdout


def test_the_parser_loads_nothing_heavy():
    """runners --help builds every command's parser; NumPy, SQLAlchemy, fmpy and Matplotlib load
    only when a command runs (docs/cli.md: start-up time)."""
    code = ("import sys, runners.cli.parser as p; p.build_parser(); "
            "print(sorted(m for m in ('numpy', 'sqlalchemy', 'fmpy', 'matplotlib', 'alembic') if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0 and p.stdout.strip() == "[]", (p.stdout, p.stderr)


def test_every_commands_help_can_be_printed():
    """argparse formats each help text with %: a bare "5 %" in one made runners --help end in a traceback."""
    import argparse

    from runners.cli.parser import build_parser

    def parsers(p: argparse.ArgumentParser):
        yield p
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                for child in action.choices.values():
                    yield from parsers(child)

    for p in parsers(build_parser()):
        assert p.format_help().startswith("usage: "), p.prog


def test_the_parsers_database_help_is_the_databases():
    from db.session import DB_HELP
    from runners.cli.args import DB_HELP as COPY

    assert COPY == DB_HELP


# --- --json: one document on stdout --------------------------------------------------------------

JSON_COMMANDS = [
    ("db", "init"), ("db", "list", "runs"), ("db", "list", "blocks"), ("db", "list", "sweeps"),
    ("db", "show", "run", "latest"), ("records", "list"), ("records", "show", "pulse3"),
    ("map", "1", "--out", "{tmp}/map.png"), ("ida", "latest", "--out", "{tmp}/ida.png"),
    ("rrd", "1", "--out", "{tmp}/r.rrd"), ("rrd", "--sweep", "1", "--out", "{tmp}/s.rrd"),
    ("compare", "1", "1", "--out", "{tmp}/c.png"), ("export-measured", "2", "--out", "{tmp}/e.csv"),
    ("import-measured", str(EX / "measured_peaks_block2.csv")), ("records", "export", "pulse3", "--out", "{tmp}/r.txt"),
    ("records", "import", str(EX / "pulse_3hz.AT2"), "--name", "pulse3"),
    ("calibrate", "1", "--law", "correction", "--no-store", "--accept-poor-fit"),
    ("simulate", str(EX / "free_rocking.toml"), "--no-store"),
]


@pytest.mark.parametrize("args", JSON_COMMANDS, ids=lambda a: " ".join(a[:2]))
def test_json_is_one_document_on_stdout(stocked, fmu_path, tmp_path, args):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    p = cli(stocked, fmu_path, *args, "--json")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)  # the whole of stdout, nothing else
    assert doc, p.stdout


def test_db_show_with_json_is_the_same_document(stocked, fmu_path):
    a = cli(stocked, fmu_path, "db", "show", "run", "1")
    b = cli(stocked, fmu_path, "db", "show", "run", "1", "--json")
    assert a.returncode == b.returncode == 0 and json.loads(a.stdout) == json.loads(b.stdout)


def test_bench_tables_become_json_rows(fmu_path):
    """bench --json: each Markdown table of a real benchmark as columns and numeric rows."""
    from runners.analysis.bench import markdown_sections, run_fmpy_bench

    text = run_fmpy_bench(fmu_path, repeats=1, stop_time=1.0)
    (section,) = markdown_sections(text)
    assert section["title"].startswith("Through fmpy") and section["columns"][0] == "case"
    assert len(section["rows"]) == text.count("\n| ") - 1  # the separator row is not a row
    assert all(isinstance(r[1], float) and isinstance(r[3], int) for r in section["rows"])


# --- --out, and the former spellings -------------------------------------------------------------

def test_simulate_out_writes_the_recording_and_rrd_still_works_with_a_note(stocked, fmu_path, tmp_path):
    new = cli(stocked, fmu_path, "simulate", str(EX / "free_rocking.toml"), "--no-store", "--out", str(tmp_path / "a.rrd"))
    assert new.returncode == 0 and (tmp_path / "a.rrd").stat().st_size > 0 and "note:" not in new.stderr, new.stderr
    old = cli(stocked, fmu_path, "simulate", str(EX / "free_rocking.toml"), "--no-store", "--rrd", str(tmp_path / "b.rrd"))
    assert old.returncode == 0 and (tmp_path / "b.rrd").stat().st_size > 0
    assert "note: --rrd is now --out" in old.stderr.splitlines()
    quiet = cli(stocked, fmu_path, "simulate", str(EX / "free_rocking.toml"), "--no-store", "--rrd",
                str(tmp_path / "c.rrd"), "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr


def test_compare_writes_its_figure_with_out_and_its_recording_with_recording(stocked, fmu_path, tmp_path):
    p = cli(stocked, fmu_path, "compare", "2", "1", "--plot", str(tmp_path / "c.png"), "--rrd", str(tmp_path / "c.rrd"))
    assert p.returncode == 0, p.stderr
    assert {"note: --plot is now --out", "note: --rrd is now --recording"} <= set(p.stderr.splitlines())
    q = cli(stocked, fmu_path, "compare", "2", "1", "--out", str(tmp_path / "d.png"), "--recording",
            str(tmp_path / "d.rrd"), "--json")
    doc = json.loads(q.stdout)
    assert doc["figure"] == str(tmp_path / "d.png") and Path(doc["recording"]).stat().st_size > 0
    assert (tmp_path / "d.png").read_bytes()[:4] == b"\x89PNG" and q.stderr == ""


def test_records_show_out_draws_the_record(stocked, fmu_path, tmp_path):
    p = cli(stocked, fmu_path, "records", "show", "pulse3", "--plot", str(tmp_path / "r.png"))
    assert p.returncode == 0 and "note: --plot is now --out" in p.stderr and (tmp_path / "r.png").is_file()


def test_sweep_points_out_and_the_former_record_record_dir_resume(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    scene = str(EX / "sweep_sine_pulse.toml")
    p = run_cli("sweep", scene, "--grid", "w=1:2:2", "--points", "0", "--out", str(tmp_path / "new"), "-q",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and p.stderr == "" and (tmp_path / "new" / "point-0.rrd").is_file(), p.stderr
    p = run_cli("sweep", scene, "--grid", "w=1:2:2", "--record", "1", "--record-dir", str(tmp_path / "old"),
                "--no-progress", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and (tmp_path / "old" / "point-1.rrd").is_file(), p.stderr
    notes = p.stderr.splitlines()
    for note in ("note: --record is now --points", "note: --record-dir is now --out", "note: --no-progress is now --quiet"):
        assert note in notes, p.stderr
    p = run_cli("sweep", "--resume", "2", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "sweep 2 is already complete: 2/2 points stored" in p.stdout, p.stderr
    assert any(n.startswith("note: --resume is now the positional SWEEP_ID") for n in p.stderr.splitlines())
    p = run_cli("sweep", "latest", "-q", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "sweep 2 is already complete: 2/2 points stored" in p.stdout and p.stderr == "", p.stderr


def test_rrd_points_out_is_a_folder(stocked, fmu_path, tmp_path):
    p = cli(stocked, fmu_path, "rrd", "--sweep", "latest", "--points", "0", "--out", str(tmp_path / "pts"), "--json", "-q")
    assert p.returncode == 0 and p.stderr == "", p.stderr
    (point,) = json.loads(p.stdout)["points"]
    assert point["point"] == 0 and Path(point["recording"]).parent == tmp_path / "pts"
    p = cli(stocked, fmu_path, "rrd", "--sweep", "1", "--points", "0", "--record-dir", str(tmp_path / "old"), "-q")
    assert p.returncode == 0 and (tmp_path / "old" / "point-0.rrd").is_file() and p.stderr == "", p.stderr


def test_bench_chart_is_charts_with_out():
    from runners.cli import output
    from runners.cli.parser import _prepare, build_parser

    args = build_parser().parse_args(["bench", "--chart", "somewhere", "--quick"])
    _prepare(args)
    output.QUIET = False
    assert (args.charts, args.out, args.quick) == (True, "somewhere", True) and args._renamed == [
        "--chart is now --charts --out DIR"]


def test_bench_refuses_out_without_charts(stocked, fmu_path):
    one_line_error(cli(stocked, fmu_path, "bench", "--out", "x"), "--out is the folder of --charts")


@pytest.mark.parametrize("args", [("export", "latest"), ("export", "--sweep", "latest", "--format", "json")])
def test_a_dash_for_an_output_file_is_refused_not_written_as_a_file_named_dash(stocked, fmu_path, tmp_path, monkeypatch,
                                                                                args):
    """'--out -' is no standard output here (an export writes files, a run's two): one line, and no file named '-'."""
    monkeypatch.chdir(tmp_path)
    p = cli(stocked, fmu_path, *args, "--out", "-")
    one_line_error(p, "'-'", "standard output")
    assert not (tmp_path / "-").exists()


# --- ids -------------------------------------------------------------------------------------------

def test_latest_names_the_newest_run_and_sweep(stocked, fmu_path, tmp_path):
    runs = json.loads(cli(stocked, fmu_path, "db", "list", "runs", "--json", "--single").stdout)["runs"]
    shown = json.loads(cli(stocked, fmu_path, "db", "show", "run", "latest").stdout)
    assert shown["id"] >= runs[0]["id"]
    sweeps = json.loads(cli(stocked, fmu_path, "db", "list", "sweeps", "--json").stdout)["sweeps"]
    p = cli(stocked, fmu_path, "rrd", "--sweep", "latest", "--out", str(tmp_path / "s.rrd"), "--json")
    assert json.loads(p.stdout)["sweep"] == sweeps[0]["id"] == 2


@pytest.mark.parametrize("args, words", [
    (("map", "abc"), ["'abc' is not an id"]), (("rrd", "999"), ["no run 999"]),
    (("rrd", "--sweep", "77"), ["no sweep 77"]), (("sweep", "77"), ["no sweep 77"]),
    (("db", "show", "sweep", "x1"), ["ids are integers"]), (("db", "list", "runs", "--sweep", "9"), ["no sweep 9"]),
    (("db", "list", "runs", "--sweep", "1", "--single"), ["not both"]), (("compare", "1", "55"), ["no measurement 55"]),
    (("db", "list", "blocks", "--single"), ["filter runs"]), (("fragility", "-3"), []),
])
def test_a_bad_id_is_a_one_line_error(stocked, fmu_path, args, words):
    one_line_error(cli(stocked, fmu_path, *args), *words)


def test_latest_in_an_empty_database_is_a_one_line_error(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'e.db'}"
    assert run_cli("db", "init", db=db, fmu_path=fmu_path).returncode == 0
    one_line_error(run_cli("rrd", "latest", db=db, fmu_path=fmu_path), "no run in the database")
    one_line_error(run_cli("map", "latest", db=db, fmu_path=fmu_path), "no sweep in the database")


# --- db list runs -------------------------------------------------------------------------------

def test_db_list_runs_has_a_header_names_and_each_sweep_as_one_line(stocked, fmu_path):
    p = cli(stocked, fmu_path, "db", "list", "runs")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].startswith("runs: 10 in ") and "(3 single, 7 sweep points)" in lines[0]
    assert lines[1].split()[:3] == ["id", "created", "(UTC)"] and "scene" in lines[1]
    body = lines[2:]
    assert len(body) == 5  # three single runs, two sweeps
    assert "harmonic table" in body[1] and "sweep 1: 4 points of one-sine pulse" in body[2]
    assert "sweep 2: 3 points" in body[0] and "free rocking" in body[3] and "free rocking" in body[4]


def test_db_list_runs_filters(stocked, fmu_path):
    single = cli(stocked, fmu_path, "db", "list", "runs", "--single").stdout.splitlines()
    assert len(single) == 2 + 3 and not any("sweep" in x for x in single[2:])
    points = cli(stocked, fmu_path, "db", "list", "runs", "--sweep", "1", "--limit", "3").stdout.splitlines()
    assert "points of sweep 1" in points[0] and len(points) == 2 + 3 + 1
    assert points[-1] == "... 1 more points of sweep 1: --limit 4 shows them all"
    assert [re.search(r"\s1, (\d)\s", x).group(1) for x in points[2:5]] == ["3", "2", "1"]
    doc = json.loads(cli(stocked, fmu_path, "db", "list", "runs", "--sweep", "1", "--json").stdout)
    assert [r["grid_index"] for r in doc["runs"]] == [3, 2, 1, 0] and doc["more"] == 0
    assert all(r["scene"].startswith("one-sine pulse") for r in doc["runs"])
    doc = json.loads(cli(stocked, fmu_path, "db", "list", "runs", "--limit", "1", "--json").stdout)
    assert (doc["shown"], doc["more"], doc["sweeps"][0]["sweep"], doc["runs"]) == (1, 4, 2, [])


# --- --quiet and progress -------------------------------------------------------------------------

def _on_a_terminal(args, db, fmu_path) -> tuple[int, str]:
    """Run the command line with its stderr on a pseudo-terminal, as in a shell: (exit status, stderr)."""
    import os

    import fcntl
    import struct
    import termios

    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))  # tqdm draws nothing 0 columns wide
    p = subprocess.run([sys.executable, "-m", "runners.cli", *args, "--db", db], stdout=subprocess.PIPE, stderr=slave,
                       cwd=ROOT, env={**os.environ, "ROCKING_FMU": str(fmu_path)}, timeout=PATIENCE)
    os.close(slave)
    chunks = []
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # EIO: the terminal's other end is closed and everything was read
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    return p.returncode, b"".join(chunks).decode("utf-8", "replace")


def test_progress_on_a_terminal_and_quiet_anywhere_silences_it(stocked, fmu_path, tmp_path):
    db = stocked[0]
    code, err = _on_a_terminal(["rrd", "--sweep", "1", "--points", "2", "--out", str(tmp_path)], db, fmu_path)
    assert code == 0 and "recording sweep 1" in err and "1/1" in err, err
    for args in (["-q", "rrd", "--sweep", "1", "--points", "2", "--out", str(tmp_path)],
                 ["rrd", "--sweep", "1", "--points", "2", "--out", str(tmp_path), "--quiet"]):
        code, err = _on_a_terminal(args, db, fmu_path)
        assert code == 0 and err == "", err


def test_no_progress_bar_in_a_log_so_that_a_failure_is_one_line(stocked, fmu_path):
    """stderr not a terminal (a log, a pipe): no bar, and a failed calibration is its one error line."""
    p = cli(stocked, fmu_path, "calibrate", "1", "--law", "modified", "--no-store")
    assert p.returncode == 0 or (p.stderr.count("\n") == 1 and p.stderr.startswith("error: ")), p.stderr
    assert "simulation" not in p.stderr.split("error:")[0], p.stderr


def test_read_only_commands_do_not_create_a_mistyped_database_and_export_latest_skips_sweep_points(
        tmp_path, fmu_path):
    missing = tmp_path / "typo.db"
    for args in (["map", "latest"], ["fragility", "latest"], ["records", "export", "x", "--out", "x.csv"],
                 ["export", "latest"]):
        p = run_cli(*args, db=f"sqlite:///{missing}", fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.startswith("error: cannot open the database"), (args, p.stderr)
        assert not missing.exists(), args
    db = f"sqlite:///{tmp_path / 'r.db'}"
    assert run_cli("simulate", "examples/free_rocking.toml", "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    assert run_cli("sweep", "examples/sweep_sine_pulse.toml", "--grid", "w=1:2:2", "--quiet",
                   db=db, fmu_path=fmu_path).returncode == 0
    p = run_cli("export", "latest", "--json", "--out", str(tmp_path / "x.csv"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["rows"] > 100  # run 1's series, not a sweep point's outcome
