"""``runners bench``: native cost of single-block simulations.

Compiles model/c/bench/bench_native.c, which loads the FMU's binary with
dlopen and times complete simulations (instantiate to free) through the FMI
API, so Python plays no part in the measured time.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

from fmpy import read_model_description

from fmu_build.build import fmi_headers_dir

BENCH_SOURCE = Path(__file__).resolve().parent.parent / "model" / "c" / "bench" / "bench_native.c"


def run_native_bench(fmu_path: Path, repeats: int = 2000) -> str:
    """Run the native benchmark and return a Markdown table of the results."""
    if repeats < 1:
        raise ValueError("--repeats must be >= 1")
    md = read_model_description(str(fmu_path))
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise OSError("no C compiler (cc or gcc) found")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with zipfile.ZipFile(fmu_path) as zf:
            zf.extractall(tmp / "fmu")
        lib = tmp / "fmu" / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
        exe = tmp / "bench_native"
        subprocess.run(
            [cc, "-O2", "-I", str(fmi_headers_dir()), "-o", str(exe), str(BENCH_SOURCE), "-ldl"],
            check=True,
        )
        proc = subprocess.run([str(exe), str(lib), md.guid, str(repeats)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise OSError(f"native benchmark failed: {proc.stderr.strip()}")
    rows = [line.split("\t") for line in proc.stdout.strip().splitlines()]
    out = [
        f"Native cost per simulation, mean of {repeats} runs (instantiate to free, one process, one core)",
        "",
        "| case | us / simulation | impacts | outcome | simulated time (s) |",
        "|---|---:|---:|---|---:|",
    ]
    out += [f"| {r[0]} | {float(r[1]):.1f} | {r[2]} | {r[3]} | {float(r[4]):.2f} |" for r in rows]
    return "\n".join(out)
