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
"""

from importlib.metadata import PackageNotFoundError, version as _version

from runners.errors import ArgumentError, RockingError
from runners.api import (METHODS, RunResult, Scene, SceneError, SweepResult, SweepStopped, as_scene, import_records,
                         open_db, simulate, sweep)

try:
    __version__ = _version("rocking")
except PackageNotFoundError:  # run from a source tree that was not installed
    __version__ = "0+unknown"

__all__ = ["simulate", "sweep", "open_db", "import_records", "as_scene", "RunResult", "SweepResult", "SweepStopped", "Scene",
           "SceneError", "RockingError", "ArgumentError", "METHODS", "__version__"]
