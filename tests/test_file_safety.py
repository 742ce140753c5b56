"""No command, and no run of runners.simulate, loses data (issue 36): a recording never replaces the
record file a scene names, the FMU (given or not), the scene, the measured file or the database; an
output that cannot be written is one line, exit 2, with nothing half-written; a command that fails
leaves its outputs, and the folders they would go to, as they were. Real files, the real FMU; every
file of the working folder is hashed before and after."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import runners
from conftest import run_cli
from runners.cli import clobber
from runners.cli.parser import build_parser
from runners.errors import ArgumentError, FileError

ROOT = Path(__file__).resolve().parents[1]
RECORD_SCENE = """name = "statue on a record"
[block]
half_width = 0.125
half_height = 0.5
[excitation]
file = "{file}"
[simulation]
stop_time = 0.5
"""


def digests(folder: Path) -> dict[str, str]:
    """sha256 of every file under `folder` (hidden ones too), by relative path."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_line_error(p: subprocess.CompletedProcess, *words: str) -> str:
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "unexpected" not in lines[0], p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.fixture
def place(tmp_path, fmu_path, monkeypatch) -> Path:
    """A working folder: examples/pulse_3hz.AT2, scenes naming it by a relative (rel.toml) and an
    absolute path (abs.toml), examples/statue.toml, a measured file, a copy of the FMU (my.fmu)
    and a database file (r.db)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").mkdir()
    for name in ("pulse_3hz.AT2", "statue.toml", "measured_peaks_block2.csv"):
        shutil.copy(ROOT / "examples" / name, tmp_path / "examples" / name)
    (tmp_path / "rel.toml").write_text(RECORD_SCENE.format(file="examples/pulse_3hz.AT2"))
    (tmp_path / "abs.toml").write_text(RECORD_SCENE.format(file=tmp_path / "examples" / "pulse_3hz.AT2"))
    shutil.copy(fmu_path, tmp_path / "my.fmu")
    (tmp_path / "r.db").write_bytes(b"")
    return tmp_path


# --- A: the record file a scene names ---------------------------------------------------------------

@pytest.mark.parametrize("scene", ["rel.toml", "abs.toml"])
@pytest.mark.parametrize("store", [["--no-store"], ["--db", "r.db"]])
@pytest.mark.parametrize("out", ["examples/pulse_3hz.AT2", "./examples/../examples/pulse_3hz.AT2"])
def test_a_recording_never_replaces_the_record_file_a_scene_names(place, scene, store, out):
    before = digests(place)
    p = run_cli("simulate", scene, "--out", out, *store, db="r.db", fmu_path=place / "my.fmu")
    one_line_error(p, f"--out {out} is the scene's record file")
    assert digests(place) == before


@pytest.mark.parametrize("recording,kw,what", [
    ("rel.toml", {}, "scene file"),
    ("examples/pulse_3hz.AT2", {}, "scene's record file"),
    ("abs.toml", {"scene": "abs.toml"}, "scene file"),
    ("examples/pulse_3hz.AT2", {"scene": "abs.toml"}, "scene's record file"),
    ("examples/pulse_3hz.AT2", {"scene": "examples/statue.toml", "record": "examples/pulse_3hz.AT2"}, "record file"),
    ("examples/pulse_3hz.AT2", {"scene": "examples/statue.toml", "record": Path("examples/pulse_3hz.AT2")},
     "record file"),
    ("examples/measured_peaks_block2.csv", {"measured": "examples/measured_peaks_block2.csv"}, "measured file"),
    ("my.fmu", {"fmu": "my.fmu"}, "FMU"),
    ("my.fmu", {"env": "my.fmu"}, "FMU"),
    ("r.db", {"store": True, "db": "r.db"}, "database"),
    ("r.db", {"store": True, "db": "sqlite:///r.db"}, "database"),
])
def test_the_python_api_refuses_a_recording_over_what_the_run_reads(place, monkeypatch, recording, kw, what):
    """runners.simulate(..., recording=PATH) refuses before anything is opened or run."""
    kw = dict(kw)
    monkeypatch.setenv("ROCKING_FMU", kw.pop("env", str(place / "my.fmu")))
    before = digests(place)
    with pytest.raises(ArgumentError) as caught:
        runners.simulate(kw.pop("scene", "rel.toml"), recording=recording, **kw)
    message = str(caught.value)
    assert f"recording {recording} is the {what}" in message and "\n" not in message
    assert digests(place) == before


# --- B: the FMU the command runs, given or not --------------------------------------------------------

def test_the_fmu_of_rocking_fmu_is_an_input(place):
    before = digests(place)
    p = run_cli("simulate", "examples/statue.toml", "--no-store", "--out", "my.fmu", db="r.db",
                fmu_path=Path("my.fmu"))
    one_line_error(p, "--out my.fmu is the FMU (ROCKING_FMU) this command reads")
    assert digests(place) == before


@pytest.mark.parametrize("line", [["simulate", "examples/statue.toml", "--out", "{fmu}"],
                                  ["rrd", "1", "--out", "{fmu}"],
                                  ["compare", "1", "1", "--recording", "{fmu}"],
                                  ["screenshot", "1", "--out", "{fmu}"],
                                  ["cosim", "examples/statue.toml", "--ssp", "{fmu}"]])
def test_the_default_fmu_is_an_input_of_every_command_with_an_fmu_option(place, monkeypatch, line):
    """Without --fmu and ROCKING_FMU, build/RockingBlock.fmu of the installation: refused as an
    output, checked on the parsed command line (nothing runs, so the FMU is never at risk)."""
    from fmu_build import build_fmu

    monkeypatch.delenv("ROCKING_FMU", raising=False)
    fmu = str(build_fmu())  # (up to date: not rebuilt)
    args = build_parser().parse_args([part.format(fmu=fmu) for part in line])
    with pytest.raises(ValueError, match=r"is the FMU this command reads: it would be overwritten"):
        clobber.check(args)


# --- E: an output that cannot be written ----------------------------------------------------------------

def test_a_recording_that_cannot_be_written_is_one_line_without_rerun_warnings(place):
    """/proc/version exists and, for root, passes os.access: the recording itself fails, in one line
    (no traceback, no Rerun WARN), before anything is written."""
    exe = Path(sys.executable).parent / "runners"
    p = subprocess.run([str(exe), "simulate", "examples/statue.toml", "--no-store", "--stop-time", "0.2",
                        "--out", "/proc/version", "--fmu", "my.fmu"], capture_output=True, text=True, cwd=place,
                       timeout=300)
    line = one_line_error(p, "/proc/version")
    assert "cannot write" in line or "may not be written" in line


@pytest.mark.parametrize("line", [["simulate", "examples/statue.toml", "--no-store", "--out", "/proc/1/a/x.rrd"],
                                  ["map", "1", "--out", "/proc/1/x.png"],
                                  ["cosim", "examples/statue.toml", "--csv", "/proc/1/x.csv"],
                                  ["figures", "--out", "/proc/1/figures", "--only", "x"]])
def test_an_output_where_no_file_may_be_written_is_refused_up_front(place, line):
    before = digests(place)
    p = run_cli(*line, db="r.db", fmu_path=place / "my.fmu")
    one_line_error(p, "its folder /proc/1 may not be written into")
    assert digests(place) == before


def test_a_recording_that_fails_half_way_leaves_the_file_as_it_was(place, fmu):
    """The record file a recording shows is gone by the time it is written: an error after the
    recording has begun, the earlier recording as it was, and no temporary file left."""
    from runners.engine.recording import write_recording
    from runners.engine.scene import load_scene

    scene = load_scene(place / "examples" / "statue.toml")
    r = fmu.run(scene.parameters, 0.2, 0.01)
    old = place / "old.rrd"
    old.write_bytes(b"an earlier recording")
    before = digests(place)
    p = {**fmu.defaults(), **scene.parameters, "excitation.file": str(place / "gone.txt")}
    with pytest.raises(runners.RockingError, match="gone.txt"):
        write_recording(old, scene.name, r.time, r.outputs, p, r.events, record={"name": "gone"})
    assert digests(place) == before


def test_a_recording_through_a_symbolic_link_replaces_the_file_it_points_to(place):
    (place / "target.rrd").write_bytes(b"an earlier recording")
    (place / "link.rrd").symlink_to("target.rrd")
    runners.simulate("examples/statue.toml", stop_time=0.2, recording="link.rrd", fmu=place / "my.fmu")
    assert (place / "link.rrd").is_symlink() and (place / "target.rrd").stat().st_size > 1000
    assert sorted(p.name for p in place.iterdir() if p.name.startswith(".")) == []


def test_the_api_says_in_one_line_that_a_recording_cannot_be_written(place):
    with pytest.raises(FileError, match=r"^cannot write the recording /proc/version: [^\n]*$"):
        runners.simulate("examples/statue.toml", stop_time=0.2, recording="/proc/version", fmu=place / "my.fmu")


# --- K: a command that fails leaves its outputs as they were ---------------------------------------------

@pytest.fixture
def systems(place, building_fmu_path, monkeypatch) -> Path:
    """The cabinet on its floor (ok.toml, 0.3 s) and the same on floors of 20 kg, whose two-way
    coupling diverges at a 10 ms step (diverges.toml; tests/test_cosim_system.py)."""
    monkeypatch.setenv("ROCKING_BUILDING_FMU", str(building_fmu_path))
    shutil.copy(ROOT / "examples" / "pulse_3hz.AT2", place / "pulse_3hz.AT2")
    text = (ROOT / "examples" / "cabinet_on_floor.toml").read_text()
    (place / "ok.toml").write_text(text.replace("stop_time = 4.0", "stop_time = 0.3"))
    (place / "diverges.toml").write_text(text.replace("mass = 2000.0", "mass = 20.0")
                                         .replace("stop_time = 4.0", "stop_time = 1.0"))
    (place / "old.ssp").write_bytes(b"an earlier SSP")
    (place / "old.png").write_bytes(b"an earlier figure")
    return place


def test_a_cosim_that_fails_leaves_its_outputs_and_folders_as_they_were(systems):
    before = digests(systems)
    p = run_cli("cosim", "diverges.toml", "--step", "0.01", "--quiet", "--ssp", "old.ssp", "--out", "old.png",
                "--csv", "new/series/s.csv", "--no-store", db="r.db", fmu_path=systems / "my.fmu")
    one_line_error(p, "two-way coupling diverged")
    assert digests(systems) == before  # old.ssp and old.png as they were, no temporary file left
    assert not (systems / "new").exists()


def test_a_cosim_that_succeeds_replaces_its_outputs_and_leaves_no_temporary_file(systems):
    before = digests(systems)
    p = run_cli("cosim", "ok.toml", "--quiet", "--ssp", "old.ssp", "--out", "old.png", "--csv", "new/s.csv",
                "--compare", "--no-store", db="r.db", fmu_path=systems / "my.fmu")  # (stored runs: test_cosim_store.py)
    assert p.returncode == 0, p.stderr
    after = digests(systems)
    assert {k for k in after if after[k] != before.get(k)} == {"old.ssp", "old.png", "new/s-one-way.csv",
                                                                "new/s-two-way.csv"}
    assert (systems / "old.ssp").read_bytes()[:2] == b"PK" and (systems / "old.png").read_bytes()[:4] == b"\x89PNG"
