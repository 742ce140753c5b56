"""The independent flight reference (model/flight_reference.py) against references it does not
compute itself: closed forms of ballistic flight and of the Coulomb block, hand formulas of the
first slide, lift-off and plastic landings, Housner's (1963) coefficient, the project's one-block
impact rule (docs/sliding.md), the energy balance and mirror symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from model import sliding_closed_form as scf
from model.flight_reference import (
    Block,
    Mode,
    SinePulse,
    constant_ground,
    offset,
    rocking_state,
    simulate,
)

G = 9.81


# ----------------------------------------------------------------------------- closed forms


def pulse_integrals(p: SinePulse, t_start: float, t: float) -> tuple[float, float]:
    """(int, double int) of the unit waveform sin(2 pi f (tau - t0)) on its window, from t_start
    (before or at t0, or inside the window) to t: by hand, not by the solver."""
    w = 2.0 * math.pi * p.frequency

    def first(tau: float) -> float:  # integral from t0 to tau of the waveform
        x = min(max(tau, p.t0), p.t_end)
        return (1.0 - math.cos(w * (x - p.t0))) / w

    def second(tau: float) -> float:  # integral from t0 to tau of first()
        x = min(max(tau, p.t0), p.t_end)
        inside = (x - p.t0) / w - math.sin(w * (x - p.t0)) / w ** 2
        return inside + first(p.t_end) * max(tau - p.t_end, 0.0)

    v = first(t) - first(t_start)
    d = second(t) - second(t_start) - first(t_start) * (t - t_start)
    return v, d


def ballistic(p: SinePulse, t_start: float, y0: np.ndarray, t: float, g: float = G) -> np.ndarray:
    """(X, Y, theta, VX, VY, w) at t of a block flying from y0 at t_start: X'' = -a_h, Y'' = -g - a_v."""
    tau = t - t_start
    v, d = pulse_integrals(p, t_start, t)
    X = y0[0] + y0[3] * tau - 0.5 * p.ah0 * tau ** 2 - p.amplitude * d
    Y = y0[1] + y0[4] * tau - 0.5 * (g + p.av0) * tau ** 2 - p.vertical * d
    VX = y0[3] - p.ah0 * tau - p.amplitude * v
    VY = y0[4] - (g + p.av0) * tau - p.vertical * v
    return np.array([X, Y, y0[2] + y0[5] * tau, VX, VY, y0[5]])


def lowest_gap(blk: Block, y: np.ndarray) -> float:
    """Height (m) of the lower bottom corner: Y - h cos(theta) - b |sin(theta)|."""
    return y[1] - blk.h * math.cos(y[2]) - blk.b * abs(math.sin(y[2]))


def residual(run) -> float:
    """Largest |energy balance| over m g h."""
    blk = run.block
    return float(np.max(np.abs(run.energy_residual))) / (blk.m * blk.g * blk.h)


# ----------------------------------------------------------------------------- flight


def test_ballistic_flight_equals_the_closed_form() -> None:
    blk = Block(0.2, 0.4, 0.5)
    pulse = SinePulse(3.0, 2.0, 1.0, t0=0.05, vertical=-4.0, ah0=0.5, av0=0.2)
    y0 = np.array([0.01, blk.h + 0.3, 0.1, 0.3, 1.0, 2.0])
    ts = np.linspace(0.0, 0.8, 161)
    run = simulate(blk, pulse, 0.8, pulse.breaks, t_out=ts, state0=y0)
    landing = run.first("landing")
    assert run.events[0].mode == Mode.FLIGHT and landing is not None
    # the landing time by hand: the closed form's lowest corner reaches the ground
    t_land = brentq(lambda t: lowest_gap(blk, ballistic(pulse, 0.0, y0, t)), 0.3, 0.8, xtol=1e-15)
    assert abs(landing.t - t_land) < 1e-11, (landing.t, t_land)
    before = ts < landing.t
    exact = np.array([ballistic(pulse, 0.0, y0, t) for t in ts[before]])
    for k, name in enumerate(("X", "Y", "theta")):
        err = np.max(np.abs(getattr(run, name)[before] - exact[:, k]))
        assert err < 1e-12, (name, err)
    err_v = np.max(np.abs(run.vy[before] - exact[:, 4]))
    assert err_v < 1e-11, err_v
    assert np.all(run.mode[before] == Mode.FLIGHT)
    gap = np.array([lowest_gap(blk, e) for e in exact])
    assert np.max(np.abs(run.gap[before] - gap)) < 1e-12
    # the state just before the impact is the closed form's there
    vm = np.array(landing.detail["v_minus"])
    assert np.max(np.abs(vm - ballistic(pulse, 0.0, y0, t_land)[3:])) < 1e-11


def test_a_block_under_av_below_minus_g_flies_at_once() -> None:
    blk = Block(0.3, 0.36, 0.3)
    ts = np.linspace(0.0, 0.5, 51)
    run = simulate(blk, constant_ground(1.0, -12.0), 0.5, t_out=ts)
    assert run.events[0].mode == Mode.FLIGHT and len(run.events) == 1
    lift = 0.5 * (12.0 - G) * ts ** 2
    assert np.max(np.abs(run.Y - blk.h - lift)) < 1e-12
    assert np.max(np.abs(run.gap - lift)) < 1e-12
    assert np.max(np.abs(run.X + 0.5 * ts ** 2)) < 1e-12
    assert np.all(run.theta == 0.0) and run.flight_time == pytest.approx(0.5, abs=1e-15)
    assert run.max_gap == pytest.approx(lift[-1], abs=1e-12)


@pytest.mark.parametrize("ground, breaks", [
    (constant_ground(0.99 * 0.3 * (G + 2.0), 2.0), ()),
    (constant_ground(-0.3 * (G - 3.0), -3.0), ()),  # exactly at the limit |a_h| = mu G
    (SinePulse(2.0, 2.0, 2.0, vertical=-2.0), (0.0, 1.0)),  # 2 <= 0.3 (9.81 - 2)
])
def test_a_block_within_the_friction_cone_stays_at_rest(ground, breaks) -> None:
    blk = Block(0.3, 0.36, 0.3)  # mu = 0.3 < b / h: it cannot tip before it slides
    run = simulate(blk, ground, 1.5, breaks, t_out=np.linspace(0.0, 1.5, 151))
    assert [e.kind for e in run.events] == ["start"], run.events
    assert np.all(run.mode == Mode.REST)
    assert np.all(run.slip == 0.0) and np.all(run.gap == 0.0) and np.all(run.theta == 0.0)
    assert np.all(run.energy == 0.0) and np.all(run.ground_work == 0.0)


# ----------------------------------------------------------------------------- the acceptance case

ACCEPT_BLOCK = Block(0.3, 0.36, 0.3)
ACCEPT_PULSE = SinePulse(3.0, 2.0, 1.0, t0=0.0, vertical=-15.0)


@pytest.fixture(scope="module")
def accept_run():
    ts = np.linspace(0.0, 1.0, 2001)
    return simulate(ACCEPT_BLOCK, ACCEPT_PULSE, 1.0, ACCEPT_PULSE.breaks, t_out=ts)


def test_acceptance_case_slides_flies_and_lands_flat(accept_run) -> None:
    run, blk, p = accept_run, ACCEPT_BLOCK, ACCEPT_PULSE
    mu, A, V, Om = blk.mu, p.amplitude, p.vertical, 2.0 * math.pi * p.frequency
    kinds = [(e.kind, e.mode.name) for e in run.events]
    slide, lift, land = run.first("slide"), run.first("lift-off"), run.first("landing")
    stop = next((e for e in run.events if e.mode == Mode.REST and e.t > 0), None)
    # hand formulas: the slide starts at 3 s = mu (g - 15 s) and the block lifts off at g - 15 s = 0
    t_slide = math.asin(mu * G / (A - mu * V)) / Om
    t_lift = math.asin(G / -V) / Om
    # the slide (to -x) between them: u'' = -a_h + mu G = mu g - (A - mu V) s(t), by the closed form
    phase = scf.Phase(t_slide, t_lift, 0.0, 0.0, -1, -mu * G, A - mu * V, Om, 0.0)
    u_lo, v_lo = phase.slip(t_lift), phase.rate(t_lift)
    y_lo = np.array([u_lo, blk.h, 0.0, v_lo, 0.0, 0.0])
    t_land = brentq(lambda t: ballistic(p, t_lift, y_lo, t)[1] - blk.h, t_lift + 0.05, 0.5, xtol=1e-15)
    y_minus = ballistic(p, t_lift, y_lo, t_land)
    vx, vy = y_minus[3], y_minus[4]
    # flat plastic landing: P_N = m |vy-|; friction takes what it can (mu P_N) of vx-
    pn = blk.m * abs(vy)
    v_after = vx - math.copysign(min(abs(vx), mu * abs(vy)), vx)
    msg = (f"events {kinds}; slide start {slide and slide.t:.12f} (hand {t_slide:.12f}), lift-off "
           f"{lift and lift.t:.12f} (hand {t_lift:.12f}), landing {land and land.t:.12f} (hand {t_land:.12f}), "
           f"stop {stop and stop.t:.12f}; slip at lift-off {u_lo:.12e} m, rate {v_lo:.12e} m/s; slip at landing "
           f"{y_minus[0]:.12e} m, vx- {vx:.12e}, vy- {vy:.12e} m/s, slip rate after {v_after:.12e} m/s; "
           f"final slip {run.slip[-1]:.12e} m; flight {run.flight_time:.12f} s, max gap {run.max_gap:.12e} m")
    assert [k for k, _ in kinds[:4]] == ["start", "slide", "lift-off", "landing"], msg
    assert abs(slide.t - t_slide) < 1e-12 and abs(lift.t - t_lift) < 1e-12, msg
    assert abs(land.t - t_land) < 1e-11, msg
    assert abs(run.flight_time - (t_land - t_lift)) < 1e-11, msg
    # the landing's impulses and velocities after
    d = land.detail
    assert abs(sum(d["Pn"]) - pn) < 1e-11, msg
    assert abs(d["v_minus"][0] - vx) < 1e-11 and abs(d["v_minus"][1] - vy) < 1e-11, msg
    assert abs(d["v_plus"][0] - v_after) < 1e-11 and abs(d["v_plus"][1]) < 1e-12, msg
    assert abs(d["loss"] - 0.5 * blk.m * (vx ** 2 + vy ** 2 - v_after ** 2)) < 1e-10, msg
    assert np.all(run.theta == 0.0) and np.all(run.omega == 0.0), msg
    # sampled slip: closed form while sliding, ballistic in flight
    ts = run.t
    on = (ts > t_slide) & (ts < t_lift)
    assert np.max(np.abs(run.slip[on] - np.array([phase.slip(t) for t in ts[on]]))) < 1e-12, msg
    fl = (ts > t_lift) & (ts < t_land)
    exact = np.array([ballistic(p, t_lift, y_lo, t) for t in ts[fl]])
    assert np.max(np.abs(run.slip[fl] - exact[:, 0])) < 1e-11, msg
    assert np.max(np.abs(run.gap[fl] - (exact[:, 1] - blk.h))) < 1e-11, msg
    assert np.all(run.mode[fl] == Mode.FLIGHT), msg
    gmax = max(ballistic(p, t_lift, y_lo, t)[1] - blk.h for t in np.linspace(t_lift, t_land, 20001))
    assert abs(run.max_gap - gmax) < 1e-9, msg
    # after the landing: at rest if friction took all of vx-, else a slide from v_after
    if v_after == 0.0:
        assert land.mode == Mode.REST and stop is not None and stop.t == land.t, msg
        assert np.all(run.slip[ts > t_land] == pytest.approx(y_minus[0], abs=1e-11)), msg
    assert residual(run) < 1e-9, msg


# ----------------------------------------------------------------------------- sliding


@pytest.mark.parametrize("pulse", [
    scf.sine_pulse(12.0, 2.0, vertical=-5.0),
    scf.sine_pulse(-8.0, 1.5, cycles=2.0, t0=0.1, vertical=3.0, ah0=0.4, av0=-1.0),
])
def test_flat_slide_equals_the_coulomb_block(pulse) -> None:
    blk = Block(0.3, 0.36, 0.3)
    ts = np.linspace(0.0, 2.0, 401)
    ground = SinePulse(pulse.amplitude, pulse.frequency, (pulse.t_end - pulse.t0) * pulse.frequency, pulse.t0,
                       pulse.vertical, pulse.ah0, pulse.av0)
    run = simulate(blk, ground, 2.0, ground.breaks, t_out=ts)
    exact = scf.coulomb_block(pulse, blk.mu, 2.0)
    assert np.max(np.abs(run.slip - exact.slip(ts))) < 1e-10
    assert np.max(np.abs(run.slip_rate - exact.slip_rate(ts))) < 1e-10
    ours = [(e.kind, e.t) for e in run.events if e.kind in ("slide", "reverse", "stick")]
    theirs = [(s.kind, s.t) for s in exact.switches]
    assert [k for k, _ in ours] == [k for k, _ in theirs]
    assert max(abs(a - b) for (_, a), (_, b) in zip(ours, theirs)) < 1e-10
    assert np.all(run.gap == 0.0) and np.all(run.theta == 0.0) and run.flight_time == 0.0
    assert residual(run) < 1e-9


# ----------------------------------------------------------------------------- impacts


def test_free_rocking_impacts_follow_housner() -> None:
    blk = Block(0.3, 0.36, 1.5)  # friction enough for every impact to stick; eta = 0.385
    run = simulate(blk, constant_ground(0.0), 3.0, state0=rocking_state(blk, 0.5, 0.0))
    impacts = [e for e in run.events if e.kind == "impact" and "rest" not in e.detail]
    assert len(impacts) >= 3
    for e in impacts:
        ratio = e.detail["v_plus"][2] / e.detail["v_minus"][2]
        assert abs(ratio - blk.eta_housner) < 1e-12, ratio
    assert run.mode_final == Mode.REST and run.state_final[2] == 0.0
    assert residual(run) < 1e-9


def _pivot_rate(blk: Block, v: tuple, s: int) -> float:
    """Slip rate of corner s at theta = 0: VX - h w."""
    return v[0] - blk.h * v[2]


def test_rocking_landing_follows_the_one_block_rule() -> None:
    """docs/sliding.md: I0 w+ + m h v+ = eta I0 w- + m h v- (Housner's eta), sticking or sliding, and
    the sliding impact's w+ = w- (h - a eta - k) / (h - a + k), a = I0 / (m h), k = sigma mu s' b."""
    seen = set()
    for mu, th0, w0, u0 in ((0.2, 0.05, -1.0, 0.0), (0.9, 0.2, -0.5, 0.3), (0.5, -0.1, 0.8, -0.2)):
        blk = Block(0.3, 0.36, mu)
        run = simulate(blk, constant_ground(0.0), 0.6, state0=rocking_state(blk, th0, w0, slip_rate=u0))
        e = run.first("impact")
        assert e is not None and len(e.detail["corners"]) == 1
        s_new = e.detail["corners"][0]
        vm, vp = e.detail["v_minus"], e.detail["v_plus"]
        a, eta = blk.I0 / (blk.m * blk.h), blk.eta_housner
        v_minus, v_plus = _pivot_rate(blk, vm, -s_new), _pivot_rate(blk, vp, s_new)
        lhs = blk.I0 * vp[2] + blk.m * blk.h * v_plus
        rhs = eta * blk.I0 * vm[2] + blk.m * blk.h * v_minus
        assert abs(lhs - rhs) < 1e-12, (mu, lhs, rhs)
        if e.detail["sigma"] != 0:
            sigma = int(np.sign(v_plus))
            k = sigma * mu * s_new * blk.b
            w_plus = vm[2] * (blk.h - a * eta - k) / (blk.h - a + k)
            assert abs(vp[2] - w_plus) < 1e-12, (vp[2], w_plus)
            assert abs(e.detail["Pt"]) == pytest.approx(mu * sum(e.detail["Pn"]), abs=1e-12)
            seen.add("slide")
        else:
            assert v_plus == pytest.approx(0.0, abs=1e-12)
            seen.add("stick")
        assert abs(vp[1] - s_new * blk.b * vp[2]) < 1e-12  # the landing corner's VY - s' b w is 0
        assert residual(run) < 1e-9
    assert seen == {"slide", "stick"}


@pytest.fixture(scope="module")
def rock_flight_runs():
    pulse = SinePulse(5.0, 2.0, 1.0, vertical=-12.0)
    out = []
    for mu in (0.8, 0.5):
        blk = Block(0.1, 0.3, mu)
        out.append(simulate(blk, pulse, 1.5, pulse.breaks, t_out=np.linspace(0.0, 1.5, 601)))
    return out


def test_landing_on_a_corner_conserves_angular_momentum_about_it(rock_flight_runs) -> None:
    for run in rock_flight_runs:
        blk = run.block
        land = run.first("landing")
        assert run.first("uplift") is not None and land is not None
        s = land.detail["corners"][0]
        before = run.events[run.events.index(land) - 1]
        assert before.kind == "lift-off"
        vm, vp = np.array(land.detail["v_minus"]), np.array(land.detail["v_plus"])
        # theta at landing from the flight's closed form: theta is linear in flight
        th = run.theta[np.searchsorted(run.t, land.t) - 1] + vm[2] * (land.t - run.t[np.searchsorted(run.t, land.t) - 1])
        rx, ry = offset(th, s, blk.b, blk.h)

        def H(v: np.ndarray, blk: Block = blk, rx: float = rx, ry: float = ry) -> float:
            """Clockwise angular momentum about the landing corner (kg m^2/s)."""
            return blk.Ic * v[2] + blk.m * (-ry * v[0] + rx * v[1])

        assert abs(H(vp) - H(vm)) < 1e-12
        assert abs(vp[1] - rx * vp[2]) < 1e-12  # the corner's normal velocity is zero after
        assert vm[1] - rx * vm[2] < 0.0
        assert residual(run) < 1e-9


# ----------------------------------------------------------------------------- energy and symmetry


ENERGY_CASES = {  # name: block, pulse, t_end, whether it flies
    "acceptance": (Block(0.3, 0.36, 0.3), SinePulse(3.0, 2.0, 1.0, vertical=-15.0), 1.0, True),
    "slide then flight, sliding landing": (Block(0.3, 0.36, 0.1), SinePulse(6.0, 2.0, 1.0, vertical=-14.0), 1.2,
                                           True),
    "rock, flight, corner landing": (Block(0.1, 0.3, 0.8), SinePulse(5.0, 2.0, 1.0, vertical=-12.0), 1.5, True),
    "slide-rock, flight": (Block(0.1, 0.3, 0.5), SinePulse(5.0, 2.0, 1.0, vertical=-12.0), 1.5, True),
    "rock and slide-rock, grounded": (Block(0.15, 0.4, 0.45), SinePulse(6.0, 1.5, 2.0, vertical=3.0), 2.0, False),
}


@pytest.mark.parametrize("name", list(ENERGY_CASES))
def test_energy_balance(name: str) -> None:
    blk, pulse, t_end, flies = ENERGY_CASES[name]
    run = simulate(blk, pulse, t_end, pulse.breaks, t_out=np.linspace(0.0, t_end, 801))
    kinds = {e.kind for e in run.events}
    assert residual(run) < 1e-9, (name, residual(run), sorted(kinds))
    assert np.all(run.friction_loss >= -1e-15) and np.all(np.diff(run.impact_loss) >= 0.0)
    if flies:
        assert {"lift-off", "landing"} <= kinds, kinds
    else:
        assert run.flight_time == 0.0 and "lift-off" not in kinds
    if "rock" in name:
        assert (run.mode == Mode.ROCK).any() or (run.mode == Mode.SLIDE_ROCK).any()


def test_mirror_symmetry(accept_run) -> None:
    p = ACCEPT_PULSE
    mirror = SinePulse(-p.amplitude, p.frequency, p.cycles, p.t0, p.vertical)
    run = simulate(ACCEPT_BLOCK, mirror, 1.0, mirror.breaks, t_out=accept_run.t)
    assert np.max(np.abs(run.slip + accept_run.slip)) < 1e-12
    assert np.max(np.abs(run.gap - accept_run.gap)) < 1e-12
    assert [(e.kind, e.mode) for e in run.events] == [(e.kind, e.mode) for e in accept_run.events]
    blk = Block(0.1, 0.3, 0.5)
    pulse = SinePulse(5.0, 2.0, 1.0, vertical=-12.0)
    ts = np.linspace(0.0, 1.0, 201)
    a = simulate(blk, pulse, 1.0, pulse.breaks, t_out=ts)
    b = simulate(blk, SinePulse(-5.0, 2.0, 1.0, vertical=-12.0), 1.0, pulse.breaks, t_out=ts)
    assert np.max(np.abs(a.slip + b.slip)) < 1e-10 and np.max(np.abs(a.theta + b.theta)) < 1e-10
    assert np.max(np.abs(a.gap - b.gap)) < 1e-12
