"""SSP (System Structure and Parameterization 1.0, Modelica Association 2019) archives of
FMUs connected into a system: the file a co-simulation tool (libcosim, OMSimulator, ...)
opens to run the system.

An archive holds ``SystemStructure.ssd`` and the FMUs under ``resources/``. Each component's
parameters are bound inline (``ssv:ParameterSet``); connections join an output connector of
one component to an input connector of another, unchanged (no linear transformation).
"""

from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

from runners.engine.files import create_beside

NS = ('xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
      'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
      'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
      'xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations" '
      'xmlns:oms="https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"')

Value = float | int | bool | str


@dataclass
class Component:
    """One FMU of the system: its instance name, the FMU file, the connectors the system uses
    (name -> (kind "input"/"output", type "Real"/"Integer"/"Boolean")) and its parameters."""

    name: str
    fmu: Path
    connectors: dict[str, tuple[str, str]] = field(default_factory=dict)
    parameters: dict[str, Value] = field(default_factory=dict)


@dataclass(frozen=True)
class Connection:
    """Output ``start`` of component ``start_element`` drives input ``end`` of ``end_element``."""

    start_element: str
    start: str
    end_element: str
    end: str


def resource(c: Component) -> str:
    """Where the archive keeps c's FMU: resources/<component name>.fmu (whatever the file's own
    name, which may hold characters a URI reference would need escaped)."""
    if not c.name or not all(ch.isalnum() or ch in "_-" for ch in c.name):
        raise ValueError(f"component name {c.name!r}: letters, digits, _ and - only")
    return f"resources/{c.name}.fmu"


# The name of every component's parameter set: one name, so that an engine that applies a set only when it is
# selected by name (Ecos: init(parameter_set=PARAMETER_SET)) applies all of them at once.
PARAMETER_SET = "parameters"

def _ssv(value: Value) -> str:
    if isinstance(value, bool):
        return f'<ssv:Boolean value="{str(value).lower()}"/>'
    if isinstance(value, int):
        return f'<ssv:Integer value="{value}"/>'
    if isinstance(value, float):
        return f'<ssv:Real value="{value!r}"/>'
    return f"<ssv:String value={quoteattr(value)}/>"


def ssd_text(name: str, components: list[Component], connections: list[Connection], start_time: float,
             stop_time: float, description: str = "", step: float | None = None) -> str:
    """The XML of SystemStructure.ssd: components with their FMUs under resources/, their
    connectors and inline parameter values, the connections and the default experiment; with
    ``step`` (s), the fixed communication step as the Open Simulation Platform's annotation
    (libcosim reads it: its loader needs a step)."""
    names = {c.name: c for c in components}
    for k in connections:
        for element, connector, kind in ((k.start_element, k.start, "output"), (k.end_element, k.end, "input")):
            if element not in names:
                raise ValueError(f"connection names an unknown component '{element}'")
            if names[element].connectors.get(connector, ("", ""))[0] != kind:
                raise ValueError(f"connection: {element}.{connector} is not an {kind} connector of {element}")
    w: list[str] = ['<?xml version="1.0" encoding="UTF-8"?>',
                    f'<ssd:SystemStructureDescription {NS} version="1.0" name={quoteattr(name)}>',
                    f"  <ssd:System name={quoteattr(name)} description={quoteattr(description)}>",
                    "    <ssd:Elements>"]
    for c in components:
        w.append(f'      <ssd:Component name={quoteattr(c.name)} source={quoteattr(resource(c))} '
                 'type="application/x-fmu-sharedlibrary">')
        w.append("        <ssd:Connectors>")
        for cname, (kind, typ) in c.connectors.items():
            w.append(f"          <ssd:Connector name={quoteattr(cname)} kind=\"{kind}\"><ssc:{typ}/></ssd:Connector>")
        w.append("        </ssd:Connectors>")
        if c.parameters:
            w += ["        <ssd:ParameterBindings>", "          <ssd:ParameterBinding>",
                  "            <ssd:ParameterValues>",
                  f'              <ssv:ParameterSet version="1.0" name={quoteattr(PARAMETER_SET)}>',
                  "                <ssv:Parameters>"]
            for pname, value in c.parameters.items():
                w.append(f"                  <ssv:Parameter name={quoteattr(pname)}>{_ssv(value)}</ssv:Parameter>")
            w += ["                </ssv:Parameters>", "              </ssv:ParameterSet>",
                  "            </ssd:ParameterValues>", "          </ssd:ParameterBinding>",
                  "        </ssd:ParameterBindings>"]
        w.append("      </ssd:Component>")
    w.append("    </ssd:Elements>")
    w.append("    <ssd:Connections>")
    for k in connections:
        w.append(f"      <ssd:Connection startElement={quoteattr(k.start_element)} startConnector={quoteattr(k.start)} "
                 f"endElement={quoteattr(k.end_element)} endConnector={quoteattr(k.end)}/>")
    w.append("    </ssd:Connections>")
    if step is not None:  # OMSimulator makes the system only with its own annotation, which gives its fixed step
        w += ["    <ssd:Annotations>", '      <ssc:Annotation type="org.openmodelica">', "        <oms:Annotations>",
              "          <oms:SimulationInformation>",
              f'            <oms:FixedStepMaster description="oms-ma" stepSize="{step!r}" absoluteTolerance="1e-6" '
              'relativeTolerance="1e-6"/>',
              "          </oms:SimulationInformation>", "        </oms:Annotations>", "      </ssc:Annotation>",
              "    </ssd:Annotations>"]
    w.append("  </ssd:System>")
    experiment = f'  <ssd:DefaultExperiment startTime="{start_time!r}" stopTime="{stop_time!r}"'
    if step is None:
        w.append(experiment + "/>")
    else:
        w += [experiment + ">", "    <ssd:Annotations>", '      <ssc:Annotation type="com.opensimulationplatform">',
              "        <osp:Algorithm>", f'          <osp:FixedStepAlgorithm baseStepSize="{step!r}"/>',
              "        </osp:Algorithm>", "      </ssc:Annotation>", "    </ssd:Annotations>",
              "  </ssd:DefaultExperiment>"]
    w.append("</ssd:SystemStructureDescription>")
    return "\n".join(w) + "\n"


def _entry(name: str) -> zipfile.ZipInfo:
    """An archive member readable by everyone once extracted (rw-r--r--, whatever the FMU file's own mode or the
    SSD's default of rw-------), compressed."""
    import time

    info = zipfile.ZipInfo(name, date_time=time.localtime()[:6])
    info.external_attr = 0o100644 << 16
    info.compress_type = zipfile.ZIP_DEFLATED
    return info


def write_ssp(path: str | Path, name: str, components: list[Component], connections: list[Connection],
              start_time: float, stop_time: float, description: str = "", step: float | None = None) -> Path:
    """Write the SSP archive ``path`` (SystemStructure.ssd and the FMUs in resources/, each named
    after its component), atomically."""
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"cannot write {path}: the folder {path.parent} does not exist")
    fmus = {resource(c): c.fmu for c in components}
    if len(fmus) != len(components):
        raise ValueError("two components with the same name")
    text = ssd_text(name, components, connections, start_time, stop_time, description, step)
    fd, tmp = create_beside(path)
    try:
        with os.fdopen(fd, "wb") as fh, zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr(_entry("SystemStructure.ssd"), text)
            for fname, fpath in sorted(fmus.items()):
                zf.writestr(_entry(fname), Path(fpath).read_bytes())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path

