"""What the Python API returns: one run (RunResult) and one stored sweep (SweepResult).

Units are SI and angles radians throughout (docs/conventions.md): the series' index is the
time in s, each column one FMU output under its modelDescription name (``block1.theta`` in rad,
``block1.omega`` in rad/s, ``ground.ah`` in m/s^2, ...).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

    from runners.analysis.fragility import Fragility
    from runners.engine.study import Outcomes
    from sqlalchemy.orm import sessionmaker


@dataclass
class RunResult:
    """One simulated (or stored) run.

    series: one row per output sample, index ``time`` (s), one column per FMU output (SI units).
        Empty for the closed-form model, which has no time history.
    events: one row per event the integrator located (kind impact, peak, rest, overturn, ...):
        columns ``time`` (s), ``kind``, then the events' fields (``theta`` in rad,
        ``omega_minus`` and ``omega_plus`` in rad/s, ``side``, ``contact``, ...; docs/export.md).
    summary: the run's outcome as ``runners simulate --json`` prints it (peaks over the
        slenderness alpha, overturned, impacts, rest time, the model chosen and why, ...).
    parameters: every FMU parameter of the run, the FMU's defaults merged with the scene's.
    run_id: the database id of the stored run, None when not stored.
    recording: the Rerun recording (.rrd) written, if any.
    report: the summary for people, as ``runners simulate`` prints it; its notes (scene
        parameters the run does not use, record units...) are in ``summary["notes"]``.
    """

    scene: str
    series: "pd.DataFrame"
    events: "pd.DataFrame"
    summary: dict[str, Any]
    parameters: dict[str, Any] = field(default_factory=dict)
    run_id: int | None = None
    recording: Path | None = None
    report: str = ""

    @property
    def overturned(self) -> bool:
        """Whether any block overturned."""
        return bool(self.summary.get("overturned", False))


@dataclass
class SweepResult:
    """A sweep stored in a database: its id and where it is; read its points with to_pandas()."""

    sweep_id: int
    factory: "sessionmaker" = field(repr=False)
    stats: dict[str, Any] = field(default_factory=dict)

    def to_pandas(self) -> "pd.DataFrame":
        """One row per grid point, in grid order: ``grid_index``, the swept parameters (SI units),
        the record and its intensity where the sweep runs records, and the outcomes (status,
        peak1_over_alpha, overturned, overturn_time in s, impacts, rest_time in s, ...)."""
        from runners.engine.tables import sweep_frame

        return sweep_frame(self.factory, self.sweep_id)

    def outcomes(self, measure: str = "pga") -> "Outcomes":
        """A record sweep's runs against intensity ``measure`` (pga in g, pgv in m/s, pgd in m,
        arias in m/s): runners.engine.study.Outcomes, the data of the fragility and IDA curves."""
        from runners import arguments
        from runners.engine import study

        measure = arguments.text(measure, "measure", "an intensity measure (str): pga, pgv, pgd or arias")
        return study.outcomes(self.factory, self.sweep_id, measure)

    def fragility(self, measure: str = "pga") -> "Fragility":
        """The lognormal fragility of overturning fitted to a record sweep by maximum likelihood
        (runners.analysis.fragility.Fragility: median and dispersion beta, in the unit of
        ``measure``). Raises FragilityError when the runs cannot determine it."""
        from runners.engine import study

        return study.fragility(self.outcomes(measure))
