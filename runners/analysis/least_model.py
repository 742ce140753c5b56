"""``runners simulate --method auto``: the least model a scene needs.

The rule, cheapest first (docs/methods.md, "The least model a scene needs"):

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

Flight is outside every model: a run that lifts off first stays NOT SUFFICIENT.
"""

from __future__ import annotations

import math
from typing import Any

from runners.engine.scene import restitution

TWO_BLOCK_PARAMETERS = ("block2.halfWidth", "block2.halfHeight", "block2.mass", "block2.theta0", "block2.omega0",
                        "restitution.etaGround", "restitution.etaInterface")


def choose_model(p: dict[str, Any], accuracy: float) -> tuple[str, str]:
    """("closed form" | "one block" | "two blocks", why) for the merged parameters p (defaults included)."""
    if not 0 < accuracy < 1:
        raise ValueError(f"--accuracy must be in (0, 1), got {accuracy}")
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
SLIDING_MODELS = (ROCKING_SLIDING, ROCKING_SLIDING_STACK)

# where each contact is, in a reason's words: (the contact, what slides there)
CONTACT_WORDS = {"ground": ("on the ground", "block 1 slides on the ground"),
                 "interface": ("between the blocks", "block 2 slides on block 1")}


# the interface's and the upper block's channels of the rocking-sliding stack (docs/stack_sliding.md),
# sampled, stored and exported with its runs on top of the one-block SLIDING_OUTPUTS (block 1's slip on
# the ground): block 2's slip along block 1's top (m), its rate, mode, peak, time sliding, first slide,
# friction loss (J), stick-to-slip transitions, and whether (and when, s) it fell off block 1
STACK_SLIDING_OUTPUTS = ("block2.slip", "block2.slipRate", "block2.mode", "block2.maxAbsSlip",
                         "block2.slideDuration", "block2.slideStartTime", "block2.frictionLoss", "block2.slides",
                         "block2.fellOff", "block2.fellOffTime")


def sliding_model(p: dict[str, Any]) -> str:
    """The name of the rocking-sliding model of a scene of merged parameters `p`: one block's or
    the stack's."""
    return ROCKING_SLIDING_STACK if int(p.get("nBlocks", 1)) == 2 else ROCKING_SLIDING


def sliding_contact(s: dict[str, Any], p: dict[str, Any]) -> str | None:
    """The contact ("ground" or "interface") whose slide makes --method auto leave rigid rocking
    after the rigid-rocking answer `s` (a summary with the rigid model's ``assumptions``, of the
    rigid stack's monitors for a stack) of a scene of merged parameters `p`; None when auto keeps
    it: rigid rocking's outcome held (nothing slid or lifted off, or only during the overturning
    fall, after fallTime), or what broke it first was flight (outside every model here)."""
    a = s.get("assumptions")
    if a is None or a.get("sliding_modelled") or a["outcome_held"]:
        return None
    slide, lift = a["slides"], a["lifts"]
    if slide is None or (lift is not None and lift["t_s"] <= slide["t_s"]):
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
    slide = a["slides"]
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
    lines = [f"scene            {name}",
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
