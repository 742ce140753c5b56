"""The contact engine with columns of up to eight bodies (drums, each standing on the one below), built as a white-box
check with EN_MAX_BODIES = 8 (the FMU's build keeps 2 until its interface takes more blocks): the chain against the
constrained Newton-Euler system at 16,000 random states of columns of 1 to 8 bodies, sticking and sliding; N drums
rocking as one against the closed form of one block of their combined height, mass and inertia, and against the
engine's own one block; and the complementarity problem's choice for a column at rest just below and above its uplift
acceleration g b / (N h), and with one slippery interface. tests/c/engine_column.c."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box

COLUMN = ("-DEN_MAX_BODIES=8", "-DNMAX=96", "-DLCP_MAX=48")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_columns_of_up_to_eight_bodies(tmp_path):
    exe = compile_white_box(tmp_path, "engine_column.c", "lcp.c",
                            flags=("-O2", "-Wall", "-Wextra", "-Werror", *COLUMN))
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    dynamics, placement, impulses, sliding = float(out[0]), float(out[1]), float(out[2]), int(out[3])
    rotation, reactions, wrong, cases = float(out[4]), float(out[5]), int(out[6]), int(out[7])
    assert sliding > 5000, sliding  # the states with a sliding contact were drawn
    assert 0.0 < dynamics <= 1e-12, dynamics  # accelerations over g, forces over the weight carried
    assert placement <= 1e-14, placement  # gaps over R, rates over sqrt(g R)
    assert 0.0 < impulses <= 1e-12, impulses
    # the locked column is one block of its combined height, mass and inertia: theta'' over g / R, reactions over
    # the weight
    assert rotation <= 1e-14 and reactions <= 1e-14, (rotation, reactions)
    assert cases >= 15 and wrong == 0, (wrong, cases)


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("valgrind") is None,
                    reason="gcc or valgrind is not installed (Debian: valgrind)")
def test_columns_read_no_uninitialised_memory(tmp_path):
    """valgrind's memcheck over 800 states: every body's rows and columns of the larger systems set before use."""
    exe = compile_white_box(tmp_path, "engine_column.c", "lcp.c", flags=("-O1", "-g", *COLUMN))
    p = subprocess.run(["valgrind", "--error-exitcode=9", "--track-origins=yes", str(exe), "800"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_the_column_bench_measures_each_size():
    """runners bench --columns (runners.analysis.bench_column) for columns of 1 and 2 drums: a row per size, and with
    valgrind the instructions per call, more for two drums than for one (no timing is asserted)."""
    from runners.analysis.bench_column import run_column_bench

    rows = [line for line in run_column_bench(range(1, 3)).splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert [r.split("|")[1].strip() for r in rows] == ["1", "2"]
    cells = [[c.strip() for c in r.split("|")[1:-1]] for r in rows]
    assert [c[7] for c in cells] == ["4", "8"]  # the choice's unknowns: 4 per drum
    if shutil.which("valgrind"):
        motion, choice = [float(c[2].replace(",", "")) for c in cells], [float(c[5].replace(",", "")) for c in cells]
        assert 0 < motion[0] < motion[1] and 0 < choice[0] < choice[1]


def test_the_column_bench_simulates_the_fmus_columns(fmu_path):
    """runners bench --columns' FMU table for columns of 1 and 2 drums: a row per size with the pulse of 1.2 g b / (N h)
    and the simulation's impacts, and with valgrind more instructions for two drums than for one (no timing is
    asserted)."""
    from runners.analysis.bench_column import DRUM, run_fmu_column_bench

    rows = [line for line in run_fmu_column_bench(fmu_path, range(1, 3)).splitlines()
            if line.startswith("| ") and line[2].isdigit()]
    cells = [[c.strip() for c in r.split("|")[1:-1]] for r in rows]
    assert [c[0] for c in cells] == ["1", "2"]
    assert [float(c[1]) for c in cells] == pytest.approx([1.2 * 9.81 * DRUM["b"] / (n * DRUM["h"]) for n in (1, 2)],
                                                         rel=1e-2)
    assert all(int(c[2]) > 0 for c in cells)  # they rock and land
    if shutil.which("valgrind"):
        counts = [float(c[5].replace(",", "")) for c in cells]
        assert 0 < counts[0] < counts[1]
