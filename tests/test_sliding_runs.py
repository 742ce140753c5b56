"""Rocking–sliding in single runs of the runners (issue 26): the scene key, the stored and
exported series, the summary's sliding story, --method auto's choice, and the recording.

Every number is checked against the FMU's own outputs, read directly through fmpy's
simulate_fmu (not through runners.engine.fmu), or against the stored run."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import runners
from conftest import run_cli
from runners.engine.scene import SceneError, load_scene, scene_from_dict
from runners.errors import ArgumentError

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "sliding_block.toml"

# the squat block of issue 26: half sizes b = 0.3 m, h = 0.36 m, mu = 0.3, a 12 m/s2 one-sine at 2 Hz
SQUAT = {"block1.halfWidth": 0.3, "block1.halfHeight": 0.36, "contact.muGround": 0.3, "excitation.kind": 1,
         "excitation.amplitude": 12.0, "excitation.frequency": 2.0, "excitation.cycles": 1.0}
EXAMPLE_PARAMS = {**SQUAT, "block1.mass": 100.0, "contact.model": 1}  # examples/sliding_block.toml


def squat_scene(**contact) -> dict:
    return {"name": "squat", "block": {"half_width": 0.3, "half_height": 0.36},
            "contact": {"mu_ground": 0.3, **contact},
            "excitation": {"kind": "sine-pulse", "amplitude": 12.0, "frequency": 2.0, "cycles": 1},
            "simulation": {"stop_time": 2.0, "step": 1e-3}}


def fmpy_final(fmu_path: Path, params: dict, stop_time: float, names: list[str]) -> dict[str, float]:
    """The FMU's own outputs at stop_time, simulated by fmpy.simulate_fmu (Co-Simulation)."""
    from fmpy import simulate_fmu

    start = {"block1.theta0": 0.0, **params}  # a scene starts at rest (docs/scenes.md)
    res = simulate_fmu(str(fmu_path), start_values=start, stop_time=stop_time, output_interval=stop_time / 200,
                       output=names, fmi_type="CoSimulation")
    return {n: float(res[n][-1]) for n in names}


def db_url(tmp_path: Path) -> str:
    return f"sqlite:///{tmp_path / 'runs.db'}"


def stored_runs(url: str) -> int:
    from sqlalchemy import func, select

    from db.schema import Run
    from db.session import open_database

    with open_database(url)() as session:
        return session.scalar(select(func.count()).select_from(Run))


# ------------------------------------------------------------------ scenes


def test_the_contact_model_key_maps_to_the_fmu_parameter():
    assert scene_from_dict(squat_scene(model="rocking-sliding")).parameters["contact.model"] == 1
    assert scene_from_dict(squat_scene(model="rigid-rocking")).parameters["contact.model"] == 0
    assert "contact.model" not in scene_from_dict(squat_scene()).parameters  # the FMU's default: rigid rocking
    sc = load_scene(EXAMPLE)
    assert sc.parameters["contact.model"] == 1 and sc.parameters["contact.muGround"] == 0.3
    assert (sc.parameters["block1.halfWidth"], sc.parameters["block1.halfHeight"]) == (0.3, 0.36)


@pytest.mark.parametrize("extra, words", [
    ({"contact": {"model": "sliding"}}, "expected one of rigid-rocking, rocking-sliding"),
    ({"contact": {"model": 1}}, "expected one of rigid-rocking, rocking-sliding"),
    ({"contact": {"model": "rocking-sliding"}, "block2": {"half_width": 0.4}}, "no wider than block 1"),
    ({"contact": {"model": "rocking-sliding"}, "simulation": {"method": "taylor"}}, "\"taylor\" integrates rigid"),
])
def test_bad_contact_models_are_one_line_and_store_nothing(tmp_path, fmu_path, extra, words):
    data = {**squat_scene(), **extra}
    with pytest.raises(SceneError) as err:
        scene_from_dict(data)
    assert words in str(err.value) and "\n" not in str(err.value)
    # the command line: one line, exit status non-zero, nothing stored
    lines = ['name = "bad"']
    for table, content in data.items():
        if isinstance(content, dict):
            lines.append(f"[{table}]")
            lines += [f"{k} = {json.dumps(v)}" for k, v in content.items()]
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    url = db_url(tmp_path)
    p = run_cli("simulate", str(path), db=url, fmu_path=fmu_path)
    assert p.returncode != 0 and p.stdout == ""
    assert p.stderr.startswith("error: ") and p.stderr.count("\n") == 1 and words in p.stderr, p.stderr
    assert not (tmp_path / "runs.db").exists() or stored_runs(url) == 0


def test_the_api_takes_the_model_by_name_and_refuses_it_for_a_wider_upper_block(tmp_path, fmu_path):
    url = db_url(tmp_path)
    r = runners.simulate(squat_scene(), contact__model="rocking-sliding", stop_time=0.5, fmu=fmu_path)
    assert r.parameters["contact.model"] == 1 and r.summary["contact_model"] == "rocking-sliding"
    stack = {**squat_scene(), "block2": {"half_width": 0.4, "half_height": 0.2}}
    with pytest.raises(ArgumentError, match="no wider than block 1"):
        runners.simulate(stack, contact__model=1, store=True, db=url, fmu=fmu_path)
    with pytest.raises(ArgumentError, match="contact.model must be one of"):
        runners.simulate(squat_scene(), contact__model="slides", store=True, db=url, fmu=fmu_path)
    with pytest.raises(ArgumentError, match="solves rigid rocking"):
        runners.simulate(squat_scene(model="rocking-sliding"), method="scipy", fmu=fmu_path)
    assert stored_runs(url) == 0


# ------------------------------------------------------------------ runs, storage, summaries

SLIDING = ["block1.slip", "block1.slipRate", "block1.mode", "block1.maxAbsSlip", "block1.slideDuration",
           "block1.slideStartTime", "block1.frictionLoss", "impactLoss", "groundWork", "block1.slides"]


def test_a_sliding_scene_is_stored_with_its_channels_and_summary(tmp_path, fmu_path):
    from db import series
    from db.schema import Run
    from db.session import open_database
    from runners.engine.fmu import RockingFMU

    url = db_url(tmp_path)
    r = runners.simulate(EXAMPLE, store=True, db=url, fmu=fmu_path)
    with open_database(url)() as session:
        run = session.get(Run, r.run_id)
        t, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
        summary = run.summary
        assert run.model == "rocking-sliding" and run.scene.parameters["contact.model"] == 1
        kinds = {e["kind"] for e in run.series.events}
        row = {k: getattr(summary, k) for k in ("motion", "max_abs_slip", "residual_slip", "slide_duration",
                                                 "slide_time", "assumptions_held")}
    assert set(SLIDING) <= set(cols)
    with RockingFMU(fmu_path) as fm:  # the same run through the runners' FMU driver, sampled alike
        sc = load_scene(EXAMPLE)
        direct = fm.run(sc.parameters, sc.stop_time, sc.step, outputs=SLIDING)
    np.testing.assert_array_equal(t, direct.time)
    for name in SLIDING:
        np.testing.assert_array_equal(cols[name], direct.outputs[name], err_msg=name)
    assert "slide" in kinds
    final = fmpy_final(fmu_path, EXAMPLE_PARAMS, 2.0, SLIDING + ["block1.maxAbsTheta"])
    assert row["motion"] == "slides" and final["block1.maxAbsTheta"] == 0.0
    assert row["max_abs_slip"] == pytest.approx(final["block1.maxAbsSlip"], rel=1e-12)
    assert row["residual_slip"] == pytest.approx(final["block1.slip"], rel=1e-12, abs=1e-15)
    assert row["slide_duration"] == pytest.approx(final["block1.slideDuration"], rel=1e-12)
    assert row["slide_time"] == pytest.approx(final["block1.slideStartTime"], rel=1e-12)
    assert row["assumptions_held"] is True  # sliding is in the model; nothing flew
    # stick-to-slip from rest where |a_h| first reaches mu g (the spec's asin(mu g / A) / (2 pi f))
    assert row["slide_time"] == pytest.approx(math.asin(0.3 * 9.81 / 12.0) / (2 * math.pi * 2.0), abs=1e-9)
    # read back through the Python API as stored
    back = runners.open_db(url).run(r.run_id)
    assert back.summary["max_abs_slip"] == row["max_abs_slip"]
    np.testing.assert_array_equal(back.series["block1.slip"].to_numpy(), cols["block1.slip"])


def _numbers(text: str) -> list[float]:
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


def test_the_summary_tells_the_sliding_story_of_a_slide_only_run(tmp_path, fmu_path):
    p = run_cli("simulate", str(EXAMPLE), "--no-store", db=db_url(tmp_path), fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    final = fmpy_final(fmu_path, EXAMPLE_PARAMS, 2.0, SLIDING + ["block1.maxAbsTheta"])
    line = next(x for x in p.stdout.splitlines() if x.startswith("sliding "))
    story = line.split(None, 1)[1]
    m = re.match(r"slid (\S+) m \(peak\), residual (\S+) m, never rocked; sliding (\S+) s in all, "
                 r"from t = (\S+) s, (\d+) slides?$", story)
    assert m, story
    peak, residual, duration, start, count = m.groups()
    assert peak == f"{final['block1.maxAbsSlip']:.3g}" and residual == f"{final['block1.slip']:.3g}"
    assert duration == f"{final['block1.slideDuration']:.3g}" and start == f"{final['block1.slideStartTime']:.4f}"
    assert int(count) == round(final["block1.slides"])
    assumptions = next(x for x in p.stdout.splitlines() if x.startswith("assumptions "))
    assert "held: sliding and flight are part of the model" in assumptions
    assert "NOT HELD" not in p.stdout
    js = run_cli("simulate", str(EXAMPLE), "--no-store", "--json", db=db_url(tmp_path), fmu_path=fmu_path)
    s = json.loads(js.stdout)
    assert s["motion"] == "slides" and s["rocked"] is False and s["slid"] is True
    assert s["max_abs_slip_m"] == final["block1.maxAbsSlip"] and s["residual_slip_m"] == final["block1.slip"]
    assert s["friction_loss_J"] == final["block1.frictionLoss"] and s["ground_work_J"] == final["groundWork"]


# a slender block (tan alpha = 0.375 < mu = 0.4) under a 2.5 Hz one-sine: at 7 m/s2 it rocks and slides
# and stays up, at 9 m/s2 it overturns after sliding
SLENDER = {"block1.halfWidth": 0.15, "block1.halfHeight": 0.4, "contact.muGround": 0.4, "contact.model": 1,
           "excitation.kind": 1, "excitation.frequency": 2.5, "excitation.cycles": 1.0}


def slender_scene(amplitude: float) -> dict:
    return {"name": f"slender {amplitude}", "block": {"half_width": 0.15, "half_height": 0.4},
            "contact": {"mu_ground": 0.4, "model": "rocking-sliding"},
            "excitation": {"kind": "sine-pulse", "amplitude": amplitude, "frequency": 2.5, "cycles": 1},
            "simulation": {"stop_time": 3.0}}


@pytest.mark.parametrize("amplitude", [7.0, 9.0])
def test_the_story_of_a_block_that_rocks_and_slides(fmu_path, amplitude):
    r = runners.simulate(slender_scene(amplitude), fmu=fmu_path)
    final = fmpy_final(fmu_path, {**SLENDER, "excitation.amplitude": amplitude}, 3.0,
                       SLIDING + ["block1.maxAbsTheta", "overturned", "overturnTime"])
    story = next(x for x in r.report.splitlines() if x.startswith("sliding ")).split(None, 1)[1]
    tail = (f"sliding {final['block1.slideDuration']:.3g} s in all, from t = {final['block1.slideStartTime']:.4f} s, "
            f"{round(final['block1.slides'])} slide{'s' if round(final['block1.slides']) != 1 else ''}")
    assert final["block1.slides"] >= 1 and final["block1.maxAbsSlip"] > 0
    if amplitude == 7.0:
        assert final["overturned"] == 0 and final["block1.maxAbsTheta"] > 0.1
        assert story == (f"rocked and slid: peak rotation {final['block1.maxAbsTheta']:.3g} rad, peak slip "
                         f"{final['block1.maxAbsSlip']:.3g} m, residual {final['block1.slip']:.3g} m, {tail}")
        assert r.summary["motion"] == "slide-rocks"
    else:
        assert final["overturned"] == 1
        assert story == (f"overturned at {final['overturnTime']:.4f} s after sliding "
                         f"{final['block1.maxAbsSlip']:.3g} m (peak slip); {tail}")
        assert r.summary["motion"] == "overturns"


# ------------------------------------------------------------------ --method auto


def test_auto_uses_rocking_sliding_where_rigid_rocking_slides_and_says_why(tmp_path, fmu_path):
    url = db_url(tmp_path)
    r = runners.simulate(squat_scene(), method="auto", store=True, db=url, fmu=fmu_path)
    s = r.summary
    rigid = fmpy_final(fmu_path, SQUAT, 2.0, ["slideTime", "friction.demandMaxGround", "lifts"])
    assert rigid["slideTime"] >= 0 and rigid["lifts"] == 0  # rigid rocking's monitors: it slides, never flies
    assert s["model"] == "rocking-sliding" and s["model_sufficient"] is True
    assert s["model_reason"] == (f"rigid rocking needs friction demand up to {rigid['friction.demandMaxGround']:.3g}"
                                 f" > mu 0.3 (the block slides from t = {rigid['slideTime']:.6g} s): "
                                 "rocking-sliding used")
    assert r.parameters["contact.model"] == 1 and "block1.slip" in r.series.columns
    assert s["rigid_rocking_assumptions"]["slides"]["t_s"] == pytest.approx(rigid["slideTime"], abs=1e-12)  # the switch
    assert "model check      sufficient: rocking-sliding follows sliding and flight" in r.report
    assert f"model            rocking-sliding: {s['model_reason']}" in r.report
    from db.schema import Run
    from db.session import open_database

    with open_database(url)() as session:
        run = session.get(Run, r.run_id)
        assert run.model == "rocking-sliding" and run.summary.max_abs_slip == s["max_abs_slip_m"]
    p = run_cli("simulate", "--method", "auto", str(EXAMPLE), "--no-store", db=url, fmu_path=fmu_path)
    assert p.returncode == 0 and "rocking-sliding used" in p.stdout, p.stdout + p.stderr


def test_auto_stays_rigid_on_a_slender_block_with_mu_07(fmu_path):
    scene = {"block": {"half_width": 0.1, "half_height": 0.4}, "contact": {"mu_ground": 0.7},
             "excitation": {"kind": "sine-pulse", "amplitude": 4.0, "frequency": 3.0, "cycles": 1},
             "simulation": {"stop_time": 3.0}}
    r = runners.simulate(scene, method="auto", fmu=fmu_path)
    rigid = fmpy_final(fmu_path, {"block1.halfWidth": 0.1, "block1.halfHeight": 0.4, "contact.muGround": 0.7,
                                  "excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 3.0,
                                  "excitation.cycles": 1.0}, 3.0, ["slideTime", "liftTime", "block1.maxAbsTheta"])
    assert rigid["slideTime"] < 0 and rigid["liftTime"] < 0 and rigid["block1.maxAbsTheta"] > 0  # it rocks
    assert r.summary["model"] == "one block" and r.summary["model_sufficient"] is True
    assert "contact_model" not in r.summary and r.parameters.get("contact.model", 0) == 0
    assert "rocking-sliding" not in r.report


@pytest.mark.parametrize("ah", [0.0, 1.0])
def test_auto_answers_a_block_that_would_fly_with_rocking_sliding(tmp_path, fmu_path, ah):
    """A vertical pulse beyond g: without a horizontal part rigid rocking lifts off first; with one it
    slides first. Either way auto runs rocking-sliding, which follows the flight and the landing
    (docs/flight.md), and says so."""
    scene = tmp_path / "fly.toml"
    scene.write_text('name = "fly"\n[block]\nhalf_width = 0.3\nhalf_height = 0.36\n[contact]\nmu_ground = 0.3\n'
                     f'[excitation]\nkind = "sine-pulse"\namplitude = {ah}\nfrequency = 2.0\ncycles = 1\n'
                     'vertical_amplitude = -15.0\n[simulation]\nstop_time = 1.0\n')
    p = run_cli("simulate", "--method", "auto", str(scene), "--no-store", "--json", db=db_url(tmp_path),
                fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    s = json.loads(p.stdout)
    assert s["model_sufficient"] is True and s["model"] == "rocking-sliding"
    assert s["flights"] == 1 and 0.2 < s["flight_time_s"] < 0.4 and s["max_gap_m"] > 0.04
    why = s["why_rocking_sliding"] if "why_rocking_sliding" in s else json.dumps(s)
    assert ("lifts off" in why) if ah == 0.0 else ("slides" in why)
    q = run_cli("simulate", "--method", "auto", str(scene), "--no-store", db=db_url(tmp_path), fmu_path=fmu_path)
    check = next(x for x in q.stdout.splitlines() if x.startswith("model check"))
    assert "sufficient" in check and "flight" in check, check
    assert any(x.startswith("flight") and "flew once" in x for x in q.stdout.splitlines()), q.stdout


# ------------------------------------------------------------------ export and recording


@pytest.mark.parametrize("scene", ["example", "slide-rock"])
def test_export_and_recording_carry_the_slip_and_draw_the_block_where_it_slid(tmp_path, fmu_path, scene):
    """The squat block slides flat (theta = 0); the slender one rocks on a corner that slides."""
    import pandas as pd

    from test_recording import column, read_back

    url = db_url(tmp_path)
    rrd = tmp_path / "slide.rrd"
    r = runners.simulate(EXAMPLE if scene == "example" else slender_scene(7.0), store=True, db=url, recording=rrd,
                         fmu=fmu_path)
    slip = r.series["block1.slip"].to_numpy()
    b = 0.3 if scene == "example" else 0.15
    assert np.abs(slip).max() > (0.05 if scene == "example" else 0.005)  # it slid a visible distance
    out = tmp_path / "run.csv"
    p = run_cli("export", str(r.run_id), "--out", str(out), db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    frame = pd.read_csv(out)
    for name in ("block1.slip", "block1.slipRate", "block1.mode"):
        np.testing.assert_array_equal(frame[name].to_numpy(), r.series[name].to_numpy(), err_msg=name)
    table = read_back(rrd)
    time_ = r.series.index.to_numpy() if "time" not in r.series.columns else r.series["time"].to_numpy()
    for entity, name in (("/block1/slip", "block1.slip"), ("/block1/slip_rate", "block1.slipRate"),
                         ("/block1/mode", "block1.mode")):
        t, rows = column(table, entity)
        assert len(rows) == len(slip), entity
        np.testing.assert_array_equal(np.array([row[1][0] for row in rows]), r.series[name].to_numpy())
    # the drawn block: its base's centre, relative to the drawn ground, at slip + s b (1 - cos theta)
    ft, frames = column(table, "/scene/block1", "LineStrips2D:strips")
    _, ground = column(table, "/scene/ground", "LineStrips2D:strips")
    assert len(frames) == len(ground) > 10
    theta = r.series["block1.theta"].to_numpy()
    moved = tilted = 0
    for tf, (_, strips), (_, g) in zip(ft, frames, ground):
        i = int(np.argmin(np.abs(time_ - tf)))
        corners = np.array(strips[0])  # the outline: bottom left, bottom right, ...
        base_x = 0.5 * (corners[0][0] + corners[1][0])
        line = np.array(g[0])  # the ground line: its centre is the base's displacement
        ground_x = 0.5 * (line[0][0] + line[1][0])
        side = 1.0 if theta[i] >= 0 else -1.0
        expected = slip[i] + side * b * (1 - math.cos(theta[i]))
        assert base_x - ground_x == pytest.approx(expected, abs=2e-6), tf  # Rerun keeps float32
        moved += abs(slip[i]) > 0.005
        tilted += abs(theta[i]) > 0.1 and abs(slip[i]) > 0.005
    assert moved > 0  # frames where the block stands visibly away from its start
    assert (tilted > 0) == (scene == "slide-rock")  # ... and, for the slender one, tilted as well
    later = tmp_path / "later.rrd"  # runners rrd: the stored run's recording, written afterwards
    p = run_cli("rrd", str(r.run_id), "--out", str(later), db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    _, rows = column(read_back(later), "/block1/slip")
    np.testing.assert_array_equal(np.array([row[1][0] for row in rows]), slip)


def test_a_sweep_points_recording_carries_the_slip(tmp_path, fmu_path):
    """runners sweep --points: the recording of a rocking-sliding point has the slip channels too (the
    sweep used to sample only the rigid model's outputs for it)."""
    from test_recording import column, read_back

    url = db_url(tmp_path)
    folder = tmp_path / "points"
    p = run_cli("sweep", str(EXAMPLE), "--grid", "excitation.amplitude=6:12:2", "--points", "all", "--out", str(folder),
                "--quiet", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    files = sorted(folder.glob("*.rrd"))
    assert len(files) == 2
    tables = [read_back(f) for f in files]
    slips = [np.array([row[1][0] for row in column(t, "/block1/slip")[1]]) for t in tables]
    assert all(len(s) > 10 for s in slips) and max(np.abs(s).max() for s in slips) > 0.01
    for entity in ("/block1/slip_rate", "/block1/mode"):
        assert all(len(column(t, entity)[1]) == len(s) for t, s in zip(tables, slips)), entity
