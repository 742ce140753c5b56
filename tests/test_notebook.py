"""examples/notebook.ipynb executed as `jupyter nbconvert --execute` does (nbclient, a real
IPython kernel), from the notebook's own folder as Jupyter starts it. What its cells compute is
checked cell by cell in tests/test_python_api.py; this checks that the notebook runs as the
README and docs/python.md say, with what the `notebook` extra (and the `test` extra) installs."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import runners
from tests.conftest import PATIENCE

ROOT = Path(__file__).resolve().parents[1]


def test_the_notebook_executes_in_a_kernel_from_its_own_folder(tmp_path, monkeypatch, fmu_path):
    nbformat = pytest.importorskip("nbformat", reason="pip install -e '.[notebook]' (or '.[test]')")
    nbclient = pytest.importorskip("nbclient", reason="pip install -e '.[notebook]' (or '.[test]')")
    pytest.importorskip("ipykernel", reason="pip install -e '.[notebook]' (or '.[test]')")
    shutil.copytree(ROOT / "examples", tmp_path / "examples")  # a scratch copy: it writes notebook.db
    monkeypatch.setenv("ROCKING_FMU", str(fmu_path))  # the kernel inherits this process's environment
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    nb = nbformat.read(tmp_path / "examples" / "notebook.ipynb", as_version=4)
    client = nbclient.NotebookClient(nb, timeout=PATIENCE, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path / "examples")}})
    client.execute()  # raises CellExecutionError, naming the cell, if one fails
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(o.output_type != "error" for c in code for o in c.outputs)
    figures = [c for c in code if any("image/png" in o.get("data", {}) for o in c.outputs)]
    assert len(figures) == 3  # the run, the overturning map, the fragility curve
    sweeps = runners.open_db(f"sqlite:///{tmp_path / 'notebook.db'}").sweeps()  # in the root, where it moved
    assert len(sweeps) == 2 and (sweeps["done"] == sweeps["total"]).all()
