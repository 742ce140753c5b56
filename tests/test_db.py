"""The experiment database: schema and migrations, catalogue, stored runs (lossless,
all or nothing), and its command line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from alembic.migration import MigrationContext
from alembic.autogenerate import compare_metadata
from sqlalchemy import func, select, text

from db import series
from db.catalogue import CATALOGUE
from db.schema import Base, Block, Run, RunSeries, Scene
from db.session import DatabaseError, open_database, integrity_ok
from tests.conftest import PATIENCE

ROOT = Path(__file__).resolve().parent.parent


def runners(*args, db, fmu_path):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=env,
                          cwd=ROOT)


def test_schema_migration_matches_the_models_and_sqlite_settings(tmp_path):
    factory = open_database(f"sqlite:///{tmp_path / 'a.db'}")
    engine = factory.kw["bind"]
    with engine.connect() as conn:
        assert compare_metadata(MigrationContext.configure(conn), Base.metadata) == []
        assert conn.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert conn.execute(text("PRAGMA foreign_keys")).scalar() == 1
    open_database(f"sqlite:///{tmp_path / 'a.db'}")  # reopening is a no-op upgrade
    assert integrity_ok(engine)


def test_bad_urls_are_one_line_errors(tmp_path):
    with pytest.raises(DatabaseError, match="cannot use database URL"):
        open_database("nope://x")
    with pytest.raises(DatabaseError, match=r"cannot create the database \S*/missing-dir/x\.db: its folder \S* does not"):
        open_database(f"sqlite:///{tmp_path / 'missing-dir' / 'x.db'}")


def test_a_plain_path_is_an_sqlite_file(tmp_path, fmu_path):
    path = tmp_path / "results.db"
    p = runners("simulate", "examples/sine_pulse.toml", db=str(path), fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(f"sqlite:///{path}")() as session:
        assert session.scalar(select(func.count()).select_from(Run)) == 1


def test_series_are_stored_bit_for_bit():
    rng = np.random.default_rng(1)
    t, cols = np.linspace(0, 1, 1001), {"a": rng.standard_normal(1001), "b": rng.standard_normal(1001) * 1e-300}
    names, n, blob = series.pack(t, cols)
    t2, cols2 = series.unpack(names, n, blob)
    assert np.array_equal(t, t2) and all(np.array_equal(cols[k], cols2[k]) for k in cols)
    assert len(blob) < 3 * 8 * 1001


def test_catalogue_loads_once_with_the_seeds_numbers(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'c.db'}"
    for _ in range(2):
        p = runners("db", "init", db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as s:
        assert s.scalar(select(func.count()).select_from(Block)) == len(CATALOGUE) == 8
        b3m = s.scalar(select(Block).where(Block.name == "B3M"))
        assert (b3m.half_width, b3m.half_height, b3m.k, b3m.k_size_average) == (0.0225, 0.050625, 0.7595, 0.8608)
        b1 = s.scalar(select(Block).where(Block.name == "anagnostopoulos-block1"))
        assert (b1.half_width, b1.half_height, b1.correction) == (0.0145, 0.060, 1.036)


def test_simulate_stores_the_run_losslessly(tmp_path, fmu_path, fmu):
    db = f"sqlite:///{tmp_path / 'r.db'}"
    p = runners("simulate", "examples/sine_pulse.toml", "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, s["run_id"])
        assert run.status == "ok" and run.summary.impacts == s["impacts"] and len(run.fmu_sha256) == 64
        assert run.summary.peak1_over_alpha == pytest.approx(s["max_abs_theta_over_alpha"], rel=1e-15)
        t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
        assert session.get(Scene, run.scene_id).source == (ROOT / "examples" / "sine_pulse.toml").read_text()
    from runners.engine.scene import load_scene
    from runners.engine.summary import SUMMARY_OUTPUTS
    scene = load_scene(ROOT / "examples" / "sine_pulse.toml")
    again = fmu.run(scene.parameters, scene.stop_time, scene.step, outputs=SUMMARY_OUTPUTS)
    assert np.array_equal(t, again.time)
    for k in SUMMARY_OUTPUTS:
        assert np.array_equal(cols[k], again.outputs[k]), k


def test_a_failing_simulation_leaves_no_rows(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'f.db'}"
    assert runners("simulate", "examples/sine_pulse.toml", db=db, fmu_path=fmu_path).returncode == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("[block]\nhalf_width = 0.1\n[excitation]\nkind = \"sine-pulse\"\nfrequency = -1.0\n")
    p = runners("simulate", str(bad), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "excitation.frequency" in p.stderr
    factory = open_database(db)
    with factory() as s:
        assert s.scalar(select(func.count()).select_from(Run)) == 1
        assert s.scalar(select(func.count()).select_from(Scene)) == 1
        assert s.scalar(select(func.count()).select_from(RunSeries)) == 1


def test_two_writers_at_once_both_complete(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'w.db'}"
    open_database(db)
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    procs = [subprocess.Popen([sys.executable, "-m", "runners.cli", "simulate", f"examples/{name}.toml"], cwd=ROOT,
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
             for name in ("sine_pulse", "harmonic", "two_blocks_free", "free_rocking")]
    assert all(p.wait(timeout=PATIENCE) == 0 for p in procs)
    factory = open_database(db)
    with factory() as s:
        assert s.scalar(select(func.count()).select_from(Run)) == 4
    assert integrity_ok(factory.kw["bind"])


def test_db_list_and_show(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'l.db'}"
    runners("db", "init", db=db, fmu_path=fmu_path)
    runners("simulate", "examples/two_blocks_free.toml", db=db, fmu_path=fmu_path)
    p = runners("db", "list", "blocks", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "B6L" in p.stdout and "anagnostopoulos-block2" in p.stdout
    shown = json.loads(runners("db", "show", "run", "1", db=db, fmu_path=fmu_path).stdout)
    assert shown["summary"]["impacts_interface"] > 0 and shown["series"]["n_samples"] > 100
    p = runners("db", "show", "run", "7", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.startswith("error: no run '7'")


def _database_at_revision(tmp_path, revision: str):
    """(url, engine) of a new SQLite file migrated only up to `revision`: an old database."""
    from alembic import command

    from db.session import _alembic_config, make_engine

    url = f"sqlite:///{tmp_path / 'old.db'}"
    engine = make_engine(url)
    cfg = _alembic_config()
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, revision)
    return url, engine


def test_an_old_database_is_migrated_without_losing_rows(tmp_path):
    """A file at the first revision gets the newer columns and keeps its rows."""
    url, engine = _database_at_revision(tmp_path, "0001")
    with engine.begin() as conn:
        conn.execute(text("INSERT INTO scenes (name, n_blocks, parameters, created_at) "
                          "VALUES ('old', 1, '{}', '2026-01-01')"))
        conn.execute(text("INSERT INTO runs (scene_id, model, method, stop_time, code_version, status, created_at) "
                          "VALUES (1, 'one block', 'fmu', 1.0, 'x', 'ok', '2026-01-01')"))
    factory = open_database(url)
    with factory() as s:
        run = s.get(Run, 1)
        assert run.model == "one block" and run.point is None
    assert integrity_ok(factory.kw["bind"])


def test_catalogue_blocks_named_by_file_number_are_renamed_after_their_source(tmp_path):
    """Revision 0007: a block named by a source document's file number (the old catalogue name) becomes
    anagnostopoulos-blockN."""
    from db.schema import Block

    url, engine = _database_at_revision(tmp_path, "0006")
    with engine.begin() as conn:
        conn.execute(text("INSERT INTO blocks (name, half_width, half_height, mass, restitution_law, correction) "
                          "VALUES ('seed000-block2', 0.03, 0.0675, 2.95, 'housner', 1.233)"))
    with open_database(url)() as s:
        names = set(s.scalars(select(Block.name)))
    assert "anagnostopoulos-block2" in names and not any(n.startswith("seed") for n in names)
