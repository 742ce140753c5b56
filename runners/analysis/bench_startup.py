"""``runners bench --startup``: the CPU time a command spends before it starts its work.

Two commands, each in a fresh Python process, as a user's script that loops over the command
line runs them:

- ``runners simulate examples/free_rocking.toml --no-store``: the CPU time from the process's
  start to the moment it instantiates the FMU (runners.engine.fmu.RockingFMU), and the whole
  command's;
- ``runners db list runs`` on an up-to-date SQLite database: the whole command's;

and, for scale, ``python -c "import fmpy"``: the least a command that runs the FMU loads.

With ``--baseline PYTHON`` (the Python of another installation of this tool, say a checkout
before a change) both installations run the commands in turn, alternating, in one run: the
ratio this / baseline is then the start-up's change, measured under the same load of a shared
machine. Times are CPU seconds (user + system), the median of the repeats.

Each is measured twice: with the compiled bytecode of every module cached, as after an
installation (in a folder of this run, PYTHONPYCACHEPREFIX, so that neither installation's
folders are written to), and with none written (PYTHONDONTWRITEBYTECODE=1, as some sandboxes
run Python), where the tool's own modules are compiled at each start.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPEATS = 10  # runs of each command by each installation
SCENE = Path(__file__).resolve().parents[2] / "examples" / "free_rocking.toml"

# runs the command line as the console script does, noting the process's CPU time (s) when the
# command instantiates the FMU: the start-up before the simulation
_UNTIL_FMU = """\
import sys, time
import runners.engine.fmu as fmu
start, note_file = fmu.RockingFMU.__init__, sys.argv[1]
def noted(self, *args, **kwargs):
    with open(note_file, "a") as fh:
        fh.write(f"{time.process_time()!r}\\n")
    start(self, *args, **kwargs)
fmu.RockingFMU.__init__ = noted
sys.argv = ["runners", *sys.argv[2:]]
from runners.cli.console import main
sys.exit(main())
"""


def _children_cpu() -> float:
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def _run(python: str, args: list[str], env: dict[str, str], cwd: str) -> float:
    """CPU seconds of one process; RuntimeError if it fails."""
    before = _children_cpu()
    done = subprocess.run([python, *args], env=env, cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{python} {' '.join(args)} failed: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
    return _children_cpu() - before


MODES = {"cached": "cached", "compiled": "not written (PYTHONDONTWRITEBYTECODE=1)"}  # the bytecode of the modules
ROWS = [("until_fmu", "`runners simulate examples/free_rocking.toml --no-store`, until the FMU starts"),
        ("simulate", "`runners simulate examples/free_rocking.toml --no-store`, whole command"),
        ("db_list", "`runners db list runs`, whole command (up-to-date SQLite database)"),
        ("fmpy", "`python -c \"import fmpy\"`: Python, NumPy and fmpy, which any run of the FMU loads")]


def _environment(folder: Path, label: str, mode: str) -> dict[str, str]:
    """The commands' environment: their own database; compiled bytecode kept in a folder of this
    run (never beside the sources of either installation), or not written at all."""
    env = {**os.environ, "ROCKING_DB": f"sqlite:///{folder / f'{label}.db'}"}
    env.pop("ROCKING_FMU", None)
    if mode == "cached":
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(folder / f"pycache-{label}")
    else:
        env.pop("PYTHONPYCACHEPREFIX", None)
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def _measure(python: str, folder: Path, label: str, mode: str) -> dict[str, float]:
    """CPU seconds of one run of each measured command by `python`."""
    env = _environment(folder, label, mode)
    noted = folder / f"{label}.fmu-start"
    noted.unlink(missing_ok=True)
    whole = _run(python, ["-c", _UNTIL_FMU, str(noted), "simulate", str(SCENE), "--no-store"], env, str(folder))
    until_fmu = float(noted.read_text().split()[0])
    listing = _run(python, ["-m", "runners.cli", "db", "list", "runs"], env, str(folder))
    fmpy = _run(python, ["-c", "import fmpy"], env, str(folder))
    return {"until_fmu": until_fmu, "simulate": whole, "db_list": listing, "fmpy": fmpy}


def run_startup_bench(baseline: str | None = None, repeats: int = REPEATS) -> str:
    """Markdown table: the median CPU seconds of each command by this installation (sys.executable)
    and, given, by `baseline` (another installation's Python), alternating, with the ratio."""
    if baseline is not None and not Path(baseline).is_file():
        raise ValueError(f"--baseline {baseline}: no such Python")
    pythons = {"this": sys.executable, **({"baseline": baseline} if baseline else {})}
    runs = [(label, mode) for mode in MODES for label in pythons]
    with tempfile.TemporaryDirectory(prefix="rocking-startup-") as tmp:
        folder = Path(tmp)
        times: dict[tuple[str, str], list[dict[str, float]]] = {run: [] for run in runs}
        for label, python in pythons.items():  # each its own database, created and brought up to date
            _run(python, ["-m", "runners.cli", "db", "init"], _environment(folder, label, "compiled"), tmp)
            for mode in MODES:  # a first run fills the bytecode cache and warms the file caches: not counted
                _measure(python, folder, label, mode)
        for k in range(repeats):
            for label, mode in runs if k % 2 == 0 else reversed(runs):
                times[label, mode].append(_measure(pythons[label], folder, label, mode))
    median = {run: {key: statistics.median(t[key] for t in measured) for key, _ in ROWS}
              for run, measured in times.items()}
    head = f"CPU time (user + system, s) of each command in a fresh process, median of {repeats} runs"
    if baseline is None:
        out = [head, "", "| command | bytecode | CPU s |", "|---|---|---:|"]
        out += [f"| {text} | {MODES[mode]} | {median['this', mode][key]:.3f} |" for mode in MODES for key, text in ROWS]
        return "\n".join(out)
    out = [f"{head}, alternating with the baseline {baseline}", "",
           "| command | bytecode | CPU s, baseline | CPU s, this | ratio this / baseline |", "|---|---|---:|---:|---:|"]
    for mode in MODES:
        for key, text in ROWS:
            old, new = median["baseline", mode][key], median["this", mode][key]
            out.append(f"| {text} | {MODES[mode]} | {old:.3f} | {new:.3f} | {new / old:.3f} |")
    return "\n".join(out)
