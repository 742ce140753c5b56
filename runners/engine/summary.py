"""Summarise a run of RockingBlock.fmu for people (text) and programs (JSON)."""

from __future__ import annotations

import math
from typing import Any

from runners.engine import shapes, supports
from runners.engine.column import column_outputs, format_table, is_column, summary_part
from runners.engine.fmu import RunResult
from runners.engine.scene import CONTACT_MODELS, KIND_NAMES, Scene, uplift_threshold

SUMMARY_OUTPUTS = (
    "block1.theta",
    "block1.omega",
    "impacts",
    "peaks",
    "overturned",
    "atRest",
    "energy",
    "block1.maxAbsTheta",
    "overturnTime",
    "restTime",
    "ground.ahTotal",
    "block2.theta",
    "block2.maxAbsTheta",
    "impactsGround",
    "impactsInterface",
    "block1.overturned",
    "block2.overturned",
    "pattern",
    # for recordings (runners.engine.recording)
    "block2.omega",
    "block1.alpha_dd",
    "block2.alpha_dd",
    "ground.avTotal",
    "contact.groundT",
    "contact.groundN",
    "contact.interfaceT",
    "contact.interfaceN",
)

# the outputs of the rocking-sliding model (contact.model = 1, docs/contact.md): sampled, stored
# and exported with its runs (runners.simulate), not with rigid-rocking ones
SLIDING_OUTPUTS = (
    "block1.slip",  # m, +x: the base's slip on the ground
    "block1.slipRate",  # m/s
    "block1.mode",  # MODES
    "block1.maxAbsSlip",  # m
    "block1.slideDuration",  # s
    "block1.slideStartTime",  # s, -1 if it never slid
    "block1.frictionLoss",  # J
    "impactLoss",  # J
    "groundWork",  # J
    "block1.slides",  # stick-to-slip transitions
    "block1.gap",  # m, the lowest corner above the ground (0 touching)
    "block1.maxGap",  # m
    "block1.flightTime",  # s in flight
    "block1.flights",  # take-offs
    "contact.painleve",  # Painleve points resolved (docs/flight.md)
)
# and those of a rocking-sliding stack (nBlocks = 2, docs/stack_sliding.md): block 2 on block 1
# (slips along block 1's top, relative to it) and its falling off
STACK_SLIDING_OUTPUTS = SLIDING_OUTPUTS + (
    "block2.slip",  # m, +x along block 1's top
    "block2.slipRate",  # m/s
    "block2.mode",  # MODES, and 5 fell off
    "block2.maxAbsSlip",  # m
    "block2.slideDuration",  # s
    "block2.slideStartTime",  # s, -1 if it never slid
    "block2.frictionLoss",  # J
    "block2.slides",  # stick-to-slip transitions
    "block2.fellOff",  # block 2 left block 1's top
    "block2.fellOffTime",  # s, -1 if it never fell off
    "block2.gap",  # m, block 2's lowest corner above block 1's top (0 touching)
    "block2.maxGap",  # m
    "block2.flightTime",  # s in flight
    "block2.flights",  # take-offs from block 1
)


# the outputs of a support (support.kind 1 or 2, docs/supports.md), and those of its energy balance in
# the base's frame when it is coupled two ways (two_way_balance)
SUPPORT_OUTPUTS = ("support.u", "support.v", "support.baseAh")  # m, m/s, m/s^2 (+x, relative to the base)
TWO_WAY_OUTPUTS = ("momentum", "support.energy", "support.dampingLoss", "support.baseWork",  # kg m/s, J, J, J
                   "block1.frictionLoss", "block2.frictionLoss", "impactLoss")  # J


def sliding_outputs(p: dict[str, Any]) -> tuple[str, ...]:
    """The model's own outputs a run with FMU parameters `p` (defaults included) samples, stores and
    exports: none for rigid rocking on the ground, SLIDING_OUTPUTS for one block, STACK_SLIDING_OUTPUTS for a
    stack; on a support SUPPORT_OUTPUTS too, and TWO_WAY_OUTPUTS where it is coupled two ways."""
    support = ()
    if int(p.get("support.kind", 0)):
        two = TWO_WAY_OUTPUTS if int(p.get("nBlocks", 1)) == 2 else tuple(o for o in TWO_WAY_OUTPUTS if "block2" not in o)
        support = SUPPORT_OUTPUTS + (two if int(p.get("support.coupling", 0)) == 1 else ())
    column = column_outputs(p)  # a column's blocks (3 or more), whatever its contact model
    if not rocking_sliding(p):
        return tuple(dict.fromkeys(column + support))
    own = STACK_SLIDING_OUTPUTS if int(p.get("nBlocks", 1)) == 2 else SLIDING_OUTPUTS
    return tuple(dict.fromkeys(own + column + support))


def two_way_balance(out: dict[str, Any], p: dict[str, Any]) -> float:
    """The largest residual of the energy balance of blocks plus a two-way support at the samples of `out`,
    over the energy scale (the largest of the energies, works and losses), docs/supports.md: the blocks'
    energy in the base's frame (energy + U momentum + m U^2 / 2, U = support.v) + support.energy +
    support.dampingLoss + friction losses + impactLoss - support.baseWork, less its value at the start."""
    import numpy as np

    mass = float(p["block1.mass"]) + (float(p["block2.mass"]) if int(p.get("nBlocks", 1)) == 2 else 0.0)
    U = np.asarray(out["support.v"])
    blocks = np.asarray(out["energy"]) + U * np.asarray(out["momentum"]) + 0.5 * mass * U * U
    friction = np.asarray(out["block1.frictionLoss"]) + (np.asarray(out["block2.frictionLoss"])
                                                         if "block2.frictionLoss" in out else 0.0)
    terms = [blocks, np.asarray(out["support.energy"]), np.asarray(out["support.dampingLoss"]), friction,
             np.asarray(out["impactLoss"]), np.asarray(out["support.baseWork"])]
    residual = terms[0] + terms[1] + terms[2] + terms[3] + terms[4] - terms[5]
    scale = max(float(np.max(np.abs(t))) for t in terms)
    return float(np.max(np.abs(residual - residual[0]))) / scale if scale > 0 else 0.0

# block1.mode (the FMU's Enumeration ContactMode) -> its name
MODES = {0: "rest", 1: "slide", 2: "rock", 3: "slide-rock", 4: "overturned", 5: "fell off", 6: "flight"}
# the run's state at its end, by block1.mode
MODE_STATES = {0: "at rest", 1: "sliding", 2: "rocking", 3: "slide-rocking", 4: "overturned", 5: "fell off",
               6: "in flight"}

# the monitors of the rigid-rocking assumptions (docs/contact.md): final values are enough
MONITOR_OUTPUTS = (
    "friction.demandMaxGround",
    "contact.normalMinGround",
    "friction.impulseDemandMax",
    "slides",
    "slideTime",
    "lifts",
    "liftTime",
    "friction.demandMaxInterface",
    "contact.normalMinInterface",
    "fallTime",
)

PATTERNS = {0: "rocking", 1: "at rest", 2: "overturned", 3: "upper block rocking alone",
            4: "locked pair rocking", 5: "both blocks rocking", 6: "a contact sliding"}


def block_sizes(p: dict[str, Any]) -> list[dict[str, Any]]:
    """Each block's full width and height (m) and mass (kg) from parameters `p` (defaults
    included; the FMU's are half sizes)."""
    sizes = []
    for i in range(1, int(p.get("nBlocks", 1)) + 1):
        if shapes.has_outline(p, i):  # a body of real shape: the extent of its outline
            b = shapes.body(p, i)
            sizes.append({"block": i, "width_m": b.width, "height_m": b.top, "mass_kg": b.mass,
                          "outline_vertices": len(b.vertices)})
            continue
        sizes.append({"block": i, "width_m": 2 * float(p[f"block{i}.halfWidth"]),
                      "height_m": 2 * float(p[f"block{i}.halfHeight"]), "mass_kg": float(p[f"block{i}.mass"])})
    return sizes


def shape_summary(p: dict[str, Any]) -> dict[str, Any]:
    """A summary's facts of a scene with bodies of real shape (parameters `p`, defaults included): ``shapes``
    (each outlined block's vertices, centre, inertia, alphas and landing angles per side: shapes.shape_facts),
    ``uplift_joints`` (every joint's uplift threshold onto either side, m/s^2: shapes.joints),
    ``uplift_threshold_right_m_s2`` and ``_left_`` (the least of them per side: a_h below minus the first tips
    something onto a right corner, a_h above the second onto a left one), ``uplift_threshold_m_s2`` the least
    of both; for one body ``alpha_left_rad``, ``alpha_right_rad`` and ``p_right_rad_per_s``,
    ``p_left_rad_per_s`` (sqrt(m g rho / I) about each corner), ``alpha_rad`` the smaller alpha and no single
    ``p_rad_per_s``."""
    joints = shapes.joints(p)
    right, left = min(j["right_m_s2"] for j in joints), min(j["left_m_s2"] for j in joints)
    out: dict[str, Any] = {"shapes": shapes.shape_facts(p), "uplift_joints": joints,
                           "uplift_threshold_right_m_s2": right, "uplift_threshold_left_m_s2": left,
                           "uplift_threshold_m_s2": min(right, left)}
    if int(p.get("nBlocks", 1)) == 1:
        b, g = shapes.body(p, 1), float(p["g"])
        out.update(alpha_left_rad=b.alpha_left, alpha_right_rad=b.alpha_right, alpha_rad=min(b.alpha_left, b.alpha_right),
                   p_rad_per_s=None, p_right_rad_per_s=b.rate(g, 1), p_left_rad_per_s=b.rate(g, -1))
    return out


RICKER_HALF_WINDOW = 3.0  # a Ricker pulse lasts 2 x 3 / frequency s (model/c/ground.c)


def excitation_end(p: dict[str, float]) -> float | None:
    """When an analytic excitation of parameters `p` ends (s, as model/c/ground.c computes it),
    None for one that does not end (an endless harmonic), none at all, or a record."""
    kind, start = int(p.get("excitation.kind", 0)), float(p.get("excitation.startTime", 0.0))
    f = float(p.get("excitation.frequency", 0.0))
    if not f > 0:
        return None
    if kind in (1, 2) or (kind == 3 and float(p.get("excitation.cycles", 0.0)) > 0):
        return start + float(p["excitation.cycles"]) / f
    if kind in (5, 6):
        return start + 2.0 * RICKER_HALF_WINDOW / f
    if kind == 7:
        return start + float(p["excitation.gamma"]) / f
    return None


def summarize(scene: Scene, result: RunResult, defaults: dict[str, float]) -> dict[str, Any]:
    """Key facts of a run; ``defaults`` are the FMU's start values. The run must have sampled
    SUMMARY_OUTPUTS (``RockingFMU.run(..., outputs=SUMMARY_OUTPUTS)``; runners.simulate does);
    a rocking-sliding run's sliding facts (sliding_summary) need SLIDING_OUTPUTS too."""
    missing = [o for o in SUMMARY_OUTPUTS if o not in result.outputs]
    if missing:
        raise ValueError(f"summarize needs the outputs of SUMMARY_OUTPUTS; the run lacks {', '.join(missing[:4])}"
                         f"{' ...' if len(missing) > 4 else ''} (run with outputs=SUMMARY_OUTPUTS, or use "
                         "runners.simulate)")
    p = {**defaults, **scene.parameters}
    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    alpha = shapes.alpha(p, 1)  # atan(b / h); a body of real shape's smaller of its two sides'
    R = math.hypot(b, h)
    out = result.outputs
    two = int(p.get("nBlocks", 1)) == 2
    overturned = bool(out["overturned"][-1])
    at_rest = bool(out["atRest"][-1])
    state = "overturned" if overturned else "at rest" if at_rest else "rocking"
    law = {0: "momentum" if two else "housner", 1: "modified", 2: "constant"}[int(p["restitution.law"])]
    summary: dict[str, Any] = {
        "scene": scene.name,
        "blocks": int(p.get("nBlocks", 1)),
        "sizes": block_sizes(p),
        "alpha_rad": alpha,
        "p_rad_per_s": math.sqrt(3 * g / (4 * R)),
        "uplift_threshold_m_s2": g * math.tan(alpha),
        "restitution_law": law,
        "excitation": KIND_NAMES[int(p["excitation.kind"])],
        "stop_time_s": float(result.time[-1]),
        "final_state": state,
        "overturned": overturned,
        "overturn_time_s": float(out["overturnTime"][-1]) if overturned else None,
        "rest_time_s": float(out["restTime"][-1]) if at_rest and out["restTime"][-1] >= 0 else None,
        "impacts": int(out["impacts"][-1]),
        "peaks": int(out["peaks"][-1]),
        "max_abs_theta_rad": float(out["block1.maxAbsTheta"][-1]),
        "max_abs_theta_over_alpha": float(out["block1.maxAbsTheta"][-1]) / alpha,
        "final_theta_rad": float(out["block1.theta"][-1]),
        "final_energy_J": float(out["energy"][-1]),
        "wall_time_s": result.wall_time,
    }
    if shapes.has_outline(p):  # bodies of real shape: their own geometry, per side (runners.engine.shapes)
        summary.update(shape_summary(p))
    support = supports.describe(p)
    if support is not None:
        summary["support"] = support
        if "support.u" in out:
            summary["support_peak_displacement_m"] = float(max(abs(float(u)) for u in out["support.u"]))
        if int(p.get("support.coupling", 0)) == 1 and all(o in out for o in sliding_outputs(p)):
            summary["energy_balance_residual"] = two_way_balance(out, p)
    end = excitation_end(p)
    if end is not None and end <= float(result.time[0]):  # (a negative start time shifted it out of the run)
        summary["excitation_end_s"] = end
    start = float(p.get("excitation.startTime", 0.0))
    if int(p.get("excitation.kind", 0)) != 0 and start >= float(result.time[-1]):  # after the run: never felt
        summary["excitation_start_s"] = start
    sliding = rocking_sliding(p) and all(o in out for o in sliding_outputs(p))  # (a stored subset may lack them)
    if sliding:
        summary.update(sliding_summary(result, p, alpha, two))
        if summary["final_state"] != "overturned":
            summary["final_state"] = summary["final_mode_state"]
        summary.pop("final_mode_state")
    held = assumptions(result, p, two)
    if held is not None:
        summary["assumptions"] = held
    if two:
        threshold, first = uplift_threshold(p)
        summary.update({
            "uplift_threshold_m_s2": threshold,
            "first_pattern": first,
            "final_pattern": PATTERNS.get(int(out["pattern"][-1]), "rocking"),
            "impacts_ground": int(out["impactsGround"][-1]),
            "impacts_interface": int(out["impactsInterface"][-1]),
            "overturned_blocks": [i for i in (1, 2) if out[f"block{i}.overturned"][-1]],
            "max_abs_theta2_rad": float(out["block2.maxAbsTheta"][-1]),
            "final_theta2_rad": float(out["block2.theta"][-1]),
            "peaks": None,
        })
        summary["per_block"] = block_outcomes({name: values[-1] for name, values in out.items()}, p, sliding)
        if sliding and summary["per_block"][1]["fell_off"] and not overturned:
            summary["final_state"] = "block 2 fell off"
    if is_column(p) and all(f"block{k}.maxAbsSlip" in out for k in range(1, summary["blocks"] + 1)):
        summary.update(summary_part({name: values[-1] for name, values in out.items()}, p, result.events))
        summary["overturned_blocks"] = [r["block"] for r in summary["per_block"] if r["overturned"] or r["fell_off"]]
        if "contact_model" in summary:
            summary["mu_interface"] = float(p["contact.muInterface"])
        summary["uplift_threshold_m_s2"], summary["first_pattern"] = uplift_threshold(p)
        if summary["column"]["collapsed"]:
            k = summary["column"]["lowest_fallen"]
            summary["final_state"] = "collapsed"
            summary["collapse"] = f"block {k} " + ("fell off" if summary["per_block"][k - 1]["fell_off"] else "overturned")
    ended = run_end(summary, excitation_end(p) if int(p["excitation.kind"]) else 0.0)  # (a record's end: run_summary)
    if ended is not None:
        summary["run_end"] = ended
    return summary


def block_outcomes(final: dict[str, Any], p: dict[str, Any], sliding: bool) -> list[dict[str, Any]]:
    """Each block's outcome in a stack's run from its final outputs `final`: whether it overturned
    (block 1 takes block 2 with it: both then overturned, ``with_block1``), its peak |theta| (rad,
    absolute, and over its own alpha; None once it overturned: no demand then) and, for a
    rocking-sliding stack (`sliding`), what its contact did (runners.engine.motion.slip_summary:
    block 1 on the ground, block 2 on block 1's top, slips relative to what it stands on, m, +x),
    and for block 2 whether and when it fell off block 1 (s)."""
    from runners.engine.motion import rocked_and_slid, slip_summary

    over_t = float(final["overturnTime"])
    blocks = []
    for i, contact in ((1, "ground"), (2, "block 1")):
        over = bool(final[f"block{i}.overturned"])
        peak = float(final[f"block{i}.maxAbsTheta"])
        alpha = shapes.alpha(p, i)
        b: dict[str, Any] = {"block": i, "stands_on": contact, "overturned": over,
                             "overturn_time_s": over_t if over and over_t >= 0 else None,
                             "with_block1": i == 2 and over and bool(final["block1.overturned"]),
                             "max_abs_theta_rad": peak, "max_abs_theta_over_alpha": None if over else peak / alpha}
        if sliding:
            cols = slip_summary(final, i, stack=True)
            rocked, slid = rocked_and_slid(final, i, stack=True)
            mode = int(final[f"block{i}.mode"])
            b.update(motion=cols["motion"], slid=slid, rocked=rocked, max_abs_slip_m=cols["max_abs_slip"],
                     residual_slip_m=cols["residual_slip"], slide_start_time_s=cols["slide_time"],
                     slide_duration_s=cols["slide_duration"], slide_count=int(final[f"block{i}.slides"]),
                     final_mode=MODES.get(mode, str(mode)), friction_loss_J=float(final[f"block{i}.frictionLoss"]))
            if f"block{i}.flights" in final:  # (its flights: block 1 off the ground, block 2 off block 1)
                b.update(flights=int(final[f"block{i}.flights"]), flight_time_s=float(final[f"block{i}.flightTime"]),
                         max_gap_m=float(final[f"block{i}.maxGap"]))
            if i == 2:
                fell = bool(final["block2.fellOff"])
                t = float(final["block2.fellOffTime"])
                b.update(fell_off=fell, fell_off_time_s=t if fell and t >= 0 else None)
        blocks.append(b)
    return blocks


def rocking_sliding(p: dict[str, Any]) -> bool:
    """Whether FMU parameters `p` select the rocking-sliding model (contact.model = 1)."""
    return int(p.get("contact.model", 0)) == CONTACT_MODELS["rocking-sliding"]


def sliding_summary(result: RunResult, p: dict[str, Any], alpha: float, two: bool = False) -> dict[str, Any]:
    """The sliding facts of a rocking-sliding run (SLIDING_OUTPUTS at its end): slips in m (+x,
    docs/conventions.md), times in s, energies in J; ``motion`` is what the block did (Shenton
    1996's modes and overturning: rests, slides, rocks, slide-rocks, overturns). Of a stack
    (`two`) these are block 1's on the ground (block_outcomes has both blocks'), and the friction
    loss both contacts'. ValueError if the run did not sample SLIDING_OUTPUTS."""
    out = result.outputs
    missing = [o for o in SLIDING_OUTPUTS if o not in out]
    if missing:
        raise ValueError(f"a rocking-sliding run's summary needs {', '.join(missing[:3])}"
                         f"{' ...' if len(missing) > 3 else ''} (run with outputs=SLIDING_OUTPUTS too)")
    from runners.engine.motion import rocked_and_slid, slip_summary

    final = {name: values[-1] for name, values in out.items()}
    cols = slip_summary(final, 1, stack=two)  # the stored columns, as a sweep point stores them
    rocked, slid = rocked_and_slid(final, 1, stack=two)
    mode = int(final["block1.mode"])
    mu_g = mu = float(p["contact.muGround"])
    contacts: dict[str, Any] = {}
    if two:  # the stack slides on the ground as one body beyond muGround g, block 2 on block 1 beyond muInterface g
        mu_i = float(p["contact.muInterface"])
        contacts = {"slide_threshold_contact": "muGround g: the stack on the ground" if mu <= mu_i
                    else "muInterface g: block 2 on block 1", "mu_interface": mu_i}
        mu = min(mu, mu_i)
    return {
        "contact_model": "rocking-sliding",
        "slide_threshold_m_s2": mu * float(p["g"]),
        "mu_ground": mu_g,
        **contacts,
        "motion": cols["motion"],
        "slid": slid,
        "rocked": rocked,
        "max_abs_slip_m": cols["max_abs_slip"],
        "residual_slip_m": cols["residual_slip"],
        "slide_start_time_s": cols["slide_time"],
        "slide_duration_s": cols["slide_duration"],
        "slide_count": int(out["block1.slides"][-1]),
        "final_mode": MODES.get(mode, str(mode)),
        "final_mode_state": MODE_STATES.get(mode, "rocking"),
        "friction_loss_J": float(out["block1.frictionLoss"][-1])
        + (float(out["block2.frictionLoss"][-1]) if two and "block2.frictionLoss" in out else 0.0),
        "impact_loss_J": float(out["impactLoss"][-1]),
        "ground_work_J": float(out["groundWork"][-1]),
        "flights": int(out["block1.flights"][-1]),
        "flight_time_s": float(out["block1.flightTime"][-1]),
        "max_gap_m": float(out["block1.maxGap"][-1]),
        "painleve_points": int(out["contact.painleve"][-1]),
    }


def flight_story(s: dict[str, Any]) -> str:
    """The flights of a rocking-sliding run's summary in plain words ("" if it never left the
    ground), e.g. "flew once: 0.29 s in the air, highest gap 55.3 mm" (times in s, gaps in m)."""
    n = s.get("flights") or 0
    if not n:
        return ""
    times = "once" if n == 1 else f"{n} times"
    return f"flew {times}: {s['flight_time_s']:.3g} s in the air, highest gap {1000 * s['max_gap_m']:.3g} mm"


def sliding_story(s: dict[str, Any]) -> str:
    """The sliding story of a rocking-sliding run's summary, or of one block of a stack
    (block_outcomes: block 2's slips are along block 1's top, relative to it, and it may fall off),
    in plain words, e.g. "slid 0.214 m (peak), residual 0.102 m, never rocked" (slips in m, +x;
    times in s)."""
    peak, residual, duration = s["max_abs_slip_m"], s["residual_slip_m"], s["slide_duration_s"]
    if s.get("fell_off") and not s["overturned"]:
        when = "" if s.get("fell_off_time_s") is None else f" at t = {s['fell_off_time_s']:.4f} s"
        if not s["slid"]:
            return f"fell off block 1{when} (rocking over its edge, never slid)"
        return (f"fell off block 1{when} after sliding {peak:.3g} m (peak slip on it); sliding {duration:.3g} s "
                f"in all, {s['slide_count']} slide{'s' if s['slide_count'] != 1 else ''}")
    if not s["slid"]:
        return "never slid" + ("" if s["rocked"] or s["overturned"] else ", never rocked")
    when = f"from t = {s['slide_start_time_s']:.4f} s" if s["slide_start_time_s"] is not None else "at an impact"
    times = f"{s['slide_count']} slide{'s' if s['slide_count'] != 1 else ''}"
    detail = f"sliding {duration:.3g} s in all, {when}, {times}"
    if s["overturned"]:
        return f"overturned at {s['overturn_time_s']:.4f} s after sliding {peak:.3g} m (peak slip); {detail}"
    if not s["rocked"]:
        return f"slid {peak:.3g} m (peak), residual {residual:.3g} m, never rocked; {detail}"
    return (f"rocked and slid: peak rotation {s['max_abs_theta_rad']:.3g} rad, peak slip {peak:.3g} m, "
            f"residual {residual:.3g} m, {detail}")


def assumptions(result: RunResult, p: dict[str, float], two: bool) -> dict[str, Any] | None:
    """Whether the run kept to rigid rocking: no contact needed more friction than its mu, no
    normal reaction turned tensile (docs/contact.md). None if the run lacks MONITOR_OUTPUTS.
    Demands are |T| / N (1), normal forces over the weight the contact carries (1), times in s."""
    out = result.outputs
    if any(k not in out for k in MONITOR_OUTPUTS):
        return None

    def first(kind: str) -> dict[str, Any] | None:
        ev = next((e for e in result.events if e.kind == kind), None)
        t = float(out[f"{kind}Time"][-1])
        if t < 0:
            return None
        return {"t_s": t, "contact": ev.labels.get("contact", "ground") if ev else "ground",
                "at_impact": bool(ev and ("impulse_demand" in ev.values or "impulse" in ev.values))}

    a: dict[str, Any] = {
        "slides": first("slide"),
        "lifts": first("lift"),
        "mu_ground": float(p["contact.muGround"]),
        "friction_demand_max_ground": float(out["friction.demandMaxGround"][-1]),
        "normal_min_ground": float(out["contact.normalMinGround"][-1]),
        "impulse_demand_max": float(out["friction.impulseDemandMax"][-1]),
    }
    if two:
        a.update({"mu_interface": float(p["contact.muInterface"]),
                  "friction_demand_max_interface": float(out["friction.demandMaxInterface"][-1]),
                  "normal_min_interface": float(out["contact.normalMinInterface"][-1])})
    modelled = rocking_sliding(p)  # sliding is part of the model: only flight is outside it
    if modelled:
        a["sliding_modelled"] = True
    a["held"] = (modelled or a["slides"] is None) and a["lifts"] is None
    fall = float(out["fallTime"][-1])
    a["fall_time_s"] = fall if fall >= 0 else None
    a["outcome_held"] = outcome_held(bool(out["overturned"][-1]), None if modelled else a["slides"] and
                                     a["slides"]["t_s"], a["lifts"] and a["lifts"]["t_s"], a["fall_time_s"])
    return a


def outcome_held(overturned: bool, slide_time: float | None, lift_time: float | None,
                 fall_time: float | None) -> bool:
    """Whether rigid rocking decided the run's outcome: no contact slid or lifted off, or the
    first one did so only during the overturning fall, after ``fall_time`` (the last time every
    block was within its stability limit; the FMU's fallTime). A falling block nearly always
    slides or flies before it lands on its side, and that does not change that it fell.
    Times in s; None for none. Without a fall time an overturned run with a violation counts
    as not held."""
    first = min((t for t in (slide_time, lift_time) if t is not None), default=None)
    if first is None:
        return True
    return overturned and fall_time is not None and first > fall_time


def format_assumptions(a: dict[str, Any]) -> str:
    """One line: whether rigid rocking held, with the margins, or when and where it stopped holding."""
    two = "mu_interface" in a
    if a.get("sliding_modelled"):
        return _rocking_sliding_assumptions(a)
    if a["held"]:
        text = (f"held: no sliding (friction demand at most {a['friction_demand_max_ground']:.3g}, mu "
                f"{a['mu_ground']:g}); no flight (normal force at least {a['normal_min_ground']:.3g} of the weight)")
        if two:
            text += (f"; between the blocks demand {a['friction_demand_max_interface']:.3g} (mu {a['mu_interface']:g}),"
                     f" normal force at least {a['normal_min_interface']:.3g} of block 2's weight")
        return text
    if a.get("outcome_held"):
        return (f"held until the overturning fall (from t = {a['fall_time_s']:.6g} s), which then {violations(a)}: "
                "the block fell either way")
    first = min((a[k]["t_s"] for k in ("slides", "lifts") if a[k] is not None))
    return f"NOT HELD: {violations(a)}: rigid rocking does not describe the motion after t = {first:.6g} s"


def _rocking_sliding_assumptions(a: dict[str, Any]) -> str:
    """format_assumptions of a rocking-sliding run: sliding and flight are part of its model (the contact
    engine, docs/flight.md), one block or a stack; a run the FMU flagged with a lift-off (a build before
    the engine followed a stack's flight) did not hold from there."""
    if a["lifts"] is None:
        text = (f"held: sliding and flight are part of the model (rocking-sliding, {mu_text(a)}; least normal "
                f"force {a['normal_min_ground']:.3g} of the weight")
        if "mu_interface" in a:
            text += f", between the blocks {a['normal_min_interface']:.3g} of block 2's weight"
        return text + ")"
    if a.get("outcome_held"):
        return (f"held until the overturning fall (from t = {a['fall_time_s']:.6g} s), which then {violations(a)}: "
                "the block fell either way")
    return (f"NOT HELD: {violations(a)}: rocking-sliding does not describe the motion after t = "
            f"{a['lifts']['t_s']:.6g} s (flight is outside the model)")


def mu_text(s: dict[str, Any]) -> str:
    """The friction coefficients of a summary (or its assumptions) with ``mu_ground`` and, for a
    stack, ``mu_interface``: "mu 0.5", or "mu 0.5 on the ground, 0.4 between the blocks"."""
    if "mu_interface" not in s:
        return f"mu {s['mu_ground']:g}"
    return f"mu {s['mu_ground']:g} on the ground, {s['mu_interface']:g} between the blocks"


def model_check_line(s: dict[str, Any]) -> str:
    """--method auto's verdict: whether the model it chose (rigid rocking, or rocking-sliding where
    rigid rocking's monitors said the block slid) answers for the scene."""
    a = s["assumptions"]
    if a.get("sliding_modelled"):
        if s["model_sufficient"]:
            return "model check      sufficient: rocking-sliding follows sliding and flight (docs/flight.md)"
        return ("model check      NOT SUFFICIENT: no model here answers for this scene: the block "
                f"{violations(a)}, and flight is outside both rigid rocking and rocking-sliding (docs/contact.md)")
    if s["model_sufficient"]:
        return "model check      sufficient: rigid rocking held until the outcome was decided"
    if a["lifts"] is not None and (a["slides"] is None or a["lifts"]["t_s"] <= a["slides"]["t_s"]):
        need = "flight, which is outside both rigid rocking and rocking-sliding"
    elif s.get("rocking_sliding_refused"):
        need = f"sliding, and rocking-sliding cannot run it: {s['rocking_sliding_refused']}"
    else:
        need = "sliding or flight"
    return ("model check      NOT SUFFICIENT: no model here answers for this scene: rigid rocking's assumptions "
            f"fail ({violations(a)}); it needs {need} (docs/contact.md)")


def violations(a: dict[str, Any]) -> str:
    """What broke the rigid-rocking assumptions, where and when, earliest first ("" if nothing did)."""
    parts = []
    for kind, what in (("slides", "slides"), ("lifts", "lifts off")):
        ev = a[kind]
        if ev is not None and not (kind == "slides" and a.get("sliding_modelled")):
            where = "between the blocks" if ev["contact"] == "interface" else "on the ground"
            text = f"{what} {where} at t = {ev['t_s']:.6g} s{' (at an impact)' if ev['at_impact'] else ''}"
            if kind == "slides":
                c = ev["contact"]
                text += f" (friction demand up to {a[f'friction_demand_max_{c}']:.3g}, mu {a[f'mu_{c}']:g})"
            parts.append((ev["t_s"], text))
    return "; ".join(text for _, text in sorted(parts, key=lambda p: p[0]))


def format_summary(s: dict[str, Any]) -> str:
    """A readable multi-line summary."""
    if "column" in s:
        return _format_column(s)
    if s["blocks"] == 2:
        block = (f"two blocks       uplift at |a_h| > {s['uplift_threshold_m_s2']:.3f} m/s2, "
                 f"then {s['first_pattern']}")
        if "contact_model" in s:
            first = ("the stack slides on the ground first" if s["mu_ground"] <= s["mu_interface"]
                     else "block 2 slides on block 1 first")
            block += f"; sliding at |a_h| > {s['slide_threshold_m_s2']:.3f} m/s2 ({mu_text(s)}: {first})"
    elif "alpha_right_rad" in s:  # one body of real shape: each side its own
        block = (f"body             alpha {s['alpha_right_rad']:.4f} rad onto its right corner, "
                 f"{s['alpha_left_rad']:.4f} rad onto its left; uplift at a_h < -{s['uplift_threshold_right_m_s2']:.3f} "
                 f"m/s2 (right corner) or a_h > {s['uplift_threshold_left_m_s2']:.3f} m/s2 (left)")
    else:
        block = (f"block            alpha = {s['alpha_rad']:.4f} rad, p = {s['p_rad_per_s']:.3f} rad/s, "
                 f"uplift at |a_h| > {s['uplift_threshold_m_s2']:.3f} m/s2")
        if "contact_model" in s:
            block += f", sliding at |a_h| > {s['slide_threshold_m_s2']:.3f} m/s2 (mu g, {mu_text(s)})"
    lines = [
        f"scene            {s['scene']}",
        *size_lines(s),
        *shape_lines(s),
        *([f"model            {s['model']}: {s['model_reason']}"] if "model" in s else []),
        block,
        f"restitution      {s['restitution_law']}",
        f"excitation       {s['excitation']}",
        *([f"support          {s['support']}"] if "support" in s else []),
        *([f"energy balance   residual {s['energy_balance_residual']:.2g} of the energy scale (blocks plus support, "
           "base's frame)"] if "energy_balance_residual" in s else []),
        simulated_line(s),
    ]
    outcome = s["final_state"]
    if s["overturned"]:
        outcome += f" at t = {s['overturn_time_s']:.4f} s"
    elif s["rest_time_s"] is not None:
        outcome += f" since t = {s['rest_time_s']:.4f} s"
    elif s["final_state"] == "at rest" and (s.get("slid") or s.get("rocked") or any(
            b.get("slid") or b.get("rocked") for b in s.get("per_block") or ())):
        pass  # rocking-sliding: it moved, then stopped (the sliding line tells how)
    elif s["final_state"] == "at rest":
        flew = (s.get("assumptions") or {}).get("lifts")
        ended, starts = s.get("excitation_end_s"), s.get("excitation_start_s")
        outcome += (f" (never tipped: the {s['excitation']} ended at t = {ended:.6g} s, before the run started at "
                    "t = 0 s: see [excitation] start_time)" if ended is not None and not flew else
                    f" (never tipped: the {s['excitation']} starts at t = {starts:.6g} s, after the run ended at "
                    f"t = {s['stop_time_s']:g} s: see [excitation] start_time)" if starts is not None and not flew else
                    " (never moved: the excitation stayed below the sliding and uplift thresholds)"
                    if not flew and "contact_model" in s else
                    " (never tipped: the excitation stayed below the uplift threshold)" if not flew else
                    f" (never tipped; from t = {flew['t_s']:.6g} s the ground fell faster than g and the block, "
                    "held to it by the model, would have flown: see assumptions)")
    if s["blocks"] == 2:
        if s["overturned"]:
            fell = s["overturned_blocks"]
            which = ("block 1 (taking block 2 with it)" if fell == [1, 2] and _with_block1(s) else
                     " and ".join(f"block {i}" for i in fell))
            outcome = f"{which} overturned at t = {s['overturn_time_s']:.4f} s"
        elif s["final_state"] == "block 2 fell off":
            t = s["per_block"][1]["fell_off_time_s"]
            outcome = "block 2 fell off block 1" + ("" if t is None else f" at t = {t:.4f} s")
        elif s["final_state"] == "rocking":
            outcome = s["final_pattern"]
        lines += [
            f"outcome          {outcome}",
            f"impacts          {s['impacts_ground']} on the ground, {s['impacts_interface']} between the blocks",
            peak_line(s),
            *block_lines(s),
        ]
        return "\n".join(lines + _assumption_lines(s) + _notes(s))
    lines += [
        f"outcome          {outcome}",
        f"impacts          {s['impacts']}",
        peak_line(s),
        *([f"sliding          {sliding_story(s)}"] if "contact_model" in s else []),
        *([f"flight           {flight_story(s)}"] if flight_story(s) else []),
    ]
    return "\n".join(lines + _assumption_lines(s) + _notes(s))


def _format_column(s: dict[str, Any]) -> str:
    """A column's summary (3 blocks or more): the scene, the run, then its outcome and one row per block."""
    lines = [
        f"scene            {s['scene']}",
        *size_lines(s),
        *shape_lines(s),
        *([f"model            {s['model']}: {s['model_reason']}"] if "model" in s else []),
        f"column           {s['blocks']} blocks, block K on block K - 1; uplift at |a_h| > "
        f"{s['uplift_threshold_m_s2']:.3f} m/s2, then {s['first_pattern']}"
        + (f"; {mu_text(s)}" if "contact_model" in s else "; rigid rocking (contacts that never slip)"),
        f"restitution      {s['restitution_law']}",
        f"excitation       {s['excitation']}",
        *([f"support          {s['support']}"] if "support" in s else []),
        simulated_line(s),
        *format_table(s),
    ]
    return "\n".join(lines + _assumption_lines(s) + _notes(s))


def size_lines(s: dict[str, Any]) -> list[str]:
    """The summary's line of block sizes (full width x height in m, mass in kg), if it has them."""
    sizes = s.get("sizes")
    if not sizes:
        return []
    if len(sizes) > 2 and all((b["width_m"], b["height_m"], b["mass_kg"]) == (sizes[0]["width_m"], sizes[0]["height_m"],
                                                                             sizes[0]["mass_kg"]) for b in sizes):
        b = sizes[0]
        return [f"{'block sizes':<17}{len(sizes)} identical blocks {b['width_m']:g} m x {b['height_m']:g} m, "
                f"{b['mass_kg']:g} kg (width x height, mass)"]
    text = "; ".join(("" if len(sizes) == 1 else f"block {b['block']} ")
                     + f"{b['width_m']:g} m x {b['height_m']:g} m, {b['mass_kg']:g} kg"
                     + (f" (outline of {b['outline_vertices']} vertices)" if b.get("outline_vertices") else "")
                     for b in sizes)
    return [f"{'block size' if len(sizes) == 1 else 'block sizes':<17}{text} (width x height, mass)"]


def shape_lines(s: dict[str, Any]) -> list[str]:
    """The summary's lines of bodies of real shape (shape_summary): each one's centre of mass and inertia,
    alphas and landing angles per side, and for a stack or column each joint's uplift thresholds."""
    lines = []
    for f in s.get("shapes") or ():
        who = "" if s.get("blocks", 1) == 1 else f"block {f['block']}: "
        x, y = (0.0 if abs(v) < 1e-12 * f["height_m"] else v for v in f["centre_m"])  # (a centroid's rounding)
        lines.append(f"{'shape':<17}{who}centre of mass ({x:.4g}, {y:.4g}) m, inertia "
                     f"{f['inertia_kg_m2']:.4g} kg m2 {'(uniform polygon)' if f['uniform'] else '(given)'}; alpha "
                     f"{f['alpha_right_rad']:.4f} rad right, {f['alpha_left_rad']:.4f} left; lands on its side at "
                     f"{f['landing_right_rad']:.4f} rad right, {f['landing_left_rad']:.4f} left")
    if s.get("blocks", 1) > 1:
        for j in s.get("uplift_joints") or ():
            who = "block" if len(j["blocks"]) == 1 else "blocks"
            above = f"{who} {j['blocks'][0]}" + (f"-{j['blocks'][-1]}" if len(j["blocks"]) > 1 else "")
            lines.append(f"{'uplift':<17}{above} on {j['on']}: a_h < -{j['right_m_s2']:.3f} m/s2 onto the right end, "
                         f"a_h > {j['left_m_s2']:.3f} m/s2 onto the left")
    return lines


def simulated_line(s: dict[str, Any]) -> str:
    """The summary's span of time simulated: the span that ran and, when the run ended before its
    stop time (``run_end``: an overturn, a fall, flight) when and why; when the motion ended at rest
    after the excitation, or a record ended before the stop time, when (times in s)."""
    wall = f"in {1e3 * s['wall_time_s']:.1f} ms wall"
    end, stop = s.get("run_end"), s["stop_time_s"]
    if end is not None and end["t_s"] < stop:
        if end["run_ended"]:
            return (f"simulated        0 .. {end['t_s']:.6g} s (of 0 .. {stop:g} s) {wall}: the run ended there, "
                    f"{end['why']}")
        return f"simulated        0 .. {stop:g} s {wall}; the motion ended at t = {end['t_s']:.6g} s, {end['why']}"
    record_end = s.get("record_end_s")
    tail = f"; the record ended at t = {record_end:g} s" if record_end is not None and record_end < stop else ""
    return f"simulated        0 .. {stop:g} s {wall}{tail}"


def run_end(s: dict[str, Any], excitation_end: float | None) -> dict[str, Any] | None:
    """When (``t_s``, s) and why (``why``) the run of summary `s` stopped following the motion
    (``run_ended``: a block overturned and lies on its side, block 2 fell off block 1, for which
    the model has no contact; the outputs keep their values after), or the motion ended at rest after the excitation ended (`excitation_end`, s;
    None while it goes on, 0 for none). None otherwise."""
    column = s.get("column")
    if column is not None and column["collapsed"] and column.get("collapse_time_s") is not None:
        return {"t_s": column["collapse_time_s"], "why": f"{s['collapse']} (the column's run ends at a fall)",
                "run_ended": True}
    if s.get("overturned") and s.get("overturn_time_s") is not None:
        fell = s.get("overturned_blocks") or [1]
        which = ("the block overturned" if s["blocks"] == 1 else "block 1 overturned, taking block 2 with it"
                 if fell == [1, 2] else " and ".join(f"block {i}" for i in fell) + " overturned")
        return {"t_s": s["overturn_time_s"], "why": f"{which} (it lies on its side from then on)", "run_ended": True}
    upper = (s.get("per_block") or [{}, {}])[1]
    if upper.get("fell_off") and upper.get("fell_off_time_s") is not None:
        return {"t_s": upper["fell_off_time_s"], "why": "block 2 fell off block 1 (the model has no contact for it)",
                "run_ended": True}
    rest = s.get("rest_time_s")
    if rest is not None and excitation_end is not None and excitation_end <= rest:
        after = "" if excitation_end <= 0 else f" after the excitation ended at t = {excitation_end:.6g} s"
        return {"t_s": rest, "why": f"at rest{after}", "run_ended": False}
    return None


def run_summary(found, record=None, notes: list[str] | tuple[str, ...] = ()) -> tuple[dict[str, Any], str]:
    """summarise: the summary (what ``runners simulate --json`` prints) and the report (what it
    prints for people) of the answer `found` (runners.engine.least_model.Answer), run on `record`
    (runners.engine.records.SceneRecord, or None), with `notes` on the scene. Units SI."""
    s, p = found.summary, found.parameters
    notes = [*notes, *found.notes]
    s.setdefault("sizes", block_sizes(p))
    if record is not None:
        scale = float(p["excitation.scale"])
        if found.result is not None:
            s.update(record.summary(scale))
        notes += [*record.notes, *record.scaling_notes(scale)]
    if record is not None and found.kind == "fmu":  # the record's end, which summarize does not know
        s["record_end_s"] = float(p.get("excitation.startTime", 0.0)) + record.end
        end = run_end(s, s["record_end_s"])
        if end is not None:
            s["run_end"] = end
    if notes:
        s["notes"] = notes
    return s, _report(found, s)


def _report(found, s: dict[str, Any]) -> str:
    """The report of an answer's summary `s`, in the words of its kind; notes stay in summary["notes"]."""
    if found.kind == "python":
        from runners.engine.python_methods import format_python

        text = format_python(found.scene.name, s, found.scene.stop_time)
    elif found.kind == "closed form":
        from runners.engine.least_model import format_closed_form

        text = format_closed_form(found.scene.name, s["model_reason"], s)
        if "assumptions" in s:
            text += f"\nassumptions      {format_assumptions(s['assumptions'])}"
    else:
        text = format_summary({k: v for k, v in s.items() if k != "notes"})
    if "model_sufficient" in s:  # --method auto: whether the least model holds
        text += "\n" + model_check_line(s)
    return text


def _with_block1(s: dict[str, Any]) -> bool:
    blocks = s.get("per_block")
    return bool(blocks and blocks[1]["with_block1"])


def block_lines(s: dict[str, Any]) -> list[str]:
    """A rocking-sliding stack's summary: one line per block, what it did on what it stands on
    (block 1 on the ground, block 2 on block 1: its slips relative to block 1); none for a rigid stack."""
    return [f"block {b['block']} ({b['motion']}) {'on the ground' if b['block'] == 1 else 'on block 1'}: "
            f"{sliding_story(b)}" + (f"; {flight_story(b)}" if flight_story(b) else "")
            for b in s.get("per_block") or () if "motion" in b]


def peak_line(s: dict[str, Any]) -> str:
    """The summary's peak |theta| line (rad, and over alpha for one block). A block that
    overturned has no peak: its largest angle is where the run stopped following its fall
    (pi/2 or so), not a demand, so the line says when it overturned instead."""
    when = f"overturned at t = {s['overturn_time_s']:.4f} s" if s.get("overturn_time_s") is not None else "overturned"
    if s["blocks"] == 2 and not (s["overturned"] and "overturned_blocks" not in s):  # (which one fell unknown)
        fell = s.get("overturned_blocks") or []
        parts = [f"block {i} " + ("overturned" if i in fell else f"{s[key]:.6f} rad")
                 for i, key in ((1, "max_abs_theta_rad"), (2, "max_abs_theta2_rad"))]
        return f"peak |theta|     {', '.join(parts)}"  # the outcome line says when
    if s["overturned"]:
        return f"peak |theta|     none: {when}"
    over = f" = {s['max_abs_theta_over_alpha']:.4f} alpha" if "max_abs_theta_over_alpha" in s else ""
    return f"peak |theta|     {s['max_abs_theta_rad']:.6f} rad{over}"


def _assumption_lines(s: dict[str, Any]) -> list[str]:
    return [f"assumptions      {format_assumptions(s['assumptions'])}"] if "assumptions" in s else []


def _notes(s: dict[str, Any]) -> list[str]:
    return [f"note             {n}" for n in s.get("notes", ())]


def block_rows(s: dict[str, Any]) -> list[dict[str, Any]] | None:
    """The database's per-block rows (db.schema.RunBlock, without run_id) of a column's summary, None
    for one or two blocks (their run_summaries columns hold them)."""
    if "column" not in s:
        return None
    keys = ("block", "max_abs_theta", "peak_over_alpha", "max_abs_slip", "residual_slip", "overturned", "fell_off",
            "final_mode")
    return [{k: r[k] for k in keys} for r in s["per_block"]]


def summary_row(s: dict[str, Any], p: dict[str, float]) -> dict[str, Any]:
    """The database's run summary (db.schema.RunSummary) from a summary dict of any method."""
    from runners.engine.motion import first_of

    alpha1 = shapes.alpha(p, 1)
    two = s.get("blocks") == 2
    peak1 = s.get("max_abs_theta_rad")
    if peak1 is None and s.get("peak_after_first_impact_rad") is not None:  # closed form
        peak1 = s["peak_after_first_impact_rad"]
    row = {
        "peak1_over_alpha": None if peak1 is None else peak1 / alpha1,
        "peak2_over_alpha": None,
        "overturned": bool(s["overturned"]),
        "overturned_blocks": None,
        "overturn_time": s.get("overturn_time_s"),
        "impacts": s.get("impacts"),
        "impacts_ground": s.get("impacts_ground"),
        "impacts_interface": s.get("impacts_interface"),
        "rest_time": s.get("rest_time_s"),
    }
    a = s.get("assumptions")
    if a is not None:
        row.update(assumptions_held=a["held"], fall_time=a.get("fall_time_s"),
                   slide_time=a["slides"] and a["slides"]["t_s"],
                   lift_time=a["lifts"] and a["lifts"]["t_s"], friction_demand_max=a["friction_demand_max_ground"],
                   normal_min=a["normal_min_ground"], impulse_demand_max=a["impulse_demand_max"],
                   friction_demand_max_interface=a.get("friction_demand_max_interface"),
                   normal_min_interface=a.get("normal_min_interface"))
    if "contact_model" in s:  # rocking-sliding: what the block did, its slip (m) and sliding time (s)
        row.update(motion=s["motion"], max_abs_slip=s["max_abs_slip_m"], residual_slip=s["residual_slip_m"],
                   slide_duration=s["slide_duration_s"], slide_time=s["slide_start_time_s"])
        upper = (s.get("per_block") or [{}, {}])[1]
        if "motion" in upper:  # a stack: block 2 on block 1 (slips relative to it)
            row.update(block2_motion=upper["motion"], block2_max_abs_slip=upper["max_abs_slip_m"],
                       block2_residual_slip=upper["residual_slip_m"], block2_slide_duration=upper["slide_duration_s"],
                       block2_slide_time=upper["slide_start_time_s"], block2_fell_off=upper["fell_off"],
                       block2_fell_off_time=upper["fell_off_time_s"],
                       slide_time=first_of(s["slide_start_time_s"], upper["slide_start_time_s"]))
    if "column" in s:  # a column: block 2's peak, and the column's outcome (each block's: block_rows)
        from runners.engine.column import summary_columns_rows

        alpha2 = shapes.alpha(p, 2)
        row["peak2_over_alpha"] = s["per_block"][1]["max_abs_theta"] / alpha2
        summary_columns_rows(row, s["column"], int(s["blocks"]))
    elif two:
        alpha2 = shapes.alpha(p, 2)
        row["peak2_over_alpha"] = s["max_abs_theta2_rad"] / alpha2
        blocks = s.get("overturned_blocks")
        row["overturned_blocks"] = ",".join(str(i) for i in blocks) if blocks else None
    elif s["overturned"]:
        row["overturned_blocks"] = "1"
    return row
