"""Measured files and calibration that went wrong: every case through the real command line
on a real SQLite file, each refused with one line that says what is wrong (or, where the
input is fine after all, accepted), and nothing stored by a refusal."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select

from conftest import run_cli
from db import series
from db.catalogue import CATALOGUE
from db.schema import Block, Measurement, Record
from db.session import open_database

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE_PEAKS = ROOT / "examples" / "measured_peaks_block2.csv"
HEADER = "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\n"


@pytest.fixture
def db(tmp_path, fmu_path) -> str:
    url = f"sqlite:///{tmp_path / 'errors.db'}"
    p = run_cli("db", "init", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return url


def one_line_error(p: subprocess.CompletedProcess) -> str:
    """The error a refusal printed, checked to be one line, exit status 2, no traceback."""
    assert p.returncode == 2 and p.stderr.startswith("error: ") and p.stderr.count("\n") == 1, p.stderr
    return p.stderr


def count(db: str, table) -> int:
    with open_database(db)() as session:
        return session.scalar(select(func.count()).select_from(table))


def import_ok(path: Path, db: str, fmu_path, *args: str) -> None:
    p = run_cli("import-measured", str(path), *args, db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr


# A. calibration judges its fit before storing it


def test_calibrating_growing_peaks_is_refused_as_a_poor_fit_and_stores_nothing(tmp_path, fmu_path, db):
    """Peaks that grow (5, 6, 7, 8, 9 deg) fit eta = 1 at its bound with chi2/dof 25: refused,
    saying why, and no block is stored."""
    csv = tmp_path / "growing.csv"
    csv.write_text(HEADER.replace("B3L", "anagnostopoulos-block2") + "time,theta\n0,5\n0.4,6\n0.8,7\n1.2,8\n1.6,9\n")
    import_ok(csv, db, fmu_path)
    blocks = count(db, Block)
    err = one_line_error(run_cli("calibrate", "1", "--law", "constant", db=db, fmu_path=fmu_path))
    assert "the fit is poor" in err and "chi2/dof" in err and "> 5" in err, err
    assert "the peaks grow" in err and "not stored" in err and "--accept-poor-fit" in err, err
    assert count(db, Block) == blocks


def test_calibrating_a_peak_table_in_seconds_declared_as_ms_is_refused_naming_the_time_units(tmp_path, fmu_path, db):
    """The example peak table imported with time=ms: today 'correction factor 0.8855 [-1.25, 3.02]';
    the interval leaves the physical range and the output points at the time units."""
    import_ok(EXAMPLE_PEAKS, db, fmu_path, "--units", "time=ms, theta=deg")
    blocks = count(db, Block)
    err = one_line_error(run_cli("calibrate", "1", "--law", "correction", db=db, fmu_path=fmu_path))
    assert "the fit is poor" in err and "physical range" in err, err
    assert "time units" in err and "declared ms" in err, err
    assert count(db, Block) == blocks


def test_accept_poor_fit_reports_and_stores_the_fit_with_its_problems(tmp_path, fmu_path, db):
    """--accept-poor-fit: exit 0, the problems in the JSON output and in the stored block's source."""
    csv = tmp_path / "growing.csv"
    csv.write_text(HEADER.replace("B3L", "anagnostopoulos-block2") + "time,theta\n0,5\n0.4,6\n0.8,7\n1.2,8\n1.6,9\n")
    import_ok(csv, db, fmu_path)
    p = run_cli("calibrate", "1", "--law", "constant", "--accept-poor-fit", "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    fit = json.loads(p.stdout)
    assert any("chi2/dof" in x for x in fit["poor_fit"]), fit
    with open_database(db)() as session:
        assert "accepted with --accept-poor-fit" in session.get(Block, fit["block_id"]).source


def test_a_good_fit_reports_no_problems(tmp_path, fmu_path, db):
    """The documentation's example still calibrates, and its JSON says the fit passed the checks."""
    import_ok(EXAMPLE_PEAKS, db, fmu_path)
    p = run_cli("calibrate", "1", "--law", "correction", "--no-store", "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    fit = json.loads(p.stdout)
    assert fit["poor_fit"] == [] and fit["low"] <= 1.233 <= fit["high"], fit


# B. export-measured --max-peaks; a Latin-1 .AT2


@pytest.mark.parametrize("value", ["-3", "0"])
def test_export_measured_refuses_a_max_peaks_below_one(tmp_path, fmu_path, db, value):
    """--max-peaks -3 used to drop the last 3 peaks without a word."""
    b = next(c for c in CATALOGUE if c["name"] == "anagnostopoulos-block2")
    scene = tmp_path / "decay.toml"
    scene.write_text(f"name = 'decay'\n[block]\nhalf_width = {b['half_width']}\nhalf_height = {b['half_height']}\n"
                     f"mass = {b['mass']}\ntheta0 = 0.3\n[simulation]\nstop_time = 3.0\nstep = 0.01\n")
    assert run_cli("simulate", str(scene), db=db, fmu_path=fmu_path).returncode == 0
    out = tmp_path / "peaks.csv"
    err = one_line_error(run_cli("export-measured", "1", "--out", str(out), "--max-peaks", value, db=db,
                                 fmu_path=fmu_path))
    assert "--max-peaks must be at least 1" in err, err
    assert not out.exists()


LATIN1_AT2 = ("PEER NGA STRONG MOTION DATABASE RECORD\n"
              "LOMA PRIETA 10/18/89, ESTACIÓN CAÑADA, Musée 090\n"
              "ACCELERATION TIME SERIES IN UNITS OF G\n"
              "NPTS=    6, DT=   .0100 SEC\n"
              "  0.01000  0.02000 -0.01000  0.00500\n  0.00000  0.00000\n").encode("latin-1")


def test_a_latin1_at2_keeps_its_station_name(tmp_path, fmu_path, db):
    """An .AT2 written in Latin-1: 'Ó', 'Ñ' and 'é' survive (records import and import-measured)."""
    at2 = tmp_path / "loma.AT2"
    at2.write_bytes(LATIN1_AT2)
    p = run_cli("records", "import", str(at2), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    import_ok(at2, db, fmu_path)
    station = "LOMA PRIETA 10/18/89, ESTACIÓN CAÑADA, Musée 090"
    with open_database(db)() as session:
        assert session.scalar(select(Record.source).where(Record.name == "loma")) == f"PEER NGA record: {station}"
        assert session.get(Measurement, 1).name == station


# C. messages that say what is wrong


def test_calibrating_a_decay_released_at_zero_says_the_release_is_missing(tmp_path, fmu_path, db):
    """A peak table whose first row is 0 deg: scipy's 'Initial guess is outside of provided bounds'
    said nothing about the data."""
    csv = tmp_path / "zero.csv"
    csv.write_text(HEADER.replace("B3L", "anagnostopoulos-block2")
                   + "time,theta\n0,0\n0.37,-15\n0.69,11\n0.89,-9.7\n1.05,7.1\n")
    import_ok(csv, db, fmu_path)
    err = one_line_error(run_cli("calibrate", "1", "--law", "constant", db=db, fmu_path=fmu_path))
    assert "the release (the first row" in err and "theta = 0 rad" in err, err
    assert "bounds" not in err, err


def test_a_latin1_csv_header_is_read_as_latin1(tmp_path, fmu_path, db):
    """A CSV saved in Latin-1 (a Spanish lab's name) is imported with its accents."""
    csv = tmp_path / "ensayo.csv"
    csv.write_bytes(("# name: Ensayo niño café\n# source: Laboratorio de Ingeniería Sísmica\n" + HEADER
                     + "time,theta\n0,10\n0.3,-7\n0.55,5\n").encode("latin-1"))
    import_ok(csv, db, fmu_path)
    with open_database(db)() as session:
        m = session.get(Measurement, 1)
        assert (m.name, m.source) == ("Ensayo niño café", "Laboratorio de Ingeniería Sísmica")


def test_a_latin1_byte_in_a_data_row_names_the_file_and_line(tmp_path, fmu_path, db):
    """'-7é' in a data row: the file and line, not "'utf-8' codec can't decode"."""
    csv = tmp_path / "typo.csv"
    csv.write_bytes((HEADER + "time,theta\n0,10\n0.3,-7é\n0.55,5\n").encode("latin-1"))
    err = one_line_error(run_cli("import-measured", str(csv), db=db, fmu_path=fmu_path))
    assert f"{csv}, line 7: not a number" in err and "codec" not in err, err
    assert count(db, Measurement) == 0


@pytest.mark.parametrize("cell", ["nan", "NaN", " -nan"])
def test_a_nan_measured_peak_is_refused_naming_the_file_and_line(tmp_path, fmu_path, db, cell):
    """A peak written as NaN is not a measured value (an empty cell is the way to leave one out)."""
    csv = tmp_path / "nan.csv"
    csv.write_text(HEADER + f"time,theta\n0,10\n0.3,{cell}\n0.55,5\n")
    err = one_line_error(run_cli("import-measured", str(csv), db=db, fmu_path=fmu_path))
    assert f"{csv}, line 7: values must be finite numbers, not {cell.strip()!r}" in err, err
    assert count(db, Measurement) == 0


def test_a_binary_file_is_refused_naming_the_file_and_line(tmp_path, fmu_path, db):
    """A PNG given as a measured file: refused as not text, with the file and the line."""
    png = tmp_path / "plot.csv"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x01\x00" + bytes(range(256)) * 4)
    err = one_line_error(run_cli("import-measured", str(png), db=db, fmu_path=fmu_path))
    assert f"{png}, line 2: byte 0x1a" in err and "not text" in err and "codec" not in err, err
    assert count(db, Measurement) == 0


def test_a_utf16_csv_is_refused_naming_the_file_and_the_encoding(tmp_path, fmu_path, db):
    """Excel's 'Unicode text' is UTF-16: say so, rather than a codec's message."""
    csv = tmp_path / "excel.csv"
    csv.write_bytes((HEADER + "time,theta\n0,10\n0.3,-7\n0.55,5\n").encode("utf-16"))
    err = one_line_error(run_cli("import-measured", str(csv), db=db, fmu_path=fmu_path))
    assert f"{csv}, line 1: the file is UTF-16 text" in err, err


def test_a_csv_starting_with_a_utf8_byte_order_mark_is_read(tmp_path, fmu_path, db):
    """A byte-order mark before '# kind:' (Excel's 'CSV UTF-8') is skipped."""
    csv = tmp_path / "bom.csv"
    csv.write_bytes(b"\xef\xbb\xbf" + (HEADER + "time,theta\n0,10\n0.3,-7\n0.55,5\n").encode())
    import_ok(csv, db, fmu_path)
    with open_database(db)() as session:
        m = session.get(Measurement, 1)
        assert (m.kind, m.n_samples, m.block1.name) == ("peaks", 3, "B3L")


def test_a_directory_given_as_the_measured_file_is_called_a_directory(tmp_path, fmu_path, db):
    folder = tmp_path / "takes.csv"
    folder.mkdir()
    err = one_line_error(run_cli("import-measured", str(folder), db=db, fmu_path=fmu_path))
    assert f"{folder} is a directory" in err and "does not exist" not in err, err


def test_an_overlong_csv_field_is_one_line_naming_the_line(tmp_path, fmu_path, db):
    """A field beyond the csv module's limit (131072 characters) raised csv.Error: a traceback."""
    csv = tmp_path / "long.csv"
    csv.write_text(HEADER + "time,theta\n0,10\n0.3," + "7" * 200_000 + "\n")
    err = one_line_error(run_cli("import-measured", str(csv), db=db, fmu_path=fmu_path))
    assert f"{csv}, line 7: not a CSV row" in err, err


# D. a long file is streamed

MEASURE = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:]); "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(p.returncode)")


def import_peak_memory(csv: Path, db: str, fmu_path) -> tuple[subprocess.CompletedProcess, int]:
    """(result, peak resident memory in kB) of `runners import-measured CSV` in its own process."""
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    p = subprocess.run([sys.executable, "-c", MEASURE, sys.executable, "-m", "runners.cli", "import-measured",
                        str(csv)], capture_output=True, text=True, env=env, cwd=ROOT)
    return p, int(p.stdout.splitlines()[-1])


def test_a_two_million_row_csv_is_imported_intact_in_bounded_memory(tmp_path, fmu_path, db):
    """2 million rows (41 MB of text, 32 MB as float64): the import's peak memory above a 3-row
    import's must stay under 300 MB. Reading the rows into Python lists took 750 MB more (3.8 GB
    for 10 million rows); streaming into float64 arrays takes about 130 MB (the arrays and
    the packing of the stored series). Every value is stored exactly."""
    n = 2_000_000
    big = tmp_path / "long.csv"
    with big.open("w") as f:
        f.write("# kind: rotation\n# units: time=s, theta=rad\n# sign: clockwise\n# block: B3L\ntime,theta\n")
        for start in range(0, n, 200_000):
            f.write("".join(f"{i / 1000:.3f},{((7 * i) % 2000 - 1000) / 1e4:.4f}\n"
                            for i in range(start, start + 200_000)))
    small = tmp_path / "short.csv"
    small.write_text("# kind: rotation\n# units: time=s, theta=rad\n# sign: clockwise\n# block: B3L\n"
                     "time,theta\n0,0.01\n0.001,0.02\n0.002,0.03\n")
    p, base = import_peak_memory(small, db, fmu_path)
    assert p.returncode == 0, p.stderr
    p, peak = import_peak_memory(big, db, fmu_path)
    assert p.returncode == 0, p.stderr
    assert f"{n} rows (0 to {(n - 1) / 1000:g} s)" in p.stdout, p.stdout
    assert peak - base < 300 * 1024, f"the import took {(peak - base) / 1024:.0f} MB above a 3-row import's"
    i = np.arange(n)
    with open_database(db)() as session:
        m = session.get(Measurement, 2)
        assert (m.kind, m.n_samples, m.names) == ("rotation", n, ["block1.theta"])
        t, cols = series.unpack(m.names, m.n_samples, m.data)
    np.testing.assert_array_equal(t, i / 1000)
    np.testing.assert_array_equal(cols["block1.theta"], ((7 * i) % 2000 - 1000) / 1e4)
    assert (t[0], t[-1], cols["block1.theta"][0], cols["block1.theta"][-1]) == (0.0, 1999.999, -0.1, 0.0993)


READ_RECORD = """
import sys
from runners.engine.record_files import read_record_file

def status(key):  # kB, from /proc/self/status
    return int(next(line for line in open("/proc/self/status") if line.startswith(key)).split()[1])

before = status("VmRSS")
t, ah, av = read_record_file(sys.argv[1])
print(status("VmHWM") - before, len(t), av is None)  # the peak while reading, above the memory before
"""


def test_a_half_million_sample_record_file_is_read_in_bounded_memory(tmp_path):
    """Our record text format (runners records import FILE) is streamed too: 500,000 samples are
    8 MB of float64; the file's bytes, its lines and a Python list per sample took 115 MB more."""
    n = 500_000
    path = tmp_path / "long.txt"
    path.write_text("# a long record\n" + "".join(f"{i / 1000:.3f} {((7 * i) % 2000 - 1000) / 1e4:.4f}\n"
                                                    for i in range(n)))
    p = subprocess.run([sys.executable, "-c", READ_RECORD, str(path)], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    grown, samples, no_vertical = p.stdout.split()
    assert (int(samples), no_vertical) == (n, "True")
    assert int(grown) < 50 * 1024, f"reading took {int(grown) / 1024:.0f} MB"
