"""What `runners simulate` says about a run (issue 36, item 8): each block's size in the header,
both contacts' friction coefficients for a stack, the span of time that actually ran and why a run
ended before its stop time, and how to give the record --pga scales. Every run is the compiled
FMU through the real command line or runners.simulate; the sizes and times it must report come
from the scene files, the record file's header and the run's own located events."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

import runners
from conftest import run_cli

EX = Path(__file__).resolve().parents[1] / "examples"
# a squat box on a plinth with little friction between them: it slides off the plinth
BOX_ON_PLINTH = {"name": "box on plinth", "block": {"half_width": 0.3, "half_height": 0.5, "mass": 450.0},
                 "block2": {"half_width": 0.25, "half_height": 0.3, "mass": 100.0},
                 "contact": {"model": "rocking-sliding", "mu_ground": 5.0, "mu_interface": 0.1},
                 "excitation": {"kind": "sine-pulse", "amplitude": 6.0, "frequency": 0.5},
                 "simulation": {"stop_time": 10.0}}


def line(report: str, head: str) -> str:
    """The report's line that starts with `head`."""
    found = [x for x in report.splitlines() if x.startswith(head)]
    assert len(found) == 1, report
    return found[0]


@pytest.mark.parametrize("scene", ["marble_statue_on_plinth.toml", "sine_pulse.toml"])
def test_the_header_gives_each_blocks_full_size_and_mass(scene, fmu_path, tmp_path):
    data = tomllib.loads((EX / scene).read_text())
    tables = [data["block"]] + ([data["block2"]] if "block2" in data else [])
    p = run_cli("simulate", str(EX / scene), "--stop-time", "0.5", "--no-store", db=f"sqlite:///{tmp_path / 'x.db'}",
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    sizes = [f"{2 * t['half_width']:g} m x {2 * t['half_height']:g} m, {t['mass']:g} kg" for t in tables]
    if len(sizes) == 1:
        assert line(p.stdout, "block size ") == f"block size       {sizes[0]} (width x height, mass)"
    else:
        assert line(p.stdout, "block sizes") == f"block sizes      block 1 {sizes[0]}; block 2 {sizes[1]} (width x height, mass)"
    assert p.stdout.splitlines()[0].startswith("scene ") and p.stdout.splitlines()[1].startswith("block size")
    printed = json.loads(run_cli("simulate", str(EX / scene), "--stop-time", "0.5", "--no-store", "--json",
                                 db=f"sqlite:///{tmp_path / 'x.db'}", fmu_path=fmu_path).stdout)
    assert printed["sizes"] == [{"block": i + 1, "width_m": 2 * t["half_width"], "height_m": 2 * t["half_height"],
                                 "mass_kg": t["mass"]} for i, t in enumerate(tables)]


def test_a_stack_summary_gives_both_contacts_mu(fmu_path):
    run = runners.simulate({**BOX_ON_PLINTH, "contact": {"model": "rocking-sliding", "mu_ground": 0.45,
                                                         "mu_interface": 0.3}}, stop_time=0.5, fmu=fmu_path)
    both = "mu 0.45 on the ground, 0.3 between the blocks"
    assert both in line(run.report, "two blocks") and "block 2 slides on block 1 first" in line(run.report, "two blocks")
    assert both in line(run.report, "assumptions")


def test_a_stack_that_falls_apart_says_when_its_run_ended_and_why(fmu_path):
    run = runners.simulate(BOX_ON_PLINTH, fmu=fmu_path)
    (fell,) = run.events.loc[run.events["kind"] == "fell-off", "time"]
    assert 0 < fell < 1  # long before the stop time
    assert line(run.report, "simulated").startswith(f"simulated        0 .. {fell:.6g} s (of 0 .. 10 s) in ")
    assert line(run.report, "simulated").endswith("the run ended there, block 2 fell off block 1 (the model has "
                                                  "no contact for it)")
    assert run.summary["run_end"] == {"t_s": fell, "why": "block 2 fell off block 1 (the model has no contact for it)",
                                      "run_ended": True}
    assert run.summary["stop_time_s"] == 10.0


def test_an_overturned_block_ends_its_run_there(fmu_path):
    slender = {"name": "slender", "block": {"half_width": 0.1, "half_height": 0.6},
               "excitation": {"kind": "sine-pulse", "amplitude": 4.0, "frequency": 2.0}, "simulation": {"stop_time": 4.0}}
    run = runners.simulate(slender, fmu=fmu_path)
    (over,) = run.events.loc[run.events["kind"] == "overturn", "time"]
    assert line(run.report, "simulated").startswith(f"simulated        0 .. {over:.6g} s (of 0 .. 4 s)")
    assert "the block overturned" in line(run.report, "simulated")


def test_a_block_at_rest_after_its_excitation_says_when_its_motion_ended(fmu_path):
    exc = tomllib.loads((EX / "sine_pulse.toml").read_text())["excitation"]
    ended = exc.get("start_time", 0.0) + exc.get("cycles", 1) / exc["frequency"]
    run = runners.simulate(EX / "sine_pulse.toml", fmu=fmu_path)
    rest = run.events.loc[run.events["kind"] == "rest", "time"].iloc[-1]
    assert line(run.report, "simulated").endswith(
        f"; the motion ended at t = {rest:.6g} s, at rest after the excitation ended at t = {ended:.6g} s")
    assert line(run.report, "simulated").startswith("simulated        0 .. 5 s in ")


def test_a_record_run_says_when_its_record_ended(fmu_path, tmp_path):
    """The record file's last sample, (NPTS - 1) DT from its header, before the run's end (5 s later)."""
    header = (EX / "pulse_3hz.AT2").read_text().splitlines()[3]
    npts, dt = int(header.split(",")[0].split("=")[1]), float(header.split("=")[2].split()[0])
    p = run_cli("simulate", str(EX / "statue.toml"), "--record", str(EX / "pulse_3hz.AT2"), "--scale", "0.3",
                "--no-store", db=f"sqlite:///{tmp_path / 'x.db'}", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert line(p.stdout, "simulated").endswith(f"; the record ended at t = {(npts - 1) * dt:g} s")


def test_pga_without_a_record_says_how_to_give_one(fmu_path, tmp_path):
    p = run_cli("simulate", str(EX / "sine_pulse.toml"), "--pga", "0.3", "--no-store",
                db=f"sqlite:///{tmp_path / 'x.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stdout == "" and len(p.stderr.strip().splitlines()) == 1
    assert p.stderr.startswith("error: --pga G scales a record to that PGA (in g)")
    assert "--record NAME|ID|FILE" in p.stderr and "record = NAME or file = PATH" in p.stderr
    with pytest.raises(runners.ArgumentError, match=r"record=NAME.*record = NAME or file = PATH"):
        runners.simulate(EX / "sine_pulse.toml", pga=0.3, fmu=fmu_path)
