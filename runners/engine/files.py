"""Files written atomically: a new file beside the destination, renamed onto it when complete."""

from __future__ import annotations

import os
from pathlib import Path


def create_beside(path: str | Path) -> tuple[int, str]:
    """A new file beside ``path`` (its descriptor, open for writing, and its name), to be renamed
    onto it: created with mode 0666 less the umask, as open() creates a file (a file of
    tempfile.mkstemp would keep its 0600, owner only)."""
    path = Path(path)
    for _ in range(100):
        tmp = str(path.parent / f".{path.name}.{os.urandom(6).hex()}")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"cannot create a temporary file beside {path}")
