"""A hostile pass on the contact engine (contact.model = 1, one block; docs/flight.md, "The contact
engine") through the built FMU: what broke, and stays fixed.

- A squat block sliding on one corner with mu just above 4/3 reached Painleve's singularity (the normal
  force its sliding needs grew without bound) and the run failed with "no acceptable step size"; the
  engine now takes the impulse that stops the slip there (a Painleve point, contact.painleve).
- A block released flat (theta0 = 0) with a rate omega0 lost that rate (it rested at once with its kinetic
  energy unaccounted) or flew: both corners were taken as touching with zero normal rate.
"""

from __future__ import annotations

import numpy as np
import pytest


OUT = ["block1.theta", "block1.omega", "block1.slip", "block1.slipRate", "block1.gap", "block1.mode", "energy",
       "block1.frictionLoss", "impactLoss", "groundWork", "contact.painleve", "overturned"]

# slides onto its left corner (slide-rock) and approaches Painleve's singularity at t = 0.2205943 s
JAM = {"contact.model": 1, "block1.halfWidth": 0.45, "block1.halfHeight": 0.5, "contact.muGround": 1.34,
       "excitation.kind": 1, "excitation.amplitude": 40.0, "excitation.verticalAmplitude": -9.0,
       "excitation.frequency": 2.0}


def balance(r):
    o = r.outputs
    keep = o["overturned"] < 0.5
    b = (o["energy"] + o["block1.frictionLoss"] + o["impactLoss"] - o["groundWork"])[keep]
    return np.abs(b - b[0]).max()


@pytest.mark.parametrize("step", [0.001, 0.1])
def test_sliding_into_painleve_singularity_stops_the_slip_instead_of_failing(fmu, step):
    r = fmu.run(JAM, 1.0, step, outputs=OUT)
    o = r.outputs
    (pain,) = [e for e in r.events if e.kind == "painleve"]
    assert pain.t == pytest.approx(0.2205943, abs=2e-6)
    assert pain.values.get("jam") == 1
    kinds = [e.kind for e in r.events if abs(e.t - pain.t) < 1e-12]
    assert "stick" in kinds  # the slip stops at the singularity: the block rocks on, sticking
    assert o["contact.painleve"][-1] == 1
    after = r.time > pain.t + 1e-9
    assert o["block1.mode"][after][0] == 2  # rocking on the corner it stopped on
    assert np.all(np.isfinite(np.column_stack(list(o.values()))))
    m_g_h = 1.0 * 9.81 * 0.5
    assert balance(r) < 1e-6 * m_g_h
    assert np.all(np.diff(o["impactLoss"]) >= -1e-12)
    assert np.all(o["block1.frictionLoss"] >= 0)


def test_painleve_singularity_results_do_not_depend_on_the_communication_step(fmu):
    fine = fmu.run(JAM, 1.0, 0.001, outputs=OUT)
    coarse = fmu.run(JAM, 1.0, 0.1, outputs=OUT)
    idx = np.searchsorted(fine.time, coarse.time - 1e-12)
    for k in ("block1.theta", "block1.slip", "energy"):
        np.testing.assert_allclose(fine.outputs[k][idx], coarse.outputs[k], atol=1e-9, rtol=1e-9)


@pytest.mark.parametrize("omega0", [-3.0, 2.0])
def test_released_flat_with_a_rate_rocks_like_the_rigid_model(fmu, omega0):
    """theta0 = 0, omega0 != 0 (too small to lift the centre off the pivot): it rocks on the corner the rate
    turns it about, as the rigid model does, until it slides or lands; energy accounted."""
    p = {"block1.halfWidth": 0.2, "block1.halfHeight": 0.5, "contact.muGround": 0.8, "excitation.kind": 0,
         "block1.theta0": 0.0, "block1.omega0": omega0}
    eng = fmu.run({**p, "contact.model": 1}, 0.1, 0.01, outputs=OUT)
    rigid = fmu.run({**p, "contact.model": 0}, 0.1, 0.01, outputs=["block1.theta"])
    assert eng.outputs["block1.mode"][1] == 2  # rocking, not at rest nor in flight
    np.testing.assert_allclose(eng.outputs["block1.theta"], rigid.outputs["block1.theta"], atol=1e-8)
    assert np.sign(eng.outputs["block1.theta"][-1]) == np.sign(omega0)
    assert balance(eng) < 1e-9


def test_released_flat_with_a_rate_that_pulls_the_pivot_flies(fmu):
    """w^2 h > g: the pivot would have to pull the centre round; the block leaves the ground at once."""
    p = {"contact.model": 1, "block1.halfWidth": 0.2, "block1.halfHeight": 0.5, "excitation.kind": 0,
         "block1.theta0": 0.0, "block1.omega0": 5.0}
    r = fmu.run(p, 0.05, 0.01, outputs=OUT)
    assert r.outputs["block1.mode"][1] == 6
    assert r.outputs["block1.gap"][-1] > 0


@pytest.mark.parametrize("params, words", [
    ({"contact.model": 1}, "contact.model"),
    # a two-way support lives in the FMU's own event loop too (its rigid rocking runs in the contact engine)
    ({"support.kind": 2, "support.coupling": 1, "excitation.kind": 0, "platform.mass": 500.0}, "support.coupling = 1"),
])
def test_model_exchange_refuses_the_contact_engine_in_one_line(fmu, params, words):
    messages = []
    m, _cb = fmu.instantiate(lambda status, cat, msg: messages.append((status, msg)), interface="ModelExchange")
    try:
        m.setupExperiment(startTime=0.0)
        fmu.set_parameters(m, params)
        with pytest.raises(Exception):
            m.enterInitializationMode()
            m.exitInitializationMode()
    finally:
        m.freeInstance()
    errors = [msg for status, msg in messages if status >= 3]
    assert errors and words in errors[-1] and "\n" not in errors[-1]


def test_a_restored_state_at_a_painleve_point_steps_on_identically(fmu):
    """FMU state taken on the step that meets the singularity (its event pending), restored, stepped on."""
    messages = []
    s, _cb = fmu.instantiate(lambda status, cat, msg: messages.append(msg))
    try:
        s.setupExperiment(startTime=0.0)
        fmu.set_parameters(s, JAM)
        s.enterInitializationMode()
        s.exitInitializationMode()
        vr = [fmu.variable(n).valueReference for n in ("block1.theta", "block1.slip", "energy")]
        t = 0.0
        while t < 0.22 - 1e-12:
            s.doStep(t, 0.01)
            t += 0.01
        blob = s.serializeFMUstate(s.getFMUstate())
        s.doStep(t, 0.01)
        s.doStep(t + 0.01, 0.1)
        first = s.getReal(vr)
        st = s.deSerializeFMUstate(blob)
        s.setFMUstate(st)
        s.freeFMUstate(st)
        s.doStep(t, 0.01)
        s.doStep(t + 0.01, 0.1)
        assert s.getReal(vr) == first
    finally:
        s.freeInstance()
