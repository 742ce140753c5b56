"""The Python API (runners.simulate, runners.sweep, runners.open_db): what docs/python.md and
examples/notebook.ipynb show runs, and what it returns agrees with the FMU's own counts, with
single runs, and with what the command line prints and stores."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import runners
from tests.conftest import run_cli

ROOT = Path(__file__).resolve().parents[1]
SINE = ROOT / "examples" / "sine_pulse.toml"


def _scratch(tmp_path: Path, monkeypatch) -> None:
    """A scratch folder holding a copy of examples/, as the working folder."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)


def test_every_example_of_docs_python_md_runs_in_order(tmp_path, monkeypatch, fmu_path):
    monkeypatch.setenv("ROCKING_FMU", str(fmu_path))
    _scratch(tmp_path, monkeypatch)
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "python.md").read_text(), re.S)
    assert len(blocks) >= 8
    namespace: dict = {}
    for i, code in enumerate(blocks):
        exec(compile(code, f"docs/python.md block {i + 1}", "exec"), namespace)
    assert (tmp_path / "theta.png").stat().st_size > 0 and (tmp_path / "map.png").stat().st_size > 0
    assert 0.05 < namespace["frag"].median < 2.0  # g: a statue's median capacity, in the levels swept


def test_the_example_notebook_runs_cell_by_cell(tmp_path, monkeypatch, fmu_path):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.setenv("ROCKING_FMU", str(fmu_path))
    _scratch(tmp_path, monkeypatch)
    nb = json.loads((ROOT / "examples" / "notebook.ipynb").read_text())
    cells = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert all(not c["outputs"] for c in cells), "the notebook is kept without outputs (they are generated)"
    namespace: dict = {}
    for i, c in enumerate(cells):
        exec(compile("".join(c["source"]), f"notebook cell {i + 1}", "exec"), namespace)
    # Housner's law: the same omega ratio at every impact, sqrt of the coefficient of
    # restitution... the ratio is the closed form 1 - 1.5 sin^2(alpha) (Housner 1963)
    alpha = namespace["alpha"]
    assert np.allclose(namespace["ratio"], 1 - 1.5 * math.sin(alpha) ** 2, rtol=1e-9)
    assert len(namespace["points"]) == 24 * 20
    assert (tmp_path / "notebook.db").is_file()


def test_series_events_and_summary_of_a_run_agree(fmu_path):
    run = runners.simulate(SINE, fmu=fmu_path)
    s, series, events = run.summary, run.series, run.events
    assert series.index.name == "time" and series.index[0] == 0.0 and series.index[-1] == s["stop_time_s"]
    assert np.allclose(np.diff(series.index), 1e-3)  # the scene's output step
    impacts = events[events["kind"] == "impact"]
    assert len(impacts) == s["impacts"] == series["impacts"].iloc[-1]
    peaks = events[events["kind"] == "peak"]
    # the largest located peak is the run's max |theta|; the sampled series never exceeds it
    assert np.abs(peaks["theta"]).max() == pytest.approx(s["max_abs_theta_rad"], rel=1e-12)
    assert np.abs(series["block1.theta"]).max() <= s["max_abs_theta_rad"] * (1 + 1e-12)
    assert run.parameters["block1.halfWidth"] == 0.1 and run.run_id is None and not run.overturned
    assert type(run.parameters["nBlocks"]) is int and type(run.parameters["restitution.law"]) is int
    assert run.report.startswith("scene ")


def test_a_dict_scene_and_keyword_overrides_are_the_toml_scene_and_its_parameters(fmu_path):
    import tomllib

    toml = runners.simulate(SINE, fmu=fmu_path, stop_time=2.0)
    as_dict = runners.simulate(tomllib.loads(SINE.read_text()), fmu=fmu_path, stop_time=2.0)
    assert toml.series.equals(as_dict.series)
    kw = runners.simulate(SINE, fmu=fmu_path, stop_time=2.0, block1__halfWidth=0.12)
    given = runners.simulate(SINE, {"block1.halfWidth": 0.12}, fmu=fmu_path, stop_time=2.0)
    assert kw.series.equals(given.series) and not kw.series.equals(toml.series)
    assert kw.parameters["block1.halfWidth"] == 0.12


@pytest.mark.parametrize("call, message", [
    (lambda f: runners.simulate(SINE, fmu=f, block1__width=0.1), "block1.width is not a parameter"),
    (lambda f: runners.simulate(SINE, fmu=f, block1__halfwidth=0.1), "did you mean block1.halfWidth?"),
    (lambda f: runners.simulate(SINE, fmu=f, block1__halfWidth="0.3"), "block1.halfWidth must be a finite number"),
    (lambda f: runners.simulate(SINE, fmu=f, restitution__law=0.5), "restitution.law must be a whole number"),
    (lambda f: runners.simulate(SINE, fmu=f, stop_time="3"), "stop_time must be a finite time > 0 s"),
    (lambda f: runners.simulate(SINE, fmu=f, method="rk5"), "unknown method 'rk5'"),
    (lambda f: runners.simulate(SINE, fmu=f, h=1e-3), "h is the fixed step"),
    (lambda f: runners.simulate(ROOT / "nothing.toml", fmu=f), "no such scene file"),
    (lambda f: runners.simulate(42, fmu=f), "a scene is a TOML path, a dict or a Scene"),
    (lambda f: runners.sweep(SINE, fmu=f, grid={"w": (1, 2)}), "give (start, stop, count)"),
])
def test_bad_arguments_raise_one_line_errors(fmu_path, call, message):
    with pytest.raises((ValueError, TypeError)) as err:
        call(fmu_path)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_the_command_line_prints_what_the_api_returns(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 'cli.db'}"
    p = run_cli("simulate", str(SINE), "--json", db=db, fmu_path=fmu_path)
    assert p.returncode == 0, p.stderr
    printed = json.loads(p.stdout)
    api = runners.simulate(SINE, fmu=fmu_path).summary
    for key in ("impacts", "peaks", "rest_time_s", "max_abs_theta_rad", "final_state", "model", "alpha_rad"):
        assert printed[key] == api[key], key
    # the stored run reads back as the API returns it, bit for bit
    stored = runners.open_db(db).run(printed["run_id"])
    fresh = runners.simulate(SINE, fmu=fmu_path)
    for column in fresh.series:
        assert np.array_equal(stored.series[column].to_numpy(), fresh.series[column].to_numpy()), column
    assert np.array_equal(stored.series.index.to_numpy(), fresh.series.index.to_numpy())
    # ...with the summary simulate gives, rebuilt from the stored series
    for key, value in fresh.summary.items():
        if key not in ("wall_time_s", "run_id", "notes", "model_reason"):  # (the reason is not stored)
            assert stored.summary[key] == value, key
    assert list(stored.series.columns) == list(fresh.series.columns)


def test_a_stored_run_has_its_id_and_a_sweep_point_matches_its_single_run(fmu_path, tmp_path):
    db = f"sqlite:///{tmp_path / 'api.db'}"
    run = runners.simulate(SINE, fmu=fmu_path, store=True, db=db)
    assert run.run_id is not None and "stored           run" in run.report
    sw = runners.sweep(ROOT / "examples" / "sweep_sine_pulse.toml", ["w=2:8:3", "a=1.5:6:2"], db=db, fmu=fmu_path)
    points = sw.to_pandas()
    assert len(points) == 6 and sw.stats["stored"] == 6 and list(points["grid_index"]) == list(range(6))
    db_ = runners.open_db(db)
    assert len(db_.runs(sweep=sw.sweep_id)) == 6 and len(db_.runs(single=True)) == 1
    # each point is the single run of its omega_g/p and a_g/(g tan alpha), converted here
    scene = runners.as_scene(ROOT / "examples" / "sweep_sine_pulse.toml")
    b, h, g = scene.parameters["block1.halfWidth"], scene.parameters["block1.halfHeight"], 9.81
    p = math.sqrt(3 * g / (4 * math.hypot(b, h)))  # rad/s, a rectangular block
    row = points.iloc[4]
    single = runners.simulate(scene, {"excitation.frequency": row["w"] * p / (2 * math.pi),
                                      "excitation.amplitude": row["a"] * g * b / h}, fmu=fmu_path)
    assert bool(row["overturned"]) == single.overturned
    assert row["peak1_over_alpha"] == pytest.approx(single.summary["max_abs_theta_over_alpha"], rel=1e-9)


def test_summarize_names_the_outputs_a_run_lacks(fmu, fmu_path):
    from runners.engine.summary import summarize

    scene = runners.as_scene(SINE)
    result = fmu.run(scene.parameters, 1.0, 1e-2, outputs=["block1.theta"])
    with pytest.raises(ValueError, match="summarize needs the outputs of SUMMARY_OUTPUTS; the run lacks"):
        summarize(scene, result, fmu.defaults())


def test_record_takes_a_record_file_as_well_as_a_stored_record(fmu_path, tmp_path):
    """docs/python.md: ``record=`` is a stored record (name or id) or a record file; the file (str
    or Path) runs as the same record imported and named."""
    t = np.arange(0, 3.0001, 0.005)
    at2 = tmp_path / "burst.AT2"
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic burst\nACCELERATION TIME SERIES IN UNITS OF G\n"
                   f"NPTS= {t.size}, DT= 0.0050 SEC\n"
                   + "\n".join(f"{v:.10E}" for v in 0.3 * np.sin(2 * math.pi * 2 * t) * (t < 1.5)) + "\n")
    db = f"sqlite:///{tmp_path / 'api.db'}"
    by_str = runners.simulate(SINE, record=str(at2), pga=0.5, fmu=fmu_path)
    by_path = runners.simulate(SINE, record=at2, pga=0.5, fmu=fmu_path, store=True, db=db)
    assert runners.import_records(at2, db=db) == 0  # the stored run stored the file's record
    by_name = runners.simulate(SINE, record="burst", pga=0.5, fmu=fmu_path, db=db)
    assert by_str.summary["record"]["pga_g"] == pytest.approx(0.5, rel=1e-12) and by_str.summary["impacts"] > 0
    for other in (by_path, by_name):
        for key in ("impacts", "overturned", "max_abs_theta_rad", "stop_time_s"):
            assert other.summary[key] == by_str.summary[key], key
    with pytest.raises(ValueError, match="no record '.*nothing.AT2' in the database and no such record file"):
        runners.simulate(SINE, record=str(tmp_path / "nothing.AT2"), pga=0.5, fmu=fmu_path, db=db)
    from db.schema import Run
    from db.session import open_database

    with open_database(db)() as session:
        excitation = session.get(Run, by_path.run_id).excitation
        assert excitation.record.name == "burst" and excitation.scale == by_str.summary["record"]["scale"]
