"""Blocks on a floor of a building, co-simulated: RockingBlock.fmu on a storey of
ShearBuilding.fmu, connected by an SSP file and run by a fixed-step master (fmpy, or libcosim
through its SSP loader).

The building (a linear shear frame under a base acceleration record, docs/cosimulation.md) moves
the blocks' floor. ``one-way``: its floor's absolute acceleration drives the blocks (``storey[j].a``
to ``ground.ah``), and the blocks do not load it. ``two-way``: the floor is one body shared by both
FMUs. The blocks' FMU carries its mass (a free platform of ``storey[j].mass``, pushed by the
building's ``storey[j].structureForce`` through ``support.force``), so their forces and impacts act
on it at once; the building carries the blocks' mass as inertia (``storey[j].carriedMass``) and
takes their load beyond it, ``contact.groundLoad`` (its mean over each communication step, impacts
included) with ``contact.groundLoadSlope`` (the step's line with the same first moment).

Masters with a fixed communication step h. libcosim's, and ours with ``interpolate=False``, hold the
inputs: at t_k = k h every FMU steps to t_{k+1} with its inputs at the values of t_k (Jacobi). Ours by
default interpolates them with input derivatives: one-way the floor's acceleration as a parabola over
the step (the building first), two-way the storey force extrapolated from its value and derivatives
(the blocks first) and the blocks' load as its line (:func:`run_ssp_fmpy`).

Python API::

    from runners.engine import cosim
    system = cosim.load_system("examples/cabinet_on_floor.toml")
    ssp = cosim.write_system_ssp(system, "cabinet.ssp")
    result = cosim.run(system, engine="fmpy")             # or "libcosim"
    result["block.block1.theta"], result["building.storey[3].a"]   # arrays at result.time

Units SI (s, m, kg, N, J), angles in radians; signs as docs/conventions.md (+x to the right).
"""

from __future__ import annotations

import functools
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
from runners.engine.scene import SCHEMA, SceneError, check_times, implausible_sizes, scene_from_dict
from runners.engine.ssp import Component, Connection, write_ssp
from runners.engine.supports import COUPLINGS  # noqa: F401 (cosim.COUPLINGS, as before)
from runners.engine.supports import (COUPLING_KEYS, MAX_STOREYS, Building, SupportError, building_from_dict,
                                     check_coupling, check_damping, check_floor, check_number, positive)

BUILDING = "building"  # the SSP components' instance names
BLOCK = "block"
ENGINES = ("fmpy", "libcosim")
DEFAULT_STEP = 1e-3  # s

# the base motion's FMU parameters a system file may set ([excitation] record, file and pga besides)
BASE_KEYS = {"excitation.kind", "excitation.scale", "excitation.startTime", "excitation.file"}

# the blocks' outputs a result keeps (block 2's only for a stack)
BLOCK_OUTPUTS = ["block1.theta", "block1.omega", "impacts", "overturned", "lifts", "slides", "energy", "momentum",
                 "contact.groundLoad", "contact.groundT", "contact.groundN", "ground.ahTotal", "groundWork",
                 "block1.frictionLoss", "impactLoss", "block1.slip", "block1.maxAbsTheta"]
BLOCK2_OUTPUTS = ["block2.theta", "block2.omega", "block2.frictionLoss", "block2.overturned"]
BUILDING_OUTPUTS = ["base.aTotal", "energy", "baseWork", "forceWork", "dampingLoss", "baseShear"]
STOREY_OUTPUTS = ["u", "v", "a"]


# two-way: the blocks' floor in RockingBlock.fmu, a free mass coupled with them (System.block_parameters)
FLOOR_PLATFORM = {"support.kind": 2, "support.coupling": 1, "platform.stiffness": 0.0, "platform.damping": 0.0}


class CosimError(SupportError):
    """A system file or a co-simulation request is invalid, or an engine failed; one line."""


@dataclass
class System:
    """Blocks (a scene's [block], [block2], [contact], [restitution], [simulation]) standing on
    floor ``floor`` of ``building``, whose base moves with a record (file the building's FMU reads,
    scale, start time).

    ``stop_time`` (s) must be a whole number of communication steps ``step`` (s). None: the run
    ends at the first communication point at or after ``default_stop_time`` (the base record's end
    plus 5 s, which load_system sets), so that it runs the whole record whatever the step.
    :func:`check_system` says, in one line, what is wrong with a system before anything runs;
    :func:`run` and :func:`write_system_ssp` call it."""

    name: str
    blocks: dict[str, Any]  # the blocks' FMU parameters (no excitation: the floor drives them)
    building: Building
    floor: int
    coupling: str
    step: float  # s, the communication step
    stop_time: float | None  # s; None: at or after default_stop_time
    base_file: Path
    base_scale: float = 1.0
    base_start: float = 0.0
    source: str = ""
    notes: list[str] = field(default_factory=list)  # the base record's notes (units, a run shorter than it)
    default_stop_time: float | None = None  # s, the base record's end plus 5 s
    record_file: Path | None = None  # the record file the system file names ([excitation] file), if any
    # the base record: {"id": its id in the database (None: a file not stored), "name": its name}
    record: dict[str, Any] | None = None

    @property
    def blocks_mass(self) -> float:
        """kg, the mass the floor carries."""
        m = float(self.blocks.get("block1.mass", 10.0))
        if int(self.blocks.get("nBlocks", 1)) == 2:
            m += float(self.blocks.get("block2.mass", 5.0))
        return m

    @property
    def end_time(self) -> float:
        """s, when the run ends: a whole number of communication steps (:func:`n_steps`)."""
        return n_steps(self) * self.step

    def building_parameters(self) -> dict[str, Any]:
        """ShearBuilding.fmu's parameters. Two-way coupling gives their floor the blocks' mass to carry (carriedMass:
        inertia, not the structure's Rayleigh damping), so that the building takes their load beyond carrying them
        along: the same structure as RockingBlock.fmu's built-in support."""
        b = self.building
        p: dict[str, Any] = {"nStoreys": b.storeys, "damping.ratio": float(b.damping_ratio)}
        for i, (m, k) in enumerate(zip(b.mass, b.stiffness), start=1):
            if i == self.floor and self.coupling == "two-way":
                p[f"storey[{i}].carriedMass"] = float(self.blocks_mass)
            p[f"storey[{i}].mass"] = float(m)
            p[f"storey[{i}].stiffness"] = float(k)
        p["excitation.file"] = str(self.base_file)
        p["excitation.scale"] = float(self.base_scale)
        p["excitation.startTime"] = float(self.base_start)
        return p

    def block_parameters(self) -> dict[str, Any]:
        """RockingBlock.fmu's parameters. Two-way coupling puts the blocks on their floor's own mass (structure only), a
        free platform in the FMU pushed by the rest of the building (the input support.force, the building's
        storey[j].structureForce): the blocks' forces and impacts act on that mass at once (docs/cosimulation.md)."""
        p = {**SCENE_DEFAULTS, **self.blocks}
        if self.coupling == "two-way":
            p.update(FLOOR_PLATFORM, **{"platform.mass": float(self.building.mass[self.floor - 1])})
        return p


# How a system file names what it sets (check_system's messages); the Python API's names are the
# fields of System and Building
FILE_NAMES = {"floor": "[coupling] floor", "coupling": "[coupling] mode", "step": "[coupling] step",
              "stop_time": "[simulation] stop_time", "mass": "[building] mass", "stiffness": "[building] stiffness",
              "damping_ratio": "[building] damping_ratio", "blocks": "the blocks' tables",
              "base_file": "[excitation] file", "base_scale": "[excitation] scale",
              "base_start": "[excitation] start_time"}


def system_tables(data: dict[str, Any], source: str = "<system>") -> tuple[Building, int, str, float, dict[str, Any]]:
    """Validate a system document's [building] and [coupling] tables: the building, the blocks'
    floor, the coupling mode and the communication step (s), and the rest of the document (the
    blocks' scene)."""
    try:
        return _system_tables(dict(data), source)
    except CosimError:
        raise
    except SupportError as exc:
        raise CosimError(str(exc)) from None


def _system_tables(data: dict[str, Any], source: str) -> tuple[Building, int, str, float, dict[str, Any]]:
    if "building" not in data:
        raise CosimError(f"{source}: no [building] table (storeys, mass, stiffness, damping_ratio)")
    building = data.pop("building")
    coupling = data.pop("coupling", {})
    if not isinstance(building, dict) or not isinstance(coupling, dict):
        raise CosimError(f"{source}: [building] and [coupling] must be tables")
    tables = sorted(set(data) - set(SCHEMA) - {"name"})
    if tables:  # (the scene's own check would not name [building] and [coupling])
        raise CosimError(f"{source}: unknown table [{tables[0]}] (expected building, coupling, {', '.join(SCHEMA)})")
    b = building_from_dict(building, source)
    unknown = sorted(set(coupling) - COUPLING_KEYS)
    if unknown:
        raise CosimError(f"{source}: [coupling] unknown key '{unknown[0]}' (expected floor, mode, step)")
    floor = check_floor(f"{source}: {FILE_NAMES['floor']}", coupling.get("floor", b.storeys), b.storeys)
    mode = check_coupling(f"{source}: {FILE_NAMES['coupling']}", coupling.get("mode", "two-way"))
    step = check_number(f"{source}: {FILE_NAMES['step']}", coupling.get("step", DEFAULT_STEP))
    return b, floor, mode, step, data


def _system_scene(data: dict[str, Any], source: str) -> tuple[Building, int, str, float, Any]:
    """The building, the blocks' floor, the coupling, the communication step (s) and the blocks'
    scene of a parsed system document, checked without reading the base record."""
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
    return b, floor, mode, step, scene


def system_from_dict(data: dict[str, Any], source: str = "<system>", factory=None) -> System:
    """Validate a parsed system document: a scene (its [excitation] is the base motion, a
    record) with a [building] and a [coupling] table."""
    from runners.engine.records import TAIL, prepare_scene  # reads the base record

    b, floor, mode, step, scene = _system_scene(data, source)
    try:
        prepared = prepare_scene(scene, factory)
    except OSError as exc:
        raise CosimError(f"{source}: [excitation] cannot read the record: {exc.strerror or exc}") from None
    except (SceneError, ValueError) as exc:
        raise CosimError(f"{source}: {exc}") from None
    p = dict(scene.parameters)
    base = {k: p.pop(k) for k in list(p) if k.startswith("excitation.")}
    start = float(base.get("excitation.startTime", 0.0))
    system = System(name=scene.name, blocks=p, building=b, floor=floor, coupling=mode, step=step,
                    stop_time=float(scene.stop_time) if scene.stop_time_given else None,
                    base_file=Path(base["excitation.file"]), base_scale=float(base.get("excitation.scale", 1.0)),
                    base_start=start, source=source, notes=list(prepared.notes),
                    default_stop_time=start + prepared.end + TAIL,
                    record_file=Path(scene.file) if scene.file else None,
                    record={"id": prepared.record_id, "name": prepared.name})
    check_system(system, FILE_NAMES, source)
    return system


def load_system(path: str | Path, factory=None) -> System:
    """Read and validate a system file (TOML: a scene plus [building] and [coupling])."""
    return system_from_dict(_read_system_file(path), str(path), factory)


def check_system_file(path: str | Path) -> Path | None:
    """CosimError, in one line, for a system file that cannot be read or whose tables are invalid,
    without reading its base record or opening a database (load_system does both); the record file
    it names ([excitation] file), if any."""
    scene = _system_scene(_read_system_file(path), str(path))[-1]
    return Path(scene.file) if scene.file else None


def _read_system_file(path: str | Path) -> dict[str, Any]:
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
    return data


# ------------------------------------------------------------------ checks the command line and the API share

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
    """The number of communication steps of a run: to ``stop_time``, which must be a whole number
    of them, or (``stop_time`` None) to the first communication point at or after
    ``default_stop_time``, the base record's end plus 5 s (rounded up: the whole record runs)."""
    if system.stop_time is not None:
        return check_step(system.stop_time, system.step)
    wanted = system.default_stop_time
    try:
        check_times(wanted, system.step, "default_stop_time", "step")
    except (SceneError, TypeError) as exc:
        raise CosimError(f"stop_time is None and {exc}" if isinstance(exc, SceneError) else
                         f"stop_time is None and default_stop_time is {wanted!r}: give a stop time (s)") from None
    return max(1, math.ceil(wanted / system.step - 1e-9))


class InvalidSystem(CosimError):
    """A System that cannot run (a floor the building does not have, an unknown coupling...);
    one line, raised before anything runs."""


def check_system(system: System, names: dict[str, str] | None = None, where: str = "") -> None:
    """InvalidSystem, in one line, unless ``system`` can run: a building of 1 to 10 storeys with a
    positive mass and stiffness each and a damping ratio in [0, 1), a floor of it, a known coupling,
    a positive step and a stop time that is a whole number of steps (or None), blocks without an
    excitation of their own (their floor drives them), an existing base record with a finite scale and
    start time. ``names``: how the caller's user names the fields in messages (FILE_NAMES for a
    system file, {"step": "--step"} for an option; else the fields' own names); ``where``: a prefix
    (the system file)."""
    name = {**{k: k for k in FILE_NAMES}, **(names or {})}
    try:
        _check_building(system.building, name)
        check_floor(name["floor"], system.floor, system.building.storeys)
        check_coupling(name["coupling"], system.coupling)
        _check_times(system, name)
        _check_inputs(system, name)
    except SupportError as exc:
        raise InvalidSystem(f"{where}: {exc}" if where else str(exc)) from None


def _check_building(b: Any, name: dict[str, str]) -> None:
    if not isinstance(b, Building):
        raise CosimError(f"building must be a Building, got {type(b).__name__}")
    for key in ("mass", "stiffness"):
        values = getattr(b, key)
        if not isinstance(values, (list, tuple)) or not 1 <= len(values) <= MAX_STOREYS:
            raise CosimError(f"{name[key]} must be a list of 1 to {MAX_STOREYS} values, one per storey, got {values!r}")
        positive(name[key], list(values))
    if len(b.stiffness) != len(b.mass):
        raise CosimError(f"{name['stiffness']}: {len(b.stiffness)} values for {len(b.mass)} storeys")
    check_damping(name["damping_ratio"], b.damping_ratio)


def _check_times(system: System, name: dict[str, str]) -> None:
    check_number(name["step"], system.step)
    if not system.step > 0:
        raise CosimError(f"{name['step']} must be > 0 s, got {system.step!r}")
    if system.stop_time is not None:
        check_number(name["stop_time"], system.stop_time)
        check_step(system.stop_time, system.step, name["step"])
    else:
        n_steps(system)


def _check_inputs(system: System, name: dict[str, str]) -> None:
    """The blocks' parameters (no excitation of their own) and the base record."""
    if not isinstance(system.blocks, dict):
        raise CosimError(f"blocks must be a dict of the blocks' FMU parameters, got {type(system.blocks).__name__}")
    moved = sorted(k for k in system.blocks if str(k).startswith("excitation.") or k == "ground.ah")
    if moved:
        raise CosimError(f"{name['blocks']} set {moved[0]}: the floor drives the blocks (the base's motion is "
                         "the building's record)")
    for key in ("block1.mass", "block2.mass"):  # (two-way, the building carries them: said as the blocks')
        if key in system.blocks:
            positive(key, [system.blocks[key]])
    placed = sorted(k for k in system.blocks if str(k).split(".")[0] in ("support", "platform", "building"))
    if placed:
        raise CosimError(f"{name['blocks']} set {placed[0]}: the system's building is the blocks' support")
    if not Path(system.base_file).is_file():
        raise CosimError(f"{name['base_file']} {system.base_file}: no such record file")
    check_number(name["base_scale"], system.base_scale, "a finite number")
    check_number(name["base_start"], system.base_start)


# a floor lighter than this (kg), or blocks this many times heavier than their floor: floor masses
# typed in tonnes, most likely (a building's floor weighs tonnes)
LIGHT_FLOOR = 100.0
UNIT_SLIP_RATIO = 10.0


def mass_notes(system: System) -> list[str]:
    """Notes on the building's masses: floors implausibly light for a building, or blocks much
    heavier than their floor (floor masses in tonnes instead of kg, most likely)."""
    floor = system.building.mass[system.floor - 1]
    ratio = system.blocks_mass / floor
    notes = []
    if ratio >= UNIT_SLIP_RATIO or min(system.building.mass) < LIGHT_FLOOR:
        masses = ", ".join(f"{m:g}" for m in system.building.mass)
        notes.append(f"check the building's masses: floors of {masses} kg carry {system.blocks_mass:g} kg of blocks "
                     f"on floor {system.floor} ({ratio:.3g} times its mass); the masses are in kg per floor, not "
                     "tonnes (a 20 t floor is mass = 20000.0)")
    return notes


def natural_frequencies(system: System) -> list[float]:
    """Hz, the building's natural frequencies with the floor masses the run uses (two-way: the
    blocks' mass on their floor), lowest first."""
    p = system.building_parameters()
    n = int(p["nStoreys"])
    m = np.array([p[f"storey[{i}].mass"] + p.get(f"storey[{i}].carriedMass", 0.0) for i in range(1, n + 1)])
    k = np.array([p[f"storey[{i}].stiffness"] for i in range(1, n + 1)])
    K = np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2 = np.linalg.eigvalsh(K / np.sqrt(np.outer(m, m)))
    return [float(f) for f in np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)]


STEPS_PER_PERIOD = 10  # communication steps per period of the building's highest mode, at least


def step_notes(system: System) -> list[str]:
    """A note when the communication step is longer than a tenth of the building's shortest
    natural period: the floor's acceleration, held over each step, then misses its highest mode."""
    f = max(natural_frequencies(system))
    if system.step * f > 1 / STEPS_PER_PERIOD:
        return [f"the communication step {system.step:g} s is longer than a tenth of the building's shortest natural "
                f"period ({1 / f:.3g} s, {f:.3g} Hz): the blocks see the floor's acceleration held over each step, "
                f"so take a step below {1 / (STEPS_PER_PERIOD * f):.2g} s (docs/cosimulation.md#limits)"]
    return []


def system_notes(system: System) -> list[str]:
    """What to read before trusting a run of ``system`` (notes, not errors): the base record's own,
    the blocks' implausible sizes, the building's masses and the communication step."""
    return [*system.notes, *implausible_sizes(system.block_parameters()), *mass_notes(system), *step_notes(system)]


# ------------------------------------------------------------------ the SSP

def _model_description(fmu: Path):
    """fmpy's reading of an FMU's modelDescription.xml, read once per version of the file."""
    st = Path(fmu).stat()
    return _read_model_description(str(Path(fmu).resolve()), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=8)
def _read_model_description(path: str, _mtime_ns: int, _size: int):
    from fmpy import read_model_description

    return read_model_description(path, validate=False)


def _block_parameters(system: System, fmu: Path) -> dict[str, Any]:
    """The blocks' parameters as the SSP binds them: an Enumeration by its Integer code parameter
    ("contact.model" -> "contact.modelCode") where the FMU has one (libcosim and Ecos cannot set an
    FMI 2.0 Enumeration, docs/model.md; every engine can set the code). InvalidSystem for a name
    that is no parameter or input of the blocks' FMU."""
    md = _model_description(fmu)
    settable = {v.name: v for v in md.modelVariables if v.causality in ("parameter", "input")}
    ints = {name for name, v in settable.items() if v.type == "Integer" and v.causality == "parameter"}
    aliases = {name: name + "Code" for name, v in settable.items()
               if v.type == "Enumeration" and v.causality == "parameter" and name + "Code" in ints}
    unknown = sorted(k for k in system.blocks if k not in settable)
    if unknown:
        raise InvalidSystem(f"blocks: {unknown[0]!r} is not a parameter of the blocks' FMU {fmu.name}")
    return {aliases.get(k, k): v for k, v in system.block_parameters().items()}


def system_components(system: System, block_fmu: Path, building_fmu: Path) -> tuple[list[Component], list[Connection]]:
    """The SSP's two components (parameters bound) and their connections."""
    j = system.floor
    if system.coupling == "one-way":  # the floor's acceleration drives the blocks
        building = Component(BUILDING, Path(building_fmu), {f"storey[{j}].a": ("output", "Real")},
                             system.building_parameters())
        block = Component(BLOCK, Path(block_fmu), {"ground.ah": ("input", "Real")},
                          _block_parameters(system, Path(block_fmu)))
        return [building, block], [Connection(BUILDING, f"storey[{j}].a", BLOCK, "ground.ah")]
    # two-way: the storeys push the blocks' floor (its mass in the blocks' FMU), the blocks load the building's
    building = Component(BUILDING, Path(building_fmu), {f"storey[{j}].structureForce": ("output", "Real"),
                                                        f"storey[{j}].force": ("input", "Real")},
                         system.building_parameters())
    block = Component(BLOCK, Path(block_fmu), {"support.force": ("input", "Real"),
                                               "contact.groundLoad": ("output", "Real")},
                      _block_parameters(system, Path(block_fmu)))
    return [building, block], [Connection(BUILDING, f"storey[{j}].structureForce", BLOCK, "support.force"),
                               Connection(BLOCK, "contact.groundLoad", BUILDING, f"storey[{j}].force")]


def write_system_ssp(system: System, path: str | Path, block_fmu: Path | None = None,
                     building_fmu: Path | None = None) -> Path:
    """Write the system as an SSP archive (both FMUs inside, parameters bound, the base record
    named by its absolute path). InvalidSystem, before anything is written, for a system that
    cannot run (:func:`check_system`)."""
    check_system(system)
    return _write_ssp(system, path, *_fmus(block_fmu, building_fmu))


# The base record's name in the resources of the SSP's copy of the building FMU, which runs it when excitation.file is
# empty (model/c/building/building.h's BUILDING_BASE_RECORD)
BASE_RECORD = "base_record.txt"


def _with_record(building_fmu: Path, record: Path, folder: Path) -> Path:
    """A copy of the building FMU in ``folder`` that carries ``record`` in its resources (BASE_RECORD): it runs it
    with excitation.file empty, so a tool that sets no String parameters (OMSimulator drops them) still has it."""
    out = folder / Path(building_fmu).name
    with zipfile.ZipFile(building_fmu) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info))
        dst.write(record, f"resources/{BASE_RECORD}")
    return out


def _write_ssp(system: System, path: str | Path, block_fmu: Path, building_fmu: Path) -> Path:
    """write_system_ssp with the system checked and the FMUs found. The building FMU goes in with the base record in
    its resources, which the binding names relative to them (a tool that drops the binding runs it too)."""
    description = (f"{system.name}: blocks on floor {system.floor} of a {system.building.storeys}-storey shear "
                   f"building, {system.coupling} coupling, communication step {system.step:g} s")
    try:
        with tempfile.TemporaryDirectory(prefix="rocking-ssp-") as tmp:
            building = _with_record(building_fmu, Path(system.base_file), Path(tmp))
            components, connections = system_components(system, block_fmu, building)
            for c in components:
                if c.fmu == building:
                    c.parameters["excitation.file"] = BASE_RECORD
            return write_ssp(path, _ssp_name(system.name), components, connections, 0.0, system.end_time,
                             description, system.step)
    except OSError as exc:
        raise CosimError(f"cannot write the SSP {path}: {exc.strerror or exc}") from None


def _ssp_name(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")[:60] or "system"


def fmu_files(block_fmu: Path | None = None, building_fmu: Path | None = None) -> tuple[Path, Path]:
    """The FMU files a run reads, without building them: the blocks' (``block_fmu``, else
    ROCKING_FMU, else build/RockingBlock.fmu) and the building's (``building_fmu``, else
    ROCKING_BUILDING_FMU, else build/ShearBuilding.fmu)."""
    from fmu_build.build import default_fmu_path
    from fmu_build.building import default_building_path

    block = block_fmu or os.environ.get("ROCKING_FMU") or default_fmu_path()
    return Path(block), Path(building_fmu or os.environ.get("ROCKING_BUILDING_FMU") or default_building_path())


def _fmus(block_fmu: Path | None, building_fmu: Path | None) -> tuple[Path, Path]:
    """fmu_files(), each built first if it is the default build and missing or out of date;
    CosimError unless they are the FMUs a system needs."""
    from runners.engine.fmu import fmu_path_from

    block = fmu_path_from(str(block_fmu) if block_fmu else None)
    building = fmu_files(block, building_fmu)[1]
    if building_fmu is None and not os.environ.get("ROCKING_BUILDING_FMU"):
        from fmu_build.building import build_building_fmu

        building = build_building_fmu()
    for p, role, needs in ((block, "the blocks' FMU (--fmu)", "contact.groundLoadSlope"),
                           (building, "the building's FMU", "storey[1].carriedMass")):
        _check_fmu(p, role, needs)
    return block, building


def _check_fmu(path: Path, role: str, needs: str) -> None:
    """CosimError unless ``path`` is an FMI 2.0 Co-Simulation FMU with the variable ``needs``."""
    if not path.is_file():
        raise CosimError(f"{role} {path} not found (make fmu builds it)")
    try:
        md = _model_description(path)
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
    # the blocks' parameters as run: the FMU's start values, the system's over them
    block_parameters: dict[str, Any] = field(default_factory=dict)
    block_fmu: Path | None = None  # the FMUs that ran (run() sets them)
    building_fmu: Path | None = None
    passes: int = 0  # passes over the communication steps in all (the iterated two-way master; 0: one each)
    # how the master passed the inputs (SCHEMES): "held" (libcosim's algorithm), "interpolated" (one-way parabolas),
    # "interface" (two-way: the blocks' floor force extrapolated, their load a line), "iterated" (that, to convergence)
    scheme: str = "held"

    def __getitem__(self, name: str) -> np.ndarray:
        return self.series[name]

    def floor(self, name: str) -> np.ndarray:
        """The building's storey output ``name`` (u, v or a) at the blocks' floor; two-way, its acceleration ``a`` is
        the blocks' FMU's (ground.ahTotal), which carries the floor's mass with the blocks' forces at each instant (the
        building takes their load as a line over each step: at a communication point after an impact its own
        storey[j].a holds the impulse spread over the step, about J / (h m), no acceleration the floor had)."""
        if name == "a" and self.system.coupling == "two-way":
            return self.series[f"{BLOCK}.ground.ahTotal"]
        return self.series[f"{BUILDING}.storey[{self.system.floor}].{name}"]

    @property
    def notes(self) -> list[str]:
        """What to read before trusting the run (system_notes: the building's masses, the step...)."""
        return system_notes(self.system)

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


# ------------------------------------------------------------------ engines

def run(system: System, engine: str = "fmpy", block_fmu: Path | None = None, building_fmu: Path | None = None,
        ssp: str | Path | None = None, progress=None, interpolate: bool = True, iterate: bool = False) -> CosimResult:
    """Write the system's SSP (to ``ssp``, else a temporary file) and run it with ``engine``
    ("fmpy": fmpy reads the SSP and the master here steps its FMUs, with input derivatives unless
    ``interpolate`` is False (then held): one-way the building first and the floor's acceleration a parabola
    over each step, two-way the blocks first with the storey force extrapolated and the building with their load's
    line, each step iterated with ``iterate`` (:func:`run_ssp_fmpy`);
    "libcosim": libcosim's SSP loader and fixed-step algorithm). ``progress(k, n)`` is called after every
    step, if given.
    InvalidSystem, before anything runs, for a system that cannot run (:func:`check_system`);
    ``result.notes`` says what to read before trusting the run (:func:`system_notes`)."""
    if engine not in ENGINES:
        raise CosimError(f"unknown engine '{engine}' (expected {', '.join(ENGINES)})")
    check_system(system)
    block_fmu, building_fmu = _fmus(block_fmu, building_fmu)
    with tempfile.TemporaryDirectory(prefix="rocking-ssp-") as tmp:
        path = Path(ssp) if ssp else Path(tmp) / f"{_ssp_name(system.name)}.ssp"
        _write_ssp(system, path, block_fmu, building_fmu)
        if engine == "fmpy":
            result = run_ssp_fmpy(system, path, progress, interpolate=interpolate, iterate=iterate)
        else:
            result = run_ssp_libcosim(system, path, progress)
    result.block_parameters = {**_start_values(block_fmu), **system.block_parameters()}
    result.block_fmu, result.building_fmu = Path(block_fmu), Path(building_fmu)
    why = divergence(result)
    if why:
        raise CosimDiverged(why, result)
    return result


class CosimDiverged(CosimError):
    """Two-way coupling made energy (the run diverged); ``result`` holds the run."""

    def __init__(self, message: str, result: CosimResult):
        super().__init__(message)
        self.result = result


# the blocks' load doing more work on the floor than this many times the energy the system was given
# (the base's work so far, the blocks' initial energy): energy the coupling made, a run that diverged.
# Measured on examples/cabinet_on_floor.toml's cabinet and on a crate that slides, floors of 2 t down
# to 20 kg, steps of 2 to 0.25 ms: the runs that hold stay below 3.5, those that diverge (blocks 2 to 50
# times their floor) pass 500, most of them 1e17, within seconds.
DIVERGED = 10.0


def divergence(result: CosimResult) -> str | None:
    """Why a two-way run diverged (one line), or None: its floor forces' work beyond DIVERGED times the
    energy the system was given, or outputs that are not finite."""
    s = result.series
    if result.system.coupling != "two-way":
        return None
    work = np.abs(s[f"{BUILDING}.forceWork"])
    given = np.maximum.accumulate(np.abs(s[f"{BUILDING}.baseWork"])) + abs(float(s[f"{BLOCK}.energy"][0])) + 1e-9
    bad = (work > DIVERGED * given) | ~np.all(np.isfinite(np.column_stack(list(s.values()))), axis=1)
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    system = result.system
    f = max(natural_frequencies(system))
    return (f"two-way coupling diverged at t = {result.time[k]:.4g} s: the blocks' load had done {work[k]:.3g} J of "
            f"work on the floor, more than {DIVERGED:g} times the {given[k]:.3g} J the system was given; the step "
            f"{system.step:g} s is {system.step * f:.3g} periods of the building's highest mode ({f:.3g} Hz; check "
            f"the masses, in kg), so take a step below {1 / (STEPS_PER_PERIOD * f):.2g} s (docs/cosimulation.md#limits)")


def _start_values(fmu: Path) -> dict[str, float]:
    """The start values of an FMU's Real and Integer parameters."""
    return {v.name: float(v.start) for v in _model_description(fmu).modelVariables
            if v.causality == "parameter" and v.type in ("Real", "Integer") and v.start is not None}


def _order(names: list[str], links: list[tuple]) -> list[str] | None:
    """The components in an order where each comes after those it reads (None if the connections loop: two-way)."""
    order, left = [], list(names)
    while left:
        ready = [c for c in left if not any(b == c and a in left for a, _, b, _ in links)]
        if not ready:
            return None
        order += ready
        left = [c for c in left if c not in ready]
    return order


MAX_SWEEPS = 8  # passes over a two-way step at most
SWEEP_TOL = 1e-6  # a fed-back value converged: its change, relative to the largest such value so far


def _pass(slaves, links, order, slopes, held, before, h, step) -> None:
    """One pass over a one-way communication step: each component in `order` gets its inputs and steps. An input from
    a component already stepped is the parabola through its source's outputs at the step before's start, this step's
    start and its end (the straight line on the first step) where its FMU takes derivatives (slopes), else held (as
    the transfer set it)."""
    for name in order:
        for i, (a, out, b, inp) in enumerate(links):
            if b != name or not slopes[b]:
                continue
            end, now = slaves[a].getReal([out])[0], held[i]
            slaves[b].setReal([inp], [now])
            if before is None:
                slaves[b].setRealInputDerivatives([inp], [1], [(end - now) / h])
            else:
                prev = before[i]
                slaves[b].setRealInputDerivatives([inp, inp], [1, 2], [(end - prev) / (2.0 * h),
                                                                        (end - 2.0 * now + prev) / h ** 2])
        step(name)


@dataclass
class _InterfaceLinks:
    """The links of a two-way system whose load carries its line and whose floor force its rate
    (:func:`_interface_links`): ``slope`` maps a link to its source's slope output (value reference), ``rate`` lists
    the links whose source gives its output's derivative."""

    links: list[tuple]
    slope: dict[int, int]
    rate: list[int]

    def rates(self, slaves) -> dict[int, float]:
        """Each rate link's source's output derivative now."""
        return {i: slaves[self.links[i][0]].getRealOutputDerivatives([self.links[i][1]], [1])[0] for i in self.rate}

    def back(self, order: list[str]) -> list[int]:
        """The rate links fed back: their source steps after the component they drive."""
        return [i for i in self.rate if order.index(self.links[i][0]) > order.index(self.links[i][2])]

    def step(self, slaves, order, held, rates, rates_before, ends, h, step) -> None:
        """One pass over a communication step [t_k, t_k + h] in ``order``. A load link whose source stepped: the
        straight line with the step's mean and first moment, mean - slope h / 2 + slope (t - t_k). A rate link: the
        parabola with the source's value and derivative at t_k and its value at the step's end (``ends``, from the
        last pass or this one), else its curvature from the derivatives at t_k-1 and t_k (extrapolated). Any other
        link: its value at t_k, held."""
        done: set[str] = set()
        for name in order:
            for i, (a, out, b, inp) in enumerate(self.links):
                if b != name:
                    continue
                if i in self.slope and a in done:
                    mean, slope = slaves[a].getReal([out, self.slope[i]])
                    slaves[b].setReal([inp], [mean - 0.5 * slope * h])
                    slaves[b].setRealInputDerivatives([inp], [1], [slope])
                elif i in self.rate:
                    x0, d0 = held[i], rates[i]
                    end = slaves[a].getReal([out])[0] if a in done else ends.get(i)
                    if end is not None:
                        d2 = 2.0 * (end - x0 - h * d0) / h ** 2
                    else:
                        d2 = (d0 - rates_before[i]) / h if rates_before is not None else 0.0
                    slaves[b].setReal([inp], [x0])
                    slaves[b].setRealInputDerivatives([inp, inp], [1, 2], [d0, d2])
                else:
                    slaves[b].setReal([inp], [held[i]])
            step(name)
            done.add(name)


def _interface_links(slaves, info, links, slopes, outputs_rate) -> _InterfaceLinks | None:
    """A two-way system's links as _InterfaceLinks where each one's target takes input derivatives and its source gives
    either its output's slope (a variable named the output's name + "Slope": contact.groundLoad's) or its derivative
    (maxOutputDerivativeOrder >= 1), one of each at least; else None (held Jacobi)."""
    slope, rate = {}, []
    names = {c: {v.valueReference: name for name, v in info[c].items()} for c in info}
    for i, (a, out, b, _) in enumerate(links):
        if not slopes[b]:
            return None
        companion = info[a].get(names[a][out] + "Slope")
        if companion is not None and companion.causality == "output":
            slope[i] = companion.valueReference
        elif outputs_rate[a]:
            rate.append(i)
        else:
            return None
    return _InterfaceLinks(links, slope, rate) if slope and rate else None


def run_ssp_fmpy(system: System, ssp: Path, progress=None, steps: int | None = None,
                 interpolate: bool = True, iterate: bool = False) -> CosimResult | None:
    """Run the SSP with fmpy: its SSD reader (validated against the SSP schema) gives components,
    parameter bindings and connections; fmpy's FMI 2.0 wrapper runs each FMU. ``steps = 0`` only
    initialises the FMUs (None when they accept their parameters, else CosimError with the FMU's message).

    Where the connections do not loop (one-way coupling) and ``interpolate``, the master steps the FMUs in
    that order, each after those it reads, and gives an input that can take it (canInterpolateInputs) the
    parabola through its source's outputs at the step before's start, this step's start and its end (on the
    first step the straight line): its value and first and second derivatives (fmi2SetRealInputDerivatives).
    The blocks then feel the floor's acceleration interpolated to third order in the step instead of held.

    Two-way with ``interpolate`` (every link's target taking input derivatives, a source giving its output's
    slope and one its derivative: _interface_links): the source of the slope (the blocks) steps first, with
    the other's output (the storey force) extrapolated as a parabola from its value and derivative at t_k
    and its derivative at t_k-1; then the other, with the load as the straight line of the step's mean and
    slope. With ``iterate`` (every FMU able to save and restore its state) the step is taken again from the
    saved states with the storey force interpolated through its value at the step's end, until that value
    changes by at most SWEEP_TOL of the largest so far (at most MAX_SWEEPS passes; ``result.passes`` counts
    them). Otherwise (``interpolate=False``, or FMUs without derivatives) every FMU steps from the outputs of
    the step before, held: libcosim's fixed-step algorithm. ``result.scheme`` says which ran."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.ssp.ssd import read_ssd

    from runners.engine.fmu import fmi2_callbacks, getter, set_value

    ssd = read_ssd(str(ssp), validate=True)
    errors: list[str] = []  # the FMUs' own error messages, for a one-line error
    callbacks = fmi2_callbacks(  # kept alive until the instances are freed
        lambda status, name, _category, message: errors.append(f"{name}: {message}") if status >= 3 else None)
    h, n = system.step, n_steps(system) if steps is None else steps
    iterations: list[int] = []  # passes over each step (two-way, iterated)
    wanted = recorded_outputs(system)
    unzip = Path(tempfile.mkdtemp(prefix="rocking-cosim-"))
    slaves: dict[str, Any] = {}
    try:
        with zipfile.ZipFile(ssp) as zf:
            zf.extractall(unzip)
        info: dict[str, dict[str, Any]] = {}
        slopes: dict[str, bool] = {}  # the component takes input derivatives
        states: dict[str, bool] = {}  # and rolls back
        outputs_rate: dict[str, bool] = {}  # and gives its outputs' first derivatives
        for comp in ssd.system.elements:
            fmu = unzip / comp.source
            md = read_model_description(str(fmu), validate=False)
            vars_ = {v.name: v for v in md.modelVariables}
            s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), unzipdir=str(unzip / comp.name)),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=comp.name)
            s.instantiate(callbacks=callbacks, loggingOn=False)
            slaves[comp.name] = s
            info[comp.name] = vars_
            slopes[comp.name] = bool(md.coSimulation.canInterpolateInputs)
            states[comp.name] = bool(md.coSimulation.canGetAndSetFMUstate)
            outputs_rate[comp.name] = int(md.coSimulation.maxOutputDerivativeOrder or 0) >= 1
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

        def step(name: str, k: int) -> None:
            status = slaves[name].doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
            if status not in (0, None):
                raise CosimError(f"fmpy: a doStep at t = {k * h:g} s returned status {status}")

        order = _order(list(slaves), links) if interpolate else None
        lines = _interface_links(slaves, info, links, slopes, outputs_rate) if interpolate and order is None else None
        if lines:  # two-way, the blocks' floor in their FMU: the source of the load's line first
            first = [c for c in slaves if any(links[i][0] == c for i in lines.slope)]
            order = first + [c for c in slaves if c not in first]
        # iterated where every FMU can roll back (else one pass, as without iterate)
        loops = iterate and lines is not None and all(states[c] for c in slaves)
        back = lines.back(order) if loops else []  # the links whose settling ends an iterated step
        transfer()
        held = [slaves[a].getReal([out])[0] for a, out, _, _ in links]  # each link's value at the step's start
        rates = lines.rates(slaves) if lines else {}  # and its source's derivative there (rate links)
        before: list[float] | None = None  # the values at the step before's start
        rates_before: dict[int, float] | None = None
        saved: dict[str, Any] = {c: None for c in slaves}
        scale, rows = 0.0, []
        for k in range(n):
            if lines:
                if loops:
                    for c in slaves:
                        if saved[c] is not None:
                            slaves[c].freeFMUstate(saved[c])
                        saved[c] = slaves[c].getFMUstate()
                ends: dict[int, float] = {}  # the back links' sources' outputs at the step's end, from the last pass
                for sweep in range(MAX_SWEEPS if loops else 1):
                    if sweep:
                        for c in slaves:
                            slaves[c].setFMUstate(saved[c])
                    lines.step(slaves, order, held, rates, rates_before, ends, h, lambda name: step(name, k))
                    if not loops:
                        break
                    new = {i: slaves[links[i][0]].getReal([links[i][1]])[0] for i in back}
                    scale = max([scale] + [abs(x) for x in new.values()])
                    settled = sweep > 0 and all(abs(new[i] - ends[i]) <= SWEEP_TOL * scale for i in new)
                    ends = new
                    if settled:
                        break
                iterations.append(sweep + 1)
            elif order is None:
                for name in slaves:
                    step(name, k)
            else:  # one-way
                _pass(slaves, links, order, slopes, held, before, h, lambda name: step(name, k))
            rows.append(sample())  # as libcosim's observer: after the step, before the transfer
            transfer()
            before, held = held, [slaves[a].getReal([out])[0] for a, out, _, _ in links]
            if lines:
                rates_before, rates = rates, lines.rates(slaves)
            if progress:
                progress(k + 1, n)
        for c, st in saved.items():
            if st is not None:
                slaves[c].freeFMUstate(st)
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
    if not rows:
        return None
    result = _result(system, "fmpy", h, rows, wanted)
    result.passes = sum(iterations)
    result.scheme = "iterated" if loops else "interface" if lines else "interpolated" if order is not None else "held"
    return result


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

