"""Deleting a stored sweep, run, co-simulated run or record, with every row that belongs to it, in one
transaction.

What belongs to it (db/schema.py, every foreign key): a run's summary (run_summaries), series
(run_series) and excitation (excitations, when no other run or measurement shares it) and its
scene (scenes, when no other run or sweep uses it); a sweep's runs with all of theirs, and its
scene. What needs it, and so refuses the delete unless ``force`` (then it goes too, and is
counted): a record is needed by the runs and sweeps driven by it (runs.excitation_id ->
excitations.record_id, and sweeps.grid["records"]), by the co-simulated runs whose building's
base it moved (cosim_runs.record_id) and by the measurements it was made from
(measurements.excitation_id); a run that is a point of a sweep is needed by that sweep (``force``
takes the point out of it, which ``runners sweep ID`` then runs again). A co-simulated run goes
with its series (cosim_series); nothing refers to it. Nothing else in the schema refers to a run
or a sweep (measurements and calibrations refer to blocks and excitations, not to runs). A sweep
a live process is running (runners.engine.sweep_lock) is never deleted.

Each delete is one transaction: it happens whole or not at all (a failure on the way rolls back
everything), and a refused one changes nothing. Statements work on sets (``DELETE ... WHERE
run_id IN (SELECT ...)``), so a sweep of a million points goes in seconds, on SQLite and PostgreSQL.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import delete, func, select, update
from sqlalchemy.orm import sessionmaker

from db.schema import (CosimRun, CosimSeries, Excitation, Measurement, Record, Run, RunBlock, RunSeries, RunSummary,
                       Scene, Sweep)
from runners.errors import RockingError

KINDS = ("sweep", "run", "cosim", "record")
# what a key of each kind is, in words (messages of runners db delete and Database.delete)
KEY_WORDS = {"sweep": "a sweep's id (a whole number) or 'latest'", "run": "a run's id (a whole number) or 'latest'",
             "cosim": "a co-simulated run's id (a whole number) or 'latest'", "record": "a record's name or id"}
TABLES = {"runs": "run", "run_summaries": "run summary", "run_series": "run series", "excitations": "excitation",
          "sweeps": "sweep", "scenes": "scene", "measurements": "measurement", "records": "record"}  # table -> one row
# tables Deleted.rows counts only when a delete removed rows of them (co-simulated runs, columns' blocks)
OTHER_TABLES = {"cosim_runs": "cosim run", "cosim_series": "cosim series", "run_blocks": "run block"}


class InUse(RockingError, ValueError):
    """A delete refused: other stored rows need what it would delete (or a process is running the
    sweep); str() is one line naming them and what to do."""


@dataclass
class Deleted:
    """What a delete removed: `kind` ("sweep", "run", "record") `id` (`name`: its scene's or the
    record's), the rows deleted per table, and with force what needed it and went too (kind ->
    ids: sweeps, runs, measurements; or "taken out of sweep": [sweep id])."""

    kind: str
    id: int
    name: str
    rows: dict[str, int] = field(default_factory=lambda: dict.fromkeys(TABLES, 0))
    with_it: dict[str, list[int]] = field(default_factory=dict)

    def add(self, counts: dict[str, int]) -> None:
        for table, n in counts.items():
            if table in self.rows or n:
                self.rows[table] = self.rows.get(table, 0) + n

    def as_dict(self) -> dict[str, Any]:
        return {"deleted": self.kind, "id": self.id, "name": self.name, "rows": dict(self.rows),
                "with_it": {k: list(v) for k, v in self.with_it.items()}}

    def text(self) -> str:
        """One line: 'deleted sweep 3 (sine pulse, 4,900 of 4,900 points); rows: 4,900 runs, 4,900 run
        summaries, 1 sweep, 1 scene'; with what went with it ('with --force also: sweep 1, run 7')."""
        one = {**TABLES, **OTHER_TABLES}
        rows = ", ".join(f"{n:,} {one[table] if n == 1 else table.replace('_', ' ')}"
                         for table, n in self.rows.items() if n)
        also = ", ".join(f"{k.replace('_', ' ') if len(v) > 1 or k.startswith('taken') else one[k]} "
                         f"{', '.join(map(str, v[:10]))}"
                         f"{' ...' if len(v) > 10 else ''}" for k, v in self.with_it.items() if v)
        return (f"deleted {self.kind} {self.id} ({self.name})" + (f"; with --force also: {also}" if also else "")
                + f"; rows: {rows or 'none'}")


def delete_stored(factory: sessionmaker, kind: str, key: int | str, force: bool = False) -> Deleted:
    """Delete a stored sweep or run (by id, or "latest": the newest) or record (by name or id)
    with everything that belongs to it, in one transaction; with `force` also what needs it.
    InUse (one line, nothing changed) when something needs it and not `force`, or when a
    process is running the sweep; ValueError for one that is not there."""
    from db.session import display_url

    if kind not in KINDS:
        raise ValueError(f"cannot delete a {kind!r}: a sweep, a run, a cosim (co-simulated run) or a record")
    where = display_url(factory.kw["bind"])
    with factory.begin() as session:
        if kind == "record":
            done = _delete_record(session, factory, _record(session, key), force)
        elif kind == "cosim":
            ident = _newest(session, CosimRun, "co-simulated run") if key == "latest" else int(key)
            row = session.get(CosimRun, ident)
            if row is None:
                raise ValueError(f"no co-simulated run {key} in {where}")
            done = Deleted("cosim", row.id, f"{row.name}, {row.coupling}, {row.engine}")
            done.add(_delete_cosims(session, CosimRun.id == row.id))
        else:
            model = Sweep if kind == "sweep" else Run
            ident = _newest(session, model, kind) if key == "latest" else int(key)
            row = session.get(model, ident)
            if row is None:
                raise ValueError(f"no {kind} {key} in {where}")
            done = (_delete_sweep if kind == "sweep" else _delete_run)(session, factory, row, force)
    if done.kind == "sweep" or done.with_it.get("sweeps"):
        from runners.engine.sweep_lock import remove_leftover

        for sweep_id in [done.id] if done.kind == "sweep" else done.with_it["sweeps"]:
            remove_leftover(factory, sweep_id)
    return done


def _record(session, key: int | str) -> Record:
    """The record named `key` (or of id `key`); ValueError, in one line, when there is none, saying
    how to delete the records of a suite when `key` names one."""
    from db.records import find_record, suite_records

    if session.scalar(select(Record.id).where(Record.name == str(key))) is None and isinstance(key, str):
        members = [r.name for r in suite_records(session, key)]
        if members:
            raise ValueError(f"{key} is a suite of {len(members)} record{'s' * (len(members) > 1)}, not a record: "
                             "runners db delete deletes one record at a time, by its name or id (e.g. runners db "
                             f"delete record {members[0]}; runners records list --suite {key} lists them all)")
    return find_record(session, key)


def _newest(session, model, kind: str) -> int:
    newest = session.scalar(select(func.max(model.id)))
    if newest is None:
        raise ValueError(f"no {kind} in the database, so none is the latest")
    return int(newest)


def _refuse_running(factory: sessionmaker, sweep_ids: list[int]) -> None:
    from runners.engine.sweep_lock import held

    running = sorted(held(factory, sweep_ids) or ())
    if running:
        raise InUse(f"sweep {running[0]} is running (a process is storing its points): stop it (Ctrl-C) before "
                    "deleting it")


def _delete_sweep(session, factory: sessionmaker, sw: Sweep, force: bool) -> Deleted:
    _refuse_running(factory, [sw.id])
    done = Deleted("sweep", sw.id, f"{session.get(Scene, sw.scene_id).name}, {sw.done:,} of {sw.total:,} points")
    done.add(_delete_sweeps(session, [sw.id]))
    return done


def _delete_run(session, factory: sessionmaker, run: Run, force: bool) -> Deleted:
    done = Deleted("run", run.id, run.scene.name)
    if run.sweep_id is not None:
        if not force:
            raise InUse(f"run {run.id} is point {run.grid_index} of sweep {run.sweep_id}, which needs it: delete the "
                        f"sweep (runners db delete sweep {run.sweep_id}), or give --force to take the point out of it "
                        f"(runners sweep {run.sweep_id} then runs it again)")
        _refuse_running(factory, [run.sweep_id])
        session.execute(update(Sweep).where(Sweep.id == run.sweep_id)
                        .values(done=Sweep.done - 1, status="stopped"))
        done.with_it["taken out of sweep"] = [run.sweep_id]
    done.add(_delete_runs(session, Run.id == run.id))
    return done


def _delete_record(session, factory: sessionmaker, rec: Record, force: bool) -> Deleted:
    uses = select(Excitation.id).where(Excitation.record_id == rec.id)
    sweeps = sorted({sw.id for sw in session.scalars(select(Sweep)) if rec.id in (sw.grid.get("records") or [])}
                    | set(session.scalars(select(Run.sweep_id).distinct().where(Run.excitation_id.in_(uses),
                                                                                Run.sweep_id.is_not(None)))))
    runs = sorted(session.scalars(select(Run.id).where(Run.excitation_id.in_(uses), Run.sweep_id.is_(None))))
    measurements = sorted(session.scalars(select(Measurement.id).where(Measurement.excitation_id.in_(uses))))
    cosims = sorted(session.scalars(select(CosimRun.id).where(CosimRun.record_id == rec.id)))
    needs = {"sweeps": sweeps, "runs": runs, "cosim_runs": cosims, "measurements": measurements}
    if any(needs.values()) and not force:
        named = " and ".join(f"{len(ids)} {OTHER_TABLES.get(k, k[:-1]) if len(ids) == 1 else k.replace('_', ' ')} "
                             f"({', '.join(map(str, ids[:5]))}{' ...' if len(ids) > 5 else ''})"
                             for k, ids in needs.items() if ids)
        raise InUse(f"record {rec.name!r} (id {rec.id}) is needed by {named}: delete them first, or give --force to "
                    "delete them with it")
    _refuse_running(factory, sweeps)
    done = Deleted("record", rec.id, rec.name, with_it={k: v for k, v in needs.items() if v})
    done.add(_delete_sweeps(session, sweeps))
    if runs:
        done.add(_delete_runs(session, Run.id.in_(runs)))
    if cosims:
        done.add(_delete_cosims(session, CosimRun.id.in_(cosims)))
    done.add({"measurements": _execute(session, delete(Measurement).where(Measurement.id.in_(measurements)))})
    done.add({"excitations": _execute(session, delete(Excitation).where(Excitation.record_id == rec.id)),
              "records": _execute(session, delete(Record).where(Record.id == rec.id))})
    return done


def _execute(session, statement) -> int:
    """Run a bulk DELETE or UPDATE without loading its rows; the rows it matched."""
    return session.execute(statement.execution_options(synchronize_session=False)).rowcount


def _delete_cosims(session, which) -> dict[str, int]:
    """Delete the co-simulated runs `which` (a condition on cosim_runs) with their series."""
    ids = select(CosimRun.id).where(which)
    return {"cosim_series": _execute(session, delete(CosimSeries).where(CosimSeries.run_id.in_(ids))),
            "cosim_runs": _execute(session, delete(CosimRun).where(which))}


def _delete_sweeps(session, sweep_ids: list[int]) -> dict[str, int]:
    """Delete sweeps, their runs with all of theirs, and their scenes no other row uses."""
    if not sweep_ids:
        return {}
    scenes = list(session.scalars(select(Sweep.scene_id).where(Sweep.id.in_(sweep_ids))))
    counts = _delete_runs(session, Run.sweep_id.in_(sweep_ids), scenes=False)
    counts["sweeps"] = _execute(session, delete(Sweep).where(Sweep.id.in_(sweep_ids)))
    counts["scenes"] = counts.get("scenes", 0) + _delete_unused_scenes(session, scenes)
    return counts


def _delete_runs(session, which, scenes: bool = True) -> dict[str, int]:
    """Delete the runs `which` (a condition on runs) with their summaries and series, their
    excitations no other run or measurement shares and (`scenes`) their scenes no other row uses."""
    ids = select(Run.id).where(which)
    lo, hi = session.execute(select(func.min(Run.excitation_id), func.max(Run.excitation_id)).where(which)).one()
    used_scenes = list(session.scalars(select(Run.scene_id).distinct().where(which))) if scenes else []
    counts = {"run_summaries": _execute(session, delete(RunSummary).where(RunSummary.run_id.in_(ids))),
              "run_series": _execute(session, delete(RunSeries).where(RunSeries.run_id.in_(ids))),
              "run_blocks": _execute(session, delete(RunBlock).where(RunBlock.run_id.in_(ids))),
              "runs": _execute(session, delete(Run).where(which))}
    counts["excitations"] = 0 if lo is None else _execute(session, delete(Excitation).where(
        Excitation.id.between(lo, hi),  # (a sweep's own excitations: the range keeps the NOT IN below cheap)
        Excitation.id.not_in(select(Run.excitation_id).where(Run.excitation_id.is_not(None))),
        Excitation.id.not_in(select(Measurement.excitation_id).where(Measurement.excitation_id.is_not(None)))))
    counts["scenes"] = _delete_unused_scenes(session, used_scenes)
    return counts


def _delete_unused_scenes(session, scene_ids: list[int]) -> int:
    if not scene_ids:
        return 0
    return _execute(session, delete(Scene).where(Scene.id.in_(scene_ids), Scene.id.not_in(select(Run.scene_id)),
                                                 Scene.id.not_in(select(Sweep.scene_id))))
