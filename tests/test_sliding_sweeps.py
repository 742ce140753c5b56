"""Rocking–sliding (contact.model = 1) in sweeps, maps and studies: each point's motion
class against a direct run of the real FMU through fmpy, the friction axis allowed only where the
block can slide, the mode and peak-slip maps, and fragility of "slides more than D" against an
independent maximum-likelihood fit of the stored peak slips."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sqlalchemy import func, select

from conftest import run_cli
from db.schema import Run, RunSummary, Sweep
from db.session import open_database
from test_damage_states import independent_fit
from test_record_sweeps import db, template  # noqa: F401  (fixtures: a database with the 28 near-field records)

G = 9.81
B, H = 0.3, 0.36  # a squat block: tan(alpha) = b / h = 0.833
SQUAT = (f'name = "squat block"\n[block]\nhalf_width = {B}\nhalf_height = {H}\n'
         '[excitation]\nkind = "sine-pulse"\nfrequency = 2.0\namplitude = 5.0\n[simulation]\nstop_time = 3.0\n')
MUS = (0.2, 0.6, 1.0, 1.4)  # contact.muGround=0.2:1.4:4
AMPLITUDES = (3.0, 7.0, 11.0, 15.0)  # excitation.amplitude=3:15:4, m/s2
MODE_NAMES = {0: "rest", 1: "slide", 2: "rock", 3: "slide-rock", 4: "overturned"}  # the FMU's ContactMode


def cli(*args, db, fmu_path):
    return run_cli(*args, db=db, fmu_path=fmu_path)


def one_line_refusal(p) -> bool:
    return p.returncode == 2 and p.stdout == "" and p.stderr.count("\n") == 1 and "Traceback" not in p.stderr


@pytest.fixture
def grid_db(tmp_path, fmu_path) -> str:
    """A rocking–sliding sweep of the squat block over mu and pulse amplitude, in a SQLite file."""
    url = f"sqlite:///{tmp_path / 'sliding.db'}"
    scene = tmp_path / "squat.toml"
    scene.write_text(SQUAT)
    p = cli("sweep", str(scene), "--grid", "contact.model=rocking-sliding", "--grid", "contact.muGround=0.2:1.4:4",
            "--grid", "excitation.amplitude=3:15:4", "--workers", "2", "--quiet", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return url


def direct_class(fmu_path, mu: float, amplitude: float) -> tuple[str, dict]:
    """The motion class of one point from its own fmpy run (Co-Simulation, 1 ms output), read from
    the mode the FMU reports at every sample: overturned if it reached Overturned, else 'slid' if it
    was ever in Slide or SlideRock, 'rocked' if ever in Rock or SlideRock; and its final outputs."""
    from fmpy import simulate_fmu

    names = ["block1.mode", "block1.slip", "block1.maxAbsSlip", "block1.slideDuration", "overturned"]
    r = simulate_fmu(str(fmu_path), start_values={"block1.theta0": 0.0, "block1.halfWidth": B, "block1.halfHeight": H,
                                                  "excitation.kind": 1, "excitation.frequency": 2.0,
                                                  "excitation.amplitude": amplitude, "contact.muGround": mu,
                                                  "contact.model": 1},
                     stop_time=3.0, output_interval=1e-3, output=names)
    seen = {MODE_NAMES[int(m)] for m in r["block1.mode"]}
    if "overturned" in seen or bool(r["overturned"][-1]):
        kind = "overturns"
    else:
        slid, rocked = bool(seen & {"slide", "slide-rock"}), bool(seen & {"rock", "slide-rock"})
        kind = {(True, True): "slide-rocks", (True, False): "slides", (False, True): "rocks"}.get((slid, rocked), "rests")
    return kind, {n: float(r[n][-1]) for n in names} | {"max_sampled_slip": float(np.max(np.abs(r["block1.slip"])))}


def test_each_point_stores_the_motion_class_and_slips_of_its_own_fmu_run(grid_db, fmu_path):
    with open_database(grid_db)() as s:
        rows = s.execute(select(Run, RunSummary).join(RunSummary, RunSummary.run_id == Run.id)
                         .where(Run.sweep_id == 1).order_by(Run.grid_index)).all()
    assert len(rows) == 16 and all(r.status == "ok" for r, _ in rows)
    seen = set()
    for run, summary in rows:
        mu, a = run.point["contact.muGround"], run.point["excitation.amplitude"]
        kind, out = direct_class(fmu_path, mu, a)
        assert summary.motion == kind, (mu, a, summary.motion, kind)
        seen.add(kind)
        # the slips of the stored point are those of the direct run (the same model, other output steps)
        assert summary.max_abs_slip == pytest.approx(out["block1.maxAbsSlip"], rel=1e-6, abs=1e-12)
        assert summary.max_abs_slip >= out["max_sampled_slip"] - 1e-12  # the peak is never below a sample of |slip|
        assert summary.residual_slip == pytest.approx(out["block1.slip"], rel=1e-6, abs=1e-12)
        assert summary.slide_duration == pytest.approx(out["block1.slideDuration"], rel=1e-6, abs=1e-12)
        if kind != "overturns":  # the first slide time is stored exactly where the block slid
            assert (summary.slide_time is not None) == (kind in ("slides", "slide-rocks"))
        # Shenton (1996)'s initiation from rest: below min(mu, tan alpha) g the block never moves; with
        # mu below tan alpha a block that moves slides and never rocks
        if a < min(mu, B / H) * G:
            assert kind == "rests", (mu, a)
        elif mu < B / H:
            assert kind == "slides", (mu, a)
    assert {"rests", "slides"} <= seen and len(seen) >= 3  # the grid crosses several of Shenton's regions


def test_rigid_points_store_no_slip_and_a_mu_axis_needs_the_sliding_model(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'axes.db'}"
    scene = tmp_path / "squat.toml"
    scene.write_text(SQUAT)
    # rigid rocking: mu never changes the motion, so a mu axis is refused in one line, and nothing is stored
    p = cli("sweep", str(scene), "--grid", "contact.muGround=0.2:1.4:4", "--quiet", db=url, fmu_path=fmu_path)
    assert one_line_refusal(p) and "friction does not change the motion" in p.stderr, p.stderr
    assert "contact.model = rocking-sliding" in p.stderr
    p = cli("sweep", str(scene), "--grid", "contact.model=0", "--grid", "contact.muGround=0.2:1.4:4", "--quiet",
            db=url, fmu_path=fmu_path)
    assert one_line_refusal(p) and "friction does not change the motion" in p.stderr, p.stderr
    p = cli("sweep", str(scene), "--grid", "contact.model=sliding", "--grid", "excitation.amplitude=3:15:2",
            "--quiet", db=url, fmu_path=fmu_path)
    assert one_line_refusal(p) and "expected rigid-rocking (0) or rocking-sliding (1)" in p.stderr, p.stderr
    p = cli("sweep", str(scene), "--grid", "contact.model=0:2:3", "--grid", "excitation.amplitude=3:15:2",
            "--quiet", db=url, fmu_path=fmu_path)
    assert one_line_refusal(p) and "contact.model is 0 (rigid-rocking) or 1 (rocking-sliding)" in p.stderr, p.stderr
    with open_database(url)() as s:
        assert s.scalar(select(func.count()).select_from(Sweep)) == 0
    # a rigid sweep stores no slip (the rigid model's points are unchanged); the sliding model over mu does
    assert cli("sweep", str(scene), "--grid", "excitation.amplitude=3:15:4", "--quiet", db=url,
               fmu_path=fmu_path).returncode == 0
    p = cli("sweep", str(scene), "--grid", "contact.model=1", "--grid", "contact.muGround=0.1:0.4:3", "--quiet",
            db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(url)() as s:
        rigid = s.scalars(select(RunSummary).join(Run).where(Run.sweep_id == 1)).all()
        sliding = s.execute(select(Run.point, RunSummary).join(RunSummary).where(Run.sweep_id == 2)).all()
    assert len(rigid) == 4 and all(r.motion is None and r.max_abs_slip is None and r.residual_slip is None
                                   for r in rigid)
    slips = [rs.max_abs_slip for _, rs in sorted(sliding, key=lambda row: row[0]["contact.muGround"])]
    assert len(slips) == 3 and all(rs.motion == "slides" for _, rs in sliding)  # 5 m/s2 moves every mu <= 0.4
    assert slips[0] > slips[1] > slips[2] > 0  # mu matters now: less friction, more slip
    # the scene's own [contact] model = "rocking-sliding" allows the axis too, and runs the same points
    scene.write_text(SQUAT + '[contact]\nmodel = "rocking-sliding"\n')
    p = cli("sweep", str(scene), "--grid", "contact.muGround=0.1:0.4:3", "--quiet", db=url, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    with open_database(url)() as s:
        again = s.execute(select(Run.point, RunSummary).join(RunSummary).where(Run.sweep_id == 3)).all()
    assert [rs.max_abs_slip for _, rs in sorted(again, key=lambda row: row[0]["contact.muGround"])] == slips


def _legend_texts(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]


def test_mode_and_slip_maps_draw_every_class_and_the_peak_slip(grid_db, fmu_path, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from runners.analysis.slip_map import mode_figure, slip_figure

    with open_database(grid_db)() as s:
        stored = dict(s.execute(select(Run.grid_index, RunSummary.motion).join(RunSummary)
                                .where(Run.sweep_id == 1)).all())
        slips = s.scalars(select(RunSummary.max_abs_slip).join(Run).where(Run.sweep_id == 1)).all()
    mode_png, slip_png = tmp_path / "mode.png", tmp_path / "slip.png"
    p = cli("map", "1", "--by", "mode", "--out", str(mode_png), "--json", db=grid_db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert mode_png.stat().st_size > 10_000 and out["figure"] == str(mode_png)
    expected = {m: list(stored.values()).count(m) for m in ("rests", "slides", "rocks", "slide-rocks", "overturns")}
    assert out["modes"] == expected
    fig, counts, _, _ = mode_figure(open_database(grid_db), "1")
    texts = _legend_texts(fig)
    for m in ("rests", "slides", "rocks", "slide-rocks", "overturns"):  # every class named, with its count
        assert f"{m} ({expected[m]})" in texts, texts
    assert any("mu = b/h" in t and "Shenton 1996" in t for t in texts)  # the friction axis' boundary
    p = cli("map", "1", "--by", "slip", "--out", str(slip_png), "--json", db=grid_db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    assert slip_png.stat().st_size > 10_000
    assert json.loads(p.stdout)["max_abs_slip_m"] == max(slips)
    fig, largest, _, _ = slip_figure(open_database(grid_db), "1")
    assert largest == max(slips)
    assert any(ax.get_ylabel() == "peak |slip| of block 1 (m)" for ax in fig.axes)  # the colour bar, in m
    # the overturning map still draws the sweep (its outcomes), by default
    p = cli("map", "1", "--out", str(tmp_path / "o.png"), db=grid_db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    # the export carries each point's class and slips (a sweep with an Integer axis exports, too)
    csv_path = tmp_path / "points.csv"
    p = cli("export", "--sweep", "1", "--out", str(csv_path), db=grid_db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    import pandas as pd

    frame = pd.read_csv(csv_path)
    assert list(frame["motion"]) == [stored[i] for i in frame["grid_index"]]
    assert max(frame["max_abs_slip"]) == max(slips) and {"residual_slip", "slide_duration"} <= set(frame.columns)


def test_mode_and_slip_maps_of_a_rigid_sweep_are_refused_in_one_line(tmp_path, fmu_path):
    url = f"sqlite:///{tmp_path / 'rigid.db'}"
    scene = tmp_path / "squat.toml"
    scene.write_text(SQUAT)
    assert cli("sweep", str(scene), "--grid", "excitation.amplitude=3:15:3", "--quiet", db=url,
               fmu_path=fmu_path).returncode == 0
    for by in ("mode", "slip"):
        png = tmp_path / f"{by}.png"
        p = cli("map", "1", "--by", by, "--out", str(png), db=url, fmu_path=fmu_path)
        assert one_line_refusal(p) and "runs rigid rocking, which computes no slip" in p.stderr, p.stderr
        assert "contact.model = rocking-sliding" in p.stderr and not png.exists()


CABINET = ('name = "cabinet"\n[block]\nhalf_width = 0.3\nhalf_height = 0.9\nmass = 200\n'
           "[contact]\nmu_ground = 0.3\n")
RECORDS = "1,2,3,4,5,6,7,8"


def stored_slips(url: str, sweep_id: int) -> dict[tuple[str, float], RunSummary]:
    with open_database(url)() as s:
        rows = s.execute(select(Run.point, RunSummary).join(RunSummary, RunSummary.run_id == Run.id)
                         .where(Run.sweep_id == sweep_id)).all()
    return {(pt["record"], pt["level"]): rs for pt, rs in rows}


def test_slide_fragility_is_the_maximum_likelihood_fit_of_the_stored_peak_slips(db, fmu_path, tmp_path):  # noqa: F811
    scene = tmp_path / "cabinet.toml"
    scene.write_text(CABINET)
    p = cli("sweep", str(scene), "--records", RECORDS, "--im", "pga=0.1:1.0:6", "--grid",
            "contact.model=rocking-sliding", "--quiet", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    stored = stored_slips(db, 1)
    assert len(stored) == 48 and all(rs.motion is not None for rs in stored.values())
    png = str(tmp_path / "f.png")
    curves = {}
    for ds in ("slide>5cm", "slide>0.05", "slide>50mm"):
        p = cli("fragility", "1", "--ds", ds, "--out", png, "--json", db=db, fmu_path=fmu_path)
        assert p.returncode == 0, p.stderr
        (curve,) = json.loads(p.stdout)["curves"]
        curves[ds] = curve
    curve = curves["slide>5cm"]
    assert curve["damage_state"] == "slide>0.05m" and curve["label"] == "peak |slip| > 0.05 m (or overturned)"
    assert curves["slide>0.05"] == curve and curves["slide>50mm"] == curve  # one distance, three spellings
    # each point reached the state where its stored peak slip exceeds 5 cm, or it overturned
    for pt in curve["points"]:
        rs = stored[(pt["record"], pt["x"])]
        assert pt["reached"] == (rs.max_abs_slip > 0.05 or rs.overturned)
    assert 0 < curve["reached"] < 48
    assert independent_fit(curve["points"]) == pytest.approx((curve["median"], curve["beta"]), rel=1e-9)
    # a larger distance is reached later
    far = json.loads(cli("fragility", "1", "--ds", "slide>20cm", "--ds", "slide>5cm", "--out", png, "--json", db=db,
                         fmu_path=fmu_path).stdout)["curves"]
    assert far[0]["reached"] <= far[1]["reached"]
    # the IDA draws and lists the peak slip of every run
    ida_png = tmp_path / "ida.png"
    p = cli("ida", "1", "--demand", "slip", "--out", str(ida_png), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    ida = json.loads(p.stdout)
    assert ida["demand"] == "slip" and ida["demand_unit"] == "m" and ida_png.stat().st_size > 10_000
    assert len(ida["runs"]) == 48
    for run in ida["runs"]:
        rs = stored[(run["record"], run["x"])]
        assert run["max_abs_slip"] == rs.max_abs_slip and run["motion"] == rs.motion
    text = cli("ida", "1", "--demand", "slip", "--out", str(ida_png), db=db, fmu_path=fmu_path).stdout
    assert "largest peak |slip| of a standing block" in text


def test_slide_states_and_slip_demands_are_refused_on_rigid_sweeps_in_one_line(db, fmu_path, tmp_path):  # noqa: F811
    scene = tmp_path / "cabinet.toml"
    scene.write_text(CABINET)
    assert cli("sweep", str(scene), "--records", "1,2", "--im", "pga=0.2:0.6:2", "--quiet", db=db,
               fmu_path=fmu_path).returncode == 0
    png = tmp_path / "f.png"
    for args in (["fragility", "1", "--ds", "slide>5cm"], ["fragility", "1", "--ds", "slide>0.05"],
                 ["ida", "1", "--demand", "slip"]):
        p = cli(*args, "--out", str(png), db=db, fmu_path=fmu_path)
        assert one_line_refusal(p), (args, p.stderr)
        assert "runs rigid rocking, which computes no slip: set contact.model = rocking-sliding" in p.stderr
        assert not png.exists()
    for ds in ("slide>0cm", "slide>-5cm", "slide>5km", "slide>nan"):
        p = cli("fragility", "1", "--ds", ds, "--out", str(png), db=db, fmu_path=fmu_path)
        assert one_line_refusal(p) and "D in slide>D must be a distance above 0" in p.stderr, (ds, p.stderr)
    # a sweep over both models: the rigid runs are named, and the sliding ones can be selected
    assert cli("sweep", str(scene), "--records", "1,2", "--im", "pga=0.2:0.6:2", "--grid", "contact.model=0:1:2",
               "--quiet", db=db, fmu_path=fmu_path).returncode == 0
    p = cli("ida", "2", "--demand", "slip", "--out", str(png), db=db, fmu_path=fmu_path)
    assert one_line_refusal(p) and "at contact.model = 0" in p.stderr and "--select contact.model=1" in p.stderr
    p = cli("ida", "2", "--demand", "slip", "--select", "contact.model=1", "--out", str(png), "--json", db=db,
            fmu_path=fmu_path)
    assert p.returncode == 0 and len(json.loads(p.stdout)["runs"]) == 4, p.stderr
