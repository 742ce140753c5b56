"""The FMU's rocking-sliding model (contact.model = 1) against Siconos, an independent nonsmooth peer.

`model/siconos_blocks.py` runs the same bodies (rigid rectangles, unilateral corners, Coulomb friction,
plastic impacts) with Siconos' event-capturing Moreau-Jean time stepping (Acary & Brogliato 2008),
under the system Python (Debian package python3-siconos, not the project's venv), called here as a
real subprocess. Moreau-Jean is first order across impacts and contact changes, so each case is run
at h = 1e-3, 1e-4 and 1e-5 s and its largest difference from the FMU over the run must shrink about
tenfold per tenfold smaller step (at least threefold), down to below 1e-3 m (and 1e-3 rad) at the
finest step. Every test is slow (`.venv/bin/python -m pytest -m slow tests/test_siconos.py`, about
eight minutes in all) and is skipped where /usr/bin/python3 cannot import siconos.
"""
from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from runners.engine.fmu import RockingFMU

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "model" / "siconos_blocks.py"
SICONOS_PYTHON = "/usr/bin/python3"
STEPS = (1e-3, 1e-4, 1e-5)  # s, Moreau-Jean's time steps
OUT_STEP = 0.001  # s, the FMU's communication step: the points compared
FINEST_LIMIT = 1e-3  # m (slips, gaps) and rad (rotations) at the finest step
RATIO = 3.0  # each tenfold smaller step divides the largest difference by at least this


@pytest.fixture(scope="module")
def siconos() -> str:
    """The Python that imports siconos, or a skip saying how to get it."""
    how = ("the Siconos peer (model/siconos_blocks.py) needs Debian's python3-siconos and python3-scipy: "
           "apt-get install python3-siconos python3-scipy (as root; `make bench` does it where it can)")
    try:
        proc = subprocess.run([SICONOS_PYTHON, "-c", "import siconos.kernel, siconos.numerics"],
                              capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.skip(f"{SICONOS_PYTHON} cannot run ({exc}); {how}")
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        pytest.skip(f"{SICONOS_PYTHON} cannot import siconos ({last}); {how}")
    return SICONOS_PYTHON


def run_siconos(python: str, case: dict) -> dict:
    """model/siconos_blocks.py on one case (its docstring's JSON input), as a subprocess: its JSON output."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([python, str(SCRIPT), "-"], input=json.dumps(case), capture_output=True, text=True,
                          env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    run = json.loads(proc.stdout)
    assert run["solver_warnings"] == 0, f"the friction-contact solver did not converge: {proc.stderr[-2000:]}"
    return run


def convergence(fmu_out: dict[str, np.ndarray], python: str, case: dict, names: Sequence[str],
                steps: Sequence[float] = STEPS) -> dict[str, list[float]]:
    """Largest |Siconos - FMU| over the output points per FMU output name (`blockK.q`, q one of
    Siconos' per-body outputs: theta rad, slip m, gap m), one entry per step of `steps`."""
    errors: dict[str, list[float]] = {n: [] for n in names}
    for h in steps:
        run = run_siconos(python, {**case, "h": h})
        for name in names:
            body, quantity = name.split(".")
            got = np.asarray(run["blocks"][int(body[-1]) - 1][quantity])
            errors[name].append(float(np.max(np.abs(got - fmu_out[name]))))
    return errors


def check_convergence(errors: dict[str, list[float]]) -> None:
    """Each tenfold smaller step divides every largest difference by RATIO or more, and the finest is
    below FINEST_LIMIT; the message (and pytest -s) gives the measured table."""
    table = "\n".join(f"  {n}: " + ", ".join(f"h={h:g}: {e:.3g}" for h, e in zip(STEPS, errs))
                      for n, errs in errors.items())
    print(f"largest |Siconos - FMU|:\n{table}")  # (shown with pytest -s)
    for name, errs in errors.items():
        for coarse, fine in zip(errs, errs[1:]):
            assert fine * RATIO <= coarse or fine <= 1e-9, f"{name} does not converge at first order:\n{table}"
        assert errs[-1] < FINEST_LIMIT, f"{name} at the finest step:\n{table}"


def fmu_run(fmu: RockingFMU, params: dict, t_end: float, names: Sequence[str]):
    res = fmu.run(params, t_end, OUT_STEP, list(names))
    return res.time, res.outputs, res


SQUAT = {"contact.model": 1, "block1.halfWidth": 0.3, "block1.halfHeight": 0.36, "block1.mass": 1.0,
         "contact.muGround": 0.3, "block1.theta0": 0.0,
         "excitation.kind": 1, "excitation.amplitude": 3.0, "excitation.verticalAmplitude": -15.0,
         "excitation.frequency": 2.0}


def test_a_squat_block_that_slides_flies_and_lands_converges_to_the_fmu(fmu, siconos):
    """The squat block (b = 0.3 m, h = 0.36 m, mu = 0.3) under a sine pulse A = 3 m/s2, V = -15 m/s2,
    f = 2 Hz: it slides, flies (lift-off at 0.0567 s), lands flat at 0.3471 s and stops at
    slip -0.0901546 m. Largest differences over 0..1 s (measured, theta = 0.5):

        h (s)     slip (m)   gap (m)
        1e-3      1.2e-4     6.5e-4
        1e-4      2.0e-5     1.1e-4
        1e-5      1.7e-6     9.0e-6
    """
    names = ["block1.slip", "block1.gap", "block1.theta"]
    t, out, res = fmu_run(fmu, SQUAT, 1.0, names)
    kinds = {e.kind: e.t for e in reversed(res.events)}
    assert kinds["flight"] == pytest.approx(0.0567, abs=1e-4) and kinds["land"] == pytest.approx(0.3471, abs=1e-4)
    assert out["block1.slip"][-1] == pytest.approx(-0.0901546, abs=1e-7)
    case = {"blocks": [{"b": 0.3, "h": 0.36, "m": 1.0}], "mu": 0.3,
            "excitation": {"kind": "sine", "A": 3.0, "V": -15.0, "f": 2.0}, "t_end": 1.0, "t_out": t.tolist()}
    errors = convergence(out, siconos, case, names)
    check_convergence({n: errors[n] for n in names[:2]})
    assert max(errors["block1.theta"]) < 1e-12  # it never tips: both stay flat


SLENDER = {"contact.model": 1, "block1.halfWidth": 0.15, "block1.halfHeight": 0.6, "block1.mass": 1.0,
           "contact.muGround": 0.8, "block1.theta0": 0.0,
           "excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.verticalAmplitude": -13.0,
           "excitation.frequency": 2.5}


def test_a_slender_block_that_rocks_flies_and_lands_on_a_corner_converges_to_the_fmu(fmu, siconos):
    """A slender block (b = 0.15 m, h = 0.6 m, mu = 0.8) under A = 4 m/s2, V = -13 m/s2 (beyond g),
    f = 2.5 Hz: it rocks (0.022 s), slide-rocks (0.049 s), flies (0.054 s), lands on a corner
    (0.244 s) and rocks on with impacts at 0.329, 0.800 and 1.211 s. Largest differences over
    0..1.5 s (measured, theta = 0.5):

        h (s)     theta (rad)   slip (m)   gap (m)
        1e-3      2.7e-2        1.7e-4     2.9e-4
        1e-4      4.0e-3        2.7e-5     4.8e-5
        1e-5      3.4e-4        2.2e-6     3.9e-6

    (theta's difference is largest late in the run, where the impact times differ by O(h).)
    """
    names = ["block1.theta", "block1.slip", "block1.gap"]
    t, out, res = fmu_run(fmu, SLENDER, 1.5, names)
    kinds = [e.kind for e in res.events]
    assert kinds[:5] == ["uplift", "slide", "flight", "impact", "land"], kinds
    assert kinds.count("impact") >= 3 and "overturn" not in kinds
    case = {"blocks": [{"b": 0.15, "h": 0.6, "m": 1.0}], "mu": 0.8,
            "excitation": {"kind": "sine", "A": 4.0, "V": -13.0, "f": 2.5}, "t_end": 1.5, "t_out": t.tolist()}
    check_convergence(convergence(out, siconos, case, names))


STATUE = {"nBlocks": 2, "contact.model": 1, "block1.halfWidth": 0.3, "block1.halfHeight": 0.5, "block1.mass": 450.0,
          "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 690.0, "block1.theta0": 0.0,
          "block2.theta0": 0.0, "contact.muGround": 0.5, "contact.muInterface": 0.5,
          "excitation.kind": 1, "excitation.amplitude": 6.0, "excitation.frequency": 1.5, "solver.relTol": 1e-10}


def test_the_marble_statue_on_its_plinth_converges_to_the_fmu(fmu, siconos):
    """examples/marble_statue_on_plinth.toml (plinth 0.6 x 1.0 m, 450 kg; statue 0.4 x 1.6 m, 690 kg;
    mu = 0.5 at both contacts) under a 6 m/s2, 1.5 Hz sine pulse: the pair rocks, the statue rocks on
    the plinth, both contacts slide and stick, the plinth settles after a cascade of impacts and the
    statue leans out towards overturning; compared up to 1.9 s. Largest differences (measured,
    theta = 0.5, the FMU at relTol 1e-10):

        h (s)     theta1 (rad)   theta2 (rad)   slip1 (m)   slip2 (m)
        1e-3      1.7e-3         3.0e-2         1.0e-3      1.5e-3
        1e-4      3.7e-4         3.7e-3         6.5e-5      7.8e-5
        1e-5      2.8e-5         1.5e-4         9.3e-6      8.5e-6

    The FMU runs the stack on its contact engine; the gaps are compared too.
    """
    names = ["block1.theta", "block2.theta", "block1.slip", "block2.slip"]
    if "block2.gap" in fmu.vars:
        names += ["block1.gap", "block2.gap"]
    t, out, res = fmu_run(fmu, STATUE, 1.9, names)
    kinds = [e.kind for e in res.events]
    assert "flight" not in kinds and "overturn" not in kinds and "fell-off" not in kinds, kinds
    case = {"blocks": [{"b": 0.3, "h": 0.5, "m": 450.0}, {"b": 0.2, "h": 0.8, "m": 690.0}], "mu": 0.5,
            "mu_interface": 0.5, "excitation": {"kind": "sine", "A": 6.0, "f": 1.5}, "t_end": 1.9,
            "t_out": t.tolist()}
    check_convergence(convergence(out, siconos, case, names))


def test_the_marble_stack_under_a_near_field_record_converges_to_the_fmu_through_the_statues_flight(
        fmu, siconos, tmp_path):
    """The marble statue on its plinth under FEMA P695 near-field record 1a scaled to PGA 0.5 g: the
    statue leaves the plinth's top at 7.755 s (up to 2.4 cm above it) and the plinth overturns at 7.887 s,
    taking it along. Compared up to 7.85 s, through the flight, at h = 1e-4 and 1e-5 s (1e-3 s is too
    coarse for 7.85 s of rocking under a record: its errors are of the angles' size). Measured:

        h (s)   theta1 (rad)  theta2 (rad)  slip1 (m)  slip2 (m)  gap2 (m)   theta1 reaches pi/2
        1e-4    1.8e-1        1.1e-1        1.9e-3     1.2e-2     2.0e-2     7.84 s
        1e-5    5.9e-3        4.0e-3        4.0e-5     1.9e-4     4.5e-4     7.89 s   (FMU: 7.887 s)

    A long chaotic run: the finest step's differences are held to 1e-2 (rad, m), and the plinth's
    overturn to 0.02 s of the FMU's, nearer than at the coarser step."""
    from tests.test_records_fmu import fema_component, write_record

    t, a = fema_component("nearfield_pulse", 1, "a")
    scale = 0.5 * 9.80665 / float(np.max(np.abs(a)))
    path = write_record(tmp_path / "record.txt", t, a)
    params = {**{k: v for k, v in STATUE.items() if not k.startswith("excitation.")}, "excitation.kind": 4,
              "excitation.file": str(path), "excitation.scale": scale}
    names = ["block1.theta", "block2.theta", "block1.slip", "block2.slip", "block1.gap", "block2.gap"]
    stop, compared = 8.0, 7.85
    res = fmu.run(params, stop, 0.01, names)
    kinds = {e.kind: e.t for e in reversed(res.events)}  # the first of each kind
    assert 7.7 < kinds["flight"] < compared < kinds["overturn"] < stop, kinds
    keep = res.time <= compared + 1e-9
    case = {"blocks": [{"b": 0.3, "h": 0.5, "m": 450.0}, {"b": 0.2, "h": 0.8, "m": 690.0}], "mu": 0.5,
            "mu_interface": 0.5, "t_end": stop, "t_out": res.time.tolist(),
            "excitation": {"kind": "record", "t": t.tolist(), "ah": (scale * a).tolist(), "av": [0.0] * len(t)}}
    errors: dict[str, list[float]] = {n: [] for n in names}
    overturn = []
    for h in (1e-4, 1e-5):
        run = run_siconos(siconos, {**case, "h": h})
        for name in names:
            got = np.asarray(run["blocks"][int(name[5]) - 1][name.split(".")[1]])
            errors[name].append(float(np.max(np.abs(got[keep] - res.outputs[name][keep]))))
        theta1 = np.abs(np.asarray(run["blocks"][0]["theta"]))
        assert theta1.max() >= np.pi / 2  # the plinth overturns in the peer too
        overturn.append(float(res.time[np.argmax(theta1 >= np.pi / 2)]))
    table = "\n".join(f"  {n}: {e}" for n, e in errors.items())
    print(f"largest |Siconos - FMU| to {compared} s at h = 1e-4, 1e-5:\n{table}\noverturn {overturn}")
    for name, (coarse, fine) in errors.items():
        assert fine * RATIO <= coarse or fine <= 1e-9, f"{name} does not converge:\n{table}"
        assert fine < 1e-2, f"{name} at the finest step:\n{table}"
    late = [abs(o - kinds["overturn"]) for o in overturn]
    assert late[1] <= 0.02 and late[1] <= late[0], (overturn, kinds["overturn"])


def test_the_peer_gives_the_closed_forms_of_a_coulomb_block_and_of_ballistic_flight(siconos):
    """Its own check, without the FMU: a block sliding flat on a level ground under a constant
    a_h = 5 m/s2 (slip -(a_h - mu g) t^2 / 2, exact with theta = 0.5 and a constant force, to the
    solver's tolerance) and under a
    record rising linearly (a_h = 20 t: slip -20 (t - t_s)^3 / 6 after a_h reaches mu g at t_s), and a
    block flying from rest under a_v = -20 m/s2 plus a sine pulse (slip -A r(t), gap
    -(g + a_v) t^2 / 2 - V r(t), r(t) = t / w - sin(w t) / w^2), at h = 1e-3 s."""
    t = np.linspace(0.0, 0.5, 11)
    run = run_siconos(siconos, {"blocks": [{"b": 0.3, "h": 0.36, "m": 1.0}], "mu": 0.3, "h": 1e-3,
                                "excitation": {"kind": "constant", "ah": 5.0}, "t_end": 0.5, "t_out": t.tolist()})
    b = run["blocks"][0]
    # (to the friction-contact solver's tolerance, 1e-10)
    assert np.abs(np.asarray(b["slip"]) + (5.0 - 0.3 * 9.81) * t ** 2 / 2).max() < 1e-9
    assert np.abs(np.asarray(b["gap"])).max() < 1e-9 and np.abs(np.asarray(b["theta"])).max() < 1e-9
    ramp_record = {"kind": "record", "t": [0.0, 0.5], "ah": [0.0, 10.0]}  # a_h = 20 t m/s2, linear: exact means
    run = run_siconos(siconos, {"blocks": [{"b": 0.3, "h": 0.36, "m": 1.0}], "mu": 0.3, "h": 1e-3,
                                "excitation": ramp_record, "t_end": 0.5, "t_out": t.tolist()})
    t_slide = 0.3 * 9.81 / 20.0  # s, where a_h reaches mu g: then slip'' = -(20 t - mu g)
    expected = -np.where(t > t_slide, 20.0 * (t - t_slide) ** 3 / 6, 0.0)
    assert np.abs(np.asarray(run["blocks"][0]["slip"]) - expected).max() < 1e-5
    A, V, f, w = 2.0, 3.0, 2.0, 4.0 * np.pi
    t = np.linspace(0.0, 0.4, 9)
    run = run_siconos(siconos, {"blocks": [{"b": 0.3, "h": 0.36, "m": 1.0}], "mu": 0.3, "h": 1e-3, "t_end": 0.4,
                                "excitation": [{"kind": "constant", "av": -20.0},
                                               {"kind": "sine", "A": A, "V": V, "f": f}], "t_out": t.tolist()})
    b, ramp = run["blocks"][0], t / w - np.sin(w * t) / w ** 2
    assert np.abs(np.asarray(b["slip"]) + A * ramp).max() < 1e-6
    assert np.abs(np.asarray(b["gap"]) - (-(9.81 - 20.0) * t ** 2 / 2 - V * ramp)).max() < 1e-6


@pytest.mark.parametrize("n, amplitude, t_end", [(3, 7.0, 0.45), (5, 6.0, 0.31)], ids=["3 drums", "5 drums"])
def test_a_column_of_squat_drums_rocking_as_one_converges_to_one_block_of_its_size(fmu, siconos, n, amplitude,
                                                                                  t_end):
    """A column of n squat drums (each b = 0.5 m, h = 0.25 m, 400 kg, mu = 0.9 everywhere) under a 2 Hz sine pulse
    above the column's uplift acceleration g b / (n h) and far below a drum's own: Siconos' column of n bodies
    (every corner a contact) converges to the FMU's one block of the column's height and mass, each drum's rotation
    to the block's, and the drums' rotations relative to each other to 0. Measured (largest differences):

        3 drums, 7 m/s2, 0.45 s (5 small impacts):  h = 1e-3: 5.2e-5 rad   1e-4: 4.9e-6   1e-5: 6.2e-7
        5 drums, 6 m/s2, 0.31 s:                    h = 1e-3: 7.5e-5 rad   1e-4: 1.2e-6   1e-5: 5.0e-8

    (Over a larger rocking the drums' impacts differ: Siconos resolves each contact of the column at an impact,
    which can open an interface, where one block's impact law pivots it whole.)"""
    b, h, m = 0.5, 0.25, 400.0
    params = {"contact.model": 1, "block1.halfWidth": b, "block1.halfHeight": n * h, "block1.mass": n * m,
              "contact.muGround": 0.9, "excitation.kind": 1, "excitation.amplitude": amplitude,
              "excitation.frequency": 2.0}
    t, out, res = fmu_run(fmu, params, t_end, ["block1.theta"])
    assert np.abs(out["block1.theta"]).max() > 5e-4  # it rocks
    case = {"blocks": [{"b": b, "h": h, "m": m}] * n, "mu": 0.9, "mu_interface": 0.9,
            "excitation": {"kind": "sine", "A": amplitude, "V": 0.0, "f": 2.0}, "t_end": t_end, "t_out": t.tolist()}
    errors, relative = [], []
    for step in STEPS:
        run = run_siconos(siconos, {**case, "h": step})
        thetas = [np.asarray(run["blocks"][k]["theta"]) for k in range(n)]
        errors.append(max(float(np.max(np.abs(x - out["block1.theta"]))) for x in thetas))
        relative.append(max(float(np.max(np.abs(x - thetas[0]))) for x in thetas))
    assert all(a > RATIO * c for a, c in zip(errors, errors[1:])) and errors[-1] < 1e-6, errors
    assert relative[-1] < 1e-6 and relative[-1] < relative[0] / 10, relative


HOLD = 0.01  # m/s: the peer holds its active contacts to a gap of HOLD h (model/siconos_blocks.py's "hold")
TAPERED3 = [(0.4, 0.4, 400.0), (0.35, 0.4, 300.0), (0.3, 0.4, 200.0)]  # (b m, h m, m kg), bottom up


def column_params(blocks: Sequence[tuple[float, float, float]], mu: float) -> dict:
    """The FMU's column of `blocks` (b, h, m bottom up), mu at every contact, starting flat at rest."""
    params = {"contact.model": 1, "nBlocks": len(blocks), "contact.muGround": mu, "contact.muInterface": mu,
              "block1.theta0": 0.0, "block2.theta0": 0.0}
    for k, (b, h, m) in enumerate(blocks, 1):
        params.update({f"block{k}.halfWidth": b, f"block{k}.halfHeight": h, f"block{k}.mass": m})
    return params


def test_a_tapered_column_of_three_drums_that_opens_and_slides_converges_to_the_fmu(fmu, siconos):
    """Three drums narrowing upwards (b = 0.4, 0.35, 0.3 m, each h = 0.4 m; 400, 300, 200 kg; mu = 0.5 at every
    contact; narrower drums so that every corner stays on the face below, which the peer's corner-on-plane contacts
    need) under a 6 m/s2, 2 Hz sine pulse: the column uplifts (0.055 s), the top drum slides (0.244 s), the lower
    interface opens (0.260 s), then impacts on the ground and at both interfaces (0.344 to 0.392 s) with slides,
    sticks and reversals, the column rocks to 0.077 rad and lands on its other corner at 0.958 s, where the ground's
    impact meets five touching corners above it. Compared to 1.0 s (every block's rotation and slip), the peer
    holding its active contacts (HOLD). Measured (largest differences):

        h (s)     theta1 (rad)  theta2 (rad)  theta3 (rad)  slip1 (m)  slip2 (m)  slip3 (m)
        1e-3      3.0e-3        3.7e-3        4.7e-3        2.9e-4     2.8e-4     7.4e-4
        1e-4      5.0e-4        5.9e-4        6.8e-4        3.2e-5     4.0e-5     9.6e-5
        1e-5      3.6e-5        4.5e-5        5.2e-5        3.1e-6     3.1e-6     8.6e-6

    Without the hold the peer's ground impact at 0.958 s leaves out an interface corner that rounding put a hair
    above its activation threshold (1.0e-9 m against its 1e-9 m margin) and opens both interfaces there (rotation
    rates -0.31, -0.31, -1.11 rad/s after it, where the FMU and the held peer give -0.45477 for all three): 3.4e-3
    rad from 0.958 s on at h = 1e-4 and 1e-5 s alike. Past 1.0 s the coarser steps branch again (9e-3 rad at
    1.6 to 1.8 s at h = 1e-3 and 1e-4 s; 3.5e-5 rad over 0..2 s at h = 1e-5 s)."""
    names = [f"block{k}.{q}" for k in (1, 2, 3) for q in ("theta", "slip")]
    params = {**column_params(TAPERED3, 0.5), "excitation.kind": 1, "excitation.amplitude": 6.0,
              "excitation.frequency": 2.0}
    t, out, res = fmu_run(fmu, params, 1.0, names)
    kinds = [e.kind for e in res.events]
    assert "open" in kinds and "slide" in kinds and kinds.count("impact") >= 6, kinds
    assert not {"flight", "fell-off", "overturn"} & set(kinds), kinds
    assert np.abs(out["block3.slip"]).max() > 5e-3  # the top drum slides 5.7 mm
    case = {"blocks": [{"b": b, "h": h, "m": m} for b, h, m in TAPERED3], "mu": 0.5, "mu_interface": 0.5,
            "excitation": {"kind": "sine", "A": 6.0, "f": 2.0}, "t_end": 1.0, "t_out": t.tolist(), "hold": HOLD}
    check_convergence(convergence(out, siconos, case, names))


TAPERED5 = [(0.45, 0.3, 500.0), (0.4, 0.3, 400.0), (0.35, 0.3, 300.0), (0.3, 0.3, 200.0), (0.25, 0.3, 150.0)]


def test_a_tapered_column_of_five_drums_that_opens_slides_and_flies_converges_to_the_fmu(fmu, siconos):
    """Five drums narrowing upwards (b = 0.45 to 0.25 m, each h = 0.3 m; 500 to 150 kg; mu = 0.6 at every contact)
    under a 6 m/s2, 2 Hz sine pulse: the column uplifts (0.055 s), both lower interfaces open (0.222, 0.259 s), and
    from 0.324 s on drums impact, slide, stick, fly off the drum below and land (the whole column in flight
    at 0.40464 s, landing at 0.40472 s), 20 impacts to 0.8 s. Compared to 0.8 s, every drum's rotation and slip, the
    peer holding its active contacts (HOLD). Measured (largest differences):

        h (s)   theta1   theta2   theta3   theta4   theta5   slip1    slip2    slip3    slip4    slip5
        1e-3    5.9e-3   1.9e-2   2.4e-2   2.4e-2   2.5e-2   2.3e-4   1.7e-3   5.2e-4   5.6e-4   1.3e-3
        1e-4    6.4e-4   1.7e-3   2.5e-3   2.3e-3   2.4e-3   2.7e-5   2.9e-4   3.1e-4   6.7e-5   1.6e-4
        1e-5    4.9e-5   1.6e-4   2.6e-4   2.4e-4   2.4e-4   2.8e-6   3.1e-5   4.3e-5   7.1e-6   1.6e-5

    (rad, m). slip3's first tenfold step gains only 1.7 times (h = 1e-3 s is coarse for it): every difference must
    shrink RATIO times from 1e-4 to 1e-5 s and RATIO^2 times from 1e-3 to 1e-5 s. Past 0.8 s the peer and the FMU part at every step alike (2.9e-2 rad by 0.9 s at h = 1e-3, 1e-4 and 1e-5 s),
    after the impacts of 0.819 s (the top three drums leave the second) and 0.856 s (interface 1's impact lands
    them): left open (see the report of this test's commit)."""
    names = [f"block{k}.{q}" for k in range(1, 6) for q in ("theta", "slip")]
    params = {**column_params(TAPERED5, 0.6), "excitation.kind": 1, "excitation.amplitude": 6.0,
              "excitation.frequency": 2.0}
    t, out, res = fmu_run(fmu, params, 0.8, names)
    kinds = [e.kind for e in res.events]
    assert {"open", "slide", "flight", "land"} <= set(kinds) and kinds.count("impact") >= 20, kinds
    assert not {"fell-off", "overturn"} & set(kinds), kinds
    case = {"blocks": [{"b": b, "h": h, "m": m} for b, h, m in TAPERED5], "mu": 0.6, "mu_interface": 0.6,
            "excitation": {"kind": "sine", "A": 6.0, "f": 2.0}, "t_end": 0.8, "t_out": t.tolist(), "hold": HOLD}
    errors = convergence(out, siconos, case, names)
    print("\n".join(f"  {n}: " + ", ".join(f"{e:.2g}" for e in errs) for n, errs in errors.items()))
    for name, (coarse, mid, fine) in errors.items():
        assert fine * RATIO <= mid and fine * RATIO ** 2 <= coarse and fine < FINEST_LIMIT, (name, errors)


G0 = 9.80665  # m/s2, the g of a record's PGA


def rest_limit(blocks: Sequence[tuple[float, float, float]], mu: float, g: float = 9.81) -> float:
    """The least horizontal ground acceleration (m/s2) that can move a column of `blocks` (b, h, m bottom up)
    standing flat: the stack above any contact tipping on the upper body's corner (g b_k over the stack's centre
    height above that contact) or sliding (mu g)."""
    limits = [mu * g]
    for k, (b, _, _) in enumerate(blocks):
        above = blocks[k:]
        y, moment = 0.0, 0.0
        for _, h, m in above:
            moment += m * (y + h)
            y += 2.0 * h
        limits.append(g * b * sum(m for _, _, m in above) / moment)
    return min(limits)


def near_field_column(tmp_path: Path, blocks: Sequence[tuple[float, float, float]], mu: float, record: int,
                      pga: float, crop: float) -> tuple[dict, dict]:
    """The FMU's parameters and the peer's case (with HOLD) for a column of `blocks` under FEMA P695 near-field
    record `record`, component a, scaled to `pga` (g) and started at `crop` s of the record (times shifted to
    0): before `crop` the scaled record stays below rest_limit, so the column would stand still there in both."""
    from tests.test_records_fmu import fema_component, write_record

    t, a = fema_component("nearfield_pulse", record, "a")
    scale = pga * G0 / float(np.max(np.abs(a)))
    keep = t >= crop - 1e-9
    assert scale * float(np.max(np.abs(a[~keep]))) < rest_limit(blocks, mu)
    t, a = t[keep] - t[keep][0], a[keep]
    path = write_record(tmp_path / f"nearfield_{record}a.txt", t, a)
    params = {**column_params(blocks, mu), "excitation.kind": 4, "excitation.file": str(path),
              "excitation.scale": scale}
    case = {"blocks": [{"b": b, "h": h, "m": m} for b, h, m in blocks], "mu": mu, "mu_interface": mu, "hold": HOLD,
            "excitation": {"kind": "record", "t": t.tolist(), "ah": (scale * a).tolist(), "av": [0.0] * len(t)}}
    return params, case


def largest_differences(run: dict, out: dict[str, np.ndarray], names: Sequence[str], keep: np.ndarray) -> dict:
    """Largest |Siconos - FMU| per output name over the output points `keep` (a mask)."""
    return {n: float(np.max(np.abs(np.asarray(run["blocks"][int(n[5]) - 1][n.split(".")[1]])[keep]
                                   - out[n][keep]))) for n in names}


def test_a_tapered_column_of_three_drums_under_a_near_field_record_converges_to_the_fmu(fmu, siconos, tmp_path):
    """The three tapered drums (TAPERED3, mu = 0.5) under FEMA P695 near-field record 7a (Cape Mendocino 1992,
    Petrolia) scaled to PGA 0.6 g, from 2.5 s of the record (the column stands still before: the scaled record
    stays below 1.03 m/s2 there, rest_limit 3.84 m/s2; on the whole record the FMU's run is the same to 2e-15):
    the column uplifts at 0.486 s, interface 1 opens four times (0.559, 0.949, 1.253, 1.677 s), 29 impacts (12 on
    the ground, 17 at the interfaces) and 26 slides (ground and both interfaces), rocking to 0.0665 rad with the top
    drum sliding 13.5 mm. Compared to 1.95 s, every drum's rotation and slip, the peer holding its active contacts
    (HOLD). Measured (largest differences):

        h (s)     theta1 (rad)  theta2 (rad)  theta3 (rad)  slip1 (m)  slip2 (m)  slip3 (m)
        1e-3      3.1e-3        4.1e-3        5.1e-3        5.0e-4     1.3e-3     2.0e-3
        1e-4      5.1e-4        5.6e-4        6.3e-4        5.7e-5     1.4e-4     1.7e-4
        1e-5      6.1e-5        7.0e-5        7.9e-5        9.1e-6     2.2e-5     2.5e-5

    The window ends before the ground impact at 1.979345 s, which interface 1's impact follows 32 us later
    (1.979377 s; drum 2 rocking on drum 1 since 1.967 s) and interface 2's at 1.979379 s. Both resolve one plastic
    impact with friction over every contact touching at the time; at h = 1e-4 s (and 1e-3 s) the peer's step
    holds both impacts, so it resolves them as one impact of the whole column (rates -0.391 rad/s for all three
    drums just after), where the FMU's two impacts in sequence leave -0.325, -0.452, -0.452 rad/s and the peer
    at h = 1e-5 s (three steps between them) -0.329, -0.463, -0.463 rad/s. From there the coarser steps follow
    another motion (to 3.3 s: 2.7e-2 rad, 2.3e-2 m at h = 1e-3 s; 2.5e-2 rad, 2.4e-2 m at 1e-4 s), and the finest step stays with
    the FMU through the whole motion (to its rest at 3.119 s, the top drum sliding 3.1 cm): 2.0e-4 rad and
    5.2e-4 m over 0..3.3 s at h = 1e-5 s, held below FINEST_LIMIT here."""
    params, case = near_field_column(tmp_path, TAPERED3, 0.5, record=7, pga=0.6, crop=2.5)
    names = [f"block{k}.{q}" for k in (1, 2, 3) for q in ("theta", "slip")]
    window, stop = 1.95, 3.3
    t, out, res = fmu_run(fmu, params, stop, names)
    kinds = [e.kind for e in res.events if e.t <= window]
    assert kinds.count("open") >= 3 and kinds.count("impact") >= 25 and kinds.count("slide") >= 20, kinds
    assert not {"flight", "fell-off", "overturn"} & {e.kind for e in res.events}, kinds
    keep = t <= window + 1e-9
    assert np.abs(out["block1.theta"][keep]).max() > 0.06 and np.abs(out["block3.slip"][keep]).max() > 0.01
    impacts = {c: [e.t for e in res.events if e.kind == "impact" and e.labels.get("contact") == c and 1.97 < e.t < 1.99]
               for c in ("ground", "interface1")}
    assert impacts["ground"] and impacts["interface1"], impacts
    assert 0.0 < impacts["interface1"][0] - impacts["ground"][0] < 1e-4, impacts  # two impacts 32 us apart
    errors: dict[str, list[float]] = {n: [] for n in names}
    for h in STEPS:
        run = run_siconos(siconos, {**case, "h": h, "t_end": stop, "t_out": t.tolist()})
        for n, e in largest_differences(run, out, names, keep).items():
            errors[n].append(e)
    whole = largest_differences(run, out, names, np.ones_like(keep))  # the finest step over 0..stop
    print(f"at h = 1e-5 s over 0..{stop} s: {whole}")
    check_convergence(errors)
    assert max(whole.values()) < FINEST_LIMIT, whole


def test_a_tapered_column_of_five_drums_under_a_near_field_record_converges_to_the_fmu(fmu, siconos, tmp_path):
    """The five tapered drums (TAPERED5, mu = 0.6) under FEMA P695 near-field record 6a (Erzincan 1992) scaled to
    PGA 0.5 g, from 2.4 s of the record (the scaled record stays below 1.54 m/s2 before, rest_limit 3.83 m/s2): the
    column uplifts at 0.478 s (to -0.013 rad), interface 1 opens at 0.787 s (drums 2 to 5 rocking on drum 1), drum 1
    lands flat at 0.913 s, drums 2 to 5 land on it at 0.940 s and impacts run up the interfaces (0.940 to 0.964 s)
    with slides at the ground and at every interface (drums 2 to 4 by 0.7, 1.1, 0.7 mm), then the column rocks the
    other way opening interfaces 2 and 3 (drums 4 and 5 to 0.026 rad, drums 1 and 2 0.004 rad) and drum 1 lifts
    off its other corner at 1.001 s: 8 impacts, 9 slides. Compared to 1.09 s, every drum's rotation and slip, the
    peer holding its active contacts (HOLD). Measured (largest differences; rad, m):

        h (s)   theta1   theta2   theta3   theta4   theta5   slip1    slip2    slip3    slip4    slip5
        1e-3    8.2e-4   1.7e-3   1.5e-3   5.7e-3   6.3e-3   3.0e-6   2.0e-4   3.4e-4   6.1e-4   2.3e-4
        1e-4    8.8e-5   1.9e-4   1.5e-4   5.8e-4   6.6e-4   1.0e-6   2.2e-5   4.1e-5   7.3e-5   7.8e-5
        1e-5    8.9e-6   1.2e-5   1.7e-5   6.1e-5   6.6e-5   9.8e-8   2.2e-6   3.7e-6   7.2e-6   8.8e-6

    (drum 1 hardly slides, 4 um: its slip's first tenfold step gains 3.0 times; as in the sine-pulse column of five,
    every difference must shrink RATIO times from 1e-4 to 1e-5 s and RATIO^2 times from 1e-3 to 1e-5 s.) The
    window ends where the FMU's events come closer than the finest step: at 1.090215 s, at interface 1's impact,
    the FMU puts all five drums in flight for 0.21 ms, their five landings at 1.090424 s lie within 0.4 us, and at
    1.09923 s three impacts at interfaces 2 and 3 come within 3 us (1.4 and 1.6 us apart). A step of 1e-5 s holds
    each cluster as one impact of every contact in it, and the differences stop shrinking: over 0..1.8 s (the
    column at rest from 1.671 s) the largest differences are 4.0e-4 rad and
    3.3e-4 m at h = 1e-5 s, drum 1's rotation only 1.9 times smaller than at h = 1e-4 s (1.25e-4 against 2.4e-4
    rad at 1.163 s) and drum 2's slip 1.8 times."""
    params, case = near_field_column(tmp_path, TAPERED5, 0.6, record=6, pga=0.5, crop=2.4)
    names = [f"block{k}.{q}" for k in range(1, 6) for q in ("theta", "slip")]
    window = 1.09
    t, out, res = fmu_run(fmu, params, 1.1, names)
    kinds = [e.kind for e in res.events if e.t <= window]
    assert "open" in kinds and kinds.count("impact") >= 8 and kinds.count("slide") >= 8, kinds
    assert not {"flight", "fell-off", "overturn"} & set(kinds), kinds
    assert window < res.event_times("flight")[0] < 1.0903  # the column's 0.21 ms flight
    assert np.abs(out["block5.theta"]).max() > 0.02
    keep = t <= window + 1e-9
    errors: dict[str, list[float]] = {n: [] for n in names}
    for h in STEPS:
        run = run_siconos(siconos, {**case, "h": h, "t_end": window, "t_out": t[keep].tolist()})
        window_out = {n: out[n][keep] for n in names}
        for n, e in largest_differences(run, window_out, names, np.ones(keep.sum(), bool)).items():
            errors[n].append(e)
    print("\n".join(f"  {n}: " + ", ".join(f"{e:.2g}" for e in errs) for n, errs in errors.items()))
    for name, (coarse, mid, fine) in errors.items():
        assert fine * RATIO <= mid and fine * RATIO ** 2 <= coarse and fine < FINEST_LIMIT, (name, errors)
