"""fmu_build: builds from source, only when the sources changed."""

from __future__ import annotations

import zipfile

from fmu_build.build import build_fmu


def test_rebuild_only_when_sources_change(tmp_path):
    out = tmp_path / "RockingBlock.fmu"
    build_fmu(out)
    stamp = out.stat().st_mtime_ns
    build_fmu(out)  # unchanged sources: nothing to do
    assert out.stat().st_mtime_ns == stamp
    build_fmu(out, force=True)
    assert out.stat().st_mtime_ns != stamp


def test_fmu_contents(tmp_path):
    out = build_fmu(tmp_path / "RockingBlock.fmu")
    names = set(zipfile.ZipFile(out).namelist())
    assert {"modelDescription.xml", "binaries/linux64/RockingBlock.so", "sources/fmi2.c", "sources/model.c",
            "sources/solver.c", "sources/integrator.c", "sources/config.h", "sources/variables.def"} <= names
