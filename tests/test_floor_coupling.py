"""RockingBlock.fmu's side of a two-way co-simulation (docs/cosimulation.md#two-way-coupling): the input support.force
pushes the blocks' floor (a two-way support's, here a free platform of the floor's mass), with its first and second
derivatives, and contact.groundLoadSlope gives the blocks' load over a step as the line with its mean and first moment.
Checked against closed forms (blocks sticking on a free mass move with it: a = F / (floor + blocks)) and against
fine quadrature of the load; and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import Slave

FLOOR = 2000.0  # kg
BLOCK = {"block1.halfWidth": 0.5, "block1.halfHeight": 0.5, "block1.mass": 1000.0, "contact.model": 1,
         "contact.muGround": 0.9}  # squat, high friction: it sticks on the floor
PLATFORM = {"support.kind": 2, "support.coupling": 1, "platform.mass": FLOOR, "platform.stiffness": 0.0,
            "platform.damping": 0.0, "excitation.kind": 0}


def test_a_free_floor_pushed_by_support_force_moves_with_its_blocks_as_one_mass(fmu):
    """F(t) = F0 + F1 t + F2 t^2 / 2 given at each communication point by its value and its two derivatives: the floor
    and the block sticking on it accelerate as F / (3000 kg), and the floor's displacement and velocity are the
    integrals of that, to 1e-12 over 500 steps of 10 ms (the sticking pair moves as a polynomial: its steps once grew
    without bound there and overflowed); the block's load beyond moving with its floor, and its slope, stay 0."""
    F0, F1, F2, M, h = 600.0, 900.0, -700.0, FLOOR + 1000.0, 0.01
    s = Slave(fmu)
    s.start({**BLOCK, **PLATFORM})
    vr = s.vr["support.force"]
    rows, t = [], 0.0
    for k in range(500):
        t = k * h
        s.s.setReal([vr], [F0 + F1 * t + 0.5 * F2 * t * t])
        s.s.setRealInputDerivatives([vr, vr], [1, 2], [F1 + F2 * t, F2])
        s.s.doStep(t, h)
        rows.append(s.real("support.u", "support.v", "ground.ahTotal", "contact.groundLoad", "contact.groundLoadSlope",
                           "block1.slip"))
    s.close()
    rows, t = np.array(rows), (np.arange(500) + 1) * h
    u = (F0 * t ** 2 / 2 + F1 * t ** 3 / 6 + F2 * t ** 4 / 24) / M
    v = (F0 * t + F1 * t ** 2 / 2 + F2 * t ** 3 / 6) / M
    a = (F0 + F1 * t + F2 * t ** 2 / 2) / M
    assert np.abs(a).max() < 0.9 * 9.81  # (within the friction cone: the block sticks)
    np.testing.assert_allclose(rows[:, 0], u, rtol=1e-12, atol=1e-12 * np.abs(u).max())
    np.testing.assert_allclose(rows[:, 1], v, rtol=1e-12, atol=1e-12 * np.abs(v).max())
    np.testing.assert_allclose(rows[:, 2], a, rtol=1e-12, atol=1e-12 * np.abs(a).max())
    assert np.abs(rows[:, 3]).max() < 1e-9 * F0 and np.abs(rows[:, 4]).max() < 1e-6 * F0 / h
    assert np.all(rows[:, 5] == 0.0)


def test_support_force_acts_on_a_two_way_support_alone(fmu):
    """On the ground, or on a one-way support, support.force is refused in one logged line: at initialisation, set
    while running, and as a derivative; a third derivative, never."""
    s = Slave(fmu)
    s.s.setupExperiment(startTime=0.0)
    fmu.set_parameters(s.s, {**BLOCK, "support.force": 10.0})
    s.expect_error(lambda: s.s.enterInitializationMode(), "support.force = 10 N acts on a two-way support")
    s.close()
    s = Slave(fmu)
    s.start(BLOCK)
    vr = s.vr["support.force"]
    s.expect_error(lambda: s.s.setReal([vr], [5.0]), "'support.force' acts on a two-way support")
    s.expect_error(lambda: s.s.setRealInputDerivatives([vr], [1], [5.0]), "'support.force' acts on a two-way support")
    s.s.doStep(0.0, 0.01)  # and it runs on
    s.close()
    s = Slave(fmu)
    s.start({**BLOCK, **PLATFORM})
    s.expect_error(lambda: s.s.setRealInputDerivatives([vr], [3], [1.0]), "derivative of order 3")
    s.expect_error(lambda: s.s.setRealInputDerivatives([vr], [1], [float("inf")]), "not a finite number")
    s.s.setRealInputDerivatives([vr, vr], [1, 2], [1.0, 2.0])
    s.s.doStep(0.0, 0.01)
    s.close()


SWAY = {"block1.halfWidth": 0.3, "block1.halfHeight": 1.0, "block1.mass": 1000.0, "excitation.kind": 1,
        "excitation.amplitude": 4.0, "excitation.frequency": 2.0}  # a sine pulse that rocks it: impacts


def moments(fmu, params, H, n, stop):
    """Over each communication step of H: the FMU's (mean, slope), the line's from n substeps of a second instance (their
    means as a midpoint rule of the load and its first moment), and the line composed from the substeps' own means and
    slopes (each substep's first moment exact if the slope is)."""
    a, b = Slave(fmu), Slave(fmu)
    a.start(params)
    b.start(params)
    ours, fine, composed, t = [], [], [], 0.0
    for k in range(int(round(stop / H))):
        t = k * H
        a.s.doStep(t, H)
        ours.append(a.real("contact.groundLoad", "contact.groundLoadSlope"))
        m = m1 = c1 = 0.0
        for i in range(n):
            b.s.doStep(t + i * H / n, H / n)
            load, slope = b.real("contact.groundLoad", "contact.groundLoadSlope")
            d = H / n
            m += load * d
            m1 += load * d * ((i + 0.5) * d)
            c1 += load * d * ((i + 0.5) * d) + slope * d ** 3 / 12
        fine.append((m / H, 12 * (m1 - m * H / 2) / H ** 3))
        composed.append(12 * (c1 - m * H / 2) / H ** 3)
    impacts = a.s.getInteger([a.vr["impacts"]])[0]
    a.close()
    b.close()
    return np.array(ours), np.array(fine), np.array(composed), impacts


STACK = {"nBlocks": 2, "block2.halfWidth": 0.2, "block2.halfHeight": 0.5, "block2.mass": 300.0}


@pytest.mark.parametrize("model, extra", [(0, {}), (1, {}), (0, STACK), (1, STACK)],
                         ids=["rigid rocking", "rocking-sliding", "two blocks, rigid rocking", "two blocks, sliding"])
def test_the_load_slope_is_the_line_of_the_step_s_first_moment(fmu, model, extra):
    """contact.groundLoadSlope, from the momentum and the blocks' mass moment at the step's ends, against the first
    moment of the load by a midpoint rule over substeps: the difference falls as the substeps shrink (an impact's
    impulse lands anywhere in its substep), within 1 % of the largest slope over steps with impacts; composed from the
    substeps' own lines, it agrees to 1e-7."""
    params = {**SWAY, **extra, "contact.model": model, "contact.muGround": 0.9, "contact.muInterface": 0.9}
    diffs = []
    for n in (40, 160):
        ours, fine, composed, impacts = moments(fmu, params, 0.02, n, 1.2)
        assert impacts >= 2
        np.testing.assert_allclose(ours[:, 1], composed, rtol=0, atol=1e-7 * np.abs(ours[:, 1]).max())
        np.testing.assert_allclose(ours[:, 0], fine[:, 0], rtol=1e-9, atol=1e-9 * np.abs(fine[:, 0]).max())
        diffs.append(np.abs(ours[:, 1] - fine[:, 1]).max() / np.abs(ours[:, 1]).max())
    assert diffs[1] < diffs[0] / 2 and diffs[1] < 0.01, diffs
