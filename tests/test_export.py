"""runners export and the DataFrames behind it: a real FMU run and a real 20-point sweep stored
in a real SQLite file, exported to CSV, Parquet and JSON and read back with pandas (bit for
bit), the stored tables and the Database object on the same file, and the refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sqlalchemy import select

from conftest import run_cli
from db.schema import Run, RunSummary
from db.session import open_database
from db.store import load_run_series
from runners.engine.database import Database, open_db
from runners.engine.tables import OUTCOMES, events_frame, run_frames, stored_table, sweep_frame

ROOT = Path(__file__).resolve().parent.parent
W = np.linspace(1, 12, 5)  # the sweep's axes: --grid w=1:12:5 --grid a=1.01:8:4
A = np.linspace(1.01, 8, 4)


@pytest.fixture(scope="module")
def stored(tmp_path_factory, fmu_path) -> dict:
    """A database with one simulated run (examples/sine_pulse.toml) and one 20-point sweep."""
    folder = tmp_path_factory.mktemp("export")
    url = f"sqlite:///{folder / 'results.db'}"
    p = run_cli("simulate", str(ROOT / "examples" / "sine_pulse.toml"), "--json", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    run_id = json.loads(p.stdout)["run_id"]
    p = run_cli("sweep", str(ROOT / "examples" / "sweep_sine_pulse.toml"), "--grid", "w=1:12:5", "--grid",
                "a=1.01:8:4", "--no-progress", "--workers", "2", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    sweep_id = int(p.stdout.split()[1].rstrip(":"))
    return {"url": url, "run": run_id, "sweep": sweep_id, "factory": open_database(url, write=False)}


def _export(stored: dict, fmu_path, *args: str):
    return run_cli("export", *args, "--quiet", db=stored["url"], fmu_path=fmu_path)


def _bits(a) -> np.ndarray:
    """float64 values as their bit patterns: equal only if bit for bit equal (NaN, -0.0 too)."""
    return np.ascontiguousarray(np.asarray(a, dtype="float64")).view("<i8")


def _stored_run(stored: dict):
    with stored["factory"]() as session:
        _, t, cols, events = load_run_series(session, stored["run"])
    return t, cols, events


def test_run_to_csv_and_parquet_reads_back_bit_for_bit(stored, fmu_path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    t, cols, events = _stored_run(stored)
    assert len(t) > 1000 and len(events) > 10  # a real run: thousands of samples, impacts and peaks
    Path(f"run-{stored['run']}.csv").write_text("an older file, replaced whole\n")
    p = _export(stored, fmu_path, str(stored["run"]), "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["files"] == [f"run-{stored['run']}.csv", f"run-{stored['run']}-events.csv"]
    assert out["rows"] == len(t) and out["events"] == len(events)
    p = _export(stored, fmu_path, str(stored["run"]), "--format", "parquet", "--out", "pq/series.parquet")
    assert p.returncode == 0, p.stderr
    assert sorted(x.name for x in (tmp_path / "pq").iterdir()) == ["series-events.parquet", "series.parquet"]

    csv = pd.read_csv(f"run-{stored['run']}.csv")
    parquet = pd.read_parquet("pq/series.parquet")
    assert list(csv.columns) == ["time", *cols]
    assert parquet.index.name == "time" and list(parquet.columns) == list(cols)
    assert np.array_equal(_bits(csv["time"]), _bits(t)) and np.array_equal(_bits(parquet.index), _bits(t))
    for name, values in cols.items():
        assert np.array_equal(_bits(parquet[name]), _bits(values)), name
        assert np.array_equal(csv[name].to_numpy(dtype="float64"), values), name  # exact (-0.0 reads as 0)

    expected = events_frame(events)
    assert list(expected.columns[:2]) == ["time", "kind"] and len(expected) == len(events)
    pd.testing.assert_frame_equal(pd.read_parquet("pq/series-events.parquet"), expected, check_exact=True)
    ev = pd.read_csv(f"run-{stored['run']}-events.csv")
    assert list(ev.columns) == list(expected.columns)
    assert ev["kind"].tolist() == [e["kind"] for e in events]
    assert np.array_equal(_bits(ev["time"]), _bits([e["t"] for e in events]))
    for name in expected.columns[2:]:
        if expected[name].dtype == "float64":
            assert np.array_equal(_bits(ev[name].to_numpy(dtype="float64")), _bits(expected[name])), name

    import pyarrow.parquet as pq

    meta = json.loads(pq.read_schema("pq/series.parquet").metadata[b"rocking"])
    assert meta["run"] == stored["run"] and meta["units"]["block1.theta"] == "rad"
    assert meta["units"]["time"] == "s" and meta["units"]["block1.omega"] == "rad/s"


def test_run_to_json_reads_back_equal(stored, fmu_path, tmp_path):
    t, cols, events = _stored_run(stored)
    path = tmp_path / "run.json"
    p = _export(stored, fmu_path, str(stored["run"]), "--out", str(path))
    assert p.returncode == 0, p.stderr
    doc = json.loads(path.read_text())
    assert doc["run"] == stored["run"] and doc["scene"] == "sine pulse, h/b = 3"
    assert doc["summary"]["model"] == "one block" and doc["summary"]["impacts"] > 0
    assert doc["parameters"]["block1.halfWidth"] == 0.1 and doc["parameters"]["block1.halfHeight"] == 0.3
    assert doc["units"]["ground.ahTotal"] == "m/s2"
    assert list(doc["series"]) == ["time", *cols]
    assert np.array_equal(_bits(doc["series"]["time"]), _bits(t))
    for name, values in cols.items():
        assert np.array_equal(_bits(doc["series"][name]), _bits(values)), name
    assert doc["events"] == [{"time": e["t"], "kind": e["kind"], **e["values"], **e["labels"]} for e in events]
    frame = pd.DataFrame(doc["series"]).set_index("time")  # as docs/export.md reads it
    pd.testing.assert_frame_equal(frame, run_frames(stored["factory"], stored["run"])[0], check_exact=True)


def test_sweep_export_has_one_row_per_grid_point(stored, fmu_path, tmp_path):
    sid = stored["sweep"]
    files = {fmt: tmp_path / f"points.{fmt}" for fmt in ("csv", "parquet", "json")}
    for fmt, path in files.items():
        p = _export(stored, fmu_path, "--sweep", str(sid), "--out", str(path), "--json")
        assert p.returncode == 0, p.stderr
        assert json.loads(p.stdout) == {"files": [str(path)], "rows": 20, "pending": 0}
    frame = sweep_frame(stored["factory"], sid)
    csv, parquet = pd.read_csv(files["csv"]), pd.read_parquet(files["parquet"])
    doc = json.loads(files["json"].read_text())
    js = pd.DataFrame(doc["points"])
    assert doc["sweep"]["total"] == 20 and doc["units"]["overturn_time"] == "s"
    for got in (frame, csv, parquet, js):
        assert len(got) == 20 and got["grid_index"].tolist() == list(range(20))
        assert np.array_equal(_bits(got["w"]), _bits(np.repeat(W, 4)))  # the last axis runs fastest
        assert np.array_equal(_bits(got["a"]), _bits(np.tile(A, 5)))
        assert set(got["status"]) == {"ok"}
    pd.testing.assert_frame_equal(parquet, frame, check_exact=True)
    with stored["factory"]() as session:  # the outcomes are the stored ones, point by point
        rows = session.execute(select(Run.grid_index, Run.id, *[getattr(RunSummary, k) for k in OUTCOMES])
                               .join(RunSummary, RunSummary.run_id == Run.id).where(Run.sweep_id == sid)
                               .order_by(Run.grid_index)).all()
    assert csv["run_id"].tolist() == [r.id for r in rows]
    for got in (csv, js):
        assert got["overturned"].tolist() == [bool(r.overturned) for r in rows]
        assert got["impacts"].tolist() == [r.impacts for r in rows]
        assert got["assumptions_held"].tolist() == [bool(r.assumptions_held) for r in rows]
        for name in ("peak1_over_alpha", "overturn_time", "rest_time", "slide_time", "fall_time",
                     "friction_demand_max", "normal_min"):
            want = np.array([np.nan if getattr(r, name) is None else getattr(r, name) for r in rows])
            assert np.array_equal(_bits(got[name].to_numpy(dtype="float64")), _bits(want)), name
    assert any(r.overturned for r in rows) and not all(r.overturned for r in rows)


def test_points_not_stored_yet_are_pending_rows_with_their_grid_values(stored, fmu_path, fmu, tmp_path,
                                                                       monkeypatch):
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    url = f"sqlite:///{tmp_path / 'pending.db'}"
    factory = open_database(url)
    scene = load_scene(ROOT / "examples" / "sweep_sine_pulse.toml")
    sid = create_sweep(factory, scene, [Axis("w", 1, 12, 3), Axis("a", 1.01, 8, 2)], fmu.defaults())
    before = sweep_frame(factory, sid)
    assert len(before) == 6 and set(before["status"]) == {"pending"}
    assert before["run_id"].isna().all() and before["overturned"].isna().all()
    assert sweep_frame(factory, sid, stored_only=True).empty

    monkeypatch.chdir(tmp_path)
    p = run_cli("export", "--sweep", str(sid), db=url, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.startswith("error: sweep") and "no stored points yet" in p.stderr
    assert not list(tmp_path.glob("sweep-*")) and not list(tmp_path.glob(".*.part"))

    run_sweep(factory, sid, fmu_path, workers=1, progress=False)
    after = sweep_frame(factory, sid)
    assert set(after["status"]) == {"ok"} and after["run_id"].notna().all()
    pd.testing.assert_frame_equal(after[["grid_index", "w", "a"]], before[["grid_index", "w", "a"]],
                                  check_exact=True)  # computed as the runs stored them


def test_database_and_stored_tables_show_names_and_filter(stored):
    db = open_db(stored["url"])
    assert isinstance(db, Database) and stored["url"] in repr(db) and db.url == stored["url"]
    runs = db.runs()
    assert len(runs) == 21 and runs.index.tolist() == sorted(runs.index, reverse=True)  # newest first
    single = db.runs(single=True)
    assert single.index.tolist() == [stored["run"]]
    assert single.loc[stored["run"], "scene"] == "sine pulse, h/b = 3"
    assert bool(single.loc[stored["run"], "has_series"]) and single["sweep_id"].isna().all()
    points = db.runs(sweep=stored["sweep"])
    assert len(points) == 20 and (points["sweep_id"] == stored["sweep"]).all()
    assert set(points["scene"]) == {"one-sine pulse, h/b = 2.25, Housner"} and not points["has_series"].any()
    assert db.runs(limit=3).index.tolist() == runs.index[:3].tolist()
    for kind in ("blocks", "scenes", "runs", "sweeps", "records", "measurements"):
        table = stored_table(stored["factory"], kind)
        assert table.index.name == "id"
        assert not any(isinstance(v, bytes) for col in table.columns for v in table[col]), kind
        assert "data" not in table.columns
    sweeps = db.sweeps()
    assert sweeps.loc[stored["sweep"], "grid"] == "w=1:12:5, a=1.01:8:4"
    assert sweeps.loc[stored["sweep"], ["total", "done"]].tolist() == [20, 20]
    assert sweeps.loc[stored["sweep"], "status"] == "done"
    scenes = db.scenes()
    assert set(scenes["name"]) == {"sine pulse, h/b = 3", "one-sine pulse, h/b = 2.25, Housner"}
    assert scenes["runs"].sum() == 21 and set(scenes["excitation"]) == {"sine-pulse"}
    assert db.records().empty and list(db.records(suite="fema-p695").columns)[:2] == ["name", "suite"]

    result = db.run(stored["run"])
    t, cols, events = _stored_run(stored)
    assert result.run_id == stored["run"] and result.scene == "sine pulse, h/b = 3"
    assert np.array_equal(_bits(result.series.index), _bits(t)) and list(result.series.columns) == list(cols)
    assert np.array_equal(_bits(result.series["block1.theta"]), _bits(cols["block1.theta"]))
    assert len(result.events) == len(events) and result.summary["impacts"] == single.loc[stored["run"], "impacts"]
    assert result.parameters["block1.halfWidth"] == 0.1 and result.parameters["g"] > 9.8  # the FMU's defaults too
    # the grid's last point (workers store points in any order, so not necessarily the newest run)
    point = db.run(int(points.index[points["grid_index"] == 19][0]))
    assert point.series.empty and point.summary["has_series"] is False
    assert point.summary["point"] == {"w": 12.0, "a": 8.0}
    sweep = db.sweep(stored["sweep"])
    assert sweep.stats["total"] == 20 and len(sweep.to_pandas()) == 20
    with pytest.raises(ValueError, match="no run 9999"):
        db.run(9999)
    with pytest.raises(ValueError, match="no sweep 9999"):
        db.sweep(9999)
    with pytest.raises(ValueError, match="unknown table"):
        stored_table(stored["factory"], "figures")
    with pytest.raises(ValueError, match="cannot be filtered by 'suite'"):
        stored_table(stored["factory"], "runs", suite="x")
    with pytest.raises(ValueError, match="stores outcomes only"):
        run_frames(stored["factory"], int(points.index[0]))


def test_events_frame_keeps_its_columns_without_events():
    empty = events_frame([])
    assert list(empty.columns) == ["time", "kind"] and empty.empty and empty["time"].dtype == "float64"


@pytest.mark.parametrize("args, message", [
    (["9999"], "no run 9999 in the database"),
    (["--sweep", "9999"], "no sweep 9999 in the database"),
    ([], "give a RUN_ID, or --sweep SWEEP_ID"),
    (["1", "--sweep", "1"], "give a RUN_ID, or --sweep SWEEP_ID"),
    (["1", "--format", "xlsx"], "argument --format: invalid choice"),
    (["1", "--format", "csv", "--out", "x.parquet"], "names a parquet file, and --format is csv"),
    (["--sweep", "1", "--out", "x.xlsx"], "writes csv, parquet or json files (.csv, .parquet or .pq, .json), not "
                                          ".xlsx"),
    (["1", "--format", "csv", "--out", "x.XLS"], "not .xls"),
    (["0"], "no run 0 in the database"),
    (["1", "--out", "/proc/rocking/x.csv"], "cannot write /proc/rocking/x.csv"),
])
def test_bad_exports_are_one_line_errors(stored, fmu_path, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    p = _export(stored, fmu_path, *args)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.startswith("error: ") and p.stderr.count("\n") == 1 and message in p.stderr, p.stderr
    assert "unexpected" not in p.stderr and not list(tmp_path.iterdir())


def test_a_sweep_point_or_a_blocked_destination_writes_nothing(stored, fmu_path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    point = stored_table(stored["factory"], "runs", sweep=stored["sweep"], limit=1).index[0]
    p = _export(stored, fmu_path, str(point))
    assert p.returncode == 2 and f"runners export --sweep {stored['sweep']}" in p.stderr
    (tmp_path / "out-events.csv").mkdir()  # the events file cannot be written: the series is not either
    p = _export(stored, fmu_path, str(stored["run"]), "--out", "out.csv")
    assert p.returncode == 2 and "out-events.csv: it exists and is not a file" in p.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == ["out-events.csv"]


def test_sweep_frame_and_exports_in_chunks_on_sqlite_and_postgresql(db_url, fmu_path, tmp_path):
    from runners.engine.export import export_run, export_sweep

    p = run_cli("sweep", str(ROOT / "examples" / "sweep_sine_pulse.toml"), "--grid", "w=1:12:3", "--grid",
                "a=1.01:8:3", "--no-progress", "--workers", "1", db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli("simulate", str(ROOT / "examples" / "free_rocking.toml"), db=db_url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    db = open_db(db_url)
    sid, rid = int(db.sweeps().index[0]), int(db.runs(single=True).index[0])
    frame = db.sweep(sid).to_pandas()
    assert frame["grid_index"].tolist() == list(range(9)) and set(frame["status"]) == {"ok"}
    assert np.array_equal(_bits(frame["w"]), _bits(np.repeat(np.linspace(1, 12, 3), 3)))
    for fmt in ("parquet", "csv", "json"):  # four grid points at a time: three chunks
        done = export_sweep(db.factory, sid, fmt, tmp_path / f"s.{fmt}", chunk=4)
        assert done.rows == 9 and done.files == [tmp_path / f"s.{fmt}"]
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "s.parquet"), frame, check_exact=True)
    assert pd.read_csv(tmp_path / "s.csv")["run_id"].tolist() == frame["run_id"].tolist()
    assert [p["impacts"] for p in json.loads((tmp_path / "s.json").read_text())["points"]] \
        == frame["impacts"].tolist()
    done = export_run(db.factory, rid, "parquet", tmp_path / "r.parquet")
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "r.parquet"), db.run(rid).series, check_exact=True)
