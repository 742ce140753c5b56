"""runners sweep on a Dask cluster (a LocalCluster of worker processes here): the same
results as the local executor, every grid point stored once even when a worker is killed
mid-sweep, and one-line errors for a bad executor set-up."""

from __future__ import annotations

import os
import signal

import pytest
from sqlalchemy import func, select

from conftest import run_cli, wait_for
from db.schema import Run, RunSummary, Sweep
from db.session import integrity_ok, open_database
from runners.engine.scene import load_scene
from runners.engine.sweep import Axis, create_sweep, run_sweep

distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install -e '.[dask]')")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "examples", "sweep_sine_pulse.toml")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def new_sweep(factory, fmu, counts=(20, 20)) -> int:
    axes = [Axis("w", 1.0, 12.0, counts[0]), Axis("a", 1.01, 8.0, counts[1])]
    return create_sweep(factory, load_scene(SCENE), axes, fmu.defaults())


def summaries(factory, sweep_id: int) -> dict[int, tuple]:
    with factory() as s:
        rows = s.execute(select(Run.grid_index, RunSummary.overturned, RunSummary.impacts,
                                RunSummary.peak1_over_alpha, RunSummary.rest_time)
                         .join(RunSummary, RunSummary.run_id == Run.id).where(Run.sweep_id == sweep_id)).all()
    return {r[0]: tuple(r[1:]) for r in rows}


def test_a_dask_sweep_stores_what_the_local_one_does(db_url, fmu, fmu_path, client):
    factory = open_database(db_url)
    local, dask = new_sweep(factory, fmu), new_sweep(factory, fmu)
    run_sweep(factory, local, fmu_path, workers=2, progress=False)
    st = run_sweep(factory, dask, fmu_path, progress=False, client=client, chunk=37)
    assert st["ran"] == 400 and st["errors"] == 0
    a, b = summaries(factory, local), summaries(factory, dask)
    assert len(a) == 400 and a == b  # bit for bit: the same FMU on the same parameters


class KillFirstFinisher(distributed.WorkerPlugin):
    """Kills (SIGKILL) the worker process on which a task first finishes computing, once: the first worker to
    finish a chunk of the sweep dies right there, mid-sweep, however fast the machine is. The pid
    goes into ``marker`` (created atomically: only one worker wins)."""

    name = "kill-first-finisher"

    def __init__(self, marker: str):
        self.marker = marker

    def transition(self, key, start, finish, **kwargs):
        if (start, finish) != ("executing", "memory"):  # a computed chunk (not the scattered set-up)
            return
        try:
            fd = os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        os.kill(os.getpid(), signal.SIGKILL)


def test_a_killed_dask_worker_loses_and_duplicates_no_point(db_url, fmu, fmu_path, client, tmp_path):
    factory = open_database(db_url)
    sweep_id = new_sweep(factory, fmu, (120, 100))
    marker = tmp_path / "killed.pid"
    before = set(client.run(os.getpid).values())
    client.register_plugin(KillFirstFinisher(str(marker)))
    try:
        run_sweep(factory, sweep_id, fmu_path, progress=False, client=client, chunk=150, batch=300)
    finally:
        client.unregister_worker_plugin(KillFirstFinisher.name)
    victim = int(marker.read_text())
    assert victim in before  # one of the cluster's workers died, with the sweep's first chunk done
    with factory() as s:
        n = s.scalar(select(func.count()).select_from(Run).where(Run.sweep_id == sweep_id))
        distinct = s.scalar(select(func.count(func.distinct(Run.grid_index))).where(Run.sweep_id == sweep_id))
        sw = s.get(Sweep, sweep_id)
        assert (n, distinct, sw.done, sw.status) == (12000, 12000, 12000, "done")
    # the worker really died and the nanny replaced it (once the new one has joined)
    wait_for(lambda: len(client.run(os.getpid)) == 2 and victim not in client.run(os.getpid).values(),
             "the killed worker replaced")
    assert integrity_ok(factory.kw["bind"])


def test_the_command_line_sweeps_on_a_running_scheduler(tmp_path, fmu_path, client):
    """runners sweep in its own process, connecting to the cluster's scheduler by address."""
    import subprocess
    import sys

    db = f"sqlite:///{tmp_path / 'cli.db'}"
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    p = subprocess.run([sys.executable, "-m", "runners.cli", "sweep", SCENE, "--grid", "w=1:12:30", "--grid",
                        "a=1.01:8:30", "--executor", "dask", "--scheduler", client.scheduler.address, "--quiet"],
                       capture_output=True, text=True, env=env, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert "900/900 points stored" in p.stdout
    with open_database(db)() as s:
        assert s.scalar(select(func.count(func.distinct(Run.grid_index)))) == 900


@pytest.mark.parametrize("args, message", [
    (["--executor", "dask"], "needs --scheduler"),
    (["--executor", "dask", "--scheduler", "local:x"], "expected local:N"),
    (["--scheduler", "tcp://127.0.0.1:8786"], "apply to --executor dask"),
    (["--executor", "dask", "--scheduler", "local:1", "--workers", "2"], "--workers applies to the local"),
    (["--executor", "dask", "--scheduler", "local:1", "--chunk", "-5"], "must be at least 1"),
    (["--workers", "0"], "must be at least 1"),
    (["--executor", "dask", "--scheduler", "local:1", "--record", "0"], "--record writes recordings"),
])
def test_bad_executor_settings_are_one_line_errors(tmp_path, fmu_path, args, message):
    p = run_cli("sweep", SCENE, "--grid", "w=1:2:2", "--quiet", *args,
                db=f"sqlite:///{tmp_path / 'e.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and message in p.stderr, p.stderr
    with open_database(f"sqlite:///{tmp_path / 'e.db'}")() as s:
        assert s.scalar(select(func.count()).select_from(Sweep)) == 0  # refused before a sweep is created


def test_sweeps_one_right_after_another_on_one_cluster_each_store_every_point(tmp_path, fmu, fmu_path, client):
    """Each sweep sends the FMU and the batch loop to the cluster: the data of one just finished must
    not be confused with the next one's (equal bytes under an equal key were released while the
    next sweep's tasks waited for them: 'lost dependencies')."""
    factory = open_database(f"sqlite:///{tmp_path / 'row.db'}")
    for counts in ((1, 2), (20, 20), (1, 2), (20, 20)):
        sweep_id = new_sweep(factory, fmu, counts)
        st = run_sweep(factory, sweep_id, fmu_path, progress=False, client=client)
        assert st["stored"] == counts[0] * counts[1] and st["errors"] == 0
