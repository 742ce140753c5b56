"""Bodies of real shape in RockingBlock.fmu (blockK.outline, docs/columns.md): a rectangle given as its
outline equals the block, and an off-centre body's uplift thresholds, free rocking and forced rocking
match the independent reference model/polygon_reference.py (derived without reading the engine: Lagrange
about either corner, the plastic impact about the landing corner, peaks from energy and times by
quadrature)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from model import polygon_reference as pr
from runners.engine.fmu import FMUError, RockingFMU

G = 9.81
TIGHT = {"solver.relTol": 1e-12, "solver.absTol": 1e-14}

# an off-centre body: base corners at x = -0.2 and 0.3 m, centre of mass at (0.02, 0.6) m, IG = 0.1 kg m^2
OFF = pr.RockingBody(xL=-0.2, xR=0.3, xG=0.02, yG=0.6, m=2.0, IG=0.1)
OFF_PARAMS = {"contact.model": 0, "block1.outline": "-0.2,0; 0.3,0; 0.3,1.3; -0.2,1.3", "block1.mass": 2.0,
              "block1.centreX": 0.02, "block1.centreY": 0.6, "block1.inertia": 0.1, "block1.theta0": 0.0, **TIGHT}


def rectangle(b: float, h: float) -> str:
    return f"{-b},0; {b},0; {b},{2 * h}; {-b},{2 * h}"


@pytest.mark.parametrize("n", [1, 2, 3])
def test_a_rectangle_given_as_its_outline_equals_the_block(fmu: RockingFMU, n: int):
    """Rocking-sliding columns of 1 to 3 blocks (a slender stone on a plinth under a 6 m/s2 sine pulse: rocking,
    sliding, impacts), each block once by its half sizes and once by the outline of the same rectangle: every
    rotation and slip within 1e-12 (rad, m) at every sample, the same events."""
    sizes = [[(0.2, 0.5, 200.0)], [(0.3, 0.25, 400.0), (0.2, 0.5, 200.0)],
             [(0.3, 0.25, 400.0), (0.25, 0.5, 300.0), (0.15, 0.45, 120.0)]][n - 1]
    base = {"nBlocks": n, "contact.model": 1, "contact.muGround": 0.6, "contact.muInterface": 0.5,
            "block1.theta0": 0.0, "excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 2.0}
    boxes, outlines = dict(base), dict(base)
    for k, (b, h, m) in enumerate(sizes, start=1):
        boxes.update({f"block{k}.halfWidth": b, f"block{k}.halfHeight": h, f"block{k}.mass": m})
        outlines.update({f"block{k}.outline": rectangle(b, h), f"block{k}.mass": m})
    names = [f"block{k}.{q}" for k in range(1, n + 1) for q in ("theta", "slip")]
    a = fmu.run(boxes, 2.5, 0.002, names)
    b = fmu.run(outlines, 2.5, 0.002, names)
    assert max(np.abs(a.outputs[x]).max() for x in names if x.endswith("theta")) > 0.01  # it rocks
    assert len(a.events) > 3 and [e.kind for e in a.events] == [e.kind for e in b.events]
    for x in names:
        assert np.abs(a.outputs[x] - b.outputs[x]).max() <= 1e-12, x


@pytest.mark.parametrize("side", [1, -1], ids=["right corner", "left corner"])
def test_an_off_centre_body_lifts_at_its_own_threshold_on_each_side(fmu: RockingFMU, side: int):
    """Under a constant ground acceleration the body stays at rest up to its threshold on that side and lifts
    just beyond it: -g bR / yG onto the right corner, g bL / yG onto the left (4.578 and 3.597 m/s2; the
    reference's moment balance), decided within 1e-10 of the threshold."""
    right, left = pr.uplift_thresholds(OFF, G)
    a = right if side > 0 else left
    assert a == pytest.approx(-G * OFF.bR / OFF.yG if side > 0 else G * OFF.bL / OFF.yG, rel=1e-14)
    for factor, lifts in ((1 - 1e-10, False), (1 + 1e-10, True)):
        r = fmu.run(OFF_PARAMS, 0.3, 0.01, ["block1.theta"], inputs=lambda t, a=a * factor: (a, 0.0))
        theta = r.outputs["block1.theta"]
        if lifts:
            assert np.sign(theta[-1]) == side and abs(theta[-1]) > 1e-12, (factor, theta[-1])
        else:
            assert np.all(theta == 0.0), (factor, np.abs(theta).max())


def test_an_off_centre_body_rocks_freely_as_the_exact_solution(fmu: RockingFMU):
    """Released from 0.15 rad with 0.3 rad/s (rocking on its right corner, whose pivot is farther from the
    centre): each peak on either side against the exact one from energy (the two sides' pivots differ), the
    times between impacts against quadrature, and the rates across each impact against the plastic law about
    the landing corner: 1e-10 over 12 impacts; the energy between impacts constant to 1e-10 of its scale."""
    theta0, omega0 = 0.15, 0.3
    r = fmu.run({**OFF_PARAMS, "block1.theta0": theta0, "block1.omega0": omega0}, 3.0, 0.002,
                ["block1.theta", "energy", "impacts"])
    ref = pr.free_rocking(OFF, theta0, omega0, 3.0, G)
    impacts, peaks = r.event_times("impact"), r.event_values("peak", "theta")
    n = 12
    assert len(impacts) >= n and len(ref.impact_times) >= n
    assert np.abs(np.diff(impacts[:n]) - np.diff(ref.impact_times[:n])).max() < 1e-10
    assert abs(impacts[0] - ref.impact_times[0]) < 1e-10
    assert np.abs(peaks[:n] - np.asarray(ref.peak_thetas[:n])).max() < 1e-10
    assert set(np.sign(peaks[:n])) == {-1.0, 1.0}  # both sides
    w_minus, w_plus = r.event_values("impact", "omega_minus"), r.event_values("impact", "omega_plus")
    assert np.abs(w_minus[:n] - np.asarray(ref.omega_before[:n])).max() < 1e-10
    assert np.abs(w_plus[:n] - np.asarray(ref.omega_after[:n])).max() < 1e-10
    # energy between the first impacts: constant (the samples strictly between impacts 1 and 2, 2 and 3)
    scale = OFF.m * G * OFF.yG
    for t0, t1 in zip(impacts[:3], impacts[1:4]):
        inside = (r.time > t0) & (r.time < t1)
        e = r.outputs["energy"][inside]
        assert len(e) > 10 and np.ptp(e) < 1e-10 * scale
        rest = pr.total_energy(OFF, 0.0, 0.0, G)  # (the FMU's energy is relative to rest)
        assert e[0] == pytest.approx(pr.total_energy(OFF, *_state_after(ref, t0), G) - rest, abs=1e-10 * scale)


def _state_after(ref: pr.FreeRockingResult, t: float) -> tuple[float, float]:
    """(theta, omega) just after the reference's impact at t."""
    i = int(np.argmin(np.abs(np.asarray(ref.impact_times) - t)))
    return 0.0, ref.omega_after[i]


@pytest.mark.parametrize("amplitude", [8.0, -6.0])
def test_an_off_centre_body_under_a_sine_pulse_follows_the_reference(fmu: RockingFMU, amplitude: float):
    """A 2 Hz sine pulse onto either side: uplift time, impacts and peaks against the reference's DOP853
    solution at rtol 1e-12 (its own accuracy, about 1e-11)."""
    ref = pr.simulate_sine_pulse(OFF, amplitude, 2.0, 2.0, G)
    r = fmu.run({**OFF_PARAMS, "excitation.kind": 1, "excitation.amplitude": amplitude,
                 "excitation.frequency": 2.0}, 2.0, 0.01, ["block1.theta"])
    assert r.event_times("uplift")[0] == pytest.approx(ref.uplift_times[0], abs=1e-10)
    n = min(len(ref.impact_times), 3)
    assert n >= 2 and np.abs(r.event_times("impact")[:n] - ref.impact_times[:n]).max() < 1e-8
    m = min(len(ref.peak_thetas), 3)
    assert np.abs(r.event_values("peak", "theta")[:m] - ref.peak_thetas[:m]).max() < 1e-8


def test_a_vase_tips_onto_its_side_where_its_hull_lands(fmu: RockingFMU):
    """A vase on a narrow foot (foot 0.16 m wide, body 0.4 m wide at 0.25 m, 0.7 m tall; uniform density):
    given a rate that carries it over, the run ends (overturned) where the hull edge next to the foot's corner
    reaches the ground: at the reference's landing angle, pi less the hull's interior angle there."""
    vase = [(-0.08, 0.0), (0.08, 0.0), (0.2, 0.25), (0.16, 0.6), (0.1, 0.7), (-0.1, 0.7), (-0.16, 0.6), (-0.2, 0.25)]
    outline = "; ".join(f"{x},{y}" for x, y in vase)
    beta_left, beta_right = pr.landing_angles(vase)
    assert beta_right == pytest.approx(math.pi - (math.pi - math.atan2(0.25, 0.12)), rel=1e-12)
    body = pr.body_from_polygon(vase, 20.0)
    r = fmu.run({"contact.model": 0, "block1.outline": outline, "block1.mass": 20.0, "block1.theta0": 0.05,
                 "block1.omega0": 1.0, **TIGHT}, 1.0, 0.001, ["block1.theta", "overturned", "overturnTime"])
    assert r.outputs["overturned"][-1] == 1
    over = r.event_times("overturn")
    assert len(over) == 1
    ref = pr.simulate_rocking(body, 1.0, G, theta0=0.05, omega0=1.0)
    assert ref.status == "side_lands" and over[0] == pytest.approx(ref.segments[-1][2], abs=1e-10)
    assert r.outputs["block1.theta"][-1] == pytest.approx(beta_right, abs=1e-15)  # it lies on that edge


@pytest.mark.parametrize("outline, text", [
    ("-0.2,0; 0.2,0; 0,0.1; 0.2,0.6; -0.2,0.6", "convex"),
    ("-0.2 0; 0.2,0; 0.2,0.6", "separated by ','"),
    ("-0.2,0; 0.2,0; 0.2,x", "not a number"),
    ("-0.2,0.1; 0.2,0; 0.2,0.6; -0.2,0.6", "base"),
    ("-0.2,0; 0.2,0", "3 vertices"),
])
def test_a_bad_outline_is_refused_in_one_line(fmu: RockingFMU, outline: str, text: str):
    with pytest.raises(FMUError) as err:
        fmu.run({"block1.outline": outline, "contact.model": 1}, 0.1, 0.1, ["block1.theta"])
    message = str(err.value)
    assert "block1.outline" in message and text in message and "\n" not in message


def test_one_body_of_real_shape_takes_the_plastic_impact_law(fmu: RockingFMU):
    with pytest.raises(FMUError, match="restitution.law = 0"):
        fmu.run({**OFF_PARAMS, "restitution.law": 2}, 0.1, 0.1, ["block1.theta"])
