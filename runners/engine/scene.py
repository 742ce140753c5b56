"""Scene files: TOML descriptions of one simulation, validated into FMU parameters.

A scene has the tables [block], [restitution], [excitation] and [simulation],
and [block2] for a second block standing on the first (which makes it a
two-block scene, nBlocks = 2). Every key is optional and falls back to the
FMU's default. Units are SI and angles radians (docs/conventions.md). Every
key, its unit and default: docs/scenes.md; examples: examples/*.toml.

A recorded earthquake is ``[excitation] kind = "record"`` with ``record = NAME``
(or a database id) of a stored record, or ``file = PATH`` (a record file, PEER
.AT2 or measured .csv, relative to the scene file), and ``scale``; runners.engine.records
turns it into the FMU's excitation.file. Without ``stop_time`` a record scene runs
until its record ends plus a few seconds (runners.engine.records.TAIL).
"""

from __future__ import annotations

import math
import numbers
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from runners.engine.shapes import MAX_VERTICES, format_outline, has_outline
from runners.engine.supports import TABLES as SUPPORT_TABLES
from runners.engine.supports import SupportError, scene_support
from runners.errors import RockingError

# "housner" is the momentum law: Housner's coefficient for one block, the
# projection of docs/two_blocks.md for two ("momentum" is its other name).
LAWS = {"housner": 0, "momentum": 0, "modified": 1, "constant": 2}
KINDS = {"none": 0, "sine-pulse": 1, "cosine-pulse": 2, "harmonic": 3, "record": 4, "ricker": 5,
         "ricker-antisymmetric": 6, "mavroeidis-papageorgiou": 7}
KIND_NAMES = {v: k for k, v in KINDS.items()}  # excitation.kind -> its name in a scene
# the FMU's integrators (solver.method, docs/methods.md): Taylor series for one block only; auto
# (the FMU's default) takes it for one block in rigid rocking but under a record, else Dormand-Prince
METHODS = {"dormand-prince": 0, "taylor": 1, "auto": 2}
# the FMU's contact models (contact.model, docs/contact.md): rigid rocking assumes the contacts
# neither slide nor lift; rocking-sliding lets block 1 slide on the ground (Coulomb, one mu)
CONTACT_MODELS = {"rigid-rocking": 0, "rocking-sliding": 1}
CONTACT_MODEL_NAMES = {v: k for k, v in CONTACT_MODELS.items()}
# g: a PGA beyond this is a mistake of units (the largest horizontal PGA recorded is about 2.7 g:
# runners.engine.records.LARGEST_PGA)
MAX_PGA_G = 5.0
# output samples one run may hold (a few hundred MB with its outputs): more is refused before
# the run starts (docs/limits.md); 2e6 is 2000 s at a 1 ms step
MAX_SAMPLES = 2_000_000

# the FMU's largest column (nBlocks 1 to 8): block K + 1 stands on block K (docs/columns_runners.md)
MAX_BLOCKS = 8
# a body of real shape (docs/columns_runners.md, runners.engine.shapes): in any block table, its convex
# outline [[x, y], ...] (m; the FMU's blockK.outline String) and, both or neither, its centre of mass
# [x, y] (m; blockK.centreX, blockK.centreY) and inertia about it (kg m2); neither: a uniform polygon
# (centre's FMU variable is named by its x: it sets blockK.centreX and blockK.centreY)
SHAPE_KEYS = {"outline": ("outline", "outline"), "centre": ("centreX", "point"), "inertia": ("inertia", "real")}
# table -> key -> (FMU variable, kind); kind is "real", "bool" or a choice dict
SCHEMA: dict[str, dict[str, tuple[str | None, Any]]] = {
    "block": {
        "half_width": ("block1.halfWidth", "real"),
        "half_height": ("block1.halfHeight", "real"),
        "mass": ("block1.mass", "real"),
        "theta0": ("block1.theta0", "real"),
        "omega0": ("block1.omega0", "real"),
        **{key: (f"block1.{name}", kind) for key, (name, kind) in SHAPE_KEYS.items()},
    },
    "block2": {
        "half_width": ("block2.halfWidth", "real"),
        "half_height": ("block2.halfHeight", "real"),
        "mass": ("block2.mass", "real"),
        "theta0": ("block2.theta0", "real"),
        "omega0": ("block2.omega0", "real"),
        **{key: (f"block2.{name}", kind) for key, (name, kind) in SHAPE_KEYS.items()},
    },
    # blocks 3 to 8 of a column (block K stands on block K - 1; they start seated, so no theta0 or omega0)
    **{f"block{k}": {
        "half_width": (f"block{k}.halfWidth", "real"),
        "half_height": (f"block{k}.halfHeight", "real"),
        "mass": (f"block{k}.mass", "real"),
        "mu": (f"block{k}.mu", "real"),  # friction with the block below (default: contact.muInterface)
        **{key: (f"block{k}.{name}", kind) for key, (name, kind) in SHAPE_KEYS.items()},
    } for k in range(3, MAX_BLOCKS + 1)},
    # a column of identical drums: block1..blockN (column_parameters)
    "column": {
        "drums": (None, "count"),
        "half_width": (None, "real"),
        "half_height": (None, "real"),
        "mass": (None, "real"),
        "mu": (None, "real"),
        "outline": (None, "outline"),  # every drum of this outline (instead of half_width, half_height)
        "centre": (None, "point"),
        "inertia": (None, "real"),
    },
    "restitution": {
        "law": ("restitution.law", LAWS),
        "k": ("restitution.k", "real"),
        "eta": ("restitution.eta", "real"),
        "correction": ("restitution.correction", "real"),
        "eta_ground": ("restitution.etaGround", "real"),
        "eta_interface": ("restitution.etaInterface", "real"),
    },
    "contact": {
        "model": ("contact.model", CONTACT_MODELS),
        "mu_ground": ("contact.muGround", "real"),
        "mu_interface": ("contact.muInterface", "real"),
    },
    "excitation": {
        "kind": ("excitation.kind", KINDS),
        "amplitude": ("excitation.amplitude", "real"),
        "frequency": ("excitation.frequency", "real"),
        "cycles": ("excitation.cycles", "real"),
        "start_time": ("excitation.startTime", "real"),
        "vertical_amplitude": ("excitation.verticalAmplitude", "real"),
        "displacement": ("excitation.displacement", "real"),
        "scale": ("excitation.scale", "real"),
        "gamma": ("excitation.gamma", "real"),
        "phase": ("excitation.phase", "real"),
        "record": (None, "record"),
        "file": (None, "text"),
        "pga": (None, "real"),  # g: the record scaled to this PGA (instead of scale)
    },
    "simulation": {
        "stop_time": (None, "real"),
        "step": (None, "real"),
        "g": ("g", "real"),
        "rel_tol": ("solver.relTol", "real"),
        "abs_tol": ("solver.absTol", "real"),
        "rest_ratio": ("solver.restRatio", "real"),
        "method": ("solver.method", METHODS),
        "early_overturn": ("solver.earlyOverturn", "bool"),
        "stop_at_overturn": ("solver.stopAtOverturn", "bool"),
    },
}


# the excitation parameters each kind uses (model/c/ground.c); a kind ignores the others
_PULSE = {"amplitude", "frequency", "startTime", "verticalAmplitude"}
EXCITATION_USES = {0: set(), 1: _PULSE | {"cycles"}, 2: _PULSE | {"cycles"},
                   3: {"displacement", "frequency", "cycles", "startTime", "verticalAmplitude"},
                   4: {"scale", "startTime", "file"}, 5: _PULSE, 6: _PULSE, 7: _PULSE | {"gamma", "phase"}}


def unused_parameter(name: str, p: dict[str, Any]) -> str | None:
    """Why the FMU ignores parameter `name` in a scene of parameters `p` (defaults included),
    or None when it uses it."""
    kind, law, n = int(p.get("excitation.kind", 0)), int(p.get("restitution.law", 0)), int(p.get("nBlocks", 1))
    two = n >= 2  # a stack or a column
    table, _, key = name.partition(".")
    if re.fullmatch(r"block[3-8]", table) and int(table[5:]) > n:
        return f"{name} belongs to block {table[5:]}, and the scene has {n} (add a [{table}] table)"
    if re.fullmatch(r"block[1-8]", table) and key in ("halfWidth", "halfHeight") and has_outline(p, int(table[5:])):
        return f"{name} is not used: {table}.outline gives the block's shape"
    if re.fullmatch(r"block[1-8]", table) and key in ("centreX", "centreY", "inertia") and (
            not has_outline(p, int(table[5:])) or not float(p.get(f"{table}.inertia", 0.0) or 0.0) > 0):
        return (f"{name} is used by a body of real shape with its inertia above 0 ({table}.outline, "
                f"{table}.inertia; 0: a uniform polygon's centroid and inertia)")
    if table == "excitation" and key != "kind" and key not in EXCITATION_USES.get(kind, set()):
        return f"{name} is not used by a scene of excitation kind \"{KIND_NAMES.get(kind, kind)}\""
    if name == "block1.mass" and not two and not (has_outline(p, 1) and float(p.get("block1.inertia", 0.0) or 0.0) > 0):
        return "one block's rocking does not depend on its mass (theta, impacts and overturning are the same)"
    if table == "block2" and not two:
        return f"{name} belongs to a second block, and the scene has one (add a [block2] table)"
    if name == "restitution.k" and (law != 1 or two):
        return "restitution.k is used by the modified law (law = \"modified\", one block) only"
    if name == "restitution.eta" and (law != 2 or two):
        return "restitution.eta is used by the constant law (law = \"constant\") of one block only"
    if name in ("restitution.etaGround", "restitution.etaInterface") and not (two and law == 2):
        return f"{name} is used by the constant law (law = \"constant\") of two blocks only"
    if name == "contact.muInterface" and not two:
        return "contact.muInterface is the friction between two blocks, and the scene has one"
    if name == "restitution.correction" and two:
        return "restitution.correction is 1 for two blocks (use the constant law's eta_ground, eta_interface)"
    return None


# m: a block's half width or half height above this is most likely entered in millimetres
PLAUSIBLE_HALF_SIZE = 10.0


def implausible_sizes(p: dict[str, Any]) -> list[str]:
    """Notes (not errors) for blocks of parameters `p` (defaults included) with a half size above
    PLAUSIBLE_HALF_SIZE: a 400 mm x 1600 mm block entered as 400 x 1600 runs as a building."""
    notes = []
    for i in range(1, int(p.get("nBlocks", 1)) + 1):
        if has_outline(p, i):  # its vertices' largest coordinate
            from runners.engine.shapes import parse_outline

            try:
                far = max(max(abs(x), abs(y)) for x, y in parse_outline(str(p[f"block{i}.outline"])))
            except ValueError:
                continue  # (the FMU says what is wrong with it)
            if far > 2 * PLAUSIBLE_HALF_SIZE:
                notes.append(f"block{i}'s outline reaches {far:g} m from its axis and base: its vertices are in "
                             "metres (docs/scenes.md)")
            continue
        b, h = float(p.get(f"block{i}.halfWidth", 0.0)), float(p.get(f"block{i}.halfHeight", 0.0))
        if max(b, h) > PLAUSIBLE_HALF_SIZE:
            notes.append(f"block{i} is {2 * b:g} m x {2 * h:g} m (half_width {b:g} m, half_height {h:g} m): sizes "
                         "are in metres (docs/scenes.md)")
    return notes


def uplift_threshold(p: dict[str, Any]) -> tuple[float, str]:
    """(|a_h| in m/s^2 above which the ground tips the block or stack of parameters `p` (defaults
    included) off its base from rest with a_v = 0, what starts then): g tan(alpha) for one block;
    for a stack the lower of the pair's g b1 / yG (yG the height of the pair's centre of mass)
    and block 2's g min(b1, b2) / h2."""
    if has_outline(p):  # bodies of real shape: every joint, both sides (runners.engine.shapes)
        from runners.engine.shapes import uplift

        return uplift(p)
    g, b1, h1 = float(p["g"]), float(p["block1.halfWidth"]), float(p["block1.halfHeight"])
    if int(p.get("nBlocks", 1)) >= 3:
        return column_uplift(p)
    if int(p.get("nBlocks", 1)) != 2:
        return g * b1 / h1, "the block rocks"
    m1, b2, h2, m2 = (float(p[k]) for k in ("block1.mass", "block2.halfWidth", "block2.halfHeight", "block2.mass"))
    y_g = (m1 * h1 + m2 * (2 * h1 + h2)) / (m1 + m2)
    pair, upper = b1 / y_g, min(b1, b2) / h2
    if pair <= upper:
        return g * pair, "the pair rocks as one body"
    return g * upper, "the upper block rocks alone"


def column_uplift(p: dict[str, Any]) -> tuple[float, str]:
    """A column's uplift threshold (m/s^2, what starts then) from rest, all blocks locked: the least
    over K of g b_K / y_K, the blocks from K up tipping as one body about the edge of their base (half
    width b_K, no wider than the block below), y_K the height of their centre of mass above it."""
    g, n = float(p["g"]), int(p["nBlocks"])
    best = (math.inf, "")
    for k in range(1, n + 1):
        m = [float(p[f"block{j}.mass"]) for j in range(k, n + 1)]
        h = [float(p[f"block{j}.halfHeight"]) for j in range(k, n + 1)]
        base = [sum(2 * x for x in h[:i]) for i in range(len(h))]
        y = sum(mj * (zj + hj) for mj, zj, hj in zip(m, base, h)) / sum(m)
        a = g * float(p[f"block{k}.halfWidth"]) / y
        if a < best[0]:
            best = (a, "the column rocks as one body" if k == 1 else
                    f"blocks {k}-{n} rock as one body on block {k - 1}" if k < n else f"block {n} rocks on block {n - 1}")
    return best


def motion_threshold(p: dict[str, Any]) -> tuple[float, str]:
    """(|a_h| in m/s^2 below which nothing of the scene of parameters `p` moves from rest with
    a_v = 0, what it is): the uplift threshold (uplift_threshold), or with rocking-sliding
    (contact.model = 1) the least of it and the contacts' mu g (Shenton 1996)."""
    uplift, _ = uplift_threshold(p)
    if int(p.get("contact.model", 0)) != CONTACT_MODELS["rocking-sliding"]:
        return uplift, ("uplift, g b / yG on its nearer side" if has_outline(p) and int(p.get("nBlocks", 1)) == 1
                        else "uplift, g tan(alpha)" if int(p.get("nBlocks", 1)) == 1 else "uplift of the stack"
                        if int(p.get("nBlocks", 1)) == 2 else "uplift of the column")
    mu = float(p["contact.muGround"])
    if int(p.get("nBlocks", 1)) >= 2:
        mu = min(mu, float(p["contact.muInterface"]))
    for k in range(3, int(p.get("nBlocks", 1)) + 1):  # a column's own mu per block (-1: muInterface's)
        if float(p.get(f"block{k}.mu", -1.0)) > 0:
            mu = min(mu, float(p[f"block{k}.mu"]))
    slide = mu * float(p["g"])
    return (slide, "sliding, mu g") if slide < uplift else (uplift, "uplift")


PULSE_KINDS = (1, 2, 5, 6, 7)  # the excitations whose excitation.amplitude is their peak acceleration


def weak_excitation(p: dict[str, Any]) -> list[str]:
    """A note (not an error) when a pulse's amplitude (excitation.amplitude, m/s^2) cannot move the
    scene of parameters `p` (defaults included), at rest at the start, at all: below its threshold
    of motion (motion_threshold) even where a vertical amplitude V lowers gravity to g - |V|. Such
    an amplitude was often meant in g."""
    from runners.engine.intensity import G0

    if int(p.get("excitation.kind", 0)) not in PULSE_KINDS:
        return []
    blocks = (1, 2) if int(p.get("nBlocks", 1)) >= 2 else (1,)
    if any(p.get(f"block{i}.{k}", 0.0) != 0 for i in blocks for k in ("theta0", "omega0")):  # it moves anyway
        return []
    amplitude, vertical, g = abs(float(p["excitation.amplitude"])), abs(float(p["excitation.verticalAmplitude"])), float(p["g"])
    try:
        threshold, what = motion_threshold(p)
    except ValueError:  # an outline the FMU will refuse, in its own words, when the run starts
        return []
    if not 0 < amplitude < threshold * max(g - vertical, 0.0) / g:
        return []
    return [f"excitation amplitude {amplitude:g} m/s2 is below the threshold of motion {threshold:.4g} m/s2 ({what}): "
            f"nothing can move. Amplitudes are in m/s2, not g ({amplitude:g} g would be {amplitude * G0:.4g} m/s2)"]


def with_times(scene: Scene, stop_time: float | None = None, step: float | None = None) -> Scene:
    """`scene` (changed in place) with the run's own stop time and output step (s) where given:
    they replace the scene's, and a record no longer sets them."""
    if stop_time is not None:
        scene.stop_time, scene.stop_time_given = float(stop_time), True
    if step is not None:
        scene.step, scene.step_given = float(step), True
    return scene


class SceneError(RockingError, ValueError):
    """A scene file is unreadable or invalid; str() is a one-line message."""


@dataclass
class Scene:
    name: str
    parameters: dict[str, float | int | bool | str] = field(default_factory=dict)
    stop_time: float = 5.0  # s
    step: float = 1e-3  # s, communication step
    source: str = ""
    record: str | None = None  # a stored record's name or id ([excitation] record)
    file: str | None = None  # a record file ([excitation] file), absolute once loaded
    stop_time_given: bool = False  # [simulation] stop_time was set (else records set it)
    step_given: bool = False  # [simulation] step was set (else a record's sample interval is used)
    pga: float | None = None  # g: scale the record to this PGA ([excitation] pga)

    @property
    def n_blocks(self) -> int:
        return int(self.parameters.get("nBlocks", 1))

    @property
    def is_record(self) -> bool:
        return int(self.parameters.get("excitation.kind", 0)) == KINDS["record"]


def _value(where: str, value: Any, kind: Any) -> Any:
    if kind == "outline":  # [[x, y], ...] in m -> the FMU's String "x,y; x,y; ..."
        return format_outline(_outline(where, value))
    if kind == "point":  # [x, y] in m
        return _pair(where, value, "[x, y] in m, e.g. centre = [0.0, 0.35]")
    if kind == "real":  # numpy's scalars too (a dict scene built in Python)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise SceneError(f"{where}: expected a number, got {value!r}")
        if not math.isfinite(value):
            raise SceneError(f"{where}: {value!r} is not a finite number")
        return float(value)
    if kind == "count":
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise SceneError(f"{where}: expected a whole number, got {value!r}")
        return int(value)
    if kind == "bool":
        if not isinstance(value, bool):
            raise SceneError(f"{where}: expected true or false, got {value!r}")
        return value
    if kind == "text":
        if not isinstance(value, str) or not value.strip():
            raise SceneError(f"{where}: expected a non-empty text, got {value!r}")
        return value
    if kind == "record":
        if isinstance(value, bool) or not isinstance(value, (str, numbers.Integral)) or not str(value).strip():
            raise SceneError(f"{where}: expected a record name or database id, got {value!r}")
        return str(value).strip() if isinstance(value, str) else str(int(value))
    if not isinstance(value, str) or value not in kind:
        raise SceneError(f"{where}: expected one of {', '.join(kind)}, got {value!r}")
    return kind[value]


def _pair(where: str, value: Any, example: str) -> tuple[float, float]:
    """Two finite numbers [x, y] (m), in one line otherwise."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(f"{where}: expected {example}, got {value!r}")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise SceneError(f"{where}: expected {example}; {v!r} is not a number")
        if not math.isfinite(v):
            raise SceneError(f"{where}: {v!r} is not a finite number")
    return float(value[0]), float(value[1])


def _outline(where: str, value: Any) -> list[tuple[float, float]]:
    """The vertices of a scene's outline (a list of 3 to MAX_VERTICES pairs [x, y] of finite numbers, m);
    whether they make a convex polygon with a flat base is the FMU's to say (its one-line refusal)."""
    if not isinstance(value, (list, tuple)):
        raise SceneError(f"{where}: expected a list of vertices [[x, y], [x, y], ...] in m, got {value!r}")
    if len(value) < 3:
        raise SceneError(f"{where}: an outline needs at least 3 vertices [x, y] (m), got {len(value)}")
    if len(value) > MAX_VERTICES:
        raise SceneError(f"{where}: an outline has at most {MAX_VERTICES} vertices, got {len(value)}")
    return [_pair(f"{where} vertex {i}", v, "a vertex [x, y] in m") for i, v in enumerate(value, start=1)]


def scene_from_dict(data: dict[str, Any], source: str = "<scene>") -> Scene:
    """Validate a parsed TOML document into a :class:`Scene`."""
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not name.strip():
        raise SceneError(f"{source}: name must be a text (name = \"statue\"), got {name!r}")
    if not name.isprintable():  # a newline or a control character would break every listing's lines
        raise SceneError(f"{source}: name must be one line of printable characters, got {name[:60]!r}")
    scene = Scene(name=name, source=source)
    data = dict(data)
    try:  # what the blocks stand on (runners.engine.supports): the FMU's own support
        scene.parameters.update(scene_support(data, source))
    except SupportError as exc:
        raise SceneError(str(exc)) from None
    column = _column_table(data, source)
    for table, content in data.items():
        if table in ("name", "column"):
            continue
        if re.fullmatch(r"block(\d+)", table) and int(table[5:]) > MAX_BLOCKS:
            raise SceneError(f"{source}: [{table}]: a column has at most {MAX_BLOCKS} blocks ([block] and [block2] "
                             f"to [block{MAX_BLOCKS}])")
        if table not in SCHEMA:
            raise SceneError(f"{source}: unknown table [{table}] (expected {', '.join((*SCHEMA, *SUPPORT_TABLES))})")
        if not isinstance(content, dict):
            raise SceneError(f"{source}: '{table}' must be a table")
        for key, value in content.items():
            if key not in SCHEMA[table]:
                raise SceneError(f"{source}: [{table}] unknown key '{key}' (expected {', '.join(SCHEMA[table])})")
            fmu_name, kind = SCHEMA[table][key]
            v = _value(f"{source}: [{table}] {key}", value, kind)
            if kind == "point":  # centre = [x, y]: blockK.centreX, blockK.centreY
                stem = fmu_name.rpartition(".")[0]
                scene.parameters[f"{stem}.centreX"], scene.parameters[f"{stem}.centreY"] = v
            elif fmu_name is None:
                setattr(scene, key, v)
                scene.stop_time_given |= key == "stop_time"
                scene.step_given |= key == "step"
            else:
                scene.parameters[fmu_name] = v
    if column is not None:
        scene.parameters.update(column)
    else:
        scene.parameters.update(_block_tables(data, source))
        for table in [t for t in data if t == "block" or re.fullmatch(r"block[2-8]", t)]:
            _check_shape(data[table], f"{source}: [{table}]")
    _check_blocks(scene.parameters, source)
    _check_record(scene, source)
    if scene.parameters.get("solver.method") == METHODS["taylor"] and scene.n_blocks >= 2:
        raise SceneError(f"{source}: [simulation] method = \"taylor\" integrates one block; a scene of "
                         f"{scene.n_blocks} blocks uses \"dormand-prince\" (or \"auto\")")
    wrong = contact_model_problem(scene.parameters, coupled=False)
    if wrong:
        raise SceneError(f"{source}: {wrong}")
    try:
        check_times(scene.stop_time, scene.step, "[simulation] stop_time", "[simulation] step")
    except SceneError as exc:
        raise SceneError(f"{source}: {exc}") from None
    return scene


def _block_tables(data: dict[str, Any], source: str) -> dict[str, Any]:
    """nBlocks from the block tables present: the highest K of [block2] ... [block8] (none: one
    block); a gap ([block4] without [block3]) is refused in one line."""
    present = sorted(int(t[5:]) for t in data if re.fullmatch(r"block[2-8]", t))
    if not present:
        return {}
    top = present[-1]
    missing = [k for k in range(2, top) if k not in present]
    if missing:
        raise SceneError(f"{source}: [block{top}] without [block{missing[0]}]: a column's blocks are [block], "
                         f"[block2], ... [block{top}] with none left out (block K stands on block K - 1)")
    return {"nBlocks": top}


def _column_table(data: dict[str, Any], source: str) -> dict[str, Any] | None:
    """The FMU parameters of a [column] table (drums identical drums: block1 ... blockN of its
    half_width, half_height and mass; its mu the friction of every interface, contact.muInterface),
    or None without one. Mixing it with [block] or [blockK] tables is refused in one line."""
    col = data.get("column")
    if col is None:
        return None
    if not isinstance(col, dict):
        raise SceneError(f"{source}: 'column' must be a table")
    blocks = [t for t in data if t == "block" or re.fullmatch(r"block\d+", t)]
    if blocks:
        raise SceneError(f"{source}: [column] gives every drum; it cannot be mixed with [{blocks[0]}] (use either "
                         "[column] or [block], [block2], ... tables)")
    values = {}
    for key, value in col.items():
        if key not in SCHEMA["column"]:
            raise SceneError(f"{source}: [column] unknown key '{key}' (expected {', '.join(SCHEMA['column'])})")
        values[key] = _value(f"{source}: [column] {key}", value, SCHEMA["column"][key][1])
    _check_shape(values, f"{source}: [column]")
    sizes = ("outline",) if "outline" in values else ("half_width", "half_height")
    for key in ("drums", *sizes, "mass"):
        if key not in values:
            raise SceneError(f"{source}: [column] needs {key} (drums, half_width, half_height and mass, or drums, "
                             "outline and mass; mu optional)")
    n = values["drums"]
    if not 1 <= n <= MAX_BLOCKS:
        raise SceneError(f"{source}: [column] drums = {n}: a column has 1 to {MAX_BLOCKS} drums")
    p: dict[str, Any] = {"nBlocks": n}
    for k in range(1, n + 1):
        if "outline" in values:  # identical drums of that outline (and mass distribution)
            p.update({f"block{k}.outline": values["outline"], f"block{k}.mass": values["mass"]})
            if "centre" in values:
                p.update({f"block{k}.centreX": values["centre"][0], f"block{k}.centreY": values["centre"][1],
                          f"block{k}.inertia": values["inertia"]})
        else:
            p.update({f"block{k}.halfWidth": values["half_width"], f"block{k}.halfHeight": values["half_height"],
                      f"block{k}.mass": values["mass"]})
    if "mu" in values:
        if "mu_interface" in (data.get("contact") or {}):
            raise SceneError(f"{source}: [column] mu and [contact] mu_interface both give the interfaces' friction: "
                             "give one")
        p["contact.muInterface"] = values["mu"]
    return p


def _check_shape(table: dict[str, Any], where: str) -> None:
    """A block table's (or [column]'s) body of real shape: outline instead of half_width and half_height,
    centre and inertia both or neither and only with an outline, inertia above 0. One line each."""
    if "outline" in table:
        given = [k for k in ("half_width", "half_height") if k in table]
        if given:
            raise SceneError(f"{where}: give outline or half_width and half_height, not both ({given[0]} with "
                             "outline: the outline is the block's shape)")
    elif "centre" in table or "inertia" in table:
        key = "centre" if "centre" in table else "inertia"
        raise SceneError(f"{where}: {key} is the mass distribution of a body of real shape: give its outline too")
    if ("centre" in table) != ("inertia" in table):
        have, lack = ("centre", "inertia") if "centre" in table else ("inertia", "centre")
        raise SceneError(f"{where}: {have} needs {lack} too (both, or neither for a uniform polygon)")
    if "inertia" in table:
        v = table["inertia"]
        if isinstance(v, numbers.Real) and not isinstance(v, bool) and not v > 0:
            raise SceneError(f"{where}: inertia = {v:g} must be above 0 kg m2 (leave out centre and inertia for a "
                             "uniform polygon)")


def _check_blocks(p: dict[str, Any], source: str) -> None:
    """Sizes and masses the scene gives: above zero; a column's block (3 or more blocks) no wider
    than the one below it; a block's mu above zero. One line each (defaults are the FMU's, valid)."""
    n = int(p.get("nBlocks", 1))
    for k in range(1, MAX_BLOCKS + 1):
        table = "[block]" if k == 1 else f"[block{k}]"
        for key, what in (("halfWidth", "half_width"), ("halfHeight", "half_height"), ("mass", "mass"),
                          ("mu", "mu")):
            v = p.get(f"block{k}.{key}")
            if v is not None and not v > 0:
                unit = "kg" if key == "mass" else "m" if key != "mu" else ""
                raise SceneError(f"{source}: {table} {what} = {v:g} must be above 0{' ' + unit if unit else ''} "
                                 f"(block{k}.{key})")
    if "contact.muInterface" in p and not p["contact.muInterface"] > 0:
        raise SceneError(f"{source}: the interfaces' mu = {p['contact.muInterface']:g} must be above 0")
    if n < 3:
        return
    widths = [p.get(f"block{k}.halfWidth", 0.1) for k in range(1, n + 1)]  # (the FMU's default: 0.1 m for every block)
    for k in range(2, n + 1):
        if has_outline(p, k) or has_outline(p, k - 1):  # the FMU checks a body stands within the top below it
            continue
        if widths[k - 1] > widths[k - 2]:
            raise SceneError(f"{source}: block {k} is wider than block {k - 1} under it (half_width {widths[k - 1]:g} > "
                             f"{widths[k - 2]:g} m): a column's block must be no wider than the one below it")


def column_blocks(p: dict[str, Any]) -> range:
    """The blocks of FMU parameters `p`: 1 .. nBlocks."""
    return range(1, int(p.get("nBlocks", 1)) + 1)


def contact_model_problem(p: dict[str, Any], coupled: bool = True) -> str | None:
    """Why parameters `p` (a scene's, or merged with overrides) cannot run the contact model they
    name (one line), or None. Rocking-sliding (contact.model = 1) models one block, or a stack whose
    block 2 is no wider than block 1, integrated by Dormand-Prince; any other value of contact.model
    is none of the FMU's models. ``coupled`` False: the support's coupling may still change (a scene
    being read: runners simulate --coupling), so what depends on it is left to the run's check."""
    model = p.get("contact.model", 0)
    if isinstance(model, bool) or not isinstance(model, numbers.Real) or model not in CONTACT_MODEL_NAMES:
        return ("contact.model must be " + " or ".join(f"{v} ({k})" for k, v in CONTACT_MODELS.items())
                + f", got {model!r}")
    if int(model) != CONTACT_MODELS["rocking-sliding"]:
        if coupled and int(p.get("support.kind", 0)) and int(p.get("support.coupling", 0)) == 1 and \
                p.get("solver.method", 0) == METHODS["taylor"]:
            return ("[simulation] method = \"taylor\" integrates rigid rocking on the ground or on a one-way support; "
                    "on a two-way support the contact engine integrates it: use \"auto\" or \"dormand-prince\", or "
                    "couple the support one way")
        return None
    if int(p.get("nBlocks", 1)) == 2 and not has_outline(p) and p.get("block2.halfWidth", 0.1) > p.get("block1.halfWidth", 0.1):
        return ("[contact] model = \"rocking-sliding\" of a stack needs block 2 no wider than block 1 (block2 "
                f"half_width {p.get('block2.halfWidth')} > block1 half_width {p.get('block1.halfWidth')}): a wider "
                "block 2 would turn about block 1's edge, which is not modelled")
    if p.get("solver.method", 0) == METHODS["taylor"]:
        return ("[contact] model = \"rocking-sliding\" is integrated by \"dormand-prince\"; [simulation] method = "
                "\"taylor\" integrates rigid rocking only")
    return None


def n_samples(stop_time: float, step: float, start_time: float = 0.0) -> int:
    """Communication steps from start_time to stop_time with steps of `step` (s): the last one
    shortened to end at stop_time, a step within 1e-9 of a whole number of them not added."""
    q = (stop_time - start_time) / step
    n = round(q)
    return max(1, n if abs(q - n) <= 1e-9 * max(1.0, q) else math.ceil(q))


def check_times(stop_time: float, step: float, stop_name: str = "stop_time", step_name: str = "step") -> None:
    """SceneError unless stop_time and step (s) are finite and positive and give at most
    MAX_SAMPLES output samples. A step longer than stop_time is one step to stop_time."""
    if not (math.isfinite(stop_time) and stop_time > 0):
        raise SceneError(f"{stop_name} must be a finite time > 0 s, got {stop_time:g}")
    if not (math.isfinite(step) and step > 0):
        raise SceneError(f"{step_name} must be a finite time > 0 s, got {step:g}")
    if stop_time / step > MAX_SAMPLES:
        raise SceneError(f"{stop_name} {stop_time:g} s at {step_name} {step:g} s gives {stop_time / step:.3g} output "
                         f"samples, more than the {MAX_SAMPLES:.0e} one run may hold: use a larger step")


def check_pga(pga: float, where: str) -> None:
    """A PGA target (g) a record can be scaled to: above zero, at most MAX_PGA_G."""
    if not 0 < pga <= MAX_PGA_G:
        raise SceneError(f"{where} = {pga:g} must be in (0, {MAX_PGA_G:g}] g (it is in g)")


def _check_record(scene: Scene, source: str) -> None:
    """record and file name the excitation of kind "record" (which they imply), one of them."""
    if scene.record is not None and scene.file is not None:
        raise SceneError(f"{source}: [excitation] give record (a stored record) or file (a record file), not both")
    given = scene.record is not None or scene.file is not None
    if given and "excitation.kind" not in scene.parameters:
        scene.parameters["excitation.kind"] = KINDS["record"]
    if given and not scene.is_record:
        raise SceneError(f"{source}: [excitation] record and file apply to kind = \"record\"")
    if scene.is_record and not given:
        raise SceneError(f"{source}: [excitation] kind = \"record\" needs record = NAME (a stored record, "
                         "runners records list) or file = PATH (a record file)")
    if scene.pga is not None:
        if not given:
            raise SceneError(f"{source}: [excitation] pga scales a record: give record or file too")
        if "excitation.scale" in scene.parameters:
            raise SceneError(f"{source}: [excitation] give pga (the record's PGA, in g) or scale, not both")
        check_pga(scene.pga, f"{source}: [excitation] pga")
    if scene.file is not None:
        base = Path(source).parent if source and not source.startswith("<") else Path.cwd()
        scene.file = str((base / scene.file).resolve()) if not Path(scene.file).is_absolute() else scene.file


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file."""
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():  # a FIFO or a device: reading would not end
        raise SceneError(f"{path}: not a regular file, not a scene file")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # a byte-order mark is allowed
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a folder, not a scene file") from None
    except UnicodeDecodeError as exc:
        line = exc.object[:exc.start].count(b"\n") + 1
        raise SceneError(f"{path}: line {line}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x}); a scene "
                         "file is TOML, saved as UTF-8") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: invalid TOML: {exc}") from None
    return scene_from_dict(data, str(path))


def restitution(p: dict[str, Any], alpha: float) -> float:
    """The one-block coefficient of restitution of the scene (as the FMU computes it)."""
    from model.reference import housner_restitution, modified_restitution  # loads SciPy: only when used

    law = int(p["restitution.law"])
    if law == 0:
        eta = housner_restitution(alpha)
    elif law == 1:
        eta = modified_restitution(alpha, p["restitution.k"])
    else:
        eta = p["restitution.eta"]
    return eta * p["restitution.correction"]
