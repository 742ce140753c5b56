"""Compile model/c into RockingBlock.fmu with the system C compiler."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path

from fmu_build.documentation import DOCS, PAGES, documentation_html
from fmu_build.model_description import model_description
from fmu_build.variables import read_enumerations, read_variables

MODEL_IDENTIFIER = "RockingBlock"
ROOT = Path(__file__).resolve().parent.parent
C_DIR = ROOT / "model" / "c"
C_SOURCES = ["fmi2.c", "instance.c", "me.c", "model.c", "ground.c", "record.c", "solver.c", "stack.c", "stack_solver.c", "events.c",
             "taylor.c", "integrator.c"]
C_HEADERS = ["instance.h", "me.h", "model.h", "ground.h", "record.h", "solver.h", "stack.h", "stack_solver.h", "events.h", "taylor.h",
             "integrator.h", "variables.def"]
VERSION = "0.1.0"

CFLAGS = ["-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra"]
SANITIZE_FLAGS = [
    "-std=c99", "-O1", "-g", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra",
    "-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=undefined",
]


class BuildError(RuntimeError):
    """The FMU could not be built (compiler missing or compilation failed)."""


def default_fmu_path(sanitize: bool = False) -> Path:
    """Where ``python -m fmu_build`` puts the FMU."""
    name = f"{MODEL_IDENTIFIER}-sanitize.fmu" if sanitize else f"{MODEL_IDENTIFIER}.fmu"
    return ROOT / "build" / name


def fmi_headers_dir() -> Path:
    """The FMI 2.0 headers that ship inside the installed fmpy package."""
    import fmpy

    path = Path(fmpy.__file__).parent / "c-code"
    if not (path / "fmi2Functions.h").is_file():
        raise BuildError(f"FMI 2.0 headers not found in the fmpy package at {path}")
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
    return h.hexdigest()


def build_fmu(
    out: Path | None = None,
    sanitize: bool = False,
    force: bool = False,
    cc: str | None = None,
) -> Path:
    """Build the FMU if its sources changed; return its path.

    The build is skipped when ``out`` exists and was made from the same
    sources and flags (a sha256 stamp next to it records that).
    """
    out = Path(out) if out else default_fmu_path(sanitize)
    cc = cc or os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise BuildError(f"C compiler '{cc}' not found (set CC or install gcc)")
    flags = SANITIZE_FLAGS if sanitize else CFLAGS
    sources_digest = _sources_digest()
    digest = hashlib.sha256((sources_digest + " ".join([cc] + flags)).encode()).hexdigest()
    stamp = out.with_name(out.name + ".sha256")
    if not force and out.is_file() and stamp.is_file() and stamp.read_text().strip() == digest:
        return out

    guid = "{" + str(uuid.UUID(sources_digest[:32])) + "}"
    variables = read_variables(C_DIR / "variables.def")
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        bindir = root / "binaries" / "linux64"
        src.mkdir(parents=True)
        bindir.mkdir(parents=True)
        for name in C_SOURCES + C_HEADERS:
            shutil.copy2(C_DIR / name, src / name)
        (src / "config.h").write_text(
            "/* Written by fmu_build: identifies this build of RockingBlock. */\n"
            "#ifndef ROCKING_CONFIG_H\n#define ROCKING_CONFIG_H\n"
            f'#define MODEL_GUID "{guid}"\n#endif\n'
        )
        enumerations = read_enumerations(C_DIR / "variables.def")
        (root / "modelDescription.xml").write_text(
            model_description(variables, MODEL_IDENTIFIER, guid, C_SOURCES, VERSION, enumerations)
        )
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(
            documentation_html(variables, enumerations, MODEL_IDENTIFIER, VERSION), encoding="utf-8")
        binary = bindir / f"{MODEL_IDENTIFIER}.so"
        cmd = [cc, *flags, "-I", str(src), "-I", str(fmi_headers_dir()), "-o", str(binary)]
        cmd += [str(src / s) for s in C_SOURCES] + ["-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise BuildError(f"compilation failed:\n{proc.stderr.strip()}")
        if proc.stderr.strip():
            print(proc.stderr.strip())
        partial = out.with_name(out.name + ".part")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    zf.write(path, path.relative_to(root).as_posix())
        partial.replace(out)
    stamp.write_text(digest + "\n")
    return out
