"""fmu_build: builds from source, only when the sources changed."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import pytest

from fmu_build.__main__ import main
from fmu_build.build import build_fmu, win64_compiler


def test_rebuild_only_when_sources_change(tmp_path):
    out = tmp_path / "RockingBlock.fmu"
    build_fmu(out, platforms=["linux64"])  # linux64 alone: quicker, and the stamp works alike
    stamp = out.stat().st_mtime_ns
    build_fmu(out, platforms=["linux64"])  # unchanged sources: nothing to do
    assert out.stat().st_mtime_ns == stamp
    build_fmu(out, platforms=["linux64"], force=True)
    assert out.stat().st_mtime_ns != stamp


def test_fmu_contents(tmp_path):
    out = build_fmu(tmp_path / "RockingBlock.fmu")
    names = set(zipfile.ZipFile(out).namelist())
    assert {"modelDescription.xml", "binaries/linux64/RockingBlock.so", "sources/fmi2.c", "sources/model.c",
            "sources/solver.c", "sources/integrator.c", "sources/config.h", "sources/variables.def"} <= names
    assert ("binaries/win64/RockingBlock.dll" in names) == (win64_compiler() is not None)


def test_the_fmu_documents_every_variable(fmu_path):
    """documentation/index.html: every variable with its unit and every enumeration item,
    then the model's documentation, as well-formed HTML."""
    from html.parser import HTMLParser

    from fmu_build.build import C_DIR
    from fmu_build.variables import read_enumerations, read_variables

    with zipfile.ZipFile(fmu_path) as zf:
        page = zf.read("documentation/index.html").decode("utf-8")

    class Text(HTMLParser):
        def __init__(self):
            super().__init__()
            self.parts: list[str] = []
            self.open: list[str] = []

        def handle_starttag(self, tag, attrs):
            if tag not in ("br", "hr", "meta", "img", "input"):
                self.open.append(tag)

        def handle_endtag(self, tag):
            assert self.open and self.open[-1] == tag, (tag, self.open[-5:])
            self.open.pop()

        def handle_data(self, data):
            self.parts.append(data)

    parser = Text()
    parser.feed(page)
    assert not parser.open
    text = " ".join(parser.parts)
    for v in read_variables(C_DIR / "variables.def"):
        assert v.name in text and v.description.split("(")[0].strip() in text, v.name
    for enum in read_enumerations(C_DIR / "variables.def").values():
        assert all(item in text for _, item, _ in enum.items)
    # the valid ranges, open bounds as such
    assert "<td>(0, inf)</td>" in page and "<td>[0, 1]</td>" in page and "<td>(1, 20]</td>" in page
    assert "Equation of motion" in text and "Model Exchange" in text


def test_without_the_cross_compiler_the_fmu_has_no_windows_binary_until_it_is_installed(tmp_path, monkeypatch,
                                                                                        capsys):
    out = tmp_path / "RockingBlock.fmu"
    monkeypatch.setenv("CC_WIN64", "x86_64-w64-mingw32-gcc-not-installed")
    build_fmu(out)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no Windows binary" in err, err
    assert not any(name.startswith("binaries/win64/") for name in zipfile.ZipFile(out).namelist())
    monkeypatch.delenv("CC_WIN64")
    if win64_compiler() is None:
        pytest.skip("the rest needs x86_64-w64-mingw32-gcc (Debian: gcc-mingw-w64-x86-64)")
    build_fmu(out)  # same sources, but now win64 can be built: the stamp says rebuild
    assert "binaries/win64/RockingBlock.dll" in zipfile.ZipFile(out).namelist()


def test_a_platform_that_cannot_be_built_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CC_WIN64", "x86_64-w64-mingw32-gcc-not-installed")
    out = tmp_path / "RockingBlock.fmu"
    for args, message in [(["--platforms", "win64"], "cross compiler 'x86_64-w64-mingw32-gcc-not-installed' is "
                                                      "not installed"),
                          (["--platforms", "linux64,macos"], "unknown platform 'macos'"),
                          (["--sanitize", "--platforms", "linux64,win64"], "for linux64 only")]:
        assert main([*args, "--out", str(out)]) == 1
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and message in err, err
    assert not out.exists()


# ------------------------------------------------------------------ declared ranges

RUNNING_EXTREMES = ("block1.maxAbsTheta", "block2.maxAbsTheta", "friction.demandMaxGround",
                    "friction.demandMaxInterface", "contact.normalMinGround", "contact.normalMinInterface")

# The choices under which the FMU checks a range (the others are checked always): a pulse's
# shape only for a built-in pulse, the second block's only with two blocks. Sizes far from the
# default block's 0.1 x 0.3 m come with the constant restitution law (Housner's needs b/h <= sqrt 2).
RANGE_CONTEXT: dict[str, dict] = {
    "excitation.amplitude": {"excitation.kind": 1},
    "excitation.frequency": {"excitation.kind": 1},
    "excitation.verticalAmplitude": {"excitation.kind": 1},
    "excitation.cycles": {"excitation.kind": 3},  # harmonic: >= 0 (a pulse needs > 0)
    "excitation.gamma": {"excitation.kind": 7},
    "block1.halfWidth": {"restitution.law": 2},
    "block1.halfHeight": {"restitution.law": 2},
    "block2.halfWidth": {"nBlocks": 2, "restitution.law": 2},
    "block2.halfHeight": {"nBlocks": 2, "restitution.law": 2},
    "block2.mass": {"nBlocks": 2},
    "block2.inertia": {"nBlocks": 2},
    "restitution.etaGround": {"nBlocks": 2},
    "restitution.etaInterface": {"nBlocks": 2},
    # a support's parameters are checked where it is chosen (a building's floors up to its storeys)
    "building.storeys": {"support.kind": 1},
    "building.floor": {"support.kind": 1, "building.storeys": 10},
    "building.dampingRatio": {"support.kind": 1},
    **{f"building.storey[{i}].{q}": {"support.kind": 1, "building.storeys": 10}
       for i in range(1, 11) for q in ("mass", "stiffness")},
    "platform.mass": {"support.kind": 2},
    "platform.stiffness": {"support.kind": 2},
    "platform.damping": {"support.kind": 2},
    # a column's blocks 3 to 8 (every one in use), each on blocks as wide as the widest it may be and
    # under blocks as narrow as the narrowest
    **{f"block{k}.{q}": {"nBlocks": 8, "block1.halfWidth": 1e4, "block2.halfWidth": 1e4,
                         **{f"block{j}.halfWidth": 1e4 if j < k else 1e-6 for j in range(3, 9) if j != k}}
       for k in range(3, 9) for q in ("halfWidth", "halfHeight", "mass")},
    **{f"block{k}.inertia": {"nBlocks": 8} for k in range(3, 9)},
}


def _tables():
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_codes, read_enumerations, read_ranges, read_variables

    path = C_DIR / "variables.def"
    return read_variables(path), read_enumerations(path), read_ranges(path), read_codes(path)


def _declared(md) -> dict[str, tuple[float | None, float | None]]:
    return {v.name: (None if v.min is None else float(v.min), None if v.max is None else float(v.max))
            for v in md.modelVariables if v.min is not None or v.max is not None}


@pytest.mark.parametrize("edition", ["FMI 2.0", "FMI 3.0"])
def test_both_editions_declare_the_ranges_of_variables_def_and_discrete_running_extremes(edition, request):
    from fmpy import read_model_description

    variables, enumerations, ranges, _ = _tables()
    md = read_model_description(str(request.getfixturevalue("fmu_path" if edition == "FMI 2.0" else "fmu3_path")))
    declared = _declared(md)
    assert declared == {name: (r.min, r.max) for name, r in ranges.items()}
    assert not set(declared) & set(enumerations)  # the items are an Enumeration's range
    # an open bound is declared as the next double inside it: mass > 0 is min = 5e-324
    assert declared["block1.mass"] == (5e-324, None) and declared["solver.restRatio"] == (5e-324, 1 - 2 ** -53)
    assert declared["nBlocks"] == (1, 8)
    starts = {v.name: float(v.start) for v in md.modelVariables if v.name in declared}
    for name, (low, high) in declared.items():  # FMI: min <= start <= max
        assert (low is None or low <= starts[name]) and (high is None or starts[name] <= high), name
    by_name = {v.name: v for v in md.modelVariables}
    for name in RUNNING_EXTREMES:
        assert by_name[name].variability == "discrete", name
    counters = [v.name for v in variables if v.causality == "output" and v.type == "Integer"]
    assert counters and all(by_name[n].variability == "discrete" for n in counters)


def _outside_and_inside(r, integer: bool):
    """(value, accepted) pairs at each bound: the bound itself if closed, else the declared
    min or max (the next double inside); and the next value outside (an open bound itself)."""
    import math

    pairs = []
    for bound, declared, outward in ((r.lower, r.min, -math.inf), (r.upper, r.max, math.inf)):
        if bound is None:
            continue
        pairs.append((declared, True))
        if integer:
            pairs.append((declared + (1 if outward > 0 else -1), False))
        else:
            pairs.append((bound.value if not bound.closed else math.nextafter(bound.value, outward), False))
    return pairs


def _exit_initialization(fmu, values: dict) -> tuple[bool, list[str]]:
    """Set values in initialisation mode; True if fmi2ExitInitializationMode accepts them,
    False if it returns fmi2Error (any other failure is raised), with the FMU's log."""
    from fmpy.fmi1 import FMICallException

    from conftest import Slave

    slave = Slave(fmu)
    try:
        slave.s.setupExperiment(startTime=0.0)
        slave.s.enterInitializationMode()
        for name, value in values.items():
            v = fmu.vars[name]
            if v.type == "Real":
                slave.s.setReal([v.valueReference], [float(value)])
            else:
                slave.s.setInteger([v.valueReference], [int(value)])
        try:
            slave.s.exitInitializationMode()
        except FMICallException as exc:
            assert exc.status == 3, exc  # fmi2Error
            return False, slave.messages
        return True, slave.messages
    finally:
        slave.close()


def test_the_fmu_accepts_every_declared_range_and_rejects_what_lies_beyond(fmu):
    """For every RANGE line: the FMU's own checks (model_validate, ground_validate, the codes)
    accept the declared min and max and reject the next value outside, at
    fmi2ExitInitializationMode, with a message naming the variable."""
    variables, _, ranges, _ = _tables()
    types = {v.name: v.type for v in variables}
    checked = 0
    for name, r in ranges.items():
        context = RANGE_CONTEXT.get(name, {})
        for value, accepted in _outside_and_inside(r, types[name] == "Integer"):
            ok, log = _exit_initialization(fmu, {**context, name: value})
            assert ok == accepted, f"{name} = {value!r}: {'rejected' if accepted else 'accepted'} ({log[-1:]})"
            if not accepted:
                # the variable, or its block ("block1 half sizes 1e-06 x 0.3 m must be in ...")
                assert any("invalid parameter" in m and (name in m or name.split(".")[0] + " " in m) for m in log), \
                    (name, log)
            checked += 1
    assert checked >= 4 * len(ranges) - 2 * sum((r.lower is None) + (r.upper is None) for r in ranges.values())


def test_every_range_line_names_a_parameter_and_a_code_spans_its_enumeration():
    from fmu_build.variables import check_tables

    variables, enumerations, ranges, codes = _tables()
    check_tables(variables, enumerations, ranges, codes)  # what the build checks
    assert set(codes) <= set(ranges)
    assert set(codes.values()) == {"excitation.kind", "restitution.law", "solver.method", "contact.model", "support.kind"}


# ------------------------------------------------------------------ make release

def test_release_installs_the_cross_compiler_as_root_or_says_in_one_line_why_it_cannot(tmp_path, monkeypatch):
    """fmu_build.release (make release): without mingw-w64 and not root, or as root when the
    install does not bring it, a reason to print; as root, the install commands run and, once
    they put the compiler on the PATH, nothing is skipped. The install command here writes a
    stand-in compiler, instead of apt-get."""
    from fmu_build.release import PACKAGE, ensure_win64_compiler

    monkeypatch.setenv("CC_WIN64", "rocking-test-mingw-gcc")
    monkeypatch.setenv("PATH", f"{tmp_path}{os.pathsep}{os.environ['PATH']}")
    reason = ensure_win64_compiler(is_root=False, attempts=())
    assert reason == f"rocking-test-mingw-gcc is not installed and this is not root (sudo apt-get install {PACKAGE})"
    reason = ensure_win64_compiler(is_root=True, attempts=((["false"],), (["true"],)))
    assert reason == f"rocking-test-mingw-gcc is not installed and apt-get install {PACKAGE} did not install it"
    fake = tmp_path / "rocking-test-mingw-gcc"
    install = ["sh", "-c", f"printf '#!/bin/sh\\n' > '{fake}' && chmod +x '{fake}'"]
    assert ensure_win64_compiler(is_root=True, attempts=((["false"],), (install,))) is None
    assert fake.is_file()
    assert ensure_win64_compiler(is_root=False, attempts=()) is None  # there now: nothing to do


def test_make_release_builds_every_fmu_with_the_platforms_given():
    """The Makefile's release target goes through fmu_build.release, which hands --platforms to
    python -m fmu_build, which gives it to every build (the FMI 3.0 one too)."""
    import ast
    import inspect

    from fmu_build import __main__ as entry

    makefile = (Path(__file__).parent.parent / "Makefile").read_text()
    assert "\nrelease: " in makefile and "-m fmu_build.release" in makefile
    calls = [node for node in ast.walk(ast.parse(inspect.getsource(entry.main)))
             if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id.startswith("build")]
    assert len(calls) >= 2  # the FMI 2.0 and FMI 3.0 builds, and any other FMU's
    for call in calls:
        given = {k.arg: ast.unparse(k.value) for k in call.keywords}
        assert given.get("platforms") == "args.platforms", f"{call.func.id} is not given --platforms"


def test_the_fmi3_build_takes_the_platforms_of_the_fmi2_build(tmp_path, monkeypatch):
    from fmu_build.build import BuildError
    from fmu_build.build3 import build_fmu3

    out = build_fmu3(tmp_path / "RockingBlock3.fmu", platforms=["linux64"])
    assert [n for n in zipfile.ZipFile(out).namelist() if n.startswith("binaries/")] == [
        "binaries/x86_64-linux/RockingBlock3.so"]
    monkeypatch.setenv("CC_WIN64", "x86_64-w64-mingw32-gcc-not-installed")
    with pytest.raises(BuildError, match="cross compiler 'x86_64-w64-mingw32-gcc-not-installed' is not installed"):
        build_fmu3(tmp_path / "other.fmu", platforms=["linux64", "win64"])


@pytest.mark.parametrize("edition", ["FMI 2.0", "FMI 3.0"])
def test_the_fmu_manipulation_toolbox_check_finds_nothing(edition, request):
    """A second opinion beside fmpy validate (tests/test_fmu_interface.py, tests/test_fmi3.py):
    fmutool -check (pip fmu-manipulation-toolbox), its schema and semantic checks. The FMU
    Compliance Checker (FMIL) has no package on PyPI or Debian."""
    import shutil
    import subprocess
    import sys

    tool = Path(sys.executable).parent / "fmutool"
    if not tool.exists():
        tool = shutil.which("fmutool")
    if not tool:
        pytest.skip("fmutool is not installed (pip fmu-manipulation-toolbox, in the test extra)")
    path = request.getfixturevalue("fmu_path" if edition == "FMI 2.0" else "fmu3_path")
    proc = subprocess.run([str(tool), "-input", str(path), "-check"], capture_output=True, text=True, timeout=300)
    out = proc.stdout + proc.stderr
    version = edition.split()[1]
    assert proc.returncode == 0, out
    assert f"compliant with FMI-{version}" in out and f"No semantic error against the FMI-{version[0]} standard" in out, out
    assert "ERROR" not in out and "WARNING" not in out, out
