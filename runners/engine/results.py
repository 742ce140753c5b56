"""What the Python API returns: one run (RunResult) and one stored sweep (SweepResult).

Units are SI and angles radians throughout (docs/conventions.md): the series' index is the
time in s, each column one FMU output under its modelDescription name (``block1.theta`` in rad,
``block1.omega`` in rad/s, ``ground.ah`` in m/s^2, ...).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from runners.errors import ArgumentError

if TYPE_CHECKING:
    import pandas as pd

    from runners.engine.fragility import Fragility
    from runners.engine.study import Curve, Outcomes
    from sqlalchemy.orm import sessionmaker


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

    series and events may be given as functions that build them: they are then built on first
    use, so that pandas loads only for a caller that reads them (runners simulate prints the
    summary only).
    """

    def __init__(self, scene: str, series: "pd.DataFrame | Callable[[], pd.DataFrame]",
                 events: "pd.DataFrame | Callable[[], pd.DataFrame]", summary: dict[str, Any],
                 parameters: dict[str, Any] | None = None, run_id: int | None = None,
                 recording: Path | None = None, report: str = "") -> None:
        self.scene, self.summary, self.parameters = scene, summary, {} if parameters is None else parameters
        self.run_id, self.recording, self.report = run_id, recording, report
        self._series, self._events = series, events

    def __repr__(self) -> str:
        return f"RunResult(scene={self.scene!r}, run_id={self.run_id!r}, overturned={self.overturned})"

    @property
    def series(self) -> "pd.DataFrame":
        if callable(self._series):
            self._series = self._series()
        return self._series

    @property
    def events(self) -> "pd.DataFrame":
        if callable(self._events):
            self._events = self._events()
        return self._events

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

    def outcomes(self, measure: str = "pga", select: dict[str, float] | None = None) -> "Outcomes":
        """A record sweep's runs against intensity ``measure`` (pga in g, pgv in m/s, pgd in m,
        arias in m/s): runners.engine.study.Outcomes, the data of the fragility and IDA curves.
        A sweep with other --grid axes (block sizes, ...) needs ``select={"block1.halfWidth": 0.3}``
        to pick one combination of their values (StudyError otherwise); outcome_sets gives them all."""
        from runners.engine import study

        return study.outcomes(self.factory, self.sweep_id, _measure(measure), _select(select))

    def outcome_sets(self, measure: str = "pga", select: dict[str, float] | None = None) -> list["Outcomes"]:
        """One Outcomes per combination of the sweep's other --grid axes (one when it has none), in
        grid order; ``select`` keeps the combinations with those values."""
        from runners.engine import study

        return study.outcome_sets(self.factory, self.sweep_id, _measure(measure), _select(select))

    def fragility(self, measure: str = "pga", ds: str = "overturn",
                  select: dict[str, float] | None = None, unanswered: str = "omit") -> "Fragility":
        """The lognormal fragility of damage state ``ds`` (default overturn, of either block; see
        fragilities) fitted to a record sweep by maximum likelihood
        (runners.engine.fragility.Fragility: median and dispersion beta, in the unit of
        ``measure``). The runs the model did not answer (its assumptions broke before the
        outcome) are left out, or counted as ``unanswered`` says ("reached", "not-reached",
        "as-run"; docs/records.md). Raises FragilityError when the runs cannot determine it,
        StudyError when the sweep has other --grid axes and ``select`` does not pick one
        combination."""
        from runners.engine.fragility import FragilityError
        from runners.engine import study

        if not isinstance(ds, str):
            raise ArgumentError(f"ds={ds!r}: expected one damage state as a string, e.g. 'block2:overturn' "
                                "(fragilities takes several)")
        curve = study.curves(self.outcomes(measure, select), [ds], _unanswered(unanswered))[0]
        if curve.fragility is None:
            raise FragilityError(curve.why)
        return curve.fragility

    def fragilities(self, measure: str = "pga", ds: list[str] | tuple[str, ...] = ("overturn",),
                    select: dict[str, float] | None = None, unanswered: str = "omit") -> list["Curve"]:
        """The fragility curve of each damage state in ``ds`` at each combination of the sweep's
        other --grid axes (runners.engine.study.Curve: ``.state``, ``.outcomes.combination``,
        ``.reached`` per run, ``.fragility`` or ``.why`` it has none, ``.as_dict()``). Damage
        states: ``[block1:|block2:|either:]overturn``, ``[BLOCK:]rot>Xalpha`` (peak |theta| / alpha
        beyond X, or overturned), ``slides`` (a contact needed more friction than its mu),
        ``[BLOCK:]slide>D`` (rocking-sliding sweeps: peak |slip| beyond D in m, cm or mm, e.g.
        ``slide>5cm``, or overturned; block 2's along block 1's top), ``block2:falloff``
        (rocking-sliding stacks: block 2 fell off block 1). The runs the model did not answer
        are left out of each fit or counted as ``unanswered`` says (as fragility; each curve's
        ``.others`` holds the fits under the other treatments). Draw them with
        runners.analysis.study_figures.curves_figure."""
        from runners.engine import study

        if not isinstance(ds, (list, tuple)) or not all(isinstance(d, str) for d in ds):
            raise ArgumentError(f"ds={ds!r}: expected a list of damage states, e.g. ['overturn', 'rot>0.5alpha']")
        return study.curves(self.outcome_sets(measure, select), list(ds), _unanswered(unanswered))


def _measure(measure: Any) -> str:
    from runners import arguments

    return arguments.text(measure, "measure", "an intensity measure (str): pga, pgv, pgd or arias")


def _unanswered(unanswered: Any) -> str:
    from runners.engine.study import UNANSWERED

    if not isinstance(unanswered, str) or unanswered not in UNANSWERED:
        raise ArgumentError(f"unanswered={unanswered!r}: expected one of {', '.join(UNANSWERED)}")
    return unanswered


def _select(select: Any) -> dict | None:
    if select is not None and not isinstance(select, dict):
        raise ArgumentError(f"select={select!r}: expected a dict of grid axis name to value, e.g. "
                            "{'block1.halfWidth': 0.3}")
    return select


def _series_frame(time, outputs: dict[str, Any]) -> "pd.DataFrame":
    from runners.engine.tables import series_frame

    return series_frame(time, outputs)


def _events_frame(events: list[dict[str, Any]]) -> "pd.DataFrame":
    from runners.engine.tables import events_frame

    return events_frame(events)


def series_later(time, outputs: dict[str, Any]) -> Callable[[], "pd.DataFrame"]:
    """A function building runners.engine.tables.series_frame(time, outputs) when called: a
    RunResult's series, built on first use (tables loads pandas and SQLAlchemy). A partial of a
    module's function, so that a RunResult can be pickled (sent to or from another process)."""
    return partial(_series_frame, time, outputs)


def events_later(events: list[dict[str, Any]]) -> Callable[[], "pd.DataFrame"]:
    """A function building runners.engine.tables.events_frame(events) when called (a RunResult's
    events, built on first use; picklable, as series_later's)."""
    return partial(_events_frame, events)
