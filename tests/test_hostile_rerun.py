"""Issue 25's hostile cases re-run with their neighbours: each bad input of the Python API is a
runners.RockingError with a one-line message and stores nothing, numpy's bools are flags, and
runners db import-unsaved refuses what is not a kept-run file (a FIFO that never ends, samples
that are not numbers) before storing it."""

from __future__ import annotations

import base64
import json
import os
import sqlite3
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

import runners
from runners.errors import ArgumentError, RockingError

from conftest import PATIENCE

ROOT = Path(__file__).resolve().parents[1]
SINE = ROOT / "examples" / "sine_pulse.toml"
AT2 = ROOT / "examples" / "pulse_3hz.AT2"
RUNNERS = Path(sys.executable).with_name("runners")


def _rows(path: Path) -> dict[str, int]:
    """Rows of each table of an SQLite file ({} when it does not exist)."""
    if not path.exists():
        return {}
    with sqlite3.connect(path) as con:
        tables = [r[0] for r in con.execute("select name from sqlite_master where type = 'table'")]
        return {t: con.execute(f'select count(*) from "{t}"').fetchone()[0] for t in tables}


def _binary_record(tmp_path: Path) -> Path:
    path = tmp_path / "noise.AT2"
    path.write_bytes(bytes(range(256)) * 8)
    return path


# (what, the call); f: the FMU, db: the database URL, tmp: a scratch folder. Each is a value the
# layers below the API refuse (they raise plain ValueError or OSError): the API says so as its own.
REFUSED = [
    ("record file missing", lambda f, db, tmp: runners.simulate(SINE, fmu=f, db=db, record=str(tmp / "nope.AT2"))),
    ("pga without a record", lambda f, db, tmp: runners.simulate(SINE, fmu=f, db=db, pga=0.3)),
    ("scale and pga", lambda f, db, tmp: runners.simulate(SINE, fmu=f, db=db, record=AT2, pga=0.3, scale=2.0)),
    ("friction axis", lambda f, db, tmp: runners.sweep(SINE, {"contact.muGround": (0.3, 0.9, 3)}, fmu=f, db=db)),
    ("unknown axis", lambda f, db, tmp: runners.sweep(SINE, {"nope": (1, 5, 2)}, fmu=f, db=db)),
    ("grid too large", lambda f, db, tmp: runners.sweep(SINE, {"w": (1, 5, 10**9)}, fmu=f, db=db)),
    ("points outside", lambda f, db, tmp: runners.sweep(SINE, {"w": (1, 5, 2)}, fmu=f, db=db, record="7")),
    ("unknown im", lambda f, db, tmp: runners.sweep(SINE, records=str(AT2.parent), im="pgd=0.1:0.3:2", fmu=f, db=db)),
    ("import missing file", lambda f, db, tmp: runners.import_records(tmp / "nope.AT2", db=db)),
    ("import binary file", lambda f, db, tmp: runners.import_records(_binary_record(tmp), db=db)),
    ("simulate binary file", lambda f, db, tmp: runners.simulate(SINE, fmu=f, db=db, record=_binary_record(tmp))),
]


@pytest.mark.parametrize("what, call", REFUSED, ids=[w for w, _ in REFUSED])
def test_a_value_the_layers_below_refuse_is_a_rocking_error(tmp_path, fmu_path, what, call):
    path = tmp_path / "hostile.db"
    runners.simulate(SINE, fmu=fmu_path, db=f"sqlite:///{path}", stop_time=0.1, store=True)  # a database with a run in it
    before = _rows(path)
    with pytest.raises(RockingError) as err:
        call(fmu_path, f"sqlite:///{path}", tmp_path)
    message = str(err.value)
    assert message and "\n" not in message and len(message) < 400
    assert _rows(path) == before


def test_numpy_bools_are_flags(tmp_path, fmu_path):
    run = runners.simulate(SINE, fmu=fmu_path, stop_time=0.5, store=np.bool_(False))
    assert run.run_id is None
    db = f"sqlite:///{tmp_path / 'flags.db'}"
    sw = runners.sweep(SINE, {"w": (1, 5, 2)}, fmu=fmu_path, db=db, workers=1, progress=np.False_)
    assert sw.stats["stored"] == 2


@pytest.mark.parametrize("ds", [None, 5, {"overturn": 1}])
def test_fragilities_of_what_is_not_a_list_of_states_is_an_argument_error(tmp_path, fmu_path, ds):
    sw = runners.sweep(SINE, {"w": (1, 5, 2)}, fmu=fmu_path, db=f"sqlite:///{tmp_path / 'f.db'}", workers=1)
    with pytest.raises(ArgumentError, match="ds="):
        sw.fragilities("pga", ds)


def _cli(*args: str, cwd: Path, db: Path, fmu_path: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "ROCKING_FMU": str(fmu_path)}
    return subprocess.run([str(RUNNERS), *args, "--db", str(db)], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=PATIENCE)


def _kept_run(tmp_path: Path, fmu_path: Path) -> Path:
    """A real kept-run file: a run whose database refused it (a trigger aborts every insert)."""
    refusing = tmp_path / "refusing.db"
    runners.simulate(SINE, fmu=fmu_path, db=f"sqlite:///{refusing}", stop_time=0.1, store=True)
    with sqlite3.connect(refusing) as con:
        con.execute("create trigger refuse before insert on runs begin select raise(abort, 'refused'); end")
    p = _cli("simulate", str(SINE), "--stop-time", "0.5", cwd=tmp_path, db=refusing, fmu_path=fmu_path)
    assert p.returncode == 2 and "import-unsaved" in p.stderr
    (kept,) = tmp_path.glob("rocking-unsaved-*.json")
    return kept


def test_import_unsaved_refuses_samples_that_are_not_numbers(tmp_path, fmu_path):
    kept = _kept_run(tmp_path, fmu_path)
    data = json.loads(kept.read_text())
    series = data["series"]
    samples = np.frombuffer(zlib.decompress(base64.b64decode(series["data"])), "<f8").copy()
    samples[-1] = np.nan  # the last sample of the last column
    series["data"] = base64.b64encode(zlib.compress(samples.tobytes())).decode()
    kept.write_text(json.dumps(data))
    db = tmp_path / "target.db"
    runners.simulate(SINE, fmu=fmu_path, db=f"sqlite:///{db}", stop_time=0.1, store=True)
    before = _rows(db)
    p = _cli("db", "import-unsaved", str(kept), cwd=tmp_path, db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
    assert "not a finite number" in p.stderr
    assert _rows(db) == before


def test_import_unsaved_refuses_what_is_not_a_regular_file(tmp_path, fmu_path):
    fifo = tmp_path / "kept.json"
    os.mkfifo(fifo)  # opening it for reading would wait for a writer that never comes
    db = tmp_path / "target.db"
    runners.simulate(SINE, fmu=fmu_path, db=f"sqlite:///{db}", stop_time=0.1, store=True)
    before = _rows(db)
    p = _cli("db", "import-unsaved", str(fifo), cwd=tmp_path, db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "not a file" in p.stderr
    assert _rows(db) == before


def _cached_file(cache: Path) -> Path:
    (path,) = (cache / "records").glob("*.txt")
    return path


def test_a_link_in_the_record_cache_is_replaced_never_its_target(tmp_path, fmu_path, monkeypatch):
    monkeypatch.setenv("ROCKING_CACHE", str(tmp_path / "cache"))
    first = runners.simulate(SINE, fmu=fmu_path, record=AT2, stop_time=0.5)
    cached = _cached_file(tmp_path / "cache")
    victim = tmp_path / "precious.txt"  # as /etc/passwd once was, run as root: written over
    victim.write_text("precious\n")
    cached.unlink()
    cached.symlink_to(victim)
    again = runners.simulate(SINE, fmu=fmu_path, record=AT2, stop_time=0.5)
    assert victim.read_text() == "precious\n"
    assert not cached.is_symlink() and cached.is_file()
    assert again.summary["impacts"] == first.summary["impacts"]
    assert again.series["block1.theta"].equals(first.series["block1.theta"])


def test_a_folder_in_the_place_of_a_record_cache_file_is_one_line_naming_it(tmp_path, fmu_path, monkeypatch):
    monkeypatch.setenv("ROCKING_CACHE", str(tmp_path / "cache"))
    runners.simulate(SINE, fmu=fmu_path, record=AT2, stop_time=0.5)
    cached = _cached_file(tmp_path / "cache")
    cached.unlink()
    cached.mkdir()
    with pytest.raises(RockingError) as err:
        runners.simulate(SINE, fmu=fmu_path, record=AT2, stop_time=0.5)
    message = str(err.value)
    assert "\n" not in message and str(cached) in message and "folder" in message
    assert not any(p.name.startswith(".") for p in cached.parent.iterdir())  # no temporary file left


@pytest.mark.parametrize("scheduler", ["udp://127.0.0.1:5", "http://127.0.0.1:8786"])
def test_a_scheduler_address_of_an_unknown_scheme_is_refused_before_the_sweep_exists(tmp_path, fmu_path, scheduler):
    path = tmp_path / "dask.db"
    runners.simulate(SINE, fmu=fmu_path, db=f"sqlite:///{path}", stop_time=0.1, store=True)
    before = _rows(path)
    with pytest.raises(ArgumentError, match="scheduler") as err:
        runners.sweep(SINE, {"w": (1, 5, 2)}, fmu=fmu_path, db=f"sqlite:///{path}", executor="dask", scheduler=scheduler)
    assert "\n" not in str(err.value)
    assert _rows(path) == before  # no sweep 'failed' for a mistyped address


@pytest.mark.parametrize("args", [
    ("sweep", str(SINE), "--records", "{folder}", "--records", "{folder}/..", "--im", "pga=0.1:0.3:2"),
    ("simulate", str(SINE), "--record", str(AT2), "--record", "{folder}/pulse.AT2", "--no-store"),
    ("simulate", str(SINE), "--record", str(AT2), "--pga", "0.3", "--pga", "0.5", "--no-store"),
    ("simulate", str(SINE), "--record", str(AT2), "--scale", "1", "--scale", "2", "--no-store"),
], ids=["records", "record", "pga", "scale"])
def test_a_record_option_given_twice_is_refused_not_the_first_dropped(tmp_path, fmu_path, args):
    from conftest import run_cli

    folder = tmp_path / "records"
    folder.mkdir()
    (folder / "pulse.AT2").write_bytes(AT2.read_bytes())
    path = tmp_path / "twice.db"
    p = run_cli(*[a.format(folder=folder) for a in args], db=f"sqlite:///{path}", fmu_path=fmu_path)
    assert p.returncode == 2 and "given twice" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert _rows(path).get("sweeps", 0) == 0


def test_a_pulse_that_starts_after_the_run_ends_is_said_so_not_below_the_threshold(tmp_path, fmu_path):
    from conftest import run_cli

    text = SINE.read_text().replace("cycles = 1", "cycles = 1\nstart_time = 1e300")
    scene = tmp_path / "late.toml"
    scene.write_text(text)
    p = run_cli("simulate", str(scene), "--no-store", db=f"sqlite:///{tmp_path / 'late.db'}", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    (outcome,) = [line for line in p.stdout.splitlines() if line.startswith("outcome")]
    assert "starts at t = 1e+300 s, after the run ended at t = 5 s" in outcome
    assert "uplift threshold" not in outcome
    run = runners.simulate(scene, fmu=fmu_path)
    assert run.summary["excitation_start_s"] == 1e300 and not run.summary["overturned"]


@pytest.mark.parametrize("name", ['"a\\nb"', '"a\\u0000b"', '"a\\u001b[31mb"', '"tab\\there"'])
def test_a_scene_name_with_a_control_character_is_refused(tmp_path, fmu_path, name):
    scene = tmp_path / "named.toml"
    scene.write_text(SINE.read_text().replace('name = "sine pulse, h/b = 3"', f"name = {name}"))
    path = tmp_path / "names.db"
    with pytest.raises(runners.SceneError, match="one line of printable characters") as err:
        runners.simulate(scene, fmu=fmu_path, store=True, db=f"sqlite:///{path}")
    assert "\n" not in str(err.value)
    assert _rows(path).get("runs", 0) == 0


def test_a_select_value_that_is_not_an_axis_value_is_shown_with_all_its_digits(tmp_path, fmu_path):
    folder = tmp_path / "records"
    folder.mkdir()
    (folder / "pulse.AT2").write_bytes(AT2.read_bytes())
    sw = runners.sweep(SINE, {"block1.halfWidth": (0.08, 0.12, 2)}, records=str(folder), im="pga=0.2:0.6:2",
                       fmu=fmu_path, db=f"sqlite:///{tmp_path / 'select.db'}", workers=1)
    assert len(sw.outcomes("pga", select={"block1.halfWidth": np.float64(0.08)}).x) == 2
    with pytest.raises(RockingError) as err:  # np.float32(0.08) is 0.07999999821186066, not the axis' 0.08
        sw.outcomes("pga", select={"block1.halfWidth": np.float32(0.08)})
    assert "select block1.halfWidth=0.0799999982" in str(err.value) and "at 0.08, 0.12 only" in str(err.value)


@pytest.mark.parametrize("first", ["root:x:0:0:root:/root:/bin/bash", "secret-token 12", "Name:\tpython"])
def test_a_file_that_is_not_a_record_is_not_quoted(tmp_path, fmu_path, first):
    from conftest import run_cli

    path = tmp_path / "not_a_record.txt"  # as /etc/passwd or /etc/shadow given as a record
    path.write_text(first + "\nmore: text\n")
    for args in (("records", "import", str(path)), ("simulate", str(SINE), "--record", str(path), "--no-store")):
        p = run_cli(*args, db=f"sqlite:///{tmp_path / 'q.db'}", fmu_path=fmu_path)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "not a record file" in p.stderr
        assert first.split()[0][:5] not in p.stderr.replace(str(path), "")


@pytest.mark.parametrize("command", ["records import", "import-measured"])
def test_a_csv_that_is_not_a_measurement_is_not_quoted(tmp_path, fmu_path, command):
    from conftest import run_cli

    path = tmp_path / "copy.csv"  # a copy of /etc/shadow named .csv
    path.write_text("# units: time=s, acceleration=m/s2\n# sign: +x\n# kind: ground-acceleration\n"
                    "root:*:20228:0:99999:7:::\ndaemon:*:20228:0:99999:7:::\n")
    p = run_cli(*command.split(), str(path), db=f"sqlite:///{tmp_path / 'q.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "the first column must be 'time'" in p.stderr and "root" not in p.stderr.replace(str(path), "")


def test_a_scene_that_is_a_fifo_is_refused_not_waited_for(tmp_path, fmu_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)  # reading it would wait for a writer that never comes
    p = _cli("simulate", str(fifo), "--no-store", cwd=tmp_path, db=tmp_path / "f.db", fmu_path=fmu_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "not a regular file" in p.stderr
    with pytest.raises(runners.SceneError, match="not a regular file"):
        runners.as_scene(fifo)
