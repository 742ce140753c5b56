"""Supports coupled two ways inside RockingBlock.fmu (support.coupling = 1, the rocking-sliding model): the
blocks' forces and impacts act on the floor. Checked against the independent monolithic reference
(model/support_reference.py, written without reading the C core, with its own derivation of the impact on a
floor of finite mass), against conservation laws (the horizontal momentum of blocks plus a free platform,
the energy balance of blocks plus support in the base's frame), and for the communication step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from model import sliding_reference as slide
from model import support_reference as ref
from runners.engine.summary import two_way_balance

ROOT = Path(__file__).resolve().parents[1]
PULSE = ROOT / "examples" / "pulse_3hz.AT2"
CABINET = {"block1.halfWidth": 0.3, "block1.halfHeight": 1.0, "block1.mass": 1000.0, "block1.theta0": 0.0,
           "contact.model": 1, "contact.muGround": 0.5, "g": 9.81, "solver.relTol": 1e-12, "solver.absTol": 1e-14}
STACK = {"nBlocks": 2, "block1.halfWidth": 0.3, "block1.halfHeight": 0.6, "block1.mass": 800.0,
         "block1.theta0": 0.0, "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 400.0,
         "contact.model": 1, "contact.muGround": 0.5, "contact.muInterface": 0.5, "g": 9.81,
         "solver.relTol": 1e-12, "solver.absTol": 1e-14}
BALANCE = ["energy", "momentum", "block1.frictionLoss", "impactLoss", "support.v", "support.energy",
           "support.dampingLoss", "support.baseWork"]
OUT = ["block1.theta", "block1.slip", "block1.maxAbsTheta", "impacts", "ground.ahTotal", "support.u", "atRest",
       *BALANCE]


def frame(top: float = 2000.0) -> dict:
    """The three-storey frame of examples/cabinet_on_floor.toml (2 t floors, 2.5e6 N/m storeys, 2 %), the top
    floor of mass `top`, the blocks on it, coupled two ways."""
    return {"support.kind": 1, "support.coupling": 1, "building.storeys": 3, "building.floor": 3,
            "building.dampingRatio": 0.02, "building.storey[1].mass": 2000.0, "building.storey[2].mass": 2000.0,
            "building.storey[3].mass": top, **{f"building.storey[{i}].stiffness": 2.5e6 for i in (1, 2, 3)}}


@pytest.fixture(scope="module")
def pulse(tmp_path_factory) -> Path:
    """examples/pulse_3hz.AT2 (one sine of 0.51 g at 3 Hz) in the FMU's record format."""
    t, a = ref.read_at2(PULSE)
    path = tmp_path_factory.mktemp("two_way") / "pulse_3hz.txt"
    np.savetxt(path, np.column_stack([t, a]), fmt="%.17g")
    return path


@pytest.mark.parametrize("mu, top", [(0.5, 2000.0), (0.31, 2000.0), (0.25, 2000.0), (0.5, 50.0)])
def test_two_way_building_matches_the_independent_monolithic_reference(fmu, pulse, mu, top):
    """The cabinet on the top floor, coupled two ways: rocking (mu 0.5), slide-rocking with impacts (0.31),
    sliding (0.25), and on a top floor 20 times lighter than the cabinet (50 kg under 1 t, where the
    co-simulation chatters): the same impacts, peak |theta| within 1e-8 rad, final slip within 1e-8 m."""
    res = fmu.run({**CABINET, **frame(top), "contact.muGround": mu, "excitation.kind": 4,
                   "excitation.file": str(pulse)}, 4.0, 0.001, OUT)
    block = slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=mu, g=9.81)
    run = ref.simulate(block, ref.Building([2000.0, 2000.0, top], [2.5e6] * 3, 0.02, 3), ref.record_file(PULSE),
                       4.0, coupling="two-way")
    o = res.outputs
    assert run.impacts > 0 or run.final_slip != 0.0  # the floor moves the cabinet
    assert o["impacts"][-1] == run.impacts
    assert abs(o["block1.maxAbsTheta"][-1] - run.peak_abs_theta) < 1e-8
    assert abs(o["block1.slip"][-1] - run.final_slip) < 1e-8
    s = run.sample(res.time)
    assert np.abs(o["support.u"] - s["floor_u"]).max() < 1e-8
    assert np.abs(o["support.v"] - s["floor_v"]).max() < 1e-7
    assert two_way_balance(o, CABINET) < 1e-9


PLATFORM = {"support.kind": 2, "support.coupling": 1, "platform.mass": 300.0, "platform.stiffness": 3.0e4,
            "platform.damping": 60.0}


@pytest.mark.parametrize("support, scale, zeta, moves", [("frame", 0.2, 0.02, False), ("frame", 0.1, 0.0, False),
                                                         ("frame", 1.0, 0.02, True), ("frame", 0.3, 0.0, True),
                                                         ("platform", 0.3, None, False), ("platform", 2.0, None, True)])
def test_blocks_at_rest_on_a_two_way_support_match_the_reference_in_closed_form(fmu, pulse, support, scale, zeta,
                                                                                  moves):
    """The cabinet at rest on its floor moves with it, and the support with the cabinet on it is linear: the FMU
    then carries them in closed form (the support's first-order modes with the cabinet's mass on its floor, and
    the base's work exactly; docs/supports.md), through the record (where the cabinet never moves) and after it
    (where it rocks, comes to rest, and the floor vibrates on with it), on an undamped frame and an isolation
    platform too. The floor's motion, the base's work and the dampers' loss equal the independent reference's, which
    integrates them."""
    if support == "frame":
        params = {**frame(), "building.dampingRatio": zeta}
        sup = ref.Building([2000.0] * 3, [2.5e6] * 3, zeta, 3)
    else:
        params = dict(PLATFORM)
        sup = ref.Platform(300.0, 3.0e4, 60.0)
    res = fmu.run({**CABINET, **params, "excitation.kind": 4, "excitation.file": str(pulse),
                   "excitation.scale": scale}, 8.0, 0.01, OUT)
    run = ref.simulate(slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=0.5, g=9.81), sup, ref.record_file(PULSE, scale),
                       8.0, coupling="two-way")
    o = res.outputs
    assert o["atRest"][-1] == 1.0 and o["impacts"][-1] == run.impacts
    assert (run.impacts > 0) == moves
    s = run.sample(res.time)
    assert np.abs(o["support.u"] - s["floor_u"]).max() < 1e-8
    assert np.abs(o["support.v"] - s["floor_v"]).max() < 1e-7
    scale_j = run.energy_scale
    assert abs(o["support.baseWork"][-1] - run.base_work[-1]) < 1e-8 * scale_j
    assert abs(o["support.dampingLoss"][-1] - run.damping_loss[-1]) < 1e-8 * scale_j
    if zeta == 0.0:
        assert o["support.dampingLoss"][-1] == 0.0 or abs(o["support.dampingLoss"][-1]) < 1e-9 * scale_j
    assert two_way_balance(o, CABINET) < 1e-9


@pytest.mark.parametrize("scale", [0.2, 1.0])
def test_a_tall_heavily_damped_frame_has_overdamped_modes_in_its_closed_form(fmu, pulse, scale):
    """Eight storeys at 50 % damping: with the cabinet on the top floor four of the support's modes are overdamped,
    so its closed form at rest has twelve terms (a real root each for those), more than the storeys: at rest
    (scale 0.2) and after rocking (scale 1) the floor, the base's work and the dampers' loss still equal the
    reference's."""
    n = 8
    params = {"support.kind": 1, "support.coupling": 1, "building.storeys": n, "building.floor": n,
              "building.dampingRatio": 0.5, **{f"building.storey[{i}].mass": 2000.0 for i in range(1, n + 1)},
              **{f"building.storey[{i}].stiffness": 2.5e6 for i in range(1, n + 1)}}
    res = fmu.run({**CABINET, **params, "excitation.kind": 4, "excitation.file": str(pulse), "excitation.scale": scale},
                  6.0, 0.01, OUT)
    run = ref.simulate(slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=0.5, g=9.81),
                       ref.Building([2000.0] * n, [2.5e6] * n, 0.5, n), ref.record_file(PULSE, scale), 6.0,
                       coupling="two-way")
    o = res.outputs
    assert o["atRest"][-1] == 1.0 and o["impacts"][-1] == run.impacts
    s = run.sample(res.time)
    assert np.abs(o["support.u"] - s["floor_u"]).max() < 1e-8
    assert abs(o["support.baseWork"][-1] - run.base_work[-1]) < 1e-8 * run.energy_scale
    assert abs(o["support.dampingLoss"][-1] - run.damping_loss[-1]) < 1e-8 * run.energy_scale
    assert two_way_balance(o, CABINET) < 1e-9


def test_a_stiffly_damped_platform_carries_the_cabinet_to_rest_long_after_the_record(fmu, pulse):
    """A platform with a damper of 1e6 N s/m (a root near -770 1/s): the cabinet, released tilted, rocks and comes
    to rest 3.4 s after the record's end, where that root's e^(-lambda t) would overflow any double; the closed form
    works from the rest's start instead. Floor, base work and dampers' loss as the reference's."""
    params = {**CABINET, **PLATFORM, "platform.damping": 1.0e6, "block1.theta0": 0.1, "excitation.kind": 4,
              "excitation.file": str(pulse), "excitation.scale": 0.2}
    res = fmu.run(params, 8.0, 0.01, OUT)
    run = ref.simulate(slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=0.5, g=9.81), ref.Platform(300.0, 3.0e4, 1.0e6),
                       ref.record_file(PULSE, 0.2), 8.0, coupling="two-way", theta0=0.1)
    o = res.outputs
    rests = [e.t for e in res.events if e.kind == "rest"]
    assert rests and rests[0] > 3.0 and o["atRest"][-1] == 1.0 and o["impacts"][-1] == run.impacts
    assert np.abs(o["support.u"] - run.sample(res.time)["floor_u"]).max() < 1e-8
    assert abs(o["support.baseWork"][-1] - run.base_work[-1]) < 1e-8 * run.energy_scale
    assert abs(o["support.dampingLoss"][-1] - run.damping_loss[-1]) < 1e-8 * run.energy_scale
    assert two_way_balance(o, CABINET) < 1e-9


def test_a_state_taken_at_rest_in_closed_form_continues_in_another_instance(fmu, pulse):
    """fmi2GetFMUstate while the cabinet rests on its two-way floor in closed form, serialized and set into another
    instance that ran a block on the ground (which reads the record and builds that form's table again): the same
    floor, base work and dampers' loss, bit for bit."""
    params = {**CABINET, **frame(), "excitation.kind": 4, "excitation.file": str(pulse), "excitation.scale": 0.2}
    names = ["support.u", "support.v", "support.baseWork", "support.dampingLoss"]

    def started(p):
        slave, callbacks = fmu.instantiate(lambda *a: None)
        slave.setupExperiment(startTime=0.0)
        fmu.set_parameters(slave, p)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        return slave, callbacks

    a, _ca = started(params)
    b, _cb = started({**CABINET, "excitation.kind": 1})
    try:
        vrs = [fmu.variable(n).valueReference for n in names]
        a.doStep(0.0, 0.5)
        blob = bytes(a.serializeFMUstate(a.getFMUstate()))
        a.doStep(0.5, 2.5)
        first = a.getReal(vrs)
        assert a.getBoolean([fmu.variable("atRest").valueReference]) == [True]
        assert first[2] != 0.0 and first[3] > 0.0
        b.setFMUstate(b.deSerializeFMUstate(blob))
        b.doStep(0.5, 2.5)
        assert b.getReal(vrs) == first
    finally:
        for slave in (a, b):
            slave.terminate()
            slave.freeInstance()


def test_an_input_on_the_base_ends_the_closed_form_and_moves_the_floor_as_a_record_would(fmu, pulse, tmp_path):
    """The cabinet at rest on its two-way floor in closed form, then ground.ah = 0.3 m/s2 held from t = 1 s: the
    floor moves as under a record that steps to 0.3 m/s2 there (within what the record's 2e-6 s ramps change)."""
    t, a = ref.read_at2(PULSE)
    stepped = tmp_path / "stepped.txt"
    # (the pulse's record ends at a nonzero sample, after which the base is still: a 2e-6 s ramp to 0 there too)
    np.savetxt(stepped, np.column_stack([np.r_[t, t[-1] + 2e-6, 1.0 - 2e-6, 1.0, 6.0], np.r_[0.2 * a, 0.0, 0.0, 0.3, 0.3]]),
               fmt="%.17g")
    base = {**CABINET, **frame(), "excitation.kind": 4}
    held = fmu.run({**base, "excitation.file": str(pulse), "excitation.scale": 0.2}, 5.0, 0.01, OUT,
                   inputs=lambda tt: (0.3 if tt >= 1.0 - 1e-9 else 0.0, 0.0))
    record = fmu.run({**base, "excitation.file": str(stepped)}, 5.0, 0.01, OUT)
    assert np.abs(held.outputs["support.u"]).max() > 1e-3
    assert np.abs(held.outputs["support.u"] - record.outputs["support.u"]).max() < 1e-6
    assert two_way_balance(held.outputs, CABINET) < 1e-6


def test_two_way_differs_from_one_way_where_the_floor_is_light(fmu, pulse):
    """The coupling is real: on the 50 kg top floor the cabinet's own load changes its motion."""
    base = {**CABINET, **frame(50.0), "excitation.kind": 4, "excitation.file": str(pulse)}
    two = fmu.run(base, 4.0, 0.01, OUT)
    one = fmu.run({**base, "support.coupling": 0}, 4.0, 0.01, OUT)
    assert abs(two.outputs["block1.maxAbsTheta"][-1] - one.outputs["block1.maxAbsTheta"][-1]) > 1e-3


@pytest.mark.parametrize("blocks", ["one", "stack"])
def test_a_free_platform_keeps_the_horizontal_momentum_through_impacts(fmu, blocks):
    """A platform without spring or damper, no excitation, the blocks released tilted: the horizontal momentum
    of blocks plus platform (relative to the base, at rest) stays 0 to 1e-12 of its scale through every
    impact, and the energy balance holds to 1e-9."""
    params = {**(CABINET if blocks == "one" else STACK), "block1.theta0": 0.15 if blocks == "one" else 0.1,
              "excitation.kind": 0, "support.kind": 2, "support.coupling": 1, "platform.mass": 300.0,
              "platform.stiffness": 0.0, "platform.damping": 0.0}
    out = [*OUT, *(["block2.frictionLoss"] if blocks == "stack" else [])]
    o = fmu.run(params, 5.0, 0.001, out).outputs
    mass = 1000.0 if blocks == "one" else 1200.0
    total = (300.0 + mass) * o["support.v"] + o["momentum"]
    scale = np.abs(o["momentum"]).max()
    assert o["impacts"][-1] >= 20
    assert np.abs(o["support.v"]).max() > 1e-3 * scale / mass  # the platform does move
    assert np.abs(total).max() < 1e-12 * scale
    assert two_way_balance(o, params) < 1e-9


@pytest.mark.parametrize("scale_", [1.0, 2.0])
def test_a_stack_on_a_two_way_floor_keeps_its_energy_balance(fmu, pulse, scale_):
    """A stack on the frame's top floor, up to block 2 falling off or overturning (after which the floor carries
    the blocks): the energy balance of blocks plus building holds to 1e-9 over the whole run."""
    params = {**STACK, **frame(300.0), "excitation.kind": 4, "excitation.file": str(pulse), "excitation.scale": scale_}
    o = fmu.run(params, 6.0, 0.001, [*OUT, "block2.frictionLoss", "impactsInterface"]).outputs
    assert o["impacts"][-1] > 5 and o["impactsInterface"][-1] > 0
    assert two_way_balance(o, params) < 1e-9


def test_two_way_results_do_not_depend_on_the_communication_step(fmu, pulse):
    """The integrator runs ahead of the communication points with its dense output: the end state is the same
    to the last bit for steps of 1 ms, 50 ms and 0.3 s."""
    params = {**STACK, **frame(300.0), "excitation.kind": 4, "excitation.file": str(pulse)}
    names = [*OUT, "block2.theta", "block2.slip"]
    runs = [fmu.run(params, 3.0, h, names) for h in (0.001, 0.05, 0.3)]
    for name in names:
        assert runs[1].outputs[name][-1] == runs[0].outputs[name][-1] == runs[2].outputs[name][-1], name


@pytest.mark.parametrize("top", [2000.0, 50.0])
def test_rigid_rocking_on_a_two_way_floor_matches_the_reference(fmu, pulse, top):
    """Rigid rocking (contact.model = 0) on a two-way floor runs in the contact engine with contacts that never
    slip: against the reference's rigid block (mu infinite), the same impacts, peak within 1e-8 rad and the floor's
    displacement within 1e-8 m; its friction monitor still says how much friction rigid rocking needed (on the
    50 kg floor far more than mu = 0.5: the rocking-sliding model is the one to trust there)."""
    params = {**CABINET, **frame(top), "contact.model": 0, "excitation.kind": 4, "excitation.file": str(pulse)}
    res = fmu.run(params, 4.0, 0.001, [*OUT, "friction.demandMaxGround"])
    block = slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=np.inf, g=9.81)
    run = ref.simulate(block, ref.Building([2000.0, 2000.0, top], [2.5e6] * 3, 0.02, 3), ref.record_file(PULSE), 4.0,
                       coupling="two-way")
    o = res.outputs
    assert o["impacts"][-1] == run.impacts > 0
    assert abs(o["block1.maxAbsTheta"][-1] - run.peak_abs_theta) < 1e-8
    assert np.abs(o["support.u"] - run.sample(res.time)["floor_u"]).max() < 1e-8
    assert two_way_balance(o, params) < 1e-9
    assert (o["friction.demandMaxGround"][-1] > 0.5) == (top < 100.0)


@pytest.mark.parametrize("coupling", ["one-way", "two-way"])
def test_an_undamped_frame_matches_the_reference(fmu, pulse, coupling):
    """The frame without damping (its floor's slope has a double root where it starts from rest, which once sent
    the one-way cell search into an endless subdivision): the same impacts and peak as the reference."""
    params = {**CABINET, **frame(), "building.dampingRatio": 0.0, "support.coupling": int(coupling == "two-way"),
              "excitation.kind": 4, "excitation.file": str(pulse)}
    res = fmu.run(params, 4.0, 0.01, OUT)
    block = slide.SlidingBlock(b=0.3, h=1.0, m=1000.0, mu=0.5, g=9.81)
    run = ref.simulate(block, ref.Building([2000.0] * 3, [2.5e6] * 3, 0.0, 3), ref.record_file(PULSE), 4.0,
                       coupling=coupling)
    assert res.outputs["impacts"][-1] == run.impacts > 0
    assert abs(res.outputs["block1.maxAbsTheta"][-1] - run.peak_abs_theta) < 1e-8


def test_a_block_that_flies_off_a_two_way_platform_keeps_the_energy_balance(fmu, tmp_path):
    """A record whose vertical column drops the base faster than gravity for 50 ms: the cabinet leaves its
    platform (a flight) and lands on it again (an impact on a support of finite mass), with the energy balance of
    block plus platform held to 1e-9."""
    t = np.arange(0.0, 2.0005, 0.001)
    a = np.where(t < 1 / 3, 3.0 * np.sin(2 * np.pi * 3 * t), 0.0)
    av = np.where((t > 0.4) & (t < 0.45), -14.0, 0.0)
    path = tmp_path / "drop.txt"
    np.savetxt(path, np.column_stack([t, a, av]), fmt="%.17g")
    params = {**CABINET, "excitation.kind": 4, "excitation.file": str(path), "support.kind": 2, "support.coupling": 1,
              "platform.mass": 200.0, "platform.stiffness": 200.0 * (2 * np.pi) ** 2, "platform.damping": 0.0}
    o = fmu.run(params, 3.0, 0.01, [*OUT, "block1.flights", "block1.maxGap"]).outputs
    assert o["block1.flights"][-1] >= 1 and o["block1.maxGap"][-1] > 1e-3 and o["impacts"][-1] > 0
    assert two_way_balance(o, params) < 1e-9

