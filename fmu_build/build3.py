"""Compile model/c into RockingBlock3.fmu: the FMI 3.0 Co-Simulation edition.

The same C core as RockingBlock.fmu (every source of ``C_SOURCES`` but the FMI
2.0 layer ``fmi2.c``) with the FMI 3.0 layer ``fmi3.c``, compiled against the
FMI 3.0 headers shipped in fmpy, for the platforms the FMI 2.0 build chooses
(:func:`fmu_build.build.build_platforms`: x86_64-linux, and x86_64-windows with
mingw-w64). Like :func:`fmu_build.build.build_fmu`, it rebuilds only when the
sources changed (a sha256 stamp next to the FMU).
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import tempfile
import uuid
from pathlib import Path

from fmu_build.build import (C_DIR, C_HEADERS, C_SOURCES, VERSION, BuildError, _sources_digest, build_platforms,
                             build_stamp, compile_platforms, default_fmu_path, fmi_headers_dir, zip_fmu)
from fmu_build.documentation import documentation_html
from fmu_build.variables import check_tables, read_codes, read_enumerations, read_ranges, read_variables

MODEL_IDENTIFIER3 = "RockingBlock3"
C_SOURCES3 = ["fmi3.c"] + [s for s in C_SOURCES if s != "fmi2.c"]


def default_fmu3_path(sanitize: bool = False) -> Path:
    """Where ``python -m fmu_build`` puts the FMI 3.0 FMU."""
    return default_fmu_path(sanitize, MODEL_IDENTIFIER3)


# the FMI 2.0 platform names of build.py and FMI 3.0's platform tuples
WINDOWS_TUPLE = "x86_64-windows"


def platform_tuple() -> str:
    """FMI 3.0's name of this machine's platform (binaries/<tuple>/), e.g. x86_64-linux."""
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}.get(
        platform.machine().lower())
    if platform.system() != "Linux" or arch is None:
        raise BuildError(f"building on {platform.system()} {platform.machine()} is not supported (Linux only)")
    return f"{arch}-linux"


def _sources_digest3() -> str:
    """The FMI 2.0 build's digest (every core source, the docs pages, the writers) and fmi3.c,
    build3.py and model_description3.py."""
    h = hashlib.sha256(_sources_digest().encode())
    h.update((C_DIR / "fmi3.c").read_bytes())
    for name in ("build3.py", "model_description3.py"):
        h.update((Path(__file__).parent / name).read_bytes())
    return h.hexdigest()


def build_fmu3(
    out: Path | None = None,
    sanitize: bool = False,
    force: bool = False,
    cc: str | None = None,
    platforms: list[str] | None = None,
) -> Path:
    """Build RockingBlock3.fmu if its sources changed; return its path. ``platforms`` as for
    :func:`fmu_build.build.build_fmu` (linux64, win64), the same default."""
    out = Path(out) if out else default_fmu3_path(sanitize)
    cc = cc or os.environ.get("CC", "cc")
    wanted, compilers = build_platforms(platforms, sanitize, cc)
    tuples = {"linux64": platform_tuple(), "win64": WINDOWS_TUPLE}
    sources_digest = _sources_digest3()
    stamp, digest, current = build_stamp(out, sources_digest, wanted, compilers, platforms, sanitize, tuples, force)
    if current:
        return out

    from fmu_build.model_description3 import build_description3, model_description3  # only to build

    token = "{" + str(uuid.UUID(sources_digest[:32])) + "}"
    variables = read_variables(C_DIR / "variables.def")
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        for name in C_SOURCES3 + C_HEADERS:
            shutil.copy2(C_DIR / name, src / name)
        (src / "config.h").write_text(
            "/* Written by fmu_build: identifies this build of RockingBlock3 (the instantiationToken). */\n"
            "#ifndef ROCKING_CONFIG_H\n#define ROCKING_CONFIG_H\n"
            f'#define MODEL_GUID "{token}"\n#endif\n'
        )
        (src / "buildDescription.xml").write_text(build_description3(MODEL_IDENTIFIER3, C_SOURCES3))
        enumerations = read_enumerations(C_DIR / "variables.def")
        ranges = read_ranges(C_DIR / "variables.def")
        check_tables(variables, enumerations, ranges, read_codes(C_DIR / "variables.def"))
        (root / "modelDescription.xml").write_text(
            model_description3(variables, MODEL_IDENTIFIER3, token, VERSION, enumerations, ranges))
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(
            documentation_html(variables, enumerations, MODEL_IDENTIFIER3, VERSION, ranges), encoding="utf-8")
        # the FMI 2.0 build's compiler calls: on x86_64 glibc, loadable on glibc 2.17 or newer; the
        # Windows DLL needing only Windows' own DLLs
        compile_platforms([src / name for name in C_SOURCES3], root, MODEL_IDENTIFIER3, wanted, compilers,
                          [src, fmi_headers_dir("3")], tuples)
        return zip_fmu(root, out, stamp, digest)
