"""Rerun recordings read back with Rerun's own dataframe API (a local server and its
catalog), checked against the stored run."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from db import series
from db.schema import Run
from db.session import open_database
from conftest import PATIENCE, run_cli

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
    p = runners("simulate", f"examples/{example}.toml", "--out", str(rrd), "--json", db=db, fmu_path=fmu_path)
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
    if len(blocks) == 2:  # block 2's pivot lies on block 1's top edge and on block 2's bottom edge
        _, outline2 = column(table, "/scene/block2", "LineStrips2D:strips")
        _, pivot2 = column(table, "/scene/pivot/block2", "Points2D:positions")
        assert len(pivot2) == len(frames)

        def off_segment(q, a, b):
            u = np.clip(np.dot(q - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
            return np.linalg.norm(q - (a + u * (b - a)))

        for f1, f2, k in zip(frames, outline2, pivot2):
            r1, r2, q = np.array(f1[1][0], float), np.array(f2[1][0], float), np.array(k[1][0], float)
            assert off_segment(q, r1[2], r1[3]) < 1e-7 and off_segment(q, r2[0], r2[1]) < 1e-7


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


@pytest.mark.parametrize("step", [None, 0.01])
def test_a_record_run_logs_its_series_and_its_record_on_shared_time_rows(tmp_path, fmu_path, step):
    """The series and /record/ah are logged on the same whole nanoseconds: a reader gets one row per
    instant, not one at the FMU's 0.004999999 s and another at the record's 0.005 s (Rerun truncates
    float seconds; the output step taken from the record's samples is 0.004999999999999893 s), which
    doubled the rows a reader returned."""
    n = 400  # samples every 0.005 s, as the FEMA P695 records
    csv = tmp_path / "rec.csv"
    csv.write_text("# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n"
                   + "".join(f"{0.005 * i:.3f},{3.0 * math.sin(2 * math.pi * 2.5 * 0.005 * i)!r}\n" for i in range(n)))
    scene = tmp_path / "s.toml"
    scene.write_text(f'[block]\nhalf_width = 0.1\nhalf_height = 0.3\n[excitation]\nfile = "{csv}"\n'
                     "[simulation]\nstop_time = 2.5\n" + (f"step = {step}\n" if step else ""))
    rrd = tmp_path / "r.rrd"
    p = runners("simulate", str(scene), "--out", str(rrd), db=f"sqlite:///{tmp_path / 'r.db'}", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    table = read_back(rrd)
    theta = np.array([v is not None for v in table.column("/block1/theta:Scalars:scalars").to_pylist()])
    ah = np.array([v is not None for v in table.column("/record/ah:Scalars:scalars").to_pylist()])
    per_step = 2 if step else 1  # record samples per output step
    assert theta.sum() == 500 // per_step + 1 and ah.sum() == n
    assert (theta & ah).sum() == len(range(0, n, per_step))  # each record sample on the output grid shares its row
    ns = np.array(table.column("sim_time").cast("int64").to_pylist())
    assert np.min(np.diff(np.sort(ns[theta | ah]))) == 5_000_000  # the sampling interval: no two rows 1 ns apart


def test_the_docs_read_a_recording_into_a_dataframe(tmp_path, monkeypatch, fmu_path):
    """docs/recordings.md's Python block, run as written on the recording its command writes:
    the DataFrame holds the stored run's series, bit for bit, at their times."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "recordings.md").read_text(), re.S)
    assert len(blocks) == 1
    db = f"sqlite:///{tmp_path / 'r.db'}"
    p = runners("simulate", "examples/sine_pulse.toml", "--out", str(tmp_path / "sine.rrd"), "--json", db=db,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as session:
        run = session.get(Run, json.loads(p.stdout)["run_id"])
        time_, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(blocks[0], "docs/recordings.md", "exec"), namespace)
    frame = namespace["series"]
    np.testing.assert_allclose(frame.index, time_, rtol=0, atol=1e-9)  # whole nanoseconds
    np.testing.assert_array_equal(frame["theta"], cols["block1.theta"])
    np.testing.assert_array_equal(frame["ah"], cols["ground.ahTotal"])


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
    assert runners("sweep", str(scene), "--grid", "w=1:10:6", "--grid", "a=1.01:8:5", "--quiet",
                   db=db, fmu_path=fmu_path).returncode == 0
    out = tmp_path / "sweep.rrd"
    p = runners("rrd", "--sweep", "1", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with rr.server.Server(host="127.0.0.1", datasets={"s": [str(out)]}) as srv:
        client = srv.client()
        dataset = client.get_dataset("s")
        table = dataset.reader(index="grid_index").to_arrow_table()
    impacts = [v[0] for v in table.column("/points/impacts:Scalars:scalars").to_pylist() if v is not None]
    grid = table.column("grid_index").to_pylist()
    assert len(impacts) == 30 and sorted(grid) == list(range(30))
    factory = open_database(db)
    with factory() as session:
        stored = {r.grid_index: r.summary.impacts for r in session.query(Run).filter(Run.sweep_id == 1)}
    assert {g: int(v) for g, v in zip(grid, impacts)} == stored
    # the map is a PNG in one row (the first grid index), not static data joined to every row
    maps = [(g, b) for g, b in zip(grid, table.column("/map:EncodedImage:blob").to_pylist()) if b is not None]
    assert len(maps) == 1 and maps[0][0] == 0
    png = bytes(maps[0][1][0])
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image as mpimg
    import io

    assert mpimg.imread(io.BytesIO(png), format="png").shape[0] > 300  # a picture, not a thumbnail


READ_SWEEP = """
import sys
import rerun as rr
with rr.server.Server(host="127.0.0.1", datasets={"s": [sys.argv[1]]}) as srv:
    client = srv.client()
    table = client.get_dataset("s").reader(index="grid_index").to_arrow_table()
    grid = table.column("grid_index").to_pylist()
    maps = sum(v is not None for v in table.column("/map:EncodedImage:blob").to_pylist())
peak = next(int(x.split()[1]) for x in open("/proc/self/status") if x.startswith("VmHWM"))
print(table.num_rows, len(set(grid)), maps, table.nbytes, peak)
"""
CAP_MB = 500


def test_a_10000_point_sweep_recording_reads_back_in_under_500_mb(tmp_path, fmu_path):
    """A real 100 x 100 sweep (one block, one-sine pulse, 1 s simulated), its recording written
    by write_sweep_recording and read back whole with Rerun's dataframe API in a child process.

    The cap is on resident memory: the parent watches the child's VmRSS and kills it above
    500 MB, and the child reports its own peak (VmHWM, Linux). Not RLIMIT_AS: Rerun's server
    and DataFusion reserve about 4 GB of address space they never touch. Not the parent's
    wait4 ru_maxrss either: Linux carries the forking pytest process's peak over the exec."""
    import time

    from runners.analysis.sweep_map import sweep_picture
    from runners.engine.fmu import RockingFMU
    from runners.engine.recording import write_sweep_recording
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    factory = open_database(f"sqlite:///{tmp_path / 'big.db'}")
    scene = load_scene(ROOT / "examples" / "sweep_sine_pulse.toml")
    scene.stop_time = 1.0
    with RockingFMU(fmu_path) as f:
        defaults = f.defaults()
    sid = create_sweep(factory, scene, [Axis("w", 1.0, 12.0, 100), Axis("a", 1.01, 8.0, 100)], defaults)
    assert run_sweep(factory, sid, fmu_path, progress=False)["stored"] == 10_000
    rrd = write_sweep_recording(tmp_path / "big.rrd", factory, sid, sweep_picture(factory, sid))
    child = subprocess.Popen([sys.executable, "-c", READ_SWEEP, str(rrd)], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
    seen, deadline = 0.0, time.monotonic() + PATIENCE  # a last resort: the cap is on memory
    while child.poll() is None:
        try:
            rss = next(int(x.split()[1]) for x in Path(f"/proc/{child.pid}/status").read_text().splitlines()
                       if x.startswith("VmRSS")) / 1024
        except (OSError, StopIteration):  # between exit and reaping
            rss = 0.0
        seen = max(seen, rss)
        if rss > CAP_MB or time.monotonic() > deadline:
            child.kill()
        try:  # ends at once when the reader exits; otherwise its memory is sampled again after 20 ms
            child.wait(timeout=0.02)
        except subprocess.TimeoutExpired:
            pass
    text = child.stdout.read()
    child.stdout.close()
    assert child.returncode == 0, f"killed or failed, {seen:.0f} MB resident seen: {text[-2000:]}"
    rows, distinct, maps, nbytes, peak_kb = map(int, text.split()[-5:])
    assert rows == distinct == 10_000 and maps == 1
    print(f"10,000-point sweep recording: {rrd.stat().st_size / 1e6:.2f} MB on disk, table {nbytes / 1e6:.2f} MB, "
          f"reader's peak resident memory {peak_kb / 1024:.0f} MB")
    assert peak_kb / 1024 < CAP_MB


def test_base_motion_is_the_table_displacement_in_a_centred_inertial_frame(fmu):
    """Seed 000's shaking table: a = -D w^2 sin(w t) is the second derivative of D sin(w t).
    Integrated twice from rest it drifts at the constant velocity D w; base_motion removes
    a line, so it must match D sin(w t) with its own least-squares line removed."""
    from runners.engine.recording import base_motion

    D, f = 0.003, 7.0
    res = fmu.run({"block1.halfWidth": 0.03, "block1.halfHeight": 0.0675, "excitation.kind": 3,
                   "excitation.displacement": D, "excitation.frequency": f, "excitation.cycles": 0},
                  2.0, 1e-3, outputs=["ground.ahTotal", "ground.avTotal"], events=False)
    t = res.time
    x, y = base_motion(t, res.outputs["ground.ahTotal"], res.outputs["ground.avTotal"])
    exact = D * np.sin(2 * np.pi * f * t)
    exact -= np.polyval(np.polyfit(t, exact, 1), t)
    assert np.max(np.abs(x - exact)) < 1e-3 * D  # trapezoid error ~ (h w)^2 / 12 = 1.6e-4
    assert np.max(np.abs(y)) == 0.0


def test_the_animated_scene_stands_on_the_moving_base(tmp_path, fmu_path):
    """Every frame: block 1 has its true size, its lowest corner is on the base, at the
    pivot in use (theta > 0: the right corner), and the base's hatching moves with it."""
    from runners.engine.recording import base_motion

    db = f"sqlite:///{tmp_path / 'b.db'}"
    rrd = tmp_path / "h.rrd"
    p = runners("simulate", "examples/harmonic.toml", "--out", str(rrd), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, json.loads(p.stdout)["run_id"])
        time_, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    xg, yg = base_motion(time_, cols["ground.ahTotal"], cols["ground.avTotal"])
    assert np.ptp(xg) > 5e-3  # the 3 mm table visibly moves
    table = read_back(rrd)
    t, frames = column(table, "/scene/block1", "LineStrips2D:strips")
    _, ground = column(table, "/scene/ground", "LineStrips2D:strips")
    k = np.searchsorted(time_, t - 1e-9)
    assert np.max(np.abs(time_[k] - t)) < 1e-8
    b, h = 0.030, 0.0675
    for j, (_, value) in zip(k, frames):
        # Rerun keeps positions as float32 (about 1e-8 m here); the recording draws y down
        pts = np.array(value[0], float)[:4] * [1, -1]
        edges = np.linalg.norm(np.diff(np.vstack([pts, pts[:1]]), axis=0), axis=1)
        np.testing.assert_allclose(sorted(edges), [2 * b, 2 * b, 2 * h, 2 * h], rtol=1e-6)
        lowest = pts[np.argmin(pts[:, 1])]
        assert abs(lowest[1] - yg[j]) < 1e-7
        side = 1.0 if cols["block1.theta"][j] > 0 else -1.0
        if cols["block1.theta"][j] != 0:
            assert abs(lowest[0] - (xg[j] + side * b)) < 1e-7
    for j, (_, value) in zip(k, ground):
        base_line = np.array(value[0], float) * [1, -1]
        assert abs(base_line.mean(axis=0)[0] - xg[j]) < 1e-7 and abs(base_line[0, 1] - yg[j]) < 1e-7


def test_measured_series_are_overlaid_and_bad_files_are_refused(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'm.db'}"
    assert runners("simulate", "examples/free_rocking.toml", db=db, fmu_path=fmu_path).returncode == 0
    factory = open_database(db)
    with factory() as session:
        time_, cols = series.unpack(*(lambda s: (s.names, s.n_samples, s.data))(session.get(Run, 1).series))
    rng = np.random.default_rng(7)
    tm = time_[::50]
    thm = cols["block1.theta"][::50] + rng.normal(0, 0.5 * np.pi / 180, len(tm))  # the thesis's +-0.5 deg
    csv = tmp_path / "measured.csv"
    csv.write_text("# free rocking, read from video\ntime,block1.theta\n"
                   + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(tm, thm)))
    out = tmp_path / "m.rrd"
    p = runners("rrd", "1", "--out", str(out), "--measured", str(csv), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    t, rows = column(read_back(out), "/measured/block1/theta")
    np.testing.assert_allclose(t, tm, atol=1.5e-9)
    np.testing.assert_array_equal([r[1][0] for r in rows], thm)
    bad = {
        "time,block1.theta\n0,0\n0,0.1\n": "does not increase",
        "time,block1.theta\n0,0\n0.1,abc\n": "not a number",
        "time,block3.theta\n0,0\n0.1,0\n": "block3.theta",
        "t,block1.theta\n0,0\n0.1,0\n": "first column must be 'time'",
        "time,block1.theta\n0,0\n0.1\n": "fields",
        "time,block1.theta\n0,0\n": "at least two data rows",
    }
    for text, reason in bad.items():
        csv.write_text(text)
        p = run_cli("rrd", "1", "--out", str(tmp_path / "x.rrd"), "--measured", str(csv), db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and reason in p.stderr, (text, p.stderr)
        assert not (tmp_path / "x.rrd").exists()
    with factory() as session:
        assert session.get(Run, 1).recording == str(out.resolve())  # a refused file changes nothing stored
    p = runners("simulate", "examples/free_rocking.toml", "--measured", str(csv), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "--out RUN.rrd" in p.stderr
    p = runners("rrd", "1", "--measured", str(tmp_path / "none.csv"), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "does not exist" in p.stderr


def test_recordings_written_at_once_from_threads_stay_apart(tmp_path, fmu):
    """Each recording has its own stream and file: two written concurrently hold only their own data."""
    from concurrent.futures import ThreadPoolExecutor

    from runners.engine.recording import write_recording

    p = fmu.defaults()
    t = np.linspace(0.0, 1.0, 1001)
    jobs = {i: (tmp_path / f"t{i}.rrd", {"block1.theta": np.full_like(t, 1e-3 * (i + 1)),
                                         "block1.omega": np.zeros_like(t)}) for i in range(4)}
    with ThreadPoolExecutor(4) as pool:
        list(pool.map(lambda i: write_recording(jobs[i][0], f"run {i}", t, jobs[i][1], p), jobs))
    for i, (path, out) in jobs.items():
        _, rows = column(read_back(path), "/block1/theta")
        assert len(rows) == len(t) and {r[1][0] for r in rows} == {1e-3 * (i + 1)}


def test_a_sweep_records_chosen_points_in_its_workers_and_later(tmp_path, fmu_path):
    """sweep --record: worker processes write full recordings of the chosen points and
    their series and events are stored; rrd --sweep --points records stored points later.
    The single-step summary of every point agrees with its full recording's events."""
    db = f"sqlite:///{tmp_path / 'rs.db'}"
    scene = ROOT / "examples" / "sweep_sine_pulse.toml"
    rec_dir = tmp_path / "rec"
    p = runners("sweep", str(scene), "--grid", "w=1:10:6", "--grid", "a=1.01:8:5", "--quiet",
                "--workers", "2", "--points", "0,7,20-22", "--out", str(rec_dir), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "recorded 5 points" in p.stdout
    p = runners("rrd", "--sweep", "1", "--points", "3,4", "--out", str(rec_dir), "--quiet",
                db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as session:
        runs = {r.grid_index: r for r in session.query(Run).filter(Run.sweep_id == 1)}
        recorded = {i: (r.recording, r.summary.impacts, r.series.events,
                        series.unpack(r.series.names, r.series.n_samples, r.series.data))
                    for i, r in runs.items() if r.recording}
        assert all(r.series is None for i, r in runs.items() if i not in recorded)
    assert sorted(recorded) == [0, 3, 4, 7, 20, 21, 22]
    for i, (path, impacts, events, (time_, cols)) in recorded.items():
        assert path == str((rec_dir / f"point-{i}.rrd").resolve())
        assert sum(e["kind"] == "impact" for e in events) == impacts  # stored summary, one doStep
        table = read_back(Path(path))
        t, rows = column(table, "/block1/theta")
        np.testing.assert_array_equal([r[1][0] for r in rows], cols["block1.theta"])
        _, texts = column(table, "/events", "TextLog:text")
        assert sum(x.startswith("impact") for e in texts for x in e[1][0].split("; ")) == impacts
    # a stored sweep point's recording can be written again from the database, with its events
    out = tmp_path / "again.rrd"
    p = runners("rrd", str(runs[21].id), "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    _, texts = column(read_back(out), "/events", "TextLog:text")
    assert sum(x.startswith("impact") for e in texts for x in e[1][0].split("; ")) == recorded[21][1]
    for bad, reason in (("30", "outside"), ("5-2", "outside"), ("x", "expected grid indices")):
        p = runners("rrd", "--sweep", "1", "--points", bad, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and reason in p.stderr, p.stderr
    p = runners("rrd", str(runs[1].id), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "--points 1" in p.stderr


def test_screenshot_without_a_browser_is_a_one_line_error(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'n.db'}"
    assert runners("simulate", "examples/sine_pulse.toml", db=db, fmu_path=fmu_path).returncode == 0
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db, "PATH": str(tmp_path)}
    p = subprocess.run([sys.executable, "-m", "runners.cli", "screenshot", "1", "--out", str(tmp_path / "s.png")],
                       capture_output=True, text=True, env=env, cwd=ROOT)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "Chromium" in p.stderr, p.stderr
    assert not (tmp_path / "s.png").exists()


def _can_screenshot() -> bool:
    import importlib.util

    return importlib.util.find_spec("playwright") is not None and any(
        shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome"))


@pytest.mark.slow
@pytest.mark.skipif(not _can_screenshot(), reason="needs Chromium (Debian: apt-get install chromium) and "
                                                   "Playwright (pip install -e '.[docs]') to draw Rerun's web viewer")
def test_screenshot_shows_the_viewer_with_the_recording(tmp_path, fmu_path):
    """Rerun's own (web) viewer draws the recording: the PNG shows the blocks' colours."""
    import matplotlib.image as mpimg

    from runners.engine.recording import COLOURS

    db = f"sqlite:///{tmp_path / 'sh.db'}"
    assert runners("simulate", "examples/two_blocks_harmonic.toml", db=db, fmu_path=fmu_path).returncode == 0
    png = tmp_path / "viewer.png"
    p = runners("screenshot", "1", "--out", str(png), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    img = (mpimg.imread(png)[..., :3] * 255).astype(int)
    for block in ("block1", "block2"):
        near = np.abs(img - np.array(COLOURS[block])).max(axis=-1) < 30
        assert near.sum() > 500, block  # outlines and curves in the block's colour


def _blueprint_ranges(rrd: Path) -> dict[str, tuple[float, float]]:
    """The y range stored in the recording's blueprint for each time-series view, by view name."""
    import rerun.chunk as rc

    reader = rc.RrdReader(rrd)
    (store,) = reader.blueprints()
    names, ranges = {}, {}
    for chunk in reader.stream(store=store):
        entity, data = chunk.entity_path, chunk.to_record_batch().to_pydict()
        view = "/".join(entity.split("/")[:3])  # /view/<id>
        for key, values in data.items():
            if key.endswith(":display_name"):
                names[view] = values[-1][0]
            if key == "ScalarAxis:range" and values[-1]:
                ranges[view] = tuple(values[-1][0])
    return {names[v]: r for v, r in ranges.items()}


@pytest.mark.parametrize("example", ["two_blocks_harmonic", "sine_pulse"])
def test_the_viewer_plots_have_ranges_with_labelled_ticks(tmp_path, fmu, example):
    """The blueprint gives each plot a y range symmetric about 0 whose powers of ten the viewer
    labels: at least 0 and +-10^k inside it, at most three steps of 10^k from 0 to the edge (so
    the labels lie far enough apart to be drawn), the curves filling at least 30% of it."""
    from runners.engine.recording import write_recording
    from runners.engine.scene import load_scene
    from runners.engine.summary import SUMMARY_OUTPUTS

    scene = load_scene(ROOT / "examples" / f"{example}.toml")
    r = fmu.run(scene.parameters, min(scene.stop_time, 3.0), 0.01, outputs=SUMMARY_OUTPUTS)
    rrd = write_recording(tmp_path / "r.rrd", scene.name, r.time, r.outputs, {**fmu.defaults(), **scene.parameters},
                          r.events)
    ranges = _blueprint_ranges(rrd)
    table = read_back(rrd)
    blocks = ["block1", "block2"] if scene.n_blocks == 2 else ["block1"]
    for view, entities in (("theta (rad)", [f"/{b}/theta" for b in blocks]),
                           ("omega (rad/s)", [f"/{b}/omega" for b in blocks]),
                           ("ground (m/s2)", ["/ground/ah", "/ground/av"])):
        lo, hi = ranges[view]
        peak = max(abs(v[1][0]) for e in entities for v in column(table, e)[1])  # as stored in the recording
        step = 10.0 ** math.floor(math.log10(hi))
        assert lo == -hi and peak <= hi and peak >= 0.3 * hi, (view, lo, hi, peak)
        assert 1 <= hi / step <= 3 + 1e-9, (view, hi)  # labels 0, +-step (and +-2, +-3 step) in view
