"""The C core's layers, read from the #include lines of model/c so that a change that breaks them fails
here. The contact engine (engine.c and its complementarity solver lcp.c) includes nothing but its own
headers and the model's data types; the three solvers (solver.c for one rigid block, which also dispatches
to the other two; stack_solver.c for the rigid stack; engine_solver.c, the engine's event loop) never call
one another in a loop, and only the dispatcher calls another; the rigid models include nothing of the
engine, and the engine's event loop nothing of the rigid models; the layers they share include no
solver."""
from __future__ import annotations

import re
from pathlib import Path

C = Path(__file__).resolve().parents[1] / "model" / "c"
INCLUDE = re.compile(r'^\s*#\s*include\s+"([A-Za-z0-9_]+)\.h"', re.M)
SOLVERS = {"solver", "stack_solver", "engine_solver"}
ENGINE = {"engine", "lcp", "engine_solver"}
RIGID = {"solver", "stack", "stack_solver", "taylor"}


def direct(name: str) -> set[str]:
    """The project headers (stems) model/c/NAME includes."""
    return set(INCLUDE.findall((C / name).read_text()))


def headers(stem: str) -> set[str]:
    """The headers a .c file sees: its includes and, through them, theirs (stems, itself left out)."""
    seen, todo = set(), list(direct(f"{stem}.c"))
    while todo:
        h = todo.pop()
        if h in seen:
            continue
        seen.add(h)
        if (C / f"{h}.h").exists():
            todo += direct(f"{h}.h")
    seen.discard(stem)
    return seen


def test_the_sources_are_found():
    assert all((C / f"{m}.c").exists() for m in SOLVERS | ENGINE | RIGID)


def test_the_engine_includes_only_itself_and_the_models_data():
    for core in ("engine", "lcp"):
        assert direct(f"{core}.c") <= {"engine", "lcp", "model"}, (core, direct(f"{core}.c"))
        assert not (headers(core) & (SOLVERS | RIGID | {"contact", "events"})), (core, headers(core))


def test_the_solvers_never_call_one_another_in_a_loop():
    calls = {s: headers(s) & SOLVERS for s in SOLVERS}
    assert calls["stack_solver"] == set() and calls["engine_solver"] == set(), calls
    assert calls["solver"] <= {"stack_solver", "engine_solver"}  # the dispatcher, one way


def test_the_rigid_models_include_nothing_of_the_engine_and_the_engine_nothing_of_them():
    for rigid in ("stack", "stack_solver", "taylor"):
        assert not (headers(rigid) & ENGINE), (rigid, headers(rigid) & ENGINE)
    assert not (headers("engine_solver") & RIGID), headers("engine_solver") & RIGID


def test_the_shared_layers_include_no_solver():
    """Contact monitors, event location, the integrators, the ground and records, the rigid stack's
    equations: what the solvers share calls none of them."""
    for shared in ("contact", "events", "integrator", "ground", "record", "taylor", "stack", "model"):
        assert not (headers(shared) & SOLVERS), (shared, headers(shared) & SOLVERS)
