"""Write modelDescription.xml for RockingBlock from the variable table."""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from fmu_build.variables import Variable

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
    "m/s2": {"m": 1, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
}


def _start(v: Variable) -> str:
    if v.type == "String":
        return v.start
    if v.type == "Boolean":
        return "true" if float(v.start) != 0 else "false"
    if v.type == "Integer":
        return str(int(float(v.start)))
    return repr(float(v.start))


def model_description(
    variables: list[Variable],
    model_identifier: str,
    guid: str,
    source_files: list[str],
    version: str,
) -> str:
    """Return the XML text of modelDescription.xml."""
    used_units = sorted({v.unit for v in variables if v.unit})
    unknown = [u for u in used_units if u not in UNITS]
    if unknown:
        raise ValueError(f"unit(s) without a definition: {unknown}")
    out: list[str] = []
    w = out.append
    w('<?xml version="1.0" encoding="UTF-8"?>')
    w(
        '<fmiModelDescription fmiVersion="2.0" '
        f'modelName="{model_identifier}" guid="{guid}" '
        'description="Rigid block rocking on its corners under horizontal and vertical ground acceleration" '
        f'version="{version}" generationTool="rocking fmu_build" '
        'variableNamingConvention="structured" numberOfEventIndicators="0">'
    )
    w(
        f'  <CoSimulation modelIdentifier="{model_identifier}" '
        'canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true" '
        'canSerializeFMUstate="true" canInterpolateInputs="false" '
        'canBeInstantiatedOnlyOncePerProcess="false" needsExecutionTool="false">'
    )
    w("    <SourceFiles>")
    for f in source_files:
        w(f'      <File name="{f}"/>')
    w("    </SourceFiles>")
    w("  </CoSimulation>")
    w("  <UnitDefinitions>")
    for u in used_units:
        exps = " ".join(f'{k}="{e}"' for k, e in UNITS[u].items())
        w(f"    <Unit name={quoteattr(u)}><BaseUnit {exps}/></Unit>" if exps else f"    <Unit name={quoteattr(u)}/>")
    w("  </UnitDefinitions>")
    w("  <LogCategories>")
    w('    <Category name="logEvents" description="Impacts, peaks, uplift, rest and overturn with full-precision times"/>')
    w('    <Category name="logStatusError" description="Errors: invalid parameters, invalid call sequences, solver failures"/>')
    w("  </LogCategories>")
    w('  <DefaultExperiment startTime="0" stopTime="5"/>')
    w("  <ModelVariables>")
    outputs: list[int] = []
    for index, v in enumerate(variables, start=1):
        attrs = (
            f"name={quoteattr(v.name)} valueReference=\"{v.value_reference}\" "
            f"causality=\"{v.causality}\" variability=\"{v.variability}\" "
            f"description={quoteattr(v.description)}"
        )
        if v.causality == "output":
            outputs.append(index)
            inner = f"<{v.type}" + (f' unit="{v.unit}"' if v.type == "Real" and v.unit else "") + "/>"
        else:
            inner = f'<{v.type} start={quoteattr(_start(v))}' + (
                f' unit="{v.unit}"' if v.type == "Real" and v.unit else ""
            ) + "/>"
        w(f"    <ScalarVariable {attrs}>{inner}</ScalarVariable>")
    w("  </ModelVariables>")
    w("  <ModelStructure>")
    w("    <Outputs>")
    for i in outputs:
        w(f'      <Unknown index="{i}"/>')
    w("    </Outputs>")
    w("    <InitialUnknowns>")
    for i in outputs:
        w(f'      <Unknown index="{i}"/>')
    w("    </InitialUnknowns>")
    w("  </ModelStructure>")
    w("</fmiModelDescription>")
    return "\n".join(out) + "\n"
