"""Input derivatives (Co-Simulation, fmi2SetRealInputDerivatives; docs/model.md): an importer that sets
ground.ah's or ground.av's first derivative at a communication point drives the blocks with the input linear over
the step (ground.ah's second derivative too, on the ground: a parabola). Checked against the same motion given as a record (the FMU joins a record's samples by straight lines):
a ramp set as a value and its slope at each communication point equals the record of that ramp, for rigid rocking
and rocking-sliding, at rest (the uplift located inside the step) and moving; and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import Slave

# a block of the default size (b = 0.1 m, h = 0.3 m): uplift at a_h = g tan(alpha) = 3.27 m/s2
RAMP = [(0.0, 0.0), (0.4, 2.0), (0.9, 4.5), (1.3, -3.0), (1.8, 1.0), (2.5, 0.0)]  # (t s, a_h m/s2), linear between
OUT = ["block1.theta", "block1.omega", "block1.maxAbsTheta", "ground.ahTotal"]
TIGHT = {"solver.relTol": 1e-12}  # the two runs' steps differ by rounding: their results, by the tolerance


def ramp_file(tmp_path, samples=RAMP):
    path = tmp_path / "ramp.txt"
    np.savetxt(path, np.array(samples), fmt="%.17g")
    return path


def by_record(fmu, params, path, stops):
    """The outputs at `stops` with the ramp as a record."""
    s = Slave(fmu)
    s.start({**params, "excitation.kind": 4, "excitation.file": str(path)})
    rows, t = [], 0.0
    for stop in stops:
        s.s.doStep(t, stop - t)
        t = stop
        rows.append(s.real(*OUT) + s.s.getInteger([s.vr["impacts"]]))
    s.close()
    return np.array(rows)


def by_input(fmu, params, stops, samples=RAMP):
    """The outputs at `stops` with the ramp as the input ground.ah: at each communication point its value and its
    slope there (the stops are the ramp's own samples, so the input is the ramp exactly)."""
    s = Slave(fmu)
    s.start({**params, "excitation.kind": 0})
    ts, a = np.array(samples).T
    rows, t = [], 0.0
    vr = s.vr["ground.ah"]
    for stop in stops:
        value = float(np.interp(t, ts, a))
        slope = float((np.interp(stop, ts, a) - value) / (stop - t))
        s.s.setReal([vr], [value])
        s.s.setRealInputDerivatives([vr], [1], [slope])
        s.s.doStep(t, stop - t)
        t = stop
        rows.append(s.real(*OUT) + s.s.getInteger([s.vr["impacts"]]))
    s.close()
    return np.array(rows)


@pytest.mark.parametrize("params", [TIGHT, {**TIGHT, "contact.model": 1, "contact.muGround": 0.8}],
                         ids=["rigid rocking", "rocking-sliding"])
def test_a_sloped_input_equals_the_record_of_its_ramp(fmu, tmp_path, params):
    stops = [t for t, _ in RAMP[1:]] + [3.0, 4.0]
    rec = by_record(fmu, params, ramp_file(tmp_path), stops)
    inp = by_input(fmu, params, stops, RAMP + [(4.0, 0.0)])
    assert rec[:, 4].max() > 0  # the ramp rocks the block (uplift inside the step from 0.4 to 0.9 s)
    np.testing.assert_array_equal(rec[:, 4], inp[:, 4])  # the same impacts
    np.testing.assert_allclose(inp[:, :3], rec[:, :3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(inp[:, 3], rec[:, 3], rtol=0, atol=1e-12)


def test_the_uplift_inside_a_step_is_located_as_the_records(fmu, tmp_path):
    """One step from rest across the uplift threshold: the lift-off (and so the whole motion) is located inside the
    step, not at its end."""
    samples = [(0.0, 0.0), (1.0, 5.0)]
    rec = by_record(fmu, TIGHT, ramp_file(tmp_path, samples), [1.0])
    inp = by_input(fmu, TIGHT, [1.0], samples)
    assert abs(rec[0, 0]) > 1e-3
    np.testing.assert_allclose(inp[0, :3], rec[0, :3], rtol=0, atol=1e-9)


def test_a_value_set_at_a_later_communication_point_ends_the_slope(fmu):
    """The slope set at t = 0 holds over the first step only once a value is set at the next point: the input is
    then held (the FMU's ground.ahTotal reads it)."""
    s = Slave(fmu)
    s.start({"excitation.kind": 0})
    vr = s.vr["ground.ah"]
    s.s.setReal([vr], [0.5])
    s.s.setRealInputDerivatives([vr], [1], [1.0])
    s.s.doStep(0.0, 0.1)
    assert s.real("ground.ahTotal")[0] == pytest.approx(0.6, abs=1e-15)
    s.s.setReal([vr], [0.6])
    s.s.doStep(0.1, 0.1)
    assert s.real("ground.ahTotal")[0] == 0.6
    s.close()


def test_bad_derivatives_are_refused_with_a_message(fmu):
    s = Slave(fmu)
    s.start({"excitation.kind": 0})
    vr = s.vr["ground.ah"]
    s.expect_error(lambda: s.s.setRealInputDerivatives([vr], [3], [1.0]), "derivative of order 3")
    s.expect_error(lambda: s.s.setRealInputDerivatives([s.vr["ground.av"]], [2], [1.0]), "a second derivative")
    s.expect_error(lambda: s.s.setRealInputDerivatives([s.vr["block1.mass"]], [1], [1.0]), "takes no derivatives")
    s.expect_error(lambda: s.s.setRealInputDerivatives([vr], [1], [float("nan")]), "not a finite number")
    s.close()
    s = Slave(fmu)
    s.start({"excitation.kind": 1, "excitation.amplitude": 1.0, "excitation.frequency": 2.0})
    s.expect_error(lambda: s.s.setRealInputDerivatives([s.vr["ground.ah"]], [1], [1.0]), "excitation.kind none or record")
    s.close()


def test_the_model_description_says_inputs_are_interpolated(fmu):
    from fmpy import read_model_description

    assert read_model_description(str(fmu.path)).coSimulation.canInterpolateInputs


FRAME = {"support.kind": 1, "building.storeys": 2, "building.floor": 2, "building.dampingRatio": 0.02,
         "building.storey[1].mass": 2000.0, "building.storey[2].mass": 2000.0,
         "building.storey[1].stiffness": 2.5e6, "building.storey[2].stiffness": 2.5e6}


@pytest.mark.parametrize("coupling", [0, 1], ids=["one-way", "two-way"])
def test_a_sloped_input_on_a_floor_does_not_depend_on_the_communication_step(fmu, tmp_path, coupling):
    """A cabinet at rest on a frame's floor, the frame under a weak record, the input ramp on top: the uplift found
    inside a step of 1.2 s is the one found with steps of 0.01 s (the same straight line given at each point)."""
    params = {**TIGHT, **FRAME, "support.coupling": coupling, "contact.model": 1, "contact.muGround": 0.8,
              "block1.halfWidth": 0.3, "block1.halfHeight": 1.0, "block1.mass": 1000.0, "excitation.kind": 4,
              "excitation.file": str(ramp_file(tmp_path, [(0.0, 0.0), (0.05, 0.3), (0.1, 0.0)])),
              "excitation.scale": 1.0}
    ramp = [(0.0, 0.0), (1.2, 4.0)]  # through the uplift threshold g tan(alpha) = 2.94 m/s2 near 0.88 s

    def run(stops):
        s = Slave(fmu)
        s.start(params)
        vr, t = s.vr["ground.ah"], 0.0
        for stop in stops:
            s.s.setReal([vr], [4.0 * t / 1.2])
            s.s.setRealInputDerivatives([vr], [1], [4.0 / 1.2])
            s.s.doStep(t, stop - t)
            t = stop
        out = s.real("block1.theta", "block1.omega", "block1.maxAbsTheta")
        s.close()
        return np.array(out)

    coarse, fine = run([1.2]), run(list(np.linspace(0.01, 1.2, 120)))
    assert abs(coarse[0]) > 1e-4  # lifted inside the step
    assert ramp[-1][1] > 0
    np.testing.assert_allclose(coarse, fine, rtol=0, atol=1e-9)


@pytest.mark.parametrize("params", [{}, {"contact.model": 1, "contact.muGround": 0.8}],
                         ids=["rigid rocking", "rocking-sliding"])
def test_a_bent_input_that_peaks_inside_one_step_lifts_the_block_as_finer_steps_do(fmu, params):
    """ground.ah = 4 - 16 (t - 0.5)^2 over [0, 1] s: 0 at both ends of one step of 1 s, 4 m/s2 at its middle, above
    the uplift threshold g tan(alpha) = 3.27 m/s2. Given once (value, first and second derivative at t = 0) it
    lifts the block inside the step as the same parabola given at 100 points does; then both rock freely."""

    def run(points):
        s = Slave(fmu)
        s.start({**TIGHT, **params, "excitation.kind": 0})
        vr, t = s.vr["ground.ah"], 0.0
        for stop in points:
            s.s.setReal([vr], [4.0 - 16.0 * (t - 0.5) ** 2])
            s.s.setRealInputDerivatives([vr, vr], [1, 2], [-32.0 * (t - 0.5), -32.0])
            s.s.doStep(t, stop - t)
            t = stop
        s.s.setReal([vr], [0.0])
        s.s.setRealInputDerivatives([vr], [1], [0.0])
        s.s.doStep(t, 2.0 - t)
        out = np.array(s.real("block1.theta", "block1.omega", "block1.maxAbsTheta") + s.s.getInteger([s.vr["impacts"]]))
        s.close()
        return out

    coarse, fine = run([1.0]), run(list(np.linspace(0.01, 1.0, 100)))
    assert coarse[2] > 1e-3  # it rocked
    assert coarse[3] == fine[3]
    np.testing.assert_allclose(coarse[:3], fine[:3], rtol=0, atol=1e-9)


def test_a_second_derivative_is_refused_on_a_support(fmu):
    s = Slave(fmu)
    s.start({**FRAME, "excitation.kind": 0})
    s.expect_error(lambda: s.s.setRealInputDerivatives([s.vr["ground.ah"]], [2], [1.0]), "support.kind = 0")
    s.close()


def test_a_state_carries_the_input_derivatives(fmu):
    """A state taken after the slope was set, serialized and restored, steps as the run it was taken from (the
    derivatives are part of the state, and a restored state's are checked: finite, orders the FMU takes)."""
    s = Slave(fmu)
    s.start({**TIGHT, "excitation.kind": 0})
    vr = s.vr["ground.ah"]
    s.s.setReal([vr], [3.0])  # 3 + 3 t - 2 t^2 m/s2: above the uplift threshold 3.27 m/s2 after 0.1 s
    s.s.setRealInputDerivatives([vr, vr], [1, 2], [3.0, -4.0])
    blob = s.s.serializeFMUstate(s.s.getFMUstate())
    s.s.doStep(0.0, 0.8)
    first = s.real("block1.theta", "block1.omega", "ground.ahTotal")
    state = s.s.deSerializeFMUstate(blob)
    s.s.setFMUstate(state)
    s.s.freeFMUstate(state)
    s.s.doStep(0.0, 0.8)
    assert s.real("block1.theta", "block1.omega", "ground.ahTotal") == first
    assert first[0] != 0.0
    s.close()
