"""``runners bench --cosim``: the cost and the accuracy of the co-simulated building + blocks
system (examples/cabinet_on_floor.toml, docs/cosimulation.md) against the communication step.

For each step h it measures, in one run: the wall time of the two-way system in fmpy (our master
over fmpy's SSP reader) and in libcosim (its SSP loader); the one-way run's error against the
blocks run alone under the floor's acceleration as a record (the hold's interpolation error); and
the two-way energy residual at the end of the run (the coupling's error measure; its largest value
along a run with impacts is not one, docs/cosimulation.md), of the crate that only slides (no
impact) and of the cabinet that rocks.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from runners.analysis.cosim import energy_balance
from runners.engine import cosim

ROOT = Path(__file__).resolve().parents[2]
STEPS = (2e-3, 1e-3, 5e-4, 2.5e-4)  # s


def _timed(system: cosim.System, engine: str, fmu: Path) -> tuple[float, cosim.CosimResult]:
    t0 = time.perf_counter()
    r = cosim.run(system, engine=engine, block_fmu=fmu)
    return time.perf_counter() - t0, r


def one_way_reference(system: cosim.System):
    """The independent monolithic solution of the example's cabinet on its floor, one-way (model/support_reference.py:
    the building exact inside it), for the one-way runs' error."""
    from model import sliding_reference as slide
    from model import support_reference as ref

    b, blk = system.building, system.blocks
    block = slide.SlidingBlock(b=blk["block1.halfWidth"], h=blk["block1.halfHeight"], m=blk["block1.mass"],
                               mu=blk["contact.muGround"], g=9.81)
    return ref.simulate(block, ref.Building(list(b.mass), list(b.stiffness), b.damping_ratio, system.floor),
                        ref.record_file(system.base_file), system.stop_time or system.default_stop_time,
                        coupling="one-way")


def run_cosim_bench(fmu: Path, steps: tuple[float, ...] = STEPS) -> str:
    """The markdown table of the co-simulation benchmark (one run)."""
    system = cosim.load_system(ROOT / "examples" / "cabinet_on_floor.toml")
    crate = replace(system, blocks={**system.blocks, "block1.halfWidth": 0.5, "block1.halfHeight": 0.5,
                                    "contact.muGround": 0.3})
    engines = ["fmpy"] + ([] if cosim.libcosim_available() else ["libcosim"])
    exact = one_way_reference(system)
    rows = []
    for h in steps:
        s = replace(system, step=h)
        cost = {}
        for engine in engines:
            cost[engine], r = _timed(s, engine, fmu)
        cabinet = energy_balance(r)
        r1 = cosim.run(replace(s, coupling="one-way"), block_fmu=fmu)
        err = float(np.max(np.abs(exact.sample(r1.time)["theta"] - r1["block.block1.theta"])))
        slides = energy_balance(cosim.run(replace(crate, step=h), block_fmu=fmu))
        libcosim = f"{cost['libcosim']:.2f} | {cost['libcosim'] / cost['fmpy']:.2f}" if "libcosim" in cost else "- | -"
        rows.append(f"| {1000 * h:g} | {cosim.n_steps(s)} | {cost['fmpy']:.2f} | {libcosim} | {err:.2e} | "
                    f"{100 * slides.relative_end:.2f} % | {100 * cabinet.relative_end:.2f} % |")
    head = ["## Co-simulation: the building and the cabinet against the communication step", "",
            f"    runners bench --cosim   # {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, one run", "",
            "| h (ms) | steps | two-way, fmpy (s) | two-way, libcosim (s) | libcosim / fmpy | one-way: max theta "
            "error against the monolithic reference (rad) | energy residual at the end, crate that slides (of the energy scale) "
            "| energy residual at the end, cabinet that rocks |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    return "\n".join(head + rows) + "\n"
