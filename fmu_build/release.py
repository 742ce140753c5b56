"""``python -m fmu_build.release`` (``make release``): every FMU ``python -m fmu_build`` makes,
each with its Windows binary.

The Windows binaries need Debian's mingw-w64 cross compiler (gcc-mingw-w64-x86-64). When it
is missing and this runs as root, apt-get installs it; otherwise (or if the install fails) the
FMUs are built for Linux alone and one line on standard error says that the Windows binaries
were skipped and why. ``make test`` and ``make run`` do not go through here: they build with
whatever compilers are installed (``python -m fmu_build``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence

from fmu_build.build import _win64_cc_name, win64_compiler

PACKAGE = "gcc-mingw-w64-x86-64"
INSTALL = (["apt-get", "install", "-y", "-q", PACKAGE],)
UPDATE_THEN_INSTALL = (["apt-get", "update", "-q"], ["apt-get", "install", "-y", "-q", PACKAGE])


def _run_all(commands: Sequence[Sequence[str]]) -> bool:
    for cmd in commands:
        try:
            if subprocess.run(list(cmd), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL).returncode != 0:
                return False
        except OSError:
            return False
    return True


def ensure_win64_compiler(is_root: bool | None = None,
                          attempts: Sequence[Sequence[Sequence[str]]] = (INSTALL, UPDATE_THEN_INSTALL)) -> str | None:
    """None if the win64 cross compiler is there (installed now with apt-get if missing and
    ``is_root``, by default whether this process runs as root); else why the Windows binaries
    cannot be built, in a few words. ``attempts``: the command lists tried in turn to install it."""
    if win64_compiler() is not None:
        return None
    cc = _win64_cc_name()
    if is_root is None:
        is_root = hasattr(os, "geteuid") and os.geteuid() == 0
    if not is_root:
        return f"{cc} is not installed and this is not root (sudo apt-get install {PACKAGE})"
    print(f"release: installing {PACKAGE} (the Windows cross compiler) with apt-get", file=sys.stderr)
    for commands in attempts:
        if _run_all(commands) and win64_compiler() is not None:
            return None
    if win64_compiler() is None:
        return f"{cc} is not installed and apt-get install {PACKAGE} did not install it"
    return None


def main(argv: list[str] | None = None) -> int:
    from fmu_build.__main__ import main as build

    if argv:
        print("usage: python -m fmu_build.release (no arguments)", file=sys.stderr)
        return 2
    reason = ensure_win64_compiler()
    status = build(["--platforms", "linux64" if reason else "linux64,win64"])
    if status == 0 and reason:
        print(f"release: Windows binaries skipped: {reason}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
