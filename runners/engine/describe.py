"""What a figure's title or a report's header says of the runs it shows: the blocks, the contact
model and its friction, the restitution, the excitation and any value a one-value --grid axis set,
all from the FMU parameters the runs used (the FMU's defaults, the scene, the one-value axes).
Never from the scene's name: that is the user's words, and a --grid override may have made it
wrong ("mu 0.4" in the name of a sweep run at mu 0.3).

Lengths in m (full widths and heights: a reader measures a block so), masses in kg,
accelerations in m/s2, frequencies in Hz.
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping

from runners.engine import supports
from runners.engine.scene import KIND_NAMES, restitution
from runners.engine.shapes import body, has_outline

LAW_NAMES = {0: "Housner (1963)", 1: "modified (Čeh & Jelenić 2022)", 2: "constant"}
PULSES = {1: "one-sine pulse", 2: "one-cosine pulse", 5: "Ricker wavelet", 6: "antisymmetric Ricker wavelet",
          7: "Mavroeidis & Papageorgiou (2003) pulse"}


def blocks(p: Mapping[str, Any]) -> str:
    """The block, or the stack's two blocks, in full sizes and masses."""
    def one(i: int) -> str:
        if has_outline(p, i):  # a body of real shape: its outline's extent
            b = body(p, i)
            return f"{b.width:.4g} m wide x {b.top:.4g} m high (an outline), {b.mass:.4g} kg"
        return (f"{2 * float(p[f'block{i}.halfWidth']):.4g} m wide x {2 * float(p[f'block{i}.halfHeight']):.4g} m "
                f"high, {float(p[f'block{i}.mass']):.4g} kg")

    n = int(p.get("nBlocks", 1))
    if n == 2:
        return f"block 1 (below) {one(1)}; block 2 (on it) {one(2)}"
    if n > 2:  # a column: its height, its foot and its mass (each block's sizes would not fit a title)
        heights = [body(p, i).top if has_outline(p, i) else 2 * float(p[f"block{i}.halfHeight"]) for i in range(1, n + 1)]
        mass = sum(float(p[f"block{i}.mass"]) for i in range(1, n + 1))
        return f"a column of {n} blocks, {sum(heights):.4g} m high, {mass:.4g} kg; block 1 {one(1)}"
    return f"block {one(1)}"


def contact(p: Mapping[str, Any], varied: Iterable[str] = ()) -> str:
    """The contact model and the friction it uses: rocking–sliding slides at mu; rigid rocking
    never slides, its mu only judges whether it should have (docs/contact.md). A mu a --grid axis
    varies (`varied`) is said to be swept."""
    varied = set(varied)
    two = int(p.get("nBlocks", 1)) == 2

    def mu_of(name: str) -> str:
        return "swept" if name in varied else f"{float(p[name]):.3g}"

    mu = f"mu {mu_of('contact.muGround')} on the ground"
    if two:
        mu += f", {mu_of('contact.muInterface')} between the blocks"
    elif int(p.get("nBlocks", 1)) > 2:
        mu += f", {mu_of('contact.muInterface')} at the joints"
    if int(p.get("contact.model", 0)) == 1:
        return f"rocking–sliding, {mu}"
    return f"rigid rocking ({mu}, monitored)"


def restitution_text(p: Mapping[str, Any]) -> str:
    """The impact law and its coefficient(s)."""
    law = int(p["restitution.law"])
    if int(p.get("nBlocks", 1)) == 2:
        if law == 2:
            return (f"constant restitution, {float(p['restitution.etaGround']):.3g} on the ground, "
                    f"{float(p['restitution.etaInterface']):.3g} between the blocks")
        names = {0: "momentum restitution (docs/two_blocks.md)", 1: "modified restitution"}
        return names.get(law, f"restitution {law}")
    if int(p.get("nBlocks", 1)) > 2:  # a column: one plastic impact over every contact that touches
        if law == 2:
            return (f"constant restitution, {float(p['restitution.etaGround']):.3g} on the ground, "
                    f"{float(p['restitution.etaInterface']):.3g} at the joints")
        return "plastic impact over every contact that touches (docs/columns.md)"
    if has_outline(p, 1):  # one body of real shape: the plastic impact about the landing corner, per side
        b = body(p, 1)
        return (f"plastic impact about the landing corner (Housner 1963's law), eta {b.impact_ratio(1):.3f} landing "
                f"on the right corner, {b.impact_ratio(-1):.3f} on the left")
    alpha = math.atan2(float(p["block1.halfWidth"]), float(p["block1.halfHeight"]))
    text = f"{LAW_NAMES.get(law, law)} restitution, eta {restitution(dict(p), alpha):.3f}"
    if law != 2 and float(p.get("restitution.correction", 1.0)) != 1.0:
        text += f" (x {float(p['restitution.correction']):g})"
    return text


def excitation(p: Mapping[str, Any], varied: Iterable[str] = ()) -> str:
    """The excitation, its amplitude and frequency unless a --grid axis varies them (`varied`:
    the axes' names, w and a included)."""
    varied = set(varied)
    kind = int(p.get("excitation.kind", 0))
    if kind == 4:
        return "recorded ground motion"
    if kind == 0:
        return "no excitation (free rocking from its initial state)"
    amp = "swept" if varied & {"excitation.amplitude", "a"} else f"{float(p['excitation.amplitude']):.4g} m/s2"
    freq = "swept" if varied & {"excitation.frequency", "w"} else f"{float(p['excitation.frequency']):.4g} Hz"
    if kind == 3:
        return f"harmonic table motion, displacement {float(p['excitation.displacement']):.4g} m at {freq}"
    name = PULSES.get(kind, KIND_NAMES.get(kind, str(kind)))
    cycles = float(p.get("excitation.cycles", 1.0))
    many = f", {cycles:g} cycles" if kind in (1, 2) and cycles != 1 else ""
    vertical = float(p.get("excitation.verticalAmplitude", 0.0))
    vert = f", vertical {vertical:.4g} m/s2" if vertical else ""
    return f"{name}, amplitude {amp}, frequency {freq}{many}{vert}"


NAMED = {"contact.model": {0: "rigid-rocking", 1: "rocking-sliding"}, "excitation.kind": KIND_NAMES}


def overrides(fixed: Mapping[str, float]) -> str:
    """The parameters a one-value --grid axis set ('' when none); a code by its name
    (contact.model = rocking-sliding, not 1)."""
    def shown(k: str, v: float) -> str:
        name = NAMED.get(k, {}).get(int(v)) if float(v).is_integer() else None
        return name or f"{v:g}"

    return ", ".join(f"{k} = {shown(k, v)}" for k, v in fixed.items())


def describe(p: Mapping[str, Any], varied: Iterable[str] = (), fixed: Mapping[str, float] | None = None,
             with_excitation: bool = True) -> list[str]:
    """The lines a title needs: blocks; contact model, friction and restitution; the excitation
    (with_excitation) and the one-value --grid overrides (`fixed`)."""
    lines = [blocks(p), f"{contact(p, varied)}; {restitution_text(p)}"]
    support = supports.describe(p) if not any(n.startswith(("support.", "building.", "platform.")) for n in varied) \
        else None
    if support:
        lines.append(f"on a {support}")
    tail = []
    if with_excitation:
        tail.append(excitation(p, varied))
    if fixed:
        tail.append(f"set by --grid: {overrides(fixed)}")
    if tail:
        lines.append("; ".join(tail))
    return lines
