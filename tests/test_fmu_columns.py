"""The FMU's columns of N blocks (nBlocks = 2 to 8, contact.model = 1) against its own one block of the column's size.

A column of N equal squat drums (each b = 0.5 m, h = 0.25 m, 400 kg) whose interfaces cannot move (mu = 0.9 at
every contact; the column's uplift acceleration g b / (N h) is far below a drum's own, g b / h) rocks as one rigid
block of half height N h and mass N m: its contact engine must give every drum the one block's rotation, at every
output sample, to 1e-12 rad, through uplift, rocking and the column's plastic impacts on the ground. The pulses are
2 Hz sines a little above the column's uplift (1.1 and 1.2 times g b / (N h)). Larger pulses are real column
behaviour, not one block: at 1.35 g b / (N h) a column of 3 opens an interface before its first impact, at 1.5 one
of 4 to 8 does (each run's event log says `open`), and the column is no longer one block.

Two drums cannot rock at mu = 0.9 (b / (2 h) = 1 > mu: the column slides before it could tip): with nBlocks = 2 it
slides as one block of its size (the same slip, both rotations 0); with mu = 1.2 at both contacts it rocks as one.
"""
from __future__ import annotations

import numpy as np
import pytest

B, H, M = 0.5, 0.25, 400.0  # m, m, kg: one drum
G = 9.81  # m/s2, the FMU's default gravity
F = 2.0  # Hz
T_END, OUT = 2.0, 0.001  # s: the run and its output step (2,001 samples compared)
TOL = 1e-12  # rad


def column(n: int, amplitude: float, mu: float) -> dict:
    params = {"contact.model": 1, "nBlocks": n, "contact.muGround": mu, "contact.muInterface": mu,
              "block1.theta0": 0.0, "block2.theta0": 0.0, "excitation.kind": 1,
              "excitation.amplitude": amplitude, "excitation.frequency": F}
    for k in range(1, n + 1):
        params.update({f"block{k}.halfWidth": B, f"block{k}.halfHeight": H, f"block{k}.mass": M})
    return params


def one_block(n: int, amplitude: float, mu: float) -> dict:
    return {"contact.model": 1, "nBlocks": 1, "block1.halfWidth": B, "block1.halfHeight": n * H,
            "block1.mass": n * M, "contact.muGround": mu, "block1.theta0": 0.0, "excitation.kind": 1,
            "excitation.amplitude": amplitude, "excitation.frequency": F}


def run_both(fmu, n: int, factor: float, mu: float):
    amplitude = factor * G * B / (n * H)
    names = [f"block{k}.{q}" for k in range(1, n + 1) for q in ("theta", "slip")]
    col = fmu.run(column(n, amplitude, mu), T_END, OUT, names)
    one = fmu.run(one_block(n, amplitude, mu), T_END, OUT, ["block1.theta", "block1.slip"])
    assert len(col.time) == len(one.time) == round(T_END / OUT) + 1
    return col, one


@pytest.mark.parametrize("factor", [1.1, 1.2])
@pytest.mark.parametrize("n", range(3, 9))
def test_a_column_of_squat_drums_that_cannot_open_rocks_as_its_one_block(fmu, n, factor):
    """Measured: the largest |theta_k - theta| over the 2,001 samples and the N drums is at most 2.1e-16 rad (1.1)
    and 1.3e-16 rad (1.2); the column rocks to 2.3e-4 to 1.3e-2 rad with 10 to 38 impacts and never opens."""
    col, one = run_both(fmu, n, factor, 0.9)
    theta = one.outputs["block1.theta"]
    assert np.abs(theta).max() > 5e-5, "it rocks"
    assert len(one.event_times("impact")) >= 5
    kinds = {e.kind for e in col.events}
    assert "uplift" in kinds and "impact" in kinds
    assert not kinds & {"open", "slide", "flight", "fell-off", "overturn"}, kinds
    for k in range(1, n + 1):
        assert np.abs(col.outputs[f"block{k}.theta"] - theta).max() <= TOL, k
        # the drums never slide on each other, nor the column on the ground
        assert np.abs(col.outputs[f"block{k}.slip"]).max() == 0.0, k
        if k > 1:  # relative rotations exactly 0 (the same number)
            assert np.array_equal(col.outputs[f"block{k}.theta"], col.outputs["block1.theta"]), k


def test_two_drums_slide_as_their_one_block(fmu):
    """nBlocks = 2 at mu = 0.9: b / (2 h) = 1 > mu, so the pair slides (it cannot tip) as one block of its size: the
    same slip (1.1 cm) to 1e-10 m (measured 2.6e-12 m: the slide is integrated, in two systems of different size,
    not a closed form), no rotation, no slide between the drums."""
    col, one = run_both(fmu, 2, 1.1, 0.9)
    assert np.abs(one.outputs["block1.slip"]).max() > 0.01
    assert np.abs(col.outputs["block1.slip"] - one.outputs["block1.slip"]).max() <= 1e-10
    assert np.abs(col.outputs["block2.slip"]).max() == 0.0
    for k in (1, 2):
        assert np.abs(col.outputs[f"block{k}.theta"]).max() == 0.0


def test_two_drums_that_cannot_slide_rock_as_their_one_block(fmu):
    """nBlocks = 2 at mu = 1.2 (both contacts) under 1.1 g b / (2 h): they rock as one (2.0e-3 rad, 6 impacts), both
    rotations the one block's to 1e-12 rad (measured 9.8e-18)."""
    col, one = run_both(fmu, 2, 1.1, 1.2)
    theta = one.outputs["block1.theta"]
    assert np.abs(theta).max() > 1e-3 and len(one.event_times("impact")) >= 5
    assert not {e.kind for e in col.events} & {"open", "slide", "flight", "fell-off", "overturn"}
    for k in (1, 2):
        assert np.abs(col.outputs[f"block{k}.theta"] - theta).max() <= TOL
        assert np.abs(col.outputs[f"block{k}.slip"]).max() == 0.0
