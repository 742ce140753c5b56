"""Bodies of real shape on the runners' side (docs/columns_runners.md, "Bodies of real shape"): a scene's
outline, centre and inertia reach the FMU as its String and Reals; a rectangle given as its outline
summarises as the rectangle of its half sizes; the vase example's thresholds per side, alphas, landing
angles and mass properties are those of the independent reference model/polygon_reference.py; bad
outlines are refused in one line (the scene's checks and the FMU's own); a sweep divides by the body's
own alpha; the recording draws the outline, rotated as the FMU's outputs say. The real FMU through fmpy,
real SQLite files and .rrd files read back."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli
from db import series
from db.schema import Run
from db.session import open_database
from model import polygon_reference as pr
from runners.engine.scene import SceneError, load_scene
from runners.engine.shapes import format_outline, parse_outline

ROOT = Path(__file__).resolve().parent.parent
VASE_SCENE = ROOT / "examples" / "vase.toml"
VASE = [(-0.08, 0.0), (0.08, 0.0), (0.2, 0.25), (0.16, 0.6), (0.1, 0.7), (-0.1, 0.7), (-0.16, 0.6), (-0.2, 0.25)]
G = 9.81
# an off-centre body (tests/test_fmu_polygons.py's): base corners at -0.2 and 0.3 m, centre (0.02, 0.6) m
OFF = pr.RockingBody(xL=-0.2, xR=0.3, xG=0.02, yG=0.6, m=2.0, IG=0.1)
OFF_TABLE = ("[block]\noutline = [[-0.2, 0.0], [0.3, 0.0], [0.3, 1.3], [-0.2, 1.3]]\ncentre = [0.02, 0.6]\n"
             "inertia = 0.1\nmass = 2.0\n")


def toml_list(vertices) -> str:
    return "[" + ", ".join(f"[{x!r}, {y!r}]" for x, y in vertices) + "]"


def scene_file(tmp_path: Path, body: str, name: str = "s") -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(body)
    return path


def simulate_json(tmp_path: Path, fmu_path: Path, path: Path, *extra: str, db: str | None = None) -> dict:
    p = run_cli("simulate", str(path), "--json", *extra, *(() if db else ("--no-store",)),
                db=db or f"sqlite:///{tmp_path / 'unused.db'}", fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


# ------------------------------------------------------------------ scenes to the FMU


def test_an_outline_reaches_the_fmu_as_its_string_and_reals(tmp_path, fmu):
    """outline = [[x, y], ...] becomes blockK.outline "x,y; ..." exactly (every double round-trips), centre
    blockK.centreX/Y and inertia blockK.inertia; the FMU holds the very String after it is set, and [column]
    outline fills every drum."""
    odd = [(-0.1234567890123, 0.0), (0.30000000000000004, 0.0), (0.3, 1.3), (-1 / 3, 1.3)]
    path = scene_file(tmp_path, f"[block]\noutline = {toml_list(odd)}\ncentre = [0.02, 0.6]\ninertia = 0.1\n"
                      "mass = 2.0\n[block2]\noutline = " + toml_list(VASE) + "\n")
    p = load_scene(path).parameters
    assert parse_outline(p["block1.outline"]) == odd  # bit for bit
    assert p["block2.outline"] == format_outline(VASE) == "-0.08,0.0; 0.08,0.0; 0.2,0.25; 0.16,0.6; 0.1,0.7; -0.1,0.7; -0.16,0.6; -0.2,0.25"
    assert (p["block1.centreX"], p["block1.centreY"], p["block1.inertia"]) == (0.02, 0.6, 0.1)
    assert "block1.halfWidth" not in p and "block2.centreX" not in p and p["nBlocks"] == 2
    slave, _cb = fmu.instantiate(lambda *a: None, logging_on=False)
    try:
        slave.setupExperiment(startTime=0.0)
        fmu.set_parameters(slave, p)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        vr = [fmu.variable(f"block{k}.outline").valueReference for k in (1, 2)]
        assert [s.decode() if isinstance(s, bytes) else s for s in slave.getString(vr)] == \
            [p["block1.outline"], p["block2.outline"]]
        assert slave.getReal([fmu.variable(n).valueReference for n in ("block1.centreX", "block1.inertia")]) == [0.02, 0.1]
    finally:
        slave.terminate()
        slave.freeInstance()
    col = load_scene(scene_file(tmp_path, f"[column]\ndrums = 3\noutline = {toml_list(VASE[:2] + [(0.08, 0.3), (-0.08, 0.3)])}\n"
                                          "mass = 5.0\nmu = 0.6\n", "col")).parameters
    assert col["nBlocks"] == 3 and all(col[f"block{k}.outline"] == "-0.08,0.0; 0.08,0.0; 0.08,0.3; -0.08,0.3"
                                       and col[f"block{k}.mass"] == 5.0 for k in (1, 2, 3))


@pytest.mark.parametrize("n", [1, 2])
def test_a_rectangle_given_as_its_outline_summarises_as_the_rectangle(tmp_path, fmu_path, n):
    """Rocking-sliding, one block and a stone on a plinth under a 6 m/s2 sine pulse: the outline of the half
    sizes' rectangle gives the same summary, every number within 1e-10 (the engine runs both; alphas from
    the outline's centroid within rounding), and it rocks."""
    blocks = [("block", 0.2, 0.5, 200.0)] if n == 1 else [("block", 0.3, 0.25, 400.0), ("block2", 0.2, 0.5, 200.0)]
    tail = ('[contact]\nmodel = "rocking-sliding"\nmu_ground = 0.6\nmu_interface = 0.5\n[excitation]\nkind = "sine-pulse"\n'
            "amplitude = 6.0\nfrequency = 2.0\n[simulation]\nstop_time = 2.5\nstep = 0.002\n")
    boxes = "".join(f"[{t}]\nhalf_width = {b}\nhalf_height = {h}\nmass = {m}\n" for t, b, h, m in blocks)
    outlines = "".join(f"[{t}]\noutline = {toml_list([(-b, 0), (b, 0), (b, 2 * h), (-b, 2 * h)])}\nmass = {m}\n"
                       for t, b, h, m in blocks)
    a = simulate_json(tmp_path, fmu_path, scene_file(tmp_path, "name = 'x'\n" + boxes + tail, "boxes"))
    b = simulate_json(tmp_path, fmu_path, scene_file(tmp_path, "name = 'x'\n" + outlines + tail, "outlines"))
    assert max(a.get("max_abs_theta_rad", 0.0), a.get("max_abs_theta2_rad", 0.0)) > 0.01  # it rocks
    assert b["shapes"] and not a.get("shapes")
    own = {"wall_time_s", "shapes", "uplift_joints", "uplift_threshold_right_m_s2", "uplift_threshold_left_m_s2",
           "alpha_left_rad", "alpha_right_rad", "p_rad_per_s", "p_right_rad_per_s", "p_left_rad_per_s", "model",
           "model_reason", "sizes"}
    assert set(a) - own == set(b) - own

    def same(x, y, where):
        if isinstance(x, dict):
            assert set(x) == set(y), where
            for k in x:
                same(x[k], y[k], f"{where}.{k}")
        elif isinstance(x, list):
            assert len(x) == len(y), where
            for i, (u, v) in enumerate(zip(x, y)):
                same(u, v, f"{where}[{i}]")
        elif isinstance(x, float) and not isinstance(x, bool):
            assert y == pytest.approx(x, rel=1e-10, abs=1e-12), where
        else:
            assert x == y, where

    for key in set(a) - own:
        same(a[key], b[key], key)
    for sa, sb in zip(a["sizes"], b["sizes"]):
        assert (sb["width_m"], sb["height_m"], sb["mass_kg"]) == (sa["width_m"], sa["height_m"], sa["mass_kg"])
    if n == 1:  # a rectangle's p and alpha, each side
        assert b["p_right_rad_per_s"] == pytest.approx(a["p_rad_per_s"], rel=1e-12)
        assert b["alpha_left_rad"] == pytest.approx(a["alpha_rad"], rel=1e-12)


# ------------------------------------------------------------------ against the reference


def test_the_vase_example_has_the_references_thresholds_alphas_and_mass(tmp_path, fmu_path):
    """examples/vase.toml (the vase on a plinth) runs and is stored; the vase's joint on the plinth has the
    reference's uplift thresholds per side (g bR / yG onto the right, g bL / yG onto the left), alphas, landing
    angles (pi less the interior angle at each foot corner), centroid and inertia of the uniform outline; the
    stored peak over alpha is the peak over the vase's own alpha."""
    db = f"sqlite:///{tmp_path / 'v.db'}"
    s = simulate_json(tmp_path, fmu_path, VASE_SCENE, db=db)
    ref = pr.body_from_polygon(VASE, 20.0)
    right, left = pr.uplift_thresholds(ref, G)
    plinth, vase = s["uplift_joints"]
    assert (vase["on"], vase["blocks"]) == ("block 1", [2])
    assert vase["right_m_s2"] == pytest.approx(-right, rel=1e-12) and vase["left_m_s2"] == pytest.approx(left, rel=1e-12)
    assert s["uplift_threshold_m_s2"] == pytest.approx(min(-right, left), rel=1e-12)  # the vase lifts first
    assert plinth["right_m_s2"] > 2 * vase["right_m_s2"]
    (shape,) = s["shapes"]
    assert shape["block"] == 2 and [tuple(v) for v in shape["vertices"]] == VASE and shape["uniform"]
    assert shape["alpha_right_rad"] == pytest.approx(pr.pivot_geometry(ref, 1)[1], rel=1e-12)
    assert shape["alpha_left_rad"] == pytest.approx(pr.pivot_geometry(ref, -1)[1], rel=1e-12)
    beta_left, beta_right = pr.landing_angles(VASE)
    assert (shape["landing_left_rad"], shape["landing_right_rad"]) == pytest.approx((beta_left, beta_right), rel=1e-12)
    _, (cx, cy), ig = pr.uniform_polygon_properties(VASE, 20.0)
    assert shape["centre_m"] == pytest.approx([cx, cy], abs=1e-12) and shape["inertia_kg_m2"] == pytest.approx(ig, rel=1e-12)
    vase_row = s["per_block"][1]
    assert 0.01 < vase_row["max_abs_theta_rad"] < shape["alpha_right_rad"] and not vase_row["overturned"]
    alpha = min(shape["alpha_left_rad"], shape["alpha_right_rad"])
    assert vase_row["max_abs_theta_over_alpha"] == pytest.approx(vase_row["max_abs_theta_rad"] / alpha, rel=1e-14)
    with open_database(db)() as session:
        run = session.get(Run, s["run_id"])
        assert run.summary.peak2_over_alpha == pytest.approx(vase_row["max_abs_theta_rad"] / alpha, rel=1e-14)
        assert run.scene.parameters["block2.outline"] == format_outline(VASE)


def test_an_off_centre_body_summarises_its_own_thresholds_per_side(tmp_path, fmu_path):
    """A body with a given centre and inertia (unequal sides): the summary's thresholds, alphas and rates
    about either corner are the reference's, and a constant-free run under a pulse onto the easy side is the
    FMU's (peak over the smaller alpha)."""
    s = simulate_json(tmp_path, fmu_path, scene_file(tmp_path, OFF_TABLE + '[excitation]\nkind = "sine-pulse"\n'
                                                    "amplitude = 5.0\nfrequency = 3.0\n[simulation]\nstop_time = 2\n"))
    right, left = pr.uplift_thresholds(OFF, G)
    assert s["uplift_threshold_right_m_s2"] == pytest.approx(-right, rel=1e-12) == G * 0.28 / 0.6
    assert s["uplift_threshold_left_m_s2"] == pytest.approx(left, rel=1e-12) == G * 0.22 / 0.6
    for side, key in ((1, "right"), (-1, "left")):
        rho, alpha, ip = pr.pivot_geometry(OFF, side)
        assert s[f"alpha_{key}_rad"] == pytest.approx(alpha, rel=1e-12)
        assert s[f"p_{key}_rad_per_s"] == pytest.approx(math.sqrt(2.0 * G * rho / ip), rel=1e-12)
    assert s["alpha_rad"] == s["alpha_left_rad"] < s["alpha_right_rad"]
    assert s["model"] == "body of real shape" and not s["shapes"][0]["uniform"]
    assert s["max_abs_theta_over_alpha"] == pytest.approx(s["max_abs_theta_rad"] / s["alpha_left_rad"], rel=1e-14)
    assert s["max_abs_theta_rad"] > 0.01


# ------------------------------------------------------------------ refusals


@pytest.mark.parametrize("table, words", [
    ("outline = [[0.0, 0.0], [1.0, 0.0]]", "at least 3 vertices"),
    ('outline = "0,0; 1,0; 1,1"', "expected a list of vertices"),
    ('outline = [[0.0, 0.0], [1.0, 0.0], [1.0, "a"]]', "vertex 3: expected a vertex [x, y] in m; 'a' is not a number"),
    ("outline = [[0.0, 0.0], [1.0, 0.0], [1.0, nan]]", "vertex 3: nan is not a finite number"),
    ("outline = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0, 2.0]]", "vertex 3: expected a vertex [x, y]"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\ncentre = [0.0, 0.3]", "centre needs inertia too"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\ninertia = 0.2", "inertia needs centre too"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\nhalf_width = 0.2", "not both"),
    ("centre = [0.0, 0.3]\ninertia = 1.0", "give its outline too"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\ncentre = [0.0, 0.3]\ninertia = 0.0", "inertia = 0 must be above 0"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\ncentre = [0.0]\ninertia = 0.1", "expected [x, y] in m"),
])
def test_bad_outlines_are_refused_in_one_line_when_the_scene_is_read(tmp_path, fmu_path, table, words):
    path = scene_file(tmp_path, f"[block]\n{table}\n")
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert words in str(err.value) and "\n" not in str(err.value)
    p = run_cli("simulate", str(path), "--no-store", db=f"sqlite:///{tmp_path / 'x.db'}", fmu_path=fmu_path)
    assert p.returncode != 0 and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and words in p.stderr


@pytest.mark.parametrize("table, words", [
    ("outline = [[-0.2, 0.0], [0.2, 0.0], [0.0, 0.1], [0.2, 0.6], [-0.2, 0.6]]", "block1.outline: the polygon is not convex"),
    ("outline = [[-0.2, 0.1], [0.2, 0.0], [0.2, 0.6], [-0.2, 0.6]]", "block1.outline: one vertex at y = 0"),
    ("outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\ncentre = [0.5, 0.3]\ninertia = 0.1",
     "the centre of mass at x = 0.5 must lie between the base corners"),
    ('outline = [[-0.1, 0.0], [0.1, 0.0], [0.0, 1.0]]\n[restitution]\nlaw = "constant"', "restitution.law = 0"),
])
def test_outlines_the_fmu_refuses_come_through_in_its_one_line(tmp_path, fmu_path, table, words):
    """The scene passes them on; the FMU's refusal, naming the block, is the command's one line (a pulse
    scene, whose threshold note would read the outline first, too)."""
    path = scene_file(tmp_path, f"[block]\n{table}\n" + ("" if "restitution" in table else
                                                          '[excitation]\nkind = "sine-pulse"\namplitude = 0.5\n'))
    load_scene(path)
    p = run_cli("simulate", str(path), "--no-store", db=f"sqlite:///{tmp_path / 'x.db'}", fmu_path=fmu_path)
    assert p.returncode != 0 and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and words in p.stderr, p.stderr


def test_methods_for_rectangles_refuse_a_body_of_real_shape(tmp_path, fmu_path):
    path = scene_file(tmp_path, OFF_TABLE)
    for method in ("closed-form", "rk4"):
        p = run_cli("simulate", str(path), "--no-store", "--method", method, db=f"sqlite:///{tmp_path / 'x.db'}",
                    fmu_path=fmu_path)
        assert p.returncode != 0 and "a body of real shape" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    s = simulate_json(tmp_path, fmu_path, path, "--method", "auto")
    assert s["model"] == "body of real shape" and "no rigid one-block least model" in s["model_reason"]


# ------------------------------------------------------------------ sweeps


def test_a_sweep_of_a_body_of_real_shape_divides_by_its_own_alpha(tmp_path, fmu_path):
    """Each point's stored peak over alpha is the single run's (the body's smaller alpha, not the default
    rectangle's); the w and a axes, a rectangle's scales, are refused in one line."""
    db = f"sqlite:///{tmp_path / 's.db'}"
    body = OFF_TABLE + '[excitation]\nkind = "sine-pulse"\nfrequency = 3.0\n[simulation]\nstop_time = 2\n'
    path = scene_file(tmp_path, body)
    p = run_cli("sweep", str(path), "--grid", "excitation.amplitude=6:8:2", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    from sqlalchemy import select

    from db.schema import RunSummary

    with open_database(db)() as session:
        stored = session.execute(select(Run.point, RunSummary.peak1_over_alpha)
                                 .join(RunSummary, RunSummary.run_id == Run.id).where(Run.sweep_id.is_not(None))).all()
    assert len(stored) == 2
    for point, peak in stored:
        amp = point["excitation.amplitude"]
        one = simulate_json(tmp_path, fmu_path, scene_file(
            tmp_path, body.replace("frequency = 3.0", f"frequency = 3.0\namplitude = {amp}"), f"a{amp}"))
        assert peak == pytest.approx(one["max_abs_theta_over_alpha"], rel=1e-12) and one["max_abs_theta_rad"] > 0.01
    p = run_cli("sweep", str(path), "--grid", "w=1:3:2", "--grid", "a=1:2:2", db=db, fmu_path=fmu_path)
    assert p.returncode != 0 and "Traceback" not in p.stderr and "a body of real shape" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


# ------------------------------------------------------------------ the recording


def test_the_recording_of_the_vase_draws_its_outline_as_the_fmu_turns_it(tmp_path, fmu_path):
    """/scene/block2 holds the vase's eight vertices (closed) at every frame: the outline itself, rigidly
    moved (every distance between vertices kept), turned by block2.theta of the stored series at that time,
    standing on the plinth's drawn top at rest; block 1 is the plinth's rectangle."""
    from test_recording import column, read_back

    db = f"sqlite:///{tmp_path / 'r.db'}"
    rrd = tmp_path / "vase.rrd"
    s = simulate_json(tmp_path, fmu_path, VASE_SCENE, "--out", str(rrd), db=db)
    with open_database(db)() as session:
        run = session.get(Run, s["run_id"])
        time_, cols = series.unpack(run.series.names, run.series.n_samples, run.series.data)
    table = read_back(rrd)
    t_frames, vase = column(table, "/scene/block2", "LineStrips2D:strips")
    _, plinth = column(table, "/scene/block1", "LineStrips2D:strips")
    assert len(vase) == len(plinth) > 100
    outline = np.array(VASE + VASE[:1])
    d_ref = np.linalg.norm(outline[:, None] - outline[None], axis=-1)
    theta2 = np.interp(t_frames, time_, cols["block2.theta"])
    turned = 0
    for (_, strips), (_, rect), th in zip(vase, plinth, theta2):
        pts = np.array(strips[0], float) * [1.0, -1.0]  # (the view's y points down)
        box = np.array(rect[0], float) * [1.0, -1.0]
        assert pts.shape == (9, 2) and box.shape == (5, 2)
        assert np.abs(np.linalg.norm(pts[:, None] - pts[None], axis=-1) - d_ref).max() < 1e-5  # float32
        base = pts[1] - pts[0]  # the foot, turned clockwise by theta2 (the plinth stays put)
        assert math.atan2(-base[1], base[0]) == pytest.approx(th, abs=1e-5)
        if th == 0.0:  # at rest: on the plinth's top, axes aligned
            np.testing.assert_allclose(pts - box[0], outline + [0.25, 0.9], atol=1e-5)
        turned += abs(th) > 0.02
    assert turned > 10  # it did rock, and was drawn turned
