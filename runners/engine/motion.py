"""What a block does in a rocking–sliding run (contact.model = 1, docs/contact.md): its motion
class, from the FMU's outputs at the end of the run.

The classes are Shenton (1996)'s modes of a rigid block on a base with Coulomb friction, plus
overturning: ``rests`` (never moved), ``slides`` (slid, never rocked), ``rocks`` (rocked, never
slid), ``slide-rocks`` (both sliding and rocking happened, at once or one after the other) and
``overturns``. Sweeps store the class of each point (run_summaries.motion), maps draw it
(runners map --by mode) and fragility and IDA take the peak slip as a demand.

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

# the FMU outputs a sweep reads at the end of a rocking–sliding point
SLIP_OUTPUTS = ["block1.slip", "block1.maxAbsSlip", "block1.slideDuration", "block1.slideStartTime",
                "block1.slides"]


def rocking_sliding(p: Mapping[str, Any]) -> bool:
    """Whether FMU parameters `p` (defaults included) select the rocking–sliding model."""
    return int(p.get("contact.model", 0) or 0) == ROCKING_SLIDING


def motion_class(out: Mapping[str, Any]) -> str:
    """The motion class (one of MOTIONS) of a rocking–sliding run from its final FMU outputs.

    - ``overturns``: ``overturned`` is true (whatever happened before);
    - otherwise the block *slid* when it ever left stick: ``block1.slides`` (stick-to-slip
      transitions) > 0, or ``block1.slideDuration`` > 0 s, or ``block1.slideStartTime`` >= 0 s
      (a slip rate left by a sliding impact counts too);
    - it *rocked* when it ever rotated: ``block1.maxAbsTheta`` > 0 rad (a block at rest or
      sliding flat keeps theta exactly 0; ``impacts`` > 0 implies it rocked as well);
    - ``slide-rocks`` when both, ``slides`` when it slid only, ``rocks`` when it rocked only,
      ``rests`` when neither (the base never moved relative to the ground).

    `out` maps output names to values (bools and ints as the FMU gives them, or floats)."""
    if bool(out["overturned"]):
        return "overturns"
    rocked, slid = rocked_and_slid(out)
    if slid and rocked:
        return "slide-rocks"
    if slid:
        return "slides"
    return "rocks" if rocked else "rests"


def rocked_and_slid(out: Mapping[str, Any]) -> tuple[bool, bool]:
    """(rocked, slid) of a rocking–sliding run from its final FMU outputs (see motion_class)."""
    start = float(out.get("block1.slideStartTime", -1.0))
    slid = (int(out.get("block1.slides", 0)) > 0 or float(out.get("block1.slideDuration", 0.0)) > 0.0
            or (math.isfinite(start) and start >= 0.0))
    rocked = float(out["block1.maxAbsTheta"]) > 0.0 or int(out.get("impacts", 0)) > 0
    return rocked, slid


def slip_summary(out: Mapping[str, Any]) -> dict[str, Any]:
    """The rocking–sliding columns of a run's summary (db.schema.RunSummary) from its final FMU
    outputs: motion (motion_class), max_abs_slip (m, peak |block1.slip|), residual_slip (m,
    block1.slip at the end, signed +x), slide_duration (s, time spent in Slide and SlideRock),
    and slide_time (s, the first slide, block1.slideStartTime; None if it never slid)."""
    start = float(out["block1.slideStartTime"])
    return {"motion": motion_class(out), "max_abs_slip": float(out["block1.maxAbsSlip"]),
            "residual_slip": float(out["block1.slip"]), "slide_duration": float(out["block1.slideDuration"]),
            "slide_time": start if start >= 0 else None}


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
