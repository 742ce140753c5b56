"""The rocking-sliding stack in the compiled FMU (nBlocks = 2, contact.model = 1) against exact and
independent references: the rigid stack where friction is large, the closed form of a Coulomb
block where the locked pair or block 2 alone slides, the energy balance, and the independent Python
solver model/stack_sliding_reference.py (its own derivation, docs/stack_sliding.md) on pulses and
FEMA P695 records."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import sliding_closed_form as scf
from model import stack_sliding_reference as ssr
from model.ground_motions import record
from runners.engine.fmu import RockingFMU

TIGHT = {"solver.relTol": 1e-12, "solver.absTol": 1e-14}
OUTPUTS = ["block1.theta", "block2.theta", "block1.slip", "block2.slip", "block1.slipRate", "block2.slipRate",
           "energy", "block1.frictionLoss", "block2.frictionLoss", "impactLoss", "groundWork", "block1.mode",
           "block2.mode", "block2.fellOff", "block2.fellOffTime", "overturned", "block1.overturned",
           "block2.overturned", "lifts", "block1.maxAbsSlip", "block2.maxAbsSlip", "impacts", "atRest",
           "block1.slides", "block2.slides", "block1.slideStartTime", "block2.slideStartTime",
           "friction.demandMaxGround", "friction.demandMaxInterface"]

# geometries (b1, h1, m1, b2, h2, m2)
STATUE = (0.3, 0.5, 450.0, 0.2, 0.8, 690.0)  # a marble statue on a plinth
BOTH_ROCK = (0.2, 0.6, 300.0, 0.15, 0.5, 100.0)  # a stack in which both blocks rock
SQUAT_TOP = (0.3, 0.5, 450.0, 0.25, 0.3, 100.0)  # a squat box on a plinth: it slides, never rocks


def stack_params(geom, mu_ground: float, mu_interface: float, **extra) -> dict:
    b1, h1, m1, b2, h2, m2 = geom
    return {"nBlocks": 2, "block1.halfWidth": b1, "block1.halfHeight": h1, "block1.mass": m1,
            "block2.halfWidth": b2, "block2.halfHeight": h2, "block2.mass": m2, "block1.theta0": 0.0,
            "contact.model": 1, "contact.muGround": mu_ground, "contact.muInterface": mu_interface,
            **TIGHT, **extra}


def pulse(amplitude: float, frequency: float) -> dict:
    return {"excitation.kind": 1, "excitation.amplitude": amplitude, "excitation.frequency": frequency}


def run(fmu: RockingFMU, params: dict, stop: float, step: float = 0.01):
    return fmu.run(params, stop, step, OUTPUTS)


def balance(res) -> np.ndarray:
    """energy + losses - ground work - energy at the start (J), while the stack is whole."""
    o = res.outputs
    e = o["energy"] + o["block1.frictionLoss"] + o["block2.frictionLoss"] + o["impactLoss"] - o["groundWork"]
    whole = (o["overturned"] == 0) & (o["block2.fellOff"] == 0)
    return (e - e[0])[whole]


def energy_scale(res) -> float:
    o = res.outputs
    return max(float(np.max(np.abs(o[k]))) for k in ("energy", "groundWork", "impactLoss", "block1.frictionLoss",
                                                       "block2.frictionLoss"))


# ---------------------------------------------------------------- limits

RIGID_KINDS = ("uplift", "open", "impact", "overturn")


def kinds_and_times(res, kinds=RIGID_KINDS):
    return [(e.kind, e.labels.get("contact", ""), e.t) for e in res.events if e.kind in kinds]


RIGID_SCENES = {
    "both rock under a sine pulse, block 2 overturns": (BOTH_ROCK, pulse(5.0, 2.0), 3.0),
    "the statue rocks on its plinth": (STATUE, pulse(4.0, 2.0), 4.0),
    "free rocking of the pair from a tilt": (BOTH_ROCK, {"block1.theta0": 0.05, "block2.theta0": 0.05}, 3.0),
    "harmonic table": (BOTH_ROCK, {"excitation.kind": 3, "excitation.displacement": 0.04,
                                   "excitation.frequency": 1.5, "excitation.cycles": 3}, 4.0),
}


@pytest.mark.parametrize("name", RIGID_SCENES)
def test_with_both_coefficients_large_the_events_are_the_rigid_stacks(fmu, name):
    geom, exc, stop = RIGID_SCENES[name]
    params = {**stack_params(geom, 1e3, 1e3), **exc}
    rigid = run(fmu, {**params, "contact.model": 0}, stop)
    sliding = run(fmu, params, stop)
    a, b = kinds_and_times(rigid), kinds_and_times(sliding)
    assert [x[:2] for x in a] == [x[:2] for x in b] and len(a) >= 3, (a, b)
    # impacts and overturns to 1e-12 s; a contact's opening to 1e-9 s: the rigid stack takes it from its
    # step's dense output (an order less accurate), the contact engine from real steps
    assert max(abs(x[2] - y[2]) for x, y in zip(a, b) if x[0] != "open") <= 1e-12
    assert max((abs(x[2] - y[2]) for x, y in zip(a, b) if x[0] == "open"), default=0.0) <= 1e-9
    assert sliding.outputs["block1.maxAbsSlip"][-1] == 0 and sliding.outputs["block2.maxAbsSlip"][-1] == 0
    for k in ("block1.theta", "block2.theta"):
        np.testing.assert_allclose(sliding.outputs[k], rigid.outputs[k], rtol=0, atol=1e-12)


def test_a_stack_that_starts_to_slide_logs_a_slide_not_an_uplift(fmu):
    """From rest, a contact that starts to slide flat logs ``slide`` (with its contact), not
    ``uplift``: the squat pair slides on the ground as one body, or block 2 on block 1, from
    t = asin(mu g / A) / (2 pi f) under the pulse A sin(2 pi f t). A stack that starts to rock
    still logs its uplift."""
    g, mu, amplitude, f = 9.81, 0.2, 4.0, 2.0
    start = math.asin(mu * g / amplitude) / (2 * math.pi * f)
    for mu_g, mu_i, contact in ((mu, 5.0, "ground"), (5.0, mu, "interface")):
        res = run(fmu, {**stack_params(SQUAT_TOP, mu_g, mu_i), **pulse(amplitude, f)}, 1.0)
        first = res.events[0]
        assert (first.kind, first.labels["contact"]) == ("slide", contact), [e.as_dict() for e in res.events[:2]]
        assert first.t == pytest.approx(start, abs=1e-12)
        assert not [e for e in res.events if e.kind == "uplift"]
    rocking = run(fmu, {**stack_params(STATUE, 1e3, 1e3), **pulse(4.0, 2.0)}, 1.0)
    assert rocking.events[0].kind == "uplift" and rocking.outputs["impacts"][-1] > 0


def test_the_locked_pair_slides_as_one_coulomb_block(fmu):
    """Ground mu small, interface mu large, a squat pair: it slides as one body of mass m1 + m2, the
    closed form of a Coulomb block on an accelerating base (to 1e-9 m)."""
    mu = 0.2
    res = run(fmu, {**stack_params(SQUAT_TOP, mu, 5.0), **pulse(4.0, 2.0)}, 2.0, step=0.005)
    exact = scf.coulomb_block(scf.sine_pulse(4.0, 2.0), mu, 2.0)
    o = res.outputs
    assert o["block1.maxAbsSlip"][-1] > 0.01 and np.all(o["block2.slip"] == 0) and np.all(o["block1.theta"] == 0)
    np.testing.assert_allclose(o["block1.slip"], exact.slip(res.time), rtol=0, atol=1e-9)
    starts = [e.t for e in res.events if e.kind == "slide"]
    assert starts[0] == pytest.approx(exact.first_slide_time, abs=1e-12)


def test_block_two_slides_on_block_one_as_on_a_table_moving_with_it(fmu):
    """Ground mu large (block 1 neither slides nor rocks), interface mu small: block 2 slides on block 1
    as a Coulomb block on a table moving with the ground (to 1e-9 m)."""
    mu = 0.2
    res = run(fmu, {**stack_params(SQUAT_TOP, 5.0, mu), **pulse(4.0, 2.0)}, 2.0, step=0.005)
    exact = scf.coulomb_block(scf.sine_pulse(4.0, 2.0), mu, 2.0)
    o = res.outputs
    assert np.all(o["block1.slip"] == 0) and np.all(o["block1.theta"] == 0) and np.all(o["block2.theta"] == 0)
    np.testing.assert_allclose(o["block2.slip"], exact.slip(res.time), rtol=0, atol=1e-9)
    stops = [e.t for e in res.events if e.kind == "stick"]
    assert stops[-1] == pytest.approx(exact.times("stick")[-1], abs=1e-12)


def test_the_stack_at_rest_starts_at_the_least_threshold(fmu):
    """A constant push just below min(mu_g, mu_i, b1 / yG, b2 / h2) g leaves the stack at rest; just
    above it the contact of that threshold moves."""
    b1, h1, m1, b2, h2, m2 = SQUAT_TOP
    y_g = (m1 * h1 + m2 * (2 * h1 + h2)) / (m1 + m2)
    for mu_g, mu_i, moving in ((0.3, 0.5, "block1.slides"), (0.5, 0.15, "block2.slides")):
        k = min(mu_g, mu_i, b1 / y_g, b2 / h2)
        assert k == min(mu_g, mu_i)
        for f, moves in ((1 - 1e-9, False), (1 + 1e-6, True)):
            p = {**stack_params(SQUAT_TOP, mu_g, mu_i), "excitation.kind": 0}
            res = fmu.run(p, 0.5, 0.1, OUTPUTS, inputs=lambda t, a=k * 9.81 * f: (a, 0.0))
            assert bool(res.outputs[moving][-1]) == moves, (mu_g, mu_i, f)


# ---------------------------------------------------------------- energy

ENERGY_SCENES = {
    "statue on a sliding plinth: slide-rock, impacts, overturn": (STATUE, 0.5, 0.5, pulse(6.0, 2.0), 3.0),
    "both blocks slide and rock": (BOTH_ROCK, 0.25, 0.3, pulse(6.0, 1.5), 3.0),
    "vertical motion too": (STATUE, 0.5, 0.5, {**pulse(5.0, 2.0), "excitation.verticalAmplitude": 3.0}, 3.0),
    "block 2 slides off its plinth": (SQUAT_TOP, 5.0, 0.1, pulse(6.0, 0.5), 3.0),
    "a cosine pulse's jump while block 2 rocks": (STATUE, 0.2, 2.0, {"excitation.kind": 2, "excitation.amplitude": 4.0,
                                                                      "excitation.frequency": 2.0,
                                                                      "excitation.startTime": 0.3,
                                                                      "block2.theta0": 0.05}, 2.0),
}


@pytest.mark.parametrize("name", ENERGY_SCENES)
def test_energy_balances_with_impacts_and_friction(fmu, name):
    geom, mg, mi, exc, stop = ENERGY_SCENES[name]
    res = run(fmu, {**stack_params(geom, mg, mi), **exc}, stop, step=0.002)
    o = res.outputs
    assert o["block1.frictionLoss"][-1] + o["block2.frictionLoss"][-1] > 0
    err = balance(res)
    assert err.size > 10 and np.max(np.abs(err)) <= 1e-9 * energy_scale(res)
    assert np.all(np.diff(o["block1.frictionLoss"]) >= -1e-12) and np.all(np.diff(o["block2.frictionLoss"]) >= -1e-12)
    assert np.all(np.diff(o["impactLoss"]) >= -1e-12)
    # the monitors see a model that holds: no contact needs more friction than it has
    if not o["lifts"][-1]:
        assert o["friction.demandMaxGround"][-1] <= mg * (1 + 1e-9)
        assert o["friction.demandMaxInterface"][-1] <= mi * (1 + 1e-9)


def test_block_two_falls_off_and_that_is_not_an_overturn(fmu):
    res = run(fmu, {**stack_params(SQUAT_TOP, 5.0, 0.1), **pulse(6.0, 0.5)}, 3.0)
    o = res.outputs
    assert o["block2.fellOff"][-1] == 1 and o["block2.overturned"][-1] == 0 and o["overturned"][-1] == 0
    t_off = o["block2.fellOffTime"][-1]
    assert 0 < t_off < 3 and [e.t for e in res.events if e.kind == "fell-off"] == [t_off]
    assert o["block2.mode"][-1] == 5


def test_a_sliding_block_two_tips_about_the_edge_where_its_normal_forces_resultant_reaches_it(fmu):
    """Block 2 sliding flat on a plinth that does not move (wide and heavy) keeps standing with an overhang once its
    corner passes the plinth's edge (the contact at that end is then the plinth's corner against block 2's base,
    docs/columns.md, "Overhangs"), and its other end opens where the resultant of its normal forces reaches the
    edge: sliding, its friction mu_i N at depth h2 puts the resultant mu_i h2 ahead of its centre
    (docs/stack_sliding.md, "Falling off"), so it tips about the plinth's corner at |u2| = b1 - mu_i h2, to the
    located event (measured 1e-16 m), and falls off the top later. The old engine ended the run there as a
    fall-off."""
    b1, h2, mu_i = 0.6, 0.3, 0.1
    geom = (b1, 0.2, 5000.0, 0.25, h2, 100.0)
    params = {**stack_params(geom, 5.0, mu_i), **pulse(6.0, 0.5)}
    res = run(fmu, params, 3.0)
    kinds = [e.kind for e in res.events]
    assert "overhang" in kinds and kinds.index("overhang") < kinds.index("open")
    t_open = [e.t for e in res.events if e.kind == "open"][0]
    at = fmu.run(params, t_open, t_open / 100, ["block2.slip", "block2.theta"])
    assert abs(at.outputs["block2.slip"][-1]) == pytest.approx(b1 - mu_i * h2, abs=1e-9)
    assert abs(at.outputs["block2.slip"][-1]) > b1 - 0.25 + 0.1  # well past the instant its corner left the top
    (off,) = [e for e in res.events if e.kind == "fell-off"]
    assert off.t > t_open
    assert np.all(res.outputs["block1.theta"] == 0.0)


# ---------------------------------------------------------------- the independent solver

def reference_stack(geom, mu_ground: float, mu_interface: float) -> ssr.SlidingStack:
    return ssr.SlidingStack(*geom, mu_ground=mu_ground, mu_interface=mu_interface)


def sine_ground(amplitude: float, frequency: float, vertical: float = 0.0):
    T = 1.0 / frequency

    def ground(t: float) -> tuple[float, float]:
        s = math.sin(2 * math.pi * frequency * t) if 0 <= t < T else 0.0
        return amplitude * s, vertical * s
    return ground, (T,)


def compare(res, ref: ssr.StackRun, tol: float = 1e-8) -> None:
    """Impact and overturn times, mode-switch times per contact, slips and the energy terms."""
    imp = [(e.labels.get("contact"), e.t) for e in res.events if e.kind == "impact"]
    rimp = [(e.contact, e.t) for e in ref.events if e.kind == "impact"]
    assert [c for c, _ in imp] == [c for c, _ in rimp], (imp, rimp)
    np.testing.assert_allclose([t for _, t in imp], [t for _, t in rimp], rtol=0, atol=tol)
    got, want = fmu_slide_changes(res), ref_slide_changes(ref)
    assert [x[1:] for x in got] == [x[1:] for x in want], (got, want)
    np.testing.assert_allclose([x[0] for x in got], [x[0] for x in want], rtol=0, atol=tol)
    o = res.outputs
    for k, (name, comp) in enumerate((("block1", 0), ("block2", 1))):
        assert o[f"{name}.maxAbsSlip"][-1] == pytest.approx(ref.peak_abs_slip[comp], abs=tol)
        assert o[f"{name}.slip"][-1] == pytest.approx(ref.final_slip[comp], abs=tol)
    ot = [e.t for e in res.events if e.kind == "overturn"]
    rot = [t for t in ref.overturn_time if t is not None]
    np.testing.assert_allclose(ot, rot, rtol=0, atol=tol)
    scale = energy_scale(res)
    assert o["block1.frictionLoss"][-1] == pytest.approx(ref.friction_loss[0], abs=tol * scale)
    assert o["block2.frictionLoss"][-1] == pytest.approx(ref.friction_loss[1], abs=tol * scale)
    assert o["impactLoss"][-1] == pytest.approx(ref.impact_loss, abs=tol * scale)
    assert o["groundWork"][-1] == pytest.approx(ref.ground_work, abs=tol * scale)


def _net_changes(steps: list[tuple[float, str, bool]]) -> list[tuple[float, str, bool]]:
    """The net change of each contact's sliding state per instant, from (t, contact, sliding) steps."""
    state = {"ground": False, "interface": False}
    out = []
    times = sorted({t for t, _, _ in steps})
    for t in times:
        before = dict(state)
        for tt, c, sliding in steps:
            if tt == t:
                state[c] = sliding
        out += [(t, c, state[c]) for c in ("ground", "interface") if state[c] != before[c]]
    return out


def fmu_slide_changes(res) -> list:
    """(time, contact, 1 if it starts sliding else 0) of the FMU's slide and stick events, net per instant."""
    steps = [(e.t, e.labels.get("contact"), e.kind == "slide") for e in res.events if e.kind in ("slide", "stick")]
    return [(t, c, float(sl)) for t, c, sl in _net_changes(steps)]


def ref_slide_changes(ref: ssr.StackRun) -> list:
    """The same from the reference's patterns after each event (label ground/interface)."""
    steps = []
    for e in ref.events:
        if e.pattern:
            g, i = e.pattern.split("/")
            steps += [(e.t, "ground", g.startswith("slide")), (e.t, "interface", i.startswith("slide"))]
    return [(t, c, float(sl)) for t, c, sl in _net_changes(steps)]


PULSES = {
    "statue on a sliding plinth (slide-rock, impacts, the statue overturns)": (STATUE, 0.5, 0.5, 6.0, 2.0, 3.0),
    "the statue slides and rocks on a sticking plinth": (STATUE, 2.0, 0.22, 4.0, 2.0, 3.0),
    "both blocks slide and rock": (BOTH_ROCK, 0.25, 0.3, 6.0, 1.5, 3.0),
    "the locked pair slides and reverses": (SQUAT_TOP, 0.2, 5.0, 4.0, 2.0, 2.0),
}


@pytest.mark.parametrize("case", PULSES)
def test_the_fmu_agrees_with_the_reference_on_pulses(fmu, case):
    geom, mg, mi, amp, f, stop = PULSES[case]
    ground, breaks = sine_ground(amp, f)
    ref = ssr.simulate(reference_stack(geom, mg, mi), stop, ground, breaks)
    res = run(fmu, {**stack_params(geom, mg, mi), **pulse(amp, f)}, stop)
    assert len(ref.events) >= 3
    compare(res, ref)


RECORDS = {  # FEMA P695 record, component, scale, geometry, mu ground, mu interface, stop time
    "far-field 1a x1.5, statue on a plinth": ("farfield", 1, "a", 1.5, STATUE, 0.5, 0.5, 15.0),
    "near-field 1a x1, statue on a plinth": ("nearfield_pulse", 1, "a", 1.0, STATUE, 0.5, 0.5, 10.0),
}


@pytest.mark.parametrize("case", RECORDS)
def test_the_fmu_agrees_with_the_reference_on_fema_records(fmu, tmp_path, case):
    from tests.test_records_fmu import fema_component, write_record

    record_set, index, component, scale, geom, mg, mi, stop = RECORDS[case]
    t, a = fema_component(record_set, index, component)
    t, a = np.append(t, t[-1] + (t[1] - t[0])), np.append(a, 0.0)  # ends without a jump
    path = write_record(tmp_path / "record.txt", t, a)
    ground, breaks = record(t, a, scale=scale)
    ref = ssr.simulate(reference_stack(geom, mg, mi), stop, ground, breaks)
    assert sum(e.kind in ("slip", "stick", "impact") for e in ref.events) >= 5
    res = run(fmu, {**stack_params(geom, mg, mi), "excitation.kind": 4, "excitation.file": str(path),
                    "excitation.scale": scale}, stop)
    compare(res, ref)


# ---------------------------------------------------------------- the FMU's contract

def test_results_do_not_depend_on_the_communication_step(fmu):
    params = {**stack_params(STATUE, 0.5, 0.5), **pulse(6.0, 2.0)}
    a = run(fmu, params, 3.0, step=0.1)
    b = run(fmu, params, 3.0, step=0.001)
    idx = np.rint(a.time / 0.001).astype(int)
    assert np.allclose(b.time[idx], a.time, rtol=0, atol=1e-12)
    for k in ("block1.theta", "block2.theta", "block1.slip", "block2.slip", "energy"):
        np.testing.assert_allclose(a.outputs[k], b.outputs[k][idx], rtol=1e-13, atol=1e-12)
    assert [(e.kind, e.t) for e in a.events] == [(e.kind, e.t) for e in b.events]


def test_a_squat_block_one_runs_with_the_momentum_law(fmu):
    """Housner's one-block coefficient is negative for b/h > sqrt(2), but a stack's law 0 is the plastic
    impact (no coefficient): a squat plinth is no reason to refuse the stack."""
    res = run(fmu, {**stack_params((0.6, 0.2, 300.0, 0.2, 0.5, 50.0), 0.6, 0.6), **pulse(8.0, 2.0)}, 2.0)
    assert res.outputs["block2.maxAbsSlip"][-1] + abs(res.outputs["block2.theta"]).max() > 0


def test_a_wider_block_two_is_refused_in_one_line(fmu):
    with pytest.raises(Exception) as err:
        run(fmu, {**stack_params(STATUE, 0.5, 0.5), "block2.halfWidth": 0.35}, 1.0)
    assert "no wider than block 1" in str(err.value) and "\n" not in str(err.value).strip()


def test_serialized_states_in_every_mode_continue_as_the_run_did(fmu_path):
    """States taken at rest, while both blocks rock, while the statue slide-rocks on the resting plinth
    and after it overturned are accepted by the state checks and continue to the bit."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)), modelIdentifier="RockingBlock")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    for k, v in {**stack_params(STATUE, 0.5, 0.5), **pulse(6.0, 2.0)}.items():
        (s.setInteger if isinstance(v, int) else s.setReal)([vr[k]], [v])
    s.enterInitializationMode()
    s.exitInitializationMode()
    names = ["block1.slip", "block2.slip", "block1.theta", "block2.theta", "groundWork", "block1.frictionLoss"]
    seen = set()
    t = 0.0
    for _ in range(300):
        modes = tuple(s.getInteger([vr["block1.mode"], vr["block2.mode"]]))
        if modes not in seen:
            seen.add(modes)
            blob = s.serializeFMUstate(s.getFMUstate())
            first = []
            for i in range(20):
                s.doStep(t + 0.01 * i, 0.01)
                first.append(s.getReal([vr[n] for n in names]))
            s.setFMUstate(s.deSerializeFMUstate(blob))
            again = []
            for i in range(20):
                s.doStep(t + 0.01 * i, 0.01)
                again.append(s.getReal([vr[n] for n in names]))
            assert first == again, modes
            t += 0.2
        else:
            s.doStep(t, 0.01)
            t += 0.01
    s.terminate()
    s.freeInstance()
    assert {(0, 0), (2, 0), (2, 2), (0, 2), (0, 3), (0, 4)} <= seen, seen  # rest, rocking, the statue slide-rocks, overturned


def test_the_marble_pulse_overturns_block_two_at_the_same_time_at_every_tolerance(fmu):
    """The marble statue on its plinth under a 6 m/s2, 1.5 Hz one-sine pulse: block 2 overturns (and
    nothing else happens to the stack) at every solver.relTol from 1e-4 to 1e-12, at the time of the
    tightest run to 1e-2 s from 1e-4 to 1e-6 and to 1e-5 s below."""
    params = {**stack_params(STATUE, 0.5, 0.5), **pulse(6.0, 1.5)}
    outs = ["block2.overturned", "block1.overturned", "block2.fellOff", "overturnTime"]
    runs = {tol: fmu.run({**params, "solver.relTol": tol, "solver.absTol": 1e-14}, 4.0, 0.01, outs).outputs
            for tol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)}
    ref = runs[1e-12]["overturnTime"][-1]
    assert 1.9 < ref < 2.1
    for tol, o in runs.items():
        final = {k: o[k][-1] for k in outs}
        assert (final["block2.overturned"], final["block1.overturned"], final["block2.fellOff"]) == (1, 0, 0), tol
        assert abs(final["overturnTime"] - ref) <= (1e-2 if tol >= 1e-6 else 1e-5), tol


@pytest.mark.parametrize("m2", [80.0, 300.0 * 3000, 300.0 / 3000])
@pytest.mark.parametrize("b2", [0.15, 0.149, 0.1499999])
def test_a_mirrored_pulse_mirrors_the_stack_at_any_mass_ratio(fmu, m2, b2):
    """A statue on a plinth of its own width (or a hair narrower) under a +9 m/s2 and a -9 m/s2 pulse, block 2
    from 1/3000 to 3000 times block 1's mass: the mirrored run (angles and slips negated, to 1e-9 of their
    scale) and the same outcome, whatever it is (fell off, overturned, flights)."""
    outs = ["block1.theta", "block2.theta", "block1.slip", "block2.slip", "block2.fellOff", "block1.overturned",
            "block2.overturned", "block1.flights", "block2.flights"]
    geom = (0.15, 0.5, 300.0, b2, 0.4, m2)
    a, b = (fmu.run({**stack_params(geom, 0.5, 0.5), **pulse(sign * 9.0, 2.0)}, 3.0, 0.01, outs).outputs
            for sign in (1, -1))
    for k in ("block1.theta", "block2.theta", "block1.slip", "block2.slip"):
        scale = max(1e-3, float(np.max(np.abs(a[k]))))
        assert np.max(np.abs(a[k] + b[k])) <= 1e-9 * scale, k
    for k in outs[4:]:
        assert a[k][-1] == b[k][-1], k
