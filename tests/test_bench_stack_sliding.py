"""runners bench's two-block rocking–sliding rows (issue 27): the harness's two-block scenes again
with contact.model = 1 (mu 5 at both contacts: nothing slides) and a statue on a plinth that slides,
with their cost against the rigid stack's."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from runners.analysis import bench
from runners.engine.fmu import FMUError, RockingFMU


def has_sliding_stack(fmu_path: Path) -> bool:
    with RockingFMU(fmu_path) as fmu:
        try:
            fmu.validate({**bench.STACK_FREE, "contact.model": 1})
        except FMUError:
            return False
    return True


@pytest.fixture
def native(fmu_path, tmp_path):
    return bench._compile_native(fmu_path, tmp_path)


def test_the_custom_form_runs_the_harness_rows_two_block_scenes(fmu_path, native):
    """The parameters the new rows start from are the harness's own two-block rows: the custom
    form of each gives the impacts the harness's row gives."""
    rows = {r[0]: r for r in bench._native_rows(*native, 1)}
    timer = bench._Custom(native, fmu_path)
    for rigid, params, stop, _ in bench.STACK_SLIDING_CASES:
        if rigid in rows:
            us, impacts = timer.time(params, stop, 1)
            assert us > 0 and impacts == int(rows[rigid][2]) > 0, rigid


def test_the_rocking_sliding_stack_rows_sit_next_to_the_two_block_rows(fmu_path, native):
    if not has_sliding_stack(fmu_path):
        assert bench._stack_sliding_rows(fmu_path, native, 1) == []  # a build before it: no rows, no error
        pytest.skip("the FMU has no rocking-sliding stack yet")
    stack = bench._stack_sliding_rows(fmu_path, native, 1)
    rows = {r[0]: r for r in bench._native_rows(*native, 1)}
    names = [r[0] for r, _ in stack]
    assert len(names) == len(bench.STACK_SLIDING_CASES) + 1  # and the statue's rigid twin
    for rigid, params, stop, what in bench.STACK_NOTHING_SLIDES:  # mu 5: nothing slides, the rigid stack's impacts
        row = next(r for r, _ in stack if r[0] == bench._stack_sliding_name(rigid, what))
        assert row[2] == rows[rigid][2] and row[3] == rows[rigid][3], row
    with RockingFMU(fmu_path) as fmu:  # the plinth row: block 1 really slides on the floor
        p = next(run for r, run in stack if "the plinth slides" in r[0])[0]
        r = fmu.run(p, 5.0, 5.0, outputs=["block1.maxAbsSlip"], events=False)
        assert r.outputs["block1.maxAbsSlip"][-1] > 1e-3
    lines = bench._stack_sliding_ratios(list(rows.values()), stack, bench._Custom(native, fmu_path))
    ratios = [line for line in lines if line.startswith("- rocking-sliding stack")]
    assert len(ratios) == len(bench.STACK_SLIDING_CASES)
    assert sum("where nothing slides" in line for line in ratios) == len(bench.STACK_NOTHING_SLIDES)


@pytest.mark.slow  # the whole native benchmark, and valgrind's counts where installed
def test_runners_bench_reports_the_stacks_ratio_in_time_and_instructions(fmu_path):
    if not has_sliding_stack(fmu_path):
        pytest.skip("the FMU has no rocking-sliding stack yet")
    text = bench.run_native_bench(fmu_path, repeats=1)
    table = [line for line in text.splitlines() if line.startswith("| two blocks")]
    first = next(i for i, line in enumerate(table) if "rocking-sliding" in line)
    assert all("rocking-sliding" not in line for line in table[:first])  # after the rigid two-block rows
    pattern = r"^- rocking-sliding stack where nothing slides, .*: (\d+\.\d+)x the rigid stack's time"
    if shutil.which("valgrind"):
        pattern += r", (\d+\.\d+)x its instructions$"
    found = [re.match(pattern, line) for line in text.splitlines()]
    assert sum(m is not None for m in found) == len(bench.STACK_NOTHING_SLIDES)
