"""Read the variable table model/c/variables.def (the single source of truth
shared by the C core and modelDescription.xml)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

_LINE = re.compile(
    r'^VAR\(\s*(?P<type>REAL|INTEGER|BOOLEAN|STRING)\s*,\s*(?P<vr>\d+)\s*,\s*(?P<field>\w+)\s*,'
    r'\s*"(?P<name>[^"]+)"\s*,\s*(?P<causality>\w+)\s*,\s*(?P<variability>\w+)\s*,'
    r'\s*(?P<start>[-+0-9.eE]+|"[^"]*")\s*,\s*"(?P<unit>[^"]*)"\s*,\s*"(?P<description>[^"]*)"\s*\)\s*$'
)


# Blocks 3 to 8 of a column: a BLOCK(...) line stands for blockK.member, K = 3..8, value reference
# base + K (the C core expands it with the same macro, variables.def); RANGE and ITEM lines naming
# "block*.member" hold for each of them.
FAMILY_BLOCKS = range(3, 9)
_BLOCK = re.compile(r'^BLOCK\(\s*(\w+)\s*,\s*(\d+)\s*,\s*(\w+)\s*,\s*"([^"]+)"\s*,(.*)$')


def expand_families(text: str) -> list[str]:
    """The lines of a variable table with every ``BLOCK(...)`` line written out as its six ``VAR(...)``
    lines and every ``RANGE``/``ITEM`` line naming ``block*.`` as one line per block."""
    out: list[str] = []
    for line in text.splitlines():
        stripped = line.strip()
        m = _BLOCK.match(stripped)
        if m:
            typ, base, field, member, rest = m.groups()
            out += [f'VAR({typ}, {int(base) + k}, {field}_{k}, "block{k}.{member}",{rest}' for k in FAMILY_BLOCKS]
        elif stripped.startswith(("RANGE(", "ITEM(")) and '"block*.' in stripped:
            out += [line.replace('"block*.', f'"block{k}.') for k in FAMILY_BLOCKS]
        else:
            out.append(line)
    return out


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
    for lineno, line in enumerate(expand_families(path.read_text()), start=1):
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
    for lineno, line in enumerate(expand_families(path.read_text()), start=1):
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


_RANGE = re.compile(
    r'^RANGE\(\s*"(?P<var>[^"]+)"\s*,\s*(?P<op1>>=|<=|>|<)\s*,\s*(?P<b1>[-+.\deE]+)\s*'
    r'(?:,\s*(?P<op2>>=|<=|>|<)\s*,\s*(?P<b2>[-+.\deE]+)\s*)?\)\s*$'
)


@dataclass(frozen=True)
class Bound:
    """One side of a valid range: ``value`` and whether it belongs to the range (closed)."""

    value: float
    closed: bool

    def declared(self, upward: bool) -> float:
        """The FMI min (``upward``: the next double above an open bound) or max (the next below)
        that declares this bound: FMI's min and max are inclusive."""
        if self.closed:
            return self.value
        return math.nextafter(self.value, math.inf if upward else -math.inf)


@dataclass(frozen=True)
class Range:
    """The valid range of a parameter: a lower and an upper bound, each optional."""

    lower: Bound | None
    upper: Bound | None

    @property
    def min(self) -> float | None:
        """The declared (inclusive) FMI min."""
        return self.lower.declared(True) if self.lower else None

    @property
    def max(self) -> float | None:
        """The declared (inclusive) FMI max."""
        return self.upper.declared(False) if self.upper else None


def read_ranges(path: Path) -> dict[str, Range]:
    """The ``RANGE(...)`` lines of ``path``: variable name -> its valid range."""
    ranges: dict[str, Range] = {}
    for lineno, line in enumerate(expand_families(path.read_text()), start=1):
        if not line.startswith("RANGE("):
            continue
        m = _RANGE.match(line.strip())
        if not m:
            raise ValueError(f"{path}:{lineno}: malformed RANGE line: {line.strip()}")
        lower = upper = None
        for op, bound in ((m["op1"], m["b1"]), (m["op2"], m["b2"])):
            if op is None:
                continue
            b = Bound(float(bound), closed=op.endswith("="))
            if op.startswith(">"):
                if lower is not None:
                    raise ValueError(f"{path}:{lineno}: two lower bounds")
                lower = b
            else:
                if upper is not None:
                    raise ValueError(f"{path}:{lineno}: two upper bounds")
                upper = b
        if m["var"] in ranges:
            raise ValueError(f"{path}:{lineno}: a second range for '{m['var']}'")
        if lower and upper and not lower.declared(True) <= upper.declared(False):
            raise ValueError(f"{path}:{lineno}: empty range")
        ranges[m["var"]] = Range(lower, upper)
    return ranges


_CODE = re.compile(r'^CODE\(\s*(?P<field>\w+)\s*,\s*(?P<enum_field>\w+)\s*,\s*"(?P<name>[^"]+)"\s*,'
                   r'\s*"(?P<enum>[^"]+)"\s*\)\s*$')


def read_codes(path: Path) -> dict[str, str]:
    """The ``CODE(...)`` lines of ``path``: the name of each Integer code -> the name of the
    Enumeration it replaces when set (model/c/codes.h)."""
    codes: dict[str, str] = {}
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.startswith("CODE("):
            continue
        m = _CODE.match(line.strip())
        if not m:
            raise ValueError(f"{path}:{lineno}: malformed CODE line: {line.strip()}")
        codes[m["name"]] = m["enum"]
    return codes


def check_tables(variables: list[Variable], enumerations: dict[str, Enumeration], ranges: dict[str, Range],
                 codes: dict[str, str]) -> None:
    """Raise ValueError unless the lines agree: a range or a code names a parameter, no
    Enumeration has a range, and a code's range is -1 to its Enumeration's largest item."""
    by_name = {v.name: v for v in variables}
    for name, r in ranges.items():
        v = by_name.get(name)
        if v is None or v.causality != "parameter" or v.type not in ("Real", "Integer"):
            raise ValueError(f"RANGE of '{name}': not a Real or Integer parameter")
        if name in enumerations:
            raise ValueError(f"RANGE of '{name}': an Enumeration's items are its range")
        if v.type == "Integer" and ((r.lower and not r.lower.closed) or (r.upper and not r.upper.closed)):
            raise ValueError(f"RANGE of Integer '{name}': write its bounds closed (>= and <=)")
        start = float(v.start)
        if (r.min is not None and start < r.min) or (r.max is not None and start > r.max):
            raise ValueError(f"'{name}': start value {v.start} outside its range")
    for code, enum in codes.items():
        if code not in by_name or enum not in enumerations:
            raise ValueError(f"CODE '{code}' of '{enum}': unknown variable or not an Enumeration")
        r = ranges.get(code)
        if r is None or (r.min, r.max) != (-1, max(value for value, _, _ in enumerations[enum].items)):
            raise ValueError(f"CODE '{code}': its RANGE must be -1 to the largest item of '{enum}'")
