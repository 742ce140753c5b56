"""``runners bench``: cost of simulations, natively and through fmpy.

The native part compiles model/c/bench/bench_native.c, which loads the FMU's
binary with dlopen and times complete simulations (instantiate to free)
through the FMI API, so Python plays no part in the measured time. The fmpy
part times the same kind of run as a user's script does it: RockingFMU.run
with a communication step, outputs read at every step.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path

from fmpy import read_model_description

import statistics

from fmu_build.build import fmi_headers_dir
from runners.engine.fmu import RockingFMU, with_scene_defaults

BENCH_SOURCE = Path(__file__).resolve().parents[2] / "model" / "c" / "bench" / "bench_native.c"


def _compile_native(fmu_path: Path, tmp: Path) -> tuple[Path, Path, str]:
    """Compile the harness; return it, the FMU's library and its GUID."""
    md = read_model_description(str(fmu_path))
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise OSError("no C compiler (cc or gcc) found")
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp / "fmu")
    lib = tmp / "fmu" / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    exe = tmp / "bench_native"
    subprocess.run([cc, "-O2", "-I", str(fmi_headers_dir()), "-o", str(exe), str(BENCH_SOURCE), "-ldl"], check=True)
    return exe, lib, md.guid


def _custom_args(variables: dict, parameters: dict, stop_time: float) -> list[str]:
    """The harness's arguments after REPEATS for its custom form, one scene: custom STOP VR=VALUE ...
    (`variables`: the FMU's model variables by name; parameters with the scene defaults)."""
    out = ["custom", repr(float(stop_time))]
    for name, value in with_scene_defaults(parameters).items():
        v = variables[name]
        out.append(f"s{v.valueReference}={value}" if v.type == "String"
                   else f"i{v.valueReference}={int(value)}" if v.type in ("Integer", "Boolean", "Enumeration")
                   else f"{v.valueReference}={float(value)!r}")
    return out


class NativeTimer:
    """Times single scenes natively (the harness's "custom" form); use as a context manager."""

    def __init__(self, fmu_path: Path):
        self._tmp = tempfile.TemporaryDirectory()
        self.exe, self.lib, self.guid = _compile_native(Path(fmu_path), Path(self._tmp.name))
        self.vars = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}

    def __enter__(self) -> "NativeTimer":
        return self

    def __exit__(self, *exc) -> None:
        self._tmp.cleanup()

    def seconds(self, parameters: dict, stop_time: float, repeats: int) -> float:
        """Wall seconds per simulation (instantiate to free) of one scene."""
        proc = subprocess.run([str(self.exe), str(self.lib), self.guid, str(repeats),
                               *_custom_args(self.vars, parameters, stop_time)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise OSError(f"native benchmark failed: {proc.stderr.strip() or proc.returncode}")
        return float(proc.stdout.split()[0]) * 1e-6


def _native_rows(exe: Path, lib: Path, guid: str, repeats: int) -> list[list[str]]:
    """The harness's built-in cases: (case, us per simulation, impacts, outcome, simulated time) each."""
    proc = subprocess.run([str(exe), str(lib), guid, str(repeats)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise OSError(f"native benchmark failed: {proc.stderr.strip()}")
    return [line.split("\t") for line in proc.stdout.strip().splitlines()]


def run_native_bench(fmu_path: Path, repeats: int = 2000) -> str:
    """Run the native benchmark and return a Markdown table of the results."""
    if repeats < 1:
        raise ValueError("--repeats must be >= 1")
    with tempfile.TemporaryDirectory() as tmp:
        native = _compile_native(fmu_path, Path(tmp))
        rows = _native_rows(*native, repeats)
        out = [
            f"Native cost per simulation, mean of {repeats} runs (instantiate to free, one process, one core)",
            "",
            "| case | us / simulation | impacts | outcome | simulated time (s) |",
            "|---|---:|---:|---|---:|",
        ]
        stack = _stack_sliding_rows(fmu_path, native, repeats)
        last = max((i for i, r in enumerate(rows) if r[0].startswith("two blocks")), default=len(rows) - 1)
        table = rows[:last + 1] + [r for r, _ in stack] + rows[last + 1:]  # next to the two-block rows
        out += [f"| {r[0]} | {float(r[1]):.1f} | {r[2]} | {r[3]} | {float(r[4]):.2f} |" for r in table]
        out += _sliding_ratios(rows, native)
        out += _stack_sliding_ratios(rows, stack, _Custom(native, fmu_path))
    return "\n".join(out)


# The harness's rocking-sliding rows where nothing slides (mu = 100) and their rigid twins: the
# same scene with contact.model = 0 (rows are matched by the scene named after the colon).
SLIDING_TWINS = {
    "sine pulse to rest, rtol 1e-10": "sine pulse to rest, rtol 1e-10, restRatio 1e-6 (defaults)",
    "free rocking 10 impacts, rtol 1e-10": "free rocking 10 impacts, rtol 1e-10",
}


def _sliding_ratios(rows: list[list[str]], native: tuple[Path, Path, str]) -> list[str]:
    """Lines giving the cost of rocking-sliding where nothing slides over rigid rocking's, per
    scene: the ratio of the times above (noisy on a shared machine) and, where valgrind is
    installed, of the instructions per simulation (exact)."""
    index = {r[0]: i for i, r in enumerate(rows)}
    pairs = [(f"rocking-sliding where nothing slides, {scene}", f"rocking-sliding, mu 100: {scene}", twin)
             for scene, twin in SLIDING_TWINS.items()]
    lines = _ratio_lines(pairs, {r[0]: float(r[1]) for r in rows}, "rigid rocking's",
                         lambda name: _instructions(*native, index[name], 5))
    return lines + ["  (rigid rocking runs its default integrator, the Taylor series; rocking-sliding Dormand-Prince)"] \
        if lines else lines


def _ratio_lines(pairs: list[tuple[str, str, str]], us: dict[str, float], base: str, count) -> list[str]:
    """One line per (label, row, twin) of `pairs` whose rows were timed (`us`: microseconds per
    simulation by row): the row's time over its twin's and, where valgrind is installed, their
    instructions per simulation (count(row) -> instructions, exact) over each other. `base` names
    the twin's model in the line ("rigid rocking's")."""
    valgrind = shutil.which("valgrind") is not None
    out = []
    for label, name, twin in pairs:
        if name not in us or twin not in us:
            continue
        line = f"- {label}: {us[name] / us[twin]:.2f}x {base} time"
        if valgrind:
            ir = [count(n) for n in (name, twin)]
            line += f", {ir[0] / ir[1]:.3f}x its instructions"
        out.append(line)
    return ["", *out] if out else []


# The two-block rows of the native harness (model/c/bench/bench_native.c) as parameters, to run
# them again with the rocking-sliding stack (contact.model = 1) in the harness's custom form
STACK_FREE = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
              "block1.theta0": 0.05, "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0,
              "block2.theta0": -0.08, "excitation.kind": 0, "restitution.law": 0, "solver.relTol": 1e-10,
              "solver.restRatio": 1e-6}
STACK_FIG17 = {"nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
               "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3, "block1.theta0": 0.0,
               "block2.theta0": 0.0, "restitution.law": 2, "excitation.kind": 3, "excitation.frequency": 7.0,
               "excitation.displacement": 0.003, "excitation.cycles": 0.0, "solver.relTol": 1e-10,
               "solver.restRatio": 1e-6}  # Anagnostopoulos's Fig. 17A (STACK_7HZ below), default etas 0.95 / 0.98
# A statue standing free on a plinth: a marble statue (b2 = 0.2 m, h2 = 0.8 m, 690 kg) on a plinth
# (b1 = 0.3 m, h1 = 0.5 m, 450 kg), mu 0.5 at both contacts, a 0.6 g one-sine pulse at 2 Hz: the
# rigid stack's plinth would need friction 0.59 on the floor (it slides from t = 0.41 s)
STATUE_ON_PLINTH = {"nBlocks": 2, "block1.halfWidth": 0.3, "block1.halfHeight": 0.5, "block1.mass": 450.0,
                    "block2.halfWidth": 0.2, "block2.halfHeight": 0.8, "block2.mass": 690.0,
                    "contact.muGround": 0.5, "contact.muInterface": 0.5, "excitation.kind": 1,
                    "excitation.amplitude": 0.6 * 9.81, "excitation.frequency": 2.0, "excitation.cycles": 1.0,
                    "solver.relTol": 1e-10, "solver.restRatio": 1e-6}
STACK_MU = 5.0  # both contacts: above every friction demand of the rigid rows (at most 0.65, an impact's)
STATUE = "two blocks, statue on plinth (0.6 g sine pulse, 2 Hz), rtol 1e-10"  # a rigid row of its own
# (rigid row of the harness or STATUE, its parameters, stop time in s, what the sliding twin is). The
# model refuses a block 2 wider than block 1 (Anagnostopoulos's Fig. 17 pair): those rows say so.
STACK_SLIDING_CASES = [
    ("two blocks, free from opposite tilts, rtol 1e-10", STACK_FREE, 3.0, f"mu {STACK_MU:g}"),
    ("two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm), 10 s, rtol 1e-10", STACK_FIG17, 10.0, f"mu {STACK_MU:g}"),
    ("two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm), 10 s, rtol 1e-6", {**STACK_FIG17, "solver.relTol": 1e-6},
     10.0, f"mu {STACK_MU:g}"),
    ("two blocks, Anagnostopoulos Fig. 17B (5.5 Hz / 3 mm), 10 s, rtol 1e-10",
     {**STACK_FIG17, "excitation.frequency": 5.5}, 10.0, f"mu {STACK_MU:g}, slides as it overturns"),
    (STATUE, STATUE_ON_PLINTH, 5.0, f"mu {STACK_MU:g}"),
    (STATUE, STATUE_ON_PLINTH, 5.0, "mu 0.5, the plinth slides"),
]
# the rows above where nothing slides (the rigid stack's monitors with mu = STACK_MU: no slide before the
# end; Fig. 17B's pair slides as it falls, the statue's plinth with mu 0.5 from 0.41 s)
STACK_NOTHING_SLIDES = [c for c in STACK_SLIDING_CASES if c[3] == f"mu {STACK_MU:g}"]


def _stack_sliding_name(rigid: str, what: str) -> str:
    """The rocking-sliding stack's row of the rigid row `rigid`: "two blocks, rocking-sliding, <what>: ..."."""
    return f"two blocks, rocking-sliding, {what}: {rigid.removeprefix('two blocks, ')}"


def _stack_sliding_parameters(params: dict, what: str) -> dict:
    """A row's parameters for the rocking-sliding stack: contact.model = 1, and mu = STACK_MU at both
    contacts for the rows where nothing should slide."""
    q = {**params, "contact.model": 1}
    if what.startswith(f"mu {STACK_MU:g}"):
        q.update({"contact.muGround": STACK_MU, "contact.muInterface": STACK_MU})
    return q


class StackRows(list):
    """The rocking-sliding stack's table rows: (row, (parameters, stop time in s)) each; ``refused``
    holds a line per case the FMU refuses (its one-line reason)."""

    def __init__(self, rows=(), refused=()):
        super().__init__(rows)
        self.refused = list(refused)


def _stack_sliding_rows(fmu_path: Path, native: tuple[Path, Path, str], repeats: int) -> StackRows:
    """The two-block rows again with the rocking-sliding stack (STACK_SLIDING_CASES), timed by the
    harness's custom form, and the rigid stack's row of the statue (no row of the harness): each
    as a table row (case, us, impacts, outcome, simulated time) with its (parameters, stop time)
    for counting its instructions. None where the FMU has no rocking-sliding stack (a build
    before it); a case it refuses (a block 2 wider than block 1) is listed in ``refused``."""
    from runners.engine.fmu import FMUError

    with RockingFMU(fmu_path) as fmu:
        try:
            fmu.validate(_stack_sliding_parameters(STACK_FREE, f"mu {STACK_MU:g}"))
        except FMUError:
            return StackRows()
        timer = _Custom(native, fmu_path)
        out = StackRows()
        for rigid, params, stop, what in STACK_SLIDING_CASES:
            runs = [(_stack_sliding_name(rigid, what), _stack_sliding_parameters(params, what))]
            try:
                fmu.validate(runs[0][1])
            except FMUError as exc:
                out.refused.append(f"- not run with the rocking-sliding stack, {rigid.removeprefix('two blocks, ')}: "
                                   f"{exc}")
                continue
            if rigid == STATUE and all(r[0] != STATUE for r, _ in out):  # no row of the harness
                runs.insert(0, (rigid, params))
            for name, p in runs:
                us, impacts = timer.time(p, stop, repeats)
                r = fmu.run(p, stop, stop, outputs=["overturned", "atRest", "block2.fellOff"], events=False)
                final = {k: v[-1] for k, v in r.outputs.items()}
                outcome = ("overturned" if final["overturned"] else "fell off" if final["block2.fellOff"]
                           else "at rest" if final["atRest"] else "rocking")
                out.append(([name, f"{us:.2f}", str(impacts), outcome, f"{stop:.2f}"], (p, stop)))
    return out


def _stack_sliding_ratios(rows: list[list[str]], stack: StackRows, custom: "_Custom") -> list[str]:
    """Lines giving the cost of the rocking-sliding stack over the rigid stack's, per two-block row
    (as _sliding_ratios for one block): times from the table, instructions counted by the custom
    form for both twins (the rigid one: the same parameters with contact.model = 0); then the
    cases the FMU refused."""
    if not stack and not stack.refused:
        return []
    scenes = {r[0]: run for r, run in stack}
    us = {**{r[0]: float(r[1]) for r in rows}, **{r[0]: float(r[1]) for r, _ in stack}}
    pairs = []
    for rigid, params, stop, what in STACK_SLIDING_CASES:
        scenes.setdefault(rigid, ({**params, "contact.model": 0}, stop))
        nothing = what == f"mu {STACK_MU:g}"
        label = (f"rocking-sliding stack {'where nothing slides' if nothing else f'({what})'}, "
                 f"{rigid.removeprefix('two blocks, ')}")
        pairs.append((label, _stack_sliding_name(rigid, what), rigid))
    lines = _ratio_lines(pairs, us, "the rigid stack's", lambda name: custom.instructions(*scenes[name]))
    return (lines or [""]) + stack.refused if stack.refused else lines


class _Custom:
    """The native harness's custom form: one scene given by its parameters."""

    def __init__(self, native: tuple[Path, Path, str], fmu_path: Path):
        self.native = native
        self.vars = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}

    def args(self, parameters: dict, stop_time: float) -> list[str]:
        """The harness's arguments after REPEATS: custom STOP VR=VALUE ..."""
        return _custom_args(self.vars, parameters, stop_time)

    def time(self, parameters: dict, stop_time: float, repeats: int) -> tuple[float, int]:
        """Microseconds per simulation (instantiate to free) and the impacts of one scene."""
        exe, lib, guid = self.native
        proc = subprocess.run([str(exe), str(lib), guid, str(repeats), *self.args(parameters, stop_time)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise OSError(f"native benchmark failed: {proc.stderr.strip() or proc.returncode}")
        us, impacts = proc.stdout.split()[:2]
        return float(us), int(impacts)

    def instructions(self, parameters: dict, stop_time: float, repeats: int = 5) -> float:
        """Instructions per simulation of one scene (valgrind, exact; see _instructions)."""
        return _instructions(*self.native, self.args(parameters, stop_time), repeats)


def _instructions(exe: Path, lib: Path, guid: str, case: int | list[str], repeats: int) -> float:
    """Instructions per simulation of one case of the native harness (its row, or the arguments
    of its custom form), counted by valgrind's cachegrind (exact and unaffected by other work on
    the machine): a run of `repeats` simulations less one of none (loading, instantiating nothing)."""
    which = [str(case)] if isinstance(case, int) else list(case)
    return (cachegrind_instructions([str(exe), str(lib), guid, str(repeats), *which]) -
            cachegrind_instructions([str(exe), str(lib), guid, "0", *which])) / repeats


def cachegrind_instructions(argv: list[str]) -> int:
    """The instructions a program runs (``argv``), counted by valgrind's cachegrind: exact, and unaffected by other
    work on the machine. OSError where valgrind gives no count."""
    proc = subprocess.run(["valgrind", "--tool=cachegrind", "--cache-sim=no", "--cachegrind-out-file=/dev/null", *argv],
                          capture_output=True, text=True)
    for line in proc.stderr.splitlines():
        if "I" in line and "refs:" in line:
            return int(line.split("refs:")[1].replace(",", "").split()[0])
    raise OSError(f"valgrind gave no instruction count: {proc.stderr.strip()[-300:]}")


def _stack_cases_of_both(paths: tuple[Path, Path]) -> list[tuple[str, dict, float]]:
    """The rocking-sliding stack's cases (STACK_SLIDING_CASES: name, parameters, stop time in s) that
    every FMU of `paths` runs (a build refuses what it has no model for)."""
    from runners.engine.fmu import FMUError

    cases = []
    for rigid, params, stop, what in STACK_SLIDING_CASES:
        p = _stack_sliding_parameters(params, what)
        try:
            for path in paths:
                with RockingFMU(path) as fmu:
                    fmu.validate(p)
        except FMUError:
            continue
        cases.append((_stack_sliding_name(rigid, what), p, stop))
    return cases


def run_native_against(fmu_path: Path, other: Path, repeats: int = 2000, rounds: int = 5,
                       count_repeats: int = 5) -> str:
    """The native benchmark of two FMUs (this one and `other`, say a build before a change),
    interleaved round by round, as a Markdown table of the smallest time per case and the
    ratio this / other: the cost of the change. The harness's rows, then the rocking-sliding stack's
    cases both builds run (through the harness's custom form). Where valgrind is installed, also the
    ratio of instructions per simulation (exact: on a shared machine times vary by tens of percent)."""
    if repeats < 1 or rounds < 1:
        raise ValueError("--repeats must be >= 1")
    for path in (fmu_path, other):  # one clear line for a missing or foreign file
        RockingFMU(path).close()
    valgrind = shutil.which("valgrind") is not None
    with tempfile.TemporaryDirectory() as tmp:
        paths = (Path(fmu_path), Path(other))
        natives = [_compile_native(p, Path(tmp) / name) for p, name in zip(paths, ("this", "other"))]
        customs = [_Custom(n, p) for n, p in zip(natives, paths)]
        stack = _stack_cases_of_both(paths)
        best: list[dict[str, float]] = [{}, {}]
        impacts: dict[str, str] = {}
        for _ in range(rounds):
            for k, native in enumerate(natives):
                timed = [(row[0], float(row[1]), row[2]) for row in _native_rows(*native, repeats)]
                for name, p, stop in stack:
                    us, n_impacts = customs[k].time(p, stop, repeats)
                    timed.append((name, us, str(n_impacts)))
                for name, us, n_impacts in timed:
                    best[k][name] = min(best[k].get(name, float("inf")), us)
                    if k == 0:
                        impacts[name] = n_impacts
        counts = {}
        if valgrind:
            harness = [name for name in best[0] if name not in {case for case, _, _ in stack}]  # its row order
            for index, case in enumerate(harness):
                counts[case] = [_instructions(*n, index, count_repeats) for n in natives]
            for name, p, stop in stack:
                counts[name] = [c.instructions(p, stop, count_repeats) for c in customs]
    head = (f"Native cost per simulation of {fmu_path.name} against {other}: smallest of {rounds} interleaved "
            f"rounds of {repeats} runs each")
    if valgrind:
        head += f"; instructions per simulation counted by valgrind (cachegrind) over {count_repeats} runs"
    out = [head, "", "| case | us / simulation | us, other | ratio | instructions | instructions, other | ratio "
                     "| impacts |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for case, us in best[0].items():
        ref = best[1].get(case, float("nan"))
        ir = counts.get(case, [float("nan"), float("nan")])
        out.append(f"| {case} | {us:.1f} | {ref:.1f} | {us / ref:.3f} | {ir[0]:,.0f} | {ir[1]:,.0f} | "
                   f"{ir[0] / ir[1]:.3f} | {impacts[case]} |")
    if not valgrind:
        out.append("\nvalgrind is not installed (Debian: valgrind): no instruction counts")
    return "\n".join(out)


# Anagnostopoulos (BEng thesis) Fig. 17A: Blocks 1 (lower) and 4 (upper), 7 Hz / 3 mm harmonic table motion
STACK_7HZ = {
    "nBlocks": 2, "block1.halfWidth": 0.0145, "block1.halfHeight": 0.060, "block1.mass": 1.3,
    "block2.halfWidth": 0.030, "block2.halfHeight": 0.050, "block2.mass": 2.3,
    "restitution.law": 2, "restitution.etaGround": 0.95, "restitution.etaInterface": 0.98,
    "excitation.kind": 3, "excitation.frequency": 7.0, "excitation.displacement": 0.003, "excitation.cycles": 0,
}
# Anagnostopoulos's Block 2 alone, same table motion (examples/harmonic.toml)
BLOCK_7HZ = {
    "block1.halfWidth": 0.030, "block1.halfHeight": 0.0675, "block1.mass": 2.95, "restitution.correction": 1.233,
    "excitation.kind": 3, "excitation.frequency": 7.0, "excitation.displacement": 0.003, "excitation.cycles": 0,
}
FMPY_CASES = [
    ("two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm)", STACK_7HZ, ["block1.theta", "block2.theta", "impacts", "pattern"]),
    ("one block, Anagnostopoulos Block 2, 7 Hz / 3 mm", BLOCK_7HZ, ["block1.theta", "impacts", "atRest", "overturned"]),
]


def run_fmpy_bench(fmu_path: Path, repeats: int = 20, stop_time: float = 10.0, step: float = 0.01) -> str:
    """Wall time of complete runs through fmpy (RockingFMU.run), as a Markdown table."""
    if repeats < 1:
        raise ValueError("--repeats must be >= 1")
    out = [
        f"Through fmpy: {stop_time:g} s simulated, communication step {step:g} s, outputs read at every step, "
        f"{repeats} runs (instantiate to free)",
        "",
        "| case | min ms / run | median ms / run | impacts |",
        "|---|---:|---:|---:|",
    ]
    with RockingFMU(fmu_path) as fmu:
        for name, params, outputs in FMPY_CASES:
            walls = []
            for _ in range(repeats):
                r = fmu.run(params, stop_time, step, outputs=outputs, events=False)
                walls.append(r.wall_time)
            out.append(f"| {name} | {1e3 * min(walls):.1f} | {1e3 * statistics.median(walls):.1f} | "
                       f"{int(r.outputs['impacts'][-1])} |")
    return "\n".join(out)


RECORDING_CASES = [("examples/harmonic.toml", "one block, 7 Hz table"),
                   ("examples/two_blocks_harmonic.toml", "stack, 7 Hz table")]


def run_recording_bench(fmu_path: Path, repeats: int = 3, stop_time: float = 10.0, step: float = 1e-3) -> str:
    """Time and size of writing the Rerun recording of a 10 s run sampled at 1 kHz."""
    from runners.engine.recording import write_recording
    from runners.engine.scene import load_scene
    from runners.engine.summary import SUMMARY_OUTPUTS

    root = Path(__file__).resolve().parents[2]
    out = [f"Rerun recordings: {stop_time:g} s sampled every {step:g} s, write time min of {repeats}", "",
           "| run | samples | events | write time (s) | size (MB) |", "|---|---:|---:|---:|---:|"]
    with RockingFMU(fmu_path) as fmu, tempfile.TemporaryDirectory() as tmp:
        defaults = fmu.defaults()
        for path, label in RECORDING_CASES:
            scene = load_scene(root / path)
            r = fmu.run(scene.parameters, stop_time, step, outputs=SUMMARY_OUTPUTS)
            best, rrd = float("inf"), Path(tmp) / "bench.rrd"
            for _ in range(repeats):
                t0 = time.perf_counter()
                write_recording(rrd, scene.name, r.time, r.outputs, {**defaults, **scene.parameters}, r.events)
                best = min(best, time.perf_counter() - t0)
            out.append(f"| {path} ({label}) | {len(r.time)} | {len(r.events)} | {best:.3f} | "
                       f"{rrd.stat().st_size / 1e6:.2f} |")
    return "\n".join(out)


def run_sweep_recording_bench(fmu_path: Path, points: int = 8) -> str:
    """Recording grid points in sweep workers: wall time with 1 and 2 worker processes, each
    point a full 6 s run at 1 kHz written to its own .rrd (examples/harmonic.toml, frequency
    axis), against the same sweep storing summaries only."""
    from db.session import open_database
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    root = Path(__file__).resolve().parents[2]
    scene = load_scene(root / "examples" / "harmonic.toml")
    rows = {}
    with RockingFMU(fmu_path) as fmu, tempfile.TemporaryDirectory() as tmp:
        defaults = fmu.defaults()
        factory = open_database(f"sqlite:///{Path(tmp) / 'bench.db'}")
        for workers, record in ((1, False), (1, True), (2, False), (2, True)):
            sweep_id = create_sweep(factory, scene, [Axis("excitation.frequency", 6.0, 8.0, points)], defaults)
            st = run_sweep(factory, sweep_id, fmu_path, workers=workers, progress=False,
                           record=list(range(points)) if record else None, record_dir=Path(tmp) / f"rec{sweep_id}")
            rows[workers, record] = st["wall_seconds"]
    out = [f"Sweep points recorded in worker processes: {points} points of {scene.stop_time:g} s at "
           f"{scene.step:g} s output (examples/harmonic.toml), sweep wall time (s)", "",
           "| workers | summaries only | recorded in full | recorded, 1 worker / this |", "|---:|---:|---:|---:|"]
    for w in (1, 2):
        out.append(f"| {w} | {rows[w, False]:.2f} | {rows[w, True]:.2f} | {rows[1, True] / rows[w, True]:.2f} |")
    return "\n".join(out)


DASK_CASES = [("examples/sweep_sine_pulse.toml", 300, "one block"), ("examples/sweep_stack_pulse.toml", 60, "two blocks")]
DASK_WORKERS = (1, 2, 4)


def run_dask_bench(fmu_path: Path) -> str:
    """Sweep wall time and throughput of a one-block 300 x 300 map (cheap points: overhead shows)
    and a two-block 60 x 60 map (costlier points) with the local executor and on a local Dask
    cluster, with 1, 2 and 4 worker processes (cluster start-up not counted), and the per-point
    overhead of the distributed path."""
    from distributed import Client, LocalCluster

    from db.session import open_database
    from runners.engine.scene import load_scene
    from runners.engine.sweep import Axis, create_sweep, run_sweep

    root = Path(__file__).resolve().parents[2]
    out = [f"Sweep executors: wall time and throughput, SQLite, cluster start-up not counted "
           f"({os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start)", "",
           "| map | points | executor | workers | wall (s) | points per second | speed-up over 1 worker |",
           "|---|---:|---|---:|---:|---:|---:|"]
    notes = []
    with RockingFMU(fmu_path) as fmu, tempfile.TemporaryDirectory() as tmp:
        defaults = fmu.defaults()
        factory = open_database(f"sqlite:///{Path(tmp) / 'bench.db'}")
        for path, n, label in DASK_CASES:
            scene = load_scene(root / path)
            axes = [Axis("w", 1.0, 12.0, n), Axis("a", 1.01, 8.0, n)]
            wall: dict[tuple[str, int], float] = {}
            for workers in DASK_WORKERS:
                sid = create_sweep(factory, scene, axes, defaults)
                wall["local", workers] = run_sweep(factory, sid, fmu_path, workers=workers,
                                                   progress=False)["wall_seconds"]
                with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, Client(cluster) as client:
                    run_sweep(factory, create_sweep(factory, scene, [Axis("w", 1, 2, 2)], defaults), fmu_path,
                              progress=False, client=client)  # warm-up: ship and extract the FMU
                    sid = create_sweep(factory, scene, axes, defaults)
                    wall["dask", workers] = run_sweep(factory, sid, fmu_path, progress=False,
                                                      client=client)["wall_seconds"]
            for ex in ("local", "dask"):
                for workers in DASK_WORKERS:
                    t = wall[ex, workers]
                    out.append(f"| {label} | {n * n} | {ex} | {workers} | {t:.2f} | {n * n / t:,.0f} | "
                               f"{wall[ex, 1] / t:.2f} |")
            notes.append(f"{label}: the Dask path adds {1e3 * (wall['dask', 1] - wall['local', 1]) / (n * n):.3f} ms "
                         f"per point against the local one ({wall['dask', 1] / wall['local', 1]:.2f}x, 1 worker)")
    return "\n".join(out + [""] + notes)


SIZE_CASES = [(100, 100), (1000, 1000), (10000, 1000)]  # w x a points of the one-sine-pulse map


def run_sweep_size_bench(fmu_path: Path, first: int = 1000) -> str:
    """Memory and start-up of sweeps of 1e4, 1e6 and 1e7 points: each runs as its own
    `runners sweep` process (1 worker), watched until `first` points are stored, then
    stopped with SIGTERM; its peak resident memory (VmHWM, Linux) and the time to that
    first stored batch. The grid is planned a window at a time, so neither should grow
    with the grid."""
    import signal
    import sqlite3
    import sys

    root = Path(__file__).resolve().parents[2]
    out = [f"Sweep size: a runners sweep process until {first} points are stored (1 worker, SQLite)", "",
           "| points | to the first stored points (s) | peak memory of the runner (MB) |", "|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for nw, na in SIZE_CASES:
            db = Path(tmp) / f"size-{nw * na}.db"
            cmd = [sys.executable, "-m", "runners.cli", "sweep", str(root / "examples" / "sweep_sine_pulse.toml"),
                   "--grid", f"w=1:12:{nw}", "--grid", f"a=1.01:8:{na}", "--workers", "1", "--quiet", "--yes",
                   "--db", str(db), "--fmu", str(fmu_path)]
            t0 = time.perf_counter()
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
            stored, peak = 0, 0
            while proc.poll() is None and stored < first and time.perf_counter() - t0 < 600:
                try:
                    status = Path(f"/proc/{proc.pid}/status").read_text()
                    peak = int(next(x for x in status.splitlines() if x.startswith("VmHWM")).split()[1])
                    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
                        stored = conn.execute("SELECT count(*) FROM runs").fetchone()[0]
                except (OSError, StopIteration, sqlite3.Error):
                    pass
                time.sleep(0.05)
            elapsed = time.perf_counter() - t0
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
            proc.communicate(timeout=60)
            out.append(f"| {nw * na:.0e} | {elapsed:.2f} | {peak / 1024:.0f} |")
    return "\n".join(out)


def markdown_sections(text: str) -> list[dict]:
    """The sections of a benchmark's Markdown as JSON-ready dicts: a title (the paragraph before
    a table), the table's columns and rows (numbers where a cell is one), and the notes (the
    paragraphs after it)."""
    def cell(x: str):
        for kind in (int, float):
            try:
                return kind(x)
            except ValueError:
                pass
        return x

    sections: list[dict] = []
    title: list[str] = []
    for block in (b.strip() for b in text.split("\n\n")):
        lines = block.splitlines()
        if lines and all(x.lstrip().startswith("|") for x in lines):
            rows = [[c.strip() for c in x.strip().strip("|").split("|")] for x in lines]
            body = [r for r in rows[1:] if not all(c and set(c) <= set("-:") for c in r)]
            sections.append({"title": " ".join(title), "columns": rows[0],
                             "rows": [[cell(c) for c in r] for r in body], "notes": []})
            title = []
        elif block and sections and not title and sections[-1]["rows"]:
            sections[-1]["notes"].append(" ".join(lines))
        elif block:
            title.append(" ".join(lines))
    if title:
        sections.append({"title": " ".join(title), "columns": [], "rows": [], "notes": []})
    return sections
