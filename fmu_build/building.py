"""Compile model/c/building into ShearBuilding.fmu: a linear shear building of N storeys, FMI 2.0
Co-Simulation, binaries/linux64 and, where mingw-w64 is installed, binaries/win64.

The C model is model/c/building (building.c: the model; fmi2_building.c: the FMI layer;
variables.def: the variable table) with two files of the rocking core: the Dormand-Prince
integrator (model/c/integrator.c, compiled through building_integrator.c with a larger NMAX) and
the record-file reader (model/c/record.c). The compiler calls are those of
:func:`fmu_build.build.compile_binary`; like the rocking FMU, it is rebuilt only when its sources
change (a sha256 stamp next to it).
"""

from __future__ import annotations

import hashlib
import html
import os
import re
import shutil
import tempfile
import uuid
from pathlib import Path
from xml.sax.saxutils import quoteattr

from fmu_build.build import (C_DIR, GLIBC_COMPAT, GLIBC_COMPAT_FILES, VERSION, build_platforms, build_stamp,
                             compile_platforms, default_fmu_path, fmi_headers_dir, zip_fmu)
from fmu_build.model_description import range_attributes, start_attribute, unit_definitions
from fmu_build.variables import Range, Variable, read_ranges, read_variables

BUILDING_IDENTIFIER = "ShearBuilding"
BUILDING_DIR = C_DIR / "building"
MAX_STOREYS = 10  # building.h BUILDING_MAX_STOREYS
# compiled units (building_integrator.c includes integrator.c) and the files they include
BUILDING_SOURCES = ["fmi2_building.c", "building.c", "building_integrator.c"]
CORE_SOURCES = ["record.c"]
BUILDING_HEADERS = ["building.h", "variables.def"]
CORE_HEADERS = ["integrator.h", "integrator.c", "record.h"]

# direct feedthrough of the outputs (every other output depends on the state only): the absolute
# floor acceleration a = M^-1 (F - C u' - K u) on the floor's force, a_g on base.a
_FEEDTHROUGH = {"base.aTotal": ["base.a"], **{f"storey[{i}].a": [f"storey[{i}].force"]
                                             for i in range(1, MAX_STOREYS + 1)}}

_STOREY = re.compile(r'^STOREY\(\s*(\w+)\s*,\s*(\d+)\s*,\s*(\w+)\s*,\s*"([^"]+)"\s*,(.*)$')


def default_building_path(sanitize: bool = False) -> Path:
    """Where ``python -m fmu_build`` puts ShearBuilding.fmu (``--sanitize``: ShearBuilding-sanitize.fmu)."""
    return default_fmu_path(sanitize, BUILDING_IDENTIFIER)


def expand_variables(def_text: str) -> str:
    """variables.def with every ``STOREY(...)`` line written out as the ``VAR(...)`` lines of
    storey[1..10] (value reference base + i, field ``array_i``), so that
    :func:`fmu_build.variables.read_variables` reads it."""
    out = []
    for line in def_text.splitlines():
        if line.startswith("RANGE(") and "storey[*]" in line:  # one range line per storey
            out += [line.replace("storey[*]", f"storey[{i}]") for i in range(1, MAX_STOREYS + 1)]
            continue
        m = _STOREY.match(line.strip())
        if not m:
            out.append(line)
            continue
        typ, base, field, member, rest = m.groups()
        for i in range(1, MAX_STOREYS + 1):
            out.append(f'VAR({typ}, {int(base) + i}, {field}_{i}, "storey[{i}].{member}",{rest}')
    return "\n".join(out) + "\n"


def building_variables(tmp: Path) -> tuple[list[Variable], dict[str, Range]]:
    """The building's variables in declaration order and their valid ranges (the expanded table
    is written to ``tmp``)."""
    path = tmp / "variables_expanded.def"
    path.write_text(expand_variables((BUILDING_DIR / "variables.def").read_text()))
    variables, ranges = read_variables(path), read_ranges(path)
    names = {v.name for v in variables if v.causality == "parameter"}
    unknown = sorted(set(ranges) - names)
    if unknown:
        raise ValueError(f"RANGE lines name no parameter of the building: {unknown}")
    return variables, ranges


def building_model_description(variables: list[Variable], guid: str, ranges: dict[str, Range] | None = None) -> str:
    """The text of ShearBuilding's modelDescription.xml (FMI 2.0 Co-Simulation)."""
    index = {v.name: i for i, v in enumerate(variables, start=1)}
    used_units = sorted({v.unit for v in variables if v.unit})
    files = BUILDING_SOURCES + CORE_SOURCES
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<fmiModelDescription fmiVersion="2.0" modelName="{BUILDING_IDENTIFIER}" guid="{guid}" '
           'description="Linear shear building of 1 to 10 storeys (Rayleigh damping) under base acceleration and '
           f'horizontal floor forces" version="{VERSION}" generationTool="rocking fmu_build" '
           'variableNamingConvention="structured" numberOfEventIndicators="0">',
           f'  <CoSimulation modelIdentifier="{BUILDING_IDENTIFIER}" canHandleVariableCommunicationStepSize="true" '
           'canGetAndSetFMUstate="true" canSerializeFMUstate="false" canInterpolateInputs="true" '
           'maxOutputDerivativeOrder="1" canBeInstantiatedOnlyOncePerProcess="false" needsExecutionTool="false">',
           "    <SourceFiles>", *[f'      <File name="{f}"/>' for f in files], "    </SourceFiles>",
           "  </CoSimulation>", *unit_definitions(used_units)]
    out += ["  <LogCategories>",
            '    <Category name="logStatusError" description="Errors: invalid parameters, invalid call sequences, '
            'integrator failures"/>', "  </LogCategories>",
            '  <DefaultExperiment startTime="0" stopTime="10" tolerance="1e-10"/>', "  <ModelVariables>"]
    for v in variables:
        attrs = (f'name={quoteattr(v.name)} valueReference="{v.value_reference}" causality="{v.causality}" '
                 f'variability="{v.variability}" description={quoteattr(v.description)}')
        extra = f' unit="{v.unit}"' if v.type == "Real" and v.unit else ""
        extra += range_attributes(v, ranges or {})
        if v.causality in ("parameter", "input"):
            extra = f" start={quoteattr(start_attribute(v))}" + extra
        out.append(f"    <ScalarVariable {attrs}><{v.type}{extra}/></ScalarVariable>")
    out += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>"]
    for v in variables:
        if v.causality == "output":
            deps = " ".join(str(index[n]) for n in _FEEDTHROUGH.get(v.name, ()))
            out.append(f'      <Unknown index="{index[v.name]}" dependencies="{deps}"/>')
    out += ["    </Outputs>", "    <InitialUnknowns>"]
    for v in variables:
        if v.causality in ("output", "calculatedParameter"):
            out.append(f'      <Unknown index="{index[v.name]}"/>')
    out += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>"]
    return "\n".join(out) + "\n"


def building_documentation(variables: list[Variable]) -> str:
    """A short documentation/index.html: the equations and the variable table."""
    rows = "\n".join(
        f"<tr><td>{html.escape(v.name)}</td><td>{v.value_reference}</td><td>{v.causality}</td>"
        f"<td>{html.escape(v.unit)}</td><td>{html.escape(v.description)}</td></tr>" for v in variables)
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{BUILDING_IDENTIFIER}</title></head><body>
<h1>{BUILDING_IDENTIFIER} {VERSION}</h1>
<p>A linear shear building of N storeys (1 to 10), FMI 2.0 Co-Simulation. SI units, +x to the right.</p>
<p>M u'' + C u' + K u = -M 1 a_g(t) + F(t), u: floor displacements relative to the base; M = diag(m_i);
K tridiagonal from the storey stiffnesses k_i (storey i between floor i-1 and floor i, floor 0 the base);
Rayleigh damping C = a0 M + a1 K with the damping ratio at modes 1 and 2 (N = 1: C = 2 zeta omega1 m,
stiffness-proportional). a_g: the record file (linear between samples, zero outside), scaled, plus base.a.
Inputs are held over a communication step; the Dormand-Prince 5(4) integrator stops at the record's samples
and at communication points. The energy balance energy(t) - energy(0) = baseWork + forceWork - dampingLoss
holds to the tolerance. storey[i].a is the absolute floor acceleration.</p>
<table border="1"><tr><th>name</th><th>value reference</th><th>causality</th><th>unit</th><th>description</th></tr>
{rows}
</table></body></html>
"""


def _sources_digest() -> str:
    h = hashlib.sha256()
    for d, names in ((BUILDING_DIR, BUILDING_SOURCES + BUILDING_HEADERS), (C_DIR, CORE_SOURCES + CORE_HEADERS),
                     (GLIBC_COMPAT, GLIBC_COMPAT_FILES)):
        for name in names:
            h.update(name.encode())
            h.update((d / name).read_bytes())
    for name in ("building.py", "build.py", "variables.py"):
        h.update((Path(__file__).parent / name).read_bytes())
    return h.hexdigest()


def build_building_fmu(out: Path | None = None, force: bool = False, cc: str | None = None,
                       platforms: list[str] | None = None, sanitize: bool = False) -> Path:
    """Build ShearBuilding.fmu if its sources changed; return its path.

    ``platforms`` as for :func:`fmu_build.build.build_fmu`: by default linux64, and win64 too where
    the mingw-w64 cross compiler is installed (else a one-line note says the FMU has no Windows
    binary). ``sanitize``: with AddressSanitizer and UBSan (linux64 only), by default into
    build/ShearBuilding-sanitize.fmu. Raises BuildError when a compiler is missing or fails.
    """
    out = Path(out) if out else default_building_path(sanitize)
    cc = cc or os.environ.get("CC", "cc")
    wanted, compilers = build_platforms(platforms, sanitize, cc)
    sources_digest = _sources_digest()
    stamp, digest, current = build_stamp(out, sources_digest, wanted, compilers, platforms, sanitize, force=force)
    if current:
        return out
    guid = "{" + str(uuid.UUID(sources_digest[:32])) + "}"
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        variables, ranges = building_variables(Path(tmp))
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        for d, names in ((BUILDING_DIR, BUILDING_SOURCES + BUILDING_HEADERS), (C_DIR, CORE_SOURCES + CORE_HEADERS)):
            for name in names:
                shutil.copy2(d / name, src / name)
        (src / "config.h").write_text(
            f"/* Written by fmu_build: identifies this build of {BUILDING_IDENTIFIER}. */\n"
            "#ifndef BUILDING_CONFIG_H\n#define BUILDING_CONFIG_H\n"
            f'#define MODEL_GUID "{guid}"\n#endif\n')
        (root / "modelDescription.xml").write_text(building_model_description(variables, guid, ranges))
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(building_documentation(variables), encoding="utf-8")
        compile_platforms([src / s for s in BUILDING_SOURCES + CORE_SOURCES], root, BUILDING_IDENTIFIER, wanted,
                          compilers, [src, fmi_headers_dir()])
        return zip_fmu(root, out, stamp, digest)
