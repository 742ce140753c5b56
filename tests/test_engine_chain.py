"""The contact engine's sticking chain (rest, rocking, a stack that rocks: every contact sticks) solves the
motion in the rotations of the bodies that rock (docs/flight.md, "A sticking chain"). Checked here against
the constrained Newton-Euler system the engine solves for every other contact set, at 20,000 random states
of every sticking set of one block and of a stack: the same accelerations and forces to rounding, and the
centres it places exactly on the constraints. A white-box check compiled from model/c with the system's gcc."""
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
C = ROOT / "model" / "c"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_the_chain_equals_the_constrained_system_at_random_states(tmp_path):
    exe = tmp_path / "engine_chain"
    subprocess.run(["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{C}", "-o", str(exe),
                    str(ROOT / "tests" / "c" / "engine_chain.c"), str(C / "lcp.c"), "-lm"], check=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    dynamics, placement = float(out[0]), float(out[1])
    assert dynamics <= 1e-12, dynamics   # accelerations over g, forces over the weight carried (or their size)
    assert placement <= 1e-14, placement  # gaps over R, rates over sqrt(g R)
    assert dynamics > 0.0 or placement > 0.0  # both computed (rounding differs between the two solvers)
