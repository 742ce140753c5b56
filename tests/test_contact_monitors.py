"""The FMU's monitors of the rigid-rocking assumptions (friction.demandMax*,
contact.normalMin*, slides/slideTime, lifts/liftTime, friction.impulseDemandMax),
checked against closed forms and against the reactions of the independent
reference (model/contact.py) at the times the FMU reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model.contact import one_block_reactions, stack_reactions
from model.reference import Block, free_rocking

G = 9.81
MON = ["friction.demandMaxGround", "contact.normalMinGround", "slides", "slideTime", "lifts", "liftTime",
       "friction.impulseDemandMax", "impacts"]
STATE = ["block1.theta", "block1.omega", "ground.ahTotal", "ground.avTotal", "atRest"]
SLENDER = {"block1.halfWidth": 0.1, "block1.halfHeight": 0.5, "block1.mass": 20.0}
SQUAT = {"block1.halfWidth": 0.25, "block1.halfHeight": 0.3, "block1.mass": 20.0, "restitution.law": 2}  # h/b = 1.2


def _final(fmu, params, stop, step=0.01, outputs=MON):
    r = fmu.run(params, stop, step, outputs=list(outputs))
    return {k: float(v[-1]) for k, v in r.outputs.items()}, r


def _state_at(fmu, params, t):
    """The outputs at time t exactly (a run that stops there)."""
    out, _ = _final(fmu, params, t, t, outputs=STATE + ["contact.groundT", "contact.groundN"])
    return out


def test_free_rocking_of_a_slender_block_keeps_the_assumptions(fmu):
    """mu = 0.7: no sliding, no flight. The extremes of the demand and of the normal force lie
    at the impacts (the slowest and the fastest states on a corner), where exact free rocking
    gives the rates: the monitors must equal the reference's reactions there. Each impact
    needs |Pt| / Pn = h (1 - eta) / (b (1 + eta)) (the momentum change about the new corner,
    eta = 1 - 1.5 sin^2(alpha), Housner 1963)."""
    b, h = SLENDER["block1.halfWidth"], SLENDER["block1.halfHeight"]
    alpha = math.atan2(b, h)
    eta = 1 - 1.5 * math.sin(alpha) ** 2
    exact = free_rocking(Block(b, h, G), 0.15, eta, 6)
    stop = 0.5 * (exact.impact_times[4] + exact.impact_times[5])  # five impacts, no rest yet
    out, r = _final(fmu, {**SLENDER, "block1.theta0": 0.15}, stop, 0.001, MON + STATE)
    assert out["impacts"] == 5 and not out["slides"] and not out["lifts"]
    assert out["slideTime"] == out["liftTime"] == -1
    assert out["friction.impulseDemandMax"] == pytest.approx(h * (1 - eta) / (b * (1 + eta)), rel=1e-12)

    def on_corner(w_toward_zero, w):  # reactions at theta = 0 on the corner the block turns about
        return one_block_reactions(math.copysign(1e-300, -w_toward_zero), w, 0.0, 0.0, b, h, 1.0, G)

    at_impacts = [on_corner(w, w) for w in exact.omega_minus[:5]]  # just before
    at_impacts += [on_corner(-w, eta * w) for w in exact.omega_minus[:5]]  # just after, on the other corner
    demand = max(abs(T) / N for T, N in at_impacts)
    normal = min(N / G for _, N in at_impacts)
    assert out["friction.demandMaxGround"] == pytest.approx(demand, rel=1e-8)
    assert out["contact.normalMinGround"] == pytest.approx(normal, rel=1e-8)
    # and no state of the run, sampled every millisecond, exceeds them
    o = r.outputs
    TN = np.array([one_block_reactions(th, w, ah, av, b, h, 1.0, G) for th, w, ah, av in
                   zip(o["block1.theta"], o["block1.omega"], o["ground.ahTotal"], o["ground.avTotal"]) if th != 0])
    assert np.max(np.abs(TN[:, 0]) / TN[:, 1]) <= demand and np.min(TN[:, 1]) / G >= normal
    assert 0 < demand < 0.7 and normal > 0


@pytest.mark.parametrize("mu", [0.5, 0.7])
def test_a_squat_block_slides_before_it_uplifts(fmu, mu):
    """mu < b/h: the table's pulse A sin(2 pi f t) reaches mu g (sliding) before g tan(alpha)
    (uplift); the slide is at asin(mu g / A) / (2 pi f) exactly."""
    A, f = 9.0, 2.0
    p = {**SQUAT, "contact.muGround": mu, "excitation.kind": 1, "excitation.amplitude": A, "excitation.frequency": f}
    out, r = _final(fmu, p, 2.0)
    b, h = SQUAT["block1.halfWidth"], SQUAT["block1.halfHeight"]
    assert mu < b / h < A / G
    t_slide = math.asin(mu * G / A) / (2 * math.pi * f)
    assert out["slides"] and abs(out["slideTime"] - t_slide) <= 1e-9
    uplift = r.event_times("uplift")
    assert len(uplift) and uplift[0] == pytest.approx(math.asin(G * b / h / A) / (2 * math.pi * f), abs=1e-9)
    assert out["slideTime"] < uplift[0]
    slides = [e for e in r.events if e.kind == "slide"]
    assert len(slides) == 1 and slides[0].t == out["slideTime"] and slides[0].labels["contact"] == "ground"


def test_a_block_with_enough_friction_rocks_and_is_clean(fmu):
    """mu above b/h and a_h above g tan(alpha): it rocks, and neither slides nor lifts."""
    p = {**SQUAT, "contact.muGround": 1.0, "excitation.kind": 1, "excitation.amplitude": 8.5,
         "excitation.frequency": 2.0}
    out, r = _final(fmu, p, 3.0)
    b, h = SQUAT["block1.halfWidth"], SQUAT["block1.halfHeight"]
    assert 1.0 > b / h and 8.5 > G * b / h
    assert len(r.event_times("uplift")) and out["impacts"] > 0
    assert not out["slides"] and not out["lifts"] and out["friction.demandMaxGround"] < 1.0


def test_sliding_while_rocking_is_where_the_reference_demand_reaches_mu(fmu):
    """Under a strong pulse the rocking block's demand |T| / N reaches mu: at the reported
    time the reference's reactions give exactly mu (the FMU located it on its dense output)."""
    b, h = SQUAT["block1.halfWidth"], SQUAT["block1.halfHeight"]
    p = {**SQUAT, "contact.muGround": 2.0, "excitation.kind": 1, "excitation.amplitude": 20.0,
         "excitation.frequency": 2.0}
    out, r = _final(fmu, p, 1.0)
    assert out["slides"] and r.event_times("uplift")[0] < out["slideTime"]
    s = _state_at(fmu, p, out["slideTime"])
    T, N = one_block_reactions(s["block1.theta"], s["block1.omega"], s["ground.ahTotal"], s["ground.avTotal"],
                               b, h, SQUAT["block1.mass"], G)
    assert abs(abs(T) - 2.0 * N) <= 1e-7 * SQUAT["block1.mass"] * G
    assert (T, N) == pytest.approx((s["contact.groundT"], s["contact.groundN"]), abs=1e-9 * SQUAT["block1.mass"] * G)


def test_flight_while_rocking_is_where_the_reference_normal_force_vanishes(fmu):
    """The same pulse, reversing while the block still rocks on its corner, pulls the
    corner off the ground: the reported lift time is where the reference's N = 0."""
    b, h = SQUAT["block1.halfWidth"], SQUAT["block1.halfHeight"]
    p = {**SQUAT, "contact.muGround": 100.0, "excitation.kind": 1, "excitation.amplitude": 20.0,
         "excitation.frequency": 2.0}
    out, r = _final(fmu, p, 1.0)
    assert out["lifts"] and out["contact.normalMinGround"] < 0
    s = _state_at(fmu, p, out["liftTime"])
    T, N = one_block_reactions(s["block1.theta"], s["block1.omega"], s["ground.ahTotal"], s["ground.avTotal"],
                               b, h, SQUAT["block1.mass"], G)
    assert abs(N) <= 1e-7 * SQUAT["block1.mass"] * G
    assert [e.t for e in r.events if e.kind == "lift"] == [out["liftTime"]]
    # as N falls to zero with T != 0 the demand |T| / N passes any mu: even mu = 100 is
    # exceeded just before, and the sliding is reported where the reference needs exactly mu
    assert out["slides"] and 0 < out["liftTime"] - out["slideTime"] < 1e-2
    s = _state_at(fmu, p, out["slideTime"])
    T, N = one_block_reactions(s["block1.theta"], s["block1.omega"], s["ground.ahTotal"], s["ground.avTotal"],
                               b, h, SQUAT["block1.mass"], G)
    assert N > 0 and abs(abs(T) - 100.0 * N) <= 1e-7 * SQUAT["block1.mass"] * G


def test_a_block_spun_hard_leaves_its_corner_at_once(fmu):
    """omega0 with R omega^2 cos(phi) above G (1 - 3/4 sin^2 phi): N < 0 at the start."""
    b, h = SLENDER["block1.halfWidth"], SLENDER["block1.halfHeight"]
    th, w = 0.05, 6.0
    T, N = one_block_reactions(th, w, 0.0, 0.0, b, h, 1.0, G)
    assert N < 0
    out, _ = _final(fmu, {**SLENDER, "block1.theta0": th, "block1.omega0": w}, 0.2)
    assert out["lifts"] and out["liftTime"] == 0.0


def test_monitors_do_not_depend_on_the_communication_step(fmu):
    p = {**SQUAT, "contact.muGround": 0.7, "excitation.kind": 1, "excitation.amplitude": 9.0,
         "excitation.frequency": 2.0}
    finals = [_final(fmu, p, 3.0, step)[0] for step in (0.01, 0.0037, 3.0)]
    for k in MON:
        assert finals[1][k] == pytest.approx(finals[0][k], rel=1e-12, abs=1e-12), k
        assert finals[2][k] == pytest.approx(finals[0][k], rel=1e-12, abs=1e-12), k


def test_stack_interface_monitors_against_the_reference(fmu):
    """Two blocks under a harmonic table motion with a slippery interface: the interface slides
    first; where its demand first reaches mu, the reference's interface forces agree."""
    p = {"nBlocks": 2, "block1.halfWidth": 0.2, "block1.halfHeight": 0.4, "block1.mass": 30.0,
         "block2.halfWidth": 0.12, "block2.halfHeight": 0.3, "block2.mass": 12.0, "restitution.law": 2,
         "excitation.kind": 3, "excitation.displacement": 0.03, "excitation.frequency": 2.5, "excitation.cycles": 4,
         "contact.muInterface": 0.3, "contact.muGround": 5.0}
    out, r = _final(fmu, p, 2.0, outputs=MON + ["friction.demandMaxInterface", "contact.normalMinInterface"])
    slides = [e for e in r.events if e.kind == "slide"]
    assert out["slides"] and slides[0].labels["contact"] == "interface" and slides[0].t == out["slideTime"]
    names = ["block1.theta", "block1.omega", "block1.alpha_dd", "block2.theta", "block2.omega", "block2.alpha_dd",
             "ground.ahTotal", "ground.avTotal", "contact.interfaceT", "contact.interfaceN"]
    s, _ = _final(fmu, p, out["slideTime"], out["slideTime"], outputs=names)
    assert abs(abs(s["contact.interfaceT"]) - 0.3 * s["contact.interfaceN"]) <= 1e-7 * 12.0 * G
    assert out["friction.demandMaxInterface"] >= 0.3


# ------------------------------------------------------- flight from the ground's vertical motion

def _linear_crossing(t: np.ndarray, a: np.ndarray, level: float) -> float:
    """First time the piecewise-linear samples a(t) fall below level."""
    i = int(np.argmax(a < level))
    assert i > 0 and a[i] < level
    return float(t[i - 1] + (level - a[i - 1]) / (a[i] - a[i - 1]) * (t[i] - t[i - 1]))


@pytest.mark.parametrize("blocks", [1, 2])
def test_a_vertical_record_below_minus_g_reports_flight_at_its_first_crossing(fmu, tmp_path, blocks):
    """A record whose vertical column falls below -g (no horizontal motion): the block on the
    ground would fly. The model holds it on its base, so the run goes on to the end, and
    reports the flight at the first instant g + a_v = 0 on the record's linear segments."""
    t = np.arange(0.0, 2.0 + 1e-9, 0.01)
    av = -12.0 * np.sin(2 * math.pi * 1.5 * t)
    path = tmp_path / "vertical.txt"
    np.savetxt(path, np.column_stack([t, 0.0 * t, av]), fmt="%.17g")
    p = {"excitation.kind": 4, "excitation.file": str(path), "nBlocks": blocks}
    out, r = _final(fmu, p, 2.0, outputs=MON + ["block1.theta", "atRest"])
    exact = _linear_crossing(t, av, -G)
    assert out["lifts"] == 1 and abs(out["liftTime"] - exact) <= 1e-9
    assert [e.kind for e in r.events] == ["lift"] and r.events[0].t == out["liftTime"]
    assert out["contact.normalMinGround"] == pytest.approx(1 + av.min() / G, rel=1e-12)  # at the deepest sample
    assert np.all(r.outputs["block1.theta"] == 0.0) and out["atRest"] == 1 and not out["slides"]


def test_a_pulse_with_a_vertical_amplitude_above_g_reports_flight_where_it_passes_minus_g(fmu):
    """A sine pulse with vertical acceleration V sin(2 pi f (t - t0)), V = -12 m/s2: the
    flight starts at t0 + asin(g / 12) / (2 pi f), to 1e-9 s."""
    f, t0 = 2.0, 0.1
    p = {"excitation.kind": 1, "excitation.amplitude": 0.0, "excitation.verticalAmplitude": -12.0,
         "excitation.frequency": f, "excitation.startTime": t0}
    out, r = _final(fmu, p, 1.0)
    assert out["lifts"] and abs(out["liftTime"] - (t0 + math.asin(G / 12.0) / (2 * math.pi * f))) <= 1e-9
    assert out["impacts"] == 0 and not r.event_times("uplift").size


def test_a_rocking_block_under_a_vertical_record_below_minus_g_lifts_where_the_reference_n_vanishes(fmu, tmp_path):
    """With a horizontal component the block uplifts first (g + a_v shrinks the threshold), and
    rocks on through the flight the model cannot follow; the reported lift-off is where the
    reference's normal force on its corner vanishes."""
    b, h = SQUAT["block1.halfWidth"], SQUAT["block1.halfHeight"]
    t = np.arange(0.0, 2.0 + 1e-9, 0.01)
    ah, av = 4.0 * np.sin(2 * math.pi * t), -12.0 * np.sin(2 * math.pi * 1.5 * t)
    path = tmp_path / "both.txt"
    np.savetxt(path, np.column_stack([t, ah, av]), fmt="%.17g")
    p = {**SQUAT, "excitation.kind": 4, "excitation.file": str(path), "contact.muGround": 100.0}
    out, r = _final(fmu, p, 2.0)
    assert out["lifts"] and r.event_times("uplift")[0] < out["liftTime"]
    s = _state_at(fmu, p, out["liftTime"])
    T, N = one_block_reactions(s["block1.theta"], s["block1.omega"], s["ground.ahTotal"], s["ground.avTotal"],
                               b, h, SQUAT["block1.mass"], G)
    assert abs(N) <= 1e-7 * SQUAT["block1.mass"] * G


# ------------------------------------------------------- the start of an overturning fall

@pytest.mark.parametrize("blocks", [1, 2])
def test_fall_time_is_where_the_blocks_last_passed_their_limits_before_overturning(fmu, blocks):
    """fallTime: the last sample with every block within its stability limit before the
    overturn. Sampled every millisecond, the motion stays beyond the limit from at most one
    integrator step after fallTime until the overturn; a run that does not overturn has -1."""
    p = {"nBlocks": blocks, "block1.halfWidth": 0.15, "block1.halfHeight": 0.6, "excitation.kind": 1,
         "excitation.amplitude": 9.0, "excitation.frequency": 1.5, "block2.halfWidth": 0.1, "block2.halfHeight": 0.4,
         "block1.mass": 10.0, "block2.mass": 5.0}
    names = ["block1.theta", "block2.theta", "overturned", "overturnTime", "fallTime"]
    r = fmu.run(p, 3.0, 1e-3, outputs=names)
    out = {k: float(v[-1]) for k, v in r.outputs.items()}
    assert out["overturned"] == 1 and 0 < out["fallTime"] < out["overturnTime"]
    b1, h1 = p["block1.halfWidth"], p["block1.halfHeight"]
    if blocks == 1:
        beyond = np.abs(r.outputs["block1.theta"]) > math.atan2(b1, h1)
    else:  # the pair about a ground corner (its centre of mass), block 2 about an end of the contact
        m1, m2, b2, h2 = p["block1.mass"], p["block2.mass"], p["block2.halfWidth"], p["block2.halfHeight"]
        y_g = (m1 * h1 + m2 * (2 * h1 + h2)) / (m1 + m2)
        beyond = (np.abs(r.outputs["block1.theta"]) > math.atan2(b1, y_g)) | \
                 (np.abs(r.outputs["block2.theta"]) > math.atan2(min(b1, b2), h2))
    falling = (r.time > out["fallTime"]) & (r.time <= out["overturnTime"])
    last_within = r.time[falling & ~beyond].max(initial=out["fallTime"])
    assert last_within - out["fallTime"] <= 0.05  # an integrator step at most
    assert np.any(beyond[falling])
    calm = fmu.run({**p, "excitation.amplitude": 2.0}, 3.0, 0.1, outputs=["overturned", "fallTime"])
    assert calm.outputs["overturned"][-1] == 0 and calm.outputs["fallTime"][-1] == -1


# ------------------------------------------------------- Model Exchange

@pytest.mark.parametrize("case", ["slides", "lifts while rocking", "free rocking", "falls"])
def test_model_exchange_locates_the_monitors_as_co_simulation_does(fmu_path, case):
    """fmpy's CVode at rtol 1e-10 integrates; the event indicators (mu N - |T|) / W and N / W
    locate the first sliding and lift-off: the times agree with Co-Simulation's to 1e-8 s,
    as do fallTime to an output interval, and, on runs without a lift-off, the extremes."""
    from fmpy import simulate_fmu

    from runners.engine.fmu import with_scene_defaults

    pulse = {"excitation.kind": 1, "excitation.frequency": 2.0}
    params = {"slides": {**SQUAT, "contact.muGround": 0.7, **pulse, "excitation.amplitude": 9.0},
              "lifts while rocking": {**SQUAT, "contact.muGround": 100.0, **pulse, "excitation.amplitude": 20.0},
              "free rocking": {**SLENDER, "block1.theta0": 0.15},
              "falls": {"block1.halfWidth": 0.03, "block1.halfHeight": 0.06, "excitation.kind": 1,
                        "excitation.amplitude": 6.0, "excitation.frequency": 1.5}}[case]
    names = MON + ["fallTime"]
    runs = [simulate_fmu(str(fmu_path), fmi_type=fmi, start_values=with_scene_defaults(params), stop_time=2.0,
                         output_interval=1e-3, output=names, **kw)
            for fmi, kw in (("CoSimulation", {}),
                            ("ModelExchange", {"solver": "CVode", "relative_tolerance": 1e-10}))]
    cs, me = ({k: float(r[k][-1]) for k in names} for r in runs)
    for k in ("slides", "lifts", "impacts"):
        assert me[k] == cs[k], k
    for k in ("slideTime", "liftTime"):
        assert abs(me[k] - cs[k]) <= 1e-8, k
    assert abs(me["fallTime"] - cs["fallTime"]) <= 2e-3
    assert me["friction.impulseDemandMax"] == pytest.approx(cs["friction.impulseDemandMax"], rel=1e-7)
    if not cs["lifts"]:
        for k in ("friction.demandMaxGround", "contact.normalMinGround"):
            assert me[k] == pytest.approx(cs[k], rel=1e-5), k
    assert (case == "free rocking") == (not cs["slides"] and not cs["lifts"])


def _locked_start_demand(A: float, side: int, b1: float, h1: float, m1: float, b2: float, h2: float, m2: float):
    """Ground reactions (T, N) of a locked pair that a step a_h = A starts rocking from rest on
    block 1's corner `side`: its angular acceleration from the pair's moment balance about the
    corner (one rigid body, theta = omega = 0), the reactions from the reference's Newton
    equations (model.contact.stack_reactions, which do not depend on how the interface
    carries its moment)."""
    px = side * b1
    bodies = [(m1, b1, h1, (0.0 - px, h1)), (m2, b2, h2, (0.0 - px, 2 * h1 + h2))]
    inertia = sum(m * ((b * b + h * h) / 3 + d[0] ** 2 + d[1] ** 2) for m, b, h, d in bodies)
    moment = sum(d[0] * (-m * G) - d[1] * (-m * A) for m, b, h, d in bodies)  # counterclockwise
    alpha = -moment / inertia  # clockwise
    r = stack_reactions(0.0, 0.0, alpha, 0.0, 0.0, alpha, side, side, A, 0.0, b1, h1, m1, b2, h2, m2, G)
    return r["ground_T"], r["ground_N"]


@pytest.mark.parametrize("start", [0.0, 0.2], ids=["at the start", "mid-run"])
def test_a_step_judges_the_instant_by_the_rocking_that_starts(fmu, start):
    """A cosine pulse is a step of a_h = A from rest (at its start time). With A / g = 0.82 above
    mu = 0.7 the slender block tips at that instant (A above g b / h): `slides` was reported at
    the step from the rest reactions m a_h, which a block that does not stay at rest never
    carries. The rocking that starts needs the reference's reactions at theta = 0+, omega = 0
    (a demand of 0.34 < mu): no sliding, and that demand is the run's first sample. With mu
    below that demand the slide is reported at the step."""
    b, h = SLENDER["block1.halfWidth"], SLENDER["block1.halfHeight"]
    A = 8.0
    T0, N0 = one_block_reactions(-1e-300, 0.0, A, 0.0, b, h, 1.0, G)  # a_h > 0 tips it onto its left corner
    demand0 = abs(T0) / N0
    assert A / G > 0.7 > demand0 and A > G * b / h
    p = {**SLENDER, "contact.muGround": 0.7, "excitation.kind": 2, "excitation.amplitude": A,
         "excitation.frequency": 1.0, "excitation.startTime": start}
    out, r = _final(fmu, p, start + 0.01, 0.001, MON + ["pattern"])
    assert r.event_times("uplift")[0] == start
    assert not out["slides"] and out["slideTime"] == -1 and not [e for e in r.events if e.kind == "slide"]
    assert out["friction.demandMaxGround"] == pytest.approx(demand0, rel=1e-12)  # the largest: the block speeds up
    tight = {**p, "contact.muGround": 0.3}
    assert demand0 > 0.3
    out, r = _final(fmu, tight, start + 0.01, 0.001)
    assert out["slides"] and out["slideTime"] == start
    assert [e.values["demand"] for e in r.events if e.kind == "slide"] == [pytest.approx(demand0, rel=1e-12)]


@pytest.mark.parametrize("start", [0.0, 0.2], ids=["at the start", "mid-run"])
def test_a_step_under_a_stack_judges_the_instant_by_the_pattern_that_starts(fmu, start):
    """The same for two blocks: the cosine pulse's step tips the pair, which starts rocking
    locked on block 1's left corner. `slides` was reported at the step with the demand A / g of
    the pair moving with the ground (0.82 > mu = 0.7); the locked pair's reactions give 0.36."""
    b1, h1, m1, b2, h2, m2, A = 0.1, 0.3, 10.0, 0.1, 0.2, 5.0, 8.0
    T0, N0 = _locked_start_demand(A, -1, b1, h1, m1, b2, h2, m2)
    demand0 = abs(T0) / N0
    assert A / G > 0.7 > demand0
    p = {"nBlocks": 2, "block1.halfWidth": b1, "block1.halfHeight": h1, "block1.mass": m1, "block2.halfWidth": b2,
         "block2.halfHeight": h2, "block2.mass": m2, "restitution.law": 0, "contact.muGround": 0.7,
         "excitation.kind": 2, "excitation.amplitude": A, "excitation.frequency": 1.0, "excitation.startTime": start}
    out, r = _final(fmu, p, start + 0.01, 0.001)
    up = [e for e in r.events if e.kind == "uplift"]
    assert up[0].t == start and up[0].labels["pattern"] == "locked"
    assert not out["slides"] and out["slideTime"] == -1
    assert out["friction.demandMaxGround"] == pytest.approx(demand0, rel=1e-12)
    out, r = _final(fmu, {**p, "contact.muGround": 0.9 * demand0}, start + 0.01, 0.001)
    assert out["slides"] and out["slideTime"] == start
