"""The block catalogue shipped with the package and loaded by ``runners db init``.

Anagnostopoulos (BEng thesis, University of Bristol), Table 2: half dimensions
from its full height x length (mm), steel; restitution: Housner's coefficient
times the Table 3 correction factor (blocks 1-3; block 4 has none). Čeh &
Jelenić (2022), Table 1 gives FULL widths and heights (mm) and masses in grams:
halved and converted here; restitution: the modified law with the exact k of
each block, and the average k of its size class kept alongside.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from db.schema import Block

ANAGNOSTOPOULOS = "Anagnostopoulos, BEng thesis, University of Bristol: Table 2 and Table 3"
CEH_JELENIC_2022 = "Čeh & Jelenić (2022), Engineering Review 42: Table 1 and section 5 (full dimensions halved)"

CATALOGUE: list[dict] = [
    # Anagnostopoulos, Table 2: height x length (mm) -> half_height, half_width (m)
    dict(name="anagnostopoulos-block1", half_width=0.029 / 2, half_height=0.120 / 2, mass=1.3, material="steel",
         restitution_law="housner", correction=1.036, source=ANAGNOSTOPOULOS),
    dict(name="anagnostopoulos-block2", half_width=0.060 / 2, half_height=0.135 / 2, mass=2.95, material="steel",
         restitution_law="housner", correction=1.233, source=ANAGNOSTOPOULOS),
    dict(name="anagnostopoulos-block3", half_width=0.060 / 2, half_height=0.238 / 2, mass=5.3, material="steel",
         restitution_law="housner", correction=1.067, source=ANAGNOSTOPOULOS),
    dict(name="anagnostopoulos-block4", half_width=0.060 / 2, half_height=0.100 / 2, mass=2.3, material="steel",
         restitution_law="housner", correction=1.0, source=ANAGNOSTOPOULOS),
    # Čeh & Jelenić (2022) Table 1: m (g), b and h FULL (mm)
    dict(name="B3M", half_width=0.045 / 2, half_height=0.10125 / 2, mass=0.5444, restitution_law="modified",
         k=0.7595, k_size_average=0.8608, correction=1.0, source=CEH_JELENIC_2022),
    dict(name="B6M", half_width=0.045 / 2, half_height=0.2025 / 2, mass=1.0896, restitution_law="modified",
         k=0.8241, k_size_average=0.8608, correction=1.0, source=CEH_JELENIC_2022),
    dict(name="B3L", half_width=0.060 / 2, half_height=0.135 / 2, mass=1.2843, restitution_law="modified",
         k=0.7259, k_size_average=0.7306, correction=1.0, source=CEH_JELENIC_2022),
    dict(name="B6L", half_width=0.060 / 2, half_height=0.270 / 2, mass=2.5692, restitution_law="modified",
         k=0.7214, k_size_average=0.7306, correction=1.0, source=CEH_JELENIC_2022),
]


def load_catalogue(session: Session) -> tuple[int, int]:
    """Insert the catalogue's blocks, updating those already present by name; (added, updated)."""
    added = updated = 0
    for entry in CATALOGUE:
        block = session.scalar(select(Block).where(Block.name == entry["name"]))
        if block is None:
            session.add(Block(**entry))
            added += 1
        else:
            for key, value in entry.items():
                setattr(block, key, value)
            updated += 1
    return added, updated


def block_parameters(block: Block, index: int = 1) -> dict[str, float | int]:
    """FMU parameters of a catalogue block as block `index` (1 or 2)."""
    p: dict[str, float | int] = {f"block{index}.halfWidth": block.half_width,
                                 f"block{index}.halfHeight": block.half_height, f"block{index}.mass": block.mass}
    if index == 1:
        p["restitution.law"] = {"housner": 0, "modified": 1, "constant": 2}[block.restitution_law]
        p["restitution.correction"] = block.correction
        if block.k is not None:
            p["restitution.k"] = block.k
        if block.eta is not None:
            p["restitution.eta"] = block.eta
    return p
