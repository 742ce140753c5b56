"""The integrator's pairs have the orders their coefficients promise, on the linear oscillator (no model):
Dormand and Prince's 5(4) pair (the engine's on the ground and on a one-way support) and their 8(5,3) pair
(DOP853, on a two-way support): the end error falls as h^5 and h^8, the dense output's as h^5 (its quartic's
error is the step's) and h^7 (degree 7), the power form of the dense output equals it, and a DOP853 step whose
sums skip components that do not vary gives the others the same values to the bit (tests/c/integrator_order.c,
compiled from model/c with the system's gcc)."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_the_pairs_have_their_orders(tmp_path):
    exe = compile_white_box(tmp_path, "integrator_order.c")
    lines = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split("\n")
    dopri5, dop853 = ([float(x) for x in line.split()] for line in lines[:2])
    assert all(4.7 < p < 5.6 for p in dopri5[:2]), dopri5  # end error ~ h^5
    assert all(7.6 < p < 8.8 for p in dop853[:2]), dop853  # ~ h^8
    assert all(4.5 < p < 5.8 for p in dopri5[2:4]), dopri5  # the quartic dense output: the step's order
    assert all(6.5 < p < 8.8 for p in dop853[2:4]), dop853  # degree 7
    assert dopri5[4] < 1e-14 and dop853[4] < 1e-14  # dense_poly's power form equals dense_eval
    assert lines[2] == "1"  # the components that vary, alone: the same step to the bit
