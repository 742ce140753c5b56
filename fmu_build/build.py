"""Compile model/c into RockingBlock.fmu: binaries/linux64 with the system C compiler and, where
Debian's mingw-w64 cross compiler is installed, binaries/win64 with it."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from fmu_build.documentation import DOCS, PAGES, documentation_html
from fmu_build.variables import check_tables, read_codes, read_enumerations, read_ranges, read_variables

MODEL_IDENTIFIER = "RockingBlock"
ROOT = Path(__file__).resolve().parent.parent
C_DIR = ROOT / "model" / "c"
C_SOURCES = ["fmi2.c", "instance.c", "me.c", "model.c", "ground.c", "record.c", "solver.c", "stack.c", "stack_solver.c", "events.c",
             "taylor.c", "integrator.c", "contact.c",
             "engine.c", "engine_solver.c", "lcp.c", "support.c", "support_rest.c", "coupling.c"]
C_HEADERS = ["instance.h", "me.h", "model.h", "ground.h", "record.h", "solver.h", "stack.h", "stack_solver.h", "events.h", "taylor.h",
             "integrator.h", "contact.h", "engine.h", "engine_solver.h", "lcp.h", "support.h", "coupling.h", "codes.h", "variables.def"]
VERSION = "0.1.0"

CFLAGS = ["-std=c99", "-O3", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra"]
SANITIZE_FLAGS = [
    "-std=c99", "-O1", "-g", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra",
    "-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=undefined",
]
# win64: the FMI functions are exported by FMI2_Export (__declspec(dllexport)) alone; libgcc
# linked in, so that the DLL needs only Windows' own DLLs (KERNEL32, msvcrt); -s: without the
# debugging sections of mingw-w64's static libraries (two thirds of the DLL)
WIN64_CC = "x86_64-w64-mingw32-gcc"
WIN64_CFLAGS = ["-std=c99", "-O3", "-shared", "-Wall", "-Wextra", "-static-libgcc", "-s"]
PLATFORMS = ("linux64", "win64")
BINARY_SUFFIX = {"linux64": ".so", "win64": ".dll"}

# Pins the glibc symbol versions of the linux64 binary to ones glibc 2.17 has (see the header)
GLIBC_COMPAT = Path(__file__).resolve().parent / "glibc_compat"
GLIBC_COMPAT_FILES = ["glibc_2_17.h", "glibc_2_17.c"]


class BuildError(RuntimeError):
    """The FMU could not be built (compiler missing or compilation failed)."""


def default_fmu_path(sanitize: bool = False, model_identifier: str = MODEL_IDENTIFIER) -> Path:
    """Where ``python -m fmu_build`` puts the FMU of ``model_identifier``."""
    name = f"{model_identifier}-sanitize.fmu" if sanitize else f"{model_identifier}.fmu"
    return ROOT / "build" / name


def fmi_headers_dir(version: str = "2") -> Path:
    """The FMI headers (version "2" or "3") that ship inside the installed fmpy package."""
    import fmpy

    path = Path(fmpy.__file__).parent / "c-code"
    if not (path / f"fmi{version}Functions.h").is_file():
        raise BuildError(f"FMI {version}.0 headers not found in the fmpy package at {path}")
    return path


def _sources_digest() -> str:
    h = hashlib.sha256()
    for name in C_SOURCES + C_HEADERS:
        h.update(name.encode())
        h.update((C_DIR / name).read_bytes())
    for name in ("build.py", "documentation.py", "model_description.py", "model_structure.py", "variables.py"):
        h.update((Path(__file__).parent / name).read_bytes())
    for page in PAGES:
        h.update((DOCS / page).read_bytes())
    for name in GLIBC_COMPAT_FILES:
        h.update((GLIBC_COMPAT / name).read_bytes())
    return h.hexdigest()


def _targets_x86_64_glibc(cc: str) -> bool:
    proc = subprocess.run([cc, "-dumpmachine"], capture_output=True, text=True)
    return proc.returncode == 0 and proc.stdout.strip().startswith(("x86_64-linux-gnu", "x86_64-pc-linux-gnu"))


def compile_binary(sources: list[Path], out: Path, platform: str, cc: str, flags: list[str],
                   include_dirs: Iterable[Path] = ()) -> str:
    """Compile ``sources`` into the shared library ``out`` for ``platform`` (linux64: a .so,
    win64: a .dll) with the compiler ``cc`` and ``flags``; return what the compiler warned
    (empty if nothing).

    linux64 with a compiler for x86_64 glibc gets the glibc_compat files, so that the binary
    loads on glibc 2.17 or newer; not a sanitizer build (``-fsanitize``), which needs the build
    machine's sanitizer runtime anyway, and whose runtime defines __xstat too, which the linker
    then leaves an empty PLT relocation for. Raises BuildError with the compiler's messages if
    it fails.
    """
    if platform not in PLATFORMS:
        raise BuildError(f"unknown platform '{platform}' (known: {', '.join(PLATFORMS)})")
    cmd = [cc, *flags]
    for d in include_dirs:
        cmd += ["-I", str(d)]
    cmd += ["-o", str(out), *map(str, sources)]
    if platform == "linux64":
        if not any(f.startswith("-fsanitize") for f in flags) and _targets_x86_64_glibc(cc):
            cmd[1:1] = ["-include", str(GLIBC_COMPAT / "glibc_2_17.h")]
            cmd.append(str(GLIBC_COMPAT / "glibc_2_17.c"))
        cmd.append("-lm")
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as exc:
        raise BuildError(f"{platform}: cannot run the C compiler '{cc}': {exc}") from None
    if proc.returncode != 0:
        raise BuildError(f"{platform}: compilation failed:\n{proc.stderr.strip()}")
    return proc.stderr.strip()


def _win64_cc_name() -> str:
    return os.environ.get("CC_WIN64", WIN64_CC)


def win64_compiler() -> str | None:
    """The mingw-w64 cross compiler for win64 (CC_WIN64, else x86_64-w64-mingw32-gcc), if installed."""
    cc = _win64_cc_name()
    return cc if shutil.which(cc) else None


def build_stamp(out: Path, sources_digest: str, wanted: list[str], compilers: dict[str, tuple[str | None, list[str]]],
                platforms: list[str] | None, sanitize: bool = False, folder: dict[str, str] | None = None,
                force: bool = False) -> tuple[Path, str, bool]:
    """The sha256 stamp next to ``out``, the digest of this build (sources, compilers, flags and
    platforms, each named by its folder) and whether ``out`` is already that build. When it is to
    be built without a Windows binary for want of the cross compiler, a one-line note says so."""
    line = " ".join(f"{(folder or {}).get(p, p)}: {compilers[p][0]} {' '.join(compilers[p][1])};" for p in wanted)
    digest = hashlib.sha256((sources_digest + line).encode()).hexdigest()
    stamp = out.with_name(out.name + ".sha256")
    current = not force and out.is_file() and stamp.is_file() and stamp.read_text().strip() == digest
    if not current and not sanitize and platforms is None and compilers["win64"][0] is None:
        print(f"note: {_win64_cc_name()} not found, so {out.name} has no Windows binary "
              "(Debian: apt-get install gcc-mingw-w64-x86-64)", file=sys.stderr)
    return stamp, digest, current


def compile_platforms(sources: list[Path], root: Path, identifier: str, wanted: list[str],
                      compilers: dict[str, tuple[str | None, list[str]]], include_dirs: list[Path],
                      folder: dict[str, str] | None = None) -> None:
    """Compile ``sources`` for every platform of ``wanted``, the compilers side by side, into
    root/binaries/<folder of the platform>/<identifier>.so or .dll (folder: FMI 2.0's platform
    names unless given, e.g. FMI 3.0's x86_64-linux); print what the compilers warned."""
    jobs = []
    with ThreadPoolExecutor(max_workers=len(wanted)) as pool:
        for platform in wanted:
            bindir = root / "binaries" / (folder or {}).get(platform, platform)
            bindir.mkdir(parents=True)
            pcc, flags = compilers[platform]
            jobs.append(pool.submit(compile_binary, sources, bindir / (identifier + BINARY_SUFFIX[platform]),
                                    platform, pcc, flags, include_dirs))
    for job in jobs:
        warnings = job.result()
        if warnings:
            print(warnings)


def zip_fmu(root: Path, out: Path, stamp: Path, digest: str) -> Path:
    """Zip the folder ``root`` into the FMU ``out`` (through a .part file of this process, so that
    builds side by side, e.g. test workers, do not mix) and record ``digest`` in ``stamp``."""
    partial = out.with_name(f"{out.name}.{os.getpid()}.part")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(root.rglob("*")):
            if path.is_file():
                zf.write(path, path.relative_to(root).as_posix())
    partial.replace(out)
    stamp.write_text(digest + "\n")
    return out


def build_platforms(platforms: list[str] | None, sanitize: bool, cc: str
                    ) -> tuple[list[str], dict[str, tuple[str | None, list[str]]]]:
    """The binaries to build (of PLATFORMS) and each platform's compiler and flags, for both
    editions: ``platforms`` if given (an error if one cannot be built), else linux64, and win64
    too where the mingw-w64 cross compiler is installed; the sanitizer build is linux64 only."""
    if shutil.which(cc) is None:
        raise BuildError(f"C compiler '{cc}' not found (set CC or install gcc)")
    wincc = win64_compiler()
    wanted = list(dict.fromkeys(platforms)) if platforms else None
    for p in wanted or ():
        if p not in PLATFORMS:
            raise BuildError(f"unknown platform '{p}' (known: {', '.join(PLATFORMS)})")
    if sanitize and wanted and wanted != ["linux64"]:
        raise BuildError("the sanitizer build is for linux64 only")
    if wanted and "win64" in wanted and wincc is None:
        raise BuildError(f"win64: the cross compiler '{_win64_cc_name()}' is not installed "
                         "(Debian: apt-get install gcc-mingw-w64-x86-64)")
    if wanted is None:
        wanted = ["linux64"] if sanitize or wincc is None else ["linux64", "win64"]
    return wanted, {"linux64": (cc, SANITIZE_FLAGS if sanitize else CFLAGS), "win64": (wincc, WIN64_CFLAGS)}


def build_fmu(
    out: Path | None = None,
    sanitize: bool = False,
    force: bool = False,
    cc: str | None = None,
    platforms: list[str] | None = None,
) -> Path:
    """Build the FMU if its sources changed; return its path.

    ``platforms`` lists the binaries to build (``linux64``, ``win64``); by default linux64,
    and win64 too where the mingw-w64 cross compiler is installed (else a one-line note says
    the FMU has no Windows binary). The sanitizer build is linux64 only.
    The build is skipped when ``out`` exists and was made from the same sources, flags and
    platforms (a sha256 stamp next to it records that).
    """
    out = Path(out) if out else default_fmu_path(sanitize)
    cc = cc or os.environ.get("CC", "cc")
    wanted, compilers = build_platforms(platforms, sanitize, cc)
    sources_digest = _sources_digest()
    stamp, digest, current = build_stamp(out, sources_digest, wanted, compilers, platforms, sanitize, force=force)
    if current:
        return out

    from fmu_build.model_description import model_description  # only to build: it loads xml.sax and urllib

    guid = "{" + str(uuid.UUID(sources_digest[:32])) + "}"
    variables = read_variables(C_DIR / "variables.def")
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        for name in C_SOURCES + C_HEADERS:
            shutil.copy2(C_DIR / name, src / name)
        (src / "config.h").write_text(
            "/* Written by fmu_build: identifies this build of RockingBlock. */\n"
            "#ifndef ROCKING_CONFIG_H\n#define ROCKING_CONFIG_H\n"
            f'#define MODEL_GUID "{guid}"\n#endif\n'
        )
        enumerations = read_enumerations(C_DIR / "variables.def")
        ranges = read_ranges(C_DIR / "variables.def")
        check_tables(variables, enumerations, ranges, read_codes(C_DIR / "variables.def"))
        (root / "modelDescription.xml").write_text(
            model_description(variables, MODEL_IDENTIFIER, guid, C_SOURCES, VERSION, enumerations, ranges)
        )
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(
            documentation_html(variables, enumerations, MODEL_IDENTIFIER, VERSION, ranges), encoding="utf-8")
        compile_platforms([src / s for s in C_SOURCES], root, MODEL_IDENTIFIER, wanted, compilers,
                          [src, fmi_headers_dir()])
        return zip_fmu(root, out, stamp, digest)
