"""Two stacked blocks (nBlocks = 2) in RockingBlock.fmu, checked against the
independent Python reference (model/two_blocks.py), exact invariants and the
one-block model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import build_container
from model import two_blocks as tb
from runners.engine.fmu import FMUError, with_scene_defaults

TALL = dict(b1=0.1, h1=0.3, m1=10.0, b2=0.1, h2=0.2, m2=5.0)
# seed 000 Table 2: Block 1 (lower) and Block 4 (upper), half dimensions
SEED = dict(b1=0.0145, h1=0.060, m1=1.3, b2=0.030, h2=0.050, m2=2.3)
# a slender upper block on a squat lower block: the upper one lifts first
SLENDER_TOP = dict(b1=0.2, h1=0.2, m1=20.0, b2=0.05, h2=0.25, m2=3.0)
PATTERN = {"rest": 1, "overturned": 2, "upper": 3, "locked": 4, "both": 5}
STATE = ["block1.theta", "block1.omega", "block2.theta", "block2.omega"]


def params(g: dict, **extra) -> dict:
    p = {"nBlocks": 2, "block1.halfWidth": g["b1"], "block1.halfHeight": g["h1"], "block1.mass": g["m1"],
         "block2.halfWidth": g["b2"], "block2.halfHeight": g["h2"], "block2.mass": g["m2"]}
    p.update(extra)
    return p


def stack(g: dict) -> tb.Stack:
    return tb.Stack(g["b1"], g["h1"], g["m1"], g["b2"], g["h2"], g["m2"])


def mirrored(p: dict) -> dict:
    q = dict(p)
    for k in ("block1.theta0", "block1.omega0", "block2.theta0", "block2.omega0", "excitation.amplitude",
              "excitation.displacement"):
        if k in q:
            q[k] = -q[k]
    return q


# ----------------------------------------------------------- equations of motion

def _initial_accelerations(fmu, p):
    r = fmu.run(p, 1e-3, 1e-3, outputs=["block1.alpha_dd", "block2.alpha_dd", "pattern"], events=False)
    return r.outputs["block1.alpha_dd"][0], r.outputs["block2.alpha_dd"][0], int(r.outputs["pattern"][0])


@pytest.mark.parametrize("geom", [TALL, SEED], ids=["tall", "seed"])
def test_accelerations_match_the_jacobian_form_reference(fmu, geom):
    """C (expanded Lagrange form) against Python (Jacobian form) at random states, to 1e-12."""
    rng = np.random.default_rng(7)
    st = stack(geom)
    worst = 0.0
    for _ in range(12):
        th1, ph = rng.uniform(0.02, 0.4) * rng.choice([-1, 1]), rng.uniform(0.02, 0.4) * rng.choice([-1, 1])
        w1, w2 = rng.uniform(-2, 2, size=2)
        ah, av = rng.uniform(-4, 4), rng.uniform(-3, 3)
        ground = {"excitation.kind": 2, "excitation.amplitude": ah, "excitation.verticalAmplitude": av}
        a1, a2, pat = _initial_accelerations(fmu, params(geom, **ground, **{
            "block1.theta0": th1, "block1.omega0": w1, "block2.theta0": th1 + ph, "block2.omega0": w2}))
        assert pat == PATTERN["both"]
        ref = tb.accelerations(st, [th1, th1 + ph], [w1, w2], int(np.sign(th1)), int(np.sign(ph)), ah, av)
        worst = max(worst, np.max(np.abs(np.array([a1, a2]) - ref)) / np.max(np.abs(ref)))
    assert worst < 1e-12


def test_locked_and_upper_accelerations_match_the_reference(fmu):
    st = stack(TALL)
    ground = {"excitation.kind": 2, "excitation.amplitude": 0.7, "excitation.verticalAmplitude": -0.4}
    a1, a2, pat = _initial_accelerations(fmu, params(TALL, **ground, **{
        "block1.theta0": 0.04, "block1.omega0": -0.1, "block2.theta0": 0.04, "block2.omega0": -0.1}))
    assert pat == PATTERN["locked"] and a1 == a2
    assert abs(a1 / tb.locked_acceleration(st, 0.04, -0.1, 1, 1, 0.7, -0.4) - 1) < 1e-12
    ground["excitation.amplitude"] = 0.1
    a1, a2, pat = _initial_accelerations(fmu, params(TALL, **ground, **{"block2.theta0": -0.05, "block2.omega0": 0.1}))
    assert pat == PATTERN["upper"] and a1 == 0.0
    assert abs(a2 / tb.upper_acceleration(st, -0.05, 0.1, -1, 0.1, -0.4) - 1) < 1e-12


@pytest.mark.parametrize("pattern", ["locked", "upper"])
def test_closed_contacts_open_where_the_reference_reaction_would_pull(fmu, pattern):
    """The FMU starts a closed contact only if the reference's reaction margins allow it."""
    rng = np.random.default_rng(11)
    st = stack(TALL)
    seen = set()
    for _ in range(40):
        big = 3.0 if pattern == "locked" else 1.0  # the seated interface is the stronger contact
        th, w = rng.uniform(-0.1, 0.1), rng.uniform(-big, big)
        ah, av = rng.uniform(-3 * big, 3 * big), rng.uniform(-2, 2)
        ground = {"excitation.kind": 2, "excitation.amplitude": ah, "excitation.verticalAmplitude": av}
        if pattern == "locked":
            start = {"block1.theta0": th, "block1.omega0": w, "block2.theta0": th, "block2.omega0": w}
            q, ww, s1, s2 = [th, th], [w, w], int(np.sign(th)), int(np.sign(th))
        else:
            start = {"block2.theta0": th, "block2.omega0": w}
            q, ww, s1, s2 = [0.0, th], [0.0, w], int(np.sign(th)), int(np.sign(th))
        margins = tb.contact_margins(st, pattern, q, ww, s1, s2, ah, av)
        if abs(margins.min()) < 1e-6:
            continue
        holds = margins.min() > 0
        _, _, pat = _initial_accelerations(fmu, params(TALL, **ground, **start))
        assert pat == (PATTERN[pattern] if holds else PATTERN["both"]), (th, w, ah, av, margins)
        seen.add(holds)
    assert seen == {True, False}


# ------------------------------------------------------------------ symmetry

CONFIGS = {
    "opposite": {"block1.theta0": 0.05, "block2.theta0": -0.08},  # seed 000 Fig. 14
    "same": {"block1.theta0": 0.03, "block2.theta0": 0.09},  # seed 000 Fig. 15
}
FORCING = {
    "free": {},
    "harmonic": {"excitation.kind": 3, "excitation.frequency": 2.0, "excitation.displacement": 0.04,
                 "excitation.cycles": 0},
}


@pytest.mark.parametrize("forcing", FORCING, ids=list(FORCING))
@pytest.mark.parametrize("config", CONFIGS, ids=list(CONFIGS))
@pytest.mark.parametrize("law", [{"restitution.law": 0}, {"restitution.law": 2}], ids=["momentum", "constant"])
def test_mirrored_start_and_excitation_give_the_mirrored_trajectory(fmu, config, forcing, law):
    p = params(TALL, **CONFIGS[config], **FORCING[forcing], **law)
    a = fmu.run(p, 4.0, 2e-3, outputs=STATE + ["impactsGround", "impactsInterface", "pattern"])
    b = fmu.run(mirrored(p), 4.0, 2e-3, outputs=STATE + ["impactsGround", "impactsInterface", "pattern"])
    assert a.outputs["impactsGround"][-1] + a.outputs["impactsInterface"][-1] > 5
    for k in STATE:
        scale = np.max(np.abs(a.outputs[k]))
        assert np.max(np.abs(a.outputs[k] + b.outputs[k])) <= 1e-12 * scale, k
    for k in ("impactsGround", "impactsInterface", "pattern"):
        np.testing.assert_array_equal(a.outputs[k], b.outputs[k])


def test_mirrored_input_signals_give_the_mirrored_trajectory(fmu):
    """The same through ground.ah set by the importer (exercises the roll-back at input changes)."""
    p = params(TALL, **{"block1.theta0": 0.02, "block2.theta0": -0.03})
    a = fmu.run(p, 3.0, 5e-3, outputs=STATE, inputs=lambda t: (3.0 * math.sin(9.0 * t), 0.5 * math.cos(4.0 * t)))
    b = fmu.run(mirrored(p), 3.0, 5e-3, outputs=STATE,
                inputs=lambda t: (-3.0 * math.sin(9.0 * t), 0.5 * math.cos(4.0 * t)))
    for k in STATE:
        assert np.max(np.abs(a.outputs[k] + b.outputs[k])) <= 1e-12 * np.max(np.abs(a.outputs[k])), k


# ------------------------------------------------------------ energy, momentum

def test_free_motion_conserves_energy_between_impacts(fmu):
    """Elastic constant restitution (eta = 1): only the integrator can change the energy, 5 s."""
    p = params(TALL, **CONFIGS["opposite"], **{"restitution.law": 2, "restitution.etaGround": 1.0,
                                               "restitution.etaInterface": 1.0})
    r = fmu.run(p, 5.0, 1e-3, outputs=["energy", "impacts"])
    E, n = r.outputs["energy"], r.outputs["impacts"]
    quiet = np.diff(n) == 0  # sample intervals without an impact
    assert n[-1] >= 10 and quiet.sum() > 4000
    net = abs(np.sum(np.diff(E)[quiet])) / E[0]  # net change away from impacts over 5 s
    segment = np.concatenate([[0], np.cumsum(~quiet)])  # samples between two impacts
    worst = max(np.max(np.abs(E[segment == k] - E[segment == k][0])) for k in np.unique(segment)) / E[0]
    assert net < 1e-9 and worst < 1e-9


def _impacts(result):
    for e in result.events:
        if e.kind != "impact":
            continue
        frm = [int(x) if i else x for i, x in enumerate(e.labels["from"].split(":"))]
        to = [int(x) if i else x for i, x in enumerate(e.labels["to"].split(":"))]
        v = e.values
        yield e.labels["contact"], frm, to, np.array([v["theta1"], v["theta2"]]), \
            np.array([v["w1m"], v["w2m"]]), np.array([v["w1p"], v["w2p"]])


def _conserved(st, contact, frm, to, q, w, pivots):
    """Angular momenta about the points where the impact's impulses have no moment."""
    s1, s2 = pivots
    out = []
    if contact == "ground" or frm[0] == "both" or to[0] == "both":  # the pair about block 1's ground pivot
        if not (contact == "interface" and frm[0] == "upper" and to[0] == "upper"):
            out.append(tb.angular_momentum(st, q, w, s1, s2, (to[1] * st.b1, 0.0)))
    if to[0] != "locked":  # block 2 about its pivot after the impact
        out.append(tb.angular_momentum(st, q, w, s1, s2, tb.pivot_K(st, q, to[1], to[2]), blocks=(2,)))
    return np.array(out)


MOMENTUM_CASES = {
    "free": (TALL, CONFIGS["opposite"]),  # ground and interface impacts, both rocking, then locked
    "harmonic": (TALL, {**CONFIGS["opposite"], **FORCING["harmonic"]}),  # and locked pairs that open
    "upper": (SLENDER_TOP, {"excitation.kind": 1, "excitation.frequency": 4.0,  # block 2 alone on block 1
                            "excitation.amplitude": 1.3 * 9.81 * 0.2}),
}


@pytest.mark.parametrize("case", MOMENTUM_CASES, ids=list(MOMENTUM_CASES))
def test_impacts_conserve_the_momenta_of_the_momentum_law_and_never_add_energy(fmu, case):
    geom, extra = MOMENTUM_CASES[case]
    r = fmu.run(params(geom, **{"restitution.law": 0}, **extra), 4.0, 0.01, outputs=["impacts"])
    st = stack(geom)
    n, kinds = 0, set()
    for contact, frm, to, q, wm, wp in _impacts(r):
        kinds.add((contact, frm[0], to[0]))
        before = _conserved(st, contact, frm, to, q, wm, (frm[1], frm[2]))
        after = _conserved(st, contact, frm, to, q, wp, (to[1], to[2]))
        scale = max(np.max(np.abs(before)), 1e-300)
        assert np.max(np.abs(after - before)) <= 1e-12 * scale, (contact, frm, to)
        Em = tb.energy(st, q, wm, frm[1], frm[2])
        Ep = tb.energy(st, q, wp, to[1], to[2])
        assert Ep <= Em + 1e-13 * abs(Em)
        n += 1
    assert n >= 5, kinds
    expected = {("interface", "upper", "upper")} if case == "upper" else {
        ("ground", "both", "both"), ("interface", "both", "both"), ("ground", "locked", "locked")}
    assert expected <= kinds, kinds


def test_constant_restitution_removes_the_kinetic_energy_fraction_one_minus_eta_squared(fmu):
    p = params(TALL, **CONFIGS["opposite"], **{"restitution.law": 2, "restitution.etaGround": 0.95,
                                               "restitution.etaInterface": 0.98})
    st = stack(TALL)
    r = fmu.run(p, 2.0, 0.01, outputs=["impacts"])
    n = 0
    for contact, frm, to, q, wm, wp in _impacts(r):
        eta = 0.95 if contact == "ground" else 0.98
        Tm = tb.energy(st, q, wm, frm[1], frm[2]) - tb.energy(st, q, [0, 0], frm[1], frm[2])
        Tp = tb.energy(st, q, wp, to[1], to[2]) - tb.energy(st, q, [0, 0], to[1], to[2])
        assert abs(Tp / Tm - eta**2) < 1e-12
        n += 1
    assert n >= 5


# ------------------------------------------------------ limits: one block

@pytest.mark.parametrize("law", [{"restitution.law": 0}, {"restitution.law": 2, "restitution.etaGround": 0.9}],
                         ids=["momentum", "constant"])
@pytest.mark.parametrize("b,h1,h2", [(0.1, 0.2, 0.2), (0.2, 0.15, 0.25)])
def test_a_locked_pair_is_the_single_block_of_the_combined_body(fmu, law, b, h1, h2):
    """Equal widths, equal densities: the pair is one rectangle 2b x 2(h1 + h2)."""
    rho = 50.0
    pair = {"nBlocks": 2, "block1.halfWidth": b, "block1.halfHeight": h1, "block1.mass": rho * h1,
            "block2.halfWidth": b, "block2.halfHeight": h2, "block2.mass": rho * h2,
            "block1.theta0": 0.1, "block2.theta0": 0.1, **law}
    # through the stack's integrator, Dormand-Prince (the default, auto, takes the Taylor series for
    # one block): the same steps, so equal to 1e-12
    one = {"block1.halfWidth": b, "block1.halfHeight": h1 + h2, "block1.mass": rho * (h1 + h2),
           "block1.theta0": 0.1, "restitution.law": law["restitution.law"], "restitution.eta": 0.9,
           "solver.method": 0}
    a = fmu.run(pair, 4.0, 2e-3, outputs=STATE + ["locked", "impacts"], events=False)
    s = fmu.run(one, 4.0, 2e-3, outputs=["block1.theta", "block1.omega", "impacts"], events=False)
    assert a.outputs["impacts"][-1] == s.outputs["impacts"][-1] >= 10
    np.testing.assert_array_equal(a.outputs["block1.theta"], a.outputs["block2.theta"])
    assert np.max(np.abs(a.outputs["block1.theta"] - s.outputs["block1.theta"])) < 1e-12
    assert np.max(np.abs(a.outputs["block1.omega"] - s.outputs["block1.omega"])) < 1e-10


def test_a_negligible_upper_block_leaves_the_lower_block_alone(fmu):
    """Upper block of mass eps * m1 and size ~ eps^(1/3): the lower block's error falls like eps."""
    lower = {"block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0, "block1.theta0": 0.1}
    s = fmu.run(lower, 4.0, 2e-3, outputs=["block1.theta"], events=False)
    errors = []
    for eps in (1e-6, 1e-9):
        top = {"nBlocks": 2, "block2.halfWidth": 0.1 * eps ** (1 / 3), "block2.halfHeight": 0.05 * eps ** (1 / 3),
               "block2.mass": 10.0 * eps, "block2.theta0": 0.1}
        a = fmu.run({**lower, **top}, 4.0, 2e-3, outputs=["block1.theta"], events=False)
        errors.append(np.max(np.abs(a.outputs["block1.theta"] - s.outputs["block1.theta"])))
    assert errors[1] < 1e-8
    assert errors[0] / errors[1] > 300


# ------------------------------------------------------------- patterns

def _thresholds(g):
    y_g = (g["m1"] * g["h1"] + g["m2"] * (2 * g["h1"] + g["h2"])) / (g["m1"] + g["m2"])
    return 9.81 * g["b1"] / y_g, 9.81 * min(g["b1"], g["b2"]) / g["h2"]  # pair, upper block


@pytest.mark.parametrize("geom,pattern", [(TALL, "locked"), (SLENDER_TOP, "upper")], ids=["pair", "upper"])
def test_uplift_from_rest_starts_the_pattern_of_the_lower_static_threshold(fmu, geom, pattern):
    pair, upper = _thresholds(geom)
    threshold = min(pair, upper)
    assert (pattern == "locked") == (pair < upper)
    A, f = 1.2 * threshold, 2.0
    r = fmu.run(params(geom, **{"excitation.kind": 1, "excitation.amplitude": A, "excitation.frequency": f}),
                0.3, 0.01, outputs=["pattern"])
    uplift = [e for e in r.events if e.kind == "uplift"]
    assert uplift and uplift[0].labels["pattern"] == pattern and uplift[0].values["side"] == -1
    t_exact = math.asin(threshold / A) / (2 * math.pi * f)  # a_h = A sin(2 pi f t) reaches the threshold
    assert abs(uplift[0].t - t_exact) < 1e-12
    assert int(r.outputs["pattern"][-1]) == PATTERN[pattern]


def test_chattering_upper_block_locks_onto_the_lower_one(fmu):
    """Seed 000 Fig. 15: after the first collisions the pair moves as one body."""
    r = fmu.run(params(TALL, **CONFIGS["same"], **{"restitution.law": 0}), 3.0, 0.01,
                outputs=["pattern", "impactsInterface", "locked"])
    settles = [e for e in r.events if e.kind == "settle"]
    assert any(e.labels["pattern"] == "locked" for e in settles)
    assert r.outputs["impactsInterface"][-1] < 50
    assert r.outputs["locked"][-1] == 1


def test_a_locked_pair_opens_when_the_interface_cannot_hold(fmu):
    r = fmu.run(params(SEED, **{"restitution.law": 2, "excitation.kind": 3, "excitation.frequency": 5.5,
                                "excitation.displacement": 0.003, "excitation.cycles": 0}), 10.0, 0.01,
                outputs=["pattern", "block1.overturned", "block2.overturned"])
    opened = [e for e in r.events if e.kind == "open"]
    assert opened and opened[0].labels["contact"] == "interface"
    i = np.searchsorted(r.time, opened[0].t)
    assert r.outputs["pattern"][i - 1] == PATTERN["locked"] and r.outputs["pattern"][i + 1] != PATTERN["locked"]


SEED_CASES = [(7.0, 0.003), (5.5, 0.003), (3.0, 0.005), (4.0, 0.003)]


@pytest.mark.parametrize("f,d", SEED_CASES, ids=[f"{f}Hz-{1e3 * d:g}mm" for f, d in SEED_CASES])
def test_seed_forced_cases_run_ten_seconds(fmu, f, d):
    """Seed 000 Fig. 17 (Blocks 1 and 4, harmonic table motion): no stall, no error."""
    p = params(SEED, **{"restitution.law": 2, "restitution.etaGround": 0.95, "restitution.etaInterface": 0.98,
                        "excitation.kind": 3, "excitation.frequency": f, "excitation.displacement": d,
                        "excitation.cycles": 0})
    r = fmu.run(p, 10.0, 0.01, outputs=STATE + ["impacts", "overturned", "energy"])
    assert r.time[-1] == 10.0
    assert all(np.all(np.isfinite(r.outputs[k])) for k in STATE)
    assert r.outputs["impacts"][-1] < 2000
    if f == 7.0:  # the thesis's periodic case: rocks, does not overturn
        assert r.outputs["overturned"][-1] == 0 and r.outputs["impacts"][-1] > 50


CHAOTIC = dict(b1=0.1557, h1=0.1981, m1=10.3113, b2=0.2328, h2=0.4936, m2=14.3977)  # found by a random search


@pytest.mark.parametrize("scene", ["tall", "chaotic"])
def test_results_do_not_depend_on_the_communication_step(fmu, scene):
    if scene == "tall":
        p = params(TALL, **CONFIGS["opposite"], **FORCING["harmonic"])
    else:  # settles, lifts off again from rest, 69 impacts: sensitive to any difference
        p = params(CHAOTIC, **{"restitution.law": 2, "excitation.kind": 3, "excitation.frequency": 3.3584,
                               "excitation.displacement": 0.011, "excitation.cycles": 0})
    fine = fmu.run(p, 4.0, 1e-3, outputs=STATE + ["impacts"], events=False)
    coarse = fmu.run(p, 4.0, 0.05, outputs=STATE + ["impacts"], events=False)
    assert fine.outputs["impacts"][-1] > 20
    for k in STATE + ["impacts"]:
        np.testing.assert_allclose(coarse.outputs[k], fine.outputs[k][::50], rtol=0, atol=1e-12)


def test_a_stack_landing_at_negligible_rates_comes_to_rest(fmu):
    """A scene of the random search that once looped between patterns at one instant."""
    geom = dict(b1=0.18693, h1=0.35326, m1=13.3065, b2=0.225, h2=0.81452, m2=9.3348)
    p = params(geom, **{"restitution.law": 2, "restitution.etaGround": 0.605, "restitution.etaInterface": 0.9458,
                        "excitation.kind": 1, "excitation.frequency": 1.98018, "excitation.amplitude": -7.5189})
    r = fmu.run(p, 5.0, 0.05, outputs=["pattern", "impacts"])
    assert r.outputs["pattern"][-1] == PATTERN["rest"]
    assert any(e.kind == "settle" and e.labels["pattern"] == "rest" for e in r.events)


# ------------------------------------------------------------ bad input

@pytest.mark.parametrize("extra,text", [
    ({"nBlocks": 9}, "nBlocks"),
    ({"block2.mass": 0.0}, "block2.mass"),
    ({"block2.halfWidth": -0.1}, "block2.halfWidth"),
    ({"block2.halfHeight": math.nan}, "block2.halfHeight"),
    ({"restitution.law": 1}, "restitution.law"),
    ({"restitution.correction": 1.1}, "restitution.correction"),
    ({"restitution.etaGround": 1.5}, "restitution.etaGround"),
    ({"restitution.etaInterface": -0.1}, "restitution.etaInterface"),
    ({"block2.theta0": 1.7}, "block2.theta0"),
    ({"solver.earlyOverturn": True}, "solver.earlyOverturn"),
])
def test_invalid_two_block_parameters_are_errors(fmu, extra, text):
    with pytest.raises(FMUError) as exc:
        fmu.run(params(TALL, **extra), 0.1, 0.1)
    assert text in str(exc.value)


# ------------------------------------------------------------- importers

def test_two_blocks_through_fmpy_simulate_and_the_container(fmu_path, fmu, tmp_path):
    p = with_scene_defaults(params(SEED, **{"restitution.law": 2, "excitation.kind": 3, "excitation.frequency": 7.0,
                                            "excitation.displacement": 0.003, "excitation.cycles": 0}))
    ours = fmu.run(p, 3.0, 0.02, outputs=["block1.theta", "block2.theta", "impactsGround"], events=False)
    assert ours.outputs["impactsGround"][-1] > 10
    r = simulate_fmu(str(fmu_path), start_values=p, stop_time=3.0, output_interval=0.02,
                     output=["block1.theta", "block2.theta"])
    np.testing.assert_allclose(r["block2.theta"], ours.outputs["block2.theta"], rtol=0, atol=1e-12)

    container = build_container(fmu_path, tmp_path, 0.005)
    c = simulate_fmu(str(container), start_values={f"rockingblock.{k}": v for k, v in p.items()},
                     stop_time=3.0, output_interval=0.02, output=["block1.theta", "block2.theta"])
    np.testing.assert_allclose(c["block1.theta"], ours.outputs["block1.theta"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(c["block2.theta"], ours.outputs["block2.theta"], rtol=0, atol=1e-12)


def test_fmu_state_round_trip_for_two_blocks(fmu):
    """getFMUstate / setFMUstate reproduce the continuation bit for bit."""
    messages: list[str] = []
    s, _cb = fmu.instantiate(lambda st, cat, msg: messages.append(msg))
    vr = [fmu.vars[k].valueReference for k in STATE]
    try:
        s.setupExperiment(startTime=0.0)
        fmu.set_parameters(s, params(TALL, **CONFIGS["opposite"], **FORCING["harmonic"]))
        s.enterInitializationMode()
        s.exitInitializationMode()
        for i in range(10):
            s.doStep(0.1 * i, 0.1)
        state = s.getFMUstate()
        first = []
        for i in range(10, 20):
            s.doStep(0.1 * i, 0.1)
            first.append(s.getReal(vr))
        s.setFMUstate(state)
        again = []
        for i in range(10, 20):
            s.doStep(0.1 * i, 0.1)
            again.append(s.getReal(vr))
        s.freeFMUstate(state)
        assert again == first
    finally:
        s.freeInstance()


def test_one_block_fills_the_shared_outputs_consistently(fmu):
    """pattern, impactsGround and block1.overturned mean the same for one block."""
    r = fmu.run({"block1.theta0": 0.2}, 3.0, 0.01, outputs=["pattern", "impacts", "impactsGround", "atRest"],
                events=False)
    o = r.outputs
    np.testing.assert_array_equal(o["impactsGround"], o["impacts"])
    np.testing.assert_array_equal(o["pattern"], np.where(o["atRest"] == 1, PATTERN["rest"], 0))
    assert o["atRest"][-1] == 1 and o["atRest"][0] == 0
    r = fmu.run({"excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 2.0}, 3.0, 0.01,
                outputs=["overturned", "block1.overturned", "pattern"], events=False)
    np.testing.assert_array_equal(r.outputs["overturned"], r.outputs["block1.overturned"])
    assert r.outputs["overturned"][-1] == 1 and r.outputs["pattern"][-1] == PATTERN["overturned"]
