"""Physics of RockingBlock.fmu against exact and independent references."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model.reference import Block, free_rocking, housner_restitution, modified_restitution

GEOMETRIES = [(0.1, 0.3), (0.0225, 0.050625)]  # h/b = 3, and seed 003 B3M (h/b = 2.25, half dimensions)
LAWS = [
    ("housner", {"restitution.law": 0}, lambda a: housner_restitution(a)),
    ("modified", {"restitution.law": 1, "restitution.k": 0.7595}, lambda a: modified_restitution(a, 0.7595)),
    ("constant", {"restitution.law": 2, "restitution.eta": 0.9, "restitution.correction": 1.05},
     lambda a: 0.9 * 1.05),
]


def rel(a, b):
    return np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0))


@pytest.mark.parametrize("b,h", GEOMETRIES)
@pytest.mark.parametrize("law", LAWS, ids=[l[0] for l in LAWS])
def test_free_rocking_matches_exact_reference(fmu, b, h, law):
    name, params, eta_of = law
    blk = Block(b, h)
    theta0 = 0.6 * blk.alpha
    ref = free_rocking(blk, theta0, eta_of(blk.alpha), 10)
    p = {"block1.halfWidth": b, "block1.halfHeight": h, "block1.theta0": theta0, **params}
    r = fmu.run(p, ref.impact_times[-1] + 0.01, 0.01)
    impacts = r.event_times("impact")[:10]
    peaks_t = r.event_times("peak")[:10]
    peaks = r.event_values("peak", "theta")[:10]
    omega_minus = r.event_values("impact", "omega_minus")[:10]
    assert len(impacts) == 10 and len(peaks) >= 9
    assert rel(impacts, ref.impact_times) < 1e-8
    assert rel(omega_minus, ref.omega_minus) < 1e-8
    n = len(peaks)
    assert rel(peaks_t, ref.peak_times[:n]) < 1e-8
    assert rel(peaks, ref.peak_thetas[:n]) < 1e-8


def _pulse(amplitude, frequency=3.0, **extra):
    return {"excitation.kind": 1, "excitation.amplitude": amplitude, "excitation.frequency": frequency, **extra}


@pytest.mark.parametrize("params", [
    _pulse(5.0),                        # rocks, many impacts, comes to rest
    _pulse(4.0, 1.0),                   # overturns after an impact
    {"excitation.kind": 3, "excitation.displacement": 0.003, "excitation.frequency": 7.0, "excitation.cycles": 0,
     "block1.halfWidth": 0.03, "block1.halfHeight": 0.0675, "restitution.correction": 1.2},
])
def test_results_do_not_depend_on_the_communication_step(fmu, params):
    fine = fmu.run(params, 5.0, 1e-3)
    one = fmu.run(params, 5.0, 5.0)
    assert len(fine.events) == len(one.events) > 0
    for kind in ("impact", "peak"):
        a, b = fine.event_times(kind), one.event_times(kind)
        assert a == pytest.approx(b, rel=1e-9, abs=0)
    np.testing.assert_allclose(fine.event_values("peak", "theta"), one.event_values("peak", "theta"), rtol=1e-9)
    for k in ("block1.theta", "block1.omega", "impacts", "overturned", "atRest"):
        assert fine.outputs[k][-1] == pytest.approx(one.outputs[k][-1], rel=1e-9, abs=1e-15)


def test_interpolated_outputs_follow_the_trajectory(fmu):
    """Outputs between internal steps come from the dense output: compare a 1 ms
    sampling with the state reached by stepping exactly to each sample time."""
    p = _pulse(5.0)
    r = fmu.run(p, 2.0, 1e-3, outputs=["block1.theta", "block1.omega"])
    for t_end in (0.312, 0.901, 1.5):
        s = fmu.run(p, t_end, t_end, outputs=["block1.theta"])
        i = int(round(t_end / 1e-3))
        assert abs(r.time[i] - t_end) < 1e-12
        assert s.outputs["block1.theta"][-1] == pytest.approx(r.outputs["block1.theta"][i], abs=1e-9)


@pytest.mark.parametrize("b,h", GEOMETRIES)
def test_uplift_threshold(fmu, b, h):
    thr = 9.81 * b / h
    base = {"block1.halfWidth": b, "block1.halfHeight": h}
    below = fmu.run({**base, **_pulse(0.999 * thr)}, 2.0, 1e-3, outputs=["block1.maxAbsTheta", "atRest", "impacts"])
    assert np.all(below.outputs["block1.maxAbsTheta"] == 0.0)
    assert np.all(below.outputs["atRest"] == 1.0)
    for sign in (+1, -1):
        a = sign * 1.001 * thr
        above = fmu.run({**base, **_pulse(a)}, 2.0, 1e-3, outputs=["block1.theta", "atRest"])
        theta = above.outputs["block1.theta"]
        first = theta[np.nonzero(theta)[0][0]]
        # a_h > 0 pushes the ground to +x: the block tips onto its left corner (theta < 0)
        assert np.sign(first) == -sign
        uplift = above.event_times("uplift")
        t_star = math.asin(1 / 1.001) / (2 * math.pi * 3.0)
        assert uplift[0] == pytest.approx(t_star, rel=1e-12)


def test_uplift_threshold_includes_vertical_acceleration(fmu):
    # a_h = -A s(t) tips the block to the right when A s > (g + a_v) tan(alpha);
    # with a_v = -V s(t) (ground dropping) uplift comes at s = g tan / (A + V tan)
    b, h, A, V = 0.1, 0.3, 4.0, 3.0
    tan = b / h
    s_star = 9.81 * tan / (A + V * tan)
    r = fmu.run({**_pulse(-A), "excitation.verticalAmplitude": -V}, 1.0, 1e-2)
    t_star = math.asin(s_star) / (2 * math.pi * 3.0)
    assert r.event_times("uplift")[0] == pytest.approx(t_star, rel=1e-12)
    assert r.event_values("uplift", "side")[0] == 1
    # without the vertical component the same pulse stays below the threshold longer
    r0 = fmu.run(_pulse(-A), 1.0, 1e-2)
    assert r0.event_times("uplift")[0] > t_star


def test_energy_is_conserved_without_dissipation(fmu):
    p = {"block1.theta0": 0.25, "restitution.law": 2, "restitution.eta": 1.0}
    r = fmu.run(p, 5.0, 1e-3, outputs=["energy", "impacts"])
    e = r.outputs["energy"]
    assert r.outputs["impacts"][-1] >= 5
    assert np.max(np.abs(e / e[0] - 1)) < 1e-9


def test_impacts_never_increase_energy_and_rest_is_reached(fmu):
    blk = Block(0.1, 0.3)
    eta = housner_restitution(blk.alpha)
    r = fmu.run({"block1.theta0": 0.2}, 5.0, 1e-3, outputs=["energy", "atRest", "impacts"])
    e = r.outputs["energy"]
    assert np.all(np.diff(e) <= 1e-9 * e[0])
    assert r.outputs["atRest"][-1] == 1.0
    # the rest impact is the first whose exact rebound peak is below restRatio * alpha
    ref = free_rocking(blk, 0.2, eta, 60)
    expected = 1 + int(np.argmax(np.abs(ref.peak_thetas) < 1e-6 * blk.alpha))
    assert r.outputs["impacts"][-1] == expected
    assert r.event_times("rest")[0] == pytest.approx(ref.impact_times[expected - 1], rel=1e-8)


def test_overturn_is_an_event_and_the_state_freezes(fmu):
    r = fmu.run(_pulse(6.0, 2.0), 5.0, 1e-2, outputs=["block1.theta", "block1.omega", "overturned", "overturnTime", "energy"])
    assert r.outputs["overturned"][-1] == 1.0
    t_over = r.outputs["overturnTime"][-1]
    assert r.event_times("overturn")[0] == t_over
    after = r.time > t_over
    th = r.outputs["block1.theta"][after]
    assert np.all(np.abs(th) == math.pi / 2)
    assert np.all(r.outputs["block1.omega"][after] == 0.0)
    assert np.all(np.isfinite(r.outputs["energy"]))


@pytest.mark.parametrize("theta0_over_alpha,omega0,falls", [
    (1.10, -0.05, True),   # past alpha moving inwards, too little energy to get back: falls
    (1.10, -0.5, False),   # past alpha moving inwards with enough energy: returns, then decays
    (1.02, +0.01, True),   # past alpha moving outwards: falls
])
def test_early_overturn_decision_matches_integration(fmu, theta0_over_alpha, omega0, falls):
    alpha = math.atan(1 / 3)
    p = {"block1.theta0": theta0_over_alpha * alpha, "block1.omega0": omega0}
    late = fmu.run(p, 5.0, 5.0, outputs=["overturned"], events=False)
    early = fmu.run({**p, "solver.earlyOverturn": True}, 5.0, 5.0, outputs=["overturned"], events=False)
    assert bool(late.outputs["overturned"][-1]) == falls
    assert bool(early.outputs["overturned"][-1]) == falls


def test_early_overturn_agrees_with_integration_on_a_map(fmu):
    thr = 9.81 / 3
    disagreements = 0
    for a in np.linspace(1.05, 8.0, 12) * thr:
        for f in np.linspace(0.5, 4.0, 12):
            p = _pulse(a, f)
            late = fmu.run(p, 8.0, 8.0, outputs=["overturned"], events=False)
            early = fmu.run({**p, "solver.earlyOverturn": True}, 8.0, 8.0, outputs=["overturned"], events=False)
            disagreements += late.outputs["overturned"][-1] != early.outputs["overturned"][-1]
    assert disagreements == 0


def test_no_peak_is_hidden_inside_a_long_step(fmu):
    """Harmonic forcing makes omega change sign several times per second; with one
    huge communication step every sign change seen at 0.1 ms sampling is still found."""
    p = {"excitation.kind": 3, "excitation.displacement": 0.004, "excitation.frequency": 6.0, "excitation.cycles": 0,
         "block1.halfWidth": 0.03, "block1.halfHeight": 0.0675, "restitution.correction": 1.2,
         "solver.relTol": 1e-6}
    fine = fmu.run(p, 3.0, 1e-4, outputs=["block1.omega", "peaks"], events=False)
    w = fine.outputs["block1.omega"]
    nz = w[w != 0]
    sign_changes = int(np.sum(np.sign(nz[1:]) != np.sign(nz[:-1])))
    one = fmu.run(p, 3.0, 3.0, outputs=["peaks"], events=False)
    assert sign_changes > 10
    assert one.outputs["peaks"][-1] == fine.outputs["peaks"][-1] >= sign_changes


def test_inputs_drive_the_block(fmu):
    thr = 9.81 / 3
    r = fmu.run({}, 1.0, 1e-3, outputs=["block1.theta", "ground.ahTotal"], inputs=lambda t: (-1.5 * thr, 0.0))
    assert np.all(r.outputs["ground.ahTotal"][1:] == -1.5 * thr)
    assert r.outputs["block1.theta"][-1] > 0  # ground pushed to -x: tips onto its right corner
