"""runners simulate --method auto: the least model a scene needs, and the closed form's answers
against the FMU."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from model import closed_form as cf
from runners.analysis.least_model import choose_model, closed_form_summary

ROOT = Path(__file__).resolve().parent.parent
SLENDER = {"block1.halfWidth": 0.05, "block1.halfHeight": 1.0}


def merged(fmu, **params) -> dict:
    defaults = fmu.defaults()
    return {**defaults, **params}


def pulse(a: float, w: float) -> dict:
    """Sine pulse of groups (a, omega) on the slender block (linear threshold g alpha)."""
    alpha, R = math.atan2(0.05, 1.0), math.hypot(0.05, 1.0)
    p = math.sqrt(3 * 9.81 / (4 * R))
    return {**SLENDER, "excitation.kind": 1, "excitation.amplitude": a * 9.81 * alpha,
            "excitation.frequency": w * p / (2 * math.pi)}


def test_the_rule_picks_the_least_model(fmu):
    assert choose_model(merged(fmu, **pulse(2.0, 3.0)), 1e-2)[0] == "closed form"
    model, why = choose_model(merged(fmu, **pulse(2.0, 3.0)), 1e-3)  # asks more than linearisation gives
    assert model == "one block" and "slender" in why
    model, why = choose_model(merged(fmu, **{**pulse(2.0, 3.0), "excitation.kind": 3}), 1e-2)
    assert model == "one block" and "one-sine pulse" in why
    model, why = choose_model(merged(fmu, **{**pulse(2.0, 3.0), "block1.theta0": 0.01}), 1e-2)
    assert model == "one block" and "rest" in why
    stack = {"nBlocks": 2, "block2.mass": 5.0}
    assert choose_model(merged(fmu, **stack), 1e-2)[0] == "two blocks"
    light = {"nBlocks": 2, "block2.mass": 1e-4, "block2.halfWidth": 0.01, "block2.halfHeight": 0.01}
    assert choose_model(merged(fmu, **light), 1e-2)[0] == "one block"
    assert choose_model(merged(fmu, **{**light, "block2.theta0": 0.01}), 1e-2)[0] == "two blocks"
    with pytest.raises(ValueError, match="accuracy"):
        choose_model(merged(fmu), 0.0)


@pytest.mark.parametrize("w", [1.5, 4.0])
@pytest.mark.parametrize("factor", [0.8, 1.2])
def test_closed_form_outcome_agrees_with_the_fmu_away_from_the_boundary(fmu, w, factor):
    eta = 1 - 1.5 * math.sin(math.atan2(0.05, 1.0)) ** 2
    a = factor * cf.smallest_overturning_a(lambda aa, ww: cf.overturns(aa, ww, eta)[0], w)
    s = closed_form_summary(merged(fmu, **pulse(a, w)))
    r = fmu.run(pulse(a, w), 40.0, 0.05, outputs=["overturned"], events=False)
    assert s["overturned"] == bool(r.outputs["overturned"][-1]) == (factor > 1)


def test_closed_form_peak_after_the_first_impact_is_within_the_accuracy(fmu):
    a, w = 3.0, 6.0  # survives; the first impact follows the pulse
    s = closed_form_summary(merged(fmu, **pulse(a, w)))
    assert not s["overturned"] and s["peak_after_first_impact_rad"] is not None
    r = fmu.run(pulse(a, w), 20.0, 0.05, outputs=["impacts"])
    first_impact = r.event_times("impact")[0]
    peaks = [(e.t, abs(e.values["theta"])) for e in r.events if e.kind == "peak" and e.t > first_impact]
    assert abs(peaks[0][1] / s["peak_after_first_impact_rad"] - 1) < 1e-2


def runners(*args, fmu_path):
    env = {**os.environ, "ROCKING_FMU": str(fmu_path)}
    return subprocess.run([sys.executable, "-m", "runners.cli", *args], capture_output=True, text=True, env=env,
                          cwd=ROOT)


def test_summary_says_which_model_ran_and_why(fmu_path, tmp_path):
    scene = tmp_path / "slender.toml"
    scene.write_text("[block]\nhalf_width = 0.05\nhalf_height = 1.0\n"
                     "[excitation]\nkind = \"sine-pulse\"\namplitude = 1.2\nfrequency = 0.5\n")
    p = runners("simulate", str(scene), "--method", "auto", "--json", fmu_path=fmu_path)
    s = json.loads(p.stdout)
    assert s["model"] == "closed form" and "slender" in s["model_reason"] and s["overturned"] is True
    p = runners("simulate", "examples/sine_pulse.toml", "--method", "auto", fmu_path=fmu_path)
    assert "model            one block: no closed form" in p.stdout
    p = runners("simulate", "examples/sine_pulse.toml", "--method", "closed-form", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.startswith("error: method closed-form does not apply")


def test_a_negligible_upper_block_runs_as_one_block(fmu_path, tmp_path):
    scene = tmp_path / "light.toml"
    scene.write_text("[block]\nhalf_width = 0.1\nhalf_height = 0.3\ntheta0 = 0.1\n"
                     "[block2]\nhalf_width = 0.01\nhalf_height = 0.01\nmass = 1e-4\ntheta0 = 0.1\n")
    auto = json.loads(runners("simulate", str(scene), "--method", "auto", "--json", fmu_path=fmu_path).stdout)
    two = json.loads(runners("simulate", str(scene), "--json", fmu_path=fmu_path).stdout)
    assert auto["model"] == "one block" and auto["blocks"] == 1 and two["blocks"] == 2
    assert auto["impacts"] == two["impacts_ground"]
    assert abs(auto["max_abs_theta_rad"] - two["max_abs_theta_rad"]) < 1e-12


# Dormand-Prince for the combined block too (the default takes the Taylor series for one block):
# the stack's integrator on both sides, so the two runs agree to 1e-12
CUT = ("[block]\nhalf_width = 0.1\nhalf_height = 0.2\nmass = 2.0\ntheta0 = 0.1\n"
       "[block2]\nhalf_width = 0.1\nhalf_height = 0.3\nmass = 3.0\ntheta0 = 0.1\n"
       "[simulation]\nstop_time = 4.0\nstep = 0.01\nmethod = \"dormand-prince\"\n")


def test_a_stack_that_stays_locked_runs_as_the_combined_block(fmu_path, tmp_path):
    scene = tmp_path / "cut.toml"
    scene.write_text(CUT)
    auto = json.loads(runners("simulate", str(scene), "--method", "auto", "--json", fmu_path=fmu_path).stdout)
    two = json.loads(runners("simulate", str(scene), "--json", fmu_path=fmu_path).stdout)
    assert auto["model"] == "one block (combined)" and "stays locked" in auto["model_reason"]
    assert two["impacts_interface"] == 0 and auto["impacts"] == two["impacts_ground"] >= 5
    assert abs(auto["final_theta_rad"] - two["final_theta_rad"]) < 1e-12
    # excitation, another law or another density: the stack may separate, so two blocks
    for extra in ('[excitation]\nkind = "sine-pulse"\namplitude = 1.0\nfrequency = 2.0\n',
                  '[restitution]\nlaw = "constant"\n'):
        scene.write_text(CUT + extra)
        s = json.loads(runners("simulate", str(scene), "--method", "auto", "--json", fmu_path=fmu_path).stdout)
        assert s["model"] == "two blocks"
    scene.write_text(CUT.replace("mass = 3.0", "mass = 4.0"))
    assert json.loads(runners("simulate", str(scene), "--method", "auto", "--json",
                              fmu_path=fmu_path).stdout)["model"] == "two blocks"
