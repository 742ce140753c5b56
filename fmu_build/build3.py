"""Compile model/c into RockingBlock3.fmu: the FMI 3.0 Co-Simulation edition.

The same C core as RockingBlock.fmu (every source of ``C_SOURCES`` but the FMI
2.0 layer ``fmi2.c``) with the FMI 3.0 layer ``fmi3.c``, compiled against the
FMI 3.0 headers shipped in fmpy. Like :func:`fmu_build.build.build_fmu`, it
rebuilds only when the sources changed (a sha256 stamp next to the FMU).
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import tempfile
import uuid
import zipfile
from pathlib import Path

from fmu_build.build import (C_DIR, C_HEADERS, C_SOURCES, CFLAGS, SANITIZE_FLAGS, VERSION, BuildError,
                             _sources_digest, compile_binary, default_fmu_path, fmi_headers_dir)
from fmu_build.documentation import documentation_html
from fmu_build.variables import read_enumerations, read_variables

MODEL_IDENTIFIER3 = "RockingBlock3"
C_SOURCES3 = ["fmi3.c"] + [s for s in C_SOURCES if s != "fmi2.c"]


def default_fmu3_path(sanitize: bool = False) -> Path:
    """Where ``python -m fmu_build`` puts the FMI 3.0 FMU."""
    return default_fmu_path(sanitize, MODEL_IDENTIFIER3)


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
) -> Path:
    """Build RockingBlock3.fmu if its sources changed; return its path."""
    out = Path(out) if out else default_fmu3_path(sanitize)
    cc = cc or os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise BuildError(f"C compiler '{cc}' not found (set CC or install gcc)")
    flags = SANITIZE_FLAGS if sanitize else CFLAGS
    tuple_ = platform_tuple()
    sources_digest = _sources_digest3()
    digest = hashlib.sha256((sources_digest + " ".join([cc, tuple_] + flags)).encode()).hexdigest()
    stamp = out.with_name(out.name + ".sha256")
    if not force and out.is_file() and stamp.is_file() and stamp.read_text().strip() == digest:
        return out

    from fmu_build.model_description3 import build_description3, model_description3  # only to build

    token = "{" + str(uuid.UUID(sources_digest[:32])) + "}"
    variables = read_variables(C_DIR / "variables.def")
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        bindir = root / "binaries" / tuple_
        src.mkdir(parents=True)
        bindir.mkdir(parents=True)
        for name in C_SOURCES3 + C_HEADERS:
            shutil.copy2(C_DIR / name, src / name)
        (src / "config.h").write_text(
            "/* Written by fmu_build: identifies this build of RockingBlock3 (the instantiationToken). */\n"
            "#ifndef ROCKING_CONFIG_H\n#define ROCKING_CONFIG_H\n"
            f'#define MODEL_GUID "{token}"\n#endif\n'
        )
        (src / "buildDescription.xml").write_text(build_description3(MODEL_IDENTIFIER3, C_SOURCES3))
        (root / "modelDescription.xml").write_text(
            model_description3(variables, MODEL_IDENTIFIER3, token, VERSION))
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(
            documentation_html(variables, read_enumerations(C_DIR / "variables.def"), MODEL_IDENTIFIER3, VERSION),
            encoding="utf-8")
        # the FMI 2.0 build's compiler call: on x86_64 glibc, loadable on glibc 2.17 or newer
        warnings = compile_binary([src / name for name in C_SOURCES3], bindir / f"{MODEL_IDENTIFIER3}.so",
                                  "linux64", cc, flags, [src, fmi_headers_dir("3")])
        if warnings:
            print(warnings)
        partial = out.with_name(f"{out.name}.{os.getpid()}.part")  # builds side by side do not mix
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    zf.write(path, path.relative_to(root).as_posix())
        partial.replace(out)
    stamp.write_text(digest + "\n")
    return out
