"""What the blocks stand on, as scene and system files give it (docs/supports.md).

- ``[building]``: a linear shear building, ``storeys`` (1 to 10), ``mass`` (kg per floor) and
  ``stiffness`` (N/m per storey): one value, or a list bottom to top; ``damping_ratio`` (Rayleigh, at
  modes 1 and 2, default 0.05);
- ``[platform]``: an isolation platform, ``mass`` (kg), ``stiffness`` (N/m, default 0) and
  ``damping`` (N s/m, default 0);
- ``[coupling]``: ``floor`` (the blocks' floor, default the top), ``mode`` (``"two-way"``, the default:
  the blocks' forces and impacts act on the support; ``"one-way"``: the support does not feel the blocks)
  and, for a co-simulation, ``step`` (s).

A scene with one of them runs the support inside RockingBlock.fmu (:func:`fmu_parameters`; two-way with
the rocking-sliding model, one-way with either); a system file for ``runners cosim`` gives the building
to ShearBuilding.fmu (runners.engine.cosim), the same coupling across a communication step. Units SI.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

from runners.errors import RockingError

MAX_STOREYS = 10  # RockingBlock.fmu's and ShearBuilding.fmu's storeys
COUPLINGS = ("one-way", "two-way")
BUILDING_KEYS = {"storeys", "mass", "stiffness", "damping_ratio"}
PLATFORM_KEYS = {"mass", "stiffness", "damping"}
COUPLING_KEYS = {"floor", "mode", "step"}
TABLES = ("building", "platform", "coupling")


class SupportError(RockingError, ValueError):
    """A support's table is invalid; one line."""


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
class Platform:
    """An isolation platform: its mass (kg) on a linear spring (N/m) and a viscous damper (N s/m) to the base."""

    mass: float
    stiffness: float = 0.0
    damping: float = 0.0


def is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def positive(where: str, values: list[Any], given: Any = None) -> list[float]:
    """``values`` as floats; SupportError unless each is a finite number > 0."""
    for v in values:
        if not is_number(v) or v <= 0:
            raise SupportError(f"{where}: expected positive numbers (one, or one per storey), got "
                               f"{values if given is None else given!r}")
    return [float(v) for v in values]


def floats(where: str, value: Any, n: int) -> list[float]:
    values = value if isinstance(value, list) else [value] * n
    if len(values) != n:
        raise SupportError(f"{where}: {len(values)} values for {n} storeys")
    return positive(where, values, value)


def check_damping(where: str, zeta: Any) -> float:
    if not is_number(zeta) or not 0 <= zeta < 1:
        raise SupportError(f"{where} must be in [0, 1), got {zeta!r}")
    return float(zeta)


def check_floor(where: str, floor: Any, storeys: int) -> int:
    if isinstance(floor, bool) or not isinstance(floor, numbers.Integral) or not 1 <= floor <= storeys:
        raise SupportError(f"{where} must be a floor of the building, 1 to {storeys}, got {floor!r}")
    return int(floor)


def check_coupling(where: str, mode: Any) -> str:
    if mode not in COUPLINGS:
        raise SupportError(f"{where} must be one of {', '.join(COUPLINGS)}, got {mode!r}")
    return mode


def check_number(where: str, value: Any, what: str = "a number of seconds") -> float:
    if not is_number(value):
        raise SupportError(f"{where} must be {what}, got {value!r}")
    return float(value)


def building_from_dict(d: dict[str, Any], where: str) -> Building:
    unknown = sorted(set(d) - BUILDING_KEYS)
    if unknown:
        raise SupportError(f"{where}: [building] unknown key '{unknown[0]}' (expected {', '.join(sorted(BUILDING_KEYS))})")
    n = d.get("storeys")
    if n is None and isinstance(d.get("mass"), list):
        n = len(d["mass"])
    if n is None:
        raise SupportError(f"{where}: [building] needs storeys (1 to {MAX_STOREYS}), or mass as a list of one value per floor")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_STOREYS:
        raise SupportError(f"{where}: [building] storeys must be a whole number from 1 to {MAX_STOREYS}, got {n!r}")
    for key, what in (("mass", "kg per floor"), ("stiffness", "N/m per storey")):
        if key not in d:
            raise SupportError(f"{where}: [building] needs {key} ({what}: one value, or a list bottom to top)")
    return Building(floats(f"{where}: [building] mass", d["mass"], n),
                    floats(f"{where}: [building] stiffness", d["stiffness"], n),
                    check_damping(f"{where}: [building] damping_ratio", d.get("damping_ratio", 0.05)))


def platform_from_dict(d: dict[str, Any], where: str) -> Platform:
    unknown = sorted(set(d) - PLATFORM_KEYS)
    if unknown:
        raise SupportError(f"{where}: [platform] unknown key '{unknown[0]}' (expected {', '.join(sorted(PLATFORM_KEYS))})")
    if "mass" not in d:
        raise SupportError(f"{where}: [platform] needs mass (kg)")
    mass = positive(f"{where}: [platform] mass", [d["mass"]])[0]
    spring_damper = []
    for key, unit in (("stiffness", "N/m"), ("damping", "N s/m")):
        value = d.get(key, 0.0)
        if not is_number(value) or value < 0:
            raise SupportError(f"{where}: [platform] {key} must be a number >= 0 {unit}, got {value!r}")
        spring_damper.append(float(value))
    return Platform(mass, *spring_damper)


def fmu_parameters(support: Building | Platform, floor: int | None = None, mode: str = "two-way") -> dict[str, Any]:
    """RockingBlock.fmu's parameters of ``support`` (the blocks on ``floor`` of a building; None: the top),
    coupled ``mode`` ("two-way" or "one-way")."""
    coupling = {"support.coupling": COUPLINGS.index(check_coupling("coupling mode", mode))}
    if isinstance(support, Platform):
        return {"support.kind": 2, "platform.mass": support.mass, "platform.stiffness": support.stiffness,
                "platform.damping": support.damping, **coupling}
    p: dict[str, Any] = {"support.kind": 1, **coupling, "building.storeys": support.storeys,
                         "building.floor": support.storeys if floor is None else int(floor),
                         "building.dampingRatio": support.damping_ratio}
    for i, (m, k) in enumerate(zip(support.mass, support.stiffness), start=1):
        p[f"building.storey[{i}].mass"] = m
        p[f"building.storey[{i}].stiffness"] = k
    return p


def scene_support(data: dict[str, Any], source: str) -> dict[str, Any]:
    """The FMU parameters of a scene document's [building] or [platform] and [coupling] tables (removed
    from ``data``); {} without them. The support runs inside the FMU."""
    building, platform = data.pop("building", None), data.pop("platform", None)
    coupling = data.pop("coupling", None)
    for name, table in (("building", building), ("platform", platform), ("coupling", coupling)):
        if table is not None and not isinstance(table, dict):
            raise SupportError(f"{source}: '{name}' must be a table")
    if building is not None and platform is not None:
        raise SupportError(f"{source}: the blocks stand on a [building] or on a [platform], not both")
    if building is None and platform is None:
        if coupling is not None:
            raise SupportError(f"{source}: [coupling] needs a [building] or a [platform] to couple the blocks to")
        return {}
    coupling = coupling or {}
    unknown = sorted(set(coupling) - COUPLING_KEYS)
    if unknown:
        raise SupportError(f"{source}: [coupling] unknown key '{unknown[0]}' (expected floor, mode, step)")
    mode = check_coupling(f"{source}: [coupling] mode", coupling.get("mode", "two-way"))
    if platform is not None:
        if "floor" in coupling:
            raise SupportError(f"{source}: [coupling] floor is a building's; the blocks stand on the [platform]")
        return fmu_parameters(platform_from_dict(platform, source), mode=mode)
    b = building_from_dict(building, source)
    floor = check_floor(f"{source}: [coupling] floor", coupling.get("floor", b.storeys), b.storeys)
    return fmu_parameters(b, floor, mode)


def describe(p: dict[str, Any]) -> str | None:
    """One line on the support of FMU parameters ``p`` (None on the ground)."""
    kind = int(p.get("support.kind", 0))
    way = COUPLINGS[int(p.get("support.coupling", 0))]
    if kind == 1:
        from runners.engine.floor_motion import first_period  # (scipy, for the modes: imported when needed)

        n = int(p["building.storeys"])
        floor = int(p.get("building.floor", 0)) or n
        return (f"shear building, {n} storey{'s' if n > 1 else ''} (f1 = {1 / first_period(p):.3g} Hz, damping "
                f"{100 * float(p['building.dampingRatio']):.3g} %), the blocks on floor {floor}; {way}")
    if kind == 2:
        m, k, c = float(p["platform.mass"]), float(p["platform.stiffness"]), float(p["platform.damping"])
        if k == 0 and c == 0:
            return f"isolation platform, {m:g} kg on rollers (no spring, no damper); {way}"
        spring = (f"f = {math.sqrt(k / m) / (2 * math.pi):.3g} Hz, damping {100 * c / (2 * math.sqrt(k * m)):.3g} %"
                  if k > 0 else f"no spring, damper {c:g} N s/m")
        return f"isolation platform, {m:g} kg ({spring}); {way}"
    return None
