"""The stack's rocking-sliding reference (model/stack_sliding_reference.py) against exact references:
the rigid stack (model/two_block_solver.py) where friction is large, the closed form of a Coulomb
block on an accelerating base (model/sliding_closed_form.py) where one contact alone slides, the
energy balance, Newton-Euler residuals of every pattern, impacts that never add energy, and
falling off at block 1's edge (docs/stack_sliding.md)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from model import sliding_closed_form as scf
from model import stack_sliding_reference as ssr
from model import two_block_solver as tbs
from model import two_blocks as tb

GEOM = (0.2, 0.6, 300.0, 0.15, 0.5, 100.0)  # b1, h1, m1, b2, h2, m2: both blocks rock
STATUE = (0.3, 0.5, 900.0, 0.2, 0.8, 690.0)  # a statue on a plinth


def rigid_events(sol: tbs.StackSolution) -> list[tuple[str, str, float]]:
    kinds = {"uplift": "start"}
    which = "ground" if sol.overturned[0] else "interface"
    return [(kinds.get(e.kind, e.kind), which if e.kind == "overturn" else e.contact, e.t)
            for e in sol.events if e.kind != "settle"]


def our_events(run: ssr.StackRun) -> list[tuple[str, str, float]]:
    return [(e.kind, e.contact, e.t) for e in run.events if e.kind in ("start", "impact", "open", "overturn")]


def assert_same_events(a, b, tol: float, n_min: int) -> None:
    assert len(a) == len(b) and len(a) >= n_min, (len(a), len(b))
    for x, y in zip(a, b):
        assert x[:2] == y[:2], (x, y)
        assert abs(x[2] - y[2]) < tol, (x, y)


def energy_scale(run: ssr.StackRun) -> float:
    return max(np.max(np.abs(run.energy())), run.friction_loss[0] + run.friction_loss[1] + run.impact_loss,
               abs(run.ground_work))


# ------------------------------------------------------------------------------ (a) the rigid limit


@pytest.mark.parametrize("theta0", [(0.05, -0.04), (-0.03, 0.06)])
def test_rigid_limit_free_rocking_from_opposite_tilts(theta0):
    """Both mu = 1000: the rigid stack's events (impacts and their contacts) over 1 s (15 and more
    impacts; later, as the rates die out, the rigid reference itself moves by 1e-8 s between
    tolerances) to 1e-9 s, no slip."""
    st = ssr.SlidingStack(*GEOM, mu_ground=1000.0, mu_interface=1000.0)
    ref = tbs.solve_stack(tbs.StackScene(tb.Stack(*GEOM), theta0=theta0), 1.0, rtol=1e-12, atol=1e-14)
    run = ssr.simulate(st, 1.0, q0=(0.0, theta0[0], 0.0, theta0[1]), atol=1e-14)
    assert_same_events(rigid_events(ref), our_events(run), 1e-9, 15)
    assert run.peak_abs_slip == (0.0, 0.0)


@pytest.mark.parametrize("law", ["momentum", "constant"])
def test_rigid_limit_harmonic_table(law):
    """Both mu = 1000 under a harmonic table motion from rest: uplift, openings and impacts of the
    rigid stack to 1e-9 s."""
    st = ssr.SlidingStack(*GEOM, mu_ground=1000.0, mu_interface=1000.0, law=law)
    gr = scf.harmonic(0.02, 2.0)
    scene = tbs.StackScene(tb.Stack(*GEOM), law=law, ground=gr, breaks=gr.breaks())
    ref = tbs.solve_stack(scene, 3.0, rtol=1e-12, atol=1e-12)
    run = ssr.simulate(st, 3.0, gr, gr.breaks())
    assert_same_events(rigid_events(ref), our_events(run), 1e-9, 10)
    assert run.peak_abs_slip == (0.0, 0.0)


# -------------------------------------------------------------------- (b), (c) one contact slides


def test_pair_slides_as_one_body():
    """Ground mu 0.2 (below the pair's b1 / yG), interface mu 1.5: the pair stays locked and flat and
    slides as one Coulomb block with the total mass: slip to 1e-9 m, switches to 1e-9 s."""
    st = ssr.SlidingStack(0.5, 0.3, 200.0, 0.3, 0.25, 80.0, mu_ground=0.2, mu_interface=1.5)
    gr = scf.sine_pulse(4.0, 2.0, cycles=2)
    run = ssr.simulate(st, 2.0, gr, gr.breaks())
    exact = scf.coulomb_block(gr, 0.2, 2.0)
    assert_slides_as_closed_form(run, exact, 5)


def test_pair_slides_as_one_body_on_a_harmonic_table_with_vertical_motion():
    """The same pair on a harmonic table (3 cycles) with a vertical sine of 2 m/s^2: the closed form with
    ``G = g + a_v(t)``, slip to 1e-9 m and every switch (slides, reversals, sticks) to 1e-9 s."""
    st = ssr.SlidingStack(0.5, 0.3, 200.0, 0.3, 0.25, 80.0, mu_ground=0.25, mu_interface=1.5)
    gr = scf.harmonic(0.05, 1.5, cycles=3, vertical=2.0)
    run = ssr.simulate(st, 3.0, gr, gr.breaks())
    exact = scf.coulomb_block(gr, 0.25, 3.0)
    assert_slides_as_closed_form(run, exact, 6)


def assert_slides_as_closed_form(run: ssr.StackRun, exact, n_min: int) -> None:
    assert np.max(np.abs(run.y[0] - exact.slip(run.t))) < 1e-9
    assert np.max(np.abs(run.y[1:4])) == 0.0
    assert abs(run.peak_abs_slip[0] - exact.max_abs_slip) < 1e-9
    kinds = {"start": "slide", "reverse": "reverse", "stick": "stick"}
    ours = [(kinds[e.kind], e.t) for e in run.events if e.kind in kinds]
    theirs = [(s.kind, s.t) for s in exact.switches]
    assert [k for k, _ in ours] == [k for k, _ in theirs] and len(ours) >= n_min, (ours, theirs)
    assert max(abs(a[1] - b[1]) for a, b in zip(ours, theirs)) < 1e-9


def test_upper_block_slides_on_block_at_rest():
    """Ground mu 2, interface mu 0.25 (below b2 / h2): block 1 stays at rest and block 2 slides on it as
    a Coulomb block on a table moving with the ground: slip to 1e-9 m."""
    st = ssr.SlidingStack(0.5, 0.3, 200.0, 0.2, 0.25, 80.0, mu_ground=2.0, mu_interface=0.25)
    gr = scf.sine_pulse(4.0, 2.0, cycles=2)
    run = ssr.simulate(st, 2.0, gr, gr.breaks())
    exact = scf.coulomb_block(gr, 0.25, 2.0)
    assert np.max(np.abs(run.y[2] - exact.slip(run.t))) < 1e-9
    assert np.max(np.abs(run.y[[0, 1, 3]])) == 0.0
    assert abs(run.final_slip[1] - exact.residual_slip) < 1e-9


# ------------------------------------------------------------------------------------ (d) energy


@pytest.mark.parametrize("case", [
    (STATUE, 0.5, 0.5, 6.0, 1.5),  # rocking, slide-rocking, impacts at both contacts, overturn
    ((0.3, 0.3, 500.0, 0.25, 0.45, 200.0), 0.5, 0.45, 8.0, 2.0),  # flat slides at both contacts
])
def test_energy_balance_with_impacts_and_friction(case):
    """E + friction losses + impact losses = E(0) + ground work, to 1e-9 of the energy scale."""
    geom, mg, mi, amp, f = case
    st = ssr.SlidingStack(*geom, mu_ground=mg, mu_interface=mi)
    gr = scf.sine_pulse(amp, f, cycles=2)
    run = ssr.simulate(st, 4.0, gr, gr.breaks())
    assert run.friction_loss[0] > 0 and run.friction_loss[1] > 0
    assert np.max(np.abs(run.balance_error())) < 1e-9 * energy_scale(run)


def random_landing(rng, landing: str):
    """A random stack and pattern landing at one contact, with the pre-impact rates."""
    geom = (rng.uniform(0.1, 0.5), rng.uniform(0.2, 1.0), rng.uniform(10, 1000),
            0, rng.uniform(0.1, 1.0), rng.uniform(10, 1000))
    geom = geom[:3] + (rng.uniform(0.3, 1.0) * geom[0],) + geom[4:]
    law = str(rng.choice(["momentum", "constant"]))
    st = ssr.SlidingStack(*geom, mu_ground=rng.uniform(0.1, 1.2), mu_interface=rng.uniform(0.1, 1.2), law=law,
                          eta_ground=rng.uniform(0.5, 1.0), eta_interface=rng.uniform(0.5, 1.0))
    s1, s2 = int(rng.choice([-1, 1])), int(rng.choice([-1, 1]))
    sg1, sg2 = int(rng.choice([-1, 0, 1])), int(rng.choice([-1, 0, 1]))
    q = np.array([rng.uniform(-0.05, 0.05), 0.0, rng.uniform(-0.05, 0.05), 0.0])
    w = rng.normal(size=4)
    if landing == "ground":
        flat_i = rng.random() < 0.4
        q[3] = 0.0 if flat_i else s2 * rng.uniform(0.01, 0.3)
        w[1] = -s1 * abs(w[1])
        if flat_i:
            w[3] = w[1]
        pat = ssr.Pattern(ssr.ContactMode(False, s1, sg1), ssr.ContactMode(flat_i, s2, sg2))
    else:
        flat_g = rng.random() < 0.4
        q[1] = 0.0 if flat_g else s1 * rng.uniform(0.01, 0.3)
        q[3] = q[1]
        if flat_g:
            w[1] = 0.0
        w[3] = w[1] - s2 * abs(rng.normal())
        pat = ssr.Pattern(ssr.ContactMode(flat_g, s1, sg1), ssr.ContactMode(False, s2, sg2))
    if pat.ground.flat and pat.ground.sigma == 0:
        w[0] = 0.0
    if pat.interface.flat and pat.interface.sigma == 0:
        w[2] = 0.0
    return st, pat, q, w


def test_impacts_never_add_energy():
    """400 random landings (either contact, every kind of the other contact, both laws, slip rates
    before the impact): the kinetic energy after is at most the one before. Random rates can ask
    for a pulling impulse at the landing contact itself (a flight the model leaves out): the
    reference then says so; that stays rare."""
    rng = np.random.default_rng(27)
    n_slide = n_refused = 0
    for k in range(400):
        landing = "ground" if k % 2 else "interface"
        st, pat, q, w = random_landing(rng, landing)
        try:
            imp = ssr.impact(st, landing, pat, q, w)
        except ssr.StackReferenceError:
            n_refused += 1
            continue
        n_slide += imp.pattern.ground.slides or imp.pattern.interface.slides
        ke_minus = ssr.kinetic_energy(st, q, w, pat.ground.s, pat.interface.s)
        ke_plus = ssr.kinetic_energy(st, q, imp.w, imp.pattern.ground.s, imp.pattern.interface.s)
        assert ke_plus <= ke_minus * (1 + 1e-12), (k, ke_minus, ke_plus)
    assert n_slide > 50  # sliding impacts were exercised
    assert n_refused <= 10


# ------------------------------------------------------------------ (e) Newton-Euler of every pattern


def centres(st: ssr.SlidingStack, q, s1: int, s2: int) -> np.ndarray:
    """Centres of both blocks written out from the geometry (not from the module's kinematics)."""
    u1, th1, u2, th2 = q
    c1, n1, c2, n2 = math.cos(th1), math.sin(th1), math.cos(th2), math.sin(th2)
    px = s1 * st.b1 + u1  # ground pivot
    # body-1 vector (x, y) turned clockwise by th1: (x c + y s, -x s + y c)
    x, y = -s1 * st.b1, st.h1
    r1 = (px + x * c1 + y * n1, -x * n1 + y * c1)
    x, y = s2 * st.b2 + u2 - s1 * st.b1, 2 * st.h1
    K = (px + x * c1 + y * n1, -x * n1 + y * c1)
    x, y = -s2 * st.b2, st.h2
    r2 = (K[0] + x * c2 + y * n2, K[1] - x * n2 + y * c2)
    return np.array([*r1, *r2])


def all_patterns():
    for gflat, gs, gsg, iflat, is_, isg in itertools.product((True, False), (1, -1), (0, 1, -1),
                                                            (True, False), (1, -1), (0, 1, -1)):
        yield ssr.Pattern(ssr.ContactMode(gflat, gs, gsg), ssr.ContactMode(iflat, is_, isg))


def test_every_pattern_satisfies_newton_euler():
    """For all 144 patterns at random states: the solved accelerations and forces leave Newton-Euler
    residuals below 1e-9 of the weights, the centres' accelerations equal the second derivative of
    the positions along the motion (finite differences), and each contact's two rows hold."""
    rng = np.random.default_rng(3)
    for pat in all_patterns():
        st = ssr.SlidingStack(0.3, 0.5, 400.0, 0.2, 0.6, 150.0, mu_ground=rng.uniform(0.2, 1.0),
                              mu_interface=rng.uniform(0.2, 1.0))
        q = np.array([rng.uniform(-.1, .1), 0.0 if pat.ground.flat else pat.ground.s * rng.uniform(0, 0.4),
                      rng.uniform(-.05, .05), 0.0])
        q[3] = q[1] + (0.0 if pat.interface.flat else pat.interface.s * rng.uniform(0, 0.4))
        w = rng.normal(size=4)
        w[1] = 0.0 if pat.ground.flat else w[1]
        w[3] = w[1] if pat.interface.flat else w[3]
        ah, av = rng.normal(0, 3), rng.normal(0, 1)
        sol = ssr.solve_pattern(st, pat, q, w, ah, av)
        res = ssr.residuals(st, sol, ah, av)
        assert np.max(np.abs(res)) < 1e-9 * (st.m1 + st.m2) * st.g, (pat, res)
        h = 1e-4
        r = [centres(st, q + w * t + 0.5 * sol.qdd * t * t, pat.ground.s, pat.interface.s) for t in (-h, 0, h)]
        fd = (r[0] - 2 * r[1] + r[2]) / h**2
        acc = np.concatenate([sol.kin.J1 @ sol.qdd + sol.kin.c1, sol.kin.J2 @ sol.qdd + sol.kin.c2])
        assert np.max(np.abs(fd - acc)) < 1e-5 * (1 + np.max(np.abs(acc))), (pat, fd, acc)
        T0, N0, M0, T1, N1, M1 = sol.forces
        if pat.ground.slides:
            assert abs(T0 + pat.ground.sigma * st.mu_ground * N0) < 1e-9 * st.m1 * st.g
        else:
            assert sol.qdd[0] == 0.0
        if pat.interface.slides:
            assert abs(T1 + pat.interface.sigma * st.mu_interface * N1) < 1e-9 * st.m2 * st.g
        else:
            assert sol.qdd[2] == 0.0
        assert (sol.qdd[1] == 0.0) if pat.ground.flat else abs(M0) < 1e-9 * st.m1 * st.g
        assert (sol.qdd[3] == sol.qdd[1]) if pat.interface.flat else abs(M1) < 1e-9 * st.m2 * st.g


def test_single_block_limit_of_slide_rock():
    """Block 2 vanishing (m2 -> 0): block 1's slide-rock equations are the one-block model's
    (docs/sliding.md: w' = q (G - R cos(phi) w^2) / (R D))."""
    st = ssr.SlidingStack(0.3, 0.5, 400.0, 0.2, 0.6, 1e-9, mu_ground=0.4, mu_interface=0.5)
    s, sigma, th, om, av = -1, 1, -0.07, -0.4, 0.8
    pat = ssr.Pattern(ssr.ContactMode(False, s, sigma), ssr.ContactMode(True, s, 0))
    sol = ssr.solve_pattern(st, pat, [0.0, th, 0.0, th], [0.3, om, 0.0, om], 1.0, av)
    R, alpha, G = math.hypot(st.b1, st.h1), math.atan2(st.b1, st.h1), st.g + av
    phi = s * alpha - th
    qq = sigma * st.mu_ground * math.cos(phi) - math.sin(phi)
    D = 1 / 3 - qq * math.sin(phi)
    wdot = qq * (G - R * math.cos(phi) * om**2) / (R * D)
    assert abs(sol.qdd[1] - wdot) < 1e-8 * abs(wdot)


def test_single_block_limit_of_the_impact_law():
    """Block 2 vanishing and locked: a ground landing gives the one-block impact law with friction
    (model/sliding_reference.impact, Housner's eta: sticking, sliding and flat landings, with and
    without a slip rate before) to 1e-9 in the rates after."""
    from model import sliding_reference as sr

    rng = np.random.default_rng(11)
    n_sliding = n_flat = n = 0
    for _ in range(600):
        b, h, mu = rng.uniform(0.1, 0.5), rng.uniform(0.3, 1.0), rng.uniform(0.1, 1.2)
        s = int(rng.choice([-1, 1]))
        wm, vm = -s * abs(rng.normal()), rng.normal() * 2.0 * rng.integers(0, 2)
        ref = sr.impact(sr.SlidingBlock(b, h, mu, m=10.0), s, wm, vm, 0.0, 0.0)
        flat_landing = ref.flat and abs(ref.Pn + 10.0 * s * b * wm) < 1e-12
        if ref.flat and not flat_landing:
            continue  # the one-block reference's rest rule (a negligible rebound), not the impact law
        st = ssr.SlidingStack(b, h, 10.0, 1e-3 * b, 1e-3, 1e-9, mu_ground=mu, mu_interface=5.0)
        sg = 0 if vm == 0 else int(np.sign(vm))
        pat = ssr.Pattern(ssr.ContactMode(False, s, sg), ssr.ContactMode(True, s, 0))
        imp = ssr.impact(st, "ground", pat, [0.0, 0.0, 0.0, 0.0], [vm, wm, 0.0, wm])
        assert abs(imp.w[1] - ref.omega_plus) < 1e-9 and abs(imp.w[0] - ref.slip_rate_plus) < 1e-9
        n += 1
        n_flat += flat_landing
        n_sliding += not ref.sticking and not flat_landing
    assert n > 400 and n_sliding > 30 and n_flat > 30


def test_initiation_from_rest_follows_shenton():
    """Block 2 vanishing (and held by a large interface mu): the pattern the enumeration picks from rest
    under a constant load is the one-block initiation mode of Ishiyama (1982) and Shenton (1996)
    (model/sliding_closed_form.initiation_mode) at 600 random blocks and loads, turning or slipping to
    the side the load pushes."""
    rng = np.random.default_rng(5)
    seen = set()
    n = 0
    while n < 600:
        mu, beta = rng.uniform(0.1, 1.2), rng.uniform(0.2, 1.2)
        lam, av = rng.uniform(0.05, 1.8) * rng.choice([-1, 1]), rng.uniform(-0.3, 0.3)
        if scf.initiation_margin(mu, beta, lam * (1 + av), av) < 1e-3:
            continue
        n += 1
        h = 0.5
        st = ssr.SlidingStack(beta * h, h, 100.0, beta * h, 1e-3, 1e-9, mu_ground=mu, mu_interface=5.0)
        ah, avv = lam * (1 + av) * st.g, av * st.g
        pat, sol = ssr.select_pattern(st, np.zeros(4), np.zeros(4), ah, avv)
        g = pat.ground
        got = (scf.Mode.REST if g.flat and not g.slides else scf.Mode.SLIDE if g.flat
               else scf.Mode.ROCK if not g.slides else scf.Mode.SLIDE_ROCK)
        want = scf.initiation_mode(mu, beta, lam * (1 + av), av)
        assert got == want, (mu, beta, lam, av, pat)
        assert pat.interface.flat and not pat.interface.slides
        side = -1 if ah > 0 else 1  # a_h > 0 tips the block onto its left corner and slides it to -x
        if not g.flat:
            assert g.s == side and side * sol.qdd[1] > 0
        if g.slides:
            assert g.sigma == side
        seen.add(got)
    assert seen == set(scf.Mode) - {scf.Mode.OVERTURNED, scf.Mode.FLIGHT}


def test_single_block_limit_of_a_whole_run():
    """Block 2 vanishing and held (a thin plate, interface mu 5): a block of b/h = 0.4 with mu = 0.5 under
    a sine pulse starts to rock, slide-rocks, sticks again and rocks through 30 impacts to rest,
    exactly as the one-block rocking-sliding reference (model/sliding_reference.py): every event to
    1e-9 s, the peak slip to 1e-9 m."""
    from model import sliding_reference as sr

    b, h, mu = 0.2, 0.5, 0.5
    exc = sr.sine_pulse(-9.0, 2.5, cycles=1)
    ref = sr.simulate(sr.SlidingBlock(b, h, mu, m=100.0), exc, 4.0)
    st = ssr.SlidingStack(b, h, 100.0, b, 1e-4, 1e-9, mu_ground=mu, mu_interface=5.0)
    run = ssr.simulate(st, 4.0, exc.ground, exc.breaks)
    names = {"uplift": "start", "slide-rock": "slip", "rest": "settle"}
    theirs = [(names.get(k, k), t) for k, t in ref.events]
    ours = [(e.kind, e.t) for e in run.events]
    assert [k for k, _ in ours] == [k for k, _ in theirs] and len(ours) > 30
    assert max(abs(a[1] - b_[1]) for a, b_ in zip(ours, theirs)) < 1e-9
    assert abs(run.peak_abs_slip[0] - ref.peak_abs_slip) < 1e-9


# ---------------------------------------------------------------------------------- (f) falling off


def test_upper_block_falls_off_the_edge():
    """Block 2 launched at 2 m/s on block 1 held by a high ground friction: it slides flat with
    u2 = v0 t - mu g t^2 / 2, its normal force's resultant mu h2 ahead of its centre, and falls off
    when that resultant reaches block 1's edge, u2 = b1 - mu h2."""
    mu, v0 = 0.3, 2.0
    st = ssr.SlidingStack(0.5, 0.3, 300.0, 0.1, 0.15, 20.0, mu_ground=2.0, mu_interface=mu)
    run = ssr.simulate(st, 1.0, w0=(0.0, 0.0, v0, 0.0))
    t_exact = brentq(lambda t: v0 * t - mu * st.g * t * t / 2 - (st.b1 - mu * st.h2), 0.0, v0 / (mu * st.g))
    assert run.fell_off_time is not None and abs(run.fell_off_time - t_exact) < 1e-9
    assert run.overturn_time == (None, None)
    assert run.events[-1].kind == "fell-off"


def test_rocking_pivot_passing_the_edge_falls_off():
    """Block 2 slide-rocking towards block 1's edge: the run ends with fell-off exactly where its
    pivot corner passes the edge, |u2 + s2 b2| = b1."""
    st = ssr.SlidingStack(0.5, 0.3, 300.0, 0.1, 0.3, 20.0, mu_ground=2.0, mu_interface=0.2)
    run = ssr.simulate(st, 2.0, q0=(0.0, 0.0, 0.3, 0.02), w0=(0.0, 0.0, 1.5, 0.0))
    assert run.fell_off_time is not None
    s2 = int(run.s[1, -1])
    assert abs(abs(run.y[2, -1] + s2 * st.b2) - st.b1) < 1e-9
    assert any(e.kind == "fell-off" for e in run.events)


# ------------------------------------------------------------------------------ symmetry and sweeps


def test_mirrored_runs_are_mirrored():
    """Mirroring the start and the ground motion mirrors the run: the same events at the same times,
    slips and rotations of opposite sign (statue on plinth, rocking and sliding at both contacts)."""
    st = ssr.SlidingStack(*STATUE, mu_ground=0.5, mu_interface=0.5)
    gr = scf.sine_pulse(6.0, 1.5, cycles=2)
    mirrored = scf.sine_pulse(-6.0, 1.5, cycles=2)
    a = ssr.simulate(st, 3.0, gr, gr.breaks())
    b = ssr.simulate(st, 3.0, mirrored, mirrored.breaks())
    assert [(e.kind, e.contact) for e in a.events] == [(e.kind, e.contact) for e in b.events]
    assert max(abs(x.t - y.t) for x, y in zip(a.events, b.events)) < 1e-9
    assert abs(a.peak_abs_slip[0] - b.peak_abs_slip[0]) < 1e-9 and abs(a.peak_abs_slip[1] - b.peak_abs_slip[1]) < 1e-9
    assert abs(a.final_slip[1] + b.final_slip[1]) < 1e-9


def synthetic_record(seed: int, pga: float, duration: float = 8.0, dt: float = 0.01):
    """A smoothed random acceleration under a build-up and decay envelope, joined by straight lines
    between samples (every sample a break), scaled to the peak ``pga`` (m/s^2)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration / dt) + 1) * dt
    kernel = np.exp(-0.5 * (np.arange(-15, 16) / 5.0) ** 2)
    x = np.convolve(rng.normal(size=t.size), kernel / kernel.sum(), mode="same")
    a = x * np.minimum(1.0, t / 1.5) * np.exp(-np.maximum(0.0, t - 4.0) / 1.5)
    a *= pga / np.max(np.abs(a))
    return (lambda tt: (float(np.interp(tt, t, a)), 0.0)), tuple(t[1:])


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_record_sweep_balances_energy(seed):
    """The statue on its plinth under synthetic records at 0.4 g and 0.7 g, three friction pairs: every
    run ends (at t_end, or with an outcome), with its energy balanced to 1e-9 of its scale."""
    for pga, (mg, mi) in itertools.product((4.0, 7.0), ((0.5, 0.5), (0.25, 0.6), (0.7, 0.3))):
        st = ssr.SlidingStack(*STATUE, mu_ground=mg, mu_interface=mi)
        ground, breaks = synthetic_record(seed, pga)
        run = ssr.simulate(st, 8.0, ground, breaks)
        assert np.max(np.abs(run.balance_error())) < 1e-9 * max(1.0, energy_scale(run))
