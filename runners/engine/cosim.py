"""Blocks on a floor of a building, co-simulated: RockingBlock.fmu on a storey of
ShearBuilding.fmu, connected by an SSP file and run by a fixed-step master (fmpy, or libcosim
through its SSP loader).

The building (a linear shear frame under a base acceleration record, docs/cosimulation.md)
gives the blocks its floor's absolute acceleration (``storey[j].a`` to ``ground.ah``). With
``two-way`` coupling the blocks load the floor back: ``contact.groundLoad``, the horizontal
force of the blocks on the floor beyond the one that carries their mass along (its mean over
each communication step, impacts included), drives ``storey[j].force``, and the floor's mass
counts the blocks' mass (which the runner adds). ``one-way`` leaves the floor unloaded (the
blocks' mass is not added either): the blocks ride on a floor they do not affect.

Both masters are Jacobi schemes with a fixed communication step h: at t_k = k h every FMU steps
to t_{k+1} with its inputs held at the values of t_k, then outputs are passed to inputs.

Python API::

    from runners.engine import cosim
    system = cosim.load_system("examples/cabinet_on_floor.toml")
    ssp = cosim.write_system_ssp(system, "cabinet.ssp")
    result = cosim.run(system, engine="fmpy")             # or "libcosim"
    result["block.block1.theta"], result["building.storey[3].a"]   # arrays at result.time

Units SI (s, m, kg, N, J), angles in radians; signs as docs/conventions.md (+x to the right).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import tomllib
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from runners.engine.fmu import SCENE_DEFAULTS
from runners.engine.scene import SCHEMA, SceneError, check_times, scene_from_dict
from runners.engine.ssp import Component, Connection, write_ssp
from runners.errors import RockingError

BUILDING = "building"  # the SSP components' instance names
BLOCK = "block"
MAX_STOREYS = 10  # ShearBuilding.fmu's storeys
COUPLINGS = ("one-way", "two-way")
ENGINES = ("fmpy", "libcosim")
DEFAULT_STEP = 1e-3  # s

BUILDING_KEYS = {"storeys", "mass", "stiffness", "damping_ratio"}
# the base motion's FMU parameters a system file may set ([excitation] record, file and pga besides)
BASE_KEYS = {"excitation.kind", "excitation.scale", "excitation.startTime", "excitation.file"}
COUPLING_KEYS = {"floor", "mode", "step"}

# the blocks' outputs a result keeps (block 2's only for a stack)
BLOCK_OUTPUTS = ["block1.theta", "block1.omega", "impacts", "overturned", "lifts", "slides", "energy", "momentum",
                 "contact.groundLoad", "contact.groundT", "contact.groundN", "ground.ahTotal", "groundWork",
                 "block1.frictionLoss", "impactLoss", "block1.slip"]
BLOCK2_OUTPUTS = ["block2.theta", "block2.omega", "block2.frictionLoss", "block2.overturned"]
BUILDING_OUTPUTS = ["base.aTotal", "energy", "baseWork", "forceWork", "dampingLoss", "baseShear"]
STOREY_OUTPUTS = ["u", "v", "a"]


class CosimError(RockingError, ValueError):
    """A system file or a co-simulation request is invalid, or an engine failed; one line."""


@dataclass
class Building:
    """A linear shear building: floor masses (kg, the structure's own), storey stiffnesses
    (N/m, storey i joins floor i - 1 to floor i; floor 0 is the base) and the Rayleigh damping
    ratio at its first two modes."""

    mass: list[float]
    stiffness: list[float]
    damping_ratio: float = 0.05

    @property
    def storeys(self) -> int:
        return len(self.mass)


@dataclass
class System:
    """Blocks (a scene's [block], [block2], [contact], [restitution], [simulation]) standing on
    floor ``floor`` of ``building``, whose base moves with a record (file the building's FMU reads,
    scale, start time)."""

    name: str
    blocks: dict[str, Any]  # the blocks' FMU parameters (no excitation: the floor drives them)
    building: Building
    floor: int
    coupling: str
    step: float  # s, the communication step
    stop_time: float  # s
    base_file: Path
    base_scale: float = 1.0
    base_start: float = 0.0
    source: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def blocks_mass(self) -> float:
        """kg, the mass the floor carries."""
        m = float(self.blocks.get("block1.mass", 10.0))
        if int(self.blocks.get("nBlocks", 1)) == 2:
            m += float(self.blocks.get("block2.mass", 5.0))
        return m

    def building_parameters(self) -> dict[str, Any]:
        """ShearBuilding.fmu's parameters; two-way coupling adds the blocks' mass to their floor."""
        b = self.building
        p: dict[str, Any] = {"nStoreys": b.storeys, "damping.ratio": float(b.damping_ratio)}
        for i, (m, k) in enumerate(zip(b.mass, b.stiffness), start=1):
            if i == self.floor and self.coupling == "two-way":
                m += self.blocks_mass
            p[f"storey[{i}].mass"] = float(m)
            p[f"storey[{i}].stiffness"] = float(k)
        p["excitation.file"] = str(self.base_file)
        p["excitation.scale"] = float(self.base_scale)
        p["excitation.startTime"] = float(self.base_start)
        return p

    def block_parameters(self) -> dict[str, Any]:
        return {**SCENE_DEFAULTS, **self.blocks}


def _floats(where: str, value: Any, n: int) -> list[float]:
    values = value if isinstance(value, list) else [value] * n
    if len(values) != n:
        raise CosimError(f"{where}: {len(values)} values for {n} storeys")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise CosimError(f"{where}: expected positive numbers (one, or one per storey), got {value!r}")
        out.append(float(v))
    return out


def building_from_dict(d: dict[str, Any], where: str) -> Building:
    unknown = sorted(set(d) - BUILDING_KEYS)
    if unknown:
        raise CosimError(f"{where}: [building] unknown key '{unknown[0]}' (expected {', '.join(sorted(BUILDING_KEYS))})")
    n = d.get("storeys")
    if n is None and isinstance(d.get("mass"), list):
        n = len(d["mass"])
    if n is None:
        raise CosimError(f"{where}: [building] needs storeys (1 to {MAX_STOREYS}), or mass as a list of one value per floor")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_STOREYS:
        raise CosimError(f"{where}: [building] storeys must be a whole number from 1 to {MAX_STOREYS}, got {n!r}")
    for key, what in (("mass", "kg per floor"), ("stiffness", "N/m per storey")):
        if key not in d:
            raise CosimError(f"{where}: [building] needs {key} ({what}: one value, or a list bottom to top)")
    zeta = d.get("damping_ratio", 0.05)
    if isinstance(zeta, bool) or not isinstance(zeta, (int, float)) or not 0 <= zeta < 1:
        raise CosimError(f"{where}: [building] damping_ratio must be in [0, 1), got {zeta!r}")
    return Building(_floats(f"{where}: [building] mass", d["mass"], n),
                    _floats(f"{where}: [building] stiffness", d["stiffness"], n), float(zeta))


def system_tables(data: dict[str, Any], source: str = "<system>") -> tuple[Building, int, str, float, dict[str, Any]]:
    """Validate a system document's [building] and [coupling] tables: the building, the blocks'
    floor, the coupling mode and the communication step (s), and the rest of the document (the
    blocks' scene)."""
    data = dict(data)
    if "building" not in data:
        raise CosimError(f"{source}: no [building] table (storeys, mass, stiffness, damping_ratio)")
    building = data.pop("building")
    coupling = data.pop("coupling", {})
    if not isinstance(building, dict) or not isinstance(coupling, dict):
        raise CosimError(f"{source}: [building] and [coupling] must be tables")
    b = building_from_dict(building, source)
    unknown = sorted(set(coupling) - COUPLING_KEYS)
    if unknown:
        raise CosimError(f"{source}: [coupling] unknown key '{unknown[0]}' (expected floor, mode, step)")
    floor = coupling.get("floor", b.storeys)
    if isinstance(floor, bool) or not isinstance(floor, int) or not 1 <= floor <= b.storeys:
        raise CosimError(f"{source}: [coupling] floor must be a floor of the building, 1 to {b.storeys}, got {floor!r}")
    mode = coupling.get("mode", "two-way")
    if mode not in COUPLINGS:
        raise CosimError(f"{source}: [coupling] mode must be one of {', '.join(COUPLINGS)}, got {mode!r}")
    step = coupling.get("step", DEFAULT_STEP)
    if isinstance(step, bool) or not isinstance(step, (int, float)):
        raise CosimError(f"{source}: [coupling] step must be a number of seconds, got {step!r}")
    return b, floor, mode, float(step), data


def system_from_dict(data: dict[str, Any], source: str = "<system>", factory=None) -> System:
    """Validate a parsed system document: a scene (its [excitation] is the base motion, a
    record) with a [building] and a [coupling] table."""
    from runners.engine.records import prepare_scene  # reads the base record

    b, floor, mode, step, data = system_tables(data, source)
    try:
        scene = scene_from_dict(data, source)
    except SceneError as exc:
        raise CosimError(str(exc)) from None
    if not scene.is_record:
        raise CosimError(f"{source}: [excitation] must be the base's record (record = NAME or file = PATH): "
                         "the building's base moves with a record, the blocks with the floor")
    if scene.step_given:
        raise CosimError(f"{source}: [simulation] step: the communication step is [coupling] step")
    base_keys = {k for k in scene.parameters if k.startswith("excitation.")} - BASE_KEYS
    if base_keys:
        key = {fmu: k for k, (fmu, _) in SCHEMA["excitation"].items()}.get(min(base_keys), min(base_keys))
        raise CosimError(f"{source}: [excitation] {key}: the building's base moves with a record, horizontally "
                         "(give record or file, scale or pga, start_time)")
    try:
        prepare_scene(scene, factory)
    except OSError as exc:
        raise CosimError(f"{source}: [excitation] cannot read the record: {exc.strerror or exc}") from None
    except (SceneError, ValueError) as exc:
        raise CosimError(f"{source}: {exc}") from None
    try:
        check_step(scene.stop_time, step)
    except CosimError as exc:
        raise CosimError(f"{source}: {exc}") from None
    p = dict(scene.parameters)
    base = {k: p.pop(k) for k in list(p) if k.startswith("excitation.")}
    return System(name=scene.name, blocks=p, building=b, floor=floor, coupling=mode, step=step,
                  stop_time=float(scene.stop_time), base_file=Path(base["excitation.file"]),
                  base_scale=float(base.get("excitation.scale", 1.0)),
                  base_start=float(base.get("excitation.startTime", 0.0)), source=source)


def load_system(path: str | Path, factory=None) -> System:
    """Read and validate a system file (TOML: a scene plus [building] and [coupling])."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise CosimError(f"{path}: no such system file") from None
    except IsADirectoryError:
        raise CosimError(f"{path}: is a folder, not a system file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CosimError(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise CosimError(f"{path}: invalid TOML: {exc}") from None
    return system_from_dict(data, str(path), factory)


# ------------------------------------------------------------------ the SSP

def _enum_aliases(fmu: Path) -> dict[str, str]:
    """Enumeration parameter -> its Integer code parameter ("contact.model" -> "contact.modelCode"),
    where the FMU has one: libcosim and Ecos cannot set an FMI 2.0 Enumeration (docs/model.md), so the
    SSP sets the code, which every engine can."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu), validate=False)
    ints = {v.name for v in md.modelVariables if v.type == "Integer" and v.causality == "parameter"}
    return {v.name: v.name + "Code" for v in md.modelVariables
            if v.type == "Enumeration" and v.causality == "parameter" and v.name + "Code" in ints}


def system_components(system: System, block_fmu: Path, building_fmu: Path) -> tuple[list[Component], list[Connection]]:
    """The SSP's two components (parameters bound) and their connections."""
    j = system.floor
    aliases = _enum_aliases(block_fmu)
    block_params = {aliases.get(k, k): v for k, v in system.block_parameters().items()}
    building = Component(BUILDING, Path(building_fmu),
                         {f"storey[{j}].a": ("output", "Real"), f"storey[{j}].force": ("input", "Real")},
                         system.building_parameters())
    block = Component(BLOCK, Path(block_fmu),
                      {"ground.ah": ("input", "Real"), "contact.groundLoad": ("output", "Real")}, block_params)
    connections = [Connection(BUILDING, f"storey[{j}].a", BLOCK, "ground.ah")]
    if system.coupling == "two-way":
        connections.append(Connection(BLOCK, "contact.groundLoad", BUILDING, f"storey[{j}].force"))
    return [building, block], connections


def write_system_ssp(system: System, path: str | Path, block_fmu: Path | None = None,
                     building_fmu: Path | None = None) -> Path:
    """Write the system as an SSP archive (both FMUs inside, parameters bound, the base record
    named by its absolute path)."""
    block_fmu, building_fmu = _fmus(block_fmu, building_fmu)
    components, connections = system_components(system, block_fmu, building_fmu)
    description = (f"{system.name}: blocks on floor {system.floor} of a {system.building.storeys}-storey shear "
                   f"building, {system.coupling} coupling, communication step {system.step:g} s")
    try:
        return write_ssp(path, _ssp_name(system.name), components, connections, 0.0, system.stop_time, description,
                         system.step)
    except OSError as exc:
        raise CosimError(f"cannot write the SSP {path}: {exc.strerror or exc}") from None


def _ssp_name(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")[:60] or "system"


def _fmus(block_fmu: Path | None, building_fmu: Path | None) -> tuple[Path, Path]:
    from runners.engine.fmu import fmu_path_from

    block = fmu_path_from(str(block_fmu) if block_fmu else None)
    if building_fmu is None and os.environ.get("ROCKING_BUILDING_FMU"):
        building_fmu = Path(os.environ["ROCKING_BUILDING_FMU"])
    if building_fmu is None:
        from fmu_build.building import build_building_fmu

        building_fmu = build_building_fmu()
    for p, role, needs in ((Path(block), "the blocks' FMU (--fmu)", "contact.groundLoad"),
                           (Path(building_fmu), "the building's FMU", "storey[1].a")):
        _check_fmu(p, role, needs)
    return Path(block), Path(building_fmu)


def _check_fmu(path: Path, role: str, needs: str) -> None:
    """CosimError unless ``path`` is an FMI 2.0 Co-Simulation FMU with the variable ``needs``."""
    from fmpy import read_model_description

    if not path.is_file():
        raise CosimError(f"{role} {path} not found (make fmu builds it)")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as exc:  # noqa: BLE001 - not a zip, no modelDescription.xml, bad XML
        raise CosimError(f"{role} {path} is not an FMU: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise CosimError(f"{role} {path} is an FMI {md.fmiVersion} FMU{'' if md.coSimulation else ' without Co-Simulation'}: "
                         "the co-simulation runs FMI 2.0 Co-Simulation FMUs")
    if needs not in {v.name for v in md.modelVariables}:
        raise CosimError(f"{role} {path} has no variable {needs}: not the FMU this needs, or an older build (make fmu)")


# ------------------------------------------------------------------ results

@dataclass
class CosimResult:
    """Outputs after every communication step, at t_1 .. t_n (t_k = k h; libcosim offers no
    sample of t_0), read right after the step, before the outputs are passed to the inputs (an
    output that follows an input at once, such as contact.groundT, still has the input of the step
    that ended): ``time`` (s) and series named "building.<variable>" and "block.<variable>"."""

    system: System
    engine: str
    time: np.ndarray
    series: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.series[name]

    def floor(self, name: str) -> np.ndarray:
        """The building's storey output ``name`` (u, v or a) at the blocks' floor."""
        return self.series[f"{BUILDING}.storey[{self.system.floor}].{name}"]

    def to_pandas(self):
        """A DataFrame: a column ``time`` (s), then every series (SI units)."""
        import pandas as pd

        return pd.DataFrame({"time": self.time, **self.series})


def recorded_outputs(system: System) -> dict[str, list[str]]:
    """The variables a result keeps, per component."""
    block = BLOCK_OUTPUTS + (BLOCK2_OUTPUTS if int(system.blocks.get("nBlocks", 1)) == 2 else [])
    building = BUILDING_OUTPUTS + [f"storey[{i}].{q}" for i in range(1, system.building.storeys + 1)
                                   for q in STOREY_OUTPUTS]
    return {BLOCK: block, BUILDING: building}


def check_step(stop_time: float, step: float, step_name: str = "[coupling] step") -> int:
    """The number of communication steps to stop_time (s); CosimError unless both are finite and
    positive and stop_time is a whole number of steps (a fixed-step master cannot stop between)."""
    try:
        check_times(stop_time, step, "stop_time", step_name)
    except SceneError as exc:
        raise CosimError(str(exc)) from None
    n = round(stop_time / step)
    if n < 1 or abs(n * step - stop_time) > 1e-9 * stop_time:
        raise CosimError(f"stop_time {stop_time:g} s is not a whole number of communication steps of {step:g} s "
                         f"({stop_time / step:.6g}): a fixed-step co-simulation cannot stop between two")
    return n


def n_steps(system: System) -> int:
    return check_step(system.stop_time, system.step)


# ------------------------------------------------------------------ engines

def run(system: System, engine: str = "fmpy", block_fmu: Path | None = None, building_fmu: Path | None = None,
        ssp: str | Path | None = None, progress=None) -> CosimResult:
    """Write the system's SSP (to ``ssp``, else a temporary file) and run it with ``engine``
    ("fmpy": fmpy reads the SSP and the master here steps its FMUs; "libcosim": libcosim's SSP
    loader and fixed-step algorithm). ``progress(k, n)`` is called after every step, if given."""
    if engine not in ENGINES:
        raise CosimError(f"unknown engine '{engine}' (expected {', '.join(ENGINES)})")
    with tempfile.TemporaryDirectory(prefix="rocking-ssp-") as tmp:
        path = Path(ssp) if ssp else Path(tmp) / f"{_ssp_name(system.name)}.ssp"
        write_system_ssp(system, path, block_fmu, building_fmu)
        runner = run_ssp_fmpy if engine == "fmpy" else run_ssp_libcosim
        return runner(system, path, progress)


def run_ssp_fmpy(system: System, ssp: Path, progress=None, steps: int | None = None) -> CosimResult | None:
    """Run the SSP with fmpy: its SSD reader (validated against the SSP schema) gives components,
    parameter bindings and connections; fmpy's FMI 2.0 wrapper runs each FMU; the master steps
    them as libcosim's fixed-step algorithm does. ``steps = 0`` only initialises the FMUs (None
    when they accept their parameters, else CosimError with the FMU's message)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.ssp.ssd import read_ssd

    from runners.engine.fmu import fmi2_callbacks, getter, set_value

    ssd = read_ssd(str(ssp), validate=True)
    errors: list[str] = []  # the FMUs' own error messages, for a one-line error
    callbacks = fmi2_callbacks(  # kept alive until the instances are freed
        lambda status, name, _category, message: errors.append(f"{name}: {message}") if status >= 3 else None)
    h, n = system.step, n_steps(system) if steps is None else steps
    wanted = recorded_outputs(system)
    unzip = Path(tempfile.mkdtemp(prefix="rocking-cosim-"))
    slaves: dict[str, Any] = {}
    try:
        with zipfile.ZipFile(ssp) as zf:
            zf.extractall(unzip)
        info: dict[str, dict[str, Any]] = {}
        for comp in ssd.system.elements:
            fmu = unzip / comp.source
            md = read_model_description(str(fmu), validate=False)
            vars_ = {v.name: v for v in md.modelVariables}
            s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), unzipdir=str(unzip / comp.name)),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=comp.name)
            s.instantiate(callbacks=callbacks, loggingOn=False)
            slaves[comp.name] = s
            info[comp.name] = vars_
            s.setupExperiment(startTime=0.0, stopTime=n * h)
            for binding in comp.parameterBindings:
                for pset in binding.parameterValues:
                    for par in pset.parameters:  # an SSV Boolean comes as the text "true" or "false"
                        set_value(s, vars_[par.name], par.value == "true" if par.type == "Boolean" else par.value)
            s.enterInitializationMode()
            s.exitInitializationMode()
        links = [(c.startElement, info[c.startElement][c.startConnector].valueReference,
                  c.endElement, info[c.endElement][c.endConnector].valueReference) for c in ssd.system.connections]

        def transfer() -> None:
            for a, out, b, inp in links:
                slaves[b].setReal([inp], slaves[a].getReal([out]))

        readers = [getter(slaves[comp], [info[comp][name] for name in names]) for comp, names in wanted.items()]

        def sample() -> list[float]:
            return [x for read in readers for x in read()]

        transfer()
        rows = []
        for k in range(n):
            for s in slaves.values():
                status = s.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
                if status not in (0, None):
                    raise CosimError(f"fmpy: a doStep at t = {k * h:g} s returned status {status}")
            rows.append(sample())  # as libcosim's observer: after the step, before the transfer
            transfer()
            if progress:
                progress(k + 1, n)
        for s in slaves.values():
            s.terminate()
    except Exception as exc:  # an FMU's error status comes as fmpy's exception
        if isinstance(exc, CosimError):
            raise
        raise CosimError(f"fmpy: {errors[-1] if errors else exc}") from None
    finally:
        for s in slaves.values():
            try:
                s.freeInstance()
            except Exception:  # noqa: BLE001 - freeing after a failure
                pass
        shutil.rmtree(unzip, ignore_errors=True)
    return _result(system, "fmpy", h, rows, wanted) if rows else None


def _result(system: System, engine: str, h: float, rows: list[list[float]], wanted: dict[str, list[str]]) -> CosimResult:
    data = np.array(rows, dtype=float)
    names = [f"{comp}.{name}" for comp, names in wanted.items() for name in names]
    time = np.arange(1, len(rows) + 1) * h
    return CosimResult(system, engine, time, {name: data[:, j] for j, name in enumerate(names)})


def libcosim_available() -> str | None:
    """Why libcosim cannot run here, or None."""
    import importlib

    try:
        importlib.import_module("libcosimpy.CosimExecution")
    except Exception as exc:  # noqa: BLE001 - a missing wheel or native library
        return f"libcosim (pip libcosimpy) is not usable here: {exc}"
    return None


def run_ssp_libcosim(system: System, ssp: Path, progress=None) -> CosimResult:
    """Run the SSP with libcosim: its SSP loader builds the execution (components, parameter
    bindings, connections), its fixed-step algorithm steps it; a last-value observer reads the
    outputs after every step."""
    why = libcosim_available()
    if why:
        raise CosimError(why)
    # libcosim ends the process (std::terminate) when an FMU refuses its parameters: initialise
    # them with fmpy first, which reports the FMU's own message
    run_ssp_fmpy(system, ssp, steps=0)
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)  # its debug lines would flood the terminal

    h, n = system.step, n_steps(system)
    step_ns = round(h * 1e9)
    if abs(step_ns * 1e-9 - h) > 1e-15 * max(1.0, h):
        raise CosimError(f"libcosim counts time in nanoseconds: the step {h!r} s is not a whole number of them")
    unzip = Path(tempfile.mkdtemp(prefix="rocking-libcosim-"))
    try:
        with zipfile.ZipFile(ssp) as zf:
            zf.extractall(unzip)
        try:
            execution = CosimExecution.from_ssp_file(str(unzip / "SystemStructure.ssd"))  # the SSP's own step
        except Exception as exc:  # noqa: BLE001 - libcosim's loader reports through exceptions
            raise CosimError(f"libcosim could not load the SSP: {exc}") from None
        index = {s.name.decode(): s.index for s in execution.slave_infos()}
        observer = CosimObserver.create_last_value()
        execution.add_observer(observer)
        wanted = recorded_outputs(system)
        read = {CosimVariableType.REAL: observer.last_real_values, CosimVariableType.INTEGER: observer.last_integer_values,
                CosimVariableType.BOOLEAN: observer.last_boolean_values}
        groups = []  # (slave, type, [(column, reference)]): one observer call per slave and type
        column = 0
        for comp, names in wanted.items():
            vs = {v.name.decode(): v for v in execution.slave_variables(index[comp])}
            by_type: dict[CosimVariableType, list[tuple[int, int]]] = {}
            for name in names:
                by_type.setdefault(CosimVariableType(vs[name].type), []).append((column, vs[name].reference))
                column += 1
            groups += [(index[comp], typ, items) for typ, items in by_type.items()]

        def sample() -> list[float]:
            row = [0.0] * column
            for i, typ, items in groups:
                for (j, _), value in zip(items, read[typ](i, [ref for _, ref in items])):
                    row[j] = float(value)
            return row

        rows = []
        for k in range(n):
            if not execution.step():
                raise CosimError(f"libcosim: the step from t = {k * h:g} s failed (an FMU returned an error; "
                                 "--engine fmpy shows its message)")
            rows.append(sample())
            if progress:
                progress(k + 1, n)
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return _result(system, "libcosim", h, rows, wanted)

