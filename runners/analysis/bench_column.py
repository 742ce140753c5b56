"""``runners bench --columns``: the cost of a column of drums against its number of drums (1 to 8): whole simulations
of RockingBlock.fmu through the FMI API (the native harness of ``runners bench``, no Python), and the contact engine
alone, from model/c/bench/bench_column.c built with EN_MAX_BODIES = 8 (the engine the white-box check of columns uses,
tests/test_engine_column.py): one evaluation of the column's equations of motion rocking as one (the chain in reduced
coordinates: the work of every integrator step) and one choice of its contact set by the complementarity problem
(Lemke's method on 4 unknowns per drum: the work of a mode change). Microseconds per call, and instructions per call
counted by valgrind where it is installed (exact, unaffected by other work on the machine).
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from runners.analysis.bench import _Custom, _compile_native, cachegrind_instructions

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "model" / "c" / "bench" / "bench_column.c"
COLUMN = ["-DEN_MAX_BODIES=8", "-DNMAX=96", "-DLCP_MAX=48"]
REPS = {"rhs": 200_000, "choose": 20_000}  # calls timed
COUNTED = {"rhs": 2_000, "choose": 200}  # calls counted under valgrind


def _compile(tmp: Path) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise OSError("no C compiler (cc or gcc) found")
    exe = tmp / "bench_column"
    subprocess.run([cc, "-std=c99", "-O3", *COLUMN, "-I", str(ROOT / "model" / "c"), "-o", str(exe), str(SOURCE),
                    str(ROOT / "model" / "c" / "lcp.c"), "-lm"], check=True)
    return exe


def _timed(exe: Path, n: int, op: str, reps: int) -> tuple[float, int]:
    """Microseconds per call (the best of three runs) and the problem's size."""
    best, size = float("inf"), 0
    for _ in range(3):
        out = subprocess.run([str(exe), str(n), op, str(reps)], capture_output=True, text=True, check=True).stdout.split()
        best, size = min(best, float(out[2])), int(out[3])
    return best, size


def run_column_bench(sizes: range = range(1, 9)) -> str:
    """The markdown table (one run)."""
    counting = shutil.which("valgrind") is not None
    rows = []
    with tempfile.TemporaryDirectory(prefix="rocking-column-") as tmp:
        exe = _compile(Path(tmp))
        base: dict[str, float] = {}
        for n in sizes:
            cells = [str(n)]
            for op in ("rhs", "choose"):
                us, size = _timed(exe, n, op, REPS[op])
                cells.append(f"{us:.3g}")
                if counting:
                    k = COUNTED[op]
                    per = (cachegrind_instructions([str(exe), str(n), op, str(k)]) -
                           cachegrind_instructions([str(exe), str(n), op, "0"])) / k
                    base.setdefault(op, per)
                    cells += [f"{per:,.0f}", f"{per / base[op]:.2f}"]
                else:
                    cells += ["-", "-"]
                if op == "choose":
                    cells.append(str(size))
            rows.append("| " + " | ".join(cells) + f" | {n * n} |")
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    head = ["## The contact engine against the number of bodies: columns of 1 to 8 drums", "",
            f"    runners bench --columns   # {when}, one run", "",
            "| drums N | equations of motion (us) | instructions | over N = 1 | contact-set choice (us) | instructions "
            "| over N = 1 | its unknowns | N^2 |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    return "\n".join(head + rows) + "\n"


# The FMU's columns: drums as wide as high (b = h = 0.25 m, 400 kg) whose joints cannot slip (mu = 3 > b / h), under a
# 2 Hz sine pulse of 1.2 times the column's uplift acceleration g b / (N h), 3 s: the column rocks, with its impacts
# (the taller ones' joints open at impacts and close again), and nothing slides.
DRUM = {"b": 0.25, "h": 0.25, "m": 400.0}
FMU_STOP = 3.0  # s
FMU_REPEATS = 20  # simulations timed per row (the best of three runs)
FMU_COUNTED = 3  # simulations counted under valgrind per row


def column_parameters(n: int) -> dict:
    """The FMU's parameters of the benchmark's column of n drums."""
    g = 9.81
    p = {"nBlocks": n, "contact.model": 1, "contact.muGround": 3.0, "contact.muInterface": 3.0, "block1.theta0": 0.0,
         "excitation.kind": 1, "excitation.frequency": 2.0,
         "excitation.amplitude": 1.2 * g * DRUM["b"] / (n * DRUM["h"])}
    for k in range(1, n + 1):
        p.update({f"block{k}.halfWidth": DRUM["b"], f"block{k}.halfHeight": DRUM["h"], f"block{k}.mass": DRUM["m"]})
    if n >= 2:
        p["block2.theta0"] = 0.0
    return p


def run_fmu_column_bench(fmu_path: Path, sizes: range = range(1, 9)) -> str:
    """The markdown table of whole simulations of the FMU's columns of 1 to 8 drums (one run): microseconds per
    simulation (instantiate to free), impacts, and instructions counted by valgrind where it is installed."""
    counting = shutil.which("valgrind") is not None
    rows = []
    with tempfile.TemporaryDirectory(prefix="rocking-column-fmu-") as tmp:
        custom = _Custom(_compile_native(Path(fmu_path), Path(tmp)), Path(fmu_path))
        base: dict[str, float] = {}
        for n in sizes:
            p = column_parameters(n)
            us, impacts = min((custom.time(p, FMU_STOP, FMU_REPEATS) for _ in range(3)), key=lambda r: r[0])
            base.setdefault("us", us)
            cells = [str(n), f"{p['excitation.amplitude']:.3g}", str(impacts), f"{us:,.0f}", f"{us / base['us']:.2f}"]
            if counting:
                per = custom.instructions(p, FMU_STOP, FMU_COUNTED)
                base.setdefault("ins", per)
                cells += [f"{per:,.0f}", f"{per / base['ins']:.2f}"]
            else:
                cells += ["-", "-"]
            rows.append("| " + " | ".join(cells) + f" | {n * n} |")
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    head = ["## Columns of 1 to 8 drums in RockingBlock.fmu: whole simulations", "",
            f"    runners bench --columns   # {when}, one run", "",
            f"Each row one simulation of {FMU_STOP:g} s through the FMI API (the native harness), drums as wide as "
            f"high (b = {DRUM['b']} m, h = {DRUM['h']} m, {DRUM['m']:g} kg) whose joints cannot slip (mu = 3), under a "
            "2 Hz sine pulse of 1.2 times the column's uplift acceleration g b / (N h): the column rocks, with its "
            "impacts (the taller ones' joints open at impacts and close again), and nothing slides. Microseconds: the "
            "best of three runs of "
            f"{FMU_REPEATS}; instructions: valgrind (cachegrind), exact.", "",
            "| drums N | pulse (m/s2) | impacts | us per simulation | over N = 1 | instructions | over N = 1 | N^2 |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    return "\n".join(head + rows) + "\n"
