"""Measured experiments: import (CSV and PEER .AT2) with declared units and signs, every
bad input refused with nothing stored, comparison with runs, calibration of the
restitution on synthetic decays made by the model with known parameters and noise of
the thesis's size (seed 000: 0.5 deg, 0.1 s), and recorded motions driving the FMU."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select

from db import series
from db.records import samples as record_samples
from db.catalogue import CATALOGUE
from db.schema import Block, Measurement, Run
from db.session import open_database
from conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent
DEG = math.pi / 180


def runners(*args, db, fmu_path):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path), "ROCKING_DB": db}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=env,
                          cwd=ROOT)


def catalogue_block(name: str) -> dict:
    b = next(c for c in CATALOGUE if c["name"] == name)
    return {"block1.halfWidth": b["half_width"], "block1.halfHeight": b["half_height"], "block1.mass": b["mass"]}


def decay(fmu, block: dict, law: dict, theta0: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The model's own free-rocking peaks (times from the release, signed angles)."""
    r = fmu.run({**block, **law, "block1.theta0": theta0}, 6.0, 6.0, outputs=["block1.theta"])
    return r.event_times("peak")[:n], r.event_values("peak", "theta")[:n]


def noisy_peak_table(path: Path, t: np.ndarray, th: np.ndarray, theta0: float, seed: int, block: str,
                     sign: str = "clockwise") -> None:
    """A peak table as read from video: the release, then the peaks, in degrees, with
    normal noise of 0.5 deg on angles and 0.05 s on times (the thesis's +-0.5 deg, 0.1 s);
    the first seed from `seed` on whose noisy times still increase (a table is in time order)."""
    for s in range(seed, seed + 100):
        rng = np.random.default_rng(s)
        tt = np.concatenate([[0.0], t + rng.normal(0, 0.05, len(t))])
        aa = np.concatenate([[theta0], th]) + rng.normal(0, 0.5 * DEG, len(t) + 1)
        if np.all(np.diff(tt) > 0):
            break
    s = 1 if sign == "clockwise" else -1
    path.write_text("# kind: peaks\n# units: time=s, theta=deg\n"
                    f"# sign: {sign}\n# block: {block}\n# source: synthetic, made by the model\n"
                    "# instrument: video, 25 fps\n# uncertainty: theta=0.5 deg, time=0.1 s\ntime,theta\n"
                    + "".join(f"{a:.3f},{s * b / DEG:.2f}\n" for a, b in zip(tt, aa)))


@pytest.fixture
def db(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'm.db'}"
    assert runners("db", "init", db=url, fmu_path=fmu_path).returncode == 0
    return url


def export_with_noise(tmp_path: Path, db: str, fmu_path, run: int, block: str, max_peaks: int = 8) -> Path:
    """runners export-measured with the thesis's reading noise (0.5 deg; 0.05 s so that
    the peaks stay in time order), from the first seed that keeps them in order."""
    out = tmp_path / "exported.csv"
    for seed in range(20):
        p = runners("export-measured", str(run), "--out", str(out), "--block", block, "--noise-theta", "0.5",
                    "--noise-time", "0.05", "--seed", str(seed), "--max-peaks", str(max_peaks), db=db,
                    fmu_path=fmu_path)
        if p.returncode == 0:
            return out
        assert "reorders" in p.stderr, p.stderr
    raise AssertionError("no seed kept the peaks in order")


@pytest.mark.parametrize("law, value", [("constant", 0.9), ("modified", 0.85)])
def test_round_trip_simulate_export_import_calibrate(tmp_path, fmu_path, db, law, value):
    """All through the command line: simulate a free decay with known restitution, export it
    as a measured peak table with noise, import it, calibrate, and recover the parameter."""
    b = next(c for c in CATALOGUE if c["name"] == "anagnostopoulos-block2")
    scene = tmp_path / "decay.toml"
    scene.write_text(f"name = 'synthetic decay'\n[block]\nhalf_width = {b['half_width']}\n"
                     f"half_height = {b['half_height']}\nmass = {b['mass']}\ntheta0 = 0.33\n"
                     f"[restitution]\nlaw = '{law}'\n{'eta' if law == 'constant' else 'k'} = {value}\n"
                     "[simulation]\nstop_time = 4.0\nstep = 0.01\n")
    assert runners("simulate", str(scene), db=db, fmu_path=fmu_path).returncode == 0
    csv = export_with_noise(tmp_path, db, fmu_path, 1, "anagnostopoulos-block2")
    p = runners("import-measured", str(csv), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    factory = open_database(db)
    with factory() as session:
        m = session.get(Measurement, 1)
        assert (m.block1.name, m.kind, m.units["theta"], m.sign) == ("anagnostopoulos-block2", "peaks", "deg", "clockwise")
        assert m.uncertainty_angle == pytest.approx(0.5 * DEG) and m.uncertainty_time == 0.05
    p = runners("db", "list", "measurements", db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "exported" in p.stdout and "anagnostopoulos-block2" in p.stdout, p.stderr
    shown = json.loads(runners("db", "show", "measurement", "1", db=db, fmu_path=fmu_path).stdout)
    assert shown["kind"] == "peaks" and shown["data"].endswith("bytes>")
    p = runners("calibrate", "1", "--law", law, "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    fit = json.loads(p.stdout)
    assert fit["low"] <= value <= fit["high"] and fit["high"] - fit["low"] < 0.2  # informative on [0, 1]
    assert abs(fit["theta0"] - 0.33) < 2 * 0.5 * DEG
    with factory() as session:
        stored = session.get(Block, fit["block_id"])
        assert stored.restitution_law == law and getattr(stored, "eta" if law == "constant" else "k") == fit["value"]
        assert "measurement 1" in stored.source


def test_a_file_in_other_units_and_signs_is_stored_in_ours(tmp_path, fmu_path, db):
    """The same peaks declared in deg/counterclockwise/ms and in rad/clockwise/s store alike."""
    ours = tmp_path / "ours.csv"
    theirs = tmp_path / "theirs.csv"
    rows = [(0.0, 0.3), (0.41, -0.2), (0.72, 0.15)]
    ours.write_text("# kind: peaks\n# units: time=s, theta=rad\n# sign: clockwise\n# block: B3L\ntime,theta\n"
                    + "".join(f"{t!r},{th!r}\n" for t, th in rows))
    theirs.write_text("# kind: peaks\n# units: time=ms, theta=deg\n# sign: counterclockwise\n# block: B3L\n"
                      "time,theta\n" + "".join(f"{t * 1e3!r},{-th / DEG!r}\n" for t, th in rows))
    for f in (ours, theirs):
        assert runners("import-measured", str(f), db=db, fmu_path=fmu_path).returncode == 0
    with open_database(db)() as session:
        a, b = (series.unpack(m.names, m.n_samples, m.data) for m in (session.get(Measurement, 1),
                                                                       session.get(Measurement, 2)))
    np.testing.assert_allclose(b[0], a[0], rtol=1e-15)
    np.testing.assert_allclose(b[1]["block1.theta"], a[1]["block1.theta"], rtol=1e-14)


@pytest.mark.parametrize("name", ["anagnostopoulos-block1", "anagnostopoulos-block2", "anagnostopoulos-block3"])
def test_anagnostopoulos_table3_in_spirit_calibration_returns_the_correction_factor(tmp_path, fmu, fmu_path, db, name):
    """A decay made with Housner's r times Table 3's factor; --law correction gets the factor back."""
    factor = next(c for c in CATALOGUE if c["name"] == name)["correction"]
    block = catalogue_block(name)
    alpha = math.atan2(block["block1.halfWidth"], block["block1.halfHeight"])
    t, th = decay(fmu, {**fmu.defaults(), **block}, {"restitution.law": 0, "restitution.correction": factor},
                  0.8 * alpha, 8)
    csv = tmp_path / "peaks.csv"
    noisy_peak_table(csv, t, th, 0.8 * alpha, seed=11, block=name)
    assert runners("import-measured", str(csv), db=db, fmu_path=fmu_path).returncode == 0
    p = runners("calibrate", "1", "--law", "correction", "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    fit = json.loads(p.stdout)
    assert fit["low"] <= factor <= fit["high"], fit


def test_the_95_percent_interval_covers_the_true_eta_in_repeated_experiments(fmu):
    """40 synthetic experiments (normal noise, 0.5 deg and 0.1 s): the linearised 95%
    intervals must contain the true eta in at least 34 (85%)."""
    from runners.analysis.calibrate import calibrate
    from runners.analysis.compare import decay_from_peaks

    block = {**fmu.defaults(), **catalogue_block("anagnostopoulos-block2")}
    alpha = math.atan2(block["block1.halfWidth"], block["block1.halfHeight"])
    t, th = decay(fmu, block, {"restitution.law": 2, "restitution.eta": 0.9}, 0.8 * alpha, 10)
    hits = 0
    for seed in range(40):
        rng = np.random.default_rng(seed)
        tt = np.concatenate([[0.0], t + rng.normal(0, 0.1, len(t))])
        aa = np.concatenate([[0.8 * alpha], th]) + rng.normal(0, 0.5 * DEG, len(t) + 1)
        fit = calibrate(fmu, block, decay_from_peaks(tt, aa), "constant", 0.5 * DEG, 0.1)
        hits += fit.low <= 0.9 <= fit.high
    assert hits >= 34, hits


def test_compare_a_rotation_history_with_its_run(tmp_path, fmu_path, db):
    """The run's own theta, sampled at 100 Hz with reading errors within the stated +-0.5 deg
    (uniform): the RMS error is the noise's, 0.5 deg / sqrt(3); measured impacts (zero
    crossings beyond the uncertainty) match the run's impact events."""
    from test_recording import column, read_back

    assert runners("simulate", "examples/free_rocking.toml", db=db, fmu_path=fmu_path).returncode == 0
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, 1)
        t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    keep = slice(0, None, 10) if t[1] - t[0] < 0.01 else slice(None)
    tm = t[keep]
    noise = np.random.default_rng(5).uniform(-0.5 * DEG, 0.5 * DEG, len(tm))
    csv = tmp_path / "rotation.csv"
    csv.write_text("# kind: rotation\n# units: time=ms, theta=rad\n# sign: clockwise\n# block: B3L\n"
                   "# uncertainty: theta=0.5 deg\ntime,block1.theta\n"
                   + "".join(f"{a * 1e3!r},{b!r}\n" for a, b in zip(tm.tolist(), (cols["block1.theta"][keep] + noise).tolist())))
    assert runners("import-measured", str(csv), db=db, fmu_path=fmu_path).returncode == 0
    png, rrd = tmp_path / "c.png", tmp_path / "c.rrd"
    p = runners("compare", "1", "1", "--out", str(png), "--recording", str(rrd), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    rms = float(p.stdout.split("RMS error ")[1].split(" rad")[0])
    assert abs(rms - 0.5 * DEG / math.sqrt(3)) < 0.1 * 0.5 * DEG / math.sqrt(3)
    assert "impact times" in p.stdout and png.stat().st_size > 10_000
    _, rows = column(read_back(rrd), "/measured/block1/theta")
    assert len(rows) == len(tm)
    # impacts are matched to 1e-2 s at 100 Hz sampling, noise aside
    line = next(x for x in p.stdout.splitlines() if x.startswith("impact times"))
    assert float(line.split("RMS error ")[1].split(" s")[0]) < 0.02


def test_a_recorded_ground_motion_drives_the_fmu_like_the_builtin_pulse(tmp_path, fmu_path, db):
    """A one-sine pulse written as a PEER .AT2 file (in g, sampled every 1e-4 s) becomes a
    record; the FMU reads it (excitation.kind 4) and gives the built-in pulse's response."""
    dt, amp, f = 1e-4, 5.0, 3.0
    n = int(round(1 / f / dt)) + 1
    a = amp * np.sin(2 * np.pi * f * dt * np.arange(n)) / 9.80665
    at2 = tmp_path / "pulse.AT2"
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic one-sine pulse\n"
                   f"ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {n}, DT= {dt:.4f} SEC\n"
                   + "".join("  ".join(f"{v: .8E}" for v in a[i:i + 5]) + "\n" for i in range(0, n, 5)))
    p = runners("import-measured", str(at2), db=db, fmu_path=fmu_path)
    assert p.returncode == 0 and "record 'synthetic one-sine pulse'" in p.stdout, p.stderr
    rec = json.loads(runners("simulate", "examples/sine_pulse.toml", "--motion", "1", "--stop-time", "3", "--json",
                             db=db, fmu_path=fmu_path).stdout)
    ref = json.loads(runners("simulate", "examples/sine_pulse.toml", "--stop-time", "3", "--json",
                             db=db, fmu_path=fmu_path).stdout)
    assert rec["excitation"] == "record synthetic one-sine pulse x 1 (PGA 0.51 g)"
    assert rec["max_abs_theta_rad"] == pytest.approx(ref["max_abs_theta_rad"], rel=1e-4)
    assert rec["overturned"] == ref["overturned"] and rec["impacts"] == ref["impacts"]
    latest = json.loads(runners("simulate", "examples/sine_pulse.toml", "--motion", "latest", "--stop-time", "3",
                                "--json", "--no-store", db=db, fmu_path=fmu_path).stdout)  # as docs/cli.md says
    assert latest["max_abs_theta_rad"] == rec["max_abs_theta_rad"]
    factory = open_database(db)
    with factory() as session:
        run = session.get(Run, rec["run_id"])
        assert run.excitation.kind == "record" and run.excitation.scale == 1.0
        assert run.excitation.record.pga == pytest.approx(amp, rel=1e-7)


def test_a_table_displacement_record_becomes_its_acceleration(tmp_path, fmu_path, db):
    """D sin(w t) in mm, differentiated twice: -D w^2 sin(w t) within the differences' error."""
    D, f, dt = 3.0, 7.0, 1e-3
    t = dt * np.arange(2001)
    csv = tmp_path / "table.csv"
    csv.write_text("# kind: table-displacement\n# units: time=s, displacement=mm\n# sign: -x\ntime,displacement\n"
                   + "".join(f"{a!r},{D * math.sin(2 * math.pi * f * a)!r}\n" for a in t.tolist()))
    assert runners("import-measured", str(csv), db=db, fmu_path=fmu_path).returncode == 0
    with open_database(db)() as session:
        m = session.get(Measurement, 1)
        te, ah, _ = record_samples(m.excitation.record)
    w = 2 * math.pi * f
    exact = -(-1e-3 * D) * w ** 2 * np.sin(w * te)  # "-x": the file's positive is our negative
    assert np.max(np.abs(ah[2:-2] - exact[2:-2])) < 2e-3 * 1e-3 * D * w ** 2


BAD = {  # file text -> what the one-line error must say
    "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\ntime,theta\n0,10\n0,5\n0.5,3\n":
        "does not increase",
    "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\ntime,theta\n0,10\n0.2,x\n": "not a number",
    "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\ntime,theta\n0,10\n0.2\n": "fields",
    "# kind: peaks\n# units: time=s, theta=furlong\n# sign: clockwise\n# block: B3L\ntime,theta\n0,1\n1,0.5\n":
        "not a unit of theta",
    "# kind: peaks\n# units: time=s, theta=mm\n# sign: clockwise\n# block: B3L\ntime,theta\n0,1\n1,0.5\n":
        "not a unit of theta",
    "# kind: peaks\n# units: time=s, theta=rad\n# sign: clockwise\n# block: B3L\ntime,theta\n0,20\n1,15\n":
        "are the units right",
    "# kind: peaks\n# sign: clockwise\n# block: B3L\ntime,theta\n0,1\n1,0.5\n": "declare the units",
    "# kind: peaks\n# units: time=s, theta=deg\n# block: B3L\ntime,theta\n0,1\n1,0.5\n": "declare the sign",
    "# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\ntime,theta\n0,1\n1,0.5\n": "declare the kind",
    "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: nope\ntime,theta\n0,1\n1,0.5\n": "no block 'nope'",
    "# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\ntime,theta\n0,1\n1,0.5\n": "needs its block",
    "# kind: ground-acceleration\n# units: time=s, acceleration=m/s2\n# sign: up\ntime,acceleration\n0,1\n1,0\n":
        "declare the sign",
    "# kind: ground-acceleration\n# units: time=s, acceleration=m/s2\n# sign: +x\ntime,acceleration\n0,1\n1,200\n":
        "are the units right",
    "# kind: rotation\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\ntime,block2.theta\n0,1\n1,0.5\n":
        "name the upper block",
}
BAD_AT2 = {
    "PEER\nx\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 4, DT= .01 SEC\n0.1 0.2 0.3\n": "NPTS=4",
    "PEER\nx\nACCELERATION TIME SERIES IN UNITS OF FURLONGS\nNPTS= 2, DT= .01 SEC\n0.1 0.2\n": "line 3",
    "PEER\nx\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 2 DT .01\n0.1 0.2\n": "line 4",
    "PEER\nx\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 2, DT= .01 SEC\n0.1 abc\n": "line 5",
}


def test_every_bad_input_is_one_line_and_stores_nothing(tmp_path, fmu_path, db):
    good = tmp_path / "good.csv"
    good.write_text("# kind: peaks\n# units: time=s, theta=deg\n# sign: clockwise\n# block: B3L\n"
                    "time,theta\n0,10\n0.3,-7\n0.55,5\n")
    assert runners("import-measured", str(good), db=db, fmu_path=fmu_path).returncode == 0
    factory = open_database(db)
    with factory() as session:
        before = session.get(Measurement, 1).data
    cases = [(text, reason, ".csv") for text, reason in BAD.items()] + \
            [(text, reason, ".AT2") for text, reason in BAD_AT2.items()]
    for i, (text, reason, suffix) in enumerate(cases):
        path = tmp_path / f"bad{i}{suffix}"
        path.write_text(text)
        p = run_cli("import-measured", str(path), db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and reason in p.stderr, (text, p.stderr)
    for args, reason in ((["import-measured", str(tmp_path / "none.csv")], "does not exist"),
                         (["import-measured", str(good), "--units", "time=s"], "no unit declared for theta"),
                         (["import-measured", str(good), "--excitation", "99"], "no excitation 99"),
                         (["calibrate", "7", "--law", "constant"], "no measurement 7"),
                         (["compare", "1", "1"], "no run 1"),
                         (["export-measured", "5", "--out", str(tmp_path / "e.csv")], "no run 5"),
                         (["simulate", "examples/sine_pulse.toml", "--motion", "1"], "not a ground or table motion")):
        p = run_cli(*args, db=db, fmu_path=fmu_path)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and reason in p.stderr, (args, p.stderr)
    p = run_cli("calibrate", "1", "--law", "constant", db=db, fmu_path=fmu_path)
    assert p.returncode == 2 and "at least 3 measured peaks" in p.stderr
    with factory() as session:
        assert session.scalar(select(func.count()).select_from(Measurement)) == 1
        assert session.get(Measurement, 1).data == before
        assert session.scalar(select(func.count()).select_from(Run)) == 0
