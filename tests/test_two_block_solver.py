"""The FMU's two-block model against the independent event-driven reference
(model/two_block_solver.py: solve_ivp on the Jacobian-form equations): the same
sequence of events, at the same times."""

from __future__ import annotations

import math

import pytest

from model import two_blocks as tb
from model.two_block_solver import StackScene, solve_stack

TALL = tb.Stack(0.1, 0.3, 10.0, 0.1, 0.2, 5.0)
SEED = tb.Stack(0.0145, 0.060, 1.3, 0.030, 0.050, 2.3)
SLENDER_TOP = tb.Stack(0.2, 0.2, 20.0, 0.05, 0.25, 3.0)


def fmu_params(st: tb.Stack, **extra) -> dict:
    return {"nBlocks": 2, "block1.halfWidth": st.b1, "block1.halfHeight": st.h1, "block1.mass": st.m1,
            "block2.halfWidth": st.b2, "block2.halfHeight": st.h2, "block2.mass": st.m2,
            "solver.relTol": 1e-12, "solver.absTol": 1e-14, **extra}


def harmonic(frequency: float, displacement: float):
    """Table displacement D sin(2 pi f t): a_h = -D (2 pi f)^2 sin(2 pi f t), as the FMU's kind 3."""
    w = 2 * math.pi * frequency
    return lambda t: (-displacement * w * w * math.sin(w * t), 0.0)


def compare(fmu, st, scene_kw, fmu_extra, t_end, n_events, tol):
    ref = solve_stack(StackScene(st, **scene_kw), t_end, rtol=1e-12, atol=1e-14)
    r = fmu.run(fmu_params(st, **fmu_extra), t_end, 0.01, outputs=["impacts"])
    ours = [(e.kind, e.labels.get("contact", ""), e.t) for e in r.events if e.kind not in ("peak", "slide", "lift")]
    theirs = [(e.kind, e.contact, e.t) for e in ref.events]
    assert len(theirs) >= n_events and len(ours) >= n_events, (len(ours), len(theirs))
    for a, b in zip(ours[:n_events], theirs[:n_events]):
        assert a[:2] == b[:2], (a, b)
        assert abs(a[2] - b[2]) < tol, (a, b)
    return ref, r


@pytest.mark.parametrize("theta0", [(0.05, -0.08), (0.03, 0.09)], ids=["opposite", "same"])
def test_free_stack_event_sequences_agree(fmu, theta0):
    ref, r = compare(fmu, TALL, {"theta0": theta0}, {"block1.theta0": theta0[0], "block2.theta0": theta0[1]},
                     3.0, 20, 1e-9)
    assert len(ref.impacts()) == int(r.outputs["impacts"][-1])


def test_forced_stack_event_sequences_agree(fmu):
    """A chaotic forced stack: locking, opening at an impact, chatter, for 3 s."""
    compare(fmu, TALL, {"theta0": (0.05, -0.08), "ground": harmonic(2.0, 0.04)},
            {"block1.theta0": 0.05, "block2.theta0": -0.08, "excitation.kind": 3, "excitation.frequency": 2.0,
             "excitation.displacement": 0.04, "excitation.cycles": 0}, 3.0, 24, 1e-8)


def test_seed_stack_with_constant_restitution_agrees(fmu):
    compare(fmu, SEED, {"law": "constant", "ground": harmonic(7.0, 0.003)},
            {"restitution.law": 2, "excitation.kind": 3, "excitation.frequency": 7.0,
             "excitation.displacement": 0.003, "excitation.cycles": 0}, 3.0, 30, 1e-9)


def test_upper_block_alone_from_rest_agrees(fmu):
    a = 1.3 * 9.81 * 0.2
    w = 2 * math.pi * 4.0
    ground = lambda t: ((a * math.sin(w * t)) if t < 0.25 else 0.0, 0.0)  # noqa: E731
    ref, r = compare(fmu, SLENDER_TOP, {"ground": ground, "breaks": (0.25,)},
                     {"excitation.kind": 1, "excitation.frequency": 4.0, "excitation.amplitude": a}, 2.0, 12, 1e-9)
    assert ref.events[0].kind == "uplift" and ref.events[0].pattern == "upper"
