"""Write the FMI 3.0 modelDescription.xml and sources/buildDescription.xml of
RockingBlock3 (Co-Simulation) from the variable table model/c/variables.def."""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from fmu_build.model_description import DISPLAY_UNITS, range_attributes, start_attribute, unit_definitions
from fmu_build.model_structure import DEPENDENCIES
from fmu_build.variables import Enumeration, Range, Variable

# value reference of the independent variable "time" (TIME_VR in model/c/fmi3.c)
TIME_VALUE_REFERENCE = 0

# variables.def types and their FMI 3.0 elements
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def _variable(v: Variable, enumerations: dict[str, Enumeration], ranges: dict[str, Range]) -> str:
    try:
        element = FMI3_TYPES[v.type]
    except KeyError:
        raise ValueError(f"variable '{v.name}': type {v.type} has no FMI 3.0 counterpart here") from None
    attrs = [
        f"name={quoteattr(v.name)}",
        f'valueReference="{v.value_reference}"',
        f"description={quoteattr(v.description)}",
        f'causality="{v.causality}"',
        f'variability="{v.variability}"',
    ]
    if v.name in enumerations:  # read and set with fmi3GetInt64 and fmi3SetInt64 (model/c/fmi3.c)
        element = "Enumeration"
        attrs.append(f'declaredType="{enumerations[v.name].name}"')
    bounds = range_attributes(v, ranges).strip()
    if bounds:
        attrs.append(bounds)
    if v.causality == "output":
        attrs.append('intermediateUpdate="true"')  # readable from the intermediateUpdate callback
    if element == "Float64" and v.unit:
        attrs.append(f"unit={quoteattr(v.unit)}")
        if v.unit in DISPLAY_UNITS:
            attrs.append(f'displayUnit="{DISPLAY_UNITS[v.unit][0]}"')
    if v.causality == "output":  # initial = "calculated": no start value
        return f"    <{element} {' '.join(attrs)}/>"
    if element == "String":
        return f"    <String {' '.join(attrs)}><Start value={quoteattr(v.start)}/></String>"
    return f"    <{element} {' '.join(attrs)} start={quoteattr(start_attribute(v))}/>"


def model_description3(
    variables: list[Variable],
    model_identifier: str,
    instantiation_token: str,
    version: str,
    enumerations: dict[str, Enumeration] | None = None,
    ranges: dict[str, Range] | None = None,
) -> str:
    """Return the XML text of the FMI 3.0 modelDescription.xml: the Enumerations of
    ``enumerations`` (variable name -> type) as EnumerationTypes, the min and max of ``ranges``."""
    enumerations = enumerations or {}
    ranges = ranges or {}
    if any(v.value_reference == TIME_VALUE_REFERENCE for v in variables):
        raise ValueError(f"value reference {TIME_VALUE_REFERENCE} is the FMI 3.0 'time': no variable may use it")
    used_units = sorted({v.unit for v in variables if v.unit} | {"s"})
    out: list[str] = []
    w = out.append
    w('<?xml version="1.0" encoding="UTF-8"?>')
    w(
        '<fmiModelDescription fmiVersion="3.0" modelName="RockingBlock" '
        f'instantiationToken="{instantiation_token}" '
        'description="Rigid block rocking on its corners under horizontal and vertical ground acceleration" '
        f'version="{version}" generationTool="rocking fmu_build" variableNamingConvention="structured">'
    )
    w(
        f'  <CoSimulation modelIdentifier="{model_identifier}" '
        'canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true" canSerializeFMUState="true" '
        'hasEventMode="true" providesIntermediateUpdate="true" mightReturnEarlyFromDoStep="true" '
        'canReturnEarlyAfterIntermediateUpdate="true" '
        'canBeInstantiatedOnlyOncePerProcess="false" needsExecutionTool="false"/>'
    )
    out += unit_definitions(used_units)
    if enumerations:
        w("  <TypeDefinitions>")
        for enum in sorted({e.name: e for e in enumerations.values()}.values(), key=lambda e: e.name):
            w(f'    <EnumerationType name="{enum.name}">')
            for value, item, description in enum.items:
                w(f'      <Item name="{item}" value="{value}" description={quoteattr(description)}/>')
            w("    </EnumerationType>")
        w("  </TypeDefinitions>")
    w("  <LogCategories>")
    w('    <Category name="logEvents" description="Impacts, peaks, uplift, rest and overturn with full-precision times"/>')
    w('    <Category name="logStatusError" description="Errors: invalid parameters, invalid call sequences, solver failures"/>')
    w("  </LogCategories>")
    w('  <DefaultExperiment startTime="0" stopTime="5" tolerance="1e-10"/>')
    w("  <ModelVariables>")
    w(f'    <Float64 name="time" valueReference="{TIME_VALUE_REFERENCE}" description="Simulation time" '
      'causality="independent" variability="continuous" unit="s"/>')
    for v in variables:
        w(_variable(v, enumerations, ranges))
    w("  </ModelVariables>")
    w("  <ModelStructure>")
    # Co-Simulation has no states: an output's dependencies are the inputs it follows at once
    ref = {v.name: v.value_reference for v in variables}
    inputs = {v.name for v in variables if v.causality == "input"}
    outputs = [v.value_reference for v in variables if v.causality == "output"]
    for v in variables:
        if v.causality == "output":
            deps = " ".join(str(ref[n]) for n in DEPENDENCIES.get(v.name, ()) if n in inputs)
            w(f'    <Output valueReference="{v.value_reference}" dependencies="{deps}"/>')
    for vr in outputs:
        w(f'    <InitialUnknown valueReference="{vr}"/>')
    w("  </ModelStructure>")
    w("</fmiModelDescription>")
    return "\n".join(out) + "\n"


def build_description3(model_identifier: str, source_files: list[str]) -> str:
    """Return sources/buildDescription.xml: how to compile the shipped sources
    (C99, against the FMI 3.0 headers, linked with the maths library)."""
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiBuildDescription fmiVersion="3.0">',
        f'  <BuildConfiguration modelIdentifier="{model_identifier}">',
        '    <SourceFileSet language="C99">',
        *(f'      <SourceFile name="{f}"/>' for f in source_files),
        "    </SourceFileSet>",
        '    <Library name="m" external="true" description="the C maths library (-lm)"/>',
        "  </BuildConfiguration>",
        "</fmiBuildDescription>",
    ]
    return "\n".join(out) + "\n"
