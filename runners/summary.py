"""Summarise a run of RockingBlock.fmu for people (text) and programs (JSON)."""

from __future__ import annotations

import math
from typing import Any

from runners.fmu import RunResult
from runners.scene import KINDS, LAWS, Scene

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
)


def summarize(scene: Scene, result: RunResult, defaults: dict[str, float]) -> dict[str, Any]:
    """Key facts of a run; ``defaults`` are the FMU's start values."""
    p = {**defaults, **scene.parameters}
    b, h, g = p["block1.halfWidth"], p["block1.halfHeight"], p["g"]
    alpha = math.atan2(b, h)
    R = math.hypot(b, h)
    out = result.outputs
    overturned = bool(out["overturned"][-1])
    at_rest = bool(out["atRest"][-1])
    state = "overturned" if overturned else "at rest" if at_rest else "rocking"
    return {
        "scene": scene.name,
        "alpha_rad": alpha,
        "p_rad_per_s": math.sqrt(3 * g / (4 * R)),
        "uplift_threshold_m_s2": g * math.tan(alpha),
        "restitution_law": {v: k for k, v in LAWS.items()}[int(p["restitution.law"])],
        "excitation": {v: k for k, v in KINDS.items()}[int(p["excitation.kind"])],
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


def format_summary(s: dict[str, Any]) -> str:
    """A readable multi-line summary."""
    lines = [
        f"scene            {s['scene']}",
        f"block            alpha = {s['alpha_rad']:.4f} rad, p = {s['p_rad_per_s']:.3f} rad/s, "
        f"uplift at |a_h| > {s['uplift_threshold_m_s2']:.3f} m/s2",
        f"restitution      {s['restitution_law']}",
        f"excitation       {s['excitation']}",
        f"simulated        0 .. {s['stop_time_s']:g} s in {1e3 * s['wall_time_s']:.1f} ms wall",
    ]
    outcome = s["final_state"]
    if s["overturned"]:
        outcome += f" at t = {s['overturn_time_s']:.4f} s"
    elif s["rest_time_s"] is not None:
        outcome += f" since t = {s['rest_time_s']:.4f} s"
    elif s["final_state"] == "at rest":
        outcome += " (never lifted: the excitation stayed below the uplift threshold)"
    lines += [
        f"outcome          {outcome}",
        f"impacts          {s['impacts']}",
        f"peak |theta|     {s['max_abs_theta_rad']:.6f} rad = {s['max_abs_theta_over_alpha']:.4f} alpha",
    ]
    return "\n".join(lines)
