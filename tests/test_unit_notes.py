"""Unit slips are noted, never run in silence (issue 36, item 5): a PGA above 2 g (meant in m/s2,
most likely), a pulse amplitude below the threshold of motion (meant in g, most likely) and a
record scaled far beyond its own intensity, in runners simulate (stderr ``note:``, the API's
``summary["notes"]``) and, once per sweep, in record sweeps.

Records here are one-sine pulses written as record files, whose PGA (A) and PGV (A / (pi f), the
peak of the velocity of one cycle of A sin(2 pi f t)) are known in closed form; thresholds come
from the scene files' sizes and friction."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

import runners
from conftest import run_cli

EX = Path(__file__).resolve().parents[1] / "examples"
G0 = 9.80665  # m/s2, the g of PGAs


def pulse_record(path: Path, pga_g: float, frequency: float) -> Path:
    """A record file of one sine cycle of peak pga_g (in g) at `frequency` (Hz), sampled every ms,
    with a second of rest after it."""
    t = np.round(np.arange(0.0, 1.0 / frequency + 1.0 + 5e-4, 1e-3), 12)
    a = np.where(t <= 1.0 / frequency, pga_g * G0 * np.sin(2 * np.pi * frequency * t), 0.0)
    np.savetxt(path, np.column_stack([t, a]), fmt="%.17g", header="time (s), ah (m/s2)")
    return path


def notes_of(stderr: str) -> list[str]:
    return [line.removeprefix("note: ") for line in stderr.splitlines() if line.startswith("note: ")]


# ------------------------------------------------------------------ (b) a PGA above 2 g

def test_a_pga_above_2_g_is_noted(fmu_path, tmp_path):
    rec = pulse_record(tmp_path / "pulse.txt", 0.5, 3.0)
    db = f"sqlite:///{tmp_path / 'x.db'}"
    p = run_cli("simulate", str(EX / "statue.toml"), "--record", str(rec), "--pga", "3.5", "--stop-time", "1",
                "--no-store", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    (high,) = [n for n in notes_of(p.stderr) if n.startswith("PGA above 2 g")]
    assert "pulse (x7, PGA 3.5 g" in high and "PGAs are in g (3.5 m/s2 is 0.357 g)" in high
    assert "2.7 g" in high and "Anderson 2010" in high
    calm = runners.simulate(EX / "statue.toml", record=rec, pga=1.9, stop_time=1.0, fmu=fmu_path)
    assert not [n for n in calm.summary.get("notes", []) if "PGA above" in n]


# ------------------------------------------------------ (c) an amplitude that moves nothing

def test_a_pulse_amplitude_below_the_uplift_threshold_is_noted(fmu_path, tmp_path):
    scene = tomllib.loads((EX / "sine_pulse.toml").read_text())
    uplift = 9.81 * scene["block"]["half_width"] / scene["block"]["half_height"]  # g tan(alpha), the model's g
    run = runners.simulate(EX / "sine_pulse.toml", excitation__amplitude=0.5, stop_time=1.0, fmu=fmu_path)
    (note,) = run.summary["notes"]
    assert note == (f"excitation amplitude 0.5 m/s2 is below the threshold of motion {uplift:.4g} m/s2 (uplift, "
                    "g tan(alpha)): nothing can move. Amplitudes are in m/s2, not g (0.5 g would be 4.903 m/s2)")
    assert run.summary["impacts"] == 0 and run.summary["max_abs_theta_rad"] == 0
    # from a scene file, on the command line
    text = (EX / "sine_pulse.toml").read_text().replace("amplitude = 5.0", "amplitude = 0.3")
    (tmp_path / "g.toml").write_text(text)
    p = run_cli("simulate", str(tmp_path / "g.toml"), "--no-store", db=f"sqlite:///{tmp_path / 'x.db'}",
                fmu_path=fmu_path)
    assert p.returncode == 0 and notes_of(p.stderr) == [note.replace("0.5", "0.3").replace("4.903", "2.942")]
    # above the threshold, or lowered below the amplitude by a vertical pulse (g - |V|), no note
    assert "notes" not in runners.simulate(EX / "sine_pulse.toml", excitation__amplitude=uplift * 1.01,
                                           stop_time=1.0, fmu=fmu_path).summary
    weak_g = runners.simulate(EX / "sine_pulse.toml", excitation__amplitude=0.9 * uplift,
                              excitation__verticalAmplitude=0.2 * 9.81, stop_time=1.0, fmu=fmu_path)
    assert "notes" not in weak_g.summary


def test_the_threshold_of_a_sliding_block_and_of_a_stack(fmu_path):
    sliding = tomllib.loads((EX / "sliding_block.toml").read_text())
    slide = sliding["contact"]["mu_ground"] * 9.81  # mu g, below g tan(alpha)
    run = runners.simulate(EX / "sliding_block.toml", excitation__amplitude=2.0, stop_time=0.5, fmu=fmu_path)
    assert run.summary["notes"][0].startswith(f"excitation amplitude 2 m/s2 is below the threshold of motion "
                                              f"{slide:.4g} m/s2 (sliding, mu g)")
    assert run.summary["max_abs_slip_m"] == 0
    marble = tomllib.loads((EX / "marble_statue_on_plinth.toml").read_text())
    b1, h1, m1 = (marble["block"][k] for k in ("half_width", "half_height", "mass"))
    h2, m2 = marble["block2"]["half_height"], marble["block2"]["mass"]
    pair = 9.81 * b1 / ((m1 * h1 + m2 * (2 * h1 + h2)) / (m1 + m2))  # the pair tips about block 1's corner
    assert pair < 0.5 * 9.81  # below mu g: uplift comes first
    stack = runners.simulate(EX / "marble_statue_on_plinth.toml", excitation__kind=1, excitation__amplitude=2.0,
                             excitation__frequency=1.5, stop_time=0.5, fmu=fmu_path)
    assert stack.summary["notes"][0].startswith(f"excitation amplitude 2 m/s2 is below the threshold of motion "
                                                f"{pair:.4g} m/s2 (uplift)")


# ------------------------------------------------------- (d) a record scaled far

def test_a_record_scaled_far_is_noted_with_its_factor_pga_and_pgv(fmu_path, tmp_path):
    weak = pulse_record(tmp_path / "weak.txt", 0.1, 5.0)  # PGV 0.1 g / (5 pi)
    run = runners.simulate(EX / "statue.toml", record=weak, scale=5.0, stop_time=1.0, fmu=fmu_path)
    (far,) = [n for n in run.summary["notes"] if "scaled by more than 4" in n]
    pgv = 5.0 * 0.1 * G0 / (math.pi * 5.0)
    assert f"weak (x5, PGA 0.5 g, PGV {pgv:.3g} m/s)" in far and "Luco & Bazzurro 2007" in far
    # not far in its factor, but to a PGV above 2 m/s
    slow = pulse_record(tmp_path / "slow.txt", 0.5, 1.0)
    pgv = 1.5 * 0.5 * G0 / math.pi
    assert pgv > 2.0
    run = runners.simulate(EX / "statue.toml", record=slow, scale=1.5, stop_time=1.0, fmu=fmu_path)
    (far,) = [n for n in run.summary["notes"] if "to a PGV above 2 m/s" in n]
    assert f"slow (x1.5, PGA 0.75 g, PGV {pgv:.3g} m/s)" in far
    near = runners.simulate(EX / "statue.toml", record=slow, scale=1.2, stop_time=2.5, fmu=fmu_path)
    assert "notes" not in near.summary


def test_a_record_sweep_notes_once_the_records_and_levels_beyond_recorded_motions(fmu_path, tmp_path):
    folder = tmp_path / "pulses"
    folder.mkdir()
    pulse_record(folder / "weak.txt", 0.1, 5.0)
    pulse_record(folder / "strong.txt", 1.0, 5.0)  # at 3 g: x3, PGV 3 g / (5 pi) = 1.87 m/s
    notes: list[str] = []
    sw = runners.sweep(EX / "statue.toml", records=folder, im="pga=0.5:3:6", stop_time=0.5, workers=1,
                       db=f"sqlite:///{tmp_path / 's.db'}", fmu=fmu_path, on_note=notes.append)
    assert sw.stats["stored"] == 12
    (high,) = [n for n in notes if n.startswith("PGA above 2 g")]
    assert high.startswith("PGA above 2 g: all 2 records at 2.5 g, 3 g.")
    (far,) = [n for n in notes if "scaled by more than 4" in n]
    assert ": in pulses, weak at 0.5 g to 3 g (x5 to x30" in far and "strong" not in far
    # a --grid scale axis: its values are the levels
    notes.clear()
    runners.sweep(EX / "statue.toml", ["scale=1:4.5:2"], records="pulses/strong", stop_time=0.5, workers=1,
                  db=f"sqlite:///{tmp_path / 's.db'}", fmu=fmu_path, on_note=notes.append)
    (high,) = [n for n in notes if n.startswith("PGA above 2 g")]
    assert high.startswith("PGA above 2 g: pulses/strong at scale 4.5 (x4.5, PGA 4.5 g")
    (far,) = [n for n in notes if "scaled by more than 4" in n]
    assert "pulses/strong at scale 4.5 (x4.5, PGA 4.5 g" in far
