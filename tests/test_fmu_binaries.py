"""The FMU's binaries: the Linux one loads on glibc 2.17 or newer."""

from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from fmu_build.build import MODEL_IDENTIFIER

GLIBC_FLOOR = (2, 17)


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
