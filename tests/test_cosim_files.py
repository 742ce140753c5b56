"""The files `runners cosim` reads and writes: it overwrites none that the system file names (its base
record, the FMUs), nor the database, nor another of its outputs (the series files --compare derives
from --csv included), and it writes its files as open() makes them (mode 0666 less the umask).
The command in its own process, on real files."""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def runners(*args: str, cwd: Path, env: dict[str, str] | None = None, umask: int | None = None
            ) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent / "runners"
    return subprocess.run([str(exe), *args], capture_output=True, text=True, cwd=cwd, timeout=300,
                          env={**os.environ, **(env or {})},
                          preexec_fn=None if umask is None else (lambda: os.umask(umask)))


def digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def place(tmp_path, fmu_path, building_fmu_path) -> Path:
    """A folder with the cabinet's system file, its record, both FMUs and a database file."""
    shutil.copy(ROOT / "examples" / "cabinet_on_floor.toml", tmp_path / "system.toml")
    shutil.copy(ROOT / "examples" / "pulse_3hz.AT2", tmp_path / "pulse_3hz.AT2")
    shutil.copy(fmu_path, tmp_path / "block.fmu")
    shutil.copy(building_fmu_path, tmp_path / "building.fmu")
    (tmp_path / "r.db").write_bytes(b"")
    return tmp_path


FMUS = ["--fmu", "block.fmu"]
ENV = {"ROCKING_BUILDING_FMU": "building.fmu"}

REFUSED = [
    (["--csv", "pulse_3hz.AT2"], "--csv pulse_3hz.AT2 is the record file this command reads"),
    (["--out", "pulse_3hz.AT2"], "--out pulse_3hz.AT2 is the record file this command reads"),
    (["--ssp", "./pulse_3hz.AT2"], "--ssp ./pulse_3hz.AT2 is the record file this command reads"),
    (["--csv", "building.fmu"], "--csv building.fmu is the building's FMU this command reads"),
    (["--ssp", "building.fmu"], "--ssp building.fmu is the building's FMU this command reads"),
    (["--csv", "pulse_3hz.csv", "--compare", "--out", "pulse_3hz-two-way.csv"],
     "--out and --csv (two-way) both name pulse_3hz-two-way.csv"),
    (["--csv", "r.db", "--compare", "--db", "r-one-way.db"], "--csv (one-way) r-one-way.db is the database"),
    (["--csv", "pulse.AT2", "--compare"], None),  # pulse-one-way.AT2, pulse-two-way.AT2: nothing it reads
]


@pytest.mark.parametrize("args, message", REFUSED[:-1], ids=[m for _, m in REFUSED[:-1]])
def test_outputs_that_are_files_the_system_names_are_refused(place, args, message):
    if "r-one-way.db" in args:
        (place / "r-one-way.db").write_bytes(b"")
    before = digests(place)
    p = runners("cosim", "system.toml", *args, *FMUS, cwd=place, env=ENV)
    assert p.returncode == 2, (p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], p.stderr
    assert digests(place) == before  # nothing written, nothing changed


def test_a_link_to_the_record_is_the_record(place):
    (place / "link.AT2").symlink_to(place / "pulse_3hz.AT2")
    p = runners("cosim", "system.toml", "--csv", "link.AT2", *FMUS, cwd=place, env=ENV)
    assert p.returncode == 2 and "is the record file this command reads" in p.stderr, p.stderr


def test_every_file_it_writes_is_made_as_open_makes_it(place):
    """The SSP (written beside its destination, then renamed), the figure, the series and the record
    cache's copy of the base record: 0644 under umask 022, 0600 under 077 (owner only, as asked)."""
    every = ["--ssp", "s.ssp", "--out", "f.png", "--csv", "s.csv", "--compare"]
    for umask, mode, outs in ((0o022, 0o644, every), (0o077, 0o600, ["--ssp", "s.ssp", "--coupling", "one-way"])):
        cache = place / f"cache-{umask:o}"
        p = runners("cosim", "system.toml", "--step", "0.004", *outs, *FMUS, cwd=place,
                    env={**ENV, "ROCKING_CACHE": str(cache)}, umask=umask)
        assert p.returncode == 0, p.stderr
        names = ("s.ssp", "f.png", "s-one-way.csv", "s-two-way.csv") if outs is every else ("s.ssp",)
        written = [place / n for n in names] + list((cache / "records").glob("*.txt"))
        assert len(written) == len(names) + 1
        for path in written:
            assert stat.S_IMODE(path.stat().st_mode) == mode, (path.name, oct(path.stat().st_mode), oct(umask))
            path.unlink()
        assert not [p for p in place.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_the_ssp_members_are_readable_by_everyone_once_extracted(place):
    """The SSD and both FMUs inside the SSP are rw-r--r-- (zipfile's SSD default is rw-------, which another
    user's tool, or a service account, could not read after extracting it)."""
    import zipfile

    p = runners("cosim", "system.toml", "--step", "0.004", "--ssp", "m.ssp", "--coupling", "one-way", *FMUS,
                cwd=place, env=ENV)
    assert p.returncode == 0, p.stderr
    with zipfile.ZipFile(place / "m.ssp") as zf:
        modes = {i.filename: stat.S_IMODE(i.external_attr >> 16) for i in zf.infolist()}
    assert set(modes) == {"SystemStructure.ssd", "resources/block.fmu", "resources/building.fmu"}
    assert set(modes.values()) == {0o644}, modes
