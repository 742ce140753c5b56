"""The Taylor-series integrator (solver.method = 1) against the exact reference and the
Dormand-Prince integrator of the same FMU (solver.method = 0); the default, auto (2), takes the
Taylor series for one block in rigid rocking and Dormand-Prince for stacks and rocking-sliding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model.reference import Block, free_rocking
from runners.engine.fmu import FMUError

BLOCK = Block(0.1, 0.3)
TAYLOR = {"solver.method": 1}
DORMAND_PRINCE = {"solver.method": 0}


@pytest.mark.parametrize("rtol,bound", [(1e-6, 1e-6), (1e-10, 1e-10), (1e-13, 1e-13)])
def test_free_rocking_meets_the_tolerance(fmu, rtol, bound):
    theta0 = 0.6 * BLOCK.alpha
    ref = free_rocking(BLOCK, theta0, 0.9, 10)
    p = {**TAYLOR, "block1.theta0": theta0, "restitution.law": 2, "restitution.eta": 0.9,
         "solver.relTol": rtol, "solver.absTol": 1e-2 * rtol}
    r = fmu.run(p, ref.impact_times[-1] + 0.05, 0.01)
    ti, pk = r.event_times("impact")[:10], r.event_values("peak", "theta")[:9]
    assert len(ti) == 10 and len(pk) == 9
    assert np.max(np.abs(ti / ref.impact_times - 1)) < bound
    assert np.max(np.abs(pk / ref.peak_thetas[:9] - 1)) < bound


SCENES = {
    "sine pulse to rest": {"excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0},
    "cosine pulse with vertical": {"excitation.kind": 2, "excitation.amplitude": 4.0, "excitation.frequency": 2.0,
                                   "excitation.verticalAmplitude": 3.0, "excitation.startTime": 0.2},
    "harmonic table": {"excitation.kind": 3, "excitation.displacement": 0.01, "excitation.frequency": 3.5,
                       "excitation.cycles": 4},
    "overturning pulse": {"excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 2.0},
}


@pytest.mark.parametrize("scene", SCENES, ids=list(SCENES))
def test_forced_scenes_agree_with_dormand_prince(fmu, scene):
    outs = ["block1.theta", "impacts", "overturned", "atRest"]
    p = {**SCENES[scene], "solver.relTol": 1e-12, "solver.absTol": 1e-14}
    a = fmu.run({**p, **TAYLOR}, 5.0, 0.01, outputs=outs)
    b = fmu.run({**p, **DORMAND_PRINCE}, 5.0, 0.01, outputs=outs)
    ta, tb = a.event_times("impact"), b.event_times("impact")
    assert len(ta) == len(tb) and a.outputs["overturned"][-1] == b.outputs["overturned"][-1]
    if len(ta):
        assert np.max(np.abs(ta[:10] - tb[:10])) < 1e-9
    assert np.max(np.abs(a.outputs["block1.theta"][:150] - b.outputs["block1.theta"][:150])) < 1e-9


def test_inputs_and_communication_steps(fmu):
    """ground.ah from the importer, and results independent of the communication step."""
    p = {**TAYLOR, "block1.theta0": 0.05}
    ah = lambda t: (2.0 * math.sin(7.0 * t), 0.0)  # noqa: E731
    a = fmu.run(p, 3.0, 0.01, outputs=["block1.theta"], inputs=ah, events=False)
    b = fmu.run({**p, "solver.method": 0}, 3.0, 0.01, outputs=["block1.theta"], inputs=ah, events=False)
    assert np.max(np.abs(a.outputs["block1.theta"] - b.outputs["block1.theta"])) < 1e-8
    free = {**TAYLOR, "block1.theta0": 0.15, "excitation.kind": 1, "excitation.amplitude": 5.0,
            "excitation.frequency": 3.0, "excitation.startTime": 0.4}
    fine = fmu.run(free, 3.0, 1e-3, outputs=["block1.theta", "block1.omega"], events=False)
    coarse = fmu.run(free, 3.0, 0.1, outputs=["block1.theta", "block1.omega"], events=False)
    for k in ("block1.theta", "block1.omega"):
        np.testing.assert_allclose(coarse.outputs[k], fine.outputs[k][::100], rtol=0, atol=1e-13)


def test_invalid_method_settings_are_errors(fmu):
    with pytest.raises(FMUError, match="solver.method"):
        fmu.run({"solver.method": 3}, 0.1, 0.1)
    with pytest.raises(FMUError, match="solver.method"):
        fmu.run({"solver.method": -1}, 0.1, 0.1)
    with pytest.raises(FMUError, match="nBlocks = 1 only"):
        fmu.run({"solver.method": 1, "nBlocks": 2}, 0.1, 0.1)
    with pytest.raises(FMUError, match="rocking-sliding"):
        fmu.run({"solver.method": 1, "contact.model": 1}, 0.1, 0.1)


def _bits(r, outs):
    return [r.outputs[k].tobytes() for k in outs] + [r.event_times(e).tobytes() for e in ("impact", "peak")]


AUTO_SCENES = {
    "free rocking": {"block1.theta0": 0.2},
    "sine pulse to rest": SCENES["sine pulse to rest"],
    "overturning pulse": SCENES["overturning pulse"],
}


def _record_scene(tmp_path):
    """A piecewise-linear record (samples every 0.02 s of two sines, 4 s), as a file."""
    t = np.arange(0.0, 4.0 + 1e-9, 0.02)
    a = 4.0 * np.sin(2 * math.pi * 1.7 * t) + 2.5 * np.sin(2 * math.pi * 4.3 * t + 0.4)
    a[-1] = 0.0
    path = tmp_path / "two_sines.txt"
    np.savetxt(path, np.column_stack([t, a]), fmt="%.17g", header="time (s), ah (m/s2)")
    return {"excitation.kind": 4, "excitation.file": str(path), "block1.halfWidth": 0.1, "block1.halfHeight": 0.4}


def test_the_default_is_auto(fmu):
    assert fmu.defaults()["solver.method"] == 2


@pytest.mark.parametrize("scene", AUTO_SCENES)
def test_auto_integrates_one_rigid_block_by_the_taylor_series(fmu, scene):
    """The default run of one block is the Taylor series' to the bit, and not Dormand-Prince's."""
    outs = ["block1.theta", "block1.omega", "impacts", "block1.maxAbsTheta"]
    p = AUTO_SCENES[scene]
    auto = fmu.run(p, 3.0, 0.01, outputs=outs)
    taylor = fmu.run({**p, **TAYLOR}, 3.0, 0.01, outputs=outs)
    dp = fmu.run({**p, **DORMAND_PRINCE}, 3.0, 0.01, outputs=outs)
    assert _bits(auto, outs) == _bits(taylor, outs)
    assert _bits(auto, outs) != _bits(dp, outs)
    # the two integrators agree to their tolerance (relTol 1e-10): the same run
    assert np.max(np.abs(auto.outputs["block1.theta"] - dp.outputs["block1.theta"])) < 1e-6
    assert np.array_equal(auto.outputs["impacts"], dp.outputs["impacts"])


STACK = {"nBlocks": 2, "block1.theta0": 0.05, "block2.theta0": -0.08, "block2.halfWidth": 0.1,
         "block2.halfHeight": 0.2, "block1.mass": 10.0, "block2.mass": 5.0}
SLIDING = {"contact.model": 1, "contact.muGround": 0.35, "block1.halfWidth": 0.15, "block1.halfHeight": 0.45,
           "excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 1.5}
STACK_SLIDING = {**STACK, "block2.halfWidth": 0.08, "contact.model": 1, "contact.muGround": 0.5, "contact.muInterface": 0.5}


@pytest.mark.parametrize("scene", ["stack", "rocking-sliding", "rocking-sliding stack", "record"])
def test_auto_integrates_stacks_rocking_sliding_and_records_by_dormand_prince(fmu, scene, tmp_path):
    """Where the Taylor series does not apply, the default is accepted (no refusal) and is
    Dormand-Prince to the bit; so is a record's (its samples cut every step, where Dormand-Prince's
    steps are the cheaper)."""
    outs = ["block1.theta", "block1.omega", "impacts"]
    scene = {"stack": STACK, "rocking-sliding": SLIDING, "rocking-sliding stack": STACK_SLIDING,
             "record": _record_scene(tmp_path)}[scene]
    auto = fmu.run(scene, 2.0, 0.01, outputs=outs)
    dp = fmu.run({**scene, **DORMAND_PRINCE}, 2.0, 0.01, outputs=outs)
    assert auto.outputs["impacts"][-1] > 0
    assert _bits(auto, outs) == _bits(dp, outs)
    if "excitation.file" in scene:  # a record: solver.method = 1 would integrate it, differently
        assert _bits(fmu.run({**scene, **TAYLOR}, 2.0, 0.01, outputs=outs), outs) != _bits(auto, outs)


def test_the_monitors_sample_inside_taylor_steps(fmu):
    """The default's steps are long; the monitors sample inside them, so the largest friction demand
    of a pulse run is the largest |T| / N along the motion (outputs every 0.1 ms, each an exact
    evaluation on the series), closer than Dormand-Prince's step-start samples get it."""
    p = {**SCENES["sine pulse to rest"], "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 2.0}
    outs = ["contact.groundT", "contact.groundN", "friction.demandMaxGround", "contact.normalMinGround"]
    fine = fmu.run(p, 2.0, 1e-4, outputs=outs, events=False)
    demand = np.abs(fine.outputs["contact.groundT"]) / fine.outputs["contact.groundN"]
    weight = 2.0 * 9.81  # m g (N)
    auto = fmu.run(p, 2.0, 2.0, outputs=outs, events=False)
    dp = fmu.run({**p, **DORMAND_PRINCE}, 2.0, 2.0, outputs=outs, events=False)
    true_max, true_min = demand.max(), fine.outputs["contact.groundN"].min() / weight
    err_auto = abs(auto.outputs["friction.demandMaxGround"][-1] / true_max - 1)
    err_dp = abs(dp.outputs["friction.demandMaxGround"][-1] / true_max - 1)
    assert err_auto < 1e-6 and err_auto < err_dp
    # the smallest normal reaction lies at an impact, which both integrators sample exactly (the
    # 0.1 ms outputs fall beside it)
    n_auto, n_dp = auto.outputs["contact.normalMinGround"][-1], dp.outputs["contact.normalMinGround"][-1]
    assert n_auto == pytest.approx(n_dp, rel=1e-9) and n_auto <= true_min


def test_fall_time_is_where_the_block_passes_its_limit(fmu):
    """fallTime of the default is the time |theta| passes alpha before the overturn, not the start
    of the step in which it does."""
    b, h = 0.03, 0.06
    p = {"block1.halfWidth": b, "block1.halfHeight": h, "excitation.kind": 1, "excitation.amplitude": 6.0,
         "excitation.frequency": 1.5}
    r = fmu.run(p, 1.0, 1e-4, outputs=["block1.theta", "fallTime", "overturned"], events=False)
    assert r.outputs["overturned"][-1]
    theta, alpha = np.abs(r.outputs["block1.theta"]), math.atan(b / h)
    over = np.nonzero(theta > alpha)[0]
    last_in = over[np.nonzero(theta[over - 1] <= alpha)[0][-1]] - 1  # the last sample within before the fall
    t0, t1, y0, y1 = r.time[last_in], r.time[last_in + 1], theta[last_in], theta[last_in + 1]
    crossing = t0 + (alpha - y0) / (y1 - y0) * (t1 - t0)  # linear between 0.1 ms samples
    assert abs(r.outputs["fallTime"][-1] - crossing) < 1e-7
