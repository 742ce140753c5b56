"""runners sweep: grids stored once per point, matching single runs, resumable after SIGKILL,
two sweeps on one SQLite file at once, failing points stored with their errors."""

from __future__ import annotations

import functools
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy import func, select

from db.schema import Run, RunSummary, Sweep
from db.session import integrity_ok, open_database
from tests.conftest import PATIENCE, wait_for

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "sweep_sine_pulse.toml"


def sweep_cmd(*args, db, fmu_path, **kw):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    return subprocess.run([sys.executable, "-m", "runners.cli", "sweep", *args, "--quiet"],
                          capture_output=True, text=True, env=env, cwd=ROOT, **kw)


def counts(db: str, sweep_id: int = 1) -> tuple[int, int, int]:
    factory = open_database(db)
    with factory() as s:
        n = s.scalar(select(func.count()).select_from(Run).where(Run.sweep_id == sweep_id))
        distinct = s.scalar(select(func.count(func.distinct(Run.grid_index))).where(Run.sweep_id == sweep_id))
        total = s.get(Sweep, sweep_id).total
    return n, distinct, total


def test_grid_points_match_single_runs(tmp_path, fmu_path, fmu):
    db = f"sqlite:///{tmp_path / 's.db'}"
    p = sweep_cmd(str(SCENE), "--grid", "w=2:8:4", "--grid", "a=1.5:6:5", "--workers", "2", db=db,
                  fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert counts(db) == (20, 20, 20)
    factory = open_database(db)
    b, h, g = 0.0225, 0.050625, 9.81
    pf = math.sqrt(3 * g / (4 * math.hypot(b, h)))
    with factory() as s:
        runs = s.scalars(select(Run).where(Run.sweep_id == 1).order_by(Run.grid_index)).all()
        overturned = {r.grid_index: (r.summary.overturned, r.summary.impacts) for r in runs}
        points = {r.grid_index: r.point for r in runs}
    assert {o for o, _ in overturned.values()} == {True, False}  # the grid spans both outcomes
    for i in (0, 7, 13, 19):
        w, a = points[i]["w"], points[i]["a"]
        r = fmu.run({"block1.halfWidth": b, "block1.halfHeight": h, "block1.mass": 0.5444, "excitation.kind": 1,
                     "excitation.frequency": w * pf / (2 * math.pi), "excitation.amplitude": a * g * b / h},
                    4.0, 4.0, outputs=["overturned", "impacts"], events=False)
        assert overturned[i] == (bool(r.outputs["overturned"][-1]), int(r.outputs["impacts"][-1]))


@functools.lru_cache(maxsize=None)
def _factory(db: str):
    return open_database(db)


def _stored(db: str) -> int:
    with _factory(db)() as s:
        return s.scalar(select(func.count()).select_from(Run))


def test_killed_sweeps_resume_to_every_point_once(db_url, fmu_path):
    db = db_url
    open_database(db)
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    cmd = [sys.executable, "-m", "runners.cli", "sweep", "--quiet"]
    # 100,000 points: a transaction every half second leaves most of them to each resume
    args = [str(SCENE), "--grid", "w=1:12:100", "--grid", "a=1.01:8:1000", "--workers", "2"]
    before = 0
    for attempt in range(3):  # start (or resume), wait for a batch or more to land, then SIGKILL everything
        proc = subprocess.Popen(cmd + (args if attempt == 0 else ["--resume", "1"]), cwd=ROOT, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        wait_for(lambda: _stored(db) > before, "a batch stored", proc)
        os.killpg(proc.pid, signal.SIGKILL)  # the runner and its workers, mid-sweep
        proc.wait()
        now = _stored(db)
        assert now > before or attempt > 0
        before = now
    n, distinct, total = counts(db)
    assert n == distinct and n < total  # partial, no duplicates
    p = sweep_cmd("--resume", "1", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert counts(db) == (100_000, 100_000, 100_000)
    factory = open_database(db)
    with factory() as s:
        assert s.scalar(select(func.count()).select_from(RunSummary)) == 100_000
        assert s.get(Sweep, 1).done == 100_000 and s.get(Sweep, 1).status == "done"
    assert integrity_ok(factory.kw["bind"])


def test_two_sweeps_on_one_database_at_once(db_url, fmu_path):
    db = db_url
    open_database(db)
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    procs = [subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", str(SCENE), "--grid", spec,
                               "--grid", "a=1.01:8:40", "--workers", "1", "--quiet"], cwd=ROOT, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
             for spec in ("w=1:6:40", "w=6:12:40")]
    outs = [p.communicate(timeout=PATIENCE) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    assert counts(db, 1) == (1600, 1600, 1600) and counts(db, 2) == (1600, 1600, 1600)


def test_failing_points_are_stored_and_the_sweep_goes_on(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'e.db'}"
    p = sweep_cmd(str(SCENE), "--grid", "block1.halfWidth=-0.02:0.02:5", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as s:
        runs = s.scalars(select(Run).where(Run.sweep_id == 1)).all()
        errors = [r for r in runs if r.status == "error"]
        assert len(runs) == 5 and len(errors) == 3  # -0.02, -0.01, 0.0
        assert all("block1.halfWidth" in r.error_message and r.summary is None for r in errors)


@pytest.mark.parametrize("args,message", [
    (["--grid", "w=1:2"], "expected NAME=START:STOP:COUNT"),
    (["--grid", "nope=1:2:3"], "unknown name 'nope'"),
    (["--grid", "w=1:2:0"], "COUNT must be >= 1"),
    ([], "at least one --grid"),
])
def test_bad_grids_are_one_line_errors(tmp_path, fmu_path, args, message):
    p = sweep_cmd(str(SCENE), *args, db=f"sqlite:///{tmp_path / 'b.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and message in p.stderr, p.stderr


def test_resuming_an_unknown_sweep_is_an_error(tmp_path, fmu_path):
    p = sweep_cmd("--resume", "42", db=f"sqlite:///{tmp_path / 'u.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and "no sweep 42" in p.stderr


def test_a_two_block_map_completes(tmp_path, fmu_path):
    scene = tmp_path / "stack.toml"
    scene.write_text((ROOT / "examples" / "two_blocks_harmonic.toml").read_text()
                     .replace('kind = "harmonic"', 'kind = "sine-pulse"\namplitude = 3.0')
                     .replace("cycles = 0             # endless", "cycles = 1")
                     .replace("stop_time = 10.0", "stop_time = 3.0"))
    db = f"sqlite:///{tmp_path / 't.db'}"
    p = sweep_cmd(str(scene), "--grid", "w=1:10:12", "--grid", "a=1.01:6:12", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as s:
        rows = s.scalars(select(RunSummary)).all()
        assert len(rows) == 144 and all(r.impacts_ground is not None for r in rows)
        assert {r.overturned for r in rows} == {True, False}


def test_map_of_a_sweep(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'm.db'}"
    assert sweep_cmd(str(SCENE), "--grid", "w=1:10:12", "--grid", "a=1.01:8:12", db=db,
                     fmu_path=fmu_path).returncode == 0
    assert sweep_cmd(str(SCENE), "--grid", "excitation.amplitude=2:10:5", db=db, fmu_path=fmu_path).returncode == 0
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    for sweep, out in (("1", "two_d.png"), ("latest", "one_d.png")):
        p = subprocess.run([sys.executable, "-m", "runners.cli", "map", sweep, "--out", str(tmp_path / out)],
                           capture_output=True, text=True, env=env, cwd=ROOT)
        assert p.returncode == 0, p.stderr
        assert (tmp_path / out).read_bytes()[:4] == b"\x89PNG"
    counts_line = subprocess.run([sys.executable, "-m", "runners.cli", "map", "1", "--out", str(tmp_path / "x.png")],
                                 capture_output=True, text=True, env=env, cwd=ROOT).stdout
    numbers = [int(s.split()[-1]) for s in counts_line.split(";")[0].split(", ")]
    assert sum(numbers) == 144 and numbers[0] > 0 and numbers[1] + numbers[2] > 0
    p = subprocess.run([sys.executable, "-m", "runners.cli", "map", "9"], capture_output=True, text=True, env=env,
                       cwd=ROOT)
    assert p.returncode == 2 and "no sweep 9" in p.stderr


def _store_as_another_resume(factory, source: int, sweep_id: int, indices: list[int]) -> None:
    """Store grid points of sweep `sweep_id` as another process resuming it would: their runs
    and summaries (the rows sweep `source`, the same grid, stored for them) and the sweep's count."""
    from sqlalchemy import insert, update

    runs, summaries = Run.__table__, RunSummary.__table__
    with factory.begin() as s:
        for row in s.execute(select(runs).where(runs.c.sweep_id == source, runs.c.grid_index.in_(indices))).mappings():
            new_id = s.execute(insert(runs).returning(runs.c.id),
                               {**{k: v for k, v in row.items() if k != "id"}, "sweep_id": sweep_id}).scalar_one()
            summary = s.execute(select(summaries).where(summaries.c.run_id == row["id"])).mappings().one()
            s.execute(insert(summaries), {**{k: v for k, v in summary.items() if k != "id"}, "run_id": new_id})
        s.execute(update(Sweep).where(Sweep.id == sweep_id).values(done=Sweep.done + len(indices)))


def test_two_resumes_of_one_sweep_share_its_points(db_url, fmu, fmu_path):
    """Two `runners sweep ID` at once compute the same points; each stores those the other has
    not. Made deterministic: the other resume stores some of the points right before each of this
    one's first two stores begin (the update of the sweep's count, the first statement of each,
    seen by an event on this one's engine), which two real resumes did in 2 of 4 tries, and which
    failed with "UNIQUE constraint failed: runs.sweep_id, runs.grid_index"."""
    from sqlalchemy import event

    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    factory = open_database(db_url)
    axes = [Axis("w", 1.0, 12.0, 4), Axis("a", 1.01, 8.0, 3)]
    twin = create_sweep(factory, load_scene(SCENE), axes, fmu.defaults())
    run_sweep(factory, twin, fmu_path, workers=1, progress=False)  # the points, as the other resume computes them
    sweep_id = create_sweep(factory, load_scene(SCENE), axes, fmu.defaults())
    other = open_database(db_url)  # the other process's connection
    its_stores = [[0, 1, 2], [3, 4, 5]]

    def other_resume_stores(_conn, _cursor, statement, *_args) -> None:
        if statement.lstrip().upper().startswith("UPDATE SWEEPS SET DONE") and its_stores:
            _store_as_another_resume(other, twin, sweep_id, its_stores.pop(0))

    engine = factory.kw["bind"]
    event.listen(engine, "before_cursor_execute", other_resume_stores)
    try:
        st = run_sweep(factory, sweep_id, fmu_path, workers=1, progress=False)
    finally:
        event.remove(engine, "before_cursor_execute", other_resume_stores)
    assert its_stores == []  # the other resume stored before both inserts
    assert st["skipped"] == 6 and st["stored"] == 12
    assert counts(db_url, sweep_id) == (12, 12, 12)  # every point once
    with factory() as s:
        sw = s.get(Sweep, sweep_id)
        assert (sw.done, sw.status) == (12, "done")
        got = s.execute(select(Run.grid_index, RunSummary.overturned, RunSummary.impacts, RunSummary.peak1_over_alpha)
                        .join(RunSummary).where(Run.sweep_id == sweep_id).order_by(Run.grid_index)).all()
        want = s.execute(select(Run.grid_index, RunSummary.overturned, RunSummary.impacts, RunSummary.peak1_over_alpha)
                         .join(RunSummary).where(Run.sweep_id == twin).order_by(Run.grid_index)).all()
    assert got == want


def test_two_resumes_started_at_once_both_finish_and_store_every_point_once(tmp_path, fmu, fmu_path):
    """The same with two real `runners sweep ID` processes started together (whether their
    batches overlap depends on the machine; the test above makes them overlap)."""
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep

    db = f"sqlite:///{tmp_path / 's.db'}"
    factory = open_database(db)
    sweep_id = create_sweep(factory, load_scene(SCENE), [Axis("w", 1.0, 12.0, 30), Axis("a", 1.01, 8.0, 30)],
                            fmu.defaults())
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    procs = [subprocess.Popen([sys.executable, "-m", "runners.cli", "sweep", str(sweep_id), "--workers", "1",
                               "--quiet", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=env, cwd=ROOT) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [err for _, err in outs]
    assert counts(db, sweep_id) == (900, 900, 900)
    with factory() as s:
        assert (s.get(Sweep, sweep_id).done, s.get(Sweep, sweep_id).status) == (900, "done")
