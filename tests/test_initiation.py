"""Which mode a block at rest takes under a suddenly applied constant a_h, a_v: rest, slide, rock
or slide-rock (Ishiyama 1982; Shenton 1996). The criteria of model/sliding_closed_form.py are
checked against an independent enumeration (each mode's Newton-Euler equations solved as a
linear system, kept if its forces and accelerations are consistent), and the FMU's
rocking-sliding model against the criteria over a grid of mu, b/h, a_h/g and a_v/g."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from model.sliding_closed_form import (
    Mode,
    initiation_margin,
    initiation_mode,
    rest_limit,
    rock_friction_limit,
    rocking_onset_demand,
)

TOL = 1e-12


def consistent_modes(mu: float, b: float, h: float, ah: float, av: float, g: float = 9.81) -> set[Mode]:
    """Every mode whose Newton-Euler equations at theta = omega = 0 have a consistent solution
    (mass 1, Ic = R^2 / 3; ground frame, so the block feels -a_h and g + a_v). Unknowns:
    the centre's accelerations X'', Y'', the counter-clockwise angular acceleration w', the
    reactions T (along +x) and N (up) and, while sliding, the contact's acceleration."""
    G, Ic = g + av, (b * b + h * h) / 3
    found: set[Mode] = set()
    # rest: T = a_h, N = G, their resultant at x_N from the centre: x_N N + h T = 0 (moment)
    if abs(ah) <= mu * G + TOL and abs(h * ah / G) <= b + TOL:
        found.add(Mode.REST)
    # flat slide, slip sign s: T = -s mu N, N = G, X'' = T - a_h must have the sign s
    for s in (1, -1):
        T = -s * mu * G
        if s * (T - ah) > TOL and abs(h * T / G) <= b + TOL:
            found.add(Mode.SLIDE)
    for c in (1, -1):  # pivot at (c b, -h) from the centre; the other corner rises if c w' < 0
        # rock (pivot fixed): X'' = -h w', Y'' = -c b w' (w' z x (-c b, h)); unknowns T, N, w'
        #   -h w' = T - a_h;   -c b w' = N - G;   Ic w' = c b N + h T
        M = np.array([[1.0, 0.0, h], [0.0, 1.0, c * b], [h, c * b, -Ic]])
        T, N, w = np.linalg.solve(M, [ah, G, 0.0])
        if c * w < -TOL and N > TOL and abs(T) <= mu * N + TOL:
            found.add(Mode.ROCK)
        for s in (1, -1):  # slide-rock: the pivot slides with acceleration a_p of sign s, T = -s mu N
            #   a_p - h w' = -s mu N - a_h;   -c b w' = N - G;   Ic w' = c b N - s mu h N
            M = np.array([[1.0, -h, s * mu], [0.0, c * b, 1.0], [0.0, Ic, -(c * b - s * mu * h)]])
            a_p, w, N = np.linalg.solve(M, [-ah, G, 0.0])
            if c * w < -TOL and N > TOL and s * a_p > TOL:
                found.add(Mode.SLIDE_ROCK)
    return found


def test_the_criteria_name_the_one_consistent_mode():
    """Over random blocks and loads (away from the boundaries) exactly one mode is consistent with
    Newton-Euler and Coulomb's law, and it is the one the criteria give."""
    rng = np.random.default_rng(26)
    seen = set()
    checked = 0
    while checked < 4000:
        mu, beta = rng.uniform(0.05, 1.5), rng.uniform(0.1, 1.5)
        ah, av = rng.uniform(-2.5, 2.5), rng.uniform(-0.6, 0.6)
        if initiation_margin(mu, beta, ah, av) < 1e-6:
            continue
        h = rng.uniform(0.1, 2.0)
        modes = consistent_modes(mu, beta * h, h, ah * 9.81, av * 9.81)
        expected = initiation_mode(mu, beta, ah, av)
        assert modes == {expected}, (mu, beta, ah, av, modes, expected)
        seen.add(expected)
        checked += 1
    assert seen == {Mode.REST, Mode.SLIDE, Mode.ROCK, Mode.SLIDE_ROCK}


def test_ishiyama_and_shenton_boundaries():
    beta = 0.4
    # Ishiyama 1982: with mu < b/h it slides once a_h > mu g; with mu > b/h nothing moves below (b/h) g
    assert initiation_mode(0.3, beta, 0.29) == Mode.REST and initiation_mode(0.3, beta, 0.31) == Mode.SLIDE
    assert initiation_mode(0.3, beta, 5.0) == Mode.SLIDE
    assert initiation_mode(0.8, beta, 0.39) == Mode.REST and initiation_mode(0.8, beta, 0.41) == Mode.ROCK
    assert rest_limit(0.3, beta) == 0.3 and rest_limit(0.8, beta) == beta
    # Shenton 1996: the friction rocking needs rises from b/h at the uplift threshold towards
    # (4 beta^2 + 1) / (3 beta); between b/h and that demand the block slide-rocks
    lam = np.linspace(beta, 50, 2001)
    demand = np.array([rocking_onset_demand(beta, x) for x in lam])
    assert demand[0] == pytest.approx(beta, rel=1e-15)
    assert np.all(np.diff(demand) > 0) and demand[-1] < (4 * beta**2 + 1) / (3 * beta)
    assert rocking_onset_demand(beta, 1e7) == pytest.approx((4 * beta**2 + 1) / (3 * beta), rel=1e-6)
    mu_r = rock_friction_limit(beta, 1.0)
    assert initiation_mode(mu_r * 0.999, beta, 1.0) == Mode.SLIDE_ROCK
    assert initiation_mode(mu_r * 1.001, beta, 1.0) == Mode.ROCK
    # a_v scales gravity: the criteria see |a_h| / (g + a_v)
    assert initiation_mode(0.8, beta, 0.35, -0.3) == Mode.ROCK and initiation_mode(0.8, beta, 0.35, 0.3) == Mode.REST
    assert rocking_onset_demand(beta, 1.3, 0.3) == rocking_onset_demand(beta, 1.0)
    # the sign of a_h only picks the side
    assert initiation_mode(0.5, beta, -1.0) == initiation_mode(0.5, beta, 1.0)


@pytest.mark.parametrize("args, text", [((0.0, 0.4, 1.0), "mu"), ((float("nan"), 0.4, 1.0), "mu"),
                                        ((0.5, -1.0, 1.0), "b_over_h"), ((0.5, 0.4, float("inf")), "finite")])
def test_bad_arguments_are_refused(args, text):
    with pytest.raises(ValueError, match=text):
        initiation_mode(*args)


# ------------------------------------------------------------------ the FMU over a grid

MU_GRID = (0.1, 0.29, 0.45, 0.71, 0.93, 1.2)
B_OVER_H_GRID = (0.2, 0.41, 0.62, 0.85, 1.13)
AH_GRID = (0.06, 0.17, 0.31, 0.53, 0.79, 1.07, 1.63, -0.67)  # a_h / g
AV_GRID = (-0.3, 0.0, 0.3)  # a_v / g


def test_the_fmu_starts_in_the_mode_the_criteria_give(fmu):
    """720 blocks at rest under constant inputs ground.ah, ground.av from t = 0: after 2 ms the
    FMU's block1.mode is the criteria's mode at every point (none within 0.001 of a boundary),
    and the block turns and slips to the side the load pushes it (a_h > 0: theta < 0, slip < 0)."""
    from runners.analysis.initiation_map import StartPoint, fmu_start_states

    points = [StartPoint(*p) for p in itertools.product(MU_GRID, B_OVER_H_GRID, AH_GRID, AV_GRID)]
    expected = [initiation_mode(p.mu, p.b_over_h, p.ah_over_g, p.av_over_g) for p in points]
    assert min(initiation_margin(p.mu, p.b_over_h, p.ah_over_g, p.av_over_g) for p in points) > 1e-3
    assert {m: expected.count(m) for m in Mode if m not in (Mode.OVERTURNED, Mode.FLIGHT)} == \
        {Mode.REST: 272, Mode.SLIDE: 242, Mode.ROCK: 165, Mode.SLIDE_ROCK: 41}
    states = fmu_start_states(fmu, points)
    wrong = [(p, s.mode.name, e.name) for p, s, e in zip(points, states, expected) if s.mode != e]
    assert not wrong, f"{len(wrong)} of {len(points)} points differ, e.g. {wrong[:5]}"
    for p, s, e in zip(points, states, expected):
        side = -math.copysign(1.0, p.ah_over_g)
        turns = e in (Mode.ROCK, Mode.SLIDE_ROCK)
        slips = e in (Mode.SLIDE, Mode.SLIDE_ROCK)
        assert (s.theta * side > 0) if turns else s.theta == 0.0, (p, s)
        assert (s.slip_rate * side > 0 and s.slip * side > 0) if slips else s.slip_rate == 0.0, (p, s)


def test_runners_figures_draws_the_initiation_map(tmp_path, fmu_path):
    """docs/figures/initiation_map.png is redrawn by `runners figures --only initiation_map`."""
    from conftest import run_cli

    p = run_cli("figures", "--only", "initiation_map", "--out", str(tmp_path), db=f"sqlite:///{tmp_path / 'x.db'}",
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "initiation_map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
