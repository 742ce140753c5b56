"""The contact engine's chain (every body on a corner of its support: rest, rocking, sliding, slide-rocking,
a stack doing any of these) solves the motion in reduced coordinates, the rotations of the bodies that rock
and the slips of the contacts that slide (docs/flight.md, "A chain"). Checked here against the constrained
Newton-Euler system the engine solves where a body flies, at 20,000 random states of every such set of one
block and of a stack (half of them with contacts sliding either way): the same accelerations and forces to
rounding, and, where every contact sticks, the centres it places exactly on the constraints; and its
plastic impact onto each such set (the rates before in place of the forces) the same rates after and impulses;
where a contact slides, the chain as a step integrates it, from the slips and slip rates it holds, places the
same state and gives the same derivatives; and Painleve's margin of one block sliding on one corner, written out,
equals the general one and never falls below 1 - 3 mu / 4. A white-box check compiled from model/c with the
system's gcc."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_the_chain_equals_the_constrained_system_at_random_states(tmp_path):
    exe = compile_white_box(tmp_path, "engine_chain.c", "lcp.c")
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    dynamics, placement, sliding, impulses = float(out[0]), float(out[1]), int(out[2]), float(out[3])
    reduced, jam, jam_slack, slope = float(out[4]), float(out[5]), float(out[6]), float(out[7])
    assert sliding > 5000, sliding  # the states with a sliding contact were drawn
    assert dynamics <= 1e-12, dynamics   # accelerations over g, forces over the weight carried (or their size)
    assert placement <= 1e-14, placement  # gaps over R, rates over sqrt(g R)
    assert 0.0 < impulses <= 1e-12, impulses  # plastic impacts: rates over sqrt(g R), impulses over the momentum
    assert dynamics > 0.0 or placement > 0.0  # both computed (rounding differs between the two solvers)
    # a sliding chain from its reduced coordinates (rotations, slips and slip rates): the centres it places over R
    # and their velocities over sqrt(g R), its derivatives against the full state's
    assert 0.0 < reduced <= 1e-11, reduced
    # Painleve's margin on the ground written out, against the rows; and never below 1 - 3 mu / 4
    assert jam <= 1e-14, jam
    assert 0.0 <= jam_slack < 1e-2, jam_slack  # the bound holds, and is nearly reached (it is the least)
    # one body's slopes in the support's acceleration from one evaluation (two-way supports), against two evaluations
    assert 0.0 < slope <= 1e-12, slope


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("valgrind") is None,
                    reason="gcc or valgrind is not installed (Debian: valgrind)")
def test_the_chain_reads_no_uninitialised_memory(tmp_path):
    """valgrind's memcheck over 2,000 states: the reduced system sums every body's columns of every
    coordinate, so a column left unset would be read (it once was, and passed the comparison by luck)."""
    exe = compile_white_box(tmp_path, "engine_chain.c", "lcp.c", flags=("-O1", "-g"))
    p = subprocess.run(["valgrind", "--error-exitcode=9", "--track-origins=yes", str(exe), "2000"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
