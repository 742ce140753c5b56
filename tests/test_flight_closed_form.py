"""Which mode a block takes at initiation from rest (now with flight, a_v <= -g) and after a landing
from flight (flat, or on a corner): the closed forms of model/sliding_closed_form.py against a
brute-force solve of the contact problem.

The brute force enumerates every active set of the complementarity problem (each corner open or
closed; the friction sticking or sliding either way), solves each as a linear system (numpy) and keeps
the ones whose inequalities hold strictly: closed corners press (P_N > 0), open ones separate (normal
velocity > 0), a sticking friction is inside the cone, a sliding one opposes the slip. The problem is
the same at the acceleration level (initiation from rest: the block's 'free' acceleration is
(-a_h, -G, 0) in the ground's frame) and at the impulse level (a plastic landing: the 'free' velocity
is the one before the impact). Mass 1, Ic = R^2 / 3, angular rates counter-clockwise inside the
brute force; the closed forms' omega is clockwise (docs/conventions.md)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from model.sliding_closed_form import (
    Landing,
    Mode,
    corner_landing,
    corner_landing_margin,
    corner_landing_thresholds,
    flat_landing,
    flat_landing_mode,
    initiation_margin,
    initiation_mode,
    initiation_modes,
    jam_ratio,
    landing_margin,
    painleve_friction,
    rocking_onset_demand,
    slide_rock_ratio,
)

BAND = 1e-3  # points closer than this to a boundary (in the ratios compared) are left out


@dataclass(frozen=True)
class Solution:
    """One consistent solution of the contact problem: the mode, the block's generalised velocity
    (or acceleration) after (vx, vy, counter-clockwise w), the normal impulses (forces) of the
    corners and the total tangential one."""

    mode: Mode
    u: np.ndarray
    pn: np.ndarray
    pt: float
    side: int  # the closed corner's x sign when one corner is closed, else 0


def enumerate_contacts(u0: np.ndarray, corners: list[tuple[float, float]], mu: float, ic: float,
                       tol: float, sides: tuple[int, ...] = (-1, 1)) -> list[Solution]:
    """Every consistent solution of: u = u0 + M^-1 (sum Jn_i^T pn_i + Jt^T pt), M = diag(1, 1, ic),
    corner i at (rx, ry) from the centre with normal velocity Jn_i u = vy + w rx and tangential
    velocity Jt u = vx - w ry (all corners at the same ry share it), complementarity on each corner and
    Coulomb's law on the total tangential impulse |pt| <= mu sum(pn). ``sides`` names the corners
    (-1 left, +1 right)."""
    n = len(corners)
    ry = corners[0][1]
    assert all(abs(c[1] - ry) < 1e-15 for c in corners)
    jn = [np.array([0.0, 1.0, rx]) for rx, _ in corners]
    jt = np.array([1.0, 0.0, -ry])
    m = np.diag([1.0, 1.0, ic])
    out = []
    for closed in itertools.product((False, True), repeat=n):
        frictions = ("stick", 1, -1) if any(closed) else ("none",)
        for fr in frictions:
            # unknowns: u (3), pn (n), pt (1)
            a = np.zeros((4 + n, 4 + n))
            rhs = np.zeros(4 + n)
            a[:3, :3] = m
            for i in range(n):
                a[:3, 3 + i] = -jn[i]
            a[:3, 3 + n] = -jt
            rhs[:3] = m @ u0
            for i in range(n):
                if closed[i]:
                    a[3 + i, :3] = jn[i]
                else:
                    a[3 + i, 3 + i] = 1.0
            row = 3 + n
            if fr == "none":
                a[row, 3 + n] = 1.0
            elif fr == "stick":
                a[row, :3] = jt
            else:  # slide with slip sign fr: pt = -fr mu sum(pn of the closed corners)
                a[row, 3 + n] = 1.0
                for i in range(n):
                    if closed[i]:
                        a[row, 3 + i] = fr * mu
            if abs(np.linalg.det(a)) < 1e-14:
                continue
            x = np.linalg.solve(a, rhs)
            u, pn, pt = x[:3], x[3:3 + n], x[3 + n]
            ok = all((pn[i] > tol) if closed[i] else (jn[i] @ u > tol) for i in range(n))
            if fr == "stick":
                ok = ok and abs(pt) < mu * pn.sum() - tol
            elif fr in (1, -1):
                ok = ok and fr * (jt @ u) > tol
            if not ok:
                continue
            k = sum(closed)
            mode = (Mode.FLIGHT if k == 0 else
                    (Mode.REST if fr == "stick" else Mode.SLIDE) if k == n and n == 2 else
                    Mode.ROCK if fr == "stick" else Mode.SLIDE_ROCK)
            side = sides[closed.index(True)] if k == 1 else 0
            out.append(Solution(mode, u, pn, float(pt), side))
    return out


def flat_corners(b: float, h: float) -> list[tuple[float, float]]:
    return [(-b, -h), (b, -h)]


def initiation_solutions(mu: float, beta: float, h: float, ah: float, av: float) -> list[Solution]:
    """The brute force at the first instant from rest (g = 1): free acceleration (-a_h, -G, 0)."""
    b = beta * h
    u0 = np.array([-ah, -(1.0 + av), 0.0])
    return enumerate_contacts(u0, flat_corners(b, h), mu, (b * b + h * h) / 3, 1e-12 * (1 + abs(ah) + abs(av)))


def kinetic(u: np.ndarray, ic: float) -> float:
    return 0.5 * (u[0] ** 2 + u[1] ** 2 + ic * u[2] ** 2)


# ------------------------------------------------------------------ initiation, with flight


def random_load(rng: np.random.Generator) -> tuple[float, float]:
    """a_h / g and a_v / g: a quarter each on ordinary loads, a_v just above -g, a_v below -g, and
    a_v far below -g with a large a_h (where a jammed corner competes with flight)."""
    kind = rng.integers(4)
    ah = rng.uniform(-4, 4)
    if kind == 0:
        av = rng.uniform(-0.9, 0.8)
    elif kind == 1:
        av = -1.0 + 10 ** rng.uniform(-5, -1)
    elif kind == 2:
        av = -1.0 - 10 ** rng.uniform(-4, 0.5)
    else:
        av, ah = -1.0 - rng.uniform(0.01, 1.0), rng.uniform(-40, 40)
    return ah, av


def test_initiation_closed_form_is_the_enumerations_answer():
    """6000 random blocks and loads (mu up to 3, so past mu_P >= 4/3; a_v from above -g, just above -g
    and below it): the set of consistent modes is the closed form's initiation_modes. With G > 0 it is
    one mode, never flight; with G < 0 it is flight alone except in the Painleve-like region
    (mu > mu_P, kappa > K), where ROCK and SLIDE_ROCK are consistent too."""
    rng = np.random.default_rng(2002)
    counts: dict[frozenset, int] = {}
    checked = 0
    while checked < 6000:
        mu, beta, h = rng.uniform(0.05, 3.0), rng.uniform(0.1, 2.0), rng.uniform(0.1, 2.0)
        ah, av = random_load(rng)
        if initiation_margin(mu, beta, ah, av) < BAND:
            continue
        sols = initiation_solutions(mu, beta, h, ah, av)
        got = frozenset(s.mode for s in sols)
        want = initiation_modes(mu, beta, ah, av)
        assert got == want and len(sols) == len(want), (mu, beta, ah, av, [s.mode for s in sols], want)
        assert initiation_mode(mu, beta, ah, av) in want
        if 1 + av > 0:
            assert len(sols) == 1 and Mode.FLIGHT not in got
            s = sols[0]
            if s.side:  # it tips to the side the load pushes it (a_h > 0: the left corner)
                assert s.side == -np.sign(ah) and s.pn.sum() > 0
        else:
            assert initiation_mode(mu, beta, ah, av) == Mode.FLIGHT
        counts[got] = counts.get(got, 0) + 1
        checked += 1
    single = {next(iter(k)) for k in counts if len(k) == 1}
    assert single == {Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK, Mode.FLIGHT}
    assert counts.get(frozenset({Mode.FLIGHT, Mode.ROCK, Mode.SLIDE_ROCK}), 0) > 50


def test_g_plus_never_flies_and_the_pivot_presses():
    """With G > 0 every tipping start has N > 0 on its pivot: rock N = (G (beta^2 + 4) + 3 beta |a_h|) /
    (4 (beta^2 + 1)), slide-rock N = G (beta^2 + 1) / (4 beta^2 + 1 - 3 mu beta) > 0 below mu_P."""
    rng = np.random.default_rng(3)
    checked = 0
    while checked < 1000:  # G from 1e-7 g to 2 g: a_v = -g + small is no boundary of these modes
        mu, beta, h = rng.uniform(0.05, 3.0), rng.uniform(0.1, 2.0), 1.0
        ah, av = rng.uniform(-5, 5), -1.0 + 10 ** rng.uniform(-7, 0.3)
        big_g = 1 + av
        if initiation_margin(mu, beta, abs(ah) / big_g, 0.0) < BAND:  # the same ratios, lambda
            continue
        (s,) = initiation_solutions(mu, beta, h, ah, av)
        assert s.mode == initiation_mode(mu, beta, ah, av) != Mode.FLIGHT
        checked += 1
        if s.mode == Mode.ROCK:
            assert s.pn.sum() == pytest.approx((big_g * (beta**2 + 4) + 3 * beta * abs(ah)) / (4 * (beta**2 + 1)))
        if s.mode == Mode.SLIDE_ROCK:
            assert s.pn.sum() == pytest.approx(big_g * (beta**2 + 1) / (4 * beta**2 + 1 - 3 * mu * beta))


def test_flight_boundary_and_painleve_region():
    beta = 0.5
    assert painleve_friction(beta) == pytest.approx(4 / 3)
    # a_v = -g: flight (grazing, no force); just above, the G > 0 criteria with lambda -> inf
    assert initiation_mode(0.3, beta, 0.0, -1.0) == Mode.FLIGHT
    assert initiation_mode(0.3, beta, 1.0, -1.0) == Mode.FLIGHT
    assert initiation_mode(0.3, beta, 1.0, -1.0 + 1e-9) == Mode.SLIDE
    assert initiation_mode(0.8, beta, 1.0, -1.0 + 1e-9) == Mode.SLIDE_ROCK  # mu_rock -> mu_P = 4/3
    assert initiation_mode(1.4, beta, 1.0, -1.0 + 1e-9) == Mode.ROCK
    assert initiation_mode(0.8, beta, 0.0, -1.0 + 1e-9) == Mode.REST
    assert initiation_mode(0.8, beta, 1.0, -1.5) == Mode.FLIGHT
    assert initiation_modes(0.8, beta, 30.0, -1.5) == {Mode.FLIGHT}
    assert initiation_modes(1.4, beta, 1.0, -1.0) == {Mode.FLIGHT, Mode.ROCK}
    assert initiation_modes(1.2, beta, 1.0, -1.0) == {Mode.FLIGHT}
    # G < 0, mu = 2 > mu_P: K = (2 * 4.25 - 1.5) / (3 - 1 - 1) = 7
    assert jam_ratio(2.0, beta) == pytest.approx(7.0)
    assert initiation_modes(2.0, beta, 6.9 * 0.5, -1.5) == {Mode.FLIGHT}
    assert initiation_modes(2.0, beta, 7.1 * 0.5, -1.5) == {Mode.FLIGHT, Mode.ROCK, Mode.SLIDE_ROCK}
    assert jam_ratio(1.0, beta) == math.inf and slide_rock_ratio(1.5, beta) == math.inf
    # the slide-rock separatrix is the inverse of the rocking demand
    for mu in (0.6, 0.9, 1.2):
        lam = slide_rock_ratio(mu, beta)
        assert rocking_onset_demand(beta, lam) == pytest.approx(mu, rel=1e-12)
    # a_v below -g is no longer refused; bad blocks still are
    with pytest.raises(ValueError, match="mu"):
        initiation_mode(0.0, beta, 1.0, -2.0)
    with pytest.raises(ValueError, match="finite"):
        initiation_mode(0.5, beta, 1.0, float("nan"))


# ------------------------------------------------------------------ flat landing


def landing_solutions(mu: float, b: float, h: float, vx: float, vy: float) -> list[Solution]:
    return enumerate_contacts(np.array([vx, vy, 0.0]), flat_corners(b, h), mu, (b * b + h * h) / 3,
                              1e-12 * (abs(vx) + abs(vy)))


def random_ratio(rng: np.random.Generator, mu: float, beta: float) -> float:
    """Landing ratios r = |vx| / |vy|: log-uniform, or close to one of the separatrices."""
    kind = rng.integers(4)
    near = 1 + rng.choice([-1, 1]) * 10 ** rng.uniform(-2.7, -0.5)
    if kind == 1:
        return min(mu, beta) * near
    if kind == 2 and beta < mu:
        r_sr = slide_rock_ratio(mu, beta)
        if math.isfinite(r_sr) and r_sr > 0:
            return r_sr * near
    return 10 ** rng.uniform(-2.5, 2.5)


def assert_same(sol: Solution, land: Landing, scale: float) -> None:
    """The brute force's solution is the closed form's landing (omega clockwise there)."""
    tol = 1e-9 * scale
    assert sol.mode == land.mode and sol.side == land.side
    assert sol.u[0] == pytest.approx(land.vx, abs=tol) and sol.u[1] == pytest.approx(land.vy, abs=tol)
    assert -sol.u[2] == pytest.approx(land.omega, abs=tol * 10)
    assert sol.pt == pytest.approx(land.p_t, abs=tol) and sol.pn.sum() == pytest.approx(land.p_n, abs=tol)


def test_flat_landing_closed_form_is_the_enumerations_answer():
    """4000 random flat landings (ratios log-uniform and within a few percent of each separatrix, none
    within 0.001): exactly one consistent outcome, the closed form's mode, velocities and impulses,
    the block tipping onto the corner it moves towards, and the kinetic energy never rises."""
    rng = np.random.default_rng(1991)
    seen: set[Mode] = set()
    checked = 0
    while checked < 4000:
        mu, beta, h = rng.uniform(0.05, 3.0), rng.uniform(0.1, 2.0), rng.uniform(0.1, 2.0)
        b = beta * h
        vy = -rng.uniform(0.05, 5.0)
        vx = rng.choice([-1, 1]) * random_ratio(rng, mu, beta) * -vy
        if landing_margin(mu, beta, vx, vy) < BAND:
            continue
        sols = landing_solutions(mu, b, h, vx, vy)
        assert len(sols) == 1, (mu, beta, vx, vy, sols)
        land = flat_landing(mu, b, h, vx, vy)
        assert land.mode == flat_landing_mode(mu, beta, vx, vy)
        assert_same(sols[0], land, abs(vx) + abs(vy))
        if land.side:
            assert land.side == np.sign(vx)
        before = 0.5 * (vx * vx + vy * vy)
        assert land.kinetic_energy(b, h) <= before * (1 + 1e-12)
        assert kinetic(sols[0].u, (b * b + h * h) / 3) <= before * (1 + 1e-12)
        seen.add(land.mode)
        checked += 1
    assert seen == {Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK}


def test_flat_landing_separatrices():
    beta, h = 0.4, 1.0
    b = beta * h
    # rest up to r = min(mu, beta), then slide (mu <= beta) or tip (mu > beta)
    assert flat_landing_mode(0.3, beta, 0.299, -1.0) == Mode.REST
    assert flat_landing_mode(0.3, beta, 0.301, -1.0) == Mode.SLIDE
    assert flat_landing_mode(0.8, beta, 0.399, -1.0) == Mode.REST
    assert flat_landing_mode(0.8, beta, 0.401, -1.0) == Mode.ROCK
    r_sr = slide_rock_ratio(0.8, beta)
    assert flat_landing_mode(0.8, beta, r_sr * 0.999, -1.0) == Mode.ROCK
    assert flat_landing_mode(0.8, beta, -r_sr * 1.001, -1.0) == Mode.SLIDE_ROCK
    # slide: friction takes mu |vy| of the horizontal velocity
    land = flat_landing(0.3, b, h, 2.0, -1.0)
    assert (land.vx, land.vy, land.omega, land.slip_rate) == pytest.approx((1.7, 0.0, 0.0, 1.7))
    # rock: angular momentum about the corner caught, omega = 3 (h |vx| - b |vy|) / (4 R^2)
    land = flat_landing(0.8, b, h, 0.5, -1.0)
    assert land.omega == pytest.approx(3 * (0.5 - 0.4) / (4 * (b * b + 1)))
    # a landing that does not move down is refused
    with pytest.raises(ValueError, match="vy"):
        flat_landing_mode(0.5, beta, 1.0, 0.0)


# ------------------------------------------------------------------ corner landing


def corner_solutions(mu: float, b: float, h: float, theta: float, omega: float, vx: float, vy: float
                     ) -> list[Solution]:
    """The brute force with the lower corner as the only contact (theta clockwise, omega clockwise)."""
    c = 1 if theta > 0 else -1
    rx = c * b * math.cos(theta) - h * math.sin(theta)
    ry = -c * b * math.sin(theta) - h * math.cos(theta)
    return enumerate_contacts(np.array([vx, vy, -omega]), [(rx, ry)], mu, (b * b + h * h) / 3,
                              1e-12 * (abs(vx) + abs(vy) + abs(omega) * h), sides=(c,))


def test_corner_landing_closed_form_is_the_enumerations_answer():
    """3000 random corner landings (|theta| up to 0.6 rad, any omega and velocity that bring the lower
    corner down; the corner's velocity ratio log-uniform or near a separatrix): exactly one consistent
    outcome, the closed form's, and the kinetic energy never rises."""
    rng = np.random.default_rng(31)
    seen: set[Mode] = set()
    checked = 0
    while checked < 3000:
        mu, beta, h = rng.uniform(0.05, 3.0), rng.uniform(0.1, 2.0), rng.uniform(0.1, 2.0)
        b = beta * h
        theta = rng.choice([-1, 1]) * 10 ** rng.uniform(-4, math.log10(0.6))
        omega = rng.uniform(-5, 5) / h
        vy = -rng.uniform(0.05, 5.0)
        c = 1 if theta > 0 else -1
        rx = c * b * math.cos(theta) - h * math.sin(theta)
        ry = -c * b * math.sin(theta) - h * math.cos(theta)
        wn = vy - omega * rx
        if wn >= -0.02:
            continue
        t_minus, t_plus = corner_landing_thresholds(mu, b, h, theta)
        pick = rng.integers(3)
        target = t_plus if pick == 1 else t_minus if pick == 2 else math.nan
        if math.isfinite(target):
            rho = target + rng.choice([-1, 1]) * 10 ** rng.uniform(-2.7, 0) * (1 + abs(target))
        else:
            rho = rng.choice([-1, 1]) * 10 ** rng.uniform(-2, 2)
        vx = rho * -wn - omega * ry
        if corner_landing_margin(mu, b, h, theta, omega, vx, vy) < BAND:
            continue
        sols = corner_solutions(mu, b, h, theta, omega, vx, vy)
        assert len(sols) == 1, (mu, beta, theta, omega, vx, vy, sols)
        land = corner_landing(mu, b, h, theta, omega, vx, vy)
        assert_same(sols[0], land, abs(vx) + abs(vy) + abs(omega) * h)
        assert land.side == c
        before = 0.5 * (vx * vx + vy * vy) + 0.5 * (b * b + h * h) / 3 * omega * omega
        assert land.kinetic_energy(b, h) <= before * (1 + 1e-12)
        seen.add(land.mode)
        checked += 1
    assert seen == {Mode.ROCK, Mode.SLIDE_ROCK}


def test_corner_landing_at_vanishing_tilt_is_the_flat_landing_that_tips():
    """A flat landing that tips onto corner c is, to first order, a landing on corner c alone at
    theta = c 1e-12: same mode, velocities and impulses; and the corner thresholds at theta -> 0 are
    the flat landing's slide-rock separatrix."""
    rng = np.random.default_rng(7)
    n = 0
    while n < 300:
        mu, beta, h = rng.uniform(0.05, 3.0), rng.uniform(0.1, 2.0), rng.uniform(0.1, 2.0)
        b, vy = beta * h, -1.0
        vx = rng.choice([-1, 1]) * 10 ** rng.uniform(-1, 2)
        if landing_margin(mu, beta, vx, vy) < BAND:
            continue
        flat = flat_landing(mu, b, h, vx, vy)
        if flat.side == 0:
            continue
        corner = corner_landing(mu, b, h, flat.side * 1e-12, 0.0, vx, vy)
        assert corner.mode == flat.mode
        for x, y in zip((corner.vx, corner.vy, corner.omega, corner.p_t, corner.p_n),
                        (flat.vx, flat.vy, flat.omega, flat.p_t, flat.p_n)):
            assert x == pytest.approx(y, rel=1e-8, abs=1e-9 * abs(vx))
        n += 1
    for mu, beta in ((0.6, 0.4), (1.2, 0.5), (2.0, 1.0)):
        t_minus, t_plus = corner_landing_thresholds(mu, beta, 1.0, 1e-13)
        assert t_plus == pytest.approx(slide_rock_ratio(mu, beta), rel=1e-9) or math.isinf(t_plus)
        assert t_minus == pytest.approx(-(mu * (beta**2 + 4) + 3 * beta) / (4 * beta**2 + 1 + 3 * mu * beta))
    with pytest.raises(ValueError, match="theta"):
        corner_landing(0.5, 0.2, 0.5, 0.0, 0.0, 1.0, -1.0)
    with pytest.raises(ValueError, match="no impact"):
        corner_landing(0.5, 0.2, 0.5, 0.1, 0.0, 1.0, 1.0)
