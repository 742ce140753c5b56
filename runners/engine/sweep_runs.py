"""The runs of a stored sweep, and whether their model answered them.

A run's model answered it when the model's own assumptions held until the run's outcome was
decided (runners.engine.summary.outcome_held): for rigid rocking, no contact slid or lifted off
first; rocking–sliding follows sliding and flight, and holds (a lift-off flag there comes only from
an FMU built before its stack followed flight). Maps and
studies mark the runs it did not answer (docs/contact.md).
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import selectinload

from db.schema import Run, RunSummary, Scene, Sweep
from runners.engine.summary import outcome_held


def rigid_rocking_held(summary: RunSummary) -> bool:
    """Whether the run's model decided its outcome (runners.engine.summary.outcome_held): True
    where the method did not monitor the contacts. A rocking–sliding run (summary.motion set)
    slides by its own model: only a lift-off (flight) is outside it."""
    if summary.assumptions_held is None or summary.assumptions_held:
        return True
    slide = None if getattr(summary, "motion", None) is not None else summary.slide_time
    return outcome_held(summary.overturned, slide, summary.lift_time, summary.fall_time)


def broke(run: Run) -> bool:
    """A point whose contacts slid or lifted off before its outcome was decided."""
    return run.status == "ok" and run.summary is not None and not rigid_rocking_held(run.summary)


def sweep_and_scene(factory, sweep_id: str) -> tuple[Sweep, Scene]:
    """The stored sweep `sweep_id` (its id as text, or 'latest') and its scene; ValueError if none."""
    with factory() as session:
        if sweep_id == "latest":
            sw = session.scalars(select(Sweep).order_by(Sweep.id.desc()).limit(1)).first()
        else:
            if not sweep_id.isdigit():
                raise ValueError(f"SWEEP_ID must be an integer or 'latest', got {sweep_id!r}")
            sw = session.get(Sweep, int(sweep_id))
        if sw is None:
            raise ValueError(f"no sweep {sweep_id} in the database")
        return sw, session.get(Scene, sw.scene_id)


def load(factory, sweep_id: str) -> tuple[Sweep, Scene, list[Run]]:
    """The stored sweep `sweep_id` (its id as text, or 'latest'), its scene and its runs with their summaries."""
    sw, scene = sweep_and_scene(factory, sweep_id)
    with factory() as session:
        runs = session.scalars(select(Run).where(Run.sweep_id == sw.id)
                               .options(selectinload(Run.summary), selectinload(Run.blocks))).all()  # one query, not one per run
        return sw, scene, list(runs)


def fixed_axes(grid: dict) -> dict[str, float]:
    """The one-value --grid axes of a stored sweep (e.g. contact.model=rocking-sliding): parameters
    every point runs with, as the scene's."""
    return {a[0]: a[1] for a in grid.get("axes") or [] if a[3] == 1 and a[0] != "excitation.scale"}


def sweep_parameters(sw: Sweep, scene: Scene) -> dict:
    """The FMU parameters every point of sweep `sw` shares: the FMU's defaults, the scene's, and
    the values its one-value --grid axes set (which replace the scene's)."""
    return {**sw.grid["defaults"], **scene.parameters, **fixed_axes(sw.grid)}
