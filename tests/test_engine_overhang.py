"""Overhang contacts in the contact engine (docs/columns.md, "Overhangs"), white-box with EN_MAX_BODIES = 8
(tests/c/engine_overhang.c): the chain with each closed end of a body on the one below in either pair (its corner on
the support's top, or the support's top corner on its base) against a constrained Newton-Euler system written in the
test from the geometry alone (rows and biases by Taylor arithmetic), at 8,000 random states of columns of 2 to 8
bodies, sticking and sliding; the chain's placement from its anchors; and the switch where the corners coincide
(flat sticking, flat sliding, tilted on the pin): the same state, accelerations and forces in either pair."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box

COLUMN = ("-DEN_MAX_BODIES=8", "-DNMAX=96", "-DLCP_MAX=48")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_overhang_pairs_against_newton_euler_and_the_switch(tmp_path):
    """Measured: dynamics 1.1e-11 (accelerations over g, forces over the weight carried), placement 2.7e-15 (over
    R), switch 9.5e-13; 7,599 of the 8,000 states hold an overhang."""
    exe = compile_white_box(tmp_path, "engine_overhang.c", "lcp.c",
                            flags=("-O2", "-Wall", "-Wextra", "-Werror", *COLUMN))
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    dynamics, placement, switch, overhangs = float(out[0]), float(out[1]), float(out[2]), int(out[3])
    assert overhangs > 7000, overhangs
    assert 0.0 < dynamics <= 1e-10, dynamics
    assert placement <= 1e-14, placement
    assert switch <= 1e-11, switch


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("valgrind") is None,
                    reason="gcc or valgrind is not installed (Debian: valgrind)")
def test_overhang_pairs_read_no_uninitialised_memory(tmp_path):
    exe = compile_white_box(tmp_path, "engine_overhang.c", "lcp.c", flags=("-O1", "-g", *COLUMN))
    p = subprocess.run(["valgrind", "--error-exitcode=9", "--track-origins=yes", str(exe), "400"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
