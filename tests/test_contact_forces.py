"""The FMU's contact reactions (contact.groundT/N, contact.interfaceT/N) against the
independent reference in model/contact.py: for one block its closed form, which
eliminates the angular acceleration with the equation of motion; for two blocks
Newton-Euler on each block with the accelerations the FMU reports. The reference's
moment residuals then also check the FMU's two-block accelerations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import Slave
from model.contact import one_block_reactions, stack_reactions

G = 9.81
ONE = {"block1.halfWidth": 0.15, "block1.halfHeight": 0.6, "block1.mass": 40.0}
TWO = {"nBlocks": 2, "block1.halfWidth": 0.2, "block1.halfHeight": 0.4, "block1.mass": 30.0,
       "block2.halfWidth": 0.12, "block2.halfHeight": 0.3, "block2.mass": 12.0, "restitution.law": 2}
OUT1 = ["block1.theta", "block1.omega", "ground.ahTotal", "ground.avTotal", "contact.groundT", "contact.groundN"]
OUT2 = OUT1[:2] + ["block1.alpha_dd", "block2.theta", "block2.omega", "block2.alpha_dd", "ground.ahTotal",
                   "ground.avTotal", "contact.groundT", "contact.groundN", "contact.interfaceT",
                   "contact.interfaceN", "pattern"]
REST, OVERTURNED, UPPER, LOCKED, BOTH = 1, 2, 3, 4, 5


def _at_start(fmu, params: dict, inputs: dict, names: list[str]) -> dict[str, float]:
    """Outputs right after initialisation with `params` and the inputs ground.ah, ground.av."""
    s = Slave(fmu)
    try:
        s.start({**params, **inputs})
        return dict(zip(names, fmu._getter(s.s, names)()))
    finally:
        s.close()


def _close(got: float, want: float, scale: float) -> bool:
    return abs(got - want) <= 1e-10 * scale


def test_one_block_reactions_at_random_states_are_the_closed_form(fmu):
    rng = np.random.default_rng(18)
    b, h, m = ONE["block1.halfWidth"], ONE["block1.halfHeight"], ONE["block1.mass"]
    alpha = math.atan2(b, h)
    for _ in range(60):
        theta = rng.uniform(0.02, 1.5) * rng.choice([-1, 1])
        params = {**ONE, "block1.theta0": theta, "block1.omega0": rng.uniform(-3, 3)}
        inputs = {"ground.ah": rng.uniform(-8, 8), "ground.av": rng.uniform(-5, 5)}
        o = _at_start(fmu, params, inputs, OUT1)
        T, N = one_block_reactions(o["block1.theta"], o["block1.omega"], o["ground.ahTotal"],
                                   o["ground.avTotal"], b, h, m, G)
        assert abs(theta) > 0 and alpha > 0
        assert _close(o["contact.groundT"], T, m * G) and _close(o["contact.groundN"], N, m * G), (params, inputs)


@pytest.mark.parametrize("scene", [
    {"block1.theta0": 0.12},  # free rocking to rest
    {"excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 1.5,
     "excitation.verticalAmplitude": 3.0},  # a pulse with a vertical component: rest, uplift, rocking
    {"excitation.kind": 3, "excitation.displacement": 0.02, "excitation.frequency": 2.0, "excitation.cycles": 3},
], ids=["free", "pulse", "harmonic"])
def test_one_block_reactions_along_a_run(fmu, scene):
    """At every output point: the closed form while the block rocks, m (a_h, g + a_v) at rest."""
    b, h, m = ONE["block1.halfWidth"], ONE["block1.halfHeight"], ONE["block1.mass"]
    r = fmu.run({**ONE, **scene}, 4.0, 0.01, outputs=OUT1 + ["atRest", "overturned"], events=False)
    o = r.outputs
    rocking = 0
    for k in range(len(r.time)):
        ah, av = o["ground.ahTotal"][k], o["ground.avTotal"][k]
        if o["atRest"][k]:
            T, N = m * ah, m * (G + av)
        elif not o["overturned"][k]:
            T, N = one_block_reactions(o["block1.theta"][k], o["block1.omega"][k], ah, av, b, h, m, G)
            rocking += 1
        else:
            continue
        assert _close(o["contact.groundT"][k], T, m * G) and _close(o["contact.groundN"][k], N, m * G), r.time[k]
    assert rocking > 50


def _check_stack(o: dict[str, float]) -> str:
    p = TWO
    b1, h1, m1 = p["block1.halfWidth"], p["block1.halfHeight"], p["block1.mass"]
    b2, h2, m2 = p["block2.halfWidth"], p["block2.halfHeight"], p["block2.mass"]
    th1, th2 = o["block1.theta"], o["block2.theta"]
    pattern = int(o["pattern"])
    if pattern == OVERTURNED:
        return pattern
    s1 = 1.0 if th1 >= 0 else -1.0
    s2 = 1.0 if th2 - th1 >= 0 else -1.0  # forces do not depend on s2 while the pair is locked
    ref = stack_reactions(th1, o["block1.omega"], o["block1.alpha_dd"], th2, o["block2.omega"],
                          o["block2.alpha_dd"], s1, s2, o["ground.ahTotal"], o["ground.avTotal"],
                          b1, h1, m1, b2, h2, m2, G)
    W = (m1 + m2) * G
    for out, key in (("contact.groundT", "ground_T"), ("contact.groundN", "ground_N"),
                     ("contact.interfaceT", "interface_T"), ("contact.interfaceN", "interface_N")):
        assert _close(o[out], ref[key], W), (out, o[out], ref[key], pattern)
    if pattern == BOTH:  # both contacts are points: the FMU's accelerations balance the moments
        L = max(b1, h1)
        assert abs(ref["residual1"]) <= 1e-10 * W * L and abs(ref["residual2"]) <= 1e-10 * W * L, ref
    return pattern


def test_stack_reactions_at_random_states_are_newton_euler_on_each_block(fmu):
    rng = np.random.default_rng(180)
    patterns = set()
    for _ in range(60):
        th1 = rng.uniform(0.01, 0.4) * rng.choice([-1, 1])
        params = {**TWO, "block1.theta0": th1, "block2.theta0": th1 + rng.uniform(-0.3, 0.3),
                  "block1.omega0": rng.uniform(-1, 1), "block2.omega0": rng.uniform(-2, 2)}
        inputs = {"ground.ah": rng.uniform(-6, 6), "ground.av": rng.uniform(-4, 4)}
        patterns.add(_check_stack(_at_start(fmu, params, inputs, OUT2)))
    assert BOTH in patterns


def test_stack_reactions_along_a_run_in_every_pattern(fmu):
    scene = {**TWO, "excitation.kind": 3, "excitation.displacement": 0.03, "excitation.frequency": 2.5,
             "excitation.cycles": 4}
    r = fmu.run(scene, 4.0, 0.005, outputs=OUT2, events=False)
    patterns = {_check_stack({n: r.outputs[n][k] for n in OUT2}) for k in range(len(r.time))}
    assert {REST, BOTH} <= patterns and patterns & {UPPER, LOCKED}, patterns
