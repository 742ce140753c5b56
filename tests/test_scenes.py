"""Scene files: the integrator choice ([simulation] method), Integer grid axes, and
docs/scenes.md checked against the FMU's variables so it cannot go stale."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import select

from conftest import run_cli
from db.schema import Run, Scene as StoredScene, Sweep
from db.session import open_database
from model.reference import Block, free_rocking
from runners.engine.scene import EXCITATION_USES, KIND_NAMES, METHODS, SCHEMA, Scene, load_scene
from runners.engine.sweep import axis_parameters, check_axes, grid_of, parse_axis, stored_point_parameters

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "scenes.md"

BLOCK = Block(0.1, 0.3)
THETA0 = 0.6 * BLOCK.alpha
ETA = 0.9
REF = free_rocking(BLOCK, THETA0, ETA, 10)  # exact: quarter periods and Housner's energy balance
RTOL = 1e-6  # a loose tolerance, where the two integrators differ most (docs/methods.md)


def free_scene(tmp_path: Path, method: str | None, *, two: bool = False, name: str = "free") -> Path:
    """Free rocking of a 0.2 x 0.6 m block from 0.6 alpha, constant restitution 0.9."""
    lines = [f'name = "{name}"', "[block]", "half_width = 0.1", "half_height = 0.3", f"theta0 = {float(THETA0)!r}",
             "[restitution]", 'law = "constant"', f"eta = {ETA}", "[simulation]", f"rel_tol = {RTOL}",
             f"abs_tol = {RTOL * 1e-2}", f"stop_time = {float(REF.impact_times[-1]) + 0.05!r}", "step = 0.01"]
    if method is not None:
        lines.append(f'method = "{method}"')
    if two:
        lines.append("[block2]")
    path = tmp_path / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_scene(fmu, scene: Scene):
    return fmu.run(scene.parameters, scene.stop_time, scene.step, outputs=["block1.theta", "energy", "impacts"])


def test_method_taylor_reaches_the_fmu_and_both_integrators_meet_the_exact_solution(fmu, tmp_path):
    taylor = load_scene(free_scene(tmp_path, "taylor", name="taylor"))
    default = load_scene(free_scene(tmp_path, None, name="default"))
    named = load_scene(free_scene(tmp_path, "dormand-prince", name="dopri"))
    auto = load_scene(free_scene(tmp_path, "auto", name="auto"))
    assert taylor.parameters["solver.method"] == 1 and "solver.method" not in default.parameters
    assert named.parameters["solver.method"] == 0 and auto.parameters["solver.method"] == 2
    runs = {k: run_scene(fmu, s) for k, s in (("taylor", taylor), ("default", default), ("named", named),
                                              ("auto", auto))}
    for key, r in runs.items():
        ti, pk = r.event_times("impact")[:10], r.event_values("peak", "theta")[:9]
        assert len(ti) == 10 and len(pk) == 9, key
        # the exact free-rocking solution: impact times and peaks, to the tolerance (a global
        # error of a few times the local one)
        assert np.max(np.abs(ti / REF.impact_times - 1)) < 10 * RTOL, key
        assert np.max(np.abs(pk / REF.peak_thetas[:9] - 1)) < 10 * RTOL, key
        # energy: constant between impacts, times eta^2 at each (theta = 0 there, all kinetic)
        e, n = r.outputs["energy"], r.outputs["impacts"]
        assert np.max(np.abs(e / (e[0] * ETA ** (2 * n)) - 1)) < 10 * RTOL, key
    a, b = runs["taylor"], runs["named"]
    assert np.max(np.abs(a.event_times("impact")[:10] / b.event_times("impact")[:10] - 1)) < 10 * RTOL
    # the key is not ignored: "taylor" integrates differently from "dormand-prince" (1e-6 apart
    # here), and the default, "auto", is the Taylor series for one block, bit for bit
    assert np.max(np.abs(a.outputs["block1.theta"] - b.outputs["block1.theta"])) > 1e-8
    np.testing.assert_array_equal(runs["default"].outputs["block1.theta"], a.outputs["block1.theta"])
    np.testing.assert_array_equal(runs["auto"].outputs["block1.theta"], a.outputs["block1.theta"])
    # docs/methods.md: at loose tolerances the Taylor series is the more accurate of the two
    err = {k: np.max(np.abs(r.event_values("peak", "theta")[:9] / REF.peak_thetas[:9] - 1)) for k, r in runs.items()}
    assert err["taylor"] < err["named"] / 10


def test_simulate_stores_the_method_and_refuses_bad_ones(tmp_path, fmu_path):
    db = f"sqlite:///{tmp_path / 'm.db'}"
    p = run_cli("simulate", str(free_scene(tmp_path, "taylor")), db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as s:
        run = s.scalars(select(Run)).one()
        assert s.get(StoredScene, run.scene_id).parameters["solver.method"] == METHODS["taylor"] == 1
    bad = [(free_scene(tmp_path, "tailor", name="bad"), "[simulation] method: expected one of dormand-prince, taylor"),
           (free_scene(tmp_path, "taylor", two=True, name="two"), "method = \"taylor\" integrates one block")]
    for path, message in bad:
        p = run_cli("simulate", str(path), db=db, fmu_path=fmu_path)
        assert p.returncode != 0 and p.stderr.startswith("error: ") and p.stderr.count("\n") == 1, p.stderr
        assert message in p.stderr and "Traceback" not in p.stderr and "unexpected" not in p.stderr + p.stdout


def test_a_sweep_over_solver_method_stores_ints_that_reach_the_fmu(fmu, fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 's.db'}"
    scene = free_scene(tmp_path, None)
    stop = 6.0  # s: the block comes to rest at about 4.3 s
    p = run_cli("sweep", str(scene), "--grid", "solver.method=0:1:2", "--stop-time", str(stop), "--workers", "1",
                "--no-progress", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(db)() as s:
        sw = s.scalars(select(Sweep)).one()
        assert sw.grid["axes"] == [["solver.method", 0, 1, 2, True]]
        axis = grid_of(s, sw).axes[0]
        assert axis.integer and [type(v) for v in axis.values.tolist()] == [int, int]
        runs = s.scalars(select(Run).where(Run.sweep_id == sw.id).order_by(Run.grid_index)).all()
        assert [r.point for r in runs] == [{"solver.method": 0}, {"solver.method": 1}]
        assert all(type(r.point["solver.method"]) is int and r.status == "ok" for r in runs)
        rest = [r.summary.rest_time for r in runs]
        params = [stored_point_parameters(s, r) for r in runs]
    assert [type(q["solver.method"]) for q in params] == [int, int]
    # each point is the FMU run with that integrator, bit for bit, and the two differ
    for m, t in enumerate(rest):
        r = fmu.run(params[m], stop, stop, outputs=["restTime"], events=False)
        assert t == r.outputs["restTime"][-1] > 0
    assert rest[0] != rest[1]


@pytest.mark.parametrize("spec,message", [
    ("solver.method=0:1:3", "solver.method is an Integer parameter"),  # 0, 0.5, 1
    ("solver.method=0.5:1.5:2", "solver.method is an Integer parameter"),
    ("restitution.law=0:1.5:2", "restitution.law is an Integer parameter"),
    ("solver.earlyOverturn=0:1:2", "a Real or Integer FMU parameter"),  # a Boolean
    ("excitation.file=0:1:2", "a Real or Integer FMU parameter"),
])
def test_bad_integer_axes_are_one_line_errors(tmp_path, fmu_path, spec, message):
    p = run_cli("sweep", str(free_scene(tmp_path, None)), "--grid", spec, "--no-progress",
                db=f"sqlite:///{tmp_path / 'b.db'}", fmu_path=fmu_path)
    assert p.returncode == 2 and p.stderr.startswith("error: ") and p.stderr.count("\n") == 1, p.stderr
    assert message in p.stderr and "unexpected" not in p.stderr


def test_unused_axes_are_judged_over_the_integer_axes(fmu):
    """restitution.k is used by the modified law only: an axis on it is refused in a scene of the
    constant law, unless a restitution.law axis brings the modified law into the grid."""
    types = axis_parameters(fmu)
    assert types["solver.method"] == "Integer" and types["block1.halfWidth"] == "Real"
    assert "solver.earlyOverturn" not in types and "excitation.file" not in types
    p = {**fmu.defaults(), "restitution.law": 2}
    k = parse_axis("restitution.k=0.5:1:3", types)
    with pytest.raises(ValueError, match="restitution.k is used by the modified law"):
        check_axes([k], p)
    check_axes([parse_axis("restitution.law=0:2:3", types), k], p)
    with pytest.raises(ValueError, match="restitution.k is used by the modified law"):
        check_axes([parse_axis("restitution.law=0:2:2", types), k], p)  # 0 and 2: never modified
    # a set of names is still accepted (Real parameters, as before)
    assert parse_axis("block1.halfWidth=0.1:0.2:2", {"block1.halfWidth"}).integer is False


# ------------------------------------------------------------------ docs/scenes.md


def _doc_tables() -> dict[str, dict[str, list[str]]]:
    """section ("" for the top level, else the table name) -> key -> the cells of its row in the
    section's "| key | FMU parameter | ..." table."""
    tables: dict[str, dict[str, list[str]]] = {"": {}}
    section, in_keys = "", False
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^## `\[(\w+)\]`", line)
        if m:
            section = m.group(1)
            tables[section] = {}
        elif line.startswith("## "):
            section = None
        in_keys = (in_keys and line.startswith("|")) or line.startswith("| key | FMU parameter |")
        if in_keys and section is not None and (m := re.match(r"^\| `(\w+)` \|(.*)\|$", line)):
            tables[section][m.group(1)] = [c.strip() for c in m.group(2).split("|")]
    return tables


def _default_matches(cell: str, kind, start) -> bool:
    cell = cell.strip("`")
    if kind == "outline":  # a String: empty, the rectangle of the half sizes
        return cell == '""' and start == ""
    if isinstance(kind, dict):
        return kind.get(cell.strip('"')) == int(start)
    if kind == "bool":
        return cell == str(start).lower()  # the XML start value: "true" or "false"
    return float(cell) == float(start)


def test_docs_list_every_scene_key_with_the_runners_default(fmu):
    tables = _doc_tables()
    assert set(tables) == {"", *SCHEMA}, "docs/scenes.md has one section per scene table"
    assert set(tables[""]) == {"name"}
    scene_defaults = {f.name: f.default for f in dataclasses.fields(Scene)}
    runner_defaults = fmu.defaults()
    for table, keys in SCHEMA.items():
        assert set(tables[table]) == set(keys), f"[{table}]: docs/scenes.md and runners/engine/scene.py differ"
        for key, (var, kind) in keys.items():
            fmu_cell, unit, default = tables[table][key][:3]
            where = f"docs/scenes.md [{table}] {key}"
            if var is None:
                assert fmu_cell == "—", where
                if key in ("stop_time", "step"):  # the Scene's own defaults
                    assert float(default) == scene_defaults[key], where
                continue
            v = fmu.variable(var)
            if kind == "point":  # centre = [x, y]: blockK.centreX and blockK.centreY
                assert fmu_cell == f"`{var}`, `{var[:-1]}Y`" and fmu.variable(var[:-1] + "Y").causality == "parameter", where
                fmu_cell = f"`{var}`"
            assert fmu_cell == f"`{var}`" and v.causality == "parameter", where
            expected = runner_defaults.get(var, v.start)  # the FMU's start value unless SCENE_DEFAULTS says
            assert _default_matches(default, kind, expected), f"{where}: the runners' default is {expected}"
            if v.unit:
                assert unit == v.unit, f"{where}: the FMU's unit is {v.unit}"
            if isinstance(kind, dict):  # every name of a choice, with its integer
                for name, i in kind.items():
                    assert f'"{name}"' in tables[table][key][3] or f'`"{name}"`' in default, f"{where}: {name}"
                    if name != "momentum":
                        assert f'"{name}"` ({i}' in tables[table][key][3], f"{where}: {name} ({i})"


def test_every_fmu_parameter_is_a_scene_key(fmu):
    """A new FMU parameter must get a scene key (and so a row in docs/scenes.md)."""
    set_by_keys = {var for keys in SCHEMA.values() for var, _ in keys.values() if var}
    set_by_keys |= {var[:-1] + "Y" for keys in SCHEMA.values() for var, kind in keys.values() if var and kind == "point"}
    implied = {"nBlocks", "excitation.file"}  # by [block2], and by record or file
    params = {n for n, v in fmu.vars.items() if v.causality == "parameter"}
    from fmu_build.build import C_DIR
    from fmu_build.variables import read_codes

    from runners.engine.supports import Building, Platform, fmu_parameters

    codes = set(read_codes(C_DIR / "variables.def"))  # Integer codes of the Enumerations the keys set (docs/model.md)
    # [building], [platform] and [coupling] (docs/supports.md)
    by_supports = set(fmu_parameters(Building([1.0] * 10, [1.0] * 10))) | set(fmu_parameters(Platform(1.0)))
    assert params - set_by_keys - codes - by_supports == implied
    text = DOC.read_text(encoding="utf-8")
    assert all(f"`{n}`" in text for n in implied)


def test_docs_say_what_each_excitation_kind_uses():
    rows = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = re.match(r'^\| `([\w-]+)` \| (.*) \|$', line)
        if m and m.group(1) in KIND_NAMES.values():
            rows[m.group(1)] = set(re.findall(r"`(\w+)`", m.group(2)))
    scene_key = {var.split(".")[1]: key for key, (var, _) in SCHEMA["excitation"].items() if var}
    scene_key["file"] = None  # excitation.file: given by record or file, scaled by scale or pga
    for kind, name in KIND_NAMES.items():
        expected = {scene_key[u] for u in EXCITATION_USES[kind]} - {None}
        if "file" in EXCITATION_USES[kind]:
            expected |= {"record", "file", "pga"}
        assert rows.get(name) == expected, f"docs/scenes.md: kind {name}"


def test_scene_docstring_points_to_the_reference():
    import runners.engine.scene as scene_module

    assert "docs/scenes.md" in scene_module.__doc__ and DOC.is_file()
    assert not re.search(r"seed 0|issue \d", DOC.read_text(encoding="utf-8"))
