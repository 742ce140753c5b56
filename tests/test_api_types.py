"""The Python API's argument types: numpy scalars are numbers wherever a number is taken (run and
sweep ids, grids, dict scenes, FMU parameters, times), and an argument of the wrong type raises
runners.ArgumentError with a one-line message naming it, before anything is stored."""

from __future__ import annotations

import sqlite3
import tomllib
from pathlib import Path

import numpy as np
import pytest

import runners
from runners.errors import ArgumentError, RockingError

ROOT = Path(__file__).resolve().parents[1]
SINE = ROOT / "examples" / "sine_pulse.toml"
SWEEP = ROOT / "examples" / "sweep_sine_pulse.toml"
AT2 = ROOT / "examples" / "pulse_3hz.AT2"


def _db(tmp_path: Path) -> str:
    return f"sqlite:///{tmp_path / 'types.db'}"


def _sweeps_stored(tmp_path: Path) -> int:
    """Sweep rows in the test's database file (0 when the file was never created)."""
    path = tmp_path / "types.db"
    if not path.exists():
        return 0
    with sqlite3.connect(path) as con:
        tables = {r[0] for r in con.execute("select name from sqlite_master where type = 'table'")}
        return con.execute("select count(*) from sweeps").fetchone()[0] if "sweeps" in tables else 0


# (the argument the message must name, the call); f: the FMU, f3: the FMI 3.0 FMU, db: a database URL
WRONG = [
    ("accuracy", lambda f, f3, db: runners.simulate(SINE, fmu=f, method="auto", accuracy=None)),
    ("pga", lambda f, f3, db: runners.simulate(SINE, fmu=f, record=AT2, pga="0.3")),
    ("workers", lambda f, f3, db: runners.sweep(SWEEP, ["w=1:2:2"], fmu=f, db=db, workers="2")),
    ("workers", lambda f, f3, db: runners.sweep(SWEEP, ["w=1:2:2"], fmu=f, db=db, workers=1.5)),
    ("records", lambda f, f3, db: runners.sweep(SINE, fmu=f, db=db, records=[{"name": "a"}], im="pga=0.1:0.2:2")),
    ("db", lambda f, f3, db: runners.simulate(SINE, fmu=f, store=True, db=5)),
    ("url", lambda f, f3, db: runners.open_db(5)),
    ("grid", lambda f, f3, db: runners.sweep(SWEEP, [("w", 1, 2, 2)], fmu=f, db=db)),
    ("grid axis w: count", lambda f, f3, db: runners.sweep(SWEEP, {"w": (1, 2, 2.5)}, fmu=f, db=db)),
    ("im", lambda f, f3, db: runners.sweep(SINE, fmu=f, db=db, records="pulse", im=("pga", 0.1, 0.2, 2))),
    ("fmu", lambda f, f3, db: runners.simulate(SINE, fmu=f3, stop_time=0.1)),
    ("fmu", lambda f, f3, db: runners.sweep(SWEEP, ["w=1:2:2"], fmu=f3, db=db)),
    ("resume", lambda f, f3, db: runners.sweep(resume="1", fmu=f, db=db)),
    ("run_id", lambda f, f3, db: runners.open_db(db).run("1")),
    ("stop_time", lambda f, f3, db: runners.simulate(SINE, fmu=f, stop_time=True)),
    ("outputs", lambda f, f3, db: runners.simulate(SINE, fmu=f, outputs="block1.theta")),
    ("store", lambda f, f3, db: runners.simulate(SINE, fmu=f, store="no")),
    ("parameters", lambda f, f3, db: runners.simulate(SINE, [("block1.halfWidth", 0.1)], fmu=f)),
    ("method", lambda f, f3, db: runners.simulate(SINE, fmu=f, method=None)),
    ("measure", lambda f, f3, db: runners.open_db(db).sweep(1).outcomes(5)),
    ("source", lambda f, f3, db: runners.import_records(5, db=db)),
    ("limit", lambda f, f3, db: runners.open_db(db).runs(limit="5")),
]


@pytest.mark.parametrize("name, call", WRONG, ids=[f"{i}-{n}" for i, (n, _) in enumerate(WRONG)])
def test_a_wrong_type_argument_is_an_argument_error_that_names_it(tmp_path, fmu_path, fmu3_path, name, call):
    db = _db(tmp_path)
    if name in ("run_id", "measure", "limit"):  # a database holding sweep 1 (and its points, runs 1 and 2)
        runners.sweep(SWEEP, ["w=1:2:2"], stop_time=0.2, fmu=fmu_path, db=db)
    before = _sweeps_stored(tmp_path)
    with pytest.raises(ArgumentError) as err:
        call(fmu_path, fmu3_path, db)
    message = str(err.value)
    assert isinstance(err.value, RockingError) and "\n" not in message and len(message) < 300
    assert message.startswith(name) or f" {name} " in message, message
    assert _sweeps_stored(tmp_path) == before  # refused before anything is stored


def test_numpy_ids_find_the_stored_run_and_sweep(tmp_path, fmu_path):
    db = _db(tmp_path)
    run = runners.simulate(SINE, fmu=fmu_path, stop_time=0.5, store=True, db=db)
    sw = runners.sweep(SWEEP, ["w=1:2:2"], stop_time=0.2, fmu=fmu_path, db=db)
    stored = runners.open_db(db)
    by_numpy = stored.run(np.int64(run.run_id))
    assert by_numpy.run_id == run.run_id and type(by_numpy.run_id) is int
    assert by_numpy.series.equals(stored.run(run.run_id).series)
    assert stored.sweep(np.int32(sw.sweep_id)).stats == stored.sweep(sw.sweep_id).stats
    assert len(stored.runs(sweep=np.int64(sw.sweep_id), limit=np.int64(5))) == 2
    again = runners.sweep(resume=np.int64(sw.sweep_id), fmu=fmu_path, db=db)  # complete: nothing to run
    assert again.sweep_id == sw.sweep_id and again.stats["ran"] == 0 and again.stats["stored"] == 2


def test_numpy_numbers_in_a_grid_give_the_grid_of_python_numbers(tmp_path, fmu_path):
    db = _db(tmp_path)
    plain = runners.sweep(SWEEP, {"w": (1.5, 4.0, 3), "a": (2.0, 6.0, 2)}, stop_time=1.0, fmu=fmu_path, db=db)
    numpy = runners.sweep(SWEEP, {"w": (np.float64(1.5), np.float32(4.0), np.int64(3)),
                                  "a": (np.int32(2), np.float16(6.0), np.uint8(2))}, stop_time=np.float32(1.0),
                          fmu=fmu_path, db=db)
    a, b = plain.to_pandas(), numpy.to_pandas()
    a, b = (x.drop(columns=["run_id"], errors="ignore") for x in (a, b))
    assert len(a) == 6 and a.equals(b)


def test_numpy_numbers_in_a_dict_scene_parameters_and_times_run_as_python_numbers(fmu_path):
    data = tomllib.loads(SINE.read_text())
    as_numpy = {**data, "block": {k: np.float64(v) if isinstance(v, float) else v for k, v in data["block"].items()},
                "excitation": {**data["excitation"], "cycles": np.int64(data["excitation"].get("cycles", 1))}}
    plain = runners.simulate(data, {"block1.halfWidth": 0.11, "restitution.law": 1}, fmu=fmu_path, stop_time=1.0,
                             step=0.01)
    numpy = runners.simulate(as_numpy, {"block1.halfWidth": np.float64(0.11), "restitution.law": np.int64(1)},
                             fmu=fmu_path, stop_time=np.float32(1.0), step=np.float64(0.01))
    assert numpy.series.equals(plain.series) and numpy.summary["impacts"] == plain.summary["impacts"]
    assert type(numpy.parameters["block1.halfWidth"]) is float and type(numpy.parameters["restitution.law"]) is int


def test_a_list_of_record_names_is_the_comma_separated_records(tmp_path, fmu_path):
    db = _db(tmp_path)
    runners.import_records(AT2, db=db, name="pulse")
    listed = runners.sweep(SINE, records=["pulse"], im="pga=0.1:0.3:2", stop_time=1.0, fmu=fmu_path, db=db)
    text = runners.sweep(SINE, records="pulse", im="pga=0.1:0.3:2", stop_time=1.0, fmu=fmu_path, db=db)
    cols = ["record", "level", "peak1_over_alpha", "overturned"]
    assert listed.to_pandas()[cols].equals(text.to_pandas()[cols])


@pytest.mark.parametrize("name", [{"a": 1}, 5, ""])
def test_a_scene_name_is_a_text(name):
    data = {**tomllib.loads(SINE.read_text()), "name": name}
    with pytest.raises(runners.SceneError, match="name must be a text"):
        runners.as_scene(data)
