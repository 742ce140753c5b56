"""Supports inside RockingBlock.fmu (support.kind 1: a shear building, 2: an isolation platform), one-way
coupling: the floor's motion against an exact state-space solution (scipy's matrix exponential), the
blocks against the independent monolithic reference (model/support_reference.py, written without reading
the C core), the stiff isolator against the ground, the floor's motion as a record, the communication
step, FMU states and bad parameters."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

from model import sliding_reference as slide
from model import support_reference as ref
from runners.engine.fmu import FMUError

ROOT = Path(__file__).resolve().parents[1]
PULSE = ROOT / "examples" / "pulse_3hz.AT2"
# the cabinet of examples/cabinet_on_floor.toml on the top floor of its three-storey frame
CABINET = {"block1.halfWidth": 0.3, "block1.halfHeight": 1.0, "block1.mass": 1000.0, "block1.theta0": 0.0,
           "contact.model": 1, "contact.muGround": 0.5, "g": 9.81}
FRAME = {"support.kind": 1, "building.storeys": 3, "building.floor": 3, "building.dampingRatio": 0.02,
         **{f"building.storey[{i}].mass": 2000.0 for i in (1, 2, 3)},
         **{f"building.storey[{i}].stiffness": 2.5e6 for i in (1, 2, 3)}}
OUT = ["block1.theta", "block1.slip", "block1.maxAbsTheta", "impacts", "ground.ahTotal", "support.u", "support.v",
       "support.baseAh"]


def write_record(path: Path, t: np.ndarray, a: np.ndarray) -> Path:
    np.savetxt(path, np.column_stack([t, a]), fmt="%.17g")
    return path


@pytest.fixture(scope="module")
def pulse_record(tmp_path_factory) -> tuple[Path, np.ndarray, np.ndarray]:
    """examples/pulse_3hz.AT2 (one sine of 0.51 g at 3 Hz) in the FMU's record format."""
    t, a = ref.read_at2(PULSE)
    return write_record(tmp_path_factory.mktemp("support") / "pulse_3hz.txt", t, a), t, a


def frame_matrices(masses, stiffnesses, zeta):
    """M, K and Rayleigh C of a shear building (zeta at modes 1 and 2), from scipy's eigh."""
    m = np.asarray(masses, float)
    k = np.append(np.asarray(stiffnesses, float), 0.0)
    n = len(m)
    K = np.diag(k[:n] + k[1:]) - np.diag(k[1:n], 1) - np.diag(k[1:n], -1)
    M = np.diag(m)
    w = np.sqrt(sl.eigh(K, M, eigvals_only=True))
    a0, a1 = (2 * zeta * w[0] * w[1] / (w[0] + w[1]), 2 * zeta / (w[0] + w[1])) if n > 1 else (0.0, 2 * zeta / w[0])
    return M, K, a0 * M + a1 * K


def exact_floor(t, a, M, K, C, floor, times):
    """Floor `floor`'s displacement relative to the base and absolute acceleration at `times`, under the
    base acceleration linear between the samples (t, a) and zero after them: the first-order system
    propagated exactly with the matrix exponential of the system augmented by the input and its slope."""
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    B = np.r_[np.zeros(n), -np.ones(n)]
    aug = np.zeros((2 * n + 2, 2 * n + 2))
    aug[:2 * n, :2 * n] = A
    aug[:2 * n, 2 * n] = B
    aug[2 * n, 2 * n + 1] = 1.0

    def flow(z, a0, a1, h):
        return (sl.expm(aug * h) @ np.r_[z, a0, a1])[:2 * n]

    slopes = np.diff(a) / np.diff(t)
    starts = [np.zeros(2 * n)]
    for i in range(len(t) - 1):
        starts.append(flow(starts[-1], a[i], slopes[i], t[i + 1] - t[i]))
    u, acc = np.empty(len(times)), np.empty(len(times))
    for j, tq in enumerate(times):
        i = int(np.searchsorted(t, tq, side="right")) - 1
        a0, a1 = (a[i], slopes[i]) if i < len(t) - 1 else (0.0, 0.0)
        z = flow(starts[i], a0, a1, tq - t[i])
        ag = a0 + a1 * (tq - t[i])
        u[j] = z[floor - 1]
        acc[j] = ag + (A[n:] @ z + B[n:] * ag)[floor - 1]
    return u, acc


def test_the_floor_moves_as_the_exact_linear_solution(fmu, pulse_record):
    """support.u and ground.ahTotal (what the blocks stand on) against the matrix exponential's solution."""
    path, t, a = pulse_record
    res = fmu.run({**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(path)}, 3.0, 0.01, OUT)
    M, K, C = frame_matrices([2000.0] * 3, [2.5e6] * 3, 0.02)
    u, acc = exact_floor(t, a, M, K, C, 3, res.time)
    scale = np.abs(acc).max()
    assert scale > 2.0 * np.abs(a).max()  # the top floor amplifies the pulse
    assert np.abs(res.outputs["ground.ahTotal"] - acc).max() < 1e-12 * scale
    assert np.abs(res.outputs["support.u"] - u).max() < 1e-12 * np.abs(u).max()
    base = np.interp(res.time, t, a, right=0.0)
    assert np.abs(res.outputs["support.baseAh"] - base).max() < 1e-12 * np.abs(a).max()


@pytest.mark.parametrize("model", [1, 0])
def test_one_way_building_matches_the_independent_monolithic_reference(fmu, pulse_record, model):
    """The cabinet on the top floor (rocking-sliding; and rigid rocking, the reference's mu = infinity):
    the same impacts, peak |theta| within 1e-8 rad and final slip within 1e-8 m."""
    path, _, _ = pulse_record
    params = {**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(path), "contact.model": model,
              "solver.relTol": 1e-12, "solver.absTol": 1e-14}
    res = fmu.run(params, 4.0, 0.001, OUT)
    block = slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=0.5 if model == 1 else np.inf, g=9.81)
    run = ref.simulate(block, ref.Building([2000.0] * 3, [2.5e6] * 3, 0.02, 3), ref.record_file(PULSE), 4.0,
                       coupling="one-way")
    assert run.impacts >= 5
    assert res.outputs["impacts"][-1] == run.impacts
    assert abs(res.outputs["block1.maxAbsTheta"][-1] - run.peak_abs_theta) < 1e-8
    if model == 1:
        assert run.final_slip != 0.0
        assert abs(res.outputs["block1.slip"][-1] - run.final_slip) < 1e-8
    theta = np.interp(res.time, run.grid_t, run.grid_theta)
    assert np.abs(res.outputs["block1.theta"] - theta).max() < 1e-7


def test_a_very_stiff_isolator_is_the_ground(fmu, pulse_record):
    """A platform at 1e6 rad/s (5 % damping) under the pulse moves the cabinet as the ground does, to 1e-9."""
    path, _, _ = pulse_record
    base = {**CABINET, "excitation.kind": 4, "excitation.file": str(path)}
    m, w = 1000.0, 1e6
    stiff = {"support.kind": 2, "platform.mass": m, "platform.stiffness": m * w * w, "platform.damping": 0.1 * m * w}
    ground = fmu.run(base, 4.0, 0.001, OUT)
    platform = fmu.run({**base, **stiff}, 4.0, 0.001, OUT)
    assert ground.outputs["impacts"][-1] >= 5
    assert platform.outputs["impacts"][-1] == ground.outputs["impacts"][-1]
    for name in ("block1.theta", "block1.slip"):
        assert np.abs(platform.outputs[name] - ground.outputs[name]).max() < 1e-9, name
    assert np.abs(platform.outputs["support.u"]).max() < 1e-11


def test_one_way_building_is_the_record_run_of_its_floor_motion(fmu, pulse_record, tmp_path):
    """The floor's exact acceleration, sampled every dt and given to the block on the ground as a record:
    the runs converge to the building's as dt shrinks (second order: the record's linear interpolation)."""
    path, t, a = pulse_record
    common = {**CABINET, "solver.relTol": 1e-12, "solver.absTol": 1e-14}
    exact = fmu.run({**common, **FRAME, "excitation.kind": 4, "excitation.file": str(path)}, 2.0, 0.001, OUT)
    M, K, C = frame_matrices([2000.0] * 3, [2.5e6] * 3, 0.02)
    errors = []
    for dt in (4e-3, 2e-3, 1e-3, 5e-4):
        ts = np.arange(0.0, 2.0 + dt / 2, dt)
        _, acc = exact_floor(t, a, M, K, C, 3, ts)
        rec = write_record(tmp_path / f"floor_{dt:g}.txt", ts, acc)
        run = fmu.run({**common, "excitation.kind": 4, "excitation.file": str(rec)}, 2.0, 0.001, OUT)
        assert run.outputs["impacts"][-1] == exact.outputs["impacts"][-1]
        errors.append(max(np.abs(run.outputs[n] - exact.outputs[n]).max() for n in ("block1.theta", "block1.slip")))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 3.0), errors  # about 4 per halving
    assert errors[-1] < 1e-5, errors


def test_the_support_does_not_depend_on_the_communication_step(fmu, pulse_record):
    path, _, _ = pulse_record
    params = {**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(path)}
    fine = fmu.run(params, 4.0, 0.001, OUT)
    coarse = fmu.run(params, 4.0, 0.25, OUT)
    for name in OUT:
        assert fine.outputs[name][-1] == coarse.outputs[name][-1], name


@pytest.mark.parametrize("model", [0, 1])
def test_a_stack_on_a_floor_is_the_record_run_of_its_floor(fmu, pulse_record, tmp_path, model):
    """Two stacked blocks on the top floor (both contact models) against the same blocks on the ground under
    the floor's exact acceleration sampled every 0.25 ms: the same impacts and rotations close to the
    interpolation error."""
    path, t, a = pulse_record
    stack = {"nBlocks": 2, "block1.halfWidth": 0.4, "block1.halfHeight": 0.5, "block1.mass": 800.0,
             "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 300.0, "block1.theta0": 0.0,
             "contact.model": model, "contact.muGround": 0.7, "contact.muInterface": 0.7, "restitution.law": 0}
    exact = fmu.run({**stack, **FRAME, "excitation.kind": 4, "excitation.file": str(path)}, 3.0, 0.001,
                    ["block1.theta", "block2.theta", "impacts"])
    M, K, C = frame_matrices([2000.0] * 3, [2.5e6] * 3, 0.02)
    ts = np.arange(0.0, 3.0 + 1e-9, 2.5e-4)
    _, acc = exact_floor(t, a, M, K, C, 3, ts)
    rec = write_record(tmp_path / "floor.txt", ts, acc)
    run = fmu.run({**stack, "excitation.kind": 4, "excitation.file": str(rec)}, 3.0, 0.001,
                  ["block1.theta", "block2.theta", "impacts"])
    assert np.abs(exact.outputs["block2.theta"]).max() > 0.02  # it rocks
    assert run.outputs["impacts"][-1] == exact.outputs["impacts"][-1]
    for name in ("block1.theta", "block2.theta"):
        assert np.abs(run.outputs[name] - exact.outputs[name]).max() < 2e-4, name


@pytest.mark.parametrize("coupling", [0, 1])
def test_a_restored_state_continues_the_same_run(fmu, pulse_record, coupling):
    """fmi2GetFMUstate in the middle of a run on a floor (one-way, two-way), then fmi2SetFMUstate: the same
    end, bit for bit."""
    path, _, _ = pulse_record
    params = {**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(path), "support.coupling": coupling}
    slave, _ = fmu.instantiate(lambda *a: None)
    try:
        slave.setupExperiment(startTime=0.0)
        fmu.set_parameters(slave, params)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        theta = [fmu.variable("block1.theta").valueReference, fmu.variable("support.u").valueReference]
        slave.doStep(0.0, 1.0)
        state = slave.getFMUstate()
        slave.doStep(1.0, 3.0)
        first = slave.getReal(theta)
        slave.setFMUstate(state)
        slave.doStep(1.0, 3.0)
        assert slave.getReal(theta) == first
        slave.freeFMUstate(state)
    finally:
        slave.terminate()
        slave.freeInstance()


@pytest.mark.parametrize("change, words", [
    ({"excitation.kind": 1, "excitation.amplitude": 2.0}, "excitation.kind must be 4"),
    ({"building.floor": 4}, "building.floor = 4"),
    ({"building.storey[2].stiffness": 0.0}, "building.storey[2].stiffness"),
    ({"building.dampingRatio": 1.0}, "building.dampingRatio"),
    ({"support.kind": 2, "platform.mass": 0.0}, "platform.mass"),
    ({"support.kind": 3}, "support.kind = 3"),
    ({"support.coupling": 2}, "support.coupling = 2"),
    ({"support.coupling": 1, "contact.model": 0, "solver.method": 1}, "rigid rocking on a two-way support needs "
                                                                      "solver.method = 0"),
])
def test_bad_support_parameters_are_refused_with_a_message(fmu, pulse_record, change, words):
    path, _, _ = pulse_record
    with pytest.raises(FMUError, match=None) as err:
        fmu.run({**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(path), **change}, 1.0, 0.01, OUT)
    assert words in str(err.value)
