"""Temporary files written beside their destination and renamed into place when whole (a new
SQLite database, an unsaved run, an export). A process killed outright (SIGKILL, a power cut)
leaves its temporary file behind; their names carry the writer's host and process id, so the
next writer on the same host removes those of processes that are gone, and leaves alone those
of live processes and of other hosts (a folder shared over the network)."""

from __future__ import annotations

import os
import re
import socket
from pathlib import Path

_HOST = re.sub(r"[^A-Za-z0-9.-]", "_", socket.gethostname())[:64] or "host"


def tag() -> str:
    """HOST-PID: who writes a temporary file, as its name says."""
    return f"{_HOST}-{os.getpid()}"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale(folder: Path, prefix: str, suffix: str = "") -> list[Path]:
    """Remove the files in `folder` named PREFIX + HOST-PID + anything + SUFFIX that a process of
    this host which is no longer running left there; returns them. Errors are ignored: the
    files are only in the way of nobody."""
    removed = []
    pattern = re.compile(re.escape(prefix) + re.escape(_HOST) + r"-(\d+)(?:\D.*)?" + re.escape(suffix), re.S)
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        m = pattern.fullmatch(name) if name.startswith(prefix) else None
        if m is None or int(m.group(1)) == os.getpid() or _alive(int(m.group(1))):
            continue
        try:
            os.unlink(Path(folder) / name)
            removed.append(Path(folder) / name)
        except OSError:
            pass
    return removed
