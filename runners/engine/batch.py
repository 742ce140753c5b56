"""Many grid points per call into the FMU: the C batch loop of model/c/batch/batch_fmi.c.

A sweep worker hands a batch of points (their parameters in arrays) to a small C library that
runs each through the FMU's FMI 2.0 Co-Simulation API (reset, set parameters, initialise, one
fmi2DoStep to the stop time, read outputs), so a point costs no Python call at all. The FMI API
stays the only way into the model: the library loads the FMU's own binary and knows nothing of
the model but the value references it is given.

The library is compiled from its source on first use with the system's C compiler (cc or gcc)
and kept in a cache folder (cache_dir: $ROCKING_CACHE/batch, else ~/.cache/rocking/batch), one
file per version of the source; `library()` returns None where no compiler is found, and the sweep then runs its points
one FMI call at a time through fmpy (the same results, slower). ROCKING_BATCH=0 forces that.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

SOURCE = Path(__file__).resolve().parents[2] / "model" / "c" / "batch" / "batch_fmi.c"
MESSAGE = 512  # bytes of a failed point's message (BATCH_MESSAGE in the source)
_LOCK = threading.Lock()


class BatchUnavailable(RuntimeError):
    """The batch library cannot be built or loaded here; str() is a one-line reason."""


def cache_dir() -> Path:
    """Where compiled libraries are kept: $ROCKING_CACHE/batch, else $XDG_CACHE_HOME/rocking/batch,
    else ~/.cache/rocking/batch (as the record files: runners.engine.record_files.cache_folder)."""
    base = os.environ.get("ROCKING_CACHE")
    if base:
        return Path(base) / "batch"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rocking" / "batch"


def enabled() -> bool:
    """False when ROCKING_BATCH asks for the one-call-per-point path (0, no, off, false; 1, yes,
    on, true or unset: the batch loop); ValueError for any other value."""
    value = os.environ.get("ROCKING_BATCH", "1").strip().lower()
    if value in ("0", "no", "off", "false"):
        return False
    if value in ("1", "yes", "on", "true", ""):
        return True
    raise ValueError(f"ROCKING_BATCH={os.environ['ROCKING_BATCH']!r}: give 1 (run a sweep's points in the C batch "
                     "loop, the default) or 0 (one FMI call at a time through fmpy)")


def library() -> Path:
    """The compiled batch library for this machine, built from SOURCE if not cached yet;
    BatchUnavailable when it cannot be (no C compiler, not Linux or macOS, no source, a cache
    folder that cannot be written).

    A cached library is used only if its bytes have the sha256 recorded next to it when it was
    built (a file cut short, changed or put there by something else is built again): it is
    never loaded to find out, since loading a damaged library can kill the process."""
    if sys.platform.startswith("win"):
        raise BatchUnavailable("the batch library is built for Linux and macOS only")
    if not SOURCE.is_file():
        raise BatchUnavailable(f"its source {SOURCE} is missing")
    from fmu_build.build import fmi_headers_dir

    headers = fmi_headers_dir()
    target = library_path()
    with _LOCK:
        if _verified(target):
            return target
        cc = shutil.which("cc") or shutil.which("gcc")
        if cc is None:
            raise BatchUnavailable("no C compiler (cc or gcc) to build it")
        tmp = None
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(suffix=".so", dir=target.parent)  # built aside, then renamed: atomic
            os.close(fd)
            done = subprocess.run([cc, "-O2", "-shared", "-fPIC", "-I", str(headers), "-o", tmp, str(SOURCE), "-ldl"],
                                  capture_output=True, text=True)
            if done.returncode != 0:
                raise BatchUnavailable(f"{cc} failed: {(done.stderr.strip().splitlines() or ['?'])[0]}")
            digest = _sha256(Path(tmp))
            os.replace(tmp, target)
            side = Path(f"{target}.sha256.tmp{os.getpid()}")
            side.write_text(digest)
            os.replace(side, f"{target}.sha256")
        except OSError as exc:
            raise BatchUnavailable(f"cannot write its cache folder {target.parent}: {exc.strerror or exc}") from None
        finally:
            if tmp and os.path.exists(tmp):
                os.remove(tmp)
        if not _verified(target):
            raise BatchUnavailable(f"another process changed {target} while it was built")
    return target


def library_path() -> Path:
    """Where the library of this version of its source is cached (built or not)."""
    from fmu_build.build import fmi_headers_dir

    key = hashlib.sha256(SOURCE.read_bytes() + (fmi_headers_dir() / "fmi2FunctionTypes.h").read_bytes())
    return cache_dir() / f"rocking_batch-{key.hexdigest()[:16]}.so"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _verified(path: Path) -> bool:
    """Whether `path` is a library this module built: its bytes match the sha256 beside it."""
    try:
        return path.is_file() and Path(f"{path}.sha256").read_text().strip() == _sha256(path)
    except OSError:
        return False


def _arg_types(lib: ctypes.CDLL) -> None:
    p, i, d, u = ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_uint)
    ip, s = ctypes.POINTER(ctypes.c_int), ctypes.c_char_p
    lib.batch_open.restype = p
    lib.batch_open.argtypes = [s, s, s, s, i]
    lib.batch_close.restype = None
    lib.batch_close.argtypes = [p]
    lib.batch_run.restype = i
    lib.batch_run.argtypes = [p, i, d, i, u, d, i, u, ip, i, u, ip, i, u, ctypes.POINTER(s), i, u, d, i, u, ip,
                              i, u, ip, d, ip, s, i]


@dataclass
class BatchOutputs:
    """What a batch gives back, one row per point: Real, Integer and Boolean outputs in the
    order asked for, the wall time of each point (s), whether it failed, and the FMU's message
    of each failed point (position -> one line)."""

    reals: np.ndarray
    ints: np.ndarray
    bools: np.ndarray
    seconds: np.ndarray
    failed: np.ndarray
    messages: dict[int, str]


def _vrs(values: Sequence[int]) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=np.uint32)


def _ptr(a: np.ndarray, ctype):
    return a.ctypes.data_as(ctypes.POINTER(ctype))


class BatchRunner:
    """One FMU instance driven by the batch library: run(...) simulates many points per call.

    `binary`: the FMU's shared library for this platform (binaries/<platform>/<id>.so of its
    extracted folder); `guid` its GUID; `resource_uri` the file: URI of its resources folder."""

    def __init__(self, binary: str | Path, guid: str, resource_uri: str, lib_path: str | Path | None = None):
        self._lib = ctypes.CDLL(str(lib_path or library()))
        _arg_types(self._lib)
        err = ctypes.create_string_buffer(MESSAGE)
        self._b = self._lib.batch_open(str(binary).encode(), guid.encode(), resource_uri.encode(), err, MESSAGE)
        if not self._b:
            raise BatchUnavailable(f"cannot run the FMU in a batch: {err.value.decode(errors='replace')}")

    def run(self, stop: np.ndarray, reals: tuple[Sequence[int], np.ndarray], ints: tuple[Sequence[int], np.ndarray],
            bools: tuple[Sequence[int], np.ndarray], strings: tuple[Sequence[int], list[list[str]]],
            outputs: tuple[Sequence[int], Sequence[int], Sequence[int]]) -> BatchOutputs:
        """Simulate len(stop) points from t = 0 to stop[k] (s). Each input is (value references,
        values with one row per point); Booleans as 0 or 1; `outputs`: the value references of
        the Real, Integer and Boolean outputs to read at the end."""
        n = len(stop)
        stop = np.ascontiguousarray(stop, dtype=np.float64)
        rv, rx = _vrs(reals[0]), np.ascontiguousarray(reals[1], dtype=np.float64).reshape(n, -1)
        iv, ix = _vrs(ints[0]), np.ascontiguousarray(ints[1], dtype=np.int32).reshape(n, -1)
        bv, bx = _vrs(bools[0]), np.ascontiguousarray(bools[1], dtype=np.int32).reshape(n, -1)
        sv = _vrs(strings[0])
        flat = [v.encode() for row in strings[1] for v in row]
        sx = (ctypes.c_char_p * max(1, len(flat)))(*flat)
        orv, oiv, obv = (_vrs(v) for v in outputs)
        oreal = np.zeros((n, len(orv)), dtype=np.float64)
        oint = np.zeros((n, len(oiv)), dtype=np.int32)
        obool = np.zeros((n, len(obv)), dtype=np.int32)
        seconds = np.zeros(n, dtype=np.float64)
        status = np.zeros(n, dtype=np.int32)
        messages = np.empty(n * MESSAGE, dtype=np.uint8)  # written for failed points only
        c_uint, c_double, c_int = ctypes.c_uint, ctypes.c_double, ctypes.c_int
        failed = self._lib.batch_run(
            self._b, n, _ptr(stop, c_double), len(rv), _ptr(rv, c_uint), _ptr(rx, c_double), len(iv), _ptr(iv, c_uint),
            _ptr(ix, c_int), len(bv), _ptr(bv, c_uint), _ptr(bx, c_int), len(sv), _ptr(sv, c_uint), sx, len(orv),
            _ptr(orv, c_uint), _ptr(oreal, c_double), len(oiv), _ptr(oiv, c_uint), _ptr(oint, c_int), len(obv),
            _ptr(obv, c_uint), _ptr(obool, c_int), _ptr(seconds, c_double), _ptr(status, c_int),
            messages.ctypes.data_as(ctypes.c_char_p), MESSAGE)
        bad = status != 0
        text: dict[int, str] = {}
        if failed:
            raw = messages.tobytes()
            for k in np.flatnonzero(bad).tolist():
                line = raw[k * MESSAGE:(k + 1) * MESSAGE].split(b"\0", 1)[0].decode(errors="replace")
                text[k] = (line.strip().splitlines() or ["error"])[0]
        return BatchOutputs(oreal, oint, obool.astype(bool), seconds, bad, text)

    def close(self) -> None:
        if self._b:
            self._lib.batch_close(self._b)
            self._b = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
