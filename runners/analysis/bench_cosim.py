"""``runners bench --cosim``: the cost and the accuracy of the co-simulated building + blocks
system (examples/cabinet_on_floor.toml, docs/cosimulation.md) against the communication step.

For each step h it measures, in one run and side by side: two-way, the wall time and the error against the
independent monolithic solution (model/support_reference.py) of three masters over the same SSP, held inputs
(libcosim's algorithm, the first-order run this project had before), the default (the blocks' floor's mass in their
FMU, its force extrapolated, their load a line over each step) and iterated, and libcosim's wall time; one-way, the
rotation's error against the monolithic solution; and the energy residual at the end of the crate that only slides.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from runners.analysis.cosim import energy_balance
from runners.engine import cosim

ROOT = Path(__file__).resolve().parents[2]
STEPS = (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4)  # s
MASTERS = {"held": {"interpolate": False}, "default": {}, "iterated": {"iterate": True}}


def _timed(system: cosim.System, fmu: Path, engine: str = "fmpy", **kw) -> tuple[float, cosim.CosimResult]:
    t0 = time.perf_counter()
    r = cosim.run(system, engine=engine, block_fmu=fmu, **kw)
    return time.perf_counter() - t0, r


def reference(system: cosim.System, coupling: str):
    """The independent monolithic solution of the example's cabinet on its floor (model/support_reference.py: the
    building exact inside it), one-way or two-way."""
    from model import sliding_reference as slide
    from model import support_reference as ref

    b, blk = system.building, system.blocks
    block = slide.SlidingBlock(b=blk["block1.halfWidth"], h=blk["block1.halfHeight"], m=blk["block1.mass"],
                               mu=blk["contact.muGround"], g=9.81)
    return ref.simulate(block, ref.Building(list(b.mass), list(b.stiffness), b.damping_ratio, system.floor),
                        ref.record_file(system.base_file), system.stop_time or system.default_stop_time,
                        coupling=coupling)




def run_cosim_bench(fmu: Path, steps: tuple[float, ...] = STEPS) -> str:
    """The markdown tables of the co-simulation benchmark (one run)."""
    system = cosim.load_system(ROOT / "examples" / "cabinet_on_floor.toml")
    crate = replace(system, blocks={**system.blocks, "block1.halfWidth": 0.5, "block1.halfHeight": 0.5,
                                    "contact.muGround": 0.3})
    exact, exact1 = reference(system, "two-way"), reference(system, "one-way")
    libcosim = cosim.libcosim_available() is None
    two, one = [], []
    for h in steps:
        s = replace(system, step=h)
        cells, wall = [], {}
        for name, kw in MASTERS.items():
            wall[name], r = _timed(s, fmu, **kw)
            peak = abs(r["block.block1.maxAbsTheta"][-1] - exact.peak_abs_theta)
            slip = abs(r["block.block1.slip"][-1] - exact.final_slip)
            cells.append(f"{peak:.2g} | {slip:.2g} | {100 * energy_balance(r).relative_end:.2g} % | "
                         f"{int(r['block.impacts'][-1])} | {wall[name]:.2f}")
            if name == "iterated":
                cells[-1] += f" | {r.passes / len(r.time):.2f}"
        lib = f"{_timed(s, fmu, 'libcosim')[0]:.2f}" if libcosim else "-"
        two.append(f"| {1000 * h:g} | " + " | ".join(cells) + f" | {wall['default'] / wall['held']:.2f} | {lib} |")
        r1 = cosim.run(replace(s, coupling="one-way"), block_fmu=fmu)
        err = float(np.max(np.abs(exact1.sample(r1.time)["theta"] - r1["block.block1.theta"])))
        slides = {name: energy_balance(cosim.run(replace(crate, step=h), block_fmu=fmu, **kw)).relative_end
                  for name, kw in MASTERS.items() if name != "iterated"}
        one.append(f"| {1000 * h:g} | {cosim.n_steps(s)} | {err:.2e} | {100 * slides['held']:.2g} % | "
                   f"{100 * slides['default']:.2g} % |")
    when = time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())
    head = ["## Co-simulation: the building and the cabinet against the communication step", "",
            f"    runners bench --cosim   # {when}, one run", "",
            f"Two-way, against the monolithic solution (exact: {exact.impacts} impacts, peak |theta| "
            f"{exact.peak_abs_theta:.6g} rad, slip at the end {exact.final_slip:.3g} m). Each master: peak |theta| "
            "error (rad), final slip error (m), energy residual at the end (of its scale), impacts, wall (s); the "
            "iterated one's passes a step; the default's wall over the held one's; libcosim's wall (s).", "",
            "| h (ms) | held: peak | slip | energy | impacts | wall | default: peak | slip | energy | impacts | wall "
            "| iterated: peak | slip | energy | impacts | wall | passes | default / held | libcosim |",
            "|---:" * 19 + "|"]
    tail = ["", "One-way, and the crate that only slides (two-way, no impact):", "",
            "| h (ms) | steps | one-way: max theta error against the monolithic solution (rad) | crate, held: energy "
            "residual at the end | crate, default |", "|---:|---:|---:|---:|---:|"]
    return "\n".join(head + two + tail + one) + "\n"
