"""Rocking rigid blocks from Python: simulate scenes, run sweeps, read stored results.

The public API (runners.api); the ``runners`` command line (runners.cli) is a thin layer over it::

    import runners
    run = runners.simulate("examples/free_rocking.toml")   # series (DataFrame), events, summary
    sw = runners.sweep("examples/sweep_sine_pulse.toml", grid={"w": (1, 12, 20), "a": (1.01, 8, 20)})
    points = sw.to_pandas()                                 # one row per grid point
    db = runners.open_db()                                  # stored runs, sweeps, records as DataFrames

Units are SI and angles radians (docs/conventions.md); docs/python.md has the whole API.
Subpackages: runners.engine (scenes, the FMU, sweeps, records, recordings), runners.analysis
(fragility, maps, charts, calibration, benchmarks, figures), runners.cli (the command line).

The names below load runners.api on first use (PEP 562), so that a command of runners.cli, which
imports this package first, pays only for the modules it uses (tests/test_startup.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from runners.errors import ArgumentError, RockingError

if TYPE_CHECKING:
    from runners.api import (METHODS, RunResult, Scene, SceneError, SweepResult, SweepStopped, as_scene,
                             import_records, open_db, simulate, sweep)

__all__ = ["simulate", "sweep", "open_db", "import_records", "as_scene", "RunResult", "SweepResult", "SweepStopped", "Scene",
           "SceneError", "RockingError", "ArgumentError", "METHODS", "__version__"]


def __getattr__(name: str) -> Any:
    """runners.simulate, runners.sweep, ...: runners.api's, imported on first use; runners.__version__:
    the installed distribution's version."""
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("rocking")
        except PackageNotFoundError:  # run from a source tree that was not installed
            return "0+unknown"
    if name in __all__:
        import runners.api

        return getattr(runners.api, name)
    raise AttributeError(f"module 'runners' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
