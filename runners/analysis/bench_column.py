"""``runners bench --columns``: the contact engine's cost against the number of bodies of a column of drums (1 to 8),
from model/c/bench/bench_column.c built with EN_MAX_BODIES = 8 (the engine the white-box check of columns uses,
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

from runners.analysis.bench import cachegrind_instructions

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
