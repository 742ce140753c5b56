"""The floor's motion in Python (runners/engine/floor_motion.py: the matrix exponential of the whole
support) against the FMU's (model/c/support.c: the modes in closed form), the peak floor acceleration,
floor spectra, and studies over records on a floor: --im pfa and sa_t1, fragility against them, and
runners floor-spectra."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from runners.engine import floor_motion, spectra
from tests.test_spectra import components
from tests.test_support_fmu import CABINET, FRAME, write_record

G0 = 9.80665
FLOOR_SCENE = """name = "cabinet on the third floor"
[block]
half_width = 0.3
half_height = 1.0
mass = 1000.0
[contact]
model = "rocking-sliding"
mu_ground = 0.5
[building]
storeys = 3
mass = 2000.0
stiffness = 2.5e6
damping_ratio = 0.02
[coupling]
mode = "one-way"
"""


@pytest.fixture(scope="module")
def near_field():
    """(t s, a m/s^2) of FEMA P695 near-field components 1a and 2b."""
    every = components("nearfield_pulse")
    return [every[0][1:], every[3][1:]]


def test_the_python_floor_is_the_fmus_floor(fmu, near_field, tmp_path):
    """Two roads to the same floor: the FMU's modes in closed form and Python's matrix exponential, to 1e-13."""
    t, a = near_field[0]
    rec = write_record(tmp_path / "nf1a.txt", t, a)
    run = fmu.run({**CABINET, **FRAME, "excitation.kind": 4, "excitation.file": str(rec)}, 30.0, 0.001,
                  ["ground.ahTotal"], events=False)
    times = run.time[::37]
    python = floor_motion.FloorMotion(FRAME, t, a)(times)
    peak = np.abs(python).max()
    assert np.abs(python - run.outputs["ground.ahTotal"][::37]).max() < 1e-13 * peak * 100


def test_the_peak_floor_acceleration_is_the_largest_on_any_finer_grid(near_field):
    t, a = near_field[1]
    motion = floor_motion.FloorMotion(FRAME, t, a)
    pfa = motion.peak()
    times, acc = motion.sampled()
    k = int(np.abs(acc).argmax())
    fine = np.linspace(times[max(k - 2, 0)], times[min(k + 2, len(times) - 1)], 4001)
    dense = np.abs(motion(fine)).max()
    assert dense <= pfa * (1 + 1e-12)
    assert pfa - dense < 1e-9 * pfa  # the refined peak is the dense grid's, to its resolution
    assert pfa > np.abs(acc).max() * (1 - 1e-15)
    assert pfa > 1.5 * np.abs(a).max()  # the top floor amplifies


@pytest.mark.parametrize("coupling", [0, 1])
def test_the_fmus_peak_floor_acceleration_is_the_python_one(fmu, near_field, tmp_path, coupling):
    """support.peakFloorAcceleration (the FMU's, at initialisation: the extrema of the modes' closed form located by
    its bound-certified search) equals the matrix exponential's PFA to 1e-12, scaled with the record, on a floor
    of the frame and on an isolation platform; the bare support's also when the blocks load it (two-way)."""
    isolator = {"support.kind": 2, "platform.mass": 800.0, "platform.stiffness": 800.0 * (2 * np.pi / 2.5) ** 2,
                "platform.damping": 2 * 0.1 * 800.0 * 2 * np.pi / 2.5}
    for k, support in enumerate([FRAME, {**FRAME, "building.floor": 1}, isolator]):
        t, a = near_field[k % 2]
        rec = write_record(tmp_path / f"nf{k}.txt", t, a)
        python = floor_motion.FloorMotion(support, t, a).peak()
        p = {**CABINET, **support, "support.coupling": coupling, "excitation.kind": 4, "excitation.file": str(rec),
             "excitation.scale": -1.7}
        assert abs(floor_motion.fmu_peak_floor_accelerations(fmu, p, [rec])[0] - python) < 1e-12 * python
        run = fmu.run(p, 0.1, 0.1, ["support.peakFloorAcceleration"])
        assert abs(run.outputs["support.peakFloorAcceleration"][-1] - 1.7 * python) < 1e-12 * python


def test_a_floor_as_stiff_as_the_ground_has_the_grounds_spectrum(near_field):
    """A 1e6 rad/s platform: the floor spectrum is the record's, and the PFA its PGA (to the grid's resolution of
    the platform's own vibration, sampled at 1/16 of the record's interval)."""
    t, a = near_field[0]
    m, w = 1000.0, 1e6
    stiff = {"support.kind": 2, "platform.mass": m, "platform.stiffness": m * w * w, "platform.damping": 0.1 * m * w}
    periods = np.array([0.05, 0.2, 0.5, 1.0, 3.0])
    floor = floor_motion.floor_spectrum(stiff, t, a, periods)
    base = spectra.spectrum(t, a, periods).sa
    assert np.abs(floor / base - 1).max() < 1e-4
    assert floor_motion.peak_floor_acceleration(stiff, t, a) == pytest.approx(np.abs(a).max(), rel=1e-4)


def test_the_floor_spectrum_converges_as_its_grid_is_refined(near_field, monkeypatch):
    """The floor's exact motion sampled on finer grids: the spectrum moves by less than 1e-3 from GRID to 4 GRID."""
    t, a = near_field[0]
    periods = np.array([0.1, 0.4, 1.0])
    coarse = floor_motion.floor_spectrum(FRAME, t[:3000], a[:3000], periods)
    monkeypatch.setattr(floor_motion, "GRID", 4 * floor_motion.GRID)
    fine = floor_motion.floor_spectrum(FRAME, t[:3000], a[:3000], periods)
    assert np.abs(coarse / fine - 1).max() < 1e-3


@pytest.fixture(scope="module")
def floor_study(tmp_path_factory, fmu_path):
    """A sweep of the cabinet on its frame's top floor over four near-field components, 11 PFA levels."""
    folder = tmp_path_factory.mktemp("floor_records")
    every = components("nearfield_pulse")
    for i in (0, 3, 9, 17):
        write_record(folder / f"nf{i}.txt", every[i][1], every[i][2])
    scene = folder.parent / "floor.toml"
    scene.write_text(FLOOR_SCENE)
    db = f"sqlite:///{folder.parent / 'floor.db'}"
    p = run_cli("sweep", str(scene), "--records", str(folder), "--im", "pfa=0.4:2.4:11", "--workers", "2", "-y", "-q",
                "--stop-time", "20", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return db, scene, folder


def test_a_sweep_scaled_by_pfa_stores_the_pfa_of_each_run(floor_study, fmu_path, tmp_path):
    db, _, _ = floor_study
    out = tmp_path / "points.json"
    p = run_cli("export", "--sweep", "latest", "--format", "json", "--out", str(out), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    rows = json.loads(out.read_text())
    rows = rows if isinstance(rows, list) else next(v for v in rows.values() if isinstance(v, list))
    assert len(rows) == 44
    for r in rows:
        assert r["pfa"] == pytest.approx(r["level"] * G0, rel=1e-12)
        assert r["sa_t1"] > 0 and r["pga"] < r["pfa"]


@pytest.mark.parametrize("im", ["pfa", "sa_t1", "pga"])
def test_fragility_against_floor_and_base_measures(floor_study, fmu_path, tmp_path, im):
    db, _, _ = floor_study
    out = tmp_path / f"fragility_{im}.png"
    p = run_cli("fragility", "latest", "--im", im, "--out", str(out), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["measure"] == im and doc["median"] > 0
    assert out.stat().st_size > 10_000


def test_floor_spectra_of_a_study(floor_study, fmu_path, tmp_path):
    db, _, _ = floor_study
    out = tmp_path / "floor.png"
    p = run_cli("floor-spectra", "latest", "--out", str(out), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert out.stat().st_size > 20_000 and len(doc["records"]) == 4
    T1 = max(doc["support_periods_s"])
    i = int(np.argmax(doc["floor_median"]))
    assert doc["periods_s"][i] == pytest.approx(T1, rel=1e-9)  # the floor resonates at the frame's first period
    assert doc["floor_median"][i] > 5 * doc["base_median"][i]


@pytest.mark.parametrize("extra, words", [
    (["--im", "pfa=0.5:1:2"], "the scene has no [building] or [platform]"),
])
def test_floor_measures_need_a_floor(floor_study, fmu_path, tmp_path, extra, words):
    _, _, folder = floor_study
    scene = tmp_path / "ground.toml"
    scene.write_text(FLOOR_SCENE.split("[building]")[0])
    p = run_cli("sweep", str(scene), "--records", str(folder), *extra, "-y", "-q",
                db=f"sqlite:///{tmp_path / 'g.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and words in p.stderr and "Traceback" not in p.stderr


def test_pfa_levels_refuse_an_axis_that_changes_the_support(floor_study, fmu_path, tmp_path):
    _, scene, folder = floor_study
    p = run_cli("sweep", str(scene), "--records", str(folder), "--im", "pfa=0.5:1:2", "--grid",
                "building.dampingRatio=0.02:0.05:2", "-y", "-q", db=f"sqlite:///{tmp_path / 'g.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and "changes the support" in p.stderr


def test_floor_spectra_refuse_a_study_on_the_ground(floor_study, fmu_path, tmp_path):
    _, _, folder = floor_study
    scene = tmp_path / "ground.toml"
    scene.write_text(FLOOR_SCENE.split("[building]")[0])
    db = f"sqlite:///{tmp_path / 'g.db'}"
    assert run_cli("sweep", str(scene), "--records", str(folder), "--im", "pga=0.5:1:2", "-y", "-q", "--stop-time", "5",
                   db=db, fmu_path=fmu_path).returncode == 0
    p = run_cli("floor-spectra", "latest", "--out", str(tmp_path / "x.png"), db=db, fmu_path=fmu_path)
    assert p.returncode != 0 and "[building] or [platform]" in p.stderr and "Traceback" not in p.stderr
    for command in ("fragility", "ida"):  # the floor's measures of a study on the ground: one line, not a KeyError
        p = run_cli(command, "latest", "--im", "pfa", "--out", str(tmp_path / "y.png"), db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and "runs do not have" in p.stderr and "unexpected" not in p.stderr
