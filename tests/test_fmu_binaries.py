"""The FMU's binaries: the Linux one loads on glibc 2.17 or newer; the Windows one (cross-compiled
with mingw-w64) exports the FMI functions the Linux one does and needs only Windows' own DLLs."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from fmu_build.build import MODEL_IDENTIFIER, win64_compiler

GLIBC_FLOOR = (2, 17)
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

def test_the_linux_binary_needs_no_glibc_newer_than_2_17(so):
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
