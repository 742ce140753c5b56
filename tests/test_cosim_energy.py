"""Which energy residual of a two-way co-simulation is its error measure: the residual at the end of
the run, which shrinks with the communication step, not the largest along it, which with impacts
holds the one-step transient of each impact's impulse and does not (docs/cosimulation.md). The API
names both, the command line reports the first."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from runners.analysis import cosim as checks
from runners.engine import cosim

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "cabinet_on_floor.toml"


def test_the_residual_shrinks_with_the_step_and_the_held_largest_does_not(fmu_path, building_fmu_path):
    """The cabinet (6 impacts): from 1 ms to 0.25 ms the default master's residual drops by more than 3, at the end
    and at its largest; held inputs (libcosim's algorithm) keep the largest within a factor 2 (an impact's transient,
    which no step removes there)."""
    system = cosim.load_system(EXAMPLE)
    balances = {held: [checks.energy_balance(cosim.run(replace(system, step=h), block_fmu=fmu_path,
                                                       building_fmu=building_fmu_path, interpolate=not held))
                       for h in (1e-3, 2.5e-4)] for held in (False, True)}
    for b in balances[False] + balances[True]:
        assert b.relative_end == pytest.approx(abs(b.residual[-1]) / b.scale, rel=1e-15)
        assert b.relative_max == pytest.approx(np.max(np.abs(b.residual)) / b.scale, rel=1e-15)
        assert b.relative_max >= b.relative_end
    coarse, fine = balances[False]
    assert fine.relative_end < coarse.relative_end / 3 and fine.relative_max < coarse.relative_max / 3
    assert coarse.relative_max < 1e-3
    coarse, fine = balances[True]
    assert fine.relative_end < coarse.relative_end / 3 and fine.relative_max > coarse.relative_max / 2
    with pytest.deprecated_call():
        assert coarse.relative == coarse.relative_max  # the former name, which did not say which


def test_the_command_reports_the_end_residual_as_the_error(fmu_path, building_fmu_path):
    env = {**os.environ, "ROCKING_BUILDING_FMU": str(building_fmu_path)}
    exe = str(Path(sys.executable).parent / "runners")
    text, doc = (subprocess.run([exe, "cosim", str(EXAMPLE), "--step", "0.002", "--fmu", str(fmu_path), *extra],
                                capture_output=True, text=True, env=env, timeout=300) for extra in ([], ["--json"]))
    assert text.returncode == doc.returncode == 0, text.stderr + doc.stderr
    run = json.loads(doc.stdout)["runs"][0]
    relative = abs(run["energy_residual_end_j"]) / run["energy_scale_j"]
    assert run["energy_residual_end_relative"] == pytest.approx(relative)
    assert not [k for k in run if "max" in k and "energy" in k]  # the largest is no error measure
    line = next(line for line in text.stdout.splitlines() if "energy balance" in line)
    assert f"{run['energy_residual_end_j']:.3g} J at the end" in line and "the coupling's error" in line
    assert "at most" not in line
    # the error estimate: the same run at twice the step, in the text and the JSON; --no-estimate skips it
    assert f"error estimate (the same run at h = 0.004 s): peak |theta| {run['error_estimate_peak_abs_theta']:.2g} rad" \
        in text.stdout
    bare = subprocess.run([exe, "cosim", str(EXAMPLE), "--step", "0.002", "--fmu", str(fmu_path), "--json",
                           "--no-estimate", "--no-store"], capture_output=True, text=True, env=env, timeout=300)
    assert bare.returncode == 0 and not [k for k in json.loads(bare.stdout)["runs"][0] if k.startswith("error_est")]
