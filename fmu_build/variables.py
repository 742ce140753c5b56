"""Read the variable table model/c/variables.def (the single source of truth
shared by the C core and modelDescription.xml)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

_LINE = re.compile(
    r'^VAR\(\s*(?P<type>REAL|INTEGER|BOOLEAN|STRING)\s*,\s*(?P<vr>\d+)\s*,\s*(?P<field>\w+)\s*,'
    r'\s*"(?P<name>[^"]+)"\s*,\s*(?P<causality>\w+)\s*,\s*(?P<variability>\w+)\s*,'
    r'\s*(?P<start>[-+0-9.eE]+|"[^"]*")\s*,\s*"(?P<unit>[^"]*)"\s*,\s*"(?P<description>[^"]*)"\s*\)\s*$'
)


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable as declared in variables.def."""

    type: str  # "Real", "Integer", "Boolean" or "String"
    value_reference: int
    field: str
    name: str
    causality: str
    variability: str
    start: str  # a number, or a String's text without its quotes
    unit: str
    description: str


def read_variables(path: Path) -> list[Variable]:
    """Parse every ``VAR(...)`` line of ``path``; raise ValueError on a malformed one."""
    variables: list[Variable] = []
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.startswith("VAR("):
            continue
        m = _LINE.match(line.strip())
        if not m:
            raise ValueError(f"{path}:{lineno}: malformed VAR line: {line.strip()}")
        d = m.groupdict()
        variables.append(
            Variable(
                type=d["type"].capitalize(),
                value_reference=int(d["vr"]),
                field=d["field"],
                name=d["name"],
                causality=d["causality"],
                variability=d["variability"],
                start=d["start"][1:-1] if d["type"] == "STRING" else d["start"],
                unit=d["unit"],
                description=d["description"],
            )
        )
    names = [v.name for v in variables]
    refs = [(v.type, v.value_reference) for v in variables]
    if len(set(names)) != len(names) or len(set(refs)) != len(refs):
        raise ValueError(f"{path}: duplicate variable name or value reference")
    return variables


_ITEM = re.compile(
    r'^ITEM\(\s*"(?P<var>[^"]+)"\s*,\s*(?P<type>\w+)\s*,\s*(?P<value>-?\d+)\s*,\s*(?P<item>\w+)\s*,'
    r'\s*"(?P<description>[^"]*)"\s*\)\s*$'
)


@dataclass(frozen=True)
class Enumeration:
    """An FMI Enumeration type: its name and items (value, name, description)."""

    name: str
    items: tuple[tuple[int, str, str], ...]


def read_enumerations(path: Path) -> dict[str, Enumeration]:
    """The ``ITEM(...)`` lines of ``path``: variable name -> its Enumeration type."""
    found: dict[str, tuple[str, list[tuple[int, str, str]]]] = {}
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.startswith("ITEM("):
            continue
        m = _ITEM.match(line.strip())
        if not m:
            raise ValueError(f"{path}:{lineno}: malformed ITEM line: {line.strip()}")
        type_name, items = found.setdefault(m["var"], (m["type"], []))
        if type_name != m["type"]:
            raise ValueError(f"{path}:{lineno}: '{m['var']}' has two enumeration types")
        items.append((int(m["value"]), m["item"], m["description"]))
    return {var: Enumeration(t, tuple(sorted(items))) for var, (t, items) in found.items()}
