"""runners bench --against: the native benchmark of this FMU against another build, with
instruction counts where valgrind is installed."""

from __future__ import annotations

import shutil

import pytest

from conftest import run_cli
from runners.analysis.bench import run_native_against


def test_a_missing_build_to_compare_with_is_one_line(db_url, fmu_path, tmp_path):
    p = run_cli("bench", "--against", str(tmp_path / "nope.fmu"), db=db_url, fmu_path=fmu_path)
    assert p.returncode != 0
    assert p.stderr.strip().count("\n") == 0 and "nope.fmu" in p.stderr and "Traceback" not in p.stderr


@pytest.fixture
def same_build(fmu_path, tmp_path):
    """A copy of the FMU: another build of the same code (valgrind needed to count its instructions)."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed (Debian: valgrind)")
    copy = tmp_path / "same.fmu"
    shutil.copy(fmu_path, copy)
    return copy


@pytest.mark.slow
def test_the_same_build_costs_the_same_instructions(fmu_path, same_build):
    table = run_native_against(fmu_path, same_build, repeats=2, rounds=1, count_repeats=2)
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table.splitlines()
            if line.startswith("| ") and not line.startswith("| case")]
    assert len(rows) > 5
    assert any(r[0].startswith("two blocks, rocking-sliding") for r in rows)  # the stack's cases too
    for r in rows:
        assert float(r[1]) > 0 and float(r[2]) > 0
        assert float(r[6]) == pytest.approx(1.0, abs=1e-3), r  # instructions: the same code does the same work


def test_study_without_a_build_to_compare_with_is_one_line(db_url, fmu_path):
    p = run_cli("bench", "--study", db=db_url, fmu_path=fmu_path)
    assert p.returncode != 0 and "Traceback" not in p.stderr
    assert p.stderr.strip() == "error: --study is a part of --against FMU: give the other build", p.stderr


@pytest.mark.slow
def test_the_same_build_costs_the_same_on_the_marble_study(fmu_path, same_build):
    from runners.analysis.bench_records import run_study_against

    text = run_study_against(fmu_path, same_build, every=60)
    assert "(420 runs swept" in text and "(7 runs)" in text, text
    ratio = float(text.split("This build costs ")[1].split("x")[0])
    assert ratio == pytest.approx(1.0, abs=1e-3), text  # the same code does the same work
