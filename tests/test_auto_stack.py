"""runners simulate --method auto on a stack (issue 27): the least model that holds, one block,
the rigid stack or the rocking–sliding stack, and the contact (ground or interface) whose slide
decided it.

The rigid stack's monitors are read directly through fmpy's simulate_fmu (not through
runners.engine.fmu), so the choice is checked against the FMU's own outputs."""

from __future__ import annotations

import pytest

import runners
from conftest import run_cli
from runners.analysis.least_model import rocking_sliding_reason, sliding_contact

G = 9.81
# issue 27's statue on a free plinth: plinth b1 = 0.3 m, h1 = 0.5 m, 450 kg; statue b2 = 0.2 m,
# h2 = 0.8 m, 690 kg; mu 0.5; a one-sine pulse of 0.6 g at 2 Hz. The rigid plinth would need
# friction 0.59 on the floor: it slides first.
PLINTH = {"nBlocks": 2, "block1.halfWidth": 0.3, "block1.halfHeight": 0.5, "block1.mass": 450.0,
          "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 690.0,
          "contact.muGround": 0.5, "contact.muInterface": 0.5, "excitation.kind": 1,
          "excitation.amplitude": 0.6 * G, "excitation.frequency": 2.0, "excitation.cycles": 1.0}
# a squat statue (b2 = 0.25 m, h2 = 0.3 m, 300 kg) on the same plinth, the floor rough (mu 5), the
# plinth's top smooth (mu 0.3 < 0.6 g): the statue slides on the plinth first
SQUAT_STATUE = {**PLINTH, "block2.halfWidth": 0.25, "block2.halfHeight": 0.3, "block2.mass": 300.0,
                "contact.muGround": 5.0, "contact.muInterface": 0.3}
# the free pair of examples/two_blocks_free.toml released from opposite tilts: nothing slides (mu 0.7)
FREE_PAIR = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
             "block1.theta0": 0.05, "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0,
             "block2.theta0": -0.08}
MONITORS = ["slideTime", "liftTime", "slides", "friction.demandMaxGround", "friction.demandMaxInterface", "fallTime",
            "overturned"]


def as_scene(params: dict, stop_time: float = 3.0):
    """The scene of FMU parameters `params` (runners.simulate takes FMU parameters as overrides)."""
    return {"name": "stack", "simulation": {"stop_time": stop_time, "step": 1e-2}}, params


def rigid_monitors(fmu_path, params: dict, stop_time: float = 3.0) -> dict[str, float]:
    """The rigid stack's monitors at stop_time, simulated by fmpy.simulate_fmu (Co-Simulation)."""
    from fmpy import simulate_fmu

    start = {"block1.theta0": 0.0, **params, "contact.model": 0}  # a scene starts at rest (docs/scenes.md)
    res = simulate_fmu(str(fmu_path), start_values=start, stop_time=stop_time, output_interval=stop_time / 100,
                       output=MONITORS, fmi_type="CoSimulation")
    return {n: float(res[n][-1]) for n in MONITORS}


def simulate(params: dict, fmu_path, method: str = "auto", stop_time: float = 3.0):
    sc, p = as_scene(params, stop_time)
    return runners.simulate(sc, parameters=p, method=method, fmu=fmu_path)


# ------------------------------------------------------------------ the rigid stack holds


def test_a_stack_whose_contacts_never_slide_stays_rigid(fmu_path):
    rigid = rigid_monitors(fmu_path, FREE_PAIR)
    assert rigid["slideTime"] < 0 and rigid["liftTime"] < 0  # the monitors: no contact slid or lifted off
    r = simulate(FREE_PAIR, fmu_path)
    s = r.summary
    assert s["model"] == "two blocks" and s["model_sufficient"] is True
    assert "sliding_contact" not in s and "rigid_rocking_assumptions" not in s
    assert r.parameters.get("contact.model", 0) == 0 and rocking_sliding_reason(s, r.parameters) is None
    # one rectangle cut in two, seated, rocking freely: the combined block, as before
    cut = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.2, "block1.mass": 2.0, "block1.theta0": 0.1,
           "block2.halfWidth": 0.1, "block2.halfHeight": 0.3, "block2.mass": 3.0, "block2.theta0": 0.1}
    assert rigid_monitors(fmu_path, cut)["slideTime"] < 0
    s = simulate(cut, fmu_path).summary
    assert s["model"] == "one block (combined)" and s["model_sufficient"] is True and "sliding_contact" not in s


def test_a_slide_during_the_overturning_fall_keeps_the_rigid_stack(fmu_path):
    """Anagnostopoulos's Fig. 17B pair overturns; its ground contact slides only as it falls
    (after fallTime), which does not change that it fell: the rigid stack answers."""
    fig17b = {"nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
              "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3, "restitution.law": 2,
              "excitation.kind": 3, "excitation.frequency": 5.5, "excitation.displacement": 0.003,
              "excitation.cycles": 0.0}
    rigid = rigid_monitors(fmu_path, fig17b, 10.0)
    assert rigid["overturned"] and 0 <= rigid["fallTime"] < rigid["slideTime"]
    s = simulate(fig17b, fmu_path, stop_time=10.0).summary
    assert s["model"] == "two blocks" and s["model_sufficient"] is True and s["overturned"]
    assert sliding_contact(s, {**fig17b}) is None


# ------------------------------------------------------------------ a contact slides: which one decides


@pytest.mark.parametrize("params, contact", [(PLINTH, "ground"), (SQUAT_STATUE, "interface")])
def test_the_rigid_stacks_monitors_name_the_contact_that_slid_first(fmu_path, params, contact):
    """The choice itself, from the rigid stack's own run (method fmu): the contact whose slide
    comes first decides, with its own demand and mu in the reason."""
    rigid = rigid_monitors(fmu_path, params)
    assert rigid["slideTime"] >= 0 and rigid["liftTime"] < 0
    r = simulate(params, fmu_path, method="fmu")
    s, p = r.summary, r.parameters
    assert s["model"] == "two blocks" and s["assumptions"]["slides"]["contact"] == contact
    assert s["assumptions"]["slides"]["t_s"] == pytest.approx(rigid["slideTime"], abs=1e-12)
    assert sliding_contact(s, p) == contact
    demand = rigid[f"friction.demandMax{contact.capitalize()}"]
    mu = params[f"contact.mu{contact.capitalize()}"]
    assert demand > mu
    where = "on the ground" if contact == "ground" else "between the blocks"
    what = "block 1 slides on the ground" if contact == "ground" else "block 2 slides on block 1"
    assert rocking_sliding_reason(s, p) == (
        f"the rigid stack needs friction demand up to {demand:.3g} > mu {mu:g} {where} ({what} from "
        f"t = {rigid['slideTime']:.6g} s): the {contact} contact decides, rocking-sliding stack used")


def test_a_stack_that_lifts_off_first_runs_the_rocking_sliding_stack_which_follows_the_flight(fmu_path):
    """A stack whose contact lifts off before any slide (a vertical pulse beyond g): the rocking-sliding
    stack follows the flight and the landing, so auto runs it, naming the contact that lifted, and calls it
    sufficient; the pair flies and lands and nothing is left to a lift-off flag."""
    fly = {**FREE_PAIR, "block1.theta0": 0.0, "block2.theta0": 0.0, "excitation.kind": 1,
           "excitation.amplitude": 0.0, "excitation.verticalAmplitude": -15.0, "excitation.frequency": 2.0,
           "excitation.cycles": 1.0}
    rigid = rigid_monitors(fmu_path, fly, 1.0)
    assert rigid["liftTime"] >= 0 and (rigid["slideTime"] < 0 or rigid["liftTime"] <= rigid["slideTime"])
    r = simulate(fly, fmu_path, stop_time=1.0)
    s = r.summary
    assert s["model"] == "rocking-sliding stack" and s["model_sufficient"] is True
    contact = s["sliding_contact"]
    assert contact in ("ground", "interface")
    assert s["model_reason"].startswith(f"the {contact} contact lifts off")
    assert f"at t = {rigid['liftTime']:.6g} s" in s["model_reason"]
    assert s["model_reason"].endswith("rocking-sliding stack, which follows flight and the landing, used")
    assert s["assumptions"]["lifts"] is None and r.parameters["contact.model"] == 1
    assert sum(b.get("flights", 0) for b in s["per_block"]) >= 1  # it flew, and the run went on


@pytest.mark.parametrize("params, contact", [(PLINTH, "ground"), (SQUAT_STATUE, "interface")])
def test_auto_on_a_sliding_stack_runs_the_rocking_sliding_stack_and_says_which_contact(fmu_path, params, contact):
    rigid = rigid_monitors(fmu_path, params)
    r = simulate(params, fmu_path)
    s = r.summary
    assert "rocking_sliding_refused" not in s, s.get("rocking_sliding_refused")
    assert s["model"] == "rocking-sliding stack" and s["sliding_contact"] == contact
    assert s["model_reason"].endswith(f"the {contact} contact decides, rocking-sliding stack used")
    assert s["rigid_rocking_assumptions"]["slides"]["contact"] == contact
    assert s["rigid_rocking_assumptions"]["slides"]["t_s"] == pytest.approx(rigid["slideTime"], abs=1e-12)
    assert r.parameters["contact.model"] == 1 and r.parameters["nBlocks"] == 2
    assert s["assumptions"].get("sliding_modelled") is True and s["model_sufficient"] is True
    assert "model check      sufficient: rocking-sliding follows sliding and flight" in r.report
    # the contact that decided is the one that slides in the rocking-sliding stack's run, from the same instant
    block = "block1" if contact == "ground" else "block2"
    assert r.series[f"{block}.maxAbsSlip"].to_numpy()[-1] > 1e-4
    assert r.series[f"{block}.slideStartTime"].to_numpy()[-1] == pytest.approx(rigid["slideTime"], abs=1e-9)
    first = r.events[r.events["kind"] == "slide"].iloc[0]
    assert first["contact"] == contact and first["time"] == pytest.approx(rigid["slideTime"], abs=1e-9)


def test_the_cli_names_the_model_and_the_contact(tmp_path, fmu_path):
    scene = tmp_path / "plinth.toml"
    scene.write_text('name = "statue on plinth"\n[block]\nhalf_width = 0.3\nhalf_height = 0.5\nmass = 450.0\n'
                     "[block2]\nhalf_width = 0.2\nhalf_height = 0.8\nmass = 690.0\n"
                     "[contact]\nmu_ground = 0.5\nmu_interface = 0.5\n"
                     f'[excitation]\nkind = "sine-pulse"\namplitude = {0.6 * G}\nfrequency = 2.0\ncycles = 1\n'
                     "[simulation]\nstop_time = 3.0\n")
    p = run_cli("simulate", str(scene), "--method", "auto", "--no-store", db=f"sqlite:///{tmp_path / 'r.db'}",
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if x.startswith("model "))
    assert line.startswith("model            rocking-sliding stack: the rigid stack needs friction demand up to ")
    assert "on the ground (block 1 slides on the ground from t = " in line and "the ground contact decides" in line


def test_a_sliding_stack_the_fmu_refuses_stays_not_sufficient_with_its_one_line_reason(tmp_path, fmu_path):
    """Anagnostopoulos's Fig. 17 pair (block 2 wider than block 1) on a slippery floor: the rigid
    stack slides on the ground first, and the rocking-sliding stack does not take a block 2 wider
    than block 1: auto keeps the rigid answer, NOT SUFFICIENT, with the FMU's own reason."""
    pair = {"nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
            "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3, "contact.muGround": 0.05,
            "excitation.kind": 1, "excitation.amplitude": 3.0, "excitation.frequency": 5.0, "excitation.cycles": 1.0}
    rigid = rigid_monitors(fmu_path, pair, 2.0)
    assert 0 <= rigid["slideTime"] < rigid["liftTime"] or (rigid["slideTime"] >= 0 > rigid["liftTime"])  # slides first
    from runners.engine.fmu import FMUError, RockingFMU

    with RockingFMU(fmu_path) as fmu, pytest.raises(FMUError) as refused:
        fmu.validate({**pair, "contact.model": 1})
    s = simulate(pair, fmu_path, stop_time=2.0).summary
    assert s["model"] == "two blocks" and s["model_sufficient"] is False and s["sliding_contact"] == "ground"
    assert s["rocking_sliding_refused"] == str(refused.value) and "\n" not in s["rocking_sliding_refused"]
    scene = tmp_path / "pair.toml"
    scene.write_text("[block]\nhalf_width = 0.0145\nhalf_height = 0.060\nmass = 1.3\n"
                     "[block2]\nhalf_width = 0.030\nhalf_height = 0.050\nmass = 2.3\n[contact]\nmu_ground = 0.05\n"
                     '[excitation]\nkind = "sine-pulse"\namplitude = 3.0\nfrequency = 5.0\ncycles = 1\n'
                     "[simulation]\nstop_time = 2.0\n")
    p = run_cli("simulate", str(scene), "--method", "auto", "--no-store", db=f"sqlite:///{tmp_path / 'r.db'}",
                fmu_path=fmu_path)
    assert p.returncode == 4 and p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
    check = next(x for x in p.stdout.splitlines() if x.startswith("model check"))
    assert "NOT SUFFICIENT" in check and str(refused.value) in check
