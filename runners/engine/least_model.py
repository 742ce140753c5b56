"""The model that answers a scene, and its answer: ``runners.simulate``'s choice of model and runs.

``answer(fm, scene, method)`` is the one entry: ``method`` "fmu" runs the model the scene
describes, "closed-form" Dimitrakopoulos & DeJong (2012)'s closed forms, a Python solver's name
that solver (runners.engine.python_methods), and "auto" (``runners simulate --method auto``) the
least model the scene needs.

The rule of auto, cheapest first (docs/methods.md, "The least model a scene needs"):

1. **closed form** (Dimitrakopoulos & DeJong 2012, model/closed_form.py): one block starting at
   rest, one horizontal one-sine pulse, and slender enough that the
   linearisation is within the requested accuracy, 2 alpha^2 <= accuracy (the
   overturning boundary of a block with alpha = 0.25 rad is off by up to 6.7%,
   below 2 alpha^2 = 12.5%; docs/BENCHMARKS.md). It answers whether the
   block overturns, by which mechanism, and the peak after the first impact
   when that impact follows the pulse;
2. **one block** (the FMU with nBlocks = 1): a one-block scene; a stack
   whose upper block is negligible (mass ratio m2 / m1 <= accuracy / 10,
   seated on block 1 at the start), as the lower block then moves as if alone
   (tests/test_fmu_two_blocks.py: its error is about 1e-6 rad per 1e-6 of
   mass ratio); or a stack that stays locked: one rectangle cut in two (equal
   widths and densities, 1/12 <= h1/h2 <= 12), seated, rocking freely (no
   excitation) under the momentum law. It then rocks as the combined
   rectangle: its interface reactions keep a positive margin at every angle
   and rate free rocking reaches, and its impacts' impulses can be carried
   (tests/test_two_blocks_reference.py), and the locked pair reproduces the
   single block to 1e-15 rad (tests/test_fmu_two_blocks.py);
3. **two blocks** (the FMU with nBlocks = 2) otherwise.

Each of these is rigid rocking. Where its contact monitors say a contact slid before the outcome
was decided (and before any flight; a slide during the overturning fall leaves the outcome
held), auto runs the scene again with the next model up and says why (rocking_sliding_reason),
naming the contact whose slide decided it:

4. **rocking-sliding** (contact.model = 1, nBlocks = 1; docs/contact.md): a one-block scene whose
   block slid on the ground;
5. **rocking-sliding stack** (contact.model = 1, nBlocks = 2; docs/stack_sliding.md): a stack
   (whichever of the models above ran it) whose rigid-stack monitors say a contact slid first:
   the ground (block 1 on the floor: friction.demandMaxGround above contact.muGround) or the
   interface (block 2 on block 1: friction.demandMaxInterface above contact.muInterface), the
   first slide's contact (slideTime and its event) deciding.

Rocking-sliding also follows flight (its contact engine, docs/flight.md): a scene whose block, or
either contact of a stack, lifted off first is run with it too, the contact that lifted naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

from runners.engine.scene import Scene, restitution
from runners.engine.shapes import has_outline
from runners.errors import ArgumentError

TWO_BLOCK_PARAMETERS = ("block2.halfWidth", "block2.halfHeight", "block2.mass", "block2.theta0", "block2.omega0",
                        "restitution.etaGround", "restitution.etaInterface")


def choose_model(p: dict[str, Any], accuracy: float) -> tuple[str, str]:
    """("closed form" | "one block" | "two blocks", why) for the merged parameters p (defaults included)."""
    if not 0 < accuracy < 1:
        raise ValueError(f"--accuracy must be in (0, 1), got {accuracy}")
    if has_outline(p):  # no closed form, no rigid one-block or two-block model takes a polygon
        return shape_model(p), ("a body of real shape runs in the contact engine (rigid contacts first): it has no "
                                "closed form and no rigid one-block least model")
    if int(p["nBlocks"]) == 2:
        ratio = p["block2.mass"] / p["block1.mass"]
        seated = p["block2.theta0"] == p["block1.theta0"] and p["block2.omega0"] == p["block1.omega0"]
        if ratio <= accuracy / 10 and seated:
            return "one block", (f"the upper block is negligible (mass ratio {ratio:.1e} <= accuracy / 10) "
                                 "and starts seated")
        if seated and stays_locked(p):
            return "one block (combined)", ("the stack is one rectangle cut in two, seated and rocking freely "
                                            "under the momentum law: it stays locked")
        return "two blocks", "a stack of two blocks that may separate"
    alpha = math.atan2(p["block1.halfWidth"], p["block1.halfHeight"])
    reasons = []
    if not (p["block1.theta0"] == 0 and p["block1.omega0"] == 0):
        reasons.append("it does not start at rest")
    if not (int(p["excitation.kind"]) == 1 and p["excitation.cycles"] == 1):
        reasons.append("the excitation is not a one-sine pulse")
    if p["excitation.verticalAmplitude"] != 0:
        reasons.append("the pulse has a vertical part")
    if 2 * alpha**2 > accuracy:
        reasons.append(f"the block is not slender enough (2 alpha^2 = {2 * alpha**2:.2g} > accuracy {accuracy:g})")
    if reasons:
        return "one block", "no closed form: " + ", ".join(reasons)
    return "closed form", (f"one block at rest under a one-sine pulse, slender (2 alpha^2 = {2 * alpha**2:.2g} "
                           f"<= accuracy {accuracy:g})")


ROCKING_SLIDING = "rocking-sliding"  # the model's name in summaries and stored runs (one block)
ROCKING_SLIDING_STACK = "rocking-sliding stack"  # the same for a stack (nBlocks = 2, contact.model = 1)
ROCKING_SLIDING_COLUMN = "rocking-sliding column"  # a column (nBlocks 3 to 8, contact.model = 1)
RIGID_COLUMN = "column"  # a column in rigid rocking (contact.model = 0: the engine's contacts never slip)
# bodies of real shape in rigid rocking (contact.model = 0: the contact engine, contacts that never slip)
RIGID_SHAPE = "body of real shape"  # one body
RIGID_SHAPE_STACK = "two blocks, contact engine"  # a stack with a body of real shape
SLIDING_MODELS = (ROCKING_SLIDING, ROCKING_SLIDING_STACK, ROCKING_SLIDING_COLUMN)

# where each contact is, in a reason's words: (the contact, what slides there)
CONTACT_WORDS = {"ground": ("on the ground", "block 1 slides on the ground"),
                 "interface": ("between the blocks", "block 2 slides on block 1")}



def shape_model(p: dict[str, Any]) -> str:
    """The rigid-rocking model's name of a scene of 1 or 2 blocks with a body of real shape (merged `p`)."""
    return RIGID_SHAPE_STACK if int(p.get("nBlocks", 1)) == 2 else RIGID_SHAPE


def sliding_model(p: dict[str, Any]) -> str:
    """The name of the rocking-sliding model of a scene of merged parameters `p`: one block's or
    the stack's."""
    n = int(p.get("nBlocks", 1))
    return ROCKING_SLIDING_COLUMN if n >= 3 else ROCKING_SLIDING_STACK if n == 2 else ROCKING_SLIDING


def sliding_contact(s: dict[str, Any], p: dict[str, Any]) -> str | None:
    """The contact ("ground" or "interface") whose slide makes --method auto leave rigid rocking
    after the rigid-rocking answer `s` (a summary with the rigid model's ``assumptions``, of the
    rigid stack's monitors for a stack) of a scene of merged parameters `p`; None when auto keeps
    it: rigid rocking's outcome held (nothing slid or lifted off, or only during the overturning
    fall, after fallTime). A lift-off first names its contact (one block's: the ground): rocking-sliding
    follows the flight."""
    a = s.get("assumptions")
    if a is None or a.get("sliding_modelled") or a["outcome_held"]:
        return None
    slide, lift = a["slides"], a["lifts"]
    if lift is not None and (slide is None or lift["t_s"] <= slide["t_s"]):
        contact = lift.get("contact", "ground") if int(p.get("nBlocks", 1)) == 2 else "ground"
        return contact if contact in CONTACT_WORDS else None
    if slide is None:
        return None
    contact = slide["contact"]
    if contact not in CONTACT_WORDS or (contact == "interface" and int(p.get("nBlocks", 1)) != 2):
        return None
    return contact


def rocking_sliding_reason(s: dict[str, Any], p: dict[str, Any]) -> str | None:
    """Why --method auto runs rocking-sliding (one block's, or the stack's) after a rigid-rocking
    answer `s` of a scene of merged parameters `p`, naming the contact whose slide decided it
    (sliding_contact), or None when it does not. Demands are |T| / N (1), times s."""
    contact = sliding_contact(s, p)
    if contact is None:
        return None
    a, stack = s["assumptions"], int(p.get("nBlocks", 1)) == 2
    slide, lift = a["slides"], a["lifts"]
    if lift is not None and (slide is None or lift["t_s"] <= slide["t_s"]):
        who = (f"the {contact} contact lifts off" + (" (block 2 leaves block 1's top)" if contact == "interface" else "")
               if stack else "the block lifts off the ground")
        why = (f"{who} at t = {lift['t_s']:.6g} s (its normal force would have to pull): "
               f"rocking-sliding{' stack' if stack else ''}, which follows flight and the landing, used")
        if int(p.get("solver.method", 0)) == 1:
            why += " (integrated by dormand-prince: taylor integrates rigid rocking only)"
        return why
    where, what = CONTACT_WORDS[contact]
    if stack:
        mu = f"mu {a[f'mu_{contact}']:g} {where}"
        if slide["at_impact"]:
            need = (f"an impact {where} needs more friction impulse than {mu} (the largest impulse demand of the "
                    f"stack's impacts is {a['impulse_demand_max']:.3g} times the normal impulse)")
        else:
            need = f"the rigid stack needs friction demand up to {a[f'friction_demand_max_{contact}']:.3g} > {mu}"
        why = (f"{need} ({what} from t = {slide['t_s']:.6g} s): the {contact} contact decides, "
               "rocking-sliding stack used")
    else:
        if slide["at_impact"]:
            need = f"an impact needs a friction impulse {a['impulse_demand_max']:.3g} times the normal one"
        else:
            need = f"rigid rocking needs friction demand up to {a['friction_demand_max_ground']:.3g}"
        why = (f"{need} > mu {a['mu_ground']:g} (the block slides from t = {slide['t_s']:.6g} s): "
               "rocking-sliding used")
    if int(p.get("solver.method", 0)) == 1:  # the Taylor series asked for (auto, 2, picks Dormand-Prince itself)
        why += " (integrated by dormand-prince: taylor integrates rigid rocking only)"
    return why


def rocking_sliding_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """A scene's parameters `params` (one block or a stack) for the rocking-sliding model
    (contact.model = 1, integrated by Dormand-Prince, solver.method = 0)."""
    q = {**params, "contact.model": 1}
    if "solver.method" in q:
        q["solver.method"] = 0
    return q


def rigid_rocking_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """`params` for rigid rocking (contact.model = 0), the model auto tries first."""
    return {**params, "contact.model": 0} if "contact.model" in params else dict(params)


def stays_locked(p: dict[str, Any]) -> bool:
    """The stack is one rectangle cut in two, rocking freely under the momentum law (see the rule above)."""
    b1, h1, m1 = p["block1.halfWidth"], p["block1.halfHeight"], p["block1.mass"]
    b2, h2, m2 = p["block2.halfWidth"], p["block2.halfHeight"], p["block2.mass"]
    return (b1 == b2 and abs(m1 / h1 - m2 / h2) <= 1e-9 * (m1 / h1) and 1 / 12 <= h1 / h2 <= 12
            and int(p["excitation.kind"]) == 0 and int(p["restitution.law"]) == 0)


def combined_block_parameters(p: dict[str, Any]) -> dict[str, Any]:
    """One-block parameters of a stack that stays locked: the combined rectangle."""
    q = one_block_parameters(p)
    q.update({"block1.halfHeight": p["block1.halfHeight"] + p["block2.halfHeight"],
              "block1.mass": p["block1.mass"] + p["block2.mass"]})
    return q


def one_block_parameters(p: dict[str, Any]) -> dict[str, Any]:
    """The scene's parameters for the one-block model (drops the upper block)."""
    return {k: v for k, v in p.items() if k not in TWO_BLOCK_PARAMETERS and k != "nBlocks"}


def closed_form_summary(p: dict[str, Any]) -> dict[str, Any]:
    """The closed forms' answer for a scene that choose_model sent to them."""
    from model import closed_form as cf  # loads SciPy: only when used

    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    alpha, R = math.atan2(b, h), math.hypot(b, h)
    pf = math.sqrt(3 * g / (4 * R))
    eta = restitution(p, alpha)
    a = abs(p["excitation.amplitude"]) / (g * alpha)
    w = 2 * math.pi * p["excitation.frequency"] / pf
    out: dict[str, Any] = {"a": a, "omega_over_p": w, "eta": eta, "alpha_rad": alpha}
    if a <= 1:
        out.update(outcome="at rest", overturned=False, case="no uplift (a <= 1)", peak_after_first_impact_rad=None)
        return out
    overturned, case = cf.overturns(a, w, eta)
    out.update(outcome="overturned" if overturned else "survives", overturned=overturned, case=case)
    peak = None
    if not overturned and cf.first_impact_in_pulse(cf.groups(a, w)) is None:
        peak = alpha * cf.max_rotation_after_impact(a, w, eta)
    out["peak_after_first_impact_rad"] = peak
    return out


CASES = {"1.1": "after an impact within the pulse (eqs. 3.20-3.21)",
         "1.2": "after an impact that follows the pulse (eq. 3.18)",
         "2": "without any impact (eq. 3.10)"}


def format_closed_form(name: str, why: str, s: dict[str, Any]) -> str:
    """The report of the closed forms' answer `s` (closed_form_summary, with the block's sizes)."""
    from runners.engine.summary import size_lines

    lines = [f"scene            {name}", *size_lines(s),
             f"model            closed form (Dimitrakopoulos & DeJong 2012): {why}",
             f"groups           a = a_g/(g alpha) = {s['a']:.4f}, omega_g/p = {s['omega_over_p']:.4f}, "
             f"eta = {s['eta']:.4f}"]
    if s["overturned"]:
        lines.append(f"outcome          overturns {CASES[s['case']]}")
    else:
        lines.append(f"outcome          {s['outcome']} ({s['case']})")
    if s["peak_after_first_impact_rad"] is not None:
        lines.append(f"peak            {s['peak_after_first_impact_rad']:.6f} rad after the first impact (eq. 4.13)")
    return "\n".join(lines)


# ------------------------------------------------------------------ the answer of runners.simulate

PYTHON_METHODS = ("scipy", "rk4", "rk4-located", "newmark", "euler")  # the independent Python solvers
FIXED_STEP_METHODS = ("rk4", "rk4-located", "newmark", "euler")
METHODS = ("fmu", "auto", "closed-form", *PYTHON_METHODS)


@dataclass
class Answer:
    """What the model a method chose answered for a scene.

    model, why: the model's name in summaries and stored runs, and why it was chosen.
    scene: the scene as it ran (auto may have dropped block 2, combined the pair or switched the
        contact model; a Python solver's scene is the one given).
    parameters: the run's FMU parameters, the FMU's defaults merged with the scene's, typed as the
        FMU declares them (Integers int, Booleans bool).
    summary: the facts of runners.engine.summary (SI units, times in s), the model and its reason;
        for auto, whether the model held (``model_sufficient``).
    kind: how the answer is reported: "fmu" (an FMU run, ``result``), "closed form" or "python".
    result: the FMU's run (None for the closed forms and the Python solvers).
    columns: the outputs of ``result`` a RunResult's series keeps (and a stored run stores).
    notes: what the reader should know about how the method ran the scene.
    """

    model: str
    scene: Scene
    parameters: dict[str, Any]
    summary: dict[str, Any]
    kind: str = "fmu"
    result: Any = None
    columns: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def answer(fm, scene: Scene, method: str = "fmu", accuracy: float = 1e-2, outputs: Sequence[str] | None = None,
           h: float | None = None, rtol: float | None = None) -> Answer:
    """The answer to `scene` of the model `method` asks for, run through the open FMU `fm`
    (runners.engine.fmu.RockingFMU): "fmu" the model the scene describes, "auto" the least model
    that meets `accuracy` and holds (the rule above: a second run with rocking-sliding where rigid
    rocking's monitors say a contact slid first), "closed-form" the closed forms (ArgumentError
    where they do not apply), or a Python solver of PYTHON_METHODS (fixed step `h` in s, default
    1e-4; `rtol` of scipy, default 1e-10). `outputs`: FMU outputs the series keeps besides the
    summary's. ArgumentError for a method that cannot run the scene's contact model."""
    defaults = fm.defaults()
    merged = {**defaults, **scene.parameters}
    if int(merged.get("contact.model", 0)) == 1 and method not in ("fmu", "auto"):
        raise ArgumentError(f"method {method} solves rigid rocking; the scene's [contact] model is "
                            "rocking-sliding (method fmu, or auto)")
    if int(merged.get("support.kind", 0)) != 0 and method not in ("fmu", "auto"):
        raise ArgumentError(f"method {method} solves a block on the ground; the scene's [building] or [platform] "
                            "runs inside the FMU (method fmu, or auto)")
    if has_outline(merged) and method not in ("fmu", "auto"):
        raise ArgumentError(f"method {method} solves rectangular blocks; a body of real shape (an outline) runs in "
                            "the FMU's contact engine (method fmu, or auto)")
    if int(merged.get("nBlocks", 1)) >= 3 and method not in ("fmu", "auto"):
        raise ArgumentError(f"method {method} solves one block or two; a column of {int(merged['nBlocks'])} blocks runs "
                            "in the FMU's contact engine (method fmu, or auto)")
    if int(merged.get("nBlocks", 1)) >= 3:  # a column: the model the scene describes (auto has no lesser one)
        model = sliding_model(merged) if int(merged.get("contact.model", 0)) == 1 else RIGID_COLUMN
        why = ("the model the scene describes (--method fmu)" if method == "fmu" else
               f"a column of {int(merged['nBlocks'])} blocks: the contact engine, the scene's own contact model")
        return run_model(fm, scene, model, why, merged, outputs)
    if method in PYTHON_METHODS:
        return _python_answer(fm, scene, merged, method, h, rtol)
    if method == "auto":  # auto tries rigid rocking first, as for every scene
        scene = replace(scene, parameters=rigid_rocking_parameters(scene.parameters))
        merged = {**defaults, **scene.parameters}
    model, why = pick_model(merged, method, accuracy)
    found = run_model(fm, scene, model, why, merged, outputs, monitor=method == "auto")
    if method == "auto":
        found = _switch_if_it_slid(fm, found, scene, merged, outputs)
        if "assumptions" in found.summary:  # the least model must also be a model that holds
            found.summary["model_sufficient"] = found.summary["assumptions"]["outcome_held"]
    return found


def pick_model(merged: dict[str, Any], method: str, accuracy: float) -> tuple[str, str]:
    """(model, why) of method "fmu" (the scene's own), "auto" (choose_model) or "closed-form"
    (ArgumentError where the closed forms do not apply) for the merged parameters."""
    if method == "fmu":
        model = (sliding_model(merged) if int(merged.get("contact.model", 0)) == 1
                 else shape_model(merged) if has_outline(merged)
                 else "two blocks" if int(merged["nBlocks"]) == 2 else "one block")
        return model, "the model the scene describes (--method fmu)"
    model, why = choose_model(merged, accuracy)
    if method == "closed-form" and model != "closed form":
        raise ArgumentError(f"method closed-form does not apply to this scene: {why.removeprefix('no closed form: ')}")
    return model, why


def run_model(fm, described: Scene, model: str, why: str, merged: dict[str, Any],
              outputs: Sequence[str] | None = None, monitor: bool = False) -> Answer:
    """Run `model` on the scene `described` (of merged parameters `merged`, defaults included)
    and summarise it. `monitor` (auto): also answer whether rigid rocking held where this model
    does not watch every contact itself (the closed form; a stack run as one block), from the
    FMU's contact monitors on the scene as described."""
    from runners.engine.summary import MONITOR_OUTPUTS, SUMMARY_OUTPUTS, sliding_outputs, summarize

    defaults = fm.defaults()
    two = int(merged["nBlocks"]) == 2
    if model == "closed form":
        s = {"scene": described.name, "model": model, "model_reason": why, **closed_form_summary(merged)}
        if monitor:  # the closed form is rigid rocking too: the FMU's monitors check that
            s["assumptions"] = monitored(fm, described, merged)
        return Answer(model, described, typed(fm, merged), s, kind="closed form")
    scene = described
    if model == "one block" and two:
        scene = replace(scene, parameters=one_block_parameters(scene.parameters))
    if model == "one block (combined)":
        combined = combined_block_parameters(merged)
        scene = replace(scene, parameters={k: v for k, v in combined.items()
                                           if k in scene.parameters or k.startswith("block1.")})
    params = {**defaults, **scene.parameters}
    own = sliding_outputs(params)  # its channels, stored and exported
    wanted = list(dict.fromkeys([*SUMMARY_OUTPUTS, *MONITOR_OUTPUTS, *own, *(outputs or ())]))
    result = fm.run(scene.parameters, scene.stop_time, scene.step, outputs=wanted)
    s = summarize(scene, result, defaults)
    s["model"], s["model_reason"] = model, why
    if monitor and two and model not in ("two blocks", ROCKING_SLIDING_STACK, RIGID_SHAPE_STACK):
        # a stack run as one block: only the two-block model sees its interface
        s["assumptions"] = monitored(fm, described, merged)
    columns = list(outputs) if outputs else [*SUMMARY_OUTPUTS, *MONITOR_OUTPUTS, *own]  # stored, exported
    return Answer(model, scene, typed(fm, params), s, result=result, columns=columns)


def _switch_if_it_slid(fm, found: Answer, described: Scene, merged: dict[str, Any],
                       outputs: Sequence[str] | None) -> Answer:
    """Auto's second step: where rigid rocking's monitors say a contact slid before the outcome
    was decided, the answer of rocking-sliding (one block's or the stack's) on the scene as
    described, keeping what the rigid monitors said; `found` itself when nothing slid, when it
    already is rocking-sliding, or when the FMU refuses rocking-sliding for this scene (the
    summary then says why)."""
    from runners.engine.fmu import FMUError

    switch = rocking_sliding_reason(found.summary, merged)
    if switch is None or found.model in SLIDING_MODELS:
        return found
    trial = rocking_sliding_parameters(described.parameters)
    contact = sliding_contact(found.summary, merged)  # the contact that decided: ground or interface
    try:  # the FMU's own checks (the restitution law's eta, ...) before the run
        fm.validate(trial)
    except FMUError as exc:
        found.summary["rocking_sliding_refused"], found.summary["sliding_contact"] = str(exc), contact
        return found
    sliding = run_model(fm, replace(described, parameters=trial), sliding_model(merged), switch,
                        {**fm.defaults(), **trial}, outputs)
    # what rigid rocking's monitors said, which made auto switch
    sliding.summary["rigid_rocking_assumptions"], sliding.summary["sliding_contact"] = \
        found.summary["assumptions"], contact
    return sliding


def monitored(fm, scene: Scene, merged: dict[str, Any]) -> dict[str, Any]:
    """The rigid-rocking assumptions of `scene` as the FMU's contact monitors see them (for a
    model whose own run does not monitor all of the scene's contacts)."""
    from runners.engine.summary import MONITOR_OUTPUTS, assumptions

    run = fm.run(scene.parameters, scene.stop_time, scene.step, outputs=[*MONITOR_OUTPUTS, "overturned"])
    return assumptions(run, merged, int(merged["nBlocks"]) == 2)


def typed(fm, params: dict[str, Any]) -> dict[str, Any]:
    """FMU parameters as the FMU declares them: Integers int, Booleans bool, the rest as given."""
    kinds = {name: fm.vars[name].type for name in params}
    return {name: int(v) if kinds[name] == "Integer" else bool(v) if kinds[name] == "Boolean" else v
            for name, v in params.items()}


def _python_answer(fm, scene: Scene, merged: dict[str, Any], method: str, h: float | None,
                   rtol: float | None) -> Answer:
    """The answer of an independent Python solver (runners.engine.python_methods): a summary,
    no series."""
    from runners.engine.python_methods import run_python

    s = {"scene": scene.name, **run_python(method, merged, scene.stop_time, 1e-4 if h is None else h,
                                           1e-10 if rtol is None else rtol)}
    notes = ([f"the scene's FMU integrator ([simulation] method) does not apply to method {method}"]
             if "solver.method" in scene.parameters else [])
    return Answer(s["model"], scene, typed(fm, merged), s, kind="python", notes=notes)
