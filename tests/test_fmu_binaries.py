"""The FMU's binaries: the Linux one loads on glibc 2.17 or newer; the Windows one (cross-compiled
with mingw-w64) exports the FMI functions the Linux one does, needs only Windows' own DLLs and,
run under wine by the C harness tests/harness/fmi2_harness.c, computes what the Linux one does,
which the same harness checks against fmpy. The FMI 3.0 edition's x86_64-windows binary likewise,
through tests/harness/fmi3_harness.c."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import time
import urllib.parse
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from fmu_build.build import MODEL_IDENTIFIER, fmi_headers_dir, win64_compiler
from tests.conftest import PATIENCE

HARNESS = Path(__file__).parent / "harness" / "fmi2_harness.c"
GLIBC_FLOOR = (2, 17)
STOP, STEP = 5.0, 0.01
OUTPUTS = ("block1.theta", "block1.omega", "impacts")
FREE_ROCKING = {"block1.theta0": 0.1}
CROSS_OBJDUMP = "x86_64-w64-mingw32-objdump"
# the DLLs every Windows has: the FMU may import nothing else (no libgcc_s, no libwinpthread)
SYSTEM_DLLS = re.compile(r"(kernel32|msvcrt|ucrtbase|api-ms-win-.*)\.dll", re.IGNORECASE)


@pytest.fixture(scope="module")
def unpacked(fmu_path, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("unpacked")
    zipfile.ZipFile(fmu_path).extractall(folder)
    return folder


@pytest.fixture(scope="module")
def so(unpacked) -> Path:
    path = unpacked / "binaries" / "linux64" / f"{MODEL_IDENTIFIER}.so"
    assert path.is_file(), "the FMU has no linux64 binary"
    return path


@pytest.fixture(scope="module")
def dll(unpacked) -> Path:
    path = unpacked / "binaries" / "win64" / f"{MODEL_IDENTIFIER}.dll"
    if not path.is_file():
        if win64_compiler() is None:
            pytest.skip("x86_64-w64-mingw32-gcc is not installed (Debian: gcc-mingw-w64-x86-64; .ci/run installs "
                        "it), so the FMU has no win64 binary")
        if os.environ.get("ROCKING_FMU"):
            pytest.skip("the FMU named by ROCKING_FMU has no win64 binary")
        pytest.fail("the mingw-w64 cross compiler is installed, but the FMU has no win64 binary")
    return path


def _tool(name: str, package: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.skip(f"{name} is not installed (Debian: {package})")
    return path


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in text.split("."))


# ------------------------------------------------------------------------- linux64

@pytest.fixture(scope="module")
def so3(fmu3_path, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("unpacked3")
    zipfile.ZipFile(fmu3_path).extractall(folder)
    path = folder / "binaries" / "x86_64-linux" / "RockingBlock3.so"
    assert path.is_file(), "the FMI 3.0 FMU has no x86_64-linux binary"
    return path


@pytest.mark.parametrize("edition", ["FMI 2.0", "FMI 3.0"])
def test_the_linux_binary_needs_no_glibc_newer_than_2_17(edition, request):
    so = request.getfixturevalue("so" if edition == "FMI 2.0" else "so3")
    objdump = _tool("objdump", "binutils")
    symbols = subprocess.run([objdump, "-T", str(so)], capture_output=True, text=True, check=True).stdout
    if "__asan_init" in symbols:
        pytest.skip("a sanitizer build (make sanitize): it needs the build machine's sanitizer runtime anyway")
    # every versioned dynamic symbol ("(GLIBC_2.2.5) memcpy", "GLIBC_2.29 exp"), and the version
    # references, the versions the dynamic loader checks for before it loads the binary
    needed = re.findall(r"\bGLIBC_(\d+(?:\.\d+)+)\)?\s+(\S+)\s*$", symbols, re.MULTILINE)
    headers = subprocess.run([objdump, "-p", str(so)], capture_output=True, text=True, check=True).stdout
    needed += [(v, "version reference") for v in re.findall(r"^\s+0x\w+ 0x\w+ \d+ GLIBC_(\d+(?:\.\d+)+)\s*$",
                                                               headers, re.MULTILINE)]
    assert any(name == "version reference" for _, name in needed), headers
    assert len(needed) > 10, symbols  # the math and string functions: the parse found them
    too_new = sorted({f"GLIBC_{v} ({name})" for v, name in needed if _version(v) > GLIBC_FLOOR})
    assert too_new == [], f"needs a glibc newer than {'.'.join(map(str, GLIBC_FLOOR))}: {too_new}"


# ------------------------------------------------------------------------- win64

def _linux_exports(so: Path) -> set[str]:
    nm = _tool("nm", "binutils")
    out = subprocess.run([nm, "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    return {line.split()[-1] for line in out.splitlines() if line.split()[1:2] == ["T"]}


def _pe_tables(dll: Path) -> tuple[set[str], set[str]]:
    """The names a PE binary exports and the DLLs it imports, read by mingw-w64's objdump."""
    objdump = _tool(CROSS_OBJDUMP, "binutils-mingw-w64-x86-64")
    out = subprocess.run([objdump, "-p", str(dll)], capture_output=True, text=True, check=True).stdout
    table = out.split("[Ordinal/Name Pointer] Table", 1)[1] if "[Ordinal/Name Pointer] Table" in out else ""
    exports = set(re.findall(r"^\s+\[\s*\d+\]\s+(\S+)\s*$", table.split("\n\n", 1)[0], re.MULTILINE))
    imports = set(re.findall(r"^\s*DLL Name: (\S+)\s*$", out, re.MULTILINE))
    return exports, imports


def test_the_windows_binary_exports_the_fmi_functions_the_linux_binary_does(so, dll):
    exports, imports = _pe_tables(dll)
    linux = _linux_exports(so)
    assert {"fmi2Instantiate", "fmi2DoStep", "fmi2GetReal"} <= linux
    assert all(name.startswith("fmi2") for name in linux), linux
    assert exports == linux
    assert imports and all(SYSTEM_DLLS.fullmatch(name) for name in imports), imports


# ------------------------------------------------------------------------- the harness

def _compile(cc: str, out: Path, *extra: str, harness: Path = HARNESS, fmi: str = "2") -> Path:
    cmd = [cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-I", str(fmi_headers_dir(fmi)), "-o", str(out), str(harness),
           *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0 and not proc.stderr.strip(), proc.stderr
    return out


@pytest.fixture(scope="module")
def native_harness(tmp_path_factory) -> Path:
    return _compile(os.environ.get("CC", "cc"), tmp_path_factory.mktemp("harness") / "fmi2_harness", "-ldl")


@pytest.fixture(scope="module")
def windows_harness(dll, tmp_path_factory) -> Path:
    # mingw's own printf and strtod (C99 formatting, correct rounding), not msvcrt's
    return _compile(win64_compiler(), tmp_path_factory.mktemp("harness") / "fmi2_harness.exe",
                    "-D__USE_MINGW_ANSI_STDIO=1", "-static-libgcc")


@pytest.fixture(scope="module")
def model(fmu_path) -> tuple[str, dict]:
    """The FMU's GUID, and its variables by name."""
    md = read_model_description(str(fmu_path))
    return md.guid, {v.name: v for v in md.modelVariables}


def _exec(cmd: list[str], env=None, timeout: float = PATIENCE) -> subprocess.CompletedProcess:
    """Run cmd; its output goes through files, not pipes: wine's own processes (services.exe,
    winedevice.exe), which the first Windows program starts, inherit its standard handles and
    outlive it by seconds, so reading a pipe to its end would wait for them too."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, env=env, timeout=timeout)
        out.seek(0)
        err.seek(0)
        return subprocess.CompletedProcess(cmd, proc.returncode, out.read().decode(errors="replace"),
                                           err.read().decode(errors="replace"))


def _run(cmd: list[str], binary: str, model, settings: dict, resources: str = "", env=None,
         timeout: float = PATIENCE) -> dict[str, np.ndarray]:
    """Run the harness on binary: the outputs OUTPUTS at 0, STEP, ..., STOP."""
    guid, variables = model
    outs = ",".join(("i" if variables[n].type == "Integer" else "r") + str(variables[n].valueReference)
                    for n in OUTPUTS)
    args = []
    for name, value in settings.items():
        v = variables[name]
        args.append({"Real": "r", "Integer": "i", "Enumeration": "i", "String": "s"}[v.type] + f"{v.valueReference}={value}")
    proc = _exec([*cmd, binary, guid, resources, repr(STOP), repr(STEP), outs, *args], env=env, timeout=timeout)
    assert proc.returncode == 0, f"exit status {proc.returncode}:\n{proc.stderr[-3000:]}"
    rows = np.array([line.split() for line in proc.stdout.splitlines()], dtype=float)
    assert rows.shape == (round(STOP / STEP) + 1, 1 + len(OUTPUTS)), proc.stdout[-2000:]
    return {"time": rows[:, 0], **{name: rows[:, 1 + k] for k, name in enumerate(OUTPUTS)}}


def _assert_same(a: dict, b: dict, atol: float = 1e-12):
    np.testing.assert_array_equal(a["time"], b["time"])
    np.testing.assert_array_equal(a["impacts"], b["impacts"])
    for name in ("block1.theta", "block1.omega"):
        np.testing.assert_allclose(a[name], b[name], rtol=0, atol=atol, err_msg=name)


def test_the_harness_on_the_linux_binary_agrees_with_fmpy(native_harness, so, model, fmu_path):
    mine = _run([str(native_harness)], str(so), model, FREE_ROCKING)
    ref = simulate_fmu(str(fmu_path), start_values=FREE_ROCKING, stop_time=STOP, output_interval=STEP,
                       output=list(OUTPUTS))
    assert mine["impacts"][-1] > 10  # it rocks
    _assert_same(mine, {"time": ref["time"], **{n: ref[n] for n in OUTPUTS}})


# ------------------------------------------------------------------------- wine

def _wine() -> str | None:
    for name in ("wine64", "wine"):
        if shutil.which(name):
            return shutil.which(name)
    return "/usr/lib/wine/wine64" if os.access("/usr/lib/wine/wine64", os.X_OK) else None  # Debian's wine64 alone


@pytest.fixture(scope="module")
def wine(windows_harness):
    """The command that runs a Windows program: wine, in a temporary prefix (made by the first
    start, which takes several seconds and writes about 700 MB), shut down and removed after."""
    exe = _wine()
    if exe is None:
        pytest.skip("wine is not installed (Debian: wine64; .ci/run installs it)")
    prefix = Path(tempfile.mkdtemp(prefix="rocking-wine-"))
    # quiet, and no offer to install wine's .NET and HTML engines into the new prefix
    env = {**os.environ, "WINEPREFIX": str(prefix), "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    try:
        start = time.monotonic()
        try:
            proc = _exec([exe, str(windows_harness)], env=env, timeout=PATIENCE)
        except subprocess.TimeoutExpired:
            pytest.skip("wine did not start a Windows program within 600 s")
        if "usage: fmi2_harness" not in proc.stderr:
            pytest.skip(f"wine cannot run a Windows program here (exit status {proc.returncode}): "
                        f"{proc.stderr.strip()[-500:]}")
        print(f"wine's first start (a new prefix): {time.monotonic() - start:.1f} s")
        yield [exe, str(windows_harness)], env
    finally:
        server = shutil.which("wineserver") or str(Path(exe).resolve().parent / "wineserver")
        subprocess.run([server, "-k"], env=env, capture_output=True, timeout=PATIENCE)
        shutil.rmtree(prefix, ignore_errors=True)


def test_the_windows_binary_under_wine_computes_what_the_linux_binary_does(wine, native_harness, so, dll, model):
    cmd, env = wine
    linux = _run([str(native_harness)], str(so), model, FREE_ROCKING)
    windows = _run(cmd, str(dll), model, FREE_ROCKING, env=env)
    assert linux["impacts"][-1] > 10
    _assert_same(linux, windows)


def _windows_path(path: Path) -> str:
    """path as Windows programs under wine see it: on drive Z:, with backslashes."""
    return "Z:" + str(path).replace("/", "\\")


def test_the_windows_binary_reads_a_record_by_a_windows_path_or_from_its_resources(
        wine, native_harness, so, dll, model, tmp_path):
    cmd, env = wine
    resources = tmp_path / "an FMU" / "resources"  # a space: %20 in the resources URI
    (resources / "records").mkdir(parents=True)
    t = np.arange(0.0, 3.0 + 1e-9, 0.005)
    a = np.where(t < 1.0, 5.0 * np.sin(2 * np.pi * 2.0 * t), 0.0)  # lifts the default block (a > g b/h)
    record = resources / "records" / "pulse.txt"
    np.savetxt(record, np.column_stack([t, a]), fmt="%.17g")
    scene = {"excitation.kind": 4}
    linux = _run([str(native_harness)], str(so), model, {**scene, "excitation.file": str(record)})
    assert linux["impacts"][-1] > 0
    by_drive_path = _run(cmd, str(dll), model, {**scene, "excitation.file": _windows_path(record)}, env=env)
    relative = _run(cmd, str(dll), model, {**scene, "excitation.file": "records\\pulse.txt"},
                    resources="file:///" + urllib.parse.quote(_windows_path(resources).replace("\\", "/"), safe="/:"),
                    env=env)
    _assert_same(linux, by_drive_path)
    _assert_same(linux, relative)


# ------------------------------------------------------------------------- FMI 3.0 win64

HARNESS3 = Path(__file__).parent / "harness" / "fmi3_harness.c"
PULSE = {"block1.theta0": 0.0, "excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0}
STACK = {"nBlocks": 2, "block1.theta0": 0.05, "block2.theta0": 0.12}


@pytest.fixture(scope="module")
def unpacked3(fmu3_path, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("unpacked3w")
    zipfile.ZipFile(fmu3_path).extractall(folder)
    return folder


@pytest.fixture(scope="module")
def dll3(unpacked3) -> Path:
    path = unpacked3 / "binaries" / "x86_64-windows" / "RockingBlock3.dll"
    if not path.is_file():
        if win64_compiler() is None:
            pytest.skip("x86_64-w64-mingw32-gcc is not installed (Debian: gcc-mingw-w64-x86-64), so the FMI 3.0 "
                        "FMU has no x86_64-windows binary")
        if os.environ.get("ROCKING_FMU3"):
            pytest.skip("the FMU named by ROCKING_FMU3 has no x86_64-windows binary")
        pytest.fail("the mingw-w64 cross compiler is installed, but the FMI 3.0 FMU has no x86_64-windows binary")
    return path


def test_the_fmi3_windows_binary_exports_the_fmi_functions_the_linux_binary_does(unpacked3, dll3):
    so3 = unpacked3 / "binaries" / "x86_64-linux" / "RockingBlock3.so"
    exports, imports = _pe_tables(dll3)
    linux = _linux_exports(so3)
    assert {"fmi3InstantiateCoSimulation", "fmi3DoStep", "fmi3GetInt64", "fmi3SetInt64"} <= linux
    assert all(name.startswith("fmi3") for name in linux), linux
    assert exports == linux
    assert imports and all(SYSTEM_DLLS.fullmatch(name) for name in imports), imports


@pytest.fixture(scope="module")
def native_harness3(tmp_path_factory) -> Path:
    return _compile(os.environ.get("CC", "cc"), tmp_path_factory.mktemp("harness3") / "fmi3_harness", "-ldl",
                    harness=HARNESS3, fmi="3")


@pytest.fixture(scope="module")
def windows_harness3(dll3, tmp_path_factory) -> Path:
    return _compile(win64_compiler(), tmp_path_factory.mktemp("harness3") / "fmi3_harness.exe",
                    "-D__USE_MINGW_ANSI_STDIO=1", "-static-libgcc", harness=HARNESS3, fmi="3")


@pytest.fixture(scope="module")
def model3(fmu3_path) -> tuple[str, dict]:
    """The FMI 3.0 FMU's instantiationToken, and its variables by name."""
    md = read_model_description(str(fmu3_path))
    return md.instantiationToken, {v.name: v for v in md.modelVariables}


def _run3(cmd: list[str], binary: str, model3, settings: dict, outputs: tuple[str, ...], resources: str = "",
          env=None) -> dict[str, np.ndarray]:
    """Run the FMI 3.0 harness on binary: the outputs at 0, STEP, ..., STOP."""
    token, variables = model3
    outs = ",".join(("i" if variables[n].type == "Int32" else "r") + str(variables[n].valueReference) for n in outputs)
    args = [{"Float64": "r", "Int32": "i", "Enumeration": "e", "String": "s"}[variables[n].type]
            + f"{variables[n].valueReference}={value}" for n, value in settings.items()]
    proc = _exec([*cmd, binary, token, resources, repr(STOP), repr(STEP), outs, *args], env=env)
    assert proc.returncode == 0, f"exit status {proc.returncode}:\n{proc.stderr[-3000:]}"
    rows = np.array([line.split() for line in proc.stdout.splitlines()], dtype=float)
    assert rows.shape == (round(STOP / STEP) + 1, 1 + len(outputs)), proc.stdout[-2000:]
    return {"time": rows[:, 0], **{name: rows[:, 1 + k] for k, name in enumerate(outputs)}}


def test_the_fmi3_harness_on_the_linux_binary_agrees_with_fmpy(native_harness3, unpacked3, model3, fmu3_path):
    so3 = unpacked3 / "binaries" / "x86_64-linux" / "RockingBlock3.so"
    mine = _run3([str(native_harness3)], str(so3), model3, PULSE, OUTPUTS)
    ref = simulate_fmu(str(fmu3_path), start_values=PULSE, stop_time=STOP, output_interval=STEP, output=list(OUTPUTS))
    assert mine["impacts"][-1] > 10  # the pulse sets it rocking: excitation.kind reached the FMU
    _assert_same(mine, {"time": ref["time"], **{n: ref[n] for n in OUTPUTS}})


def test_the_fmi3_windows_binary_under_wine_computes_what_the_linux_binary_does(
        wine, windows_harness3, native_harness3, unpacked3, dll3, model3, tmp_path):
    """Three scenes to 1e-12: a built-in pulse (an Enumeration set with fmi3SetInt64), a record
    file (by a Windows path, and relative to the resources folder) and a two-block stack."""
    (exe, _), env = wine
    so3 = str(unpacked3 / "binaries" / "x86_64-linux" / "RockingBlock3.so")
    resources = tmp_path / "an FMU" / "resources"
    (resources / "records").mkdir(parents=True)
    t = np.arange(0.0, 3.0 + 1e-9, 0.005)
    record = resources / "records" / "pulse.txt"
    np.savetxt(record, np.column_stack([t, np.where(t < 1.0, 5.0 * np.sin(2 * np.pi * 2.0 * t), 0.0)]), fmt="%.17g")
    stack_outputs = OUTPUTS + ("block2.theta", "impactsInterface")
    for settings, outputs, win_settings, win_resources in [
        (PULSE, OUTPUTS, PULSE, ""),
        ({"excitation.kind": 4, "excitation.file": str(record)}, OUTPUTS,
         {"excitation.kind": 4, "excitation.file": _windows_path(record)}, ""),
        ({"excitation.kind": 4, "excitation.file": str(record)}, OUTPUTS,
         {"excitation.kind": 4, "excitation.file": "records\\pulse.txt"}, _windows_path(resources) + "\\"),
        (STACK, stack_outputs, STACK, ""),
    ]:
        linux = _run3([str(native_harness3)], so3, model3, settings, outputs)
        windows = _run3([exe, str(windows_harness3)], str(dll3), model3, win_settings, outputs,
                        resources=win_resources, env=env)
        assert linux["impacts"][-1] > 0, settings
        _assert_same(linux, windows)
        for name in outputs[3:]:
            np.testing.assert_allclose(linux[name], windows[name], rtol=0, atol=1e-12, err_msg=name)
