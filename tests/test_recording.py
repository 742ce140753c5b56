"""Rerun recordings read back with Rerun's own dataframe API (a local server and its
catalog), checked against the stored run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from db import series
from db.schema import Run
from db.session import open_database

ROOT = Path(__file__).resolve().parent.parent


def runners(*args, db, fmu_path):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=env,
                          cwd=ROOT)


def read_back(path: Path):
    """The recording as an arrow table indexed by sim_time."""
    import rerun as rr

    with rr.server.Server(host="127.0.0.1", datasets={"runs": [str(path)]}) as srv:
        client = srv.client()  # the client must outlive the query
        dataset = client.get_dataset("runs")
        return dataset.reader(index="sim_time").to_arrow_table()


def column(table, entity: str, component: str = "Scalars:scalars") -> tuple[np.ndarray, np.ndarray]:
    """(sim_time in s, values) of the rows where the entity has data."""
    name = f"{entity}:{component}"
    values = table.column(name).to_pylist()
    times = table.column("sim_time").to_pylist()
    rows = [(t, v) for t, v in zip(times, values) if v is not None]
    t = np.array([r[0].total_seconds() if hasattr(r[0], "total_seconds") else r[0] / 1e9 for r in rows])
    return t, rows


@pytest.mark.parametrize("example", ["harmonic", "two_blocks_free"])
def test_recording_holds_the_stored_run(tmp_path, fmu_path, example):
    db = f"sqlite:///{tmp_path / 'r.db'}"
    rrd = tmp_path / f"{example}.rrd"
    p = runners("simulate", f"examples/{example}.toml", "--rrd", str(rrd), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, s["run_id"])
        assert run.recording == str(rrd.resolve())
        time_, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    table = read_back(rrd)
    blocks = ["block1", "block2"] if example.startswith("two") else ["block1"]
    for b in blocks:
        for var in ("theta", "omega", "alpha_dd"):
            t, rows = column(table, f"/{b}/{var}")
            assert len(rows) == len(time_)
            np.testing.assert_allclose(t, time_, rtol=0, atol=1.5e-9)  # the timeline is in whole nanoseconds
            np.testing.assert_array_equal(np.array([r[1][0] for r in rows]), cols[f"{b}.{var}"])
    for entity in ("/ground/ah", "/energy", "/block1/pivot"):
        assert len(column(table, entity)[1]) == len(time_)
    _, events = column(table, "/events", "TextLog:text")
    impacts = sum(1 for e in events for text in e[1][0].split("; ") if text.startswith("impact"))
    assert impacts == s["impacts"]
    _, frames = column(table, "/scene/block1", "LineStrips2D:strips")
    assert 0 < len(frames) <= 100 * time_[-1] + 1
    assert len(frames[0][1][0]) == 5  # a closed rectangle


def test_rrd_of_a_stored_run_and_errors(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    assert runners("simulate", "examples/sine_pulse.toml", db=db, fmu_path=fmu_path).returncode == 0
    out = tmp_path / "later.rrd"
    p = runners("rrd", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    t, rows = column(read_back(out), "/block1/theta")
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, 1)
        _, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
        assert run.recording == str(out.resolve())
    np.testing.assert_array_equal(np.array([r[1][0] for r in rows]), cols["block1.theta"])
    p = runners("rrd", "5", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "no run 5" in p.stderr


def test_view_without_a_display_writes_the_recording_and_says_where(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'v.db'}"
    assert runners("simulate", "examples/sine_pulse.toml", db=db, fmu_path=fmu_path).returncode == 0
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(ROCKING_FMU=str(fmu_path), ROCKING_DB=db)
    p = subprocess.run([sys.executable, "-m", "runners.cli", "view", "1"], capture_output=True, text=True,
                       env=env, cwd=tmp_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "no display" in p.stderr
    assert (tmp_path / "recordings" / "run-1.rrd").is_file()


def test_a_sweep_recording_holds_the_map_and_every_point(tmp_path, fmu_path):
    import rerun as rr

    db = f"sqlite:///{tmp_path / 'w.db'}"
    scene = ROOT / "examples" / "sweep_sine_pulse.toml"
    assert runners("sweep", str(scene), "--grid", "w=1:10:6", "--grid", "a=1.01:8:5", "--no-progress",
                   db=db, fmu_path=fmu_path).returncode == 0
    out = tmp_path / "sweep.rrd"
    p = runners("rrd", "--sweep", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with rr.server.Server(host="127.0.0.1", datasets={"s": [str(out)]}) as srv:
        client = srv.client()
        dataset = client.get_dataset("s")
        table = dataset.reader(index="grid_index").to_arrow_table()
        static = dataset.reader(index=None).to_arrow_table()
    impacts = [v[0] for v in table.column("/points/impacts:Scalars:scalars").to_pylist() if v is not None]
    grid = table.column("grid_index").to_pylist()
    assert len(impacts) == 30 and sorted(grid) == list(range(30))
    factory = open_database(db)
    with factory() as session:
        stored = {r.grid_index: r.summary.impacts for r in session.query(Run).filter(Run.sweep_id == 1)}
    assert {g: int(v) for g, v in zip(grid, impacts)} == stored
    assert any(name.startswith("/map:Image") for name in static.column_names)
