"""The layers of runners (README, Layout): the engine (scenes, the FMU, sweeps, records, studies,
stored runs) never reaches up into analysis (figures, maps, charts) or the command line.

Two checks: every import statement in runners/engine, at module level or inside a function, read
from the source; and every engine module imported in a fresh interpreter, after which no
runners.analysis or runners.cli module may be loaded (an import chain through another package
would show there)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

ENGINE = Path(__file__).resolve().parents[1] / "runners" / "engine"
ABOVE = ("runners.analysis", "runners.cli")


def imports_above(source: str, package: str = "runners.engine") -> list[tuple[int, str]]:
    """(line, module) of each import in `source` (a module of `package`) of a module in ABOVE,
    relative imports resolved."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        found += [(node.lineno, n) for n in names if n == "runners" and isinstance(node, ast.ImportFrom)
                  and any(a.name in ("analysis", "cli") for a in node.names)
                  or n.startswith(ABOVE)]
    return found


def test_the_checker_sees_imports_of_analysis_and_cli_anywhere():
    bad = ("from runners.analysis.sweep_map import load\n"
           "def f():\n    from runners.cli import output\n    import runners.analysis.fragility\n"
           "def g():\n    from ..analysis import figures\n    from runners import cli\n")
    lines = sorted({line for line, _ in imports_above(bad)})
    assert lines == [1, 3, 4, 6, 7]
    assert imports_above("from runners.engine import study\nimport numpy\n") == []


def test_no_engine_module_imports_analysis_or_cli():
    modules = sorted(ENGINE.glob("*.py"))
    assert len(modules) > 20
    crossing = [f"{m.name}:{line} imports {name}" for m in modules
                for line, name in imports_above(m.read_text())]
    assert crossing == []


def test_importing_every_engine_module_loads_no_analysis_or_cli_module():
    names = [f"runners.engine.{m.stem}" for m in sorted(ENGINE.glob("*.py")) if m.stem != "__init__"]
    code = ("import importlib, json, sys\n"
            f"for n in {names!r}: importlib.import_module(n)\n"
            f"print(json.dumps(sorted(m for m in sys.modules if m.startswith({ABOVE!r}))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(out.stdout) == []
