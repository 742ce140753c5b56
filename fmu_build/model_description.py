"""Write modelDescription.xml for RockingBlock from the variable table."""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from fmu_build.model_structure import DEPENDENCIES, STATES
from fmu_build.variables import Enumeration, Range, Variable

# SI base-unit exponents of every unit the model uses
UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "m": {"m": 1},
    "kg": {"kg": 1},
    "s": {"s": 1},
    "Hz": {"s": -1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.s": {"kg": 1, "m": 1, "s": -1},
    "N/s": {"kg": 1, "m": 1, "s": -3},
    "kg.m2": {"kg": 1, "m": 2},
    "1/s": {"s": -1},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
}


# display units of the angle units: degrees for people, radians in the model
DISPLAY_UNITS: dict[str, tuple[str, float]] = {
    "rad": ("deg", 180.0 / 3.141592653589793),
    "rad/s": ("deg/s", 180.0 / 3.141592653589793),
    "rad/s2": ("deg/s2", 180.0 / 3.141592653589793),
}

NUMBER_OF_EVENT_INDICATORS = 6  # model/c/me.h ME_INDICATORS


def unit_definitions(used_units: list[str]) -> list[str]:
    """The <UnitDefinitions> lines (FMI 2.0 and 3.0 alike) of the units used, with the
    display units of the angle units; ValueError for a unit without a definition."""
    unknown = [u for u in used_units if u not in UNITS]
    if unknown:
        raise ValueError(f"unit(s) without a definition: {unknown}")
    lines = ["  <UnitDefinitions>"]
    for u in used_units:
        exps = " ".join(f'{k}="{e}"' for k, e in UNITS[u].items())
        base = f"<BaseUnit {exps}/>" if exps else ""
        if u in DISPLAY_UNITS:
            name, factor = DISPLAY_UNITS[u]
            base += f'<DisplayUnit name="{name}" factor="{factor!r}"/>'
        lines.append(f"    <Unit name={quoteattr(u)}>{base}</Unit>" if base else f"    <Unit name={quoteattr(u)}/>")
    lines.append("  </UnitDefinitions>")
    return lines


def start_attribute(v: Variable) -> str:
    """The text of v's start attribute (FMI 2.0 and 3.0 alike; a String's text as it is)."""
    if v.type == "String":
        return v.start
    if v.type == "Boolean":
        return "true" if float(v.start) != 0 else "false"
    if v.type == "Integer":
        return str(int(float(v.start)))
    return repr(float(v.start))


def range_attributes(v: Variable, ranges: dict[str, Range]) -> str:
    """The min and max attributes (FMI 2.0 and 3.0 alike, inclusive) of v's valid range, if it has one."""
    r = ranges.get(v.name)
    if r is None:
        return ""
    text = (lambda x: str(int(x))) if v.type == "Integer" else repr
    return "".join(f' {attr}="{text(x)}"' for attr, x in (("min", r.min), ("max", r.max)) if x is not None)


def model_description(
    variables: list[Variable],
    model_identifier: str,
    guid: str,
    source_files: list[str],
    version: str,
    enumerations: dict[str, Enumeration] | None = None,
    ranges: dict[str, Range] | None = None,
) -> str:
    """Return the XML text of modelDescription.xml (Co-Simulation and Model Exchange)."""
    enumerations = enumerations or {}
    ranges = ranges or {}
    index = {v.name: i for i, v in enumerate(variables, start=1)}
    unknown_names = [n for n in list(DEPENDENCIES) + list(STATES) + list(STATES.values()) + list(enumerations)
                     if n not in index]
    for deps in DEPENDENCIES.values():
        unknown_names += [n for n in deps if n not in index]
    if unknown_names:
        raise ValueError(f"model structure names unknown variable(s): {sorted(set(unknown_names))}")
    derivative_of = {der: state for state, der in STATES.items()}
    used_units = sorted({v.unit for v in variables if v.unit})
    out: list[str] = []
    w = out.append
    w('<?xml version="1.0" encoding="UTF-8"?>')
    w(
        '<fmiModelDescription fmiVersion="2.0" '
        f'modelName="{model_identifier}" guid="{guid}" '
        'description="Rigid block rocking on its corners under horizontal and vertical ground acceleration" '
        f'version="{version}" generationTool="rocking fmu_build" '
        'variableNamingConvention="structured" '
        f'numberOfEventIndicators="{NUMBER_OF_EVENT_INDICATORS}">'
    )
    w(
        f'  <ModelExchange modelIdentifier="{model_identifier}" '
        'needsExecutionTool="false" completedIntegratorStepNotNeeded="false" '
        'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUstate="false" '
        'canSerializeFMUstate="false">'
    )
    w("    <SourceFiles>")
    for f in source_files:
        w(f'      <File name="{f}"/>')
    w("    </SourceFiles>")
    w("  </ModelExchange>")
    w(
        f'  <CoSimulation modelIdentifier="{model_identifier}" '
        'canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true" '
        'canSerializeFMUstate="true" canInterpolateInputs="true" '
        'canBeInstantiatedOnlyOncePerProcess="false" needsExecutionTool="false">'
    )
    w("    <SourceFiles>")
    for f in source_files:
        w(f'      <File name="{f}"/>')
    w("    </SourceFiles>")
    w("  </CoSimulation>")
    out += unit_definitions(used_units)
    if enumerations:
        w("  <TypeDefinitions>")
        for enum in sorted({e.name: e for e in enumerations.values()}.values(), key=lambda e: e.name):
            w(f'    <SimpleType name="{enum.name}">')
            w("      <Enumeration>")
            for value, item, description in enum.items:
                w(f'        <Item name="{item}" value="{value}" description={quoteattr(description)}/>')
            w("      </Enumeration>")
            w("    </SimpleType>")
        w("  </TypeDefinitions>")
    w("  <LogCategories>")
    w('    <Category name="logEvents" description="Impacts, peaks, uplift, rest and overturn with full-precision times"/>')
    w('    <Category name="logStatusError" description="Errors: invalid parameters, invalid call sequences, solver failures"/>')
    w("  </LogCategories>")
    w('  <DefaultExperiment startTime="0" stopTime="5" tolerance="1e-10"/>')
    w("  <ModelVariables>")
    outputs: list[int] = []
    for i, v in enumerate(variables, start=1):
        attrs = (
            f"name={quoteattr(v.name)} valueReference=\"{v.value_reference}\" "
            f"causality=\"{v.causality}\" variability=\"{v.variability}\" "
            f"description={quoteattr(v.description)}"
        )
        if v.causality == "output":
            outputs.append(i)
        element = v.type
        extra = ""
        if v.name in enumerations:
            element = "Enumeration"
            extra += f' declaredType="{enumerations[v.name].name}"'
        if v.type == "Real" and v.unit:
            extra += f' unit="{v.unit}"'
            if v.unit in DISPLAY_UNITS:
                extra += f' displayUnit="{DISPLAY_UNITS[v.unit][0]}"'
        if v.name in derivative_of:
            extra += f' derivative="{index[derivative_of[v.name]]}"'
        extra += range_attributes(v, ranges)
        if v.causality != "output":
            extra = f" start={quoteattr(start_attribute(v))}" + extra
        w(f"    <ScalarVariable {attrs}><{element}{extra}/></ScalarVariable>")
    w("  </ModelVariables>")
    w("  <ModelStructure>")
    w("    <Outputs>")
    for i in outputs:
        deps = " ".join(str(index[n]) for n in DEPENDENCIES.get(variables[i - 1].name, ()))
        w(f'      <Unknown index="{i}" dependencies="{deps}"/>')
    w("    </Outputs>")
    w("    <Derivatives>")
    for state, der in STATES.items():
        deps = " ".join(str(index[n]) for n in DEPENDENCIES.get(der, ()))
        w(f'      <Unknown index="{index[der]}" dependencies="{deps}"/>')
    w("    </Derivatives>")
    w("    <InitialUnknowns>")
    for i in outputs:
        w(f'      <Unknown index="{i}"/>')
    w("    </InitialUnknowns>")
    w("  </ModelStructure>")
    w("</fmiModelDescription>")
    return "\n".join(out) + "\n"
