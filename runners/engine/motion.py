"""What a block does in a rocking–sliding run (contact.model = 1, docs/contact.md and, for a
stack, docs/stack_sliding.md): its motion class, from the FMU's outputs at the end of the run.

The classes are Shenton (1996)'s modes of a rigid block on a base with Coulomb friction, plus
overturning: ``rests`` (never moved), ``slides`` (slid, never rocked), ``rocks`` (rocked, never
slid), ``slide-rocks`` (both sliding and rocking happened, at once or one after the other) and
``overturns``; the upper block of a stack may also ``falls-off`` (its base left block 1's top,
block2.fellOff). Each block of a stack has its own class and slips at its own contact: block 1
on the ground (block1.*), block 2 on block 1's top (block2.*, relative to block 1). Sweeps store
the classes of each point (run_summaries.motion, block2_motion), maps draw block 1's (runners
map --by mode) and fragility and IDA take each block's peak slip as a demand.

Units SI: slips in m (positive +x, docs/conventions.md), times in s.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

# contact.model (the FMU's Enumeration ContactModel) by the names a scene or a grid spells
CONTACT_MODELS = {"rigid-rocking": 0, "rocking-sliding": 1}
ROCKING_SLIDING = 1

# the motion classes, in the order of the maps' colours and legends
MOTIONS = ["rests", "slides", "rocks", "slide-rocks", "overturns"]
FALLS_OFF = "falls-off"  # the upper block of a stack whose base left block 1's top (block2.fellOff)

# the FMU outputs a sweep reads at the end of a rocking–sliding point (of one contact: block i's)
SLIP_OUTPUTS = ["block1.slip", "block1.maxAbsSlip", "block1.slideDuration", "block1.slideStartTime",
                "block1.slides"]
# and those a rocking–sliding stack adds: block 2's contact with block 1, its falling off, and
# block 2's mode and both rotations at the end (whether it was still rocking on block 1)
STACK_SLIP_OUTPUTS = [name.replace("block1.", "block2.") for name in SLIP_OUTPUTS] + [
    "block2.fellOff", "block2.fellOffTime", "block2.mode", "block1.theta", "block2.theta"]


def rocking_sliding(p: Mapping[str, Any]) -> bool:
    """Whether FMU parameters `p` (defaults included) select the rocking–sliding model."""
    return int(p.get("contact.model", 0) or 0) == ROCKING_SLIDING


def motion_class(out: Mapping[str, Any], block: int = 1, stack: bool = False) -> str:
    """The motion class (one of MOTIONS, or FALLS_OFF for block 2) of block `block` (1 or 2) of a
    rocking–sliding run from its final FMU outputs.

    - ``overturns``: the block overturned (``overturned`` for one block; ``block{i}.overturned``
      for a stack, where block 1 overturning takes block 2 with it: both flags true);
    - ``falls-off`` (block 2 only): ``block2.fellOff``, its base left block 1's top without
      overturning;
    - otherwise the block *slid* when its contact ever left stick: ``block{i}.slides``
      (stick-to-slip transitions) > 0, or ``block{i}.slideDuration`` > 0 s, or
      ``block{i}.slideStartTime`` >= 0 s (a slip rate left by a sliding impact counts too);
    - it *rocked* when it ever rotated on its contact: block 1 when ``block1.maxAbsTheta`` > 0 rad
      (a block at rest or sliding flat keeps theta exactly 0); block 2 of a stack when it rocked
      on block 1, which every rock on block 1 ends with an impact on the interface
      (``impactsInterface`` > 0) unless the run ended while it rocked (``block2.mode`` 2 or 3, or
      a rotation relative to block 1 left at the end, ``block2.theta`` != ``block1.theta``: a run
      that ended in flight); a block 2 that never left block 1's top keeps exactly theta1;
    - ``slide-rocks`` when both, ``slides`` when it slid only, ``rocks`` when it rocked only,
      ``rests`` when neither (its base never moved relative to what it stands on).

    `out` maps output names to values (bools and ints as the FMU gives them, or floats); `stack`:
    the run is a stack's (block 2 implies it)."""
    if block not in (1, 2):
        raise ValueError(f"block {block!r}: expected 1 or 2")
    stack = stack or block == 2
    if bool(out[f"block{block}.overturned"] if stack else out["overturned"]):
        return "overturns"
    if block == 2 and bool(out.get("block2.fellOff", False)):
        return FALLS_OFF
    rocked, slid = rocked_and_slid(out, block, stack)
    if slid and rocked:
        return "slide-rocks"
    if slid:
        return "slides"
    return "rocks" if rocked else "rests"


def rocked_and_slid(out: Mapping[str, Any], block: int = 1, stack: bool = False) -> tuple[bool, bool]:
    """(rocked, slid) of block `block` of a rocking–sliding run from its final FMU outputs (see
    motion_class)."""
    b = f"block{block}."
    start = float(out.get(b + "slideStartTime", -1.0))
    slid = (int(out.get(b + "slides", 0)) > 0 or float(out.get(b + "slideDuration", 0.0)) > 0.0
            or (math.isfinite(start) and start >= 0.0))
    if block == 1:
        impacts = "impactsGround" if stack else "impacts"
        rocked = float(out["block1.maxAbsTheta"]) > 0.0 or int(out.get(impacts, 0)) > 0
    else:
        rocked = (int(out.get("impactsInterface", 0)) > 0 or int(out.get("block2.mode", 0)) in (2, 3)
                  or float(out.get("block2.theta", 0.0)) != float(out.get("block1.theta", 0.0)))
    return rocked, slid


def slip_summary(out: Mapping[str, Any], block: int = 1, stack: bool = False) -> dict[str, Any]:
    """The rocking–sliding columns of block `block`'s contact in a run's summary
    (db.schema.RunSummary) from its final FMU outputs: motion (motion_class), max_abs_slip (m,
    peak |block{i}.slip|), residual_slip (m, block{i}.slip at the end, signed +x; block 2's along
    block 1's top, relative to it), slide_duration (s, time spent in Slide and SlideRock), and
    slide_time (s, the first slide, block{i}.slideStartTime; None if it never slid)."""
    b = f"block{block}."
    start = float(out[b + "slideStartTime"])
    return {"motion": motion_class(out, block, stack), "max_abs_slip": float(out[b + "maxAbsSlip"]),
            "residual_slip": float(out[b + "slip"]), "slide_duration": float(out[b + "slideDuration"]),
            "slide_time": start if start >= 0 else None}


def stack_slip_summary(out: Mapping[str, Any]) -> dict[str, Any]:
    """The rocking–sliding columns of a stack's run summary (db.schema.RunSummary) from its final
    FMU outputs: block 1's as slip_summary (motion, max_abs_slip, residual_slip, slide_duration),
    slide_time (s, the first slide at either contact, as the stack's slideTime), block 2's contact
    with block 1 as block2_motion, block2_max_abs_slip (m), block2_residual_slip (m, relative to
    block 1), block2_slide_duration (s), block2_slide_time (s, None: never), and block2_fell_off
    (bool), block2_fell_off_time (s, None: never)."""
    row = slip_summary(out, 1, stack=True)
    row.update({f"block2_{k}": v for k, v in slip_summary(out, 2, stack=True).items()})
    row["slide_time"] = first_of(row["slide_time"], row["block2_slide_time"])  # the first slide at either contact
    fell = bool(out["block2.fellOff"])
    t = float(out["block2.fellOffTime"])
    row.update(block2_fell_off=fell, block2_fell_off_time=t if fell and t >= 0 else None)
    return row


def first_of(*times: float | None) -> float | None:
    """The earliest of `times` (s) that is not None; None if all are."""
    return min((t for t in times if t is not None), default=None)


def contact_model_value(value: Any) -> int:
    """contact.model from a number (0 or 1) or a name (rigid-rocking, rocking-sliding; case and
    '_' / '–' for '-' ignored); ValueError in one line otherwise."""
    if isinstance(value, str):
        key = value.strip().lower().replace("_", "-").replace("\u2013", "-").replace(" ", "-")
        if key in CONTACT_MODELS:
            return CONTACT_MODELS[key]
        try:
            value = float(key)
        except ValueError:
            raise ValueError(f"contact.model {value!r}: expected rigid-rocking (0) or rocking-sliding (1)") from None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value not in (0, 1):
        raise ValueError(f"contact.model {value!r}: expected rigid-rocking (0) or rocking-sliding (1)")
    return int(value)
