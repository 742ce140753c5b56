"""Record import and record names as a new user meets them (issue 36, item 6): a CSV record whose
header lacks several things is told all of them in one line, with a header that works; a mistyped
suite or record name is told the closest stored ones. Real files, real SQLite databases, the real
FEMA P695 records."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import runners
from conftest import run_cli
from test_record_sweeps import db, template  # noqa: F401  (fixtures: a database with the 28 near-field records)

ROOT = Path(__file__).resolve().parent.parent
DATA = "0,0.01\n0.01,0.02\n0.02,-0.01\n0.03,0\n"


def one_line_error(p) -> str:
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("error:"), p.stderr
    assert "Traceback" not in p.stderr
    return p.stderr.strip()


def test_a_csv_header_lacking_everything_is_told_everything_in_one_line_with_a_header_that_works(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'r.db'}"
    bare = tmp_path / "ground.csv"
    bare.write_text("time,accel\n" + DATA)  # a column name the importer does not know, no units, no sign
    err = one_line_error(run_cli("records", "import", str(bare), db=url, fmu_path=fmu_path))
    for lacking in ("columns after 'time' must be distinct names among acceleration", "(got accel)",
                    "declare the units", "time and acceleration", "declare the sign convention", "+x, -x"):
        assert lacking in err, err
    # the header it proposes, written as it says, is imported
    example = re.search(r"A header that works: (.*) \(", err).group(1)
    lines = re.findall(r"'([^']*)'", example)
    assert lines[-1] == "time,acceleration" and any(x.startswith("# units:") for x in lines), lines
    fixed = tmp_path / "fixed.csv"
    fixed.write_text("\n".join(lines) + "\n" + DATA)
    p = run_cli("records", "import", str(fixed), db=url, fmu_path=fmu_path)
    assert p.returncode == 0 and "record 1 fixed: 4 samples" in p.stdout, p.stderr


def test_a_csv_given_some_of_its_header_is_told_the_rest_at_once(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'r.db'}"
    path = tmp_path / "ground.csv"
    path.write_text("time,acceleration\n" + DATA)
    err = one_line_error(run_cli("records", "import", str(path), "--units", "acceleration=g", db=url,
                                 fmu_path=fmu_path))
    assert "no unit declared for time" in err and "declare the sign convention" in err, err
    p = run_cli("records", "import", str(path), "--units", "time=s, acceleration=g", "--sign", "+x", db=url,
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr


def test_a_mistyped_suite_is_told_the_closest_suites(db, fmu_path, tmp_path):  # noqa: F811
    scene = ROOT / "examples" / "statue.toml"
    err = one_line_error(run_cli("sweep", str(scene), "--records", "fema-p695/nearfield", "--im", "pga=0.1:1:3",
                                 db=db, fmu_path=fmu_path))
    assert "did you mean the suite fema-p695/nearfield_pulse?" in err, err
    with pytest.raises(runners.ArgumentError, match="did you mean the suite fema-p695/nearfield_pulse"):
        runners.sweep(scene, records="fema-p695/nearfield_puls", im="pga=0.1:1:3", db=db, fmu=fmu_path)
    err = one_line_error(run_cli("sweep", str(scene), "--records", "fema-p695/farfield", "--im", "pga=0.1:1:3",
                                 db=db, fmu_path=fmu_path))
    assert "the FEMA P695 set farfield is not stored; runners records import fema-p695 farfield" in err, err


def test_a_mistyped_record_is_told_the_closest_record(db, fmu_path):  # noqa: F811
    scene = str(ROOT / "examples" / "statue.toml")
    err = one_line_error(run_cli("simulate", scene, "--record", "fema-p695/nearfield_puls/1a", "--no-store",
                                 db=db, fmu_path=fmu_path))
    assert "did you mean fema-p695/nearfield_pulse/1a?" in err, err
    err = one_line_error(run_cli("sweep", scene, "--records", "fema-p695/nearfield_pulse/1a,fema-p695/nearfeld_pulse/2b",
                                 "--im", "pga=0.1:1:3", db=db, fmu_path=fmu_path))
    assert "no record 'fema-p695/nearfeld_pulse/2b'" in err and "did you mean fema-p695/nearfield_pulse/2b?" in err
    err = one_line_error(run_cli("records", "show", "zzzz", db=db, fmu_path=fmu_path))
    assert "did you mean" not in err  # nothing close: no guess
