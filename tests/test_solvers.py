"""The independent Python solvers (model/solvers.py) against exact references,
their orders of convergence, and the FMU."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model.reference import Block, free_rocking
from model.solvers import Scene, sine_pulse, solve_event_driven, solve_fixed_step

BLOCK = Block(0.1, 0.3)
ETA = 0.9
THETA0 = 0.6 * BLOCK.alpha
REF = free_rocking(BLOCK, THETA0, ETA, 10)
FREE = Scene(BLOCK, ETA, theta0=THETA0)
T_END = 1.5 * REF.impact_times[-1]


def errors(sol) -> tuple[float, float]:
    """Largest relative error of the first 10 impact times and of the 9 peaks between them."""
    ti = np.array(sol.impact_times[:10])
    pk = np.array(sol.peak_thetas[:9])
    assert len(ti) == 10 and len(pk) == 9, (len(ti), len(pk))
    return float(np.max(np.abs(ti / REF.impact_times - 1))), float(np.max(np.abs(pk / REF.peak_thetas[:9] - 1)))


@pytest.mark.parametrize("method", ["DOP853", "RK45", "Radau"])
def test_event_driven_scipy_matches_the_exact_free_rocking(method):
    rtol = 1e-11 if method != "Radau" else 1e-9
    e_t, e_p = errors(solve_event_driven(FREE, T_END, method, rtol, rtol * 1e-2, max_impacts=10))
    assert e_t < 1e-9 and e_p < 1e-8


@pytest.mark.parametrize("method,locate,h,order", [
    ("euler", False, 2e-3, 1),
    ("rk4", True, 2e-2, 4),
    ("newmark", True, 2e-3, 2),
])
def test_fixed_step_methods_converge_at_their_order(method, locate, h, order):
    """Halving the step divides the impact-time error by about 2^order."""
    coarse = errors(solve_fixed_step(FREE, T_END, method, h, locate, max_impacts=10))[0]
    fine = errors(solve_fixed_step(FREE, T_END, method, h / 2, locate, max_impacts=10))[0]
    observed = math.log2(coarse / fine)
    assert abs(observed - order) < 0.4, observed


def test_rk4_with_sign_change_detection_is_first_order_accurate_at_impacts():
    """Seed 000's RK4 at its 1e-4 s: the impact is placed at the end of the step, so times are O(h)."""
    e_t, e_p = errors(solve_fixed_step(FREE, T_END, "rk4", 1e-4, locate=False, max_impacts=10))
    assert 1e-4 < e_t < 1e-2 and 1e-3 < e_p < 3e-2
    located = errors(solve_fixed_step(FREE, T_END, "rk4", 1e-4, locate=True, max_impacts=10))
    assert max(located) < 1e-10


def test_linearised_impact_time_is_the_closed_form():
    """Linear free rocking from rest at theta0: theta = alpha + (theta0 - alpha) cosh(p t) until impact."""
    a, p = BLOCK.alpha, math.sqrt(BLOCK.p2)
    sol = solve_event_driven(Scene(BLOCK, ETA, theta0=THETA0, linear=True), 2.0, rtol=1e-12, atol=1e-14,
                             max_impacts=1)
    assert sol.impact_times[0] == pytest.approx(math.acosh(a / (a - THETA0)) / p, rel=1e-11)


def test_sine_pulse_uplift_and_impacts_agree_with_the_fmu(fmu):
    A, f = 5.0, 3.0
    ground, breaks = sine_pulse(A, f)
    sol = solve_event_driven(Scene(BLOCK, 0.85, ground=ground, breaks=breaks), 5.0, rtol=1e-12, atol=1e-14)
    r = fmu.run({"excitation.kind": 1, "excitation.amplitude": A, "excitation.frequency": f,
                 "restitution.law": 2, "restitution.eta": 0.85}, 5.0, 0.01)
    fmu_impacts = r.event_times("impact")
    assert len(sol.impact_times) == len(fmu_impacts) > 10
    assert np.max(np.abs(np.array(sol.impact_times[:10]) / fmu_impacts[:10] - 1)) < 1e-8
    assert r.outputs["atRest"][-1] == 1 and sol.rest_time is not None
    uplift = r.event_times("uplift")[0]
    exact = math.asin(9.81 * math.tan(BLOCK.alpha) / A) / (2 * math.pi * f)
    assert abs(uplift - exact) < 1e-12


def test_overturning_pulse_overturns_in_every_method(fmu):
    ground, breaks = sine_pulse(6.0, 2.0)
    scene = Scene(BLOCK, 0.85, ground=ground, breaks=breaks)
    r = fmu.run({"excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 2.0}, 5.0, 0.01,
                outputs=["overturned", "overturnTime"])
    assert r.outputs["overturned"][-1] == 1
    sols = [solve_event_driven(scene, 5.0), solve_fixed_step(scene, 5.0, "rk4", 1e-3, True),
            solve_fixed_step(scene, 5.0, "newmark", 1e-3, True)]
    for s in sols:
        assert s.overturned, s.method
        assert abs(s.overturn_time - r.outputs["overturnTime"][-1]) < 1e-3


@pytest.mark.parametrize("rtol", ["1e-14", "1e-300"])
def test_scipy_refuses_a_tolerance_below_what_it_meets_in_one_line(fmu_path, rtol):
    """`--method scipy --rtol 1e-14` printed scipy's raw UserWarning (it raises rtol to 100
    machine epsilons), and `--rtol 1e-300` never returned. Both: one line, exit 2, no warning;
    the smallest rtol scipy meets runs."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent

    def simulate(r: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "runners.cli", "simulate", "examples/sine_pulse.toml",
                               "--method", "scipy", "--rtol", r, "--no-store", "-q"], capture_output=True,
                              text=True, cwd=root, env={**os.environ, "ROCKING_FMU": str(fmu_path)}, timeout=600)

    p = simulate(rtol)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and "below what scipy" in p.stderr and "3e-14" in p.stderr, p.stderr
    ok = simulate("3e-14")
    assert ok.returncode == 0 and "Warning" not in ok.stderr and "impacts" in ok.stdout, ok.stderr
