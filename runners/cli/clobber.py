"""No command overwrites what it reads, its database, or another of its own outputs.

Each command declares which of its arguments name files it reads and files it writes
(runners.cli.args.files); runners.cli.parser.main checks them with ``check`` before the command
runs, and a command that learns of more inputs as it goes (the record file a system file names,
say) checks again with ``refuse`` (runners.engine.files, where runners.simulate calls it too). The
FMU of a command with an --fmu option is an input even when the option is not given (ROCKING_FMU's,
else build/RockingBlock.fmu). A refusal is one line (ValueError, exit 2) and nothing has been written.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Iterable

# refuse, sqlite_path and DEFAULT_DB live in the engine (runners.simulate refuses too); here for the commands
from runners.engine.files import DEFAULT_DB, default_fmu, refuse, sqlite_path  # noqa: F401


def _fmu(args: argparse.Namespace, reads: list[tuple[str, str]]) -> dict[str, str]:
    """The FMU a command with an --fmu option reads: the one given, else ROCKING_FMU's, else
    build/RockingBlock.fmu (runners.engine.files.default_fmu), by the label it is declared with."""
    if not hasattr(args, "fmu"):
        return {}
    if args.fmu:
        return {dict(reads).get("fmu", "--fmu"): args.fmu}
    return {"FMU (ROCKING_FMU)" if os.environ.get("ROCKING_FMU") else "FMU": default_fmu()}


def check(args: argparse.Namespace) -> None:
    """refuse() for the files a parsed command line declares (runners.cli.args.files)."""
    declared = getattr(args, "_files", None)
    if not declared:
        return
    reads, writes = declared

    def named(entries: Iterable[tuple[str, str]]) -> dict[str, str | None]:
        out: dict[str, str | None] = {}
        for dest, label in entries:
            value = getattr(args, dest, None)
            for k, v in enumerate(value if isinstance(value, (list, tuple)) else [value]):
                if isinstance(v, str) and v and not v.isdecimal():  # (an id or 'latest' is not a file)
                    out[label if k == 0 else f"{label} ({k + 1})"] = v
        return out

    ins = {k: v for k, v in {**named(reads), **_fmu(args, reads)}.items() if v is not None and Path(v).is_file()}
    refuse(named(writes), ins, getattr(args, "db", None), database=hasattr(args, "db"))
