"""``runners simulate --method scipy|rk4|rk4-located|newmark|euler``: a scene through the
independent Python solvers (model/solvers.py, model/two_block_solver.py) instead of the FMU.

The scene's FMU parameters (defaults included) are turned into the solvers'
scenes here, with the FMU's excitations (model/c/ground.c) written out again in
Python (here and in model/ground_motions.py).
"""

from __future__ import annotations

import math
import sys
from typing import Any

from model import ground_motions as gm
from model import two_blocks as tb
from model.reference import Block
from model.solvers import Scene, solve_event_driven, solve_fixed_step
from model.two_block_solver import StackScene, solve_stack
from runners.engine.scene import restitution
from runners.errors import ArgumentError

FIXED = {"rk4": ("rk4", False), "rk4-located": ("rk4", True), "newmark": ("newmark", True),
         "euler": ("euler", False)}
METHODS = ["scipy", *FIXED]
# scipy's solve_ivp raises a smaller rtol to this with a warning (scipy.integrate._ivp.common)
SCIPY_RTOL_MIN = 100 * sys.float_info.epsilon
MAX_STEPS = 100_000_000  # fixed steps a Python solver may take (about 20 minutes of rk4)


def ground_of(p: dict[str, Any]):
    """(a_h, a_v)(t) of the excitation, and its break points (pulses and records: model.ground_motions)."""
    kind = int(p["excitation.kind"])
    if kind == 0:
        return (lambda t: (0.0, 0.0)), ()
    f, t0 = p["excitation.frequency"], p["excitation.startTime"]
    amp, vert = p["excitation.amplitude"], p["excitation.verticalAmplitude"]
    if kind == 4:
        from runners.engine.record_files import read_record_file

        t, ah, av = read_record_file(p["excitation.file"])
        return gm.record(t, ah, av, p["excitation.scale"], t0)
    if kind == 5:
        return gm.ricker(amp, f, t0, vert)
    if kind == 6:
        return gm.ricker_antisymmetric(amp, f, t0, vert)
    if kind == 7:
        return gm.mp_pulse(amp, f, p["excitation.gamma"], p["excitation.phase"], t0, vert)
    w = 2 * math.pi * f
    cycles = p["excitation.cycles"]
    t1 = math.inf if (kind == 3 and cycles == 0) else t0 + cycles / f
    amp = p["excitation.displacement"] * w * w if kind == 3 else p["excitation.amplitude"]
    vert = p["excitation.verticalAmplitude"]
    wave = {1: math.sin, 2: math.cos, 3: lambda x: -math.sin(x)}[kind]

    def ground(t: float) -> tuple[float, float]:
        if not t0 <= t < t1:
            return 0.0, 0.0
        s = wave(w * (t - t0))
        return amp * s, vert * s

    return ground, tuple(b for b in (t0, t1) if math.isfinite(b))


def run_python(method: str, p: dict[str, Any], stop_time: float, h: float, rtol: float) -> dict[str, Any]:
    """Simulate with a Python method; a summary in the keys of runners.engine.summary where they apply."""
    if method != "scipy" and not (math.isfinite(h) and h > 0):
        raise ValueError(f"--h must be a finite step > 0 s, got {h}")
    if method != "scipy" and stop_time / h > MAX_STEPS:
        raise ValueError(f"--h {h:g} s over {stop_time:g} s is {stop_time / h:.3g} steps, more than the "
                         f"{MAX_STEPS:.0e} a Python solver takes in reasonable time: use a larger --h")
    p_rate = math.sqrt(0.75 * p["g"] / math.hypot(p["block1.halfWidth"], p["block1.halfHeight"]))  # rad/s
    if method != "scipy" and h * p_rate > 0.5:
        raise ValueError(f"--h {h:g} s is more than half the block's time scale 1/p = {1 / p_rate:.3g} s: a fixed "
                         f"step that long cannot follow the rocking (use --h {0.01 / p_rate:.1g} or less)")
    if not (math.isfinite(rtol) and 0 < rtol <= 0.1):  # scipy loops forever on rtol nan or 0
        raise ValueError(f"--rtol {rtol:g} must be a tolerance in (0, 0.1]")
    if method == "scipy" and rtol < SCIPY_RTOL_MIN:  # scipy warns and raises it; with atol 1e-2 rtol it never ends
        raise ArgumentError(f"--rtol {rtol:g} is below what scipy's DOP853 can meet (100 machine epsilons, "
                            f"{SCIPY_RTOL_MIN:.5g}): use --rtol 3e-14 or more")
    ground, breaks = ground_of(p)
    if int(p["nBlocks"]) == 2:
        if method != "scipy":
            raise ValueError(f"--method {method} is a one-block method; two blocks run with --method scipy or fmu")
        law = {0: "momentum", 2: "constant"}.get(int(p["restitution.law"]))
        if law is None:
            raise ValueError("restitution.law = 1 (modified) is defined for one block only")
        st = tb.Stack(p["block1.halfWidth"], p["block1.halfHeight"], p["block1.mass"], p["block2.halfWidth"],
                      p["block2.halfHeight"], p["block2.mass"], p["g"])
        scene = StackScene(st, law, p["restitution.etaGround"], p["restitution.etaInterface"],
                           (p["block1.theta0"], p["block2.theta0"]), (p["block1.omega0"], p["block2.omega0"]),
                           ground, breaks, p["solver.restRatio"])
        s = solve_stack(scene, stop_time, "DOP853", rtol, 1e-2 * rtol)
        overturn = [e.t for e in s.events if e.kind == "overturn"]
        settled = [e.t for e in s.events if e.kind == "settle" and e.pattern == "rest"]
        return {"model": "two blocks, Python event-driven reference (scipy DOP853)", "blocks": 2,
                "final_state": "overturned" if any(s.overturned) else "at rest" if s.pattern == "rest" else "rocking",
                "overturned": any(s.overturned), "overturn_time_s": overturn[0] if overturn else None,
                "rest_time_s": settled[-1] if settled and s.pattern == "rest" else None,
                "impacts": len(s.impacts()), "impacts_ground": len(s.impacts("ground")),
                "impacts_interface": len(s.impacts("interface")), "max_abs_theta_rad": s.max_abs_theta[0],
                "max_abs_theta2_rad": s.max_abs_theta[1], "wall_time_s": s.wall_time}
    blk = Block(p["block1.halfWidth"], p["block1.halfHeight"], p["g"])
    scene = Scene(blk, restitution(p, blk.alpha), p["block1.theta0"], p["block1.omega0"], ground, breaks,
                  p["solver.restRatio"])
    if method == "scipy":
        s = solve_event_driven(scene, stop_time, "DOP853", rtol, 1e-2 * rtol)
        model = f"one block, Python scipy DOP853 event-driven, rtol {rtol:g}"
    else:
        kind, locate = FIXED[method]
        s = solve_fixed_step(scene, stop_time, kind, h, locate)
        model = f"one block, Python {method} with fixed step {h:g} s"
    return {"model": model, "blocks": 1,
            "final_state": "overturned" if s.overturned else "at rest" if s.at_rest else "rocking",
            "overturned": s.overturned, "overturn_time_s": s.overturn_time, "rest_time_s": s.rest_time if s.at_rest else None,
            "impacts": len(s.impact_times), "max_abs_theta_rad": s.max_abs_theta,
            "wall_time_s": s.wall_time}


def format_python(name: str, s: dict[str, Any], stop_time: float) -> str:
    from runners.engine.summary import peak_line, size_lines

    outcome = s["final_state"]
    if s["overturned"]:
        outcome += f" at t = {s['overturn_time_s']:.4f} s"
    elif s["rest_time_s"] is not None:
        outcome += f" since t = {s['rest_time_s']:.4f} s"
    lines = [f"scene            {name}", *size_lines(s), f"model            {s['model']}",
             f"simulated        0 .. {stop_time:g} s in {1e3 * s['wall_time_s']:.1f} ms wall",
             f"outcome          {outcome}"]
    if s["blocks"] == 2:
        lines += [f"impacts          {s['impacts_ground']} on the ground, {s['impacts_interface']} between the blocks",
                  peak_line(s)]
    else:
        lines += [f"impacts          {s['impacts']}", peak_line(s)]
    return "\n".join(lines)
