"""Shared fixtures: the real FMU, built from model/c (or ROCKING_FMU)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fmu_build import build_fmu
from runners.fmu import RockingFMU


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    env = os.environ.get("ROCKING_FMU")
    return Path(env).resolve() if env else build_fmu()


@pytest.fixture(scope="session")
def fmu(fmu_path: Path):
    with RockingFMU(fmu_path) as f:
        yield f
