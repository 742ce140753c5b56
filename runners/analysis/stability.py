"""Stability chart: does each method get the outcome right on scenes of rising difficulty?

Scenes (one block, h/b = 3): a one-sine pulse just below and just above the
smallest overturning amplitude (1% either side, found with the reference),
free rocking that ends after many small impacts, and a pulse run by the FMU
with a communication step longer than the pulse. The reference is scipy's
DOP853 at rtol 1e-12 (model/solvers.py), independent of the FMU. A method
gets a scene right if it agrees on overturning, on the number of impacts and
on the largest |theta| within 1% (if it does not overturn). The two-block
scene (Anagnostopoulos Fig. 15's same-direction tilts, which chatter and lock) is
checked against the two-block reference (model/two_block_solver.py at rtol
1e-12) on the impacts of both contacts and the largest |theta1|; the
fixed-step methods exist for one block only.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from model import two_blocks as tb
from model.reference import Block
from model.solvers import Scene, sine_pulse, solve_event_driven, solve_fixed_step
from model.two_block_solver import StackScene, solve_stack
from runners.engine.fmu import RockingFMU

BLOCK = Block(0.1, 0.3)
ETA = 0.85
FREQ = 2.0  # Hz, of the pulses
T_END = 8.0


@dataclass
class Outcome:
    overturned: bool
    impacts: int
    max_abs_theta: float


STACK = tb.Stack(0.1, 0.3, 10.0, 0.1, 0.2, 5.0)
STACK_SCENE = StackScene(STACK, theta0=(0.03, 0.09))
STACK_PARAMS = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
                "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0,
                "block1.theta0": 0.03, "block2.theta0": 0.09, "restitution.law": 0}


def reference(scene) -> Outcome:
    if isinstance(scene, StackScene):
        s = solve_stack(scene, T_END, "DOP853", 1e-12, 1e-14)
        return Outcome(any(s.overturned), len(s.impacts()), s.max_abs_theta[0])
    s = solve_event_driven(scene, T_END, "DOP853", 1e-12, 1e-14)
    return Outcome(s.overturned, len(s.impact_times), s.max_abs_theta)


def pulse_scene(amplitude: float) -> tuple[Scene, dict]:
    ground, breaks = sine_pulse(amplitude, FREQ)
    return (Scene(BLOCK, ETA, ground=ground, breaks=breaks),
            {"excitation.kind": 1, "excitation.amplitude": amplitude, "excitation.frequency": FREQ})


def critical_amplitude() -> float:
    """Smallest overturning amplitude of the pulse (m/s^2), by bisection on the reference."""
    lo, hi = 1.05 * BLOCK.g * math.tan(BLOCK.alpha), 40.0
    while hi / lo - 1 > 1e-4:
        mid = math.sqrt(lo * hi)
        if reference(pulse_scene(mid)[0]).overturned:
            hi = mid
        else:
            lo = mid
    return hi


def free_rocking_scene() -> tuple[str, Scene, dict, float]:
    """Free rocking from 0.6 alpha with eta 0.95, to rest after many small impacts."""
    theta0 = 0.6 * BLOCK.alpha
    return ("free rocking to rest (eta 0.95)", Scene(BLOCK, 0.95, theta0=theta0),
            {"block1.theta0": theta0, "restitution.eta": 0.95}, 0.01)


def scenes() -> list[tuple[str, Scene, dict, float]]:
    """(name, scene, FMU parameters, FMU communication step)."""
    a_c = critical_amplitude()
    below, p_below = pulse_scene(0.99 * a_c)
    above, p_above = pulse_scene(1.01 * a_c)
    return [
        ("pulse 1% below overturning", below, p_below, 0.01),
        ("pulse 1% above overturning", above, p_above, 0.01),
        free_rocking_scene(),
        ("pulse below, communication step 2 s", below, p_below, 2.0),
        ("two blocks chattering, then locked", STACK_SCENE, STACK_PARAMS, 0.01),
    ]


THETA_TOLERANCE = 0.01  # relative, on the largest |theta| of a block that does not overturn
REFERENCE = "scipy DOP853 at rtol 1e-12"
CRITERION = (f"right (green): the same outcome as the reference ({REFERENCE}): overturns or not as it does, "
             f"the same number of impacts and, if the block stands,\nthe largest |theta| within "
             f"{100 * THETA_TOLERANCE:g}% of the reference's. Wrong (red): any of the three differs (the cell says "
             "which). Grey: does not apply (communication steps\nconcern the FMU only; the fixed-step methods and "
             "the Taylor-series integrator are one-block methods)")


def right(got: Outcome, ref: Outcome) -> bool:
    """Same overturning, same impacts and, if it survives, the same largest |theta| within
    THETA_TOLERANCE (1%)."""
    if got.overturned != ref.overturned or got.impacts != ref.impacts:
        return False
    return ref.overturned or abs(got.max_abs_theta / ref.max_abs_theta - 1) < THETA_TOLERANCE


METHODS = [("FMU", {"rtol": r}) for r in (1e-4, 1e-6, 1e-10)] + \
          [("FMU Taylor", {"rtol": r}) for r in (1e-6, 1e-10)] + \
          [("scipy DOP853", {"rtol": r}) for r in (1e-4, 1e-8)] + \
          [("RK4 sign change", {"h": h}) for h in (1e-3, 1e-4)] + \
          [("RK4 located", {"h": h}) for h in (1e-2, 1e-3)] + \
          [("Newmark located", {"h": h}) for h in (1e-2, 1e-3)] + \
          [("Euler sign change", {"h": 1e-4})]


def run_method(fmu: RockingFMU, method: str, setting: dict, scene: Scene, params: dict, step: float) -> Outcome | None:
    """The outcome of one method on one scene; None where the scene does not apply to it."""
    if method.startswith("FMU"):
        if method == "FMU Taylor" and isinstance(scene, StackScene):
            return None  # the Taylor-series integrator is a one-block integrator
        one = {} if isinstance(scene, StackScene) else {
            "block1.halfWidth": BLOCK.b, "block1.halfHeight": BLOCK.h, "restitution.law": 2, "restitution.eta": ETA,
            "solver.method": 1 if method == "FMU Taylor" else 0}
        p = {**one, **params, "solver.relTol": setting["rtol"], "solver.absTol": 1e-2 * setting["rtol"]}
        r = fmu.run(p, T_END, step, outputs=["overturned", "impacts", "block1.maxAbsTheta"], events=False)
        return Outcome(bool(r.outputs["overturned"][-1]), int(r.outputs["impacts"][-1]),
                       float(r.outputs["block1.maxAbsTheta"][-1]))
    if step > 1.0:
        return None  # communication steps concern the FMU only
    if isinstance(scene, StackScene):
        if method != "scipy DOP853":
            return None  # the fixed-step methods are one-block methods
        s = solve_stack(scene, T_END, "DOP853", setting["rtol"], 1e-2 * setting["rtol"])
        return Outcome(any(s.overturned), len(s.impacts()), s.max_abs_theta[0])
    if method == "scipy DOP853":
        s = solve_event_driven(scene, T_END, "DOP853", setting["rtol"], 1e-2 * setting["rtol"])
    else:
        kind, locate = {"RK4 sign change": ("rk4", False), "RK4 located": ("rk4", True),
                        "Newmark located": ("newmark", True), "Euler sign change": ("euler", False)}[method]
        s = solve_fixed_step(scene, T_END, kind, setting["h"], locate)
    return Outcome(s.overturned, len(s.impact_times), s.max_abs_theta)


def compute(fmu_path: Path, methods=None, cases=None) -> tuple[list[dict], list[str], list[Outcome]]:
    """The outcome of every method (default METHODS) on every scene (default scenes()) against the
    reference: (rows, scene names, reference outcomes)."""
    cases = scenes() if cases is None else cases
    refs = [reference(sc) for _, sc, _, _ in cases]
    rows = []
    with RockingFMU(fmu_path) as fmu:
        for method, setting in METHODS if methods is None else methods:
            label = f"{method} " + ", ".join(f"{k} {v:g}" for k, v in setting.items())
            for (name, sc, params, step), ref in zip(cases, refs):
                got = run_method(fmu, method, setting, sc, params, step)
                rows.append({"method": label, "scene": name,
                             "right": None if got is None else right(got, ref),
                             "impacts": None if got is None else got.impacts, "reference_impacts": ref.impacts,
                             "overturned": None if got is None else got.overturned,
                             "reference_overturned": ref.overturned,
                             "max_abs_theta_error": None if got is None else
                             abs(got.max_abs_theta / ref.max_abs_theta - 1)})
    return rows, [c[0] for c in cases], refs


def run_stability(fmu_path: Path, out_dir: Path) -> str:
    """Write stability.png and .csv to out_dir; return a Markdown table."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows, names, refs = compute(fmu_path)
    with open(out_dir / "stability.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    draw(rows, names, out_dir / "stability.png")
    labels = list(dict.fromkeys(r["method"] for r in rows))
    lines = ["| method | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for lab in labels:
        cells = []
        for n in names:
            r = next(x for x in rows if x["method"] == lab and x["scene"] == n)
            cells.append("n/a" if r["right"] is None else
                         ("right" if r["right"] else "**wrong**") + f" ({r['impacts']} impacts"
                         + (", overturned" if r["overturned"] else
                            f", max theta off by {100 * r['max_abs_theta_error']:.1f}%") + ")")
        lines.append(f"| {lab} | " + " | ".join(cells) + " |")
    ref_line = f"reference ({REFERENCE}): " + "; ".join(
        f"{n}: {r.impacts} impacts" + (", overturned" if r.overturned else "") for n, r in zip(names, refs))
    return "\n".join(lines + ["", ref_line, f"written: {out_dir}/stability.png, .csv"])


RIGHT, WRONG, NOT_APPLICABLE, REFERENCE_COLOUR = "#b8e0b0", "#f2a6a6", "#eeeeee", "#d9e6f2"


def _why_wrong(r: dict) -> str:
    """What differs from the reference, shortly, for a red cell."""
    if r["overturned"] != r["reference_overturned"]:
        return "overturns, ref. stands" if r["overturned"] else "stands, ref. overturns"
    if r["impacts"] != r["reference_impacts"]:
        return f"ref. {r['reference_impacts']} impacts"
    return f"|theta| max off {100 * r['max_abs_theta_error']:.1f}%"


def stability_figure(rows: list[dict], names: list[str]):
    """The chart as a matplotlib Figure: one row per method and one column per scene, green where
    the method gets the scene right (CRITERION), red where not, with the reference's outcome in
    the top row and the criterion under the grid."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Rectangle

    labels = list(dict.fromkeys(r["method"] for r in rows))
    fig, ax = plt.subplots(figsize=(2.3 * len(names) + 3.2, 0.45 * (len(labels) + 1) + 2.6))
    ref_label = f"reference: {REFERENCE}"
    for j, n in enumerate(names):
        r = next(x for x in rows if x["scene"] == n)
        ax.add_patch(Rectangle((j, 0), 1, 1, color=REFERENCE_COLOUR, ec="white"))
        ax.text(j + 0.5, 0.5, f"{r['reference_impacts']}" + (" OT" if r["reference_overturned"] else ""),
                ha="center", va="center", fontsize=8, weight="bold")
    for i, lab in enumerate(labels, start=1):
        for j, n in enumerate(names):
            r = next(x for x in rows if x["method"] == lab and x["scene"] == n)
            colour = NOT_APPLICABLE if r["right"] is None else (RIGHT if r["right"] else WRONG)
            ax.add_patch(Rectangle((j, i), 1, 1, color=colour, ec="white"))
            text = "n/a" if r["right"] is None else f"{r['impacts']}" + (" OT" if r["overturned"] else "")
            if r["right"] is not None and not r["right"]:
                text += f"\n({_why_wrong(r)})"
            ax.text(j + 0.5, i + 0.5, text, ha="center", va="center", fontsize=7 if "\n" in text else 8)
    ax.axhline(1, color="k", lw=1.2)  # the reference row above, the methods below
    ax.set_xlim(0, len(names))
    ax.set_ylim(len(labels) + 1, 0)
    ax.set_xticks([j + 0.5 for j in range(len(names))], names, fontsize=8, rotation=12)
    ax.set_yticks([i + 0.5 for i in range(len(labels) + 1)], [ref_label] + labels, fontsize=8)
    ax.set_title("Does each method get the outcome right? Cells: impacts (OT = overturned)", fontsize=10)
    ax.legend(handles=[Patch(color=RIGHT, label=f"right: overturning, impacts and |theta| max within "
                                                f"{100 * THETA_TOLERANCE:g}% as the reference"),
                       Patch(color=WRONG, label="wrong: one of them differs"),
                       Patch(color=NOT_APPLICABLE, label="does not apply")],
              loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, fontsize=8, frameon=False)
    fig.text(0.01, 0.01, CRITERION, fontsize=7, va="bottom", ha="left", color="0.2")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def draw(rows: list[dict], names: list[str], out: Path) -> Path:
    """Write stability_figure(rows, names) as a PNG."""
    from runners.analysis.plotting import save_png

    return save_png(stability_figure(rows, names), out)
